//! The Jenkins element: a spring `kd` in series with a Coulomb slider `Fd`.
//!
//! The paper's "stick-slip" reference element (section 3, Fig. 3.1). The
//! paper does not write out its law; a spring and slider is what
//! "stick-slip" and its `kd₀ = k_low − k` rule (stiffness `k + kd` at low
//! force) imply. In stick the force is `kd (x − x_s)` with `x_s` the slider's
//! position; when it would exceed `Fd` the slider moves and the force stays at
//! `±Fd`. Its loops are parallelograms with slopes `kd` and 0, the `N → ∞`
//! limit of the eq. (10) Masing element.

use super::element::{
    Description, Element, ElementForce, ImplicitStep, Law, SLIP_FORCE, STICK_STIFFNESS,
    SensitivityTerms, copy_short, sign,
};
use crate::error::{Result, require_positive};
use num_complex::Complex64;
use std::cell::Cell;
use std::f64::consts::PI;

/// Spring `kd` in series with a Coulomb slider of slip force `fd`.
#[derive(Clone, Debug)]
pub struct Jenkins {
    kd: f64,
    fd: f64,
    /// Committed slider position, m.
    slider: f64,
    /// `Fd/kd`, the slip displacement.
    xc: f64,
    /// `(bx, 1/(1 + bx kd))` of the last closed-form solve: `bx` is fixed for
    /// a simulator, so the division is done once.
    stick_gain: Cell<(f64, f64)>,
    /// `∂slider/∂p` carried by [`Element::commit_sensitivity`] (empty: zero).
    slider_sensitivity: Vec<f64>,
    /// Whether [`Element::commit_sensitivity_terms`] has stated the current
    /// `slider_sensitivity` as its memory term.
    slider_stated: bool,
    /// The simulator's sample interval (0: the law sampled as is, see
    /// [`Element::set_sample_interval`]).
    h: f64,
    /// The last committed sample: velocity, force, and the direction it
    /// slipped in (0: stuck).
    last_v: f64,
    last_force: f64,
    slip_dir: f64,
    /// See [`Element::kink_impulse`].
    impulse: f64,
}

impl Jenkins {
    /// A virgin element (slider at 0).
    pub fn new(kd: f64, fd: f64) -> Result<Jenkins> {
        require_positive("joint.kd", kd)?;
        require_positive("joint.fd", fd)?;
        Ok(Jenkins {
            kd,
            fd,
            slider: 0.0,
            xc: fd / kd,
            stick_gain: Cell::new((f64::NAN, f64::NAN)),
            slider_sensitivity: Vec::new(),
            slider_stated: false,
            h: 0.0,
            last_v: 0.0,
            last_force: 0.0,
            slip_dir: 0.0,
            impulse: 0.0,
        })
    }

    /// Stick stiffness, N/m.
    pub fn kd(&self) -> f64 {
        self.kd
    }

    /// Slip force, N.
    pub fn fd(&self) -> f64 {
        self.fd
    }

    /// The committed slider position, m.
    pub fn slider(&self) -> f64 {
        self.slider
    }

    /// Where the slider stands for a sample ending with velocity `v`, and
    /// its derivative in `v`: the committed position, unless the last sample
    /// slipped and the velocity reversed inside this one. The slider then
    /// slipped on to the displacement's extremum inside the sample, not to
    /// the last sample (an error of up to `|x''| h²/8`, held through the
    /// whole stick phase, whose size depends on where the reversal falls in
    /// the sample). The velocity taken linear over the sample vanishes at
    /// `τ = h v₀/(v₀ − v)`, where the displacement has gone `v₀ τ/2` further
    /// (exact to `O(h³)`).
    #[inline]
    fn slider_for(&self, v: f64) -> (f64, f64) {
        let v0 = self.last_v;
        if self.h > 0.0 && self.slip_dir * v0 > 0.0 && self.slip_dir * v < 0.0 {
            let dv = v0 - v;
            let tau = self.h * v0 / dv;
            (
                self.slider + 0.5 * v0 * tau,
                0.5 * self.h * v0 * v0 / (dv * dv),
            )
        } else {
            (self.slider, 0.0)
        }
    }

