//! Checks of the reference simulator itself: closed-form receptance,
//! Jenkins dissipation, Masing rules, step halving, the files it writes.

use super::kit::corpus::{
    CaseOptions, EffectKind, JointKind, Quantity, SampleFormat, Sweep, case_with, generate,
};
use super::kit::recording::{quantise, write_recording};
use super::kit::refsim::{Hysteresis, RefJoint, RefMode, RefSystem, SteppedSine, masing_backbone};
use num_complex::Complex64;
use std::f64::consts::PI;

/// Least-squares fit of `a sin(ωτ) + b cos(ωτ) + c` over samples
/// `from..to` (τ = t − t0); returns the complex amplitude `a + i b`
/// (the phasor of `Im(H e^{iωτ})`).
fn sine_fit(y: &[f64], fs: f64, f: f64, t0: f64, from: usize, to: usize) -> Complex64 {
    let w = 2.0 * PI * f;
    let mut ata = [[0.0f64; 3]; 3];
    let mut aty = [0.0f64; 3];
    for i in from..to {
        let tau = i as f64 / fs - t0;
        let row = [(w * tau).sin(), (w * tau).cos(), 1.0];
        for r in 0..3 {
            aty[r] += row[r] * y[i];
            for c in 0..3 {
                ata[r][c] += row[r] * row[c];
            }
        }
    }
    // 3×3 solve by Cramer's rule
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&ata);
    let solve = |k: usize| {
        let mut m = ata;
        for r in 0..3 {
            m[r][k] = aty[r];
        }
        det(&m) / d
    };
    Complex64::new(solve(0), solve(1))
}

fn receptance(modes: &[RefMode], f: f64) -> Complex64 {
    let w = 2.0 * PI * f;
    modes
        .iter()
        .map(|m| m.residue / Complex64::new(m.omega * m.omega - w * w, 2.0 * m.zeta * m.omega * w))
        .sum()
}

/// Steady state of a long single dwell against Σ R/(ω_r² − ω² + 2jζω_rω),
/// for displacement, velocity and acceleration.
fn check_linear(modes: Vec<RefMode>, fs: f64, freqs: &[f64]) {
    let slowest = modes
        .iter()
        .map(|m| 1.0 / (m.zeta * m.omega))
        .fold(0.0, f64::max);
    let sys = RefSystem {
        modes: modes.clone(),
        joint: RefJoint::None,
        effects: vec![],
        coil: None,
    };
    for &f in freqs {
        // 12 time constants of transient (e^-12 ≈ 6e-6), then 40 periods
        let settle = (12.0 * slowest * f).ceil() as u64;
        let t0 = 0.37 / fs;
        let sine = SteppedSine::new(t0, &[(f, 3.0, settle + 40, 0.0)]);
        let n = (sine.t_end() * fs) as usize;
        let out = sys.simulate(&sine, fs, n, 16);
        let from = n - (40.0 * fs / f) as usize;
        let h = receptance(&modes, f);
        let w = 2.0 * PI * f;
        for (name, y, expect) in [
            ("displacement", &out.displacement, h),
            ("velocity", &out.velocity, h * Complex64::new(0.0, w)),
            ("acceleration", &out.acceleration, h * (-w * w)),
        ] {
            let got = sine_fit(y, fs, f, t0, from, n) / 3.0;
            let rel = (got - expect).norm() / expect.norm();
            assert!(
                rel < 1e-4,
                "{name} at {f} Hz: simulated {got}, closed form {expect}, relative {rel:.3e}"
            );
        }
        // the force itself is exact
        let gf = sine_fit(&out.force, fs, f, t0, from, n);
        assert!(
            (gf - Complex64::new(3.0, 0.0)).norm() < 1e-9,
            "force phasor {gf}"
        );
    }
}

#[test]
fn reference_linear_sdof_matches_receptance() {
    let m = 2.0;
    let k = m * (2.0 * PI * 50.0f64).powi(2);
    let c = 2.0 * 0.02 * (k * m).sqrt();
    check_linear(
        vec![RefMode::from_mck(m, c, k)],
        4096.0,
        &[31.3, 48.9, 50.0, 50.7, 66.1],
    );
}

#[test]
fn reference_two_mode_matches_receptance() {
    let modes = vec![
        RefMode::from_hz(50.0, 0.02, 2.0),
        RefMode::from_hz(180.0, 0.015, 0.7),
    ];
    check_linear(modes, 10240.0, &[37.7, 50.2, 120.3, 179.1, 230.9]);
}

