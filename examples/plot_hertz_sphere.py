"""
A sphere pressed on a block, against Hertz
==========================================

A case file of your own mesh: a quarter of a 10 mm steel hemisphere on a
block (``meshes/hertz_coarse.msh``, 10-node tetrahedra, 0.2 mm elements at
the contact), its flat face pushed down in five load steps. The case is
written as TOML, solved with `fe_impact.solve`, and the contact radius
and pressure compared with Hertz's closed form (Johnson, *Contact
Mechanics*, 1985, section 4.2):

$$
a = \\left(\\frac{3 F R}{4 E^*}\\right)^{1/3}, \\qquad
p(r) = p_0 \\sqrt{1 - r^2 / a^2}, \\qquad p_0 = \\frac{3 F}{2 \\pi a^2},
\\qquad \\frac{1}{E^*} = 2\\,\\frac{1 - \\nu^2}{E}.
$$

The FE contact radius comes from the area of the nodes in contact, which
places the edge of the contact to within about half an element.

![pressure and contact radius against Hertz](../images/examples/plot_hertz_sphere.png)
"""

# mkdocs_gallery_thumbnail_path = 'images/examples/plot_hertz_sphere.png'

import os
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import fe_impact  # noqa: E402

out = Path(os.environ.get("FE_IMPACT_EXAMPLES_OUT", "."))
out.mkdir(parents=True, exist_ok=True)
here = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
mesh = here.parent / "meshes" / "hertz_coarse.msh"

# %%
# The case file. Physical groups of the mesh name the volumes and surfaces;
# the two symmetry planes hold the quarter model.
E, NU, R = 212e9, 0.289, 10e-3     # Pa, -, m
CASE = f"""
[mesh]
file = "{mesh.as_posix()}"
unit = "m"

[[materials]]
volumes = ["sphere", "block"]
youngs_modulus = {E:g}
poisson_ratio = {NU:g}
density = 7860.0

[[contacts]]
slave = "sphere_contact"
master = "block_contact"

[[supports]]
surface = "block_bottom"
fix = ["z"]

[[supports]]
surface = "sym_x"
fix = ["x"]

[[supports]]
surface = "sym_y"
fix = ["y"]

[[displacements]]
surface = "sphere_equator"
component = "z"
values = [-5e-6, -1e-5, -1.5e-5, -2e-5, -2.5e-5]

[analysis]
type = "static"
"""
case_file = out / "sphere_on_block.toml"
case_file.write_text(CASE)

# %%
# Solve (a few seconds); with ``out=`` the fields would also be written for
# ParaView.
result = fe_impact.solve(case_file)

# %%
# Hertz for the FE force of each step (four times the quarter model's).
e_star = E / (2.0 * (1.0 - NU ** 2))
force = np.array([4.0 * s.contact_force[0] for s in result.steps])
a_fe = np.sqrt(4.0 * np.array([s.contact_area[0] for s in result.steps]) / np.pi)
a_hertz = (3.0 * force * R / (4.0 * e_star)) ** (1.0 / 3.0)
for f, a, ah in zip(force, a_fe, a_hertz, strict=True):
    print(f"F = {f:7.1f} N: contact radius {a * 1e6:5.0f} um, Hertz {ah * 1e6:5.0f} um "
          f"({a / ah - 1:+.1%})")

# %%
# The pressure at the contact nodes at full load, against Hertz's ellipse.
last = result.steps[-1]
nodes = result.mesh.surface_points("sphere_contact")
xy = result.mesh.points[nodes, :2]
r = np.hypot(xy[:, 0], xy[:, 1])
a, p0 = a_hertz[-1], 3.0 * force[-1] / (2.0 * np.pi * a_hertz[-1] ** 2)
near = r < 1.5 * a
rr = np.linspace(0.0, a, 200)

fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
left.plot(r[near] * 1e3, last.pressure[nodes][near] / 1e6, "o", ms=4, label="FE, nodes")
left.plot(rr * 1e3, p0 * np.sqrt(1 - (rr / a) ** 2) / 1e6, "k-", label="Hertz")
left.set(xlabel="radius r [mm]", ylabel="contact pressure [MPa]",
         title=f"pressure at F = {force[-1]:.0f} N")
left.legend()
h = 0.2e-3     # element size at the contact
ff = np.linspace(0.0, force.max() * 1.05, 200)
af = (3.0 * ff * R / (4.0 * e_star)) ** (1.0 / 3.0)
right.fill_between(ff, np.maximum(af - h / 2, 0.0) * 1e3, (af + h / 2) * 1e3, color="0.88",
                   label="Hertz +- half an element")
right.plot(ff, af * 1e3, "k-", label="Hertz")
right.plot(force, a_fe * 1e3, "o", label="FE, nodes in contact")
right.set(xlabel="contact force F [N]", ylabel="contact radius a [mm]",
          title="contact radius")
right.legend()
fig.suptitle("10 mm steel sphere on a block (coarse P2 mesh) against Hertz")
fig.savefig(out / "plot_hertz_sphere.png", dpi=110)
