"""The contact core against independent truths: a uniform pressure between
non-matching meshes (the patch test), the penalty's area at a master edge, a
block sliding across the master under a load, and the auto penalty's element
size. Each test failed on the code before its fix (see the commit messages).
"""

from __future__ import annotations

import numpy as np
import pytest

from fe_impact.contact.surfaces import ContactPair, ContactSurface, project
from fe_impact.fe.case import (
    AnalysisSpec,
    Case,
    ContactSpec,
    MaterialSpec,
    RigidBodySpec,
    SupportSpec,
)
from fe_impact.fe.mesh import load_mesh
from fe_impact.solvers.static import StaticSolver
from validation import patch_test as pt

E, NU, RHO = pt.E, pt.NU, pt.RHO


@pytest.mark.parametrize("coarse", ["upper", "lower"])
@pytest.mark.parametrize("slave", ["upper", "lower"])
def test_patch_test_uniform_pressure_at_every_node(tmp_path_factory, coarse, slave):
    # Two blocks of one material under a uniform compression: the exact
    # contact pressure is uniform and known in closed form with the penalty's
    # compliance (validation/patch_test.py). 0.1% at every slave node is the
    # issue's requirement: far above the solver's tolerance (1e-9 here) and
    # far below the +-3.9% of a slave quadrature not split at the master's
    # edges (coarse slave over fine master; 0.3% with the fine slave).
    r = pt.run_one(tmp_path_factory.getbasetemp() / "patch", coarse, slave)
    assert r.max_error <= pt.PRESSURE_TOL


@pytest.fixture(scope="module")
def overhang(tmp_path_factory):
    """An upper block half over the lower one's edge: footprints 1 x 1 mm, the
    upper one shifted by half its width along x; non-matching meshes."""
    path = tmp_path_factory.mktemp("overhang") / "overhang.msh"
    pt.build_blocks(path, pt.BlockSpec(0.5e-3, 0.0, 1e-3, 1e-3, 0.5e-3, 1e-3 / 3),
                    pt.BlockSpec(0.0, 0.0, 1e-3, 1e-3, 0.5e-3, 1e-3 / 7), gap=0.0)
    return load_mesh(path, "m")


def test_penalty_area_is_the_area_the_gap_averages(overhang):
    # The penalty force of a node is eps * area * <-g>, with g averaged over
    # the part of its support that a master face covers. If the area is the
    # whole support, a node half over the master edge takes the force of its
    # whole area on the gap of its covered half. Independent truth: the test
    # functions sum to one, so the areas of the nodes that see the master sum
    # to the covered area, here the 0.5 x 1 mm overlap of the footprints.
    # Tolerance: the nodes covered on less than 1e-3 of their support are left
    # out, at most 1e-3 of a node's area each along the edge (~1e-3 in all).
    mesh = overhang
    pair = ContactPair(ContactSurface.from_mesh(mesh, "upper_bottom"),
                       ContactSurface.from_mesh(mesh, "lower_top"), 1.0)
    st = pair.gap_state(mesh, np.zeros((mesh.n_points, 3)), np.arange(len(pair.slave.faces)),
                        np.arange(len(pair.master.faces)))
    seen = np.isfinite(st.gap)
    assert st.weight[seen].sum() == pytest.approx(0.5e-6, rel=1e-3)


def _oblique_case(mesh_file, load: float) -> Case:
    """The upper block tied by its top to a rigid body that moves along a
    direction tilted 78.7 deg from the normal, under a load along it."""
    d = np.array([1.0, 0.0, -0.2])
    d /= np.linalg.norm(d)
    return Case(path=mesh_file.with_suffix(".case"), mesh_file=mesh_file, unit="m",
                materials=(MaterialSpec(("upper", "lower"), E, NU, RHO),),
                contacts=(ContactSpec("upper_bottom", "lower_top"),),
                supports=(SupportSpec("lower_bottom", (0, 1, 2)),),
                rigid_bodies=(RigidBodySpec("upper_top", "translation", tuple(d),
                                            loads=(load,)),),
                analysis=AnalysisSpec())


def test_nodes_that_slide_across_the_zone_are_found_again(tmp_path_factory):
    # A 1 mm block 0.25 mm above a 3 x 2 mm block, pushed by a load along a
    # direction five times more tangential than normal: it slides 1.25 mm
    # before it touches, beyond the master faces of its initial zone (before
    # the fix, 14 of its 31 nodes lost their gap and 0.72 um of penetration
    # went unseen).
    # Independent truth: geometry. Every slave node that penetrates the
    # deformed master must carry a contact pressure (frictionless, the
    # pressure is the only force the contact has); a node dropped from the
    # zone penetrates without one.
    folder = tmp_path_factory.mktemp("oblique")
    path = folder / "oblique.msh"
    pt.build_blocks(path, pt.BlockSpec(0.25e-3, 0.5e-3, 1e-3, 1e-3, 0.5e-3, 0.25e-3),
                    pt.BlockSpec(0.0, 0.0, 3e-3, 2e-3, 0.5e-3, 0.25e-3), gap=0.25e-3)
    mesh = load_mesh(path, "m")
    step = StaticSolver(_oblique_case(path, 20.0), mesh).run().steps[0]
    x = mesh.points + step.u
    slave = ContactSurface.from_mesh(mesh, "upper_bottom")
    master = ContactSurface.from_mesh(mesh, "lower_top")
    nodes = np.unique(slave.faces)
    proj = project(x[nodes], master, x, np.arange(len(master.faces)))
    # slid: the block's bottom now lies over master faces it was far from
    assert step.u[nodes, 0].min() > 1.2e-3
    # The penalty penetration at this load is ~1e-10 m; a node is penetrating
    # when its gap is below -1e-12 m, 1% of that, far above the round-off of
    # gaps (1e-19 m on millimetre coordinates).
    penetrating = proj.valid & (proj.gap < -1e-12)
    assert penetrating.sum() > 0.5 * len(nodes)
    unseen = penetrating & (step.pressure[nodes] <= 0.0)
    assert not unseen.any(), (f"{unseen.sum()} of {len(nodes)} slave nodes penetrate by up "
                              f"to {-proj.gap[unseen].min():.3g} m without a contact force")


