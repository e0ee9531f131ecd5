"""A case solved: static contact in load steps, or a transient impact."""

from __future__ import annotations

import logging
import math
import os
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from fe_impact.api.common import Echo, PathLike, say_to
from fe_impact.api.readers import read_case
from fe_impact.errors import FeImpactError

if TYPE_CHECKING:
    from fe_impact.fe.case import Case
    from fe_impact.solvers.dynamic import DynamicResult
    from fe_impact.solvers.static import StaticResult

__all__ = ["MAX_FRAMES", "MIN_STEPS_PER_CONTACT", "solve"]

logger = logging.getLogger(__name__)

#: Most VTU frames :func:`solve` writes for a transient case unless
#: ``max_frames`` says otherwise; above it the output interval is widened (with
#: a warning). A frame of a 100k-DOF tooth pair is some 10 MB and 0.3 s: an
#: output interval of 1e-10 s over a 40 us impact asked for 400,000 frames and,
#: with the automatic Newmark step, as many steps.
MAX_FRAMES = 1000
#: Fewer time steps than this over a transient run, or over its measured
#: contact, get a warning: the peak force and the contact time are not resolved
#: (the impact benchmark needs some 60 for 0.4 %).
MIN_STEPS_PER_CONTACT = 20


def solve(case: Case | PathLike, out: PathLike | None = None, *, max_frames: int = MAX_FRAMES,
          echo: Echo | None = None,
          progress: Callable[[float], None] | None = None) -> StaticResult | DynamicResult:
    """Solve a case: static contact (load steps) or a transient impact.

    Parameters
    ----------
    case : Case, str or path-like
        A case or its TOML file (:func:`read_case`).
    out : str or path-like, optional
        Folder for ``summary.json``, the VTU fields with a PVD series and, for an
        impact, ``history.csv`` and plots; None: nothing is written.
    max_frames : int
        Most VTU frames of a transient run; a finer ``[analysis]
        output_interval`` is widened to give this many, with a warning.
    echo : callable, optional
        Receives the progress lines (set-up, each load step, the result).
    progress : callable, optional
        ``progress(fraction)`` now and then during a transient run.

    Returns
    -------
    StaticResult or DynamicResult
        A static run's load steps (``steps[i].contact_force`` [N],
        ``.pressure`` per mesh point [Pa], ``.u`` [m]); a transient run's
        histories (``history["time"]``, ``["contact_force"]``, ...) and
        ``measurements`` (peak force, maximum approach, contact time,
        restitution, energy error).

    Notes
    -----
    Interrupted (SIGINT, :class:`KeyboardInterrupt`), a run with ``out``
    writes what it did, marked ``status: "stopped"``, and raises again.
    """
    if max_frames < 2:
        raise FeImpactError(f"--max-frames {max_frames}: must be at least 2")
    if isinstance(case, (str, os.PathLike)):
        case = read_case(case)
    if out is not None:
        from fe_impact.output.files import check_output_dir

        out = check_output_dir(out)
    say = say_to(echo)
    if case.analysis.dynamic:
        return _solve_dynamic(_checked_dynamic(case, max_frames), out, say, progress)
    return _solve_static(case, out, say)


def _solve_static(case: Case, out: Path | None, say: Echo) -> StaticResult:
    from fe_impact.fe.mesh import load_mesh
    from fe_impact.interrupts import ignore_signals
    from fe_impact.output.results import write_static_results
    from fe_impact.solvers.static import StaticResult, StaticSolver

    t0 = time.perf_counter()
    say(f"{case.path.name}: setting up (mesh, assembly, factorisation)")
    solver = StaticSolver(case, load_mesh(case.mesh_file, case.unit))
    say(f"  {solver.model.n_dofs} DOFs, P{solver.mesh.order}, {solver.n_condensed} "
        f"contact-zone coordinates ({time.perf_counter() - t0:.1f} s)")
    done = []

    def step_hook(i: int, step) -> None:
        done.append(step)
        forces = ", ".join(f"{f:.4g}" for f in step.contact_force)
        say(f"  step {i + 1}/{case.n_steps}: value {step.value:.4g} m, contact force {forces} "
            f"N, max pressure {step.max_pressure / 1e6:.4g} MPa, {step.iterations} iterations")

    try:
        result = solver.run(step_hook=step_hook)
    except KeyboardInterrupt as exc:
        if out is not None:
            partial = StaticResult(done, solver.mesh, solver.model,
                                   [p.penalty for p in solver.pairs], dict(solver.timings), {})
            with ignore_signals():
                write_static_results(out, case, partial, status="stopped",
                                     error=f"interrupted ({getattr(exc, 'name', 'SIGINT')})")
        raise
    if out is not None:
        path = write_static_results(out, case, result)
        say(f"wrote {path} ({time.perf_counter() - t0:.1f} s)")
    return result


