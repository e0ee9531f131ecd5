"""Time integrators on a single-DOF spring column: HHT-alpha damping, plastic dissipation.

The spring column (meshes/spring_column.msh, see meshes/generate.py) is a
1 mm cube of linear tetrahedra with nodes at its corners only: bottom face
fixed, top face tied to a rigid mass moving along z. Every node is on the
top or the bottom face, so the displacement is exactly linear in z
(uniaxial strain) and the model has one degree of freedom q, the top's
displacement:

- stiffness k = (lambda + 2 mu) A / H (P1 reproduces the linear field);
- mass M = m + rho A H / 3 with the consistent mass (it integrates the
  square of the linear mode exactly), or m plus the HRZ-lumped masses of the
  top nodes (rho V_e / 4 per node and element) with the explicit scheme.

The stop cube above, 0.1 mm away, only gives the case its contact pair; the
column never comes near it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fe_impact.fe.case import (
    AnalysisSpec,
    Case,
    ContactSpec,
    MaterialSpec,
    RigidBodySpec,
    SupportSpec,
)
from fe_impact.fe.mesh import load_mesh
from fe_impact.solvers.dynamic import DynamicSolver
from meshes.generate import committed

E, NU, RHO = 212e9, 0.289, 7860.0
SIZE = 1e-3                      # edge of the column (m)
MASS = 0.01                      # rigid mass on top (kg)
LAME = E * NU / ((1 + NU) * (1 - 2 * NU))
SHEAR = E / (2 * (1 + NU))
K_COLUMN = (LAME + 2 * SHEAR) * SIZE          # N/m
M_CONSISTENT = MASS + RHO * SIZE**3 / 3.0     # kg
OMEGA = math.sqrt(K_COLUMN / M_CONSISTENT)    # rad/s
#: A small penalty: the stop is never touched, and the explicit stable-step
#: estimate (which assumes every zone node in contact) stays the column's.
PENALTY = 1e12


@pytest.fixture(scope="module")
def column():
    path = committed("spring_column.msh")
    return path, load_mesh(path)


def column_case(path: Path, integrator: str, time_step: float, duration: float,
                speed: float, yield_strength: float | None = None, **analysis) -> Case:
    """The column case; ``speed`` (m/s) is the rigid mass's initial velocity along -z."""
    return Case(
        path=path.with_suffix(".case"), mesh_file=path, unit="m",
        materials=(MaterialSpec(("column",), E, NU, RHO, yield_strength),
                   MaterialSpec(("stop",), E, NU, RHO)),
        contacts=(ContactSpec("stop_bottom", "column_top", penalty=PENALTY),),
        supports=(SupportSpec("column_bottom", (0, 1, 2)), SupportSpec("stop_all", (0, 1, 2))),
        rigid_bodies=(RigidBodySpec("column_top", "translation", (0.0, 0.0, 1.0),
                                    inertia=MASS, initial_velocity=-speed),),
        analysis=AnalysisSpec(type="dynamic", integrator=integrator, duration=duration,
                              time_step=time_step, output_interval=time_step, **analysis))


def run_column(case: Case, mesh) -> tuple[dict, np.ndarray]:
    """History of every step and the top's displacement q (m, along z) at every step."""
    top = mesh.surface_points("column_top")
    q = []
    result = DynamicSolver(case, mesh).run(
        frame_hook=lambda frame: q.append(frame.u[top, 2].mean()))
    return result.history, np.asarray(q)


def hht_amplification(omega_dt: float, alpha: float) -> np.ndarray:
    """HHT-alpha's amplification matrix of (u, dt v, dt^2 a) for an undamped oscillator.

    Hilber, Hughes and Taylor 1977 (docs/references.md): a_1 + (1 + alpha) w^2 u_1
    - alpha w^2 u_0 = 0 with Newmark's updates, beta = (1 - alpha)^2 / 4,
    gamma = 1/2 - alpha.
    """
    beta, gamma = (1 - alpha) ** 2 / 4, 0.5 - alpha
    # the equation of motion divided by w^2, so that omega_dt = inf gives the limit
    new = np.array([[1.0, 0.0, -beta], [0.0, 1.0, -gamma], [1 + alpha, 0.0, omega_dt**-2]])
    old = np.array([[1.0, 1.0, 0.5 - beta], [0.0, 1.0, 1 - gamma], [alpha, 0.0, 0.0]])
    return np.linalg.solve(new, old)


