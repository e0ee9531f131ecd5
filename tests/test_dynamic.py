"""Transient solver: closed-form single-DOF impacts, a coarse Hertz impact, the CLI,
robustness and the dynamic case-file keys."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from fe_impact.cli.main import main
from fe_impact.errors import CaseError, SolverError
from fe_impact.fe.case import Case, load_case
from fe_impact.fe.casefile import write_case
from fe_impact.fe.linalg import inverse_from_cholesky
from fe_impact.fe.mesh import load_mesh
from fe_impact.physics import hertz
from fe_impact.solvers.dynamic import DynamicSolver
from validation.impact_cases import (
    NU,
    RHO,
    E,
    R,
    sphere_block_mesh,
    write_sdof,
    write_sphere_impact,
)

# Rigid 1 mm cube (10 g rigid mass + 7.86 mg of cube) on a 1e18 Pa/m penalty over
# 1 mm^2: a linear spring k = 1e12 N/m. Closed form: half-sine contact.
PENALTY, MASS, SPEED, SIZE = 1e18, 0.01, 1.0, 1e-3
K_SPRING = PENALTY * SIZE ** 2
M_TOTAL = MASS + RHO * SIZE ** 3
OMEGA = math.sqrt(K_SPRING / M_TOTAL)
T_CONTACT = math.pi / OMEGA
F_PEAK = SPEED * math.sqrt(K_SPRING * M_TOTAL)
GAP = 1e-8
DURATION = GAP / SPEED + 2.0 * T_CONTACT


def solver_for(case: Case) -> DynamicSolver:
    """The transient solver on the case's mesh file."""
    return DynamicSolver(case, load_mesh(case.mesh_file, case.unit))


def sdof_case(folder, integrator, dt, **analysis) -> Case:
    """The SDOF case file, read back; ``analysis`` changes its [analysis] fields."""
    case = load_case(write_sdof(folder, integrator, dt, DURATION, PENALTY, MASS, SPEED,
                                size=SIZE, gap=GAP))
    return replace(case, analysis=replace(case.analysis, **analysis))


def run_sdof(folder, integrator, dt, **analysis):
    solver = solver_for(sdof_case(folder, integrator, dt, **analysis))
    return solver, solver.run()


@pytest.mark.parametrize("integrator", ["newmark", "explicit"])
def test_sdof_contact_time_converges_second_order(tmp_path, integrator):
    """Contact time of the half-sine against pi/omega at dt = tc/16, /32, /64."""
    errors = []
    for n in (16, 32, 64):
        _, result = run_sdof(tmp_path, integrator, T_CONTACT / n)
        errors.append(abs(result.measurements.contact_duration / T_CONTACT - 1.0))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    # Both schemes are second order; the contact switch falls inside a step, which
    # the interpolated first touch and separation recover to O(dt^2).
    assert np.all(orders > 1.8), (errors, orders)
    assert errors[-1] < 5e-4


@pytest.mark.parametrize("integrator", ["newmark", "explicit"])
def test_sdof_contact_time_is_the_schemes_period_error(tmp_path, integrator):
    """The half-sine lasts half the period each scheme gives a linear oscillator.

    Average acceleration: omega~ dt = 2 atan(omega dt / 2), the period grows by
    (omega dt)^2 / 12; central difference: omega~ dt = 2 asin(omega dt / 2), it
    shrinks by (omega dt)^2 / 24. At dt = tc/64 these are +2.0e-4 and -1.0e-4;
    the contact is then solved implicitly (Newmark) or explicitly, and a
    Newmark step that treated the contact explicitly would show -1.0e-4. The
    interpolated first touch and separation add much less (measured within
    0.5% of the closed form), hence the 5% tolerance.
    """
    dt = T_CONTACT / 64
    x = OMEGA * dt
    if integrator == "newmark":
        expected = x / (2.0 * math.atan(x / 2.0)) - 1.0
    else:
        expected = x / (2.0 * math.asin(x / 2.0)) - 1.0
    _, result = run_sdof(tmp_path, integrator, dt)
    error = result.measurements.contact_duration / T_CONTACT - 1.0
    assert error == pytest.approx(expected, rel=0.05)


