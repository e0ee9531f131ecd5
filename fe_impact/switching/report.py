"""Result files of a switching study: time series, impacts, statistics, report, plots.

A leaf module: nothing numerical imports it. Every file is written
atomically (`fe_impact.output.files`); matplotlib is imported lazily, with the Agg
backend.

Files written to the output folder for a preset with cases ``C``:

- ``C_series.csv``: the sampled time series (SI units in the column names,
  10 significant digits);
- ``C_impacts.csv``: one row per impact;
- ``statistics.csv``: the seed's table layout, model beside seed, in the
  seed's units;
- ``statistics.json``: the same plus series and impact statistics per
  stage, run figures and model parameters;
- ``report.md``: tables and where and why the numbers differ from the seed;
- ``elastic_displacement.png``, ``impact_speed.png``, ``impact_force.png``,
  ``potential_energy.png`` (like the seed's Figures 8-24) and
  ``impacts.png`` (the recorded impacts).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from fe_impact.output.files import (
    atomic_path,
    remove_stale,
    write_array_csv,
    write_csv,
    write_json,
)
from fe_impact.switching.geometry import seed_switching_speed, switching_speed
from fe_impact.switching.model import DriveModel
from fe_impact.switching.presets import Preset
from fe_impact.switching.seed_tables import (
    LABELS,
    QUANTITIES,
    SEED_TABLES,
    SEED_UNITS,
    STATISTICS,
    TO_SEED_UNITS,
)
from fe_impact.switching.simulation import CONTACT_NAMES, KIND_NAMES, LAW_NAMES, SwitchingRun
from fe_impact.switching.statistics import comparison_rows, impact_statistics, series_statistics

logger = logging.getLogger(__name__)

__all__ = ["model_parameters", "render_report", "write_results"]

_SERIES_OF = {
    "elastic_displacement": "elastic_displacement_m",
    "impact_speed": "impact_speed_m_s",
    "impact_force": "impact_force_N",
    "potential_energy": "potential_energy_J",
}
_IMPACT_COLUMNS = ("time_s", "stage", "kind", "flank", "closing_speed_m_s", "peak_approach_m",
                   "peak_force_N", "peak_energy_J", "end_time_s", "separation_speed_m_s",
                   "restitution", "law_clamped", "contact", "law", "position_m")


def model_parameters(model: DriveModel) -> dict:
    """The model's parameters as used (derived values filled in), SI units."""
    geo = model.geometry
    fr = model.friction
    return {
        "gearset": model.gearset.name,
        "stage_teeth": [s.teeth for s in model.gearset.stages],
        "pinion_teeth": model.gearset.pinion.teeth,
        "module_m": model.gearset.module,
        "n_pinions": model.pinions,
        "pinion_inertia_kg_m2": model.pinion_j,
        "ring_inertias_kg_m2": model.ring_inertias.tolist(),
        "output_inertia_kg_m2": model.output_j,
        "pinion_base_radius_m": geo.base_radius,
        "ring_base_levers_m": model.base_levers.tolist(),
        "contact_ratio": geo.contact_ratio,
        "tip_edge_radii_m": {"pinion": model.gearset.pinion.tip_edge_radius,
                             "face_gear": model.gearset.face_tip_edge_radius},
        "corner_gaps": model.corner_source,
        "corner_spans_m": [[g.approach.delta_max, g.recess.delta_max] for g in
                           map(model.stage_geometry, range(1, model.n_stages + 1))],
        "backlash_m": model.backlashes.tolist(),
        "coupling_stiffness_Nm_rad": model.couplings.tolist(),
        "coupling_damping_ratio": model.coupling_damping_ratio,
        "transmission_error_m": model.transmission_error,
        "drag_torque_Nm": model.drag_torque,
        "friction": None if fr is None else {
            "static": fr.static, "dynamic": fr.dynamic,
            "stiction_speed_m_s": fr.stiction_speed, "transition_speed_m_s": fr.transition_speed},
        "drive": model.drive,
        "ramp_time_s": model.ramp_time,
        "engage_position": model.engage_position,
        "effective_mass_kg": [model.effective_mass(s) for s in range(1, model.n_stages + 1)],
        "laws": model.law_set.source,
        "law_sources": _law_sources(model),
        "law_notes": list(model.law_set.notes),
        "rtol": model.rtol,
        "length_tol_m": model.length_tol,
        "speed_tol_m_s": model.speed_tol,
        "max_step_s": model.max_step,
    }


def _law_sources(model: DriveModel) -> dict[str, list[str | None]]:
    """Per law kind, the source of each stage's table (None: the stage has none)."""
    laws = model.law_set
    return {kind: [laws.table(stage, kind).source if laws.has(stage, kind) else None
                   for stage in range(1, model.n_stages + 1)]
            for kind in LAW_NAMES.values()}


def _segment_record(seg) -> dict:
    """A segment's fields for statistics.json (those set); a load series by its file and
    extremes."""
    record = {k: v for k, v in vars(seg).items() if v is not None and k != "load_series"}
    if seg.load_series is not None:
        loads = seg.load_profile()[1]
        record["load_series"] = {"file": seg.load_series.source,
                                 "points": int(seg.load_series.times.size),
                                 "min_Nm": float(loads.min()), "max_Nm": float(loads.max())}
    return record


