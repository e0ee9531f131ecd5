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
from fe_impact.meshing.toothpair import pair_key


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


def test_refinement_one_keeps_the_cache_keys_of_existing_meshes(gearset):
    """The key of refinement 1 is the hash of the spec without the field (the key
    of the meshes made before it, in the key's format 4 of every mesh since the
    face-gear flank's smooth continuation beyond the face's ends); another refinement
    is another mesh."""
    spec = PairSpec(stage=1, level="coarse", gap=2e-6, impact_speed=0.1)
    fields = asdict(spec)
    del fields["contact"], fields["refinement"]
    payload = json.dumps({"gearset": asdict(gearset), "spec": fields, "format": 4},
                         sort_keys=True, default=repr)
    assert pair_key(gearset, spec) == hashlib.sha256(payload.encode()).hexdigest()[:16]
    assert pair_key(gearset, replace(spec, refinement=1.5)) != pair_key(gearset, spec)


@pytest.mark.parametrize("value", [0.1, 5.0, math.nan, True, "2"])
def test_refinement_out_of_range_is_refused_by_name(value):
    with pytest.raises(MeshError, match=r"refinement = .*allowed 0\.5 \.\. 4"):
        PairSpec(refinement=value)
