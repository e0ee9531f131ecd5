"""A free rigid rotor keeps its angular velocity; its inertia is the closed form.

The upper cube of the two-block specimen (meshes/two_blocks.msh: 1 mm cubes,
the upper 10 nm above the lower) is tied as a whole to a rigid body rotating
about the vertical axis through its centre, with no added inertia: the cube
is the rotor. The lower cube is fixed. A rotation about z moves the facing
squares in their own plane, so the contact pair between them never closes
(the linearised rotation u = theta e_z x (x - p) has no z component) and
nothing acts on the rotor: theta = omega t exactly, and every node moves by
omega t e_z x (x - p).

Inertia about the axis: rho a^5 / 6 with Newmark's consistent mass (the
rotation field is linear, so the P1 mass matrix integrates x^2 + y^2
exactly); with the explicit scheme's HRZ-lumped mass, sum over the elements
of rho V_e / 4 times the squared distances of its four nodes from the axis.
"""

from __future__ import annotations

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
SIZE = 1e-3
AXIS_POINT = (0.5e-3, 0.5e-3, 0.0)
OMEGA = 200.0        # rad/s: 0.2 rad over the run, 0.14 mm at the corners


def rotor_case(path, integrator: str, time_step: float, duration: float,
               surface: str = "upper_all", omega: float = OMEGA,
               carries: tuple[str, ...] = ()) -> Case:
    """The rotor tied to ``surface`` of the upper cube, turning at ``omega``."""
    return Case(
        path=path.with_suffix(".case"), mesh_file=path, unit="m",
        materials=(MaterialSpec(("upper", "lower"), E, NU, RHO),),
        contacts=(ContactSpec("upper_bottom", "lower_top", penalty=1e14),),
        supports=(SupportSpec("lower_all", (0, 1, 2)),),
        rigid_bodies=(RigidBodySpec(surface, "rotation", (0.0, 0.0, 1.0),
                                    point=AXIS_POINT, inertia=0.0,
                                    initial_velocity=omega, carries=carries),),
        analysis=AnalysisSpec(type="dynamic", integrator=integrator, duration=duration,
                              time_step=time_step, output_interval=duration / 4))


def lumped_inertia(mesh) -> float:
    """HRZ-lumped moment of inertia of the upper cube: rho V_e / 4 at each P1 node."""
    cells = mesh.cells[mesh.volume("upper")]
    x = mesh.points[cells]
    volumes = np.abs(np.linalg.det(x[:, 1:] - x[:, :1])) / 6.0
    r2 = ((x[..., :2] - np.array(AXIS_POINT[:2])) ** 2).sum(axis=-1)
    return float(RHO * np.sum(volumes * r2.sum(axis=1)) / 4.0)


@pytest.mark.parametrize("integrator", ["newmark", "explicit"])
def test_free_rotor_turns_at_constant_speed_with_the_cube_inertia(integrator):
    path = committed("two_blocks.msh")
    mesh = load_mesh(path)
    duration = 1e-3
    frames = []
    result = DynamicSolver(rotor_case(path, integrator, duration / 40, duration), mesh).run(
        frame_hook=frames.append)
    h = result.history
    assert np.all(h["contact_force"] == 0.0)
    inertia = RHO * SIZE**5 / 6.0 if integrator == "newmark" else lumped_inertia(mesh)
    energy = 0.5 * inertia * OMEGA**2
    assert h["kinetic_energy"][0] == pytest.approx(energy, rel=1e-12)
    # Both schemes integrate a force-free body exactly. The rotation's stiffness is zero only
    # to the rounding of K: about eps E a per element and lever a^2, some 1e-11 N m/rad
    # summed, a spurious frequency w of up to ~3 rad/s against I = 1.3e-12 kg m^2. It
    # trades (w t)^2 <= 1e-5 of the energy into strain over the 1 ms run, turns the
    # cube (w t)^2 / 6 less and slows it (w t)^2 / 2; the energy stays conserved
    # (Newmark exactly on a linear system; central difference to (w dt)^2 ~ 1e-8 of the
    # strain share, itself <= 1e-5).
    np.testing.assert_allclose(h["kinetic_energy"], energy, rtol=1e-5)
    np.testing.assert_allclose(h["kinetic_energy"] + h["strain_energy"], energy, rtol=1e-12)
    upper = np.unique(mesh.cells[mesh.volume("upper")])
    lower = np.unique(mesh.cells[mesh.volume("lower")])
    r = mesh.points[upper] - np.array(AXIS_POINT)
    assert len(frames) == 5
    for frame in frames:
        expected = OMEGA * frame.time * np.cross([0.0, 0.0, 1.0], r)
        np.testing.assert_allclose(frame.u[upper], expected, rtol=0,
                                   atol=1e-5 * OMEGA * duration * SIZE)
        np.testing.assert_allclose(frame.v[upper], OMEGA * np.cross([0.0, 0.0, 1.0], r),
                                   rtol=0, atol=1e-5 * OMEGA * SIZE)
        assert np.abs(frame.u[lower]).max() == 0.0
    assert frames[-1].time == pytest.approx(duration, rel=1e-12)


