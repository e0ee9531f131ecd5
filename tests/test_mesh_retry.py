"""The tooth-pair builder meshes again with less stretch when an element comes out inverted.

``build_pair`` maps the contact zone into a stretched space, meshes there and
maps back; a mesh with a nearly inverted element (quality below MIN_SICN) is
made again with the stretch capped at 5, 2.5 (with the map's compensation
ending 4, then 2.5 zone half-lengths from the contact) and finally 1
(isotropic). Here
the first attempts are made to fail by wrapping the builder's meshing step.
"""

from __future__ import annotations

import logging

import pytest

from fe_impact.errors import MeshError
from fe_impact.gears import default_gearset
from fe_impact.meshing import solids as solid_cache
from fe_impact.meshing import stretchmesh, toothpair

GAP, SPEED = 2e-6, 0.1


def _failing_mesh(monkeypatch, failures: int) -> list[tuple[float, float]]:
    """Make the first ``failures`` meshing attempts report an inverted element; return
    the stretch factor and the map's reach (in zone half-lengths) of every attempt
    as it is made."""
    real = toothpair._mesh
    factors: list[tuple[float, float]] = []

    def mesh(model, design, *args, **kwargs):
        st = design.stretch
        factors.append((design.sizes["factor"], round(st.reach / st.half_length, 12)))
        if len(factors) <= failures:
            raise stretchmesh.InvertedMesh(
                f"the mesh has an element of quality -0.1 at stretch factor "
                f"{design.sizes['factor']:.3g}")
        return real(model, design, *args, **kwargs)

    monkeypatch.setattr(toothpair, "_mesh", mesh)
    return factors


def test_every_attempt_inverted_ends_in_a_mesh_error(tmp_path, monkeypatch, caplog):
    # The coarse level's design stretch, (a/3) / (b/2) = 11-22 for b/a = 0.03-0.06, is
    # capped at the level's 8, then at 5, 2.5 (compensation to 4 and to 2.5 zone
    # half-lengths) and 1; after the isotropic attempt the error reaches the caller.
    factors = _failing_mesh(monkeypatch, failures=10)
    with caplog.at_level(logging.WARNING, logger="fe_impact.meshing"), \
            pytest.raises(MeshError, match=r"^stage 1 at \+0\.000 deg roll: .*quality"):
        toothpair.build_pair(default_gearset(), 1, 0.0, "coarse", 2, GAP, SPEED, tmp_path)
    assert factors == [(toothpair.LEVELS["coarse"].max_stretch, 4.0), (5.0, 4.0), (2.5, 4.0),
                       (2.5, 2.5), (1.0, 4.0)]
    retries = [r.getMessage() for r in caplog.records if "meshing again" in r.getMessage()]
    assert len(retries) == 4
    assert "at most 5.0" in retries[0] and "at most 1.0" in retries[-1]
    assert retries[2].endswith("at most 2.5 and the map's compensation ending 2.5 zone "
                               "half-lengths from the contact")
    assert not (tmp_path / "pair.msh").exists()


@pytest.mark.slow
def test_one_inverted_attempt_is_meshed_again_with_less_stretch(tmp_path, monkeypatch,
                                                                 caplog):
    factors = _failing_mesh(monkeypatch, failures=1)
    with caplog.at_level(logging.WARNING, logger="fe_impact.meshing"):
        pair = toothpair.build_pair(default_gearset(), 1, 0.0, "coarse", 2, GAP, SPEED,
                                    tmp_path)
    assert factors == [(toothpair.LEVELS["coarse"].max_stretch, 4.0), (5.0, 4.0)]
    (warning,) = [r for r in caplog.records if "meshing again" in r.getMessage()]
    assert warning.levelno == logging.WARNING and "at most 5.0" in warning.getMessage()
    assert warning.getMessage().startswith("stage 1 at +0.000 deg roll: ")   # which pair
    # the written mesh is the second attempt's: element sizes 5 : 1 along and across
    sizes = pair.stats.element_sizes
    assert sizes["major"] / sizes["minor"] == pytest.approx(5.0, rel=1e-12)
    assert pair.mesh_path.is_file()


