"""Settings that are legal but surely unintended get a warning that says why; numerical
nonsense stops with a clear error instead of a NaN table."""

from __future__ import annotations

import json
import logging
import math
import re

import numpy as np
import pytest

from fe_impact.cli.main import MIN_STEPS_PER_CONTACT, main
from fe_impact.errors import CalibrationError, SolverError
from fe_impact.physics import hertz
from fe_impact.switching.calibration import (
    MIN_CONTACT_TIME,
    LawSet,
    LawTable,
    check_integrable,
    closed_form_laws,
    contact_time,
)
from fe_impact.switching.model import DriveModel
from fe_impact.switching.presets import get_preset
from fe_impact.switching.simulation import simulate
from tests.test_bad_inputs import DURATION, T_CONTACT, sdof


def warnings_of(caplog) -> str:
    return "\n".join(r.getMessage() for r in caplog.records if r.levelno == logging.WARNING)


def test_one_time_step_over_the_whole_run_is_warned(tmp_path, caplog):
    case = tmp_path / "c.toml"
    case.write_text(sdof(time_step=DURATION))
    assert main(["solve", str(case), "--out", str(tmp_path / "o")]) == 0
    assert re.search(r"time_step = \S+ s gives 1 step\(s\) over the whole duration .* about "
                     rf"{MIN_STEPS_PER_CONTACT} or more", warnings_of(caplog))


def test_a_contact_of_few_time_steps_is_warned(tmp_path, caplog):
    """Eight steps over the closed-form contact time pi sqrt(m/k): the measured contact
    lasts 8 steps, within one (Newmark lengthens the period by (w dt)^2/12 = 1.3 %)."""
    case = tmp_path / "c.toml"
    case.write_text(sdof(time_step=T_CONTACT / 8))
    assert main(["solve", str(case), "--out", str(tmp_path / "o")]) == 0
    found = re.search(r"the contact lasted \S+ s, only (\S+) time steps", warnings_of(caplog))
    assert found and 7.0 <= float(found.group(1)) <= 9.0, warnings_of(caplog)
    caplog.clear()
    case.write_text(sdof(time_step=T_CONTACT / 40))       # resolved: no warning
    assert main(["solve", str(case), "--out", str(tmp_path / "o2")]) == 0
    assert "time steps" not in warnings_of(caplog)


def test_frames_above_the_cap_are_thinned_with_a_warning(tmp_path, caplog):
    # 1e-12 s over a 0.64 us run asked for 638,567 frames (and as many steps).
    case = tmp_path / "c.toml"
    case.write_text(sdof(extra="output_interval = 1e-12"))
    out = tmp_path / "o"
    assert main(["solve", str(case), "--out", str(out), "--max-frames", "5"]) == 0
    assert re.search(r"output_interval = 1e-12 s asks for \d{6} frames, more than the cap of 5: "
                     r".*--max-frames", warnings_of(caplog))
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary["fields"]["frames"]) == 5
    assert sorted(p.name for p in out.glob("frame_*.vtu")) == [f"frame_{i:04d}.vtu"
                                                               for i in range(5)]


def test_switching_run_too_short_for_its_statistics(tmp_path, caplog):
    # 0.2 s at 100 r/min is 6.3 mesh cycles of the 19-tooth pinion (the seed's 5 s: 158).
    out = tmp_path / "o"
    assert main(["switching", "--preset", "table1-100rpm", "--duration", "0.2",
                 "--out", str(out)]) == 0
    text = warnings_of(caplog)
    assert re.search(r"run too short for its statistics: table1-100rpm: stage 1 at 100 r/min "
                     r"runs 6.33 mesh cycles .* give --duration 0.632 or more", text), text
    stats = json.loads((out / "statistics.json").read_text())
    assert stats["status"] == "completed" and "too short" in stats["notes"][0]
    assert "**Note:** run too short" in (out / "report.md").read_text()


def test_contact_time_of_a_power_law_against_closed_forms():
    # Linear spring: half the period, pi sqrt(m/k). Hertz: Johnson's 2.94328 delta_max/v
    # (physics.hertz, written separately). Both to round-off.
    assert contact_time(1e9, 1.0, 0.05, 0.3) == pytest.approx(math.pi * math.sqrt(0.05 / 1e9),
                                                              rel=1e-12)
    hit = hertz.impact_from_stiffness(0.05, 0.01, 2e10)
    assert contact_time(2e10, 1.5, 0.05, 0.01) == pytest.approx(hit.contact_time, rel=1e-5)
    # k = 1e300 neither overflows nor passes.
    assert contact_time(1e300, 1.5, 0.05, 0.01) < 1e-100


def _law_table(stage: int, k: float, cmax: float = 20.0) -> LawTable:
    speeds = np.array([1e-3, 1.0])
    return LawTable(stage, "mesh", speeds, np.full(2, k), np.full(2, 1.5), np.full(2, cmax),
                    np.full(2, 1e-7), "test")


def test_laws_that_cannot_be_integrated_are_refused():
    with pytest.raises(CalibrationError, match=r"test: stage 1 'mesh' at 0.001 m/s: k = 1e\+300.*"
                                               r"contact would last .* cannot be integrated"):
        check_integrable(_law_table(1, 1e300), 0.05)
    with pytest.raises(CalibrationError, match=r"damping time m/cmax would be 5e-302 s"):
        check_integrable(_law_table(1, 1e7, cmax=1e300), 0.05)
    check_integrable(_law_table(1, 1e10), 0.05)          # the seed's order: accepted
    assert contact_time(1e10, 1.5, 0.05, 1.0) > 1e3 * MIN_CONTACT_TIME


def test_an_overflowing_law_stops_the_run_with_an_error_not_a_nan_table():
    """k = 1e300 put in the model directly (past the reader's check): the first contact
    overflows; the run stops with SolverError instead of integrating NaN."""
    model = DriveModel()
    masses = [model.effective_mass(s) for s in range(1, model.n_stages + 1)]
    laws = closed_form_laws(model.gearset, masses)
    tables = dict(laws.tables)
    tables[(1, "mesh")] = _law_table(1, 1e300)
    tables[(1, "switch")] = _law_table(1, 1e300)
    model = model.with_laws(LawSet(tables, "test"))
    case = get_preset("table1-300rpm").cases[0]
    with pytest.raises(SolverError, match=r"step size collapsed|became NaN/inf"):
        simulate(model, case.schedule.scaled(0.2))


def test_a_nan_anywhere_in_the_state_stops_the_transient_run(tmp_path, monkeypatch, capsys):
    """A NaN put into the last velocity (the rigid body's) at step 3: one line naming the
    step, exit 2, and summary.json says how the run ended."""
    from fe_impact.solvers import integrators

    step = integrators.newmark_step

    def poisoned(s, *args, **kwargs):
        new = step(s, *args, **kwargs)
        if new.n == 3:
            new.v[-1] = np.nan
        return new

    monkeypatch.setattr(integrators, "newmark_step", poisoned)
    case = tmp_path / "c.toml"
    case.write_text(sdof())
    out = tmp_path / "o"
    assert main(["solve", str(case), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert re.search(r"fe-impact: error: the solution became NaN/inf at t = \S+ s \(step 3\)",
                     err), err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "stopped" and "step 3" in summary["error"]
