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

:func:`native_handlers_kept` is for libraries that reset signal handlers
behind Python's back: ``gmsh.initialize`` sets SIGTERM and SIGPIPE to their
defaults, after which a SIGTERM killed the process at once (and a worker
that should ignore it), leaving temporary files.
"""

from __future__ import annotations

import contextlib
import ctypes
import signal
import threading
from collections.abc import Callable, Iterator

__all__ = ["SIGNALS", "Interrupted", "exit_status", "handle_signals", "held_signals",
           "ignore_signals", "native_handlers_kept"]

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


@contextlib.contextmanager
def held_signals() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back within the block (main thread only): one arriving
    meanwhile is delivered at its end, so the stop it raises cannot fall inside the
    block (a temporary file made but not yet in charge of, or half removed). Keep the
    block short. Where the platform cannot mask signals nothing is changed."""
    mask = getattr(signal, "pthread_sigmask", None)
    if mask is None or not _main_thread():
        yield
        return
    old = mask(signal.SIG_BLOCK, set(SIGNALS))
    try:
        yield
    finally:
        mask(signal.SIG_SETMASK, old)


#: Bytes kept for a C ``struct sigaction``: more than any libc's (152 on Linux x86-64).
_SIGACTION_BYTES = 1024


def _sigaction():
    """The C library's ``sigaction``, or None (not a POSIX C library)."""
    try:
        return ctypes.CDLL(None).sigaction
    except (OSError, AttributeError, TypeError):
        return None


@contextlib.contextmanager
def native_handlers_kept(signals=(signal.SIGINT, signal.SIGTERM, signal.SIGPIPE)
                         ) -> Iterator[None]:
    """Put back, at the end of the block, the C-level dispositions of ``signals``.

    The ``struct sigaction`` is copied as opaque bytes (read with
    ``sigaction(sig, NULL, old)``, written back with ``sigaction(sig, old,
    NULL)``), so its layout does not matter. Works from any thread.
    """
    sigaction = _sigaction()
    saved = {}
    if sigaction is not None:
        for s in signals:
            old = ctypes.create_string_buffer(_SIGACTION_BYTES)
            if sigaction(int(s), None, old) == 0:
                saved[s] = old
    try:
        yield
    finally:
        for s, old in saved.items():
            sigaction(int(s), old, None)
