"""The lumped model against the rolling FE: the comparison's figures and the lumped runner."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from fe_impact.errors import CaseError
from fe_impact.gears.gearset import default_gearset
from fe_impact.rolling.compare import (
    ContactEvents,
    RollingCondition,
    RollingRecord,
    check_goal,
    mesh_harmonics,
    mesh_metrics,
    mesh_window,
    write_comparison,
)
from fe_impact.rolling.lumped import lumped_model, run_lumped

GEARSET = default_gearset()


def _condition(name="c", stage=1, speed=1000.0, torque=0.0, duration=0.05, settle=0.0,
               **kw):
    return RollingCondition(name, stage, speed, torque, duration, GEARSET.pinion.inertia,
                            GEARSET.stages[stage - 1].inertia, 1.4e-4, settle=settle, **kw)


def _record(time, te, events=None, source="model", condition=None):
    condition = condition or _condition()
    zero = np.zeros_like(time)
    return RollingRecord(source, condition, GEARSET.pinion.teeth, time, te, zero + 1.0, zero,
                         events if events is not None else ContactEvents.empty())


# -- spectrum -------------------------------------------------------------------------------
def test_mesh_orders_of_a_sum_of_sines_are_their_amplitudes():
    # TE = c + sum a_h sin(2 pi h f t + phi_h): over whole periods each order's DFT bin
    # holds a_h exactly; the only error is the linear resampling of a record sampled
    # 1024 times a period, whose amplitude error at order h is at most
    # 1 - cos(pi h / 1024) < 5e-5 for h <= 4: tolerance 2e-4 of the largest amplitude.
    # A slow component off the mesh orders (a quarter order, on its own exact bin as
    # the window holds 12 periods) must not leak into them.
    condition = _condition(speed=1000.0, duration=0.05, settle=0.0105)
    f = condition.mesh_frequency(GEARSET.pinion.teeth)
    a = np.array([1.3e-6, 0.4e-6, 0.25e-6, 0.1e-6])
    phase = np.array([0.3, -1.1, 2.0, 0.7])
    t = np.arange(0.0, condition.duration, 1.0 / (1024 * f))
    te = 5e-5 + sum(a[h] * np.sin(2 * np.pi * (h + 1) * f * t + phase[h]) for h in range(4))
    t0, t1, periods = mesh_window(t, f, condition.settle)
    assert periods == math.floor((t[-1] - condition.settle) * f) == 12
    assert t1 - t0 == pytest.approx(periods / f, rel=1e-12)
    got = mesh_harmonics(t, te + 0.3e-6 * np.sin(0.5 * np.pi * f * t), f, periods, t0)
    np.testing.assert_allclose(got, a, rtol=0, atol=2e-4 * a.max())
    m = mesh_metrics(_record(t, te, condition=condition))
    np.testing.assert_allclose(m.te_harmonics, a, rtol=0, atol=2e-4 * a.max())
    # RMS of a sum of sines: sqrt(sum a^2 / 2); the sample mean over a closed window of
    # ~12k samples carries one extra end sample: relative bias ~1e-4, tolerance 1e-3
    assert m.te_rms == pytest.approx(math.sqrt(np.sum(a**2) / 2), rel=1e-3)


def test_peak_to_peak_of_one_sine_and_a_too_short_window():
    condition = _condition(speed=300.0, duration=0.1)
    f = condition.mesh_frequency(GEARSET.pinion.teeth)
    t = np.linspace(0.0, 0.1, 20001)
    m = mesh_metrics(_record(t, 2e-6 * np.cos(2 * np.pi * f * t), condition=condition))
    # 210 samples a period: the sampled crest is within 1 - cos(pi / 210) = 1.1e-4 of 2a
    assert m.te_peak_to_peak == pytest.approx(4e-6, rel=2e-4)
    assert m.periods == 9 and m.te_harmonics[0] == pytest.approx(2e-6, rel=1e-3)
    with pytest.raises(CaseError, match="no whole mesh period"):
        mesh_window(t[:100], f, 0.0)


# -- events ---------------------------------------------------------------------------------
def test_event_statistics_count_only_the_window_and_their_kind():
    condition = _condition(speed=300.0, duration=0.1, settle=0.03)
    f = condition.mesh_frequency(GEARSET.pinion.teeth)
    t = np.linspace(0.0, 0.1, 4001)
    # TE window: the last floor(0.07 f) = 6 periods, from 0.1 - 6 / 95 = 0.0368 s;
    # impacts from settle (0.03 s) on, mesh-in ones up to a period (10.5 ms) before the end
    events = ContactEvents(
        time=[0.01, 0.032, 0.05, 0.06, 0.07, 0.08, 0.09, 0.092, 0.095],
        kind=["mesh-in", "mesh-in", "rattle", "mesh-in", "mesh-out", "mesh-in", "rattle",
              "mesh-in", "rattle"],
        flank=[1, 1, -1, 1, 1, 1, 1, 1, -1],
        closing_speed=[9.0, 0.02, 0.1, 0.04, 0.5, 0.03, 0.2, 7.0, 0.15],
        peak_force=[5000.0, 700.0, 30.0, 760.0, math.nan, 690.0, 80.0, 9000.0, 20.0],
        location=["flank", "corner-approach", "flank", "corner-approach", "flank",
                  "corner-approach", "flank", "corner-approach", "flank"],
        position=np.full(9, math.nan))
    m = mesh_metrics(_record(t, np.zeros_like(t), events, condition=condition))
    assert m.window[0] == pytest.approx(0.1 - 6 / f, rel=1e-12)
    # the mesh-in at 0.01 s is before settle, the one at 0.092 s too close to the end
    # for its peak to be in the record: 700, 760, 690 remain
    assert m.mesh_in_count == 3
    assert m.mesh_in_force_median == 700.0 and m.mesh_in_force_max == 760.0
    assert m.mesh_in_speed_median == 0.03 and m.mesh_in_speed_max == 0.04
    assert m.rattle_count == 3 and m.rattle_force_max == 80.0 and m.rattle_speed_max == 0.2
    none = mesh_metrics(_record(t, np.zeros_like(t), condition=condition))
    assert none.mesh_in_count == 0 and math.isnan(none.mesh_in_force_median)
    with pytest.raises(CaseError, match="events.kind"):
        ContactEvents([0.0], ["impact"], [1], [0.1], [1.0], ["flank"], [0.0])


def test_goal_check_and_files(tmp_path):
    condition = _condition(speed=300.0, duration=0.1)
    f = condition.mesh_frequency(GEARSET.pinion.teeth)
    t = np.linspace(0.0, 0.1, 4001)

    def model(source, amplitude, force):
        ev = ContactEvents([0.05], ["mesh-in"], [1], [0.04], [force], ["corner-approach"],
                           [math.nan])
        return _record(t, amplitude * np.sin(2 * np.pi * f * t), ev, source, condition)

    fe = model("rolling FE", 1e-6, 700.0)
    cal = model("lumped, calibrated", 1.05e-6, 740.0)     # +5%, +5.7%
    closed = model("lumped, closed-form", 1.3e-6, 800.0)  # +30%, +14%
    goal = check_goal(*(mesh_metrics(r) for r in (fe, cal, closed)))
    assert goal.passed
    assert goal.calibrated["mesh_in_force_max"] == pytest.approx(40.0 / 700.0, rel=1e-12)
    far = check_goal(mesh_metrics(fe), mesh_metrics(model("x", 1.2e-6, 700.0)),
                     mesh_metrics(closed))
    assert not far.passed and not far.within["te_peak_to_peak"]
    paths = write_comparison(tmp_path, [fe, cal, closed], goal={condition.name: goal})
    assert {p.name for p in paths} >= {"compare.md", "compare.csv", "compare.json",
                                       f"compare_{condition.name}.png"}
    data = json.loads((tmp_path / "compare.json").read_text())
    row = next(r for r in data["rows"] if r["figure"] == "mesh_in_force_max")
    assert row["lumped, closed-form vs FE"] == pytest.approx(100.0 / 700.0, rel=1e-12)
    assert "goal met" in (tmp_path / "compare.md").read_text()
    # a record survives its file (NaN peak forces included)
    from fe_impact.rolling.compare import read_record, write_record

    back = read_record(write_record(tmp_path / "fe.json", fe))
    assert back.condition == fe.condition and np.array_equal(back.te, fe.te)
    assert mesh_metrics(back) == mesh_metrics(fe)
    with pytest.raises(CaseError, match="not a rolling record"):
        (tmp_path / "bad.json").write_text("{}")
        read_record(tmp_path / "bad.json")


def test_basis_lines_name_figures_set_by_one_event():
    # 300 r/min (95 Hz), 0.1 s, no settle: the window is the last 9 whole periods. One
    # record has a decaying ring started by a mesh-in at 0.07 s (max 1/4 of a ring
    # period later, 0.07 + 0.25 / 1000 s; min at 0.75 of it): both extremes follow that
    # one mesh-in by far less than a mesh period; the other is a pure mesh-order sine
    # and one rattle, whose extremes (0.25 and 0.75 of a mesh period) are not both
    # after it.
    from fe_impact.rolling.compare import basis_lines, te_extremes

    condition = _condition(speed=300.0, duration=0.1)
    f = condition.mesh_frequency(GEARSET.pinion.teeth)
    t = np.linspace(0.0, 0.1, 100001)
    ring = np.where(t >= 0.07, np.exp(-(t - 0.07) / 0.01)
                    * np.sin(2 * np.pi * 1000.0 * (t - 0.07)), 0.0) * 1e-6
    one = ContactEvents([0.07], ["mesh-in"], [1], [0.05], [600.0], ["corner-approach"],
                        [math.nan])
    rung = _record(t, ring + 1e-8 * np.sin(2 * np.pi * f * t), one, "rung", condition)
    hi, lo = te_extremes(rung)
    assert hi == pytest.approx(0.07 + 0.25e-3, abs=2e-5)
    assert lo == pytest.approx(0.07 + 0.75e-3, abs=2e-5)
    rattle = ContactEvents([0.05], ["rattle"], [-1], [0.01], [20.0], ["flank"], [math.nan])
    sine = _record(t, 1e-6 * np.sin(2 * np.pi * f * t), rattle, "sine", condition)
    text = basis_lines([rung, sine]).splitlines()
    assert len(text) == 2
    assert "TE over 9 mesh periods" in text[0]
    assert "mesh-in figures from one event" in text[0]
    assert "peak-to-peak set by one mesh-in" in text[0]
    # 0.25 and 0.75 ms after it: 0.024 and 0.071 of a 10.5 ms mesh period
    assert "max 0.02 periods after a mesh-in, its min 0.07 periods after" in text[0]
    assert "set by one" not in text[1] and "from one event" not in text[1]
    # each of the 9 periods of a 1 um sine: peak-to-peak 2 um, RMS 1/sqrt(2) um (the
    # closed forms; sampled at 1e-6 s, 0.01% of a period, well within 3 digits)
    assert "(per period: peak-to-peak " + " ".join(["2"] * 9) + " um, RMS " \
        + " ".join(["0.707"] * 9) + " um)" in text[1]
    # two mesh-ins: the line gives the range their median comes from (600 and 900 N:
    # median 750, the events' own values)
    two = ContactEvents([0.03, 0.05], ["mesh-in"] * 2, [1, 2], [0.05, 0.06], [600.0, 900.0],
                        ["corner-approach"] * 2, [math.nan] * 2)
    both = _record(t, 1e-6 * np.sin(2 * np.pi * f * t), two, "two", condition)
    assert "2 mesh-in (peak forces 600 .. 900 N, median 750 N)" in basis_lines([both])


# -- the lumped runner ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def loaded():
    """Stage 1 at 1000 r/min under 50 N m, no friction, 30 mesh periods."""
    return run_lumped(_condition("loaded", 1, 1000.0, 50.0, duration=0.1, settle=0.005,
                                 drag_torque=0.01))


def test_lumped_mean_mesh_force_balances_the_load(loaded):
    # Torque balance of the face-gear rotor over whole mesh periods: r_b2 <F> = T + drag
    # (no friction). The residual is the rotor's mean angular acceleration over the
    # window, J |d omega| / T_w / r_b2: the mesh mode's ringing, ~1 um at ~2 kHz, moves
    # the ring by ~0.2 rad/s, i.e. ~0.3 N against 634 N: tolerance 0.2%.
    lever = 0.5 * GEARSET.module * GEARSET.stages[0].teeth * math.cos(math.radians(20.0))
    m = mesh_metrics(loaded)
    assert m.mean_drive_force == pytest.approx((50.0 + 0.01) / lever, rel=2e-3)
    assert m.mean_coast_force == 0.0 and m.rattle_count == 0
    # a tooth pair enters each mesh period
    assert abs(m.mesh_in_count - m.periods) <= 1


def test_lumped_te_spectrum_peaks_at_the_mesh_frequency(loaded):
    # the strongest line of the TE's whole spectrum (not only the mesh orders) is the
    # tooth-mesh frequency N_p n / 60 = 316.7 Hz: a rigid-kinematics truth
    m = mesh_metrics(loaded)
    inside = (loaded.time >= m.window[0]) & (loaded.time < m.window[1])
    t, te = loaded.time[inside], loaded.te[inside]
    spectrum = np.abs(np.fft.rfft(te - te.mean()))
    freq = np.fft.rfftfreq(te.size, t[1] - t[0])
    assert freq[np.argmax(spectrum)] == pytest.approx(19 * 1000.0 / 60.0, rel=1e-9)


def test_lumped_calibrated_on_the_closed_forms_is_the_closed_form_run(tmp_path):
    # a calibration file holding stage 2's closed-form flank laws must give stage 2's
    # closed-form run: the stage is picked and renumbered right (stage 1's or 3's laws
    # would change the mesh stiffness and the TE)
    condition = _condition("s2", 2, 300.0, 20.0, duration=0.02)
    closed = lumped_model(condition).law_set
    cases = [{"stage": 2, "kind": kind, "impact_speed": float(v),
              "impact": {"k": float(k), "exponent": float(n), "cmax": float(c), "d": float(d)}}
             for kind in ("mesh", "switch")
             for v, k, n, c, d in zip(*(getattr(closed.table(1, kind), a) for a in
                                        ("impact_speed", "k", "exponent", "cmax", "d")),
                                      strict=True)]
    path = tmp_path / "calibration.json"
    path.write_text(json.dumps({"schema": "fe-impact/calibration/1", "cases": cases}))
    a = run_lumped(condition, "calibrated", calibration=path)
    b = run_lumped(condition, "closed-form")
    np.testing.assert_allclose(a.te, b.te, rtol=0, atol=1e-15)
    with pytest.raises(CaseError, match="needs a calibration file"):
        run_lumped(condition, "calibrated")
    with pytest.raises(CaseError, match="stages 1..3"):
        run_lumped(replace(_condition(), stage=4))


def test_record_of_a_rolling_fe_run_sums_its_pairs_and_names_its_events():
    from types import SimpleNamespace

    t = np.linspace(0.0, 0.01, 5)
    forces = np.zeros((5, 3, 2))
    forces[:, 0, 0], forces[:, 1, 0], forces[:, 2, 1] = 100.0, 50.0, 7.0
    forces[2, 1, 0] = np.nan                                # out of reach: no force
    event = SimpleNamespace(time_s=0.004, flank="drive", tooth=1, kind="mesh-in",
                            closing_speed_m_s=0.04, peak_force_n=690.0, where="approach-edge",
                            s_m=1e-3, end_time_s=0.009, end_s_m=0.016)
    result = SimpleNamespace(time_s=t, te_m=np.zeros(5), pair_force_n=forces, events=[event],
                             info={"dofs": 1})
    from fe_impact.rolling.compare import record_from_roll

    record = record_from_roll(result, _condition(), GEARSET.pinion.teeth)
    np.testing.assert_array_equal(record.drive_force, [150.0, 150.0, 100.0, 150.0, 150.0])
    np.testing.assert_array_equal(record.coast_force, np.full(5, 7.0))
    assert record.events.location.tolist() == ["corner-approach"]
    assert record.events.flank.tolist() == [1] and record.events.kind.tolist() == ["mesh-in"]
    bad = SimpleNamespace(**{**result.__dict__,
                             "events": [SimpleNamespace(**{**event.__dict__, "where": "tip"})]})
    with pytest.raises(CaseError, match="where = 'tip'"):
        record_from_roll(bad, _condition(), GEARSET.pinion.teeth)


def test_pairs_touching_together_after_a_flight_are_one_rattle_of_their_flank():
    # The FE lists a rattle per tooth pair; the module's convention (and the lumped
    # model) has one per flank contact, its peak force the flank's total. Two drive
    # pairs touch in the same step at 2 ms (closing 2.15 and 2.16 mm/s), carrying
    # 9 N and 11 N at 3 ms (20 N together); a coast pair touches at 8 ms, after
    # their contact ended (7 ms): one drive rattle of 20 N at 2.16 mm/s, one coast.
    from types import SimpleNamespace

    from fe_impact.rolling.compare import record_from_roll

    t = np.linspace(0.0, 0.01, 11)
    forces = np.zeros((11, 3, 2))
    forces[2:8, 0, 0] = [1.0, 9.0, 6.0, 3.0, 1.0, 0.0]
    forces[2:8, 1, 0] = [1.5, 11.0, 7.0, 2.0, 0.5, 0.0]
    forces[8:10, 2, 1] = [4.0, 2.0]

    def rattle(time, flank, tooth, speed, peak, end):
        return SimpleNamespace(time_s=time, flank=flank, tooth=tooth, kind="rattle",
                               closing_speed_m_s=speed, peak_force_n=peak, where="flank",
                               s_m=5e-3, end_time_s=end, end_s_m=6e-3)

    events = [rattle(0.002, "drive", 0, 2.15e-3, 9.0, 0.007),
              rattle(0.002, "drive", 1, 2.16e-3, 11.0, 0.007),
              rattle(0.008, "coast", 2, 1.0e-3, 4.0, 0.010)]
    result = SimpleNamespace(time_s=t, te_m=np.zeros(11), pair_force_n=forces,
                             events=events, info={})
    ev = record_from_roll(result, _condition(), GEARSET.pinion.teeth).events
    assert ev.kind.tolist() == ["rattle", "rattle"]
    assert ev.flank.tolist() == [1, -1]
    assert ev.peak_force.tolist() == [20.0, 4.0]
    assert ev.closing_speed.tolist() == [2.16e-3, 1.0e-3]
    assert ev.time.tolist() == [0.002, 0.008]


def test_phase_offset_of_the_mesh_in_impacts_wraps_around_the_period():
    from fe_impact.rolling.compare import phase_offset

    condition = _condition(speed=1000.0, duration=0.01)
    f = condition.mesh_frequency(GEARSET.pinion.teeth)
    t = np.linspace(0.0, 0.01, 200)

    def at(phases):
        n = len(phases)
        ev = ContactEvents(np.asarray(phases) / f, ["mesh-in"] * n, [1] * n, [0.04] * n,
                           [700.0] * n, ["corner-approach"] * n, [math.nan] * n)
        return _record(t, np.zeros_like(t), ev, condition=condition)

    # lumped entries at 0.93 and 1.93 periods, the FE's at 0.14 and 1.14: moving the
    # lumped pairs on by 0.79 of a base pitch makes them enter 0.79 period earlier
    assert phase_offset(at([0.14, 1.14]), at([0.93, 1.93])) == pytest.approx(0.79, abs=1e-9)
    assert phase_offset(at([0.95, 1.96]), at([0.05, 1.06])) == pytest.approx(0.10, abs=1e-9)
    assert math.isnan(phase_offset(at([]), at([0.5])))


def test_undamped_tip_edges_change_only_the_tip_edge_laws_damping():
    # the diagnostic run of rolling_compare: the corner (mesh-in) laws lose their damping,
    # every other law and parameter is the closed-form run's
    condition = _condition("tip", 1, 1000.0, 50.0)
    damped = lumped_model(condition).law_set.tables
    undamped = lumped_model(condition, tip_edge_damping=False).law_set.tables
    assert damped.keys() == undamped.keys()
    assert any(kind.startswith("corner") for _, kind in damped)
    for key, table in damped.items():
        other = undamped[key]
        for name in ("impact_speed", "k", "exponent", "d"):
            np.testing.assert_array_equal(getattr(other, name), getattr(table, name))
        if key[1].startswith("corner"):
            assert not other.cmax.any() and table.cmax.any()
        else:
            np.testing.assert_array_equal(other.cmax, table.cmax)


# -- the excitation: the same kinematic TE in both models ------------------------------------
#: Kinematic TE amplitude of the excitation checks [m]: ten times the studies' 1 um, so
#: that what else moves the TE at the mesh frequency is small beside it.
EXCITATION = 10e-6


def _sine_amplitude(t, te, f, t0):
    """Least-squares ``(a, b)`` of ``te ~ c + a sin(2 pi f t) + b cos(2 pi f t)`` on
    ``t >= t0``."""
    keep = t >= t0
    w = 2.0 * np.pi * f * t[keep]
    basis = np.column_stack([np.ones(keep.sum()), np.sin(w), np.cos(w)])
    coef, *_ = np.linalg.lstsq(basis, te[keep], rcond=None)
    return coef[1], coef[2]


def test_kinematic_te_is_plus_e_in_both_models():
    # The condition's kinematic TE e = A sin(2 pi u / p_b) (u the pinion's roll since
    # t = 0) is, by its definition in the record's sign convention (TE > 0 when the
    # pinion leads), the TE of the unloaded drive flank: under a steady load the TE of
    # a run with e minus that of the same run without it is +e, quasi-statically.
    # Both models are run at 100 r/min (mesh 31.7 Hz) under 20 N m (253 N) applied at
    # once: the inertia force of the face gear following e, m (2 pi f)^2 A with
    # m = 1.15 kg, is 0.46 N, 5e-9 m of approach on the mesh's ~1e8 N/m (0.05% of A),
    # so the drive flank stays loaded; the start, where e' = 2 mm/s is asked of the
    # face gear at once, lifts it off by v^2 / 2a = 0.009 um (a = 253 N / 1.15 kg).
    # Tolerance 5% of A on the sine component and on the cosine (phase), for the
    # lumped model's mesh stiffness (about 1 um of Hertz approach, the same with and
    # without e) and the stiffened (E x 1e6), undamped FE's contact chatter at its
    # step. An excitation of the opposite sign gives -e, and the FE's mesh then
    # leaves its drive flank within two periods (its coast flank touches).
    import fe_impact.rolling.model as rm
    from fe_impact.rolling.run import integrate
    from fe_impact.rolling.sectors import tooth_range

    speed, torque = 100.0, 20.0
    cond = _condition(speed=speed, torque=torque, duration=3.0 * 60.0 / (19 * speed),
                      settle=60.0 / (19 * speed), mesh_phase=0.3)
    f = cond.mesh_frequency(GEARSET.pinion.teeth)
    lumped = [run_lumped(replace(cond, transmission_error=a)) for a in (EXCITATION, 0.0)]
    a, b = _sine_amplitude(lumped[0].time, lumped[0].te - lumped[1].te, f, cond.settle)
    assert a == pytest.approx(EXCITATION, rel=0.05)
    assert abs(b) < 0.05 * EXCITATION

    geo = rm.ContactGeometry.build(GEARSET, 1, stiffen=1e6, n=31, corners="planar")
    pair = geo.pair

    runs = []
    for amp in (EXCITATION, 0.0):
        s = rm.RollSettings(speed=speed * 2 * math.pi / 60, torque=torque, cycles=2.0,
                            steps_per_cycle=60, ramp_cycles=0.0, te_amplitude=amp)
        roller = rm.Roller(geo, rm.rigid_body("pinion", GEARSET.pinion.inertia,
                                              *pair.pinion_axis),
                           rm.rigid_body("face_gear", GEARSET.stages[0].inertia,
                                         *pair.face_axis),
                           tooth_range(), 0.0, pair.nominal_face_angle(0.0), s)
        runs.append(integrate(roller))
    t = runs[0].time_s
    a, b = _sine_amplitude(t, runs[0].te_m - runs[1].te_m, f, 0.0)
    assert a == pytest.approx(EXCITATION, rel=0.05)
    assert abs(b) < 0.05 * EXCITATION
    assert not np.any(runs[0].pair_force_n[:, :, 1] > 0.0)


@pytest.mark.parametrize("teeth", [4, 5, 6, 7])
def test_comparison_runs_fit_the_sectors_and_count_the_mesh_ins(teeth):
    # the comparison's start (MESH_PHASE - pair_offset) and length (cycles_for) must lie
    # in the window the rolling FE's sectors hold (the solid tip-edge gaps, as the FE
    # runs them): the Roller refuses otherwise. A pair enters every mesh period, at
    # 1 - MESH_PHASE (+ a tip edge's approach, < 0.1 period) past each whole period; a
    # mesh-in counts when the run goes on MESH_IN_HOLD periods after it: after the
    # 1-period load ramp, 7 teeth (4.4 periods) count the entries near 1.1, 2.1 and 3.1
    # periods, as the 7-tooth rolling FE of loaded-1000 counted them (1.08, 2.10, 3.11).
    import sys
    from pathlib import Path

    from fe_impact.rolling.compare import MESH_IN_HOLD
    from fe_impact.rolling.model import ContactGeometry, Roller, RollSettings, rigid_body
    from fe_impact.rolling.sectors import tooth_range

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from validation.rolling_compare import MESH_PHASE, cycles_for, pair_offset

    geo = ContactGeometry.build(GEARSET, 1)
    pair = geo.pair
    s = RollSettings(speed=100.0, cycles=cycles_for(teeth),
                     start_cycles=MESH_PHASE - pair_offset(teeth))
    Roller(geo, rigid_body("pinion", GEARSET.pinion.inertia, *pair.pinion_axis),
           rigid_body("face_gear", GEARSET.stages[0].inertia, *pair.face_axis),
           tooth_range(teeth), 0.0, pair.nominal_face_angle(0.0), s)
    entries = [k + 1.0 - MESH_PHASE for k in range(1, 10)]
    counted = [t for t in entries if t + 0.1 + MESH_IN_HOLD <= cycles_for(teeth)]
    assert len(counted) == teeth - 4
