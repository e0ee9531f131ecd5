"""The mesh-cycle validation study: its arithmetic against closed forms, and its quick run.

The study (validation/mesh_cycle.py) compares the quasi-static single-pair
curve with a tooth impact, checks its convergence under mesh refinement and
its limit at vanishing load. The helpers here are checked on data whose
answer is known in closed form; the quick setting (coarse meshes, about one
minute) must pass its own checks.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fe_impact.errors import CalibrationError
from validation import mesh_cycle as study


def test_richardson_recovers_order_and_limit_on_uneven_refinement():
    # phi(h) = phi0 + C h^p exactly, refinement ratios 1.6 and 1.38 (uneven, as
    # the tooth-pair levels): the order and the limit to the iteration's 1e-12,
    # the fine level's error |phi_1 - phi0| / phi0 exactly, and the GCI is 1.25
    # times the Richardson estimate of that error in the fine value's units.
    phi0, c, p = 2.0, 0.3, 1.7
    h = [1.0, 0.625, 0.453]
    phi = [phi0 + c * x ** p for x in h]
    r = study.richardson(h, phi)
    assert r["order"] == pytest.approx(p, rel=1e-9)
    assert r["monotone"]
    assert r["extrapolated"] == pytest.approx(phi0, rel=1e-9)
    assert r["error_fine"] == pytest.approx((phi[2] - phi0) / phi0, rel=1e-6)
    assert r["gci_fine"] == pytest.approx(1.25 * (phi[2] - phi0) / phi[2], rel=1e-6)


def test_richardson_keeps_divergence_and_flags_oscillation():
    h = [1.0, 0.625, 0.453]
    # differences that grow under refinement: a negative order, no error estimate
    grow = study.richardson(h, [1.0, 1.01, 1.05])
    assert grow["order"] < 0 and grow["gci_fine"] == math.inf
    # differences that alternate in sign: oscillatory
    assert not study.richardson(h, [1.0, 1.04, 1.02])["monotone"]
    with pytest.raises(CalibrationError, match="must decrease"):
        study.richardson([0.5, 0.6, 0.4], [1.0, 1.1, 1.2])


def test_loglog_force_is_exact_on_a_power_law_in_any_point_order():
    # Piecewise power laws reproduce F = K d^e exactly, inside and beyond the
    # points (end powers), whatever the order the points come in.
    k, e = 3e10, 1.37
    d = np.array([4e-7, 1e-7, 8e-7, 2e-7])
    f = k * d ** e
    x = np.array([5e-8, 1.5e-7, 6e-7, 2e-6])
    np.testing.assert_allclose(study.loglog_force(x, f, d), k * x ** e, rtol=1e-12)
    assert np.isnan(study.loglog_force(np.array([0.0, -1e-9]), f, d)).all()


def test_branch_errors_split_mean_and_vibration():
    # A loading branch 1% above a static power law with a swing of 2% of the
    # local force, 8.25 periods over the branch (steps even in time, the
    # approach slowing to the peak as an impact's): the mean over the compared
    # range (from a quarter of the peak force, about 6 periods) finds the 1%
    # to within the swing's leftover, at most A / (pi n) = 0.02 / (6 pi) =
    # 1.1e-3, and the swing about it the 2% to within that leftover.
    k, e = 5e10, 1.4
    t = np.linspace(0.0, 1.0, 331)
    d = 1e-6 * np.sin(0.5 * np.pi * t)
    f = k * d ** e * (1.01 + 0.02 * np.sin(2 * np.pi * 8.25 * t + 0.7))
    impact = {"force": f.tolist(), "approach_hub": d.tolist(), "first_on": 1,
              "peak": len(t) - 1}
    static_d = np.geomspace(1e-8, 1.2e-6, 9)
    r = study.branch_errors(impact, (k * static_d ** e).tolist(), static_d.tolist())
    assert r["mean_error"] == pytest.approx(0.01, abs=1.1e-3)
    assert r["vibration_max"] == pytest.approx(0.02, abs=1.1e-3)
    assert r["max_error"] == pytest.approx(0.03, abs=1e-3)
    assert r["sign_changes"] == pytest.approx(12, abs=1)   # two a period, ~6 periods


def test_shift_refuses_an_offset_beyond_the_curve():
    from fe_impact.calibration.meshcycle import PositionRecord

    rec = PositionRecord(
        id="r", stage=1, roll_angle_deg=0.0, end="", forces=[5.0, 50.0], approaches=[5e-8, 4e-7],
        torques=[0.1, 1.0], rotations=[0.0, 0.0], contact_areas=[0.0, 0.0],
        max_pressures=[0.0, 0.0], hertz_approaches=[0.0, 0.0], stiffness=1.0, exponent=1.0,
        fit_error=0.0, nominal_force=5.0, nominal_stiffness=1e8, lever=0.0268, edge="",
        ellipse_outline=[], footprint=[], flank_edges=[], n_dofs=0)
    assert study.shifted(rec, 2e-8).approaches == pytest.approx([3e-8, 3.8e-7])
    with pytest.raises(CalibrationError, match="first-touch offset"):
        study.shifted(rec, 6e-8)


def test_quick_study_passes_its_checks(tmp_path):
    """Coarse impact and static curves, two meshes of the stiffness's refinement family,
    three coarse positions, the nominal point against a mesh made for its load."""
    result = study.run(quick=True, out=tmp_path)
    checks = study.check(result)
    assert len(checks) == 4          # the convergence is reported only on the quick setting
    failed = [c.line() for c in checks if not c.passed]
    assert not failed, failed
    assert (tmp_path / "mesh_cycle.json").is_file()


def test_nominal_path_table_reports_rows_and_meshes_that_cannot_be_made():
    rows = [{"roll_deg": -12.955, "reference": {"force": 2.61, "approach": 1.033e-7},
             "fe_approach": 1.468e-7, "fe_error": 1.468 / 1.033 - 1.0,
             "model_approach": 1.06e-7, "model_error": 1.06 / 1.033 - 1.0},
            {"roll_deg": 17.095, "error": "stage 1 at +17.095 deg roll: inverted"}]
    lines = study.nominal_path_lines(2, rows)
    assert lines[4] == "| -12.955 | 2.61 | 0.1033 | 0.1468 (+42.1%) | 0.1060 (+2.6%) |"
    assert lines[5].startswith("| +17.095 | - | stage 1 at +17.095 deg roll: inverted |")
