"""``fe-impact switching``: run a seed condition through the torsional model.

::

    fe-impact switching --list
    fe-impact switching [GEARSET] --preset NAME [--calibration FILE] [--duration S] --out DIR
    fe-impact switching [GEARSET] --schedule FILE [--calibration FILE] --out DIR

`register` adds the subcommand to the CLI's subparsers; the handler returns
an exit status and raises `fe_impact.errors.FeImpactError` subclasses for bad
input (the CLI prints them as one line).
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time
from pathlib import Path

from fe_impact.defaults import SAMPLE_INTERVAL
from fe_impact.errors import CalibrationError, CaseError

__all__ = ["MIN_MESH_CYCLES", "register", "run"]

logger = logging.getLogger(__name__)

#: Fewer mesh cycles than this in a segment (pinion teeth x revolutions) and
#: its statistics are those of the start transient: a warning says so. The
#: seed's 5 s segments hold 158 cycles at 100 r/min.
MIN_MESH_CYCLES = 20

#: Most time-series samples of one case: 2e6 rows of the series' 22 columns are
#: 350 MB (the seed's longest preset, 15 s at the default interval, takes 75,000).
MAX_SAMPLES = 2_000_000

_DESCRIPTION = (
    "Lumped torsional model of the multistage face-gear drive (pinions, rings, output) "
    "with backlash, the calibrated IMPACT law per tooth pair and ratio switching. Runs one "
    "of the seed study's conditions (--preset) or a duty cycle from a schedule file "
    "(--schedule) and writes time series, impacts, statistics (beside the seed's Tables 1-4 "
    "for a preset; CSV, JSON, report.md) and plots to --out. The IMPACT parameters come "
    "from --calibration, else ./calibration.json, else closed forms (with a warning)."
)


def register(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``switching`` subcommand to ``subparsers``; returns its parser."""
    p = subparsers.add_parser("switching", description=_DESCRIPTION,
                              help="ratio-switching runs of a seed preset or a schedule file")
    p.add_argument("gearset", nargs="?", type=Path,
                   help="gear-set TOML (default: the built-in seed set); the calibration "
                        "must be of it")
    p.add_argument("--list", action="store_true", help="list the presets and exit")
    p.add_argument("--preset", metavar="NAME", help="preset to run (see --list)")
    p.add_argument("--schedule", type=Path, metavar="FILE",
                   help="schedule file (TOML) to run in place of a preset: segments of "
                        "engaged stage, pinion speed, output load torque and duration, a "
                        "ratio switch where the stage changes (docs: guide/schedule.md)")
    p.add_argument("--calibration", type=Path, metavar="FILE",
                   help="calibration file (fe-impact calibrate's calibration.json)")
    p.add_argument("--duration", type=float, metavar="S",
                   help="simulated time of each case [s] (default: the seed's, 5 s per "
                        "segment, or the schedule's); segments are scaled in proportion")
    p.add_argument("--sample-interval", type=float, default=SAMPLE_INTERVAL, metavar="S",
                   help="time-series sampling interval [s] (default 2e-4; statistics use "
                        "every integration step)")
    p.add_argument("--out", type=Path, metavar="DIR", help="output folder")
    p.add_argument("--no-baseline", action="store_true",
                   help="do not rerun the cases on the laws reduced to the pitch point (no "
                        "mesh cycle, no corner laws), whose statistics the report gives "
                        "beside the full laws' and the seed's")
    p.add_argument("--corners", choices=("auto", "3d", "planar"), default="auto",
                   help="tip-corner gaps: the three-dimensional first touch of the rounded "
                        "tip edges over the face ('3d'), the planar rack-and-pinion model "
                        "('planar'); default 'auto': '3d' when the gear set's tip edges are "
                        "rounded")
    p.set_defaults(func=run)
    p.epilog = (f"A segment with fewer than {MIN_MESH_CYCLES} mesh cycles gets a warning: "
                "its statistics are not comparable with the seed's 5 s tables.")
    return p


def _list_presets() -> int:
    from fe_impact.api import presets

    known = presets()
    width = max(len(name) for name in known)
    for name, preset in known.items():
        print(f"{name:<{width}}  {preset.duration:5.1f} s  {preset.description}")
    return 0


def _check(args: argparse.Namespace) -> None:
    from fe_impact.output.files import check_output_dir

    if args.preset is not None and args.schedule is not None:
        raise CaseError(f"--preset = {args.preset!r} and --schedule = {str(args.schedule)!r}: "
                        "give one of them")
    if args.preset is None and args.schedule is None:
        raise CaseError("--preset NAME or --schedule FILE is required (or --list); see "
                        "fe-impact switching --list")
    if args.out is None:
        option = "--preset" if args.schedule is None else "--schedule"
        raise CaseError(f"--out is required with {option}: the folder for the results")
    check_output_dir(args.out)
    if (args.out / "calibration.json").is_file():
        raise CaseError(f"--out {args.out}: holds a calibration (calibration.json): the "
                        "study's report.md and statistics would overwrite its files; give "
                        f"another folder, e.g. {args.out / 'switching' / 'NAME'}")
    for option, value in (("--duration", args.duration),
                          ("--sample-interval", args.sample_interval)):
        if value is not None and not (math.isfinite(value) and value > 0.0):
            raise CaseError(f"{option} = {value!r} s must be a number > 0")
    if args.calibration is not None:
        if args.calibration.is_dir():
            raise CalibrationError(f"--calibration = {str(args.calibration)!r}: is a "
                                   "directory; give a calibration file (calibration.json)")
        if not args.calibration.is_file():
            raise CalibrationError(f"--calibration = {str(args.calibration)!r}: no such file")


