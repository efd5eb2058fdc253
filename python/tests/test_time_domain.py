"""The time-domain fit through the package equals `hystid identify --domain
time`: refining the small test's FRF fit, and a multisine fitted from its
linear estimate (no start written down)."""

import json

import numpy as np
import pytest

import hystid

from conftest import SMALL, run_cli
from test_cli_parity import read_wav_f32, without


def same_fit(py, cli):
    """Equal but for wall times and the response's name (the command's is
    the recording's channel, the package's arrays name none)."""
    strip = lambda d: without(d, "effort", "files", "response")
    assert strip(py) == strip(cli)
    if "effort" in cli:
        assert without(py["effort"], "seconds", "ms_per_evaluation") == without(
            cli["effort"], "seconds", "ms_per_evaluation"
        )


def small_record(cli):
    """The small test's recording as a time-domain call takes it, named as
    the command names it, and its FRFs reduced as the command reduces it."""
    samples = read_wav_f32(cli["dir"] / "sim" / "recording.wav").astype(np.float64)
    meta = cli["recording"]
    fs, steps = meta["sample_rate_hz"], meta["excitation"]["steps"]
    record = {
        "force": samples[:, 0],
        "response": samples[:, 1],
        "sample_rate_hz": fs,
        "steps": steps,
        "name": "sim/recording.json",
    }
    return record, hystid.extract(samples[:, 0], samples[:, 1], fs, steps=steps)


def test_refining_an_frf_fit_is_identify_domain_time(cli):
    d = cli["dir"]
    run_cli("identify", "sim/recording.json", "--out", "fit_time", "--domain", "time", cwd=d)
    ref = json.loads((d / "fit_time" / "fit.json").read_text())
    record, frf = small_record(cli)
    fit = hystid.identify(
        frf, recording="sim/recording.json", reference=SMALL,
        domain="time", recordings=[record],
    )
    assert fit["time_domain"]["status"] == "converged"
    same_fit(fit, ref)


def test_an_frf_fits_refinement_takes_the_replay_and_the_starts(cli):
    """`fit=` refined with `replay` and `starts` is `identify --domain time
    --replay continuous --starts 2` (they were ignored: the default replay
    from one start)."""
    d = cli["dir"]
    run_cli("identify", "sim/recording.json", "--out", "fit_time_c2", "--domain", "time",
            "--replay", "continuous", "--starts", "2", cwd=d)
    ref = json.loads((d / "fit_time_c2" / "fit.json").read_text())
    record, _ = small_record(cli)
    fit = json.loads((d / "fit" / "fit.json").read_text())
    refined = hystid.identify_time([record], fit=fit, replay="continuous", starts=2)
    notes = " ".join(refined["time_domain"]["notes"])
    assert "--replay continuous" in notes and "descended from 2 starts" in notes
    assert len(refined["time_domain"]["starts"]) == 2
    assert refined["time_domain"] == ref["time_domain"]


def test_a_diagnosis_refined_in_time_is_diagnose_domain_time(cli):
    """`diagnose(frf, recordings=[...])` is `diagnose --domain time` on the
    small test's stepped sine: the FRF diagnosis, its final model refitted
    on the time histories, each kept effect confirmed there and the time
    residual read in the FRFs' plane, to the bit but for the wall time."""
    d = cli["dir"]
    run_cli("diagnose", "sim/recording.json", "--out", "diag_time", "--domain", "time", cwd=d)
    ref = json.loads((d / "diag_time" / "diagnosis.json").read_text())
    record, frf = small_record(cli)
    with pytest.raises(hystid.HystidError, match=r"starts: the time-domain fit descends from several starts; give the time histories as recordings=\[\.\.\.\]"):
        hystid.diagnose(frf, starts=2)
    with pytest.raises(hystid.HystidError, match="max_judged_samples: only the time-domain fit judges samples"):
        hystid.diagnose(frf, max_judged_samples=1000)
    diagnosis = hystid.diagnose(frf, recordings=[record])
    assert "refit" in diagnosis["time_domain"]
    assert without(diagnosis, "seconds") == without(ref, "seconds")


