"""Hertz impact validation: sphere-on-block impacts against Hertz impact theory.

Run ``python validation/hertz_impact.py --out out/hertz_impact`` (about
10 minutes; ``--quick`` runs a coarse subset in about 1 minute). Writes
``hertz_impact.json``, ``hertz_impact.csv``, ``hertz_impact.md`` (with the
checks) and ``hertz_impact.png``; exits 1 when a check fails (tolerances:
the constants below, each with its reason).

(a) Rigid-mass striker. A hemisphere R = 10 mm whose flat face is tied to a
    rigid mass of 0.5 kg hits a 20 x 20 x 10 mm block (bottom supported) at
    0.1, 1 and 3 m/s; Newmark. Hertz impact theory with the effective mass
    m = 0.5 kg + the hemisphere's 16.5 g (the block is held) and R = 10 mm.
    Hertz assumes two half-spaces; the finite specimen is stiffer (its
    hemisphere ends 10 mm above the contact, its block is held 10 mm below).
    To separate that from the transient solver's error, the same mesh is
    also solved statically (displacement control of the flat face, the
    static solver validated in ``hertz_static``), and the quasi-static
    impact of the rigid mass on that force-displacement curve is integrated:
    the "specimen" reference. FE minus specimen is the dynamic error;
    specimen minus Hertz is the finite-body effect.
(b) Free elastic sphere (quarter model of a whole sphere, mass 32.9 g) at
    1 m/s, explicit and Newmark: restitution, energy error, the energy lost
    to elastic waves against Hunter's estimate 1.04 (v/c0)^0.6, and the
    agreement of the two integrators.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import PchipInterpolator

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.fe.mesh import load_mesh
from fe_impact.output.files import write_csv, write_json
from fe_impact.physics import hertz
from fe_impact.solvers.dynamic import DynamicSolver
from fe_impact.solvers.static import StaticSolver
from validation import checks as ck
from validation.impact_cases import (
    NU,
    RHO,
    E,
    R,
    sphere_block_case,
    sphere_block_mesh,
    sphere_impact_case,
)

logger = logging.getLogger(__name__)

SYMMETRY = 4.0
RIGID_MASS = 0.5
HEMISPHERE_MASS = 2.0 / 3.0 * math.pi * R ** 3 * RHO
SPHERE_MASS = 2.0 * HEMISPHERE_MASS
SPEEDS = (0.1, 1.0, 3.0)
#: Contact element size per speed: about 5-9 elements across the Hertz radius
#: (a = 0.33, 0.84, 1.29 mm), refined out to 1.2 a.
MESH_SIZE = {0.1: 0.07e-3, 1.0: 0.1e-3, 3.0: 0.15e-3}
GAP = 1e-6
QUICK_SIZE = 0.2e-3
E_STAR = hertz.effective_modulus(E, NU)
C0 = math.sqrt(E / RHO)
#: FE against the quasi-static impact on the same mesh (peak force, largest
#: approach, contact time). The contact lasts 30-150 times the time an elastic
#: wave needs to cross the hemisphere, so inertia inside it changes the force
#: by well under 1%; Newmark at the automatic step (about t_c/50) misses the
#: period by ~0.1%. 1% leaves room for the contact switches and catches a
#: solver error of a few per cent.
SPECIMEN_TOLERANCE = 0.01
#: FE against Hertz (two half-spaces): the finite specimen is stiffer, and its
#: own quasi-static impact (the specimen reference above, from the static
#: solver's curve) departs from Hertz's by +4.2% in peak force at 3 m/s, the
#: fastest case; with the 1% allowed for the solver, 6% (rounded up). The
#: specimen check above is the sharp one.
HERTZ_TOLERANCE = 0.06
#: The free sphere at 1 m/s against Hertz: the same specimen's departure at 1 m/s
#: (the rigid-mass case there: +3.1% against Hertz, +0.4% against the specimen,
#: so about +2.7% for the specimen) and the 1% for the solver, rounded up: 5%.
FREE_HERTZ_TOLERANCE = 0.05
#: Energy of the Newmark runs (average acceleration conserves it up to the
#: contact switches) and of the explicit run (central differences conserve a
#: shadow energy within O(omega^2 dt^2) of it).
ENERGY_TOLERANCE = 1e-3
#: An elastic rigid-mass impact loses energy only to waves and vibration:
#: e > 0.99 (Hunter's wave loss of a free sphere at 1 m/s is 0.6% of the energy).
ELASTIC_FLOOR = 0.99
#: Explicit against Newmark on the same mesh: both are second order and their
#: period errors at their time steps are below 0.1%; the explicit penalty is
#: softer (30 against 1000 E*/h), which lengthens the contact by ~0.3%. 1%.
INTEGRATOR_TOLERANCE = 0.01
#: Hunter's wave loss 1.04 (v/c0)^0.6 (0.6% of the energy at 1 m/s) is for
#: waves that leave for good into a half-space; in the 10 mm block they come
#: back within a tenth of the contact time, so the free sphere is reported
#: beside Hunter but asserted only to rebound elastically, |1 - e| <= 1%.
FREE_TOLERANCE = 0.01


def specimen_impact(mesh: Path, mass: float, speed: float, gap: float,
                    delta_guess: float) -> dict:
    """Quasi-static impact of ``mass`` on the specimen's static force-displacement curve."""
    disp = gap + delta_guess * np.linspace(0.1, 1.3, 9)
    # The first steps touch on a few nodes only: a looser displacement tolerance
    # (1e-4 of the contact displacement) stops active-set cycling on them.
    case = sphere_block_case(mesh, tuple(-disp), tolerance=1e-4, max_iterations=60)
    result = StaticSolver(case, load_mesh(mesh)).run()
    force = np.array([SYMMETRY * s.contact_force[0] for s in result.steps])
    curve = PchipInterpolator(np.concatenate([[gap], disp]), np.concatenate([[0.0], force]))

    def rhs(t, y):
        d = y[0]
        f = float(curve(d)) if d > gap else 0.0
        return [y[1], -f / mass]

    def separated(t, y):
        return y[0] - gap
    separated.terminal, separated.direction = True, -1

    t_end = 20.0 * delta_guess / speed
    sol = solve_ivp(rhs, (0.0, t_end), [gap, speed], events=separated, rtol=1e-10,
                    atol=1e-15, max_step=t_end / 2000, dense_output=True)
    tt = np.linspace(0.0, sol.t[-1], 4001)
    d = sol.sol(tt)[0]
    return {"peak_force": float(curve(d.max())), "max_approach": float(d.max() - gap),
            "contact_time": float(sol.t[-1]), "static_force": force.tolist(),
            "static_displacement": disp.tolist()}


