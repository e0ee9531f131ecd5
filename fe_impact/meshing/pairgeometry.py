"""Gmsh geometry of the tooth pair: the two sectors as OCC solids, and the exact flanks.

:func:`add_sectors` builds, in the mesh frame of :mod:`fe_impact.gears.tca`
(the model in millimetres, :data:`MM`), one pinion tooth (or adjacent
teeth, :mod:`fe_impact.meshing.twopair`) over the pinion's face width and
``n_face_teeth`` face-gear teeth cut by the ring of the face width, each
sector with ``neighbour_teeth`` unloaded teeth more on each side, as lofts
through exact sections, and finds the faces of each surface group
(``pinion_flank``, ``pinion_hub``, ``face_flank``, ``face_hub``).
:func:`snap_flanks` moves the mesh nodes of both flanks onto the exact
analytic flanks. The teeth are placed as a
:class:`~fe_impact.gears.pairanalysis.PairAnalysis` says (the pinion turned
back from the TCA position to open the gap). The gmsh model is passed in;
this module does not import gmsh.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from fe_impact.errors import MeshError
from fe_impact.gears.facegear import FaceGearTooth
from fe_impact.gears.pairanalysis import PairAnalysis
from fe_impact.gears.tca import GearPair
from fe_impact.meshing.session import set_nodes

__all__ = ["MM", "add_sectors", "snap_flanks"]

MM = 1e3  # the gmsh model and the mesh file are in millimetres


# -- exact flank models ------------------------------------------------------------------
#: Length [m] over which the face-gear flank's slope in the radius runs out to zero
#: beyond the face's ends (:meth:`_FaceFlank.angle`).
END_BLEND = 2e-3


class _FaceFlank:
    """The face-gear flank ``side=+1`` as meshed (face-gear frame, metres).

    Exact (:meth:`FaceGearTooth.flank`) from the tip down to ``h_ext``, the
    lowest height the shaper involute generates over the whole face (plus a
    micrometre); below it the flank's angular position is continued along its
    tangent at constant radius down to the root plane. Beyond the face's ends
    (the ring cuts the sector there) it leaves along its tangent in the radius
    and levels off over :data:`END_BLEND`, so that the lofts, whose sections
    cross the ends, interpolate a smooth function there (:meth:`angle`).
    """

    def __init__(self, face: FaceGearTooth) -> None:
        self.face = face
        self.h_ext = max(face.height_range(face.face_inner)[0],
                         face.height_range(face.face_outer)[0]) + 1e-6

    def _angle(self, radius: NDArray, height: NDArray) -> NDArray:
        p = self.face.flank(radius, height).points
        return np.arctan2(p[..., 0], p[..., 2])

    def angle(self, radius: NDArray, height: NDArray) -> NDArray:
        """Polar angle ``atan2(x, z)`` [rad] of the flank at radius ``L`` and height ``h``.

        Beyond the face's ends the angle leaves along its tangent in ``L`` (a
        one-sided difference from inside), and its slope runs out linearly to
        zero over :data:`END_BLEND`: C1 across the end, constant beyond the
        blend. Held constant from the end, its kink there put the lofts, whose
        section planes ``z = c`` cross the cylinder ``L = face_inner`` over
        about 0.3 mm of ``L``, up to 12.9 um (median 5.2 um) off the flank
        within 0.15 mm of that end; moved onto the flank, the micron-sized
        elements of a corner contact refined up to it turned over (stage 2's
        recess corner at 180 mm/s, 1.1 mm from the inner end): now 1.8 um,
        median 0.26 um. With the tangent continued without end (1.8 um,
        median 0.12 um) OCC's loft of stage 3's approach corner failed: its
        first sections lie millimetres beyond the inner end (3.7 mm at stage
        1), where that continuation moves the flank furthest; held constant,
        or blended over 1 or 2 mm, the approach and recess corners of the
        three stages all loft (gaps of 1 and 2 um).
        """
        radius, height = np.broadcast_arrays(np.asarray(radius, float), np.asarray(height, float))
        inner, outer = self.face.face_inner, self.face.face_outer
        clipped = np.clip(radius, inner, outer)
        angle = self._angle_on_face(clipped, height)
        beyond = radius != clipped
        if np.any(beyond):
            into = np.where(radius[beyond] < inner, 1.0, -1.0)   # from the end into the face
            step = 1e-6 * into
            slope = (self._angle_on_face(clipped[beyond] + step, height[beyond])
                     - angle[beyond]) / step
            out = np.minimum(np.abs(radius[beyond] - clipped[beyond]), END_BLEND)
            angle[beyond] -= into * slope * (out - out**2 / (2.0 * END_BLEND))
        return angle

    def _angle_on_face(self, radius: NDArray, height: NDArray) -> NDArray:
        """:meth:`angle` at radii within the face."""
        h = np.maximum(height, self.h_ext)
        angle = self._angle(radius, h)
        below = height < self.h_ext
        if np.any(below):
            step = 1e-6
            base = self._angle(radius[below], np.full(below.sum(), self.h_ext))
            up = self._angle(radius[below], np.full(below.sum(), self.h_ext + step))
            angle[below] = base + (height[below] - self.h_ext) * (up - base) / step
        return angle

    def point(self, radius: NDArray, height: NDArray) -> NDArray:
        """Flank points (..., 3): exact (crowning included) above ``h_ext``.

        A node a little beyond a face end that lies close to the undercut limit
        can be above ``h_ext`` but below the lowest generated height at its own
        radius (two-stage drive, stage 1: the inner end 0.05 mm outside the
        undercut limit, a node 0.02 mm beyond it): it has no exact flank point
        and is continued as the nodes below ``h_ext`` are.
        """
        radius, height = np.broadcast_arrays(np.asarray(radius, float), np.asarray(height, float))
        out = np.empty(radius.shape + (3,))
        above = height >= self.h_ext
        if np.any(above):
            out[above] = self.face.flank(radius[above], height[above], strict=False).points
            lost = np.zeros_like(above)
            lost[above] = ~np.isfinite(out[above]).all(axis=-1)
            lost &= (radius < self.face.face_inner) | (radius > self.face.face_outer)
            above &= ~lost
            if not np.isfinite(out[above]).all():   # inside the face: a real error
                self.face.flank(radius[above], height[above])
        if np.any(~above):
            a = self.angle(radius[~above], height[~above])
            r = radius[~above]
            out[~above] = np.stack([r * np.sin(a), height[~above], r * np.cos(a)], axis=-1)
        return out


def _pinion_flank_point(pinion, u: NDArray, radius: NDArray) -> NDArray:
    """Crowned right flank of the pinion at axial position ``u`` and radius (pinion frame).

    With ``P . N = r_b t`` the squared radius of ``P - delta N`` is
    ``g(t) = r_b^2 (1 + t^2) - 2 delta r_b t + delta^2 = r_b^2 + (r_b t - delta)^2``:
    smallest, ``r_b``, at the flank's start ``t* = delta(t*) / r_b`` and rising
    beyond it. The roll angle is found by Newton on ``g(t) = radius^2`` from
    above the root (``g`` is convex there, so the iterates fall monotonically
    onto it) and kept ``>= t*``; a mesh node a hair inside the base circle
    (where the flank meets the root) has no root and lands on the flank's
    start. (Unguarded, such a node was moved onto the mirrored branch, up to
    millimetres away, turning its elements inside out.)
    """
    r_b = pinion.base_radius
    span = pinion.theta_tip - pinion.theta_pitch
    u, radius = np.broadcast_arrays(np.asarray(u, float), np.asarray(radius, float))
    lengthwise = pinion.lengthwise_relief(u)
    start = np.zeros(radius.shape)
    for _ in range(6):   # fixed point t* = delta(t*) / r_b; delta varies slowly with t
        start = (lengthwise + pinion.profile_relief(start)) / r_b
    d_hi = (lengthwise + pinion.profile_relief(np.zeros(radius.shape))
            + pinion.profile_relief(np.full(radius.shape, pinion.theta_tip)))
    # |P| - delta <= radius at the root, so this is at or above it
    theta = np.maximum(np.sqrt(np.maximum(((radius + d_hi) / r_b) ** 2 - 1.0, 0.0)), start)
    for _ in range(50):
        d = lengthwise + pinion.profile_relief(theta)
        d_theta = 2.0 * pinion.profile_crowning * (theta - pinion.theta_pitch) / span**2
        f = r_b**2 * (1 + theta**2) - 2 * d * r_b * theta + d**2 - radius**2
        df = 2.0 * (r_b - d_theta) * (r_b * theta - d)
        step = np.divide(f, df, out=np.zeros_like(f), where=df > 0.0)
        new = np.maximum(theta - step, start)
        step, theta = theta - new, new
        if np.all(np.abs(step) < 1e-15):
            break
    with np.errstate(invalid="ignore"):  # the normal at the very start may be 0/0: unused
        return pinion.flank_surface(u, theta, side=1).points


# -- sections (physical mesh frame, metres) -----------------------------------------------
Piece = tuple[str, NDArray]  # name, points (n, 3); consecutive pieces share end points


#: Largest point spacing along section pieces [m]: the splines through the mapped
#: points must follow the map's transverse variation (C2 steps over ~1 mm).
_POINT_SPACING = 0.2e-3


def _line(a: NDArray, b: NDArray) -> NDArray:
    """Points from ``a`` to ``b`` at most ``_POINT_SPACING`` apart."""
    n = max(2, int(math.ceil(np.linalg.norm(b - a) / _POINT_SPACING)) + 1)
    return a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)


def _turned(xy: NDArray, angle: float) -> NDArray:
    """Transverse points (n, 2) of the pinion frame turned by ``angle`` from ``+y`` towards
    ``+x`` (the tooth that sits at roll angle ``roll - angle``)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * xy[:, 0] + s * xy[:, 1], c * xy[:, 1] - s * xy[:, 0]], axis=-1)


