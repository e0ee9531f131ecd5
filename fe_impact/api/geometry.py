"""A gear set's checks before any FE work, and a meshed tooth pair."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

from fe_impact.api.common import PathLike
from fe_impact.api.readers import as_gearset, seed_load_torque
from fe_impact.errors import GeometryError

if TYPE_CHECKING:
    from fe_impact.gears.gearset import GearSet
    from fe_impact.meshing.toothpair import PairMesh

__all__ = ["geometry_report", "mesh_pair", "pair_picture"]


def geometry_report(gearset: GearSet | PathLike | None = None,
                    torque: float | list[float] | None = None, *,
                    root_stress: str = "iso", level: str = "coarse",
                    cache: PathLike = "cache") -> list[dict]:
    """The checks of a gear set before any finite-element work, one row per stage.

    Parameters
    ----------
    gearset : GearSet, str or path-like, optional
        A gear set or its TOML file; None: the seed set.
    torque : float or list of float, optional
        Load torque on the output [N m] for the Hertz and root-bending numbers, or
        one per stage; None: the seed's largest load (:func:`seed_load_torque`).
    root_stress : {"iso", "fe"}
        ``"fe"`` also meshes each stage's tooth pair at the pitch point (mesh
        ``level``, kept under ``cache``) and presses it with the stage's normal
        force: the FE's peak root tensions join the ISO-style figures
        (:func:`fe_impact.calibration.root_stress.fe_root_stress`; about 20 s of CPU a
        stage at the coarse level).

    Returns
    -------
    list of dict
        Per stage (``"stage"``, ``"teeth"``, ...), in SI units: the face-width
        limits and chosen radii (``"face_width"``), the path of contact in pinion
        roll angle and the contact ratio (``"path_of_contact"``), the Hertz
        contact at the pitch point (``"pitch_point"``), the pinion's root bending
        (``"root_bending"``), the reduced masses (``"masses"``), the tip edges and
        the first touch of a rounded edge (``"tip_edges"``, ``"corners"``). See
        :func:`fe_impact.gears.report.stage_geometry`.
    """
    from fe_impact.gears.report import stage_geometry

    if root_stress not in ("iso", "fe"):
        raise GeometryError(f"root_stress = {root_stress!r}: must be 'iso' or 'fe'")
    gs = as_gearset(gearset)
    values = [torque] if torque is None or not isinstance(torque, (list, tuple)) else torque
    for value in values:
        if value is not None and not (math.isfinite(value) and value > 0.0):
            raise GeometryError(f"torque = {value:g} N m: must be a number > 0")
    rows = stage_geometry(gs, seed_load_torque() if torque is None else torque)
    if root_stress == "fe":
        from fe_impact.calibration.root_stress import fe_root_stress

        for row in rows:
            force = row["pitch_point"]["normal_force_N"]
            result = fe_root_stress(gs, row["stage"], force, level=level, cache=cache)
            row["root_bending"].update(result.fe_rows())
            row["root_bending"]["fe_level"] = level
    return rows


def mesh_pair(gearset: GearSet | PathLike | None = None, stage: int = 1, *,
              out: PathLike, roll_angle_deg: float = 0.0, level: str = "default",
              order: int = 2, gap: float = 5e-6, impact_speed: float = 0.1,
              face_teeth: int = 1, neighbour_teeth: int = 1, contact: str = "flank",
              refinement: float = 1.0, reuse: bool = False) -> PairMesh:
    """Mesh a pinion tooth and face-gear teeth at their contact, ready for an impact.

    Writes ``pair.msh`` (mm), ``case.toml`` (a transient impact case for
    :func:`solve`) and ``tca.json`` to ``out``.

    Parameters
    ----------
    gearset : GearSet, str or path-like, optional
        None: the seed set.
    stage : int
        Face-gear stage, from 1.
    out : str or path-like
        Output folder (made; removed again if meshing fails before writing).
    roll_angle_deg : float
        Pinion roll angle from the pitch-point position [deg].
    level : {"coarse", "default", "fine"}
        Mesh refinement.
    order : {1, 2}
        Element order.
    gap : float
        Initial normal gap at the contact point [m].
    impact_speed : float
        Closing normal speed at the contact point [m/s].
    face_teeth : {1, 2, 3}
        Face-gear teeth in the sector.
    neighbour_teeth : {0, 1, 2}
        Unloaded teeth on each side of both sectors.
    contact : {"flank", "corner-approach", "corner-recess"}
        Where the teeth touch: on the flanks, or a rounded tip edge's first touch.
    refinement : float
        Divides every element size of ``level``.
    reuse : bool
        Keep the files in ``out`` if made from the same inputs.

    Returns
    -------
    PairMesh
        Paths (``mesh_path``, ``case_path``, ``tca_path``), the contact point and
        normal (``contact``), the Hertz ellipse (``ellipse``), the pair analysis
        with the Hertz impact estimate (``analysis.impact``) and mesh statistics.
    """
    from fe_impact.meshing.toothpair import build_pair
    from fe_impact.output.files import check_output_dir, removed_if_left_empty

    check_output_dir(out)
    gs = as_gearset(gearset)
    n = len(gs.stages)
    if not 1 <= stage <= n:
        raise GeometryError(f"--stage {stage}: gear set {gs.name!r} has stages 1..{n}")
    with removed_if_left_empty(out) as folder:    # a pair not made leaves no empty folder
        return build_pair(gs, stage, roll_angle_deg, level, order, gap, impact_speed, folder,
                          reuse=reuse, n_face_teeth=face_teeth, neighbour_teeth=neighbour_teeth,
                          contact=contact, refinement=refinement)


def pair_picture(pair: PairMesh, path: PathLike,
                 gearset: GearSet | None = None) -> tuple[Path, str]:
    """Picture of a meshed pair and its Hertz contact ellipse (PNG).

    pyvista off-screen, else matplotlib. ``gearset`` lets the ellipse be laid on
    the curved face flank. Returns the path and which renderer drew it.
    """
    from fe_impact.output.pair_picture import write_picture

    return write_picture(pair, Path(path), gearset)
