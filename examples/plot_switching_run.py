"""
A switching run on a calibration
================================

The lumped torsional model of the drive (pinions, rings, output, backlash)
run through the seed's Table 1 condition at 300 r/min with no load, where
the teeth rattle in the backlash: once with the IMPACT law calibrated on
the FE impacts (the one-stage calibration of the example before, made here
if it is not there), once with the seed's closed-form law.
`fe_impact.simulate_switching` runs one schedule in memory;
`fe_impact.run_switching` runs a whole study and writes its files
(``fe-impact switching``). A schedule is a preset's name, as here, or a
schedule file of your own (`fe_impact.read_schedule`).

The figure shows the impacts of the 5 s run, their peak force and closing
speed against time. The rattle closes far slower than the one FE impact of
this cut-down calibration: the law is taken at its nearest calibrated speed
(a warning says so). The full calibration strikes its impacts at the closing
speeds the presets produce (``preset_speeds``).

![impacts of the rattle](../images/examples/plot_switching_run.png)
"""

# mkdocs_gallery_thumbnail_path = 'images/examples/plot_switching_run.png'

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import fe_impact  # noqa: E402

out = Path(os.environ.get("FE_IMPACT_EXAMPLES_OUT", "."))
#: The calibration of plot_calibrate_stage.py (the same options resume it).
OPTIONS = dict(stages=[1], speeds=[300.0], level="coarse", mesh_cycle=False,
               switching=False, preset_speeds=False, workers=1)
SCHEDULE = "table1-300rpm"    # fe_impact.presets() lists the others


def main():
    # %%
    # The calibration: made here (about a minute) unless the example before left it.
    path = out / "calibration" / "calibration.json"
    if not path.is_file():
        fe_impact.calibrate(out=path.parent, cache=out / "cache", **OPTIONS)

    # %%
    # The same 5 s run on both laws (a second or two each).
    runs = {"calibrated law": fe_impact.simulate_switching(SCHEDULE, calibration=path),
            "closed-form law": fe_impact.simulate_switching(SCHEDULE, calibration=None)}
    for name, run in runs.items():
        ev = run.events
        print(f"{name}: {len(ev.time)} impacts, largest {ev.force.max():.1f} N, "
              f"fastest {ev.speed.max() * 1e3:.2f} mm/s")

    # %%
    # Impacts over the run: peak force, and closing speed beside the speed the FE
    # impact of the calibration was struck at (the law is taken at the nearest
    # calibrated speed: the log says how many impacts fell outside).
    fe_speed = fe_impact.read_calibration(path).cases[0].impact_speed
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True,
                                      layout="constrained")
    for (name, run), style in zip(runs.items(), ("o", "x"), strict=True):
        ev = run.events
        top.plot(ev.time, ev.force, style, ms=4, mfc="none",
                 label=f"{name}: {len(ev.time)} impacts, largest {ev.force.max():.0f} N")
        bottom.plot(ev.time, ev.speed * 1e3, style, ms=4, mfc="none", label=name)
    bottom.axhline(fe_speed * 1e3, color="k", ls="--",
                   label=f"FE impact of the calibration ({fe_speed * 1e3:.1f} mm/s)")
    top.set(ylabel="impact peak force [N]",
            title=f"stage 1 at 300 r/min, no load ({SCHEDULE}): tooth impacts in the backlash")
    top.set_ylim(0.0, 1.4 * top.get_ylim()[1])
    top.legend(loc="upper left", fontsize=9)
    bottom.set(xlabel="time [s]", ylabel="closing speed [mm/s]", yscale="log")
    bottom.legend(loc="lower right", fontsize=9)
    fig.savefig(out / "plot_switching_run.png", dpi=110)
    return runs


if __name__ == "__main__":
    main()