def test_a_multisine_is_fitted_from_its_linear_estimate(tmp_path):
    """A Jenkins SDOF driven by 4 periods of a multisine (lines 5-60 Hz of a
    1 s period at 2 kHz), written to CSV and imported: the command and the
    package give the same fit, and it finds the joint that made the data:
    kd, fd within 0.5 % (measured -0.1 %, +0.1 %: noise-free data stored
    as float32). The joint slips at 0.09 RMS of the response: a start that
    sticks throughout (the start before the grid of starts) ended at kd
    -82 %."""
    fs, period = 2000, 2000
    rng = np.random.default_rng(3)
    t = np.arange(period) / fs
    one = sum(np.cos(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi)) for f in range(5, 61))
    force = 40.0 * np.tile(one, 4) / np.std(one)
    truth = hystid.model({
        "system": {"mass": 1.0, "damping": 20.0, "stiffness": 4.0e4},
        "joint": {"kind": "jenkins", "kd": 4.0e4, "fd": 8.0},
    })
    y = hystid.simulate(truth, force, fs)
    lines = ["# fs = 2000 Hz", "force,y"] + [f"{a:.17g},{b:.17g}" for a, b in zip(force, y)]
    (tmp_path / "m.csv").write_text("\n".join(lines) + "\n")
    run_cli("import", "m.csv", "--out", "m", "-c", "force:force", "-c", "y:displacement",
            "--excitation", "unknown", cwd=tmp_path)
    samples = read_wav_f32(tmp_path / "m.wav").astype(np.float64)
    record = [{"force": samples[:, 0], "response": samples[:, 1], "sample_rate_hz": fs, "name": "m.json"}]

    def as_the_command(out, flags, **kwargs):
        """The package's fit with ``kwargs``, the command's with ``flags``: the same."""
        run_cli("identify", "m.json", "--out", out, "--domain", "time", "--element", "jenkins",
                *flags, cwd=tmp_path, expect=None)
        ref = json.loads((tmp_path / out / "fit.json").read_text())
        fit = hystid.identify_time(record, element="jenkins", **kwargs)
        same_fit(fit, ref)
        return fit

    fit = as_the_command("fit", [])
    assert "4 periods of 2000 samples" in fit["time_domain"]["notes"][0]
    p = fit["time_domain"]["parameters"]
    assert p["kd"]["value"] == pytest.approx(4.0e4, rel=0.005)
    assert p["fd"]["value"] == pytest.approx(8.0, rel=0.005)
    # replayed as the continuous model (`--replay continuous`): said in the
    # notes; the recording was made by the ramp-invariant simulator, whose
    # stuck joint the compensation stiffens by kd (omega T)^2/12, 0.2 % at
    # its 45 Hz, so the joint comes back within 1 %
    continuous = hystid.identify_time(record, element="jenkins", replay="continuous")
    assert any("continuous model" in n for n in continuous["time_domain"]["notes"])
    q = continuous["time_domain"]["parameters"]
    assert q["kd"]["value"] == pytest.approx(4.0e4, rel=0.01)
    assert q["fd"]["value"] == pytest.approx(8.0, rel=0.01)
    with pytest.raises(ValueError, match="replay"):
        hystid.identify_time([{"force": force, "response": y, "sample_rate_hz": fs}], replay="smooth")
    # from three starts (`--starts 3`): the command's fit, every start
    # listed with its misfit, the kept one the lowest, the joint as found
    three = as_the_command("fit3", ["--starts", "3"], starts=3)
    listed = three["time_domain"]["starts"]
    assert [s["start"] for s in listed] == [0, 1, 2]
    best = min(listed, key=lambda s: s["misfit"])
    assert f"start {best['start']}'s" in three["time_domain"]["notes"][-1]
    q = three["time_domain"]["parameters"]
    assert q["kd"]["value"] == pytest.approx(4.0e4, rel=0.005)
    assert q["fd"]["value"] == pytest.approx(8.0, rel=0.005)
    with pytest.raises(hystid.HystidError, match="starts"):
        hystid.identify_time([{"force": force, "response": y, "sample_rate_hz": fs}], starts=0)
    # judged at a lower rate (`--max-judged-samples 1000`): the command's
    # fit; one sample in 5 (not the 6 the bound alone asks: 8 samples a
    # period of the 45 Hz stuck mode at 2 kHz is the floor), which leaves
    # 1200 of the 6000 the fit judges (the first period is the start's
    # transient), more than the bound: the periods alike, the record is
    # judged on its share as its first steady periods, 999 samples at that
    # rate in all (its replays stop there); the joint as found
    judged = as_the_command("fitj", ["--max-judged-samples", "1000"], max_judged_samples=1000)
    assert judged["time_domain"]["samples"] == 999
    notes = judged["time_domain"]["notes"]
    assert any("judged on 999 of the 6000 samples" in n and "first steady periods" in n for n in notes)
    q = judged["time_domain"]["parameters"]
    assert q["kd"]["value"] == pytest.approx(4.0e4, rel=0.01)
    assert q["fd"]["value"] == pytest.approx(8.0, rel=0.01)
    with pytest.raises(hystid.HystidError, match="max_judged_samples"):
        hystid.identify_time([{"force": force, "response": y, "sample_rate_hz": fs}],
                             max_judged_samples=999)


