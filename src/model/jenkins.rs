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
    Description, Element, ElementForce, ImplicitStep, Law, SLIP_FORCE, STICK_STIFFNESS, sign,
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

    #[inline]
    fn evaluate(&self, x: f64) -> (ElementForce, f64) {
        let stick = self.kd * (x - self.slider);
        if stick.abs() <= self.fd {
            (
                ElementForce {
                    force: stick,
                    stiffness: self.kd,
                    damping: 0.0,
                },
                self.slider,
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
        example: &[2.4e7, 246.048],
    };

    fn from_parameters(values: &[f64]) -> Result<Self> {
        Jenkins::new(values[0], values[1])
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
    fn trial(&self, x: f64, _v: f64) -> ElementForce {
        self.evaluate(x).0
    }

    #[inline]
    fn commit(&mut self, x: f64, _v: f64) -> ElementForce {
        let (f, slider) = self.evaluate(x);
        self.slider = slider;
        f
    }

    fn reset(&mut self) {
        self.slider = 0.0;
        self.slider_sensitivity.clear();
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
        if self.slider_sensitivity.len() != dx.len() {
            self.slider_sensitivity.clear();
            self.slider_sensitivity.resize(dx.len(), 0.0);
        }
        let (f, slider) = self.evaluate(x);
        if f.stiffness != 0.0 {
            for ((d, &a), &s) in df.iter_mut().zip(dx).zip(&self.slider_sensitivity) {
                *d += self.kd * (a - s);
            }
        } else {
            self.slider_sensitivity.copy_from_slice(dx);
        }
        self.slider = slider;
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
        if g.abs() <= self.fd {
            Some(s.force - g)
        } else {
            Some(s.force - sign(g) * self.fd)
        }
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
