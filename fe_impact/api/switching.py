"""Switching studies: the lumped torsional model of the drive through a schedule."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

from fe_impact.api.common import PathLike
from fe_impact.api.readers import as_gearset, read_schedule
from fe_impact.defaults import SAMPLE_INTERVAL
from fe_impact.errors import FeImpactError

if TYPE_CHECKING:
    from fe_impact.gears.gearset import GearSet
    from fe_impact.switching.model import StageSchedule
    from fe_impact.switching.presets import Preset
    from fe_impact.switching.schedule import DutyCycle
    from fe_impact.switching.simulation import SwitchingRun

__all__ = ["run_switching", "simulate_switching", "study_preset"]


def study_preset(schedule: str | PathLike | Preset | DutyCycle,
                 gearset: GearSet | PathLike | None = None, *,
                 duration: float | None = None) -> Preset:
    """The cases a switching study runs, from a preset or a schedule.

    Parameters
    ----------
    schedule : str, path-like, Preset or DutyCycle
        A preset's name (:func:`presets`) or a preset; a schedule file (a path,
        or a string ending in ``.toml``) or a schedule read
        (:func:`read_schedule`), checked against the gear set (its stages, the pinion's
        pitch-line speed, the contact pressure of the loads).
    gearset : GearSet, str or path-like, optional
        None: the seed set.
    duration : float, optional
        Simulated time of each case [s]; segments are scaled in proportion.

    Returns
    -------
    Preset
        ``name``, ``cases`` (each a name and a ``schedule`` of segments) and
        ``duration`` (all cases) [s].
    """
    preset = _preset(schedule, as_gearset(gearset))
    return preset if duration is None else preset.scaled(duration)


def _preset(schedule: str | PathLike | Preset | DutyCycle, gearset: GearSet) -> Preset:
    """A study's cases from a preset (or its name), a schedule file or a read schedule."""
    from fe_impact.switching.presets import Preset, get_preset, schedule_preset
    from fe_impact.switching.schedule import DutyCycle

    if isinstance(schedule, Preset):
        return schedule
    if isinstance(schedule, str) and not schedule.endswith(".toml"):
        return get_preset(schedule)
    duty = schedule if isinstance(schedule, DutyCycle) else read_schedule(schedule)
    duty.check_gearset(gearset)
    return schedule_preset(duty)


def run_switching(schedule: str | PathLike | Preset | DutyCycle,
                  gearset: GearSet | PathLike | None = None,
                  calibration: PathLike | None = None, *, out: PathLike,
                  duration: float | None = None, sample_interval: float = SAMPLE_INTERVAL,
                  corners: str = "auto", baseline: bool = True, search: bool = False,
                  notes: Sequence[str] = (),
                  on_case: Callable[[object], Callable | None] | None = None) -> dict:
    """A switching study: the lumped torsional model run through a schedule, with files.

    The model is the multistage face-gear drive (pinions, three rings, output)
    with backlash, the calibrated IMPACT law per tooth pair and ratio switching.
    It writes the time series, impacts, statistics beside the seed's Tables 1-4
    (CSV, JSON, ``report.md``) and plots to ``out``. It is what ``fe-impact
    switching`` does.

    Parameters
    ----------
    schedule : str, path-like, Preset or DutyCycle
        A preset's name (:func:`presets`) or a preset; a schedule file (a path,
        or a string ending in ``.toml``) or a schedule read
        (:func:`read_schedule`).
    gearset : GearSet, str or path-like, optional
        None: the seed set. The calibration must be of it.
    calibration : str or path-like, optional
        A ``calibration.json``; None: ``./calibration.json`` if ``search``, else
        the closed-form laws (with a warning).
    out : str or path-like
        Output folder.
    duration : float, optional
        Simulated time of each case [s]; segments are scaled in proportion.
    sample_interval : float
        Time-series sampling [s]; statistics use every integration step.
    corners : {"auto", "3d", "planar"}
        Tip-corner gaps (``auto``: ``3d`` when the tip edges are rounded).
    baseline : bool
        Also run the cases on the laws reduced to the pitch point, for comparison.
    search : bool
        Look for ``./calibration.json`` when ``calibration`` is None.
    notes : sequence of str
        Lines heading the study's report (e.g. why its statistics are short).
    on_case : callable, optional
        ``on_case(case)`` may return a step hook ``(t, t_end)`` for the case's progress.

    Returns
    -------
    dict
        ``"preset"``, ``"laws"`` (their source) and per case its ``"steps"``,
        ``"impacts"``, ``"wall_s"`` and clamped law look-ups.
    """
    from fe_impact.output.files import check_output_dir
    from fe_impact.switching.study import run_study

    check_output_dir(out)
    gs = as_gearset(gearset)
    preset = _preset(schedule, gs)
    if duration is not None:
        preset = preset.scaled(duration)
    return run_study(preset, gs, calibration, out, corners=corners,
                     sample_interval=sample_interval, notes=notes, search=search,
                     on_case=on_case, baseline=baseline)


def simulate_switching(schedule: str | PathLike | Preset | DutyCycle | StageSchedule,
                       gearset: GearSet | PathLike | None = None,
                       calibration: PathLike | None = None, *,
                       duration: float | None = None,
                       sample_interval: float = SAMPLE_INTERVAL,
                       corners: str = "auto") -> SwitchingRun:
    """One run of the torsional model through a schedule, in memory (no files).

    Parameters
    ----------
    schedule : str, path-like, Preset, DutyCycle or StageSchedule
        As in :func:`run_switching` (a preset of one case), or the segments.
    gearset, calibration, duration, sample_interval, corners
        As in :func:`run_switching` (``calibration`` None: closed-form laws).

    Returns
    -------
    SwitchingRun
        ``series`` (time series by name, SI units: ``"time"``,
        ``"mesh_force"``, ...), ``events`` (the impacts: time, stage, kind,
        closing speed, peak force) and ``info``.
    """
    from fe_impact.switching.calibration import laws_for
    from fe_impact.switching.model import DriveModel, StageSchedule
    from fe_impact.switching.simulation import simulate

    gs = as_gearset(gearset)
    if not isinstance(schedule, StageSchedule):
        preset = _preset(schedule, gs)
        if len(preset.cases) != 1:
            raise FeImpactError(f"schedule {preset.name!r}: has {len(preset.cases)} cases; "
                                f"give one of them ({', '.join(c.name for c in preset.cases)})"
                                " or use run_switching")
        schedule = preset.cases[0].schedule
    if duration is not None:
        schedule = schedule.scaled(duration)
    model = DriveModel(gearset=gs, corners=corners)
    masses = [model.effective_mass(s) for s in range(1, model.n_stages + 1)]
    model = model.with_laws(laws_for(gs, masses, calibration, search=False))
    return simulate(model, schedule, sample_interval=sample_interval)
