"""
Your own gear set: the geometry report
======================================

A two-stage face-gear drive written as a gear-set file, read with
`fe_impact.read_gearset` and checked with `fe_impact.geometry_report`
before any finite-element work (what ``fe-impact geometry`` prints). The
figure shows, per stage, the usable band of face radii between the
inner limits (undercut, conjugate tip) and the pointing limit, the face
chosen inside it, the pitch radius, and the contact ratio and Hertz pressure
at the pitch point under the load torque.

![face-width limits of the two stages](../images/examples/plot_user_gearset.png)
"""

# mkdocs_gallery_thumbnail_path = 'images/examples/plot_user_gearset.png'

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import fe_impact  # noqa: E402

out = Path(os.environ.get("FE_IMPACT_EXAMPLES_OUT", "."))
out.mkdir(parents=True, exist_ok=True)

# %%
# The gear-set file: every key with a unit says it in its suffix. Module 2.5 mm,
# a 20-tooth pinion, rings of 60 and 80 teeth cut by a 22-tooth shaper. The
# radii are chosen inside the limits the report checks (a first run with
# any radii tells the limits).
GEARSET = """
name = "two-stage example"
n_pinions = 2

[material]
youngs_modulus_pa = 206e9
poisson_ratio = 0.3
density_kg_m3 = 7850.0
yield_strength_pa = 835e6

[pinion]
teeth = 20
module_mm = 2.5
pressure_angle_deg = 20.0
addendum_coeff = 1.0
clearance_coeff = 0.25
face_width_mm = 20.0
fillet_radius_coeff = 0.38
lengthwise_crowning_um = 10.0
profile_crowning_um = 0.0
inertia_kg_m2 = 9.6e-5

[face_gear]
module_mm = 2.5
inner_limit = "conjugate"

[[face_gear.stages]]
teeth = 60
shaper_teeth = 22
inner_radius_mm = 73.5
outer_radius_mm = 85.0
lengthwise_crowning_um = 0.0
inertia_kg_m2 = 4.0e-3

[[face_gear.stages]]
teeth = 80
shaper_teeth = 22
inner_radius_mm = 98.0
outer_radius_mm = 113.5
lengthwise_crowning_um = 0.0
inertia_kg_m2 = 1.1e-2
"""
path = out / "two_stage.toml"
path.write_text(GEARSET)
gearset = fe_impact.read_gearset(path)

# %%
# The report: one row per stage, SI units (m, Pa, rad).
torque = 20.0   # N m on the output
rows = fe_impact.geometry_report(gearset, torque=torque)
for row in rows:
    w, c, p = row["face_width"], row["path_of_contact"], row["pitch_point"]
    print(f"stage {row['stage']}: face {w['inner_radius_m'] * 1e3:.1f}-"
          f"{w['outer_radius_m'] * 1e3:.1f} mm, contact ratio {c['contact_ratio']:.3f}, "
          f"p0 {p['max_pressure_Pa'] / 1e6:.0f} MPa at {p['normal_force_N']:.0f} N")

# %%
# The face-width band of each stage: the chosen face (blue) must lie between
# the inner limit and the pointing limit (grey); the margins are printed.
fig, axes = plt.subplots(len(rows), 1, figsize=(7.5, 1.9 * len(rows) + 0.6),
                         layout="constrained")
LIMITS = (("inner_undercut_limit_m", "undercut"), ("inner_conjugate_limit_m", "conjugate tip"),
          ("pitch_radius_m", "pitch radius"), ("outer_pointing_limit_m", "pointing"))
for ax, row in zip(axes, rows, strict=True):
    w = {k: (None if v is None else v * 1e3) for k, v in row["face_width"].items()
         if k.endswith("_m")}     # lengths in mm
    inner_limit = max(w[k] for k in ("inner_undercut_limit_m", "inner_conjugate_limit_m")
                      if w[k] is not None)
    ax.axvspan(inner_limit, w["outer_pointing_limit_m"], color="0.88")
    ax.barh(0, w["outer_radius_m"] - w["inner_radius_m"], left=w["inner_radius_m"],
            height=0.4, color="tab:blue")
    for key, name in LIMITS:
        if w[key] is not None:
            ax.axvline(w[key], color="k", lw=1.2, ls=":" if key == "pitch_radius_m" else "-")
            ax.annotate(name, (w[key], 0.45), rotation=90, ha="right", va="top", fontsize=8)
    ax.annotate(f"margin {w['inner_radius_m'] - inner_limit:.2f} mm",
                (w["inner_radius_m"], -0.32), ha="left", fontsize=8)
    ax.annotate(f"margin {w['outer_pointing_limit_m'] - w['outer_radius_m']:.2f} mm",
                (w["outer_radius_m"], -0.32), ha="right", fontsize=8)
    ax.set_xlim(w["inner_undercut_limit_m"] - 2.0, w["outer_pointing_limit_m"] + 2.0)
    ax.set_ylim(-0.5, 0.5)
    ax.set_yticks([])
    ax.set_title(f"stage {row['stage']} ({row['teeth']} teeth): contact ratio "
                 f"{row['path_of_contact']['contact_ratio']:.2f}, Hertz p0 "
                 f"{row['pitch_point']['max_pressure_Pa'] / 1e6:.0f} MPa at {torque:g} N m",
                 fontsize=10)
axes[-1].set_xlabel("face-gear radius [mm]")
fig.suptitle(f"{gearset.name}: chosen face (blue) inside the usable radii (grey)")
fig.savefig(out / "plot_user_gearset.png", dpi=110)
