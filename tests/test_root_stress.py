"""Tooth-root bending: the 30 deg tangent construction against ISO 6336-3's closed
forms, and the FE stress extraction against the bending of a cantilever."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fe_impact.calibration.root_stress import peak_tension
from fe_impact.errors import GeometryError
from fe_impact.gears.pinion import PinionTooth
from fe_impact.gears.root_stress import iso_section


def _inv(a: float) -> float:
    return math.tan(a) - a


def _iso_closed_form(z: int, m: float, alpha_deg: float, rho_coeff: float, d_en: float):
    """ISO 6336-3:2019 method B for an external spur gear cut by a rack without
    profile shift or protuberance (h_fP = 1.25 m): the 30 deg tangent section
    solved in closed form (the iteration for theta, then s_Fn, rho_F, h_Fe)."""
    from scipy.optimize import brentq

    a = math.radians(alpha_deg)
    h_fp, rho_fp = 1.25 * m, rho_coeff * m
    e = math.pi / 4 * m - h_fp * math.tan(a) - (1 - math.sin(a)) * rho_fp / math.cos(a)
    g = rho_fp / m - h_fp / m
    h = 2 / z * (math.pi / 2 - e / m) - math.pi / 3
    theta = brentq(lambda t: t - 2 * g / z * math.tan(t) + h, 0.0, 1.5)
    s_fn = m * (z * math.sin(math.pi / 3 - theta)
                + math.sqrt(3) * (g / math.cos(theta) - rho_fp / m))
    rho_f = m * (rho_fp / m + 2 * g ** 2 / (math.cos(theta) * (z * math.cos(theta) ** 2 - 2 * g)))
    alpha_en = math.acos(m * z * math.cos(a) / d_en)
    gamma_e = math.pi / (2 * z) + _inv(a) - _inv(alpha_en)
    alpha_fen = alpha_en - gamma_e
    h_fe = m / 2 * ((math.cos(gamma_e) - math.sin(gamma_e) * math.tan(alpha_fen)) * d_en / m
                    - z * math.cos(math.pi / 3 - theta) - g / math.cos(theta) + rho_fp / m)
    return s_fn, h_fe, rho_f, alpha_fen


@pytest.mark.parametrize("teeth, alpha_deg, rho_coeff", [
    (19, 20.0, 0.38), (28, 25.0, 0.30), (22, 22.5, 0.35), (40, 18.0, 0.30), (14, 28.0, 0.10)])
@pytest.mark.parametrize("where", ["pitch", "tip"])
def test_tangent_section_matches_iso_closed_form(teeth, alpha_deg, rho_coeff, where):
    """The construction on the generated trochoid against ISO's closed form for a
    rack-cut tooth. Tolerances: the section point is interpolated between fillet
    samples 1/4000 of the fillet apart, on a curve smooth to second order, so the
    chord, arm and angle hold to 1e-6; the radius of curvature is a three-chord
    difference quotient, first-order in the sample spacing: 1e-3."""
    m = 3e-3
    pinion = PinionTooth(teeth, m, alpha_deg, 1.0, 0.25, rho_coeff, 0.02)
    radius = pinion.pitch_radius if where == "pitch" else pinion.tip_radius
    s = iso_section(pinion, radius)
    s_fn, h_fe, rho_f, alpha_fen = _iso_closed_form(teeth, m, alpha_deg, rho_coeff, 2 * radius)
    assert s.s_fn == pytest.approx(s_fn, rel=1e-6)
    assert s.h_fe == pytest.approx(h_fe, rel=1e-6)
    assert s.alpha_fen == pytest.approx(alpha_fen, rel=1e-6, abs=1e-9)
    assert s.rho_f == pytest.approx(rho_f, rel=1e-3)


def test_tangent_section_refuses_a_load_off_the_involute():
    pinion = PinionTooth(19, 3e-3, 20.0, 1.0, 0.25, 0.38, 0.02)
    with pytest.raises(GeometryError, match="load radius .* base circle"):
        iso_section(pinion, 0.99 * pinion.base_radius)


def _cantilever(n_across: int):
    """A steel cantilever 10 x 1 x 1 (m) of P2 tetrahedra, clamped at x = 0, a shear
    force F = 1e3 N spread uniformly over the end x = L (along -y)."""
    from skfem import (
        Basis,
        ElementTetP2,
        ElementVector,
        FacetBasis,
        LinearForm,
        MeshTet,
        asm,
        condense,
        solve,
    )
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    length, force = 10.0, 1e3
    mesh = MeshTet.init_tensor(np.linspace(0, length, 10 * n_across + 1),
                               np.linspace(-0.5, 0.5, n_across + 1),
                               np.linspace(-0.5, 0.5, n_across + 1))
    basis = Basis(mesh, ElementVector(ElementTetP2()))
    lame = lame_parameters(210e9, 0.3)
    K = asm(linear_elasticity(*lame), basis)
    end = FacetBasis(mesh, basis.elem, facets=mesh.facets_satisfying(
        lambda x: np.isclose(x[0], length)))

    @LinearForm
    def shear(v, w):
        return -force * v[1]          # traction F / A over the unit end face

    f = asm(shear, end)
    clamped = basis.get_dofs(lambda x: np.isclose(x[0], 0.0)).all()
    u = solve(*condense(K, f, D=clamped))
    return mesh, u, lame, length, force


@pytest.mark.parametrize("n_across", [2, 3])
def test_peak_tension_of_a_cantilever_is_m_c_over_i(n_across):
    """Mid-span, four depths from both ends, Saint-Venant's flexure solution gives
    sigma_xx = M y / I exactly (end effects decay like exp(-pi x / h)), and the maximum
    principal stress at the outer fibre is M c / I with M = F (L - x). The P2 elements'
    linear strain fits the bilinear sigma_xx to (h_e/2)^2 / ((L - x) c) of its value
    (under 1 % at 2 elements across the depth): 2 %."""
    mesh, u, lame, length, force = _cantilever(n_across)
    centroids = mesh.p[:, mesh.t].mean(axis=1)
    region = np.flatnonzero((centroids[0] > 0.4 * length) & (centroids[0] < 0.6 * length))
    peak = peak_tension(mesh, 2, u, region, lame)
    inertia, c = 1.0 / 12.0, 0.5
    expected = force * (length - peak.point[0]) * c / inertia
    assert abs(peak.point[1]) == pytest.approx(c)          # at the outer fibre
    assert peak.point[1] > 0.0                              # the tension side (load along -y)
    assert peak.stress == pytest.approx(expected, rel=0.02)
    assert peak.element_size == pytest.approx(1.0 / n_across, rel=0.5)


def test_bending_stress_limit_is_checked_like_its_neighbours():
    from fe_impact.api import read_gearset
    from fe_impact.gears import gearset_from_dict
    from fe_impact.gears.gearset import DEFAULT_BENDING_STRESS_LIMIT

    assert read_gearset(None).material.bending_stress_limit == DEFAULT_BENDING_STRESS_LIMIT
    import tomllib
    from importlib.resources import files

    data = tomllib.loads(files("fe_impact.gears").joinpath("seed.toml").read_text())
    data["material"]["bending_stress_limit_pa"] = -5.0
    with pytest.raises(GeometryError, match=r"\[material\] bending_stress_limit_pa"):
        gearset_from_dict(data)
    data["material"]["bending_stress_limit_pa"] = 430e6
    assert gearset_from_dict(data).material.bending_stress_limit == 430e6


def test_stage_record_reads_back_what_it_wrote():
    """The calibration's workers write the record as JSON and the report reads it back."""
    import json

    from fe_impact.calibration.root_stress import RootPeak, StageRootStress

    pinion = PinionTooth(19, 3e-3, 20.0, 1.0, 0.25, 0.38, 0.02)
    iso = iso_section(pinion, pinion.pitch_radius)
    record = StageRootStress(
        stage=2, normal_force=1e3, level="coarse", refinement=1.0,
        pinion=RootPeak(1.2e8, np.array([1e-3, 2e-3, 3e-3]), 2e-3, 40),
        face=RootPeak(9e7, np.array([4e-3, 5e-3, 6e-3]), 3e-3, 50), iso=iso,
        iso_stress=1.1e8, face_width=0.024, allowable=1e9, contact_force=999.0)
    back = StageRootStress.from_dict(json.loads(json.dumps(record.to_dict())))
    assert back.to_dict() == record.to_dict()
    assert back.iso == iso


