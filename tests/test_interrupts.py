"""SIGINT and SIGTERM stop ``solve`` and ``calibrate`` cleanly (subprocesses).

The signal goes to the whole process group, as Ctrl-C in a terminal does. A stopped
run prints one line, exits with 128 + the signal, writes its summary.json with
``status: "stopped"``, leaves no temporary file and no worker process, and a rerun
finishes the job (and removes what an earlier killed run left behind).
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fe_impact.calibration.sweep import STOP_GRACE
from fe_impact.cli.main import main
from fe_impact.output.files import is_temporary
from tests.test_bad_inputs import sdof
from tests.test_calibrate_e2e import frictionless_gearset

ROOT = Path(__file__).resolve().parents[1]
SIGNALS = [signal.SIGINT, signal.SIGTERM]


def start(argv: list[str]) -> subprocess.Popen:
    """``fe-impact ARGV`` in a process group of its own."""
    code = "import sys; from fe_impact.cli import main; sys.exit(main())"
    return subprocess.Popen([sys.executable, "-c", code, *map(str, argv)], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def wait_for(condition, proc: subprocess.Popen, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.2)


def stop(proc: subprocess.Popen, sig: int, timeout: float) -> tuple[int, str, float]:
    """Signal the process group; the exit status, stderr and the seconds it took."""
    t0 = time.monotonic()
    os.killpg(proc.pid, sig)
    _, err = proc.communicate(timeout=timeout)
    return proc.returncode, err, time.monotonic() - t0


def group_gone(pgid: int, timeout: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.2)
    return False


def messages(stderr: str) -> list[str]:
    """The lines of stderr but progress bars (tqdm redraws with \\r) and warnings."""
    lines = [part.strip() for line in stderr.split("\n") for part in line.split("\r")]
    return [line for line in lines if line and "%|" not in line
            and not line.startswith("WARNING")]


def strict(path: Path):
    """Parse as a strict reader (JavaScript's JSON.parse) does: no NaN or Infinity."""
    def refuse(name):
        raise ValueError(f"{path}: non-standard JSON constant {name}")
    return json.loads(path.read_text(), parse_constant=refuse)


def leftovers(*folders: Path) -> list[Path]:
    return [p for f in folders if f.exists() for p in f.rglob("*") if is_temporary(p)]


def check_stopped(rc: int, err: str, sig: int, resumes: bool) -> None:
    # calibrate resumes its finished cases; solve keeps its frames and starts again
    assert rc == 128 + sig, err
    assert "Traceback" not in err, err
    name = signal.Signals(sig).name
    left = ("finished results are kept, rerun to continue" if resumes else
            "what was written is kept, marked stopped; a rerun starts again")
    assert messages(err) == [f"fe-impact: interrupted ({name}); {left}"], err


@pytest.mark.slow
@pytest.mark.parametrize("sig", SIGNALS, ids=lambda s: signal.Signals(s).name)
def test_solve_stops_cleanly_and_reruns(tmp_path, sig):
    # The two-block SDOF over 20,000 Newmark steps (10 s or so), a frame every 200.
    case = tmp_path / "long.toml"
    case.write_text(sdof(time_step=1e-8, duration=2e-4, extra="output_interval = 2e-6"))
    out = tmp_path / "out"
    proc = start(["solve", case, "--out", out])
    wait_for(lambda: len(list(out.glob("frame_*.vtu"))) >= 3, proc, 120)
    rc, err, seconds = stop(proc, sig, 60)
    check_stopped(rc, err, sig, resumes=False)
    assert seconds < 10 and group_gone(proc.pid)
    summary = strict(out / "summary.json")
    assert summary["status"] == "stopped"
    assert summary["error"] == f"interrupted ({signal.Signals(sig).name})"
    frames = summary["fields"]["frames"]
    assert 3 <= len(frames) < 101 and all((out / f).is_file() for f in frames)
    assert (out / "impact.pvd").read_text().count("<DataSet") >= len(frames) - 1
    assert leftovers(out) == []
    # A rerun (solve has nothing to resume from) runs to the end over the stopped files.
    assert main(["solve", str(case), "--out", str(out)]) == 0
    summary = strict(out / "summary.json")
    assert summary["status"] == "completed" and len(summary["fields"]["frames"]) == 101
    assert leftovers(out) == []


@pytest.mark.slow
def test_calibrate_stops_cleanly_and_resumes(tmp_path):
    """SIGINT, then SIGTERM, while the FE impact writes its frames; then a rerun that
    finishes on the cached mesh and removes a leftover of a killed run."""
    out, cache = tmp_path / "out", tmp_path / "cache"
    # frictionless flanks: the subject is the stop and the resume, not friction (whose
    # calibration adds a frictionless companion case and four times the CPU)
    argv = ["calibrate", frictionless_gearset(tmp_path), "--no-switching", "--out", out,
            "--cache", cache, "--stages", "1", "--speeds", "300", "--no-mesh-cycle",
            "--level", "coarse", "--workers", "1"]
    case_id = "stage1_mesh_300rpm"
    fe = out / "cases" / case_id / "fe"
    out.mkdir()
    (out / "calibration.json").write_text("{}")    # an earlier run's: a stop keeps it
    for sig in SIGNALS:
        proc = start(argv)
        wait_for(lambda: len(list(fe.glob("frame_*.vtu"))) >= 3, proc, 600)
        rc, err, seconds = stop(proc, sig, 120)
        check_stopped(rc, err, sig, resumes=True)
        # The case stops within STOP_POLL plus one step; closing the cluster takes a few s.
        assert seconds < STOP_GRACE, seconds
        assert group_gone(proc.pid), "a worker outlived the stopped run"
        assert leftovers(out, cache) == []
        summary = strict(out / "summary.json")
        assert summary["status"] == "stopped" and summary["missing"] == [case_id]
        assert summary["finished"] == [] and summary["calibration"] is None
        assert (out / "calibration.json").read_text() == "{}"
        for stale in fe.glob("frame_*.vtu"):    # the next run must write frames afresh
            stale.unlink()
    mesh = next(cache.glob("meshes/*/pair.msh"))
    meshed = mesh.stat().st_mtime_ns
    (fe / ".frame_0003-abcd1234.vtu").write_bytes(b"half a frame of a killed run")
    proc = start(argv)
    _, err = proc.communicate(timeout=900)
    assert proc.returncode == 0, err
    assert "Traceback" not in err and "8787" not in err
    summary = strict(out / "summary.json")
    assert summary["status"] == "completed" and summary["missing"] == []
    assert summary["finished"] == [case_id] and summary["calibration"] == "calibration.json"
    calibration = strict(out / "calibration.json")
    assert [c["id"] for c in calibration["cases"]] == [case_id]
    assert mesh.stat().st_mtime_ns == meshed          # resumed on the cached mesh
    assert leftovers(out, cache) == []
    assert (out / "cases" / case_id / "result.json").is_file()
    # Every JSON file written is standard JSON; a non-finite number is null.
    for path in [*out.rglob("*.json"), *cache.rglob("*.json")]:
        strict(path)
    record = calibration["cases"][0]
    assert math.isfinite(record["impact"]["k"]) and record["fe"]["peak_force"] > 0


GMSH_THEN_SIGTERM = """
import os, signal, sys, time
from fe_impact.interrupts import Interrupted, handle_signals
from fe_impact.meshing.session import gmsh_session
with handle_signals():
    with gmsh_session("t"):
        pass
    try:
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5)
    except Interrupted as exc:
        print("handled", exc.name)
signal.signal(signal.SIGTERM, signal.SIG_IGN)     # as in a calibration worker
with gmsh_session("t"):
    pass
os.kill(os.getpid(), signal.SIGTERM)
time.sleep(0.2)
print("ignored")
"""


def test_a_gmsh_session_keeps_the_signal_handlers():
    """gmsh.initialize sets SIGTERM to its default at the C level: a SIGTERM then killed
    the process outright (no summary, temporary files left), and a worker that ignores
    it. Both dispositions must survive a session."""
    done = subprocess.run([sys.executable, "-c", GMSH_THEN_SIGTERM], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, (done.returncode, done.stderr)
    assert done.stdout.split() == ["handled", "SIGTERM", "ignored"]


def test_a_worker_drops_only_unretrieved_timeouts_from_asyncio(caplog):
    # In a worker (no handler on its asyncio logger) Python's last-resort handler
    # printed Dask's unretrieved internal TimeoutError into the terminal during a
    # clean stop. The case runner filters that one record; other asyncio errors
    # must still be logged.
    import asyncio
    import gc
    import logging

    from fe_impact.calibration import cluster

    def unretrieved(exc: BaseException) -> None:
        loop = asyncio.new_event_loop()
        future = loop.create_future()
        future.set_exception(exc)
        del future
        gc.collect()
        loop.close()

    log = logging.getLogger("asyncio")
    before = list(log.filters)
    try:
        cluster.quiet_asyncio()
        cluster.quiet_asyncio()                      # once, however often a worker runs cases
        assert len(log.filters) == len(before) + 1
        with caplog.at_level(logging.ERROR, logger="asyncio"):
            unretrieved(TimeoutError("Timeout"))
            assert not caplog.records
            unretrieved(ValueError("a real error"))
        assert [r.exc_info[1].args for r in caplog.records] == [("a real error",)]
    finally:
        log.filters[:] = before