/// Energy dissipated in the second cycle of an imposed `x = a sin(ωt)`.
fn dissipation(joint: RefJoint, a: f64) -> f64 {
    let mut h = Hysteresis::new(joint);
    let n = 20000;
    let mut e = 0.0;
    let (mut x0, mut f0) = (0.0, 0.0);
    for i in 1..=2 * n {
        let x = a * (2.0 * PI * i as f64 / n as f64).sin();
        let f = h.update(x);
        if i > n {
            e += 0.5 * (f + f0) * (x - x0);
        }
        (x0, f0) = (x, f);
    }
    e
}

#[test]
fn reference_jenkins_dissipation_is_4fd_a_minus_slip() {
    let (kd, fd) = (3.0e6, 45.0);
    let xs = fd / kd;
    for r in [1.2, 1.5, 3.0, 10.0, 50.0] {
        let a = r * xs;
        let e = dissipation(RefJoint::Jenkins { kd, fd }, a);
        let exact = 4.0 * fd * (a - xs);
        assert!(
            (e / exact - 1.0).abs() < 0.005,
            "a = {r} Fd/kd: {e} J against {exact} J"
        );
    }
    // in stick nothing is dissipated
    assert!(dissipation(RefJoint::Jenkins { kd, fd }, 0.9 * xs).abs() < 1e-12 * fd * xs);
}

#[test]
fn reference_masing_approaches_jenkins_for_large_n() {
    let (kd, fd) = (3.0e6, 45.0);
    let a = 3.0 * fd / kd;
    let ej = dissipation(RefJoint::Jenkins { kd, fd }, a);
    let mut last = f64::INFINITY;
    for n in [2.0, 5.0, 10.0, 20.0, 80.0] {
        let em = dissipation(RefJoint::Masing { kd, fd, n }, a);
        let rel = (em / ej - 1.0).abs();
        assert!(
            rel < last,
            "N = {n}: |E_masing/E_jenkins − 1| = {rel} did not shrink (was {last})"
        );
        last = rel;
        if n >= 20.0 {
            assert!(rel < 0.05, "N = {n}: Masing dissipates {em}, Jenkins {ej}");
        }
    }
    // the backbone itself tends to the clipped line
    for u in [0.2, 0.9, 1.1, 4.0] {
        let x = u * fd / kd;
        let b = masing_backbone(kd, fd, 200.0, x);
        assert!(
            (b - (kd * x).clamp(-fd, fd)).abs() < 0.01 * fd,
            "u = {u}: {b}"
        );
    }
}

/// The Iwan slider bank against Segalman's closed forms (J. Appl. Mech.
/// 72, 2005): the virgin backbone `K_T u − R u^(χ+2)/((χ+1)(χ+2))` up to
/// `φ_max` and `F_S` beyond, and the microslip dissipation per cycle
/// `4 R A^(χ+3)/((χ+2)(χ+3))`, whose log-log slope is `3 + χ`.
#[test]
fn reference_iwan_bank_follows_segalmans_closed_forms() {
    let (fs, kt) = (120.0, 4.0e6);
    for (chi, beta) in [(-0.5, 0.3), (-0.2, 1.5), (-0.8, 0.05)] {
        let joint = RefJoint::Iwan4 { fs, kt, chi, beta };
        // Segalman's φ_max and R from the four parameters
        let phi_max = fs * (1.0 + beta) / (kt * (beta + (chi + 1.0) / (chi + 2.0)));
        let r = kt * (chi + 1.0) / ((1.0 + beta) * phi_max.powf(chi + 1.0));
        let backbone = |u: f64| {
            if u < phi_max {
                kt * u - r * u.powf(chi + 2.0) / ((chi + 1.0) * (chi + 2.0))
            } else {
                fs
            }
        };
        let mut h = Hysteresis::new(joint);
        let mut worst: f64 = 0.0;
        for i in 1..=400 {
            let u = 1.5 * phi_max * i as f64 / 400.0;
            let f = h.update(u);
            worst = worst.max((f - backbone(u)).abs() / fs);
        }
        eprintln!("chi {chi}, beta {beta}: backbone within {worst:.1e} F_S");
        assert!(
            worst < 2e-5,
            "chi {chi}, beta {beta}: backbone off by {worst} of F_S"
        );
        let closed = |a: f64| 4.0 * r * a.powf(chi + 3.0) / ((chi + 2.0) * (chi + 3.0));
        let mut last = None;
        for frac in [0.02, 0.04, 0.08, 0.16, 0.32] {
            let a = frac * phi_max;
            let e = dissipation(joint, a);
            eprintln!(
                "  A/φmax {frac}: dissipation / closed form − 1 = {:.1e}",
                e / closed(a) - 1.0
            );
            assert!(
                (e / closed(a) - 1.0).abs() < 1e-3,
                "chi {chi}, A/φmax {frac}: {e} J against {} J",
                closed(a)
            );
            if let Some((a0, e0)) = last {
                let slope = f64::ln(e / e0) / f64::ln(a / a0);
                assert!(
                    (slope / (3.0 + chi) - 1.0).abs() < 0.01,
                    "chi {chi}, A/φmax {frac}: slope {slope} against {}",
                    3.0 + chi
                );
            }
            last = Some((a, e));
        }
    }
}

