"""The exported Exudyn model against fe-impact's own switching model (a multibody engine
as the calibration's client).

Run ``python validation/exudyn_export.py [--out out/exudyn_export]`` (about eight
minutes on a busy two-core machine: the 5 s Exudyn run takes two, its Python
force function is called some 3x10^6 times; the rest is the step-halving study
and fe-impact's 16-run ensemble). It prints the agreement table and one
``[pass]``/``[FAIL]`` line per check, writes ``exudyn_export.md``,
``exudyn_export.json`` and ``checks.json``, and exits 1 when a check fails.

Case: the seed's stage 1 at 300 r/min with no load (drag only), 5 s, on a
calibration made of the closed-form laws of the seed set (every kind, 25
closing speeds) with a position law along the path (`calibration_file`:
made for the test, not measured). Both sides read the same file: fe-impact
through `fe_impact.switching.load_calibration`, the Exudyn script through
the data `fe-impact export --to exudyn` wrote into it.

Checks (tolerances from the issue, set before any run):

1. mesh-force history over the first `CYCLES` mesh cycles, sampled every
   1e-5 s on each side's step interpolant: largest difference within 2% of
   the largest force;
2. the whole 5 s: impact count and the peak-force statistics (mean, median,
   largest) within 5%. The issue's check; it is ill-posed for a chaotic rattle
   (below), so with the ensemble run it is reported in the table, and the largest
   force is asserted at 5% only where both runs reach it within the deterministic
   first `STUDY_TIME` s; reached later, it is checked against fe-impact's ensemble
   like the count and the mean force;
3. (added) the impacts of more than 1 N over the first `STUDY_TIME` s, where
   both sides' runs are still deterministic: as many, each peak force within
   the 2% of check 1.

Step-halving study on each side (`study`): fe-impact with its largest step
halved and its tolerances divided by 32 (a halved step for a fifth-order
method); the Exudyn script likewise, its tolerances divided by 10 (they are
1/320 of fe-impact's as exported), over the first `STUDY_TIME` s, where the
impacts are still deterministic: the side whose impacts move under the
refinement towards the other's converged values is the one at fault.

And the 5 s statistics' own spread: fe-impact run `ENSEMBLE` times with the
initial mesh position moved by 1e-11 m (1e-9 of a base pitch), far below any
tolerance. The rattle of a nearly elastic mesh is chaotic: those runs part
after about 0.5 s, and their 5 s statistics spread by much more than 5%. A
third check therefore asks whether Exudyn's 5 s statistics lie within
fe-impact's ensemble (its mean +- 2 standard deviations). And under load
(`loaded`: 2 N m, the first three mesh cycles) each side against fe-impact
converged (tolerances / 1024, largest step 0.5 us), a table without a check.

Measured: history 0.0037 N of an 8.25 N peak (0.045%, pass); the four impacts over
1 N to 0.42 s as many, peak forces within 0.95% (pass); 5 s impacts 129 (Exudyn)
against 103 (fe-impact), mean peak force 108.4 against 77.1 N, largest 323.1 against
228.3 N (reported: both reached after 0.42 s); fe-impact's ensemble 97-471 impacts
(203 +- 98), mean force 77-343 N, largest 162-890 N, its refinement variants 103-368
impacts; Exudyn's standard scores in it -0.76 (count), -0.62 (mean force) and -0.08
(largest force). Fourth impact: fe-impact 0.401193 s, 42.263 N, refined (tolerances
/ 32) 0.401220 s, 42.118 N; Exudyn 0.401259 s, 41.860 N, unchanged by step halving,
0.401222 s, 42.134 N with tolerances / 10. Under load: fe-impact at its defaults
0.41% of the peak from converged, the Exudyn export 0.78%.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import json
import logging
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from validation import checks as ck  # noqa: E402

logger = logging.getLogger(__name__)

STAGE, RPM, DURATION = 1, 300.0, 5.0
#: Mesh cycles of the history check (one cycle: a pinion tooth, 10.5 ms at 300 r/min).
CYCLES = 5
HISTORY_SAMPLE = 1e-5
HISTORY_TOL, STATISTICS_TOL = 0.02, 0.05
#: Simulated time of the Exudyn step-halving runs [s]: the first four impacts, before
#: the rattle parts runs that differ by round-off (about 0.45 s on this case).
STUDY_TIME = 0.42
#: Output load of the loaded history [N m] (the seed's largest is 1 N m).
LOAD = 2.0
ENSEMBLE = 16
#: A position law for the test (not measured): the closed form's stiffness scaled along
#: the path of contact, a softer pair at its ends.
POSITIONS = {"roll_angle_deg": [-14.0, -7.0, 0.0, 9.0, 18.0],
             "scale": [0.80, 0.95, 1.0, 0.92, 0.78],
             "exponent": [1.44, 1.47, 1.50, 1.48, 1.43]}
STATISTICS = ("impacts", "mean_force", "median_force", "max_force")


def calibration_file(path: Path, positions: bool = True) -> Path:
    """Write a calibration of the seed set from its closed-form laws (every stage and
    kind, their 25 closing speeds), with the test's position law `POSITIONS`."""
    from fe_impact.gears.gearset import default_gearset
    from fe_impact.switching import DriveModel, closed_form_laws

    gearset = default_gearset()
    model = DriveModel(gearset=gearset)
    laws = closed_form_laws(gearset, [model.effective_mass(s)
                                      for s in range(1, model.n_stages + 1)])
    cases = [{"stage": stage, "kind": kind, "face_teeth": gearset.stages[stage - 1].teeth,
              "impact_speed": float(v),
              "impact": {"k": float(k), "exponent": float(e), "cmax": float(c),
                         "d": float(d)}}
             for (stage, kind), t in sorted(laws.tables.items())
             for v, k, e, c, d in zip(t.impact_speed, t.k, t.exponent, t.cmax, t.d,
                                      strict=True)]
    doc = {"schema": "fe-impact/calibration/2", "cases": cases}
    if positions:
        doc["mesh_cycle"] = {
            str(s): {"roll_angle_deg": POSITIONS["roll_angle_deg"],
                     "k": [float(laws.table(s).k[0]) * f for f in POSITIONS["scale"]],
                     "exponent": POSITIONS["exponent"]}
            for s in range(1, model.n_stages + 1)}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(doc))
    return path