#: Points along a tip-edge rounding's arc in a section.
_ARC_POINTS = 13


def _arc(centre: NDArray, start: NDArray, end: NDArray, n: int = _ARC_POINTS) -> NDArray:
    """Points (n, 2) of the circle about ``centre`` from ``start`` to ``end`` (the shorter
    way; both at the same distance from the centre)."""
    a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
    a1 = math.atan2(end[1] - centre[1], end[0] - centre[0])
    a1 = a0 + (a1 - a0 + math.pi) % (2.0 * math.pi) - math.pi
    radius = float(np.linalg.norm(start - centre))
    t = np.linspace(a0, a1, n)
    out = centre + radius * np.stack([np.cos(t), np.sin(t)], axis=-1)
    out[0], out[-1] = start, end
    return out


def _rounded_pinion_profile(pinion, u: float, radius: float) -> list[tuple[str, NDArray]]:
    """The transverse profile at ``u`` with its right flank's tip edge rounded.

    The rounding (:func:`~fe_impact.gears.corner.pinion_edge_rounding`) leaves the
    crowned flank at :func:`~fe_impact.gears.corner.pinion_rounding_roll` and meets
    the tip cylinder ``r_a``; the pieces ``tip`` (from the left flank's end to the
    rounding, its radius running linearly from that end's to ``r_a``),
    ``round_right`` (the arc) and ``flank_right`` (from the rounding down) replace
    the sharp ones.
    """
    from fe_impact.gears.corner import pinion_rounding_roll

    prof = pinion.transverse_profile(u=u, n_flank=60, n_fillet=30, n_tip=12, n_root=8)
    theta = float(pinion_rounding_roll(pinion, radius, np.array([u]))[0])
    flank = pinion.flank_surface(u, np.linspace(pinion.theta_form, theta, 60), side=1)
    start = flank.points[-1]
    centre = (start - radius * flank.normals[-1])[:2]
    land = centre / np.linalg.norm(centre) * pinion.tip_radius
    left_end = prof.segment("tip").points[0]
    a0, a1 = math.atan2(left_end[0], left_end[1]), math.atan2(land[0], land[1])
    w = np.linspace(0.0, 1.0, 12)
    r = (1.0 - w) * np.linalg.norm(left_end) + w * pinion.tip_radius
    a = (1.0 - w) * a0 + w * a1
    tip = np.stack([r * np.sin(a), r * np.cos(a)], axis=-1)
    tip[0] = left_end
    out = []
    for seg in prof.segments:
        if seg.name == "tip":
            out.append(("tip", tip))
            out.append(("round_right", _arc(centre, land, start[:2])))
        elif seg.name == "flank_right":
            out.append(("flank_right", flank.points[::-1, :2]))
        else:
            out.append((seg.name, seg.points))
    return out


