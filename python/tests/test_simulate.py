"""`simulate` against a closed form, the model's input forms, the released
GIL, and byte-identical results for the same seed."""

import json
import threading
import time

import numpy as np
import pytest

import hystid

from conftest import SMALL

M, C, K = 10.0, 200.0, 1.0e7  # the paper's SDOF: 159.15 Hz, 1 % damping


def receptance(f):
    w = 2 * np.pi * f
    return 1.0 / (K - M * w**2 + 1j * C * w)


@pytest.mark.parametrize("fs,p", [(10000.0, 50), (10000.0, 37), (51200.0, 256)])
def test_linear_sdof_steady_state_is_the_closed_form(fs, p):
    """A cosine of p samples per period drives the linear SDOF from rest
    for 5 s; the fundamental of the last 200 periods is the ramp-invariant
    filter's exact steady state, the alias sum of the receptance weighted by
    sinc^2 (the filter interpolates the force linearly between samples):
    sum_k H(f + k fs) sinc^2(f/fs + k).

    Tolerance 1e-9: the transient has decayed to exp(-zeta w_n 4 s) =
    exp(-40) = 4e-18 of its start and the rest is the round-off of 50 000
    recursions (measured 7e-15 to 2.4e-13). Against the continuous receptance
    alone the error is the sinc^2 of linear interpolation, (pi f/fs)^2/3 to
    first order (1.3e-3 at 50 samples per period)."""
    f = fs / p
    n = int(5 * fs) // p * p
    i = np.arange(n)
    force = 100.0 * np.cos(2 * np.pi * (i % p) / p)
    x = hystid.simulate({"system": {"mass": M, "damping": C, "stiffness": K}}, force, fs)
    tail = slice(n - 200 * p, n)
    X = 2.0 / (200 * p) * np.sum(x[tail] * np.exp(-2j * np.pi * (i[tail] % p) / p))
    k = np.arange(-4000, 4001)
    fk = f + k * fs
    exact = 100.0 * np.sum(receptance(fk) * np.sinc(fk / fs) ** 2)
    assert abs(X / exact - 1) < 1e-9
    plain = abs(X / (100.0 * receptance(f)) - 1)
    assert plain == pytest.approx((np.pi * f / fs) ** 2 / 3, rel=0.02)


def test_all_outputs_agree_with_single_outputs():
    m = hystid.model(SMALL)
    fs = 50000.0
    force = 300.0 * np.sin(2 * np.pi * 150.0 * np.arange(20000) / fs)
    every = hystid.simulate(m, force, fs, output="all")
    assert set(every) == {"displacement", "velocity", "acceleration", "element_force"}
    for name, y in every.items():
        assert np.array_equal(y, hystid.simulate(m, force, fs, output=name)), name
    # a Jenkins joint's force is bounded by its slip force Fd = 246.048 N
    assert np.max(np.abs(every["element_force"])) <= 246.048 * (1 + 1e-12)
    # a non-contiguous or integer force is converted, not refused
    assert np.array_equal(
        hystid.simulate(m, np.repeat(force, 2)[::2], fs), every["displacement"]
    )


def test_a_model_from_any_form_is_the_same_model(tmp_path):
    from_toml = hystid.model(SMALL.read_text())
    (tmp_path / "m.toml").write_text(SMALL.read_text())
    as_dict = {
        "system": {"mass": 10.0, "damping": 200.0, "stiffness": 1e7},
        "joint": {"kind": "jenkins", "kd": 2.4e7, "fd": 246.048},
    }
    forms = [
        hystid.model(SMALL),
        hystid.model(tmp_path / "m.toml"),
        hystid.model(as_dict),
        hystid.model(json.dumps(as_dict)),
        hystid.model(json.loads(from_toml.to_json())),  # fit.json's `model`
        hystid.model(from_toml.to_json()),
        hystid.Model.from_toml("[system]\nmass = 10\ndamping = 200\nstiffness = 1e7\n"
                               "[joint]\nkind = 'jenkins'\nkd = 2.4e7\nfd = 246.048\n"),
    ]
    for m in forms:
        assert m == from_toml
    assert from_toml.highest_linearised_frequency_hz == pytest.approx(
        np.sqrt((K + 2.4e7) / M) / (2 * np.pi), rel=1e-12
    )


def test_the_gil_is_released_while_simulating():
    """Python code runs in another thread while `simulate` works: the main
    thread's timestamps fall inside the middle half of the call (with the
    GIL held none could)."""
    m = hystid.model(SMALL)
    fs = 100000.0
    force = 500.0 * np.sin(2 * np.pi * 150.0 * np.arange(4_000_000) / fs)
    span = {}

    def work():
        span["start"] = time.perf_counter()
        hystid.simulate(m, force, fs)
        span["end"] = time.perf_counter()

    th = threading.Thread(target=work)
    stamps = []
    th.start()
    while th.is_alive():
        stamps.append(time.perf_counter())
        time.sleep(0.001)
    th.join()
    a, b = span["start"], span["end"]
    q = (b - a) / 4
    inside = [t for t in stamps if a + q < t < b - q]
    assert len(inside) > 0, (b - a, len(stamps))


