"""One of the seed's condition sets run on a gear set and its laws: the runs and their files.

:func:`run_study` is what ``fe-impact switching --preset`` does;
:func:`seed_study_job` is the same for a calibration just made, as the
main job runs it on the sweep's workers (``fe-impact calibrate`` ends with
the :data:`SEED_STUDIES`, one task each).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from fe_impact.defaults import SAMPLE_INTERVAL
from fe_impact.switching.presets import Preset

__all__ = ["SAMPLE_INTERVAL", "SEED_STUDIES", "run_study", "seed_study_job", "study_folder",
           "study_preset", "study_stages"]

#: The seed's condition sets: its Tables 1-4 (sections 4.1, 4.2) and its two
#: switching runs (sections 5.1, 5.2).
SEED_STUDIES = ("table1", "table2", "table3", "table4", "variable-speed", "variable-load")


def study_stages(preset: Preset) -> set[int]:
    """The stages (from 1) a condition set engages."""
    return {seg.stage for case in preset.cases for seg in case.schedule.segments}


def run_study(preset: Preset, gearset, calibration: str | Path | None, out: str | Path, *,
              corners: str = "auto", sample_interval: float = SAMPLE_INTERVAL,
              notes: Sequence[str] = (), search: bool = True,
              on_case: Callable[[object], Callable | None] | None = None,
              baseline: bool = True) -> dict:
    """Run every case of ``preset`` and write the study's files to ``out``.

    The laws are ``calibration``'s (or, with ``search``, ``./calibration.json``,
    else closed forms: `calibration.laws_for`). ``on_case(case)`` may return
    a step hook ``(t, t_end)`` for the case's progress. With ``baseline``, the
    cases run a second time on the same laws reduced to the pitch point
    (`LawSet.pitch_point_only`: no mesh cycle, no corner laws), whose statistics
    the files give beside the full laws' and the seed's. On an interrupt the
    finished cases are written, marked stopped, and the interrupt is raised
    again. Returns per case the steps, impacts, wall time and clamped law
    look-ups, and the laws' source.
    """
    from fe_impact.switching.calibration import laws_for
    from fe_impact.switching.model import DriveModel
    from fe_impact.switching.report import write_results
    from fe_impact.switching.simulation import simulate

    model = DriveModel(gearset=gearset, corners=corners)
    masses = [model.effective_mass(s) for s in range(1, model.n_stages + 1)]
    model = model.with_laws(laws_for(gearset, masses, calibration, search=search))
    # what the laws lack (no position dependence, a kind borrowed from another)
    # heads the report too, not only the log
    notes = [*notes, *(f"Contact laws: {n}." for n in model.law_set.notes)]
    runs = {}
    try:
        for case in preset.cases:
            hook = on_case(case) if on_case is not None else None
            runs[case.name] = simulate(model, case.schedule, sample_interval=sample_interval,
                                       step_hook=hook)
    except KeyboardInterrupt:
        from fe_impact.interrupts import ignore_signals

        with ignore_signals():   # the files of the finished cases belong together
            write_results(out, preset, runs, status="stopped",
                          missing=[c.name for c in preset.cases if c.name not in runs],
                          notes=notes)
        raise
    reduced = model.law_set.pitch_point_only() if baseline else None
    before = None
    if reduced is not None:
        plain = model.with_laws(reduced)
        before = {case.name: simulate(plain, case.schedule, sample_interval=sample_interval)
                  for case in preset.cases}
    write_results(out, preset, runs, notes=notes, baseline=before)
    return {"preset": preset.name, "laws": model.law_set.source,
            "cases": {name: {k: run.info[k] for k in ("steps", "impacts", "wall_s",
                                                       "clamped_low", "clamped_high")}
                      for name, run in runs.items()}}


def study_preset(name: str) -> Preset:
    """The study ``name`` stands for: a preset's name, or the path of a schedule file
    (`fe_impact.switching.schedule`; anything ending in ``.toml``)."""
    from fe_impact.switching.presets import get_preset, schedule_preset
    from fe_impact.switching.schedule import read_schedule

    if name.endswith(".toml"):
        return schedule_preset(read_schedule(name))
    return get_preset(name)


def study_folder(name: str) -> str:
    """The folder name of study ``name`` (:func:`study_preset`): the preset's name, or the
    schedule's ``name`` (its file's stem by default)."""
    return study_preset(name).name if name.endswith(".toml") else name


def seed_study_job(gearset_text: str, name: str, calibration: str, out: str) -> dict:
    """:func:`run_study` of the seed condition set ``name`` (or of the schedule file
    ``name``, :func:`study_preset`) on the gear set given as TOML text and the
    calibration file just written (a task of the main job).

    The model's warnings (a kind of law borrowed from another, clamped speeds) are
    not logged: six studies would repeat them into the terminal, and each study's
    report states its notes and the calibration report tables the clamped look-ups.
    """
    import logging
    import tomllib

    from fe_impact.gears import gearset_from_dict

    gearset = gearset_from_dict(tomllib.loads(gearset_text))
    log = logging.getLogger("fe_impact.switching")
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        return run_study(study_preset(name), gearset, calibration, out, search=False)
    finally:
        log.setLevel(level)
