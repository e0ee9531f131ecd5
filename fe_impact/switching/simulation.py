"""Running a `DriveModel` through a `StageSchedule`: the result records and the driver.

`simulate` packs the model into arrays, integrates segment by segment in
chunks with the compiled kernel (`fe_impact.switching._kernel`: Dormand-
Prince 5(4) with error control, numba), and collects the sampled time
series, the impacts and the per-stage statistics.

Impact detection: an impact is a contact onset with a closing speed. After
each accepted step every tooth pair's approach is compared with its value at
the step start; a sign change locates the onset (or the separation) on the
cubic Hermite interpolant of the approach, and the closing (opening) speed is
the interpolant's slope there. The law parameters of the pair are then taken
at that speed. See `ImpactEvents` for the kinds and what is recorded.
"""

from __future__ import annotations

import functools
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from fe_impact.calibration.records import KINDS
from fe_impact.errors import CaseError, SolverError
from fe_impact.switching import _kernel as K
from fe_impact.switching.model import (
    DRIVES,
    RPM,
    DriveModel,
    Friction,
    Segment,
    StageSchedule,
)

logger = logging.getLogger(__name__)

__all__ = [
    "CONTACT_NAMES",
    "friction_coefficient",
    "KIND_NAMES",
    "LAW_NAMES",
    "SERIES_QUANTITIES",
    "ImpactEvents",
    "SwitchingRun",
    "mechanical_energy",
    "series_columns",
    "simulate",
]

#: Quantities whose statistics are kept per stage, in the kernel's order: signed
#: approach [m], relative speed along the line of action [m/s], signed mesh force
#: [N], elastic energy of the mesh [J] (all per mesh).
SERIES_QUANTITIES = ("elastic_displacement", "impact_speed", "impact_force", "potential_energy")
#: Largest ``h omega`` allowed for the stiffest coupling mode (DOPRI5 is stable up to
#: about 3.3 on the imaginary axis; the margin avoids rejected steps).
_STABLE_STEP = 2.0


def series_columns(n_stages: int) -> tuple[str, ...]:
    """Names of the time-series columns (SI units in the suffixes)."""
    rings = tuple(f"ring{i}_speed_rad_s" for i in range(1, n_stages + 1))
    twists = tuple(f"ring{i}_twist_rad" for i in range(1, n_stages + 1))
    return ("time_s", "stage", "pinion_speed_rad_s", *rings, "output_speed_rad_s", *twists,
            "elastic_displacement_m", "impact_speed_m_s", "impact_force_N",
            "potential_energy_J", "pairs_in_contact", "mesh_displacement_m",
            "friction_torque_Nm", "load_torque_Nm", "input_torque_Nm", "drive_force_N",
            "coast_force_N")


#: Names of the impact kinds recorded in `ImpactEvents.kind`.
KIND_NAMES = {K.KIND_RATTLE: "rattle", K.KIND_MESH_IN: "mesh-in", K.KIND_SWITCH: "switch"}
#: Names of where the pair touched, `ImpactEvents.contact`.
CONTACT_NAMES = {K.CONTACT_FLANK: "flank", K.CONTACT_APPROACH: "corner-approach",
                 K.CONTACT_RECESS: "corner-recess"}
#: Names of the law tables an impact's onset took (`ImpactEvents.law`): the kinds of
#: `fe_impact.calibration.records.KINDS`, in their order.
LAW_NAMES = dict(enumerate(KINDS))


