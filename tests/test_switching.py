"""Lumped multistage ratio-switching model: kinematics, laws, conservation, CLI.

Each test compares with a truth computed independently of the kernel (a one-degree-of-
freedom impact integrated by `fe_impact.physics.laws.simulate_impact`, rigid-body
kinematics, momentum and energy theorems, limits of the seed's formulas worked by hand,
the seed's printed values), with the tolerance justified where it is set.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import math
import re

import numpy as np
import pytest
from scipy.optimize import brentq

from fe_impact.cli.switching import register
from fe_impact.errors import CalibrationError, CaseError
from fe_impact.gears import default_gearset
from fe_impact.gears.kinematics import _RackPinionFrame
from fe_impact.physics import laws
from fe_impact.switching import (
    PRESETS,
    DriveModel,
    Friction,
    LawSet,
    LawTable,
    Segment,
    StageSchedule,
    load_calibration,
    mechanical_energy,
    mesh_geometry,
    seed_switching_speed,
    series_statistics,
    simulate,
    switching_speed,
)
from fe_impact.switching.seed_tables import SEED_TABLES

RPM = 2.0 * math.pi / 60.0
GEARSET = default_gearset()
#: No excitation and no losses outside the contact law.
QUIET = dict(transmission_error=0.0, drag_torque=0.0, friction=None, coupling_damping_ratio=0.0)
#: Error control far below the checked tolerances.
TIGHT = dict(rtol=1e-10, length_tol=1e-13, speed_tol=1e-10)


def _law_set(k: float, cmax: float, d: float, exponent: float = 1.5) -> LawSet:
    """The same IMPACT law for every stage, kind and speed."""
    tables = {}
    for stage in (1, 2, 3):
        for kind in ("mesh", "switch"):
            tables[(stage, kind)] = LawTable(stage, kind, np.array([1.0]), np.array([k]),
                                             np.array([exponent]), np.array([cmax]),
                                             np.array([d]), "test")
    return LawSet(tables, "test")


# -- kinematics and geometry ------------------------------------------------------------------
def test_contact_path_and_corner_gaps():
    p = GEARSET.pinion
    sharp = dataclasses.replace(GEARSET, pinion=dataclasses.replace(p, tip_edge_radius=0.0),
                                face_tip_edge_radius=0.0)
    geo = mesh_geometry(sharp)
    m, alpha = p.module, math.radians(p.pressure_angle_deg)
    r_p, r_b, r_a = p.pitch_radius, p.pitch_radius * math.cos(alpha), p.pitch_radius + m
    # Textbook contact ratio of a pinion on a rack with sharp tips (Litvin & Fuentes,
    # ch. 10): [sqrt(r_a^2 - r_b^2) - r_p sin a + ha m / sin a] / (pi m cos a) = 1.7623
    # for z = 19.
    textbook = (math.sqrt(r_a**2 - r_b**2) - r_p * math.sin(alpha) + m / math.sin(alpha)) / (
        math.pi * m * math.cos(alpha))
    assert geo.contact_ratio == pytest.approx(textbook, rel=1e-12)  # same closed form: round-off
    # two pairs for the first (eps - 1) of each base pitch, one pair for the rest
    assert [geo.pair_count(f * geo.base_pitch) for f in (0.1, 0.7, 0.8, 0.95)] == [2, 2, 1, 1]
    # The tables reproduce the exact planar geometry they are built from, sharp and with
    # the default set's rounded tip edges; the spline in sqrt(delta) is good to ~1e-5
    # relative, far below the um-level approaches it gates.
    rounded = _RackPinionFrame(r_p, alpha, m, r_a, GEARSET.face_tip_edge_radius,
                               p.tip_edge_radius)
    for gears, frame in ((sharp, _RackPinionFrame(r_p, alpha, m, r_a)), (GEARSET, rounded)):
        geo = mesh_geometry(gears)
        assert (geo.s_start, geo.s_end) == (frame.s_start, frame.s_end)
        for table, exact in ((geo.approach, frame.approach_gap), (geo.recess, frame.recess_gap)):
            delta = np.linspace(0.02, 1.0, 50) * table.delta_max
            g, slope = table(delta)
            np.testing.assert_allclose(g, exact(delta), rtol=1e-4)
            # slope against a central difference of the exact gap (step 1e-9 m:
            # truncation ~1e-9 relative, round-off ~1e-7)
            fd = (exact(delta + 1e-9) - exact(delta - 1e-9)) / 2e-9
            np.testing.assert_allclose(slope, fd, rtol=1e-3, atol=1e-6)
            # A tip edge leaves the flank tangentially: the gap starts quadratically.
            assert table(np.array(1e-7))[0] < 1e-12


# -- conservation and balance laws ----------------------------------------------------------------
def test_undamped_frictionless_run_conserves_energy():
    # Free pinion (no input torque), rings rattling between both flanks at 0.04 m/s while
    # the pinion rolls two base pitches, so tooth pairs enter and leave through their tip
    # corners and the transmission error (kept, 2 um) moves the flanks: every force derives
    # from a potential, so kinetic + web + contact energy is constant.
    model = DriveModel(drive="torque", laws=_law_set(6.5e10, 0.0, 1e-6),
                       **{**QUIET, "transmission_error": 2e-6}, **TIGHT)
    schedule = StageSchedule((Segment(0.1, 1, 60.0),))
    rates = [0.0, -0.5, -0.5, -0.5, -0.5]
    run = simulate(model, schedule, initial_rates=rates, sample_interval=1e-4)
    energy = mechanical_energy(run)
    assert len(run.events) >= 10  # impacts on both flanks (20 in this run)
    assert {-1, 1} <= set(run.events.flank.tolist())
    # 1e-6 relative: the requested bound. The integrator's local error (rtol 1e-10 on the
    # states) accumulated over ~5e4 steps stays below 1e-7 (6e-8 measured).
    assert np.ptp(energy) / energy[0] < 1e-6


def test_friction_only_dissipates():
    # The same free rattle with Coulomb friction (seed eqs. 9-10): the friction power
    # -mu F |v_slide| <= 0, so the energy never rises and has dropped by the end.
    friction = Friction(static=0.05, dynamic=0.02)
    model = DriveModel(drive="torque", laws=_law_set(6.5e10, 0.0, 1e-6),
                       **{**QUIET, "friction": friction}, **TIGHT)
    run = simulate(model, StageSchedule((Segment(0.1, 1, 60.0),)),
                   initial_rates=[0.0, -0.5, -0.5, -0.5, -0.5], sample_interval=1e-4)
    energy = mechanical_energy(run)
    # rises no more than the frictionless run's numerical drift (< 1e-7, test above)
    assert np.max(np.diff(energy)) / energy[0] < 1e-7
    assert energy[-1] < energy[0] * (1.0 - 1e-6)
    assert np.any(run.series["friction_torque_Nm"] != 0.0)


def test_mean_mesh_force_is_load_over_base_radius():
    # Stage 2 at 300 r/min carrying 2 N m plus 0.01 N m drag. Angular momentum of rings +
    # output: dL/dt = n r_b F - T_load - T_drag, exactly (the ring lever is r_b for every
    # tooth pair). So the time-mean force is (T_load + T_drag)/(n r_b) + dL/(n r_b T).
    model = DriveModel(transmission_error=1e-6, friction=None)
    load = 2.0
    run = simulate(model, StageSchedule((Segment(0.3, 2, 300.0, load),)), sample_interval=1e-4)
    mean_force = series_statistics(run)["2"]["impact_force"][0]
    n, lever = model.pinions, model.base_levers[1]
    s = run.series
    inertias = [*model.ring_inertias, model.output_j]
    speeds = [s["ring1_speed_rad_s"], s["ring2_speed_rad_s"], s["ring3_speed_rad_s"],
              s["output_speed_rad_s"]]
    momentum = sum(j * w for j, w in zip(inertias, speeds, strict=True))
    duration = run.schedule.duration
    static = (load + model.drag_torque) / (n * lever)
    expected = static + (momentum[-1] - momentum[0]) / (n * lever * duration)
    # The samples start at t = 0 and end one sample before T: the momentum change over the
    # missing 1e-4 s is bounded by the force fluctuation (< 20 N) times 1e-4 s / T, <1e-2 N.
    assert mean_force == pytest.approx(expected, abs=1e-2)
    # and in steady operation that is torque / base radius to 0.5%
    assert mean_force == pytest.approx(static, rel=5e-3)


# -- impacts -------------------------------------------------------------------------------
def test_single_impact_reproduces_calibration_case(tmp_path):
    # A calibration case made from laws.simulate_impact: the same law at the same speed on
    # the same effective mass must give back its restitution and peak force. One tooth
    # pair must carry it: the planar corner gaps leave the neighbours 41 um (approach
    # side) and 26 um (recess) clear of a 1.8 um approach; the seed set's
    # three-dimensional recess gap there is 1.6 um, and that pair would share the load.
    model = DriveModel(drive="torque", coupling_stiffness=(1e-6,) * 3, engage_position=0.999,
                       mesh_phase=0.88, max_step=1e-6, corners="planar", **QUIET, **TIGHT)
    mass = model.effective_mass(1)
    speed = 0.05
    law = laws.ImpactLaw(k=6.5e10, exponent=1.5, cmax=1.5e3, d=1e-6)
    truth = laws.simulate_impact(law, mass, speed)
    assert 0.4 < truth.restitution < 0.8  # a lossy but not dead impact (0.59)
    cases = [{"stage": s, "face_teeth": t, "kind": "mesh", "speed_rpm": 0.0,
              "impact_speed": speed, "effective_mass": mass,
              "fe": {"peak_force": truth.force_max, "restitution": truth.restitution},
              "impact": {"k": law.k, "exponent": law.exponent, "cmax": law.cmax, "d": law.d}}
             for s, t in ((1, 56), (2, 68), (3, 80))]
    path = tmp_path / "calibration.json"
    path.write_text(json.dumps({"schema": "fe-impact/calibration/1", "units": {},
                                "cases": cases}))
    model = model.with_laws(load_calibration(path, GEARSET))
    # ring (and output) closing the drive flank at `speed`; pinion initially at rest
    rate = -speed / model.base_levers[0]
    run = simulate(model, StageSchedule((Segment(1e-3, 1, 0.0),)),
                   initial_rates=[0.0, rate, 0.0, 0.0, rate])
    hit = run.events.select(kind="rattle")
    assert len(hit) == 1
    # closing speed: 0.07 um of free flight at constant speed; the onset is located on the
    # step's Hermite interpolant, which the contact force inside that step perturbs by a
    # few 1e-6 (see test_switching_impact_speed)
    assert hit.speed[0] == pytest.approx(speed, rel=1e-5)
    # restitution: integrator error (rtol 1e-10) and Hermite location of the separation
    # (~(h/t_c)^3 with 1 us steps in a 180 us contact) are both < 1e-5
    assert hit.restitution[0] == pytest.approx(truth.restitution, rel=1e-4)
    # peak force: sampled at step ends, (pi h / t_c)^2 / 8 ~ 4e-5 below the true peak
    assert hit.force[0] == pytest.approx(truth.force_max, rel=2e-4)
    assert hit.approach[0] == pytest.approx(truth.delta_max, rel=2e-4)


def _single_impact(tmp_path, law, mesh_cycle=None):
    """The single-impact run above, with ``law`` in the file and an optional mesh cycle."""
    model = DriveModel(drive="torque", coupling_stiffness=(1e-6,) * 3, engage_position=0.999,
                       mesh_phase=0.88, max_step=1e-6, corners="planar", **QUIET, **TIGHT)
    mass, speed = model.effective_mass(1), 0.05
    cases = [{"stage": s, "kind": "mesh", "impact_speed": speed,
              "impact": {"k": law.k, "exponent": law.exponent, "cmax": law.cmax, "d": law.d}}
             for s in (1, 2, 3)]
    doc = {"schema": "fe-impact/calibration/2", "cases": cases}
    if mesh_cycle is not None:
        doc["mesh_cycle"] = mesh_cycle
    tmp_path.mkdir(parents=True, exist_ok=True)
    path = tmp_path / "calibration.json"
    path.write_text(json.dumps(doc))
    law_set = load_calibration(path, GEARSET)
    rate = -speed / model.base_levers[0]
    run = simulate(model.with_laws(law_set), StageSchedule((Segment(1e-3, 1, 0.0),)),
                   initial_rates=[0.0, rate, 0.0, 0.0, rate])
    return law_set, run.events.select(kind="rattle"), mass, speed


def test_the_mesh_cycle_sets_the_pair_stiffness(tmp_path):
    # A position law four times stiffer than the impact's, the same at every
    # position, with the impact's damping: the run must be that of the law
    # (4k, exponent, cmax, d) given as the impact's law, to round-off (the
    # kernel evaluates the same force), whatever the pair's position.
    law = laws.ImpactLaw(k=6.5e10, exponent=1.5, cmax=1.5e3, d=1e-6)
    stiff = laws.ImpactLaw(k=4 * law.k, exponent=law.exponent, cmax=law.cmax, d=law.d)
    cycle = {str(s): {"roll_angle_deg": [-14.0, 0.0, 18.0], "k": [stiff.k] * 3,
                      "exponent": [law.exponent] * 3} for s in (1, 2, 3)}
    law_set, hit, _, _ = _single_impact(tmp_path / "a", law, cycle)
    assert "mesh cycle" in law_set.source
    assert not any("position" in n for n in law_set.notes)
    _, direct, _, _ = _single_impact(tmp_path / "b", stiff)
    assert len(hit) == 1 and len(direct) == 1
    for name in ("force", "approach", "restitution", "speed"):
        assert getattr(hit, name)[0] == pytest.approx(getattr(direct, name)[0], rel=1e-12)
    # and it is not the impact's own law: 4 k raises the peak force (by 4^(2/5)
    # = 1.74 undamped; the damping ramp over the shorter approach adds to it)
    _, soft, _, _ = _single_impact(tmp_path / "c", law)
    assert hit.force[0] / soft.force[0] > 1.7


def test_a_calibration_without_mesh_cycle_says_so(tmp_path, caplog):
    law = laws.ImpactLaw(k=6.5e10, exponent=1.5, cmax=1.5e3, d=1e-6)
    with caplog.at_level("WARNING"):
        law_set, _, _, _ = _single_impact(tmp_path, law)
    assert any("no position dependence" in n for n in law_set.notes)
    assert "no position dependence" in caplog.text


def test_position_law_interpolation():
    # log k and the exponent linear in the path coordinate between positions,
    # held beyond the ends; no table: the slot's own law.
    from fe_impact.switching._kernel import NPOS, position_law

    tab = np.full((3, NPOS), np.nan)
    tab[:, :3] = [[0.0, 1.0, 3.0], [1e9, 4e9, 2e9], [1.2, 1.4, 1.3]]
    k, n = position_law(0.5, tab, 0.0, 0.0)
    assert k == pytest.approx(2e9, rel=1e-12) and n == pytest.approx(1.3, rel=1e-12)
    assert position_law(-1.0, tab, 0.0, 0.0) == (1e9, 1.2)
    assert position_law(9.0, tab, 0.0, 0.0) == (2e9, 1.3)
    assert position_law(0.5, np.full((3, NPOS), np.nan), 7.0, 1.5) == (7.0, 1.5)


@pytest.mark.parametrize("rpm", [100.0, 1000.0])
def test_switching_impact_speed(rpm):
    # Unloaded rings turning with the output at the stage-1 ratio; at the switch the pinion
    # enters ring 2 in the middle of its backlash. Until the first contact nothing acts, so
    # the closing speed is the kinematic mismatch r_bp w_p (68/56 - 1), on the coast flank
    # (ring 2's teeth run faster than the pinion's).
    model = DriveModel(ramp_time=1e-3, **QUIET, **TIGHT)
    schedule = StageSchedule((Segment(0.01, 1, rpm), Segment(0.02, 2, rpm)))
    run = simulate(model, schedule)
    hit = run.events.select(kind="switch")
    assert len(hit) == 1 and hit.flank[0] == -1
    omega = rpm * RPM
    # truth from gear dimensions only: r_bp = m z cos(a) / 2
    p = GEARSET.pinion
    r_bp = 0.5 * p.module * p.teeth * math.cos(math.radians(p.pressure_angle_deg))
    # Free flight up to the contact: exact but for the location of the onset. The step that
    # contains it already feels the force (~k h^1.5 after the onset), which the cubic
    # Hermite of h does not represent: ~1e-6 relative here, checked to 1e-5.
    assert hit.speed[0] == pytest.approx(switching_speed(omega, 19, 56, 68, r_bp), rel=1e-5)
    # The same closing speed from the simulated motion itself, just before the switch:
    # pinion r_bp w_p against ring 2's line-of-action speed r_b2 w_2 (no load and no
    # losses: both turn steadily before the switch). The onset location error above
    # (~1e-6) dominates: 1e-5.
    s = run.series
    before = np.flatnonzero(s["time_s"] < 0.01)[-1]
    lever = model.base_levers[1]
    measured = r_bp * s["pinion_speed_rad_s"][before] - lever * s["ring2_speed_rad_s"][before]
    assert hit.speed[0] == pytest.approx(abs(measured), rel=1e-5)


@pytest.mark.parametrize("teeth", [56, 68, 80])
def test_seed_switching_speed_limits(teeth):
    # Seed eq. 5 in two limits worked by hand from its definitions (s = r_c tan a, so
    # alpha' = a): a face gear of vanishing radius gives gamma' = a and the factor
    # 1 - cos(2a)/cos(a); an infinitely large one gamma' = pi/2 and 1 + tan(a).
    # Only round-off separates the limits from the formula (r_f = 1e-9 r_c moves
    # gamma' by ~1e-18; r_f = 1e9 r_c by 1e-9, hence rel=1e-8).
    p = GEARSET.pinion
    r_c, a, omega, q = p.pitch_radius, math.radians(20.0), 100.0 * RPM, teeth / 19
    scale = omega * r_c * (1 + 1 / q)
    small = seed_switching_speed(omega, r_c, 1e-9 * r_c, q, a)
    assert small == pytest.approx(scale * (1 - math.cos(2 * a) / math.cos(a)), rel=1e-12)
    large = seed_switching_speed(omega, r_c, 1e9 * r_c, q, a)
    assert large == pytest.approx(scale * (1 + math.tan(a)), rel=1e-8)
    # proportional to the pinion speed, as the kinematic closing speed
    assert seed_switching_speed(7 * omega, r_c, 0.5 * p.module * teeth, q, a) == pytest.approx(
        7 * seed_switching_speed(omega, r_c, 0.5 * p.module * teeth, q, a), rel=1e-14)


# -- calibration file -----------------------------------------------------------------------
def _calibration(tmp_path, cases, schema="fe-impact/calibration/1"):
    path = tmp_path / "calibration.json"
    path.write_text(json.dumps({"schema": schema, "cases": cases}))
    return path


def _case(stage, speed, k, kind="mesh"):
    return {"stage": stage, "kind": kind, "impact_speed": speed,
            "impact": {"k": k, "exponent": 1.5, "cmax": 10.0 * k / 1e10, "d": 1e-6}}


def test_calibration_interpolates_in_log_speed_and_clamps(tmp_path, caplog):
    cases = [_case(s, v, k) for s in (1, 2, 3) for v, k in ((0.01, 1e10), (1.0, 3e10))]
    laws_set = load_calibration(_calibration(tmp_path, cases), GEARSET)
    # at the geometric mean speed, half way in log(speed): the arithmetic mean
    assert laws_set.law(2, 0.1).k == pytest.approx(2e10, rel=1e-12)
    # a stage with only "mesh" cases uses them for "switch" too (and says so)
    assert laws_set.law(2, 0.1, kind="switch").k == pytest.approx(2e10, rel=1e-12)
    assert any("switch" in note for note in laws_set.notes)
    # and the reports' list of sources says it, not only the file's name
    switch = laws_set.table(2, "switch")
    assert switch.kind == "switch" and switch.source.endswith("its mesh cases (no switch case)")
    assert laws_set.table(2, "mesh").source == "calibration.json"
    with caplog.at_level(logging.WARNING, logger="fe_impact.switching.calibration"):
        assert laws_set.law(1, 10.0).k == 3e10  # clamped to the fastest case
    assert "outside the calibrated range" in caplog.text


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda d: d.update(schema="fe-impact/calib/0"), "schema = 'fe-impact/calib/0'"),
        (lambda d: d["cases"][0].pop("impact"), "missing key(s) ['impact'] in [cases[0]]"),
        (lambda d: d["cases"][0].update(kind="rattle"), "kind = 'rattle'"),
        (lambda d: d["cases"][0].update(stage=4),
         "[cases[0]] stage = 4: must be an integer in 1..3"),
        (lambda d: d["cases"][0].update(face_teeth=60),
         "[cases[0]] face_teeth = 60: stage 1 of gear set"),
        (lambda d: d["cases"][0]["impact"].update(k=-1.0),
         "[cases[0].impact] k = -1.0: must be > 0"),
        (lambda d: d["cases"].append(_case(1, 0.01, 2e10)), "two stage 1 'mesh' cases"),
    ],
)
def test_calibration_rejects_bad_files(tmp_path, mutate, message):
    data = {"schema": "fe-impact/calibration/1",
            "cases": [_case(s, 0.01, 1e10) for s in (1, 2, 3)]}
    mutate(data)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(CalibrationError, match=re.escape(message)):
        load_calibration(path, GEARSET)


# -- presets and command ---------------------------------------------------------------------
def _main(argv):
    """The subcommand as the CLI will call it."""
    parser = argparse.ArgumentParser(prog="fe-impact")
    register(parser.add_subparsers())
    args = parser.parse_args(argv)
    return args.func(args)


def test_presets_follow_the_seed():
    # seed 4.1: 100/300/1000 r/min, 5 s, no load; 4.2: 300 r/min, 50..1000 N mm on stage 2
    for number in (1, 2, 3):
        preset = PRESETS[f"table{number}"]
        assert [c.condition for c in preset.cases] == list(SEED_TABLES[f"table{number}"]
                                                           .conditions)
        for case, rpm in zip(preset.cases, (100, 300, 1000), strict=True):
            (seg,) = case.schedule.segments
            assert (seg.stage, seg.speed_rpm, seg.load, seg.duration) == (number, rpm, 0, 5)
    loads = [c.schedule.segments[0].load for c in PRESETS["table4"].cases]
    assert loads == [0.05, 0.2, 0.5, 1.0]
    speed = PRESETS["variable-speed"].cases[0].schedule
    assert [(s.stage, s.speed_rpm) for s in speed.segments] == [(1, 100), (2, 300), (3, 1000)]
    assert PRESETS["variable-load"].cases[0].schedule.duration == 20.0
    # a transcription spot check: Table 2, 1000 r/min, minimum force printed "v3.178e+6"
    assert SEED_TABLES["table2"].value("impact_force", "minimum", "1000 r/min") == -3.178e6


def test_list_prints_every_preset(capsys):
    assert _main(["switching", "--list"]) == 0
    printed = capsys.readouterr().out
    assert all(name in printed for name in PRESETS)


@pytest.mark.parametrize(
    ("argv", "error", "message"),
    [
        (["--preset", "table9", "--out", "x"], CaseError, "--preset = 'table9' is not a preset"),
        (["--preset", "table1", "--out", "x", "--duration", "-1"], CaseError,
         "--duration = -1.0 s must be a number > 0"),
        (["--preset", "table1"], CaseError, "--out is required"),
        (["--out", "x"], CaseError, "--preset NAME or --schedule FILE is required"),
        (["--preset", "table1", "--schedule", "s.toml", "--out", "x"], CaseError,
         "--preset = 'table1' and --schedule = 's.toml': give one of them"),
        (["--schedule", "s.toml", "--out", "x"], CaseError, "s.toml: schedule file not found"),
        (["--preset", "table1", "--out", "x", "--calibration", "missing.json"],
         CalibrationError, "--calibration = 'missing.json': no such file"),
    ],
)
def test_bad_options(tmp_path, monkeypatch, argv, error, message):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(error) as info:
        _main(["switching", *argv])
    assert message in str(info.value)
    if "preset = 'table9'" in message:
        assert "table1" in str(info.value) and "variable-speed" in str(info.value)


def test_command_writes_series_statistics_report_and_plots(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no calibration.json here: closed forms, with a warning
    out = tmp_path / "out"
    assert _main(["switching", "--preset", "variable-speed", "--duration", "0.6",
                  "--out", str(out)]) == 0
    names = {p.name for p in out.iterdir()}
    assert {"variable-speed_series.csv", "variable-speed_impacts.csv", "statistics.csv",
            "statistics.json", "report.md", "elastic_displacement.png", "impact_speed.png",
            "impact_force.png", "potential_energy.png", "impacts.png"} <= names
    assert not [n for n in names if n.startswith(".")]  # atomic writes left no temporaries
    summary = json.loads((out / "statistics.json").read_text())
    rows = summary["comparison"]
    # every seed value of section 5.1 appears beside a model value
    seed = SEED_TABLES["section5.1"]
    printed = {(r["condition"], r["quantity"], r["statistic"]): r for r in rows}
    for (quantity, statistic), values in seed.values.items():
        for condition, value in zip(seed.conditions, values, strict=True):
            assert printed[(condition, quantity, statistic)]["seed"] == value
    run = summary["cases"]["variable-speed"]["run"]
    assert run["impacts"] >= 2  # at least the two switching impacts
    assert "Where and why the numbers differ" in (out / "report.md").read_text()


def test_benchmark_runs_on_a_coarse_setting():
    # validation/bench_switching.py at 0.6 s: both switches happen and are recorded
    from validation.bench_switching import run

    record = run(duration=0.6)
    assert record["simulated_s"] == pytest.approx(0.6)
    assert record["impacts_by_kind"]["switch"] == 2
    assert record["steps"] > 0 and record["wall_s"] > 0.0


# -- rounded tip edges: the planar gaps against a sampled profile --------------------------------
def _inv(a):
    return np.tan(a) - a


def _rack_profile(frame, theta: float, n: int = 4000) -> np.ndarray:
    """The rack tooth's drive side at pinion angle ``theta`` (world frame), sampled: the
    straight flank, the tip rounding and the tip line, built here from their definitions
    (flank: normal d through the line-of-action point the involute reaches at
    ``theta``; rounding: the circle inside both lines, tangent to them)."""
    a, r, rho = frame.alpha, frame.pitch_radius, frame.rack_edge_radius
    d = np.array([-math.cos(a), math.sin(a)])
    t = np.array([r * math.sin(a) * math.cos(a), r * math.cos(a) ** 2])
    s_tip = r * math.sin(a) - frame.rack_addendum / math.sin(a)
    foot = t + (s_tip + frame.base_radius * theta) * d   # flank point on the line of action
    y_tip = r - frame.rack_addendum
    # centre: (c - foot).d = rho and c_y = y_tip + rho, a 2x2 linear system
    centre = np.linalg.solve(np.array([d, [0.0, 1.0]]), [rho + foot @ d, y_tip + rho])
    along = np.array([d[1], -d[0]])                  # along the flank, pointing up
    flank_end = centre - rho * d
    flank = flank_end + np.multiply.outer(np.linspace(0.0, 3e-3, n), along)
    # arc from the flank's tangency (normal -d) to the tip line's (normal (0, -1))
    start, stop = math.atan2(-d[1], -d[0]), -0.5 * math.pi
    phi = np.linspace(start, stop, n)
    arc = centre + rho * np.stack([np.cos(phi), np.sin(phi)], axis=-1)
    tip = np.stack([centre[0] - np.linspace(0.0, 3e-3, n), np.full(n, y_tip)], axis=-1)
    return np.concatenate([flank, arc, tip])


def _pinion_profile(frame, n: int = 4000) -> tuple[np.ndarray, float]:
    """The pinion tooth's drive side near its tip (pinion frame at angle 0), sampled: the
    involute from the involute function, the tip rounding found by bisection as the
    circle of radius rho centred on the circle r_a - rho and tangent to the sampled
    involute, and the tip circle; and the radius at which the involute ends."""
    r_b, r_a, rho = frame.base_radius, frame.pinion_tip_radius, frame.pinion_edge_radius
    p_ref = frame.on_line(frame.s_tip_line)           # on the involute at angle 0
    r_ref = np.hypot(*p_ref)
    # the polar angle of a point on_line(s) turned back by s / r_b falls as inv(alpha_r)
    phi0 = math.atan2(p_ref[1], p_ref[0]) + _inv(math.acos(r_b / r_ref))

    def involute(radius):
        ang = phi0 - _inv(np.arccos(r_b / radius))
        return np.stack([radius * np.cos(ang), radius * np.sin(ang)], axis=-1)

    dense = involute(np.linspace(r_a - 4e-3, r_a, 20 * n))
    tip_angle = phi0 - _inv(math.acos(r_b / r_a))
    touch = dense[-1]
    if rho == 0.0:
        arc = dense[-1:]
        end = tip_angle
    else:
        def clearance(angle):   # centre at angle: distance to the involute less rho
            c = (r_a - rho) * np.array([math.cos(angle), math.sin(angle)])
            return np.min(np.hypot(*(dense - c).T)) - rho
        # the centre lies inside the tooth, at a smaller polar angle than the tip corner
        end = brentq(clearance, tip_angle - 0.2, tip_angle, xtol=1e-14)
        c = (r_a - rho) * np.array([math.cos(end), math.sin(end)])
        touch = dense[np.argmin(np.hypot(*(dense - c).T))]
        start = math.atan2(*(touch - c)[::-1])
        phi = np.linspace(start, end, n)
        arc = c + rho * np.stack([np.cos(phi), np.sin(phi)], axis=-1)
        dense = dense[np.hypot(*dense.T) <= np.hypot(*touch)]
    ang = np.linspace(end - 0.05, end, n)
    tip = r_a * np.stack([np.cos(ang), np.sin(ang)], axis=-1)
    return np.concatenate([dense, arc, tip]), float(np.hypot(*touch))


@pytest.mark.parametrize("radii", [(1e-4, 3e-4), (0.5e-3, 0.6e-3)])
def test_rounded_tip_edge_gaps_match_sampled_profiles(radii):
    # Two definitions of the same gaps. The frame: closed forms for the ends of the
    # flanks and the gap of a rounding's centre less its radius (the involutes of a
    # base circle are parallel curves). Here: each tooth's profile sampled from its
    # own construction, and the gap as the least mesh-coordinate distance over the
    # samples (the pinion turned onto the held rack, r_b times the polar angle to the
    # involute; the rack moved along d onto the held pinion). 4000 samples on an arc
    # of at most 0.6 mm miss its lowest point by under rho (pi/2/4000)^2/8 = 1e-11 m;
    # the sampled involute's chords, 0.2 um apart, miss the circle's tangency by
    # about 1e-11 m; tolerance 2e-9 m, 1e-4 of the 20 um gaps it checks.
    p = GEARSET.pinion
    a, r_p = math.radians(p.pressure_angle_deg), p.pitch_radius
    frame = _RackPinionFrame(r_p, a, p.module, r_p + p.module, *radii)
    r_b = frame.base_radius
    phi_ref = (math.atan2(*frame.on_line(frame.s_tip_line)[::-1])
               + _inv(math.acos(r_b / np.hypot(*frame.on_line(frame.s_tip_line)))))

    def rack_gap(s):   # pinion turned by (s - s_tip_line) / r_b, rack held
        theta = (s - frame.s_tip_line) / r_b
        pts = _rack_profile(frame, theta)
        c, sn = math.cos(-theta), math.sin(-theta)
        q = pts @ np.array([[c, sn], [-sn, c]])          # into the pinion frame
        radius = np.hypot(*q.T)
        keep = radius > r_b
        inv_angle = phi_ref - _inv(np.arccos(r_b / radius[keep]))
        return np.min(r_b * (np.arctan2(q[keep, 1], q[keep, 0]) - inv_angle))

    pinion, r_t = _pinion_profile(frame)
    d = frame.direction

    def pinion_gap(s):   # rack flank through on_line(s), pinion at the conjugate angle
        theta = (s - frame.s_tip_line) / r_b
        c, sn = math.cos(theta), math.sin(theta)
        q = pinion @ np.array([[c, sn], [-sn, c]])
        return np.min((frame.on_line(s) - q) @ d)

    for delta in (5e-4, 1e-3, 1.5e-3):
        assert frame.approach_gap(delta) == pytest.approx(rack_gap(frame.s_start - delta),
                                                          abs=2e-9)
        assert frame.recess_gap(delta) == pytest.approx(pinion_gap(frame.s_end + delta),
                                                        abs=2e-9)
    # The flanks' ends. The pinion's involute ends at the radius where the sampled
    # rounding touches it (samples 50 nm apart in radius: s within 0.2 um). The rack's
    # flank ends where the end of its sampled flank (the rounding's tangency) is on the
    # line of action, found by bisection in the pinion angle (exact to round-off).
    assert frame.s_end == pytest.approx(math.sqrt(r_t**2 - r_b**2), abs=2e-7)

    def off_line(theta):   # the flank's end, across the line of action
        v = _rack_profile(frame, theta, n=2)[0] - frame.on_line(0.0)
        return float(v[0] * d[1] - v[1] * d[0])

    theta = brentq(off_line, -0.05, 0.05, xtol=1e-15)
    assert frame.s_start == pytest.approx(frame.s_tip_line + r_b * theta, abs=1e-12)
    # inside them the pair is in flank contact, outside the rounding holds it off
    for gap, end, inside in ((rack_gap, frame.s_start, 1.0), (pinion_gap, frame.s_end, -1.0)):
        assert abs(gap(end + inside * 2e-4)) < 2e-9
        assert gap(end - inside * 2e-4) > 1e-8


def test_three_dimensional_corner_tables_follow_the_first_touch():
    # Each ring's table is a spline through 129 samples in xi = sqrt(delta / delta_max) of
    # the three-dimensional first touch; between samples it must give the first touch
    # computed afresh (same 121 edge sections). A cubic spline of a smooth function with
    # 128 intervals: relative error ~(1/128)^4 ~ 4e-9 of the gap's scale; 1e-4 relative
    # leaves room for the kinks where the touch moves between separate places of the edge
    # (with 65 samples one point, 1.58 um, was off by 2e-4).
    from fe_impact.gears.corner import corner_gaps, face_edge_rounding, pinion_edge_rounding
    from fe_impact.gears.kinematics import SOLID_CORNER_SECTIONS
    from fe_impact.gears.tca import GearPair

    flat = mesh_geometry(GEARSET)
    model = DriveModel(corners="3d")
    for stage in (1, 3):
        pair = GearPair.from_gearset(GEARSET, stage)
        geo = model.stage_geometry(stage)
        assert (geo.s_start, geo.s_end) == (flat.s_start, flat.s_end)
        for side, table, edge in (
                ("approach", geo.approach, face_edge_rounding(
                    pair, GEARSET.face_tip_edge_radius, n=SOLID_CORNER_SECTIONS)),
                ("recess", geo.recess, pinion_edge_rounding(
                    pair, GEARSET.pinion.tip_edge_radius, n=SOLID_CORNER_SECTIONS))):
            delta = table.delta_max * np.array([0.13, 0.37, 0.61, 0.89]) ** 2
            exact = corner_gaps(pair, edge, side, flat.corner_roll(side, delta))
            np.testing.assert_allclose(table(delta)[0], exact, rtol=1e-4, atol=1e-10)
            # the tables end at the cap, like the planar ones
            assert table(np.array(table.delta_max))[0] == pytest.approx(100e-6, rel=1e-3)
    # the kernel gets each ring's own tables
    from fe_impact.switching.simulation import _pack

    packed = _pack(model, StageSchedule((Segment(1e-3, 1, 0.0),)), 1e-4)
    for stage in (1, 2, 3):
        geo = model.stage_geometry(stage)
        np.testing.assert_array_equal(packed.corners[stage - 1, 1, 0], geo.recess.values)
        assert packed.stages["corner_in"][stage - 1] == geo.approach.delta_max
    assert DriveModel().corner_source == "3d"
    sharp = dataclasses.replace(GEARSET, face_tip_edge_radius=0.0)
    assert DriveModel(gearset=sharp).corner_source == "planar"
    with pytest.raises(CaseError, match="corners = '3d' needs rounded tip edges"):
        DriveModel(gearset=sharp, corners="3d")


def test_impacts_are_placed_on_the_flank_or_a_tip_edge():
    # The kernel marks where the touching pair was: before the path's start on the face
    # gear's edge, after its end on the pinion's, else on the flanks.
    from fe_impact.switching import _kernel as K
    from fe_impact.switching.simulation import CONTACT_NAMES, _pack
    from fe_impact.switching.statistics import impact_statistics

    model = DriveModel(corners="planar")
    p = _pack(model, StageSchedule((Segment(1e-3, 1, 0.0),)), 1e-4).p
    geo = model.geometry
    assert [CONTACT_NAMES[K.contact_kind(s, p)] for s in
            (geo.s_start - 1e-9, geo.s_start + 1e-9, geo.s_end - 1e-9, geo.s_end + 1e-9)] == \
        ["corner-approach", "flank", "flank", "corner-recess"]
    # A mesh-in (a pair touching while its flank carries load) is the entering pair
    # reaching the approach corner when the loaded approach closes its corner gap; a
    # leaving pair touching again would do so at the recess corner, whose planar gaps
    # (26 um 1.5 mm beyond the path) the approach under 1 N m does not reach.
    run = simulate(model, StageSchedule((Segment(0.3, 1, 300.0, load=1.0),)))
    mesh_in = run.events.select(kind="mesh-in")
    assert len(mesh_in) > 0
    assert set(mesh_in.contact.tolist()) == {K.CONTACT_APPROACH}
    stats = impact_statistics(run)["all"]
    for kind in ("rattle", "mesh-in", "switch", "all"):
        assert sum(stats["contacts"][kind][place]["count"] for place in CONTACT_NAMES.values()) \
            == stats[kind]["count"]


# -- laws of the kinds of contact -------------------------------------------------------------
def test_closed_form_corner_laws_take_the_rounded_edges_first_touch():
    # Across the edge the touch's relative radius is the rounding's radius rho combined
    # with the mating flank's convex profile: 1/Rx = 1/rho + 1/R_flank, so rho/(1 +
    # rho/R_flank,min) <= Rx <= rho. On the approach side the flank is the pinion's
    # involute, whose radius of curvature is least at the form circle,
    # sqrt(r_form^2 - r_b^2); on the recess side it is the face gear's flank, which is
    # flatter in profile than that involute (a rack's is straight).
    from fe_impact.gears.tca import GearPair
    from fe_impact.switching.calibration import corner_radii

    masses = [DriveModel().effective_mass(s) for s in (1, 2, 3)]
    laws_ = DriveModel().law_set
    for stage in (1, 2, 3):
        pinion = GearPair.from_gearset(GEARSET, stage).pinion
        r_min = math.sqrt(pinion.form_radius**2 - pinion.base_radius**2)
        for side, rho in (("approach", GEARSET.face_tip_edge_radius),
                          ("recess", GEARSET.pinion.tip_edge_radius)):
            rx, ry = corner_radii(GEARSET, stage - 1, side)
            assert rho / (1.0 + rho / r_min) <= rx <= rho
            assert ry > 10 * rx  # along the edge: a long, narrow ellipse
            corner = laws_.table(stage, f"corner-{side}")
            flank = laws_.table(stage, "mesh")
            # a narrower contact is softer: Hertz k grows with the contact's radii
            assert np.all(corner.k < flank.k)
            assert np.all(corner.exponent == 1.5)
    # sharp edges: no rounding, no corner law; corner contacts take the flank's
    sharp = dataclasses.replace(GEARSET, face_tip_edge_radius=0.0)
    from fe_impact.switching.calibration import closed_form_laws

    only = closed_form_laws(sharp, masses)
    assert not any(only.has(s, "corner-approach") for s in (1, 2, 3))
    assert all(only.has(s, "corner-recess") for s in (1, 2, 3))
    sharp_both = dataclasses.replace(sharp, pinion=dataclasses.replace(sharp.pinion,
                                                                       tip_edge_radius=0.0))
    none = closed_form_laws(sharp_both, masses)
    assert not any(none.has(s, k) for s in (1, 2, 3) for k in ("corner-approach",
                                                                "corner-recess"))
    assert "corner contacts take the flank's law" in none.source


def test_fe_corner_positions_replace_the_roundings_hertz_stiffness(tmp_path):
    # A calibration whose mesh cycle carries FE corner laws: the corner tables take
    # their K and exponent; the rest of the law stays the closed form's.
    from fe_impact.switching.calibration import _closed_form_table, closed_form_laws

    masses = [DriveModel().effective_mass(s) for s in (1, 2, 3)]
    cycle = {str(s): {"roll_angle_deg": [-14.0, 0.0, 18.0], "k": [5e9] * 3,
                      "exponent": [1.35] * 3,
                      "corners": {"recess": {"k": 4.0e9 * s, "exponent": 1.37}}}
             for s in (1, 2, 3)}
    law = {"k": 6.5e10, "exponent": 1.5, "cmax": 1.5e3, "d": 1e-6}
    doc = {"schema": "fe-impact/calibration/2", "mesh_cycle": cycle,
           "cases": [{"stage": s, "kind": "mesh", "impact_speed": 0.05, "impact": law}
                     for s in (1, 2, 3)]}
    path = tmp_path / "calibration.json"
    path.write_text(json.dumps(doc))
    read = load_calibration(path, GEARSET, masses)
    closed = closed_form_laws(GEARSET, masses)
    for stage in (1, 2, 3):
        recess = read.table(stage, "corner-recess")
        assert np.all(recess.k == 4.0e9 * stage) and np.all(recess.exponent == 1.37)
        assert recess.source.startswith("FE corner position")
        approach = read.table(stage, "corner-approach")   # none measured: the closed form
        assert np.array_equal(approach.k, closed.table(stage, "corner-approach").k)
        assert any(f"stage {stage}: no 'corner-recess' impact case; the FE corner" in n
                   for n in read.notes)
    # the measured law's impact follows the energy balance of F = K delta^n; with the
    # Hertz K and n = 3/2 it is seed eq. 16 (a separate formula), so the damping agrees
    # to round-off
    hertz_table = closed.table(1, "corner-recess")
    from fe_impact.switching.calibration import corner_radii

    again = _closed_form_table(GEARSET, 0, masses[0], "corner-recess",
                               corner_radii(GEARSET, 0, "recess"),
                               (float(hertz_table.k[0]), 1.5))
    assert np.allclose(again.cmax, hertz_table.cmax, rtol=1e-12, atol=0.0)


def test_pair_law_follows_where_the_pair_touches():
    # On the path a pair takes the flank's stiffness; beyond the path's start the approach
    # edge's, beyond its end the recess edge's, from where the edge first touches (the
    # planar corner gap at REFERENCE_GAP, the roll the corner laws are measured at) on;
    # between the path's end and there it passes continuously from the flank's to the
    # edge's (no step where the contact leaves the flank). Without a corner law (NaN) the
    # flank's, through the position law.
    from fe_impact.gears.corner import REFERENCE_GAP
    from fe_impact.switching import _kernel as K
    from fe_impact.switching.simulation import _pack

    model = DriveModel(corners="planar")
    pk = _pack(model, StageSchedule((Segment(1e-3, 1, 0.0),)), 1e-4)
    p, stage = pk.p, pk.stages[0]
    geo, ring = model.geometry, model.stage_geometry(1)
    # the corner laws stand where the edge's gap is the reference gap (rel. 1e-9: brentq's
    # xtol of 1e-13 m on a roll distance of about 1e-4 m, times the gap's slope)
    assert ring.approach(stage["law_in"])[0] == pytest.approx(REFERENCE_GAP, rel=1e-6)
    assert ring.recess(stage["law_out"])[0] == pytest.approx(REFERENCE_GAP, rel=1e-6)
    assert 0.0 < stage["law_in"] < stage["corner_in"]
    assert 0.0 < stage["law_out"] < stage["corner_out"]
    none = np.full((3, K.NPOS), np.nan)
    laws = (1.0, 1.5, 2.0, 1.4, 3.0, 1.3)
    on = 0.5 * (geo.s_start + geo.s_end)
    assert K.pair_law(on, p, none, *laws, stage) == (1.0, 1.5)
    beyond_in, beyond_out = geo.s_start - stage["law_in"], geo.s_end + stage["law_out"]
    assert K.pair_law(beyond_in - 1e-9, p, none, *laws, stage) == (2.0, 1.4)
    assert K.pair_law(beyond_in, p, none, *laws, stage) == (2.0, 1.4)
    assert K.pair_law(beyond_out + 1e-9, p, none, *laws, stage) == (3.0, 1.3)
    # continuous at the path's ends: 1e-12 m past them, within 1e-7 of the flank's
    for end in (geo.s_start - 1e-12, geo.s_end + 1e-12):
        k, n = K.pair_law(end, p, none, *laws, stage)
        assert k == pytest.approx(1.0, rel=1e-7) and n == pytest.approx(1.5, rel=1e-7)
    # and monotone between the two laws
    ks = [K.pair_law(s, p, none, *laws, stage)[0]
          for s in np.linspace(geo.s_end, beyond_out, 9)[1:]]
    assert np.all(np.diff(ks) > 0.0) and 1.0 < ks[0] and ks[-1] == pytest.approx(3.0)
    nan = (1.0, 1.5, np.nan, np.nan, 3.0, 1.3)
    assert K.pair_law(beyond_in - 1e-9, p, none, *nan, stage) == (1.0, 1.5)


def test_a_pair_on_a_tip_edge_feels_the_edges_law():
    # The right-hand side with one tooth pair pressed 1 um onto the approach tip edge and
    # its slot holding a corner law (no damping): the pair's force is k_in h^n_in
    # exactly, and the flank law's k h^n once the corner law is absent (NaN).
    from fe_impact.switching import _kernel as K
    from fe_impact.switching.simulation import _pack, _start_segment

    model = DriveModel(corners="planar", **QUIET)
    schedule = StageSchedule((Segment(1e-3, 1, 0.0),))
    pk = _pack(model, schedule, 1e-4)
    p, geo = pk.p, model.geometry
    y = np.zeros(2 + 2 * (model.n_stages + 1))
    # the run's set-up of its first segment: engaged ring, backlash, default law (the
    # pairs without a law of their own, pressed too, take it)
    _start_segment(model, pk, schedule.segments[0], 0.0, y, True)
    y[:] = 0.0
    dy, aux = np.zeros_like(y), np.zeros(K.N_AUX)
    pairs, npairs = np.zeros((2, K.MAXPAIR), dtype=K.PAIR), np.zeros(2, dtype=np.int64)

    def evaluate():
        K.rhs(0.0, y, dy, p, pk.stages, pk.aoff, pk.corners, pk.postab, pk.sch, pk.slots,
              pairs, npairs, aux)
        return [pairs[0, m].copy() for m in range(npairs[0])]

    first = min(evaluate(), key=lambda q: q["s"])   # the pair nearest the path's start
    y[0] = (geo.s_start - 0.5 * pk.stages["corner_in"][0] - first["s"]) / geo.base_radius
    (target,) = [q for q in evaluate() if q["pair"] == first["pair"]]
    assert target["s"] < geo.s_start                # turned onto the face gear's edge
    p["x0"] += 1e-6 - target["h"]                   # and pressed 1 um onto it
    slot = pk.slots[0, K.slot_of(target["pair"])]
    slot["pair"], slot["has_law"] = target["pair"], 1
    slot["k"], slot["n"], slot["cmax"], slot["d"] = 5e10, 1.5, 0.0, 1e-6
    slot["k_in"], slot["n_in"], slot["k_out"], slot["n_out"] = 1e10, 1.4, np.nan, np.nan
    pk.postab[:] = np.nan                    # no position law
    (hit,) = [q for q in evaluate() if q["pair"] == target["pair"]]
    assert hit["h"] == pytest.approx(1e-6, rel=1e-9)
    assert hit["f"] == pytest.approx(1e10 * hit["h"]**1.4, rel=1e-12)
    slot["k_in"] = slot["n_in"] = np.nan
    (hit,) = [q for q in evaluate() if q["pair"] == target["pair"]]
    assert hit["f"] == pytest.approx(5e10 * hit["h"]**1.5, rel=1e-12)


def test_each_impact_takes_the_law_of_its_kind_of_contact():
    # 1 N m at 300 r/min on stage 1: mesh-in at the approach corner (test above), with
    # the closed-form laws, which include the rounded edges'.
    from fe_impact.switching.simulation import LAW_NAMES

    model = DriveModel(corners="planar")
    assert model.law_set.has(1, "corner-approach")
    ev = simulate(model, StageSchedule((Segment(0.3, 1, 300.0, load=1.0),))).events
    names = np.array([LAW_NAMES[c] for c in ev.law])
    mesh_in = ev.kind == 1
    assert mesh_in.any()
    # mesh-in touches on the face gear's edge take its corner law, flank touches the mesh law
    assert set(names[mesh_in & (ev.contact == 1)]) == {"corner-approach"}
    assert set(names[(ev.contact == 0) & (ev.kind != 2)]) <= {"mesh"}


def test_report_tables_the_clamped_look_ups_and_the_yield_onset():
    # The yield-onset speed scales p0 ~ v^(2/5) from one reference impact: the Hertz
    # impact computed directly at that speed must reach 1.6 Y (to round-off).
    from fe_impact.physics import hertz
    from fe_impact.switching.calibration import contact_radii
    from fe_impact.switching.report import YIELD_PRESSURE, _clamp_lines, _yield_speed

    model = DriveModel(corners="planar")
    material = GEARSET.material
    e_star = hertz.effective_modulus(material.youngs_modulus, material.poisson_ratio)
    rx, ry = contact_radii(GEARSET, 0)
    k = 100.0 / hertz.ellipse_contact(100.0, rx, ry, e_star).delta ** 1.5
    v_y = _yield_speed(model, 1)
    force = float(hertz.impact_from_stiffness(model.effective_mass(1), v_y, k).force_max)
    assert hertz.ellipse_contact(force, rx, ry, e_star).p0 == pytest.approx(
        YIELD_PRESSURE * material.yield_strength, rel=1e-9)
    # a law table of one speed, 50 mm/s: every slower impact is clamped below, every
    # faster one above, and the section counts them
    law = _law_set(6.5e10, 50.0, 1e-6)
    tables = {key: dataclasses.replace(t, impact_speed=np.array([0.05])) for key, t in
              law.tables.items()}
    run = simulate(model.with_laws(LawSet(tables, "test")),
                   StageSchedule((Segment(0.1, 1, 300.0, load=1.0),)))
    text = "\n".join(_clamp_lines({"case": run}))
    ev = run.events
    below, above = int(np.sum(ev.clamped < 0)), int(np.sum(ev.clamped > 0))
    assert below + above == len(ev) > 0
    assert np.all((ev.speed < 0.05) == (ev.clamped < 0))
    assert f"| 1 | mesh (test) | 50-50 | {below} (" in text
    # the damped law loses more the faster it closes, so the smallest restitution
    # below the table, the one "at least" quotes, is that of its fastest impact there
    fastest = float(np.max(ev.speed[ev.clamped < 0]))
    e_min = laws.simulate_impact(tables[(1, "mesh")].law(0.05), model.effective_mass(1),
                                 fastest).restitution
    assert laws.simulate_impact(tables[(1, "mesh")].law(0.05), model.effective_mass(1),
                                float(np.min(ev.speed))).restitution > e_min
    assert f"a restitution of at least {e_min:.4f}" in text


def test_an_events_clamp_flag_is_that_of_its_recorded_speed():
    # A rattle event's closing speed is its flank's earliest touch: when another
    # tooth pair touches earlier within the same step, the event takes that
    # pair's speed, and its clamp flag must follow it (below the law's table
    # exactly when slower than its first row, above exactly when faster than
    # its last). Stage 1 of the seed set at 1000 r/min, no load, one second, its
    # mesh law narrowed to 12.5-125 mm/s: one of the 57 mesh-law events kept
    # the other pair's flag before the flag followed the speed.
    from fe_impact.switching.calibration import closed_form_laws
    from fe_impact.switching.simulation import LAW_NAMES

    model = DriveModel(gearset=GEARSET)
    laws = closed_form_laws(GEARSET, [model.effective_mass(s) for s in (1, 2, 3)])
    lo, hi = 0.0125, 0.125

    def narrowed(t):
        return dataclasses.replace(t, impact_speed=np.array([lo, hi]), k=t.k[:1].repeat(2),
                                   exponent=t.exponent[:1].repeat(2),
                                   cmax=t.cmax[:1].repeat(2), d=t.d[:1].repeat(2))

    tables = {key: narrowed(t) if key[1] == "mesh" else t for key, t in laws.tables.items()}
    ev = simulate(model.with_laws(LawSet(tables, "test")),
                  StageSchedule((Segment(1.0, 1, 1000.0),))).events
    mesh = np.array([LAW_NAMES[c] == "mesh" for c in ev.law])
    assert np.any(ev.clamped[mesh] < 0)
    np.testing.assert_array_equal((ev.clamped < 0)[mesh], (ev.speed < lo)[mesh])
    np.testing.assert_array_equal((ev.clamped > 0)[mesh], (ev.speed > hi)[mesh])


def test_a_corner_laws_yield_onset_is_its_roundings():
    # A corner law's clamped impacts are judged against the yield onset of its own
    # contact, the rounded tip edge's first touch: the Hertz impact of the stage's
    # effective mass on the rounding at that speed reaches 1.6 Y (to round-off),
    # far below the flanks' onset (seed set: about 1 mm/s against 0.26 m/s).
    from fe_impact.physics import hertz
    from fe_impact.switching.calibration import corner_radii
    from fe_impact.switching.report import YIELD_PRESSURE, _yield_speed

    model = DriveModel(corners="planar")
    material = GEARSET.material
    e_star = hertz.effective_modulus(material.youngs_modulus, material.poisson_ratio)
    for side in ("approach", "recess"):
        rx, ry = corner_radii(GEARSET, 0, side)
        v_y = _yield_speed(model, 1, f"corner-{side}")
        k = 100.0 / hertz.ellipse_contact(100.0, rx, ry, e_star).delta ** 1.5
        force = float(hertz.impact_from_stiffness(model.effective_mass(1), v_y, k).force_max)
        assert hertz.ellipse_contact(force, rx, ry, e_star).p0 == pytest.approx(
            YIELD_PRESSURE * material.yield_strength, rel=1e-9)
        assert v_y < 0.1 * _yield_speed(model, 1)


def test_a_study_gives_the_pitch_point_only_laws_beside(tmp_path):
    # The baseline is the same laws without the mesh cycle and the corner laws; its
    # columns are the statistics of the cases simulated on exactly those laws.
    import csv

    from fe_impact.switching.presets import get_preset
    from fe_impact.switching.statistics import comparison_rows
    from fe_impact.switching.study import run_study

    model = DriveModel()
    assert _law_set(6.5e10, 50.0, 1e-6).pitch_point_only() is None  # nothing to take away
    reduced = model.law_set.pitch_point_only()
    assert set(reduced.tables) == {(s, k) for s in (1, 2, 3) for k in ("mesh", "switch")}
    preset = get_preset("table1").scaled(0.15)
    run_study(preset, GEARSET, None, tmp_path, search=False)
    with open(tmp_path / "statistics.csv") as f:
        rows = list(csv.DictReader(f))
    plain = model.with_laws(reduced)
    runs = {c.name: simulate(plain, c.schedule) for c in preset.cases}
    expected = {(r["condition"], r["quantity"], r["statistic"]): r["model_impacts"]
                for r in comparison_rows(preset, runs)}
    for r in rows:
        want = expected[(r["condition"], r["quantity"], r["statistic"])]
        if want is not None:
            assert float(r["baseline_impacts"]) == pytest.approx(want, rel=1e-12)
    assert "## Beside the pitch-point-only laws and the seed" in \
        (tmp_path / "report.md").read_text()


@pytest.mark.parametrize("n_rows", [1, 2])
def test_a_law_table_flags_a_speed_outside_it_whatever_its_rows(n_rows):
    # A stage calibrated at one speed (one switch case, say) has a one-row table: a
    # look-up above it is clamped like one above a longer table's last row (it
    # read as inside), below it like one below its first, at it as inside.
    from fe_impact.switching._kernel import law_lookup

    speeds = [0.1, 0.2][:n_rows]
    tab = np.zeros((1, 1, 2, 5))
    for i, v in enumerate(speeds):
        tab[0, 0, i] = [math.log(v), 1e10 * (i + 1), 1.5, 10.0, 1e-6]
    ntab = np.array([[n_rows]], dtype=np.int64)
    flags = [law_lookup(tab, ntab, 0, 0, v)[1] for v in (0.05, speeds[0], speeds[-1], 1.0)]
    assert flags == [-1, 0, 0, 1]
    assert law_lookup(tab, ntab, 0, 0, 1.0)[0][0] == tab[0, 0, n_rows - 1, 1]


def test_the_coast_pairs_stand_where_the_symmetric_teeth_put_them():
    # Independent truth: the seed pinion's standard involute teeth, each flank found
    # where it crosses its line of action (a root of polar angle of the line's point
    # against the flank's polar angle at that radius), s from each line's base-circle
    # tangency. The drive flanks' s plus the coast flanks' s is the same at every
    # pinion angle and equals 2 s_pitch + p_b / 2 (mod p_b), which the kernel's
    # numbering must reproduce. It used s_start + s_end + p_b / 2, 2.02 mm apart on
    # the seed set, whose path is not centred on the pitch point.
    from fe_impact.switching._kernel import PARAMS, flank_roll

    def _involute(a: float) -> float:
        return math.tan(a) - a

    model = DriveModel()
    geo = model.geometry
    pin = model.gearset.pinion
    z, alpha = pin.teeth, math.radians(pin.pressure_angle_deg)
    rb, pb = geo.base_radius, geo.base_pitch
    half = math.pi / (2 * z) + _involute(alpha)      # half a tooth at the base circle
    reach = math.sqrt((pin.pitch_radius + pin.addendum_coeff * pin.module) ** 2 - rb**2)

    def crossings(turn: float, coast: bool) -> list[float]:
        side = -1.0 if coast else 1.0
        start = np.array([side * rb * math.sin(alpha), rb * math.cos(alpha)])
        along = np.array([-side * math.cos(alpha), math.sin(alpha)])
        found = []
        for j in range(z):
            centre = math.pi / 2 + turn + 2 * math.pi * j / z
            flank = centre + side * half           # the base point of the flank facing it

            def f(s, flank=flank):
                x, y = start + s * along
                rho = math.hypot(x, y)
                polar = flank - side * _involute(math.acos(min(rb / rho, 1.0)))
                return (math.atan2(y, x) - polar + math.pi) % (2 * math.pi) - math.pi

            grid = np.linspace(1e-6, reach, 200)
            values = [f(s) for s in grid]
            found += [brentq(f, a, b) for a, b, fa, fb in zip(grid, grid[1:], values,
                                                                values[1:], strict=False)
                      if fa * fb < 0 and abs(fa - fb) < 1.0]
        return found

    p = np.zeros(1, dtype=PARAMS)[0]
    p["s_start"], p["s_end"], p["s_pitch"], p["base_pitch"] = (geo.s_start, geo.s_end,
                                                                 geo.s_pitch, pb)
    p["u0"] = 0.37 * pb
    kernel = (2 * geo.s_start + flank_roll(0, 1.3e-3, p) + flank_roll(1, 1.3e-3, p)) % pb
    for turn in (0.0, 0.0123, 0.071):
        sums = {round(((d + c) % pb) / pb, 9) % 1.0 for d in crossings(turn, False)
                for c in crossings(turn, True)}
        # one sum over all pairs (to the root finder's 1e-9 of a pitch)
        assert len(sums) == 1
        assert sums.pop() == pytest.approx(((2 * geo.s_pitch + pb / 2) % pb) / pb, abs=1e-8)
    assert kernel / pb == pytest.approx(((2 * geo.s_pitch + pb / 2) % pb) / pb, abs=1e-12)


def test_a_loaded_start_is_static_on_the_position_law():
    # The run starts with the mesh deflected to carry the load statically. The
    # deflection must come from the law the kernel gives the pairs (the mesh cycle's
    # position law here, three times softer than the impact law): the first sample's
    # drive force is then load / (pinions r_b), as the static balance says. On the
    # impact law's stiffness it started at 0.31 of it and rang.
    base = _law_set(6.5e10, 0.0, 1e-6)
    rolls = np.array([-15.0, 0.0, 19.0])
    soft = {s: (rolls, np.full(3, 2.0e10), np.full(3, 1.5)) for s in (1, 2, 3)}
    laws_ = dataclasses.replace(base, positions=soft)
    model = DriveModel(laws=laws_, **QUIET, **TIGHT)
    load = 1.0
    run = simulate(model, StageSchedule((Segment(0.002, 1, 10.0, load),)),
                   sample_interval=1e-5)
    static = load / (model.pinions * model.base_levers[0])
    # The bisection and the integrator's tolerances are far below 0.1%; the force in
    # the first 0.1 ms stays at it (no start-up transient) to 1%.
    assert run.series["drive_force_N"][0] == pytest.approx(static, rel=1e-3)
    early = run.series["drive_force_N"][:10]
    assert np.ptp(early) < 0.01 * static


def test_the_python_corner_gap_is_the_kernels_inside_and_beyond_its_table():
    # CornerGap.__call__ documents itself as the kernel's interpolant: the same gap
    # and slope to rounding at nodes, between them, at the table's end and beyond it
    # (where both hold the end's gap with zero slope: the pair is out of reach).
    from fe_impact.switching._kernel import corner

    geo = mesh_geometry(GEARSET)
    for table in (geo.approach, geo.recess):
        deltas = np.concatenate([np.linspace(0.0, table.delta_max, 97),
                                 table.delta_max * np.array([1.0, 1.001, 1.5, 3.0])])
        g, dg = table(deltas)
        packed = np.stack([table.values, table.slopes])
        for d, gi, si in zip(deltas, g, dg, strict=True):
            gk, sk = corner(float(d), packed, table.delta_max)
            assert gi == pytest.approx(gk, rel=1e-12, abs=1e-18)
            assert si == pytest.approx(sk, rel=1e-9, abs=1e-15)
