"""``fe-impact calibrate --scheduler ADDRESS`` runs its cases on a separately started cluster."""

from __future__ import annotations

import json
import logging

import pytest

from fe_impact.cli.main import main

ARGV = ["calibrate", "--no-switching", "--stages", "1", "--speeds", "100", "--level", "coarse",
        "--no-mesh-cycle"]


def _cases(folder) -> dict:
    doc = json.loads((folder / "calibration.json").read_text())
    return {c["id"]: c for c in doc["cases"]}


@pytest.mark.slow
def test_calibrate_on_an_external_scheduler_matches_a_local_run(tmp_path):
    """One coarse case on a scheduler and worker started here (as a user would start
    them on another machine), then the same case on the command's own local cluster
    with the mesh from the shared cache. Both run the same deterministic FE impact
    (one thread per worker, same mesh, same time steps) and the same fit: the
    results must agree to rounding (1e-12)."""
    from dask.distributed import LocalCluster

    cache = str(tmp_path / "cache")
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=None, silence_logs=logging.ERROR) as cluster:
        remote = tmp_path / "remote"
        argv = [*ARGV, "--scheduler", cluster.scheduler_address, "--out", str(remote),
                "--cache", cache]
        assert main(argv) == 0
        # the case was a task of this scheduler (keys "fe-impact-<case>-<hash>")
        assert any(name.startswith("fe-impact") for name in cluster.scheduler.task_prefixes)
    local = tmp_path / "local"
    assert main([*ARGV, "--workers", "1", "--out", str(local), "--cache", cache]) == 0
    remote_cases, local_cases = _cases(remote), _cases(local)
    assert list(remote_cases) == list(local_cases) and len(remote_cases) == 1
    for case_id, theirs in remote_cases.items():
        ours, theirs = _leaves(local_cases[case_id]), _leaves(theirs)
        assert ours.keys() == theirs.keys()
        assert "fe.peak_force" in ours and "fe.restitution" in ours
        for key, value in ours.items():
            if isinstance(value, float):
                assert theirs[key] == pytest.approx(value, rel=1e-12, abs=1e-300), key
            else:
                assert theirs[key] == value, key


#: Keys of wall-clock times in a case record: they differ from run to run.
WALL_TIMES = ("timings_s", "wall_time", "wall_time_s", "seconds")


def _leaves(record, prefix: str = "") -> dict:
    """Every value of a JSON record by its dotted path, without the wall times."""
    if isinstance(record, dict):
        out = {}
        for key, value in record.items():
            if key not in WALL_TIMES:
                out.update(_leaves(value, f"{prefix}{key}."))
        return out
    if isinstance(record, list):
        out = {}
        for i, value in enumerate(record):
            out.update(_leaves(value, f"{prefix}{i}."))
        return out
    return {prefix[:-1]: record}


def test_local_workers_compile_into_caches_of_their_own(tmp_path):
    """Two local workers must not share a numba cache folder (two processes compiling
    one cached kernel into one folder can crash a later load: numba#4807); each
    gets ``<cache>/numba/w<name>``, stable across runs."""
    import os

    from fe_impact.calibration.cluster import local_cluster

    cluster, client = local_cluster(2, tmp_path / "numba")
    try:
        dirs = client.run(lambda: os.environ.get("NUMBA_CACHE_DIR"))
    finally:
        client.close()
        cluster.close()
    assert sorted(dirs.values()) == [str(tmp_path / "numba" / "w0"),
                                     str(tmp_path / "numba" / "w1")]


def test_a_single_local_worker_may_use_all_the_memory():
    """``--workers 1`` gets the machine's memory, two workers half each: Dask's default
    gave every worker memory / cores, so one worker on two cores was restarted at
    half the machine (a stage-3 approach corner needs more)."""
    from distributed.system import MEMORY_LIMIT

    from fe_impact.calibration.cluster import local_cluster

    for n in (1, 2):
        cluster, client = local_cluster(n)
        try:
            limits = client.run(lambda dask_worker: dask_worker.memory_manager.memory_limit)
        finally:
            client.close()
            cluster.close()
        assert sorted(limits.values()) == [MEMORY_LIMIT // n] * n


def test_runs_at_the_same_time_take_numba_slots_of_their_own(tmp_path, monkeypatch):
    # The kernels live in the user's cache, one slot per running calibration: a
    # second run while the first holds slot0 gets slot1, a later run slot0 again.
    from fe_impact.calibration.sweep import numba_folder

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "user"))
    root = tmp_path / "user" / "fe-impact" / "numba"
    with numba_folder(tmp_path / "cache") as first:
        with numba_folder(tmp_path / "cache") as second:
            assert (first, second) == (root / "slot0", root / "slot1")
    with numba_folder(tmp_path / "cache") as later:
        assert later == root / "slot0"


def test_the_sweep_hands_out_impacts_stage_by_stage_then_positions():
    # Largest first (the slowest impact of each stage, stage 3's bigger face gear
    # first), the stages in turn so that two workers start on different stages'
    # solids; the quasi-static positions after every impact.
    from fe_impact.calibration.execution import sweep_order
    from fe_impact.calibration.meshcycle import PositionCase, plan_positions
    from fe_impact.calibration.planning import plan_cases
    from fe_impact.gears import default_gearset

    gs = default_gearset()
    order = sweep_order(plan_positions(gs, positions=3) + plan_cases(gs))
    impacts = [c for c in order if not isinstance(c, PositionCase)]
    assert [c.stage for c in impacts] == [3, 2, 1] * 3
    assert [c.speed_rpm for c in impacts] == [100.0] * 3 + [300.0] * 3 + [1000.0] * 3
    assert all(isinstance(c, PositionCase) for c in order[len(impacts):])
    assert order[len(impacts)].stage == 3
    # corner positions (--corners), the longest cases, before everything
    from fe_impact.calibration.meshcycle import plan_corner_positions

    corners = plan_corner_positions(gs)
    order = sweep_order(plan_positions(gs, positions=3) + plan_cases(gs) + corners)
    assert [c.contact for c in order[:6]] == ["corner-approach"] * 3 + ["corner-recess"] * 3
    assert not any(getattr(c, "contact", "flank") != "flank" for c in order[6:])


def test_checking_a_scheduler_address_keeps_the_distributed_loggers_level():
    # Importing distributed sets its logger to INFO; the CLI sets WARNING before it
    # checks --scheduler, and the run's workers would print at INFO if the check
    # let the import reset it. A fresh interpreter: this one may have imported it.
    import subprocess
    import sys

    code = ("import logging; logging.getLogger('distributed').setLevel(logging.WARNING); "
            "from fe_impact.calibration.sweep import check_scheduler_address; "
            "check_scheduler_address('tcp://127.0.0.1:8786'); "
            "print(logging.getLogger('distributed').level)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120)
    assert out.stdout.strip() == str(logging.WARNING)
