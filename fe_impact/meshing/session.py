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