def _clean(obj):
    """JSON-safe copy: tuples to lists, non-finite floats to None."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_clean(v) for v in obj]
    if isinstance(obj, float | np.floating):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def _impact_rows(run: SwitchingRun) -> list[list]:
    ev = run.events
    return [[t, s, KIND_NAMES[k], f, v, a, fo, e, te, vo, r, c, CONTACT_NAMES[w], LAW_NAMES[g],
             x]
            for t, s, k, f, v, a, fo, e, te, vo, r, c, w, g, x in zip(
                ev.time.tolist(), ev.stage.tolist(), ev.kind.tolist(), ev.flank.tolist(),
                ev.speed.tolist(), ev.approach.tolist(), ev.force.tolist(), ev.energy.tolist(),
                ev.end_time.tolist(), ev.separation_speed.tolist(), ev.restitution.tolist(),
                ev.clamped.tolist(), ev.contact.tolist(), ev.law.tolist(),
                ev.position.tolist(), strict=True)]


def _contact_lines(runs: dict[str, SwitchingRun]) -> list[str]:
    """Impacts by kind and by where the pair touched, and the law each used."""
    first = next(iter(runs.values()))
    model = first.model
    lines = [
        "## Where the impacts touch",
        "",
        "Where the touching tooth pair was at each impact's onset: on the flanks (the path "
        "of contact), or on a rounded tip edge before the path (the face gear's, "
        "corner-approach) or after it (the pinion's, corner-recess). Corner gaps: "
        + ("three-dimensional first touch of the rounded edges (`fe-impact geometry`)."
           if model.corner_source == "3d" else "planar rack-and-pinion geometry."),
        "",
        "| case | kind | flank | corner-approach | corner-recess | closing speed at the "
        "corners [mm/s] (min-max) |",
        "|---|---|---|---|---|---|",
    ]
    for name, run in runs.items():
        for kind in KIND_NAMES.values():
            ev = run.events.select(kind=kind)
            if not len(ev):
                continue
            counts = [int(np.sum(ev.contact == c)) for c in sorted(CONTACT_NAMES)]
            corner = ev.speed[ev.contact != 0]
            span = (f"{corner.min() * 1e3:.3g}-{corner.max() * 1e3:.3g}" if corner.size
                    else "-")
            lines.append(f"| {name} | {kind} | {' | '.join(map(str, counts))} | {span} |")
    position = "mesh cycle" in first.info.get("law_source", "")
    lines += [
        "",
        "Which law each impact's onset took: the switch law for the first contact after a "
        "switch, the corner law of the tip edge it touched (where the stage has one), else "
        "the mesh law; each at the impact's closing speed. The onset's law sets the "
        "contact's damping and penetration. Its stiffness and exponent then follow where "
        "the pair touches: the corner law's on a tip edge, on the flanks "
        + ("the mesh cycle's position law at the pair's roll."
           if position else "the flank law's (mesh or switch) taken at the onset."),
        "",
        "| case | kind | " + " | ".join(f"{law} law" for law in LAW_NAMES.values()) + " |",
        "|---|---|" + "---|" * len(LAW_NAMES),
    ]
    for name, run in runs.items():
        for code, kind in KIND_NAMES.items():
            ev = run.events.law[run.events.kind == code]
            if ev.size:
                counts = [str(int(np.sum(ev == law))) for law in LAW_NAMES]
                lines.append(f"| {name} | {kind} | {' | '.join(counts)} |")
    lines += ["", "Where each law comes from, stage by stage:", ""]
    for kind, sources in _law_sources(model).items():
        text = "; ".join(f"stage {i}: {src or 'none (the flank law holds)'}"
                         for i, src in enumerate(sources, start=1))
        lines.append(f"- {kind}: {text}")
    lines.append("")
    return lines


#: Peak Hertz pressure at the onset of yield, in units of the yield strength (Johnson,
#: *Contact Mechanics*, section 6.2: 1.6 Y for nu = 0.3).
YIELD_PRESSURE = 1.6


def _yield_speed(model: DriveModel, stage: int, kind: str = "mesh") -> float:
    """Closing speed [m/s] at which the Hertz impact of the stage's effective mass on the
    law's contact reaches the yield-onset pressure `YIELD_PRESSURE` Y
    (`fe_impact.physics.hertz.ellipse_yield_speed`): the flanks' design point, or for
    a corner kind the rounded tip edge's first touch (`corner_radii`; about 1 mm/s on
    a 0.1 mm rounding, where the flanks' is 0.26 m/s)."""
    from fe_impact.physics import hertz
    from fe_impact.switching.calibration import CORNER_KINDS, contact_radii, corner_radii

    material = model.gearset.material
    e_star = hertz.effective_modulus(material.youngs_modulus, material.poisson_ratio)
    side = {v: k for k, v in CORNER_KINDS.items()}.get(kind)
    radii = corner_radii(model.gearset, stage - 1, side) if side is not None else None
    rx, ry = radii if radii is not None else contact_radii(model.gearset, stage - 1)
    return hertz.ellipse_yield_speed(model.effective_mass(stage), rx, ry, e_star,
                                     material.yield_strength, YIELD_PRESSURE)


