"""Gmsh builders for the analytic test specimens (sphere on block).

The Hertz validations and tests run on these: a quarter model of a
hemisphere (or a whole quarter sphere) touching an elastic block at the
origin, with the symmetry planes x = 0 and y = 0. The block's top face is
z = 0 and the sphere touches it at one point with an optional initial gap.

Physical groups (the interface to the solver):

- volumes ``sphere``, ``block``;
- surfaces ``sphere_contact`` (the curved surface), ``block_contact``
  (the top face), ``block_bottom``, ``sphere_equator`` (the flat face of a
  hemisphere), ``sym_x`` (x = 0 faces of both bodies), ``sym_y``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

from fe_impact.meshing.session import gmsh_session, write_msh

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class SphereBlockSpec:
    """Dimensions (m) and mesh sizes of a quarter sphere-on-block model.

    ``h_contact`` is the element size within ``r_fine`` of the contact point;
    it grows linearly to ``h_far`` over ``r_grade``.
    """

    radius: float = 10e-3
    block_half_width: float = 10e-3
    block_depth: float = 10e-3
    gap: float = 0.0
    h_contact: float = 0.1e-3
    h_far: float = 2.5e-3
    r_fine: float = 1.0e-3
    r_grade: float = 6e-3
    order: int = 2
    hemisphere: bool = True

    def __post_init__(self) -> None:
        for name in ("radius", "block_half_width", "block_depth", "h_contact", "h_far",
                     "r_fine", "r_grade"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        if self.order not in (1, 2):
            raise ValueError(f"order must be 1 or 2, got {self.order}")


def build_sphere_block(spec: SphereBlockSpec, path: str | Path) -> Path:
    """Mesh the quarter sphere-on-block model and write it as MSH 4.1 (metres)."""
    with gmsh_session("sphere_block") as model:
        _add_geometry(model, spec)
        _add_size_field(model, spec)
        model.mesh.generate(3)
        if spec.order == 2:
            model.mesh.setOrder(2)
        return write_msh(path)


def _add_geometry(model, spec: SphereBlockSpec) -> None:
    occ = model.occ
    R, W, H, g = spec.radius, spec.block_half_width, spec.block_depth, spec.gap
    zc = R + g
    ball = occ.addSphere(0, 0, zc, R)
    keep = occ.addBox(0, 0, zc - R - 1e-3 * R, R * 1.1, R * 1.1,
                      R * (1.0 if spec.hemisphere else 2.0) + 1e-3 * R)
    sphere, _ = occ.intersect([(3, ball)], [(3, keep)])
    block = occ.addBox(0, 0, -H, W, W, H)
    occ.synchronize()
    sphere_tag = sphere[0][1]
    _tag_groups(model, spec, sphere_tag, block)


def _tag_groups(model, spec: SphereBlockSpec, sphere_tag: int, block_tag: int) -> None:
    R, H, g = spec.radius, spec.block_depth, spec.gap
    eps = 1e-3 * R  # OCC bounding boxes are padded by its tolerance (~1e-7 m)
    model.addPhysicalGroup(3, [sphere_tag], name="sphere")
    model.addPhysicalGroup(3, [block_tag], name="block")
    groups: dict[str, list[int]] = {k: [] for k in (
        "sphere_contact", "block_contact", "block_bottom", "sphere_equator", "sym_x", "sym_y")}
    for dim, tag in model.getBoundary([(3, sphere_tag)], oriented=False):
        xmin, ymin, zmin, xmax, ymax, zmax = model.getBoundingBox(dim, tag)
        if xmax < eps:
            groups["sym_x"].append(tag)
        elif ymax < eps:
            groups["sym_y"].append(tag)
        elif zmin > R + g - eps:
            groups["sphere_equator"].append(tag)
        else:
            groups["sphere_contact"].append(tag)
    for dim, tag in model.getBoundary([(3, block_tag)], oriented=False):
        xmin, ymin, zmin, xmax, ymax, zmax = model.getBoundingBox(dim, tag)
        if xmax < eps:
            groups["sym_x"].append(tag)
        elif ymax < eps:
            groups["sym_y"].append(tag)
        elif zmin > -eps:
            groups["block_contact"].append(tag)
        elif zmax < -H + eps:
            groups["block_bottom"].append(tag)
    for name, tags in groups.items():
        if tags:
            model.addPhysicalGroup(2, tags, name=name)


def _add_size_field(model, spec: SphereBlockSpec) -> None:
    # A point just at the contact: the distance field refines both bodies.
    p = model.occ.addPoint(0, 0, spec.gap / 2)
    model.occ.synchronize()
    refine_around_point(model, p, spec)


def refine_around_point(model, point: int, spec) -> None:
    """Mesh size ``spec.h_contact`` within ``spec.r_fine`` of the gmsh ``point``,
    graded to ``spec.h_far`` over ``spec.r_grade`` (a Distance field through
    :func:`refine_within`)."""
    fields = model.mesh.field
    pt = fields.add("Distance")
    fields.setNumbers(pt, "PointsList", [point])
    refine_within(model, pt, spec)


def refine_within(model, distance: int, spec) -> None:
    """Mesh size ``spec.h_contact`` where the gmsh field ``distance`` is below
    ``spec.r_fine``, graded to ``spec.h_far`` over ``spec.r_grade`` (a Threshold
    field as the background mesh; sizes from the boundary, points and curvature
    switched off), meshed in 3-D by HXT."""
    import gmsh

    fields = model.mesh.field
    th = fields.add("Threshold")
    fields.setNumber(th, "InField", distance)
    fields.setNumber(th, "SizeMin", spec.h_contact)
    fields.setNumber(th, "SizeMax", spec.h_far)
    fields.setNumber(th, "DistMin", spec.r_fine)
    fields.setNumber(th, "DistMax", spec.r_fine + spec.r_grade)
    fields.setAsBackgroundMesh(th)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.Algorithm3D", 10)  # HXT: fast and robust
    logger.debug("size field: %.3g m within %.3g m of contact", spec.h_contact, spec.r_fine)


def build_two_blocks(path: str | Path, size: float = 1e-3, gap: float = 1e-6,
                     order: int = 1, lower_element: float | None = None) -> Path:
    """Two stacked cubes of edge ``size`` (m), the upper ``gap`` above the lower.

    Meshed with one element size equal to the edge, so a P1 mesh has only the
    cube corners as nodes: tying every boundary face of the upper cube to a
    rigid body and fixing the lower one leaves a single degree of freedom on
    a linear penalty spring (``eps * size^2``), an impact with a closed-form
    half-sine solution. ``lower_element``: a finer element size (m) for the
    lower cube instead. Groups: volumes ``upper``, ``lower``; surfaces
    ``upper_all`` and ``lower_all`` (whole boundaries), ``upper_bottom`` and
    ``lower_top`` (the facing squares).
    """
    import gmsh

    with gmsh_session("two_blocks") as model:
        occ = model.occ
        lower = occ.addBox(0, 0, -size, size, size, size)
        upper = occ.addBox(0, 0, gap, size, size, size)
        occ.synchronize()
        model.addPhysicalGroup(3, [upper], name="upper")
        model.addPhysicalGroup(3, [lower], name="lower")
        for name, vol, face_z in (("upper", upper, gap), ("lower", lower, 0.0)):
            faces = [t for _, t in model.getBoundary([(3, vol)], oriented=False)]
            model.addPhysicalGroup(2, faces, name=f"{name}_all")
            facing = [t for t in faces
                      if abs(model.getBoundingBox(2, t)[2] - face_z) < 1e-3 * size
                      and abs(model.getBoundingBox(2, t)[5] - face_z) < 1e-3 * size]
            model.addPhysicalGroup(2, facing, name=f"{name}_bottom" if name == "upper"
                                   else f"{name}_top")
        fine = size if lower_element is None else lower_element
        gmsh.option.setNumber("Mesh.MeshSizeMin", min(size, fine))
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        if lower_element is not None:
            for vol, h in ((upper, size), (lower, lower_element)):
                corners = model.getBoundary([(3, vol)], combined=False, oriented=False,
                                            recursive=True)
                model.mesh.setSize([c for c in corners if c[0] == 0], h)
        model.mesh.generate(3)
        if order == 2:
            model.mesh.setOrder(2)
        return write_msh(path)
