"""Schedule files: a duty cycle of the drive, segment by segment, read from TOML.

A schedule file lists the segments the torsional model runs one after the
other from t = 0. Each segment gives the engaged stage, the pinion speed
(constant or ramped), the load torque on the output (constant, ramped, or a
CSV time series) and its duration; a segment on another stage than the one
before it is a ratio switch at its start. Example (the reference is the user
guide's ``schedule.md``)::

    schema = "fe-impact/schedule/1"
    name = "climb"
    description = "stage 1 spin-up, then a switch to stage 2 under load"
    blend_s = 0.1                    # default blend of speed and load steps [s]

    [[segments]]
    stage = 1
    duration_s = 2.0
    speed_rpm = { from = 100, to = 1000 }
    load_Nm = 50

    [[segments]]
    stage = 2                        # another stage: a ratio switch at t = 2 s
    duration_s = 3.0
    speed_rpm = 1000
    load_Nm = { file = "torque.csv" }   # time_s,load_Nm from the segment's start
    switch = { engage = 0.0 }

:func:`read_schedule` checks every key and value and raises
:class:`~fe_impact.errors.CaseError` with one line naming the file, the key
(with the segment's index), the value and what is allowed; nothing is run or
written before the whole file has been read. The seed's operating conditions
are schedule files of the package (:data:`SCHEDULE_DIR`), read by the same
reader (`fe_impact.switching.presets`).
"""

from __future__ import annotations

import csv
import hashlib
import json
import logging
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fe_impact.errors import CaseError
from fe_impact.inputs import Reader, is_real, read_document
from fe_impact.switching.model import LoadSeries, Segment, StageSchedule

logger = logging.getLogger(__name__)

__all__ = ["MAX_PITCH_LINE_SPEED", "MAX_SERIES_POINTS", "SCHEDULE_DIR", "SCHEMA",
           "STATIC_CONTACT_FACTOR", "DutyCycle", "load_limit", "load_problem",
           "read_load_series", "read_schedule", "schedule_from_dict", "speed_problem",
           "top_speed_rpm"]

#: The ``schema`` of a schedule file this version reads.
SCHEMA = "fe-impact/schedule/1"
#: The package's schedule files (the seed's operating conditions).
SCHEDULE_DIR = Path(__file__).resolve().parent / "schedules"
#: Most points of one load series: each becomes a piece of the kernel's schedule table
#: (about 100 bytes) searched by bisection at every right-hand-side evaluation.
MAX_SERIES_POINTS = 1_000_000
#: Columns of a load-series CSV file.
SERIES_COLUMNS = ("time_s", "load_Nm")

#: Fastest pitch-line speed of the pinion a schedule may ask for [m/s]: turbo gears, the
#: fastest gear drives built, run at up to about 200 m/s (Niemann and Winter,
#: Maschinenelemente II, ch. 21); a faster one is taken for a unit mistake (r/min x 1000).
MAX_PITCH_LINE_SPEED = 200.0
#: Static contact strength over the allowable stress sigma_Hlim: ISO 6336-2's life factor
#: Z_NT at static load (N_L <= 1e5, limited pitting permitted; steels incl. case-hardened).
#: A schedule whose load gives a larger Hertz p0 at the pitch point would crush the flanks
#: at its first mesh (a torque in N mm given as N m is the usual cause).
STATIC_CONTACT_FACTOR = 1.6
#: A schedule's name: it names the result files, so no folder separators or spaces.
_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]*")

_TOP_KEYS = ("schema", "name", "description", "blend_s", "segments")
_SEGMENT_KEYS = ("stage", "duration_s", "speed_rpm", "load_Nm", "blend_s", "switch")
_SWITCH_KEYS = ("engage",)
_RAMP_KEYS = ("from", "to")


