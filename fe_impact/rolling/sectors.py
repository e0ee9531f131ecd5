"""Tooth sectors for the rolling mesh: several pinion and face-gear teeth, both flanks.

:func:`build_sectors` meshes, with the lofts of
:func:`~fe_impact.meshing.pairgeometry.add_sectors`, a pinion sector and a
face-gear sector of ``teeth`` teeth each (:data:`SECTOR_TEETH` = 5 by default,
:data:`TEETH_RANGE` allowed), placed at the pitch-point position of tooth 0 (the
TCA's roll angle 0, pinion turned back by ``gap``), and names the drive and coast
flank of every tooth:

- volumes ``pinion``, ``face_gear``; surfaces ``pinion_hub``, ``face_hub``;
- ``pinion_drive_{k}`` / ``pinion_coast_{k}`` (pinion tooth ``k``: tooth 0
  turned back by ``k`` angular pitches, ``k`` in :func:`tooth_range`, ``-1 .. 3``
  for 5 teeth);
- ``face_drive_{k}`` / ``face_coast_{k}`` (face-gear tooth ``k``, counted
  towards ``-x``).

The mesh is uniform at the level's far-field size (no contact refinement: the
contact is not resolved by the mesh, see :mod:`fe_impact.rolling.model`), in
millimetres, written as ``sectors.msh`` with ``sectors.json`` (SI units).
"""

from __future__ import annotations

import logging
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from fe_impact.errors import CaseError, MeshError
from fe_impact.gears.pairanalysis import PairSpec, analyse_stage_pair
from fe_impact.meshing.sizing import LEVELS

logger = logging.getLogger(__name__)

__all__ = ["NEIGHBOURS", "SECTOR_TEETH", "TEETH", "TEETH_RANGE", "SectorMesh",
           "build_sectors", "check_teeth", "split_teeth", "tooth_range"]

#: Loaded teeth of each sector (pinion teeth ``0 .. TEETH - 1`` and the face-gear teeth
#: opposite them) and the whole teeth beside them on each side, of the default sectors.
TEETH, NEIGHBOURS = 3, 1
#: Teeth of each sector by default (``TEETH + 2 * NEIGHBOURS``).
SECTOR_TEETH = TEETH + 2 * NEIGHBOURS
#: Teeth of each sector allowed. Fewest: 4, so that the sectors hold a whole mesh cycle
#: at a contact ratio up to 2 (the window holds ``teeth - (reach of a pair along the line
#: of action) / base pitch`` cycles, the reach being the path of contact plus the tip
#: edges' approach and recess: 2.2-2.5 base pitches on the seed set, contact ratio 1.7).
#: Most: 7, what the sector lofts build (3 loaded teeth and 2 neighbours a side,
#: :class:`~fe_impact.gears.pairanalysis.PairSpec`).
TEETH_RANGE = (4, 7)
#: Element size on the flanks as a fraction of the level's far-field size.
FLANK_FRACTION = 0.5


def check_teeth(teeth) -> int:
    """``teeth`` if :data:`TEETH_RANGE` allows it; else one line naming ``--teeth``.

    Raises
    ------
    CaseError
    """
    lo, hi = TEETH_RANGE
    if isinstance(teeth, bool) or not isinstance(teeth, int | np.integer) \
            or not lo <= teeth <= hi:
        raise CaseError(f"--teeth {teeth}: the sectors take {lo} to {hi} teeth each ({lo}: "
                        f"a whole mesh cycle at a contact ratio up to 2; {hi}: what the "
                        f"sector lofts build); ask for a whole number in {lo}..{hi} "
                        f"(default {SECTOR_TEETH})")
    return int(teeth)


def split_teeth(teeth: int = SECTOR_TEETH) -> tuple[int, int]:
    """``(loaded, neighbours)`` of a sector of ``teeth`` teeth: ``loaded`` (1..3) teeth
    from tooth 0 on and ``neighbours`` (1 or 2) beside them on each side, ``loaded + 2
    neighbours = teeth`` (5: 3 and 1, the default; 7: 3 and 2)."""
    teeth = check_teeth(teeth)
    neighbours = 1 if teeth <= 5 else 2
    return teeth - 2 * neighbours, neighbours


def tooth_range(teeth: int = SECTOR_TEETH) -> range:
    """Tooth numbers ``k`` present in both sectors of ``teeth`` teeth each."""
    loaded, neighbours = split_teeth(teeth)
    return range(-neighbours, loaded + neighbours)


def _suffix(k: int) -> str:
    return "" if k == 0 else f"_{k}"


def _groups(teeth: int) -> tuple[dict, dict]:
    pinion = {"pinion_hub": ("hub_left", "hub_right", "hub_rim")}
    face = {"face_hub": ("hub_left", "hub_right", "hub_bottom")}
    for k in tooth_range(teeth):
        pinion[f"pinion_drive_{k}"] = (f"flank_right{_suffix(k)}",)
        pinion[f"pinion_coast_{k}"] = (f"flank_left{_suffix(k)}",)
        face[f"face_drive_{k}"] = (f"flank_plus_{k}",)
        face[f"face_coast_{k}"] = (f"flank_minus_{k}",)
    return pinion, face


@dataclass(frozen=True)
class SectorMesh:
    """What :func:`build_sectors` wrote.

    Attributes
    ----------
    mesh_path : Path
        ``sectors.msh`` (millimetres).
    pinion_roll_placed, face_angle_placed : float
        TCA roll angle of pinion tooth 0 and face-gear angle of the mesh [rad].
    n_nodes, n_elements, seconds : int, int, float
    size_m : float
        Far-field element size [m] (flanks: :data:`FLANK_FRACTION` of it).
    teeth : int
        Teeth of each sector.
    """

    mesh_path: Path
    pinion_roll_placed: float
    face_angle_placed: float
    n_nodes: int
    n_elements: int
    seconds: float
    size_m: float
    teeth: int = SECTOR_TEETH

    def to_dict(self) -> dict:
        return {**asdict(self), "mesh_path": str(self.mesh_path)}


