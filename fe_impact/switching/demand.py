"""What the switching runs ask of a calibration: the closing speeds and forces of their impacts.

The calibration measures impacts at chosen closing speeds, and the torsional
model interpolates its laws between them, clamping outside. Which speeds
matter is the model's business: :func:`preset_demand` runs the seed's
condition sets (:data:`~fe_impact.switching.study.SEED_STUDIES`) and the
user's schedules (`fe_impact.switching.schedule`) on a gear set with the
closed-form laws (the first pass of the loop the main job closes: closed
forms, then FE at the speeds they produce, then the same runs again on the
calibration) and keeps, per stage and per law an impact's onset takes
(`fe_impact.switching.simulation.LAW_NAMES`), how many impacts there were and
their closing speeds and peak forces, and per stage the largest mesh force
of the runs (the force range the mesh cycle and the corner laws must span).

The runs take about half a minute on two processes (a fresh process also
compiles the model's kernel, some 16 s); the result is kept in the user's
cache (``fe-impact/demand``) under a key of the gear set, the condition sets
and the source of the package that computes it.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import tempfile
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from fe_impact.gears.gearset import GearSet
from fe_impact.switching.model import StageSchedule

logger = logging.getLogger(__name__)

__all__ = ["FORCE_MARGIN", "Demand", "LawDemand", "corner_impacts", "cover", "curve_top_force",
           "place_switches", "preset_demand", "top_speed"]

#: The closing speed of an FE case added at the top of a stage's range is the
#: largest the closed-form presets produce times this margin, rounded up to two
#: significant digits: the presets rerun on the calibrated laws close somewhat
#: faster or slower (measured on the seed set: 175-183 mm/s on the coarse
#: calibration against 196 mm/s with the closed forms).
TOP_MARGIN = 1.2


@dataclass(frozen=True)
class LawDemand:
    """The impacts of one stage that took one law: count, closing speeds [m/s]
    (least, median, largest), the largest peak force [N] and where they touched."""

    count: int
    speed_min: float
    speed_median: float
    speed_max: float
    force_max: float
    #: Median place of the touching pair on the line of action at the onsets,
    #: ``s`` [m] (`fe_impact.switching.simulation.ImpactEvents.position`).
    position_median: float = math.nan


#: The mesh cycle and the corner laws are measured up to this factor times the largest
#: mesh force of the first pass (issue: the laws must not be extrapolated at the forces
#: the runs on the calibration reach, which differ from the closed forms' by some 10%).
FORCE_MARGIN = 1.5


@dataclass(frozen=True)
class Demand:
    """Per stage (from 1) and law kind, the runs' impacts (`LawDemand`); per stage, the
    largest mesh force of the runs [N, per mesh]; the names of the presets and of the
    schedules run."""

    presets: tuple[str, ...]
    stages: dict[int, dict[str, LawDemand]]
    mesh_force: dict[int, float] = field(default_factory=dict)
    schedules: tuple[str, ...] = ()

    def top_mesh_force(self) -> float | None:
        """Largest mesh force of any stage [N] (None: no run engaged a stage)."""
        return max(self.mesh_force.values(), default=None)

    def top_speed(self, stage: int, laws: Sequence[str] = ("mesh", "switch")) -> float | None:
        """Largest closing speed [m/s] of the stage's impacts that took one of ``laws``."""
        rows = [self.stages.get(stage, {}).get(law) for law in laws]
        speeds = [r.speed_max for r in rows if r is not None]
        return max(speeds) if speeds else None

    def to_dict(self) -> dict:
        return {"presets": list(self.presets), "schedules": list(self.schedules),
                "stages": {str(s): {law: asdict(d) for law, d in laws.items()}
                           for s, laws in self.stages.items()},
                "mesh_force_max_N": {str(s): f for s, f in self.mesh_force.items()},
                "force_margin": FORCE_MARGIN}

    @classmethod
    def from_dict(cls, data: dict) -> Demand:
        return cls(tuple(data["presets"]),
                   {int(s): {law: LawDemand(**d) for law, d in laws.items()}
                    for s, laws in data["stages"].items()},
                   {int(s): float(f) for s, f in data.get("mesh_force_max_N", {}).items()},
                   tuple(data.get("schedules", ())))


