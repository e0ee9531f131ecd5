"""The main job: FE tooth impacts of a gear set -> the lumped IMPACT law of each stage."""

from __future__ import annotations

import contextlib
import json
import logging
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from fe_impact.api.common import Echo, PathLike, say_to
from fe_impact.api.readers import cores, read_calibration, read_gearset, read_schedule
from fe_impact.errors import CalibrationError

if TYPE_CHECKING:
    from fe_impact.calibration.planning import ImpactCase, Settings
    from fe_impact.calibration.records import Calibration
    from fe_impact.gears.gearset import GearSet
    from fe_impact.switching.demand import Demand
    from fe_impact.switching.schedule import DutyCycle

__all__ = ["calibrate", "calibration_summary", "seed_studies"]

logger = logging.getLogger(__name__)


def calibrate(gearset: PathLike | None = None, *, out: PathLike = "out/calibration",
              stages: Sequence[int] | None = None, speeds: Sequence[float] | None = None,
              impact_speeds: Sequence[float] | None = None, switch: str | bool | None = None,
              positions: int | Sequence[float] | None = None, mesh_cycle: bool = True,
              corners: bool = False, corner_impacts: bool = False, switching: bool = True,
              preset_speeds: bool = True, level: str = "default",
              mesh_cycle_level: str | None = None, integrator: str = "newmark",
              workers: int | None = None, scheduler: str | None = None,
              cache: PathLike = "cache", schedules: Sequence[PathLike] = (),
              progress: Callable[[int, int, str], None] | None = None,
              echo: Echo | None = None) -> Calibration:
    """FE tooth impacts of a gear set -> the lumped IMPACT law of each stage (the main job).

    Meshes the tooth pair of each stage, runs the FE impacts at the impact
    speeds of the operating speeds (seed eq. 4 in mesh, eq. 5 for a ratio
    switch) and, unless ``mesh_cycle`` is False, the quasi-static single-pair
    curves along the path of contact; fits the ADAMS IMPACT parameters and
    writes ``calibration.json``/``.csv``, ``report.md``, plots and a PVD series
    per impact, and ``summary.json`` to ``out``; then runs the seed's switching
    studies on it (``switching``). Finished cases are kept: a second call
    with the same inputs resumes. It is what ``fe-impact calibrate`` does; each
    keyword is the option of the same name.

    The FE contact takes the gear set's flank friction (``[friction]``, default
    the seed's); with friction, one impact and one mesh-cycle position are solved
    again frictionless for the report's friction section
    (:func:`fe_impact.calibration.planning.friction_companions`).

    Parameters
    ----------
    gearset : str or path-like, optional
        The gear-set TOML file (its text keys the resume); None: the seed set.
    out : str or path-like
        Output folder.
    stages : sequence of int, optional
        Stage numbers (from 1); None: all.
    speeds : sequence of float, optional
        Operating (pinion) speeds [r/min]; None: 100, 300, 1000.
    impact_speeds : sequence of float, optional
        Impact speeds [m/s] instead of ``speeds``.
    switch : {"eq5", "kinematic", "both"} or bool, optional
        Also ratio-switch impacts into stages 2.. at each speed's switching
        speed (seed eq. 5, rigid kinematics, or both; True: both).
    positions : int or sequence of float, optional
        Mesh-cycle positions: a count along the path of contact (default 9) or
        pinion roll angles [deg].
    mesh_cycle : bool
        False: impacts only, no single-pair curves along the path.
    corners : bool
        Also the quasi-static first touch of each rounded tip edge.
    corner_impacts : bool
        Also FE impacts on the rounded tip edges (expensive: see the command's help).
    switching : bool
        End with the seed's switching studies on the calibration.
    preset_speeds : bool
        Fit the impacts to the closing speeds the seed's presets produce with
        the closed-form laws (a first pass, cached per gear set).
    level : {"coarse", "default", "fine"}
        Mesh level of the impacts.
    mesh_cycle_level : str, optional
        Mesh level of the mesh-cycle positions; None: one level below ``level``.
    integrator : {"newmark", "explicit"}
    workers : int, optional
        Local Dask workers; None: one per core, at most one per case.
    scheduler : str, optional
        Address of an existing ``dask.distributed`` scheduler instead.
    cache : str or path-like
        Mesh cache folder.
    schedules : sequence of str or path-like
        The user's schedule files (:func:`read_schedule`): their closing speeds
        join the presets' in the first pass (the impacts are struck at them, the
        mesh-cycle curves reach their largest mesh force), and with
        ``switching`` each is run as a study on the calibration.
    progress : callable, optional
        ``progress(done, total, last_case_id)`` as cases finish.
    echo : callable, optional
        Receives the plan's and the result's lines.

    Returns
    -------
    Calibration
        The calibration written to ``out/calibration.json``.

    Notes
    -----
    The cases run on Dask worker processes (or an existing scheduler's), which
    import the calling script again: in a script, call this under ``if __name__
    == "__main__":`` (Python's multiprocessing "spawn" rule). Interrupted
    (SIGINT, :class:`KeyboardInterrupt`), the finished cases are kept,
    ``summary.json`` says ``"stopped"``, and the interrupt is raised again.

    Examples
    --------
    One coarse impact of stage 1 at 300 r/min, without the mesh cycle and the
    switching studies (about a minute on one core)::

        cal = fe_impact.calibrate(stages=[1], speeds=[300], level="coarse",
                                  mesh_cycle=False, switching=False,
                                  preset_speeds=False, out="cal")
        cal.cases[0].parameters.k     # N/m^exponent
    """
    from fe_impact.calibration.cluster import check_scheduler_address, numba_folder
    from fe_impact.calibration.planning import Settings
    from fe_impact.output.files import check_output_dir

    say = say_to(echo)
    out, cache = Path(out), Path(cache)
    _check_run_options(workers, scheduler, level, mesh_cycle_level, integrator)
    if scheduler is not None:
        check_scheduler_address(scheduler)
    check_output_dir(out)
    check_output_dir(cache, "--cache")
    with contextlib.ExitStack() as stack:
        # the local workers' compiled kernels, held for the run: the presets' first
        # pass compiles the switching kernel into them, which the studies reuse
        numba = None if scheduler is not None else stack.enter_context(numba_folder(cache))
        path = Path(gearset) if gearset is not None else _seed_path()
        gs = read_gearset(path)
        text = path.read_text(encoding="utf-8-sig")
        duties = _schedules(schedules, gs)
        settings = Settings(level=level, integrator=integrator, cycle_level=mesh_cycle_level)
        plan = _Plan(gs, None if stages is None else list(stages), settings, positions,
                     mesh_cycle, corners)
        cases = plan.impacts(speeds, impact_speeds, switch)
        plan.check_cycle_options(mesh_cycle_level)
        cycle = plan.positions(cases)    # checks the options before the presets run
        presets_run = seed_studies(gs, plan.stages)
        if corner_impacts and not presets_run:
            raise CalibrationError("--corner-impacts: none of the seed's switching presets "
                                   "runs on these stages, so there are no corner closing "
                                   "speeds to strike at; add stages or drop the option")
        studies = (*presets_run, *(str(Path(p).resolve()) for p in schedules)) \
            if switching else ()
        given = speeds is not None or impact_speeds is not None
        demand = None
        switches = any(c.kind == "switch" for c in cases)
        if (presets_run or duties) and preset_speeds and (
                switches or corner_impacts or duties or (studies and not given)):
            demand = _first_pass(gs, presets_run, out, numba, say, duties)
        if demand is not None and (studies or duties) and not given:
            covered = _covered(demand, cases, gs, say)
            if covered != cases:
                cases = covered
                cycle = plan.positions(cases)
        if demand is not None and duties:
            cycle = plan.positions(cases, _curve_top_force(demand))
        if demand is not None and switches:
            cases = _placed_switches(demand, cases, gs, say)
        if corner_impacts:
            cases = cases + _corner_impacts(demand, gs, cases, say)
        path = _sweep(text, cases, cycle, settings, out, cache, workers, scheduler, progress,
                      studies, numba, say)
        return read_calibration(path)


