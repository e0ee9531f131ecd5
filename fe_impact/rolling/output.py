"""Outputs of a rolling run: JSON and CSV tables, PNG plots, a PVD series.

:func:`write_outputs` writes, in ``out``:

- ``roll.json``: inputs, sizes, costs, energy balance (``energy_balance``: the
  largest error in J, against the kinetic energy and against the work done;
  ``energy_error``: the latter, null at no load), events,
  centrifugal and Coriolis terms;
- ``te.csv``: time, transmission error on the line of action, rotor speeds,
  energies and works;
- ``pairs.csv``: per step and tooth pair in contact: flank, place on the line of
  action, force, contact point (mesh frame);
- ``events.csv``: the contact events (:class:`~fe_impact.rolling.run.ContactEvent`);
- ``pattern.csv``: the contact pattern, each pair's contact points over the run;
- ``te.png``, ``forces.png``, ``events.png``;
- ``frames/rolling.pvd`` with one ``.vtu`` per frame (:class:`FrameWriter`): both
  sectors turned and deformed, von Mises stress as cell data. Its index is
  rewritten after each frame, so a stopped run leaves a readable series.
"""

from __future__ import annotations

import logging
from dataclasses import asdict
from pathlib import Path

import numpy as np

logger = logging.getLogger(__name__)

__all__ = ["FrameWriter", "clear_frames", "write_outputs"]


def clear_frames(out: Path) -> None:
    """Remove an earlier run's PVD series from ``out/frames`` (its own file names only),
    so that a rerun into the same folder does not show the old run's frames."""
    folder = Path(out) / "frames"
    if not folder.is_dir():
        return
    for path in [*folder.glob("frame_*.vtu"), folder / "rolling.pvd",
                 folder / ".rolling.pvd.tmp"]:
        path.unlink(missing_ok=True)
    try:
        folder.rmdir()
    except OSError:     # something else is there: left as it is
        pass


class FrameWriter:
    """Write every ``every``-th step as a VTU frame of the PVD series."""

    def __init__(self, out: Path, roller, mesh_path, every: int) -> None:
        from fe_impact.fe.mesh import load_mesh

        self.folder = Path(out) / "frames"      # made at the first frame, not before
        self.roller, self.every = roller, every
        self.mesh = load_mesh(mesh_path, unit="mm")
        self.entries: list[tuple[float, str]] = []

    def _field(self, body, q: np.ndarray) -> np.ndarray:
        u = np.zeros(body.n_dofs_mesh)
        u[body.free_dofs] = q[:-1]
        return u

    def write(self, step: int, t: float, q_p: np.ndarray, q_f: np.ndarray) -> None:
        if step % self.every:
            return
        import meshio

        from fe_impact.fe.elasticity import von_mises

        r, mesh = self.roller, self.mesh
        u = self._field(r.p, q_p) + self._field(r.f, q_f)
        stress = von_mises(r.p.model, u)
        dofs = 3 * mesh.point_dof[:, None] + np.arange(3)
        x = mesh.points + u[dofs]
        out = x.copy()
        for q, name in ((q_p, "pinion"), (q_f, "face_gear")):
            nodes = np.unique(mesh.cells[mesh.volume(name)])
            origin = r.t_p if name == "pinion" else np.zeros(3)
            rot = np.column_stack([r.world(origin + e, q[-1], name) - r.world(origin, q[-1],
                                                                             name)
                                   for e in np.eye(3)])
            out[nodes] = (x[nodes] - origin) @ rot.T + r.world(origin, q[-1], name)
        cell_type = "tetra10" if mesh.order == 2 else "tetra"
        name = f"frame_{step:06d}.vtu"
        self.folder.mkdir(parents=True, exist_ok=True)
        meshio.write(self.folder / name, meshio.Mesh(
            out, [(cell_type, mesh.cells)], cell_data={"von_mises_pa": [stress]}))
        self.entries.append((t, name))
        rows = "\n".join(f'    <DataSet timestep="{ts:.9g}" file="{f}"/>'
                         for ts, f in self.entries)
        tmp = self.folder / ".rolling.pvd.tmp"
        tmp.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n'
                       f"  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n")
        tmp.replace(self.folder / "rolling.pvd")      # atomic: a stopped run leaves it whole


