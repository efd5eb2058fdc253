//! The Bouc-Wen hysteresis: a force `z` that follows the displacement with
//! a memory that fades gradually.
//!
//! Bouc (1967), Wen (1976), in the form of the nonlinearbenchmark.org
//! hysteretic benchmark (Noël & Schoukens 2016):
//! `m y'' + c y' + k y + z = u`,
//! `z' = α y' − β (γ |y'| |z|^(ν−1) z + δ y' |z|^ν)`.
//! Every term carries `y'`, so the law is rate-independent: along a
//! displacement that moves in direction `s = sign(Δy)`,
//!
//! `dz/dy = f_s(z) = α − β |z|^ν (γ s sign(z) + δ)`,
//!
//! and the element is a function of the displacement path alone, like the
//! other joint laws. The path between two committed samples is taken as
//! straight (what the digital-filter simulator assumes), and `z` is carried
//! along it by the exact flow for `ν = 1` (`f_s` is affine in `z` on either
//! side of `z = 0`: an exponential, split where `z` changes sign) and, for
//! other `ν`, along the law's universal curve (the `universal` module): on either
//! side of `z = 0` and in either direction the law is one equation
//! `dU/dψ = 1 ∓ U^ν` scaled, tabulated once per `ν` to rounding, so a step
//! costs two short polynomials however stiff it is (exponential
//! Rosenbrock–Euler sub-steps where the table ends: a stiffening side
//! driven far past its scale).
//!
//! `α` is the stiffness at a reversal from `z = 0`; `γ + δ > 0` softens on
//! loading towards the force `(α / (β (γ + δ)))^(1/ν)`, `γ + δ < 0` stiffens
//! (the benchmark: γ 0.8, δ −1.1). Unlike a Masing law, a loop does not
//! close on itself: after a change of amplitude the memory of the earlier
//! state decays over several cycles (by `exp(−β |γ ± δ| ∫|dy|)` for `ν = 1`),
//! so harmonic balance marches periods until the loop repeats
//! ([`Element::periods_to_settle`]).
//!
//! Sensitivities (for harmonic balance's Newton step) follow from the flow
//! being one-dimensional: `∫ dz / f_s(z) = Δy` gives `∂z₁ = f_s(z₁) (∂Δy +
//! ∂z₀ / f_s(z₀))`, exact to rounding along the exact flow and the
//! universal curves (to the sub-steps' accuracy where those take over).

use super::element::{
    Description, Domain, Element, ElementForce, FitScale, Law, ParameterInfo, Role, sign,
};
use crate::error::{Error, Result};
use std::cell::Cell;

mod universal;

/// Bouc-Wen parameters and state (see the module docs).
#[derive(Clone, Debug)]
pub struct BoucWen {
    alpha: f64,
    beta: f64,
    gamma: f64,
    delta: f64,
    nu: f64,
    /// The force at which the law's nonlinear term matches `α`,
    /// `(α / (β max(|γ + δ|, |γ − δ|)))^(1/ν)`: the scale a sub-step's
    /// change of `z` is measured against (the saturation force of a
    /// softening law).
    z_scale: f64,
    /// Last committed displacement, m.
    y: f64,
    /// Last committed force `z`, N.
    z: f64,
    /// Where the committed `z` lies on each region's universal curve, `ψ`
    /// (`NaN`: not yet known; found when a step first needs it, then kept).
    psi: Cell<[f64; 2]>,
    /// `dz/dy` at the committed `z` moving up and down (`NaN`: not yet
    /// known). A flow's end slope comes with it, so the next step's start
    /// slope costs nothing unless the direction turns.
    slopes: Cell<[f64; 2]>,
    /// The law on the loading (`s sign(z) > 0`) and unloading side (`ν ≠
    /// 1`).
    regions: Option<[Region; 2]>,
    /// `∂z/∂p` carried by [`Element::commit_sensitivity`] (empty: zero).
    z_sensitivity: Vec<f64>,
    /// `∂y/∂p` of the last committed sample.
    y_sensitivity: Vec<f64>,
    /// `z` and `∂z/∂p` when harmonic balance opened the period.
    period_z: f64,
    period_z_sensitivity: Vec<f64>,
    /// `∂z/∂z_open`: how the period's start still shows in `z`, tracked
    /// only while harmonic balance marches periods (not in the simulator).
    memory_gain: f64,
    period_open: bool,
    /// The last flow: its start `z₀` and step `h` (as bits) and its end.
    /// The simulator commits the point its last trial settled on, whose
    /// flow need not be run again (a flow is a function of `z₀` and `h`
    /// alone: the same bits either way).
    last_flow: Cell<Option<([u64; 2], FlowEnd)>>,
}

/// One side of the law (`ν ≠ 1`): `dz/dy = α − c |z|^ν` with `c = β (γ s
/// sign(z) + δ)` fixed, the universal curve `U_ε` scaled (see
/// [`universal`]).
#[derive(Clone, Debug)]
struct Region {
    /// `a = (α / |c|)^(1/ν)`: the force per unit `U`.
    a: f64,
    /// `α / a`: `ψ` per unit path length.
    rate: f64,
    /// `U_(sign c)`; `None` where `c = 0` (the side is linear, `dz/dy = α`).
    curve: Option<std::sync::Arc<universal::Universal>>,
}

/// The end of a flow: `z`, the slope `dz/dy` there in the flow's
/// direction, and where it lies on the universal curve (`region` 2: not
/// on one).
#[derive(Clone, Copy, Debug)]
struct FlowEnd {
    z: f64,
    slope: f64,
    region: usize,
    psi: f64,
}