#: Slow enough that the zone does not move past its re-projection tolerance in the run
#: (2 mrad: 1.4 um at the corners), so the whole run is one rigid flight.
OMEGA_SLOW = 2.0


def carried_case(path, carries: tuple[str, ...]) -> Case:
    """The rotor tied to the upper cube's bottom face only, carrying the cube or not."""
    return rotor_case(path, "newmark", 1e-3 / 40, 1e-3, "upper_bottom", OMEGA_SLOW, carries)


def test_a_carried_cube_turns_with_its_rotor_and_its_flight_needs_no_solve():
    """The cube carried by the rotor on its bottom face starts in the rotor's rigid
    motion: its kinetic energy is the closed form and it turns rigidly, and Newmark
    takes the flight without solves: the exact rotation, which the solved steps
    follow within what K's rounding on the rotation does to them.
    Not carried, the cube starts at rest behind its turning face: no rigid start."""
    path = committed("two_blocks.msh")
    mesh = load_mesh(path)
    upper = np.unique(mesh.cells[mesh.volume("upper")])
    r = mesh.points[upper] - np.array(AXIS_POINT)
    energy = 0.5 * RHO * SIZE**5 / 6.0 * OMEGA_SLOW**2
    runs = {}
    for free in (True, False):
        solver = DynamicSolver(carried_case(path, ("upper",)), mesh)
        solver.free_flight = free
        frames = []
        runs[free] = (solver.run(frame_hook=frames.append), frames)
    (flown, frames), (solved, solved_frames) = runs[True], runs[False]
    assert flown.info["free_steps"] == flown.info["steps"] == 40
    assert solved.info["free_steps"] == 0
    h = flown.history
    # the consistent P1 mass integrates the linear rotation field exactly
    assert h["kinetic_energy"][0] == pytest.approx(energy, rel=1e-12)
    np.testing.assert_allclose(h["kinetic_energy"], energy, rtol=1e-12)
    # a rigid field's strain energy is K's rounding: eps E a u^2 an element entry, with
    # u = w T a; bounded by a thousand such entries (24 elements of 144)
    rounding = 1e3 * np.finfo(float).eps * E * SIZE * (OMEGA_SLOW * 1e-3 * SIZE) ** 2
    assert np.abs(h["strain_energy"]).max() < rounding
    for frame, other in zip(frames, solved_frames, strict=True):
        np.testing.assert_allclose(frame.u[upper],
                                   OMEGA_SLOW * frame.time * np.cross([0.0, 0.0, 1.0], r),
                                   rtol=0, atol=1e-12 * SIZE)
        # the solved steps feel K's rounding on the rotation: (w t)^2 <= 1e-5 of the
        # turn (the first test's reasoning); the flight is the exact rotation
        np.testing.assert_allclose(frame.u, other.u, rtol=0,
                                   atol=1e-5 * OMEGA_SLOW * frame.time * SIZE)
    np.testing.assert_allclose(solved.history["kinetic_energy"], h["kinetic_energy"],
                               rtol=1e-5)

    behind = DynamicSolver(carried_case(path, ()), mesh).run()
    assert behind.info["free_steps"] == 0
    # the face drags the resting cube up to speed: the waves it sends hold a share of
    # the kinetic energy the cube gains (of order its rigid energy; 1e-3 of it is loose)
    assert behind.history["strain_energy"].max() > 1e-3 * energy