#: A run's impacts: (stage, law code, closing speed, peak force, position) each; and per
#: stage (from 1) the largest mesh force of the run [N].
_Rows = tuple[list[tuple[int, int, float, float, float]], dict[int, float]]


def _run_preset(gearset: GearSet, name: str | StageSchedule) -> _Rows:
    """The impacts and mesh forces of preset ``name`` (or of one schedule) on the
    closed-form laws."""
    from fe_impact.switching.model import DriveModel
    from fe_impact.switching.presets import get_preset
    from fe_impact.switching.simulation import simulate

    model = DriveModel(gearset=gearset)
    schedules = ([name] if isinstance(name, StageSchedule)
                 else [case.schedule for case in get_preset(name).cases])
    out, forces = [], {}
    for schedule in schedules:
        run = simulate(model, schedule)
        ev = run.events
        out += list(zip(ev.stage.tolist(), ev.law.tolist(), ev.speed.tolist(),
                        ev.force.tolist(), ev.position.tolist(), strict=True))
        for stage in schedule.stages:
            # stage_stats[:, 2]: the signed mesh force, its largest magnitude either flank
            top = float(np.max(np.abs(run.stage_stats[stage - 1, 2, 1:3])))
            forces[stage] = max(forces.get(stage, 0.0), top)
    return out, forces


def _run_in_processes(gearset: GearSet, presets: Sequence[str | StageSchedule], n: int,
                      numba: Path) -> list[_Rows]:
    """`_run_preset` of every preset on ``n`` fresh processes, process ``i`` compiling
    its kernels into ``numba/w<i>`` (the folders of a local Dask cluster's workers).

    Each process gets its folder in its environment when it starts: the kernel's
    cache location is fixed when the module is imported, and two processes
    compiling one cached function into one folder at once can leave files that
    crash a later load (numba/numba#4807).
    """
    import multiprocessing
    import os

    context = multiprocessing.get_context("spawn")
    pools = []
    before = os.environ.get("NUMBA_CACHE_DIR")
    try:
        for i in range(n):
            os.environ["NUMBA_CACHE_DIR"] = str(numba / f"w{i}")
            pool = ProcessPoolExecutor(1, mp_context=context)
            pool.submit(os.getpid).result()     # started now, with this environment
            pools.append(pool)
    finally:
        if before is None:
            os.environ.pop("NUMBA_CACHE_DIR", None)
        else:
            os.environ["NUMBA_CACHE_DIR"] = before
    try:
        futures = [pools[k % n].submit(_run_preset, gearset, name)
                   for k, name in enumerate(presets)]
        return [f.result() for f in futures]
    finally:
        for pool in pools:
            pool.shutdown(cancel_futures=True)


def _key(gearset: GearSet, presets: Sequence[str], schedules: Sequence = ()) -> str:
    import fe_impact.physics
    import fe_impact.switching

    digest = hashlib.sha256(json.dumps({"gearset": asdict(gearset), "presets": list(presets),
                                        "schedules": [d.digest or repr(d.schedule)
                                                      for d in schedules]},
                                       sort_keys=True, default=repr).encode())
    for package in (fe_impact.switching, fe_impact.physics):
        for source in sorted(Path(package.__file__).parent.glob("*.py")):
            digest.update(source.read_bytes())
    return digest.hexdigest()[:24]


