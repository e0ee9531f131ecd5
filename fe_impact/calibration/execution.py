"""Executing a calibration run: the sweep of its cases on Dask, resumable, and its files.

Cases run as a sweep on Dask (a local cluster by default, or an existing
``dask.distributed`` scheduler; :mod:`fe_impact.calibration.cluster`). Each
finished case is written to ``cases/<id>/result.json`` at once (atomically),
so an interrupted run keeps its finished cases and a rerun computes only the
missing ones (:func:`~fe_impact.calibration.planning.case_hash`).

A case is computed under a lock on its folder (``cases/<id>/.lock``, see
:func:`fe_impact.output.files.folder_lock`): a second run on the same output
folder waits for the cases the first is computing and takes their results.
Holding the lock, a case first deletes the temporary files that a killed
run may have left in its folder. SIGINT (Ctrl-C) or SIGTERM stops the
sweep: the running cases stop within a second or so (:data:`STOP_GRACE` at
most), ``summary.json`` is written with ``status: "stopped"``, the finished
and the missing cases, and the command ends with one line; an earlier
``calibration.json`` is left as it was. The workers ignore both signals
themselves; the parent stops them.

A completed sweep writes ``calibration.json``/``.csv``, ``report.md``
(:mod:`fe_impact.calibration.report`) and ``summary.json``, and runs the
seed's switching studies on the calibration.
"""

from __future__ import annotations

import contextlib
import functools
import json
import logging
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

from fe_impact.calibration import meshcycle
from fe_impact.calibration.cluster import (
    CaseStopped,
    case_lock,
    cores,
    import_distributed,
    local_cluster,
    numba_folder,
    quiet_asyncio,
    stop_watch,
)
from fe_impact.calibration.measurement import run_case
from fe_impact.calibration.meshcycle import PositionCase
from fe_impact.calibration.planning import ImpactCase, Settings, case_hash
from fe_impact.calibration.records import (
    NOTES,
    Calibration,
    CalibrationRecord,
    write_calibration,
    write_calibration_csv,
)
from fe_impact.errors import CalibrationError
from fe_impact.inputs import Reader, read_document
from fe_impact.interrupts import Interrupted, handle_signals, ignore_signals
from fe_impact.output.drawing import Draw, draw_here, draw_on
from fe_impact.output.files import folder_lock, remove_temporaries, removed_if_left_empty
from fe_impact.version import __version__

logger = logging.getLogger(__name__)

#: Schema of the run's summary.json (status, finished and missing cases).
SUMMARY_SCHEMA = "fe-impact/calibration-run/1"
#: After SIGINT/SIGTERM, wait at most this long [s] for the running cases to
#: stop before the workers are closed regardless. A case checks every
#: STOP_POLL s and stops at the next Python statement, which in a tooth
#: impact is well within a second (one Newmark step is 0.1-0.5 s).
STOP_GRACE = 20.0


@dataclass(frozen=True)
class Studies:
    """Switching studies to run on a finished calibration, each into ``switching/<folder>/``.

    The lumped model is downstream of the calibration, so the calibration does not
    import it: the caller hands its studies in (:func:`fe_impact.api.calibrate` with
    :func:`fe_impact.switching.study.seed_study_job` and
    :func:`~fe_impact.switching.study.study_folder`).

    Attributes
    ----------
    names : tuple of str
        Each study as ``job`` takes it: a seed condition set's name or a schedule
        file's path.
    job : callable
        ``job(gearset_text, name, calibration_json, out_folder) -> dict``: one study,
        run on a worker (picklable).
    folder : callable
        ``folder(name) -> str``: the study's folder under ``switching/``.
    """

    names: tuple[str, ...]
    job: Callable[[str, str, str, str], dict]
    folder: Callable[[str], str] = str


@dataclass
class Sweep:
    """Cases of a run, split into finished (loaded from disk) and to do."""

    cases: list[ImpactCase]
    done: dict[str, CalibrationRecord] = field(default_factory=dict)

    @property
    def todo(self) -> list[ImpactCase]:
        return [c for c in self.cases if c.id not in self.done]


def load_finished(out: Path, cases: list[ImpactCase], settings: Settings,
                  gearset_text: str) -> Sweep:
    """Finished cases of an earlier run with the same parameters (resume)."""
    sweep = Sweep(cases)
    for c in cases:
        record = finished_record(out, c, settings, gearset_text)
        if record is not None:
            sweep.done[c.id] = record
    return sweep


