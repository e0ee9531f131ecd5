"""Two tooth pairs in contact: FE of a two-tooth sector against the superposition of one pair.

Run ``python validation/two_pair.py --out out/two_pair`` (the default mesh
level, about 6 minutes per position on two shared cores, 220k DOFs for the
two-pair sector) or with ``--quick`` (the coarse level, about 4 minutes for
the three positions); ``--fractions`` picks other positions. It writes
``two_pair.json``, ``two_pair.md`` and ``checks.json``, prints one
``[pass]``/``[FAIL]`` line per check and exits 1 when a figure is more than
5% from the superposition.

What is checked
---------------
The mesh cycle (:func:`fe_impact.calibration.meshcycle.mesh_cycle`) shares a
pinion torque between the pairs in contact by superposition: at one pinion
rotation every pair follows its own single-pair load-approach curve
(:func:`~fe_impact.calibration.meshcycle.run_position`: one pinion tooth on
one face-gear tooth, each with an unloaded neighbour tooth on either side,
the sectors cut and held half a pitch beyond them). Here the two pairs are
solved together: a pinion sector with two adjacent teeth (and a neighbour on
either side) pressed on a face-gear sector with the two mating teeth (idem)
(:func:`~fe_impact.meshing.twopair.build_two_pair`, both contacts refined as
a single pair's; the face-gear hub held, the pinion hub a rigid rotor under
torque). At three roll angles spread over the two-pair zone of the path of
contact (:data:`ZONE_FRACTIONS`) and at the torques that give about
:data:`PAIR_FORCES` per pair, the FE is compared with the superposition of
``run_position``'s curves at the two pairs' roll angles (same mesh level,
same design force, same gap):

- the load share, each pair's contact force over their sum;
- the torsional mesh stiffness of the pinion, as a secant ``T / theta``
  (``theta`` the pinion rotation from first touch) and as a tangent
  ``dT / d theta`` (central difference over the torques ``(1 +- STEP) T``,
  the same difference on both sides).

Both pairs touch at the same rotation (unmodified profiles: no unloaded
transmission error), so pair ``i`` closes by ``delta_i = theta |l_i|``.

Where a difference comes from. The two-pair FE differs from the
superposition by (a) the coupling of the pairs through the rim and the teeth
(a load on one tooth moves the other's contact), and (b) the single-pair
model itself: another mesh, another stretch factor. To separate them, each
pair's curve is also measured on the two-pair mesh with the other pair's
contact left out (the other teeth pass through each other): superposing
those curves leaves (a) alone, and those curves against ``run_position``'s
give (b).

Measured on the seed set (stage 1, coarse, all three positions and both
torques): load shares within 1.6%, secant mesh stiffness -3.4% to -2.1% and
tangent -5.0% to +1.7% of the two-pair FE, 18 of 18 checks passing, the
tangent at 6.49 deg and 200 N at the limit (-4.98%); the coupling (a) makes
the superposition up to 2.6% stiff. That position's sector is meshed at
stretch 8 after a retry that refines around an element turned over at 8;
made at stretch 5 instead, its pairs were up to 5.3% softer, (b), and the
two checks there failed (earlier meshes: 18 of 18, shares 3.5%, secant
2.3%, tangent 3.1%). At the default level, middle
position (238k DOFs for the two-pair sector, 8 minutes beside a test run):
shares within 0.9%, secant -2.9% / -3.1%, tangent -3.4% / -3.5% (6 of 6
pass). Before the sectors had
neighbour teeth (cut rigidly half a pitch beside the loaded tooth) the
two-pair FE was 2-6.5% softer than the superposition and the stiffness
checks failed at some positions: the rigid cuts held the tooth's root.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.calibration.meshcycle import PAIR_GAP, PositionCase, pair_force, run_position
from fe_impact.fe.linalg import limit_threads
from fe_impact.fe.mesh import load_mesh
from fe_impact.gears import gearset_from_dict
from fe_impact.gears.gearset import default_gearset_path
from fe_impact.meshing.twopair import build_two_pair, two_pair_static_case, two_pair_zone
from fe_impact.output.files import write_json
from fe_impact.solvers.static import StaticSolver
from validation import checks as ck

logger = logging.getLogger(__name__)

STAGE = 1
#: Positions of pair 1 over the two-pair zone, as fractions of it (0: pair 2
#: at the last point of contact, about to leave; 1: pair 1 at the first).
ZONE_FRACTIONS = (0.15, 0.5, 0.85)
#: Normal force per pair (N) of the compared torques: ``T = F (|l_1| + |l_2|)``.
PAIR_FORCES = (200.0, 1000.0)
#: Relative torque step of the tangent stiffness's central difference.
STEP = 0.1
#: Forces of the single-pair curves (N): from below the smallest pair force
#: at the smallest torque to above the largest at the largest (a pair can
#: carry up to about 80% of the load); the largest also sets the element
#: sizes of every mesh (the design force), single or two-pair.
CURVE_FORCES = (50.0, 100.0, 150.0, 200.0, 300.0, 400.0, 500.0, 700.0, 1000.0, 1300.0,
                1600.0, 2000.0)
#: Agreement asked of the superposition: load shares and stiffnesses within 5%. It is
#: the requirement the mesh cycle was built to (its issue's figure), not a budget
#: of known errors: of these, the pairs' coupling through the rim, which the
#: superposition leaves out, measured 1.0-2.6% stiff (docs/tolerances.md).
TOLERANCE = 0.05
LEVEL, QUICK_LEVEL = "default", "coarse"
ORDER = 2


@dataclass(frozen=True)
class Curve:
    """A single-pair load-approach curve (what :func:`pair_force` reads)."""

    forces: list[float]       # N
    approaches: list[float]   # m, from first touch


def _gearset_text() -> str:
    """The seed gear set's TOML text (what run_position is given)."""
    return default_gearset_path().read_text(encoding="utf-8-sig")