def _clamp_lines(runs: dict[str, SwitchingRun]) -> list[str]:
    """The impacts whose closing speed left their law's table, and what the clamp did."""
    from fe_impact.physics.laws import simulate_impact

    first = next(iter(runs.values()))
    model = first.model
    events = [r.events for r in runs.values()]
    stage = np.concatenate([e.stage for e in events])
    law = np.concatenate([e.law for e in events])
    clamp = np.concatenate([e.clamped for e in events])
    speed = np.concatenate([e.speed for e in events])
    lines = ["## Law look-ups outside the calibrated speeds", ""]
    if not np.any(clamp != 0):
        return lines + ["None: every impact's closing speed lies within its law's table.", ""]
    lines += [
        "Impacts whose closing speed lies outside their law's table take the parameters of "
        "its nearest end (clamped). Per stage and law: the table's range, the impacts below "
        "and above it, and the restitution the clamped law gives at the slowest and fastest "
        "of them (one impact of the stage's effective mass on the law, "
        "`fe_impact.physics.laws.simulate_impact`), beside the closing speed at which the "
        f"Hertz impact on the law's contact reaches yield ({YIELD_PRESSURE:g} Y: the flanks' "
        "design point, or a tip edge's rounding at its first touch).",
        "",
        "| stage | law (source) | table [mm/s] | below: impacts (slowest, mm/s) | e (fastest-"
        "slowest) | above: impacts (fastest, mm/s) | e there | yield onset [mm/s] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    names = list(LAW_NAMES.items())
    worst_low, worst_high = [], []
    for st in range(1, model.n_stages + 1):
        for code, kind in names:
            pick = (stage == st) & (law == code)
            low, high = pick & (clamp < 0), pick & (clamp > 0)
            if not (low.any() or high.any()):
                continue
            table = model.law_set.table(st, kind)
            mass = model.effective_mass(st)
            onset = _yield_speed(model, st, kind)
            cells = []
            for mask, end, reduce in ((low, 0, np.min), (high, -1, np.max)):
                if not mask.any():
                    cells += ["0", "-"]
                    continue
                v = float(reduce(speed[mask]))
                clamped = table.law(float(table.impact_speed[end]))   # the end's row
                e = simulate_impact(clamped, mass, v).restitution
                fastest = float(np.max(speed[mask]))
                cell = f"{e:.4f}"
                if end == 0 and fastest > v:
                    # the law loses more the faster it closes: the group's smallest
                    # restitution is its fastest impact's, next to the table's end
                    e_fast = simulate_impact(clamped, mass, fastest).restitution
                    cell, e = f"{e_fast:.4f}-{e:.4f}", e_fast
                # the smallest restitution of the group, and its fastest's yield ratio
                (worst_low if end == 0 else worst_high).append((e, fastest / onset))
                cells += [f"{int(mask.sum())} ({v * 1e3:.3g})", cell]
            lo, hi = table.speed_range
            lines.append(f"| {st} | {kind} ({table.source}) | {lo * 1e3:.3g}-{hi * 1e3:.3g} | "
                         f"{' | '.join(cells)} | {onset * 1e3:.4g} |")
    lines.append("")
    if worst_low:
        e_low = min(e for e, _ in worst_low)
        ratio = max(r for _, r in worst_low)
        lines.append(
            "Below the tables the impacts are slower than any calibrated one "
            + (f"and quasi-static: their contacts are elastic (at most {ratio:.2g} times "
               "their contact's yield-onset speed) and the clamp changes only their small "
               "damping, "
               if ratio < 1.0 else
               f"but up to {ratio:.3g} times their contact's yield-onset speed (a tip edge's "
               "rounding yields at a few mm/s): they take the slowest calibrated case's "
               "plastic loss, ")
            + f"and the clamped laws give them a restitution of at least {e_low:.4f}; their "
            "stiffness and exponent are the mesh cycle's quasi-static ones where the "
            "calibration has a mesh cycle.")
    if worst_high:
        ratio = max(r for _, r in worst_high)
        lines.append(
            "Above the tables the impacts are faster than the fastest calibrated one, at up "
            f"to {ratio:.3g} times their contact's yield-onset speed: "
            + ("still elastic, where the Hertz-type law extrapolates and the clamp holds "
               "only the damping of the fastest case."
               if ratio < 1.0 else
               "beyond the yield onset, where the clamped law misses the plastic loss: an FE "
               "case at their speed (`fe-impact calibrate --impact-speeds`) closes the gap."))
    lines.append("")
    return lines


def _fmt(value: float | None) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    if value == 0.0:
        return "0"
    return f"{value:.4g}"


def _seed_layout_table(rows: list[dict], key: str, conditions: list[str],
                      seed: bool = True) -> list[str]:
    """Markdown table: category, value, then ``model / seed`` per condition (``model``
    alone without ``seed``)."""
    lines = ["| category | value | " + " | ".join(conditions) + " |",
             "|---|---|" + "---|" * len(conditions)]
    index = {(r["condition"], r["quantity"], r["statistic"]): r for r in rows}
    for quantity in QUANTITIES:
        for statistic in STATISTICS:
            label = f"{LABELS[quantity]} ({SEED_UNITS[quantity]})" if statistic == "average" \
                else ""
            cells = []
            for condition in conditions:
                r = index[(condition, quantity, statistic)]
                model = _fmt(r[key])
                cells.append(model if key == "model_impacts" or not seed
                             else f"{model} / {_fmt(r['seed'])}")
            lines.append(f"| {label} | {statistic} | " + " | ".join(cells) + " |")
    return lines


def _baseline_lines(rows: list[dict], conditions: list[str], runs: dict[str, SwitchingRun],
                    baseline: dict[str, SwitchingRun] | None, seed: bool = True) -> list[str]:
    """The statistics on these laws beside the pitch-point-only laws' and (``seed``: a
    preset with a seed table) the seed's."""
    if baseline is None:
        return []
    laws = next(iter(baseline.values())).model.law_set.source
    cells_are = ("these laws / pitch point only / seed; series statistics, then the "
                 "impacts' (the seed has no impact statistics)." if seed else
                 "these laws / pitch point only; series statistics, then the impacts'.")
    lines = ["## Beside the pitch-point-only laws" + (" and the seed" if seed else ""), "",
             "The same cases rerun on these laws reduced to what a calibration at the pitch "
             "point alone gives: every tooth pair takes its impact's law at every position "
             "and on the tip edges (" + laws + "). Cells: " + cells_are, "",
             "| category | value | " + " | ".join(conditions) + " |",
             "|---|---|" + "---|" * len(conditions)]
    index = {(r["condition"], r["quantity"], r["statistic"]): r for r in rows}
    for quantity in QUANTITIES:
        for statistic in ("maximum", "average"):
            cells = [f"{_fmt(r['model_series'])} / {_fmt(r['baseline_series'])}"
                     + (f" / {_fmt(r['seed'])}" if seed else "")
                     for r in (index[(c, quantity, statistic)] for c in conditions)]
            lines.append(f"| {LABELS[quantity]} ({SEED_UNITS[quantity]}) | series {statistic} | "
                         + " | ".join(cells) + " |")
        cells = [f"{_fmt(r['model_impacts'])} / {_fmt(r['baseline_impacts'])}"
                 for r in (index[(c, quantity, "maximum")] for c in conditions)]
        lines.append("| | impacts' maximum | " + " | ".join(cells) + " |")
    counts = [f"{len(runs[n].events)} / {len(baseline[n].events)}" for n in runs]
    lines += ["", "Impacts per case, these laws / pitch point only: "
              + ", ".join(f"{n} {c}" for n, c in zip(runs, counts, strict=True)) + ".", ""]
    return lines


def _magnitude_gap(rows: list[dict], quantity: str) -> str:
    """Typical log10 ratio seed/model of the maxima of one quantity."""
    ratios = [abs(r["seed"]) / abs(r["model_series"]) for r in rows
              if r["quantity"] == quantity and r["statistic"] == "maximum"
              and r["seed"] and r["model_series"]]
    if not ratios:
        return "no common values"
    return f"seed/model ratio of the maxima {min(ratios):.2g} to {max(ratios):.2g}"


def _differences(preset: Preset, runs: dict[str, SwitchingRun], rows: list[dict]) -> list[str]:
    """The report's explanation of where and why the numbers differ from the seed."""
    model = next(iter(runs.values())).model
    table = SEED_TABLES[preset.seed_table]
    law = model.law_set.source
    lines = [
        "## Where and why the numbers differ from the seed",
        "",
        "The seed's values come from an ADAMS model whose quantities are not defined, "
        "whose stiffness is not given and whose output was sampled every 0.01 s "
        "(\"5 s, step size 500\"); several of them cannot be physical. The model here "
        "reproduces the seed's *conditions* (stages, speeds, loads, 5 s segments, friction "
        "0.02/0.05), not its numbers. Differences, quantity by quantity:",
        "",
        f"- **Elastic displacement** ({_magnitude_gap(rows, 'elastic_displacement')}). The "
        "seed's extremes are the same to five digits at every speed and load (+-1.0025e-5 mm, "
        "+-1.7158e-5 mm for stage 3 and the multistage runs), with averages near zero: a "
        "fixed geometric offset of the ADAMS contact, independent of the dynamics. Here it is "
        "the Hertz approach of the tooth pairs, which grows with the impact energy.",
        f"- **Impact speed** ({_magnitude_gap(rows, 'impact_speed')}). The seed's stage-1 and "
        "multistage impact speeds (1e-13 to 1e-9 mm/s) are numerically zero; no impact can "
        "happen at such speeds. Its stages 2-3 values (up to 7 mm/s at 1000 r/min) are of a "
        "plausible order. Here the series is the relative speed of the teeth along the line "
        "of action: its extremes are rattle and switching impacts; the kinematic switching "
        "speed r_bp w_p |N_new/N_old - 1| is 60 mm/s at 100 r/min from stage 1 to 2. An output "
        "every 0.01 s misses impacts that last about 0.1 ms; the statistics here use every "
        "integration step (steps of microseconds in contact).",
        f"- **Impact force** ({_magnitude_gap(rows, 'impact_force')}). The seed reports 0.3 to "
        "4 MN without load. A module-3 tooth 24 mm wide breaks in bending at a few tens of kN "
        f"(Lewis, 1 GPa at the root), and {_energy_argument(model)} The seed's averages "
        "(-13 kN to +13 kN without load) are not the mean mesh force either, which must equal "
        "the load and drag torque over the base radius and the number of meshes (here "
        f"{_mean_force_text(runs)}; checked by the tests). A unit mix-up in the ADAMS contact "
        "parameters (N/mm against N/m) is the likely cause.",
        f"- **Potential energy** ({_magnitude_gap(rows, 'potential_energy')}). The seed's "
        "values are negative in most columns, impossible for an elastic energy; here it is "
        "the strain energy of the contacts, >= 0.",
        "",
        "What drives the model's numbers, and how sure they are:",
        "",
        f"- Contact law: {law}. "
        + ("The closed forms use the seed's eq. 14 restitution, which is 1 below the "
           "yield-onset speed (about 0.09 m/s): rattle impacts are then undamped except for "
           "friction and the coupling damping, so rattle, once started, decays slowly. "
           "Lubricant squeeze-film damping, the main loss in real gear rattle, is in none of "
           "the seed's formulas; an FE calibration with plasticity gives e < 1 only above the "
           "yield speed. Rattle amplitudes are therefore upper bounds."
           if "closed form" in law else
           "Impacts outside the calibrated speed range use the nearest case (clamped; "
           "counted in statistics.json)."),
        f"- Excitation without load: a transmission error of "
        f"{model.transmission_error * 1e6:.3g} um at mesh frequency against a drag of "
        f"{model.drag_torque * 1e3:.3g} N mm on the output. Rattle starts when the error's "
        "acceleration exceeds the drag's deceleration, so it grows with speed and stops under "
        "enough load; both inputs are estimates (the seed gives neither), and the no-load "
        "statistics scale with them.",
        f"- Backlash {', '.join(f'{b * 1e3:.3f}' for b in model.backlashes)} mm (ISO/TR "
        "10064-2 minimum for industrial drives; not given by the seed). The switching impact "
        "speed does not depend on it; the time to the first contact does.",
        f"- Geometry: module {model.gearset.module * 1e3:g} mm for pinion and rings (the "
        "seed's m = 2 pinion cannot mesh with its m = 3 face gears); four pinions in phase, "
        "values per mesh. Tip edges rounded "
        f"{model.gearset.pinion.tip_edge_radius * 1e3:g} mm (pinion) and "
        f"{model.gearset.face_tip_edge_radius * 1e3:g} mm (rings): the flanks end where the "
        f"roundings begin (contact ratio {model.geometry.contact_ratio:.4f} on the line of "
        "action), and a pair entering or leaving mesh touches on a rounding. "
        + ("Corner gaps: each ring's three-dimensional first touch of the rounded edges over "
           "the whole face (fe_impact.gears.corner; smaller than the planar rack model's: "
           "see `fe-impact geometry`)."
           if model.corner_source == "3d" else
           "Corner gaps: the planar rack-and-pinion geometry at the rings' design radius."),
    ]
    if table.notes:
        lines += ["", f"Transcription notes on the seed's {table.source}:", ""]
        lines += [f"- {note}" for note in table.notes]
    return lines


def _energy_argument(model: DriveModel) -> str:
    """Why MN forces are out of reach: stored energy at 1 MN against the drive's kinetic energy."""
    law = model.law_set.table(1).law(model.law_set.table(1).speed_range[0])
    force = 1e6
    energy = force * (force / law.k) ** (1.0 / law.exponent) / (law.exponent + 1.0)
    omega = 1000.0 * 2.0 * math.pi / 60.0
    out = omega * model.gearset.pinion.teeth / model.gearset.stages[0].teeth
    kinetic = 0.5 * (model.output_j + model.ring_inertias.sum()) * out**2 \
        + 0.5 * model.pinions * model.pinion_j * omega**2
    return (f"one tooth contact of this stiffness stores {energy:.3g} J at 1 MN, more than the "
            f"whole kinetic energy of the drive at 1000 r/min ({kinetic:.3g} J).")


def _mean_force_text(runs: dict[str, SwitchingRun]) -> str:
    parts = []
    for name, run in runs.items():
        for stage, stats in series_statistics(run).items():
            if stage != "all":
                parts.append(f"{name} stage {stage}: {_fmt(stats['impact_force'][0])} N")
    return "; ".join(parts[:4]) + ("; ..." if len(parts) > 4 else "")


def _switching_lines(runs: dict[str, SwitchingRun]) -> list[str]:
    """Measured switching impacts beside rigid kinematics and the seed's eq. 5."""
    lines, ratios = [], []
    for name, run in runs.items():
        model, hits = run.model, run.events.select(kind="switch")
        starts = run.schedule.start_times
        for t, speed, stage in zip(hits.time, hits.speed, hits.stage, strict=True):
            k = int(np.searchsorted(starts, t, side="right")) - 1
            before, seg = run.schedule.segments[k - 1], run.schedule.segments[k]
            rpm = before.end_speed_rpm          # the pinion's speed at the switch
            omega = rpm * 2.0 * math.pi / 60.0
            teeth = [s.teeth for s in model.gearset.stages]
            p = model.gearset.pinion
            kinematic = switching_speed(omega, p.teeth, teeth[before.stage - 1],
                                        teeth[stage - 1], model.geometry.base_radius)
            eq5 = seed_switching_speed(omega, p.pitch_radius, model.pitch_radii[stage - 1],
                                       teeth[stage - 1] / p.teeth, model.geometry.pressure_angle)
            ratios.append(eq5 / kinematic)
            lines.append(f"| {name} | {t:.4f} | {before.stage} -> {seg.stage} | "
                         f"{rpm:g} | {1e3 * speed:.4g} | {1e3 * kinematic:.4g} | "
                         f"{1e3 * eq5:.4g} |")
    if not lines:
        return []
    return [
        "## Switching impacts",
        "",
        "Closing speed of the first contact after each switch, beside the rigid kinematics "
        "(rings on one output, pinion speed unchanged: r_bp w_p |N_new/N_old - 1|) and the "
        "seed's eq. 5. They differ where the rings were still rattling or the speed ramp had "
        "begun. Eq. 5 has the same proportionality to the pinion speed but a geometric "
        f"factor {min(ratios):.2g} to {max(ratios):.2g} times larger; it is not derived in the "
        "seed, and no consistent kinematics of rings locked to the output reproduces it.",
        "",
        "| case | time [s] | stages | pinion at the switch [r/min] | model [mm/s] | "
        "kinematics [mm/s] | "
        "eq. 5 [mm/s] |",
        "|---|---|---|---|---|---|---|",
        *lines,
        "",
    ]


def _trend_lines(preset: Preset, runs: dict[str, SwitchingRun]) -> list[str]:
    """Qualitative statements of the seed checked against the model."""
    if preset.layout != "conditions" or len(preset.cases) < 2:
        return []
    key = str(preset.stage)
    speeds = [series_statistics(runs[c.name]).get(key, {}).get("impact_speed", (0, 0, 0))[1]
              for c in preset.cases]
    forces = [series_statistics(runs[c.name]).get(key, {}).get("impact_force", (0, 0, 0))[1]
              for c in preset.cases]
    rises = all(b >= a for a, b in zip(speeds, speeds[1:], strict=False))
    word = "rises" if rises else "does not rise monotonically"
    conditions = ", ".join(c.condition for c in preset.cases)
    return [
        "## Trends",
        "",
        f"Maximum relative speed over {conditions}: "
        + ", ".join(f"{1e3 * v:.4g}" for v in speeds) + f" mm/s ({word}; the seed reports "
        "impact-speed amplitudes growing with the input speed and with the load).",
        "Maximum mesh force: " + ", ".join(f"{f:.4g}" for f in forces) + " N.",
        "",
    ]


def render_report(preset: Preset, runs: dict[str, SwitchingRun], rows: list[dict],
                  notes: Sequence[str] = (),
                  baseline: dict[str, SwitchingRun] | None = None) -> str:
    """The text of ``report.md``; ``notes`` (warnings about the run) come first;
    ``baseline``: the same cases on the pitch-point-only laws (`write_results`)."""
    seed = preset.seed_table is not None
    conditions = list(dict.fromkeys(r["condition"] for r in rows))
    first = next(iter(runs.values()))
    if seed:
        table = SEED_TABLES[preset.seed_table]
        intro = [f"{preset.description}. Compared with the seed's {table.source} "
                 f"({table.title}); plots correspond to the seed's {preset.figures}.", ""]
    else:
        intro = [f"{preset.description}.", "", *_schedule_lines(first.schedule)]
    lines = [
        f"# Ratio-switching study `{preset.name}`",
        "",
        *[f"**Note:** {n}\n" for n in notes],
        *intro,
        "## Runs",
        "",
        "| case | simulated [s] | steps | rejected | wall [s] | impacts (rattle / mesh-in / "
        "switch) |",
        "|---|---|---|---|---|---|",
    ]
    for name, run in runs.items():
        counts = [int(np.sum(run.events.kind == k)) for k in sorted(KIND_NAMES)]
        lines.append(f"| {name} | {run.schedule.duration:g} | {run.info['steps']} | "
                     f"{run.info['rejected_steps']} | {run.info['wall_s']:.2f} | "
                     f"{len(run.events)} ({' / '.join(map(str, counts))}) |")
    lines += [
        "",
        f"Integrator: {first.info['integrator']}. Contact law: {first.info['law_source']}.",
        "",
        "## Definitions",
        "",
        "All values per mesh (one of the pinions), for the ring engaged at the time.",
        "",
        "- *Elastic displacement*: contact approach, + drive flank, - coast flank, 0 in free "
        "flight. *Impact speed*: relative speed of the teeth along the line of action, + "
        "closing the drive flank. *Impact force*: normal mesh force, drive minus coast. "
        "*Potential energy*: elastic energy stored in the contacts.",
        "- Series statistics: time average, maximum and minimum over every integration step "
        "while the stage is engaged (the seed's tables appear to be of this kind).",
        "- Impact statistics: over the impacts, i.e. contact onsets with a closing speed "
        "(rattle: a flank touching from free flight; mesh-in: a tooth pair touching while its "
        "flank carries load; switch: the first contact after a ratio switch): closing speed, "
        "peak approach, peak force, peak energy of each contact.",
        "",
        "## Series statistics, model / seed (seed units)" if seed
        else "## Series statistics (seed units)",
        "",
        *_seed_layout_table(rows, "model_series", conditions, seed),
        "",
        "## Impact statistics, model (seed units)",
        "",
        *_seed_layout_table(rows, "model_impacts", conditions),
        "",
        *_baseline_lines(rows, conditions, runs, baseline, seed),
        *_trend_lines(preset, runs),
        *_contact_lines(runs),
        *_clamp_lines(runs),
        *_switching_lines(runs),
        *(_differences(preset, runs, rows) if seed else []),
        "",
    ]
    return "\n".join(lines)


def _schedule_lines(schedule) -> list[str]:
    """The schedule's segments as a table: start, stage, duration, speed and load."""
    lines = ["## Schedule", "",
             "| segment | start [s] | stage | duration [s] | pinion [r/min] | load [N m] |",
             "|---|---|---|---|---|---|"]
    previous = None
    for i, (t0, seg) in enumerate(zip(schedule.start_times, schedule.segments, strict=True)):
        speed = (f"{seg.speed_rpm:g}" if seg.speed_end_rpm is None
                 else f"{seg.speed_rpm:g} -> {seg.speed_end_rpm:g}")
        if seg.load_series is not None:
            _, loads = seg.load_profile()
            load = (f"series {Path(seg.load_series.source).name} "
                    f"({loads.min():.4g}..{loads.max():.4g})")
        else:
            load = f"{seg.load:.4g}" + ("" if seg.load_end is None else f" -> {seg.load_end:.4g}")
        stage = f"{seg.stage}" + (" (switch)" if previous is not None and previous != seg.stage
                                  else "")
        lines.append(f"| {i} | {t0:g} | {stage} | {seg.duration:g} | {speed} | {load} |")
        previous = seg.stage
    return [*lines, ""]


# -- plots ---------------------------------------------------------------------------------
def _save(fig, path: Path) -> Path:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120)
    return path


