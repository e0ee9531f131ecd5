"""Kinematics of a pinion on a face-gear ring, as seen by the torsional model.

A face gear meshing with a spur pinion behaves, at each radius ``L`` of its
face, like a rack whose pressure angle ``alpha_L`` satisfies
``cos(alpha_L) = r_2 cos(alpha0) / L`` (Litvin,
NASA/CR-2000-209909, section 1.5). The face-gear point at ``L`` moves at
``omega_2 L`` along the pinion's transverse plane, and its speed along the
contact normal is ``omega_2 L cos(alpha_L) = omega_2 r_2 cos(alpha0)``, the
same at every radius. Hence the mesh coordinate along the line of action

    x = r_bp theta_p - r_b2 theta_2,   r_bp = r_p cos(alpha0),
                                       r_b2 = r_2 cos(alpha0)

is exact for any contact radius on the face (``r_2`` is the pitch radius
``m N_2 / 2``), the conjugate speed ratio is ``omega_p / omega_2 = r_2 / r_p
= N_2 / N_p``, and a normal force ``F`` gives the torques ``F r_bp`` and
``F r_b2``. The tooth-pair geometry along the line of action (start and end
of contact, contact ratio, what happens at the tooth tips) is that of the
pinion with a rack of pressure angle ``alpha0`` and addendum ``ha* m``,
i.e. the face gear at its design radius ``L = r_2``.

Roll coordinate ``s``: distance along the line of action from the pinion's
base-circle tangency point. Contact of a tooth pair runs from ``s_start``
(face-gear tip) to ``s_end`` (pinion tip). Outside that range the pair can
still touch at a tip corner: the face-gear tip corner on the extended pinion
involute before ``s_start`` (approach), the pinion tip corner on the rack
flank after ``s_end`` (recess). The corner gaps, measured in mesh-coordinate
units, are computed exactly from the planar geometry here and tabulated
(`CornerGap`); a loaded mesh closes them early, which is what makes each
tooth pair's mesh-in an impact.

SI units: m, rad, s.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicSpline
from scipy.optimize import brentq

from fe_impact.gears.gearset import GearSet, involute_end, rack_flank_end

logger = logging.getLogger(__name__)

__all__ = [
    "CORNER_SOURCES",
    "CornerGap",
    "MeshGeometry",
    "corner_reference_roll",
    "default_backlash",
    "mesh_geometry",
    "seed_switching_speed",
    "solid_corner_gaps",
    "switching_speed",
]

#: Largest corner gap tabulated [m]. A tooth pair whose corner gap exceeds it
#: is not looked at; approaches in these drives stay below ~30 um.
CORNER_GAP_CAP = 100e-6
#: Nodes of the corner-gap tables, uniform in ``xi = sqrt(delta / delta_max)``
#: (the approach-side gap behaves like delta^2 with a non-analytic correction
#: near the base circle, which ``xi`` makes smooth enough for a cubic spline).
CORNER_GAP_NODES = 513


def _rotate(angle: NDArray, points: NDArray) -> NDArray:
    """Rotate points, shape (..., 2), counter-clockwise by ``angle`` (broadcast)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * points[..., 0] - s * points[..., 1],
                     s * points[..., 0] + c * points[..., 1]], axis=-1)


def _base_normal(points: NDArray, base_radius: float) -> NDArray:
    """Unit normal, at ``points`` (..., 2), of the involutes of the base circle that
    unwind counter-clockwise: the direction from the point's base-circle tangency
    (the one behind it) to the point.

    The involutes of one base circle are parallel curves: a point's distance to
    any of them along this normal is ``r_b`` times their angle apart, and this
    field is the gradient of that distance, the same whatever the involute.
    """
    radius = np.hypot(points[..., 0], points[..., 1])
    behind = np.arctan2(points[..., 1], points[..., 0]) - np.arccos(base_radius / radius)
    tangency = base_radius * np.stack([np.cos(behind), np.sin(behind)], axis=-1)
    return (points - tangency) / np.sqrt(radius**2 - base_radius**2)[..., None]


