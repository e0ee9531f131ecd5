"""The package's docstring examples run as tests (``--doctest-modules`` in pyproject).

Collecting them imports every module of ``fe_impact``; that must stay cheap:
the mesher, the cluster, the plotting and the sparse-solver libraries are
imported where they are used, not at module level.
"""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Libraries that start a process, a session or a GUI back end, or take seconds to load.
HEAVY = ("gmsh", "dask", "distributed", "matplotlib", "pyvista", "pypardiso", "tqdm")


def test_importing_every_module_loads_no_heavy_library():
    # A fresh interpreter: this test session has imported most of them already.
    code = (
        "import importlib, pkgutil, sys, fe_impact\n"
        "names = [m.name for m in pkgutil.walk_packages(fe_impact.__path__, 'fe_impact.')]\n"
        "for name in names:\n"
        "    importlib.import_module(name)\n"
        f"print(len(names), [h for h in {HEAVY!r} if h in sys.modules])\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, timeout=120, check=True).stdout.split(maxsplit=1)
    assert int(out[0]) > 40           # every subpackage was walked
    assert out[1].strip() == "[]"


def test_pytest_collects_the_package_doctests():
    # Without these two settings the examples above silently stop being tested.
    options = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"][
        "ini_options"]
    assert "fe_impact" in options["testpaths"]
    assert "--doctest-modules" in options["addopts"].split()