def two_modes_driven(fs, period):
    """Two modes (30 Hz and 95 Hz) and a Jenkins joint at the point (as stiff
    as the first mode, slipping at 15 N), driven by 4 periods of a
    random-phase multisine over 10-150 Hz of 20 N RMS: the force, the
    displacement `simulate` gives, and the joint's kd."""
    rng = np.random.default_rng(5)
    t = np.arange(period) / fs
    lines = np.arange(20, 301) * fs / period
    one = sum(np.cos(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi)) for f in lines)
    force = 20.0 * np.tile(one, 4) / np.std(one)
    kd = 2.0 * (2 * np.pi * 30.0) ** 2
    truth = hystid.model({
        "modes": [
            {"frequency_hz": 30.0, "damping_ratio": 0.015, "modal_mass": 2.0},
            {"frequency_hz": 95.0, "damping_ratio": 0.01, "modal_mass": 3.0},
        ],
        "joint": {"kind": "jenkins", "kd": kd, "fd": 15.0},
    })
    return force, hystid.simulate(truth, force, fs), kd


def test_a_multisine_over_two_modes_takes_modes(tmp_path):
    """Two modes (30 Hz and 95 Hz) and a Jenkins joint at the point, driven
    by 4 periods of a multisine over 10-150 Hz: `modes=2` gives the fit of
    `identify --domain time --modes 2`, which finds the joint and the second
    mode (kd, fd within 1 %, its frequency within 0.1 %; measured within
    0.05 %)."""
    fs, period = 1024, 2048
    force, y, kd = two_modes_driven(fs, period)
    text = ["# fs = 1024 Hz", "force,y"] + [f"{a:.17g},{b:.17g}" for a, b in zip(force, y)]
    (tmp_path / "m.csv").write_text("\n".join(text) + "\n")
    run_cli("import", "m.csv", "--out", "m", "-c", "force:force", "-c", "y:displacement",
            "--excitation", "unknown", cwd=tmp_path)
    run_cli("identify", "m.json", "--out", "fit", "--domain", "time", "--element", "jenkins",
            "--modes", "2", cwd=tmp_path, expect=None)
    ref = json.loads((tmp_path / "fit" / "fit.json").read_text())
    samples = read_wav_f32(tmp_path / "m.wav").astype(np.float64)
    fit = hystid.identify_time(
        [{"force": samples[:, 0], "response": samples[:, 1], "sample_rate_hz": fs, "name": "m.json"}],
        element="jenkins", modes=2,
    )
    same_fit(fit, ref)
    assert "with 2 modes" in fit["time_domain"]["notes"][0]
    p = fit["time_domain"]["parameters"]
    assert p["kd"]["value"] == pytest.approx(kd, rel=0.01)
    assert p["fd"]["value"] == pytest.approx(15.0, rel=0.01)
    assert p["second_mode.frequency_hz"]["value"] == pytest.approx(95.0, rel=0.001)


def test_without_a_start_a_record_that_is_no_multisine_is_an_error():
    force = np.sin(2 * np.pi * 0.013 * np.arange(3000) ** 1.5)
    with pytest.raises(hystid.HystidError, match="not multisines"):
        hystid.identify_time([{"force": force, "response": 1e-3 * force, "sample_rate_hz": 1000.0}])
    with pytest.raises(hystid.HystidError, match="recordings\\[0\\]"):
        hystid.identify_time([{"force": force}])


