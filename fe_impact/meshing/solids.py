"""A stage's sector solids, built once and turned into place for every mesh.

Step 1 of a tooth-pair mesh (the two sectors built in physical space as OCC
lofts through exact sections, :func:`~fe_impact.meshing.pairgeometry.add_sectors`)
depends on the gear set and the sector's make-up only. :func:`add_solids`
builds them once per process and stage, at the pitch point with no gap,
writes them as BRep, and for every other position, speed and retry imports
them and turns each sector about its gear's axis into place (on the seed set
at the coarse level a mesh built so takes about half the time of one built
from the sections). The processes of a sweep share the BRep files through a
folder (:func:`share_solids`, :func:`solids_folder`), pruned to
:data:`SOLIDS_BUDGET`.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import logging
import os
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from fe_impact.errors import MeshError
from fe_impact.gears.pairanalysis import PairSpec, analyse_stage_pair
from fe_impact.meshing.pairgeometry import MM, add_sectors, free_entities
from fe_impact.meshing.sizing import PairDesign

logger = logging.getLogger(__name__)

#: Fields of :class:`PairSpec` that shape the sectors' solids (the rest place them
#: or size the mesh): the key of :data:`_SOLIDS`.
_SOLID_FIELDS = ("stage", "n_face_teeth", "neighbour_teeth", "rim_modules",
                 "pinion_axial_position")


@dataclass
class _Solids:
    """Two sectors' solids as built once (OCC BRep, exact), where they were placed,
    and the centres of mass [mm] of their volumes and of each group's faces."""

    brep: Path
    pinion_roll: float             # PairAnalysis.pinion_roll_placed of the build, rad
    face_angle: float              # contact.face_angle of the build, rad
    volumes: dict[str, NDArray]
    faces: dict[str, list[NDArray]]
    #: Where the first import found them: each volume's place among the imported
    #: volumes and each group face's among its volume's boundary faces. A BRep
    #: reads back in the same order, and a turn keeps the topology, so later
    #: imports take the same places (checked against the bounding boxes).
    index: tuple[dict[str, int], dict[str, list[int]]] | None = None


#: Solids built in this process, by gear set and :data:`_SOLID_FIELDS`: the
#: positions of a stage, the speeds of an impact and the retries of a mesh
#: differ only in where the same two solids are placed (a turn of each about
#: its gear's axis) and in the mesh.
_SOLIDS: dict[str, _Solids] = {}
_SOLIDS_DIR: list[Path] = []
#: A folder the processes of a sweep share their solids through (see
#: :func:`share_solids`); empty: each process builds its own.
_SHARED: list[Path] = []


#: Most bytes of solids a shared folder keeps: about ten gear sets of three stages
#: (18-20 MB a stage); the entries used longest ago go first.
SOLIDS_BUDGET = 500 * 1024 * 1024


def share_solids(folder: str | Path | None) -> None:
    """Share the solids through ``folder`` (None: stop sharing).

    A process that needs a stage's solids takes them from there if another
    one has built them (``<key>.brep`` and ``<key>.json``, each written
    whole), and otherwise builds and leaves them there. Building them costs
    about 4.5 s a stage (two lofts and a cut); a sweep on two workers built
    each stage twice.
    """
    _SHARED.clear()
    if folder is not None:
        _SHARED.append(Path(folder))


def solids_folder(cache: str | Path) -> Path:
    """Where a calibration shares its solids: ``fe-impact/solids`` in the user's cache,
    so that later runs on the same gear set take them (the key holds the gear set,
    the sector fields and the source of the code that builds them: :func:`_solids_key`),
    else ``<cache>/solids``."""
    from fe_impact.runtime import user_cache

    return user_cache("solids") or Path(cache) / "solids"


@functools.cache
def _builder_digest() -> str:
    """Digest of the source that shapes the solids (the sectors' builder and the gear
    surfaces), so that solids kept across runs are never those of other code."""
    from fe_impact import gears
    from fe_impact.meshing import pairgeometry

    digest = hashlib.sha256()
    for path in [Path(pairgeometry.__file__), Path(__file__),
                 *sorted(Path(gears.__file__).parent.glob("*.py"))]:
        digest.update(path.read_bytes())
    return digest.hexdigest()


