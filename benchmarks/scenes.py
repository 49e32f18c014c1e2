"""What a simulated minute costs, effect by effect (a section of docs/accuracy-vs-time.md).

Called by ``benchmarks.accuracy_vs_time``; every number comes from this run. Each effect is
simulated alone (with the inputs it needs named beside it, as a scene must) on the same sensors, and
each shipped scene at its own length; the time is per simulated minute, best of three runs.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from monitor.scene import load_scene, parse_scene, simulate

SCENES = Path(__file__).resolve().parents[1] / "recordings" / "scenes"
MODES = {"modes": [{"frequency_hz": 60.0, "damping": 0.05, "gain": 1e-6}]}
SENSORS = [
    {
        "name": "mb2-vertical",
        "kind": "acceleration",
        "location": "main bearing 2",
        "direction": "vertical",
        "sample_rate_hz": 10240.0,
    },
    {"name": "tooth", "kind": "tooth", "sample_rate_hz": 10240.0},
    {"name": "keyphasor", "kind": "keyphasor", "representation": "events"},
    {
        "name": "free-end-axial",
        "kind": "acceleration",
        "location": "free end",
        "direction": "axial",
        "sample_rate_hz": 10240.0,
    },
]
EFFECTS: list[tuple[str, dict[str, Any]]] = [
    ("none (crank angle and sensors only)", {}),
    ("noise", {"noise": {"mb2-vertical": 0.01}}),
    ("inertia", {"inertia": {}}),
    ("gas", {"gas": {}}),
    ("unbalance", {"unbalance": {"throw": 2, "kgm": 1000.0}}),
    ("external_torque", {"external_torque": {"orders": [{"order": 4, "amplitude_nm": 1e5}]}}),
    ("misfire (with gas)", {"gas": {}, "misfire": {"cylinders": [4]}}),
    ("crank_speed rigid (with inertia, gas)", {"inertia": {}, "gas": {}, "crank_speed": {}}),
    (
        "crank_speed shaft_line (with inertia, gas)",
        {"inertia": {}, "gas": {}, "crank_speed": {"model": "shaft_line"}},
    ),
    (
        "crank_speed variable_inertia, damping 0.4 (with inertia, gas)",
        {"inertia": {}, "gas": {}, "crank_speed": {"model": "variable_inertia", "damping": 0.4}},
    ),
    ("bearing_vibration (with inertia, gas)", {"inertia": {}, "gas": {}, "bearing_vibration": MODES}),
    ("axial_vibration (with inertia, gas)", {"inertia": {}, "gas": {}, "axial_vibration": {}}),
    (
        "worn_bearing (with inertia, gas, bearing_vibration)",
        {
            "inertia": {},
            "gas": {},
            "bearing_vibration": MODES,
            "worn_bearing": {"bearing": 2, "severity": 0.3},
        },
    ),
    ("keyphasor_faults", {"keyphasor_faults": {"sensor": "keyphasor", "dropouts": 2, "extras": 1}}),
    ("tooth_spacing_errors", {"tooth_spacing_errors": {"sensor": "tooth", "rms_deg": 0.05}}),
    ("clipping", {"clipping": {"sensor": "mb2-vertical", "limit": 0.1}}),
    ("gain_error", {"gain_error": {"sensor": "mb2-vertical", "gain": 1.1}}),
]
SECONDS = 60.0


def _best(run: Any, repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


def sections() -> list[str]:
    """The scene-cost section of docs/accuracy-vs-time.md."""
    simulate(
        parse_scene(
            {
                "engine": "man-b-w-7k98mc",
                "duration_s": 2.0,
                "operating_point": {"speed_rpm": 104.0},
                "sensors": SENSORS,
                "effects": {},
            }
        )
    )  # imports and numba's cache, not counted
    rows = [
        "| effects named | time per simulated minute | over none |",
        "|---|---|---|",
    ]
    base = 0.0
    for label, effects in EFFECTS:
        scene = parse_scene(
            {
                "engine": "man-b-w-7k98mc",
                "duration_s": SECONDS,
                "operating_point": {"speed_rpm": 104.0},
                "sensors": SENSORS,
                "effects": effects,
            }
        )
        seconds = _best(lambda scene=scene: simulate(scene)) / (SECONDS / 60)
        base = base or seconds
        rows.append(f"| {label} | {seconds * 1e3:.0f} ms | {seconds / base:.2f} |")
    shipped = [
        "| scene | simulated | channels | effects | time per simulated minute |",
        "|---|---|---|---|---|",
    ]
    for path in sorted(SCENES.glob("*.toml")):
        scene = load_scene(path)
        seconds = _best(lambda scene=scene: simulate(scene), repeat=1)
        shipped.append(
            f"| {path.stem} | {scene.duration_s:g} s | {len(scene.sensors)} | {', '.join(scene.effects)} | "
            f"{seconds / (scene.duration_s / 60):.2f} s |"
        )
    return [
        "## What a simulated minute costs",
        "",
        f"The 7K98MC at 104 rpm, {SECONDS:g} s: an accelerometer on main bearing 2, an axial one at the "
        "free end and an analog tooth wheel at 10.24 kHz, a keyphasor as events. Each effect alone, "
        "with the inputs it needs named beside it (as a scene must name them); an effect that is not "
        "named is not evaluated, so the cost of a scene follows what it names. Best of three runs.",
        "",
        *rows,
        "",
        "The shipped scenes (recordings/scenes/), each at its own length and sensors, one run each:",
        "",
        *shipped,
        "",
    ]
