"""Turn solver results into files: ``summary.json``, VTU frames and a PVD series."""

from __future__ import annotations

from pathlib import Path

from . import __version__
from .case import Case
from .io import write_json, write_pvd, write_vtu
from .static import StaticResult, StepResult

SUMMARY_SCHEMA = "fe-impact/static-summary/1"


def _one_or_list(values: list[float]) -> float | list[float]:
    return values[0] if len(values) == 1 else values


def step_record(step: StepResult) -> dict:
    """The JSON record of one load step (SI units)."""
    return {
        "value": step.value,
        "contact_force": _one_or_list(step.contact_force),
        "contact_area": _one_or_list(step.contact_area),
        "max_pressure": step.max_pressure,
        "max_penetration": step.max_penetration,
        "reaction_force": _one_or_list(step.reaction_force),
        "iterations": step.iterations,
        "active_set_iterations": step.active_set_iterations,
    }


def write_static_results(out: str | Path, case: Case, result: StaticResult) -> Path:
    """Write ``summary.json``, ``step_NNN.vtu`` and ``static.pvd`` to ``out``."""
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
    summary = {
        "schema": SUMMARY_SCHEMA,
        "fe_impact_version": __version__,
        "case": str(case.path),
        "mesh": str(case.mesh_file),
        "units": {"value": "m", "contact_force": "N", "contact_area": "m^2",
                  "max_pressure": "Pa", "max_penetration": "m", "reaction_force": "N"},
        "notes": ("contact_force is the total normal force of each pair on the modelled "
                  "part (a symmetric model carries only its share); reaction_force is the "
                  "summed reaction on each [[displacements]] surface along its component"),
        "penalty": _one_or_list(result.penalties),
        "model": result.info,
        "timings_s": result.timings,
        "steps": [step_record(s) for s in result.steps],
        "fields": {"series": "static.pvd", "frames": [f for _, f in frames]},
    }
    return write_json(out / "summary.json", summary)
