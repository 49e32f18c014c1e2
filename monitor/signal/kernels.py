"""The kernels that evaluate a time-domain channel at the crank-angle grid's times.

The angle-domain Nyquist order ``N / (2 R)`` (``N`` samples per cycle, ``R``
revolutions per cycle) is reached in time at the lowest speed of the
recording: that is the stopband edge of the anti-alias low-pass; its
passband edge is the highest order wanted at the fastest speed (or
``cutoff`` of the stopband edge).

The default kernel does the anti-alias filtering and the interpolation in
one step, computing only the output samples: each grid time's value is the
channel convolved with a continuous windowed-sinc low-pass (Kaiser window,
passband ripple and stopband 1e-5) evaluated at that time,

    y(t) = sum_n x[n] h(t fs - n),

so a sample is as many multiply-adds as the kernel is long (the filter's
transition band sets its length), whatever the decimation.  ``h`` is
tabulated at ``_PHASES`` (1024) fractions of a sample and each time rounded
to the nearest; the loop is compiled with numba and runs in the samples'
stored precision (float32 recordings in float32).  The filter is zero-phase:
the orders' phases are untouched.

The second kernel, for filters too long for the first (more than
``_FUSED_TAPS_PER_INPUT`` taps per input sample between grid points: a narrow
transition band at a high sampling rate), for comparison (``interpolation_order``
1, 3 or 5), and without anti-aliasing: a linear-phase FIR low-pass applied through FFTs,
decimation to at least ``OVERSAMPLING`` (10) times the passband edge, then
B-spline interpolation of that order (prefilter and evaluation compiled with
numba, the splines of ``scipy.ndimage.map_coordinates``); at the passband
edge cubic splines are within 4e-4 of a sine's amplitude, at a tenth of it
within 1e-7.  docs/accuracy-vs-time.md compares the two.

:func:`choose_resampler` picks one; :mod:`monitor.signal.resample` runs it block by block.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property, lru_cache

import numba
import numpy as np
import scipy.fft as sp_fft  # scipy's FFTs transform float32 in float32

from monitor.types import FloatArray

__all__ = ["OVERSAMPLING", "CentredFir", "Resampler", "choose_resampler"]


# decimated rate over the passband edge: cubic B-splines then interpolate a sine at the edge to 4e-4
OVERSAMPLING = 10.0
_RIPPLE_DB = 100.0  # anti-alias FIR: passband ripple and stopband attenuation 1e-5
_SPLINE_MARGIN = 32  # decimated samples beyond the grid: the B-spline prefilter's edge effect < 1e-12


# the fused kernel's windowed sinc, tabulated at this many fractions of a sample; a position is rounded to
# the nearest, at most 1 / 2048 of a sample away: at the passband edge f_p that moves a sample's phase by at
# most pi f_p / (fs _PHASES), 2e-4 rad when f_p is fs / 15, and averages out over a recording's cycles
_PHASES = 1024
# its design attenuation: 10 dB beyond the 1e-5 of ripple and stopband wanted, because sampled at a sample's
# fraction the continuous kernel's images at multiples of the sampling rate add up in its passband (measured:
# 2.5e-5 at a 100 dB design, below 1e-5 at 110 dB; tests/signal/test_signal.py)
_FUSED_DESIGN_DB = 110.0
# a kernel longer than this many taps per input sample between grid points costs about as much as the FFT
# filter and splines (whose cost per input sample hardly depends on the filter's length; the forced rows of
# the angle-domain section of docs/accuracy-vs-time.md): a narrow transition band at a high sampling rate,
# or a grid much finer than the samples, takes that route instead
_FUSED_TAPS_PER_INPUT = 48.0


@dataclass(frozen=True)
class _BandLimited:
    """A continuous windowed-sinc low-pass, tabulated for evaluation at fractional sample positions.

    ``table[p, j]`` is ``h(p / phases + half - 1 - j)``, ``h`` in input samples, ``half`` the kernel's
    half length: the value at position ``u = n0 + p / phases`` is
    ``sum_j x[n0 - half + 1 + j] table[p, j]``.
    """

    table: FloatArray
    passband_hz: float
    stopband_hz: float

    @property
    def half(self) -> int:
        """Input samples the kernel reaches on each side of a position."""
        return int(self.table.shape[1] // 2)


@lru_cache(maxsize=16)  # the channels of a recording share one kernel
def _band_limited(passband_hz: float, stopband_hz: float, sample_rate: float) -> _BandLimited:
    """The fused kernel passing up to ``passband_hz`` and stopping from ``stopband_hz`` (at most Nyquist).

    Kaiser's design rules (Oppenheim & Schafer, Discrete-Time Signal Processing, 3rd ed., eqs. 7.62 and
    7.63): for an attenuation of ``A`` dB (here :data:`_FUSED_DESIGN_DB`) the window's shape is
    ``beta = 0.1102 (A - 8.7)`` and its length ``(A - 8) / (2.285 dw)`` samples, ``dw`` the transition
    width in radians per sample.  Each row of the
    table is scaled to a sum of one: a constant passes exactly at every fractional position.
    """
    beta = 0.1102 * (_FUSED_DESIGN_DB - 8.7)
    half = _fused_taps(passband_hz, stopband_hz, sample_rate) // 2
    cutoff = 0.5 * (passband_hz + stopband_hz) / sample_rate  # [cycles per sample]
    offsets = np.arange(_PHASES + 1)[:, None] / _PHASES + (half - 1) - np.arange(2 * half)[None, :]
    window = np.i0(beta * np.sqrt(np.clip(1.0 - (offsets / half) ** 2, 0.0, None))) / np.i0(beta)
    table = 2 * cutoff * np.sinc(2 * cutoff * offsets) * window
    table /= table.sum(axis=1, keepdims=True)
    return _BandLimited(np.ascontiguousarray(table), passband_hz, stopband_hz)


def _fused_taps(passband_hz: float, stopband_hz: float, sample_rate: float) -> int:
    """The fused kernel's length for this design [samples]."""
    width = 2 * math.pi * (stopband_hz - passband_hz) / sample_rate
    return 2 * max(2, math.ceil((_FUSED_DESIGN_DB - 8.0) / (2.285 * width) / 2))


