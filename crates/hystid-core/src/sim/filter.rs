//! Ramp-invariant second-order sections, one per mode.
//!
//! The ramp-invariant (first-order-hold) transform maps a continuous system to
//! a digital filter whose output equals, at the sample instants, the
//! continuous response to the piecewise-linear interpolation of the sampled
//! input (Ahlin, Magnevall & Josefsson, ISMA 2006; ABRAVIBE `timefresp.m`
//! and `fresppv.m`). Poles map exactly (`z = e^{pT}`), the static gain is
//! exact, and the only error is the known, system-independent amplitude
//! factor `sinc²(f/fs)` (plus sinc²-weighted aliases).
//!
//! Per complex pole `p` with residue `c` (for `c/(s − p)`):
//!
//! ```text
//! H_p(z) = c/(p²T) · [(e^{pT} − 1 − pT) + (1 − e^{pT} + pT e^{pT}) z⁻¹] / (1 − e^{pT} z⁻¹)
//! ```
//!
//! and the pole pair combines to `B/A = 2 Re(N conj(D)) / (D conj(D))`. The
//! same routine gives displacement (residue `c`), velocity (`c p`) and
//! acceleration (`c p²`, plus the direct term `1/m`, which is exact under the
//! ramp-invariant transform).

use crate::model::Mode;
use num_complex::Complex64;

/// A second-order section `y[n] = b0 u[n] + b1 u[n−1] + b2 u[n−2] − a1 y[n−1] − a2 y[n−2]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Section {
    /// Numerator `[b0, b1, b2]`.
    pub b: [f64; 3],
    /// Denominator `[a1, a2]` (`a0 = 1`).
    pub a: [f64; 2],
}

impl Section {
    /// The section's frequency response at normalised angular frequency
    /// `wt = ωT` (rad per sample).
    pub fn response(&self, wt: f64) -> Complex64 {
        let z1 = Complex64::from_polar(1.0, -wt);
        let z2 = z1 * z1;
        (self.b[0] + self.b[1] * z1 + self.b[2] * z2) / (1.0 + self.a[0] * z1 + self.a[1] * z2)
    }

    /// Static gain `Σb / Σa`.
    pub fn static_gain(&self) -> f64 {
        self.b.iter().sum::<f64>() / (1.0 + self.a[0] + self.a[1])
    }
}

/// A mode's three sections (displacement, velocity, acceleration per force),
/// sharing one denominator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModeFilter {
    /// Receptance section.
    pub displacement: Section,
    /// Mobility section.
    pub velocity: Section,
    /// Accelerance section.
    pub acceleration: Section,
}

/// `e^{z} − 1 − z`, accurate for small `|z|` (a series below 0.1, where the
/// direct form loses digits to cancellation).
fn expm1_minus_z(z: Complex64) -> Complex64 {
    if z.norm() < 0.1 {
        // Σ_{k≥2} z^k/k!; 16 terms leave < 1e-30 relative
        let mut term = z * z / 2.0;
        let mut sum = term;
        for k in 3..18 {
            term = term * z / k as f64;
            sum += term;
        }
        sum
    } else {
        z.exp() - 1.0 - z
    }
}

/// The real second-order section of `c/(s − p) + conj` under ramp invariance.
fn pole_pair_section(c: Complex64, p: Complex64, t: f64) -> Section {
    let pt = p * t;
    let e = pt.exp();
    let e1 = expm1_minus_z(pt); // e^{pT} − 1 − pT
    let g = c / (p * p * t);
    let n0 = g * e1;
    // 1 − e^{pT} + pT e^{pT} = (pT)² + (pT − 1)(e^{pT} − 1 − pT)
    let n1 = g * (pt * pt + (pt - 1.0) * e1);
    let ec = e.conj();
    // 2 Re( [n0, n1] * [1, −conj(e)] )
    let b = [2.0 * n0.re, 2.0 * (n1 - n0 * ec).re, 2.0 * (-n1 * ec).re];
    let a = [-2.0 * e.re, e.norm_sqr()];
    Section { b, a }
}

impl ModeFilter {
    /// The ramp-invariant filters of `mode` at sample interval `t` (s).
    pub fn new(mode: &Mode, t: f64) -> ModeFilter {
        let wn = mode.omega();
        let zeta = mode.damping_ratio;
        let wd = wn * (1.0 - zeta * zeta).sqrt();
        let p = Complex64::new(-zeta * wn, wd);
        // R/(s² + 2ζω s + ω²) = c/(s − p) + conj,  c = R/(p − p*) = R/(2jω_d)
        let c = Complex64::new(0.0, -mode.residue / (2.0 * wd));
        let displacement = pole_pair_section(c, p, t);
        let velocity = pole_pair_section(c * p, p, t);
        let mut acceleration = pole_pair_section(c * p * p, p, t);
        // s²H(s) = c p²/(s − p) + conj + R: the direct term passes unchanged,
        // B += R·A
        let r = mode.residue;
        acceleration.b[0] += r;
        acceleration.b[1] += r * acceleration.a[0];
        acceleration.b[2] += r * acceleration.a[1];
        ModeFilter {
            displacement,
            velocity,
            acceleration,
        }
    }

