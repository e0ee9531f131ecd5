"""The command line, called as a function (``main(argv) -> int``)."""

from __future__ import annotations

import json

import meshio
import numpy as np

from fe_impact.cli.main import main


def test_solve_writes_summary_and_fields(coarse_hertz_case, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["solve", str(coarse_hertz_case), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert printed.count("step ") == 5  # one progress line per load step
    summary = json.loads((out / "summary.json").read_text())
    steps = summary["steps"]
    assert [s["value"] for s in steps] == [-5e-6, -1e-5, -1.5e-5, -2e-5, -2.5e-5]
    for key in ("contact_force", "contact_area", "max_pressure", "max_penetration",
                "iterations"):
        assert all(key in s for s in steps)
    forces = [s["contact_force"] for s in steps]
    assert np.all(np.diff(forces) > 0)
    # The VTU frames carry the fields ParaView needs; displacement matches the load.
    m = meshio.read(out / "step_005.vtu")
    assert {"displacement", "contact_pressure"} <= set(m.point_data)
    assert "von_mises" in m.cell_data
    assert np.isclose(m.point_data["displacement"][:, 2].min(), -2.5e-5, rtol=1e-9)
    assert np.isclose(m.point_data["contact_pressure"].max(), steps[-1]["max_pressure"])
    assert (out / "static.pvd").read_text().count("<DataSet") == 5
    assert not list(out.glob(".*"))  # no temporary files left behind


def test_help_and_version(capsys):
    assert main([]) == 0
    assert "solve" in capsys.readouterr().out
