//! Single-harmonic describing functions and the single-harmonic FRF.
//!
//! For `x = Re(a e^{jθ})` the describing function `N(a)` gives the
//! fundamental of the element force as `N(a)·a` (`Re N`: equivalent
//! stiffness, `Im N`: equivalent damping times ω):
//!
//! * [`jenkins`]: closed form (Caughey 1960, bilinear hysteresis with zero
//!   post-slip stiffness);
//! * [`masing`]: the eq. (10) Masing loop by Gauss–Legendre quadrature of
//!   `Re N = −(4/(πa)) ∫₀^π f(a sin²(θ/2)) cos θ dθ` and
//!   `Im N = W/(πa²)`, `W = 8∫₀^a f − 4a f(a)`, with the backbone `f` of
//!   [`crate::model::PowerBackbone`] (the element's own law);
//! * [`numeric`]: any element, by marching one periodic loop (AFT);
//! * [`of_elements`]: the sum over a set, closed forms where known.
//!
//! [`solve`] finds every amplitude of the single-harmonic balance
//! `a |1 + H N(a)| = F|H|` (a log-spaced scan for sign changes, then Brent's
//! method) and returns `X_1 = F H/(1 + H N(a))`. Harmonic balance starts its
//! sweeps there.

use super::LinearPart;
use crate::model::masing::loop_describing_function;
use crate::model::{Element, PowerBackbone};
use num_complex::Complex64;

/// The Jenkins element's describing function (Caughey 1960): see
/// [`crate::model::jenkins::describing_function`].
pub fn jenkins(kd: f64, fd: f64, amplitude: f64) -> Complex64 {
    crate::model::jenkins::describing_function(kd, fd, amplitude)
}

/// The eq. (10) Masing element's describing function, by Gauss–Legendre
/// quadrature split at the backbone's knee (better than 1e-8 relative for
/// `n` up to several hundred; tested against a brute-force loop integral).
///
/// NaN (both parts) unless `kd`, `fd`, `n` are finite and positive and the
/// amplitude finite.
pub fn masing(kd: f64, fd: f64, n: f64, amplitude: f64) -> Complex64 {
    match PowerBackbone::new(kd, fd, n) {
        Ok(b) if amplitude.is_finite() => loop_describing_function(&b, fd / kd, amplitude, 8),
        _ => Complex64::new(f64::NAN, f64::NAN),
    }
}

/// The describing function of any element, from one periodic loop of
/// `samples` points: see [`crate::model::element::loop_fundamental`].
pub fn numeric<E: Element>(
    element: &mut E,
    amplitude: f64,
    omega: f64,
    samples: usize,
) -> Complex64 {
    crate::model::element::loop_fundamental(element, amplitude, omega, samples)
}

/// The describing function of an element or a set of them at amplitude `a`
/// and angular frequency `omega`: each element's own
/// [`Element::describing_function`] (closed forms where known, a cheap
/// quadrature for the eq. (10) Masing element: these are starting points;
/// else one marched loop of `samples` points). The element is left reset.
pub fn of_elements<E: Element>(
    elements: &mut E,
    amplitude: f64,
    omega: f64,
    samples: usize,
) -> Complex64 {
    elements.describing_function(amplitude, omega, samples)
}

