"""``fe-impact geometry`` and :func:`fe_impact.gears.report.stage_geometry`.

Truths: the seed file's comments (fe_impact/gears/seed.toml: the limits table, the
rounding rules of the chosen radii, the clearances), closed forms of a spur pinion
on a rack (the face gear at its pitch radius: the line of action of Litvin &
Fuentes, *Gear Geometry and Applied Theory*, 2004, ch. 10), the involute and the
crowning parabola, and the Hertz closed forms of :mod:`fe_impact.physics.hertz`
(Johnson 1985) evaluated here on the reported curvatures.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re

import pytest

from fe_impact.atomic import standard_json
from fe_impact.cli.main import main
from fe_impact.gears import default_gearset
from fe_impact.gears.gearset import default_gearset_path
from fe_impact.gears.report import ROLL_TOLERANCE, TOP_LAND_MIN, stage_geometry
from fe_impact.physics import hertz

SEED = default_gearset_path()


@pytest.fixture(scope="module")
def gearset():
    return default_gearset()


@pytest.fixture(scope="module")
def rows(gearset):
    from fe_impact.switching.presets import seed_load_torque

    return stage_geometry(gearset, seed_load_torque())


def _seed_limits_table() -> dict[int, tuple[float, ...]]:
    """The seed file's comment table: teeth -> (r_2, undercut, conjugate tip, pointing) [mm]."""
    table = {}
    for line in SEED.read_text(encoding="utf-8").splitlines():
        m = re.fullmatch(r"#\s+(\d+)\s+([\d.]+)\s+([\d.]+)\s+([\d.]+)\s+([\d.]+)\s*", line)
        if m:
            table[int(m[1])] = tuple(float(v) for v in m.groups()[1:])
    return table


# -- face width --------------------------------------------------------------------------
def test_radii_limits_agree_with_the_seed_file_comments(rows):
    """The comments print the limits to 0.001 mm: agreement to half of that."""
    table = _seed_limits_table()
    assert sorted(table) == [56, 68, 80]
    for row in rows:
        fw = row["face_width"]
        mm = [fw[k] * 1e3 for k in ("pitch_radius_m", "inner_undercut_limit_m",
                                    "inner_conjugate_limit_m", "outer_pointing_limit_m")]
        assert mm == pytest.approx(table[row["teeth"]], abs=5e-4 + 1e-9)


def test_chosen_radii_follow_the_seed_file_rules(rows):
    """seed.toml: inner = conjugate-tip limit rounded up to 0.5 mm; outer = radius of a
    0.2 mm top land rounded down to 0.5 mm (96.0, 116.5, 137.0 mm); stage 2's outer
    radius 1.18 mm inside its pointing limit; clearances 4.0 mm (rings 56-68) and
    1.0 mm (68-80); full usable widths would overlap by 0.29 mm, or 2.76 mm with the
    undercut limit. Comments are rounded as printed there."""
    fw = [r["face_width"] for r in rows]
    for f in fw:
        assert f["inner_radius_m"] * 1e3 == pytest.approx(
            math.ceil(f["inner_conjugate_limit_m"] * 2e3) / 2, abs=1e-9)
        assert f["outer_radius_m"] * 1e3 == pytest.approx(
            math.floor(f["radius_at_top_land_min_m"] * 2e3) / 2, abs=1e-9)
        # the outer radius lies inside the 0.2 mm land radius: its land is wider
        assert f["top_land_at_outer_radius_m"] > TOP_LAND_MIN
    assert [f["outer_radius_m"] * 1e3 for f in fw] == pytest.approx([96.0, 116.5, 137.0])
    assert fw[1]["outer_margin_m"] * 1e3 == pytest.approx(1.18, abs=5e-3)
    assert [f["clearance_to_next_ring_m"] for f in fw[:2]] == pytest.approx([4.0e-3, 1.0e-3])
    assert fw[2]["clearance_to_next_ring_m"] is None
    overlap = fw[1]["outer_pointing_limit_m"] - fw[2]["inner_conjugate_limit_m"]
    assert overlap * 1e3 == pytest.approx(0.29, abs=5e-3)
    overlap = fw[1]["outer_pointing_limit_m"] - fw[2]["inner_undercut_limit_m"]
    assert overlap * 1e3 == pytest.approx(2.76, abs=5e-3)


