"""The shipped drives under geometry/ and face-gear sets across the design ranges.

Truths: the face-gear limits searched for independently on the generated surface
(validation/face_gear_limits.py: the shaper and the generating motion from their
definitions, the meshing equation solved numerically; none of the package's face-gear
code), the drives' files (their published numbers and their comments' tables), the
Hertz law ``a ~ F^(1/3)`` and the exact radius of points on the contact ellipse.
"""

from __future__ import annotations

import copy
import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from fe_impact.cli.main import main
from fe_impact.errors import GeometryError
from fe_impact.gears import default_gearset_path, gearset_from_dict, load_gearset
from fe_impact.gears.report import ELLIPSE_EDGES, ellipse_edges, pitch_point
from validation import face_gear_limits as independent

GEOMETRY = Path(__file__).resolve().parents[1] / "geometry"
DRIVES = ("nasa-25deg", "two-stage", "split-torque-4")


def _drive(name: str) -> Path:
    return GEOMETRY / f"{name}.toml"


def test_the_drives_are_shipped_and_the_seed_is_one_file():
    """Three drives beside the packaged seed, and no second copy of the seed."""
    assert sorted(p.stem for p in GEOMETRY.glob("*.toml")) == sorted(DRIVES)
    assert default_gearset_path().parent.name == "gears"
    kinds = {name: load_gearset(_drive(name)) for name in DRIVES}
    nasa, two, split = kinds["nasa-25deg"], kinds["two-stage"], kinds["split-torque-4"]
    # the published proportions (NASA face-gear tests): 28/107 teeth, 8 1/in, 25 deg
    assert (nasa.pinion.teeth, nasa.stages[0].teeth) == (28, 107)
    assert nasa.module == pytest.approx(25.4e-3 / 8, rel=1e-15)
    assert nasa.pinion.pressure_angle_deg == 25.0 and len(nasa.stages) == 1
    assert len(two.stages) == 2 and split.n_pinions == 4


# -- limits against the independent search ----------------------------------------------------
def test_limits_agree_with_an_independent_search_on_a_coarse_grid():
    """validation/face_gear_limits.py --quick: six designs over the ranges, both kinds of
    inner limit (the conjugate-tip limit absent on three), each limit within 1e-7 r_2
    (the study's tolerance, set from its numerical steps; the full grid: one command)."""
    result = independent.run(quick=True)
    checks = independent.check(result)
    assert len(checks) == 3 * len(independent.QUICK)
    assert all(c.passed for c in checks), [c.line() for c in checks if not c.passed]
    assert sum(r["conjugate_m"] is None for r in result["rows"]) == 3


@pytest.fixture(scope="module")
def reports(tmp_path_factory):
    """``fe-impact geometry DRIVE --torque 200 --json`` of each drive."""
    out = {}
    for name in DRIVES:
        path = tmp_path_factory.mktemp(name) / "geometry.json"
        assert main(["geometry", str(_drive(name)), "--torque", "200", "--json",
                     str(path)]) == 0
        out[name] = json.loads(path.read_text())
    return out


@pytest.mark.parametrize("name", DRIVES)
def test_geometry_reports_the_limit_that_governs(reports, name):
    """The governing inner limit is the larger of the independent undercut and
    conjugate-tip limits (the NASA drive has no conjugate-tip limit; the two-stage
    drive's rings have one each way), and the chosen radii lie inside the limits."""
    gearset = load_gearset(_drive(name))
    for stage, row in zip(gearset.stages, reports[name]["stages"], strict=True):
        d = independent.Design(stage.teeth, stage.shaper_teeth, gearset.module,
                               gearset.pinion.pressure_angle_deg)
        undercut, conjugate = independent.undercut_limit(d), independent.conjugate_limit(d)
        fw = row["face_width"]
        governs = "undercut" if conjugate is None or undercut > conjugate else "conjugate tip"
        assert fw["inner_limit_governing"] == governs
        assert (fw["inner_conjugate_limit_m"] is None) == (conjugate is None)
        assert fw["inner_undercut_limit_m"] <= stage.inner_radius
        assert fw["inner_margin_m"] >= 0.0 and fw["outer_margin_m"] >= 0.0
        if conjugate is None:
            assert "does not exist" in fw["inner_limit_reason"]
    governing = [r["face_width"]["inner_limit_governing"]
                 for r in reports["two-stage"]["stages"]]
    assert name != "two-stage" or governing == ["undercut", "conjugate tip"]


