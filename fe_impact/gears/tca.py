"""Tooth contact analysis (TCA) of a spur pinion meshing with a face gear.

For a pinion rotation (the *roll angle*) the unloaded pair touches at one
point (the contact is localised by ``N_s > N_p`` and by crowning). TCA finds
that point by solving the continuity of position and normal of the two
flanks (F. L. Litvin & A. Fuentes, *Gear Geometry and Applied Theory*, 2nd
ed., 2004, the TCA sections; Litvin et al., NASA/CR-2000-209909, face-gear
TCA), then gives the principal curvatures of
both flanks, their relative curvature and the Hertz contact ellipse. SI
units: m, rad, N, Pa, kg.

Frame (the *mesh frame*, shared with :mod:`fe_impact.meshing.toothpair`): the
face-gear frame of :mod:`fe_impact.gears.facegear`. ``y`` is the face-gear
axis (tooth height), the origin lies on that axis in the pitch plane, and
the pinion axis is the line ``x = 0, y = r_p`` along ``z``. Positions:

- face gear turned by ``phi_2`` about ``y``: ``r = Ry(phi_2) r_2(L, h)``;
- pinion turned by ``phi_1`` about its axis:
  ``r = Rz(pi + pi/(2 N_p) + phi_1) r_p(u, theta) + (0, r_p, z_0)``, with
  ``r_p(u, theta)`` the pinion frame of :mod:`fe_impact.gears.pinion` (tooth
  on ``+y``) and ``z_0`` the axial position of the pinion's mid-face (the
  vertex of its lengthwise crowning).

The contacting flanks are the face gear's flank ``side=+1`` (facing ``+x``)
and the pinion's right flank (``side=+1`` in the pinion frame, facing
``-x`` here). Positive rotations follow the generating motion (``Rz`` for
the pinion, ``Ry`` for the face gear), so the nominal ratio is
``phi_2 = -pi/(2 N_2) + (N_p/N_2) phi_1``: at ``phi_1 = 0`` both pitch
points lie on the pitch line ``x = y = 0`` (the *pitch-point position*, the
design contact point at ``L = r_2``). The unloaded transmission error is
``phi_2 - phi_2,nominal = phi_2 + pi/(2 N_2) - (N_p/N_2) phi_1`` [rad].

For this mounting the pinion touches the generating shaper on their common
line of action, where the meshing equation gives ``u_s = r_2``: the path of
contact is the line of action in the plane ``z = r_2``. With the pinion's
crowning vertex in that plane (the default ``z_0``) the crowning changes the
curvature but not the path, and the transmission error stays zero.

Curvature convention: each surface's curvature is taken with respect to its
own outward normal (out of its material), positive where the surface is
convex. The gap between the two flanks near the contact point is then
``h = 1/2 s^T (K_1 + K_2) s`` for a tangent offset ``s`` (Johnson, *Contact
Mechanics*, 1985, section 4.1), which is the "Euler-formula" combination of
the two sets of principal curvatures and directions.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fe_impact.errors import GeometryError
from fe_impact.gears.facegear import FaceGearTooth
from fe_impact.gears.pinion import PinionTooth
from fe_impact.physics import hertz

logger = logging.getLogger(__name__)

__all__ = [
    "ContactEllipse",
    "ContactPath",
    "ContactPoint",
    "GearPair",
    "PrincipalCurvatures",
    "RelativeCurvature",
    "contact_ellipse",
    "effective_mass",
    "ellipses",
    "equivalent_radius",
    "principal_curvatures",
    "relative_curvature",
]

# Newton on the five TCA unknowns, in module-scaled variables: a step of 1e-13
# module is 3e-16 m, below the rounding of 0.1 m coordinates.
_TCA_TOL = 1e-13
_TCA_MAXITER = 40
_FD_STEP = 1e-7  # scaled: 3e-10 m; central differences, rounding ~ 1e-16/3e-10
# Second differences for curvature: a 10 um step. Truncation ~ h^2/12 times the
# fourth derivative (~1/R^3 for R >= 5 mm: ~1e-5 1/m), rounding ~ 4 ulp(0.1 m) /
# h^2 ~ 1e-6 1/m; both far below the smallest relative curvature (~0.5 1/m).
_CURVATURE_STEP = 1e-5
#: Largest roll-angle increment [rad] when following the contact from the
#: pitch-point position (continuation keeps Newton in its basin).
MAX_ROLL_STEP = np.radians(1.0)


# -- small geometry helpers --------------------------------------------------------
def _rz(angle: float) -> NDArray[np.float64]:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _ry(angle: float) -> NDArray[np.float64]:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _unit(v: ArrayLike) -> NDArray[np.float64]:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


# -- curvature ---------------------------------------------------------------------------
@dataclass(frozen=True)
class PrincipalCurvatures:
    """Principal curvatures of a surface at a point.

    Attributes
    ----------
    kappa : ndarray, shape (2,)
        Principal curvatures [1/m], ascending; positive where the surface is
        convex seen from outside (curving away from its outward normal).
    directions : ndarray, shape (2, 3)
        Unit principal directions (rows), tangent to the surface.
    normal : ndarray, shape (3,)
        Outward unit normal.
    """

    kappa: NDArray[np.float64]
    directions: NDArray[np.float64]
    normal: NDArray[np.float64]

    def normal_curvature(self, direction: ArrayLike) -> float:
        """Normal curvature [1/m] in a tangent ``direction`` (Euler's formula)."""
        d = _unit(direction)
        c = self.directions @ d
        return float(np.sum(self.kappa * c**2) / np.sum(c**2))

    def rotated(self, rotation: NDArray[np.float64]) -> PrincipalCurvatures:
        """The same curvatures with directions and normal turned by ``rotation`` (3x3)."""
        return PrincipalCurvatures(
            self.kappa, self.directions @ rotation.T, rotation @ self.normal
        )


SurfaceFunction = Callable[[NDArray, NDArray], tuple[NDArray, NDArray]]


def principal_curvatures(
    surface: SurfaceFunction, s: float, t: float, step_s: float, step_t: float
) -> PrincipalCurvatures:
    """Principal curvatures of a parametric surface by central differences.

    The fundamental forms ``I = [r_i . r_j]`` and ``II = -[r_ij . n]`` (sign
    chosen so that convex is positive for the outward normal ``n``) give the
    principal curvatures as the eigenvalues of ``II`` relative to ``I``
    (generalised symmetric problem) and the directions from the eigenvectors
    (do Carmo, *Differential Geometry of Curves and Surfaces*, 1976, 3-3).

    Parameters
    ----------
    surface : callable
        ``surface(s, t) -> (points, normals)`` for broadcast arrays ``s, t``;
        shapes ``(..., 3)``, normals outward and of unit length.
    s, t : float
        Parameters of the point.
    step_s, step_t : float
        Difference steps in ``s`` and ``t``; choose them so that they move the
        point by about 10 um.

    Returns
    -------
    PrincipalCurvatures
    """
    ds = np.array([0, 1, -1, 0, 0, 1, 1, -1, -1], dtype=float) * step_s
    dt = np.array([0, 0, 0, 1, -1, 1, -1, 1, -1], dtype=float) * step_t
    p, n = surface(s + ds, t + dt)
    r_s = (p[1] - p[2]) / (2 * step_s)
    r_t = (p[3] - p[4]) / (2 * step_t)
    r_ss = (p[1] - 2 * p[0] + p[2]) / step_s**2
    r_tt = (p[3] - 2 * p[0] + p[4]) / step_t**2
    r_st = (p[5] - p[6] - p[7] + p[8]) / (4 * step_s * step_t)
    normal = _unit(n[0])
    first = np.array([[r_s @ r_s, r_s @ r_t], [r_s @ r_t, r_t @ r_t]])
    second = -np.array(
        [[r_ss @ normal, r_st @ normal], [r_st @ normal, r_tt @ normal]]
    )
    # I^{-1/2} II I^{-1/2} is symmetric; its eigenvectors map back through I^{-1/2}
    w, v = np.linalg.eigh(first)
    inv_sqrt = v @ np.diag(1.0 / np.sqrt(w)) @ v.T
    kappa, vec = np.linalg.eigh(inv_sqrt @ second @ inv_sqrt)
    coeffs = inv_sqrt @ vec  # columns: (ds, dt) of each principal direction
    directions = np.stack([_unit(c[0] * r_s + c[1] * r_t) for c in coeffs.T])
    return PrincipalCurvatures(kappa, directions, normal)


@dataclass(frozen=True)
class RelativeCurvature:
    """Relative curvature of two surfaces touching at a point.

    The gap near the contact point is ``h = 1/2 (lambda_min xi^2 +
    lambda_max eta^2)`` in the coordinates ``xi`` along ``major`` and ``eta``
    along ``minor``; in Hertz's notation ``A = lambda_min / 2``,
    ``B = lambda_max / 2``.

    Attributes
    ----------
    lambda_min, lambda_max : float
        Eigenvalues of ``K_1 + K_2`` [1/m].
    major, minor : ndarray, shape (3,)
        Unit tangent directions of ``lambda_min`` (the contact ellipse's major
        axis) and ``lambda_max``.
    normal : ndarray, shape (3,)
        Unit common normal (that of the second surface).
    """

    lambda_min: float
    lambda_max: float
    major: NDArray[np.float64]
    minor: NDArray[np.float64]
    normal: NDArray[np.float64]

    @property
    def radii(self) -> tuple[float, float]:
        """Relative principal radii ``(R_x, R_y) = (1/lambda_min, 1/lambda_max)`` [m]."""
        return 1.0 / self.lambda_min, 1.0 / self.lambda_max


def relative_curvature(
    first: PrincipalCurvatures, second: PrincipalCurvatures
) -> RelativeCurvature:
    """Combine two surfaces' principal curvatures into the relative curvature.

    Each surface contributes ``K_i = sum_j kappa_ij d_ij d_ij^T`` (Euler's
    formula: normal curvature ``kappa_I cos^2 + kappa_II sin^2``) projected on
    the common tangent plane; the relative curvature is ``K_1 + K_2``
    (Johnson 1985, section 4.1: ``A + B`` and ``B - A`` from the two sets of
    radii and the angle between their principal planes).

    Parameters
    ----------
    first, second : PrincipalCurvatures
        The two surfaces at the contact point, each with its own outward
        normal (the normals are opposite).

    Raises
    ------
    GeometryError
        If the normals are not opposite (not a contact point) or the relative
        curvature is not positive definite (the surfaces are conformal or
        cross: no Hertz contact).
    """
    n = second.normal
    if float(first.normal @ n) > -1.0 + 1e-8:
        raise GeometryError(
            "relative curvature needs opposite normals at a contact point; "
            f"n1 . n2 = {float(first.normal @ n):.9f}"
        )
    t1 = _unit(second.directions[0] - (second.directions[0] @ n) * n)
    t2 = np.cross(n, t1)
    basis = np.stack([t1, t2])
    tensor = np.zeros((2, 2))
    for curv in (first, second):
        proj = curv.directions @ basis.T  # (2 directions, 2 basis components)
        tensor += proj.T @ np.diag(curv.kappa) @ proj
    lam, vec = np.linalg.eigh(tensor)
    if lam[0] <= 0.0:
        raise GeometryError(
            f"relative curvature is not positive definite (eigenvalues {lam[0]:.4g}, "
            f"{lam[1]:.4g} 1/m): the flanks do not make a point (Hertz) contact"
        )
    major, minor = vec[:, 0] @ basis, vec[:, 1] @ basis
    return RelativeCurvature(float(lam[0]), float(lam[1]), major, minor, n.copy())


# -- Hertz ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class ContactEllipse:
    """Hertz contact ellipse at a given normal load.

    Attributes
    ----------
    force : float
        Normal load [N].
    a, b : float
        Semi-axes [m] along ``major`` and ``minor``.
    p0 : float
        Peak pressure [Pa].
    approach : float
        Hertz approach ``delta`` of distant points [m].
    major, minor : ndarray, shape (3,)
        Unit directions of the axes.
    """

    force: float
    a: float
    b: float
    p0: float
    approach: float
    major: NDArray[np.float64]
    minor: NDArray[np.float64]

    @property
    def slenderness(self) -> float:
        """``b / a`` [-]."""
        return self.b / self.a

    def to_dict(self) -> dict[str, object]:
        """JSON-friendly record (SI units)."""
        return {
            "force_N": self.force,
            "a_m": self.a,
            "b_m": self.b,
            "b_over_a": self.slenderness,
            "p0_Pa": self.p0,
            "approach_m": self.approach,
            "major": self.major.tolist(),
            "minor": self.minor.tolist(),
        }


def contact_ellipse(relative: RelativeCurvature, force: float, e_star: float) -> ContactEllipse:
    """Exact Hertz ellipse for the relative curvature ``relative`` under ``force``.

    Uses :func:`fe_impact.physics.hertz.ellipse_contact` with ``R_x = 1/lambda_min``,
    ``R_y = 1/lambda_max`` (Johnson 1985, sections 3.6 and 4.2).

    Parameters
    ----------
    relative : RelativeCurvature
    force : float
        Normal load [N], > 0.
    e_star : float
        Effective modulus [Pa] (:func:`fe_impact.physics.hertz.effective_modulus`).
    """
    rx, ry = relative.radii
    c = hertz.ellipse_contact(force, rx, ry, e_star)
    return ContactEllipse(force, c.a, c.b, c.p0, c.delta, relative.major, relative.minor)


def equivalent_radius(relative: RelativeCurvature, e_star: float) -> float:
    """Radius [m] of the sphere contact with the same load-approach law.

    An elliptical Hertz contact also follows ``P = K delta^1.5``; ``K`` is
    independent of the load, and the sphere with
    ``(4/3) E* sqrt(R) = K`` has ``R = (3 K / (4 E*))^2``. It feeds the
    impact estimates of :func:`fe_impact.physics.hertz.impact`.
    """
    c = hertz.ellipse_contact(1.0, *relative.radii, e_star)
    stiffness = 1.0 / c.delta**1.5  # P = 1 N
    return float((3.0 * stiffness / (4.0 * e_star)) ** 2)


def effective_mass(
    inertia: float,
    axis_point: ArrayLike,
    axis_direction: ArrayLike,
    point: ArrayLike,
    normal: ArrayLike,
) -> tuple[float, float]:
    """Mass [kg] of a rotor reduced to the contact normal, and its lever arm [m].

    A rotor of inertia ``I`` about an axis (unit direction ``e`` through
    ``p``) moves the contact point ``x`` along the normal ``n`` at
    ``omega l`` with the signed lever arm ``l = (e x (x - p)) . n``; its
    kinetic energy ``I omega^2 / 2`` is that of a mass ``m = I / l^2`` moving
    at ``omega l``.

    Returns
    -------
    (mass, lever)
        ``I / l^2`` and the signed ``l`` (its sign gives the sense of
        rotation that moves the point along ``+n``).
    """
    e = _unit(axis_direction)
    arm = np.asarray(point, float) - np.asarray(axis_point, float)
    lever = float(np.cross(e, arm) @ _unit(normal))
    if abs(lever) < 1e-9:
        raise GeometryError("the contact normal passes through the rotor axis: lever arm is 0")
    return inertia / lever**2, lever


# -- the contact pair ------------------------------------------------------------------------
@dataclass(frozen=True)
class ContactPoint:
    """Unloaded contact of the pair at one roll angle (mesh frame, SI units).

    Attributes
    ----------
    roll_angle : float
        Pinion rotation ``phi_1`` from the pitch-point position [rad].
    face_angle : float
        Face-gear rotation ``phi_2`` [rad].
    transmission_error : float
        ``phi_2 - phi_2,nominal`` [rad] (module docstring).
    point : ndarray, shape (3,)
        Contact point [m].
    normal : ndarray, shape (3,)
        Common unit normal, out of the face gear (into the pinion).
    pinion_parameters : tuple of float
        ``(u, theta)`` on the pinion flank: axial position [m] from its
        mid-face and involute roll angle [rad].
    face_parameters : tuple of float
        ``(L, h)`` on the face-gear flank: radius and height [m].
    pinion_curvature, face_curvature : PrincipalCurvatures
        Both flanks at the point, in the mesh frame.
    relative : RelativeCurvature
    on_flank : bool
        True when the point lies on the real working flanks of both
        members: the pinion involute (root-form point to tip) within its face
        width, and the face gear's involute-generated band within its face.
    residual : float
        Position mismatch [m] of the two flanks at the solution.
    """

    roll_angle: float
    face_angle: float
    transmission_error: float
    point: NDArray[np.float64]
    normal: NDArray[np.float64]
    pinion_parameters: tuple[float, float]
    face_parameters: tuple[float, float]
    pinion_curvature: PrincipalCurvatures
    face_curvature: PrincipalCurvatures
    relative: RelativeCurvature
    on_flank: bool
    residual: float

    def to_dict(self) -> dict[str, object]:
        """JSON-friendly record (SI units, angles in rad)."""
        return {
            "roll_angle_rad": self.roll_angle,
            "face_angle_rad": self.face_angle,
            "transmission_error_rad": self.transmission_error,
            "point_m": self.point.tolist(),
            "normal": self.normal.tolist(),
            "pinion_u_m": self.pinion_parameters[0],
            "pinion_roll_parameter_rad": self.pinion_parameters[1],
            "face_radius_m": self.face_parameters[0],
            "face_height_m": self.face_parameters[1],
            "pinion_curvatures_1_m": self.pinion_curvature.kappa.tolist(),
            "pinion_directions": self.pinion_curvature.directions.tolist(),
            "face_curvatures_1_m": self.face_curvature.kappa.tolist(),
            "face_directions": self.face_curvature.directions.tolist(),
            "relative_curvatures_1_m": [self.relative.lambda_min, self.relative.lambda_max],
            "relative_radii_m": list(self.relative.radii),
            "major_axis": self.relative.major.tolist(),
            "minor_axis": self.relative.minor.tolist(),
            "on_flank": self.on_flank,
            "residual_m": self.residual,
        }


@dataclass(frozen=True)
class ContactPath:
    """Contact points over a range of roll angles (one mesh cycle by default).

    Attributes
    ----------
    points : tuple of ContactPoint
        In roll-angle order.
    """

    points: tuple[ContactPoint, ...]

    @property
    def roll_angles(self) -> NDArray[np.float64]:
        """[rad], shape (n,)."""
        return np.array([c.roll_angle for c in self.points])

    @property
    def transmission_error(self) -> NDArray[np.float64]:
        """[rad], shape (n,)."""
        return np.array([c.transmission_error for c in self.points])

    @property
    def positions(self) -> NDArray[np.float64]:
        """Contact points [m], shape (n, 3)."""
        return np.array([c.point for c in self.points])

    @property
    def on_flank(self) -> NDArray[np.bool_]:
        """shape (n,)."""
        return np.array([c.on_flank for c in self.points])


@dataclass(frozen=True)
class GearPair:
    """A pinion and one face-gear stage at their design mounting.

    Parameters
    ----------
    pinion : PinionTooth
    face : FaceGearTooth
    pinion_axial_position : float or None
        ``z_0`` [m]: where the pinion's mid-face (the vertex of its lengthwise
        crowning) lies along its axis in the mesh frame. None puts it at the
        design contact point ``L = r_2``, so that crowning leaves the contact
        at the pitch-point position unchanged.

    Examples
    --------
    >>> from fe_impact.gears import default_gearset
    >>> pair = GearPair.from_gearset(default_gearset(), stage=1)
    >>> c = pair.contact(0.0)
    >>> [round(float(v) * 1e3, 6) + 0.0 for v in c.point]  # pitch point at L = r_2 [mm]
    [0.0, 0.0, 84.0]
    """

    pinion: PinionTooth
    face: FaceGearTooth
    pinion_axial_position: float | None = None

    def __post_init__(self) -> None:
        if not np.isclose(self.pinion.module, self.face.module, rtol=1e-12, atol=0.0):
            raise GeometryError(
                f"pinion module {self.pinion.module * 1e3:g} mm differs from face-gear module "
                f"{self.face.module * 1e3:g} mm"
            )
        if self.pinion.pressure_angle_deg != self.face.pressure_angle_deg:
            raise GeometryError(
                f"pinion pressure angle {self.pinion.pressure_angle_deg} deg differs from the "
                f"face gear's {self.face.pressure_angle_deg} deg"
            )

    @classmethod
    def from_gearset(
        cls, gearset, stage: int, pinion_axial_position: float | None = None
    ) -> GearPair:
        """The pair of ``gearset``'s pinion and stage ``stage`` (1-based, as in the seed)."""
        n = len(gearset.stages)
        integral = isinstance(stage, int | np.integer) and not isinstance(stage, bool)
        if not integral or not 1 <= stage <= n:
            raise GeometryError(f"stage = {stage!r}: pick a stage number in 1..{n}")
        return cls(
            gearset.pinion_tooth(), gearset.face_gear_tooth(stage - 1), pinion_axial_position
        )

    # -- mounting ----------------------------------------------------------------------
    @property
    def z0(self) -> float:
        """Axial position of the pinion mid-face ``z_0`` [m]."""
        if self.pinion_axial_position is None:
            return self.face.pitch_radius
        return float(self.pinion_axial_position)

    @property
    def ratio(self) -> float:
        """Nominal ``N_p / N_2`` [-]."""
        return self.pinion.teeth / self.face.teeth

    @property
    def pinion_axis(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Point [m] and unit direction of the pinion axis (``+z``)."""
        return np.array([0.0, self.pinion.pitch_radius, 0.0]), np.array([0.0, 0.0, 1.0])

    @property
    def face_axis(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Point [m] and unit direction of the face-gear axis (``+y``)."""
        return np.zeros(3), np.array([0.0, 1.0, 0.0])

    def nominal_face_angle(self, roll_angle: float) -> float:
        """``phi_2`` of conjugate motion: ``-pi/(2 N_2) + (N_p/N_2) phi_1`` [rad]."""
        return -np.pi / (2 * self.face.teeth) + self.ratio * roll_angle

    def pinion_rotation(self, roll_angle: float) -> NDArray[np.float64]:
        """Rotation from the pinion frame to the mesh frame, ``Rz(pi + pi/(2 N_p) + phi_1)``."""
        return _rz(np.pi + np.pi / (2 * self.pinion.teeth) + roll_angle)

    def face_rotation(self, face_angle: float) -> NDArray[np.float64]:
        """Rotation from the face-gear frame to the mesh frame, ``Ry(phi_2)``."""
        return _ry(face_angle)

    def pinion_to_mesh(self, points: ArrayLike, roll_angle: float) -> NDArray[np.float64]:
        """Pinion-frame points [m], shape (..., 3), to the mesh frame."""
        return np.asarray(points, float) @ self.pinion_rotation(roll_angle).T + np.array(
            [0.0, self.pinion.pitch_radius, self.z0]
        )

    def face_to_mesh(self, points: ArrayLike, face_angle: float) -> NDArray[np.float64]:
        """Face-gear-frame points [m], shape (..., 3), to the mesh frame."""
        return np.asarray(points, float) @ self.face_rotation(face_angle).T

    # -- flanks in their own frames ---------------------------------------------------------
    def _pinion_surface(self, u: NDArray, theta: NDArray) -> tuple[NDArray, NDArray]:
        s = self.pinion.flank_surface(u, theta, side=1)
        return s.points, s.normals

    def _face_surface(self, radius: NDArray, height: NDArray) -> tuple[NDArray, NDArray]:
        s = self.face.flank(radius, height, side=1)
        return s.points, s.normals

    # -- TCA ----------------------------------------------------------------------------------
    def _scales(self) -> NDArray[np.float64]:
        """Unknowns (u, theta, L, h, TE) divided by these are O(1) per module of motion."""
        m = self.pinion.module
        return np.array([m, m / self.pinion.base_radius, m, m, m / self.face.pitch_radius])

    def _residual(self, q: NDArray, roll_angle: float, tangents: NDArray) -> NDArray:
        """Position mismatch / module (3) and normal misalignment (2), shape (..., 5)."""
        u, theta, radius, height, te = np.moveaxis(q, -1, 0)
        p1, n1 = self._pinion_surface(u, theta)
        p1 = self.pinion_to_mesh(p1, roll_angle)
        n1 = n1 @ self.pinion_rotation(roll_angle).T
        p2, n2 = self._face_surface(radius, height)
        # each row has its own face angle: rotate point by point about y
        phi2 = self.nominal_face_angle(roll_angle) + te
        c, s = np.cos(phi2), np.sin(phi2)

        def turn(v: NDArray) -> NDArray:
            return np.stack(
                [c * v[..., 0] + s * v[..., 2], v[..., 1], -s * v[..., 0] + c * v[..., 2]],
                axis=-1,
            )

        p2, n2 = turn(p2), turn(n2)
        dn = n1 + n2
        return np.concatenate(
            [(p1 - p2) / self.pinion.module, dn @ tangents.T], axis=-1
        )

    def _initial_guess(self) -> NDArray[np.float64]:
        """Pitch-point position: involute at its pitch roll angle, face gear at (r_2, 0)."""
        r_2 = self.face.pitch_radius
        return np.array([r_2 - self.z0, self.pinion.theta_pitch, r_2, 0.0, 0.0])

    def _solve(self, roll_angle: float, guess: NDArray) -> NDArray:
        """Newton with a central-difference Jacobian in scaled unknowns."""
        alpha = self.pinion.pressure_angle
        n_ref = np.array([np.cos(alpha), np.sin(alpha), 0.0])
        tangents = np.stack([np.array([0.0, 0.0, 1.0]), np.cross(n_ref, [0.0, 0.0, 1.0])])
        scale = self._scales()
        x = guess / scale
        eye = np.eye(5) * _FD_STEP
        for _ in range(_TCA_MAXITER):
            probes = np.concatenate([x[None], x + eye, x - eye]) * scale
            f = self._residual(probes, roll_angle, tangents)
            jac = (f[1:6] - f[6:11]).T / (2 * _FD_STEP)
            step = np.linalg.solve(jac, -f[0])
            # damp steps larger than 0.2 module (or 0.2 module of roll) to stay on the flank
            step *= min(1.0, 0.2 / np.abs(step).max())
            x = x + step
            if np.abs(step).max() < _TCA_TOL:
                return x * scale
        raise GeometryError(
            f"tooth contact not found at roll angle {np.degrees(roll_angle):.4f} deg "
            f"(Newton did not converge; last step {np.abs(step).max():.3g} module): the "
            "contact may not be localised (shaper_teeth equal to pinion teeth and no crowning?)"
        )

    def contact(self, roll_angle: float, guess: ArrayLike | None = None) -> ContactPoint:
        """Unloaded contact at pinion roll angle ``phi_1`` [rad].

        Solves ``r_1 = r_2`` and ``n_1 = -n_2`` for the pinion flank
        parameters ``(u, theta)``, the face-gear flank parameters ``(L, h)``
        and the transmission error, following the contact from the
        pitch-point position in steps of at most :data:`MAX_ROLL_STEP`.

        Parameters
        ----------
        roll_angle : float
            Pinion rotation from the pitch-point position [rad].
        guess : array_like, optional
            Starting unknowns ``(u, theta, L, h, TE)``; default: continuation.

        Raises
        ------
        GeometryError
            If Newton does not converge (no localised contact) or the
            relative curvature is not positive definite.
        """
        roll_angle = float(roll_angle)
        if guess is None:
            q = self._initial_guess()
            n = int(np.ceil(abs(roll_angle) / MAX_ROLL_STEP))
            for phi in np.linspace(0.0, roll_angle, n + 1)[1:-1] if n > 1 else []:
                q = self._solve(float(phi), q)
        else:
            q = np.asarray(guess, dtype=float)
        q = self._solve(roll_angle, q)
        if q[1] <= 0.0:
            raise GeometryError(
                f"roll angle {np.degrees(roll_angle):.4g} deg: the contact would lie below the "
                "pinion's base circle (no involute there); pick an angle nearer 0"
            )
        return self._contact_record(roll_angle, q)

    def path(self, roll_angles: ArrayLike | None = None, n: int = 41) -> ContactPath:
        """Contact points over a range of roll angles.

        Parameters
        ----------
        roll_angles : array_like, optional
            Pinion rotations [rad]; default: ``n`` values over one angular
            pitch ``2 pi / N_p`` centred on the pitch-point position.
        n : int
            Number of roll angles for the default range.
        """
        if roll_angles is None:
            half = np.pi / self.pinion.teeth
            roll_angles = np.linspace(-half, half, n)
        roll_angles = np.asarray(roll_angles, dtype=float)
        order = np.argsort(np.abs(roll_angles), kind="stable")
        solved: dict[int, ContactPoint] = {}
        # follow the contact outwards from the roll angle nearest zero, each
        # solution seeding its neighbour on the same side
        last = {1: None, -1: None}
        for i in order:
            phi = float(roll_angles[i])
            side = 1 if phi >= 0 else -1
            prev = last[side] if last[side] is not None else last[-side]
            if prev is not None and abs(phi - prev.roll_angle) <= MAX_ROLL_STEP:
                q0 = self._unknowns(prev)
                solved[i] = self._contact_record(phi, self._solve(phi, q0))
            else:
                solved[i] = self.contact(phi)
            last[side] = solved[i]
        return ContactPath(tuple(solved[i] for i in range(len(roll_angles))))

    def _unknowns(self, c: ContactPoint) -> NDArray[np.float64]:
        return np.array([*c.pinion_parameters, *c.face_parameters, c.transmission_error])

    def _contact_record(self, roll_angle: float, q: NDArray) -> ContactPoint:
        u, theta, radius, height, te = (float(v) for v in q)
        face_angle = self.nominal_face_angle(roll_angle) + te
        rot1, rot2 = self.pinion_rotation(roll_angle), self.face_rotation(face_angle)
        p1, _ = self._pinion_surface(np.asarray(u), np.asarray(theta))
        p2, n2 = self._face_surface(np.asarray(radius), np.asarray(height))
        point1 = self.pinion_to_mesh(p1, roll_angle)
        point2 = self.face_to_mesh(p2, face_angle)
        step = _CURVATURE_STEP
        k1 = principal_curvatures(
            self._pinion_surface, u, theta, step, step / (self.pinion.base_radius * theta)
        ).rotated(rot1)
        k2 = principal_curvatures(self._face_surface, radius, height, step, step).rotated(rot2)
        return ContactPoint(
            roll_angle=roll_angle,
            face_angle=face_angle,
            transmission_error=te,
            point=0.5 * (point1 + point2),
            normal=rot2 @ n2,
            pinion_parameters=(u, theta),
            face_parameters=(radius, height),
            pinion_curvature=k1,
            face_curvature=k2,
            relative=relative_curvature(k1, k2),
            on_flank=self._on_flank(u, theta, radius, height),
            residual=float(np.linalg.norm(point1 - point2)),
        )

    def _on_flank(self, u: float, theta: float, radius: float, height: float) -> bool:
        p, f = self.pinion, self.face
        on_pinion = p.theta_form <= theta <= p.theta_tip and abs(u) <= 0.5 * p.face_width
        if not f.face_inner <= radius <= f.face_outer:
            return False
        low, high = f.height_range(radius)
        return bool(on_pinion and low <= height <= high)

    # -- loads and masses ------------------------------------------------------------------
    def effective_masses(
        self, contact: ContactPoint, pinion_inertia: float, face_inertia: float
    ) -> dict[str, float]:
        """Rotor masses reduced to the contact normal (:func:`effective_mass`).

        Returns
        -------
        dict
            ``pinion_mass``, ``pinion_lever``, ``face_mass``, ``face_lever``
            [kg, m, signed levers] and ``effective_mass = 1/(1/m_1 + 1/m_2)``.
        """
        m1, l1 = effective_mass(pinion_inertia, *self.pinion_axis, contact.point, contact.normal)
        m2, l2 = effective_mass(face_inertia, *self.face_axis, contact.point, contact.normal)
        return {
            "pinion_mass": m1,
            "pinion_lever": l1,
            "face_mass": m2,
            "face_lever": l2,
            "effective_mass": 1.0 / (1.0 / m1 + 1.0 / m2),
        }


def ellipses(
    contact: ContactPoint, forces: Sequence[float], e_star: float
) -> list[ContactEllipse]:
    """Hertz ellipses of one contact point for several loads [N]."""
    return [contact_ellipse(contact.relative, float(f), e_star) for f in forces]
