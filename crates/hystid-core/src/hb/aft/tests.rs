//! Tests of the alternating frequency–time evaluation against direct sums,
//! finite differences and the half-wave march.

use super::*;
use crate::model::{ElementKind, ElementSet, ElementSpec};

/// A naive reference: direct sums for synthesis and analysis, the
/// element marched the same way.
fn naive_g<E: Element>(
    harmonics: &[usize],
    xs: &[f64],
    ns: usize,
    omega: f64,
    e: &mut E,
) -> Vec<f64> {
    let lay = Layout::new(harmonics);
    let z = lay.unpack(xs);
    let mut x = vec![0.0; ns];
    let mut v = vec![0.0; ns];
    for j in 0..ns {
        let th = 2.0 * PI * j as f64 / ns as f64;
        for (i, &h) in harmonics.iter().enumerate() {
            let e = Complex64::from_polar(1.0, h as f64 * th);
            x[j] += (z[i] * e).re;
            v[j] += (z[i] * e * Complex64::new(0.0, h as f64 * omega)).re;
        }
    }
    // turning points between samples, by bisection on the slope
    let slope = |th: f64| -> f64 {
        harmonics
            .iter()
            .enumerate()
            .map(|(i, &h)| {
                (z[i] * Complex64::new(0.0, h as f64) * Complex64::from_polar(1.0, h as f64 * th))
                    .re
            })
            .sum()
    };
    let value = |th: f64| -> f64 {
        harmonics
            .iter()
            .enumerate()
            .map(|(i, &h)| (z[i] * Complex64::from_polar(1.0, h as f64 * th)).re)
            .sum()
    };
    let dt = 2.0 * PI / ns as f64;
    let mut turning = vec![None; ns];
    for (j, t) in turning.iter_mut().enumerate() {
        let (mut lo, mut hi) = (j as f64 * dt, (j + 1) as f64 * dt);
        let (a, b) = (slope(lo), slope(hi));
        if a * b < 0.0 {
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if (slope(mid) > 0.0) == (a > 0.0) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            *t = Some(value(0.5 * (lo + hi)));
        }
    }
    // two periods from virgin, keep the second; a gradually settling
    // law: periods until the force repeats to rounding (plain
    // repetition, no Newton step)
    e.reset();
    let mut g = vec![0.0; ns];
    let passes = if e.periods_to_settle() > 0 { 5000 } else { 2 };
    for pass in 0..passes {
        let mut change = 0.0f64;
        for j in 0..ns {
            let f = e.commit(x[j], v[j]).force;
            if pass > 0 {
                change = change.max((g[j] - f).abs());
            }
            g[j] = f;
            if let (true, Some(xt)) = (e.has_memory(), turning[j]) {
                e.commit(xt, 0.0);
            }
        }
        if pass > 0 && change <= 1e-14 * g.iter().fold(0.0f64, |m, x| m.max(x.abs())) {
            break;
        }
    }
    let mut out = vec![0.0; lay.len];
    for (i, &h) in harmonics.iter().enumerate() {
        let mut acc = Complex64::new(0.0, 0.0);
        for (j, gj) in g.iter().enumerate() {
            acc += gj * Complex64::from_polar(1.0, -(h as f64) * 2.0 * PI * j as f64 / ns as f64);
        }
        let s = lay.slots[i];
        if h == 0 {
            out[s] = acc.re / ns as f64;
        } else {
            out[s] = 2.0 * acc.re / ns as f64;
            out[s + 1] = 2.0 * acc.im / ns as f64;
        }
    }
    out
}

/// Every registered law at its description's example, and the Masing
/// element at a soft curvature too.
fn all_specs() -> Vec<ElementSpec> {
    let mut specs: Vec<ElementSpec> = ElementKind::ALL
        .iter()
        .map(|&k| ElementSpec::from_values(k, k.description().example))
        .collect();
    specs.push(ElementSpec::Masing {
        kd: 2.4e7,
        fd: 246.048,
        n: 3.0,
    });
    specs
}

/// A response with DC, even and odd harmonics, inner loops.
fn test_x(lay: &Layout) -> Vec<f64> {
    let mut xs = vec![0.0; lay.len];
    for (k, x) in xs.iter_mut().enumerate() {
        *x = 1e-5 * ((k as f64 * 1.7).sin() + 0.3) / (1.0 + k as f64);
    }
    xs
}

