"""Coulomb friction between the flanks of the rolling mesh (the seed's eqs. 9-10).

The law is the lumped switching model's, called, not copied
(:func:`fe_impact.switching.simulation.friction_coefficient` with the coefficients of
:class:`fe_impact.switching.model.Friction`, taken from the gear set's
``[friction]`` section, :class:`~fe_impact.gears.gearset.FlankFriction`): the seed's
``F_t = -mu F_n sgn(v12)`` with ``sgn`` smoothed by the ADAMS STEP cubic below the
stiction speed (1 mm/s) and ``mu`` falling from ``mu_static`` to ``mu_dynamic`` at
the transition speed (10 mm/s). So the rolling FE and the lumped model it checks
take the same friction.

At each pair the model holds (a row of :meth:`~fe_impact.rolling.model.Roller._rows`:
a contact point on each body and the face gear's outward normal ``n``), the sliding
velocity is that of the two rotors' rotations at the contact point, in the
current configuration, projected on the tangent plane::

    v_s = (I - n n^T) (omega_p dx_p/dtheta_p - omega_f dx_f/dtheta_f)

(``dx/dtheta`` the point's motion per unit rotor angle, drive sense). The sectors'
elastic velocity is left out. Physically it is of the order of the transmission
error's rate (mm/s) against sliding speeds of m/s that vanish only at the pitch
point; in the model the flank nodes' velocities under the spread contact load
carry the undamped mesh's unresolved high-frequency modes: with them (the nodes'
predicted velocities, weighted as the normal force) the loaded seed condition's
friction loss fell from 0.30% to 0.044% of the drive's work and moved by 35%
when the step was halved, against 0.02% with the rotations alone. The pinion
takes
``-mu(|v_s|) F_n t`` (``t = v_s / |v_s|``), the face gear ``+mu F_n t``, both at the
contact point and spread onto the sectors' flank nodes with the weights of the
normal force (the Hertz line load along the ellipse's major axis); each rotor
takes the force's moment, ``F . dx/dtheta``.

In a time step (:func:`fe_impact.rolling.run.integrate`) ``mu`` and ``t`` are those of
the step's end, from the pinion's prescribed motion and the face gear's predicted
angle and speed (Newmark's predictors, ``v + dt a / 2`` for the speed: it stays
within the range of the speeds even when the face gear rings faster than the step
resolves, where ``v + dt a`` overshoots); the normal force is the step's own (the
friction is part of each pair's unit-force column, so the contact problem sees it).
The explicit part is the face gear's speed in ``v_s``: its error is a part of the
face gear's speed fluctuation (mm/s against sliding speeds of m/s), which matters
only where the sliding reverses; ``validation/rolling_friction.py`` halves the
step and compares the loss.
"""

from __future__ import annotations

import logging

import numpy as np

logger = logging.getLogger(__name__)

__all__ = ["coefficient", "friction_of", "slide"]

#: Finite-difference step of ``dx/dtheta`` [rad]: central differences of an exact
#: rotation, error ~ (1e-6)^2 relative, round-off ~ 1e-16 / 1e-6 relative.
_DTHETA = 1e-6


def friction_of(gearset):
    """The lumped model's :class:`~fe_impact.switching.model.Friction` of ``gearset``'s
    ``[friction]`` coefficients (None when both are 0: frictionless flanks)."""
    from fe_impact.switching.model import Friction

    fr = gearset.friction
    return Friction(fr.mu_static, fr.mu_dynamic) if fr.active else None


def coefficient(law, speed: float) -> float:
    """``mu`` [-] at the sliding speed ``speed`` [m/s] (signed: ``mu(|v|) sgn(v)``,
    smoothed): the lumped model's law itself."""
    from fe_impact.switching.simulation import friction_coefficient

    return friction_coefficient(law, speed)


def _frame(roller, theta: float, body: str
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``R``, ``c``, ``dR/dtheta`` and ``dc/dtheta`` of ``body``'s placement at ``theta``: a
    reference point ``x`` is at ``R x + c`` in the mesh frame
    (:meth:`~fe_impact.rolling.model.Roller.world`), the rates by central differences."""
    def rot(a):
        c = roller.world(np.zeros(3), a, body)
        return np.column_stack([roller.world(e, a, body) - c for e in np.eye(3)]), c

    (R, c), (R1, c1), (R0, c0) = rot(theta), rot(theta + _DTHETA), rot(theta - _DTHETA)
    return R, c, (R1 - R0) / (2.0 * _DTHETA), (c1 - c0) / (2.0 * _DTHETA)


def _spread(entry, direction: np.ndarray):
    """The normal force's spread ``(dofs, coefs)`` turned to ``direction`` (body frame):
    the same nodes and weights (each node's 3 coefficients are its weight times the
    unit normal), the force along ``direction``."""
    if entry is None:
        return None
    dofs, coefs = entry
    weights = np.linalg.norm(coefs.reshape(-1, 3), axis=1)
    return dofs, (weights[:, None] * direction[None, :]).ravel()


def slide(roller, rows: list[dict], law, theta_p: float, omega_p: float, theta_f: float,
          omega_f: float) -> None:
    """Add the friction of each pair of ``rows`` at the rotors' angles and speeds.

    Each row gets ``slip`` (the tangential sliding velocity of the pinion on the
    face gear, mesh frame [m/s]), ``slip_speed`` (its magnitude, signed: positive
    when the pinion slides towards its own tip), ``mu`` (the coefficient at
    ``|v_s|``), and per unit normal force the friction's generalised forces:
    ``p_t``, ``f_t`` (``(dofs, coefs)`` on each sector's free DOFs, None for a rigid
    gear) and ``dtheta_p_t``, ``dtheta_f_t`` (the rotors' moments [m]).
    """
    if not rows:
        return
    Rp, cp, dRp, dcp = _frame(roller, theta_p, "pinion")
    Rf, _, dRf, dcf = _frame(roller, theta_f, "face_gear")
    axis_point = roller.p.axis_point
    axis = roller.p.axis / np.linalg.norm(roller.p.axis)
    for row in rows:
        xp = Rp @ row["xp"] + cp
        dxp, dxf = dRp @ row["xp"] + dcp, dRf @ row["xf"] + dcf
        n = Rp @ row["np"]
        n /= np.linalg.norm(n)
        v = omega_p * dxp - omega_f * dxf
        v_t = v - (v @ n) * n
        speed = float(np.linalg.norm(v_t))
        t = v_t / speed if speed > 0.0 else np.zeros(3)
        mu = coefficient(law, speed)
        # towards the pinion's tip: its radial direction at the point
        radial = xp - axis_point - ((xp - axis_point) @ axis) * axis
        force_p = -mu * t                       # on the pinion, per unit normal force
        row["slip"], row["mu"] = v_t, mu
        row["slip_speed"] = speed if v_t @ radial >= 0.0 else -speed
        row["dtheta_p_t"] = float(force_p @ dxp)
        row["dtheta_f_t"] = float(-force_p @ dxf)
        row["p_t"] = _spread(row["p"], Rp.T @ force_p)
        row["f_t"] = _spread(row["f"], Rf.T @ -force_p)
