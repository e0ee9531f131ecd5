"""Result files are standard JSON and appear atomically."""

import json

import numpy as np
import pytest

from fe_impact.output.files import atomic_path, write_json


def strict_load(text: str):
    """Parse as a strict reader (JavaScript's JSON.parse) does: no NaN or Infinity."""
    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")
    return json.loads(text, parse_constant=refuse)


def test_non_finite_values_are_written_as_null(tmp_path):
    data = {"relative_difference": float("inf"), "nan": np.nan, "neg": -np.inf,
            "array": np.array([1.0, np.nan]), "f32": np.float32(2.5), "i": np.int64(3),
            "flag": np.bool_(True), "nested": [{"x": (np.float64("nan"), 1)}]}
    path = write_json(tmp_path / "r.json", data)
    doc = strict_load(path.read_text())
    assert doc == {"relative_difference": None, "nan": None, "neg": None,
                   "array": [1.0, None], "f32": 2.5, "i": 3, "flag": True,
                   "nested": [{"x": [None, 1]}]}


def test_unserialisable_value_leaves_no_file(tmp_path):
    with pytest.raises(TypeError):
        write_json(tmp_path / "r.json", {"x": object()})
    assert list(tmp_path.iterdir()) == []


def test_atomic_path_removes_the_temporary_file_on_error(tmp_path):
    with pytest.raises(RuntimeError), atomic_path(tmp_path / "a.txt") as tmp:
        tmp.write_text("half")
        raise RuntimeError("interrupted")
    assert list(tmp_path.iterdir()) == []


def test_array_csv_keeps_ten_significant_digits_and_reads_back(tmp_path):
    """A numeric table read back with the csv module equals the array to 10
    significant digits (relative 5e-10, the rounding of the last digit), with its
    header, non-finite values and an empty table."""
    import csv

    from fe_impact.atomic import ARRAY_DIGITS
    from fe_impact.output.files import write_array_csv

    rng = np.random.default_rng(1)
    data = rng.standard_normal((50, 3)) * np.array([1e-9, 1.0, 1e6])
    data[3] = [np.nan, np.inf, -np.inf]
    path = write_array_csv(tmp_path / "t.csv", ["a", "b [m]", "c"], data)
    rows = list(csv.reader(path.read_text().splitlines()))
    assert rows[0] == ["a", "b [m]", "c"]
    back = np.array(rows[1:], dtype=float)
    assert back.shape == data.shape
    finite = np.isfinite(data)
    assert np.array_equal(np.isnan(back), np.isnan(data))
    assert np.array_equal(back[~finite & ~np.isnan(data)], data[~finite & ~np.isnan(data)])
    assert np.allclose(back[finite], data[finite], rtol=0.5 * 10.0 ** (1 - ARRAY_DIGITS),
                       atol=0.0)
    empty = write_array_csv(tmp_path / "e.csv", ["a", "b"], np.zeros((0, 2)))
    assert empty.read_text().splitlines() == ["a,b"]


def test_a_rerun_into_the_same_folder_leaves_none_of_the_earlier_files(tmp_path):
    # An earlier run wrote more frames (or other cases) than this one: they go, the
    # files this run keeps and every other file of the folder stay.
    from fe_impact.output.files import remove_stale

    for name in ("frame_0000.vtu", "frame_0001.vtu", "frame_0002.vtu", "impact.pvd",
                 "notes.txt"):
        (tmp_path / name).write_text("x")
    gone = remove_stale(tmp_path, "frame_*.vtu", ["frame_0000.vtu"])
    assert sorted(p.name for p in gone) == ["frame_0001.vtu", "frame_0002.vtu"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["frame_0000.vtu", "impact.pvd",
                                                           "notes.txt"]


@pytest.mark.parametrize("where", ["setup", "body"])
def test_a_stop_while_a_file_is_written_leaves_no_temporary_file(tmp_path, monkeypatch, where):
    # Ctrl-C arriving while atomic_path sets its temporary file up (between mkstemp and
    # taking charge of it) or writes it: the stop comes through, the target is not
    # written and no temporary file is left. The signal is sent to this process, as the
    # terminal sends it; in the set-up it is held back until the file is in charge.
    import os
    import signal

    import fe_impact.atomic as atomic

    target = tmp_path / "frame.vtu"
    if where == "setup":
        chmod = os.chmod

        def signalled_chmod(*args, **kwargs):
            chmod(*args, **kwargs)
            os.kill(os.getpid(), signal.SIGINT)

        monkeypatch.setattr(atomic.os, "chmod", signalled_chmod)
    # Python's own Ctrl-C handler, whatever an earlier test in this process left
    # (a worker started with SIGINT ignored, fe_impact.interrupts.ignore_signals)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            with atomic.atomic_path(target) as tmp:
                tmp.write_text("half")
                if where == "body":
                    os.kill(os.getpid(), signal.SIGINT)
                    for _ in range(10**6):   # the handler runs at the next bytecode
                        pass
                tmp.write_text("whole")
    finally:
        signal.signal(signal.SIGINT, previous)
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []
