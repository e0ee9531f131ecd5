"""Benchmark: the calibration sweep on one and on two workers, and on an external scheduler.

The sweep's cases are independent, so two workers on two cores should take
little more than half the time of one: the target is at most 0.6 of the
one-worker wall time (0.5 ideal, plus the unequal case sizes' tail and the
cluster's start). The same cases on an external Dask scheduler with two
workers (started here as a user would start them on another machine) must
give the same results as the local cluster to rounding (1e-12): every case
is a deterministic single-threaded FE run on the same mesh.

Runs ``fe-impact calibrate`` on stage 1 at three speeds, coarse meshes, plus
three mesh-cycle positions (``--quick``: two speeds and two positions;
``--main-job``: the sweep of ``fe-impact calibrate --level coarse``, its 9
impacts and 27 positions, against which the start, the planning and the
report, the same few seconds as for six cases, are a small part; about ten
minutes), each
time from an empty output folder, with one shared mesh cache built by a
first untimed run so that every timed run does the same FE work. Prints the
wall times, writes ``out/bench_sweep/bench_sweep.json`` and exits 1 when the
ratio or the agreement is missed.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import shutil
import sys
import time
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.output.files import write_json
from validation import checks as ck

#: Two workers over one: see the module docstring.
TWO_OVER_ONE = 0.6
#: External scheduler against the local cluster: deterministic runs, rounding only.
AGREEMENT = 1e-12
#: Keys of wall-clock times in the records: they differ from run to run.
WALL_TIMES = ("timings_s", "wall_time", "wall_time_s", "seconds", "total")


def _argv(quick: bool, main_job: bool = False) -> list[str]:
    # --no-switching: the switching studies that a calibration ends with are one
    # job per condition set after the sweep (on stage 1, table1 alone: a serial
    # 10 s tail on either cluster), not part of the sweep measured here
    if main_job:
        return ["calibrate", "--level", "coarse", "--no-switching"]
    speeds = "100,1000" if quick else "100,300,1000"
    return ["calibrate", "--stages", "1", "--speeds", speeds, "--level", "coarse",
            "--positions", "2" if quick else "3", "--no-switching"]


def _leaves(record, prefix: str = "") -> dict:
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


def _largest_difference(a: Path, b: Path) -> float:
    """Largest relative difference of any number in two calibration.json files."""
    la = _leaves(json.loads((a / "calibration.json").read_text()))
    lb = _leaves(json.loads((b / "calibration.json").read_text()))
    if la.keys() != lb.keys():
        return float("inf")
    worst = 0.0
    for key, x in la.items():
        y = lb[key]
        if isinstance(x, float) and isinstance(y, float):
            if not (math.isfinite(x) and math.isfinite(y)):   # max() would drop a NaN
                if not x == y:
                    return float("inf")
                continue
            worst = max(worst, abs(x - y) / max(abs(x), abs(y), 1e-300))
        elif x != y and not key.endswith(("version", "settings.cache")):
            return float("inf")
    return worst


def _timed(argv: list[str]) -> float:
    from fe_impact.cli.main import main

    t = time.perf_counter()
    if main(argv) != 0:
        raise SystemExit(f"fe-impact {' '.join(argv)} failed")
    return time.perf_counter() - t


def run(quick: bool = False, out: str | Path = "out/bench_sweep",
        main_job: bool = False) -> dict:
    from dask.distributed import LocalCluster

    out = Path(out)
    shutil.rmtree(out, ignore_errors=True)
    cache = out / "cache"
    base = _argv(quick, main_job)
    # Untimed: build the meshes once, so every timed run does the same work.
    _timed([*base, "--workers", "2", "--out", str(out / "warm"), "--cache", str(cache)])
    one = _timed([*base, "--workers", "1", "--out", str(out / "one"), "--cache", str(cache)])
    two = _timed([*base, "--workers", "2", "--out", str(out / "two"), "--cache", str(cache)])
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None, silence_logs=logging.ERROR) as cluster:
        external = _timed([*base, "--scheduler", cluster.scheduler_address,
                           "--out", str(out / "external"), "--cache", str(cache)])
    record = {"argv": base, "wall_s": {"one_worker": one, "two_workers": two,
                                       "external_two_workers": external},
              "two_over_one": two / one,
              "external_vs_local_max_rel_diff": _largest_difference(out / "two",
                                                                    out / "external")}
    write_json(out / "bench_sweep.json", record)
    print(f"sweep {' '.join(base[1:])}: one worker {one:.1f} s, two {two:.1f} s "
          f"({two / one:.2f}), external scheduler with two workers {external:.1f} s")
    return record


def check(result: dict) -> list[ck.Check]:
    return [ck.at_most("two workers / one worker (wall)", result["two_over_one"], TWO_OVER_ONE),
            ck.at_most("external scheduler vs local cluster (largest relative difference)",
                       result["external_vs_local_max_rel_diff"], AGREEMENT)]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="two speeds and two positions")
    p.add_argument("--main-job", action="store_true",
                   help="the sweep of `fe-impact calibrate --level coarse` (36 cases; about "
                        "ten minutes)")
    p.add_argument("--out", default="out/bench_sweep")
    args = p.parse_args(argv)
    if args.quick and args.main_job:
        p.error("--quick and --main-job: choose one")
    result = run(args.quick, args.out, args.main_job)
    return ck.finish("bench_sweep", check(result), Path(args.out))


if __name__ == "__main__":
    raise SystemExit(main())
