"""Every script of ``examples/`` runs as shipped and its figure or number holds.

Each example is run with :func:`runpy.run_path` (as scikit-fem's
``tests/test_examples.py`` imports its ``docs/examples``), writing into one
folder for the module, and its namespace is checked against an independent
truth: a closed form, or an inequality the mechanics imposes. The calibration
examples keep their work under ``if __name__ == "__main__":`` (Dask's workers
import the script again) and are run by calling their ``main()``. The
switching example finds the calibration the calibration example left in the
folder (tests of a file run in order on one worker: ``--dist loadfile``).
"""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SCRIPTS = sorted(p.name for p in EXAMPLES.glob("plot_*.py"))


@pytest.fixture(scope="module")
def out(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("examples")


def run(name: str, out: Path, monkeypatch, main: bool = False) -> dict:
    """The example's namespace after running it in ``out``; with ``main``, its
    ``main()`` called and its result under ``"result"``."""
    monkeypatch.setenv("FE_IMPACT_EXAMPLES_OUT", str(out))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    ns = runpy.run_path(str(EXAMPLES / name), run_name="example" if main else "__main__")
    if main:
        ns["result"] = ns["main"]()
    figure = out / name.replace(".py", ".png")
    assert figure.is_file() and figure.stat().st_size > 10_000, f"{name}: no figure"
    return ns


def test_every_example_is_tested():
    tested = {"plot_hertz_sphere.py", "plot_user_gearset.py", "plot_tooth_impact.py",
              "plot_calibrate_stage.py", "plot_switching_run.py"}
    assert set(SCRIPTS) == tested


def test_every_example_shows_its_committed_figure():
    # the gallery renders the scripts without running them: each shows its figure
    docs = EXAMPLES.parent / "docs" / "images" / "examples"
    for name in SCRIPTS:
        text = (EXAMPLES / name).read_text()
        png = name.replace(".py", ".png")
        assert f"../images/examples/{png}" in text, name
        assert (docs / png).is_file(), f"docs/images/examples/{png} is not committed"


def test_hertz_sphere(out, monkeypatch):
    ns = run("plot_hertz_sphere.py", out, monkeypatch)
    a_fe, a_hertz, h = ns["a_fe"], ns["a_hertz"], ns["h"]
    # The contact radius from the area of the loaded nodes places the contact's
    # edge to within half an element: |a - a_Hertz| <= h/2 + 1% of a (the static
    # Hertz study's RADIUS_SLACK, docs/tolerances.md), checked where a spans two
    # elements or more, as that study does (the first steps span 1.1-2).
    resolved = a_hertz >= 2.0 * h
    assert resolved.sum() >= 2
    err = np.abs(a_fe - a_hertz)[resolved]
    assert np.all(err <= 0.5 * h + 0.01 * a_hertz[resolved]), (a_fe, a_hertz)


def test_user_gearset(out, monkeypatch):
    ns = run("plot_user_gearset.py", out, monkeypatch)
    gearset, rows, torque = ns["gearset"], ns["rows"], ns["torque"]
    assert [r["teeth"] for r in rows] == [60, 80]
    for row in rows:
        # The pitch radius of a face gear is m N / 2, and at the pitch point the
        # normal force acts on the lever r_2 cos(alpha) about the face gear's axis
        # (the base radius of the generating shaper's rack, Litvin 2004, ch. 19),
        # shared by the n_pinions meshes: F = T / (n_p r_2 cos alpha). Tolerance
        # 0.1%: the contact analysis places the pitch-point contact at r_2 within
        # a fraction of the crowning's 10 um over the 75-100 mm radii.
        r2 = 2.5e-3 * row["teeth"] / 2.0
        assert row["face_width"]["pitch_radius_m"] == pytest.approx(r2, rel=1e-12)
        force = torque / (gearset.n_pinions * r2 * np.cos(np.radians(20.0)))
        assert row["pitch_point"]["normal_force_N"] == pytest.approx(force, rel=1e-3)


@pytest.mark.slow   # meshing and a transient FE impact: some 18 s of CPU
def test_tooth_impact(out, monkeypatch):
    ns = run("plot_tooth_impact.py", out, monkeypatch)
    closed, rigid, f_rigid, m = ns["a"].impact, ns["rigid"], ns["f_rigid"], ns["m"]
    # The example's integration of m delta'' = -K delta^1.5 against Hertz's closed
    # form of the same impact (Johnson 1985, 11.4): the peak sampled every
    # t_c/500 is low by (pi/500)^2/8 ~ 5e-6, the separation located to rtol 1e-9.
    assert f_rigid.max() == pytest.approx(closed.force_max, rel=1e-4)
    assert rigid.t[-1] == pytest.approx(closed.contact_time, rel=1e-4)
    # The teeth bend as well as flatten: a compliance in series with the contact
    # lowers the peak force and lengthens the contact of the same mass and speed.
    assert m.peak_force < closed.force_max
    assert m.contact_duration > closed.contact_time


@pytest.mark.slow   # a Dask worker, meshing, an FE impact and the fit: some 27 s of CPU
def test_calibrate_stage(out, monkeypatch):
    ns = run("plot_calibrate_stage.py", out, monkeypatch, main=True)
    record = ns["result"].cases[0]
    law, closed = record.impact, record.closed_form
    # Bending (linear) in series with Hertz's contact (exponent 1.5): the fitted
    # exponent lies between, and at the FE's maximum approach the pair carries
    # less force than the contact alone would.
    assert 1.0 < law.exponent < 1.5
    assert record.fe.peak_force < closed.k * record.fe.max_approach ** 1.5
    assert (out / "calibration" / "report.md").is_file()


def test_switching_run(out, monkeypatch):
    ns = run("plot_switching_run.py", out, monkeypatch, main=True)
    runs = ns["result"]
    for run_ in runs.values():
        ev = run_.events
        # no load at 300 r/min: the teeth rattle in the backlash (seed Table 1)
        assert len(ev.time) > 10
        assert np.all(np.diff(ev.time) >= 0.0) and ev.time[-1] <= 5.0
        assert np.all(ev.force > 0.0)
