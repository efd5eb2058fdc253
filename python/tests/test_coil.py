"""The shaker's coil from Python: `hystid.fit_coil` gives a coil written
from its own equations back, and the coil `hystid identify` reports for a
virtual test with a force gauge."""

import json

import numpy as np
import pytest

import hystid

from conftest import SMALL, run_cli


def coil_dwells(frequencies, r=2.0, l=3e-4, bl=15.0, fs=20_000.0, n=2000):
    """Dwells written from the coil's equations, independently of hystid: a
    force F on a structure of mobility Y moves it at v = Y F, and the voltage
    is e = F (R + j w L)/Bl + Bl v."""
    m, c, k = 2.0, 30.0, 4e6
    e_all, f_all, v_all, x_all, steps = [], [], [], [], []
    t = np.arange(n) / fs
    for f in frequencies:
        w = 2 * np.pi * f
        force = 40.0 + 0j
        v = force * 1j * w / (k - m * w * w + 1j * w * c)
        e = force * (r + 1j * w * l) / bl + bl * v
        rot = np.exp(1j * w * t)
        steps.append({"frequency_hz": f, "level": abs(e), "start": len(e_all) * n,
                      "settle": 0, "length": n})
        e_all.append((e * rot).real)
        f_all.append((force * rot).real)
        v_all.append((v * rot).real)
        x_all.append((v / (1j * w) * rot).real)
    cat = np.concatenate
    return cat(e_all), cat(f_all), cat(v_all), cat(x_all), steps


def test_a_coil_written_from_its_equations_comes_back():
    e, f, v, x, steps = coil_dwells([150.0, 250.0, 400.0, 700.0])
    coil = hystid.fit_coil(e, f, v, 20_000.0, steps=steps)
    assert coil["r"] == pytest.approx(2.0, rel=1e-9)
    assert coil["l"] == pytest.approx(3e-4, rel=1e-9)
    assert coil["bl"] == pytest.approx(15.0, rel=1e-9)
    assert coil["gain"] == pytest.approx(7.5, rel=1e-9)
    assert coil["dwells"] == 4
    # the displacement instead of the velocity
    coil_x = hystid.fit_coil(e, f, x, 20_000.0, steps=steps, motion_quantity="displacement")
    assert coil_x["bl"] == pytest.approx(15.0, rel=1e-9)
    with pytest.raises(hystid.HystidError, match="steps"):
        hystid.fit_coil(e, f, v, 20_000.0, steps=[])
    with pytest.raises(hystid.HystidError, match="motion_quantity"):
        hystid.fit_coil(e, f, v, 20_000.0, steps=steps, motion_quantity="force")
    with pytest.raises(hystid.HystidError, match="sampled together"):
        hystid.fit_coil(e[:-1], f, v, 20_000.0, steps=steps)


GAUGE_TEST = SMALL.read_text().replace(
    "[test]",
    '[[effects]]\nkind = "shaker"\nr = 1.0\nl = 5e-4\nbl = 20.0\n\n[test]',
).replace("levels_n = [5.0, 300.0, 1000.0, 30000.0]", "levels_n = [0.25, 15.0, 50.0]") + (
    "force_noise = 0.02\nforce_gauge = true\n"
)


def test_the_coil_is_the_one_hystid_identify_reports(tmp_path):
    (tmp_path / "gauge.toml").write_text(GAUGE_TEST)
    run_cli("simulate", "gauge.toml", "--out", "sim", cwd=tmp_path)
    run_cli("identify", "sim/recording.json", "--out", "fit", cwd=tmp_path)
    cli = json.loads((tmp_path / "fit" / "fit.json").read_text())["coil"]
    t = hystid.virtual_test(tmp_path / "gauge.toml")
    s, meta = t["signals"], t["recording"]
    coil = hystid.fit_coil(
        s["drive"], s["force"], s["velocity"], meta["sample_rate_hz"],
        steps=meta["excitation"]["steps"],
    )
    assert {k: v for k, v in coil.items() if k != "channels"} == {
        k: v for k, v in cli.items() if k != "channels"
    }
    assert coil["bl"] == pytest.approx(20.0, rel=0.01)