impl FlowEnd {
    fn off_curve(z: f64, slope: f64) -> FlowEnd {
        FlowEnd {
            z,
            slope,
            region: 2,
            psi: f64::NAN,
        }
    }
}

/// Largest number of sub-steps per sample (`ν ≠ 1`).
const MAX_SUBSTEPS: usize = 1024;
/// Largest change of `z` per sub-step, as a share of `max(|z|, z_scale)`.
const SUBSTEP: f64 = 0.04;

impl BoucWen {
    /// A virgin element (`y = z = 0`).
    pub fn new(alpha: f64, beta: f64, gamma: f64, delta: f64, nu: f64) -> Result<BoucWen> {
        let spec = super::ElementSpec::BoucWen {
            alpha,
            beta,
            gamma,
            delta,
            nu,
        };
        spec.validate("joint")?;
        if !(gamma > 0.0 || delta <= gamma) {
            // the unloading slope α + β|z|^ν (γ − δ) would turn negative at
            // a large enough |z|, and z run away after a reversal
            return Err(Error::model(
                "joint.gamma",
                format!(
                    "must be > 0, or at least delta = {delta} (else the unloading stiffness turns negative), got {gamma}"
                ),
            ));
        }
        let shape = (gamma + delta).abs().max((gamma - delta).abs());
        let z_scale = if shape > 0.0 {
            (alpha / (beta * shape)).powf(1.0 / nu)
        } else {
            f64::INFINITY
        };
        Ok(BoucWen {
            alpha,
            beta,
            gamma,
            delta,
            nu,
            z_scale,
            y: 0.0,
            z: 0.0,
            psi: Cell::new([0.0; 2]),
            slopes: Cell::new([alpha; 2]),
            regions: (nu != 1.0).then(|| {
                [gamma + delta, delta - gamma].map(|w| {
                    let c = beta * w;
                    if c == 0.0 {
                        Region {
                            a: f64::INFINITY,
                            rate: 0.0,
                            curve: None,
                        }
                    } else {
                        let a = (alpha / c.abs()).powf(1.0 / nu);
                        Region {
                            a,
                            rate: alpha / a,
                            curve: Some(universal::curve(nu, c.signum())),
                        }
                    }
                })
            }),
            z_sensitivity: Vec::new(),
            y_sensitivity: Vec::new(),
            period_z: 0.0,
            period_z_sensitivity: Vec::new(),
            memory_gain: 1.0,
            period_open: false,
            last_flow: Cell::new(None),
        })
    }

    /// The committed force `z`, N.
    pub fn z(&self) -> f64 {
        self.z
    }

    /// `dz/dy` at `z` moving in direction `s` (±1).
    #[inline]
    pub fn slope(&self, z: f64, s: f64) -> f64 {
        self.slope_with(z, self.power(z.abs()), s)
    }

    /// `|z|^(ν−1)`: whole exponents (the usual 1, 2, 3) by multiplication,
    /// not `powf`; 0 at `z = 0` (where every use multiplies it by `|z|`).
    #[inline]
    fn power(&self, az: f64) -> f64 {
        if az == 0.0 {
            0.0
        } else if self.nu == 1.0 {
            1.0
        } else if self.nu == 2.0 {
            az
        } else if self.nu.fract() == 0.0 {
            az.powi(self.nu as i32 - 1)
        } else {
            az.powf(self.nu - 1.0)
        }
    }

    /// `dz/dy` at `z` moving in direction `s`, given `p = |z|^(ν−1)`.
    #[inline]
    fn slope_with(&self, z: f64, p: f64, s: f64) -> f64 {
        self.alpha - self.beta * p * z.abs() * (self.gamma * s * sign(z) + self.delta)
    }

    /// `z` carried from `z0` along a straight displacement step `h`.
    #[inline]
    pub fn flow(&self, z0: f64, h: f64) -> f64 {
        self.flow_end(z0, h, false).z
    }

    /// The flow from `z0` over `h ≠ 0` with its end slope: exact for `ν =
    /// 1`, along the universal curve otherwise (the sub-steps where the
    /// curve's table ends); the last one remembered. `committed`: `z0` is
    /// the committed `z`, whose `ψ` is kept.
    #[inline]
    fn flow_end(&self, z0: f64, h: f64, committed: bool) -> FlowEnd {
        if self.nu == 1.0 {
            let z = self.flow_exact(z0, h);
            return FlowEnd::off_curve(z, self.slope_with(z, 1.0, sign(h)));
        }
        // harmonic balance commits each sample once, with no trial before
        let remember = !self.period_open;
        let key = [z0.to_bits(), h.to_bits()];
        if remember
            && let Some((k, end)) = self.last_flow.get()
            && k == key
        {
            return end;
        }
        let end = self.flow_universal(z0, h, committed).unwrap_or_else(|| {
            let (z, p) = self.flow_substepped(z0, self.power(z0.abs()), h);
            FlowEnd::off_curve(z, self.slope_with(z, p, sign(h)))
        });
        if remember {
            self.last_flow.set(Some((key, end)));
        }
        end
    }

    /// The flow for `ν ≠ 1` along the universal curves: on the side of
    /// `z = 0` and in the direction it starts, `ψ` moves by `±ℓ α / a`
    /// (away from zero: up), and where it would pass `ψ = 0`, `z` has
    /// crossed zero and the rest of the step starts the other side's curve
    /// at its origin. `None` off the curves' tables (a stiffening side
    /// driven far, a softening one above its asymptote).
    fn flow_universal(&self, z0: f64, h: f64, committed: bool) -> Option<FlowEnd> {
        if !committed {
            return self.flow_universal_from(z0, h, None);
        }
        let mut known = self.psi.get();
        let end = self.flow_universal_from(z0, h, Some(&mut known));
        self.psi.set(known);
        end
    }

