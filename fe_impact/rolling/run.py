"""The time loop of the rolling mesh and its record.

:func:`integrate` steps a :class:`~fe_impact.rolling.model.Roller` and returns a
:class:`RollResult`: the transmission error on the line of action, each pair's
force, place and contact point, the contact events and the energy balance.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import asdict, dataclass, field

import numpy as np

from fe_impact.rolling.model import BETA, GAMMA, Roller, solve_contact

logger = logging.getLogger(__name__)

__all__ = ["ContactEvent", "RollResult", "integrate"]

#: Pairs whose free gap is below this take part in the step's contact problem [m].
CANDIDATE_GAP = 20e-6
#: A touch becomes a contact event once its Hertz approach passes this [m]: the force
#: ``k_H (1 nm)^1.5`` (1.6-2.3 mN on the seed set) is far above round-off touches (1e-13 N,
#: approaches of 1e-16 m) and far below the slowest rattle (1 mm/s between ~1 kg
#: of reduced mass: Hertz peak ~1 N).
EVENT_APPROACH = 1e-9


@dataclass(frozen=True)
class ContactEvent:
    """One contact of one tooth pair, from first touch to separation.

    ``kind`` as the torsional model counts them: ``rattle``, a touch while no pair
    of that flank was in contact the step before (the end of a free flight
    across the backlash), else ``mesh-in`` (a pair taking up load beside a loaded
    one); ``flank_loaded`` says which. The contact's end (``end_time_s``,
    ``end_s_m``) is its mesh-out. ``where``: ``approach-edge`` (before the path:
    the face gear's tip edge), ``recess-edge`` (after it: the pinion's), or
    ``flank``. ``closing_speed_m_s``: the rate the free gap closed at over the
    step before the touch.

    A touch counts once its force passes the Hertz force of an approach of
    :data:`EVENT_APPROACH` (round-off touches do not); its time, place and
    closing speed are those of its first touch. The contact the run starts in
    (the drive flank touching at zero force) is the start, not an event: it is
    not listed, but its flank counts as loaded until it opens.
    """

    time_s: float
    flank: str
    tooth: int
    kind: str
    closing_speed_m_s: float
    peak_force_n: float
    where: str
    s_m: float
    flank_loaded: bool
    end_time_s: float
    end_s_m: float


@dataclass(frozen=True)
class RollResult:
    """Time series of a rolling run (SI units; ``te_m`` is the torsional model's ``x``).

    Attributes
    ----------
    time_s, te_m, pinion_speed_rad_s, face_speed_rad_s : ndarray (n,)
    teeth : tuple of int
        Tooth numbers of the pairs (axis 1 of the pair arrays).
    pair_force_n, pair_s_m : ndarray (n, n_teeth, 2)
        Normal force and place on the line of action, ``[..., 0]`` drive, ``[..., 1]``
        coast (NaN: out of reach).
    contact_point_m : ndarray (n, n_teeth, 2, 3)
        The pinion's contact point in the mesh frame (NaN: no force).
    energy : dict of ndarray (n,)
        ``kinetic``, ``strain``, ``hertz`` (the local law's: the Hertz or the layers'
        energy), ``drive_work``, ``load_work``,
        ``centrifugal_work`` (of the centrifugal load on the sectors),
        ``friction_dissipation`` (minus the work of the flanks' friction on both
        gears, cumulative), ``friction_power`` (``sum mu F_n |v_s|`` over the pairs at
        each step [W]: the rate the dissipation should have), ``error``.
    events : list of ContactEvent
    info : dict
        Inputs, sizes and costs.
    pair_slip_m_s : ndarray (n, n_teeth, 2) or None
        With friction: each pair's sliding speed (the pinion's on the face gear,
        positive towards the pinion's tip; NaN: out of reach); None without.
    """

    time_s: np.ndarray
    te_m: np.ndarray
    pinion_speed_rad_s: np.ndarray
    face_speed_rad_s: np.ndarray
    teeth: tuple
    pair_force_n: np.ndarray
    pair_s_m: np.ndarray
    contact_point_m: np.ndarray
    energy: dict
    events: list = field(default_factory=list)
    info: dict = field(default_factory=dict)
    pair_slip_m_s: np.ndarray | None = None

    def energy_balance(self) -> dict:
        """The energy balance's largest error in J, and against the kinetic energy and
        the works.

        ``error_j``: largest ``|E - E_0 - W|``; ``kinetic_j``: largest kinetic
        energy; ``work_j``: the scale of :meth:`energy_error`;
        ``relative_to_kinetic``; ``relative_to_work`` (None when no work is done
        beyond round-off, ``work_j <= 1e-9 kinetic_j``: a run at no load).
        """
        e = self.energy
        error = float(np.nanmax(np.abs(e["error"]), initial=0.0))
        kinetic = float(np.nanmax(e["kinetic"], initial=0.0))
        work = self._work_scale()
        return {"error_j": error, "kinetic_j": kinetic, "work_j": work,
                "relative_to_kinetic": error / kinetic if kinetic > 0.0 else None,
                "relative_to_work": error / work if work > 1e-9 * kinetic and work > 0.0
                else None}

    def energy_error(self) -> float:
        """Largest ``|E - E_0 - W_drive - W_load|`` over the run, divided by the largest of
        the drive's work, the load's work and the kinetic energy's change [-]."""
        scale = max(self._work_scale(), 1e-300)
        return float(np.nanmax(np.abs(self.energy["error"]), initial=0.0) / scale)

    def _work_scale(self) -> float:
        """The largest of the drive's work, the load's work and the kinetic energy's
        change over the run [J]."""
        e = self.energy
        kinetic = e["kinetic"][~np.isnan(e["kinetic"])]
        return max(float(np.abs(e["drive_work"]).max(initial=0.0)),
                   float(np.abs(e["load_work"]).max(initial=0.0)),
                   float(np.ptp(kinetic)) if len(kinetic) else 0.0)

    def to_dict(self) -> dict:
        return {"time_s": self.time_s.tolist(), "te_m": self.te_m.tolist(),
                "pinion_speed_rad_s": self.pinion_speed_rad_s.tolist(),
                "face_speed_rad_s": self.face_speed_rad_s.tolist(), "teeth": list(self.teeth),
                "pair_force_n": np.nan_to_num(self.pair_force_n).tolist(),
                "pair_s_m": np.where(np.isnan(self.pair_s_m), None, self.pair_s_m).tolist(),
                "energy": {k: np.where(np.isnan(v), None, v).tolist()
                           for k, v in self.energy.items()},
                "events": [asdict(e) for e in self.events], "info": self.info}


class _State:
    def __init__(self, n: int) -> None:
        self.q, self.v, self.a = np.zeros(n), np.zeros(n), np.zeros(n)


def _body_solve(body, rhs: np.ndarray) -> np.ndarray:
    """``S^-1 rhs`` of ``body``'s Newmark matrix, ``rhs`` (n, k)."""
    out = body.solver(rhs)
    return out.reshape(rhs.shape)


def integrate(roller: Roller, progress=None, stop=None, energy_every: int = 10,
              frame=None, friction=None) -> RollResult:
    """Integrate ``roller`` over its steps.

    ``friction``: the flanks' Coulomb law (:func:`fe_impact.rolling.friction.friction_of`;
    None: frictionless), applied at each pair as :mod:`fe_impact.rolling.friction`
    says: its coefficient and direction from the step's end kinematics, its size the
    step's normal force (part of each pair's unit-force column).

    The energies are evaluated every ``energy_every`` steps (and at the last;
    NaN between: two sparse products each), the works at every step.

    ``frame(step, t, q_pinion, q_face)`` is called each step (the output's frames);
    ``progress(step, n_steps)`` is called each step; ``stop()`` returning True ends
    the run early (what is done is returned, ``info["complete"]`` False).
    """
    started, cpu0 = time.perf_counter(), time.process_time()
    r, p, f = roller, roller.p, roller.f
    dt, n_steps = r.dt, r.n_steps
    teeth = tuple(r.teeth)
    col = {k: i for i, k in enumerate(teeth)}
    Mp, Kp, Mf, Kf = p.M.tocsr(), p.K.tocsr(), f.M.tocsr(), f.K.tocsr()
    npu = p.n - 1
    mp_col = Mp[:-1, -1].toarray().ravel()
    sp_, sf = _State(p.n), _State(f.n)
    th, w, al = r.pinion_motion(0.0)
    sp_.q[-1], sp_.v[-1], sp_.a[-1] = th, w, al
    sf.q[-1], sf.v[-1] = r.ratio * th, r.ratio * w
    c = r.geo.backlash
    te = np.zeros(n_steps + 1)
    wp_, wf_ = np.zeros(n_steps + 1), np.zeros(n_steps + 1)
    force = np.zeros((n_steps + 1, len(teeth), 2))
    place = np.full((n_steps + 1, len(teeth), 2), np.nan)
    point = np.full((n_steps + 1, len(teeth), 2, 3), np.nan)
    en = {k: np.zeros(n_steps + 1) for k in ("kinetic", "strain", "hertz", "drive_work",
                                              "load_work", "centrifugal_work",
                                              "friction_dissipation", "friction_power",
                                              "error")}
    slip = np.full((n_steps + 1, len(teeth), 2), np.nan) if friction is not None else None
    g_fric = (np.zeros(p.n), np.zeros(f.n))     # friction's generalised forces, step before
    w_friction = 0.0

    def x_of(qp, qf):
        return r.r_bp * qp[-1] - r.r_b2 * qf[-1] + 0.5 * c

    def kinetic():
        return 0.5 * (sp_.v @ (Mp @ sp_.v) + sf.v @ (Mf @ sf.v))

    def strain():
        return 0.5 * (sp_.q @ (Kp @ sp_.q) + sf.q @ (Kf @ sf.q))

    te[0], wp_[0], wf_[0] = x_of(sp_.q, sf.q) - 0.5 * c, w, sf.v[-1]
    en["kinetic"][0] = kinetic()
    e0 = en["kinetic"][0]
    torque_drive, torque_load = 0.0, -r.load(0.0)
    w_drive = w_load = w_centrifugal = 0.0
    th0, thf0 = th, sf.q[-1]
    cf_p = p.centrifugal if p.centrifugal is not None else np.zeros(p.n)
    cf_f = f.centrifugal if f.centrifugal is not None else np.zeros(f.n)
    cf_p, cf_f = cf_p.copy(), cf_f.copy()
    cf_p[-1] = cf_f[-1] = 0.0
    fc_p0, fc_f0 = w * w * cf_p, sf.v[-1] ** 2 * cf_f
    qp0, qf0 = sp_.q.copy(), sf.q.copy()
    open_events: dict = {}
    events: list[ContactEvent] = []
    prev_gap: dict = {}
    pending: dict = {}
    x0 = x_of(sp_.q, sf.q)
    for row in r._rows(th, sf.q[-1]):         # the pairs the run starts touching
        gap0 = row["g"] - row["sign"] * x0
        prev_gap[(row["tooth"], row["flank"])] = gap0
        if gap0 <= EVENT_APPROACH:
            open_events[(row["tooth"], row["flank"])] = {"start": True}
    done = n_steps
    for n in range(1, n_steps + 1):
        t1 = n * dt
        th1, w1, al1 = r.pinion_motion(t1)
        load1 = -r.load(t1)
        # predictors
        qt_p = sp_.q + dt * sp_.v + (0.5 - BETA) * dt * dt * sp_.a
        vt_p = sp_.v + (1 - GAMMA) * dt * sp_.a
        qt_f = sf.q + dt * sf.v + (0.5 - BETA) * dt * dt * sf.a
        vt_f = sf.v + (1 - GAMMA) * dt * sf.a
        rows = r._rows(th1, qt_f[-1])
        m = len(rows)
        if friction is not None:
            from fe_impact.rolling.friction import slide
            slide(r, rows, friction, th1, w1, qt_f[-1], vt_f[-1])
        # one solve per gear for the free motion and every pair's unit force
        # A: where a pair's force enters the sectors; R: where its gap reads them
        A_p, A_f = np.zeros((m, p.n)), np.zeros((m, f.n))
        R_p, R_f = np.zeros((m, p.n)), np.zeros((m, f.n))
        for i, row in enumerate(rows):
            for key, A, R in (("p", A_p, R_p), ("f", A_f, R_f)):
                if row[key] is not None:
                    np.add.at(A[i], row[key][0], row[key][1])
                    np.add.at(R[i], row[key + "_read"][0], row[key + "_read"][1])
            A_f[i, -1] += row["dtheta_f"]
            R_f[i, -1] += row["dtheta_f"]
            if friction is not None:        # the friction rides on the normal force
                for key, A in (("p", A_p), ("f", A_f)):
                    if row[key + "_t"] is not None:
                        np.add.at(A[i], row[key + "_t"][0], row[key + "_t"][1])
                A_f[i, -1] += row["dtheta_f_t"]
        a_p = np.zeros(p.n)
        a_p[-1] = al1
        yp = np.zeros((m, p.n))
        fc_p1 = w1 * w1 * cf_p
        fc_f1 = sf.v[-1] ** 2 * cf_f       # the face gear's speed of the step before
        if npu:
            rhs = -(Kp @ np.append(qt_p[:-1], 0.0))[:-1] - mp_col * al1 + fc_p1[:-1]
            sol = _body_solve(p, np.column_stack([rhs, A_p[:, :-1].T]))
            a_p[:-1] = sol[:, 0]
            yp[:, :-1] = sol[:, 1:].T
        rhs_f = -(Kf @ qt_f) + fc_f1
        rhs_f[-1] += load1
        sol = _body_solve(f, np.column_stack([rhs_f, A_f.T]))
        a_f, yf = sol[:, 0], sol[:, 1:].T
        q_p = qt_p + BETA * dt * dt * a_p
        q_p[-1] = th1
        q_f = qt_f + BETA * dt * dt * a_f
        x1 = x_of(q_p, q_f)
        gfree = np.array([row["g"] - row["sign"] * x1 for row in rows]) + R_p[:, :-1] @ q_p[
            :-1] + R_f[:, :-1] @ q_f[:-1]
        for row, g in zip(rows, gfree, strict=True):
            row["gfree"] = g
        on = np.flatnonzero(gfree < CANDIDATE_GAP)
        cand = [rows[i] for i in on]
        lam = np.zeros(0)
        if cand:
            yp, yf = yp[on], yf[on]
            D = BETA * dt * dt * (R_p[on] @ yp.T + R_f[on] @ yf.T)
            if r.depth <= 0.0 and friction is None:  # read where loaded: symmetric
                D = 0.5 * (D + D.T)
            law = r.law(cand)
            lam = solve_contact(gfree[on], D, law)
            a_p = a_p + lam @ yp
            a_f = a_f + lam @ yf
            a_p[-1] = al1
        sp_.q = qt_p + BETA * dt * dt * a_p
        sp_.q[-1] = th1
        sp_.v = vt_p + GAMMA * dt * a_p
        sp_.v[-1] = w1
        sp_.a = a_p
        sf.q = qt_f + BETA * dt * dt * a_f
        sf.v = vt_f + GAMMA * dt * a_f
        sf.a = a_f
        # the drive torque: the pinion rotor's equation solved for it
        contact_torque = sum(li * (row["dtheta_p"] + row.get("dtheta_p_t", 0.0))
                             for li, row in zip(lam, cand, strict=True))
        if friction is not None:    # its work: trapezoidal, as Newmark's energy balance
            g_new = (np.zeros(p.n), np.zeros(f.n))
            power = 0.0
            for li, row in zip(lam, cand, strict=True):
                for g, key in zip(g_new, ("p", "f"), strict=True):
                    if row[key + "_t"] is not None:
                        np.add.at(g, row[key + "_t"][0], li * row[key + "_t"][1])
                g_new[0][-1] += li * row["dtheta_p_t"]
                g_new[1][-1] += li * row["dtheta_f_t"]
                power += li * abs(row["mu"]) * abs(row["slip_speed"])
            w_friction += 0.5 * ((g_fric[0] + g_new[0]) @ (sp_.q - qp0)
                                 + (g_fric[1] + g_new[1]) @ (sf.q - qf0))
            g_fric = g_new
            en["friction_dissipation"][n], en["friction_power"][n] = -w_friction, power
            for row in rows:
                slip[n, col[row["tooth"]], row["flank"]] = row["slip_speed"]
        t_drive1 = float((Mp[-1] @ a_p)[0]) - contact_torque
        w_drive += 0.5 * (torque_drive + t_drive1) * (th1 - th0)
        w_load += 0.5 * (torque_load + load1) * (sf.q[-1] - thf0)
        w_centrifugal += 0.5 * ((fc_p0 + fc_p1) @ (sp_.q - qp0) + (fc_f0 + fc_f1) @ (sf.q - qf0))
        fc_p0, fc_f0, qp0, qf0 = fc_p1, fc_f1, sp_.q.copy(), sf.q.copy()
        torque_drive, torque_load, th0, thf0 = t_drive1, load1, th1, sf.q[-1]
        # record
        hertz_pe = float(law.energy(lam).sum()) if cand else 0.0
        for li, row in zip(lam, cand, strict=True):
            j, fl = col[row["tooth"]], row["flank"]
            force[n, j, fl] = li
            if li > 0.0:
                point[n, j, fl] = r.world(row["xp"], th1, "pinion")
        for row in rows:
            place[n, col[row["tooth"]], row["flank"]] = row["s"]
        _events(r, n * dt, rows, lam, cand, open_events, pending, events, prev_gap, dt)
        te[n] = x_of(sp_.q, sf.q) - 0.5 * c
        wp_[n], wf_[n] = w1, sf.v[-1]
        en["hertz"][n] = hertz_pe
        en["drive_work"][n], en["load_work"][n] = w_drive, w_load
        en["centrifugal_work"][n] = w_centrifugal
        if n % energy_every == 0 or n == n_steps or (stop is not None and stop()):
            en["kinetic"][n] = kinetic()
            en["strain"][n] = strain()
            en["error"][n] = (en["kinetic"][n] + en["strain"][n] + hertz_pe - e0 - w_drive
                              - w_load - w_centrifugal - w_friction)
        else:
            en["kinetic"][n] = en["strain"][n] = en["error"][n] = np.nan
        if frame is not None:
            frame(n, t1, sp_.q, sf.q)
        if progress is not None:
            progress(n, n_steps)
        if stop is not None and stop():
            done = n
            break
    for ev in open_events.values():     # contacts still open at the end
        if not ev.get("start"):
            events.append(ContactEvent(**ev, end_time_s=math.nan, end_s_m=math.nan))
    k = done + 1
    info = {"n_steps": done, "complete": done == n_steps, "dt_s": dt,
            "dofs": {"pinion": p.n, "face_gear": f.n},
            "wall_s": time.perf_counter() - started, "cpu_s": time.process_time() - cpu0,
            "cycles_done": done / max(r.set.steps_per_cycle, 1),
            "friction": None if friction is None else {
                "mu_static": friction.static, "mu_dynamic": friction.dynamic,
                "stiction_speed_m_s": friction.stiction_speed,
                "transition_speed_m_s": friction.transition_speed}}
    return RollResult(np.arange(k) * dt, te[:k], wp_[:k], wf_[:k], teeth, force[:k],
                      place[:k], point[:k], {key: v[:k] for key, v in en.items()},
                      sorted(events, key=lambda e: e.time_s), info,
                      None if slip is None else slip[:k])


def _events(r: Roller, t: float, rows, lam, cand, open_events, pending, events, prev_gap,
            dt) -> None:
    """Open, grow and close :class:`ContactEvent` records.

    A first touch waits in ``pending`` until its force passes the Hertz force of
    :data:`EVENT_APPROACH`; it is dropped if the pair opens before. A contact
    closes when its force is zero. ``open_events`` entries marked ``start`` are
    the run's starting contact: they count for ``flank_loaded`` but are not listed.
    """
    lam_of = {(row["tooth"], row["flank"]): li for li, row in zip(lam, cand, strict=True)}
    geo = r.geo.mesh
    loaded = {fl for (_, fl) in open_events}     # flanks in contact the step before
    for row in rows:
        key = (row["tooth"], row["flank"])
        li = lam_of.get(key, 0.0)
        if li > 0.0 and key not in open_events:
            if key not in pending:
                g_prev = prev_gap.get(key)
                speed = (g_prev - row["gfree"]) / dt if g_prev is not None else math.nan
                s = row["s"]
                where = ("approach-edge" if s < geo.s_start else "recess-edge"
                         if s > geo.s_end else "flank")
                flank_loaded = row["flank"] in loaded
                pending[key] = dict(time_s=t, flank="drive" if row["flank"] == 0 else "coast",
                                    tooth=row["tooth"], kind="mesh-in" if flank_loaded
                                    else "rattle", closing_speed_m_s=speed, peak_force_n=li,
                                    where=where, s_m=s, flank_loaded=flank_loaded)
            ev = pending[key]
            ev["peak_force_n"] = max(ev["peak_force_n"], li)
            if li > row["kh"] * EVENT_APPROACH ** 1.5:
                open_events[key] = pending.pop(key)
        elif li > 0.0:
            ev = open_events[key]
            if not ev.get("start"):
                ev["peak_force_n"] = max(ev["peak_force_n"], li)
        else:
            pending.pop(key, None)
            if key in open_events:
                ev = open_events.pop(key)
                if not ev.get("start"):
                    events.append(ContactEvent(**ev, end_time_s=t, end_s_m=row["s"]))
        prev_gap[key] = row["gfree"]
