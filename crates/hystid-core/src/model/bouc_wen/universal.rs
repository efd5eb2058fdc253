//! The Bouc-Wen law's universal curve for one exponent `ν`: every flow of
//! the law is a stretch of it.
//!
//! Where the sign of `z` and the direction `s` of the displacement are
//! fixed, the law reads `dz/dy = α − c |z|^ν` with `c = β (γ s sign(z) +
//! δ)`. With `|z| = a u`, `a = (α / |c|)^(1/ν)` and `ψ` the path length in
//! units of `a / α` (signed: growing away from `z = 0`), every such flow is
//! the one curve
//!
//! `dU/dψ = 1 − ε U^ν`, `U(0) = 0`, `ε = sign(c)`,
//!
//! entered at `ψ₀ = U⁻¹(|z₀| / a)` and left at `ψ₀ ± ℓ α / a`. For `ν = 2`
//! it is `tanh ψ` (`ε = 1`) or `tan ψ` (`ε = −1`), for `ν = 1` an
//! exponential (the tests' closed forms); for most `ν` it has none, so it
//! is tabulated once per exponent, to rounding:
//!
//! * by Taylor polynomials of degree 10 about nodes, each node's
//!   coefficients from the equation itself: `(k + 1) a_(k+1) = [k = 0] − ε
//!   b_k`, `b = (Σ a_j t^j)^ν`, the power of a series by J.C.P. Miller's
//!   recurrence (Knuth, TAOCP vol. 2, 4.7);
//! * near `ψ = 0`, where `U^ν` is not smooth for a fractional `ν` (the
//!   series about `ψ` converge only to `ψ`), the nodes are graded: eight
//!   per octave, found from the bits of `ψ`, each started from the series
//!   in `q = ψ^ν`, `U = ψ Σ c_k q^k` (substituted into the equation, `(kν +
//!   1) c_k = −ε [q^(k−1)] (Σ c_j q^j)^ν`), down to where `ψ^ν` is below
//!   rounding and `U = ψ`;
//! * beyond the power of two where that series stops converging fast,
//!   evenly spaced, the next node reached by the longer series of the last;
//! * for `ε = 1` past `1 − U < 10⁻⁸`, where `1 − U` decays as `e^(−νψ)` to
//!   within `10⁻⁸` of itself, by that exponential.
//!
//! A flow then costs two polynomials (the curve and its slope, by Estrin's
//! scheme) where a sub-stepped flow takes tens of exponentials, and it is
//! exact to rounding, so harmonic balance's symmetric-loop start and its
//! sensitivities are exact for every `ν`.

use std::sync::{Arc, Mutex};

/// Degree of the polynomials kept per node (evaluated at most half a step
/// from their node, an eighth of the series' radius there: `16⁻¹¹ < 10⁻¹³`).
const DEGREE: usize = 10;
/// Degree of the series that carries one node to the next (a whole step:
/// `8⁻²¹ < 10⁻¹⁸`).
const PROPAGATION_DEGREE: usize = 20;
/// Terms of the series about `ψ = 0`.
const ZERO_TERMS: usize = 40;
/// The largest `q = ψ^ν` the series about zero is used to (below its
/// radius for every `ν` of the law's range; the terms left out are checked
/// at construction).
const ZERO_Q: f64 = 0.3;
/// Nodes per octave below `ψ_s` (a power of two: the sub-interval is read
/// from the mantissa's leading [`NEAR_BITS`] bits).
const NEAR_NODES: usize = 8;
/// `log2` of [`NEAR_NODES`].
const NEAR_BITS: u32 = 3;
/// `1 − U` where the softening curve hands over to its exponential tail.
const TAIL: f64 = 1e-8;
/// The stiffening curve (`ε = −1`) is tabulated to this `U` (beyond, the
/// caller's sub-steps take over: its growth outruns any fixed step).
const STIFFENING_MAX: f64 = 64.0;
/// Most nodes a curve holds.
const MAX_NODES: usize = 16_384;

