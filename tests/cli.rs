//! Integration tests: the `hystid` binary.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn hystid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hystid"))
        .args(args)
        .env_remove("CI")
        .output()
        .expect("run hystid")
}

pub fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// `hystid simulate TEST --out OUT --quiet`, which must succeed.
pub fn simulated(test: &Path, out: &Path) {
    let o = hystid(&[
        "simulate",
        test.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
}

/// A small, fast test definition (2 levels, 11 frequencies).
pub const SMALL_TEST: &str = r#"
[system]
mass = 10.0
damping = 200.0
stiffness = 1.0e7
[joint]
kind = "jenkins"
kd = 2.4e7
fd = 246.048
[test]
frequencies_hz = { start = 150.0, stop = 300.0, count = 11 }
levels_n = [50.0, 3000.0]
noise = 0.10
seed = 4
"#;

pub fn write_test(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|r| {
            r.map(|e| e.unwrap().file_name().into_string().unwrap())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// `frf.uff` holds `frf.json`'s FRFs: one dataset per level and harmonic,
/// frequencies ascending (six printed digits), H to 13 significant digits.
fn frf_uff_matches_frf_json(dir: &Path) {
    use hystid::import::uff::{Abscissa, Ordinate, UffFile};
    let frf: hystid::extract::NonlinearFrf =
        serde_json::from_slice(&std::fs::read(dir.join("frf.json")).unwrap()).unwrap();
    let file = UffFile::open(&dir.join("frf.uff")).unwrap();
    let k = frf.max_harmonic + 1;
    assert_eq!(file.datasets.len(), frf.levels.len() * k);
    for (d, (l, h)) in file
        .functions()
        .zip(frf.levels.iter().flat_map(|l| (0..k).map(move |h| (l, h))))
    {
        let (_, f) = d;
        assert_eq!(f.function_type, 4);
        assert_eq!(f.id_lines[3], format!("level {} N, sweep up", l.level));
        assert_eq!(f.id_lines[4], format!("harmonic {h}"));
        assert_eq!(f.version, h as i64);
        assert_eq!(f.z_axis_value, l.level);
        let (Abscissa::Uneven(x), Ordinate::Complex(y)) = (&f.abscissa, &f.ordinate) else {
            panic!("{:?}", f.id_lines)
        };
        let mut points: Vec<_> = l.points.iter().collect();
        points.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
        assert_eq!(x.len(), points.len());
        for ((x, y), p) in x.iter().zip(y).zip(points) {
            // E13.5: half a unit in the sixth digit
            assert!((x - p.frequency_hz).abs() <= 5e-6 * p.frequency_hz, "{x}");
            // E20.12: half a unit in the thirteenth digit, per part
            let scale = p.h[h].re.abs().max(p.h[h].im.abs());
            assert!((y - p.h[h]).norm() <= 1e-12 * scale, "{y} {}", p.h[h]);
        }
    }
}

#[test]
fn simulate_writes_every_output_and_is_byte_identical_across_thread_counts() {
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let a = dir.path().join("a");
    let b = dir.path().join("b");
    let o = hystid(&[
        "simulate",
        test.to_str().unwrap(),
        "--out",
        a.to_str().unwrap(),
        "--threads",
        "1",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let o = hystid(&[
        "simulate",
        test.to_str().unwrap(),
        "--out",
        b.to_str().unwrap(),
        "--threads",
        "2",
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(o.stdout.is_empty(), "--quiet printed: {}", text(&o));
    let names = files_in(&a);
    for f in [
        "run.mcap",
        "recording.wav",
        "recording.json",
        "frf.json",
        "frf.csv",
        "frf.uff",
        "frf.png",
        "frf.svg",
        "summary.json",
    ] {
        assert!(names.contains(&f.to_string()), "{f} missing: {names:?}");
    }
    for f in [
        "run.mcap",
        "recording.wav",
        "recording.json",
        "frf.json",
        "frf.csv",
        "frf.uff",
        "frf.svg",
        "frf.png",
    ] {
        assert_eq!(
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f} differs between 1 and 2 threads"
        );
    }
    frf_uff_matches_frf_json(&a);
    // the recording reads back and its dwells are the MCAP's
    let rec = hystid::record::read_recording(&a.join("recording.wav")).unwrap();
    let run = hystid::record::read_run(&a.join("run.mcap")).unwrap();
    assert!(!run.truncated);
    assert_eq!(rec.meta.excitation.steps.len(), 22);
    assert_eq!(run.dwells.len(), 22);
    let from_mcap = run.to_recording().unwrap();
    assert_eq!(from_mcap.meta.excitation.steps, rec.meta.excitation.steps);
    for (c, name) in ["force", "displacement", "velocity", "acceleration"]
        .iter()
        .enumerate()
    {
        let i = from_mcap.channel_index(name).unwrap();
        assert_eq!(from_mcap.channels[i], rec.channels[c], "{name}");
    }
}

#[test]
fn simulate_mcap_passes_the_official_python_reader() {
    let ok = Command::new("python3")
        .args(["-c", "import mcap.reader, mcap_ros2.decoder"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        eprintln!("SKIPPED: python mcap reader not installed");
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set: the Python mcap reader must be installed"
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let out = dir.path().join("o");
    simulated(&test, &out);
    let rec = hystid::record::read_recording(&out.join("recording.wav")).unwrap();
    // expected counts from the dwells, independently of the MCAP reader
    let steps = &rec.meta.excitation.steps;
    let blocks: usize = steps.iter().map(|s| s.length.div_ceil(4096)).sum();
    let frames = rec.frames();
    let decimation = (rec.meta.sample_rate_hz / 1000.0).ceil() as usize;
    let n = steps[0].length.min(4096);
    let f32s = |c: usize| rec.channels[c][..n].to_vec();
    let expect = serde_json::json!({
        "counts": {
            "/hystid/signals": blocks,
            "/hystid/dwell": steps.len(),
            "/hystid/preview": frames.div_ceil(decimation),
        },
        "first_block": {
            "step": 0, "first_frame": 0, "t0": 0.0, "fs": rec.meta.sample_rate_hz,
            "force": f32s(0), "displacement": f32s(1), "velocity": f32s(2), "acceleration": f32s(3),
        },
        "metadata": {},
        "attachment": SMALL_TEST,
    });
    let expect_path = dir.path().join("expect.json");
    std::fs::write(&expect_path, serde_json::to_string(&expect).unwrap()).unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/interop/check_mcap.py");
    let o = Command::new("python3")
        .arg(&script)
        .arg(out.join("run.mcap"))
        .arg(&expect_path)
        .output()
        .unwrap();
    assert!(o.status.success(), "check_mcap.py: {}", text(&o));
}

#[test]
fn bad_test_definitions_fail_cleanly_without_output() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            SMALL_TEST.replace("mass = 10.0", "mass = -1.0"),
            "system.mass",
        ),
        (
            SMALL_TEST.replace("levels_n = [50.0,", "levels_n = [nan,"),
            "test.levels_n[0]",
        ),
        (
            SMALL_TEST.replace("seed = 4", "seed = 4\nsample_rate_hz = 3000.0"),
            "Nyquist",
        ),
        (
            SMALL_TEST.replace("seed = 4", "seed = 4\ncolour = \"red\""),
            "colour",
        ),
        (SMALL_TEST.replace("fd = 246.048", "fd = \"much\""), "fd"),
    ];
    for (i, (t, needle)) in cases.iter().enumerate() {
        let test = write_test(dir.path(), &format!("bad{i}.toml"), t);
        let out = dir.path().join(format!("out{i}"));
        let o = hystid(&[
            "simulate",
            test.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2), "case {i}: {}", text(&o));
        let msg = text(&o);
        assert!(msg.contains(needle), "case {i}: `{needle}` not in: {msg}");
        assert!(
            msg.contains(&format!("bad{i}.toml")) || msg.contains("invalid"),
            "case {i} names no file: {msg}"
        );
        assert!(
            files_in(&out).is_empty(),
            "case {i} left files: {:?}",
            files_in(&out)
        );
    }
    let o = hystid(&[
        "simulate",
        "/nonexistent/t.toml",
        "--out",
        dir.path().join("x").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("/nonexistent/t.toml"));
}

/// `diagnose --element jenkins` keeps the user's joint law in every
/// candidate: the second-mode candidate re-identifies the structure with one
/// more mode, and once did so with the default options (a Masing joint,
/// whose curvature `n` then appeared among the candidate's parameters).
#[test]
fn diagnose_keeps_the_users_joint_law_in_every_candidate() {
    let dir = tempfile::tempdir().unwrap();
    let with_mode = SMALL_TEST
        .replace("count = 11", "count = 15")
        .replace("levels_n = [50.0, 3000.0]", "levels_n = [50.0, 1000.0, 30000.0]")
        .replace(
            "[test]",
            "[[effects]]\nkind = \"second_mode\"\nfrequency_hz = 420.0\ndamping_ratio = 0.01\nmodal_mass = 50.0\n[test]",
        );
    let test = write_test(dir.path(), "mode.toml", &with_mode);
    let sim = dir.path().join("sim");
    simulated(&test, &sim);
    let out = dir.path().join("diag");
    let o = hystid(&[
        "diagnose",
        sim.join("recording.wav").to_str().unwrap(),
        "--element",
        "jenkins",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let d: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("diagnosis.json")).unwrap()).unwrap();
    for model in ["baseline_model", "model"] {
        assert_eq!(
            d[model]["joint"]["kind"], "jenkins",
            "{model}: {}",
            d[model]
        );
    }
    let candidates = d["candidates"].as_array().unwrap();
    assert!(
        candidates.iter().any(|c| c["effect"] == "second_mode"),
        "the second-mode candidate was not tried: {candidates:?}"
    );
    // (but for a joint law tried in its place: an Iwan joint has kt and fs,
    // a Bouc-Wen joint alpha and the shape)
    for c in candidates
        .iter()
        .filter(|c| !["iwan4_joint", "bouc_wen_joint"].contains(&c["effect"].as_str().unwrap()))
    {
        let params = c["parameters"].as_object().unwrap();
        assert!(
            params.contains_key("kd") && params.contains_key("fd"),
            "{c}"
        );
        assert!(
            !params.contains_key("n"),
            "{} carries a Masing curvature: {c}",
            c["effect"]
        );
    }
    // the final model as reported (with flags) is the diagnosis's final fit,
    // parameter for parameter (and derived ones, such as a mode's modal
    // mass), and diagnosis.md states it
    let reported = &d["final_model"];
    let fitted = d["final"]["parameters"].as_object().unwrap();
    let shown = reported["parameters"].as_object().unwrap();
    for (name, e) in fitted {
        assert_eq!(&shown[name]["value"], e, "{name}: {}", shown[name]);
    }
    let added: Vec<&serde_json::Value> = d["selected"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| &s["effect"])
        .collect();
    assert_eq!(
        reported["added_effects"]
            .as_array()
            .unwrap()
            .iter()
            .collect::<Vec<_>>(),
        added
    );
    let md = std::fs::read_to_string(out.join("diagnosis.md")).unwrap();
    assert!(md.contains("## The model: jenkins joint"), "{md}");

    // diagnosis.json is a model as validate and the time fit's --start take
    // one: its final model (with the mode it kept), not its baseline
    assert_eq!(added, [&serde_json::json!("second_mode")]);
    let rec = sim.join("recording.json");
    let validated = |model: &Path, tag: &str| -> f64 {
        let v = dir.path().join(tag);
        let o = hystid(&[
            "validate",
            model.to_str().unwrap(),
            rec.to_str().unwrap(),
            "--out",
            v.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(o.status.success(), "{tag}: {}", text(&o));
        let r: serde_json::Value =
            serde_json::from_slice(&std::fs::read(v.join("validate.json")).unwrap()).unwrap();
        r["recordings"][0]["whole"]["relative"].as_f64().unwrap()
    };
    let diagnosed = validated(&out.join("diagnosis.json"), "val_final");
    let mut baseline = d.clone();
    baseline["model"] = d["baseline_model"].clone();
    let base_path = dir.path().join("baseline_diagnosis.json");
    std::fs::write(&base_path, serde_json::to_vec(&baseline).unwrap()).unwrap();
    let base = validated(&base_path, "val_base");
    eprintln!("e_RMS / RMS: final {diagnosed:.4}, baseline {base:.4}");
    // the test's 10 % response noise is the floor: the final model sits on
    // it, the baseline (without the mode) 7 % above it
    assert!(
        (0.09..0.103).contains(&diagnosed) && diagnosed < 0.95 * base,
        "final {diagnosed} against baseline {base}"
    );
    // replayed as the continuous model (the joint's force compensated too):
    // said in validate.json, and on the same noise floor
    let v = dir.path().join("val_continuous");
    let o = hystid(&[
        "validate",
        out.join("diagnosis.json").to_str().unwrap(),
        rec.to_str().unwrap(),
        "--replay",
        "continuous",
        "--out",
        v.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(v.join("validate.json")).unwrap()).unwrap();
    assert_eq!(r["recordings"][0]["replay"], "continuous");
    let continuous = r["recordings"][0]["whole"]["relative"].as_f64().unwrap();
    eprintln!("e_RMS / RMS replayed as the continuous model: {continuous:.4}");
    assert!((0.09..0.103).contains(&continuous), "{continuous}");
    let o = hystid(&[
        "validate",
        out.join("diagnosis.json").to_str().unwrap(),
        rec.to_str().unwrap(),
        "--replay",
        "smooth",
        "--out",
        dir.path().join("val_refused").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--replay"), "{}", text(&o));
    let o = hystid(&[
        "validate",
        out.join("diagnosis.json").to_str().unwrap(),
        rec.to_str().unwrap(),
        "--linear",
        "--out",
        dir.path().join("val_linear").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("not a diagnosis"), "{}", text(&o));
    let tf = dir.path().join("time_fit");
    let o = hystid(&[
        "identify",
        rec.to_str().unwrap(),
        "--domain",
        "time",
        "--start",
        out.join("diagnosis.json").to_str().unwrap(),
        "--out",
        tf.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let f: serde_json::Value =
        serde_json::from_slice(&std::fs::read(tf.join("fit.json")).unwrap()).unwrap();
    let p = f["time_domain"]["parameters"].as_object().unwrap();
    assert!(
        p.contains_key("second_mode.frequency_hz") && p.contains_key("kd"),
        "{:?}",
        p.keys()
    );
}

/// `run` chains simulate and identify into one folder, and its report
/// describes the test that ran: the measured noise, the system and joint of
/// the definition, the fitted law's parameters with the values they were
/// simulated with, the paper's table for the paper's system. A parameter
/// at its bound (a Masing curvature fitted to a Jenkins joint runs to its
/// limit) is flagged in report.md, run.json and the terminal. With
/// `--no-recording` nothing but the time histories is missing: the FRFs
/// are the same bytes and the fit the same numbers.
#[test]
fn run_reports_the_test_that_ran_and_flags_a_parameter_at_its_bound() {
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let out = dir.path().join("run");
    let o = hystid(&[
        "run",
        test.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-diagnose",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let terminal = text(&o);
    let run: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("run.json")).unwrap()).unwrap();
    assert_eq!(run["fit"]["status"], "converged", "{}", run["fit"]);
    // the run file's fit channel: one message per evaluation of the fit's
    // stages, numbered on from each other (1, 2, ... without a repeat), as
    // its trace is; read with the mcap crate's own reader
    let bytes = std::fs::read(out.join("run.mcap")).unwrap();
    let iterations: Vec<u64> = mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| m.unwrap())
        .filter(|m| m.channel.topic == hystid::record::TOPIC_FIT)
        .map(|m| {
            serde_json::from_slice::<serde_json::Value>(&m.data).unwrap()["iteration"]
                .as_u64()
                .unwrap()
        })
        .collect();
    let trace = run["fit"]["trace"].as_array().map_or(0, Vec::len);
    assert!(
        trace > 0 && iterations.len() == trace,
        "{} messages, trace {trace}",
        iterations.len()
    );
    assert!(
        iterations
            .iter()
            .enumerate()
            .all(|(i, &n)| n == i as u64 + 1),
        "{:?}",
        &iterations[..iterations.len().min(40)]
    );
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    // 10 % response noise asked for: the measured RMS ratio, within its
    // scatter over 22 dwells
    let noise: f64 = report
        .split(" % response noise (measured, RMS)")
        .next()
        .and_then(|head| head.rsplit(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no measured noise in:\n{report}"));
    assert!((noise - 10.0).abs() < 1.0, "noise {noise} %");
    assert!(
        report.contains(
            "an SDOF, m = 10 kg, c = 200 N s/m, k = 1e7 N/m with joint `jenkins` (kd = 2.4e7, fd = 246.048): 2 levels (50, 3000 N) × 11 frequencies 150–300 Hz"
        ),
        "{report}"
    );
    // the paper's system (another test plan): its Table 3.1 beside the result
    assert!(report.contains("## Table 3.1"), "{report}");
    // the final model is the fit's; its parameters beside the simulated ones
    let fin = &run["final"];
    assert_eq!(fin["source"], "fit");
    assert!(fin.get("before").is_none(), "{fin}");
    let kd_reference = fin["parameters"]["kd"]["reference"].as_f64().unwrap();
    assert!((kd_reference / 2.4e7 - 1.0).abs() < 1e-12, "{fin}");
    let kd = report
        .lines()
        .find(|l| l.starts_with("| kd |"))
        .unwrap_or_else(|| panic!("no kd row:\n{report}"));
    assert!(kd.contains("| 2.4000e7 ("), "{kd}");
    // the curvature at its bound, flagged in all three
    let n = &fin["parameters"]["n"];
    assert_eq!(
        n["flags"],
        serde_json::json!(["at_bound", "not_identifiable"]),
        "{n}"
    );
    assert!(fin["parameters"]["kd"].get("flags").is_none(), "{fin}");
    assert!(
        report.contains("- **n**: at a bound of its fit; not identifiable"),
        "{report}"
    );
    assert!(
        terminal.contains("FLAG: at a bound of its fit; not identifiable"),
        "{terminal}"
    );
    // the same without the time histories
    let bare = dir.path().join("bare");
    let o = hystid(&[
        "run",
        test.to_str().unwrap(),
        "--out",
        bare.to_str().unwrap(),
        "--no-diagnose",
        "--no-recording",
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let (with, without) = (files_in(&out), files_in(&bare));
    let missing: Vec<&String> = with.iter().filter(|f| !without.contains(f)).collect();
    assert_eq!(
        missing,
        ["recording.json", "recording.wav", "run.mcap"],
        "{without:?}"
    );
    for f in ["frf.json", "frf.csv", "frf.uff"] {
        assert_eq!(
            std::fs::read(out.join(f)).unwrap(),
            std::fs::read(bare.join(f)).unwrap(),
            "{f}"
        );
    }
    let bare_run: serde_json::Value =
        serde_json::from_slice(&std::fs::read(bare.join("run.json")).unwrap()).unwrap();
    assert_eq!(bare_run["final"], run["final"]);
    assert_eq!(bare_run["fit"]["model"], run["fit"]["model"]);
}

/// `identify` flags what `run` flags: a Masing law fitted to Jenkins data
/// runs its curvature `n` to its bound (the law's Jenkins limit, N → ∞), so
/// `n` is flagged at its bound and not identifiable, in the terminal and in
/// fit.json, for the FRF fit and the time-domain refinement alike; the
/// joint's `kd` and `fd`, recovered within 0.2 %, carry no flag.
#[test]
fn identify_flags_a_parameter_at_its_bound_in_the_terminal_and_fit_json() {
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let sim = dir.path().join("sim");
    simulated(&test, &sim);
    let out = dir.path().join("fit");
    let o = hystid(&[
        "identify",
        sim.join("run.mcap").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--domain",
        "time",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let terminal = text(&o);
    // the run file's dwells are reduced one at a time, not read whole
    assert!(terminal.contains("(streamed)"), "{terminal}");
    let fit: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("fit.json")).unwrap()).unwrap();
    let flagged = serde_json::json!({"n": ["at_bound", "not_identifiable"]});
    assert_eq!(fit["flags"], flagged, "{}", fit["flags"]);
    assert_eq!(fit["at_bound"], serde_json::json!(["n"]));
    assert_eq!(
        fit["time_domain_flags"], flagged,
        "{}",
        fit["time_domain_flags"]
    );
    assert_eq!(fit["time_domain"]["at_bound"], serde_json::json!(["n"]));
    // one flagged line for each fit: the FRF's and the time domain's
    let n_lines: Vec<&str> = terminal
        .lines()
        .filter(|l| l.trim_start().starts_with("n = "))
        .collect();
    assert_eq!(n_lines.len(), 2, "{terminal}");
    for l in &n_lines {
        assert!(
            l.ends_with("FLAG: at a bound of its fit; not identifiable"),
            "{l}"
        );
    }
    for name in ["kd = ", "fd = "] {
        let l = terminal
            .lines()
            .find(|l| l.trim_start().starts_with(name))
            .unwrap_or_else(|| panic!("no {name} in:\n{terminal}"));
        assert!(!l.contains("FLAG"), "{l}");
    }
}

/// `diagnose --domain time --replay continuous` replays every model as the
/// continuous model: diagnosis.json records how (`time_domain.replay`), the
/// refit carries the note, diagnosis.md says so, and the time residual is
/// that of the compensated replays (its H1 chi2/dof differs from the
/// band-limited replay's: measured 1.07 against 1.11 on this recording,
/// both at the noise); an unknown replay is refused with exit 2.
#[test]
fn diagnose_in_the_time_domain_replays_as_asked() {
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let sim = dir.path().join("sim");
    simulated(&test, &sim);
    let run = sim.join("run.mcap");
    let diagnose = |replay: &str| {
        let out = dir.path().join(replay);
        let o = hystid(&[
            "diagnose",
            run.to_str().unwrap(),
            "--domain",
            "time",
            "--replay",
            replay,
            "--out",
            out.to_str().unwrap(),
            "-q",
        ]);
        assert!(o.status.success(), "{}", text(&o));
        let d: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("diagnosis.json")).unwrap()).unwrap();
        let md = std::fs::read_to_string(out.join("diagnosis.md")).unwrap();
        (d["time_domain"].clone(), md)
    };
    let (plain, plain_md) = diagnose("band-limited");
    let (continuous, md) = diagnose("continuous");
    assert_eq!(plain["replay"], "band_limited");
    assert_eq!(continuous["replay"], "continuous");
    assert!(
        plain_md.contains("replayed on the band-limited reference"),
        "{plain_md}"
    );
    assert!(md.contains("replayed as the continuous model"), "{md}");
    let notes = continuous["refit"]["notes"].to_string();
    assert!(notes.contains("--replay continuous"), "{notes}");
    let h1 = |t: &serde_json::Value| {
        t["residual"]["features"]["chi2_per_dof_by_harmonic"]["1"]
            .as_f64()
            .unwrap()
    };
    let (a, b) = (h1(&plain), h1(&continuous));
    eprintln!("time residual H1 chi2/dof: band-limited {a:.3}, continuous {b:.3}");
    assert!((a - b).abs() > 1e-3, "{a} vs {b}");
    for c in [a, b] {
        assert!(c > 0.7 && c < 1.5, "{c}");
    }
    let o = hystid(&[
        "diagnose",
        run.to_str().unwrap(),
        "--domain",
        "time",
        "--replay",
        "smooth",
        "--out",
        dir.path().join("refused").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--replay"), "{}", text(&o));
}

/// `identify --starts N` and `--replay` are the time-domain fit's: without
/// `--domain time` they are refused with exit 2 and leave no output, as is
/// a count of 0; `diagnose --replay` likewise.
#[test]
fn time_domain_options_are_refused_without_the_time_domain() {
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let sim = dir.path().join("sim");
    simulated(&test, &sim);
    let out = dir.path().join("fit");
    let recording = sim.join("recording.json");
    for (command, extra, expected) in [
        ("identify", &["--starts", "3"][..], "--starts"),
        (
            "identify",
            &["--starts", "0", "--domain", "time"][..],
            "--starts",
        ),
        ("identify", &["--replay", "continuous"][..], "--replay"),
        ("diagnose", &["--replay", "continuous"][..], "--replay"),
        ("diagnose", &["--starts", "2"][..], "--starts"),
        (
            "diagnose",
            &["--starts", "0", "--domain", "time"][..],
            "--starts",
        ),
    ] {
        let mut a = vec![
            command,
            recording.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        a.extend(extra);
        let o = hystid(&a);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(text(&o).contains(expected), "{}", text(&o));
        assert!(!out.exists(), "an output was left: {}", text(&o));
    }
}

/// `run` on a test with an undeclared cubic stiffness reports one model,
/// the diagnosis's, everywhere: the terminal, report.md and run.json name
/// it and give its parameters (the cubic's with the value it was simulated
/// with), and the first fit is the "before", its error measured as the
/// final model's (one definition, the same points: fit.json's figure for
/// the first fit, diagnosis.json's for the final model).
#[test]
fn run_reports_the_model_after_the_diagnosis_with_the_first_fit_as_before() {
    let dir = tempfile::tempdir().unwrap();
    let cubic = SMALL_TEST
        .replace(
            "levels_n = [50.0, 3000.0]",
            "levels_n = [50.0, 1000.0, 30000.0]",
        )
        .replace(
            "[test]",
            "[[effects]]\nkind = \"cubic_stiffness\"\nk3 = 1.0e7\n[test]",
        );
    let test = write_test(dir.path(), "cubic.toml", &cubic);
    let out = dir.path().join("run");
    let o = hystid(&[
        "run",
        test.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--element",
        "jenkins",
        "--no-recording",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let terminal = text(&o);
    assert!(
        terminal.contains("final model (after the diagnosis): jenkins joint + cubic_stiffness"),
        "{terminal}"
    );
    let json = |name: &str| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(out.join(name)).unwrap()).unwrap()
    };
    let (run, fit, diagnosis) = (json("run.json"), json("fit.json"), json("diagnosis.json"));
    let fin = &run["final"];
    assert_eq!(fin["source"], "diagnosis");
    assert_eq!(fin["added_effects"], serde_json::json!(["cubic_stiffness"]));
    assert_eq!(fin["model"], diagnosis["model"]);
    let k3 = &fin["parameters"]["cubic_stiffness.k3"];
    let k3_reference = k3["reference"].as_f64().unwrap();
    assert!((k3_reference / 1e7 - 1.0).abs() < 1e-12, "{k3}");
    let v = k3["value"].as_f64().unwrap();
    assert!((v / 1e7 - 1.0).abs() < 0.3, "{k3}");
    assert!(k3.get("flags").is_none(), "{k3}");
    for p in ["kd", "fd", "mass", "damping", "stiffness"] {
        assert!(
            fin["parameters"][p]["ci95"][1].as_f64().is_some(),
            "{p}: {fin}"
        );
    }
    // one error figure: the first fit's as fit.json has it, the final
    // model's as diagnosis.json has it
    let close = |a: &serde_json::Value, b: &serde_json::Value| {
        let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
        assert!((a / b - 1.0).abs() < 1e-6, "{a} vs {b}");
    };
    close(
        &fin["before"]["error"]["relative"],
        &fit["error"]["relative"],
    );
    close(
        &fin["error"]["relative"],
        &diagnosis["final"]["error_relative"],
    );
    close(
        &fin["baseline"]["relative"],
        &diagnosis["baseline"]["error_relative"],
    );
    assert!(fin["error"]["relative"].as_f64() < fin["before"]["error"]["relative"].as_f64());
    // the pinned figures of this run
    let shown = crate::common::pinned_figures("Figures of that run:").expect("pinned figures");
    let num = |v: &serde_json::Value| v.as_f64().unwrap();
    let pct = |name: &str| {
        let p = &fin["parameters"][name];
        100.0 * (num(&p["value"]) / num(&p["reference"]) - 1.0)
    };
    for (what, value, at) in [
        ("k3", v, 0),
        ("k3's CI low", num(&k3["ci95"][0]), 1),
        ("k3's CI high", num(&k3["ci95"][1]), 2),
        ("k3's error [%]", pct("cubic_stiffness.k3"), 3),
        ("kd's error [%]", pct("kd"), 4),
        ("Fd's error [%]", pct("fd"), 5),
        (
            "the first fit's error [%]",
            100.0 * num(&fin["before"]["error"]["relative"]),
            6,
        ),
        (
            "the baseline's error [%]",
            100.0 * num(&fin["baseline"]["relative"]),
            7,
        ),
        (
            "the final error [%]",
            100.0 * num(&fin["error"]["relative"]),
            8,
        ),
        (
            "the first fit's chi2/dof",
            num(&fin["before"]["error"]["chi2_per_dof"]),
            9,
        ),
        (
            "the baseline's chi2/dof",
            num(&fin["baseline"]["chi2_per_dof"]),
            10,
        ),
        ("the final chi2/dof", num(&fin["error"]["chi2_per_dof"]), 11),
    ] {
        crate::common::assert_pinned_figure(what, value, shown[at]);
    }
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        report.contains("## The model: jenkins joint + cubic_stiffness"),
        "{report}"
    );
    assert!(report.contains("| cubic_stiffness.k3 | "), "{report}");
    assert!(
        report.contains("| before: the first fit (jenkins joint alone) |"),
        "{report}"
    );
    assert!(report.contains("![final model](final_frf.png)"), "{report}");
    // not the paper's system: no paper's table
    assert!(!report.contains("Table 3.1"), "{report}");
    let files = files_in(&out);
    for f in ["final_frf.png", "loops.png", "fit_frf.png", "residual.png"] {
        assert!(files.contains(&f.to_string()), "{f}: {files:?}");
    }
    for f in ["run.mcap", "recording.wav", "recording.json"] {
        assert!(!files.contains(&f.to_string()), "{f}: {files:?}");
    }
}

/// `run` with its default candidates on the validation pages' virtual test of a
/// hysteretic mode: the first fit (a Masing joint alone) leaves the mode
/// out, leaving far more than twice the noise, so the diagnosis tries the
/// hysteretic mode, adds it alone, recovers the mode and its joint (the
/// frequency within 1 %, the rest within 2 %), and the error in H1 falls
/// more than 3x (issue 12); the pinned line is pinned.
#[test]
fn run_finds_an_undeclared_hysteretic_mode() {
    let dir = tempfile::tempdir().unwrap();
    let def = dir.path().join("hysteretic_mode.toml");
    std::fs::write(&def, crate::common::HYSTERETIC_MODE_TEST).unwrap();
    let out = dir.path().join("out");
    let o = hystid(&[
        "run",
        def.to_str().unwrap(),
        "--no-recording",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let run: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("run.json")).unwrap()).unwrap();
    let f = &run["final"];
    assert_eq!(f["added_effects"], serde_json::json!(["hysteretic_mode"]));
    let shown = crate::common::pinned_figures(
        "- Undeclared on that virtual test, `hystid run TEST.toml` (the first fit a Masing joint \
         alone, then the diagnosis with its default candidates) adds `hysteretic_mode` alone:",
    )
    .expect("the pinned figures");
    let mut figures = Vec::new();
    for (name, tolerance) in [
        ("frequency_hz", 0.01),
        ("modal_mass", 0.02),
        ("damping_ratio", 0.02),
        ("joint.kd", 0.02),
        ("joint.fd", 0.02),
    ] {
        let p = &f["parameters"][format!("hysteretic_mode.{name}")];
        let e = p["value"].as_f64().unwrap() / p["reference"].as_f64().unwrap() - 1.0;
        assert!(e.abs() < tolerance, "{name}: {p}");
        figures.push((name, 100.0 * e));
    }
    let (before, after) = (
        f["before"]["error"]["relative"].as_f64().unwrap(),
        f["error"]["relative"].as_f64().unwrap(),
    );
    assert!(before > 3.0 * after, "{before} -> {after}");
    figures.extend([
        ("H1 error before", 100.0 * before),
        ("H1 error after", 100.0 * after),
        (
            "chi2/dof before",
            f["before"]["error"]["chi2_per_dof"].as_f64().unwrap(),
        ),
        (
            "chi2/dof after",
            f["error"]["chi2_per_dof"].as_f64().unwrap(),
        ),
    ]);
    for (i, (what, value)) in figures.into_iter().enumerate() {
        crate::common::assert_pinned_figure(what, value, shown[i]);
    }
}

/// A model that runs away under one recording's drive (a softening cubic
/// stiffness whose restoring force turns over past 2 cm) is that
/// recording's result, not the end of the others': `validate` writes the
/// figures of the recording it could replay, says why it could not replay
/// the other (its replay did not converge), and exits 1 (degraded); one
/// recording alone, it still writes validate.json with the reason.
#[test]
fn validate_reports_a_replay_that_runs_away_and_validates_the_rest() {
    use hystid::record::ExcitationKind;
    let dir = tempfile::tempdir().unwrap();
    let model_text = "[system]\nmass = 1.0\ndamping = 20.0\nstiffness = 4.0e5\n\n\
                      [[effects]]\nkind = \"cubic_stiffness\"\nk3 = -1.0e9\n";
    let model_path = dir.path().join("model.toml");
    std::fs::write(&model_path, model_text).unwrap();
    let fs = 5000.0;
    // 50 Hz, below the 100 Hz mode: 20 N moves it 0.07 mm, 20 kN 7 cm
    let recording = |amplitude: f64, name: &str| -> PathBuf {
        let force: Vec<f64> = (0..5000)
            .map(|i| amplitude * (2.0 * std::f64::consts::PI * 50.0 * i as f64 / fs).sin())
            .collect();
        let x = hystid::sim::simulate(
            &hystid::testbench::model_from_toml(
                "[system]\nmass = 1.0\ndamping = 20.0\nstiffness = 4.0e5\n",
                "linear",
            )
            .unwrap(),
            &force,
            fs,
            hystid::sim::Output::Displacement,
            &hystid::observe::Silent,
        )
        .unwrap();
        force_and_displacement(
            &dir.path().join(name),
            fs,
            force,
            x,
            ExcitationKind::SteppedSine,
        )
    };
    let quiet = recording(20.0, "quiet");
    let loud = recording(20_000.0, "loud");
    let out = dir.path().join("val");
    let o = hystid(&[
        "validate",
        model_path.to_str().unwrap(),
        quiet.to_str().unwrap(),
        loud.to_str().unwrap(),
        "--no-frf",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("1 of 2 recordings could not be replayed"),
        "{}",
        text(&o)
    );
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("validate.json")).unwrap()).unwrap();
    let entries = v["recordings"].as_array().unwrap();
    assert_eq!(entries.len(), 2);
    // the quiet one validated: the model is the linear one plus a cubic that
    // barely acts there, so it replays the linear response within 1e-3
    let relative = entries[0]["whole"]["relative"].as_f64().unwrap();
    assert!(relative < 1e-3, "{relative}");
    assert!(entries[0].get("replay_failed").is_none());
    // the loud one: no figures, and why
    assert!(entries[1].get("whole").is_none(), "{}", entries[1]);
    let why = entries[1]["replay_failed"].as_str().unwrap();
    assert!(
        why.contains("loud.json") && why.contains("did not converge"),
        "{why}"
    );
    // alone, the same: a report that says why, exit 1
    let o = hystid(&[
        "validate",
        model_path.to_str().unwrap(),
        loud.to_str().unwrap(),
        "--no-frf",
        "--out",
        dir.path().join("val_loud").to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(dir.path().join("val_loud/validate.json").is_file());
}

/// A recording of a force and a displacement at `fs`, written at `stem`
/// (float WAV + JSON) with the excitation `kind` and no steps stated; the
/// JSON's path.
fn force_and_displacement(
    stem: &Path,
    fs: f64,
    force: Vec<f64>,
    x: Vec<f64>,
    kind: hystid::record::ExcitationKind,
) -> PathBuf {
    use hystid::harmonics::Quantity;
    use hystid::record::{Recording, SampleFormat, write_recording};
    let rec = Recording {
        meta: super::cli_realdata::meta(fs, Quantity::Displacement, kind),
        channels: vec![force, x],
    };
    write_recording(stem, &rec, SampleFormat::Float32).unwrap();
    stem.with_extension("json")
}

/// A recording that states no excitation and whose force is a multisine
/// played five times is refused by the FRF path (`identify`, `diagnose`),
/// naming it a multisine, its period and lines, and the time-domain fit
/// that reads it (which does: exit 0); a dwell search used to cut it into
/// "dwells" and fail on a harmonic above Nyquist (the Bouc-Wen
/// benchmark's estimation record). Stated as a stepped sine, it is not
/// refused for being a multisine.
#[test]
fn an_unstated_multisine_is_sent_to_the_time_domain_fit() {
    use hystid::record::ExcitationKind;
    let dir = tempfile::tempdir().unwrap();
    let (fs, period) = (2000.0, 1000);
    // lines 5..60 of a 2 Hz grid (10-120 Hz), Schroeder phases
    let one: Vec<f64> = (0..period)
        .map(|i| {
            (5..60)
                .map(|k| {
                    let phase = -std::f64::consts::PI * (k * (k - 1)) as f64 / 55.0;
                    (2.0 * std::f64::consts::PI * k as f64 * i as f64 / period as f64 + phase).cos()
                })
                .sum::<f64>()
        })
        .collect();
    let force: Vec<f64> = one
        .iter()
        .cycle()
        .take(5 * period)
        .map(|v| 10.0 * v)
        .collect();
    let linear = hystid::testbench::model_from_toml(
        "[system]\nmass = 1.0\ndamping = 20.0\nstiffness = 4.0e5\n",
        "linear",
    )
    .unwrap();
    let x = hystid::sim::simulate(
        &linear,
        &force,
        fs,
        hystid::sim::Output::Displacement,
        &hystid::observe::Silent,
    )
    .unwrap();
    let rec = force_and_displacement(
        &dir.path().join("ms"),
        fs,
        force,
        x,
        ExcitationKind::Unknown,
    );
    for command in ["identify", "diagnose"] {
        let o = hystid(&[
            command,
            rec.to_str().unwrap(),
            "--out",
            dir.path().join(command).to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2), "{command}: {}", text(&o));
        let t = text(&o);
        assert!(
            t.contains("ms.json")
                && t.contains("is a multisine (a period of 1000 samples repeated, 55 excited lines over 10.0000-118.0000 Hz)")
                && t.contains("identify --domain time"),
            "{command}: {t}"
        );
    }
    let o = hystid(&[
        "identify",
        rec.to_str().unwrap(),
        "--domain",
        "time",
        "--out",
        dir.path().join("time").to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let o = hystid(&[
        "identify",
        rec.to_str().unwrap(),
        "--excitation",
        "stepped",
        "--out",
        dir.path().join("stated").to_str().unwrap(),
        "--quiet",
    ]);
    assert!(!text(&o).contains("multisine"), "{}", text(&o));
}

/// A fit remembers what its reference was (fit.json's `reference_quantity`),
/// and `validate` refuses a recording driven by the other quantity, naming
/// the channel (a model fitted in newtons driven by volts gave figures that
/// meant nothing: e_RMS 100 % of the RMS), exit 2; the same recording
/// driven by a force validates.
#[test]
fn validate_refuses_a_recording_driven_by_another_quantity_than_the_fit() {
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let sim = dir.path().join("sim");
    simulated(&test, &sim);
    let fit = dir.path().join("fit");
    let o = hystid(&[
        "identify",
        sim.join("recording.json").to_str().unwrap(),
        "--out",
        fit.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let fit_json = fit.join("fit.json");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&fit_json).unwrap()).unwrap();
    assert_eq!(report["reference_quantity"], "force");
    // the same samples, the reference declared a voltage
    let mut meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(sim.join("recording.json")).unwrap()).unwrap();
    meta["channels"][0]["quantity"] = "voltage".into();
    meta["channels"][0]["unit"] = "V".into();
    std::fs::write(
        dir.path().join("volts.json"),
        serde_json::to_vec(&meta).unwrap(),
    )
    .unwrap();
    std::fs::copy(sim.join("recording.wav"), dir.path().join("volts.wav")).unwrap();
    let o = hystid(&[
        "validate",
        fit_json.to_str().unwrap(),
        dir.path().join("volts.json").to_str().unwrap(),
        "--no-frf",
        "--out",
        dir.path().join("val_volts").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let t = text(&o);
    assert!(
        t.contains("volts.json")
            && t.contains(
                "reference channel `force`: is a voltage, but the model was fitted with a force"
            ),
        "{t}"
    );
    let o = hystid(&[
        "validate",
        fit_json.to_str().unwrap(),
        sim.join("recording.json").to_str().unwrap(),
        "--no-frf",
        "--out",
        dir.path().join("val").to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
}

/// A recording longer than a channel is held in memory for
/// (`signals::SAMPLES_HELD_IN_MEMORY` samples) is held in a scratch file in `TMPDIR`:
/// where that directory does not exist, `validate` says so, naming it, with
/// exit code 2 and no output; given one, it validates and leaves nothing
/// there (the files have no name).
#[test]
fn a_recording_too_long_to_hold_is_held_in_the_scratch_directory() {
    use hystid::record::{Channel, Excitation, ExcitationKind, RecordingMeta, RecordingWriter};
    use hystid::signals::Step;
    let dir = tempfile::tempdir().unwrap();
    let (fs, f) = (30_000.0, 200.0);
    let n = hystid::signals::SAMPLES_HELD_IN_MEMORY + 30_000;
    let w = 2.0 * std::f64::consts::PI * f / fs;
    let force: Vec<f32> = (0..n)
        .map(|i| (100.0 * (w * i as f64).sin()) as f32)
        .collect();
    // the small test's structure, stuck: 100 N / (k + kd)
    let x: Vec<f32> = force.iter().map(|v| v / 3.4e7).collect();
    let channel = |name: &str, quantity: hystid::harmonics::Quantity| Channel {
        name: name.into(),
        quantity,
        unit: quantity.si_unit().into(),
        scale: 1.0,
    };
    let meta = RecordingMeta::new(
        fs,
        vec![
            channel("force", hystid::harmonics::Quantity::Force),
            channel("x", hystid::harmonics::Quantity::Displacement),
        ],
        Excitation {
            kind: ExcitationKind::SteppedSine,
            steps: vec![Step {
                frequency_hz: f,
                level: 100.0,
                start: 0,
                settle: 30_000,
                length: n,
            }],
            sweep: None,
        },
    );
    let stem = dir.path().join("long");
    let mut writer = RecordingWriter::create(&stem, meta).unwrap();
    writer.write_frames(&[&force, &x]).unwrap();
    writer.finish().unwrap();
    let model = write_test(dir.path(), "model.toml", SMALL_TEST);
    let scratch = dir.path().join("scratch");
    let validate = |tmp: &Path, out: &Path| {
        Command::new(env!("CARGO_BIN_EXE_hystid"))
            .args(["validate", "--quiet", "--out"])
            .arg(out)
            .arg(&model)
            .arg(dir.path().join("long.json"))
            .env_remove("CI")
            .env("TMPDIR", tmp)
            .output()
            .unwrap()
    };
    let out = dir.path().join("refused");
    let o = validate(&scratch, &out);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains(&format!("scratch file in {}", scratch.display())) && t.contains("TMPDIR"),
        "{t}"
    );
    assert!(!out.join("validate.json").exists());
    std::fs::create_dir(&scratch).unwrap();
    let out = dir.path().join("validated");
    let o = validate(&scratch, &out);
    assert!(o.status.success(), "{}", text(&o));
    assert!(out.join("validate.json").exists());
    assert_eq!(std::fs::read_dir(&scratch).unwrap().count(), 0);
}

/// `diagnose --domain time --acquisition`: the refit's replays are put
/// through the chain (its time-domain errors move from the plain refit's),
/// diagnosis.json's refit names it, and `validate` of that diagnosis puts
/// its replay through it too; without `--domain time` the flag is refused
/// (exit 2, nothing written).
#[test]
fn a_time_domain_diagnosis_takes_the_acquisition_chain() {
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let run = dir.path().join("run");
    simulated(&test, &run);
    let recording = run.join("recording.json");
    let diagnosed = |name: &str, flags: &[&str]| {
        let out = dir.path().join(name);
        let mut a = vec![
            "diagnose",
            "--quiet",
            recording.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        a.extend(flags);
        (hystid(&a), out)
    };
    let json = |p: &Path| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
    };
    let (o, plain) = diagnosed("plain", &["--domain", "time"]);
    assert!(o.status.success(), "{}", text(&o));
    let (o, chained) = diagnosed("chained", &["--domain", "time", "--acquisition", "4"]);
    assert!(o.status.success(), "{}", text(&o));
    let (plain, chained_json) = (
        json(&plain.join("diagnosis.json")),
        json(&chained.join("diagnosis.json")),
    );
    let refit = |d: &serde_json::Value| d["time_domain"]["refit"].clone();
    let chain = serde_json::json!({"decimated_by": 4, "taps": 31});
    assert!(refit(&plain).get("acquisition").is_none());
    assert_eq!(refit(&chained_json)["acquisition"], chain);
    let e = |d: &serde_json::Value| refit(d)["after"][0]["window"]["e_rms"].as_f64().unwrap();
    assert!(
        e(&plain) != e(&chained_json),
        "{} {}",
        e(&plain),
        e(&chained_json)
    );
    let val = dir.path().join("val");
    let o = hystid(&[
        "validate",
        "--quiet",
        chained.join("diagnosis.json").to_str().unwrap(),
        recording.to_str().unwrap(),
        "--out",
        val.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(json(&val.join("validate.json"))["acquisition"], chain);
    let (o, refused) = diagnosed("refused", &["--acquisition", "4"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("add --domain time"), "{}", text(&o));
    assert!(!refused.exists());
}

/// A model file's `[acquisition]` reaches `validate`: the replay is put
/// through the chain (the error moves, by the FIR's droop at the response's
/// frequencies), `validate.json` names the chain, and a chain that is not
/// one (a factor of 1, an even number of taps, an unknown key) is refused
/// with exit code 2, naming the file and `acquisition`, nothing written.
#[test]
fn a_declared_acquisition_is_put_through_by_validate() {
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let run = dir.path().join("run");
    simulated(&test, &run);
    let recording = run.join("recording.json");
    let validated = |name: &str, acquisition: &str| {
        let model = write_test(
            dir.path(),
            &format!("{name}.toml"),
            &format!("{SMALL_TEST}\n{acquisition}"),
        );
        let out = dir.path().join(name);
        let o = hystid(&[
            "validate",
            "--quiet",
            model.to_str().unwrap(),
            recording.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        (o, out)
    };
    let report = |out: &Path| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(out.join("validate.json")).unwrap()).unwrap()
    };
    let e_rms = |v: &serde_json::Value| v["recordings"][0]["whole"]["e_rms"].as_f64().unwrap();
    let (o, plain) = validated("plain", "");
    assert!(o.status.success(), "{}", text(&o));
    let (o, chained) = validated("chained", "[acquisition]\ndecimated_by = 4\n");
    assert!(o.status.success(), "{}", text(&o));
    let (plain, chained) = (report(&plain), report(&chained));
    assert!(plain.get("acquisition").is_none());
    assert_eq!(
        chained["acquisition"],
        serde_json::json!({"decimated_by": 4, "taps": 31})
    );
    let (a, b) = (e_rms(&plain), e_rms(&chained));
    assert!(a.is_finite() && b.is_finite() && a != b, "{a} {b}");
    for (i, bad) in [
        "[acquisition]\ndecimated_by = 1\n",
        "[acquisition]\ndecimated_by = 20\ntaps = 30\n",
        "[acquisition]\ndecimate = 20\n",
    ]
    .into_iter()
    .enumerate()
    {
        let name = format!("bad{i}");
        let (o, out) = validated(&name, bad);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{bad}: {t}");
        assert!(
            t.contains(&format!("{name}.toml")) && t.contains("acquisition"),
            "{bad}: {t}"
        );
        assert!(!out.join("validate.json").exists());
    }
    // a model file's chain given to the FRF fit (which compares harmonics as
    // recorded) is said to be left aside, not dropped silently
    let declared = dir.path().join("fit_declared");
    let o = hystid(&[
        "identify",
        recording.to_str().unwrap(),
        "--start",
        dir.path().join("chained.toml").to_str().unwrap(),
        "--out",
        declared.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains(
            "chained.toml: its acquisition chain is put through by the time-domain fit only"
        ),
        "{}",
        text(&o)
    );
    // `identify` takes the chain for its time-domain fit only, and refuses
    // one that is not a chain before it writes anything
    for (flags, expected) in [
        (&["--acquisition", "4"][..], "add --domain time"),
        (
            &["--max-judged-samples", "1000"][..],
            "--max-judged-samples: only the time-domain fit judges samples; add --domain time",
        ),
        (
            &["--domain", "time", "--acquisition", "1"][..],
            "--acquisition",
        ),
    ] {
        let out = dir.path().join("fit_refused");
        let mut a = vec![
            "identify",
            "--quiet",
            recording.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        a.extend(flags);
        let o = hystid(&a);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{flags:?}: {t}");
        assert!(t.contains(expected), "{flags:?}: {t}");
        assert!(!out.exists(), "{flags:?}: an output was left");
    }
}

/// `diagnose --domain time --each-alone` refits the final refit's
/// recordings alone and reports them in diagnosis.json
/// (`time_domain.refit.each_alone`, beside the refit's `after`), in
/// diagnosis.md (a table and the note) and on the terminal: on the same
/// recording given twice, the consistent case, alone comes no closer than
/// together (1.00x), and the note says the misfit is shared.
#[test]
fn a_time_diagnosis_refits_each_recording_alone_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let run = dir.path().join("run");
    simulated(&test, &run);
    let recording = run.join("recording.json");
    let r = recording.to_str().unwrap();
    let out = dir.path().join("diag");
    let o = hystid(&[
        "diagnose",
        r,
        r,
        "--domain",
        "time",
        "--each-alone",
        "--out",
        out.to_str().unwrap(),
    ]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let d: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("diagnosis.json")).unwrap()).unwrap();
    let refit = &d["time_domain"]["refit"];
    let alone = refit["each_alone"].as_array().expect("each_alone");
    assert_eq!(alone.len(), 2);
    for (a, after) in alone.iter().zip(refit["after"].as_array().unwrap()) {
        assert_eq!(a["together"], after["window"]["relative"]);
        let ratio = a["together"].as_f64().unwrap() / a["alone"].as_f64().unwrap();
        assert!((ratio - 1.0).abs() < 1e-3, "{a}");
    }
    let md = std::fs::read_to_string(out.join("diagnosis.md")).unwrap();
    assert!(md.contains("| recording | together | alone |"), "{md}");
    assert!(
        md.contains("Refitted alone, the recordings come 1.00x closer")
            && md.contains("shared by every recording"),
        "{md}"
    );
    assert!(
        t.contains("refitted alone: ") && t.contains("1.00x closer"),
        "{t}"
    );
}

/// `identify --each-alone` (and `diagnose --each-alone`) refits each of
/// several recordings alone in the time domain: without `--domain time`,
/// or with one recording, it is refused before anything is written (exit
/// 2, the flag named). What it
/// reports is tested in `fit::time` (a wrong dependence on level against a
/// consistent one), on the UNESP chirps (`cli_realdata`) and through the
/// Python package (the same recording twice: 1.00x).
#[test]
fn each_alone_is_refused_where_nothing_can_be_refitted_alone() {
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let run = dir.path().join("run");
    simulated(&test, &run);
    let recording = run.join("recording.json");
    let r = recording.to_str().unwrap();
    let cases = [
        (vec![r, r], &["--each-alone"][..], "add --domain time"),
        (
            vec![r],
            &["--domain", "time", "--each-alone"][..],
            "give two or more",
        ),
    ];
    for (command, (recordings, flags, expected)) in ["identify", "diagnose"]
        .into_iter()
        .flat_map(|c| cases.iter().cloned().map(move |case| (c, case)))
    {
        let out = dir.path().join("refused");
        let mut a = vec![command, "--quiet"];
        a.extend(recordings);
        a.extend(["--out", out.to_str().unwrap()]);
        a.extend(flags);
        let o = hystid(&a);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{flags:?}: {t}");
        assert!(
            t.contains("--each-alone") && t.contains(expected),
            "{flags:?}: {t}"
        );
        assert!(!out.exists(), "{flags:?}: an output was left");
    }
}
