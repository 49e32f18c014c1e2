"""Accuracy against time of angle-domain resampling (a section of docs/accuracy-vs-time.md).

Called by ``benchmarks.accuracy_vs_time``; every number comes from this run.
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.integrate import cumulative_trapezoid

from monitor.signal.angle_domain import order_spectrum, to_angle_domain
from monitor.signal.anglemap import AngleMap

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
    for order in (1, 3, 5):  # compile the numba kernels first (cached on disk after the first run)
        to_angle_domain(x[: int(2 * FS)], FS, angle_map, samples_per_cycle=64, interpolation_order=order)
    rows = [
        "| interpolation order | samples per revolution | largest amplitude error | "
        "largest phase error [deg] | "
        f"time for {SECONDS:g} s at {FS / 1000:g} kHz | real time over computing time |",
        "|---|---|---|---|---|---|",
    ]
    for order in (1, 3, 5):
        for samples in (32, 64, 128, 256, 512):
            start = time.perf_counter()
            spectrum = order_spectrum(
                to_angle_domain(x, FS, angle_map, samples_per_cycle=samples, interpolation_order=order)
            )  # type: ignore[arg-type]
            elapsed = time.perf_counter() - start
            amp = max(abs(spectrum.magnitude[k] / a - 1) for k, (a, _) in ORDERS.items())
            phase = max(
                abs(math.degrees(math.remainder(spectrum.phase[k] - ph, 2 * math.pi)))
                for k, (_, ph) in ORDERS.items()
            )
            rows.append(
                f"| {order} | {samples} | {amp:.2e} | {phase:.2e} | {elapsed * 1e3:.0f} ms | "
                f"{SECONDS / elapsed:.0f} |"
            )
    return [
        "## Angle-domain resampling: interpolation order and grid against error",
        "",
        f"Orders {sorted(ORDERS)} with known amplitudes and phases, speed varying +-20 % around 600 rpm, "
        f"{SECONDS:g} s at {FS / 1000:g} kHz; angle map from the edges of a 60-2 tooth wheel (monotone "
        "interpolation between teeth); anti-alias FIR (Kaiser, ripple 1e-5) passing up to 0.8 of the "
        "angle-domain Nyquist order at the lowest speed, the filtered signal kept at ten times its "
        "passband edge; errors relative to the true amplitudes (largest over the orders) and in phase. "
        "At 32 samples per revolution order 12 lies above the passband at the fastest speed and is "
        "filtered out (the pipeline refuses such a grid for these orders).",
        "",
        *rows,
        "",
    ]