def _between(v: NDArray, a: NDArray, b: NDArray) -> NDArray:
    """Whether the directions ``v`` lie in the angle from ``a`` to ``b`` (< 180 deg,
    counter-clockwise or not), ends included to round-off."""
    cross = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    side = np.sign(cross)
    ta = side * (a[..., 0] * v[..., 1] - a[..., 1] * v[..., 0])
    tb = side * (v[..., 0] * b[..., 1] - v[..., 1] * b[..., 0])
    return (ta >= -1e-12) & (tb >= -1e-12)


@dataclass(frozen=True)
class _RackPinionFrame:
    """Planar pinion-on-rack geometry in the pinion's transverse plane.

    Pinion centre at the origin, turning counter-clockwise (positive); rack
    pitch line ``y = r_p`` moving towards ``-x``. The drive line of action
    leaves the base-circle tangency ``T`` in direction ``d``; the pinion
    pushes the rack along ``d``.

    The tip edges may be rounded: the rack's (the face gear's) by a circle of
    radius ``rack_edge_radius`` tangent to its flank and tip line, the
    pinion's by one of ``pinion_edge_radius`` tangent to its involute and
    tip circle. The straight flank and the involute then end where their
    roundings begin (``s_start``, ``s_end``), and beyond these ends the pair
    touches on a rounding. Radii of 0 are sharp corners.

    The pinion angle is 0 when its drive involute crosses the line of action
    at ``s_tip_line``, where the rack's tip line does; the rack is where the
    involute's conjugate flank puts it.
    """

    pitch_radius: float
    alpha: float
    rack_addendum: float
    pinion_tip_radius: float
    rack_edge_radius: float = 0.0
    pinion_edge_radius: float = 0.0

    @property
    def base_radius(self) -> float:
        return self.pitch_radius * math.cos(self.alpha)

    @property
    def direction(self) -> NDArray:
        return np.array([-math.cos(self.alpha), math.sin(self.alpha)])

    @property
    def tangency(self) -> NDArray:
        r, a = self.pitch_radius, self.alpha
        return np.array([r * math.sin(a) * math.cos(a), r * math.cos(a) ** 2])

    @property
    def s_tip_line(self) -> float:
        """Where the rack tip line ``y = r_p - ha m`` crosses the line of action."""
        a = self.alpha
        return self.pitch_radius * math.sin(a) - self.rack_addendum / math.sin(a)

    @property
    def s_start(self) -> float:
        """Where the rack's straight flank ends: on the line of action, the flank
        point below which the rounding begins
        (:func:`~fe_impact.gears.gearset.rack_flank_end`)."""
        return self.s_tip_line + rack_flank_end(self.alpha, self.rack_edge_radius)

    @property
    def s_end(self) -> float:
        """Where the pinion's involute ends: its tip circle, or where the tip
        rounding begins (:func:`~fe_impact.gears.gearset.involute_end`)."""
        return involute_end(self.base_radius, self.pinion_tip_radius, self.pinion_edge_radius)

    def on_line(self, s: ArrayLike) -> NDArray:
        return self.tangency + np.multiply.outer(np.asarray(s, dtype=float), self.direction)

    def flank_polar_angle(self, radius: NDArray) -> NDArray:
        """Polar angle, in the pinion frame at rotation 0, of the drive involute."""
        s = np.sqrt(radius**2 - self.base_radius**2)
        point = _rotate(-(s - self.s_tip_line) / self.base_radius, self.on_line(s))
        return np.arctan2(point[..., 1], point[..., 0])

    def involute_gap(self, points: NDArray) -> NDArray:
        """Signed distance [m] of pinion-frame points ahead of the drive involute,
        along its normal: ``r_b`` times the polar angle between the point and the
        involute at the point's radius (in mesh-coordinate units: turning the
        pinion by ``dtheta`` moves the involute by ``r_b dtheta``)."""
        radius = np.hypot(points[..., 0], points[..., 1])
        angle = np.arctan2(points[..., 1], points[..., 0])
        return self.base_radius * (angle - self.flank_polar_angle(radius))

    @property
    def rack_edge_centre(self) -> NDArray:
        """Centre of the rack's tip rounding at pinion angle 0 (flank through
        ``on_line(s_tip_line)``): ``rho`` on the rack's side of the flank
        (``+d``) and above the tip line. For ``rho = 0`` the sharp corner."""
        rho, d = self.rack_edge_radius, self.direction
        foot = self.on_line(self.s_tip_line)
        y = foot[1] + rho
        x = foot[0] + (rho - (y - foot[1]) * d[1]) / d[0]
        return np.array([x, y])

    def approach_gap(self, delta: ArrayLike) -> NDArray:
        """Gap of the rack's tip edge to the pinion involute, ``delta`` before ``s_start``.

        The rounding touches first where the involute's normal through its
        centre meets it: the gap is the centre's :meth:`involute_gap` less
        the radius, while that normal points into the rounding's arc (between
        the flank's and the tip line's normals); past the arc, its end.
        """
        delta = np.asarray(delta, dtype=float)
        theta = (self.s_start - delta - self.s_tip_line) / self.base_radius
        rack_shift = np.stack([-self.pitch_radius * theta, np.zeros_like(theta)], axis=-1)
        centre = self.rack_edge_centre + rack_shift
        rho = self.rack_edge_radius
        gap = self.involute_gap(_rotate(-theta, centre)) - rho
        if rho == 0.0:
            return gap
        # far from the path (the table's bracket search), parts of the rounding
        # reach inside the base circle, where the involutes end: NaN there
        with np.errstate(invalid="ignore"):
            normal = _base_normal(centre, self.base_radius)
            on_arc = _between(normal, self.direction, np.array([0.0, 1.0]))
            ends = [centre - rho * np.broadcast_to(n, centre.shape)
                    for n in (self.direction, np.array([0.0, 1.0]))]
            end_gap = np.minimum(*(self.involute_gap(_rotate(-theta, e)) for e in ends))
        return np.where(on_arc, gap, end_gap)

    @property
    def pinion_edge_centre(self) -> NDArray:
        """Centre of the pinion's tip rounding in the pinion frame (``rho`` behind
        the involute's end at ``s_end`` along its normal); the corner for 0."""
        turn = -(self.s_end - self.s_tip_line) / self.base_radius
        end = _rotate(np.array(turn), self.on_line(self.s_end))
        return end - self.pinion_edge_radius * _rotate(np.array(turn), self.direction)

    def recess_gap(self, delta: ArrayLike) -> NDArray:
        """Gap of the pinion's tip edge to the rack flank, ``delta`` after ``s_end``.

        The rack flank is a plane normal to ``d``; moving the rack changes the
        mesh coordinate and this distance equally. The rounding's nearest
        point is ``rho`` from its centre along ``d`` while ``d`` points into
        its arc (between the involute's normal at ``s_end`` and the radius to
        the tip circle); past the arc, its end.
        """
        d = self.direction
        s = self.s_end + np.asarray(delta, dtype=float)
        theta = (s - self.s_tip_line) / self.base_radius
        rho = self.pinion_edge_radius
        centre = _rotate(theta, np.broadcast_to(self.pinion_edge_centre, theta.shape + (2,)))
        gap = self.on_line(s) @ d - centre @ d - rho
        if rho == 0.0:
            return gap
        turn = np.array(-(self.s_end - self.s_tip_line) / self.base_radius)
        flank_normal = _rotate(theta + turn, d)
        radial = centre / np.hypot(centre[..., 0], centre[..., 1])[..., None]
        on_arc = _between(np.broadcast_to(d, centre.shape), flank_normal, radial)
        end_gap = np.minimum(*(self.on_line(s) @ d - (centre + rho * n) @ d
                               for n in (flank_normal, radial)))
        return np.where(on_arc, gap, end_gap)


