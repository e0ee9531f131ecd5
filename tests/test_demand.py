"""The first pass of the calibration loop: what the switching presets ask of the FE cases."""

from __future__ import annotations

import math

import pytest

from fe_impact.calibration.sweep import plan_cases
from fe_impact.gears import default_gearset
from fe_impact.switching import demand as D


def test_top_speed_rounds_up_to_two_digits_with_the_margin():
    assert D.top_speed(0.1528) == pytest.approx(0.19)    # 0.18336 -> 0.19
    assert D.top_speed(0.25) == pytest.approx(0.30)      # exactly 0.30 stays
    assert D.top_speed(1.0e-3) == pytest.approx(1.2e-3)
    for v in (0.0123, 0.4567, 3.3):
        assert D.TOP_MARGIN * v <= D.top_speed(v) < D.TOP_MARGIN * v * 1.1


def _demand(rows):
    return D.Demand(("x",), {s: {law: D.LawDemand(1, v, v, v, 1.0)} for s, law, v in rows})


def test_a_stage_gets_an_fe_impact_only_where_the_presets_close_faster():
    gearset = default_gearset()
    planned = plan_cases(gearset)          # 12.5, 37.6 and 125 mm/s on every stage
    demand = _demand([(1, "mesh", 0.05), (2, "switch", 0.16), (3, "corner-recess", 0.5)])
    cases, lines = D.cover(demand, planned, gearset)
    # stage 1 stays within its cases; stage 3's fast impacts took a corner law (the
    # flank FE cases do not calibrate it); stage 2's switch impacts need a faster case,
    # which takes the place of its fastest (three planned: the cost stays)
    assert len(cases) == len(planned) and len(lines) == 1
    changed = [c for c in cases if c not in planned]
    (case,) = changed
    assert (case.stage, case.kind, case.face_teeth) == (2, "mesh", 68)
    assert case.impact_speed == pytest.approx(0.2)       # 1.2 x 0.16 = 0.192 -> 0.20
    assert case.speed_rpm is None and case.id == "stage2_mesh_200mms"
    gone = [c for c in planned if c not in cases]
    assert [c.id for c in gone] == ["stage2_mesh_1000rpm"]
    assert "in place of stage2_mesh_1000rpm" in lines[0]
    # stages with fewer cases keep them and get one more: without the 1000 r/min cases
    # stage 1 (37.6 mm/s) is outrun too (50 mm/s -> 60)
    few = [c for c in planned if c.speed_rpm != 1000.0]
    cases, _ = D.cover(demand, few, gearset)
    added = cases[len(few):]
    assert cases[:len(few)] == few
    assert [(c.stage, round(c.impact_speed, 6)) for c in added] == [(1, 0.06), (2, 0.2)]


