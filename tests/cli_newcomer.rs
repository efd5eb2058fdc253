//! Integration tests: what a new user trips on, through the `hystid`
//! binary. Every bad input exits with 2, names the file and the field (or
//! the flag) and what was expected, and leaves no output behind.

use crate::cli::{SMALL_TEST, hystid, text, write_test};
use std::path::{Path, PathBuf};

/// A plain WAV (no sidecar): a force and an acceleration at 8 kHz, 16-bit.
fn plain_wav(dir: &Path, name: &str) -> PathBuf {
    let path = dir.join(name);
    let spec = hound::WavSpec {
        channels: 2,
        sample_rate: 8000,
        bits_per_sample: 16,
        sample_format: hound::SampleFormat::Int,
    };
    let mut w = hound::WavWriter::create(&path, spec).unwrap();
    for i in 0..8000 {
        let t = i as f64 / 8000.0;
        let f = (2.0 * std::f64::consts::PI * 100.0 * t).sin();
        w.write_sample((0.5 * f * 32767.0).round() as i16).unwrap();
        w.write_sample((-0.25 * f * 32767.0).round() as i16)
            .unwrap();
    }
    w.finalize().unwrap();
    path
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|r| {
            r.map(|e| e.unwrap().file_name().into_string().unwrap())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Runs `hystid args`, which must be refused with exit 2 and a message
/// holding every one of `needles`; returns the message.
fn refused(args: &[&str], needles: &[&str]) -> String {
    let o = hystid(args);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {t}");
    assert!(!t.contains("panicked"), "{args:?}: {t}");
    for n in needles {
        assert!(t.contains(n), "{args:?}: `{n}` not in: {t}");
    }
    t
}

/// A WAV without its JSON sidecar imports when its channels are named
/// with `-c NAME=#K:QUANTITY` (the rate from its header, or `--rate`);
/// without channels, the missing sidecar is said with the `-c` form to use.
#[test]
fn a_plain_wav_imports_with_its_channels_named() {
    let dir = tempfile::tempdir().unwrap();
    let wav = plain_wav(dir.path(), "plain.wav");
    let w = wav.to_str().unwrap();
    for (k, rate) in [&["--rate", "8000"][..], &[][..]].into_iter().enumerate() {
        let out = dir.path().join(format!("pw{k}"));
        let out_arg = format!("{}/", out.display());
        let mut a = vec![
            "import",
            w,
            "--out",
            &out_arg,
            "-c",
            "force=#1:force",
            "-c",
            "acc=#2:acceleration*9.81",
        ];
        a.extend(rate);
        let o = hystid(&a);
        assert!(o.status.success(), "{rate:?}: {}", text(&o));
        let rec = hystid::record::read_recording(&out.join("plain.json")).unwrap();
        assert_eq!(rec.meta.sample_rate_hz, 8000.0);
        let names: Vec<&str> = rec.meta.channels.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["force", "acc"]);
        // integer samples as fractions of full scale, times the scale
        let peak = |c: usize| rec.channels[c].iter().fold(0f64, |m, v| m.max(v.abs()));
        assert!((peak(0) - 0.5).abs() < 1e-3, "{}", peak(0));
        assert!((peak(1) - 0.25 * 9.81).abs() < 1e-2, "{}", peak(1));
    }
    // read as a recording: import it first
    refused(
        &[
            "identify",
            w,
            "--out",
            dir.path().join("d").to_str().unwrap(),
        ],
        &["plain.json", "hystid import", "-c force=#1:force"],
    );
    // no channels: the sidecar is missing, and the form to use
    let out = dir.path().join("none");
    refused(
        &["import", w, "--out", out.to_str().unwrap()],
        &["plain.json", "-c force=#1:force", "2 channel(s) at 8000 Hz"],
    );
    assert!(!out.exists());
    // a named source, a channel the file lacks, a rate it cannot take
    for (c, rate, needles) in [
        ("force=Force:force", "auto", &["plain.wav", "#1 to #2"][..]),
        ("force=#3:force", "auto", &["plain.wav", "#3", "#1 to #2"]),
        ("force=#1:force", "comment", &["plain.wav", "sample_rate"]),
    ] {
        let out = dir.path().join("bad");
        refused(
            &[
                "import",
                w,
                "--out",
                out.to_str().unwrap(),
                "-c",
                c,
                "--rate",
                rate,
            ],
            needles,
        );
        assert!(!out.exists());
    }
}

/// A directory where files are read is refused as one, with the files in
/// it that would do: recordings for `identify`, importable files for
/// `import`, and a fit.json for `validate`'s model.
#[test]
fn a_directory_given_as_input_is_refused_with_its_files() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("unesp");
    std::fs::create_dir(&data).unwrap();
    plain_wav(&data, "shaker.wav");
    let d = data.to_str().unwrap();
    let out = dir.path().join("d1");
    let o = out.to_str().unwrap();
    refused(
        &["identify", d, "--out", o],
        &[
            "is a directory",
            "holds no recording",
            "shaker.wav",
            "hystid import",
        ],
    );
    refused(
        &["import", d, "--out", &format!("{o}/")],
        &["is a directory", "one file at a time", "shaker.wav"],
    );
    // with a recording in it, that is the one named
    let o2 = hystid(&[
        "import",
        data.join("shaker.wav").to_str().unwrap(),
        "--out",
        data.join("rec").to_str().unwrap(),
        "-c",
        "force=#1:force",
        "-c",
        "acc=#2:acceleration",
    ]);
    assert!(o2.status.success(), "{}", text(&o2));
    for command in ["identify", "diagnose"] {
        refused(
            &[command, d, "--out", o],
            &["is a directory", "rec.wav", &format!("hystid {command} ")],
        );
    }
    refused(
        &[
            "validate",
            d,
            data.join("rec.wav").to_str().unwrap(),
            "--out",
            o,
        ],
        &["is a directory", "name the model file"],
    );
    assert!(!out.exists());
}