def _checked_dynamic(case: Case, max_frames: int) -> Case:
    """The transient case with at most ``max_frames`` output frames; warnings for
    settings that are legal but surely unintended."""
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


def _solve_dynamic(case: Case, out: Path | None, say: Echo,
                   progress: Callable[[float], None] | None) -> DynamicResult:
    from fe_impact.errors import SolverError
    from fe_impact.fe.mesh import load_mesh
    from fe_impact.interrupts import ignore_signals
    from fe_impact.output.results import DynamicWriter
    from fe_impact.solvers.dynamic import DynamicSolver

    t0 = time.perf_counter()
    a = case.analysis
    say(f"{case.path.name}: setting up (mesh, assembly, contact zone, "
        f"{'stable step' if a.integrator == 'explicit' else 'factorisation'})")
    solver = DynamicSolver(case, load_mesh(case.mesh_file, case.unit))
    n_steps = max(1, round(a.duration / solver.dt))
    say(f"  {solver.model.n_dofs} DOFs, P{solver.mesh.order}, {a.integrator}, time step "
        f"{solver.dt:.4g} s x {n_steps} steps ({time.perf_counter() - t0:.1f} s)")
    writer = None if out is None else DynamicWriter(out, case, solver.mesh,
                                                     solver.model.material)
    try:
        result = solver.run(frame_hook=None if writer is None else writer.frame,
                            progress=progress)
    except (SolverError, KeyboardInterrupt) as exc:
        if writer is not None:
            with ignore_signals():   # a second Ctrl-C must not cut the summary short
                error = (f"interrupted ({getattr(exc, 'name', 'SIGINT')})"
                         if isinstance(exc, KeyboardInterrupt) else str(exc))
                writer.finish(solver.result(), status="stopped", error=error)
        raise
    path = None if writer is None else writer.finish(result)
    _warn_short_contact(result.measurements.contact_duration, solver.dt)
    for line in _impact_lines(result):
        say(line)
    if path is not None:
        say(f"wrote {path} ({time.perf_counter() - t0:.1f} s)")
    return result


def _warn_short_contact(t_c: float | None, dt: float) -> None:
    """A warning when the measured contact spans too few time steps."""
    if t_c is not None and t_c / dt < MIN_STEPS_PER_CONTACT:
        logger.warning("the contact lasted %.4g s, only %.1f time steps of %.4g s (fewer than "
                       "%d): peak force and contact time are not resolved; use [analysis] "
                       "time_step = %.3g s or less", t_c, t_c / dt, dt,
                       MIN_STEPS_PER_CONTACT, t_c / MIN_STEPS_PER_CONTACT)


def _impact_lines(result: DynamicResult) -> list[str]:
    """The measured impact in a line or two, for the terminal."""
    m = result.measurements

    def fmt(v, scale=1.0, spec=".4g"):
        return "-" if v is None else format(v * scale, spec)

    lines = [f"  peak force {fmt(m.peak_force)} N, max approach "
             f"{fmt(m.max_approach, 1e6)} um, contact {fmt(m.contact_duration, 1e6)} us, "
             f"restitution {fmt(m.restitution)}, "
             f"energy error {fmt(m.energy_error, 100, '.3f')}%"]
    pl = result.info.get("plasticity")
    if pl:
        lines.append(f"  plastic work {fmt(pl['dissipation'])} J, max equivalent plastic "
                     f"strain {fmt(pl['max_equivalent_plastic_strain'], 100, '.3g')}%, "
                     f"residual indentation {fmt(m.residual_indentation, 1e6)} um")
    return lines