@pytest.mark.parametrize("integrator", ["newmark", "explicit"])
def test_sdof_energy_restitution_and_peak(tmp_path, integrator):
    """Energy table of one integrator at dt = tc/64 against the conservative closed form."""
    solver, result = run_sdof(tmp_path, integrator, T_CONTACT / 64)
    m, h = result.measurements, result.history
    e_end = abs(h["total_energy"][-1] / h["total_energy"][0] - 1.0)
    # Undamped linear spring: restitution 1 and no energy change after separation.
    # Measured drift is ~5e-6; 5e-5 leaves room for the switch steps.
    assert abs(m.restitution - 1.0) < 5e-5
    assert e_end < 5e-5
    # During contact the penalty switch inside a step costs O(dt) energy while it
    # lasts (measured 5.6e-4 at tc/64); it is returned at separation.
    assert m.energy_error < 1e-3
    # Peak force and approach are sampled at the steps: (pi/64)^2/8 = 3e-4 error.
    assert m.peak_force == pytest.approx(F_PEAK, rel=1e-3)
    assert m.max_approach == pytest.approx(SPEED / OMEGA, rel=1e-3)


@pytest.mark.parametrize("integrator", ["newmark", "explicit"])
def test_run_stops_after_separation(tmp_path, integrator):
    """``stop_after_separation = 0.25`` ends the run a quarter contact after separation.

    The rebound velocity is momentum over mass, constant once the force has
    vanished, so the measurements equal those of the full run; the end time is
    separation + 0.25 t_c within a step.
    """
    dt = T_CONTACT / 64
    _, full = run_sdof(tmp_path / "full", integrator, dt)
    _, short = run_sdof(tmp_path / "short", integrator, dt, stop_after_separation=0.25)
    m = short.measurements
    assert short.info["end_time"] == pytest.approx(
        m.separation + 0.25 * m.contact_duration, abs=1.5 * dt)
    assert short.info["end_time"] < 0.8 * full.info["end_time"]
    for key in ("peak_force", "contact_duration", "restitution"):
        assert getattr(m, key) == pytest.approx(getattr(full.measurements, key), rel=1e-9)


def test_explicit_stable_step_matches_closed_form(tmp_path):
    solver, _ = run_sdof(tmp_path, "explicit", T_CONTACT / 16)
    # One DOF: the limit is exactly 2 / omega.
    assert solver.dt_stable == pytest.approx(2.0 / OMEGA, rel=1e-9)


def test_explicit_step_above_limit_is_refused(tmp_path):
    case = sdof_case(tmp_path, "explicit", 3.0 / OMEGA)
    with pytest.raises(CaseError, match=r"time_step = 3\.001e-07 s is above the explicit "
                                        r"stability limit 2\.001e-07 s"):
        solver_for(case)


def test_energy_growth_stops_the_run_and_keeps_frames(tmp_path, capsys):
    """A tiny energy_limit makes the switch-step energy change count as growth."""
    case = sdof_case(tmp_path, "explicit", T_CONTACT / 8, energy_limit=1e-9,
                     output_interval=1e-9)
    with pytest.raises(SolverError, match=r"energy grew to .* at t = .* \(step \d+\)"):
        solver_for(case).run()
    out = tmp_path / "out"
    path = write_case(case, tmp_path / "energy.toml")
    assert main(["solve", str(path), "--out", str(out)]) == 2
    assert "energy grew" in capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "stopped" and "energy grew" in summary["error"]
    assert (out / "impact.pvd").exists() and summary["fields"]["frames"]


