"""Compiled core of the torsional model: right-hand side, integrator, impact detection.

Private module: `fe_impact.switching.simulation` packs the model into the
records and arrays below and calls `integrate` chunk by chunk. Everything
here is a pure function of its arguments (numba ``njit``, cached on disk).
Scalars travel as NumPy structured records (`PARAMS`, `PROGRESS`) read by
field name; per-ring data, schedule segments, contact slots, tooth pairs and
events are arrays of records (`STAGE`, `SEGMENT`, `SLOT`, `FLANK`, `PAIR`,
`EVENT`). The contact law is `fe_impact.physics.impact_law`.

Degrees of freedom, ``n`` rings: 0 pinion, 1..n rings, n+1 output. The state
holds deviations from a reference rotation, ``theta_j = q_j + c_j psi(t) +
a_j`` with ``psi`` the scheduled pinion angle, ``c = 1`` for the pinion and
``c = N_p / N_engaged`` for rings and output, and ``a_j`` constant offsets:
``y = [q_0, qdot_0, q_1, qdot_1, ...]``. Deviations stay of the order of
the backlash over the lever, so the error control works on what matters.

Integrator: Dormand-Prince 5(4) with FSAL and the PI step-size controller
of Hairer, Norsett & Wanner's DOPRI5 (*Solving ODEs I*, sections II.4-5). The
contact force is C1 at first touch (``k h^1.5`` and the damping ramp of
``STEP`` both start with zero slope), so the steps shrink by error control
alone; contact onsets and separations are then located inside the accepted
step on the cubic Hermite interpolant of each pair's approach.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from fe_impact.physics.impact_law import impact_force_energy, unit_step

# -- records ---------------------------------------------------------------------------------
# Scalar parameters of a run: one record (a structured NumPy scalar passed by reference, so
# the kernel's write to ``pending`` is seen by the caller). Fields are read by name.
PARAMS = np.dtype([
    ("base_radius", np.float64),  # pinion base radius r_bp [m]
    ("base_pitch", np.float64),  # base pitch p_b [m]
    ("s_start", np.float64),  # start of the active path [m]
    ("s_end", np.float64),  # end of the active path [m]
    ("s_pitch", np.float64),  # pitch point on the path [m]
    ("pinions", np.float64),  # pinions (identical meshes in phase)
    ("te_amplitude", np.float64),  # transmission-error amplitude [m]
    ("mu_static", np.float64),  # static friction coefficient
    ("mu_dynamic", np.float64),  # dynamic friction coefficient
    ("stiction_speed", np.float64),  # [m/s]
    ("transition_speed", np.float64),  # friction transition speed [m/s]
    ("friction", np.int64),  # 1 with friction
    ("drive", np.int64),  # 0 speed-driven pinion, 1 torque-driven
    ("x0", np.float64),  # mesh-coordinate offset of the engaged ring [m]
    ("engaged", np.int64),  # engaged ring, 0-based
    ("u0", np.float64),  # roll offset of the tooth-pair numbering [m]
    ("ratio", np.float64),  # c of rings and output
    ("rtol", np.float64),
    ("max_step", np.float64),  # largest step [s]
    ("half_backlash", np.float64),  # of the engaged mesh [m]
    ("friction_lever", np.float64),  # face-gear lever r_2 sin(alpha0) of the engaged ring [m]
    ("pending", np.int64),  # 1 until the first contact after a switch
    ("pinion_inertia", np.float64),  # all pinions [kg m^2]
    ("output_inertia", np.float64),  # [kg m^2]
    ("sample_dt", np.float64),  # sampling interval [s]
    ("drag", np.float64),  # drag torque on the output [N m]
    # IMPACT law of a tooth pair before its first onset: k, exponent, cmax, d, and the
    # stiffness and exponent on the approach and recess tip edges (NaN: the flank's)
    ("law_k", np.float64), ("law_n", np.float64), ("law_cmax", np.float64), ("law_d", np.float64),
    ("law_k_in", np.float64), ("law_n_in", np.float64), ("law_k_out", np.float64),
    ("law_n_out", np.float64),
], align=True)

#: Per ring (stage): inertia [kg m^2], web stiffness [N m/rad] and damping [N m s/rad],
#: base lever r_b [m], roll spans of its approach and recess corner tables [m], and the
#: roll distances beyond the path's start and end at which its tip edges' corner laws
#: stand (their first touch; `pair_law` passes to them from the flank's law there).
STAGE = np.dtype([("inertia", np.float64), ("coupling", np.float64), ("damping", np.float64),
                  ("lever", np.float64), ("corner_in", np.float64),
                  ("corner_out", np.float64), ("law_in", np.float64),
                  ("law_out", np.float64)], align=True)

#: Piece of a schedule, for `reference`: a schedule segment, or a part of one between two
#: points of its load time series. Within a segment the pinion speed is linear in time
#: and, within a piece, the load; at a segment's start both blend from the previous
#: segment's end values over ``blend`` with the ADAMS STEP cubic.
SEGMENT = np.dtype([
    ("t_start", np.float64),  # start of the piece [s]
    ("seg_start", np.float64),  # start of its segment [s]
    ("speed", np.float64),  # pinion speed at the segment's start, before blending [rad/s]
    ("speed_rate", np.float64),  # its slope over the segment [rad/s^2]
    ("prev_speed", np.float64),  # the previous segment's speed at its end [rad/s]
    ("load", np.float64),  # load torque at the piece's start, before blending [N m]
    ("load_rate", np.float64),  # its slope over the piece [N m/s]
    ("prev_load", np.float64),  # the previous segment's load at its end [N m]
    ("input_torque", np.float64),  # [N m]
    ("prev_input_torque", np.float64),  # [N m]
    ("psi_start", np.float64),  # scheduled pinion angle at the segment's start [rad]
    ("blend", np.float64),  # blend time at the segment's start [s]
    ("follows", np.int64),  # 1 if a segment precedes (its values blend in)
], align=True)

#: Contact slot of a tooth pair, SLOTS[flank, pair mod NSLOT]: the pair number, whether it
#: is in contact, its open event (-1: none), whether it has its own law (else the
#: default), the law taken at its onset (k and exponent: the flank's; cmax and d: the
#: onset kind's), the stiffness and exponent on the approach and recess tip edges (NaN:
#: no corner law, the flank's holds there), and the approach and rate at the end of the
#: last accepted step.
SLOT = np.dtype([("pair", np.int64), ("on", np.int64), ("event", np.int64), ("has_law", np.int64),
                 ("k", np.float64), ("n", np.float64), ("cmax", np.float64), ("d", np.float64),
                 ("k_in", np.float64), ("n_in", np.float64), ("k_out", np.float64),
                 ("n_out", np.float64), ("h", np.float64), ("hd", np.float64)], align=True)
NSLOT = 8  # slots per flank, indexed by pair number mod NSLOT

#: Flank state: any pair in contact, and the flank's open event (-1: none).
FLANK = np.dtype([("on", np.int64), ("event", np.int64)], align=True)

#: Tooth pair evaluated by `rhs`, PAIRS[flank, m]: number, roll, approach, its rate,
#: force and elastic energy.
PAIR = np.dtype([("pair", np.int64), ("s", np.float64), ("h", np.float64), ("hd", np.float64),
                 ("f", np.float64), ("e", np.float64)], align=True)
MAXPAIR = 6  # pairs looked at per flank

#: An impact: onset time, stage (from 1), kind, flank (+1 drive, -1 coast), closing speed,
#: peak approach, force and energy, end time and opening speed (NaN while open), law-table
#: clamp (-1/0/+1), the tooth pair, where it touched (CONTACT_*), the law table its
#: onset took (LAW_*) and the pair's place on the line of action then (s, m).
EVENT = np.dtype([("time", np.float64), ("stage", np.int64), ("kind", np.int64),
                  ("flank", np.int64), ("speed", np.float64), ("approach", np.float64),
                  ("force", np.float64), ("energy", np.float64), ("end", np.float64),
                  ("speed_out", np.float64), ("clamp", np.int64), ("pair", np.int64),
                  ("contact", np.int64), ("law", np.int64), ("s", np.float64)], align=True)
KIND_RATTLE, KIND_MESH_IN, KIND_SWITCH = 0, 1, 2
#: Where a tooth pair touches at an impact's onset: on the flanks (the active path),
#: on the face gear's tip edge before it (approach), on the pinion's after it (recess).
CONTACT_FLANK, CONTACT_APPROACH, CONTACT_RECESS = 0, 1, 2
#: Law tables, TAB[stage, LAW_*] (the order of `fe_impact.calibration.records.KINDS`).
LAW_MESH, LAW_SWITCH, LAW_APPROACH, LAW_RECESS = 0, 1, 2, 3

#: Integrator state and counters of a run: time, step size, next sample time, previous
#: error norm; steps, rejected steps, right-hand sides, clamped law look-ups (below/above
#: the table), dropped events, pairs leaving the window in contact, samples written by the
#: last call, events recorded.
PROGRESS = np.dtype([("t", np.float64), ("h", np.float64), ("t_sample", np.float64),
                     ("err_prev", np.float64), ("steps", np.int64), ("rejected", np.int64),
                     ("rhs", np.int64), ("clamp_low", np.int64), ("clamp_high", np.int64),
                     ("dropped", np.int64), ("guard", np.int64), ("n_samples", np.int64),
                     ("n_events", np.int64)], align=True)

# -- per-evaluation results AUX[...] (consecutive columns of the time series) -------------
A_APPROACH, A_XDOT, A_FORCE, A_ENERGY, A_NCONTACT, A_X = 0, 1, 2, 3, 4, 5
A_FRICTION, A_LOAD, A_INPUT, A_FDRIVE, A_FCOAST = 6, 7, 8, 9, 10
N_AUX = 11

# Series statistics STATS[stage, quantity, (integral, max, min, duration)]
N_STAT_Q = 4

# Dormand-Prince 5(4) tableau (Hairer, Norsett & Wanner, Table II.5.2): nodes, stage
# weights (row s: coefficients of k_0..k_{s-1}; the last row is the 5th-order solution,
# FSAL), and the error weights (5th minus 4th order).
_NODES = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0])
_WEIGHTS = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [1 / 5, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3 / 40, 9 / 40, 0.0, 0.0, 0.0, 0.0],
    [44 / 45, -56 / 15, 32 / 9, 0.0, 0.0, 0.0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0.0, 0.0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0.0],
    [35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84],
])
_ERROR = np.array([71 / 57600, 0.0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525,
                   -1 / 40])
_EXPO, _BETA, _SAFE = 0.2 - 0.04 * 0.75, 0.04, 0.9


@njit(cache=True)
def piece_index(t, sch):
    """Index of the schedule piece holding ``t``: the last starting at or before it (0 before
    the first), by bisection."""
    lo, hi = 0, sch.shape[0] - 1
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if sch[mid].t_start <= t:
            lo = mid
        else:
            hi = mid - 1
    return lo


@njit(cache=True)
def segment_angle(psi0, tau, w0, rate, wp, blend):
    """Scheduled pinion angle ``tau`` [s] into a segment that starts at ``psi0`` [rad].

    The speed ``w0 + rate tau`` blends in from ``wp`` over ``blend`` with the STEP
    cubic ``S(z) = 3 z^2 - 2 z^3``: the integrals of ``S`` and ``z S`` over the blend
    are ``blend (z^3 - z^4 / 2)`` and ``blend^2 (3 z^4 / 4 - 2 z^5 / 5)``.
    """
    if blend > 0.0 and tau < blend:
        z = tau / blend
        return (psi0 + wp * tau + (w0 - wp) * blend * (z**3 - 0.5 * z**4)
                + rate * blend * blend * (0.75 * z**4 - 0.4 * z**5))
    if blend > 0.0:
        return (psi0 + wp * blend + 0.5 * (w0 - wp) * blend + w0 * (tau - blend)
                + rate * (0.35 * blend * blend + 0.5 * (tau * tau - blend * blend)))
    return psi0 + w0 * tau + 0.5 * rate * tau * tau


@njit(cache=True)
def reference(t, sch):
    """Scheduled pinion angle, speed, acceleration, load and input torque at ``t``.

    ``sch`` holds `SEGMENT` records; speed, load and input torque blend from
    the previous segment's end values over the segment's ``blend`` with the
    ADAMS STEP cubic.
    """
    seg = sch[piece_index(t, sch)]
    tau = t - seg.seg_start
    w1 = seg.speed + seg.speed_rate * tau
    w0 = seg.prev_speed
    ramp = seg.blend
    blend = 1.0
    psi = segment_angle(seg.psi_start, tau, seg.speed, seg.speed_rate, w0, ramp)
    if ramp > 0.0 and tau < ramp:
        z = tau / ramp
        blend = unit_step(z)
        psid = w0 + (w1 - w0) * blend
        psidd = (w1 - w0) * 6.0 * z * (1.0 - z) / ramp + seg.speed_rate * blend
    else:
        psid = w1
        psidd = seg.speed_rate
    base = seg.load + seg.load_rate * (t - seg.t_start)
    if seg.follows:
        load = seg.prev_load + (base - seg.prev_load) * blend
        tin = seg.prev_input_torque + (seg.input_torque - seg.prev_input_torque) * blend
    else:
        load = base
        tin = seg.input_torque
    return psi, psid, psidd, load, tin


@njit(cache=True)
def corner(delta, table, delta_max):
    """Tabulated corner gap and its slope (see `geometry.CornerGap`).

    ``table[0]`` holds the nodal values, ``table[1]`` the nodal slopes.
    """
    values = table[0]
    if delta > delta_max:      # beyond the table: out of reach, the end's gap held
        return values[values.shape[0] - 1], 0.0
    if delta <= 0.0:
        return 0.0, 0.0
    n = values.shape[0] - 1
    xi = math.sqrt(delta / delta_max)
    i = min(int(xi * n), n - 1)
    w = xi * n - i
    step = 1.0 / n
    s0, s1 = table[1, i] * step, table[1, i + 1] * step
    v0, v1 = values[i], values[i + 1]
    g = ((2 * w**3 - 3 * w**2 + 1) * v0 + (w**3 - 2 * w**2 + w) * s0
         + (-2 * w**3 + 3 * w**2) * v1 + (w**3 - w**2) * s1)
    dg_dw = ((6 * w**2 - 6 * w) * v0 + (3 * w**2 - 4 * w + 1) * s0
             + (6 * w - 6 * w**2) * v1 + (3 * w**2 - 2 * w) * s1)
    return g, dg_dw * n / (2.0 * delta_max * xi)


@njit(cache=True)
def pair_gap(s, p, corners, stage):
    """Gap ``g(s)`` and ``dg/ds`` of a tooth pair at roll ``s`` on ring ``stage``.

    ``corners[0]`` is the ring's approach (before ``s_start``) and ``corners[1]``
    its recess (after ``s_end``) corner table, spanning ``stage.corner_in`` and
    ``stage.corner_out``.
    """
    if s < p.s_start:
        g, dg = corner(p.s_start - s, corners[0], stage.corner_in)
        return g, -dg
    if s > p.s_end:
        return corner(s - p.s_end, corners[1], stage.corner_out)
    return 0.0, 0.0


@njit(cache=True)
def friction_coefficient(v, p):
    """Signed Coulomb coefficient ``mu(|v|) sgn(v)``, smoothed (seed eqs. 9-10).

    ``sgn`` is the ADAMS STEP from -1 at ``-v_s`` to +1 at ``+v_s``
    (stiction, ``mu_s``); above ``v_s`` the coefficient blends to ``mu_d`` at
    ``v_t``.
    """
    av = abs(v)
    vs = p.stiction_speed
    if av < vs:
        return p.mu_static * (2.0 * unit_step((v + vs) / (2.0 * vs)) - 1.0)
    mu = p.mu_static + (p.mu_dynamic - p.mu_static) * unit_step(
        (av - vs) / (p.transition_speed - vs))
    return mu if v > 0.0 else -mu


#: The law tables' signature: the callers pass the table kinds as the module's
#: constants, which numba would otherwise type as literals and compile a version of
#: the function for each (four of ``law_lookup``, 2.6 s of compiling in a fresh cache).
_TABLE_ARGS = "float64[:, :, :, ::1], int64[:, ::1], int64, int64, float64"


@njit(f"Tuple((float64[::1], int64))({_TABLE_ARGS})", cache=True)
def law_lookup(tab, ntab, stage, kind, speed):
    """IMPACT parameters at ``speed``, linear in log(speed); clamp flag -1/0/+1."""
    n = ntab[stage, kind]
    rows = tab[stage, kind]
    x = math.log(max(speed, 1e-300))
    out = np.empty(4)
    if x <= rows[0, 0]:
        out[:] = rows[0, 1:5]
        return out, (-1 if (x < rows[0, 0]) else 0)
    if x >= rows[n - 1, 0]:     # a one-row table above its speed too
        out[:] = rows[n - 1, 1:5]
        return out, (1 if x > rows[n - 1, 0] else 0)
    i = 0
    while rows[i + 1, 0] < x:
        i += 1
    w = (x - rows[i, 0]) / (rows[i + 1, 0] - rows[i, 0])
    out[:] = rows[i, 1:5] + w * (rows[i + 1, 1:5] - rows[i, 1:5])
    return out, 0


#: Largest number of mesh-cycle positions per stage (the kernel's table width).
NPOS = 32


@njit(cache=True)
def position_law(s, tab, k, n):
    """A pair's stiffness and exponent at path coordinate ``s``.

    ``tab``: the engaged stage's position table, rows ``s`` (rising), ``k``,
    exponent, NaN-padded (all NaN: no table, ``(k, n)`` returned). Between
    positions ``log k`` and the exponent are linear in ``s`` (so is the log
    of the force at any approach); beyond the ends they are held.
    """
    if not tab[0, 0] == tab[0, 0]:
        return k, n
    m = 1
    while m < tab.shape[1] and tab[0, m] == tab[0, m]:
        m += 1
    if s <= tab[0, 0]:
        return tab[1, 0], tab[2, 0]
    if s >= tab[0, m - 1]:
        return tab[1, m - 1], tab[2, m - 1]
    i = 0
    while tab[0, i + 1] < s:
        i += 1
    w = (s - tab[0, i]) / (tab[0, i + 1] - tab[0, i])
    return (math.exp((1.0 - w) * math.log(tab[1, i]) + w * math.log(tab[1, i + 1])),
            (1.0 - w) * tab[2, i] + w * tab[2, i + 1])


@njit(cache=True)
def _towards(kf, nf, kc, nc, w):
    """``log k`` and the exponent a share ``w`` of the way from ``(kf, nf)`` to ``(kc, nc)``."""
    return (math.exp((1.0 - w) * math.log(kf) + w * math.log(kc)),
            (1.0 - w) * nf + w * nc)


@njit(cache=True)
def pair_law(s, p, postab, k, n, k_in, n_in, k_out, n_out, stage):
    """Stiffness and exponent of a pair at ``s``: on the path the flank's (the position
    law's, or ``(k, n)`` without one); beyond its start or end, where the tip edge has a
    corner law (not NaN), passing from the flank's at the path's end to the corner law's
    at its first touch (``stage.law_in`` / ``law_out`` beyond the end), ``log k`` and
    the exponent linear in ``s`` as between mesh-cycle positions, and the corner law's
    from there on. The contact passes from the flank onto the rounding continuously, so
    does the pair's stiffness (a step there kicks the mesh's vibration at every
    mesh-out)."""
    if s < p.s_start and k_in == k_in:
        span = stage.law_in
        if not span > 0.0 or p.s_start - s >= span:
            return k_in, n_in
        kf, nf = position_law(p.s_start, postab, k, n)
        return _towards(kf, nf, k_in, n_in, (p.s_start - s) / span)
    if s > p.s_end and k_out == k_out:
        span = stage.law_out
        if not span > 0.0 or s - p.s_end >= span:
            return k_out, n_out
        kf, nf = position_law(p.s_end, postab, k, n)
        return _towards(kf, nf, k_out, n_out, (s - p.s_end) / span)
    return position_law(s, postab, k, n)


@njit(cache=True)
def flank_roll(fl, u, p):
    """Roll of the tooth-pair numbering on flank ``fl`` (0 drive, 1 coast) when the
    pinion has rolled ``u`` [m]: pair ``k`` stands at ``s_start + roll - k p_b``.

    A tooth's two flanks are symmetric about its centre line, so its pairs on the
    two lines of action stand at ``s_d + s_c = 2 s_pitch + p_b / 2`` (mod ``p_b``);
    the coast pairs move back along their line as the pinion rolls on.
    """
    if fl == 0:
        return u + p.u0
    return 2.0 * (p.s_pitch - p.s_start) + 0.5 * p.base_pitch - (u + p.u0)


@njit(cache=True)
def slot_of(k):
    return k - NSLOT * (k // NSLOT)


@njit(cache=True)
def rhs(t, y, dy, p, stages, aoff, corners, postab, sch, slots, pairs, npairs, aux):
    """Time derivative of the state; fills the tooth-pair records ``pairs`` and ``aux``.

    Forces are per mesh; the ``pinions`` identical meshes act together on
    the rings and the pinions.
    """
    n = stages.shape[0]
    psi, psid, psidd, load, tin = reference(t, sch)
    c = p.ratio
    eng = p.engaged
    rbp, rbe, pb = p.base_radius, stages[eng].lever, p.base_pitch
    wp = y[1] + psid
    we = y[3 + 2 * eng] + c * psid
    x = rbp * y[0] - rbe * y[2 + 2 * eng] + p.x0
    xd = rbp * wp - rbe * we
    u = rbp * (y[0] + psi + aoff[0])
    phase = 2.0 * math.pi / pb
    e = p.te_amplitude * math.sin(phase * u)
    de = p.te_amplitude * phase * math.cos(phase * u)
    length = p.s_end - p.s_start
    q_pinion = 0.0
    q_ring = 0.0
    friction = 0.0
    force_drive, force_coast = 0.0, 0.0
    energy = 0.0
    approach_drive, approach_coast = 0.0, 0.0
    ncontact = 0
    for fl in range(2):
        sg = 1.0 if fl == 0 else -1.0
        roll = flank_roll(fl, u, p)
        srate = sg * rbp * wp
        lo = math.ceil((roll - length - stages[eng].corner_out) / pb)
        hi = math.floor((roll + stages[eng].corner_in) / pb)
        m = 0
        for k in range(lo, hi + 1):
            s = p.s_start + roll - k * pb
            g, dg = pair_gap(s, p, corners[eng], stages[eng])
            h = sg * x - p.half_backlash - g - sg * e
            hd = sg * xd - dg * srate - sg * de * rbp * wp
            slot = slots[fl, slot_of(k)]
            if slot.pair == k and slot.has_law == 1:
                kk, nn = pair_law(s, p, postab[eng], slot.k, slot.n, slot.k_in, slot.n_in,
                                  slot.k_out, slot.n_out, stages[eng])
                f, pe = impact_force_energy(h, hd, kk, nn, slot.cmax, slot.d)
            else:
                kk, nn = pair_law(s, p, postab[eng], p.law_k, p.law_n, p.law_k_in, p.law_n_in,
                                  p.law_k_out, p.law_n_out, stages[eng])
                f, pe = impact_force_energy(h, hd, kk, nn, p.law_cmax, p.law_d)
            if f > 0.0 or h > 0.0:
                if h > 0.0:
                    ncontact += 1
                    if fl == 0:
                        approach_drive = max(approach_drive, h)
                    else:
                        approach_coast = max(approach_coast, h)
                q_pinion -= f * sg * rbp * (1.0 - dg - de)
                q_ring += f * sg * rbe
                if p.friction > 0 and f > 0.0:
                    mu = friction_coefficient(wp * s - we * p.friction_lever, p)
                    q_pinion -= mu * f * s
                    q_ring += mu * f * p.friction_lever
                    friction -= mu * f * s
            if fl == 0:
                force_drive += f
            else:
                force_coast += f
            energy += pe
            if m < MAXPAIR:
                pair = pairs[fl, m]
                pair.pair = k
                pair.s = s
                pair.h = h
                pair.hd = hd
                pair.f = f
                pair.e = pe
                m += 1
        npairs[fl] = m
    npin = p.pinions
    # pinion: prescribed motion, or driven by the input torque
    dy[0] = y[1]
    input_torque = p.pinion_inertia * psidd - npin * q_pinion
    if p.drive > 0:
        dy[1] = (npin * q_pinion + tin) / p.pinion_inertia - psidd
        input_torque = tin
    else:
        dy[1] = 0.0
    out = 2 + 2 * n
    wo = y[out + 1] + c * psid
    t_out = -load - p.drag
    for i in range(n):
        ring = stages[i]
        twist = y[2 + 2 * i] - y[out] + aoff[i + 1] - aoff[n + 1]
        wi = y[3 + 2 * i] + c * psid
        coupling = ring.coupling * twist + ring.damping * (wi - wo)
        torque = -coupling + (npin * q_ring if i == eng else 0.0)
        dy[2 + 2 * i] = y[3 + 2 * i]
        dy[3 + 2 * i] = torque / ring.inertia - c * psidd
        t_out += coupling
    dy[out] = y[out + 1]
    dy[out + 1] = t_out / p.output_inertia - c * psidd
    aux[A_APPROACH] = approach_drive if approach_drive >= approach_coast else -approach_coast
    aux[A_XDOT] = xd
    aux[A_FORCE] = force_drive - force_coast
    aux[A_ENERGY] = energy
    aux[A_NCONTACT] = ncontact
    aux[A_X] = x
    aux[A_FRICTION] = friction
    aux[A_LOAD] = load
    aux[A_INPUT] = input_torque
    aux[A_FDRIVE] = force_drive
    aux[A_FCOAST] = force_coast


@njit(cache=True)
def crossing(t0, t1, h0, hd0, h1, hd1):
    """Time and rate where the cubic Hermite of ``h`` on [t0, t1] changes sign."""
    dt = t1 - t0
    a0, a1 = hd0 * dt, hd1 * dt
    lo, hi = 0.0, 1.0
    up = h1 > h0
    for _ in range(60):
        z = 0.5 * (lo + hi)
        val = ((2 * z**3 - 3 * z**2 + 1) * h0 + (z**3 - 2 * z**2 + z) * a0
               + (-2 * z**3 + 3 * z**2) * h1 + (z**3 - z**2) * a1)
        if (val > 0.0) == up:
            hi = z
        else:
            lo = z
    z = 0.5 * (lo + hi)
    rate = ((6 * z**2 - 6 * z) * h0 + (3 * z**2 - 4 * z + 1) * a0
            + (6 * z - 6 * z**2) * h1 + (3 * z**2 - 2 * z) * a1) / dt
    return t0 + z * dt, rate


@njit(cache=True)
def contact_kind(s, p):
    """Where a pair at roll ``s`` touches: `CONTACT_FLANK`, `_APPROACH` or `_RECESS`."""
    if s < p.s_start:
        return CONTACT_APPROACH
    if s > p.s_end:
        return CONTACT_RECESS
    return CONTACT_FLANK


@njit(f"UniTuple(float64, 2)({_TABLE_ARGS})", cache=True)
def corner_law(tab, ntab, stage, table, speed):
    """Stiffness and exponent of a corner table at ``speed`` (NaN: no table)."""
    if ntab[stage, table] == 0:
        return np.nan, np.nan
    law, _ = law_lookup(tab, ntab, stage, table, speed)
    return law[0], law[1]


@njit(cache=True)
def onset_law(ntab, stage, kind, where):
    """The law table an onset takes (LAW_*): the switch law for the first contact after a
    switch, a corner law for a touch on a tip edge (if the stage has one), else the
    flank's."""
    if kind == KIND_SWITCH:
        return LAW_SWITCH
    if where == CONTACT_APPROACH and ntab[stage, LAW_APPROACH] > 0:
        return LAW_APPROACH
    if where == CONTACT_RECESS and ntab[stage, LAW_RECESS] > 0:
        return LAW_RECESS
    return LAW_MESH