    /// [`BoucWen::flow_universal`] with the committed `z`'s `ψ` per region
    /// in `known` (`NaN`: not yet found; found when needed and kept there),
    /// or none when `z0` is not the committed `z`.
    #[inline(always)]
    fn flow_universal_from(
        &self,
        z0: f64,
        h: f64,
        mut known: Option<&mut [f64; 2]>,
    ) -> Option<FlowEnd> {
        let regions = self.regions.as_ref()?;
        let s = sign(h);
        let (mut z, mut left) = (z0, h.abs());
        for _ in 0..2 {
            let sigma = if z != 0.0 { sign(z) } else { s };
            let kappa = s * sigma;
            let r = if kappa > 0.0 { 0 } else { 1 };
            let region = &regions[r];
            let Some(curve) = &region.curve else {
                // a linear side: dz/dy = α
                let z1 = z + s * self.alpha * left;
                if z == 0.0 || z1 == 0.0 || sign(z1) == sigma {
                    return Some(FlowEnd::off_curve(z1, self.alpha));
                }
                left -= z.abs() / self.alpha;
                z = 0.0;
                continue;
            };
            let psi0 = match known.as_deref_mut() {
                _ if z == 0.0 => 0.0,
                Some(known) if z.to_bits() == z0.to_bits() => {
                    if known[r].is_nan() {
                        known[r] = curve.inverse(z.abs() / region.a)?;
                    }
                    known[r]
                }
                _ => curve.inverse(z.abs() / region.a)?,
            };
            let psi1 = psi0 + kappa * left * region.rate;
            if psi1 >= 0.0 {
                let (u, du) = curve.at(psi1)?;
                return Some(FlowEnd {
                    z: sigma * region.a * u,
                    slope: self.alpha * du,
                    region: r,
                    psi: psi1,
                });
            }
            // crossed zero: the path length it took
            left = (left - psi0 / region.rate).max(0.0);
            z = 0.0;
        }
        None
    }

    /// The exact flow for `ν = 1`: on either side of `z = 0`, `dz/dy = α −
    /// c z` with `c = β (γ s + δ σ)`, `σ = sign(z)`; at most one crossing
    /// of zero per step (there `dz/dy = α` pushes `z` the way `y` moves).
    fn flow_exact(&self, z0: f64, h: f64) -> f64 {
        let s = sign(h);
        let (mut z, mut h) = (z0, h);
        for _ in 0..2 {
            let sigma = if z != 0.0 { sign(z) } else { s };
            let c = self.beta * (self.gamma * s + self.delta * sigma);
            let ch = c * h;
            // e^{−ch} and (1 − e^{−ch}) / c: a short step (a sample of a
            // simulation) by their series, to rounding; else from one exp
            let (decay, phi) = if ch.abs() < 1e-2 {
                let phi1 = phi1_series(-ch);
                (1.0 - ch * phi1, h * phi1)
            } else {
                let e = (-ch).exp();
                (e, (1.0 - e) / c)
            };
            let z1 = z * decay + self.alpha * phi;
            if z1 == 0.0 || sign(z1) == sigma || z == 0.0 {
                return z1;
            }
            // crossed zero after the step h*: z e^{−ch*} + α (1 − e^{−ch*})/c = 0
            let q = c * z / self.alpha;
            let cross = if q.abs() < 1e-8 {
                -z / self.alpha * (1.0 + 0.5 * q)
            } else {
                (-q).ln_1p() / c
            };
            h -= cross;
            z = 0.0;
        }
        z
    }

    /// The flow for any `ν` by exponential Rosenbrock–Euler sub-steps (the
    /// step's exact solution of `dz/dy` linearised at its start: exact for
    /// an affine law and stable however stiff it is, so that at saturation,
    /// where `f_s → 0` fast, one sub-step carries `z` to rest), each
    /// Richardson-extrapolated from one step and two half steps (third
    /// order). A sub-step moves `z` by at most [`SUBSTEP`] of
    /// `max(|z|, z_scale)` and stops at `z = 0`, where `|z|^ν` and `sign(z)`
    /// change.
    fn flow_substepped(&self, z0: f64, p0: f64, h: f64) -> (f64, f64) {
        let s = sign(h);
        let (mut z, mut p, mut left) = (z0, p0, h.abs());
        // ν < 1: `|z|^ν` is steep at zero, shorter steps
        let share = SUBSTEP * self.nu.min(1.0).powi(2);
        for i in 0..MAX_SUBSTEPS {
            let (rate, jac) = self.rate_along(z, p, s);
            let mut dl = if i + 1 == MAX_SUBSTEPS || rate == 0.0 {
                left
            } else {
                left.min(share * z.abs().max(self.z_scale) / rate.abs())
            };
            // where the linearised law reaches zero: exact for ν = 1
            let zero_at = if z != 0.0 && rate * z < 0.0 {
                let q = -z * jac / rate;
                if q.abs() < 1e-8 {
                    -z / rate
                } else if q > -1.0 {
                    q.ln_1p() / jac
                } else {
                    f64::INFINITY
                }
            } else {
                f64::INFINITY
            };
            if zero_at <= dl {
                dl = zero_at;
                z = 0.0;
            } else {
                let full = ere_step(z, rate, jac, dl);
                let half = ere_step(z, rate, jac, 0.5 * dl);
                let (rate_h, jac_h) = self.rate_along(half, self.power(half.abs()), s);
                let two = ere_step(half, rate_h, jac_h, 0.5 * dl);
                let extrapolated = two + (two - full) / 3.0;
                // no extrapolation across zero, where the law has a kink
                z = if sign(extrapolated) == sign(two) && sign(half) == sign(two) {
                    extrapolated
                } else {
                    two
                };
            }
            left -= dl;
            p = self.power(z.abs());
            // a law run away (a stiffening shape driven far) is the model
            // point's failure, reported as such, not a reason to spin
            if left <= 0.0 || !z.is_finite() {
                break;
            }
        }
        (z, p)
    }

