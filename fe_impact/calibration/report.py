"""Calibration report: ``report.md`` with tables and PNG plots beside calibration.json."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from fe_impact.calibration.records import Calibration, CalibrationRecord
from fe_impact.inputs import read_document
from fe_impact.output.files import atomic_path

logger = logging.getLogger(__name__)


def _fmt(v, spec=".4g", scale=1.0) -> str:
    return "-" if v is None else format(v * scale, spec)


def _gap(gap: float | None) -> str:
    if gap is None:
        from fe_impact.calibration.sweep import GAP_FRACTION, MAX_GAP

        return (f"{GAP_FRACTION:g} x the Hertz approach, at most {MAX_GAP * 1e6:g} um "
                "(per case in calibration.json)")
    return f"{gap * 1e6:g} um"


def write_calibration_report(out: Path, calibration: Calibration) -> Path:
    """Write ``report.md`` and its plots for a calibration (records with every section)."""
    cases = calibration.cases
    settings = calibration.settings or {}
    plots = []
    for name, fn in (("force_time.png", _plot_histories), ("parameters.png", _plot_parameters),
                     ("stress.png", _plot_stress)):
        try:
            if fn(out, cases, out / name):
                plots.append(name)
        except Exception as exc:  # a missing plot must not lose the tables
            logger.warning("plot %s skipped: %s", name, exc)
    lines = ["# fe-impact calibration", "",
             f"Settings: level `{settings.get('level')}`, integrator "
             f"`{settings.get('integrator')}`, P{settings.get('order')}, initial gap "
             f"{_gap(settings.get('gap'))}. Wall time {_fmt(calibration.wall_time_s, '.0f')} s.",
             "",
             "## FE measurements", "",
             "| case | v (m/s) | m_eff (kg) | F_max (N) | delta_max (um) | t_c (us) | e "
             "| dent (um) | K (N/m^xi) | xi | fit R^2 | k_mesh at nominal load (N/m) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in cases:
        fe = c.fe
        lines.append(f"| {c.id} | {c.impact_speed:.4g} | {_fmt(c.effective_mass)} | "
                     f"{_fmt(fe.peak_force)} | {_fmt(fe.max_approach, '.4g', 1e6)} | "
                     f"{_fmt(fe.contact_time, '.4g', 1e6)} | {_fmt(fe.restitution, '.4f')}"
                     f" | {_fmt(fe.residual_indentation, '.3g', 1e6)}"
                     f" | {_fmt(fe.stiffness_k, '.4g')} | "
                     f"{_fmt(fe.stiffness_exponent, '.3f')} | "
                     f"{_fmt(fe.stiffness_fit_r2, '.5f')} | {_fmt(fe.mesh_stiffness)} |")
    lines += ["", "## IMPACT parameters: fitted against the seed's closed forms (eq. 12-17)", "",
              "| case | k | closed k | exponent | closed | cmax (N s/m) | closed | d (um) "
              "| closed | force residual | restitution error |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in cases:
        i, cf, q = c.impact, c.closed_form, c.fit_quality
        lines.append(f"| {c.id} | {_fmt(i.k)} | {_fmt(cf.k)} | "
                     f"{_fmt(i.exponent, '.3f')} | {_fmt(cf.exponent, '.3f')} | "
                     f"{_fmt(i.cmax)} | {_fmt(cf.cmax)} | "
                     f"{_fmt(i.d, '.4g', 1e6)} | {_fmt(cf.d, '.4g', 1e6)} | "
                     f"{_fmt(q.residual_force_rms, '.2%')} | "
                     f"{_fmt(q.restitution_error, '.2e')} |")
    with_models = [c for c in cases if c.restitution_models is not None]
    if with_models:
        lines += ["", "## Restitution against the seed's eq. 14", "",
                  "FE: elastic-plastic (J2) teeth. eq. 14 with the yield-onset speed of eq. 15 "
                  "(a solid sphere of the steel) and with this tooth pair's own: the speed at "
                  "which its Hertz impact (TCA ellipse, effective mass) reaches p0 = 1.6 Y.",
                  "",
                  "| case | v (m/s) | e FE | v_y eq. 15 (m/s) | v/v_y | e eq. 14 | "
                  "v_y tooth (m/s) | v/v_y | e eq. 14 |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for c in with_models:
            r = c.restitution_models
            lines.append(f"| {c.id} | {c.impact_speed:.4g} | "
                         f"{c.fe.restitution:.4f} | {r.v_y_eq15:.4g} | "
                         f"{r.yield_ratio_eq15:.3g} | {r.seed_eq14:.4f} | "
                         f"{r.v_y_tooth:.4g} | {r.yield_ratio_tooth:.3g} | "
                         f"{r.seed_eq14_tooth:.4f} |")
    lines += ["", "## Hysteresis models: chi for the measured restitution", ""]
    models = sorted({k for c in cases for k in c.hysteresis_chi or {}})
    if models:
        lines += ["| case | " + " | ".join(models) + " |",
                  "|---|" + "---|" * len(models)]
        for c in cases:
            chis = c.hysteresis_chi or {}
            lines.append(f"| {c.id} | " + " | ".join(
                _fmt(chis[m].chi if m in chis else None, ".4g") for m in models) + " |")
    lines += ["", "## Time per case (s)", "",
              "FE = set-up (assembly, factorisation, contact condensation) + time steps + "
              "output (stress fields and VTU frames).", "",
              "| case | DOFs | steps | mesh | FE set-up | FE steps | FE output | fit | total |",
              "|---|---|---|---|---|---|---|---|---|"]
    for c in cases:
        t = c.timings_s or {}
        lines.append(f"| {c.id} | {c.model.n_dofs} | {c.model.steps} | "
                     f"{_fmt(t.get('mesh'), '.1f')} | {_fmt(t.get('fe_setup'), '.1f')} | "
                     f"{_fmt(t.get('fe_steps'), '.1f')} | {_fmt(t.get('fe_output'), '.1f')} | "
                     f"{_fmt(t.get('fit'), '.1f')} | {_fmt(t.get('total'), '.1f')} |")
    if cases:
        total = sum((c.timings_s or {}).get("total", 0.0) for c in cases)
        lines += ["", f"Sum over cases {total:.0f} s; wall time of this run "
                  f"{_fmt(calibration.wall_time_s, '.0f')} s (resumed cases cost nothing "
                  "the second time)."]
    lines += [""] + [f"![{p}]({p})" for p in plots] + [""]
    if calibration.mesh_cycle:
        from fe_impact.calibration.meshcycle_report import report_lines

        lines += report_lines(calibration.mesh_cycle)
    path = out / "report.md"
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines))
    return path


def _history(out: Path, case: CalibrationRecord) -> dict | None:
    path = out / "cases" / case.id / "fe" / "summary.json"
    if not path.is_file():
        return None
    return read_document(path, "FE summary", syntax="json")


def _plot_histories(out: Path, cases: tuple[CalibrationRecord, ...], path: Path) -> bool:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fe_impact.physics.laws import ImpactLaw, simulate_impact

    fig, ax = plt.subplots(1, 2, figsize=(12, 4.5))
    for c in cases:
        s = _history(out, c)
        if s is None:
            continue
        h = s["history"]
        t, f, d = (np.asarray(h[k]) for k in ("time", "contact_force", "approach"))
        t0 = s.get("first_touch") or 0.0
        line, = ax[0].plot((t - t0) * 1e6, f, lw=1.2, label=f"{c.id} FE")
        i = c.impact
        run = simulate_impact(ImpactLaw(i.k, i.exponent, i.cmax, i.d), c.effective_mass,
                              c.fe.impact_velocity)
        ax[0].plot(run.time * 1e6, run.force, "--", color=line.get_color(), lw=1)
        on = d > 0
        ax[1].plot(d[on] * 1e6, f[on], color=line.get_color(), lw=1.2)
        ax[1].plot(run.delta * 1e6, run.force, "--", color=line.get_color(), lw=1)
    ax[0].set(xlabel="time from first touch (us)", ylabel="contact force (N)",
              title="force against time: FE (solid), fitted IMPACT law (dashed)")
    ax[1].set(xlabel="approach (um)", ylabel="contact force (N)",
              title="force against approach (hysteresis loop)")
    for a in ax:
        a.grid(alpha=0.3)
    ax[0].legend(fontsize=7)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return True


def _plot_parameters(out: Path, cases: tuple[CalibrationRecord, ...], path: Path) -> bool:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    fig, ax = plt.subplots(2, 3, figsize=(15, 8))
    keys = (("k", "k (N/m^exponent)"), ("exponent", "exponent"), ("cmax", "cmax (N s/m)"),
            ("d", "d (m)"))
    panels = ax.ravel()
    for stage in sorted({c.stage for c in cases}):
        cs = sorted((c for c in cases if c.stage == stage), key=lambda c: c.impact_speed)
        v = [c.impact_speed for c in cs]
        for a, (k, label) in zip(panels[:4], keys, strict=True):
            line, = a.plot(v, [getattr(c.impact, k) for c in cs], "o-",
                           label=f"stage {stage} fit")
            a.plot(v, [getattr(c.closed_form, k, np.nan) for c in cs], "s--",
                   color=line.get_color(), label=f"stage {stage} closed form")
            a.set(xlabel="impact speed (m/s)", ylabel=label, xscale="log")
        a = panels[4]
        line, = a.plot(v, [c.fe.restitution for c in cs], "o-", label=f"stage {stage} FE")
        models = [c.restitution_models for c in cs]
        a.plot(v, [getattr(r, "seed_eq14", np.nan) for r in models], "s--",
               color=line.get_color(), label=f"stage {stage} eq. 14 (v_y eq. 15)")
        a.plot(v, [getattr(r, "seed_eq14_tooth", np.nan) for r in models], "^:",
               color=line.get_color(), label=f"stage {stage} eq. 14 (v_y tooth)")
        a.set(xlabel="impact speed (m/s)", ylabel="restitution e", xscale="log",
              title="restitution")
    # Ticks at the case speeds: a log axis spanning about a decade labels its
    # minor ticks, which overlap.
    speeds = sorted({c.impact_speed for c in cases})
    for a in panels[:5]:
        a.grid(alpha=0.3)
        a.xaxis.set_minor_formatter(NullFormatter())
        a.set_xticks(speeds, [f"{v:.3g}" for v in speeds])
    panels[0].legend(fontsize=7)
    panels[4].legend(fontsize=7)
    panels[5].axis("off")
    fig.suptitle("IMPACT parameters against impact speed")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return True


def _plot_stress(out: Path, cases: tuple[CalibrationRecord, ...], path: Path) -> bool:
    """3-D von Mises field at peak force of the hardest impact (pyvista off-screen)."""
    import pyvista as pv

    c = max(cases, key=lambda c: c.fe.peak_force)
    s = _history(out, c)
    if s is None or not s["fields"]["frames"]:
        return False
    # The frame nearest the peak: the fields are written at every few output
    # times only (sweep.VTU_FRAME_STRIDE), so index the frames by their own times.
    times = np.asarray(s["fields"].get("frame_times") or s["history"]["time"])
    k = int(np.argmin(np.abs(times - s["time_of_peak_force"])))
    k = min(k, len(s["fields"]["frames"]) - 1)
    grid = pv.read(out / "cases" / c.id / "fe" / s["fields"]["frames"][k])
    pv.OFF_SCREEN = True
    # Off screen without an X server VTK falls back to its own context after
    # printing a warning about the missing display; keep the terminal clean.
    pv.vtk_verbosity("off")
    p = pv.Plotter(off_screen=True, window_size=(1000, 750))
    p.add_mesh(grid, scalars="von_mises", cmap="turbo", show_edges=False,
               scalar_bar_args={"title": "von Mises (Pa)"})
    p.add_text(f"{c.id}: von Mises stress at peak force {c.fe.peak_force:.4g} N",
               font_size=10)
    p.view_isometric()
    with atomic_path(path) as tmp:
        p.screenshot(str(tmp))
    p.close()
    return True