/// The curves built so far, by `ν` and `ε`, the latest last: a fit moves
/// `ν` between evaluations, but the simulator, harmonic balance and the
/// replays build the same element many times (a curve takes 0.1-0.3 ms for
/// `ν ≥ 1.5`, a few for `ν = 0.5`).
static CURVES: Mutex<Vec<CachedCurve>> = Mutex::new(Vec::new());
/// A curve and its key, `ν`'s bits and whether `ε = 1`.
type CachedCurve = ((u64, bool), Arc<Universal>);
/// How many curves [`CURVES`] keeps.
const CACHED: usize = 16;

/// `U_ε` for `nu`, from [`CURVES`] or built (the same curve either way).
pub(super) fn curve(nu: f64, eps: f64) -> Arc<Universal> {
    let key = (nu.to_bits(), eps > 0.0);
    let mut cache = CURVES.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(i) = cache.iter().position(|(k, _)| *k == key) {
        let hit = cache.remove(i);
        let c = hit.1.clone();
        cache.push(hit);
        return c;
    }
    let c = Arc::new(Universal::new(nu, eps));
    if cache.len() == CACHED {
        cache.remove(0);
    }
    cache.push((key, c.clone()));
    c
}

/// `U_ε` for one `ν` (see the module docs).
#[derive(Clone, Debug)]
pub(super) struct Universal {
    nu: f64,
    eps: f64,
    /// Below `ψ_s = 2^e_s`: Taylor coefficients about the centres of
    /// [`NEAR_NODES`] equal parts of each octave, the top octave first,
    /// their derivatives' and the centres.
    near: Vec<[f64; DEGREE + 1]>,
    near_slopes: Vec<[f64; DEGREE + 1]>,
    near_centres: Vec<f64>,
    e_s: i32,
    /// Below it `U = ψ` to rounding.
    psi_min: f64,
    /// Where the evenly spaced nodes start.
    psi_s: f64,
    /// `U(ψ_s)`.
    u_s: f64,
    /// Node spacing and its inverse.
    h: f64,
    inv_h: f64,
    /// Taylor coefficients about node `i` at `ψ_s + i h`, low order first.
    nodes: Vec<[f64; DEGREE + 1]>,
    /// Their derivative's, `(k + 1) a_(k+1)` (padded with a zero).
    slopes: Vec<[f64; DEGREE + 1]>,
    /// Where the nodes end (`ψ` of the last node plus half a step) and `U`
    /// there.
    psi_end: f64,
    u_end: f64,
}