@dataclass(frozen=True, eq=False)
class ImpactEvents:
    """Impacts recorded during a run (one entry per contact onset with closing speed).

    Kinds: ``rattle`` (0), a flank touching while none of its pairs was in
    contact; ``mesh-in`` (1), a tooth pair touching while its flank already
    carries load; ``switch`` (2), the first contact after a ratio switch.
    For rattle and switch impacts, approach, force and energy are the peaks
    of the whole flank over the contact; for mesh-in impacts those of the
    pair, over its engagement.

    Attributes
    ----------
    time : ndarray
        Contact onset [s] (located on the step's interpolant).
    stage, kind, flank : ndarray of int
        Stage from 1; kind code; +1 drive flank, -1 coast flank.
    speed : ndarray
        Closing speed at onset [m/s].
    approach, force, energy : ndarray
        Peak approach [m], force per mesh [N], elastic energy per mesh [J].
    end_time, separation_speed : ndarray
        When the contact ended [s] and the opening speed then [m/s]; NaN if
        it had not ended by the end of the run, or by the ratio switch that
        cut it (the new ring's segment starts with no contact open).
    clamped : ndarray of int
        -1/+1 if the impact speed was below/above the law table, else 0.
    contact : ndarray of int
        Where the (first) touching pair was at the onset (`CONTACT_NAMES`): on
        the flanks, or beyond the path's start or end on a rounded tip edge.
    law : ndarray of int
        The law table the onset took (`LAW_NAMES`): the switch law for a
        switch impact, a corner law for a touch on a rounded tip edge (where
        the stage has one), else the mesh law.
    position : ndarray
        Where the (first) touching pair was on the line of action at the onset,
        ``s`` [m] from the pinion's base-circle tangency (the path of contact runs
        from `MeshGeometry.s_start` to ``s_end``).
    """

    time: np.ndarray
    stage: np.ndarray
    kind: np.ndarray
    flank: np.ndarray
    speed: np.ndarray
    approach: np.ndarray
    force: np.ndarray
    energy: np.ndarray
    end_time: np.ndarray
    separation_speed: np.ndarray
    clamped: np.ndarray
    contact: np.ndarray
    law: np.ndarray
    position: np.ndarray

    @classmethod
    def from_kernel(cls, ev: np.ndarray) -> ImpactEvents:
        """From the kernel's `_kernel.EVENT` records."""
        fields = ("time", "stage", "kind", "flank", "speed", "approach", "force", "energy",
                  "end", "speed_out", "clamp", "contact", "law", "s")
        return cls(*(ev[name].copy() for name in fields))

    def __len__(self) -> int:
        return int(self.time.size)

    @property
    def restitution(self) -> np.ndarray:
        """``separation_speed / speed`` [-] (NaN for contacts still open)."""
        return self.separation_speed / self.speed

    def select(self, stage: int | None = None, kind: str | None = None,
               contact: str | None = None) -> ImpactEvents:
        """The events of one stage, kind (``"rattle"``, ``"mesh-in"``, ``"switch"``) and/or
        place of contact (``"flank"``, ``"corner-approach"``, ``"corner-recess"``)."""
        keep = np.ones(len(self), dtype=bool)
        if stage is not None:
            keep &= self.stage == stage
        for name, value, names, codes_of in (("kind", kind, KIND_NAMES, self.kind),
                                             ("contact", contact, CONTACT_NAMES, self.contact)):
            if value is None:
                continue
            codes = {v: k for k, v in names.items()}
            if value not in codes:
                raise CaseError(f"{name} = {value!r}; pick one of {list(codes)}")
            keep &= codes_of == codes[value]
        return ImpactEvents(*(getattr(self, f)[keep] for f in self.__dataclass_fields__))


@dataclass(frozen=True, eq=False)
class SwitchingRun:
    """Result of `simulate`.

    Attributes
    ----------
    model : DriveModel
    schedule : StageSchedule
    series : dict of str to ndarray
        Time series sampled every ``sample_interval``; names in
        `series_columns`, SI units. Mesh quantities are those of the engaged
        ring, per mesh.
    events : ImpactEvents
    stage_stats : ndarray, shape (n_stages, 4, 4)
        Per stage and quantity of `SERIES_QUANTITIES`: time integral, max,
        min over every accepted integration step while the stage was engaged,
        and the engaged duration (in ``[:, 0, 3]``).
    info : dict
        Integrator and run figures (steps, rejected steps, right-hand-side
        evaluations, wall time, clamped law look-ups, ...).
    """

    model: DriveModel
    schedule: StageSchedule
    series: dict[str, np.ndarray]
    events: ImpactEvents
    stage_stats: np.ndarray
    info: dict


# -- packing the model for the kernel -----------------------------------------------------
def _schedule_array(schedule: StageSchedule, ramp: float) -> np.ndarray:
    """`_kernel.SEGMENT` records for `_kernel.reference`: one per segment, or per part of a
    segment between two points of its load series. ``ramp``: the blend of the segments
    that do not set their own."""
    rows = []
    psi = 0.0
    prev = None
    for t0, seg in zip(schedule.start_times, schedule.segments, strict=True):
        w0 = seg.speed_rpm * RPM
        rate = (seg.end_speed_rpm - seg.speed_rpm) * RPM / seg.duration
        if prev is None:
            blend, before = 0.0, (w0, seg.load, seg.input_torque)
        else:
            blend = ramp if seg.blend is None else seg.blend
            before = (prev.end_speed_rpm * RPM, prev.end_load, prev.input_torque)
        times, loads = seg.load_profile()
        for k in range(len(times) - 1):
            slope = (loads[k + 1] - loads[k]) / (times[k + 1] - times[k])
            rows.append((t0 + times[k], t0, w0, rate, before[0], loads[k], slope, before[1],
                         seg.input_torque, before[2], psi, blend, int(prev is not None)))
        psi += K.segment_angle(0.0, seg.duration, w0, rate, before[0], blend)
        prev = seg
    return np.array(rows, dtype=K.SEGMENT)


