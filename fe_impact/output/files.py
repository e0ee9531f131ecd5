"""Result files: JSON summaries, VTU fields, PVD collections, CSV tables.

Every writer writes to a temporary name in the target folder and renames it,
so an interrupted run never leaves a half-written file behind.
"""

from __future__ import annotations

import contextlib
import csv
import json
import os
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from fe_impact.fe.mesh import FEMesh


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; rename it to ``path`` on success."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)   # mkstemp makes 0600; results are meant to be shared
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


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


def write_vtu(path: str | Path, mesh: FEMesh, point_data: dict | None = None,
              cell_data: dict | None = None) -> Path:
    """Write the mesh and fields as a VTU file (ParaView reads P2 tetrahedra natively).

    ``point_data`` arrays have shape (n_points, ...) and ``cell_data`` arrays
    (n_elements, ...).
    """
    import meshio

    kind = "tetra10" if mesh.order == 2 else "tetra"
    m = meshio.Mesh(mesh.points, [(kind, mesh.cells)],
                    point_data=dict(point_data or {}),
                    cell_data={k: [np.asarray(v)] for k, v in (cell_data or {}).items()})
    with atomic_path(path) as tmp:
        meshio.write(tmp, m, file_format="vtu")
    return Path(path)


def write_pvd(path: str | Path, frames: Sequence[tuple[float, str]]) -> Path:
    """Write a ParaView collection of (time, relative VTU file name) frames."""
    lines = ['<?xml version="1.0"?>',
             '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
             "  <Collection>"]
    lines += [f'    <DataSet timestep="{t:.9g}" part="0" file={quoteattr(f)}/>'
              for t, f in frames]
    lines += ["  </Collection>", "</VTKFile>", ""]
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines))
    return Path(path)
