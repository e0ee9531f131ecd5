"""The rolling mesh's common record, and the lumped model compared with the rolling FE.

Both sides of the comparison write one `RollingRecord`: the rolling FE
(`fe-impact roll`) and the lumped torsional model run on the same
`RollingCondition` (`fe_impact.rolling.lumped`). The comparison is then a
function of two records: `mesh_metrics` reduces one record to the figures a
gear engineer compares (transmission-error amplitude and mesh-order spectrum,
peak mesh-in force, mesh-in closing speeds, rattle impacts), and
`compare_metrics` gives their relative differences.

Conventions shared by every producer of a record
-----------------------------------------------
- Angles are positive in the driving sense (the pinion drives the face gear).
- Transmission error on the line of action (m): ``TE = r_bp theta_p - r_b2 theta_2``,
  ``r_bp`` the pinion's base radius, ``r_b2 = r_2 cos(alpha0)`` the face gear's
  lever, ``theta`` the rotor (hub) angles measured from the rigid, unloaded
  kinematic position; positive when the pinion leads (drive flank loaded). Any
  constant offset is allowed: the metrics remove the mean.
- Mesh force (N): the sum of the tooth pairs' normal contact forces on the drive
  flank (``drive_force``) and on the coast flank (``coast_force``), both >= 0, of
  one pinion-to-face-gear mesh.
- Contact events (`ContactEvents`), one per contact onset with a closing speed:

  - ``rattle``: a flank touches while none of its tooth pairs was in contact;
    peak force: the flank's total over that contact;
  - ``mesh-in``: a tooth pair touches while its flank already carries load
    (another pair of the same flank in contact); peak force: that pair's
    largest force over its engagement;
  - ``mesh-out``: a tooth pair leaves contact (closing speed: the opening speed,
    > 0; peak force: NaN);
  - ``switch``: the first contact after a ratio switch (the lumped model only).

  ``closing_speed`` is the rate of the pair's approach along the line of action
  at the onset [m/s, > 0]; ``location`` is where the pair first touched:
  ``flank`` (on the active path), ``corner-approach`` (the face gear's rounded tip
  edge, before the path) or ``corner-recess`` (the pinion's, after it);
  ``position`` is the pair's place on the line of action ``s`` [m] from the
  pinion's base-circle tangency (NaN if unknown).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from fe_impact.errors import CaseError

logger = logging.getLogger(__name__)

__all__ = [
    "EVENT_KINDS",
    "LOCATIONS",
    "ContactEvents",
    "RollingCondition",
    "RollingRecord",
]

#: Kinds of `ContactEvents.kind`.
EVENT_KINDS = ("rattle", "mesh-in", "mesh-out", "switch")
#: Places of `ContactEvents.location`.
LOCATIONS = ("flank", "corner-approach", "corner-recess")


@dataclass(frozen=True)
class RollingCondition:
    """One operating condition of a gear set's stage, the same for the FE and the lumped model.

    Attributes
    ----------
    name : str
        Short label, e.g. ``"loaded-1000"``, ``"rattle-300"``.
    stage : int
        Face-gear stage (ring), from 1.
    speed_rpm : float
        Pinion speed [r/min], constant, > 0.
    torque : float
        Load torque on the face gear [N m], >= 0, resisting its rotation (one mesh:
        one pinion drives the face-gear rotor).
    duration : float
        Simulated time [s], > 0; the metrics use the whole mesh periods after
        ``settle``.
    pinion_inertia : float
        Pinion rotor [kg m^2] (one pinion), > 0.
    gear_inertia : float
        Face-gear rotor [kg m^2] (ring, hub and load together), > 0.
    backlash : float
        Total normal backlash of the mesh [m], > 0.
    transmission_error : float
        Amplitude of a kinematic (no-load) transmission error at mesh frequency
        [m], >= 0: the excitation of an unloaded mesh, ``e = A sin(2 pi u / p_b)``
        with ``u`` the pinion's roll on the line of action; 0 for ideal flanks.
    drag_torque : float
        Constant drag on the face gear [N m], >= 0 (bearings, churning).
    friction : bool
        Coulomb friction between the flanks (the gear set's coefficients).
    settle : float
        Time [s] from the start left out of the metrics (start-up transient), >= 0.
    """

    name: str
    stage: int
    speed_rpm: float
    torque: float
    duration: float
    pinion_inertia: float
    gear_inertia: float
    backlash: float
    transmission_error: float = 0.0
    drag_torque: float = 0.0
    friction: bool = False
    settle: float = 0.0

    def __post_init__(self) -> None:
        if isinstance(self.stage, bool) or not isinstance(self.stage, int) or self.stage < 1:
            raise CaseError(f"condition {self.name!r}: stage = {self.stage!r} must be an "
                            "integer >= 1")
        positive = ("speed_rpm", "duration", "pinion_inertia", "gear_inertia", "backlash")
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0.0):
                raise CaseError(f"condition {self.name!r}: {name} = {value!r} must be a "
                                "finite number > 0")
        for name in ("torque", "transmission_error", "drag_torque", "settle"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0.0):
                raise CaseError(f"condition {self.name!r}: {name} = {value!r} must be a "
                                "finite number >= 0")
        if self.settle >= self.duration:
            raise CaseError(f"condition {self.name!r}: settle = {self.settle!r} s must be "
                            f"shorter than duration = {self.duration!r} s")

    def mesh_frequency(self, pinion_teeth: int) -> float:
        """Tooth-mesh frequency ``N_p n / 60`` [Hz]."""
        return pinion_teeth * self.speed_rpm / 60.0


def _floats(values, name: str, n: int | None = None) -> np.ndarray:
    out = np.asarray(values, dtype=float).reshape(-1)
    if n is not None and out.size != n:
        raise CaseError(f"{name}: {out.size} values, expected {n}")
    return out


@dataclass(frozen=True, eq=False)
class ContactEvents:
    """Contact onsets (and separations) of a rolling run; see the module's conventions.

    Attributes
    ----------
    time : ndarray, shape (m,)
        Onset (or separation) [s].
    kind : ndarray of str, shape (m,)
        One of `EVENT_KINDS`.
    flank : ndarray of int, shape (m,)
        +1 drive flank, -1 coast flank.
    closing_speed : ndarray, shape (m,)
        [m/s] along the line of action, > 0 (mesh-out: the opening speed).
    peak_force : ndarray, shape (m,)
        [N]; NaN where not defined (mesh-out, or a contact still open).
    location : ndarray of str, shape (m,)
        One of `LOCATIONS`.
    position : ndarray, shape (m,)
        The pair's place on the line of action [m] (NaN: unknown).
    """

    time: np.ndarray
    kind: np.ndarray
    flank: np.ndarray
    closing_speed: np.ndarray
    peak_force: np.ndarray
    location: np.ndarray
    position: np.ndarray

    def __post_init__(self) -> None:
        t = _floats(self.time, "events.time")
        n = t.size
        object.__setattr__(self, "time", t)
        object.__setattr__(self, "kind", np.asarray(self.kind, dtype=str).reshape(-1))
        object.__setattr__(self, "location", np.asarray(self.location, dtype=str).reshape(-1))
        object.__setattr__(self, "flank", np.asarray(self.flank, dtype=int).reshape(-1))
        for name in ("closing_speed", "peak_force", "position"):
            object.__setattr__(self, name, _floats(getattr(self, name), f"events.{name}", n))
        for name in ("kind", "location", "flank"):
            if getattr(self, name).size != n:
                raise CaseError(f"events.{name}: {getattr(self, name).size} values, "
                                f"expected {n}")
        bad = sorted(set(self.kind) - set(EVENT_KINDS))
        if bad:
            raise CaseError(f"events.kind: {bad} not among {list(EVENT_KINDS)}")
        bad = sorted(set(self.location) - set(LOCATIONS))
        if bad:
            raise CaseError(f"events.location: {bad} not among {list(LOCATIONS)}")

    @classmethod
    def empty(cls) -> ContactEvents:
        """No events."""
        z = np.zeros(0)
        return cls(z, np.zeros(0, dtype=str), np.zeros(0, dtype=int), z, z, np.zeros(0, str), z)

    def __len__(self) -> int:
        return int(self.time.size)

    def select(self, kind: str | None = None, t_min: float = -math.inf,
               t_max: float = math.inf) -> ContactEvents:
        """The events of one kind with ``t_min <= time <= t_max``."""
        keep = (self.time >= t_min) & (self.time <= t_max)
        if kind is not None:
            if kind not in EVENT_KINDS:
                raise CaseError(f"kind = {kind!r}; pick one of {list(EVENT_KINDS)}")
            keep &= self.kind == kind
        return ContactEvents(*(getattr(self, f)[keep] for f in self.__dataclass_fields__))

    def as_dict(self) -> dict[str, list]:
        """JSON-ready columns."""
        return {f: getattr(self, f).tolist() for f in self.__dataclass_fields__}


@dataclass(frozen=True, eq=False)
class RollingRecord:
    """What one model (rolling FE or lumped) computed for one `RollingCondition`.

    Attributes
    ----------
    source : str
        The model: e.g. ``"rolling FE"``, ``"lumped, calibrated"``, ``"lumped, closed forms"``.
    condition : RollingCondition
    pinion_teeth : int
        ``N_p`` (the mesh frequency is ``N_p n / 60``).
    time : ndarray, shape (n,)
        Sample times [s], rising; uniform sampling is not required (the metrics
        resample).
    te : ndarray, shape (n,)
        Transmission error on the line of action [m] (module conventions).
    drive_force, coast_force : ndarray, shape (n,)
        Total normal force of the drive / coast flank's tooth pairs [N], >= 0.
    events : ContactEvents
    pair_force : ndarray, shape (n, k) or None
        Force of each tooth pair in the model [N] (the FE's; None for the
        lumped model, which records the flanks' totals).
    info : dict
        Free-form run figures (wall time, mesh size, law source...), JSON-ready.
    """

    source: str
    condition: RollingCondition
    pinion_teeth: int
    time: np.ndarray
    te: np.ndarray
    drive_force: np.ndarray
    coast_force: np.ndarray
    events: ContactEvents
    pair_force: np.ndarray | None = None
    info: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        t = _floats(self.time, f"{self.source}: time")
        n = t.size
        object.__setattr__(self, "time", t)
        for name in ("te", "drive_force", "coast_force"):
            object.__setattr__(self, name, _floats(getattr(self, name),
                                                   f"{self.source}: {name}", n))
        if n < 2 or np.any(np.diff(t) <= 0.0):
            raise CaseError(f"{self.source}: time needs two or more rising samples")
        if self.pair_force is not None:
            pf = np.asarray(self.pair_force, dtype=float)
            if pf.ndim != 2 or pf.shape[0] != n:
                raise CaseError(f"{self.source}: pair_force has shape {pf.shape}, expected "
                                f"({n}, pairs)")
            object.__setattr__(self, "pair_force", pf)

    @property
    def mesh_frequency(self) -> float:
        """[Hz]."""
        return self.condition.mesh_frequency(self.pinion_teeth)
