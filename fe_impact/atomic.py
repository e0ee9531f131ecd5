"""Files that appear whole: written under a temporary name in the target
folder, then renamed, so an interrupted run never leaves a half-written file
under a real name; JSON that strict readers accept.

A low-level module every stage may use (the case writer, the mesh cache, the
calibration records, the result writers of :mod:`fe_impact.output`).
"""

from __future__ import annotations

import contextlib
import csv
import json
import os
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from fe_impact.interrupts import held_signals

__all__ = ["atomic_folder", "atomic_path", "standard_json", "write_csv", "write_json"]


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; rename it to ``path`` on success. A stop
    (Ctrl-C, SIGTERM) at any point leaves no temporary file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = None
    try:
        with held_signals():
            fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=path.suffix,
                                       dir=path.parent)
            os.close(fd)
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)   # mkstemp makes 0600; results are to be shared
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        with held_signals():
            if tmp is not None and os.path.exists(tmp):
                os.remove(tmp)


@contextlib.contextmanager
def atomic_folder(folder: str | Path, stem: str = "build") -> Iterator[Path]:
    """Yield a new private folder inside ``folder`` (``.{stem}-XXXXXXXX``), removed at the end.

    Files made there and moved into ``folder`` with :func:`os.replace`
    appear whole under their real names, and scratch files made there are
    the process's own.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    tmp = None
    try:
        with held_signals():
            tmp = Path(tempfile.mkdtemp(prefix=f".{stem}-", dir=folder))
        yield tmp
    finally:
        with held_signals():
            if tmp is not None:
                shutil.rmtree(tmp, ignore_errors=True)


def standard_json(obj):
    """``obj`` with NumPy values made plain and every NaN or infinity made ``None``.

    JSON has no NaN or Infinity: Python writes them, but strict readers
    (JavaScript's ``JSON.parse``, most non-Python libraries) reject the file.
    A quantity that has no finite value is written as ``null``.
    """
    if isinstance(obj, dict):
        return {str(k): standard_json(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [standard_json(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return standard_json(obj.tolist())
    if isinstance(obj, bool | np.bool_):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, float | np.floating):
        return float(obj) if np.isfinite(obj) else None
    if isinstance(obj, Path):
        return str(obj)
    return obj


def write_json(path: str | Path, data: dict) -> Path:
    """Write ``data`` as indented, standard JSON (no NaN/Infinity: see
    :func:`standard_json`), atomically."""
    text = json.dumps(standard_json(data), indent=2, allow_nan=False)
    with atomic_path(path) as tmp:
        tmp.write_text(text + "\n")
    return Path(path)


def write_csv(path: str | Path, header: Sequence[str], rows: Sequence[Sequence]) -> Path:
    """Write a CSV table with a header row, atomically."""
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(rows)
    return Path(path)


#: Significant digits of :func:`write_array_csv`: ten are beyond every figure the
#: models compute (a time of 10 s is resolved to 1 ns), and a float written in
#: them costs a third of its shortest exact form (time series of 30k rows).
ARRAY_DIGITS = 10


def write_array_csv(path: str | Path, header: Sequence[str], data: np.ndarray) -> Path:
    """Write a numeric table (rows of ``data``, one column per ``header`` name) as CSV
    with :data:`ARRAY_DIGITS` significant digits, atomically. Non-finite values are
    written ``nan``, ``inf``, ``-inf``."""
    data = np.asarray(data, dtype=float).reshape(-1, len(header))
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
        csv.writer(fh).writerow(header)
        np.savetxt(fh, data, fmt=f"%.{ARRAY_DIGITS}g", delimiter=",")
    return Path(path)
