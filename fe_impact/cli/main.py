"""Command line: ``fe-impact SUBCOMMAND ...``.

User mistakes (bad case files, missing meshes, invalid options, an output
folder that cannot be made) print one clear line and exit with status 2,
before any computation starts; nothing else prints a traceback unless
``--debug`` is given. Settings that are legal but surely unintended get a
warning saying why (a transient case with fewer than
`fe_impact.api.MIN_STEPS_PER_CONTACT` time steps, more than
`fe_impact.api.MAX_FRAMES` output frames).

SIGINT (Ctrl-C) and SIGTERM stop every command alike
(:mod:`fe_impact.interrupts`): the summary is written with
``status: "stopped"``, no temporary file is left, one line is printed, and
the exit status is 128 + the signal's number (130, 143).

Each handler parses its options and calls one function of :mod:`fe_impact.api`
(``solve``, ``calibrate``, ...), which does the work and says its progress
through the ``echo`` and ``progress`` callbacks given here.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import sys
from pathlib import Path

from fe_impact import __version__
from fe_impact.api import MAX_FRAMES, MIN_STEPS_PER_CONTACT  # noqa: F401 (importable here)
from fe_impact.errors import FeImpactError

logger = logging.getLogger("fe_impact")

def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``fe-impact`` command; returns the exit status."""
    parser = _parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:   # --help, or a bad option (argparse printed why)
        return int(exc.code or 0)
    _configure_logging(args.verbose)
    if not hasattr(args, "func"):
        parser.print_help()
        return 0
    from fe_impact.runtime import keep_freed_memory

    keep_freed_memory()
    from fe_impact.interrupts import exit_status, handle_signals

    try:
        with handle_signals():
            return _run(args)
    except KeyboardInterrupt as exc:
        if args.debug:
            raise
        print(f"fe-impact: interrupted ({getattr(exc, 'name', 'SIGINT')}); "
              f"{INTERRUPTED[getattr(args, 'resumes', False)]}", file=sys.stderr)
        return exit_status(exc)


#: What an interrupt leaves, by whether the command resumes (calibrate) or not.
INTERRUPTED = {True: "finished results are kept, rerun to continue",
               False: "what was written is kept, marked stopped; a rerun starts again"}


