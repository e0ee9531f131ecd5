"""Result files: JSON summaries, VTU fields, PVD collections, CSV tables.

Every writer writes to a temporary name in the target folder,
``.{stem}-XXXXXXXX{suffix}`` (:func:`atomic_path`), and renames it, so an
interrupted run never leaves a half-written file under the real name. A
process killed outright can still leave the temporary file:
:func:`remove_temporaries` deletes such leftovers, and :func:`folder_lock`
lets a run make sure that no other process is writing the folder first.
:func:`check_output_dir` refuses an output folder that cannot be made before
any work starts.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import re
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from fe_impact.atomic import (  # noqa: F401 - re-exported: the result writers' API
    atomic_folder,
    atomic_path,
    standard_json,
    write_array_csv,
    write_csv,
    write_json,
)
from fe_impact.errors import FeImpactError
from fe_impact.fe.mesh import FEMesh

#: Names of the temporary files and folders of :func:`atomic_path` and
#: :func:`atomic_folder`: ``.`` + stem + ``-`` + eight characters of
#: :func:`tempfile.mkstemp`'s alphabet + the suffix.
TEMPORARY_NAME = re.compile(r"^\..+-[a-z0-9_]{8}(\.[A-Za-z0-9]+)?$")
#: The lock file :func:`folder_lock` holds in a folder.
LOCK_NAME = ".lock"


def check_output_dir(path: str | Path, option: str = "--out") -> Path:
    """``path`` if it is a folder or can be made one; else one line naming ``option``.

    Nothing is left behind (a probe folder is made and removed): this is meant
    to run before any computation, so that a run is not lost to an output
    folder that turns out to be a file, to lie under a file, or to be on a
    file system that takes no folders (read-only, or virtual like /proc).
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise FeImpactError(f"{option} {path}: is a file, not a folder; give a folder "
                            "(it is made if missing)")
    existing = path
    while not os.path.lexists(existing) and existing != existing.parent:
        existing = existing.parent
    if existing != path and not existing.is_dir():
        what = "a broken link" if existing.is_symlink() else "a file"
        raise FeImpactError(f"{option} {path}: cannot make the folder, {existing} is {what}")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise FeImpactError(f"{option} {path}: {existing} is not writable")
    # os.access says yes to root everywhere and knows nothing of read-only or
    # virtual file systems (/proc): make a folder there and take it away again
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".fe-impact-probe-", dir=existing))
    except OSError as exc:
        raise FeImpactError(f"{option} {path}: cannot make a folder in {existing} "
                            f"({exc.strerror or exc})") from None
    return path


def is_temporary(path: str | Path) -> bool:
    """True for a name that :func:`atomic_path` or :func:`atomic_folder` makes."""
    return bool(TEMPORARY_NAME.match(Path(path).name))


def remove_temporaries(folder: str | Path, recursive: bool = True) -> list[Path]:
    """Delete the temporary files and folders that killed writers left in ``folder``.

    Call it only while no other process writes to ``folder`` (hold its
    :func:`folder_lock`): a live writer's temporary file looks the same.
    Returns what was removed.
    """
    folder = Path(folder)
    if not folder.is_dir():
        return []
    removed = []
    for entry in sorted(folder.iterdir()):
        if is_temporary(entry):
            if entry.is_dir() and not entry.is_symlink():
                shutil.rmtree(entry, ignore_errors=True)
            else:
                entry.unlink(missing_ok=True)
            removed.append(entry)
        elif recursive and entry.is_dir() and not entry.is_symlink():
            removed += remove_temporaries(entry, recursive)
    return removed


@contextlib.contextmanager
def removed_if_left_empty(folder: str | Path) -> Iterator[Path]:
    """Make ``folder`` if need be; if the block fails and leaves a folder made here
    empty, remove it (a run that wrote nothing leaves no empty output folder)."""
    folder = Path(folder)
    made = not folder.exists()
    folder.mkdir(parents=True, exist_ok=True)
    try:
        yield folder
    except BaseException:
        if made and folder.is_dir() and not any(folder.iterdir()):
            folder.rmdir()
        raise


