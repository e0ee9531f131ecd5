"""Calibration planning: impact speeds from the operating point and option checks."""

from __future__ import annotations

import math

import pytest

from fe_impact.calibration.sweep import ImpactCase, Settings, mesh_impact_speed, plan_cases
from fe_impact.cli.main import main
from fe_impact.errors import CalibrationError
from fe_impact.gears import default_gearset


def test_mesh_impact_speed_closed_form():
    # Seed eq. 4 with w_f r_f = w_c r_c: v = w r (sqrt 2 - sqrt(1 + cos^2 20 deg)).
    # At 1000 r/min and r = 28.5 mm: w r = 2.9845 m/s; factor 0.041981.
    v = mesh_impact_speed(28.5e-3, math.radians(20.0), 1000.0)
    assert v == pytest.approx(2.98451302 * (math.sqrt(2) - math.sqrt(1 + 0.88302222)),
                              rel=1e-7)
    assert v == pytest.approx(0.12529, rel=1e-4)
    # linear in the speed
    assert mesh_impact_speed(28.5e-3, math.radians(20.0), 100.0) == pytest.approx(v / 10)


def test_default_plan_is_three_stages_by_three_speeds():
    cases = plan_cases(default_gearset())
    assert len(cases) == 9
    assert {c.stage for c in cases} == {1, 2, 3}
    assert {c.face_teeth for c in cases} == {56, 68, 80}
    assert len({c.id for c in cases}) == 9
    switch = plan_cases(default_gearset(), switch=True)
    # into stages 2 and 3 at three speeds, by eq. 5 and by rigid kinematics
    assert len(switch) == 9 + 12 and {c.kind for c in switch} == {"mesh", "switch"}
    assert len({c.id for c in switch}) == 21
    gearset = default_gearset()
    (kin,) = [c for c in switch if c.basis == "kinematic" and c.stage == 2
              and c.speed_rpm == 300.0]
    # r_bp w_p |N_2 / N_1 - 1| by hand: r_bp = m N_p cos(a) / 2
    pinion = gearset.pinion
    r_bp = 0.5 * gearset.module * pinion.teeth * math.cos(math.radians(pinion.pressure_angle_deg))
    assert kin.impact_speed == pytest.approx(r_bp * 300 * math.pi / 30 * (68 / 56 - 1), rel=1e-12)
    assert len(plan_cases(gearset, switch="eq5")) == len(plan_cases(gearset, switch="kinematic"))\
        == 9 + 6
    assert {c.basis for c in plan_cases(gearset, switch="kinematic") if c.kind == "switch"} \
        == {"kinematic"}


@pytest.mark.parametrize("kwargs,pattern", [
    ({"stages": [4]}, r"--stages \[4\]: the gear set has stages 1..3"),
    ({"speeds_rpm": [100], "impact_speeds": [0.1]}, r"not both"),
    ({"impact_speeds": [-0.1]}, r"--impact-speeds \[-0.1\]: need positive"),
    ({"stages": [1, 1]}, r"--stages \[1, 1\]: a value is repeated"),
    ({"speeds_rpm": [100, 100]}, r"--speeds \[100, 100\]: a value is repeated"),
    ({"impact_speeds": [0.01, 0.010000001]},
     r"--impact-speeds: two speeds give the case stage1_mesh_10mms"),
    ({"impact_speeds": [0.1], "switch": "eq5"}, r"--switch with --impact-speeds"),
    ({"stages": [1], "switch": "both"}, r"--switch with --stages \[1\]: a switch goes into "
                                        r"stage 2 or later"),
])
def test_bad_plans(kwargs, pattern):
    with pytest.raises(CalibrationError, match=pattern):
        plan_cases(default_gearset(), **kwargs)


@pytest.mark.parametrize("kwargs,pattern", [
    ({"level": "huge"}, r"level = 'huge': pick one of \['coarse', 'default', 'fine'\]"),
    ({"integrator": "rk4"}, r"integrator = 'rk4'"),
    ({"cycle_level": "huge"}, r"mesh-cycle level = 'huge': pick one of \['coarse', "),
])
def test_bad_settings(kwargs, pattern):
    with pytest.raises(CalibrationError, match=pattern):
        Settings(**kwargs)


