//! The underlying linear system from one FRF (paper section 3: "estimated by
//! exciting the reference system with a large sinusoidal force"; method notes
//! f.2).
//!
//! The dynamic stiffness of an SDOF is linear in its parameters,
//! `1/H(ω) = k − mω² + jcω`, so a weighted linear least-squares fit of
//! `Re(1/H)` gives `k, m` and of `Im(1/H)/ω` gives `c`. The weights
//! `|H|⁴/σ²` make it the first-order equivalent of fitting `H` itself, whose
//! errors `σ` are what the measurement knows; a few Gauss–Newton steps on
//! `(H − 1/Z(θ))/σ` then remove the remaining bias. At the largest force level
//! the joint slips freely and this is the underlying linear system; at the
//! smallest it sticks and the stiffness is `k + kd` (the paper's initial-guess
//! rule `kd₀ = k_low − k`).

use crate::error::{Error, Result};
use crate::harmonics::{Quantity, omega};
use nalgebra::{Matrix3, Vector3};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// One measured FRF point for the linear fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrfSample {
    /// Frequency, Hz.
    pub frequency_hz: f64,
    /// FRF of `quantity` per force.
    pub h: Complex64,
    /// Standard error of `h` (RMS of the complex error); 0 if unknown.
    pub std_error: f64,
}

/// An SDOF fitted to one FRF.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SdofEstimate {
    /// kg.
    pub mass: f64,
    /// N s/m.
    pub damping: f64,
    /// N/m.
    pub stiffness: f64,
    /// RMS of `|H − H_fit|/|H|` over the points.
    pub relative_rms_residual: f64,
    /// Points used.
    pub points: usize,
    /// +1, or −1 for a transfer FRF whose modal constant is negative (the
    /// response moves against the drive below resonance): `H = sign/(k −
    /// mω² + jcω)` with `m, c, k` positive.
    #[serde(default = "plus_one")]
    pub sign: f64,
}

fn plus_one() -> f64 {
    1.0
}

impl SdofEstimate {
    /// Natural frequency, Hz.
    pub fn natural_frequency_hz(&self) -> f64 {
        (self.stiffness / self.mass).sqrt() / (2.0 * std::f64::consts::PI)
    }

    /// Damping ratio.
    pub fn damping_ratio(&self) -> f64 {
        self.damping / (2.0 * (self.stiffness * self.mass).sqrt())
    }
}

