"""A level's uniform refinement: the family of meshes the convergence study extrapolates on.

``PairSpec.refinement`` divides every element size of a level and its
gradation by one factor, so the size field is the level's, scaled, and the
stretched space (whose core radius is a size difference over the gradation)
is the same map. Richardson's extrapolation rests on exactly that.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, replace

import pytest

from fe_impact.errors import MeshError
from fe_impact.gears import default_gearset
from fe_impact.gears.pairanalysis import PairSpec
from fe_impact.meshing.sizing import LEVELS, design_pair, level_of
from fe_impact.meshing.toothpair import MESH_FORMAT, pair_key
from fe_impact.meshing.twopair import two_pair_key


@pytest.fixture(scope="module")
def gearset():
    return default_gearset()


def test_refinement_scales_every_size_and_keeps_the_map(gearset):
    spec = PairSpec(stage=1, level="default", design_force=500.0)
    base, fine = design_pair(gearset, spec), design_pair(gearset, replace(spec, refinement=1.5))
    for name in ("minor", "major", "far"):
        # the sizes are products of the level's fractions: exact to round-off
        assert fine.sizes[name] == pytest.approx(base.sizes[name] / 1.5, rel=1e-12)
    assert fine.sizes["factor"] == pytest.approx(base.sizes["factor"], rel=1e-12)
    level = level_of(replace(spec, refinement=1.5))
    assert level.gradation == pytest.approx(LEVELS["default"].gradation / 1.5, rel=1e-12)
    assert level.max_stretch == LEVELS["default"].max_stretch   # a shape bound, not a size
    for name in ("half_length", "reach", "ramp", "core_radius", "outer_radius", "factor"):
        assert getattr(fine.stretch, name) == pytest.approx(getattr(base.stretch, name),
                                                            rel=1e-12), name


def test_every_field_of_the_spec_and_the_format_enter_the_mesh_keys(gearset):
    """A mesh key is the hash of the gear set, every field of the spec and the
    mesh format: a spec that differs in any one field is another mesh, and so is
    the same spec meshed by the two-pair builder."""
    spec = PairSpec(stage=1, level="coarse", gap=2e-6, impact_speed=0.1)
    payload = json.dumps({"gearset": asdict(gearset), "spec": asdict(spec),
                          "format": MESH_FORMAT}, sort_keys=True, default=repr)
    assert pair_key(gearset, spec) == hashlib.sha256(payload.encode()).hexdigest()[:16]
    changed = {"stage": 2, "roll_angle_deg": 1.0, "level": "default", "refinement": 1.5,
               "order": 1, "gap": 3e-6, "impact_speed": 0.2, "n_face_teeth": 2,
               "rim_modules": 3.0, "neighbour_teeth": 0, "design_force": 100.0,
               "velocity_split": "pinion", "pinion_axial_position": 0.1,
               "contact": "corner-approach"}
    assert set(changed) == set(asdict(spec)), "a field of PairSpec is not varied here"
    keys = {pair_key(gearset, replace(spec, **{name: value}))
            for name, value in changed.items()}
    assert len(keys) == len(changed) and pair_key(gearset, spec) not in keys
    assert two_pair_key(gearset, spec) != pair_key(gearset, spec)


@pytest.mark.parametrize("value", [0.1, 5.0, math.nan, True, "2"])
def test_refinement_out_of_range_is_refused_by_name(value):
    with pytest.raises(MeshError, match=r"refinement = .*allowed 0\.5 \.\. 4"):
        PairSpec(refinement=value)