def exported_module(calibration: Path, folder: Path, duration: float = DURATION,
                    load: float = 0.0):
    """Export the stage with ``fe-impact export --to exudyn`` and import the script."""
    from fe_impact.export import export_calibration

    result = export_calibration(calibration, "exudyn", folder, stage=STAGE, speed_rpm=RPM,
                                load=load, duration=duration)
    script = next(p for p in result.files if p.suffix == ".py")
    spec = importlib.util.spec_from_file_location(f"exported_{script.stem}", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def drive_model(calibration: Path, **changes):
    """fe-impact's switching model of the seed set on ``calibration``."""
    from fe_impact.gears.gearset import default_gearset
    from fe_impact.switching import DriveModel, load_calibration

    gearset = default_gearset()
    model = DriveModel(gearset=gearset)
    masses = [model.effective_mass(s) for s in range(1, model.n_stages + 1)]
    return dataclasses.replace(model.with_laws(load_calibration(calibration, gearset, masses)),
                               **changes)


def fe_run(model, duration: float, sample_interval: float = 2e-4, load: float = 0.0):
    """fe-impact's run of the case: ``(times, forces)`` of the series, the impacts'
    ``(time, peak force)``, steps, wall time [s]."""
    from fe_impact.switching import Segment, StageSchedule, simulate

    wall = time.perf_counter()
    run = simulate(model, StageSchedule((Segment(duration, STAGE, RPM, load),)),
                   sample_interval=sample_interval)
    s = run.series
    return {"time": s["time_s"], "force": s["impact_force_N"],
            "impacts": np.column_stack([run.events.time, run.events.force]),
            "steps": run.info["steps"], "wall_s": time.perf_counter() - wall}


def exudyn_run(module, duration: float, sample_interval: float = 2e-4, **settings):
    """The exported model's run, in `fe_run`'s layout."""
    wall = time.perf_counter()
    rec = module.simulate(module.DATA, duration, sample_interval=sample_interval, **settings)
    series = np.array(rec.series)
    return {"time": series[:, 0], "force": series[:, 1],
            "impacts": np.array([[i["time"], i["force"]] for i in rec.impacts]).reshape(-1, 2),
            "steps": rec.info["steps"], "wall_s": time.perf_counter() - wall}


def statistics(run: dict) -> dict:
    """Impact count and peak-force statistics [N]."""
    f = run["impacts"][:, 1]
    if f.size == 0:
        return dict.fromkeys(STATISTICS, 0.0)
    return {"impacts": float(f.size), "mean_force": float(f.mean()),
            "median_force": float(np.median(f)), "max_force": float(f.max()),
            "max_force_time": float(run["impacts"][int(np.argmax(f)), 0])}


def history(fe: dict, ex: dict, cycles: int = CYCLES) -> dict:
    """Largest force difference over the first ``cycles`` mesh cycles, and the peak."""
    period = 60.0 / (RPM * 19)
    n = min(fe["time"].size, ex["time"].size)
    if not np.allclose(fe["time"][:n], ex["time"][:n], rtol=0.0, atol=1e-9):
        raise AssertionError("the two series are not sampled at the same times")
    keep = fe["time"][:n] <= cycles * period
    a, b = fe["force"][:n][keep], ex["force"][:n][keep]
    peak = float(np.abs(a).max())
    return {"cycles": cycles, "duration_s": cycles * period, "peak_N": peak,
            "max_difference_N": float(np.abs(a - b).max()),
            "relative": float(np.abs(a - b).max() / peak)}


def loaded(calibration: Path, folder: Path, load: float = LOAD, cycles: int = 3) -> dict:
    """The first ``cycles`` mesh cycles under ``load`` [N m]: each side at its own
    settings against fe-impact converged (tolerances / 1024, largest step 0.5 us):
    largest force difference over the peak."""
    duration = cycles * 60.0 / (RPM * 19)
    module = exported_module(calibration, folder, duration, load)
    base = drive_model(calibration)
    tight = drive_model(calibration, rtol=base.rtol / 1024, length_tol=base.length_tol / 1024,
                        speed_tol=base.speed_tol / 1024, max_step=5e-7)
    ref = fe_run(tight, duration, HISTORY_SAMPLE, load)
    sides = {"fe-impact": fe_run(base, duration, HISTORY_SAMPLE, load),
             "exudyn": exudyn_run(module, duration, HISTORY_SAMPLE)}
    out = {"load_Nm": load, "cycles": cycles, "peak_N": float(np.abs(ref["force"]).max())}
    for name, side in sides.items():
        out[f"{name} against converged"] = history(ref, side, cycles)["relative"]
    out["exudyn against fe-impact"] = history(sides["fe-impact"], sides["exudyn"],
                                              cycles)["relative"]
    return out


def study(calibration: Path, module) -> dict:
    """Step halving and smaller tolerances on each side (fe-impact's / 32, Exudyn's / 10:
    the export's are already 1/320 of fe-impact's): the first impacts, and fe-impact's
    5 s statistics."""
    base = drive_model(calibration)
    h = module.DATA["tolerances"]["max_step"]
    fine = {"rtol": base.rtol / 32, "length_tol": base.length_tol / 32,
            "speed_tol": base.speed_tol / 32}
    fe_variants = {"as run": {}, "largest step / 2": {"max_step": h / 2},
                   "tolerances / 32": fine, "both": {**fine, "max_step": h / 2}}
    a, r = module.tolerances(module.DATA)
    ex_variants = {"as run": {}, "largest step / 2": {"max_step": h / 2},
                   "tolerances / 10": {"atol": a / 10, "rtol": r / 10},
                   "both": {"atol": a / 10, "rtol": r / 10, "max_step": h / 2}}
    out = {"fe-impact": {}, "exudyn": {}}
    for name, change in fe_variants.items():
        model = dataclasses.replace(base, **change)
        early = fe_run(model, STUDY_TIME)
        whole = fe_run(model, DURATION)
        out["fe-impact"][name] = {"first_impacts": early["impacts"].tolist(),
                                  "statistics": statistics(whole), "steps": whole["steps"]}
    for name, change in ex_variants.items():
        early = exudyn_run(module, STUDY_TIME, **change)
        out["exudyn"][name] = {"first_impacts": early["impacts"].tolist(),
                               "steps": early["steps"]}
    return out


def ensemble(calibration: Path, size: int = ENSEMBLE, duration: float = DURATION) -> dict:
    """fe-impact's statistics over ``duration`` [s] with the initial mesh position moved
    by 1e-9 of a base pitch per member (the members part after about 0.5 s)."""
    base = drive_model(calibration)
    rows = [statistics(fe_run(dataclasses.replace(base, mesh_phase=base.mesh_phase
                                                  + 1e-9 * i), duration))
            for i in range(size)]
    table = {k: np.array([r[k] for r in rows]) for k in STATISTICS}
    return {"size": size, "members": rows,
            "mean": {k: float(v.mean()) for k, v in table.items()},
            "std": {k: float(v.std(ddof=1)) for k, v in table.items()},
            "min": {k: float(v.min()) for k, v in table.items()},
            "max": {k: float(v.max()) for k, v in table.items()}}


def run(out: Path | None = None, duration: float = DURATION, ensemble_size: int = ENSEMBLE,
        with_study: bool = True) -> dict:
    """The comparison: history, 5 s statistics, step-halving study, ensemble."""
    logging.getLogger("fe_impact").setLevel(logging.ERROR)
    folder = Path(tempfile.mkdtemp(prefix="exudyn_export-")) if out is None else out
    calibration = calibration_file(folder / "calibration.json")
    module = exported_module(calibration, folder / "exudyn", duration)
    model = drive_model(calibration)
    period = 60.0 / (RPM * 19)
    fe_h = fe_run(model, CYCLES * period, HISTORY_SAMPLE)
    ex_h = exudyn_run(module, CYCLES * period, HISTORY_SAMPLE)
    fe, ex = fe_run(model, duration), exudyn_run(module, duration)
    record = {"case": f"stage {STAGE}, {RPM:g} r/min, no load, {duration:g} s",
              "history": history(fe_h, ex_h),
              "fe-impact": {**statistics(fe), "steps": fe["steps"], "wall_s": fe["wall_s"]},
              "exudyn": {**statistics(ex), "steps": ex["steps"], "wall_s": ex["wall_s"]},
              "first_impacts": {"fe-impact": fe["impacts"][:6].tolist(),
                                "exudyn": ex["impacts"][:6].tolist()}}
    if with_study:
        record["study"] = study(calibration, module)
        record["loaded"] = loaded(calibration, folder / "exudyn_loaded")
    if ensemble_size > 1:
        record["ensemble"] = ensemble(calibration, ensemble_size, duration)
    return record


def first_impacts(fe: list, ex: list) -> dict:
    """The impacts of the deterministic window on both sides: whether they are as many,
    and the largest relative difference of their peak forces (None if not as many)."""
    fe, ex = np.asarray(fe).reshape(-1, 2), np.asarray(ex).reshape(-1, 2)
    # the mesh-in touches of a few 0.01-0.2 N while the flank carries the rattle impact
    # are left out: their peaks are the crossing of a second pair, not an impact force
    big = [f[f[:, 1] > 1.0] for f in (fe, ex)]
    same = big[0].shape == big[1].shape
    worst = float(np.max(np.abs(big[1][:, 1] / big[0][:, 1] - 1.0))) if same else None
    return {"impacts": int(big[0].shape[0]), "exudyn_impacts": int(big[1].shape[0]),
            "largest_force_difference": worst,
            "largest_time_difference_s": (float(np.max(np.abs(big[1][:, 0] - big[0][:, 0])))
                                          if same else None)}


def check(record: dict) -> list[ck.Check]:
    """The issue's two checks, the first impacts, and Exudyn within fe-impact's 5 s
    ensemble."""
    h = record["history"]
    out = [ck.at_most(f"mesh force over the first {h['cycles']} mesh cycles, largest "
                      "difference / peak", h["relative"], HISTORY_TOL)]
    if "study" in record:
        first = first_impacts(record["study"]["fe-impact"]["as run"]["first_impacts"],
                              record["study"]["exudyn"]["as run"]["first_impacts"])
        worst = first["largest_force_difference"]
        out.append(ck.holds(f"the impacts over 1 N to {STUDY_TIME} s (deterministic): as many, "
                            "largest peak-force difference", math.inf if worst is None
                            else worst, worst is not None and worst <= HISTORY_TOL,
                            f"same count, <= {HISTORY_TOL:g}"))
    fe, ex = record["fe-impact"], record["exudyn"]
    ens = record.get("ensemble")
    if ens is None:
        # Without the ensemble only the single-trajectory comparison is at hand.
        out += [ck.within(f"5 s {k.replace('_', ' ')}: Exudyn against fe-impact", ex[k], fe[k],
                          STATISTICS_TOL) for k in STATISTICS]
    else:
        # Two runs of a chaotic rattle that part after ~0.45 s are two samples of one
        # distribution: fe-impact's own runs with the start moved by 1e-11 m spread by far
        # more than 5% (report()'s ensemble table). The single-trajectory 5% comparison is
        # then reported, not asserted; the 5 s statistics are checked against that spread.
        # The largest force stays at 5% where both runs reach it within the deterministic
        # first STUDY_TIME s; reached later, it is one more statistic of the chaos.
        late = max(fe.get("max_force_time", math.inf),
                   ex.get("max_force_time", math.inf)) > STUDY_TIME
        if not late:
            out.append(ck.within("5 s largest force: Exudyn against fe-impact",
                                 ex["max_force"], fe["max_force"], STATISTICS_TOL))
        for k in ("impacts", "mean_force", *(("max_force",) if late else ())):
            diff, std = ex[k] - ens["mean"][k], ens["std"][k]
            z = diff / std if std > 0.0 else (0.0 if diff == 0.0 else math.inf)
            out.append(ck.holds(f"5 s {k.replace('_', ' ')}: Exudyn in fe-impact's ensemble "
                                f"of {ens['size']} (standard score)", z, abs(z) <= 2.0,
                                "|z| <= 2"))
    return out


def report(record: dict) -> str:
    """The agreement table in Markdown."""
    h, fe, ex = record["history"], record["fe-impact"], record["exudyn"]
    lines = [f"# Exudyn export against fe-impact ({record['case']})", "",
             f"Mesh force over the first {h['cycles']} mesh cycles ({h['duration_s']:.4f} s): "
             f"largest difference {h['max_difference_N']:.4g} N of a {h['peak_N']:.4g} N peak "
             f"({100 * h['relative']:.3g}%, tolerance {100 * HISTORY_TOL:g}%).", "",
             "| 5 s | fe-impact | Exudyn | difference | tolerance |", "|---|---|---|---|---|"]
    for k in STATISTICS:
        d = ex[k] / fe[k] - 1.0 if fe[k] else math.nan
        lines.append(f"| {k} | {fe[k]:.4g} | {ex[k]:.4g} | {100 * d:+.1f}% | "
                     f"{100 * STATISTICS_TOL:g}% |")
    lines.append(f"| steps | {fe['steps']} | {ex['steps']} | | |")
    lines.append(f"| wall time (s) | {fe['wall_s']:.1f} | {ex['wall_s']:.1f} | | |")
    if "study" in record:
        lines += ["", f"## Step-halving study: the first impacts (to {STUDY_TIME} s), time (s) "
                      "and peak force (N)", "", "| side | variant | impacts |", "|---|---|---|"]
        for side, variants in record["study"].items():
            for name, v in variants.items():
                hits = ", ".join(f"{t:.6f} s {f:.3f} N" for t, f in v["first_impacts"])
                lines.append(f"| {side} | {name} | {hits} |")
        lines += ["", "fe-impact's own 5 s statistics under the same refinements:", "",
                  "| variant | " + " | ".join(STATISTICS) + " |",
                  "|---|" + "---|" * len(STATISTICS)]
        for name, v in record["study"]["fe-impact"].items():
            lines.append(f"| {name} | " + " | ".join(f"{v['statistics'][k]:.4g}"
                                                     for k in STATISTICS) + " |")
    if "loaded" in record:
        ld = record["loaded"]
        lines += ["", f"## Under load: {ld['load_Nm']:g} N m, the first {ld['cycles']} mesh "
                      f"cycles (peak {ld['peak_N']:.4g} N)", "",
                  "Largest force difference over the peak; converged: fe-impact with its "
                  "tolerances / 1024 and a largest step of 0.5 us.", "",
                  "| comparison | difference / peak |", "|---|---|"]
        lines += [f"| {k} | {100 * ld[k]:.2f}% |" for k in ld
                  if k not in ("load_Nm", "cycles", "peak_N")]
    if "ensemble" in record:
        ens = record["ensemble"]
        lines += ["", f"## fe-impact ensemble: {ens['size']} runs, initial mesh position "
                      "moved by 1e-11 m each", "",
                  "| statistic | mean | std | min | max | Exudyn |", "|---|---|---|---|---|---|"]
        for k in STATISTICS:
            lines.append(f"| {k} | {ens['mean'][k]:.4g} | {ens['std'][k]:.3g} | "
                         f"{ens['min'][k]:.4g} | {ens['max'][k]:.4g} | {ex[k]:.4g} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/exudyn_export"))
    p.add_argument("--ensemble", type=int, default=ENSEMBLE,
                   help=f"fe-impact runs of the 5 s ensemble (default {ENSEMBLE}; 0: none)")
    p.add_argument("--no-study", action="store_true", help="leave out the step-halving study")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    record = run(args.out, ensemble_size=args.ensemble, with_study=not args.no_study)
    checks = check(record)
    text = report(record) + "\n## Checks\n\n" + ck.markdown(checks)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "exudyn_export.md").write_text(text)
    (args.out / "exudyn_export.json").write_text(json.dumps(record, indent=1) + "\n")
    print(text)
    return ck.finish("exudyn_export", checks, args.out)


if __name__ == "__main__":
    sys.exit(main())