def test_the_same_seed_gives_byte_identical_results():
    a = hystid.virtual_test(SMALL)
    b = hystid.virtual_test(SMALL)
    for name in a["signals"]:
        assert a["signals"][name].tobytes() == b["signals"][name].tobytes()
    assert a["frf"] == b["frf"] and a["recording"] == b["recording"]
    fa = hystid.identify(a["frf"])
    fb = hystid.identify(b["frf"])
    fa["effort"].pop("seconds"), fb["effort"].pop("seconds")
    fa["effort"].pop("ms_per_evaluation"), fb["effort"].pop("ms_per_evaluation")
    assert json.dumps(fa) == json.dumps(fb)
    m = hystid.model(SMALL)
    force = 300.0 * np.sin(np.arange(10000) * 0.02)
    assert hystid.simulate(m, force, 5e4).tobytes() == hystid.simulate(m, force, 5e4).tobytes()
    # another seed, other noise
    other = hystid.virtual_test(SMALL.read_text().replace("seed = 3", "seed = 4"))
    assert other["signals"]["force"].tobytes() == a["signals"]["force"].tobytes()  # no force noise
    assert other["signals"]["displacement"].tobytes() != a["signals"]["displacement"].tobytes()


def test_a_hysteretic_mode_that_never_slips_is_the_closed_form():
    """A mode with a joint of its own (a hysteretic mode), given as a dict
    like any model: beside the paper's SDOF, a 230 Hz mode held by a Jenkins
    joint that never slips (kd 4e7 N/m, slip force 1e12 N) on its own
    coordinate. The steady state is the closed form of the filters: the
    SDOF's s^2 H plus the mode's s^2 H_r / (1 + kd s^2 H_r), with s^2 =
    sinc^2(f/fs) (the joint's force is fed back sample by sample, so the
    filter's sinc^2 acts inside the loop); a transfer mode (negative modal
    mass) turns its part over. Tolerance 1e-7: the aliases left out
    (measured 2e-9 in the Rust test of the same closed form)."""
    fs, p, kd = 51200.0, 256, 4.0e7
    f = fs / p
    w = 2 * np.pi * f
    s2 = np.sinc(f / fs) ** 2
    for sign in (1.0, -1.0):
        mass = sign * 50.0
        wr, zeta = 2 * np.pi * 230.0, 0.02
        definition = {
            "modes": [
                {"frequency_hz": np.sqrt(K / M) / (2 * np.pi), "damping_ratio": C / (2 * np.sqrt(K * M)), "modal_mass": M},
                {
                    "frequency_hz": 230.0,
                    "damping_ratio": zeta,
                    "modal_mass": mass,
                    "joint": {"kind": "jenkins", "kd": kd, "fd": 1e12},
                },
            ]
        }
        n = int(3 * fs) // p * p + 4 * p
        i = np.arange(n)
        x = hystid.simulate(definition, np.cos(2 * np.pi * (i % p) / p), fs)
        last = x[-4 * p :]
        got = 2 * np.mean(last * np.exp(-2j * np.pi * (np.arange(4 * p) % p) / p))
        hr = s2 / abs(mass) / (wr**2 - w**2 + 2j * zeta * wr * w)
        expected = s2 * receptance(f) + sign * hr / (1 + kd * hr)
        assert abs(got / expected - 1) < 1e-7, (sign, got, expected)


def test_a_simulation_fed_in_blocks_is_the_whole_run():
    """`Simulation` carries the structure's and the joint's state from one
    block to the next: blocks of 1000, 1, 300 000 (two progress stretches
    of 262 144 samples and a part) and the rest give, joined, the bits of one
    `simulate` of the whole, for each output and for "all"; `reset` is rest
    again. The paper's Jenkins joint, slipping under 300 N: a state lost at a
    block's edge would move the slider and show at once."""
    m = hystid.model(SMALL)
    fs = 50000.0
    n = 700_000
    t = np.arange(n) / fs
    force = 300.0 * np.sin(2 * np.pi * 150.0 * t) + 80.0 * np.sin(2 * np.pi * 410.0 * t)
    edges = [0, 1000, 1001, 301_001, n]
    for output in ("displacement", "element_force"):
        whole = hystid.simulate(m, force, fs, output=output)
        sim = hystid.Simulation(m, fs)
        parts = [sim.run(force[a:b], output=output) for a, b in zip(edges, edges[1:])]
        assert sim.samples == n
        assert np.array_equal(np.concatenate(parts), whole), output
        sim.reset()
        assert sim.samples == 0
        assert np.array_equal(sim.run(force[:1000], output=output), whole[:1000])
    every = hystid.simulate(m, force, fs, output="all")
    sim = hystid.Simulation(m, fs)
    blocks = [sim.run(force[a:b], output="all") for a, b in zip(edges, edges[1:])]
    for name, y in every.items():
        assert np.array_equal(np.concatenate([b[name] for b in blocks]), y), name


def test_a_simulation_stopped_inside_a_block_must_be_reset():
    """A block stopped part-way (here the progress callable's exception at
    its second stretch) leaves the state inside that block: the next `run`
    raises, naming `reset`, and after `reset` the simulation is the whole
    run again."""
    m = hystid.model(SMALL)
    fs = 50000.0
    force = 300.0 * np.sin(2 * np.pi * 150.0 * np.arange(600_000) / fs)
    sim = hystid.Simulation(m, fs)
    first = sim.run(force[:5000])

    def stop(event):
        if event["done"] > 262_144:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sim.run(force[5000:], progress=stop)
    with pytest.raises(hystid.HystidError, match="reset"):
        sim.run(force[:10])
    sim.reset()
    assert np.array_equal(sim.run(force[:5000]), first)
    assert "50000.0 Hz" in repr(sim)