def finished_record(out: Path, case: ImpactCase, settings: Settings,
                    gearset_text: str) -> CalibrationRecord | None:
    """``cases/<id>/result.json`` if it holds this case with these settings, else None."""
    path = Path(out) / "cases" / case.id / "result.json"
    if not path.is_file():
        return None
    try:
        data = read_document(path, "calibration result", CalibrationError, "json")
        if data.get("hash") != case_hash(case, settings, gearset_text):
            return None   # another version, gear set or settings: computed again
        if isinstance(case, PositionCase):
            return meshcycle.PositionRecord.from_dict(data)
        return CalibrationRecord.from_dict(data, Reader(str(path), CalibrationError, "json"))
    except CalibrationError as exc:   # cut short or edited: computed again
        logger.warning("%s; case %s is computed again", exc, case.id)
        return None


def calibrate(gearset_text: str, cases: list[ImpactCase], settings: Settings, out: Path,
              cache: Path, workers: int | None = None, scheduler: str | None = None,
              progress: Callable[[int, int, str], None] | None = None,
              studies: Studies | None = None, numba: Path | None = None) -> Path:
    """Run the sweep (resuming), then write calibration.json/.csv, the report and summary.json.

    ``studies``: the switching studies to run on the finished calibration, each
    into ``switching/<folder>/`` (on the sweep's workers while the report is
    written); the report lists them. ``numba``: the folder of the
    local workers' compiled kernels, held by the caller (:func:`numba_folder`);
    None: one is taken for the run.

    ``summary.json`` says how the run ended (``status``), which cases are
    finished and which are missing. On SIGINT or SIGTERM
    (:class:`KeyboardInterrupt`) only it is written, with ``status:
    "stopped"`` (calibration.json and the report need every case, and a
    complete calibration.json from an earlier run stays), and the interrupt
    is raised again.
    """
    # a run that fails before writing anything (a scheduler that never answered)
    # leaves no empty --out
    with removed_if_left_empty(out) as out:
        return _calibrate(gearset_text, cases, settings, out, cache, workers, scheduler,
                          progress, studies, numba)


def _calibrate(gearset_text: str, cases: list[ImpactCase], settings: Settings, out: Path,
               cache, workers, scheduler, progress, studies: Studies | None,
               numba: Path | None) -> Path:
    """:func:`calibrate` in its ``out`` folder."""
    t0 = time.perf_counter()
    sweep = load_finished(out, cases, settings, gearset_text)
    if sweep.done:
        logger.info("resuming: %d of %d cases already finished", len(sweep.done), len(cases))
    if progress is not None:
        progress(len(sweep.done), len(cases), "")
    todo = sweep.todo
    busy = [c.id for c in todo if _held_elsewhere(out / "cases" / c.id)]
    if busy:
        logger.warning("cases %s are being computed by another run on %s: this run waits for "
                       "them and takes their results", busy, out)
    written = []      # the calibration's files are complete once this holds their path

    def finish(draw: Draw, roots: Callable[[], list[str]] | None = None) -> Path:
        """The files of a completed sweep, the pictures drawn by ``draw``, and the
        switching studies run by ``draw``: on the workers (``draw_on``) the studies
        start as soon as calibration.json is written and run beside the report's
        pictures (no idle worker between the two); drawn here they run after.
        ``roots``: waits for the tooth-root stresses the sweep started
        (:func:`start_root_stresses`); None: they are drawn by ``draw``."""
        started: list[Callable[[], None]] = []

        def start(calibration: Path) -> None:
            started.append(_start_studies(out, calibration, gearset_text, studies, draw))

        path = _write_summary(out, cases, sweep, settings, time.perf_counter() - t0,
                              "completed", gearset_text, draw,
                              None if draw is draw_here else start, cache, roots)
        written.append(path)
        if started:
            started[0]()
        else:
            _run_studies(out, path, gearset_text, studies, draw)
        return path

    try:
        if not todo:
            return finish(draw_here)
        # the report's pictures and the studies are run on the sweep's workers before
        # they stop
        return _run_dask(todo, settings, gearset_text, out, cache, workers, scheduler, sweep,
                         progress, finish, numba)
    except KeyboardInterrupt:
        if not written:    # an interrupted study leaves the calibration complete
            _write_summary(out, cases, sweep, settings, time.perf_counter() - t0, "stopped",
                           gearset_text)
        raise