def _group_areas(path) -> dict[str, float]:
    """Area of each surface group (flat triangles through the corner nodes), m^2."""
    import numpy as np

    from fe_impact.fe.mesh import load_mesh

    mesh = load_mesh(path, "mm")
    areas = {}
    for name in ("pinion_flank", "face_flank", "pinion_hub", "face_hub"):
        x = mesh.points[mesh.surface(name)[:, :3]]
        areas[name] = 0.5 * float(np.linalg.norm(
            np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1).sum())
    return areas


@pytest.mark.slow
def test_a_retry_reloads_the_sectors_it_built(tmp_path, monkeypatch):
    """The second attempt imports the first one's solids (BRep) and finds the volumes and
    the groups' faces again by their centres of mass. Each group's area is the one a
    first attempt meshes: the same exact faces, covered by another mesh, whose flat
    triangles cut the curved faces' chords (rim arc h^2 / 12 r over the hub, about
    1e-3 of it), so within 1%; a face put in the wrong group changes an area by tens
    of per cent. The scratch BRep file is removed."""
    fresh = toothpair.build_pair(default_gearset(), 1, 0.0, "coarse", 2, GAP, SPEED,
                                 tmp_path / "fresh")
    real = toothpair._mesh
    factors: list[float] = []

    def mesh(model, design, *args, **kwargs):
        factors.append(design.sizes["factor"])
        stats = real(model, design, *args, **kwargs)
        if len(factors) == 1:   # built and meshed: report it inverted after all
            raise stretchmesh.InvertedMesh("the mesh has an element of quality -0.1")
        return stats

    monkeypatch.setattr(toothpair, "_mesh", mesh)
    retried = toothpair.build_pair(default_gearset(), 1, 0.0, "coarse", 2, GAP, SPEED,
                                   tmp_path / "retried")
    assert factors[1] == 5.0
    want, got = _group_areas(fresh.mesh_path), _group_areas(retried.mesh_path)
    for name in want:
        assert got[name] == pytest.approx(want[name], rel=0.01), name
    assert not list(tmp_path.rglob("*.brep"))


def _group_centroids(path) -> dict[str, object]:
    """Area-weighted centroid of each surface group's triangles, m."""
    import numpy as np

    from fe_impact.fe.mesh import load_mesh

    mesh = load_mesh(path, "mm")
    out = {}
    for name in ("pinion_flank", "face_flank", "pinion_hub", "face_hub"):
        x = mesh.points[mesh.surface(name)[:, :3]]
        w = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
        out[name] = (w[:, None] * x.mean(axis=1)).sum(axis=0) / w.sum()
    return out


@pytest.mark.slow
def test_solids_built_at_one_position_serve_another(tmp_path, monkeypatch):
    """A process builds a stage's solids once; at another roll angle it turns them about
    each gear's axis. The turned sectors' groups against sectors built in place at that
    roll: the same faces, meshed again, so areas within 1% (as above) and centroids
    within 20 um (the triangles' chords on curved faces, 1e-3 of the hub's 12 mm
    depth; a turn about the wrong axis or by the wrong angle moves the faces by
    millimetres: one degree of pinion roll is 0.3 mm at the root)."""
    import numpy as np

    monkeypatch.setattr(solid_cache, "_SOLIDS", {})
    gs = default_gearset()
    # 1 and 3 deg: both mesh on the first attempt (+-6 deg were made again up to
    # three times with less stretch, which only cost time here)
    toothpair.build_pair(gs, 1, 1.0, "coarse", 2, GAP, SPEED, tmp_path / "built")
    assert len(solid_cache._SOLIDS) == 1
    turned = toothpair.build_pair(gs, 1, 3.0, "coarse", 2, GAP, SPEED, tmp_path / "turned")
    assert len(solid_cache._SOLIDS) == 1
    solid_cache._SOLIDS.clear()
    fresh = toothpair.build_pair(gs, 1, 3.0, "coarse", 2, GAP, SPEED, tmp_path / "fresh")
    want, got = _group_areas(fresh.mesh_path), _group_areas(turned.mesh_path)
    for name in want:
        assert got[name] == pytest.approx(want[name], rel=0.01), name
    want, got = _group_centroids(fresh.mesh_path), _group_centroids(turned.mesh_path)
    for name in want:
        assert np.linalg.norm(got[name] - want[name]) < 20e-6, name


