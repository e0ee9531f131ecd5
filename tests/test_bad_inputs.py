"""Bad inputs to every command: one line naming the file, key or option, the value and
what is allowed; exit status 2; no traceback; nothing written, and all of it before
any computation starts.

Each table row is (id, argv builder, words the message must hold). A builder
gets the test's folder and returns the command line; ``OUT`` stands for the
output folder, which must not exist afterwards.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from fe_impact.cli.main import main
from fe_impact.gears.gearset import default_gearset_path
from validation.hertz_static import DISPLACEMENTS
from validation.impact_cases import NU, RHO, E

MESHES = Path(__file__).resolve().parents[1] / "meshes"

# Case files as text, for the reader's tests: these files are broken on purpose
# by editing the text (the package writes cases with fe_impact.fe.casefile).
_MATERIAL = f"""\
[[materials]]
volumes = {{volumes}}
youngs_modulus = {E}
poisson_ratio = {NU}
density = {RHO:g}
"""

#: The quarter sphere-on-block specimen: mesh, material, contact and supports; the
#: static and the impact cases add their loading to it.
SPECIMEN = """\
[mesh]
file = "{mesh}"
unit = "m"

""" + _MATERIAL.format(volumes='["sphere", "block"]') + """
[[contacts]]
slave = "sphere_contact"
master = "block_contact"
penalty = "auto"

[[supports]]
surface = "block_bottom"
fix = ["z"]
[[supports]]
surface = "sym_x"
fix = ["x"]
[[supports]]
surface = "sym_y"
fix = ["y"]
"""

SPHERE_BLOCK = SPECIMEN + """
[[initial_velocities]]
volumes = ["sphere"]
value = [0.0, 0.0, {v}]
{rigid}
[analysis]
type = "dynamic"
integrator = "{integrator}"
duration = {duration}
time_step = {time_step}
output_interval = {output}
"""

RIGID = """
[[rigid_bodies]]
surface = "sphere_equator"
motion = "translation"
direction = [0.0, 0.0, 1.0]
inertia = {inertia}
initial_velocity = {v}
"""



SDOF = """\
[mesh]
file = "{mesh}"
unit = "m"

{material}
[[contacts]]
slave = "upper_bottom"
master = "lower_top"
penalty = {penalty}

[[supports]]
surface = "lower_all"
fix = ["x", "y", "z"]

[[rigid_bodies]]
surface = "upper_all"
motion = "translation"
direction = [0.0, 0.0, 1.0]
inertia = {mass}
initial_velocity = {v}

