"""Closest-point projection on a curved 6-node master surface, searched and hinted.

Independent truth: the master is a cylinder patch of radius 10 mm, its 6-node
triangles' nodes on the cylinder; a point at height ``h`` above a node of
the grid projects onto the surface at ``R + h`` from the axis, within the
P2 interpolation error of the faces: an arc of angle ``d`` interpolated
quadratically deviates by at most ``R d^3 / (9 sqrt 3)`` = 3e-9 m at the
faces' ``d`` = 1/60 rad, so 5e-9 m. The hinted projection must agree with the search wherever
both find one (same face, gaps to round-off).
"""

from __future__ import annotations

import numpy as np
import pytest

from fe_impact.contact.surfaces import _HINT_MARGIN, ContactSurface, _project_hinted, project

R = 0.01          # m
N = 12            # grid cells per side


def _cylinder_patch(shift: float = 0.0):
    """P2 triangles on a cylinder patch (axis y) of 0.2 rad by 2 mm; points (n, 3)."""
    m = 2 * N + 1                               # nodes per side, mid-sides included
    th = np.linspace(-0.1, 0.1, m)
    y = np.linspace(-1e-3, 1e-3, m)
    T, Y = np.meshgrid(th, y, indexing="ij")
    x = np.stack([R * np.sin(T), Y, R * np.cos(T) + shift], axis=-1).reshape(-1, 3)
    idx = np.arange(m * m).reshape(m, m)
    faces = []
    for i in range(0, m - 1, 2):
        for j in range(0, m - 1, 2):
            a, b, c, d = idx[i, j], idx[i + 2, j], idx[i + 2, j + 2], idx[i, j + 2]
            # corners, then mid-sides 01, 12, 20 (meshio/VTK order); outward = +r
            faces.append([a, c, d, idx[i + 1, j + 1], idx[i + 1, j + 2], idx[i, j + 1]])
            faces.append([a, b, c, idx[i + 1, j], idx[i + 2, j + 1], idx[i + 1, j + 1]])
    return x, np.array(faces)


def test_hinted_projection_is_the_searched_one():
    x, faces = _cylinder_patch()
    surface = ContactSurface("master", faces)
    rng = np.random.default_rng(0)
    n = 4000
    th = rng.uniform(-0.09, 0.09, n)
    y = rng.uniform(-0.9e-3, 0.9e-3, n)
    h = rng.uniform(-20e-6, 20e-6, n)
    pts = np.stack([(R + h) * np.sin(th), y, (R + h) * np.cos(th)], axis=1)
    all_faces = np.arange(len(faces))
    searched = project(pts, surface, x, all_faces)
    assert searched.valid.all()
    # the closest point of the exact cylinder is at radius R: gap = h
    np.testing.assert_allclose(searched.gap, h, rtol=0, atol=5e-9)
    # a hint from the surface 1 um away (the last configuration of a load step)
    x_old, _ = _cylinder_patch(shift=1e-6)
    old = project(pts, surface, x_old, all_faces)
    hinted = project(pts, surface, x, all_faces, hint=old)
    assert hinted.valid.all()
    # most points keep their face: the others lie within the margin of an edge,
    # three strips of 1 - (1 - 0.02)^2 = 4% of a face each, 12% (88% kept here)
    kept = _project_hinted(pts, x, faces.astype(np.int64), old.face, old.xi, old.eta, 6,
                           _HINT_MARGIN)[0]
    assert kept.mean() > 0.6
    np.testing.assert_array_equal(hinted.face, searched.face)
    np.testing.assert_allclose(hinted.gap, searched.gap, rtol=0, atol=1e-15)
    np.testing.assert_allclose(hinted.xi, searched.xi, rtol=0, atol=1e-9)
    # a hint with no face (an invalid projection) or for other points is searched
    no_face = project(pts, surface, x, all_faces, hint=type(old)(
        np.zeros(n, bool), old.face, old.xi, old.eta, old.point, old.normal, old.gap))
    np.testing.assert_array_equal(no_face.face, searched.face)
    wrong_size = project(pts[:10], surface, x, all_faces, hint=old)
    np.testing.assert_array_equal(wrong_size.face, searched.face[:10])