@dataclass(frozen=True)
class DutyCycle:
    """A schedule read from a file.

    Attributes
    ----------
    name : str
        Identifier used in result file names (default: the file's stem).
    description : str
    schedule : StageSchedule
        The segments, as the model runs them.
    source : str
        The file read ("" for a schedule built from a dict).
    digest : str
        SHA-256 of the file and of the load series it reads (cache keys).
    """

    name: str
    description: str
    schedule: StageSchedule
    source: str = ""
    digest: str = ""

    def check_gearset(self, gearset: Any) -> None:
        """CaseError naming the first segment the gear set cannot run: a stage it lacks,
        a pinion speed above `top_speed_rpm`, or a load above `load_limit`'s.

        ``gearset`` is a `fe_impact.gears.gearset.GearSet`.
        """
        self.check_stages(len(gearset.stages), f"the gear set {gearset.name!r}")
        where = f"{self.source}: " if self.source else ""
        for i, seg in enumerate(self.schedule.segments):
            message = speed_problem(gearset, seg.max_speed_rpm)
            if message:
                raise CaseError(f"{where}[segments[{i}]] speed_rpm = {message}")
        top: dict[int, tuple[float, int]] = {}
        for i, seg in enumerate(self.schedule.segments):
            if seg.max_load > top.get(seg.stage, (0.0, -1))[0]:
                top[seg.stage] = (seg.max_load, i)
        for stage, (load, i) in top.items():
            message = load_problem(gearset, stage, load)
            if message:
                raise CaseError(f"{where}[segments[{i}]] load_Nm = {message}")

    def check_stages(self, n_stages: int, gearset_name: str = "the gear set") -> None:
        """CaseError naming the first segment whose stage the gear set lacks."""
        for i, seg in enumerate(self.schedule.segments):
            if seg.stage > n_stages:
                where = f"{self.source}: " if self.source else ""
                raise CaseError(f"{where}[segments[{i}]] stage = {seg.stage}: {gearset_name} "
                                f"has stages 1..{n_stages}; give one of them")

    @property
    def max_load(self) -> float:
        """Largest output load torque of the schedule [N m]."""
        return max(seg.max_load for seg in self.schedule.segments)


# -- operating limits of a gear set ------------------------------------------------------
def top_speed_rpm(gearset: Any) -> float:
    """Fastest pinion speed [r/min] of ``gearset``: `MAX_PITCH_LINE_SPEED` at the
    pinion's pitch radius."""
    return MAX_PITCH_LINE_SPEED / gearset.pinion.pitch_radius * 30.0 / math.pi


def speed_problem(gearset: Any, speed_rpm: float) -> str:
    """"" if the pinion may run at ``speed_rpm``, else ``"<value>: <what is allowed>"``."""
    radius, top = gearset.pinion.pitch_radius, top_speed_rpm(gearset)
    if speed_rpm <= top:
        return ""
    return (f"{speed_rpm:g}: a pitch-line speed of {speed_rpm * radius * math.pi / 30.0:.4g} "
            f"m/s on the pinion ({radius * 1e3:g} mm pitch radius); at most {top:.4g} r/min "
            f"({MAX_PITCH_LINE_SPEED:g} m/s): the speed is in r/min")


def load_limit(gearset: Any, stage: int, load: float) -> tuple[float, float, float]:
    """Hertz p0 [Pa] at stage ``stage``'s pitch point under ``load`` [N m, > 0] on the
    output, the flanks' static contact strength [Pa] (`STATIC_CONTACT_FACTOR` x the
    material's ``contact_stress_limit_pa``), and the load [N m] at which p0 reaches it
    (exact: p0 scales as the load's cube root for a point contact, Hertz)."""
    from fe_impact.gears.report import pitch_point

    p0 = pitch_point(gearset, stage, load)[1]["pitch_point"]["max_pressure_Pa"]
    strength = STATIC_CONTACT_FACTOR * gearset.material.contact_stress_limit
    return p0, strength, load * (strength / p0) ** 3


def load_problem(gearset: Any, stage: int, load: float) -> str:
    """"" if stage ``stage`` may carry ``load`` [N m], else ``"<value>: <what is allowed>"``."""
    if load <= 0.0:
        return ""
    p0, strength, allowed = load_limit(gearset, stage, load)
    if p0 <= strength:
        return ""
    return (f"{load:g}: Hertz p0 = {p0 / 1e6:.4g} MPa at stage {stage}'s pitch point, above "
            f"the flanks' static contact strength {strength / 1e6:.4g} MPa "
            f"({STATIC_CONTACT_FACTOR:g} x contact_stress_limit_pa, ISO 6336-2); at most "
            f"{allowed:.4g} N m on this gear set: the load is in N m on the output")


