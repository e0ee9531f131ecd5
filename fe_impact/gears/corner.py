"""Tip-edge contact of a tooth pair entering or leaving mesh, in three dimensions.

Before the path of contact begins, a pair can already touch where the face
gear's rounded tip edge meets the pinion's involute, extended below its
working part (the *approach* side); after it ends, where the pinion's
rounded tip edge meets the face gear's flank (the *recess* side). A loaded
mesh closes these gaps early, which makes each tooth pair's mesh-in an
impact (:mod:`fe_impact.switching.geometry` tabulates them in the planar
rack-and-pinion model the torsional model runs on).

A tip edge rounded with radius ``rho`` is the envelope of balls of radius
``rho`` centred on a curve (:class:`EdgeRounding`): at each section of the
edge the centre lies ``rho`` inside both the flank and the tip land. The
rounding touches a mating flank exactly when one of these balls does, i.e.
when the distance from a centre to the flank falls to ``rho``. The *corner
gap* at a pinion roll angle is how far, in mesh-coordinate units, the
mating member must turn from the conjugate position for that to happen, the
other held: the pinion by ``g / r_bp`` on the approach side (the planar
model's definition there), the face gear by ``g / r_b2`` on the recess side
(``r_b2 = r_2 cos(alpha0)``, at whose normal speed every radius of the face
moves; the planar model moves its rack along the line of action). The
touching point, the common normal and the curvatures there (the ball's
``1/rho`` across the edge, the rounding's own along it, the mating flank's)
give the Hertz contact of the first touch with the ellipse code of
:mod:`fe_impact.gears.tca`.

Frames and roll angles are those of :class:`~fe_impact.gears.tca.GearPair`:
the face gear on its nominal angle ``phi_2(phi_1)`` (no transmission error),
roll angles positive towards the face-gear tip end of the path. SI units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fe_impact.errors import GeometryError
from fe_impact.gears.gearset import involute_end, rack_flank_end
from fe_impact.gears.tca import (
    ContactEllipse,
    GearPair,
    PrincipalCurvatures,
    RelativeCurvature,
    contact_ellipse,
    principal_curvatures,
    relative_curvature,
)

__all__ = [
    "CORNER_SIDES",
    "REFERENCE_GAP",
    "CornerContact",
    "EdgeRounding",
    "corner_contact",
    "corner_gaps",
    "face_edge_rounding",
    "flank_end_roll",
    "midplane_rounding",
    "pinion_edge_rounding",
    "pinion_rounding_roll",
    "touching_edge",
]

#: The two tip edges a pair can touch on: the face gear's before the path
#: (approach) and the pinion's after it (recess).
CORNER_SIDES = ("approach", "recess")
#: Sections of an edge the first touch is searched over (evenly along it).
EDGE_SECTIONS = 241
#: Bisection halvings for the rounding's centre in a section (its bracket is
#: ``rho`` wide: 2^-50 rho, below 1e-19 m).
_HALVINGS = 50
#: Newton steps of a point's projection onto a flank (quadratic from an
#: initial guess within a few um: round-off after four).
_PROJECTION_STEPS = 8
#: Newton steps on a ball's closing turn, and the step [rad] below which it
#: has converged (1e-14 rad moves a flank by 3e-16 m).
_TURN_STEPS = 20
_TURN_TOL = 1e-14
#: Sections of the refinement around each roll's least (:func:`_first_touch`).
_REFINE = 17
#: Planar corner gap [m] (the torsional model's, :mod:`fe_impact.switching.geometry`)
#: at whose roll angle the first touch stands for the corner: a loaded mesh closes
#: corner gaps of 2-30 um at mesh-in, over which the touch's relative radii change by
#: a few per cent. ``fe-impact geometry`` reports the touch there, and the closed-form
#: corner laws take its curvatures.
REFERENCE_GAP = 10e-6


@dataclass(frozen=True)
class EdgeRounding:
    """A rounded tip edge: its balls' centres along the edge, in the gear's own frame.

    Attributes
    ----------
    radius : float
        ``rho`` [m].
    parameter : ndarray, shape (n,)
        Position along the edge of each section: face radius ``L`` (face
        gear) or axial position ``u`` from mid-face (pinion) [m].
    centres : ndarray, shape (n, 3)
        Ball centres [m].
    flank_normals, land_normals : ndarray, shape (n, 3)
        Outward normals of the flank and of the tip land (or tip cylinder)
        where the rounding meets them: the ends of its arc.
    """

    radius: float
    parameter: NDArray[np.float64]
    centres: NDArray[np.float64]
    flank_normals: NDArray[np.float64]
    land_normals: NDArray[np.float64]


def face_edge_rounding(pair: GearPair, radius: float, n: int = EDGE_SECTIONS,
                       lengths: NDArray | None = None) -> EdgeRounding:
    """The face gear's rounded tip edge (flank ``side=+1`` and the tip plane), at
    ``n`` radii evenly over the face, or at the radii ``lengths`` [m].

    At each radius ``L`` of the face the rounding leaves the flank at the
    height ``h`` where the flank point ``p`` and its outward normal ``nu``
    put the centre ``p - rho nu`` at ``rho`` below the tip plane:
    ``h - rho nu_y = h_tip - rho`` (bisection in ``h`` over ``[h_tip - rho,
    h_tip]``, where the left side changes sign).
    """
    face = pair.face
    tip = face.tip_height
    if lengths is None:
        lengths = np.linspace(face.face_inner, face.face_outer, n)
    lengths = np.asarray(lengths, float)
    n = len(lengths)
    low, high = np.full(n, tip - radius), np.full(n, tip)
    for _ in range(_HALVINGS):
        mid = 0.5 * (low + high)
        s = face.flank(lengths, mid, side=1)
        above = mid - radius * s.normals[:, 1] > tip - radius
        low, high = np.where(above, low, mid), np.where(above, mid, high)
    s = face.flank(lengths, 0.5 * (low + high), side=1)
    land = np.broadcast_to([0.0, 1.0, 0.0], (n, 3)).copy()
    return EdgeRounding(radius, lengths, s.points - radius * s.normals, s.normals, land)


def pinion_edge_rounding(pair: GearPair, radius: float, n: int = EDGE_SECTIONS,
                         axial: NDArray | None = None) -> EdgeRounding:
    """The pinion's rounded tip edge (flank ``side=+1`` and the tip cylinder), at
    ``n`` axial positions evenly over the part of its face that lies over the
    face gear's (``L = z_0 + u``), or at the positions ``axial`` [m].

    At each axial position ``u`` the rounding leaves the (crowned) involute
    at the roll parameter ``theta`` where the centre ``p - rho nu`` lies on
    the cylinder of radius ``r_a - rho``; bisection in ``theta`` from the
    point ``2 rho`` below the tip to the tip.
    """
    pinion = pair.pinion
    if axial is None:
        face = pair.face
        axial = np.linspace(max(-0.5 * pinion.face_width, face.face_inner - pair.z0),
                            min(0.5 * pinion.face_width, face.face_outer - pair.z0), n)
    axial = np.asarray(axial, float)
    s = pinion.flank_surface(axial, pinion_rounding_roll(pinion, radius, axial), side=1)
    c, normals = s.points - radius * s.normals, s.normals
    land = np.zeros_like(c)
    land[:, :2] = c[:, :2] / np.hypot(c[:, 0], c[:, 1])[:, None]
    return EdgeRounding(radius, axial, c, normals, land)


def touching_edge(gearset, side: str) -> tuple[float, str, object]:
    """The tip edge that touches on ``side``: its rounding radius [m], the gear-set key
    that gives it and the builder of its rounding (:func:`face_edge_rounding` on the
    approach side, :func:`pinion_edge_rounding` on the recess side)."""
    if side not in CORNER_SIDES:
        raise GeometryError(f"corner side = {side!r}: pick one of {list(CORNER_SIDES)}")
    if side == "approach":
        return gearset.face_tip_edge_radius, "face_gear", face_edge_rounding
    return gearset.pinion.tip_edge_radius, "pinion", pinion_edge_rounding


def pinion_rounding_roll(pinion, radius: float, axial: NDArray) -> NDArray:
    """Roll parameter ``theta`` [rad] at which a tip-edge rounding of ``radius`` leaves
    the pinion's (crowned) right flank at the axial positions ``axial`` [m]: where the
    centre ``p - rho nu`` lies on the cylinder of radius ``r_a - rho`` (bisection from
    the point ``2 rho`` below the tip to the tip)."""
    axial = np.asarray(axial, float)
    r_a, r_b = pinion.tip_radius, pinion.base_radius
    low = np.full(axial.shape, math.sqrt(max((r_a - 2.0 * radius) ** 2 / r_b**2 - 1.0, 0.0)))
    high = np.full(axial.shape, pinion.theta_tip)
    for _ in range(_HALVINGS):
        mid = 0.5 * (low + high)
        s = pinion.flank_surface(axial, mid, side=1)
        c = s.points - radius * s.normals
        outside = np.hypot(c[..., 0], c[..., 1]) > r_a - radius
        low, high = np.where(outside, low, mid), np.where(outside, mid, high)
    return 0.5 * (low + high)


def midplane_rounding(pair: GearPair, radius: float, side: str, roll_angle: float
                      ) -> EdgeRounding:
    """Three sections, 1 um apart, of the held edge around the pinion's mid-face
    plane ``z = z_0`` at ``roll_angle``: the transverse plane in which the
    torsional model's planar geometry lies (the face gear there is the rack of
    pressure angle ``alpha0``). On the face gear the section in that plane
    moves with the roll; it is interpolated from 2001 sections over the face.
    """
    if side == "recess":
        return pinion_edge_rounding(pair, radius, axial=np.array([-1e-6, 0.0, 1e-6]))
    dense = face_edge_rounding(pair, radius, n=2001)
    z = pair.face_to_mesh(dense.centres, pair.nominal_face_angle(roll_angle))[:, 2]
    order = np.argsort(z)
    length = float(np.interp(pair.z0, z[order], dense.parameter[order]))
    return face_edge_rounding(pair, radius, lengths=length + np.array([-1e-6, 0.0, 1e-6]))


# -- projections onto the flanks ---------------------------------------------------------------
def _project(surface, x: NDArray, a: NDArray, b: NDArray, steps: tuple[float, float],
             iterations: int = _PROJECTION_STEPS) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Foot of points ``x`` (..., 3) on ``surface(a, b) -> (points, normals)`` by Newton
    on the tangency conditions ``(x - r) . r_a = (x - r) . r_b = 0`` (Gauss-Newton:
    the surface's second derivatives are dropped, exact at the solution);
    returns the parameters, the feet's signed distance along the outward normal
    and the normals."""
    ha, hb = steps
    for _ in range(iterations):
        p, _ = surface(np.stack([a, a + ha, a - ha, a, a]), np.stack([b, b, b, b + hb, b - hb]))
        r, ra, rb = p[0], (p[1] - p[2]) / (2 * ha), (p[3] - p[4]) / (2 * hb)
        d = x - r
        m = np.stack([np.stack([(ra * ra).sum(-1), (ra * rb).sum(-1)], -1),
                      np.stack([(ra * rb).sum(-1), (rb * rb).sum(-1)], -1)], -2)
        rhs = np.stack([(d * ra).sum(-1), (d * rb).sum(-1)], -1)
        step = np.linalg.solve(m, rhs[..., None])[..., 0]
        a, b = a + step[..., 0], b + step[..., 1]
    p, normal = surface(a, b)
    return a, b, ((x - p) * normal).sum(-1), normal


