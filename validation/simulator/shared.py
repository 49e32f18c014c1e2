"""What every part of the simulator shares: the array type, the ambient pressure, the random streams
and the error a case that cannot be simulated raises."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

#: Ambient (crankcase) pressure [Pa].
AMBIENT_PRESSURE = 1.013e5

# random streams (second word of the seed sequence)
ENGINE_STREAM, INSTALLATION_STREAM, DESCRIPTION_STREAM, OPERATION_STREAM, NOISE_STREAM, POINT_STREAM = range(
    6
)
TWIN_WORD = 1  # third word of a healthy twin's noise stream


class SimulationError(RuntimeError):
    """The simulation cannot produce the case asked for (e.g. the engine stalls); the message says why."""
