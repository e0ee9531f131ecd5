"""Calibration records: JSON and CSV round trips, standard JSON, checked reading."""

from __future__ import annotations

import copy
import csv
import dataclasses
import json
import math

import pytest

from fe_impact.calibration.records import (
    CSV_COLUMNS,
    SCHEMA,
    UNITS,
    Calibration,
    CalibrationRecord,
    ClosedForm,
    Difference,
    FEMeasurements,
    FitQuality,
    HysteresisChi,
    ImpactParameters,
    ModelInfo,
    RestitutionModels,
    read_calibration,
    read_record,
    write_calibration,
    write_calibration_csv,
    write_record,
)
from fe_impact.errors import CalibrationError


def _strict(text: str):
    """json.loads that refuses NaN and Infinity, which standard JSON does not have."""

    def refuse(name):
        raise ValueError(f"{name} is not standard JSON")

    return json.loads(text, parse_constant=refuse)


def _record(**changes) -> CalibrationRecord:
    """A complete record with the values of a default-level stage-1 case at 100 r/min,
    rounded; the closed-form cmax is 0 (restitution 1), so its relative difference is
    infinite."""
    rec = CalibrationRecord(
        stage=1, face_teeth=56, kind="mesh",
        restitution_models=RestitutionModels(
            v_y_eq15=0.0866, v_y_tooth=0.3116, yield_ratio_eq15=0.1447,
            yield_ratio_tooth=0.0402, seed_eq14=1.0, seed_eq14_tooth=1.0),
        speed_rpm=100.0, impact_speed=0.012529, effective_mass=0.22883,
        fe=FEMeasurements(
            peak_force=47.64, max_approach=8.62e-7, contact_time=2.12e-4, restitution=1.0,
            restitution_measured=1.00006, energy_lost=0.0, impact_velocity=0.0121,
            energy_error=7.5e-4, residual_indentation=0.0, stiffness_k=1.456e10,
            stiffness_exponent=1.4008, stiffness_fit_r2=0.9984, nominal_load=100.0,
            mesh_stiffness=None, mesh_stiffness_power_law=None),
        impact=ImpactParameters(1.349e10, 1.3955, 3.045, 1.724e-6),
        fit_quality=FitQuality(
            residual_force_rms=0.0092, restitution_model=0.9995, restitution_error=-5e-4,
            peak_force_error=-0.028, contact_time_error=7.6e-4, success=True,
            message="`ftol` termination condition is satisfied.", n_evaluations=317,
            start=(1.3e10, 1.4, 0.99, 4.2e-7), fe_force_max=47.64, fe_contact_time=2.05e-4,
            wall_time=0.151),
        closed_form=ClosedForm(k=6.602e10, exponent=1.5, cmax=0.0, d=8.34e-7,
                               delta_max=8.34e-7, force_max=50.3, contact_time=1.96e-4,
                               restitution=1.0),
        hysteresis_chi={"hunt-crossley": HysteresisChi(0.0, 1.0),
                        "flores": HysteresisChi(0.0, 1.0)},
        differences={"k": Difference(1.349e10, 6.602e10, -0.7957),
                     "cmax": Difference(3.045, 0.0, math.inf)},
        id="stage1_mesh_100rpm", hash="c6d1dbd4f6babd81",
        timings_s={"mesh": 5.04, "fe_setup": 46.6, "fe": 88.7, "fe_output": 8.86,
                   "fe_steps": 33.3, "fit": 0.25, "total": 94.3},
        initial_gap=4.13e-7,
        model=ModelInfo(n_dofs=135954, n_elements=29186, element_order=2,
                        integrator="newmark", time_step=3.23e-6, steps=92),
    )
    return dataclasses.replace(rec, **changes)


#: The keys a calibration case carried before the record type (measure_and_fit's dict
#: plus run_case's additions), in their order: the files keep them.
OLD_KEYS = ["stage", "face_teeth", "kind", "restitution_models", "speed_rpm",
            "impact_speed", "effective_mass", "fe", "impact", "fit_quality", "closed_form",
            "hysteresis_chi", "differences", "id", "hash", "timings_s", "initial_gap", "model"]
OLD_FE_KEYS = ["peak_force", "max_approach", "contact_time", "restitution",
               "restitution_measured", "energy_lost", "impact_velocity", "energy_error",
               "residual_indentation", "stiffness_k", "stiffness_exponent", "stiffness_fit_r2",
               "nominal_load", "mesh_stiffness", "mesh_stiffness_power_law"]
#: calibration.csv's header before the record type.
OLD_CSV_HEADER = ["id", "stage", "face_teeth", "kind", "speed_rpm", "impact_speed",
                  "effective_mass", "peak_force", "max_approach", "contact_time",
                  "restitution", "residual_indentation", "stiffness_k", "stiffness_exponent",
                  "mesh_stiffness", "k", "exponent", "cmax", "d", "closed_k",
                  "closed_exponent", "closed_cmax", "closed_d", "seconds"]


