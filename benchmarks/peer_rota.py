"""Peer benchmark: the product's order spectra against rota-order 0.3.0 on the same recording.

Run with ``python -m benchmarks.peer_rota [--minutes M] [--minutes-used U]``
(default 5 minutes, all of it used). It generates a recording with
:func:`benchmarks.long_recording.generate` in a temporary folder, runs the
product and the peer on the same excerpt and prints a markdown table.

The peer. ``rota-order`` (import name ``rota``) is GPL-3.0-or-later: it is
never a dependency of the product and is never imported by it. It lives in a
separate, git-ignored virtual environment ``.venv-peers/`` at the root of the
repository, which this module creates on first use (``python -m venv`` and
``pip install rota-order==0.3.0 h5py numpy scipy``; rota itself requires only
numpy and scipy, h5py reads the recording). Every peer run is a subprocess
of that environment's interpreter running this file as a script; the
product side never imports ``rota`` and the peer side never imports the
product.

What is compared. The same excerpt (the first ``minutes_used`` minutes; when
that is less than the whole recording, both read a copy of that span made by
:func:`write_excerpt`), the same four accelerometer channels
``mb1-vertical`` .. ``mb4-vertical`` and the same orders 1, 2, 4, 6 and 8,
whose true peak amplitudes (``benchmarks.long_recording.TRUE_ORDERS``: 1, 0.5,
0.2, 0.1, 0.05) and phases (``0.3 i + 0.1 k`` rad for channel ``i`` = 0..3
and order ``k``, relative to the generator's crank angle) are those of the
generator. Each tool yields one complex peak amplitude per channel and order
for the whole excerpt:

- the product: ``spectra(recording, cycle_revolutions=1, max_order=24,
  samples_per_cycle=256, channels=<the four>)``, its angle map decoded from
  the 60-2 tooth wheel, ``amplitude[k]`` the complex synchronous average over
  one-revolution blocks;
- rota, given the crank speed in rpm at every accelerometer sample, taken
  from the product's angle map (``speed_at``, held at its end values for the
  few samples outside the span of the tooth pulses) and written to a .npy
  file. rota's phases are relative to shaft angle 0 at the first sample (its
  ``rpm_to_phase`` starts at 0); they are shifted by ``k theta0``, ``theta0``
  the product map's angle at the first sample, so that both tools' phases
  refer to the same angle zero. The routes and settings are in
  :data:`PEER_SETTINGS`:

  * ``rota.extract.tracked_harmonics`` (phase-locked averaging over frames
    of fixed angle; rota's extractor "for long multichannel records"):
    the complex peak envelopes averaged over the samples more than
    ``params["edge_revs"]`` revolutions from either end (the span its
    documentation says to trust). Defaults: ``window_revs=8, overlap=0.75,
    window="hann", significance=None``. Fastest: ``overlap=0``; the cost is
    proportional to ``1 / (1 - overlap)`` and does not depend on the window
    length or shape, and its normalised overlap-add keeps stationary
    amplitudes exact at any overlap.
  * ``rota.maps.rpm_order_map`` then ``rota.slices.order_spectrum`` (computed
    order tracking then an angle-domain short-time FFT): the amplitude is
    the order spectrum's RMS over frames of the peak-scaled map at the bin of
    the order (every order lies on a bin), the phase that of the complex mean
    over frames of ``rota.slices.order_slice(...).complex``. The map's
    default amplitude convention is RMS; ``amplitude="peak"`` is passed in
    both settings, a scaling only. Defaults: ``order_resolution=0.25,
    overlap=0.75, window="hann"``, ``max_order`` 0.45 fs over the top speed
    (838 here) and ``samples_per_rev`` 2.5 times that. Fastest:
    ``max_order=24`` (the product's) and ``overlap=0``. The cost is mostly
    the time-to-angle resampling, which ``rpm_order_map`` does not let one
    tune (its ``upsample`` and ``attenuation`` stay at 4 and 80 dB), and
    whose intermediate grid is set by the slowest speed, not by ``max_order``.
  * ``rota.extract.order_waveform`` (Vold-Kalman) at its defaults
    (``bandwidth=1`` Hz, ``joint=True``): it refuses input this long with
    a MemoryError from its own 200 MB working-set check; the row records
    that. Settings under which it runs (e.g. ``bandwidth=5`` or
    ``joint=False``) took about half a minute or more per recording-minute
    of the four channels when this benchmark was written, too slow for its time
    budget.

Numbers. Each run is its own fresh process. ``seconds`` is the wall time
from opening the file to the complex amplitudes (imports excluded);
``cpu_seconds`` the user plus system time of that span (the product computes
channels in threads on every core, rota's routes use one core);
``peak_bytes`` the process's maximum resident set (``ru_maxrss``, interpreter
and libraries included). For rota, deriving its rpm input from the product's
angle map is not part of ``seconds``; it is ``reference_seconds``, while the
product's ``seconds`` include decoding its own tooth wheel.
``amplitude_error`` is the largest ``|measured - true| / true`` over channels
and orders, ``phase_error_deg`` the largest phase error [deg] against the
generator's crank angle. Both tools' phases are referred to the same angle
zero, the product's map's, so an error of that zero would show in both alike.

Limits. rota's memory grows with the excerpt's length: its extractors return
full-rate envelopes and waveforms (24 bytes per sample, order and channel)
and its order map resamples all channels at once, several GiB for five
minutes of four channels, so an excerpt of an hour does not fit in 24 GiB (a
killed run is reported as that row's ``error``). Times are single runs on a
shared machine and vary by some tens of percent from run to run.
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

# Only the standard library and numpy at the top: the peer side runs this file as a script in
# .venv-peers/, which has rota, h5py, numpy and scipy but not the product (nor the benchmarks package),
# and benchmarks.performance imports it into child processes whose imports and memory are measured. So
# rota, scipy and h5py, and on the product side the product and benchmarks.long_recording, are
# imported in the functions that use them.

ROOT = Path(__file__).resolve().parents[1]
PEER_VENV = ROOT / ".venv-peers"
PEER_PACKAGES = ("rota-order==0.3.0", "h5py", "numpy", "scipy")
PEER_VERSION = "0.3.0"
CHANNELS = tuple(f"mb{i}-vertical" for i in range(1, 5))
GENERATOR_NOTES = "generated by benchmarks.performance"
MAX_ORDER = 24.0
SAMPLES_PER_CYCLE = 256

#: rota routes and settings: (label, function, keyword arguments besides x, fs, rpm and orders).
PEER_SETTINGS: tuple[tuple[str, str, dict[str, Any]], ...] = (
    (
        "rota tracked_harmonics, defaults (window_revs=8, overlap=0.75, window='hann')",
        "tracked_harmonics",
        {},
    ),
    (
        "rota tracked_harmonics, fastest: overlap=0 (window_revs=8, window='hann')",
        "tracked_harmonics",
        {"overlap": 0.0},
    ),
    (
        "rota rpm_order_map + order_spectrum, defaults (order_resolution=0.25, overlap=0.75, "
        "window='hann', max_order=0.45 fs/top speed), amplitude='peak'",
        "rpm_order_map",
        {},
    ),
    (
        "rota rpm_order_map + order_spectrum, fastest: max_order=24, overlap=0 "
        "(order_resolution=0.25, window='hann'), amplitude='peak'",
        "rpm_order_map",
        {"max_order": MAX_ORDER, "overlap": 0.0},
    ),
    (
        "rota order_waveform (Vold-Kalman), defaults (bandwidth=1 Hz, joint=True)",
        "order_waveform",
        {},
    ),
)


def true_orders() -> dict[int, float]:
    """True peak amplitudes by order of :func:`benchmarks.long_recording.generate` (product side only)."""
    from benchmarks.long_recording import TRUE_ORDERS

    return {int(k): float(a) for k, a in TRUE_ORDERS.items()}


def true_phase(channel_index: int, order: int) -> float:
    """True phase [rad] of ``order`` on accelerometer ``channel_index`` (0-based), as generate() writes it."""
    return 0.3 * channel_index + 0.1 * order


# --------------------------------------------------------------------------------------------------
# both sides: the recording and the errors
# --------------------------------------------------------------------------------------------------


def _check_recording(path: Path) -> float:
    """Refuse a file the generator did not write; return its accelerometers' duration [s]."""
    import h5py

    with h5py.File(path, "r") as f:
        notes = f.attrs.get("notes", "")
        notes = notes.decode() if isinstance(notes, bytes) else str(notes)
        if notes != GENERATOR_NOTES:
            raise ValueError(
                f"{path}: notes attribute {notes!r}, expected {GENERATOR_NOTES!r}: the errors are "
                "computed against the amplitudes of benchmarks.long_recording.generate, so only its "
                "recordings can be measured"
            )
        missing = [name for name in (*CHANNELS, "tooth", "keyphasor") if name not in f["channels"]]
        if missing:
            raise ValueError(f"{path}: channel(s) {', '.join(missing)} missing under /channels")
        first = f["channels"][CHANNELS[0]]
        return float(first.shape[0] / float(first.attrs["sample_rate_hz"]))


