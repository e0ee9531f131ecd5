"""Friction condensed on the contact patch's tangent coordinates only.

A large zone with friction is condensed on its nodes' normal coordinates and on
the tangent ones of the nodes the rows in contact reach, grown (a new
factorisation) when a row with a force reaches a node left out
(:data:`fe_impact.contact.condensed.FULL_TANGENTIAL_COORDINATES`). A row with no
force carries no tangential force, so the solution is the one condensed on all
three coordinates of every node: these tests force the patch's condensation on
the small zones of the friction studies and compare.
"""

from __future__ import annotations

import pytest

import fe_impact.contact.condensed as condensed


def _patch_only(monkeypatch):
    monkeypatch.setattr(condensed, "FULL_TANGENTIAL_COORDINATES", 0)


def test_newmark_oblique_impact_on_the_patch_equals_the_whole_zone(tmp_path, monkeypatch):
    # The coarse Newmark oblique impact at 62 deg (gross slip, the study of
    # validation/friction_oblique.py). Outside the rows in contact only the normal
    # rows differ (the normal part of their nodes' motion, as without friction),
    # and those rows carry no force; 1e-8 relative: round-off over the step's
    # solves (measured on the coarse tooth impact 3.5e-12), far below the
    # penalty's own regularisation (1e-3), and a row missed at the patch's edge
    # would move the rebound by its share of the force (1e-3 or more).
    from validation import friction_oblique

    whole = friction_oblique.run(quick=True, out=tmp_path / "whole", integrator="newmark",
                                 angles=(62.0,))["angles"][0]
    _patch_only(monkeypatch)
    grown = []
    grow = condensed.CondensedContact._grow_tangential

    def counted(self, rows):
        grown.append(len(rows))
        return grow(self, rows)

    monkeypatch.setattr(condensed.CondensedContact, "_grow_tangential", counted)
    patch = friction_oblique.run(quick=True, out=tmp_path / "patch", integrator="newmark",
                                 angles=(62.0,))["angles"][0]
    assert grown, "the patch's tangent coordinates never grew"
    for key in ("tangential_restitution", "tan_rebound", "friction_dissipation_J"):
        assert patch[key] == pytest.approx(whole[key], rel=1e-8), key


def test_static_cattaneo_on_the_patch_equals_the_whole_zone(tmp_path, monkeypatch):
    # The coarse Cattaneo-Mindlin loading (validation/friction_cattaneo.py, six
    # tangential steps). The projection iteration stops at the analysis tolerance
    # (1e-6 of the contact displacement), and a growth restarts it from another
    # path: 1e-5 relative on the forces and the microslip.
    from validation import friction_cattaneo as fc

    whole = fc.run_level(tmp_path, "whole", 0.2e-3, steps=6)
    _patch_only(monkeypatch)
    patch = fc.run_level(tmp_path, "patch", 0.2e-3, steps=6)
    assert patch["n_contact_dofs"] < whole["n_contact_dofs"]
    for a, b in zip(whole["steps"], patch["steps"], strict=True):
        for key in ("P", "Q", "microslip_fe_m"):
            assert b[key] == pytest.approx(a[key], rel=1e-5, abs=1e-5 * abs(a["slide_m"])
                                           if key == "microslip_fe_m" else 0.0), key
