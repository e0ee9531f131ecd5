"""Gear-set records, TOML loading and validation messages."""

import copy
import tomllib
from pathlib import Path

import numpy as np
import pytest

from fe_impact.errors import GeometryError
from fe_impact.gears import (
    FaceGearTooth,
    GearSet,
    PinionTooth,
    default_gearset,
    gearset_from_dict,
    load_gearset,
)

SEED = Path(__file__).resolve().parents[1] / "geometry" / "seed.toml"


@pytest.fixture
def seed_data():
    with SEED.open("rb") as fh:
        return tomllib.load(fh)


def test_default_gearset_loads():
    gs = default_gearset()
    assert isinstance(gs, GearSet)
    assert gs.pinion.teeth == 19 and gs.pinion.module == pytest.approx(3e-3, rel=1e-15)
    assert [s.teeth for s in gs.stages] == [56, 68, 80]
    assert all(s.shaper_teeth == 21 for s in gs.stages)
    assert gs.n_pinions == 4 and gs.inner_limit == "conjugate"
    assert gs.material.youngs_modulus == 212e9 and gs.material.poisson_ratio == 0.289
    assert gs.material.density == 7860.0 and gs.material.yield_strength == 835e6
    assert gs.pinion.lengthwise_crowning == pytest.approx(10e-6, rel=1e-12)
    for i, stage in enumerate(gs.stages):
        lim = gs.stage_limits(i)
        assert lim.inner_conjugate <= stage.inner_radius < stage.outer_radius
        assert stage.outer_radius <= lim.outer_pointing
    # nested rings with running clearance
    radii = [(s.inner_radius, s.outer_radius) for s in gs.stages]
    assert all(a[1] < b[0] for a, b in zip(radii, radii[1:], strict=False))
    assert isinstance(gs.pinion_tooth(), PinionTooth)
    tooth = gs.face_gear_tooth(2)
    assert isinstance(tooth, FaceGearTooth) and tooth.face_outer == pytest.approx(0.137)
    assert load_gearset(SEED) == gs


def _set(path, value):
    """Return a mutator that sets ``data[path...] = value`` (None deletes)."""

    def mutate(data):
        node = data
        for key in path[:-1]:
            node = node[key]
        if value is None:
            del node[path[-1]]
        else:
            node[path[-1]] = value

    return mutate


STAGE1 = ("face_gear", "stages", 0)
STAGE2 = ("face_gear", "stages", 1)
STAGE3 = ("face_gear", "stages", 2)

