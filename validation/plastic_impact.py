"""Elastic-plastic impact: restitution of a sphere striking a block against Jackson-Green-Marghitu.

Run ``python validation/plastic_impact.py --out out/plastic_impact`` (a few
minutes; ``--quick`` about a minute). Writes ``plastic_impact.json``,
``.csv``, ``.md`` (with the checks) and ``.png``; exits 1 when a check fails.

A free steel sphere R = 10 mm (quarter model) strikes a block of the same
steel (yield 835 MPa, elastic-perfectly plastic) at speeds from 0.5 to 30
times Johnson's yield-onset speed ``V_y = sqrt(26 Y^5 / (rho E*^4))``
(0.0866 m/s), Newmark, with the contact mesh refined to about a quarter of
the Hertz contact radius at each speed; the same impacts above yield are
run again with linear hardening (E/100).

Reference: the fit of Jackson, Green and Marghitu to finite-element impacts
of elastic-perfectly plastic spheres (Nonlinear Dynamics 60, 2010, 217;
:func:`fe_impact.physics.hertz.jgm_restitution`: e = 0.956, 0.888, 0.830,
0.729 at V/V_y = 2, 5, 10, 30). Shown beside it: Thornton's model (J. Appl.
Mech. 64, 1997; :func:`~fe_impact.physics.hertz.thornton_restitution`: 0.93,
0.77, 0.66, 0.50), a lower bound since it caps the pressure at first yield,
and the seed's eq. 14. Asserted (``check``): the FE within 5% of JGM and
above Thornton at 2-30 V_y, decreasing with speed, above 0.99 below yield,
the energy balance within 1e-3, and hardening raising e.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.fe.mesh import load_mesh
from fe_impact.output.files import write_csv, write_json
from fe_impact.physics import hertz
from fe_impact.solvers.dynamic import DynamicSolver
from validation import checks as ck
from validation.impact_cases import (
    NU,
    RHO,
    STEEL,
    E,
    R,
    plastic,
    sphere_block_mesh,
    sphere_impact_case,
)

logger = logging.getLogger(__name__)

YIELD = 835e6
E_STAR = hertz.effective_modulus(E, NU)
V_Y = hertz.yield_onset_speed(YIELD, RHO, E_STAR)
SPHERE_MASS = 4.0 / 3.0 * math.pi * R ** 3 * RHO
RATIOS = (0.5, 2.0, 5.0, 10.0, 30.0)
QUICK_RATIOS = (0.5, 5.0, 30.0)
#: Linear isotropic hardening of the comparison run: E/100 (2.1 GPa), the
#: order of the tangent modulus of a case-hardening steel such as 20CrMnTi
#: past yield; JGM's fit is for perfectly plastic spheres.
HARDENING = E / 100.0
#: FE restitution against the JGM fit, 2 <= V/V_y <= 30. JGM fitted their own
#: FE impacts (elastic-perfectly plastic, S_y/E' 0.001-0.01) with a scatter of
#: a few per cent; the mesh, the Poisson ratio and V_y's definition (JGM's
#: critical interference against the 1.6 Y criterion: 1.5% in V_y) add about
#: as much. 5% holds all of that and still catches Thornton's law (15-30% low
#: here) or a 3% stiffer contact at 30 V_y.
JGM_TOLERANCE = 0.05
#: Below yield only wave and integrator losses remain (Hunter: 0.2% of the
#: energy at 0.5 V_y, i.e. e > 0.999); 0.99 allows the coarse mesh's vibration.
ELASTIC_FLOOR = 0.99
#: kinetic + strain + penalty + plastic work is conserved by the average
#: acceleration scheme up to the contact switches (measured ~2e-4).
ENERGY_TOLERANCE = 1e-3


def thornton(ratio: float) -> float:
    """Thornton (1997) restitution at V/V_y (``hertz.thornton_restitution``)."""
    return hertz.thornton_restitution(ratio)


def seed_eq14(ratio: float) -> float:
    """The seed's eq. 14 at V/V_y (:func:`fe_impact.physics.seed.restitution`)."""
    from fe_impact.physics import seed

    return seed.restitution(ratio)


