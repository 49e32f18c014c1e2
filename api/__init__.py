"""The HTTP service (FastAPI): uploads, results, engines; see :mod:`api.app`."""
