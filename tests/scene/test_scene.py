"""Scenes: parsing, dependency resolution, only-what-is-named, determinism, and the pipeline's recovery."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import monitor.scene.crank
import monitor.scene.sources
from monitor.cli import main
from monitor.errors import SceneError
from monitor.io import read_recording
from monitor.io.hdf5 import write_hdf5
from monitor.io.recording import Channel, Recording
from monitor.model.engine import bundled_engines, load_engine
from monitor.scene import EFFECTS, Scene, load_scene, parse_scene, simulate
from monitor.scene.synthesis import CycleTable, synthesise
from monitor.signal.measure import spectra
from monitor.signal.pitch import tooth_spacing_errors
from monitor.signal.pulses import detect_edges
from monitor.signal.toothwheel import decode_tooth_wheel
from monitor.torsion.axial_coupling import engine_axial_response
from monitor.torsion.shaft_line import shaft_line_of

SCENES = Path(__file__).resolve().parents[2] / "recordings" / "scenes"


def _without_tooth_noise(scene: Scene) -> Scene:
    """The scene with the noise of its tooth-wheel sensor left out."""
    noise = {k: v for k, v in scene.effects.get("noise", {}).items() if k != "tooth"}
    return scene.model_copy(update={"effects": {**scene.effects, "noise": noise}})


def _scene(effects: dict, *, sensors: list | None = None, engine: str = "man-b-w-7k98mc", **top):  # type: ignore[no-untyped-def, type-arg]
    data = {
        "engine": engine,
        "duration_s": 8.0,
        "operating_point": {"speed_rpm": 104.0},
        "sensors": sensors
        or [
            {
                "name": "mb2-vertical",
                "kind": "acceleration",
                "location": "main bearing 2",
                "direction": "vertical",
                "sample_rate_hz": 5120.0,
            },
            {"name": "tooth", "kind": "tooth", "sample_rate_hz": 10240.0},
        ],
        "effects": effects,
        **top,
    }
    return parse_scene(data)


MODES = {"modes": [{"frequency_hz": 300.0, "damping": 0.05, "gain": 1e-6}]}


@pytest.mark.parametrize(
    ("effects", "message"),
    [
        ({"misfires": {}}, r"unknown effect\(s\) misfires; known effects: .*misfire"),
        ({"gas": {"modle": "parametric"}}, r"effect 'gas': modle: unknown field \(fields: model, scale\)"),
        ({"crank_speed": {}}, r"'crank_speed' needs a torque: add one of external_torque, gas, inertia"),
        ({"bearing_vibration": MODES}, r"'bearing_vibration' needs a bearing force: add one of gas, inertia"),
        ({"inertia": {}, "misfire": {"cylinders": [4]}}, r"'misfire' changes 'gas': add gas"),
        ({"noise": {"mb9": 0.1}}, r"names sensor 'mb9', which the scene does not have"),
        (
            {"weak_cylinder": {"cylinder": 2, "scale": 1.5}, "gas": {}},
            r"scale: Input should be less than or equal to 1",
        ),
    ],
)
def test_bad_effects_are_refused_with_what_to_change(effects: dict, message: str) -> None:  # type: ignore[type-arg]
    with pytest.raises(SceneError, match=message):
        _scene(effects)


def test_bad_scene_fields_are_refused() -> None:
    with pytest.raises(SceneError, match=r"operating_point.speed_rpm: Input should be greater than 0"):
        parse_scene({"engine": "x", "duration_s": 1, "operating_point": {"speed_rpm": -1}, "sensors": []})
    with pytest.raises(SceneError, match=r"durations: unknown field"):
        _scene({}, durations=3)
    with pytest.raises(SceneError, match="sensor names must be unique; repeated: a"):
        _scene({}, sensors=[{"name": "a", "kind": "tooth"}, {"name": "a", "kind": "keyphasor"}])
    with pytest.raises(SceneError, match=r"misfire.* cylinder 9 does not exist"):
        simulate(_scene({"gas": {}, "misfire": {"cylinders": [9]}}))


def test_every_shipped_scene_parses_and_names_known_effects() -> None:
    files = sorted(SCENES.glob("*.toml"))
    assert len(files) >= 18
    for path in files:
        scene = load_scene(path)
        assert set(scene.effects) <= set(EFFECTS)


def test_an_effect_that_is_not_named_costs_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without force sources the crank-train model is never built; without crank_speed the rigid-body
    inertia and the torque integration are never evaluated."""

    def forbidden(*args, **kwargs):  # type: ignore[no-untyped-def]
        raise AssertionError("evaluated although not named")

    monkeypatch.setattr(monitor.scene.crank, "_rigid_inertia", forbidden)
    result = simulate(_scene({"inertia": {}, "bearing_vibration": MODES}))
    assert result.evaluated == ("inertia", "bearing_vibration")
    monkeypatch.setattr(monitor.scene.sources, "EngineModel", forbidden)
    quiet = simulate(_scene({"noise": {"mb2-vertical": 0.1}}))
    assert quiet.evaluated == ("noise",)
    assert np.std(quiet.recording.channel("mb2-vertical").data) == pytest.approx(0.1, rel=0.05)