@pytest.mark.parametrize("name", DRIVES)
def test_contact_stress_against_the_allowable(reports, name):
    """p0 at 200 N m against the file's sigma_Hlim, 1500 MPa; p0 from the reported
    ellipse, 3 F / (2 pi a b) (Hertz)."""
    for row in reports[name]["stages"]:
        pp = row["pitch_point"]
        assert pp["contact_stress_limit_Pa"] == 1500e6
        p0 = 3.0 * pp["normal_force_N"] / (2.0 * math.pi * pp["a_m"] * pp["b_m"])
        assert pp["max_pressure_Pa"] == pytest.approx(p0, rel=1e-9)
        assert pp["contact_stress_ratio"] == pytest.approx(p0 / 1500e6, rel=1e-9)
        assert pp["ellipse_nearest_edge"] in ELLIPSE_EDGES


def test_ellipse_overhang_against_the_exact_radius_of_its_points():
    """The face-gear inner end of the NASA drive with its face moved out to 165 mm (the
    contact at r_2 = 169.863 mm): how far the Hertz ellipse reaches past it, computed
    exactly from 7200 points of its boundary (each point's distance from the face-gear
    axis), against the report's linearised reach. The linearisation leaves out the
    radius' curvature, at most a^2 / (2 L); and ``reach`` grows as F^(1/3)."""
    data = tomllib.loads(_drive("nasa-25deg").read_text())
    data["face_gear"]["stages"][0]["inner_radius_mm"] = 165.0
    gearset = gearset_from_dict(data)
    for torque in (200.0, 2000.0, 6000.0):
        pair, rows = pitch_point(gearset, 1, torque)
        contact, pp = rows["_contact"], rows["pitch_point"]
        a, b = pp["a_m"], pp["b_m"]
        t = np.linspace(0.0, 2.0 * np.pi, 7200, endpoint=False)
        ring = (np.asarray(contact.point)[None, :]
                + a * np.cos(t)[:, None] * np.asarray(contact.relative.major)[None, :]
                + b * np.sin(t)[:, None] * np.asarray(contact.relative.minor)[None, :])
        ring = ring @ pair.face_rotation(contact.face_angle)   # to the face gear's frame
        exact = 0.165 - np.hypot(ring[:, 0], ring[:, 2]).min()
        linear = ellipse_edges(pair, contact, a, b)["face-gear inner end"]
        radius = float(np.hypot(contact.point[0], contact.point[2]))
        # sampling: 2 pi / 7200 of arc leaves (pi a / 7200)^2 / (2 a) of the extreme
        assert abs(linear - exact) <= a**2 / (2.0 * radius) + a * 1e-6
        assert pp["ellipse_overhang_m"]["face-gear inner end"] == pytest.approx(linear)
    # 6000 N m reaches past 165 mm, 200 N m does not
    assert pp["ellipse_nearest_edge"] == "face-gear inner end" and pp["ellipse_past_edge_m"] > 0


# -- refusals --------------------------------------------------------------------------------
@pytest.fixture
def nasa_data():
    return tomllib.loads(_drive("nasa-25deg").read_text())


def _set(path, value):
    def mutate(data):
        node = data
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
    return mutate


STAGE = ("face_gear", "stages", 0)
RANGES = {
    "pressure angle 17": ([_set(("pinion", "pressure_angle_deg"), 17.0)],
                          ["[pinion] pressure_angle_deg = 17 deg", "[18, 30] deg"]),
    "pressure angle 31": ([_set(("pinion", "pressure_angle_deg"), 31.0)],
                          ["[pinion] pressure_angle_deg = 31 deg", "[18, 30] deg"]),
    "module 0.5": ([_set(("pinion", "module_mm"), 0.5), _set(("face_gear", "module_mm"), 0.5)],
                   ["[pinion] module_mm = 0.5 mm", "[1, 10] mm"]),
    "module 12": ([_set(("pinion", "module_mm"), 12.0), _set(("face_gear", "module_mm"), 12.0)],
                  ["[pinion] module_mm = 12 mm", "[1, 10] mm"]),
    "pinion teeth 41": ([_set(("pinion", "teeth"), 41)], ["[pinion] teeth = 41", "12..40"]),
    "pinion teeth 11": ([_set(("pinion", "teeth"), 11)], ["[pinion] teeth = 11", "12..40"]),
    "five pinions": ([_set(("n_pinions",), 5)], ["n_pinions = 5", "1..4"]),
    "six stages": ([lambda d: d["face_gear"]["stages"].extend(
        copy.deepcopy(d["face_gear"]["stages"][0]) for _ in range(5))],
        ["6 stages given, at most 5"]),
    "shaper N_p + 4": ([_set((*STAGE, "shaper_teeth"), 32)],
                       ["shaper_teeth = 32", "[29, 31]", "force_shaper"]),
    # the face width: the governing limit named, the usable range from it
    "inner radius below the undercut limit": (
        [_set((*STAGE, "inner_radius_mm"), 157.0)],
        ["inner_radius_mm = 157.000 mm is below the inner limit",
         "raise it to at least 157.408 mm", "undercut limit 157.408 mm governs",
         "conjugate-tip limit does not exist", "usable [157.408, 189.654] mm"]),
    "outer radius past pointing": (
        [_set((*STAGE, "outer_radius_mm"), 190.0)],
        ["outer_radius_mm = 190.000 mm", "lower it to at most 189.654 mm"]),
    # a face gear too small for its shaper: the usable face lies outside r_2
    # (20 deg, a 19-tooth pinion and a 21-tooth shaper: the undercut limit falls below
    # r_2 from 34 face-gear teeth on, 0.998 r_2 there, 1.006 r_2 at 30)
    "too few face-gear teeth": (
        [_set(("pinion", "pressure_angle_deg"), 20.0), _set(("pinion", "teeth"), 19),
         _set(("pinion", "fillet_radius_coeff"), 0.38), _set((*STAGE, "teeth"), 30),
         _set((*STAGE, "shaper_teeth"), 21), _set((*STAGE, "inner_radius_mm"), 45.0),
         _set((*STAGE, "outer_radius_mm"), 55.0)],
        ["stage 1 (30 teeth)", "does not hold the pitch radius 47.625 mm",
         "give it at least 33 teeth"]),
    "pinion undercut": (
        [_set(("pinion", "pressure_angle_deg"), 18.0), _set(("pinion", "teeth"), 14),
         _set((*STAGE, "shaper_teeth"), 16)],
        ["[pinion] teeth = 14 must be >= ", "raise pressure_angle_deg to >="]),
}


