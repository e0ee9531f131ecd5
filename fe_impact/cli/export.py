"""``fe-impact export``: the calibrated laws for ADAMS, CSV tables or Exudyn.

::

    fe-impact export CALIBRATION.json --to adams|tables|exudyn --out DIR
        [--gearset FILE] [--stage N] [--speed RPM] [--load NM] [--duration S]

`register` adds the subcommand to the CLI's subparsers; `run` calls
`fe_impact.api.export_calibration` and prints what was written.
"""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["register", "run"]

#: The formats, for --help without importing the API (`fe_impact.api.EXPORT_FORMATS`).
_FORMATS = ("adams", "tables", "exudyn")

_DESCRIPTION = (
    "Write a calibration's IMPACT laws for another tool: 'adams' (IMPACT statements and "
    "contacts per stage, kind of contact and closing speed in mm, N, s; spline tables of "
    "the position law; README.txt), 'tables' (CSV of k, exponent, cmax and d against roll "
    "angle, closing speed and kind; README.txt), 'exudyn' (a runnable Exudyn model of one "
    "stage on the same law, inertias, backlash and loads as fe-impact's switching model).")


def register(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``export`` subcommand to ``subparsers``; returns its parser."""
    p = subparsers.add_parser("export", help="the calibrated laws for ADAMS, CSV tables or "
                                             "Exudyn", description=_DESCRIPTION)
    p.add_argument("calibration", type=Path, help="calibration.json (fe-impact calibrate's)")
    p.add_argument("--to", required=True, metavar="FORMAT",
                   help=f"one of {', '.join(_FORMATS)}")
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    p.add_argument("--gearset", type=Path, metavar="FILE",
                   help="exudyn: gear-set TOML the calibration is of (default: the seed set)")
    p.add_argument("--stage", type=int, help="exudyn: stage, from 1 (default 1)")
    p.add_argument("--speed", type=float, metavar="RPM",
                   help="exudyn: pinion speed [r/min] (default 300)")
    p.add_argument("--load", type=float, metavar="NM",
                   help="exudyn: load torque on the output [N m] (default 0)")
    p.add_argument("--duration", type=float, metavar="S",
                   help="exudyn: simulated time [s] (default 5, the seed's segment)")
    p.set_defaults(func=run)
    return p


def _check_exudyn_options(args: argparse.Namespace) -> None:
    """The Exudyn model's options with another target: refused (they would be ignored)."""
    from fe_impact.errors import FeImpactError

    if args.to == "exudyn":
        return
    for option, value in (("--gearset", args.gearset), ("--stage", args.stage),
                          ("--speed", args.speed), ("--load", args.load),
                          ("--duration", args.duration)):
        if value is not None:
            raise FeImpactError(f"{option} {value}: only --to exudyn takes it ('{args.to}' "
                                "exports every stage, kind and closing speed); remove it")


def run(args: argparse.Namespace) -> int:
    """Handler of ``fe-impact export``; returns the exit status."""
    from fe_impact.api import EXPORT_FORMATS, export_calibration
    from fe_impact.errors import FeImpactError
    from fe_impact.output.files import check_output_dir

    if args.to not in EXPORT_FORMATS:
        raise FeImpactError(f"--to {args.to!r}: unknown format; pick one of "
                            f"{', '.join(EXPORT_FORMATS)}")
    _check_exudyn_options(args)
    check_output_dir(args.out)
    given = {key: value for key, value in (("stage", args.stage), ("speed_rpm", args.speed),
                                           ("load", args.load), ("duration", args.duration),
                                           ("gearset", args.gearset)) if value is not None}
    result = export_calibration(args.calibration, args.to, args.out, **given)
    for note in result.notes:
        print(f"note: {note}")
    for path in result.files:
        print(f"wrote {path}")
    return 0
