"""The transient run loop: a step hook ends the run on the step it chooses, and
a frame stride thins the field frames without thinning the output history.

The rotor of tests/test_rigid_body.py (a free cube turning at constant speed,
touching nothing) is the cheapest case with a moving state.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fe_impact.fe.mesh import load_mesh
from fe_impact.solvers.dynamic import DynamicSolver
from meshes.generate import committed
from tests.test_rigid_body import rotor_case

N_STEPS = 24


@pytest.fixture(scope="module")
def rotor(tmp_path_factory):
    path = committed("two_blocks.msh")
    case = rotor_case(path, "newmark", 1e-6, N_STEPS * 1e-6)
    case = dataclasses.replace(case, analysis=dataclasses.replace(
        case.analysis, output_interval=2e-6))          # 12 output times after t = 0
    return case, load_mesh(path, "m")


def test_step_hook_stops_on_the_step_it_returns_true(rotor):
    case, mesh = rotor
    full = DynamicSolver(case, mesh).run()
    seen = []

    def hook(state, row):
        seen.append(row["time"])
        return len(seen) == 10               # the 10th recorded step: t = 9 dt

    part = DynamicSolver(case, mesh).run(step_hook=hook)
    n = len(part.history["time"])
    assert n == 10 and len(full.history["time"]) == N_STEPS + 1
    # The stopped run is exactly the first steps of the full one (same arithmetic).
    for k in part.history:
        np.testing.assert_array_equal(part.history[k], full.history[k][:n])
    assert part.history["time"][-1] == pytest.approx(9e-6, rel=1e-12)


def test_frame_stride_thins_fields_not_history(rotor):
    case, mesh = rotor
    frames = {1: [], 3: []}
    results = {s: DynamicSolver(case, mesh).run(frame_hook=lambda f, s=s: frames[s].append(f.time),
                                                frame_stride=s) for s in frames}
    out1, out3 = (results[s].output_history["time"] for s in (1, 3))
    np.testing.assert_array_equal(out1, out3)
    assert len(out1) == N_STEPS // 2 + 1
    assert frames[1] == pytest.approx(list(out1), rel=1e-12)
    # Every third output time from t = 0, and the last one.
    expected = list(out1[::3]) + ([out1[-1]] if (len(out1) - 1) % 3 else [])
    assert frames[3] == pytest.approx(expected, rel=1e-12)
    # The rotor turns at constant speed: the stride changes nothing in the state.
    assert results[3].history["kinetic_energy"][-1] == results[1].history["kinetic_energy"][-1]


def test_frame_stride_must_be_positive(rotor):
    case, mesh = rotor
    with pytest.raises(ValueError, match="frame_stride = 0"):
        DynamicSolver(case, mesh).run(frame_stride=0)