def test_a_multisine_is_diagnosed_at_its_lines_as_the_command_does(tmp_path):
    """The two-mode system above, fitted with one mode: `diagnose_time`
    gives the diagnosis of `diagnose --domain time` on the same recording
    (the missing mode added at 95 Hz within 0.1 %; measured within 0.01 %),
    the same to the bit but for the wall time. At 4096 Hz:
    `simulate` takes the force as a ramp between samples and the replays as
    the band-limited signal it stands for, which at 1024 Hz (7 samples per
    period of the top line) differ by 3 % of the response, three times the
    noise, and a diagnosis rightly adds an effect for it."""
    fs, period = 4096, 8192
    force, y, _ = two_modes_driven(fs, period)
    # 1 % noise, so that the periods' scatter measures something
    y = y + 0.01 * np.std(y) * np.random.default_rng(6).standard_normal(y.size)
    text = ["# fs = 4096 Hz", "force,y"] + [f"{a:.17g},{b:.17g}" for a, b in zip(force, y)]
    (tmp_path / "m.csv").write_text("\n".join(text) + "\n")
    run_cli("import", "m.csv", "--out", "m", "-c", "force:force", "-c", "y:displacement",
            "--excitation", "unknown", cwd=tmp_path)
    run_cli("diagnose", "m.json", "--out", "diag", "--domain", "time", "--element", "jenkins",
            cwd=tmp_path, expect=None)
    ref = json.loads((tmp_path / "diag" / "diagnosis.json").read_text())
    samples = read_wav_f32(tmp_path / "m.wav").astype(np.float64)
    got = hystid.diagnose_time(
        [{"force": samples[:, 0], "response": samples[:, 1], "sample_rate_hz": fs, "name": "m.json"}],
        element="jenkins",
    )
    assert without(got, "seconds") == without(ref, "seconds")
    assert got["selected"] == ["second_mode"]
    assert got["residual"]["chi2_per_line"] < 1.2
    # traced and refitted beside a hysteretic mode there, whose start (a
    # joint that can stick) explains more as it stands; refitted, the linear
    # mode wins
    traced = {t["effect"] for t in got["rounds"][0]["traced"][:3]}
    assert "second_mode" in traced
    f = got["refit"]["parameters"]["second_mode.frequency_hz"]["value"]
    assert f == pytest.approx(95.0, rel=0.001)
    # `validate` judges the final model at the lines of the period as the
    # command does (three steady periods: the noise from their scatter)
    run_cli("validate", "diag/diagnosis.json", "m.json", "--out", "val",
            "--min-samples-per-period", "40", cwd=tmp_path)
    cli = json.loads((tmp_path / "val" / "validate.json").read_text())["recordings"][0]
    v = hystid.validate(got, samples[:, 0], samples[:, 1], fs,
                        min_samples_per_period=40.0, recording="m.json")
    assert v["recordings"][0]["lines"] == cli["lines"]
    assert cli["lines"]["steady_periods"] == 3
    assert cli["lines"]["chi2_per_line"] < 1.2
    # from two starts and judging at most 12 000 samples, as `diagnose
    # --starts 2 --max-judged-samples 12000` does: the 24 576 samples of
    # the three steady periods judged one in 3 (8 192)
    run_cli("diagnose", "m.json", "--out", "diag2", "--domain", "time", "--element", "jenkins",
            "--starts", "2", "--max-judged-samples", "12000", cwd=tmp_path, expect=None)
    ref2 = json.loads((tmp_path / "diag2" / "diagnosis.json").read_text())
    recording = [{"force": samples[:, 0], "response": samples[:, 1], "sample_rate_hz": fs,
                  "name": "m.json"}]
    got2 = hystid.diagnose_time(recording, element="jenkins", starts=2, max_judged_samples=12000)
    assert without(got2, "seconds") == without(ref2, "seconds")
    assert len(got2["baseline"]["starts"]) == 2
    assert got2["baseline"]["samples"] == 8192
    with pytest.raises(hystid.HystidError, match="max_judged_samples"):
        hystid.diagnose_time(recording, max_judged_samples=999)
    with pytest.raises(hystid.HystidError, match="max_judged_samples"):
        hystid.diagnose(got, max_judged_samples=5000)
    with pytest.raises(hystid.HystidError, match="not multisines"):
        hystid.diagnose_time([{"force": np.sin(0.01 * np.arange(3000) ** 1.5),
                               "response": np.zeros(3000), "sample_rate_hz": 1000.0}])


def test_a_time_fit_through_the_acquisition_chain_is_the_commands(cli):
    """`acquisition=` is `--acquisition`: the refinement of the FRF fit put
    through a decimation by 4 is `identify --domain time --acquisition 4`,
    fit.json keeps the chain, and `validate` of that fit puts its replay
    through it as the command does; given to `validate`, it takes the place
    of the fit's (`validate fit.json --acquisition 4`). A chain that is not
    one is refused naming it."""
    d = cli["dir"]
    run_cli("identify", "sim/recording.json", "--out", "fit_time_acq", "--domain", "time",
            "--acquisition", "4", cwd=d)
    ref = json.loads((d / "fit_time_acq" / "fit.json").read_text())
    record, _ = small_record(cli)
    fit = json.loads((d / "fit" / "fit.json").read_text())
    refined = hystid.identify_time([record], fit=fit, acquisition=4)
    chain = {"decimated_by": 4, "taps": 31}
    assert refined["time_domain"]["acquisition"] == chain
    assert refined["time_domain"] == ref["time_domain"]
    force, response, fs = record["force"], record["response"], record["sample_rate_hz"]
    for name, model, flags, given in [
        ("val_time_acq", "fit_time_acq/fit.json", [], None),
        ("val_frf_acq", "fit/fit.json", ["--acquisition", "4"], [4]),
    ]:
        run_cli("validate", model, "sim/recording.json", "--out", name, *flags, cwd=d)
        expected = json.loads((d / name / "validate.json").read_text())
        fitted = json.loads((d / model).read_text())
        val = hystid.validate(fitted, force, response, fs, steps=record["steps"],
                              acquisition=given)
        assert val["acquisition"] == expected["acquisition"] == chain
        assert val["recordings"][0]["whole"] == expected["recordings"][0]["whole"]
    with pytest.raises(hystid.HystidError, match="acquisition"):
        hystid.identify_time([record], fit=fit, acquisition=1)
    with pytest.raises(hystid.HystidError, match="acquisition"):
        hystid.validate(fit, force, response, fs, steps=record["steps"],
                        acquisition={"decimated_by": 4, "taps": 30})


