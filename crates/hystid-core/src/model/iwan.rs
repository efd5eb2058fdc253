//! Segalman's four-parameter Iwan element: a continuum of Jenkins elements
//! whose slip displacements `φ` follow a truncated power law plus a spike,
//! the law of bolted lap joints in microslip (Segalman 2005, "A
//! four-parameter Iwan model for lap-type joints", J. Appl. Mech. 72).
//!
//! The density of sliders over slip displacement is
//! `ρ(φ) = R φ^χ [H(φ) − H(φ − φ_max)] + S δ(φ − φ_max)`, named by what a test
//! sees: the joint's slip force `F_S`, its stick stiffness `K_T`, the
//! exponent `χ ∈ (−1, 0)` (energy per cycle grows as `A^(χ+3)` in
//! microslip) and `β = S/(R φ_max^(χ+1)/(χ+1))` (the spike's share). From
//! them `φ_max = F_S (1 + β) / (K_T (β + (χ+1)/(χ+2)))`,
//! `R = K_T (χ+1) / ((1+β) φ_max^(χ+1))` and `S = K_T β/(1+β)`.
//!
//! Under monotonic loading from the virgin state the sliders give the
//! backbone `f(u) = K_T u − R u^(χ+2)/((χ+1)(χ+2))` for `u < φ_max` and
//! `F_S` beyond (its slope falls from `K_T` to `S`, then to 0: a kink at
//! `φ_max`). An Iwan model obeys Masing's rules exactly, so the element is
//! the [`Masing`] element on this backbone: loops, inner loops and
//! wipe-out come from the same turning-point stack as the eq. (10) joint.

use super::element::{Description, Domain, FitScale, Law, ParameterInfo, Role, sign};
use super::masing::{Backbone, Masing};
use crate::error::{Error, Result};

/// The four-parameter Iwan backbone (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Iwan4Backbone {
    kt: f64,
    fs: f64,
    /// `χ + 1` and `χ + 2`.
    chi1: f64,
    chi2: f64,
    /// `R`, N/m^(χ+2).
    r: f64,
    /// `φ_max`, m.
    phi_max: f64,
    /// `(6 ε F_S / (R |χ| 2^(1−χ)))^(1/3)`: the Taylor radius at `u` is this
    /// times `u^((1−χ)/3)` (see [`Backbone::taylor_radius_at`]).
    radius_scale: f64,
}

/// A second-order expansion of the backbone errs by at most this share of
/// `F_S` (as the eq. (10) backbone's, `masing::PowerBackbone`).
const TAYLOR_TOLERANCE: f64 = 1e-13;

impl Iwan4Backbone {
    /// The backbone of slip force `fs`, stick stiffness `kt`, exponent
    /// `chi` in (−1, 0) and spike share `beta` ≥ 0.
    pub fn new(fs: f64, kt: f64, chi: f64, beta: f64) -> Result<Iwan4Backbone> {
        let ok = fs.is_finite()
            && fs > 0.0
            && kt.is_finite()
            && kt > 0.0
            && chi > -1.0
            && chi < 0.0
            && beta.is_finite()
            && beta >= 0.0;
        if !ok {
            return Err(Error::model(
                "iwan4",
                format!(
                    "needs fs > 0, kt > 0, -1 < chi < 0, beta >= 0; got fs = {fs}, kt = {kt}, chi = {chi}, beta = {beta}"
                ),
            ));
        }
        let (chi1, chi2) = (chi + 1.0, chi + 2.0);
        let phi_max = fs * (1.0 + beta) / (kt * (beta + chi1 / chi2));
        let r = kt * chi1 / ((1.0 + beta) * phi_max.powf(chi1));
        let radius_scale =
            (6.0 * TAYLOR_TOLERANCE * fs / (r * chi.abs() * 2f64.powf(1.0 - chi))).cbrt();
        Ok(Iwan4Backbone {
            kt,
            fs,
            chi1,
            chi2,
            r,
            phi_max,
            radius_scale,
        })
    }

    /// `φ_max`: the slip displacement of the last sliders (macroslip
    /// beyond it).
    pub fn phi_max(&self) -> f64 {
        self.phi_max
    }

    /// The density's `R`.
    pub fn r(&self) -> f64 {
        self.r
    }
}

impl Backbone for Iwan4Backbone {
    #[inline]
    fn eval(&self, x: f64) -> (f64, f64) {
        let (f, k, _) = self.eval_with_curvature(x);
        (f, k)
    }

    /// `f'' = −R u^χ` (odd in `x`), from the same power as `f` and `f'`.
    #[inline]
    fn eval_with_curvature(&self, x: f64) -> (f64, f64, f64) {
        let u = x.abs();
        if u >= self.phi_max {
            return (sign(x) * self.fs, 0.0, 0.0);
        }
        if u == 0.0 {
            return (0.0, self.kt, 0.0);
        }
        let p = u.powf(self.chi1); // u^(χ+1)
        let f = self.kt * u - self.r * p * u / (self.chi1 * self.chi2);
        let k = self.kt - self.r * p / self.chi1;
        (sign(x) * f, k, -sign(x) * self.r * p / u)
    }

