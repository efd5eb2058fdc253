//! A naive harmonic balance, written as a textbook states it, as the
//! yardstick `hb/curve/*` reports hystid's solver against: the SDOF with a
//! Jenkins joint in receptance form, `R = X − H(hω)(F δ_h1 − G(X))`, the
//! alternating frequency/time method with direct sums over precomputed
//! cosine and sine tables, the slider marched two periods from rest at every
//! evaluation (the second period kept; no turning point placed between
//! samples), the Jacobian by forward differences (one evaluation per
//! unknown), full Newton steps and Gaussian elimination. Nothing in it is
//! shared with `hystid::hb`.

use num_complex::Complex64;
use std::f64::consts::PI;

/// The structure and joint: `m x'' + c x' + k x + g = F cos ωt`, Jenkins
/// `g` of stick stiffness `kd` and slip force `fd`.
pub struct NaiveHb {
    m: f64,
    c: f64,
    k: f64,
    kd: f64,
    fd: f64,
    /// Harmonics `0..=top`.
    top: usize,
    samples: usize,
    /// `cos hθ_j`, `sin hθ_j`, row `h`, column `j`.
    cos: Vec<f64>,
    sin: Vec<f64>,
    /// `H(hω)`, per harmonic.
    receptance: Vec<Complex64>,
    x: Vec<f64>,
    g: Vec<f64>,
}

impl NaiveHb {
    pub fn new(m: f64, c: f64, k: f64, kd: f64, fd: f64, top: usize, samples: usize) -> NaiveHb {
        let mut cos = vec![0.0; (top + 1) * samples];
        let mut sin = vec![0.0; (top + 1) * samples];
        for h in 0..=top {
            for j in 0..samples {
                let t = 2.0 * PI * (h * j) as f64 / samples as f64;
                cos[h * samples + j] = t.cos();
                sin[h * samples + j] = t.sin();
            }
        }
        NaiveHb {
            m,
            c,
            k,
            kd,
            fd,
            top,
            samples,
            cos,
            sin,
            receptance: vec![Complex64::new(0.0, 0.0); top + 1],
            x: vec![0.0; samples],
            g: vec![0.0; samples],
        }
    }

    /// Unknowns: `X0, Re X1, Im X1, …, Re X_top, Im X_top`.
    pub fn unknowns(&self) -> usize {
        2 * self.top + 1
    }

    /// `X_h` from the unknowns.
    pub fn harmonic(x: &[f64], h: usize) -> Complex64 {
        if h == 0 {
            Complex64::new(x[0], 0.0)
        } else {
            Complex64::new(x[2 * h - 1], x[2 * h])
        }
    }

    fn residual(&mut self, force: f64, xs: &[f64], r: &mut [f64]) {
        let ns = self.samples;
        for j in 0..ns {
            let mut v = xs[0];
            for h in 1..=self.top {
                v += xs[2 * h - 1] * self.cos[h * ns + j] - xs[2 * h] * self.sin[h * ns + j];
            }
            self.x[j] = v;
        }
        // two periods from a relaxed slider; the second is the loop
        let mut slider = 0.0;
        for pass in 0..2 {
            for j in 0..ns {
                let mut g = self.kd * (self.x[j] - slider);
                if g > self.fd {
                    slider = self.x[j] - self.fd / self.kd;
                    g = self.fd;
                } else if g < -self.fd {
                    slider = self.x[j] + self.fd / self.kd;
                    g = -self.fd;
                }
                if pass == 1 {
                    self.g[j] = g;
                }
            }
        }
        for h in 0..=self.top {
            let (mut re, mut im) = (0.0, 0.0);
            for j in 0..ns {
                re += self.g[j] * self.cos[h * ns + j];
                im -= self.g[j] * self.sin[h * ns + j];
            }
            let scale = if h == 0 { 1.0 } else { 2.0 } / ns as f64;
            let gh = Complex64::new(re * scale, im * scale);
            let f = if h == 1 { force } else { 0.0 };
            let rh = Self::harmonic(xs, h) - self.receptance[h] * (f - gh);
            if h == 0 {
                r[0] = rh.re;
            } else {
                r[2 * h - 1] = rh.re;
                r[2 * h] = rh.im;
            }
        }
    }

    /// Solves the point at `frequency_hz`, `force` from `x` (overwritten):
    /// the Newton iterations, or `None` when it does not converge to
    /// `‖R‖ ≤ tolerance ‖X‖` in 50.
    pub fn solve(
        &mut self,
        frequency_hz: f64,
        force: f64,
        x: &mut [f64],
        tolerance: f64,
    ) -> Option<usize> {
        let w = 2.0 * PI * frequency_hz;
        for h in 0..=self.top {
            let hw = h as f64 * w;
            self.receptance[h] = 1.0 / Complex64::new(self.k - self.m * hw * hw, self.c * hw);
        }
        let n = self.unknowns();
        let mut r = vec![0.0; n];
        let mut rp = vec![0.0; n];
        let mut jac = vec![0.0; n * n];
        let norm = |v: &[f64]| v.iter().map(|a| a * a).sum::<f64>().sqrt();
        for iteration in 0..50 {
            self.residual(force, x, &mut r);
            if norm(&r) <= tolerance * norm(x) {
                return Some(iteration);
            }
            let scale = norm(x).max(f64::MIN_POSITIVE);
            for k in 0..n {
                let step = 1e-7 * scale;
                let keep = x[k];
                x[k] += step;
                self.residual(force, x, &mut rp);
                x[k] = keep;
                for i in 0..n {
                    jac[i * n + k] = (rp[i] - r[i]) / step;
                }
            }
            // Gaussian elimination with partial pivoting on [J | −R]
            let mut b: Vec<f64> = r.iter().map(|v| -v).collect();
            for col in 0..n {
                let p = (col..n)
                    .max_by(|&a, &c| jac[a * n + col].abs().total_cmp(&jac[c * n + col].abs()))
                    .unwrap();
                if jac[p * n + col] == 0.0 {
                    return None;
                }
                if p != col {
                    for k in 0..n {
                        jac.swap(p * n + k, col * n + k);
                    }
                    b.swap(p, col);
                }
                for i in col + 1..n {
                    let f = jac[i * n + col] / jac[col * n + col];
                    for k in col..n {
                        jac[i * n + k] -= f * jac[col * n + k];
                    }
                    b[i] -= f * b[col];
                }
            }
            for i in (0..n).rev() {
                let mut s = b[i];
                for k in i + 1..n {
                    s -= jac[i * n + k] * b[k];
                }
                b[i] = s / jac[i * n + i];
            }
            for (xi, d) in x.iter_mut().zip(&b) {
                *xi += d;
            }
        }
        None
    }
}
