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

import numpy as np

from fe_impact.defaults import LEVEL_NAMES, REFINEMENT_RANGE
from fe_impact.errors import MeshError

logger = logging.getLogger(__name__)

__all__ = ["register", "run", "write_picture"]

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
    from fe_impact.errors import GeometryError
    from fe_impact.gears import default_gearset, load_gearset
    from fe_impact.meshing.toothpair import build_pair
    from fe_impact.output.files import check_output_dir, removed_if_left_empty

    _check_options(args)
    check_output_dir(args.out)
    gearset = default_gearset() if args.gearset is None else load_gearset(args.gearset)
    n = len(gearset.stages)
    if not 1 <= args.stage <= n:
        raise GeometryError(f"--stage {args.stage}: gear set {gearset.name!r} has stages 1..{n}")
    t0 = time.perf_counter()
    stage = gearset.stages[args.stage - 1]
    print(f"{gearset.name}: stage {args.stage} ({stage.teeth} teeth), roll angle "
          f"{args.roll_angle:g} deg, level {args.level}"
          f"{'' if args.refinement == 1.0 else f' / {args.refinement:g}'}, P{args.order}",
          flush=True)
    print("  tooth contact analysis, geometry and mesh ...", flush=True)
    with removed_if_left_empty(args.out) as out:    # a pair not made leaves no empty --out
        pair = build_pair(gearset, args.stage, args.roll_angle, args.level, args.order,
                          args.gap * 1e-6, args.impact_speed, out, reuse=args.reuse,
                          n_face_teeth=args.face_teeth, neighbour_teeth=args.neighbour_teeth,
                          contact=args.contact, refinement=args.refinement)
    c, e, s = pair.contact, pair.ellipse, pair.stats
    print(f"  contact point {np.round(c.point * 1e3, 4).tolist()} mm, normal "
          f"{np.round(c.normal, 5).tolist()}", flush=True)
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
        picture, how = write_picture(pair, Path(args.out) / "pair.png", gearset)
        print(f"  picture {picture} ({how})", flush=True)
    print(f"wrote {pair.mesh_path}, {pair.case_path}, {pair.tca_path} "
          f"({time.perf_counter() - t0:.1f} s)")
    return 0


# -- picture -----------------------------------------------------------------------------------
def _surfaces(mesh_path: Path) -> tuple[np.ndarray, dict[str, np.ndarray], dict]:
    """Points [mm], corner triangles of the surface groups and corner tetrahedra of
    the volume groups of the mesh file."""
    import meshio

    m = meshio.read(mesh_path)
    tri = "triangle6" if "triangle6" in m.cells_dict else "triangle"
    tet = "tetra10" if "tetra10" in m.cells_dict else "tetra"
    surfaces, volumes = {}, {}
    for name, blocks in m.cell_sets_dict.items():
        if name.startswith("gmsh:"):
            continue
        if tri in blocks:
            surfaces[name] = m.cells_dict[tri][blocks[tri]][:, :3]
        if tet in blocks:
            volumes[name] = m.cells_dict[tet][blocks[tet]][:, :4]
    return m.points, surfaces, volumes


def _ellipse_outline(pair, gearset=None, n: int = 400) -> np.ndarray:
    """Contact ellipse at the design force [mm], laid on the face-gear flank.

    The outline is drawn in the tangent plane and, when the gear set is given,
    moved onto the face flank (at the same radius and height), so the curved
    flank does not hide it; then lifted by 2 um towards the pinion.
    """
    t = np.linspace(0.0, 2 * np.pi, n)
    e, c = pair.ellipse, pair.contact
    pts = c.point + np.outer(e.a * np.cos(t), e.major) + np.outer(e.b * np.sin(t), e.minor)
    if gearset is not None:
        from fe_impact.gears.tca import GearPair

        face = GearPair.from_gearset(gearset, pair.analysis.spec.stage).face
        ca, sa = np.cos(c.face_angle), np.sin(c.face_angle)
        local = np.stack([ca * pts[:, 0] - sa * pts[:, 2], pts[:, 1],
                          sa * pts[:, 0] + ca * pts[:, 2]], axis=1)
        radius = np.clip(np.hypot(local[:, 0], local[:, 2]), face.face_inner, face.face_outer)
        on = face.flank(radius, local[:, 1]).points
        pts = np.stack([ca * on[:, 0] + sa * on[:, 2], on[:, 1],
                        -sa * on[:, 0] + ca * on[:, 2]], axis=1)
    return (pts + 2e-6 * c.normal) * 1e3