/// A quantity mistyped in `-c` names the flag, the quantity and the
/// valid ones (as the library lists them), not a test definition.
#[test]
fn a_mistyped_quantity_names_the_flag_and_the_valid_quantities() {
    let dir = tempfile::tempdir().unwrap();
    let csv = write_test(
        dir.path(),
        "laser.csv",
        "# fs = 1000 Hz\nforce,laser_velocity_m_per_s\n1,2\n3,4\n",
    );
    let out = dir.path().join("x");
    let valid = hystid::harmonics::Quantity::ALL
        .map(|q| q.name())
        .join(", ");
    let t = refused(
        &[
            "import",
            csv.to_str().unwrap(),
            "--out",
            &format!("{}/", out.display()),
            "-c",
            "force=force:force",
            "-c",
            "laser=laser_velocity_m_per_s:velocty",
        ],
        &["-c/--channel", "`velocty`", &valid],
    );
    assert!(!t.contains("test definition"), "{t}");
    assert!(!out.exists());
}

/// A test definition's refused value names the file and the field: a
/// noise above 1 (a percentage written as one) with the fraction meant, a
/// negative level or mass, and an unknown joint kind with exactly the
/// registry's joint laws and `none`.
#[test]
fn test_definition_errors_name_the_file_and_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let joints: Vec<&str> = hystid::model::ElementKind::joints()
        .map(|k| k.name())
        .collect();
    let joint_list = format!("expected one of {}, or none", joints.join(", "));
    let cases = [
        (
            SMALL_TEST.replace("noise = 0.10", "noise = 5"),
            vec!["test.noise", "noise = 0.05", "[0, 1]"],
        ),
        (
            SMALL_TEST.replace("levels_n = [50.0,", "levels_n = [-5.0,"),
            vec!["test.levels_n[0]", "> 0 N"],
        ),
        (
            SMALL_TEST.replace("mass = 10.0", "mass = -2.0"),
            vec!["system.mass"],
        ),
        (
            SMALL_TEST.replace("kind = \"jenkins\"", "kind = \"massing\""),
            vec!["`massing`", &joint_list],
        ),
    ];
    for (i, (t, needles)) in cases.iter().enumerate() {
        let name = format!("newcomer{i}.toml");
        let test = write_test(dir.path(), &name, t);
        let out = dir.path().join(format!("out{i}"));
        let mut needles = needles.clone();
        needles.push(&name);
        let msg = refused(
            &[
                "simulate",
                test.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ],
            &needles,
        );
        assert!(!out.exists(), "case {i} left {:?}", entries(&out));
        if i == 3 {
            // effects are not joint kinds
            assert!(!msg.contains("cubic_stiffness"), "{msg}");
        }
    }
}