@dataclass
class _Packed:
    """Arrays handed to the kernel; mutable run state lives here too.

    ``params`` holds one `_kernel.PARAMS` record (`p` is that record, a
    view: writing its fields writes the array); ``stages`` one
    `_kernel.STAGE` record per ring; ``corners`` each ring's approach and
    recess corner-gap tables, shape (rings, 2, 2, nodes): values and slopes.
    """

    params: np.ndarray
    stages: np.ndarray
    aoff: np.ndarray
    atol: np.ndarray
    corners: np.ndarray
    postab: np.ndarray
    sch: np.ndarray
    tab: np.ndarray
    ntab: np.ndarray
    slots: np.ndarray = field(default_factory=lambda: np.zeros((2, K.NSLOT), dtype=K.SLOT))
    flanks: np.ndarray = field(default_factory=lambda: np.zeros(2, dtype=K.FLANK))

    @property
    def p(self) -> np.void:
        return self.params[0]


def _pack(model: DriveModel, schedule: StageSchedule, sample_interval: float) -> _Packed:
    geo = model.geometry
    n = model.n_stages
    rings = [model.stage_geometry(i + 1) for i in range(n)]
    window = geo.s_end - geo.s_start + max(r.approach.delta_max + r.recess.delta_max
                                           for r in rings)
    if math.floor(window / geo.base_pitch) + 2 > min(K.MAXPAIR, K.NSLOT):
        raise CaseError(f"{window / geo.base_pitch:.1f} base pitches of contact path and tip "
                        f"corners: more tooth pairs than the kernel tracks ({K.MAXPAIR})")
    params = np.zeros(1, dtype=K.PARAMS)
    p = params[0]
    p["base_radius"], p["base_pitch"] = geo.base_radius, geo.base_pitch
    p["s_start"], p["s_end"], p["s_pitch"] = geo.s_start, geo.s_end, geo.s_pitch
    p["pinions"] = model.pinions
    p["te_amplitude"] = model.transmission_error
    _set_friction(p, model.friction)
    p["drive"] = DRIVES.index(model.drive)
    p["u0"] = model.mesh_phase * geo.base_pitch
    p["rtol"] = model.rtol
    max_speed = max(max(s.max_speed_rpm for s in schedule.segments) * RPM, 1e-9)
    # a tooth pair passes every p_b / (r_bp omega): take at least 8 steps per pair
    passing = geo.base_pitch / (geo.base_radius * max_speed)
    # the ring-on-web modes (~9 kHz) are resolved but carry little: keep the step inside
    # the explicit method's stability limit (|h lambda| < 3.3 on the imaginary axis for
    # DOPRI5) instead of letting the error control find it by rejections
    web = np.sqrt(model.couplings / model.ring_inertias
                  * (1.0 + model.ring_inertias / model.output_j)).max()
    p["max_step"] = min(model.max_step, passing / 8.0, _STABLE_STEP / web)
    p["pinion_inertia"] = model.pinions * model.pinion_j
    p["output_inertia"] = model.output_j
    p["sample_dt"] = sample_interval
    p["drag"] = model.drag_torque
    stages = np.zeros(n, dtype=K.STAGE)
    stages["inertia"] = model.ring_inertias
    stages["coupling"] = model.couplings
    stages["damping"] = model.coupling_damping
    stages["lever"] = model.base_levers
    stages["corner_in"] = [r.approach.delta_max for r in rings]
    stages["corner_out"] = [r.recess.delta_max for r in rings]
    stages["law_in"] = [r.approach.reference_delta for r in rings]
    stages["law_out"] = [r.recess.reference_delta for r in rings]
    levers = np.concatenate([[geo.base_radius], model.base_levers, [model.base_levers.min()]])
    atol = np.empty(2 * (n + 2))
    atol[0::2] = model.length_tol / levers
    atol[1::2] = model.speed_tol / levers
    tab, ntab = model.law_set.kernel_arrays()
    corners = np.stack([np.stack([np.stack([r.approach.values, r.approach.slopes]),
                                  np.stack([r.recess.values, r.recess.slopes])])
                        for r in rings])
    postab = model.law_set.position_arrays(geo.s_pitch, geo.base_radius, K.NPOS)
    return _Packed(params=params, stages=stages, aoff=np.zeros(n + 2), atol=atol,
                   corners=corners, postab=postab,
                   sch=_schedule_array(schedule, model.ramp_time), tab=tab, ntab=ntab)


