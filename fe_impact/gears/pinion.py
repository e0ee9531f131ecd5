"""Involute spur pinion: transverse tooth profile and crowned flank surface.

The pinion (the seed's "cylindrical gear") is a standard involute spur gear
without profile shift, cut by a rack with a rounded tip, so its root fillet
is the trochoidal envelope of the rack's tip round (Litvin & Fuentes, *Gear
Geometry and Applied Theory*, 2nd ed., 2004, chapter on spur involute
gears). SI units: m, rad.

Pinion frame ``S_p``: ``z`` along the pinion axis, origin at mid-face on the
axis; the reference tooth is centred on ``+y`` (symmetric about the plane
``x = 0``); its right flank (``side=+1``) faces ``+x``, the left flank
(``side=-1``) is its mirror image. Polar angles ``sigma = atan2(x, y)`` are
measured from ``+y`` towards ``+x``. Normals point out of the material.

Involute parameter: the roll angle ``theta = tan(alpha_r)`` (the unwound
length of the generating line is ``r_b theta``); the radius is
``r_b sqrt(1 + theta^2)``.

Modifications (both remove material along the flank normal):

- lengthwise crowning, parabolic in the axial position ``u``:
  ``delta_l(u) = lengthwise_crowning (2 u / b)^2`` (zero at mid-face, the full
  amount at both ends of the face width ``b``);
- profile crowning, parabolic in roll length: ``delta_p(theta) =
  profile_crowning ((theta - theta_pitch) / (theta_tip - theta_pitch))^2``
  (zero at the pitch circle, the full amount at the tip), close to what a
  rack cutter with a parabolic profile gives (Litvin & Fuentes 2004).
  The root fillet is shifted by the relief at the root-form point, so the
  section stays continuous; with profile crowning its tangent turns there
  by ``delta_p'(theta_form) / (r_b theta_form)`` (0.05 rad for 5 um of
  crowning on the seed pinion, over a micrometre-sized region far from the
  contact zone); without it the junction is tangent.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fe_impact.errors import GeometryError

logger = logging.getLogger(__name__)

# ISO 53 quotes rho_f = 0.38 m for the 20 deg, c* = 0.25 rack, which rounds the
# working-depth bound 0.37995 up; allow such rounding (0.1 %: the root-form
# point moves by less than 0.1 um at m = 3).
_FILLET_BOUND_SLACK = 1e-3

__all__ = [
    "PinionTooth",
    "ProfileSegment",
    "SurfaceSample",
    "ToothProfile",
    "involute_function",
    "max_fillet_radius_coeff",
    "min_teeth_without_undercut",
]


def involute_function(alpha: ArrayLike) -> NDArray[np.float64]:
    """Involute function ``inv(alpha) = tan(alpha) - alpha`` [rad]."""
    alpha = np.asarray(alpha, dtype=float)
    return np.tan(alpha) - alpha


def _rack_tip_centre(
    module: float, alpha: float, addendum_coeff: float, clearance_coeff: float, rho: float
) -> tuple[float, float]:
    """Centre ``(X_c, Y_c)`` [m] of the generating rack's tip round.

    Rack frame: pitch line ``Y = 0``, the rack tooth (which cuts one tooth
    space) centred on ``X = 0`` and pointing to ``-Y``; its right flank is
    ``X = pi m / 4 + Y tan(alpha)`` and its tip line ``Y = -(ha + c) m``. The
    round of radius ``rho`` is tangent to both.
    """
    y_c = -(addendum_coeff + clearance_coeff) * module + rho
    x_c = np.pi * module / 4.0 + y_c * np.tan(alpha) - rho / np.cos(alpha)
    return float(x_c), float(y_c)


def max_fillet_radius_coeff(
    pressure_angle_deg: float, addendum_coeff: float, clearance_coeff: float
) -> float:
    """Largest rack tip-round radius ``rho_f / m`` this rack profile allows.

    Two bounds: the round must end on the straight rack flank no higher than
    the addendum line (``rho <= c m / (1 - sin alpha)``, so the involute spans
    the working depth; 0.38 for c* = 0.25 and 20 deg, ISO 53 profile A), and
    the two rounds of one rack tooth must not overlap (``X_c >= 0``). The
    first bound is relaxed by 0.1 % so that ISO 53's rounded 0.38 passes.

    Parameters
    ----------
    pressure_angle_deg : float
        Rack (pressure) angle [deg].
    addendum_coeff, clearance_coeff : float
        ``ha*`` and ``c*`` [-].

    Returns
    -------
    float
        The bound on ``rho_f / m`` [-].
    """
    alpha = np.radians(pressure_angle_deg)
    by_working_depth = clearance_coeff / (1.0 - np.sin(alpha))
    # X_c(rho) = pi/4 - (ha + c - rho) tan(alpha) - rho / cos(alpha) is linear in rho.
    slope = np.tan(alpha) - 1.0 / np.cos(alpha)
    by_tooth_width = (np.pi / 4.0 - (addendum_coeff + clearance_coeff) * np.tan(alpha)) / -slope
    return float(min(by_working_depth * (1.0 + _FILLET_BOUND_SLACK), by_tooth_width))


def min_teeth_without_undercut(
    pressure_angle_deg: float,
    addendum_coeff: float,
    clearance_coeff: float,
    fillet_radius_coeff: float,
) -> float:
    """Smallest (real) tooth count whose involute the rack does not undercut.

    The rack's straight flank ends at depth ``d = (ha + c) m - rho (1 - sin
    alpha)`` below the pitch line; no undercut while ``d <= r sin^2(alpha)``
    with ``r = m z / 2`` (Litvin & Fuentes 2004, undercutting of spur gears), i.e.
    ``z >= 2 (d / m) / sin^2(alpha)``: 17.1 for the standard 20 deg rack.

    Returns
    -------
    float
        The bound on ``z`` [-]; any integer ``z`` at or above it is free of
        undercut.
    """
    alpha = np.radians(pressure_angle_deg)
    depth = addendum_coeff + clearance_coeff - fillet_radius_coeff * (1.0 - np.sin(alpha))
    return float(2.0 * depth / np.sin(alpha) ** 2)


@dataclass(frozen=True)
class SurfaceSample:
    """Points and unit normals sampled on a tooth surface.

    Attributes
    ----------
    points : ndarray, shape (..., 3)
        Surface points [m].
    normals : ndarray, shape (..., 3)
        Unit normals pointing out of the material.
    """

    points: NDArray[np.float64]
    normals: NDArray[np.float64]


@dataclass(frozen=True)
class ProfileSegment:
    """One piece of a transverse tooth profile.

    Attributes
    ----------
    name : str
        ``root_left``, ``fillet_left``, ``flank_left``, ``tip``,
        ``flank_right``, ``fillet_right`` or ``root_right``.
    points : ndarray, shape (n, 2)
        Points ``(x, y)`` [m]; consecutive segments share their end points.
    normals : ndarray, shape (n, 2)
        In-plane unit normals pointing out of the material.
    """

    name: str
    points: NDArray[np.float64]
    normals: NDArray[np.float64]


@dataclass(frozen=True)
class ToothProfile:
    """Transverse section of one pinion tooth, from space centre to space centre.

    The segments run from the left space centre (polar angle ``-pi/z``)
    along the root circle, up the left fillet and flank, across the tip
    land and down the right side to the right space centre (``+pi/z``).
    """

    segments: tuple[ProfileSegment, ...]

    def segment(self, name: str) -> ProfileSegment:
        """Return the segment called ``name``; GeometryError lists the names otherwise."""
        for seg in self.segments:
            if seg.name == name:
                return seg
        names = [seg.name for seg in self.segments]
        raise GeometryError(f"unknown profile segment {name!r}; pick one of {names}")

    @property
    def points(self) -> NDArray[np.float64]:
        """All points, shape (n, 2), with the shared segment ends kept once."""
        parts = [self.segments[0].points] + [seg.points[1:] for seg in self.segments[1:]]
        return np.concatenate(parts, axis=0)


def _mirror(vectors: NDArray[np.float64]) -> NDArray[np.float64]:
    """Mirror ``x -> -x`` (first component) of an array of vectors."""
    out = np.array(vectors, dtype=float, copy=True)
    out[..., 0] *= -1.0
    return out


@dataclass(frozen=True)
class PinionTooth:
    """Geometry of one tooth of a standard involute spur pinion.

    Parameters
    ----------
    teeth : int
        Number of teeth ``z``.
    module : float
        Module ``m`` [m].
    pressure_angle_deg : float
        Pressure angle ``alpha0`` of the generating rack [deg].
    addendum_coeff, clearance_coeff : float
        ``ha*`` and ``c*`` [-]; tip radius ``r + ha* m``, root radius
        ``r - (ha* + c*) m``.
    fillet_radius_coeff : float
        Rack tip-round radius over module [-]; the root fillet is its
        trochoidal envelope.
    face_width : float
        Face width ``b`` [m]; the face spans ``-b/2 <= u <= b/2``.
    lengthwise_crowning, profile_crowning : float
        Parabolic crowning amounts [m] (module docstring), 0 for none.

    Examples
    --------
    >>> tooth = PinionTooth(19, 3e-3, 20.0, 1.0, 0.25, 0.38, 24e-3)
    >>> round(float(tooth.tooth_thickness(tooth.pitch_radius)) * 1e3, 6)  # pi m / 2 [mm]
    4.712389
    """

    teeth: int
    module: float
    pressure_angle_deg: float = 20.0
    addendum_coeff: float = 1.0
    clearance_coeff: float = 0.25
    fillet_radius_coeff: float = 0.38
    face_width: float = 0.024
    lengthwise_crowning: float = 0.0
    profile_crowning: float = 0.0

    def __post_init__(self) -> None:
        for name in ("module", "face_width", "addendum_coeff", "clearance_coeff"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0.0:
                raise GeometryError(f"PinionTooth.{name} = {value!r} must be > 0")
        if not 0.0 < self.pressure_angle_deg < 45.0:
            raise GeometryError(
                f"PinionTooth.pressure_angle_deg = {self.pressure_angle_deg!r} "
                "must lie in (0, 45) deg"
            )
        rho_max = max_fillet_radius_coeff(
            self.pressure_angle_deg, self.addendum_coeff, self.clearance_coeff
        )
        if not 0.0 < self.fillet_radius_coeff <= rho_max:
            raise GeometryError(
                f"PinionTooth.fillet_radius_coeff = {self.fillet_radius_coeff!r} "
                f"must lie in (0, {rho_max:.4f}]"
            )
        z_min = min_teeth_without_undercut(
            self.pressure_angle_deg,
            self.addendum_coeff,
            self.clearance_coeff,
            self.fillet_radius_coeff,
        )
        if int(self.teeth) != self.teeth or self.teeth < z_min:
            raise GeometryError(
                f"PinionTooth.teeth = {self.teeth!r} must be an integer >= {z_min:.2f} "
                "(fewer teeth are undercut by the rack)"
            )
        for name in ("lengthwise_crowning", "profile_crowning"):
            value = getattr(self, name)
            if not 0.0 <= value <= 0.1 * self.module:
                raise GeometryError(
                    f"PinionTooth.{name} = {value!r} m must lie in "
                    f"[0, {0.1 * self.module:.3g}] m (0.1 module)"
                )
        if self.tooth_thickness(self.tip_radius) <= 0.0:
            raise GeometryError(f"PinionTooth with {self.teeth} teeth has a pointed tip")

    # -- radii and parameters ------------------------------------------------
    @property
    def pressure_angle(self) -> float:
        """Pressure angle ``alpha0`` [rad]."""
        return float(np.radians(self.pressure_angle_deg))

    @property
    def pitch_radius(self) -> float:
        """Pitch (reference) radius ``r = m z / 2`` [m]."""
        return 0.5 * self.module * self.teeth

    @property
    def base_radius(self) -> float:
        """Base radius ``r_b = r cos(alpha0)`` [m]."""
        return self.pitch_radius * np.cos(self.pressure_angle)

    @property
    def tip_radius(self) -> float:
        """Tip radius ``r + ha* m`` [m]."""
        return self.pitch_radius + self.addendum_coeff * self.module

    @property
    def root_radius(self) -> float:
        """Root radius ``r - (ha* + c*) m`` [m]."""
        return self.pitch_radius - (self.addendum_coeff + self.clearance_coeff) * self.module

    @property
    def fillet_radius(self) -> float:
        """Tip-round radius of the generating rack ``rho_f`` [m]."""
        return self.fillet_radius_coeff * self.module

    @property
    def theta_pitch(self) -> float:
        """Roll angle at the pitch circle, ``tan(alpha0)`` [rad]."""
        return float(np.tan(self.pressure_angle))

    @property
    def theta_tip(self) -> float:
        """Roll angle at the tip circle [rad]."""
        return float(np.sqrt((self.tip_radius / self.base_radius) ** 2 - 1.0))

    @property
    def theta_form(self) -> float:
        """Roll angle at the root-form point, where involute and fillet meet [rad].

        The rack's straight flank ends at depth ``d`` below the pitch line;
        it meets the line of action ``d / sin(alpha0)`` from the pitch point,
        i.e. ``r sin(alpha0) - d / sin(alpha0)`` from the base-circle tangency.
        """
        alpha = self.pressure_angle
        depth = (self.addendum_coeff + self.clearance_coeff) * self.module - self.fillet_radius * (
            1.0 - np.sin(alpha)
        )
        return float(
            (self.pitch_radius * np.sin(alpha) - depth / np.sin(alpha)) / self.base_radius
        )

    @property
    def form_radius(self) -> float:
        """Root-form radius [m], the lower end of the involute."""
        return float(self.base_radius * np.hypot(1.0, self.theta_form))

    @property
    def base_angle(self) -> float:
        """Polar angle of the right involute's base point, ``pi/(2z) + inv(alpha0)`` [rad]."""
        return float(np.pi / (2 * self.teeth) + involute_function(self.pressure_angle))

    # -- involute ------------------------------------------------------------
    def involute_polar_angle(self, radius: ArrayLike) -> NDArray[np.float64]:
        """Polar angle ``sigma`` of the right (unmodified) involute at ``radius``.

        ``sigma(r) = pi/(2z) + inv(alpha0) - inv(alpha_r)``,
        ``cos(alpha_r) = r_b / r``; the left flank is at ``-sigma``.
        """
        radius = np.asarray(radius, dtype=float)
        alpha_r = np.arccos(np.clip(self.base_radius / radius, -1.0, 1.0))
        return self.base_angle - involute_function(alpha_r)

    def tooth_thickness(self, radius: ArrayLike) -> NDArray[np.float64]:
        """Arc tooth thickness ``2 r sigma(r)`` of the unmodified tooth [m]."""
        radius = np.asarray(radius, dtype=float)
        return 2.0 * radius * self.involute_polar_angle(radius)

    def _frame(self, theta: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
        """Base point direction angle ``xi``, unit tangent ``T`` and normal ``N``."""
        xi = self.base_angle - theta
        tangent = np.stack([np.sin(xi), np.cos(xi)], axis=-1)
        normal = np.stack([np.cos(xi), -np.sin(xi)], axis=-1)
        return xi, tangent, normal

    def involute_point(self, theta: ArrayLike, side: int = 1) -> NDArray[np.float64]:
        """Point of the unmodified involute at roll angle ``theta``.

        Right flank: ``r_b (sin xi + theta cos xi, cos xi - theta sin xi)``
        with ``xi = base_angle - theta``.

        Returns
        -------
        ndarray, shape (..., 2)
            ``(x, y)`` [m] in the pinion frame.
        """
        theta = np.asarray(theta, dtype=float)
        _, tangent, normal = self._frame(theta)
        # base point r_b (sin xi, cos xi) plus the unwound length r_b theta along N
        point = self.base_radius * (tangent + theta[..., None] * normal)
        return point if side > 0 else _mirror(point)

    def involute_normal(self, theta: ArrayLike, side: int = 1) -> NDArray[np.float64]:
        """Unit outward normal of the unmodified involute, shape (..., 2)."""
        _, _, normal = self._frame(np.asarray(theta, dtype=float))
        return normal if side > 0 else _mirror(normal)

    def involute_curvature(self, theta: ArrayLike) -> NDArray[np.float64]:
        """Curvature of the involute, ``1 / (r_b theta)`` [1/m].

        Convex; the centre of curvature is the base-circle tangency point.
        """
        return 1.0 / (self.base_radius * np.asarray(theta, dtype=float))

    # -- modifications -------------------------------------------------------
    def lengthwise_relief(self, u: ArrayLike) -> NDArray[np.float64]:
        """Lengthwise crowning ``delta_l(u)`` [m] at axial position ``u`` [m]."""
        u = np.asarray(u, dtype=float)
        return self.lengthwise_crowning * (2.0 * u / self.face_width) ** 2

    def profile_relief(self, theta: ArrayLike) -> NDArray[np.float64]:
        """Profile crowning ``delta_p(theta)`` [m] at roll angle ``theta``."""
        theta = np.asarray(theta, dtype=float)
        span = self.theta_tip - self.theta_pitch
        return self.profile_crowning * ((theta - self.theta_pitch) / span) ** 2

    def _relief_derivatives(self, u: NDArray, theta: NDArray) -> tuple[NDArray, NDArray]:
        """``d delta / d u`` and ``d delta / d theta`` of the total relief."""
        d_u = 8.0 * self.lengthwise_crowning * u / self.face_width**2
        span = self.theta_tip - self.theta_pitch
        d_theta = 2.0 * self.profile_crowning * (theta - self.theta_pitch) / span**2
        return d_u, d_theta

    # -- flank surface ---------------------------------------------------------
    def flank_surface(self, u: ArrayLike, theta: ArrayLike, side: int = 1) -> SurfaceSample:
        """Crowned involute flank ``r(u, theta)`` and its unit normal.

        ``r = (P(theta) - delta(u, theta) N(theta), u)`` with ``delta =
        delta_l(u) + delta_p(theta)``. With the profile frame (N, T, z)
        (``dP/dtheta = r_b theta T``, ``dN/dtheta = T``) the exact normal is
        ``(r_b theta - delta) N + delta_theta T + (r_b theta - delta) delta_u z``.

        Parameters
        ----------
        u : array_like
            Axial position [m], ``-b/2 <= u <= b/2`` on the face.
        theta : array_like
            Roll angle [rad], ``theta_form <= theta <= theta_tip`` on the flank.
            ``u`` and ``theta`` broadcast together.
        side : {1, -1}
            Right (``+x``) or left flank.

        Returns
        -------
        SurfaceSample
            Points and outward unit normals, shape ``broadcast(u, theta) + (3,)``.
        """
        u, theta = np.broadcast_arrays(np.asarray(u, float), np.asarray(theta, float))
        _, tangent, normal = self._frame(theta)
        delta = self.lengthwise_relief(u) + self.profile_relief(theta)
        d_u, d_theta = self._relief_derivatives(u, theta)
        arm = self.base_radius * theta - delta
        xy = self.involute_point(theta) - delta[..., None] * normal
        points = np.concatenate([xy, u[..., None]], axis=-1)
        n_xy = arm[..., None] * normal + d_theta[..., None] * tangent
        n = np.concatenate([n_xy, (arm * d_u)[..., None]], axis=-1)
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        if side < 0:
            points, n = _mirror(points), _mirror(n)
        return SurfaceSample(points=points, normals=n)

    def flank_grid(self, n_u: int, n_theta: int, side: int = 1) -> SurfaceSample:
        """Flank sampled on a regular ``(n_u, n_theta)`` grid over the face width and
        the involute (root-form point to tip); e.g. control data for a BSpline surface."""
        u = np.linspace(-0.5 * self.face_width, 0.5 * self.face_width, n_u)
        theta = np.linspace(self.theta_form, self.theta_tip, n_theta)
        return self.flank_surface(u[:, None], theta[None, :], side)

    # -- root fillet -------------------------------------------------------------
    def _fillet_space_frame(self, n: int) -> tuple[NDArray, NDArray]:
        """Fillet generated by the rack tip round, in a frame whose space is on ``+y``.

        At pinion rotation ``phi`` the rack has moved ``-r phi``; the round's
        centre is ``C = (X_c - r phi, Y_c + r)`` and, rolling about the pitch
        point ``I = (0, r)``, the contact point is ``C + rho (C - I)/|C - I|``
        (Litvin & Fuentes 2004,
        generation of the fillet). ``phi`` runs from the root
        circle (``C`` straight below ``I``) to the flank tangency (``C - I``
        along the rack flank normal ``(cos alpha0, -sin alpha0)``). Returns
        points and outward normals, (n, 2), ordered from the root circle to
        the root-form point.
        """
        r = self.pitch_radius
        x_c, y_c = _rack_tip_centre(
            self.module,
            self.pressure_angle,
            self.addendum_coeff,
            self.clearance_coeff,
            self.fillet_radius,
        )
        phi_root = x_c / r
        phi_form = (x_c + y_c / np.tan(self.pressure_angle)) / r
        phi = np.linspace(phi_root, phi_form, n)
        d = np.stack([x_c - r * phi, np.full_like(phi, y_c)], axis=-1)
        d_hat = d / np.linalg.norm(d, axis=-1, keepdims=True)
        centre = np.stack([x_c - r * phi, np.full_like(phi, y_c + r)], axis=-1)
        fixed = centre + self.fillet_radius * d_hat
        # into the rotating gear frame: Rz(-phi)
        c, s = np.cos(phi), np.sin(phi)

        def rotate(v: NDArray) -> NDArray:
            return np.stack([c * v[:, 0] + s * v[:, 1], -s * v[:, 0] + c * v[:, 1]], axis=-1)

        # the round's normal d_hat points into the gear material: outward is -d_hat
        return rotate(fixed), rotate(-d_hat)

    def fillet(self, n: int = 24, side: int = 1) -> tuple[NDArray, NDArray]:
        """Unmodified root fillet: points and outward normals, shape (n, 2).

        Ordered from the root-form point (junction with the involute) down to
        the root circle.
        """
        points, normals = self._fillet_space_frame(n)
        # The space-frame fillet bounds the tooth at -pi/z from +y on its left;
        # rotate that tooth onto +y (counter-clockwise by pi/z), then mirror
        # to get the right flank.
        a = np.pi / self.teeth
        rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
        points, normals = points @ rot.T, normals @ rot.T
        if side > 0:
            points, normals = _mirror(points), _mirror(normals)
        return points[::-1], normals[::-1]

    # -- transverse profile ------------------------------------------------------
    def transverse_profile(
        self,
        u: float = 0.0,
        n_flank: int = 40,
        n_fillet: int = 24,
        n_tip: int = 8,
        n_root: int = 6,
    ) -> ToothProfile:
        """Transverse section of the (crowned) tooth at axial position ``u``.

        The fillet and root are shifted along their normals by the relief at
        the root-form point, so every junction stays continuous and tangent;
        the tip land is the arc through the two (crowned) flank end points.

        Parameters
        ----------
        u : float
            Axial position of the section [m].
        n_flank, n_fillet, n_tip, n_root : int
            Points per segment (end points included).

        Returns
        -------
        ToothProfile
            Seven segments from the left space centre to the right one.
        """
        theta = np.linspace(self.theta_form, self.theta_tip, n_flank)
        flank = self.flank_surface(u, theta, side=1)
        flank_xy = flank.points[:, :2]
        flank_n = flank.normals[:, :2] / np.linalg.norm(flank.normals[:, :2], axis=1)[:, None]
        shift = float(self.lengthwise_relief(u) + self.profile_relief(self.theta_form))
        fil_p, fil_n = self.fillet(n_fillet, side=1)
        fil_p = fil_p - shift * fil_n
        root_r = self.root_radius - shift
        sigma_root = np.arctan2(fil_p[-1, 0], fil_p[-1, 1])
        sig = np.linspace(sigma_root, np.pi / self.teeth, n_root)
        root_n = np.stack([np.sin(sig), np.cos(sig)], axis=-1)
        tip_r = float(np.linalg.norm(flank_xy[-1]))
        sigma_tip = np.arctan2(flank_xy[-1, 0], flank_xy[-1, 1])
        sig_t = np.linspace(-sigma_tip, sigma_tip, n_tip)
        tip_n = np.stack([np.sin(sig_t), np.cos(sig_t)], axis=-1)
        right = [
            ProfileSegment("flank_right", flank_xy[::-1], flank_n[::-1]),
            ProfileSegment("fillet_right", fil_p, fil_n),
            ProfileSegment("root_right", root_r * root_n, root_n),
        ]
        left = [
            ProfileSegment(
                s.name.replace("right", "left"), _mirror(s.points)[::-1], _mirror(s.normals)[::-1]
            )
            for s in reversed(right)
        ]
        tip = ProfileSegment("tip", tip_r * tip_n, tip_n)
        return ToothProfile(segments=(*left, tip, *right))
