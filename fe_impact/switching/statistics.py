"""Statistics of a switching run in the seed's layout, and their comparison with the seed.

Two sets, both per stage (engaged ring), for the four quantities of the
seed's tables:

- **series statistics** (what the seed's tables appear to be: average,
  maximum and minimum of a signed time history), over every accepted
  integration step while the stage is engaged:

  - elastic displacement: the contact approach of the mesh, positive on the
    drive flank, negative on the coast flank, 0 in free flight (largest
    approach of the flank's tooth pairs);
  - impact speed: the relative speed of pinion and ring along the line of
    action, ``r_bp omega_p - r_bi omega_i`` (positive closing the drive
    flank); at a contact onset it is the closing speed;
  - impact force: the normal mesh force, drive minus coast flank;
  - potential energy: elastic energy stored in the mesh's contacts,
    ``sum k h^(n+1) / (n+1)`` (>= 0).

  The average is the time average; all values are per mesh (one of the
  ``n_pinions`` meshes).
- **impact statistics**: average, maximum and minimum over the impacts
  (contact onsets with a closing speed, `model.ImpactEvents`) of the
  closing speed, peak approach, peak force and peak elastic energy.
"""

from __future__ import annotations

import numpy as np

from fe_impact.switching.presets import Preset
from fe_impact.switching.seed_tables import (
    QUANTITIES,
    SEED_TABLES,
    SEED_UNITS,
    STATISTICS,
    TO_SEED_UNITS,
)
from fe_impact.switching.simulation import (
    CONTACT_NAMES,
    SERIES_QUANTITIES,
    ImpactEvents,
    SwitchingRun,
)

__all__ = ["comparison_rows", "impact_statistics", "series_statistics"]

Stats = tuple[float, float, float]  # average, maximum, minimum
ALL = "all"


def series_statistics(run: SwitchingRun) -> dict[str, dict[str, Stats]]:
    """Series statistics (SI) per engaged stage (``"1"``, ``"2"``, ...) and ``"all"``.

    Stages never engaged are left out.
    """
    st = run.stage_stats
    out: dict[str, dict[str, Stats]] = {}
    engaged = [i for i in range(st.shape[0]) if st[i, 0, 3] > 0.0]
    for i in engaged:
        out[str(i + 1)] = {q: (st[i, j, 0] / st[i, 0, 3], st[i, j, 1], st[i, j, 2])
                           for j, q in enumerate(SERIES_QUANTITIES)}
    total = sum(st[i, 0, 3] for i in engaged)
    if engaged:
        out[ALL] = {q: (sum(st[i, j, 0] for i in engaged) / total,
                        max(st[i, j, 1] for i in engaged), min(st[i, j, 2] for i in engaged))
                    for j, q in enumerate(SERIES_QUANTITIES)}
    return out


def _summary(values: np.ndarray) -> Stats:
    if values.size == 0:
        return (np.nan, np.nan, np.nan)
    return (float(np.mean(values)), float(np.max(values)), float(np.min(values)))


def _impact_summary(events: ImpactEvents) -> dict:
    return {
        "count": len(events),
        "elastic_displacement": _summary(events.approach),
        "impact_speed": _summary(events.speed),
        "impact_force": _summary(events.force),
        "potential_energy": _summary(events.energy),
        "restitution": _summary(events.restitution[np.isfinite(events.restitution)]),
    }


def impact_statistics(run: SwitchingRun) -> dict[str, dict[str, dict]]:
    """Impact statistics (SI) per stage and ``"all"``, each by kind and ``"all"``.

    ``result[stage][kind]`` has ``count`` and, per quantity, (average,
    maximum, minimum); kinds ``rattle``, ``mesh-in``, ``switch``.
    ``result[stage]["contacts"][kind][place]`` splits each kind (and
    ``"all"``) by where the pair touched: ``flank``, ``corner-approach``,
    ``corner-recess`` (`simulation.CONTACT_NAMES`).
    """
    out: dict[str, dict[str, dict]] = {}
    stages = [str(s) for s in sorted(set(run.events.stage.tolist()))]
    kinds = ("rattle", "mesh-in", "switch")
    for key in [*stages, ALL]:
        events = run.events if key == ALL else run.events.select(stage=int(key))
        out[key] = {kind: _impact_summary(events.select(kind=kind)) for kind in kinds}
        out[key][ALL] = _impact_summary(events)
        out[key]["contacts"] = {
            kind: {place: _impact_summary(
                (events if kind == ALL else events.select(kind=kind)).select(contact=place))
                for place in CONTACT_NAMES.values()}
            for kind in (*kinds, ALL)}
    return out


def _columns(preset: Preset, runs: dict[str, SwitchingRun]) -> list[tuple[str, dict, dict]]:
    """(seed condition, series stats, impact stats) per column of the seed table."""
    columns = []
    if preset.layout == "conditions":
        key = str(preset.stage)
        for case in preset.cases:
            run = runs[case.name]
            columns.append((case.condition, series_statistics(run).get(key, {}),
                            impact_statistics(run).get(key, {}).get(ALL, {})))
    else:
        run = runs[preset.cases[0].name]
        series, impacts = series_statistics(run), impact_statistics(run)
        # the seed's multistage tables have stages 1-3; a user's schedule, the stages it runs
        stages = (1, 2, 3) if preset.seed_table is not None else sorted(run.schedule.stages)
        for key, label in [*((str(i), f"stage {i}") for i in stages), (ALL, "all stages")]:
            columns.append((label, series.get(key, {}), impacts.get(key, {}).get(ALL, {})))
    return columns


def comparison_rows(preset: Preset, runs: dict[str, SwitchingRun]) -> list[dict]:
    """Model statistics beside the seed's, in the seed's units.

    One row per seed condition (column), quantity and statistic, with keys
    ``condition, quantity, statistic, unit, model_series, model_impacts,
    seed`` (None where a value does not exist).
    """
    table = None if preset.seed_table is None else SEED_TABLES[preset.seed_table]
    rows = []
    for condition, series, impacts in _columns(preset, runs):
        for quantity in QUANTITIES:
            scale = TO_SEED_UNITS[quantity]
            for k, statistic in enumerate(STATISTICS):
                model = series.get(quantity)
                hits = impacts.get(quantity)
                seed = table.value(quantity, statistic, condition) \
                    if table is not None and condition in table.conditions else None
                rows.append({
                    "condition": condition,
                    "quantity": quantity,
                    "statistic": statistic,
                    "unit": SEED_UNITS[quantity],
                    "model_series": None if model is None else float(model[k] * scale),
                    "model_impacts": None if hits is None or not np.isfinite(hits[k])
                    else float(hits[k] * scale),
                    "seed": seed,
                })
    return rows
