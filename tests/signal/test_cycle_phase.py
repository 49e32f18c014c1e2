"""The four-stroke cycle phase given by the user, or left unknown, when no channel tells it."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest

from monitor.cli import main
from monitor.diagnosis import diagnose
from monitor.errors import FormatError, SignalError
from monitor.io import read_recording
from monitor.io.hdf5 import write_hdf5
from monitor.io.mcap.writer import write_mcap
from monitor.io.recording import Recording
from monitor.model.engine import load_engine
from monitor.signal.reference import angle_reference
from tests.conftest import ROOT

SAMPLE = ROOT / "recordings" / "samples" / "6l32-misfire-cyl3.h5"


def _without_cam() -> tuple[Recording, float]:
    """The bundled 6L32 misfire recording without its cam channel, and the phase its cam gave [rad]."""
    recording = read_recording(SAMPLE)
    with_cam = angle_reference(recording, cycle_revolutions=2)
    assert with_cam.cycle_phase == "cam"
    stripped = Recording(
        recording.engine_id, recording.start_time, tuple(c for c in recording.channels if c.kind != "cam")
    )
    plain = angle_reference(stripped, cycle_revolutions=2, cycle_phase=0.0)
    shift = float(with_cam.angle_map.angles[0] - plain.angle_map.angles[0])
    assert shift == pytest.approx(0.0, abs=1e-9) or shift == pytest.approx(2 * math.pi, abs=1e-9)
    return stripped, shift


def test_without_a_cam_the_phase_is_refused_then_given_then_left_unknown(tmp_path: Path) -> None:
    """No cam and no cylinder-1 pressure: refused with a message naming --cycle-phase; given the phase
    the cam gave, cylinder 3 is named alone; left unknown, cylinder 3 is named with the cylinder that
    fires 360 deg from it (or that one with cylinder 3)."""
    recording, shift = _without_cam()
    engine = load_engine("medium-speed-6l32")
    with pytest.raises(SignalError, match="--cycle-phase"):
        diagnose(recording, engine)
    given = diagnose(recording, engine, cycle_phase=shift)
    assert [f.subject for f in given.findings if f.kind == "cylinder"] == ["cylinder 3"]
    unknown = diagnose(recording, engine, cycle_phase="unknown")
    named = [f.subject for f in unknown.findings if f.kind == "cylinder"]
    assert len(named) == 1 and "cylinder 3" in named[0] and " or cylinder " in named[0], named
    assert any("cycle phase is unknown" in note for note in unknown.notes)
    path = write_hdf5(recording, tmp_path / "no-cam.h5")
    degrees = f"{math.degrees(shift):.0f}"
    assert main(["compare", str(path), "--cycle-phase", degrees]) == 2
    assert main(["compare", str(path), "--cycle-phase", "unknown"]) == 2
    assert main(["compare", str(path)]) == 3
    assert main(["spectrum", str(path), "--cycle-phase", degrees, "--orders", "0.5"]) == 0
    with pytest.raises(SystemExit) as refused:
        main(["spectrum", str(path), "--cycle-phase", "90"])
    assert refused.value.code == 2


@pytest.mark.parametrize("suffix", [".h5", ".mcap"])
def test_the_phase_stated_in_the_recording_is_used_and_kept_by_both_formats(
    tmp_path: Path, suffix: str
) -> None:
    """cycle_phase_deg written with the recording (HDF5 attribute, MCAP metadata) is read back and
    gives the same diagnosis as the cam did; a value other than 0 or 360 is refused."""
    recording, shift = _without_cam()
    stated = replace(recording, cycle_phase_deg=math.degrees(shift))
    path = (write_hdf5 if suffix == ".h5" else write_mcap)(stated, tmp_path / f"phase{suffix}")
    again = read_recording(path)
    assert again.cycle_phase_deg == pytest.approx(math.degrees(shift))
    diagnosis = diagnose(again, load_engine("medium-speed-6l32"))
    assert [f.subject for f in diagnosis.findings if f.kind == "cylinder"] == ["cylinder 3"]
    assert angle_reference(again, cycle_revolutions=2).cycle_phase == "recording"
    with pytest.raises(FormatError, match="cycle_phase_deg"):
        replace(recording, cycle_phase_deg=90.0)