def write_excerpt(path: Path, minutes_used: float, target: Path) -> Path:
    """Copy the first ``minutes_used`` minutes of a recording into a new HDF5 file.

    Attributes are copied; waveform channels are cut to the span (same dtype,
    chunks, checksums and compression) with ``duration_s`` updated, event
    channels keep the events inside it.

    Parameters
    ----------
    path : Path
        A recording in the product's HDF5 format.
    minutes_used : float
        Length of the excerpt [min].
    target : Path
        File to write.

    Returns
    -------
    Path
        ``target``.
    """
    import h5py

    end = minutes_used * 60.0
    with h5py.File(path, "r") as src, h5py.File(target, "w") as dst:
        dst.attrs.update(dict(src.attrs))
        group = dst.create_group("channels", track_order=True)
        for name, ds in src["channels"].items():
            attrs = dict(ds.attrs)
            offset = float(attrs.get("start_offset_s", 0.0))
            if attrs.get("representation", "waveform") == "events":
                times = ds[()]
                out = group.create_dataset(name, data=times[times < end])
            else:
                rate = float(attrs["sample_rate_hz"])
                n = min(ds.shape[0], max(0, round((end - offset) * rate)))
                out = group.create_dataset(
                    name,
                    shape=(n,),
                    dtype=ds.dtype,
                    chunks=ds.chunks if ds.chunks and n >= ds.chunks[0] else None,
                    fletcher32=ds.fletcher32,
                    compression=ds.compression,
                    compression_opts=ds.compression_opts,
                )
                step = int(10 * rate)
                for a in range(0, n, step):
                    out[a : min(n, a + step)] = ds[a : min(n, a + step)]
                attrs["duration_s"] = n / rate
            out.attrs.update(attrs)
    return target