    /// The filters of `mode` taken quasi-static at sample interval `t`: its
    /// static flexibility `s = R/ω_r²` alone, for a mode far above every
    /// frequency the samples can carry.
    ///
    /// The displacement `s u[n]` is [`ModeFilter::new`]'s limit as
    /// `ω_r → ∞` at fixed `s` (the mode follows the piecewise-linear input
    /// at once). That limit's velocity, the slope of the sample just ended,
    /// lags by half a sample (15 % of the mode's part at 20 samples a
    /// period), and its acceleration is zero at the samples; a band-limited
    /// recording shows `s u̇` and `s ü`. So the velocity is the second-order
    /// backward difference `s (3u[n] − 4u[n−1] + u[n−2])/(2T)` (no lag; its
    /// gain `1 + θ²/3` at `θ = ωT` rad a sample), and the acceleration the
    /// second difference `s (u[n] − 2u[n−1] + u[n−2])/T²` (a sample's lag,
    /// the best three samples give). A lightly damped mode above the
    /// Nyquist frequency run through [`ModeFilter::new`] instead rings at
    /// its alias inside the band (its exact sampled response to the ramps),
    /// which a recording's anti-alias filter never shows.
    pub fn quasi_static(mode: &Mode, t: f64) -> ModeFilter {
        let s = mode.static_flexibility();
        ModeFilter {
            displacement: Section {
                b: [s, 0.0, 0.0],
                a: [0.0, 0.0],
            },
            velocity: Section {
                b: [1.5 * s / t, -2.0 * s / t, 0.5 * s / t],
                a: [0.0, 0.0],
            },
            acceleration: Section {
                b: [s / (t * t), -2.0 * s / (t * t), s / (t * t)],
                a: [0.0, 0.0],
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harmonics::{omega, sinc};

    fn irvine_displacement(m: f64, c: f64, k: f64, t: f64) -> [f64; 3] {
        // T. Irvine's closed-form real ramp-invariant coefficients ("Modal
        // Transient Analysis ... via a Ramp Invariant Digital Recursive
        // Filtering Relationship"), divided by m for a force input
        let wn = (k / m).sqrt();
        let z = c / (2.0 * (k * m).sqrt());
        let wd = wn * (1.0 - z * z).sqrt();
        let e = (-z * wn * t).exp();
        let (cc, s) = ((wd * t).cos(), (wd * t).sin());
        let d1 = wn / wd * (2.0 * z * z - 1.0);
        let den = m * wn.powi(3) * t;
        [
            (2.0 * z * (e * cc - 1.0) + d1 * e * s + wn * t) / den,
            (-2.0 * wn * t * e * cc + 2.0 * z * (1.0 - e * e) - 2.0 * d1 * e * s) / den,
            ((2.0 * z + wn * t) * e * e + d1 * e * s - 2.0 * z * e * cc) / den,
        ]
    }

    #[test]
    fn matches_the_closed_form_real_coefficients() {
        let (m, c, k) = (10.0, 200.0, 1e7);
        let mode = Mode::from_mck(m, c, k).unwrap();
        for fs in [5e3, 3e4, 1e5] {
            let f = ModeFilter::new(&mode, 1.0 / fs);
            let irv = irvine_displacement(m, c, k, 1.0 / fs);
            for i in 0..3 {
                assert!(
                    (f.displacement.b[i] / irv[i] - 1.0).abs() < 1e-9,
                    "fs={fs} b{i}"
                );
            }
        }
    }

    #[test]
    fn static_gain_is_exact_and_velocity_acceleration_have_none() {
        let mode = Mode::from_mck(10.0, 200.0, 1e7).unwrap();
        for fs in [2e3, 3e4, 1e6] {
            let f = ModeFilter::new(&mode, 1.0 / fs);
            assert!(
                (f.displacement.static_gain() * 1e7 - 1.0).abs() < 1e-10,
                "fs={fs}"
            );
            assert!(
                f.velocity.static_gain().abs() < 1e-9 * f.velocity.b[0].abs().max(1e-30) + 1e-15
            );
            assert!(f.acceleration.b.iter().sum::<f64>().abs() < 1e-12 * f.acceleration.b[0].abs());
        }
    }

    #[test]
    fn frequency_response_is_the_analytic_one_times_sinc_squared() {
        let (m, c, k) = (10.0, 200.0, 1e7);
        let mode = Mode::from_mck(m, c, k).unwrap();
        let fs = 3.0e4;
        let flt = ModeFilter::new(&mode, 1.0 / fs);
        for f in [20.0, 100.0, 159.0, 159.2, 300.0, 1000.0] {
            let w = omega(f);
            let h = mode.receptance(w);
            let hd = flt.displacement.response(w / fs);
            let exact = aliased(|w| mode.receptance(w), f, fs);
            assert!((hd / exact - 1.0).norm() < 1e-9, "f={f}: {hd} vs {exact}");
            // the aliases add (f/fs)^4-small terms: 1.4e-6 at f = fs/30
            assert!(
                (hd / (h * sinc(f / fs).powi(2)) - 1.0).norm() < 1e-5,
                "f={f}"
            );
        }
    }

    /// The quasi-static displacement is the exact filter's limit: a mode at
    /// 10⁴ times the sample rate, damped enough that each kink's transient
    /// dies within the sample, gives the same output to 1e-3 of its size
    /// on a random piecewise-linear input (the mode's lag `2ζ/ω_r` is 2e-5
    /// of a sample), and its acceleration is zero at the samples. The
    /// velocity and acceleration sections are the derivatives of a sine to
    /// their stated orders: `1 + θ²/3` and a sample's lag.
    #[test]
    fn a_quasi_static_mode_is_the_exact_filters_limit_far_above_the_rate() {
        let t = 1.0 / 16384.0;
        let mode = Mode::from_modal_mass(1e4 / t, 0.5, 2.5e-3).unwrap();
        let s = mode.static_flexibility();
        let (exact, limit) = (
            ModeFilter::new(&mode, t),
            ModeFilter::quasi_static(&mode, t),
        );
        let run = |f: &Section, u: &[f64]| {
            let mut y = vec![0.0; u.len()];
            for n in 0..u.len() {
                let at = |k: usize| if n >= k { u[n - k] } else { 0.0 };
                let past = |k: usize| if n >= k { y[n - k] } else { 0.0 };
                y[n] = f.b[0] * at(0) + f.b[1] * at(1) + f.b[2] * at(2)
                    - f.a[0] * past(1)
                    - f.a[1] * past(2);
            }
            y
        };
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
        let u: Vec<f64> = (0..2000).map(|_| rng.random_range(-0.5..0.5)).collect();
        let (ye, yl) = (run(&exact.displacement, &u), run(&limit.displacement, &u));
        let size = yl.iter().map(|v| v * v).sum::<f64>().sqrt();
        let diff = ye
            .iter()
            .zip(&yl)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(diff < 1e-3 * size, "{diff} of {size}");
        assert!((limit.displacement.static_gain() / s - 1.0).abs() < 1e-12);
        // the exact acceleration at the samples: zero to the rounding of
        // `R u − ω_r² x`, far below the second difference's `s u/T²`
        let peak = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let ya = run(&exact.acceleration, &u);
        assert!(
            peak(&ya) * t * t < 1e-3 * peak(&yl),
            "{}",
            peak(&ya) * t * t / peak(&yl)
        );
        // a sine of θ = 0.2 rad a sample: the velocity's gain 1 + θ²/3, no
        // lag; the acceleration's lag one sample
        for theta in [0.05, 0.2] {
            let w = theta / t;
            let v = limit.velocity.response(theta) / (s * Complex64::new(0.0, w));
            assert!(
                (v.norm() - (1.0 + theta * theta / 3.0)).abs() < 0.1 * theta * theta,
                "{v}"
            );
            assert!(v.arg().abs() < 0.1 * theta * theta, "{v}");
            let a = limit.acceleration.response(theta) / (-s * w * w);
            assert!((a.arg() + theta).abs() < 1e-12, "{a}");
            assert!((a.norm() - 1.0).abs() < theta * theta / 12.0 * 1.01, "{a}");
        }
        assert_eq!(limit.acceleration.b.iter().sum::<f64>(), 0.0);
    }

    /// Σ_k H(f + k fs) sinc²(f/fs + k): the exact response of a ramp-invariant filter.
    pub(crate) fn aliased(h: impl Fn(f64) -> Complex64, f: f64, fs: f64) -> Complex64 {
        let mut s = Complex64::new(0.0, 0.0);
        for k in -2000i32..=2000 {
            let fk = f + k as f64 * fs;
            s += h(omega(fk)) * sinc(fk / fs).powi(2);
        }
        s
    }
}
