"""Calibration report: ``report.md`` with tables and PNG plots beside calibration.json."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fe_impact.calibration.measurement import GAP_FRACTION, MAX_GAP
from fe_impact.calibration.records import Calibration, CalibrationRecord
from fe_impact.errors import CalibrationError
from fe_impact.inputs import read_document
from fe_impact.output.drawing import Draw, draw_here
from fe_impact.output.files import atomic_path

logger = logging.getLogger(__name__)


def _fmt(v, spec=".4g", scale=1.0) -> str:
    return "-" if v is None else format(v * scale, spec)


def _impact_load(cases) -> str:
    """The load of the impacts' tangent stiffness column (``Settings.nominal_load``;
    not the mesh cycle's nominal load, that of the seed presets)."""
    loads = sorted({c.fe.nominal_load for c in cases})
    return " / ".join(f"{v:g} N" for v in loads) or "the nominal load"


def _gap(gap: float | None) -> str:
    if gap is None:
        return (f"{GAP_FRACTION:g} x the Hertz approach, at most {MAX_GAP * 1e6:g} um "
                "(per case in calibration.json)")
    return f"{gap * 1e6:g} um"


def _span(values, spec: str = ".3g") -> str:
    """``lo-hi`` of ``values`` (one value if they agree to the format)."""
    lo, hi = format(min(values), spec), format(max(values), spec)
    return lo if lo == hi else f"{lo}-{hi}"


#: A damping range wider than this (largest over smallest) is reported as undetermined.
UNDETERMINED_SPREAD = 1.1


def _undetermined_damping(cases) -> list[str]:
    """Lines on the cases whose history does not determine ``cmax`` and ``d``: laws
    that fit it equally well (:data:`~fe_impact.calibration.impact_fit.EQUAL_FIT`)
    span more than :data:`UNDETERMINED_SPREAD` in either."""
    from fe_impact.calibration.impact_fit import EQUAL_FIT

    wide = []
    for c in cases:
        q = c.fit_quality
        if q is None or q.cmax_range is None or q.d_range is None:
            continue
        (c_lo, c_hi), (d_lo, d_hi) = q.cmax_range, q.d_range
        if c_hi > UNDETERMINED_SPREAD * c_lo or d_hi > UNDETERMINED_SPREAD * d_lo:
            wide.append(f"- {c.id} (e = {c.fe.restitution:.5f}): cmax {c_lo:.3g}-{c_hi:.3g} "
                        f"N s/m, d {d_lo * 1e6:.3g}-{d_hi * 1e6:.3g} um")
    if not wide:
        return []
    return ["", f"The history does not determine the damping of these impacts: laws that "
            f"reproduce it equally well (force and restitution residual within {EQUAL_FIT:.1%} "
            "of the best; the other starts' optima and the residual's quadratic model about "
            "the best) span these ranges. The table gives the best fit; the nearly elastic "
            "impacts lose too little energy for the history to tell cmax from d.", "", *wide]


def _fit_remarks(cases) -> list[str]:
    """Lines on the fits to read with care: those the optimiser did not see converge,
    those with a parameter stopped at its search bound, and those whose figures come
    from the fast model (:func:`~fe_impact.calibration.impact_fit.fit_impact_law`'s
    ``message``: the optimiser's status, then each such remark)."""
    rows = []
    for c in cases:
        q = c.fit_quality
        if q is None:
            continue
        status, *remarks = q.message.split("; ") if q.message else [""]
        if not q.success:
            remarks.insert(0, f"not converged ({status or 'no status'})")
        if remarks:
            rows.append(f"- {c.id}: {'; '.join(remarks)}")
    if not rows:
        return []
    return ["", "Fits to read with care. A parameter at a bound of its search range (the "
            "exponent's, or d's against the largest approach) stopped there: the history "
            "would take it further, outside the range the law is fitted in, and the table "
            "gives the bound. A fit not converged gives the optimiser's last point.", "",
            *rows]


#: The terminal summary's words for the kinds of FE impact other than the flanks' in mesh.
_KIND_WORDS = {"switch": "ratio-switch", "corner-approach": "approach-corner",
               "corner-recess": "recess-corner"}


def terminal_summary(doc: dict) -> list[str]:
    """A few lines per stage of a calibration.json document, for the terminal: what
    the FE impacts fitted against the closed form, and the mesh cycle's single-pair
    stiffness along the path (report.md has the tables)."""
    lines = []
    cases = doc.get("cases", [])
    cycle = doc.get("mesh_cycle") or {}
    for stage in sorted({int(c["stage"]) for c in cases} | {int(s) for s in cycle}):
        mine = [c for c in cases if int(c["stage"]) == stage]
        head = f"stage {stage}:"
        # a line per kind of contact: a flank's law beside a tip edge's would span both
        for kind in dict.fromkeys(c.get("kind", "mesh") for c in mine):
            group = [c for c in mine if c.get("kind", "mesh") == kind]
            law = [c["impact"] for c in group]
            closed = group[0]["closed_form"]
            speeds = [1e3 * c["impact_speed"] for c in group]
            what = "" if kind == "mesh" else f"{_KIND_WORDS.get(kind, kind)} "
            lines.append(
                f"{head} {len(group)} FE {what}impact{'s' * (len(group) > 1)} at "
                f"{_span(speeds)} mm/s: K {_span([v['k'] for v in law])} N/m^e, exponent "
                f"{_span([v['exponent'] for v in law])} (closed form {closed['k']:.3g}, "
                f"{closed['exponent']:.3g}), cmax {_span([v['cmax'] for v in law])} N s/m")
            head = " " * len(head)
        path = cycle.get(str(stage))
        if path:
            rolls = path["roll_angle_deg"]
            lines.append(
                f"{head} mesh cycle at {len(rolls)} positions ({min(rolls):+.1f} to "
                f"{max(rolls):+.1f} deg of roll): K {_span(path['k'])} N/m^e, exponent "
                f"{_span(path['exponent'])}; single-pair stiffness at "
                f"{_span(path['nominal_force'])} N {_span(path['nominal_stiffness'])} N/m")
    return lines


# -- what the flank friction changes --------------------------------------------------------
#: The impact measurements the friction section compares (FEMeasurements fields).
_FRICTION_IMPACT = ("peak_force", "restitution_measured", "contact_time", "max_approach",
                    "friction_dissipation")