def _run(args: argparse.Namespace) -> int:
    """The command, with user errors as one line."""
    try:
        return args.func(args)
    except FeImpactError as exc:
        if args.debug:
            raise
        print(f"fe-impact: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into e.g. `head`
        sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - silence the flush at exit
        return 0
    except ArithmeticError as exc:   # numpy's LinAlgError is a ValueError: see below
        if args.debug:
            raise
        print(f"fe-impact: error: numerical failure ({type(exc).__name__}: {exc}); check "
              "the input values", file=sys.stderr)
        return 2
    except ValueError as exc:   # numpy.linalg.LinAlgError, told by name (numpy not loaded here)
        if args.debug or type(exc).__name__ != "LinAlgError":
            raise
        print(f"fe-impact: error: a linear solve failed ({exc}); check the input values "
              "(a body held in too few directions, or a penalty or modulus far out of "
              "scale?)", file=sys.stderr)
        return 2


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="fe-impact",
        description="Finite-element tooth impact for face-gear drives.")
    p.add_argument("--version", action="version", version=f"fe-impact {__version__}")
    p.add_argument("-v", "--verbose", action="count", default=0,
                   help="more log output (-vv for debug)")
    p.add_argument("--debug", action="store_true", help="show tracebacks for errors")
    sub = p.add_subparsers(title="commands", metavar="COMMAND")
    s = sub.add_parser("solve", help="solve a case file (static contact or transient impact)",
                       description="Solve a TOML case file ([analysis] type = \"static\" or "
                                   "\"dynamic\"); writes summary.json, VTU fields with a PVD "
                                   "series and, for an impact, history.csv and plots to --out.")
    s.add_argument("case", type=Path, help="the case file (.toml)")
    s.add_argument("--out", type=Path, required=True, help="output folder")
    s.add_argument("--max-frames", type=int, default=MAX_FRAMES, metavar="N",
                   help=f"most VTU frames of a transient run (default {MAX_FRAMES}); a finer "
                        "[analysis] output_interval is widened to give N, with a warning")
    s.set_defaults(func=_cmd_solve)
    c = sub.add_parser(
        "calibrate", help="FE tooth impacts -> lumped IMPACT-law parameters (the main job)",
        description="Mesh the tooth pair of each stage, run FE impacts at the impact speeds "
                    "of the operating speeds (seed eq. 4 in mesh, eq. 5 for a ratio switch), "
                    "fit the ADAMS IMPACT parameters and write calibration.json/.csv, "
                    "report.md, plots and a PVD series per impact, and summary.json (status, "
                    "finished and missing cases). Finished cases are kept; rerunning resumes. "
                    "A second run on the same --out waits for the cases the first is "
                    "computing. Ctrl-C or SIGTERM stops the cases and writes summary.json "
                    "with status \"stopped\".")
    c.add_argument("gearset", nargs="?", type=Path,
                   help="gear-set TOML (default: the built-in seed set)")
    c.add_argument("--out", type=Path, default=Path("out/calibration"),
                   help="output folder (default: out/calibration)")
    c.add_argument("--stages", type=_int_list, help="comma-separated stage numbers, e.g. 1,2,3")
    c.add_argument("--speeds", type=_float_list,
                   help="operating (pinion) speeds in r/min (default 100,300,1000)")
    c.add_argument("--impact-speeds", type=_float_list, help="impact speeds in m/s instead")
    c.add_argument("--switch", nargs="?", const="both", default=None,
                   choices=("eq5", "kinematic", "both"),
                   help="also ratio-switch impacts into stages 2.., at each speed's seed "
                        "eq. 5 switching speed, its rigid-kinematics one, or both (the "
                        "default when no value is given); with the operating speeds (--speeds "
                        "or their default), not with --impact-speeds, and a stage from 2 on")
    c.add_argument("--positions", type=_positions, default=None, metavar="N|DEG,...",
                   help="mesh cycle: quasi-static single-pair load-approach curves at N "
                        "positions along the path of contact (default 9, the ends 0.5%% of the "
                        "path inside it on coarse meshes, 5%% on finer ones) or at the given "
                        "pinion roll angles (deg, comma-separated)")
    c.add_argument("--no-mesh-cycle", action="store_true",
                   help="impacts only: no single-pair curves along the path of contact")
    c.add_argument("--corners", action="store_true",
                   help="mesh cycle: also the quasi-static load-approach of each rounded tip "
                        "edge's first touch (the face gear's before the path, the pinion's "
                        "after it, at the corner gap of the closed-form corner laws); their "
                        "fitted stiffness and exponent replace the closed form's in the corner "
                        "laws (part of make run; coarse, one core: a recess corner 27-41 s, an "
                        "approach corner 83-115 s and up to 3.5 GB)")
    c.add_argument("--corner-impacts", action="store_true",
                   help="also FE impacts on the rounded tip edges (the elastic-plastic "
                        "corner laws) at the median and the largest closing speed the seed's "
                        "presets produce there with the closed-form laws (the first pass, "
                        "cached once per gear set): up to four a stage; at coarse, stage 1, "
                        "a recess impact takes a minute, an approach impact about 14 minutes "
                        "and 7.5-9.7 GB on one core")
    c.add_argument("--no-switching", action="store_true",
                   help="do not end with the seed's switching studies (Tables 1-4 and the two "
                        "switching runs, about 20 s on two workers) on the calibration")
    c.add_argument("--no-preset-speeds", action="store_true",
                   help="do not fit the FE impacts to the closing speeds the seed's "
                        "switching presets produce with the closed-form laws (by default, a "
                        "stage whose presets close faster than its fastest planned impact "
                        "has that one struck at 1.2 times their fastest instead, and the "
                        "--switch cases strike where the presets' first contacts after a "
                        "switch touched; about 50 s the first time for a gear set, then "
                        "cached). Without it the switch cases strike at the pitch point")
    c.add_argument("--level", default="default",
                   help="mesh level of the impacts: coarse, default or fine (default: default)")
    c.add_argument("--mesh-cycle-level", default=None, metavar="LEVEL",
                   help="mesh level of the mesh-cycle positions (default: one level below "
                        "--level, coarse at the least)")
    c.add_argument("--integrator", default="newmark",
                   help="newmark or explicit (default: newmark)")
    c.add_argument("--workers", type=int,
                   help="local Dask workers (default: one per core, at most one per case; "
                        "not used with --scheduler, whose workers run the cases)")
    c.add_argument("--scheduler", help="address of an existing dask.distributed scheduler")
    c.add_argument("--cache", type=Path, default=Path("cache"),
                   help="mesh cache folder (default: cache)")
    c.add_argument("--schedule", type=Path, action="append", default=None, metavar="FILE",
                   help="a schedule file of your own (repeatable): its closing speeds join "
                        "the presets' first pass (the impacts are struck at them, the "
                        "mesh-cycle curves reach its largest mesh force) and, unless "
                        "--no-switching, it is run as a study on the calibration")
    c.set_defaults(func=_cmd_calibrate, resumes=True)
    for module in _COMMAND_MODULES:
        importlib.import_module(module).register(sub)
    return p


