"""The stage clock: seconds per stage, added up over repeats and threads."""

from __future__ import annotations

import threading
import time

from monitor.runtime.timing import StageClock, stage


def test_stages_add_up_over_repeats_and_threads() -> None:
    clock = StageClock()

    def work() -> None:
        for _ in range(3):
            with stage(clock, "sleep"):
                time.sleep(0.01)

    threads = [threading.Thread(target=work) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    with stage(None, "ignored"):  # no clock: nothing recorded, nothing raised
        pass
    assert set(clock.seconds) == {"sleep"}
    # six sleeps of 10 ms in two threads: at least 60 ms summed (sleep never returns early)
    assert clock.seconds["sleep"] >= 0.06


def test_a_stage_that_raises_is_still_counted() -> None:
    clock = StageClock()
    try:
        with clock.stage("failing"):
            raise ValueError("inside")
    except ValueError:
        pass
    assert clock.seconds["failing"] >= 0.0 and "failing" in clock.seconds
