"""Errors come as `hystid.HystidError` (a ValueError) with the library's
message, the one the command line prints."""

from pathlib import Path

import numpy as np
import pytest

import hystid

from conftest import SMALL, run_cli

BAD_MASS = SMALL.read_text().replace("mass = 10.0", "mass = -10.0")


def test_a_bad_definition_gives_the_command_lines_message(tmp_path, monkeypatch):
    (tmp_path / "bad.toml").write_text(BAD_MASS)
    code, stderr = run_cli("simulate", "bad.toml", "--out", "o", cwd=tmp_path, expect=2)
    cli_message = stderr.strip().removeprefix("error: ")
    # the file named as it was given, here from the same folder
    monkeypatch.chdir(tmp_path)
    with pytest.raises(hystid.HystidError) as e:
        hystid.virtual_test(Path("bad.toml"))
    assert str(e.value) == cli_message
    assert str(e.value) == "bad.toml: `system.mass`: must be a finite number > 0, got -10"
    assert isinstance(e.value, ValueError)
    # the model alone says the same
    with pytest.raises(hystid.HystidError, match=r"`system\.mass`: must be a finite number > 0"):
        hystid.model(BAD_MASS)


def test_unknown_keys_and_options_are_named():
    with pytest.raises(hystid.HystidError, match="stiffnes"):
        hystid.model({"system": {"mass": 1.0, "damping": 1.0, "stiffnes": 1.0}})
    frf = {"response": "displacement", "reference": "force", "max_harmonic": 1, "levels": []}
    with pytest.raises(hystid.HystidError, match="unknown option `weighted`"):
        hystid.identify(frf, weighted=True)
    with pytest.raises(hystid.HystidError, match="`element`: expected a joint law"):
        hystid.identify(frf, element="cubic_stiffness")
    with pytest.raises(hystid.HystidError, match="unknown effect `friction`"):
        hystid.diagnose(frf, candidates=["friction"])


def test_bad_signals_are_named():
    m = hystid.model(SMALL)
    with pytest.raises(hystid.HystidError, match="must exceed twice the highest mode"):
        hystid.simulate(m, np.ones(10), 100.0)
    with pytest.raises(hystid.HystidError, match="output: expected one of"):
        hystid.simulate(m, np.ones(10), 1e5, output="strain")
    with pytest.raises(hystid.HystidError, match="expected a 1-D array"):
        hystid.simulate(m, np.ones((2, 5)), 1e5)
    f = np.sin(np.arange(1000) * 0.1)
    with pytest.raises(hystid.HystidError, match="same, non-zero length"):
        hystid.extract(f, f[:-1], 1e4)
    with pytest.raises(hystid.HystidError, match=r"response\[3\]"):
        y = f.copy()
        y[3] = np.nan
        hystid.extract(f, y, 1e4)
    with pytest.raises(hystid.HystidError, match="flat"):
        hystid.extract(np.zeros(100), f[:100], 1e4)


def test_identify_points_names_a_joint_at_an_unknown_sensor(tmp_path):
    # refused before any recording is read or any folder made
    with pytest.raises(hystid.HystidError, match=r"joint.*`a4` is not one of the responses \(a1, a2, a3\)"):
        hystid.identify_points(tmp_path / "r.json", tmp_path / "out", "a1,a2,a3", joint="a2:a4")
    assert not (tmp_path / "out").exists()
    with pytest.raises(hystid.HystidError, match="two response channels or more"):
        hystid.identify_points(tmp_path / "r.json", tmp_path / "out", ["a1"])