def run_rigid(speed: float, h: float, out: Path) -> dict:
    folder = out / f"rigid_{speed:g}_{h * 1e6:.0f}um".replace(".", "p")
    m = RIGID_MASS + HEMISPHERE_MASS
    ref = hertz.impact(m, speed, R, E_STAR)
    a = math.sqrt(R * ref.delta_max)
    mesh = sphere_block_mesh(folder, h, gap=GAP, r_fine=max(1.2 * a, 0.5e-3))
    t = time.perf_counter()
    case = sphere_impact_case(mesh, speed, GAP / speed + 1.3 * ref.contact_time,
                              rigid_mass=RIGID_MASS, frames=20)
    solver = DynamicSolver(case, load_mesh(mesh))
    res = solver.run()
    secs = time.perf_counter() - t
    meas = res.measurements
    spec = specimen_impact(mesh, m, speed, solver.initial_gap, ref.delta_max)
    fe = {"peak_force": SYMMETRY * meas.peak_force, "max_approach": meas.max_approach,
          "contact_time": meas.contact_duration}
    hz = {"peak_force": ref.force_max, "max_approach": ref.delta_max,
          "contact_time": ref.contact_time}
    row = {"speed": speed, "h_contact_mm": h * 1e3, "n_dofs": res.info["n_dofs"],
           "steps": res.info["steps"], "seconds": secs,
           "restitution": meas.restitution, "energy_error": meas.energy_error}
    for k in fe:
        row[f"{k}_fe"] = fe[k]
        row[f"{k}_hertz"] = hz[k]
        row[f"{k}_specimen"] = spec[k]
        row[f"{k}_error_hertz"] = fe[k] / hz[k] - 1.0
        row[f"{k}_error_specimen"] = fe[k] / spec[k] - 1.0
        row[f"{k}_finite_body"] = spec[k] / hz[k] - 1.0
    row["history"] = {"time": res.history["time"].tolist(),
                      "force": (SYMMETRY * res.history["contact_force"]).tolist(),
                      "approach": res.history["approach"].tolist()}
    return row