    /// The largest `δ` whose quadratic expansion errs by at most
    /// [`TAYLOR_TOLERANCE`] of `F_S`: `|f'''| δ³/6` with `f''' = −Rχu^(χ−1)`,
    /// which grows toward the origin, taken at `u/2` (so `δ ≤ u/2`), and
    /// never across the kink at `φ_max`.
    fn taylor_radius(&self) -> f64 {
        self.phi_max
    }

    #[inline]
    fn taylor_radius_at(&self, x: f64) -> f64 {
        let u = x.abs();
        if u == 0.0 || u >= self.phi_max {
            return 0.0;
        }
        let reach = self.radius_scale * u.powf((1.0 - (self.chi1 - 1.0)) / 3.0);
        reach.min(0.5 * u).min(self.phi_max - u)
    }

    fn knee(&self) -> Option<f64> {
        Some(self.phi_max)
    }
}

impl Law for Masing<Iwan4Backbone> {
    const DESCRIPTION: Description = Description {
        name: "iwan4",
        summary: "Segalman's four-parameter Iwan element: a power-law continuum of Jenkins sliders with Masing's rules",
        parameters: &[
            ParameterInfo {
                name: "fs",
                unit: "N",
                meaning: "slip force (every slider slipping)",
                domain: Domain::Positive,
                scale: FitScale::Log,
                role: Role::SlipForce,
                start: 1.0,
            },
            ParameterInfo {
                name: "kt",
                unit: "N/m",
                meaning: "stick stiffness",
                domain: Domain::Positive,
                scale: FitScale::Log,
                role: Role::StickStiffness,
                start: 1.0,
            },
            ParameterInfo {
                name: "chi",
                unit: "1",
                meaning: "exponent of the slider density (energy per cycle ∝ A^(χ+3))",
                domain: Domain::Range {
                    min: -0.99,
                    max: -0.01,
                },
                scale: FitScale::Linear,
                role: Role::Other,
                start: -0.5,
            },
            ParameterInfo {
                name: "beta",
                unit: "1",
                meaning: "share of the sliders slipping last (the density's spike)",
                domain: Domain::NonNegative,
                scale: FitScale::Log,
                role: Role::Other,
                start: 0.5,
            },
        ],
        memory: true,
        odd: true,
        // the slope drops from S to 0 at φ_max: a corner, as the Jenkins
        // element's
        samples_per_period: 512,
        smooth_samples: None,
        example: &[246.048, 2.4e7, -0.5, 0.5],
    };