def friction_effect(gearset_text: str, records, positions, companions) -> dict | None:
    """What the gear set's flank friction changes, for ``calibration.json`` and the report.

    Each frictionless companion (:func:`~fe_impact.calibration.planning.friction_companions`)
    is set beside its frictional case: for the impact, the FE measurements
    (:data:`_FRICTION_IMPACT`: peak force [N], measured restitution, contact time [s],
    largest approach [m], friction's dissipation [J]) with and without friction and
    their relative change; for the mesh-cycle position, the loaded transmission error
    (the pinion hub's approach along the line of action, m: this single pair carrying
    the torque) and the normal contact force [N] at two of its torques [N m], the
    smallest load step of the fit (from
    :data:`~fe_impact.calibration.meshcycle.FIT_MIN_FORCE`) and the largest. Both runs
    of a position are loaded by the same torques (the static case presses the pinion
    by a torque), so they compare step by step.

    Returns
    -------
    dict or None
        ``mu_static``, ``mu_dynamic``, ``impact`` and ``position`` (None where the run
        has no companion of that kind), ``solved_frictionless`` (the cases that fell
        back to frictionless flanks at the frictional solve's limits); None for
        frictionless flanks.
    """
    import tomllib

    from fe_impact.gears import gearset_from_dict

    friction = gearset_from_dict(tomllib.loads(gearset_text)).friction
    if not friction.active:
        return None
    out: dict = {"mu_static": friction.mu_static, "mu_dynamic": friction.mu_dynamic,
                 "impact": None, "position": None,
                 "solved_frictionless": [r.id for r in (*records, *positions)
                                         if not any(r.friction or ())]}
    for comp in companions:
        if isinstance(comp, CalibrationRecord):
            base = next((r for r in records if (r.stage, r.kind, r.impact_speed)
                         == (comp.stage, comp.kind, comp.impact_speed)), None)
            if base is not None and any(base.friction or ()):
                out["impact"] = _impact_effect(base, comp)
        else:
            base = next((p for p in positions if (p.stage, p.contact, p.roll_angle_deg)
                         == (comp.stage, comp.contact, comp.roll_angle_deg)), None)
            if base is not None and any(base.friction):
                out["position"] = _position_effect(base, comp)
    return out


def _impact_effect(rough: CalibrationRecord, smooth: CalibrationRecord) -> dict:
    """An impact's FE measurements with (``rough``) and without friction (``smooth``)."""
    def values(r: CalibrationRecord) -> dict:
        return {k: getattr(r.fe, k) for k in _FRICTION_IMPACT}

    with_, without = values(rough), values(smooth)
    return {"id": rough.id, "stage": rough.stage, "impact_speed": rough.impact_speed,
            "with": with_, "without": without,
            "relative_change": {k: with_[k] / without[k] - 1.0 for k in _FRICTION_IMPACT
                                if with_[k] is not None and without[k]}}


def _position_effect(rough, smooth) -> dict:
    """A mesh-cycle position's loaded TE and contact force with (``rough``) and without
    friction (``smooth``) at its smallest fitted and its largest load step."""
    from fe_impact.calibration.meshcycle import FIT_MIN_FORCE

    forces = np.asarray(smooth.forces)
    fitted = np.flatnonzero(forces >= FIT_MIN_FORCE * (1.0 - 1e-3))
    steps = [int(fitted[np.argmin(forces[fitted])]), int(np.argmax(forces))]
    te_with = [rough.fe_approaches[i] for i in steps]
    te_without = [smooth.fe_approaches[i] for i in steps]
    return {"id": rough.id, "stage": rough.stage, "roll_angle_deg": rough.roll_angle_deg,
            "torques": [abs(smooth.torques[i]) for i in steps],
            "te_with": te_with, "te_without": te_without,
            "te_relative_change": [a / b - 1.0 for a, b in zip(te_with, te_without,
                                                               strict=True)],
            "force_with": [rough.forces[i] for i in steps],
            "force_without": [smooth.forces[i] for i in steps]}


def friction_lines(effect: dict | None) -> list[str]:
    """The report's section on the flank friction (:func:`friction_effect`)."""
    if effect is None:
        return ["", "## Flank friction", "", "Frictionless flanks (the gear set's "
                "[friction] gives mu_static = mu_dynamic = 0)."]
    lines = ["", "## Flank friction", "",
             f"The FE contact of every impact and mesh-cycle position has Coulomb friction, "
             f"mu_static {effect['mu_static']:g} and mu_dynamic {effect['mu_dynamic']:g} "
             "(the gear set's [friction]; a static position takes mu_static). One impact "
             "and one position were solved again frictionless; what friction changes there:"]
    fell = effect.get("solved_frictionless") or []
    if fell:
        lines += ["", f"Solved frictionless, the frictional solve refusing them (a contact "
                  f"zone too large to condense the friction on; the log says why): "
                  f"{', '.join(fell)}."]
    imp = effect.get("impact")
    if imp:
        w, o, d = imp["with"], imp["without"], imp["relative_change"]
        lines += ["", f"Impact {imp['id']} ({imp['impact_speed'] * 1e3:.4g} mm/s):", "",
                  "| | F_max (N) | e | t_c (us) | delta_max (um) | friction dissipation (uJ) |",
                  "|---|---|---|---|---|---|"]
        for name, v in (("with friction", w), ("frictionless", o)):
            lines.append(f"| {name} | {_fmt(v['peak_force'])} | "
                         f"{_fmt(v['restitution_measured'], '.5f')} | "
                         f"{_fmt(v['contact_time'], '.4g', 1e6)} | "
                         f"{_fmt(v['max_approach'], '.4g', 1e6)} | "
                         f"{_fmt(v['friction_dissipation'], '.3g', 1e6)} |")
        lines.append(f"| change | {_fmt(d.get('peak_force'), '+.3%')} | "
                     f"{_fmt(d.get('restitution_measured'), '+.3%')} | "
                     f"{_fmt(d.get('contact_time'), '+.3%')} | "
                     f"{_fmt(d.get('max_approach'), '+.3%')} | |")
    pos = effect.get("position")
    if pos:
        lines += ["", f"Mesh-cycle position {pos['id']} (stage {pos['stage']}, roll "
                  f"{pos['roll_angle_deg']:+.3f} deg): the loaded transmission error (the "
                  "pinion's approach along the line of action, this pair carrying the torque "
                  "alone) at two pinion torques. The quasi-static positions hold no rolling: "
                  "their friction acts on the slips of the flanks' deformation, not on the "
                  "mesh's sliding, which reverses at the pitch point.", "",
                  "| pinion torque (N m) | TE with friction (um) | frictionless (um) | change "
                  "| normal force with / without (N) |",
                  "|---|---|---|---|---|"]
        for k, torque in enumerate(pos["torques"]):
            lines.append(f"| {torque:.4g} | {pos['te_with'][k] * 1e6:.4f} | "
                         f"{pos['te_without'][k] * 1e6:.4f} | "
                         f"{pos['te_relative_change'][k]:+.3%} | "
                         f"{pos['force_with'][k]:.4g} / {pos['force_without'][k]:.4g} |")
    return lines