@pytest.mark.parametrize("argv,pattern", [
    (["--level", "huge"], "--level 'huge': pick one of coarse, default, fine"),
    (["--mesh-cycle-level", "huge"], "--mesh-cycle-level 'huge': pick one of coarse"),
    (["--stages", "0"], r"--stages \[0\]"),
    (["--workers", "0"], "--workers 0: must be at least 1"),
])
def test_cli_rejects_bad_options(tmp_path, capsys, argv, pattern):
    assert main(["calibrate", "--out", str(tmp_path / "o"), *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("fe-impact: error:") and pattern.replace("\\", "") in err
    assert not (tmp_path / "o" / "calibration.json").exists()


def test_more_workers_than_cores_get_a_warning(tmp_path, caplog, monkeypatch):
    # Legal but surely unintended: eight workers on two cores share them and each
    # holds its own case's memory. (The run then stops at the bad level.)
    from fe_impact.calibration import cluster

    monkeypatch.setattr(cluster, "cores", lambda: 2)
    with caplog.at_level("WARNING"):
        assert main(["calibrate", "--out", str(tmp_path / "o"), "--workers", "8",
                     "--level", "huge"]) == 2
    assert "--workers 8 on 2 cores" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING"):
        main(["calibrate", "--out", str(tmp_path / "o"), "--workers", "2", "--level", "huge"])
    assert "--workers" not in caplog.text


def test_mesh_cycle_level_keys_the_positions_not_the_impacts():
    # The positions' mesh level enters their resume key (default: one level
    # below the impacts'); the impacts' keys do not depend on it.
    from fe_impact.calibration import meshcycle
    from fe_impact.calibration.sweep import case_hash

    impact = ImpactCase(1, 68, "mesh", 0.0387, 300.0)
    position = meshcycle.PositionCase(1, 68, 0.0, (50.0, 100.0))
    plain, coarse = Settings(), Settings(cycle_level="coarse")
    assert plain.position_level == "coarse" and coarse.position_level == "coarse"
    assert Settings(level="fine").position_level == "default"
    assert Settings(level="coarse").position_level == "coarse"
    assert Settings(cycle_level="fine").position_level == "fine"
    assert case_hash(impact, plain, "g") == case_hash(impact, coarse, "g")
    assert case_hash(position, Settings(cycle_level="default"), "g") != \
        case_hash(position, coarse, "g")
    assert case_hash(position, Settings(level="coarse"), "g") == \
        case_hash(position, coarse, "g")
    # What the files say is the level the positions were meshed at, not the option.
    assert plain.to_dict()["cycle_level"] == "coarse" and plain.to_dict()["level"] == "default"


def test_case_ids_are_stable():
    c = ImpactCase(2, 68, "mesh", 0.0387, 300.0)
    assert c.id == "stage2_mesh_300rpm"


def test_resume_key_covers_settings_version_and_mesh_format(monkeypatch):
    # A stored result is reused only for the same case, settings, fe-impact
    # version and mesh format: each of them must change the key.
    from fe_impact.calibration import sweep as cal
    from fe_impact.meshing import toothpair

    c = cal.ImpactCase(2, 68, "mesh", 0.0387, 300.0)
    key = cal.case_hash(c, cal.Settings(), "gear set")
    assert key == cal.case_hash(c, cal.Settings(), "gear set")
    assert key != cal.case_hash(cal.ImpactCase(2, 68, "mesh", 0.04, 300.0), cal.Settings(),
                                "gear set")
    assert key != cal.case_hash(c, cal.Settings(level="coarse"), "gear set")
    assert key != cal.case_hash(c, cal.Settings(), "another gear set")
    monkeypatch.setattr(toothpair, "MESH_FORMAT", toothpair.MESH_FORMAT + 1)
    assert key != cal.case_hash(c, cal.Settings(), "gear set")
    position = cal.PositionCase(1, 56, 2.0, (50.0, 100.0))
    moved = cal.case_hash(position, cal.Settings(), "gear set")
    monkeypatch.undo()
    assert moved != cal.case_hash(position, cal.Settings(), "gear set")
    from fe_impact.calibration import planning

    monkeypatch.setattr(planning, "__version__", "0.0.0-other")
    assert key != cal.case_hash(c, cal.Settings(), "gear set")


def test_the_seed_studies_run_are_those_the_calibration_has_laws_for():
    # a study runs only on stages with laws: Table 1 engages stage 1, Tables 2 and 4
    # stage 2, Table 3 stage 3, the two switching runs all three
    from fe_impact.api import seed_studies as _seed_studies
    from fe_impact.gears import default_gearset

    gearset = default_gearset()
    assert _seed_studies(gearset, None) == ("table1", "table2", "table3", "table4",
                                            "variable-speed", "variable-load")
    assert _seed_studies(gearset, [1]) == ("table1",)
    assert _seed_studies(gearset, [2]) == ("table2", "table4")
    assert _seed_studies(gearset, [1, 3]) == ("table1", "table3")


def test_an_interrupted_study_leaves_the_calibration_complete(tmp_path):
    # Ctrl-C while the studies run: the calibration stays "completed" in summary.json,
    # the switching entry says "stopped", and the interrupt goes on to the CLI (130).
    import json

    from fe_impact.calibration import execution
    from fe_impact.output.drawing import draw_here

    (tmp_path / "summary.json").write_text(json.dumps({"status": "completed",
                                                       "calibration": "calibration.json"}))
    (tmp_path / "report.md").write_text("# report\n")
    ran = []

    def job(gearset_text, name, calibration, out):
        ran.append(name)
        if name == "table2":
            raise KeyboardInterrupt
        return {}

    with pytest.raises(KeyboardInterrupt):
        execution._run_studies(tmp_path, tmp_path / "calibration.json", "",
                               execution.Studies(("table1", "table2", "table3"), job),
                               draw_here)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary == {"status": "completed", "calibration": "calibration.json",
                       "switching": "stopped"}
    assert ran == ["table1", "table2"]
    assert "Switching runs" not in (tmp_path / "report.md").read_text()


def test_studies_started_before_the_summary_are_tabled_into_it(tmp_path):
    # On the workers the studies start as soon as calibration.json is written, before
    # report.md and summary.json: starting must not read them, and the wait tables
    # the studies into the summary written meanwhile; a Ctrl-C in the wait marks
    # them stopped and leaves the calibration complete.
    import json

    from fe_impact.calibration import execution

    studies = execution.Studies(("table1", "table2"), lambda *args: {})
    queued = []

    def later(jobs):        # an asynchronous Draw: the jobs run when waited for
        queued.extend(jobs)
        return lambda: [name for name, fn, args in jobs if fn(*args) is not None]

    finish = execution._start_studies(tmp_path, tmp_path / "calibration.json", "", studies,
                                      later)
    assert [name for name, *_ in queued] == ["switching study table1",
                                             "switching study table2"]
    assert not (tmp_path / "summary.json").exists()
    (tmp_path / "summary.json").write_text(json.dumps({"status": "completed"}))
    (tmp_path / "report.md").write_text("# report\n")
    finish()
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary == {"status": "completed",
                       "switching": ["switching/table1", "switching/table2"]}

    def interrupted(jobs):
        def wait():
            raise KeyboardInterrupt
        return wait

    finish = execution._start_studies(tmp_path, tmp_path / "calibration.json", "",
                                      execution.Studies(("table3",), lambda *args: {}),
                                      interrupted)
    with pytest.raises(KeyboardInterrupt):
        finish()
    assert json.loads((tmp_path / "summary.json").read_text())["switching"] == "stopped"


def test_report_names_the_fits_that_stopped_at_a_bound_or_did_not_converge():
    # fit_impact_law's message is the optimiser's status, then one remark per
    # parameter at a bound; a fit without remarks that converged is not listed.
    from types import SimpleNamespace

    from fe_impact.calibration.report import _fit_remarks

    def case(cid, success, message):
        return SimpleNamespace(id=cid, fit_quality=SimpleNamespace(success=success,
                                                                   message=message))

    clean = case("clean", True, "`ftol` termination condition is satisfied.")
    bound = case("stage1_mesh_100rpm", True, "`ftol` termination condition is satisfied.; "
                 "d at its upper bound")
    lost = case("stage3_mesh_100rpm", False, "The maximum number of function evaluations "
                "is exceeded.")
    assert _fit_remarks([clean, SimpleNamespace(id="old", fit_quality=None)]) == []
    lines = _fit_remarks([clean, bound, lost])
    assert lines[1].startswith("Fits to read with care")
    assert lines[-2:] == ["- stage1_mesh_100rpm: d at its upper bound",
                          "- stage3_mesh_100rpm: not converged (The maximum number of "
                          "function evaluations is exceeded.)"]


def test_terminal_summary_gives_each_kind_of_impact_its_own_line():
    # A tip edge's law spans other K and exponents than the flanks'; beside each
    # kind's span stands that kind's own closed form.
    from fe_impact.calibration.report import terminal_summary

    def case(kind, speed, k, closed_k):
        return {"stage": 1, "kind": kind, "impact_speed": speed,
                "impact": {"k": k, "exponent": 1.4, "cmax": 2.0},
                "closed_form": {"k": closed_k, "exponent": 1.5}}

    doc = {"cases": [case("mesh", 0.0125, 1.2e10, 1.9e10), case("mesh", 0.125, 1.3e10, 1.9e10),
                     case("corner-approach", 0.048, 4.3e9, 6.6e10)]}
    lines = terminal_summary(doc)
    assert len(lines) == 2
    assert lines[0].startswith("stage 1: 2 FE impacts at 12.5-125 mm/s: K 1.2e+10-1.3e+10")
    assert "closed form 1.9e+10" in lines[0]
    assert lines[1].startswith("         1 FE approach-corner impact at 48 mm/s: K 4.3e+09 ")
    assert "closed form 6.6e+10" in lines[1]


def test_report_names_the_impacts_whose_damping_the_history_leaves_open():
    from types import SimpleNamespace

    from fe_impact.calibration.report import _undetermined_damping

    def case(cid, cmax_range, d_range):
        return SimpleNamespace(id=cid, fe=SimpleNamespace(restitution=0.99979),
                               fit_quality=SimpleNamespace(cmax_range=cmax_range,
                                                           d_range=d_range))

    tight = case("tight", (2.0, 2.01), (1e-6, 1.001e-6))
    old = case("old-file", None, None)                 # written before the ranges
    wide = case("stage2_mesh_100rpm", (0.5, 2.9), (1.2e-7, 1.7e-6))
    assert _undetermined_damping([tight, old]) == []
    lines = _undetermined_damping([tight, wide, old])
    assert lines[1].startswith("The history does not determine the damping")
    assert lines[-1] == "- stage2_mesh_100rpm (e = 0.99979): cmax 0.5-2.9 N s/m, d 0.12-1.7 um"


def test_a_run_that_fails_before_any_case_leaves_no_output_folder(tmp_path, monkeypatch):
    # A scheduler that never answers fails after its 10 s timeout, before any file is
    # written (here the failure is raised in its place): the --out the run made goes
    # with it, as a mistaken option leaves none. A folder that was there stays.
    from fe_impact.calibration import execution as cal

    def no_scheduler(*args, **kwargs):
        raise CalibrationError("--scheduler tcp://127.0.0.1:1: cannot connect (timed out)")

    monkeypatch.setattr(cal, "_run_dask", no_scheduler)
    cases = plan_cases(default_gearset(), stages=[1], speeds_rpm=[300])
    for existed in (False, True):
        out = tmp_path / f"out{existed}"
        if existed:
            out.mkdir()
        with pytest.raises(CalibrationError, match="cannot connect"):
            cal.calibrate("", cases, Settings(), out, tmp_path / "cache", workers=1,
                          scheduler="tcp://127.0.0.1:1")
        assert out.exists() == existed


def test_friction_enters_the_resume_key_but_not_the_mesh():
    # A changed coefficient computes a case again; a frictionless companion is a case of
    # its own (its own id and key) on the same mesh folder as the case it companions.
    from fe_impact.calibration import meshcycle, planning

    rough = ImpactCase(1, 56, "mesh", 0.0376, 300.0, friction=(0.05, 0.02))
    other = ImpactCase(1, 56, "mesh", 0.0376, 300.0, friction=(0.08, 0.02))
    twin = ImpactCase(1, 56, "mesh", 0.0376, 300.0, companion=True)
    s, g = Settings(), "gear set"
    keys = {planning.case_hash(c, s, g) for c in (rough, other, twin)}
    assert len(keys) == 3 and twin.id == rough.id + "_frictionless"
    assert {planning.mesh_key(c, s, g) for c in (rough, other, twin)} == \
        {planning.case_hash(ImpactCase(1, 56, "mesh", 0.0376, 300.0), s, g)}
    at = meshcycle.PositionCase(1, 56, 2.0, (50.0, 100.0), friction=(0.05, 0.02))
    alone = meshcycle.PositionCase(1, 56, 2.0, (50.0, 100.0), companion=True)
    assert meshcycle.case_hash(at, "coarse", 2, g) != meshcycle.case_hash(alone, "coarse", 2, g)
    assert meshcycle.mesh_hash(at, "coarse", 2, g) == meshcycle.mesh_hash(alone, "coarse", 2, g)


def test_cases_take_the_gear_sets_friction_and_one_impact_and_position_get_companions():
    from dataclasses import replace

    from fe_impact.calibration import meshcycle
    from fe_impact.calibration.planning import friction_companions
    from fe_impact.gears.gearset import FlankFriction

    gs = default_gearset()
    impacts = plan_cases(gs, stages=[2, 1])
    positions = meshcycle.plan_positions(gs, [1], positions=5)
    assert {c.friction for c in impacts + positions} == {(0.05, 0.02)}
    impact, position = friction_companions(gs, impacts, positions)
    # stage 1 at the median of the planned speeds (100, 300, 1000 r/min); the stage-1
    # position nearest the middle of the path of contact (the middle one of five)
    assert (impact.stage, impact.speed_rpm, impact.friction) == (1, 300.0, (0.0, 0.0))
    middle = [p for p in positions if p.stage == 1][2]
    assert position == replace(middle, friction=(0.0, 0.0), companion=True)
    smooth = replace(gs, friction=FlankFriction(0.0, 0.0))
    assert friction_companions(smooth, plan_cases(smooth, [1]), positions) == []
    assert {c.friction for c in plan_cases(smooth, [1])} == {(0.0, 0.0)}


def test_a_companion_takes_the_record_of_its_case_that_fell_back_to_frictionless(tmp_path):
    # A position whose frictional solve is refused (a contact zone too large to condense
    # the friction on) is solved frictionless: the very solve its companion asks for (same
    # mesh, loads and solver). The companion then takes that record under its own id and
    # resume key, which a resume accepts, and computes nothing. A case solved with
    # friction, or not finished yet, leaves its companion to be computed.
    from dataclasses import replace

    from fe_impact.calibration.execution import finished_record, frictionless_twin
    from fe_impact.calibration.meshcycle import PositionCase, PositionRecord
    from fe_impact.calibration.planning import case_hash
    from fe_impact.gears.gearset import default_gearset_path
    from fe_impact.output.files import write_json

    text = default_gearset_path().read_text(encoding="utf-8-sig")
    s = Settings(level="coarse")
    base = PositionCase(1, 56, 2.0, (50.0, 100.0), friction=(0.05, 0.02))
    alone = replace(base, friction=(0.0, 0.0), companion=True)
    record = PositionRecord(
        id=base.id, stage=1, roll_angle_deg=2.0, end="", forces=[50.0, 100.0],
        approaches=[1e-6, 1.6e-6], torques=[1.3, 2.6], rotations=[-1e-5, -2e-5],
        contact_areas=[1e-7, 2e-7], max_pressures=[1e9, 1.3e9],
        hertz_approaches=[5e-7, 8e-7], stiffness=2e10, exponent=1.4, fit_error=0.0,
        nominal_force=50.0, nominal_stiffness=5e7, lever=0.0268, edge="",
        ellipse_outline=[], footprint=[], flank_edges=[], n_dofs=40000,
        hash=case_hash(base, s, text), timings_s={"total": 9.0}, friction=[0.0, 0.0],
        friction_note="solved frictionless: the contact zone holds 9000 coordinates")
    out = tmp_path / "out"
    assert frictionless_twin(out, alone, s, text) is None          # not finished yet
    write_json(out / "cases" / base.id / "result.json", record.to_dict())
    assert frictionless_twin(out, base, s, text) is None           # not a companion
    twin = frictionless_twin(out, alone, s, text)
    assert twin.id == alone.id and twin.companion and twin.friction == [0.0, 0.0]
    assert twin.approaches == record.approaches and twin.friction_note == ""
    assert finished_record(out, alone, s, text) == twin
    rough = tmp_path / "rough"
    write_json(rough / "cases" / base.id / "result.json",
               replace(record, friction=[0.05, 0.02], friction_note="").to_dict())
    assert frictionless_twin(rough, alone, s, text) is None        # solved with friction
