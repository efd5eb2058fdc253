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

/// Single-harmonic HB against the describing-function FRF (method notes
/// d.2–d.3), through the transition from stick to slip.
#[test]
fn single_harmonic_balance_equals_the_describing_function_frf() {
    let linear = paper_linear();
    let freqs = grid(120.0, 340.0, 12);
    // Jenkins: AFT's kink error falls as ~N^-2 (method notes d.1): 8192
    // samples put it below 1e-7
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
