"""Reading input files: file errors and checked, typed values, written once.

Every input file of fe-impact (case files, gear sets, calibration files) is
read by :func:`read_document` and its values are taken with a
:class:`Reader`, so a mistake reads the same everywhere: one line naming the
file, the key path, the value and what is allowed::

    bad.toml: [materials[0]] poisson_ratio = 0.5: must be in (-1.0, 0.5)
    bad.toml: unknown key(s) ['colour'] in [materials[0]]; allowed: ['density', ...]
    calibration.json: [cases[2].impact] k = -1.0: must be > 0

Records check their own fields (in ``__post_init__``) with the same words
through :func:`check_number`, :func:`check_integer`, :func:`check_choice`
and :func:`check_flag`.

>>> r = Reader("c.toml", syntax="toml")
>>> r.number({"nu": 0.7}, "material", "nu", low=-1.0, high=0.5, low_open=True,
...          high_open=True)
Traceback (most recent call last):
...
fe_impact.errors.FeImpactError: c.toml: [material] nu = 0.7: must be in (-1.0, 0.5)
"""

from __future__ import annotations

import json
import math
import numbers
import tomllib
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fe_impact.errors import FeImpactError

__all__ = [
    "MAX_DENSITY",
    "MAX_YOUNGS_MODULUS",
    "SYNTAXES",
    "Reader",
    "check_choice",
    "check_flag",
    "check_integer",
    "check_number",
    "invalid",
    "is_real",
    "read_document",
]

#: Document syntaxes :func:`read_document` understands.
SYNTAXES = ("toml", "json")
#: Upper bounds of material values shared by the readers (case files, gear
#: sets): finite numbers beyond them are unit mistakes, and 1.7e308 Pa
#: overflowed in the assembly. Young's modulus: 10 x diamond's 1.2e12 Pa;
#: density: 4 x osmium's 22,590 kg/m^3.
MAX_YOUNGS_MODULUS = 1e13
MAX_DENSITY = 1e5


def is_real(value: Any) -> bool:
    """True for a finite real number (int or float, numpy scalars too), not a bool."""
    return (isinstance(value, numbers.Real) and not isinstance(value, bool)
            and math.isfinite(value))