def _pinion_distance(pair: GearPair, x: NDArray, start=None, iterations=_PROJECTION_STEPS):
    """Signed distance of pinion-frame points to the pinion's flank (outward positive);
    +inf where the foot falls off the involute's real part (below the form circle,
    where the root fillet lies, above the tip, or beyond the face's ends): the tooth
    there is not the extended involute."""
    pinion = pair.pinion
    if start is None:
        radius = np.hypot(x[..., 0], x[..., 1])
        start = (x[..., 2].copy(),
                 np.sqrt(np.maximum(radius**2 / pinion.base_radius**2 - 1.0, 1e-6)))
    m = pinion.module
    a, b, dist, normal = _project(pair._pinion_surface, x, *start,
                                  (1e-3 * m, 1e-3 * m / pinion.base_radius), iterations)
    real = ((b >= pinion.theta_form) & (b <= pinion.theta_tip)
            & (np.abs(a) <= 0.5 * pinion.face_width))
    return a, b, np.where(real, dist, np.inf), normal


def _face_distance(pair: GearPair, x: NDArray, start=None, iterations=_PROJECTION_STEPS):
    """Signed distance of face-gear-frame points to its flank (outward positive); +inf
    for points more than a module above the tip plane or below the root plane, or two
    modules beyond the ends of the face (far from the working flank, where the flank's
    parametrisation has no point at their radius and height), and where the foot falls
    off the generated flank (:attr:`~fe_impact.gears.facegear.FlankSample.valid`) or
    beyond the face."""
    face = pair.face
    m = face.module
    length, height = np.hypot(x[..., 0], x[..., 2]), x[..., 1]
    if start is None:
        start = (length, height.copy())
    near = ((height > face.root_height - m) & (height < face.tip_height + m)
            & (length > face.face_inner - 2 * m) & (length < face.face_outer + 2 * m))
    a, b = np.array(start[0], float, copy=True), np.array(start[1], float, copy=True)
    dist = np.full(x.shape[:-1], np.inf)
    normal = np.zeros_like(x)
    if np.any(near):
        def surface(radius, height):    # NaN where no flank point is (the root fillet)
            s = face.flank(radius, height, side=1, strict=False)
            return s.points, s.normals

        a[near], b[near], dist[near], normal[near] = _project(
            surface, x[near], a[near], b[near], (1e-3 * m, 1e-3 * m), iterations)
        # feet off the generated flank (the root fillet, beyond the face): +inf
        real = face.flank(a[near], b[near], side=1, strict=False).valid \
            & (a[near] >= face.face_inner) & (a[near] <= face.face_outer)
        dist[near] = np.where(real & np.isfinite(dist[near]), dist[near], np.inf)
    return a, b, dist, normal


