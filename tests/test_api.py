"""The Python API's own contract: what a script gets, and one clear error for bad input.

The numbers behind these calls are tested where they are computed (and in
tests/test_examples.py through the examples); here: the readers, the options
a script passes, and that refusals come before any work, as
:class:`~fe_impact.errors.FeImpactError` subclasses with one line naming the
option, the value and what is allowed.
"""

from __future__ import annotations

import pytest

import fe_impact
from fe_impact.errors import CalibrationError, CaseError, FeImpactError, GeometryError


def test_readers_and_defaults():
    seed = fe_impact.default_gearset()
    assert fe_impact.read_gearset() == seed and len(seed.stages) == 3
    assert {"table1", "variable-load", "table4-500Nmm"} <= set(fe_impact.presets())
    # the studies a calibration of some stages has laws for (Table 1 engages
    # stage 1, Tables 2 and 4 stage 2, Table 3 stage 3, the switching runs all)
    assert fe_impact.seed_studies(seed, [2]) == ("table2", "table4")


@pytest.mark.parametrize(("options", "error", "words"), [
    ({"workers": 0}, CalibrationError, "--workers 0: must be at least 1"),
    ({"level": "huge"}, CalibrationError, "--level 'huge': pick one of coarse"),
    ({"integrator": "rk4"}, CalibrationError, "--integrator 'rk4'"),
    ({"stages": [4]}, CalibrationError, "--stages [4]: the gear set has stages 1..3"),
    ({"mesh_cycle": False, "positions": 5}, CalibrationError,
     "--positions and --no-mesh-cycle"),
    ({"mesh_cycle": False, "corners": True}, CalibrationError, "--corners and --no-mesh-cycle"),
])
def test_calibrate_refuses_bad_options_before_any_work(tmp_path, options, error, words):
    out = tmp_path / "cal"
    with pytest.raises(error, match=None) as info:
        fe_impact.calibrate(out=out, cache=tmp_path / "cache", **options)
    assert words in str(info.value) and "\n" not in str(info.value)
    assert not (out / "calibration.json").exists()


def test_solve_refuses_a_frame_cap_below_two(tmp_path):
    with pytest.raises(FeImpactError, match="--max-frames 1: must be at least 2"):
        fe_impact.solve(tmp_path / "no_case.toml", max_frames=1)


def test_solve_names_a_missing_case_file(tmp_path):
    with pytest.raises(CaseError, match="no_case.toml"):
        fe_impact.solve(tmp_path / "no_case.toml")


def test_geometry_report_refuses_a_bad_torque():
    with pytest.raises(GeometryError, match="torque = -1 N m: must be a number > 0"):
        fe_impact.geometry_report(torque=-1.0)


def test_mesh_pair_names_the_stages_of_the_gear_set(tmp_path):
    with pytest.raises(GeometryError, match="--stage 5: gear set .* has stages 1..3"):
        fe_impact.mesh_pair(stage=5, out=tmp_path / "pair")
    assert not (tmp_path / "pair").exists()


def test_a_schedule_is_checked_against_the_gear_set(tmp_path):
    path = tmp_path / "climb.toml"
    path.write_text('schema = "fe-impact/schedule/1"\n'
                    "[[segments]]\nstage = 4\nduration_s = 1\nspeed_rpm = 300\nload_Nm = 0\n")
    with pytest.raises(CaseError, match=r"stage = 4: the gear set .* has stages 1..3"):
        fe_impact.study_preset(path)
    # a preset's name, a preset and the scaled duration
    preset = fe_impact.api.study_preset("variable-speed", duration=1.5)
    assert preset.name == "variable-speed"
    assert preset.duration == pytest.approx(1.5)
    assert fe_impact.api.study_preset(preset) is preset


def test_simulate_switching_takes_one_case(tmp_path):
    with pytest.raises(FeImpactError, match="'table1': has 3 cases; give one of them"):
        fe_impact.simulate_switching("table1")
