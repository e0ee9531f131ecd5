"""Shared fixtures: the static Hertz specimen's case files, on the committed meshes.

The meshes come from ``meshes/`` (``meshes/generate.py``; tests/test_meshes.py
checks that they are what the recipes make); when a file is missing the mesh
is generated into the test's folder instead.
"""

from __future__ import annotations

import os
import shutil
import warnings
from pathlib import Path

# Each pytest-xdist worker compiles the numba kernels (cache=True) into a cache
# of its own: two processes compiling the same kernel into one cache at once can
# leave an index and a data file that do not belong together, and a process
# that loads them crashes (numba/numba#4807, #10128). The folder is stable per
# worker, so later runs still load their compiled kernels. Set before any
# numba kernel is imported: numba reads it when a kernel is decorated.
if "PYTEST_XDIST_WORKER" in os.environ and "NUMBA_CACHE_DIR" not in os.environ:
    os.environ["NUMBA_CACHE_DIR"] = str(Path(__file__).resolve().parents[1] / ".numba_cache"
                                        / os.environ["PYTEST_XDIST_WORKER"])

import pytest  # noqa: E402

from fe_impact.fe.casefile import write_case as write_case_file
from validation.hertz_static import DISPLACEMENTS, write_case
from validation.impact_cases import sphere_block_case

MESHES = Path(__file__).resolve().parents[1] / "meshes"

#: Tests that take more than about 10 s (the call, or the module fixture they need),
#: by file: test-name prefixes, "" for every test of the file. They get the ``slow``
#: marker here, so that ``pytest -m "not slow"`` is a fast subset. Measured with
#: ``--durations`` on two loaded cores (the whole suite took 24 minutes, the fast
#: subset 3); a test file may also mark its own tests with ``@pytest.mark.slow``.
SLOW_TESTS: dict[str, tuple[str, ...]] = {
    "test_calibrate_e2e.py": ("",),       # a coarse calibration (module fixture ~1 min)
    # each study's quick setting, 10 s - 3 min
    "test_validation_quick.py": ("test_study_passes_its_checks_on_the_quick_setting",),
    "test_plastic_impact.py": ("",),      # three plastic impacts (module fixture 1.5 min)
    "test_dynamic.py": ("test_contact_zone_grows_before_faces_outside_touch",
                        "test_coarse_hemisphere_impact_against_hertz"),
    # the medium Hertz specimen (the medium_run fixture, 10-20 s) and its variants
    "test_static_contact.py": ("test_force_matches_hertz_locally",
                               "test_pressure_and_radius_at_full_load",
                               "test_peak_pressure_converges",
                               "test_pressure_settles_as_the_penalty_grows",
                               "test_split_multiplier_agrees_in_force",
                               "test_midside_pressure_is_the_corner_mean"),
    "test_switching.py": ("test_undamped_frictionless_run_conserves_energy",),
    "test_toothmesh.py": ("test_command_writes_mesh_case_summary_and_picture",),
    # the mesh-cycle study's quick setting (coarse impact and positions, ~1 min)
    "test_validation_mesh_cycle.py": ("test_quick_study_passes_its_checks",),
}


def pytest_collection_modifyitems(config, items):
    """Mark the tests of :data:`SLOW_TESTS`; warn about entries that match nothing."""
    used: set[tuple[str, str]] = set()
    files = set()
    for item in items:
        prefixes = SLOW_TESTS.get(item.path.name)
        if prefixes is None:
            continue
        files.add(item.path.name)
        for prefix in prefixes:
            if item.name.startswith(prefix):
                item.add_marker(pytest.mark.slow)
                used.add((item.path.name, prefix))
    stale = [f"{name}::{prefix}" for name in files for prefix in SLOW_TESTS[name]
             if (name, prefix) not in used]
    if stale and not config.getoption("keyword"):
        warnings.warn(pytest.PytestWarning(
            f"tests/conftest.py SLOW_TESTS entries match no collected test: {stale}"),
            stacklevel=1)


def hertz_case(folder: Path, committed: str, h_contact: float, order: int = 2) -> Path:
    """The static Hertz study's case file in ``folder``, on the committed mesh if present."""
    source = MESHES / committed
    if not source.is_file():
        return write_case(folder, h_contact, order=order)
    shutil.copyfile(source, folder / "sphere_block.msh")
    return write_case_file(sphere_block_case(folder / "sphere_block.msh", DISPLACEMENTS),
                           folder / "case.toml")


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