    /// The force at `(x, v)` and the slider position after it.
    #[inline]
    fn evaluate(&self, x: f64, v: f64) -> (ElementForce, f64) {
        let (slider, dslider_dv) = self.slider_for(v);
        let stick = self.kd * (x - slider);
        if stick.abs() <= self.fd {
            (
                ElementForce {
                    force: stick,
                    stiffness: self.kd,
                    damping: -self.kd * dslider_dv,
                },
                slider,
            )
        } else {
            let s = sign(stick);
            (
                ElementForce {
                    force: s * self.fd,
                    stiffness: 0.0,
                    damping: 0.0,
                },
                x - s * self.xc,
            )
        }
    }
}

impl Law for Jenkins {
    const DESCRIPTION: Description = Description {
        name: "jenkins",
        summary: "a spring kd in series with a Coulomb slider of slip force Fd",
        parameters: &[STICK_STIFFNESS, SLIP_FORCE],
        memory: true,
        odd: true,
        // the loop's corners are kinks: 512 samples a period put the
        // prediction's aliasing below the 10 % test's noise
        samples_per_period: 512,
        smooth_samples: None,
        example: &[2.4e7, 246.048],
    };

    fn from_parameters(values: &[f64]) -> Result<Self> {
        Jenkins::new(values[0], values[1])
    }
}

impl Jenkins {
    /// Commits `x` as harmonic balance's sampled law (no sample interval)
    /// and carries the slider's sensitivity: in slip the slider follows, so
    /// `∂x_s = ∂x`; in stick (the force's stiffness not 0) it is kept.
    #[inline]
    fn carry_slider(&mut self, x: f64, dx: &[f64]) -> ElementForce {
        if self.slider_sensitivity.len() != dx.len() {
            self.slider_sensitivity.clear();
            self.slider_sensitivity.resize(dx.len(), 0.0);
            self.slider_stated = false;
        }
        let (f, slider) = self.evaluate(x, 0.0);
        if f.stiffness == 0.0 {
            copy_short(&mut self.slider_sensitivity, dx);
            self.slider_stated = false;
        }
        self.slider = slider;
        f
    }
}

/// The Jenkins element's describing function (Caughey 1960).
///
/// `a ≤ Fd/kd`: `kd` (stick). Beyond, with `β = arccos(1 − 2a_c/a)`:
/// `Re N = (kd/π)(β − ½ sin 2β)`, `Im N = 4Fd(a − a_c)/(πa²)`.
///
/// NaN (both parts) unless `kd`, `fd` are finite and positive and the
/// amplitude finite.
pub fn describing_function(kd: f64, fd: f64, amplitude: f64) -> Complex64 {
    let valid = |p: f64| p.is_finite() && p > 0.0;
    if !(valid(kd) && valid(fd) && amplitude.is_finite()) {
        return Complex64::new(f64::NAN, f64::NAN);
    }
    let a = amplitude.abs();
    let ac = fd / kd;
    if a <= ac {
        return Complex64::new(kd, 0.0);
    }
    let beta = (1.0 - 2.0 * ac / a).clamp(-1.0, 1.0).acos();
    Complex64::new(
        kd / PI * (beta - 0.5 * (2.0 * beta).sin()),
        4.0 * fd * (a - ac) / (PI * a * a),
    )
}

impl Element for Jenkins {
    #[inline]
    fn trial(&self, x: f64, v: f64) -> ElementForce {
        self.evaluate(x, v).0
    }

    #[inline]
    fn commit(&mut self, x: f64, v: f64) -> ElementForce {
        let (f, slider) = self.evaluate(x, v);
        if self.h > 0.0 {
            let dir = if f.stiffness == 0.0 {
                sign(f.force)
            } else {
                0.0
            };
            // stick turned to slip inside the sample: the stick force,
            // linear in the sample's displacement, met ±Fd at τ and stayed
            // there, a kink the straight line from the last force cuts
            self.impulse = if dir != 0.0 && self.slip_dir == 0.0 {
                let rise = dir * self.fd - self.last_force;
                let trial = self.kd * (x - self.slider) - self.last_force;
                let tau = (rise / trial).clamp(0.0, 1.0);
                0.5 * self.h * rise * (1.0 - tau)
            } else {
                0.0
            };
            self.last_v = v;
            self.last_force = f.force;
            self.slip_dir = dir;
        }
        self.slider = slider;
        f
    }

