"""Compare the impact measurements of two calibrations case by case.

Run ``python validation/compare_calibrations.py OLD/calibration.json
NEW/calibration.json`` (``--tolerance``: the largest relative difference
allowed, 1e-3 by default). It prints, per impact case found in both files,
the relative change of the FE measurements (peak force, largest approach,
contact time, restitution, the fitted stiffness and exponent) and of the
IMPACT law (K, exponent, cmax, d), the worst of each, and exits 1 when a
change exceeds the tolerance or a case is missing from the new file.

Use it when a change of the solvers should leave the results alone (a speed
change, say): the default 1e-3 is well inside the accuracy the validations
show for these quantities (the Hertz impact's peak force within 6%, the
quasi-static loading branch within 2%), and far above the round-off of two
runs of the same code (0).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

FE_KEYS = ("peak_force", "max_approach", "contact_time", "restitution", "stiffness_k",
           "stiffness_exponent")
LAW_KEYS = ("k", "exponent", "cmax", "d")


def changes(old: dict, new: dict) -> tuple[dict[str, dict[str, float]], list[str]]:
    """Relative change per case and quantity; the ids missing from ``new``."""
    before = {c["id"]: c for c in old["cases"]}
    after = {c["id"]: c for c in new["cases"]}
    out: dict[str, dict[str, float]] = {}
    for cid, a in sorted(before.items()):
        if cid not in after:
            continue
        b = after[cid]
        row = {}
        for group, keys in (("fe", FE_KEYS), ("impact", LAW_KEYS)):
            for k in keys:
                x, y = a[group].get(k), b[group].get(k)
                if x is None and y is None:
                    continue
                if x is None or y is None or not (math.isfinite(x) and math.isfinite(y)):
                    # gone, come, or not a number: no agreement (max() would drop a NaN)
                    row[f"{group}.{k}"] = math.inf
                    continue
                row[f"{group}.{k}"] = (y - x) / abs(x) if x else float(y != x)
        out[cid] = row
    return out, sorted(set(before) - set(after))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("old", type=Path)
    p.add_argument("new", type=Path)
    p.add_argument("--tolerance", type=float, default=1e-3,
                   help="largest relative change allowed (default 1e-3)")
    args = p.parse_args(argv)
    if not args.tolerance > 0:
        p.error(f"--tolerance {args.tolerance}: must be > 0")
    try:
        old, new = (json.loads(f.read_text()) for f in (args.old, args.new))
    except (OSError, json.JSONDecodeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    rows, missing = changes(old, new)
    if not rows:
        print("error: the two files have no impact case in common", file=sys.stderr)
        return 2
    keys = list(next(iter(rows.values())))
    print("| case | " + " | ".join(keys) + " |")
    print("|---" * (len(keys) + 1) + "|")
    worst: dict[str, float] = {}
    for cid, row in rows.items():
        print(f"| {cid} | " + " | ".join(f"{100 * row.get(k, 0.0):+.4f}%" for k in keys) + " |")
        for k, v in row.items():
            worst[k] = max(worst.get(k, 0.0), abs(v))
    print("worst: " + ", ".join(f"{k} {v:.2e}" for k, v in worst.items()))
    for cid in missing:
        print(f"[FAIL] {cid}: missing from {args.new}")
    largest = max(worst.values())
    ok = largest <= args.tolerance and not missing
    print(f"[{'pass' if ok else 'FAIL'}] largest relative change {largest:.2e} "
          f"(tolerance {args.tolerance:g}) over {len(rows)} cases")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
