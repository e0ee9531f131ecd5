"""Calibration records: one FE impact's measurements and fitted laws, and the files.

A calibration run writes, per impact case, ``cases/<id>/result.json`` (one
:class:`CalibrationRecord`) and, for the whole sweep, ``calibration.json``
(a :class:`Calibration`: schema `SCHEMA`, units `UNITS`, the run's settings
and the records) with ``calibration.csv`` beside it (columns `CSV_COLUMNS`).
The lumped model reads ``calibration.json`` back (`read_calibration`).

A record holds, in this order in the file::

    stage, face_teeth, kind            the case: stage (from 1), its face-gear
                                       teeth, the kind of contact (`KINDS`)
    restitution_models                 seed eq. 14 restitution, yield-onset speeds
    speed_rpm, impact_speed, effective_mass
    fe                                 FE measurements (`FEMeasurements`)
    impact                             fitted ADAMS IMPACT law (`ImpactParameters`)
    fit_quality                        how well the law reproduces the FE impact
    closed_form                        the seed's eq. 12-17 parameters
    hysteresis_chi                     chi of five hysteresis models for e
    differences                        fitted against closed form, per parameter
    id, hash, timings_s, initial_gap, model     the run (resume key, seconds, FE model)

Only ``stage``, ``kind``, ``impact_speed`` and ``impact`` are required: a
calibration file written by hand for the lumped model may hold only those
(with ``face_teeth``, ``speed_rpm``, ``effective_mass``). Every section
present is checked when read, and reported naming the file, the key path
and the value. Units are SI (`UNITS`).

The files are standard JSON: a value that is not finite (a
``relative_difference`` against a closed-form value of 0) is written as
``null`` and read back as None.
"""

from __future__ import annotations

import json
import math
import numbers
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from fe_impact.atomic import atomic_path, write_csv
from fe_impact.errors import CalibrationError
from fe_impact.inputs import Reader, read_document

__all__ = [
    "CSV_COLUMNS",
    "KINDS",
    "NOTES",
    "SCHEMA",
    "UNITS",
    "Calibration",
    "CalibrationRecord",
    "ClosedForm",
    "Difference",
    "FEMeasurements",
    "FitQuality",
    "HysteresisChi",
    "ImpactParameters",
    "ModelInfo",
    "RestitutionModels",
    "csv_row",
    "read_calibration",
    "read_record",
    "write_calibration",
    "write_calibration_csv",
    "write_record",
]

SCHEMA = "fe-impact/calibration/2"
#: The schema before the position-dependent law (``mesh_cycle``); still read.
SCHEMA_V1 = "fe-impact/calibration/1"
#: Impact kinds: tooth contact on the flanks in mesh (seed eq. 4), the first
#: contact after a ratio switch into the stage (eq. 5), and contact on a rounded
#: tip edge as a pair enters mesh early (the face gear's edge on the pinion
#: before the path of contact, the pinion's edge on the face gear after it);
#: the order of the lumped model's tables.
KINDS = ("mesh", "switch", "corner-approach", "corner-recess")
#: Units of the quantities, by key name (written in calibration.json).
UNITS = {"impact_speed": "m/s", "speed_rpm": "r/min", "effective_mass": "kg",
         "peak_force": "N", "max_approach": "m", "contact_time": "s", "restitution": "-",
         "energy_lost": "-", "stiffness_k": "N/m^stiffness_exponent",
         "mesh_stiffness": "N/m", "k": "N/m^exponent", "exponent": "-", "cmax": "N s/m",
         "d": "m", "residual_indentation": "m", "chi": "-", "seconds": "s", "v_y_eq15": "m/s",
         "v_y_tooth": "m/s", "seed_eq14": "-", "yield_ratio_eq15": "-"}
NOTES = ("impact: ADAMS IMPACT parameters fitted jointly to the FE force history "
         "and restitution of a one-DOF model with the case's effective mass and "
         "impact speed; closed_form: the seed's eq. 12-17; fe: FE measurements "
         "(stiffness_k/stiffness_exponent fit F = K delta^xi on the loading branch)")


# -- field kinds -----------------------------------------------------------------------
@dataclass(frozen=True)
class _Spec:
    """How a field is read: its kind, whether it may be null/absent, and its checks."""

    kind: str       # number, integer, string, choice, flag, numbers, section, sections, table
    optional: bool = False
    options: Mapping[str, Any] = field(default_factory=dict)


