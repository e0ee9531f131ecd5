"""Element sizes of the tooth-pair mesh: refinement levels, the stretch and gmsh size fields.

A :class:`MeshLevel` gives the element sizes relative to the design Hertz
ellipse; :func:`design_pair` turns it, for one
:class:`~fe_impact.gears.pairanalysis.PairSpec`, into the sizes and the
:class:`~fe_impact.meshing.contactstretch.ContactStretch` of the stretched
space (:class:`PairDesign`); :func:`reference_size_field` and
:func:`size_field` set gmsh's background size in physical and in stretched
space (:mod:`fe_impact.meshing.toothpair` describes the steps).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from fe_impact.gears.pairanalysis import (
    LEVEL_NAMES,
    PairAnalysis,
    PairSpec,
    analyse_stage_pair,
)
from fe_impact.gears.tca import ContactEllipse, ContactPoint, GearPair
from fe_impact.meshing.contactstretch import ContactStretch
from fe_impact.meshing.pairgeometry import MM

__all__ = [
    "LEVELS",
    "MeshLevel",
    "PairDesign",
    "design_pair",
    "level_of",
    "edge_radii",
    "reference_size_field",
    "size_field",
]


# -- levels ----------------------------------------------------------------------------
@dataclass(frozen=True)
class MeshLevel:
    """Element sizes of a refinement level, relative to the design Hertz ellipse.

    Attributes
    ----------
    minor_fraction : float
        Size across the ellipse (minor axis) and along the normal, over ``b``.
    major_fraction : float
        Size along the major axis, over ``a``; the stretch factor is
        ``major_fraction a / (minor_fraction b)``, capped at ``max_stretch``.
    far_modules : float
        Largest element size, in modules.
    gradation : float
        Growth of the element size per unit distance from the contact zone
        (in the stretched space).
    max_stretch : float
        Upper bound of the element aspect ratio in the contact zone.
    """

    minor_fraction: float
    major_fraction: float
    far_modules: float
    gradation: float
    max_stretch: float = 8.0


LEVELS: dict[str, MeshLevel] = {
    "coarse": MeshLevel(1 / 2, 1 / 3, 1.25, 0.7),
    "default": MeshLevel(1 / 3, 1 / 4, 0.8, 0.5),
    "fine": MeshLevel(1 / 4, 1 / 6, 0.5, 0.35),
}
if tuple(LEVELS) != LEVEL_NAMES:  # PairSpec accepts exactly these names
    raise ImportError(f"LEVELS {list(LEVELS)} differ from PairSpec's {list(LEVEL_NAMES)}")


def level_of(spec: PairSpec) -> MeshLevel:
    """The sizes ``spec`` is meshed with: its level, every size and the gradation
    divided by ``spec.refinement`` (the stretch cap, a shape bound, kept)."""
    level, r = LEVELS[spec.level], spec.refinement
    if r == 1.0:
        return level
    return replace(level, minor_fraction=level.minor_fraction / r,
                   major_fraction=level.major_fraction / r,
                   far_modules=level.far_modules / r, gradation=level.gradation / r)


# -- design: sizes and stretch -----------------------------------------------------------
#: End of the stretch map's compensation, in zone half-lengths from the contact.
#: The compensation gives back the zone's shift at slope ``c``, half as steep
#: at 4 as at 2.5 (``c = k (2a - r) / (2 (reach - a))``), and the map's bend
#: where it ends turns fewer of the large far-field elements over: a mesh
#: comes back from the map with a turned-over element (all four nodes on the
#: surface, 6.6 mm long, across the compensation's end at stage 1, -5.4 deg)
#: and is made again with less stretch in 14 of the seed set's 60 coarse
#: positions (9 and 11 per stage) at 4, against 32 at 2.5 (13 and 10 of 27 at
#: 3.5 and 6). The compensation's elements are longer too: 9% fewer nodes on
#: the positions, 8-31% fewer on the default level's impacts. A mesh that
#: fails at 4 can pass at 2.5 (the stage-2 ratio switch at 4.2 m/s, whose
#: ellipse is longer than the face: isotropic, 67k DOFs, at 4; stretch 2.5,
#: 40k DOFs, at 2.5), so the retries try both (:data:`~fe_impact.meshing.stretchmesh.RETRIES`).
REACH = 4.0
#: The compensation's end used before :data:`REACH`, tried again when a mesh
#: at the stretch cap of 2.5 fails with :data:`REACH`.
SHORT_REACH = 2.5


@dataclass(frozen=True)
class PairDesign:
    """Everything computed before meshing (SI units, mesh frame).

    ``sizes`` holds the element sizes [m] ``minor``, ``major`` and ``far`` and
    the stretch ``factor`` (``major / minor``).
    """

    pair: GearPair
    analysis: PairAnalysis
    sizes: dict[str, float]
    stretch: ContactStretch
    #: Tip-edge rounding radii [m] of the pinion and the face gear built into the
    #: solids (a corner contact's; 0: sharp).
    edge_radii: tuple[float, float] = (0.0, 0.0)
    #: Balls of smaller elements in the stretched space, each ``(x, y, z, size)``
    #: [m]: where an earlier attempt's element came back turned over
    #: (:func:`~fe_impact.meshing.toothpair.mesh_with_retries`).
    refine: tuple[tuple[float, float, float, float], ...] = ()

    @property
    def ellipse(self) -> ContactEllipse:
        return self.analysis.design_ellipse


def design_pair(gearset, spec: PairSpec, max_stretch: float | None = None,
                reach: float = REACH) -> PairDesign:
    """The analysis of ``spec``'s pair, its element sizes and the stretch; the
    stretch factor capped at ``max_stretch`` too if given, the map's
    compensation ending ``reach`` zone half-lengths from the contact."""
    pair, analysis = analyse_stage_pair(gearset, spec)
    ellipse = analysis.design_ellipse
    level = level_of(spec)
    minor = level.minor_fraction * ellipse.b
    cap = level.max_stretch if max_stretch is None else min(max_stretch, level.max_stretch)
    factor = float(np.clip(level.major_fraction * ellipse.a / minor, 1.0, cap))
    sizes = {"minor": minor, "major": factor * minor, "factor": factor,
             "far": level.far_modules * pair.pinion.module}
    return PairDesign(pair=pair, analysis=analysis, sizes=sizes,
                      stretch=_stretch(analysis.contact, spec, ellipse, sizes, reach),
                      edge_radii=edge_radii(gearset, spec))


def edge_radii(gearset, spec: PairSpec) -> tuple[float, float]:
    """Tip-edge rounding radii [m] of the contacting flanks of the pinion and the face
    gear: the touching edge's for a corner contact (the face gear's on the approach
    side, the pinion's on the recess side), the others sharp, as for a flank contact:
    those edges lie far from the contact, and a rounding there only costs elements."""
    if spec.contact == "corner-approach":
        return 0.0, gearset.face_tip_edge_radius
    if spec.contact == "corner-recess":
        return gearset.pinion.tip_edge_radius, 0.0
    return 0.0, 0.0


def _stretch(design_contact: ContactPoint, spec: PairSpec, ellipse: ContactEllipse,
             sizes: dict[str, float], reach: float) -> ContactStretch:
    """The anisotropic map for this contact (see
    :class:`~fe_impact.meshing.contactstretch.ContactStretch`).

    The zone covers the ellipse with 30 % to spare; its outer half is the
    ramp back from full compression (the size field keeps the elements there
    short, so they follow the map closely); the compensation takes
    ``reach - 1`` zone half-lengths on each side (it ends ``reach``
    half-lengths from the centre); the core radius
    reaches where the graded size has grown to the major-axis size, and the
    fall-off is twice the largest shift wide (shear below about 1).
    """
    level = level_of(spec)
    e1 = ellipse.major if ellipse.major[2] > 0 else -ellipse.major  # towards larger radius
    n = design_contact.normal
    half = 1.3 * ellipse.a
    ramp = 0.5 * half
    core = 1.5 * ellipse.b + (sizes["major"] - sizes["minor"]) / level.gradation
    shift = (1.0 - 1.0 / sizes["factor"]) * half
    return ContactStretch(
        origin=design_contact.point + 0.5 * spec.gap * n,
        axes=np.stack([e1, np.cross(n, e1), n]),
        factor=sizes["factor"],
        half_length=half,
        reach=reach * half,
        ramp=ramp,
        core_radius=core,
        outer_radius=core + max(2.0 * shift, core),
    )


# -- gmsh size fields ---------------------------------------------------------------------
def box_distance(axes: NDArray, centre: NDArray, half: tuple[float, ...]) -> str:
    """MathEval expression: distance [mm] from the box ``|(x - centre) . axes_i| <= half_i``."""
    terms = []
    for axis, width in zip(axes, half, strict=True):
        dot = "+".join(f"({a:.17g})*({v}-({c:.17g}))" for a, v, c in zip(axis, "xyz", centre,
                                                                        strict=True))
        terms.append(f"Max(Fabs({dot})-({width:.17g}),0)^2")
    return "Sqrt(" + "+".join(terms) + ")"


def _segment_distance(a: NDArray, b: NDArray) -> str:
    """MathEval expression: distance [mm] from the segment from ``a`` to ``b`` [mm]."""
    d = b - a
    length = float(np.linalg.norm(d))
    t = d / length
    dot = "+".join(f"({tc:.17g})*({v}-({ac:.17g}))" for tc, v, ac in zip(t, "xyz", a,
                                                                         strict=True))
    along = f"Min(Max({dot},0),{length:.17g})"
    return "Sqrt(" + "+".join(f"({v}-({ac:.17g})-({tc:.17g})*{along})^2"
                              for v, ac, tc in zip("xyz", a, t, strict=True)) + ")"


#: Segments of the polyline through a rounded tip edge's centres in its size term.
EDGE_SEGMENTS = 8


def _edge_terms(design: PairDesign, to_space=None) -> list[tuple[float, str]]:
    """Size terms [mm] of the rounded tip edges of a corner contact: about the rounding's
    radius on the rounding (its arc then takes one or two elements, which the snapping
    puts on the exact rounding; the contact zone is much finer), graded away from the
    polyline through the balls' centres. ``to_space`` maps the polyline's points (m)
    into the space the field lives in (the stretched space); default physical."""
    from fe_impact.gears.corner import face_edge_rounding, pinion_edge_rounding

    analysis, pair = design.analysis, design.pair
    radii = design.edge_radii
    terms = []
    for radius, centres in (
            (radii[0], lambda r: pair.pinion_to_mesh(
                pinion_edge_rounding(pair, r, n=EDGE_SEGMENTS + 1).centres,
                analysis.pinion_roll_placed)),
            (radii[1], lambda r: pair.face_to_mesh(
                face_edge_rounding(pair, r, n=EDGE_SEGMENTS + 1).centres,
                analysis.contact.face_angle))):
        if radius <= 0.0:
            continue
        points = centres(radius)
        if to_space is not None:
            points = to_space(points)
        points = points * MM
        distance = "Min(" * (len(points) - 2) + _segment_distance(points[0], points[1])
        for a, b in zip(points[1:-1], points[2:], strict=True):
            distance += "," + _segment_distance(a, b) + ")"
        terms.append((radius * MM, distance))
    return terms


def set_size_field(model, terms: list[tuple[float, str]], gradation: float, far: float) -> None:
    """Background size ``min(far, min_i(size_i + gradation d_i))`` [mm], all else off.

    ``terms`` pairs a size [mm] with a distance expression (see :func:`box_distance`).
    """
    import gmsh

    expr = f"{far:.17g}"
    for size, distance in terms:
        expr = f"Min({expr},{size:.17g}+{gradation}*{distance})"
    field_id = model.mesh.field.add("MathEval")
    model.mesh.field.setString(field_id, "F", expr)
    model.mesh.field.setAsBackgroundMesh(field_id)
    for name, value in (("MeshSizeExtendFromBoundary", 0), ("MeshSizeFromPoints", 0),
                        ("MeshSizeFromCurvature", 0), ("MeshSizeMax", far),
                        ("Algorithm3D", 10), ("SecondOrderLinear", 1)):
        gmsh.option.setNumber(f"Mesh.{name}", value)


def zone_half_widths(design: PairDesign) -> tuple[float, float]:
    """Half-widths [m] of the refined zone across the ellipse and along the normal."""
    return 1.25 * design.ellipse.b, 1.0 * design.ellipse.b


def reference_size_field(model, design: PairDesign) -> None:
    """Physical-space sizes of the reference surface mesh.

    It only carries the geometry into the stretched space, where the final
    mesh is placed on it; it is finer than the final mesh across the ellipse
    (and isotropic, so much finer along it).
    """
    st, level = design.stretch, level_of(design.analysis.spec)
    width, depth = zone_half_widths(design)
    half = (st.half_length * MM, width * MM, depth * MM)
    distance = box_distance(st.axes, st.origin * MM, half)
    set_size_field(model, [(0.7 * design.sizes["minor"] * MM, distance),
                            *_edge_terms(design)],
                    0.5 * level.gradation, 0.5 * design.sizes["far"] * MM)


def size_field(model, design: PairDesign) -> None:
    """Isotropic size field of the stretched space: ``minor`` in the image of the
    zone (ramps included, so elements stay short where the compression
    changes), graded out to ``far``."""
    st, level, sizes = design.stretch, level_of(design.analysis.spec), design.sizes
    width, depth = zone_half_widths(design)
    lo, hi = st.mapped_interval(st.half_length)
    centre = (st.origin + 0.5 * (lo + hi) * st.axes[0]) * MM
    half = (0.5 * (hi - lo) * MM, width * MM, depth * MM)
    set_size_field(model, [(sizes["minor"] * MM, box_distance(st.axes, centre, half)),
                            *_edge_terms(design, st.to_mesh), *refine_terms(design.refine)],
                    level.gradation, sizes["far"] * MM)


def refine_terms(balls) -> list[tuple[float, str]]:
    """Size terms [mm] of ``balls`` (``(x, y, z, size)`` in metres, stretched space):
    ``size`` at each centre, growing with the level's gradation away from it."""
    return [(h * MM, "Sqrt(" + "+".join(f"(({c})-({v * MM:.17g}))^2"
                                       for c, v in zip("xyz", (x, y, z), strict=True)) + ")")
            for x, y, z, h in balls]