def _held_elsewhere(folder: Path) -> bool:
    """True if another process holds the case folder's lock."""
    if not folder.is_dir():
        return False
    with folder_lock(folder, wait=False) as held:
        return not held


def _write_summary(out: Path, cases: list[ImpactCase | PositionCase], sweep: Sweep,
                   settings: Settings, wall: float, status: str, gearset_text: str,
                   draw: Draw = draw_here,
                   written: Callable[[Path], None] | None = None,
                   cache: Path | None = None,
                   roots: Callable[[], list[str]] | None = None) -> Path:
    """summary.json and, for a completed run, calibration.json/.csv and report.md (its
    pictures drawn by ``draw`` while the tables are written, with the tooth-root
    stresses at the mesh cycle's largest force when there is a mesh ``cache``: drawn
    by ``draw``, or, if the sweep started them, waited for by ``roots``);
    ``written(path)`` is called once calibration.json is complete (it must not block)."""
    from fe_impact.calibration.report import (
        friction_effect,
        root_stress_jobs,
        write_calibration_report,
    )
    from fe_impact.output.files import write_json

    summary = {"schema": SUMMARY_SCHEMA, "fe_impact_version": __version__, "status": status,
               "finished": [c.id for c in cases if c.id in sweep.done],
               "missing": [c.id for c in cases if c.id not in sweep.done],
               "settings": settings.to_dict(), "wall_time_s": wall,
               "calibration": "calibration.json" if status == "completed" else None}
    with ignore_signals():   # the files belong together: a second Ctrl-C waits for them
        path = None
        if status == "completed":
            records = [sweep.done[c.id] for c in cases
                       if isinstance(c, ImpactCase) and not c.companion]
            positions = [sweep.done[c.id] for c in cases
                         if isinstance(c, PositionCase) and not c.companion]
            companions = [sweep.done[c.id] for c in cases if c.companion]
            cycle, drawing = None, None
            if positions:
                from fe_impact.calibration.meshcycle_report import write_mesh_cycle

                cycle, drawing = write_mesh_cycle(out, positions, gearset_text, draw)
            calibration = Calibration(cases=records, settings=settings.to_dict(),
                                      wall_time_s=wall, fe_impact_version=__version__,
                                      notes=NOTES, mesh_cycle=cycle,
                                      friction=friction_effect(gearset_text, records,
                                                               positions, companions))
            path = write_calibration(out / "calibration.json", calibration)
            if written is not None:
                written(path)
            write_calibration_csv(out / "calibration.csv", records)
            jobs = [] if cache is None or roots is not None else root_stress_jobs(
                out, gearset_text, positions, settings.position_level, cache)
            write_calibration_report(out, calibration, draw, jobs, roots)
            if drawing is not None:
                drawing()
        summary_path = write_json(out / "summary.json", summary)
    return path or summary_path


def _run_studies(out: Path, calibration: Path, gearset_text: str, studies: Studies | None,
                 draw: Draw) -> None:
    """Run the switching ``studies`` on the finished ``calibration`` (one ``draw`` job
    each), table them in report.md and list them in summary.json. A study that fails
    is logged and left out. Interrupted, the studies finished are kept (each study
    writes what it ran), summary.json says ``"switching": "stopped"``, and the
    interrupt is raised again: the calibration itself is complete."""
    try:
        finish = _start_studies(out, calibration, gearset_text, studies, draw)
    except KeyboardInterrupt:   # a draw that runs its jobs at once
        _studies_stopped(out)
        raise
    finish()


def _start_studies(out: Path, calibration: Path, gearset_text: str, studies: Studies | None,
                   draw: Draw) -> Callable[[], None]:
    """Hand the ``studies`` to ``draw``; returns what waits for them and then tables
    them (:func:`_run_studies`: summary.json must exist by then)."""
    if studies is None or not studies.names:
        return lambda: None
    from fe_impact.calibration.report import add_switching_section
    from fe_impact.output.files import write_json

    folders = [studies.folder(name) for name in studies.names]
    wait = draw([(f"switching study {folder}", studies.job,
                  (gearset_text, name, str(calibration), str(out / "switching" / folder)))
                 for name, folder in zip(studies.names, folders, strict=True)])

    def finish() -> None:
        try:
            done = wait()
        except KeyboardInterrupt:
            _studies_stopped(out)
            raise
        with ignore_signals():   # the report's table and the summary belong together
            summary_path = out / "summary.json"
            summary = json.loads(summary_path.read_text())
            add_switching_section(out, done)
            write_json(summary_path, {**summary, "switching": [
                f"switching/{job.removeprefix('switching study ')}" for job in done]})

    return finish


