"""``--to tables``: the calibrated laws as CSV tables for a general force element.

Three files, SI units (the column names carry them):

- ``impact_laws.csv``: one row per calibrated impact, ``stage, kind,
  impact_speed_m_s, k_N_per_m_pow_exponent, exponent, cmax_N_s_per_m, d_m``:
  the ADAMS IMPACT law against closing speed and kind of contact;
- ``pair_stiffness.csv``: the mesh cycle's position law, ``stage,
  roll_angle_deg, k, exponent`` (and each rounded tip edge's corner law,
  ``position`` = ``corner-approach`` or ``corner-recess``);
- ``contact_table.csv``: the two combined, ``stage, kind, impact_speed,
  roll_angle_deg, k, exponent, cmax, d`` for every kind, speed and position:
  on the flanks ``k`` and the exponent are the position law's at that roll
  angle (the impact's own where the file has no mesh cycle: roll angle
  empty), ``cmax`` and ``d`` the impact's. This is how fe-impact's switching
  model combines them (`fe_impact.switching.calibration`).

Roll angle: the pinion's roll from the pitch point [deg]; the line-of-action
coordinate is ``s = s_pitch - r_bp roll``, so a positive roll lies towards
the start of the path of contact (approach).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path

from fe_impact.atomic import atomic_path, write_csv
from fe_impact.calibration.records import KINDS, Calibration, CalibrationRecord

logger = logging.getLogger(__name__)

__all__ = ["LAW_COLUMNS", "contact_rows", "law_rows", "position_rows", "write_tables"]

LAW_COLUMNS = ("stage", "kind", "impact_speed_m_s", "k_N_per_m_pow_exponent", "exponent",
               "cmax_N_s_per_m", "d_m")
POSITION_COLUMNS = ("stage", "position", "roll_angle_deg", "k_N_per_m_pow_exponent",
                    "exponent")
CONTACT_COLUMNS = ("stage", "kind", "impact_speed_m_s", "roll_angle_deg",
                   "k_N_per_m_pow_exponent", "exponent", "cmax_N_s_per_m", "d_m")


def sorted_cases(calibration: Calibration) -> list[CalibrationRecord]:
    """The cases by stage, kind (in `KINDS` order) and impact speed."""
    return sorted(calibration.cases, key=lambda c: (c.stage, KINDS.index(c.kind),
                                                    c.impact_speed))


def law_rows(calibration: Calibration) -> list[list]:
    """`LAW_COLUMNS` rows, one per case."""
    return [[c.stage, c.kind, c.impact_speed, c.impact.k, c.impact.exponent, c.impact.cmax,
             c.impact.d] for c in sorted_cases(calibration)]


def position_rows(calibration: Calibration) -> list[list]:
    """`POSITION_COLUMNS` rows: the mesh cycle's positions, then its corner laws."""
    rows = []
    for stage, law in sorted((calibration.mesh_cycle or {}).items(), key=lambda i: int(i[0])):
        for a, k, e in zip(law["roll_angle_deg"], law["k"], law["exponent"], strict=True):
            rows.append([int(stage), "flank", a, k, e])
        for side, corner in sorted((law.get("corners") or {}).items()):
            rows.append([int(stage), f"corner-{side}", corner.get("roll_angle_deg", ""),
                         corner["k"], corner["exponent"]])
    return rows


def contact_rows(calibration: Calibration) -> list[list]:
    """`CONTACT_COLUMNS` rows: every case at every position of its stage's law."""
    rows = []
    cycles = calibration.mesh_cycle or {}
    for c in sorted_cases(calibration):
        law = cycles.get(str(c.stage))
        damping = [c.impact.cmax, c.impact.d]
        corner = (law or {}).get("corners", {}).get(c.kind.removeprefix("corner-"))
        if c.kind.startswith("corner") and corner is not None:
            rows.append([c.stage, c.kind, c.impact_speed, corner.get("roll_angle_deg", ""),
                         corner["k"], corner["exponent"], *damping])
        elif law is None or c.kind.startswith("corner"):
            rows.append([c.stage, c.kind, c.impact_speed, "", c.impact.k, c.impact.exponent,
                         *damping])
        else:
            rows.extend([c.stage, c.kind, c.impact_speed, a, k, e, *damping]
                        for a, k, e in zip(law["roll_angle_deg"], law["k"], law["exponent"],
                                           strict=True))
    return rows


def write_tables(calibration: Calibration, out: Path) -> list[Path]:
    """Write the three CSV files to ``out``; returns them."""
    files: Sequence[tuple[str, Sequence[str], list]] = (
        ("impact_laws.csv", LAW_COLUMNS, law_rows(calibration)),
        ("pair_stiffness.csv", POSITION_COLUMNS, position_rows(calibration)),
        ("contact_table.csv", CONTACT_COLUMNS, contact_rows(calibration)),
    )
    return [*(write_csv(out / name, header, rows) for name, header, rows in files),
            write_readme(out)]


README = """fe-impact calibration as tables (SI units: m, N, s)
===================================================

impact_laws.csv     stage, kind, impact_speed_m_s, k_N_per_m_pow_exponent, exponent,
                    cmax_N_s_per_m, d_m: the ADAMS IMPACT law
                    F = max(0, k h^exponent + STEP(h, 0, 0, d, cmax) hdot)
                    (h the penetration, hdot its rate) fitted to each FE impact,
                    against the closing speed at the contact's onset and the kind
                    of contact (mesh, switch, corner-approach, corner-recess).
pair_stiffness.csv  stage, position, roll_angle_deg, k, exponent: the pair's
                    stiffness law along the path of contact (position = flank), and
                    on each rounded tip edge (corner-approach, corner-recess).
contact_table.csv   stage, kind, impact_speed_m_s, roll_angle_deg, k, exponent, cmax,
                    d: both combined, as fe-impact's switching model applies them: k
                    and exponent of the position (log k and the exponent linear in
                    roll angle between rows, held beyond the ends), cmax and d of the
                    impact's onset (linear in log speed between speeds, held beyond).
                    An empty roll angle: the same at every position.

Roll angle: the pinion's roll from the pitch point [deg]. The line-of-action
coordinate is s = s_pitch - r_bp * roll (r_bp the pinion's base radius): a positive
roll lies towards the start of the path of contact, where a pair enters mesh.

Using the tables elsewhere
- a general force element (Simpack, RecurDyn, your own code): the force law above
  with k(roll) and exponent(roll) from pair_stiffness.csv or contact_table.csv,
  cmax and d from impact_laws.csv at the onset's closing speed;
- a k(position) file (GEARpie-style, a RecurDyn gear meta-model table): position
  column <- roll_angle_deg (or s), stiffness <- k_N_per_m_pow_exponent; the
  exponent column tells whether the law is linear (1) or Hertzian (about 1.5): a
  tool that takes a linear mesh stiffness needs the secant or tangent stiffness at
  its load, k * exponent * h^(exponent - 1) at the penetration h of that load.
"""


def write_readme(out: Path) -> Path:
    """Write the tables' README.txt."""
    return write_text(out / "README.txt", README)


def write_text(path: Path, text: str) -> Path:
    """Write ``text`` to ``path``, atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return path