# -- tooth-root bending stress ----------------------------------------------------------------
#: Folder of the run's tooth-root stresses, one ``stage<n>.json`` a stage.
ROOT_STRESS = "root_stress"


def root_stress_jobs(out: Path, gearset_text: str, positions, level: str,
                     cache: Path) -> list:
    """Drawing jobs (:data:`~fe_impact.output.drawing.Job`) computing each stage's
    tooth-root stresses (:func:`fe_impact.calibration.root_stress.fe_root_stress`,
    about 20 s of CPU a stage at the coarse level) under the largest force of its mesh-cycle
    flank positions, at the positions' mesh ``level``; none without positions."""
    return [(f"{ROOT_STRESS}/stage{s}.json", write_root_stress,
             (gearset_text, s, f, level, str(cache), out / ROOT_STRESS / f"stage{s}.json"))
            for s, f in sorted(root_stress_forces(positions).items())]


def root_stress_forces(positions) -> dict[int, float]:
    """Per stage, the largest force [N] of its mesh-cycle flank positions (records, or
    cases: their ``contact``, ``stage`` and ``forces``)."""
    force: dict[int, float] = {}
    for p in positions:
        if p.contact == "flank":
            force[p.stage] = max(force.get(p.stage, 0.0), max(p.forces))
    return force


def root_stress_task(gearset_text: str, stage: int, level: str, cache: str, path: Path,
                     *positions) -> tuple[bool, str]:
    """:func:`write_root_stress` of ``stage`` under the largest force of the finished
    flank ``positions`` (its mesh-cycle records), as a drawing job's outcome
    (:func:`~fe_impact.output.drawing.drawn`): run on the sweep's workers once the
    stage's positions are done (:func:`fe_impact.calibration.execution.start_root_stresses`)."""
    from fe_impact.output.drawing import drawn

    return drawn(write_root_stress, gearset_text, stage,
                 root_stress_forces(positions)[stage], level, cache, path)


def write_root_stress(gearset_text: str, stage: int, force: float, level: str, cache: str,
                      path: Path) -> Path:
    """One stage's tooth-root stresses under the normal ``force`` [N], to ``path`` (JSON)."""
    import tomllib

    from fe_impact.calibration.root_stress import fe_root_stress
    from fe_impact.gears import gearset_from_dict
    from fe_impact.output.files import write_json

    result = fe_root_stress(gearset_from_dict(tomllib.loads(gearset_text)), stage, force,
                            level=level, cache=cache)
    return write_json(path, result.to_dict())


def _root_stress_lines(out: Path, written: list[str]) -> list[str]:
    """The report's tooth-root section from the stages' files that were written."""
    names = sorted(n for n in written if n.startswith(f"{ROOT_STRESS}/"))
    if not names:
        return []
    try:
        from fe_impact.calibration.root_stress import StageRootStress, report_lines

        return [""] + report_lines([StageRootStress.from_dict(read_document(
            out / n, "root stress", CalibrationError, "json")) for n in names])
    except Exception as exc:   # noqa: BLE001 - an optional section: the report keeps the rest
        logger.warning("tooth-root stress section skipped: %s: %s", type(exc).__name__, exc)
        return []


def write_calibration_report(out: Path, calibration: Calibration,
                             draw: Draw = draw_here, jobs=(),
                             started: Callable[[], list[str]] | None = None) -> Path:
    """Write ``report.md`` and its plots for a calibration (records with every section).

    The plots, and the further ``jobs`` (the tooth-root stresses,
    :func:`root_stress_jobs`), are drawn by ``draw`` while the tables are written;
    ``started`` waits for jobs started before (the sweep's tooth-root stresses) and
    returns the files they wrote.
    """
    cases = calibration.cases
    settings = calibration.settings or {}
    wait = draw([*((name, fn, (out, cases, out / name))
                   for name, fn in (("force_time.png", _plot_histories),
                                    ("parameters.png", _plot_parameters),
                                    ("stress.png", _plot_stress))), *jobs])
    cycle_level = settings.get("cycle_level") or settings.get("level")
    cycle = f", mesh cycle at level `{cycle_level}`" if calibration.mesh_cycle else ""
    lines = ["# fe-impact calibration", "",
             f"Settings: level `{settings.get('level')}`{cycle}, integrator "
             f"`{settings.get('integrator')}`, P{settings.get('order')}, initial gap "
             f"{_gap(settings.get('gap'))}. Wall time {_fmt(calibration.wall_time_s, '.0f')} s.",
             "",
             "## FE measurements", "",
             "| case | v (m/s) | m_eff (kg) | F_max (N) | delta_max (um) | t_c (us) | e "
             f"| dent (um) | K (N/m^xi) | xi | fit R^2 | dF/d delta at {_impact_load(cases)} "
             "(N/m) |",
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
    lines += ["", "The pair starts in rigid motion (each rotor carries its sector) and closes "
              "at the impact speed v_k. At the calibration's step (t_c / 60) F_max, delta_max, "
              "t_c and the fitted law are within 0.15% of a four times finer step, e within "
              "1e-4 (`validation/time_step.py`)."]
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
    lines += _fit_remarks(cases)
    lines += _undetermined_damping(cases)
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
              "output (stress fields and VTU frames); picture: the case's row of "
              f"stress.png (cases/<id>/{CONTACT_PICTURE}).", "",
              "| case | DOFs | steps | mesh | FE set-up | FE steps | FE output | fit | "
              "picture | total |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for c in cases:
        t = c.timings_s or {}
        lines.append(f"| {c.id} | {c.model.n_dofs} | {c.model.steps} | "
                     f"{_fmt(t.get('mesh'), '.1f')} | {_fmt(t.get('fe_setup'), '.1f')} | "
                     f"{_fmt(t.get('fe_steps'), '.1f')} | {_fmt(t.get('fe_output'), '.1f')} | "
                     f"{_fmt(t.get('fit'), '.1f')} | {_fmt(t.get('picture'), '.1f')} | "
                     f"{_fmt(t.get('total'), '.1f')} |")
    if cases:
        total = sum((c.timings_s or {}).get("total", 0.0) for c in cases)
        lines += ["", f"Sum over cases {total:.0f} s; wall time of this run "
                  f"{_fmt(calibration.wall_time_s, '.0f')} s (resumed cases cost nothing "
                  "the second time)."]
    written = wait() + (started() if started is not None else [])
    lines += [""] + [f"![{p}]({p})" for p in written if p.endswith(".png")] + [""]
    if calibration.mesh_cycle:
        from fe_impact.calibration.meshcycle_report import report_lines

        lines += report_lines(calibration.mesh_cycle)
    lines += friction_lines(calibration.friction)
    lines += _root_stress_lines(out, written)
    path = out / "report.md"
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines))
    return path