def _check_preset(args: argparse.Namespace, preset, gearset) -> list[str]:
    """Options against the preset: an error, or warnings (returned) for a short run."""
    n_stages = len(gearset.stages)
    top = max(seg.stage for c in preset.cases for seg in c.schedule.segments)
    if args.preset is not None and top > n_stages:
        from fe_impact.api import presets

        fits = [name for name, p in presets().items()
                if max(seg.stage for c in p.cases for seg in c.schedule.segments) <= n_stages]
        raise CaseError(f"--preset = {args.preset!r} runs stage {top}; the gear set "
                        f"{gearset.name!r} has stages 1..{n_stages}: give one of "
                        f"{', '.join(fits) or 'no preset'}, or a --schedule of its stages")
    shortest = min(c.schedule.duration for c in preset.cases)
    if args.sample_interval > shortest:
        if args.duration is not None and args.sample_interval == SAMPLE_INTERVAL:
            raise CaseError(f"--duration = {args.duration:g} s: shorter than the time series' "
                            f"sample interval ({SAMPLE_INTERVAL:g} s, --sample-interval)")
        raise CaseError(f"--sample-interval = {args.sample_interval:g} s: longer than the run "
                        f"({shortest:g} s); give at most the duration")
    longest = max(c.schedule.duration for c in preset.cases)
    if longest / args.sample_interval > MAX_SAMPLES:
        option, value = (("--duration", f"{args.duration:g} s") if args.duration is not None
                         and args.sample_interval == SAMPLE_INTERVAL
                         else ("--sample-interval", f"{args.sample_interval:g} s"))
        raise CaseError(f"{option} = {value}: {longest / args.sample_interval:.3g} time-series "
                        f"samples of a {longest:g} s case; at most {MAX_SAMPLES:g}: give a "
                        f"--sample-interval of {longest / MAX_SAMPLES:.3g} s or more, or a "
                        "shorter --duration"
                        + (" (the schedule's duration_s are in seconds)"
                           if args.schedule is not None and args.duration is None else ""))
    notes, needed = [], 0.0
    for case in preset.cases:
        total = case.schedule.duration
        for seg in case.schedule.segments:
            cycles = seg.duration * seg.mean_speed_rpm / 60.0 * gearset.pinion.teeth
            if seg.mean_speed_rpm > 0.0 and cycles < MIN_MESH_CYCLES:
                needed = max(needed, MIN_MESH_CYCLES / cycles * total)
                notes.append(f"{case.name}: stage {seg.stage} at {seg.mean_speed_rpm:g} r/min "
                             f"runs {cycles:.3g} mesh cycles in {seg.duration:.3g} s")
    if not notes:
        return []
    seed = (", and are not comparable with the seed's tables"
            if preset.seed_table is not None else "")
    text = (f"run too short for its statistics: {'; '.join(notes[:3])}"
            f"{'; ...' if len(notes) > 3 else ''} (fewer than {MIN_MESH_CYCLES}): they "
            f"describe the start, not a steady run{seed}; give --duration {needed:.3g} or "
            "more")
    logger.warning("%s", text)
    return [text]


def run(args: argparse.Namespace) -> int:
    """Handler of ``fe-impact switching``; returns the exit status."""
    if args.list:
        return _list_presets()
    _check(args)
    from fe_impact.api import read_gearset, read_schedule, run_switching, study_preset

    duty = None if args.schedule is None else read_schedule(args.schedule)
    gearset = read_gearset(args.gearset)
    if duty is not None:
        duty.check_gearset(gearset)
    preset = study_preset(args.preset if duty is None else duty, gearset,
                          duration=args.duration)
    notes = _check_preset(args, preset, gearset)
    print(f"{preset.name}: {len(preset.cases)} case(s), {preset.duration:g} s simulated",
          flush=True)
    t0 = time.perf_counter()
    try:
        summary = run_switching(preset, gearset, args.calibration, out=args.out,
                                corners=args.corners, sample_interval=args.sample_interval,
                                notes=notes, on_case=_progress, baseline=not args.no_baseline,
                                search=True)
    except CalibrationError as exc:
        raise CalibrationError(f"--calibration: {exc}") from exc
    for name, info in summary["cases"].items():
        print(f"  {name}: {info['steps']} steps, {info['impacts']} impacts, "
              f"{info['wall_s']:.1f} s", flush=True)
    print(f"laws: {summary['laws']}")
    print(f"wrote {args.out} ({time.perf_counter() - t0:.1f} s)")
    return 0


def _progress(case):
    """A step hook drawing ``case``'s progress bar (closed when the run ends)."""
    from tqdm import tqdm

    bar = tqdm(total=case.schedule.duration, desc=case.name, unit="s", leave=False,
               file=sys.stderr, disable=None,
               bar_format="{l_bar}{bar}| {n:.2f}/{total:.2f} s simulated [{elapsed}]")

    def hook(t: float, t_end: float) -> None:
        bar.update(t - bar.n)
        if t >= t_end:
            bar.close()

    return hook