    /// `dz/dℓ = s f_s(z)` along the path length `ℓ` moving in direction
    /// `s`, and its slope in `z`, given `p1 = |z|^(ν−1)`.
    #[inline]
    fn rate_along(&self, z: f64, p1: f64, s: f64) -> (f64, f64) {
        let az = z.abs();
        if az == 0.0 {
            return (s * self.alpha, 0.0);
        }
        let sigma = sign(z);
        let w = self.gamma * s * sigma + self.delta;
        (
            s * (self.alpha - self.beta * p1 * az * w),
            -s * self.beta * self.nu * p1 * sigma * w,
        )
    }

    /// Classical RK4 steps of `dz/dy = f_s(z)` over `h`, each moving `z` by
    /// at most `share` of `max(|z|, 10⁻⁶ z_scale)` (graded towards zero,
    /// where `|z|^ν` is not smooth) and `|f_s′| ℓ` at most `20 share` (the
    /// stiff approach to saturation); within that tiny `|z|` of zero it
    /// crosses at the rate there. The reference the flows are tested
    /// against (a uniform step loses RK4's order where `z` crosses zero).
    #[cfg(test)]
    fn rk4_graded(&self, z0: f64, h: f64, share: f64) -> f64 {
        let s = sign(h);
        let (mut z, mut left) = (z0, h.abs());
        let tiny = 1e-6 * self.z_scale.min(self.alpha / self.beta);
        while left > 0.0 && z.is_finite() {
            let (rate, jac) = self.rate_along(z, self.power(z.abs()), s);
            // towards zero, within a tiny |z| of it: across, at the rate there
            if z != 0.0 && rate * z < 0.0 && z.abs() <= tiny {
                left -= z.abs() / rate.abs();
                z = 0.0;
                continue;
            }
            let dl = left
                .min(share * z.abs().max(tiny) / rate.abs().max(f64::MIN_POSITIVE))
                .min(20.0 * share / jac.abs().max(f64::MIN_POSITIVE));
            let f = |z: f64| s * self.slope(z, s);
            let k1 = f(z);
            let k2 = f(z + 0.5 * dl * k1);
            let k3 = f(z + 0.5 * dl * k2);
            let k4 = f(z + dl * k3);
            z += dl / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
            left -= dl;
        }
        z
    }

    /// The direction of a step to `x` (at rest: the velocity's, else up).
    #[inline]
    fn direction(&self, x: f64, v: f64) -> f64 {
        let h = x - self.y;
        if h != 0.0 { sign(h) } else { sign(v) }
    }

    /// `dz/dy` at the committed `z` moving in direction `s`.
    #[inline]
    fn committed_slope(&self, s: f64) -> f64 {
        if self.regions.is_none() {
            // ν = 1: no power to save
            return self.slope_with(self.z, 1.0, s);
        }
        let d = usize::from(s < 0.0);
        let mut known = self.slopes.get();
        if known[d].is_nan() {
            known[d] = self.slope(self.z, s);
            self.slopes.set(known);
        }
        known[d]
    }

    /// The force at `x` (from the committed state) and where the flow to it
    /// ended on the universal curves (`None`: `ν = 1`, or `x` is the
    /// committed displacement).
    #[inline(always)]
    fn evaluate(&self, x: f64, v: f64) -> (ElementForce, Option<FlowEnd>) {
        if self.regions.is_none() {
            (self.evaluate_exact(x, v), None)
        } else {
            self.evaluate_general(x, v)
        }
    }

    /// [`BoucWen::evaluate`] for `ν = 1`: the exact flow, nothing to keep.
    #[inline(always)]
    fn evaluate_exact(&self, x: f64, v: f64) -> ElementForce {
        let h = x - self.y;
        let z = if h == 0.0 {
            self.z
        } else {
            self.flow_exact(self.z, h)
        };
        ElementForce {
            force: z,
            stiffness: self.slope_with(z, 1.0, self.direction(x, v)),
            damping: 0.0,
        }
    }

    /// [`BoucWen::evaluate`] for `ν ≠ 1`.
    #[inline]
    fn evaluate_general(&self, x: f64, v: f64) -> (ElementForce, Option<FlowEnd>) {
        let h = x - self.y;
        if h == 0.0 {
            let f = ElementForce {
                force: self.z,
                stiffness: self.committed_slope(self.direction(x, v)),
                damping: 0.0,
            };
            return (f, None);
        }
        let e = self.flow_end(self.z, h, true);
        let f = ElementForce {
            force: e.z,
            stiffness: e.slope,
            damping: 0.0,
        };
        (f, Some(e))
    }

    /// Commits the force `f` at `x`, reached by a flow in direction `s`
    /// that ended at `end` on the universal curves.
    #[inline]
    fn settle(&mut self, x: f64, s: f64, f: &ElementForce, end: Option<FlowEnd>) {
        self.y = x;
        self.z = f.force;
        if let Some(e) = end {
            let mut psi = [f64::NAN; 2];
            if e.region < 2 {
                psi[e.region] = e.psi;
            }
            self.psi.set(psi);
            let mut slopes = [f64::NAN; 2];
            slopes[usize::from(s < 0.0)] = e.slope;
            self.slopes.set(slopes);
        }
    }

