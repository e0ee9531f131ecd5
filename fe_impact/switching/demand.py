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

from fe_impact.calibration.planning import (  # noqa: F401 (planning from a Demand: importable here)
    TOP_MARGIN,
    corner_impacts,
    cover,
    place_switches,
    top_speed,
)
from fe_impact.gears.gearset import GearSet
from fe_impact.switching.model import StageSchedule

logger = logging.getLogger(__name__)

__all__ = ["FORCE_MARGIN", "Demand", "LawDemand", "corner_impacts", "cover", "curve_top_force",
           "place_switches", "preset_demand", "top_speed"]

@dataclass(frozen=True)
class LawDemand:
    """The impacts of one stage that took one law: count, closing speeds [m/s]
    (least, median, largest), the largest peak force [N], where they touched, and the
    least and median peak force [N]."""

    count: int
    speed_min: float
    speed_median: float
    speed_max: float
    force_max: float
    #: Median place of the touching pair on the line of action at the onsets,
    #: ``s`` [m] (`fe_impact.switching.simulation.ImpactEvents.position`).
    position_median: float = math.nan
    force_min: float = math.nan
    force_median: float = math.nan


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
                        float(np.median(pick[:, 4])), float(pick[:, 3].min()),
                        float(np.median(pick[:, 3])))
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
