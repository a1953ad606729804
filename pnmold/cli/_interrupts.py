"""Ctrl-C on the command line: noted as it arrives, raised where it is safe, never lost.

Standard library only, so the handler is in place before anything heavy is imported. An interrupt
that arrives while a module is being imported is noted and not raised there: an import cut in
half can leave a C extension half set up (a crash later), and some libraries import their extras
under ``except BaseException`` (trimesh), which would swallow it. A noted interrupt is raised at
the next stage of the run (:func:`pnmold.cli._common.stages`) and ends the run as interrupted
(130) even where a library turned it into an error of its own. A second Ctrl-C ends the process at
once (a long C call, e.g. a CAD boolean, runs to its end before Python sees the first).
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from collections.abc import Iterator

#: the Ctrl-C presses of the current run (shared with the stage callback that raises a pending one)
INTERRUPTS: list[bool] = []


def _importing(frame) -> bool:
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            return True
        frame = frame.f_back
    return False


def on_sigint(signum, frame) -> None:
    INTERRUPTS.append(True)
    if len(INTERRUPTS) > 1:  # pressed again while the first waits for a long C call to return: leave now
        os.write(2, b"interrupted\n")  # temporary files of this run are removed by the next run into its folders
        os._exit(130)
    if not _importing(frame):
        raise KeyboardInterrupt


@contextlib.contextmanager
def noting_interrupts() -> Iterator[list[bool]]:
    """Install :func:`on_sigint` for the block (main thread only) and put the handler back after; nested
    (the handler already in), keep what was noted so far."""
    if signal.getsignal(signal.SIGINT) is on_sigint:
        yield INTERRUPTS
        return
    INTERRUPTS.clear()
    if threading.current_thread() is not threading.main_thread():
        yield INTERRUPTS
        return
    before = signal.signal(signal.SIGINT, on_sigint)
    try:
        yield INTERRUPTS
    finally:
        signal.signal(signal.SIGINT, before)