def _check_schedule(model: DriveModel, schedule: StageSchedule) -> None:
    for i, seg in enumerate(schedule.segments):
        if seg.stage > model.n_stages:
            raise CaseError(f"segment {i + 1}: stage = {seg.stage} but the gear set has "
                            f"{model.n_stages} stages (1..{model.n_stages})")
        blend = model.ramp_time if seg.blend is None else seg.blend
        if i > 0 and seg.duration < blend:
            what = "ramp_time" if seg.blend is None else "its blend"
            raise CaseError(f"segment {i + 1}: duration = {seg.duration!r} s is shorter than "
                            f"{what} = {blend!r} s")


def _static_offset(model: DriveModel, pk: _Packed, stage: int, load: float,
                   roll: float) -> float:
    """Mesh coordinate that carries ``load`` statically at pinion roll ``roll``.

    Drive flank, elastic part of the laws the kernel gives each pair before its
    first onset (``pk.p``'s, set for ``stage``: the position law on the path, a
    tip edge's corner law beyond it; :func:`~fe_impact.switching._kernel.pair_law`);
    bisection on the total force of the pairs on the active path and near its ends.
    """
    i = stage - 1
    half = 0.5 * model.backlashes[i]
    target = load / (model.pinions * model.base_levers[i])
    if target <= 0.0:
        return model.engage_position * half
    p = pk.p
    geo = model.stage_geometry(stage)
    phase = (roll + model.mesh_phase * geo.base_pitch) % geo.base_pitch
    s = geo.s_start + phase + geo.base_pitch * np.arange(-2, 4)
    g, _ = geo.gap(s)
    kn = np.array([K.pair_law(float(x), p, pk.postab[i], p["law_k"], p["law_n"], p["law_k_in"],
                              p["law_n_in"], p["law_k_out"], p["law_n_out"], pk.stages[i])
                   for x in s])
    te = model.transmission_error * math.sin(2.0 * math.pi * roll / geo.base_pitch)

    def force(x: float) -> float:
        h = np.maximum(x - half - g - te, 0.0)
        return float(np.sum(kn[:, 0] * h ** kn[:, 1])) - target

    upper = half + te + 1e-6
    while force(upper) < 0.0:
        upper += 1e-5
    lo, hi = half + te - 1e-9, upper
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if force(mid) < 0.0 else (lo, mid)
    return 0.5 * (lo + hi)


def _start_segment(model: DriveModel, pk: _Packed, seg: Segment, t: float, y: np.ndarray,
                   first: bool) -> None:
    """Set the engaged ring, offsets and mesh position at the start of a segment."""
    n = model.n_stages
    i = seg.stage - 1
    geo = model.geometry
    psi, psid, _, _, _ = K.reference(t, pk.sch)
    p = pk.p
    old_c = p["ratio"]
    new_c = geo.base_radius / model.base_levers[i]
    if first:
        y[:] = 0.0
        pk.aoff[:] = 0.0
        # the engaged web carries load and drag
        pk.aoff[1 + i] = (seg.load + model.drag_torque) / model.couplings[i]
        p["ratio"] = new_c
    else:
        # re-base rings and output on the new ratio: same angles and speeds
        for j in range(1, n + 2):
            pk.aoff[j] += y[2 * j] + (old_c - new_c) * psi
            y[2 * j] = 0.0
            y[2 * j + 1] += (old_c - new_c) * psid
        p["ratio"] = new_c
    p["engaged"] = i
    p["half_backlash"] = 0.5 * model.backlashes[i]
    p["friction_lever"] = model.pitch_radii[i] * math.sin(geo.pressure_angle)
    p["pending"] = 0 if first else 1
    laws = model.law_set
    law = laws.table(seg.stage).as_rows()[0]
    p["law_k"], p["law_n"], p["law_cmax"], p["law_d"] = law[1:5]
    for side, kind in (("in", "corner-approach"), ("out", "corner-recess")):
        corner = (laws.table(seg.stage, kind).as_rows()[0] if laws.has(seg.stage, kind)
                  else np.full(5, np.nan))
        p[f"law_k_{side}"], p[f"law_n_{side}"] = corner[1:3]
    roll = geo.base_radius * (y[0] + psi + pk.aoff[0])
    if first:   # on the laws just set
        p["x0"] = _static_offset(model, pk, seg.stage, seg.load + model.drag_torque, roll)
    else:
        engage = model.engage_position if seg.engage is None else seg.engage
        p["x0"] = engage * 0.5 * model.backlashes[i]
        p["x0"] -= geo.base_radius * y[0]  # x = x0 at the switch, whatever q_p is