def _is_integer(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _type_name(value: Any) -> str:
    return {dict: "a table", list: "a list", str: "a string", bool: "a boolean",
            type(None): "null"}.get(type(value), type(value).__name__)


# -- files --------------------------------------------------------------------------
def read_document(path: str | Path, what: str, error: type[FeImpactError] = FeImpactError,
                  syntax: str | None = None) -> dict[str, Any]:
    """Read a TOML or JSON file whose top level is a table (object).

    Parameters
    ----------
    path : str or Path
        The file.
    what : str
        What the file is, for messages ("case file", "gear-set file", ...).
    error : type
        The exception raised, a subclass of :class:`~fe_impact.errors.FeImpactError`.
    syntax : {"toml", "json"}, optional
        Default: ``json`` for a ``.json`` suffix, else ``toml``.

    Raises
    ------
    error
        One line naming the file and what is wrong: not found, a directory,
        not UTF-8 text, invalid syntax (with line and column) or a top level
        that is not a table.
    """
    path = Path(path)
    syntax = syntax or ("json" if path.suffix.lower() == ".json" else "toml")
    if syntax not in SYNTAXES:
        raise ValueError(f"syntax = {syntax!r}: pick one of {list(SYNTAXES)}")
    try:
        raw = path.read_bytes()
    except FileNotFoundError as exc:
        raise error(f"{path}: {what} not found") from exc
    except IsADirectoryError as exc:
        raise error(f"{path}: is a directory, not a {what}") from exc
    except OSError as exc:
        raise error(f"{path}: cannot read the {what}: {exc.strerror}") from exc
    try:
        text = raw.decode("utf-8-sig")   # a byte-order mark is tolerated
    except UnicodeDecodeError as exc:
        raise error(f"{path}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset "
                    f"{exc.start}); save the {what} as UTF-8") from exc
    try:
        data = tomllib.loads(text) if syntax == "toml" else json.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{path}: not valid TOML: {exc}") from exc
    except json.JSONDecodeError as exc:
        raise error(f"{path}: not valid JSON: {exc}") from exc
    if not isinstance(data, dict):
        word = "an object" if syntax == "json" else "a table"
        raise error(f"{path}: the top level must be {word}, got {_type_name(data)}")
    return data


# -- checks of single values ----------------------------------------------------------
def _bound(x: float, scale: float | None) -> str:
    if scale is not None:
        return f"{x * scale:g}"
    return str(x) if x == 0 or 1e-4 <= abs(x) < 1e6 else f"{x:g}"   # 1e+13, not 10000000000000.0


def _range(low: float | None, high: float | None, low_open: bool, high_open: bool,
           scale: float | None = None) -> str:
    """``> 0``, ``<= 1``, ``in (-1.0, 0.5)`` or ``""`` (bounds shown as given, or scaled)."""
    if low is not None and high is not None:
        return (f"in {'(' if low_open else '['}{_bound(low, scale)}, "
                f"{_bound(high, scale)}{')' if high_open else ']'}")
    if low is not None:
        return f"{'>' if low_open else '>='} {_bound(low, scale)}"
    if high is not None:
        return f"{'<' if high_open else '<='} {_bound(high, scale)}"
    return ""


def _number_problem(value: Any, low: float | None, high: float | None, low_open: bool,
                    high_open: bool, unit: str | None = None, scale: float = 1.0,
                    hint: str = "") -> str | None:
    """What is wrong with ``value`` as a number in the range, or None."""
    shown = None if unit is None else scale
    rng = _range(low, high, low_open, high_open, shown)
    tail = "".join(f" {s}" for s in (unit, hint) if s)
    if not is_real(value):
        return f"must be a number{f' {rng}' if rng else ''}{tail}"
    too_low = low is not None and (value <= low if low_open else value < low)
    too_high = high is not None and (value >= high if high_open else value > high)
    if too_low or too_high:
        return f"must be {rng}{tail}"
    return None


def _integer_problem(value: Any, low: int | None, high: int | None) -> str | None:
    if low is not None and high is not None:
        rng = f" in {low}..{high}"
    else:
        rng = f" >= {low}" if low is not None else (f" <= {high}" if high is not None else "")
    ok = _is_integer(value) and (low is None or value >= low) and (high is None or value <= high)
    return None if ok else f"must be an integer{rng}"


def invalid(name: str, value: Any, problem: str, error: type[FeImpactError] = FeImpactError,
            shown: str | None = None) -> FeImpactError:
    """The exception for ``name = value: problem`` (``shown`` replaces ``repr(value)``)."""
    return error(f"{name} = {repr(value) if shown is None else shown}: {problem}")


def check_number(name: str, value: Any, *, low: float | None = None,
                 high: float | None = None, low_open: bool = False, high_open: bool = False,
                 unit: str | None = None, scale: float = 1.0, hint: str = "",
                 error: type[FeImpactError] = FeImpactError) -> float:
    """``value`` as a float if it is a finite number in the range, else raise ``error``.

    With a ``unit``, the value and the bounds are shown multiplied by ``scale``
    and followed by the unit (a length in m shown in mm: ``unit="mm",
    scale=1e3``); without, as given.

    >>> check_number("pinion.module", -0.003, low=0.0, low_open=True, unit="mm", scale=1e3)
    Traceback (most recent call last):
    ...
    fe_impact.errors.FeImpactError: pinion.module = -3 mm: must be > 0 mm
    """
    problem = _number_problem(value, low, high, low_open, high_open, unit, scale, hint)
    if problem is not None:
        shown = None
        if unit is not None and is_real(value):
            shown = f"{value * scale:g} {unit}".rstrip()
        raise invalid(name, value, problem, error, shown)
    return float(value)


def check_integer(name: str, value: Any, *, low: int | None = None, high: int | None = None,
                  error: type[FeImpactError] = FeImpactError) -> int:
    """``value`` if it is an integer in ``low..high`` (either may be None), else raise."""
    problem = _integer_problem(value, low, high)
    if problem is not None:
        raise invalid(name, value, problem, error)
    return int(value)


def check_choice(name: str, value: Any, choices: Collection,
                 error: type[FeImpactError] = FeImpactError) -> Any:
    """``value`` if it is one of ``choices``, else raise naming them."""
    if isinstance(value, Mapping | list) or value not in choices:
        raise invalid(name, value, f"pick one of {list(choices)}", error)
    return value


def check_flag(name: str, value: Any, error: type[FeImpactError] = FeImpactError) -> bool:
    """``value`` if it is a bool, else raise."""
    if not isinstance(value, bool):
        raise invalid(name, value, "must be true or false", error)
    return value


# -- documents -----------------------------------------------------------------------------
def _location(where: str, key: str) -> str:
    return f"[{where}] {key}" if where else key


def _path(where: str, key: str) -> str:
    return f"{where}.{key}" if where else key


def _scope(where: str) -> str:
    return f"in [{where}]" if where else "at the top level"


@dataclass(frozen=True)
class Reader:
    """Typed access to the tables of one document, with messages naming file and key.

    ``where`` is the path of the table that holds the key, shown in brackets:
    ``"materials[0]"``, ``"face_gear.stages 1"``, ``"cases[3].impact"``, or
    ``""`` for the top level. Getters return the value converted (floats,
    tuples) or raise ``error`` with ``file: [where] key = value: what is
    allowed``.

    Attributes
    ----------
    file : str
        Shown first in every message ("" for none, e.g. a dict built in code).
    error : type
        The exception raised (`CaseError`, `GeometryError`, `CalibrationError`).
    syntax : {"toml", "json"}
        The document's words for tables: "table" or "object".
    """

    file: str = ""
    error: type[FeImpactError] = FeImpactError
    syntax: str = "toml"

    # -- messages --------------------------------------------------------------------
    def problem(self, text: str) -> FeImpactError:
        """The exception for a message about the document (the file name prepended)."""
        return self.error(f"{self.file}: {text}" if self.file else text)

    def fail(self, where: str, key: str, value: Any, allowed: str) -> FeImpactError:
        """The exception for ``[where] key = value: allowed``."""
        return self.problem(f"{_location(where, key)} = {value!r}: {allowed}")

    @property
    def _table_word(self) -> str:
        return "an object" if self.syntax == "json" else "a table"

    # -- structure -----------------------------------------------------------------
    def keys(self, t: Any, where: str, allowed: Collection[str],
             required: Collection[str] = ()) -> None:
        """Check that ``t`` is a table with only ``allowed`` keys and all ``required`` ones."""
        if not isinstance(t, Mapping):
            loc = f"[{where}]" if where else "the top level"
            raise self.problem(f"{loc} must be {self._table_word}, got {_type_name(t)}")
        unknown = sorted(set(t) - set(allowed))
        if unknown:
            raise self.problem(f"unknown key(s) {unknown} {_scope(where)}; "
                               f"allowed: {sorted(allowed)}")
        missing = sorted(set(required) - set(t))
        if missing:
            raise self.problem(f"missing key(s) {missing} {_scope(where)}")

    def table(self, t: Mapping, where: str, key: str, default: Mapping | None = None
              ) -> Mapping[str, Any]:
        """The table (object) under ``key``; ``default`` when absent (None: required)."""
        v = t[key] if default is None else t.get(key, default)
        if not isinstance(v, Mapping):
            example = f", e.g. [{_path(where, key)}]" if self.syntax == "toml" else ""
            raise self.fail(where, key, v, f"must be {self._table_word}{example}")
        return v

    def array(self, t: Mapping, where: str, key: str, required: bool = False
              ) -> list[Mapping[str, Any]]:
        """The array of tables under ``key`` (``[]`` when absent)."""
        v = t.get(key, [])
        name = _path(where, key)
        if not isinstance(v, list) or not all(isinstance(x, Mapping) for x in v):
            what = ("a list of objects" if self.syntax == "json"
                    else f"an array of tables, e.g. [[{name}]]")
            raise self.fail(where, key, v, f"must be {what}")
        if required and not v:
            if self.syntax == "json":
                raise self.fail(where, key, v, "must be a non-empty list of objects")
            raise self.problem(f"at least one [[{name}]] is required")
        return v

    # -- values --------------------------------------------------------------------
    def string(self, t: Mapping, where: str, key: str, default: str | None = None,
               empty: bool = False) -> str:
        """A string (non-empty unless ``empty``)."""
        v = t.get(key, default)
        if not isinstance(v, str) or (not v and not empty):
            raise self.fail(where, key, v, "must be a string" if empty
                            else "must be a non-empty string")
        return v

    def strings(self, t: Mapping, where: str, key: str, what: str = "group names"
                ) -> list[str]:
        """A non-empty list of non-empty strings; a single string counts as a list of one."""
        v = t[key]
        if isinstance(v, str):
            v = [v]
        if not isinstance(v, list) or not v or not all(isinstance(s, str) and s for s in v):
            raise self.fail(where, key, v, f"must be a non-empty list of {what}")
        return v

    def numbers(self, t: Mapping, where: str, key: str, size: int | None = None,
                unit: str = "") -> tuple[float, ...]:
        """A list of finite numbers: ``size`` of them, or any non-empty list."""
        v = t[key]
        ok = (isinstance(v, list) and (len(v) == size if size is not None else bool(v))
              and all(is_real(c) for c in v))
        if not ok:
            count = {3: "three"}.get(size, str(size)) if size is not None else None
            what = f"a list of {count} numbers" if count else "a non-empty list of numbers"
            raise self.fail(where, key, v, f"must be {what} {unit}".rstrip())
        return tuple(float(c) for c in v)

    def vector(self, t: Mapping, where: str, key: str, unit: str
               ) -> tuple[float, float, float]:
        """Three finite numbers."""
        return self.numbers(t, where, key, 3, unit)  # type: ignore[return-value]

    def choice(self, t: Mapping, where: str, key: str, choices: Sequence, default=None):
        """One of ``choices``."""
        v = t.get(key, default)
        if isinstance(v, Mapping | list) or v not in choices:
            raise self.fail(where, key, v, f"pick one of {list(choices)}")
        return v

    def number(self, t: Mapping, where: str, key: str, low: float | None = None,
               high: float | None = None, low_open: bool = False, high_open: bool = False,
               default: float | None = None, hint: str = "", null: bool = False
               ) -> float | None:
        """A finite number in the range (bounds as given; ``*_open`` excludes them).

        ``default`` is used when the key is absent; with ``null`` a null
        (None) value is allowed and returned as None.
        """
        v = t.get(key, default)
        if null and v is None:
            return None
        problem = _number_problem(v, low, high, low_open, high_open, hint=hint)
        if problem is not None:
            raise self.fail(where, key, v, problem)
        return float(v)

    def integer(self, t: Mapping, where: str, key: str, low: int | None = None,
                high: int | None = None, default: int | None = None, null: bool = False
                ) -> int | None:
        """An integer in ``low..high`` (either may be None)."""
        v = t.get(key, default)
        if null and v is None:
            return None
        problem = _integer_problem(v, low, high)
        if problem is not None:
            raise self.fail(where, key, v, problem)
        return int(v)

    def boolean(self, t: Mapping, where: str, key: str, default: bool | None = None) -> bool:
        """true or false."""
        v = t.get(key, default)
        if not isinstance(v, bool):
            raise self.fail(where, key, v, "must be true or false")
        return v