def _excerpt(path: Path, minutes_used: float, folder: Path) -> Path:
    """The recording itself if ``minutes_used`` covers it, else an excerpt written into ``folder``."""
    duration = _check_recording(path)
    if not (math.isfinite(minutes_used) and minutes_used > 0):
        raise ValueError(f"minutes_used = {minutes_used!r}: expected a positive number of minutes")
    if minutes_used * 60.0 > duration + 1e-6:
        raise ValueError(
            f"minutes_used = {minutes_used:g}: the recording {path} holds only {duration / 60:g} minutes"
        )
    if minutes_used * 60.0 >= duration - 1e-6:
        return path
    return write_excerpt(path, minutes_used, folder / "excerpt.h5")


def _errors(amplitudes: dict[str, dict[int, complex]]) -> dict[str, float]:
    """Largest amplitude and phase errors over the channels and orders (see the module docstring)."""
    amplitude_error = phase_error = 0.0
    for i, name in enumerate(CHANNELS):
        for k, a in true_orders().items():
            z = amplitudes[name][k]
            amplitude_error = max(amplitude_error, abs(abs(z) - a) / a)
            wrapped = math.remainder(float(np.angle(z)) - true_phase(i, k), 2 * math.pi)
            phase_error = max(phase_error, abs(math.degrees(wrapped)))
    return {"amplitude_error": amplitude_error, "phase_error_deg": phase_error}


