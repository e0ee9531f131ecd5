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
from scipy.optimize import brentq

from fe_impact.errors import GeometryError
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
    "CornerContact",
    "EdgeRounding",
    "corner_contact",
    "face_edge_rounding",
    "midplane_rounding",
    "pinion_edge_rounding",
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
    r_a = pinion.tip_radius
    if axial is None:
        face = pair.face
        axial = np.linspace(max(-0.5 * pinion.face_width, face.face_inner - pair.z0),
                            min(0.5 * pinion.face_width, face.face_outer - pair.z0), n)
    axial = np.asarray(axial, float)
    n = len(axial)
    r_b = pinion.base_radius
    low = np.full(n, math.sqrt(max((r_a - 2.0 * radius) ** 2 / r_b**2 - 1.0, 0.0)))
    high = np.full(n, pinion.theta_tip)

    def centres(theta: NDArray) -> tuple[NDArray, NDArray]:
        s = pinion.flank_surface(axial, theta, side=1)
        return s.points - radius * s.normals, s.normals

    for _ in range(_HALVINGS):
        mid = 0.5 * (low + high)
        c, _ = centres(mid)
        outside = np.hypot(c[:, 0], c[:, 1]) > r_a - radius
        low, high = np.where(outside, low, mid), np.where(outside, mid, high)
    c, normals = centres(0.5 * (low + high))
    land = np.zeros_like(c)
    land[:, :2] = c[:, :2] / np.hypot(c[:, 0], c[:, 1])[:, None]
    return EdgeRounding(radius, axial, c, normals, land)


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
def _project(surface, x: NDArray, a: NDArray, b: NDArray, steps: tuple[float, float]
             ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Foot of points ``x`` (n, 3) on ``surface(a, b) -> (points, normals)`` by Newton
    on the tangency conditions ``(x - r) . r_a = (x - r) . r_b = 0`` (Gauss-Newton:
    the surface's second derivatives are dropped, exact at the solution);
    returns the parameters, the feet's signed distance along the outward normal
    and the normals."""
    ha, hb = steps
    for _ in range(_PROJECTION_STEPS):
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


def _pinion_distance(pair: GearPair, x: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Signed distance of pinion-frame points to the pinion's flank (outward positive)."""
    pinion = pair.pinion
    radius = np.hypot(x[:, 0], x[:, 1])
    theta = np.sqrt(np.maximum(radius**2 / pinion.base_radius**2 - 1.0, 1e-6))
    m = pinion.module

    def surface(u, t):
        s = pinion.flank_surface(u, t, side=1)
        return s.points, s.normals

    return _project(surface, x, x[:, 2].copy(), theta, (1e-3 * m, 1e-3 * m / pinion.base_radius))


def _face_distance(pair: GearPair, x: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Signed distance of face-gear-frame points to its flank (outward positive)."""
    face = pair.face
    m = face.module

    def surface(length, height):
        s = face.flank(length, height, side=1)
        return s.points, s.normals

    return _project(surface, x, np.hypot(x[:, 0], x[:, 2]), x[:, 1].copy(), (1e-3 * m, 1e-3 * m))


def _rz(angle: float) -> NDArray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _ry(angle: float) -> NDArray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


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

    def ellipse(self, force: float, e_star: float) -> ContactEllipse:
        """Hertz ellipse of the touch under ``force`` [N] (``E*`` [Pa])."""
        return contact_ellipse(self.relative, force, e_star)

    def to_dict(self) -> dict[str, object]:
        """JSON-friendly record (SI units, angles in rad)."""
        return {
            "side": self.side, "roll_angle_rad": self.roll_angle, "gap_m": self.gap,
            "turn_rad": self.turn, "section_m": self.section, "point_m": self.point.tolist(),
            "normal": self.normal.tolist(), "on_rounding": self.on_rounding,
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
    """One side's geometry at one roll angle: the held edge's ball centres, in the
    moving member's frame, as functions of its extra turn."""

    def __init__(self, pair: GearPair, edge: EdgeRounding, side: str, roll: float):
        self.pair, self.edge, self.side, self.roll = pair, edge, side, roll
        phi2 = pair.nominal_face_angle(roll)
        self.phi2 = phi2
        if side == "approach":   # face-gear centres into the pinion frame at roll
            mesh = pair.face_to_mesh(edge.centres, phi2)
            self.base = (mesh - [0.0, pair.pinion.pitch_radius, pair.z0]) @ pair.pinion_rotation(
                roll)
            self.lever = pair.pinion.base_radius
        else:                    # pinion centres into the face-gear frame at phi2
            mesh = pair.pinion_to_mesh(edge.centres, roll)
            self.base = mesh @ pair.face_rotation(phi2)
            self.lever = pair.face.pitch_radius * math.cos(pair.face.pressure_angle)

    def turned(self, turn: float) -> NDArray:
        """The centres as the moving member sees them after it turned by ``turn``."""
        rot = _rz(-turn) if self.side == "approach" else _ry(-turn)
        return self.base @ rot.T

    def distances(self, turn: float):
        x = self.turned(turn)
        if self.side == "approach":
            return _pinion_distance(self.pair, x)
        return _face_distance(self.pair, x)

    def clearance(self, turn: float) -> float:
        """Least distance of a ball to the moving flank, less ``rho``."""
        return float(np.min(self.distances(turn)[2])) - self.edge.radius


def corner_contact(pair: GearPair, edge: EdgeRounding, side: str, roll_angle: float
                   ) -> CornerContact:
    """First touch of ``edge`` (held) and the mating flank at ``roll_angle`` [rad].

    ``edge``: :func:`face_edge_rounding` for the approach side,
    :func:`pinion_edge_rounding` for the recess side. The closing turn is
    bracketed from 0 and found by ``brentq`` on the least ball clearance (a
    continuous, decreasing function of the turn while the balls approach);
    the touching section is refined by a parabola through the least sampled
    clearance and its neighbours.

    Raises
    ------
    GeometryError
        For an unknown side, or when no turn of up to a tenth of a pitch
        brings the edge onto the flank, or when the pair already overlaps
        (the roll angle is inside the path of contact).
    """
    if side not in CORNER_SIDES:
        raise GeometryError(f"corner side = {side!r}: pick one of {list(CORNER_SIDES)}")
    c = _Corner(pair, edge, side, roll_angle)
    if c.clearance(0.0) <= 0.0:
        raise GeometryError(
            f"roll angle {math.degrees(roll_angle):.4f} deg: the {side} tip edge already "
            "touches or overlaps the mating flank there (inside the path of contact)")
    # the closing sense: the one in which the least clearance falls
    probe = 1e-6
    sense = 1.0 if c.clearance(probe) < c.clearance(-probe) else -1.0
    teeth = pair.pinion.teeth if side == "approach" else pair.face.teeth
    limit = 0.1 * 2.0 * math.pi / teeth
    hi = 1e-5
    while c.clearance(sense * hi) > 0.0:
        hi *= 2.0
        if hi > limit:
            raise GeometryError(
                f"roll angle {math.degrees(roll_angle):.4f} deg: the {side} tip edge does not "
                f"reach the mating flank within a tenth of a pitch; allowed roll angles lie "
                "just outside the path of contact")
    turn = sense * brentq(lambda t: c.clearance(sense * t), 0.0, hi, xtol=1e-15, rtol=1e-14)
    return _touch(c, turn)


def _touch(c: _Corner, turn: float) -> CornerContact:
    """The contact record at the closing ``turn``."""
    pair, edge = c.pair, c.edge
    a, b, dist, normals = c.distances(turn)
    i = int(np.argmin(dist))
    j = min(max(i, 1), len(dist) - 2)
    # the touching section: a parabola through the least clearance and its neighbours
    y0, y1, y2 = dist[j - 1], dist[j], dist[j + 1]
    curve = y0 - 2.0 * y1 + y2
    shift = float(np.clip(0.5 * (y0 - y2) / curve, -1.0, 1.0)) if curve > 0.0 else 0.0
    section = float(edge.parameter[j] + shift * (edge.parameter[1] - edge.parameter[0]))
    point = c.turned(turn)[i] - edge.radius * normals[i]   # moving member's frame
    if c.side == "approach":      # the pinion moved; the face gear holds the edge
        moved = pair.pinion_rotation(c.roll + turn)
        point = pair.pinion_to_mesh(point[None], c.roll + turn)[0]
        held = pair.face_rotation(c.phi2)
        flank = principal_curvatures(
            lambda u, t: _surface(pair.pinion.flank_surface(u, t, side=1)), a[i], b[i],
            1e-3 * pair.pinion.module, 1e-3 * pair.pinion.module / pair.pinion.base_radius)
    else:                         # the face gear moved; the pinion holds the edge
        moved = pair.face_rotation(c.phi2 + turn)
        point = pair.face_to_mesh(point[None], c.phi2 + turn)[0]
        held = pair.pinion_rotation(c.roll)
        flank = principal_curvatures(
            lambda length, h: _surface(pair.face.flank(length, h, side=1)), a[i], b[i],
            1e-3 * pair.face.module, 1e-3 * pair.face.module)
    flank = flank.rotated(moved)
    normal = moved @ normals[i]
    # the rounding's outward normal at the touch, in the held member's frame
    outward = held.T @ (-normal)
    on_arc = _between(outward, edge.flank_normals[i], edge.land_normals[i])
    rounding = _edge_curvatures(edge, i, held, -normal)
    relative = relative_curvature(flank, rounding)
    return CornerContact(c.side, c.roll, abs(turn) * c.lever, turn, section, point, normal,
                         on_arc, i in (0, len(dist) - 1), rounding, flank, relative)


def _surface(sample) -> tuple[NDArray, NDArray]:
    return sample.points, sample.normals


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
