"""Gmsh session handling and mesh writing shared by every mesh builder.

Gmsh keeps global state; :func:`gmsh_session` is the one place that
initialises and finalises it, so a failing builder never leaves a session
open.
"""

from __future__ import annotations

import contextlib
import logging
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

logger = logging.getLogger(__name__)


@contextlib.contextmanager
def gmsh_session(name: str = "fe_impact", verbose: bool = False) -> Iterator[object]:
    """Initialise gmsh, yield the ``gmsh.model`` module, always finalise.

    Parameters
    ----------
    name : str
        Model name.
    verbose : bool
        Let gmsh print to the terminal.
    """
    import gmsh

    from fe_impact.interrupts import native_handlers_kept

    with native_handlers_kept():   # gmsh resets SIGTERM and SIGPIPE to their defaults
        gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 1 if verbose else 0)
        gmsh.model.add(name)
        yield gmsh.model
    finally:
        with native_handlers_kept():
            gmsh.finalize()


def write_msh(path: str | Path) -> Path:
    """Write the current gmsh model as MSH 4.1 atomically (temporary name, then rename)."""
    import gmsh

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    # Only elements in physical groups are saved: the groups are the interface.
    gmsh.option.setNumber("Mesh.SaveAll", 0)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        gmsh.write(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return path


def set_nodes(tags, coords) -> None:
    """Move the nodes ``tags`` to ``coords`` (shape (n, 3), model units), no parametric
    coordinates.

    gmsh's Python ``setNode`` converts its two lists for every node, about 15 us
    a call (0.26 s a coarse tooth-pair mesh); this calls the same C API entry
    (``gmshModelMeshSetNode``) on the rows of one array.
    """
    import ctypes

    import gmsh
    import numpy as np

    x = np.ascontiguousarray(coords, dtype=np.float64).reshape(-1, 3)
    tags = np.asarray(tags, dtype=np.uint64).ravel()
    if len(tags) != len(x):
        raise ValueError(f"{len(tags)} node tags for {len(x)} coordinate rows")
    fn = gmsh.lib.gmshModelMeshSetNode
    ierr = ctypes.c_int()
    three, none = ctypes.c_size_t(3), ctypes.c_size_t(0)
    base, stride = x.ctypes.data, x.strides[0]
    for i, tag in enumerate(tags.tolist()):
        fn(ctypes.c_size_t(tag), ctypes.c_void_p(base + i * stride), three, None, none,
           ctypes.byref(ierr))
        if ierr.value != 0:
            from fe_impact.errors import MeshError

            raise MeshError(f"gmsh could not move node {tag}: {gmsh.logger.getLastError()}")