@pytest.mark.parametrize("case", list(RANGES))
def test_a_set_outside_the_ranges_is_refused_in_one_line(nasa_data, case):
    mutators, fragments = RANGES[case]
    for mutate in mutators:
        mutate(nasa_data)
    with pytest.raises(GeometryError) as info:
        gearset_from_dict(nasa_data)
    message = str(info.value)
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, message


def test_the_advised_face_gear_teeth_are_accepted(nasa_data):
    """"give it at least 33 teeth" (the case above): 33 accepted, 32 refused."""
    for mutate in RANGES["too few face-gear teeth"][0]:
        mutate(nasa_data)
    for teeth, ok in ((33, True), (32, False)):
        # 33 teeth: r_2 52.3875 mm, the undercut limit 52.384 mm
        nasa_data["face_gear"]["stages"][0].update(teeth=teeth, inner_radius_mm=52.386,
                                                   outer_radius_mm=60.0)
        if ok:
            assert gearset_from_dict(nasa_data).stages[0].teeth == 33
        else:
            with pytest.raises(GeometryError, match="does not hold the pitch radius"):
                gearset_from_dict(nasa_data)


@pytest.mark.parametrize("angle, teeth, clearance", [(18.0, 40, 0.25), (30.0, 12, 0.1),
                                                     (25.0, 28, 0.25)])
def test_the_range_corners_are_accepted(nasa_data, angle, teeth, clearance):
    """A pinion at the ranges' corners with a face gear whose face is the usable width
    around r_2: accepted (18 deg takes the 40-tooth pinion, 30 deg the 12-tooth one; there
    the shaper, cutting (1 + c*) m deep, keeps a tip land with c* = 0.1, not 0.25)."""
    from fe_impact.gears import face_gear_limits
    from fe_impact.gears.pinion import max_fillet_radius_coeff

    n2, m = 4 * teeth, 1e-3 if angle == 18.0 else 10e-3
    lim = face_gear_limits(n2, teeth + 2, m, angle, 1.0, clearance)
    nasa_data["pinion"].update(teeth=teeth, pressure_angle_deg=angle, module_mm=m * 1e3,
                               clearance_coeff=clearance, face_width_mm=8 * m * 1e3,
                               fillet_radius_coeff=0.9 * max_fillet_radius_coeff(
                                   angle, 1.0, clearance), lengthwise_crowning_um=0.0)
    nasa_data["face_gear"]["module_mm"] = m * 1e3
    nasa_data["face_gear"]["stages"][0].update(
        teeth=n2, shaper_teeth=teeth + 2, inner_radius_mm=lim.inner() * 1e3 + 0.01,
        outer_radius_mm=lim.outer_pointing * 1e3 - 0.3 * m * 1e3)
    nasa_data["face_gear"]["tip_edge_radius_mm"] = 0.0
    gearset = gearset_from_dict(nasa_data)
    assert gearset.stages[0].teeth == n2


# -- the commands on each drive (slow: Gmsh and an FE impact) ---------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("name", DRIVES)
def test_mesh_on_each_drive(tmp_path, name):
    """``fe-impact mesh DRIVE --level coarse``: the tooth pair at the pitch point."""
    assert main(["mesh", str(_drive(name)), "--level", "coarse", "--out", str(tmp_path),
                 "--no-picture"]) == 0
    assert (tmp_path / "pair.msh").stat().st_size > 0
    tca = json.loads((tmp_path / "tca.json").read_text())
    assert tca