@pytest.mark.slow
def test_solids_that_cannot_be_matched_are_built_again(tmp_path, monkeypatch, caplog):
    # If the reloaded solids' entities cannot be told apart (here: every centre of
    # mass recorded wrong), the builder logs it and builds the sectors from the
    # sections: a mesh, not an error.
    import numpy as np

    monkeypatch.setattr(solid_cache, "_SOLIDS", {})
    gs = default_gearset()
    toothpair.build_pair(gs, 1, 1.0, "coarse", 2, GAP, SPEED, tmp_path / "built")
    (solids,) = solid_cache._SOLIDS.values()
    solids.volumes = {k: c + 1.0 for k, c in solids.volumes.items()}   # 1 mm off
    solids.index = None             # not where an earlier import found them either
    with caplog.at_level(logging.WARNING, logger="fe_impact.meshing"):
        pair = toothpair.build_pair(gs, 1, 3.0, "coarse", 2, GAP, SPEED, tmp_path / "again")
    assert any("building the sectors again" in r.getMessage() for r in caplog.records)
    assert pair.mesh_path.is_file() and np.isfinite(pair.stats.min_sicn)


@pytest.mark.slow
def test_faces_taken_where_the_first_import_found_them_mesh_as_searched(tmp_path, monkeypatch,
                                                                        caplog):
    # Later imports of a stage's solids take the volumes and the groups' faces at the
    # places the first import's search by centres of mass found them (_Solids.index):
    # the same mesh as the first import's, byte for byte (at 3 deg: no retry; at this
    # gap none of 2, 4 and 6 deg meshes on the first attempt). A wrong place is
    # noticed (the face's bounding box does not hold the group face's turned
    # centre) and the faces are searched again: that mesh, from the search, must be
    # byte for byte the mesh made from the places.
    monkeypatch.setattr(solid_cache, "_SOLIDS", {})
    gs = default_gearset()
    first = toothpair.build_pair(gs, 1, 3.0, "coarse", 2, GAP, SPEED, tmp_path / "first")
    (solids,) = solid_cache._SOLIDS.values()
    assert solids.index is not None
    volumes, places = solids.index
    indexed = toothpair.build_pair(gs, 1, 3.0, "coarse", 2, GAP, SPEED, tmp_path / "indexed")
    assert indexed.mesh_path.read_bytes() == first.mesh_path.read_bytes()
    solids.index = (volumes, {g: [0] * len(p) for g, p in places.items()})   # all wrong
    with caplog.at_level(logging.INFO, logger="fe_impact.meshing"):
        searched = toothpair.build_pair(gs, 1, 3.0, "coarse", 2, GAP, SPEED,
                                        tmp_path / "searched")
    assert any("searching them by their centres" in r.getMessage() for r in caplog.records)
    assert solids.index[1] == places           # found again where the first search found them
    assert indexed.mesh_path.read_bytes() == searched.mesh_path.read_bytes()