def _grow(ev: np.ndarray, nev: int) -> np.ndarray:
    if nev < ev.shape[0] // 2:
        return ev
    bigger = np.zeros(2 * ev.shape[0], dtype=K.EVENT)
    bigger[:nev] = ev[:nev]
    return bigger


def simulate(
    model: DriveModel,
    schedule: StageSchedule,
    *,
    sample_interval: float = 2e-4,
    chunk: float = 0.05,
    step_hook: Callable[[float, float], None] | None = None,
    initial_rates: Sequence[float] | None = None,
) -> SwitchingRun:
    """Run the torsional model through a schedule.

    Parameters
    ----------
    model : DriveModel
    schedule : StageSchedule
    sample_interval : float
        Time-series sampling [s]; statistics use every integration step.
    chunk : float
        Simulated time per kernel call [s]; ``step_hook(t, t_end)`` is called
        after each (progress bars).
    step_hook : callable, optional
    initial_rates : sequence of float, optional
        Angular-velocity deviations [rad/s] added to the steady start, one
        per degree of freedom (pinion, rings, output); the pinion's must be
        0 for a speed-driven pinion.

    Returns
    -------
    SwitchingRun

    Raises
    ------
    CaseError
        For a schedule the model cannot run.
    SolverError
        If the step size collapses.
    """
    if not sample_interval > 0.0 or not chunk > 0.0:
        raise CaseError(f"sample_interval = {sample_interval!r} and chunk = {chunk!r} s "
                        "must be > 0")
    _check_schedule(model, schedule)
    n = model.n_stages
    if initial_rates is not None:
        rates = np.asarray(initial_rates, dtype=float)
        if rates.shape != (n + 2,) or not np.all(np.isfinite(rates)):
            raise CaseError(f"initial_rates needs {n + 2} finite values (pinion, {n} rings, "
                            f"output), got {initial_rates!r}")
        if model.drive == "speed" and rates[0] != 0.0:
            raise CaseError("initial_rates[0] must be 0: the pinion speed is prescribed")
    wall = time.perf_counter()
    pk = _pack(model, schedule, sample_interval)
    y = np.zeros(2 * (n + 2))
    f = np.zeros_like(y)
    progress = np.zeros(1, dtype=K.PROGRESS)
    run = progress[0]
    run["h"], run["err_prev"] = 1e-7, 1e-4
    ev = np.zeros(4096, dtype=K.EVENT)
    stats = np.zeros((n, K.N_STAT_Q, 4))
    stats[:, :, 1], stats[:, :, 2] = -np.inf, np.inf
    aux_prev = np.zeros(K.N_AUX)
    ncol = len(series_columns(n))
    pieces = []
    t_total = schedule.duration
    starts = schedule.start_times
    for index, seg in enumerate(schedule.segments):
        t0 = float(starts[index])
        if index == 0 or seg.stage != schedule.segments[index - 1].stage:
            _start_segment(model, pk, seg, t0, y, index == 0)
            if index == 0 and initial_rates is not None:
                y[1::2] += rates
            K.prepare(t0, y, f, pk.p, pk.stages, pk.aoff, pk.corners, pk.postab, pk.sch,
                      pk.slots, pk.flanks, aux_prev)
        t_seg_end = t0 + seg.duration
        while run["t"] < t_seg_end - 1e-12 * t_total:
            t_next = min(run["t"] + chunk, t_seg_end)
            samples = np.empty((int((t_next - run["t"]) / sample_interval) + 3, ncol))
            ev = _grow(ev, int(run["n_events"]))
            status = K.integrate(t_next, run, y, f, pk.p, pk.stages, pk.aoff, pk.atol,
                                 pk.corners, pk.postab, pk.sch, pk.tab, pk.ntab, pk.slots,
                                 pk.flanks, ev,
                                 stats, samples, aux_prev)
            pieces.append(samples[: run["n_samples"]].copy())
            if status != 0:
                raise SolverError(f"step size collapsed at t = {run['t']:.6g} s "
                                  f"(stage {seg.stage}): check the laws' units (k in "
                                  "N/m^exponent, cmax in N s/m), or loosen the model's rtol "
                                  "(Python API: DriveModel(rtol=...))")
            if not np.all(np.isfinite(y)):
                raise SolverError(f"the state became NaN/inf at t = {run['t']:.6g} s (stage "
                                  f"{seg.stage}): the contact laws cannot be integrated; "
                                  "check their parameters (k in N/m^exponent, cmax in N s/m)")
            if step_hook is not None:
                step_hook(float(run["t"]), t_total)
    data = np.concatenate(pieces) if pieces else np.zeros((0, ncol))
    series = {name: data[:, j] for j, name in enumerate(series_columns(n))}
    events = ImpactEvents.from_kernel(ev[: run["n_events"]])
    info = _run_info(model, run, time.perf_counter() - wall, events)
    return SwitchingRun(model, schedule, series, events, stats, info)


