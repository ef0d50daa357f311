"""A rich progress bar for `nnfmu batch`: cases done and failed, and the rate in cases per hour."""

from __future__ import annotations

import time

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from nnfmu.workflows.campaign.execute import FAILED, CaseOutcome


class CaseProgress:
    """Shows `done/total`, the failed count and the rate of the cases run now (skipped ones count as done)."""

    def __init__(self, console: Console | None = None) -> None:
        self._bar = Progress(
            TextColumn("cases"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("failed {task.fields[failed]}"),
            TextColumn("{task.fields[rate]}"),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
            console=console or Console(stderr=True),
        )
        self._task = None
        self._failed = self._ran = 0
        self._started = 0.0

    def start(self, total: int, skipped: int) -> None:
        self._bar.start()
        self._task = self._bar.add_task("cases", total=total, completed=skipped, failed=0, rate="")
        self._started = time.perf_counter()

    def advance(self, outcome: CaseOutcome) -> None:
        self._ran += 1
        self._failed += outcome.status == FAILED
        elapsed = max(time.perf_counter() - self._started, 1e-9)
        self._bar.update(self._task, advance=1, failed=self._failed, rate=f"{self._ran / elapsed * 3600:.0f} cases/h")

    def stop(self) -> None:
        self._bar.stop()
