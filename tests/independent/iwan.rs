//! Issue 12: hystid's `iwan4` joint against the reference kit's Iwan
//! joint, which is a different thing written from Segalman's definitions:
//! a parallel bank of 1001 Jenkins sliders, not a backbone under Masing's
//! rules.

use super::kit::corpus::{CaseOptions, JointKind, Quantity, SampleFormat, Sweep, case_with};
use super::kit::refsim::{Hysteresis, IWAN_SLIDERS, RefJoint};
use super::kit::runner::{describe, run_cases};
use hystid::model::{Element, ElementSpec};
use std::path::PathBuf;
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

/// `diagnose --element iwan4` on recordings of an Iwan joint made by the
/// reference simulator (a slider bank, RK4; 10 % response noise, the
/// corpus's random structure, levels from microslip to full slip): the
/// right law declared recovers `F_S` and `K_T` within 3 %, `χ` within
/// 0.05 and `β` within 20 % (issue 12), and adds no effect.
#[test]
fn iwan_joint_from_the_independent_simulator_is_identified() {
    let o = CaseOptions {
        levels: Some(6),
        frequencies: Some(16),
        format: Some(SampleFormat::Pcm24),
        quantity: Some(Quantity::Displacement),
        sweep: Some(Sweep::Up),
        with_steps: Some(true),
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
    }
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("independent-iwan");
    let scores = run_cases(&cases, &dir, 2, Duration::from_secs(900));
    let mut failed = Vec::new();
    for s in &scores {
        eprintln!("{}\n", describe(s));
        if !s.failures.is_empty() {
            failed.push(format!("{}: {}", s.name, s.failures.join("; ")));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}