INVALID = {
    "unequal modules": (
        [_set(("face_gear", "module_mm"), 2.0)],
        ["face_gear.module = 2 mm", "pinion.module = 3 mm", "same module"],
    ),
    "teeth not a multiple of n_pinions": (
        [_set((*STAGE1, "teeth"), 58)],
        ["stage 1 (58 teeth)", "teeth = 58", "multiple of n_pinions = 4"],
    ),
    "shaper too small": (
        [_set((*STAGE2, "shaper_teeth"), 19)],
        ["stage 2 (68 teeth)", "shaper_teeth = 19", "[20, 22]", "force_shaper"],
    ),
    "shaper too large": (
        [_set((*STAGE2, "shaper_teeth"), 23)],
        ["shaper_teeth = 23", "[20, 22]"],
    ),
    "inner radius below the conjugate limit": (
        [_set((*STAGE1, "inner_radius_mm"), 82.0)],
        ["stage 1 (56 teeth)", "inner_radius = 82.000 mm", "[82.371, 96.978] mm", "conjugate"],
    ),
    "outer radius beyond pointing": (
        [_set((*STAGE3, "outer_radius_mm"), 139.0)],
        ["stage 3 (80 teeth)", "outer_radius = 139.000 mm", "pointing", "138.390"],
    ),
    "rings overlap": (
        [
            _set(("face_gear", "inner_limit"), "undercut"),
            _set((*STAGE2, "outer_radius_mm"), 117.5),
            _set((*STAGE3, "inner_radius_mm"), 116.0),
        ],
        ["stage 2 (68 teeth) and stage 3 (80 teeth) overlap radially by 1.500 mm"],
    ),
    "zero face width": (
        [_set(("pinion", "face_width_mm"), 0.0)],
        ["pinion.face_width = 0 mm", "> 0"],
    ),
    "negative module": (
        [_set(("pinion", "module_mm"), -3.0), _set(("face_gear", "module_mm"), None)],
        ["pinion.module = -3 mm", "> 0"],
    ),
    "negative inner radius": (
        [_set((*STAGE1, "inner_radius_mm"), -1.0)],
        ["stage 1: ", "inner_radius = -1 mm", "> 0"],
    ),
    "zero inertia": (
        [_set(("pinion", "inertia_kg_m2"), 0.0)],
        ["pinion.inertia = 0 kg m^2"],
    ),
    "Poisson ratio 0.5": (
        [_set(("material", "poisson_ratio"), 0.5)],
        ["material.poisson_ratio = 0.5", "(-1, 0.5)"],
    ),
    "Poisson ratio -1": (
        [_set(("material", "poisson_ratio"), -1.0)],
        ["material.poisson_ratio = -1.0", "(-1, 0.5)"],
    ),
    "unknown pinion key": (
        [_set(("pinion", "modulus_mm"), 3.0)],
        ["unknown key(s) ['modulus_mm'] in [pinion]", "allowed:", "module_mm", "face_width_mm"],
    ),
    "unknown stage key": (
        [_set((*STAGE1, "width_mm"), 3.0)],
        ["unknown key(s) ['width_mm'] in [face_gear.stages 1]", "inner_radius_mm"],
    ),
    "unknown top-level key": (
        [_set(("gears",), 3)],
        ["unknown key(s) ['gears'] at the top level", "allowed:", "pinion"],
    ),
    "missing key": (
        [_set(("material", "density_kg_m3"), None)],
        ["missing key(s) ['density_kg_m3'] in [material]"],
    ),
    "crowning in mm by mistake": (
        [_set(("pinion", "lengthwise_crowning_um"), 10000.0)],
        ["pinion.lengthwise_crowning = 10000", "[0, 300] um"],
    ),
    "unknown inner-limit rule": (
        [_set(("face_gear", "inner_limit"), "loose")],
        ["face_gear.inner_limit = 'loose'", "conjugate", "undercut"],
    ),
    "pinion undercut": (
        [_set(("pinion", "teeth"), 15)],
        ["pinion.teeth = 15", ">= 18", "undercut"],
    ),
    "fillet radius too large": (
        [_set(("pinion", "fillet_radius_coeff"), 0.45)],
        ["pinion.fillet_radius_coeff = 0.45", "(0, 0.3803]"],
    ),
    "number given as text": (
        [_set(("pinion", "module_mm"), "3")],
        ["[pinion] module_mm = '3': must be a number"],
    ),
}


@pytest.mark.parametrize("case", list(INVALID))
def test_invalid_gearset_is_rejected_naming_the_field(seed_data, case):
    mutators, fragments = INVALID[case]
    data = copy.deepcopy(seed_data)
    for mutate in mutators:
        mutate(data)
    with pytest.raises(GeometryError) as info:
        gearset_from_dict(data)
    for fragment in fragments:
        assert fragment in str(info.value)


def test_force_shaper_accepts_a_shaper_outside_the_range(seed_data):
    data = copy.deepcopy(seed_data)
    data["face_gear"]["stages"][1]["shaper_teeth"] = 23
    data["face_gear"]["stages"][1]["force_shaper"] = True
    assert gearset_from_dict(data).stages[1].shaper_teeth == 23


def test_undercut_rule_admits_radii_between_the_two_inner_limits(seed_data):
    data = copy.deepcopy(seed_data)
    data["face_gear"]["stages"][0]["inner_radius_mm"] = 82.0  # 81.515 < 82.0 < 82.371
    with pytest.raises(GeometryError, match="conjugate limit"):
        gearset_from_dict(data)
    data["face_gear"]["inner_limit"] = "undercut"
    assert gearset_from_dict(data).stages[0].inner_radius == pytest.approx(0.082)


def test_load_gearset_reports_the_path(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(SEED.read_text().replace("poisson_ratio = 0.289", "poisson_ratio = 0.7"))
    with pytest.raises(GeometryError, match=r"bad\.toml: material\.poisson_ratio = 0\.7"):
        load_gearset(bad)
    with pytest.raises(GeometryError, match="not found"):
        load_gearset(tmp_path / "missing.toml")
    broken = tmp_path / "broken.toml"
    broken.write_text("name = \n")
    with pytest.raises(GeometryError, match="not valid TOML"):
        load_gearset(broken)


def test_units_are_converted_to_si(seed_data):
    gs = gearset_from_dict(seed_data)
    np.testing.assert_allclose(
        [s.inner_radius for s in gs.stages], [0.0825, 0.100, 0.1175], rtol=1e-15
    )
    assert gs.pinion.face_width == pytest.approx(0.024, rel=1e-15)
    assert gs.stages[0].inertia == pytest.approx(7.15e-3)
