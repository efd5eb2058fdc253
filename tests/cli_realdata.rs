//! Integration tests: `hystid import`, `identify` on several and swept
//! recordings, and `validate`, through the binary.
//!
//! Round trips compare the FRFs reduced from an imported recording with
//! those of the same samples in memory, within the quantisation the chosen
//! sample format implies (computed in the test from the format's step).

use crate::cli::{hystid, text};
use crate::common;
use hystid::extract::{NonlinearFrf, ReduceOptions, reduce_stepped};
use hystid::harmonics::{Quantity, omega};
use hystid::model::{ElementSpec, ModalModel, Model};
use hystid::record::{
    Channel, Excitation, ExcitationKind, FORMAT_V1, Recording, RecordingMeta, SampleFormat, Step,
    read_recording, write_recording,
};
use hystid::sim::Simulator;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// SDOF 20 Hz, ζ = 2 %, 1 kg, Masing joint kd = k/2, Fd = 20 N, N = 3.
fn joint_model() -> Model {
    let k = omega(20.0).powi(2);
    let c = 2.0 * 0.02 * k.sqrt();
    Model::new(
        ModalModel::sdof(1.0, c, k).unwrap(),
        vec![ElementSpec::Masing {
            kd: 0.5 * k,
            fd: 20.0,
            n: 3.0,
        }],
    )
    .unwrap()
}

fn channel(name: &str, q: Quantity) -> Channel {
    Channel {
        name: name.into(),
        quantity: q,
        unit: q.si_unit().into(),
        scale: 1.0,
    }
}

/// A recording's metadata: `force` and a response `y` of `response`, at
/// `fs`, with the excitation `kind` and no steps stated.
pub(crate) fn meta(fs: f64, response: Quantity, kind: ExcitationKind) -> RecordingMeta {
    RecordingMeta {
        format: FORMAT_V1.into(),
        sample_rate_hz: fs,
        channels: vec![channel("force", Quantity::Force), channel("y", response)],
        excitation: Excitation {
            kind,
            steps: Vec::new(),
            sweep: None,
        },
        description: String::new(),
        metadata: Default::default(),
        extra: Default::default(),
        chosen_reference: None,
    }
}

/// Dwells of the joint model (phase-continuous), 2 s settling + 2 s
/// measured each, displacement response; with the steps stated.
fn stepped(fs: f64, levels: &[f64], freqs: &[f64]) -> Recording {
    let model = joint_model();
    let mut sim = Simulator::new(&model.linear, model.element_set().unwrap(), fs).unwrap();
    let (mut force, mut x, mut steps) = (Vec::new(), Vec::new(), Vec::new());
    let mut phase = 0.0;
    for &level in levels {
        for &f in freqs {
            let (start, length) = (force.len(), (4.0 * fs) as usize);
            for _ in 0..length {
                let v = level * f64::sin(phase);
                phase += 2.0 * PI * f / fs;
                force.push(v);
                x.push(sim.step(v).unwrap().displacement);
            }
            steps.push(Step {
                frequency_hz: f,
                level,
                start,
                settle: length / 2,
                length,
            });
        }
    }
    let mut m = meta(fs, Quantity::Displacement, ExcitationKind::SteppedSine);
    m.excitation.steps = steps;
    Recording {
        meta: m,
        channels: vec![force, x],
    }
}

/// A linear sweep f0 -> f1 over `seconds` at amplitude `a` (half-second
/// fade-in), acceleration response of the joint model.
fn swept(fs: f64, f0: f64, f1: f64, seconds: f64, a: f64) -> Recording {
    let n = (seconds * fs) as usize;
    let rate = (f1 - f0) / seconds;
    let force: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 / fs;
            let fade = if t < 0.5 {
                0.5 - 0.5 * (PI * t).cos()
            } else {
                1.0
            };
            a * fade * (2.0 * PI * (f0 * t + 0.5 * rate * t * t)).sin()
        })
        .collect();
    let model = joint_model();
    let mut sim = Simulator::new(&model.linear, model.element_set().unwrap(), fs).unwrap();
    let acc = sim
        .run(&force, &hystid::observe::Silent)
        .unwrap()
        .acceleration;
    Recording {
        meta: meta(fs, Quantity::Acceleration, ExcitationKind::SweptSine),
        channels: vec![force, acc],
    }
}

// ------------------------------------------------------------- MAT writer

fn element(ty: u32, data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend(ty.to_le_bytes());
    out.extend((data.len() as u32).to_le_bytes());
    out.extend(data);
    while out.len() % 8 != 0 {
        out.push(0);
    }
    out
}

/// A level-5 MAT-file of real double matrices `name`, `rows x cols`,
/// values in column-major order.
fn mat_file(vars: &[(&str, usize, usize, Vec<f64>)]) -> Vec<u8> {
    let mut out = b"MATLAB 5.0 MAT-file, hystid cli_realdata tests".to_vec();
    out.resize(116, b' ');
    out.extend([0u8; 8]);
    out.extend(0x0100u16.to_le_bytes());
    out.extend(b"IM");
    for (name, rows, cols, values) in vars {
        let mut m = Vec::new();
        m.extend(element(6, &[6, 0, 0, 0, 0, 0, 0, 0])); // mxDOUBLE_CLASS
        let mut dims = Vec::new();
        dims.extend((*rows as i32).to_le_bytes());
        dims.extend((*cols as i32).to_le_bytes());
        m.extend(element(5, &dims));
        m.extend(element(1, name.as_bytes()));
        let data: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        m.extend(element(9, &data));
        out.extend(element(14, &m));
    }
    out
}

fn h1(frf: &NonlinearFrf) -> Vec<(f64, num_complex::Complex64, f64, f64)> {
    frf.levels
        .iter()
        .flat_map(|l| {
            l.points
                .iter()
                .map(|p| (p.frequency_hz, p.h[1], p.force_amplitude, p.h[1].norm()))
        })
        .collect()
}

