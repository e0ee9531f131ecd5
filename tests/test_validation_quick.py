"""The validation studies listed below pass their own checks on the quick setting.

Each study's ``run(quick=True)`` computes on the coarse setting and its
``check`` compares the headline figures with the tolerances written (with
their reasons) in the study; the same checks make ``make validate`` fail.

The benchmarks' checks are all timings (ratios to baselines timed in the
same run). The default tests share their cores with other tests, so they
assert no timing: a benchmark here is run on its quick setting for what
it must do whatever the clock says, run its case through the solver's
step path with its counting wrappers (which must keep up with the solver's
interface) and report each ratio as a finite positive number; `make
validate`, run alone on the machine, asserts the timing targets.
"""

from __future__ import annotations

import importlib
import math

import pytest

STUDIES = [
    "hertz_impact",
    "corner_gaps",
    pytest.param("hertz_static", marks=pytest.mark.slow),
    pytest.param("plastic_impact", marks=pytest.mark.slow),
    # its check counts projections, not seconds: a failure is not the machine's
    pytest.param("bench_static_pair", marks=pytest.mark.slow),
]
BENCHMARKS = [
    "bench_switching",
    # one coarse calibration impact from mesh to fit, about 15 s
    pytest.param("bench_tooth_impact", marks=pytest.mark.slow),
]
# Not here: validation/corner_contact.py, whose quick setting (the finest refinement
# alone, 257k DOFs) takes eight minutes and 10.3 GB; `make validate
# VALIDATE_FLAGS=--quick` asserts it. Nor validation/calculix_pair.py, which needs
# CalculiX (a Debian package, not a pip one) and about five minutes of it;
# tests/test_calculix_deck.py checks the deck it writes. Nor validation/patch_test.py,
# whose four cases tests/test_contact_defects.py asserts. Nor validation/mesh_cycle.py,
# which tests/test_validation_mesh_cycle.py runs. Nor validation/time_step.py (half
# a minute of tooth impacts at three step counts; tests/test_time_step_study.py
# checks its arithmetic), validation/two_pair.py (about a minute of two-pair
# sectors), validation/bench_sweep.py (whole sweeps on one and two workers) and the
# timing-only benchmarks bench_static and bench_dynamic: `make validate` runs them.


@pytest.mark.parametrize("name", STUDIES)
def test_study_passes_its_checks_on_the_quick_setting(name, tmp_path):
    study = importlib.import_module(f"validation.{name}")
    checks = study.check(study.run(quick=True, out=tmp_path))
    assert checks, "a study must assert something"
    failed = [c.line() for c in checks if not c.passed]
    assert not failed, failed


@pytest.mark.parametrize("name", BENCHMARKS)
def test_benchmark_runs_and_reports_its_ratios(name, tmp_path):
    study = importlib.import_module(f"validation.{name}")
    checks = study.check(study.run(quick=True, out=tmp_path))
    assert checks, "a benchmark must report something"
    for c in checks:
        assert math.isfinite(c.value) and c.value > 0.0, c.line()


def test_plastic_impact_states_its_reference(tmp_path):
    # the report names the reference and explains the other curves, without a run
    from validation import plastic_impact as study

    assert "Jackson" in study.__doc__ and "Thornton" in study.WHY
    # JGM's values quoted in the study for this steel (S_y/E* = 0.0072)
    assert [round(study.jgm(j), 3) for j in (2, 5, 10, 30)] == [0.956, 0.888, 0.830, 0.729]


def test_a_failed_check_fails_the_study(tmp_path, capsys):
    from validation import checks as ck

    good = ck.within("force", 1.004, 1.0, 0.01)
    bad = ck.within("force", 1.03, 1.0, 0.01)
    assert good.passed and not bad.passed
    assert ck.finish("demo", [good], tmp_path) == 0
    assert ck.finish("demo", [good, bad], tmp_path) == 1
    assert ck.finish("demo", [], tmp_path) == 1          # asserting nothing is no pass
    assert capsys.readouterr().out.rstrip().endswith("demo: FAIL (0/0 checks)")
    assert (tmp_path / "checks.json").exists()


def test_a_study_that_cannot_run_here_is_skipped_not_passed(monkeypatch, capsys):
    # run_all counts a study that exits 2 with a SKIPPED line (a peer program
    # missing) apart: the run then fails only on the studies that failed
    from validation import run_all

    outcomes = {"calculix_pair": (2, "calculix_pair: SKIPPED (ccx not found)", 0.1),
                "corner_gaps": (0, "corner_gaps: PASS (3/3 checks)", 0.1),
                "two_pair": (2, "two_pair: FAIL (exit status 2; see log)", 0.1)}
    monkeypatch.setattr(run_all, "run_study", lambda name, out, quick: outcomes[name])
    assert run_all.main(["--only", "calculix_pair,corner_gaps"]) == 0
    assert capsys.readouterr().out.rstrip().endswith("1 passed, 0 failed, 1 skipped")
    assert run_all.main(["--only", "calculix_pair,two_pair"]) == 1   # a crash is no skip
    assert capsys.readouterr().out.rstrip().endswith("0 passed, 1 failed, 1 skipped")


def test_a_study_without_its_summary_line_fails(monkeypatch, tmp_path, capsys):
    # a study that exits 0 without reporting its checks has checked nothing: it was
    # listed as FAIL and yet counted as passed
    import subprocess

    from validation import run_all

    monkeypatch.setattr(subprocess, "run", lambda *a, **k: subprocess.CompletedProcess(
        a[0], 0, stdout='{"figure": 1.0}\n', stderr=""))
    assert run_all.main(["--only", "corner_gaps", "--out", str(tmp_path)]) == 1
    out = capsys.readouterr().out.rstrip()
    assert "corner_gaps: FAIL (exit status 0, no summary line" in out
    assert out.endswith("0 passed, 1 failed, 0 skipped")


def test_every_checked_study_is_run_or_said_why_not(tmp_path):
    # A study that asserts figures (ck.finish) is in `make validate` or in its list
    # of studies left out with the reason; each study listed takes --quick when
    # run_all passes it and exists as a script.
    from pathlib import Path

    from validation import run_all

    folder = Path(run_all.__file__).parent
    checked = {f.stem for f in folder.glob("*.py") if "ck.finish(" in f.read_text()}
    listed = set(run_all.STUDIES) | set(run_all.LEFT_OUT)
    assert checked <= listed, sorted(checked - listed)
    for name in run_all.STUDIES:
        text = (folder / f"{name}.py").read_text()
        argv = run_all.study_argv(name, tmp_path, quick=True)
        assert ("--quick" in argv) == ('"--quick"' in text), name
