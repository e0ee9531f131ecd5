"""Picture of a meshed tooth pair and its Hertz contact ellipse (``pair.png``).

pyvista off-screen when it can render, else a matplotlib 3-D plot. The
ellipse is laid on the curved face flank when the gear set is given.
:func:`write_picture` is what ``fe-impact mesh`` draws
(:func:`fe_impact.api.pair_picture`).
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

logger = logging.getLogger(__name__)

__all__ = ["write_picture"]


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
