"""`progress=`: the long calls report what they do, and stop on Ctrl-C or on
an exception the callable raises."""

import _thread
import signal
import threading

import numpy as np
import pytest

import hystid
from conftest import SMALL


def test_progress_sees_every_dwell_and_does_not_change_the_result():
    events = []
    t = hystid.virtual_test(SMALL, progress=events.append)
    plain = hystid.virtual_test(SMALL)
    steps = t["recording"]["excitation"]["steps"]
    dwells = [e for e in events if e["stage"] == "dwell"]
    # one event per dwell of the recording, every level's every frequency
    assert len(dwells) == len(steps) == 4 * 11
    assert sorted(e["frequency_hz"] for e in dwells) == sorted(s["frequency_hz"] for s in steps)
    assert sorted({e["level_index"] for e in dwells}) == [0, 1, 2, 3]
    assert t["frf"] == plain["frf"]


def test_a_fit_reports_every_evaluation_of_its_trace_numbered_alike():
    frf = hystid.virtual_test(SMALL)["frf"]
    events = []
    fit = hystid.identify(frf, progress=events.append)
    # one event per evaluation of the fit's trace, numbered as it is (its
    # stages on from each other)
    seen = sorted((e["evaluation"], e["cost"]) for e in events if e["stage"] == "fit")
    assert seen and seen == [(t["evaluation"], t["cost"]) for t in fit["trace"]]
    # the same fit (its wall time aside)
    plain = hystid.identify(frf)
    del fit["effort"]["seconds"], fit["effort"]["ms_per_evaluation"]
    del plain["effort"]["seconds"], plain["effort"]["ms_per_evaluation"]
    assert fit == plain


def test_a_model_written_down_reports_its_fit_numbered_on_across_its_stages():
    frf = hystid.virtual_test(SMALL)["frf"]
    start = hystid.model(SMALL)
    events = []
    fit = hystid.identify(frf, start=start, progress=events.append)
    # the simplex and the refit number their evaluations on from each
    # other: 1..N, each once
    numbers = [e["evaluation"] for e in events if e["stage"] == "fit"]
    assert numbers == list(range(1, len(numbers) + 1)) and len(numbers) > 10
    assert fit == hystid.identify(frf, start=start)
    calls, stop = stopping_at(5)
    with pytest.raises(Stop, match="enough"):
        hystid.identify(frf, start=start, progress=stop)
    assert len(calls) == 5


@pytest.fixture
def sigint():
    """Python's own SIGINT handler for the test: a shell starts a background
    job with SIGINT ignored, and Python then leaves it so (and an
    interrupt does nothing)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


class Stop(Exception):
    pass


def stopping_at(n):
    """A progress callable that records its events and raises `Stop` at the
    `n`-th; and the list it records them in."""
    calls = []

    def stop(event):
        calls.append(event)
        if len(calls) == n:
            raise Stop("enough")

    return calls, stop


def test_an_exception_in_progress_stops_the_call_and_is_raised():
    calls, stop = stopping_at(3)
    with pytest.raises(Stop, match="enough"):
        hystid.virtual_test(SMALL, progress=stop)
    # never called again once it raised
    assert len(calls) == 3


def test_ctrl_c_stops_a_diagnosis_inside_its_first_round(sigint):
    frf = hystid.virtual_test(SMALL)["frf"]
    fit = hystid.identify(frf)
    # the interrupt arrives while the library works (the full diagnosis of
    # this test takes seconds); with the GIL released and no signal checks
    # it would surface only after the call
    events = []
    timer = threading.Timer(0.3, _thread.interrupt_main)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            hystid.diagnose(frf, fit, candidates=["all"], progress=events.append)
    finally:
        timer.cancel()
    rounds = [e for e in events if e.get("event") == "round"]
    # stopped inside the first round: its candidates were not all refitted
    assert len(rounds) <= 1, rounds
    if rounds:
        done = [e for e in events if e.get("event") == "candidate"]
        assert len(done) < rounds[0]["candidates"], (len(done), rounds[0])


def test_ctrl_c_stops_a_virtual_test_without_a_progress_callable(sigint):
    big = SMALL.read_text().replace("count = 11", "count = 400")
    timer = threading.Timer(0.3, _thread.interrupt_main)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            hystid.virtual_test(big)
    finally:
        timer.cancel()


def progress_of(events):
    return [(e["task"], e["done"], e["total"]) for e in events if e["stage"] == "progress"]


def test_a_simulation_reports_its_samples_and_stops_when_asked():
    # a million samples: four stretches of 2^18, the last one short
    n = 1_000_000
    force = 100.0 * np.sin(2 * np.pi * 80.0 * np.arange(n) / 20_000.0)
    m = hystid.model(SMALL)
    events = []
    y = hystid.simulate(m, force, 20_000.0, progress=events.append)
    stretch = 1 << 18
    expected = [("simulating", min(k * stretch, n), n) for k in range(1, 5)]
    assert progress_of(events) == expected
    # the same bits as one stretch (the simulator carries its state across)
    assert np.array_equal(y, hystid.simulate(m, force, 20_000.0))
    every = []
    all_outputs = hystid.simulate(m, force, 20_000.0, output="all", progress=every.append)
    assert progress_of(every) == expected
    assert np.array_equal(all_outputs["displacement"], y)
    calls, stop = stopping_at(2)
    with pytest.raises(Stop, match="enough"):
        hystid.simulate(m, force, 20_000.0, progress=stop)
    assert len(calls) == 2
    # a short one runs on the calling thread (no worker to start): one event,
    # and the callable's exception is raised all the same
    short = []
    assert np.array_equal(hystid.simulate(m, force[:1000], 20_000.0, progress=short.append), y[:1000])
    assert progress_of(short) == [("simulating", 1000, 1000)]
    calls, stop = stopping_at(1)
    with pytest.raises(Stop, match="enough"):
        hystid.simulate(m, force[:1000], 20_000.0, output="all", progress=stop)


def test_a_reduction_and_a_validation_report_their_dwells_and_stages():
    t = hystid.virtual_test(SMALL)
    s, meta = t["signals"], t["recording"]
    fs, steps = meta["sample_rate_hz"], meta["excitation"]["steps"]
    events = []
    frf = hystid.extract(s["force"], s["displacement"], fs, steps=steps, progress=events.append)
    # one event per dwell, in order
    n = len(steps)
    assert progress_of(events) == [("reducing", k, n) for k in range(1, n + 1)]
    assert frf == hystid.extract(s["force"], s["displacement"], fs, steps=steps)
    fit = hystid.identify(frf)
    seen = []
    val = hystid.validate(fit, s["force"], s["displacement"], fs, steps=steps, progress=seen.append)
    p = progress_of(seen)
    simulating = [e for e in p if e[0] == "simulating"]
    # the measured response reduced, then the replay to its last sample
    # (upsampled or not), reduced as it is made, then the comparison done
    assert simulating and simulating[-1][1] == simulating[-1][2] >= len(s["force"])
    task = "reducing the measured and simulated responses"
    assert p == [(task, 0, 2), (task, 1, 2)] + simulating + [(task, 2, 2)]
    plain = hystid.validate(fit, s["force"], s["displacement"], fs, steps=steps)
    assert np.array_equal(val["recordings"][0].pop("simulated"), plain["recordings"][0].pop("simulated"))
    assert val == plain