impl Universal {
    /// The curve for exponent `nu` (> 0) and sign `eps` (±1).
    pub fn new(nu: f64, eps: f64) -> Universal {
        let mut zero = vec![1.0];
        let mut power = vec![1.0];
        for k in 1..ZERO_TERMS {
            // power[k − 1] needs zero[..k]
            let c = -eps * power[k - 1] / (k as f64 * nu + 1.0);
            zero.push(c);
            power.push(miller_next(&zero, &power, nu));
        }
        // the series about zero to where its last terms fall below rounding
        let mut q_s = ZERO_Q;
        while q_s > 1e-3
            && zero[ZERO_TERMS - 4..]
                .iter()
                .enumerate()
                .any(|(j, c)| (c * q_s.powi((ZERO_TERMS - 4 + j) as i32)).abs() > 1e-17)
        {
            q_s *= 0.8;
        }
        // the terms that count there
        let terms = (0..ZERO_TERMS)
            .rposition(|k| (zero[k] * q_s.powi(k as i32)).abs() > 1e-17)
            .map_or(1, |k| k + 1);
        zero.truncate(terms);
        // the nodes take over at a power of two, 2^e_s, below which the
        // series about zero sets the graded nodes (see `near`)
        let e_s = q_s.powf(1.0 / nu).log2().floor() as i32;
        let psi_s = 2f64.powi(e_s);
        let series = |psi: f64| psi * horner(&zero, psi.powf(nu));
        let u_s = series(psi_s);
        // below ψ_s, nodes graded with ψ: NEAR_NODES per octave down to
        // where ψ^ν is below rounding (U = ψ there), each the series' value
        // expanded by the equation (the Taylor radius about ψ is ψ, so a
        // node spans a 16th of it either way)
        let mut octaves = 0;
        while octaves < 1100 && (2f64.powi(e_s - octaves).powf(nu) * zero[1]).abs() >= 1e-17 {
            octaves += 1;
        }
        let mut near = Vec::new();
        let mut near_slopes = Vec::new();
        let mut near_centres = Vec::new();
        let mut coefficients = [0.0; DEGREE + 1];
        for o in 0..octaves {
            let low = 2f64.powi(e_s - 1 - o);
            for m in 0..NEAR_NODES {
                let centre = low * (1.0 + (m as f64 + 0.5) / NEAR_NODES as f64);
                taylor(series(centre), nu, eps, &mut coefficients);
                near.push(coefficients);
                near_slopes.push(derivative(&coefficients));
                near_centres.push(centre);
            }
        }
        // the Taylor radius about a node is at least its distance to the
        // branch point at 0 (≥ ψ_s) and, as ν grows, the curve's corner
        // sharpens like 1/ν
        // (the stiffening curve's pole, for ν > 1, is approached in finer steps)
        let h = psi_s.min(1.0 / nu) / if eps > 0.0 { 8.0 } else { 32.0 };
        let mut nodes: Vec<[f64; DEGREE + 1]> = Vec::new();
        let mut u = u_s;
        let mut coefficients = [0.0; PROPAGATION_DEGREE + 1];
        loop {
            taylor(u, nu, eps, &mut coefficients);
            // the stiffening curve's pole (ν > 1) comes within the step's
            // reach: the table ends at the last node whose series converge
            let scale = u.max(1.0);
            if !nodes.is_empty()
                && ((coefficients[DEGREE] * (0.5 * h).powi(DEGREE as i32)).abs() > 1e-13 * scale
                    || (coefficients[PROPAGATION_DEGREE] * h.powi(PROPAGATION_DEGREE as i32)).abs()
                        > 1e-16 * scale)
            {
                break;
            }
            let mut kept = [0.0; DEGREE + 1];
            kept.copy_from_slice(&coefficients[..=DEGREE]);
            nodes.push(kept);
            let next = horner(&coefficients, h);
            let done = if eps > 0.0 {
                1.0 - next < TAIL
            } else {
                next > STIFFENING_MAX || !next.is_finite()
            };
            if done || nodes.len() == MAX_NODES {
                break;
            }
            u = next;
        }
        let last = nodes.len() - 1;
        let psi_end = psi_s + (last as f64 + 0.5) * h;
        let u_end = horner(&nodes[last], 0.5 * h);
        let slopes = nodes.iter().map(derivative).collect();
        Universal {
            nu,
            eps,
            near,
            near_slopes,
            near_centres,
            e_s,
            psi_min: 2f64.powi(e_s - octaves),
            slopes,
            psi_s,
            u_s,
            h,
            inv_h: 1.0 / h,
            nodes,
            psi_end,
            u_end,
        }
    }

    /// `U(ψ)` and `U′(ψ) = 1 − ε U^ν` for `ψ ≥ 0`; `None` past the
    /// stiffening curve's table.
    #[inline]
    pub fn at(&self, psi: f64) -> Option<(f64, f64)> {
        if psi < self.psi_s {
            if psi < self.psi_min {
                return Some((psi, 1.0));
            }
            // the octave below 2^e_s and the sub-interval, from the bits
            let bits = psi.to_bits();
            let e = ((bits >> 52) & 0x7ff) as i32 - 1023;
            let m = ((bits >> (52 - NEAR_BITS)) & (NEAR_NODES as u64 - 1)) as usize;
            let i = (self.e_s - 1 - e) as usize * NEAR_NODES + m;
            let t = psi - self.near_centres[i];
            return Some(value_and_slope(&self.near[i], &self.near_slopes[i], t));
        }
        if psi < self.psi_end {
            let x = (psi - self.psi_s) * self.inv_h;
            let i = (x + 0.5) as usize;
            let t = psi - (self.psi_s + i as f64 * self.h);
            let i = i.min(self.nodes.len() - 1);
            return Some(value_and_slope(&self.nodes[i], &self.slopes[i], t));
        }
        if self.eps > 0.0 {
            // 1 − U = (1 − U_end) e^(−ν(ψ − ψ_end)), U′ = 1 − U^ν ≈ ν (1 − U)
            let rest = (1.0 - self.u_end) * (-self.nu * (psi - self.psi_end)).exp();
            return Some((1.0 - rest, self.nu * rest));
        }
        None
    }