def _joined_roots(pieces: list[tuple[str, NDArray]]) -> list[tuple[str, NDArray]]:
    """The pieces with each run of fillets and root lands made one piece.

    Each tooth's profile ends half-way across the root land on either side
    (``root_left``, ``root_right``: 0.17 mm on the seed pinion), so the
    sections put strips that narrow between the fillets, tangent to them and
    to each other. Lofted, the strips are faces far narrower than the coarse
    elements there, and the volume mesher closed them with flat tetrahedra
    whose four nodes lie on the strips' edges: valid in the stretched space,
    turned over once mapped back, and the mesh was made again with less
    stretch (on the seed set's 27 coarse positions 12 meshes made again, 7
    with the roots joined, the rest at the face gear's tip land; 4.6% fewer
    DOFs, 13% less meshing time). The fillet of one tooth, the land and the
    fillet of the next, one smooth curve, are one piece ``root_land`` (with
    the first tooth's suffix); at a sector's cut, the half land and the
    fillet are one piece ``root_end`` (with the tooth's).
    """
    out: list[tuple[str, NDArray]] = []
    for joined, run in itertools.groupby(
            pieces, key=lambda piece: piece[0].startswith(("fillet_", "root_"))):
        run = list(run)
        if not joined or len(run) == 1:
            out += run
            continue
        first = run[0][0]
        between = first.startswith("fillet_right") and run[-1][0].startswith("fillet_left")
        suffix = first[len("fillet_right" if first.startswith("fillet_right") else
                           "root_left"):]
        out.append((("root_land" if between else "root_end") + suffix,
                    np.concatenate([run[0][1]] + [xy[1:] for _, xy in run[1:]])))
    return out


def _pinion_section(pair: GearPair, roll: float, u: float, rim: float,
                    n_teeth: int = 1, neighbours: int = 0, edge_radius: float = 0.0
                    ) -> list[Piece]:
    """Closed transverse section of the pinion sector at axial position ``u``.

    ``n_teeth`` adjacent teeth: tooth ``k`` is the placed tooth turned back by
    ``k`` angular pitches (it sits where the placed one is at ``roll - k``
    pitches); its pieces carry the suffix ``_k`` (none for ``k = 0``).
    ``neighbours`` more teeth on each side, ``k = -neighbours .. -1`` and
    ``n_teeth .. n_teeth + neighbours - 1``. The sector is cut half a pitch
    beyond its outer teeth. ``edge_radius`` > 0 rounds the placed tooth's right
    flank's tip edge (:func:`_rounded_pinion_profile`; the other edges stay sharp).
    """
    p = pair.pinion
    prof = p.transverse_profile(u=u, n_flank=60, n_fillet=30, n_tip=12, n_root=8)
    a = np.pi / p.teeth
    first, last = -neighbours, n_teeth + neighbours - 1
    left, right = (2 * first - 1) * a, (2 * last + 1) * a   # the cuts
    rim_l = rim * np.array([np.sin(left), np.cos(left)])
    rim_r = rim * np.array([np.sin(right), np.cos(right)])
    seg = [(s.name, s.points) for s in prof.segments]
    rounded = _rounded_pinion_profile(p, u, edge_radius) if edge_radius > 0.0 else seg
    teeth = [(name if k == 0 else f"{name}_{k}", _turned(xy, 2 * k * a) if k else xy)
             for k in range(first, last + 1) for name, xy in (rounded if k == 0 else seg)]
    teeth = _joined_roots(teeth)
    arc = np.linspace(right, left, 1 + 8 * (last - first + 1))
    pieces2d = [
        ("hub_left", _line(rim_l, teeth[0][1][0])),
        *teeth,
        ("hub_right", _line(teeth[-1][1][-1], rim_r)),
        ("hub_rim", rim * np.stack([np.sin(arc), np.cos(arc)], axis=-1)),
    ]
    out = []
    for name, xy in pieces2d:
        pts = np.concatenate([xy, np.full((len(xy), 1), u)], axis=1)
        out.append((name, pair.pinion_to_mesh(pts, roll)))
    return out


