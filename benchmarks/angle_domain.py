"""Accuracy against time of angle-domain resampling (a section of docs/accuracy-vs-time.md).

Called by ``benchmarks.accuracy_vs_time``; every number comes from this run.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from scipy.integrate import cumulative_trapezoid

from monitor.signal.angle_domain import order_spectrum, to_angle_domain
from monitor.signal.anglemap import AngleMap
from monitor.signal.pulses import SignalError

FS = 25600.0
SECONDS = 60.0
ORDERS = {1: (2.0, 0.3), 2: (1.0, -1.0), 4: (0.25, 2.0), 6: (0.1, 0.4), 8: (0.05, -0.9), 12: (0.02, 0.7)}


def _case() -> tuple[np.ndarray, AngleMap]:
    t = np.arange(int(SECONDS * FS)) / FS
    w = (
        600
        * math.pi
        / 30
        * (1 + 0.2 * (0.7 * np.sin(2 * np.pi * 0.37 * t) + 0.3 * np.sin(2 * np.pi * 1.13 * t)))
    )
    alpha = cumulative_trapezoid(w, t, initial=0.0)
    x = sum(a * np.cos(k * alpha + ph) for k, (a, ph) in ORDERS.items())
    pitch = math.pi / 30
    teeth = np.arange(1, math.floor(alpha[-1] / pitch)) * pitch
    teeth = teeth[np.mod(np.round(teeth / pitch), 60) < 58]  # a 60-2 wheel
    return np.asarray(x), AngleMap(np.interp(teeth, alpha, t), teeth)


def sections() -> list[str]:
    """The angle-domain section of docs/accuracy-vs-time.md."""
    x, angle_map = _case()
    kernels: list[tuple[str, dict[str, Any]]] = [
        ("band-limited, passband to order 12", {"max_order": 12.0}),
        ("band-limited, passband 0.8 of Nyquist", {}),
        *((f"B-spline {order}", {"interpolation_order": order}) for order in (1, 3, 5)),
    ]
    for _, options in kernels:  # compile the numba kernels first (cached on disk after the first run)
        to_angle_domain(x[: int(2 * FS)], FS, angle_map, samples_per_cycle=64, **options)
    rows = [
        "| kernel | samples per revolution | largest amplitude error | largest phase error [deg] | "
        f"time for {SECONDS:g} s at {FS / 1000:g} kHz | real time over computing time |",
        "|---|---|---|---|---|---|",
    ]
    for label, options in kernels:
        for samples in (32, 64, 128, 256, 512):
            start = time.perf_counter()
            try:
                resampled = to_angle_domain(x, FS, angle_map, samples_per_cycle=samples, **options)
            except SignalError:  # order 12 at the fastest speed above this grid's Nyquist order
                rows.append(f"| {label} | {samples} | refused: the grid cannot hold order 12 | | | |")
                continue
            spectrum = order_spectrum(resampled)
            elapsed = time.perf_counter() - start
            amp = max(abs(spectrum.magnitude[k] / a - 1) for k, (a, _) in ORDERS.items())
            phase = max(
                abs(math.degrees(math.remainder(spectrum.phase[k] - ph, 2 * math.pi)))
                for k, (_, ph) in ORDERS.items()
            )
            rows.append(
                f"| {label} | {samples} | {amp:.2e} | {phase:.2e} | {elapsed * 1e3:.0f} ms | "
                f"{SECONDS / elapsed:.0f} |"
            )
    return [
        "## Angle-domain resampling: kernel and grid against error",
        "",
        f"Orders {sorted(ORDERS)} with known amplitudes and phases, speed varying +-20 % around 600 rpm, "
        f"{SECONDS:g} s at {FS / 1000:g} kHz; angle map from the edges of a 60-2 tooth wheel (monotone "
        "interpolation between teeth). Two kernels (see `monitor/signal/angle_domain.py`): the fused "
        "band-limited one (the default: a Kaiser windowed sinc evaluated at each grid time, ripple and "
        "stopband 1e-5), with its passband edge at the highest order wanted (12 here, at the fastest "
        "speed; what the pipeline passes) or at 0.8 of the angle-domain Nyquist order at the lowest "
        "speed; and an FFT-applied FIR of the same ripple, the filtered signal kept at ten times its "
        "passband edge, then B-splines of order 1, 3 or 5. Errors relative to the true amplitudes "
        "(largest over the orders) and in phase. At 32 samples per revolution order 12 lies above the "
        "passband at the fastest speed: filtered out by the kernels given 0.8 of Nyquist (the pipeline "
        "refuses such a grid for these orders), refused by the one given the order.",
        "",
        *rows,
        "",
    ]
