"""The progress bar: drawn on a terminal only, with the time left, never going backwards."""

from __future__ import annotations

import io

from monitor.runtime.progress import progress_bar


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_nothing_is_drawn_when_the_stream_is_not_a_terminal() -> None:
    out = io.StringIO()
    with progress_bar(10, "spectra", unit="s", stream=out) as report:
        for done in range(11):
            report(done)
    assert out.getvalue() == ""


def test_a_terminal_gets_the_description_the_count_and_the_time_left() -> None:
    out = _Terminal()
    with progress_bar(4, "diagnosing", unit="recording", stream=out, redraw_s=0, delay_s=0) as report:
        report(1)
        report(2)
        drawn = out.getvalue()
    assert "diagnosing" in drawn
    assert "2/4" in drawn
    assert "<" in drawn  # tqdm's "elapsed<left" estimate


def test_reports_that_go_backwards_or_beyond_the_total_are_held_to_the_range() -> None:
    out = _Terminal()
    with progress_bar(3, "rows", stream=out, redraw_s=0, delay_s=0) as report:
        report(2)
        report(1)
        assert "2/3" in out.getvalue().rsplit("\r", 1)[-1]
        report(99)
        assert "3/3" in out.getvalue().rsplit("\r", 1)[-1]


def test_quick_work_shows_no_bar() -> None:
    out = _Terminal()
    with progress_bar(3, "quick", stream=out, redraw_s=0, delay_s=60) as report:
        report(3)
    assert "quick" not in out.getvalue()
