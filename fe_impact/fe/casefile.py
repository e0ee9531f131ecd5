"""Writing a :class:`~fe_impact.fe.case.Case` as a case file.

:func:`write_case` is the one writer of case files; :func:`~fe_impact.fe.case.load_case`
is the one reader. The text is checked by reading it back before it is
written, so a file from :func:`write_case` always loads to the case it was
written from (with ``path`` set to the file). A variant of a case is made with
:func:`dataclasses.replace` and written again::

    case = load_case("sphere_block.toml")
    stiffer = replace(case, contacts=(replace(case.contacts[0], penalty=1e15),))
    write_case(stiffer, "stiffer.toml")   # load_case reads back `stiffer`

Numbers are written with the shortest text that reads back to the same
float, so a rerun of the file gives the same results as the case in
memory.
"""

from __future__ import annotations

import dataclasses
import math
import os
import tomllib
from collections.abc import Iterable
from pathlib import Path

from fe_impact.atomic import atomic_path
from fe_impact.errors import CaseError
from fe_impact.fe.case import (
    COMPONENTS,
    DEFAULT_TRANSITION_SPEED,
    AnalysisSpec,
    Case,
    ContactSpec,
    DisplacementSpec,
    InitialVelocitySpec,
    MaterialSpec,
    RigidBodySpec,
    parse_case,
)

__all__ = ["case_text", "write_case"]

_COMPONENT_NAMES = {i: name for name, i in COMPONENTS.items()}


def write_case(case: Case, path: str | Path, header: str = "") -> Path:
    """Write ``case`` to ``path`` (atomically) as a TOML case file; returns ``path``.

    Parameters
    ----------
    case : Case
        The case; its ``mesh_file`` is written relative to the folder of ``path``.
    path : str or Path
        The case file to write (its folder is created).
    header : str
        Comment lines put at the top of the file (``#`` is added to each).

    Raises
    ------
    CaseError
        If the case is not one a case file can describe (a value the reader
        refuses, or settings the reader would not give back, such as Newmark
        controls on a static case); nothing is written then.
    """
    path = Path(path)
    text = case_text(case, path.parent, header)
    _check_round_trip(case, text, path)
    _write_atomic(path, text)
    return path


def case_text(case: Case, folder: str | Path, header: str = "") -> str:
    """The TOML text of ``case`` for a file in ``folder`` (the mesh path is relative to it)."""
    mesh = Path(os.path.relpath(Path(case.mesh_file).resolve(), Path(folder).resolve()))
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    if lines:
        lines.append("")
    lines += ["[mesh]", f"file = {_string(mesh.as_posix())}", f"unit = {_string(case.unit)}"]
    for m in case.materials:
        lines += ["", "[[materials]]", *_material(m)]
    for c in case.contacts:
        lines += ["", "[[contacts]]", *_contact(c)]
    for s in case.supports:
        lines += ["", "[[supports]]", f"surface = {_string(s.surface)}",
                  f"fix = {_strings(_COMPONENT_NAMES[i] for i in s.fix)}"]
    for d in case.displacements:
        lines += ["", "[[displacements]]", *_displacement(d)]
    for v in case.initial_velocities:
        lines += ["", "[[initial_velocities]]", *_initial_velocity(v)]
    for b in case.rigid_bodies:
        lines += ["", "[[rigid_bodies]]", *_rigid_body(b, case.analysis.dynamic)]
    lines += ["", "[analysis]", *_analysis(case.analysis), ""]
    return "\n".join(lines)


def _material(m: MaterialSpec) -> list[str]:
    lines = [f"volumes = {_strings(m.volumes)}",
             f"youngs_modulus = {_number(m.youngs_modulus)}",
             f"poisson_ratio = {_number(m.poisson_ratio)}",
             f"density = {_number(m.density)}"]
    if m.yield_strength is not None:
        lines.append(f"yield_strength = {_number(m.yield_strength)}")
    if m.hardening_modulus:
        lines.append(f"hardening_modulus = {_number(m.hardening_modulus)}")
    return lines


