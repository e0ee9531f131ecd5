"""Bad options get one line naming the option, the value and what is allowed
(exit status 2), before any work starts and with nothing written."""

import pytest

from fe_impact.cli import main


@pytest.mark.parametrize("argv,words", [
    # An empty list used to mean "all stages".
    (["--stages", ","], ["--stages", "need at least one integer"]),
    (["--speeds", ","], ["--speeds", "need at least one number"]),
    # Refused before the Dask cluster starts (it used to fail on a worker).
    (["--speeds", "1e9"], ["--speeds 1e+09", "allowed impact speeds are (0, 20] m/s"]),
    (["--impact-speeds", "25"], ["--impact-speeds 25", "(0, 20] m/s"]),
    (["--scheduler", "not an address"], ["--scheduler 'not an address'",
                                         "give host:port or tcp://host:port"]),
])
def test_calibrate_rejects_before_work(tmp_path, capsys, argv, words):
    assert main(["calibrate", "--out", str(tmp_path / "o"), "--cache", str(tmp_path / "c"),
                 *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("fe-impact: error:") or err.startswith("usage:"), err
    assert "Traceback" not in err
    for w in words:
        assert w in err, (w, err)
    assert not (tmp_path / "o").exists() and not (tmp_path / "c").exists()
