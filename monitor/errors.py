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