def _field(kind: str, optional: bool = False, **options: Any) -> Any:
    meta = {"spec": _Spec(kind, optional, options)}
    return field(default=None, metadata=meta) if optional else field(metadata=meta)


def _number(optional: bool = False, **bounds: Any) -> Any:
    """A float; ``optional``: may be null (not finite, or absent from older files)."""
    return _field("number", optional, **bounds)


def _spec(f) -> _Spec:
    return f.metadata["spec"]


def _plain(value: Any) -> Any:
    """JSON-ready: records as dicts, tuples and arrays as lists, non-finite floats as None."""
    if isinstance(value, _Record):
        return value.to_dict()
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [_plain(v) for v in value]
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        return float(value) if math.isfinite(value) else None
    return value


class _Record:
    """Dict conversion and checked reading, driven by the fields' specs."""

    def __post_init__(self) -> None:
        # Plain Python numbers (numpy scalars come from the fits); a value that
        # is not finite where null is allowed is stored as None, as it is written,
        # and refused where it is not (it would be written as null, which reading refuses).
        for f in fields(self):
            v, kind = getattr(self, f.name), _spec(f).kind
            if kind == "number" and isinstance(v, numbers.Real) and not isinstance(v, bool):
                if not math.isfinite(v) and not _spec(f).optional:
                    raise CalibrationError(f"{type(self).__name__}.{f.name} = {v}: must be a "
                                           "finite number")
                v = None if not math.isfinite(v) else float(v)
            elif kind == "integer" and isinstance(v, numbers.Integral) and not isinstance(v, bool):
                v = int(v)
            elif kind == "numbers" and v is not None:
                v = tuple(float(x) for x in v)
            object.__setattr__(self, f.name, v)

    def to_dict(self) -> dict[str, Any]:
        """The record as JSON-ready dicts and lists, keys in field order."""
        return {f.name: _plain(getattr(self, f.name)) for f in fields(self)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], reader: Reader | None = None,
                  where: str = "", skip: Iterable[str] = ()):
        """Check and convert a dict as :meth:`to_dict` writes it.

        ``reader`` names the file in messages; ``where`` is the key path of
        ``data`` (e.g. ``cases[2].fe``); keys in ``skip`` are allowed but not read.

        Raises
        ------
        CalibrationError
            Unknown or missing keys, or a value of the wrong type or range.
        """
        r = reader or Reader(error=CalibrationError, syntax="json")
        specs = {f.name: _spec(f) for f in fields(cls)}
        r.keys(data, where, specs, required=[k for k, s in specs.items() if not s.optional])
        skip = set(skip)
        return cls(**{k: _read(r, data, where, k, s) for k, s in specs.items()
                      if k in data and k not in skip})

    @classmethod
    def from_source(cls, source: Any):
        """The record from an object with the same attribute names (e.g. a fit result)."""
        return cls(**{f.name: getattr(source, f.name) for f in fields(cls)})


def _read(r: Reader, t: Mapping[str, Any], where: str, key: str, spec: _Spec) -> Any:
    v, o = t[key], spec.options
    if spec.optional and (v is None or (isinstance(v, float) and not math.isfinite(v))):
        return None   # null, or an Infinity/NaN from a file written before nulls
    here = f"{where}.{key}" if where else key
    kind = spec.kind
    if kind == "number":
        return r.number(t, where, key, **o)
    if kind == "integer":
        return r.integer(t, where, key, **o)
    if kind == "string":
        return r.string(t, where, key, empty=True)
    if kind == "choice":
        return r.choice(t, where, key, o["choices"])
    if kind == "flag":
        return r.boolean(t, where, key)
    if kind == "numbers":
        return r.numbers(t, where, key, o.get("size"))
    table = r.table(t, where, key)
    if kind == "section":
        return o["type"].from_dict(table, r, here)
    if kind == "sections":
        return {name: o["type"].from_dict(r.table(table, here, name), r, f"{here}.{name}")
                for name in table}
    if kind == "table":   # name -> number >= 0
        return {name: r.number(table, here, name, low=0) for name in table}
    raise AssertionError(kind)


# -- the sections ------------------------------------------------------------------------
@dataclass(frozen=True)
class ImpactParameters(_Record):
    """The ADAMS IMPACT law ``F = k x^exponent + step(x, 0, 0, d, cmax) xdot`` (seed eq. 11).

    ``k`` [N/m^exponent] > 0, ``exponent`` [-] > 0, ``cmax`` [N s/m] >= 0,
    ``d`` [m] > 0: the full damping is reached at penetration ``d``.
    """

    k: float = _number(low=0, low_open=True)
    exponent: float = _number(low=0, low_open=True)
    cmax: float = _number(low=0)
    d: float = _number(low=0, low_open=True)