@njit(cache=True)
def new_event(ev, run, t, stage, kind, flank, speed, clamp, pair, contact, law, s):
    i = run.n_events
    if i >= ev.shape[0]:
        run.dropped += 1
        return -1
    run.n_events = i + 1
    event = ev[i]
    event.time = t
    event.stage = stage + 1
    event.kind = kind
    event.flank = 1 if flank == 0 else -1
    event.speed = speed
    event.approach = 0.0
    event.force = 0.0
    event.energy = 0.0
    event.end = np.nan
    event.speed_out = np.nan
    event.clamp = clamp
    event.pair = pair
    event.contact = contact
    event.law = law
    event.s = s
    return i


@njit(cache=True)
def track_contacts(t0, t1, p, tab, ntab, slots, flanks, pairs, npairs, ev, run):
    """Update contact states after an accepted step ``[t0, t1]``; record impacts.

    An impact is a contact onset with a closing speed. A tooth pair that
    touches while no pair of its flank is in contact starts a flank impact
    (rattle, or the switching impact if it is the first contact after a
    switch); a pair that touches while its flank already carries load is a
    mesh-in impact. Each onset selects the law parameters at its closing
    speed. Returns True if any law changed (the derivative must be redone).
    """
    eng = p.engaged
    changed = False
    for fl in range(2):
        was_on = flanks[fl].on == 1
        any_now = False
        flank_event = flanks[fl].event
        created = -1
        sep_t, sep_v = np.nan, np.nan
        h_max, f_sum, e_sum = 0.0, 0.0, 0.0
        for m in range(npairs[fl]):
            pair = pairs[fl, m]
            k = pair.pair
            slot = slots[fl, slot_of(k)]
            h1, hd1 = pair.h, pair.hd
            if slot.pair != k:
                if slot.on == 1 or h1 > 0.0:
                    run.guard += 1  # a pair entered or left the window in contact
                slot.pair = k
                slot.on = 0
                slot.event = -1
                slot.has_law = 0
                slot.h = -1.0
                slot.hd = 0.0
            h0, hd0 = slot.h, slot.hd
            if h1 > 0.0:
                any_now = True
                h_max = max(h_max, h1)
                if slot.on == 0:
                    tc, vc = crossing(t0, t1, h0, hd0, h1, hd1)
                    if was_on:
                        kind = KIND_MESH_IN
                    elif p.pending > 0:
                        kind = KIND_SWITCH
                    else:
                        kind = KIND_RATTLE
                    where = contact_kind(pair.s, p)
                    speed = max(vc, 1e-12)
                    used = onset_law(ntab, eng, kind, where)
                    law, clamp = law_lookup(tab, ntab, eng, used, speed)
                    if clamp < 0:
                        run.clamp_low += 1
                    elif clamp > 0:
                        run.clamp_high += 1
                    slot.cmax, slot.d = law[2], law[3]
                    if used == LAW_APPROACH or used == LAW_RECESS:
                        law, _ = law_lookup(tab, ntab, eng, LAW_MESH, speed)
                    slot.k, slot.n = law[0], law[1]
                    slot.k_in, slot.n_in = corner_law(tab, ntab, eng, LAW_APPROACH, speed)
                    slot.k_out, slot.n_out = corner_law(tab, ntab, eng, LAW_RECESS, speed)
                    slot.has_law = 1
                    slot.on = 1
                    changed = True
                    if kind == KIND_MESH_IN:
                        slot.event = new_event(ev, run, tc, eng, kind, fl, vc, clamp, k,
                                               where, used, pair.s)
                    elif created < 0:
                        created = new_event(ev, run, tc, eng, kind, fl, vc, clamp, k, where,
                                            used, pair.s)
                        flank_event = created
                    elif tc < ev[created].time:  # the earliest touch of the flank defines it
                        ev[created].time = tc
                        ev[created].speed = vc
                        ev[created].clamp = clamp
                        ev[created].pair = k
                        ev[created].contact = where
                        ev[created].law = used
                        ev[created].s = pair.s
            elif slot.on == 1:
                tc, vc = crossing(t0, t1, h0, hd0, h1, hd1)
                slot.on = 0
                j = slot.event
                if j >= 0:
                    ev[j].end = tc
                    ev[j].speed_out = -vc
                    slot.event = -1
                if not (sep_t >= tc):
                    sep_t, sep_v = tc, -vc
            j = slot.event
            if j >= 0:
                ev[j].approach = max(ev[j].approach, h1)
                ev[j].force = max(ev[j].force, pair.f)
                ev[j].energy = max(ev[j].energy, pair.e)
            f_sum += pair.f
            e_sum += pair.e
            slot.h = h1
            slot.hd = hd1
        if flank_event >= 0:
            event = ev[flank_event]
            event.approach = max(event.approach, h_max)
            event.force = max(event.force, f_sum)
            event.energy = max(event.energy, e_sum)
            if not any_now:
                event.end = sep_t
                event.speed_out = sep_v
                flank_event = -1
        if created >= 0 and ev[created].kind == KIND_SWITCH:
            p.pending = 0
        flanks[fl].on = 1 if any_now else 0
        flanks[fl].event = flank_event
    return changed


