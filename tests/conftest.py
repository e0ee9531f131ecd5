"""Shared fixtures: the static Hertz specimen's case files, on the committed meshes.

The meshes come from ``meshes/`` (``meshes/generate.py``; tests/test_meshes.py
checks that they are what the recipes make); when a file is missing the mesh
is generated into the test's folder instead.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from validation.hertz_static import CASE_TEMPLATE, DISPLACEMENTS, write_case

MESHES = Path(__file__).resolve().parents[1] / "meshes"


def hertz_case(folder: Path, committed: str, h_contact: float, order: int = 2) -> Path:
    """The static Hertz study's case file in ``folder``, on the committed mesh if present."""
    source = MESHES / committed
    if not source.is_file():
        return write_case(folder, h_contact, order=order)
    shutil.copyfile(source, folder / "sphere_block.msh")
    case = folder / "case.toml"
    case.write_text(CASE_TEMPLATE.format(mesh="sphere_block.msh", values=list(DISPLACEMENTS)))
    return case


@pytest.fixture(scope="session")
def coarse_hertz_case(tmp_path_factory) -> Path:
    """Coarse quarter sphere-on-block case (h = 0.2 mm at contact, P2)."""
    return hertz_case(tmp_path_factory.mktemp("hertz_coarse"), "hertz_coarse.msh", 0.2e-3)


@pytest.fixture(scope="session")
def medium_hertz_case(tmp_path_factory) -> Path:
    """The validation's medium level (h = 0.1 mm at contact, P2)."""
    return hertz_case(tmp_path_factory.mktemp("hertz_medium"), "hertz_medium.msh", 0.1e-3)


@pytest.fixture(scope="session")
def coarse_hertz_case_p1(tmp_path_factory) -> Path:
    """The same specimen with linear tetrahedra."""
    return hertz_case(tmp_path_factory.mktemp("hertz_coarse_p1"), "hertz_coarse_p1.msh",
                      0.2e-3, order=1)