[analysis]
type = "dynamic"
integrator = "{integrator}"
duration = {duration}
time_step = {time_step}
{extra}
"""


CASE_TEMPLATE = SPECIMEN + """
[[displacements]]
surface = "sphere_equator"
component = "z"
values = {values}
"""

SEED = default_gearset_path().read_text()
STATIC = CASE_TEMPLATE.format(mesh=MESHES / "hertz_coarse.msh", values=list(DISPLACEMENTS))
# The two-block SDOF (tests/test_dynamic.py): a 1 mm cube with 10 g on a 1e12 N/m
# spring, 1 m/s; contact time pi sqrt(m/k) = 0.314 us.
T_CONTACT = math.pi * math.sqrt((0.01 + 7860e-9) / 1e12)
DURATION = 1e-8 + 2.0 * T_CONTACT


def sdof(time_step: float | str = "auto", duration: float = DURATION, extra: str = "",
         penalty: float = 1e18) -> str:
    return SDOF.format(mesh=MESHES / "two_blocks.msh",
                       material=_MATERIAL.format(volumes='["upper", "lower"]'),
                       penalty=penalty, mass=0.01, v=-1.0, integrator="newmark",
                       duration=duration,
                       time_step=f'"{time_step}"' if isinstance(time_step, str) else time_step,
                       extra=extra)


def write(folder: Path, name: str, text: str | bytes) -> str:
    path = folder / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return str(path)


def changed(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new)


def solve(text: str, *more: str):
    return lambda d: ["solve", write(d, "case.toml", text), "--out", "OUT", *more]


def static(old: str, new: str):
    return solve(changed(STATIC, old, new))


def gearset(old: str, new: str, command: str = "mesh"):
    def argv(d):
        path = write(d, "gears.toml", changed(SEED, old, new))
        more = ["--level", "coarse", "--no-picture"] if command == "mesh" else \
            ["--stages", "1", "--speeds", "300", "--level", "coarse"]
        return [command, path, "--out", "OUT", *more]
    return argv


def mesh(*options: str):
    return lambda d: ["mesh", "--level", "coarse", "--out", "OUT", *options]


def calibrate(*options: str):
    return lambda d: ["calibrate", "--out", "OUT", "--cache", str(d / "cache"), *options]


def switching(*options: str, preset: str = "table1-100rpm"):
    return lambda d: ["switching", "--preset", preset, "--duration", "1", "--out", "OUT",
                      *options]


SEGMENT = "[[segments]]\nstage = {stage}\nduration_s = {duration}\nspeed_rpm = {speed}\n" \
          "load_Nm = {load}\n"


def schedule(*segments: dict, top: str = "", files: dict | None = None):
    """``switching --schedule`` of the given segments (defaults: stage 1, 1 s, 300 r/min,
    0.1 N m) on the seed gear set; ``files``: CSV files written beside the schedule."""
    def argv(d):
        for name, text in (files or {}).items():
            write(d, name, text)
        text = top + "".join(SEGMENT.format(**{"stage": 1, "duration": 1.0, "speed": 300,
                                                "load": 0.1, **s}) + s.get("extra", "")
                             for s in segments)
        return ["switching", "--schedule", write(d, "duty.toml", text), "--out", "OUT"]
    return argv


def calibration_file(k=1e7, cmax=20.0, **top):
    """A calibration file with one stage-1 case (every other stage: closed forms)."""
    data = {"schema": "fe-impact/calibration/1", **top,
            "cases": [{"stage": 1, "kind": "mesh", "impact_speed": 0.01,
                       "impact": {"k": k, "exponent": 1.5, "cmax": cmax, "d": 1e-7}}]}
    return json.dumps(data, allow_nan=True)


def with_calibration(text: str):
    return lambda d: switching("--calibration", write(d, "cal.json", text))(d)


def a_file(d: Path) -> str:
    return write(d, "a_file", "x")


LATIN1 = STATIC.replace("unit", "# caf\xe9\nunit").encode("latin-1")
UNCROWNED = changed(SEED, "lengthwise_crowning_um = 10.0", "lengthwise_crowning_um = 0.0")

SOLVE = [
    ("case missing", lambda d: ["solve", str(d / "none.toml"), "--out", "OUT"],
     ["none.toml", "case file not found"]),
    ("case is a directory", lambda d: ["solve", str(d), "--out", "OUT"],
     ["is a directory, not a case file"]),
    ("case not UTF-8", lambda d: ["solve", write(d, "c.toml", LATIN1), "--out", "OUT"],
     ["c.toml", "not UTF-8 text (byte 0xe9", "save the case file as UTF-8"]),
    ("case not TOML", solve("[mesh\n"), ["case.toml", "not valid TOML", "line 1"]),
    ("case empty", solve(""), ["missing key(s) ['materials', 'mesh']"]),
    ("--out is a file", lambda d: ["solve", write(d, "c.toml", STATIC), "--out", a_file(d)],
     ["--out", "a_file: is a file, not a folder"]),
    ("--out under a file",
     lambda d: ["solve", write(d, "c.toml", STATIC), "--out", a_file(d) + "/sub"],
     ["--out", "cannot make the folder", "a_file is a file"]),
    ("--max-frames 1", solve(sdof(), "--max-frames", "1"), ["--max-frames 1", "at least 2"]),
    ("[mesh] file is a directory", static(f'"{MESHES / "hertz_coarse.msh"}"', f'"{MESHES}"'),
     ["[mesh] file", "is a directory", "give a Gmsh .msh file"]),
    # Used to end in a singular solve, a leaked LinAlgWarning and a hint at the penalty.
    ("a body held by nothing", solve(STATIC.split("[[supports]]")[0]
                                     + STATIC[STATIC.index("[[displacements]]"):]),
     ["case.toml: volume 'block' is held by no [[supports]], [[displacements]] or "
      "[[rigid_bodies]] surface"]),
    # Used to end in numpy's "cannot reshape array of size 0" traceback.
    ("bodies that never touch", solve(f"""\
[mesh]
file = "{MESHES / 'spring_column.msh'}"
unit = "m"

""" + _MATERIAL.format(volumes='["column", "stop"]') + """
[[contacts]]
slave = "stop_bottom"
master = "column_top"
penalty = "auto"

[[supports]]
surface = "column_bottom"
fix = ["x", "y", "z"]

