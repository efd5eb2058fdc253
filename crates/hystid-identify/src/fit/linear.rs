//! The underlying linear system from one FRF (paper section 3: "estimated by
//! exciting the reference system with a large sinusoidal force": at
//! resonance the slider then adds only about `4Fd/(πF0)` to the relative
//! damping).
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
use nalgebra::{DMatrix, DVector, Dyn, Matrix3, Owned, Vector3};
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
    /// Upper residual `A` (m/N): the flexibility of modes above the band,
    /// added as a constant to the receptance (0 when the plain SDOF fits).
    #[serde(default)]
    pub upper_residual: f64,
    /// Lower residual `B` (m/N · (rad/s)²): modes below the band, added as
    /// `−B/ω²` (0 when the plain SDOF fits).
    #[serde(default)]
    pub lower_residual: f64,
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
///
/// Modes outside the band leave their mark in it as residual terms: a mode
/// far below adds `−B/ω²` (a residual mass), one far above a constant `A`
/// (a residual flexibility), the classical residuals of modal analysis.
/// Where the plain SDOF does not explain the points (by the information
/// criterion), `m, c, k` come from a fit of `1/(k − mω² + jcω) + A − B/ω²`
/// instead, started from a grid over the natural frequency and damping
/// ratio, so that a mode out of the band does not bend (or break) the one in
/// it; `A` and `B` are reported.
pub fn fit_sdof(samples: &[FrfSample], quantity: Quantity, what: &str) -> Result<SdofEstimate> {
    let plain = fit_sdof_plain(samples, quantity, what);
    if samples.len() < 6 || !quantity.is_motion() {
        return plain;
    }
    let pts = receptance_points(samples, quantity);
    if !pts
        .iter()
        .all(|p| p.2 > 0.0 && p.1.norm() > 0.0 && p.1.re.is_finite() && p.1.im.is_finite())
    {
        return plain;
    }
    let chi2_of = |k: f64, m: f64, c: f64, a: f64, b: f64| -> f64 {
        pts.iter()
            .map(|&(w, h, s)| {
                let model = 1.0 / Complex64::new(k - m * w * w, c * w) + a - b / (w * w);
                (h - model).norm_sqr() / (s * s)
            })
            .sum()
    };
    let Some((k, m, c, a, b)) = sdof_with_residuals(&pts) else {
        return plain;
    };
    let chi2_r = chi2_of(k, m, c, a, b);
    let n = 2.0 * pts.len() as f64;
    let reduced = (chi2_r / (n - 5.0).max(1.0)).max(1.0);
    // only where the plain SDOF is no mode at all, or explains the points
    // far worse (a level's nonlinearity also leaves a misfit, which the
    // residual terms would soak up and turn into a wrong m, c, k)
    let better = match &plain {
        Ok(p) => {
            let chi2_p = chi2_of(
                p.sign * p.stiffness,
                p.sign * p.mass,
                p.sign * p.damping,
                0.0,
                0.0,
            );
            chi2_r + 2.0 * n.ln() * reduced < chi2_p && chi2_r < 0.1 * chi2_p
        }
        Err(_) => true,
    };
    let sign = if k < 0.0 && m < 0.0 && c <= 0.0 {
        -1.0
    } else {
        1.0
    };
    let (k, m, c) = (sign * k, sign * m, sign * c);
    // written to refuse a NaN as well as a value out of range
    let physical = k > 0.0 && m > 0.0 && c >= 0.0 && k.is_finite() && m.is_finite();
    if !better || !physical {
        return plain;
    }
    Ok(estimate(&pts, k, m, c, sign, a, b))
}

/// The estimate of `m, c, k` (positive), `sign` and residuals `a, b`, with
/// its relative RMS misfit over the receptance points `(ω, H, σ)`.
fn estimate(
    pts: &[(f64, Complex64, f64)],
    k: f64,
    m: f64,
    c: f64,
    sign: f64,
    a: f64,
    b: f64,
) -> SdofEstimate {
    let rms = (pts
        .iter()
        .map(|&(w, h, _)| {
            ((h - sign / Complex64::new(k - m * w * w, c * w) - a + b / (w * w)) / h).norm_sqr()
        })
        .sum::<f64>()
        / pts.len() as f64)
        .sqrt();
    SdofEstimate {
        mass: m,
        damping: c,
        stiffness: k,
        relative_rms_residual: rms,
        points: pts.len(),
        sign,
        upper_residual: a,
        lower_residual: b,
    }
}