def _margins(fig, rows: int, *, left: float = 0.85, right: float = 0.2, top: float = 0.55,
             bottom: float = 0.5, gap: float = 0.45) -> None:
    """Fixed margins in inches around a column of ``rows`` axes (room for the
    y label, the suptitle, each axes' title above it and the time axis below).
    ``tight_layout`` measured every tick label for the same result: 0.19 s a
    figure, a sixth of a study's output."""
    width, height = fig.get_size_inches()
    inner = height - top - bottom
    axes_height = (inner - (rows - 1) * gap) / rows
    fig.subplots_adjust(left=left / width, right=1.0 - right / width,
                        bottom=bottom / height, top=1.0 - top / height,
                        hspace=gap / axes_height if rows > 1 else 0.0)


def _plot_quantity(preset: Preset, runs: dict[str, SwitchingRun], quantity: str, path: Path
                   ) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scale, unit = TO_SEED_UNITS[quantity], SEED_UNITS[quantity]
    column = _SERIES_OF[quantity]
    names = list(runs)
    fig, axes = plt.subplots(len(names), 1, figsize=(9, 2.4 * len(names) + 0.8), sharex=True,
                             squeeze=False)
    for ax, name in zip(axes[:, 0], names, strict=True):
        s = runs[name].series
        t, stage = s["time_s"], s["stage"].astype(int)
        for number in np.unique(stage):
            on = np.where(stage == number, s[column] * scale, np.nan)
            ax.plot(t, on, lw=0.6, label=f"stage {number}")
        for t_switch in runs[name].schedule.start_times[1:]:
            ax.axvline(t_switch, color="0.6", lw=0.8, ls="--")
        case = next(c for c in preset.cases if c.name == name)
        ax.set_title(f"{name} ({case.condition})", fontsize=9)
        ax.set_ylabel(f"[{unit}]")
        ax.grid(alpha=0.3)
        if len(np.unique(stage)) > 1:
            ax.legend(fontsize=8, loc="upper left")
    axes[-1, 0].set_xlabel("time [s]")
    cf = f" (cf. seed {preset.figures})" if preset.seed_table is not None else ""
    fig.suptitle(f"{LABELS[quantity]} per mesh{cf}", fontsize=10)
    _margins(fig, len(names))
    _save(fig, path)
    plt.close(fig)
    return path