def _encode(amplitudes: dict[str, dict[int, complex]]) -> dict[str, dict[str, list[float]]]:
    return {name: {str(k): [z.real, z.imag] for k, z in row.items()} for name, row in amplitudes.items()}


def _decode(data: dict[str, dict[str, list[float]]]) -> dict[str, dict[int, complex]]:
    return {name: {int(k): complex(*v) for k, v in row.items()} for name, row in data.items()}


def _run_child(command: list[str], what: str) -> dict[str, Any]:
    """Run a measuring child; its last output line is JSON. A crash or kill is reported, not raised."""
    out = subprocess.run(command, capture_output=True, text=True, cwd=ROOT, check=False)
    if out.returncode != 0:
        tail = " | ".join(out.stderr.strip().splitlines()[-3:])
        how = "killed by the system (out of memory?)" if out.returncode == -9 else f"exit {out.returncode}"
        return {"error": f"{what}: {how}: {tail}"}
    lines = out.stdout.strip().splitlines()
    if not lines:
        return {"error": f"{what}: printed no result; stderr: {out.stderr.strip()[-500:]}"}
    result: dict[str, Any] = json.loads(lines[-1])
    return result


def _row(tool: str, label: str, child: dict[str, Any], reference_seconds: float) -> dict[str, Any]:
    row: dict[str, Any] = {
        "tool": tool,
        "label": label,
        "channels": list(CHANNELS),
        "orders": list(true_orders()),
        "seconds": None,
        "cpu_seconds": None,
        "peak_bytes": child.get("peak_bytes"),
        "amplitude_error": None,
        "phase_error_deg": None,
        "reference_seconds": reference_seconds,
        "error": child.get("error"),
    }
    if row["error"] is None:
        row["seconds"] = child["seconds"]
        row["cpu_seconds"] = child["cpu_seconds"]
        row.update(_errors(_decode(child["amplitudes"])))
    return row


def _usage() -> tuple[float, float]:
    """(wall, cpu) clocks of this process [s]."""
    ru = resource.getrusage(resource.RUSAGE_SELF)
    return time.perf_counter(), ru.ru_utime + ru.ru_stime


def _peak_bytes() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # KiB on Linux


# --------------------------------------------------------------------------------------------------
# the product
# --------------------------------------------------------------------------------------------------


def measure_ours(path: Path, minutes_used: float) -> list[dict[str, Any]]:
    """Measure the product's order spectra on the first ``minutes_used`` minutes of a recording.

    Parameters
    ----------
    path : Path
        A recording written by :func:`benchmarks.long_recording.generate`.
    minutes_used : float
        Minutes from the start to analyse [min].

    Returns
    -------
    list of dict
        One row with ``tool``, ``label`` (the exact call), ``channels``,
        ``orders``, ``seconds``, ``cpu_seconds``, ``peak_bytes``,
        ``amplitude_error``, ``phase_error_deg``, ``reference_seconds`` (0: the
        angle map is part of ``seconds``) and ``error`` (None, or what failed).
    """
    with tempfile.TemporaryDirectory() as folder:
        used = _excerpt(Path(path), minutes_used, Path(folder))
        spec = Path(folder) / "ours.json"
        spec.write_text(json.dumps({"path": str(used), "orders": list(true_orders())}))
        child = _run_child(
            [sys.executable, "-m", "benchmarks.peer_rota", "--ours-child", str(spec)], "the product's spectra"
        )
    label = (
        f"engine-monitor spectra(cycle_revolutions=1, max_order={MAX_ORDER:g}, "
        f"samples_per_cycle={SAMPLES_PER_CYCLE}), angle map from the 60-2 tooth wheel"
    )
    return [_row("engine-monitor", label, child, 0.0)]


