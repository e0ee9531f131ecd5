"""Two runs at once never break each other (subprocesses).

Two calibrations on one output folder: the case is computed once, under its
lock, and the second run takes the first's result. Two tooth-pair meshings into
one folder: each meshes in a private folder and the files appear whole.
"""

from __future__ import annotations

import json

import pytest

from fe_impact.fe.mesh import load_mesh
from tests.test_interrupts import leftovers, start, strict

pytestmark = pytest.mark.slow


def test_two_calibrations_on_one_output_folder(tmp_path):
    """Each run has its own mesh cache, so the cache that holds a mesh tells which run
    computed the case: exactly one did; the other waited for its lock."""
    out = tmp_path / "out"
    caches = [tmp_path / "cache1", tmp_path / "cache2"]
    runs = [start(["calibrate", "--no-switching", "--out", out, "--cache", cache, "--stages",
                   "1", "--speeds", "300", "--level", "coarse", "--no-mesh-cycle", "--workers",
                   "1"])
            for cache in caches]
    errs = [run.communicate(timeout=1200)[1] for run in runs]
    assert [run.returncode for run in runs] == [0, 0], errs
    for err in errs:
        assert "Traceback" not in err and "8787" not in err, err    # the dashboard's port
    meshed = [len(list(cache.glob("meshes/*/pair.msh"))) for cache in caches]
    assert sorted(meshed) == [0, 1], meshed
    assert strict(out / "summary.json")["status"] == "completed"
    calibration = strict(out / "calibration.json")
    record = strict(out / "cases" / "stage1_mesh_300rpm" / "result.json")
    assert calibration["cases"] == [record]
    assert leftovers(out, *caches) == []


def test_two_meshings_into_one_folder(tmp_path):
    """Both used to write gmsh's scratch file ``.pair-reference.msh`` in the folder and
    could read each other's; now both finish and leave one whole, loadable entry."""
    out = tmp_path / "pair"
    runs = [start(["mesh", "--level", "coarse", "--order", "1", "--no-picture", "--reuse",
                   "--out", out]) for _ in range(2)]
    errs = [run.communicate(timeout=600)[1] for run in runs]
    assert [run.returncode for run in runs] == [0, 0], errs
    assert sorted(p.name for p in out.iterdir()) == ["case.toml", "pair.msh", "tca.json"]
    summary = json.loads((out / "tca.json").read_text())
    mesh = load_mesh(out / "pair.msh", "mm")
    assert len(mesh.cells) == summary["mesh"]["n_elements"]["total"]