def test_the_demand_is_counted_per_stage_and_law_and_cached(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    calls = []

    def fake(gearset, name):
        calls.append(name)
        # (stage, law code, closing speed, peak force, place on the line of action):
        # two mesh, one corner-approach
        return ([(1, 0, 0.01, 10.0, 0.011), (1, 0, 0.03, 30.0, 0.013),
                 (1, 2, 0.02, 5.0, 0.001)], {1: 40.0 if name == "a" else 55.0})

    monkeypatch.setattr(D, "_run_preset", fake)
    gearset = default_gearset()
    got = D.preset_demand(gearset, ["a", "b"], workers=1)
    assert calls == ["a", "b"]
    mesh = got.stages[1]["mesh"]
    assert (mesh.count, mesh.speed_min, mesh.speed_max, mesh.force_max) == (4, 0.01, 0.03,
                                                                            30.0)
    assert math.isclose(mesh.speed_median, 0.02) and math.isclose(mesh.position_median, 0.012)
    assert (mesh.force_min, mesh.force_median) == (10.0, 20.0)
    assert got.stages[1]["corner-approach"].count == 2
    assert got.top_speed(1) == 0.03 and got.top_speed(2) is None
    assert got.mesh_force == {1: 55.0} and got.top_mesh_force() == 55.0
    assert D.curve_top_force(got) == pytest.approx(83.0)  # 1.5 x 55 = 82.5, up to 2 digits
    again = D.preset_demand(gearset, ["a", "b"], workers=1)
    assert calls == ["a", "b"] and again == got           # from the cache
    D.preset_demand(gearset, ["a"], workers=1)            # other presets: run again
    assert calls == ["a", "b", "a"]


def test_corner_impacts_strike_each_rounded_edge_at_the_presets_speeds():
    # Per stage and struck edge: the median and the largest closing speed to two
    # digits, one case when they round alike; an edge the presets never struck and a
    # sharp edge get none.
    import dataclasses

    gearset = default_gearset()
    demand = D.Demand(("x",), {
        1: {"corner-approach": D.LawDemand(45, 0.003, 0.02375, 0.04775, 447.0),
            "corner-recess": D.LawDemand(95, 0.0002, 0.0109, 0.0111, 458.0)},
        2: {"mesh": D.LawDemand(9, 0.001, 0.01, 0.1, 1.0)}})
    cases, lines = D.corner_impacts(demand, gearset, [1, 2])
    assert [(c.stage, c.kind, c.impact_speed) for c in cases] == [
        (1, "corner-approach", 0.024), (1, "corner-approach", 0.048),
        (1, "corner-recess", 0.011)]
    assert cases[0].id == "stage1_corner-approach_24mms"
    assert sum("never struck" in line for line in lines) == 2     # stage 2's two edges
    sharp = dataclasses.replace(gearset, face_tip_edge_radius=0.0)
    cases, lines = D.corner_impacts(demand, sharp, [1])
    assert [c.kind for c in cases] == ["corner-recess"]
    assert any("sharp edge" in line for line in lines)


def test_a_corner_impact_strikes_where_the_corner_laws_take_the_touch():
    from fe_impact.calibration.sweep import ImpactCase, Settings, case_contact
    from fe_impact.switching.calibration import corner_reference_roll

    gearset = default_gearset()
    settings = Settings(roll_angle_deg=0.0)
    assert case_contact(ImpactCase(1, 56, "mesh", 0.01), settings, gearset) == ("flank", 0.0)
    assert case_contact(ImpactCase(2, 68, "switch", 0.1), settings, gearset) == ("flank", 0.0)
    for side in ("approach", "recess"):
        contact, roll = case_contact(ImpactCase(1, 56, f"corner-{side}", 0.01), settings,
                                     gearset)
        assert contact == f"corner-{side}"
        assert roll == pytest.approx(math.degrees(corner_reference_roll(gearset, side)),
                                     rel=1e-12)


def test_switch_cases_strike_where_the_presets_first_contacts_touched():
    # The median place s of a stage's switch impacts becomes the pinion roll angle
    # (s_pitch - s) / r_bp of its switch cases; a place beyond the path is held at
    # the FE path's end; a stage without switch impacts keeps the pitch point.
    from fe_impact.calibration.meshcycle import path_positions
    from fe_impact.switching.geometry import mesh_geometry

    gearset = default_gearset()
    line = mesh_geometry(gearset)
    planned = plan_cases(gearset, switch="eq5")
    s2 = line.s_pitch - line.base_radius * math.radians(4.0)      # 4 deg of roll
    demand = D.Demand(("x",), {2: {"switch": D.LawDemand(2, 0.1, 0.12, 0.15, 9.0, s2)},
                               3: {"switch": D.LawDemand(2, 0.1, 0.12, 0.15, 9.0, 0.0)}})
    cases, lines = D.place_switches(demand, planned, gearset)
    switch = {c.stage: c.roll_angle_deg for c in cases if c.kind == "switch"}
    assert switch[2] == pytest.approx(4.0, rel=1e-12)
    assert switch[3] == pytest.approx(max(path_positions(gearset, 3, 2)), rel=1e-12)
    assert "beyond the FE path" in lines[1]
    assert all(c.roll_angle_deg is None for c in cases if c.kind == "mesh")
    assert [c.id for c in cases] == [c.id for c in planned]
    none, lines = D.place_switches(D.Demand(("x",), {}), planned, gearset)
    assert none == planned and "pitch point" in lines[0]


def test_a_user_schedule_joins_the_first_pass(tmp_path, monkeypatch):
    # A schedule at a real load: its largest mesh force on stage 2 is at least the static
    # share T / (n r_b) of each mesh (the time mean is that, the peak cannot be below it),
    # and the cache keys on the schedule's content.
    from fe_impact.switching.model import DriveModel
    from fe_impact.switching.schedule import schedule_from_dict

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    gearset = default_gearset()
    doc = {"name": "loaded", "segments": [{"stage": 2, "duration_s": 0.05, "speed_rpm": 300,
                                           "load_Nm": 200}]}
    duty = schedule_from_dict(doc)
    got = D.preset_demand(gearset, [], workers=1, schedules=[duty])
    model = DriveModel(gearset=gearset)
    static = 200.0 / (model.pinions * model.base_levers[1])
    assert got.schedules == ("loaded",) and set(got.mesh_force) == {2}
    # upper bound: a dynamic factor below 2 (the pitch-line speed is 0.9 m/s, where
    # ISO 6336-1's K_v - 1, proportional to it, is a few per cent for any accuracy grade)
    assert static <= got.mesh_force[2] < 2.0 * static
    assert D.curve_top_force(got) >= D.FORCE_MARGIN * got.mesh_force[2]
    doc["segments"][0]["load_Nm"] = 400
    other = D.preset_demand(gearset, [], workers=1, schedules=[schedule_from_dict(doc)])
    # twice the load: the peak is at least the mean, which is the static share 2 x static
    # to within the short run's start transient (5% allowed)
    assert other.mesh_force[2] > 1.9 * static
