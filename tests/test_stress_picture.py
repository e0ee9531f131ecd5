"""The calibration report's stress picture: a view of the contact, scaled to it.

A synthetic frame: a block (the flank, top face z = 0) carrying a Hertz
pressure ellipse and a smooth von Mises field, a second block above it with a
huge stress, and one far corner cell of the first block with a huge stress.
The picture must look at the first block's top along its outward normal and
scale its colours to the cells near the contact, not to the global maximum.
"""

from __future__ import annotations

import json
import logging
from types import SimpleNamespace

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")

from fe_impact.calibration import report  # noqa: E402

H = 0.25e-3                       # voxel edge (m)
A, B = 2.0e-3, 0.5e-3             # pressure ellipse semi-axes along x and y (m)
P0 = 1.2e9                        # peak pressure (Pa)
VM_PEAK = 300e6                   # von Mises near the contact (Pa)
OUTLIER = 5e9                     # a far cell of the flank body (Pa)
OTHER = 1e10                      # every cell of the other body (Pa)


def _block(origin, dims) -> pv.UnstructuredGrid:
    grid = pv.ImageData(dimensions=dims, spacing=(H, H, H), origin=origin).triangulate()
    grid.points = np.round(np.asarray(grid.points, dtype=float) / H * 100) * (H / 100)
    return grid


def _frame() -> pv.UnstructuredGrid:
    """The flank body (x in +-3.5 mm, y in +-2.5 mm, z in [-1.5, 0] mm) and the
    other body 50 um above it, not connected."""
    flank = _block((-3.5e-3, -2.5e-3, -1.5e-3), (29, 21, 7))
    other = _block((-3.5e-3, -2.5e-3, 0.05e-3), (29, 21, 3))
    x = flank.points
    r2 = (x[:, 0] / A) ** 2 + (x[:, 1] / B) ** 2
    flank.point_data["contact_pressure"] = np.where(
        np.isclose(x[:, 2], 0.0) & (r2 < 1.0), P0 * np.sqrt(np.clip(1.0 - r2, 0.0, None)), 0.0)
    c = flank.cell_centers().points
    vm = 5e6 + VM_PEAK * np.exp(-(c[:, 0] / (2 * A)) ** 2 - (c[:, 1] / (2 * B)) ** 2
                                - ((c[:, 2] + 0.5 * B) / B) ** 2)
    vm[np.argmin(np.linalg.norm(c - [3.4e-3, 2.4e-3, -1.4e-3], axis=1))] = OUTLIER
    flank.cell_data["von_mises"] = vm
    other.point_data["contact_pressure"] = np.zeros(other.n_points)
    other.cell_data["von_mises"] = np.full(other.n_cells, OTHER)
    return flank.merge(other, merge_points=False)


def _expected_window(grid: pv.UnstructuredGrid) -> tuple[np.ndarray, float, float]:
    """The in-window cells, from the footprint's nodes and the picture's rule.

    Footprint: the flank nodes strictly inside the ellipse (grid nodes at
    multiples of H, so its half-extents are 1.75 and 0.25 mm, centred at 0).
    Every voxel tetrahedron spans H along x and y, so the element size is H.
    """
    p = grid.point_data["contact_pressure"]
    foot = grid.points[p > 0]
    a, b = max(np.abs(foot[:, 0]).max(), H), max(np.abs(foot[:, 1]).max(), H)
    assert (a, b) == pytest.approx((1.75e-3, 0.25e-3), rel=1e-9)
    section = report._STRESS_SECTION * b
    fw, fh = report._FLANK
    w_major = max(report._STRESS_WINDOW_MAJOR * a, section * fw / fh)
    w_minor = w_major * fh / fw
    c = grid.cell_centers().points
    inside = ((np.abs(c[:, 0]) <= w_major) & (np.abs(c[:, 1]) <= w_minor)
              & (np.abs(c[:, 2]) <= section) & (c[:, 2] < 0.0))   # z < 0: the flank body
    return inside, w_major, w_minor


