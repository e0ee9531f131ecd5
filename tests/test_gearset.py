"""Gear-set records, TOML loading and validation messages."""

import copy
import math
import tomllib

import numpy as np
import pytest
from scipy.optimize import brentq

from fe_impact.errors import GeometryError
from fe_impact.gears import (
    FaceGearTooth,
    GearSet,
    PinionTooth,
    default_gearset,
    default_gearset_path,
    gearset_from_dict,
    load_gearset,
)
from fe_impact.gears.gearset import Pinion, pinion_tip_rounding
from fe_impact.gears.pinion import involute_function

SEED = default_gearset_path()


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
        ["[face_gear] module_mm = 2 mm", "[pinion] module_mm = 3 mm", "same module"],
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
        ["stage 1 (56 teeth)", "inner_radius_mm = 82.000 mm", "raise it to at least 82.371 mm",
         "[82.371, 96.978] mm", "conjugate-tip limit 82.371 mm governs",
         "undercut limit 81.515 mm lies inside"],
    ),
    "outer radius beyond pointing": (
        [_set((*STAGE3, "outer_radius_mm"), 139.0)],
        ["stage 3 (80 teeth)", "outer_radius_mm = 139.000 mm", "pointing",
         "lower it to at most 138.390 mm"],
    ),
    "rings overlap": (
        [
            _set(("face_gear", "inner_limit"), "undercut"),
            _set((*STAGE2, "outer_radius_mm"), 117.5),
            _set((*STAGE3, "inner_radius_mm"), 116.0),
        ],
        ["stage 2 (68 teeth) and stage 3 (80 teeth) overlap radially by 1.500 mm",
         "lower stage 2's outer_radius_mm to at most 116.000 mm",
         "raise stage 3's inner_radius_mm to at least 117.500 mm"],
    ),
    # Used to be accepted, then refused by the contact analysis at roll 0 deg.
    "face beside the pitch radius": (
        [_set((*STAGE1, "inner_radius_mm"), 86.0)],
        ["stage 1 (56 teeth): the face 86.000 to 96.000 mm does not hold the pitch radius "
         "84.000 mm", "allowed inner_radius_mm < 84.000 mm < outer_radius_mm"],
    ),
    "zero face width": (
        [_set(("pinion", "face_width_mm"), 0.0)],
        ["[pinion] face_width_mm = 0 mm", "> 0"],
    ),
    "negative module": (
        [_set(("pinion", "module_mm"), -3.0), _set(("face_gear", "module_mm"), None)],
        ["[pinion] module_mm = -3 mm", "[1, 10] mm", "design range"],
    ),
    "negative inner radius": (
        [_set((*STAGE1, "inner_radius_mm"), -1.0)],
        ["stage 1: ", "inner_radius_mm = -1 mm", "> 0"],
    ),
    "zero inertia": (
        [_set(("pinion", "inertia_kg_m2"), 0.0)],
        ["[pinion] inertia_kg_m2 = 0 kg m^2"],
    ),
    "Poisson ratio 0.5": (
        [_set(("material", "poisson_ratio"), 0.5)],
        ["[material] poisson_ratio = 0.5", "(-1, 0.5)"],
    ),
    "Poisson ratio -1": (
        [_set(("material", "poisson_ratio"), -1.0)],
        ["[material] poisson_ratio = -1.0", "(-1, 0.5)"],
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
    "missing pinion module": (
        # the face gear's module may be left out (it is the pinion's); the pinion's not
        [_set(("pinion", "module_mm"), None)],
        ["missing key(s) ['module_mm'] in [pinion]"],
    ),
    "crowning in mm by mistake": (
        [_set(("pinion", "lengthwise_crowning_um"), 10000.0)],
        ["[pinion] lengthwise_crowning_um = 10000", "[0, 300] um"],
    ),
    "unknown inner-limit rule": (
        [_set(("face_gear", "inner_limit"), "loose")],
        ["[face_gear] inner_limit = 'loose'", "conjugate", "undercut"],
    ),
    "pinion undercut": (
        [_set(("pinion", "teeth"), 15)],
        ["[pinion] teeth = 15", ">= 18", "undercut"],
    ),
    "fillet radius too large": (
        [_set(("pinion", "fillet_radius_coeff"), 0.45)],
        ["[pinion] fillet_radius_coeff = 0.45", "(0, 0.3803]"],
    ),
    "negative pinion tip-edge radius": (
        [_set(("pinion", "tip_edge_radius_mm"), -0.1)],
        ["[pinion] tip_edge_radius_mm = -0.1 mm", ">= 0 mm", "sharp"],
    ),
    "pinion tip-edge roundings wider than the land": (
        [_set(("pinion", "tip_edge_radius_mm"), 2.0)],
        ["[pinion] tip_edge_radius_mm = 2 mm", "leave no tip land", "allowed below 1.705 mm"],
    ),
    # Used to say "allowed below 0 mm": the bisection spanned 0 to 1e30 mm.
    "pinion tip-edge radius 1e30 mm": (
        [_set(("pinion", "tip_edge_radius_mm"), 1e30)],
        ["[pinion] tip_edge_radius_mm = 1e+30 mm", "allowed below 1.705 mm"],
    ),
    "face-gear tip-edge roundings wider than the land": (
        [_set(("face_gear", "tip_edge_radius_mm"), 0.25)],
        ["[face_gear] tip_edge_radius_mm = 0.25 mm", "stage 1 (56 teeth)", "radius 96.00 mm",
         "below 0.209 mm"],
    ),
    "number given as text": (
        [_set(("pinion", "module_mm"), "3")],
        ["[pinion] module_mm = '3': must be a number"],
    ),
    "negative friction coefficient": (
        [_set(("friction", "mu_dynamic"), -0.02)],
        ["[friction] mu_dynamic = -0.02", "[0.0, 1.0)"],
    ),
    "NaN friction coefficient": (
        [_set(("friction", "mu_static"), math.nan)],
        ["[friction] mu_static = nan", "must be a number"],
    ),
    "static friction below the dynamic": (
        [_set(("friction", "mu_static"), 0.01)],
        ["[friction] mu_static = 0.01", "at least [friction] mu_dynamic = 0.02", "swap"],
    ),
    "friction coefficient of 1 or more": (
        [_set(("friction", "mu_static"), 1.5)],
        ["[friction] mu_static = 1.5", "[0.0, 1.0)"],
    ),
    "unknown friction key": (
        [_set(("friction", "mu"), 0.1)],
        ["unknown key(s) ['mu'] in [friction]", "mu_dynamic", "mu_static"],
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
    with pytest.raises(GeometryError, match="conjugate-tip limit 82.371 mm governs"):
        gearset_from_dict(data)
    data["face_gear"]["inner_limit"] = "undercut"
    assert gearset_from_dict(data).stages[0].inner_radius == pytest.approx(0.082)


def test_load_gearset_reports_the_path(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(SEED.read_text().replace("poisson_ratio = 0.289", "poisson_ratio = 0.7"))
    with pytest.raises(GeometryError, match=r"bad\.toml: \[material\] poisson_ratio = 0\.7"):
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


# -- the gear set's own limits: rack, tip land, shaper, pinion face -------------------------
def _pinion(**change):
    fields = dict(teeth=19, module=3e-3, pressure_angle_deg=20.0, addendum_coeff=1.0,
                  clearance_coeff=0.25, face_width=0.024, fillet_radius_coeff=0.38,
                  lengthwise_crowning=0.0, profile_crowning=0.0, inertia=1e-4,
                  tip_edge_radius=0.0)
    return Pinion(**{**fields, **change})


def test_tip_land_equals_the_tooth_thickness_of_the_tooth_geometry():
    """The closed form of the tip land against the involute tooth's own thickness
    (PinionTooth, from the involute's polar angle); both are exact: 1e-12."""
    for teeth, angle, ha in ((19, 20.0, 1.0), (12, 30.0, 1.0), (40, 25.0, 1.2)):
        p = _pinion(teeth=teeth, pressure_angle_deg=angle, addendum_coeff=ha,
                    clearance_coeff=0.1, fillet_radius_coeff=0.01)
        tooth = PinionTooth(teeth=teeth, module=3e-3, pressure_angle_deg=angle,
                            addendum_coeff=ha, clearance_coeff=0.1, fillet_radius_coeff=0.01)
        assert p.tip_land() == pytest.approx(float(tooth.tooth_thickness(tooth.tip_radius)),
                                             rel=1e-12)


def test_pinion_tip_rounding_against_a_sampled_involute():
    """The closed form of the rounding's end on the involute and of the land it leaves,
    against the rounding found on a sampled involute: the centre on the circle
    ``r_a - rho`` whose distance to the involute is ``rho`` (bisection in its polar
    angle), its tangency the nearest sample. Samples 25 nm apart: the end's roll
    length within 0.1 um, the centre's angle within 1e-9 rad of the chords' error."""
    alpha, r_p, z = math.radians(20.0), 0.0285, 19
    r_b, r_a = r_p * math.cos(alpha), 0.0315

    def involute(radius):   # drive side of a tooth centred on the x axis
        half = math.pi / (2 * z) + involute_function(alpha) - involute_function(
            np.arccos(r_b / radius))
        return np.stack([radius * np.cos(half), radius * np.sin(half)], axis=-1)

    dense = involute(np.linspace(r_a - 4e-3, r_a, 160_001))
    sharp = pinion_tip_rounding(z, alpha, r_p, r_a, 0.0)
    assert sharp[0] == pytest.approx(math.sqrt(r_a**2 - r_b**2), rel=1e-15)
    assert sharp[1] == pytest.approx(float(np.arctan2(*dense[-1][::-1])), abs=1e-15)
    for rho in (0.3e-3, 1.0e-3):
        s_t, half = pinion_tip_rounding(z, alpha, r_p, r_a, rho)

        def clearance(angle, rho=rho):
            c = (r_a - rho) * np.array([math.cos(angle), math.sin(angle)])
            return np.min(np.hypot(*(dense - c).T)) - rho

        angle = brentq(clearance, 0.0, sharp[1], xtol=1e-14)
        c = (r_a - rho) * np.array([math.cos(angle), math.sin(angle)])
        touch = dense[np.argmin(np.hypot(*(dense - c).T))]
        assert s_t == pytest.approx(math.sqrt(np.hypot(*touch) ** 2 - r_b**2), abs=1e-7)
        assert half == pytest.approx(angle, abs=1e-8)


def test_pointed_pinion_tooth_names_the_addendum_and_its_limit():
    # 12 teeth at 30 deg: the tip closes at ha* = 1.125 (bisection of the tip land),
    # before the rack (1.26 with c* = 0.1) or the undercut bound (9.7 teeth) object.
    with pytest.raises(GeometryError, match=r"pinion.addendum_coeff = 1.2: the pinion tooth "
                                            r"comes to a point .* below 1.12"):
        _pinion(teeth=12, pressure_angle_deg=30.0, addendum_coeff=1.2, clearance_coeff=0.1,
                fillet_radius_coeff=0.01)
    limit = 1.1245
    p = _pinion(teeth=12, pressure_angle_deg=30.0, addendum_coeff=limit, clearance_coeff=0.1,
                fillet_radius_coeff=0.01)
    assert 0.0 < p.tip_land() < 1e-3 * p.module     # just below the limit: a thin land


def test_rack_tooth_pointed_names_addendum_and_clearance():
    # The rack tooth is pi m / 2 wide on its pitch line and its flanks lean at alpha:
    # they meet (pi / 4) / tan(alpha) modules below it, 2.158 at 20 deg.
    depth = np.pi / 4 / np.tan(np.radians(20.0))
    with pytest.raises(GeometryError, match=rf"their sum 3.25 must be below .* = "
                                            rf"{depth:.4g}"):
        _pinion(addendum_coeff=3.0)


def test_shaper_never_fewer_teeth_than_the_pinion(seed_data):
    stage = seed_data["face_gear"]["stages"][0]
    stage.update(shaper_teeth=18, force_shaper=True)
    with pytest.raises(GeometryError, match=r"shaper_teeth = 18 must be at least \[pinion\] "
                                            r"teeth = 19, force_shaper or not"):
        gearset_from_dict(seed_data)
    stage.update(shaper_teeth=19)
    seed_data["pinion"]["lengthwise_crowning_um"] = 0.0
    with pytest.raises(GeometryError, match=r"shaper_teeth = 19 equals \[pinion\] teeth and the "
                                            r"pinion has no lengthwise crowning"):
        gearset_from_dict(seed_data)


def test_pinion_face_limit_is_where_neighbouring_pinions_touch():
    """Brute force in the plane of two neighbouring pinion axes, where the tip cylinders
    are widest: each pinion a rectangle ``2 r_a`` wide along its radial axis from
    ``r_2 - b/2`` to ``r_2 + b/2``. Sampled points of one rectangle inside the other:
    none at 0.999 of the limit, some at 1.001 of it."""
    gs = default_gearset()
    limit = gs.pinion_face_limit()
    r_a = gs.pinion.pitch_radius + gs.pinion.addendum_coeff * gs.pinion.module
    r_2 = 0.5 * gs.module * min(s.teeth for s in gs.stages)
    theta = 2 * np.pi / gs.n_pinions

    def overlap(b: float) -> bool:
        axial, lateral = np.meshgrid(np.linspace(r_2 - b / 2, r_2 + b / 2, 801),
                                     np.linspace(-r_a, r_a, 401))
        x, y = axial.ravel(), lateral.ravel()              # pinion A along the x axis
        along = x * np.cos(theta) + y * np.sin(theta)     # in pinion B's frame
        across = -x * np.sin(theta) + y * np.cos(theta)
        return bool(np.any((np.abs(across) < r_a) & (along > r_2 - b / 2)
                           & (along < r_2 + b / 2)))

    assert not overlap(0.999 * limit) and overlap(1.001 * limit)
    # four pinions: r_a cot 45 deg = r_a from the axis, 2 (84 - 31.5) mm
    assert limit * 1e3 == pytest.approx(105.0, abs=1e-9)
    assert gs.pinion.face_width < limit           # the seed's 24 mm
    with pytest.raises(GeometryError, match=r"pinion.face_width = 300 mm: .* at most 105 mm"):
        GearSet(gs.name, _replace(gs.pinion, face_width=0.3), gs.stages, gs.material)


def _replace(record, **change):
    import dataclasses

    return dataclasses.replace(record, **change)


def test_a_pointed_shaper_is_refused(seed_data):
    # 26 pinion teeth with ha* = 1.4: the 27-tooth shaper reaches (1.4 + 0.25) m above
    # its pitch circle, where its involute tooth has closed: half angle pi / (2 N_s) +
    # inv(20 deg) - inv(alpha_a) < 0, a land of -0.127 mm at 45.45 mm. Accepted before,
    # with a shaper tip that cut no physical root.
    data = copy.deepcopy(seed_data)
    data["pinion"].update(teeth=26, addendum_coeff=1.4, fillet_radius_coeff=0.26)
    data["face_gear"]["stages"] = [dict(data["face_gear"]["stages"][0], teeth=80,
                                        shaper_teeth=27)]
    with pytest.raises(GeometryError, match=r"stage 1 \(80 teeth\): the 27-tooth shaper is "
                                            r"pointed at its tip radius 45\.450 mm .* tip land "
                                            r"would be -0\.127 mm"):
        gearset_from_dict(data)


def test_friction_defaults_to_the_seeds_greased_flanks_and_feeds_the_lumped_model(seed_data):
    # Seed section 4 (eqs. 9-10): mu 0.05 static, 0.02 dynamic. Without a [friction]
    # table the set takes them; the lumped switching model takes the set's (one source),
    # and frictionless flanks (0 and 0) give it none.
    from fe_impact.switching import DriveModel

    data = copy.deepcopy(seed_data)
    data.pop("friction", None)
    plain = gearset_from_dict(data)
    assert (plain.friction.mu_static, plain.friction.mu_dynamic) == (0.05, 0.02)
    data["friction"] = {"mu_static": 0.08, "mu_dynamic": 0.03}
    model = DriveModel(gearset=gearset_from_dict(data))
    assert (model.friction.static, model.friction.dynamic) == (0.08, 0.03)
    data["friction"] = {"mu_static": 0.0, "mu_dynamic": 0.0}
    smooth = gearset_from_dict(data)
    assert not smooth.friction.active and DriveModel(gearset=smooth).friction is None