def _studies_stopped(out: Path) -> None:
    """Mark the studies stopped in summary.json (the calibration stays complete)."""
    from fe_impact.output.files import write_json

    summary_path = out / "summary.json"
    with ignore_signals():
        write_json(summary_path, {**json.loads(summary_path.read_text()),
                                  "switching": "stopped"})


def _run_dask(todo, settings, gearset_text, out, cache, workers, scheduler, sweep,
              progress, finish: Callable[..., Path] | None = None,
              numba: Path | None = None) -> Path | None:
    import_distributed()
    with contextlib.ExitStack() as stack:
        return _sweep_on_dask(todo, settings, gearset_text, out, cache, workers, scheduler,
                              sweep, progress, stack, finish, numba)


def _sweep_on_dask(todo, settings, gearset_text, out, cache, workers, scheduler, sweep,
                   progress, stack: contextlib.ExitStack,
                   finish: Callable[..., Path] | None = None,
                   numba: Path | None = None) -> Path | None:
    """Run ``todo`` on a local cluster or ``scheduler``; then, every case done, return
    ``finish(draw, roots)`` with a :data:`~fe_impact.output.drawing.Draw` on the same
    workers and what waits for the tooth-root stresses started with the cases
    (:func:`start_root_stresses`)."""
    from dask.distributed import Client, Event

    if scheduler:
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, ValueError) as exc:
            raise CalibrationError(f"--scheduler {scheduler}: cannot connect ({exc})") from None
        cluster = None
    else:
        if numba is None:
            numba = stack.enter_context(numba_folder(Path(cache)))
        cluster, client = local_cluster(workers or max(1, min(len(todo), cores())), numba)
    stop_name = f"fe-impact-stop-{uuid.uuid4().hex}"
    try:
        order = sweep_order(todo)
        futures = {client.submit(run_locked_case, c, settings, gearset_text, str(out),
                                 str(cache), stop_name,
                                 key=f"fe-impact-{c.id}-{case_hash(c, settings, gearset_text)}",
                                 priority=len(order) - i, pure=False): c
                   for i, c in enumerate(order)}
        roots = None if finish is None else start_root_stresses(
            client, futures, sweep, settings, gearset_text, out, cache)
        failures: list[str] = []
        with _interrupt_flag() as interrupted:
            try:
                _collect(futures, sweep, failures, progress, interrupted)
            except KeyboardInterrupt:
                with ignore_signals():   # stopping is bounded by STOP_GRACE
                    _stop_cases(Event(stop_name, client=client), futures)
                raise
        if failures:
            raise CalibrationError(f"{len(failures)} case(s) failed (finished cases are kept; "
                                   "rerun to retry): " + "; ".join(failures))
        return None if finish is None else finish(draw_on(client), roots)
    finally:
        with ignore_signals():
            client.close()
            if cluster is not None:
                cluster.close()
        _clean_cases(out, todo)


