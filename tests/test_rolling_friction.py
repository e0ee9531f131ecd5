"""Flank friction in the rolling mesh: the energy it takes and the direction it acts in.

Rigid sectors at a quasi-static speed (seconds); the longer runs, the closed-form
loss and the elastic sectors are ``validation/rolling_friction.py``'s.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from fe_impact.cli.main import main
from fe_impact.gears import default_gearset
from fe_impact.gears.kinematics import mesh_geometry
from fe_impact.rolling.api import RollInputs, roll

#: Load ramp over the first half cycle, then one whole cycle measured (steps 60..180).
STEPS, CYCLES, RAMP = 120, 1.5, 0.5


@pytest.fixture(scope="module")
def runs():
    gearset = default_gearset()
    out = {}
    for friction in (True, False):
        out[friction] = roll(gearset, RollInputs(
            stage=1, speed_rpm=50.0, torque_nm=50.0, cycles=CYCLES, ramp_cycles=RAMP,
            steps_per_cycle=STEPS, elastic=False, friction=friction, start_cycles=-1.15),
            None, check_step=False)
    return gearset, out


def test_dissipation_is_the_drive_work_not_delivered(runs):
    """Energy conservation: over a mesh cycle at quasi-static speed, the drive's work
    minus the load's work minus the change of the stored energies equals the integral
    of ``sum mu F_n |v_s|``, each pair's normal force times its coefficient times the
    sliding speed of the two rotations at the contact point. Tolerance 2%: the
    frictionless rigid model closes its energy to ~2e-5 of the work and friction
    dissipates ~0.3% of it, so the balance errs by <1% of the dissipation, the
    power's trapezoid over 120 steps by ~1e-4."""
    _, res = runs
    r = res[True]
    e = r.energy
    i0, i1 = round(RAMP * STEPS), round(CYCLES * STEPS)

    def stored(i):
        return e["kinetic"][i] + e["strain"][i] + e["hertz"][i]

    balance = (e["drive_work"][i1] - e["drive_work"][i0] + e["load_work"][i1]
               - e["load_work"][i0] - stored(i1) + stored(i0))
    power = np.trapezoid(e["friction_power"][i0:i1 + 1], r.time_s[i0:i1 + 1])
    assert power > 0.0
    assert balance == pytest.approx(power, rel=0.02)
    # without friction the same balance is zero to the model's closure (2e-5 of the work)
    f = res[False].energy
    lossless = (f["drive_work"][i1] - f["drive_work"][i0] + f["load_work"][i1]
                - f["load_work"][i0] - (f["kinetic"][i1] + f["hertz"][i1])
                + (f["kinetic"][i0] + f["hertz"][i0]))
    assert abs(lossless) < 0.05 * power


def test_sliding_reverses_at_the_pitch_point(runs):
    """Each pair's sliding speed against the kinematics of a spur pinion on a face
    gear: in the pinion's transverse plane the face gear is a rack, so the pinion
    slides at ``omega_p (s_pitch - s)`` along its profile, towards its tip before the
    geometry's pitch point and towards its root after it (the driver's friction
    points away from the pitch line: Buckingham 1949, ch. 19); the face gear's
    rotation adds ``omega_f (s - s_pitch) cos(alpha)`` along the pinion's axis
    (``validation/rolling_friction.py``). The run's face gear rings about its
    conjugate speed, and the friction takes its speed predicted from the step before
    (within the same range): the sliding speed may differ from the kinematic one by
    the largest deviation times the contact's distance from the face gear's axis
    (about its pitch radius; twice that allowed). The sign is asserted where the
    kinematic speed exceeds that bound, the size within it plus 2% (the TCA's
    contact points, linear between 0.25 mm, place the point to ~1e-3) on the path of
    contact (beyond its ends the tip edges touch where the path ends)."""
    gearset, res = runs
    geo = mesh_geometry(gearset, 1, "3d")
    r = res[True]
    pinion = gearset.pinion
    face_radius = 0.5 * gearset.module * gearset.stages[0].teeth
    u = face_radius / pinion.pitch_radius
    alpha = geo.pressure_angle
    slip, s = r.pair_slip_m_s[..., 0], r.pair_s_m[..., 0]
    loaded = np.nan_to_num(r.pair_force_n[..., 0]) > 0.0
    w_p = r.pinion_speed_rad_s[:, None]
    kinematic = w_p * (geo.s_pitch - s) * np.sqrt(1.0 + (np.cos(alpha) / u) ** 2)
    ringing = float(np.abs(r.face_speed_rad_s - r.pinion_speed_rad_s / u).max()) * face_radius
    clear = loaded & (np.abs(kinematic) > 2.0 * ringing)
    before, after = clear & (s < geo.s_pitch), clear & (s > geo.s_pitch)
    assert before.sum() > 10 and after.sum() > 10
    assert np.all(slip[before] > 0.0)
    assert np.all(slip[after] < 0.0)
    path = loaded & (s >= geo.s_start) & (s <= geo.s_end)
    assert np.all(np.abs(slip - kinematic)[path]
                  <= 0.02 * np.abs(kinematic[path]) + 2.0 * ringing)


def test_no_friction_option_runs_frictionless(tmp_path):
    out = tmp_path / "r"
    assert main(["roll", "--rigid", "--speed", "300", "--cycles", "0.3", "--quasi-static",
                 "--no-friction", "--out", str(out)]) == 0
    info = json.loads((out / "roll.json").read_text())["info"]
    assert info["friction"] is None and info["inputs"]["friction"] is False
