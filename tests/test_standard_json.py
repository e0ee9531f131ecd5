"""Every JSON file a command writes is standard JSON: a strict parser (as JavaScript's
``JSON.parse`` or Perl's JSON::PP) reads it; a quantity without a finite value is null.

``calibrate``'s files are parsed in tests/test_interrupts.py, after its full run.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from fe_impact.cli.main import main
from tests.test_bad_inputs import STATIC, sdof
from tests.test_interrupts import strict


def _solve_static(d: Path) -> list[str]:
    (d / "static.toml").write_text(STATIC)
    return ["solve", str(d / "static.toml")]


def _solve_dynamic(d: Path) -> list[str]:
    (d / "impact.toml").write_text(sdof())
    return ["solve", str(d / "impact.toml")]


COMMANDS = [
    pytest.param(_solve_static, id="solve static"),
    pytest.param(_solve_dynamic, id="solve dynamic"),
    # A run of one mesh cycle: statistics with empty impact sets (None) and a warning.
    pytest.param(lambda d: ["switching", "--preset", "table1-100rpm", "--duration", "0.03"],
                 id="switching"),
    pytest.param(lambda d: ["mesh", "--level", "coarse", "--order", "1"], id="mesh",
                 marks=pytest.mark.slow),
]


@pytest.mark.parametrize("command", COMMANDS)
def test_every_json_output_is_standard(tmp_path, command):
    out = tmp_path / "out"
    assert main([*command(tmp_path), "--out", str(out)]) == 0
    files = sorted(out.rglob("*.json"))
    assert files
    for path in files:
        strict(path)