@dataclass(frozen=True)
class CornerGap:
    """Tabulated tip-corner gap ``g(delta)`` beyond one end of the contact path.

    ``g`` is stored against ``xi = sqrt(delta / delta_max)`` as nodal values
    and slopes of a C1 cubic Hermite interpolant (from a cubic spline of the
    exact geometry); the torsional kernel evaluates the same interpolant.

    Attributes
    ----------
    delta_max : float
        Roll distance [m] at which the gap reaches `CORNER_GAP_CAP`.
    values, slopes : ndarray, shape (CORNER_GAP_NODES,)
        ``g`` [m] and ``dg/dxi`` [m] at the nodes ``xi = linspace(0, 1, n)``.
    """

    delta_max: float
    values: NDArray
    slopes: NDArray

    @classmethod
    def from_function(cls, gap, delta_max: float, n: int = CORNER_GAP_NODES) -> CornerGap:
        xi = np.linspace(0.0, 1.0, n)
        return cls.from_samples(xi, gap(delta_max * xi**2), delta_max, n)

    @classmethod
    def from_samples(cls, xi: NDArray, gaps: NDArray, delta_max: float,
                     n: int = CORNER_GAP_NODES) -> CornerGap:
        """The table of a cubic spline through gaps [m] at ``xi = sqrt(delta /
        delta_max)`` (``xi[0] = 0``, where the gap is taken as 0).

        The spline's slope at ``xi = 0`` is held at 0: a tip edge leaves the flank
        tangentially, ``g ~ delta^2 ~ xi^4``. A free end's slope (a few 1e-10 m) made
        ``dg/d delta = (dg/dxi) / (2 delta_max xi)`` unbounded at the path's end, and a
        pair evaluated there under load took a spurious closing speed (metres per
        second) into its damping force.
        """
        spline = CubicSpline(xi, gaps, bc_type=((1, 0.0), "not-a-knot"))
        nodes = np.linspace(0.0, 1.0, n)
        values = spline(nodes)
        values[0] = 0.0
        return cls(delta_max, values, spline(nodes, 1))

    def delta_at(self, gap: float) -> float:
        """Roll distance [m] beyond the path's end at which the table's gap is ``gap``
        [m], ``0 < gap <= CORNER_GAP_CAP``."""
        return brentq(lambda d: float(self(d)[0]) - gap, 1e-9, self.delta_max, xtol=1e-13)

    @cached_property
    def reference_delta(self) -> float:
        """Roll distance [m] beyond the path's end of the tip edge's first touch as the
        corner laws take it (`corner_reference_roll`): where the gap is
        `fe_impact.gears.corner.REFERENCE_GAP`."""
        from fe_impact.gears.corner import REFERENCE_GAP

        return self.delta_at(REFERENCE_GAP)

    def __call__(self, delta: ArrayLike) -> tuple[NDArray, NDArray]:
        """``g(delta)`` [m] and ``dg/d delta`` [-] (the kernel's interpolant; beyond the
        table the end's gap with zero slope, as the kernel holds it)."""
        raw = np.asarray(delta, dtype=float)
        delta = np.clip(raw, 0.0, self.delta_max)
        xi = np.sqrt(delta / self.delta_max)
        n = self.values.size - 1
        i = np.minimum((xi * n).astype(int), n - 1)
        w, step = xi * n - i, 1.0 / n
        h00, h10 = 2 * w**3 - 3 * w**2 + 1, w**3 - 2 * w**2 + w
        h01, h11 = -2 * w**3 + 3 * w**2, w**3 - w**2
        g = (h00 * self.values[i] + h10 * step * self.slopes[i]
             + h01 * self.values[i + 1] + h11 * step * self.slopes[i + 1])
        dg_dw = ((6 * w**2 - 6 * w) * self.values[i] + (3 * w**2 - 4 * w + 1) * step
                 * self.slopes[i] + (6 * w - 6 * w**2) * self.values[i + 1]
                 + (3 * w**2 - 2 * w) * step * self.slopes[i + 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            slope = np.where(xi > 0.0, dg_dw * n / (2.0 * self.delta_max * xi), 0.0)
        return g, np.where(raw > self.delta_max, 0.0, slope)


@dataclass(frozen=True)
class MeshGeometry:
    """Line-of-action geometry of the pinion on a face gear at its design radius.

    Attributes
    ----------
    base_radius : float
        Pinion base radius ``r_bp = r_p cos(alpha0)`` [m].
    pitch_radius : float
        Pinion pitch radius ``r_p`` [m].
    pressure_angle : float
        ``alpha0`` [rad].
    base_pitch : float
        ``p_b = pi m cos(alpha0)`` [m], the roll between successive tooth pairs.
    s_start, s_end : float
        Active contact path along the line of action, from the base
        tangency [m].
    approach, recess : CornerGap
        Tip-corner gaps before ``s_start`` and after ``s_end``.
    """

    base_radius: float
    pitch_radius: float
    pressure_angle: float
    base_pitch: float
    s_start: float
    s_end: float
    approach: CornerGap
    recess: CornerGap

    @property
    def contact_ratio(self) -> float:
        """``(s_end - s_start) / p_b`` [-]: mean number of tooth pairs in contact."""
        return (self.s_end - self.s_start) / self.base_pitch

    @property
    def s_pitch(self) -> float:
        """Pitch point ``r_p sin(alpha0)`` [m], where sliding reverses."""
        return self.pitch_radius * math.sin(self.pressure_angle)

    def gap(self, s: ArrayLike) -> tuple[NDArray, NDArray]:
        """Tooth-pair gap ``g(s)`` [m] and ``dg/ds`` [-]; 0 on the active path.

        Beyond the tabulated ranges the gap is reported as `CORNER_GAP_CAP`
        with zero slope (the pair is out of reach).
        """
        s = np.asarray(s, dtype=float)
        g_in, dg_in = self.approach(self.s_start - s)
        g_out, dg_out = self.recess(s - self.s_end)
        g = np.where(s < self.s_start, g_in, np.where(s > self.s_end, g_out, 0.0))
        dg = np.where(s < self.s_start, -dg_in, np.where(s > self.s_end, dg_out, 0.0))
        return g, dg

    def corner_roll(self, side: str, delta: ArrayLike) -> NDArray:
        """Pinion roll angle [rad] of the position ``delta`` [m] of line of action before
        the path's start (``side="approach"``) or after its end (``"recess"``), in
        :class:`~fe_impact.gears.tca.GearPair`'s sense: from the pitch-point position,
        growing towards the face-gear tip end, ``phi = (s_pitch - s) / r_bp``."""
        delta = np.asarray(delta, dtype=float)
        return self.roll_at(self.s_start - delta if side == "approach" else self.s_end + delta)

    def roll_at(self, s: ArrayLike) -> NDArray:
        """Pinion roll angle [rad] of the place ``s`` [m] on the line of action, in
        :class:`~fe_impact.gears.tca.GearPair`'s sense (`corner_roll`)."""
        return (self.s_pitch - np.asarray(s, dtype=float)) / self.base_radius

    def pair_count(self, roll: float) -> int:
        """Tooth pairs on the active path when the pinion has rolled ``roll`` [m]."""
        phase = roll % self.base_pitch
        length = self.s_end - self.s_start
        return int(np.floor((length - phase) / self.base_pitch)) + 1


def mesh_geometry(gearset: GearSet, stage: int | None = None,
                  corners: str = "planar") -> MeshGeometry:
    """Line-of-action geometry of ``gearset``'s pinion with its face gears.

    The path of contact is the same for every stage: each face gear is a rack
    of pressure angle ``alpha0`` at its design radius, with the face-gear tip
    at ``ha* m`` above the pitch plane (`fe_impact.gears.facegear`), and the
    flanks end where the tip-edge roundings begin. The corner gaps beyond its
    ends are that planar geometry's (``corners="planar"``), or, for
    ``corners="3d"``, stage ``stage``'s three-dimensional first touch of the
    rounded edges over the whole face (:func:`solid_corner_gaps`).
    """
    p = gearset.pinion
    alpha = math.radians(p.pressure_angle_deg)
    frame = _RackPinionFrame(
        pitch_radius=p.pitch_radius,
        alpha=alpha,
        rack_addendum=p.addendum_coeff * p.module,
        pinion_tip_radius=p.pitch_radius + p.addendum_coeff * p.module,
        rack_edge_radius=gearset.face_tip_edge_radius,
        pinion_edge_radius=p.tip_edge_radius,
    )
    if frame.s_start <= 0.0:
        raise ValueError(
            f"the face-gear tip reaches below the pinion base circle (s_start = "
            f"{frame.s_start * 1e3:.3f} mm): the pinion is undercut/interferes"
        )
    if corners not in CORNER_SOURCES:
        raise ValueError(f"corners = {corners!r}: pick one of {list(CORNER_SOURCES)}")
    if corners == "3d":
        if stage is None:
            raise ValueError("corners = '3d' needs the stage")
        tables = [solid_corner_gaps(gearset, stage, side) for side in ("approach", "recess")]
    else:
        tables = []
        for gap in (frame.approach_gap, frame.recess_gap):
            delta_max = brentq(lambda d, f=gap: float(f(d)) - CORNER_GAP_CAP,
                               1e-9, 0.5 * p.module * p.teeth, xtol=1e-15)
            tables.append(CornerGap.from_function(gap, delta_max))
    return MeshGeometry(
        base_radius=frame.base_radius,
        pitch_radius=p.pitch_radius,
        pressure_angle=alpha,
        base_pitch=math.pi * p.module * math.cos(alpha),
        s_start=frame.s_start,
        s_end=frame.s_end,
        approach=tables[0],
        recess=tables[1],
    )


#: Where the torsional model's corner gaps come from (:func:`mesh_geometry`).
CORNER_SOURCES = ("3d", "planar")
#: Roll spans, as multiples of the planar table's, searched for where the
#: three-dimensional corner gap reaches :data:`CORNER_GAP_CAP`.
_SPAN_SEARCH = np.geomspace(0.25, 8.0, 24)
#: Samples of a three-dimensional corner-gap table, uniform in ``xi``, and the
#: sections of the edge they take the least over (refined between sections).
SOLID_CORNER_SAMPLES = 129
SOLID_CORNER_SECTIONS = 121


@lru_cache(maxsize=32)
def solid_corner_gaps(gearset: GearSet, stage: int, side: str) -> CornerGap:
    """Corner-gap table of stage ``stage`` from the three-dimensional first touch.

    :func:`fe_impact.gears.corner.corner_gaps` of the rounded face-gear tip
    edge on the pinion (``side="approach"``) or of the rounded pinion tip edge
    on the face gear (``"recess"``), at roll distances ``delta`` beyond the
    planar path's ends (the torsional model's ``s_start``, ``s_end``), where
    the pinion's roll angle is ``(r_p sin(alpha0) - s) / r_bp``. Negative gaps
    (the edge still on the flank there) count as 0. The span reaches where the
    gap is :data:`CORNER_GAP_CAP`; the table is a cubic spline through
    :data:`SOLID_CORNER_SAMPLES` samples in ``xi``.

    A table takes about a second; it is kept in the user's cache
    (``fe-impact/corners``) under a key of the gear set, the stage, the side,
    the table's settings and the source of the code that computes it.

    Raises
    ------
    GeometryError
        If the edge is sharp (radius 0: no ball to touch with), or the gap does
        not reach the cap within :data:`_SPAN_SEARCH`.
    """
    from fe_impact.runtime import user_cache

    folder = user_cache("corners")
    path = None if folder is None else folder / f"{_corner_key(gearset, stage, side)}.npz"
    if path is not None and path.is_file():
        try:
            with np.load(path) as data:
                return CornerGap(float(data["delta_max"]), data["values"], data["slopes"])
        except (OSError, ValueError, KeyError):
            logger.warning("corner-gap cache %s unreadable; computing the table again", path)
    table = _solid_corner_table(gearset, stage, side)
    if path is not None:
        from fe_impact.atomic import atomic_path

        try:
            with atomic_path(path) as tmp:
                with open(tmp, "wb") as f:
                    np.savez(f, delta_max=table.delta_max, values=table.values,
                             slopes=table.slopes)
        except OSError as exc:
            logger.info("corner-gap table not cached (%s)", exc)
    return table


def _corner_key(gearset: GearSet, stage: int, side: str) -> str:
    """Cache key of a three-dimensional corner-gap table (hex digest)."""
    import hashlib
    import json
    from dataclasses import asdict
    from pathlib import Path

    from fe_impact.gears import corner

    digest = hashlib.sha256()
    digest.update(json.dumps({"gearset": asdict(gearset), "stage": stage, "side": side,
                              "samples": SOLID_CORNER_SAMPLES,
                              "sections": SOLID_CORNER_SECTIONS, "cap": CORNER_GAP_CAP,
                              "spans": _SPAN_SEARCH.tolist(), "nodes": CORNER_GAP_NODES},
                             sort_keys=True, default=repr).encode())
    for module in (corner.__file__, __file__):
        digest.update(Path(module).read_bytes())
    return digest.hexdigest()[:24]


def _solid_corner_table(gearset: GearSet, stage: int, side: str) -> CornerGap:
    """:func:`solid_corner_gaps`, computed."""
    from fe_impact.errors import GeometryError
    from fe_impact.gears.corner import corner_gaps, touching_edge
    from fe_impact.gears.tca import GearPair

    flat = mesh_geometry(gearset)
    radius, key, make = touching_edge(gearset, side)
    if radius <= 0.0:
        raise GeometryError(f"{key}.tip_edge_radius_mm = 0: the three-dimensional corner gaps "
                            "need rounded tip edges; give a radius > 0 or use the planar "
                            "corners")
    pair = GearPair.from_gearset(gearset, stage)
    edge = make(pair, radius, n=SOLID_CORNER_SECTIONS)

    def gap(delta: NDArray) -> NDArray:
        rolls = np.atleast_1d(flat.corner_roll(side, delta))
        return np.maximum(corner_gaps(pair, edge, side, rolls), 0.0)

    planar = getattr(flat, side).delta_max
    spans = planar * _SPAN_SEARCH
    above = np.nonzero(gap(spans) >= CORNER_GAP_CAP)[0]
    if not len(above) or above[0] == 0:
        raise GeometryError(f"stage {stage}: the {side} corner gap does not reach "
                            f"{CORNER_GAP_CAP * 1e6:g} um within {spans[-1] * 1e3:.3g} mm of roll "
                            "beyond the path's end")
    k = above[0]
    # the cap is where the table stops looking, not a physical value: 0.1 um of roll
    delta_max = brentq(lambda d: float(gap(d)[0]) - CORNER_GAP_CAP, spans[k - 1], spans[k],
                       xtol=1e-7)
    xi = np.linspace(0.0, 1.0, SOLID_CORNER_SAMPLES)
    return CornerGap.from_samples(xi, gap(delta_max * xi**2), delta_max)


def default_backlash(module: float, pinion_pitch_radius: float, face_pitch_radius: float) -> float:
    """Total normal backlash ``j_n`` [m] recommended for industrial gears.

    ``j_n,min = (2/3) (0.06 + 0.0005 a + 0.03 m)`` mm with ``a`` and ``m`` in
    mm (ISO/TR 10064-2:1996, AGMA 2002; minimum backlash for industrial
    drives). A face-gear drive has no centre distance; ``a = r_p + r_2``, the
    pinion-axis-to-ring distance scale, is used. 0.14-0.15 mm for the seed's
    stages.
    """
    a_mm = (pinion_pitch_radius + face_pitch_radius) * 1e3
    return (2.0 / 3.0) * (0.06 + 0.0005 * a_mm + 0.03 * module * 1e3) * 1e-3


def switching_speed(pinion_speed: float, teeth_pinion: int, teeth_from: int, teeth_to: int,
                    pinion_base_radius: float) -> float:
    """Closing speed at the first contact after a ratio switch [m/s].

    Rigid kinematics of the rings on one output: before the switch the output
    turns at ``omega_p N_p / N_from``; the new ring's speed along the line of
    action is ``r_b,to omega_out = r_bp omega_p N_to / N_from``, so the teeth
    close at ``r_bp omega_p |N_to / N_from - 1|`` (no load, no drag, constant
    pinion speed between the switch and the contact).

    Parameters
    ----------
    pinion_speed : float
        ``omega_p`` [rad/s].
    teeth_pinion, teeth_from, teeth_to : int
        ``N_p``; face-gear teeth of the ring left and of the ring engaged.
    pinion_base_radius : float
        ``r_bp`` [m].
    """
    del teeth_pinion  # the ratio cancels: kept for symmetry with seed_switching_speed
    return abs(pinion_base_radius * pinion_speed * (teeth_to / teeth_from - 1.0))


def seed_switching_speed(pinion_speed: float, pinion_pitch_radius: float,
                         face_pitch_radius: float, ratio: float, pressure_angle: float) -> float:
    """Seed eq. 5: ``v_s = w_c r_c (1 + 1/q) [1 - cos(a' + g') / cos(a)]`` [m/s].

    With the seed's definitions ``s = r_c tan(alpha)``,
    ``alpha' = arctan(s / r_c)`` (= ``alpha``) and
    ``gamma' = arccos(r_c^2 / (sqrt(r_c^2 + r_f^2) sqrt(r_c^2 + s^2)))``.

    Parameters
    ----------
    pinion_speed : float
        ``omega_c`` [rad/s].
    pinion_pitch_radius, face_pitch_radius : float
        ``r_c`` and ``r_f`` [m], reference radii of the pinion and the working
        face gear.
    ratio : float
        ``q_cfi``, taken as ``N_f / N_c`` of the working (newly engaged) pair.
    pressure_angle : float
        ``alpha`` [rad].
    """
    rc, rf = pinion_pitch_radius, face_pitch_radius
    s = rc * math.tan(pressure_angle)
    alpha_c = math.atan(s / rc)
    gamma_c = math.acos(rc**2 / (math.hypot(rc, rf) * math.hypot(rc, s)))
    factor = 1.0 - math.cos(alpha_c + gamma_c) / math.cos(pressure_angle)
    return pinion_speed * rc * (1.0 + 1.0 / ratio) * factor


@lru_cache(maxsize=64)
def corner_reference_roll(gearset: GearSet, side: str) -> float:
    """Pinion roll angle [rad] at which a tip edge's first touch stands for the corner
    of ``side``: where the torsional model's planar corner gap is
    `fe_impact.gears.corner.REFERENCE_GAP` (the same for every stage: the pinion's
    line of action)."""
    line = mesh_geometry(gearset)
    return float(line.corner_roll(side, getattr(line, side).reference_delta))