def test_cli_dynamic_outputs(tmp_path):
    case = sdof_case(tmp_path, "newmark", T_CONTACT / 32, output_interval=DURATION / 10)
    out = tmp_path / "out"
    path = write_case(case, tmp_path / "frames.toml")
    assert main(["solve", str(path), "--out", str(out)]) == 0
    s = json.loads((out / "summary.json").read_text())
    for key in ("peak_force", "max_approach", "contact_duration", "restitution",
                "energy_error"):
        assert s[key] is not None, key
    assert set(s["history"]) >= {"time", "contact_force", "approach", "kinetic_energy",
                                 "strain_energy", "contact_energy"}
    assert len(s["history"]["time"]) == 11   # t = 0 and ten output intervals
    assert s["peak_force"] == pytest.approx(F_PEAK, rel=2e-3)
    header = (out / "history.csv").read_text().splitlines()[0]
    assert header.startswith("time [s],contact_force [N],approach [m]")
    pvd = (out / "impact.pvd").read_text()
    assert pvd.count("<DataSet") == 11
    assert (out / "force.png").stat().st_size > 1000


def test_coarse_hemisphere_impact_against_hertz(tmp_path):
    """Hemisphere R = 10 mm tied to a 0.5 kg rigid mass hits a block at 1 m/s (Newmark).

    Against the quasi-static impact on the same mesh (the static solver's
    force-displacement curve of this specimen, integrated for the same mass:
    ``validation/hertz_impact.py``'s specimen reference), which takes the
    finite specimen's stiffness and the coarse mesh's error out of the
    comparison. The contact lasts about 100 times a wave's transit through
    the hemisphere and Newmark's period error at t_c/50 is ~0.1%, so the
    transient must match within 1% (measured 0.5% / 0.3% / 0.3%). Hertz
    (m = 0.5 kg + the hemisphere's 16.5 g) is within 5%: the specimen is
    about 3% stiffer than two half-spaces.
    """
    from fe_impact.fe.mesh import load_mesh
    from validation.hertz_impact import specimen_impact
    from validation.impact_cases import sphere_impact_case

    mesh = sphere_block_mesh(tmp_path, 0.2e-3, gap=1e-6)
    m = 0.5 + 2.0 / 3.0 * math.pi * R ** 3 * RHO
    ref = hertz.impact(m, 1.0, R, hertz.effective_modulus(212e9, 0.289))
    case = sphere_impact_case(mesh, 1.0, 1.4 * ref.contact_time, rigid_mass=0.5, frames=10)
    solver = DynamicSolver(case, load_mesh(mesh))
    meas = solver.run().measurements
    spec = specimen_impact(mesh, m, 1.0, solver.initial_gap, ref.delta_max)
    assert 4.0 * meas.peak_force == pytest.approx(spec["peak_force"], rel=0.01)
    assert meas.max_approach == pytest.approx(spec["max_approach"], rel=0.01)
    assert meas.contact_duration == pytest.approx(spec["contact_time"], rel=0.01)
    assert 4.0 * meas.peak_force == pytest.approx(ref.force_max, rel=0.05)
    # Elastic impact: only wave loss (Hunter: 0.6% of the energy at 1 m/s for a
    # free sphere; far less with a rigid mass behind it) and integrator error.
    assert 0.99 < meas.restitution <= 1.0 + 1e-3
    assert meas.energy_error < 1e-3