# -- load series -------------------------------------------------------------------------
def read_load_series(path: str | Path, where: str = "") -> LoadSeries:
    """Read a load time series: a CSV file with a header ``time_s,load_Nm`` (either order)
    and one row per point, times in s from the segment's start (first 0, strictly
    increasing), load torques in N m (>= 0).

    ``where`` prefixes every message (the schedule file and key that names the series).

    Raises
    ------
    CaseError
        One line naming the file, the line and column, the value and what is allowed.
    """
    path = Path(path)
    head = f"{where}: " if where else ""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise CaseError(f"{head}{path}: load series not found") from None
    except IsADirectoryError:
        raise CaseError(f"{head}{path}: is a directory, not a load-series CSV file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CaseError(f"{head}{path}: cannot read the load series ({exc})") from None
    rows = [(n, r) for n, r in enumerate(csv.reader(text.splitlines()), start=1)
            if r and not r[0].lstrip().startswith("#")]
    if not rows:
        raise CaseError(f"{head}{path}: empty; give a header {','.join(SERIES_COLUMNS)} and "
                        "one row per point")
    header = [c.strip() for c in rows[0][1]]
    if sorted(header) != sorted(SERIES_COLUMNS):
        sep = next((c for c in ";\t|" if c in rows[0][1][0]), None) if len(header) == 1 else None
        hint = f" separated by commas (this file uses {sep!r})" if sep else " (either order)"
        raise CaseError(f"{head}{path}: line {rows[0][0]}: header {header}: give the two "
                        f"columns {list(SERIES_COLUMNS)}{hint}")
    if len(rows) - 1 > MAX_SERIES_POINTS:
        raise CaseError(f"{head}{path}: {len(rows) - 1} points; at most "
                        f"{MAX_SERIES_POINTS}: resample the series")
    columns = [header.index(c) for c in SERIES_COLUMNS]
    values = np.empty((len(rows) - 1, 2))
    for k, (line, row) in enumerate(rows[1:]):
        if len(row) != 2:
            raise CaseError(f"{head}{path}: line {line}: {len(row)} values; give two "
                            f"({','.join(header)})")
        for j, col in enumerate(columns):
            values[k, j] = _series_value(row[col], path, line, SERIES_COLUMNS[j], head)
    _check_series(values, [line for line, _ in rows[1:]], path, head)
    return LoadSeries(values[:, 0], values[:, 1], str(path))


def _series_value(text: str, path: Path, line: int, column: str, head: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise CaseError(f"{head}{path}: line {line}: {column} = {text.strip()!r}: must be a "
                        "number") from None
    if not math.isfinite(value):
        raise CaseError(f"{head}{path}: line {line}: {column} = {text.strip()}: must be a "
                        "finite number (no NaN or inf)")
    return value


def _check_series(values: np.ndarray, lines: list[int], path: Path, head: str) -> None:
    """Times from 0, strictly increasing; torques >= 0; two points or more."""
    if len(values) < 2:
        raise CaseError(f"{head}{path}: {len(values)} point(s); give two or more rows")
    if values[0, 0] != 0.0:
        raise CaseError(f"{head}{path}: line {lines[0]}: time_s = {values[0, 0]:g}: the "
                        "series must start at 0 s (times count from the segment's start)")
    back = np.flatnonzero(np.diff(values[:, 0]) <= 0.0)
    if back.size:
        k = int(back[0]) + 1
        raise CaseError(f"{head}{path}: line {lines[k]}: time_s = {values[k, 0]:g} is not "
                        f"after line {lines[k - 1]}'s {values[k - 1, 0]:g}: times must "
                        "increase strictly")
    negative = np.flatnonzero(values[:, 1] < 0.0)
    if negative.size:
        k = int(negative[0])
        raise CaseError(f"{head}{path}: line {lines[k]}: load_Nm = {values[k, 1]:g}: must be "
                        ">= 0 (the load resists the rotation)")


# -- schedule files ----------------------------------------------------------------------
def read_schedule(path: str | Path) -> DutyCycle:
    """Read and check a schedule file (TOML; format in the module docstring).

    Load series named in the file are read relative to the file's folder.

    Raises
    ------
    CaseError
        One line naming the file, the key (``[segments[i]] key``), the value and
        what is allowed.
    """
    path = Path(path)
    data = read_document(path, "schedule file", CaseError, "toml")
    digest = hashlib.sha256(path.read_bytes())
    duty = schedule_from_dict(data, path.stem, base=path.parent, file=str(path),
                              digest=digest)
    logger.info("read schedule %r from %s: %d segments, %g s", duty.name, path,
                len(duty.schedule.segments), duty.schedule.duration)
    return duty


def schedule_from_dict(data: Mapping[str, Any], name: str = "schedule",
                       base: Path | None = None, file: str = "",
                       digest: Any = None) -> DutyCycle:
    """A `DutyCycle` from a parsed schedule document (``name``: the default name; ``base``:
    the folder load-series paths are relative to; ``file``: shown in messages)."""
    r = Reader(file, CaseError, "toml")
    r.keys(data, "", _TOP_KEYS, required=("segments",))
    if "schema" in data and data["schema"] != SCHEMA:
        raise r.fail("", "schema", data["schema"], f"this version reads {SCHEMA!r}")
    if "name" not in data:       # the file's stem: made a valid name
        name = re.sub(r"[^A-Za-z0-9_.+-]+", "_", name).lstrip(".-+") or "schedule"
    name = r.string(data, "", "name", default=name)
    if not _NAME.fullmatch(name):
        raise r.fail("", "name", name, "names the result files: letters, digits and "
                     "'_', '-', '.', '+' only (no spaces or folders)")
    description = r.string(data, "", "description", default="", empty=True)
    blend = r.number(data, "", "blend_s", low=0.0, default=None, null=True)
    if digest is None:     # a document built in code: its content keys the caches
        digest = hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode())
    segments: list[Segment] = []
    for i, table in enumerate(r.array(data, "", "segments", required=True)):
        where = f"segments[{i}]"
        segment = _segment(r, table, where, segments, blend, base or Path("."), digest)
        segments.append(segment)
    return DutyCycle(name, description, StageSchedule(tuple(segments)), file,
                     digest.hexdigest()[:24])


def _segment(r: Reader, t: Mapping[str, Any], where: str, before: list[Segment],
             blend: float | None, base: Path, digest: Any) -> Segment:
    r.keys(t, where, _SEGMENT_KEYS, required=("stage", "duration_s", "speed_rpm"))
    stage = r.integer(t, where, "stage", low=1)
    duration = r.number(t, where, "duration_s", low=0.0, low_open=True,
                        hint="s")
    speed, speed_end = _ramp(r, t, where, "speed_rpm", "r/min")
    load, load_end, series = _load(r, t, where, base, digest)
    if series is not None and series.times[-1] < duration * (1.0 - 1e-12):
        raise r.fail(where, "load_Nm", t["load_Nm"],
                     f"{series.source} ends at {series.times[-1]:g} s, before the segment's "
                     f"duration_s = {duration:g} s; extend the series or shorten the segment")
    if "blend_s" in t and not before:
        raise r.fail(where, "blend_s", t["blend_s"], "the first segment has nothing to blend "
                     "from; remove it")
    own_blend = r.number(t, where, "blend_s", low=0.0, null=True)
    seg_blend = own_blend if own_blend is not None else blend
    if before and seg_blend is not None and seg_blend > duration:
        key = "blend_s" if own_blend is not None else "duration_s"
        raise r.fail(where, key, t[key], f"the segment ({duration:g} s) must last at least "
                     f"its blend_s = {seg_blend:g} s")
    engage = _switch(r, t, where, stage, before)
    return Segment(duration, stage, speed, load, speed_end_rpm=speed_end, load_end=load_end,
                   load_series=series, blend=None if not before else seg_blend,
                   engage=engage)


def _ramp(r: Reader, t: Mapping[str, Any], where: str, key: str, unit: str
          ) -> tuple[float, float | None]:
    """A number >= 0, or a table ``{from, to}`` of two (a linear ramp over the segment)."""
    value = t[key]
    if isinstance(value, Mapping):
        r.keys(value, f"{where}.{key}", _RAMP_KEYS, required=_RAMP_KEYS)
        start = r.number(value, f"{where}.{key}", "from", low=0.0, hint=unit)
        end = r.number(value, f"{where}.{key}", "to", low=0.0, hint=unit)
        return start, end
    if not is_real(value) or value < 0.0:
        raise r.fail(where, key, value, f"must be a number >= 0 [{unit}], or a ramp "
                     f"{{ from = ..., to = ... }}")
    return float(value), None


def _load(r: Reader, t: Mapping[str, Any], where: str, base: Path, digest: Any
          ) -> tuple[float, float | None, LoadSeries | None]:
    """The segment's load: constant, ramped, or a series ``{ file = "x.csv" }``."""
    value = t.get("load_Nm", 0.0)
    if isinstance(value, Mapping) and "file" in value:
        r.keys(value, f"{where}.load_Nm", ("file",), required=("file",))
        name = r.string(value, f"{where}.load_Nm", "file")
        path = base / name
        series = read_load_series(path, f"{r.file}: [{where}] load_Nm".lstrip(": "))
        digest.update(path.read_bytes())
        return float(series.torques[0]), None, series
    if isinstance(value, Mapping):
        if not set(value) <= set(_RAMP_KEYS):
            raise r.problem(f"unknown key(s) {sorted(set(value) - set(_RAMP_KEYS))} in "
                            f"[{where}.load_Nm]; give a ramp {{ from, to }} or a series "
                            "{ file = \"load.csv\" }")
    load, end = _ramp(r, {"load_Nm": value}, where, "load_Nm", "N m")
    return load, end, None


def _switch(r: Reader, t: Mapping[str, Any], where: str, stage: int,
            before: list[Segment]) -> float | None:
    """The engage position of a declared switch; None without a ``switch`` table."""
    if "switch" not in t:
        return None
    table = r.table(t, where, "switch")
    if not before:
        raise r.fail(where, "switch", dict(table), "the first segment engages its stage; "
                     "a switch needs a segment before it on another stage")
    if stage == before[-1].stage:
        raise r.fail(where, "switch", dict(table), f"a ratio switch to stage {stage}, which "
                     f"segments[{len(before) - 1}] already engages; give another stage, or "
                     "remove switch to stay on this one")
    r.keys(table, f"{where}.switch", _SWITCH_KEYS)
    return r.number(table, f"{where}.switch", "engage", low=-1.0, high=1.0, null=True)