def test_record_json_round_trip_is_exact_and_standard(tmp_path):
    rec = _record()
    # not finite where null is allowed: held as None, as it is written
    assert rec.differences["cmax"].relative_difference is None
    path = write_record(tmp_path / "result.json", rec)
    data = _strict(path.read_text())
    assert data["differences"]["cmax"]["relative_difference"] is None
    # the old keys keep their place; the flank friction's come after them
    assert list(data) == [*OLD_KEYS, "friction", "companion"]
    assert list(data["fe"]) == [*OLD_FE_KEYS, "friction_dissipation"]
    assert read_record(path) == rec            # floats written with repr: read back bit for bit
    assert CalibrationRecord.from_dict(rec.to_dict()) == rec


def test_calibration_file_round_trip(tmp_path):
    cal = Calibration(cases=[_record(), _record(stage=2, face_teeth=68, id="s2")],
                      settings={"level": "coarse", "order": 2, "gap": None},
                      wall_time_s=12.5, fe_impact_version="0.2.1", notes="n")
    path = write_calibration(tmp_path / "calibration.json", cal)
    data = _strict(path.read_text())
    assert data["schema"] == SCHEMA and data["units"] == UNITS
    assert list(data) == ["schema", "fe_impact_version", "units", "settings", "wall_time_s",
                          "notes", "cases", "mesh_cycle", "friction"]
    assert read_calibration(path) == cal


def test_nan_in_a_required_field_is_refused_when_built_and_when_read(tmp_path):
    # A record is not built with a value it could not read back: null is written
    # for a value that is not finite, and reading refuses null where it is required.
    with pytest.raises(CalibrationError, match=r"ImpactParameters\.k = nan: must be a finite"):
        ImpactParameters(math.nan, 1.5, 1.0, 1e-6)
    data = _record().to_dict()
    data["impact"]["k"] = None
    path = tmp_path / "result.json"
    path.write_text(json.dumps(data))
    with pytest.raises(CalibrationError, match=r"result\.json: \[impact\] k = None: must be"):
        read_record(path)


def test_infinity_from_older_files_reads_as_none(tmp_path):
    data = _record().to_dict()
    text = json.dumps(data).replace('"relative_difference": null', '"relative_difference": '
                                    "Infinity")
    path = tmp_path / "old.json"
    path.write_text(text)
    assert read_record(path).differences["cmax"].relative_difference is None


def test_csv_columns_come_from_the_record(tmp_path):
    assert [name for name, _ in CSV_COLUMNS] == OLD_CSV_HEADER
    # every column is a field of the record (or of one of its sections)
    section = {f.name: f for f in dataclasses.fields(CalibrationRecord)}
    for _, path in CSV_COLUMNS:
        head, _, rest = path.partition(".")
        assert head in section, path
        kind = section[head].metadata["spec"]
        if rest and kind.kind == "section":
            assert rest in {f.name for f in dataclasses.fields(kind.options["type"])}, path
    recs = [_record(), _record(fe=None, id="bare")]
    path = write_calibration_csv(tmp_path / "calibration.csv", recs)
    rows = list(csv.reader(path.open()))
    assert rows[0] == OLD_CSV_HEADER
    row = dict(zip(rows[0], rows[1], strict=True))
    assert float(row["k"]) == recs[0].impact.k and float(row["seconds"]) == 94.3
    assert float(row["closed_cmax"]) == 0.0 and row["mesh_stiffness"] == ""
    assert dict(zip(rows[0], rows[2], strict=True))["peak_force"] == ""   # no fe section


def _doc(**case_changes):
    case = {"stage": 1, "kind": "mesh", "impact_speed": 0.05,
            "impact": {"k": 1e10, "exponent": 1.5, "cmax": 1.0, "d": 1e-6}}
    case.update(case_changes)
    return {"schema": SCHEMA, "cases": [case]}


def test_a_hand_written_law_table_is_a_calibration(tmp_path):
    path = tmp_path / "calibration.json"
    path.write_text(json.dumps(_doc(face_teeth=56, fe={"peak_force": 3.0})))
    cal = read_calibration(path, law_only=True)      # the lumped model's reading
    (rec,) = cal.cases
    assert rec.impact == ImpactParameters(1e10, 1.5, 1.0, 1e-6) and rec.fe is None
    # read in full, the partial fe section is refused, naming what is missing
    with pytest.raises(CalibrationError, match=r"missing key\(s\) \['contact_time', .*"
                                               r"in \[cases\[0\]\.fe\]"):
        read_calibration(path)