#: Modules that add their own subcommands with ``register(subparsers)``.
_COMMAND_MODULES = ("fe_impact.cli.mesh", "fe_impact.cli.switching", "fe_impact.cli.geometry",
                    "fe_impact.cli.export", "fe_impact.cli.roll")


def _configure_logging(verbose: int) -> None:
    level = logging.WARNING if verbose == 0 else logging.INFO if verbose == 1 else logging.DEBUG
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    if verbose < 2:
        for name in ("skfem", "distributed", "numba"):
            logging.getLogger(name).setLevel(logging.WARNING)


class _Progress:
    """A tqdm bar made at a run's first progress report and closed before the next
    printed line (the ``progress`` and ``echo`` callbacks of :mod:`fe_impact.api`)."""

    def __init__(self, **options) -> None:
        self.options = options
        self.bar = None

    def echo(self, line: str) -> None:
        self.close()
        print(line, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def _bar(self, total: int):
        if self.bar is None:
            from tqdm import tqdm

            self.bar = tqdm(total=total, **self.options)
        return self.bar

    def fraction(self, fraction: float) -> None:
        """A transient run's progress, in thousandths."""
        bar = self._bar(1000)
        bar.update(int(1000 * fraction) - bar.n)

    def cases(self, done: int, total: int, last: str) -> None:
        """A calibration's finished cases, the last one's id beside the bar."""
        bar = self._bar(total)
        bar.update(done - bar.n)
        if last:
            bar.set_postfix_str(last)


def _cmd_solve(args: argparse.Namespace) -> int:
    from fe_impact.api import solve

    shown = _Progress(desc="  integrating", unit="permille", leave=False,
                      bar_format="{desc}: {percentage:3.0f}%|{bar}| {elapsed}<{remaining}")
    try:
        solve(args.case, args.out, max_frames=args.max_frames, echo=shown.echo,
              progress=shown.fraction)
    finally:
        shown.close()
    return 0


def _list_of(cast, plural: str, singular: str):
    """An argparse type: comma-separated values of ``cast``, at least one."""
    def parse(text: str) -> list:
        try:
            values = [cast(x) for x in text.split(",") if x.strip()]
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r}: need comma-separated {plural}") from None
        if not values:
            raise argparse.ArgumentTypeError(f"{text!r}: need at least one {singular}")
        return values
    return parse


_int_list = _list_of(int, "integers", "integer")
_float_list = _list_of(float, "numbers", "number")


def _positions(text: str) -> int | list[float]:
    """``--positions``: a count (an integer) or roll angles (comma-separated numbers)."""
    if "," not in text and text.strip().lstrip("+").isdigit():
        return int(text)
    angles = _float_list(text)
    if len(angles) == 1:
        raise argparse.ArgumentTypeError(
            f"{text!r}: one roll angle; give a count of positions (an integer, e.g. 9) or "
            "two or more roll angles in degrees, comma-separated")
    return angles


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from fe_impact.api import calibrate

    shown = _Progress(desc="  cases", unit="case")
    try:
        calibrate(args.gearset, out=args.out, stages=args.stages, speeds=args.speeds,
                  impact_speeds=args.impact_speeds, switch=args.switch,
                  positions=args.positions, mesh_cycle=not args.no_mesh_cycle,
                  corners=args.corners, corner_impacts=args.corner_impacts,
                  switching=not args.no_switching, preset_speeds=not args.no_preset_speeds,
                  level=args.level, mesh_cycle_level=args.mesh_cycle_level,
                  integrator=args.integrator, workers=args.workers, scheduler=args.scheduler,
                  cache=args.cache, schedules=args.schedule or (), progress=shown.cases,
                  echo=shown.echo)
    finally:
        shown.close()
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
