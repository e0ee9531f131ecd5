"""The ``fe-impact mesh`` command: a meshed tooth pair ready for the impact solver.

``fe-impact mesh [GEARSET] --stage 1 --roll-angle DEG --level coarse|default|fine
--order 1|2 --gap UM --impact-speed M/S --out DIR`` writes ``pair.msh``,
``case.toml``, ``tca.json`` (see :mod:`fe_impact.meshing.toothpair`) and
``pair.png``, a picture of the pair with the Hertz contact ellipse.

:func:`register` adds the subcommand to an ``argparse`` subparsers object;
the CLI calls ``args.func(args)`` and prints :class:`~fe_impact.errors.FeImpactError`
messages on one line.
"""

from __future__ import annotations

import argparse
import logging
import math
import time
from pathlib import Path

from fe_impact.defaults import LEVEL_NAMES, REFINEMENT_RANGE
from fe_impact.errors import MeshError

logger = logging.getLogger(__name__)

__all__ = ["register", "run"]

LEVEL_CHOICES = LEVEL_NAMES


def register(subparsers) -> argparse.ArgumentParser:
    """Add ``mesh`` to ``subparsers`` (from ``ArgumentParser.add_subparsers``)."""
    p = subparsers.add_parser(
        "mesh",
        help="mesh a pinion tooth and face-gear teeth at their contact",
        description="Tooth contact analysis and a Gmsh mesh of one pinion tooth and "
        "face-gear teeth placed at the contact with an initial gap; writes pair.msh (mm), "
        "case.toml (dynamic impact), tca.json and pair.png to --out.",
    )
    p.add_argument("gearset", nargs="?", type=Path, default=None,
                   help="gear-set TOML file (default: the seed gear set)")
    p.add_argument("--stage", type=int, default=1, help="face-gear stage, 1-based (default 1)")
    p.add_argument("--roll-angle", type=float, default=0.0, metavar="DEG",
                   help="pinion roll angle from the pitch-point position [deg] (default 0)")
    p.add_argument("--level", default="default", metavar="LEVEL",
                   help=f"refinement: {', '.join(LEVEL_CHOICES)} (default: default)")
    p.add_argument("--refinement", type=float, default=1.0, metavar="R",
                   help="divide every element size of --level and its gradation by R, "
                        f"{REFINEMENT_RANGE[0]:g} .. {REFINEMENT_RANGE[1]:g} (default 1): "
                        "meshes of one level at R = 1, 1.5, 2.25 are a family for a "
                        "convergence study (Richardson's extrapolation)")
    p.add_argument("--order", type=int, default=2, help="element order, 1 or 2 (default 2)")
    p.add_argument("--gap", type=float, default=5.0, metavar="UM",
                   help="initial normal gap at the contact point [um] (default 5)")
    p.add_argument("--impact-speed", type=float, default=0.1, metavar="M/S",
                   help="closing normal speed at the contact point [m/s] (default 0.1)")
    p.add_argument("--face-teeth", type=int, default=1, metavar="N",
                   help="face-gear teeth in the sector, 1..3 (default 1)")
    p.add_argument("--neighbour-teeth", type=int, default=1, metavar="N",
                   help="unloaded teeth on each side of both sectors, 0..2 (default 1: the "
                        "loaded teeth's roots free as in the whole gear; 0 holds the sector "
                        "cuts half a pitch beside them, which stiffens the pair)")
    p.add_argument("--contact", default="flank",
                   choices=("flank", "corner-approach", "corner-recess"),
                   help="where the teeth touch: on the flanks (default), or at the first "
                        "touch of the face gear's rounded tip edge on the pinion before the "
                        "path of contact (corner-approach) or of the pinion's on the face "
                        "gear after it (corner-recess); --roll-angle must then lie beyond "
                        "the path's end (`fe-impact geometry` gives the path's ends). The "
                        "touching edge is rounded and the lofts refined around the touch")
    p.add_argument("--out", type=Path, required=True, help="output folder")
    p.add_argument("--reuse", action="store_true",
                   help="keep the files in --out if they were made from the same inputs")
    p.add_argument("--no-picture", action="store_true", help="do not write pair.png")
    p.set_defaults(func=run)
    return p


