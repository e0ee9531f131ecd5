"""Command line: ``fe-impact SUBCOMMAND ...``.

User mistakes (bad case files, missing meshes, invalid options, an output
folder that cannot be made) print one clear line and exit with status 2,
before any computation starts; nothing else prints a traceback unless
``--debug`` is given. Settings that are legal but surely unintended get a
warning saying why (a transient case with fewer than `MIN_STEPS_PER_CONTACT`
time steps, more than `MAX_FRAMES` output frames).

SIGINT (Ctrl-C) and SIGTERM stop every command alike
(:mod:`fe_impact.interrupts`): the summary is written with
``status: "stopped"``, no temporary file is left, one line is printed, and
the exit status is 128 + the signal's number (130, 143).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import json
import logging
import os
import sys
import time
from pathlib import Path

from fe_impact import __version__
from fe_impact.errors import FeImpactError

logger = logging.getLogger("fe_impact")

#: Most VTU frames ``solve`` writes for a transient case unless ``--max-frames``
#: says otherwise; above it the output interval is widened (with a warning).
#: A frame of a 100k-DOF tooth pair is some 10 MB and 0.3 s: an output interval
#: of 1e-10 s over a 40 us impact asked for 400,000 frames and, with the
#: automatic Newmark step, as many steps.
MAX_FRAMES = 1000
#: Fewer time steps than this over a transient run, or over its measured
#: contact, get a warning: the peak force and the contact time are not resolved
#: (the impact benchmark needs some 60 for 0.4 %).
MIN_STEPS_PER_CONTACT = 20


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
    except ValueError as exc:
        import numpy as np

        if args.debug or not isinstance(exc, np.linalg.LinAlgError):
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
    c.set_defaults(func=_cmd_calibrate, resumes=True)
    for module in _COMMAND_MODULES:
        importlib.import_module(module).register(sub)
    return p


#: Modules that add their own subcommands with ``register(subparsers)``.
_COMMAND_MODULES = ("fe_impact.cli.mesh", "fe_impact.cli.switching", "fe_impact.cli.geometry")


def _configure_logging(verbose: int) -> None:
    level = logging.WARNING if verbose == 0 else logging.INFO if verbose == 1 else logging.DEBUG
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    if verbose < 2:
        for name in ("skfem", "distributed", "numba"):
            logging.getLogger(name).setLevel(logging.WARNING)


def _cmd_solve(args: argparse.Namespace) -> int:
    from fe_impact.fe.case import load_case
    from fe_impact.fe.mesh import load_mesh
    from fe_impact.interrupts import ignore_signals
    from fe_impact.output.files import check_output_dir
    from fe_impact.output.results import write_static_results
    from fe_impact.solvers.static import StaticResult, StaticSolver

    if args.max_frames < 2:
        raise FeImpactError(f"--max-frames {args.max_frames}: must be at least 2")
    case = load_case(args.case)
    check_output_dir(args.out)
    if case.analysis.dynamic:
        return _solve_dynamic(_checked_dynamic(case, args.max_frames), args.out)
    t0 = time.perf_counter()
    print(f"{case.path.name}: setting up (mesh, assembly, factorisation)", flush=True)
    solver = StaticSolver(case, load_mesh(case.mesh_file, case.unit))
    info = (f"{solver.model.n_dofs} DOFs, P{solver.mesh.order}, "
            f"{solver.n_condensed} contact-zone coordinates")
    print(f"  {info} ({time.perf_counter() - t0:.1f} s)", flush=True)

    done = []

    def progress(i: int, step) -> None:
        done.append(step)
        forces = ", ".join(f"{f:.4g}" for f in step.contact_force)
        print(f"  step {i + 1}/{case.n_steps}: value {step.value:.4g} m, contact force "
              f"{forces} N, max pressure {step.max_pressure / 1e6:.4g} MPa, "
              f"{step.iterations} iterations", flush=True)

    try:
        result = solver.run(step_hook=progress)
    except KeyboardInterrupt as exc:
        partial = StaticResult(done, solver.mesh, solver.model,
                               [p.penalty for p in solver.pairs], dict(solver.timings), {})
        with ignore_signals():
            write_static_results(args.out, case, partial, status="stopped",
                                 error=f"interrupted ({getattr(exc, 'name', 'SIGINT')})")
        raise
    out = write_static_results(args.out, case, result)
    print(f"wrote {out} ({time.perf_counter() - t0:.1f} s)")
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
    from tqdm import tqdm

    from fe_impact.calibration.sweep import (
        Settings,
        calibrate,
        check_scheduler_address,
        numba_folder,
        plan_cases,
    )
    from fe_impact.defaults import LEVEL_NAMES
    from fe_impact.errors import CalibrationError
    from fe_impact.fe.case import INTEGRATORS
    from fe_impact.gears import default_gearset_path, load_gearset
    from fe_impact.output.files import check_output_dir

    if args.workers is not None and args.workers < 1:
        raise CalibrationError(f"--workers {args.workers}: must be at least 1")
    if args.workers is not None and args.scheduler is None:
        from fe_impact.calibration.sweep import _cores

        cores = _cores()
        if args.workers > cores:
            logger.warning("--workers %d on %d cores: the workers share the cores (no faster) "
                           "and each holds its case's memory (up to 3 GB at the default "
                           "level, 10 GB for a corner impact)", args.workers, cores)
    for option, value, allowed in (("--level", args.level, LEVEL_NAMES),
                                   ("--mesh-cycle-level", args.mesh_cycle_level, LEVEL_NAMES),
                                   ("--integrator", args.integrator, INTEGRATORS)):
        if value is not None and value not in allowed:
            raise CalibrationError(f"{option} {value!r}: pick one of {', '.join(allowed)}")
    if args.scheduler is not None:
        check_scheduler_address(args.scheduler)
    check_output_dir(args.out)
    check_output_dir(args.cache, "--cache")
    with contextlib.ExitStack() as stack:
        # the local workers' compiled kernels, held for the run: the presets' first
        # pass compiles the switching kernel into them, which the studies reuse
        numba = (None if args.scheduler is not None
                 else stack.enter_context(numba_folder(args.cache)))
        path = args.gearset if args.gearset is not None else default_gearset_path()
        gearset = load_gearset(path)
        text = path.read_text(encoding="utf-8-sig")
        settings = Settings(level=args.level, integrator=args.integrator,
                            cycle_level=args.mesh_cycle_level)
        cases = plan_cases(gearset, args.stages, args.speeds, args.impact_speeds, args.switch)
        if args.no_mesh_cycle and args.positions is not None:
            raise CalibrationError("--positions and --no-mesh-cycle: give one or the other")
        if args.no_mesh_cycle and args.mesh_cycle_level is not None:
            raise CalibrationError("--mesh-cycle-level and --no-mesh-cycle: give one or the "
                                   "other")
        if args.no_mesh_cycle and args.corners:
            raise CalibrationError("--corners and --no-mesh-cycle: the corner positions are "
                                   "part of the mesh cycle; give one or the other")

        def positions(impacts: list) -> list:
            if args.no_mesh_cycle:
                return []
            from fe_impact.calibration.meshcycle import DEFAULT_POSITIONS, plan_positions

            # The curves reach the largest impact force the sweep expects (Hertz
            # estimate at the pitch point, a quarter above for the bending).
            from fe_impact.gears.pairanalysis import hertz_impact_estimate

            top = max((1.25 * hertz_impact_estimate(gearset, c.stage, settings.roll_angle_deg,
                                                    c.impact_speed).force_max for c in impacts),
                      default=None)
            flank = plan_positions(gearset, args.stages, args.positions if args.positions
                                   is not None else DEFAULT_POSITIONS, top_force=top,
                                   level=settings.position_level)
            if not args.corners:
                return flank
            from fe_impact.calibration.meshcycle import plan_corner_positions

            corners = plan_corner_positions(gearset, args.stages, top_force=top)
            if not corners:
                raise CalibrationError("--corners: the gear set's tip edges are sharp "
                                       "(tip_edge_radius_mm = 0 on the pinion and the face "
                                       "gears): there is no rounding to touch")
            return flank + corners

        cycle = positions(cases)    # checks the options before the presets run
        presets = _seed_studies(gearset, args.stages)
        if args.corner_impacts and not presets:
            raise CalibrationError("--corner-impacts: none of the seed's switching presets "
                                   "runs on these stages, so there are no corner closing "
                                   "speeds to strike at; add stages or drop the option")
        studies = () if args.no_switching else presets
        demand = None
        switches = any(c.kind == "switch" for c in cases)
        if presets and not args.no_preset_speeds and (
                switches or args.corner_impacts
                or (studies and args.speeds is None and args.impact_speeds is None)):
            demand = _first_pass(gearset, presets, args.out, numba)
        if (demand is not None and studies and args.speeds is None
                and args.impact_speeds is None):
            covered = _cover(demand, cases, gearset)
            if covered != cases:
                cases = covered
                cycle = positions(cases)
        if demand is not None and switches:
            from fe_impact.switching.demand import place_switches

            cases, lines = place_switches(demand, cases, gearset)
            for line in lines:
                print(f"  {line}", flush=True)
        if args.corner_impacts:
            from fe_impact.switching.demand import corner_impacts

            if demand is None:
                raise CalibrationError("--corner-impacts and --no-preset-speeds: the corner "
                                       "impacts' closing speeds come from the presets' first "
                                       "pass; give one or the other")
            extra, lines = corner_impacts(demand, gearset, sorted({c.stage for c in cases}))
            for line in lines:
                print(f"  {line}", flush=True)
            if not extra:
                raise CalibrationError("--corner-impacts: the presets struck no rounded tip "
                                       "edge of these stages (or the edges are sharp)")
            cases += extra
        n_impacts = len(cases)
        cases += cycle
        levels = settings.level if settings.position_level == settings.level or \
            len(cases) == n_impacts else f"{settings.level} / {settings.position_level}"
        print(f"calibrating {n_impacts} impacts and {len(cases) - n_impacts} mesh-cycle positions "
              f"({levels} meshes, {settings.integrator}) -> {args.out}", flush=True)
        bar = tqdm(total=len(cases), desc="  cases", unit="case")

        def progress(done: int, total: int, last: str) -> None:
            bar.update(done - bar.n)
            if last:
                bar.set_postfix_str(last)

        try:
            path = calibrate(text, cases, settings, args.out, args.cache, args.workers,
                             args.scheduler, progress, studies, numba)
        finally:
            bar.close()
        print(f"wrote {path}, {args.out / 'calibration.csv'} and {args.out / 'report.md'}")
        from fe_impact.calibration.report import terminal_summary

        for line in terminal_summary(json.loads(Path(path).read_text(encoding="utf-8"))):
            print(f"  {line}")
        if studies:
            print(f"switching studies {', '.join(studies)} on it: {args.out / 'switching'}")
        return 0


def _first_pass(gearset, presets, out: Path, numba: Path | None):
    """The loop's first pass: the seed presets on the closed-form laws, their closing
    speeds and places written to ``out/preset_demand.json``
    (:func:`fe_impact.switching.demand.preset_demand`)."""
    from fe_impact.output.files import write_json
    from fe_impact.switching.demand import TOP_MARGIN, preset_demand

    print(f"switching presets {', '.join(presets)} on the closed-form laws: their closing "
          "speeds ...", flush=True)
    demand = preset_demand(gearset, presets, numba=numba)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "preset_demand.json", {**demand.to_dict(), "top_margin": TOP_MARGIN,
                                            "units": {"speed": "m/s", "force": "N",
                                                      "position": "m"}})
    return demand


def _cover(demand, cases: list, gearset) -> list:
    """The planned impacts adjusted to the presets' closing speeds
    (:func:`fe_impact.switching.demand.cover`), each change printed."""
    from fe_impact.switching.demand import cover

    covered, lines = cover(demand, cases, gearset)
    for line in lines:
        print(f"  {line}", flush=True)
    return covered


def _seed_studies(gearset, stages) -> tuple[str, ...]:
    """The seed's switching studies the calibration will have laws for: those engaging
    only calibrated stages of a gear set that has them."""
    from fe_impact.switching.presets import get_preset
    from fe_impact.switching.study import SEED_STUDIES, study_stages

    have = set(stages) if stages else set(range(1, len(gearset.stages) + 1))
    return tuple(name for name in SEED_STUDIES if study_stages(get_preset(name)) <= have)


def _checked_dynamic(case, max_frames: int):
    """The transient case with at most ``max_frames`` output frames; warnings for
    settings that are legal but surely unintended."""
    import math
    from dataclasses import replace

    a = case.analysis
    where = f"{case.path.name}: [analysis]"
    if a.time_step is not None and a.duration / a.time_step < MIN_STEPS_PER_CONTACT:
        logger.warning("%s time_step = %.4g s gives %d step(s) over the whole duration %.4g s, "
                       "and fewer over the contact: an impact needs about %d or more over "
                       "the contact", where, a.time_step, max(1, round(a.duration / a.time_step)),
                       a.duration, MIN_STEPS_PER_CONTACT)
    interval = a.output_step
    frames = math.floor(a.duration / interval * (1 + 1e-9)) + 1
    if frames <= max_frames:
        return case
    wider = a.duration / (max_frames - 1)
    logger.warning("%s output_interval = %.4g s asks for %d frames, more than the cap of %d: "
                   "writing every %.4g s instead (raise the cap with --max-frames)", where,
                   interval, frames, max_frames, wider)
    return replace(case, analysis=replace(a, output_interval=wider))


def _solve_dynamic(case, out: Path) -> int:
    from tqdm import tqdm

    from fe_impact.errors import SolverError
    from fe_impact.fe.mesh import load_mesh
    from fe_impact.interrupts import ignore_signals
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
        with ignore_signals():   # a second Ctrl-C must not cut the summary short
            partial = solver.result()
            error = (f"interrupted ({getattr(exc, 'name', 'SIGINT')})"
                     if isinstance(exc, KeyboardInterrupt) else str(exc))
            writer.finish(partial, status="stopped", error=error)
        raise
    bar.close()
    path = writer.finish(result)
    m = result.measurements
    t_c = m.get("contact_duration")
    if t_c is not None and t_c / solver.dt < MIN_STEPS_PER_CONTACT:
        logger.warning("the contact lasted %.4g s, only %.1f time steps of %.4g s (fewer than "
                       "%d): peak force and contact time are not resolved; use [analysis] "
                       "time_step = %.3g s or less", t_c, t_c / solver.dt, solver.dt,
                       MIN_STEPS_PER_CONTACT, t_c / MIN_STEPS_PER_CONTACT)

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
