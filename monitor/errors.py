"""Errors and warnings of the product.

One small hierarchy: every error the product raises on purpose is a
:class:`MonitorError`; the ones caused by a bad value also subclass
:class:`ValueError` so that callers who only know the standard library can
still catch them.  Messages name the parameter, the value and what was
expected.
"""

from __future__ import annotations


class MonitorError(Exception):
    """Base of every error the product raises on purpose."""


class EngineDescriptionError(MonitorError, ValueError):
    """An engine description is missing a field, has an unknown field, or breaks a rule."""


class ModelError(MonitorError, ValueError):
    """A model was asked for something outside its domain (e.g. a rod ratio >= 1)."""


class DiagnosisError(MonitorError, ValueError):
    """A recording that cannot be diagnosed as asked: another engine than its baseline, a channel
    layout the baseline lacks, no usable angle reference for what is asked."""


class DataQualityWarning(UserWarning):
    """Suspect but usable data; the message says how to fix it."""


class SignalError(MonitorError, ValueError):
    """A signal cannot be decoded as asked (no pulses, no gap, inconsistent pulse train)."""


class PlotError(MonitorError, ValueError):
    """A figure's path that cannot be written: an unknown format, a folder that does not exist."""


class SceneError(ModelError):
    """A scene that cannot be simulated as written (names what is wrong and what is expected)."""


class NamingError(MonitorError, ValueError):
    """A name that is empty, too long, not printable or padded with white space."""


class FormatError(MonitorError, ValueError):
    """A recording file, or a channel in it, breaks the format; the message names which and how."""


class StoreError(MonitorError):
    """The store cannot do what was asked (unreachable database, unknown fleet, ...)."""


class OutputFolderError(MonitorError, FileNotFoundError):
    """An output file's folder does not exist: the product makes no folder it was not asked for."""