def positions(gearset, fractions=ZONE_FRACTIONS) -> list[float]:
    """Roll angles (deg) of pair 1 at ``fractions`` of the two-pair zone."""
    lo, hi = two_pair_zone(gearset, STAGE)
    return [float(lo + f * (hi - lo)) for f in fractions]


def torque_steps(levers: tuple[float, float]) -> list[float]:
    """Pinion torques (N m): each compared torque and its neighbours ``(1 +- STEP) T``."""
    base = [f * (abs(levers[0]) + abs(levers[1])) for f in PAIR_FORCES]
    return sorted(t * s for t in base for s in (1.0 - STEP, 1.0, 1.0 + STEP))


def superpose(curves: list[Curve], levers: list[float],
              torque: float) -> tuple[float, list[float]]:
    """Pinion rotation from first touch (rad) and pair forces (N) sharing ``torque``.

    Every pair closes by ``theta |l_i|`` and ``sum_i |l_i| F_i = T``
    (:func:`fe_impact.calibration.meshcycle.pair_force` on each curve).
    """
    arms = [abs(x) for x in levers]

    def excess(theta: float) -> float:
        return sum(a * pair_force(c, theta * a)[0] for c, a in zip(curves, arms, strict=True)) \
            - torque

    top = 1e-5
    while excess(top) < 0.0:
        top *= 2.0
    theta = brentq(excess, 1e-12, top, xtol=1e-16, rtol=1e-13)
    return theta, [pair_force(c, theta * a)[0] for c, a in zip(curves, arms, strict=True)]


def _solve(case) -> tuple[list, dict, float]:
    t = time.perf_counter()
    solver = StaticSolver(case, load_mesh(case.mesh_file, case.unit))
    result = solver.run()
    return result.steps, result.info, time.perf_counter() - t


def _rotation(step, lever: float, gap: float) -> float:
    """Pinion rotation from pair 1's first touch (rad): ``delta_1 / |l_1|``."""
    return (-step.rigid_values[0] * lever - gap) / abs(lever)