_COLOURS = {"pinion_flank": "tomato", "face_flank": "royalblue", "pinion_hub": "grey",
            "face_hub": "grey"}


def write_picture(pair, path: Path, gearset=None) -> tuple[Path, str]:
    """Picture of the pair and the contact ellipse; pyvista, else matplotlib.

    ``gearset`` (optional) lets the ellipse be drawn on the curved face flank.
    Returns the path and which renderer drew it.
    """
    from fe_impact.output.files import atomic_path

    points, surfaces, volumes = _surfaces(pair.mesh_path)
    ellipse = _ellipse_outline(pair, gearset)
    with atomic_path(path) as tmp:   # a stopped run leaves no half-written picture
        try:
            _pyvista_picture(points, surfaces, volumes, ellipse, pair, tmp)
            how = "pyvista, off-screen"
        except Exception as exc:  # no OpenGL context, missing VTK pieces, ...
            logger.warning("pyvista off-screen rendering failed (%s); using matplotlib", exc)
            _matplotlib_picture(points, surfaces, ellipse, tmp)
            how = f"matplotlib 3-D: pyvista failed ({type(exc).__name__})"
    return path, how


def _pyvista_picture(points, surfaces, volumes, ellipse, pair, path: Path) -> None:
    """Left: both sectors (outer surfaces, flanks coloured); right: the face flank's
    mesh around the contact seen along the normal, with the Hertz ellipse."""
    import pyvista as pv

    def poly(tris: np.ndarray):
        return pv.PolyData(points, np.hstack([np.full((len(tris), 1), 3), tris]).ravel())

    def solid(tets: np.ndarray):
        cells = np.hstack([np.full((len(tets), 1), 4), tets]).ravel()
        kinds = np.full(len(tets), pv.CellType.TETRA, dtype=np.uint8)
        return pv.UnstructuredGrid(cells, kinds, points).extract_surface(
            algorithm="dataset_surface")

    normal, minor = pair.contact.normal, pair.ellipse.minor
    centre = pair.contact.point * 1e3
    lifted = ellipse
    plotter = pv.Plotter(off_screen=True, shape=(1, 2), window_size=(1600, 800))
    plotter.subplot(0, 0)
    for name, colour in (("pinion", "mistyrose"), ("face_gear", "lightsteelblue")):
        if name in volumes:
            plotter.add_mesh(solid(volumes[name]), color=colour, opacity=0.35)
    for name, tris in surfaces.items():
        plotter.add_mesh(poly(tris), color=_COLOURS.get(name, "lightgrey"))
    plotter.add_mesh(pv.lines_from_points(lifted), color="gold", line_width=5)
    plotter.add_text("pinion tooth and face-gear sector (mm)", font_size=10)
    plotter.view_vector(normal + 0.8 * minor + 0.4 * pair.ellipse.major, viewup=[0, 1, 0])
    plotter.reset_camera()
    plotter.subplot(0, 1)
    if "face_flank" in surfaces:
        plotter.add_mesh(poly(surfaces["face_flank"]), color=_COLOURS["face_flank"],
                         show_edges=True)
    plotter.add_mesh(pv.lines_from_points(lifted), color="gold", line_width=4)
    plotter.add_text(f"face flank mesh and Hertz ellipse at {pair.ellipse.force:.0f} N "
                     f"(a = {pair.ellipse.a * 1e3:.2f} mm, b = {pair.ellipse.b * 1e3:.3f} mm)",
                     font_size=10)
    plotter.camera.focal_point = centre
    plotter.camera.position = centre + 50.0 * normal
    plotter.camera.up = minor
    plotter.camera.parallel_projection = True
    plotter.camera.parallel_scale = 1.25 * pair.ellipse.a * 1e3
    plotter.screenshot(str(path))
    plotter.close()


def _matplotlib_picture(points, groups, ellipse, path: Path) -> None:
    """The two flanks and the ellipse as a 3-D matplotlib plot (no OpenGL needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(8, 7))
    ax = fig.add_subplot(projection="3d")
    for name in ("pinion_flank", "face_flank"):
        if name in groups:
            ax.plot_trisurf(points[:, 0], points[:, 1], points[:, 2], triangles=groups[name],
                            color=_COLOURS[name], alpha=0.6, linewidth=0.1)
    ax.plot(*ellipse.T, color="gold", linewidth=2)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_zlabel("z [mm]")
    fig.savefig(path, dpi=120)
    plt.close(fig)
