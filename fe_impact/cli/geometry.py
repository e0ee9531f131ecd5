"""``fe-impact geometry``: the checks of a gear set before any finite-element work.

::

    fe-impact geometry [GEARSET] [--torque NM | --schedule FILE] [--root-stress {iso,fe}]
                       [--json FILE]

Prints one column per face-gear stage: the face-width limits (undercut,
conjugate tip, pointing) and the chosen radii, the path of contact in pinion
roll angle and the contact ratio, the Hertz contact at the pitch point under
the nominal load, and the rotor masses reduced to the contact normal
(:func:`fe_impact.api.geometry_report`). ``--json`` writes the same
numbers in SI units. `register` adds the subcommand; bad input raises
`fe_impact.errors.FeImpactError` subclasses (the CLI prints them as one line).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from fe_impact.errors import CaseError, GeometryError

__all__ = ["JSON_SCHEMA", "TABLE", "format_table", "register", "run"]

#: ``schema`` of the file ``--json`` writes.
JSON_SCHEMA = "fe-impact/geometry/1"

_DEG = 180.0 / math.pi

#: Rows of the printed table, by section: (key, label with unit, scale from SI,
#: format). A key ``name[i]`` takes item ``i`` of a list, ``table.name`` a key of a
#: sub-table (``-`` where it is None); strings print as they are.
TABLE: dict[str, tuple[tuple[str, str, float, str], ...]] = {
    "face_width": (
        ("pitch_radius_m", "pitch radius r_2 [mm]", 1e3, ".3f"),
        ("inner_undercut_limit_m", "inner limit: undercut [mm]", 1e3, ".3f"),
        ("inner_conjugate_limit_m", "inner limit: conjugate tip [mm]", 1e3, ".3f"),
        ("outer_pointing_limit_m", "outer limit: pointing [mm]", 1e3, ".3f"),
        ("inner_limit_governing", "inner limit that governs", 1.0, "s"),
        ("inner_undercut_u_m", "undercut limit, shaper axis u_s [mm]", 1e3, ".3f"),
        ("inner_conjugate_u_m", "conjugate-tip limit, u_s [mm]", 1e3, ".3f"),
        ("radius_at_top_land_min_m", "radius of a 0.2 mm top land [mm]", 1e3, ".3f"),
        ("inner_radius_m", "inner radius, chosen [mm]", 1e3, ".3f"),
        ("outer_radius_m", "outer radius, chosen [mm]", 1e3, ".3f"),
        ("face_width_m", "face width [mm]", 1e3, ".3f"),
        ("inner_margin_m", "inner radius - inner limit [mm]", 1e3, ".3f"),
        ("outer_margin_m", "pointing limit - outer radius [mm]", 1e3, ".3f"),
        ("top_land_at_outer_radius_m", "top land at outer radius [mm]", 1e3, ".3f"),
        ("clearance_to_next_ring_m", "radial clearance to next ring [mm]", 1e3, ".3f"),
    ),
    "path_of_contact": (
        ("first_roll_rad", "first point of contact [deg]", _DEG, "+.4f"),
        ("first_limit", "  limited by", 1.0, "s"),
        ("last_roll_rad", "last point of contact [deg]", _DEG, "+.4f"),
        ("last_limit", "  limited by", 1.0, "s"),
        ("path_length_rad", "path length [deg]", _DEG, ".4f"),
        ("angular_pitch_rad", "angular pitch 360/N_p [deg]", _DEG, ".4f"),
        ("contact_ratio", "contact ratio [-]", 1.0, ".4f"),
    ),
    "pitch_point": (
        ("pinion_curvatures_1_m[0]", "pinion curvature k_1 [1/m]", 1.0, ".4g"),
        ("pinion_curvatures_1_m[1]", "pinion curvature k_2 [1/m]", 1.0, ".4g"),
        ("face_curvatures_1_m[0]", "face-gear curvature k_1 [1/m]", 1.0, ".4g"),
        ("face_curvatures_1_m[1]", "face-gear curvature k_2 [1/m]", 1.0, ".4g"),
        ("relative_curvatures_1_m[0]", "relative curvature 2A (min) [1/m]", 1.0, ".4g"),
        ("relative_curvatures_1_m[1]", "relative curvature 2B (max) [1/m]", 1.0, ".4g"),
        ("relative_radii_m[0]", "relative radius R_x (major axis) [mm]", 1e3, ".4g"),
        ("relative_radii_m[1]", "relative radius R_y (minor axis) [mm]", 1e3, ".4g"),
        ("equivalent_radius_m", "equivalent radius R_eq [mm]", 1e3, ".4g"),
        ("effective_modulus_Pa", "E* [GPa]", 1e-9, ".5g"),
        ("load_torque_Nm", "load torque on the output [N m]", 1.0, ".4g"),
        ("normal_force_N", "normal force per mesh [N]", 1.0, ".4g"),
        ("a_m", "Hertz semi-axis a [mm]", 1e3, ".4g"),
        ("b_m", "Hertz semi-axis b [mm]", 1e3, ".4g"),
        ("max_pressure_Pa", "max pressure p0 [MPa]", 1e-6, ".4g"),
        ("approach_m", "approach delta [um]", 1e6, ".4g"),
        ("contact_stress_limit_Pa", "allowable sigma_Hlim (material) [MPa]", 1e-6, ".4g"),
        ("contact_stress_ratio", "p0 / sigma_Hlim [-]", 1.0, ".3f"),
        ("ellipse_nearest_edge", "ellipse: nearest edge", 1.0, "s"),
        ("ellipse_past_edge_m", "  cut off past it (+) / short of it (-) [mm]", 1e3, "+.4g"),
    ),
    "root_bending": (
        ("load_radius_m", "load at pinion radius [mm]", 1e3, ".4g"),
        ("s_Fn_m", "30 deg section chord s_Fn [mm]", 1e3, ".4g"),
        ("h_Fe_m", "bending arm h_Fe [mm]", 1e3, ".4g"),
        ("rho_F_m", "fillet radius rho_F there [mm]", 1e3, ".4g"),
        ("Y_F", "form factor Y_F [-]", 1.0, ".4f"),
        ("Y_S", "stress correction Y_S [-]", 1.0, ".4f"),
        ("face_width_m", "b: face-gear face width [mm]", 1e3, ".4g"),
        ("sigma_F0_Pa", "ISO-style sigma_F0 = F_t/(b m) Y_F Y_S [MPa]", 1e-6, ".4g"),
        ("fe_pinion_Pa", "FE: pinion fillet, peak tension [MPa]", 1e-6, ".4g"),
        ("fe_pinion_element_m", "  element size at the peak [mm]", 1e3, ".3g"),
        ("fe_over_iso", "  FE / ISO-style [-]", 1.0, ".3f"),
        ("fe_face_Pa", "FE: face-gear root (sharp corner) [MPa]", 1e-6, ".4g"),
        ("fe_face_element_m", "  element size at the peak [mm]", 1e3, ".3g"),
        ("allowable_Pa", "allowable 2 sigma_Flim (material) [MPa]", 1e-6, ".4g"),
        ("iso_ratio", "sigma_F0 / allowable [-]", 1.0, ".3f"),
        ("fe_ratio", "FE pinion peak / allowable [-]", 1.0, ".3f"),
    ),
    "masses": (
        ("pinion_inertia_kg_m2", "pinion inertia I_1 [kg m^2]", 1.0, ".4g"),
        ("face_inertia_kg_m2", "face-gear inertia I_2 [kg m^2]", 1.0, ".4g"),
        ("pinion_lever_m", "pinion lever l_1 [mm]", 1e3, ".4g"),
        ("face_lever_m", "face-gear lever l_2 [mm]", 1e3, ".4g"),
        ("pinion_mass_kg", "pinion mass I_1/l_1^2 [kg]", 1.0, ".4g"),
        ("face_mass_kg", "face-gear mass I_2/l_2^2 [kg]", 1.0, ".4g"),
        ("effective_mass_kg", "effective mass [kg]", 1.0, ".4g"),
    ),
    "tip_edges": (
        ("face_radius_m", "face-gear tip-edge radius [mm]", 1e3, ".3f"),
        ("face_limit_m", "  largest the top land takes [mm]", 1e3, ".3f"),
        ("face_limit_at_radius_m", "  at radius [mm]", 1e3, ".2f"),
        ("pinion_radius_m", "pinion tip-edge radius [mm]", 1e3, ".3f"),
        ("pinion_tip_land_left_m", "  pinion tip land left [mm]", 1e3, ".3f"),
        ("pinion_tip_land_sharp_m", "  pinion tip land, sharp edges [mm]", 1e3, ".3f"),
        ("line_start_m", "flank contact starts at s [mm]", 1e3, ".4f"),
        ("line_start_sharp_m", "  with sharp edges [mm]", 1e3, ".4f"),
        ("line_end_m", "flank contact ends at s [mm]", 1e3, ".4f"),
        ("line_end_sharp_m", "  with sharp edges [mm]", 1e3, ".4f"),
        ("contact_ratio", "contact ratio on the line of action [-]", 1.0, ".4f"),
        ("contact_ratio_sharp", "  with sharp edges [-]", 1.0, ".4f"),
    ),
    "corners": tuple(
        row for side in ("approach", "recess") for row in (
            (f"{side}.roll_rad", f"{side}: roll angle [deg]", _DEG, "+.4f"),
            (f"{side}.line_beyond_end_m", "  beyond the flank's end [mm]", 1e3, ".4f"),
            (f"{side}.planar_gap_m", "  gap, planar model [um]", 1e6, ".3g"),
            (f"{side}.midplane_gap_m", "  gap, 3-D in the mid-face plane [um]", 1e6, ".3g"),
            (f"{side}.gap_m", "  gap, 3-D over the face [um]", 1e6, ".3g"),
            (f"{side}.section_m", "  touching at L (approach) / u (recess) [mm]", 1e3, ".3f"),
            (f"{side}.a_m", "  Hertz semi-axis a, nominal load [mm]", 1e3, ".4g"),
            (f"{side}.b_m", "  Hertz semi-axis b [mm]", 1e3, ".4g"),
            (f"{side}.max_pressure_Pa", "  max pressure p0 [MPa]", 1e-6, ".4g"),
            (f"{side}.arc_margin_rad", "  touch to the rounding's nearer end [deg]", _DEG,
             ".3f"),
            (f"{side}.rounding_force_N", "  Hertz ellipse on the rounding up to [N]", 1.0,
             ".3g"),
        )),
}

_TITLES = {
    "face_width": "face width",
    "path_of_contact": "path of contact (pinion roll angle from the pitch point)",
    "pitch_point": "Hertz contact at the pitch point (roll angle 0), nominal load",
    "root_bending": "tooth-root bending at the pitch point, one pair carrying the normal force",
    "masses": "rotor masses reduced to the contact normal at the pitch point",
    "tip_edges": "tip edges, and the line of action of the torsional model (s from the "
                 "base-circle tangency)",
    "corners": "first touch on a rounded tip edge, where the planar corner gap is 10 um "
               "(approach: face-gear edge on the pinion; recess: pinion edge on the face gear)",
}


def register(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``geometry`` subcommand to ``subparsers``; returns its parser."""
    p = subparsers.add_parser(
        "geometry", help="face-width limits, path of contact, Hertz and masses per stage",
        description="What to check before any finite-element work, per face-gear stage: "
                    "face-width limits by undercut, conjugate tip and pointing with the chosen "
                    "radii; the path of contact in pinion roll angle and the contact ratio "
                    "(tooth contact analysis); at the pitch point the curvatures, E*, the "
                    "Hertz ellipse, pressure and approach under the nominal load; the rotor "
                    "masses reduced to the contact normal. One column per stage.")
    p.add_argument("gearset", nargs="?", type=Path, default=None,
                   help="gear-set TOML file (default: the built-in seed set)")
    p.add_argument("--torque", type=float, default=None, metavar="NM",
                   help="load torque on the output [N m] for the Hertz numbers (default: the "
                        "largest load of the seed presets, 1 N m)")
    p.add_argument("--schedule", type=Path, default=None, metavar="FILE",
                   help="a schedule file: each stage at the largest load its segments give it "
                        "(a stage the schedule leaves out: at the schedule's largest load)")
    p.add_argument("--root-stress", default="iso", metavar="{iso,fe}",
                   help="iso: the pinion's ISO 6336-3 style root stress only (default); fe: "
                        "also mesh each stage's tooth pair (coarse) and press it with the "
                        "normal force, for the FE's peak root tensions (about 20 s of CPU a "
                        "stage)")
    p.add_argument("--cache", type=Path, default=Path("cache"),
                   help="mesh cache folder of --root-stress fe (default: cache)")
    p.add_argument("--json", type=Path, default=None, metavar="FILE",
                   help="also write the numbers to FILE as JSON, in SI units")
    p.set_defaults(func=run)
    return p


