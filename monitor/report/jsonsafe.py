"""Values as JSON holds them: the one conversion every document and page of the product goes through."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["json_ready"]


def json_ready(value: Any) -> Any:
    """A value as JSON holds it: numpy arrays to lists, numpy scalars to Python, non-finite floats to None.

    Parameters
    ----------
    value : Any
        Dicts, lists and tuples are converted item by item.

    Returns
    -------
    Any
    """
    if isinstance(value, dict):
        return {str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_ready(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_ready(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
