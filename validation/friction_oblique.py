"""Oblique impact of an elastic sphere on a block with Coulomb friction (explicit).

Run ``python validation/friction_oblique.py --out out/friction_oblique``
(``--quick``: a coarse mesh). Writes ``friction_oblique.json`` and
``checks.json``; exits 1 when a check fails.

Model: a steel sphere (R = 10 mm, half model, symmetry y = 0) strikes a steel
block (20 x 10 x 10 mm half, bottom fixed) at the normal speed ``V_N`` and the
tangential speed ``V_N tan(alpha)`` along x, without spin, friction ``MU``;
explicit central difference. After the impact the sphere's rigid motion is
taken from its nodes' momentum and angular momentum (lumped mass): the
contact point's tangential velocity ``V_t2 = v_x - omega_y R`` and the
normal rebound speed ``V_n2``.

Reference: Maw, Barber and Fawcett (1976, Wear 38:101-114). In their
non-dimensional form (``psi = 2 (1 - nu) / (mu (2 - nu)) V_t / V_n``,
``chi = (1 - nu) / (2 - nu) (1 + m R^2 / I)``; a solid sphere has
``m R^2 / I = 5/2``) the sphere slides throughout the impact once
``psi_1 >= 4 chi``, and then ``psi_2 = psi_1 - 4 chi``: the tangential
restitution ``e_t = V_t2 / V_t1 = 1 - 4 chi / psi_1`` and the rebound angle
``tan(beta) = V_t2 / V_n2`` (elastic: ``V_n2 = V_n1``). The two incidence
angles of the check (``ANGLES``) lie in that regime; below it the sphere
sticks part of the time and their curves (tangential compliance) apply, which
the study does not assert (their values are not tabulated here).

Tolerances (set before the results were seen): 5% on ``e_t`` and on
``tan(beta)`` (the issue's); the energy balance, with the friction's
dissipation, closed to 1e-3 (the issue's). What the FE adds to the theory: wave loss
(about 0.6% of the energy at 1 m/s, Hunter 1957: a normal restitution of
about 0.997) and the mesh's sphere, whose ``m R^2 / I`` differs from 5/2 by
its faceting (well below 1% at these sizes).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.fe.case import (
    AnalysisSpec,
    Case,
    ContactSpec,
    InitialVelocitySpec,
    MaterialSpec,
    SupportSpec,
)
from fe_impact.fe.mesh import load_mesh
from fe_impact.output.files import write_json
from fe_impact.physics import hertz
from fe_impact.solvers.dynamic import DynamicSolver
from validation import checks as ck
from validation.friction_specimens import HalfSphereBlock, build_half_sphere_block

E, NU, RHO, R = 212e9, 0.289, 7860.0, 10e-3
MU = 0.1
V_N = 1.0
#: incidence angles from the normal (deg); psi_1 = 9.9 and 15.6 against 4 chi = 5.82
ANGLES = (50.0, 62.0)
GAP = 2e-6
#: the issue's 5% on both figures (see the docstring)
TOLERANCE = 0.05
LEVELS = {"quick": (0.4e-3, 1), "full": (0.3e-3, 2)}


def chi(nu: float = NU, inertia_ratio: float = 2.5) -> float:
    """Maw, Barber and Fawcett's ``chi = (1 - nu) / (2 - nu) (1 + m R^2 / I)``."""
    return (1.0 - nu) / (2.0 - nu) * (1.0 + inertia_ratio)


def psi(tangential_over_normal: float, mu: float = MU, nu: float = NU) -> float:
    """Their non-dimensional incidence ``2 (1 - nu) / (mu (2 - nu)) V_t / V_n``."""
    return 2.0 * (1.0 - nu) / (mu * (2.0 - nu)) * tangential_over_normal


def mbf_gross_slip(alpha_deg: float, inertia_ratio: float = 2.5) -> dict:
    """Tangential restitution and rebound angle of a sphere sliding throughout
    (``inertia_ratio``: its ``m R^2 / I``, 5/2 for a solid sphere)."""
    p1 = psi(math.tan(math.radians(alpha_deg)))
    c = chi(inertia_ratio=inertia_ratio)
    if p1 < 4.0 * c:
        raise ValueError(f"alpha = {alpha_deg} deg: psi_1 = {p1:.3g} < 4 chi = {4 * c:.3g}, "
                         "not gross slip")
    p2 = p1 - 4.0 * c
    return {"psi_1": p1, "psi_2": p2, "tangential_restitution": p2 / p1,
            "tan_rebound": p2 / p1 * math.tan(math.radians(alpha_deg))}


def oblique_case(mesh_file: Path, alpha_deg: float, duration: float,
                 integrator: str = "explicit") -> Case:
    vt = V_N * math.tan(math.radians(alpha_deg))
    return Case(path=Path(mesh_file).with_suffix(".case"), mesh_file=Path(mesh_file),
                unit="m", materials=(MaterialSpec(("sphere", "block"), E, NU, RHO),),
                contacts=(ContactSpec("sphere_contact", "block_contact", mu_static=MU,
                                      mu_dynamic=MU),),
                supports=(SupportSpec("block_bottom", (0, 1, 2)), SupportSpec("sym_y", (1,))),
                initial_velocities=(InitialVelocitySpec(("sphere",), (vt, 0.0, -V_N)),),
                analysis=AnalysisSpec(type="dynamic", integrator=integrator,
                                      duration=duration, output_interval=duration / 20,
                                      stop_after_separation=0.1))


