//! Each peak's mode fitted near its peak: a pole per peak from the lines
//! around it once the other modes are taken out, and every mode's residues
//! from all the lines with the poles held (least-squares frequency domain,
//! LSFD), the two alternated.
//!
//! Near its peak a mode's receptance `A_p/(λ − ω² + jωc)` (`λ = ω_r²`,
//! `c = 2ζ_r ω_r`) is linear in `(λ, c, A_p)` once multiplied out,
//! `H_p λ + jω H_p c − A_p = ω² H_p`, solved by least squares over every
//! response at once with the Sanathanan–Koerner weight `1/|λ' − ω² + jωc'|`
//! of the previous pole (Levy's method iterated). The residues of
//! mass-normalised real modes are real, `A_p = φ_r(p) φ_r(d)`.

use crate::error::{Error, Result};
use crate::model::ShapedMode;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use std::f64::consts::PI;

/// Alternations of the poles and the residues.
const ROUNDS: usize = 30;

/// One mode's pole: `λ = ω_r²` and `c = 2 ζ_r ω_r`.
#[derive(Clone, Copy, Debug)]
struct Pole {
    lambda: f64,
    c: f64,
}

impl Pole {
    fn of(frequency_hz: f64, damping_ratio: f64) -> Pole {
        let w = 2.0 * PI * frequency_hz;
        Pole {
            lambda: w * w,
            c: 2.0 * damping_ratio * w,
        }
    }
    fn frequency_hz(self) -> f64 {
        self.lambda.sqrt() / (2.0 * PI)
    }
    fn damping_ratio(self) -> f64 {
        self.c / (2.0 * self.lambda.sqrt())
    }
    fn basis(self, w: f64) -> Complex64 {
        1.0 / Complex64::new(self.lambda - w * w, w * self.c)
    }
}

/// The modes of `peaks` (Hz; from the peaks of the summed receptances)
/// and of `outside` (Hz, held, damped at `outside_damping`: the modes
/// beyond the lines, seen only through what they leave), fitted to the
/// receptances `h[p][k]` at `omega[k]` (rad/s), the structure driven at
/// `drive`. The peaks' poles start at `outside_damping` too.
///
/// Errors: a pole that leaves the lines or loses its stiffness or
/// damping.
pub fn peak_modes(
    omega: &[f64],
    h: &[Vec<Complex64>],
    drive: usize,
    peaks: &[f64],
    (outside, outside_damping): (&[f64], f64),
) -> Result<Vec<ShapedMode>> {
    let mut poles: Vec<Pole> = (peaks.iter())
        .map(|&f| Pole::of(f, outside_damping))
        .collect();
    poles.extend(outside.iter().map(|&f| Pole::of(f, outside_damping)));
    let free = peaks.len();
    let mut residues = residues_of(omega, h, &poles);
    for _ in 0..ROUNDS {
        let before: Vec<f64> = poles[..free].iter().map(|p| p.lambda).collect();
        for r in 0..free {
            let near = near_lines(omega, &poles, r, free);
            let alone: Vec<Vec<Complex64>> = h
                .iter()
                .zip(&residues)
                .map(|(hp, a)| {
                    near.iter()
                        .map(|&k| {
                            let others: Complex64 = (0..poles.len())
                                .filter(|&s| s != r)
                                .map(|s| a[s] * poles[s].basis(omega[k]))
                                .sum();
                            hp[k] - others
                        })
                        .collect()
                })
                .collect();
            let w: Vec<f64> = near.iter().map(|&k| omega[k]).collect();
            poles[r] = sdof_pole(&w, &alone, poles[r])?;
        }
        residues = residues_of(omega, h, &poles);
        let moved = poles[..free]
            .iter()
            .zip(&before)
            .map(|(p, b)| (p.lambda / b - 1.0).abs())
            .fold(0.0, f64::max);
        if moved < 1e-9 {
            break;
        }
    }
    let (lo, hi) = omega
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(l, u), &w| (l.min(w), u.max(w)));
    for p in &poles[..free] {
        if !(p.lambda.sqrt() > lo && p.lambda.sqrt() < hi && p.c > 0.0) {
            return Err(Error::input(
                "data",
                format!(
                    "a peak's mode fitted near it left the lines or lost its damping \
                     ({:.4} Hz, ζ {:.4})",
                    p.frequency_hz(),
                    p.damping_ratio()
                ),
            ));
        }
    }
    Ok(shaped(&poles, &residues, drive))
}

/// The lines nearest mode `r` among the peak modes (`free` of them), within
/// three half-power widths of its pole, and at least five.
fn near_lines(omega: &[f64], poles: &[Pole], r: usize, free: usize) -> Vec<usize> {
    let wr = poles[r].lambda.sqrt();
    let width = 3.0 * poles[r].c.max(1e-3 * wr);
    let nearest = |w: f64| {
        (0..free)
            .min_by(|&a, &b| {
                let d = |s: usize| (w.ln() - poles[s].lambda.sqrt().ln()).abs();
                d(a).total_cmp(&d(b))
            })
            .unwrap_or(r)
    };
    let mut near: Vec<usize> = (0..omega.len())
        .filter(|&k| nearest(omega[k]) == r && (omega[k] - wr).abs() <= width)
        .collect();
    if near.len() < 5 {
        let mut by: Vec<usize> = (0..omega.len()).collect();
        by.sort_by(|&a, &b| (omega[a] - wr).abs().total_cmp(&(omega[b] - wr).abs()));
        near = by.into_iter().take(5).collect();
    }
    near
}