# -- the first touch ----------------------------------------------------------------------------
@dataclass(frozen=True)
class CornerContact:
    """First touch of a rounded tip edge on the mating flank at one roll angle.

    Attributes
    ----------
    side : {"approach", "recess"}
    roll_angle : float
        Pinion roll angle ``phi_1`` of the conjugate position [rad].
    gap : float
        Corner gap [m] in mesh-coordinate units (module docstring).
    turn : float
        Rotation [rad] of the moving member (pinion: approach, face gear:
        recess) that closes it, in its :class:`GearPair` sense.
    section : float
        Where along the edge it touches: face radius ``L`` or pinion axial
        position ``u`` [m].
    point, normal : ndarray, shape (3,)
        Touching point [m] and the mating flank's outward normal there, mesh
        frame, at the closed position.
    on_rounding : bool
        Whether the touch lies on the rounding's arc (between its tangency
        with the flank and with the tip land); False: it lies beyond, where
        the ball is only a bound.
    at_edge_end : bool
        Whether it touches at the first or last section of the edge (an end
        of the face): the edge's end corner, not modelled, may touch first.
    edge, flank : PrincipalCurvatures
        The rounding's curvatures (``1/rho`` across the edge) and the mating
        flank's, each about its own outward normal, mesh frame.
    relative : RelativeCurvature
    foot : tuple of float
        The touch on the mating flank in its own parameters: ``(u, theta)`` on the
        pinion (approach), ``(L, h)`` on the face gear (recess).
    arc_margin : float
        Angle [rad] from the touch to the nearer end of the rounding's arc (its
        tangency with the flank or the tip land), 0 beyond the arc: the Hertz
        contact stays on the rounding while its half-width across the edge is
        below ``radius * arc_margin`` (:meth:`rounding_force`).
    """

    side: str
    roll_angle: float
    gap: float
    turn: float
    section: float
    point: NDArray[np.float64]
    normal: NDArray[np.float64]
    on_rounding: bool
    at_edge_end: bool
    edge: PrincipalCurvatures
    flank: PrincipalCurvatures
    relative: RelativeCurvature
    foot: tuple[float, float] = (math.nan, math.nan)
    arc_margin: float = math.nan

    def ellipse(self, force: float, e_star: float) -> ContactEllipse:
        """Hertz ellipse of the touch under ``force`` [N] (``E*`` [Pa])."""
        return contact_ellipse(self.relative, force, e_star)

    def rounding_force(self, radius: float, e_star: float) -> float:
        """Largest force [N] whose Hertz ellipse stays on the rounding of ``radius`` [m]:
        its half-width across the edge (the minor semi-axis, the rounding's curvature
        being the larger) reaches the arc's nearer end, ``radius * arc_margin``.
        Hertz widths grow as ``F^(1/3)``."""
        b1 = self.ellipse(1.0, e_star).b
        return (radius * self.arc_margin / b1) ** 3

    def to_dict(self) -> dict[str, object]:
        """JSON-friendly record (SI units, angles in rad)."""
        return {
            "side": self.side, "roll_angle_rad": self.roll_angle, "gap_m": self.gap,
            "turn_rad": self.turn, "section_m": self.section, "point_m": self.point.tolist(),
            "normal": self.normal.tolist(), "on_rounding": self.on_rounding,
            "arc_margin_rad": self.arc_margin,
            "at_edge_end": self.at_edge_end,
            "edge_curvatures_1_m": self.edge.kappa.tolist(),
            "flank_curvatures_1_m": self.flank.kappa.tolist(),
            "relative_curvatures_1_m": [self.relative.lambda_min, self.relative.lambda_max],
        }


