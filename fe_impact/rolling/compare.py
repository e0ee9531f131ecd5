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
from pathlib import Path

import numpy as np

from fe_impact.errors import CaseError

logger = logging.getLogger(__name__)

__all__ = [
    "COMPARED",
    "EVENT_KINDS",
    "GOAL",
    "GOAL_FIGURES",
    "LOCATIONS",
    "ContactEvents",
    "GoalCheck",
    "basis_lines",
    "MeshMetrics",
    "RollingCondition",
    "RollingRecord",
    "check_goal",
    "compare_metrics",
    "counted_events",
    "te_extremes",
    "comparison_rows",
    "markdown_table",
    "mesh_harmonics",
    "mesh_metrics",
    "mesh_window",
    "phase_offset",
    "plot_condition",
    "read_record",
    "record_from_roll",
    "write_comparison",
    "write_record",
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
    load_ramp : float
        The load torque rises from 0 as ``sin^2`` over this time [s] (0: at once); the
        drag acts from the start.
    mesh_phase : float
        Where the tooth pairs stand at t = 0: pair 0 this many base pitches past the
        start of the path of contact [-].
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
    load_ramp: float = 0.0
    mesh_phase: float = 0.0

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
        for name in ("torque", "transmission_error", "drag_torque", "settle", "load_ramp",
                     "mesh_phase"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0.0):
                raise CaseError(f"condition {self.name!r}: {name} = {value!r} must be a "
                                "finite number >= 0")
        if self.settle >= self.duration or self.load_ramp > self.duration:
            raise CaseError(f"condition {self.name!r}: settle = {self.settle!r} s and "
                            f"load_ramp = {self.load_ramp!r} s must be shorter than "
                            f"duration = {self.duration!r} s")

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


#: Schema of `write_record`'s files.
RECORD_SCHEMA = "fe-impact/rolling-record/1"


def record_to_dict(record: RollingRecord) -> dict:
    """``record`` as JSON-ready data (`RECORD_SCHEMA`)."""
    return {"schema": RECORD_SCHEMA, "source": record.source,
            "condition": dict(record.condition.__dict__), "pinion_teeth": record.pinion_teeth,
            "time": record.time.tolist(), "te": record.te.tolist(),
            "drive_force": record.drive_force.tolist(),
            "coast_force": record.coast_force.tolist(), "events": record.events.as_dict(),
            "pair_force": None if record.pair_force is None else record.pair_force.tolist(),
            "info": record.info}


def record_from_dict(data: dict, where: str = "record") -> RollingRecord:
    """The `RollingRecord` of `record_to_dict`'s data; CaseError naming ``where`` if it
    is not one."""
    if not isinstance(data, dict) or data.get("schema") != RECORD_SCHEMA:
        raise CaseError(f"{where}: not a rolling record (schema {RECORD_SCHEMA!r} expected)")
    try:
        events = {k: [math.nan if v is None else v for v in vals] if k in (
            "closing_speed", "peak_force", "position") else vals
            for k, vals in data["events"].items()}
        pair = data.get("pair_force")
        return RollingRecord(
            source=data["source"], condition=RollingCondition(**data["condition"]),
            pinion_teeth=int(data["pinion_teeth"]), time=data["time"], te=data["te"],
            drive_force=data["drive_force"], coast_force=data["coast_force"],
            events=ContactEvents(**events),
            pair_force=None if pair is None else np.array(pair, dtype=float),
            info=data.get("info") or {})
    except (KeyError, TypeError) as exc:
        raise CaseError(f"{where}: incomplete rolling record ({exc})") from None


def write_record(path: str | Path, record: RollingRecord) -> Path:
    """Write ``record`` as JSON (atomically)."""
    from fe_impact.output.files import write_json

    return write_json(path, record_to_dict(record))


def read_record(path: str | Path) -> RollingRecord:
    """Read a record written by `write_record`."""
    import json

    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise CaseError(f"{path}: cannot read a rolling record ({exc})") from None
    return record_from_dict(data, str(path))


#: The rolling FE's names of where a pair touched, as `LOCATIONS`.
_FE_WHERE = {"flank": "flank", "approach-edge": "corner-approach",
             "recess-edge": "corner-recess"}
_FE_FLANK = {"drive": 1, "coast": -1}


def record_from_roll(result, condition: RollingCondition, pinion_teeth: int,
                     source: str = "rolling FE") -> RollingRecord:
    """The `RollingRecord` of a rolling FE run (`fe_impact.rolling.run.RollResult`).

    Flank forces are the sums of the tooth pairs' (``pair_force_n[..., 0]`` drive,
    ``[..., 1]`` coast; NaN, out of reach, counts 0); each `ContactEvent` keeps its
    kind, closing speed, peak force, place and ``s``, except the rattle impacts:
    the FE lists one per tooth pair, and two pairs of a flank that touch together
    at the end of a flight across the backlash (the contact ratio is above 1) are
    two rattle events there. A rattle is the flank's (module conventions), as the
    lumped model counts it: the FE's rattle events of one flank that begin before
    the first of them ends are one impact, at the first's time, place and closing
    speed (the fastest of those that touched in that step), with the flank's largest
    total force over the merged contact as its peak force (`_flank_rattles`).
    """
    forces = np.nan_to_num(np.asarray(result.pair_force_n, dtype=float))
    rows, rattles = [], []
    for e in result.events:
        if e.where not in _FE_WHERE or e.flank not in _FE_FLANK or e.kind not in EVENT_KINDS:
            raise CaseError(f"{source}: event at {e.time_s:g} s has kind = {e.kind!r}, "
                            f"where = {e.where!r}, flank = {e.flank!r}; expected "
                            f"{list(EVENT_KINDS)}, {list(_FE_WHERE)}, {list(_FE_FLANK)}")
        row = (e.time_s, e.kind, _FE_FLANK[e.flank], e.closing_speed_m_s, e.peak_force_n,
               _FE_WHERE[e.where], e.s_m)
        if e.kind == "rattle":
            rattles.append((row, e.end_time_s))
        else:
            rows.append(row)
    rows.extend(_flank_rattles(rattles, np.asarray(result.time_s, dtype=float),
                               forces.sum(axis=1)))
    rows.sort(key=lambda r: r[0])
    columns = list(zip(*rows, strict=True)) if rows else [[]] * 7
    events = (ContactEvents(*columns) if rows else ContactEvents.empty())
    return RollingRecord(
        source=source, condition=condition, pinion_teeth=pinion_teeth,
        time=result.time_s, te=result.te_m, drive_force=forces[..., 0].sum(axis=1),
        coast_force=forces[..., 1].sum(axis=1), events=events,
        pair_force=forces.reshape(forces.shape[0], -1), info=dict(result.info))


def _flank_rattles(rattles, time: np.ndarray, flank_forces: np.ndarray) -> list[tuple]:
    """One event row per flank contact of the FE's per-pair rattle events.

    ``rattles``: ``(row, end_time)`` of `record_from_roll`'s rows; ``flank_forces``
    (n, 2): the drive and coast flanks' total force at ``time``. Events of one flank
    whose onsets fall before the first one's end (NaN: still open) are merged.
    """
    out = []
    for flank in (1, -1):
        group = sorted((r for r in rattles if r[0][2] == flank), key=lambda r: r[0][0])
        column = flank_forces[:, 0 if flank == 1 else 1]
        while group:
            (first, end), rest = group[0], group[1:]
            stop = math.inf if math.isnan(end) else end
            merged = [first] + [r for r, _ in rest if r[0] < stop]
            group = [(r, e) for r, e in rest if r[0] >= stop]
            ends = [stop] + [e for r, e in rest if r[0] < stop]
            last = max(math.inf if math.isnan(e) else e for e in ends)
            inside = (time >= first[0]) & (time <= last)
            peak = float(column[inside].max()) if inside.any() else first[4]
            speed = max(r[3] for r in merged if r[0] == first[0])
            out.append((first[0], "rattle", flank, speed, max(peak, first[4]), first[5],
                        first[6]))
    return out


# -- metrics ------------------------------------------------------------------------------
#: Mesh orders whose transmission-error amplitude the metrics keep.
HARMONICS = 4
#: Samples per mesh period of the resampled transmission error.
RESAMPLE = 128
#: A mesh-in counts when the record runs this many mesh periods past its onset: a pair's
#: force peaks in the single-contact zone, which ends one base pitch after the pair
#: entered the path, so its peak force is in the record.
MESH_IN_HOLD = 1.0
#: Fraction of a mesh period by which the metrics' window may start before ``settle``.
SLACK = 0.02


@dataclass(frozen=True)
class MeshMetrics:
    """The figures of one `RollingRecord` that the comparison compares (SI units).

    Attributes
    ----------
    source, condition : str
        The record's model and condition name.
    mesh_frequency : float
        [Hz].
    periods : int
        Whole mesh periods in the window the figures are taken over.
    window : tuple of float
        ``(t0, t1)`` [s]: the last ``periods`` whole mesh periods after ``settle`` (the
        transmission error's figures).
    te_peak_to_peak, te_rms : float
        Of the mean-removed transmission error over the window [m].
    te_harmonics : tuple of float
        Amplitude of mesh orders 1..`HARMONICS` of the transmission error [m].
    mean_drive_force, mean_coast_force : float
        Time averages over the window [N].
    mesh_in_count : int
        Mesh-in impacts from ``settle`` to `MESH_IN_HOLD` periods before the end.
    mesh_in_force_median, mesh_in_force_max : float
        Their peak forces [N] (NaN without any).
    mesh_in_speed_median, mesh_in_speed_max : float
        Their closing speeds [m/s] (NaN without any).
    rattle_count : int
        Rattle impacts from ``settle`` on.
    rattle_force_max, rattle_speed_max : float
        Largest rattle peak force [N] and closing speed [m/s] (NaN without any).
    """

    source: str
    condition: str
    mesh_frequency: float
    periods: int
    window: tuple[float, float]
    te_peak_to_peak: float
    te_rms: float
    te_harmonics: tuple[float, ...]
    mean_drive_force: float
    mean_coast_force: float
    mesh_in_count: int
    mesh_in_force_median: float
    mesh_in_force_max: float
    mesh_in_speed_median: float
    mesh_in_speed_max: float
    rattle_count: int
    rattle_force_max: float
    rattle_speed_max: float

    def scalars(self) -> dict[str, float]:
        """The compared figures by name (harmonics as ``te_h1``, ``te_h2``, ...)."""
        out = {name: float(getattr(self, name)) for name in COMPARED if not
               name.startswith("te_h")}
        out.update({f"te_h{h + 1}": float(a) for h, a in enumerate(self.te_harmonics)})
        return {name: out[name] for name in COMPARED}


#: The figures `compare_metrics` sets side by side, in the table's order.
COMPARED = ("te_peak_to_peak", "te_rms", *(f"te_h{h}" for h in range(1, HARMONICS + 1)),
            "mesh_in_force_median", "mesh_in_force_max", "mesh_in_speed_median",
            "mesh_in_speed_max", "mesh_in_count", "rattle_count", "rattle_force_max",
            "rattle_speed_max", "mean_drive_force")
#: The figures of the goal: the calibrated model within `GOAL` of the rolling FE, and
#: closer than the closed forms.
GOAL_FIGURES = ("te_peak_to_peak", "te_rms", "mesh_in_force_median", "mesh_in_force_max")
GOAL = 0.10
#: Units and scale of each compared figure in the tables.
UNITS = {"te_peak_to_peak": ("um", 1e6), "te_rms": ("um", 1e6),
         **{f"te_h{h}": ("um", 1e6) for h in range(1, HARMONICS + 1)},
         "mesh_in_force_median": ("N", 1.0), "mesh_in_force_max": ("N", 1.0),
         "mesh_in_speed_median": ("mm/s", 1e3), "mesh_in_speed_max": ("mm/s", 1e3),
         "mesh_in_count": ("", 1.0), "rattle_count": ("", 1.0),
         "rattle_force_max": ("N", 1.0), "rattle_speed_max": ("mm/s", 1e3),
         "mean_drive_force": ("N", 1.0)}


def mesh_window(time: np.ndarray, frequency: float, settle: float) -> tuple[float, float, int]:
    """The last whole number of mesh periods of ``time`` after ``settle``: ``(t0, t1, periods)``
    (``t0`` may precede ``settle`` by up to `SLACK` of a period).

    A window of whole periods puts every mesh order on an exact bin of the discrete
    Fourier transform, so a signal periodic in the mesh period has no leakage
    (rectangular window).
    """
    t_start = max(float(time[0]), float(time[0]) + settle)
    t_end = float(time[-1])
    # a record sampled up to its duration may end a sample short of it: the window may
    # reach back up to SLACK of a period into the settling time
    periods = int(math.floor((t_end - t_start) * frequency + SLACK))
    if periods < 1:
        raise CaseError(f"{t_end - t_start:.4g} s after settle hold no whole mesh period "
                        f"({1.0 / frequency:.4g} s): run longer")
    return t_end - periods / frequency, t_end, periods


def mesh_harmonics(time: np.ndarray, signal: np.ndarray, frequency: float, periods: int,
                   t0: float, orders: int = HARMONICS,
                   per_period: int = RESAMPLE) -> np.ndarray:
    """Amplitudes of mesh orders ``1..orders`` of ``signal`` over ``periods`` whole periods.

    The signal is resampled linearly at ``per_period`` points per period from ``t0``
    (``M = periods per_period`` points, ends excluded), its mean removed, and order
    ``h`` read from DFT bin ``h periods``: amplitude ``2 |X_k| / M``, exact for
    ``a sin(2 pi h f t + phi)`` (no window needed: the window holds whole periods).

    Returns
    -------
    ndarray, shape (orders,)
        Amplitudes in the signal's unit.
    """
    if per_period <= 2 * orders:
        raise CaseError(f"per_period = {per_period} must exceed 2 orders = {2 * orders} "
                        "(Nyquist)")
    m = periods * per_period
    t = t0 + np.arange(m) / (per_period * frequency)
    y = np.interp(t, time, signal)
    spectrum = np.fft.rfft(y - y.mean())
    bins = periods * np.arange(1, orders + 1)
    return 2.0 * np.abs(spectrum[bins]) / m


def _stat(values: np.ndarray, how) -> float:
    return float(how(values)) if values.size else math.nan


def counted_events(record: RollingRecord) -> tuple[ContactEvents, ContactEvents]:
    """The mesh-in and the rattle impacts the metrics count: from ``settle`` on, the
    mesh-in ones up to `MESH_IN_HOLD` mesh periods before the record's end."""
    start, end = record.time[0] + record.condition.settle, record.time[-1]
    hold = MESH_IN_HOLD / record.mesh_frequency
    return (record.events.select("mesh-in", start, end - hold),
            record.events.select("rattle", start, end))


def mesh_metrics(record: RollingRecord) -> MeshMetrics:
    """Reduce a record to its `MeshMetrics`.

    The transmission error over the last whole mesh periods after ``settle``
    (`mesh_window`); the impacts from ``settle`` on (mesh-in impacts up to
    `MESH_IN_HOLD` periods before the end).
    """
    f = record.mesh_frequency
    t0, t1, periods = mesh_window(record.time, f, record.condition.settle)
    inside = (record.time >= t0) & (record.time <= t1)
    te = record.te[inside]
    te = te - te.mean()
    harmonics = mesh_harmonics(record.time, record.te, f, periods, t0)
    mesh_in, rattle = counted_events(record)
    return MeshMetrics(
        source=record.source, condition=record.condition.name, mesh_frequency=f,
        periods=periods, window=(t0, t1), te_peak_to_peak=float(np.ptp(te)),
        te_rms=float(np.sqrt(np.mean(te**2))), te_harmonics=tuple(float(a) for a in harmonics),
        mean_drive_force=float(np.mean(record.drive_force[inside])),
        mean_coast_force=float(np.mean(record.coast_force[inside])),
        mesh_in_count=len(mesh_in),
        mesh_in_force_median=_stat(mesh_in.peak_force, np.median),
        mesh_in_force_max=_stat(mesh_in.peak_force, np.max),
        mesh_in_speed_median=_stat(mesh_in.closing_speed, np.median),
        mesh_in_speed_max=_stat(mesh_in.closing_speed, np.max),
        rattle_count=len(rattle), rattle_force_max=_stat(rattle.peak_force, np.max),
        rattle_speed_max=_stat(rattle.closing_speed, np.max))


def te_extremes(record: RollingRecord) -> tuple[float, float]:
    """Times [s] of the largest and the smallest transmission error in the metrics'
    window (`mesh_window`): the two samples its peak-to-peak is taken from."""
    t0, t1, _ = mesh_window(record.time, record.mesh_frequency, record.condition.settle)
    inside = np.flatnonzero((record.time >= t0) & (record.time <= t1))
    te = record.te[inside]
    return float(record.time[inside[np.argmax(te)]]), float(record.time[inside[np.argmin(te)]])


def period_figures(record: RollingRecord) -> tuple[np.ndarray, np.ndarray]:
    """TE peak-to-peak and RMS [m] of each whole mesh period of the metrics' window
    (`mesh_window`), each period's own mean removed: how much the window's figures vary
    from one mesh period (one mesh-in) to the next."""
    f = record.mesh_frequency
    t0, _, periods = mesh_window(record.time, f, record.condition.settle)
    pp, rms = np.zeros(periods), np.zeros(periods)
    for k in range(periods):
        inside = (record.time >= t0 + k / f) & (record.time <= t0 + (k + 1) / f)
        te = record.te[inside] - record.te[inside].mean()
        pp[k], rms[k] = np.ptp(te), np.sqrt(np.mean(te**2))
    return pp, rms


def _last_impact(record: RollingRecord, t: float) -> tuple[float, str] | None:
    """Onset [s] and kind of the record's last mesh-in or rattle impact in the mesh
    period up to ``t`` (counted by the metrics or not: one near the record's end still
    rings the TE); None when there is none."""
    ev = record.events
    first = t - 1.0 / record.mesh_frequency
    before = [(float(e), str(kind)) for e, kind in zip(ev.time, ev.kind, strict=True)
              if kind in ("mesh-in", "rattle") and first < e <= t]
    return max(before) if before else None


def basis_lines(records) -> str:
    """What each condition's figures rest on, one Markdown line per condition and model:
    the whole mesh periods of the TE window, where its peak-to-peak's two extremes
    fall (how many mesh periods after an impact, when less than one), and how many
    impacts the impact figures count (with several periods, each one's TE peak-to-peak
    and RMS; with several mesh-ins, the range of their peak
    forces beside the median). A figure taken from one impact (its median is its
    largest) and a peak-to-peak whose two extremes both follow the same impact by less
    than a mesh period are that event's, not a statistic of the mesh: the line says
    so."""
    lines = []
    for name, group in _by_condition(records).items():
        for record in group:
            m = mesh_metrics(record)
            f = record.mesh_frequency
            extremes = te_extremes(record)
            after = [_last_impact(record, t) for t in extremes]
            where = [f"{(t - a[0]) * f:.2f} periods after a {a[1]}" if a else
                     "not within a period after an impact"
                     for t, a in zip(extremes, after, strict=True)]
            single = []
            if m.mesh_in_count == 1:
                single.append("mesh-in figures from one event")
            if after[0] and after[0] == after[1]:
                single.append(f"peak-to-peak set by one {after[0][1]}")
            note = f" ({'; '.join(single)})" if single else ""
            spread = ""
            if m.mesh_in_count > 1:     # the spread the median and the largest come from
                forces = counted_events(record)[0].peak_force
                spread = (f" (peak forces {forces.min():.4g} .. {forces.max():.4g} N, "
                          f"median {m.mesh_in_force_median:.4g} N)")
            per = ""
            if m.periods > 1:
                pp, rms = period_figures(record)
                per = (f" (per period: peak-to-peak {' '.join(f'{v * 1e6:.3g}' for v in pp)}"
                       f" um, RMS {' '.join(f'{v * 1e6:.3g}' for v in rms)} um)")
            lines.append(f"- {name}, {record.source}: TE over {m.periods} mesh period"
                         f"{'s' if m.periods != 1 else ''}{per}, its max {where[0]}, its min "
                         f"{where[1]}; {m.mesh_in_count} mesh-in{spread}, "
                         f"{m.rattle_count} rattle{note}")
    return "\n".join(lines) + "\n"


def mesh_in_phase(record: RollingRecord) -> float:
    """Where in the mesh period the record's mesh-in impacts fall, from ``settle`` on:
    the circular mean of ``t f mod 1`` [-, 0..1); NaN without a mesh-in."""
    f = record.mesh_frequency
    ev = record.events.select("mesh-in", record.time[0] + record.condition.settle)
    if not len(ev):
        return math.nan
    z = np.mean(np.exp(2j * np.pi * ev.time * f))
    return float(np.angle(z) / (2 * np.pi) % 1.0)


def phase_offset(reference: RollingRecord, other: RollingRecord) -> float:
    """How much earlier in the mesh period ``other``'s mesh-in impacts fall than
    ``reference``'s [periods, 0..1): add it to ``other``'s ``mesh_phase`` to place its
    tooth pairs as ``reference``'s (NaN when either has no mesh-in)."""
    return float((mesh_in_phase(other) - mesh_in_phase(reference)) % 1.0)


def relative_difference(value: float, reference: float) -> float:
    """``(value - reference) / |reference|``; 0 when both are 0, NaN when only the
    reference is 0 or either is NaN."""
    if math.isnan(value) or math.isnan(reference):
        return math.nan
    if reference == 0.0:
        return 0.0 if value == 0.0 else math.nan
    return (value - reference) / abs(reference)


def compare_metrics(reference: MeshMetrics, other: MeshMetrics) -> dict[str, float]:
    """Relative difference of each `COMPARED` figure of ``other`` from ``reference``."""
    ref, val = reference.scalars(), other.scalars()
    return {name: relative_difference(val[name], ref[name]) for name in COMPARED}


@dataclass(frozen=True)
class GoalCheck:
    """The goal on one condition: the calibrated lumped model within `GOAL` of the FE on
    each of `GOAL_FIGURES`, and closer to it than the closed forms.

    Attributes
    ----------
    condition : str
    calibrated, closed_form : dict
        Relative differences from the FE per goal figure.
    within : dict
        Whether ``|calibrated| <= GOAL`` per figure (figures the FE lacks, e.g. no
        mesh-in impact, are left out).
    closer : dict
        Whether ``|calibrated| < |closed_form|`` per figure.
    """

    condition: str
    calibrated: dict
    closed_form: dict
    within: dict
    closer: dict

    @property
    def passed(self) -> bool:
        return all(self.within.values()) and all(self.closer.values())


def check_goal(fe: MeshMetrics, calibrated: MeshMetrics, closed_form: MeshMetrics) -> GoalCheck:
    """`GoalCheck` of one condition from the three models' metrics."""
    cal = compare_metrics(fe, calibrated)
    closed = compare_metrics(fe, closed_form)
    defined = [n for n in GOAL_FIGURES if not math.isnan(fe.scalars()[n])]
    within = {n: bool(abs(cal[n]) <= GOAL) for n in defined}
    closer = {n: bool(abs(cal[n]) < abs(closed[n])) for n in defined}
    return GoalCheck(fe.condition, {n: cal[n] for n in defined},
                     {n: closed[n] for n in defined}, within, closer)


# -- tables and plots ---------------------------------------------------------------------
#: The record the others are compared with, when present.
REFERENCE = "rolling FE"


def _by_condition(records) -> dict[str, list[RollingRecord]]:
    out: dict[str, list[RollingRecord]] = {}
    for record in records:
        out.setdefault(record.condition.name, []).append(record)
    return out


def comparison_rows(records, reference: str = REFERENCE) -> list[dict]:
    """One row per condition and compared figure: each model's value (table units) and,
    when ``reference`` is among the condition's records, each other's relative
    difference from it."""
    rows = []
    for name, group in _by_condition(records).items():
        metrics = {r.source: mesh_metrics(r) for r in group}
        ref = metrics.get(reference)
        for figure in COMPARED:
            unit, scale = UNITS[figure]
            row = {"condition": name, "figure": figure, "unit": unit}
            for source, m in metrics.items():
                row[source] = m.scalars()[figure] * scale
            if ref is not None:
                for source, m in metrics.items():
                    if source != reference:
                        row[f"{source} vs FE"] = compare_metrics(ref, m)[figure]
            rows.append(row)
    return rows


def _cell(value) -> str:
    if isinstance(value, str):
        return value
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    return f"{value:.4g}"


def markdown_table(rows: list[dict]) -> str:
    """The rows as a Markdown table (relative differences in percent)."""
    columns = list(dict.fromkeys(k for row in rows for k in row))
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for row in rows:
        cells = []
        for c in columns:
            v = row.get(c)
            if c.endswith(" vs FE") and isinstance(v, float) and not math.isnan(v):
                cells.append(f"{100.0 * v:+.1f}%")
            else:
                cells.append(_cell(v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def write_comparison(out: str | Path, records, reference: str = REFERENCE,
                     goal: dict | None = None) -> list[Path]:
    """Write ``compare.md``, ``compare.csv``, ``compare.json`` and one PNG per condition.

    Parameters
    ----------
    out : path
        Folder (made if missing).
    records : sequence of RollingRecord
    reference : str
        The source the others are compared with.
    goal : dict, optional
        Condition name -> `GoalCheck`, written into the JSON and the Markdown.
    """
    from fe_impact.output.files import atomic_path, write_csv, write_json

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rows = comparison_rows(records, reference)
    columns = list(dict.fromkeys(k for row in rows for k in row))
    text = markdown_table(rows) + "\n" + basis_lines(records)
    if goal:
        text += "\n" + goal_lines(goal)
    with atomic_path(out / "compare.md") as tmp:
        tmp.write_text(text)
    paths = [out / "compare.md",
             write_csv(out / "compare.csv", columns, [[row.get(c) for c in columns]
                                                      for row in rows])]
    metrics = [mesh_metrics(r).__dict__ | {"law_source": r.info.get("law_source")}
               for r in records]
    conditions = {r.condition.name: r.condition.__dict__ for r in records}
    payload = {"schema": "fe-impact/rolling-compare/1", "reference": reference,
               "goal_tolerance": GOAL, "conditions": conditions, "metrics": metrics,
               "rows": rows,
               "goal": {k: v.__dict__ | {"passed": v.passed} for k, v in (goal or {}).items()}}
    paths.append(write_json(out / "compare.json", payload))
    for name, group in _by_condition(records).items():
        paths.append(plot_condition(group, out / f"compare_{name}.png"))
    return paths


def goal_lines(goal: dict) -> str:
    """One Markdown line per condition's `GoalCheck`."""
    lines = []
    for name, check in goal.items():
        figures = ", ".join(f"{n} {100 * check.calibrated[n]:+.1f}% (closed forms "
                            f"{100 * check.closed_form[n]:+.1f}%)" for n in check.calibrated)
        verdict = "met" if check.passed else "NOT met"
        lines.append(f"- {name}: goal {verdict}: {figures or 'no figure defined'}")
    return "\n".join(lines) + "\n"


def plot_condition(records, path: str | Path, periods_shown: int = 6) -> Path:
    """One PNG for one condition: TE over the last ``periods_shown`` mesh periods, its
    mesh-order amplitudes, and the impacts the metrics count (`counted_events`: closing
    speed against peak force), each model in its own colour."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fe_impact.output.files import atomic_path

    fig, (ax_te, ax_sp, ax_ev) = plt.subplots(1, 3, figsize=(15, 4.2))
    width = 0.8 / max(len(records), 1)
    markers = {"mesh-in": "o", "rattle": "x"}
    for j, record in enumerate(records):
        colour = f"C{j}"
        m = mesh_metrics(record)
        period = 1.0 / m.mesh_frequency
        t0 = m.window[1] - min(periods_shown, m.periods) * period
        keep = record.time >= t0
        inside = (record.time >= m.window[0]) & (record.time <= m.window[1])
        mean = record.te[inside].mean()
        ax_te.plot((record.time[keep] - t0) / period, 1e6 * (record.te[keep] - mean),
                   color=colour, label=record.source)
        orders = np.arange(1, len(m.te_harmonics) + 1)
        ax_sp.bar(orders + (j - 0.5 * (len(records) - 1)) * width,
                  1e6 * np.asarray(m.te_harmonics), width, color=colour, label=record.source)
        for kind, ev in zip(("mesh-in", "rattle"), counted_events(record), strict=True):
            if len(ev) and np.any(np.isfinite(ev.peak_force)):
                ax_ev.scatter(1e3 * ev.closing_speed, ev.peak_force, marker=markers[kind],
                              color=colour, label=f"{record.source}: {kind}")
    name = records[0].condition.name if records else ""
    ax_te.set(xlabel="time [mesh periods]", ylabel="TE - mean [um]",
              title=f"{name}: transmission error")
    ax_sp.set(xlabel="mesh order", ylabel="TE amplitude [um]", title="TE spectrum")
    ax_ev.set(xlabel="closing speed [mm/s]", ylabel="peak force [N]", title="impacts")
    for ax in (ax_te, ax_sp, ax_ev):
        ax.grid(alpha=0.3)
    ax_te.legend(fontsize=8)
    if ax_ev.collections:
        ax_ev.legend(fontsize=7)
    fig.tight_layout()
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    return path
