"""Friction's cost: nothing when it is off, no re-projections it does not need, and
the four bad inputs of the friction keys refused by ``solve`` in one line.

Timings are the benchmarks' (``validation/bench_static.py``,
``validation/bench_dynamic.py``); these tests hold the properties the timings rest
on, by counts, not by the clock.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

import fe_impact.contact.friction as friction
import fe_impact.solvers.dynamic as dynamic
import fe_impact.solvers.static as static
from fe_impact.cli.main import main
from fe_impact.fe.casefile import write_case
from fe_impact.fe.mesh import load_mesh
from tests.test_bad_inputs import changed, sdof, solve
from validation.impact_cases import sphere_block_case, sphere_impact_case

MESHES = Path(__file__).resolve().parents[1] / "meshes"
COARSE = MESHES / "hertz_coarse_p1.msh"


def _refuse(*_args, **_kwargs):
    raise AssertionError("friction work in a frictionless run")


@pytest.fixture
def no_friction_work(monkeypatch):
    """Every entry of the friction's work raises: the law, the slip Jacobians and
    frames, the frictional problem, the integrators' friction objects."""
    for name in ("solve_frictional", "relative_jacobian", "slip_jacobians", "tangent_frames",
                 "return_mapping", "local_law", "ExplicitFriction", "ImplicitFriction"):
        monkeypatch.setattr(friction, name, _refuse)
    monkeypatch.setattr(static, "solve_frictional", _refuse)
    monkeypatch.setattr(dynamic, "ExplicitFriction", _refuse)
    monkeypatch.setattr(dynamic, "ImplicitFriction", _refuse)


@pytest.mark.parametrize("integrator", ["newmark", "explicit"])
def test_frictionless_impact_does_no_friction_work(no_friction_work, integrator):
    # friction off costs nothing: no slip rows, frames or frictional solves are made
    case = sphere_impact_case(COARSE, 1.0, 3e-6, integrator=integrator, frames=1)
    solver = dynamic.DynamicSolver(case, load_mesh(COARSE))
    result = solver.run()
    assert result.info["steps"] > 0
    assert solver.friction is None and not solver.contact.friction
    assert solver.contact.slip_tolerance is None and not hasattr(solver.contact, "Bt")


def test_frictionless_static_solve_does_no_friction_work(no_friction_work):
    case = sphere_block_case(COARSE, (-2e-6, -4e-6))
    result = static.StaticSolver(case, load_mesh(COARSE), stress=False).run()
    assert result.steps[-1].contact_force[0] > 0.0


def test_friction_on_a_normal_impact_reprojects_as_often_as_without():
    # The re-projections follow the zone's deformation, as without friction, and the
    # rows' slide along their master faces, which a normal impact hardly has (its
    # radial slip is the Poisson mismatch of like materials: none): so the same
    # count. Held to the slide tolerance alone, the deformation re-projected the
    # bench_dynamic impact 21 times instead of 4.
    case = sphere_impact_case(COARSE, 1.0, 12e-6, frames=1)
    rough = replace(case, contacts=(replace(case.contacts[0], mu_static=0.05,
                                            mu_dynamic=0.02),))
    counts = []
    for c in (case, rough):
        solver = dynamic.DynamicSolver(c, load_mesh(COARSE))
        result = solver.run()
        counts.append(result.info["projections"])
        assert result.measurements.peak_force > 0.0
    assert solver.contact.slip_tolerance < solver.contact.tolerance
    assert counts[1] == counts[0], counts


CONTACT = 'master = "lower_top"\n'


def _rough(text: str, keys: str) -> str:
    return changed(text, CONTACT, CONTACT + keys + "\n")


BAD = [
    ("negative mu", solve(_rough(sdof(), "friction = -0.1")),
     ["[contacts[0]] friction = -0.1", "in [0.0, 5.0]"]),
    ("NaN mu", solve(_rough(sdof(), "friction = nan")),
     ["[contacts[0]] friction = nan", "must be a number in [0.0, 5.0]"]),
    ("static below dynamic", solve(_rough(sdof(), "mu_static = 0.02\nmu_dynamic = 0.05")),
     ["[contacts[0]] mu_static = 0.02", "at least mu_dynamic = 0.05"]),
    ("zero transition speed",
     solve(_rough(sdof(), "mu_static = 0.05\nmu_dynamic = 0.02\ntransition_speed = 0.0")),
     ["[contacts[0]] transition_speed = 0.0", "(0.0, 10000.0]", "m/s"]),
    ("explicit step that cannot resolve stick", lambda d: ["solve", str(_stick_case(d)),
                                                            "--out", "OUT"],
     ["[contacts[0]] friction (mu_static = 0.3)", "[analysis] time_step = ",
      "cannot resolve stick", "(the tangential penalty) is", 'time_step = "auto"']),
]


def _stick_case(folder: Path) -> Path:
    """The coarse explicit impact with mu = 0.3 and a time step between the stable
    limits of the normal contact and of the stick (the tangential springs), written
    as a case file."""
    case = sphere_impact_case(COARSE, 1.0, 1e-6, integrator="explicit")
    rough = replace(case, contacts=(replace(case.contacts[0], mu_static=0.3, mu_dynamic=0.3),))
    dt_normal = dynamic.DynamicSolver(case, load_mesh(COARSE)).dt_stable
    dt_stick = dynamic.DynamicSolver(rough, load_mesh(COARSE)).dt_stable
    assert dt_stick < dt_normal
    bad = replace(rough, analysis=replace(rough.analysis, time_step=0.5 * (dt_stick + dt_normal)))
    return write_case(bad, folder / "case.toml")


@pytest.mark.parametrize("build,words", [pytest.param(b, w, id=n) for n, b, w in BAD])
def test_bad_friction_input_gets_one_clear_line(tmp_path, capsys, build, words):
    argv = [str(tmp_path / "out") if a == "OUT" else a for a in build(tmp_path)]
    made = sorted(tmp_path.rglob("*"))
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    errors = [line for line in err.splitlines() if line.startswith("fe-impact")]
    assert len(errors) == 1 and ": error: " in errors[0], err
    for w in words:
        assert w in errors[0], (w, errors[0])
    assert not (tmp_path / "out").exists()
    assert sorted(tmp_path.rglob("*")) == made