@dataclass(frozen=True, kw_only=True)
class FEMeasurements(_Record):
    """FE impact measurements (SI units, `UNITS`).

    ``restitution`` is the measured one clipped to 1 (an elastic rebound a
    hair above 1 is integrator error), ``restitution_measured`` the measured
    one; ``energy_lost = 1 - e^2``. ``stiffness_k``, ``stiffness_exponent``
    and ``stiffness_fit_r2``: the power law ``F = K delta^xi`` on the loading
    branch. ``mesh_stiffness`` (and from the power law) is ``dF/d delta`` at
    ``nominal_load``: None when the impact's peak force stays below it.
    ``friction_dissipation`` [J]: the energy the flank friction dissipated over the
    impact (0 frictionless; absent in files written before friction).
    """

    peak_force: float = _number()
    max_approach: float = _number()
    contact_time: float = _number()
    restitution: float = _number()
    restitution_measured: float | None = _number(optional=True)
    energy_lost: float = _number()
    impact_velocity: float = _number()
    energy_error: float | None = _number(optional=True)
    residual_indentation: float | None = _number(optional=True)
    stiffness_k: float = _number()
    stiffness_exponent: float = _number()
    stiffness_fit_r2: float | None = _number(optional=True)
    nominal_load: float = _number()
    mesh_stiffness: float | None = _number(optional=True)
    mesh_stiffness_power_law: float | None = _number(optional=True)
    friction_dissipation: float | None = _number(optional=True, low=0)


@dataclass(frozen=True, kw_only=True)
class FitQuality(_Record):
    """How well the fitted law reproduces the FE impact
    (:class:`fe_impact.calibration.impact_fit.ImpactFit` without the parameters).

    Relative errors of the one-DOF model against the FE; ``start`` is the
    initial guess ``(k, exponent, cmax, d)``; ``cmax_range`` and ``d_range``
    the spans of the damping parameters that fit equally well (absent in
    files written before them); ``wall_time`` in s.
    """

    residual_force_rms: float | None = _number(optional=True)
    restitution_model: float | None = _number(optional=True)
    restitution_error: float | None = _number(optional=True)
    peak_force_error: float | None = _number(optional=True)
    contact_time_error: float | None = _number(optional=True)
    success: bool = _field("flag")
    message: str = _field("string")
    n_evaluations: int | None = _field("integer", optional=True, low=0)
    start: tuple[float, ...] | None = _field("numbers", optional=True, size=4)
    cmax_range: tuple[float, ...] | None = _field("numbers", optional=True, size=2)
    d_range: tuple[float, ...] | None = _field("numbers", optional=True, size=2)
    fe_force_max: float | None = _number(optional=True)
    fe_contact_time: float | None = _number(optional=True)
    wall_time: float | None = _number(optional=True)


@dataclass(frozen=True, kw_only=True)
class ClosedForm(_Record):
    """The seed's closed-form IMPACT parameters (eq. 12, 13, 16, 17) at this impact
    (:class:`fe_impact.calibration.closed_form.ClosedFormParameters`)."""

    k: float = _number()
    exponent: float = _number()
    cmax: float = _number()
    d: float = _number()
    delta_max: float = _number()
    force_max: float = _number()
    contact_time: float = _number()
    restitution: float = _number()


@dataclass(frozen=True)
class HysteresisChi(_Record):
    """One hysteresis model's chi for the FE restitution, and the restitution it gives."""

    chi: float = _number()
    restitution: float = _number()


@dataclass(frozen=True)
class Difference(_Record):
    """A fitted value beside its closed form; ``relative_difference = fit / closed_form - 1``
    (None when the closed form is 0)."""

    fit: float = _number()
    closed_form: float = _number()
    relative_difference: float | None = _number(optional=True)


@dataclass(frozen=True, kw_only=True)
class RestitutionModels(_Record):
    """The seed's eq. 14 restitution with two yield-onset speeds (m/s): eq. 15's and the
    tooth pair's own (see :func:`fe_impact.calibration.measurement.restitution_models`)."""

    v_y_eq15: float = _number()
    v_y_tooth: float = _number()
    yield_ratio_eq15: float = _number()
    yield_ratio_tooth: float = _number()
    seed_eq14: float = _number()
    seed_eq14_tooth: float = _number()