def test_contact_zone_grows_before_faces_outside_touch(tmp_path):
    """A search distance far below the approach: the zone must grow during the impact.

    The coarse hemisphere impact with a 2 um search distance (the approach is
    about 20 um) starts from a zone of a few faces. Faces outside are watched
    through linearised gaps and join before they touch, so the run must give
    the same impact as with the automatic zone: the penalty LCP is exact for
    the linearised gaps either way, and only the re-projection points differ
    (measured: nine growths; peak force -0.014%, approach and contact time
    within 0.01%). The tolerance, 7x the peak-force difference, catches the
    zone edge cutting the supports of the nodes on it (their weighted gaps
    then integrate over part of their faces): that gave +0.23%.
    """
    mesh = sphere_block_mesh(tmp_path, 0.2e-3, gap=1e-6)
    m = 0.5 + 2.0 / 3.0 * math.pi * R ** 3 * RHO
    ref = hertz.impact(m, 1.0, R, hertz.effective_modulus(212e9, 0.289))
    auto = load_case(write_sphere_impact(tmp_path, mesh, 1.0, 1.4 * ref.contact_time,
                                         rigid_mass=0.5, frames=10))
    (contact,) = auto.contacts
    small = replace(auto, contacts=(replace(contact, search_distance=2e-6),))
    fe_mesh = load_mesh(mesh)
    runs = {name: DynamicSolver(case, fe_mesh).run()
            for name, case in (("auto", auto), ("small", small))}
    small, auto = runs["small"], runs["auto"]
    assert small.info["zone_growths"] >= 1
    assert auto.info["zone_growths"] == 0
    for key in ("peak_force", "max_approach", "contact_duration"):
        assert getattr(small.measurements, key) == pytest.approx(
            getattr(auto.measurements, key), rel=1e-3)


def test_normal_condensation_is_exact_on_a_flat_master(tmp_path):
    """Newmark keeps one (normal) coordinate per zone node in the gap Jacobian.

    Against a flat master every gap row moves its nodes along the master normal
    (for the slave nodes too, though the sphere's own normal tilts by up to
    r/R), so the frames must find that normal and the projection must drop
    nothing: the projected Jacobian equals the full one to rounding.
    """
    mesh = sphere_block_mesh(tmp_path, 0.2e-3, gap=1e-6)
    case = write_sphere_impact(tmp_path, mesh, 1.0, 1e-5, rigid_mass=0.5, frames=2)
    solver = DynamicSolver(load_case(case), load_mesh(mesh))
    c = solver.contact
    full, projected = c.B_full.toarray(), c.B.toarray()
    assert np.abs(projected - full).max() < 1e-9 * np.abs(full).max()
    # One condensed coordinate per zone node, except the nodes on the symmetry
    # planes, which keep their free components unrotated.
    assert len(solver.condensed.coordinates) < 0.5 * 3 * len(solver.zone.points())


DYNAMIC_BAD = [
    ('duration = ', '# duration = ', r"missing key\(s\) \['duration'\]"),
    ('integrator = "newmark"', 'integrator = "leapfrog"',
     r"integrator = 'leapfrog'.*\['newmark', 'explicit'\]"),
    ('motion = "translation"', 'motion = "screw"', r"motion = 'screw'.*translation"),
    ('direction = [0.0, 0.0, 1.0]', 'direction = [0.0, 0.0, 0.0]',
     r"direction = \[0.0, 0.0, 0.0\]: must be a non-zero vector"),
    ('direction = [0.0, 0.0, 1.0]', 'direction = [0.0, 1.0]', r"three numbers"),
    ('type = "dynamic"', 'type = "dynamic"\nhht_alpha = -0.5', r"hht_alpha = -0.5.*HHT"),
    ('type = "dynamic"', 'type = "dynamic"\nplastic_solver = "bfgs"',
     r"plastic_solver = 'bfgs'.*\['newton', 'anderson'\]"),
    ('integrator = "newmark"', 'integrator = "explicit"\nplastic_solver = "newton"',
     r"plastic_solver = 'newton'.*newmark"),
    ('inertia = 0.01', 'inertia = -1', r"inertia = -1.*kg"),
    ('time_step = ', 'time_step = 1.0 #', r"time_step = 1.0.*at most the duration"),
    ('[analysis]', '[[displacements]]\nsurface = "upper_all"\ncomponent = "z"\nvalues = [1e-6]'
     '\n[analysis]', r"\[\[displacements\]\] apply to static analysis"),
    ('type = "dynamic"', 'type = "static"',
     r"inertia and initial_velocity need \[analysis\] type = \"dynamic\""),
]