@njit(cache=True)
def accumulate(stats, stage, dt, a0, a1):
    """Trapezoidal time integral, max and min of the four series quantities."""
    for q in range(N_STAT_Q):
        v0, v1 = a0[q], a1[q]
        stats[stage, q, 0] += 0.5 * (v0 + v1) * dt
        stats[stage, q, 1] = max(stats[stage, q, 1], v1)
        stats[stage, q, 2] = min(stats[stage, q, 2], v1)
    stats[stage, 0, 3] += dt


@njit(cache=True)
def write_sample(row, t, y, p, stages, aoff, sch, aux):
    """One row of the time series (columns: see `model.series_columns`)."""
    n = stages.shape[0]
    psi, psid, psidd, load, tin = reference(t, sch)
    c = p.ratio
    out = 2 + 2 * n
    row[0] = t
    row[1] = p.engaged + 1
    row[2] = y[1] + psid
    for i in range(n):
        row[3 + i] = y[3 + 2 * i] + c * psid
    row[3 + n] = y[out + 1] + c * psid
    for i in range(n):
        row[4 + n + i] = y[2 + 2 * i] - y[out] + aoff[i + 1] - aoff[n + 1]
    base = 4 + 2 * n
    for j in range(N_AUX):
        row[base + j] = aux[j]