# -- path of contact -----------------------------------------------------------------------
def test_contact_ratio_is_the_path_over_the_angular_pitch(rows, gearset):
    """The ratio equals the roll-angle path length over 360/N_p degrees, and the ends
    are those of a pinion on a rack (the face gear at L = r_2): the last point at the
    pinion tip, roll -(sqrt((r_a/r_b)^2 - 1) - tan a); the first where the face-gear
    tip (depth ha m) or the pinion's form circle (the generating rack's straight
    flank ends at depth (ha + c - rho (1 - sin a)) m) cuts the line of action,
    roll depth / (r_b sin a), the nearer to 0 of the two. Tolerance: the bisection
    bracket ROLL_TOLERANCE plus the TCA's Newton (1e-13 module)."""
    p = gearset.pinion
    a = math.radians(p.pressure_angle_deg)
    r_b, r_a = p.pitch_radius * math.cos(a), p.pitch_radius + p.addendum_coeff * p.module
    last = -(math.sqrt((r_a / r_b) ** 2 - 1.0) - math.tan(a))
    tip_depth = p.addendum_coeff * p.module
    form_depth = (p.addendum_coeff + p.clearance_coeff
                  - p.fillet_radius_coeff * (1.0 - math.sin(a))) * p.module
    first = min(tip_depth, form_depth) / (r_b * math.sin(a))
    for row in rows:
        path = row["path_of_contact"]
        span_deg = math.degrees(path["first_roll_rad"] - path["last_roll_rad"])
        assert path["contact_ratio"] == pytest.approx(span_deg / (360.0 / p.teeth), rel=1e-12)
        assert path["first_roll_rad"] == pytest.approx(first, abs=2 * ROLL_TOLERANCE)
        assert path["last_roll_rad"] == pytest.approx(last, abs=2 * ROLL_TOLERANCE)
        assert path["last_limit"] == "pinion tip"
        assert path["first_limit"] == ("pinion form circle" if form_depth < tip_depth
                                       else "face-gear tip")
        assert path["first_margins_m"][path["first_limit"]] == pytest.approx(0.0, abs=1e-9)
    # The textbook rack ratio (face-gear tip to pinion tip) differs only by the
    # sliver between form circle and face-gear tip: here 0.03 um of depth.
    textbook = (math.sqrt(r_a**2 - r_b**2) - p.pitch_radius * math.sin(a)
                + tip_depth / math.sin(a)) / (math.pi * p.module * math.cos(a))
    assert rows[0]["path_of_contact"]["contact_ratio"] == pytest.approx(textbook, rel=1e-4)


# -- pitch point ---------------------------------------------------------------------------
def test_hertz_numbers_are_the_closed_forms_of_the_printed_curvatures(rows, gearset):
    """Ellipse, pressure and approach from hertz.ellipse_contact on R = 1/lambda (same
    function, round-off); the relative curvature's trace is the sum of the four
    principal curvatures (both tangent planes are one at the contact: Euler's
    formula); the pinion's curvatures are the involute's 1/(r_p sin a) and the
    crowning parabola's 2c/(b/2)^2 (finite differences of 10 um: 1e-4 1/m)."""
    m = gearset.material
    e_star = hertz.effective_modulus(m.youngs_modulus, m.poisson_ratio)
    p = gearset.pinion
    a = math.radians(p.pressure_angle_deg)
    for row in rows:
        pp = row["pitch_point"]
        assert pp["effective_modulus_Pa"] == pytest.approx(e_star, rel=1e-14)
        lam = pp["relative_curvatures_1_m"]
        c = hertz.ellipse_contact(pp["normal_force_N"], 1.0 / lam[0], 1.0 / lam[1], e_star)
        for key, value in (("a_m", c.a), ("b_m", c.b), ("max_pressure_Pa", c.p0),
                           ("approach_m", c.delta)):
            assert pp[key] == pytest.approx(value, rel=1e-12)
        assert pp["relative_radii_m"] == pytest.approx([1.0 / lam[0], 1.0 / lam[1]], rel=1e-14)
        trace = sum(pp["pinion_curvatures_1_m"]) + sum(pp["face_curvatures_1_m"])
        assert sum(lam) == pytest.approx(trace, rel=1e-9)
        assert sorted(pp["pinion_curvatures_1_m"]) == pytest.approx(
            [2.0 * p.lengthwise_crowning / (0.5 * p.face_width) ** 2,
             1.0 / (p.pitch_radius * math.sin(a))], abs=1e-4)


