"""Drawing a run's pictures, here or on the sweep's workers.

A report's pictures are independent of each other and of its tables: a
writer hands them to a :data:`Draw` as jobs ``(file name, function,
arguments)`` and reads the outcome when its tables are written. The
calibration draws them on its Dask workers, which are idle once the cases
are done and have matplotlib loaded (the coarse calibration's six pictures:
about 7 s one after the other in the main process); elsewhere they are drawn
here, one after the other.

A picture that fails is reported by name and skipped: a missing picture
must not lose the tables.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence

logger = logging.getLogger(__name__)

#: ``(file name, function, arguments)``: ``function(*arguments)`` writes the file,
#: or returns False if it had nothing to draw.
Job = tuple[str, Callable[..., object], tuple]
#: Starts the jobs and returns what waits for them: a callable returning the
#: names of the pictures written.
Draw = Callable[[Sequence[Job]], Callable[[], list[str]]]


def drawn(function: Callable[..., object], *args) -> tuple[bool, str]:
    """Run one job: (whether the picture was written, the error if one was raised)."""
    try:
        return function(*args) is not False, ""
    except Exception as exc:   # noqa: BLE001 - reported by name, tables kept
        return False, f"{type(exc).__name__}: {exc}"


def outcome(name: str, result: tuple[bool, str]) -> bool:
    """Log a failed job; whether its picture (or other output) exists."""
    written, error = result
    if error:
        logger.warning("%s skipped: %s", name, error)
    return written


def draw_here(jobs: Sequence[Job]) -> Callable[[], list[str]]:
    """Draw the jobs now, in this process, one after the other."""
    written = [name for name, fn, args in jobs if outcome(name, drawn(fn, *args))]
    return lambda: written


def draw_on(client) -> Draw:
    """A :data:`Draw` on a Dask ``client``'s workers, one task per picture."""
    def draw(jobs: Sequence[Job]) -> Callable[[], list[str]]:
        futures = [(name, client.submit(drawn, fn, *args, pure=False))
                   for name, fn, args in jobs]

        def wait() -> list[str]:
            out = []
            for name, future in futures:
                try:
                    result = future.result()
                except Exception as exc:   # noqa: BLE001 - a lost worker: picture skipped
                    result = (False, f"{type(exc).__name__}: {exc}")
                if outcome(name, result):
                    out.append(name)
            return out

        return wait

    return draw


__all__ = ["Draw", "Job", "draw_here", "draw_on", "drawn", "outcome"]