    fn reset(&mut self) {
        self.slider = 0.0;
        self.slider_sensitivity.clear();
        self.slider_stated = false;
        self.last_v = 0.0;
        self.last_force = 0.0;
        self.slip_dir = 0.0;
        self.impulse = 0.0;
    }

    fn set_sample_interval(&mut self, h: f64) {
        self.h = if h.is_finite() && h > 0.0 { h } else { 0.0 };
    }

    #[inline]
    fn kink_impulse(&self) -> f64 {
        self.impulse
    }

    /// Stick: `g = kd (x − x_s)`, so `∂g = kd (∂x − ∂x_s)`; slip: `g = ±Fd`
    /// and the slider follows, `∂x_s = ∂x` (the chain rule NLvib's
    /// `HB_residual.m` uses for its Jenkins element).
    #[inline]
    fn commit_sensitivity(
        &mut self,
        x: f64,
        _v: f64,
        dx: &[f64],
        _dv: &[f64],
        df: &mut [f64],
    ) -> ElementForce {
        let f = self.carry_slider(x, dx);
        if f.stiffness != 0.0 {
            for ((d, &a), &s) in df.iter_mut().zip(dx).zip(&self.slider_sensitivity) {
                *d += self.kd * (a - s);
            }
        }
        f
    }

    fn memory_terms(&self) -> Option<usize> {
        Some(1)
    }

    /// [`Element::commit_sensitivity`]'s `kd (∂x − ∂x_s)` in stick: the
    /// tangent `kd` and one memory term, `−kd` times the slider's
    /// sensitivity, which changes only while it slips.
    #[inline]
    fn commit_sensitivity_terms(
        &mut self,
        x: f64,
        _v: f64,
        dx: &[f64],
        _dv: &[f64],
        terms: &mut SensitivityTerms,
    ) -> ElementForce {
        let f = self.carry_slider(x, dx);
        if f.stiffness != 0.0 {
            if !self.slider_stated {
                terms.replace(0, &self.slider_sensitivity);
                self.slider_stated = true;
            }
            terms.tangent(self.kd, 0.0);
            terms.coefficient(0, -self.kd);
        }
        f
    }

    fn has_memory(&self) -> bool {
        Self::DESCRIPTION.memory
    }

    fn odd_law(&self) -> bool {
        Self::DESCRIPTION.odd
    }

    fn describing_function(&mut self, amplitude: f64, _omega: f64, _samples: usize) -> Complex64 {
        describing_function(self.kd, self.fd, amplitude)
    }