    /// `ψ` with `U(ψ) = u` (`u ≥ 0`); `None` at or past the softening
    /// curve's asymptote `U = 1` and past the stiffening curve's table.
    pub fn inverse(&self, u: f64) -> Option<f64> {
        if u.is_nan() || u < 0.0 {
            return None;
        }
        if u <= self.u_s {
            // ψ = ∫₀ᵘ dv / (1 − ε v^ν) = u Σ (ε u^ν)^k / (kν + 1)
            let r = self.eps * u.powf(self.nu);
            let (mut sum, mut term) = (0.0, 1.0);
            for k in 0..200 {
                let add = term / (k as f64 * self.nu + 1.0);
                sum += add;
                if add.abs() <= 1e-17 * sum.abs() {
                    break;
                }
                term *= r;
            }
            return Some(u * sum);
        }
        if u < self.u_end {
            // the node whose stretch holds u, then Newton on its polynomial
            let mut i = self.nodes.partition_point(|a| a[0] <= u).saturating_sub(1);
            if i + 1 < self.nodes.len() && u > horner(&self.nodes[i], 0.5 * self.h) {
                i += 1;
            }
            let (a, d) = (&self.nodes[i], &self.slopes[i]);
            let (lo, hi) = (-0.5 * self.h, 0.5 * self.h);
            let mut t = ((u - a[0]) / a[1]).clamp(lo, hi);
            for _ in 0..30 {
                let (p, dp) = value_and_slope(a, d, t);
                let step = (p - u) / dp;
                t = (t - step).clamp(lo, hi);
                if step.abs() <= 1e-16 * self.h {
                    break;
                }
            }
            return Some((self.psi_s + i as f64 * self.h + t).max(self.psi_s));
        }
        if self.eps > 0.0 && u < 1.0 {
            return Some(self.psi_end + ((1.0 - self.u_end) / (1.0 - u)).ln() / self.nu);
        }
        None
    }
}

/// The next coefficient of `B = A^ν` given `A`'s first `k + 1` and `B`'s
/// first `k` (`k = B.len()`): `b_k = Σ_{j=1..k} ((ν + 1) j − k) a_j
/// b_(k−j) / (k a₀)` (Miller).
fn miller_next(a: &[f64], b: &[f64], nu: f64) -> f64 {
    let k = b.len();
    let mut sum = 0.0;
    for j in 1..=k {
        sum += ((nu + 1.0) * j as f64 - k as f64) * a[j] * b[k - j];
    }
    sum / (k as f64 * a[0])
}

/// The Taylor coefficients of `U` about a point where `U = u > 0`, from
/// `(k + 1) a_(k+1) = [k = 0] − ε b_k`, `b = (Σ a_j t^j)^ν`.
fn taylor(u: f64, nu: f64, eps: f64, out: &mut [f64]) {
    let n = out.len();
    out[0] = u;
    let mut b = Vec::with_capacity(n);
    b.push(u.powf(nu));
    for k in 0..n - 1 {
        let one = if k == 0 { 1.0 } else { 0.0 };
        out[k + 1] = (one - eps * b[k]) / (k as f64 + 1.0);
        if k + 2 < n {
            let next = miller_next(&out[..k + 2], &b, nu);
            b.push(next);
        }
    }
}