/// The pole of one mode alone in `h[p][k]` at `w[k]`, Levy's linearised fit
/// weighted by the previous pole's `1/|D|` (a few passes).
fn sdof_pole(w: &[f64], h: &[Vec<Complex64>], start: Pole) -> Result<Pole> {
    let responses = h.len();
    let mut pole = start;
    for _ in 0..5 {
        // unknowns: λ, c, then Re A_p, Im A_p per response
        let cols = 2 + 2 * responses;
        let rows = 2 * w.len() * responses;
        let mut a = DMatrix::zeros(rows, cols);
        let mut b = DVector::zeros(rows);
        let mut row = 0;
        for (p, hp) in h.iter().enumerate() {
            for (k, &wk) in w.iter().enumerate() {
                let s = pole.basis(wk).norm();
                let x = hp[k];
                let jw = Complex64::new(0.0, wk) * x;
                let rhs = wk * wk * x;
                for (part, pick) in [(0, re as fn(Complex64) -> f64), (1, im)] {
                    a[(row, 0)] = pick(x) * s;
                    a[(row, 1)] = pick(jw) * s;
                    a[(row, 2 + 2 * p + part)] = -s;
                    b[row] = pick(rhs) * s;
                    row += 1;
                }
            }
        }
        let x = a
            .svd(true, true)
            .solve(&b, 1e-14)
            .map_err(|e| Error::input("data", format!("a pole's fit: {e}")))?;
        pole = Pole {
            lambda: x[0],
            c: x[1],
        };
        if pole.lambda.is_nan() || pole.lambda <= 0.0 {
            return Err(Error::input("data", "a peak's mode lost its stiffness"));
        }
    }
    Ok(pole)
}

fn re(z: Complex64) -> f64 {
    z.re
}

fn im(z: Complex64) -> f64 {
    z.im
}

/// Every response's complex residues at `poles`, by least squares over all
/// the lines: `[p][r]`.
fn residues_of(omega: &[f64], h: &[Vec<Complex64>], poles: &[Pole]) -> Vec<Vec<Complex64>> {
    let n = poles.len();
    let a = DMatrix::from_fn(2 * omega.len(), 2 * n, |row, col| {
        let z = poles[col / 2].basis(omega[row / 2]);
        // (A_re + j A_im) z
        let z = if col % 2 == 0 {
            z
        } else {
            Complex64::new(0.0, 1.0) * z
        };
        if row % 2 == 0 { z.re } else { z.im }
    });
    let svd = a.svd(true, true);
    h.iter()
        .map(|hp| {
            let b = DVector::from_fn(2 * omega.len(), |row, _| {
                let z = hp[row / 2];
                if row % 2 == 0 { z.re } else { z.im }
            });
            let x = svd
                .solve(&b, 1e-14)
                .unwrap_or_else(|_| DVector::zeros(2 * n));
            (0..n)
                .map(|r| Complex64::new(x[2 * r], x[2 * r + 1]))
                .collect()
        })
        .collect()
}

/// Real modes from the poles and the residues' real parts:
/// `φ_r(d) = √|A_dr|`, `φ_r(p) = A_pr/φ_r(d)`.
fn shaped(poles: &[Pole], residues: &[Vec<Complex64>], drive: usize) -> Vec<ShapedMode> {
    poles
        .iter()
        .enumerate()
        .map(|(r, pole)| {
            let phi_d = residues[drive][r].re.abs().sqrt().max(f64::MIN_POSITIVE);
            ShapedMode {
                frequency_hz: pole.frequency_hz(),
                damping_ratio: pole.damping_ratio(),
                shape: residues.iter().map(|a| a[r].re / phi_d).collect(),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three close modes, summed exactly, come back to 1e-6.
    #[test]
    fn three_close_modes_come_back_from_their_exact_receptances() {
        let truth = [
            (5.2, 0.012, [1.0, 0.4, -0.3]),
            (6.65, 0.006, [0.3, -0.8, 0.5]),
            (7.3, 0.02, [0.7, 0.6, 0.9]),
        ];
        let omega: Vec<f64> = (0..300)
            .map(|k| 2.0 * PI * (4.5 + 0.015 * k as f64))
            .collect();
        let h: Vec<Vec<Complex64>> = (0..3)
            .map(|p| {
                omega
                    .iter()
                    .map(|&w| {
                        truth
                            .iter()
                            .map(|(f, z, s)| s[p] * s[0] * Pole::of(*f, *z).basis(w))
                            .sum()
                    })
                    .collect()
            })
            .collect();
        let modes = peak_modes(&omega, &h, 0, &[5.25, 6.6, 7.35], (&[], 0.02)).unwrap();
        for (m, (f, z, s)) in modes.iter().zip(&truth) {
            assert!((m.frequency_hz / f - 1.0).abs() < 1e-6, "{m:?}");
            assert!((m.damping_ratio / z - 1.0).abs() < 1e-6, "{m:?}");
            for (found, truth) in m.shape.iter().zip(s) {
                assert!((found - truth).abs() < 1e-6, "{m:?}");
            }
        }
    }
}
