//! The three data sets' protocols of issue 13, fitted in the time domain
//! on their estimation records and judged on held-out ones, through the
//! `hystid` binary with the validation pages' commands: shared by `cargo bench
//! --bench datasets` (the table and `target/datasets/report.json`) and the
//! test that pins the validation pages' table.
//!
//! - Bouc-Wen: fitted on the estimation multisine (no start written down),
//!   judged on the sine-sweep and multisine test sets (the latter one
//!   steady-state period, `--periodic`).
//! - F-16: fitted on the sine sweeps of levels 1, 3, 5, 7 over 4.5-9 Hz
//!   (three modes, a Masing joint), judged on levels 2, 4, 6 over the same
//!   band.
//! - UNESP: fitted on the 0.05, 0.15, 0.25 V chirps over 88-100 Hz (one
//!   mode, a Masing joint, driven by the voltage), judged on 0.10, 0.20,
//!   0.30 V.
//!
//! Each returns one row per validation recording: `dataset`, `recording`,
//! `e_rms` (the response's unit), `e_rms_relative` (a fraction of the
//! measured response's RMS over the judged window), `window_hz` (the band
//! the window is cut at; `null`: the whole record), `window_s`, `seconds`
//! (the fit's wall time plus this validation's), the linearised model's
//! `linear_e_rms_relative` where the protocol compares with it (the fitted
//! model with its joint's slip force times 1e9: it never slips, so it is
//! the low-amplitude linear model the joint model must beat), and the
//! issue's `target_relative` / `target_e_rms`.

#![allow(dead_code)]

use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

pub fn hystid() -> PathBuf {
    std::env::var_os("HYSTID_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_hystid")))
}

/// Runs `hystid args`; panics with its output on failure. Returns the wall
/// time.
pub fn run(args: &[&str]) -> f64 {
    let t = Instant::now();
    let o = Command::new(hystid())
        .args(args)
        .arg("-q")
        .output()
        .expect("hystid runs");
    assert!(
        o.status.code().is_some_and(|c| c == 0 || c == 3),
        "hystid {args:?}:\n{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    t.elapsed().as_secs_f64()
}

fn s(p: &Path) -> &str {
    p.to_str().expect("UTF-8 path")
}

fn read(p: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(p).expect("json")).expect("json parses")
}

/// `fit.json` with its joint's slip force times 1e9 (never slips), as a
/// file beside it.
pub fn linearised(fit: &Path) -> PathBuf {
    let mut v = read(fit);
    for model in ["model", "time_domain/model"] {
        let pointer = format!("/{model}/joint/fd");
        if let Some(fd) = v.pointer_mut(&pointer) {
            *fd = json!(fd.as_f64().expect("fd") * 1e9);
        }
    }
    let out = fit.with_file_name("fit_linearised.json");
    std::fs::write(&out, serde_json::to_vec(&v).unwrap()).unwrap();
    out
}

pub struct Protocol<'a> {
    pub dataset: &'static str,
    /// The fit's arguments after `identify` (the output directory added).
    pub fit: Vec<String>,
    /// Held-out recordings, with extra `validate` arguments each.
    pub validation: Vec<(PathBuf, Vec<&'a str>)>,
    pub window_hz: Option<(f64, f64)>,
    pub compare_linear: bool,
    pub target_relative: Option<f64>,
    pub target_e_rms: Option<f64>,
    /// A model written down to fit from (`identify --start`; a path from
    /// the crate's root), recorded in each row as `start`.
    pub start: Option<&'static str>,
}

/// Where [`run_protocol`] writes the fit of data set `dataset` (the
/// protocol's own name: `f16`, `unesp`, `bouc_wen`) inside `work`, fitted
/// from a start written down or not.
pub fn fit_dir(work: &Path, dataset: &str, from_start: bool) -> PathBuf {
    let variant = if from_start { "_start" } else { "" };
    work.join(format!("{dataset}{variant}_fit"))
}