def add_switching_section(out: Path, studies: list[str]) -> Path:
    """Append to ``report.md`` a table of the switching studies run on this calibration
    (``studies``: their job names, ``switching study <preset>``), read from their
    ``switching/<preset>/statistics.json``."""
    import json

    lines = ["", "## Switching runs on this calibration", "",
             "The seed's condition sets run through the torsional model with the laws above "
             "(`fe-impact switching --preset NAME --calibration calibration.json` does one "
             "again); each folder holds the time series, the impacts, the statistics beside "
             "the seed's tables and a report. Per study: impacts (rattle / mesh-in / switch), "
             "those touching on a tip edge, the largest closing speed and force of an impact, "
             "and the law look-ups at closing speeds below / above the calibrated ones (their "
             "damping is the nearest calibrated impact's; stiffness and exponent come from "
             "the mesh cycle where there is one). An impact touching on a rounded tip edge "
             "takes that edge's corner law: this calibration's corner cases where it has "
             "them, else the closed form of the edge's first touch (each study's report "
             "counts the impacts per law and names each law's source).", "",
             "| study | cases | simulated (s) | impacts | on a tip edge | largest closing speed "
             "(mm/s) | largest force (N) | below / above the calibrated speeds | report |",
             "|---|---|---|---|---|---|---|---|---|"]
    for job in studies:
        name = job.removeprefix("switching study ")
        folder = out / "switching" / name
        try:
            data = json.loads((folder / "statistics.json").read_text())
        except (OSError, ValueError) as exc:
            lines.append(f"| {name} | - | - | - | - | - | - | - | unreadable: {exc} |")
            continue
        cases = data.get("cases", {})
        # each case's statistics over all its stages (absent for a case with no impact)
        every = [c["impact_statistics"]["all"] for c in cases.values()
                 if "all" in c["impact_statistics"]]
        kinds = [sum(e[k]["count"] for e in every) for k in ("rattle", "mesh-in", "switch")]
        edge = sum(e["contacts"]["all"][place]["count"] for e in every
                   for place in ("corner-approach", "corner-recess"))
        top = [e["all"] for e in every]
        speed = max((t["impact_speed"][1] or 0.0 for t in top), default=None)
        force = max((t["impact_force"][1] or 0.0 for t in top), default=None)
        low = sum(c["run"]["clamped_low"] for c in cases.values())
        high = sum(c["run"]["clamped_high"] for c in cases.values())
        simulated = sum(sum(seg["duration"] for seg in c["segments"]) for c in cases.values())
        lines.append(f"| {name} | {len(cases)} | {simulated:g} | {sum(kinds)} "
                     f"({' / '.join(map(str, kinds))}) | {edge} | "
                     f"{_fmt(speed, '.4g', 1e3)} | {_fmt(force, '.4g')} | {low} / {high} | "
                     f"[report](switching/{name}/report.md) |")
    lines += _demand_lines(out)
    path = out / "report.md"
    text = path.read_text() if path.is_file() else ""
    with atomic_path(path) as tmp:
        tmp.write_text(text.rstrip("\n") + "\n" + "\n".join(lines) + "\n")
    return path


def _demand_lines(out: Path) -> list[str]:
    """The first pass of the loop (``preset_demand.json``, written by ``fe-impact
    calibrate``): the closing speeds the presets produced on the closed-form laws,
    beside the calibrated range of each stage."""
    import json

    path = out / "preset_demand.json"
    if not path.is_file():
        return []
    try:
        demand = json.loads(path.read_text())
        calibration = json.loads((out / "calibration.json").read_text())
    except (OSError, ValueError) as exc:
        return ["", f"(preset_demand.json unreadable: {exc})"]
    speeds: dict[int, list[float]] = {}
    for case in calibration.get("cases", []):
        speeds.setdefault(int(case["stage"]), []).append(float(case["impact_speed"]))
    runs = [*demand["presets"], *(f"schedule {n}" for n in demand.get("schedules", []))]
    lines = ["", "### What the presets asked of the calibration", "",
             f"The same condition sets ({', '.join(runs)}) run first on the "
             "closed-form laws: per stage and law taken at the onset, the impacts and their "
             "closing speeds. A stage whose flank impacts (mesh and switch laws) closed "
             "faster than its fastest planned FE impact had that one struck at "
             f"{demand.get('top_margin', 1.2):g} times their fastest instead (rounded up; "
             "beside the others when fewer than three were planned); slower "
             "impacts than the slowest FE case are elastic and quasi-static (the switching "
             "reports' clamp tables), the corner laws are closed forms.", "",
             "| stage | law | impacts | closing speed min / median / max [mm/s] | peak "
             "force min / median / max [N] | FE impacts of the stage [mm/s] |",
             "|---|---|---|---|---|---|"]
    for stage, laws in sorted(demand["stages"].items(), key=lambda kv: int(kv[0])):
        fe = ", ".join(f"{v * 1e3:.3g}" for v in sorted(speeds.get(int(stage), []))) or "-"
        for law, d in laws.items():
            force = " / ".join(_fmt(_finite(d.get(key)), ".4g") for key in
                               ("force_min", "force_median", "force_max"))
            lines.append(f"| {stage} | {law} | {d['count']} | {d['speed_min'] * 1e3:.3g} / "
                         f"{d['speed_median'] * 1e3:.3g} / {d['speed_max'] * 1e3:.3g} | "
                         f"{force} | {fe} |")
    return lines + _force_range_lines(out, demand)


