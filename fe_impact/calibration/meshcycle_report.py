"""Mesh-cycle files and pictures: what a gear engineer looks at.

:func:`write_mesh_cycle` takes the positions a sweep measured
(:class:`~fe_impact.calibration.meshcycle.PositionRecord`) and writes

- ``mesh_cycle.json``: every position's load-approach curve and fitted law,
  and the loaded transmission error and mesh stiffness over one mesh cycle
  at three pinion torques per stage;
- ``mesh_cycle.csv``: one row per position;
- ``contact_pattern.png``: the pressure footprint at the largest force of
  every position on one drawing of the face-gear flank (radius against
  height), with the Hertz ellipse outlines and the flank's edges (the
  colours end at :data:`PRESSURE_QUANTILE` of the nodal pressures);
- ``stiffness_along_path.png``: the fitted ``K`` and exponent and the
  secant stiffness at the nominal load along the path of contact;
- ``transmission_error.png``: loaded TE and mesh stiffness over one cycle.

It returns the position-dependent law for ``calibration.json``
(:func:`position_law`); the pictures are drawn by a
:data:`~fe_impact.output.drawing.Draw` (the sweep's workers in a
calibration). :func:`report_lines` gives the report's section.
"""

from __future__ import annotations

import logging
import tomllib
from collections.abc import Callable
from pathlib import Path

import numpy as np

from fe_impact.atomic import atomic_path, write_csv, write_json
from fe_impact.calibration.meshcycle import SCHEMA, PositionRecord, mesh_cycle, path_of_contact
from fe_impact.output.drawing import Draw, draw_here

logger = logging.getLogger(__name__)

#: Besides the nominal one, the cycle is shown at the pinion torques that
#: load a single pair with these forces (N).
CYCLE_FORCES = (200.0, 1000.0)
CSV_COLUMNS = ("stage", "roll_angle_deg", "end", "K", "exponent", "fit_error",
               "nominal_force", "nominal_stiffness", "nominal_modelled", "lever", "edge",
               "n_dofs", "seconds")


def _by_stage(records: list[PositionRecord]) -> dict[int, list[PositionRecord]]:
    out: dict[int, list[PositionRecord]] = {}
    for r in sorted(records, key=lambda r: (r.stage, r.roll_angle_deg)):
        out.setdefault(r.stage, []).append(r)
    return out


def position_law(records: list[PositionRecord],
                 corners: list[PositionRecord] = ()) -> dict:
    """The position-dependent pair law per stage (``calibration.json``'s ``mesh_cycle``).

    ``corners``: the corner positions
    (:func:`~fe_impact.calibration.meshcycle.plan_corner_positions`), each stage's
    under ``"corners"``, keyed by side (``"approach"``, ``"recess"``).
    """
    law = {str(stage): {
        "roll_angle_deg": [r.roll_angle_deg for r in recs],
        "k": [r.stiffness for r in recs],
        "exponent": [r.exponent for r in recs],
        "fit_error": [r.fit_error for r in recs],
        "nominal_force": [r.nominal_force for r in recs],
        "nominal_stiffness": [r.nominal_stiffness for r in recs],
        "nominal_modelled": [r.nominal_modelled for r in recs],
        "edge": [r.edge for r in recs],
    } for stage, recs in _by_stage(records).items()}
    for r in corners:
        if str(r.stage) in law:
            law[str(r.stage)].setdefault("corners", {})[r.contact.removeprefix("corner-")] = {
                "roll_angle_deg": r.roll_angle_deg, "k": r.stiffness, "exponent": r.exponent,
                "fit_error": r.fit_error, "nominal_stiffness": r.nominal_stiffness,
                "edge": r.edge, "n_dofs": r.n_dofs, "forces": r.forces,
                "approaches": r.approaches, "hertz_approaches": r.hertz_approaches,
                "resolved": r.resolved}
    return law