def jgm(ratio: float) -> float:
    """Jackson-Green-Marghitu (2010) at V/V_y, ``S_y/E*`` (``hertz.jgm_restitution``)."""
    return hertz.jgm_restitution(ratio, YIELD, E_STAR)


def run_speed(ratio: float, out: Path, coarse: bool = False, hardening: float = 0.0,
              solver: str = "newton") -> dict:
    """One impact at ``ratio`` x V_y; ``hardening`` the linear hardening modulus (Pa)."""
    speed = ratio * V_Y
    ref = hertz.impact(SPHERE_MASS, speed, R, E_STAR)
    a = math.sqrt(R * ref.delta_max)
    h = (0.5 if coarse else 0.25) * a
    folder = out / f"v{ratio:g}".replace(".", "p")
    mesh_file = sphere_block_mesh(folder, h, gap=0.05 * ref.delta_max, hemisphere=False,
                                  r_fine=max(2.0 * a, 4 * h))
    case = sphere_impact_case(mesh_file, speed, 0.05 * ref.delta_max / speed
                              + 1.6 * ref.contact_time, frames=10,
                              material=plastic(STEEL, YIELD, hardening), plastic_solver=solver)
    t = time.perf_counter()
    res = DynamicSolver(case, load_mesh(mesh_file)).run()
    m = res.measurements
    pl = res.info["plasticity"] or {}
    e = m.restitution
    th = hertz.thornton_impact(SPHERE_MASS, speed, R, E_STAR, 1.6 * YIELD)
    yielded = ratio >= 2
    return {"V_over_Vy": ratio, "speed": speed, "hardening_modulus": hardening,
            "h_contact_mm": h * 1e3,
            "n_dofs": res.info["n_dofs"], "steps": res.info["steps"],
            "seconds": time.perf_counter() - t, "restitution": e,
            "jgm": jgm(ratio), "error_vs_jgm": e / jgm(ratio) - 1.0 if e else None,
            "thornton": thornton(ratio) if yielded else None,
            "error_vs_thornton": (e / thornton(ratio) - 1.0) if yielded and e else None,
            "seed_eq14": seed_eq14(ratio) if yielded else None,
            "energy_error": m.energy_error,
            "dissipation_share": pl.get("dissipation", 0.0) * 4.0
            / (0.5 * SPHERE_MASS * speed ** 2),
            "max_plastic_strain": pl.get("max_equivalent_plastic_strain"),
            "zone_boundary_yielded": pl.get("boundary_yielded"),
            "plastic_iterations": pl.get("plastic_iterations"),
            "krylov_products": pl.get("krylov_products"),
            "newton_fallbacks": pl.get("newton_fallbacks"),
            "peak_force": 4.0 * m.peak_force, "peak_force_hertz": ref.force_max,
            "peak_force_thornton": th.force_max,
            "max_approach_um": m.max_approach * 1e6,
            "residual_indentation_um": m.residual_indentation * 1e6,
            "residual_indentation_thornton_um": th.residual * 1e6}


def run(quick: bool = False, out: str | Path = "out/plastic_impact") -> dict:
    """Perfectly plastic impacts at every ratio, and linear hardening above yield.

    ``quick``: coarse meshes (h = a/2) at V/V_y = 0.5, 5, 30, hardening at 30.
    """
    out = Path(out)
    ratios = QUICK_RATIOS if quick else RATIOS
    rows = [run_speed(r, out, coarse=quick) for r in ratios]
    hard = [run_speed(r, out / "hardening", coarse=quick, hardening=HARDENING)
            for r in ((30.0,) if quick else (2.0, 5.0, 10.0, 30.0))]
    return {"quick": quick, "yield_onset_speed": V_Y, "rows": rows, "hardening": hard}