/// The samples as receptance points `(ω, H, σ)` (a motion FRF divided by
/// its `(jω)^p`).
fn receptance_points(samples: &[FrfSample], quantity: Quantity) -> Vec<(f64, Complex64, f64)> {
    samples
        .iter()
        .map(|s| {
            let w = omega(s.frequency_hz);
            let p = quantity.from_displacement(w);
            (w, s.h / p, s.std_error / p.norm())
        })
        .collect()
}

/// `H = R/(ω_n² − ω² + 2jζω_nω) + A − B/ω²` fitted to receptance points
/// `(ω, H, σ)`: a grid over `ω_n` (over the points' range) and `ζ` with `R,
/// A, B` (real) by weighted least squares, then Gauss–Newton on `(k, m, c,
/// A, B)` of `1/(k − mω² + jcω) + A − B/ω²`. Signed `k, m, c` (all negative
/// for a negative modal constant).
fn sdof_with_residuals(pts: &[(f64, Complex64, f64)]) -> Option<(f64, f64, f64, f64, f64)> {
    let wmin = pts.iter().map(|p| p.0).fold(f64::MAX, f64::min);
    let wmax = pts.iter().map(|p| p.0).fold(0.0, f64::max);
    // weighted real least squares for (R, A, B) with the mode's shape g(ω)
    let solve_linear = |wn: f64, zeta: f64| -> Option<(f64, [f64; 3])> {
        let mut ata = nalgebra::Matrix3::<f64>::zeros();
        let mut atb = nalgebra::Vector3::<f64>::zeros();
        for &(w, h, s) in pts {
            let g = 1.0 / Complex64::new(wn * wn - w * w, 2.0 * zeta * wn * w);
            let cols = [
                g,
                Complex64::new(1.0, 0.0),
                Complex64::new(-1.0 / (w * w), 0.0),
            ];
            let wt = 1.0 / (s * s);
            for i in 0..3 {
                for j in 0..3 {
                    ata[(i, j)] += wt * (cols[i].conj() * cols[j]).re;
                }
                atb[i] += wt * (cols[i].conj() * h).re;
            }
        }
        // scale the columns for conditioning
        let d = nalgebra::Vector3::from_fn(|i, _| ata[(i, i)].sqrt().max(f64::MIN_POSITIVE));
        let scaled = nalgebra::Matrix3::from_fn(|i, j| ata[(i, j)] / (d[i] * d[j]));
        let x = scaled.lu().solve(&atb.component_div(&d))?.component_div(&d);
        let chi2: f64 = pts
            .iter()
            .map(|&(w, h, s)| {
                let g = 1.0 / Complex64::new(wn * wn - w * w, 2.0 * zeta * wn * w);
                (h - x[0] * g - x[1] + x[2] / (w * w)).norm_sqr() / (s * s)
            })
            .sum();
        chi2.is_finite().then_some((chi2, [x[0], x[1], x[2]]))
    };
    let mut best: Option<(f64, f64, f64, [f64; 3])> = None;
    for i in 0..=200 {
        let wn = wmin * (wmax / wmin).powf(i as f64 / 200.0);
        for zeta in [0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2] {
            if let Some((chi2, x)) = solve_linear(wn, zeta)
                && best.is_none_or(|b| chi2 < b.0)
            {
                best = Some((chi2, wn, zeta, x));
            }
        }
    }
    let (_, wn, zeta, [r, mut a, mut b]) = best?;
    if r == 0.0 {
        return None;
    }
    let (mut k, mut m, mut c) = (wn * wn / r, 1.0 / r, 2.0 * zeta * wn / r);
    // Gauss–Newton on all five, columns scaled by the parameters
    for _ in 0..30 {
        let np = pts.len();
        let mut jac = DMatrix::<f64>::zeros(2 * np, 5);
        let mut res = DVector::<f64>::zeros(2 * np);
        for (i, &(w, h, s)) in pts.iter().enumerate() {
            let z = Complex64::new(k - m * w * w, c * w);
            let model = 1.0 / z + a - b / (w * w);
            let r_i = (h - model) / s;
            let d = -1.0 / (z * z) / s;
            let cols = [
                d * k,
                d * (-w * w) * m,
                d * Complex64::new(0.0, w) * c,
                Complex64::new(1.0 / s, 0.0) * a.abs().max(1e-300),
                Complex64::new(-1.0 / (w * w * s), 0.0) * b.abs().max(1e-300),
            ];
            for (j, col) in cols.iter().enumerate() {
                jac[(2 * i, j)] = col.re;
                jac[(2 * i + 1, j)] = col.im;
            }
            res[2 * i] = r_i.re;
            res[2 * i + 1] = r_i.im;
        }
        let svd = jac.clone().svd(true, true);
        let Ok(step) = svd.solve(&res, 1e-12) else {
            break;
        };
        let scale = [k, m, c, a.abs().max(1e-300), b.abs().max(1e-300)];
        let (k1, m1, c1, a1, b1) = (
            k + step[0] * scale[0],
            m + step[1] * scale[1],
            c + step[2] * scale[2],
            a + step[3] * scale[3],
            b + step[4] * scale[4],
        );
        if ![k1, m1, c1, a1, b1].iter().all(|v| v.is_finite()) {
            break;
        }
        (k, m, c, a, b) = (k1, m1, c1, a1, b1);
        if step.iter().take(3).all(|s| s.abs() < 1e-10) {
            break;
        }
    }
    Some((k, m, c, a, b))
}

