"""SIGINT and SIGTERM handled alike: both stop a run the way Ctrl-C does.

Python turns SIGINT into :class:`KeyboardInterrupt` but lets SIGTERM (what
``kill``, ``timeout`` and job schedulers send) end the process at once, so a
run stopped that way wrote no summary and left its temporary files.
:func:`handle_signals` makes both raise :class:`Interrupted`, a
``KeyboardInterrupt`` that knows which signal it was, in the main thread;
the code that catches ``KeyboardInterrupt`` to write a ``status: "stopped"``
summary then works for both.

:func:`ignore_signals` is for starting worker processes: a child started
while a signal is ignored keeps ignoring it (POSIX keeps ``SIG_IGN`` across
``fork`` and ``exec``), so Ctrl-C in a terminal, which signals the whole
process group, reaches only the parent, which stops the workers itself.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Iterator

__all__ = ["SIGNALS", "Interrupted", "exit_status", "handle_signals", "ignore_signals"]

#: The signals that stop a run.
SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """A run stopped by SIGINT (Ctrl-C) or SIGTERM."""

    def __init__(self, signum: int = signal.SIGINT) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)

    @property
    def name(self) -> str:
        """``"SIGINT"`` or ``"SIGTERM"``."""
        return signal.Signals(self.signum).name


def exit_status(exc: BaseException) -> int:
    """The shell's status for a process ended by the signal: 128 + its number."""
    return 128 + getattr(exc, "signum", signal.SIGINT)


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextlib.contextmanager
def handle_signals(on_signal: Callable[[int], None] | None = None) -> Iterator[None]:
    """Within the block, SIGINT and SIGTERM raise :class:`Interrupted` in the main thread.

    ``on_signal(signum)`` is called first (e.g. to set a flag that survives
    library code that swallows the exception). The previous handlers are
    restored at the end. Outside the main thread nothing is changed (Python
    runs signal handlers only there).
    """
    if not _main_thread():
        yield
        return

    def handler(signum, frame):
        if on_signal is not None:
            on_signal(signum)
        raise Interrupted(signum)

    old = {s: signal.signal(s, handler) for s in SIGNALS}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


@contextlib.contextmanager
def ignore_signals() -> Iterator[None]:
    """Ignore SIGINT and SIGTERM within the block (main thread only), then restore.

    Processes started within the block ignore them for good. A signal
    arriving meanwhile is lost, so keep the block short.
    """
    if not _main_thread():
        yield
        return
    old = {s: signal.signal(s, signal.SIG_IGN) for s in SIGNALS}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
