"""Command line: ``fe-impact SUBCOMMAND ...``.

User mistakes (bad case files, missing meshes, invalid options) print one
clear line and exit with status 2; nothing else prints a traceback unless
``--debug`` is given.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
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
    except BrokenPipeError:  # output piped into e.g. `head`
        sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - silence the flush at exit
        return 0
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
    s = sub.add_parser("solve", help="solve a case file (static contact or transient impact)",
                       description="Solve a TOML case file ([analysis] type = \"static\" or "
                                   "\"dynamic\"); writes summary.json, VTU fields with a PVD "
                                   "series and, for an impact, history.csv and plots to --out.")
    s.add_argument("case", type=Path, help="the case file (.toml)")
    s.add_argument("--out", type=Path, required=True, help="output folder")
    s.set_defaults(func=_cmd_solve)
    for module in _COMMAND_MODULES:
        importlib.import_module(module, __package__).register(sub)
    return p


#: Modules that add their own subcommands with ``register(subparsers)``.
_COMMAND_MODULES = (".switching.command",)


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
    if case.analysis.dynamic:
        return _solve_dynamic(case, args.out)
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


def _solve_dynamic(case, out: Path) -> int:
    from tqdm import tqdm

    from .dynamic import DynamicSolver
    from .errors import SolverError
    from .results import DynamicWriter

    t0 = time.perf_counter()
    a = case.analysis
    print(f"{case.path.name}: setting up (mesh, assembly, contact zone, "
          f"{'stable step' if a.integrator == 'explicit' else 'factorisation'})", flush=True)
    solver = DynamicSolver(case)
    n_steps = max(1, round(a.duration / solver.dt))
    print(f"  {solver.model.n_dofs} DOFs, P{solver.mesh.order}, {a.integrator}, time step "
          f"{solver.dt:.4g} s x {n_steps} steps ({time.perf_counter() - t0:.1f} s)", flush=True)
    writer = DynamicWriter(out, case, solver.mesh, solver.model.material)
    bar = tqdm(total=1000, desc="  integrating", unit="permille", leave=False,
               bar_format="{desc}: {percentage:3.0f}%|{bar}| {elapsed}<{remaining}")

    def progress(fraction: float) -> None:
        bar.update(int(1000 * fraction) - bar.n)

    try:
        result = solver.run(frame_hook=writer.frame, progress=progress)
    except (SolverError, KeyboardInterrupt) as exc:
        bar.close()
        partial = solver.result()
        writer.finish(partial, status="stopped", error=str(exc) or "interrupted")
        raise
    bar.close()
    path = writer.finish(result)
    m = result.measurements

    def fmt(v, scale=1.0, spec=".4g"):
        return "-" if v is None else format(v * scale, spec)

    print(f"  peak force {fmt(m['peak_force'])} N, max approach "
          f"{fmt(m['max_approach'], 1e6)} um, contact {fmt(m['contact_duration'], 1e6)} us, "
          f"restitution {fmt(m['restitution'])}, "
          f"energy error {fmt(m['energy_error'], 100, '.3f')}%")
    print(f"wrote {path} ({time.perf_counter() - t0:.1f} s)")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
