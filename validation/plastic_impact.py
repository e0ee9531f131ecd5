"""Elastic-plastic impact: restitution of a sphere striking a block against Thornton (1997).

Run ``python validation/plastic_impact.py --out out/plastic_impact`` (a few
minutes; ``--quick`` about a minute). Writes ``plastic_impact.json``,
``.csv``, ``.md`` and ``.png``.

A free steel sphere R = 10 mm (quarter model) strikes a block of the same
steel (yield 835 MPa, elastic-perfectly plastic as in Thornton's model) at
speeds from 0.5 to 30 times Johnson's yield-onset speed
``V_y = sqrt(26 Y^5 / (rho E*^4))`` (0.0866 m/s), Newmark, with the contact
mesh refined to about a quarter of the Hertz contact radius at each speed.
Compared with Thornton's model (closed form,
:func:`fe_impact.physics.hertz.thornton_restitution`: e = 0.93, 0.77, 0.66, 0.50 at
V/V_y = 2, 5, 10, 30) and the seed's eq. 14 (Jackson-Green form as printed
there).
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

from fe_impact.fe.case import load_case
from fe_impact.output.files import write_csv, write_json
from fe_impact.physics import hertz
from fe_impact.solvers.dynamic import DynamicSolver
from validation.impact_cases import NU, RHO, E, R, sphere_block_mesh, write_sphere_impact

logger = logging.getLogger(__name__)

YIELD = 835e6
E_STAR = hertz.effective_modulus(E, NU)
V_Y = hertz.yield_onset_speed(YIELD, RHO, E_STAR)
SPHERE_MASS = 4.0 / 3.0 * math.pi * R ** 3 * RHO
RATIOS = (0.5, 2.0, 5.0, 10.0, 30.0)
#: Thornton's e is for spheres; the tolerance of the comparison (issue acceptance).
TOLERANCE = 0.15


def thornton(ratio: float) -> float:
    """Thornton (1997) restitution at V/V_y (``hertz.thornton_restitution``)."""
    return hertz.thornton_restitution(ratio)


def seed_eq14(ratio: float) -> float:
    """The seed's eq. 14 at V/V_y (:func:`fe_impact.physics.hertz.seed_restitution`)."""
    return hertz.seed_restitution(ratio)


def run_speed(ratio: float, out: Path, coarse: bool = False, hardening: float = 0.0,
              solver: str = "newton") -> dict:
    speed = ratio * V_Y
    ref = hertz.impact(SPHERE_MASS, speed, R, E_STAR)
    a = math.sqrt(R * ref.delta_max)
    h = (0.5 if coarse else 0.25) * a
    folder = out / f"v{ratio:g}".replace(".", "p")
    mesh = sphere_block_mesh(folder, h, gap=0.05 * ref.delta_max, hemisphere=False,
                             r_fine=max(2.0 * a, 4 * h))
    case = write_sphere_impact(folder, mesh, speed, 0.05 * ref.delta_max / speed
                               + 1.6 * ref.contact_time, frames=10)
    text = case.read_text().replace(
        "density = 7860\n", f"density = 7860\nyield_strength = {YIELD}\n"
        f"hardening_modulus = {hardening}\n")
    text = text.replace('integrator = "newmark"\n',
                        f'integrator = "newmark"\nplastic_solver = "{solver}"\n')
    case.write_text(text)
    t = time.perf_counter()
    dyn = DynamicSolver(load_case(case))
    res = dyn.run()
    m = res.measurements
    pl = res.info["plasticity"] or {}
    e = m["restitution"]
    th = hertz.thornton_impact(SPHERE_MASS, speed, R, E_STAR, 1.6 * YIELD)
    return {"V_over_Vy": ratio, "speed": speed, "h_contact_mm": h * 1e3,
            "n_dofs": res.info["n_dofs"], "steps": res.info["steps"],
            "seconds": time.perf_counter() - t, "restitution": e,
            "thornton": thornton(ratio) if ratio >= 2 else None,
            "error_vs_thornton": (e / thornton(ratio) - 1.0) if ratio >= 2 and e else None,
            "seed_eq14": seed_eq14(ratio) if ratio >= 2 else None,
            "energy_error": m["energy_error"],
            "dissipation_share": pl.get("dissipation", 0.0) * 4.0
            / (0.5 * SPHERE_MASS * speed ** 2),
            "max_plastic_strain": pl.get("max_equivalent_plastic_strain"),
            "zone_boundary_yielded": pl.get("boundary_yielded"),
            "plastic_iterations": pl.get("plastic_iterations"),
            "krylov_products": pl.get("krylov_products"),
            "newton_fallbacks": pl.get("newton_fallbacks"),
            "peak_force": 4.0 * m["peak_force"], "peak_force_hertz": ref.force_max,
            "peak_force_thornton": th.force_max,
            "max_approach_um": m["max_approach"] * 1e6,
            "residual_indentation_um": m["residual_indentation"] * 1e6,
            "residual_indentation_thornton_um": th.residual * 1e6}