def build_sectors(gearset, stage: int, level: str = "coarse", out_dir: str | Path = ".",
                  order: int = 2, gap: float = 1e-6, teeth: int = SECTOR_TEETH
                  ) -> SectorMesh:
    """Mesh the pinion and face-gear sectors of ``stage``; write ``sectors.msh``.

    Parameters
    ----------
    gearset : GearSet
    stage : int
        Face-gear stage, 1-based.
    level : str
        A level of :data:`fe_impact.meshing.sizing.LEVELS`: its far-field size
        ``far_modules * m`` is the element size.
    out_dir : str or Path
    order : {1, 2}
    gap : float
        Normal gap [m] the pinion is turned back by at tooth 0 (the sectors
        must not touch in the mesh).
    teeth : int
        Teeth of each sector, :data:`TEETH_RANGE` (:func:`split_teeth`).

    Raises
    ------
    MeshError, GeometryError, CaseError
    """
    from fe_impact.meshing.pairgeometry import MM, add_sectors
    from fe_impact.meshing.session import gmsh_session, write_msh

    if level not in LEVELS:
        raise MeshError(f"level = {level!r}; pick one of {list(LEVELS)}")
    loaded, neighbours = split_teeth(teeth)
    started = time.perf_counter()
    spec = PairSpec(stage=stage, roll_angle_deg=0.0, level=level, order=order, gap=gap,
                    n_face_teeth=loaded, neighbour_teeth=neighbours, impact_speed=0.1)
    pair, analysis = analyse_stage_pair(gearset, spec)
    size = LEVELS[level].far_modules * gearset.module
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "sectors.msh"
    pinion_groups, face_groups = _groups(teeth)
    # two neighbours a side: the ring cuts the face sector's left cut face short of the
    # section that names the faces (its mid-point there lies beyond the outer radius),
    # so that face is found by its plane instead
    by_plane = neighbours > 1
    if by_plane:
        face_groups["face_hub"] = ("hub_right", "hub_bottom")
    with gmsh_session("rolling_sectors") as model:
        import gmsh

        volumes, groups = add_sectors(model, pair, analysis, pinion_teeth=loaded,
                                      pinion_groups=pinion_groups, face_groups=face_groups)
        if by_plane:
            pitch = 2.0 * np.pi / pair.face.teeth
            cut = (-(loaded - 1 + neighbours) - 0.5) * pitch + analysis.contact.face_angle
            groups["face_hub"] += _faces_on_cut(model, volumes["face_gear"], cut)
        flank_faces = [f for name, faces in groups.items() if "_drive_" in name
                       or "_coast_" in name for f in faces]
        field = model.mesh.field.add("Constant")
        model.mesh.field.setNumber(field, "VIn", FLANK_FRACTION * size * MM)
        model.mesh.field.setNumber(field, "VOut", size * MM)
        model.mesh.field.setNumbers(field, "SurfacesList", flank_faces)
        model.mesh.field.setAsBackgroundMesh(field)
        for name, value in (("MeshSizeExtendFromBoundary", 0), ("MeshSizeFromPoints", 0),
                            ("MeshSizeFromCurvature", 0), ("MeshSizeMax", size * MM),
                            ("Algorithm3D", 10), ("SecondOrderLinear", 0)):
            gmsh.option.setNumber(f"Mesh.{name}", value)
        model.mesh.generate(3)
        if order == 2:
            model.mesh.setOrder(2)
        for name, tag in volumes.items():
            model.addPhysicalGroup(3, [tag], name=name)
        for name, faces in groups.items():
            if not faces:
                raise MeshError(f"sector surface group {name} is empty")
            model.addPhysicalGroup(2, faces, name=name)
        n_nodes = len(model.mesh.getNodes()[0])
        n_elements = sum(len(t) for t in model.mesh.getElements(3)[1])
        write_msh(path)
    seconds = time.perf_counter() - started
    logger.info("wrote %s (%d nodes, %d elements, %.1f s)", path, n_nodes, n_elements, seconds)
    return SectorMesh(path, float(analysis.pinion_roll_placed),
                      float(analysis.contact.face_angle), int(n_nodes), int(n_elements),
                      seconds, float(size), int(teeth))


def _faces_on_cut(model, volume: int, angle: float) -> list[int]:
    """Boundary faces of ``volume`` in the face sector's cut plane at ``angle`` [rad]:
    the plane through the face gear's axis (``y``) holding the points ``(z tan(angle),
    y, z)``, to 1 um (the model is in millimetres; the plane passes the origin)."""
    normal = np.array([np.cos(angle), 0.0, -np.sin(angle)])
    out = []
    for _, tag in model.getBoundary([(3, volume)], oriented=False):
        (u0, v0), (u1, v1) = model.getParametrizationBounds(2, tag)
        uv = [(u, v) for u in np.linspace(u0, u1, 3) for v in np.linspace(v0, v1, 3)]
        points = np.reshape(model.getValue(2, tag, np.ravel(uv)), (-1, 3))
        if np.all(np.abs(points @ normal) < 1e-3):
            out.append(tag)
    if not out:
        raise MeshError(f"face-gear sector: no face in its cut plane at {np.degrees(angle):.4g}"
                        " deg")
    return out


def placed(mesh: SectorMesh) -> np.ndarray:
    """``(pinion roll, face angle)`` of the mesh [rad]."""
    return np.array([mesh.pinion_roll_placed, mesh.face_angle_placed])