    /// `z` set from outside a flow: what was kept about it is forgotten.
    fn set_z(&mut self, z: f64) {
        self.z = z;
        self.psi.set([f64::NAN; 2]);
        self.slopes.set([f64::NAN; 2]);
    }
}

impl Law for BoucWen {
    const DESCRIPTION: Description = Description {
        name: "bouc_wen",
        summary: "the Bouc-Wen hysteresis z' = alpha y' - beta (gamma |y'| |z|^(nu-1) z + delta y' |z|^nu)",
        parameters: &[
            ParameterInfo {
                name: "alpha",
                unit: "N/m",
                meaning: "stiffness at a reversal from z = 0",
                domain: Domain::Positive,
                scale: FitScale::Log,
                role: Role::StickStiffness,
                start: 1.0,
            },
            ParameterInfo {
                name: "beta",
                unit: "N^(1-nu)/m",
                meaning: "rate at which the loop's memory fades",
                domain: Domain::Positive,
                scale: FitScale::Log,
                role: Role::Gauge,
                start: 1.0,
            },
            ParameterInfo {
                name: "gamma",
                unit: "1",
                meaning: "shape: loading/unloading asymmetry",
                domain: Domain::Signed,
                scale: FitScale::Linear,
                role: Role::Other,
                start: 0.5,
            },
            ParameterInfo {
                name: "delta",
                unit: "1",
                meaning: "shape: softening (> 0) or stiffening (< 0)",
                domain: Domain::Signed,
                scale: FitScale::Linear,
                role: Role::Other,
                start: 0.5,
            },
            ParameterInfo {
                name: "nu",
                unit: "1",
                meaning: "smoothness of the transition",
                domain: Domain::Range {
                    min: 0.5,
                    max: 20.0,
                },
                scale: FitScale::Reciprocal {
                    min: 0.5,
                    max: 20.0,
                },
                role: Role::Other,
                start: 1.0,
            },
        ],
        memory: true,
        odd: true,
        samples_per_period: 256,
        smooth_samples: None,
        // softening to z_max = α/(β(γ+δ)) = 240 N at the paper's scale
        example: &[2.4e7, 1e5, 0.5, 0.5, 1.0],
    };

    fn from_parameters(values: &[f64]) -> Result<Self> {
        BoucWen::new(values[0], values[1], values[2], values[3], values[4])
    }
}

impl Element for BoucWen {
    #[inline]
    fn trial(&self, x: f64, v: f64) -> ElementForce {
        self.evaluate(x, v).0
    }

    #[inline]
    fn commit(&mut self, x: f64, v: f64) -> ElementForce {
        if self.regions.is_none() && !self.period_open {
            // ν = 1 in a simulation: the exact flow, nothing else to keep
            let f = self.evaluate_exact(x, v);
            self.y = x;
            self.z = f.force;
            return f;
        }
        let s = self.direction(x, v);
        let (f, end) = if self.period_open {
            let f0 = self.committed_slope(s);
            let (f, end) = self.evaluate(x, v);
            self.memory_gain *= flow_ratio(f0, f.stiffness, self.alpha);
            (f, end)
        } else {
            self.evaluate(x, v)
        };
        self.settle(x, s, &f, end);
        f
    }

    /// Harmonic balance's march along the universal curves (`ν ≠ 1`, a
    /// period open) with the committed state in locals: the same steps, to
    /// the bit, as [`Element::commit`] sample by sample, without its cells'
    /// round trips per sample.
    fn commit_run(&mut self, x: &[f64], v: &[f64], g: &mut [f64]) {
        if !(self.period_open && self.regions.is_some()) {
            for ((&x, &v), g) in x.iter().zip(v).zip(g) {
                *g += self.commit(x, v).force;
            }
            return;
        }
        let (mut y, mut z, mut gain) = (self.y, self.z, self.memory_gain);
        let (mut psi, mut slopes) = (self.psi.get(), self.slopes.get());
        for ((&x, &v), g) in x.iter().zip(v).zip(g) {
            let h = x - y;
            let s = if h != 0.0 { sign(h) } else { sign(v) };
            let d = usize::from(s < 0.0);
            if slopes[d].is_nan() {
                slopes[d] = self.slope(z, s);
            }
            let f0 = slopes[d];
            y = x;
            if h == 0.0 {
                // the committed force and slope
                gain *= flow_ratio(f0, f0, self.alpha);
                *g += z;
                continue;
            }
            let end = self
                .flow_universal_from(z, h, Some(&mut psi))
                .unwrap_or_else(|| {
                    let (z1, p) = self.flow_substepped(z, self.power(z.abs()), h);
                    FlowEnd::off_curve(z1, self.slope_with(z1, p, s))
                });
            gain *= flow_ratio(f0, end.slope, self.alpha);
            z = end.z;
            psi = [f64::NAN; 2];
            if end.region < 2 {
                psi[end.region] = end.psi;
            }
            slopes = [f64::NAN; 2];
            slopes[d] = end.slope;
            *g += z;
        }
        self.y = y;
        self.z = z;
        self.memory_gain = gain;
        self.psi.set(psi);
        self.slopes.set(slopes);
    }

    fn reset(&mut self) {
        self.y = 0.0;
        self.z = 0.0;
        self.psi.set([0.0; 2]);
        self.slopes.set([self.alpha; 2]);
        self.z_sensitivity.clear();
        self.y_sensitivity.clear();
        self.period_z_sensitivity.clear();
        self.memory_gain = 1.0;
        self.period_open = false;
    }

    fn has_memory(&self) -> bool {
        Self::DESCRIPTION.memory
    }

    fn odd_law(&self) -> bool {
        Self::DESCRIPTION.odd
    }

    fn periods_to_settle(&self) -> usize {
        PERIODS_TO_SETTLE
    }

