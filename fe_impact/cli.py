"""Command line: ``fe-impact SUBCOMMAND ...``.

User mistakes (bad case files, missing meshes, invalid options) print one
clear line and exit with status 2; nothing else prints a traceback unless
``--debug`` is given.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

from . import __version__
from .errors import FeImpactError

logger = logging.getLogger("fe_impact")


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``fe-impact`` command; returns the exit status."""
    parser = _parser()
    args = parser.parse_args(argv)
    _configure_logging(args.verbose)
    if not hasattr(args, "func"):
        parser.print_help()
        return 0
    try:
        return args.func(args)
    except FeImpactError as exc:
        if args.debug:
            raise
        print(f"fe-impact: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("fe-impact: interrupted; finished results are kept", file=sys.stderr)
        return 130


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="fe-impact",
        description="Finite-element tooth impact for face-gear drives.")
    p.add_argument("--version", action="version", version=f"fe-impact {__version__}")
    p.add_argument("-v", "--verbose", action="count", default=0,
                   help="more log output (-vv for debug)")
    p.add_argument("--debug", action="store_true", help="show tracebacks for errors")
    sub = p.add_subparsers(title="commands", metavar="COMMAND")
    s = sub.add_parser("solve", help="solve a case file (static contact)",
                       description="Solve a TOML case file; writes summary.json and VTU "
                                   "fields to --out.")
    s.add_argument("case", type=Path, help="the case file (.toml)")
    s.add_argument("--out", type=Path, required=True, help="output folder")
    s.set_defaults(func=_cmd_solve)
    return p


def _configure_logging(verbose: int) -> None:
    level = logging.WARNING if verbose == 0 else logging.INFO if verbose == 1 else logging.DEBUG
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    if verbose < 2:
        logging.getLogger("skfem").setLevel(logging.WARNING)


def _cmd_solve(args: argparse.Namespace) -> int:
    from .case import load_case
    from .results import write_static_results
    from .static import StaticSolver

    case = load_case(args.case)
    t0 = time.perf_counter()
    print(f"{case.path.name}: setting up (mesh, assembly, factorisation)", flush=True)
    solver = StaticSolver(case)
    info = (f"{solver.model.n_dofs} DOFs, P{solver.mesh.order}, "
            f"{len(solver.zone_dofs)} contact-zone DOFs")
    print(f"  {info} ({time.perf_counter() - t0:.1f} s)", flush=True)

    def progress(i: int, step) -> None:
        forces = ", ".join(f"{f:.4g}" for f in step.contact_force)
        print(f"  step {i + 1}/{case.n_steps}: value {step.value:.4g} m, contact force "
              f"{forces} N, max pressure {step.max_pressure / 1e6:.4g} MPa, "
              f"{step.iterations} iterations", flush=True)

    result = solver.run(step_hook=progress)
    out = write_static_results(args.out, case, result)
    print(f"wrote {out} ({time.perf_counter() - t0:.1f} s)")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
