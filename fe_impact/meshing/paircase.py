"""The FE case of a tooth-pair mesh: the dynamic impact of the two sectors.

:func:`impact_case` builds the :class:`~fe_impact.fe.case.Case` of the mesh
:func:`fe_impact.meshing.toothpair.build_pair` writes (material, flank contact,
rigid rotors on the hubs with their initial angular velocities, Newmark over a
few Hertz contact times); :func:`case_header` gives the comment lines that
``case.toml`` opens with (where the case comes from, and the TCA). Both read a
:class:`~fe_impact.gears.pairanalysis.PairAnalysis`; the case is written by
:func:`~fe_impact.fe.casefile.write_case`.
"""

from __future__ import annotations

from pathlib import Path

from numpy.typing import NDArray

from fe_impact.fe.case import (
    AnalysisSpec,
    Case,
    ContactSpec,
    MaterialSpec,
    RigidBodySpec,
    SupportSpec,
)
from fe_impact.gears.pairanalysis import PairAnalysis
from fe_impact.gears.tca import GearPair

__all__ = ["DURATION_FACTOR", "FRAMES_PER_CONTACT", "case_header", "impact_case",
           "static_case"]

#: Contact time multiple simulated (about 2.5 Hertz contact times).
DURATION_FACTOR = 2.5
#: Output frames per Hertz contact time.
FRAMES_PER_CONTACT = 20


def impact_case(gearset, pair: GearPair, analysis: PairAnalysis, case_path: Path,
                mesh_path: Path) -> Case:
    """The dynamic impact case on the pair's mesh (``case.toml``).

    The gear set's material on both sectors; the pinion flank (slave) on the
    face flank (master) with the automatic penalty; each hub tied to a rigid
    rotor with the gear's inertia about its axis, turning at the
    :attr:`~fe_impact.gears.pairanalysis.PairAnalysis.velocities` that close
    the gap at the impact speed, and carrying its sector, which starts in the
    rotor's rigid motion (a sector at rest behind a turning hub would be
    struck by its hub and close the gap at the momentum-weighted 0.9 of the
    impact speed, its teeth ringing); Newmark with the automatic step over
    :data:`DURATION_FACTOR` Hertz contact times, :data:`FRAMES_PER_CONTACT` output
    frames per contact time.
    """
    a, mat = analysis, gearset.material
    t_c = a.impact.contact_time
    rotors = (("pinion_hub", "pinion", pair.pinion_axis, gearset.pinion.inertia,
               a.velocities[0]),
              ("face_hub", "face_gear", pair.face_axis,
               gearset.stages[a.spec.stage - 1].inertia, a.velocities[1]))
    return Case(
        path=case_path, mesh_file=mesh_path.resolve(), unit="mm",
        materials=(MaterialSpec(
            ("pinion", "face_gear"), float(mat.youngs_modulus), float(mat.poisson_ratio),
            float(mat.density),
            None if mat.yield_strength is None else float(mat.yield_strength)),),
        contacts=(ContactSpec("pinion_flank", "face_flank"),),
        rigid_bodies=tuple(
            RigidBodySpec(surface, "rotation", direction=_floats(direction),
                          point=_floats(point), inertia=float(inertia),
                          initial_velocity=float(omega), carries=(volume,))
            for surface, volume, (point, direction), inertia, omega in rotors),
        analysis=AnalysisSpec(type="dynamic", integrator="newmark",
                              duration=DURATION_FACTOR * t_c,
                              output_interval=t_c / FRAMES_PER_CONTACT),
    )