def _prune_shared(folder: Path, budget: int = SOLIDS_BUDGET) -> None:
    """Remove the entries of ``folder`` used longest ago (``<key>.json`` times, set
    again on every use) while the folder holds more than ``budget`` bytes."""
    entries = []
    for meta in folder.glob("*.json"):
        brep = meta.with_suffix(".brep")
        try:
            entries.append((meta.stat().st_mtime, meta, brep,
                            brep.stat().st_size if brep.is_file() else 0))
        except OSError:
            continue
    total = sum(size for *_, size in entries)
    for _, meta, brep, size in sorted(entries, key=lambda e: e[0]):
        if total <= budget:
            break
        meta.unlink(missing_ok=True)   # the entry is invalid without it: first
        brep.unlink(missing_ok=True)
        total -= size


def _shared_solids(key: str) -> _Solids | None:
    """The solids of ``key`` in the shared folder, if complete there."""
    if not _SHARED:
        return None
    meta, brep = _SHARED[0] / f"{key}.json", _SHARED[0] / f"{key}.brep"
    try:
        data = json.loads(meta.read_text())
    except (OSError, ValueError):
        return None
    if not brep.is_file():
        return None
    with contextlib.suppress(OSError):
        os.utime(meta)   # used now: the last to be pruned
    return _Solids(brep, float(data["pinion_roll"]), float(data["face_angle"]),
                   {k: np.array(v) for k, v in data["volumes"].items()},
                   {k: [np.array(c) for c in cs] for k, cs in data["faces"].items()})


def _leave_shared(key: str, solids: _Solids) -> None:
    """Write the metadata that makes freshly built solids, whose BRep is already in
    the shared folder (:func:`_solids_dir`), a valid entry there."""
    if not _SHARED:
        return
    from fe_impact.atomic import write_json

    write_json(_SHARED[0] / f"{key}.json", {
        "pinion_roll": solids.pinion_roll, "face_angle": solids.face_angle,
        "volumes": {k: v.tolist() for k, v in solids.volumes.items()},
        "faces": {k: [c.tolist() for c in cs] for k, cs in solids.faces.items()}})
    _prune_shared(_SHARED[0])


def _solids_dir() -> Path:
    """Where built solids are written: the shared folder (:func:`share_solids`), or
    else this process's scratch folder (removed when it exits)."""
    if _SHARED:
        return _SHARED[0]
    if not _SOLIDS_DIR:
        import atexit
        import shutil
        import tempfile

        folder = Path(tempfile.mkdtemp(prefix="fe_impact_sectors_"))
        atexit.register(shutil.rmtree, folder, ignore_errors=True)
        _SOLIDS_DIR.append(folder)
    return _SOLIDS_DIR[0]


def _affine(rotation: NDArray, centre: NDArray) -> NDArray:
    """The 3 x 4 row-major matrix of ``x -> rotation (x - centre) + centre`` [mm]."""
    return np.hstack([rotation, (centre - rotation @ centre)[:, None]])


def _apply(matrix: NDArray, x: NDArray) -> NDArray:
    return matrix[:, :3] @ x + matrix[:, 3]


def _rotate(occ, tag: int, matrix: NDArray) -> None:
    """Turn volume ``tag`` by the rotation ``matrix`` of :func:`_affine`.

    As an axis and an angle (OCC's exact placement change), not as a general
    affine map, which OCC applies by converting every surface to a B-spline
    (measured: 0.46 s per sector; the seed set's 33 coarse positions at 11
    per stage meshed in 208 s instead of 228 s, 15 meshes made again with
    either). The axis passes through the fixed point the matrix keeps (its
    translation solves ``(I - R) c = t``; the centre given to :func:`_affine`
    is one).
    """
    from scipy.spatial.transform import Rotation

    rotvec = Rotation.from_matrix(matrix[:, :3]).as_rotvec()
    angle = float(np.linalg.norm(rotvec))
    if angle <= 1e-14:   # the build's own placement: R R^T, the identity to rounding
        return
    axis = rotvec / angle
    # a point of the axis: the least-squares fixed point (I - R) c = t, made exact
    # along the axis' normal plane (I - R is singular along the axis only)
    point = np.linalg.lstsq(np.eye(3) - matrix[:, :3], matrix[:, 3], rcond=None)[0]
    occ.rotate([(3, tag)], *point, *axis, angle)