def _face_flank_at_plane(flank: _FaceFlank, c: float, heights: NDArray, centre: float,
                         sign: int, face_angle: float) -> NDArray:
    """Points (n, 3) of a face-gear flank in the plane ``z = c`` of the mesh frame.

    The flank of the tooth centred at ``centre`` (face frame), side ``sign``;
    fixed-point iteration on the radius ``L = c / cos(angle)``.
    """
    radius = np.full_like(heights, c)
    for _ in range(30):
        angle = centre + sign * flank.angle(radius, heights) + face_angle
        new = c / np.cos(angle)
        done = np.abs(new - radius).max() < 1e-13
        radius = new
        if done:
            break
    return np.stack([radius * np.sin(angle), heights, radius * np.cos(angle)], axis=-1)


def _face_rounding_in_plane(flank: _FaceFlank, c: float, face_angle: float, tip: float,
                            radius: float) -> tuple[float, NDArray, NDArray]:
    """The placed tooth's plus flank's tip-edge rounding in the plane ``z = c``.

    The circle of ``radius`` tangent to the flank's section (from inside the
    tooth) and to the tip line ``y = tip``: returns the height where it leaves
    the flank, its centre and the tangency on the tip line (``(x, y)``, mesh
    frame). It is the section of the rounding of
    :func:`~fe_impact.gears.corner.face_edge_rounding` to first order in the
    angle between the edge and the plane's normal (about 1 um off it); used
    beyond the face, where the exact rounding is not defined and the ring cuts
    the sector away.
    """
    from scipy.optimize import brentq

    def centre(h: float) -> NDArray:
        step = 1e-7
        a, b = (_face_flank_at_plane(flank, c, np.array([h, h - step]), 0.0, 1, face_angle)
                [:, :2])
        t = (a - b) / np.linalg.norm(a - b)      # up the flank
        n = np.array([t[1], -t[0]])              # out of the tooth: the plus flank is at +x
        return a - radius * n

    h = brentq(lambda h: centre(h)[1] - (tip - radius), tip - 2.0 * radius, tip, xtol=1e-13)
    cen = centre(h)
    return h, cen, np.array([cen[0], tip])


def _face_rounding_section(pair: GearPair, radius: float, c: float, face_angle: float,
                           n: int = _ARC_POINTS) -> NDArray:
    """The plus flank's rounded tip edge (:func:`~fe_impact.gears.corner.face_edge_rounding`)
    cut by the plane ``z = c`` of the mesh frame: points (n, 3) from the tip land to the
    flank, each on a ball's characteristic circle (centre ``C(L)``, radius ``rho``,
    in the plane normal to the edge), the edge position ``L`` found for each so that
    the point lies in the plane (a few fixed-point steps along the edge)."""
    from fe_impact.gears.corner import face_edge_rounding

    psi = np.linspace(1.0, 0.0, n)            # 1: on the tip land, 0: on the flank
    rot = pair.face_rotation(face_angle)
    lengths = np.full(n, float(c))
    step = 1e-6
    for _ in range(6):
        here = face_edge_rounding(pair, radius, lengths=lengths)
        ahead = face_edge_rounding(pair, radius, lengths=lengths + step)
        centre = here.centres @ rot.T
        tangent = (ahead.centres - here.centres) @ rot.T
        tangent /= np.linalg.norm(tangent, axis=1)[:, None]
        e1 = here.flank_normals @ rot.T
        e1 -= (e1 * tangent).sum(axis=1)[:, None] * tangent
        e1 /= np.linalg.norm(e1, axis=1)[:, None]
        land = here.land_normals @ rot.T
        e2 = land - (land * tangent).sum(axis=1)[:, None] * tangent
        e2 -= (e2 * e1).sum(axis=1)[:, None] * e1
        e2 /= np.linalg.norm(e2, axis=1)[:, None]
        span = np.arccos(np.clip((land * e1).sum(axis=1) / np.linalg.norm(land, axis=1),
                                 -1.0, 1.0))
        d = np.cos(psi * span)[:, None] * e1 + np.sin(psi * span)[:, None] * e2
        points = centre + radius * d
        dz = points[:, 2] - c
        slope = (ahead.centres @ rot.T)[:, 2] - centre[:, 2]
        lengths = lengths - dz * step / slope
        if np.abs(dz).max() < 1e-12:
            break
    points[:, 2] = c
    return points