def _ours_child(spec_path: str) -> None:
    """In a fresh product process: run the pipeline on the file and print time, memory and amplitudes."""
    from monitor.io import open_recording
    from monitor.signal.measure import spectra

    spec = json.loads(Path(spec_path).read_text())
    orders = [int(k) for k in spec["orders"]]
    wall, cpu = _usage()
    with open_recording(spec["path"]) as recording:
        result = spectra(
            recording,
            cycle_revolutions=1,
            max_order=MAX_ORDER,
            samples_per_cycle=SAMPLES_PER_CYCLE,
            channels=list(CHANNELS),
        )
        amplitudes = {
            name: {k: complex(result.spectra[name].amplitude[k]) for k in orders} for name in CHANNELS
        }
        wall_end, cpu_end = _usage()
        peak = _peak_bytes()
        axis = result.spectra[CHANNELS[0]].orders
        if not all(abs(axis[k] - k) < 1e-9 for k in orders):
            raise RuntimeError(f"the product's order axis does not put order k at index k: {axis[:9]}")
    print(
        json.dumps(
            {
                "seconds": wall_end - wall,
                "cpu_seconds": cpu_end - cpu,
                "peak_bytes": peak,
                "amplitudes": _encode(amplitudes),
            }
        )
    )


# --------------------------------------------------------------------------------------------------
# the peer
# --------------------------------------------------------------------------------------------------


def peer_python() -> Path:
    """The peer environment's interpreter, creating ``.venv-peers/`` and installing rota first if needed.

    Returns
    -------
    Path
        ``.venv-peers/bin/python``.

    Raises
    ------
    RuntimeError
        If the environment cannot be created or the packages cannot be installed.
    """
    python = PEER_VENV / "bin" / "python"
    probe = [str(python), "-c", "import h5py, numpy, scipy, rota; print(rota.__version__)"]
    if python.exists():
        out = subprocess.run(probe, capture_output=True, text=True, check=False)
        if out.returncode == 0 and out.stdout.strip() == PEER_VERSION:
            return python
    else:
        print(f"creating the peer environment {PEER_VENV.name}/ (once) ...", file=sys.stderr, flush=True)
        made = subprocess.run(
            [sys.executable, "-m", "venv", str(PEER_VENV)], capture_output=True, text=True, check=False
        )
        if made.returncode != 0:
            raise RuntimeError(f"could not create the peer environment {PEER_VENV}: {made.stderr.strip()}")
    print(f"installing {' '.join(PEER_PACKAGES)} into {PEER_VENV.name}/ ...", file=sys.stderr, flush=True)
    installed = subprocess.run(
        [str(python), "-m", "pip", "install", "--quiet", "--disable-pip-version-check", *PEER_PACKAGES],
        capture_output=True,
        text=True,
        check=False,
    )
    if installed.returncode != 0:
        raise RuntimeError(
            f"could not install {' '.join(PEER_PACKAGES)} into {PEER_VENV}: "
            f"{installed.stderr.strip()[-1000:]}"
        )
    out = subprocess.run(probe, capture_output=True, text=True, check=False)
    if out.returncode != 0 or out.stdout.strip() != PEER_VERSION:
        raise RuntimeError(
            f"{PEER_VENV}: rota {PEER_VERSION} still not importable after installing "
            f"({out.stdout.strip() or out.stderr.strip()[-500:]})"
        )
    return python


def _speed_reference(path: Path, rpm_file: Path) -> dict[str, Any]:
    """Write the crank speed [rpm] at every accelerometer sample, from the product's angle map.

    Returns the sample count and rate, the map's angle at the first sample
    (``theta0``, rad) and the seconds this took.
    """
    from monitor.io import open_recording
    from monitor.signal.reference import angle_reference

    start = time.perf_counter()
    with open_recording(path) as recording:
        angle_map = angle_reference(recording, cycle_revolutions=1).angle_map
        channels = [recording.channel(name) for name in CHANNELS]
        rates = {float(c.sample_rate or 0) for c in channels}
        offsets = {c.start_offset for c in channels}
        sizes = {int(c.data.shape[0]) for c in channels}
        if len(rates) != 1 or len(offsets) != 1 or len(sizes) != 1:
            raise ValueError(
                f"{path}: the accelerometers differ in rate, start or length ({rates}, {offsets}, {sizes}): "
                "rota needs one speed per sample of all of them"
            )
        rate, t0, n = rates.pop(), offsets.pop(), sizes.pop()
        times = t0 + np.arange(n) / rate
        first, last = float(angle_map.times[0]), float(angle_map.times[-1])
        speed = angle_map.speed_at(np.clip(times, first, last))  # held at the ends outside the pulses
        theta0 = float(angle_map.angle_at(first)) - float(speed[0]) * (first - t0)
        np.save(rpm_file, speed * (30.0 / math.pi))
    return {
        "samples": n,
        "rate": rate,
        "theta0": theta0,
        "seconds": time.perf_counter() - start,
    }