def check(result: dict) -> list[ck.Check]:
    """The headline figures against their tolerances (see the constants above)."""
    rows = result["rows"]
    out = []
    for r in rows:
        j = r["V_over_Vy"]
        if j < 1.0:
            out.append(ck.at_least(f"e at {j:g} V_y (elastic)", r["restitution"],
                                   ELASTIC_FLOOR))
            continue
        out.append(ck.within(f"e at {j:g} V_y vs JGM", r["restitution"], r["jgm"],
                             JGM_TOLERANCE))
        out.append(ck.holds(f"e at {j:g} V_y above Thornton", r["restitution"] - r["thornton"],
                            r["restitution"] > r["thornton"], "e - e_Thornton > 0"))
    e = [r["restitution"] for r in rows]
    steps = np.diff(e)
    out.append(ck.holds("e decreases with speed", float(steps.max()), bool(np.all(steps < 0)),
                        "largest step in e < 0"))
    out.append(ck.at_most("energy error", max(r["energy_error"] for r in rows + result[
        "hardening"]), ENERGY_TOLERANCE))
    by_ratio = {r["V_over_Vy"]: r for r in rows}
    for h in result["hardening"]:
        pp = by_ratio.get(h["V_over_Vy"])
        if pp is not None:
            # hardening raises the contact pressure the plastic zone carries, so
            # less work is dissipated and more comes back
            out.append(ck.holds(f"hardening raises e at {h['V_over_Vy']:g} V_y",
                                h["restitution"] - pp["restitution"],
                                h["restitution"] > pp["restitution"], "e_hard - e > 0"))
    return out


WHY = """Why the curves differ. Thornton (1997) caps the contact pressure at the
first-yield value 1.6 Y for the rest of the impact. In the FE, as in the
finite-element impacts JGM fitted, the plastic zone stays contained under an
elastic surround well past first yield and the mean pressure rises towards
the fully plastic limit of about 3 Y, so the contact is stiffer, the dent
shallower and more of the energy comes back: Thornton's e is a lower bound,
15-30% below the FE at 5-30 V_y. JGM's fit, e = 1 - 0.0361 (S_y/E')^-0.114
ln(V*) (V* - 1)^(9.5 S_y/E'), comes from such FE impacts and is the
reference here. The seed's eq. 14, e = 1 - 0.035 ln(j) j^0.1645, has the
form of that fit but constants that fit no single material: for this steel
(S_y/E* = 0.0072) JGM's factor is 0.0361 (S_y/E')^-0.114 = 0.063 and its
exponent 9.5 S_y/E' = 0.069, while 0.035 would need S_y/E' = 1.3 and 0.1645
would need 0.017; it also has j where JGM have V* - 1 in the power. So eq. 14
loses only 60-75% of JGM's energy share and lies 2-9% above it at 2-30 V_y.
The remaining FE-JGM differences (a few per cent either way) are of the size
of JGM's own fitting scatter and of the definition of V_y (1.6 Y here, JGM's
critical interference: 1.5% in V_y).
"""
def report(result: dict, checks: list[ck.Check] | None = None) -> str:
    rows, hard = result["rows"], result["hardening"]

    def f(v, spec):
        return "-" if v is None else format(v, spec)

    lines = ["# Elastic-plastic impact: restitution against Jackson-Green-Marghitu (2010)", "",
             f"Free sphere R = 10 mm on a block, 20CrMnTi with Y = {YIELD / 1e6:.0f} MPa, "
             f"elastic-perfectly plastic; V_y = {V_Y:.4f} m/s (Johnson). Newmark.", "",
             "| V/V_y | v (m/s) | h (um) | DOFs | time (s) | e (FE) | JGM | FE vs JGM "
             "| Thornton | FE vs Thornton | seed eq. 14 | plastic work / KE | energy error |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['V_over_Vy']:g} | {r['speed']:.4g} | {r['h_contact_mm'] * 1e3:.0f} "
                     f"| {r['n_dofs']} | {r['seconds']:.0f} | {f(r['restitution'], '.4f')} | "
                     f"{r['jgm']:.3f} | {f(r['error_vs_jgm'], '+.1%')} | "
                     f"{f(r['thornton'], '.3f')} | {f(r['error_vs_thornton'], '+.1%')} | "
                     f"{f(r['seed_eq14'], '.3f')} | {r['dissipation_share']:.3f} | "
                     f"{f(r['energy_error'], '.1e')} |")
    lines += ["", WHY, "Peak force and residual indentation (permanent approach of both "
              "bodies) against Thornton's model; iterations (elastic trials included) and "
              "GMRES products of the Newmark plasticity:", "",
              "| V/V_y | peak force FE / Thornton (N) | residual FE / Thornton (um) "
              "| iterations | GMRES products |", "|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['V_over_Vy']:g} | {r['peak_force']:.0f} / "
                     f"{r['peak_force_thornton']:.0f} | {r['residual_indentation_um']:.3f} / "
                     f"{r['residual_indentation_thornton_um']:.3f} | {r['plastic_iterations']} "
                     f"| {r['krylov_products']} |")
    by_ratio = {r["V_over_Vy"]: r for r in rows}
    lines += ["", f"Linear isotropic hardening, H = E/100 = {HARDENING / 1e9:.2f} GPa, beside "
              "the perfectly plastic runs:", "",
              "| V/V_y | e perfectly plastic | e hardening | raised by | plastic work / KE "
              "(pp / hardening) | residual (um, pp / hardening) |", "|---|---|---|---|---|---|"]
    for h in hard:
        pp = by_ratio.get(h["V_over_Vy"])
        if pp is None:
            continue
        lines.append(f"| {h['V_over_Vy']:g} | {pp['restitution']:.4f} | "
                     f"{h['restitution']:.4f} | {h['restitution'] - pp['restitution']:+.4f} | "
                     f"{pp['dissipation_share']:.3f} / {h['dissipation_share']:.3f} | "
                     f"{pp['residual_indentation_um']:.3f} / "
                     f"{h['residual_indentation_um']:.3f} |")
    if checks is not None:
        lines += ["", "## Checks", "", ck.markdown(checks)]
    return "\n".join(lines) + "\n"


