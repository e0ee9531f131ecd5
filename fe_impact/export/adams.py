"""``--to adams``: the calibrated IMPACT laws in ADAMS's units and syntax.

Unit system: millimetre, newton, second, kilogram (ADAMS's MMKS, ``UNITS/
LENGTH = MILLIMETER, FORCE = NEWTON, MASS = KILOGRAM, TIME = SECOND``).
``F = k h^e`` with ``h`` in mm gives the stiffness in N/mm^e:
``k_mm = k_SI * 1e-3^e``; damping ``cmax`` in N s/mm (``* 1e-3``);
penetration ``d`` in mm (``* 1e3``). The exponent does not change.

Files:

- ``impact_contacts.adm``: per stage, kind of contact and calibrated
  closing speed, an ``SFORCE`` whose function is
  ``IMPACT(DM(I,J), VR(I,J), x1, k, e, cmax, d)`` (solver dataset
  syntax; ``I``, ``J`` and the free length ``x1`` are placeholders);
- ``impact_contacts.cmd``: the same parameters as Adams View ``contact
  create`` commands (``stiffness``, ``exponent``, ``damping``, ``dmax``),
  geometry names as placeholders;
- ``pair_stiffness_splines.adm`` and ``pair_stiffness_mm.csv``: where the
  calibration has a mesh cycle, ``k`` and the exponent against the pinion
  roll angle as ``SPLINE`` statements and a CSV (ADAMS's IMPACT takes
  constant parameters: the splines go into a general ``SFORCE`` function,
  see README.txt);
- ``README.txt``: how to use them.
"""

from __future__ import annotations

import logging
from pathlib import Path

from fe_impact.atomic import atomic_path, write_csv
from fe_impact.calibration.records import Calibration
from fe_impact.export.tables import sorted_cases

logger = logging.getLogger(__name__)

__all__ = ["MM", "adams_parameters", "write_adams"]

#: Metres per millimetre.
MM = 1e-3
#: First SFORCE / SPLINE identifiers (ADAMS statement ids must be unique).
_SFORCE_ID, _SPLINE_ID = 1001, 2001


def adams_parameters(k: float, exponent: float, cmax: float, d: float) -> tuple[float, ...]:
    """An IMPACT law's ``(k, exponent, cmax, d)`` from SI (N/m^e, -, N s/m, m) to
    MMKS (N/mm^e, -, N s/mm, mm)."""
    return k * MM**exponent, exponent, cmax * MM, d / MM


def _header(calibration: Calibration, comment: str) -> list[str]:
    return [f"{comment} fe-impact calibration export, schema {calibration.schema}",
            f"{comment} units: mm, N, s, kg; k in N/mm^exponent, cmax in N s/mm, d and "
            "penetration in mm"]


def _adm(calibration: Calibration) -> str:
    lines = _header(calibration, "!")
    lines += ["UNITS/FORCE = NEWTON, MASS = KILOGRAM, LENGTH = MILLIMETER, TIME = SECOND", "!",
              "! One SFORCE per stage, kind of contact and calibrated closing speed: keep",
              "! the one whose speed is nearest your model's closing speed (README.txt).",
              "! I, J: markers on the two teeth, on the line of action (the force pushes",
              "! them apart along I-J); x1: their distance at first touch [mm]."]
    for n, c in enumerate(sorted_cases(calibration)):
        k, e, cmax, d = adams_parameters(c.impact.k, c.impact.exponent, c.impact.cmax,
                                         c.impact.d)
        lines += ["!", f"! stage {c.stage}, {c.kind}, closing speed "
                       f"{c.impact_speed * 1e3:.6g} mm/s",
                  f"SFORCE/{_SFORCE_ID + n}, I = <I>, J = <J>, TRANSLATION",
                  f", FUNCTION = IMPACT(DM(<I>, <J>), VR(<I>, <J>), <x1>, "
                  f"{k:.8g}, {e:.8g}, {cmax:.8g}, {d:.8g})"]
    return "\n".join(lines) + "\n"


def _cmd(calibration: Calibration) -> str:
    lines = _header(calibration, "!")
    lines += ["default units length = mm force = newton mass = kg time = second"]
    for c in sorted_cases(calibration):
        k, e, cmax, d = adams_parameters(c.impact.k, c.impact.exponent, c.impact.cmax,
                                         c.impact.d)
        name = f"stage{c.stage}_{c.kind.replace('-', '_')}_{c.impact_speed * 1e3:.4g}mm_s"
        lines += ["!", f"! stage {c.stage}, {c.kind}, closing speed "
                       f"{c.impact_speed * 1e3:.6g} mm/s",
                  f"contact create contact_name = .model.{name.replace('.', 'p')} &",
                  "   i_geometry_name = <pinion_flank> j_geometry_name = <face_flank> &",
                  f"   stiffness = {k:.8g} exponent = {e:.8g} damping = {cmax:.8g} "
                  f"dmax = {d:.8g}"]
    return "\n".join(lines) + "\n"