@numba.njit(cache=True, nogil=True, fastmath=True)
def _resample(x: FloatArray, positions: FloatArray, table: FloatArray, out: FloatArray) -> None:
    """The band-limited value of ``x`` at each of ``positions`` (in samples of ``x``), into ``out``.

    Every position needs ``half`` samples of ``x`` before it and ``half`` after (the caller's margins).
    The sum runs in the precision of ``x`` and ``table`` (the same dtype); ``out`` may be wider.
    """  # pragma: no cover - compiled
    phases = table.shape[0] - 1
    taps = table.shape[1]
    half = taps // 2
    for k in range(positions.size):
        u = positions[k]
        n0 = math.floor(u)
        p = int((u - n0) * phases + 0.5)  # the nearest tabulated fraction (the last row is a whole sample)
        base = int(n0) - half + 1
        window = x[base : base + taps]  # a slice: indices known to be in range, so the loop vectorises
        weights = table[p]
        total = weights[0] - weights[0]  # zero in the table's dtype (weights[0] * 0 would be float64)
        for j in range(taps):
            total += window[j] * weights[j]
        out[k] = total


@dataclass(frozen=True)
class CentredFir:
    """An FIR (Kaiser window, linear phase, applied centred: zero phase) and the decimation after it.

    The anti-alias low-pass of the B-spline route, or the high-frequency profile's band-pass
    (:func:`monitor.signal.impact.impact_band`, not decimated).

    Applied by overlap-save over short segments, transformed together (many
    short real FFTs cost a third of one long one per sample).
    """

    taps: FloatArray
    decimation: int
    passband_hz: float

    @property
    def lead(self) -> int:
        """Input samples lost at each end of a segment: half the kernel, rounded up to the decimation."""
        return -(-(self.taps.size // 2) // self.decimation) * self.decimation

    @cached_property
    def segment(self) -> int:
        """Segment length: the decimation times a power of two, at least 16 leads."""
        return self.decimation * 2 ** math.ceil(math.log2(max(4096, 16 * self.lead) / self.decimation))

    @cached_property
    def response(self) -> FloatArray:
        """Real frequency response of the centred kernel on the segment's FFT grid (the bins kept)."""
        half = self.taps.size // 2
        kernel = np.zeros(self.segment)
        kernel[: half + 1] = self.taps[half:]
        kernel[self.segment - half :] = self.taps[:half]
        keep = self.segment // self.decimation // 2 + 1
        return np.ascontiguousarray(np.fft.rfft(kernel)[:keep].real)

    def apply(self, x: FloatArray) -> FloatArray:
        """Filtered samples at input samples ``lead``, ``lead + decimation``, ... of ``x``.

        Valid up to ``lead`` samples before the end of ``x``.
        """
        hop = self.segment - 2 * self.lead
        count = max(1, -(-(x.size - 2 * self.lead) // hop))
        padded = np.zeros(count * hop + 2 * self.lead, dtype=x.dtype)
        padded[: x.size] = x
        rows = np.lib.stride_tricks.sliding_window_view(padded, self.segment)[::hop]
        spectra = sp_fft.rfft(rows, axis=-1)
        kept = spectra[:, : self.response.size] * self.response.astype(spectra.real.dtype)
        filtered = sp_fft.irfft(kept, n=self.segment // self.decimation, axis=-1)
        lead = self.lead // self.decimation
        return np.asarray(filtered[:, lead : lead + hop // self.decimation].reshape(-1) / self.decimation)


def _anti_alias(passband_hz: float, stopband_hz: float, sample_rate: float) -> CentredFir | None:
    if stopband_hz >= 0.5 * sample_rate:
        return None
    # here, not at the top: scipy.signal takes most of a second to import, and the diagnosis and the
    # service import this module's users without ever designing a filter
    from scipy.signal import firwin, kaiserord

    numtaps, beta = kaiserord(_RIPPLE_DB, (stopband_hz - passband_hz) / (0.5 * sample_rate))
    taps = firwin(numtaps | 1, 0.5 * (passband_hz + stopband_hz), window=("kaiser", beta), fs=sample_rate)
    decimation = max(1, int(sample_rate // (OVERSAMPLING * passband_hz)))
    return CentredFir(np.asarray(taps), decimation, passband_hz)


# poles of the B-spline interpolation prefilters (Unser, Aldroubi & Eden 1991; Thevenaz et al. 2000)
_POLES = {1: (), 3: (math.sqrt(3.0) - 2.0,), 5: (-0.430575347099973, -0.0430962882032647)}


def _spline_coefficients(y: FloatArray, order: int) -> FloatArray:
    """B-spline coefficients that interpolate ``y`` (mirror boundaries; exact away from the ends)."""
    c = np.array(y, dtype=np.float64)
    if order > 1:
        _prefilter(c, np.array(_POLES[order]))
    return c


@numba.njit(cache=True, nogil=True)
def _prefilter(c: FloatArray, poles: FloatArray) -> None:  # pragma: no cover - compiled
    """In place: the causal and anticausal recursions of each pole, with the overall gain."""
    n = c.size
    gain = 1.0
    for z in poles:
        gain *= (1.0 - z) * (1.0 - 1.0 / z)
    for k in range(n):
        c[k] *= gain
    for z in poles:
        horizon = min(n, math.ceil(math.log(1e-16) / math.log(abs(z))))
        total, power = c[0], z
        for k in range(1, horizon):  # causal start: the mirrored signal's sum, truncated below 1e-16
            total += power * c[k]
            power *= z
        c[0] = total
        for k in range(1, n):
            c[k] += z * c[k - 1]
        c[n - 1] = z / (z * z - 1.0) * (c[n - 1] + z * c[n - 2])
        for k in range(n - 2, -1, -1):
            c[k] = z * (c[k + 1] - c[k])


@numba.njit(cache=True, nogil=True)
def _interpolate(c: FloatArray, q: FloatArray, order: int, out: FloatArray) -> None:  # pragma: no cover
    """The B-spline of ``order`` with coefficients ``c`` at positions ``q`` (in samples), into ``out``."""
    n = c.size
    for p in range(q.size):
        x = q[p]
        i = math.floor(x)
        t = x - i
        if order == 1:
            out[p] = (1.0 - t) * c[min(max(i, 0), n - 1)] + t * c[min(max(i + 1, 0), n - 1)]
        elif order == 3:
            s = 1.0 - t
            w0 = s * s * s / 6.0
            w3 = t * t * t / 6.0
            w1 = (4.0 - 6.0 * t * t + 3.0 * t * t * t) / 6.0
            w2 = 1.0 - w0 - w1 - w3
            out[p] = (
                w0 * c[min(max(i - 1, 0), n - 1)]
                + w1 * c[min(max(i, 0), n - 1)]
                + w2 * c[min(max(i + 1, 0), n - 1)]
                + w3 * c[min(max(i + 2, 0), n - 1)]
            )
        else:
            total = 0.0
            for j in range(
                -2, 4
            ):  # quintic B-spline at t - j: 1/120 sum_k (-1)^k C(6, k) (t - j + 3 - k)_+^5
                d = t - j
                beta, sign, binomial = 0.0, 1.0, 1.0
                for k in range(7):
                    u = d + 3.0 - k
                    if u > 0.0:
                        beta += sign * binomial * u**5
                    sign = -sign
                    binomial = binomial * (6 - k) / (k + 1)
                total += beta / 120.0 * c[min(max(i + j, 0), n - 1)]
            out[p] = total


@dataclass
class Resampler:
    """How a channel's samples are evaluated at the grid's times: the fused band-limited kernel, or the
    FFT-applied anti-alias filter (or none) then B-splines of ``order``.

    Attributes
    ----------
    kernel : _BandLimited or None
        The fused kernel, when it is the one used.
    fir : CentredFir or None
        The anti-alias filter before the splines, when there is one.
    order : int
        The B-splines' order (1, 3 or 5) when the fused kernel is not used.
    """

    kernel: _BandLimited | None
    fir: CentredFir | None
    order: int
    _table: FloatArray | None = field(default=None, init=False, repr=False)  # the kernel, samples' dtype

    @property
    def decimation(self) -> int:
        """Input samples per sample the splines interpolate."""
        return self.fir.decimation if self.fir is not None else 1

    @property
    def lead(self) -> int:
        """The input sample of the first filtered sample."""
        return self.fir.lead if self.fir is not None else 0

    @property
    def margin(self) -> int:
        """Input samples needed beyond the first and last grid times of a block."""
        if self.kernel is not None:
            return self.kernel.half + 1
        return self.lead + _SPLINE_MARGIN * self.decimation

    @property
    def cutoff_hz(self) -> float | None:
        """The passband edge of the filter applied [Hz]; None when none was."""
        if self.kernel is not None:
            return self.kernel.passband_hz
        return self.fir.passband_hz if self.fir is not None else None

    @property
    def name(self) -> str:
        """How the samples were found (:attr:`AngleDomainSignal.interpolation`)."""
        return "band-limited" if self.kernel is not None else f"B-spline {self.order}"

    def evaluate(self, x: FloatArray, positions: FloatArray, out: FloatArray) -> None:
        """The values of ``x`` at ``positions`` (in samples of ``x``, :attr:`margin` inside it), into
        ``out``."""
        if self.kernel is not None:
            if self._table is None or self._table.dtype != x.dtype:
                self._table = self.kernel.table.astype(x.dtype)
            _resample(x, positions, self._table, out)
        else:
            y = self.fir.apply(x) if self.fir is not None else x
            _interpolate(
                _spline_coefficients(y, self.order),
                (positions - self.lead) / self.decimation,
                self.order,
                out,
            )


def choose_resampler(
    sample_rate: float,
    passband_hz: float,
    stopband_hz: float,
    *,
    cutoff: float,
    spacing: float,
    anti_alias: bool,
    interpolation_order: int | None,
) -> Resampler:
    """The fused kernel where it is short enough, else the FFT filter and B-splines.

    Parameters
    ----------
    sample_rate : float
        [Hz].
    passband_hz : float
        The highest frequency wanted [Hz].
    stopband_hz : float
        The angle-domain Nyquist frequency at the slowest speed [Hz].
    cutoff : float
        The FFT filter's passband edge as a fraction of ``stopband_hz`` [-]: the splines lose up to 4e-4
        of a sine at the passband's edge, so the wanted orders are kept well inside it.
    spacing : float
        Input samples per grid point at the mean speed [-]: the fused kernel is chosen only where
        its length is at most ``_FUSED_TAPS_PER_INPUT`` (48) taps times this.
    anti_alias : bool
        Filter; without it, B-splines of ``interpolation_order`` (or cubic).
    interpolation_order : {1, 3, 5} or None
        B-splines of this order; None for the fused kernel where it fits.

    Returns
    -------
    Resampler
        The fused band-limited kernel, or the FFT filter (with ``anti_alias``) followed by
        B-splines of ``interpolation_order`` (cubic if None).
    """
    kernel: _BandLimited | None = None
    fir: CentredFir | None = None
    edge = min(stopband_hz, 0.5 * sample_rate)
    if (
        anti_alias
        and interpolation_order is None
        and passband_hz < 0.9 * edge
        and _fused_taps(passband_hz, edge, sample_rate) <= _FUSED_TAPS_PER_INPUT * spacing
    ):
        kernel = _band_limited(passband_hz, edge, sample_rate)
    elif anti_alias:
        fir = _anti_alias(cutoff * stopband_hz, stopband_hz, sample_rate)
    order = interpolation_order if interpolation_order is not None else 3
    return Resampler(kernel, fir, order)
