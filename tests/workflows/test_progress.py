"""The demo's stage clock: stamped lines, a heartbeat in a quiet stage with the step's progress, stage times."""

from __future__ import annotations

import time

from nnfmu.workflows.progress import StageClock, clock_time, stamp


def test_quiet_stage_speaks_up_and_stages_are_timed() -> None:
    lines: list[str] = []
    clock = StageClock(lines.append, heartbeat=0.2)
    try:
        with clock.stage("training"):
            clock.log("damper: training")
            clock.progress("mlp hidden 5, restart 1/1", 0.5)
            time.sleep(0.9)
    finally:
        clock.close()
    assert lines[0] == "[0:00] == training" and lines[1] == "[0:00] damper: training"
    beats = [line for line in lines[2:] if "training: still running (last: mlp hidden 5, restart 1/1)" in line]
    assert beats and "step 50% done, about" in beats[0]
    assert 0.9 <= clock.seconds["training"] < 5


def test_times_read_as_minutes_and_seconds() -> None:
    assert stamp(83.4) == "1:23" and clock_time(12.4) == "12 s" and clock_time(185) == "3 min 05 s"
