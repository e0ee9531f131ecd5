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


def test_static_solve_stopped_keeps_the_steps_done(coarse_hertz_case, tmp_path, monkeypatch,
                                                   capsys):
    """A SIGTERM during the third load step: summary.json with the two steps done and
    status "stopped", exit status 143, one line, no temporary file."""
    import signal

    from fe_impact.interrupts import Interrupted
    from fe_impact.output.files import is_temporary
    from fe_impact.solvers.static import StaticSolver

    solve_step = StaticSolver.solve_step

    def interrupted_at_the_third(self, i):
        if i == 2:
            raise Interrupted(signal.SIGTERM)
        return solve_step(self, i)

    monkeypatch.setattr(StaticSolver, "solve_step", interrupted_at_the_third)
    out = tmp_path / "out"
    assert main(["solve", str(coarse_hertz_case), "--out", str(out)]) == 143
    err = capsys.readouterr().err
    assert err.strip().splitlines()[-1] == ("fe-impact: interrupted (SIGTERM); what was written "
                                            "is kept, marked stopped; a rerun starts again")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "stopped" and summary["error"] == "interrupted (SIGTERM)"
    assert [s["value"] for s in summary["steps"]] == [-5e-6, -1e-5]
    assert sorted(p.name for p in out.glob("step_*.vtu")) == ["step_001.vtu", "step_002.vtu"]
    assert not [p for p in out.iterdir() if is_temporary(p)]


def test_help_and_option_errors_do_not_load_the_solvers():
    """The parser quotes its defaults from fe_impact.defaults: building it must not
    import numba, scipy's optimisers, gmsh or the switching kernels (1.4-2.8 s
    before a help text when it did). A fresh interpreter, since this one has
    them all loaded."""
    import subprocess
    import sys

    code = ("import sys\n"
            "from fe_impact.cli.main import main\n"
            "for argv in (['--help'], ['mesh', '--help'], ['switching', '--help'],\n"
            "             ['calibrate', '--no-such-option']):\n"
            "    main(argv)\n"
            "heavy = [m for m in ('numba', 'scipy.optimize', 'gmsh', 'skfem',\n"
            "                     'fe_impact.switching.simulation') if m in sys.modules]\n"
            "print('HEAVY', heavy)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert "HEAVY []" in out.stdout, out.stdout[-500:] + out.stderr[-2000:]
