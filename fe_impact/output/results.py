"""Turn solver results into files: ``summary.json``, VTU frames and a PVD series."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fe_impact.fe.case import Case
from fe_impact.output.files import remove_stale, write_array_csv, write_json, write_pvd, write_vtu
from fe_impact.solvers.static import StaticResult, StepResult
from fe_impact.version import __version__

SUMMARY_SCHEMA = "fe-impact/static-summary/1"


def _one_or_list(values: list[float]) -> float | list[float]:
    return values[0] if len(values) == 1 else values


def step_record(step: StepResult, case: Case) -> dict:
    """The JSON record of one load step (SI units); ``case`` names the rigid bodies."""
    record = {
        "value": step.value,
        "contact_force": _one_or_list(step.contact_force),
        "contact_area": _one_or_list(step.contact_area),
        "max_pressure": step.max_pressure,
        "max_penetration": step.max_penetration,
        "reaction_force": _one_or_list(step.reaction_force),
        "iterations": step.iterations,
        "active_set_iterations": step.active_set_iterations,
    }
    if step.rigid_values:
        record["rigid_bodies"] = [
            {"surface": b.surface, "motion": b.motion, "value": v, "reaction": r}
            for b, v, r in zip(case.rigid_bodies, step.rigid_values, step.rigid_reactions,
                               strict=True)]
    return record


def write_static_results(out: str | Path, case: Case, result: StaticResult,
                         status: str = "completed", error: str | None = None) -> Path:
    """Write ``summary.json``, ``step_NNN.vtu`` and ``static.pvd`` to ``out``.

    ``status`` says how the run ended (``"stopped"``: interrupted, ``result``
    holds the load steps done).
    """
    out = Path(out)
    frames = []
    for i, step in enumerate(result.steps):
        name = f"step_{i + 1:03d}.vtu"
        write_vtu(out / name, result.mesh,
                  point_data={"displacement": step.u, "contact_pressure": step.pressure},
                  cell_data={"von_mises": step.von_mises,
                             "material": result.model.material})
        frames.append((float(i + 1), name))
    write_pvd(out / "static.pvd", frames)
    remove_stale(out, "step_*.vtu", [name for _, name in frames])   # an earlier run's steps
    summary = {
        "schema": SUMMARY_SCHEMA,
        "fe_impact_version": __version__,
        "status": status,
        "error": error,
        "case": str(case.path),
        "mesh": str(case.mesh_file),
        "units": {"value": "m", "contact_force": "N", "contact_area": "m^2",
                  "max_pressure": "Pa", "max_penetration": "m", "reaction_force": "N",
                  "rigid_bodies": "value: m (translation) or rad (rotation); reaction: N or "
                                  "N m along the direction / about the axis"},
        "notes": ("contact_force is the total normal force of each pair on the modelled "
                  "part (a symmetric model carries only its share); reaction_force is the "
                  "summed reaction on each [[displacements]] surface along its component; "
                  "rigid_bodies gives each rigid body's coordinate and the force or torque "
                  "that holds it there"),
        "penalty": _one_or_list(result.penalties),
        "model": result.info,
        "timings_s": result.timings,
        "steps": [step_record(s, case) for s in result.steps],
        "fields": {"series": "static.pvd", "frames": [f for _, f in frames]},
    }
    return write_json(out / "summary.json", summary)


DYNAMIC_SCHEMA = "fe-impact/dynamic-summary/1"
HISTORY_UNITS = {"time": "s", "contact_force": "N", "approach": "m", "normal_velocity": "m/s",
                 "kinetic_energy": "J", "strain_energy": "J", "contact_energy": "J",
                 "plastic_dissipation": "J", "total_energy": "J"}


class DynamicWriter:
    """Writes a transient run as it goes: VTU frames, the PVD series and, at the end,
    ``history.csv``, ``summary.json`` and the plots.

    The PVD collection is rewritten (atomically) after every frame, so a run
    stopped part-way leaves a readable series of the frames done so far.
    """

    def __init__(self, out: str | Path, case: Case, mesh, material) -> None:
        self.out = Path(out)
        self.out.mkdir(parents=True, exist_ok=True)
        remove_stale(self.out, "frame_*.vtu")    # an earlier run's frames
        self.case, self.mesh, self.material = case, mesh, material
        self.frames: list[tuple[float, str]] = []

    def frame(self, frame) -> None:
        name = f"frame_{len(self.frames):04d}.vtu"
        write_vtu(self.out / name, self.mesh,
                  point_data={"displacement": frame.u, "velocity": frame.v,
                              "contact_pressure": frame.pressure},
                  cell_data={"von_mises": frame.von_mises, "material": self.material,
                             **({} if frame.plastic_strain is None else
                                {"equivalent_plastic_strain": frame.plastic_strain})})
        self.frames.append((frame.time, name))
        write_pvd(self.out / "impact.pvd", self.frames)

    def finish(self, result, status: str = "completed", error: str | None = None) -> Path:
        """Write history, summary and plots; ``status`` says how the run ended."""
        hist = result.output_history
        keys = list(HISTORY_UNITS)
        # no output yet (a run stopped at once): a (0, k) table, the header alone
        write_array_csv(self.out / "history.csv", [f"{k} [{HISTORY_UNITS[k]}]" for k in keys],
                        np.column_stack([hist[k] for k in keys]))
        plots = plot_impact(self.out, result.history) if len(result.history["time"]) > 1 else []
        summary = {
            "schema": DYNAMIC_SCHEMA,
            "fe_impact_version": __version__,
            "status": status,
            "error": error,
            "case": str(self.case.path),
            "mesh": str(self.case.mesh_file),
            "units": {"peak_force": "N", "max_approach": "m", "contact_duration": "s",
                      "restitution": "-", "energy_error": "-", "impact_velocity": "m/s",
                      "rebound_velocity": "m/s", "residual_indentation": "m",
                      **{f"history.{k}": u for k, u in HISTORY_UNITS.items()}},
            "notes": ("contact_force is the total normal force on the modelled part (a "
                      "symmetric model carries only its share). approach: closing "
                      "displacement of the two sides at the initial contact point along the "
                      "initial normal, minus the initial gap; a side is its rigid body if it "
                      "has one, else its mass-weighted translation along the normal, and a "
                      "supported side is the fixed reference. restitution = -(relative normal "
                      "velocity after separation) / (before first touch). "
                      "residual_indentation: the approach at which the force falls to zero "
                      "on unloading (permanent dent of both sides; 0 when no point yielded). "
                      "energy_error = "
                      "max |E(t) - E(0)| / E(0), E = kinetic + strain + penalty energy (+ plastic "
                      "work when a material yields)."),
            **result.measurements.to_dict(),
            "model": result.info,
            "timings_s": result.timings,
            "history": {k: hist[k] for k in keys},
            "fields": {"series": "impact.pvd", "frames": [f for _, f in self.frames],
                       "frame_times": [t for t, _ in self.frames]},
            "plots": plots,
        }
        return write_json(self.out / "summary.json", summary)


def plot_impact(out: Path, history: dict) -> list[str]:
    """Force against time and against approach (PNG); returns the file names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fe_impact.output.files import atomic_path

    t, F, d = history["time"], history["contact_force"], history["approach"]
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    ax[0].plot(t * 1e6, F, lw=1.2)
    ax[0].set(xlabel="time (us)", ylabel="contact force (N)", title="Force against time")
    on = d > -0.05 * max(d.max(), 1e-30)
    ax[1].plot(d[on] * 1e6, F[on], lw=1.2)
    ax[1].set(xlabel="approach (um)", ylabel="contact force (N)",
              title="Force against approach")
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    with atomic_path(out / "force.png") as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
    E = history
    fig, a = plt.subplots(figsize=(6, 4))
    for k in ("kinetic_energy", "strain_energy", "contact_energy", "plastic_dissipation",
              "total_energy"):
        a.plot(t * 1e6, E[k], label=k.replace("_", " "))
    a.set(xlabel="time (us)", ylabel="energy (J)", title="Energy balance")
    a.legend()
    a.grid(alpha=0.3)
    fig.tight_layout()
    with atomic_path(out / "energy.png") as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
    return ["force.png", "energy.png"]