def write_outputs(out: Path, result, roller) -> None:
    """Write the tables, plots and summary of ``result`` to ``out``."""
    from fe_impact.atomic import write_csv, write_json

    out.mkdir(parents=True, exist_ok=True)
    e = result.energy
    write_csv(out / "te.csv", ["time_s", "te_m", "pinion_speed_rad_s", "face_speed_rad_s",
                               "kinetic_j", "strain_j", "hertz_j", "drive_work_j",
                               "load_work_j", "centrifugal_work_j", "energy_error_j"],
              np.column_stack([result.time_s, result.te_m, result.pinion_speed_rad_s,
                               result.face_speed_rad_s, e["kinetic"], e["strain"], e["hertz"],
                               e["drive_work"], e["load_work"], e["centrifugal_work"],
                               e["error"]]).tolist())
    rows = []
    for n, j, fl in zip(*np.nonzero(result.pair_force_n > 0.0), strict=True):
        rows.append([result.time_s[n], result.teeth[j], "drive" if fl == 0 else "coast",
                     result.pair_s_m[n, j, fl], result.pair_force_n[n, j, fl],
                     *result.contact_point_m[n, j, fl]])
    header = ["time_s", "tooth", "flank", "s_m", "force_n", "x_m", "y_m", "z_m"]
    write_csv(out / "pairs.csv", header, rows)
    write_csv(out / "pattern.csv", header, rows[::max(1, len(rows) // 2000)])
    fields = list(asdict(result.events[0])) if result.events else [
        "time_s", "flank", "tooth", "kind", "closing_speed_m_s", "peak_force_n", "where",
        "s_m", "flank_loaded", "end_time_s", "end_s_m"]
    write_csv(out / "events.csv", fields,
              [[asdict(ev)[k] for k in fields] for ev in result.events])
    balance = result.energy_balance()
    summary = {"info": result.info, "energy_balance": balance,
               "energy_error": balance["relative_to_work"],
               "te_m": {"min": float(result.te_m.min()), "max": float(result.te_m.max()),
                        "mean": float(result.te_m.mean())},
               "peak_pair_force_n": float(result.pair_force_n.max(initial=0.0)),
               "events": [asdict(ev) for ev in result.events]}
    write_json(out / "roll.json", summary)
    try:
        _plots(out, result)
    except Exception as exc:   # noqa: BLE001 - the tables are written; a plot is extra
        logger.warning("plots not written: %s", exc)


def _plots(out: Path, result) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t_ms = result.time_s * 1e3
    fig, ax = plt.subplots(figsize=(8, 3.5))
    ax.plot(t_ms, result.te_m * 1e6)
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("TE on the line of action [um]")
    fig.tight_layout()
    fig.savefig(out / "te.png", dpi=120)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(8, 3.5))
    for j, k in enumerate(result.teeth):
        for fl, style in ((0, "-"), (1, "--")):
            f = result.pair_force_n[:, j, fl]
            if f.max() > 0:
                ax.plot(t_ms, f, style, label=f"pair {k} {'drive' if fl == 0 else 'coast'}")
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("pair force [N]")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "forces.png", dpi=120)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(8, 3.5))
    for kind, marker in (("mesh-in", "o"), ("rattle", "x")):
        ev = [e for e in result.events if e.kind == kind]
        ax.plot([e.time_s * 1e3 for e in ev], [e.peak_force_n for e in ev], marker,
                linestyle="none", label=kind)
    ax.set_xlabel("time of first touch [ms]")
    ax.set_ylabel("peak force [N]")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "events.png", dpi=120)
    plt.close(fig)
