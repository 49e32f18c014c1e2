"""Accuracy against time of angle-domain resampling (a section of docs/accuracy-vs-time.md).

Called by ``benchmarks.accuracy_vs_time``, or alone as ``python -m benchmarks.angle_domain``, which
rewrites only this section (between its markers) and says so in it; every number comes from the run.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import Any
from unittest.mock import patch

import numpy as np
from scipy.integrate import cumulative_trapezoid

from benchmarks.sections import replace_section
from monitor.errors import SignalError
from monitor.signal import kernels as signal_kernels
from monitor.signal.anglemap import AngleMap
from monitor.signal.resample import to_angle_domain
from monitor.signal.spectrum import order_spectrum

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


ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "accuracy-vs-time.md"
START = "<!-- angle-domain section: start -->"
END = "<!-- angle-domain section: end -->"


def sections(*, header: str = "") -> list[str]:
    """The angle-domain section of docs/accuracy-vs-time.md, between its markers."""
    x, angle_map = _case()
    kernels: list[tuple[str, dict[str, Any], bool]] = [
        ("default, passband to order 12", {"max_order": 12.0}, False),
        ("default, passband 0.8 of Nyquist", {}, False),
        ("band-limited forced, passband to order 12", {"max_order": 12.0}, True),
        ("band-limited forced, passband 0.8 of Nyquist", {}, True),
        *((f"B-spline {order}", {"interpolation_order": order}, False) for order in (1, 3, 5)),
    ]
    for _, options, _ in kernels:  # compile the numba kernels first (cached on disk after the first run)
        to_angle_domain(x[: int(2 * FS)], FS, angle_map, samples_per_cycle=64, **options)
    rows = [
        "| kernel asked for | samples per revolution | kernel used (taps per input sample) | "
        "largest amplitude error | largest phase error [deg] | "
        f"time for {SECONDS:g} s at {FS / 1000:g} kHz | real time over computing time |",
        "|---|---|---|---|---|---|---|",
    ]
    slowest, fastest = (w / (2 * math.pi) for w in angle_map.speed_range)
    for label, options, forced in kernels:
        for samples in (32, 64, 128, 256, 512):
            stopband = min(samples / 2 * slowest, FS / 2)
            passband = options.get("max_order", 0.8 * samples / 2 * slowest / fastest) * fastest
            spacing = FS / (samples * angle_map.mean_speed / (2 * math.pi))
            limit = math.inf if forced else signal_kernels._FUSED_TAPS_PER_INPUT
            with patch.object(signal_kernels, "_FUSED_TAPS_PER_INPUT", limit):
                try:
                    elapsed = math.inf
                    for _ in range(3):  # the best of three (a shared machine)
                        start = time.perf_counter()
                        resampled = to_angle_domain(x, FS, angle_map, samples_per_cycle=samples, **options)
                        spectrum = order_spectrum(resampled)
                        elapsed = min(elapsed, time.perf_counter() - start)
                except SignalError:  # order 12 at the fastest speed above this grid's Nyquist order
                    rows.append(f"| {label} | {samples} | refused: the grid cannot hold order 12 | | | | |")
                    continue
            used = resampled.interpolation
            if used == "band-limited":
                used += f" ({signal_kernels._fused_taps(passband, stopband, FS) / spacing:.0f})"
            amp = max(abs(spectrum.magnitude[k] / a - 1) for k, (a, _) in ORDERS.items())
            phase = max(
                abs(math.degrees(math.remainder(spectrum.phase[k] - ph, 2 * math.pi)))
                for k, (_, ph) in ORDERS.items()
            )
            rows.append(
                f"| {label} | {samples} | {used} | {amp:.2e} | {phase:.2e} | {elapsed * 1e3:.0f} ms | "
                f"{SECONDS / elapsed:.0f} |"
            )
    return [
        START,
        "## Angle-domain resampling: kernel and grid against error",
        "",
        *([header, ""] if header else []),
        f"Orders {sorted(ORDERS)} with known amplitudes and phases, speed varying +-20 % around 600 rpm, "
        f"{SECONDS:g} s at {FS / 1000:g} kHz; angle map from the edges of a 60-2 tooth wheel (monotone "
        "interpolation between teeth). Two kernels (see `monitor/signal/kernels.py`): the fused "
        "band-limited one (the default: a Kaiser windowed sinc evaluated at each grid time, ripple and "
        "stopband 1e-5), with its passband edge at the highest order wanted (12 here, at the fastest "
        "speed; what the pipeline passes) or at 0.8 of the angle-domain Nyquist order at the lowest "
        "speed; and an FFT-applied FIR of the same ripple, the filtered signal kept at ten times its "
        "passband edge, then B-splines of order 1, 3 or 5. Errors relative to the true amplitudes "
        "(largest over the orders) and in phase. At 32 samples per revolution order 12 lies above the "
        "passband at the fastest speed: filtered out by the kernels given 0.8 of Nyquist (the pipeline "
        "refuses such a grid for these orders), refused by the one given the order. The default "
        "takes the band-limited kernel unless it would need more than "
        f"{signal_kernels._FUSED_TAPS_PER_INPUT:g} taps per input sample between grid points (then the "
        "FFT filter and cubic splines); the rows forcing it show what it costs beyond that. Times are "
        "the best of three runs.",
        "",
        *rows,
        "",
        END,
        "",
    ]


def main() -> None:
    """Rewrite the angle-domain section of docs/accuracy-vs-time.md alone."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.parse_args()
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    header = (
        f"This section was written by `python -m benchmarks.angle_domain` on {stamp}, Python "
        f"{platform.python_version()}, numpy {np.__version__}, {platform.machine()} with {os.cpu_count()} "
        "cores (shared machine: compare ratios within this table), apart from the rest of this document."
    )
    replace_section(DOC, START, END, "\n".join(sections(header=header)).rstrip("\n"))
    print(f"wrote the angle-domain section of {DOC.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