/// [`fit_sdof`] without residual terms.
fn fit_sdof_plain(samples: &[FrfSample], quantity: Quantity, what: &str) -> Result<SdofEstimate> {
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
    let pts = receptance_points(samples, quantity);
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
                "the FRF does not look like one damped mode in this band (fit gave m = {m:e}, c = {c:e}, k = {k:e}: kg, N s/m, N/m on a force reference; V s^2/m, V s/m, V/m on a voltage one)"
            ),
        ));
    }
    Ok(estimate(&pts, k, m, c, sign, 0.0, 0.0))
}

/// Locates one more mode in an FRF that `model` fits: a grid over its
/// frequency (from 0.3 × the lowest to 10 × the highest point) and damping
/// ratio, with the (real) modal constant by weighted least squares on the
/// residual `H − H_model` as a receptance. `None` with fewer than 4 points.
pub fn locate_extra_mode(
    samples: &[FrfSample],
    quantity: Quantity,
    model: &crate::model::ModalModel,
) -> Option<crate::model::Mode> {
    if samples.len() < 4 {
        return None;
    }
    let pts: Vec<(f64, Complex64, f64)> = samples
        .iter()
        .map(|s| {
            let w = omega(s.frequency_hz);
            let p = quantity.from_displacement(w);
            let h = s.h / p;
            let sd = if s.std_error > 0.0 {
                s.std_error / p.norm()
            } else {
                h.norm()
            };
            (s.frequency_hz, h - model.receptance(w), sd)
        })
        .collect();
    locate_mode_in(
        &pts,
        &model
            .modes
            .iter()
            .map(|m| m.frequency_hz)
            .collect::<Vec<_>>(),
    )
}

/// The mode that best explains a receptance residual `(f, r, σ)`, away
/// (3 %) from the frequencies in `avoid`.
pub fn locate_mode_in(pts: &[(f64, Complex64, f64)], avoid: &[f64]) -> Option<crate::model::Mode> {
    if pts.len() < 4 {
        return None;
    }
    let fmin = pts.iter().map(|p| p.0).fold(f64::MAX, f64::min);
    let fmax = pts.iter().map(|p| p.0).fold(0.0, f64::max);
    locate_mode_between(pts, avoid, 0.3 * fmin, 10.0 * fmax)
}

/// [`locate_mode_in`] with the mode's frequency searched between `lo_hz`
/// and `hi_hz` only (e.g. below or above the measured band, where a mode
/// shows only as a residual mass or flexibility and a global search may
/// prefer a spurious mode inside the band).
pub fn locate_mode_between(
    pts: &[(f64, Complex64, f64)],
    avoid: &[f64],
    lo_hz: f64,
    hi_hz: f64,
) -> Option<crate::model::Mode> {
    locate_mode_against(pts, &[], avoid, lo_hz, hi_hz)
}