def _between(v: NDArray, a: NDArray, b: NDArray) -> bool:
    """Whether direction ``v`` lies in the angle (< 180 deg) from ``a`` to ``b``, in the
    plane of ``a`` and ``b`` (``v`` projected on it), ends included to round-off."""
    axis = np.cross(a, b)
    axis /= np.linalg.norm(axis)
    v = v - (v @ axis) * axis
    return bool(np.cross(a, v) @ axis >= -1e-9 and np.cross(v, b) @ axis >= -1e-9)


class _Corner:
    """One side's geometry at some roll angles: the held edge's ball centres in the
    moving member's frame, shape (rolls, sections, 3), and each ball's closing turn."""

    def __init__(self, pair: GearPair, edge: EdgeRounding, side: str, rolls: NDArray,
                 groups: int | None = None):
        self.pair, self.edge, self.side = pair, edge, side
        self.rolls = np.atleast_1d(np.asarray(rolls, float))
        self.phi2 = pair.nominal_face_angle(self.rolls)
        base = []
        for r, (roll, phi2) in enumerate(zip(self.rolls, self.phi2, strict=True)):
            # every section at every roll, or the r-th group of ``groups`` sections
            centres = edge.centres if groups is None else \
                edge.centres[r * groups:(r + 1) * groups]
            if side == "approach":   # face-gear centres into the pinion frame at roll
                mesh = pair.face_to_mesh(centres, phi2)
                base.append((mesh - [0.0, pair.pinion.pitch_radius, pair.z0])
                            @ pair.pinion_rotation(roll))
            else:                    # pinion centres into the face-gear frame at phi2
                base.append(pair.pinion_to_mesh(centres, roll) @ pair.face_rotation(phi2))
        self.base = np.stack(base)
        self.lever = (pair.pinion.base_radius if side == "approach"
                      else pair.face.pitch_radius * math.cos(pair.face.pressure_angle))

    def turned(self, turns: NDArray) -> tuple[NDArray, NDArray]:
        """The centres as the moving member sees them after it turned by ``turns`` (one
        per ball), and their rate of change with the turn."""
        c, s = np.cos(turns), np.sin(turns)
        x, y, z = np.moveaxis(self.base, -1, 0)
        if self.side == "approach":      # Rz(-turn): the pinion turned by +turn
            xt, yt = c * x + s * y, -s * x + c * y
            return np.stack([xt, yt, z], -1), np.stack([yt, -xt, np.zeros_like(z)], -1)
        xt, zt = c * x - s * z, s * x + c * z   # Ry(-turn): the face gear turned
        return np.stack([xt, y, zt], -1), np.stack([-zt, np.zeros_like(y), xt], -1)

    def distances(self, turns: NDArray, start=None, iterations: int = _PROJECTION_STEPS):
        x, _ = self.turned(turns)
        measure = _pinion_distance if self.side == "approach" else _face_distance
        return measure(self.pair, x, start, iterations)

    def closing_turns(self) -> tuple[NDArray, NDArray]:
        """Each ball's turn of the moving member that brings the flank to ``rho`` of its
        centre (Newton on the signed distance, whose derivative is the flank normal's
        component of the centre's motion; the projection warm-started), and the gap it
        makes, ``lever * turn`` signed as the clearance at the conjugate position
        (negative: the ball overlaps the flank there; +inf: a ball far from the flank)."""
        rho = self.edge.radius
        turns = np.zeros(self.base.shape[:-1])
        a, b, dist, normal = self.distances(turns)
        first = dist - rho
        live = np.isfinite(dist)
        for _ in range(_TURN_STEPS):
            _, rate = self.turned(turns)
            slope = (normal * rate).sum(-1)
            step = np.where(live, -(dist - rho) / np.where(live, slope, 1.0), 0.0)
            turns = turns + step
            a, b, dist, normal = self.distances(turns, (a, b), iterations=3)
            live &= np.isfinite(dist)
            if np.max(np.abs(step)) < _TURN_TOL:
                break
        a, b, dist, normal = self.distances(turns, (a, b))
        live &= np.isfinite(dist)
        self.feet = (a, b, normal)
        gaps = np.where(live, np.sign(first) * np.abs(turns) * self.lever, np.inf)
        return turns, gaps