def _splines(calibration: Calibration) -> tuple[str, list[list]] | None:
    """The mesh cycles as SPLINE statements (k in N/mm^e, and the exponent, against the
    roll angle in degrees) and CSV rows; None without a mesh cycle."""
    if not calibration.mesh_cycle:
        return None
    lines = _header(calibration, "!")
    rows = []
    ident = _SPLINE_ID
    for stage, law in sorted(calibration.mesh_cycle.items(), key=lambda i: int(i[0])):
        roll, e = law["roll_angle_deg"], law["exponent"]
        k = [kk * MM**ee for kk, ee in zip(law["k"], e, strict=True)]
        rows += [[int(stage), a, kk, ee] for a, kk, ee in zip(roll, k, e, strict=True)]
        for what, values, where in (("k [N/mm^exponent]", k, ident),
                                    ("exponent [-]", e, ident + 1)):
            lines += ["!", f"! stage {stage}: {what} against pinion roll angle [deg]",
                      f"SPLINE/{where}", ", X = " + ", ".join(f"{a:.8g}" for a in roll),
                      ", Y = " + ", ".join(f"{v:.8g}" for v in values)]
        ident += 10
    return "\n".join(lines) + "\n", rows


README = """fe-impact calibration in ADAMS units and syntax
===============================================

Units: millimetre, newton, second, kilogram (MMKS). Stiffness k in N/mm^exponent,
damping cmax in N s/mm, penetration d in mm. From SI: k_mm = k_SI * 0.001^exponent,
cmax_mm = cmax_SI * 0.001, d_mm = d_SI * 1000.

impact_contacts.adm   SFORCE statements with IMPACT(x, xdot, x1, k, exponent, cmax, d),
                      one per stage, kind of contact and calibrated closing speed.
                      Replace <I>, <J> by markers on the two teeth, on the line of
                      action (the force pushes them apart along I-J), and <x1> by
                      their distance at first touch [mm].
impact_contacts.cmd   The same parameters as Adams View `contact create` commands
                      (stiffness, exponent, damping, dmax = d); replace the geometry
                      names. Import with File > Import > Adams View command file.

ADAMS's IMPACT has constant parameters, fe-impact's law depends on:
- the closing speed at the contact's onset: keep the statement whose closing speed
  is nearest your model's (in mesh, seed eq. 4; after a ratio switch, eq. 5), or
  run one case per speed;
- the kind of contact: `mesh` (flank contact in mesh or rattle), `switch` (the
  first contact after a ratio switch), `corner-approach` / `corner-recess`
  (a rounded tip edge before / after the path of contact);
- the pair's position along the path of contact (the mesh cycle), when the
  calibration has one: pair_stiffness_splines.adm holds, per stage, SPLINE
  statements of k [N/mm^exponent] and of the exponent against the pinion's roll
  angle from the pitch point [deg] (ids 2001/2002 for stage 1, 2011/2012 for
  stage 2, ...); pair_stiffness_mm.csv holds the same table. Use them in a general
  SFORCE in place of IMPACT, with ROLL an expression of the pinion's roll angle
  in degrees, H = x1 - DM(I,J) the penetration [mm] and HDOT = -VR(I,J) its
  rate [mm/s] (positive while closing):
    FUNCTION = IF(H: 0, 0, MAX(0, AKISPL(ROLL, 0, 2001) * H**AKISPL(ROLL, 0, 2002)
               + STEP(H, 0, 0, d, cmax) * HDOT))
  cmax and d stay those of the IMPACT statement of your closing speed.
  fe-impact holds k and the exponent at the table's end values beyond its first
  and last roll angle, whereas AKISPL extrapolates: clamp ROLL to the spline's X
  range, e.g. MAX(-14, MIN(18, ROLL)) for X = -14 .. 18. Between the rows
  fe-impact takes log k and the exponent linear in the roll angle, AKISPL an
  Akima curve through the same rows.
"""


def write_adams(calibration: Calibration, out: Path) -> list[Path]:
    """Write the ADAMS files and README.txt to ``out``; returns them."""
    written = []
    for name, text in (("impact_contacts.adm", _adm(calibration)),
                       ("impact_contacts.cmd", _cmd(calibration))):
        with atomic_path(out / name) as tmp:
            tmp.write_text(text)
        written.append(out / name)
    splines = _splines(calibration)
    if splines is not None:
        text, rows = splines
        with atomic_path(out / "pair_stiffness_splines.adm") as tmp:
            tmp.write_text(text)
        written.append(out / "pair_stiffness_splines.adm")
        written.append(write_csv(out / "pair_stiffness_mm.csv",
                                 ["stage", "roll_angle_deg", "k_N_per_mm_pow_exponent",
                                  "exponent"], rows))
    else:   # an earlier export's splines are not this calibration's
        for name in ("pair_stiffness_splines.adm", "pair_stiffness_mm.csv"):
            (out / name).unlink(missing_ok=True)
    readme = README if splines is not None else README + (
        "\nThis calibration has no mesh cycle (no position dependence): no spline files.\n")
    with atomic_path(out / "README.txt") as tmp:
        tmp.write_text(readme)
    written.append(out / "README.txt")
    return written
