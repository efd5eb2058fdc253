//! Issue 12: hystid's `iwan4` joint against the reference kit's Iwan
//! joint, which is a different thing written from Segalman's definitions:
//! a parallel bank of 1001 Jenkins sliders, not a backbone under Masing's
//! rules.

use super::kit::corpus::{
    Case, CaseOptions, JointKind, Quantity, SampleFormat, Sweep, case_with, generate,
};
use super::kit::recording::write_recording;
use super::kit::refsim::{Hysteresis, IWAN_SLIDERS, RefJoint};
use super::kit::score::{hystid_bin, run_diagnose, run_identify, selected_effects};
use hystid::model::{Element, ElementSpec};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The element's force along a displacement history with inner loops,
/// partial wipe-out and full slip, against the slider bank's: the same
/// within 2e-5 of `F_S` (the issue asks 0.5 %; the bank's own
/// discretisation error is ~1e-5 of `F_S`, see
/// `reference_iwan_bank_follows_segalmans_closed_forms`).
#[test]
fn hystid_iwan4_is_the_slider_bank() {
    let (fs, kt) = (250.0, 2.0e7);
    for (chi, beta) in [(-0.5, 0.4), (-0.15, 2.0), (-0.85, 0.02)] {
        let mut bank = Hysteresis::new(RefJoint::Iwan4 { fs, kt, chi, beta });
        let mut element = ElementSpec::Iwan4 { fs, kt, chi, beta }.build().unwrap();
        let scale = fs / kt;
        let n = 20_000;
        let mut worst: f64 = 0.0;
        for i in 0..n {
            let t = i as f64 / n as f64;
            // a growing, then decaying, two-tone history: reversals inside
            // reversals, amplitudes from microslip to 3 slip displacements
            let envelope = 3.0 * (std::f64::consts::PI * t).sin();
            let x = scale
                * envelope
                * (0.8 * (2.0 * std::f64::consts::PI * 7.0 * t).sin()
                    + 0.3 * (2.0 * std::f64::consts::PI * 23.0 * t).sin());
            let f_bank = bank.update(x);
            let f = element.commit(x, 0.0).force;
            worst = worst.max((f - f_bank).abs() / fs);
        }
        eprintln!(
            "chi {chi}, beta {beta}: |iwan4 - bank of {} sliders| <= {worst:.1e} F_S",
            IWAN_SLIDERS + 1
        );
        assert!(
            worst < 2e-5,
            "chi {chi}, beta {beta}: iwan4 departs from the slider bank by {worst} F_S"
        );
    }
}

