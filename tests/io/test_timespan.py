"""A recording cut to a span of time: the samples and events inside it, at their own times."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from monitor.errors import FormatError
from monitor.io import open_recording
from monitor.io.hdf5 import write_hdf5
from monitor.io.recording import Channel, Recording, SampleReader
from monitor.io.timespan import between


def _recording(rng: np.random.Generator) -> Recording:
    rate = 1000.0
    data = rng.standard_normal(5000)
    data[2100:2110] = np.nan  # a masked span, inside the cut
    wave = Channel("mb1", "acceleration", "m/s^2", data, rate, start_offset=0.25, location="main bearing 1")
    events = Channel("kp", "keyphasor", "s", np.arange(0.1, 5.0, 0.3), None, fields={"pulse_angle_deg": 0.0})
    return Recording("e1", "2026-01-01T00:00:00Z", (wave.checked(), events), notes="bench")


def test_the_cut_holds_the_samples_and_events_inside_the_span_at_their_own_times() -> None:
    """Independent of the cut's arithmetic: every kept sample's time (from the channel's own times)
    lies in the span, the ones just outside do not, and the values are those at those times."""
    whole = _recording(np.random.default_rng(1))
    cut = between(whole, 1.5004, 3.2)
    wave, part = whole.channel("mb1"), cut.channel("mb1")
    times, kept = wave.times(), part.times()
    inside = (times >= 1.5004) & (times <= 3.2)
    np.testing.assert_allclose(kept, times[inside], rtol=0, atol=1e-12)  # the new offset: round-off
    np.testing.assert_array_equal(part.data, wave.data[inside])
    assert part.mask is not None and part.mask.sum() == 10 and part.quality[0].reason == "nan"
    events = whole.channel("kp").data
    np.testing.assert_array_equal(cut.channel("kp").data, events[(events >= 1.5004) & (events <= 3.2)])
    assert cut.notes == "bench; cut to 1.500-3.200 s"


def test_a_channel_read_from_its_file_is_cut_without_being_read_whole(tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    data = rng.standard_normal(20000).astype(np.float32)
    wave = Channel("mb1", "acceleration", "m/s^2", data, 2000.0, location="main bearing 1")
    path = write_hdf5(Recording("e1", "2026-01-01T00:00:00Z", (wave,)), tmp_path / "r.h5")
    with open_recording(path) as opened:
        part = between(opened, 2.0, 4.0).channel("mb1")
        assert isinstance(part.data, SampleReader)
        assert part.start_offset == pytest.approx(2.0)
        np.testing.assert_array_equal(np.asarray(part.data), data[4000:8001])
        np.testing.assert_array_equal(part.data[10:20], data[4010:4020])
        out = np.empty(5, dtype=np.float32)
        part.data.read_into(3, out)
        np.testing.assert_array_equal(out, data[4003:4008])


@pytest.mark.parametrize(("start", "stop"), [(2.0, 2.0), (3.0, 1.0), (float("nan"), 1.0)])
def test_an_empty_or_unknown_span_is_refused(start: float, stop: float) -> None:
    with pytest.raises(FormatError, match="expected finite times, start before stop"):
        between(_recording(np.random.default_rng(3)), start, stop)
