"""validation/compare_calibrations.py: relative changes per case, the verdict."""

import json

from validation import compare_calibrations as cmp


def _doc(scale=1.0, ids=("a", "b")):
    fe = {k: 2.0 for k in cmp.FE_KEYS}
    law = {k: 3.0 for k in cmp.LAW_KEYS}
    return {"cases": [{"id": i, "fe": dict(fe, peak_force=2.0 * scale), "impact": law}
                      for i in ids]}


def _run(tmp_path, old, new, *extra):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps(old))
    b.write_text(json.dumps(new))
    return cmp.main([str(a), str(b), *extra])


def test_relative_change_is_measured_per_quantity():
    rows, missing = cmp.changes(_doc(), _doc(1.002))
    assert missing == []
    assert abs(rows["a"]["fe.peak_force"] - 0.002) < 1e-12
    assert rows["a"]["impact.k"] == 0.0


def test_verdict(tmp_path, capsys):
    assert _run(tmp_path, _doc(), _doc()) == 0
    assert _run(tmp_path, _doc(), _doc(1.002)) == 1            # 2e-3 > 1e-3
    assert _run(tmp_path, _doc(), _doc(1.002), "--tolerance", "0.01") == 0
    assert _run(tmp_path, _doc(), _doc(ids=("a",))) == 1        # a case lost
    assert "[FAIL] b: missing" in capsys.readouterr().out


def test_a_quantity_that_becomes_nan_or_goes_missing_fails(tmp_path):
    # max(0.0, nan) is 0.0: a NaN used to read as no change, and a quantity None
    # on one side only was skipped. Both are failures; None on both sides is not.
    lost = _doc()
    lost["cases"][0]["fe"]["restitution"] = None
    assert _run(tmp_path, _doc(), lost) == 1
    nan = _doc()
    nan["cases"][0]["fe"]["peak_force"] = float("nan")
    assert _run(tmp_path, _doc(), nan) == 1
    assert _run(tmp_path, lost, lost) == 0
