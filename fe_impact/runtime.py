"""Process settings that the solvers' speed depends on."""

from __future__ import annotations

import ctypes
import ctypes.util
import logging
import os
from pathlib import Path

logger = logging.getLogger(__name__)

def user_cache(name: str) -> Path | None:
    """``fe-impact/<name>`` in the user's cache (``$XDG_CACHE_HOME`` or ``~/.cache``),
    created; None if it cannot be created or written."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    folder = Path(base) / "fe-impact" / name
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return folder if os.access(folder, os.W_OK) else None


# glibc mallopt parameters (malloc.h)
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: glibc's upper limit for the mmap threshold on 64-bit systems.
_MMAP_THRESHOLD_MAX = 32 * 1024 * 1024


def keep_freed_memory(trim_threshold: int = 1 << 30) -> bool:
    """Let glibc keep freed memory in the heap for reuse instead of returning it.

    A time step allocates many temporary vectors of a few MB. By default
    glibc maps each one afresh (above 128 kB) and returns it on free, and
    Dask's worker launcher even lowers the trim threshold to 64 kB, so every
    temporary is faulted in page by page: on a 90k-DOF tooth impact that was
    11 million page faults and 39 s of system time out of 109 s. Keeping
    arrays up to 32 MB in the heap brought it to 0.6 million faults and 72 s.
    Returns False where the C library is not glibc (nothing is changed).
    """
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    ok = bool(mallopt(_M_MMAP_THRESHOLD, _MMAP_THRESHOLD_MAX))
    ok &= bool(mallopt(_M_TRIM_THRESHOLD, int(trim_threshold)))
    if not ok:
        logger.debug("mallopt refused the heap settings")
    return ok
