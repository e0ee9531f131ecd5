"""Assertions of the validation studies: each headline figure against its tolerance.

A study's ``check(result)`` returns a list of :class:`Check`; :func:`finish`
prints them, writes ``checks.json`` beside the study's output and turns them
into the exit status (0 when all pass), so ``make validate`` fails when a
figure leaves its stated tolerance. The tolerance of every check is set in
the study from the physics or the published accuracy of its reference, with
the reason in a comment there; ``docs/tolerances.md`` collects them.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path


@dataclass(frozen=True)
class Check:
    """One asserted figure: ``value`` measured, ``limit`` the tolerance as text."""

    name: str
    value: float
    limit: str
    passed: bool

    def line(self) -> str:
        state = "pass" if self.passed else "FAIL"
        return f"[{state}] {self.name}: {self.value:.4g} ({self.limit})"


def at_most(name: str, value: float, limit: float) -> Check:
    """``value <= limit``."""
    return Check(name, float(value), f"<= {limit:g}", bool(value <= limit))


def at_least(name: str, value: float, limit: float) -> Check:
    """``value >= limit``."""
    return Check(name, float(value), f">= {limit:g}", bool(value >= limit))


def within(name: str, value: float, reference: float, rel: float) -> Check:
    """``|value / reference - 1| <= rel``; the value reported is the relative error."""
    err = value / reference - 1.0
    return Check(name, float(err), f"|error| <= {rel:g}", bool(abs(err) <= rel))


def holds(name: str, value: float, passed: bool, limit: str) -> Check:
    """A check whose condition is stated in ``limit`` (e.g. an ordering)."""
    return Check(name, float(value), limit, bool(passed))


def summary(study: str, checks: list[Check]) -> str:
    """One line: the study, PASS or FAIL and the failed checks' names."""
    failed = [c.name for c in checks if not c.passed]
    state = "PASS" if checks and not failed else "FAIL"
    tail = f"; failed: {', '.join(failed)}" if failed else ""
    return f"{study}: {state} ({len(checks) - len(failed)}/{len(checks)} checks){tail}"


def finish(study: str, checks: list[Check], out: Path | None) -> int:
    """Print the checks and the summary line, write ``checks.json``; the exit status."""
    for c in checks:
        print(c.line())
    line = summary(study, checks)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        (out / "checks.json").write_text(json.dumps(
            {"study": study, "summary": line, "checks": [asdict(c) for c in checks]},
            indent=2) + "\n")
    print(line)
    return 0 if checks and all(c.passed for c in checks) else 1


def markdown(checks: list[Check]) -> str:
    """The checks as a Markdown table."""
    rows = ["| check | measured | tolerance | result |", "|---|---|---|---|"]
    rows += [f"| {c.name} | {c.value:.4g} | {c.limit} | {'pass' if c.passed else 'FAIL'} |"
             for c in checks]
    return "\n".join(rows) + "\n"