def cycles(records: list[PositionRecord], pitch_deg: float,
           paths: dict[int, tuple[float, float]] | None = None) -> list:
    """Loaded TE and mesh stiffness per stage at the nominal torque and :data:`CYCLE_FORCES`.

    ``paths``: per stage, the first and last point of contact (deg of pinion
    roll); without it a stage's path is the span of its positions.
    """
    out = []
    for stage, recs in _by_stage(records).items():
        lever = float(np.mean([r.lever for r in recs]))
        path = (paths or {}).get(stage)
        for force in (recs[0].nominal_force, *CYCLE_FORCES):
            out.append(mesh_cycle(recs, pitch_deg, force * lever, path=path))
    return out


def write_mesh_cycle(out: Path, records: list[PositionRecord], gearset_text: str,
                     draw: Draw = draw_here) -> tuple[dict, Callable[[], list[str]]]:
    """Write the mesh-cycle files to ``out`` and start its pictures on ``draw``.

    ``records``: the positions along the path and any corner positions (kept
    apart: ``mesh_cycle.json``'s ``corners``, the law's ``corners``; the cycle
    and the pictures take the path's). Returns :func:`position_law` and what waits
    for the pictures (the names of those written).
    """
    from fe_impact.gears import gearset_from_dict

    corners = [r for r in records if r.contact != "flank"]
    records = [r for r in records if r.contact == "flank"]
    gearset = gearset_from_dict(tomllib.loads(gearset_text))
    pitch = 360.0 / gearset.pinion.teeth
    stages = sorted({r.stage for r in records})
    paths = {s: path_of_contact(gearset, s) for s in stages}
    results = cycles(records, pitch, paths)
    write_json(out / "mesh_cycle.json", {
        "schema": SCHEMA, "angular_pitch_deg": pitch,
        "path_of_contact_deg": {str(s): list(p) for s, p in paths.items()},
        "units": {"forces": "N", "approaches": "m", "torques": "N m", "rotations": "rad",
                  "K": "N/m^exponent", "nominal_stiffness": "N/m", "transmission_error": "m",
                  "mesh_stiffness": "N/m", "roll_deg": "deg"},
        "positions": [r.to_dict() for r in records],
        "corners": [r.to_dict() for r in corners],
        "cycles": [c.to_dict() for c in results]})
    write_csv(out / "mesh_cycle.csv", list(CSV_COLUMNS), [
        [r.stage, r.roll_angle_deg, r.end, r.stiffness, r.exponent, r.fit_error,
         r.nominal_force, r.nominal_stiffness, r.nominal_modelled, r.lever, r.edge, r.n_dofs,
         r.timings_s.get("total")] for r in sorted(records, key=lambda r: (r.stage,
                                                                           r.roll_angle_deg))])
    wait = draw([(name, plot, (records, results, out / name))
                 for name, plot in (("contact_pattern.png", _plot_pattern),
                                    ("stiffness_along_path.png", _plot_stiffness),
                                    ("transmission_error.png", _plot_cycle))])
    return position_law(records, corners), wait


def report_lines(section: dict) -> list[str]:
    """Markdown of the position-dependent law (``calibration.json``'s ``mesh_cycle``)."""
    lines = ["## The mesh cycle: single-pair stiffness along the path of contact", "",
             "Quasi-static FE of the tooth pair at each position (face-gear hub held, pinion "
             "torque): approach along the contact normal from first touch, against force. "
             "K and exponent fit F = K delta^e from 50 N up; the nominal stiffness is F/delta "
             "at the nominal load. Marked *: the nominal load's Hertz patch is narrower than "
             "one element of the mesh (made for the largest force), where the FE approach is "
             "the discrete contact's, not the pair's; its approach is then the Hertz approach "
             "of the contact analysis' ellipse plus the FE's compliance beyond Hertz "
             "(bending) at the smallest resolved force, in proportion to the force "
             "(`fe_approaches` in `mesh_cycle.json` keeps the FE's). `edge`: the pressure at "
             "the largest force reaches a flank edge. Files: `mesh_cycle.json`, "
             "`mesh_cycle.csv`.", "",
             "| stage | roll (deg) | K | exponent | fit error | k at nominal load (N/m) "
             "| edge |", "|---|---|---|---|---|---|---|"]
    loads = [f"stage {stage} {law['nominal_force'][0]:.3g} N"
             for stage, law in section.items() if law.get("nominal_force")]
    if loads:   # older calibrations do not carry them
        lines[4:4] = ["Nominal load per mesh (the seed presets' largest load torque): "
                      + ", ".join(loads) + ".", ""]
    for stage, law in section.items():
        modelled = law.get("nominal_modelled") or [False] * len(law["roll_angle_deg"])
        for i, roll in enumerate(law["roll_angle_deg"]):
            lines.append(f"| {stage} | {roll:+.3f} | {law['k'][i]:.4g} | "
                         f"{law['exponent'][i]:.3f} | {law['fit_error'][i]:.1%} | "
                         f"{law['nominal_stiffness'][i]:.4g}{' *' if modelled[i] else ''} | "
                         f"{law['edge'][i] or '-'} |")
    lines += ["", "![contact pattern](contact_pattern.png)", "",
              "![stiffness along the path](stiffness_along_path.png)", "",
              "![transmission error](transmission_error.png)", ""]
    return lines + _corner_lines(section)


