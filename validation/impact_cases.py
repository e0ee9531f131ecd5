"""Cases of the validations and tests: sphere on block, rigid-mass SDOF.

The studies build their cases in memory as :mod:`fe_impact.fe.case` records
(:func:`sphere_block_case`, :func:`sphere_impact_case`, :func:`sdof_case`;
variants with :func:`dataclasses.replace`) and hand them to the solvers with
the mesh. ``write_sphere_impact`` and ``write_sdof`` write the same cases as
case files, for the tests of the case-file path.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from fe_impact.fe.case import (
    AnalysisSpec,
    Case,
    ContactSpec,
    DisplacementSpec,
    InitialVelocitySpec,
    MaterialSpec,
    RigidBodySpec,
    SupportSpec,
)
from fe_impact.fe.casefile import write_case
from validation.specimens import SphereBlockSpec, build_sphere_block, build_two_blocks

E, NU, RHO = 212e9, 0.289, 7860.0
R = 10e-3

STEEL = MaterialSpec(("sphere", "block"), E, NU, RHO)
Z = (0.0, 0.0, 1.0)


def sphere_block_case(mesh_file: Path, displacements: tuple[float, ...] = (),
                      material: MaterialSpec = STEEL, **analysis) -> Case:
    """The quarter sphere-on-block specimen (static): contact, supports, symmetry.

    ``displacements`` (m, one per load step) push the sphere's flat equator
    face along z; ``analysis`` sets :class:`AnalysisSpec` fields.
    """
    loads = ((DisplacementSpec("sphere_equator", 2, tuple(float(d) for d in displacements)),)
             if displacements else ())
    return Case(path=Path(mesh_file).with_suffix(".case"), mesh_file=Path(mesh_file),
                unit="m", materials=(material,),
                contacts=(ContactSpec("sphere_contact", "block_contact"),),
                supports=(SupportSpec("block_bottom", (2,)), SupportSpec("sym_x", (0,)),
                          SupportSpec("sym_y", (1,))),
                displacements=loads, analysis=AnalysisSpec(**analysis))


def sphere_impact_case(mesh_file: Path, speed: float, duration: float,
                       integrator: str = "newmark", rigid_mass: float | None = None,
                       time_step: float | None = None, frames: int = 50,
                       material: MaterialSpec = STEEL, **analysis) -> Case:
    """Quarter-model impact: the sphere moves down at ``speed`` (m/s).

    ``rigid_mass`` (kg, whole sphere) ties the flat face to a rigid mass; the
    quarter model carries a quarter of it. ``time_step`` None: automatic.
    """
    static = sphere_block_case(mesh_file, material=material)
    rigid = () if rigid_mass is None else (RigidBodySpec(
        "sphere_equator", "translation", Z, inertia=rigid_mass / 4.0,
        initial_velocity=-speed),)
    return replace(static, initial_velocities=(InitialVelocitySpec(("sphere",),
                                                                   (0.0, 0.0, -speed)),),
                   rigid_bodies=rigid,
                   analysis=AnalysisSpec(type="dynamic", integrator=integrator,
                                         duration=duration, time_step=time_step,
                                         output_interval=duration / frames, **analysis))


def plastic(material: MaterialSpec, yield_strength: float,
            hardening_modulus: float = 0.0) -> MaterialSpec:
    """``material`` made elastic-plastic (J2, linear isotropic hardening)."""
    return replace(material, yield_strength=yield_strength,
                   hardening_modulus=hardening_modulus)


def two_blocks_mesh(folder: Path, size: float = 1e-3, gap: float = 1e-8) -> Path:
    """Mesh the two-cube SDOF specimen once per folder (:func:`build_two_blocks`)."""
    folder.mkdir(parents=True, exist_ok=True)
    mesh = folder / "two_blocks.msh"
    if not mesh.exists():
        build_two_blocks(mesh, size=size, gap=gap)
    return mesh


def sdof_case(mesh_file: Path, integrator: str, time_step: float | None, duration: float,
              penalty: float, mass: float, speed: float, **analysis) -> Case:
    """Rigid cube on a linear penalty spring: see :func:`build_two_blocks`."""
    return Case(path=Path(mesh_file).with_suffix(".case"), mesh_file=Path(mesh_file),
                unit="m", materials=(MaterialSpec(("upper", "lower"), E, NU, RHO),),
                contacts=(ContactSpec("upper_bottom", "lower_top", penalty=penalty),),
                supports=(SupportSpec("lower_all", (0, 1, 2)),),
                rigid_bodies=(RigidBodySpec("upper_all", "translation", Z, inertia=mass,
                                            initial_velocity=-speed),),
                analysis=AnalysisSpec(type="dynamic", integrator=integrator,
                                      duration=duration, time_step=time_step, **analysis))


def sphere_block_mesh(folder: Path, h_contact: float, gap: float = 1e-6, order: int = 2,
                      hemisphere: bool = True, r_fine: float = 1.0e-3,
                      block: float = 10e-3) -> Path:
    """Mesh the quarter sphere-on-block specimen once per folder."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "sphere_block.msh"
    if not path.exists():
        spec = SphereBlockSpec(radius=R, h_contact=h_contact, gap=gap, order=order,
                               hemisphere=hemisphere, r_fine=r_fine,
                               block_half_width=block, block_depth=block)
        build_sphere_block(spec, path)
    return path


def write_sphere_impact(folder: Path, mesh: Path, speed: float, duration: float,
                        integrator: str = "newmark", rigid_mass: float | None = None,
                        time_step: float | str = "auto", frames: int = 50,
                        name: str = "case.toml") -> Path:
    """:func:`sphere_impact_case` written as a case file ``folder/name`` (for the
    tests of the case-file path); ``time_step`` ``"auto"``: automatic."""
    case = sphere_impact_case(mesh, speed, duration, integrator, rigid_mass,
                              None if time_step == "auto" else time_step, frames)
    return write_case(case, Path(folder) / name)


def write_sdof(folder: Path, integrator: str, time_step: float | str, duration: float,
               penalty: float, mass: float, speed: float, size: float = 1e-3,
               gap: float = 1e-8, **analysis) -> Path:
    """:func:`sdof_case` on the two-block mesh of ``folder``, written as
    ``folder/sdof_<integrator>.toml``; ``time_step`` ``"auto"``: automatic."""
    mesh = two_blocks_mesh(Path(folder), size=size, gap=gap)
    case = sdof_case(mesh, integrator, None if time_step == "auto" else time_step, duration,
                     penalty, mass, speed, **analysis)
    return write_case(case, Path(folder) / f"sdof_{integrator}.toml")
