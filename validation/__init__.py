"""Validation of the product against an engine simulator of its own (:mod:`validation.simulator`).

Nothing here is part of the product: the package imports from ``monitor`` only the recording
containers, the HDF5 writer and the engine-description parser, never its physics, scene
simulator, pipeline or diagnosis, so that a diagnosis checked on these cases is checked against
equations written independently of the ones it was built from.
"""