def run_position_pair(roll: float, gearset, gearset_text: str, level: str, out: Path) -> dict:
    """The two-pair FE at pair 1's roll angle ``roll``, the single-pair curves of both
    pairs (``run_position`` and on the same mesh) and the comparison."""
    t0 = time.perf_counter()
    mesh = build_two_pair(gearset, STAGE, roll, level, ORDER, PAIR_GAP,
                          out / "meshes" / f"roll{roll:+.3f}", reuse=True,
                          design_force=max(CURVE_FORCES))
    t_mesh = time.perf_counter() - t0
    rolls = mesh.roll_angles_deg
    levers = [a.masses.pinion_lever for a in mesh.analyses]
    gaps = [a.gap for a in mesh.analyses]
    torques = torque_steps(levers)
    with limit_threads(1):
        steps, info, t_two = _solve(two_pair_static_case(
            gearset, mesh, mesh.mesh_path.with_name("static.toml"), tuple(torques)))
        same_mesh, t_same = [], 0.0
        for k in (1, 2):
            loads = tuple(f * abs(levers[k - 1]) for f in CURVE_FORCES)
            own, _, secs = _solve(two_pair_static_case(
                gearset, mesh, mesh.mesh_path.with_name(f"static_pair{k}.toml"), loads, (k,)))
            t_same += secs
            theta = [_rotation(s, levers[0], gaps[0]) for s in own]
            same_mesh.append(Curve([s.contact_force[0] for s in own],
                                   [th * abs(levers[k - 1]) for th in theta]))
    singles, t_single = [], []
    for r in rolls:
        t = time.perf_counter()
        case = PositionCase(STAGE, gearset.stages[STAGE - 1].teeth, r, CURVE_FORCES)
        singles.append(run_position(case, level, ORDER, gearset_text, out / "cache"))
        t_single.append(time.perf_counter() - t)
    fe = [{"torque_Nm": float(tq), "applied_torque_Nm": float(abs(s.rigid_reactions[0])),
           "rotation_rad": _rotation(s, levers[0], gaps[0]),
           "forces_N": [float(f) for f in s.contact_force],
           "moment_balance": float(sum(abs(x) * f for x, f in zip(levers, s.contact_force,
                                                                   strict=True)) / tq - 1.0)}
          for tq, s in zip(torques, steps, strict=True)]
    targets = [_compare(fe, torques, levers, singles, same_mesh, f) for f in PAIR_FORCES]
    return {
        "roll_deg": list(rolls), "levers_m": levers, "gaps_m": gaps,
        "mesh": {"n_dofs": mesh.stats.n_dofs, "n_elements": mesh.stats.n_elements["total"],
                 "min_sicn": mesh.stats.min_sicn, "element_sizes_m": mesh.stats.element_sizes,
                 "n_contact_dofs": info["n_contact_dofs"], "mesh_s": mesh.stats.seconds},
        "single_pair": [{"roll_deg": s.roll_angle_deg, "n_dofs": s.n_dofs,
                         "forces_N": s.forces, "approaches_m": s.approaches,
                         "edge": s.edge, "seconds": secs,
                         "stretch_factor": _stretch_factor(out, s.hash)}
                        for s, secs in zip(singles, t_single, strict=True)],
        "same_mesh_pair": [{"forces_N": c.forces, "approaches_m": c.approaches}
                           for c in same_mesh],
        "fe_steps": fe, "targets": targets,
        "seconds": {"two_pair_mesh": t_mesh, "two_pair_fe": t_two, "same_mesh_curves": t_same,
                    "single_pairs": t_single, "total": time.perf_counter() - t0},
    }


def _stretch_factor(out: Path, key: str) -> float | None:
    """Stretch factor of run_position's single-pair mesh (its tca.json)."""
    import json

    path = out / "cache" / "meshes" / f"static_{key}" / "tca.json"
    try:
        return float(json.loads(path.read_text())["stretch_factor"])
    except (OSError, KeyError, ValueError):
        return None


def _figures(theta: float, forces: list[float], torque: float) -> dict:
    total = sum(forces)
    return {"rotation_rad": theta, "forces_N": forces, "shares": [f / total for f in forces],
            "secant_stiffness_Nm_rad": torque / theta}