    fn open_period(&mut self) {
        self.period_open = true;
        self.period_z = self.z;
        self.period_z_sensitivity.clone_from(&self.z_sensitivity);
        self.memory_gain = 1.0;
    }

    /// The period map `z_open → z_close` has slope `g` = `memory_gain`, so
    /// its fixed point is `z_open + (z_close − z_open)/(1 − g)`; the carried
    /// sensitivities obey `d = g d + b` with `b = d_close − g d_open`, fixed
    /// at `b/(1 − g)`. Over half a period (`mirror`) the periodic state is
    /// the one the half period carries into its own negative: `z_close =
    /// −z_open`, fixed at `z* = z_open − (z_close + z_open)/(1 + g)` and
    /// `d* = −b/(1 + g)`; the element, now at the mirrored point, takes
    /// `−z*` and `−d*`. Exact when the map is affine (a nearly linear loop:
    /// where plain repetition is slowest), a Newton step otherwise.
    fn close_period(&mut self, mirror: bool) -> f64 {
        let g = self.memory_gain;
        self.memory_gain = 1.0;
        let (residual, k) = if mirror {
            ((self.z + self.period_z).abs(), 1.0 / (1.0 + g))
        } else {
            ((self.z - self.period_z).abs(), 1.0 / (1.0 - g))
        };
        // g ≥ 0 along a monotone flow; a whole period's step needs g < 1
        // (its 1/(1 − g) blows up where the loop is nearly elastic), half a
        // period's 1/(1 + g) does not: there plain repetition would swing
        // between z and −z for ever
        if !(g.is_finite() && g >= 0.0 && (mirror || g < 0.999_999)) {
            return residual;
        }
        self.set_z(if mirror {
            (self.z + self.period_z) * k - self.period_z
        } else {
            self.period_z + (self.z - self.period_z) * k
        });
        if self.period_z_sensitivity.len() == self.z_sensitivity.len() {
            for (d, &d0) in self
                .z_sensitivity
                .iter_mut()
                .zip(&self.period_z_sensitivity)
            {
                *d = (*d - g * d0) * k;
            }
        }
        residual
    }

    /// The tip memory `z*` of the symmetric loop between `±x` whose half
    /// cycles are monotone: the half cycle to `−x` carries it into `−z*`,
    /// `φ(z) = flow(z, −2x) + z = 0`, solved by Newton's method (`φ' = 1 +
    /// ∂flow/∂z ≥ 1`, so `φ` is increasing and has one root). Its
    /// sensitivity follows from `∂φ/∂x = −2 f(z₁)`: `∂z* = 2 f(z₁) / (1 +
    /// ∂flow/∂z) ∂x`, with `∂x` the tip's, which the ramp left in
    /// `y_sensitivity`. Where Newton's method does not settle (a law run
    /// away), the ramp's memory is kept.
    fn start_symmetric_loop(&mut self, x: f64) {
        let h = -2.0 * x;
        if h == 0.0 {
            return;
        }
        let s = sign(h);
        let mut z = self.z;
        for _ in 0..SYMMETRIC_LOOP_ITERATIONS {
            let end = self.flow_end(z, h, false);
            let (z1, f1) = (end.z, end.slope);
            let gain = flow_ratio(self.slope(z, s), f1, self.alpha);
            let step = (z1 + z) / (1.0 + gain);
            if !step.is_finite() {
                return;
            }
            z -= step;
            if step.abs() <= 1e-13 * z.abs() {
                self.set_z(z);
                let dz = 2.0 * f1 / (1.0 + gain);
                for (d, &dy) in self.z_sensitivity.iter_mut().zip(&self.y_sensitivity) {
                    *d = dz * dy;
                }
                return;
            }
        }
    }

    /// `∂z₁ = f_s(z₁) (∂y₁ − ∂y₀ + ∂z₀ / f_s(z₀))` (module docs), with the
    /// step's direction held.
    fn commit_sensitivity(
        &mut self,
        x: f64,
        v: f64,
        dx: &[f64],
        _dv: &[f64],
        df: &mut [f64],
    ) -> ElementForce {
        let n = dx.len();
        if self.z_sensitivity.len() != n {
            self.z_sensitivity.clear();
            self.z_sensitivity.resize(n, 0.0);
            self.y_sensitivity.clear();
            self.y_sensitivity.resize(n, 0.0);
        }
        let s = self.direction(x, v);
        let f0 = self.committed_slope(s);
        let (f, end) = self.evaluate(x, v);
        let f1 = f.stiffness;
        let ratio = flow_ratio(f0, f1, self.alpha);
        self.memory_gain *= ratio;
        for k in 0..n {
            let dz = ratio * self.z_sensitivity[k] + f1 * (dx[k] - self.y_sensitivity[k]);
            self.z_sensitivity[k] = dz;
            self.y_sensitivity[k] = dx[k];
            df[k] += dz;
        }
        self.settle(x, s, &f, end);
        f
    }
}

/// One exponential Rosenbrock–Euler step of length `dl` from `z`, where
/// `dz/dℓ = rate` with slope `jac`: `z + dl φ₁(jac dl) rate`,
/// `φ₁(x) = (eˣ − 1)/x`.
#[inline]
fn ere_step(z: f64, rate: f64, jac: f64, dl: f64) -> f64 {
    let x = jac * dl;
    let phi = if x.abs() < 1e-2 {
        phi1_series(x)
    } else {
        x.exp_m1() / x
    };
    z + dl * phi * rate
}