@pytest.mark.parametrize("old,new,pattern", DYNAMIC_BAD)
def test_dynamic_case_errors(tmp_path, old, new, pattern):
    # A reader test: the SDOF case file as text (tests/test_bad_inputs.py), broken on purpose.
    from tests.test_bad_inputs import sdof

    text = sdof(time_step=1e-9, duration=1e-7)
    assert old in text, old
    if new.startswith('type = "static"'):
        text = "\n".join(line for line in text.splitlines()
                         if not line.startswith(("integrator", "duration", "time_step")))
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace(old, new))
    with pytest.raises(CaseError, match=pattern):
        load_case(bad)


def test_rigid_body_clashing_with_support_is_refused(tmp_path):
    case = sdof_case(tmp_path, "newmark", 1e-9, duration=1e-7)
    (support,) = case.supports
    bad = replace(case, supports=(replace(support, surface="upper_all"),))
    with pytest.raises(CaseError, match=r"moves \d+ DOFs that \[\[supports\]\] fix"):
        solver_for(bad)


def test_residual_indentation_of_a_synthetic_unloading():
    # Thornton-like history: Hertz loading to d_max, Hertz unloading to a permanent
    # approach d_p, sampled in 200 steps. F^(2/3) is linear in d on that curve, so
    # the extrapolation recovers d_p to round-off (1e-6 of a step asked; the last
    # loaded step itself is 0.73-0.88 steps off here); an elastic history
    # (d_p = 0) gives zero.
    from fe_impact.solvers.dynamic import impact_measurements

    for d_p in (0.0, 2e-6):
        t = np.linspace(0.0, 1.0, 201)
        d_max = 5e-6
        d = d_max * np.sin(np.pi * t) - 1e-7                  # approach, closes then opens
        d = np.where(t > 0.5, d_p + (d_max - d_p) * np.sin(np.pi * t) - 1e-7, d)
        base = np.where(t > 0.5, d_p, 0.0)
        F = 1e10 * np.clip(d - base, 0.0, None) ** 1.5
        hist = {"time": t, "contact_force": F, "approach": d,
                "normal_velocity": np.gradient(-d, t), "total_energy": np.ones_like(t)}
        m = impact_measurements(hist, 0.0)
        step = np.abs(np.diff(d)).max()
        assert abs(m.residual_indentation - d_p) < 1e-6 * step
        # when nothing yielded there is no dent, whatever the history's tail
        assert impact_measurements(hist, 0.0, plastic=False).residual_indentation == 0.0


def test_a_touch_at_first_contact_is_not_a_separation():
    # A force for one step while the approach is still just below zero (a node
    # touching before the probe has closed), then none: the bodies have not been
    # pressed together, so the run must not stop there. After a real contact
    # (positive approach) they are apart once the approach is negative again for
    # the given fraction of the contact's duration.
    from fe_impact.solvers.measurements import SeparationWatch

    watch = SeparationWatch(0.25)
    assert not watch.apart(0.0, 5.0, -1e-9)
    assert not watch.apart(1.0, 0.0, -5e-10)
    assert not watch.apart(2.0, 0.0, 1e-9)
    for t in range(3, 11):
        assert not watch.apart(float(t), 100.0, 1e-6)
    # contact from t = 0 to 10: apart 2.5 after the last step with a force
    assert not watch.apart(11.0, 0.0, 1e-7)       # no force, but still pressed in
    assert not watch.apart(12.0, 0.0, -1e-8)      # 2 < 0.25 x 10
    assert watch.apart(12.5, 0.0, -1e-8)
    assert not SeparationWatch(None).apart(1.0, 0.0, -1.0)


def test_no_contact_has_no_time_of_peak_force():
    from fe_impact.solvers.dynamic import impact_measurements

    t = np.linspace(0.0, 1.0, 11)
    hist = {"time": t, "contact_force": np.zeros_like(t), "approach": -1e-6 + 0 * t,
            "normal_velocity": 0 * t, "total_energy": np.ones_like(t)}
    m = impact_measurements(hist, 0.0)
    assert m.peak_force == 0.0 and m.time_of_peak_force is None and m.contacts == 0