/// The structured projection of the sensitivities (tangents by one FFT,
/// memory terms by weighted sums) equals the dense one (every column
/// transformed) for every element, a set mixing memory and memoryless
/// laws, both periodic-loop methods, and the half-wave march.
#[test]
fn structured_jacobian_equals_the_dense_one() {
    let omega = 2.0 * PI * 200.0;
    let mut sets: Vec<(String, ElementSet<crate::model::AnyElement>)> = all_specs()
        .into_iter()
        .map(|spec| {
            (
                format!("{spec:?}"),
                ElementSet::new(vec![spec.build().unwrap()]),
            )
        })
        .collect();
    let mixed = [
        ElementSpec::Jenkins {
            kd: 2.4e7,
            fd: 246.048,
        },
        ElementSpec::Masing {
            kd: 1.2e7,
            fd: 120.0,
            n: 3.0,
        },
        ElementSpec::from_values(
            ElementKind::CubicStiffness,
            ElementKind::CubicStiffness.description().example,
        ),
        ElementSpec::from_values(
            ElementKind::ViscousDamping,
            ElementKind::ViscousDamping.description().example,
        ),
    ];
    sets.push((
        "Jenkins + Masing + cubic + viscous".into(),
        ElementSet::new(mixed.iter().map(|s| s.build().unwrap()).collect()),
    ));
    for (harmonics, ns, odd) in [
        (&[0, 1, 2, 3, 5][..], 128, false),
        (&[1, 3, 5, 7][..], 128, true),
    ] {
        let mut aft = Aft::new(harmonics, ns);
        let n = aft.layout.len;
        let xs = test_x(&aft.layout);
        for (name, e) in &mut sets {
            let odd = odd && e.odd_law();
            for method in [PeriodicLoop::MaxAmplitude, PeriodicLoop::TwoPeriods] {
                let (mut g, mut dg) = (vec![0.0; n], vec![0.0; n * n]);
                aft.dense_only = false;
                aft.evaluate(&xs, omega, e, method, odd, &mut g, Some(&mut dg))
                    .unwrap();
                // every law but a gradually settling one takes the
                // structured form in the usual march
                if method == PeriodicLoop::MaxAmplitude && e.periods_to_settle() == 0 {
                    assert!(aft.structured, "{name}: dense");
                }
                let (mut g_dense, mut dg_dense) = (vec![0.0; n], vec![0.0; n * n]);
                aft.dense_only = true;
                aft.evaluate(
                    &xs,
                    omega,
                    e,
                    method,
                    odd,
                    &mut g_dense,
                    Some(&mut dg_dense),
                )
                .unwrap();
                assert_eq!(g, g_dense, "{name}: the forces differ");
                let scale = dg_dense.iter().fold(0.0f64, |m, d| m.max(d.abs()));
                for (i, (a, b)) in dg.iter().zip(&dg_dense).enumerate() {
                    assert!(
                        (a - b).abs() <= 1e-12 * scale,
                        "{name} {method:?} odd {odd} ∂G[{}]/∂X[{}]: {a} vs {b}",
                        i / n,
                        i % n
                    );
                }
            }
        }
    }
}

#[test]
fn fft_aft_equals_the_naive_direct_sums_for_every_element() {
    let harmonics = [0, 1, 2, 3, 5];
    let ns = 64;
    let omega = 2.0 * PI * 200.0;
    let mut aft = Aft::new(&harmonics, ns);
    let xs = test_x(&aft.layout);
    for spec in all_specs() {
        let mut e = spec.build().unwrap();
        let mut g = vec![0.0; aft.layout.len];
        for method in [PeriodicLoop::MaxAmplitude, PeriodicLoop::TwoPeriods] {
            aft.evaluate(&xs, omega, &mut e, method, false, &mut g, None)
                .unwrap();
            let reference = naive_g(&harmonics, &xs, ns, omega, &mut e);
            for (a, b) in g.iter().zip(&reference) {
                let scale = reference.iter().fold(0.0f64, |m, r| m.max(r.abs()));
                assert!(
                    (a - b).abs() <= 1e-12 * scale,
                    "{spec:?} {method:?}: {a} vs {b}"
                );
            }
        }
    }
}