@pytest.mark.slow
def test_solids_shared_through_a_folder_mesh_the_same(tmp_path, monkeypatch):
    # A sweep's workers share their solids through the cache (share_solids): a
    # process that finds a stage's solids there does not build them (building is
    # refused here) and its mesh is the very mesh of the process that built them.
    monkeypatch.setattr(solid_cache, "_SOLIDS", {})
    monkeypatch.setattr(solid_cache, "_SHARED", [])
    toothpair.share_solids(tmp_path / "solids")
    gs = default_gearset()
    built = toothpair.build_pair(gs, 1, 0.0, "coarse", 2, GAP, SPEED, tmp_path / "built")
    assert len(list((tmp_path / "solids").glob("*.brep"))) == 1
    solid_cache._SOLIDS.clear()          # another process: nothing in memory

    def refuse(*args, **kwargs):
        raise AssertionError("the shared solids were built again")

    monkeypatch.setattr(solid_cache, "add_sectors", refuse)
    shared = toothpair.build_pair(gs, 1, 0.0, "coarse", 2, GAP, SPEED, tmp_path / "shared")
    assert shared.mesh_path.read_bytes() == built.mesh_path.read_bytes()
    toothpair.share_solids(None)


@pytest.mark.slow
def test_a_retry_from_the_kept_surface_mesh_is_the_mesh_built_afresh(tmp_path, monkeypatch):
    # A retry starts from the first attempt's physical surface mesh (it does not
    # depend on the stretch cap): its mesh must be byte for byte the one of a
    # build whose first attempt made no surface mesh, and the kept file is gone.
    real = toothpair._mesh
    gs = default_gearset()

    def after_meshing(model, design, *args, **kwargs):   # meshes, then fails once
        stats = real(model, design, *args, **kwargs)
        if design.sizes["factor"] == toothpair.LEVELS["coarse"].max_stretch:
            raise stretchmesh.InvertedMesh("inverted (test)")
        return stats

    monkeypatch.setattr(toothpair, "_mesh", after_meshing)
    kept = toothpair.build_pair(gs, 1, 0.0, "coarse", 2, GAP, SPEED, tmp_path / "kept")
    assert not list((tmp_path / "kept").rglob(".*physical*"))
    monkeypatch.setattr(toothpair, "_mesh", real)
    _failing_mesh(monkeypatch, failures=1)               # fails before meshing
    afresh = toothpair.build_pair(gs, 1, 0.0, "coarse", 2, GAP, SPEED, tmp_path / "afresh")
    assert kept.stats.element_sizes["factor"] == afresh.stats.element_sizes["factor"] == 5.0
    assert kept.mesh_path.read_bytes() == afresh.mesh_path.read_bytes()


def test_shared_solids_are_pruned_least_recently_used_first(tmp_path):
    """Over its byte budget a shared folder drops the entries used longest ago: an
    entry taken by a process (``_shared_solids``) counts as used now."""
    import json
    import os

    folder = tmp_path / "solids"
    folder.mkdir()
    meta = {"pinion_roll": 0.0, "face_angle": 0.0, "volumes": {}, "faces": {}}
    for age, key in enumerate(("c", "b", "a")):          # a oldest, c newest
        (folder / f"{key}.brep").write_bytes(b"x" * 10)
        (folder / f"{key}.json").write_text(json.dumps(meta))
        os.utime(folder / f"{key}.json", (1e9 - age * 100, 1e9 - age * 100))
    toothpair.share_solids(folder)
    try:
        assert solid_cache._shared_solids("a") is not None   # a is used: now the newest
    finally:
        toothpair.share_solids(None)
    solid_cache._prune_shared(folder, budget=25)             # 30 bytes: one entry goes
    assert sorted(p.name for p in folder.iterdir()) == ["a.brep", "a.json", "c.brep",
                                                        "c.json"]
    solid_cache._prune_shared(folder, budget=25)             # within the budget: kept
    assert len(list(folder.iterdir())) == 4