def plot(result: dict, path: Path) -> Path:
    """Restitution against V/V_y: FE, JGM, Thornton and the seed's eq. 14 (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows, hard = result["rows"], result["hardening"]
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    x = np.geomspace(1, 100, 100)
    y = np.array([jgm(v) for v in x])
    ax.plot(x, y, "C0-", label="Jackson-Green-Marghitu 2010")
    ax.fill_between(x, y * (1 - JGM_TOLERANCE), y * (1 + JGM_TOLERANCE), color="C0",
                    alpha=0.15, label=f"JGM +-{JGM_TOLERANCE:.0%}")
    ax.plot(x, [thornton(v) for v in x], "k-", label="Thornton 1997")
    ax.plot(x, [seed_eq14(v) for v in x], "k--", label="seed eq. 14")
    ax.plot([r["V_over_Vy"] for r in rows], [r["restitution"] for r in rows], "o",
            color="C3", label="FE, perfectly plastic")
    ax.plot([r["V_over_Vy"] for r in hard], [r["restitution"] for r in hard], "^",
            color="C2", label="FE, hardening E/100")
    ax.set(xscale="log", xlabel="V / V_y", ylabel="restitution e", ylim=(0.3, 1.05),
           title="Elastic-plastic sphere impact")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/plastic_impact"))
    p.add_argument("--quick", action="store_true",
                   help="coarse meshes, V/V_y = 0.5, 5, 30 (about a minute)")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    result = run(args.quick, args.out)
    checks = check(result)
    rows = result["rows"] + result["hardening"]
    write_csv(args.out / "plastic_impact.csv", list(rows[0]), [list(r.values()) for r in rows])
    write_json(args.out / "plastic_impact.json", result)
    text = report(result, checks)
    (args.out / "plastic_impact.md").write_text(text)
    if not args.no_plot:
        plot(result, args.out / "plastic_impact.png")
    print(text)
    return ck.finish("plastic_impact", checks, args.out)


if __name__ == "__main__":
    sys.exit(main())
