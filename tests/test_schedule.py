"""Schedule files: the reader's checks, the shipped presets, and the kernel's time functions
(ramped speed, ramped and tabulated load) against independent integrals."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from fe_impact.errors import CaseError
from fe_impact.switching import _kernel as K
from fe_impact.switching.model import RPM, DriveModel, LoadSeries, Segment, StageSchedule
from fe_impact.switching.presets import PRESETS, preset_file
from fe_impact.switching.schedule import SCHEMA, read_load_series, read_schedule
from fe_impact.switching.simulation import _schedule_array, simulate

GOOD = """\
schema = "fe-impact/schedule/1"
name = "climb"
blend_s = 0.02

[[segments]]
stage = 1
duration_s = 0.1
speed_rpm = { from = 100, to = 300 }
load_Nm = 20

[[segments]]
stage = 2
duration_s = 0.1
speed_rpm = 300
load_Nm = { file = "torque.csv" }
switch = { engage = 0.5 }

[[segments]]
stage = 2
duration_s = 0.05
speed_rpm = 300
load_Nm = { from = 30, to = 60 }
blend_s = 0.01
"""
SERIES = "time_s,load_Nm\n0,20\n0.05,40\n0.1,30\n0.2,0\n"


def _write(folder: Path, text: str, series: str = SERIES) -> Path:
    (folder / "torque.csv").write_text(series)
    path = folder / "duty.toml"
    path.write_text(text)
    return path


def test_reader_builds_the_segments(tmp_path):
    duty = read_schedule(_write(tmp_path, GOOD))
    a, b, c = duty.schedule.segments
    assert duty.name == "climb"
    assert (a.stage, a.speed_rpm, a.speed_end_rpm, a.load, a.blend) == (1, 100, 300, 20, None)
    assert (b.stage, b.engage, b.blend, b.load) == (2, 0.5, 0.02, 20.0)
    np.testing.assert_array_equal(b.load_series.times, [0, 0.05, 0.1, 0.2])
    assert (c.load, c.load_end, c.blend, c.engage) == (30, 60, 0.01, None)
    assert duty.max_load == 60
    assert len(duty.digest) == 24


def _replace(text: str, old: str, new: str) -> str:
    assert old in text
    return text.replace(old, new, 1)


@pytest.mark.parametrize(("old", "new", "message"), [
    ("duration_s = 0.1\nspeed_rpm = 300", "duration_s = 0\nspeed_rpm = 300",
     "[segments[1]] duration_s = 0: must be > 0"),
    ("duration_s = 0.1\nspeed_rpm = 300", "duration_s = -2\nspeed_rpm = 300",
     "[segments[1]] duration_s = -2: must be > 0"),
    ("stage = 2\nduration_s = 0.05", "stage = 1\nduration_s = 0.05", None),  # no switch table
    ("stage = 2\nduration_s = 0.1", "stage = 1\nduration_s = 0.1",
     "[segments[1]] switch = {'engage': 0.5}: a ratio switch to stage 1, which segments[0] "
     "already engages"),
    ("switch = { engage = 0.5 }", "switch = { engage = 2 }",
     "[segments[1].switch] engage = 2: must be in [-1.0, 1.0]"),
    ("speed_rpm = 300\nload_Nm = { from", "speed_rpm = -5\nload_Nm = { from",
     "[segments[2]] speed_rpm = -5: must be a number >= 0"),
    ("blend_s = 0.01", "blend_s = 0.2", "[segments[2]] blend_s = 0.2: the segment (0.05 s) "
     "must last at least its blend_s = 0.2 s"),
    ('schema = "fe-impact/schedule/1"', 'schema = "fe-impact/schedule/9"',
     "schema = 'fe-impact/schedule/9': this version reads 'fe-impact/schedule/1'"),
    ("load_Nm = 20", "load_Nm = 20\ncolour = 1", "unknown key(s) ['colour'] in [segments[0]]"),
    ("load_Nm = 20", "load_Nm = { from = 1, upto = 2 }", "unknown key(s) ['upto'] in "
     "[segments[0].load_Nm]"),
    ('{ file = "torque.csv" }', '{ file = "missing.csv" }', "missing.csv: load series not "
     "found"),
])
def test_reader_refuses_in_one_line(tmp_path, old, new, message):
    path = _write(tmp_path, _replace(GOOD, old, new))
    if message is None:          # a stage kept without a switch table is no switch: fine
        read_schedule(path)
        return
    with pytest.raises(CaseError) as info:
        read_schedule(path)
    text = str(info.value)
    assert "\n" not in text and text.startswith(str(path)) and message in text, text


@pytest.mark.parametrize(("series", "message"), [
    ("time_s,load_Nm\n0,20\n0.1,30\n0.05,40\n0.3,1\n",
     "line 4: time_s = 0.05 is not after line 3's 0.1: times must increase strictly"),
    ("time_s,load_Nm\n0,20\n0.1,30\n0.1,40\n0.3,1\n", "line 4: time_s = 0.1 is not after"),
    ("time_s,load_Nm\n0,20\n0.1,nan\n0.3,1\n",
     "line 3: load_Nm = nan: must be a finite number (no NaN or inf)"),
    ("time_s,load_Nm\n0,20\n0.1,abc\n0.3,1\n", "line 3: load_Nm = 'abc': must be a number"),
    ("time_s,load_Nm\n0.01,20\n0.3,1\n", "line 2: time_s = 0.01: the series must start at 0"),
    ("time_s,load_Nm\n0,20\n0.3,-1\n", "line 3: load_Nm = -1: must be >= 0"),
    ("t,T\n0,20\n0.3,1\n", "line 1: header ['t', 'T']: give the two columns"),
    ("time_s,load_Nm\n0,20\n0.05,1\n", "ends at 0.05 s, before the segment's duration_s = "
     "0.1 s"),
])
def test_series_refused_in_one_line(tmp_path, series, message):
    path = _write(tmp_path, GOOD, series)
    with pytest.raises(CaseError) as info:
        read_schedule(path)
    text = str(info.value)
    assert "\n" not in text and "[segments[1]] load_Nm" in text and message in text, text


def test_series_columns_in_either_order(tmp_path):
    path = tmp_path / "s.csv"
    path.write_text("# measured\nload_Nm,time_s\n5,0\n7,1\n")
    series = read_load_series(path)
    np.testing.assert_array_equal(series.times, [0, 1])
    np.testing.assert_array_equal(series.torques, [5, 7])


def test_stage_the_gear_set_lacks(tmp_path):
    duty = read_schedule(_write(tmp_path, _replace(GOOD, "stage = 2\nduration_s = 0.05",
                                                   "stage = 4\nduration_s = 0.05")))
    with pytest.raises(CaseError, match=r"\[segments\[2\]\] stage = 4: the gear set 'seed' "
                                        r"has stages 1..3"):
        duty.check_stages(3, "the gear set 'seed'")


def test_presets_are_schedule_files():
    # every case of every preset is a package file with the current schema
    names = {c.name for p in PRESETS.values() for c in p.cases}
    for name in names:
        path = preset_file(name)
        assert SCHEMA in path.read_text()
        duty = read_schedule(path)
        (case,) = [c for c in PRESETS[name].cases]
        assert duty.schedule == case.schedule


# -- the kernel's time functions -----------------------------------------------------------
def test_reference_angle_is_the_integral_of_its_speed():
    # ramps and blends: the closed-form angle of `_kernel.reference` against the trapezoid
    # integral of its own speed on 2e5 points (error ~ h^2 |psi'''| ~ 1e-10 rad here)
    schedule = StageSchedule((
        Segment(0.3, 1, 100.0, 5.0, speed_end_rpm=700.0, load_end=50.0),
        Segment(0.2, 2, 400.0, 10.0, blend=0.15),
        Segment(0.25, 2, 900.0, 0.0, speed_end_rpm=200.0, blend=0.05),
    ))
    sch = _schedule_array(schedule, 0.1)
    t = np.linspace(0.0, schedule.duration, 200_001)
    values = np.array([K.reference(x, sch) for x in t])
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (values[1:, 1] + values[:-1, 1])
                                                * np.diff(t))])
    assert np.max(np.abs(values[:, 0] - integral)) < 1e-8
    # the speed's slope is its acceleration (central differences, O(h^2))
    h = 1e-6
    for x in (0.05, 0.31, 0.4, 0.52, 0.7):
        fd = (K.reference(x + h, sch)[1] - K.reference(x - h, sch)[1]) / (2 * h)
        assert abs(fd - K.reference(x, sch)[2]) < 1e-4 * max(1.0, abs(fd))
    # outside the blends, the ramps themselves: linear speed, linear load
    assert K.reference(0.15, sch)[1] == pytest.approx(400.0 * RPM, rel=1e-12)
    assert K.reference(0.15, sch)[3] == pytest.approx(27.5, rel=1e-12)
    assert K.reference(0.6, sch)[1] == pytest.approx((900.0 - 700.0 * 0.1 / 0.25) * RPM,
                                                     rel=1e-12)


def test_load_series_reaches_the_model(tmp_path):
    # the sampled load torque equals the CSV's linear interpolation once the blend is over
    duty = read_schedule(_write(tmp_path, GOOD))
    run = simulate(DriveModel(), duty.schedule, sample_interval=1e-3)
    t, load = run.series["time_s"], run.series["load_torque_Nm"]
    seg = duty.schedule.segments[1]
    inside = (t > 0.1 + 0.02) & (t < 0.2)
    expected = np.interp(t[inside] - 0.1, seg.load_series.times, seg.load_series.torques)
    np.testing.assert_allclose(load[inside], expected, rtol=1e-12, atol=1e-12)
    pinion = run.series["pinion_speed_rad_s"]
    first = t < 0.1
    np.testing.assert_allclose(pinion[first], (100.0 + 2000.0 * t[first]) * RPM, rtol=1e-9)
    assert math.isclose(float(pinion[-1]), 300.0 * RPM, rel_tol=1e-9)


def test_load_series_record_checks():
    with pytest.raises(CaseError, match="times must start at 0 s and increase strictly"):
        LoadSeries([0.0, 0.2, 0.1], [1.0, 2.0, 3.0])
    with pytest.raises(CaseError, match="no NaN"):
        LoadSeries([0.0, 0.2], [1.0, math.nan])


def test_cli_refuses_a_stage_the_gear_set_lacks(tmp_path):
    import argparse

    from fe_impact.cli.switching import register

    parser = argparse.ArgumentParser(prog="fe-impact")
    register(parser.add_subparsers())
    path = _write(tmp_path, _replace(GOOD, "stage = 2\nduration_s = 0.05",
                                     "stage = 4\nduration_s = 0.05"))
    args = parser.parse_args(["switching", "--schedule", str(path), "--out",
                              str(tmp_path / "out")])
    with pytest.raises(CaseError, match=r"duty.toml: \[segments\[2\]\] stage = 4: the gear set "
                                        r"'seed-multistage-face-gear' has stages 1..3"):
        args.func(args)
    assert not (tmp_path / "out").exists()


def test_a_schedule_file_is_a_study(tmp_path):
    from fe_impact.switching.study import study_folder, study_preset

    path = _write(tmp_path, GOOD)
    preset = study_preset(str(path))
    assert (preset.name, preset.seed_table, len(preset.cases)) == ("climb", None, 1)
    assert study_folder(str(path)) == "climb" and study_folder("table1") == "table1"
    assert study_preset("table1").seed_table == "table1"


@pytest.mark.parametrize("schema", ["fe-impact/calibration/99", "fe-impact/mesh-cycle/1", 2])
def test_a_calibration_of_another_schema_is_refused(tmp_path, schema):
    # a file this version cannot read must not be run on: one line naming the key, the
    # value and the schemas read; nothing written
    import argparse
    import json

    from fe_impact.cli.switching import register
    from fe_impact.errors import CalibrationError
    from fe_impact.gears import default_gearset
    from fe_impact.switching.calibration import load_calibration

    path = tmp_path / "calibration.json"
    path.write_text(json.dumps({"schema": schema, "cases": [
        {"stage": 1, "kind": "mesh", "impact_speed": 0.05,
         "impact": {"k": 6.5e10, "exponent": 1.5, "cmax": 1.5e3, "d": 1e-6}}]}))
    with pytest.raises(CalibrationError) as info:
        load_calibration(path, default_gearset())
    text = str(info.value)
    assert "\n" not in text and f"schema = {schema!r}" in text
    assert "'fe-impact/calibration/2'" in text
    parser = argparse.ArgumentParser(prog="fe-impact")
    register(parser.add_subparsers())
    args = parser.parse_args(["switching", "--preset", "table1-100rpm", "--duration", "0.05",
                              "--calibration", str(path), "--out", str(tmp_path / "out")])
    with pytest.raises(CalibrationError, match="schema"):
        args.func(args)
    assert not (tmp_path / "out").exists()


def test_calibrate_plans_for_the_schedules(tmp_path, monkeypatch):
    # The plan of calibrate --schedule, the sweep left out: the first pass is given the
    # schedule; the stage whose flank impacts close faster than its planned FE impacts
    # gets one at 1.2 x their speed (rounded up); the mesh-cycle curves reach 1.5 x the
    # largest mesh force (rounded up to two digits); the schedule runs as a study.
    import math

    import fe_impact.api.calibrating as api  # where calibrate looks up _sweep
    from fe_impact.switching import demand as D

    seen = {}

    def first_pass(gearset, presets, workers=2, numba=None, schedules=()):
        seen["schedules"] = [d.name for d in schedules]
        row = D.LawDemand(10, 0.01, 0.05, 0.3, 900.0, math.nan)
        return D.Demand(tuple(presets), {2: {"mesh": row}}, {1: 800.0, 2: 12345.0},
                        tuple(d.name for d in schedules))

    def sweep(text, cases, cycle, settings, out, cache, workers, scheduler, progress,
              studies, numba, say):
        seen.update(cases=cases, cycle=cycle, studies=studies)
        raise KeyboardInterrupt   # stop before anything runs

    monkeypatch.setattr(D, "preset_demand", first_pass)
    monkeypatch.setattr(api, "_sweep", sweep)
    path = _write(tmp_path, GOOD)
    with pytest.raises(KeyboardInterrupt):
        api.calibrate(None, out=tmp_path / "cal", schedules=[path], level="coarse",
                      cache=tmp_path / "cache", stages=[1, 2], positions=3)
    assert seen["schedules"] == ["climb"]
    assert str(path.resolve()) in seen["studies"]
    fastest = max(c.impact_speed for c in seen["cases"] if c.stage == 2 and c.kind == "mesh")
    assert fastest == pytest.approx(0.36)                    # 1.2 x 0.3 m/s
    top = max(max(p.forces) for p in seen["cycle"])
    # 1.5 x 12345 = 18518 -> 19000 N, above the impacts' own Hertz estimate (3.9 kN)
    assert top == pytest.approx(19000.0)
    assert {p.stage for p in seen["cycle"] if max(p.forces) == top} == {1, 2}


def test_calibrate_refuses_a_schedule_stage_the_gear_set_lacks(tmp_path):
    import fe_impact.api as api

    path = _write(tmp_path, _replace(GOOD, "stage = 2\nduration_s = 0.05",
                                     "stage = 4\nduration_s = 0.05"))
    with pytest.raises(CaseError, match=r"\[segments\[2\]\] stage = 4: the gear set"):
        api.calibrate(None, out=tmp_path / "cal", schedules=[path], level="coarse",
                      cache=tmp_path / "cache")
    assert not (tmp_path / "cal").exists()


def test_scaling_a_schedule_stretches_its_load_series(tmp_path):
    duty = read_schedule(_write(tmp_path, GOOD))
    longer = duty.schedule.scaled(2.0 * duty.schedule.duration)
    before, after = duty.schedule.segments[1], longer.segments[1]
    np.testing.assert_allclose(after.load_series.times, 2.0 * before.load_series.times)
    np.testing.assert_array_equal(after.load_series.torques, before.load_series.torques)
    assert after.duration == pytest.approx(2.0 * before.duration)


def test_calibration_report_tables_the_force_range(tmp_path):
    # two stages: one whose curves reach 1.5 x the runs' force, one short of it (said so);
    # a position fitted below its top (edge loading) shows in the fitted range
    import json

    from fe_impact.calibration.report import _force_range_lines

    demand = {"mesh_force_max_N": {"1": 1000.0, "2": 4000.0}, "force_margin": 1.5}
    positions = [
        {"stage": 1, "forces": [50.0, 1500.0], "fit_forces": [50.0, 1500.0], "edge": ""},
        {"stage": 1, "forces": [50.0, 1500.0], "fit_forces": [50.0, 400.0],
         "edge": "the pressure reaches the pinion flank edge from 1500 N"},
        {"stage": 2, "forces": [50.0, 5000.0], "fit_forces": [50.0, 5000.0], "edge": ""},
    ]
    (tmp_path / "mesh_cycle.json").write_text(json.dumps({"positions": positions}))
    rows = [line for line in _force_range_lines(tmp_path, demand) if line.startswith("| 1")
            or line.startswith("| 2")]
    assert rows[0] == "| 1 | 1000 | 1500 | 1.50 | 400-1500 | 1 of 2 |"
    assert rows[1].startswith("| 2 | 4000 | 5000 | 1.25 (short of the margin")


def test_calibration_report_says_when_the_flank_impacts_peak_below_the_fits(tmp_path):
    # a stage whose flank impacts' median peak (20 N) lies below the least fitted force
    # (50 N): the note names it with the law's secant stiffness at the nominal load over
    # the curve's, here built to be 1.25 (law F = 1e10 d^1.5 at 4 N, the curve's point
    # 1.25 times as compliant); a stage whose median lies above gets no note
    import json

    from fe_impact.calibration.report import _force_range_lines

    f, k, n = 4.0, 1e10, 1.5
    secant = f / (f / k) ** (1.0 / n)
    position = {"forces": [f, 50.0, 500.0], "fit_forces": [50.0, 500.0], "edge": "",
                "nominal_force": f, "nominal_stiffness": secant / 1.25, "stiffness": k,
                "exponent": n}
    positions = [{**position, "stage": 1}, {**position, "stage": 2}]
    (tmp_path / "mesh_cycle.json").write_text(json.dumps({"positions": positions}))
    demand = {"mesh_force_max_N": {"1": 300.0, "2": 300.0}, "force_margin": 1.5,
              "stages": {"1": {"mesh": {"force_median": 20.0}},
                         "2": {"mesh": {"force_median": 80.0}}}}
    (note,) = [line for line in _force_range_lines(tmp_path, demand)
               if line.startswith("The flank impacts")]
    assert "stage 1: median 20 N" in note and "1.25-1.25 times" in note
    assert "stage 2" not in note and "(50 N)" in note
    demand["stages"]["1"]["mesh"]["force_median"] = float("nan")   # an older cache
    assert not [line for line in _force_range_lines(tmp_path, demand)
                if line.startswith("The flank impacts")]


# -- a schedule against the gear set: unit mistakes -------------------------------------
def _duty(tmp_path, speed=300.0, load=0.1, name=None):
    top = "" if name is None else f'name = "{name}"\n'
    path = tmp_path / "my duty.toml"
    path.write_text(f"{top}[[segments]]\nstage = 1\nduration_s = 1\nspeed_rpm = {speed}\n"
                    f"load_Nm = {load}\n")
    return read_schedule(path)


def test_pitch_line_speed_bound_on_the_seed_pinion(tmp_path):
    # Seed pinion: 19 teeth, module 3 mm -> pitch radius 28.5 mm; 200 m/s there is
    # 200 / 0.0285 * 60 / (2 pi) = 67,013 r/min (by hand). 1000 r/min (the seed's top)
    # and 60,000 r/min run; 70,000 r/min and the seed's 300 r/min x 1000 are refused.
    from fe_impact.gears.gearset import default_gearset

    seed = default_gearset()
    for rpm in (1000.0, 60_000.0):
        _duty(tmp_path, speed=rpm).check_gearset(seed)
    for rpm in (70_000.0, 300_000.0):
        with pytest.raises(CaseError, match=r"speed_rpm = .*at most 6\.701e\+04 r/min"):
            _duty(tmp_path, speed=rpm).check_gearset(seed)


def test_load_bound_is_the_static_contact_strength(tmp_path):
    # The reported largest torque must give p0 = 1.6 sigma_Hlim at the pitch point when
    # computed directly: the message's number comes from Hertz's p0 ~ F^(1/3) scaling,
    # exact for a point contact of fixed curvatures (round-off: 1e-9). 200 N mm given as
    # 200,000 N m is refused; the seed's loads (below 1 N m) run.
    from fe_impact.gears.gearset import default_gearset
    from fe_impact.gears.report import pitch_point

    seed = default_gearset()
    _duty(tmp_path, load=1.0).check_gearset(seed)
    with pytest.raises(CaseError, match=r"load_Nm = 200000: .*ISO 6336-2") as err:
        _duty(tmp_path, load=200_000.0).check_gearset(seed)
    allowed = float(re.search(r"at most (\S+) N m", str(err.value)).group(1))
    p0 = pitch_point(seed, 1, allowed)[1]["pitch_point"]["max_pressure_Pa"]
    # the message gives 4 digits: p0 ~ T^(1/3) moves by a third of their 5e-4 rounding
    assert p0 == pytest.approx(1.6 * seed.material.contact_stress_limit, rel=2e-4)


def test_schedule_name_names_files_only(tmp_path):
    # A name with a folder or a space would put the result files elsewhere than --out;
    # a file's stem with a space becomes a valid default name.
    assert _duty(tmp_path).name == "my_duty"
    for bad in ("a/b", "..", "x y"):
        with pytest.raises(CaseError, match=r"name = .*no spaces or folders"):
            _duty(tmp_path, name=bad)


def test_switching_schedule_writes_what_the_guide_lists(tmp_path, capsys):
    # fe-impact switching --schedule end to end on the seed set (closed-form laws): every
    # file docs/guide/outputs.md lists is written and opens; the series follows the
    # schedule's stages (stage 1 to t = 0.1 s, then 2); a schedule has no seed table, so
    # no seed column beside the pitch-point-only laws.
    import csv
    import json

    from fe_impact.cli.main import main

    out = tmp_path / "out"
    assert main(["switching", "--schedule", str(_write(tmp_path, GOOD)), "--out", str(out),
                 "--sample-interval", "1e-3"]) == 0
    for name in ("report.md", "statistics.csv", "statistics.json", "climb_series.csv",
                 "climb_impacts.csv", "impacts.png", "impact_force.png"):
        assert (out / name).stat().st_size > 0, name
    json.loads((out / "statistics.json").read_text())
    with open(out / "climb_series.csv") as fh:
        rows = list(csv.DictReader(fh))
    t = np.array([float(r["time_s"]) for r in rows])
    stage = np.array([int(r["stage"]) for r in rows])
    assert t[0] == 0.0 and 0.25 - 1e-3 - 1e-12 <= t[-1] <= 0.25   # one sample interval
    assert set(stage[t < 0.099]) == {1} and set(stage[t > 0.101]) == {2}
    report = (out / "report.md").read_text()
    assert "## Schedule" in report and "| 1 | 0.1 | 2 (switch) |" in report
    assert "## Beside the pitch-point-only laws\n" in report
    assert "/ seed" not in report and "seed's tables" not in capsys.readouterr().err


def test_switching_impact_of_a_schedule_is_at_the_speed_of_the_switch(tmp_path):
    # A switch at the end of a speed ramp (200 -> 800 r/min on stage 1, under load so the
    # rings do not rattle): the report's rigid kinematics r_bp w_p |N_2/N_1 - 1| must take
    # the pinion's speed at the switch, 800 r/min, not the ramp's start (it took 200 and
    # gave a quarter of the model's closing speed). The model's first contact after the
    # switch closes at that rigid speed within 5% (measured 0.7% on the two-stage drive;
    # the web twist under load and the blend's first instants move it a little).
    import re

    from fe_impact.cli.main import main
    from fe_impact.gears import default_gearset
    from fe_impact.switching.model import DriveModel

    text = ("blend_s = 0.005\n[[segments]]\nstage = 1\nduration_s = 0.05\n"
            "speed_rpm = { from = 200, to = 800 }\nload_Nm = 20\n"
            "[[segments]]\nstage = 2\nduration_s = 0.02\nspeed_rpm = 800\nload_Nm = 20\n")
    path = tmp_path / "ramp_switch.toml"
    path.write_text(text)
    out = tmp_path / "out"
    assert main(["switching", "--schedule", str(path), "--out", str(out), "--no-baseline",
                 "--sample-interval", "1e-3"]) == 0
    report = (out / "report.md").read_text()
    row = re.search(r"\| ramp_switch \| [\d.]+ \| 1 -> 2 \| (\S+) \| (\S+) \| (\S+) \|", report)
    assert row, report
    rpm, model_speed, kinematic = (float(x) for x in row.groups())
    gearset = default_gearset()
    teeth = [s.teeth for s in gearset.stages]
    r_bp = DriveModel(gearset=gearset).geometry.base_radius
    expected = r_bp * 800.0 * math.pi / 30.0 * abs(teeth[1] / teeth[0] - 1.0) * 1e3  # mm/s
    assert rpm == 800.0
    assert kinematic == pytest.approx(expected, rel=1e-3)        # 4 digits printed
    assert model_speed == pytest.approx(kinematic, rel=0.05)


# -- the user guide's schedule page -------------------------------------------------------
GUIDE = Path(__file__).resolve().parents[1] / "docs" / "guide" / "schedule.md"


def _guide_blocks() -> dict[str, str]:
    """The guide's example schedule, its torque CSV, and its two blocks of messages."""
    import re

    text = GUIDE.read_text()
    blocks = re.findall(r"```(\w*)\n(.*?)```", text, re.S)
    toml = next(b for lang, b in blocks if lang == "toml")
    series = next(b for lang, b in blocks if b.startswith("time_s,load_Nm"))
    messages = [line for lang, b in blocks for line in b.splitlines()
                if line.startswith("duty.toml: ")]
    return {"toml": toml, "csv": series, "messages": messages}