def _finite(v):
    """``v``, or None when it is missing or NaN (a cache written before the field)."""
    return None if v is None or not math.isfinite(float(v)) else float(v)


def _force_range_lines(out: Path, demand: dict) -> list[str]:
    """The first pass's largest mesh force per stage beside the mesh cycle's and the corner
    laws' quasi-static curves (``mesh_cycle.json``): their largest force, the forces their
    laws are fitted up to, and the positions whose pressure reached a flank edge."""
    import json

    margin = float(demand.get("force_margin", 1.5))
    forces = {int(s): float(f) for s, f in demand.get("mesh_force_max_N", {}).items()}
    if not forces:
        return []
    curves: dict[int, list[tuple[float, float, bool]]] = {}
    low: dict[int, list[tuple[float, float]]] = {}   # least fitted force, law / curve there
    try:
        cycle = json.loads((out / "mesh_cycle.json").read_text())
        for record in [*cycle.get("positions", []), *cycle.get("corners", [])]:
            top = max(record.get("forces") or [0.0])
            fitted = max(record.get("fit_forces") or record.get("forces") or [0.0])
            curves.setdefault(int(record["stage"]), []).append(
                (top, fitted, bool(record.get("edge"))))
    except (OSError, ValueError, KeyError, TypeError):
        curves, cycle = {}, {}
    try:
        for record in cycle.get("positions", []):
            f, k = float(record["nominal_force"]), float(record["nominal_stiffness"])
            law = f / (f / float(record["stiffness"])) ** (1.0 / float(record["exponent"]))
            low.setdefault(int(record["stage"]), []).append(
                (min(record.get("fit_forces") or [f]), law / k))
    except (ValueError, KeyError, TypeError, ZeroDivisionError):
        low = {}
    lines = ["", "Largest mesh force of these runs per stage (per mesh, both flanks), and the "
             f"stage's quasi-static curves, which are to reach {margin:g} times it: their "
             "largest force, the least and largest force their laws are fitted up to (a "
             "position's law is fitted up to the step where the pressure reaches a flank "
             "edge, its record says which; beyond, the power law extrapolates), and the "
             "positions that reached an edge.", "",
             "| stage | largest mesh force [N] | curves reach [N] | ratio | laws fitted up to "
             "[N] | positions at an edge |", "|---|---|---|---|---|---|"]
    for stage, force in sorted(forces.items()):
        rows = curves.get(stage, [])
        reach = max((r[0] for r in rows), default=None)
        ratio = "-" if reach is None or force <= 0 else f"{reach / force:.2f}"
        if reach is not None and force > 0 and reach < margin * force * 0.999:
            ratio += " (short of the margin: the laws extrapolate there)"
        fitted = (f"{min(r[1] for r in rows):.4g}-{max(r[1] for r in rows):.4g}" if rows
                  else "-")
        edges = f"{sum(r[2] for r in rows)} of {len(rows)}" if rows else "-"
        lines.append(f"| {stage} | {force:.4g} | {_fmt(reach, '.4g')} | {ratio} | {fitted} | "
                     f"{edges} |")
    below = []
    for stage, rows in sorted(low.items()):
        flank = demand.get("stages", {}).get(str(stage), {}).get("mesh", {})
        median = _finite(flank.get("force_median"))
        floor = min(r[0] for r in rows)
        if median is not None and median < floor:
            ratios = [r[1] for r in rows]
            below.append(f"stage {stage}: median {median:.3g} N, the laws' secant stiffness "
                         f"at the nominal load {min(ratios):.2f}-{max(ratios):.2f} times the "
                         "curve's")
    if below:
        least = min(r[0] for v in low.values() for r in v)
        lines += ["", "The flank impacts of these runs peak mostly below the least force the "
                  f"position laws are fitted from ({least:.3g} N), where the power law "
                  "extrapolates; against the curve's nominal point "
                  "(Hertz plus the FE's linear compliance) it is stiffer there: "
                  + "; ".join(below) + ". One exponent does not hold from a rattle's few "
                  "newtons to a loaded mesh's hundreds: the laws are fitted where the loaded "
                  "mesh and the mesh-in impacts act, and a rattle's force and rebound are "
                  "the less certain for it (the validation's whole chain measures it on the "
                  "seed set)."]
    return lines


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


#: Stress picture: the colour scale of von Mises ends at this percentile of the
#: cells in the window at the contact (cells above it are drawn in _STRESS_ABOVE_COLOUR).
_STRESS_PERCENTILE = 99.0
_STRESS_ABOVE_COLOUR = "magenta"
#: The flank window's half-width along the footprint's long axis, in its long
#: semi-axis a (so that the whole footprint shows), and the section's
#: half-width and depth in its short semi-axis b (Hertz: the largest von Mises
#: lies 0.5-0.8 b deep). a and b are at least the local element size along them.
_STRESS_WINDOW_MAJOR, _STRESS_SECTION = 1.5, 4.0
#: Contact pressure outlining the footprint, as a fraction of its peak.
_STRESS_OUTLINE = 0.01
#: One impact's row (pixels): a header, two flank views and a section.
_FLANK, _SECTION, _HEADER = (720, 440), (480, 440), 190


