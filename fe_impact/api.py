"""The Python API: everything the ``fe-impact`` command does, as functions.

The command line is a thin layer over this module (meshio's ``_cli`` calls
``meshio.read`` and ``meshio.write`` the same way): each subcommand parses its
options, calls one function here and prints what it returns. A script does
the same without the command::

    import fe_impact

    gearset = fe_impact.read_gearset("geometry/two-stage.toml")
    rows = fe_impact.geometry_report(gearset)            # fe-impact geometry
    pair = fe_impact.mesh_pair(gearset, stage=1, level="coarse", out="pair")
    result = fe_impact.solve(pair.case_path, out="impact")   # fe-impact solve
    calibration = fe_impact.calibrate("geometry/two-stage.toml", stages=[1], speeds=[300],
                                      level="coarse", out="cal")   # fe-impact calibrate
    study = fe_impact.run_switching("table1", "geometry/two-stage.toml",
                                    "cal/calibration.json", out="sw")  # fe-impact switching

(in a script, :func:`calibrate` goes under ``if __name__ == "__main__":``: its
Dask workers import the script again).

Units are SI throughout (m, s, N, kg), except where a name says otherwise
(``speeds`` in r/min, ``roll_angle_deg``). Bad input raises a subclass of
:class:`fe_impact.errors.FeImpactError` whose message is one line naming the
option, the value and what is allowed; options shared with the command are
named in the command's spelling (``--impact-speeds`` for ``impact_speeds``).

Functions that print progress take ``echo``, a callable given each line
(the command passes :func:`print`); without it the lines go to this module's
logger at INFO level.
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Union

from fe_impact.defaults import SAMPLE_INTERVAL
from fe_impact.errors import CalibrationError, FeImpactError, GeometryError
from fe_impact.export import FORMATS as EXPORT_FORMATS
from fe_impact.export import ExportResult, export_calibration

if TYPE_CHECKING:
    from fe_impact.calibration.planning import ImpactCase, Settings
    from fe_impact.calibration.records import Calibration
    from fe_impact.fe.case import Case
    from fe_impact.gears.gearset import GearSet
    from fe_impact.meshing.toothpair import PairMesh
    from fe_impact.solvers.dynamic import DynamicResult
    from fe_impact.solvers.static import StaticResult
    from fe_impact.switching.demand import Demand
    from fe_impact.switching.model import StageSchedule
    from fe_impact.switching.presets import Preset
    from fe_impact.switching.schedule import DutyCycle
    from fe_impact.switching.simulation import SwitchingRun

__all__ = [
    "EXPORT_FORMATS",
    "MAX_FRAMES",
    "MIN_STEPS_PER_CONTACT",
    "calibrate",
    "calibration_summary",
    "cores",
    "default_gearset",
    "export_calibration",
    "ExportResult",
    "geometry_report",
    "mesh_pair",
    "pair_picture",
    "presets",
    "read_calibration",
    "read_case",
    "read_gearset",
    "read_schedule",
    "run_switching",
    "seed_load_torque",
    "seed_studies",
    "simulate_switching",
    "solve",
    "study_preset",
]

logger = logging.getLogger(__name__)

#: A file or folder name: a string or a path.
PathLike = Union[str, "os.PathLike[str]"]
#: Receives each progress line of a run (``print`` in the command).
Echo = Callable[[str], None]

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


def __getattr__(name: str):
    """``TOP_LAND_MIN``: the narrowest top land the seed file's outer radii leave [m]
    (imported when asked: it lives with the geometry report's numerical code)."""
    if name == "TOP_LAND_MIN":
        from fe_impact.gears.report import TOP_LAND_MIN

        return TOP_LAND_MIN
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _say(echo: Echo | None) -> Echo:
    """``echo``, or a function logging each line at INFO level."""
    if echo is not None:
        return echo
    return lambda line: logger.info("%s", line)


# -- readers -------------------------------------------------------------------------------------
def read_gearset(path: PathLike | None = None) -> GearSet:
    """Read a gear-set TOML file.

    Parameters
    ----------
    path : str or path-like, optional
        The file (its keys are described in the gear-set guide); None: the
        built-in seed gear set (``fe_impact/gears/seed.toml``, packaged).

    Returns
    -------
    GearSet
        The validated gear set, in SI units.

    Raises
    ------
    GeometryError
        A missing file, a bad key or value (one line naming the file's key).
    """
    from fe_impact.gears.gearset import default_gearset as seed
    from fe_impact.gears.gearset import load_gearset

    return seed() if path is None else load_gearset(path)


def default_gearset() -> GearSet:
    """The built-in seed gear set (three face-gear stages, one pinion)."""
    return read_gearset(None)


def read_case(path: PathLike) -> Case:
    """Read a case file (TOML): mesh, materials, contacts, supports and analysis.

    Parameters
    ----------
    path : str or path-like
        The case file; its ``mesh`` is taken relative to the file's folder.

    Returns
    -------
    Case
        The validated case (``case.analysis.dynamic`` tells a transient one).

    Raises
    ------
    CaseError
        A missing file, a bad key or value (one line naming the key).
    """
    from fe_impact.fe.case import load_case

    return load_case(path)


def read_calibration(path: PathLike) -> Calibration:
    """Read a ``calibration.json`` written by :func:`calibrate`.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    Calibration
        Its records (one per FE impact: stage, kind, impact speed, the fitted
        IMPACT parameters ``k``, ``exponent``, ``cmax``, ``d`` and the FE
        measurements), the run's settings and the mesh cycle's
        position-dependent law.

    Raises
    ------
    CalibrationError
        A file of another schema, a missing or malformed field.
    """
    from fe_impact.calibration.records import read_calibration as read

    return read(path)


def presets() -> dict[str, Preset]:
    """The seed's operating conditions for :func:`run_switching`, by name.

    ``table1`` .. ``table3`` (one stage, no load, 100 / 300 / 1000 r/min),
    ``table4`` (stage 2, 300 r/min, four loads), ``variable-speed`` and
    ``variable-load`` (switching 1 -> 2 -> 3), and each of their cases alone
    (``table1-100rpm``, ``table4-500Nmm``, ...).
    """
    from fe_impact.switching.presets import PRESETS

    return dict(PRESETS)


def read_schedule(path: PathLike) -> DutyCycle:
    """Read a schedule file (TOML): the drive's duty cycle, segment by segment.

    Parameters
    ----------
    path : str or path-like
        The file: per segment the engaged stage, the pinion speed (constant or
        ramped), the output load (constant, ramped or a CSV series) and the
        duration; a segment on another stage is a ratio switch.

    Returns
    -------
    DutyCycle
        ``name``, ``description`` and ``schedule`` (the segments as the model
        runs them), for :func:`run_switching` and :func:`simulate_switching`.

    Raises
    ------
    CaseError
        One line naming the file, the key (with the segment's index), the value
        and what is allowed.
    """
    from fe_impact.switching.schedule import read_schedule as read

    return read(path)


def seed_load_torque() -> float:
    """The largest load torque of the seed's presets on the output [N m] (1 N m): the
    default load of :func:`geometry_report`."""
    from fe_impact.switching.presets import seed_load_torque as largest

    return largest()


def cores() -> int:
    """The cores this process may use (the default number of local workers)."""
    from fe_impact.calibration import cluster

    return cluster.cores()


# -- geometry and meshing ------------------------------------------------------------------------
def geometry_report(gearset: GearSet | PathLike | None = None,
                    torque: float | None = None) -> list[dict]:
    """The checks of a gear set before any finite-element work, one row per stage.

    Parameters
    ----------
    gearset : GearSet, str or path-like, optional
        A gear set or its TOML file; None: the seed set.
    torque : float, optional
        Load torque on the output [N m] for the Hertz numbers; None: the
        seed's largest load (:func:`seed_load_torque`).

    Returns
    -------
    list of dict
        Per stage (``"stage"``, ``"teeth"``, ...), in SI units: the face-width
        limits and chosen radii (``"face_width"``), the path of contact in pinion
        roll angle and the contact ratio (``"path_of_contact"``), the Hertz
        contact at the pitch point (``"pitch_point"``), the reduced masses
        (``"masses"``), the tip edges and the first touch of a rounded edge
        (``"tip_edges"``, ``"corners"``). See
        :func:`fe_impact.gears.report.stage_geometry`.
    """
    from fe_impact.gears.report import stage_geometry

    if torque is not None and not (math.isfinite(torque) and torque > 0.0):
        raise GeometryError(f"torque = {torque:g} N m: must be a number > 0")
    return stage_geometry(_gearset(gearset), seed_load_torque() if torque is None else torque)


def _gearset(gearset: GearSet | PathLike | None) -> GearSet:
    """A gear set given as itself, as its file, or None (the seed set)."""
    if gearset is None or isinstance(gearset, (str, os.PathLike)):
        return read_gearset(gearset)
    return gearset


def mesh_pair(gearset: GearSet | PathLike | None = None, stage: int = 1, *,
              out: PathLike, roll_angle_deg: float = 0.0, level: str = "default",
              order: int = 2, gap: float = 5e-6, impact_speed: float = 0.1,
              face_teeth: int = 1, neighbour_teeth: int = 1, contact: str = "flank",
              refinement: float = 1.0, reuse: bool = False) -> PairMesh:
    """Mesh a pinion tooth and face-gear teeth at their contact, ready for an impact.

    Writes ``pair.msh`` (mm), ``case.toml`` (a transient impact case for
    :func:`solve`) and ``tca.json`` to ``out``.

    Parameters
    ----------
    gearset : GearSet, str or path-like, optional
        None: the seed set.
    stage : int
        Face-gear stage, from 1.
    out : str or path-like
        Output folder (made; removed again if meshing fails before writing).
    roll_angle_deg : float
        Pinion roll angle from the pitch-point position [deg].
    level : {"coarse", "default", "fine"}
        Mesh refinement.
    order : {1, 2}
        Element order.
    gap : float
        Initial normal gap at the contact point [m].
    impact_speed : float
        Closing normal speed at the contact point [m/s].
    face_teeth : {1, 2, 3}
        Face-gear teeth in the sector.
    neighbour_teeth : {0, 1, 2}
        Unloaded teeth on each side of both sectors.
    contact : {"flank", "corner-approach", "corner-recess"}
        Where the teeth touch: on the flanks, or a rounded tip edge's first touch.
    refinement : float
        Divides every element size of ``level``.
    reuse : bool
        Keep the files in ``out`` if made from the same inputs.

    Returns
    -------
    PairMesh
        Paths (``mesh_path``, ``case_path``, ``tca_path``), the contact point and
        normal (``contact``), the Hertz ellipse (``ellipse``), the pair analysis
        with the Hertz impact estimate (``analysis.impact``) and mesh statistics.
    """
    from fe_impact.meshing.toothpair import build_pair
    from fe_impact.output.files import check_output_dir, removed_if_left_empty

    check_output_dir(out)
    gs = _gearset(gearset)
    n = len(gs.stages)
    if not 1 <= stage <= n:
        raise GeometryError(f"--stage {stage}: gear set {gs.name!r} has stages 1..{n}")
    with removed_if_left_empty(out) as folder:    # a pair not made leaves no empty folder
        return build_pair(gs, stage, roll_angle_deg, level, order, gap, impact_speed, folder,
                          reuse=reuse, n_face_teeth=face_teeth, neighbour_teeth=neighbour_teeth,
                          contact=contact, refinement=refinement)


def pair_picture(pair: PairMesh, path: PathLike,
                 gearset: GearSet | None = None) -> tuple[Path, str]:
    """Picture of a meshed pair and its Hertz contact ellipse (PNG).

    pyvista off-screen, else matplotlib. ``gearset`` lets the ellipse be laid on
    the curved face flank. Returns the path and which renderer drew it.
    """
    from fe_impact.output.pair_picture import write_picture

    return write_picture(pair, Path(path), gearset)


# -- solving a case ------------------------------------------------------------------------------
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
    say = _say(echo)
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


# -- the main job: calibration -------------------------------------------------------------------
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

    say = _say(echo)
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
    from fe_impact.calibration.execution import Studies
    from fe_impact.calibration.execution import calibrate as run
    from fe_impact.switching.study import seed_study_job, study_folder

    cases = impacts + cycle
    levels = settings.level if settings.position_level == settings.level or not cycle \
        else f"{settings.level} / {settings.position_level}"
    say(f"calibrating {len(impacts)} impacts and {len(cycle)} mesh-cycle positions "
        f"({levels} meshes, {settings.integrator}) -> {out}")
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


# -- switching -----------------------------------------------------------------------------------
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
    preset = _preset(schedule, _gearset(gearset))
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
    gs = _gearset(gearset)
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

    gs = _gearset(gearset)
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