def _seed_path() -> Path:
    from fe_impact.gears.gearset import default_gearset_path

    return default_gearset_path()


def _check_run_options(workers: int | None, scheduler: str | None, level: str,
                       cycle_level: str | None, integrator: str) -> None:
    """The run's options, before any work; a warning for more workers than cores."""
    from fe_impact.defaults import LEVEL_NAMES
    from fe_impact.fe.case import INTEGRATORS

    if workers is not None and workers < 1:
        raise CalibrationError(f"--workers {workers}: must be at least 1")
    n = cores() if workers is not None and scheduler is None else None
    if n is not None and workers > n:
        logger.warning("--workers %d on %d cores: the workers share the cores (no faster) "
                       "and each holds its case's memory (up to 3 GB at the default "
                       "level, 10 GB for a corner impact)", workers, n)
    for option, value, allowed in (("--level", level, LEVEL_NAMES),
                                   ("--mesh-cycle-level", cycle_level, LEVEL_NAMES),
                                   ("--integrator", integrator, INTEGRATORS)):
        if value is not None and value not in allowed:
            raise CalibrationError(f"{option} {value!r}: pick one of {', '.join(allowed)}")


class _Plan:
    """The cases of a calibration: the impacts, and the mesh-cycle positions that go
    with them."""

    def __init__(self, gearset: GearSet, stages: list[int] | None, settings: Settings,
                 positions: int | Sequence[float] | None, mesh_cycle: bool,
                 corners: bool) -> None:
        self.gearset, self.stages, self.settings = gearset, stages, settings
        self.given_positions, self.mesh_cycle, self.corners = positions, mesh_cycle, corners

    def impacts(self, speeds, impact_speeds, switch) -> list[ImpactCase]:
        """The planned FE impacts (:func:`fe_impact.calibration.planning.plan_cases`)."""
        from fe_impact.calibration.planning import plan_cases

        return plan_cases(self.gearset, self.stages, None if speeds is None else list(speeds),
                          None if impact_speeds is None else list(impact_speeds), switch)

    def check_cycle_options(self, cycle_level: str | None) -> None:
        """Options that need the mesh cycle, refused without it."""
        if self.mesh_cycle:
            return
        if self.given_positions is not None:
            raise CalibrationError("--positions and --no-mesh-cycle: give one or the other")
        if cycle_level is not None:
            raise CalibrationError("--mesh-cycle-level and --no-mesh-cycle: give one or the "
                                   "other")
        if self.corners:
            raise CalibrationError("--corners and --no-mesh-cycle: the corner positions are "
                                   "part of the mesh cycle; give one or the other")

    def positions(self, impacts: list[ImpactCase], top_force: float | None = None) -> list:
        """The mesh-cycle cases, reaching the largest impact force the sweep expects
        (Hertz estimate at the pitch point, a quarter above for the bending), or
        ``top_force`` [N] if larger (the schedules' mesh force)."""
        if not self.mesh_cycle:
            return []
        from fe_impact.calibration.meshcycle import (
            DEFAULT_POSITIONS,
            plan_corner_positions,
            plan_positions,
        )
        from fe_impact.gears.pairanalysis import hertz_impact_estimate

        s = self.settings
        top = max((1.25 * hertz_impact_estimate(self.gearset, c.stage, s.roll_angle_deg,
                                                c.impact_speed).force_max for c in impacts),
                  default=None)
        if top_force is not None:
            top = top_force if top is None else max(top, top_force)
        given = self.given_positions
        flank = plan_positions(self.gearset, self.stages,
                               DEFAULT_POSITIONS if given is None
                               else given if isinstance(given, int) else list(given),
                               top_force=top, level=s.position_level)
        if not self.corners:
            return flank
        corners = plan_corner_positions(self.gearset, self.stages, top_force=top)
        if not corners:
            raise CalibrationError("--corners: the gear set's tip edges are sharp "
                                   "(tip_edge_radius_mm = 0 on the pinion and the face "
                                   "gears): there is no rounding to touch")
        return flank + corners


