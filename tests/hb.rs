//! Integration tests: hb (harmonic balance).
//!
//! Known answers: the linear FRF (modal, tabulated), the single-harmonic
//! describing-function FRFs (Jenkins closed form, Masing quadrature), the
//! time simulator's steady state, the closed-form single-harmonic Duffing
//! folds; plus self-consistency (two periodic-loop methods, harmonic
//! convergence, finite-difference vs analytic Jacobian, determinism).

use hystid::hb::{
    self, HbOptions, HbSolver, JacobianMethod, LinearPart, PeriodicLoop, TabulatedFrf, describing,
};
use hystid::model::{
    CubicStiffness, Element, ElementForce, ElementSet, ElementSpec, Jenkins, Masing, ModalModel,
    Mode, Model, NoElement, ViscousDamping,
};
use hystid::sim::Simulator;
use num_complex::Complex64;
use std::f64::consts::PI;

const M: f64 = 10.0;
const C: f64 = 200.0;
const K: f64 = 1e7;
const KD: f64 = 2.4e7;
const FD: f64 = 246.048;

fn paper_linear() -> ModalModel {
    ModalModel::sdof(M, C, K).unwrap()
}

fn grid(from: f64, to: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| from + (to - from) * i as f64 / (n - 1) as f64)
        .collect()
}

fn rel(a: Complex64, b: Complex64) -> f64 {
    (a - b).norm() / b.norm()
}

#[test]
fn linear_elements_give_the_analytic_frf() {
    let freqs = grid(100.0, 350.0, 26);
    // a two-mode structure and the paper SDOF; no element / viscous only
    let two = ModalModel::new(vec![
        Mode::from_modal_mass(159.0, 0.01, 10.0).unwrap(),
        Mode::from_modal_mass(420.0, 0.02, 4.0).unwrap(),
    ])
    .unwrap();
    for linear in [paper_linear(), two] {
        for opts in [
            HbOptions::default(),
            HbOptions::with_harmonics(hb::all_harmonics(4)),
        ] {
            let s = hb::sweep(&linear, &mut NoElement, &freqs, 50.0, &opts).unwrap();
            for p in &s.points {
                assert!(p.converged, "{p:?}");
                let exact = linear.receptance(2.0 * PI * p.frequency_hz);
                let e = rel(p.frf(1).unwrap(), exact);
                assert!(e < 1e-10, "{} Hz: {e:e}", p.frequency_hz);
                for (&h, x) in p.harmonics.iter().zip(&p.x) {
                    if h != 1 {
                        assert!(x.norm() < 1e-12 * p.amplitude(), "X{h} = {x}");
                    }
                }
            }
            // viscous damping at the joint: H = 1/(1/H0 + jω cj)
            let cj = 150.0;
            let mut e = ElementSet::new(vec![ViscousDamping { cj }]);
            let s = hb::sweep(&linear, &mut e, &freqs, 50.0, &opts).unwrap();
            for p in &s.points {
                let w = 2.0 * PI * p.frequency_hz;
                let exact = 1.0 / (1.0 / linear.receptance(w) + Complex64::new(0.0, w * cj));
                let e = rel(p.frf(1).unwrap(), exact);
                assert!(p.converged && e < 1e-10, "{} Hz: {e:e}", p.frequency_hz);
            }
        }
    }
}

#[test]
fn tabulated_receptance_gives_the_modal_answer_and_errors_outside_its_range() {
    let linear = paper_linear();
    let table = TabulatedFrf::sample(&linear, &grid(0.0, 2000.0, 201)).unwrap();
    let mut a = Jenkins::new(KD, FD).unwrap();
    let mut b = a.clone();
    let freqs = grid(150.0, 350.0, 11);
    let opts = HbOptions::default();
    let sa = hb::sweep(&linear, &mut a, &freqs, 300.0, &opts).unwrap();
    let sb = hb::sweep(&table, &mut b, &freqs, 300.0, &opts).unwrap();
    for (p, q) in sa.points.iter().zip(&sb.points) {
        assert!(p.converged && q.converged);
        for (x, y) in p.h.iter().zip(&q.h) {
            assert!((x - y).norm() <= 1e-9 * p.h[0].norm(), "{x} vs {y}");
        }
    }
    // harmonic 5 of 450 Hz is 2250 Hz, beyond the table
    let e = hb::sweep(&table, &mut b, &[300.0, 450.0], 300.0, &opts)
        .unwrap_err()
        .to_string();
    assert!(e.contains("2250") && e.contains("harmonic 5"), "{e}");
}

/// Single-harmonic HB against the describing-function FRF, through the
/// transition from stick to slip.
#[test]
fn single_harmonic_balance_equals_the_describing_function_frf() {
    let linear = paper_linear();
    let freqs = grid(120.0, 340.0, 12);
    // Jenkins: AFT's kink error falls as ~N^-2: 8192 samples put it below 1e-7
    let mut opts = HbOptions::with_harmonics(vec![1]);
    opts.samples_per_period = 8192;
    let mut j = Jenkins::new(KD, FD).unwrap();
    let mut worst: f64 = 0.0;
    for level in [50.0, 300.0, 1000.0, 5000.0] {
        let s = hb::sweep(&linear, &mut j, &freqs, level, &opts).unwrap();
        for p in &s.points {
            let w = 2.0 * PI * p.frequency_hz;
            let roots = describing::solve(linear.receptance(w), level, |a| {
                describing::jenkins(KD, FD, a)
            });
            assert_eq!(roots.len(), 1);
            worst = worst.max(rel(p.x[0], roots[0]));
        }
    }
    eprintln!("Jenkins: single-harmonic HB vs describing function, worst {worst:.2e}");
    assert!(worst < 1e-6, "{worst:e}");
    // Masing eq. (10): the loop's curvature jumps at the reversals, so the
    // sampled-force quadrature errs as ~N^-3 (6e-5 at 256 samples); 2048
    // put it near 1e-7
    let mut opts = HbOptions::with_harmonics(vec![1]);
    opts.samples_per_period = 2048;
    let mut worst: f64 = 0.0;
    for n in [2.0, 22.55] {
        let mut m = Masing::new(KD, FD, n).unwrap();
        for level in [50.0, 300.0, 1000.0, 5000.0] {
            let s = hb::sweep(&linear, &mut m, &freqs, level, &opts).unwrap();
            for p in &s.points {
                let w = 2.0 * PI * p.frequency_hz;
                let roots = describing::solve(linear.receptance(w), level, |a| {
                    describing::masing(KD, FD, n, a)
                });
                assert_eq!(roots.len(), 1);
                worst = worst.max(rel(p.x[0], roots[0]));
            }
        }
    }
    eprintln!("Masing: single-harmonic HB vs describing function, worst {worst:.2e}");
    assert!(worst < 1e-6, "{worst:e}");
}