/// `commit_sensitivity` through the whole march (every element, the
/// turning-point histories included) equals central differences of the
/// AFT force harmonics.
#[test]
fn analytic_jacobian_equals_finite_differences_for_every_element() {
    let harmonics = [0, 1, 2, 3, 5];
    let ns = 128;
    let omega = 2.0 * PI * 200.0;
    let mut aft = Aft::new(&harmonics, ns);
    let n = aft.layout.len;
    let xs = test_x(&aft.layout);
    for spec in all_specs() {
        for method in [PeriodicLoop::MaxAmplitude, PeriodicLoop::TwoPeriods] {
            let mut e = ElementSet::new(vec![spec.build().unwrap()]);
            let mut g = vec![0.0; n];
            let mut dg = vec![0.0; n * n];
            aft.evaluate(&xs, omega, &mut e, method, false, &mut g, Some(&mut dg))
                .unwrap();
            let mut g_plain = vec![0.0; n];
            aft.evaluate(&xs, omega, &mut e, method, false, &mut g_plain, None)
                .unwrap();
            assert_eq!(
                g, g_plain,
                "{spec:?}: the sensitivity march changed the forces"
            );
            let scale = dg.iter().fold(0.0f64, |m, d| m.max(d.abs()));
            for k in 0..n {
                // a step far below the samples' spacing from any kink,
                // large enough for round-off (forces ~1e2 N, x ~1e-5 m):
                // the differences agree to ~2e-8 of the largest entry
                let step = 1e-13;
                let mut xp = xs.clone();
                xp[k] += step;
                let mut gp = vec![0.0; n];
                aft.evaluate(&xp, omega, &mut e, method, false, &mut gp, None)
                    .unwrap();
                let mut xm = xs.clone();
                xm[k] -= step;
                let mut gm = vec![0.0; n];
                aft.evaluate(&xm, omega, &mut e, method, false, &mut gm, None)
                    .unwrap();
                for r in 0..n {
                    let fd = (gp[r] - gm[r]) / (2.0 * step);
                    assert!(
                        (fd - dg[r * n + k]).abs() <= 1e-6 * scale,
                        "{spec:?} {method:?} ∂G[{r}]/∂X[{k}]: fd {fd} vs {}",
                        dg[r * n + k]
                    );
                }
            }
        }
    }
}

/// Half a period mirrored equals the whole period, forces and
/// Jacobian, for every odd element (odd harmonics, inner loops).
#[test]
fn half_wave_march_equals_the_full_period() {
    let harmonics = [1, 3, 5, 7];
    let ns = 128;
    let omega = 2.0 * PI * 200.0;
    let mut aft = Aft::new(&harmonics, ns);
    let n = aft.layout.len;
    let xs = test_x(&aft.layout);
    for spec in all_specs() {
        if matches!(spec, ElementSpec::BilinearStiffness { .. }) {
            continue;
        }
        let mut e = spec.build().unwrap();
        let (mut g1, mut d1) = (vec![0.0; n], vec![0.0; n * n]);
        let (mut g2, mut d2) = (vec![0.0; n], vec![0.0; n * n]);
        let m = PeriodicLoop::MaxAmplitude;
        aft.evaluate(&xs, omega, &mut e, m, false, &mut g1, Some(&mut d1))
            .unwrap();
        aft.evaluate(&xs, omega, &mut e, m, true, &mut g2, Some(&mut d2))
            .unwrap();
        let gs = g1.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let ds = d1.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        for (a, b) in g1.iter().zip(&g2) {
            assert!((a - b).abs() <= 1e-12 * gs, "{spec:?}: {a} vs {b}");
        }
        // a settling law's sensitivities are carried from the Newton
        // step on the period map before the kept period, which used that
        // step's own march: consistent to ~4e-8 (the half march starts
        // on the symmetric loop, which inner loops move it off by a
        // little, the whole one from the virgin ramp), far inside what
        // Newton's iteration needs (the forces agree to rounding)
        let tol = if e.periods_to_settle() > 0 {
            1e-7
        } else {
            1e-10
        };
        for (a, b) in d1.iter().zip(&d2) {
            assert!((a - b).abs() <= tol * ds, "{spec:?}: {a} vs {b}");
        }
    }
}