@pytest.mark.parametrize(("change", "message"), [
    ({"kind": "rattle"}, "[cases[0]] kind = 'rattle': pick one of ['mesh', 'switch', "
                         "'corner-approach', 'corner-recess']"),
    ({"stage": 0}, "[cases[0]] stage = 0: must be an integer >= 1"),
    ({"impact_speed": -0.1}, "[cases[0]] impact_speed = -0.1: must be > 0"),
    ({"speed": 1.0}, "unknown key(s) ['speed'] in [cases[0]]; allowed: ["),
    ({"impact": {"k": 1e10, "exponent": 1.5, "cmax": -1.0, "d": 1e-6}},
     "[cases[0].impact] cmax = -1.0: must be >= 0"),
    ({"impact": {"k": 1e10, "exponent": 1.5, "cmax": 1.0}},
     "missing key(s) ['d'] in [cases[0].impact]"),
    ({"model": {**_record().to_dict()["model"], "element_order": 3}},
     "[cases[0].model] element_order = 3: must be an integer in 1..2"),
    ({"hysteresis_chi": {"flores": {"chi": "0.1", "restitution": 0.9}}},
     "[cases[0].hysteresis_chi.flores] chi = '0.1': must be a number"),
    ({"timings_s": {"total": -1.0}}, "[cases[0].timings_s] total = -1.0: must be >= 0"),
])
def test_reading_rejects_a_bad_value_naming_the_key(tmp_path, change, message):
    path = tmp_path / "calibration.json"
    path.write_text(json.dumps(_doc(**change)))
    with pytest.raises(CalibrationError) as info:
        read_calibration(path)
    assert str(info.value).startswith(f"{path}: ")
    assert message in str(info.value)


@pytest.mark.parametrize(("mutate", "message"), [
    (lambda d: d.update(schema="fe-impact/calibration/0"),
     "schema = 'fe-impact/calibration/0': expected 'fe-impact/calibration/2' (or the older "
     "'fe-impact/calibration/1')"),
    (lambda d: d.update(cases=[]), "cases = []: must be a non-empty list of objects"),
    (lambda d: d.update(extra=1), "unknown key(s) ['extra'] at the top level"),
])
def test_reading_rejects_a_bad_document(tmp_path, mutate, message):
    data = copy.deepcopy(_doc())
    mutate(data)
    path = tmp_path / "calibration.json"
    path.write_text(json.dumps(data))
    with pytest.raises(CalibrationError) as info:
        read_calibration(path)
    assert message in str(info.value)


LAW = {"roll_angle_deg": [-14.6, 2.1, 18.7], "k": [1.8e9, 8.5e9, 5.5e9],
       "exponent": [1.26, 1.36, 1.37]}


def test_the_position_law_is_read_and_the_older_schema_still_is(tmp_path):
    path = tmp_path / "calibration.json"
    path.write_text(json.dumps({**_doc(), "mesh_cycle": {"1": LAW}}))
    cal = read_calibration(path, law_only=True)
    assert cal.schema == SCHEMA and cal.mesh_cycle["1"]["k"] == LAW["k"]
    corners = {"recess": {"k": 4.0e9, "exponent": 1.37, "roll_angle_deg": -16.0}}
    path.write_text(json.dumps({**_doc(), "mesh_cycle": {"1": {**LAW, "corners": corners}}}))
    cal = read_calibration(path, law_only=True)
    assert cal.mesh_cycle["1"]["corners"] == corners
    path.write_text(json.dumps({**_doc(), "schema": "fe-impact/calibration/1"}))
    old = read_calibration(path, law_only=True)
    assert old.schema == "fe-impact/calibration/1" and old.mesh_cycle is None


@pytest.mark.parametrize(("law", "message"), [
    ({**LAW, "k": [1.0, 2.0]}, "[mesh_cycle.1] k = [1.0, 2.0]: must be a list of three numbers"),
    ({**LAW, "roll_angle_deg": [2.0, 1.0, 3.0]},
     "[mesh_cycle.1] roll_angle_deg = [2.0, 1.0, 3.0]: must hold two or more rising angles"),
    ({**LAW, "exponent": [1.0, 0.0, 1.0]},
     "[mesh_cycle.1] exponent = [1.0, 0.0, 1.0]: must be positive"),
    ({**LAW, "corners": {"tip": {"k": 1e9, "exponent": 1.3}}},
     "[mesh_cycle.1.corners] tip = '...': corner sides are 'approach' and 'recess'"),
    ({**LAW, "corners": {"recess": {"k": -1e9, "exponent": 1.3}}},
     "[mesh_cycle.1.corners.recess] k = -1000000000.0: must be a positive number"),
    ({**LAW, "corners": {"approach": {"k": 1e9}}},
     "[mesh_cycle.1.corners.approach] exponent = None: must be a positive number"),
])
def test_a_bad_position_law_is_refused_naming_the_key(tmp_path, law, message):
    path = tmp_path / "calibration.json"
    path.write_text(json.dumps({**_doc(), "mesh_cycle": {"1": law}}))
    with pytest.raises(CalibrationError) as info:
        read_calibration(path, law_only=True)
    assert message in str(info.value)