def test_load_and_masses_use_the_pitch_point_levers(rows, gearset):
    """At the pitch point the normal is the line of action: levers r_p cos a (pinion)
    and r_2 cos a (face gear), so F = T / (n_pinions r_2 cos a) and m_i = I_i / l_i^2."""
    p = gearset.pinion
    cos_a = math.cos(math.radians(p.pressure_angle_deg))
    for row, stage in zip(rows, gearset.stages, strict=True):
        r_b2 = 0.5 * p.module * stage.teeth * cos_a
        pp, ms = row["pitch_point"], row["masses"]
        assert pp["load_torque_Nm"] == 1.0  # seed presets: 1000 N mm at most
        assert pp["normal_force_N"] == pytest.approx(1.0 / (gearset.n_pinions * r_b2),
                                                     rel=1e-12)
        assert abs(ms["face_lever_m"]) == pytest.approx(r_b2, rel=1e-12)
        assert abs(ms["pinion_lever_m"]) == pytest.approx(p.pitch_radius * cos_a, rel=1e-12)
        m1, m2 = p.inertia / (p.pitch_radius * cos_a) ** 2, stage.inertia / r_b2**2
        assert ms["pinion_mass_kg"] == pytest.approx(m1, rel=1e-12)
        assert ms["face_mass_kg"] == pytest.approx(m2, rel=1e-12)
        assert ms["effective_mass_kg"] == pytest.approx(m1 * m2 / (m1 + m2), rel=1e-12)


def test_torque_scales_the_force_only(gearset):
    """Twice the torque, twice the force; the ellipse grows as F^(1/3) (Hertz)."""
    first = dataclasses.replace(gearset, stages=gearset.stages[:1])
    one = stage_geometry(first, 1.0)[0]["pitch_point"]
    two = stage_geometry(first, 2.0)[0]["pitch_point"]
    assert two["normal_force_N"] == pytest.approx(2.0 * one["normal_force_N"], rel=1e-14)
    assert two["a_m"] == pytest.approx(2.0 ** (1 / 3) * one["a_m"], rel=1e-10)