def principal_root(omega_dt: float, alpha: float) -> complex:
    roots = np.linalg.eigvals(hht_amplification(omega_dt, alpha))
    return complex(roots[np.argmax(np.abs(roots))])


@pytest.mark.parametrize("alpha", [0.0, -0.1, -1.0 / 3.0])
def test_amplification_matrix_has_the_published_limits(alpha):
    # HHT 1977: spectral radius 1 at every step for alpha = 0 (average acceleration),
    # and (1 + alpha) / (1 - alpha) as omega dt -> infinity. Rounding only, except
    # that the roots coalesce at alpha = -1/3 and a double eigenvalue is computed to
    # about sqrt(eps) = 1.5e-8: 1e-7.
    assert abs(principal_root(0.5, 0.0)) == pytest.approx(1.0, abs=1e-14)
    rho_inf = max(abs(np.linalg.eigvals(hht_amplification(np.inf, alpha))))
    assert rho_inf == pytest.approx((1 + alpha) / (1 - alpha), abs=1e-7)


def _prony(u: np.ndarray) -> tuple[float, float]:
    """Per-step decay rho and phase theta of a damped sinusoid u_n = R rho^n cos(n theta + p).

    Such a sequence obeys u_(n+1) = 2 rho cos(theta) u_n - rho^2 u_(n-1); the two
    coefficients are fitted by least squares over the whole history.
    """
    rows = np.column_stack([u[1:-1], u[:-2]])
    (p, q), *_ = np.linalg.lstsq(rows, u[2:], rcond=None)
    rho = math.sqrt(-q)
    return rho, math.acos(p / (2 * rho))


@pytest.mark.parametrize("alpha", [0.0, -0.1, -0.3])
@pytest.mark.parametrize("omega_dt", [0.5, 2.0])
def test_hht_free_vibration_decays_by_the_spectral_radius(column, alpha, omega_dt):
    """The rigid mass on the column vibrates freely; its displacement history, fitted
    as a damped sinusoid, decays per step by the spectral radius of HHT's
    amplification matrix and turns by the phase of its principal root.

    The spurious third root of the matrix is below 0.3 in modulus at these steps:
    after 20 steps it is under 1e-10 of the response, so the fit starts there. The
    fit is then exact up to rounding of the ~60 nm displacements (1e-16 m, 1e-9
    relative): tolerance 1e-8 on rho and theta, and the per-period decay
    rho^(2 pi / theta) follows to 1e-6.
    """
    path, mesh = column
    dt = omega_dt / OMEGA
    case = column_case(path, "newmark", dt, 120 * dt, speed=0.01, hht_alpha=alpha)
    history, q = run_column(case, mesh)
    assert np.all(history["contact_force"] == 0.0)
    assert len(q) == len(history["time"]) == 121
    rho, theta = _prony(q[20:])
    root = principal_root(omega_dt, alpha)
    assert rho == pytest.approx(abs(root), abs=1e-8)
    assert theta == pytest.approx(abs(np.angle(root)), abs=1e-8)
    per_period = rho ** (2 * math.pi / theta)
    assert per_period == pytest.approx(abs(root) ** (2 * math.pi / abs(np.angle(root))),
                                       rel=1e-6)
    if alpha == 0.0:
        assert per_period == pytest.approx(1.0, abs=1e-7)   # average acceleration: no decay
    else:
        assert per_period < 1.0 - 1e-4                      # HHT damps


# -- plasticity ------------------------------------------------------------------------
YIELD = 835e6
BULK = LAME + 2.0 * SHEAR / 3.0
STRAIN_Y = YIELD / (2.0 * SHEAR)     # uniaxial strain at first yield: sigma_z - sigma_x = Y


def first_loading(energy: float) -> tuple[float, float]:
    """Peak strain and plastic work of the column's first compression (closed form).

    Uniaxial strain eps, J2 perfect plasticity: the von Mises stress is
    |sigma_z - sigma_x| = 2 mu (eps - kappa) up to Y; past yield kappa = eps - eps_y,
    the stored energy per volume is K eps^2 / 2 + Y^2 / (6 mu) and the plastic
    work (2/3) Y (eps - eps_y) (s : d eps_p with eps_p = kappa diag(2/3, -1/3, -1/3)).
    The kinetic energy is spent at eps_m: V [K eps_m^2 / 2 + Y^2/(6 mu)
    + (2/3) Y (eps_m - eps_y)] = energy.
    """
    volume = SIZE**3
    a = 0.5 * BULK
    b = 2.0 / 3.0 * YIELD
    c = YIELD**2 / (6.0 * SHEAR) - b * STRAIN_Y - energy / volume
    eps = (-b + math.sqrt(b * b - 4 * a * c)) / (2 * a)
    return eps, volume * b * (eps - STRAIN_Y)


