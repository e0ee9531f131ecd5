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

from fe_impact import __version__
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
    c = sub.add_parser(
        "calibrate", help="FE tooth impacts -> lumped IMPACT-law parameters (the main job)",
        description="Mesh the tooth pair of each stage, run FE impacts at the impact speeds "
                    "of the operating speeds (seed eq. 4 in mesh, eq. 5 for a ratio switch), "
                    "fit the ADAMS IMPACT parameters and write calibration.json/.csv, "
                    "report.md, plots and a PVD series per impact. Finished cases are kept; "
                    "rerunning resumes.")
    c.add_argument("gearset", nargs="?", type=Path,
                   help="gear-set TOML (default: the built-in seed set)")
    c.add_argument("--out", type=Path, default=Path("out/calibration"),
                   help="output folder (default: out/calibration)")
    c.add_argument("--stages", type=_int_list, help="comma-separated stage numbers, e.g. 1,2,3")
    c.add_argument("--speeds", type=_float_list,
                   help="operating (pinion) speeds in r/min (default 100,300,1000)")
    c.add_argument("--impact-speeds", type=_float_list, help="impact speeds in m/s instead")
    c.add_argument("--switch", action="store_true",
                   help="also ratio-switch impacts into stages 2.. (eq. 5)")
    c.add_argument("--level", default="default", help="mesh level: coarse, default or fine")
    c.add_argument("--integrator", default="newmark", help="newmark or explicit")
    c.add_argument("--workers", type=int, help="local Dask workers (default: one per core)")
    c.add_argument("--scheduler", help="address of an existing dask.distributed scheduler")
    c.add_argument("--cache", type=Path, default=Path("cache"),
                   help="mesh cache folder (default: cache)")
    c.set_defaults(func=_cmd_calibrate)
    for module in _COMMAND_MODULES:
        importlib.import_module(module).register(sub)
    return p


#: Modules that add their own subcommands with ``register(subparsers)``.
_COMMAND_MODULES = ("fe_impact.cli.mesh", "fe_impact.cli.switching")


def _configure_logging(verbose: int) -> None:
    level = logging.WARNING if verbose == 0 else logging.INFO if verbose == 1 else logging.DEBUG
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    if verbose < 2:
        for name in ("skfem", "distributed", "numba"):
            logging.getLogger(name).setLevel(logging.WARNING)


def _cmd_solve(args: argparse.Namespace) -> int:
    from fe_impact.fe.case import load_case
    from fe_impact.fe.mesh import load_mesh
    from fe_impact.output.results import write_static_results
    from fe_impact.solvers.static import StaticSolver

    case = load_case(args.case)
    if case.analysis.dynamic:
        return _solve_dynamic(case, args.out)
    t0 = time.perf_counter()
    print(f"{case.path.name}: setting up (mesh, assembly, factorisation)", flush=True)
    solver = StaticSolver(case, load_mesh(case.mesh_file, case.unit))
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


def _int_list(text: str) -> list[int]:
    try:
        values = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: need comma-separated integers") from None
    if not values:
        raise argparse.ArgumentTypeError(f"{text!r}: need at least one integer")
    return values


def _float_list(text: str) -> list[float]:
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: need comma-separated numbers") from None
    if not values:
        raise argparse.ArgumentTypeError(f"{text!r}: need at least one number")
    return values


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from fe_impact.calibration.sweep import (
        Settings,
        calibrate,
        check_scheduler_address,
        plan_cases,
    )
    from fe_impact.errors import CalibrationError
    from fe_impact.gears import default_gearset, load_gearset
    from fe_impact.gears.gearset import _default_candidates

    if args.workers is not None and args.workers < 1:
        raise CalibrationError(f"--workers {args.workers}: must be at least 1")
    if args.scheduler is not None:
        check_scheduler_address(args.scheduler)
    if args.gearset is not None:
        gearset = load_gearset(args.gearset)
        text = args.gearset.read_text()
    else:
        gearset = default_gearset()
        text = next(p for p in _default_candidates() if p.is_file()).read_text()
    settings = Settings(level=args.level, integrator=args.integrator)
    cases = plan_cases(gearset, args.stages, args.speeds, args.impact_speeds, args.switch)
    print(f"calibrating {len(cases)} impacts ({settings.level} meshes, {settings.integrator}) "
          f"-> {args.out}", flush=True)
    bar = tqdm(total=len(cases), desc="  cases", unit="case")

    def progress(done: int, total: int, last: str) -> None:
        bar.update(done - bar.n)
        if last:
            bar.set_postfix_str(last)

    try:
        path = calibrate(text, cases, settings, args.out, args.cache, args.workers,
                         args.scheduler, progress)
    finally:
        bar.close()
    print(f"wrote {path}, {args.out / 'calibration.csv'} and {args.out / 'report.md'}")
    return 0


def _solve_dynamic(case, out: Path) -> int:
    from tqdm import tqdm

    from fe_impact.errors import SolverError
    from fe_impact.fe.mesh import load_mesh
    from fe_impact.output.results import DynamicWriter
    from fe_impact.solvers.dynamic import DynamicSolver

    t0 = time.perf_counter()
    a = case.analysis
    print(f"{case.path.name}: setting up (mesh, assembly, contact zone, "
          f"{'stable step' if a.integrator == 'explicit' else 'factorisation'})", flush=True)
    solver = DynamicSolver(case, load_mesh(case.mesh_file, case.unit))
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
    pl = result.info.get("plasticity")
    if pl:
        print(f"  plastic work {fmt(pl['dissipation'])} J, max equivalent plastic strain "
              f"{fmt(pl['max_equivalent_plastic_strain'], 100, '.3g')}%, residual "
              f"indentation {fmt(m['residual_indentation'], 1e6)} um")
    print(f"wrote {path} ({time.perf_counter() - t0:.1f} s)")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
