"""The time-step study's arithmetic (validation/time_step.py), on made-up runs.

The study itself takes minutes (`make validate` runs it), so it is not run
here; what it computes from its runs is.
"""

from __future__ import annotations

import pytest

from validation import time_step as ts


def _row(n: float, err: float, energy: float = 1e-4) -> dict:
    """A run at ``n`` steps per contact whose figures carry ``err`` relative error
    (the restitution an absolute one) and an energy error ``energy``."""
    return {"steps_per_contact": n, "steps": int(1.6 * n), "time_step": 1.0 / n,
            "steps_cpu_s": n / 10, "peak_force": 100.0 * (1 + err),
            "max_approach": 1e-6 * (1 + err), "contact_time": 2e-4 * (1 + err),
            "restitution": 1.0 + err, "energy_error": energy, "law_k": 1e10,
            "law_exponent": 1.5, "law_force": 90.0 * (1 + err)}


def test_a_second_order_integrator_shows_order_two():
    # errors c / n^2: each halving of the step divides the change by four
    rows = [_row(n, 50.0 / n ** 2) for n in (30, 60, 120, 240)]
    err = ts._errors(rows)
    for q in ("peak_force", "max_approach", "contact_time"):
        assert err["observed_order"][q] == pytest.approx(2.0, abs=1e-9)
    # deviations from the finest run: (1 + 50/60^2) / (1 + 50/240^2) - 1
    expected = (1 + 50 / 60 ** 2) / (1 + 50 / 240 ** 2) - 1
    assert err["deviation"]["60"]["peak_force"] == pytest.approx(expected, rel=1e-12)
    assert err["deviation"]["60"]["restitution"] == pytest.approx(50 / 60 ** 2 - 50 / 240 ** 2)


def test_the_checks_fail_a_step_whose_figures_move_more_than_the_tolerance():
    # 60 steps 0.6% off the finest: outside the 0.5%; 0.4%: inside
    for off, passed in ((0.006, False), (0.004, True)):
        rows = [_row(30, 0.02), _row(60, off), _row(240, 0.0)]
        result = {"calibration_steps": 60, "reference_steps": 240,
                  "runs": {"100": {"case": "x", "rows": rows}},
                  "errors": {"100": ts._errors(rows)}}
        checks = {c.name: c.passed for c in ts.check(result)}
        force = [k for k in checks if "peak_force" in k]
        assert len(force) == 1 and checks[force[0]] is passed
        assert "energy error exceeds" in " ".join(checks)
    assert "| 100 r/min | 60 |" in ts.table(result)


def test_the_plot_is_written_from_the_runs(tmp_path):
    rows = [_row(n, 50.0 / n ** 2) for n in (30, 60, 120, 240)]
    result = {"calibration_steps": 60, "reference_steps": 240, "level": "coarse",
              "runs": {"100": {"case": "x", "rows": rows}, "1000": {"case": "y", "rows": rows}},
              "errors": {"100": ts._errors(rows), "1000": ts._errors(rows)}}
    path = tmp_path / "time_step.png"
    ts.plot(result, path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]   # no temporary left


def test_the_energy_threshold_is_where_a_power_law_crosses_it():
    # energy error 1.6 / n^2 crosses 1e-3 at n = sqrt(1600) = 40 exactly; the
    # log-log interpolation is exact for a power law
    rows = [_row(n, 0.0, 1.6 / n ** 2) for n in (30, 60, 120, 240)]
    assert ts.threshold_steps(rows) == pytest.approx(40.0, rel=1e-12)
    # none above: at or below the smallest count; all above: no threshold found
    assert ts.threshold_steps([_row(n, 0.0, 1e-4) for n in (40, 60)]) == 40.0
    assert ts.threshold_steps([_row(n, 0.0, 2e-3) for n in (40, 60)]) == float("inf")


def test_coarse_counts_above_the_energy_tolerance_do_not_fail_the_study():
    # 30 and 40 steps above 1e-3 (as measured), 60 below: the threshold (~40)
    # lies under 0.8 x 60 = 48, every check passes
    rows = [_row(30, 0.002, 1.85e-3), _row(40, 0.001, 1.01e-3), _row(60, 0.0003, 4.4e-4),
            _row(240, 0.0)]
    result = {"calibration_steps": 60, "reference_steps": 240,
              "runs": {"100": {"case": "x", "rows": rows}},
              "errors": {"100": ts._errors(rows)}}
    checks = ts.check(result)
    assert all(c.passed for c in checks), [c.line() for c in checks if not c.passed]
    # a calibration count at the threshold fails
    result["calibration_steps"] = 40
    result["errors"]["100"] = ts._errors(rows)
    assert not all(c.passed for c in ts.check(result))