@dataclass(frozen=True, kw_only=True)
class ModelInfo(_Record):
    """Size and integration of the FE model behind a record (``time_step`` in s)."""

    n_dofs: int = _field("integer", low=1)
    n_elements: int = _field("integer", low=1)
    element_order: int = _field("integer", low=1, high=2)
    integrator: str = _field("string")
    time_step: float | None = _number(optional=True, low=0, low_open=True)
    steps: int = _field("integer", low=0)

    @classmethod
    def from_info(cls, info: Mapping[str, Any]) -> ModelInfo:
        """From a dynamic result's ``info`` (its other entries are left out)."""
        return cls(**{f.name: info[f.name] for f in fields(cls)})


#: Sections the lumped model does not read (skipped by ``read_calibration(law_only=True)``).
_INFORMATION = ("restitution_models", "fe", "fit_quality", "closed_form", "hysteresis_chi",
                "differences", "timings_s", "model")


@dataclass(frozen=True, kw_only=True)
class CalibrationRecord(_Record):
    """One calibrated impact case: what was measured, fitted and compared.

    Attributes
    ----------
    stage : int
        Stage number, from 1.
    kind : str
        One of `KINDS`.
    impact_speed : float
        Impact (closing) speed of the case [m/s], > 0.
    impact : ImpactParameters
        The fitted law, the one the lumped model uses.
    face_teeth, speed_rpm, effective_mass, id, hash, initial_gap
        The case: face-gear teeth of the stage, operating speed [r/min] (None
        for a case given by impact speed), effective mass [kg], case id, resume
        key, initial gap at the contact point [m].
    fe, fit_quality, closed_form, hysteresis_chi, differences, restitution_models
        See the section classes; ``hysteresis_chi`` and ``differences`` are
        keyed by model and by parameter name.
    timings_s : dict of str to float
        Seconds per phase (``mesh``, ``fe_setup``, ``fe_steps``, ``fe_output``,
        ``fe``, ``fit``, ``total``).
    model : ModelInfo
    friction : tuple of float
        Flank friction ``(mu_static, mu_dynamic)`` the FE impact was solved with
        (absent in files written before friction: frictionless).
    companion : bool
        True for a frictionless companion of a case (the report's friction
        section); not in ``calibration.json``'s cases.
    """

    stage: int = _field("integer", low=1)
    face_teeth: int | None = _field("integer", optional=True, low=3)
    kind: str = _field("choice", choices=KINDS)
    restitution_models: RestitutionModels | None = _field("section", True,
                                                          type=RestitutionModels)
    speed_rpm: float | None = _number(optional=True, low=0)
    impact_speed: float = _number(low=0, low_open=True)
    effective_mass: float | None = _number(optional=True, low=0, low_open=True)
    fe: FEMeasurements | None = _field("section", True, type=FEMeasurements)
    impact: ImpactParameters = _field("section", type=ImpactParameters)
    fit_quality: FitQuality | None = _field("section", True, type=FitQuality)
    closed_form: ClosedForm | None = _field("section", True, type=ClosedForm)
    hysteresis_chi: Mapping[str, HysteresisChi] | None = _field("sections", True,
                                                                type=HysteresisChi)
    differences: Mapping[str, Difference] | None = _field("sections", True, type=Difference)
    id: str | None = _field("string", optional=True)
    hash: str | None = _field("string", optional=True)
    timings_s: Mapping[str, float] | None = _field("table", optional=True)
    initial_gap: float | None = _number(optional=True, low=0)
    model: ModelInfo | None = _field("section", True, type=ModelInfo)
    friction: tuple[float, ...] | None = _field("numbers", True, size=2)
    companion: bool | None = _field("flag", True)


