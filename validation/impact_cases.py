"""Case files of the impact validations and tests (sphere on block, rigid-mass SDOF)."""

from __future__ import annotations

from pathlib import Path

from validation.specimens import SphereBlockSpec, build_sphere_block, build_two_blocks

E, NU, RHO = 212e9, 0.289, 7860.0
R = 10e-3

_MATERIAL = f"""\
[[materials]]
volumes = {{volumes}}
youngs_modulus = {E}
poisson_ratio = {NU}
density = {RHO:g}
"""

#: The quarter sphere-on-block specimen: mesh, material, contact and supports; the
#: static and the impact cases add their loading to it.
SPECIMEN = """\
[mesh]
file = "{mesh}"
unit = "m"

""" + _MATERIAL.format(volumes='["sphere", "block"]') + """
[[contacts]]
slave = "sphere_contact"
master = "block_contact"
penalty = "auto"

[[supports]]
surface = "block_bottom"
fix = ["z"]
[[supports]]
surface = "sym_x"
fix = ["x"]
[[supports]]
surface = "sym_y"
fix = ["y"]
"""

SPHERE_BLOCK = SPECIMEN + """
[[initial_velocities]]
volumes = ["sphere"]
value = [0.0, 0.0, {v}]
{rigid}
[analysis]
type = "dynamic"
integrator = "{integrator}"
duration = {duration}
time_step = {time_step}
output_interval = {output}
"""

RIGID = """
[[rigid_bodies]]
surface = "sphere_equator"
motion = "translation"
direction = [0.0, 0.0, 1.0]
inertia = {inertia}
initial_velocity = {v}
"""


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
    """Quarter-model impact case: the sphere moves down at ``speed`` (m/s).

    ``rigid_mass`` (kg, whole sphere) ties the flat face to a rigid mass; the
    quarter model carries a quarter of it.
    """
    rigid = "" if rigid_mass is None else RIGID.format(inertia=rigid_mass / 4.0, v=-speed)
    text = SPHERE_BLOCK.format(
        mesh=mesh.name, v=-speed,
        rigid=rigid, integrator=integrator, duration=duration,
        time_step=f'"{time_step}"' if isinstance(time_step, str) else time_step,
        output=duration / frames)
    path = folder / name
    path.write_text(text)
    return path


SDOF = """\
[mesh]
file = "{mesh}"
unit = "m"

{material}
[[contacts]]
slave = "upper_bottom"
master = "lower_top"
penalty = {penalty}

[[supports]]
surface = "lower_all"
fix = ["x", "y", "z"]

[[rigid_bodies]]
surface = "upper_all"
motion = "translation"
direction = [0.0, 0.0, 1.0]
inertia = {mass}
initial_velocity = {v}

[analysis]
type = "dynamic"
integrator = "{integrator}"
duration = {duration}
time_step = {time_step}
{extra}
"""


def write_sdof(folder: Path, integrator: str, time_step: float | str, duration: float,
               penalty: float, mass: float, speed: float, extra: str = "",
               size: float = 1e-3, gap: float = 1e-8) -> Path:
    """Rigid cube on a linear penalty spring: see :func:`build_two_blocks`."""
    folder.mkdir(parents=True, exist_ok=True)
    mesh = folder / "two_blocks.msh"
    if not mesh.exists():
        build_two_blocks(mesh, size=size, gap=gap)
    path = folder / f"sdof_{integrator}.toml"
    path.write_text(SDOF.format(
        mesh=mesh.name, material=_MATERIAL.format(volumes='["upper", "lower"]'),
        penalty=penalty, mass=mass, v=-speed, integrator=integrator, duration=duration,
        time_step=f'"{time_step}"' if isinstance(time_step, str) else time_step, extra=extra))
    return path
