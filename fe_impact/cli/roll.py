"""``fe-impact roll``: the tooth sectors turning through mesh at speed (transient FE).

A thin layer over :func:`fe_impact.rolling.api.roll`: it reads the gear set, draws a
progress bar and turns Ctrl-C into a clean stop (the steps done are written, the
summary marked ``complete: false``).
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path

_DESCRIPTION = (
    "Transient FE of a pinion sector and a face-gear sector (5 teeth each) turning "
    "through mesh: each sector elastic in a frame turning with its rotor (the gear set's "
    "inertias), the pinion at a constant speed, the face gear under a load torque, the "
    "contact at the exact flanks and rounded tip edges with the gear set's backlash. "
    "Writes the transmission error on the line of action, each pair's force and contact "
    "point, the contact events (mesh-in, rattle; closing speed, peak force, where), the "
    "energy balance (JSON/CSV), PNG plots and a PVD series of the turning sectors with "
    "von Mises stress to --out."
)


def register(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``roll`` subcommand to ``subparsers``; returns its parser."""
    p = subparsers.add_parser("roll", description=_DESCRIPTION,
                              help="transient FE of the tooth sectors turning through mesh")
    p.add_argument("gearset", nargs="?", type=Path,
                   help="gear-set TOML (default: the built-in seed set)")
    p.add_argument("--stage", type=int, default=1, metavar="N", help="face-gear stage (1)")
    p.add_argument("--speed", type=float, required=True, metavar="RPM",
                   help="pinion speed [r/min]")
    p.add_argument("--torque", type=float, default=0.0, metavar="NM",
                   help="load torque on the face gear [N m] (0)")
    p.add_argument("--cycles", type=float, default=2.0, metavar="K",
                   help="mesh cycles to simulate (2; the sectors hold about 2.4)")
    p.add_argument("--level", default="coarse", help="mesh level (coarse)")
    p.add_argument("--steps-per-cycle", type=int, default=240, metavar="N",
                   help="time steps per mesh cycle (240)")
    p.add_argument("--ramp-cycles", type=float, default=1.0, metavar="K",
                   help="the load torque rises as sin^2 over these cycles (1)")
    p.add_argument("--te-amplitude", type=float, default=0.0, metavar="UM",
                   help="kinematic TE excitation [um] (a profile error; 0)")
    p.add_argument("--rigid", action="store_true",
                   help="rigid rotors, Hertz contact only (no sector mesh): a quick look")
    p.add_argument("--mesh-dir", type=Path, metavar="DIR",
                   help="where the sector mesh is kept and reused (default: OUT/mesh)")
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``fe-impact roll``; returns the exit status."""
    from tqdm import tqdm

    from fe_impact.api import read_gearset
    from fe_impact.rolling.api import RollInputs, check_inputs, roll

    gearset = read_gearset(args.gearset)
    inputs = RollInputs(stage=args.stage, speed_rpm=args.speed, torque_nm=args.torque,
                        cycles=args.cycles, level=args.level,
                        steps_per_cycle=args.steps_per_cycle, ramp_cycles=args.ramp_cycles,
                        te_amplitude=args.te_amplitude * 1e-6, elastic=not args.rigid)
    check_inputs(gearset, inputs)        # bad input: one line, nothing written
    stopped = {"signal": None}
    bar = tqdm(total=1, desc="  rolling", unit="step", leave=False, file=sys.stderr,
               disable=None)

    def progress(step: int, total: int) -> None:
        bar.total = total
        bar.update(step - bar.n)

    def on_signal(signum, frame) -> None:
        stopped["signal"] = signum

    old = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    t0 = time.perf_counter()
    try:
        result = roll(gearset, inputs, args.out, progress=progress,
                      stop=lambda: stopped["signal"] is not None, mesh_dir=args.mesh_dir)
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        bar.close()
    info = result.info
    print(f"{info['n_steps']} steps ({info['cycles_done']:.2f} mesh cycles), "
          f"TE {result.te_m.min() * 1e6:.3f} .. {result.te_m.max() * 1e6:.3f} um, "
          f"{len(result.events)} contact events, energy balance "
          f"{result.energy_error():.2e}; wall {info['wall_s']:.0f} s, cpu {info['cpu_s']:.0f} s")
    print(f"wrote {args.out} ({time.perf_counter() - t0:.1f} s)")
    if stopped["signal"] is not None:
        print("fe-impact: interrupted; the steps done are written (complete: false)",
              file=sys.stderr)
        return 128 + int(stopped["signal"])
    return 0