@dataclass(frozen=True, kw_only=True)
class Calibration(_Record):
    """A calibration file: the records of a sweep and how they were made.

    ``settings`` are the run's options (:class:`fe_impact.calibration.planning.Settings`
    as a dict), ``wall_time_s`` the run's wall time [s]. The schema and the units
    are `SCHEMA` and `UNITS`; a file with another schema is refused.
    """

    TOP_KEYS: ClassVar[tuple[str, ...]] = ("schema", "fe_impact_version", "units", "settings",
                                           "wall_time_s", "notes", "cases", "mesh_cycle",
                                           "friction")

    cases: tuple[CalibrationRecord, ...]
    settings: Mapping[str, Any] | None = None
    wall_time_s: float | None = None
    fe_impact_version: str | None = None
    notes: str | None = None
    #: The position-dependent pair law per stage (schema 2):
    #: ``{"1": {"roll_angle_deg": [...], "k": [...], "exponent": [...], ...}}``
    #: (:func:`fe_impact.calibration.meshcycle_report.position_law`); None in a
    #: file without the mesh cycle.
    mesh_cycle: Mapping[str, Any] | None = None
    #: The flank friction of the run and what it changes (:func:`fe_impact.calibration.
    #: report.friction_effect`): ``mu_static``, ``mu_dynamic``, ``impact`` and
    #: ``position`` (each with and without friction); None in a file without it.
    friction: Mapping[str, Any] | None = None
    schema: str = SCHEMA

    def __post_init__(self) -> None:
        object.__setattr__(self, "cases", tuple(self.cases))

    def to_dict(self) -> dict[str, Any]:
        return {"schema": SCHEMA, "fe_impact_version": self.fe_impact_version,
                "units": dict(UNITS), "settings": _plain(self.settings),
                "wall_time_s": _plain(self.wall_time_s), "notes": self.notes,
                "cases": [c.to_dict() for c in self.cases],
                "mesh_cycle": _plain(self.mesh_cycle), "friction": _plain(self.friction)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], reader: Reader | None = None,
                  where: str = "", skip: Iterable[str] = ()) -> Calibration:
        """Check and convert a calibration document; ``skip`` applies to every case."""
        r = reader or Reader(error=CalibrationError, syntax="json")
        r.keys(data, where, cls.TOP_KEYS, required=("schema", "cases"))
        if data["schema"] not in (SCHEMA, SCHEMA_V1):
            raise r.fail(where, "schema", data["schema"], f"expected {SCHEMA!r} (or the "
                         f"older {SCHEMA_V1!r})")
        if "units" in data:
            r.table(data, where, "units")
        settings = None
        if data.get("settings") is not None:
            settings = dict(r.table(data, where, "settings"))
        cases = tuple(CalibrationRecord.from_dict(c, r, f"cases[{i}]", skip)
                      for i, c in enumerate(r.array(data, where, "cases", required=True)))
        return cls(cases=cases, settings=settings, schema=data["schema"],
                   mesh_cycle=_mesh_cycle(r, data, where),
                   friction=(None if data.get("friction") is None
                             else dict(r.table(data, where, "friction"))),
                   wall_time_s=r.number(data, where, "wall_time_s", low=0, null=True),
                   fe_impact_version=(None if data.get("fe_impact_version") is None
                                      else r.string(data, where, "fe_impact_version")),
                   notes=(None if data.get("notes") is None
                          else r.string(data, where, "notes", empty=True)))


def _mesh_cycle(r: Reader, data: Mapping[str, Any], where: str) -> dict | None:
    """Check the position-dependent law: per stage, two or more rising roll angles
    with positive ``k`` and ``exponent`` of the same length."""
    if data.get("mesh_cycle") is None:
        return None
    out = {}
    for stage, law in r.table(data, where, "mesh_cycle").items():
        w = f"{where}.mesh_cycle" if where else "mesh_cycle"
        if not (stage.isdigit() and int(stage) >= 1):
            raise r.fail(w, stage, "...", "stages are keyed by their number: 1, 2, ...")
        if not isinstance(law, Mapping):
            raise r.fail(w, stage, law, "must be an object with roll_angle_deg, k, exponent")
        w = f"{w}.{stage}"
        roll = r.numbers(law, w, "roll_angle_deg", unit="(deg)")
        k = r.numbers(law, w, "k", size=len(roll))
        e = r.numbers(law, w, "exponent", size=len(roll))
        if len(roll) < 2 or np.any(np.diff(roll) <= 0):
            raise r.fail(w, "roll_angle_deg", list(roll), "must hold two or more rising angles")
        for key, values in (("k", k), ("exponent", e)):
            if min(values) <= 0:
                raise r.fail(w, key, list(values), "must be positive")
        out[stage] = {**law, "roll_angle_deg": list(roll), "k": list(k), "exponent": list(e)}
        if law.get("corners") is not None:
            out[stage]["corners"] = _corner_laws(r, law, w)
    return out


