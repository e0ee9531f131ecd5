"""End-to-end coarse calibration on a real local Dask cluster, and resuming it."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fe_impact.calibration import meshcycle
from fe_impact.cli.main import main
from fe_impact.gears import default_gearset
from fe_impact.gears.pairanalysis import PairSpec, analyse_pair
from fe_impact.physics import hertz
from tests.test_meshcycle import rack_contact_ratio


def frictionless_gearset(folder):
    """The seed set with frictionless flanks ([friction] 0 and 0), as a file in ``folder``:
    for the runs whose subject is not friction (they keep the frictionless cost)."""
    import re

    from fe_impact.gears import default_gearset_path

    text = re.sub(r"(?m)^(mu_static|mu_dynamic) = .*$", r"\1 = 0.0",
                  default_gearset_path().read_text())
    path = folder / "seed_frictionless.toml"
    path.write_text(text)
    return str(path)


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    out = tmp_path_factory.mktemp("calibration")
    argv = ["calibrate", "--stages", "1", "--impact-speeds", "0.05", "--level", "coarse",
            "--positions", "3", "--workers", "1", "--out", str(out / "run"),
            "--cache", str(out / "cache")]
    assert main(argv) == 0
    return out, argv


def test_mesh_cycle_outputs(calibrated):
    """The path's two ends and middle measured quasi-statically, their laws in
    calibration.json."""
    out, _ = calibrated
    run = out / "run"
    law = json.loads((run / "calibration.json").read_text())["mesh_cycle"]["1"]
    first, last = meshcycle.path_of_contact(default_gearset(), 1)
    assert len(law["roll_angle_deg"]) == 3
    # The ends are moved inward by the coarse level's inset of the path (the exact
    # ends are edges where the contact analysis has no contact point); --level coarse
    # puts the positions on coarse meshes too (the level below, coarse at the least).
    inset = meshcycle.END_INSETS["coarse"] * abs(first - last)
    ends = sorted([first - inset, last + inset])
    assert sorted(law["roll_angle_deg"]) == pytest.approx([ends[0], sum(ends) / 2, ends[1]],
                                                          abs=1e-9)
    cycle = json.loads((run / "mesh_cycle.json").read_text())
    pinion = default_gearset().pinion
    # the mesh cycle is made of the positions with the seed's flank friction, or of
    # positions that say why they were solved without it
    assert all(p["friction"] == [0.05, 0.02] or "solved frictionless" in p["friction_note"]
               for p in cycle["positions"])
    assert len(cycle["positions"]) == 3
    for pos in cycle["positions"]:
        f, d, h = (np.asarray(pos[k]) for k in ("forces", "approaches", "hertz_approaches"))
        loaded = f >= meshcycle.FIT_MIN_FORCE
        # The approach holds the teeth's bending besides the contact: the Hertz
        # approach of the contact alone is a lower bound from 50 N up (below,
        # the patch is narrower than an element and the FE is stiffer).
        assert np.all(d[loaded] > h[loaded])
        # The pinion's torque is carried by the contact's normal force times the lever
        # and by the flank friction's moment, which is at most mu_static F times the
        # contact's distance from the pinion axis (inside the tip radius r_a), to the
        # tilt of the normal over the patch (5e-3, as frictionless below).
        t = np.abs(np.asarray(pos["torques"]))
        r_a = pinion.pitch_radius + pinion.addendum_coeff * pinion.module
        assert np.all(np.abs(t / pos["lever"] - f) <= (0.05 * r_a / pos["lever"] + 5e-3) * f)
        assert pos["fit_error"] < 0.05
    # Frictionless, the torque is carried by the normal force alone: torque / lever =
    # contact force, to the tilt of the normal over the patch (1e-3).
    (alone,) = [json.loads(p.read_text()) for p in run.glob("cases/*_frictionless/result.json")
                if "roll" in p.parent.name]
    assert alone["friction"] == [0.0, 0.0] and alone["companion"]
    t = np.abs(np.asarray(alone["torques"]))
    assert t / alone["lever"] == pytest.approx(np.asarray(alone["forces"]), rel=5e-3)
    # One mesh cycle: a roll of one angular pitch with two pairs over
    # (contact ratio - 1) of it, the contact ratio in closed form; to a sample
    # of the cycle's roll angles either way.
    eps = rack_contact_ratio(default_gearset().pinion)
    for c in cycle["cycles"]:
        two = np.mean(np.asarray(c["pairs"]) == 2)
        assert two == pytest.approx(eps - 1.0, abs=2.0 / len(c["pairs"]))
    for name in ("mesh_cycle.csv", "contact_pattern.png", "stiffness_along_path.png",
                 "transmission_error.png"):
        assert (run / name).stat().st_size > 100, name


def test_the_run_ends_with_the_seed_studies_it_has_laws_for(calibrated):
    """Stage 1 calibrated: the seed's Table 1 study runs on it (the others engage stages
    without laws) and the report tables what its own statistics.json holds."""
    out, _ = calibrated
    run = out / "run"
    assert json.loads((run / "summary.json").read_text())["switching"] == ["switching/table1"]
    study = run / "switching" / "table1"
    stats = json.loads((study / "statistics.json").read_text())
    assert stats["status"] == "completed" and len(stats["cases"]) == 3
    assert "calibration.json" in stats["model"]["laws"]      # its laws, not closed forms
    assert (study / "report.md").is_file() and (study / "impacts.png").stat().st_size > 100
    impacts = sum(c["impact_statistics"]["all"]["all"]["count"]
                  for c in stats["cases"].values() if "all" in c["impact_statistics"])
    row = next(line for line in (run / "report.md").read_text().splitlines()
               if line.startswith("| table1 |"))
    assert row.split(" | ")[3].split(" ")[0] == str(impacts)
    assert not (run / "switching" / "table2").exists()


def test_calibration_outputs(calibrated):
    out, _ = calibrated
    doc = json.loads((out / "run" / "calibration.json").read_text())
    assert doc["schema"] == "fe-impact/calibration/2"
    (case,) = doc["cases"]
    fe, law, tca_mass = case["fe"], case["impact"], case["effective_mass"]
    # Elastic tooth impact below the yield speed: the FE restitution is close to 1
    # (wave loss only); the approach and force are checked against a static
    # solve of the same mesh in test_tooth_impact_against_its_quasi_static_solve.
    assert 0.98 < fe["restitution"] <= 1.0 + 1e-3
    # Each rotor carries its sector, so the pair flies rigidly to first touch and
    # closes at the speed its rotors were given: the probe's velocity (at the FE node
    # of the first touch, along its normal) differs from the contact analysis' only
    # by where that node and normal lie, of order h / R (a sector at rest behind
    # its turning hub closed at 0.90 of it)
    assert fe["impact_velocity"] == pytest.approx(case["impact_speed"], rel=1e-3)
    # Newmark's average acceleration conserves kinetic + strain + penalty energy
    # up to the contact switches (the sphere impacts close to 1e-4).
    assert fe["energy_error"] < 1e-3
    # The fitted law reproduces the FE history it was fitted to (relative RMS of force).
    assert case["fit_quality"]["residual_force_rms"] < 0.05
    assert law["k"] > 0 and tca_mass > 0
    # eq. 15 for 20CrMnTi is 0.0866 m/s (docs/references.md, "Hertz impact, wave loss
    # and yield onset");
    # at 0.05 m/s the seed's eq. 14 says elastic, like the FE.
    models = case["restitution_models"]
    assert models["v_y_eq15"] == pytest.approx(0.0866, rel=1e-3)
    assert models["seed_eq14"] == 1.0
    # The tooth's own yield-onset speed: its Hertz impact there (the record's
    # effective mass, the one its fit and closed form take; the equivalent radius)
    # loads the TCA ellipse to p0 = 1.6 Y.
    tca = analyse_pair(default_gearset(), PairSpec(stage=1, level="coarse",
                                                   gap=case["initial_gap"],
                                                   impact_speed=case["impact_speed"]))
    e_star = tca.effective_modulus
    hit = hertz.impact(tca_mass, models["v_y_tooth"], tca.equivalent_radius,
                       e_star)
    rx, ry = tca.contact.relative.radii
    p0 = hertz.ellipse_contact(hit.force_max, rx, ry, e_star).p0
    assert p0 == pytest.approx(1.6 * 835e6, rel=1e-6)
    for name in ("calibration.csv", "report.md", "force_time.png", "parameters.png"):
        assert (out / "run" / name).stat().st_size > 100, name
    assert (out / "run" / "cases" / case["id"] / "fe" / "impact.pvd").exists()
    # the worker rendered the case's row of stress.png; the report stacked it as is
    from PIL import Image

    row = np.asarray(Image.open(out / "run" / "cases" / case["id"] / "contact.png"))
    stress = np.asarray(Image.open(out / "run" / "stress.png"))
    np.testing.assert_array_equal(stress[:row.shape[0], :row.shape[1]], row)


def _quasi_static_tooth_pair(case_file, max_approach):
    """Static solve of the impact's own tooth-pair mesh, hubs held instead of rotating.

    The face-gear hub is fixed and the pinion hub is pushed along the contact
    normal (the master normal at the node of the smallest weighted gap, where
    the impact measures its approach) to the initial gap plus 0.25 ... 1.1 of
    the impact's largest approach. The hubs' rigid motions differ from the
    impact's rotations only by a rigid motion, which leaves the contact force
    at a given normal approach unchanged up to the tangential slide (microns
    on flanks curved over millimetres).
    """
    from dataclasses import replace

    import numpy as np

    from fe_impact.contact.zone import contact_pairs, reference_states
    from fe_impact.fe.case import AnalysisSpec, DisplacementSpec, SupportSpec, load_case
    from fe_impact.fe.elasticity import build_model
    from fe_impact.fe.mesh import load_mesh
    from fe_impact.solvers.static import StaticSolver

    impact = load_case(case_file)
    mesh = load_mesh(impact.mesh_file, impact.unit)
    held = replace(impact, rigid_bodies=(), initial_velocities=(),
                   supports=(SupportSpec("face_hub", (0, 1, 2)),), analysis=AnalysisSpec())
    pairs = contact_pairs(held, mesh, build_model(mesh, held.materials))
    st = reference_states(mesh, pairs)[0]
    k = int(np.argmin(np.where(np.isfinite(st.gap), st.gap, np.inf)))
    gap, normal = float(st.gap[k]), st.normal[k]
    approach = max_approach * np.array([0.25, 0.5, 0.75, 1.0, 1.1])
    push = tuple(DisplacementSpec("pinion_hub", i, tuple(-(gap + a) * normal[i] for a in approach))
                 for i in range(3))
    solver = StaticSolver(replace(held, displacements=push), mesh)
    return impact, solver, solver.run(), approach, st.point[k], normal


@pytest.mark.slow
def test_tooth_impact_against_its_quasi_static_solve(calibrated):
    """The tooth impact against the static solve of its own mesh; the hub reactions.

    Quasi-static impact: the effective mass at the impact speed spends its
    kinetic energy on the static force-approach curve, which gives the
    largest approach. The impact lasts many periods of the teeth's lowest
    modes, so the FE must reach it within 1% (a 1% error of the force over
    the loading branch moves it by 0.7%; measured -0.25%). The force
    oscillates about the static curve with the teeth's vibration, and the
    peak can sit anywhere in that swing. The peak force is compared with the
    static curve's force at the impact's own largest approach (so the
    approach's error above does not enter it), to 1%: the sum of the swing
    (each rotor carries its sector, so the teeth start in rigid motion:
    0.5% of the local force, ``validation/mesh_cycle.py`` on this stage and
    level), the peak's time-step error at the calibration's 60 steps per
    contact (0.14%, ``validation/time_step.py``) and the interpolation of
    the static curve between its five loads (PCHIP on a force growing as
    approach^1.4-1.5 sampled every quarter of the range: below 0.2% from
    0.5 of the range up), 0.84%, rounded up.

    Action and reaction, in the static solve at the impact's largest approach:
    K u sums to zero to round-off, and the reactions of the two hubs are equal
    and opposite to the second order of the normals' mismatch: the static
    solver condenses the zone nodes' normal coordinates only, so each node's
    contact force acts along its own surface normal, and slave and master
    normals across the patch differ by a / R (a few per mille), which leaves
    an imbalance of order (a / R)^2: held to 1e-4, (1e-2)^2 (measured 6.6e-6
    of the force). Each hub's reaction
    equals the contact force, and each hub's torque about its gear's axis over
    its lever arm at the contact point equals the contact force within 1%
    (the normals vary over the contact patch by a / R, a few per mille;
    measured 0.06%).
    """
    import numpy as np
    from scipy.interpolate import PchipInterpolator
    from scipy.optimize import brentq

    out, _ = calibrated
    # the impact's frictionless companion (the static solve is frictionless), on the
    # impact's own mesh
    case = json.loads((out / "run" / "cases" / "stage1_mesh_50mms_frictionless" /
                       "result.json").read_text())
    fe = case["fe"]
    (case_file,) = (out / "cache" / "meshes").glob(
        "*/case_newmark_calibration_frictionless.toml")
    impact, solver, result, approach, x_c, normal = _quasi_static_tooth_pair(
        case_file, fe["max_approach"])
    force = np.array([s.contact_force[0] for s in result.steps])
    curve = PchipInterpolator(np.concatenate([[0.0], approach]), np.concatenate([[0.0], force]))
    work = curve.antiderivative()
    energy = 0.5 * case["effective_mass"] * fe["impact_velocity"] ** 2
    reach = brentq(lambda d: float(work(d)) - energy, 1e-3 * approach[0], approach[-1])
    assert fe["max_approach"] == pytest.approx(reach, rel=0.01)
    assert fe["peak_force"] == pytest.approx(float(curve(fe["max_approach"])), rel=0.01)

    step = result.steps[3]                       # at the impact's largest approach
    mesh, K = solver.mesh, solver.model.K
    ok = mesh.point_dof >= 0
    u = np.zeros(K.shape[0])
    for c in range(3):
        u[3 * mesh.point_dof[ok] + c] = step.u[ok, c]
    r = K @ u
    bodies = {b.surface: b for b in impact.rigid_bodies}
    resultants = []
    for hub in ("pinion_hub", "face_hub"):
        pts = mesh.surface_points(hub)
        reaction = np.stack([r[3 * mesh.point_dof[pts] + c] for c in range(3)], axis=1)
        axis, point = np.array(bodies[hub].direction), np.array(bodies[hub].point)
        torque = float(np.sum(np.cross(mesh.points[pts] - point, reaction) @ axis))
        lever = abs(float(np.cross(x_c - point, normal) @ axis))
        assert abs(torque) / lever == pytest.approx(step.contact_force[0], rel=0.01), hub
        resultants.append(reaction.sum(axis=0))
    pinion, face = resultants
    total = (K @ u).reshape(-1, 3).sum(axis=0)
    assert np.linalg.norm(total) < 1e-9 * np.linalg.norm(pinion)
    assert np.linalg.norm(pinion + face) < 1e-4 * np.linalg.norm(pinion)
    assert np.linalg.norm(pinion) == pytest.approx(step.contact_force[0], rel=1e-3)


def test_terminal_summary_repeats_the_calibration(calibrated):
    # the lines the command ends with carry calibration.json's own figures
    from fe_impact.calibration.report import terminal_summary

    out, _ = calibrated
    doc = json.loads((out / "run" / "calibration.json").read_text())
    lines = terminal_summary(doc)
    case, path = doc["cases"][0], doc["mesh_cycle"]["1"]
    assert len(lines) == 2 and lines[0].startswith("stage 1: 1 FE impact at 50 mm/s")
    assert f"K {case['impact']['k']:.3g} N/m^e" in lines[0]
    assert f"closed form {case['closed_form']['k']:.3g}" in lines[0]
    assert f"mesh cycle at {len(path['k'])} positions" in lines[1]
    stiff = sorted(path["nominal_stiffness"])
    assert f"{stiff[0]:.3g}-{stiff[-1]:.3g} N/m" in lines[1]


def test_rerun_resumes_without_recomputing(calibrated):
    out, argv = calibrated
    result = out / "run" / "cases" / "stage1_mesh_50mms" / "result.json"
    stamp = result.stat().st_mtime_ns
    (out / "run" / "calibration.json").unlink()     # as if stopped before the tables
    assert main(argv) == 0
    assert result.stat().st_mtime_ns == stamp         # the finished case was kept
    doc = json.loads((out / "run" / "calibration.json").read_text())
    # the tables are written again from the kept case
    assert [c["id"] for c in doc["cases"]] == ["stage1_mesh_50mms"]


def test_ctrl_c_keeps_finished_cases_and_rerun_completes(calibrated, tmp_path):
    """Ctrl-C during a sweep: exit status 130, finished cases kept, a rerun does the rest.

    A real SIGINT to the command line, sent once the first of two cases has
    written its result; with one worker the second case is still running.
    """
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    cache = calibrated[0] / "cache"
    argv = ["calibrate", frictionless_gearset(tmp_path), "--no-switching", "--stages", "1",
            "--impact-speeds", "0.05,0.08", "--level", "coarse", "--no-mesh-cycle",
            "--workers", "1", "--out", str(tmp_path / "run"), "--cache", str(cache)]
    exe = Path(sys.executable).with_name("fe-impact")
    proc = subprocess.Popen([str(exe), *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    first = tmp_path / "run" / "cases" / "stage1_mesh_50mms" / "result.json"
    deadline = time.monotonic() + 300
    while not first.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.5)
    assert first.exists(), proc.communicate()[1][-2000:]
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err[-2000:]
    assert "interrupted" in err
    assert not (tmp_path / "run" / "calibration.json").exists()
    stamp = first.stat().st_mtime_ns
    json.loads(first.read_text())                          # complete, not half-written
    assert main(argv) == 0
    assert first.stat().st_mtime_ns == stamp                # kept, not recomputed
    doc = json.loads((tmp_path / "run" / "calibration.json").read_text())
    assert [c["id"] for c in doc["cases"]] == ["stage1_mesh_50mms", "stage1_mesh_80mms"]


def test_ratio_switch_impact_yields(tmp_path):
    """``--switch`` adds the eq. 5 ratio-switch impact, which is elastic-plastic.

    Stage 2 at 1000 r/min, coarse, two workers. The in-mesh impact (0.125 m/s)
    is below the tooth pair's yield-onset speed (v/v_y = 0.39) and stays
    elastic; the switch closes at about 4.2 m/s (v/v_y = 13) and yields:
    measured e = 0.687 with about half the energy dissipated plastically. The
    energy balance (kinetic + strain + penalty + plastic dissipation) must
    still close within 2% (measured 0.6%).
    """
    argv = ["calibrate", frictionless_gearset(tmp_path), "--no-switching", "--stages", "2",
            "--speeds", "1000", "--switch", "eq5",
            "--level", "coarse", "--no-mesh-cycle",
            "--workers", "2", "--out", str(tmp_path / "run"), "--cache", str(tmp_path / "c")]
    assert main(argv) == 0
    doc = json.loads((tmp_path / "run" / "calibration.json").read_text())
    cases = {c["kind"]: c for c in doc["cases"]}
    mesh, switch = cases["mesh"], cases["switch"]
    assert mesh["restitution_models"]["yield_ratio_tooth"] < 1.0
    assert mesh["fe"]["restitution"] > 0.99
    assert 3.0 < switch["impact_speed"] < 6.0
    assert switch["restitution_models"]["yield_ratio_tooth"] > 5.0
    assert switch["fe"]["restitution"] < 0.9
    # the switch leaves a dent; the in-mesh impact none (0 if nothing yielded)
    assert 0.0 < switch["fe"]["residual_indentation"] < switch["fe"]["max_approach"]
    assert abs(mesh["fe"]["residual_indentation"]) < 0.01 * mesh["fe"]["max_approach"]
    assert switch["fe"]["energy_error"] < 0.02
    fe = json.loads((tmp_path / "run" / "cases" / switch["id"] / "fe" / "summary.json")
                    .read_text())
    assert fe["model"]["plasticity"]["dissipation"] > 0.2 * fe["history"]["total_energy"][0]


def test_friction_section_of_the_calibration(calibrated):
    """The seed's flank friction in the calibration, and what it changes.

    The impact and the mesh-cycle position nearest the path's middle were solved
    again frictionless. Friction only dissipates: the frictional impact's
    restitution is at most the frictionless one's (to twice the ~1e-4 by which an
    elastic FE rebound scatters about its true value, integrator and penalty
    switches), and its dissipation is positive and at most the energy the impact
    lost, ``(1 - e^2) m v^2 / 2`` (to the energy balance's 1e-3 of ``m v^2 / 2``). Under one torque
    a static pair with friction turns no further than without: its sticking flanks
    add tangential stiffness (a positive semi-definite term, which cannot raise the
    compliance of the loaded rotation) and slipping ones a force opposing the slip;
    to the solves' own tolerances (load root 1e-9, frictional Newton 1e-10: 1e-6).
    """
    out, _ = calibrated
    doc = json.loads((out / "run" / "calibration.json").read_text())
    fr = doc["friction"]
    assert (fr["mu_static"], fr["mu_dynamic"]) == (0.05, 0.02)
    (case,) = doc["cases"]
    assert case["friction"] == [0.05, 0.02] and not case["companion"]
    imp = fr["impact"]
    assert imp["id"] == case["id"]
    rough, smooth = imp["with"], imp["without"]
    assert rough["restitution_measured"] <= smooth["restitution_measured"] + 2e-4
    assert smooth["friction_dissipation"] == 0.0
    energy = 0.5 * case["effective_mass"] * case["fe"]["impact_velocity"] ** 2
    lost = (1.0 - rough["restitution_measured"] ** 2) * energy
    assert 0.0 < rough["friction_dissipation"] <= lost + 1e-3 * energy
    pos = fr["position"]
    assert len(pos["torques"]) == 2 and pos["torques"][0] < pos["torques"][1]
    for te, te0 in zip(pos["te_with"], pos["te_without"], strict=True):
        assert 0.0 < te <= te0 * (1.0 + 1e-6)
    report = (out / "run" / "report.md").read_text()
    assert "## Flank friction" in report and imp["id"] in report and pos["id"] in report


def test_the_tooth_root_stress_is_taken_under_the_largest_flank_force(calibrated):
    # The sweep's workers compute each stage's tooth-root stress once its flank positions
    # are done: under the largest contact force of those positions' records, and the
    # report has its section.
    out, _ = calibrated
    run = out / "run"
    cycle = json.loads((run / "mesh_cycle.json").read_text())
    largest = max(max(p["forces"]) for p in cycle["positions"]
                  if p["stage"] == 1 and p["contact"] == "flank")
    root = json.loads((run / "root_stress" / "stage1.json").read_text())
    assert root["normal_force_N"] == largest
    assert "## Tooth-root bending stress" in (run / "report.md").read_text()