def seed_studies(gearset: GearSet, stages: Sequence[int] | None = None) -> tuple[str, ...]:
    """The seed's switching studies a calibration of ``stages`` has laws for.

    Parameters
    ----------
    gearset : GearSet
    stages : sequence of int, optional
        The calibrated stages; None: all of the gear set's.

    Returns
    -------
    tuple of str
        Names of :data:`fe_impact.switching.study.SEED_STUDIES` engaging only
        those stages.
    """
    from fe_impact.switching.presets import get_preset
    from fe_impact.switching.study import SEED_STUDIES, study_stages

    have = set(stages) if stages else set(range(1, len(gearset.stages) + 1))
    return tuple(name for name in SEED_STUDIES if study_stages(get_preset(name)) <= have)


def _schedules(paths: Sequence[PathLike], gearset: GearSet) -> tuple[DutyCycle, ...]:
    """The user's schedule files, read and checked against the gear set."""
    duties = tuple(read_schedule(p) for p in paths)
    for duty in duties:
        duty.check_gearset(gearset)
    return duties


def _curve_top_force(demand: Demand) -> float | None:
    """The force [N] the mesh-cycle curves reach for the first pass's mesh forces."""
    from fe_impact.switching.demand import curve_top_force

    return curve_top_force(demand)


def _first_pass(gearset: GearSet, presets_run: Sequence[str], out: Path, numba: Path | None,
                say: Echo, duties: Sequence[DutyCycle] = ()) -> Demand:
    """The loop's first pass: the seed presets and the user's schedules on the
    closed-form laws, their closing speeds and places written to
    ``out/preset_demand.json`` (:func:`fe_impact.switching.demand.preset_demand`)."""
    from fe_impact.calibration.planning import TOP_MARGIN
    from fe_impact.output.files import write_json
    from fe_impact.switching.demand import preset_demand

    runs = f"presets {', '.join(presets_run)}"
    if duties:
        names = f"schedules {', '.join(d.name for d in duties)}"
        runs = f"{runs} and {names}" if presets_run else names
    say(f"switching {runs} on the closed-form laws: their closing speeds ...")
    demand = preset_demand(gearset, presets_run, numba=numba, schedules=duties)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "preset_demand.json", {**demand.to_dict(), "top_margin": TOP_MARGIN,
                                            "units": {"speed": "m/s", "force": "N",
                                                      "position": "m"}})
    return demand