def test_fe_root_stress_of_a_drive_against_the_iso_figure(tmp_path):
    """The single-stage 25 deg drive's tooth pair at the pitch point (coarse), 3.25 kN.

    The solve carries the requested force (the load-controlled hub's tolerance,
    1e-3). The pinion's peak tension lies on the loaded side (tension there, so
    positive) and within [0.8, 2.5] of ISO's sigma_F0 for the same load at the same
    point: ISO's Y_S is an empirical fit (about 10 % against 2-D FE and
    photoelasticity), the localised contact loads less of the face than the b of
    sigma_F0 (raising the FE's figure up to b over the contact's length, about 2
    here), and the coarse mesh at the fillet lowers it (20 % between the coarse
    level and its sizes / 1.5 on this pair)."""
    from pathlib import Path

    from fe_impact.api import read_gearset
    from fe_impact.calibration.root_stress import fe_root_stress

    drive = Path(__file__).resolve().parents[1] / "geometry" / "nasa-25deg.toml"
    result = fe_root_stress(read_gearset(drive), 1, 3248.0, level="coarse", cache=tmp_path)
    assert result.contact_force == pytest.approx(3248.0, rel=1e-3)
    assert result.pinion.stress > 0.0 and result.face.stress > 0.0
    assert 0.8 <= result.pinion.stress / result.iso_stress <= 2.5
    assert result.allowable == 2.0 * 500e6