[[displacements]]
surface = "stop_all"
component = "z"
values = [-1e-6]
"""), ["case.toml: [[contacts]] stop_bottom on column_top: no slave node comes within "
       "the search distance", "the closest is 0.0001 m away"]),
    ("[mesh] file missing", static("hertz_coarse.msh", "nowhere.msh"),
     ["[mesh] file", "nowhere.msh", "no such file"]),
    ("[mesh] file empty", lambda d: static(f'"{MESHES / "hertz_coarse.msh"}"',
                                           f'"{write(d, "e.msh", "")}"')(d),
     ["e.msh is empty", "not a Gmsh MSH file"]),
    ("[mesh] file not a mesh", lambda d: static(f'"{MESHES / "hertz_coarse.msh"}"',
                                                f'"{write(d, "g.msh", bytes(range(256)))}"')(d),
     ["g.msh does not start with $MeshFormat"]),
    ("[mesh] unit", static('unit = "m"', 'unit = "inch"'), ["unit = 'inch'", "['m', 'mm']"]),
    ("youngs_modulus 1.7e308", static("212000000000.0", "1.7e308"),
     ["[materials[0]] youngs_modulus = 1.7e+308", "must be in (0.0, 1e+13] (Pa)"]),
    ("youngs_modulus nan", static("212000000000.0", "nan"),
     ["youngs_modulus = nan", "must be a number"]),
    ("poisson_ratio 0.5", static("poisson_ratio = 0.289", "poisson_ratio = 0.5"),
     ["poisson_ratio = 0.5", "(-1.0, 0.5)"]),
    ("density 1e300", static("density = 7860", "density = 1e300"),
     ["density = 1e+300", "(0.0, 100000.0] (kg/m^3)"]),
    ("yield above E", static("density = 7860", "density = 7860\nyield_strength = 3e11"),
     ["yield_strength = 300000000000.0", "below the Young's modulus"]),
    ("penalty 1e300", static('penalty = "auto"', "penalty = 1e300"),
     ["penalty = 1e+300", "(0.0, 1e+23]"]),
    ("displacement 1e300", static("-5e-06", "-1e300"),
     ["[displacements[0]] values", "must be in [-1, 1] m"]),
    ("unknown key", static("density = 7860", 'density = 7860\ncolour = "red"'),
     ["unknown key(s) ['colour'] in [materials[0]]"]),
    ("duration -1", solve(sdof(duration=-1.0)), ["[analysis] duration = -1", "> 0"]),
    ("time_step above the duration", solve(sdof(time_step=2 * DURATION)),
     ["[analysis] time_step", "at most the duration"]),
    ("output_interval 0", solve(sdof(extra="output_interval = 0.0")),
     ["[analysis] output_interval = 0.0", "must be in"]),
    ("initial_velocity 1e300",
     solve(changed(sdof(), "initial_velocity = -1.0", "initial_velocity = -1e300")),
     ["[rigid_bodies[0]] initial_velocity = -1e+300", "[-10000.0, 10000.0]"]),
    ("rigid inertia inf", solve(changed(sdof(), "inertia = 0.01", "inertia = inf")),
     ["inertia = inf", "must be a number in [0.0, 1e+09]"]),
    # Used to end in "the solution became NaN/inf ...; reduce the time step".
    ("rigid inertia 1e300", solve(changed(sdof(), "inertia = 0.01", "inertia = 1e300")),
     ["inertia = 1e+300", "must be in [0.0, 1e+09] (kg, or kg m^2 for a rotation)"]),
    ("dynamic penalty 1e300", solve(sdof(penalty=1e300)), ["penalty = 1e+300"]),
    ("carries an unknown volume",
     solve(changed(sdof(), "initial_velocity = -1.0", 'initial_velocity = -1.0\n'
                   'carries = ["uper"]')),
     ["rigid_bodies[0].carries = 'uper'", "no volume group 'uper'"]),
    ("carries a volume with its own initial velocity",
     solve(changed(sdof(), "initial_velocity = -1.0", 'initial_velocity = -1.0\n'
                   'carries = ["upper"]\n[[initial_velocities]]\nvolumes = ["upper"]\n'
                   'value = [0.0, 0.0, -1.0]')),
     ["[rigid_bodies[0]] carries = 'upper'", "from [initial_velocities[0]]",
      "one initial velocity"]),
    ("carries a supported volume",
     solve(changed(sdof(), "initial_velocity = -1.0", 'initial_velocity = -1.0\n'
                   'carries = ["lower"]')),
     ["[rigid_bodies[0]] carries = 'lower'", "supports[0] (surface 'lower_all')",
      "move with its body alone"]),
    ("carries in a static case",
     static('fix = ["z"]', 'fix = ["z"]\n[[rigid_bodies]]\nsurface = "sphere_equator"\n'
            'motion = "translation"\ndirection = [0.0, 0.0, 1.0]\nvalues = [0.0]\n'
            'carries = ["sphere"]'),
     ["carries need [analysis] type = \"dynamic\""]),
]

MESH = [
    ("gear set missing", lambda d: ["mesh", str(d / "none.toml"), "--out", "OUT"],
     ["none.toml: gear-set file not found"]),
    ("gear set is a directory", lambda d: ["mesh", str(d), "--out", "OUT"],
     ["is a directory, not a gear-set file"]),
    ("gear set not UTF-8",
     lambda d: ["mesh", write(d, "g.toml", SEED.replace("name =", "# caf\xe9\nname =")
                              .encode("latin-1")), "--out", "OUT"],
     ["g.toml: not UTF-8 text", "save the gear-set file as UTF-8"]),
    ("gear set not TOML", lambda d: ["mesh", write(d, "g.toml", "[pinion\n"), "--out", "OUT"],
     ["g.toml: not valid TOML"]),
    ("--out is a file", lambda d: ["mesh", "--out", a_file(d)], ["--out", "is a file"]),
    ("--out under a file", lambda d: ["mesh", "--out", a_file(d) + "/x"],
     ["--out", "cannot make the folder"]),
    ("--level", mesh("--level", "superfine"), ["--level 'superfine'", "coarse, default, fine"]),
    ("--order", mesh("--order", "3"), ["--order 3", "1 (linear) or 2 (quadratic)"]),
    ("--gap", mesh("--gap", "-1"), ["--gap -1 um", "0 .. 1000 um"]),
    ("--gap nan", mesh("--gap", "nan"), ["--gap nan um"]),
    ("--impact-speed", mesh("--impact-speed", "0"), ["--impact-speed 0 m/s", "(0, 20] m/s"]),
    ("--face-teeth", mesh("--face-teeth", "4"), ["--face-teeth 4", "1, 2 or 3"]),
    ("--neighbour-teeth", mesh("--neighbour-teeth", "3"), ["--neighbour-teeth 3", "0, 1 or 2"]),
    ("--roll-angle", mesh("--roll-angle", "90"), ["--roll-angle 90 deg", "-60 .. 60 deg"]),
    # Used to leave an empty --out folder behind.
    ("--roll-angle off the flanks", mesh("--roll-angle", "19", "--no-picture"),
     ["roll angle = 19 deg puts the contact off the working flanks"]),
    # Used to fail after 15-18 s in the mesh builder ("face of piece 'hub_left' not found").
    ("--roll-angle far past the corner", mesh("--contact", "corner-approach", "--roll-angle",
                                              "60", "--no-picture"),
     ["roll angle 60.0000 deg has no approach corner contact", "allowed roll angles ("]),
    ("--stage", mesh("--stage", "4"), ["--stage 4", "has stages 1..3"]),
    ("--stage not a number", mesh("--stage", "x"), ["--stage", "invalid int value: 'x'"]),
    # Used to name fillet_radius_coeff with the empty range (0, -0.5677].
    ("addendum_coeff 3", gearset("addendum_coeff = 1.0", "addendum_coeff = 3.0"),
     ["[pinion] addendum_coeff = 3 and clearance_coeff = 0.25", "below pi / (4 tan 20 deg)",
      "addendum_coeff < 1.908"]),
    ("clearance_coeff 2", gearset("clearance_coeff = 0.25", "clearance_coeff = 2.0"),
     ["clearance_coeff = 2", "their sum 3"]),
    ("addendum_coeff 1.2", gearset("addendum_coeff = 1.0", "addendum_coeff = 1.2"),
     ["fillet_radius_coeff = 0.38", "(0, 0.3679]", "addendum_coeff = 1.2"]),
    ("pinion teeth 15", gearset("teeth = 19", "teeth = 15"), ["[pinion] teeth = 15", ">= 18",
                                                              "pressure_angle_deg to >="]),
    # Used to fail in the contact analysis: "relative curvature is not positive definite".
    ("shaper fewer teeth than the pinion",
     gearset("shaper_teeth = 21   #", "force_shaper = true\nshaper_teeth = 15   #"),
     ["stage 1 (56 teeth): shaper_teeth = 15", "at least [pinion] teeth = 19", "force_shaper"]),
    ("shaper as many teeth as an uncrowned pinion",
     lambda d: ["mesh", write(d, "g.toml", changed(
         UNCROWNED, "shaper_teeth = 21   #", "force_shaper = true\nshaper_teeth = 19   #")),
                "--out", "OUT"],
     ["shaper_teeth = 19 equals [pinion] teeth", "lengthwise_crowning_um > 0"]),
    ("shaper outside pinion + 1..3", gearset("shaper_teeth = 21   #", "shaper_teeth = 25   #"),
     ["shaper_teeth = 25 must lie in [20, 22]", "force_shaper = true"]),
    # Used to be meshed: 300 mm of pinion on a ring of 84 mm pitch radius.
    ("pinion face width 300 mm", gearset("face_width_mm = 24.0", "face_width_mm = 300.0"),
     ["[pinion] face_width_mm = 300 mm", "66 mm past the face-gear axis", "at most 105 mm"]),
    ("outer radius beyond the pointing limit",
     gearset("outer_radius_mm = 96.0", "outer_radius_mm = 99.0"),
     ["stage 1 (56 teeth): outer_radius_mm = 99.000 mm", "pointing limit", "96.978"]),
    ("inner radius below the undercut limit",
     gearset("inner_radius_mm = 82.5", "inner_radius_mm = 70.0"),
     ["inner_radius_mm = 70.000 mm is below the inner limit", "82.371"]),
    ("crowning 1 mm", gearset("lengthwise_crowning_um = 10.0",
                              "lengthwise_crowning_um = 1000.0"),
     ["[pinion] lengthwise_crowning_um = 1000 um", "[0, 300] um"]),
    ("youngs_modulus 1.7e308 (gear set)",
     gearset("youngs_modulus_pa = 212e9", "youngs_modulus_pa = 1.7e308"),
     ["[material] youngs_modulus_pa = 1.7e+308 Pa", "(0, 1e+13] Pa"]),
    ("yield above E (gear set)", gearset("yield_strength_pa = 835e6",
                                         "yield_strength_pa = 835e12"),
     ["[material] yield_strength_pa", "below the Young's modulus"]),
    ("module mismatch", gearset("(checked).\nmodule_mm = 3.0", "(checked).\nmodule_mm = 2.0"),
     ["[face_gear] module_mm = 2 mm differs from [pinion] module_mm = 3 mm"]),
    ("teeth not a multiple of the pinions", gearset("teeth = 56", "teeth = 57"),
     ["teeth = 57 must be a multiple of n_pinions = 4"]),
    ("unknown key (gear set)", gearset("teeth = 19", "teeth = 19\ncolour = 1"),
     ["unknown key(s) ['colour'] in [pinion]"]),
]

CALIBRATE = [
    # An empty list used to mean "all stages".
    ("--stages ,", calibrate("--stages", ","), ["--stages", "need at least one integer"]),
    ("--speeds ,", calibrate("--speeds", ","), ["--speeds", "need at least one number"]),
    ("--stages a", calibrate("--stages", "a"), ["--stages", "need comma-separated integers"]),
    ("--stages 9", calibrate("--stages", "9"), ["--stages [9]", "stages 1..3"]),
    # Used to start the Dask cluster and fail on a worker with a remote traceback.
    ("--speeds 1e9", calibrate("--speeds", "1e9"),
     ["--speeds 1e+09", "allowed impact speeds are (0, 20] m/s"]),
    ("--speeds -1", calibrate("--speeds", "-1"), ["--speeds [-1.0]", "positive numbers"]),
    ("--speeds nan", calibrate("--speeds", "nan"), ["--speeds [nan]", "positive numbers"]),
    ("--impact-speeds 25", calibrate("--impact-speeds", "25"),
     ["--impact-speeds 25", "(0, 20] m/s"]),
    ("--speeds and --impact-speeds", calibrate("--speeds", "100", "--impact-speeds", "0.1"),
     ["give --speeds (r/min) or --impact-speeds (m/s), not both"]),
    # Used to end in distributed's ValueError.
    ("--scheduler", calibrate("--scheduler", "not an address"),
     ["--scheduler 'not an address'", "give host:port or tcp://host:port"]),
    ("--workers 0", calibrate("--workers", "0"), ["--workers 0", "at least 1"]),
    ("--level", calibrate("--level", "superfine"), ["--level 'superfine'", "coarse"]),
    ("--mesh-cycle-level", calibrate("--mesh-cycle-level", "tiny"),
     ["--mesh-cycle-level 'tiny'", "coarse, default, fine"]),
    ("--integrator", calibrate("--integrator", "rk4"), ["--integrator 'rk4'", "newmark"]),
    ("--switch on stage 1", calibrate("--stages", "1", "--switch"),
     ["--switch with --stages [1]", "stage 2 or later"]),
    ("--speeds repeated", calibrate("--speeds", "100,100"),
     ["--speeds [100.0, 100.0]", "a value is repeated"]),
    ("--out is a file", lambda d: ["calibrate", "--out", a_file(d), "--cache",
                                   str(d / "cache")], ["--out", "is a file, not a folder"]),
    ("--out under a file", lambda d: ["calibrate", "--out", a_file(d) + "/x", "--cache",
                                      str(d / "cache")], ["--out", "cannot make the folder"]),
    ("--cache is a file", lambda d: ["calibrate", "--out", "OUT", "--cache", a_file(d)],
     ["--cache", "is a file, not a folder"]),
    ("gear set is a directory", lambda d: calibrate()(d)[:1] + [str(d)] + calibrate()(d)[1:],
     ["is a directory, not a gear-set file"]),
    ("--positions off the path", calibrate("--positions=-10,0,40"),
     ["--positions 40", "path of contact runs from 18.765 to -14.625 deg"]),
    ("--positions within one pitch", calibrate("--positions", "0,5"),
     ["--positions 0,5", "less than one angular pitch (18.947 deg)"]),
    ("--positions 1", calibrate("--positions", "1"), ["--positions 1", "need at least 2"]),
    # Used to plan two cases of one id (one folder, one point of the cycle).
    ("--positions repeated", calibrate("--positions=5,-14,5.0001"),
     ["--positions 5,-14,5.0001", "the angle +5.000 deg is given twice"]),
    ("--positions one angle", calibrate("--positions", "3.5"),
     ["--positions", "'3.5': one roll angle", "a count of positions"]),
    ("--positions a", calibrate("--positions", "a"), ["--positions", "comma-separated numbers"]),
    ("--positions and --no-mesh-cycle", calibrate("--positions", "3", "--no-mesh-cycle"),
     ["--positions and --no-mesh-cycle: give one or the other"]),
    # Used to be ignored in silence.
    ("--mesh-cycle-level and --no-mesh-cycle",
     calibrate("--mesh-cycle-level", "fine", "--no-mesh-cycle"),
     ["--mesh-cycle-level and --no-mesh-cycle: give one or the other"]),
    ("--corners and --no-mesh-cycle", calibrate("--corners", "--no-mesh-cycle"),
     ["--corners and --no-mesh-cycle: the corner positions are part of the mesh cycle"]),
    ("--corner-impacts and --no-preset-speeds",
     calibrate("--corner-impacts", "--no-preset-speeds"),
     ["--corner-impacts and --no-preset-speeds: the corner impacts' closing speeds come from"]),
    ("--corners with sharp tip edges",   # both radii to 0 (the old value left as a comment)
     lambda d: [*gearset("tip_edge_radius_mm =", "tip_edge_radius_mm = 0.0 #", "calibrate")(d),
                "--corners"],
     ["--corners: the gear set's tip edges are sharp"]),
    ("pinion face width 300 mm (calibrate)",
     gearset("face_width_mm = 24.0", "face_width_mm = 300.0", "calibrate"),
     ["[pinion] face_width_mm = 300 mm"]),
]

SWITCHING = [
    ("no --preset", lambda d: ["switching", "--out", "OUT"],
     ["--preset NAME or --schedule FILE is required"]),
    ("gear set missing", lambda d: ["switching", str(d / "none.toml"), "--preset",
                                    "table1-100rpm", "--duration", "1", "--out", "OUT"],
     ["none.toml"]),
    ("unknown preset", switching(preset="nope"), ["--preset = 'nope' is not a preset"]),
    ("no --out", lambda d: ["switching", "--preset", "table1-100rpm"], ["--out is required"]),
    ("--out is a file", lambda d: ["switching", "--preset", "table1", "--out", a_file(d)],
     ["--out", "is a file, not a folder"]),
    ("--out under a file", lambda d: ["switching", "--preset", "table1", "--out",
                                      a_file(d) + "/x"], ["--out", "cannot make the folder"]),
    ("--duration 0", switching("--duration", "0"), ["--duration = 0.0 s", "> 0"]),
    ("--duration nan", switching("--duration", "nan"), ["--duration = nan s"]),
    ("--duration inf", switching("--duration", "inf"), ["--duration = inf s"]),
    ("--sample-interval 0", switching("--sample-interval", "0"), ["--sample-interval = 0.0"]),
    # Used to run and be compared with the seed's tables.
    ("--sample-interval longer than the run", switching("--sample-interval", "2"),
     ["--sample-interval = 2 s: longer than the run (1 s)"]),
    # Used to end in a traceback: 1.5 TiB of samples could not be allocated.
    ("--sample-interval 1e-12", switching("--sample-interval", "1e-12"),
     ["--sample-interval = 1e-12 s", "1e+12 time-series samples of a 1 s case; at most 2e+06",
      "5e-07 s or more"]),
    # Used to run without end.
    ("--duration 1e300", switching("--duration", "1e300"),
     ["--duration = 1e+300 s", "time-series samples", "shorter --duration"]),
    ("--duration 1e-9", switching("--duration", "1e-9"),
     ["--duration = 1e-09 s: shorter than the time series' sample interval (0.0002 s"]),
    ("--calibration missing", lambda d: switching("--calibration", str(d / "no.json"))(d),
     ["--calibration", "no.json", "no such file"]),
    # Used to say "no such file".
    ("--calibration is a directory", lambda d: switching("--calibration", str(d))(d),
     ["--calibration", "is a directory"]),
    ("--calibration not UTF-8", with_calibration(b'{"a": "caf\xe9"}'),
     ["cal.json: not UTF-8 text"]),
    ("--calibration not JSON", with_calibration("{"), ["cal.json: not valid JSON"]),
    ("--calibration schema", with_calibration('{"schema": "x", "cases": []}'),
     ["schema = 'x': expected 'fe-impact/calibration/2' (or the older "
      "'fe-impact/calibration/1')"]),
    ("--calibration k -1", with_calibration(calibration_file(k=-1.0)),
     ["[cases[0].impact] k = -1.0", "must be > 0"]),
    ("--calibration k Infinity", with_calibration(calibration_file(k=math.inf)),
     ["k = inf", "must be a number > 0"]),
    # Used to run to exit 0 with a NaN series and a statistics.json of zeros.
    ("--calibration k 1e300", with_calibration(calibration_file(k=1e300)),
     ["cal.json: stage 1 'mesh'", "k = 1e+300", "cannot be integrated"]),
    # Used to end in "step size collapsed at t = 0.0254 s": k in the wrong units (too soft).
    # Hertz's peak approach (5 m v^2 / (4 k))^(2/5) with the seed stage 1's effective mass
    # 0.2869 kg at 0.01 m/s and k = 65 is 3.14 mm (by hand).
    ("--calibration k 65 (too soft)", with_calibration(calibration_file(k=65.0)),
     ["cal.json: stage 1 'mesh'", "k = 65", "approach by 3.14 mm", "k in N/m^exponent"]),
    ("--calibration cmax 1e300", with_calibration(calibration_file(cmax=1e300)),
     ["damping time m/cmax", "cannot be integrated"]),
    ("--calibration without cases",
     with_calibration(json.dumps({"schema": "fe-impact/calibration/1", "cases": []})),
     ["cal.json: cases = []: must be a non-empty list of objects"]),
    ("--schedule missing", lambda d: ["switching", "--schedule", str(d / "no.toml"), "--out",
                                      "OUT"], ["no.toml"]),
    ("--schedule is a directory", lambda d: ["switching", "--schedule", str(d), "--out", "OUT"],
     ["is a directory"]),
    ("schedule duration 0", schedule({"duration": 0}),
     ["duty.toml: [segments[0]] duration_s = 0: must be > 0"]),
    ("schedule stage the gear set lacks", schedule({}, {"stage": 4}),
     ["[segments[1]] stage = 4", "has stages 1..3"]),
    ("schedule typo'd key", schedule({"extra": "speed_rmp = 3\n"}),
     ["unknown key(s) ['speed_rmp'] in [segments[0]]", "allowed"]),
    ("schedule switch to the engaged stage", schedule({}, {"extra": "switch = {}\n"}),
     ["[segments[1]] switch = {}", "already engages"]),
    ("schedule torque series not monotonic",
     schedule({"load": '{ file = "t.csv" }'}, files={"t.csv": "time_s,load_Nm\n0,1\n0.6,2\n"
                                                               "0.5,2\n1,1\n"}),
     ["t.csv: line 4: time_s = 0.5 is not after line 3's 0.6"]),
    ("schedule torque series NaN",
     schedule({"load": '{ file = "t.csv" }'}, files={"t.csv": "time_s,load_Nm\n0,1\n1,nan\n"}),
     ["t.csv: line 3: load_Nm = nan: must be a finite number"]),
    ("schedule torque series separated by ';'",
     schedule({"load": '{ file = "t.csv" }'}, files={"t.csv": "time_s;load_Nm\n0;1\n1;1\n"}),
     ["t.csv: line 1: header", "separated by commas (this file uses ';')"]),
    ("schedule torque series missing", schedule({"load": '{ file = "t.csv" }'}),
     ["[segments[0]] load_Nm", "t.csv: load series not found"]),
    # Used to run: a name with a folder wrote the series into a subfolder of --out.
    ("schedule name with a folder", schedule({}, top='name = "a/b"\n'),
     ["name = 'a/b'", "no spaces or folders"]),
    # Used to run: 200 N mm given as 200,000 N m (p0 about 9 GPa on the seed's stage 1).
    ("schedule load in N mm", schedule({"load": 200000}),
     ["[segments[0]] load_Nm = 200000", "static contact strength", "N m on this gear set"]),
    # Used to fail after building the laws with "segment 2: duration = 0.0667 s is shorter
    # than ramp_time = 0.1 s", naming no option.
    ("--duration shrinks a segment below its blend",
     lambda d: ["switching", "--preset", "variable-speed", "--duration", "0.2", "--out", "OUT"],
     ["--duration = 0.2 s", "segments[1] would last 0.0667 s", "0.1 s blend",
      "--duration 0.3 or more"]),
    # Used to overwrite the calibration's report.md with the study's.
    ("--out is a calibration folder",
     lambda d: ["switching", "--preset", "table1-100rpm", "--duration", "1", "--out",
                str(Path(write(d, "calibration.json", calibration_file())).parent)],
     ["holds a calibration (calibration.json)", "would overwrite its files"]),
    # A duration in ms given as s: too many samples; the message points at duration_s.
    ("schedule duration in ms", schedule({"duration": 5000}),
     ["2.5e+07 time-series samples of a 5000 s case", "duration_s are in seconds"]),
    # Used to fail late, naming neither the option nor the presets that fit.
    ("preset of a stage the gear set lacks",
     lambda d: ["switching", str(MESHES.parent / "geometry" / "nasa-25deg.toml"), "--preset",
                "table2", "--duration", "1", "--out", "OUT"],
     ["--preset = 'table2' runs stage 2", "has stages 1..1", "table1"]),
    # Used to run: r/min x 1000 (a pitch-line speed of 9 km/s).
    ("schedule speed x 1000", schedule({"speed": 3e6}),
     ["[segments[0]] speed_rpm = 3e+06", "at most", "r/min (200 m/s)"]),
]


NASA = MESHES.parent / "geometry" / "nasa-25deg.toml"


def roll(*options: str, gears: Path | None = None):
    """``roll`` with a rigid quick look (no mesh): the refusals come before any step."""
    return lambda d: ["roll", *([str(gears)] if gears else []), "--rigid", "--out", "OUT",
                      *options]


def geometry(*options: str):
    return lambda d: ["geometry", *options]


ROLL = [
    ("--cycles 0", roll("--speed", "1000", "--cycles", "0"), ["--cycles 0", "> 0"]),
    ("--speed NaN", roll("--speed", "nan"), ["--speed nan", "must be a number > 0"]),
    ("--torque against the drive", roll("--speed", "1000", "--torque", "-50"),
     ["--torque -50", ">= 0", "N m on the face gear"]),
    ("--stage the shipped one-stage drive lacks", roll("--speed", "1000", "--stage", "2",
                                                        gears=NASA),
     ["--stage 2", "'nasa-25deg-28x107' has stages 1..1"]),
    ("gear-set file missing", lambda d: ["roll", str(d / "no.toml"), "--rigid", "--speed",
                                         "1000", "--out", "OUT"],
     ["no.toml", "not found"]),
]

GEOMETRY = [
    ("--schedule is a folder", lambda d: ["geometry", "--schedule", str(d)],
     ["--schedule", "is a folder", "schedule TOML file"]),
    # A gear-set file given where the schedule goes.
    ("--schedule is a gear-set file", geometry("--schedule", str(NASA)),
     ["nasa-25deg.toml", "unknown key(s)", "allowed: ['blend_s'"]),
    # 200 N mm typed as 200000 N m: p0 = 8938 MPa on stage 1; p0 ~ T^(1/3), so the
    # 2400 MPa strength is reached at 200000 (2400/8938)^3 = 3872 N m (by hand).
    ("schedule load in N mm",
     lambda d: ["geometry", "--schedule", write(d, "duty.toml", SEGMENT.format(
         stage=1, duration=1.0, speed=300, load=200000))],
     ["[segments[0]] load_Nm = 200000", "static contact strength", "at most 3872 N m"]),
    ("--torque NaN", geometry("--torque", "nan"), ["--torque nan N m", "> 0"]),
    ("--json in a folder that cannot be made", geometry("--json", "/proc/none/g.json"),
     ["--json /proc/none/g.json", "cannot make a folder"]),
    ("schedule without a load",
     lambda d: ["geometry", "--schedule", write(d, "duty.toml", SEGMENT.format(
         stage=1, duration=1.0, speed=300, load=0))],
     ["--schedule", "duty.toml", "every segment's load_Nm is 0", "or --torque"]),
    # A coefficient quoted as text in the gear set's [friction].
    ("gear-set friction coefficient as text",
     lambda d: ["geometry", write(d, "gears.toml", changed(SEED, "mu_static = 0.05",
                                                          'mu_static = "0.05"'))],
     ["[friction] mu_static = '0.05'", "must be a number"]),
]


def _params(command: str, table: list) -> list:
    return [pytest.param(build, words, id=f"{command}: {name}") for name, build, words in table]


@pytest.mark.parametrize("build,words", _params("solve", SOLVE) + _params("mesh", MESH)
                         + _params("calibrate", CALIBRATE) + _params("switching", SWITCHING)
                         + _params("roll", ROLL) + _params("geometry", GEOMETRY))
def test_bad_input_gets_one_clear_line(tmp_path, capsys, build, words):
    before = sorted(tmp_path.rglob("*"))
    argv = [str(tmp_path / "out") if a == "OUT" else a for a in build(tmp_path)]
    made = sorted(tmp_path.rglob("*"))     # the inputs the builder wrote
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "Warning:" not in err, err
    errors = [line for line in err.splitlines() if line.startswith("fe-impact")]
    assert len(errors) == 1 and ": error: " in errors[0], err   # argparse adds its usage
    message = errors[0]
    for w in words:
        assert w in message, (w, message)
    # Nothing written: no output folder, no cache, no file beside the inputs.
    assert not (tmp_path / "out").exists()
    assert not (tmp_path / "cache").exists()
    assert sorted(tmp_path.rglob("*")) == made and set(before) <= set(made)
    assert all(Path(p).read_bytes() == b"x" for p in made if Path(p).name == "a_file")


def test_table_covers_every_kind_of_the_issue():
    """The table holds each kind the report found, per command (the count is the report's)."""
    counts = {"solve": len(SOLVE), "mesh": len(MESH), "calibrate": len(CALIBRATE),
              "switching": len(SWITCHING)}
    assert all(n >= 10 for n in counts.values()), counts
