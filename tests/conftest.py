"""Shared fixtures: small Gmsh meshes and case files built once per session."""

from __future__ import annotations

from pathlib import Path

import pytest

from validation.hertz_static import write_case


@pytest.fixture(scope="session")
def coarse_hertz_case(tmp_path_factory) -> Path:
    """Coarse quarter sphere-on-block case (h = 0.2 mm at contact, P2)."""
    return write_case(tmp_path_factory.mktemp("hertz_coarse"), 0.2e-3)


@pytest.fixture(scope="session")
def medium_hertz_case(tmp_path_factory) -> Path:
    """The validation's medium level (h = 0.1 mm at contact, P2)."""
    return write_case(tmp_path_factory.mktemp("hertz_medium"), 0.1e-3)


@pytest.fixture(scope="session")
def coarse_hertz_case_p1(tmp_path_factory) -> Path:
    """The same specimen with linear tetrahedra."""
    return write_case(tmp_path_factory.mktemp("hertz_coarse_p1"), 0.2e-3, order=1)