def _check(args: argparse.Namespace) -> None:
    """Options and the output file, before any computation."""
    from fe_impact.output.files import check_output_dir

    if args.torque is not None and not (math.isfinite(args.torque) and args.torque > 0.0):
        raise CaseError(f"--torque {args.torque:g} N m: must be a number > 0")
    if args.root_stress not in ("iso", "fe"):
        raise CaseError(f"--root-stress {args.root_stress}: must be iso (the ISO 6336-3 style "
                        "figure) or fe (also the FE's peak root tensions)")
    if args.torque is not None and args.schedule is not None:
        raise CaseError(f"--torque {args.torque:g} and --schedule {args.schedule}: give one "
                        "of them (the schedule sets each stage's load)")
    if args.schedule is not None and not args.schedule.is_file():
        what = "is a folder" if args.schedule.is_dir() else "no such file"
        raise CaseError(f"--schedule {args.schedule}: {what}; give a schedule TOML file")
    if args.json is not None:
        if args.json.is_dir():
            raise CaseError(f"--json {args.json}: is a folder; give a file name "
                            "(e.g. geometry.json)")
        check_output_dir(args.json.resolve().parent, f"--json {args.json}: folder")


def _load(path: Path | None):
    """The gear set at ``path``, or the built-in seed set; errors name GEARSET."""
    from fe_impact.api import read_gearset

    if path is None:
        return read_gearset(None)
    if path.is_dir():
        raise GeometryError(f"GEARSET {path}: is a folder; give a gear-set TOML file, or "
                            "none for the built-in seed set")
    if not path.exists():
        raise GeometryError(f"GEARSET {path}: no such file; give a gear-set TOML file, or "
                            "none for the built-in seed set")
    try:
        return read_gearset(path)
    except GeometryError as exc:
        raise GeometryError(f"GEARSET {exc}") from exc