def _compare(fe: list[dict], torques: list[float], levers: list[float], singles, same_mesh,
             pair_f: float) -> dict:
    """FE against both superpositions at the torque of ``pair_f`` per pair."""
    torque = pair_f * (abs(levers[0]) + abs(levers[1]))
    i = int(np.argmin(np.abs(np.asarray(torques) - torque)))
    lo, mid, hi = fe[i - 1], fe[i], fe[i + 1]
    got = _figures(mid["rotation_rad"], mid["forces_N"], mid["torque_Nm"])
    got["tangent_stiffness_Nm_rad"] = ((hi["torque_Nm"] - lo["torque_Nm"])
                                       / (hi["rotation_rad"] - lo["rotation_rad"]))
    out = {"pair_force_N": pair_f, "torque_Nm": mid["torque_Nm"], "fe": got}
    for name, curves in (("superposition", singles), ("same_mesh_superposition", same_mesh)):
        th = {k: superpose(curves, levers, fe[j]["torque_Nm"]) for k, j in
              (("lo", i - 1), ("mid", i), ("hi", i + 1))}
        pred = _figures(th["mid"][0], th["mid"][1], mid["torque_Nm"])
        pred["tangent_stiffness_Nm_rad"] = ((hi["torque_Nm"] - lo["torque_Nm"])
                                            / (th["hi"][0] - th["lo"][0]))
        out[name] = pred
        out[f"{name}_errors"] = _errors(got, pred)
    # Each pair's stiffness on the two-pair mesh (the other contact left out)
    # over run_position's, at the pair's force in the two-pair FE: (b) alone.
    out["same_mesh_over_single_stiffness"] = [
        _secant(cs, f) / _secant(cr, f) - 1.0
        for cs, cr, f in zip(same_mesh, singles, mid["forces_N"], strict=True)]
    return out


def _secant(curve, force: float) -> float:
    """Secant stiffness F / delta (N/m) of a curve at ``force``."""
    approach = brentq(lambda d: pair_force(curve, d)[0] - force, 1e-10, 1e-3, xtol=1e-16,
                      rtol=1e-13)
    return force / approach


def _errors(got: dict, pred: dict) -> dict:
    """Relative differences FE / prediction - 1; the shares' also in points."""
    return {
        "shares": [g / p - 1.0 for g, p in zip(got["shares"], pred["shares"], strict=True)],
        "share_points": [g - p for g, p in zip(got["shares"], pred["shares"], strict=True)],
        "secant_stiffness": got["secant_stiffness_Nm_rad"] / pred["secant_stiffness_Nm_rad"] - 1,
        "tangent_stiffness": (got["tangent_stiffness_Nm_rad"]
                              / pred["tangent_stiffness_Nm_rad"] - 1.0),
    }


def run(quick: bool = False, out: str | Path = "out/two_pair", level: str | None = None,
        fractions=ZONE_FRACTIONS) -> dict:
    """Every position at the level (coarse with ``quick``); writes two_pair.json."""
    out = Path(out)
    level = level or (QUICK_LEVEL if quick else LEVEL)
    text = _gearset_text()
    gearset = gearset_from_dict(tomllib.loads(text))
    t = time.perf_counter()
    rolls = positions(gearset, fractions)
    results = []
    for roll in rolls:
        logger.info("two-pair position: pair 1 at %.3f deg", roll)
        results.append(run_position_pair(roll, gearset, text, level, out))
    record = {"level": level, "order": ORDER, "stage": STAGE, "gap_m": PAIR_GAP,
              "zone_deg": list(two_pair_zone(gearset, STAGE)), "zone_fractions": list(fractions),
              "curve_forces_N": list(CURVE_FORCES), "pair_forces_N": list(PAIR_FORCES),
              "torque_step": STEP, "tolerance": TOLERANCE, "positions": results,
              "seconds": time.perf_counter() - t}
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "two_pair.json", record)
    (out / "two_pair.md").write_text(report(record))
    return record


def check(record: dict) -> list[ck.Check]:
    """Load shares and both stiffnesses within :data:`TOLERANCE` of the superposition."""
    out = []
    for p in record["positions"]:
        for t in p["targets"]:
            name = f"pair 1 at {p['roll_deg'][0]:.2f} deg, {t['pair_force_N']:g} N per pair"
            e = t["superposition_errors"]
            worst = max(e["shares"], key=abs)
            out.append(ck.at_most(f"{name}: load share vs superposition", abs(worst), TOLERANCE))
            out.append(ck.at_most(f"{name}: secant mesh stiffness vs superposition",
                                  abs(e["secant_stiffness"]), TOLERANCE))
            out.append(ck.at_most(f"{name}: tangent mesh stiffness vs superposition",
                                  abs(e["tangent_stiffness"]), TOLERANCE))
    return out


