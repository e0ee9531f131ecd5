"""Tip-edge corner gaps: the three-dimensional first touch against a sampled rounding and
against the torsional model's planar geometry.

Run ``python validation/corner_gaps.py --out out/corner_gaps`` (the three
stages, both sides, where the planar gap is 2, 10 and 30 um; about a minute)
or with ``--quick`` (stage 1, 10 um). It writes ``corner_gaps.json``,
``corner_gaps.md`` and ``checks.json``, prints one ``[pass]``/``[FAIL]``
line per check and exits 1 when a check fails.

For each stage and side (:mod:`fe_impact.gears.corner`: the face gear's
rounded tip edge meeting the pinion before the path of contact, the pinion's
meeting the face gear after it), at the roll angle where the planar corner
gap (:mod:`fe_impact.switching.geometry`) is the given value:

- **checked**: the first touch over the whole face against the least turn over
  the rounding sampled at 1201 sections of 400 points each (shares nothing with
  the module's Newton solutions but the flanks' equations). The samples lie on
  the rounding, so their least gap is never below the true one, and above it by
  at most the sampling error: ``k (h/2)^2`` between sections (``k`` < 20 1/m the
  clearance's curvature along the edge, ``h`` the sections' largest spacing,
  11-16 um) plus ``rho dpsi^2 / 8`` on the arc (``dpsi`` the arc's largest
  sample spacing), computed for each row from its sampled edge (1.0-1.7e-9 m);
- **checked**: convergence in the edge's sections: the default 241 sections
  against 961, within 1e-4 of the gap or 1e-11 m (the first touch is refined to
  1/8 of a section between the least's neighbours, where the clearance is a
  parabola to within ``k' h^3``);
- **reported**: the gap in the pinion's mid-face plane, where the planar model
  lies, and over the whole face, beside the planar gap. The planar rack is not
  the face gear's section (a curved profile) and not where the edge first
  touches (away from the design radius on the approach side, towards the ring's
  inner end on the recess side); the torsional model therefore takes the
  three-dimensional gaps (``fe-impact switching --corners``).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.gears import default_gearset
from fe_impact.gears.corner import (
    corner_contact,
    face_edge_rounding,
    midplane_rounding,
    pinion_edge_rounding,
)
from fe_impact.gears.tca import GearPair
from fe_impact.switching.geometry import mesh_geometry
from validation import checks as ck

#: Planar corner gaps [m] at which the sides are compared.
PLANAR_GAPS = (2e-6, 10e-6, 30e-6)
#: Sampling of the brute force: sections along the edge, points on each arc.
BRUTE_SECTIONS, BRUTE_ARC = 1201, 400
#: Curvature bound [1/m] of the clearance along the edge (module docstring).
CLEARANCE_CURVATURE = 20.0
#: Sections of the converged reference, and the convergence tolerance.
FINE_SECTIONS, CONVERGED_REL, CONVERGED_ABS = 961, 1e-4, 1e-11


def arc_samples(edge, n: int) -> np.ndarray:
    """Points of the rounding between each section's flank and land normals."""
    a, b = edge.flank_normals, edge.land_normals
    angle = np.arccos(np.clip((a * b).sum(-1), -1.0, 1.0))[:, None, None]
    t = np.linspace(0.0, 1.0, n)[None, :, None]
    direction = (np.sin((1.0 - t) * angle) * a[:, None] + np.sin(t * angle) * b[:, None]) \
        / np.sin(angle)
    return (edge.centres[:, None] + edge.radius * direction).reshape(-1, 3)


def brute_bound(edge, n: int) -> float:
    """Bound [m] of the sampled rounding's excess over the least gap: ``k (h/2)^2``
    between the sections (``h`` their largest spacing) plus ``rho dpsi^2 / 8`` on
    the arc (``dpsi`` its largest sample spacing of ``n`` points)."""
    h = float(np.linalg.norm(np.diff(edge.centres, axis=0), axis=1).max())
    angle = np.arccos(np.clip((edge.flank_normals * edge.land_normals).sum(-1), -1.0, 1.0))
    dpsi = float(angle.max()) / (n - 1)
    return CLEARANCE_CURVATURE * (h / 2) ** 2 + edge.radius * dpsi**2 / 8


def brute_gap(pair: GearPair, side: str, points: np.ndarray, roll: float) -> float:
    """Least turn of the moving member onto the sampled rounding, times its lever."""
    if side == "approach":      # the pinion turns onto the face gear's edge
        p = pair.pinion
        mesh = pair.face_to_mesh(points, pair.nominal_face_angle(roll))
        x = (mesh - [0.0, p.pitch_radius, pair.z0]) @ pair.pinion_rotation(roll)
        radius = np.hypot(x[:, 0], x[:, 1])
        x, radius = x[radius > p.base_radius], radius[radius > p.base_radius]
        involute = p.involute_point(np.sqrt(radius**2 / p.base_radius**2 - 1.0))
        turn = np.arctan2(x[:, 1], x[:, 0]) - np.arctan2(involute[:, 1], involute[:, 0])
        return float(np.min(np.abs(p.base_radius * turn) + p.lengthwise_relief(x[:, 2])))
    face = pair.face              # the face gear turns onto the pinion's edge
    x = pair.pinion_to_mesh(points, roll) @ pair.face_rotation(pair.nominal_face_angle(roll))
    flank = face.flank(np.hypot(x[:, 0], x[:, 2]), x[:, 1], side=1).points
    turn = np.arctan2(x[:, 0], x[:, 2]) - np.arctan2(flank[:, 0], flank[:, 2])
    return float(np.min(np.abs(turn)) * face.pitch_radius * math.cos(face.pressure_angle))