def preset_demand(gearset: GearSet, presets: Sequence[str] | None = None,
                  workers: int = 2, numba: Path | None = None,
                  schedules: Sequence = ()) -> Demand:
    """The closing speeds and forces the seed's condition sets and the user's
    ``schedules`` (`fe_impact.switching.schedule.DutyCycle`) produce on ``gearset`` with
    the closed-form laws (module docstring), from the user's cache when it has them.

    ``numba``: the calibration's folder of compiled kernels
    (:func:`fe_impact.calibration.sweep.numba_folder`); process ``i`` of the pool
    compiles into its ``w<i>``, which the sweep's worker ``i`` then loads (the
    switching studies at its end need the same kernel). None: a temporary folder.
    """
    from fe_impact.runtime import user_cache
    from fe_impact.switching.simulation import LAW_NAMES
    from fe_impact.switching.study import SEED_STUDIES

    presets = tuple(SEED_STUDIES if presets is None else presets)
    schedules = tuple(schedules)
    folder = user_cache("demand")
    path = None if folder is None else folder / f"{_key(gearset, presets, schedules)}.json"
    if path is not None and path.is_file():
        try:
            return Demand.from_dict(json.loads(path.read_text()))
        except (OSError, ValueError, KeyError, TypeError):
            logger.warning("preset demand cache %s unreadable; running the presets again", path)
    runs = [*presets, *(d.schedule for d in schedules)]
    if workers > 1 and len(runs) > 1:
        with tempfile.TemporaryDirectory(prefix="fe-impact-numba-") as scratch:
            results = _run_in_processes(gearset, runs, min(workers, len(runs)),
                                        Path(numba or scratch))
    else:
        results = [_run_preset(gearset, name) for name in runs]
    rows = [r for impacts, _ in results for r in impacts]
    mesh_force: dict[int, float] = {}
    for _, forces in results:
        for stage, force in forces.items():
            mesh_force[stage] = max(mesh_force.get(stage, 0.0), force)
    stages: dict[int, dict[str, LawDemand]] = {}
    if rows:
        table = np.array(rows, dtype=float)
        for stage in np.unique(table[:, 0]).astype(int):
            for code, law in LAW_NAMES.items():
                pick = table[(table[:, 0] == stage) & (table[:, 1] == code)]
                if len(pick):
                    stages.setdefault(int(stage), {})[law] = LawDemand(
                        len(pick), float(pick[:, 2].min()), float(np.median(pick[:, 2])),
                        float(pick[:, 2].max()), float(pick[:, 3].max()),
                        float(np.median(pick[:, 4])))
    demand = Demand(presets, stages, dict(sorted(mesh_force.items())),
                    tuple(d.name for d in schedules))
    if path is not None:
        from fe_impact.atomic import atomic_path

        try:
            with atomic_path(path) as tmp:
                tmp.write_text(json.dumps(demand.to_dict(), indent=1))
        except OSError as exc:
            logger.info("preset demand not cached (%s)", exc)
    return demand


def curve_top_force(demand: Demand) -> float | None:
    """The force [N] the mesh cycle's and the corner laws' quasi-static curves must reach:
    `FORCE_MARGIN` times the largest mesh force of the first pass, rounded up to two
    significant digits; None when the runs engaged no stage."""
    top = demand.top_mesh_force()
    if top is None or not top > 0.0:
        return None
    f = top * FORCE_MARGIN
    scale = 10.0 ** (math.floor(math.log10(f)) - 1)
    return math.ceil(f / scale - 1e-9) * scale


def top_speed(speed: float) -> float:
    """``speed`` times `TOP_MARGIN`, rounded up to two significant digits [m/s]."""
    v = speed * TOP_MARGIN
    scale = 10.0 ** (math.floor(math.log10(v)) - 1)
    return math.ceil(v / scale - 1e-9) * scale


def cover(demand: Demand, planned: Sequence, gearset: GearSet) -> tuple[list, list[str]]:
    """The planned FE impacts adjusted to the closing speeds the presets produce.

    A stage whose flank impacts (mesh and switch laws) close faster than its fastest
    planned impact gets an impact at `top_speed` of their fastest, in place of its
    fastest planned one when it has three or more (the main job's 100, 300 and
    1000 r/min: the calibration then spans 100 r/min to what the presets ask, at
    the same cost), else beside them. Returns the cases and one line per change.
    """
    from fe_impact.calibration.sweep import ImpactCase

    cases, lines = list(planned), []
    for stage in sorted({c.stage for c in planned}):
        need = demand.top_speed(stage)
        mesh = [c for c in cases if c.stage == stage and c.kind == "mesh"]
        if need is None or not mesh or need <= max(c.impact_speed for c in mesh):
            continue
        case = ImpactCase(stage, gearset.stages[stage - 1].teeth, "mesh", top_speed(need))
        fastest = max(mesh, key=lambda c: c.impact_speed)
        what = f"stage {stage}: flank impacts up to {need * 1e3:.4g} mm/s: an FE impact at " \
               f"{case.impact_speed * 1e3:.4g} mm/s"
        if len(mesh) >= 3:
            cases[cases.index(fastest)] = case
            what += f" in place of {fastest.id} ({fastest.impact_speed * 1e3:.4g} mm/s)"
        else:
            cases.append(case)
        lines.append(what)
    return cases, lines