def remove_stale(folder: str | Path, pattern: str, keep: Sequence[str] = ()) -> list[Path]:
    """Remove the files of ``folder`` matching ``pattern`` whose names are not in
    ``keep``: what an earlier run into the same folder wrote and this one does not
    (more frames, other cases), which would sit beside its results. Returns them."""
    gone = [p for p in Path(folder).glob(pattern) if p.is_file() and p.name not in set(keep)]
    for p in gone:
        p.unlink(missing_ok=True)
    return gone


@contextlib.contextmanager
def folder_lock(folder: str | Path, wait: bool = True) -> Iterator[bool]:
    """Hold an exclusive lock on ``folder`` (``flock`` on its ``.lock`` file).

    Yields True once the lock is held; with ``wait=False`` yields False at
    once if another process holds it. The operating system releases the
    lock when the holder exits, however it ends, so a killed run never
    leaves a folder locked. The folder is made if missing.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    fd = os.open(folder / LOCK_NAME, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
        except BlockingIOError:
            yield False
            return
        yield True
    finally:
        os.close(fd)   # releases the lock


#: zlib level of the VTU files: level 1 writes a 52k-point P2 frame of a tooth pair
#: in 0.09 s (3.6 MB), level 6 in 0.21 s (3.5 MB); meshio, which takes zlib's
#: default level and base64-encodes, 0.20 s (4.7 MB).
VTU_COMPRESSION_LEVEL = 1


def write_vtu(path: str | Path, mesh: FEMesh, point_data: dict | None = None,
              cell_data: dict | None = None) -> Path:
    """Write the mesh and fields as a VTU file (ParaView reads P2 tetrahedra natively).

    ``point_data`` arrays have shape (n_points, ...) and ``cell_data`` arrays
    (n_elements, ...); None values are left out. VTK's own XML writer writes
    it (raw appended data, zlib at :data:`VTU_COMPRESSION_LEVEL`); meshio and
    ParaView read it. The grid is built from VTK's classes directly, not
    pyvista's: those finalise in Python (``__del__``), and a SIGTERM that
    arrives while one runs is swallowed as an "exception ignored", so a run
    meant to stop went on (seen once in the interrupt tests).
    """
    from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
    from vtkmodules.vtkCommonCore import vtkPoints
    from vtkmodules.vtkCommonDataModel import (
        VTK_QUADRATIC_TETRA,
        VTK_TETRA,
        vtkCellArray,
        vtkUnstructuredGrid,
    )
    from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridWriter

    def vtk_array(values, name: str | None = None):
        array = numpy_to_vtk(np.ascontiguousarray(values), deep=True)
        if name is not None:
            array.SetName(name)
        return array

    cells = np.ascontiguousarray(mesh.cells, dtype=np.int64)
    points = vtkPoints()
    points.SetData(vtk_array(np.asarray(mesh.points, dtype=float)))
    offsets = np.arange(len(cells) + 1, dtype=np.int64) * cells.shape[1]
    connectivity = vtkCellArray()
    connectivity.SetData(numpy_to_vtkIdTypeArray(offsets, deep=True),
                         numpy_to_vtkIdTypeArray(cells.ravel(), deep=True))
    grid = vtkUnstructuredGrid()
    grid.SetPoints(points)
    grid.SetCells(VTK_QUADRATIC_TETRA if mesh.order == 2 else VTK_TETRA, connectivity)
    for target, data in ((grid.GetPointData(), point_data), (grid.GetCellData(), cell_data)):
        for name, values in (data or {}).items():
            if values is not None:
                target.AddArray(vtk_array(values, name))
    writer = vtkXMLUnstructuredGridWriter()
    writer.SetInputData(grid)
    writer.SetDataModeToAppended()
    writer.EncodeAppendedDataOff()
    writer.SetCompressorTypeToZLib()
    writer.SetCompressionLevel(VTU_COMPRESSION_LEVEL)
    with atomic_path(path) as tmp:
        writer.SetFileName(str(tmp))
        if writer.Write() != 1:
            raise FeImpactError(f"{path}: VTK could not write the file")
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
