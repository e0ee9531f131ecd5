"""Compiled core of the torsional model: right-hand side, integrator, impact detection.

Private module: `fe_impact.switching.simulation` packs the model into the
arrays below and calls `integrate` chunk by chunk. Everything here is a pure
function of its arrays (numba ``njit``, cached on disk).

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

# -- scalar parameters P[...] ----------------------------------------------------------
RBP = 0  # pinion base radius [m]
PB = 1  # base pitch [m]
SSTART = 2  # start of the active path [m]
SEND = 3  # end of the active path [m]
NPIN = 4  # pinions (identical meshes in phase)
TEA = 5  # transmission-error amplitude [m]
MUS = 6  # static friction coefficient
MUD = 7  # dynamic friction coefficient
VS = 8  # stiction speed [m/s]
VT = 9  # friction transition speed [m/s]
FRIC = 10  # 1 with friction
DRIVE = 11  # 0 speed-driven pinion, 1 torque-driven
RAMP = 12  # speed/load ramp time [s]
X0 = 13  # mesh-coordinate offset of the engaged ring [m]
ENG = 14  # engaged ring, 0-based
U0 = 15  # roll offset of the tooth-pair numbering [m]
RATIO = 16  # c of rings and output
RTOL = 17
HMAX = 18  # largest step [s]
BH = 19  # half backlash of the engaged mesh [m]
R2SIN = 20  # face-gear friction lever r_2 sin(alpha0) of the engaged ring [m]
PEND = 21  # 1 until the first contact after a switch
JP = 22  # pinion inertia, all pinions [kg m^2]
JO = 23  # output inertia [kg m^2]
SAMPLE_DT = 24  # sampling interval [s]
DRAG = 25  # drag torque on the output [N m]
N_P = 26

# -- integer slot data SI[flank, slot, ...] and float slot data SF[flank, slot, ...] -----
NSLOT = 8  # slots per flank, indexed by pair number mod NSLOT
SI_K, SI_ON, SI_EV, SI_LAW = 0, 1, 2, 3
SF_LAW, SF_H, SF_HD = 0, 4, 5  # law parameters k, n, cmax, d at 0..3
MAXPAIR = 6  # pairs looked at per flank

# -- per-evaluation results AUX[...] ------------------------------------------------------
A_APPROACH, A_XDOT, A_FORCE, A_ENERGY, A_NCONTACT, A_X = 0, 1, 2, 3, 4, 5
A_FRICTION, A_LOAD, A_INPUT, A_FDRIVE, A_FCOAST = 6, 7, 8, 9, 10
N_AUX = 11
# work arrays W[flank, pair, ...]
W_K, W_S, W_H, W_HD, W_F, W_E = 0, 1, 2, 3, 4, 5

# -- events EV[i, ...] -----------------------------------------------------------------------
E_TIME, E_STAGE, E_KIND, E_FLANK, E_SPEED, E_APPROACH, E_FORCE, E_ENERGY = range(8)
E_END, E_SPEED_OUT, E_CLAMP, E_PAIR = 8, 9, 10, 11
N_EV = 12
KIND_RATTLE, KIND_MESH_IN, KIND_SWITCH = 0, 1, 2

# -- counters CNT[...] -------------------------------------------------------------------------
C_STEPS, C_REJECTED, C_RHS, C_CLAMP_LOW, C_CLAMP_HIGH, C_DROPPED, C_GUARD, C_NSAMP = range(8)
N_CNT = 8

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
def smooth_step(z):
    """ADAMS STEP from 0 at z = 0 to 1 at z = 1 (clamped)."""
    if z <= 0.0:
        return 0.0
    if z >= 1.0:
        return 1.0
    return z * z * (3.0 - 2.0 * z)


@njit(cache=True)
def reference(t, sch, ramp):
    """Scheduled pinion angle, speed, acceleration, load and input torque at ``t``.

    ``sch[k] = (t_start, speed, load, input_torque, psi_start)``; speed, load
    and input torque blend from the previous segment's value over ``ramp``
    with the ADAMS STEP cubic.
    """
    k = 0
    while k + 1 < sch.shape[0] and sch[k + 1, 0] <= t:
        k += 1
    tau = t - sch[k, 0]
    w1 = sch[k, 1]
    w0 = sch[k - 1, 1] if k > 0 else w1
    blend = 1.0
    if ramp > 0.0 and k > 0 and tau < ramp:
        z = tau / ramp
        blend = z * z * (3.0 - 2.0 * z)
        psi = sch[k, 4] + w0 * tau + (w1 - w0) * ramp * (z**3 - 0.5 * z**4)
        psid = w0 + (w1 - w0) * blend
        psidd = (w1 - w0) * 6.0 * z * (1.0 - z) / ramp
    else:
        if ramp > 0.0 and k > 0:
            psi = sch[k, 4] + w0 * ramp + 0.5 * (w1 - w0) * ramp + w1 * (tau - ramp)
        else:
            psi = sch[k, 4] + w1 * tau
        psid = w1
        psidd = 0.0
    if k > 0:
        load = sch[k - 1, 2] + (sch[k, 2] - sch[k - 1, 2]) * blend
        tin = sch[k - 1, 3] + (sch[k, 3] - sch[k - 1, 3]) * blend
    else:
        load = sch[k, 2]
        tin = sch[k, 3]
    return psi, psid, psidd, load, tin


@njit(cache=True)
def corner(delta, table, delta_max):
    """Tabulated corner gap and its slope (see `geometry.CornerGap`)."""
    values = table[0]
    if delta >= delta_max:
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
def pair_gap(s, p, gin, gout, din, dout):
    """Gap ``g(s)`` and ``dg/ds`` of a tooth pair at roll ``s``."""
    if s < p[SSTART]:
        g, dg = corner(p[SSTART] - s, gin, din)
        return g, -dg
    if s > p[SEND]:
        return corner(s - p[SEND], gout, dout)
    return 0.0, 0.0


@njit(cache=True)
def friction_coefficient(v, p):
    """Signed Coulomb coefficient ``mu(|v|) sgn(v)``, smoothed (seed eqs. 9-10).

    ``sgn`` is the ADAMS STEP from -1 at ``-v_s`` to +1 at ``+v_s``
    (stiction, ``mu_s``); above ``v_s`` the coefficient blends to ``mu_d`` at
    ``v_t``.
    """
    av = abs(v)
    vs = p[VS]
    if av < vs:
        return p[MUS] * (2.0 * smooth_step((v + vs) / (2.0 * vs)) - 1.0)
    mu = p[MUS] + (p[MUD] - p[MUS]) * smooth_step((av - vs) / (p[VT] - vs))
    return mu if v > 0.0 else -mu


@njit(cache=True)
def law_lookup(tab, ntab, stage, kind, speed):
    """IMPACT parameters at ``speed``, linear in log(speed); clamp flag -1/0/+1."""
    n = ntab[stage, kind]
    rows = tab[stage, kind]
    x = math.log(max(speed, 1e-300))
    out = np.empty(4)
    if n == 1 or x <= rows[0, 0]:
        out[:] = rows[0, 1:5]
        return out, (-1 if (x < rows[0, 0]) else 0)
    if x >= rows[n - 1, 0]:
        out[:] = rows[n - 1, 1:5]
        return out, (1 if x > rows[n - 1, 0] else 0)
    i = 0
    while rows[i + 1, 0] < x:
        i += 1
    w = (x - rows[i, 0]) / (rows[i + 1, 0] - rows[i, 0])
    out[:] = rows[i, 1:5] + w * (rows[i + 1, 1:5] - rows[i, 1:5])
    return out, 0


@njit(cache=True)
def impact_law(h, hd, k, n, cmax, d):
    """ADAMS IMPACT in penetration form: force and stored elastic energy of one pair."""
    if h <= 0.0:
        return 0.0, 0.0
    hn = h**n
    force = k * hn + cmax * smooth_step(h / d) * hd
    return max(force, 0.0), k * hn * h / (n + 1.0)


@njit(cache=True)
def slot_of(k):
    return k - NSLOT * (k // NSLOT)


@njit(cache=True)
def rhs(t, y, dy, p, jr, kc, cc, rb, aoff, gin, gout, geo, sch, default, si, sf, w, wn, aux):
    """Time derivative of the state; fills the tooth-pair data ``w`` and ``aux``.

    ``geo = (delta_max approach, delta_max recess)``. Forces are per mesh;
    the ``NPIN`` identical meshes act together on the rings and the pinions.
    """
    n = jr.shape[0]
    psi, psid, psidd, load, tin = reference(t, sch, p[RAMP])
    c = p[RATIO]
    eng = int(p[ENG])
    rbp, rbe, pb = p[RBP], rb[eng], p[PB]
    wp = y[1] + psid
    we = y[3 + 2 * eng] + c * psid
    x = rbp * y[0] - rbe * y[2 + 2 * eng] + p[X0]
    xd = rbp * wp - rbe * we
    u = rbp * (y[0] + psi + aoff[0])
    phase = 2.0 * math.pi / pb
    e = p[TEA] * math.sin(phase * u)
    de = p[TEA] * phase * math.cos(phase * u)
    length = p[SEND] - p[SSTART]
    q_pinion = 0.0
    q_ring = 0.0
    friction = 0.0
    force_drive, force_coast = 0.0, 0.0
    energy = 0.0
    approach_drive, approach_coast = 0.0, 0.0
    ncontact = 0
    for fl in range(2):
        sg = 1.0 if fl == 0 else -1.0
        roll = u + p[U0] if fl == 0 else length + 0.5 * pb - (u + p[U0])
        srate = sg * rbp * wp
        lo = math.ceil((roll - length - geo[1]) / pb)
        hi = math.floor((roll + geo[0]) / pb)
        m = 0
        for k in range(lo, hi + 1):
            s = p[SSTART] + roll - k * pb
            g, dg = pair_gap(s, p, gin, gout, geo[0], geo[1])
            h = sg * x - p[BH] - g - sg * e
            hd = sg * xd - dg * srate - sg * de * rbp * wp
            slot = slot_of(k)
            if si[fl, slot, SI_K] == k and si[fl, slot, SI_LAW] == 1:
                f, pe = impact_law(h, hd, sf[fl, slot, 0], sf[fl, slot, 1], sf[fl, slot, 2],
                                   sf[fl, slot, 3])
            else:
                f, pe = impact_law(h, hd, default[0], default[1], default[2], default[3])
            if f > 0.0 or h > 0.0:
                if h > 0.0:
                    ncontact += 1
                    if fl == 0:
                        approach_drive = max(approach_drive, h)
                    else:
                        approach_coast = max(approach_coast, h)
                q_pinion -= f * sg * rbp * (1.0 - dg - de)
                q_ring += f * sg * rbe
                if p[FRIC] > 0.0 and f > 0.0:
                    mu = friction_coefficient(wp * s - we * p[R2SIN], p)
                    q_pinion -= mu * f * s
                    q_ring += mu * f * p[R2SIN]
                    friction -= mu * f * s
            if fl == 0:
                force_drive += f
            else:
                force_coast += f
            energy += pe
            if m < MAXPAIR:
                w[fl, m, W_K] = k
                w[fl, m, W_S] = s
                w[fl, m, W_H] = h
                w[fl, m, W_HD] = hd
                w[fl, m, W_F] = f
                w[fl, m, W_E] = pe
                m += 1
        wn[fl] = m
    npin = p[NPIN]
    # pinion: prescribed motion, or driven by the input torque
    dy[0] = y[1]
    input_torque = p[JP] * psidd - npin * q_pinion
    if p[DRIVE] > 0.0:
        dy[1] = (npin * q_pinion + tin) / p[JP] - psidd
        input_torque = tin
    else:
        dy[1] = 0.0
    out = 2 + 2 * n
    wo = y[out + 1] + c * psid
    t_out = -load - p[DRAG]
    for i in range(n):
        twist = y[2 + 2 * i] - y[out] + aoff[i + 1] - aoff[n + 1]
        wi = y[3 + 2 * i] + c * psid
        coupling = kc[i] * twist + cc[i] * (wi - wo)
        torque = -coupling + (npin * q_ring if i == eng else 0.0)
        dy[2 + 2 * i] = y[3 + 2 * i]
        dy[3 + 2 * i] = torque / jr[i] - c * psidd
        t_out += coupling
    dy[out] = y[out + 1]
    dy[out + 1] = t_out / p[JO] - c * psidd
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
def new_event(ev, nev, cnt, t, stage, kind, flank, speed, clamp, pair):
    i = nev[0]
    if i >= ev.shape[0]:
        cnt[C_DROPPED] += 1
        return -1
    nev[0] = i + 1
    ev[i, E_TIME] = t
    ev[i, E_STAGE] = stage + 1
    ev[i, E_KIND] = kind
    ev[i, E_FLANK] = 1.0 if flank == 0 else -1.0
    ev[i, E_SPEED] = speed
    ev[i, E_APPROACH] = 0.0
    ev[i, E_FORCE] = 0.0
    ev[i, E_ENERGY] = 0.0
    ev[i, E_END] = np.nan
    ev[i, E_SPEED_OUT] = np.nan
    ev[i, E_CLAMP] = clamp
    ev[i, E_PAIR] = pair
    return i


@njit(cache=True)
def track_contacts(t0, t1, p, tab, ntab, si, sf, fi, w, wn, ev, nev, cnt):
    """Update contact states after an accepted step ``[t0, t1]``; record impacts.

    An impact is a contact onset with a closing speed. A tooth pair that
    touches while no pair of its flank is in contact starts a flank impact
    (rattle, or the switching impact if it is the first contact after a
    switch); a pair that touches while its flank already carries load is a
    mesh-in impact. Each onset selects the law parameters at its closing
    speed. Returns True if any law changed (the derivative must be redone).
    """
    eng = int(p[ENG])
    changed = False
    for fl in range(2):
        was_on = fi[fl, 0] == 1
        any_now = False
        flank_event = fi[fl, 1]
        created = -1
        sep_t, sep_v = np.nan, np.nan
        h_max, f_sum, e_sum = 0.0, 0.0, 0.0
        for m in range(wn[fl]):
            k = int(w[fl, m, W_K])
            slot = slot_of(k)
            h1, hd1 = w[fl, m, W_H], w[fl, m, W_HD]
            if si[fl, slot, SI_K] != k:
                if si[fl, slot, SI_ON] == 1 or h1 > 0.0:
                    cnt[C_GUARD] += 1  # a pair entered or left the window in contact
                si[fl, slot, SI_K] = k
                si[fl, slot, SI_ON] = 0
                si[fl, slot, SI_EV] = -1
                si[fl, slot, SI_LAW] = 0
                sf[fl, slot, SF_H] = -1.0
                sf[fl, slot, SF_HD] = 0.0
            h0, hd0 = sf[fl, slot, SF_H], sf[fl, slot, SF_HD]
            if h1 > 0.0:
                any_now = True
                h_max = max(h_max, h1)
                if si[fl, slot, SI_ON] == 0:
                    tc, vc = crossing(t0, t1, h0, hd0, h1, hd1)
                    if was_on:
                        kind = KIND_MESH_IN
                    elif p[PEND] > 0.0:
                        kind = KIND_SWITCH
                    else:
                        kind = KIND_RATTLE
                    law, clamp = law_lookup(tab, ntab, eng, 1 if kind == KIND_SWITCH else 0,
                                            max(vc, 1e-12))
                    if clamp < 0:
                        cnt[C_CLAMP_LOW] += 1
                    elif clamp > 0:
                        cnt[C_CLAMP_HIGH] += 1
                    sf[fl, slot, 0:4] = law
                    si[fl, slot, SI_LAW] = 1
                    si[fl, slot, SI_ON] = 1
                    changed = True
                    if kind == KIND_MESH_IN:
                        si[fl, slot, SI_EV] = new_event(ev, nev, cnt, tc, eng, kind, fl, vc,
                                                        clamp, k)
                    elif created < 0:
                        created = new_event(ev, nev, cnt, tc, eng, kind, fl, vc, clamp, k)
                        flank_event = created
                    elif tc < ev[created, E_TIME]:  # the earliest touch of the flank defines it
                        ev[created, E_TIME] = tc
                        ev[created, E_SPEED] = vc
                        ev[created, E_PAIR] = k
            elif si[fl, slot, SI_ON] == 1:
                tc, vc = crossing(t0, t1, h0, hd0, h1, hd1)
                si[fl, slot, SI_ON] = 0
                j = si[fl, slot, SI_EV]
                if j >= 0:
                    ev[j, E_END] = tc
                    ev[j, E_SPEED_OUT] = -vc
                    si[fl, slot, SI_EV] = -1
                if not (sep_t >= tc):
                    sep_t, sep_v = tc, -vc
            j = si[fl, slot, SI_EV]
            if j >= 0:
                ev[j, E_APPROACH] = max(ev[j, E_APPROACH], h1)
                ev[j, E_FORCE] = max(ev[j, E_FORCE], w[fl, m, W_F])
                ev[j, E_ENERGY] = max(ev[j, E_ENERGY], w[fl, m, W_E])
            f_sum += w[fl, m, W_F]
            e_sum += w[fl, m, W_E]
            sf[fl, slot, SF_H] = h1
            sf[fl, slot, SF_HD] = hd1
        if flank_event >= 0:
            ev[flank_event, E_APPROACH] = max(ev[flank_event, E_APPROACH], h_max)
            ev[flank_event, E_FORCE] = max(ev[flank_event, E_FORCE], f_sum)
            ev[flank_event, E_ENERGY] = max(ev[flank_event, E_ENERGY], e_sum)
            if not any_now:
                ev[flank_event, E_END] = sep_t
                ev[flank_event, E_SPEED_OUT] = sep_v
                flank_event = -1
        if created >= 0 and ev[created, E_KIND] == KIND_SWITCH:
            p[PEND] = 0.0
        fi[fl, 0] = 1 if any_now else 0
        fi[fl, 1] = flank_event
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
def write_sample(row, t, y, p, jr, aoff, sch, aux):
    """One row of the time series (columns: see `model.series_columns`)."""
    n = jr.shape[0]
    psi, psid, psidd, load, tin = reference(t, sch, p[RAMP])
    c = p[RATIO]
    out = 2 + 2 * n
    row[0] = t
    row[1] = p[ENG] + 1
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
def integrate(t_end, state, y, f, p, jr, kc, cc, rb, aoff, atol, gin, gout, geo, sch, tab, ntab,
              default, si, sf, fi, ev, nev, stats, cnt, samples, aux_prev):
    """Integrate from ``state[0]`` to ``t_end``; returns 0, or 1 if the step collapsed.

    ``state = [t, step size, next sample time, previous error]`` is updated in place, as are
    ``y`` and its derivative ``f`` (FSAL), the contact slots, events,
    statistics, counters and the samples of this call (``cnt[C_NSAMP]``
    rows).
    """
    nv = y.shape[0]
    stages = np.empty((7, nv))
    ynew, ytmp = np.empty(nv), np.empty(nv)
    w = np.zeros((2, MAXPAIR, 6))
    wn = np.zeros(2, dtype=np.int64)
    w2 = np.zeros((2, MAXPAIR, 6))
    wn2 = np.zeros(2, dtype=np.int64)
    aux = np.zeros(N_AUX)
    aux2 = np.zeros(N_AUX)
    scratch = np.empty(nv)
    rtol, hmax, dts = p[RTOL], p[HMAX], p[SAMPLE_DT]
    eng = int(p[ENG])
    t, h = state[0], state[1]
    cnt[C_NSAMP] = 0
    while t < t_end:
        h = min(h, hmax, t_end - t)
        if t + h >= t_end - 1e-12 * max(1.0, abs(t_end)):
            h = t_end - t
        stages[0, :] = f
        for s in range(1, 7):
            for i in range(nv):
                acc = 0.0
                for j in range(s):
                    acc += _WEIGHTS[s, j] * stages[j, i]
                ytmp[i] = y[i] + h * acc
            rhs(t + _NODES[s] * h, ytmp, stages[s], p, jr, kc, cc, rb, aoff, gin, gout, geo,
                sch, default, si, sf, w, wn, aux)
        # the last stage was evaluated at the new solution (FSAL): w, aux hold its data
        ynew[:] = ytmp
        k7 = stages[6]
        cnt[C_RHS] += 6
        err = 0.0
        for i in range(nv):
            e = 0.0
            for j in range(7):
                e += _ERROR[j] * stages[j, i]
            scale = atol[i] + rtol * max(abs(y[i]), abs(ynew[i]))
            err += (h * e / scale) ** 2
        err = math.sqrt(err / nv)
        if err > 1.0:
            cnt[C_REJECTED] += 1
            h /= min(5.0, err**_EXPO / _SAFE)
            if h < 1e-15 * max(1.0, t):
                state[0], state[1] = t, h
                return 1
            continue
        t_new = t + h
        changed = track_contacts(t, t_new, p, tab, ntab, si, sf, fi, w, wn, ev, nev, cnt)
        accumulate(stats, eng, h, aux_prev, aux)
        # samples in (t, t_new], on the cubic Hermite of the state
        while state[2] <= t_new + 1e-12 * h and cnt[C_NSAMP] < samples.shape[0]:
            ts = state[2]
            z = (ts - t) / h
            for i in range(nv):
                ytmp[i] = ((2 * z**3 - 3 * z**2 + 1) * y[i] + (z**3 - 2 * z**2 + z) * h * f[i]
                           + (-2 * z**3 + 3 * z**2) * ynew[i] + (z**3 - z**2) * h * k7[i])
            rhs(ts, ytmp, scratch, p, jr, kc, cc, rb, aoff, gin, gout, geo, sch, default, si, sf,
                w2, wn2, aux2)
            write_sample(samples[cnt[C_NSAMP]], ts, ytmp, p, jr, aoff, sch, aux2)
            cnt[C_NSAMP] += 1
            state[2] += dts
        for i in range(nv):
            y[i] = ynew[i]
            f[i] = k7[i]
        aux_prev[:] = aux
        if changed:
            rhs(t_new, y, f, p, jr, kc, cc, rb, aoff, gin, gout, geo, sch,
                default, si, sf, w, wn, aux)
            aux_prev[:] = aux
            cnt[C_RHS] += 1
        t = t_new
        cnt[C_STEPS] += 1
        # PI step control (Hairer & Wanner's DOPRI5: exponents 0.17 and 0.04)
        err = max(err, 1e-10)
        h /= min(5.0, max(0.1, err**_EXPO / state[3] ** _BETA / _SAFE))
        state[3] = max(err, 1e-4)
    state[0], state[1] = t, h
    return 0


@njit(cache=True)
def prepare(t, y, f, p, jr, kc, cc, rb, aoff, gin, gout, geo, sch, default, si, sf, fi,
            aux_prev):
    """Derivative at ``t`` and contact states of a fresh segment (no events)."""
    w = np.zeros((2, MAXPAIR, 6))
    wn = np.zeros(2, dtype=np.int64)
    si[:, :, SI_K] = -(2**62)
    si[:, :, SI_ON] = 0
    si[:, :, SI_EV] = -1
    si[:, :, SI_LAW] = 0
    fi[:, 0] = 0
    fi[:, 1] = -1
    rhs(t, y, f, p, jr, kc, cc, rb, aoff, gin, gout, geo, sch, default, si, sf, w, wn, aux_prev)
    for fl in range(2):
        for m in range(wn[fl]):
            k = int(w[fl, m, W_K])
            slot = slot_of(k)
            si[fl, slot, SI_K] = k
            on = w[fl, m, W_H] > 0.0
            si[fl, slot, SI_ON] = 1 if on else 0
            sf[fl, slot, SF_H] = w[fl, m, W_H]
            sf[fl, slot, SF_HD] = w[fl, m, W_HD]
            if on:
                fi[fl, 0] = 1