def test_the_same_scene_and_seed_give_identical_files(tmp_path: Path) -> None:
    scene = _scene({"inertia": {}, "gas": {}, "bearing_vibration": MODES, "noise": {"mb2-vertical": 0.01}})
    first = write_hdf5(simulate(scene, seed=5).recording, tmp_path / "a.h5")
    second = write_hdf5(simulate(scene, seed=5).recording, tmp_path / "b.h5")
    other = write_hdf5(simulate(scene, seed=6).recording, tmp_path / "c.h5")
    assert first.read_bytes() == second.read_bytes()
    assert first.read_bytes() != other.read_bytes()


def test_the_pipeline_recovers_the_orders_the_model_predicts() -> None:
    """Baseline 7K98MC: the accelerometer orders the truth states (model at the mean speed, through the
    scene's mode) are recovered from the simulated waveforms, through the tooth wheel's angle map, where
    they stand clear of the noise: amplitude within 2 %, phase within 2 deg."""
    simulation = simulate(load_scene(SCENES / "7k98mc-baseline.toml"))
    result = spectra(simulation.recording, cycle_revolutions=1, max_order=24)
    for name in ("mb2-vertical", "mb5-vertical"):
        truth = simulation.truth["expected_orders"][name]
        measured = result.spectra[name]
        floor = 5 * 0.005 * math.sqrt(2 / (256 * measured.blocks))  # five times the noise per order
        checked = 0
        for k in range(1, 25):
            if truth["amplitude"][k] > 10 * floor:
                assert abs(measured.amplitude[k]) == pytest.approx(truth["amplitude"][k], rel=0.02)
                phase = math.degrees(np.angle(measured.amplitude[k])) - truth["phase_deg"][k]
                assert abs(math.remainder(phase, 360)) < 2.0
                checked += 1
            else:
                assert abs(measured.amplitude[k]) < truth["amplitude"][k] + floor
        assert checked >= 10


def test_nothing_beyond_the_noise_where_no_named_effect_gives_an_order() -> None:
    """An unbalance alone excites the first order only: every other order stays at the noise floor."""
    scene = _scene(
        {
            "unbalance": {"throw": 2, "kgm": 2000.0},  # between main bearings 2 and 3
            "bearing_vibration": {"modes": [{"frequency_hz": 5.0, "damping": 0.05, "gain": 1e-6}]},
            "noise": {"mb2-vertical": 0.001},
        }
    )
    simulation = simulate(scene)
    kp = {"name": "kp", "kind": "keyphasor", "representation": "events"}
    with_kp = simulate(_scene(scene.effects, sensors=[*[s.model_dump() for s in scene.sensors], kp]))
    assert with_kp.evaluated == simulation.evaluated
    spectrum = spectra(simulation.recording, cycle_revolutions=1, max_order=12).spectra["mb2-vertical"]
    floor = 5 * 0.001 * math.sqrt(2 / (256 * spectrum.blocks))
    truth = simulation.truth["expected_orders"]["mb2-vertical"]
    assert abs(spectrum.amplitude[1]) == pytest.approx(truth["amplitude"][1], rel=0.02)
    assert truth["amplitude"][1] > 20 * floor
    assert np.all(np.abs(spectrum.amplitude[2:]) < floor)