    /// Closed form (the law is linear in stick and constant in slip, so no
    /// iteration): try stick, else slip in the direction the stick trial
    /// pushed.
    #[inline]
    fn solve_implicit(&self, s: &ImplicitStep) -> Option<f64> {
        // stick: x = x_p + bx (F − kd (x − x_s))
        let (bx, mut gain) = self.stick_gain.get();
        if bx != s.bx {
            gain = 1.0 / (1.0 + s.bx * self.kd);
            self.stick_gain.set((s.bx, gain));
        }
        let x = (s.x_pred + s.bx * (s.force + self.kd * self.slider)) * gain;
        let g = self.kd * (x - self.slider);
        let u = if g.abs() <= self.fd {
            s.force - g
        } else {
            s.force - sign(g) * self.fd
        };
        // a velocity reversed inside a sample that started slipping moves
        // the slider with the velocity (see `slider_for`): the simulator
        // iterates on `trial` for that sample
        if self.h > 0.0
            && self.slip_dir * self.last_v > 0.0
            && self.slip_dir * (s.v_pred + s.bv * u) < 0.0
        {
            return None;
        }
        Some(u)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::element::check::check_element;

    #[test]
    fn passes_the_element_checker() {
        check_element(Jenkins::new(2.4e7, 246.048).unwrap(), 2e-5, 246.0);
    }

    #[test]
    fn loop_is_a_parallelogram_with_the_closed_form_energy() {
        let (kd, fd) = (2.4e7, 246.048);
        let a = 3.0 * fd / kd;
        let mut e = Jenkins::new(kd, fd).unwrap();
        let n = 20000;
        let mut xs = Vec::new();
        let mut fs = Vec::new();
        for cycle in 0..2 {
            for i in 0..n {
                let x = a * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos();
                let f = e.commit(x, 0.0).force;
                if cycle == 1 {
                    xs.push(x);
                    fs.push(f);
                }
            }
        }
        // energy per cycle: ∮ g dx (trapezoid) against 4 Fd (a − Fd/kd)
        let mut w = 0.0;
        for i in 0..n {
            let j = (i + 1) % n;
            w += 0.5 * (fs[i] + fs[j]) * (xs[j] - xs[i]);
        }
        let exact = 4.0 * fd * (a - fd / kd);
        assert!((w.abs() / exact - 1.0).abs() < 1e-3, "{w} vs {exact}");
        assert!(fs.iter().all(|f| f.abs() <= fd * (1.0 + 1e-12)));
    }

    /// Stick turning to slip halfway through a sample of a straight
    /// displacement path: the force rises to Fd at τ = 1/2 and stays, a
    /// triangle of `h (Fd − g₀)(1 − τ)/2` above the chord; a reversal after
    /// slipping puts the slider at the extremum of the sample's path.
    #[test]
    fn transitions_inside_a_sample_are_placed() {
        let (kd, fd, h) = (2.0e7, 200.0, 1e-5);
        let mut e = Jenkins::new(kd, fd).unwrap();
        e.set_sample_interval(h);
        let x0 = 9.0 * fd / kd / 10.0; // 180 N, stuck
        e.commit(x0, 1.0);
        assert_eq!(e.kink_impulse(), 0.0);
        // the stick trial would reach 220 N: Fd is met halfway
        let f = e.commit(x0 + 2.0 * fd / kd / 10.0, 1.0);
        assert_eq!(f.force, fd);
        let area = 0.5 * h * 20.0 * 0.5;
        assert!(
            (e.kink_impulse() / area - 1.0).abs() < 1e-12,
            "{}",
            e.kink_impulse()
        );
        // slipping on: no kink
        let x2 = x0 + 4.0 * fd / kd / 10.0;
        e.commit(x2, 1.0);
        assert_eq!(e.kink_impulse(), 0.0);
        // the velocity reverses from 1 to -1 m/s: it vanished at h/2, where
        // the displacement had gone h/4 further, and the slider with it
        let x3 = x2 - 0.1 * h;
        let g = e.commit(x3, -1.0).force;
        let expected = kd * (x3 - (x2 + 0.25 * h - fd / kd));
        assert!((g / expected - 1.0).abs() < 1e-9, "{g} vs {expected}");
        // without a sample interval, the sampled law: the slider at x2
        let mut plain = Jenkins::new(kd, fd).unwrap();
        for (x, v) in [(x0, 1.0), (x0 + 2.0 * fd / kd / 10.0, 1.0), (x2, 1.0)] {
            plain.commit(x, v);
        }
        assert!((plain.commit(x3, -1.0).force - kd * (x3 - x2 + fd / kd)).abs() < 1e-9);
        assert_eq!(plain.kink_impulse(), 0.0);
    }

    #[test]
    fn implicit_closed_form_solves_the_equation() {
        let mut e = Jenkins::new(2.4e7, 246.048).unwrap();
        e.commit(2e-5, 0.0);
        for &(xp, f) in &[(1e-5, 10.0), (3e-5, 500.0), (-4e-5, -100.0), (1.9e-5, 0.0)] {
            let s = ImplicitStep {
                x_pred: xp,
                v_pred: 0.0,
                bx: 1e-7,
                bv: 0.0,
                force: f,
            };
            let u = e.solve_implicit(&s).unwrap();
            let x = xp + s.bx * u;
            let r = u - f + e.trial(x, 0.0).force;
            assert!(r.abs() < 1e-9 * (1.0 + f.abs()), "residual {r}");
        }
    }
}
