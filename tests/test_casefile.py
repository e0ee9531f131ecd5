"""Case files: what :func:`write_case` writes, :func:`load_case` reads back unchanged.

The truth is the written case itself: every field of the dataclasses read
back equal (floats bit for bit, since the writer prints ``repr``).
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from pathlib import Path

import pytest

from fe_impact.errors import CaseError
from fe_impact.fe.case import (
    AnalysisSpec,
    Case,
    ContactSpec,
    DisplacementSpec,
    InitialVelocitySpec,
    MaterialSpec,
    RigidBodySpec,
    SupportSpec,
    load_case,
)
from fe_impact.fe.casefile import write_case

STEEL = MaterialSpec(("sphere",), 212e9, 0.289, 7860.0)
#: Plastic, with hardening, and numbers that 10 significant digits would not keep.
PLASTIC = MaterialSpec(("block",), 2.0e11 / 3.0, 0.3, 7850.0, yield_strength=835e6,
                       hardening_modulus=math.pi * 1e9)


def _mesh(folder: Path, name: str = "mesh.msh") -> Path:
    """A stand-in mesh file: the reader only checks that it exists."""
    path = folder / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("not read\n")
    return path.resolve()


def _static(folder: Path) -> Case:
    return Case(
        path=folder / "static.toml", mesh_file=_mesh(folder), unit="mm",
        materials=(STEEL, PLASTIC),
        contacts=(ContactSpec("sphere_contact", "block_contact", penalty=1.234567890123e15,
                              search_distance=2e-6, multiplier="split"),),
        supports=(SupportSpec("block_bottom", (2,)), SupportSpec("sym", (0, 1))),
        displacements=(DisplacementSpec("sphere_top", 2, (-5e-6, -1e-5, -1.5e-5)),
                       DisplacementSpec("sphere_side", 0, (0.0, 1e-7, 2e-7))),
        analysis=AnalysisSpec("static", max_iterations=12, tolerance=1e-9),
    )


def _dynamic(folder: Path) -> Case:
    return Case(
        path=folder / "dynamic.toml", mesh_file=_mesh(folder), unit="m",
        materials=(STEEL, PLASTIC),
        contacts=(ContactSpec("pinion_flank", "face_flank"),
                  ContactSpec("a", "b", penalty=1e18, search_distance=1.2e-5)),
        supports=(SupportSpec("ground", (0, 1, 2)),),
        initial_velocities=(InitialVelocitySpec(("sphere",), (0.0, 0.1 / 3.0, -1.0)),),
        rigid_bodies=(
            RigidBodySpec("pinion_hub", "rotation", (0.0, 0.0, 1.0), (0.0, 0.0285, 0.0),
                          1.96e-4, -0.17453292519943295, carries=("block",)),
            RigidBodySpec("top", "translation", (0.6, 0.0, 0.8), inertia=0.125,
                          initial_velocity=-1.0 / 7.0),
        ),
        analysis=AnalysisSpec("dynamic", integrator="newmark", duration=1.0 / 3.0 * 1e-4,
                              time_step=1e-4 / 180.0, output_interval=1e-4 / 60.0,
                              hht_alpha=-0.05, energy_limit=0.02, plastic_zone=3e-4,
                              stop_after_separation=0.25, plastic_solver="anderson"),
    )


def _explicit(folder: Path) -> Case:
    case = _dynamic(folder)
    return dataclasses.replace(
        case, path=folder / "explicit.toml",
        analysis=AnalysisSpec("dynamic", integrator="explicit", duration=2e-5,
                              safety_factor=0.8))


@pytest.mark.parametrize("build", [_static, _dynamic, _explicit])
def test_written_case_reads_back_equal(tmp_path, build):
    case = build(tmp_path)
    path = write_case(case, case.path)
    assert path == case.path
    assert load_case(path) == case


def test_defaults_read_back_as_defaults(tmp_path):
    """A minimal dynamic case: automatic penalty, step, zone; no output interval."""
    case = Case(path=tmp_path / "min.toml", mesh_file=_mesh(tmp_path), unit="m",
                materials=(STEEL,), contacts=(ContactSpec("s", "m"),),
                analysis=AnalysisSpec("dynamic", duration=1e-5))
    assert load_case(write_case(case, case.path)) == case
    text = tomllib.loads(case.path.read_text())
    assert text["contacts"][0]["penalty"] == "auto"
    assert text["analysis"]["time_step"] == "auto" and text["analysis"]["plastic_zone"] == "auto"
    assert "output_interval" not in text["analysis"]


def test_variant_by_replace(tmp_path):
    """A variant made with dataclasses.replace is written and read back as such."""
    case = _dynamic(tmp_path)
    stiffer = dataclasses.replace(
        case, contacts=(dataclasses.replace(case.contacts[0], penalty=5e15),
                        *case.contacts[1:]))
    back = load_case(write_case(stiffer, tmp_path / "stiffer.toml"))
    assert back.contacts[0].penalty == 5e15
    assert back == dataclasses.replace(stiffer, path=tmp_path / "stiffer.toml")
    with pytest.raises(dataclasses.FrozenInstanceError):
        back.unit = "m"


def test_mesh_in_another_folder_and_relative_case_path(tmp_path, monkeypatch):
    """The mesh is written relative to the case file's folder, wherever both are."""
    mesh = _mesh(tmp_path / "meshes", "pair.msh")
    monkeypatch.chdir(tmp_path)
    case = dataclasses.replace(_static(tmp_path), path=Path("cases/a.toml"), mesh_file=mesh)
    write_case(case, case.path)
    assert tomllib.loads(case.path.read_text())["mesh"]["file"] == "../meshes/pair.msh"
    assert load_case(case.path) == case


def test_group_names_are_quoted(tmp_path):
    odd = 'flank "A"\\left\tside'
    case = dataclasses.replace(_static(tmp_path),
                               supports=(SupportSpec(odd, (0,)),))
    assert load_case(write_case(case, case.path)).supports[0].surface == odd


def test_header_becomes_comments(tmp_path):
    case = _static(tmp_path)
    write_case(case, case.path, header="written by a test\nsecond line")
    lines = case.path.read_text().splitlines()
    assert lines[:2] == ["# written by a test", "# second line"]
    assert load_case(case.path) == case


@pytest.mark.parametrize("change, field", [
    # a static analysis has no Newmark controls: the reader would drop them
    (lambda c: dataclasses.replace(c, analysis=dataclasses.replace(c.analysis,
                                                                   integrator="explicit")),
     "analysis"),
    # the reader makes directions unit vectors
    (lambda c: dataclasses.replace(c, analysis=AnalysisSpec("dynamic", duration=1e-5),
                                   supports=(), displacements=(),
                                   rigid_bodies=(RigidBodySpec("top", "translation",
                                                               (0.0, 0.0, 2.0)),)),
     "rigid_bodies"),
])
def test_cases_a_file_cannot_hold_are_refused(tmp_path, change, field):
    case = change(_static(tmp_path))
    with pytest.raises(CaseError, match=f"cannot be written as a case file: {field}"):
        write_case(case, case.path)
    assert not case.path.exists()


def test_invalid_values_are_refused_by_the_reader(tmp_path):
    case = dataclasses.replace(_static(tmp_path), materials=(
        dataclasses.replace(STEEL, poisson_ratio=0.5), PLASTIC))
    with pytest.raises(CaseError, match=r"poisson_ratio = 0.5"):
        write_case(case, case.path)
    assert not list(tmp_path.glob("*.toml")) and not list(tmp_path.glob(".*"))
