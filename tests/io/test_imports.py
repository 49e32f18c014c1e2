"""Import from MDF4 and TDMS through a channel-mapping file."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest

from monitor.cli import main
from monitor.errors import FormatError
from monitor.io import read_recording
from monitor.io.imports.dispatch import import_file
from monitor.io.imports.mapping import load_mapping
from monitor.io.imports.mdf import import_mdf
from monitor.io.imports.tdms import import_tdms
from monitor.io.imports.text import import_text
from tests.conftest import shared_path

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
    path.write_text(extra + MAPPING.format(acc=acc, tooth=tooth))
    return load_mapping(path)


def test_tdms_import(tmp_path: Path, rng: np.random.Generator) -> None:
    import nptdms

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
    import asammdf

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
    import nptdms

    from monitor.cli import main
    from monitor.io import read_recording

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


# ------------------------------------------------------------------------------------------ text exports
TEXT_MAPPING = """
engine_id = "medium-speed-6l32"
start_time = "2026-11-22T10:15:00Z"
{keys}
[[channel]]
source = {acc}
name = "mb3-vertical"
kind = "acceleration"
unit = "g"
[[channel]]
source = {tooth}
name = "tooth"
kind = "tooth"
unit = "V"
fields = {{ teeth = 60, missing_teeth = 2, first_tooth_angle_deg = 117.0 }}
"""


def _text_mapping(
    tmp_path: Path, keys: str = 'time_column = "time"', acc: str = '"acc"', tooth: str = '"tooth"'
):  # type: ignore[no-untyped-def]
    path = tmp_path / "map.toml"
    path.write_text(TEXT_MAPPING.format(keys=keys, acc=acc, tooth=tooth))
    return load_mapping(path)


def _bench_columns(
    rng: np.random.Generator, rate: float, n: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(n) / rate
    return t, rng.standard_normal(n).round(5), np.sin(2 * np.pi * 50 * t).round(5)


def _write_text(path: Path, rows: list[str], header: list[str] | None = None) -> Path:
    path.write_text("".join(f"{line}\n" for line in [*(header or []), *rows]))
    return path


@pytest.mark.parametrize(
    ("name", "delimiter", "decimal"),
    [("bench.csv", ",", "."), ("bench.csv", ";", ","), ("bench.tsv", "\t", "."), ("bench.dat", "  ", ",")],
    ids=["comma", "semicolon-decimal-comma", "tab", "whitespace-decimal-comma"],
)
def test_text_import_delimiters_and_header(
    tmp_path: Path, rng: np.random.Generator, name: str, delimiter: str, decimal: str
) -> None:
    t, acc, tooth = _bench_columns(rng, 5000.0, 2000)
    rows = [
        delimiter.join(f"{v:.6f}".replace(".", decimal) for v in row)
        for row in zip(t, acc, tooth, strict=True)
    ]
    path = _write_text(tmp_path / name, rows, header=[delimiter.join(["time", "acc", "tooth"])])
    recording = import_file(path, _text_mapping(tmp_path))
    assert recording.start_time == "2026-11-22T10:15:00Z"
    channel = recording.channel("mb3-vertical")
    assert channel.sample_rate == 5000.0 and channel.unit == "g" and channel.start_offset == 0.0
    assert channel.data.dtype == np.float32
    np.testing.assert_array_equal(channel.data, acc.astype(np.float32))
    np.testing.assert_array_equal(recording.channel("tooth").data, tooth.astype(np.float32))
    assert recording.channel("tooth").fields["teeth"] == 60


def test_text_import_column_numbers_header_rows_and_ms(tmp_path: Path, rng: np.random.Generator) -> None:
    """No names: columns by number; two header lines given; time in ms (printed to 1 us) from 2.5 s on."""
    t, acc, tooth = _bench_columns(rng, 25600.0, 6000)
    rows = [f"{1e3 * (2.5 + a):.3f},{b:.5f},{c:.5f}" for a, b, c in zip(t, acc, tooth, strict=True)]
    path = _write_text(tmp_path / "bench.csv", rows, header=["bench 4, run 7", "ms,g,V"])
    mapping = _text_mapping(
        tmp_path, 'time_column = 0\ntime_unit = "ms"\nheader_rows = 2', acc="1", tooth="2"
    )
    recording = import_text(path, mapping)
    channel = recording.channel("mb3-vertical")
    assert channel.sample_rate == 25600.0 and channel.start_offset == pytest.approx(2.5, abs=1e-12)
    np.testing.assert_array_equal(channel.data, acc.astype(np.float32))
    # a rate given in the mapping, and --rate's override of it, are taken as they are
    assert import_text(path, mapping, sample_rate_hz=25000.0).channel("tooth").sample_rate == 25000.0
    given = _text_mapping(tmp_path, "sample_rate_hz = 1000.0\nheader_rows = 2", acc="1", tooth="2")
    assert import_text(path, given).channel("tooth").sample_rate == 1000.0


@pytest.mark.parametrize(
    ("fmt", "seconds"), [("{:.6f}", 1.0), ("{:.6g}", 12.0)], ids=["rounded-to-1us", "6-significant-digits"]
)
def test_text_rate_derived_through_the_rounding_of_the_times(
    tmp_path: Path, rng: np.random.Generator, fmt: str, seconds: float
) -> None:
    """25.6 kHz: the intervals of times printed to 1 us are 39 or 40 us, and with 6 significant digits,
    after 10 s, coarser (100 us) than a sample interval; the rate is still 25.6 kHz, and a sample
    missing, or a time late by 4 us, is refused naming its line."""
    n = int(25600 * seconds)
    t = np.arange(n) / 25600.0
    values = rng.standard_normal(n).round(4)
    lines = [f"{fmt.format(a)}\t{b:.4f}\t{b:.4f}" for a, b in zip(t, values, strict=True)]
    path = _write_text(tmp_path / "bench.txt", lines, header=["time\tacc\ttooth"])
    mapping = _text_mapping(tmp_path)
    assert import_text(path, mapping).channel("tooth").sample_rate == pytest.approx(25600.0, rel=1e-9)
    gap = _write_text(tmp_path / "gap.txt", lines[:1000] + lines[1001:], header=["time\tacc\ttooth"])
    with pytest.raises(
        FormatError, match=r"time column 'time' is not sampled at a fixed rate: at line 1002 "
    ):
        import_text(gap, mapping)
    if seconds == 1.0:  # jitter of 4 us is within the rounding of 6 significant digits after 10 s
        late = [*lines]
        late[700] = f"{fmt.format(t[700] + 4e-6)}\t0.0\t0.0"
        jitter = _write_text(tmp_path / "late.txt", late, header=["time\tacc\ttooth"])
        with pytest.raises(FormatError, match=r"at line 702 the time steps by 4.3\d*e-05 s"):
            import_text(jitter, mapping)


def test_text_missing_or_unreadable_columns_are_refused(tmp_path: Path, rng: np.random.Generator) -> None:
    t, acc, tooth = _bench_columns(rng, 1000.0, 100)
    rows = [f"{a:.3f},{b:.5f},{c:.5f}" for a, b, c in zip(t, acc, tooth, strict=True)]
    path = _write_text(tmp_path / "bench.csv", rows, header=["time,acc,tooth"])
    with pytest.raises(
        FormatError, match=r"channel 'tooth': no column 'teeth'; the header has 'time', 'acc'"
    ):
        import_text(path, _text_mapping(tmp_path, tooth='"teeth"'))
    with pytest.raises(FormatError, match=r"channel 'tooth': there is no column 3; the rows have 3 columns"):
        import_text(path, _text_mapping(tmp_path, tooth="3"))
    with pytest.raises(FormatError, match=r"time_column: no column 't'; the header has"):
        import_text(path, _text_mapping(tmp_path, keys='time_column = "t"'))
    headless = _write_text(tmp_path / "headless.csv", rows)
    with pytest.raises(FormatError, match=r"no column 'acc': the file has no header row; expected a 0-based"):
        import_text(headless, _text_mapping(tmp_path, keys="time_column = 0"))
    broken = _write_text(
        tmp_path / "broken.csv", [*rows[:50], "0.050,x,0.1", *rows[51:]], header=["time,acc,tooth"]
    )
    with pytest.raises(FormatError, match=r"broken.csv: line 52, column 1 \(0-based\): 'x' is not a number"):
        import_text(broken, _text_mapping(tmp_path))
    with pytest.raises(FormatError, match=r"channel 'tooth': a text file carries no units; give unit"):
        text = TEXT_MAPPING.format(keys='time_column = "time"', acc='"acc"', tooth='"tooth"')
        (tmp_path / "nounit.toml").write_text(text.replace('unit = "V"\n', ""))
        import_text(path, load_mapping(tmp_path / "nounit.toml"))
    with pytest.raises(FormatError, match=r"no time column and no rate: give time_column or sample_rate_hz"):
        import_text(path, _text_mapping(tmp_path, keys=""))
    thousands = _write_text(tmp_path / "thousands.csv", ["1.000,5;2,5", "1.001,5;2,5"])
    with pytest.raises(FormatError, match=r"thousands separators"):
        import_text(thousands, _text_mapping(tmp_path, keys="time_column = 0", acc="1", tooth="1"))


def test_real_text_export_of_a_bench(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """../shared/external/tue-4gb10/E0NOLOAD1.txt: a test rig's own export, tab-separated without a
    header (time [s], 60-2 tooth-wheel sensor [V], cylinder pressure sensor [V], times printed to 7
    significant digits): 100 kHz derived from its times, the samples as the text has them."""
    path = shared_path("external", "tue-4gb10", "E0NOLOAD1.txt")
    mapping = tmp_path / "tue.toml"
    mapping.write_text(
        # first_tooth_angle_deg: TDC of the cylinder is 242.5 deg after the first tooth after the gap, by
        # the compression peak of the coast-down recorded on the same rig (tests/signal/test_signal.py)
        'engine_id = "kluczyk-1cyl-4stroke"\nstart_time = "2026-11-22T10:15:00Z"\ntime_column = 0\n'
        '[[channel]]\nsource = 1\nname = "tooth"\nkind = "tooth"\nunit = "V"\n'
        "fields = { teeth = 60, missing_teeth = 2, first_tooth_angle_deg = 117.5 }\n"
        '[[channel]]\nsource = 2\nname = "pressure"\nkind = "pressure"\nunit = "V"\n'
        "fields = { cylinder = 1 }\n"
    )
    recording = import_text(path, load_mapping(mapping))
    expected = np.loadtxt(path)
    for column, name in ((1, "tooth"), (2, "pressure")):
        channel = recording.channel(name)
        assert channel.sample_rate == pytest.approx(1e5, rel=1e-6) and channel.start_offset == 0.0
        assert channel.data.dtype == np.float32 and channel.data.size == 50000
        np.testing.assert_allclose(channel.data, expected[:, column], rtol=2.0**-24, atol=0)
    assert recording.channel("pressure").fields["cylinder"] == 1
    out = tmp_path / "tue.h5"
    assert main(["import", str(path), "--map", str(mapping), "-o", str(out)]) == 0
    assert "100000 Hz" in capsys.readouterr().out
    written = read_recording(out)
    assert written.engine_id == "kluczyk-1cyl-4stroke" and written.channel("tooth").sample_rate == 1e5
    np.testing.assert_array_equal(written.channel("tooth").data, recording.channel("tooth").data)


def test_mdf_times_rounded_to_1us_and_the_rate_override(tmp_path: Path, rng: np.random.Generator) -> None:
    """An MDF whose time stamps were rounded to 1 us (intervals of 39 and 40 us at 25.6 kHz) is 25.6 kHz;
    a rate given (mapping or --rate) is used as it is, even where the time stamps are irregular."""
    import asammdf

    from monitor.cli import main
    from monitor.io import read_recording

    t = np.round(np.arange(25600) / 25600.0, 6)
    assert set(np.round(np.diff(t) * 1e6).tolist()) == {39.0, 40.0}
    acc, tooth = rng.standard_normal(t.size), np.sin(t * 300) * 2
    mdf = asammdf.MDF(version="4.10")
    mdf.header.start_time = datetime(2026, 11, 22, 10, 15, tzinfo=UTC)
    mdf.append(
        [asammdf.Signal(acc, t, name="MB3_vert", unit="g"), asammdf.Signal(tooth, t, name="Teeth", unit="V")]
    )
    path = tmp_path / "bench.mf4"
    mdf.save(path)
    recording = import_mdf(path, _mapping(tmp_path, "MB3_vert", "Teeth"))
    assert recording.channel("mb3-vertical").sample_rate == 25600.0
    assert recording.channel("tooth").sample_rate == 25600.0
    dat = tmp_path / "bench.dat"  # MDF files may end in .dat too: told from text by their first bytes
    dat.write_bytes(path.read_bytes())
    assert import_file(dat, _mapping(tmp_path, "MB3_vert", "Teeth")).channel("tooth").sample_rate == 25600.0
    gap = asammdf.MDF(version="4.10")
    keep = np.arange(t.size) != 9000
    gap.append([asammdf.Signal(acc[keep], t[keep], name="MB3_vert", unit="g")])  # a group of its own
    gap.append([asammdf.Signal(tooth, t, name="Teeth", unit="V")])
    gap.save(tmp_path / "gap.mf4")
    with pytest.raises(FormatError, match=r"'MB3_vert' is not sampled at a fixed rate: at sample 9000 "):
        import_mdf(tmp_path / "gap.mf4", _mapping(tmp_path, "MB3_vert", "Teeth"))
    given = import_mdf(
        tmp_path / "gap.mf4", _mapping(tmp_path, "MB3_vert", "Teeth", "sample_rate_hz = 25600.0\n")
    )
    assert given.channel("mb3-vertical").sample_rate == 25600.0
    assert (
        import_mdf(path, _mapping(tmp_path, "MB3_vert", "Teeth"), sample_rate_hz=25000.0)
        .channel("tooth")
        .sample_rate
        == 25000.0
    )
    mapping = tmp_path / "map.toml"
    out = tmp_path / "gap.h5"
    assert main(["import", str(tmp_path / "gap.mf4"), "--map", str(mapping), "-o", str(out)]) == 2
    assert (
        main(["import", str(tmp_path / "gap.mf4"), "--map", str(mapping), "--rate", "25600", "-o", str(out)])
        == 0
    )
    assert read_recording(out).channel("mb3-vertical").sample_rate == 25600.0
    with pytest.raises(FormatError, match=r"time_column do not apply to a MDF file"):
        import_mdf(path, _mapping(tmp_path, "MB3_vert", "Teeth", 'time_column = "t"\n'))