def _face_section(pair: GearPair, flank: _FaceFlank, face_angle: float, c: float,
                  n_teeth: int, bottom: float, neighbours: int = 0,
                  edge_radius: float = 0.0) -> list[Piece]:
    """Closed section of the face-gear sector in the plane ``z = c`` (mesh frame).

    Teeth ``i = 0 .. n_teeth - 1`` counted from the placed one towards ``-x``
    (pieces ``flank_minus_i``, ``tip_i``, ``flank_plus_i``), and
    ``neighbours`` more on each side (``i < 0`` towards ``+x``); the sector is
    cut half a pitch beyond its outer teeth. ``edge_radius`` > 0 rounds the
    placed tooth's plus flank's tip edge (piece ``round_plus_0`` between
    ``tip_0`` and ``flank_plus_0``: :func:`_face_rounding_section` over the face,
    the circle of :func:`_face_rounding_in_plane` beyond it, where the ring cuts
    the sector).
    """
    f = pair.face
    pitch = 2 * np.pi / f.teeth
    heights = np.concatenate([np.linspace(f.root_height, flank.h_ext, 20)[:-1],
                              np.linspace(flank.h_ext, f.tip_height, 60)])
    first, last = -(n_teeth - 1 + neighbours), neighbours   # j = -i, from -x to +x
    left_cut = (first - 0.5) * pitch + face_angle
    right_cut = (last + 0.5) * pitch + face_angle

    def at(angle: float, y: float) -> NDArray:
        return np.array([c * np.tan(angle), y, c])

    pieces: list[Piece] = [("hub_left", _line(at(left_cut, bottom), at(left_cut, f.root_height)))]
    corner = pieces[0][1][-1]
    for j in range(first, last + 1):
        minus = _face_flank_at_plane(flank, c, heights, j * pitch, -1, face_angle)
        if j == 0 and edge_radius > 0.0:
            if f.face_inner + edge_radius < c < f.face_outer - edge_radius:
                arc = _face_rounding_section(pair, edge_radius, c, face_angle)
            else:   # beyond the face (the ring cuts it off): the circle in the plane
                h, centre, land = _face_rounding_in_plane(flank, c, face_angle, f.tip_height,
                                                          edge_radius)
                end = _face_flank_at_plane(flank, c, np.array([h]), 0.0, 1, face_angle)[0]
                arc = np.concatenate([_arc(centre, land[:2], end[:2]),
                                      np.full((_ARC_POINTS, 1), c)], axis=1)
            up = np.concatenate([heights[heights < flank.h_ext],
                                 np.linspace(flank.h_ext, arc[-1, 1], 60)])
            plus = _face_flank_at_plane(flank, c, up, 0.0, 1, face_angle)
            arc[-1] = plus[-1]     # the same point, to round-off
            pieces.append(("root", _line(corner, minus[0])))
            pieces.append(("flank_minus_0", minus))
            pieces.append(("tip_0", _line(minus[-1], arc[0])))
            pieces.append(("round_plus_0", arc))
            pieces.append(("flank_plus_0", plus[::-1]))
            corner = plus[0]
            continue
        plus = _face_flank_at_plane(flank, c, heights, j * pitch, 1, face_angle)
        pieces.append(("root", _line(corner, minus[0])))
        pieces.append((f"flank_minus_{-j}", minus))
        pieces.append((f"tip_{-j}", _line(minus[-1], plus[-1])))
        pieces.append((f"flank_plus_{-j}", plus[::-1]))
        corner = plus[0]
    right = at(right_cut, f.root_height)
    pieces.append(("root", _line(corner, right)))
    pieces.append(("hub_right", _line(right, at(right_cut, bottom))))
    pieces.append(("hub_bottom", _line(at(right_cut, bottom), at(left_cut, bottom))))
    return pieces


# -- gmsh geometry ------------------------------------------------------------------------------
@dataclass
class _Solid:
    """A lofted solid in the gmsh model and where its named faces are."""

    volume: int
    representatives: dict[str, list[NDArray]] = field(default_factory=dict)