def _check_options(args: argparse.Namespace) -> None:
    """User errors named by their option, with the value and what is allowed."""
    if args.level not in LEVEL_CHOICES:
        raise MeshError(f"--level {args.level!r}: pick one of {', '.join(LEVEL_CHOICES)}")
    lo, hi = REFINEMENT_RANGE
    if not (math.isfinite(args.refinement) and lo <= args.refinement <= hi):
        raise MeshError(f"--refinement {args.refinement:g}: allowed {lo:g} .. {hi:g}")
    if args.order not in (1, 2):
        raise MeshError(f"--order {args.order}: allowed 1 (linear) or 2 (quadratic)")
    if not (math.isfinite(args.gap) and 0.0 <= args.gap <= 1000.0):
        raise MeshError(f"--gap {args.gap:g} um: allowed 0 .. 1000 um")
    if not (math.isfinite(args.impact_speed) and 0.0 < args.impact_speed <= 20.0):
        raise MeshError(f"--impact-speed {args.impact_speed:g} m/s: allowed (0, 20] m/s")
    if args.face_teeth not in (1, 2, 3):
        raise MeshError(f"--face-teeth {args.face_teeth}: allowed 1, 2 or 3")
    if args.neighbour_teeth not in (0, 1, 2):
        raise MeshError(f"--neighbour-teeth {args.neighbour_teeth}: allowed 0, 1 or 2")
    if not (math.isfinite(args.roll_angle) and abs(args.roll_angle) <= 60.0):
        raise MeshError(f"--roll-angle {args.roll_angle:g} deg: allowed -60 .. 60 deg")


def run(args: argparse.Namespace) -> int:
    """Handler of ``fe-impact mesh``; returns the exit status."""
    from fe_impact.api import mesh_pair, pair_picture, read_gearset
    from fe_impact.output.files import check_output_dir

    _check_options(args)
    check_output_dir(args.out)
    gearset = read_gearset(args.gearset)
    t0 = time.perf_counter()
    if 1 <= args.stage <= len(gearset.stages):
        stage = gearset.stages[args.stage - 1]
        print(f"{gearset.name}: stage {args.stage} ({stage.teeth} teeth), roll angle "
              f"{args.roll_angle:g} deg, level {args.level}"
              f"{'' if args.refinement == 1.0 else f' / {args.refinement:g}'}, P{args.order}",
              flush=True)
        print("  tooth contact analysis, geometry and mesh ...", flush=True)
    pair = mesh_pair(gearset, args.stage, out=args.out, roll_angle_deg=args.roll_angle,
                     level=args.level, order=args.order, gap=args.gap * 1e-6,
                     impact_speed=args.impact_speed, face_teeth=args.face_teeth,
                     neighbour_teeth=args.neighbour_teeth, contact=args.contact,
                     refinement=args.refinement, reuse=args.reuse)
    c, e, s = pair.contact, pair.ellipse, pair.stats
    print(f"  contact point {_mm(c.point)} mm, normal {_rounded(c.normal, 5)}", flush=True)
    print(f"  Hertz ellipse at {e.force:.4g} N: a = {e.a * 1e3:.4g} mm, b = {e.b * 1e3:.4g} mm "
          f"(b/a = {e.slenderness:.3f}), p0 = {e.p0 / 1e6:.4g} MPa", flush=True)
    hit = pair.analysis.impact
    print(f"  impact at {args.impact_speed:g} m/s: m_eff = "
          f"{pair.analysis.masses.effective_mass:.4g} kg, delta_max = "
          f"{hit.delta_max * 1e6:.4g} um, F_max = {hit.force_max:.4g} N, "
          f"t_c = {hit.contact_time * 1e6:.4g} us", flush=True)
    print(f"  mesh: {s.n_elements['total']} elements, {s.n_nodes} nodes, {s.n_dofs} DOFs, "
          f"min SICN {s.min_sicn:.3f} (mean {s.mean_sicn:.3f}), stretch factor "
          f"{s.element_sizes['factor']:.3g} ({s.seconds:.1f} s)", flush=True)
    if not args.no_picture:
        picture, how = pair_picture(pair, Path(args.out) / "pair.png", gearset)
        print(f"  picture {picture} ({how})", flush=True)
    print(f"wrote {pair.mesh_path}, {pair.case_path}, {pair.tca_path} "
          f"({time.perf_counter() - t0:.1f} s)")
    return 0


def _rounded(values, digits: int) -> list[float]:
    """``values`` rounded to ``digits`` decimals, as a list (printed like numpy's)."""
    return [round(float(v), digits) for v in values]


def _mm(point) -> list[float]:
    """A point [m] in mm, to 0.1 um."""
    return _rounded([1e3 * float(v) for v in point], 4)