def test_a_misfire_changes_the_crank_speed_as_the_model_says() -> None:
    """Misfire of cylinder 4 against the baseline: the crank-speed orders the rigid-body model gives
    (the truth) are recovered from the tooth wheel up to order 10, within 1 % or 0.5 % of the largest
    order (58 pulses per revolution: the speed spline follows orders up to about a sixth of them this
    closely; the tooth wheel without its noise); the low orders, which cancel between seven equal
    cylinders, appear with the misfire."""
    measured, truths = [], []
    for name in ("7k98mc-baseline", "7k98mc-misfire-cyl4"):
        simulation = simulate(_without_tooth_noise(load_scene(SCENES / f"{name}.toml")))
        speed = spectra(simulation.recording, cycle_revolutions=1, max_order=24).spectra["crank speed"]
        truth = np.asarray(
            simulation.truth["expected_orders"]["crank speed"]["amplitude"][: speed.orders.size]
        )
        big = truth[1:11] > 1e-3 * truth[1:].max()
        assert np.count_nonzero(big) >= 1
        np.testing.assert_allclose(
            speed.magnitude[1:11][big], truth[1:11][big], rtol=0.01, atol=5e-3 * truth[1:].max()
        )
        measured.append(speed.magnitude)
        truths.append(truth)
    assert truths[1][1] > 100 * truths[0][1] and measured[1][1] > 100 * measured[0][1]
    assert truths[1][7] < truths[0][7] and measured[1][7] < measured[0][7]