# -- command line ----------------------------------------------------------------------------
def test_command_prints_a_column_per_stage_and_json_round_trips(rows, tmp_path, capsys):
    out = tmp_path / "sub" / "geometry.json"
    assert main(["geometry", str(SEED), "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    lines = printed.splitlines()
    assert re.fullmatch(r"\s+stage 1\s+stage 2\s+stage 3", lines[1])
    table = [line for line in lines if re.search(r"\]\s", line)]   # rows with a unit
    assert len(table) > 30
    for line in table:
        label, values = re.split(r"\]\s+", line, maxsplit=1)
        assert len(values.split()) == len(rows), line
    data = json.loads(out.read_text())
    assert data["schema"] == "fe-impact/geometry/1"
    assert data["load_torque_Nm"] == 1.0
    assert data["stages"] == standard_json(rows)
    ratio = next(line for line in table if line.startswith("contact ratio"))
    printed_ratios = [float(v) for v in ratio.split()[-3:]]
    assert printed_ratios == pytest.approx(
        [s["path_of_contact"]["contact_ratio"] for s in data["stages"]], abs=5e-5)
    assert [p.name for p in out.parent.iterdir()] == ["geometry.json"]  # no temporary left


@pytest.mark.parametrize("argv, expected", [
    (lambda d: ["geometry", str(d / "none.toml")], ["GEARSET", "none.toml", "no such file",
                                                   "gear-set TOML file"]),
    (lambda d: ["geometry", str(d)], ["GEARSET", "is a folder"]),
    (lambda d: ["geometry", "--torque", "0"], ["--torque 0 N m", "> 0"]),
    (lambda d: ["geometry", "--json", str(d)], ["--json", "is a folder", "file name"]),
    (lambda d: ["geometry", "--schedule", str(d / "none.toml")],
     ["--schedule", "none.toml", "no such file", "schedule TOML file"]),
    (lambda d: ["geometry", "--torque", "5", "--schedule", str(_schedule(d, 1))],
     ["--torque 5", "--schedule", "give one of them"]),
    (lambda d: ["geometry", "--schedule", str(_schedule(d, 4))],
     ["[segments[1]] stage = 4", "stages 1..3"]),
    (lambda d: ["geometry", "--root-stress", "xfem"], ["--root-stress", "xfem", "iso"]),
])
def test_bad_input_is_one_line_and_exit_2(argv, expected, tmp_path, capsys):
    assert main(argv(tmp_path)) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1
    for text in expected:
        assert text in lines[0]


def _schedule(folder, second_stage: int, loads=(40.0, 25.0)):
    """A two-segment schedule: stage 1 at ``loads[0]``, then ``second_stage`` ramping to
    ``loads[1]`` N m."""
    path = folder / f"duty{second_stage}.toml"
    path.write_text(f"""name = "duty"
[[segments]]
stage = 1
duration_s = 1.0
speed_rpm = 300
load_Nm = {loads[0]}
[[segments]]
stage = {second_stage}
duration_s = 1.0
speed_rpm = 300
load_Nm = {{ from = 5, to = {loads[1]} }}
""")
    return path


def test_schedule_sets_each_stages_load(tmp_path, capsys, gearset):
    """Each stage at its own largest load in the schedule (the ramp's end), the stage
    the schedule leaves out at the schedule's largest; the Hertz and root-bending
    numbers follow: the normal force is T / (n_pinions l_2) with that stage's T."""
    out = tmp_path / "g.json"
    assert main(["geometry", str(SEED), "--schedule", str(_schedule(tmp_path, 2)),
                 "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "stage 3: not in the schedule; at the schedule's largest, 40 N m" in printed
    data = json.loads(out.read_text())
    assert data["load_torque_Nm"] == [40.0, 25.0, 40.0]
    assert data["load_torque_source"] == "--schedule"
    for row, torque in zip(data["stages"], (40.0, 25.0, 40.0), strict=True):
        pp = row["pitch_point"]
        assert pp["load_torque_Nm"] == torque
        assert pp["normal_force_N"] == pytest.approx(
            torque / (gearset.n_pinions * abs(row["masses"]["face_lever_m"])), rel=1e-12)
        rb = row["root_bending"]
        assert rb["allowable_Pa"] == 2.0 * gearset.material.bending_stress_limit
        assert rb["fe_pinion_Pa"] is None          # --root-stress iso: no FE
    # the pinion's section does not depend on the stage; sigma_F0 is linear in the force
    # over the face width
    r1, r2 = (row["root_bending"] for row in data["stages"][:2])
    assert r1["Y_F"] == pytest.approx(r2["Y_F"], rel=1e-12)
    f1, f2 = (row["pitch_point"]["normal_force_N"] for row in data["stages"][:2])
    assert r1["sigma_F0_Pa"] / r2["sigma_F0_Pa"] == pytest.approx(
        f1 / r1["face_width_m"] / (f2 / r2["face_width_m"]), rel=1e-12)


# -- tip edges and the first touch on them ------------------------------------------------------
def test_corner_rows_are_taken_where_the_planar_gap_is_the_reported_one(rows, gearset):
    """Each side's roll angle is where the torsional model's exact planar gap (the
    closed form of its frame, not the table the row was inverted from) equals
    CORNER_REPORT_GAP: within the table's spline error, 1e-4 relative; the
    three-dimensional gaps are positive and the touch lies on the rounding."""
    from fe_impact.gears.kinematics import _RackPinionFrame
    from fe_impact.gears.report import CORNER_REPORT_GAP

    p = gearset.pinion
    a = math.radians(p.pressure_angle_deg)
    frame = _RackPinionFrame(p.pitch_radius, a, p.addendum_coeff * p.module,
                             p.pitch_radius + p.addendum_coeff * p.module,
                             gearset.face_tip_edge_radius, p.tip_edge_radius)
    s_pitch = p.pitch_radius * math.sin(a)
    for row in rows:
        for side, gap, end in (("approach", frame.approach_gap, frame.s_start),
                               ("recess", frame.recess_gap, frame.s_end)):
            corner = row["corners"][side]
            delta = corner["line_beyond_end_m"]
            assert float(gap(delta)) == pytest.approx(CORNER_REPORT_GAP, rel=1e-4)
            s = end - delta if side == "approach" else end + delta
            assert corner["roll_rad"] == pytest.approx((s_pitch - s) / frame.base_radius,
                                                       rel=1e-12)
            assert 0.0 < corner["gap_m"] <= corner["midplane_gap_m"] * (1.0 + 1e-9)
            assert corner["on_rounding"] and corner["a_m"] > corner["b_m"] > 0.0