def _least(values: NDArray, parameter: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Least of ``values`` (rolls, sections) over the sections: the sampled least's index,
    and a parabola's least value and position through it and its two neighbours (the
    sampled one at the ends of the edge). ``parameter``: the sections' positions along
    the edge, (sections,) or (rolls, sections), evenly spaced."""
    i = np.argmin(values, axis=-1)
    j = np.clip(i, 1, values.shape[-1] - 2)
    rows = np.arange(values.shape[0])
    y0, y1, y2 = values[rows, j - 1], values[rows, j], values[rows, j + 1]
    with np.errstate(invalid="ignore"):     # a neighbour far from the flank: +inf
        curve = y0 - 2.0 * y1 + y2
        inner = (i == j) & (curve > 0.0) & np.isfinite(curve)
        shift = np.where(inner, np.clip(0.5 * (y0 - y2) / np.where(inner, curve, 1.0), -1, 1),
                         0.0)
        least = np.where(inner, y1 - 0.25 * (y0 - y2) * shift, values[rows, i])
    grid = np.broadcast_to(parameter, values.shape)
    step = grid[:, 1] - grid[:, 0] if values.shape[-1] > 1 else np.zeros(len(rows))
    where = np.where(inner, grid[rows, j] + shift * step, grid[rows, i])
    return i, least, where


def _first_touch(pair: GearPair, edge: EdgeRounding, side: str, rolls
                 ) -> tuple[_Corner, NDArray, NDArray, NDArray, NDArray, NDArray]:
    """Each roll's first touch: the least closing gap over ``edge``'s sections, then
    again over :data:`_REFINE` sections spanning the least's two neighbouring
    intervals (the clearance along the edge can curve on a scale finer than the
    sections: 10 1/m against gaps of 0.1 um). Returns the refined :class:`_Corner`,
    its turns and gaps, and per roll the touching ball's index in it, the gap, the
    touching position and whether it is an end section of ``edge``."""
    coarse = _Corner(pair, edge, side, rolls)
    _, gaps = coarse.closing_turns()
    i = np.argmin(gaps, axis=-1)
    n = len(edge.parameter)
    lo = edge.parameter[np.maximum(i - 1, 0)]
    hi = edge.parameter[np.minimum(i + 1, n - 1)]
    local = lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, _REFINE)[None, :]
    make = face_edge_rounding if side == "approach" else pinion_edge_rounding
    fine = make(pair, edge.radius, None, local.ravel())
    c = _Corner(pair, fine, side, rolls, groups=_REFINE)
    turns, fine_gaps = c.closing_turns()
    k, least, where = _least(fine_gaps, local)
    return c, turns, fine_gaps, k, least, (where, (i == 0) | (i == n - 1))


def corner_gaps(pair: GearPair, edge: EdgeRounding, side: str, roll_angles) -> NDArray:
    """Corner gaps [m] at several roll angles at once (module docstring): the least
    over the edge's sections of each ball's closing gap, refined between sections
    (:func:`_first_touch`); negative where the edge already overlaps the flank."""
    if side not in CORNER_SIDES:
        raise GeometryError(f"corner side = {side!r}: pick one of {list(CORNER_SIDES)}")
    return _first_touch(pair, edge, side, roll_angles)[4]


def corner_contact(pair: GearPair, edge: EdgeRounding, side: str, roll_angle: float
                   ) -> CornerContact:
    """First touch of ``edge`` (held) and the mating flank at ``roll_angle`` [rad].

    ``edge``: :func:`face_edge_rounding` for the approach side,
    :func:`pinion_edge_rounding` for the recess side. Each ball's closing turn
    is found by Newton; the first to touch is the least, refined between
    sections by a parabola through it and its neighbours.

    Raises
    ------
    GeometryError
        For an unknown side, a roll angle on the flank side of
        :func:`flank_end_roll` (no corner contact there) or more than half an
        angular pitch past it, or when the edge already overlaps the flank there.
    """
    if side not in CORNER_SIDES:
        raise GeometryError(f"corner side = {side!r}: pick one of {list(CORNER_SIDES)}")
    end = flank_end_roll(pair, edge.radius, side)
    # half an angular pitch past the flank's end the next pair has long taken over (the
    # lumped model's corner-gap tables end 6.4 / 8.6 deg past it on the seed set)
    reach = math.pi / pair.pinion.teeth
    far = end + reach if side == "approach" else end - reach
    beyond = end < roll_angle <= far if side == "approach" else far <= roll_angle < end
    if not beyond:
        lo, hi = sorted((end, far))
        raise GeometryError(
            f"roll angle {math.degrees(roll_angle):.4f} deg has no {side} corner contact: the "
            f"flank contact runs to {math.degrees(end):.4f} deg there; allowed roll angles "
            f"{'(' if side == 'approach' else '['}{math.degrees(lo):.4f}, "
            f"{math.degrees(hi):.4f}{']' if side == 'approach' else ')'} deg (up to half an "
            "angular pitch past the flank's end)")
    c, turns, _, k, least, (where, at_end) = _first_touch(pair, edge, side, [roll_angle])
    if least[0] <= 0.0:
        raise GeometryError(
            f"roll angle {math.degrees(roll_angle):.4f} deg: the {side} tip edge already "
            "touches or overlaps the mating flank there")
    i = int(k[0])
    return _touch(c, i, float(turns[0, i]), float(least[0]), float(where[0]), bool(at_end[0]))


def flank_end_roll(pair: GearPair, radius: float, side: str) -> float:
    """Pinion roll angle [rad] where the flank contact ends at ``side`` with a tip-edge
    rounding of ``radius`` on the edge there, in the pinion-on-rack geometry at the
    design radius (the torsional model's path, :mod:`fe_impact.switching.geometry`):
    the face gear's straight flank ends :func:`~fe_impact.gears.gearset.rack_flank_end`
    beyond where its tip line crosses the line of action, the pinion's involute at
    :func:`~fe_impact.gears.gearset.involute_end`. Roll angles grow towards the
    face-gear tip end: ``phi = (r_p sin a - s) / r_b``."""
    pinion = pair.pinion
    a, r_b = pinion.pressure_angle, pinion.base_radius
    if side == "approach":
        s = (pinion.pitch_radius * math.sin(a) - pair.face.tip_height / math.sin(a)
             + rack_flank_end(a, radius))
    else:
        s = involute_end(r_b, pinion.tip_radius, radius)
    return (pinion.pitch_radius * math.sin(a) - s) / r_b


def _touch(c: _Corner, i: int, turn: float, gap: float, section: float, at_end: bool
           ) -> CornerContact:
    """The contact record of ball ``i`` touching at ``turn``."""
    pair, edge = c.pair, c.edge
    a, b, normals = (f[0] for f in c.feet)
    roll, phi2 = float(c.rolls[0]), float(c.phi2[0])
    x, _ = c.turned(np.full(c.base.shape[:-1], turn))
    point = x[0, i] - edge.radius * normals[i]          # moving member's frame
    if c.side == "approach":      # the pinion moved; the face gear holds the edge
        moved = pair.pinion_rotation(roll + turn)
        point = pair.pinion_to_mesh(point[None], roll + turn)[0]
        held = pair.face_rotation(phi2)
        flank = principal_curvatures(
            pair._pinion_surface, a[i], b[i],
            1e-3 * pair.pinion.module, 1e-3 * pair.pinion.module / pair.pinion.base_radius)
    else:                         # the face gear moved; the pinion holds the edge
        moved = pair.face_rotation(phi2 + turn)
        point = pair.face_to_mesh(point[None], phi2 + turn)[0]
        held = pair.pinion_rotation(roll)
        flank = principal_curvatures(
            pair._face_surface, a[i], b[i], 1e-3 * pair.face.module, 1e-3 * pair.face.module)
    flank = flank.rotated(moved)
    normal = moved @ normals[i]
    # the rounding's outward normal at the touch, in the held member's frame
    outward = held.T @ (-normal)
    on_arc = _between(outward, edge.flank_normals[i], edge.land_normals[i])
    margin = min(math.acos(min(1.0, abs(float(outward @ n)))) for n in
                 (edge.flank_normals[i], edge.land_normals[i])) if on_arc else 0.0
    rounding = _edge_curvatures(edge, i, held, -normal)
    relative = relative_curvature(flank, rounding)
    return CornerContact(c.side, roll, gap, turn, section, point, normal, on_arc, at_end,
                         rounding, flank, relative, (float(a[i]), float(b[i])), margin)


def _edge_curvatures(edge: EdgeRounding, i: int, to_mesh: NDArray, outward: NDArray
                     ) -> PrincipalCurvatures:
    """The rounding's principal curvatures at section ``i`` where its outward normal is
    ``outward`` (mesh frame): ``1/rho`` across the edge, and along it the centre
    curve's curvature vector ``k`` seen through the ball, ``-(k . nu) / (1 - rho
    k . nu)`` (a tube about a curve; convex positive)."""
    j = min(max(i, 1), len(edge.parameter) - 2)
    c0, c1, c2 = (edge.centres[k] @ to_mesh.T for k in (j - 1, j, j + 1))
    d1, d2 = np.linalg.norm(c1 - c0), np.linalg.norm(c2 - c1)
    t = (c2 - c0) / (d1 + d2)
    k = 2.0 * ((c2 - c1) / d2 - (c1 - c0) / d1) / (d1 + d2)   # curvature vector
    tangent = t - (t @ outward) * outward
    tangent /= np.linalg.norm(tangent)
    kn = float(k @ outward)
    along = -kn / (1.0 - edge.radius * kn)
    across = np.cross(outward, tangent)
    kappa = np.array([along, 1.0 / edge.radius])
    directions = np.stack([tangent, across])
    order = np.argsort(kappa)
    return PrincipalCurvatures(kappa[order], directions[order], outward.copy())
