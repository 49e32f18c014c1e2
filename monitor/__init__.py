"""engine-monitor: condition monitoring of large reciprocating engines.

The library compares the orders measured on an engine (crank-angle domain
spectra of bearing accelerations and crank speed) with the orders the
engine's physics predicts. The few entry points a user needs are names of
this package::

    import monitor

    engine = monitor.load_engine("man-b-w-7k98mc")  # a bundled engine, or a TOML file
    with monitor.open_recording("recordings/samples/7k98mc-baseline.h5") as recording:
        baseline = monitor.calibrate(recording, engine)
    with monitor.open_recording("recordings/samples/7k98mc-misfire-cyl4.h5") as recording:
        diagnosis = monitor.diagnose(recording, engine, baseline=baseline)

- reading: :func:`open_recording`, :func:`read_recording` (:mod:`monitor.io`);
- the engine and its physics: :func:`load_engine`, :class:`EngineModel`, :func:`predict_orders`
  (:mod:`monitor.model`), the predicted order table of an operating point;
- measuring: :func:`spectra` (:mod:`monitor.signal`), angle-domain order spectra of a recording;
- diagnosing: :func:`calibrate` and :func:`diagnose` (:mod:`monitor.diagnosis`);
- simulating: :func:`load_scene` and :func:`simulate` (:mod:`monitor.scene`).

Each is imported on first use (PEP 562), so ``import monitor`` loads none of
them: the command line's quick commands stay quick. The packages and their
layering are told in docs/architecture.md.
"""

from __future__ import annotations

import importlib
from importlib.metadata import PackageNotFoundError, version
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the same names as _ENTRY_POINTS, for the type checkers
    from monitor.diagnosis import calibrate
    from monitor.diagnosis.diagnose import diagnose
    from monitor.io import open_recording, read_recording
    from monitor.model.crankshaft import EngineModel
    from monitor.model.engine import load_engine
    from monitor.model.predicted import predict_orders
    from monitor.scene import load_scene, simulate
    from monitor.signal.measure import spectra

try:
    __version__ = version("engine-monitor")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

# each entry point, and the module or package it is imported from
_ENTRY_POINTS = {
    "open_recording": "monitor.io",
    "read_recording": "monitor.io",
    "load_engine": "monitor.model.engine",
    "EngineModel": "monitor.model.crankshaft",
    "predict_orders": "monitor.model.predicted",
    "spectra": "monitor.signal.measure",
    "calibrate": "monitor.diagnosis",
    "diagnose": "monitor.diagnosis.diagnose",
    "load_scene": "monitor.scene",
    "simulate": "monitor.scene",
}

__all__ = [
    "EngineModel",
    "__version__",
    "calibrate",
    "diagnose",
    "load_engine",
    "load_scene",
    "open_recording",
    "predict_orders",
    "read_recording",
    "simulate",
    "spectra",
]


def __getattr__(name: str) -> Any:
    """An entry point, imported from its module on first use and kept here from then on."""
    try:
        module = _ENTRY_POINTS[name]
    except KeyError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """The public names, loaded or not (what tab completion offers)."""
    return sorted(__all__)