@dataclass(frozen=True)
class _ContactWindow:
    """Where the stress picture of one VTU frame looks: a box at the contact.

    Lengths in m, stresses in Pa. The flank window has half-widths
    ``half_size[0]`` along ``major`` and ``half_size[1]`` along ``minor``
    (the footprint's long and short axes in the flank's tangent plane); the
    section across the footprint has half-width ``section`` and shows that
    depth below the flank. The colour range is taken over the ``window``
    cells: the viewed body's cells whose centroids lie in the flank window,
    at most ``section`` above or below the tangent plane.
    """

    centre: np.ndarray           # pressure-weighted centroid of the footprint
    peak_point: np.ndarray       # node of the largest contact pressure
    normal: np.ndarray           # outward normal of the viewed flank
    major: np.ndarray
    minor: np.ndarray
    semi_axes: tuple[float, float]     # footprint half-extents (major, minor)
    element_size: tuple[float, float]  # local element extents (major, minor)
    half_size: tuple[float, float]     # flank window (major, minor)
    section: float                     # section half-width and depth
    body: np.ndarray             # bool per cell: the viewed body
    window: np.ndarray           # bool per cell: the viewed body's cells in the window
    clim: tuple[float, float]    # von Mises colour range: 0 to the in-window percentile
    vm_max: float                # largest von Mises in the window
    vm_max_depth: float          # its cell centroid's depth below the flank
    p_max: float                 # largest contact pressure
    footprint_nodes: int         # nodes with a contact pressure on the viewed body


def _cell_nodes(grid) -> tuple[np.ndarray, np.ndarray]:
    """Connectivity and offsets (n_cells + 1) of an unstructured grid."""
    name = "cell_offsets" if "cell_offsets" in dir(type(grid)) else "offset"
    return np.asarray(grid.cell_connectivity), np.asarray(getattr(grid, name))


def _centroids(grid) -> np.ndarray:
    """Mean of each cell's nodes (n_cells, 3)."""
    conn, offsets = _cell_nodes(grid)
    pts = np.asarray(grid.points, dtype=float)
    return np.add.reduceat(pts[conn], offsets[:-1]) / np.diff(offsets)[:, None]


def _bodies(grid) -> tuple[np.ndarray, np.ndarray]:
    """Connected bodies of an unstructured grid: a label per point and per cell."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    conn, offsets = _cell_nodes(grid)
    cells = csr_matrix((np.ones(len(conn)), conn, offsets),
                       shape=(grid.n_cells, grid.n_points))
    _, points = connected_components(cells.T @ cells, directed=False)
    return points, points[conn[offsets[:-1]]]


def _tangent_axes(normal: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors (major, minor) of the tangent plane: the principal axes of
    ``offsets`` projected on it (an arbitrary pair when there are fewer than two)."""
    seed = np.eye(3)[int(np.argmin(np.abs(normal)))]
    e1 = seed - (seed @ normal) * normal
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    if len(offsets) >= 2:
        q = offsets @ np.column_stack([e1, e2])
        v = np.linalg.eigh(q.T @ q)[1][:, 1]     # eigenvector of the largest eigenvalue
        e1 = v[0] * e1 + v[1] * e2
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(normal, e1)
    return e1, e2


def _in_box(x: np.ndarray, centre: np.ndarray, axes: tuple[np.ndarray, ...],
            half: tuple[float, ...]) -> np.ndarray:
    """Points ``x`` within ``half`` of ``centre`` along each of ``axes``, both ways."""
    d = x - centre
    return np.all([np.abs(d @ e) <= w for e, w in zip(axes, half, strict=True)], axis=0)


def _contact_window(grid, normal: np.ndarray | None = None,
                    point: np.ndarray | None = None) -> _ContactWindow:
    """Find the contact in a frame: the footprint, the flank it is on and the window.

    Parameters
    ----------
    grid : pyvista.UnstructuredGrid
        A frame with point data ``contact_pressure`` and cell data ``von_mises`` (Pa).
    normal, point : array_like, optional
        The contact normal and point of the FE summary: the normal (either sign)
        is used when given, else the footprint's plane; the point only when no
        node carries a pressure.

    Returns
    -------
    _ContactWindow
        The viewed body is the one carrying the largest contact pressure (the
        slave side of the contact).
    """
    if "von_mises" not in grid.cell_data:
        raise CalibrationError("stress picture: the frame has no cell data 'von_mises'")
    pts = np.asarray(grid.points, dtype=float)
    vm = np.asarray(grid.cell_data["von_mises"], dtype=float)
    p = (np.asarray(grid.point_data["contact_pressure"], dtype=float)
         if "contact_pressure" in grid.point_data else np.zeros(len(pts)))
    labels, cell_labels = _bodies(grid)
    if p.max(initial=0.0) > 0.0:
        peak = int(np.argmax(p))
    elif point is not None:
        peak = int(np.argmin(np.linalg.norm(pts - np.asarray(point, float), axis=1)))
    else:
        raise CalibrationError("stress picture: no node carries a contact pressure and the "
                               "FE summary gives no contact_point")
    body = cell_labels == labels[peak]
    foot = (p > 0.0) & (labels == labels[peak])
    centre = (np.average(pts[foot], axis=0, weights=p[foot]) if foot.any()
              else pts[peak].copy())
    if normal is not None:
        n = np.asarray(normal, dtype=float)
    elif foot.sum() >= 3:
        d = pts[foot] - centre
        n = np.linalg.eigh(d.T @ d)[1][:, 0]    # the footprint plane's normal
    else:
        raise CalibrationError("stress picture: the footprint has fewer than 3 nodes and the "
                               "FE summary gives no contact_normal")
    n = n / np.linalg.norm(n)
    centroids = _centroids(grid)
    ids = np.flatnonzero(body)
    near = ids[np.argsort(np.linalg.norm(centroids[ids] - centre, axis=1))[:20]]
    # The body lies behind its flank: orient the normal out of it.
    if np.mean((centroids[near] - centre) @ n) > 0.0:
        n = -n
    major, minor = _tangent_axes(n, pts[foot] - centre)
    conn, offsets = _cell_nodes(grid)
    extent = np.array([np.ptp(pts[conn[offsets[c]:offsets[c + 1]]] @ np.column_stack(
        [major, minor]), axis=0) for c in near])
    h = tuple(float(v) for v in np.median(extent, axis=0))
    d = pts[foot] - centre
    semi = ((float(np.abs(d @ major).max()), float(np.abs(d @ minor).max())) if foot.any()
            else (0.0, 0.0))
    a, b = max(semi[0], h[0]), max(semi[1], h[1])
    section = _STRESS_SECTION * b
    w_major = max(_STRESS_WINDOW_MAJOR * a, section * _FLANK[0] / _FLANK[1])
    half = (w_major, w_major * _FLANK[1] / _FLANK[0])
    window = body & _in_box(centroids, centre, (major, minor, n), (*half, section))
    if not window.any():
        raise CalibrationError("stress picture: no cell of the contacting body lies in the "
                               f"window of half-widths {half} m at the contact")
    vmw = vm[window]
    top = int(np.argmax(vmw))
    return _ContactWindow(
        centre=centre, peak_point=pts[peak].copy(), normal=n, major=major, minor=minor,
        semi_axes=semi, element_size=h, half_size=half, section=section, body=body,
        window=window, clim=(0.0, float(np.percentile(vmw, _STRESS_PERCENTILE))),
        vm_max=float(vmw[top]), vm_max_depth=float(-(centroids[window][top] - centre) @ n),
        p_max=float(p.max(initial=0.0)), footprint_nodes=int(foot.sum()))


