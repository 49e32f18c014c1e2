"""engine-monitor: condition monitoring of large reciprocating engines.

The library compares the orders measured on an engine (crank-angle domain
spectra of bearing accelerations and crank speed) with the orders the
engine's physics predicts. Physics lives in pure-function modules:
:mod:`monitor.model.kinematics`, :mod:`monitor.model.gas`, :mod:`monitor.model.forces`,
:mod:`monitor.model.crankshaft`, :mod:`monitor.fourier`; the predicted order table
of an operating point is :func:`monitor.model.predicted.predict_orders`.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("engine-monitor")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