#[test]
fn both_periodic_loop_methods_agree_for_jenkins_and_masing() {
    let linear = paper_linear();
    let freqs = grid(150.0, 330.0, 10);
    for spec in [
        ElementSpec::Jenkins { kd: KD, fd: FD },
        ElementSpec::Masing {
            kd: KD,
            fd: FD,
            n: 3.0,
        },
    ] {
        let mut e = spec.build().unwrap();
        let mut worst: f64 = 0.0;
        for level in [100.0, 500.0, 3000.0] {
            let mut a = HbOptions::with_harmonics(hb::odd_harmonics(7));
            a.periodic_loop = PeriodicLoop::MaxAmplitude;
            let mut b = a.clone();
            b.periodic_loop = PeriodicLoop::TwoPeriods;
            let sa = hb::sweep(&linear, &mut e, &freqs, level, &a).unwrap();
            let sb = hb::sweep(&linear, &mut e, &freqs, level, &b).unwrap();
            for (p, q) in sa.points.iter().zip(&sb.points) {
                assert!(p.converged && q.converged);
                for (x, y) in p.x.iter().zip(&q.x) {
                    worst = worst.max((x - y).norm() / p.amplitude());
                }
            }
        }
        // both are the same periodic loop; only Newton's tolerance differs
        assert!(worst < 1e-9, "{spec:?}: {worst:e}");
    }
}

#[test]
fn half_wave_symmetry_changes_nothing_but_the_cost() {
    let linear = paper_linear();
    let freqs = grid(120.0, 340.0, 12);
    for spec in [
        ElementSpec::Jenkins { kd: KD, fd: FD },
        ElementSpec::Masing {
            kd: KD,
            fd: FD,
            n: 22.55,
        },
        ElementSpec::CubicStiffness { k3: 1e13 },
    ] {
        let mut e = spec.build().unwrap();
        let a = HbOptions::default();
        let b = HbOptions {
            half_wave_symmetry: false,
            ..HbOptions::default()
        };
        for level in [50.0, 500.0, 3000.0] {
            let sa = hb::sweep(&linear, &mut e, &freqs, level, &a).unwrap();
            let sb = hb::sweep(&linear, &mut e, &freqs, level, &b).unwrap();
            for (p, q) in sa.points.iter().zip(&sb.points) {
                assert!(p.converged && q.converged);
                for (x, y) in p.x.iter().zip(&q.x) {
                    assert!(
                        (x - y).norm() < 1e-9 * p.amplitude(),
                        "{spec:?}: {x} vs {y}"
                    );
                }
            }
        }
    }
}

#[test]
fn finite_difference_jacobian_gives_the_same_solutions() {
    let linear = paper_linear();
    let freqs = grid(200.0, 300.0, 6);
    let mut e = Masing::new(KD, FD, 5.0).unwrap();
    let a = HbOptions::default();
    let mut b = a.clone();
    b.jacobian = JacobianMethod::FiniteDifference;
    let sa = hb::sweep(&linear, &mut e, &freqs, 400.0, &a).unwrap();
    let sb = hb::sweep(&linear, &mut e, &freqs, 400.0, &b).unwrap();
    for (p, q) in sa.points.iter().zip(&sb.points) {
        assert!(p.converged && q.converged);
        assert!(rel(p.x[0], q.x[0]) < 1e-9);
    }
    // the analytic route needs far fewer AFT evaluations
    assert!(
        sa.evaluations * 2 < sb.evaluations,
        "{} vs {}",
        sa.evaluations,
        sb.evaluations
    );
}

/// The simulator's receptance as harmonic balance should see it: the
/// ramp-invariant filter is `H(f)·sinc²(f/fs)` (up to sinc²-weighted aliases),
/// and the element force passes the same filter, so HB with this receptance is
/// the simulator's steady state without its sampling bias.
struct SampledReceptance<'a> {
    linear: &'a ModalModel,
    sample_rate: f64,
}

impl LinearPart for SampledReceptance<'_> {
    fn receptance(&self, omega: f64) -> hystid::Result<Complex64> {
        let s = hystid::harmonics::sinc(omega / (2.0 * PI * self.sample_rate));
        Ok(self.linear.receptance(omega) * (s * s))
    }
}

/// Steady-state FRFs `X_h/F_1` of the time simulator for harmonics `hs`:
/// integer samples per period (≥ 100 per stick period), a 0.2 s raised-cosine
/// ramp, settled for 1.5 s (`c/2m = 10 s⁻¹`: transients below 1e-6), then 20
/// whole periods; also the H1 drift between the last two 10-period blocks.
fn simulated_frf<E: Element>(
    linear: &ModalModel,
    elements: E,
    f: f64,
    force: f64,
    hs: &[usize],
) -> (Vec<Complex64>, f64, f64) {
    let p = (100.0 * 293.4 / f).ceil() as usize;
    let fs = p as f64 * f;
    let mut sim = Simulator::new(linear, elements, fs).unwrap();
    let ramp = (0.2 * fs) as usize;
    let settle = (1.5 * f).ceil() as usize * p;
    let measure = 20 * p;
    let drive = |i: usize| {
        let env = if i < ramp {
            0.5 - 0.5 * (PI * i as f64 / ramp as f64).cos()
        } else {
            1.0
        };
        env * force * (2.0 * PI * (i % p) as f64 / p as f64).cos()
    };
    let mut out = hystid::sim::Response::default();
    sim.run_generator(settle + measure, drive, &mut out)
        .unwrap();
    let x = &out.displacement[settle..];
    let harmonic = |y: &[f64], h: usize| -> Complex64 {
        let mut acc = Complex64::new(0.0, 0.0);
        for (n, v) in y.iter().enumerate() {
            acc += v * Complex64::from_polar(1.0, -2.0 * PI * (h * (n % p)) as f64 / p as f64);
        }
        acc * (2.0 / y.len() as f64)
    };
    let f1: Vec<f64> = (0..measure).map(|n| drive(settle + n)).collect();
    let f1 = harmonic(&f1, 1);
    let frf: Vec<Complex64> = hs.iter().map(|&h| harmonic(x, h) / f1).collect();
    let half = measure / 2;
    let drift = rel(harmonic(&x[..half], 1), harmonic(&x[half..], 1));
    (frf, fs, drift)
}

