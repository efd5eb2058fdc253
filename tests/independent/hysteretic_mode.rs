//! Issue 12: a hysteretic mode (a further mode that carries a joint of its
//! own) on recordings of the reference simulator, which knows no such
//! thing: the case's structure with its Jenkins joint, plus an SDOF with a
//! Jenkins joint of its own, each integrated by RK4 under the same force and
//! their motions added. Undeclared, `diagnose` must find it by name.

use super::kit::corpus::{
    CaseOptions, JointKind, Quantity, SampleFormat, Sweep, case_with, generate_with,
};
use super::kit::recording::write_recording;
use super::kit::refsim::{RefJoint, RefMode, RefSystem};
use super::kit::score::{hystid_bin, run_diagnose_with, selected_effects};
use std::f64::consts::PI;
use std::path::PathBuf;
use std::time::Duration;

/// The case's structure (a random mass, stiffness and Jenkins joint, 10 %
/// response noise, 0.5 % force noise, levels from microslip to full slip)
/// with a mode 1.3x its slipping frequency, 1.5 % damped, of twice its mass,
/// held by a joint as stiff as itself (stuck 1.84x) that slips from the
/// middle level up. `diagnose --element jenkins` (its default candidates)
/// selects `hysteretic_mode`, finds its frequency
/// within 1 %, its modal mass, damping ratio, stick stiffness and slip force
/// within 5 %, and the error in H1 falls at least 3x.
#[test]
fn a_hysteretic_mode_from_the_independent_simulator_is_found() {
    let o = CaseOptions {
        levels: Some(5),
        frequencies: Some(24),
        format: Some(SampleFormat::Pcm24),
        quantity: Some(Quantity::Displacement),
        sweep: Some(Sweep::Up),
        with_steps: Some(true),
        broad: false,
    };
    let mut case = case_with(231, JointKind::Jenkins, &[], &o);
    case.name = "hysteretic-mode-231".into();
    let f_slip = case.f_slip();
    let (f_bare, zeta, mass) = (1.3 * f_slip, 0.015, 2.0 * case.mass);
    let k_bare = mass * (2.0 * PI * f_bare).powi(2);
    let (kd, fd) = (k_bare, (case.levels[1] * case.levels[3]).sqrt());
    let f_stuck = f_bare * 2f64.sqrt();
    // the band: both of the case's own resonances and both of the mode's
    let n = 24;
    let (lo, hi) = (0.7 * f_slip, (1.15 * f_stuck).max(1.15 * case.f_stuck()));
    case.frequencies = (0..n)
        .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
        .collect();
    while (case.sample_rate as f64) < 40.0 * hi {
        case.sample_rate *= 2;
    }
    eprintln!(
        "{} + mode {f_bare:.2} Hz (stuck {f_stuck:.2}), {mass:.3} kg, kd {kd:.4e}, fd {fd:.4e}",
        case.summary()
    );
    let mode = RefSystem {
        modes: vec![RefMode::from_hz(f_bare, zeta, mass)],
        joint: RefJoint::Jenkins { kd, fd },
        effects: vec![],
        coil: None,
    };
    let rec = generate_with(&case, &[mode]);
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("independent-hysteretic-mode");
    let js = write_recording(&dir.join("recordings"), &case, &rec).unwrap();
    drop(rec);
    let run = run_diagnose_with(
        &hystid_bin(),
        &js,
        &dir.join("out"),
        "jenkins",
        &[],
        Duration::from_secs(900),
    );
    let d = run
        .diagnosis
        .unwrap_or_else(|| panic!("diagnose failed: {}", run.stderr_tail));
    let selected = selected_effects(&d);
    let (before, after) = (
        d["baseline"]["error_relative"].as_f64().unwrap(),
        d["final"]["error_relative"].as_f64().unwrap(),
    );
    eprintln!(
        "selected {selected:?}: H1 error {:.2} % -> {:.2} % ({:.1}x), chi2/dof {:.1} -> {:.2}, {:.0} s",
        100.0 * before,
        100.0 * after,
        before / after,
        d["baseline"]["chi2_per_dof"].as_f64().unwrap(),
        d["final"]["chi2_per_dof"].as_f64().unwrap(),
        run.seconds
    );
    assert_eq!(selected, ["hysteretic_mode"], "{}", d["explanation"]);
    let hm = d["selected"][0]["parameters"].clone();
    let got = |n: &str| hm[n]["value"].as_f64().unwrap_or(f64::NAN);
    // the validation pages' row
    let shown = crate::common::pinned_figures(&format!("| {} |", case.name))
        .unwrap_or_else(|| panic!("no pinned row for {}", case.name));
    let chi2 = |at: &str| d[at]["chi2_per_dof"].as_f64().unwrap();
    for (i, (what, value)) in [
        ("frequency", 100.0 * (got("frequency_hz") / f_bare - 1.0)),
        ("modal mass", 100.0 * (got("modal_mass") / mass - 1.0)),
        ("damping ratio", 100.0 * (got("damping_ratio") / zeta - 1.0)),
        ("kd", 100.0 * (got("joint.kd") / kd - 1.0)),
        ("fd", 100.0 * (got("joint.fd") / fd - 1.0)),
        ("H1 error before", 100.0 * before),
        ("H1 error after", 100.0 * after),
        ("chi2/dof before", chi2("baseline")),
        ("chi2/dof after", chi2("final")),
    ]
    .into_iter()
    .enumerate()
    {
        crate::common::assert_pinned_figure(&format!("{}: {what}", case.name), value, shown[i]);
    }
    for (name, truth, tolerance) in [
        ("frequency_hz", f_bare, 0.01),
        ("modal_mass", mass, 0.05),
        ("damping_ratio", zeta, 0.05),
        ("joint.kd", kd, 0.05),
        ("joint.fd", fd, 0.05),
    ] {
        let e = got(name) / truth - 1.0;
        eprintln!(
            "  {name} = {:.6e} (true {truth:.6e}, {:+.2} %)",
            got(name),
            100.0 * e
        );
        assert!(e.abs() < tolerance, "{name}: {} vs {truth}", got(name));
    }
    assert!(before >= 3.0 * after, "H1 error {before} -> {after}");
}
