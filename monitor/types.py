"""Array type aliases shared by the product's modules (for annotations only)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["ComplexArray", "FloatArray"]

FloatArray = npt.NDArray[np.float64]
"""Real values, float64."""

ComplexArray = npt.NDArray[np.complex128]
"""Complex amplitudes, complex128."""