def test_window_is_at_the_contact_and_scaled_to_it():
    grid = _frame()
    w = report._contact_window(grid, normal=[0.0, 0.0, -1.0])   # the sign is found
    inside, w_major, w_minor = _expected_window(grid)
    vm = grid.cell_data["von_mises"]
    # Geometry: exact up to round-off of the voxel coordinates.
    assert w.normal == pytest.approx([0.0, 0.0, 1.0], abs=1e-12)
    assert abs(w.major[0]) == pytest.approx(1.0, abs=1e-12)
    assert w.centre == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)
    assert w.half_size == pytest.approx((w_major, w_minor), rel=1e-12)
    np.testing.assert_array_equal(w.window, inside)
    # The colour scale ends at the in-window percentile, far below the global
    # maximum (the other body's stress and the far outlier are left out).
    expected = np.percentile(vm[inside], report._STRESS_PERCENTILE)
    assert w.clim == pytest.approx((0.0, expected), rel=1e-12)
    assert w.clim[1] < VM_PEAK < OUTLIER < vm.max()
    assert w.vm_max == pytest.approx(vm[inside].max(), rel=1e-12)
    assert w.p_max == pytest.approx(grid.point_data["contact_pressure"].max(), rel=1e-12)


def _write_case(out, grid, frames=("frame_0000.vtu",)):
    fe = out / "cases" / "s1" / "fe"
    fe.mkdir(parents=True)
    if frames:
        grid.save(fe / frames[0])
    t = np.linspace(0.0, 1e-4, 11)
    summary = {"history": {"time": t.tolist(),
                           "contact_force": (100.0 * np.sin(np.pi * t / 1e-4)).tolist()},
               "fields": {"frames": list(frames), "frame_times": [5e-5] * len(frames)},
               "time_of_peak_force": 5e-5, "first_touch": 0.0,
               "model": {"contact_normal": [0.0, 0.0, 1.0], "contact_point": [0.0, 0.0, 0.0],
                         "sides": {"slave": "slave (pinion)", "master": "master (face_gear)"}}}
    (fe / "summary.json").write_text(json.dumps(summary))
    return SimpleNamespace(id="s1", stage=1, kind="mesh", impact_speed=0.05,
                           fe=SimpleNamespace(peak_force=100.0))


def test_picture_is_written_and_coloured_over_the_window(tmp_path):
    grid = _frame()
    case = _write_case(tmp_path, grid)
    path = tmp_path / "stress.png"
    assert report._plot_stress(tmp_path, (case,), path)
    from PIL import Image

    image = np.asarray(Image.open(path).convert("RGB"))
    fw, fh = report._FLANK
    assert image.shape[:2] == (report._HEADER + fh, 2 * fw + report._SECTION[0])
    # The flank panel: a smooth field over hundreds of cells in the window,
    # scaled to it, shows many colours (one colour would be 1).
    flank = image[report._HEADER:, :fw].reshape(-1, 3)
    assert len(np.unique(flank, axis=0)) > 200
    # The colour map the picture used ends at the in-window percentile.
    w = report._contact_window(grid, normal=[0.0, 0.0, 1.0])
    _, used = report._render_contact(grid, w, ("", "", ""))
    inside, _, _ = _expected_window(grid)
    expected = np.percentile(grid.cell_data["von_mises"][inside], report._STRESS_PERCENTILE)
    assert used == pytest.approx((0.0, expected), rel=1e-9)   # round trip through MPa


def test_missing_frame_is_logged_not_raised(tmp_path, caplog):
    case = _write_case(tmp_path, _frame(), frames=("frame_0000.vtu",))
    (tmp_path / "cases" / "s1" / "fe" / "frame_0000.vtu").unlink()
    with caplog.at_level(logging.WARNING):
        assert not report._plot_stress(tmp_path, (case,), tmp_path / "stress.png")
    assert "stress picture of s1 skipped" in caplog.text
    assert not (tmp_path / "stress.png").exists()