def _corner_lines(section: dict) -> list[str]:
    """Markdown of the FE corner positions (``--corners``), if the section has them."""
    rows = [(stage, side, c) for stage, law in section.items()
            for side, c in sorted((law.get("corners") or {}).items())]
    if not rows:
        return []
    lines = ["### The tip-edge corners", "",
             "Quasi-static FE of each rounded tip edge's first touch (the roll angle of the "
             "closed-form corner laws), measured like the positions: approach from first "
             "touch, bending included. Its K and exponent replace the Hertz stiffness of the "
             "rounding in the corner laws (restitution and damping stay closed forms). "
             "Beside it, the Hertz approach of the rounding's ellipse alone (no bending), "
             "the closed form's premise: a smaller FE approach means the contact does not "
             "stay on the rounding (it spreads onto the flank beside it). Marked *: a force "
             "whose Hertz patch is narrower than one element, where the approach is modelled "
             "as on the positions (Hertz plus the FE's compliance beyond it), so its ratio "
             "says nothing of where the contact lies.", "",
             "| stage | edge | roll (deg) | K | exponent | fit error | DOFs | FE / Hertz "
             "approach at the forces (N) |", "|---|---|---|---|---|---|---|---|"]
    for stage, side, c in rows:
        forces = c.get("forces", [])
        resolved = c.get("resolved") or [True] * len(forces)   # older files: no marks
        ratios = ", ".join(f"{a / h:.2f}{'' if ok else '*'} ({f:.0f})" for f, a, h, ok in zip(
            forces, c.get("approaches", []), c.get("hertz_approaches", []), resolved,
            strict=True) if h > 0)
        lines.append(f"| {stage} | {side} | {c['roll_angle_deg']:+.3f} | {c['k']:.4g} | "
                     f"{c['exponent']:.3f} | {c['fit_error']:.1%} | {c.get('n_dofs', '-')} | "
                     f"{ratios or '-'} |")
    return lines + [""]


# -- pictures -----------------------------------------------------------------------------
def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> None:
    plt = _pyplot()
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