def run(out: Path | None = None, quick: bool = False) -> dict:
    """Every stage, side and planar gap (``quick``: stage 1 at 10 um): the rows of the
    study, written to ``out`` as ``corner_gaps.json`` when given."""
    stages, planar_gaps = ((1,), (10e-6,)) if quick else ((1, 2, 3), PLANAR_GAPS)
    gearset = default_gearset()
    flat = mesh_geometry(gearset)
    rows = []
    for stage in stages:
        pair = GearPair.from_gearset(gearset, stage)
        for side, table, radius, make in (
                ("approach", flat.approach, gearset.face_tip_edge_radius, face_edge_rounding),
                ("recess", flat.recess, gearset.pinion.tip_edge_radius, pinion_edge_rounding)):
            edge, fine = make(pair, radius), make(pair, radius, n=FINE_SECTIONS)
            brute_edge = make(pair, radius, n=BRUTE_SECTIONS)
            samples = arc_samples(brute_edge, BRUTE_ARC)
            for planar in planar_gaps:
                delta = table.delta_at(planar)
                roll = float(flat.corner_roll(side, delta))
                t0 = time.perf_counter()
                touch = corner_contact(pair, edge, side, roll)
                seconds = time.perf_counter() - t0
                rows.append({
                    "stage": stage, "side": side, "planar_gap_m": planar,
                    "beyond_end_m": delta, "roll_rad": roll,
                    "gap_m": touch.gap, "section_m": touch.section,
                    "on_rounding": touch.on_rounding, "at_edge_end": touch.at_edge_end,
                    "fine_gap_m": corner_contact(pair, fine, side, roll).gap,
                    "brute_gap_m": brute_gap(pair, side, samples, roll),
                    "brute_bound_m": brute_bound(brute_edge, BRUTE_ARC),
                    "midplane_gap_m": corner_contact(
                        pair, midplane_rounding(pair, radius, side, roll), side, roll).gap,
                    "seconds": seconds,
                })
    result = {"rows": rows, "sections": len(edge.parameter), "fine_sections": FINE_SECTIONS,
              "brute": [BRUTE_SECTIONS, BRUTE_ARC]}
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        (out / "corner_gaps.json").write_text(json.dumps(result, indent=2) + "\n")
    return result


def check(result: dict) -> list[ck.Check]:
    checks = []
    for r in result["rows"]:
        name = f"stage {r['stage']} {r['side']}, planar {r['planar_gap_m'] * 1e6:g} um"
        excess, bound = r["brute_gap_m"] - r["gap_m"], r["brute_bound_m"]
        checks.append(ck.holds(f"{name}: sampled rounding - first touch [m]", excess,
                               -1e-11 <= excess <= bound, f"in [-1e-11, {bound:.3g}]"))
        diff = abs(r["gap_m"] - r["fine_gap_m"])
        checks.append(ck.holds(
            f"{name}: {result['sections']} against {result['fine_sections']} sections [m]",
            diff, diff <= max(CONVERGED_REL * r["fine_gap_m"], CONVERGED_ABS),
            f"<= max({CONVERGED_REL:g} gap, {CONVERGED_ABS:g})"))
    return checks


def _markdown(result: dict, checks: list[ck.Check]) -> str:
    lines = ["# Tip-edge corner gaps", "",
             "| stage | side | planar gap [um] | mid-face plane [um] | whole face [um] | "
             "touching at [mm] | beyond the flank's end [mm] |",
             "|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        lines.append(f"| {r['stage']} | {r['side']} | {r['planar_gap_m'] * 1e6:g} | "
                     f"{r['midplane_gap_m'] * 1e6:.4g} | {r['gap_m'] * 1e6:.4g} | "
                     f"{r['section_m'] * 1e3:.3f}{' (face end)' if r['at_edge_end'] else ''} | "
                     f"{r['beyond_end_m'] * 1e3:.4f} |")
    lines += ["", "Touching at: the face radius L (approach) or the pinion's axial position "
              "u from mid-face (recess).", "", ck.markdown(checks)]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=None, help="folder for the results")
    p.add_argument("--quick", action="store_true", help="stage 1 at a 10 um planar gap")
    args = p.parse_args(argv)
    result = run(args.out, args.quick)
    checks = check(result)
    for r in result["rows"]:
        print(f"stage {r['stage']} {r['side']:8s} planar {r['planar_gap_m'] * 1e6:4g} um: "
              f"mid-face {r['midplane_gap_m'] * 1e6:.4g} um, whole face "
              f"{r['gap_m'] * 1e6:.4g} um ({r['seconds']:.2f} s)")
    if args.out is not None:
        (args.out / "corner_gaps.md").write_text(_markdown(result, checks))
    return ck.finish("corner_gaps", checks, args.out)


if __name__ == "__main__":
    raise SystemExit(main())