def report(rows: list[dict]) -> str:
    lines = ["# Elastic-plastic impact: restitution against Thornton (1997)", "",
             f"Free sphere R = 10 mm on a block, 20CrMnTi with Y = {YIELD / 1e6:.0f} MPa, "
             f"elastic-perfectly plastic; V_y = {V_Y:.4f} m/s (Johnson). Newmark.", "",
             "| V/V_y | v (m/s) | h (um) | DOFs | time (s) | e (FE) | Thornton | FE vs Thornton "
             "| seed eq. 14 | plastic work / KE | energy error |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        def f(v, spec):
            return "-" if v is None else format(v, spec)
        lines.append(f"| {r['V_over_Vy']:g} | {r['speed']:.4g} | {r['h_contact_mm'] * 1e3:.0f} "
                     f"| {r['n_dofs']} | {r['seconds']:.0f} | {f(r['restitution'], '.4f')} | "
                     f"{f(r['thornton'], '.3f')} | {f(r['error_vs_thornton'], '+.1%')} | "
                     f"{f(r['seed_eq14'], '.3f')} | {r['dissipation_share']:.3f} | "
                     f"{f(r['energy_error'], '.1e')} |")
    lines += ["", "Peak force and residual indentation (permanent approach of both bodies) "
              "against Thornton's model; iterations (elastic trials included) and GMRES "
              "products of the Newmark plasticity:", "",
              "| V/V_y | peak force FE / Thornton (N) | residual FE / Thornton (um) "
              "| iterations | GMRES products |", "|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['V_over_Vy']:g} | {r['peak_force']:.0f} / "
                     f"{r['peak_force_thornton']:.0f} | {r['residual_indentation_um']:.3f} / "
                     f"{r['residual_indentation_thornton_um']:.3f} | {r['plastic_iterations']} "
                     f"| {r['krylov_products']} |")
    return "\n".join(lines) + "\n"


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    x = np.geomspace(1, 100, 100)
    ax.plot(x, [thornton(max(v, 2.0)) if v >= 2 else np.nan for v in x], "k-",
            label="Thornton 1997")
    ax.plot(x, [seed_eq14(max(v, 2.0)) if v >= 2 else np.nan for v in x], "k--",
            label="seed eq. 14")
    ax.fill_between(x, [thornton(max(v, 2)) * (1 - TOLERANCE) for v in x],
                    [thornton(max(v, 2)) * (1 + TOLERANCE) for v in x], color="0.85",
                    label="Thornton +-15%")
    ax.plot([r["V_over_Vy"] for r in rows], [r["restitution"] for r in rows], "o",
            color="C3", label="FE (J2, Newmark)")
    ax.set(xscale="log", xlabel="V / V_y", ylabel="restitution e", ylim=(0.2, 1.05),
           title="Elastic-plastic sphere impact")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/plastic_impact"))
    p.add_argument("--quick", action="store_true", help="coarse meshes, V/V_y = 0.5, 5, 30")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    ratios = (0.5, 5.0, 30.0) if args.quick else RATIOS
    rows = [run_speed(r, args.out, coarse=args.quick) for r in ratios]
    write_csv(args.out / "plastic_impact.csv", list(rows[0]), [list(r.values()) for r in rows])
    write_json(args.out / "plastic_impact.json", {"yield_onset_speed": V_Y, "rows": rows})
    text = report(rows)
    (args.out / "plastic_impact.md").write_text(text)
    plot(rows, args.out / "plastic_impact.png")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
