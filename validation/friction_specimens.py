"""Half models of a sphere on a block for the friction studies (Gmsh).

A tangential load along x breaks the quarter model's x = 0 symmetry, so these
keep only the plane y = 0: the sphere (centre ``R + gap`` above the block's top
face z = 0, radius ``R``; a hemisphere with its flat face on top, or the
whole sphere) over a block ``|x| <= W``, ``0 <= y <= W``, ``-H <= z <= 0``.
The mesh is refined to ``h_contact`` within ``r_fine`` of the contact point
and coarsens to ``h_far`` over ``r_grade``. With ``depth_ratio`` k above 1
the distance is measured as ``sqrt(x^2 + y^2 + k^2 z^2)``: the fine zone is a
disc of radius ``r_fine`` and depth ``r_fine / k`` under the contact, and the
size grows k times faster into the bodies than along the surface, which
keeps a fine contact surface affordable (a Hertz or Mindlin field varies on
the scale of the contact radius in depth as along the surface).

Physical groups: volumes ``sphere``, ``block``; surfaces ``sphere_contact``
(the sphere's curved surface), ``sphere_equator`` (the hemisphere's flat face),
``block_contact`` (top), ``block_bottom``, ``sym_y`` (y = 0 faces of both).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from fe_impact.meshing.session import gmsh_session, write_msh
from validation.specimens import refine_around_point, refine_within


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
    depth_ratio: float = 1.0


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
        if spec.depth_ratio == 1.0:
            refine_around_point(model, p, spec)
        else:
            _refine_layer(model, spec, g / 2)
        model.mesh.generate(3)
        if spec.order == 2:
            model.mesh.setOrder(2)
        return write_msh(path)


def _refine_layer(model, spec: HalfSphereBlock, z0: float) -> None:
    """Size ``spec.h_contact`` within the anisotropic distance ``spec.r_fine`` of
    the contact point ``(0, 0, z0)``, graded to ``spec.h_far`` over ``spec.r_grade``
    (a MathEval field through :func:`validation.specimens.refine_within`)."""
    fields = model.mesh.field
    dist = fields.add("MathEval")
    k2 = spec.depth_ratio ** 2
    fields.setString(dist, "F", f"sqrt(x*x + y*y + {k2!r}*(z - {z0!r})*(z - {z0!r}))")
    refine_within(model, dist, spec)