def _covered(demand: Demand, cases: list, gearset: GearSet, say: Echo) -> list:
    """The planned impacts adjusted to the presets' closing speeds
    (:func:`fe_impact.calibration.planning.cover`), each change said."""
    from fe_impact.calibration.planning import cover

    covered, lines = cover(demand, cases, gearset)
    for line in lines:
        say(f"  {line}")
    return covered


def _placed_switches(demand: Demand, cases: list, gearset: GearSet, say: Echo) -> list:
    """The switch impacts struck where the presets' first contacts after a switch
    touched (:func:`fe_impact.calibration.planning.place_switches`)."""
    from fe_impact.calibration.planning import place_switches

    placed, lines = place_switches(demand, cases, gearset)
    for line in lines:
        say(f"  {line}")
    return placed


def _corner_impacts(demand: Demand | None, gearset: GearSet, cases: list, say: Echo) -> list:
    """The FE impacts on the rounded tip edges at the presets' closing speeds
    (:func:`fe_impact.calibration.planning.corner_impacts`)."""
    from fe_impact.calibration.planning import corner_impacts

    if demand is None:
        raise CalibrationError("--corner-impacts and --no-preset-speeds: the corner "
                               "impacts' closing speeds come from the presets' first "
                               "pass; give one or the other")
    extra, lines = corner_impacts(demand, gearset, sorted({c.stage for c in cases}))
    for line in lines:
        say(f"  {line}")
    if not extra:
        raise CalibrationError("--corner-impacts: the presets struck no rounded tip "
                               "edge of these stages (or the edges are sharp)")
    return extra


def _sweep(text: str, impacts: list, cycle: list, settings: Settings, out: Path, cache: Path,
           workers: int | None, scheduler: str | None, progress, studies: Sequence[str],
           numba: Path | None, say: Echo) -> Path:
    """Run the planned cases (:func:`fe_impact.calibration.execution.calibrate`) and say
    what was written; returns the path of calibration.json."""
    import tomllib

    from fe_impact.calibration.execution import Studies
    from fe_impact.calibration.execution import calibrate as run
    from fe_impact.calibration.planning import friction_companions
    from fe_impact.gears import gearset_from_dict
    from fe_impact.switching.study import seed_study_job, study_folder

    gearset = gearset_from_dict(tomllib.loads(text))
    companions = friction_companions(gearset, impacts, cycle)
    cases = impacts + cycle + companions
    levels = settings.level if settings.position_level == settings.level or not cycle \
        else f"{settings.level} / {settings.position_level}"
    fr = gearset.friction
    flanks = (f"flank friction mu_static {fr.mu_static:g}, mu_dynamic {fr.mu_dynamic:g}"
              if fr.active else "frictionless flanks")
    say(f"calibrating {len(impacts)} impacts and {len(cycle)} mesh-cycle positions "
        f"({levels} meshes, {settings.integrator}, {flanks}) -> {out}")
    if companions:
        say(f"  and {len(companions)} frictionless companions for the report's friction "
            f"section: {', '.join(c.id for c in companions)}")
    path = run(text, cases, settings, out, cache, workers, scheduler, progress,
               Studies(tuple(studies), seed_study_job, study_folder), numba)
    say(f"wrote {path}, {out / 'calibration.csv'} and {out / 'report.md'}")
    for line in calibration_summary(path):
        say(f"  {line}")
    if studies:
        names = [Path(s).stem if s.endswith(".toml") else s for s in studies]
        say(f"switching studies {', '.join(names)} on it: {out / 'switching'}")
    return Path(path)


def calibration_summary(path: PathLike) -> list[str]:
    """A few lines per stage of a ``calibration.json``: what the FE impacts fitted
    against the closed form, and the mesh cycle's single-pair stiffness along the
    path (``report.md`` has the tables)."""
    from fe_impact.calibration.report import terminal_summary

    return terminal_summary(json.loads(Path(path).read_text(encoding="utf-8")))
