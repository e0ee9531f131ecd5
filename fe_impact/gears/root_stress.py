"""Tooth-root bending of the pinion, ISO 6336-3 style: the 30 degree tangent section.

:func:`iso_section`: the pinion's critical root section by the **30 degree
tangent construction** of ISO 6336-3:2019 (method B, the Hofer construction):
the points of the root fillet whose tangent makes 30 deg with the tooth
centreline bound the section ``s_Fn``; the load line through the point where
the normal force acts meets the centreline at height ``h_Fe`` above it,
inclined ``alpha_Fen`` to the perpendicular of the centreline; ``rho_F`` is
the fillet's radius of curvature there. The construction is made numerically
on the pinion's own generated fillet (the trochoid of the rack tip round,
:meth:`~fe_impact.gears.pinion.PinionTooth.fillet`), not by ISO's closed forms
for a rack-cut tooth; those closed forms are the check
(``tests/test_root_stress.py``). Then

``Y_F = 6 (h_Fe/m) cos(alpha_Fen) / ((s_Fn/m)^2 cos(alpha_n))``,
``Y_S = (1.2 + 0.13 L) q_s^(1/(1.21 + 2.3/L))`` (``L = s_Fn/h_Fe``,
``q_s = s_Fn/(2 rho_F)``, valid for ``1 <= q_s < 8``) and the nominal root
stress ``sigma_F0 = F_t/(b m) Y_F Y_S Y_beta`` with ``F_t = F_n cos(alpha_n)``
and ``Y_beta = 1`` (spur pinion).

ISO's method B applies the load at the outer point of single pair tooth
contact; here it is applied where the contact is (the pitch point in
``fe-impact geometry`` and in the FE comparison of
:mod:`fe_impact.calibration.root_stress`), so the FE and ISO figures are for
one load at one place. ``b`` is the face gear's face width (the length of the
contact lines of a conjugate, unlocalised pair): a localised contact
(``N_s > N_p``, crowning) loads a shorter length, so an FE peak is expected
above ``sigma_F0``; their ratio plays the part of ISO's face load factor
``K_Fbeta``.

The allowable: ISO 6336-5's ``sigma_Flim`` (the gear set's
``material.bending_stress_limit_pa``) is the nominal stress number of the
standard reference test gear, whose local root stress is ``Y_ST = 2`` times
it; a calculated local root stress (with ``Y_S``) is compared with
``sigma_FE = Y_ST sigma_Flim`` (ISO 6336-3, the permissible root stress with
the life, notch, roughness and size factors and the safety factor 1).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fe_impact.errors import GeometryError

logger = logging.getLogger(__name__)

__all__ = [
    "TANGENT_ANGLE_DEG",
    "Y_ST",
    "IsoSection",
    "iso_for_contact",
    "iso_root_bending",
    "iso_section",
    "pinion_frame",
]

#: ISO 6336-3's critical section: where the fillet's tangent makes this angle with
#: the tooth centreline (external gears) [deg].
TANGENT_ANGLE_DEG = 30.0
#: ISO 6336-3 stress correction factor of the standard reference test gear.
Y_ST = 2.0
#: Fillet points sampled for the 30 deg construction: the point is interpolated
#: between samples 1/4000 of the fillet apart; the tests hold the closed form to 1e-6.
_FILLET_SAMPLES = 4001


# -- ISO 6336-3 style nominal root stress ----------------------------------------------
@dataclass(frozen=True)
class IsoSection:
    """The pinion's critical root section and ISO 6336-3 factors for one load point.

    Attributes
    ----------
    load_radius : float
        Radius of the load point on the involute [m].
    s_fn : float
        Chord of the critical section between the 30 deg tangent points [m].
    h_fe : float
        Bending arm: the load line's intersection with the centreline above the
        section [m].
    rho_f : float
        Fillet radius of curvature at the tangent point [m].
    alpha_fen : float
        Load angle to the perpendicular of the centreline [rad].
    section_radius : float
        Radius of the tangent points from the pinion axis [m].
    y_f, y_s : float
        Form factor and stress correction factor [-].
    """

    load_radius: float
    s_fn: float
    h_fe: float
    rho_f: float
    alpha_fen: float
    section_radius: float
    y_f: float
    y_s: float

    @property
    def q_s(self) -> float:
        """Notch parameter ``s_Fn / (2 rho_F)`` [-] (``Y_S`` is fitted for 1..8)."""
        return self.s_fn / (2.0 * self.rho_f)

    def nominal_stress(self, normal_force: float, face_width: float, module: float,
                       pressure_angle: float) -> float:
        """``sigma_F0 = F_t / (b m) Y_F Y_S`` [Pa] with ``F_t = F_n cos(alpha_n)``."""
        return normal_force * math.cos(pressure_angle) / (face_width * module) \
            * self.y_f * self.y_s


def _tangent_point(points: NDArray, normals: NDArray) -> tuple[NDArray, float]:
    """The fillet point whose outward normal is ``TANGENT_ANGLE_DEG`` above ``+x`` (its
    tangent that far from the centreline ``+y``) and the radius of curvature there."""
    beta = np.arctan2(normals[:, 1], normals[:, 0])
    target = math.radians(TANGENT_ANGLE_DEG)
    order = np.argsort(beta)
    if not beta[order[0]] < target < beta[order[-1]]:
        raise GeometryError(
            f"pinion fillet: its tangent turns from {math.degrees(beta.min()):.1f} to "
            f"{math.degrees(beta.max()):.1f} deg, not through the 30 deg of the "
            "ISO 6336-3 section; a pressure angle below 30 deg is needed")
    i = int(np.flatnonzero(np.diff(np.sign(beta - target)) != 0)[0])
    t = (target - beta[i]) / (beta[i + 1] - beta[i])
    point = points[i] + t * (points[i + 1] - points[i])
    ds = np.linalg.norm(np.diff(points[i - 1:i + 3], axis=0), axis=1)
    rho = float(np.sum(ds[:3]) / abs(beta[i + 2] - beta[i - 1]))
    return point, rho


def iso_section(pinion, load_radius: float) -> IsoSection:
    """The 30 deg tangent section and ``Y_F``, ``Y_S`` of ``pinion`` loaded at ``load_radius``.

    Parameters
    ----------
    pinion : PinionTooth
        The stage's pinion (:class:`~fe_impact.gears.pinion.PinionTooth`).
    load_radius : float
        Radius where the normal force acts on the involute [m], between the
        base and the tip circle.

    Returns
    -------
    IsoSection

    Notes
    -----
    ISO 6336-3:2019, method B (formulae for ``Y_F``, ``Y_S`` and the 30 deg
    tangent section); the construction made on the generated fillet. The
    profile crowning and lengthwise crowning are left out (micrometres on a
    section of millimetres).
    """
    if not pinion.base_radius < load_radius <= pinion.tip_radius * (1.0 + 1e-12):
        raise GeometryError(
            f"load radius {load_radius * 1e3:.4g} mm: must lie between the base circle "
            f"{pinion.base_radius * 1e3:.4g} mm and the tip circle "
            f"{pinion.tip_radius * 1e3:.4g} mm")
    points, normals = pinion.fillet(_FILLET_SAMPLES, side=1)
    point, rho_f = _tangent_point(points, normals)
    theta = math.sqrt((load_radius / pinion.base_radius) ** 2 - 1.0)
    p = pinion.involute_point(theta, side=1)
    n = pinion.involute_normal(theta, side=1)
    y_load = p[1] - p[0] * n[1] / n[0]          # the load line meets x = 0
    alpha_fen = math.atan2(n[1], n[0])
    s_fn, h_fe, m = 2.0 * point[0], y_load - point[1], pinion.module
    y_f = 6.0 * (h_fe / m) * math.cos(alpha_fen) / ((s_fn / m) ** 2
                                                    * math.cos(pinion.pressure_angle))
    ratio = s_fn / h_fe
    y_s = (1.2 + 0.13 * ratio) * (s_fn / (2.0 * rho_f)) ** (1.0 / (1.21 + 2.3 / ratio))
    return IsoSection(load_radius=float(load_radius), s_fn=float(s_fn), h_fe=float(h_fe),
                      rho_f=rho_f, alpha_fen=float(alpha_fen),
                      section_radius=float(np.hypot(*point)), y_f=float(y_f), y_s=float(y_s))


def pinion_frame(pair, points: NDArray, roll_angle: float) -> NDArray:
    """Mesh-frame points (n, 3) [m] into the pinion's frame at ``roll_angle`` [rad]
    (the inverse of :meth:`~fe_impact.gears.tca.GearPair.pinion_to_mesh`)."""
    origin = np.array([0.0, pair.pinion.pitch_radius, pair.z0])
    return (np.asarray(points, float) - origin) @ pair.pinion_rotation(roll_angle)


def iso_for_contact(pair, contact) -> IsoSection:
    """:func:`iso_section` of ``pair``'s pinion loaded where ``contact`` (a
    :class:`~fe_impact.gears.tca.ContactPoint`) touches its involute."""
    local = pinion_frame(pair, contact.point[None], contact.roll_angle)[0]
    return iso_section(pair.pinion, float(np.hypot(local[0], local[1])))


def iso_root_bending(pair, contact, normal_force: float, bending_stress_limit: float) -> dict:
    """The ISO-style root-bending rows of ``fe-impact geometry`` (SI units): the pinion's
    30 deg section and factors for the load at ``contact``, ``sigma_F0`` under
    ``normal_force`` [N] with ``b`` the face gear's face width, and the allowable
    ``Y_ST sigma_Flim`` (``bending_stress_limit`` [Pa])."""
    iso = iso_for_contact(pair, contact)
    width = pair.face.face_outer - pair.face.face_inner
    sigma = iso.nominal_stress(normal_force, width, pair.pinion.module,
                               pair.pinion.pressure_angle)
    allowable = Y_ST * bending_stress_limit
    return {"load_radius_m": iso.load_radius, "s_Fn_m": iso.s_fn, "h_Fe_m": iso.h_fe,
            "rho_F_m": iso.rho_f, "alpha_Fen_rad": iso.alpha_fen, "Y_F": iso.y_f,
            "Y_S": iso.y_s, "q_s": iso.q_s, "face_width_m": width, "sigma_F0_Pa": sigma,
            "allowable_Pa": allowable, "iso_ratio": sigma / allowable,
            "fe_pinion_Pa": None, "fe_pinion_element_m": None, "fe_face_Pa": None,
            "fe_face_element_m": None, "fe_ratio": None, "fe_over_iso": None}