/// Multi-harmonic balance against the digital-filter simulator's steady
/// state for the paper-like system, over stick, transition and slip.
#[test]
fn multi_harmonic_balance_matches_the_time_simulator() {
    let linear = paper_linear();
    let hs = hb::odd_harmonics(15);
    let mut opts = HbOptions::with_harmonics(hs.clone());
    opts.samples_per_period = 512;
    let (mut worst1, mut worst3) = (0.0f64, 0.0f64);
    let mut compared3 = 0;
    for force in [5.0, 200.0, 500.0, 3000.0] {
        for f in [200.0, 250.0, 290.0] {
            let jenkins = Jenkins::new(KD, FD).unwrap();
            let (sim, fs, drift) = simulated_frf(&linear, jenkins.clone(), f, force, &hs);
            assert!(drift < 1e-6, "F={force} f={f}: not settled ({drift:e})");
            let sampled = SampledReceptance {
                linear: &linear,
                sample_rate: fs,
            };
            let p = hb::solve_point(&sampled, &mut jenkins.clone(), f, force, None, &opts).unwrap();
            assert!(p.converged, "{p:?}");
            let e1 = rel(sim[0], p.h[0]);
            worst1 = worst1.max(e1);
            assert!(
                e1 < 2e-3,
                "F={force} f={f}: H1 sim {} hb {} ({e1:e})",
                sim[0],
                p.h[0]
            );
            if p.h[1].norm() > 1e-3 * p.h[0].norm() {
                let e3 = rel(sim[1], p.h[1]);
                worst3 = worst3.max(e3);
                compared3 += 1;
                assert!(
                    e3 < 5e-2,
                    "F={force} f={f}: H3 sim {} hb {} ({e3:e})",
                    sim[1],
                    p.h[1]
                );
            }
        }
    }
    eprintln!(
        "HB {{1..15}} vs simulator (≥100 samples per stick period): H1 worst {worst1:.2e}, \
         H3 worst {worst3:.2e} over {compared3} points with |H3/H1| > 1e-3"
    );
    assert!(
        compared3 >= 4,
        "too few points with a third harmonic to compare"
    );
}

/// More harmonics converge: the change in H1 shrinks as the set grows.
#[test]
fn harmonic_count_converges() {
    let linear = paper_linear();
    let freqs = grid(150.0, 330.0, 7);
    let run = |hs: Vec<usize>| {
        let mut o = HbOptions::with_harmonics(hs);
        o.samples_per_period = 1024;
        let mut e = Jenkins::new(KD, FD).unwrap();
        [200.0, 500.0, 1000.0]
            .iter()
            .map(|&lvl| hb::sweep(&linear, &mut e, &freqs, lvl, &o).unwrap())
            .collect::<Vec<_>>()
    };
    let h1 = run(vec![1]);
    let h5 = run(hb::odd_harmonics(5));
    let h15 = run(hb::odd_harmonics(15));
    let h31 = run(hb::odd_harmonics(31));
    let change = |a: &[hb::HbSweep], b: &[hb::HbSweep]| {
        let mut w = 0.0f64;
        for (sa, sb) in a.iter().zip(b) {
            for (p, q) in sa.points.iter().zip(&sb.points) {
                assert!(p.converged && q.converged);
                w = w.max(rel(p.frf(1).unwrap(), q.frf(1).unwrap()));
            }
        }
        w
    };
    let (c1, c5, c15) = (change(&h1, &h15), change(&h5, &h15), change(&h15, &h31));
    eprintln!(
        "H1 change to {{1,3,..,15}}: from {{1}} {c1:.2e}, from {{1,3,5}} {c5:.2e}; \
         {{1..15}} to {{1..31}}: {c15:.2e}"
    );
    assert!(c5 < c1 / 3.0 && c15 < c5, "{c1:e} {c5:e} {c15:e}");
    assert!(c5 < 2e-3, "{c5:e}");
}

/// Eq. (10)'s samples per period (`Description::smooth_samples`): with
/// the turning points located between samples, what is left is the
/// quadrature of a force whose knee narrows in phase as N grows. On the
/// paper's system from stuck to slipping (5 N to 3 kN, 100-350 Hz,
/// harmonics {1, 3, 5}), against 4096 samples: at N <= 3.5 the 128 samples
/// a fit then takes keep every H1 within 1e-4 of |H1| (measured 2.8e-5 at N
/// = 2, 8.2e-5 at 3.5), about as close as the default 256 keep the sharper
/// knees (8.0e-5 at the paper's 22.55), while at N = 4 128 would not
/// (1.1e-4), which is why the law asks the default there.
#[test]
fn a_smooth_masing_knee_is_balanced_at_128_samples_as_a_sharp_one_at_256() {
    let freqs = grid(100.0, 350.0, 26);
    let levels = [5.0, 200.0, 1000.0, 3000.0];
    let worst = |n: f64, samples: usize| {
        let model = Model::new(
            paper_linear(),
            vec![ElementSpec::Masing { kd: KD, fd: FD, n }],
        )
        .unwrap();
        let solve = |ns: usize| {
            let o = HbOptions {
                samples_per_period: ns,
                ..HbOptions::default()
            };
            hb::frf_set_for_model(&model, &levels, &freqs, &o).unwrap()
        };
        let (coarse, fine) = (solve(samples), solve(4096));
        let mut w = 0.0f64;
        for (a, b) in coarse.iter().zip(&fine) {
            for (p, q) in a.points.iter().zip(&b.points) {
                assert!(p.converged && q.converged);
                w = w.max((p.h[0] - q.h[0]).norm() / q.h[0].norm());
            }
        }
        w
    };
    let sharp = worst(22.55, 256);
    for n in [1.4, 2.0, 3.0, 3.5] {
        let w = worst(n, 128);
        eprintln!("N = {n}: 128 samples, worst H1 error {w:.2e} (N = 22.55 at 256: {sharp:.2e})");
        assert!(
            w < 1e-4 && w < 1.5 * sharp,
            "N = {n}: {w:e} against {sharp:e}"
        );
    }
    let w4 = worst(4.0, 128);
    eprintln!("N = 4: 128 samples, worst H1 error {w4:.2e}");
    assert!(w4 > 1e-4, "{w4:e}");
}