def sphere_motion(solver: DynamicSolver, v: np.ndarray, z: np.ndarray) -> dict:
    """The sphere's mass, centre velocity, spin about y and inertia from its nodes.

    With the solver's own mass (lumped or consistent: the sphere shares no node
    with the block, so ``M v`` on its DOFs is its momentum, and ``x`` lies in the
    element space, so the sums are the integrals of ``rho v`` and ``rho x x``).
    """
    mesh, kin = solver.mesh, solver.kin
    pts = np.unique(mesh.cells[mesh.volume("sphere")])
    red = -np.ones(solver.model.n_dofs, dtype=np.int64)
    red[kin.free] = np.arange(kin.n_free)
    idx = red[3 * mesh.point_dof[pts][:, None] + np.arange(3)]        # (n, 3), all free

    def times_mass(w: np.ndarray) -> np.ndarray:
        return solver.m * w if solver.explicit else solver.scheme.M_product @ w

    def field(values: np.ndarray) -> np.ndarray:   # (n, 3) -> reduced vector
        out = np.zeros(kin.n)
        out[idx.ravel()] = values.ravel()
        return out

    x = mesh.points[pts] + z[idx]
    ones = [times_mass(field(np.tile(np.eye(3)[c], (len(pts), 1))))[idx] for c in range(3)]
    mass = float(ones[0][:, 0].sum())
    p = times_mass(v)[idx]                                              # (n, 3) momenta
    vc = p.sum(axis=0) / mass
    xc = np.array([(ones[c][:, c] * x[:, c]).sum() for c in range(3)]) / mass
    r = x - xc
    L = np.cross(r, p).sum(axis=0)            # about the centre (sum of M r vanishes)
    Mr = times_mass(field(r))[idx]
    Iyy = float((r[:, 0] * Mr[:, 0] + r[:, 2] * Mr[:, 2]).sum())
    return {"mass": mass, "vc": vc, "omega_y": L[1] / Iyy, "Iyy": Iyy}


def run_angle(mesh_file: Path, alpha_deg: float, t_c: float,
              integrator: str = "explicit") -> dict:
    case = oblique_case(mesh_file, alpha_deg, GAP / V_N + 2.0 * t_c, integrator)
    solver = DynamicSolver(case, load_mesh(mesh_file))
    last = {}

    def hook(state, row):
        last["state"] = state

    res = solver.run(step_hook=hook)
    s = last["state"]
    before = sphere_motion(solver, solver.v0, np.zeros_like(s.z))
    after = sphere_motion(solver, s.v, s.z)
    R_m = R   # contact point below the centre: v_point = v_c + omega x (0, 0, -R)
    vt1 = before["vc"][0] + before["omega_y"] * -R_m
    vt2 = after["vc"][0] + after["omega_y"] * -R_m
    vn1, vn2 = -before["vc"][2], after["vc"][2]
    ref = mbf_gross_slip(alpha_deg)
    ratio = after["mass"] * R ** 2 / after["Iyy"]
    h = res.history
    e0 = h["total_energy"][0]
    return {"alpha_deg": alpha_deg, "reference": ref,
            "tangential_restitution": vt2 / vt1, "tan_rebound": vt2 / vn2,
            "normal_restitution": vn2 / vn1,
            "inertia_ratio": ratio,
            "reference_mesh_sphere": mbf_gross_slip(alpha_deg, ratio),
            "friction_dissipation_J": float(h["friction_dissipation"][-1]),
            "energy_error": float(np.abs(h["total_energy"] - e0).max() / e0),
            "steps": res.info["steps"], "n_dofs": res.info["n_dofs"],
            "seconds": res.timings["integration"]}


def run(quick: bool = False, out: str | Path = "out/friction_oblique",
        integrator: str = "explicit", angles: tuple[float, ...] = ANGLES) -> dict:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    h, order = LEVELS["quick" if quick else "full"]
    mesh_file = out / f"sphere_{h * 1e6:.0f}um_p{order}.msh"
    if not mesh_file.exists():
        build_half_sphere_block(HalfSphereBlock(
            radius=R, gap=GAP, h_contact=h, order=order, hemisphere=False,
            r_fine=2.0e-3, h_far=3e-3 if quick else 2.5e-3), mesh_file)
    mass = RHO * 4.0 / 3.0 * math.pi * R ** 3
    t_c = hertz.impact(mass, V_N, R, hertz.effective_modulus(E, NU)).contact_time
    results = [run_angle(mesh_file, a, t_c, integrator) for a in angles]
    record = {"quick": quick, "integrator": integrator, "mu": MU, "h_contact": h,
              "order": order, "angles": results}
    write_json(out / "friction_oblique.json", record)
    return record


#: the energy balance with the friction's dissipation (the issue's bound)
ENERGY_TOLERANCE = 1e-3


def check(r: dict) -> list[ck.Check]:
    out = []
    for a in r["angles"]:
        out.append(ck.at_most(f"energy balance at {a['alpha_deg']:g} deg", a["energy_error"],
                              ENERGY_TOLERANCE))
        ref = a["reference"]
        out += [ck.within(f"tangential restitution at {a['alpha_deg']:g} deg",
                          a["tangential_restitution"], ref["tangential_restitution"], TOLERANCE),
                ck.within(f"tan(rebound angle) at {a['alpha_deg']:g} deg", a["tan_rebound"],
                          ref["tan_rebound"], TOLERANCE)]
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/friction_oblique"))
    p.add_argument("--quick", action="store_true", help="coarse mesh")
    p.add_argument("--integrator", choices=("explicit", "newmark"), default="explicit")
    args = p.parse_args(argv)
    r = run(args.quick, args.out, args.integrator)
    print(json.dumps(r, indent=2, default=float))
    return ck.finish("friction_oblique", check(r), args.out)


if __name__ == "__main__":
    sys.exit(main())