fn run_ok(args: &[&str]) -> String {
    let o = hystid(args);
    let t = text(&o);
    assert!(o.status.success(), "hystid {args:?} failed:\n{t}");
    t
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Synthetic stepped-sine data (2 levels x 3 frequencies of the joint
/// model) in every input format:
/// MAT v5 (force 1xN, response as row 2 of a 3xN matrix, Fs), CSV with a
/// time column and the response in mm with a calibration scale, TSV with
/// the rate in a comment, and a WAV + JSON recording; written as float 32,
/// PCM 24 and PCM 16. Each import is reduced on the same dwells as the
/// original f64 samples: the H1 difference must stay within the
/// quantisation bound `q_y/|Y1| + q_f/|F1|` (a least-squares harmonic moves
/// by at most one step `q` when every sample errs by at most half a step;
/// the dwells here hold whole periods of 25 samples at 20 Hz, so the
/// rounding errors repeat and do not average out), and the calibrated
/// channel comes back in metres. A TOML `--spec` gives the same recording
/// as the flags.
#[test]
fn import_round_trips_every_format_into_the_same_frfs() {
    let dir = tempfile::tempdir().unwrap();
    let fs = 500.0;
    let mut rec = stepped(fs, &[4.0, 12.0], &[18.0, 20.0, 22.0]);
    // the files carry no steps; the reductions below are given the same
    // ones, so that only the format differs (the dwell finder's discrete
    // choice of a settled window would add its own 1e-4-scale jumps)
    let steps = std::mem::take(&mut rec.meta.excitation.steps);
    rec.meta.excitation.kind = ExcitationKind::Unknown;
    let opts = ReduceOptions::default();
    let with_steps = |r: &Recording| {
        let mut r = r.clone();
        r.meta.excitation.steps = steps.clone();
        r
    };
    let want = h1(&reduce_stepped(&with_steps(&rec), 1, &opts).unwrap());
    assert_eq!(want.len(), 6);
    let (force, y) = (&rec.channels[0], &rec.channels[1]);
    let n = force.len();
    // MAT: Response is 3xN, row 2 the displacement
    let mut resp = Vec::with_capacity(3 * n);
    for i in 0..n {
        resp.extend([0.5 * force[i], y[i], -y[i]]);
    }
    let mat = dir.path().join("bench.mat");
    std::fs::write(
        &mat,
        mat_file(&[
            ("Force", 1, n, force.clone()),
            ("Response", 3, n, resp),
            ("Fs", 1, 1, vec![fs]),
        ]),
    )
    .unwrap();
    // CSV: time column, response in mm
    let csv = dir.path().join("bench.csv");
    let mut t = String::from("# a synthetic bench\ntime_s,force_N,y_mm\n");
    for i in 0..n {
        t += &format!("{:?},{:?},{:?}\n", i as f64 / fs, force[i], 1e3 * y[i]);
    }
    std::fs::write(&csv, t).unwrap();
    // TSV: rate in a comment
    let tsv = dir.path().join("bench.tsv");
    let mut t = format!("# fs = {fs} Hz\nF\tx\n");
    for i in 0..n {
        t += &format!("{:?}\t{:?}\n", force[i], y[i]);
    }
    std::fs::write(&tsv, t).unwrap();
    // WAV + JSON
    let wav = dir.path().join("bench_in");
    write_recording(&wav, &rec, SampleFormat::Float32).unwrap();
    let inputs: Vec<(PathBuf, Vec<&str>)> = vec![
        (
            mat.clone(),
            vec![
                "-c",
                "force=Force:force",
                "-c",
                "y=Response(2):displacement",
                "--rate",
                "variable:Fs",
            ],
        ),
        (
            csv.clone(),
            vec![
                "-c",
                "force=force_N:force",
                "-c",
                "y=y_mm:displacement*1e-3",
                "--rate",
                "time:time_s",
            ],
        ),
        (
            tsv.clone(),
            vec!["-c", "force=F:force", "-c", "y=#2:displacement"],
        ),
        (wav.with_extension("json"), vec![]),
    ];
    for (input, flags) in &inputs {
        for (format, bits) in [("float32", 23), ("pcm24", 23), ("pcm16", 15)] {
            let stem = dir.path().join(format!(
                "{}_{}_{format}",
                input.file_stem().unwrap().to_str().unwrap(),
                input.extension().unwrap().to_str().unwrap()
            ));
            let mut args = vec!["import", s(input), "--out", s(&stem), "--format", format];
            args.extend(flags.iter().copied());
            let out = run_ok(&args);
            assert!(out.contains("0 errors"), "{out}");
            let back = read_recording(&stem).unwrap();
            assert_eq!(back.meta.sample_rate_hz, fs);
            assert_eq!(back.meta.channels[1].quantity, Quantity::Displacement);
            assert_eq!(back.meta.channels[1].unit, "m");
            assert!(stem.with_extension("quality.json").exists());
            assert!(back.meta.excitation.steps.is_empty());
            let got = h1(&reduce_stepped(&with_steps(&back), 1, &opts).unwrap());
            assert_eq!(got.len(), want.len(), "{}", stem.display());
            // quantisation step: PCM full scale is the peak, float 32
            // rounds to 2^-23 relative at most
            let peak = |x: &[f64]| x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let q = |x: &[f64]| peak(x) / 2f64.powi(bits);
            let mut worst = 0.0f64;
            for (a, b) in got.iter().zip(&want) {
                assert!((a.0 - b.0).abs() < 1e-6, "frequency {} vs {}", a.0, b.0);
                // a least-squares harmonic of N samples moves by at most
                // twice the largest sample error, i.e. one step
                let bound = q(y) / (b.3 * b.2) + q(force) / b.2;
                let err = (a.1 - b.1).norm() / b.1.norm();
                worst = worst.max(err / bound);
                assert!(
                    err <= bound,
                    "{}: {} Hz: H1 differs by {err:.3e}, bound {bound:.3e}",
                    stem.display(),
                    b.0
                );
            }
            eprintln!(
                "{}: worst H1 difference {worst:.3} x the quantisation bound",
                stem.display()
            );
        }
    }
    // the same MAT import from a TOML spec: the same recording
    let spec = dir.path().join("import.toml");
    std::fs::write(
        &spec,
        "sample_rate = { variable = \"Fs\" }\n\
         [[channels]]\nvariable = \"Force\"\nname = \"force\"\nquantity = \"force\"\n\
         [[channels]]\nvariable = \"Response\"\nrow = 2\nname = \"y\"\nquantity = \"displacement\"\n",
    )
    .unwrap();
    let from_spec = dir.path().join("from_spec");
    run_ok(&[
        "import",
        s(&mat),
        "--out",
        s(&from_spec),
        "--spec",
        s(&spec),
    ]);
    let flags = dir.path().join("bench_mat_float32");
    let (a, b) = (
        read_recording(&from_spec).unwrap(),
        read_recording(&flags).unwrap(),
    );
    assert_eq!(a.channels, b.channels);
    assert_eq!(a.meta.channels, b.meta.channels);
}

/// NaN in the data: exit 2, the channel and sample named, nothing written.
/// Clipping, a DC offset and a declared rate the time column contradicts
/// are warnings: written, and said.
#[test]
fn import_stops_on_nan_and_warns_on_clipping() {
    let dir = tempfile::tempdir().unwrap();
    let fs = 1000.0;
    let mut lines = String::from("time_s,f,y\n");
    for i in 0..4000 {
        let t = i as f64 / fs;
        let f = (2.0 * PI * 10.0 * t).sin();
        let y = if i == 1234 {
            f64::NAN
        } else {
            0.3 * (2.0 * PI * 10.0 * t - 0.4).sin()
        };
        lines += &format!("{t:?},{f:?},{y:?}\n");
    }
    let bad = dir.path().join("nan.csv");
    std::fs::write(&bad, &lines).unwrap();
    let out = dir.path().join("nan_out");
    let o = hystid(&[
        "import",
        s(&bad),
        "--out",
        s(&out),
        "-c",
        "f:force",
        "-c",
        "y:velocity",
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(t.contains("`y`") && t.contains("1234"), "{t}");
    assert!(t.contains("nothing written"), "{t}");
    assert!(!out.with_extension("wav").exists() && !out.with_extension("json").exists());
    // clipped force (a rail at 0.8) and a response with a large offset
    let mut lines = String::from("# fs = 1000 Hz\nf,y\n");
    for i in 0..4000 {
        let t = i as f64 / fs;
        let f = (2.0 * PI * 10.0 * t).sin().clamp(-0.8, 0.8);
        let y = 2.0 + 0.3 * (2.0 * PI * 10.0 * t - 0.4).sin();
        lines += &format!("{f:?},{y:?}\n");
    }
    let clip = dir.path().join("clip.csv");
    std::fs::write(&clip, &lines).unwrap();
    let out = dir.path().join("clip_out");
    let t = run_ok(&[
        "import",
        s(&clip),
        "--out",
        s(&out),
        "-c",
        "f:force",
        "-c",
        "y:velocity",
    ]);
    assert!(t.contains("warning") && t.contains("clip"), "{t}");
    assert!(t.contains("mean") && t.contains("offset"), "{t}");
    assert!(out.with_extension("json").exists());
    let q: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.with_extension("quality.json")).unwrap())
            .unwrap();
    let kinds: Vec<&str> = q["findings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["kind"].as_str().unwrap())
        .collect();
    assert!(
        kinds.contains(&"clipping") && kinds.contains(&"dc-offset"),
        "{kinds:?}"
    );
    // a declared rate the time column contradicts is said; a rate from a
    // time column printed with 7 decimals is rounded to whole Hz
    let mut lines = String::from("time_s,f,y\n");
    for i in 0..4000 {
        let t = i as f64 / 1024.0;
        let f = (2.0 * PI * 10.0 * t).sin();
        lines += &format!(
            "{t:.7},{f:.10},{:.10}\n",
            0.3 * (2.0 * PI * 10.0 * t - 0.4).sin()
        );
    }
    let timed = dir.path().join("timed.csv");
    std::fs::write(&timed, &lines).unwrap();
    let ch = ["-c", "f:force", "-c", "y:velocity"];
    let out = dir.path().join("declared");
    let mut args = vec!["import", s(&timed), "--out", s(&out), "--rate", "1000"];
    args.extend(ch);
    let t = run_ok(&args);
    assert!(t.contains("warning") && t.contains("1024.000000 Hz"), "{t}");
    let out = dir.path().join("rounded");
    let mut args = vec![
        "import",
        s(&timed),
        "--out",
        s(&out),
        "--rate",
        "time:time_s",
    ];
    args.extend(ch);
    let t = run_ok(&args);
    assert!(t.contains("rounded to 1024 Hz"), "{t}");
    assert_eq!(read_recording(&out).unwrap().meta.sample_rate_hz, 1024.0);
}

/// Every import error names the file and the field, with exit status 2.
#[test]
fn import_errors_name_the_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let n = 500;
    let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.1).sin()).collect();
    let mat = dir.path().join("short.mat");
    std::fs::write(
        &mat,
        mat_file(&[
            ("Force", 1, n, x.clone()),
            ("Acc", 1, n - 1, x[..n - 1].to_vec()),
            ("Fs", 1, 1, vec![100.0]),
        ]),
    )
    .unwrap();
    let out = dir.path().join("o");
    let err = |args: &[&str], parts: &[&str]| {
        let o = hystid(args);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {t}");
        for p in parts {
            assert!(t.contains(p), "{args:?}: `{p}` missing in:\n{t}");
        }
    };
    // missing variable, with the variables listed
    err(
        &[
            "import",
            s(&mat),
            "--out",
            s(&out),
            "-c",
            "Nope:force",
            "-c",
            "Acc:acceleration",
        ],
        &["short.mat", "Nope", "Force"],
    );
    // mismatched lengths
    err(
        &[
            "import",
            s(&mat),
            "--out",
            s(&out),
            "-c",
            "Force:force",
            "-c",
            "Acc:acceleration",
        ],
        &["short.mat", "Acc", "499", "500"],
    );
    // no channels: the variables are listed
    err(
        &["import", s(&mat), "--out", s(&out)],
        &["short.mat", "no channels", "Acc (1x499"],
    );
    // a bad channel spec
    err(
        &["import", s(&mat), "--out", s(&out), "-c", "Force:forse"],
        &["forse", "QUANTITY"],
    );
    // wrong column
    let csv = dir.path().join("t.csv");
    std::fs::write(&csv, "# fs = 100 Hz\nf,y\n1,2\n3,4\n5,6\n").unwrap();
    err(
        &[
            "import",
            s(&csv),
            "--out",
            s(&out),
            "-c",
            "f:force",
            "-c",
            "z:velocity",
        ],
        &["t.csv", "z"],
    );
    // truncated MAT
    let bytes = std::fs::read(&mat).unwrap();
    let cut = dir.path().join("cut.mat");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    err(
        &[
            "import",
            s(&cut),
            "--out",
            s(&out),
            "-c",
            "Acc:acceleration",
            "-c",
            "Fs:force",
        ],
        &["cut.mat"],
    );
    // a corrupted WAV header and a truncated WAV of a recording
    let rec = stepped(200.0, &[1.0], &[20.0]);
    let good = dir.path().join("rec");
    write_recording(&good, &rec, SampleFormat::Pcm16).unwrap();
    let mut wav = std::fs::read(good.with_extension("wav")).unwrap();
    let damaged = dir.path().join("damaged");
    std::fs::copy(good.with_extension("json"), damaged.with_extension("json")).unwrap();
    wav[8..12].copy_from_slice(b"WAVX");
    std::fs::write(damaged.with_extension("wav"), &wav).unwrap();
    err(
        &[
            "import",
            s(&damaged.with_extension("json")),
            "--out",
            s(&out),
        ],
        &["damaged.wav"],
    );
    let short = dir.path().join("short_rec");
    std::fs::copy(good.with_extension("json"), short.with_extension("json")).unwrap();
    let full = std::fs::read(good.with_extension("wav")).unwrap();
    std::fs::write(short.with_extension("wav"), &full[..full.len() - 100]).unwrap();
    err(
        &["import", s(&short.with_extension("wav")), "--out", s(&out)],
        &["short_rec.wav"],
    );
    // a rate from a time column that is no whole number of Hz
    let odd = dir.path().join("odd.csv");
    let mut t = String::from("time_s,f,y\n");
    for i in 0..200 {
        let x = i as f64 / 610.3515625;
        t += &format!("{x:.10},{},{}\n", (7.0 * x).sin(), (7.0 * x).cos());
    }
    std::fs::write(&odd, t).unwrap();
    err(
        &[
            "import",
            s(&odd),
            "--out",
            s(&out),
            "-c",
            "f:force",
            "-c",
            "y:velocity",
            "--rate",
            "time:time_s",
        ],
        &["odd.csv", "610.35", "whole number of Hz"],
    );
    // validate: a fit without a model, a missing recording
    let fit = dir.path().join("fit.json");
    std::fs::write(&fit, "{\"response_sign\": 1}").unwrap();
    err(
        &[
            "validate",
            s(&fit),
            s(&good.with_extension("json")),
            "--out",
            s(&out),
        ],
        &["fit.json", "model"],
    );
    assert!(!out.with_extension("wav").exists());
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Swept-sine recordings of the joint model at 3, 10 and 30 N (identify
/// with the linear start from the lowest level), validated by simulation
/// on an unseen 6 N sweep: the fitted model's e_RMS must be a small part of
/// the response (it is the true model's family; the fit error is what
/// remains) and below the linear model's. Then single-dwell recordings
/// (one WAV per dwell, 2 levels x 4 frequencies) combine into 2 levels of 4
/// points, and a stepped recording with stated steps is reduced from disk.
#[test]
fn identify_and_validate_through_the_binary() {
    let dir = tempfile::tempdir().unwrap();
    let fs = 400.0;
    let mut paths = Vec::new();
    for (name, a) in [("s3", 3.0), ("s10", 10.0), ("s30", 30.0), ("s6", 6.0)] {
        let p = dir.path().join(name);
        write_recording(&p, &swept(fs, 14.0, 30.0, 32.0, a), SampleFormat::Float32).unwrap();
        paths.push(p.with_extension("json"));
    }
    let fit_dir = dir.path().join("fit");
    let out = run_ok(&[
        "identify",
        s(&paths[0]),
        s(&paths[1]),
        s(&paths[2]),
        "--out",
        s(&fit_dir),
        "--band",
        "15:28",
        "--linear-start",
        "lowest",
        "--hop-periods",
        "6",
    ]);
    eprintln!("{out}");
    assert!(
        out.contains("swept sine") && out.contains("compensation"),
        "{out}"
    );
    let fit = json(&fit_dir.join("fit.json"));
    assert_eq!(fit["response"], "y");
    let val_dir = dir.path().join("val");
    let out = run_ok(&[
        "validate",
        s(&fit_dir.join("fit.json")),
        s(&paths[3]),
        "--out",
        s(&val_dir),
        "--band",
        "15:28",
    ]);
    eprintln!("{out}");
    let v = json(&val_dir.join("validate.json"));
    let r = &v["recordings"][0];
    let rel = r["whole"]["relative"].as_f64().unwrap();
    let lin_dir = dir.path().join("lin");
    run_ok(&[
        "validate",
        s(&fit_dir.join("fit.json")),
        s(&paths[3]),
        "--out",
        s(&lin_dir),
        "--linear",
        "--no-frf",
    ]);
    let vl = json(&lin_dir.join("validate.json"));
    let rel_lin = vl["recordings"][0]["whole"]["relative"].as_f64().unwrap();
    eprintln!("6 N sweep: fitted e_RMS {rel:.4} of the RMS, linear {rel_lin:.4}");
    assert!(rel < 0.1, "{rel}");
    assert!(rel < rel_lin);
    assert_eq!(v["model_kind"], "fitted");
    assert_eq!(r["response"], "y");
    assert_eq!(r["quantity"], "acceleration");
    assert_eq!(vl["model_kind"], "linear");
    for f in ["s6_time.png", "s6_time_window.svg", "s6_frf.png"] {
        assert!(val_dir.join(f).exists(), "{f}");
    }
    assert!(r["window"]["start_s"].as_f64().unwrap() > 0.0);
    // single-dwell files combine by level
    let mut singles = Vec::new();
    for level in [2.0, 8.0] {
        for f in [17.0, 19.0, 21.0, 23.0] {
            let mut rec = stepped(fs, &[level], &[f]);
            rec.meta.excitation.steps.clear();
            let p = dir.path().join(format!("dwell_{level}_{f}"));
            write_recording(&p, &rec, SampleFormat::Pcm24).unwrap();
            singles.push(p.with_extension("json"));
        }
    }
    let single_dir = dir.path().join("singles");
    let mut args = vec!["identify"];
    args.extend(singles.iter().map(|p| s(p)));
    args.extend(["--out", s(&single_dir), "--element", "jenkins"]);
    let out = run_ok(&args);
    assert_eq!(out.matches("1 point(s)").count(), 8, "{out}");
    let fit = json(&single_dir.join("fit.json"));
    assert_eq!(fit["linear"]["stick"]["points"], 4);
    assert_eq!(fit["linear"]["underlying"]["points"], 4);
    // stated steps: reduced from disk, one dwell at a time
    let p = dir.path().join("stepped");
    write_recording(
        &p,
        &stepped(fs, &[2.0, 8.0], &[17.0, 19.0, 21.0, 23.0]),
        SampleFormat::Float32,
    )
    .unwrap();
    let out = run_ok(&[
        "identify",
        s(&p.with_extension("json")),
        "--out",
        s(&dir.path().join("streamed")),
        "--element",
        "jenkins",
    ]);
    assert!(
        out.contains("(streamed)") && out.contains("8 point(s)"),
        "{out}"
    );
}

/// The UNESP single sines: one dwell per file, combined into one level of
/// six points; a joint fit needs two levels and says so.
#[test]
fn unesp_single_sines_are_one_level() {
    let Some(data) = common::dataset("bolted_beam_unesp_bert") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let mut recs = Vec::new();
    for f in ["06Hz", "09p5Hz", "17Hz", "18Hz", "19Hz", "20Hz"] {
        let out = dir.path().join(format!("sine_{f}"));
        run_ok(&[
            "import",
            s(&data.join(format!("csv/sine_{f}_0p15V_time.csv"))),
            "--out",
            s(&out),
            "-c",
            "drive=shaker_amp_V:voltage",
            "-c",
            "laser=laser_velocity_m_per_s:velocity",
            "--excitation",
            "stepped",
            "-q",
        ]);
        recs.push(out.with_extension("json"));
    }
    let mut args = vec!["identify"];
    args.extend(recs.iter().map(|p| s(p)));
    let fit_dir = dir.path().join("fit");
    args.extend(["--out", s(&fit_dir)]);
    let o = hystid(&args);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert_eq!(t.matches("1 point(s)").count(), 6, "{t}");
    assert!(
        t.contains("at least two force levels") && t.contains("found 1"),
        "{t}"
    );
}

/// Imports the Bouc-Wen benchmark's sets named in `which` (`est`: the
/// estimation multisine, `sweep` and `multisine`: the test sets) into
/// `dir` as NAME.wav / NAME.json.
fn import_bouc_wen(data: &Path, dir: &Path, which: &[&str]) {
    let mat = data.join("bouc-wen.mat");
    for (name, u, y, excitation) in [
        ("est", "u", "y", "unknown"),
        ("sweep", "uval_sinesweep", "yval_sinesweep", "swept"),
        ("multisine", "uval_multisine", "yval_multisine", "unknown"),
    ] {
        if !which.contains(&name) {
            continue;
        }
        run_ok(&[
            "import",
            s(&mat),
            "--out",
            s(&dir.join(name)),
            "-c",
            &format!("force={u}:force"),
            "-c",
            &format!("y={y}:displacement"),
            "--rate",
            "750",
            "--excitation",
            excitation,
            "-q",
        ]);
    }
}

/// The validation pages' Bouc-Wen walkthrough through the binary: `identify --domain
/// time --element bouc_wen --fix nu` on the estimation multisine with no
/// start given (the multisine's period and linear estimate found by
/// `identify`, the closest of the start grid; β held: with ν = 1 only βγ and
/// βδ count), then `validate` of its fit.json on both test sets (the
/// multisine's with `--periodic`: it is one steady-state period). Checked
/// against the benchmark's published parameters (m 2, c 10, k 5e4, α 5e4,
/// βγ 800, βδ −1100) and issue 13's e_RMS target (≤ 3e-6 m), with the
/// README's table and parameters pinned.
/// `--start` is read as a model written down: a name `--fix` does not know,
/// and `--start` without `--domain time`, are clear errors (exit 2) that
/// leave no output.
#[test]
fn bouc_wen_fitted_through_the_binary_validates_on_both_test_sets() {
    let Some(data) = common::dataset("boucwen_benchmark") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    import_bouc_wen(&data, dir.path(), &["est", "sweep", "multisine"]);
    let est = dir.path().join("est.json");
    let start = dir.path().join("start.toml");
    std::fs::write(
        &start,
        "[system]\nmass = 2.03\ndamping = 91.1\nstiffness = 6.28e4\n\
         [joint]\nkind = \"bouc_wen\"\nalpha = 6.28e4\nbeta = 150.0\ngamma = 0.5\ndelta = 0.1\nnu = 1.0\n",
    )
    .unwrap();
    let start_dir = dir.path().join("fit_start");
    for (fix, domain, expected) in [
        (
            "beta,bogus",
            &["--domain", "time"][..],
            "`bogus` is not a parameter of the start",
        ),
        ("beta,nu", &[][..], "add --domain time"),
    ] {
        let mut a = vec![
            "identify",
            s(&est),
            "--out",
            s(&start_dir),
            "--start",
            s(&start),
            "--fix",
            fix,
        ];
        a.extend(domain);
        let o = hystid(&a);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{t}");
        assert!(t.contains(expected), "{t}");
        assert!(!start_dir.exists(), "an output was left: {t}");
    }
    let found_dir = dir.path().join("fit_found");
    let found_json = found_dir.join("fit.json");
    let mut a = vec!["identify", s(&est), "--out", s(&found_dir)];
    a.extend(super::protocols::BOUC_WEN_FIT);
    let out = run_ok(&a);
    eprintln!("{out}");
    assert!(
        out.contains("5 periods of 8192 samples"),
        "the period is reported: {out}"
    );
    let found = json(&found_json);
    let t = &found["time_domain"];
    assert_eq!(t["status"], "converged");
    let p = |n: &str| t["parameters"][n]["value"].as_f64().unwrap();
    let beta = found["start"]["joint"]["beta"].as_f64().unwrap();
    let close = |got: f64, truth: f64, tol: f64| (got / truth - 1.0).abs() <= tol;
    let fitted = [
        ("m", p("mass"), 2.0, 0.01),
        ("c", p("damping"), 10.0, 0.03),
        ("k", p("stiffness"), 5e4, 0.01),
        ("alpha", p("alpha"), 5e4, 0.01),
        ("beta gamma", beta * p("gamma"), 800.0, 0.02),
        ("beta delta", beta * p("delta"), -1100.0, 0.02),
    ];
    let shown = common::pinned_figures("Fitted Bouc-Wen parameters:").expect("pinned figures");
    for ((what, value, truth, tol), shown) in fitted.into_iter().zip(shown) {
        common::assert_pinned_figure(&format!("Bouc-Wen fit: {what}"), value, shown);
        assert!(
            close(value, truth, tol),
            "{what}: {value} (published {truth})"
        );
    }
    // the multisine test set is one steady-state period: --periodic
    for (set, row, table_row, extra) in [
        (
            "sweep",
            "| sine sweep test set |",
            "| Bouc-Wen | sine sweep | whole record |",
            None,
        ),
        (
            "multisine",
            "| multisine test set |",
            "| Bouc-Wen | multisine | one period |",
            Some("--periodic"),
        ),
    ] {
        let val_dir = dir.path().join(format!("val_{set}"));
        let rec = dir.path().join(format!("{set}.json"));
        let mut a = vec![
            "validate",
            s(&found_json),
            s(&rec),
            "--out",
            s(&val_dir),
            "--min-samples-per-period",
            "400",
            "-q",
        ];
        a.extend(extra);
        run_ok(&a);
        let v = json(&val_dir.join("validate.json"));
        let whole = &v["recordings"][0]["whole"];
        let (e, relative) = (
            whole["e_rms"].as_f64().unwrap(),
            whole["relative"].as_f64().unwrap(),
        );
        eprintln!(
            "Bouc-Wen {set} test set through the binary: e_RMS {e:.4e} m ({:.3} % of the RMS)",
            100.0 * relative
        );
        // the walkthrough's table and the data sets' table
        for row in [row, table_row] {
            let shown = common::pinned_figures(row).expect("pinned figures");
            for ((what, value), shown) in
                [("e_RMS", e), ("its share of the RMS (%)", 100.0 * relative)]
                    .into_iter()
                    .zip(shown)
            {
                common::assert_pinned_figure(&format!("{row} {what}"), value, shown);
            }
        }
        assert!(e <= 3e-6, "{set}: e_RMS {e}");
        // one period (`--periodic`): the error at its lines, whose RMS is
        // e_RMS but for what lies above three times the highest excited
        // line (Parseval: never more, and here nearly all of it), and its
        // classes the validation pages'
        let l = &v["recordings"][0]["line_spectrum"];
        if extra.is_none() {
            assert!(
                l.is_null(),
                "a record of many periods has no one-period lines"
            );
            continue;
        }
        let at_lines = l["error_rms_at_lines"].as_f64().unwrap();
        assert!(
            at_lines <= e * (1.0 + 1e-9) && at_lines >= 0.99 * e,
            "{at_lines} at the lines against e_RMS {e}"
        );
        assert!(val_dir.join("multisine_lines.png").exists());
        let relative = |class: &str| {
            let c = l["by_class"]
                .as_array()
                .unwrap()
                .iter()
                .find(|c| c["class"] == class);
            100.0 * c.unwrap()["relative"].as_f64().unwrap()
        };
        let shown = common::pinned_figures("Bouc-Wen multisine test set at its lines:")
            .expect("pinned figures");
        for ((what, value), shown) in [
            ("excited", relative("excited")),
            ("odd not excited", relative("odd_not_excited")),
            ("even not excited", relative("even_not_excited")),
        ]
        .into_iter()
        .zip(shown)
        {
            common::assert_pinned_figure(&format!("Bouc-Wen lines: {what} (%)"), value, shown);
        }
    }
    // the sweep test set's decimation declared (`--acquisition 20`): the
    // fitted model put through it too, named in validate.json; a chain that
    // is not one refused naming the flag
    let val_dir = dir.path().join("val_sweep_acquired");
    let rec = dir.path().join("sweep.json");
    let mut a = vec!["validate", s(&found_json), s(&rec), "--out", s(&val_dir)];
    a.extend([
        "--min-samples-per-period",
        "400",
        "-q",
        "--acquisition",
        "20",
    ]);
    run_ok(&a);
    let v = json(&val_dir.join("validate.json"));
    assert_eq!(
        v["acquisition"],
        serde_json::json!({"decimated_by": 20, "taps": 31})
    );
    let e = v["recordings"][0]["whole"]["e_rms"].as_f64().unwrap();
    eprintln!("Bouc-Wen sweep through its acquisition: e_RMS {e:.4e} m");
    let shown = common::pinned_figures("The fitted model through the sweep's acquisition:")
        .expect("pinned figures");
    common::assert_pinned_figure("the fitted model's e_RMS through the chain", e, shown[0]);
    assert!(e <= 3e-7, "{e}");
    let bad = dir.path().join("val_bad");
    let o = hystid(&[
        "validate",
        s(&found_json),
        s(&rec),
        "--out",
        s(&bad),
        "--acquisition",
        "1",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("--acquisition") && !bad.join("validate.json").exists());
}

/// `identify --domain time` through the response's acquisition chain: the
/// benchmark's sine-sweep test set (integrated at 15 kHz and decimated by
/// MATLAB's `decimate(y, 20, 'fir')`, whose FIR droops 0.42 % at the
/// resonance) fitted from a start written down some 3-5 % off the published
/// model, once as recorded and once with the model file's `[acquisition]`
/// declaring that decimation. Through the chain the fit is the published
/// model (each of m, c, k, alpha, beta gamma, beta delta within 0.25 %: the
/// replay's own error at 19 times the recording's rate is about 1e-7 m of a
/// 6.6e-4 m response, the RK4 reference's through the chain 6.5e-8 m); as
/// recorded the fit bends k, alpha and c by 4-6 % to the droop. fit.json
/// names the chain and `validate` of it puts its replay through the chain
/// too, to the fit's own figure.
#[test]
fn bouc_wen_fitted_on_the_sweep_through_its_acquisition_is_the_published_model() {
    let Some(data) = common::dataset("boucwen_benchmark") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    import_bouc_wen(&data, dir.path(), &["sweep"]);
    let sweep = dir.path().join("sweep.json");
    let start = "[system]\nmass = 2.04\ndamping = 10.5\nstiffness = 5.15e4\n\
                 [joint]\nkind = \"bouc_wen\"\nalpha = 4.85e4\nbeta = 1.0e3\ngamma = 0.76\n\
                 delta = -1.14\nnu = 1.0\n";
    let fitted = |name: &str, acquisition: &str| {
        let model = dir.path().join(format!("{name}.toml"));
        std::fs::write(&model, format!("{start}{acquisition}")).unwrap();
        let out = dir.path().join(name);
        run_ok(&[
            "identify",
            s(&sweep),
            "--domain",
            "time",
            "--start",
            s(&model),
            "--fix",
            "nu",
            "--min-samples-per-period",
            "400",
            "--out",
            s(&out),
            "-q",
        ]);
        let f = json(&out.join("fit.json"));
        assert_eq!(f["time_domain"]["status"], "converged", "{name}");
        (f, out)
    };
    let (plain, _) = fitted("as_recorded", "");
    let (chained, chained_dir) = fitted("through_the_chain", "[acquisition]\ndecimated_by = 20\n");
    assert!(plain["time_domain"].get("acquisition").is_none());
    assert_eq!(
        chained["time_domain"]["acquisition"],
        serde_json::json!({"decimated_by": 20, "taps": 31})
    );
    // m, c, k, alpha, beta gamma, beta delta (beta held at the start's 1e3)
    let figures = |f: &serde_json::Value| {
        let t = &f["time_domain"];
        let p = |n: &str| t["parameters"][n]["value"].as_f64().unwrap();
        let e = t["after"][0]["window"]["e_rms"].as_f64().unwrap();
        [
            p("stiffness"),
            p("alpha"),
            p("damping"),
            p("mass"),
            1e3 * p("gamma"),
            1e3 * p("delta"),
            e,
        ]
    };
    let published = [5e4, 5e4, 10.0, 2.0, 800.0, -1100.0];
    let (a, b) = (figures(&plain), figures(&chained));
    eprintln!("as recorded {a:?}\nthrough the chain {b:?}");
    for (i, truth) in published.iter().enumerate() {
        let (off_plain, off_chained) = (a[i] / truth - 1.0, b[i] / truth - 1.0);
        assert!(
            off_chained.abs() <= 2.5e-3,
            "parameter {i}: {off_chained:+.2e} off"
        );
        // the droop's bias: k, alpha and c moved by percents
        if i < 3 {
            assert!(
                off_plain.abs() >= 0.02,
                "parameter {i}: {off_plain:+.2e} off as recorded"
            );
        }
    }
    assert!(
        b[6] <= 1e-7 && b[6] <= 0.2 * a[6],
        "e_RMS {} through the chain, {} as recorded",
        b[6],
        a[6]
    );
    let shown =
        common::pinned_figures("Fitted on the sine-sweep test set through its acquisition:")
            .expect("pinned figures");
    let names = ["k", "alpha", "c", "m", "beta gamma", "beta delta", "e_RMS"];
    for (k, value) in b.iter().chain(&a).enumerate() {
        let what = format!(
            "{} {}",
            if k < 7 {
                "through the chain"
            } else {
                "as recorded"
            },
            names[k % 7]
        );
        common::assert_pinned_figure(&what, *value, shown[k]);
    }
    // validate reads the chain from fit.json
    let val = dir.path().join("val");
    run_ok(&[
        "validate",
        s(&chained_dir.join("fit.json")),
        s(&sweep),
        "--min-samples-per-period",
        "400",
        "--out",
        s(&val),
        "-q",
    ]);
    let v = json(&val.join("validate.json"));
    assert_eq!(v["acquisition"], chained["time_domain"]["acquisition"]);
    let e = v["recordings"][0]["whole"]["e_rms"].as_f64().unwrap();
    assert!(
        (e / b[6] - 1.0).abs() < 1e-6,
        "validate {e}, the fit {}",
        b[6]
    );
}

/// The validation pages' diagnosis figures of a real data set, read from the
/// `diagnosis.json` the validation pages' commands write: the baseline's and the final
/// model's H1 error and `χ²/dof`, then each kept effect's parameters with
/// their 95 % intervals, in the order the pinned line gives them (the line
/// that starts with `start`). The kept effects must be `kept`, in order.
fn assert_pinned_diagnosis(start: &str, diagnosis: &Path, kept: &[(&str, &[&str])]) {
    let d = json(diagnosis);
    let selected: Vec<&str> = d["selected"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["effect"].as_str().unwrap())
        .collect();
    let names: Vec<&str> = kept.iter().map(|k| k.0).collect();
    assert_eq!(selected, names, "{start}: the effects kept");
    let mut figures = vec![
        (
            "baseline H1 error (%)",
            100.0 * d["baseline"]["error_relative"].as_f64().unwrap(),
        ),
        (
            "final H1 error (%)",
            100.0 * d["final"]["error_relative"].as_f64().unwrap(),
        ),
        (
            "baseline chi2/dof",
            d["baseline"]["chi2_per_dof"].as_f64().unwrap(),
        ),
        (
            "final chi2/dof",
            d["final"]["chi2_per_dof"].as_f64().unwrap(),
        ),
    ];
    for (effect, parameters) in kept {
        let e = d["selected"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["effect"] == *effect)
            .unwrap();
        for p in *parameters {
            let q = &e["parameters"][*p];
            let ci = q["ci95"].as_array().unwrap();
            figures.push((p, q["value"].as_f64().unwrap()));
            figures.push(("its 95 % interval's low end", ci[0].as_f64().unwrap()));
            figures.push(("its 95 % interval's high end", ci[1].as_f64().unwrap()));
        }
    }
    eprintln!("{start} {figures:?}");
    let shown = common::pinned_figures(start).expect("pinned figures");
    assert_eq!(shown.len(), figures.len(), "{start}: {shown:?}");
    for ((what, value), shown) in figures.into_iter().zip(shown) {
        common::assert_pinned_figure(&format!("{start} {what}"), value, shown);
    }
}

/// A walkthrough through the binary: each source file imported with
/// `import_args` (the channel flags), then all diagnosed with
/// `diagnose_args`; the folder holding `diagnosis.json` and its path.
fn diagnose_walkthrough(
    sources: &[PathBuf],
    import_args: &[&str],
    diagnose_args: &[&str],
) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let mut recs = Vec::new();
    for (i, source) in sources.iter().enumerate() {
        let out = dir.path().join(format!("rec{i}"));
        let mut args = vec!["import", s(source), "--out", s(&out)];
        args.extend(import_args);
        args.push("-q");
        run_ok(&args);
        recs.push(out.with_extension("json"));
    }
    let out = dir.path().join("diag");
    let mut args = vec!["diagnose"];
    args.extend(recs.iter().map(|p| s(p)));
    args.extend(["--out", s(&out), "-q"]);
    args.extend(diagnose_args);
    run_ok(&args);
    let json = out.join("diagnosis.json");
    (dir, json)
}

/// The validation pages' F-16 walkthrough: the odd levels imported from the data set's
/// MAT files and diagnosed on the torsion mode's band, as the validation pages'
/// commands do; its figures are pinned (a softening cubic stiffness kept, the
/// residual still far above the noise).
#[test]
fn f16_diagnosis_is_as_pinned() {
    let Some(data) = common::dataset("f16_gvt_benchmark") else {
        return;
    };
    let sources: Vec<PathBuf> = ["1", "3", "5", "7"]
        .iter()
        .map(|l| data.join(format!("BenchmarkData/F16Data_SineSw_Level{l}.mat")))
        .collect();
    let (_dir, diagnosis) = diagnose_walkthrough(
        &sources,
        &super::protocols::F16_IMPORT,
        &[
            "--band",
            "6.9:7.6",
            "--linear-start",
            "lowest",
            "--hop-periods",
            "4",
            // acc2 is on the wing, not at the drive
            "--transfer",
        ],
    );
    assert_pinned_diagnosis(
        "Diagnosis figures (F-16):",
        &diagnosis,
        &[("cubic_stiffness", &["k3"])],
    );
    // still above the noise: the candidates tried only when named are the
    // next step, and the explanation says so
    let explanation = json(&diagnosis)["explanation"]
        .as_str()
        .unwrap()
        .to_string();
    assert!(
        explanation.ends_with(
            "Not tried, as they are tried only when named: bouc_wen_joint \
             (`--candidates default,bouc_wen_joint`)."
        ),
        "{explanation}"
    );
}

/// The validation pages' F-16 second mode: the odd levels diagnosed with every
/// default candidate on a band that holds both nonlinear modes (6-7.6 Hz),
/// then the diagnosed model validated on the even levels over that band;
/// pinned: a hysteretic mode slipping near 6.30 Hz (the 6.2-6.6 Hz mode,
/// found by the diagnosis on its own), a linear mode below the band and a
/// softening cubic stiffness kept, the residual still above the noise, and
/// the validation's table.
#[test]
fn f16_second_mode_diagnosis_is_as_pinned() {
    let Some(data) = common::dataset("f16_gvt_benchmark") else {
        return;
    };
    let work = tempfile::tempdir().unwrap();
    let (odd, held) = f16_levels(work.path(), &data);
    let out = work.path().join("diag");
    let mut args: Vec<&str> = vec!["diagnose"];
    args.extend(odd.iter().map(|p| s(p)));
    args.extend([
        "--band",
        "6:7.6",
        "--linear-start",
        "lowest",
        "--hop-periods",
        "8",
        "--transfer",
        "-q",
        "--out",
        s(&out),
    ]);
    run_ok(&args);
    let diagnosis = out.join("diagnosis.json");
    assert_pinned_diagnosis(
        "Diagnosis figures (F-16, 6-7.6 Hz):",
        &diagnosis,
        &[
            ("hysteretic_mode", &["frequency_hz", "joint.fd"]),
            ("cubic_stiffness", &["k3"]),
        ],
    );
    f16_validation_is_as_pinned(
        work.path(),
        &diagnosis,
        &held,
        "6:7.6",
        "F-16 diagnosed on 6-7.6 Hz, two nonlinear modes",
    );
}

/// The F-16 levels imported into `work` as the walkthrough imports
/// them: the odd levels (fitted) and the even ones (held out).
fn f16_levels(work: &Path, data: &Path) -> (Vec<PathBuf>, Vec<PathBuf>) {
    let level = |l: &str| {
        super::protocols::import(
            work,
            &data.join(format!("BenchmarkData/F16Data_SineSw_Level{l}.mat")),
            &format!("L{}", &l[..1]),
            &super::protocols::F16_IMPORT,
        )
    };
    let odd = ["1", "3", "5", "7"].iter().map(|l| level(l)).collect();
    let held = ["2_Validation", "4_Validation", "6_Validation"]
        .iter()
        .map(|l| level(l))
        .collect();
    (odd, held)
}

/// `model` validated on the F-16's held-out levels over `band`; each
/// level's e_RMS and share of the RMS asserted as the validation pages' row `| {row}
/// | level {l} |` prints them; the shares (%).
fn f16_validation_is_as_pinned(
    work: &Path,
    model: &Path,
    held: &[PathBuf],
    band: &str,
    row: &str,
) -> Vec<f64> {
    let val = work.join("val");
    let mut args: Vec<&str> = vec!["validate", s(model)];
    args.extend(held.iter().map(|p| s(p)));
    args.extend(["--band", band, "-q", "--out", s(&val)]);
    run_ok(&args);
    let v = json(&val.join("validate.json"));
    let mut shares = Vec::new();
    for (r, l) in v["recordings"].as_array().unwrap().iter().zip([2, 4, 6]) {
        let relative = 100.0 * r["window"]["relative"].as_f64().unwrap();
        let e_rms = r["window"]["e_rms"].as_f64().unwrap();
        eprintln!("level {l}: e_RMS {e_rms:.3} m/s^2, {relative:.1} % of the RMS");
        let shown =
            common::pinned_figures(&format!("| {row} | level {l} |")).expect("pinned figures");
        common::assert_pinned_figure(&format!("level {l} e_RMS"), e_rms, shown[0]);
        common::assert_pinned_figure(&format!("level {l} share (%)"), relative, shown[1]);
        shares.push(relative);
    }
    shares
}

/// The validation pages' UNESP walkthrough: three chirps diagnosed on mode 2's band,
/// as the validation pages' commands do; its figures are pinned (the shaker's lag,
/// a softening cubic stiffness and a clearance kept, the residual still far
/// above the noise).
#[test]
fn unesp_diagnosis_is_as_pinned() {
    let Some(data) = common::dataset("bolted_beam_unesp_bert") else {
        return;
    };
    let sources: Vec<PathBuf> = ["0p05", "0p15", "0p25"]
        .iter()
        .map(|l| data.join(format!("csv/chirp_70to110Hz_{l}V_time.csv")))
        .collect();
    let (_dir, diagnosis) = diagnose_walkthrough(
        &sources,
        &super::protocols::UNESP_IMPORT,
        &super::protocols::UNESP_REDUCTION,
    );
    assert_pinned_diagnosis(
        "Diagnosis figures (UNESP):",
        &diagnosis,
        &[
            ("shaker", &["te"]),
            ("cubic_stiffness", &["k3"]),
            ("second_mode", &["frequency_hz"]),
        ],
    );
    // voltage to laser velocity, first modal constant negative: a transfer,
    // so a further mode of negative modal constant is judged by its size
    // (unresolved where it lowered chi-square enough), never refused for
    // its sign
    let d = json(&diagnosis);
    assert_eq!(d["response_sign"], -1.0);
    let modes: Vec<&serde_json::Value> = d["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["effect"] == "second_mode")
        .collect();
    assert_eq!(modes.len(), 3, "{modes:?}");
    assert!(
        modes.iter().any(|c| c["verdict"] == "size_not_resolved"),
        "{modes:?}"
    );
    for c in modes {
        let note = c["note"].as_str().unwrap_or_default();
        assert!(!note.contains("driving-point"), "{c}");
    }
    // over a band around one mode the back-EMF damping is the modes' own:
    // its interval holds zero (at its bound, the one-sided range the data
    // allow), while the lag's is narrow
    let shaker = &d["selected"][0]["parameters"];
    let ci = |n: &str| {
        let c = shaker[n]["ci95"].as_array().unwrap();
        (c[0].as_f64().unwrap(), c[1].as_f64().unwrap())
    };
    assert!(ci("ce").0 <= 0.0 && ci("ce").1 > 0.0, "{shaker}");
    assert!(ci("te").1 < 2.0 * ci("te").0, "{shaker}");
}

/// The UNESP beam's first mode (about 18.7 Hz) from the 0-40 Hz chirps,
/// which start at 0 Hz (refused before 2026-11-26: no period at the
/// sweep's start): diagnosed over 15-22 Hz as a transfer (the laser is not
/// at the drive). The joint model is left near the noise and nothing is
/// kept; the pinned figures are pinned.
#[test]
fn unesp_first_mode_diagnosis_is_as_pinned() {
    let Some(data) = common::dataset("bolted_beam_unesp_bert") else {
        return;
    };
    let sources: Vec<PathBuf> = ["0p05", "0p15", "0p25"]
        .iter()
        .map(|l| data.join(format!("csv/chirp_0to40Hz_{l}V_time.csv")))
        .collect();
    let (_dir, diagnosis) = diagnose_walkthrough(
        &sources,
        &super::protocols::UNESP_IMPORT,
        &[
            "--band",
            "15:22",
            "--linear-start",
            "lowest",
            "--hop-periods",
            "4",
            "--max-harmonic",
            "3",
            "--transfer",
        ],
    );
    let d = json(&diagnosis);
    assert!(
        d["selected"].as_array().unwrap().is_empty(),
        "{}",
        d["explanation"]
    );
    let best = d["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|c| c["chi2_per_dof"].as_f64().map(|x| (x, c)))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap();
    let figures = [
        100.0 * d["baseline"]["error_relative"].as_f64().unwrap(),
        d["baseline"]["chi2_per_dof"].as_f64().unwrap(),
        best.0,
    ];
    eprintln!("{figures:?}, best {}", best.1["effect"]);
    assert_eq!(best.1["effect"], "hysteretic_mode");
    assert_eq!(best.1["verdict"], "size_not_resolved");
    let shown =
        common::pinned_figures("Diagnosis figures (UNESP, mode 1):").expect("pinned figures");
    assert_eq!(shown.len(), figures.len());
    for (value, shown) in figures.into_iter().zip(shown) {
        common::assert_pinned_figure("UNESP mode 1", value, shown);
    }
}

/// A pinned table's column: its heading and how a row's figure is read.
type Column = (&'static str, fn(&serde_json::Value) -> f64);

/// Runs `protocol` on the data set `name` (nothing where it is absent)
/// and pins each row it returns to the validation pages' row that starts with the
/// matching `rows` entry: the figures `columns` read from it, in the
/// README's order. Returns the rows.
fn pin_protocol_rows(
    work: &Path,
    name: &str,
    protocol: fn(&Path, &Path) -> Vec<serde_json::Value>,
    rows: [&str; 3],
    columns: &[Column],
) -> Vec<serde_json::Value> {
    let Some(dir) = common::dataset(name) else {
        return Vec::new();
    };
    let got = protocol(&dir, work);
    assert_eq!(got.len(), rows.len(), "{name}: {got:?}");
    for (r, row) in got.iter().zip(rows) {
        eprintln!("{row} {r}");
        let shown = common::pinned_figures(row).expect("pinned figures");
        assert_eq!(shown.len(), columns.len(), "{row}: {shown:?}");
        for ((what, value), shown) in columns.iter().zip(shown) {
            common::assert_pinned_figure(&format!("{row} {what}"), value(r), shown);
        }
    }
    got
}

fn field(r: &serde_json::Value, k: &str) -> f64 {
    r[k].as_f64().unwrap_or_else(|| panic!("{k} in {r}"))
}

/// Issue 13's F-16 and UNESP protocols in the time domain, run as `cargo
/// bench --bench datasets` runs them (`tests/protocols`): each validation
/// recording's row of the validation pages' table (e_RMS, its share of the RMS over
/// the band's window, the linearised model's share, the target). The
/// targets themselves (15 %, 5 %) are not met and not asserted; the
/// issue's other criterion is: the joint model at least 3 times closer
/// than the linearised one on every validation recording.
#[test]
fn datasets_time_protocols_are_as_pinned() {
    let work = tempfile::tempdir().unwrap();
    let columns: [Column; 4] = [
        ("e_RMS", |r| field(r, "e_rms")),
        ("its share of the RMS (%)", |r| {
            100.0 * field(r, "e_rms_relative")
        }),
        ("the linearised model's (%)", |r| {
            100.0 * field(r, "linear_e_rms_relative")
        }),
        ("the target (%)", |r| 100.0 * field(r, "target_relative")),
    ];
    for (name, protocol, rows) in [
        (
            "f16_gvt_benchmark",
            super::protocols::f16 as fn(&Path, &Path) -> Vec<serde_json::Value>,
            [
                "| F-16 | level 2 |",
                "| F-16 | level 4 |",
                "| F-16 | level 6 |",
            ],
        ),
        (
            "bolted_beam_unesp_bert",
            super::protocols::unesp,
            [
                "| UNESP | 0.10 V |",
                "| UNESP | 0.20 V |",
                "| UNESP | 0.30 V |",
            ],
        ),
    ] {
        for r in pin_protocol_rows(work.path(), name, protocol, rows, &columns) {
            assert!(
                field(&r, "linear_e_rms_relative") >= 3.0 * field(&r, "e_rms_relative"),
                "{r}: not 3 times closer than the linearised model"
            );
        }
    }
}

/// The validation pages' F-16 time-domain fit with a hysteretic mode: the odd
/// levels fitted from `signals/f16_hysteretic_mode_start.toml` (the
/// three-mode fit's model plus the 6.2-6.6 Hz mode with a joint of its
/// own, and an Iwan joint at the drive point), validated on the even
/// levels over 4.5-9 Hz. The fit is the one `cargo bench --bench datasets`
/// makes (`tests/protocols`: the walkthrough command), so its
/// rows of the validation pages' second protocols table are pinned here, then the
/// walkthrough's own validation: each level's share of the RMS, below
/// the three-mode protocol's, and where the residual lies in frequency.
#[test]
fn f16_time_fit_with_a_hysteretic_mode_is_as_pinned() {
    if common::dataset("f16_gvt_benchmark").is_none() {
        return;
    }
    let work = tempfile::tempdir().unwrap();
    let held = pin_from_start_rows(
        work.path(),
        "f16_gvt_benchmark",
        super::protocols::f16_from_start,
        [
            "| F-16 | hysteretic mode | level 2 |",
            "| F-16 | hysteretic mode | level 4 |",
            "| F-16 | hysteretic mode | level 6 |",
        ],
    );
    let out = super::protocols::fit_dir(work.path(), "f16", true);
    // the fit's final errors are split by frequency about its band too: the
    // parts (Parseval, one FFT) add up to the window's relative e_RMS (a sum
    // in time)
    let fitted = json(&out.join("fit.json"));
    for a in fitted["time_domain"]["after"].as_array().unwrap() {
        let w = &a["window"];
        let b = &w["by_frequency"];
        let parts: f64 = ["below", "inside", "above", "beyond"]
            .iter()
            .map(|p| b[*p]["error"].as_f64().unwrap().powi(2))
            .sum();
        let relative = w["relative"].as_f64().unwrap();
        assert!((parts.sqrt() / relative - 1.0).abs() < 1e-9, "{a}");
    }
    let shares = f16_validation_is_as_pinned(
        work.path(),
        &out.join("fit.json"),
        &held,
        "4.5:9",
        "F-16 with a hysteretic mode",
    );
    for (relative, l) in shares.into_iter().zip([2, 4, 6]) {
        let without =
            common::pinned_figures(&format!("| F-16 | level {l} |")).expect("pinned figures");
        assert!(
            relative < without[1].0,
            "level {l}: {relative} % vs {} % without",
            without[1].0
        );
    }
    // where the residual lies in frequency, over each level's window
    let v = json(&work.path().join("val/validate.json"));
    for (r, l) in v["recordings"].as_array().unwrap().iter().zip([2, 4, 6]) {
        let b = &r["window"]["by_frequency"];
        let pc = |part: &str, of: &str| 100.0 * b[part][of].as_f64().unwrap();
        let figures = [
            ("error in the band", pc("inside", "error")),
            ("error just above it", pc("above", "error")),
            ("error beyond", pc("beyond", "error")),
            ("measured beyond", pc("beyond", "measured")),
            ("model beyond", pc("beyond", "simulated")),
        ];
        let shown = common::pinned_figures(&format!(
            "| by frequency, F-16 with a hysteretic mode | level {l} |"
        ))
        .expect("pinned figures");
        assert_eq!(shown.len(), figures.len(), "{shown:?}");
        for ((what, value), shown) in figures.into_iter().zip(shown) {
            common::assert_pinned_figure(&format!("level {l} {what} (%)"), value, shown);
        }
    }
}

/// Issue 13's UNESP protocol with the shaker (issue 12): the time-domain fit
/// of the 0.05 / 0.15 / 0.25 V chirps started from the FRF fit's mode and
/// Masing joint plus the diagnosis's shaker lag
/// (`signals/unesp_shaker_start.toml`, a transfer: `response_sign = -1`),
/// validated on the 0.10 / 0.20 / 0.30 V chirps over 88-100 Hz. The validation pages'
/// rows are pinned, and each is below the protocol's own (no shaker).
#[test]
fn unesp_time_fit_with_the_shaker_is_as_pinned() {
    let Some(data) = common::dataset("bolted_beam_unesp_bert") else {
        return;
    };
    let work = tempfile::tempdir().unwrap();
    let fitted = unesp_time_fit(&data, work.path(), "unesp_shaker_start.toml", &[]);
    let te = fitted.fit["time_domain"]["parameters"]["shaker.te"]["value"]
        .as_f64()
        .unwrap();
    let first =
        common::pinned_figures("UNESP with the shaker, fitted lag:").expect("pinned figures");
    common::assert_pinned_figure("the fitted lag te (s)", te, first[0]);
    for (relative, l) in fitted.pin_rows("UNESP with the shaker") {
        let without =
            common::pinned_figures(&format!("| UNESP | {l} V |")).expect("pinned figures");
        assert!(
            relative < without[1].0,
            "{l} V: {relative} % vs {} % without",
            without[1].0
        );
    }
}

/// The same with a second, broad mode beside the joint's
/// (`signals/unesp_background_start.toml`): the fit drives its damping ratio
/// to the bound (a background, not a resonance), and the two lower validation
/// chirps come within issue 13's 5 %. The fit is the one `cargo bench
/// --bench datasets` makes (`tests/protocols`), so its rows of the validation pages'
/// second protocols table are pinned here; then the walkthrough's
/// validation: the validation pages' rows and the background's figures, each row
/// below the shaker-only fit's.
#[test]
fn unesp_time_fit_with_a_background_is_as_pinned() {
    if common::dataset("bolted_beam_unesp_bert").is_none() {
        return;
    }
    let work = tempfile::tempdir().unwrap();
    let held = pin_from_start_rows(
        work.path(),
        "bolted_beam_unesp_bert",
        super::protocols::unesp_from_start,
        [
            "| UNESP | shaker and background | 0.10 V |",
            "| UNESP | shaker and background | 0.20 V |",
            "| UNESP | shaker and background | 0.30 V |",
        ],
    );
    let out = super::protocols::fit_dir(work.path(), "unesp", true);
    let fitted = unesp_validation(work.path(), &out, &held);
    let p = &fitted.fit["time_domain"]["parameters"];
    let value = |name: &str| p[name]["value"].as_f64().unwrap();
    assert_eq!(
        value("second_mode.damping_ratio"),
        0.9,
        "the background's damping sits at its bound"
    );
    let line = common::pinned_figures("UNESP with a background, fitted:").expect("pinned figures");
    common::assert_pinned_figure(
        "the background's frequency (Hz)",
        value("second_mode.frequency_hz"),
        line[0],
    );
    common::assert_pinned_figure(
        "the background's residue",
        value("second_mode.residue"),
        line[1],
    );
    common::assert_pinned_figure("the lag te (s)", value("shaker.te"), line[2]);
    for (relative, l) in fitted.pin_rows("UNESP with the shaker and a background") {
        let shaker = common::pinned_figures(&format!("| UNESP with the shaker | {l} V |"))
            .expect("pinned figures");
        assert!(
            relative < shaker[1].0,
            "{l} V: {relative} % vs {} % with the shaker alone",
            shaker[1].0
        );
    }
}

/// `identify --each-alone` on the UNESP chirps, the fit of the background
/// start (as `unesp_time_fit_with_a_background_is_as_pinned` makes it):
/// each chirp refitted alone from the fitted model comes 1.7-2.6x closer
/// than in the fit of all three (2.4x at the median), and the note says
/// that what the model lacks changes from one level to the next: measured
/// data, not hystid's (`fit::time` tests the consistent case, 1.00x, and a
/// structure changed between runs on hystid's own recordings). Figures
/// pinned in the validation pages.
#[test]
fn unesp_chirps_refitted_alone_come_closer_than_together() {
    let Some(data) = common::dataset("bolted_beam_unesp_bert") else {
        return;
    };
    let work = tempfile::tempdir().unwrap();
    let fitted = unesp_time_fit(
        &data,
        work.path(),
        "unesp_background_start.toml",
        &["--each-alone"],
    );
    let t = &fitted.fit["time_domain"];
    let alone = t["each_alone"].as_array().expect("each_alone");
    assert_eq!(alone.len(), 3);
    let mut closer = Vec::new();
    for ((a, after), l) in alone
        .iter()
        .zip(t["after"].as_array().unwrap())
        .zip(["0.05", "0.15", "0.25"])
    {
        assert_eq!(a["status"], "converged", "{a}");
        assert_eq!(a["recording"], after["recording"]);
        let (together, by_itself) = (
            a["together"].as_f64().unwrap(),
            a["alone"].as_f64().unwrap(),
        );
        assert_eq!(together, after["window"]["relative"].as_f64().unwrap());
        let row = common::pinned_figures(&format!("| UNESP refitted alone | {l} V |"))
            .expect("pinned figures");
        common::assert_pinned_figure(&format!("{l} V together (%)"), 100.0 * together, row[0]);
        common::assert_pinned_figure(&format!("{l} V alone (%)"), 100.0 * by_itself, row[1]);
        closer.push(together / by_itself);
    }
    closer.sort_by(f64::total_cmp);
    assert!(
        closer[0] > hystid::fit::time::CLOSER_ALONE,
        "every chirp comes closer alone: {closer:?}"
    );
    let line =
        common::pinned_figures("UNESP refitted alone, at the median:").expect("pinned figures");
    common::assert_pinned_figure("the median (x)", closer[1], line[0]);
    let notes = t["notes"].as_array().unwrap();
    let note = notes.last().unwrap().as_str().unwrap();
    assert!(
        note.starts_with(&format!(
            "refitted alone, the recordings come {:.2}x closer",
            closer[1]
        )) && note.contains("changes from one to the next"),
        "{note}"
    );
}

/// The UNESP fit with a background replayed as the continuous model
/// (`--replay continuous`): from the given start alone it settles in a
/// basin where the mode's viscous damping does the joint's work (11.2,
/// 8.9 and 5.7 % on the fitted chirps, 10.9 % at 0.10 V); descending from
/// two starts (`--starts 2`), the spread one reaches
/// well under half the given start's misfit (0.3), and every validation
/// chirp is closer than the shaker's fit without the background. Figures
/// pinned in the validation pages.
#[test]
fn unesp_time_fit_from_several_starts_leaves_the_worse_basin() {
    let Some(data) = common::dataset("bolted_beam_unesp_bert") else {
        return;
    };
    let work = tempfile::tempdir().unwrap();
    let fitted = unesp_time_fit(
        &data,
        work.path(),
        "unesp_background_start.toml",
        &["--replay", "continuous", "--starts", "2"],
    );
    let starts = fitted.fit["time_domain"]["starts"].as_array().unwrap();
    assert_eq!(starts.len(), 2);
    let misfit = |k: usize| starts[k]["misfit"].as_f64().unwrap();
    let best = (0..2)
        .min_by(|&a, &b| misfit(a).total_cmp(&misfit(b)))
        .unwrap();
    eprintln!(
        "misfits: {:?}; the lowest start {best}'s",
        (0..2).map(misfit).collect::<Vec<_>>()
    );
    assert_ne!(best, 0, "a spread start does better than the given one");
    assert!(misfit(best) < 0.5 * misfit(0), "{starts:?}");
    let notes = fitted.fit["time_domain"]["notes"].to_string();
    assert!(notes.contains(&format!("start {best}'s")), "{notes}");
    let line =
        common::pinned_figures("UNESP with a background from two starts:").expect("pinned figures");
    common::assert_pinned_figure("the given start's misfit", misfit(0), line[0]);
    common::assert_pinned_figure("the lowest misfit", misfit(best), line[1]);
    for (relative, l) in fitted.pin_rows("UNESP with a background, continuous, two starts") {
        let one = common::pinned_figures(&format!("| UNESP with the shaker | {l} V |"))
            .expect("pinned figures");
        eprintln!("{l} V: {relative:.1} % (the shaker alone: {} %)", one[1].0);
        assert!(relative < one[1].0, "{l} V: {relative} %");
    }
}

/// Issue 12's case of the lap-joint beam's first mode: both bending modes
/// in one model, fitted in the time domain on the 0.05, 0.15 and 0.25 V
/// chirps of both bands at once (0-40 Hz through the first mode, 70-110 Hz
/// through the second) from `signals/unesp_two_modes_start.toml`: the second
/// mode with the drive-point Masing joint, the first a hysteretic mode with
/// a Segalman Iwan joint of its own. Validated on the 0.10, 0.20 and 0.30 V
/// chirps of each band over its mode's window (15-22 and 88-100 Hz), it
/// follows the first mode's damping with level where the same model with
/// that mode linear (its joint held stuck) cannot: closer at every
/// validation level, about twice as close at the loudest. Figures pinned in
/// the validation pages.
#[test]
fn unesp_two_nonlinear_modes_are_as_pinned() {
    let Some(data) = common::dataset("bolted_beam_unesp_bert") else {
        return;
    };
    let work = tempfile::tempdir().unwrap();
    let chirp = |band: &str, stem: &str, l: &str| {
        super::protocols::import(
            work.path(),
            &data.join(format!("csv/chirp_{band}Hz_{l}V_time.csv")),
            &format!("{stem}{l}"),
            &super::protocols::UNESP_IMPORT,
        )
    };
    let levels = |ls: [&str; 3]| -> Vec<PathBuf> {
        ls.iter()
            .flat_map(|l| [chirp("0to40", "m", l), chirp("70to110", "c", l)])
            .collect()
    };
    let (fit, held) = (
        levels(["0p05", "0p15", "0p25"]),
        levels(["0p10", "0p20", "0p30"]),
    );
    let start = Path::new(env!("CARGO_MANIFEST_DIR")).join("signals/unesp_two_modes_start.toml");
    // the same model, its first mode linear: at its stuck frequency, its
    // joint stuck and held
    let text = std::fs::read_to_string(&start).unwrap();
    let (bare, iwan) = (
        "frequency_hz = 14.75",
        r#"joint = { kind = "iwan4", kt = 106.0, fs = 2.0, chi = -0.5, beta = 0.5 }"#,
    );
    assert!(text.contains(bare) && text.contains(iwan));
    let linear = work.path().join("linear_first_mode.toml");
    std::fs::write(
        &linear,
        text.replace(bare, "frequency_hz = 18.7").replace(
            iwan,
            r#"joint = { kind = "jenkins", kd = 1.0e-6, fd = 1.0e6 }"#,
        ),
    )
    .unwrap();
    let fitted = |start: &Path, name: &str, extra: &[&str]| {
        let out = work.path().join(name);
        let mut args: Vec<&str> = vec!["identify"];
        args.extend(fit.iter().map(|p| s(p)));
        args.extend([
            "--domain",
            "time",
            "--start",
            s(start),
            "-q",
            "--out",
            s(&out),
        ]);
        args.extend(extra);
        run_ok(&args);
        out.join("fit.json")
    };
    let validated = |fit_json: &Path, name: &str| {
        // each band's held-out chirps over its mode's window
        [("m", "15:22"), ("c", "88:100")].map(|(stem, band)| {
            let val = work.path().join(format!("{name}_{stem}"));
            let mut args: Vec<&str> = vec!["validate", s(fit_json)];
            let chirps: Vec<&PathBuf> = held
                .iter()
                .filter(|p| p.file_name().unwrap().to_str().unwrap().starts_with(stem))
                .collect();
            args.extend(chirps.iter().map(|p| s(p)));
            args.extend(["--band", band, "-q", "--out", s(&val)]);
            run_ok(&args);
            json(&val.join("validate.json"))["recordings"]
                .as_array()
                .unwrap()
                .iter()
                .map(|r| 100.0 * r["window"]["relative"].as_f64().unwrap())
                .collect::<Vec<f64>>()
        })
    };
    let two = fitted(&start, "two", &[]);
    let [first, second] = validated(&two, "two");
    let lin = fitted(
        &linear,
        "linear",
        &["--fix", "hysteretic_mode.joint.kd,hysteretic_mode.joint.fd"],
    );
    let [first_linear, second_linear] = validated(&lin, "linear");
    eprintln!(
        "first mode, 15-22 Hz: {first:.1?} % ({first_linear:.1?} % linear); second, 88-100 Hz: {second:.1?} % ({second_linear:.1?} %)"
    );
    let f = json(&two);
    let p = &f["time_domain"]["parameters"];
    let value = |name: &str| p[name]["value"].as_f64().unwrap();
    let mode: Vec<f64> = [
        "hysteretic_mode.frequency_hz",
        "hysteretic_mode.joint.kt",
        "hysteretic_mode.joint.fs",
        "hysteretic_mode.joint.chi",
        "hysteretic_mode.joint.beta",
    ]
    .iter()
    .map(|n| value(n))
    .collect();
    eprintln!("the first mode: {mode:?}");
    for (row, figures) in [
        (
            "| the first mode, a hysteretic mode with an Iwan joint |",
            first.iter().chain(&second),
        ),
        (
            "| the first mode linear |",
            first_linear.iter().chain(&second_linear),
        ),
    ] {
        let shown = common::pinned_figures(row).expect("pinned figures");
        let figures: Vec<f64> = figures.copied().collect();
        assert_eq!(shown.len(), figures.len(), "{row}");
        for ((value, shown), k) in figures.iter().zip(shown).zip(0..) {
            common::assert_pinned_figure(&format!("{row} {k}"), *value, shown);
        }
    }
    let line =
        common::pinned_figures("The first mode's own joint, fitted:").expect("pinned figures");
    for ((what, v), shown) in ["bare frequency", "kt", "fs", "chi", "beta"]
        .iter()
        .zip(&mode)
        .zip(line)
    {
        common::assert_pinned_figure(what, *v, shown);
    }
    // the first mode closer at every validation level with its own joint,
    // and about twice as close at the loudest; the second about as before
    for (k, (a, b)) in first.iter().zip(&first_linear).enumerate() {
        assert!(a < b, "level {k}: {a} % against {b} % linear");
    }
    assert!(
        first[2] < 0.6 * first_linear[2],
        "{first:?} {first_linear:?}"
    );
    assert!(
        second
            .iter()
            .zip(&second_linear)
            .all(|(a, b)| (a - b).abs() < 2.0)
    );
    assert!((-1.0..0.0).contains(&mode[3]), "chi {}", mode[3]);
}

/// A UNESP time-domain fit from a start in `signals/` and its validation.
struct UnespTimeFit {
    fit: serde_json::Value,
    validation: serde_json::Value,
}

impl UnespTimeFit {
    /// Pins the validation pages' rows `| {model} | {l} V | e_RMS | share |`; returns
    /// each validation chirp's share of the RMS (%) with its level.
    fn pin_rows(&self, model: &str) -> Vec<(f64, &'static str)> {
        let mut shares = Vec::new();
        for (r, l) in self.validation["recordings"]
            .as_array()
            .unwrap()
            .iter()
            .zip(["0.10", "0.20", "0.30"])
        {
            let relative = 100.0 * r["window"]["relative"].as_f64().unwrap();
            let e_rms = r["window"]["e_rms"].as_f64().unwrap();
            eprintln!("{model}, {l} V: e_RMS {e_rms:.4} m/s, {relative:.1} % of the RMS");
            let shown =
                common::pinned_figures(&format!("| {model} | {l} V |")).expect("pinned figures");
            common::assert_pinned_figure(&format!("{l} V e_RMS"), e_rms, shown[0]);
            common::assert_pinned_figure(&format!("{l} V share (%)"), relative, shown[1]);
            shares.push((relative, l));
        }
        shares
    }
}

/// Fits the 0.05 / 0.15 / 0.25 V chirps in the time domain from
/// `signals/{start}` over 88-100 Hz and validates on the 0.10 / 0.20 / 0.30 V
/// ones.
fn unesp_time_fit(data: &Path, work: &Path, start: &str, extra: &[&str]) -> UnespTimeFit {
    let chirp = |l: &str| {
        super::protocols::import(
            work,
            &data.join(format!("csv/chirp_70to110Hz_{l}V_time.csv")),
            &format!("c{l}"),
            &super::protocols::UNESP_IMPORT,
        )
    };
    let fit: Vec<PathBuf> = ["0p05", "0p15", "0p25"].iter().map(|l| chirp(l)).collect();
    let held: Vec<PathBuf> = ["0p10", "0p20", "0p30"].iter().map(|l| chirp(l)).collect();
    let start = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("signals")
        .join(start);
    let out = work.join("fit");
    let mut args: Vec<&str> = vec!["identify"];
    args.extend(fit.iter().map(|p| s(p)));
    args.extend([
        "--domain",
        "time",
        "--start",
        s(&start),
        "--band",
        "88:100",
        "-q",
        "--out",
        s(&out),
    ]);
    args.extend(extra);
    run_ok(&args);
    unesp_validation(work, &out, &held)
}

/// The fit in `out` validated on `held` over 88-100 Hz.
fn unesp_validation(work: &Path, out: &Path, held: &[PathBuf]) -> UnespTimeFit {
    let fitted = json(&out.join("fit.json"));
    assert_eq!(fitted["time_domain"]["response_sign"], -1.0);
    let val = work.join("val");
    let fit_json = out.join("fit.json");
    let mut args: Vec<&str> = vec!["validate", s(&fit_json)];
    args.extend(held.iter().map(|p| s(p)));
    args.extend(["--band", "88:100", "-q", "--out", s(&val)]);
    run_ok(&args);
    UnespTimeFit {
        fit: fitted,
        validation: json(&val.join("validate.json")),
    }
}

/// The validation pages' second protocols table's rows of data set `name`:
/// `protocol` (fitted from a model in `signals/`, as `cargo bench --bench
/// datasets` adds them to its rows as `from_start`) run into `work`, each
/// row's e_RMS, share of the RMS and target pinned. The held-out
/// recordings, as the protocol imported them into `work`.
fn pin_from_start_rows(
    work: &Path,
    name: &str,
    protocol: fn(&Path, &Path) -> Vec<serde_json::Value>,
    rows: [&str; 3],
) -> Vec<PathBuf> {
    let columns: [Column; 3] = [
        ("e_RMS", |r| field(r, "e_rms")),
        ("its share of the RMS (%)", |r| {
            100.0 * field(r, "e_rms_relative")
        }),
        ("the target (%)", |r| 100.0 * field(r, "target_relative")),
    ];
    pin_protocol_rows(work, name, protocol, rows, &columns)
        .iter()
        .map(|r| {
            assert!(
                r["start"]
                    .as_str()
                    .is_some_and(|s| s.starts_with("signals/")),
                "{r}"
            );
            work.join(r["recording"].as_str().expect("the row's recording"))
        })
        .collect()
}

/// Issue 13's diagnosis on time-domain fits, on data hystid did not make:
/// the Bouc-Wen benchmark's estimation multisine, fitted with hystid's
/// default Masing joint and diagnosed at the lines of its period, the
/// Bouc-Wen law among the candidates. The law the data were made with is
/// traced first, added and refitted: the misfit falls to the noise, and the
/// final model validates on the swept test set within issue 13's target
/// (3e-6 m). pinned figures pinned.
#[test]
fn bouc_wen_benchmark_diagnosed_at_its_lines_finds_its_law() {
    let Some(data) = common::dataset("boucwen_benchmark") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    import_bouc_wen(&data, dir.path(), &["est", "sweep"]);
    let out = dir.path().join("diag");
    let printed = run_ok(&[
        "diagnose",
        s(&dir.path().join("est.json")),
        "--out",
        s(&out),
        "--domain",
        "time",
        "--candidates",
        "default,bouc_wen_joint",
        "--min-samples-per-period",
        "80",
    ]);
    eprintln!("{printed}");
    let d = json(&out.join("diagnosis.json"));
    let selected: Vec<&str> = d["selected"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e.as_str().unwrap())
        .collect();
    let traced = &d["rounds"][0]["traced"][0];
    let misfit =
        |fit: &serde_json::Value| 100.0 * fit["after"][0]["segment_relative"].as_f64().unwrap();
    let (before, after) = (misfit(&d["baseline"]), misfit(&d["refit"]));
    let chi2 = |r: &serde_json::Value| r["chi2_per_line"].as_f64().unwrap();
    let (chi2_before, chi2_after) = (chi2(&d["rounds"][0]["residual"]), chi2(&d["residual"]));
    let share = 100.0 * traced["share"].as_f64().unwrap();
    let val = dir.path().join("val");
    run_ok(&[
        "validate",
        s(&out.join("diagnosis.json")),
        s(&dir.path().join("sweep.json")),
        "--out",
        s(&val),
        "--min-samples-per-period",
        "400",
        "-q",
    ]);
    let v = json(&val.join("validate.json"));
    let e_rms = v["recordings"][0]["whole"]["e_rms"].as_f64().unwrap();
    let p = |n: &str| d["refit"]["parameters"][n]["value"].as_f64().unwrap();
    let figures = [
        share,
        before,
        after,
        chi2_before,
        chi2_after,
        p("mass"),
        p("stiffness"),
        p("alpha"),
        e_rms,
    ];
    eprintln!("Bouc-Wen diagnosed at its lines: {figures:?}");
    let shown = common::pinned_figures("Bouc-Wen benchmark diagnosed at its lines:")
        .expect("pinned figures");
    for (i, (value, shown)) in figures.into_iter().zip(shown).enumerate() {
        common::assert_pinned_figure(&format!("Bouc-Wen diagnosis figure {i}"), value, shown);
    }
    assert_eq!(selected, ["bouc_wen_joint"], "{printed}");
    assert_eq!(traced["effect"], "bouc_wen_joint", "{printed}");
    assert!(
        chi2_after <= 1.3,
        "chi2 per line {chi2_before} -> {chi2_after}"
    );
    assert!(
        e_rms <= 3e-6,
        "the final model's e_RMS on the sweep: {e_rms:.3e} m"
    );
}
