"""
A tooth-pair impact
===================

One pinion tooth strikes a face-gear tooth of the seed drive's first stage at
the pitch point, closing at 0.1 m/s: `fe_impact.mesh_pair` meshes the
pair at the coarse level (the rotors' inertia on rigid hubs) and writes its
case file, and `fe_impact.solve` runs the transient impact.

The figure sets the FE contact force beside the impact of two rigid bodies
with the same effective mass and Hertz's local contact law
$F = \\tfrac43 E^* \\sqrt{R}\\, \\delta^{3/2}$ on the ellipse's
equivalent radius (Johnson, *Contact Mechanics*, 1985, section 11.4): the
teeth's bending adds compliance in series with the contact, so the FE
impact is softer, longer and lower. That difference is what the calibration
(`fe_impact.calibrate`) fits into the lumped IMPACT law.

![contact force of a tooth-pair impact](../images/examples/plot_tooth_impact.png)
"""

# mkdocs_gallery_thumbnail_path = 'images/examples/plot_tooth_impact.png'

import os
from pathlib import Path

import matplotlib
import numpy as np
from scipy.integrate import solve_ivp

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import fe_impact  # noqa: E402

out = Path(os.environ.get("FE_IMPACT_EXAMPLES_OUT", "."))
SPEED = 0.1   # m/s, closing speed at the contact point

# %%
# Mesh the pair (coarse: some 37,000 DOFs; about 10 s) and solve the impact
# (about 20 s on one core). ``out`` of solve would add the VTU frames.
pair = fe_impact.mesh_pair(stage=1, level="coarse", impact_speed=SPEED,
                           out=out / "tooth_pair", reuse=True)
result = fe_impact.solve(pair.case_path)
m = result.measurements
print(f"FE: peak force {m.peak_force:.1f} N, contact {m.contact_duration * 1e6:.1f} us, "
      f"restitution {m.restitution:.4f}")

# %%
# The rigid-body Hertz impact, integrated from the first touch.
a = pair.analysis
mass = a.masses.effective_mass
k = 4.0 / 3.0 * a.effective_modulus * np.sqrt(a.equivalent_radius)


def hertz(t, y):
    return [y[1], -k * max(y[0], 0.0) ** 1.5 / mass]


def separated(t, y):
    return y[0]


separated.terminal, separated.direction = True, -1
t_guess = 4.0 * a.impact.contact_time
rigid = solve_ivp(hertz, (0.0, t_guess), [0.0, SPEED], events=separated, max_step=t_guess / 2000,
                  rtol=1e-9, atol=1e-15)
f_rigid = k * np.clip(rigid.y[0], 0.0, None) ** 1.5
print(f"rigid bodies, Hertz: peak force {f_rigid.max():.1f} N, contact "
      f"{rigid.t[-1] * 1e6:.1f} us (closed form: {a.impact.force_max:.1f} N, "
      f"{a.impact.contact_time * 1e6:.1f} us)")

# %%
# The FE force from its first touch.
t = result.history["time"] - m.first_touch
f = result.history["contact_force"]
fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
ax.plot(t * 1e6, f, label=f"FE tooth pair (peak {m.peak_force:.0f} N)")
ax.plot(rigid.t * 1e6, f_rigid, "k--",
        label=f"rigid bodies + Hertz contact (peak {f_rigid.max():.0f} N)")
ax.set(xlabel="time from first touch [us]", ylabel="contact force [N]",
       xlim=(-10, 1.15 * max(rigid.t[-1], m.contact_duration) * 1e6),
       title=f"stage 1 tooth impact at {SPEED:g} m/s, effective mass {mass:.3f} kg")
ax.set_ylim(0.0, 1.3 * f_rigid.max())
ax.legend(loc="upper right")
fig.savefig(out / "plot_tooth_impact.png", dpi=110)