def _contact(c: ContactSpec) -> list[str]:
    lines = [f"slave = {_string(c.slave)}", f"master = {_string(c.master)}",
             f"penalty = {_auto(c.penalty)}"]
    if c.search_distance is not None:
        lines.append(f"search_distance = {_number(c.search_distance)}")
    lines.append(f"multiplier = {_string(c.multiplier)}")
    if c.friction or c.transition_speed != DEFAULT_TRANSITION_SPEED:
        lines += [f"mu_static = {_number(c.mu_static)}", f"mu_dynamic = {_number(c.mu_dynamic)}",
                  f"transition_speed = {_number(c.transition_speed)}"]
    return lines


def _displacement(d: DisplacementSpec) -> list[str]:
    return [f"surface = {_string(d.surface)}",
            f"component = {_string(_COMPONENT_NAMES[d.component])}",
            f"values = {_numbers(d.values)}"]


def _initial_velocity(v: InitialVelocitySpec) -> list[str]:
    return [f"volumes = {_strings(v.volumes)}", f"value = {_numbers(v.value)}"]


def _rigid_body(b: RigidBodySpec, dynamic: bool) -> list[str]:
    lines = [f"surface = {_string(b.surface)}", f"motion = {_string(b.motion)}",
             f"direction = {_numbers(b.direction)}", f"point = {_numbers(b.point)}"]
    if not dynamic:
        key, values = ("loads", b.loads) if b.load_controlled else ("values", b.values)
        return lines + [f"{key} = {_numbers(values)}"]
    lines += [f"inertia = {_number(b.inertia)}",
              f"initial_velocity = {_number(b.initial_velocity)}"]
    return lines + ([f"carries = {_strings(b.carries)}"] if b.carries else [])


def _analysis(a: AnalysisSpec) -> list[str]:
    lines = [f"type = {_string(a.type)}", f"max_iterations = {int(a.max_iterations)}",
             f"tolerance = {_number(a.tolerance)}"]
    if not a.dynamic:
        return lines
    lines += [f"integrator = {_string(a.integrator)}",
              f"duration = {_number(a.duration)}",
              f"time_step = {_auto(a.time_step)}"]
    if a.output_interval is not None:
        lines.append(f"output_interval = {_number(a.output_interval)}")
    if a.integrator == "newmark":  # the reader refuses these keys for the explicit scheme
        lines += [f"hht_alpha = {_number(a.hht_alpha)}",
                  f"plastic_solver = {_string(a.plastic_solver)}"]
    lines += [f"safety_factor = {_number(a.safety_factor)}",
              f"energy_limit = {_number(a.energy_limit)}",
              f"plastic_zone = {_auto(a.plastic_zone)}"]
    if a.stop_after_separation is not None:
        lines.append(f"stop_after_separation = {_number(a.stop_after_separation)}")
    return lines


def _number(value: float) -> str:
    """A TOML float literal that reads back to the same double.

    The shorter of ``repr`` and the shortest exact ``%g`` form (``2.12e+11``
    rather than ``212000000000.0``); never an integer literal.
    """
    value = float(value)
    text = repr(value)
    if math.isfinite(value):
        short = next(t for t in (f"{value:.{n}g}" for n in range(1, 18)) if float(t) == value)
        text = min(text, short, key=len)
    return text if any(ch in text for ch in ".eni") else text + ".0"


def _numbers(values: Iterable[float]) -> str:
    return "[" + ", ".join(_number(v) for v in values) + "]"


def _auto(value: float | None) -> str:
    return '"auto"' if value is None else _number(value)


def _string(text: str) -> str:
    """A TOML basic string; quotes, backslashes and control characters escaped."""
    out = []
    for ch in str(text):
        if ch in '"\\':
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _strings(values: Iterable[str]) -> str:
    return "[" + ", ".join(_string(v) for v in values) + "]"


def _check_round_trip(case: Case, text: str, path: Path) -> None:
    """Raise :class:`CaseError` unless ``text`` reads back to ``case`` at ``path``."""
    back = parse_case(tomllib.loads(text), path)
    expected = dataclasses.replace(case, path=path, mesh_file=Path(case.mesh_file).resolve())
    if back != expected:
        fields = [f.name for f in dataclasses.fields(Case)
                  if getattr(back, f.name) != getattr(expected, f.name)]
        raise CaseError(f"{path.name}: the case cannot be written as a case file: "
                        f"{', '.join(fields)} would read back as "
                        f"{', '.join(repr(getattr(back, f)) for f in fields)}")


def _write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` so that it appears whole (no half-written file)."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)