    fn from_parameters(values: &[f64]) -> Result<Self> {
        let b = Iwan4Backbone::new(values[0], values[1], values[2], values[3])?;
        Ok(Masing::with_backbone(b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Element;
    use crate::model::masing::PiecewiseLinearBackbone;

    const FS: f64 = 246.048;
    const KT: f64 = 2.4e7;

    /// The quadratic expansion the Masing element makes about an exact
    /// evaluation holds within its radius to the tolerance (1e-13 of `F_S`,
    /// and 2e-13 for the rounding of the forces compared), anywhere from
    /// microslip to the kink, for shapes from a uniform to a crowded
    /// density; the curvature is the tangent's derivative.
    #[test]
    fn taylor_expansion_holds_within_its_radius() {
        for (chi, beta) in [(-0.5, 0.5), (-0.05, 0.1), (-0.95, 2.0)] {
            let b = Iwan4Backbone::new(FS, KT, chi, beta).unwrap();
            let mut worst: f64 = 0.0;
            for i in 1..400 {
                let u0 = b.phi_max() * (i as f64 / 400.0).powi(3);
                for x0 in [u0, -u0] {
                    let (f0, k0, c0) = b.eval_with_curvature(x0);
                    let r = b.taylor_radius_at(x0);
                    assert!(r > 0.0 && r <= 0.5 * u0 && r <= b.phi_max() - u0);
                    for t in [-1.0, -0.5, 0.5, 1.0] {
                        let h = t * r;
                        let taylor = f0 + k0 * h + 0.5 * c0 * h * h;
                        worst = worst.max((taylor - b.eval(x0 + h).0).abs() / FS);
                    }
                    // (near the origin the tangent's difference is lost to
                    // the rounding of K_T)
                    if u0 > 1e-3 * b.phi_max() {
                        let d = 1e-4 * u0;
                        let fd = (b.eval(x0 + d).1 - b.eval(x0 - d).1) / (2.0 * d);
                        assert!((fd - c0).abs() <= 1e-5 * c0.abs(), "{fd} vs {c0}");
                    }
                }
            }
            eprintln!("chi {chi}: the expansion errs by {worst:.1e} F_S at most");
            assert!(worst < 2e-13, "chi {chi}: {worst}");
        }
    }

    /// The backbone is the slider integral `∫₀^u φρ dφ + u ∫_u^∞ ρ dφ`,
    /// done here by brute force over the density (a slow reference), and
    /// reaches `F_S` at `φ_max` with the slope `S` just before.
    #[test]
    fn backbone_is_the_slider_integral() {
        for (chi, beta) in [(-0.5, 0.5), (-0.2, 0.0), (-0.8, 3.0)] {
            let b = Iwan4Backbone::new(FS, KT, chi, beta).unwrap();
            let (r, phi_max) = (b.r(), b.phi_max());
            let s = KT * beta / (1.0 + beta);
            let n = 400_000;
            for frac in [0.01, 0.3, 0.77, 0.999] {
                let u = frac * phi_max;
                // midpoint rule in φ; the spike at φ_max adds S·u
                let mut f = s * u;
                let h = phi_max / n as f64;
                for i in 0..n {
                    let phi = (i as f64 + 0.5) * h;
                    f += r * phi.powf(chi) * h * phi.min(u);
                }
                let (g, _) = b.eval(u);
                assert!(
                    (g / f - 1.0).abs() < 2e-4,
                    "chi {chi} u/φmax {frac}: {g} vs {f}"
                );
            }
            assert!((b.eval(phi_max).0 / FS - 1.0).abs() < 1e-12);
            let (_, k) = b.eval(phi_max * (1.0 - 1e-12));
            assert!(
                (k - s).abs() <= 1e-6 * KT,
                "slope before the kink {k} vs S {s}"
            );
            // the tangent tends to K_T as u → 0, slowly: K_T − f'(u) =
            // K_T/(1+β) (u/φ_max)^(χ+1)
            let (_, k) = b.eval(1e-9 * phi_max);
            let gap = KT / (1.0 + beta) * 1e-9f64.powf(chi + 1.0);
            assert!(((KT - k) / gap - 1.0).abs() < 1e-6, "{k}");
        }
    }

    /// Segalman's microslip dissipation: a cycle of amplitude `A < φ_max`
    /// loses `D = 4R A^(χ+3)/((χ+2)(χ+3))` (closed form), measured as the
    /// area of the element's marched loop; and the same loop as a bank of
    /// 4000 discrete Jenkins sliders drawn from the density.
    #[test]
    fn microslip_dissipation_is_segalmans_power_law() {
        let (chi, beta) = (-0.5, 0.5);
        let mut e = Masing::with_backbone(Iwan4Backbone::new(FS, KT, chi, beta).unwrap());
        let b = Iwan4Backbone::new(FS, KT, chi, beta).unwrap();
        let (r, phi_max) = (b.r(), b.phi_max());
        // the discrete bank: sliders at the midpoints of 4000 slices, and
        // the spike
        let n = 4000;
        let h = phi_max / n as f64;
        let mut slips: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let phi = (i as f64 + 0.5) * h;
                let lo = i as f64 * h;
                let hi = lo + h;
                (
                    phi,
                    r * (hi.powf(chi + 1.0) - lo.powf(chi + 1.0)) / (chi + 1.0),
                )
            })
            .collect();
        slips.push((phi_max, KT * beta / (1.0 + beta)));
        let mut bank = Masing::with_backbone(PiecewiseLinearBackbone { slips });
        // ∮ g dx over the second whole cycle after a virgin ramp to +A: the
        // energy the structure loses to the element
        let area = |e: &mut dyn Element, a: f64| -> f64 {
            e.reset();
            let (ramp, m) = (10_000, 40_000);
            let (mut w, mut x0, mut f0) = (0.0, 0.0, 0.0);
            for i in 0..=(ramp + 2 * m) {
                let x = if i <= ramp {
                    a * i as f64 / ramp as f64
                } else {
                    a * (2.0 * std::f64::consts::PI * (i - ramp) as f64 / m as f64).cos()
                };
                let f = e.commit(x, 0.0).force;
                if i > ramp + m {
                    w += 0.5 * (f + f0) * (x - x0);
                }
                (x0, f0) = (x, f);
            }
            w
        };
        let mut last = None;
        for frac in [0.05, 0.2, 0.6] {
            let a = frac * phi_max;
            let closed = 4.0 * r * a.powf(chi + 3.0) / ((chi + 2.0) * (chi + 3.0));
            let marched = area(&mut e, a);
            let banked = area(&mut bank, a);
            assert!(
                (marched / closed - 1.0).abs() < 1e-3,
                "A/φmax {frac}: loop area {marched} vs {closed}"
            );
            assert!(
                (banked / closed - 1.0).abs() < 2e-2,
                "A/φmax {frac}: slider bank {banked} vs {closed}"
            );
            if let Some((a0, d0)) = last {
                let slope = f64::ln(marched / d0) / f64::ln(a / a0);
                assert!((slope - (chi + 3.0)).abs() < 1e-3, "slope {slope}");
            }
            last = Some((a, marched));
        }
    }
}