/// Recordings of an Iwan joint made by the reference simulator (a slider
/// bank, RK4; 10 % response noise, 0.5 % force noise, the corpus's random
/// structure, 6 levels from microslip to full slip x 16 frequencies), read
/// through the recording format like a user's:
///
/// - declared: `identify --element iwan4` recovers `F_S` and `K_T` within
///   3 %, `χ` within 0.05 and `β` within 20 % (issue 12);
/// - undeclared: `diagnose --element masing` (the paper's law) replaces the
///   joint by the `iwan4_joint` candidate, adds nothing else, recovers the
///   same figures, and its error in H1 falls at least 3x.
#[test]
fn iwan_joint_from_the_independent_simulator_is_identified_declared_or_not() {
    let o = CaseOptions {
        levels: Some(6),
        frequencies: Some(16),
        format: Some(SampleFormat::Pcm24),
        quantity: Some(Quantity::Displacement),
        sweep: Some(Sweep::Up),
        with_steps: Some(true),
        broad: false,
    };
    let mut cases = vec![
        case_with(
            201,
            JointKind::Iwan4 {
                chi: -0.5,
                beta: 0.5,
            },
            &[],
            &o,
        ),
        case_with(
            202,
            JointKind::Iwan4 {
                chi: -0.3,
                beta: 1.5,
            },
            &[],
            &o,
        ),
    ];
    for c in &mut cases {
        c.name = format!("iwan4-{}", c.seed);
        // 8 RK4 sub-steps per sample, not the corpus's 16: the 1001-slider
        // bank makes each stage 1000 times dearer, and halving the step
        // changes a response by ~1e-5 of its peak (`reference_step_halving`
        // measures 7e-6 from 16 to 32), far below the 10 % noise
        c.substeps = 8;
    }
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("independent-iwan");
    let failures: Vec<String> = std::thread::scope(|scope| {
        let handles: Vec<_> = cases
            .iter()
            .map(|case| {
                let dir = &dir;
                scope.spawn(move || check_case(case, dir))
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap())
            .collect()
    });
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// One case of the test above: its failures.
fn check_case(case: &Case, dir: &Path) -> Vec<String> {
    let (JointKind::Iwan4 { chi, beta }, kt, fs) = (case.joint, case.kd, case.fd) else {
        unreachable!("an Iwan case");
    };
    let rec = generate(case);
    let js = write_recording(&dir.join("recordings"), case, &rec).unwrap();
    drop(rec);
    let mut failures = Vec::new();
    // the validation pages' row of this recording and analysis
    let row = |how: &str| {
        let (JointKind::Iwan4 { chi, beta }, name) = (case.joint, &case.name) else {
            unreachable!()
        };
        crate::common::pinned_figures(&format!("| {name} (chi {chi}, beta {beta}) | {how} |"))
            .unwrap_or_else(|| panic!("no pinned row for {name}, {how}"))
    };
    let mut judge = |how: &str, got: [Option<f64>; 4]| {
        let [kt_hat, fs_hat, chi_hat, beta_hat] = got.map(|v| v.unwrap_or(f64::NAN));
        let rel = |a: f64, b: f64| (a / b - 1.0).abs();
        eprintln!(
            "{} {how}: kt {:+.3} %, fs {:+.3} %, chi {chi_hat:.4} (truth {chi}), beta {:+.2} %",
            case.name,
            100.0 * (kt_hat / kt - 1.0),
            100.0 * (fs_hat / fs - 1.0),
            100.0 * (beta_hat / beta - 1.0)
        );
        let shown = row(how);
        for (what, value, at) in [
            ("kt's error [%]", 100.0 * (kt_hat / kt - 1.0), 0),
            ("fs's error [%]", 100.0 * (fs_hat / fs - 1.0), 1),
            ("chi", chi_hat, 2),
            ("beta's error [%]", 100.0 * (beta_hat / beta - 1.0), 3),
        ] {
            crate::common::assert_pinned_figure(
                &format!("{} {how}: {what}", case.name),
                value,
                shown[at],
            );
        }
        if !(rel(kt_hat, kt) <= 0.03
            && rel(fs_hat, fs) <= 0.03
            && (chi_hat - chi).abs() <= 0.05
            && rel(beta_hat, beta) <= 0.2)
        {
            failures.push(format!(
                "{} {how}: kt {kt_hat} ({kt}), fs {fs_hat} ({fs}), chi {chi_hat} ({chi}), beta {beta_hat} ({beta})",
                case.name
            ));
        }
    };
    // declared
    let out = dir.join("out").join(&case.name).join("identify");
    let fit = run_identify(&hystid_bin(), &js, &out, "iwan4");
    let p = |n: &str| fit["parameters"][n]["value"].as_f64();
    judge(
        "`identify --element iwan4` (declared)",
        [p("kt"), p("fs"), p("chi"), p("beta")],
    );
    // undeclared
    let run = run_diagnose(
        &hystid_bin(),
        &js,
        &dir.join("out").join(&case.name).join("diagnose"),
        "masing",
        Duration::from_secs(900),
    );
    let Some(d) = run.diagnosis else {
        failures.push(format!(
            "{}: diagnose failed: {}",
            case.name, run.stderr_tail
        ));
        return failures;
    };
    let selected = selected_effects(&d);
    let j = &d["model"]["joint"];
    let how = "`diagnose --element masing` (undeclared): selects `iwan4_joint` alone";
    judge(
        how,
        [
            j["kt"].as_f64(),
            j["fs"].as_f64(),
            j["chi"].as_f64(),
            j["beta"].as_f64(),
        ],
    );
    let (before, after) = (
        d["baseline"]["error_relative"].as_f64().unwrap(),
        d["final"]["error_relative"].as_f64().unwrap(),
    );
    let chi2 = |at: &str| d[at]["chi2_per_dof"].as_f64().unwrap();
    let shown = row(how);
    for (what, value, at) in [
        ("the H1 error before [%]", 100.0 * before, 4),
        ("the H1 error after [%]", 100.0 * after, 5),
        ("chi2/dof before", chi2("baseline"), 6),
        ("chi2/dof after", chi2("final"), 7),
    ] {
        crate::common::assert_pinned_figure(&format!("{}: {what}", case.name), value, shown[at]);
    }
    eprintln!(
        "{}: selected {selected:?}, H1 error {:.2} % -> {:.2} % ({:.1}x), chi2/dof {:.1} -> {:.2}, {:.0} s",
        case.name,
        100.0 * before,
        100.0 * after,
        before / after,
        d["baseline"]["chi2_per_dof"].as_f64().unwrap(),
        d["final"]["chi2_per_dof"].as_f64().unwrap(),
        run.seconds
    );
    if selected != ["iwan4_joint"] {
        failures.push(format!("{}: selected {selected:?}", case.name));
    }
    // the final model states the swap once: the Iwan joint in place of the
    // Masing law, its parameters under the joint's plain names only
    let fm = &d["final_model"];
    let names: Vec<&str> = (fm["parameters"].as_object().unwrap().keys())
        .map(String::as_str)
        .collect();
    if fm["joint"] != "iwan4"
        || fm["replaced_joint"] != "masing"
        || fm["added_effects"] != serde_json::json!([])
        || names.iter().any(|n| n.starts_with("iwan4_joint."))
    {
        failures.push(format!(
            "{}: final model {} (replaced {}, added {}) with parameters {names:?}",
            case.name, fm["joint"], fm["replaced_joint"], fm["added_effects"]
        ));
    }
    if !(before >= 3.0 * after) {
        failures.push(format!(
            "{}: the H1 error fell from {before} only to {after}",
            case.name
        ));
    }
    failures
}
