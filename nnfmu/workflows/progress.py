"""Stage clock of a long run (`nnfmu demo`): each line carries the elapsed time, a stage silent for `heartbeat`
seconds says it is still running (its step, its share done and an estimate of what is left where the step reports
one), and the stages' times are kept for the run's summary."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

# The heartbeat quotes at most this much of the step it is in, so it stays on one line of a terminal.
STEP_CHARS = 48


def stamp(seconds: float) -> str:
    """`seconds` as a log line's `m:ss` stamp."""
    minutes, rest = divmod(round(max(0.0, seconds)), 60)
    return f"{minutes}:{rest:02d}"


def clock_time(seconds: float) -> str:
    """`seconds` as `12 s` or `3 min 05 s`."""
    seconds = max(0.0, seconds)
    if seconds < 60:
        return f"{seconds:.0f} s"
    minutes, rest = divmod(round(seconds), 60)
    return f"{minutes} min {rest:02d} s"


class StageClock:
    """Prefixes every log line with the run's elapsed time and speaks up when a stage has been quiet for
    `heartbeat` seconds (a background thread; `close` stops it)."""

    # 8 s: on a loaded machine the clock's thread wakes late (11 s of silence seen at load 9 with 10 s here).
    def __init__(self, log: Callable[[str], None], heartbeat: float = 8.0) -> None:
        self._log = log
        self._heartbeat = heartbeat
        self._started = time.perf_counter()
        self._lock = threading.Lock()
        self._last = self._started
        self._stage = ""
        self._stage_started = self._started
        self._step = ""
        self._step_started = self._started
        self._done: float | None = None
        self.seconds: dict[str, float] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, name="nnfmu-stage-clock", daemon=True)
        self._thread.start()

    def elapsed(self) -> float:
        return time.perf_counter() - self._started

    def log(self, message: str) -> None:
        """Print `message` with the elapsed time; it is the stage's current step until the next one."""
        with self._lock:
            self._last = time.perf_counter()
            self._step, self._step_started, self._done = message, self._last, None
            line = f"[{stamp(self._last - self._started)}] {message}"
        self._log(line)

    def aside(self, message: str) -> None:
        """Print `message` with the elapsed time, leaving the stage's current step as it is (a line of work running
        beside the stage, such as a child process's)."""
        with self._lock:
            line = f"[{stamp(time.perf_counter() - self._started)}] {message}"
        self._log(line)

    def record(self, name: str, seconds: float) -> None:
        """Keep `seconds` as the time of `name`, work timed elsewhere (beside the stages, in its own process)."""
        with self._lock:
            self.seconds[name] = seconds

    def progress(self, label: str, done: float) -> None:
        """A step's own progress (a training's `label` and share `done` in [0, 1]): shown only by the heartbeat."""
        with self._lock:
            if label != self._step:
                self._step, self._step_started = label, time.perf_counter()
            self._done = min(max(done, 0.0), 1.0)

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Time the stage `name` (added to `seconds`) and announce it."""
        with self._lock:
            self._stage, self._stage_started = name, time.perf_counter()
        self.log(f"== {name}")
        try:
            yield
        finally:
            with self._lock:
                self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - self._stage_started

    def close(self) -> None:
        self._stop.set()
        self._thread.join()

    def _watch(self) -> None:
        while not self._stop.wait(0.5):
            now = time.perf_counter()
            with self._lock:
                if now - self._last < self._heartbeat or not self._stage:
                    continue
                self._last = now
                step = self._step.removeprefix(f"== {self._stage}").strip()
                step = step if len(step) <= STEP_CHARS else step[: STEP_CHARS - 1] + "…"
                where = f"{self._stage}: still running" + (f" (last: {step})" if step else "")
                where += f", {clock_time(now - self._stage_started)} in this stage"
                if self._done is not None and self._done >= 0.05:
                    spent = now - self._step_started
                    where += (
                        f"; step {self._done:.0%} done, about {clock_time(spent * (1 - self._done) / self._done)} left"
                    )
                line = f"[{stamp(now - self._started)}] {where}"
            self._log(line)