#[test]
fn reference_masing_rules_and_wipe_out() {
    let (kd, fd, n) = (2.0e5, 10.0, 2.5);
    let f = |x: f64| masing_backbone(kd, fd, n, x);
    let xs = fd / kd;
    let mut h = Hysteresis::new(RefJoint::Masing { kd, fd, n });
    let walk = |h: &mut Hysteresis, from: f64, to: f64| -> f64 {
        let mut r = 0.0;
        for i in 1..=1000 {
            r = h.update(from + (to - from) * i as f64 / 1000.0);
        }
        r
    };
    // virgin to a: backbone
    let a = 2.0 * xs;
    assert!((walk(&mut h, 0.0, a) - f(a)).abs() < 1e-12 * fd);
    // unload to b: the Masing branch from (a, f(a))
    let b = -0.5 * xs;
    let fb = walk(&mut h, a, b);
    assert!((fb - (f(a) + 2.0 * f((b - a) / 2.0))).abs() < 1e-9 * fd);
    // an inner loop b -> c -> b closes and the branch from a resumes
    let c = 0.7 * xs;
    walk(&mut h, b, c);
    let back = walk(&mut h, c, -xs);
    assert!(
        (back - (f(a) + 2.0 * f((-xs - a) / 2.0))).abs() < 1e-9 * fd,
        "{back}"
    );
    // continue past -a: back on the backbone (the branch meets it at -a)
    let beyond = walk(&mut h, -xs, -3.0 * xs);
    assert!(
        (beyond - f(-3.0 * xs)).abs() < 1e-9 * fd,
        "{beyond} vs {}",
        f(-3.0 * xs)
    );
    // the stage evaluation agrees with the update without moving the state
    let peek = h.force_at(-2.0 * xs);
    let moved = h.update(-2.0 * xs);
    assert!((peek - moved).abs() < 1e-12 * fd);
}

/// 16 against 32 sub-steps per sample, on a hysteretic case with a
/// smooth effect. RK4 is 4th order on the smooth parts; the splitting
/// makes the hysteretic part 1st order at the slip/stick switches, so the
/// difference halves with the step: 1e-3 of the response peak is 100×
/// below the recordings' 10 % response noise and 5× below the 0.5 %
/// force noise. The Bouc-Wen joint, integrated with the structure and its
/// step shortened where `z` relaxes fast, moves by 1.2e-7 of the peak.
#[test]
fn reference_step_halving() {
    for (joint, effects) in [
        (
            JointKind::Masing { n: 3.0 },
            vec![EffectKind::CubicStiffness],
        ),
        (JointKind::Jenkins, vec![EffectKind::BilinearStiffness]),
        // the equation in time, its step also shortened where z relaxes fast
        (
            JointKind::BoucWen {
                gamma: 0.3,
                delta: 0.7,
                nu: 1.5,
            },
            vec![],
        ),
    ] {
        let o = CaseOptions {
            levels: Some(3),
            frequencies: Some(6),
            ..Default::default()
        };
        let mut case = case_with(7, joint, &effects, &o);
        let a = generate(&case);
        case.substeps = 32;
        let b = generate(&case);
        let peak = a.clean_response.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let diff = a
            .clean_response
            .iter()
            .zip(&b.clean_response)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        eprintln!(
            "step halving {:?} {:?}: max |x16 − x32| / peak = {:.3e}",
            joint,
            effects,
            diff / peak
        );
        assert!(
            diff / peak < 1e-3,
            "max difference {:.3e} of the peak",
            diff / peak
        );
    }
}

