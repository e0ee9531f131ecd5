"""
Calibrating one stage
=====================

The main job, cut down to one FE impact: `fe_impact.calibrate` meshes
the seed drive's stage-1 tooth pair at the coarse level, strikes it at the
in-mesh impact speed of 300 r/min (seed eq. 4) and fits the lumped IMPACT
law ``F = k delta^e + damping`` to the FE force history. No mesh cycle, no
switching studies, no preset speeds: about a minute on one core. The whole
job is the same call without these restrictions (``fe-impact calibrate``).

The figure shows the FE contact force against the approach of the two
teeth, the fitted law's elastic part and the seed's closed form (Hertz's
``K delta^1.5`` on the contact's curvatures): the FE pair is softer, with an
exponent below 1.5, because the teeth bend as well as flatten.

The calibration runs its cases on Dask worker processes, which import this
script again: the work sits under ``if __name__ == "__main__":``.

![force against approach](../images/examples/plot_calibrate_stage.png)
"""

# mkdocs_gallery_thumbnail_path = 'images/examples/plot_calibrate_stage.png'

import os
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import fe_impact  # noqa: E402

out = Path(os.environ.get("FE_IMPACT_EXAMPLES_OUT", "."))

#: The one-stage calibration; the switching example runs on it.
OPTIONS = dict(stages=[1], speeds=[300.0], level="coarse", mesh_cycle=False,
               switching=False, preset_speeds=False, workers=1)


def main():
    # %%
    # Calibrate; the files (calibration.json, report.md, plots, the FE frames
    # of each case for ParaView) go to ``calibration/``.
    folder = out / "calibration"
    calibration = fe_impact.calibrate(out=folder, cache=out / "cache", echo=print, **OPTIONS)
    record = calibration.cases[0]
    law, closed = record.impact, record.closed_form
    print(f"{record.id}: k = {law.k:.3g} N/m^e, e = {law.exponent:.3f}, "
          f"cmax = {law.cmax:.3g} N s/m, d = {law.d * 1e6:.2f} um")

    # %%
    # The FE history of the impact, written beside the case's VTU frames.
    history = np.genfromtxt(folder / "cases" / record.id / "fe" / "history.csv",
                            delimiter=",", names=True)
    delta, force = history["approach_m"], history["contact_force_N"]
    touching = force > 0.0
    peak = int(np.argmax(force))
    loading = touching & (np.arange(len(force)) <= peak)

    d = np.linspace(0.0, 1.1 * record.fe.max_approach, 200)
    fig, ax = plt.subplots(figsize=(7, 4.2), layout="constrained")
    ax.plot(delta[loading] * 1e6, force[loading], "o", label="FE, loading")
    ax.plot(delta[touching & ~loading] * 1e6, force[touching & ~loading], "s", mfc="none",
            label="FE, unloading")
    ax.plot(d * 1e6, law.k * d ** law.exponent, "-",
            label=f"fitted law: k = {law.k:.3g} N/m^e, e = {law.exponent:.2f}")
    ax.plot(d * 1e6, closed.k * d ** closed.exponent, "k--",
            label=f"closed form (Hertz): K = {closed.k:.3g} N/m^1.5")
    ax.set(xlabel="approach of the teeth [um]", ylabel="contact force [N]",
           title=f"stage 1, impact at {record.impact_speed * 1e3:.1f} mm/s (300 r/min): "
                 f"restitution {record.fe.restitution:.4f}")
    ax.set_xlim(0.0, None)
    ax.set_ylim(0.0, None)
    ax.legend(loc="upper left")
    fig.savefig(out / "plot_calibrate_stage.png", dpi=110)
    return calibration


if __name__ == "__main__":
    main()