def add_solids(model, gearset, spec: PairSpec, design: PairDesign
                ) -> tuple[dict[str, int], dict[str, list[int]]]:
    """The sectors of :func:`add_sectors`, built once per process and reused.

    The first call for a gear set and :data:`_SOLID_FIELDS` builds them at
    the pitch point with no gap (roll angle 0, ``gap = 0``), whatever its own
    position, and writes them as BRep; every call imports that file, turns
    the pinion sector about the pinion's axis and the face-gear sector about
    the face gear's to their places, then finds the volumes and the surface groups'
    faces by their centres of mass (the first import; later ones take the places
    it found, :attr:`_Solids.index`). Built at one placement and turned, a
    sector differs from one built in place only between its loft sections,
    by the lofts' interpolation (below 0.01 um on the flanks, which the
    mesh's flank nodes are snapped onto anyway).
    """
    import gmsh

    from fe_impact.atomic import atomic_path

    if spec.contact != "flank":
        # built in place, with sections refined around the corner contact: the solids
        # of one corner position serve no other
        return add_sectors(model, design.pair, design.analysis, edge_radii=design.edge_radii)

    key = _solids_key(gearset, spec)
    pair, analysis, occ = design.pair, design.analysis, model.occ
    solids = _SOLIDS.get(key)
    if solids is None or not solids.brep.is_file():
        solids = _shared_solids(key)
        if solids is not None:
            _SOLIDS[key] = solids
    if solids is None or not solids.brep.is_file():
        # Built from the sections, written without the lofts' leftover points and
        # curves (hidden: removing 20k entities from OCC costs seconds), then
        # read back like any later call: the model holds the two solids alone.
        # Always at the pitch point with no gap, whatever position asked first:
        # a mesh then depends on its own parameters only, not on which case
        # the process happened to build the solids for (measured before: a
        # coarse stage-3 position meshed to 82.5k or 159k DOFs by the order).
        home = replace(spec, roll_angle_deg=0.0, gap=0.0)
        pair_home, analysis_home = ((pair, analysis) if home == spec
                                    else analyse_stage_pair(gearset, home))
        volumes, groups = add_sectors(model, pair_home, analysis_home)
        brep = _solids_dir() / f"{key}.brep"
        model.setVisibility(free_entities(model, [(3, t) for t in volumes.values()]), 0)
        gmsh.option.setNumber("Geometry.OCCExportOnlyVisible", 1)
        try:
            with atomic_path(brep) as tmp:   # whole: another process may read it
                gmsh.write(str(tmp))
        finally:
            gmsh.option.setNumber("Geometry.OCCExportOnlyVisible", 0)
        solids = _SOLIDS[key] = _Solids(
            brep, analysis_home.pinion_roll_placed, analysis_home.contact.face_angle,
            {k: np.array(occ.getCenterOfMass(3, t)) for k, t in volumes.items()},
            {k: [np.array(occ.getCenterOfMass(2, f)) for f in faces]
             for k, faces in groups.items()})
        _leave_shared(key, solids)
        name = model.getCurrent()
        gmsh.clear()
        model.add(name)
    try:
        return _turned_solids(model, design, solids)
    except MeshError as exc:   # not expected; building them costs only time
        logger.warning("%s; building the sectors again", exc)
        occ.remove(model.getEntities(3), recursive=True)
        occ.synchronize()
        return add_sectors(model, pair, analysis)


