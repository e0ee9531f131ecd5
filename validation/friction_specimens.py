"""Half models of a sphere on a block for the friction studies (Gmsh).

A tangential load along x breaks the quarter model's x = 0 symmetry, so these
keep only the plane y = 0: the sphere (centre ``R + gap`` above the block's top
face z = 0, radius ``R``; a hemisphere with its flat face on top, or the
whole sphere) over a block ``|x| <= W``, ``0 <= y <= W``, ``-H <= z <= 0``.
The mesh is refined to ``h_contact`` within ``r_fine`` of the contact point
and coarsens to ``h_far``.

Physical groups: volumes ``sphere``, ``block``; surfaces ``sphere_contact``
(the sphere's curved surface), ``sphere_equator`` (the hemisphere's flat face),
``block_contact`` (top), ``block_bottom``, ``sym_y`` (y = 0 faces of both).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from fe_impact.meshing.session import gmsh_session, write_msh
from validation.specimens import refine_around_point


@dataclass(frozen=True)
class HalfSphereBlock:
    """Dimensions and mesh sizes (m) of a half sphere-on-block model."""

    radius: float = 10e-3
    half_width: float = 10e-3
    depth: float = 10e-3
    gap: float = 0.0
    h_contact: float = 0.1e-3
    h_far: float = 2.5e-3
    r_fine: float = 1.0e-3
    r_grade: float = 6e-3
    order: int = 2
    hemisphere: bool = True


def build_half_sphere_block(spec: HalfSphereBlock, path: str | Path) -> Path:
    """Mesh the model and write it as MSH 4.1 (metres)."""

    R, W, H, g = spec.radius, spec.half_width, spec.depth, spec.gap
    with gmsh_session("half_sphere_block") as model:
        occ = model.occ
        zc = R + g
        ball = occ.addSphere(0, 0, zc, R)
        keep = occ.addBox(-1.1 * R, 0, zc - R - 1e-3 * R, 2.2 * R, 1.1 * R,
                          R * (1.0 if spec.hemisphere else 2.0) + 1e-3 * R)
        sphere, _ = occ.intersect([(3, ball)], [(3, keep)])
        block = occ.addBox(-W, 0, -H, 2 * W, W, H)
        p = occ.addPoint(0, 0, g / 2)
        occ.synchronize()
        s_tag = sphere[0][1]
        eps = 1e-3 * R
        model.addPhysicalGroup(3, [s_tag], name="sphere")
        model.addPhysicalGroup(3, [block], name="block")
        groups: dict[str, list[int]] = {k: [] for k in (
            "sphere_contact", "sphere_equator", "block_contact", "block_bottom", "sym_y")}
        for _, tag in model.getBoundary([(3, s_tag)], oriented=False):
            box = model.getBoundingBox(2, tag)
            if box[4] < eps:
                groups["sym_y"].append(tag)
            elif spec.hemisphere and box[2] > zc - eps:
                groups["sphere_equator"].append(tag)
            else:
                groups["sphere_contact"].append(tag)
        for _, tag in model.getBoundary([(3, block)], oriented=False):
            box = model.getBoundingBox(2, tag)
            if box[4] < eps:
                groups["sym_y"].append(tag)
            elif box[2] > -eps:
                groups["block_contact"].append(tag)
            elif box[5] < -H + eps:
                groups["block_bottom"].append(tag)
        for name, tags in groups.items():
            if tags:
                model.addPhysicalGroup(2, tags, name=name)
        refine_around_point(model, p, spec)
        model.mesh.generate(3)
        if spec.order == 2:
            model.mesh.setOrder(2)
        return write_msh(path)