def _run_info(model: DriveModel, run: np.void, wall: float, events: ImpactEvents) -> dict:
    info = {
        "integrator": "Dormand-Prince 5(4), adaptive, numba; contact onsets located on "
                      "the step interpolant",
        "steps": int(run["steps"]),
        "rejected_steps": int(run["rejected"]),
        "rhs_evaluations": int(run["rhs"]),
        "wall_s": wall,
        "impacts": len(events),
        "clamped_low": int(run["clamp_low"]),
        "clamped_high": int(run["clamp_high"]),
        "dropped_events": int(run["dropped"]),
        "window_violations": int(run["guard"]),
        "law_source": model.law_set.source,
    }
    if info["clamped_low"] or info["clamped_high"]:
        logger.warning(
            "%d impacts below and %d above the law tables' speed range: parameters clamped "
            "(%s)", info["clamped_low"], info["clamped_high"], model.law_set.source,
        )
    if info["window_violations"]:
        logger.warning("%d tooth pairs entered or left the search window in contact: "
                       "approaches beyond the tabulated corner gap", info["window_violations"])
    if info["dropped_events"]:
        logger.warning("%d impacts not recorded (event buffer full)", info["dropped_events"])
    return info


def mechanical_energy(run: SwitchingRun) -> np.ndarray:
    """Kinetic + coupling + contact energy at the samples [J] (energy checks).

    Uses absolute speeds and twists from the series; contact energy is the
    per-mesh series times the number of pinions.
    """
    model, s = run.model, run.series
    n = model.n_stages
    kinetic = 0.5 * model.pinions * model.pinion_j * s["pinion_speed_rad_s"] ** 2
    kinetic = kinetic + 0.5 * model.output_j * s["output_speed_rad_s"] ** 2
    elastic = model.pinions * s["potential_energy_J"]
    for i in range(n):
        kinetic = kinetic + 0.5 * model.ring_inertias[i] * s[f"ring{i + 1}_speed_rad_s"] ** 2
        elastic = elastic + 0.5 * model.couplings[i] * s[f"ring{i + 1}_twist_rad"] ** 2
    return kinetic + elastic


def _set_friction(p, friction: Friction | None) -> None:
    """Write ``friction``'s coefficients and speeds into a `_kernel.PARAMS` record."""
    if friction is not None:
        p["mu_static"], p["mu_dynamic"], p["friction"] = (friction.static, friction.dynamic,
                                                          1)
        p["stiction_speed"] = friction.stiction_speed
        p["transition_speed"] = friction.transition_speed
    else:
        p["stiction_speed"], p["transition_speed"] = 1.0, 2.0


def friction_coefficient(friction: Friction, speed: float) -> float:
    """The signed coefficient ``mu(|v|) sgn(v)`` [-] of the lumped model's flank friction
    (seed eqs. 9-10, the sign smoothed below the stiction speed) at the sliding speed
    ``speed`` [m/s]: the kernel's own law, for models that share it (the rolling FE)."""
    return float(K.friction_coefficient(float(speed), _friction_params(friction)))


@functools.lru_cache(maxsize=8)
def _friction_params(friction: Friction):
    """A `_kernel.PARAMS` record holding ``friction`` alone (kept: the rolling FE asks
    for the coefficient at every contact row of every step)."""
    params = np.zeros(1, dtype=K.PARAMS)
    _set_friction(params[0], friction)
    return params[0]
