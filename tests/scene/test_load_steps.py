"""Load steps inside a scene: validated with clear errors, joined at the step, and nothing else changed."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from monitor.errors import SceneError
from monitor.scene import Scene, load_scene, parse_scene, simulate

SCENES = Path(__file__).resolve().parents[2] / "recordings" / "scenes"


def _data(**operating: Any) -> dict[str, Any]:
    return {
        "engine": "medium-speed-6l32",
        "duration_s": 4.0,
        "operating_point": {"speed_rpm": 750.0, **operating},
        "sensors": [
            {"name": "tooth", "kind": "tooth"},
            {"name": "p1", "kind": "pressure", "cylinder": 1},
            {"name": "cam", "kind": "cam", "representation": "events"},
        ],
        "effects": {"inertia": {}, "gas": {}, "crank_speed": {}, "noise": {"tooth": 0.05}},
    }


@pytest.mark.parametrize(
    ("steps", "effects", "message"),
    [
        ([{"time_s": 3.0, "load": 0.5}, {"time_s": 2.0, "load": 0.7}], None, r"times 3, 2 s must increase"),
        (
            [{"time_s": 4.0, "load": 0.5}],
            None,
            r"time_s = 4 s is not inside the recording \(duration_s = 4 s\)",
        ),
        (
            [{"time_s": 1.0, "load": 1.5}],
            None,
            r"load_steps\.0\.load: Input should be less than or equal to 1\.1",
        ),
        (
            [{"time_s": 1.0, "lode": 0.5}],
            None,
            r"load_steps\.0\.lode: unknown field \(fields: time_s, load\)",
        ),
        (
            [{"time_s": 1.0, "load": 0.5}],
            {"inertia": {}},
            r"load_steps change the gas pressure: add the effect 'gas'",
        ),
        (
            [{"time_s": 1.0, "load": 0.5}],
            {"inertia": {}, "gas": {}, "crank_speed": {"model": "shaft_line"}},
            r"joined on the rigid crank only",
        ),
    ],
)
def test_a_wrong_load_step_is_refused_with_what_to_change(
    steps: list[dict[str, float]], effects: dict[str, Any] | None, message: str
) -> None:
    data = _data(load_steps=steps)
    if effects is not None:
        data["effects"] = effects
    with pytest.raises(SceneError, match=message):
        parse_scene(data)


def _at(scene: Scene, **update: Any) -> Scene:
    return scene.model_copy(update={"operating_point": scene.operating_point.model_copy(update=update)})


def test_a_load_step_joins_the_two_loads_at_its_time_and_changes_nothing_before() -> None:
    """Before the step every channel is the steady scene's at the first load, sample for sample;
    after it the pressure is the steady scene's at the second load (the join): each cycle's peak
    equal within 0.5 % (the crank reaches its angles a little earlier or later after a step, so
    samples fall up to 0.18 deg apart near the peak, where the pressure changes by less than that
    share), and lower than at full load; the cam's events hardly move (the governor holds the mean
    speed: only the fluctuation changes)."""
    stepped = parse_scene(_data(load=1.0, load_steps=[{"time_s": 2.0, "load": 0.5}]))
    full = simulate(parse_scene(_data(load=1.0))).recording
    half = simulate(parse_scene(_data(load=0.5))).recording
    both = simulate(stepped).recording
    p_full, p_half, p_both = (r.channel("p1") for r in (full, half, both))
    t = p_both.times()
    before, after = t < 2.0, t >= 2.0
    np.testing.assert_array_equal(p_both.data[before], p_full.data[before])
    cycle = 0.16  # s, two revolutions at 750 rpm
    for start in np.arange(2.0 + cycle, 4.0 - cycle, cycle):
        inside = (t >= start) & (t < start + cycle)
        assert p_both.data[inside].max() == pytest.approx(p_half.data[inside].max(), rel=5e-3)
        assert p_both.data[inside].max() < 0.9 * p_full.data[inside].max()
    tooth_full, tooth_both = full.channel("tooth").data, both.channel("tooth").data
    np.testing.assert_array_equal(tooth_both[before], tooth_full[before])
    assert not np.array_equal(tooth_both[after], tooth_full[after])  # the speed's fluctuation follows
    # the cam pulse once a cycle: the mean speed is held, so its times move by the fluctuation only
    cam_full, cam_both = full.channel("cam").data, both.channel("cam").data
    assert cam_both.size == cam_full.size
    assert np.max(np.abs(cam_both - cam_full)) < 1e-3 * (cam_full[1] - cam_full[0])


def test_a_scene_without_steps_keeps_its_truth_and_one_with_steps_states_them() -> None:
    plain = simulate(load_scene(SCENES / "6l32-baseline.toml").model_copy(update={"duration_s": 1.0}))
    assert "load_steps" not in json.loads(plain.recording.truth)["operating_point"]
    stepped = simulate(parse_scene(_data(load_steps=[{"time_s": 2.0, "load": 0.5}])))
    assert stepped.truth["operating_point"]["load_steps"] == [{"time_s": 2.0, "load": 0.5}]
