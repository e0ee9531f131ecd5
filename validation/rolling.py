"""Validation of the rolling mesh (the elastic sectors, coarse level, stage 1 of the seed set).

One command: ``python validation/rolling.py [--quick] [--reference MESH_CYCLE_JSON]
[--out DIR]``; exits 1 when a figure leaves its tolerance.

(a) Kinematics. No load, Young's modulus x 1e6, the pinion accelerated to
    1000 r/min (``sin^2`` over 1.5 mesh cycles): the face gear is driven by the
    flanks alone. With the seed set's unmodified profiles (lengthwise crowning
    only) the tooth contact analysis' unloaded TE is zero (docs: the mesh-cycle
    validation's "vanishing load", 2e-16 rad), so the TE must be zero to the
    issue's 0.01 um while the flanks push, through one- and two-pair zones.
(b) Quasi-static limit. 50 r/min, the nominal torque (1000 N at the pitch point),
    the load ramped over one cycle: the TE over the next cycle against the mesh
    cycle's superposition of a calibration (``--reference``: its
    ``mesh_cycle.json``, the cycle at the same pinion torque), within the issue's
    3% of the mean TE (skipped, said so, without a reference). ``--probe-depth``
    sets where the sectors are read below the contact (the model's default: two
    flank element sizes, at most half the tooth's thickness), for the
    sensitivity of the result to it.
(c) Energy. 1000 r/min, 50 N m, no damping: kinetic + strain + contact energy
    minus the drive's and the load's work stays at its start within 0.1% of the
    work done (the issue's tolerance).

The costs (DOFs, wall and CPU time per mesh cycle, peak memory) are reported.
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import sys
import time
from pathlib import Path

import numpy as np

#: Tolerances of the issue (set before the results were seen).
TE_KINEMATIC = 0.01e-6      # m
QUASI_STATIC = 0.03         # of the mean TE
ENERGY = 1e-3               # of the work done


def _roll(gearset, out: Path, mesh_dir: Path, check_step: bool = True, **kw):
    from fe_impact.rolling.api import RollInputs, roll

    inputs = RollInputs(stage=1, level="coarse", **kw)
    t0 = time.perf_counter()
    result = roll(gearset, inputs, out, mesh_dir=mesh_dir, check_step=check_step)
    result.info["total_wall_s"] = time.perf_counter() - t0
    return result


def kinematics(gearset, out: Path, mesh_dir: Path, quick: bool,
               probe_depth: float | None = None) -> dict:
    res = _roll(gearset, out / "kinematics", mesh_dir, probe_depth=probe_depth,
                speed_rpm=1000.0, torque_nm=0.0,
                cycles=2.0, speed_ramp_cycles=1.5, ramp_cycles=0.0, stiffen=1e6,
                steps_per_cycle=240, frames_per_cycle=4)
    # while the drive flanks push (after the push the face gear flies free across the
    # backlash, and hits the coast flanks: not a kinematic state)
    pushed = res.pair_force_n[:, :, 0].sum(axis=1) > 1.0
    two = (res.pair_force_n[pushed, :, 0] > 0).sum(axis=1).max(initial=0)
    te = float(np.abs(res.te_m[pushed]).max()) if pushed.any() else math.inf
    return {"largest_te_m": te, "steps_pushed": int(pushed.sum()), "most_pairs": int(two),
            "peak_force_n": float(res.pair_force_n.max()),
            "passed": bool(te < TE_KINEMATIC and two == 2), "cost": _cost(res)}


def quasi_static(gearset, out: Path, mesh_dir: Path, reference: Path | None,
                 quick: bool, probe_depth: float | None = None) -> dict:
    from fe_impact.gears.tca import GearPair

    pair = GearPair.from_gearset(gearset, 1)
    cos_a = math.cos(pair.pinion.pressure_angle)
    r_bp, r_b2 = pair.pinion.pitch_radius * cos_a, pair.face.pitch_radius * cos_a
    pinion_torque = 1000.0 * r_bp
    # quasi-static: the mesh-in closes at ~1 cm/s, no impact for the step to resolve
    res = _roll(gearset, out / "quasi_static", mesh_dir, check_step=False,
                probe_depth=probe_depth, speed_rpm=50.0,
                torque_nm=pinion_torque * r_b2 / r_bp, cycles=2.4, ramp_cycles=1.0,
                steps_per_cycle=120 if quick else 240, frames_per_cycle=4)
    n_cycle = res.info["inputs"]["steps_per_cycle"]
    last = slice(len(res.te_m) - int(1.2 * n_cycle), len(res.te_m))
    te = res.te_m[last]
    out_d = {"pinion_torque_nm": pinion_torque, "probe_depth_m": res.info.get("probe_depth_m"),
             "probe_depth_range_m": res.info.get("probe_depth_range_m"),
             "flank_element_m": res.info.get("flank_element_m"), "te_mean_m": float(te.mean()),
             "te_min_m": float(te.min()), "te_max_m": float(te.max()), "cost": _cost(res)}
    if reference is None:
        out_d.update(passed=None, note="no --reference mesh_cycle.json: not compared")
        return out_d
    data = json.loads(Path(reference).read_text())
    cycles = [c for c in data["cycles"] if c["stage"] == 1]
    cyc = min(cycles, key=lambda c: abs(c["torque"] - pinion_torque))
    if abs(cyc["torque"] / pinion_torque - 1.0) > 1e-3:
        out_d.update(passed=None, note=f"no reference cycle at {pinion_torque:.4g} N m")
        return out_d
    ref_te = np.asarray(cyc["transmission_error"])
    err_mean = float(te.mean() / ref_te.mean() - 1.0)
    out_d.update(reference_te_mean_m=float(ref_te.mean()),
                 reference_te_min_m=float(ref_te.min()), reference_te_max_m=float(ref_te.max()),
                 mean_error=err_mean,
                 max_error=float(te.max() / ref_te.max() - 1.0),
                 min_error=float(te.min() / ref_te.min() - 1.0),
                 passed=bool(abs(err_mean) <= QUASI_STATIC))
    return out_d


def energy(gearset, out: Path, mesh_dir: Path, quick: bool,
           probe_depth: float | None = None) -> dict:
    res = _roll(gearset, out / "energy", mesh_dir, probe_depth=probe_depth,
                speed_rpm=1000.0, torque_nm=50.0,
                cycles=1.5 if quick else 2.4, ramp_cycles=1.0, steps_per_cycle=240,
                frames_per_cycle=4)
    err = res.energy_error()
    return {"relative_error": err, "drive_work_j": float(res.energy["drive_work"][-1]),
            "peak_force_n": float(res.pair_force_n.max()),
            "events": len(res.events), "inertial_terms": res.info["inertial_terms"],
            "passed": bool(err < ENERGY), "cost": _cost(res)}


def _cost(res) -> dict:
    info = res.info
    cycles = max(info["cycles_done"], 1e-9)
    return {"dofs": info["dofs"], "steps": info["n_steps"],
            "wall_s_per_cycle": info["wall_s"] / cycles, "cpu_s_per_cycle": info["cpu_s"] / cycles,
            "total_wall_s": info.get("total_wall_s"),
            "peak_rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6}


def run(quick: bool = False, reference: Path | None = None, out: Path | None = None,
        probe_depth: float | None = None, only: str | None = None) -> dict:
    """All three checks (or ``only`` one of them); the figures and whether each passed.

    ``probe_depth`` [m]: where the sectors are read below the contact point (None:
    the model's default, two flank element sizes; 0: on the surface with the Hertz
    approach added).
    """
    from fe_impact.gears import default_gearset

    gearset = default_gearset()
    out = Path(out or "validation_rolling")
    mesh_dir = out / "mesh"
    checks = {"kinematics": lambda: kinematics(gearset, out, mesh_dir, quick, probe_depth),
              "quasi_static": lambda: quasi_static(gearset, out, mesh_dir, reference, quick,
                                                   probe_depth),
              "energy": lambda: energy(gearset, out, mesh_dir, quick, probe_depth)}
    results = {k: (f() if only in (None, k) else {"passed": None, "note": "not run"})
               for k, f in checks.items()}
    mesh = json.loads((mesh_dir / "sectors.json").read_text())
    results["mesh"] = {k: mesh[k] for k in ("n_nodes", "n_elements", "seconds", "size_m")}
    out.mkdir(parents=True, exist_ok=True)
    (out / "rolling_validation.json").write_text(json.dumps(results, indent=1, default=str))
    return results


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="shorter runs")
    p.add_argument("--reference", type=Path, help="a calibration's mesh_cycle.json for (b)")
    p.add_argument("--out", type=Path, help="output folder (validation_rolling)")
    p.add_argument("--probe-depth", type=float, metavar="MM",
                   help="depth [mm] of the sectors' reading below the contact (default: two "
                        "flank element sizes; 0: on the surface, Hertz approach added)")
    p.add_argument("--only", choices=("kinematics", "quasi_static", "energy"),
                   help="run one check only")
    args = p.parse_args(argv)
    if args.probe_depth is not None and not (args.probe_depth >= 0.0):
        p.error(f"--probe-depth {args.probe_depth}: must be a number >= 0 (mm)")
    depth = None if args.probe_depth is None else args.probe_depth * 1e-3
    results = run(args.quick, args.reference, args.out, depth, args.only)
    print(json.dumps(results, indent=1, default=str))
    failed = [k for k in ("kinematics", "quasi_static", "energy")
              if results[k]["passed"] is False]
    if failed:
        print(f"outside tolerance: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