def _corner_laws(r: Reader, law: Mapping[str, Any], where: str) -> dict:
    """A stage's FE corner laws: per tip-edge side, a positive ``k`` and ``exponent``."""
    out = {}
    for side, corner in r.table(law, where, "corners").items():
        w = f"{where}.corners"
        if side not in ("approach", "recess"):
            raise r.fail(w, side, "...", "corner sides are 'approach' and 'recess'")
        if not isinstance(corner, Mapping):
            raise r.fail(w, side, corner, "must be an object with k and exponent")
        values = {}
        for key in ("k", "exponent"):
            v = corner.get(key)
            if isinstance(v, bool) or not isinstance(v, int | float) or not (
                    math.isfinite(v) and v > 0):
                raise r.fail(f"{w}.{side}", key, v, "must be a positive number")
            values[key] = float(v)
        out[side] = {**corner, **values}
    return out


# -- CSV ----------------------------------------------------------------------------------
#: calibration.csv: (column, attribute path in a CalibrationRecord).
CSV_COLUMNS: tuple[tuple[str, str], ...] = (
    ("id", "id"), ("stage", "stage"), ("face_teeth", "face_teeth"), ("kind", "kind"),
    ("speed_rpm", "speed_rpm"), ("impact_speed", "impact_speed"),
    ("effective_mass", "effective_mass"),
    ("peak_force", "fe.peak_force"), ("max_approach", "fe.max_approach"),
    ("contact_time", "fe.contact_time"), ("restitution", "fe.restitution"),
    ("residual_indentation", "fe.residual_indentation"), ("stiffness_k", "fe.stiffness_k"),
    ("stiffness_exponent", "fe.stiffness_exponent"), ("mesh_stiffness", "fe.mesh_stiffness"),
    ("k", "impact.k"), ("exponent", "impact.exponent"), ("cmax", "impact.cmax"),
    ("d", "impact.d"),
    ("closed_k", "closed_form.k"), ("closed_exponent", "closed_form.exponent"),
    ("closed_cmax", "closed_form.cmax"), ("closed_d", "closed_form.d"),
    ("seconds", "timings_s.total"),
)


def _lookup(record: Any, path: str) -> Any:
    value = record
    for name in path.split("."):
        if value is None:
            return None
        value = value.get(name) if isinstance(value, Mapping) else getattr(value, name)
    return value


def csv_row(record: CalibrationRecord) -> list[Any]:
    """The record's `CSV_COLUMNS` values (empty for a missing section or a null)."""
    return [_plain(_lookup(record, path)) for _, path in CSV_COLUMNS]


# -- files --------------------------------------------------------------------------------
def _write(path: str | Path, data: dict[str, Any]) -> Path:
    # allow_nan=False: a NaN or Infinity left in would make the file non-standard
    # JSON (_plain writes them as null); fail here rather than in a reader.
    text = json.dumps(data, indent=2, allow_nan=False) + "\n"
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)


def write_record(path: str | Path, record: CalibrationRecord) -> Path:
    """Write one case's record (``result.json``), atomically."""
    return _write(path, record.to_dict())


def read_record(path: str | Path) -> CalibrationRecord:
    """Read and check one case's record (``result.json``)."""
    data = read_document(path, "calibration result", CalibrationError, "json")
    return CalibrationRecord.from_dict(data, Reader(str(path), CalibrationError, "json"))


def write_calibration(path: str | Path, calibration: Calibration) -> Path:
    """Write ``calibration.json``, atomically."""
    return _write(path, calibration.to_dict())


def write_calibration_csv(path: str | Path, records: Sequence[CalibrationRecord]) -> Path:
    """Write ``calibration.csv``: one row per record, columns `CSV_COLUMNS`."""
    return write_csv(path, [name for name, _ in CSV_COLUMNS], [csv_row(r) for r in records])


def read_calibration(path: str | Path, *, law_only: bool = False) -> Calibration:
    """Read and check a calibration file.

    Parameters
    ----------
    path : str or Path
    law_only : bool
        Read only what the lumped model uses (the case, its speed and its
        ``impact`` law); the other sections are left out (None) unchecked.

    Raises
    ------
    CalibrationError
        Missing file, invalid JSON, another schema or an invalid case; the
        message names the file, the key path and the value.
    """
    data = read_document(path, "calibration file", CalibrationError, "json")
    return Calibration.from_dict(data, Reader(str(path), CalibrationError, "json"),
                                 skip=_INFORMATION if law_only else ())