def _side_name(summary: dict | None) -> str:
    """The slave side's name (it carries the contact pressure), e.g. ``pinion``."""
    name = ((summary or {}).get("model") or {}).get("sides", {}).get("slave", "")
    if "(" in name and name.endswith(")"):
        name = name[name.index("(") + 1:-1]
    return name.replace("_", " ") or "contacting body"


def _surface(grid):
    """The outer surface, quadratic faces split once (pyvista's default algorithm)."""
    import inspect

    extra = ({"algorithm": "dataset_surface"}
             if "algorithm" in inspect.signature(grid.extract_surface).parameters else {})
    return grid.extract_surface(nonlinear_subdivision=1, **extra)


def _camera(p, focus: np.ndarray, towards: np.ndarray, up: np.ndarray,
            half_height: float) -> None:
    """Parallel view of the current panel onto ``focus`` from the side of ``towards``."""
    p.camera_position = [tuple(focus + 100 * half_height * towards), tuple(focus), tuple(up)]
    p.enable_parallel_projection()
    p.camera.parallel_scale = half_height
    p.reset_camera_clipping_range()


def _render_contact(grid, w: _ContactWindow, titles: tuple[str, str, str]
                    ) -> tuple[np.ndarray, tuple[float, float]]:
    """Render one frame's contact as a row of three panels (pyvista off-screen).

    Left: von Mises (MPa) on the flank seen along the contact normal, the
    footprint outlined in white; middle: the contact pressure (MPa) there
    with the element edges; right: von Mises in the section across the
    footprint through its centre, the flank on top. ``titles`` head the three
    columns, above their colour bars. Returns the RGB image and the von Mises
    range of the left panel's colour map (Pa).
    """
    import pyvista as pv

    pv.OFF_SCREEN = True
    # Off screen without an X server VTK falls back to its own context after
    # printing a warning about the missing display; keep the terminal clean.
    pv.vtk_verbosity("off")
    (wmaj, wmin), ws = w.half_size, w.section
    shown = w.body & _in_box(_centroids(grid), w.centre, (w.major, w.minor, w.normal),
                             (1.3 * wmaj, 1.3 * wmin, 1.3 * max(ws, wmin)))
    sub = grid.extract_cells(np.flatnonzero(shown))
    sub.cell_data["vm"] = np.asarray(sub.cell_data["von_mises"]) / 1e6
    sub.point_data["p"] = (np.asarray(sub.point_data["contact_pressure"]) / 1e6
                           if "contact_pressure" in sub.point_data else np.zeros(sub.n_points))
    surf = _surface(sub)
    lift = 1e-3 * wmin * w.normal          # lines and marks just above the flank
    outline = None
    if w.p_max > 0:
        outline = surf.contour([_STRESS_OUTLINE * w.p_max / 1e6], scalars="p")
        if outline.n_points:
            outline.points = outline.points + lift
        else:
            outline = None
    peak = pv.PolyData((w.peak_point + lift)[None, :])
    clim = (w.clim[0] / 1e6, w.clim[1] / 1e6)
    vm_style = dict(scalars="vm", preference="cell", cmap="turbo", clim=clim,
                    above_color=_STRESS_ABOVE_COLOUR, show_scalar_bar=False, lighting=False)
    mark = dict(color="black", point_size=10, render_points_as_spheres=True)

    height = _HEADER + _FLANK[1]
    p = pv.Plotter(shape=(2, 3), off_screen=True, border=False,
                   window_size=(2 * _FLANK[0] + _SECTION[0], height),
                   row_weights=[_HEADER, _FLANK[1]],
                   col_weights=[_FLANK[0], _FLANK[0], _SECTION[0]])
    p.set_background("white")
    p.subplot(1, 0)
    actor = p.add_mesh(surf, **vm_style)
    if outline is not None:
        p.add_mesh(outline, color="white", line_width=3)
    p.add_mesh(peak, **mark)
    _camera(p, w.centre, w.normal, w.minor, wmin)
    p.add_axes(line_width=3, color="white", viewport=(0.0, 0.0, 0.14, 0.24))
    p.subplot(1, 1)
    pressure = p.add_mesh(surf, scalars="p", cmap="YlOrRd", show_scalar_bar=False,
                          clim=(0.0, max(w.p_max / 1e6, 1e-9)), show_edges=True,
                          edge_color="grey", line_width=0.5, lighting=False)
    if outline is not None:
        p.add_mesh(outline, color="blue", line_width=2)
    p.add_mesh(peak, **mark)
    _camera(p, w.centre, w.normal, w.minor, wmin)
    p.subplot(1, 2)
    cut = sub.slice(normal=w.major, origin=w.centre)
    if cut.n_cells:
        p.add_mesh(cut, show_edges=True, edge_color="grey", line_width=0.5, **vm_style)
    p.add_mesh(pv.PolyData((w.centre + lift)[None, :]), **mark)
    _camera(p, w.centre - 0.6 * ws * w.normal, w.major, w.normal,
            ws * _SECTION[1] / _SECTION[0])
    # Four labels: none in the middle, under the title.
    bar = dict(n_labels=4, fmt="%.0f", color="black", title_font_size=13,
               label_font_size=12, position_x=0.08, position_y=0.22, width=0.8, height=0.3)
    for col, (title, mapper) in enumerate(zip(
            titles, (actor.mapper, pressure.mapper, None), strict=True)):
        p.subplot(0, col)
        p.add_text(title, position="upper_left", font_size=10, color="black")
        if mapper is not None:
            name = "von Mises (MPa)" if col == 0 else "contact pressure (MPa)"
            p.add_scalar_bar(name, mapper=mapper, **bar)
    image = p.screenshot(return_img=True)
    used = tuple(float(v) * 1e6 for v in actor.mapper.scalar_range)
    p.close()
    return image, used