def _loft(model, sections: list[list[Piece]], probe: int) -> _Solid:
    """Loft closed sections (mesh frame, metres) into a solid (millimetres).

    ``probe`` is the index of the section whose piece mid-points are kept to
    recognise the lofted faces later (choose one inside the final solid).
    """
    occ = model.occ
    wires, solid = [], _Solid(volume=-1)
    before = set(occ.getEntities())
    for i, sec in enumerate(sections):
        first = occ.addPoint(*(sec[0][1][0] * MM))
        prev, curves = first, []
        for j, (name, pts) in enumerate(sec):
            pts = pts * MM
            last = first if j == len(sec) - 1 else occ.addPoint(*pts[-1])
            tags = [prev] + [occ.addPoint(*q) for q in pts[1:-1]] + [last]
            curves.append(occ.addSpline(tags) if len(pts) > 2 else occ.addLine(prev, last))
            prev = last
            if i == probe:
                solid.representatives.setdefault(name, []).append(pts[len(pts) // 2])
        wires.append(occ.addWire(curves))
    try:
        out = occ.addThruSections(wires, makeSolid=True, makeRuled=False)
    except Exception as exc:   # gmsh raises a bare Exception with OCC's message
        # leave the model as it was: no stray points, curves and wires to mesh
        occ.remove([e for e in occ.getEntities() if e not in before], recursive=True)
        raise MeshError(f"the smooth loft through {len(sections)} sections failed in OCC "
                        f"({exc})") from None
    solid.volume = out[0][1]
    return solid


def _classify(model, solid: _Solid, groups: dict[str, tuple[str, ...]]) -> dict[str, list[int]]:
    """Faces of ``solid`` carrying each group, by the pieces' representative points."""
    faces = [tag for _, tag in model.getBoundary([(3, solid.volume)], oriented=False)]
    boxes = np.array([model.getBoundingBox(2, f) for f in faces]).reshape(-1, 2, 3)
    found: dict[str, list[int]] = {g: [] for g in groups}
    for group, pieces in groups.items():
        for piece in pieces:
            for rep in solid.representatives.get(piece, []):
                # only the faces whose bounding box holds the point (OCC's boxes are
                # padded; the closest-point query is the costly part)
                near = np.all((boxes[:, 0] - 1e-3 <= rep) & (rep <= boxes[:, 1] + 1e-3), axis=1)
                tags = [f for f, keep in zip(faces, near, strict=True) if keep] or faces
                dist = [np.linalg.norm(np.array(model.getClosestPoint(2, f, rep)[0]) - rep)
                        for f in tags]
                best = int(np.argmin(dist))
                if dist[best] > 1e-3:  # mm: the loft passes through its section points
                    raise MeshError(f"face of piece {piece!r} not found ({dist[best]:.3g} mm)")
                if tags[best] not in found[group]:
                    found[group].append(tags[best])
    return found


def _annulus(model, inner: float, outer: float, y0: float, y1: float) -> list[tuple[int, int]]:
    """Ring between radii ``inner`` and ``outer`` [mm] about ``y``, seam turned to ``-z``."""
    occ = model.occ
    big = occ.addCylinder(0, y0, 0, 0, y1 - y0, 0, outer)
    small = occ.addCylinder(0, y0, 0, 0, y1 - y0, 0, inner)
    ring, _ = occ.cut([(3, big)], [(3, small)])
    occ.rotate(ring, 0, 0, 0, 0, 1, 0, np.pi)  # OCC cylinders have their seam on +z here
    return ring


# -- the sectors ---------------------------------------------------------------------------
_PINION_GROUPS = {"pinion_flank": ("flank_right",),
                  "pinion_hub": ("hub_left", "hub_right", "hub_rim")}
_FACE_GROUPS = {"face_flank": ("flank_plus_0",),
                "face_hub": ("hub_left", "hub_right", "hub_bottom")}
#: The contacting flanks' rounded tip edges, when they are rounded.
_PINION_EDGE = {"pinion_edge": ("round_right",)}
_FACE_EDGE = {"face_edge": ("round_plus_0",)}
#: Loft section spacing [modules]. The flanks vary slowly along the face (the
#: crowning is a parabola), and the lofts are exact at the sections: measured
#: flank deviation below 0.01 um between sections at this spacing.
_SECTION_MODULES = 0.5


def _stations_through(lo: float, hi: float, at: float, step: float,
                      fine: tuple[float, float] | None = None) -> NDArray:
    """About ``step``-spaced positions over ``[lo, hi]``, one of them at ``at``; with
    ``fine = (half_width, fine_step)``, ``fine_step``-spaced within ``half_width`` of
    ``at`` (a corner contact: the lofts are exact at the sections only, and its
    elements are microns small). A coarse position closer than half a fine step to
    the fine window is left out: a slab thinner than the window's own steps adds a
    section without adding accuracy (stage 3's recess corner had one 45 um wide)."""
    if fine is not None:
        half, small = fine
        a, b = max(lo, at - half), min(hi, at + half)
        core = np.concatenate([np.linspace(a, at, max(2, int(math.ceil((at - a) / small)) + 1)),
                               np.linspace(at, b, max(2, int(math.ceil((b - at) / small))
                                                      + 1))[1:]])
        outer = [x for x in _stations_through(lo, hi, at, step)
                 if x < a - 0.5 * small or x > b + 0.5 * small]
        return np.sort(np.concatenate([core, outer]))
    left = np.linspace(lo, at, max(2, int(math.ceil((at - lo) / step)) + 1))
    right = np.linspace(at, hi, max(2, int(math.ceil((hi - at) / step)) + 1))
    return np.concatenate([left, right[1:]])


#: Corner contacts: loft sections every FINE_STEP [m] within FINE_HALF of the contact.
FINE_HALF, FINE_STEP = 2.5e-3, 0.5e-3


def _add_pinion(model, pair: GearPair, analysis: PairAnalysis, n_teeth: int = 1,
                groups: dict[str, tuple[str, ...]] | None = None, edge_radius: float = 0.0
                ) -> tuple[int, dict[str, list[int]]]:
    """The pinion sector over its face width (one loft of transverse sections).

    ``n_teeth`` adjacent teeth (:func:`_pinion_section`); ``groups`` maps each
    surface group to its section pieces (default :data:`_PINION_GROUPS`, with
    ``pinion_edge`` when ``edge_radius`` rounds the contacting flank's tip edge).
    """
    if groups is None:
        groups = {**_PINION_GROUPS, **(_PINION_EDGE if edge_radius > 0.0 else {})}
    p, spec = pair.pinion, analysis.spec
    rim = p.root_radius - spec.rim_modules * p.module
    u_c = float(np.clip(analysis.contact.point[2] - pair.z0, -0.4 * p.face_width,
                        0.4 * p.face_width))
    fine = (FINE_HALF, FINE_STEP) if spec.contact != "flank" else None
    us = _stations_through(-0.5 * p.face_width, 0.5 * p.face_width, u_c,
                           _SECTION_MODULES * p.module, fine)
    sections = [_pinion_section(pair, analysis.pinion_roll_placed, u, rim, n_teeth,
                                spec.neighbour_teeth, edge_radius) for u in us]
    solid = _loft(model, sections, int(np.argmin(np.abs(us - u_c))))
    model.occ.synchronize()
    return solid.volume, _classify(model, solid, groups)


def _add_face_gear(model, pair: GearPair, analysis: PairAnalysis,
                   groups: dict[str, tuple[str, ...]] | None = None, edge_radius: float = 0.0
                   ) -> tuple[int, dict[str, list[int]]]:
    """The face-gear sector: a loft of sections ``z = const``, cut by the ring.

    ``groups`` maps each surface group to its section pieces (default
    :data:`_FACE_GROUPS`, with ``face_edge`` when ``edge_radius`` rounds the
    contacting flank's tip edge; tooth ``j`` of the sector, counted from the
    placed one towards ``-x``, has the pieces ``flank_plus_j`` and ``flank_minus_j``).
    """
    if groups is None:
        groups = {**_FACE_GROUPS, **(_FACE_EDGE if edge_radius > 0.0 else {})}
    f, spec, contact = pair.face, analysis.spec, analysis.contact
    flank = _FaceFlank(f)
    bottom = f.root_height - spec.rim_modules * f.module
    pitch = 2 * np.pi / f.teeth
    widest = (spec.n_face_teeth - 0.5 + spec.neighbour_teeth) * pitch + abs(contact.face_angle)
    margin = 0.5 * f.module
    z_c = contact.point[2]
    fine = (FINE_HALF, FINE_STEP) if spec.contact != "flank" else None
    cs = _stations_through(f.face_inner * np.cos(widest) - margin, f.face_outer + margin, z_c,
                           _SECTION_MODULES * f.module, fine)
    angle = contact.face_angle
    sections = [_face_section(pair, flank, angle, c, spec.n_face_teeth, bottom,
                              spec.neighbour_teeth, edge_radius) for c in cs]
    solid = _loft(model, sections, int(np.argmin(np.abs(cs - z_c))))
    ring = _annulus(model, f.face_inner * MM, f.face_outer * MM, (bottom - margin) * MM,
                    (f.tip_height + margin) * MM)
    out, _ = model.occ.intersect([(3, solid.volume)], ring)
    model.occ.synchronize()
    if len(out) != 1:
        raise MeshError(f"face-gear sector: the cut by the ring gave {len(out)} volumes")
    solid.volume = out[0][1]
    return solid.volume, _classify(model, solid, groups)


def add_sectors(model, pair: GearPair, analysis: PairAnalysis, *, pinion_teeth: int = 1,
                pinion_groups: dict[str, tuple[str, ...]] | None = None,
                face_groups: dict[str, tuple[str, ...]] | None = None,
                edge_radii: tuple[float, float] = (0.0, 0.0),
                ) -> tuple[dict[str, int], dict[str, list[int]]]:
    """Both sectors in ``model`` (OCC, millimetres), placed as ``analysis`` says.

    Returns the volume tags (``pinion``, ``face_gear``) and the surface tags
    of each surface group. ``pinion_teeth`` adjacent pinion teeth (the placed
    one and the next ones turned back by one angular pitch each); the groups
    map surface-group names to section pieces (see :func:`_add_pinion` and
    :func:`_add_face_gear`; default: one flank per sector and the hubs).
    ``edge_radii`` (pinion, face gear) [m] round the contacting flanks' tip edges
    (0: sharp), which then form the groups ``pinion_edge`` and ``face_edge``.
    """
    pinion, pinion_faces = _add_pinion(model, pair, analysis, pinion_teeth, pinion_groups,
                                       edge_radii[0])
    face, face_faces = _add_face_gear(model, pair, analysis, face_groups, edge_radii[1])
    extra = [(3, t) for _, t in model.getEntities(3) if t not in (pinion, face)]
    if extra:  # construction leftovers of the boolean
        model.occ.remove(extra, recursive=True)
        model.occ.synchronize()
    return {"pinion": pinion, "face_gear": face}, {**pinion_faces, **face_faces}


def free_entities(model, volumes: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The points, curves and surfaces that bound none of ``volumes``: the sections'
    interpolation points and wires stay in the model after the lofts (some 20k
    points on a sector pair), and every one would be meshed, mapped and written."""
    keep, level = set(volumes), list(volumes)
    for _ in range(3):
        level = sorted({(d, abs(t)) for d, t in
                        model.getBoundary(level, combined=False, oriented=False)})
        keep.update(level)
    return [e for e in model.getEntities() if e[0] < 3 and e not in keep]


# -- the mesh on the exact flanks --------------------------------------------------------
def _surface_nodes(model, surfaces: list[int]) -> tuple[NDArray, NDArray]:
    """Node tags and coordinates [m] of ``surfaces``, their boundaries included."""
    nodes, coords = [], []
    for surface in surfaces:
        t, c, _ = model.mesh.getNodes(2, surface, includeBoundary=True)
        nodes.append(t)
        coords.append(c.reshape(-1, 3))
    nodes, first = np.unique(np.concatenate(nodes), return_index=True)
    return nodes, np.concatenate(coords)[first] / MM


def snap_flanks(model, pair: GearPair, analysis: PairAnalysis,
                groups: dict[str, list[int]], edge_radii: tuple[float, float] = (0.0, 0.0)
                ) -> NDArray:
    """Move the mesh nodes of both flanks onto the exact flanks, and those of rounded tip
    edges (groups ``pinion_edge``, ``face_edge``, radii ``edge_radii``) onto the exact
    roundings; largest move per flank [m].

    ``groups`` are the surface tags of :func:`add_sectors`. A node on the line where
    a rounding leaves its flank stays on the flank.
    """
    moves = []
    corner = analysis.spec.contact != "flank"
    for group, snap in (("pinion_flank", _snap_pinion), ("face_flank", _snap_face)):
        nodes, x = _surface_nodes(model, groups[group])
        if corner:
            # a corner contact's solids are exact where their sections are fine; beyond,
            # the narrow rounded tip's elements do not survive a move onto the flank
            near = np.abs(x[:, 2] - analysis.contact.point[2]) < FINE_HALF
            nodes, x = nodes[near], x[near]
        exact = snap(pair, analysis, x)
        moves.append(float(np.linalg.norm(exact - x, axis=1).max(initial=0.0)))
        set_nodes(nodes, exact * MM)
        edge = group.replace("flank", "edge")
        if edge not in groups:
            continue
        edge_nodes, y = _surface_nodes(model, groups[edge])
        # only where the lofts have their fine sections (FINE_HALF of the contact): there
        # the rounding is built exact to 0.01 um; beyond, between sections 1.5 mm apart,
        # it is off by up to 20 um, and moving a node that far turns elements over
        keep = (~np.isin(edge_nodes, nodes)
                & (np.abs(y[:, 2] - analysis.contact.point[2]) < FINE_HALF))
        radius = edge_radii[0] if group.startswith("pinion") else edge_radii[1]
        on_edge = _snap_edge(pair, analysis, group.split("_")[0], radius, y[keep])
        moves[-1] = max(moves[-1], float(np.linalg.norm(on_edge - y[keep], axis=1).max(
            initial=0.0)))
        set_nodes(edge_nodes[keep], on_edge * MM)
    return np.array(moves)


def _snap_edge(pair: GearPair, analysis: PairAnalysis, body: str, radius: float,
               x: NDArray) -> NDArray:
    """Points ``x`` (n, 3) [m, mesh frame] moved onto the exact rounding of ``body``'s
    tip edge (:func:`~fe_impact.gears.corner.pinion_edge_rounding` or
    :func:`~fe_impact.gears.corner.face_edge_rounding`): each onto the ball of the
    centre nearest it, along the line from that centre, which is the rounding's normal
    there (the centre curve sampled every 10 um, the nearest refined by a parabola
    through it and its neighbours)."""
    from fe_impact.gears.corner import face_edge_rounding, pinion_edge_rounding

    if not len(x):
        return x
    if body == "pinion":
        roll = analysis.pinion_roll_placed
        rot = pair.pinion_rotation(roll)
        local = (x - np.array([0.0, pair.pinion.pitch_radius, pair.z0])) @ rot
        p = pair.pinion
        u = np.clip(local[:, 2], -0.5 * p.face_width, 0.5 * p.face_width)
        edge = pinion_edge_rounding(pair, radius, axial=u)
        c = edge.centres
        d = local - c
        d[:, 2] = 0.0                      # in the transverse plane of the node
        on = c + radius * d / np.linalg.norm(d, axis=1)[:, None]
        on[:, 2] = local[:, 2]
        return pair.pinion_to_mesh(on, roll)
    angle = analysis.contact.face_angle
    local = x @ pair.face_rotation(angle)
    f = pair.face
    n = max(3, int(math.ceil((f.face_outer - f.face_inner) / 1e-5)) + 1)
    edge = face_edge_rounding(pair, radius, n=n)
    from scipy.spatial import cKDTree

    i = np.clip(cKDTree(edge.centres).query(local)[1], 1, n - 2)
    d0, d1, d2 = (np.linalg.norm(local - edge.centres[i + k], axis=1) for k in (-1, 0, 1))
    den = d0 - 2.0 * d1 + d2
    shift = np.clip(np.divide(0.5 * (d0 - d2), den, out=np.zeros_like(den), where=den > 0),
                    -1.0, 1.0)
    lengths = edge.parameter[i] + shift * (edge.parameter[1] - edge.parameter[0])
    c = face_edge_rounding(pair, radius, lengths=lengths).centres
    d = local - c
    on = c + radius * d / np.linalg.norm(d, axis=1)[:, None]
    return pair.face_to_mesh(on, angle)


def _snap_pinion(pair: GearPair, analysis: PairAnalysis, x: NDArray) -> NDArray:
    rot = pair.pinion_rotation(analysis.pinion_roll_placed)
    local = (x - np.array([0.0, pair.pinion.pitch_radius, pair.z0])) @ rot
    exact = _pinion_flank_point(pair.pinion, local[:, 2], np.hypot(local[:, 0], local[:, 1]))
    return pair.pinion_to_mesh(exact, analysis.pinion_roll_placed)


def _snap_face(pair: GearPair, analysis: PairAnalysis, x: NDArray) -> NDArray:
    angle = analysis.contact.face_angle
    local = x @ pair.face_rotation(angle)
    exact = _FaceFlank(pair.face).point(np.hypot(local[:, 0], local[:, 2]), local[:, 1])
    return pair.face_to_mesh(exact, angle)
