"""Meshing in the stretched space: the steps and the retries every tooth-pair builder shares.

Both builders (:func:`fe_impact.meshing.toothpair.build_pair`, one pair, and
:func:`fe_impact.meshing.twopair.build_two_pair`, two) mesh the same way:

1. the sectors are covered by a fine reference surface mesh in physical
   space, which :func:`keep_reference` can keep for the retries;
2. its nodes are mapped into the stretched space (:func:`map_nodes` with
   :class:`~fe_impact.meshing.contactstretch.ContactStretch`) and the model is
   reloaded as discrete geometry (:func:`reload_as_discrete`);
3. tetrahedra are made there with an isotropic size field and mapped back
   (:func:`volume_mesh`, which mends the elements that come back turned over
   where gmsh can);
4. the flank nodes are snapped onto the exact flanks, and the mesh is
   checked (:func:`mesh_statistics`, :data:`MIN_SICN`): a turned-over element
   raises :class:`InvertedMesh`, which :func:`mesh_with_retries` answers by
   meshing again with smaller elements around it, then with less stretch
   (:data:`RETRIES`), down to the isotropic mesh.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from fe_impact.errors import MeshError
from fe_impact.meshing.pairgeometry import MM
from fe_impact.meshing.session import set_nodes
from fe_impact.meshing.sizing import REACH, SHORT_REACH

logger = logging.getLogger(__name__)

D = TypeVar("D")   # a mesh design (PairDesign, TwoPairDesign)

#: Smallest element quality accepted (gmsh's minimum signed inverse condition
#: number; 0 is a degenerate element). Below it the mesh is made again with
#: less anisotropy.
MIN_SICN = 0.01


class InvertedMesh(MeshError):
    """A mesh with a (nearly) inverted element; :func:`mesh_with_retries` retries.

    ``balls``: where the turned-over elements lie in the stretched space and
    a third of their size there, ``(x, y, z, size)`` [m] each (see
    :func:`turned_balls`); empty if unknown.
    """

    def __init__(self, message: str, balls=()) -> None:
        super().__init__(message)
        self.balls = tuple(balls)


# -- results -------------------------------------------------------------------------------
@dataclass(frozen=True)
class MeshStats:
    """Size and quality of the written mesh.

    Attributes
    ----------
    n_elements : dict
        Tetrahedra per volume group and ``"total"``.
    n_nodes : int
        Nodes of the tetrahedra (P2: vertices and mid-edge nodes).
    n_dofs : int
        ``3 n_nodes``.
    min_sicn, mean_sicn : float
        Gmsh's signed inverse condition number (minimum over the element's
        Jacobian for P2); 1 for a regular tetrahedron, <= 0 invalid.
    min_gamma, mean_gamma : float
        Inscribed/circumscribed radius ratio of the vertices' tetrahedra.
    seconds : float
        Wall time of the whole build.
    element_sizes : dict
        Target sizes [m]: ``minor`` (across the ellipse and along the
        normal), ``major`` (along the major axis) and ``far``.
    """

    n_elements: dict[str, int]
    n_nodes: int
    n_dofs: int
    min_sicn: float
    mean_sicn: float
    min_gamma: float
    mean_gamma: float
    seconds: float
    element_sizes: dict[str, float]


def map_nodes(model, mapping) -> tuple[NDArray, NDArray]:
    """Apply ``mapping`` (metres -> metres) to every node; returns tags and new mm coordinates."""
    tags, coords, _ = model.mesh.getNodes()
    x = mapping(coords.reshape(-1, 3) / MM) * MM
    set_nodes(tags, x)
    return tags, x


def mesh_statistics(model, volumes: dict[str, int], seconds: float, sizes: dict) -> MeshStats:
    counts, all_tags, all_nodes = {}, [], []
    for name, tag in volumes.items():
        _, elem_tags, node_tags = model.mesh.getElements(3, tag)
        counts[name] = int(sum(len(t) for t in elem_tags))
        all_tags.extend(elem_tags)
        all_nodes.extend(node_tags)
    counts["total"] = sum(counts.values())
    tags = np.concatenate(all_tags)
    n_nodes = len(np.unique(np.concatenate(all_nodes)))
    sicn = np.asarray(model.mesh.getElementQualities(tags, "minSICN"))
    gamma = np.asarray(model.mesh.getElementQualities(tags, "gamma"))
    return MeshStats(
        n_elements=counts, n_nodes=n_nodes, n_dofs=3 * n_nodes,
        min_sicn=float(sicn.min()), mean_sicn=float(sicn.mean()),
        min_gamma=float(gamma.min()), mean_gamma=float(gamma.mean()),
        seconds=seconds, element_sizes={k: float(v) for k, v in sizes.items()},
    )


def _qualities(model, volumes: dict[str, int]) -> tuple[NDArray, NDArray]:
    """Tags and minimum-SICN qualities of the volume elements."""
    tags = np.concatenate([np.concatenate(model.mesh.getElements(3, tag)[1])
                           for tag in volumes.values()])
    return tags, np.asarray(model.mesh.getElementQualities(tags, "minSICN"))


def _min_quality(model, volumes: dict[str, int]) -> float:
    """Smallest minimum-SICN of the volume elements."""
    return float(np.min(_qualities(model, volumes)[1]))


def turned_balls(model, volumes: dict[str, int], stretch) -> list[tuple[float, ...]]:
    """``(x, y, z, size)`` [m] in the stretched space of each element below
    :data:`MIN_SICN`: its corners' centroid mapped by ``stretch.to_mesh``, and a
    third of its longest edge there (the size a retry asks for around it); none
    if there are more than :data:`MAX_BALLS` of them."""
    tags, quality = _qualities(model, volumes)
    bad = tags[quality <= MIN_SICN]
    if len(bad) > MAX_BALLS:    # not a local defect: the stretch itself is too strong
        return []
    balls = []
    for tag in bad:
        _, nodes, _, _ = model.mesh.getElement(int(tag))
        corners = np.array([model.mesh.getNode(int(n))[0] for n in nodes[:4]]) / MM
        y = stretch.to_mesh(corners)
        edges = np.linalg.norm(y[:, None, :] - y[None, :, :], axis=2)
        balls.append((*(float(v) for v in y.mean(axis=0)), float(edges.max()) / 3.0))
    return balls


def volume_mesh(model, volumes: dict[str, int], stretch) -> None:
    """Tetrahedra in the stretched space, mapped back by ``stretch.to_physical``, and
    the elements that come back turned over mended where gmsh can (step 3 of the
    module docstring)."""
    model.mesh.generate(3)
    # gmsh's default tetrahedral optimisation of the stretched mesh (0.02 s on
    # a coarse pair): on the seed set's 27 coarse positions 15 -> 13 meshes
    # made again, among them the stage-3 position at +13.3 deg that went to
    # the isotropic mesh (159k DOFs) in the calibration's sweep
    model.mesh.optimize("")
    map_nodes(model, stretch.to_physical)
    if _min_quality(model, volumes) <= MIN_SICN:
        # a large element where the map varies fast can come back turned over;
        # gmsh's vertex relocation mends some (on the seed set's 27 coarse
        # positions: 2 of the 17 meshes that were made again before)
        model.mesh.optimize("Relocate3D")
        _flip_flat_caps(model, volumes)


def _flip_flat_caps(model, volumes: dict[str, int]) -> int:
    """Remove the turned-over tetrahedra that cap a boundary surface; returns how many.

    Such a cap has two faces on one boundary surface and all four nodes on
    it or its edges (seen on the face gear's flat tip land: curved in the
    stretched space, where the mesher laid a thin element on it, and flat
    again once mapped back, where the element turns over). Its nodes are
    all on the boundary, so no relocation mends it; without it the surface
    is the same quadrilateral triangulated across the other diagonal (the
    element's two other faces, oriented as the two it had on the surface).
    Other turned-over elements are left for the retry with less stretch.
    """
    tags, quality = _qualities(model, volumes)
    bad = tags[quality <= MIN_SICN]
    if not len(bad):
        return 0
    triangles: dict[frozenset, tuple[int, int, list[int]]] = {}
    for _, surface in model.getEntities(2):
        types, elem_tags, nodes = model.mesh.getElements(2, surface)
        for etype, et, nd in zip(types, elem_tags, nodes, strict=True):
            if etype != 2:   # 3-node triangles: the mesh is still linear here
                continue
            for t, tri in zip(et, np.asarray(nd).reshape(-1, 3), strict=True):
                corners = [int(n) for n in tri]
                triangles[frozenset(corners)] = (surface, int(t), corners)
    flipped = 0
    for tet in bad:
        _, element_nodes, _, volume = model.mesh.getElement(int(tet))
        nodes = [int(n) for n in element_nodes[:4]]
        on = [(triangles.get(frozenset(nodes[:i] + nodes[i + 1:])), nodes[i])
              for i in range(4)]
        caps = [(face, missing) for face, missing in on if face is not None]
        if len(caps) != 2 or caps[0][0][0] != caps[1][0][0]:
            continue
        (old1, p), (old2, q) = caps
        surface = old1[0]
        u, v = [n for n in nodes if n not in (p, q)]
        x = {n: np.asarray(model.mesh.getNode(n)[0]) for n in nodes}
        normal = np.cross(x[old1[2][1]] - x[old1[2][0]], x[old1[2][2]] - x[old1[2][0]])
        new = []
        for a, b, c in ((p, q, v), (p, q, u)):
            if np.dot(np.cross(x[b] - x[a], x[c] - x[a]), normal) < 0.0:
                b, c = c, b
            new += [a, b, c]
        model.mesh.removeElements(3, volume, [int(tet)])
        model.mesh.removeElements(2, surface, [old1[1], old2[1]])
        first = int(model.mesh.getMaxElementTag()) + 1
        model.mesh.addElementsByType(surface, 2, [first, first + 1], new)
        flipped += 1
    if flipped:
        logger.info("%d flat tetrahedra capping a boundary surface removed", flipped)
    return flipped


def keep_reference(path: Path) -> Path:
    """Write the physical reference surface mesh next to ``path`` for the retries
    (binary MSH: the coordinates come back exact)."""
    return _write_scratch(path.with_name(f".{path.stem}-physical.msh"), binary=True)


def _write_scratch(path: Path, binary: bool = False) -> Path:
    """Write the whole model's mesh (every entity, MSH 4.1) to ``path``, to be merged
    again."""
    import gmsh

    path.parent.mkdir(parents=True, exist_ok=True)
    gmsh.option.setNumber("Mesh.SaveAll", 1)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", int(binary))
    try:
        gmsh.write(str(path))
    finally:
        gmsh.option.setNumber("Mesh.Binary", 0)
    return path


def reload_as_discrete(model, path: Path) -> None:
    """Replace the model by its surface mesh, as discrete geometry (step 2 above).

    The mesh goes through a scratch file next to ``path``: gmsh reloads a
    mesh as discrete entities only from a file.
    """
    import gmsh

    reference = path.with_name(f".{path.stem}-reference.msh")
    try:
        _write_scratch(reference)
        gmsh.clear()
        gmsh.merge(str(reference))
    finally:
        reference.unlink(missing_ok=True)
    model.mesh.createGeometry()



#: Stretch caps and ends of the map's compensation (in zone half-lengths)
#: tried in turn when a mesh comes out with an element turned inside out by
#: the map; the last, a cap of 1, is the plain isotropic mesh (no map). At
#: the cap of 2.5 the shorter compensation is tried too before the isotropic
#: mesh, which costs 1.5-2 times the DOFs (:data:`~fe_impact.meshing.sizing.REACH`).
RETRIES = ((None, REACH), (5.0, REACH), (2.5, REACH), (2.5, SHORT_REACH), (1.0, REACH))
#: Attempts at one stretch with smaller elements around the elements that came
#: back turned over (:func:`turned_balls`), before the stretch is lowered: a
#: large element where the map varies fast turns over, a smaller one there
#: does not, and the contact zone keeps its discretisation.
LOCAL_REFINEMENTS = 2
#: More turned-over elements than this are not refined one by one (each is a
#: term of the size field, evaluated at every size query): the stretch is lowered.
MAX_BALLS = 16


def mesh_with_retries(where: str, session: str,
                      design_for: Callable[[float | None, float], D],
                      mesh: Callable[[object, D], MeshStats], factor: Callable[[D], float],
                      verbose: bool, started: float) -> tuple[D, MeshStats]:
    """Mesh, lowering the anisotropy while an element comes out inverted.

    ``design_for(cap, reach)`` designs the mesh for a stretch cap and an end
    of the map's compensation of :data:`RETRIES` (cap None: the level's
    own); ``mesh(model, design)`` meshes it in a gmsh session named
    ``session`` and raises :class:`InvertedMesh` on a turned-over element;
    ``factor(design)`` is the stretch factor the design took. A design equal
    to one already tried (a cap above the level's own factor) is skipped:
    the mesher is deterministic. ``where`` names the pair in the warnings
    and in the :class:`MeshError` raised when the isotropic mesh fails too.
    """
    from fe_impact.meshing.session import gmsh_session

    tried: set[tuple[float, float | None]] = set()
    failed: tuple[InvertedMesh, float] | None = None   # the last failure, its reach
    for cap, reach in RETRIES:
        design = design_for(cap, reach)
        stretch = factor(design)
        attempt = (stretch, reach if stretch > 1.0 else None)   # no map: no reach
        if attempt in tried:
            continue
        tried.add(attempt)
        if failed is not None:
            logger.warning("%s: %s; meshing again with a stretch factor of at most %s%s",
                           where, failed[0], cap,
                           "" if reach == failed[1] or stretch <= 1.0 else
                           f" and the map's compensation ending {reach:g} zone "
                           "half-lengths from the contact")
        for refined in range(LOCAL_REFINEMENTS + 1):
            try:
                with gmsh_session(session, verbose=verbose) as model:
                    stats = mesh(model, design)
            except InvertedMesh as exc:
                if stretch <= 1.0:
                    raise MeshError(f"{where}: {exc}") from exc
                failed = (exc, reach)
                if refined == LOCAL_REFINEMENTS or not exc.balls:
                    break
                logger.info("%s: %s; meshing again at the same stretch with elements of a "
                            "third of its size around it", where, exc)
                design = replace(design, refine=design.refine + exc.balls)
                continue
            return design, replace(stats, seconds=time.perf_counter() - started)
    raise AssertionError("unreachable: the isotropic mesh either passes or raises")