def measure_rota(path: Path, minutes_used: float) -> list[dict[str, Any]]:
    """Measure rota-order 0.3.0 on the first ``minutes_used`` minutes of a recording, each setting.

    Runs every entry of :data:`PEER_SETTINGS` in its own process of the peer
    environment (created on first use, see :func:`peer_python`) on the four
    accelerometers, with the speed from the product's angle map.

    Parameters
    ----------
    path : Path
        A recording written by :func:`benchmarks.long_recording.generate`.
    minutes_used : float
        Minutes from the start to analyse [min].

    Returns
    -------
    list of dict
        One row per setting, with the fields of :func:`measure_ours`;
        ``reference_seconds`` is the time taken to derive rota's rpm input
        from the product's angle map (not in ``seconds``), ``error`` what
        failed if the setting did not run (then the measured fields are None).
    """
    python = peer_python()
    with tempfile.TemporaryDirectory() as folder:
        used = _excerpt(Path(path), minutes_used, Path(folder))
        rpm_file = Path(folder) / "rpm.npy"
        reference = _speed_reference(used, rpm_file)
        rows = []
        for label, function, kwargs in PEER_SETTINGS:
            spec = Path(folder) / "peer.json"
            spec.write_text(
                json.dumps(
                    {
                        "path": str(used),
                        "rpm": str(rpm_file),
                        "samples": reference["samples"],
                        "rate": reference["rate"],
                        "theta0": reference["theta0"],
                        "orders": list(true_orders()),
                        "function": function,
                        "kwargs": kwargs,
                    }
                )
            )
            child = _run_child([str(python), str(Path(__file__).resolve()), "--peer-child", str(spec)], label)
            tool = f"rota-order {child.get('versions', PEER_VERSION)}"
            rows.append(_row(tool, label, child, reference["seconds"]))
    return rows


def _peer_child(spec_path: str) -> None:
    """In a fresh peer process: run one rota setting and print time, memory and amplitudes (or the error)."""
    import h5py
    import rota
    import scipy

    spec = json.loads(Path(spec_path).read_text())
    function, kwargs = spec["function"], spec["kwargs"]
    fs, n, theta0 = float(spec["rate"]), int(spec["samples"]), float(spec["theta0"])
    orders = [int(k) for k in spec["orders"]]
    versions = f"{rota.__version__} (numpy {np.__version__}, scipy {scipy.__version__})"
    wall, cpu = _usage()
    try:
        with h5py.File(spec["path"], "r") as f:
            x = np.column_stack([f["channels"][name][:n] for name in CHANNELS])  # (n, 4) float32
        rpm = np.load(spec["rpm"])
        values = np.empty((len(orders), len(CHANNELS)), dtype=complex)  # relative to angle 0 at sample 0
        if function in ("tracked_harmonics", "order_waveform"):
            extract = getattr(rota.extract, function)
            components = extract(x, fs, rpm, orders, **kwargs)
            if function == "tracked_harmonics":  # trust the span beyond edge_revs from either end
                edge = float(components.params["edge_revs"])
                rev = components.rev
                a, b = np.searchsorted(rev, [rev[0] + edge, rev[-1] - edge])
            else:  # five envelope time constants (0.18 / bandwidth s) from either end
                margin = int(5 * 0.18 / min(components.params["bandwidth"]) * fs)
                a, b = margin, n - margin
            values[:] = components.envelopes[a:b].mean(axis=0)
        elif function == "rpm_order_map":
            order_map = rota.maps.rpm_order_map(x, fs, rpm, amplitude="peak", **kwargs)
            spectrum = rota.slices.order_spectrum(order_map)
            for j, k in enumerate(orders):
                b = int(np.argmin(np.abs(spectrum.axis - k)))
                if abs(spectrum.axis[b] - k) > 1e-9:
                    raise ValueError(f"order {k} falls between the map's bins ({spectrum.axis[b]:g})")
                phase = np.angle(np.nanmean(rota.slices.order_slice(order_map, k).complex, axis=0))
                values[j] = spectrum.amplitude[b] * np.exp(1j * phase)
        else:
            raise ValueError(f"unknown rota route {function!r}")
    except (MemoryError, ValueError) as error:
        print(json.dumps({"error": f"{type(error).__name__}: {error}", "versions": versions}))
        return
    wall_end, cpu_end = _usage()
    peak = _peak_bytes()
    values *= np.exp(-1j * np.asarray(orders, dtype=float) * theta0)[:, None]  # to the product's angle zero
    amplitudes = {
        name: {k: complex(values[j, i]) for j, k in enumerate(orders)} for i, name in enumerate(CHANNELS)
    }
    print(
        json.dumps(
            {
                "seconds": wall_end - wall,
                "cpu_seconds": cpu_end - cpu,
                "peak_bytes": peak,
                "amplitudes": _encode(amplitudes),
                "versions": versions,
            }
        )
    )