/// Every solution of the single-harmonic balance `X_1 (1/H + N(|X_1|)) = F`
/// at one frequency, given the receptance `h = H(ω)` and the describing
/// function `n_of(a)`; sorted by amplitude.
///
/// Solved as `φ(a) = a |1 + H N(a)| − F|H| = 0` (no division by `H`): a scan
/// of 8 points per decade over `F|H|·[1e-6, 1e6]`; each sign change is refined
/// by Brent's method to 1e-13 relative. Two roots within one grid step (near a
/// fold) leave no sign change but a local extremum of `φ` on the wrong side of
/// zero: there `φ` is minimised (or maximised) by golden section, and if it
/// crosses zero both roots are bracketed. Roots closer than ~1e-6 relative (a
/// fold exactly) can be missed.
pub fn solve(h: Complex64, force: f64, mut n_of: impl FnMut(f64) -> Complex64) -> Vec<Complex64> {
    const PER_DECADE: usize = 8;
    const DECADES: usize = 12;
    const POINTS: usize = PER_DECADE * DECADES + 1;
    let target = force * h.norm();
    let roots = {
        let mut phi = |a: f64| a * (1.0 + h * n_of(a)).norm() - target;
        let grid = |k: usize| target * 10f64.powf(-6.0 + k as f64 / PER_DECADE as f64);
        let a: Vec<f64> = (0..POINTS).map(grid).collect();
        let p: Vec<f64> = a.iter().map(|&x| phi(x)).collect();
        let mut roots = Vec::new();
        for k in 0..POINTS - 1 {
            let (p0, p1) = (p[k], p[k + 1]);
            if !(p0.is_finite() && p1.is_finite()) {
                continue;
            }
            if p0 == 0.0 {
                roots.push(a[k]);
            } else if p1 != 0.0 && (p0 < 0.0) != (p1 < 0.0) {
                roots.extend(brent(&mut phi, a[k], a[k + 1], p0, p1, 1e-13));
            } else if k > 0 && p[k - 1].is_finite() {
                // a local extremum of φ that stays on one side of zero at the
                // grid points may still cross it in between
                let pm = p[k - 1];
                let dip = p0 > 0.0 && p0 < pm && p0 < p1;
                let bump = p0 < 0.0 && p0 > pm && p0 > p1;
                if dip || bump {
                    let sign = if dip { 1.0 } else { -1.0 };
                    let (x, v) = golden_min(&mut |x| sign * phi(x), a[k - 1], a[k + 1]);
                    let v = sign * v;
                    if v != 0.0 && (v < 0.0) != (p0 < 0.0) {
                        // the left root may lie in [a_{k-1}, a_k] or
                        // [a_k, x]; [a_{k-1}, x] brackets it either way
                        roots.extend(brent(&mut phi, a[k - 1], x, pm, v, 1e-13));
                        roots.extend(brent(&mut phi, x, a[k + 1], v, p1, 1e-13));
                    }
                }
            }
        }
        roots.sort_by(f64::total_cmp);
        roots.dedup_by(|x, y| (*x - *y).abs() <= 1e-12 * y.abs());
        roots
    };
    roots
        .into_iter()
        .map(|a| force * h / (1.0 + h * n_of(a)))
        .collect()
}

/// [`solve`] on a [`LinearPart`] at `omega` with `elements`' describing
/// function over loops of `samples` points: the drive model's `D(ω)` (a
/// shaker's, [`LinearPart::drive`]) scales the force reaching the structure
/// and turns the solutions by its phase.
pub fn solve_on<L: LinearPart, E: Element>(
    linear: &L,
    elements: &mut E,
    omega: f64,
    force: f64,
    samples: usize,
) -> crate::Result<Vec<Complex64>> {
    let h = linear.receptance(omega)?;
    let d = linear.drive(omega);
    let turn = d / d.norm();
    Ok(solve(h, force * d.norm(), |a| {
        of_elements(elements, a, omega, samples)
    })
    .into_iter()
    .map(|x| x * turn)
    .collect())
}

/// Golden-section minimum of `f` on `[lo, hi]` (60 steps: ~1e-12 of the
/// bracket); returns `(x, f(x))`.
fn golden_min(f: &mut impl FnMut(f64) -> f64, mut lo: f64, mut hi: f64) -> (f64, f64) {
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let mut x1 = hi - r * (hi - lo);
    let mut x2 = lo + r * (hi - lo);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..60 {
        if f1 < f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - r * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + r * (hi - lo);
            f2 = f(x2);
        }
    }
    if f1 < f2 { (x1, f1) } else { (x2, f2) }
}

