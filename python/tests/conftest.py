"""Shared fixtures: the `hystid` binary and its outputs on the small test."""

import json
import os
import pathlib
import subprocess

import pytest

HERE = pathlib.Path(__file__).resolve().parent
REPO = HERE.parent.parent
SMALL = HERE / "small.toml"


def hystid_bin():
    """The command-line tool: `HYSTID_BIN`, else the root crate's release
    build (in `CARGO_TARGET_DIR` or `target/`)."""
    given = os.environ.get("HYSTID_BIN")
    if given:
        if not os.access(given, os.X_OK):
            pytest.fail(f"HYSTID_BIN={given} is not an executable")
        return given
    dirs = [os.environ.get("CARGO_TARGET_DIR"), REPO / "target"]
    for d in dirs:
        if d:
            p = pathlib.Path(d) / "release" / "hystid"
            if p.is_file():
                return str(p)
    pytest.skip("no hystid binary: build it (cargo build --release) or set HYSTID_BIN")


def run_cli(*args, cwd, expect=0):
    """Runs the tool quietly in `cwd`; returns (exit code, stderr)."""
    r = subprocess.run(
        [hystid_bin(), *map(str, args), "--quiet"],
        cwd=cwd,
        capture_output=True,
        text=True,
    )
    if expect is not None:
        assert r.returncode == expect, f"hystid {args}: exit {r.returncode}\n{r.stderr}"
    return r.returncode, r.stderr


@pytest.fixture(scope="session")
def cli(tmp_path_factory):
    """The command line on the small test: simulate, identify, validate and
    diagnose, their JSON outputs read back."""
    d = tmp_path_factory.mktemp("cli")
    (d / "small.toml").write_text(SMALL.read_text())
    run_cli("simulate", "small.toml", "--out", "sim", cwd=d)
    run_cli("identify", "sim/recording.json", "--out", "fit", cwd=d)
    run_cli("validate", "fit/fit.json", "sim/recording.json", "--out", "val", cwd=d)
    run_cli("diagnose", "sim/recording.json", "--out", "diag", cwd=d)
    load = lambda p: json.loads((d / p).read_text())
    return {
        "dir": d,
        "summary": load("sim/summary.json"),
        "frf": load("sim/frf.json"),
        "recording": load("sim/recording.json"),
        "fit": load("fit/fit.json"),
        "validate": load("val/validate.json"),
        "diagnosis": load("diag/diagnosis.json"),
    }