def _plot_impacts(runs: dict[str, SwitchingRun], path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_v, ax_f) = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    offset = 0.0
    for name, run in runs.items():
        ev = run.events
        for code, kind in KIND_NAMES.items():
            keep = ev.kind == code
            if np.any(keep):
                ax_v.semilogy(offset + ev.time[keep], ev.speed[keep] * 1e3, ".", ms=3,
                              label=f"{name}: {kind}")
                ax_f.semilogy(offset + ev.time[keep], np.maximum(ev.force[keep], 1e-6), ".",
                              ms=3)
        offset += run.schedule.duration
        if len(runs) > 1:
            ax_v.axvline(offset, color="0.6", lw=0.8)
    ax_v.set_ylabel("closing speed [mm/s]")
    ax_f.set_ylabel("peak force [N]")
    ax_f.set_xlabel("time [s] (cases one after the other)")
    for ax in (ax_v, ax_f):
        ax.grid(alpha=0.3, which="both")
    if ax_v.get_legend_handles_labels()[0]:
        ax_v.legend(fontsize=7, ncol=2)
    fig.suptitle("Impacts (contact onsets with a closing speed)", fontsize=10)
    _margins(fig, 2, gap=0.2)   # shared time axis: no title between the two
    _save(fig, path)
    plt.close(fig)
    return path


