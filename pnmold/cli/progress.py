"""Terminal progress of a long command: each stage on its own line with its elapsed time,
the current one with a spinner and a running clock, and the total (rich)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.progress import Progress, SpinnerColumn, TaskID, TextColumn, TimeElapsedColumn

#: what the build's stages (pnmold.pipeline.build) are called on screen
STAGE_LABELS = {
    "cad": "CAD: actuator, layers, molds (CadQuery)",
    "export": "export STEP and STL",
    "measure": "measure the parts",
    "checks": "design-rule checks (and PrusaSlicer)",
    "fem": "quick FE: mesh and bend",
    "report": "report.html",
}


@contextmanager
def stage_progress(console: Console, quiet: bool = False, title: str = "build") -> Iterator[Callable[[str], None]]:
    """Yield a callback ``say(stage)`` that closes the previous stage and starts ``stage``.

    With ``quiet`` the callback does nothing and nothing is shown."""
    if quiet:
        yield lambda stage: None
        return
    columns = (SpinnerColumn(finished_text="[green]✓[/green]"), TextColumn("{task.description}"),
               TimeElapsedColumn())
    with Progress(*columns, console=console, transient=False) as progress:
        total = progress.add_task(f"[bold]{title}[/bold]", total=None)
        current: list[TaskID] = []

        def say(stage: str) -> None:
            if current:
                progress.update(current[-1], total=1, completed=1)
            current.append(progress.add_task(STAGE_LABELS.get(stage, stage), total=None))

        try:
            yield say
        except BaseException:
            if current:
                task = progress.tasks[current[-1]]
                progress.update(current[-1], description=f"[red]failed:[/red] {task.description}")
                progress.stop_task(current[-1])
            progress.stop_task(total)
            raise
        for task in (*current, total):
            progress.update(task, total=1, completed=1)
