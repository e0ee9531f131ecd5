"""What the transient solver measures: the impact seen along the contact normal.

Each side of the first contact pair (the bodies owning the slave and the
master surface) is summarised by one generalised coordinate: its rigid body's
motion if it has one, otherwise a translation along the contact normal. The
side's displacement and velocity are the mass-weighted averages of that mode
(momentum / generalised mass, so a free body's value stays constant after
separation); a side whose supports block the mode is the fixed reference (0).
The approach is the closing displacement of the two sides at the initial
contact point along the initial contact normal, minus the initial gap
(:class:`ImpactProbe`). :func:`impact_measurements` reads peak force,
contact duration, restitution and residual indentation from the history,
and :class:`SeparationWatch` tells when the bodies have parted for good.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
import scipy.sparse as sp

from fe_impact.contact.surfaces import GapState
from fe_impact.fe.case import Case
from fe_impact.fe.kinematics import Kinematics, point_dofs, rigid_mode
from fe_impact.fe.mesh import FEMesh


@dataclass(frozen=True, eq=False)
class Side:
    """One body of the measured contact pair, reduced to one coordinate."""

    name: str
    weights: np.ndarray | None   # q = weights . z (None: a fixed reference, q = 0)
    lever: float                 # normal displacement at the contact point per unit q
    rigid_body: int | None
    mass: float = math.inf       # generalised mass / lever^2: mass seen along the normal

    def normal_displacement(self, z: np.ndarray) -> float:
        return 0.0 if self.weights is None else self.lever * float(self.weights @ z)


def _side_points(mesh: FEMesh, surface_points: np.ndarray) -> tuple[np.ndarray, list]:
    """Points and volume names of the volume groups touching a surface."""
    touched = np.isin(mesh.cells[:, :4], surface_points).any(axis=1)
    names = [n for n, el in mesh.volumes.items() if touched[el].any()]
    cells = np.concatenate([mesh.volumes[n] for n in names])
    return np.unique(mesh.cells[cells]), names


def make_side(label: str, mesh: FEMesh, kin: Kinematics, M_r: sp.spmatrix, surface: str,
              x_c: np.ndarray, normal: np.ndarray) -> Side:
    """The side of the body owning ``surface``; ``M_r`` the reduced mass matrix."""
    pts, names = _side_points(mesh, mesh.surface_points(surface))
    body = next((k for k, spec in enumerate(kin.rigid)
                 if np.isin(mesh.surface_points(spec.surface), pts).all()), None)
    phi = np.zeros(kin.T.shape[0])
    if body is None:
        mode = np.broadcast_to(normal, (len(pts), 3))
        lever = 1.0
    else:
        spec = kin.rigid[body]
        mode = rigid_mode(spec, mesh.points[pts])
        lever = float(rigid_mode(spec, x_c[None, :])[0] @ normal)
    phi[point_dofs(mesh, pts)] = mode.ravel()
    name = f"{label} ({', '.join(names)})"
    if np.abs(phi[kin.fixed]).max(initial=0.0) > 1e-9 * np.abs(phi).max():
        return Side(name, None, 0.0, None)
    phi_z = np.zeros(kin.n)
    phi_z[:kin.n_free] = phi[kin.free]
    if body is not None:
        phi_z[kin.n_free + body] = 1.0
    Mphi = M_r @ phi_z
    gen = float(phi_z @ Mphi)
    return Side(name, Mphi / gen, lever, body, gen / lever ** 2 if lever else math.inf)


@dataclass(frozen=True, eq=False)
class ImpactProbe:
    """Initial contact point and normal of the first pair, and the pair's two sides.

    The initial gap is the smallest weighted gap, where the discrete contact
    first pushes. On curved surfaces it exceeds the geometric gap by the
    surface's sag averaged over that node's support, about 0.15 h^2/R with
    the linear pressure (0.04 h^2/R split); on the tooth impacts of the
    default calibration that was 0.4-1.0% of the largest approach.
    """

    x_contact: np.ndarray   # (3,) m
    normal: np.ndarray      # (3,) unit contact normal
    initial_gap: float      # m
    slave: Side
    master: Side

    @classmethod
    def build(cls, case: Case, mesh: FEMesh, kin: Kinematics, M_r: sp.spmatrix,
              state: GapState) -> ImpactProbe:
        """The probe of the first pair, whose undeformed zone gap state is ``state``."""
        k = int(np.argmin(np.where(np.isfinite(state.gap), state.gap, np.inf)))
        x, normal = state.point[k].copy(), state.normal[k].copy()
        spec = case.contacts[0]
        return cls(x, normal, float(state.gap[k]),
                   make_side("slave", mesh, kin, M_r, spec.slave, x, normal),
                   make_side("master", mesh, kin, M_r, spec.master, x, normal))

    def approach(self, z: np.ndarray) -> float:
        """Closing displacement (m) at the contact point, 0 at first touch."""
        return -(self.slave.normal_displacement(z)
                 - self.master.normal_displacement(z)) - self.initial_gap

    def normal_velocity(self, v: np.ndarray) -> float:
        """Relative normal velocity slave - master (negative while closing)."""
        return self.slave.normal_displacement(v) - self.master.normal_displacement(v)

    @property
    def effective_mass(self) -> float:
        """``1/(1/m_s + 1/m_m)`` of the two sides along the contact normal (kg)."""
        inv = sum(1.0 / s.mass for s in (self.slave, self.master)
                  if math.isfinite(s.mass) and s.weights is not None)
        return 1.0 / inv if inv > 0 else math.inf


@dataclass
class SeparationWatch:
    """Tells when the bodies have been apart for ``fraction`` x the contact duration.

    Apart means no contact force and a negative approach after the bodies
    have been pressed together (a positive approach while a force acted):
    they have moved back past the position of first touch. A node chattering
    at first touch, where the approach is still about zero, does not count
    as a separation. ``fraction = None`` never stops.
    """

    fraction: float | None
    first_on: float | None = None   # time of the first step with a contact force (s)
    last_on: float | None = None    # time of the last one so far (s)
    pressed: bool = False           # a step had a contact force and a positive approach

    def apart(self, t: float, force: float, approach: float) -> bool:
        if self.fraction is None:
            return False
        if force > 0.0:
            if self.first_on is None:
                self.first_on = t
            self.last_on = t
            self.pressed |= approach > 0.0
            return False
        if not self.pressed or approach >= 0.0:
            return False
        return t - self.last_on >= self.fraction * (self.last_on - self.first_on)


@dataclass(frozen=True)
class ImpactMeasurements:
    """What :func:`impact_measurements` reads off a run's history (SI units; None where
    the run does not show it: no contact, or no separation within the run).

    Attributes
    ----------
    peak_force : float
        Largest contact force [N] (0 without contact).
    time_of_peak_force : float or None
        Its time [s].
    max_approach : float or None
        Largest approach [m].
    energy_error : float or None
        ``max |E(t) - E(0)| / E(0)``.
    contact_duration : float or None
        ``separation - first_touch`` [s].
    first_touch, separation : float or None
        Times [s], interpolated where the approach crosses zero (or the dent).
    restitution : float or None
        ``rebound_velocity / impact_velocity``.
    impact_velocity, rebound_velocity : float or None
        Relative normal speed [m/s] before first touch (closing positive) and
        after separation (opening positive).
    residual_indentation : float or None
        Permanent dent of both sides [m] (0 when nothing yielded).
    contacts : int
        How many times the force switched on.
    """

    peak_force: float
    time_of_peak_force: float | None
    max_approach: float | None
    energy_error: float | None
    contact_duration: float | None
    first_touch: float | None
    separation: float | None
    restitution: float | None
    impact_velocity: float | None
    rebound_velocity: float | None
    residual_indentation: float | None
    contacts: int

    def to_dict(self) -> dict:
        """The fields by name, in order (as ``summary.json`` writes them)."""
        return asdict(self)


def impact_measurements(history: dict[str, np.ndarray], initial_gap: float,
                        plastic: bool = True) -> ImpactMeasurements:
    """Peak force, approach, contact duration, restitution and energy error of a history.

    The contact starts at the first step with a force and ends at the first
    step after the peak force where the force is zero again (single nodes may
    chatter on and off at first touch); both ends are interpolated linearly
    in the approach, which is zero at first touch and at an elastic
    separation (the residual indentation after a dent). The
    restitution compares the relative normal velocity at the end of the run
    (or just before the bodies touch again) with that before first touch.
    The residual indentation is the approach at which the force reaches zero
    on unloading (``F^(2/3)`` extrapolated from the last two loaded steps,
    within the step where it vanishes): the permanent dent of both bodies
    together. When nothing yielded (``plastic=False``) it is 0: the bodies'
    vibration moves the point where an elastic pair parts by 1-3% of the
    largest approach either way, which is not a dent.
    """
    t, F = history["time"], history["contact_force"]
    E = history["total_energy"]
    e0 = E[0] if len(E) else 0.0
    out = {"peak_force": float(F.max(initial=0.0)),
           "time_of_peak_force": float(t[int(np.argmax(F))]) if F.max(initial=0.0) > 0
           else None,
           "max_approach": float(history["approach"].max(initial=-np.inf)) if len(F) else None,
           "energy_error": float(np.abs(E - e0).max() / e0) if e0 > 0 else None,
           "contact_duration": None, "first_touch": None, "separation": None,
           "restitution": None, "impact_velocity": None, "rebound_velocity": None,
           "residual_indentation": None, "contacts": 0}
    on = F > 0
    if not on.any():
        return ImpactMeasurements(**out)
    i0 = int(np.argmax(on))
    ipk = int(np.argmax(F))
    rest = ~on[ipk:]
    i1 = ipk + int(np.argmax(rest)) if rest.any() else None
    d = history["approach"]

    def cross(i: int) -> float:
        # the approach crosses zero between steps i-1 and i
        a, b = d[i - 1], d[i]
        s = 0.0 if b == a else min(max(-a / (b - a), 0.0), 1.0)
        return float(t[i - 1] + s * (t[i] - t[i - 1]))

    out["first_touch"] = cross(i0) if i0 > 0 else float(t[0])
    starts = np.flatnonzero(on[1:] & ~on[:-1]) + 1
    out["contacts"] = int(len(starts) + (1 if on[0] else 0))
    vn = history["normal_velocity"]
    v_before = float(vn[max(i0 - 1, 0)])
    out["impact_velocity"] = -v_before
    if i1 is not None:
        # first step with zero force: separation lies in (i1-1, i1], where the
        # approach passes zero (elastic) or, if it stays positive, the residual
        # indentation (a dent)
        res = _unloaded_approach(F, d, i1)
        end = 0.0 if d[i1] <= 0.0 else res
        a, b = d[i1 - 1] - end, d[i1] - end
        s = 0.0 if b == a else min(max(a / (a - b), 0.0), 1.0)
        out["separation"] = float(t[i1 - 1] + s * (t[i1] - t[i1 - 1]))
        out["contact_duration"] = out["separation"] - out["first_touch"]
        # an elastic pair can part a little before the first-touch position (the
        # sides' vibration): no dent, not a negative one
        out["residual_indentation"] = max(res, 0.0) if plastic else 0.0
        later = starts[starts > i1]
        j = int(later[0] - 1) if len(later) else len(t) - 1
        v_after = float(vn[j])
        out["rebound_velocity"] = v_after
        if v_before < 0:
            out["restitution"] = -v_after / v_before
    return ImpactMeasurements(**out)


def _unloaded_approach(F: np.ndarray, d: np.ndarray, i1: int) -> float:
    """Approach where the force falls to zero between steps ``i1 - 1`` and ``i1``.

    Unloading ends along a Hertz curve ``F ~ (d - d_p)^1.5`` (elastic or
    from a dent, as in Thornton's model), so ``F^(2/3)`` is extrapolated
    linearly from the last two loaded steps: exact for that curve, kept
    within the step.
    """
    lo, hi = sorted((float(d[i1]), float(d[i1 - 1])))
    if i1 >= 2 and F[i1 - 2] > F[i1 - 1] > 0 and d[i1 - 2] != d[i1 - 1]:
        y1, y2 = F[i1 - 1] ** (2.0 / 3.0), F[i1 - 2] ** (2.0 / 3.0)
        slope = (y2 - y1) / (d[i1 - 2] - d[i1 - 1])
        if slope > 0:
            return float(min(max(d[i1 - 1] - y1 / slope, lo), hi))
    return float(d[i1 - 1])