# -- everything -----------------------------------------------------------------------------
def write_results(out: str | Path, preset: Preset, runs: dict[str, SwitchingRun],
                  status: str = "completed", missing: Sequence[str] = (),
                  notes: Sequence[str] = (),
                  baseline: dict[str, SwitchingRun] | None = None) -> list[Path]:
    """Write all result files of a study to ``out``; returns their paths.

    ``status`` is ``"completed"`` or ``"stopped"`` (interrupted: ``runs``
    holds the cases finished, ``missing`` names the others, and with no
    finished case only ``statistics.json`` is written). ``notes`` are
    warnings about the run, kept in statistics.json and report.md.
    ``baseline``: the same cases on the pitch-point-only laws, whose statistics
    go beside (columns ``baseline_series``, ``baseline_impacts``).
    """
    out = Path(out)
    if not runs:
        return [write_json(out / "statistics.json", {
            "preset": preset.name, "status": status, "missing": list(missing),
            "notes": list(notes), "cases": {}})]
    preset = replace(preset, cases=tuple(c for c in preset.cases if c.name in runs))
    if status != "completed":
        notes = [*notes, f"status {status}: interrupted before the case(s) {list(missing)} "
                         "finished; the tables hold the finished cases only"]
    written = []
    for name, run in runs.items():
        columns = list(run.series)
        data = np.column_stack([run.series[c] for c in columns])
        written.append(write_array_csv(out / f"{name}_series.csv", columns, data))
        written.append(write_csv(out / f"{name}_impacts.csv", _IMPACT_COLUMNS,
                                 _impact_rows(run)))
    for pattern in ("*_series.csv", "*_impacts.csv"):   # an earlier study's cases
        remove_stale(out, pattern, [p.name for p in written])
    rows = comparison_rows(preset, runs)
    header = ["condition", "quantity", "statistic", "unit", "model_series", "model_impacts",
              "seed"]
    if baseline is not None:
        index = {(r["condition"], r["quantity"], r["statistic"]): r
                 for r in comparison_rows(preset, baseline)}
        for r in rows:
            b = index[(r["condition"], r["quantity"], r["statistic"])]
            r["baseline_series"], r["baseline_impacts"] = b["model_series"], b["model_impacts"]
        header += ["baseline_series", "baseline_impacts"]
    written.append(write_csv(out / "statistics.csv", header,
                             [[r[h] for h in header] for r in rows]))
    model = next(iter(runs.values())).model
    summary = {
        "preset": preset.name,
        "status": status,
        "missing": list(missing),
        "notes": list(notes),
        "description": preset.description,
        "seed_table": (None if preset.seed_table is None
                       else SEED_TABLES[preset.seed_table].source),
        "seed_notes": ([] if preset.seed_table is None
                       else list(SEED_TABLES[preset.seed_table].notes)),
        "units": {"comparison": SEED_UNITS, "statistics": "SI (m, m/s, N, J)"},
        "comparison": rows,
        "cases": {name: {
            "condition": next(c.condition for c in preset.cases if c.name == name),
            "segments": [_segment_record(s) for s in run.schedule.segments],
            "series_statistics": series_statistics(run),
            "impact_statistics": impact_statistics(run),
            "run": run.info,
        } for name, run in runs.items()},
        "model": model_parameters(model),
    }
    if baseline is not None:
        first = next(iter(baseline.values()))
        summary["baseline"] = {
            "laws": first.model.law_set.source,
            "cases": {name: {"impact_statistics": impact_statistics(run), "run": run.info}
                      for name, run in baseline.items()}}
    written.append(write_json(out / "statistics.json", _clean(summary)))
    with atomic_path(out / "report.md") as tmp:
        tmp.write_text(render_report(preset, runs, rows, notes, baseline))
    written.append(out / "report.md")
    for quantity in QUANTITIES:
        written.append(_plot_quantity(preset, runs, quantity, out / f"{quantity}.png"))
    written.append(_plot_impacts(runs, out / "impacts.png"))
    logger.info("wrote %d files to %s", len(written), out)
    return written
