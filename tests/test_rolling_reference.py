"""The reference of the rolling mesh's quasi-static check (``validation/rolling.py`` (b)):
the mesh cycle's superposition with the tip-edge pairs beyond the path of contact."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fe_impact.calibration.meshcycle import PositionRecord, mesh_cycle, path_of_contact
from fe_impact.gears import default_gearset
from fe_impact.gears.kinematics import mesh_geometry
from validation.rolling import corner_superposition

K_FLANK, K_TIP = 1.0e8, 4.0e7      # N/m: linear pair laws, so the sharing has a closed form


def _record(roll: float, k: float, lever: float, contact: str = "flank") -> dict:
    forces = [100.0, 1000.0]
    return PositionRecord(
        id=f"{contact}{roll:+.3f}", stage=1, roll_angle_deg=roll, end="", forces=forces,
        approaches=[f / k for f in forces], torques=[0.0, 0.0], rotations=[0.0, 0.0],
        contact_areas=[0.0, 0.0], max_pressures=[0.0, 0.0], hertz_approaches=[0.0, 0.0],
        stiffness=k, exponent=1.0, fit_error=0.0, nominal_force=100.0,
        nominal_stiffness=k, lever=lever, edge="", ellipse_outline=[], footprint=[],
        flank_edges=[], n_dofs=0, contact=contact).to_dict()


@pytest.fixture(scope="module")
def setup():
    gearset = default_gearset()
    first, last = path_of_contact(gearset, 1)
    pitch = 360.0 / gearset.pinion.teeth
    geo = mesh_geometry(gearset, 1, "3d")
    r_b = geo.base_radius
    data = {"positions": [_record(r, K_FLANK, r_b) for r in np.linspace(last, first, 5)],
            "corners": [_record(first + 0.5, K_TIP, r_b, "corner-approach"),
                        _record(last - 1.5, K_TIP, r_b, "corner-recess")],
            "path_of_contact_deg": {"1": [first, last]}, "angular_pitch_deg": pitch}
    return gearset, data, geo, 1000.0 * geo.base_radius


def test_flank_pairs_alone_are_the_mesh_cycle(setup):
    # without the tip edges it is the calibration's own superposition (a separate
    # implementation: vectorised bisection over the cycle); both bisect log TE to
    # ~1e-17, so they agree to round-off
    gearset, data, _, torque = setup
    te = corner_superposition(data, gearset, 1, torque, corners=False, n=40)
    recs = [PositionRecord.from_dict(p) for p in data["positions"]]
    ref = mesh_cycle(recs, data["angular_pitch_deg"], torque, 40,
                     tuple(data["path_of_contact_deg"]["1"]))
    np.testing.assert_allclose(te, ref.transmission_error, rtol=1e-9)


def test_tip_edge_pairs_share_as_springs_behind_their_gaps(setup):
    # linear laws: the TE solves r_b (N k te + sum_active k_t (te - g_i)) = T, the
    # active tip pairs those whose corner gap g_i is below te; solved exactly by
    # adding them in order of their gap (bisection to ~1e-17 in log TE: 1e-9 is
    # round-off's margin)
    gearset, data, geo, torque = setup
    first, last = data["path_of_contact_deg"]["1"]
    pitch = data["angular_pitch_deg"]
    n = 40
    te = corner_superposition(data, gearset, 1, torque, n=n)
    reach = (geo.s_start - geo.approach.delta_max, geo.s_end + geo.recess.delta_max)
    active_somewhere = False
    for theta, got in zip(np.linspace(last, last + pitch, n, endpoint=False), te,
                          strict=True):
        rolls = theta + pitch * np.arange(-4, 5)
        flank = int(np.sum((last <= rolls) & (rolls <= first)))
        s = geo.s_pitch - geo.base_radius * np.radians(rolls)
        tips = ~((last <= rolls) & (rolls <= first)) & (reach[0] < s) & (s < reach[1])
        gaps = np.sort(geo.gap(s[tips])[0]) if tips.any() else np.zeros(0)
        exact = torque / geo.base_radius / (flank * K_FLANK)
        for m in range(1, len(gaps) + 1):
            trial = ((torque / geo.base_radius + K_TIP * gaps[:m].sum())
                     / (flank * K_FLANK + m * K_TIP))
            if trial > gaps[m - 1]:
                exact = trial
                active_somewhere = True
        assert got == pytest.approx(exact, rel=1e-9)
    assert active_somewhere        # the check saw tip pairs carry load
    assert te.max() < corner_superposition(data, gearset, 1, torque, corners=False,
                                           n=n).max()


def test_no_corner_records_no_reference(setup):
    gearset, data, _, torque = setup
    assert corner_superposition({**data, "corners": []}, gearset, 1, torque) is None
    assert math.isfinite(corner_superposition({**data, "corners": []}, gearset, 1, torque,
                                              corners=False, n=4)[0])