def start_root_stresses(client, futures: dict, sweep: Sweep, settings: Settings,
                        gearset_text: str, out: Path, cache) -> Callable[[], list[str]] | None:
    """Start each stage's tooth-root stresses on the sweep's workers, each as soon as
    the stage's flank positions are done and a worker has no case left to take (the
    lowest priority): the end of the sweep, where a worker would wait for the other's
    last case, rather than after it with the report's pictures and the studies (where
    they were the longest jobs and came last). The same job as
    :func:`~fe_impact.calibration.report.root_stress_jobs` (the largest force of the
    stage's flank position records). Returns what waits for them and gives the files
    written (a failed one is logged and left out); None without flank positions.
    """
    from fe_impact.calibration.report import ROOT_STRESS, root_stress_task
    from fe_impact.output.drawing import outcome

    running = {c.id: f for f, c in futures.items()}
    flank = [c for c in sweep.cases
             if isinstance(c, PositionCase) and c.contact == "flank" and not c.companion]
    jobs = []
    for stage in sorted({c.stage for c in flank}):
        inputs = [running.get(c.id, sweep.done.get(c.id)) for c in flank if c.stage == stage]
        if any(x is None for x in inputs):   # not planned in this sweep: nothing to wait for
            return None
        name = f"{ROOT_STRESS}/stage{stage}.json"
        jobs.append((name, client.submit(
            root_stress_task, gearset_text, stage, settings.position_level, str(cache),
            Path(out) / name, *inputs, priority=0, pure=False)))
    if not jobs:
        return None

    def wait() -> list[str]:
        done = []
        for name, future in jobs:
            try:
                result = future.result()
            except Exception as exc:   # noqa: BLE001 - a lost worker: the section is skipped
                result = (False, f"{type(exc).__name__}: {exc}")
            if outcome(name, result):
                done.append(name)
        return done

    return wait


def sweep_order(cases: list) -> list:
    """The order the cases are handed out in.

    Largest models first (impacts before the quasi-static positions, slower
    impacts: finer meshes), so the last case to finish is a small one; the
    impacts' stages taken in turn (the slowest of each stage, then the next
    speed), so that the workers start on different stages and build different
    sector solids, which they then share (:func:`~fe_impact.meshing.toothpair.share_solids`):
    with the stages one after the other both workers built stage 3's at once.
    The corner cases (``--corners``, ``--corner-impacts``) go before everything:
    a tip edge's contact zone is long and finely meshed (a coarse approach
    corner: 223k DOFs, 6 minutes static), the face gear's edge (approach)
    before the pinion's. The frictionless companions (:func:`~fe_impact.calibration.
    planning.friction_companions`) go last: they take the meshes of their cases,
    which are made by then.
    """
    rank: dict[int, list] = {}
    for c in sorted((c for c in cases if not isinstance(c, PositionCase)),
                    key=lambda c: c.impact_speed):
        rank.setdefault(c.stage, []).append(c.id)

    def group(c) -> int:
        if c.companion:
            return 4
        where = c.contact if isinstance(c, PositionCase) else c.kind
        return {"corner-approach": 0, "corner-recess": 1}.get(
            where, 3 if isinstance(c, PositionCase) else 2)

    return sorted(cases, key=lambda c: (
        group(c), 0 if isinstance(c, PositionCase) else rank[c.stage].index(c.id),
        -c.face_teeth, c.impact_speed))


def _collect(futures: dict, sweep: Sweep, failures: list[str], progress,
             interrupted: threading.Event) -> None:
    """Wait for the cases, recording each as it finishes."""
    pending = dict(futures)
    while pending:
        # Poll rather than block in the client: a Ctrl-C that lands while
        # dask's machinery runs can be swallowed there, the flag is not.
        if interrupted.is_set():
            raise Interrupted(interrupted.signum)
        finished = [f for f in pending if f.done()]
        if not finished:
            time.sleep(0.2)
            continue
        for fut in finished:
            c = pending.pop(fut)
            try:
                record = fut.result()
                if record is None:   # stopped (only after an interrupt)
                    continue
                sweep.done[c.id] = record
            except Exception as exc:  # a failed case does not stop the others
                failures.append(f"{c.id}: {exc}")
                logger.error("case %s failed: %s", c.id, exc)
            if progress is not None:
                progress(len(sweep.done), len(sweep.cases), c.id)


def _stop_cases(stop, futures: dict) -> None:
    """Tell every case to stop (:func:`run_locked_case` watches ``stop``) and wait for them.

    Cases not started yet end at once; running ones at their next Python
    statement. At most :data:`STOP_GRACE` seconds.
    """
    try:
        stop.set()
    except Exception as exc:   # scheduler gone: the workers are going too
        logger.info("could not signal the workers to stop: %s", exc)
        return
    deadline = time.monotonic() + STOP_GRACE
    while time.monotonic() < deadline and not all(f.done() for f in futures):
        time.sleep(0.1)
    running = [c.id for f, c in futures.items() if not f.done()]
    if running:
        logger.warning("cases %s did not stop within %g s; their workers are closed", running,
                       STOP_GRACE)