/// `φ₁(x) = (eˣ − 1)/x` for `|x| < 1e-2` by its series to `x⁵`: the
/// remainder `x⁶/5040 < 2e-16`, below rounding, without a transcendental.
#[inline]
fn phi1_series(x: f64) -> f64 {
    1.0 + x
        * (1.0 / 2.0 + x * (1.0 / 6.0 + x * (1.0 / 24.0 + x * (1.0 / 120.0 + x * (1.0 / 720.0)))))
}

/// `∂z₁/∂z₀ = f_s(z₁)/f_s(z₀)` of a step; an equilibrium of the flow
/// (`f_s(z₀) = 0`) stays one: 1.
#[inline]
fn flow_ratio(f0: f64, f1: f64, alpha: f64) -> f64 {
    if f0.abs() > 1e-12 * alpha {
        f1 / f0
    } else {
        1.0
    }
}

/// Newton iterations [`Element::start_symmetric_loop`] may take (a
/// monotone, nearly affine map: a few are enough).
const SYMMETRIC_LOOP_ITERATIONS: usize = 40;

/// Periods harmonic balance may march before the loop repeats. Left alone,
/// the memory fades by about `exp(−β |γ ± δ| · 4a)` per period, slowly at
/// small amplitude; with the Newton step of [`Element::close_period`] a few
/// periods do.
const PERIODS_TO_SETTLE: usize = 50;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::element::check::check_element;

    /// The benchmark's published parameters (Noël & Schoukens 2016).
    fn benchmark() -> BoucWen {
        BoucWen::new(5e4, 1e3, 0.8, -1.1, 1.0).unwrap()
    }

    #[test]
    fn passes_the_element_checker() {
        check_element(
            BoucWen::new(2.4e7, 1e5, 0.5, 0.5, 1.0).unwrap(),
            2e-5,
            246.0,
        );
        check_element(benchmark(), 1e-3, 50.0);
        check_element(
            BoucWen::new(2.4e7, 2.4e7 / 240.0 / 240.0, 0.5, 0.5, 2.0).unwrap(),
            2e-5,
            246.0,
        );
        // a fractional exponent, stiffer unloading than loading
        check_element(
            BoucWen::new(2.4e7, 2.4e7 / 240f64.powf(1.5), 0.8, -0.3, 1.5).unwrap(),
            2e-5,
            246.0,
        );
    }

    /// The exact flow against RK4 in fine steps (the same law, a second
    /// method), for ν = 1 on both sides of zero, loading and unloading, a
    /// softening and the benchmark's stiffening shape.
    #[test]
    fn exact_flow_equals_fine_rk4() {
        for e in [
            benchmark(),
            BoucWen::new(2.4e7, 1e5, 0.5, 0.5, 1.0).unwrap(),
        ] {
            let scale = e.alpha / e.beta;
            for z0 in [-0.5, -0.01, 0.0, 0.02, 0.7] {
                for h in [-3.0, -0.2, -1e-4, 1e-4, 0.3, 2.5] {
                    let (z0, h) = (z0 * scale, h / e.beta);
                    let exact = e.flow_exact(z0, h);
                    let z = e.rk4_graded(z0, h, 1e-3);
                    assert!(
                        (exact - z).abs() <= 1e-9 * (scale + z.abs()),
                        "z0 {z0} h {h}: exact {exact} vs RK4 {z}"
                    );
                    // the sub-steps (where the universal curves' tables end)
                    let g = e.flow_substepped(z0, e.power(z0.abs()), h).0;
                    assert!(
                        (g - z).abs() <= 1e-5 * (scale + z.abs()),
                        "z0 {z0} h {h}: flow_substepped {g} vs {z}"
                    );
                }
            }
        }
    }

    /// The flow for `ν ≠ 1` (along the universal curves) against RK4 in
    /// fine steps graded towards `z = 0` (where `|z|^ν` is not smooth),
    /// loading and unloading from either side of zero, across saturation,
    /// for softening, stiffening and linear sides (`γ = δ` unloads
    /// linearly): within 1e-10 of the law's force scale, or of `|z|` where
    /// it grows beyond, where the curves hold the step,
    /// and the sub-steps' 1e-4 where they do not (a stiffening side driven
    /// far past its scale).
    #[test]
    fn general_flow_equals_fine_rk4() {
        let (mut worst, mut worst_sub): (f64, f64) = (0.0, 0.0);
        let (mut on, mut off) = (0, 0);
        for nu in [0.55, 1.5, 2.0, 3.0, 8.0, 19.5] {
            for (gamma, delta) in [(0.5, 0.5), (0.3, 0.7), (0.8, -0.3), (0.6, 0.1), (0.3, -0.5)] {
                let (alpha, zc) = (2.4e7, 240.0f64);
                let beta = alpha / zc.powf(nu);
                let e = BoucWen::new(alpha, beta, gamma, delta, nu).unwrap();
                for z0 in [-0.9, -0.01, 0.0, 0.02, 0.6, 0.999] {
                    for h in [-8.0, -0.3, -1e-3, 1e-3, 1.0, 5.0] {
                        let (z0, h) = (z0 * zc, h * zc / alpha);
                        let z = e.rk4_graded(z0, h, 1e-3);
                        // a stiffening side run away (ν > 1 blows up at a
                        // finite displacement)
                        if !z.is_finite() || z.abs() >= 1e3 * zc {
                            continue;
                        }
                        let g = e.flow(z0, h);
                        let error = (g - z).abs() / z.abs().max(zc);
                        if e.flow_universal(z0, h, false).is_some() {
                            on += 1;
                            worst = worst.max(error);
                            assert!(
                                error <= 1e-10,
                                "nu {nu} gamma {gamma} delta {delta} z0 {z0} h {h}: {g} vs RK4 {z}"
                            );
                        } else {
                            off += 1;
                            worst_sub = worst_sub.max(error);
                            assert!(error <= 1e-4, "nu {nu} z0 {z0} h {h}: {g} vs RK4 {z}");
                        }
                    }
                }
            }
        }
        eprintln!(
            "{on} flows along the curves within {worst:.1e} of the force scale, {off} sub-stepped within {worst_sub:.1e}"
        );
        // both kinds are exercised
        assert!(off >= 1 && off * 10 < on, "{on} {off}");
    }

    /// A softening law saturates at `z_max = (α/(β(γ+δ)))^(1/ν)` on a long
    /// monotone load, for ν = 1 (exact flow) and ν = 2 (sub-stepped).
    #[test]
    fn softening_loading_saturates_at_the_closed_form() {
        for nu in [1.0, 2.0] {
            let (alpha, gamma, delta) = (2.4e7, 0.5, 0.5);
            let beta = alpha / 240f64.powf(nu);
            let mut e = BoucWen::new(alpha, beta, gamma, delta, nu).unwrap();
            let zmax = (alpha / (beta * (gamma + delta))).powf(1.0 / nu);
            let mut f = 0.0;
            for i in 1..=2000 {
                f = e.commit(i as f64 * 1e-7, 1.0).force;
            }
            assert!((f / zmax - 1.0).abs() < 1e-6, "nu {nu}: {f} vs {zmax}");
        }
    }

    /// The carried sensitivity equals a central difference of the committed
    /// force over a history that depends on a parameter.
    #[test]
    fn sensitivity_matches_a_difference() {
        for e0 in [
            benchmark(),
            BoucWen::new(2.4e7, 2.4e7 / 240.0 / 240.0, 0.5, 0.5, 2.0).unwrap(),
        ] {
            let scale = 3.0 * (e0.alpha / e0.beta).powf(1.0 / e0.nu) / e0.alpha;
            let path = |p: f64, i: usize| {
                let t = i as f64 / 50.0;
                scale * ((1.0 + p) * (2.1 * t).sin() + 0.4 * (5.3 * t).cos() - 0.4)
            };
            let dpath = |i: usize| {
                let t = i as f64 / 50.0;
                scale * (2.1 * t).sin()
            };
            let march = |p: f64| {
                let mut e = e0.clone();
                (0..400)
                    .map(|i| e.commit(path(p, i), 0.0).force)
                    .collect::<Vec<_>>()
            };
            let eps = 1e-6;
            let (up, down) = (march(eps), march(-eps));
            let mut e = e0.clone();
            for i in 0..400 {
                let mut df = [0.0];
                let f = e.commit_sensitivity(path(0.0, i), 0.0, &[dpath(i)], &[0.0], &mut df);
                let fd = (up[i] - down[i]) / (2.0 * eps);
                // exact flows: the difference's own error
                let rel = 1e-6;
                let tol = rel * (fd.abs() + f.force.abs().max(1.0));
                assert!(
                    (df[0] - fd).abs() <= tol,
                    "nu {} sample {i}: {} vs {fd}",
                    e0.nu,
                    df[0]
                );
            }
        }
    }

    /// The symmetric loop's tip memory, solved at once, is where plain
    /// repetition of the half cycles settles after many periods (a second
    /// method), for the benchmark's stiffening shape and softening shapes at
    /// ν = 1 and 2; its sensitivity to the tip equals a central difference.
    #[test]
    fn symmetric_loop_start_is_where_repetition_settles() {
        for (e0, amplitude) in [
            (benchmark(), 2e-3),
            (BoucWen::new(2.4e7, 1e5, 0.5, 0.5, 1.0).unwrap(), 2e-5),
            (
                BoucWen::new(2.4e7, 2.4e7 / 240.0 / 240.0, 0.5, 0.5, 2.0).unwrap(),
                2e-5,
            ),
        ] {
            // a sine sampled at its tips: monotone between them, so the
            // march sees exactly the loop's half cycles
            let mut e = e0.clone();
            let ns = 64;
            let mut tip = 0.0;
            for i in 0..400 * ns {
                let theta = 2.0 * std::f64::consts::PI * i as f64 / ns as f64;
                let f = e.commit(amplitude * theta.sin(), 0.0).force;
                if i % ns == ns / 4 {
                    tip = f;
                }
            }
            let start = |x: f64| {
                let mut e = e0.clone();
                let mut df = [0.0];
                e.commit_sensitivity(x, 0.0, &[1.0], &[0.0], &mut df);
                e.start_symmetric_loop(x);
                (e.z, e.z_sensitivity[0])
            };
            let (z, dz) = start(amplitude);
            // exact flows (general_flow_equals_fine_rk4)
            let tol = 1e-9;
            assert!(
                (z - tip).abs() <= tol * tip.abs(),
                "{e0:?}: {z} vs repetition's {tip}"
            );
            // the mirrored tip
            assert!((start(-amplitude).0 + z).abs() <= 1e-12 * z.abs());
            let eps = 1e-6 * amplitude;
            let fd = (start(amplitude + eps).0 - start(amplitude - eps).0) / (2.0 * eps);
            let tol = 1e-6;
            assert!(
                (dz - fd).abs() <= tol * fd.abs(),
                "nu {}: {dz} vs {fd}",
                e0.nu
            );
        }
    }

    #[test]
    fn unbounded_shapes_are_refused() {
        let e = BoucWen::new(5e4, 1e3, -1.5, 1.0, 1.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("joint.gamma"), "{e}");
        let e = BoucWen::new(5e4, 1e3, 0.8, -1.1, 0.1)
            .unwrap_err()
            .to_string();
        assert!(e.contains("joint.nu"), "{e}");
    }
}