def report(record: dict) -> str:
    """The comparison as Markdown."""
    lines = [f"# Two pairs in contact: FE of a two-tooth sector against superposition "
             f"({record['level']} level, P{record['order']})", "",
             f"Two-pair zone: pair 1 at {record['zone_deg'][0]:.3f} .. {record['zone_deg'][1]:.3f}"
             " deg of pinion roll (pair 2 one pitch behind). Load share = pair force / sum; "
             "secant stiffness T / theta, tangent dT / d theta (central difference over "
             f"+-{record['torque_step']:.0%} of the torque), theta the pinion rotation from "
             "first touch. Errors: FE / prediction - 1.", "",
             "| pair rolls (deg) | N per pair | T (N m) | FE shares | superposition shares "
             "| share error | secant K FE (N m/rad) | secant error | tangent error "
             "| same-mesh superposition: share / secant / tangent error "
             "| same-mesh pair over single-pair stiffness |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for p in record["positions"]:
        for t in p["targets"]:
            e, s = t["superposition_errors"], t["same_mesh_superposition_errors"]
            fe, sp = t["fe"], t["superposition"]
            lines.append(
                f"| {p['roll_deg'][0]:.2f} / {p['roll_deg'][1]:.2f} | {t['pair_force_N']:g} "
                f"| {t['torque_Nm']:.2f} | {fe['shares'][0]:.3f} / {fe['shares'][1]:.3f} "
                f"| {sp['shares'][0]:.3f} / {sp['shares'][1]:.3f} "
                f"| {e['shares'][0]:+.1%} / {e['shares'][1]:+.1%} "
                f"| {fe['secant_stiffness_Nm_rad']:.4g} | {e['secant_stiffness']:+.1%} "
                f"| {e['tangent_stiffness']:+.1%} "
                f"| {max(s['shares'], key=abs):+.1%} / {s['secant_stiffness']:+.1%} / "
                f"{s['tangent_stiffness']:+.1%} "
                f"| {t['same_mesh_over_single_stiffness'][0]:+.1%} / "
                f"{t['same_mesh_over_single_stiffness'][1]:+.1%} |")
    lines += ["", "| pair rolls (deg) | two-pair DOFs | elements | min SICN | stretch 1 / 2 "
              "| single-pair DOFs | single stretch | mesh (s) | two-pair FE (s) "
              "| same-mesh curves (s) | single pairs (s) |", "|---" * 11 + "|"]
    for p in record["positions"]:
        m, sec, singles = p["mesh"], p["seconds"], p["single_pair"]
        sizes = m["element_sizes_m"]
        single_stretch = " / ".join("?" if s["stretch_factor"] is None
                                    else f"{s['stretch_factor']:.3g}" for s in singles)
        lines.append(
            f"| {p['roll_deg'][0]:.2f} / {p['roll_deg'][1]:.2f} | {m['n_dofs']} "
            f"| {m['n_elements']} | {m['min_sicn']:.3f} "
            f"| {sizes['factor_1']:.3g} / {sizes['factor_2']:.3g} "
            f"| {' / '.join(str(s['n_dofs']) for s in singles)} | {single_stretch} "
            f"| {sec['two_pair_mesh']:.0f} | {sec['two_pair_fe']:.0f} "
            f"| {sec['same_mesh_curves']:.0f} "
            f"| {' / '.join(f'{x:.0f}' for x in sec['single_pairs'])} |")
    lines.append("")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/two_pair"))
    p.add_argument("--quick", action="store_true", help=f"the {QUICK_LEVEL} mesh level")
    p.add_argument("--level", choices=("coarse", "default", "fine"), default=None,
                   help=f"mesh level (default: {LEVEL}, {QUICK_LEVEL} with --quick)")
    p.add_argument("--fractions", default=None,
                   help="comma-separated positions of pair 1 over the two-pair zone, 0..1 "
                        f"(default: {','.join(f'{f:g}' for f in ZONE_FRACTIONS)})")
    args = p.parse_args(argv)
    fractions = ZONE_FRACTIONS
    if args.fractions:
        try:
            fractions = tuple(float(f) for f in args.fractions.split(","))
        except ValueError:
            p.error(f"--fractions {args.fractions!r}: give numbers between 0 and 1")
        if not all(0.0 <= f <= 1.0 for f in fractions):
            p.error(f"--fractions {args.fractions!r}: each must lie between 0 and 1")
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    logging.getLogger("skfem").setLevel(logging.WARNING)
    record = run(args.quick, args.out, args.level, fractions)
    checks = check(record)
    text = report(record) + "\n## Checks\n\n" + ck.markdown(checks)
    (args.out / "two_pair.md").write_text(text)
    print(text)
    return ck.finish("two_pair", checks, args.out)


if __name__ == "__main__":
    sys.exit(main())