/// A Bouc-Wen loop far below its saturation force is nearly elastic:
/// a half period leaves almost all of its memory (`g` within 1e-6 of
/// 1, where a whole period's Newton step is not taken). The half-period
/// march still settles, and the force is `α x` to the loop's relative
/// size, ~`β (γ + δ) |z|/α` = 1e-7.
#[test]
fn a_nearly_elastic_bouc_wen_loop_settles_by_half_periods() {
    let harmonics = [1, 3, 5];
    let ns = 256;
    let mut aft = Aft::new(&harmonics, ns);
    let n = aft.layout.len;
    let (alpha, beta) = (2.4e7, 1e5);
    let mut e = ElementSpec::BoucWen {
        alpha,
        beta,
        gamma: 0.5,
        delta: 0.5,
        nu: 1.0,
    }
    .build()
    .unwrap();
    // 1e-7 of the saturation force's displacement α/(β α) = 1e-5 m
    let mut xs = vec![0.0; n];
    xs[0] = 1e-12;
    xs[2] = 2e-13;
    let mut g = vec![0.0; n];
    let mut dg = vec![0.0; n * n];
    aft.evaluate(
        &xs,
        1000.0,
        &mut e,
        PeriodicLoop::MaxAmplitude,
        true,
        &mut g,
        Some(&mut dg),
    )
    .unwrap();
    for k in 0..n {
        assert!(
            (g[k] - alpha * xs[k]).abs() <= 1e-6 * alpha * xs[0],
            "G[{k}] = {} vs α X = {}",
            g[k],
            alpha * xs[k]
        );
    }
}

/// A Masing joint (N = 5) balanced by `aft` at `xs` (ω = 1, odd law,
/// with its Jacobian), the outputs filled with `init` beforehand.
fn masing_evaluated(aft: &mut Aft, xs: &[f64], init: f64) -> (Vec<f64>, Vec<f64>) {
    let mut e = ElementSpec::Masing {
        kd: 2.4e7,
        fd: 246.048,
        n: 5.0,
    }
    .build()
    .unwrap();
    let n = aft.layout.len;
    let (mut g, mut d) = (vec![init; n], vec![init; n * n]);
    aft.evaluate(
        xs,
        1.0,
        &mut e,
        PeriodicLoop::MaxAmplitude,
        true,
        &mut g,
        Some(&mut d),
    )
    .unwrap();
    (g, d)
}

#[test]
fn workspace_results_do_not_depend_on_dirty_buffers() {
    let mut aft = Aft::new(&[1, 3, 5], 32);
    let xs = test_x(&aft.layout);
    let first = masing_evaluated(&mut aft, &xs, 0.0);
    for b in [
        &mut aft.x,
        &mut aft.v,
        &mut aft.g,
        &mut aft.buf,
        &mut aft.dg_rows,
        &mut aft.dv,
    ] {
        b.fill(f64::NAN);
    }
    aft.spectrum.fill(Complex64::new(f64::NAN, f64::NAN));
    assert_eq!(first, masing_evaluated(&mut aft, &xs, f64::NAN));
}

/// Workspaces of one harmonic set and sample count share one set of
/// tables, built once and never written: a workspace made after another
/// has evaluated gives the same bits, and the shared tables are those
/// built afresh.
#[test]
fn workspaces_share_tables_that_evaluations_leave_as_built() {
    let harmonics = [1, 3, 5, 7];
    let mut first = Aft::new(&harmonics, 48);
    let xs = test_x(&first.layout);
    let a = masing_evaluated(&mut first, &xs, 0.0);
    let mut second = Aft::new(&harmonics, 48);
    assert!(Arc::ptr_eq(&first.tables, &second.tables));
    assert!(!Arc::ptr_eq(
        &first.tables,
        &Aft::new(&harmonics, 64).tables
    ));
    assert!(!Arc::ptr_eq(&first.tables, &Aft::new(&[1, 3], 48).tables));
    assert_eq!(a, masing_evaluated(&mut second, &xs, f64::NAN));
    let fresh = Tables::new(&first.layout, 48);
    let shared = &second.tables;
    assert_eq!(fresh.basis_x, shared.basis_x);
    assert_eq!(fresh.basis_v, shared.basis_v);
    assert_eq!(fresh.analysis, shared.analysis);
    assert_eq!(fresh.units, shared.units);
    assert_eq!(fresh.odd_only, shared.odd_only);
}