def run_free(integrator: str, h: float, out: Path, speed: float = 1.0) -> dict:
    folder = out / "free_sphere"
    mesh = sphere_block_mesh(folder, h, gap=GAP, hemisphere=False)
    ref = hertz.impact(SPHERE_MASS, speed, R, E_STAR)
    t = time.perf_counter()
    case = sphere_impact_case(mesh, speed, GAP / speed + 1.5 * ref.contact_time,
                              integrator=integrator, frames=20)
    res = DynamicSolver(case, load_mesh(mesh)).run()
    meas = res.measurements
    e = meas.restitution
    return {"integrator": integrator, "speed": speed, "h_contact_mm": h * 1e3,
            "n_dofs": res.info["n_dofs"], "steps": res.info["steps"],
            "time_step": res.info["time_step"], "seconds": time.perf_counter() - t,
            "peak_force": SYMMETRY * meas.peak_force, "peak_force_hertz": ref.force_max,
            "contact_time": meas.contact_duration, "contact_time_hertz": ref.contact_time,
            "restitution": e, "energy_error": meas.energy_error,
            "energy_lost": 1.0 - e ** 2 if e is not None else None,
            "hunter_wave_loss": hertz.hunter_wave_loss(speed, E, RHO)}


def report(rigid: list[dict], free: list[dict]) -> str:
    lines = ["# Hertz impact validation", "",
             f"(a) Hemisphere R = 10 mm tied to a {RIGID_MASS} kg rigid mass on a block, "
             f"Newmark. Hertz: m = {RIGID_MASS + HEMISPHERE_MASS:.4f} kg (rigid mass + "
             "hemisphere), R = 10 mm, E* = "
             f"{E_STAR / 1e9:.2f} GPa. 'specimen': quasi-static impact on the same mesh's "
             "static force-displacement curve.", "",
             "| v (m/s) | DOFs | steps | time (s) | quantity | FE | Hertz | FE vs Hertz "
             "| FE vs specimen | finite-body effect |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    units = {"peak_force": ("N", 1.0), "max_approach": ("um", 1e6),
             "contact_time": ("us", 1e6)}
    for r in rigid:
        for k, (u, s) in units.items():
            lines.append(f"| {r['speed']:g} | {r['n_dofs']} | {r['steps']} | "
                         f"{r['seconds']:.0f} | {k} ({u}) | {r[f'{k}_fe'] * s:.4g} | "
                         f"{r[f'{k}_hertz'] * s:.4g} | {r[f'{k}_error_hertz']:+.2%} | "
                         f"{r[f'{k}_error_specimen']:+.2%} | {r[f'{k}_finite_body']:+.2%} |")
    lines += ["", "Restitution / energy error: " + ", ".join(
        f"{r['speed']:g} m/s: {r['restitution']:.5f} / {r['energy_error']:.2e}"
        for r in rigid), "",
        "(b) Free elastic sphere R = 10 mm (quarter of a whole sphere) at 1 m/s.", "",
        "| integrator | DOFs | steps | time (s) | peak force (N) | Hertz | contact time (us) "
        "| Hertz | restitution | energy error | energy lost | Hunter wave loss |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in free:
        lines.append(f"| {r['integrator']} | {r['n_dofs']} | {r['steps']} | "
                     f"{r['seconds']:.0f} | {r['peak_force']:.4g} | "
                     f"{r['peak_force_hertz']:.4g} | {r['contact_time'] * 1e6:.4g} | "
                     f"{r['contact_time_hertz'] * 1e6:.4g} | {r['restitution']:.5f} | "
                     f"{r['energy_error']:.2e} | {r['energy_lost']:.2e} | "
                     f"{r['hunter_wave_loss']:.2e} |")
    if len(free) == 2:
        a, b = free
        lines += ["", f"Explicit vs Newmark: peak force "
                  f"{a['peak_force'] / b['peak_force'] - 1:+.2%}, contact time "
                  f"{a['contact_time'] / b['contact_time'] - 1:+.2%}."]
    return "\n".join(lines) + "\n"


def plot(rigid: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    for r in rigid:
        h = r["history"]
        t, f, d = np.array(h["time"]), np.array(h["force"]), np.array(h["approach"])
        ref = hertz.impact(RIGID_MASS + HEMISPHERE_MASS, r["speed"], R, E_STAR)
        line, = ax[0].plot(t / ref.contact_time, f / ref.force_max, label=f"{r['speed']:g} m/s")
        tau = np.linspace(0, 1, 200)
        # Hertz force history is close to sin(pi t/tc)^1.5 (within 1%)
        ax[0].plot(tau, np.sin(np.pi * tau) ** 1.5, "k:", lw=0.8)
        on = d > 0
        ax[1].plot(d[on] / ref.delta_max, f[on] / ref.force_max, color=line.get_color())
    x = np.linspace(0, 1, 100)
    ax[1].plot(x, x ** 1.5, "k--", label="Hertz")
    ax[0].set(xlabel="t / t_c (Hertz)", ylabel="F / F_max (Hertz)", title="force history")
    ax[1].set(xlabel="approach / delta_max (Hertz)", ylabel="F / F_max (Hertz)",
              title="force against approach")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(quick: bool = False, out: str | Path = "out/hertz_impact") -> dict:
    """Both parts; ``quick``: h = 0.2 mm, the rigid-mass case at 1 m/s, Newmark only."""
    out = Path(out)
    if quick:
        rigid = [run_rigid(1.0, QUICK_SIZE, out)]
        free = [run_free("newmark", QUICK_SIZE, out)]
    else:
        rigid = [run_rigid(v, MESH_SIZE[v], out) for v in SPEEDS]
        free = [run_free(i, 0.1e-3, out) for i in ("explicit", "newmark")]
    return {"quick": quick, "rigid_mass": rigid, "free_sphere": free}


def check(result: dict) -> list[ck.Check]:
    """The headline figures against their tolerances (see the constants above)."""
    out = []
    for r in result["rigid_mass"]:
        v = f"{r['speed']:g} m/s"
        for k in ("peak_force", "max_approach", "contact_time"):
            out.append(ck.within(f"rigid {v}: {k.replace('_', ' ')} vs specimen",
                                 r[f"{k}_fe"], r[f"{k}_specimen"], SPECIMEN_TOLERANCE))
        out.append(ck.within(f"rigid {v}: peak force vs Hertz", r["peak_force_fe"],
                             r["peak_force_hertz"], HERTZ_TOLERANCE))
        out.append(ck.at_least(f"rigid {v}: restitution", r["restitution"], ELASTIC_FLOOR))
        out.append(ck.at_most(f"rigid {v}: energy error", r["energy_error"], ENERGY_TOLERANCE))
    for r in result["free_sphere"]:
        i = r["integrator"]
        out.append(ck.within(f"free {i}: peak force vs Hertz", r["peak_force"],
                             r["peak_force_hertz"], FREE_HERTZ_TOLERANCE))
        out.append(ck.within(f"free {i}: contact time vs Hertz", r["contact_time"],
                             r["contact_time_hertz"], FREE_HERTZ_TOLERANCE))
        out.append(ck.at_most(f"free {i}: energy error", r["energy_error"], ENERGY_TOLERANCE))
        out.append(ck.within(f"free {i}: restitution", r["restitution"], 1.0,
                             FREE_TOLERANCE))
    if len(result["free_sphere"]) == 2:
        a, b = result["free_sphere"]
        for k in ("peak_force", "contact_time"):
            out.append(ck.within(f"explicit vs Newmark: {k.replace('_', ' ')}", a[k], b[k],
                                 INTEGRATOR_TOLERANCE))
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/hertz_impact"))
    p.add_argument("--quick", action="store_true",
                   help="coarse meshes (h = 0.2 mm), rigid-mass case at 1 m/s, Newmark only")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    logging.getLogger("skfem").setLevel(logging.WARNING)
    out = args.out
    result = run(args.quick, out)
    rigid, free = result["rigid_mass"], result["free_sphere"]
    checks = check(result)
    rows = [{k: v for k, v in r.items() if k != "history"} for r in rigid]
    write_csv(out / "hertz_impact.csv", list(rows[0]), [list(r.values()) for r in rows])
    write_json(out / "hertz_impact.json", {"rigid_mass": rigid, "free_sphere": free})
    text = report(rigid, free) + "\n## Checks\n\n" + ck.markdown(checks)
    (out / "hertz_impact.md").write_text(text)
    if not args.no_plot:
        plot(rigid, out / "hertz_impact.png")
    print(text)
    return ck.finish("hertz_impact", checks, out)


if __name__ == "__main__":
    sys.exit(main())