def static_case(gearset, pair: GearPair, analysis: PairAnalysis, case_path: Path,
                mesh_path: Path, forces: tuple[float, ...]) -> Case:
    """The quasi-static case on the pair's mesh: the pinion pressed on the face gear.

    The face-gear hub is held; the pinion hub is tied to a rigid rotor loaded,
    step by step, by the torque that balances a contact normal force
    ``forces[i]`` (N) at the analysis' contact point: ``T = -F l_1`` with
    ``l_1`` the pinion's signed lever arm (:class:`~fe_impact.gears.pairanalysis.ReducedMasses`;
    the contact force on the pinion is ``+F n``, n out of the face gear).

    The contact zone is every face whose gap is below the initial gap plus
    1.25 Hertz approaches at the largest force: on a Hertz patch the
    undeformed separation never exceeds the approach (the elastic
    displacement ``delta - h`` is positive inside it), and the solver grows
    the zone if the patch spreads further (at the end of the face).
    """
    mat = gearset.material
    point, direction = pair.pinion_axis
    lever = analysis.masses.pinion_lever
    design = analysis.design_ellipse
    approach = design.approach * (max(forces) / design.force) ** (2.0 / 3.0)
    return Case(
        path=case_path, mesh_file=mesh_path.resolve(), unit="mm",
        materials=(MaterialSpec(("pinion", "face_gear"), float(mat.youngs_modulus),
                                float(mat.poisson_ratio), float(mat.density)),),
        contacts=(ContactSpec("pinion_flank", "face_flank",
                              search_distance=analysis.gap + 1.25 * approach),),
        supports=(SupportSpec("face_hub", (0, 1, 2)),),
        rigid_bodies=(RigidBodySpec("pinion_hub", "rotation", direction=_floats(direction),
                                    point=_floats(point),
                                    loads=tuple(float(-f * lever) for f in forces)),),
        analysis=AnalysisSpec(type="static"),
    )


def static_pair_case(gearset, pair_mesh, forces: tuple[float, ...]) -> Case:
    """:func:`static_case` on a meshed pair (a
    :class:`~fe_impact.meshing.toothpair.PairMesh`): the gear pair taken from the
    pair analysis' own spec, the case's path ``static.toml`` beside ``case.toml``."""
    from fe_impact.gears.pairanalysis import analyse_stage_pair

    pair, _ = analyse_stage_pair(gearset, pair_mesh.analysis.spec)
    return static_case(gearset, pair, pair_mesh.analysis,
                       pair_mesh.case_path.with_name("static.toml"), pair_mesh.mesh_path, forces)


def _floats(v: NDArray) -> tuple[float, ...]:
    return tuple(float(c) for c in v)


def _vec(v: NDArray) -> str:
    return "[" + ", ".join(f"{float(c):.10g}" for c in v) + "]"


def case_header(gearset, pair: GearPair, analysis: PairAnalysis, key: str) -> str:
    """Comment lines of ``case.toml``: where the case comes from, and the TCA
    (``key``: :func:`~fe_impact.meshing.toothpair.pair_key`)."""
    a = analysis
    spec, c, m, hit, ell = a.spec, a.contact, a.masses, a.impact, a.design_ellipse
    rx, ry = c.relative.radii
    w1, w2 = a.velocities
    return "\n".join([
        "Dynamic single-tooth impact written by fe_impact.meshing.toothpair.build_pair",
        f"gear set {gearset.name!r}, stage {spec.stage} ({pair.face.teeth} teeth), "
        f"roll angle {spec.roll_angle_deg:g} deg, level {spec.level}, P{spec.order}, key {key}",
        "Mesh frame: y = face-gear axis (origin on it, in the pitch plane); pinion axis",
        f"x = 0, y = {pair.pinion.pitch_radius:.6g} m along z. pair.msh is in millimetres;",
        "every other length here is in metres (SI).",
        f"Contact point (TCA) {_vec(c.point)} m, normal (out of the face gear) {_vec(c.normal)}",
        f"Initial gap {spec.gap * 1e6:g} um: the pinion is turned by gap / l1 out of contact.",
        f"Relative radii Rx = {rx:.6g} m, Ry = {ry:.6g} m; equivalent (sphere) radius"
        f" {a.equivalent_radius:.6g} m; E* = {a.effective_modulus:.6g} Pa",
        f"Lever arms |(e x (x_c - p)) . n|: pinion {abs(m.pinion_lever):.6g} m, face gear"
        f" {abs(m.face_lever):.6g} m",
        f"Masses I/l^2: pinion {m.pinion_mass:.6g} kg, face gear {m.face_mass:.6g} kg;"
        f" m_eff = {m.effective_mass:.6g} kg",
        f"Hertz impact at v_k = {spec.impact_speed:g} m/s: delta_max {hit.delta_max:.4g} m,"
        f" F_max {hit.force_max:.4g} N, t_c {hit.contact_time:.4g} s",
        f"Hertz ellipse at {ell.force:.4g} N (sets the mesh):"
        f" a {ell.a:.4g} m, b {ell.b:.4g} m, p0 {ell.p0:.4g} Pa",
        f"Initial velocities ({spec.velocity_split!r} split): normal speeds omega_i l_i"
        f" {w1 * m.pinion_lever:.6g} and {w2 * m.face_lever:.6g} m/s, closing at"
        f" {spec.impact_speed:g} m/s",
    ])