/// [`locate_mode_between`] with the mode fitted together with real
/// multiples of `background` (columns over `pts`, e.g. the receptance's
/// sensitivities to the fitted mass, stiffness and damping).
///
/// A residual is what the fitted model left: when the model already bent
/// its own parameters towards a missing mode, the residual is the mode
/// *minus* that bending, and a search for the mode alone prefers a far,
/// heavily damped one that mimics the difference. Projecting the
/// bending out (variable projection: the linear coefficients solved at
/// each trial frequency and damping) finds the mode itself.
pub fn locate_mode_against(
    pts: &[(f64, Complex64, f64)],
    background: &[Vec<Complex64>],
    avoid: &[f64],
    lo_hz: f64,
    hi_hz: f64,
) -> Option<crate::model::Mode> {
    let columns = 1 + background.len();
    if pts.len() < 2 * columns
        || !(lo_hz > 0.0 && hi_hz > lo_hz)
        || background.iter().any(|b| b.len() != pts.len())
    {
        return None;
    }
    let weight: Vec<f64> = pts
        .iter()
        .map(|p| 1.0 / p.2.max(f64::MIN_POSITIVE))
        .collect();
    // the weighted real and imaginary rows of the response and background
    let n = 2 * pts.len();
    let mut y = nalgebra::DVector::<f64>::zeros(n);
    let mut a = nalgebra::DMatrix::<f64>::zeros(n, columns);
    for (i, p) in pts.iter().enumerate() {
        y[2 * i] = weight[i] * p.1.re;
        y[2 * i + 1] = weight[i] * p.1.im;
        for (j, b) in background.iter().enumerate() {
            a[(2 * i, j + 1)] = weight[i] * b[i].re;
            a[(2 * i + 1, j + 1)] = weight[i] * b[i].im;
        }
    }
    let mut best: Option<(f64, crate::model::Mode)> = None;
    for i in 0..=300 {
        let f2 = lo_hz * (hi_hz / lo_hz).powf(i as f64 / 300.0);
        if avoid.iter().any(|e| (f2 / e - 1.0).abs() < 0.03) {
            continue;
        }
        for zeta in [0.002, 0.005, 0.01, 0.02, 0.05, 0.1] {
            let w2 = omega(f2);
            for (k, p) in pts.iter().enumerate() {
                let w = omega(p.0);
                let g = 1.0 / Complex64::new(w2 * w2 - w * w, 2.0 * zeta * w2 * w);
                a[(2 * k, 0)] = weight[k] * g.re;
                a[(2 * k + 1, 0)] = weight[k] * g.im;
            }
            let ata = a.transpose() * &a;
            let aty = a.transpose() * &y;
            let Some(x) = ata.cholesky().map(|c| c.solve(&aty)) else {
                continue;
            };
            let res = x[0];
            if !res.is_finite() || res == 0.0 {
                continue;
            }
            let cost = (&y - &a * &x).norm_squared();
            if best.as_ref().is_none_or(|b| cost < b.0) {
                best = Some((
                    cost,
                    crate::model::Mode {
                        frequency_hz: f2,
                        damping_ratio: zeta,
                        residue: res,
                        joint: None,
                    },
                ));
            }
        }
    }
    best.map(|b| b.1)
}

/// Fits every mode of `start` (frequency, damping ratio, modal constant) to
/// FRF points by Levenberg–Marquardt on `(H − H_model)/σ` as receptances,
/// with the analytic Jacobian. Returns the modes and the RMS relative
/// residual.
pub fn fit_modes(
    samples: &[FrfSample],
    quantity: Quantity,
    start: &crate::model::ModalModel,
    what: &str,
) -> Result<(crate::model::ModalModel, f64)> {
    use crate::model::{ModalModel, Mode};
    let pts: Vec<(f64, Complex64, f64)> = samples
        .iter()
        .map(|s| {
            let w = omega(s.frequency_hz);
            let p = quantity.from_displacement(w);
            let h = s.h / p;
            (
                w,
                h,
                if s.std_error > 0.0 {
                    s.std_error / p.norm()
                } else {
                    h.norm()
                },
            )
        })
        .collect();
    let n = start.modes.len();
    if pts.len() < 3 * n + 1 {
        return Err(Error::input(
            what,
            format!("{} points cannot determine {n} modes", pts.len()),
        ));
    }
    // θ per mode: ln ω_r, ln ζ_r, R_r / R_r0
    let scales: Vec<f64> = start.modes.iter().map(|m| m.residue.abs()).collect();
    let mut theta = DVector::zeros(3 * n);
    for (r, m) in start.modes.iter().enumerate() {
        theta[3 * r] = m.omega().ln();
        theta[3 * r + 1] = m.damping_ratio.max(1e-5).ln();
        theta[3 * r + 2] = m.residue / scales[r];
    }
    let (p, report) = levenberg_marquardt::LevenbergMarquardt::new().minimize(ModalLeastSquares {
        pts: &pts,
        scales: &scales,
        theta,
    });
    if !report.termination.was_successful() && report.objective_function.is_nan() {
        return Err(Error::NotConverged {
            stage: "modal fit",
            reason: format!("{what}: {:?}", report.termination),
        });
    }
    let modes: Vec<Mode> = p
        .modes()
        .into_iter()
        .map(|(wr, z, res)| Mode {
            frequency_hz: wr / (2.0 * std::f64::consts::PI),
            damping_ratio: z.min(0.99),
            residue: res,
            joint: None,
        })
        .collect();
    let model = ModalModel::new(modes)
        .map_err(|e| Error::input(what, format!("the modal fit gave an invalid mode: {e}")))?;
    let rms = (pts
        .iter()
        .map(|&(w, h, _)| ((h - model.receptance(w)) / h).norm_sqr())
        .sum::<f64>()
        / pts.len() as f64)
        .sqrt();
    Ok((model, rms))
}