def test_auto_penalty_takes_the_size_of_the_contact_faces(coarse_hertz_case):
    # The coarse Hertz specimen is meshed at h_contact = 0.2 mm within 0.8 mm of
    # the contact point and coarsens to 2.5 mm away from it (meshes/README.md):
    # the auto penalty 1000 E*/h must take the h of the faces that touch. Gmsh
    # meets a size target with edges spread around it; their median lies within
    # 15% of it (measured 0.190 mm). The whole surface group's median (0.54 mm,
    # +170%) made the penalty 2.8 times softer than its factor says.
    from fe_impact.contact.zone import PENALTY_FACTOR, contact_pairs, pair_modulus
    from fe_impact.fe.case import load_case
    from fe_impact.fe.elasticity import build_model

    case = load_case(coarse_hertz_case)
    mesh = load_mesh(case.mesh_file, case.unit)
    model = build_model(mesh, case.materials)
    (pair,) = contact_pairs(case, mesh, model)
    h = PENALTY_FACTOR["linear"] * pair_modulus(mesh, model, pair.slave, pair.master) / \
        pair.penalty
    assert h == pytest.approx(0.2e-3, rel=0.15)


def test_the_projection_fallback_is_logged_as_a_warning(coarse_hertz_case, monkeypatch,
                                                        caplog):
    # When the projection iteration alternates between two contact states the
    # solver returns their mean: an approximation the user must hear of, so a
    # warning, not an info line. The alternation is forced from the third
    # projection on (the tolerance set too tight for the iteration to stop
    # before it; the Hertz patch grows over the first projections).
    import dataclasses
    import logging

    import fe_impact.solvers.static as static
    from fe_impact.fe.case import load_case

    monkeypatch.setattr(static, "_alternates", lambda cycle, *rest: len(cycle) == 2)
    case = load_case(coarse_hertz_case)
    (push,) = case.displacements
    case = dataclasses.replace(
        case, displacements=(dataclasses.replace(push, values=push.values[-1:]),),
        analysis=dataclasses.replace(case.analysis, tolerance=1e-15))
    with caplog.at_level(logging.INFO, logger="fe_impact.solvers.static"):
        static.StaticSolver(case, load_mesh(case.mesh_file, case.unit)).run()
    hits = [r for r in caplog.records if "alternates between two states" in r.getMessage()]
    assert hits and all(r.levelno == logging.WARNING for r in hits)


def test_overlap_candidates_hold_every_overlap_and_few_others():
    """Candidate pairs of the mortar segments against a brute-force overlap test.

    Slave faces 7 um across (a tip-edge rounding's size) over master faces of
    5 um, with a few 2 mm master faces far away. Truth: a pair can overlap
    when their discs (centre, circumradius) meet, which brute force checks
    over every pair; each such pair must be a candidate. The large faces must
    not widen the search around the small ones: the candidates stay within
    the pairs closer than 2 (r_s + r_m), which the brute force counts too.
    Under one search radius taken from the largest face, every small master
    face within 4 mm of each slave face was drawn (all 3,600 here).
    """
    from fe_impact.contact.surfaces import overlap_candidates

    rng = np.random.default_rng(3)
    anchor = rng.uniform(0.0, 300e-6, (40, 3)) * [1, 1, 0]
    r_s = np.full(len(anchor), 7e-6)
    small = rng.uniform(0.0, 300e-6, (3600, 3)) * [1, 1, 0]
    big = np.array([[3e-3, 0.0, 0.0], [0.0, 3e-3, 0.0], [-3e-3, 0.0, 0.0]])
    centre = np.vstack([small, big])
    r_m = np.concatenate([np.full(len(small), 5e-6), np.full(len(big), 2e-3)])
    pi, pj = overlap_candidates(anchor, r_s, centre, r_m)
    got = set(zip(pi.tolist(), pj.tolist(), strict=True))
    d = np.linalg.norm(anchor[:, None, :] - centre[None, :, :], axis=2)
    meet = set(zip(*np.nonzero(d <= r_s[:, None] + r_m[None, :]), strict=True))
    within = np.count_nonzero(d <= 2.0 * (r_s[:, None] + r_m[None, :]))
    assert meet <= got                      # no overlap is missed
    assert len(got) == within               # and nothing beyond the pairs' own reach
    assert len(got) < 0.05 * d.size         # a few per slave face, not all 3,600