def test_solids_key_changes_with_the_builders_source(monkeypatch):
    """Solids kept in the user's cache outlive the code that built them: their key
    holds that code's source, so other code never takes them."""
    from fe_impact.gears.pairanalysis import PairSpec

    gs = default_gearset()
    spec = PairSpec(stage=1, level="coarse")
    key = solid_cache._solids_key(gs, spec)
    assert solid_cache._solids_key(gs, PairSpec(stage=1, level="default",
                                              roll_angle_deg=3.0)) == key   # mesh only
    assert solid_cache._solids_key(gs, PairSpec(stage=2, level="coarse")) != key
    monkeypatch.setattr(solid_cache, "_builder_digest", lambda: "other source")
    assert solid_cache._solids_key(gs, spec) != key


def test_a_calibrations_solids_go_to_the_users_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert toothpair.solids_folder(tmp_path / "cache") == tmp_path / "xdg/fe-impact/solids"
    # a cache that cannot be written: the run's own cache folder
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "file"))
    assert toothpair.solids_folder(tmp_path / "cache") == tmp_path / "cache/solids"


def test_a_turned_over_element_is_first_refined_at_the_same_stretch(tmp_path, monkeypatch,
                                                                    caplog):
    """An attempt that reports where its element turned over is made again at the same
    stretch with smaller elements there (the size field's ball terms), before the
    stretch is lowered; the mesh is the refined attempt's, at the level's stretch."""
    real = toothpair._mesh
    attempts = []

    def mesh(model, design, *args, **kwargs):
        attempts.append((design.sizes["factor"], design.refine))
        if len(attempts) == 1:
            # a ball at the contact zone's centre in the stretched space, 20 um elements
            centre = tuple(float(v) for v in design.stretch.origin)
            raise stretchmesh.InvertedMesh("the mesh has an element of quality -0.1",
                                          [(*centre, 20e-6)])
        return real(model, design, *args, **kwargs)

    monkeypatch.setattr(toothpair, "_mesh", mesh)
    with caplog.at_level(logging.INFO, logger="fe_impact.meshing"):
        pair = toothpair.build_pair(default_gearset(), 1, 0.0, "coarse", 2, GAP, SPEED,
                                    tmp_path)
    level = toothpair.LEVELS["coarse"].max_stretch
    assert [a[0] for a in attempts] == [level, level]
    assert attempts[0][1] == () and len(attempts[1][1]) == 1
    assert any("same stretch" in r.getMessage() for r in caplog.records)
    assert not any("meshing again with a stretch factor" in r.getMessage()
                   for r in caplog.records)
    assert pair.stats.element_sizes["major"] / pair.stats.element_sizes["minor"] == \
        pytest.approx(level, rel=1e-12)


def test_refine_terms_are_the_distance_from_each_ball():
    """The balls' size terms: the size at the centre [mm] and the Euclidean distance
    [mm] from it, every coordinate in parentheses (gmsh's parser rejects ``x--1``;
    the refined build above has gmsh read such a term)."""
    import math

    from fe_impact.meshing.sizing import refine_terms

    ((size, expr),) = refine_terms([(-1e-3, 2e-3, -3e-3, 5e-6)])
    assert size == pytest.approx(5e-3)
    assert "--" not in expr and "+-" not in expr
    python = expr.replace("Sqrt", "math.sqrt").replace("^", "**")
    # from (-1, 2, -3) mm to (2, 6, -3) mm: 5 mm
    assert eval(python, {"math": math, "x": 2.0, "y": 6.0, "z": -3.0}) == \
        pytest.approx(5.0, rel=1e-12)


def test_many_turned_over_elements_lower_the_stretch(monkeypatch):
    """More than MAX_BALLS turned-over elements are not refined one by one (each is a
    size-field term): no balls, so the retry lowers the stretch."""
    import numpy as np

    n = stretchmesh.MAX_BALLS + 1
    monkeypatch.setattr(stretchmesh, "_qualities",
                        lambda model, volumes: (np.arange(n), np.full(n, -0.1)))
    assert stretchmesh.turned_balls(None, {}, None) == []
