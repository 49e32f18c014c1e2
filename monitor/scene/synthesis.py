"""Orders synthesised into a signal: ``Re sum_k C_k exp(i k theta)``, directly or by a table.

Every force, torque and response of a scene is a sum of orders of the crank (cycle) angle; channels
are synthesised sample by sample with the crank angle ``theta(t)`` of the recording.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from monitor.types import ComplexArray, FloatArray

__all__ = ["MAX_ORDER", "CycleTable", "synthesise"]

MAX_ORDER = 36.0  # highest order synthesised [-]


def synthesise(coefficients: ComplexArray, orders: FloatArray, angle: FloatArray) -> FloatArray:
    """``Re sum_k c_k exp(i k angle)`` for coefficients per sample (n, n_orders) or shared (n_orders,).

    Parameters
    ----------
    coefficients : ndarray of complex
        Complex peak amplitudes ``c_k`` [the quantity's unit], shape (n, n_orders) or (n_orders,).
    orders : ndarray
        The orders ``k`` of the crank angle, shape (n_orders,) [-].
    angle : ndarray
        Crank angles, shape (n,) [rad].

    Returns
    -------
    ndarray
        The sum at each angle, shape (n,) [the quantity's unit].
    """
    phasor = np.exp(1j * np.multiply.outer(angle, orders))
    return np.asarray(np.real((phasor * coefficients).sum(axis=-1)))


@dataclass(frozen=True)
class CycleTable:
    """``Re sum_k C_k(w) exp(i k theta)`` tabulated over a cycle (2^16 points per revolution) at a few
    mean speeds.

    Evaluated per sample by linear interpolation in angle (error below 1e-5 of the sum of the order
    magnitudes, for orders up to 36; tested against the direct sum) and in speed between the tabulated
    speeds: a cost per sample that does not grow with the number of orders.
    """

    values: FloatArray  # (n_speeds, points + 1), the first point repeated at the end
    speeds: FloatArray
    cycle: float

    @classmethod
    def of(
        cls, coefficients: ComplexArray, orders: FloatArray, revolutions: int, speeds: FloatArray
    ) -> CycleTable:
        points = (1 << 16) * revolutions
        harmonics = np.rint(orders * revolutions).astype(np.int64)  # per cycle
        spectrum = np.zeros((speeds.size, points // 2 + 1), dtype=np.complex128)
        spectrum[:, harmonics] = coefficients * (points / 2)
        spectrum[:, 0] = (
            coefficients[:, harmonics == 0].real.sum(axis=1) * points if (harmonics == 0).any() else 0
        )
        table = np.fft.irfft(spectrum, n=points, axis=-1)
        return cls(np.concatenate([table, table[:, :1]], axis=1), speeds, 2 * math.pi * revolutions)

    def at(self, angle: FloatArray, speed: FloatArray | None = None) -> FloatArray:
        """The tabulated sum at crank angles ``angle`` [rad] and mean speeds ``speed`` [rad/s].

        ``speed`` is needed only when more than one speed is tabulated.
        """
        points = self.values.shape[1] - 1
        where = np.mod(angle, self.cycle) * (points / self.cycle)
        i = np.minimum(where.astype(np.int64), points - 1)
        frac = where - i
        if self.speeds.size == 1:
            row = self.values[0]
            return np.asarray(row[i] * (1 - frac) + row[i + 1] * frac)
        if speed is None:
            raise ValueError("a table over several mean speeds needs the speed of every sample")
        position = np.clip((speed - self.speeds[0]) / (self.speeds[-1] - self.speeds[0]), 0, 1) * (
            self.speeds.size - 1
        )
        j = np.minimum(position.astype(np.int64), self.speeds.size - 2)
        g = position - j
        low = self.values[j, i] * (1 - frac) + self.values[j, i + 1] * frac
        high = self.values[j + 1, i] * (1 - frac) + self.values[j + 1, i + 1] * frac
        return np.asarray(low * (1 - g) + high * g)