pub fn run_protocol(p: &Protocol, work: &Path) -> Vec<Value> {
    let variant = if p.start.is_some() { "_start" } else { "" };
    let fit_dir = fit_dir(work, p.dataset, p.start.is_some());
    let _ = std::fs::remove_dir_all(&fit_dir);
    let mut args: Vec<&str> = vec!["identify", "--out", s(&fit_dir)];
    args.extend(p.fit.iter().map(String::as_str));
    let start = p
        .start
        .map(|f| Path::new(env!("CARGO_MANIFEST_DIR")).join(f));
    if let Some(f) = &start {
        args.extend(["--start", s(f)]);
    }
    let fit_seconds = run(&args);
    let fit = fit_dir.join("fit.json");
    let linear = p.compare_linear.then(|| linearised(&fit));
    let band = p.window_hz.map(|(a, b)| format!("{a}:{b}"));
    let mut rows = Vec::new();
    for (k, (rec, extra)) in p.validation.iter().enumerate() {
        let validate = |model: &Path, tag: &str| -> (Value, f64) {
            let out = work.join(format!("{}{variant}_val{k}{tag}", p.dataset));
            let _ = std::fs::remove_dir_all(&out);
            let mut a = vec![
                "validate",
                s(model),
                s(rec),
                "--out",
                s(&out),
                "--min-samples-per-period",
                "400",
            ];
            if let Some(b) = &band {
                a.extend(["--band", b.as_str()]);
            }
            a.extend(extra.iter().copied());
            let seconds = run(&a);
            let v = read(&out.join("validate.json"));
            let r = &v["recordings"][0];
            let judged = if r["window"].is_object() {
                r["window"].clone()
            } else {
                r["whole"].clone()
            };
            (judged, seconds)
        };
        let (judged, seconds) = validate(&fit, "");
        let lin = linear.as_ref().map(|l| validate(l, "_linear").0);
        rows.push(json!({
            "dataset": p.dataset,
            "recording": rec.file_name().unwrap().to_string_lossy(),
            "e_rms": judged["e_rms"],
            "e_rms_relative": judged["relative"],
            "window_hz": p.window_hz.map(|(a, b)| [a, b]),
            "window_s": [judged["start_s"], judged["end_s"]],
            "seconds": fit_seconds + seconds,
            "linear_e_rms_relative": lin.map(|l| l["relative"].clone()),
            "target_relative": p.target_relative,
            "target_e_rms": p.target_e_rms,
            "start": p.start,
        }));
    }
    rows
}

pub fn dataset(root: &Option<PathBuf>, name: &str) -> Option<PathBuf> {
    let dir = root.as_ref().map(|r| r.join(name)).filter(|d| d.is_dir());
    if dir.is_none() {
        println!(
            "SKIPPED: data set `{name}` not found (looked in $HYSTID_DATASETS or ../shared/datasets)"
        );
    }
    dir
}

/// Imports `source` into `work/name` with `args`; the recording's sidecar.
pub fn import(work: &Path, source: &Path, name: &str, args: &[&str]) -> PathBuf {
    let stem = work.join(name);
    let mut a = vec!["import", s(source), "--out", s(&stem)];
    a.extend(args);
    run(&a);
    stem.with_extension("json")
}

/// The Bouc-Wen benchmark's protocol (`d`: its folder).
pub fn bouc_wen(d: &Path, work: &Path) -> Vec<Value> {
    let mat = d.join("bouc-wen.mat");
    let rec = |name: &str, u: &str, y: &str, excitation: &str| {
        let (force, response) = (format!("force={u}:force"), format!("y={y}:displacement"));
        import(
            work,
            &mat,
            name,
            &[
                "-c",
                &force,
                "-c",
                &response,
                "--rate",
                "750",
                "--excitation",
                excitation,
            ],
        )
    };
    let est = rec("bw_est", "u", "y", "unknown");
    let sweep = rec("bw_sweep", "uval_sinesweep", "yval_sinesweep", "swept");
    let multisine = rec(
        "bw_multisine",
        "uval_multisine",
        "yval_multisine",
        "unknown",
    );
    run_protocol(
        &Protocol {
            dataset: "bouc_wen",
            fit: std::iter::once(s(&est))
                .chain(BOUC_WEN_FIT)
                .map(String::from)
                .collect(),
            validation: vec![(sweep, vec![]), (multisine, vec!["--periodic"])],
            window_hz: None,
            compare_linear: false,
            target_relative: None,
            target_e_rms: Some(3e-6),
            start: None,
        },
        work,
    )
}

/// `import`'s arguments for an F-16 level (the validation pages').
pub const F16_IMPORT: [&str; 8] = [
    "-c",
    "force=Force:force",
    "-c",
    "acc2=Acceleration(2):acceleration",
    "--rate",
    "variable:Fs",
    "--excitation",
    "swept",
];

/// `import`'s arguments for a UNESP chirp (the validation pages').
pub const UNESP_IMPORT: [&str; 6] = [
    "-c",
    "drive=shaker_amp_V:voltage",
    "-c",
    "laser=laser_velocity_m_per_s:velocity",
    "--excitation",
    "swept",
];

/// The UNESP walkthroughs' band and reduction (`identify`, `diagnose`):
/// mode 2's band, the smallest level's mode as the linear start.
pub const UNESP_REDUCTION: [&str; 8] = [
    "--band",
    "88:100",
    "--linear-start",
    "lowest",
    "--hop-periods",
    "8",
    "--max-harmonic",
    "3",
];