/// Brent's method (Brent 1973, `zeroin`) on a bracket with `f(a)`, `f(b)` of
/// opposite signs; `None` if the bracket is invalid.
pub(crate) fn brent(
    f: &mut impl FnMut(f64) -> f64,
    mut a: f64,
    mut b: f64,
    mut fa: f64,
    mut fb: f64,
    rel_tol: f64,
) -> Option<f64> {
    if (fa < 0.0) == (fb < 0.0) {
        return None;
    }
    let (mut c, mut fc) = (a, fa);
    let mut d = b - a;
    let mut e = d;
    for _ in 0..200 {
        if (fb < 0.0) == (fc < 0.0) {
            c = a;
            fc = fa;
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        let tol = 2.0 * f64::EPSILON * b.abs() + 0.5 * rel_tol * b.abs();
        let m = 0.5 * (c - b);
        if m.abs() <= tol || fb == 0.0 {
            return Some(b);
        }
        if e.abs() >= tol && fa.abs() > fb.abs() {
            let s = fb / fa;
            let (mut p, mut q) = if a == c {
                (2.0 * m * s, 1.0 - s)
            } else {
                let q = fa / fc;
                let r = fb / fc;
                (
                    s * (2.0 * m * q * (q - r) - (b - a) * (r - 1.0)),
                    (q - 1.0) * (r - 1.0) * (s - 1.0),
                )
            };
            if p > 0.0 {
                q = -q;
            } else {
                p = -p;
            }
            if 2.0 * p < (3.0 * m * q - (tol * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = m;
                e = m;
            }
        } else {
            d = m;
            e = m;
        }
        a = b;
        fa = fb;
        b += if d.abs() > tol { d } else { tol.copysign(m) };
        fb = f(b);
    }
    Some(b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Backbone, CubicStiffness, Jenkins, PiecewiseLinearBackbone};
    use std::f64::consts::PI;

    const KD: f64 = 2.4e7;
    const FD: f64 = 246.048;

    /// A brute-force reference: the loop's fundamental by a fine rectangle
    /// rule (exact for periodic integrands up to the kink error ~1/M²).
    fn brute(f: impl Fn(f64) -> f64, a: f64) -> Complex64 {
        // Masing loop of amplitude a: descending F = f(a) − 2 f((a − x)/2)
        let m = 400_000;
        let mut acc = Complex64::new(0.0, 0.0);
        for i in 0..m {
            let th = 2.0 * PI * (i as f64 + 0.5) / m as f64;
            let x = a * th.cos();
            let g = if th <= PI {
                f(a) - 2.0 * f((a - x) / 2.0)
            } else {
                -f(a) + 2.0 * f((a + x) / 2.0)
            };
            acc += g * Complex64::from_polar(1.0, -th);
        }
        acc * (2.0 / m as f64) / a
    }

    #[test]
    fn masing_quadrature_equals_a_brute_force_loop_integral() {
        for n in [1.0, 3.0, 22.55, 300.0] {
            let b = PowerBackbone::new(KD, FD, n).unwrap();
            for ratio in [0.1, 0.9, 1.5, 4.0, 30.0] {
                let a = ratio * FD / KD;
                let q = masing(KD, FD, n, a);
                let r = brute(|u| b.eval(u).0, a);
                let err = (q - r).norm() / r.norm();
                assert!(err < 1e-8, "n={n} a/ac={ratio}: {q} vs {r} ({err:e})");
                let fast = loop_describing_function(&b, FD / KD, a, 2);
                let err = (fast - r).norm() / r.norm();
                assert!(
                    err < 2e-4,
                    "fast n={n} a/ac={ratio}: {fast} vs {r} ({err:e})"
                );
            }
        }
    }

    #[test]
    fn jenkins_closed_form_equals_the_loop_and_masing_with_a_clamped_backbone() {
        // the Jenkins loop is the Masing loop of f = clamp(kd x, ±Fd)
        let clamp = PiecewiseLinearBackbone {
            slips: vec![(FD / KD, KD)],
        };
        for ratio in [0.5, 1.0, 1.01, 2.0, 10.0, 1000.0] {
            let a = ratio * FD / KD;
            let j = jenkins(KD, FD, a);
            let r = brute(|u| clamp.eval(u).0, a);
            assert!((j - r).norm() < 1e-7 * r.norm(), "a/ac={ratio}: {j} vs {r}");
            let q = loop_describing_function(&clamp, FD / KD, a, 8);
            assert!(
                (j - q).norm() < 1e-10 * j.norm(),
                "a/ac={ratio}: {j} vs {q}"
            );
        }
        // energy per cycle W = 4 Fd (a − a_c) = π a² Im N
        let a = 3.0 * FD / KD;
        let w = PI * a * a * jenkins(KD, FD, a).im;
        assert!((w / (4.0 * FD * (a - FD / KD)) - 1.0).abs() < 1e-14);
    }

    #[test]
    fn numeric_describing_function_matches_the_closed_forms() {
        let mut j = Jenkins::new(KD, FD).unwrap();
        let mut c = CubicStiffness { k3: 1e15 };
        for ratio in [0.5, 3.0, 20.0] {
            let a = ratio * FD / KD;
            let exact = jenkins(KD, FD, a);
            let num = numeric(&mut j, a, 1000.0, 8192);
            // AFT's error at the slip kinks falls as ~N⁻²: far below 1e-6 at
            // 8192 samples
            assert!(
                (num - exact).norm() < 1e-6 * exact.norm(),
                "{num} vs {exact}"
            );
            let cubic = numeric(&mut c, a, 1000.0, 64);
            let exact = Complex64::new(0.75 * 1e15 * a * a, 0.0);
            assert!((cubic - exact).norm() < 1e-12 * exact.norm());
        }
    }

    #[test]
    fn single_harmonic_solve_finds_all_three_duffing_amplitudes() {
        // m x'' + c x' + k x + k3 x³ = F cos ωt, single harmonic:
        // a² [(k − mω² + ¾ k3 a²)² + (cω)²] = F²
        let (m, c, k, k3, f) = (1.0, 0.1, 1.0, 0.5, 1.0);
        let w: f64 = 1.6;
        let h = Complex64::new(1.0, 0.0) / Complex64::new(k - m * w * w, c * w);
        let roots = solve(h, f, |a| Complex64::new(0.75 * k3 * a * a, 0.0));
        assert_eq!(roots.len(), 3, "{roots:?}");
        for x in &roots {
            let a = x.norm();
            let lhs = a * a * ((k - m * w * w + 0.75 * k3 * a * a).powi(2) + (c * w).powi(2));
            assert!((lhs / (f * f) - 1.0).abs() < 1e-10, "a={a}");
        }
        assert!(roots[0].norm() < roots[1].norm() && roots[1].norm() < roots[2].norm());
    }

    #[test]
    fn single_harmonic_solve_finds_two_roots_within_one_grid_step() {
        // paper SDOF + k3 = 4e12 at 172 Hz, F = 200 N: |X1| = 1.212e-4,
        // 7.060e-4 and 7.784e-4 m; the last two are 10 % apart
        let (m, c, k, k3, f) = (10.0, 200.0, 1e7, 4e12, 200.0);
        let w = 2.0 * PI * 172.0;
        let h = Complex64::new(1.0, 0.0) / Complex64::new(k - m * w * w, c * w);
        let roots = solve(h, f, |a| Complex64::new(0.75 * k3 * a * a, 0.0));
        assert_eq!(roots.len(), 3, "{roots:?}");
        for (x, expect) in roots.iter().zip([1.2123e-4, 7.0599e-4, 7.7839e-4]) {
            let a = x.norm();
            assert!((a / expect - 1.0).abs() < 1e-3, "{x}");
            let lhs = a * a * ((k - m * w * w + 0.75 * k3 * a * a).powi(2) + (c * w).powi(2));
            assert!((lhs / (f * f) - 1.0).abs() < 1e-10, "a={a}");
        }
    }

    #[test]
    fn bad_parameters_give_nan_not_a_panic() {
        assert!(jenkins(-1.0, FD, 1e-5).re.is_nan());
        assert!(jenkins(KD, f64::NAN, 1e-5).im.is_nan());
        assert!(masing(KD, FD, 0.0, 1e-5).re.is_nan());
        assert!(masing(KD, FD, 3.0, f64::INFINITY).re.is_nan());
    }

    #[test]
    fn brent_finds_a_root_to_tolerance() {
        let mut f = |x: f64| x * x * x - 2.0;
        let r = brent(&mut f, 0.0, 2.0, -2.0, 6.0, 1e-14).unwrap();
        assert!((r - 2f64.cbrt()).abs() < 1e-13);
        assert!(brent(&mut f, 0.0, 1.0, -2.0, -1.0, 1e-14).is_none());
    }
}