def _plot_pattern(records, _results, path: Path) -> None:
    plt = _pyplot()
    stages = _by_stage(records)
    fig, axes = plt.subplots(len(stages), 1, figsize=(9, 3.2 * len(stages)), squeeze=False)
    for ax, (stage, recs) in zip(axes[:, 0], stages.items(), strict=True):
        for seg in np.asarray(recs[0].flank_edges).reshape(-1, 4) * 1e3:
            ax.plot(seg[[0, 2]], seg[[1, 3]], color="0.3", lw=0.8)
        footprints = [np.asarray(r.footprint).reshape(-1, 3) for r in recs]
        p_all = np.concatenate([fp[:, 2] for fp in footprints])
        top, scale = _pressure_scale(p_all)
        for r, fp in zip(recs, footprints, strict=True):
            sc = ax.scatter(fp[:, 0] * 1e3, fp[:, 1] * 1e3, c=fp[:, 2] / 1e6, s=4,
                            cmap="inferno", vmin=0, vmax=scale / 1e6)
            el = np.asarray(r.ellipse_outline) * 1e3
            ax.plot(el[:, 0], el[:, 1], color="tab:cyan", lw=0.9)
        label = "pressure at the largest force (MPa)"
        if top > scale:
            label = (f"pressure at the largest force (MPa;\nthe top "
                     f"{1.0 - PRESSURE_QUANTILE:.0%} up to {top / 1e6:.0f})")
        fig.colorbar(sc, ax=ax, label=label, extend="max" if top > scale else "neither")
        ax.set(xlabel="radius on the face gear (mm)", ylabel="height (mm)",
               title=f"stage {stage}: contact pattern over the path (FE pressure; Hertz "
                     "ellipses in cyan; flank edges in grey)")
        ax.set_aspect("equal", adjustable="datalim")
    _save(fig, path)


#: The contact pattern's colour scale ends at this quantile of the nodal pressures
#: (the rest is drawn in the top colour): where the patch is cut by a flank edge
#: (the ring's inner end at stage 1) the edge nodes carry several times the Hertz
#: pressure, which would leave the whole pattern in the scale's bottom tenth.
PRESSURE_QUANTILE = 0.99


def _pressure_scale(pressures: np.ndarray) -> tuple[float, float]:
    """The largest pressure and the colour scale's top (Pa) of a contact pattern."""
    p = pressures[pressures > 0]
    if len(p) == 0:
        return 1.0, 1.0
    return float(p.max()), float(np.quantile(p, PRESSURE_QUANTILE))


def _plot_stiffness(records, _results, path: Path) -> None:
    plt = _pyplot()
    fig, ax = plt.subplots(1, 3, figsize=(14, 4))
    for stage, recs in _by_stage(records).items():
        roll = [r.roll_angle_deg for r in recs]
        line, = ax[0].plot(roll, [r.nominal_stiffness / 1e6 for r in recs], "o-",
                           label=f"stage {stage}")
        modelled = [r for r in recs if r.nominal_modelled]
        if modelled:   # hollow: the modelled nominal approach (complete_curve)
            ax[0].plot([r.roll_angle_deg for r in modelled],
                       [r.nominal_stiffness / 1e6 for r in modelled], "o", mfc="white",
                       color=line.get_color())
        ax[1].plot(roll, [r.stiffness for r in recs], "o-", label=f"stage {stage}")
        ax[2].plot(roll, [r.exponent for r in recs], "o-", label=f"stage {stage}")
        for r in recs:
            if r.edge:
                ax[0].plot(r.roll_angle_deg, r.nominal_stiffness / 1e6, "x", color="k")
    ax[0].set(ylabel="single-pair stiffness at the nominal load (N/um)")
    ax[1].set(ylabel="K of F = K delta^e", yscale="log")
    ax[2].set(ylabel="exponent e")
    for a in ax:
        a.set(xlabel="pinion roll angle (deg)")
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    ax[0].set_title("x: pressure reaches a flank edge\nhollow: the nominal patch narrower than "
                    "an element,\nHertz + the FE's bending compliance", fontsize=8)
    _save(fig, path)


def _plot_cycle(_records, results, path: Path) -> None:
    plt = _pyplot()
    fig, ax = plt.subplots(1, 2, figsize=(13, 4.2))
    for c in results:
        label = f"stage {c.stage}, {c.torque:.3g} N m"
        line, = ax[0].plot(c.roll_deg, c.transmission_error * 1e6, label=label)
        ax[1].plot(c.roll_deg, c.mesh_stiffness / 1e6, color=line.get_color(), label=label)
    ax[0].set(ylabel="loaded transmission error (um, line of action)")
    ax[1].set(ylabel="mesh stiffness (N/um)")
    for a in ax:
        a.set(xlabel="pinion roll angle over one mesh cycle (deg)")
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    _save(fig, path)


__all__ = ["CSV_COLUMNS", "cycles", "position_law", "report_lines", "write_mesh_cycle"]
