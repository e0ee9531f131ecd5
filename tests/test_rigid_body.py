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


def rotor_case(path, integrator: str, time_step: float, duration: float) -> Case:
    return Case(
        path=path.with_suffix(".case"), mesh_file=path, unit="m",
        materials=(MaterialSpec(("upper", "lower"), E, NU, RHO),),
        contacts=(ContactSpec("upper_bottom", "lower_top", penalty=1e14),),
        supports=(SupportSpec("lower_all", (0, 1, 2)),),
        rigid_bodies=(RigidBodySpec("upper_all", "rotation", (0.0, 0.0, 1.0),
                                    point=AXIS_POINT, inertia=0.0,
                                    initial_velocity=OMEGA),),
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