@njit(cache=True)
def integrate(t_end, run, y, f, p, stages, aoff, atol, corners, postab, sch, tab, ntab, slots,
              flanks, ev, stats, samples, aux_prev):
    """Integrate from ``run.t`` to ``t_end``; returns 0, or 1 if the step collapsed.

    ``run`` (a `PROGRESS` record) is updated in place, as are ``y`` and its
    derivative ``f`` (FSAL), the contact slots and flanks, the events
    ``ev`` (`EVENT` records), the statistics and the samples of this call
    (``run.n_samples`` rows).
    """
    nv = y.shape[0]
    stages_k = np.empty((7, nv))
    ynew, ytmp = np.empty(nv), np.empty(nv)
    pairs = np.zeros((2, MAXPAIR), dtype=PAIR)
    npairs = np.zeros(2, dtype=np.int64)
    pairs2 = np.zeros((2, MAXPAIR), dtype=PAIR)
    npairs2 = np.zeros(2, dtype=np.int64)
    aux = np.zeros(N_AUX)
    aux2 = np.zeros(N_AUX)
    scratch = np.empty(nv)
    rtol, hmax, dts = p.rtol, p.max_step, p.sample_dt
    eng = p.engaged
    t, h = run.t, run.h
    run.n_samples = 0
    while t < t_end:
        h = min(h, hmax, t_end - t)
        if t + h >= t_end - 1e-12 * max(1.0, abs(t_end)):
            h = t_end - t
        stages_k[0, :] = f
        for s in range(1, 7):
            for i in range(nv):
                acc = 0.0
                for j in range(s):
                    acc += _WEIGHTS[s, j] * stages_k[j, i]
                ytmp[i] = y[i] + h * acc
            rhs(t + _NODES[s] * h, ytmp, stages_k[s], p, stages, aoff, corners, postab, sch,
                slots, pairs, npairs, aux)
        # the last stage was evaluated at the new solution (FSAL): pairs, aux hold its data
        ynew[:] = ytmp
        k7 = stages_k[6]
        run.rhs += 6
        err = 0.0
        for i in range(nv):
            e = 0.0
            for j in range(7):
                e += _ERROR[j] * stages_k[j, i]
            scale = atol[i] + rtol * max(abs(y[i]), abs(ynew[i]))
            err += (h * e / scale) ** 2
        err = math.sqrt(err / nv)
        if not err <= 1.0:  # a NaN error (an overflowing law) is rejected too, not accepted
            run.rejected += 1
            h /= min(5.0, err**_EXPO / _SAFE)
            if h < 1e-15 * max(1.0, t):
                run.t, run.h = t, h
                return 1
            continue
        t_new = t + h
        changed = track_contacts(t, t_new, p, tab, ntab, slots, flanks, pairs, npairs, ev, run)
        accumulate(stats, eng, h, aux_prev, aux)
        # samples in (t, t_new], on the cubic Hermite of the state
        while run.t_sample <= t_new + 1e-12 * h and run.n_samples < samples.shape[0]:
            ts = run.t_sample
            z = (ts - t) / h
            for i in range(nv):
                ytmp[i] = ((2 * z**3 - 3 * z**2 + 1) * y[i] + (z**3 - 2 * z**2 + z) * h * f[i]
                           + (-2 * z**3 + 3 * z**2) * ynew[i] + (z**3 - z**2) * h * k7[i])
            rhs(ts, ytmp, scratch, p, stages, aoff, corners, postab, sch, slots, pairs2, npairs2,
                aux2)
            write_sample(samples[run.n_samples], ts, ytmp, p, stages, aoff, sch, aux2)
            run.n_samples += 1
            run.t_sample += dts
        for i in range(nv):
            y[i] = ynew[i]
            f[i] = k7[i]
        aux_prev[:] = aux
        if changed:
            rhs(t_new, y, f, p, stages, aoff, corners, postab, sch, slots, pairs, npairs, aux)
            aux_prev[:] = aux
            run.rhs += 1
        t = t_new
        run.steps += 1
        # PI step control (Hairer & Wanner's DOPRI5: exponents 0.17 and 0.04)
        err = max(err, 1e-10)
        h /= min(5.0, max(0.1, err**_EXPO / run.err_prev ** _BETA / _SAFE))
        run.err_prev = max(err, 1e-4)
    run.t, run.h = t, h
    return 0


@njit(cache=True)
def prepare(t, y, f, p, stages, aoff, corners, postab, sch, slots, flanks, aux_prev):
    """Derivative at ``t`` and contact states of a fresh segment (no events)."""
    pairs = np.zeros((2, MAXPAIR), dtype=PAIR)
    npairs = np.zeros(2, dtype=np.int64)
    for fl in range(2):
        for i in range(NSLOT):
            slot = slots[fl, i]
            slot.pair = -(2**62)
            slot.on = 0
            slot.event = -1
            slot.has_law = 0
        flanks[fl].on = 0
        flanks[fl].event = -1
    rhs(t, y, f, p, stages, aoff, corners, postab, sch, slots, pairs, npairs, aux_prev)
    for fl in range(2):
        for m in range(npairs[fl]):
            pair = pairs[fl, m]
            slot = slots[fl, slot_of(pair.pair)]
            slot.pair = pair.pair
            on = pair.h > 0.0
            slot.on = 1 if on else 0
            slot.h = pair.h
            slot.hd = pair.hd
            if on:
                flanks[fl].on = 1