# --------------------------------------------------------------------------------------------------
# standalone
# --------------------------------------------------------------------------------------------------


def table(rows: list[dict[str, Any]]) -> list[str]:
    def number(value: float | None, fmt: str) -> str:
        return "-" if value is None else format(value, fmt)

    lines = [
        "| tool and settings | time [s] | CPU time [s] | peak memory [GiB] | amplitude error | "
        "phase error [deg] |",
        "|---|---|---|---|---|---|",
    ]
    for row in rows:
        label = row["label"] if row["error"] is None else f"{row['label']}: **failed**: {row['error']}"
        peak = None if row["peak_bytes"] is None else row["peak_bytes"] / 1024**3
        lines.append(
            f"| {label} | {number(row['seconds'], '.2f')} | {number(row['cpu_seconds'], '.2f')} | "
            f"{number(peak, '.2f')} | {number(row['amplitude_error'], '.1e')} | "
            f"{number(row['phase_error_deg'], '.3f')} |"
        )
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=5.0, help="length of the generated recording [min]")
    parser.add_argument(
        "--minutes-used", type=float, default=None, help="minutes from the start to analyse (default: all)"
    )
    parser.add_argument("--ours-child", metavar="SPEC", help=argparse.SUPPRESS)
    parser.add_argument("--peer-child", metavar="SPEC", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.ours_child:
        _ours_child(args.ours_child)
        return
    if args.peer_child:
        _peer_child(args.peer_child)
        return

    from benchmarks.long_recording import generate

    used = args.minutes if args.minutes_used is None else args.minutes_used
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "recording.h5"
        print(f"generating {args.minutes:g} minutes ...", file=sys.stderr, flush=True)
        generate(path, args.minutes)
        print("warming up the product (numba's compile cache) ...", file=sys.stderr, flush=True)
        small = Path(folder) / "small.h5"
        generate(small, 0.25)
        measure_ours(small, 0.25)
        small.unlink()
        print("the product ...", file=sys.stderr, flush=True)
        rows = measure_ours(path, used)
        print("rota, each setting in its own process ...", file=sys.stderr, flush=True)
        rows += measure_rota(path, used)
    reference = rows[-1]["reference_seconds"]
    tool = rows[-1]["tool"]
    print(
        "\n".join(
            [
                f"Recording from benchmarks.long_recording.generate, {args.minutes:g} min; the first "
                f"{used:g} min of {', '.join(CHANNELS)} analysed, "
                f"orders {', '.join(map(str, true_orders()))}. "
                f"Peer: {tool}. rota's rpm input took {reference:.2f} s more to derive from the product's "
                "angle map (not in its times). Errors: largest over channels and orders; see the "
                "module docstring.",
                "",
                *table(rows),
            ]
        )
    )


if __name__ == "__main__":
    main()