def test_cli_simulates_and_prints_the_truth(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r.mcap"
    scene = SCENES / "zubaydi-1cyl-baseline.toml"
    assert main(["simulate", str(scene), "-o", str(out), "--seed", "3"]) == 0
    assert read_recording(out).channel("mb1-vertical").data.size == 5 * 25600
    capsys.readouterr()
    assert main(["simulate", "--truth", str(out)]) == 0
    truth = json.loads(capsys.readouterr().out)
    assert truth["seed"] == 3 and truth["engine"] == "zubaydi-1cyl-2stroke"
    assert main(["simulate", str(scene)]) == 2
    assert "needs SCENE.toml and -o" in capsys.readouterr().err


def test_a_velocity_sensor_reads_the_acceleration_integrated_in_mm_per_s() -> None:
    sensors = [
        {
            "name": "a",
            "kind": "acceleration",
            "location": "main bearing 2",
            "direction": "vertical",
            "sample_rate_hz": 5120.0,
        },
        {
            "name": "v",
            "kind": "velocity",
            "location": "main bearing 2",
            "direction": "vertical",
            "sample_rate_hz": 5120.0,
        },
    ]
    truth = simulate(_scene({"inertia": {}, "gas": {}, "bearing_vibration": MODES}, sensors=sensors)).truth
    a, v = truth["expected_orders"]["a"], truth["expected_orders"]["v"]
    omega = 104.0 * math.pi / 30
    assert v["unit"] == "mm/s"
    for k in (1, 7, 14):
        assert v["amplitude"][k] == pytest.approx(1e3 * a["amplitude"][k] / (k * omega), rel=1e-9)
        assert math.remainder(v["phase_deg"][k] - a["phase_deg"][k] + 90.0, 360.0) == pytest.approx(
            0, abs=1e-9
        )


def _sensors(*extra: dict) -> list[dict]:  # type: ignore[type-arg]
    return [
        {
            "name": "mb2-vertical",
            "kind": "acceleration",
            "location": "main bearing 2",
            "direction": "vertical",
            "sample_rate_hz": 10240.0,
        },
        {
            "name": "mb5-vertical",
            "kind": "acceleration",
            "location": "main bearing 5",
            "direction": "vertical",
            "sample_rate_hz": 10240.0,
        },
        *extra,
    ]


def test_an_external_torque_alone_drives_the_crank_speed() -> None:
    """A blade-order torque (order 4) and nothing else: the crank speed shows order 4 as the rigid body
    (the engine side, free end to the turning wheel) turns it, and the truth states it; no cylinder
    model is built."""
    scene = _scene(
        {
            "external_torque": {"orders": [{"order": 4, "amplitude_nm": 5e5, "phase_deg": 30}]},
            "crank_speed": {},
        },
        sensors=[{"name": "tooth", "kind": "tooth", "representation": "events"}],
    )
    simulation = simulate(scene)
    assert simulation.evaluated == ("external_torque", "crank_speed")
    truth = simulation.truth["expected_orders"]["crank speed"]["amplitude"]
    speed = spectra(simulation.recording, cycle_revolutions=1, max_order=12).spectra["crank speed"]
    assert speed.magnitude[4] == pytest.approx(truth[4], rel=0.01)
    omega = 104 * math.pi / 30

    line = shaft_line_of(load_engine(bundled_engines()["man-b-w-7k98mc"]))
    engine_side = line.node_names.index("turning wheel")  # the rigid body: free end to the flywheel
    inertia = sum(n.inertia for n in line.nodes[: engine_side + 1])
    assert truth[4] == pytest.approx(5e5 / (4 * inertia * omega), rel=0.01)  # first order: T / (k J Omega)
    assert max(speed.magnitude[k] for k in (1, 2, 3, 5, 6, 7)) < 1e-3 * speed.magnitude[4]


def test_a_worn_bearing_raises_the_higher_orders_at_its_own_sensor() -> None:
    base = {"inertia": {}, "gas": {}, "bearing_vibration": MODES}
    worn = {**base, "worn_bearing": {"bearing": 2, "severity": 0.5}}
    level = {}
    for label, effects in (("base", base), ("worn", worn)):
        simulation = simulate(
            _scene(effects, sensors=_sensors({"name": "tooth", "kind": "tooth", "representation": "events"}))
        )
        result = spectra(simulation.recording, cycle_revolutions=1, max_order=60)
        level[label] = {
            n: float(np.sum(result.spectra[n].magnitude[30:61])) for n in ("mb2-vertical", "mb5-vertical")
        }
    assert "mb2-vertical knocks" in simulation.truth["expected_orders"]
    assert level["worn"]["mb2-vertical"] > 5 * level["base"]["mb2-vertical"]
    assert level["worn"]["mb5-vertical"] == pytest.approx(level["base"]["mb5-vertical"], rel=1e-6)


def test_sensor_faults_are_put_in_and_found_by_the_pipeline(tmp_path: Path) -> None:
    """Keyphasor dropouts and extras (repaired, counted), tooth-spacing errors (recovered per tooth),
    a clipped channel (reported with its spans on reading), a gain error (the orders scaled)."""

    effects = {
        "inertia": {},
        "gas": {},
        "bearing_vibration": MODES,
        "keyphasor_faults": {"sensor": "kp", "dropouts": 2, "extras": 1},
        "tooth_spacing_errors": {"sensor": "tooth", "rms_deg": 0.1},
        "clipping": {"sensor": "mb5-vertical", "limit": 2e-5},
        "gain_error": {"sensor": "mb2-vertical", "gain": 1.2},
    }
    sensors = _sensors(
        {"name": "kp", "kind": "keyphasor", "sample_rate_hz": 10240.0},
        {"name": "tooth", "kind": "tooth", "sample_rate_hz": 51200.0},
    )
    simulation = simulate(_scene(effects, sensors=sensors))
    recording = read_recording(write_hdf5(simulation.recording, tmp_path / "faults.h5"))
    kp_only = type(recording)(
        recording.engine_id, recording.start_time, tuple(c for c in recording.channels if c.name != "tooth")
    )
    reference = spectra(kp_only, cycle_revolutions=1, max_order=4, channels=[]).reference
    assert reference.source == "kp" and reference.repairs == 3
    tooth = recording.channel("tooth")
    decoding = decode_tooth_wheel(detect_edges(tooth.data, tooth.sample_rate).times, teeth=60, missing=2)
    truth = np.radians(simulation.truth["expected_orders"]["tooth tooth errors"]["error_deg"][:58])
    truth = truth - truth[0]
    truth -= truth.mean()
    np.testing.assert_allclose(tooth_spacing_errors(decoding), truth, atol=np.radians(0.005))
    assert (
        recording.channel("mb5-vertical").quality
        and recording.channel("mb5-vertical").quality[0].reason == "clipped"
    )
    # the gain, on the orders through a clean keyphasor (the tooth errors would blur the angle map)
    clean = simulate(
        _scene(
            {k: v for k, v in effects.items() if k not in ("keyphasor_faults", "tooth_spacing_errors")},
            sensors=sensors[:3],
        )
    )
    gained = spectra(clean.recording, cycle_revolutions=1, max_order=12, channels=["mb2-vertical"])
    expected = np.asarray(clean.truth["expected_orders"]["mb2-vertical"]["amplitude"][:13])
    big = expected > 0.05 * expected.max()
    np.testing.assert_allclose(gained.spectra["mb2-vertical"].magnitude[big], 1.2 * expected[big], rtol=0.01)


def test_a_run_up_through_a_torsional_critical_peaks_where_the_campbell_diagram_says() -> None:
    """7K98MC from 40 to 60 rpm, crank speed by the shaft-line model: the tooth wheel's order-4 speed
    fluctuation, measured over 8 s windows, peaks within 1 rpm of the first mode's order-4 critical
    speed computed from the natural frequency (an independent route: eigenvalues, not forced response)."""

    simulation = simulate(load_scene(SCENES / "7k98mc-run-up.toml"))
    assert "crank_speed" in simulation.evaluated
    tooth = simulation.recording.channel("tooth")
    rpm, level = [], []
    for start in np.arange(0.0, 240.0, 8.0):
        edges = tooth.data[(tooth.data >= start) & (tooth.data < start + 8.0)]
        window = Recording(
            "man-b-w-7k98mc",
            simulation.recording.start_time,
            (Channel("tooth", "tooth", "s", edges, None, fields=tooth.fields),),
        )
        result = spectra(window, cycle_revolutions=1, max_order=8)
        rpm.append(result.mean_speed * 30 / math.pi)
        level.append(result.spectra["crank speed"].magnitude[4])
    first_mode = shaft_line_of(load_engine(bundled_engines()["man-b-w-7k98mc"])).modes().frequencies_hz[0]
    critical = first_mode * 60 / 4
    assert 45 < critical < 55
    assert rpm[int(np.argmax(level))] == pytest.approx(critical, abs=1.0)
    assert max(level) > 5 * level[0] and max(level) > 5 * level[-1]


@pytest.mark.parametrize("path", sorted(SCENES.glob("*.toml")), ids=lambda p: p.stem)
def test_every_shipped_scene_simulates_and_reads_back(path: Path, tmp_path: Path) -> None:
    """Each scene, cut to its first 12 s, simulates with the effects it names and round-trips through HDF5
    with its truth."""
    scene = load_scene(path)
    short = scene.model_copy(update={"duration_s": min(scene.duration_s, 12.0)})
    simulation = simulate(short)
    assert set(simulation.evaluated) == set(scene.effects)
    back = read_recording(write_hdf5(simulation.recording, tmp_path / "r.h5"))
    assert [c.name for c in back.channels] == [s.name for s in scene.sensors]
    assert json.loads(back.truth)["engine"] == load_scene(path).engine


@pytest.mark.parametrize("revolutions", [1, 2])
def test_the_tabulated_cycle_equals_the_direct_sum_of_orders(revolutions: int) -> None:
    """The per-sample synthesis by table (angle and speed interpolation) against the direct sum of
    complex exponentials: within 1e-5 of the sum of the coefficients' magnitudes (the signal's bound)."""

    rng = np.random.default_rng(revolutions)
    orders = np.arange(0, 36 * revolutions + 1) / revolutions
    speeds = np.linspace(5.0, 6.0, 65)
    base = rng.standard_normal(orders.size) + 1j * rng.standard_normal(orders.size)
    coefficients = base[None, :] * (1 + 0.3 * (speeds[:, None] - 5.0))  # linear in speed
    table = CycleTable.of(coefficients, orders, revolutions, speeds)
    angle = rng.uniform(0, 200.0, 5000)
    speed = rng.uniform(5.0, 6.0, angle.size)
    direct = synthesise(base[None, :] * (1 + 0.3 * (speed[:, None] - 5.0)), orders, angle)
    bound = np.abs(coefficients).sum(axis=1).max()
    np.testing.assert_allclose(table.at(angle, speed), direct, rtol=0, atol=1e-5 * bound)


SAMPLES = sorted((SCENES.parent / "samples").glob("*.h5"))


@pytest.mark.parametrize("path", SAMPLES, ids=lambda p: p.stem)
def test_the_committed_sample_recordings_are_what_their_scenes_give(path: Path) -> None:
    """recordings/samples/ (written by `make samples`): every sample equals a fresh simulation of its
    scene, and its expected-summary file is the truth stored in it.

    Equal as a physicist compares signals: a waveform within 1e-6 of its rms, where a float32 sample
    carries 6e-8 of its own size (a peak of a few rms is a few 1e-7 of the rms). Not bit for bit: the
    simulation's sums and FFTs round differently on CPUs with other vector units (one sample in 10^5
    was seen one unit apart), and the float32 store then rounds to the neighbouring value; pulse
    times within a nanosecond. Bit for bit is what one machine gives twice (the next test)."""
    stored = read_recording(path)
    expected = json.loads(path.with_suffix(".expected.json").read_text(encoding="utf-8"))
    assert json.loads(stored.truth) == expected
    scene = load_scene(SCENES / f"{path.stem}.toml").model_copy(update={"duration_s": expected["duration_s"]})
    fresh = simulate(scene, seed=expected["seed"]).recording
    for channel in fresh.channels:
        kept = np.asarray(stored.channel(channel.name).data, dtype=np.float64)
        if channel.is_events:  # pulse times: within a nanosecond (float64 seconds hold 1e-15 of a minute)
            np.testing.assert_allclose(kept, channel.data, rtol=0, atol=1e-9, err_msg=channel.name)
            continue
        rms = float(np.sqrt(np.mean(kept**2))) if kept.size else 0.0
        np.testing.assert_allclose(kept, channel.data, rtol=0, atol=1e-6 * rms, err_msg=channel.name)


def test_a_scene_simulates_the_same_twice_on_one_machine() -> None:
    """Determinism: the same scene and seed, simulated twice in one process, give the same samples bit
    for bit (the same arithmetic in the same order on the same CPU)."""
    scene = load_scene(SCENES / "7k98mc-misfire-cyl4.toml").model_copy(update={"duration_s": 2.0})
    first, second = simulate(scene, seed=7).recording, simulate(scene, seed=7).recording
    for a in first.channels:
        np.testing.assert_array_equal(a.data, second.channel(a.name).data, err_msg=a.name)


def test_there_are_committed_samples() -> None:
    assert len(SAMPLES) >= 3
    assert sum(p.stat().st_size for p in SAMPLES) < 8e6  # a few MB in all


def test_axial_vibration_follows_the_coupled_model_and_is_recovered() -> None:
    """An axial accelerometer at the free end: its orders equal -(k w)^2 times the axial displacement of
    journal 1 from engine_axial_response (the torque orders there come from predict_orders, another
    route than the scene's cylinder-by-cylinder sum), and the pipeline recovers them."""

    sensors = [
        {
            "name": "axial",
            "kind": "acceleration",
            "location": "free end",
            "direction": "axial",
            "sample_rate_hz": 5120.0,
        },
        {"name": "tooth", "kind": "tooth", "representation": "events"},
    ]
    simulation = simulate(_scene({"inertia": {}, "gas": {}, "axial_vibration": {}}, sensors=sensors))
    assert simulation.evaluated == ("inertia", "gas", "axial_vibration")
    truth = simulation.truth["expected_orders"]["axial"]
    omega = 104 * math.pi / 30
    reference = engine_axial_response(
        load_engine(bundled_engines()["man-b-w-7k98mc"]), [omega], load=1.0, max_order=14
    )
    for k in (1, 7, 14):
        expected = -((k * omega) ** 2) * reference.axial[0, 0, k - 1]
        assert truth["amplitude"][k] == pytest.approx(abs(expected), rel=1e-6)
    measured = spectra(simulation.recording, cycle_revolutions=1, max_order=14).spectra["axial"]
    big = np.asarray(truth["amplitude"][:15]) > 0.01 * max(truth["amplitude"][:15])
    np.testing.assert_allclose(measured.magnitude[big], np.asarray(truth["amplitude"][:15])[big], rtol=0.01)


def test_a_four_stroke_scene_is_recovered_in_half_orders() -> None:
    """6L32 baseline: cycle phase from the cam, half orders; the accelerometer orders the truth states
    are recovered where they stand clear of the noise (2 %, 2 deg), and the crank speed's firing
    order (3, six cylinders in 720 deg) within 1 % (the tooth wheel without its noise)."""
    simulation = simulate(_without_tooth_noise(load_scene(SCENES / "6l32-baseline.toml")))
    result = spectra(simulation.recording, cycle_revolutions=2, max_order=12)
    assert result.reference.cycle_phase == "cam"
    name = "mb3-vertical"
    truth = simulation.truth["expected_orders"][name]
    measured = result.spectra[name]
    assert measured.orders[1] == 0.5 and truth["orders"][1] == 0.5
    samples = 64  # spectra's default grid for max_order 12 on a four-stroke at steady speed
    floor = 5 * 0.01 * math.sqrt(2 / (samples * measured.blocks))
    checked = 0
    for i in range(1, measured.orders.size):
        if truth["amplitude"][i] > 10 * floor:
            assert abs(measured.amplitude[i]) == pytest.approx(truth["amplitude"][i], rel=0.02)
            phase = math.degrees(np.angle(measured.amplitude[i])) - truth["phase_deg"][i]
            assert abs(math.remainder(phase, 360)) < 2.0
            checked += 1
    assert checked >= 8
    speed = result.spectra["crank speed"]
    speed_truth = simulation.truth["expected_orders"]["crank speed"]["amplitude"]
    assert speed.magnitude[6] == pytest.approx(speed_truth[6], rel=0.01)  # order 3 = index 6 in half orders


@pytest.mark.parametrize(
    "name",
    [
        p.stem
        for p in sorted(SCENES.glob("*.toml"))
        if p.stem.startswith(("7k98mc-misfire", "6l32-misfire", "7k98mc-weak", "7k98mc-worn"))
    ],
)
def test_every_faulty_engine_scene_is_recovered(name: str) -> None:
    """Each misfire, the weak cylinder and the worn bearing (10 s of each, the tooth wheel without its
    noise: the chain's accuracy, not the noise's; the bad sensors' tooth errors blur the speed on
    purpose, tested apart): the crank-speed orders below a sixth of the tooth count that stand above
    1 % of the largest match the truth within 2 % or 0.5 % of the largest."""
    scene = _without_tooth_noise(load_scene(SCENES / f"{name}.toml"))
    simulation = simulate(scene.model_copy(update={"duration_s": 10.0}))
    revolutions = 2 if name.startswith("6l32") else 1
    speed = spectra(simulation.recording, cycle_revolutions=revolutions, max_order=10).spectra["crank speed"]
    truth = np.asarray(simulation.truth["expected_orders"]["crank speed"]["amplitude"][: speed.orders.size])
    top = truth[1:].max()
    big = truth[1:] > 0.01 * top
    np.testing.assert_allclose(speed.magnitude[1:][big], truth[1:][big], rtol=0.02, atol=5e-3 * top)


def test_a_healthy_seven_cylinder_engine_turns_with_the_firing_orders_only() -> None:
    """Seven equal cylinders evenly fired: their torques cancel except at multiples of order 7, so the
    truth holds nothing else, and the tooth wheel's speed (without its noise) shows nothing else above
    2e-3 of order 7 (the floor of simulation and analysis together)."""
    simulation = simulate(_without_tooth_noise(load_scene(SCENES / "7k98mc-baseline.toml")))
    truth = np.asarray(simulation.truth["expected_orders"]["crank speed"]["amplitude"][:22])
    speed = spectra(simulation.recording, cycle_revolutions=1, max_order=21).spectra["crank speed"].magnitude
    others = np.array([k for k in range(1, 22) if k % 7])
    assert np.all(truth[others] < 1e-9 * truth[7])
    assert np.all(speed[others] < 2e-3 * speed[7])


def test_the_secondary_resonance_case_of_paper_002() -> None:
    """The equivalent variable-inertia crank of the 7K98MC at r = 1/10, twisted and let go: the truth is
    the Floquet harmonic content (principal order near 10, secondary components at 8 and 12, as paper
    002 Table 2 shows for epsilon 0.34); the tooth wheel's angular vibration shows the same pattern.
    The principal order (10.04, not whole) is within 2 % in the blocks' mean magnitude; the secondary
    components, which leak a little into their neighbours, within 15 %, and they are the largest after
    the principal."""
    simulation = simulate(load_scene(SCENES / "7k98mc-secondary-resonance.toml"))
    truth = simulation.truth["expected_orders"]["crank angular vibration"]
    assert truth["r"] == pytest.approx(0.1, rel=1e-6) and truth["principal_order"] == pytest.approx(
        10, abs=0.1
    )
    amplitude = dict(zip(np.rint(truth["orders"]).astype(int).tolist(), truth["amplitude"], strict=True))
    vibration = spectra(simulation.recording, cycle_revolutions=1, max_order=16).spectra[
        "crank angular vibration"
    ]
    measured = vibration.magnitude_mean
    assert measured[10] == pytest.approx(amplitude[10], rel=0.02)
    assert measured[8] == pytest.approx(amplitude[8], rel=0.15)
    assert measured[12] == pytest.approx(amplitude[12], rel=0.15)
    ranked = [int(k) for k in np.argsort(measured[4:17])[::-1] + 4]
    assert ranked[0] == 10 and set(ranked[1:3]) == {8, 12}


def test_the_variable_inertia_crank_is_refused_where_it_does_not_apply() -> None:
    vi = {"crank_speed": {"model": "variable_inertia"}}
    with pytest.raises(SceneError, match="driven by the reciprocating parts' inertia: add inertia"):
        simulate(_scene({"gas": {}, **vi}))
    ramp = {"speed_rpm": 20.0, "trend": {"kind": "ramp", "to_rpm": 30.0}}
    with pytest.raises(SceneError, match="is for a constant speed"):
        simulate(_scene({"inertia": {}, **vi}, operating_point=ramp))


def test_per_cylinder_gas_scale_and_per_sensor_modes() -> None:
    """gas.scale sets each cylinder's heat release (0.7 on cylinder 4 is the weak-cylinder fault), and a
    sensor given its own modes responds through them, not the common ones."""
    weak = simulate(_scene({"gas": {}, "inertia": {}, "weak_cylinder": {"cylinder": 4, "scale": 0.7}}))
    scaled = simulate(_scene({"gas": {"scale": [1, 1, 1, 0.7, 1, 1, 1]}, "inertia": {}}))
    assert scaled.truth["cylinder_gas_scale"] == weak.truth["cylinder_gas_scale"]
    for a, b in zip(weak.recording.channels, scaled.recording.channels, strict=True):
        np.testing.assert_array_equal(a.data, b.data)
    with pytest.raises(SceneError, match="scale has 3 values; the engine has 7 cylinders"):
        simulate(_scene({"gas": {"scale": [1, 1, 1]}}))
    own = [{"frequency_hz": 30.0, "damping": 0.05, "gain": 1e-6}]
    modes = {**MODES, "sensors": {"mb2-vertical": own}}
    common = simulate(_scene({"inertia": {}, "bearing_vibration": MODES})).truth["expected_orders"][
        "mb2-vertical"
    ]
    special = simulate(_scene({"inertia": {}, "bearing_vibration": modes})).truth["expected_orders"][
        "mb2-vertical"
    ]
    f = 2 * (104 / 60)  # order 2 [Hz]

    def denominator(fn: float) -> float:  # |fn^2 - f^2 + 2 j zeta fn f| of one mode (same gain)
        return abs(fn**2 - f**2 + 2j * 0.05 * fn * f)

    assert special["amplitude"][2] / common["amplitude"][2] == pytest.approx(
        denominator(300.0) / denominator(30.0), rel=1e-9
    )
    with pytest.raises(SceneError, match="gives modes to mb9, which the scene does not have"):
        _scene({"inertia": {}, "bearing_vibration": {**MODES, "sensors": {"mb9": own}}})


def test_review_findings_are_refused_or_recorded() -> None:
    """A review found silent cases: a bearing the engine lacks, a fault the variable-inertia crank cannot
    take, an axial model with no cylinder torque, a scene too short to sample; each is now refused with
    what to change, and the truth records the pressure model used."""
    bad_location = [
        {"name": "a", "kind": "acceleration", "location": "main bearing 99", "direction": "vertical"}
    ]
    with pytest.raises(SceneError, match=r"'main bearing 99': expected 'main bearing N' with N = 1\.\.8"):
        simulate(_scene({}, sensors=bad_location))
    with pytest.raises(SceneError, match="worn_bearing': bearing 99 does not exist"):
        simulate(_scene({"inertia": {}, "worn_bearing": {"bearing": 99, "severity": 1.0}}))
    with pytest.raises(SceneError, match="remove misfire or use the rigid or shaft_line model"):
        simulate(
            _scene(
                {
                    "inertia": {},
                    "gas": {},
                    "misfire": {"cylinders": [2]},
                    "crank_speed": {"model": "variable_inertia"},
                }
            )
        )
    axial = [{"name": "x", "kind": "acceleration", "location": "free end", "direction": "axial"}]
    with pytest.raises(SceneError, match="axial_vibration is driven by the cylinders' torques"):
        simulate(
            _scene(
                {"external_torque": {"orders": [{"order": 4, "amplitude_nm": 1e5}]}, "axial_vibration": {}},
                sensors=axial,
            )
        )
    with pytest.raises(SceneError, match="fewer than 16 samples"):
        _scene({}, duration_s=1e-5)
    with pytest.raises(SceneError, match=r"locaton: unknown field \(fields: name, kind, location"):
        _scene({}, sensors=[{"name": "a", "kind": "tooth", "locaton": "x"}])
    assert simulate(_scene({"gas": {}, "misfire": {"cylinders": [2]}})).truth["gas_model"] == "parametric"
