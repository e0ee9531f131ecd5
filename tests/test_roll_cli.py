"""``fe-impact roll``: its refusals, its outputs' figures at no load, Ctrl-C, the mesh reuse.

Everything here runs on rigid rotors or stops before the time loop (seconds);
the elastic sectors' checks are ``validation/rolling.py``'s.
"""

from __future__ import annotations

import json
import math
import os
import re
import signal
from pathlib import Path

import pytest

from fe_impact.cli.main import main
from fe_impact.errors import CaseError
from fe_impact.gears import default_gearset
from fe_impact.rolling import api
from fe_impact.rolling.api import RollInputs, check_inputs


@pytest.fixture(scope="module")
def gearset():
    return default_gearset()


def _refused(capsys, tmp_path, *options: str, out: str | None = None) -> str:
    """Run ``fe-impact roll --rigid ...``: exit 2, one line, no traceback, nothing written;
    returns the line."""
    before = sorted(tmp_path.rglob("*"))
    target = out if out is not None else str(tmp_path / "out")
    assert main(["roll", "--rigid", "--out", target, *options]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    lines = [line for line in err.splitlines() if line.startswith("fe-impact")]
    assert len(lines) == 1 and ": error: " in lines[0], err
    assert not (tmp_path / "out").exists()
    assert sorted(tmp_path.rglob("*")) == before
    return lines[0]


def _inputs(**kw) -> RollInputs:
    base = dict(stage=1, speed_rpm=1000.0, torque_nm=0.0, cycles=2.0, elastic=False)
    return RollInputs(**{**base, **kw})


# -- the step check's advice --------------------------------------------------------------
def test_step_advice_points_to_more_steps_or_a_higher_speed(gearset, capsys, tmp_path):
    # the rattle case at the default 240 steps: the advice must name the option
    # to change, and each alternative it gives must pass the same check (the
    # contact time falls slower than the step as the speed rises: t_c ~ v^-1/5)
    line = _refused(capsys, tmp_path, "--speed", "300")
    assert "--steps-per-cycle 240" in line and "--speed 300" in line, line
    assert "lower speed" not in line and "--quasi-static" in line, line
    steps = int(re.search(r"ask for --steps-per-cycle (\d+)", line).group(1))
    faster = int(re.search(r"--speed of at least (\d+) r/min", line).group(1))
    assert steps > 240 and faster > 300
    check_inputs(gearset, _inputs(speed_rpm=300.0, steps_per_cycle=steps))
    check_inputs(gearset, _inputs(speed_rpm=float(faster)))
    # the advice is the least that passes (to its rounding: 1 step, 1% of speed)
    with pytest.raises(CaseError):
        check_inputs(gearset, _inputs(speed_rpm=300.0, steps_per_cycle=steps - 2))
    with pytest.raises(CaseError):
        check_inputs(gearset, _inputs(speed_rpm=0.97 * faster))
    # the quasi-static way out: no step check
    check_inputs(gearset, _inputs(speed_rpm=300.0), check_step=False)


def test_quasi_static_option_runs_what_the_step_check_refuses(capsys, tmp_path):
    out = tmp_path / "qs"
    assert main(["roll", "--rigid", "--speed", "300", "--cycles", "0.3", "--quasi-static",
                 "--out", str(out)]) == 0
    assert json.loads((out / "roll.json").read_text())["info"]["complete"] is True


# -- the torque, before the step and in every mode -----------------------------------------
def test_torque_beyond_the_flanks_is_named_in_rigid_mode(gearset, capsys, tmp_path):
    # 2000 N m on one mesh: 40 x the nominal; refused for the torque, not the step
    line = _refused(capsys, tmp_path, "--speed", "1000", "--torque", "2000")
    assert line.startswith("fe-impact: error: --torque 2000:"), line
    assert "static contact strength" in line and "2400 MPa" in line, line
    top = float(re.search(r"at most ([0-9.e+]+) N m", line).group(1))
    # the torque it allows is the edge: p0 ~ T^(1/3) (Hertz), so 1% either side
    check_inputs(gearset, _inputs(torque_nm=0.99 * top), check_step=False)
    with pytest.raises(CaseError, match="--torque"):
        check_inputs(gearset, _inputs(torque_nm=1.01 * top), check_step=False)
    # elastic sectors: the lower yield limit (1.6 x 835 MPa) as well; 500 N m is
    # below the strength (p0 ~ 0.5^(1/3) x that of 968 N m: ~1.9 GPa) but above it
    check_inputs(gearset, _inputs(torque_nm=500.0), check_step=False)
    with pytest.raises(CaseError, match=r"--torque 500: .* 1336 MPa"):
        check_inputs(gearset, _inputs(torque_nm=500.0, elastic=True), check_step=False)


# -- the speed's upper bound ---------------------------------------------------------------
def test_speed_above_the_pitch_line_limit(gearset, capsys, tmp_path):
    line = _refused(capsys, tmp_path, "--speed", "1e6")
    radius = gearset.pinion.pitch_radius
    top = 200.0 / radius * 30.0 / math.pi     # 200 m/s on the pinion's pitch circle
    v = 1e6 * math.pi / 30.0 * radius
    assert "--speed 1e+06" in line and f"{v:.4g} m/s" in line, line
    assert f"at most {top:.4g} r/min" in line, line
    check_inputs(gearset, _inputs(speed_rpm=0.999 * top))


# -- the guide's examples pass the checks ----------------------------------------------------
def test_guide_examples_pass_the_checks(tmp_path, monkeypatch):
    import shlex

    class Reached(Exception):
        pass

    def reached(*a, **k):
        raise Reached

    monkeypatch.setattr(api, "roll", reached)
    monkeypatch.chdir(tmp_path)
    guide = Path(__file__).resolve().parents[1] / "docs" / "guide" / "roll.md"
    lines = [line.split("#")[0] for line in guide.read_text().splitlines()
             if line.startswith("fe-impact roll ")]
    assert len(lines) >= 2
    for line in lines:
        with pytest.raises(Reached):        # every check passed; roll() was reached
            main(shlex.split(line)[1:])
    assert list(tmp_path.iterdir()) == []


# -- --out and --mesh-dir before any computing -----------------------------------------------
@pytest.mark.parametrize("where", ["proc", "file", "under_file"])
def test_out_checked_before_computing(capsys, tmp_path, monkeypatch, where):
    def no_roll(*a, **k):
        raise AssertionError("computed before checking --out")

    monkeypatch.setattr(api, "roll", no_roll)
    (tmp_path / "a_file").write_text("x")
    target = {"proc": "/proc/none/x", "file": str(tmp_path / "a_file"),
              "under_file": str(tmp_path / "a_file" / "x")}[where]
    line = _refused(capsys, tmp_path, "--speed", "1000", out=target)
    assert f"--out {target}:" in line, line
    assert (tmp_path / "a_file").read_text() == "x"


def test_mesh_dir_checked_before_computing(capsys, tmp_path, monkeypatch):
    monkeypatch.setattr(api, "roll", lambda *a, **k: pytest.fail("computed"))
    (tmp_path / "a_file").write_text("x")
    before = sorted(tmp_path.rglob("*"))
    assert main(["roll", "--speed", "1000", "--torque", "50", "--mesh-dir",
                 str(tmp_path / "a_file"), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"--mesh-dir {tmp_path / 'a_file'}: is a file" in err, err
    assert sorted(tmp_path.rglob("*")) == before


# -- the ramps, the TE amplitude, the steps: one line each --------------------------------
@pytest.mark.parametrize("options, words", [
    (["--ramp-cycles", "-1"], ["--ramp-cycles -1:", ">= 0 and below --cycles 2"]),
    # the load would never reach --torque within the run
    (["--ramp-cycles", "5", "--cycles", "2"], ["--ramp-cycles 5:", "below --cycles 2"]),
    (["--ramp-cycles", "nan"], ["--ramp-cycles nan:"]),
    # 1 mm typed for 1 um: the seed stage's backlash is 137.5 um (ISO/TR 10064-2)
    (["--te-amplitude", "1000"], ["--te-amplitude 1000 um:", "at most 68.75 um",
                                  "backlash (137.5 um)"]),
    (["--te-amplitude", "nan"], ["--te-amplitude nan um:"]),
    (["--steps-per-cycle", "0"], ["--steps-per-cycle 0:", ">= 20"]),
    (["--steps-per-cycle", "5"], ["--steps-per-cycle 5:", ">= 20"]),
])
def test_one_line_each(capsys, tmp_path, options, words):
    line = _refused(capsys, tmp_path, "--speed", "1000", "--torque", "50", *options)
    for w in words:
        assert w in line, (w, line)


def test_te_amplitude_within_the_limit_and_negative_accepted(gearset):
    check_inputs(gearset, _inputs(te_amplitude=-68e-6, torque_nm=0.01))
    check_inputs(gearset, _inputs(ramp_cycles=0.0))


# -- a run at no load and a loaded one: the figures the summary shows ------------------------
@pytest.fixture(scope="module")
def no_load(tmp_path_factory):
    out = tmp_path_factory.mktemp("roll") / "noload"
    assert main(["roll", "--rigid", "--speed", "1000", "--cycles", "1", "--out",
                 str(out)]) == 0
    return out


def test_no_load_energy_balance_reads_against_the_kinetic_energy(no_load, capsys):
    # exact conjugate flanks at no load, the face gear at the conjugate speed: no force,
    # no work, the kinetic energy constant (conservation: its error is round-off)
    data = json.loads((no_load / "roll.json").read_text())
    balance = data["energy_balance"]
    assert balance["relative_to_work"] is None and data["energy_error"] is None
    assert balance["kinetic_j"] > 1.0
    assert balance["relative_to_kinetic"] < 1e-12


def test_no_load_lists_no_round_off_contacts(no_load):
    # the flanks never press (conjugate, unloaded): the 1e-13 N touches of round-off are
    # not contact events, nor is the start's touching drive flank
    data = json.loads((no_load / "roll.json").read_text())
    assert data["events"] == []
    assert (no_load / "events.csv").read_text().count("\n") == 1     # the header alone


def test_summary_line_at_no_load(capsys, tmp_path):
    assert main(["roll", "--rigid", "--speed", "1000", "--cycles", "0.2", "--out",
                 str(tmp_path / "o")]) == 0
    line = capsys.readouterr().out.splitlines()[0]
    assert "of the kinetic energy, no work done" in line, line
    assert "1.00e+00" not in line, line


def test_loaded_run_starts_without_a_rattle(gearset):
    # 50 N m ramped in over one cycle on the pair the run starts touching: the drive
    # flank stays loaded, so every later touch is a mesh-in beside a loaded pair and
    # none is a rattle (the coast flank is 137.5 um away); each event's peak force is
    # a real load (the nominal mesh force is 634 N)
    res = api.roll(gearset, _inputs(torque_nm=50.0, cycles=1.5))
    kinds = [e.kind for e in res.events]
    assert kinds and set(kinds) == {"mesh-in"}, kinds
    assert all(e.time_s > 2 * res.info["dt_s"] for e in res.events)
    assert all(e.peak_force_n > 10.0 and math.isfinite(e.closing_speed_m_s)
               for e in res.events)
    assert res.energy_balance()["relative_to_work"] < 1e-3


def test_rerun_removes_an_earlier_runs_frames(tmp_path):
    # an elastic run's PVD series left in --out must not play as this rigid run's
    out = tmp_path / "o"
    (out / "frames").mkdir(parents=True)
    for name in ("rolling.pvd", "frame_000012.vtu"):
        (out / "frames" / name).write_text("old")
    (out / "notes.txt").write_text("mine")
    assert main(["roll", "--rigid", "--speed", "1000", "--cycles", "0.2", "--out",
                 str(out)]) == 0
    assert not (out / "frames").exists()
    assert (out / "notes.txt").read_text() == "mine" and (out / "roll.json").exists()


def test_teeth_passing_through_are_flagged():
    # drive flanks 44 um into each other (a third of the backlash) with no force: an
    # overlap no contact explains; the same TE with the drive flank loaded is not one
    from types import SimpleNamespace

    import numpy as np

    b = 137.5e-6
    te = np.array([0.0, 1e-6, 44e-6])
    force = np.zeros((3, 2, 2))
    run = SimpleNamespace(te_m=te, pair_force_n=force, time_s=np.arange(3) * 1e-5)
    assert "went through each other: TE 44 um" in api.passed_through(run, b)
    force[:, 0, 0] = 5e3
    assert api.passed_through(run, b) == ""
    run.te_m = np.array([0.0, -b, -1.3 * b])       # the coast side, unloaded
    assert "went through" in api.passed_through(run, b)


# -- Ctrl-C --------------------------------------------------------------------------------
def test_ctrl_c_during_set_up_stops_at_once_writing_nothing(capsys, tmp_path, monkeypatch):
    from fe_impact.rolling import model, run

    build = model.ContactGeometry.build
    stepped = []

    def interrupted_build(*a, **k):
        os.kill(os.getpid(), signal.SIGINT)       # as Ctrl-C during the set-up
        return build(*a, **k)

    monkeypatch.setattr(model.ContactGeometry, "build", interrupted_build)
    monkeypatch.setattr(run, "integrate", lambda *a, **k: stepped.append(1))
    out = tmp_path / "out"
    assert main(["roll", "--rigid", "--speed", "1000", "--out", str(out)]) == 130
    assert "interrupted (SIGINT)" in capsys.readouterr().err
    assert not stepped and not out.exists()


def test_ctrl_c_during_the_steps_writes_what_is_done(capsys, tmp_path, monkeypatch):
    from fe_impact.rolling import run

    integrate = run.integrate

    def interrupted(*a, **k):
        os.kill(os.getpid(), signal.SIGINT)       # as Ctrl-C as the first step starts
        return integrate(*a, **k)

    monkeypatch.setattr(run, "integrate", interrupted)
    out = tmp_path / "out"
    assert main(["roll", "--rigid", "--speed", "1000", "--out", str(out)]) == 130
    data = json.loads((out / "roll.json").read_text())
    assert data["info"]["complete"] is False and data["info"]["n_steps"] >= 1


def test_interrupted_meshing_leaves_nothing(gearset, tmp_path, monkeypatch):
    from fe_impact.rolling import sectors

    def half_mesh(gearset, stage, level, out_dir, **k):
        Path(out_dir, "sectors.msh").write_text("half")
        raise KeyboardInterrupt

    monkeypatch.setattr(sectors, "build_sectors", half_mesh)
    with pytest.raises(KeyboardInterrupt):
        api.sector_mesh(gearset, _inputs(elastic=True), tmp_path / "out" / "mesh")
    assert list(tmp_path.iterdir()) == []


# -- a reused mesh, from another working folder ----------------------------------------------
def test_reused_mesh_found_from_another_folder(gearset, tmp_path, monkeypatch):
    from fe_impact.rolling import sectors

    made = []

    def fake_mesh(gearset, stage, level, out_dir, **k):
        path = Path(out_dir) / "sectors.msh"
        path.write_text("mesh")
        made.append(path)
        return sectors.SectorMesh(path, 0.1, 0.2, 10, 5, 1.0, 0.006)

    monkeypatch.setattr(sectors, "build_sectors", fake_mesh)
    (tmp_path / "first").mkdir()
    (tmp_path / "second").mkdir()
    monkeypatch.chdir(tmp_path / "first")
    first = api.sector_mesh(gearset, _inputs(elastic=True), Path("e1") / "mesh")
    assert Path(first["mesh_path"]) == Path("e1") / "mesh" / "sectors.msh"
    stored = json.loads((Path("e1") / "mesh" / "sectors.json").read_text())
    assert stored["mesh_path"] == "sectors.msh"       # relative to the mesh folder
    monkeypatch.chdir(tmp_path / "second")
    folder = tmp_path / "first" / "e1" / "mesh"
    again = api.sector_mesh(gearset, _inputs(elastic=True), folder)
    assert len(made) == 1                              # reused, not meshed again
    assert Path(again["mesh_path"]) == folder / "sectors.msh"
    assert Path(again["mesh_path"]).read_text() == "mesh"