/// Closed-form single-harmonic Duffing folds: where the cubic
/// `A[(k − mω² + ¾k3 A)² + (cω)²] = F²` in `A = a²` changes from one to
/// three real roots (its discriminant's sign), by bisection.
fn duffing_folds(m: f64, c: f64, k: f64, k3: f64, force: f64, from: f64, to: f64) -> Vec<f64> {
    let e = 0.75 * k3;
    let a0_scale = (force / k).powi(2) * 1e4;
    let disc = |f: f64| {
        let w = 2.0 * PI * f;
        let d = k - m * w * w;
        let (a3, a2, a1, a0) = (
            e * e * a0_scale.powi(3),
            2.0 * d * e * a0_scale.powi(2),
            (d * d + (c * w).powi(2)) * a0_scale,
            -force * force,
        );
        18.0 * a3 * a2 * a1 * a0 - 4.0 * a2.powi(3) * a0 + a2 * a2 * a1 * a1
            - 4.0 * a3 * a1.powi(3)
            - 27.0 * a3 * a3 * a0 * a0
    };
    let mut folds = Vec::new();
    let steps = 4000;
    for i in 0..steps {
        let (mut lo, mut hi) = (
            from + (to - from) * i as f64 / steps as f64,
            from + (to - from) * (i + 1) as f64 / steps as f64,
        );
        if (disc(lo) > 0.0) != (disc(hi) > 0.0) {
            let s = disc(lo) > 0.0;
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                if (disc(mid) > 0.0) == s {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            folds.push(0.5 * (lo + hi));
        }
    }
    folds
}

#[test]
fn hardening_cubic_sweeps_up_and_down_follow_different_branches_and_report_folds() {
    let linear = paper_linear();
    let (k3, force) = (4e12, 200.0);
    let exact = duffing_folds(M, C, K, k3, force, 140.0, 200.0);
    assert_eq!(exact.len(), 2, "{exact:?}");
    let (lower, upper) = (exact[0], exact[1]);
    let up = grid(150.0, 190.0, 81);
    let down: Vec<f64> = up.iter().rev().copied().collect();
    for harmonics in [vec![1], hb::odd_harmonics(5)] {
        let opts = HbOptions::with_harmonics(harmonics.clone());
        let mut e = CubicStiffness { k3 };
        let su = hb::sweep(&linear, &mut e, &up, force, &opts).unwrap();
        let sd = hb::sweep(&linear, &mut e, &down, force, &opts).unwrap();
        assert!(su.points.iter().chain(&sd.points).all(|p| p.converged));
        assert_eq!(su.folds.len(), 1, "{:?}", su.folds);
        assert_eq!(sd.folds.len(), 1, "{:?}", sd.folds);
        let (fu, fd) = (&su.folds[0], &sd.folds[0]);
        eprintln!(
            "harmonics {harmonics:?}: up-sweep fold {:.4} Hz (|X1| {:.3e} -> {:.3e} m), \
             down-sweep fold {:.4} Hz ({:.3e} -> {:.3e} m); single-harmonic closed form \
             {upper:.4} / {lower:.4} Hz",
            fu.frequency_hz,
            fu.amplitude_before,
            fu.amplitude_after,
            fd.frequency_hz,
            fd.amplitude_before,
            fd.amplitude_after
        );
        assert!(fu.located && fd.located);
        // the jump lies between the two sweep points around the fold
        assert!(up[fu.index - 1] <= fu.frequency_hz && fu.frequency_hz <= up[fu.index]);
        assert!(down[fd.index] <= fd.frequency_hz && fd.frequency_hz <= down[fd.index - 1]);
        // up jumps down, down jumps up
        assert!(fu.amplitude_after < 0.5 * fu.amplitude_before);
        assert!(fd.amplitude_after > 2.0 * fd.amplitude_before);
        if harmonics == [1] {
            // arc-length locates the closed-form folds
            assert!(
                (fu.frequency_hz - upper).abs() < 1e-3,
                "{} vs {upper}",
                fu.frequency_hz
            );
            assert!(
                (fd.frequency_hz - lower).abs() < 1e-3,
                "{} vs {lower}",
                fd.frequency_hz
            );
        } else {
            // harmonics 3 and 5 move the folds only slightly
            assert!((fu.frequency_hz - upper).abs() < 0.01 * upper);
            assert!((fd.frequency_hz - lower).abs() < 0.01 * lower);
        }
        // between the folds the two sweeps are on different branches; outside
        // they agree
        for (i, f) in up.iter().enumerate() {
            let p = &su.points[i];
            let q = &sd.points[up.len() - 1 - i];
            let d = rel(p.frf(1).unwrap(), q.frf(1).unwrap());
            if *f > fd.frequency_hz + 0.1 && *f < fu.frequency_hz - 0.1 {
                assert!(p.amplitude() > 2.0 * q.amplitude(), "{f} Hz: {d}");
            } else if *f < fd.frequency_hz - 0.1 || *f > fu.frequency_hz + 0.1 {
                assert!(d < 1e-8, "{f} Hz: {d:e}");
            }
        }
    }
}

/// A sweep that starts inside the bistable band starts on the branch it
/// would have arrived on: the upper one going up, the lower one going down.
#[test]
fn a_sweep_starting_between_the_folds_picks_the_branch_of_its_direction() {
    let linear = paper_linear();
    let (k3, force) = (4e12, 200.0);
    let opts = HbOptions::default();
    let mut e = CubicStiffness { k3 };
    let from_below = hb::sweep(&linear, &mut e, &grid(150.0, 172.0, 45), force, &opts).unwrap();
    let from_above = hb::sweep(&linear, &mut e, &grid(190.0, 172.0, 37), force, &opts).unwrap();
    let upper = from_below.points.last().unwrap();
    let lower = from_above.points.last().unwrap();
    assert!(upper.amplitude() > 2.0 * lower.amplitude());
    let up = hb::sweep(&linear, &mut e, &[172.0, 173.0], force, &opts).unwrap();
    let down = hb::sweep(&linear, &mut e, &[172.0, 171.0], force, &opts).unwrap();
    assert!(rel(up.points[0].x[0], upper.x[0]) < 1e-8);
    assert!(rel(down.points[0].x[0], lower.x[0]) < 1e-8);
}

/// `solve_point` walked along the frequencies, each point's guess the last
/// solution, starts from the balance linearised about that solution
/// (unless the step it predicts is large, as near a fold): the same
/// solutions as the plain walk from the last solution (each point on a fresh
/// solver, which holds no walk), on the same branches through a Duffing
/// fold, in fewer evaluations.
#[test]
fn a_point_by_point_walk_is_predicted_and_keeps_its_branch() {
    let linear = paper_linear();
    type Solve<'a> = dyn FnMut(&mut HbSolver, f64, Option<&[Complex64]>) -> hb::HbPoint + 'a;
    let walk = |e: &mut Solve, freqs: &[f64], fresh: bool, opts: &HbOptions| {
        let mut solver = HbSolver::new(opts).unwrap();
        let (mut last, mut points, mut evaluations) = (None::<Vec<Complex64>>, vec![], 0);
        for &f in freqs {
            if fresh {
                evaluations += solver.evaluations();
                solver = HbSolver::new(opts).unwrap();
            }
            let p = e(&mut solver, f, last.as_deref());
            assert!(p.converged, "{f} Hz: {:?}", p.failure);
            last = Some(p.x.clone());
            points.push(p);
        }
        (points, evaluations + solver.evaluations())
    };
    // the Jenkins curve of the speed bench, and a hardening Duffing
    // oscillator swept up and down through its folds
    let jenkins = HbOptions {
        harmonics: (0..=7).collect(),
        samples_per_period: 512,
        ..HbOptions::default()
    };
    let mut j = Jenkins::new(KD, FD).unwrap();
    let mut solve_j = |s: &mut HbSolver, f: f64, g: Option<&[Complex64]>| {
        s.solve_point(&linear, &mut j, f, 1000.0, g).unwrap()
    };
    let mut cases = vec![];
    let jf = grid(150.0, 350.0, 121);
    let (a, ea) = walk(&mut solve_j, &jf, false, &jenkins);
    let (b, eb) = walk(&mut solve_j, &jf, true, &jenkins);
    cases.push(("jenkins", a, b, ea, eb, 0.75));
    let up = grid(150.0, 190.0, 81);
    let down: Vec<f64> = up.iter().rev().copied().collect();
    let odd = HbOptions::with_harmonics(hb::odd_harmonics(5));
    let mut cubic = CubicStiffness { k3: 4e12 };
    let mut solve_c = |s: &mut HbSolver, f: f64, g: Option<&[Complex64]>| {
        s.solve_point(&linear, &mut cubic, f, 200.0, g).unwrap()
    };
    for (name, freqs) in [("duffing up", &up), ("duffing down", &down)] {
        let (a, ea) = walk(&mut solve_c, freqs, false, &odd);
        let (b, eb) = walk(&mut solve_c, freqs, true, &odd);
        cases.push((name, a, b, ea, eb, 0.9));
    }
    for (name, a, b, ea, eb, most) in cases {
        let worst = a
            .iter()
            .zip(&b)
            .map(|(p, q)| rel(p.frf(1).unwrap(), q.frf(1).unwrap()))
            .fold(0.0, f64::max);
        eprintln!(
            "{name}: predicted walk {ea} evaluations, plain walk {eb}; H1 within {worst:.1e}"
        );
        // both within the solver's tolerance (1e-8 on the harmonics)
        assert!(worst < 1e-6, "{name}: H1 differs by {worst:.1e}");
        assert!(
            (ea as f64) < most * eb as f64,
            "{name}: {ea} evaluations against {eb}"
        );
    }
}

/// The same walk with each guess the neighbour's solution found another
/// way (a sweep of the same curve, as the speed bench and a caller holding
/// an earlier curve pass it): equal to the solver's own last solution to
/// the tolerance, not to the bit, it is predicted as the solver's own walk
/// is (before, bit-equality was asked and every such point started from the
/// guess itself).
#[test]
fn a_walk_from_neighbours_solved_elsewhere_is_predicted_too() {
    let linear = paper_linear();
    let opts = HbOptions {
        harmonics: (0..=7).collect(),
        samples_per_period: 512,
        ..HbOptions::default()
    };
    let freqs = grid(150.0, 350.0, 121);
    let mut j = Jenkins::new(KD, FD).unwrap();
    let swept = hb::sweep(&linear, &mut j, &freqs, 1000.0, &opts).unwrap();
    let mut walk = |from_sweep: bool, fresh: bool| {
        let mut solver = HbSolver::new(&opts).unwrap();
        let (mut last, mut points, mut evaluations) = (None::<Vec<Complex64>>, vec![], 0);
        for (i, &f) in freqs.iter().enumerate() {
            if fresh {
                evaluations += solver.evaluations();
                solver = HbSolver::new(&opts).unwrap();
            }
            let guess = if from_sweep && i > 0 {
                Some(swept.points[i - 1].x.clone())
            } else {
                last.clone()
            };
            let p = solver
                .solve_point(&linear, &mut j, f, 1000.0, guess.as_deref())
                .unwrap();
            assert!(p.converged, "{f} Hz: {:?}", p.failure);
            last = Some(p.x.clone());
            points.push(p);
        }
        (points, evaluations + solver.evaluations())
    };
    let (own, e_own) = walk(false, false);
    let (elsewhere, e_elsewhere) = walk(true, false);
    let (_, e_plain) = walk(true, true);
    let worst = own
        .iter()
        .zip(&elsewhere)
        .map(|(p, q)| rel(p.frf(1).unwrap(), q.frf(1).unwrap()))
        .fold(0.0, f64::max);
    eprintln!(
        "own walk {e_own} evaluations, from the sweep's solutions {e_elsewhere}, each from its \
         guess alone {e_plain}; H1 within {worst:.1e}"
    );
    assert!(worst < 1e-6, "H1 differs by {worst:.1e}");
    // predicted as the own walk (a point's guess differs from the held
    // solution by the tolerance, so its path may differ by an evaluation)
    assert!(
        (e_elsewhere as f64) <= 1.05 * e_own as f64 && (e_elsewhere as f64) < 0.75 * e_plain as f64,
        "{e_elsewhere} evaluations against {e_own} (own walk) and {e_plain} (unpredicted)"
    );
}

#[test]
fn options_read_from_toml_with_defaults_and_reject_unknown_keys() {
    let o: HbOptions =
        toml::from_str("harmonics = [0, 1, 2, 3]\nperiodic_loop = \"two_periods\"\n").unwrap();
    assert_eq!(o.harmonics, vec![0, 1, 2, 3]);
    assert_eq!(o.periodic_loop, PeriodicLoop::TwoPeriods);
    assert_eq!(o.samples_per_period, 256);
    assert!(toml::from_str::<HbOptions>("harmonic = [1]\n").is_err());
}

/// An element that breaks down (NaN force) beyond a displacement.
#[derive(Clone, Debug)]
struct Breaks;

impl Element for Breaks {
    fn trial(&self, x: f64, _v: f64) -> ElementForce {
        let k = if x.abs() > 1e-6 { f64::NAN } else { 1e6 };
        ElementForce {
            force: k * x,
            stiffness: k,
            damping: 0.0,
        }
    }
    fn commit(&mut self, x: f64, v: f64) -> ElementForce {
        self.trial(x, v)
    }
    fn reset(&mut self) {}
    fn has_memory(&self) -> bool {
        false
    }
}

#[test]
fn a_point_that_does_not_converge_is_flagged_with_nan_and_a_reason() {
    let linear = paper_linear();
    // the response (~1e-5 m) lies where the element has no force
    let p = hb::solve_point(
        &linear,
        &mut Breaks,
        150.0,
        100.0,
        None,
        &HbOptions::default(),
    )
    .unwrap();
    assert!(!p.converged);
    assert!(
        p.x.iter()
            .chain(&p.h)
            .all(|z| z.re.is_nan() && z.im.is_nan())
    );
    let why = p.failure.clone().unwrap();
    assert!(
        why.contains("not finite") || why.contains("no starting amplitude"),
        "{why}"
    );
    // a sweep goes on past such points, and serialises them as null
    let s = hb::sweep(
        &linear,
        &mut Breaks,
        &[150.0, 160.0],
        100.0,
        &HbOptions::default(),
    )
    .unwrap();
    assert!(s.points.iter().all(|p| !p.converged && p.failure.is_some()));
    let json = serde_json::to_string(&s.points[0]).unwrap();
    assert!(
        json.contains("null") && json.contains("\"converged\":false"),
        "{json}"
    );
    // too few iterations for a hard point: the reason names the cap (a
    // smooth Masing loop; Jenkins' piecewise-linear residual is often solved
    // in one step)
    let opts = HbOptions {
        max_iterations: 1,
        ..HbOptions::default()
    };
    let mut e = Masing::new(KD, FD, 2.0).unwrap();
    let p = hb::solve_point(&linear, &mut e, 250.0, 500.0, None, &opts).unwrap();
    assert!(!p.converged && p.residual > opts.tolerance, "{p:?}");
    assert!(p.failure.unwrap().contains("1 Newton iterations"));
}

#[test]
fn bad_input_is_an_error() {
    let linear = paper_linear();
    let opts = HbOptions::default();
    let mut e = NoElement;
    assert!(hb::sweep(&linear, &mut e, &[100.0, f64::NAN], 1.0, &opts).is_err());
    assert!(hb::sweep(&linear, &mut e, &[100.0], -1.0, &opts).is_err());
    assert!(
        hb::solve_point(
            &linear,
            &mut e,
            100.0,
            1.0,
            Some(&[Complex64::new(0.0, 0.0)]),
            &opts
        )
        .is_err()
    );
    for bad in [vec![3, 5], vec![1, 1], vec![5, 1]] {
        assert!(HbOptions::with_harmonics(bad).validate().is_err());
    }
    let mut o = HbOptions::with_harmonics(hb::odd_harmonics(15));
    o.samples_per_period = 30;
    let e = o.validate().unwrap_err().to_string();
    assert!(e.contains("samples_per_period"), "{e}");
}

/// The FRF set is identical run to run, and to sequential sweeps.
#[test]
fn frf_set_is_deterministic_and_equals_sequential_sweeps() {
    let model = Model::new(
        paper_linear(),
        vec![ElementSpec::Masing {
            kd: KD,
            fd: FD,
            n: 22.55,
        }],
    )
    .unwrap();
    let levels = [5.0, 200.0, 3000.0];
    let freqs = grid(100.0, 350.0, 11);
    let opts = HbOptions::default();
    let a = hb::frf_set_for_model(&model, &levels, &freqs, &opts).unwrap();
    let b = hb::frf_set_for_model(&model, &levels, &freqs, &opts).unwrap();
    assert_eq!(
        serde_json::to_string(&a).unwrap(),
        serde_json::to_string(&b).unwrap()
    );
    let mut solver = HbSolver::new(&opts).unwrap();
    for (lvl, s) in levels.iter().zip(&a) {
        let mut e = model.element_set().unwrap();
        let q = solver.sweep(&model.linear, &mut e, &freqs, *lvl).unwrap();
        assert_eq!(&q.points, &s.points);
    }
}

/// An asymmetric element needs the static part and even harmonics: HB over
/// `{0, 1, …, 8}` against the simulator's steady state (memoryless, so the
/// periodic state is unique).
#[test]
fn bilinear_stiffness_static_and_even_harmonics_match_the_simulator() {
    use hystid::model::BilinearStiffness;
    let linear = paper_linear();
    let e = BilinearStiffness { kb: 5e6 };
    let hs = hb::all_harmonics(8);
    let opts = HbOptions::with_harmonics(hs.clone());
    for f in [120.0, 180.0] {
        let (sim, fs, drift) = simulated_frf(&linear, e, f, 500.0, &hs);
        assert!(drift < 1e-6);
        let sampled = SampledReceptance {
            linear: &linear,
            sample_rate: fs,
        };
        let p = hb::solve_point(&sampled, &mut e.clone(), f, 500.0, None, &opts).unwrap();
        assert!(p.converged, "{p:?}");
        // static offset (the sim's DC bin is 2× the mean in `simulated_frf`)
        let x0_sim = 0.5 * sim[0].re;
        let x0_hb = p.h[0].re;
        assert!(
            p.h[0].norm() > 1e-2 * p.h[1].norm(),
            "a real offset: {}",
            p.h[0]
        );
        assert!(
            (x0_sim - x0_hb).abs() < 1e-2 * x0_hb.abs(),
            "X0 sim {x0_sim} hb {x0_hb}"
        );
        assert!(rel(sim[1], p.h[1]) < 2e-3, "H1 {} vs {}", sim[1], p.h[1]);
        assert!(rel(sim[2], p.h[2]) < 5e-2, "H2 {} vs {}", sim[2], p.h[2]);
    }
}

/// Every registered element law, at its description's example parameters
/// on the paper's linear system, against the simulator's steady state: a new
/// law is checked by harmonic balance and the time simulator together
/// without a test of its own. HB solves `{0, 1, …, 7}` (what an asymmetric law
/// needs) with the law's own samples per period.
#[test]
fn every_registered_element_matches_the_time_simulator() {
    use hystid::model::{ElementKind, ElementSpec};
    let linear = paper_linear();
    let hs = hb::all_harmonics(7);
    for &kind in ElementKind::ALL {
        let d = kind.description();
        let spec = ElementSpec::from_values(kind, d.example);
        let mut opts = HbOptions::with_harmonics(hs.clone());
        opts.samples_per_period = opts.samples_per_period.max(d.samples_per_period);
        for f in [180.0, 260.0] {
            let e = spec.build().unwrap();
            let (sim, fs, drift) = simulated_frf(&linear, e.clone(), f, 500.0, &hs);
            assert!(drift < 1e-6, "{}: not settled ({drift:e})", d.name);
            let sampled = SampledReceptance {
                linear: &linear,
                sample_rate: fs,
            };
            let p = hb::solve_point(&sampled, &mut e.clone(), f, 500.0, None, &opts).unwrap();
            assert!(p.converged, "{}: {p:?}", d.name);
            let e1 = rel(sim[1], p.h[1]);
            eprintln!("{} at {f} Hz: H1 HB vs simulator {e1:.1e}", d.name);
            assert!(
                e1 < 2e-3,
                "{} at {f} Hz: H1 {} vs {} ({e1:e})",
                d.name,
                sim[1],
                p.h[1]
            );
            // an odd law has no static part or even harmonic (beyond the
            // simulator's sampling, ~1e-5 of H1); the others
            // match the simulator's (its DC bin is 2× the mean). A law with
            // memory may keep a static offset from the transient (a Jenkins
            // slider left off centre), which no periodic solution fixes.
            for h in [0, 2] {
                if h == 0 && d.memory {
                    continue;
                }
                let s = if h == 0 {
                    0.5 * sim[0].re
                } else {
                    sim[2].norm()
                };
                let size = s.abs() / p.h[1].norm();
                if d.odd {
                    assert!(
                        size < 1e-4,
                        "{}: harmonic {h} of an odd law: {size:e}",
                        d.name
                    );
                    assert!(p.h[h].norm() < 1e-12 * p.h[1].norm(), "{}", d.name);
                } else if size > 1e-3 {
                    let hb = if h == 0 {
                        p.h[0].re.abs()
                    } else {
                        p.h[2].norm()
                    };
                    assert!(
                        (s.abs() - hb).abs() < 5e-2 * hb,
                        "{}: harmonic {h} sim {s} hb {hb}",
                        d.name
                    );
                }
            }
        }
    }
}

/// The fastest of `reps` timings of `f`, seconds (the machine is shared:
/// the minimum is the least disturbed).
fn fastest(reps: usize, mut f: impl FnMut()) -> f64 {
    (0..reps)
        .map(|_| {
            let t = std::time::Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Speed figures (run with `--ignored --nocapture`; no timing asserts).
#[test]
#[ignore]
fn hb_speed_report() {
    let linear = paper_linear();
    let masing = ElementSpec::Masing {
        kd: KD,
        fd: FD,
        n: 22.55,
    };
    let model = Model::new(linear.clone(), vec![masing]).unwrap();
    let freqs = grid(100.0, 350.0, 51);
    let levels = [5.0, 50.0, 200.0, 500.0, 1000.0, 3000.0, 30000.0];
    let opts = HbOptions::default();
    let mut solver = HbSolver::new(&opts).unwrap();
    let mut e = model.element_set().unwrap();
    let (mut total_sweep, mut total_evals) = (0.0, 0u64);
    for &level in &levels {
        let s = solver.sweep(&linear, &mut e, &freqs, level).unwrap();
        assert!(s.points.iter().all(|p| p.converged));
        total_evals += s.evaluations;
        let sweep = fastest(15, || {
            std::hint::black_box(solver.sweep(&linear, &mut e, &freqs, level).unwrap());
        });
        total_sweep += sweep;
        // the first point is a cold start: time it alone
        let cold = fastest(15, || {
            std::hint::black_box(solver.sweep(&linear, &mut e, &freqs[..1], level).unwrap());
        });
        eprintln!(
            "F = {level:>6} N: sweep of 51 {:.2} ms: cold start {:.0} us, warm points {:.1} us each, {:.2} AFT evaluations/point",
            sweep * 1e3,
            cold * 1e6,
            (sweep - cold) * 1e6 / 50.0,
            s.evaluations as f64 / 51.0
        );
    }
    eprintln!(
        "all 7 sweeps on one thread: {:.1} ms ({:.1} us/point, {:.2} evaluations/point)",
        total_sweep * 1e3,
        total_sweep * 1e6 / (7.0 * 51.0),
        total_evals as f64 / (7.0 * 51.0)
    );
    let set = fastest(15, || {
        std::hint::black_box(hb::frf_set_for_model(&model, &levels, &freqs, &opts).unwrap());
    });
    eprintln!(
        "FRF set 7 levels x 51 frequencies, Masing, {{1,3,5}}, 256 samples: {:.1} ms on {} threads",
        set * 1e3,
        rayon::current_num_threads()
    );
    for tol in [1e-8, 1e-6] {
        let o = HbOptions {
            tolerance: tol,
            ..HbOptions::default()
        };
        let t = fastest(10, || {
            std::hint::black_box(hb::frf_set_for_model(&model, &levels, &freqs, &o).unwrap());
        });
        eprintln!("  same at tolerance {tol:.0e}: {:.1} ms", t * 1e3);
    }
    let full = HbOptions {
        half_wave_symmetry: false,
        ..HbOptions::default()
    };
    let t = fastest(10, || {
        std::hint::black_box(hb::frf_set_for_model(&model, &levels, &freqs, &full).unwrap());
    });
    eprintln!("  same without half-wave symmetry: {:.1} ms", t * 1e3);
    let mut jopts = opts.clone();
    jopts.samples_per_period = 512;
    let jmodel = Model::new(
        linear.clone(),
        vec![ElementSpec::Jenkins { kd: KD, fd: FD }],
    )
    .unwrap();
    let t = fastest(10, || {
        std::hint::black_box(hb::frf_set_for_model(&jmodel, &levels, &freqs, &jopts).unwrap());
    });
    eprintln!("FRF set, Jenkins, 512 samples: {:.1} ms", t * 1e3);
    // single-harmonic describing-function FRF: cold (log-grid scan + Brent)
    // and warm (a bracket around the last amplitude, regula falsi)
    let cold_df = fastest(3, || {
        for &f in &freqs {
            let w = 2.0 * PI * f;
            std::hint::black_box(describing::solve(linear.receptance(w), 500.0, |a| {
                describing::masing(KD, FD, 22.55, a)
            }));
        }
    }) / freqs.len() as f64;
    let warm_df = fastest(10, || {
        for &level in &levels {
            let mut a = describing::solve(linear.receptance(2.0 * PI * freqs[0]), level, |a| {
                describing::masing(KD, FD, 22.55, a)
            })[0]
                .norm();
            for &f in &freqs[1..] {
                let h = linear.receptance(2.0 * PI * f);
                let phi = |a: f64| {
                    a * (1.0 + h * describing::masing(KD, FD, 22.55, a)).norm() - level * h.norm()
                };
                let (mut lo, mut hi) = (a / 1.5, a * 1.5);
                let (mut flo, mut fhi) = (phi(lo), phi(hi));
                while flo > 0.0 {
                    lo /= 1.5;
                    flo = phi(lo);
                }
                while fhi < 0.0 {
                    hi *= 1.5;
                    fhi = phi(hi);
                }
                // Illinois regula falsi to 1e-12 relative
                let mut side = 0;
                for _ in 0..100 {
                    a = (lo * fhi - hi * flo) / (fhi - flo);
                    let fa = phi(a);
                    if (hi - lo) < 1e-12 * a || fa == 0.0 {
                        break;
                    }
                    if fa < 0.0 {
                        lo = a;
                        flo = fa;
                        if side == -1 {
                            fhi *= 0.5;
                        }
                        side = -1;
                    } else {
                        hi = a;
                        fhi = fa;
                        if side == 1 {
                            flo *= 0.5;
                        }
                        side = 1;
                    }
                }
                std::hint::black_box(a);
            }
        }
    }) / (levels.len() * (freqs.len() - 1)) as f64;
    eprintln!(
        "single-harmonic describing function (quadrature): cold solve {:.0} us/point, warm {:.1} us/point; HB {{1,3,5}} warm point / warm DF = {:.1}",
        cold_df * 1e6,
        warm_df * 1e6,
        total_sweep / (7.0 * 51.0) / warm_df
    );
}

/// AFT accuracy at the default sample counts (run with `--ignored
/// --nocapture`): single-harmonic HB against the describing functions.
#[test]
#[ignore]
fn hb_accuracy_report() {
    let linear = paper_linear();
    let freqs = grid(120.0, 340.0, 12);
    for ns in [256usize, 512, 1024] {
        let mut opts = HbOptions::with_harmonics(vec![1]);
        opts.samples_per_period = ns;
        let (mut wj, mut wm) = (0.0f64, 0.0f64);
        for level in [50.0, 300.0, 1000.0, 5000.0] {
            let mut j = Jenkins::new(KD, FD).unwrap();
            let mut m = Masing::new(KD, FD, 22.55).unwrap();
            let sj = hb::sweep(&linear, &mut j, &freqs, level, &opts).unwrap();
            let sm = hb::sweep(&linear, &mut m, &freqs, level, &opts).unwrap();
            for (p, q) in sj.points.iter().zip(&sm.points) {
                let w = 2.0 * PI * p.frequency_hz;
                let h = linear.receptance(w);
                let rj = describing::solve(h, level, |a| describing::jenkins(KD, FD, a));
                let rm = describing::solve(h, level, |a| describing::masing(KD, FD, 22.55, a));
                wj = wj.max(rel(p.x[0], rj[0]));
                wm = wm.max(rel(q.x[0], rm[0]));
            }
        }
        eprintln!("{ns} samples: worst |ΔH1|/|H1| Jenkins {wj:.2e}, Masing N=22.55 {wm:.2e}");
    }
}

/// Robustness over the parameter ranges a fit explores: every point of the
/// paper's 7 × 51 FRF set converges for Masing elements from soft to stiff,
/// weak to strong, round to sharp (N from 0.5 to 1e4), and for Jenkins.
#[test]
fn every_point_converges_over_a_fit_like_parameter_range() {
    let freqs = grid(100.0, 350.0, 51);
    let levels = [5.0, 50.0, 200.0, 500.0, 1000.0, 3000.0, 30000.0];
    let opts = HbOptions::default();
    let mut failures = Vec::new();
    let mut points = 0;
    for kd in [1e6, 2.4e7, 3e8] {
        for fd in [10.0, 246.048, 5000.0] {
            let specs = [0.5, 1.5, 22.55, 1000.0, 1e4]
                .map(|n| ElementSpec::Masing { kd, fd, n })
                .into_iter()
                .chain([ElementSpec::Jenkins { kd, fd }]);
            for spec in specs {
                let model = Model::new(paper_linear(), vec![spec]).unwrap();
                for s in hb::frf_set_for_model(&model, &levels, &freqs, &opts).unwrap() {
                    for p in &s.points {
                        points += 1;
                        if !p.converged {
                            failures.push(format!(
                                "{spec:?} F {} f {}: {:?}",
                                p.force_amplitude, p.frequency_hz, p.failure
                            ));
                        }
                    }
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {points} failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// A derivative by differences of a converged point: the joint's slip force
/// changed by 1e-11 of itself moves the balance's residual by less than the
/// tolerance notices, so a solve warm-started at the old solution returns it
/// unchanged (the derivative reads zero). With `step_at_least_once` the
/// solve takes one Newton step, exact to second order in the change: its
/// derivative equals a central difference of two cold solves at ±1e-5
/// (solved to 1e-14) within 1e-4, the round-off of a 1e-11 difference.
#[test]
fn a_difference_step_below_the_tolerance_still_moves_the_solution() {
    let linear = paper_linear();
    let (f, level) = (200.0, 300.0);
    let solve = |fd: f64, guess: Option<&[Complex64]>, once: bool, tolerance: f64| {
        let mut e = ElementSpec::Masing {
            kd: KD,
            fd,
            n: 22.55,
        }
        .build()
        .unwrap();
        let mut s = HbSolver::new(&HbOptions {
            tolerance,
            ..HbOptions::default()
        })
        .unwrap();
        s.step_at_least_once(once);
        let p = s.solve_point(&linear, &mut e, f, level, guess).unwrap();
        assert!(p.converged);
        p.x
    };
    let x0 = solve(FD, None, false, 1e-14);
    let h = 1e-11;
    let plain = solve(FD * (1.0 + h), Some(&x0), false, 1e-10);
    let stepped = solve(FD * (1.0 + h), Some(&x0), true, 1e-10);
    let (up, down) = (
        solve(FD * (1.0 + 1e-5), None, false, 1e-14),
        solve(FD * (1.0 - 1e-5), None, false, 1e-14),
    );
    let scale = x0[0].norm();
    for k in 0..x0.len() {
        let reference = (up[k] - down[k]) / (2e-5 * FD);
        assert_eq!(plain[k], x0[k], "harmonic {k}: the plain solve moved");
        let d = (stepped[k] - x0[k]) / (h * FD);
        assert!(
            (d - reference).norm() <= 1e-4 * reference.norm().max(1e-3 * scale / FD),
            "harmonic {k}: {d} vs {reference}"
        );
    }
    // the fundamental's sensitivity is what a fit sees: far from zero
    assert!((up[0] - down[0]).norm() > 1e-6 * scale);
}

/// A hysteretic mode (a mode with a Jenkins joint of its own) beside the
/// paper's jointed SDOF: `simulate --check-hb` balances the point structure
/// and the mode apart and adds their harmonics, against the simulator's
/// steady state, which runs them as two uncoupled systems under one force.
/// Issue 12 asks 0.2 % in H1; the pinned figures are pinned here.
#[test]
fn a_hysteretic_mode_is_balanced_as_the_simulator_runs_it() {
    let dir = tempfile::tempdir().unwrap();
    let def = dir.path().join("hysteretic_mode.toml");
    std::fs::write(&def, crate::common::HYSTERETIC_MODE_TEST).unwrap();
    let out = dir.path().join("out");
    let o = crate::cli::hystid(&[
        "simulate",
        def.to_str().unwrap(),
        "--check-hb",
        "--no-recording",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let checks: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("hb_check.json")).unwrap()).unwrap();
    let mut h1: Vec<f64> = checks
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            assert_eq!(c["converged"], true, "{c}");
            c["h1_relative_difference"].as_f64().unwrap()
        })
        .collect();
    h1.sort_by(f64::total_cmp);
    let (median, max) = (h1[h1.len() / 2], h1[h1.len() - 1]);
    let h3 = {
        let mut v: Vec<f64> = (checks.as_array().unwrap().iter())
            .filter_map(|c| c["higher"][0][1].as_f64())
            .collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    eprintln!(
        "{} dwells: H1 {median:.1e} (median) / {max:.1e} (max), H3 {h3:.1e}",
        h1.len()
    );
    assert_eq!(h1.len(), 84);
    assert!(max < 2e-3, "{max}");
    let shown = crate::common::pinned_figures(
        "- `simulate --check-hb` on the paper's system plus a hysteretic mode:",
    )
    .expect("the pinned figures");
    crate::common::assert_pinned_figure("H1 median", median, shown[0]);
    crate::common::assert_pinned_figure("H1 max", max, shown[1]);
    crate::common::assert_pinned_figure("dwells", h1.len() as f64, shown[2]);
    crate::common::assert_pinned_figure("H3 median", h3, shown[3]);
}
