"""Bad case files get one clear message naming the key, the value and what is allowed."""

from __future__ import annotations

import re

import pytest

from fe_impact.cli.main import main
from fe_impact.errors import CaseError, MeshError
from fe_impact.fe.case import load_case
from fe_impact.fe.mesh import load_mesh
from fe_impact.solvers.static import StaticSolver


def mutate(case, tmp_path, old, new):
    """The static Hertz case as text (on the committed coarse mesh) with ``old``
    replaced by ``new``: a case file broken on purpose. ``case`` is unused (the
    text is the reader tests' template, tests/test_bad_inputs.py)."""
    from tests.test_bad_inputs import STATIC

    text = STATIC + "\n[analysis]\n"
    assert old in text, old
    path = tmp_path / "bad.toml"
    path.write_text(text.replace(old, new))
    return path


BAD = [
    ('youngs_modulus = 212000000000.0', 'youngs_modulus = -1.0',
     r"youngs_modulus = -1.0: must be in \(0.0, 1e\+13\] \(Pa\)"),
    ('poisson_ratio = 0.289', 'poisson_ratio = 0.5', r"poisson_ratio = 0.5.*\(-1.0, 0.5\)"),
    ('unit = "m"', 'unit = "inch"', r"unit = 'inch'.*\['m', 'mm'\]"),
    ('fix = ["z"]', 'fix = ["w"]', r"fix = \['w'\].*\['x', 'y', 'z'\]"),
    ('penalty = "auto"', 'penalty = "stiff"', r"penalty = 'stiff'.*auto"),
    ('penalty = "auto"', 'penalty = "auto"\nmultiplier = "quadratic"',
     r"multiplier = 'quadratic'.*linear.*split"),
    ('component = "z"', 'component = "q"', r"component = 'q'.*pick one of"),
    ('[analysis]', '[analysis]\ntype = "modal"', r"type = 'modal'.*static"),
    ('density = 7860', 'density = 7860\ncolour = "red"', r"unknown key.*colour.*allowed"),
    ('unit = "m"', 'unit = "m"\nfile = "x"', r"not valid TOML|file"),
]


@pytest.mark.parametrize("old,new,pattern", BAD)
def test_bad_values_are_named(coarse_hertz_case, tmp_path, old, new, pattern):
    with pytest.raises(CaseError, match=pattern):
        load_case(mutate(coarse_hertz_case, tmp_path, old, new))


@pytest.mark.parametrize("old,new,pattern", [
    ('slave = "sphere_contact"', 'slave = "sphere_kontakt"',
     r"contacts\[0\].slave = 'sphere_kontakt'.*surface groups: \[.*'sphere_contact'"),
    ('surface = "block_bottom"', 'surface = "block"',
     r"'block' is a volume, a surface group is needed"),
    ('volumes = ["sphere", "block"]', 'volumes = ["sphere", "block_bottom"]',
     r"'block_bottom' is a surface, a volume group is needed"),
    ('volumes = ["sphere", "block"]', 'volumes = ["sphere"]',
     r"volume groups \['block'\] have no material"),
])
def test_groups_checked_against_mesh(coarse_hertz_case, tmp_path, old, new, pattern):
    with pytest.raises(CaseError, match=pattern):
        case = load_case(mutate(coarse_hertz_case, tmp_path, old, new))
        StaticSolver(case, load_mesh(case.mesh_file, case.unit))


def test_missing_case_and_mesh_files(tmp_path):
    with pytest.raises(CaseError, match="case file not found"):
        load_case(tmp_path / "none.toml")
    with pytest.raises(MeshError, match="mesh file not found"):
        load_mesh(tmp_path / "none.msh")
    (tmp_path / "x.toml").write_text("[mesh\n")
    with pytest.raises(CaseError, match="not valid TOML"):
        load_case(tmp_path / "x.toml")


def test_cli_reports_user_errors_without_traceback(coarse_hertz_case, tmp_path, capsys):
    bad = mutate(coarse_hertz_case, tmp_path, 'poisson_ratio = 0.289', 'poisson_ratio = 0.7')
    assert main(["solve", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "poisson_ratio = 0.7" in err and "Traceback" not in err
    assert not (tmp_path / "o" / "summary.json").exists()
    assert re.search(r"error", err)


def test_missing_mesh_named_in_case(tmp_path):
    (tmp_path / "c.toml").write_text(
        '[mesh]\nfile = "nowhere.msh"\n[[materials]]\n'
        'volumes = ["a"]\nyoungs_modulus = 1e9\npoisson_ratio = 0.3\n')
    with pytest.raises(CaseError, match=r"file = 'nowhere.msh': no such file"):
        load_case(tmp_path / "c.toml")
