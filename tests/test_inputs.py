"""The input toolkit: file errors, typed getters and their messages, and the three readers.

The truth here is the message text itself: one line naming the file, the key
path, the value and what is allowed, the same words in every reader.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from fe_impact.errors import CalibrationError, CaseError, FeImpactError, GeometryError
from fe_impact.fe.case import load_case
from fe_impact.gears import load_gearset
from fe_impact.gears.gearset import default_gearset_path
from fe_impact.inputs import Reader, check_choice, check_integer, check_number, read_document
from fe_impact.switching import load_calibration

SEED = default_gearset_path()


# -- files ------------------------------------------------------------------------------
@pytest.mark.parametrize(("name", "content", "message"), [
    ("none.toml", None, "{path}: case file not found"),
    ("folder.toml", "dir", "{path}: is a directory, not a case file"),
    ("latin1.toml", b"name = \"M\xfcller\"\n", "{path}: not UTF-8 text (byte 0xfc at offset 9)"),
    ("bad.toml", "[mesh\n", "{path}: not valid TOML: "),
    ("bad.json", '{"a": 1,}', "{path}: not valid JSON: "),
    ("list.json", "[1, 2]", "{path}: the top level must be an object, got a list"),
])
def test_file_errors_name_the_file_in_one_line(tmp_path, name, content, message):
    path = tmp_path / name
    if content == "dir":
        path.mkdir()
    elif isinstance(content, bytes):
        path.write_bytes(content)
    elif content is not None:
        path.write_text(content)
    with pytest.raises(CaseError) as info:
        read_document(path, "case file", CaseError)
    text = str(info.value)
    assert text.startswith(message.format(path=path)), text
    assert "\n" not in text


def test_documents_are_read_by_suffix_and_a_bom_is_tolerated(tmp_path):
    (tmp_path / "a.json").write_text('{"x": [1, 2.5]}')
    (tmp_path / "a.toml").write_bytes("\ufeffx = [1, 2.5]\n".encode())
    assert read_document(tmp_path / "a.json", "file") == {"x": [1, 2.5]}
    assert read_document(tmp_path / "a.toml", "file") == {"x": [1, 2.5]}


# -- getters ------------------------------------------------------------------------------
R = Reader("f.toml", CaseError)
T = {"nu": 0.7, "E": -1.0, "s": "", "n": 2.5, "c": "q", "v": [0.0, 1.0], "flag": 1,
     "names": [], "tab": 3, "arr": {"a": 1}}
GETTERS = [
    (lambda: R.number(T, "m[0]", "nu", low=-1.0, high=0.5, low_open=True, high_open=True),
     "f.toml: [m[0]] nu = 0.7: must be in (-1.0, 0.5)"),
    (lambda: R.number(T, "m[0]", "E", low=0.0, low_open=True),
     "f.toml: [m[0]] E = -1.0: must be > 0.0"),
    (lambda: R.number(T, "", "s", low=0.0, hint="(s)"),
     "f.toml: s = '': must be a number >= 0.0 (s)"),
    (lambda: R.number(T, "a", "missing", high=1.0, high_open=True),
     "f.toml: [a] missing = None: must be a number < 1.0"),
    (lambda: R.integer(T, "a", "n", low=1), "f.toml: [a] n = 2.5: must be an integer >= 1"),
    (lambda: R.integer(T, "a", "n", low=1, high=3), "must be an integer in 1..3"),
    (lambda: R.choice(T, "a", "c", ("x", "y")), "f.toml: [a] c = 'q': pick one of ['x', 'y']"),
    (lambda: R.string(T, "a", "s"), "f.toml: [a] s = '': must be a non-empty string"),
    (lambda: R.strings(T, "a", "names"),
     "[a] names = []: must be a non-empty list of group names"),
    (lambda: R.vector(T, "a", "v", "m/s"),
     "[a] v = [0.0, 1.0]: must be a list of three numbers m/s"),
    (lambda: R.boolean(T, "a", "flag"), "f.toml: [a] flag = 1: must be true or false"),
    (lambda: R.table(T, "", "tab"), "f.toml: tab = 3: must be a table, e.g. [tab]"),
    (lambda: R.array(T, "", "arr"),
     "f.toml: arr = {'a': 1}: must be an array of tables, e.g. [[arr]]"),
    (lambda: R.array(T, "", "none", required=True), "f.toml: at least one [[none]] is required"),
    (lambda: R.keys(T, "m[0]", {"nu", "E"}), "f.toml: unknown key(s) ['arr', 'c', 'flag', "),
    (lambda: R.keys({"nu": 1}, "", {"nu", "E"}, required={"E"}),
     "f.toml: missing key(s) ['E'] at the top level"),
    (lambda: R.keys([], "m[0]", {"nu"}), "f.toml: [m[0]] must be a table, got a list"),
]


@pytest.mark.parametrize(("get", "message"), GETTERS)
def test_getters_name_file_key_value_and_what_is_allowed(get, message):
    with pytest.raises(CaseError) as info:
        get()
    assert message in str(info.value)


def test_getters_convert_and_default():
    t = {"a": 2, "v": [1, 2, 3], "one": "x", "b": False}
    assert R.number(t, "", "a", low=0) == 2.0 and isinstance(R.number(t, "", "a"), float)
    assert R.number(t, "", "z", default=1.5) == 1.5
    assert R.number({"z": None}, "", "z", null=True) is None
    assert R.integer(t, "", "a", low=1, high=2) == 2
    assert R.vector(t, "", "v", "m") == (1.0, 2.0, 3.0)
    assert R.strings(t, "", "one") == ["x"]
    assert R.boolean(t, "", "b") is False
    json_reader = Reader("c.json", CalibrationError, "json")
    with pytest.raises(CalibrationError, match=r"c\.json: x = 3: must be an object$"):
        json_reader.table({"x": 3}, "", "x")


@pytest.mark.parametrize(("check", "message"), [
    (lambda: check_number("pinion.module", -0.003, low=0.0, low_open=True, unit="mm",
                          scale=1e3), "pinion.module = -3 mm: must be > 0 mm"),
    (lambda: check_number("crowning", 0.01, low=0, high=3e-4, unit="um", scale=1e6),
     "crowning = 10000 um: must be in [0, 300] um"),
    (lambda: check_number("x", "3", low=0, low_open=True, unit="mm", scale=1e3),
     "x = '3': must be a number > 0 mm"),
    (lambda: check_number("nu", float("nan"), low=-1, high=0.5),
     "nu = nan: must be a number in [-1, 0.5]"),
    (lambda: check_integer("teeth", True, low=3), "teeth = True: must be an integer >= 3"),
    (lambda: check_choice("rule", "loose", ("a", "b")), "rule = 'loose': pick one of ['a', 'b']"),
])
def test_record_checks(check, message):
    with pytest.raises(FeImpactError) as info:
        check()
    assert str(info.value) == message


# -- the three readers reject a bad value naming the key ----------------------------------
def _case(tmp_path: Path) -> Path:
    (tmp_path / "m.msh").write_text("")   # the reader checks the mesh file exists, not its content
    path = tmp_path / "c.toml"
    path.write_text('[mesh]\nfile = "m.msh"\n\n[[materials]]\nvolumes = ["a"]\n'
                    'youngs_modulus = 1e9\npoisson_ratio = 0.7\n')
    return path


def _gearset(tmp_path: Path) -> Path:
    path = tmp_path / "g.toml"
    path.write_text(SEED.read_text().replace("module_mm = 3.0", 'module_mm = "3"', 1))
    return path


def _calibration(tmp_path: Path) -> Path:
    path = tmp_path / "calibration.json"
    case = {"stage": 1, "kind": "mesh", "impact_speed": 0.1,
            "impact": {"k": 1e10, "exponent": 1.5, "cmax": "10", "d": 1e-6}}
    path.write_text(json.dumps({"schema": "fe-impact/calibration/1", "cases": [case]}))
    return path


READERS = [
    (lambda p: load_case(_case(p)), CaseError,
     r"c\.toml: \[materials\[0\]\] poisson_ratio = 0\.7: must be in \(-1\.0, 0\.5\)"),
    (lambda p: load_gearset(_gearset(p)), GeometryError,
     r"g\.toml: \[pinion\] module_mm = '3': must be a number"),
    (lambda p: load_calibration(_calibration(p), load_gearset(SEED)), CalibrationError,
     r"calibration\.json: \[cases\[0\]\.impact\] cmax = '10': must be a number >= 0"),
]


@pytest.mark.parametrize(("load", "error", "pattern"), READERS)
def test_each_reader_names_file_and_key_of_a_bad_value(tmp_path, load, error, pattern):
    with pytest.raises(error) as info:
        load(tmp_path)
    assert re.search(pattern, str(info.value)), str(info.value)


@pytest.mark.parametrize(("load", "error"), [
    (load_case, CaseError), (load_gearset, GeometryError),
    (lambda p: load_calibration(p, load_gearset(SEED)), CalibrationError),
])
def test_each_reader_reports_a_file_that_is_not_utf8(tmp_path, load, error):
    path = tmp_path / "x.json"
    path.write_bytes(b"\x80\x81")
    with pytest.raises(error, match=r"x\.json: not UTF-8 text"):
        load(path)
