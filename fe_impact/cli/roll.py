"""``fe-impact roll``: the tooth sectors turning through mesh at speed (transient FE).

A thin layer over :func:`fe_impact.rolling.api.roll`: it reads the gear set, checks
the inputs and the output folders before any computing, draws a progress bar and,
while the time loop runs, turns Ctrl-C into a clean stop (the steps done are
written, the summary marked ``complete: false``). Ctrl-C during the set-up (meshing,
matrices) ends the run at once with nothing written.
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading
import time
from pathlib import Path

_DESCRIPTION = (
    "Transient FE of a pinion sector and a face-gear sector (5 teeth each, --teeth) turning "
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
                   help="load torque on the face gear from this one mesh [N m] (0); with "
                        "several pinions on the ring, the output torque divided by "
                        "their number")
    p.add_argument("--cycles", type=float, default=2.0, metavar="K",
                   help="mesh cycles to simulate (2; 5-tooth sectors hold about 2.4, each "
                        "added tooth one more)")
    p.add_argument("--teeth", type=int, default=5, metavar="N",
                   help="teeth of each sector, 4..7 (5): the mesh cycles they hold are "
                        "about N minus the reach of a pair along the line of action in "
                        "base pitches (2.5 on the seed set)")
    p.add_argument("--level", default="coarse", help="mesh level (coarse)")
    p.add_argument("--steps-per-cycle", type=int, default=240, metavar="N",
                   help="time steps per mesh cycle (240)")
    p.add_argument("--ramp-cycles", type=float, metavar="K",
                   help="the load torque rises as sin^2 over these cycles, fewer than "
                        "--cycles (1, or half of --cycles if that is less)")
    p.add_argument("--te-amplitude", type=float, default=0.0, metavar="UM",
                   help="kinematic TE excitation [um] (a profile error; 0)")
    p.add_argument("--quasi-static", action="store_true",
                   help="skip the check that the step resolves the mesh-in impacts (a slow "
                        "run whose step follows the load's variation, not the impacts)")
    p.add_argument("--rigid", action="store_true",
                   help="rigid rotors, Hertz contact only (no sector mesh): a quick look")
    p.add_argument("--no-friction", dest="friction", action="store_false",
                   help="frictionless flanks (default: Coulomb friction with the gear "
                        "set's [friction] coefficients)")
    p.add_argument("--mesh-dir", type=Path, metavar="DIR",
                   help="where the sector mesh is kept and reused (default: OUT/mesh)")
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``fe-impact roll``; returns the exit status."""
    from tqdm import tqdm

    from fe_impact.api import RollInputs, read_gearset, roll
    from fe_impact.api import check_roll_inputs as check_inputs
    from fe_impact.output.files import check_output_dir

    gearset = read_gearset(args.gearset)
    inputs = RollInputs(stage=args.stage, speed_rpm=args.speed, torque_nm=args.torque,
                        cycles=args.cycles, level=args.level,
                        steps_per_cycle=args.steps_per_cycle,
                        ramp_cycles=(args.ramp_cycles if args.ramp_cycles is not None
                                     else min(1.0, 0.5 * args.cycles)),
                        te_amplitude=args.te_amplitude * 1e-6, elastic=not args.rigid,
                        friction=args.friction, teeth=args.teeth)
    # bad input: one line, nothing written
    check_inputs(gearset, inputs, check_step=not args.quasi_static)
    check_output_dir(args.out)
    if args.mesh_dir is not None and not args.rigid:
        check_output_dir(args.mesh_dir, "--mesh-dir")
    stopped = {"signal": None}
    bar = tqdm(total=1, desc="  rolling", unit="step", leave=False, file=sys.stderr,
               disable=None)

    def progress(step: int, total: int) -> None:
        bar.total = total
        bar.update(step - bar.n)

    t0 = time.perf_counter()
    try:
        result = roll(gearset, inputs, args.out, progress=progress,
                      stop=lambda: stopped["signal"] is not None, mesh_dir=args.mesh_dir,
                      check_step=not args.quasi_static, while_stepping=_stepping(stopped))
    finally:
        bar.close()
    info = result.info
    balance = result.energy_balance()
    versus = (f", {balance['relative_to_work']:.2e} of the work done"
              if balance["relative_to_work"] is not None else ", no work done")
    print(f"{info['n_steps']} steps ({info['cycles_done']:.2f} mesh cycles), "
          f"TE {result.te_m.min() * 1e6:.3f} .. {result.te_m.max() * 1e6:.3f} um, "
          f"{len(result.events)} contact events, energy balance error "
          f"{balance['error_j']:.2e} J ({balance['relative_to_kinetic'] or 0.0:.2e} of the "
          f"kinetic energy{versus}); wall {info['wall_s']:.0f} s, cpu {info['cpu_s']:.0f} s")
    friction = info.get("friction")
    if friction:
        lost = float(result.energy["friction_dissipation"][-1])
        drive = float(result.energy["drive_work"][-1])
        share = f" ({lost / drive:.2%} of the drive's work)" if drive > 0.0 else ""
        print(f"flank friction mu_static {friction['mu_static']:g}, mu_dynamic "
              f"{friction['mu_dynamic']:g}: {lost:.3e} J dissipated{share}")
    else:
        print("frictionless flanks")
    print(f"wrote {args.out} ({time.perf_counter() - t0:.1f} s)")
    if info.get("passed_through"):
        print(f"fe-impact: error: the results in {args.out} are not valid: the teeth went "
              "through each other (roll.json: info.passed_through)", file=sys.stderr)
        return 1
    if stopped["signal"] is not None:
        print("fe-impact: interrupted; the steps done are written (complete: false)",
              file=sys.stderr)
        return 128 + int(stopped["signal"])
    return 0


@contextlib.contextmanager
def _stepping(stopped: dict):
    """While the time loop runs, SIGINT and SIGTERM set ``stopped["signal"]`` (the loop
    ends after its step and writes what is done); outside it they stop at once."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def on_signal(signum, frame) -> None:
        stopped["signal"] = signum

    old = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