def test_a_stale_hint_is_searched_again():
    # A hint whose face no longer holds the point (the point moved one face on)
    # ends outside that face: the point is searched, and finds its new face.
    x, faces = _cylinder_patch()
    surface = ContactSurface("master", faces)
    all_faces = np.arange(len(faces))
    pts = np.array([[R * np.sin(0.0123), 2e-4, R * np.cos(0.0123)]])
    searched = project(pts, surface, x, all_faces)
    moved = np.array([[R * np.sin(0.05), -3e-4, R * np.cos(0.05)]])
    stale = project(moved, surface, x, all_faces)
    assert stale.face[0] != searched.face[0]
    hinted = project(pts, surface, x, all_faces, hint=stale)
    assert hinted.face[0] == searched.face[0]
    assert hinted.gap[0] == pytest.approx(searched.gap[0], abs=1e-15)


def _curved_face(rng, stretch: float, bend: float) -> np.ndarray:
    """A 6-node triangle, ``stretch`` times longer than wide, its mid-side nodes
    off their chords by up to ``bend`` times the edge (a 0.3 mm face of a 10 mm
    radius flank: 0.004)."""
    corners = np.array([[0.0, 0.0, 0.0], [stretch, 0.0, 0.0], [0.3 * stretch, 1.0, 0.0]])
    corners = corners + rng.normal(0.0, 0.1, (3, 3))
    mids = 0.5 * (corners + np.roll(corners, -1, axis=0))
    edges = np.linalg.norm(np.roll(corners, -1, axis=0) - corners, axis=1)
    mids = mids + rng.uniform(-bend, bend, (3, 3)) * edges[:, None]
    return 1e-4 * np.vstack([corners, mids])


@pytest.mark.parametrize("stretch", [1.0, 8.0])
@pytest.mark.parametrize("bend", [0.2, 0.01])
def test_the_search_skips_only_faces_without_an_inside_closest_point(stretch, bend):
    """The flat pre-check (:func:`_far_outside`) against the Gauss-Newton iteration.

    Independent truth: a point's closest points on the face found by 40
    Gauss-Newton steps from a grid of 28 starts (the stationary points
    inside the face). Where one lies inside, the pre-check must not skip the
    face, for points from a tenth of a face to ten faces away, on faces bent
    far more than a flank's (``bend`` 0.2) and as much (0.01), isotropic and
    eight times longer than wide. On the isotropic flank-like faces it must
    skip most of the faces whose stationary points all lie far outside (the
    search's saving; on a stretched face bent along its length the bound
    across it is wide, and little is skipped).
    """
    from fe_impact.contact.surfaces import _far_outside, _gauss_newton, _scratch

    rng = np.random.default_rng(1)
    tol = 1e-6
    inside = skipped = far_out = 0
    grid = [(a, b) for a in np.linspace(0, 1, 7) for b in np.linspace(0, 1, 7) if a + b <= 1]
    N, dxi, deta, pos, t1, t2 = _scratch(6)
    for _ in range(200):
        X = _curved_face(rng, stretch, bend)
        size = np.linalg.norm(X[1] - X[0])
        cent = X[:3].mean(axis=0)
        control = np.vstack([X[:3], 2.0 * X[3:] - 0.5 * (X[:3] + np.roll(X[:3], -1, axis=0))])
        reach = np.linalg.norm(control - cent, axis=1).max()
        for _ in range(40):
            p = cent + rng.normal(0.0, 1.0, 3) * size * rng.choice([0.1, 1.0, 3.0, 10.0])
            far = np.linalg.norm(p - cent) + reach
            ends = []
            for xi0, eta0 in grid:
                xi, eta, step = _gauss_newton(p, X, xi0, eta0, 40, N, dxi, deta, pos, t1, t2)
                if step < 1e-12:
                    ends.append((xi, eta))
            hit = any(xi >= -tol and eta >= -tol and xi + eta <= 1 + tol for xi, eta in ends)
            skip = _far_outside(p, X, far, 2.0 * tol)
            if hit:
                inside += 1
                assert not skip, (p, X)
            elif ends and all(min(xi, eta, 1 - xi - eta) < -0.5 for xi, eta in ends):
                far_out += 1
                skipped += skip
    assert inside > 500 and far_out > 500
    if bend <= 0.01 and stretch == 1.0:
        assert skipped > 0.5 * far_out