/// The modes' least squares of [`fit_modes`]: the points `(ω, H, σ)` in
/// receptance, and per mode `θ = (ln ω_r, ln ζ_r, R_r / R_r0)`.
struct ModalLeastSquares<'a> {
    pts: &'a [(f64, Complex64, f64)],
    scales: &'a [f64],
    theta: DVector<f64>,
}
impl ModalLeastSquares<'_> {
    /// `(ω_r, ζ_r, R_r)` of each mode at `θ`.
    fn modes(&self) -> Vec<(f64, f64, f64)> {
        (0..self.scales.len())
            .map(|r| {
                (
                    self.theta[3 * r].exp(),
                    self.theta[3 * r + 1].exp(),
                    self.theta[3 * r + 2] * self.scales[r],
                )
            })
            .collect()
    }
}

impl levenberg_marquardt::LeastSquaresProblem<f64, Dyn, Dyn> for ModalLeastSquares<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;
    fn set_params(&mut self, x: &DVector<f64>) {
        self.theta.copy_from(x);
    }
    fn params(&self) -> DVector<f64> {
        self.theta.clone()
    }
    fn residuals(&self) -> Option<DVector<f64>> {
        let modes = self.modes();
        let mut r = DVector::zeros(2 * self.pts.len());
        for (i, &(w, h, s)) in self.pts.iter().enumerate() {
            let m: Complex64 = modes
                .iter()
                .map(|&(wr, z, res)| res / Complex64::new(wr * wr - w * w, 2.0 * z * wr * w))
                .sum();
            let d = (h - m) / s;
            r[2 * i] = d.re;
            r[2 * i + 1] = d.im;
        }
        Some(r)
    }
    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let modes = self.modes();
        let mut j = DMatrix::zeros(2 * self.pts.len(), 3 * modes.len());
        for (i, &(w, _, s)) in self.pts.iter().enumerate() {
            for (r, &(wr, z, res)) in modes.iter().enumerate() {
                let den = Complex64::new(wr * wr - w * w, 2.0 * z * wr * w);
                let g = 1.0 / den;
                // ∂(−R g)/∂θ: ∂den/∂ln ω_r = 2ω_r² + 2jζω_r ω, ∂den/∂ln ζ = 2jζω_r ω
                let d_lnw = res * g * g * Complex64::new(2.0 * wr * wr, 2.0 * z * wr * w) / s;
                let d_lnz = res * g * g * Complex64::new(0.0, 2.0 * z * wr * w) / s;
                let d_r = -g * self.scales[r] / s;
                for (c, v) in [(3 * r, d_lnw), (3 * r + 1, d_lnz), (3 * r + 2, d_r)] {
                    j[(2 * i, c)] = v.re;
                    j[(2 * i + 1, c)] = v.im;
                }
            }
        }
        Some(j)
    }
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

    /// A mode above the band that a single-mode fit has already bent its
    /// own stiffness and mass towards: the residual is the mode minus that
    /// bending. Projecting the bending out finds the mode's frequency (to
    /// the trial grid's spacing and the linearised bending's error).
    #[test]
    fn a_mode_above_the_band_is_found_under_the_fits_own_bending() {
        let (m, c, k) = (2.0, 40.0, 2.0e6); // 159 Hz
        let (f2, z2, r2) = (1.6 * 350.0, 0.03, 0.8);
        let mode = |f: f64| {
            let (w, w2) = (omega(f), omega(f2));
            r2 / Complex64::new(w2 * w2 - w * w, 2.0 * z2 * w2 * w)
        };
        let data: Vec<FrfSample> = (0..51)
            .map(|i| {
                let f = 100.0 + 5.0 * i as f64;
                let w = omega(f);
                let h = 1.0 / Complex64::new(k - m * w * w, c * w) + mode(f);
                FrfSample {
                    frequency_hz: f,
                    h,
                    std_error: 1e-3 * h.norm(),
                }
            })
            .collect();
        let start = crate::model::ModalModel {
            modes: vec![crate::model::Mode {
                frequency_hz: 159.0,
                damping_ratio: 0.01,
                residue: 0.5,
                joint: None,
            }],
        };
        let (fitted, _) = fit_modes(&data, Quantity::Displacement, &start, "test").unwrap();
        let fit = fitted.modes[0];
        let residual: Vec<(f64, Complex64, f64)> = data
            .iter()
            .map(|p| {
                (
                    p.frequency_hz,
                    p.h - fit.receptance(omega(p.frequency_hz)),
                    p.std_error,
                )
            })
            .collect();
        let background: Vec<Vec<Complex64>> = (0..3)
            .map(|j| {
                data.iter()
                    .map(|p| {
                        let w = omega(p.frequency_hz);
                        let h2 = fit.receptance(omega(p.frequency_hz)).powi(2);
                        [-h2, w * w * h2, -Complex64::i() * w * h2][j]
                    })
                    .collect()
            })
            .collect();
        let found = locate_mode_against(&residual, &background, &[fit.frequency_hz], 385.0, 1050.0)
            .expect("a mode");
        // the plain search, misled by the bending, stops at the range's edge
        let plain = locate_mode_between(&residual, &[fit.frequency_hz], 385.0, 1050.0).unwrap();
        assert!(plain.frequency_hz < 390.0, "{plain:?}");
        // the projected one is in the mode's basin (its flexibility traded
        // against its frequency, the bending being large here): a two-mode
        // fit from it recovers the mode
        assert!((found.frequency_hz / f2 - 1.0).abs() < 0.2, "{found:?}");
        let two = crate::model::ModalModel {
            modes: vec![fit, found],
        };
        let (both, _) = fit_modes(&data, Quantity::Displacement, &two, "test").unwrap();
        let m2 = both.modes[1];
        assert!((m2.frequency_hz / f2 - 1.0).abs() < 1e-3, "{m2:?}");
        assert!((m2.residue / r2 - 1.0).abs() < 1e-2, "{m2:?}");
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
    fn a_second_mode_is_located_and_both_are_fitted() {
        use crate::model::{ModalModel, Mode};
        let truth = ModalModel::new(vec![
            Mode::from_mck(10.0, 200.0, 1e7).unwrap(),
            Mode::from_modal_mass(420.0, 0.01, 50.0).unwrap(),
        ])
        .unwrap();
        let s: Vec<FrfSample> = (0..51)
            .map(|i| {
                let f = 100.0 + 5.0 * i as f64;
                let h = truth.receptance(omega(f));
                FrfSample {
                    frequency_hz: f,
                    h,
                    std_error: 1e-3 * h.norm(),
                }
            })
            .collect();
        let sdof = fit_sdof(&s, Quantity::Displacement, "t").unwrap();
        let one = ModalModel::sdof(sdof.mass, sdof.damping, sdof.stiffness).unwrap();
        let extra = locate_extra_mode(&s, Quantity::Displacement, &one).unwrap();
        assert!((extra.frequency_hz / 420.0 - 1.0).abs() < 0.15, "{extra:?}");
        let start = ModalModel::new(vec![one.modes[0], extra]).unwrap();
        let (fitted, rms) = fit_modes(&s, Quantity::Displacement, &start, "t").unwrap();
        assert!(rms < 1e-8, "rms {rms}");
        for (a, b) in fitted.modes.iter().zip(&truth.modes) {
            assert!((a.frequency_hz / b.frequency_hz - 1.0).abs() < 1e-8);
            assert!((a.damping_ratio / b.damping_ratio - 1.0).abs() < 1e-6);
            assert!((a.residue / b.residue - 1.0).abs() < 1e-6);
        }
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