/// `identify`'s arguments after the recordings for the Bouc-Wen estimation
/// multisine (no start written down).
pub const BOUC_WEN_FIT: [&str; 8] = [
    "--domain",
    "time",
    "--element",
    "bouc_wen",
    "--fix",
    "nu",
    "--min-samples-per-period",
    "200",
];

/// A protocol of swept records: `records` imported, those at `fit` fitted
/// with `options`, those at `held_out` judged inside `band`, against the
/// linearised model too.
#[allow(clippy::too_many_arguments)] // one per column of the protocol's table
fn swept_protocol(
    dataset: &'static str,
    records: &[PathBuf],
    (fit, held_out): (&[usize], &[usize]),
    options: &[&str],
    band: (f64, f64),
    target_relative: f64,
    start: Option<&'static str>,
    work: &Path,
) -> Vec<Value> {
    let fit = fit
        .iter()
        .map(|&i| s(&records[i]))
        .chain(options.iter().copied())
        .map(String::from)
        .collect();
    run_protocol(
        &Protocol {
            dataset,
            fit,
            validation: held_out
                .iter()
                .map(|&i| (records[i].clone(), vec![]))
                .collect(),
            window_hz: Some(band),
            // the linearised model is the plain protocol's comparison
            compare_linear: start.is_none(),
            target_relative: Some(target_relative),
            target_e_rms: None,
            start,
        },
        work,
    )
}

/// The F-16's levels 1-7 imported into `work` (`d`: its folder).
fn f16_levels(d: &Path, work: &Path) -> Vec<PathBuf> {
    [
        "1",
        "2_Validation",
        "3",
        "4_Validation",
        "5",
        "6_Validation",
        "7",
    ]
    .iter()
    .map(|l| {
        import(
            work,
            &d.join(format!("BenchmarkData/F16Data_SineSw_Level{l}.mat")),
            &format!("f16_L{}", &l[..1]),
            &F16_IMPORT,
        )
    })
    .collect()
}

/// The F-16 ground vibration test's protocol (`d`: its folder).
pub fn f16(d: &Path, work: &Path) -> Vec<Value> {
    let options = [
        "--band",
        "4.5:9",
        "--linear-start",
        "lowest",
        "--hop-periods",
        "4",
        "--modes",
        "3",
        "--domain",
        "time",
    ];
    swept_protocol(
        "f16",
        &f16_levels(d, work),
        (&[0, 2, 4, 6], &[1, 3, 5]),
        &options,
        (4.5, 9.0),
        0.15,
        None,
        work,
    )
}

/// The F-16's protocol fitted from the model written down in
/// `signals/f16_hysteretic_mode_start.toml` (the three-mode fit's model
/// and the 6.2-6.6 Hz mode with a joint of its own).
pub fn f16_from_start(d: &Path, work: &Path) -> Vec<Value> {
    swept_protocol(
        "f16",
        &f16_levels(d, work),
        (&[0, 2, 4, 6], &[1, 3, 5]),
        &["--band", "4.5:9", "--domain", "time"],
        (4.5, 9.0),
        0.15,
        Some("signals/f16_hysteretic_mode_start.toml"),
        work,
    )
}

/// The UNESP beam's chirps imported into `work` (`d`: its folder).
fn unesp_chirps(d: &Path, work: &Path) -> Vec<PathBuf> {
    ["0p05", "0p10", "0p15", "0p20", "0p25", "0p30"]
        .iter()
        .map(|l| {
            import(
                work,
                &d.join(format!("csv/chirp_70to110Hz_{l}V_time.csv")),
                &format!("unesp_c{l}"),
                &UNESP_IMPORT,
            )
        })
        .collect()
}

/// The UNESP lap-joint beam's protocol (`d`: its folder).
pub fn unesp(d: &Path, work: &Path) -> Vec<Value> {
    let options: Vec<&str> = UNESP_REDUCTION
        .into_iter()
        .chain(["--domain", "time"])
        .collect();
    swept_protocol(
        "unesp",
        &unesp_chirps(d, work),
        (&[0, 2, 4], &[1, 3, 5]),
        &options,
        (88.0, 100.0),
        0.05,
        None,
        work,
    )
}

/// The UNESP beam's protocol fitted from the model written down in
/// `signals/unesp_background_start.toml` (the shaker and a broad
/// background beside the joint's mode).
pub fn unesp_from_start(d: &Path, work: &Path) -> Vec<Value> {
    swept_protocol(
        "unesp",
        &unesp_chirps(d, work),
        (&[0, 2, 4], &[1, 3, 5]),
        &["--band", "88:100", "--domain", "time"],
        (88.0, 100.0),
        0.05,
        Some("signals/unesp_background_start.toml"),
        work,
    )
}