def test_each_recording_refitted_alone_is_the_commands(cli):
    """`each_alone=True` is `--each-alone`: the FRF fit's model fitted in
    time to the same recording given twice, then each copy refitted alone
    from the fitted model, as `identify REC REC --domain time --start
    fit.json --each-alone` does, to the bit. The same recording twice is the
    consistent case: alone, each comes no closer than together (1.00x), and
    the note says the misfit is shared."""
    d = cli["dir"]
    run_cli("identify", "sim/recording.json", "sim/recording.json", "--out", "fit_alone",
            "--domain", "time", "--start", "fit/fit.json", "--each-alone", cwd=d)
    ref = json.loads((d / "fit_alone" / "fit.json").read_text())
    record, _ = small_record(cli)
    start = cli["fit"]["model"]
    refined = hystid.identify_time([record, record], start=start, each_alone=True)
    assert refined["time_domain"] == ref["time_domain"]
    alone = refined["time_domain"]["each_alone"]
    after = refined["time_domain"]["after"]
    assert [a["together"] for a in alone] == [a["window"]["relative"] for a in after]
    for a in alone:
        assert a["status"] == "converged" and "failed" not in a
        assert abs(a["alone"] / a["together"] - 1.0) < 1e-3, a
    note = refined["time_domain"]["notes"][-1]
    assert note.startswith("refitted alone, the recordings come 1.00x closer"), note
    assert "shared by every recording" in note
    # without it, no refit alone and no such note
    plain = hystid.identify_time([record, record], start=start)
    assert "each_alone" not in plain["time_domain"]
    assert not any(n.startswith("refitted alone") for n in plain["time_domain"]["notes"])


def test_a_diagnosis_refits_each_recording_alone_when_asked(cli):
    """`diagnose(frf, recordings=[r, r], each_alone=True)` is `diagnose REC REC
    --domain time --each-alone` for the refit's recordings alone: each copy
    of the same recording refitted alone from the final refit comes no
    closer than together (1.00x); without recordings it is refused naming
    it."""
    record, frf = small_record(cli)
    diagnosis = hystid.diagnose(frf, recordings=[record, record], each_alone=True)
    refit = diagnosis["time_domain"]["refit"]
    alone = refit["each_alone"]
    assert [a["together"] for a in alone] == [a["window"]["relative"] for a in refit["after"]]
    for a in alone:
        assert abs(a["alone"] / a["together"] - 1.0) < 1e-3, a
    assert any(n.startswith("refitted alone, the recordings come 1.00x") for n in refit["notes"])
    with pytest.raises(hystid.HystidError, match="each_alone: .*; give the time histories as recordings"):
        hystid.diagnose(frf, each_alone=True)


def test_a_diagnosis_refined_through_the_acquisition_chain_is_the_commands(cli):
    """`diagnose(frf, recordings=[...], acquisition=4)` is `diagnose --domain
    time --acquisition 4`, to the bit but for the wall time; without
    recordings the chain is refused naming it."""
    d = cli["dir"]
    run_cli("diagnose", "sim/recording.json", "--out", "diag_time_acq", "--domain", "time",
            "--acquisition", "4", cwd=d)
    ref = json.loads((d / "diag_time_acq" / "diagnosis.json").read_text())
    record, frf = small_record(cli)
    diagnosis = hystid.diagnose(frf, recordings=[record], acquisition=4)
    assert diagnosis["time_domain"]["refit"]["acquisition"] == {"decimated_by": 4, "taps": 31}
    assert without(diagnosis, "seconds") == without(ref, "seconds")
    with pytest.raises(hystid.HystidError, match="acquisition: .*; give the time histories as recordings"):
        hystid.diagnose(frf, acquisition=4)