def _titles(c: CalibrationRecord, summary: dict, w: _ContactWindow, t: float,
            force: float) -> tuple[str, str, str]:
    """The three column headings of one impact's row."""
    side = _side_name(summary)
    t0 = summary.get("first_touch") or 0.0
    t_peak = summary.get("time_of_peak_force")
    t_peak = t if t_peak is None else t_peak
    return (f"{c.id}: v = {c.impact_speed:.3g} m/s, peak force {c.fe.peak_force:.4g} N at "
            f"{(t_peak - t0) * 1e6:.0f} us\n"
            f"frame at {(t - t0) * 1e6:.0f} us ({force:.4g} N); max von Mises near the "
            f"contact {w.vm_max / 1e6:.0f} MPa\n"
            f"{side} flank along the contact normal, {2e3 * w.half_size[0]:.3g} x "
            f"{2e3 * w.half_size[1]:.3g} mm;\ncolours to the {_STRESS_PERCENTILE:g}th "
            f"percentile there, above in {_STRESS_ABOVE_COLOUR}",
            f"contact pressure on the {side} flank, peak {w.p_max / 1e6:.0f} MPa\n"
            f"footprint half-extents {w.semi_axes[0] * 1e6:.0f} x "
            f"{w.semi_axes[1] * 1e6:.0f} um ({w.footprint_nodes} nodes),\noutlined at "
            f"{_STRESS_OUTLINE:.0%} of the peak; element edges in grey",
            f"section across the footprint, {2e6 * w.section:.0f} um wide,\n"
            f"flank on top, colours as on the left;\nmax von Mises {w.vm_max / 1e6:.0f} MPa "
            f"at {w.vm_max_depth * 1e6:.0f} um depth\n(footprint half-width "
            f"{w.semi_axes[1] * 1e6:.0f} um)")


def _peak_frame(out: Path, case: CalibrationRecord,
                summary: dict) -> tuple[Path, float, float] | None:
    """The VTU frame of the largest contact force: (file, time s, force N).

    The fields are written at every few output times only
    (measurement.VTU_FRAME_STRIDE): the force at each frame's time is read off the
    history, and the frame with the largest one is taken.
    """
    frames = summary["fields"]["frames"]
    if not frames:
        return None
    h = summary["history"]
    t, f = np.asarray(h["time"], float), np.asarray(h["contact_force"], float)
    times = np.asarray(summary["fields"].get("frame_times") or t[:len(frames)], float)
    n = min(len(frames), len(times))
    k = int(np.argmax(np.interp(times[:n], t, f)))
    return (out / "cases" / case.id / "fe" / frames[k], float(times[k]),
            float(np.interp(times[k], t, f)))


#: Each impact's row of the stress picture, rendered by the worker that ran
#: the case (:func:`write_contact_picture`) so the report only stacks them.
CONTACT_PICTURE = "contact.png"


def _contact_row(out: Path, c: CalibrationRecord) -> np.ndarray | None:
    """One impact's row of the stress picture (RGB), or None (warned) without frames."""
    import pyvista as pv

    s = _history(out, c)
    if s is None or c.fe is None:
        return None
    try:
        found = _peak_frame(out, c, s)
        if found is None:
            return None
        frame, t, force = found
        grid = pv.read(frame)
        model = s.get("model") or {}
        w = _contact_window(grid, model.get("contact_normal"), model.get("contact_point"))
    except (OSError, KeyError, ValueError, CalibrationError) as exc:
        logger.warning("stress picture of %s skipped: %s", c.id, exc)
        return None
    return _render_contact(grid, w, _titles(c, s, w, t, force))[0]


def write_contact_picture(out: Path, c: CalibrationRecord) -> Path | None:
    """``cases/<id>/contact.png``: the impact's contact at the frame of peak force
    (the row :func:`_plot_stress` shows for it); None if it has no frames."""
    from PIL import Image

    row = _contact_row(Path(out), c)
    if row is None:
        return None
    path = Path(out) / "cases" / c.id / CONTACT_PICTURE
    with atomic_path(path) as tmp:
        Image.fromarray(row).save(tmp, format="png")
    return path


def _plot_stress(out: Path, cases: tuple[CalibrationRecord, ...], path: Path) -> bool:
    """von Mises at the contact of each impact, at the frame of peak contact force.

    One row per impact (pyvista off-screen, see :func:`_render_contact`): the
    flank seen along the contact normal in a window around the footprint, the
    colour scale from 0 to the _STRESS_PERCENTILE percentile of the cells in
    that window; the contact pressure there; the section across the footprint.
    A row the case's worker rendered (:data:`CONTACT_PICTURE`, not older than
    the FE results it shows) is read back; the others are rendered here. A
    case whose frames are missing or unreadable is left out with a warning.
    """
    from PIL import Image

    rows = []
    for c in sorted(cases, key=lambda c: (c.stage, c.kind, c.impact_speed)):
        folder = out / "cases" / c.id
        png, fe = folder / CONTACT_PICTURE, folder / "fe" / "summary.json"
        row = None
        if png.is_file() and fe.is_file() and png.stat().st_mtime >= fe.stat().st_mtime:
            try:
                row = np.asarray(Image.open(png).convert("RGB"))
            except OSError as exc:
                logger.info("contact picture of %s rendered again: %s", c.id, exc)
        if row is None:
            row = _contact_row(out, c)
        if row is not None:
            rows.append(row)
    if not rows:
        return False
    width = max(r.shape[1] for r in rows)
    rows = [np.pad(r, ((0, 0), (0, width - r.shape[1]), (0, 0)), constant_values=255)
            for r in rows]
    with atomic_path(path) as tmp:
        Image.fromarray(np.vstack(rows)).save(tmp, format="png")
    return True