/// Fits `m, c, k` to FRF points of a motion `quantity` per force; `what`
/// names the data in errors (e.g. `level 30000 N`).
pub fn fit_sdof(samples: &[FrfSample], quantity: Quantity, what: &str) -> Result<SdofEstimate> {
    if !quantity.is_motion() {
        return Err(Error::input(
            what,
            format!("an FRF of a motion is needed, got {quantity}"),
        ));
    }
    if samples.len() < 3 {
        return Err(Error::input(
            what,
            format!(
                "at least 3 FRF points are needed for m, c, k, got {}",
                samples.len()
            ),
        ));
    }
    // to receptance
    let pts: Vec<(f64, Complex64, f64)> = samples
        .iter()
        .map(|s| {
            let w = omega(s.frequency_hz);
            let p = quantity.from_displacement(w);
            (w, s.h / p, s.std_error / p.norm())
        })
        .collect();
    for (i, (w, h, _)) in pts.iter().enumerate() {
        if !(w.is_finite() && *w > 0.0 && h.re.is_finite() && h.im.is_finite() && h.norm() > 0.0) {
            return Err(Error::input(
                format!("{what}, point {i}"),
                "FRF points must be finite, non-zero, at f > 0",
            ));
        }
    }
    let use_sigma = pts.iter().all(|p| p.2 > 0.0);
    // weighted linear least squares on the dynamic stiffness
    let (mut a, mut b) = (
        nalgebra::Matrix2::<f64>::zeros(),
        nalgebra::Vector2::<f64>::zeros(),
    );
    let (mut cc, mut cb) = (0.0, 0.0);
    for &(w, h, s) in &pts {
        let z = 1.0 / h;
        let wt = if use_sigma {
            h.norm_sqr().powi(2) / (s * s)
        } else {
            h.norm_sqr()
        };
        let row = nalgebra::Vector2::new(1.0, -w * w);
        a += wt * row * row.transpose();
        b += wt * row * z.re;
        cc += wt * w * w;
        cb += wt * w * z.im;
    }
    let km = a.lu().solve(&b).ok_or_else(|| {
        Error::input(
            what,
            "the FRF points do not determine k and m (all at one frequency?)",
        )
    })?;
    let mut theta = Vector3::new(km[0], km[1], cb / cc); // k, m, c
    // Gauss–Newton on (H − 1/Z)/σ
    for _ in 0..20 {
        let (mut jtj, mut jtr) = (Matrix3::<f64>::zeros(), Vector3::<f64>::zeros());
        for &(w, h, s) in &pts {
            let z = Complex64::new(theta[0] - theta[1] * w * w, theta[2] * w);
            let wt = if use_sigma { 1.0 / s } else { 1.0 / h.norm() };
            let r = (h - 1.0 / z) * wt;
            let d = -1.0 / (z * z) * wt; // ∂(1/Z)/∂Z, and ∂Z/∂(k, m, c) = (1, −ω², jω)
            let cols = [d, d * (-w * w), d * Complex64::new(0.0, w)];
            for i in 0..3 {
                for j in 0..3 {
                    jtj[(i, j)] += (cols[i].conj() * cols[j]).re;
                }
                jtr[i] += (cols[i].conj() * r).re;
            }
        }
        let Some(step) = jtj.lu().solve(&jtr) else {
            break;
        };
        theta += step;
        if step
            .iter()
            .zip(theta.iter())
            .all(|(s, t)| s.abs() <= 1e-12 * t.abs())
        {
            break;
        }
    }
    let (k, m, c) = (theta[0], theta[1], theta[2]);
    // a negative modal constant (a transfer FRF) flips every sign
    let sign = if k < 0.0 && m < 0.0 && c <= 0.0 {
        -1.0
    } else {
        1.0
    };
    let (k, m, c) = (sign * k, sign * m, sign * c);
    if !(k > 0.0 && m > 0.0 && c >= 0.0 && k.is_finite() && m.is_finite()) {
        return Err(Error::input(
            what,
            format!(
                "the FRF does not look like one damped mode in this band (fit gave m = {m:e} kg, c = {c:e} N s/m, k = {k:e} N/m)"
            ),
        ));
    }
    let rms = (pts
        .iter()
        .map(|&(w, h, _)| ((h - sign / Complex64::new(k - m * w * w, c * w)) / h).norm_sqr())
        .sum::<f64>()
        / pts.len() as f64)
        .sqrt();
    Ok(SdofEstimate {
        mass: m,
        damping: c,
        stiffness: k,
        relative_rms_residual: rms,
        points: pts.len(),
        sign,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    fn samples(m: f64, c: f64, k: f64, q: Quantity, noise: f64, seed: u64) -> Vec<FrfSample> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let n = Normal::new(0.0, 1.0).unwrap();
        (0..51)
            .map(|i| {
                let f = 100.0 + 5.0 * i as f64;
                let w = omega(f);
                let h = q.from_displacement(w) / Complex64::new(k - m * w * w, c * w);
                let s = noise * h.norm();
                let e = Complex64::new(n.sample(&mut rng), n.sample(&mut rng)) * (s / 2f64.sqrt());
                FrfSample {
                    frequency_hz: f,
                    h: h + e,
                    std_error: s,
                }
            })
            .collect()
    }

    #[test]
    fn recovers_an_exact_sdof_from_any_quantity() {
        for q in [
            Quantity::Displacement,
            Quantity::Velocity,
            Quantity::Acceleration,
        ] {
            let e = fit_sdof(&samples(10.0, 200.0, 1e7, q, 0.0, 1), q, "test").unwrap();
            assert!((e.mass / 10.0 - 1.0).abs() < 1e-9, "{q}: {e:?}");
            assert!((e.damping / 200.0 - 1.0).abs() < 1e-7, "{q}: {e:?}");
            assert!((e.stiffness / 1e7 - 1.0).abs() < 1e-9, "{q}: {e:?}");
        }
    }

    #[test]
    fn noisy_fit_is_within_a_few_standard_errors() {
        // 0.3 % complex noise per point, 51 points: the damping (set by ~5
        // points near resonance, 1 % damping) scatters by ~1 %, m and k by ~0.05 %
        let mut worst = [0.0f64; 3];
        for seed in 0..20 {
            let e = fit_sdof(
                &samples(10.0, 200.0, 1e7, Quantity::Displacement, 3e-3, seed),
                Quantity::Displacement,
                "t",
            )
            .unwrap();
            worst[0] = worst[0].max((e.mass / 10.0 - 1.0).abs());
            worst[1] = worst[1].max((e.damping / 200.0 - 1.0).abs());
            worst[2] = worst[2].max((e.stiffness / 1e7 - 1.0).abs());
        }
        assert!(
            worst[0] < 2e-3 && worst[2] < 2e-3 && worst[1] < 3e-2,
            "{worst:?}"
        );
    }

    #[test]
    fn a_negative_modal_constant_is_a_sign() {
        let mut s = samples(10.0, 200.0, 1e7, Quantity::Acceleration, 0.0, 1);
        s.iter_mut().for_each(|p| p.h = -p.h);
        let e = fit_sdof(&s, Quantity::Acceleration, "t").unwrap();
        assert_eq!(e.sign, -1.0);
        assert!((e.mass / 10.0 - 1.0).abs() < 1e-9 && (e.stiffness / 1e7 - 1.0).abs() < 1e-9);
    }

    #[test]
    fn garbage_is_an_error() {
        let mut s = samples(10.0, 200.0, 1e7, Quantity::Displacement, 0.0, 1);
        s[3].h = Complex64::new(f64::NAN, 0.0);
        assert!(
            fit_sdof(&s, Quantity::Displacement, "level 5 N")
                .unwrap_err()
                .to_string()
                .contains("level 5 N, point 3")
        );
        assert!(fit_sdof(&s[..2], Quantity::Displacement, "x").is_err());
        assert!(fit_sdof(&s, Quantity::Force, "x").is_err());
    }
}
