"""The terminal view of a running sweep (rich): a bar with done, failed, left and the ETA.
The CLI hands in its console; the library itself never writes to the terminal."""

from __future__ import annotations

from typing import Any

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from pnmold.sweep.run import Counts


def _eta(seconds: float | None) -> str:
    if seconds is None:
        return "ETA -:--:--"
    s = int(round(seconds))
    return f"ETA {s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"


class SweepProgress:
    """``on_update`` for :func:`pnmold.sweep.run_sweep`; use as a context manager."""

    def __init__(self, console: Console, name: str):
        self.name = name
        self.progress = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                                 TextColumn("{task.fields[status]}"), TimeElapsedColumn(), console=console,
                                 transient=False)
        self.task = None

    def __enter__(self) -> SweepProgress:
        self.progress.start()
        return self

    def __exit__(self, *exc) -> None:
        self.progress.stop()

    def __call__(self, counts: Counts, row: dict[str, Any] | None) -> None:
        s = counts.by_status
        status = f"failed {s['failed']}"
        status += "".join(f" · {label} {s[k]}" for k, label in (("check_failed", "check failed"),
                                                                 ("refused", "refused")) if s[k])
        status += f" · left {counts.left} · {_eta(counts.eta_s)}"
        if counts.skipped:
            status += f" · {counts.skipped} done before"
        if self.task is None:
            self.task = self.progress.add_task(self.name, total=counts.total or 1, status=status)
        self.progress.update(self.task, completed=counts.done if counts.total else 1, status=status)