def test_history_cut_to_the_steps_every_quantity_has():
    # A stop signal can land while a step's row is being appended: the history
    # then ends at the last complete step, so the measurements index it safely.
    from fe_impact.solvers.dynamic import HISTORY_KEYS, _RunLog
    from fe_impact.solvers.measurements import SeparationWatch, impact_measurements

    log = _RunLog(SeparationWatch(None))
    t = np.linspace(0.0, 1.0, 11)
    force = np.maximum(np.sin(np.pi * t / 0.6), 0.0) * (t < 0.6)
    for i, ti in enumerate(t):
        row = dict.fromkeys(HISTORY_KEYS, 1.0)
        row.update(time=ti, contact_force=force[i], approach=force[i] - 1e-9,
                   normal_velocity=-1.0 if ti < 0.3 else 0.5)
        for k, v in row.items():
            log.rows[k].append(v)
    log.rows["time"].append(1.1)                  # the interrupted step's first entries
    log.rows["contact_force"].append(0.0)
    h = log.history()
    assert {len(v) for v in h.values()} == {11}
    assert impact_measurements(h, 0.0).rebound_velocity == 0.5


def _newmark_sphere_impact(tmp_path):
    """The coarse sphere at 1 m/s on a 0.5 kg rigid mass, Newmark at t_c / 20: its
    case and mesh file (the factorisation tests below)."""
    mesh = sphere_block_mesh(tmp_path, 0.2e-3, gap=1e-6)
    ref = hertz.impact(0.5, 1.0, R, hertz.effective_modulus(E, NU))
    return load_case(write_sphere_impact(tmp_path, mesh, 1.0, 1e-6 + 1.2 * ref.contact_time,
                                         rigid_mass=0.5, time_step=ref.contact_time / 20,
                                         frames=2)), mesh


def test_plain_factorisation_taking_the_solves_over_changes_nothing(tmp_path):
    """The Newmark solves go through the Schur-complement factorisation of the
    rotated step matrix, then (after ``schur_solves``) through a plain one: the
    impact is the same to round-off whichever serves them (both are backward
    stable on the same SPD matrix; 1e-9 of the peak leaves the round-off of ~30
    steps, about 1e-12, a wide margin)."""
    case, mesh = _newmark_sphere_impact(tmp_path)
    runs = []
    for schur_solves in (None, 7):
        solver = DynamicSolver(case, load_mesh(mesh))
        if schur_solves is not None:
            solver.condensed.solver.schur_solves = schur_solves
        runs.append((solver, solver.run()))
    (first, a), (second, b) = runs
    assert first.condensed.solver._plain is None
    assert second.condensed.solver._plain is not None
    assert a.measurements.peak_force > 0
    for key in ("contact_force", "approach", "kinetic_energy"):
        scale = np.abs(a.history[key]).max()
        np.testing.assert_allclose(b.history[key], a.history[key], rtol=0, atol=1e-9 * scale)