const _: () = assert!(DEGREE == 10, "estrin is written for degree 10");

/// A node's polynomial and its derivative's at `t` from the node, the two
/// evaluated side by side.
#[inline(always)]
fn value_and_slope(a: &[f64; DEGREE + 1], d: &[f64; DEGREE + 1], t: f64) -> (f64, f64) {
    let t2 = t * t;
    let t4 = t2 * t2;
    let t8 = t4 * t4;
    (estrin(a, t, t2, t4, t8), estrin(d, t, t2, t4, t8))
}

/// `Σ a_k t^k` of degree [`DEGREE`] by Estrin's scheme, given `t²`, `t⁴`,
/// `t⁸`: a few multiplications deep instead of ten.
#[inline(always)]
fn estrin(a: &[f64; DEGREE + 1], t: f64, t2: f64, t4: f64, t8: f64) -> f64 {
    let p0 = a[0] + a[1] * t + (a[2] + a[3] * t) * t2;
    let p1 = a[4] + a[5] * t + (a[6] + a[7] * t) * t2;
    let p2 = a[8] + a[9] * t + a[10] * t2;
    p0 + p1 * t4 + p2 * t8
}

/// The coefficients of a polynomial's derivative, `(k + 1) a_(k+1)`
/// (padded with a zero).
fn derivative(a: &[f64; DEGREE + 1]) -> [f64; DEGREE + 1] {
    let mut d = [0.0; DEGREE + 1];
    for k in 0..DEGREE {
        d[k] = (k as f64 + 1.0) * a[k + 1];
    }
    d
}

/// `Σ c_k x^k`.
#[inline]
fn horner(c: &[f64], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &ck| acc * x + ck)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the closed forms: `ν = 2` gives `tanh ψ` and `tan ψ`, `ν = 1`
    /// gives `1 − e^(−ψ)` and `e^ψ − 1`; and each inverse returns its `ψ`.
    #[test]
    fn curves_equal_their_closed_forms() {
        // ν, ε, U, U′ and how far to check
        type Case = (f64, f64, fn(f64) -> f64, fn(f64) -> f64, f64);
        let cases: [Case; 4] = [
            (2.0, 1.0, f64::tanh, |p| 1.0 / p.cosh().powi(2), 30.0),
            (2.0, -1.0, f64::tan, |p| 1.0 / p.cos().powi(2), 1.5),
            (1.0, 1.0, |p| -(-p).exp_m1(), |p| (-p).exp(), 40.0),
            (1.0, -1.0, f64::exp_m1, f64::exp, 4.0),
        ];
        let mut worst: f64 = 0.0;
        for (nu, eps, u, du, top) in cases {
            let c = Universal::new(nu, eps);
            // evenly, then geometrically towards zero (the graded nodes)
            let grid = (0..=3000)
                .map(|i| top * (i as f64 / 3000.0).powi(2))
                .chain((0..400).map(|k| 0.7f64.powf(0.37 * k as f64)));
            for psi in grid {
                let Some((v, dv)) = c.at(psi) else {
                    assert!(eps < 0.0 && u(psi) > 2.0, "nu {nu} eps {eps} psi {psi}");
                    continue;
                };
                let (e, de) = ((v - u(psi)).abs(), (dv - du(psi)).abs());
                worst = worst.max(e / u(psi).max(1.0));
                assert!(
                    e <= 2e-14 * u(psi).max(1.0) && de <= 1e-12 * du(psi).max(1.0),
                    "nu {nu} eps {eps} psi {psi}: {v} vs {}, {dv} vs {}",
                    u(psi),
                    du(psi)
                );
                if eps < 0.0 || v < 1.0 - 1e-12 {
                    let back = c.inverse(v).unwrap();
                    assert!(
                        (back - psi).abs() <= 1e-12 * psi.max(1.0) / dv.min(1.0),
                        "nu {nu} eps {eps}: inverse of U({psi}) = {back}"
                    );
                }
            }
        }
        eprintln!("closed forms met within {worst:.1e}");
    }
}