/// An `--out` that is a file (or under one) is refused before any work, by
/// every command that takes it; the file is left as it was.
#[test]
fn an_output_that_is_a_file_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let wav = plain_wav(dir.path(), "plain.wav");
    let o = hystid(&[
        "import",
        wav.to_str().unwrap(),
        "--out",
        dir.path().join("rec").to_str().unwrap(),
        "-c",
        "force=#1:force",
        "-c",
        "acc=#2:acceleration",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let rec = dir.path().join("rec.wav");
    let taken = write_test(dir.path(), "taken", "mine");
    let (t, r, w) = (
        test.to_str().unwrap(),
        rec.to_str().unwrap(),
        wav.to_str().unwrap(),
    );
    for out in [taken.clone(), taken.join("sub")] {
        let o = out.to_str().unwrap();
        let slash = format!("{o}/");
        let commands: [Vec<&str>; 6] = [
            vec!["simulate", t, "--out", o],
            vec!["run", t, "--out", o],
            vec!["identify", r, "--out", o],
            vec!["diagnose", r, "--out", o],
            vec!["validate", t, r, "--out", o],
            vec!["import", w, "--out", &slash, "-c", "f=#1:force"],
        ];
        for a in commands {
            let start = std::time::Instant::now();
            refused(&a, &["--out", "is a file, not a folder"]);
            // refused before reading or reducing anything
            assert!(start.elapsed().as_secs_f64() < 2.0, "{a:?}");
        }
    }
    assert_eq!(std::fs::read_to_string(&taken).unwrap(), "mine");
}

/// fit.json and run.json say one thing per parameter: `identifiable` is
/// false exactly where the flags say `not_identifiable`. Here a Masing
/// joint of curvature 60 under 70 % noise: its final model's `n` has an
/// interval without an upper end, which the flags said and
/// `identifiable` did not.
#[test]
fn identifiable_agrees_with_the_flags_in_fit_and_run_json() {
    let dir = tempfile::tempdir().unwrap();
    let def = SMALL_TEST
        .replace("kind = \"jenkins\"", "kind = \"masing\"\nn = 60")
        .replace("noise = 0.10", "noise = 0.7")
        .replace("count = 11", "count = 7")
        .replace("seed = 4", "seed = 2");
    let test = write_test(dir.path(), "masing.toml", &def);
    let out = dir.path().join("run");
    let o = hystid(&[
        "run",
        test.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
        "--no-recording",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let read = |f: &str| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(out.join(f)).unwrap()).unwrap()
    };
    let not_identifiable = |flags: &serde_json::Value| {
        flags
            .as_array()
            .is_some_and(|f| f.iter().any(|f| f == "not_identifiable"))
    };
    let run = read("run.json");
    let fin = run["final"]["parameters"].as_object().unwrap();
    assert!(not_identifiable(&fin["n"]["flags"]), "{}", fin["n"]);
    for (name, e) in fin {
        assert_eq!(
            e["identifiable"].as_bool(),
            Some(!not_identifiable(&e["flags"])),
            "run.json final {name}: {e}"
        );
    }
    let fit = read("fit.json");
    assert!(not_identifiable(&fit["flags"]["n"]), "{}", fit["flags"]);
    for (name, e) in fit["parameters"].as_object().unwrap() {
        assert_eq!(
            e["identifiable"].as_bool(),
            Some(!not_identifiable(&fit["flags"][name])),
            "fit.json {name}: {e} beside flags {}",
            fit["flags"]
        );
    }
}

/// Ctrl-C during `run` stops it at the stage's next check: exit 130, said
/// on the terminal, and neither a temporary nor the lock left in the
/// output folder.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[test]
fn ctrl_c_during_run_leaves_no_temporary_and_no_lock() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    // the default test: long enough to be interrupted while recording
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_hystid"))
        .args(["run", "--out", out.to_str().unwrap(), "--quiet"])
        .env_remove("CI")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // interrupted once it writes: a temporary in the folder
    let start = std::time::Instant::now();
    while !entries(&out).iter().any(|f| f.contains(".tmp")) {
        assert!(start.elapsed().as_secs() < 60, "{:?}", entries(&out));
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    // SAFETY: a signal to the child this test spawned
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGINT) }, 0);
    let o = child.wait_with_output().unwrap();
    let t = text(&o);
    assert_eq!(o.status.code(), Some(130), "{t}");
    assert!(t.contains("interrupted"), "{t}");
    let left = entries(&out);
    assert!(
        !left
            .iter()
            .any(|f| f.contains(".tmp") || f == hystid::atomic::LOCK_FILE),
        "{left:?}"
    );
}

/// A recording (WAV + JSON) of `columns` of the simulated `sim` recording
/// (each `(name, quantity, unit, column, factor)`), its virtual test's
/// description left out, as a measured recording has none.
fn recording_of(sim: &Path, out: &Path, columns: &[(&str, &str, &str, usize, f32)]) -> PathBuf {
    let mut reader = hound::WavReader::open(sim.join("recording.wav")).unwrap();
    let spec = reader.spec();
    assert_eq!(spec.sample_format, hound::SampleFormat::Float);
    let width = spec.channels as usize;
    let samples: Vec<f32> = reader.samples::<f32>().map(Result::unwrap).collect();
    let mut w = hound::WavWriter::create(
        out.with_extension("wav"),
        hound::WavSpec {
            channels: columns.len() as u16,
            ..spec
        },
    )
    .unwrap();
    for frame in samples.chunks(width) {
        for &(_, _, _, c, factor) in columns {
            w.write_sample(factor * frame[c]).unwrap();
        }
    }
    w.finalize().unwrap();
    let mut meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(sim.join("recording.json")).unwrap()).unwrap();
    meta.as_object_mut().unwrap().remove("metadata");
    meta["channels"] = columns
        .iter()
        .map(|&(name, quantity, unit, _, _)| {
            serde_json::json!({"name": name, "quantity": quantity, "unit": unit, "scale": 1.0})
        })
        .collect();
    let json = out.with_extension("json");
    std::fs::write(&json, serde_json::to_vec_pretty(&meta).unwrap()).unwrap();
    json
}