def _solids_key(gearset, spec: PairSpec) -> str:
    """Key of a stage's solids: the gear set, the sector fields, the version and the
    builder's source (solids shared on disk outlive the process and the run)."""
    from fe_impact.version import __version__

    blob = json.dumps({"gearset": asdict(gearset), "version": __version__,
                       "source": _builder_digest(),
                       **{k: getattr(spec, k) for k in _SOLID_FIELDS}},
                      sort_keys=True, default=repr)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def _turned_solids(model, design: PairDesign, solids: _Solids
                   ) -> tuple[dict[str, int], dict[str, list[int]]]:
    """Import ``solids`` and turn each sector into the place ``design`` says."""
    pair, analysis, occ = design.pair, design.analysis, model.occ
    # OCC's own entities serve until the turns are made: one synchronisation
    # (0.13 s on a coarse pair) instead of one before and one after them
    tags = [t for d, t in occ.importShapes(str(solids.brep)) if d == 3]
    turns = {
        "pinion": _affine(pair.pinion_rotation(analysis.pinion_roll_placed)
                          @ pair.pinion_rotation(solids.pinion_roll).T,
                          np.array([0.0, pair.pinion.pitch_radius, pair.z0]) * MM),
        "face_gear": _affine(pair.face_rotation(analysis.contact.face_angle)
                             @ pair.face_rotation(solids.face_angle).T, np.zeros(3)),
    }
    if solids.index is not None and len(tags) == len(solids.volumes):
        volumes = {k: tags[i] for k, i in solids.index[0].items()}
    else:
        centres = np.array([occ.getCenterOfMass(3, t) for t in tags])
        volumes = {k: tags[_nearest(centres, c, k)] for k, c in solids.volumes.items()}
    for name, tag in volumes.items():
        _rotate(occ, tag, turns[name])
    occ.synchronize()
    faces = {name: [t for _, t in model.getBoundary([(3, tag)], oriented=False)]
             for name, tag in volumes.items()}
    boxes = {name: np.array([model.getBoundingBox(2, f) for f in fs]).reshape(-1, 2, 3)
             for name, fs in faces.items()}
    turned = {group: [_apply(turns[_body(group)], c) for c in cs]
              for group, cs in solids.faces.items()}
    if solids.index is not None:
        groups = _indexed_groups(solids.index[1], faces, boxes, turned)
        if groups is not None:
            return volumes, groups
        logger.info("the reloaded sectors' faces are not where the first import found "
                    "them: searching them by their centres")
        solids.index = None
        occ.remove(model.getEntities(3), recursive=True)
        occ.synchronize()
        return _turned_solids(model, design, solids)
    centres: dict[tuple[str, int], NDArray] = {}   # computed once, when needed

    def centre(name: str, i: int) -> NDArray:
        if (name, i) not in centres:
            centres[name, i] = np.array(occ.getCenterOfMass(2, faces[name][i]))
        return centres[name, i]

    groups: dict[str, list[int]] = {}
    places: dict[str, list[int]] = {}
    for group, cs in turned.items():
        name = _body(group)
        groups[group], places[group] = [], []
        for c in cs:
            # a face's centre of mass lies in its bounding box (OCC pads the box):
            # the costly centres are computed for those faces only
            near = np.flatnonzero(_in_boxes(boxes[name], c))
            pool = near if len(near) else np.arange(len(faces[name]))
            d = np.array([centre(name, int(i)) for i in pool])
            i = int(pool[_nearest(d, c, group)])
            groups[group].append(faces[name][i])
            places[group].append(i)
    solids.index = ({k: tags.index(t) for k, t in volumes.items()}, places)
    return volumes, groups



def _body(group: str) -> str:
    """The sector a surface group belongs to."""
    return "pinion" if group.startswith("pinion") else "face_gear"


def _in_boxes(boxes: NDArray, c: NDArray) -> NDArray:
    """Which of the (padded by 1 um) bounding boxes ``boxes`` (n, 2, 3) [mm] hold ``c``."""
    return np.all((boxes[:, 0] - 1e-3 <= c) & (c <= boxes[:, 1] + 1e-3), axis=1)


def _indexed_groups(places: dict[str, list[int]], faces: dict[str, list[int]],
                    boxes: dict[str, NDArray], turned: dict[str, list[NDArray]]
                    ) -> dict[str, list[int]] | None:
    """The groups' faces at the places the first import found them (:attr:`_Solids.index`),
    or None unless each such face's box holds the group face's turned centre of mass
    (then the centres are searched again). 0.2 s a mesh less than the search: OCC
    integrates every centre of mass afresh."""
    groups = {}
    for group, where in places.items():
        name = _body(group)
        if max(where) >= len(faces[name]):
            return None
        if not all(_in_boxes(boxes[name][i:i + 1], c)[0]
                   for i, c in zip(where, turned[group], strict=True)):
            return None
        groups[group] = [faces[name][i] for i in where]
    return groups


def _nearest(centres: NDArray, c: NDArray, name: str) -> int:
    """Index of the centre nearest ``c`` [mm]: the same exact shapes, read back and
    turned. OCC integrates the centres of mass numerically (measured: up to about
    1e-6 mm apart for the same face, turned), so within 1 um, and no other entity
    within 10 um (distinct faces of a sector are a tenth of a millimetre apart or
    more)."""
    d = np.linalg.norm(centres - c, axis=1)
    order = np.argsort(d)
    i = int(order[0])
    second = d[order[1]] if len(d) > 1 else np.inf
    if d[i] > 1e-3 or second < 1e-2:
        raise MeshError(f"{name}: the reloaded sectors have no single entity at {c} mm "
                        f"(nearest {d[i]:.3g} mm, next {second:.3g} mm away)")
    return i