def _two_digits(speed: float) -> float:
    """``speed`` rounded to two significant digits [m/s]."""
    return float(f"{speed:.2g}")


def corner_impacts(demand: Demand, gearset: GearSet, stages: Sequence[int]
                   ) -> tuple[list, list[str]]:
    """FE impacts on the rounded tip edges at the closing speeds the presets produce
    there: per stage and edge, the median and the largest closing speed of the
    impacts whose onset took that edge's corner law, to two significant digits
    (one case when they round alike). An edge the presets never struck, or a
    sharp one, gets none. Returns the cases and one line per stage and edge."""
    from fe_impact.calibration.sweep import ImpactCase
    from fe_impact.gears.corner import CORNER_SIDES, touching_edge

    cases, lines = [], []
    for stage in stages:
        teeth = gearset.stages[stage - 1].teeth
        for side in CORNER_SIDES:
            kind = f"corner-{side}"
            if touching_edge(gearset, side)[0] <= 0.0:
                lines.append(f"stage {stage}, {kind}: sharp edge, no corner impact")
                continue
            row = demand.stages.get(stage, {}).get(kind)
            if row is None or row.count == 0:
                lines.append(f"stage {stage}, {kind}: the presets never struck it, no FE "
                             "impact")
                continue
            speeds = sorted({_two_digits(row.speed_median), _two_digits(row.speed_max)})
            cases += [ImpactCase(stage, teeth, kind, v) for v in speeds]
            lines.append(f"stage {stage}, {kind}: {row.count} impacts in the presets, "
                         f"median {row.speed_median * 1e3:.3g} and largest "
                         f"{row.speed_max * 1e3:.3g} mm/s: FE impacts at "
                         f"{', '.join(f'{v * 1e3:.2g}' for v in speeds)} mm/s")
    return cases, lines


def place_switches(demand: Demand, planned: Sequence, gearset: GearSet
                   ) -> tuple[list, list[str]]:
    """The planned switch impacts moved to where the presets' first contacts after a
    ratio switch touched: the median place of a stage's switch impacts on the line of
    action, as a pinion roll angle (`fe_impact.switching.geometry.MeshGeometry.roll_at`;
    the coast flank's place is the mirror of
    the drive flank's, which the FE pair models). A place beyond the path's ends
    (a first touch on a tip edge) is taken at the nearest end of the FE path
    (`fe_impact.calibration.meshcycle.path_positions`' ends at the inset that every
    mesh level can make), and said so. Returns
    the cases and one line per stage moved."""
    from dataclasses import replace

    from fe_impact.calibration.meshcycle import path_positions
    from fe_impact.switching.geometry import mesh_geometry

    line = mesh_geometry(gearset)
    cases, lines = list(planned), []
    for stage in sorted({c.stage for c in planned if c.kind == "switch"}):
        row = demand.stages.get(stage, {}).get("switch")
        if row is None or not math.isfinite(row.position_median):
            lines.append(f"stage {stage}: the presets made no switch impact, the switch "
                         "cases strike at the pitch point")
            continue
        roll = math.degrees(float(line.roll_at(row.position_median)))
        ends = path_positions(gearset, stage, 2)
        lo, hi = min(ends), max(ends)
        where = f"{roll:+.3f} deg of pinion roll"
        if not lo <= roll <= hi:
            roll = min(max(roll, lo), hi)
            where += f" (beyond the FE path: taken at {roll:+.3f} deg)"
        for i, c in enumerate(cases):
            if c.stage == stage and c.kind == "switch":
                cases[i] = replace(c, roll_angle_deg=roll)
        lines.append(f"stage {stage}: the presets' {row.count} switch impacts touched at "
                     f"s = {row.position_median * 1e3:.3f} mm on the line of action, "
                     f"{where}: the switch cases strike there")
    return cases, lines