def _schedule_torques(path: Path, gearset) -> tuple[list[float], list[str]]:
    """Each stage's load [N m] from the schedule at ``path``: the largest of its
    segments on that stage, the schedule's largest for a stage it leaves out; and a
    note per stage saying which."""
    from fe_impact.api import read_schedule

    duty = read_schedule(path)
    duty.check_gearset(gearset)
    segments = duty.schedule.segments
    top = duty.max_load
    if not top > 0.0:
        raise CaseError(f"--schedule {path}: every segment's load_Nm is 0; give a schedule "
                        "with a load, or --torque")
    torques, notes = [], []
    for number in range(1, len(gearset.stages) + 1):
        loads = [seg.max_load for seg in segments if seg.stage == number]
        if loads and max(loads) > 0.0:
            torques.append(max(loads))
            notes.append(f"stage {number}: {max(loads):g} N m, its largest in the schedule")
        else:
            torques.append(top)
            why = "not loaded" if loads else "not in the schedule"
            notes.append(f"stage {number}: {why}; at the schedule's largest, {top:g} N m")
    return torques, notes


def _cell(row: dict, section: str, key: str, scale: float, spec: str) -> str:
    name, _, item = key.partition("[")
    value = row[section]
    for part in name.split("."):      # "side.key": a key of a sub-table (None: absent)
        value = None if value is None else value[part]
    if item and value is not None:
        value = value[int(item.rstrip("]"))]
    if value is None:
        return "-"
    if isinstance(value, str):
        return value
    return format(float(value) * scale, spec)


