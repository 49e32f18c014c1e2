"""The field types of an engine description: a unit in the field's name, a plausible range in its check.

A value outside the range is refused with the range and the unit, and a hint where the commonest
slip is a unit (a bore in millimetres, a pressure in pascals): ``between(0.01, 1.5, "m", "was it
given in mm?")``. The types below (:data:`Length`, :data:`Mass`, ...) are those checks on a float,
as the description's tables use them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Annotated

from pydantic import AfterValidator

__all__ = [
    "AngleDeg",
    "Inertia",
    "Length",
    "Mass",
    "PressureBar",
    "Unbalance",
    "between",
    "non_negative",
    "positive",
]


def between(low: float, high: float, unit: str, hint: str = "") -> Callable[[float], float]:
    """Validator: finite and within a plausible range; the message states the range and unit.

    Parameters
    ----------
    low, high : float
        The range [the field's unit, ``unit``].
    unit : str
    hint : str, optional
        Added to the message (the likely slip).

    Returns
    -------
    callable
        The check, for :class:`pydantic.AfterValidator`.
    """

    def check(value: float) -> float:
        if not math.isfinite(value) or not low <= value <= high:
            extra = f"; {hint}" if hint else ""
            raise ValueError(f"expected {low:g} <= value <= {high:g} {unit}{extra}")
        return value

    return check


def positive(unit: str) -> Callable[[float], float]:
    """Validator: positive and finite.

    Parameters
    ----------
    unit : str

    Returns
    -------
    callable
    """

    def check(value: float) -> float:
        if not math.isfinite(value) or value <= 0:
            raise ValueError(f"expected a positive, finite value [{unit}]")
        return value

    return check


def non_negative(unit: str) -> Callable[[float], float]:
    """Validator: zero or positive, and finite.

    Parameters
    ----------
    unit : str

    Returns
    -------
    callable
    """

    def check(value: float) -> float:
        if not math.isfinite(value) or value < 0:
            raise ValueError(f"expected a non-negative, finite value [{unit}]")
        return value

    return check


Length = Annotated[float, AfterValidator(between(0.005, 5.0, "m", "was it given in mm?"))]
Mass = Annotated[float, AfterValidator(positive("kg"))]
Unbalance = Annotated[float, AfterValidator(non_negative("kg m"))]
Inertia = Annotated[float, AfterValidator(positive("kg m^2"))]
PressureBar = Annotated[float, AfterValidator(between(0.05, 400.0, "bar", "was it given in Pa?"))]
AngleDeg = Annotated[float, AfterValidator(between(-720.0, 720.0, "deg"))]