#[test]
fn reference_recordings_read_back() {
    let dir = tempfile::tempdir().unwrap();
    for (i, (format, quantity)) in [
        (SampleFormat::Float32, Quantity::Displacement),
        (SampleFormat::Pcm16, Quantity::Velocity),
        (SampleFormat::Pcm24, Quantity::Acceleration),
    ]
    .into_iter()
    .enumerate()
    {
        let o = CaseOptions {
            levels: Some(2),
            frequencies: Some(5),
            format: Some(format),
            quantity: Some(quantity),
            sweep: Some(Sweep::Down),
            with_steps: Some(true),
            broad: false,
        };
        let case = case_with(30 + i as u64, JointKind::Jenkins, &[], &o);
        let rec = generate(&case);
        let js = write_recording(dir.path(), &case, &rec).unwrap();
        let doc: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&js).unwrap()).unwrap();
        assert_eq!(doc["format"], "hystid.recording.v1");
        assert_eq!(doc["sample_rate_hz"], case.sample_rate);
        assert_eq!(doc["channels"][0]["quantity"], "force");
        assert_eq!(doc["channels"][1]["quantity"], quantity.name());
        let scales = [
            doc["channels"][0]["scale"].as_f64().unwrap(),
            doc["channels"][1]["scale"].as_f64().unwrap(),
        ];
        let mut r = hound::WavReader::open(js.with_extension("wav")).unwrap();
        let spec = r.spec();
        assert_eq!((spec.channels, spec.sample_rate), (2, case.sample_rate));
        let values: Vec<f64> = match format {
            SampleFormat::Float32 => r.samples::<f32>().map(|s| s.unwrap() as f64).collect(),
            _ => {
                let full = (1i64 << (spec.bits_per_sample - 1)) as f64;
                r.samples::<i32>()
                    .map(|s| s.unwrap() as f64 / full)
                    .collect()
            }
        };
        assert_eq!(values.len(), 2 * rec.force.len());
        let bits = spec.bits_per_sample;
        for (c, sig) in [&rec.force, &rec.response].into_iter().enumerate() {
            let peak = sig.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let tol = match format {
                SampleFormat::Float32 => peak * 1e-7,
                _ => {
                    // half an LSB, and the peak at 90 % of full scale
                    assert!((peak / scales[c] - 0.9).abs() < 1e-9);
                    0.5 * scales[c] / (1i64 << (bits - 1)) as f64 * (1.0 + 1e-9)
                }
            };
            for (k, x) in sig.iter().enumerate() {
                let back = values[2 * k + c] * scales[c];
                assert!(
                    (back - x).abs() <= tol,
                    "{format:?} channel {c} sample {k}: {back} vs {x}"
                );
            }
            if format != SampleFormat::Float32 {
                assert_eq!(
                    quantise(peak, scales[c], bits as u32).unsigned_abs() as f64,
                    (0.9 * (1i64 << (bits - 1)) as f64).round()
                );
            }
        }
        // the steps: in time order, contiguous, each starting at the first
        // sample after a rising force zero crossing
        let steps = doc["excitation"]["steps"].as_array().unwrap();
        assert_eq!(steps.len(), case.levels.len() * case.frequencies.len());
        let fs = case.sample_rate as f64;
        for (j, s) in steps.iter().enumerate() {
            let start = s["start"].as_u64().unwrap() as usize;
            let f = s["frequency_hz"].as_f64().unwrap();
            let a = s["level"].as_f64().unwrap();
            let f0 = rec.clean_force[start];
            assert!(
                f0 >= 0.0 && f0 <= a * (2.0 * PI * f / fs).sin() * (1.0 + 1e-9),
                "step {j}: force {f0} at its start"
            );
            assert!(
                rec.clean_force[start - 1] <= 0.0,
                "step {j}: the switch is not between samples start-1 and start"
            );
            if j + 1 < steps.len() {
                assert_eq!(
                    start + s["length"].as_u64().unwrap() as usize,
                    steps[j + 1]["start"].as_u64().unwrap() as usize
                );
            }
            assert!(s["settle"].as_u64().unwrap() < s["length"].as_u64().unwrap());
        }
        assert!(doc["metadata"]["truth"]["joint"]["kd"].as_f64().unwrap() == case.kd);
    }
}