def test_step_by_one_pass_over_the_zone_factor_equals_the_step_by_two_solves(tmp_path):
    """While the zone's Cholesky factor serves, a step's condensed solution is
    ``L^-T (L^-1 y_c + f W lambda)`` with ``W = L^-1 B_c^T`` (one triangular pass
    each way) instead of two solves with the zone's Schur complement: the same
    arithmetic regrouped, so the forces and the displacement agree to round-off
    (1e-9 of their largest, as the factorisations' comparison above), on two steps
    in contact."""
    case, mesh = _newmark_sphere_impact(tmp_path)
    solver = DynamicSolver(case, load_mesh(mesh))
    states = []

    def in_contact(state, row):   # the steps up to the third in contact
        states.append(state)
        return sum(r > 0.0 for r in solver.log.rows["contact_force"]) == 3

    solver.run(step_hook=in_contact)
    condensed, nm = solver.condensed, solver.scheme
    assert condensed.solver.partial and condensed.compliance.W is not None
    c0, c1 = 1.0 / (nm.beta * nm.dt ** 2), 1.0 / (nm.beta * nm.dt)
    c2 = 1.0 / (2.0 * nm.beta) - 1.0
    touched = []
    for s in states[-2:]:
        rhs0 = nm.M @ (c0 * s.z + c1 * s.v + c2 * s.a) + nm.alpha * (
            nm.K @ s.z - s.f_plastic - s.f_contact)
        one = condensed._solve_partial(rhs0, s.active)
        two = condensed._solve_partial_solves(rhs0, s.active)
        touched.append(bool(one.lam.any()))
        np.testing.assert_allclose(one.z, two.z, rtol=0, atol=1e-9 * np.abs(two.z).max())
        np.testing.assert_allclose(one.lam, two.lam, rtol=0,
                                   atol=1e-9 * max(np.abs(two.lam).max(), 1e-30))
    assert touched == [True, True]


def test_step_linearisation_is_the_solves_derivative_on_either_factorisation(tmp_path):
    """The plastic Newton's products ``w -> dz`` (a Newmark step's response at a fixed
    active set) come from one forward and one backward substitution through the
    kept Schur factorisation, the zone's part by its Cholesky factor (one pass
    each way with the gap rows' ``L^-1 B^T``) or by its inverse (once formed),
    or from two solves once the plain factorisation serves. Each must be the
    derivative of the step's own contact solve: at a fixed active set the
    penalty LCP's solution is linear in the right-hand side, so a finite
    difference of two solves is exact to round-off (and the LCP solver's stop,
    1e-12 of the forces), checked to 1e-7; the three ways agree to 1e-9 (one
    backward-stable factorisation against another)."""
    case, mesh = _newmark_sphere_impact(tmp_path)
    solver = DynamicSolver(case, load_mesh(mesh))
    last = {"steps": 0}

    def in_contact(state, row):   # the third step in contact: loading, about 10 nodes on
        last["state"] = state
        last["steps"] += row["contact_force"] > 0.0
        return last["steps"] == 3

    solver.run(step_hook=in_contact)
    condensed, state = solver.condensed, last["state"]
    assert condensed.solver.partial
    nm, s = solver.scheme, state                   # the next step's right-hand side
    c0, c1 = 1.0 / (nm.beta * nm.dt ** 2), 1.0 / (nm.beta * nm.dt)
    c2 = 1.0 / (2.0 * nm.beta) - 1.0
    rhs0 = nm.M @ (c0 * s.z + c1 * s.v + c2 * s.a) + nm.alpha * (
        nm.K @ s.z - s.f_plastic - s.f_contact)
    base = condensed.solve(rhs0, s.active)
    assert base.lam.any()
    w = np.random.default_rng(1).standard_normal(len(state.z))
    w *= 1e-3 * np.linalg.norm(state.f_contact) / np.linalg.norm(w)   # keeps the active set
    assert condensed.compliance.W is not None                 # the Cholesky factor's way
    partial = condensed.linearisation(base.lam)(w)
    moved = condensed.solve(rhs0 + w, base.active)
    assert np.array_equal(moved.lam > 0, base.lam > 0)        # the same active set
    scale = np.abs(partial).max()
    assert np.abs((moved.z - base.z) - partial).max() < 1e-7 * scale
    zone = condensed.compliance                                # the inverse's way
    zone.G, zone.L, zone.W = inverse_from_cholesky(zone.L), None, None
    np.testing.assert_allclose(condensed.linearisation(base.lam)(w), partial, rtol=0,
                               atol=1e-9 * scale)
    condensed.solver.solves = condensed.solver.schur_solves   # the plain one takes over
    assert not condensed.solver.partial
    np.testing.assert_allclose(condensed.linearisation(base.lam)(w), partial, rtol=0,
                               atol=1e-9 * scale)