def lumped_top_mass(mesh) -> float:
    """HRZ-lumped mass of the column's top nodes: rho V_e / 4 per node of each P1 element."""
    cells = mesh.cells[mesh.volume("column")]
    x = mesh.points[cells]
    volumes = np.abs(np.linalg.det(x[:, 1:] - x[:, :1])) / 6.0
    on_top = np.isin(cells, mesh.surface_points("column_top")).sum(axis=1)
    return float(RHO * np.sum(volumes * on_top) / 4.0)


@pytest.mark.parametrize("integrator", ["explicit", "newmark"])
def test_plastic_dissipation_of_the_first_compression(column, integrator):
    """The mass (2 m/s, 5.6 times the energy the column stores at first yield)
    compresses the column plastically, then rebounds and yields the other way.

    - The energy balance kinetic + strain + plastic work closes: both schemes are
      second order, the error is O((omega dt)^2) = 2.5e-4 of the energy away from the
      yield kinks, where the force's slope changes inside a step; 2e-3 holds both.
    - The plastic work at the first standstill (it stays constant while the column
      unloads elastically, 2 eps_y of strain) equals the closed form: the uniform
      strain makes the FE exact, so only the schemes' O((omega dt)^2) error in the
      peak remains, which the plastic work shares (dD/D = dE/E here): 1e-3.
    """
    path, mesh = column
    mass = M_CONSISTENT if integrator == "newmark" else MASS + lumped_top_mass(mesh)
    period = 2 * math.pi * math.sqrt(mass / K_COLUMN)
    speed = 2.0
    case = column_case(path, integrator, period / 400, 2.0 * period, speed=speed,
                       yield_strength=YIELD, plastic_zone=1.0)
    h, q = run_column(case, mesh)
    assert np.all(h["contact_force"] == 0.0)
    energy = 0.5 * mass * speed**2
    assert h["total_energy"][0] == pytest.approx(energy, rel=1e-12)
    assert np.abs(h["total_energy"] / energy - 1.0).max() < 2e-3
    # the first standstill: the largest compression before the top moves back up
    turn = int(np.argmax(np.diff(q) > 0.0))
    eps_m, work = first_loading(energy)
    assert -q[turn] / SIZE == pytest.approx(eps_m, rel=1e-3)
    assert h["plastic_dissipation"][turn] == pytest.approx(work, rel=1e-3)
    assert h["plastic_dissipation"][turn + 5] == h["plastic_dissipation"][turn]
    # and it yields again in reverse before the run ends
    assert h["plastic_dissipation"][-1] > 1.1 * work
    assert eps_m > 2 * STRAIN_Y


def test_verlet_kernels_are_the_numpy_expressions_to_the_last_bit():
    """The explicit step's two fused passes against the numpy expressions they
    replace, on values of mixed scale: equal bit for bit (no fused multiply-add)."""
    from fe_impact.solvers.integrators import _verlet_correct, _verlet_predict

    rng = np.random.default_rng(2)
    n, dt = 1000, 3.7e-9
    a, v0, z0 = (rng.standard_normal(n) * 10.0 ** rng.integers(-9, 9, n) for _ in range(3))
    v, z = _verlet_predict(a, v0, z0, 0.5 * dt, dt)
    v_np = 0.5 * dt * a
    v_np += v0
    z_np = dt * v_np
    z_np += z0
    np.testing.assert_array_equal(v, v_np)
    np.testing.assert_array_equal(z, z_np)
    Kz, fc, minv = (rng.standard_normal(n) * 10.0 ** rng.integers(-6, 6, n) for _ in range(3))
    a_np = minv * (fc - Kz)
    v_np += 0.5 * dt * a_np
    f = Kz + (-fc)
    acc = _verlet_correct(f, minv, v, 0.5 * dt)
    assert acc is f
    np.testing.assert_array_equal(acc, a_np)
    np.testing.assert_array_equal(v, v_np)