def format_table(rows: list[dict]) -> str:
    """The aligned table of :func:`fe_impact.api.geometry_report`'s rows:
    one column per stage, a titled block per section, units in the labels."""
    lines = [("", [f"stage {r['stage']}" for r in rows]),
             ("face-gear teeth / shaper teeth", [f"{r['teeth']} / {r['shaper_teeth']}"
                                                 for r in rows])]
    for section, entries in TABLE.items():
        lines.append((None, [_TITLES[section]]))
        lines += [(label, [_cell(r, section, key, scale, spec) for r in rows])
                  for key, label, scale, spec in entries]
    width = max(len(label) for label, _ in lines if label is not None)
    column = max(len(v) for label, values in lines if label is not None for v in values)
    out = []
    for label, values in lines:
        if label is None:
            out.append(f"\n{values[0]}:")
        else:
            out.append(f"{label:<{width}}" + "".join(f"  {v:>{column}}" for v in values))
    return "\n".join(out)


def _torque_text(torque: float | list[float]) -> str:
    """``100`` or ``100 / 250 / 250`` (one per stage)."""
    if isinstance(torque, list):
        return " / ".join(f"{t:g}" for t in torque)
    return f"{torque:g}"


def run(args: argparse.Namespace) -> int:
    """Handler of ``fe-impact geometry``; returns the exit status."""
    from fe_impact.api import TOP_LAND_MIN, geometry_report, seed_load_torque
    from fe_impact.atomic import write_json

    _check(args)
    gearset = _load(args.gearset)
    default = args.torque is None and args.schedule is None
    notes: list[str] = []
    if args.schedule is not None:
        torque, notes = _schedule_torques(args.schedule, gearset)
        source = f"from --schedule {args.schedule}"
    else:
        torque = seed_load_torque() if default else args.torque
        source = ("the largest load of the seed presets\n(table4, variable-load; --torque "
                  "changes it)" if default else "from --torque")
    rows = geometry_report(gearset, torque, root_stress=args.root_stress, cache=args.cache)
    print(f"{gearset.name}: {len(rows)} stage(s), pinion {gearset.pinion.teeth} teeth, "
          f"module {gearset.module * 1e3:g} mm, {gearset.n_pinions} pinion(s)")
    print(format_table(rows))
    print("\nInner limit, stage by stage: " + "; ".join(
        f"{r['stage']}: {r['face_width']['inner_limit_reason']}" for r in rows))
    print(f"Top land: arc width at the tip plane; the seed file takes the outer radii where "
          "it is "
          f"{TOP_LAND_MIN * 1e3:g} mm.\nRoll angles: pinion rotation from the pitch-point "
          "position; first and last in the order\na driving pinion meets them.\n"
          f"Load: {_torque_text(torque)} N m on the output, {source}: each of the "
          f"{gearset.n_pinions} meshes carries\nF = T / (n_pinions l_2).\n"
          + "".join(f"  {note}\n" for note in notes) +
          "Ellipse: how far the Hertz ellipse at the pitch point runs past the nearest edge of "
          "the\nworking flanks (< 0: it fits; > 0: it is cut off, and the pressure at that edge "
          "exceeds p0).\n"
          "First touch: 3-D gaps are how far the pinion (approach) or the face gear "
          "(recess)\nturns from the conjugate position to touch, times its base lever; "
          "'-' for a sharp edge.\n"
          "Root bending: ISO 6336-3 method B's 30 deg tangent section on the pinion's "
          "generated fillet,\nthe load at the pitch point on one pair, b the face gear's "
          "face width; the allowable is\nY_ST sigma_Flim = 2 x the material's "
          "bending_stress_limit_pa (ISO 6336-5). "
          + ("FE: the largest maximum\nprincipal stress in the loaded root at the pitch "
             "point (coarse mesh: the peak is\nunderestimated where the element is larger "
             "than rho_F); the face gear's root is a\nsharp corner in the mesh, its figure "
             "mesh-dependent." if args.root_stress == "fe" else
             "--root-stress fe adds the FE's peak\nroot tensions."))
    if args.json is not None:
        write_json(args.json, {
            "schema": JSON_SCHEMA,
            "gearset": gearset.name,
            "gearset_file": None if args.gearset is None else str(args.gearset),
            "n_pinions": gearset.n_pinions,
            "pinion_teeth": gearset.pinion.teeth,
            "module_m": gearset.module,
            "inner_limit_rule": gearset.inner_limit,
            "load_torque_Nm": torque,
            "load_torque_source": ("seed presets (largest load)" if default else
                                   "--torque" if args.schedule is None else "--schedule"),
            "schedule_file": None if args.schedule is None else str(args.schedule),
            "stages": rows,
        })
        print(f"wrote {args.json}")
    return 0