/// A model fitted to recordings holding one response (`acc2`) names it in
/// fit.json, and `validate` compares it with that channel on a recording
/// holding several (not with the first, `acc1`), says so, and names it in
/// validate.json; `--response` still chooses another.
#[test]
fn validate_compares_the_response_the_model_was_fitted_to() {
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let sim = dir.path().join("sim");
    crate::cli::simulated(&test, &sim);
    // the simulated columns: force, displacement, velocity, acceleration
    let only = recording_of(
        &sim,
        &dir.path().join("only_acc2"),
        &[
            ("force", "force", "N", 0, 1.0),
            ("acc2", "acceleration", "m/s^2", 3, 1.0),
        ],
    );
    // acc1 another point of the structure: three times the motion
    let several = recording_of(
        &sim,
        &dir.path().join("three"),
        &[
            ("force", "force", "N", 0, 1.0),
            ("acc1", "acceleration", "m/s^2", 3, 3.0),
            ("acc2", "acceleration", "m/s^2", 3, 1.0),
            ("acc3", "acceleration", "m/s^2", 3, -1.0),
        ],
    );
    let fit = dir.path().join("fit");
    let o = hystid(&[
        "identify",
        only.to_str().unwrap(),
        "--start",
        test.to_str().unwrap(),
        "--out",
        fit.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let read = |p: &Path| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
    };
    let fitted = read(&fit.join("fit.json"));
    assert_eq!(fitted["response"], "acc2");
    // the recordings fitted to: a list of the paths as given
    assert_eq!(
        fitted["recording"],
        serde_json::json!([only.to_str().unwrap()])
    );
    let validated = |tag: &str, extra: &[&str]| {
        let out = dir.path().join(tag);
        let mut a: Vec<String> = vec![
            "validate".to_string(),
            fit.join("fit.json").to_str().unwrap().to_string(),
            several.to_str().unwrap().to_string(),
            "--no-frf".to_string(),
            "--out".to_string(),
            out.to_str().unwrap().to_string(),
        ];
        a.extend(extra.iter().map(|s| s.to_string()));
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let o = hystid(&a);
        assert!(o.status.success(), "{}", text(&o));
        let r = read(&out.join("validate.json"))["recordings"][0].clone();
        (text(&o), r)
    };
    let (t, r) = validated("val", &[]);
    assert_eq!(r["response"], "acc2", "{r}");
    assert!(
        t.contains("`acc2` (the response the model was fitted to)"),
        "{t}"
    );
    let fitted = r["whole"]["relative"].as_f64().unwrap();
    let (_, r) = validated("val_acc1", &["--response", "acc1"]);
    assert_eq!(r["response"], "acc1", "{r}");
    let other = r["whole"]["relative"].as_f64().unwrap();
    assert!(fitted < 0.3 && other > 0.5, "acc2 {fitted}, acc1 {other}");
    // a recording without the fitted channel: its own response, said
    let plain = recording_of(
        &sim,
        &dir.path().join("acc1_only"),
        &[
            ("force", "force", "N", 0, 1.0),
            ("acc1", "acceleration", "m/s^2", 3, 1.0),
        ],
    );
    let out = dir.path().join("val_plain");
    let o = hystid(&[
        "validate",
        fit.join("fit.json").to_str().unwrap(),
        plain.to_str().unwrap(),
        "--no-frf",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("no channel `acc2`, the response the model was fitted to"),
        "{}",
        text(&o)
    );
    assert_eq!(
        read(&out.join("validate.json"))["recordings"][0]["response"],
        "acc1"
    );
}

/// On FRFs measured against a force, the shaker between a voltage and the
/// structure has nothing to model: diagnosis.md and diagnosis.json say it
/// is not applicable, not that it failed.
#[test]
fn the_shaker_is_not_applicable_on_a_force_reference() {
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let sim = dir.path().join("sim");
    crate::cli::simulated(&test, &sim);
    let out = dir.path().join("diag");
    let o = hystid(&[
        "diagnose",
        sim.join("recording.json").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let md = std::fs::read_to_string(out.join("diagnosis.md")).unwrap();
    let row = md
        .lines()
        .find(|l| l.starts_with("| shaker |"))
        .unwrap_or_else(|| panic!("no shaker row: {md}"));
    assert!(
        row.contains("| not applicable |") && !row.contains("failed"),
        "{row}"
    );
    let d: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("diagnosis.json")).unwrap()).unwrap();
    let shaker = d["failed"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["effect"] == "shaker")
        .unwrap();
    assert_eq!(shaker["not_applicable"], true, "{shaker}");
}

/// fit.json's `recording` lists the recordings as given, one entry each;
/// a fit.json of an earlier version (one comma-joined string) still reads.
#[test]
fn fit_json_lists_its_recordings_as_given() {
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let sim = dir.path().join("sim");
    crate::cli::simulated(&test, &sim);
    let rec = sim.join("recording.json");
    let again = dir.path().join("again.json");
    std::fs::copy(sim.join("recording.wav"), dir.path().join("again.wav")).unwrap();
    std::fs::copy(&rec, &again).unwrap();
    let fit = dir.path().join("fit");
    let o = hystid(&[
        "identify",
        rec.to_str().unwrap(),
        again.to_str().unwrap(),
        "--start",
        test.to_str().unwrap(),
        "--out",
        fit.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let mut f: serde_json::Value =
        serde_json::from_slice(&std::fs::read(fit.join("fit.json")).unwrap()).unwrap();
    assert_eq!(
        f["recording"],
        serde_json::json!([rec.to_str().unwrap(), again.to_str().unwrap()])
    );
    f["recording"] = serde_json::json!(format!("{}, {}", rec.display(), again.display()));
    let old = dir.path().join("old_fit.json");
    std::fs::write(&old, serde_json::to_vec(&f).unwrap()).unwrap();
    let o = hystid(&[
        "validate",
        old.to_str().unwrap(),
        rec.to_str().unwrap(),
        "--no-frf",
        "--out",
        dir.path().join("val").to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
}

/// On a voltage reference the model's forces are volts: `identify` gives
/// the linear estimate in the drive's units (V s²/m, not kg), as
/// `diagnose` does; on a force, in newtons' as before.
#[test]
fn identify_gives_the_linear_estimate_in_the_drives_units() {
    let dir = tempfile::tempdir().unwrap();
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let sim = dir.path().join("sim");
    crate::cli::simulated(&test, &sim);
    let driven = recording_of(
        &sim,
        &dir.path().join("driven"),
        &[
            ("drive", "voltage", "V", 0, 1.0),
            ("disp", "displacement", "m", 1, 1.0),
        ],
    );
    let linear_line = |rec: &Path, tag: &str| {
        let out = dir.path().join(tag);
        let o = hystid(&[
            "identify",
            rec.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", text(&o));
        text(&o)
            .lines()
            .find(|l| l.trim_start().starts_with("linear: m ="))
            .unwrap_or_else(|| panic!("no linear line: {}", text(&o)))
            .to_string()
    };
    let volts = linear_line(&driven, "fit_v");
    assert!(
        volts.contains("V s²/m,") && volts.contains("V s/m,") && !volts.contains("kg"),
        "{volts}"
    );
    let newtons = linear_line(&sim.join("recording.json"), "fit_n");
    assert!(
        newtons.contains(" kg,") && newtons.contains("N s/m,"),
        "{newtons}"
    );
}

/// Whether `line` names a newton-based unit: a word `N` or `kg`.
fn in_newtons(line: &str) -> bool {
    line.split(|c: char| !c.is_alphanumeric())
        .any(|w| w == "N" || w == "kg")
}

/// On a voltage reference every fitted parameter is stated in volts: the
/// parameter lines of `identify` and of `diagnose` on the terminal, the
/// effect the diagnosis adds in its account, and the parameter tables of
/// diagnosis.md (the final model's and the candidates'); none says N or kg.
/// On the force reference the same lines say N and kg.
#[test]
fn parameters_are_stated_in_the_drives_units() {
    let dir = tempfile::tempdir().unwrap();
    // a cubic stiffness the diagnosis finds (as `run` does on it in cli.rs)
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
    let sim = dir.path().join("sim");
    crate::cli::simulated(&test, &sim);
    let driven = recording_of(
        &sim,
        &dir.path().join("driven"),
        &[
            ("drive", "voltage", "V", 0, 1.0),
            ("disp", "displacement", "m", 1, 1.0),
        ],
    );
    let run = |command: &str, rec: &Path, tag: &str| {
        let out = dir.path().join(tag);
        let o = hystid(&[
            command,
            rec.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", text(&o));
        (text(&o), out)
    };
    // a parameter's line, `name = value ...` (identify: `ci95 [..]`,
    // diagnose: `95 % [..]`)
    let line_of = |t: &str, name: &str| -> String {
        t.lines()
            .find(|l| l.trim_start().starts_with(&format!("{name} =")) && l.contains('['))
            .unwrap_or_else(|| panic!("no line for {name}: {t}"))
            .to_string()
    };
    // the SMALL_TEST joint fits as a Masing or Jenkins law: fd and kd
    let volts = [
        ("mass", "V s²/m"),
        ("damping", "V s/m"),
        ("stiffness", "V/m"),
        ("kd", "V/m"),
        ("fd", "V"),
    ];
    for command in ["identify", "diagnose"] {
        let (t, _) = run(command, &driven, &format!("{command}_v"));
        for (name, unit) in volts {
            let l = line_of(&t, name);
            assert!(
                l.trim_end().ends_with(&format!("] {unit}")),
                "{command}: {l}"
            );
            assert!(!in_newtons(&l), "{command}: {l}");
        }
        let (t, _) = run(
            command,
            &sim.join("recording.json"),
            &format!("{command}_n"),
        );
        assert!(line_of(&t, "mass").contains("] kg"), "{t}");
        assert!(line_of(&t, "fd").contains("] N"), "{t}");
    }
    let (t, out) = run("diagnose", &driven, "diagnose_md");
    let account = t
        .lines()
        .find(|l| l.starts_with("hystid diagnose:"))
        .unwrap();
    assert!(
        account.contains("cubic_stiffness added (k3 = "),
        "{account}"
    );
    assert!(
        account.contains(" V/m³)") && !in_newtons(account),
        "{account}"
    );
    assert!(line_of(&t, "cubic_stiffness.k3").ends_with("] V/m³"), "{t}");
    let md = std::fs::read_to_string(out.join("diagnosis.md")).unwrap();
    // the final model's table: `| mass | 10.00238 V s²/m | [..] | |`
    for (name, unit) in volts {
        let row = md
            .lines()
            .find(|l| l.starts_with(&format!("| {name} | ")))
            .unwrap_or_else(|| panic!("no row for {name}: {md}"));
        assert!(row.contains(&format!(" {unit} | [")), "{row}");
    }
    // the candidates' table: cubic stiffness's k3 in V/m³
    let cubic = md
        .lines()
        .find(|l| l.starts_with("| cubic_stiffness |"))
        .unwrap_or_else(|| panic!("no cubic_stiffness row: {md}"));
    assert!(cubic.contains(" V/m³"), "{cubic}");
    let tables: Vec<&str> = md.lines().filter(|l| l.starts_with("| ")).collect();
    for row in tables {
        assert!(!in_newtons(row), "{row}");
    }
}

/// `diagnose`'s FRF figure exists and diagnosis.md shows it with a caption
/// (a relative link); its legend names each level once, rounded to 3
/// significant digits in the drive's unit, and each kind of line once
/// (measured, baseline model, final model), not each level's model apart.
#[test]
fn the_diagnosis_figure_is_in_the_report_with_a_short_legend() {
    let dir = tempfile::tempdir().unwrap();
    let levels = SMALL_TEST.replace("levels_n = [50.0, 3000.0]", "levels_n = [57.7418, 3000.0]");
    let test = write_test(dir.path(), "small.toml", &levels);
    let sim = dir.path().join("sim");
    crate::cli::simulated(&test, &sim);
    let driven = recording_of(
        &sim,
        &dir.path().join("driven"),
        &[
            ("drive", "voltage", "V", 0, 1.0),
            ("disp", "displacement", "m", 1, 1.0),
        ],
    );
    let out = dir.path().join("diag");
    let o = hystid(&[
        "diagnose",
        driven.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let png = std::fs::metadata(out.join("diagnosis_frf.png")).unwrap();
    assert!(png.len() > 1000, "{} bytes", png.len());
    let md = std::fs::read_to_string(out.join("diagnosis.md")).unwrap();
    assert!(md.contains("](diagnosis_frf.png)\n"), "{md}");
    assert!(
        md.lines().any(
            |l| l.starts_with("*[diagnosis_frf.png](diagnosis_frf.png): ")
                && l.contains("baseline")
        ),
        "no caption: {md}"
    );
    let svg = std::fs::read_to_string(out.join("diagnosis_frf.svg")).unwrap();
    let texts: Vec<&str> = svg
        .split("<text")
        .skip(1)
        .filter_map(|t| t.split_once('>').and_then(|(_, r)| r.split_once("</text>")))
        .map(|(t, _)| t.trim())
        .collect();
    for entry in [
        "57.7 V",
        "3000 V",
        "measured",
        "baseline model",
        "final model",
    ] {
        assert_eq!(
            texts.iter().filter(|t| **t == entry).count(),
            1,
            "`{entry}` not once in {texts:?}"
        );
    }
    assert!(
        !texts
            .iter()
            .any(|t| t.contains("(model)") || t.contains("57.74")),
        "{texts:?}"
    );
}

/// Clipping found at import reaches `identify` and `diagnose`: the import's
/// quality report beside a recording gives a warning on the terminal, a note
/// in fit.json, `quality_warnings` in diagnosis.json and a section in
/// diagnosis.md; a recording without one gives none of these.
#[test]
fn import_quality_warnings_reach_identify_and_diagnose() {
    let dir = tempfile::tempdir().unwrap();
    // a force clipped at 0.8 of its amplitude: flat tops at both extremes
    let mut csv = String::from("force,acc\n");
    for i in 0..8000 {
        let s = (2.0 * std::f64::consts::PI * 100.0 * i as f64 / 8000.0).sin();
        csv += &format!("{},{}\n", s.clamp(-0.8, 0.8), -0.25 * s);
    }
    let clipped = dir.path().join("clipped.csv");
    std::fs::write(&clipped, csv).unwrap();
    let imported = dir.path().join("imp");
    let o = hystid(&[
        "import",
        clipped.to_str().unwrap(),
        "--out",
        &format!("{}/", imported.display()),
        "--rate",
        "8000",
        "-c",
        "force=#1:force",
        "-c",
        "acc=#2:acceleration",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let report = imported.join("clipped.quality.json");
    assert!(
        std::fs::read_to_string(&report)
            .unwrap()
            .contains("clipped")
    );
    // a recording identify can fit, the import's report beside it
    let test = write_test(dir.path(), "small.toml", SMALL_TEST);
    let sim = dir.path().join("sim");
    crate::cli::simulated(&test, &sim);
    let columns = [
        ("force", "force", "N", 0, 1.0),
        ("disp", "displacement", "m", 1, 1.0),
    ];
    let rec = recording_of(&sim, &dir.path().join("rec"), &columns);
    std::fs::copy(&report, dir.path().join("rec.quality.json")).unwrap();
    let plain = recording_of(&sim, &dir.path().join("plain"), &columns);
    let run = |cmd: &str, rec: &Path, out: &str| {
        let out = dir.path().join(out);
        let r = rec.to_str().unwrap();
        let o = hystid(&[cmd, r, "--out", out.to_str().unwrap(), "--quiet"]);
        assert!(o.status.success(), "{}", text(&o));
        (out, String::from_utf8_lossy(&o.stderr).to_string())
    };
    let read = |p: PathBuf| std::fs::read_to_string(p).unwrap();
    let said = format!("{}: warning: channel `force` looks clipped", rec.display());
    let (fit, err) = run("identify", &rec, "fit");
    assert!(err.contains(&format!("warning: {said}")), "{err}");
    let f: serde_json::Value = serde_json::from_str(&read(fit.join("fit.json"))).unwrap();
    let notes = f["notes"].as_array().unwrap();
    assert!(
        notes.iter().any(|n| n.as_str().unwrap().starts_with(&said)),
        "{notes:?}"
    );
    let (diag, err) = run("diagnose", &rec, "diag");
    assert!(err.contains(&said), "{err}");
    let d: serde_json::Value = serde_json::from_str(&read(diag.join("diagnosis.json"))).unwrap();
    assert!(
        d["quality_warnings"][0]
            .as_str()
            .unwrap()
            .starts_with(&said)
    );
    let md = read(diag.join("diagnosis.md"));
    assert!(md.contains("## Data quality") && md.contains(&said), "{md}");
    // no report beside it: nothing said
    let (fit, err) = run("identify", &plain, "fit_plain");
    assert!(!err.contains("quality report"), "{err}");
    assert!(!read(fit.join("fit.json")).contains("quality report"));
    let (diag, _) = run("diagnose", &plain, "diag_plain");
    assert!(!read(diag.join("diagnosis.json")).contains("quality_warnings"));
    assert!(!read(diag.join("diagnosis.md")).contains("Data quality"));
}

/// A linear SDOF (m, c, k) driven by `force` sampled at `fs`, from rest:
/// RK4 at 10 sub-steps a sample, the force interpolated linearly between
/// samples (as a replay takes it); the displacement at each sample.
fn sdof_response(force: &[f64], fs: f64, (m, c, k): (f64, f64, f64)) -> Vec<f64> {
    let sub = 10;
    let h = 1.0 / (fs * sub as f64);
    let accel = |x: f64, v: f64, f: f64| (f - c * v - k * x) / m;
    let (mut x, mut v) = (0.0, 0.0);
    let mut out = Vec::with_capacity(force.len());
    for (i, &f0) in force.iter().enumerate() {
        out.push(x);
        let f1 = force.get(i + 1).copied().unwrap_or(f0);
        for s in 0..sub {
            let at = |t: f64| f0 + (f1 - f0) * (s as f64 + t) / sub as f64;
            let (k1x, k1v) = (v, accel(x, v, at(0.0)));
            let (k2x, k2v) = (
                v + h / 2.0 * k1v,
                accel(x + h / 2.0 * k1x, v + h / 2.0 * k1v, at(0.5)),
            );
            let (k3x, k3v) = (
                v + h / 2.0 * k2v,
                accel(x + h / 2.0 * k2x, v + h / 2.0 * k2v, at(0.5)),
            );
            let (k4x, k4v) = (v + h * k3v, accel(x + h * k3x, v + h * k3v, at(1.0)));
            x += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
            v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
        }
    }
    out
}

/// A seeded broadband force (white noise through two 60 Hz one-pole
/// low-passes) of `n` samples at `fs`.
fn broadband_force(n: usize, fs: f64) -> Vec<f64> {
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut white = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let a = (-2.0 * std::f64::consts::PI * 60.0 / fs).exp();
    let (mut y1, mut y2) = (0.0, 0.0);
    (0..n)
        .map(|_| {
            y1 = a * y1 + (1.0 - a) * white() * 200.0;
            y2 = a * y2 + (1.0 - a) * y1;
            y2
        })
        .collect()
}

/// A broadband random force on a linear SDOF (20 Hz, 5 % damping)
/// integrated by RK4, imported from CSV, its excitation unknown or stated
/// `random`: `validate` finds no dwell (or is told) and, instead of
/// failing, compares in the time domain and by H1, saying what it assumed.
/// The measured H1 is the SDOF's receptance in closed form; the true
/// model's replay gives the same H1; a model 10 % stiffer does not.
#[test]
fn a_random_recording_is_validated_in_the_time_domain_and_by_h1() {
    let dir = tempfile::tempdir().unwrap();
    let (fs, n) = (1000.0, 32_000);
    let force = broadband_force(n, fs);
    let (m, k) = (1.0, (2.0 * std::f64::consts::PI * 20.0_f64).powi(2));
    let c = 2.0 * 0.05 * (k * m).sqrt();
    let disp = sdof_response(&force, fs, (m, c, k));
    let csv = dir.path().join("r.csv");
    let mut body = String::from("force,disp\n");
    for (f, x) in force.iter().zip(&disp) {
        body.push_str(&format!("{f:e},{x:e}\n"));
    }
    std::fs::write(&csv, body).unwrap();
    let import = |out: &str, extra: &[&str]| {
        let mut a = vec![
            "import",
            csv.to_str().unwrap(),
            "--out",
            out,
            "-c",
            "force=#1:force",
            "-c",
            "disp=#2:displacement",
            "--rate",
            "1000",
        ];
        a.extend(extra);
        let o = hystid(&a);
        assert!(o.status.success(), "{}", text(&o));
    };
    let unknown = format!("{}/", dir.path().join("unknown").display());
    let stated = format!("{}/", dir.path().join("stated").display());
    import(&unknown, &[]);
    import(&stated, &["--excitation", "random"]);
    let model = |name: &str, k: f64| {
        write_test(
            dir.path(),
            name,
            &format!(
                "[system]\nmass = {m}\ndamping = {c}\nstiffness = {k}\n\n[joint]\nkind = \"none\"\n"
            ),
        )
    };
    let validate = |model: &Path, rec: &str, out: &str| {
        let val = dir.path().join(out);
        let o = hystid(&[
            "validate",
            model.to_str().unwrap(),
            &format!("{rec}r.json"),
            "--band",
            "5:60",
            "--out",
            val.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{out}: {}", text(&o));
        let v: serde_json::Value =
            serde_json::from_slice(&std::fs::read(val.join("validate.json")).unwrap()).unwrap();
        assert!(val.join("r_h1.png").is_file(), "{out}: no H1 figure");
        (text(&o), v["recordings"][0].clone())
    };
    let truth = model("truth.toml", k);
    for (rec, said) in [
        (&unknown, "no sine dwell was found in the reference"),
        (&stated, "the recording states a random excitation"),
    ] {
        let (out, entry) = validate(&truth, rec, if rec == &unknown { "u" } else { "s" });
        assert!(out.contains(said), "{out}");
        assert!(entry["assumed"].as_str().unwrap().contains(said), "{entry}");
        assert!(entry["frf"].is_null(), "{entry}");
        // the model is the truth: what is left is the CSV's rounding, the
        // replay's own integration and its drive between samples, well
        // under 1 % of a response dominated by the resonance
        let relative = entry["whole"]["relative"].as_f64().unwrap();
        assert!(relative < 0.01, "relative e_RMS {relative}");
        let h1 = &entry["h1"];
        let error = h1["relative_error"].as_f64().unwrap();
        assert!(error < 0.01, "H1 error {error}");
        // the measured H1 is the receptance 1/(k - m w^2 + i c w): within
        // 5 % RMS over the coherent lines (the Hann window's bias at a
        // resonance 8 lines wide is about 1 %, and the scatter of 14
        // averages)
        let (mut num, mut den) = (0.0, 0.0);
        for (f, h) in h1["frequency_hz"]
            .as_array()
            .unwrap()
            .iter()
            .zip(h1["measured"].as_array().unwrap())
        {
            let w = 2.0 * std::f64::consts::PI * f.as_f64().unwrap();
            let (re, im) = (k - m * w * w, c * w);
            let d = re * re + im * im;
            let exact = (re / d, -im / d);
            let (hr, hi) = (h[0].as_f64().unwrap(), h[1].as_f64().unwrap());
            num += (hr - exact.0).powi(2) + (hi - exact.1).powi(2);
            den += exact.0.powi(2) + exact.1.powi(2);
        }
        let closed_form = (num / den).sqrt();
        assert!(
            closed_form < 0.05,
            "measured H1 vs closed form {closed_form}"
        );
    }
    let stiffer = model("stiffer.toml", 1.1 * k);
    let (_, entry) = validate(&stiffer, &unknown, "k");
    let error = entry["h1"]["relative_error"].as_f64().unwrap();
    assert!(error > 0.3, "a 10 % stiffer model's H1 error {error}");
}

/// A recording stated `random` has no harmonics: `identify` refuses it,
/// naming the kind and what to do instead.
#[test]
fn identify_refuses_a_random_recording_with_what_to_do() {
    let dir = tempfile::tempdir().unwrap();
    let force = broadband_force(4000, 1000.0);
    let csv = dir.path().join("r.csv");
    let mut body = String::from("force,disp\n");
    for f in &force {
        body.push_str(&format!("{f:e},{:e}\n", f * 1e-4));
    }
    std::fs::write(&csv, body).unwrap();
    let out = format!("{}/", dir.path().join("imp").display());
    let o = hystid(&[
        "import",
        csv.to_str().unwrap(),
        "--out",
        &out,
        "-c",
        "force=#1:force",
        "-c",
        "disp=#2:displacement",
        "--rate",
        "1000",
        "--excitation",
        "random",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let o = hystid(&[
        "identify",
        &format!("{out}r.json"),
        "--out",
        dir.path().join("fit").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let said = text(&o);
    assert!(
        said.contains("`excitation.kind` is `random`") && said.contains("hystid validate"),
        "{said}"
    );
}
