"""Import from MDF4 and TDMS through a channel-mapping file."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest

from monitor.io.imports import import_mdf, import_tdms, load_mapping
from monitor.recording import FormatError

MAPPING = """
engine_id = "medium-speed-6l32"
notes = "bench 4"
[[channel]]
source = "{acc}"
name = "mb3-vertical"
kind = "acceleration"
location = "main bearing 3"
direction = "vertical"
scale = 9.80665
unit = "m/s^2"
[[channel]]
source = "{tooth}"
name = "tooth"
kind = "tooth"
fields = {{ teeth = 60, missing_teeth = 2, first_tooth_angle_deg = 117.0 }}
"""


def _mapping(tmp_path: Path, acc: str, tooth: str, extra: str = ""):  # type: ignore[no-untyped-def]
    path = tmp_path / "map.toml"
    path.write_text(MAPPING.format(acc=acc, tooth=tooth) + extra)
    return load_mapping(path)


def test_tdms_import(tmp_path: Path, rng: np.random.Generator) -> None:
    nptdms = pytest.importorskip("nptdms", reason="npTDMS (import extra) not installed")
    acc, tooth = rng.standard_normal(5000), np.sin(np.arange(5000) * 0.3) * 2
    props = {
        "wf_increment": 1 / 5000.0,
        "wf_start_offset": 0.0,
        "wf_start_time": np.datetime64("2026-11-22T10:15:00"),
    }
    path = tmp_path / "bench.tdms"
    with nptdms.TdmsWriter(str(path)) as writer:
        writer.write_segment(
            [
                nptdms.ChannelObject(
                    "Vibration", "MB3 vertical", acc, properties={**props, "unit_string": "g"}
                ),
                nptdms.ChannelObject("Speed", "Teeth", tooth, properties={**props, "unit_string": "V"}),
            ]
        )
    recording = import_tdms(path, _mapping(tmp_path, "Vibration/MB3 vertical", "Speed/Teeth"))
    assert recording.engine_id == "medium-speed-6l32" and recording.start_time.startswith(
        "2026-11-22T10:15:00"
    )
    channel = recording.channel("mb3-vertical")
    assert channel.sample_rate == pytest.approx(5000.0) and channel.unit == "m/s^2"
    np.testing.assert_allclose(channel.data, acc * 9.80665)
    assert recording.channel("tooth").fields["teeth"] == 60 and recording.channel("tooth").unit == "V"
    with pytest.raises(FormatError, match=r"no channel 'Vibration/MB9'; the file has ") as info:
        import_tdms(path, _mapping(tmp_path, "Vibration/MB9", "Speed/Teeth"))
    assert "Vibration/MB3 vertical" in str(info.value) and "Speed/Teeth" in str(info.value)


def test_mdf4_import(tmp_path: Path, rng: np.random.Generator) -> None:
    asammdf = pytest.importorskip("asammdf", reason="asammdf (import extra) not installed")
    t = np.arange(4000) / 2000.0
    acc, tooth = rng.standard_normal(t.size), np.sin(t * 40) * 2
    mdf = asammdf.MDF(version="4.10")
    mdf.header.start_time = datetime(2026, 11, 22, 10, 15, tzinfo=UTC)
    mdf.append(
        [asammdf.Signal(acc, t, name="MB3_vert", unit="g"), asammdf.Signal(tooth, t, name="Teeth", unit="V")]
    )
    path = tmp_path / "bench.mf4"
    mdf.save(path)
    recording = import_mdf(path, _mapping(tmp_path, "MB3_vert", "Teeth"))
    assert recording.start_time.startswith("2026-11-22T10:15:00")
    channel = recording.channel("mb3-vertical")
    assert channel.sample_rate == 2000.0
    np.testing.assert_allclose(channel.data, acc * 9.80665)
    irregular = asammdf.MDF(version="4.10")
    irregular.append(
        [
            asammdf.Signal(acc, np.sort(rng.uniform(0, 2, t.size)), name="MB3_vert"),
            asammdf.Signal(tooth, t, name="Teeth"),
        ]
    )
    irregular.save(tmp_path / "irregular.mf4")
    with pytest.raises(FormatError, match="'MB3_vert' is not sampled at a fixed rate"):
        import_mdf(tmp_path / "irregular.mf4", _mapping(tmp_path, "MB3_vert", "Teeth"))


def test_bad_mappings_are_refused(tmp_path: Path) -> None:
    path = tmp_path / "m.toml"
    path.write_text('engine_id = "x"\n[[channel]]\nsource = "a"\nname = "b"\nkind = "sound"\n')
    with pytest.raises(FormatError, match="kind 'sound' is unknown"):
        load_mapping(path)
    path.write_text('engine_id = "x"\n[[channel]]\nsource = "a"\nname = "b"\nkind = "velocity"\ncolour = 1\n')
    with pytest.raises(FormatError, match=r"channel\.0\.colour: Extra inputs are not permitted"):
        load_mapping(path)
    path.write_text('engine_id = "x"\n')
    with pytest.raises(FormatError, match="channel: Field required"):
        load_mapping(path)


def test_cli_import_to_hdf5_and_mcap(
    tmp_path: Path, rng: np.random.Generator, capsys: pytest.CaptureFixture[str]
) -> None:
    nptdms = pytest.importorskip("nptdms", reason="npTDMS (import extra) not installed")
    from monitor.cli import main
    from monitor.pipeline import read_recording

    props = {"wf_increment": 1 / 1000.0, "wf_start_offset": 0.0, "unit_string": "V"}
    path = tmp_path / "b.tdms"
    with nptdms.TdmsWriter(str(path)) as writer:
        writer.write_segment(
            [
                nptdms.ChannelObject("Vibration", "MB3 vertical", rng.standard_normal(100), properties=props),
                nptdms.ChannelObject("Speed", "Teeth", rng.standard_normal(100), properties=props),
            ]
        )
    mapping = tmp_path / "map.toml"
    text = MAPPING.format(acc="Vibration/MB3 vertical", tooth="Speed/Teeth")
    mapping.write_text('start_time = "2026-11-22T10:15:00Z"\n' + text)
    for out in ("r.h5", "r.mcap"):
        assert main(["import", str(path), "--map", str(mapping), "-o", str(tmp_path / out)]) == 0
        assert read_recording(tmp_path / out).channel("tooth").fields["missing_teeth"] == 2
    assert "mb3-vertical" in capsys.readouterr().out
    assert main(["import", str(tmp_path / "x.csv"), "--map", str(mapping), "-o", str(tmp_path / "y.h5")]) == 2