@pytest.mark.slow
@pytest.mark.parametrize("name", DRIVES)
def test_calibrate_coarse_on_each_drive(tmp_path, name):
    """``fe-impact calibrate DRIVE --level coarse`` as cheap as it stays a calibration:
    stage 1, one impact speed, no mesh cycle, no switching studies, no preset speeds.
    The fitted law is a contact law: exponent between bending's 1 and Hertz's 1.5."""
    argv = ["calibrate", str(_drive(name)), "--level", "coarse", "--stages", "1",
            "--impact-speeds", "0.05", "--no-mesh-cycle", "--no-switching",
            "--no-preset-speeds", "--workers", "1", "--out", str(tmp_path / "out"),
            "--cache", str(tmp_path / "cache")]
    assert main(argv) == 0
    data = json.loads((tmp_path / "out" / "calibration.json").read_text())
    text = json.dumps(data)
    assert "exponent" in text
    exponents = [float(v) for v in _values(data, "exponent")]
    assert exponents and all(1.0 <= e <= 1.6 for e in exponents), exponents


def _values(node, key):
    """Every value of ``key`` anywhere in a JSON tree."""
    if isinstance(node, dict):
        for k, v in node.items():
            if k == key and isinstance(v, int | float):
                yield v
            else:
                yield from _values(v, key)
    elif isinstance(node, list):
        for v in node:
            yield from _values(v, key)


# -- edge loading in the mesh cycle ---------------------------------------------------------------
def test_an_edge_loaded_position_fits_the_law_to_the_steps_without_it():
    """A curve that follows F = K delta^1.5 (Hertz) up to 200 N, then runs onto the
    pinion's flank edge and stiffens: the law is fitted to the clean steps alone and
    gives back K and 1.5 exactly; the note names the edge, the force and the fit."""
    from fe_impact.calibration.meshcycle import edge_note, fit_power_law, fit_steps

    k, forces = 2e10, np.array([5.0, 50.0, 100.0, 200.0, 500.0, 1000.0])
    approach = (forces / k) ** (1 / 1.5)
    approach[4:] = approach[3] + (forces[4:] - forces[3]) / 5e9   # edge: linear, stiffer
    edges = ["", "", "", "", "pinion flank edge", "pinion flank edge"]
    fitted = fit_steps(forces, edges)
    assert fitted.tolist() == [False, True, True, True, False, False]
    K, e, err = fit_power_law(forces[fitted], approach[fitted])
    assert e == pytest.approx(1.5, rel=1e-12) and K == pytest.approx(k, rel=1e-9)
    whole = fit_power_law(forces[forces >= 50], approach[forces >= 50])
    assert whole[2] > 0.05            # fitted through the edge, the law misses by > 5%
    note = edge_note(forces, edges, fitted, err, {"pinion outer face end": 1.2e-3,
                                                  "face-gear tip": -1e-4})
    assert "\n" not in note
    for part in ("pinion flank edge from 500 N", "fitted to the 3 steps 50-200 N",
                 "fit error 0.0%", "past the pinion outer face end by 1.2 mm"):
        assert part in note, note
    assert "face-gear tip" not in note
    # every fitted step on the edge: all kept, and said so
    all_edge = fit_steps(forces, ["", "x", "x", "x", "x", "x"])
    assert all_edge.tolist() == [False, True, True, True, True, True]
    assert "every one with edge loading" in edge_note(forces, ["", "x", "x", "x", "x", "x"],
                                                      all_edge, 0.1, {})
    assert edge_note(forces, [""] * 6, fitted, 0.0, {"pinion tip": -1e-3}) == ""


def test_the_cycle_curves_leave_out_non_positive_approaches_without_a_warning():
    """An end position whose smallest force closes less than the gap to the contact
    point (it first touches at an edge): no numpy warning, the point left out."""
    import warnings

    from fe_impact.calibration.meshcycle import PositionRecord, pair_force

    forces = [5.0, 50.0, 100.0, 200.0]
    approach = [-2e-8, 1e-6, 1.6e-6, 2.5e-6]
    record = PositionRecord(
        id="p", stage=1, roll_angle_deg=0.0, end="last", forces=forces,
        approaches=approach, torques=[0.0] * 4, rotations=[0.0] * 4,
        contact_areas=[0.0] * 4, max_pressures=[0.0] * 4, hertz_approaches=[0.0] * 4,
        stiffness=1.0, exponent=1.0, fit_error=0.0, nominal_force=5.0,
        nominal_stiffness=1.0, lever=0.03, edge="", ellipse_outline=[], footprint=[],
        flank_edges=[], n_dofs=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        force, _ = pair_force(record, 1.6e-6)
    assert force == pytest.approx(100.0, rel=1e-12)