def test_the_guides_example_runs_as_shipped(tmp_path):
    # The guide's duty.toml and torque.csv, as printed: read, then run for a short while on
    # the seed set (a switch from stage 1 to 2 at t = 1 s; 200 N m at most).
    from fe_impact.gears import default_gearset

    g = _guide_blocks()
    path = _write(tmp_path, g["toml"], g["csv"])
    duty = read_schedule(path)
    duty.check_gearset(default_gearset())
    assert [s.stage for s in duty.schedule.segments] == [1, 2, 2]
    assert duty.schedule.start_times[1] == 1.0 and duty.max_load == 200.0
    run = simulate(DriveModel(), duty.schedule.scaled(0.2), sample_interval=1e-3)
    assert len(run.events.select(kind="switch")) == 1


def test_the_guides_messages_are_the_readers(tmp_path):
    # Each message the guide prints under 'Checks' is the one the reader gives for the
    # mistake it describes, made in the guide's own example (seed gear set).
    from fe_impact.gears import default_gearset

    g = _guide_blocks()
    toml, series = g["toml"], g["csv"]
    mistakes = [
        (_replace(toml, "duration_s = 2.0", "duration_s = 0"), series),
        (_replace(toml, "load_Nm = { from = 200, to = 20 }",
                  "load_Nm = { from = 200, to = 20 }\nswitch = {}"), series),
        (toml, _replace(series, "1.2,160", "0.4,160")),
        (_replace(toml, "stage = 2\nduration_s = 1.0", "stage = 4\nduration_s = 1.0"), series),
        (_replace(toml, "load_Nm = 50", "load_Nm = 200000"), series),
    ]
    assert len(g["messages"]) == len(mistakes)
    for (text, csv_text), message in zip(mistakes, g["messages"], strict=True):
        folder = tmp_path / str(len(list(tmp_path.iterdir())))
        folder.mkdir()
        with pytest.raises(CaseError) as info:
            read_schedule(_write(folder, text, csv_text)).check_gearset(default_gearset())
        got = str(info.value).replace(f"{folder}/", "")
        assert got == message