def _clean_cases(out, cases: list[ImpactCase]) -> None:
    """Delete temporary files in the folders of ``cases`` that no process is writing."""
    for c in cases:
        folder = Path(out) / "cases" / c.id
        if not folder.is_dir():
            continue
        with folder_lock(folder, wait=False) as free:
            if free:
                for path in remove_temporaries(folder):
                    logger.info("removed the unfinished file %s", path)



@contextlib.contextmanager
def _interrupt_flag():
    """An event set by SIGINT (Ctrl-C) or SIGTERM while the sweep waits.

    The handler also raises :class:`~fe_impact.interrupts.Interrupted` at
    once; the event (with the signal number as ``flag.signum``) keeps the
    interrupt if some library code in between catches it. The old handlers
    are restored at the end.
    """
    flag = threading.Event()
    flag.signum = None

    def note(signum: int) -> None:
        flag.signum = signum
        flag.set()

    with handle_signals(note):
        yield flag


# -- one case under its lock (runs on a worker) -------------------------------------------


def run_locked_case(case: ImpactCase, settings: Settings, gearset_text: str, out: str,
                    cache: str, stop_name: str | None = None) -> CalibrationRecord | None:
    """:func:`run_case` holding the case folder's lock; stops when ``stop_name`` is set.

    Waits while another process holds the lock (a second run on the same
    output folder) and then returns that run's result if it finished the
    case. Before computing, deletes the temporary files a killed run left in
    the case folder. ``stop_name`` names a ``distributed.Event``: once it is
    set the case stops and None is returned (a stop is not a failure: the
    worker logs nothing).
    """
    folder = Path(out) / "cases" / case.id
    quiet_asyncio()
    try:
        with stop_watch(stop_name, case.id), case_lock(folder, case.id):
            record = finished_record(Path(out), case, settings, gearset_text)
            if record is not None:
                logger.info("case %s: finished by another run", case.id)
                return record
            twin = frictionless_twin(Path(out), case, settings, gearset_text)
            if twin is not None:
                return twin
            for path in remove_temporaries(folder):
                logger.info("removed the unfinished file %s", path)
            return run_case(case, settings, gearset_text, out, cache,
                            functools.partial(_contact_picture, out))
    except (KeyboardInterrupt, CaseStopped):
        # A stopped case ends as an ordinary return, not by unwinding the worker.
        return None


def frictionless_twin(out: Path, case, settings: Settings,
                      gearset_text: str) -> meshcycle.PositionRecord | None:
    """A frictionless companion position whose frictional case is finished and fell back
    to frictionless flanks (:func:`~fe_impact.calibration.meshcycle.run_position`: a
    contact zone too large for the frictional solve): that case's record under the
    companion's id and resume key, written to its ``result.json``; else None (the
    companion is computed).

    The fallback is the companion's own solve (the same mesh, loads and frictionless
    static solve, on one thread), so the record is what computing it gives; the
    report's friction section leaves such a pair out either way (nothing to compare).
    A frictional case still running when its companion starts is not waited for.
    """
    import tomllib

    from fe_impact.gears import gearset_from_dict
    from fe_impact.output.files import write_json

    if not (isinstance(case, PositionCase) and case.companion):
        return None
    mu = meshcycle.gearset_friction(gearset_from_dict(tomllib.loads(gearset_text)))
    base = replace(case, friction=mu, companion=False)
    if base.friction == (0.0, 0.0):
        return None
    record = finished_record(out, base, settings, gearset_text)
    if record is None or any(record.friction):
        return None
    twin = replace(record, id=case.id, hash=case_hash(case, settings, gearset_text),
                   companion=True, friction_note="", timings_s={"total": 0.0})
    write_json(out / "cases" / case.id / "result.json", twin.to_dict())
    logger.info("case %s: the same solve as %s (%s), taken from it", case.id, base.id,
                record.friction_note)
    return twin


def _contact_picture(out: str, record: CalibrationRecord) -> None:
    """The case's row of the report's stress picture, rendered here on the worker
    (0.5 s an impact, off the report's serial end); a failure only costs the
    report the rendering."""
    from fe_impact.calibration.report import write_contact_picture

    try:
        write_contact_picture(Path(out), record)
    except (OSError, ValueError, RuntimeError) as exc:
        logger.warning("contact picture of %s not rendered: %s", record.id, exc)
