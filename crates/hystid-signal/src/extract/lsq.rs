//! Least-squares fit of a mean plus harmonics at a known phase.
//!
//! The model of every channel is `y(t) = c_0 + Σ_{h=1..K} a_h cos(hθ(t)) +
//! b_h sin(hθ(t))`, which in the convention of [`crate::harmonics`] is
//! `Y_0 = c_0`, `Y_h = a_h − j b_h`. All channels share the basis, so the
//! normal matrix is formed once per record and solved once by Cholesky for
//! every channel. Over one period or more the basis is nearly orthogonal
//! (condition number of the normal matrix of order 1), so the normal
//! equations lose no useful precision.

use num_complex::Complex64;

/// Accumulates and solves the normal equations of a harmonic fit.
#[derive(Clone, Debug)]
pub(crate) struct HarmonicLsq {
    k: usize,
    m: usize,
    channels: usize,
    /// Upper triangle of `AᵀA`, row-major `m × m`.
    gram: Vec<f64>,
    /// `Aᵀy` per channel, `channels × m`.
    rhs: Vec<f64>,
    /// `Σ y²` per channel.
    sum_sq: Vec<f64>,
    basis: Vec<f64>,
    /// Cholesky factor `Rᵀ R = AᵀA` (upper triangle of `R`).
    chol: Vec<f64>,
    /// Coefficients per channel, `channels × m`.
    coef: Vec<f64>,
    count: usize,
}

impl HarmonicLsq {
    /// A fit of harmonics `0..=k` for `channels` signals.
    pub(crate) fn new(k: usize, channels: usize) -> Self {
        let m = 2 * k + 1;
        HarmonicLsq {
            k,
            m,
            channels,
            gram: vec![0.0; m * m],
            rhs: vec![0.0; m * channels],
            sum_sq: vec![0.0; channels],
            basis: vec![0.0; m],
            chol: vec![0.0; m * m],
            coef: vec![0.0; m * channels],
            count: 0,
        }
    }

    /// Unknowns per channel, `2K + 1`.
    pub(crate) fn unknowns(&self) -> usize {
        self.m
    }

    /// Forgets the accumulated samples.
    pub(crate) fn reset(&mut self) {
        self.gram.iter_mut().for_each(|g| *g = 0.0);
        self.rhs.iter_mut().for_each(|g| *g = 0.0);
        self.sum_sq.iter_mut().for_each(|g| *g = 0.0);
        self.count = 0;
    }

    /// Fills `basis` with `1, cos θ, sin θ, cos 2θ, …` from `sin θ`, `cos θ`
    /// (angle addition: one `sin_cos` per sample).
    #[inline]
    fn fill_basis_sc(basis: &mut [f64], k: usize, s1: f64, c1: f64) {
        basis[0] = 1.0;
        let (mut c, mut s) = (c1, s1);
        for h in 1..=k {
            basis[2 * h - 1] = c;
            basis[2 * h] = s;
            (c, s) = (c * c1 - s * s1, s * c1 + c * s1);
        }
    }

    /// Adds one sample at phase `theta` with one value per channel.
    #[inline]
    pub(crate) fn add(&mut self, theta: f64, values: &[f64]) {
        let (s1, c1) = theta.sin_cos();
        self.add_sc(s1, c1, values);
    }

    /// [`Self::add`] with `sin θ`, `cos θ` precomputed.
    #[inline]
    pub(crate) fn add_sc(&mut self, s1: f64, c1: f64, values: &[f64]) {
        debug_assert_eq!(values.len(), self.channels);
        let m = self.m;
        Self::fill_basis_sc(&mut self.basis, self.k, s1, c1);
        let basis = &self.basis;
        for i in 0..m {
            let bi = basis[i];
            let row = &mut self.gram[i * m + i..i * m + m];
            for (g, bj) in row.iter_mut().zip(&basis[i..]) {
                *g += bi * bj;
            }
        }
        for (c, &y) in values.iter().enumerate() {
            let rhs = &mut self.rhs[c * m..c * m + m];
            for (r, b) in rhs.iter_mut().zip(basis) {
                *r += b * y;
            }
            self.sum_sq[c] += y * y;
        }
        self.count += 1;
    }

    /// Factorises and solves. `false` if the normal matrix is singular to
    /// working precision (too few samples, or a harmonic at or above the
    /// Nyquist frequency).
    pub(crate) fn solve(&mut self) -> bool {
        let m = self.m;
        if self.count < m {
            return false;
        }
        // Cholesky AᵀA = RᵀR, R upper triangular
        self.chol.copy_from_slice(&self.gram);
        let scale = (0..m).map(|i| self.gram[i * m + i]).fold(0.0, f64::max);
        for i in 0..m {
            let mut d = self.chol[i * m + i];
            for p in 0..i {
                d -= self.chol[p * m + i] * self.chol[p * m + i];
            }
            if d.is_nan() || d <= 1e-10 * scale {
                return false;
            }
            let d = d.sqrt();
            self.chol[i * m + i] = d;
            for j in i + 1..m {
                let mut v = self.chol[i * m + j];
                for p in 0..i {
                    v -= self.chol[p * m + i] * self.chol[p * m + j];
                }
                self.chol[i * m + j] = v / d;
            }
        }
        for c in 0..self.channels {
            let (rhs, coef) = (
                &self.rhs[c * m..c * m + m],
                &mut self.coef[c * m..c * m + m],
            );
            Self::cholesky_solve(&self.chol, m, rhs, coef);
        }
        true
    }

    fn cholesky_solve(chol: &[f64], m: usize, rhs: &[f64], x: &mut [f64]) {
        // Rᵀ z = rhs
        for i in 0..m {
            let mut v = rhs[i];
            for p in 0..i {
                v -= chol[p * m + i] * x[p];
            }
            x[i] = v / chol[i * m + i];
        }
        // R x = z
        for i in (0..m).rev() {
            let mut v = x[i];
            for j in i + 1..m {
                v -= chol[i * m + j] * x[j];
            }
            x[i] = v / chol[i * m + i];
        }
    }

    /// The fitted harmonics `Y_0..Y_K` of one channel (after [`Self::solve`]).
    pub(crate) fn harmonics(&self, channel: usize, out: &mut [Complex64]) {
        let c = &self.coef[channel * self.m..(channel + 1) * self.m];
        out[0] = Complex64::new(c[0], 0.0);
        for h in 1..=self.k {
            out[h] = Complex64::new(c[2 * h - 1], -c[2 * h]);
        }
    }

    /// The fitted coefficients of one channel: `c_0, a_1, b_1, a_2, …`.
    pub(crate) fn coefficients(&self, channel: usize) -> &[f64] {
        &self.coef[channel * self.m..(channel + 1) * self.m]
    }

    /// Evaluates the fitted model of `channel` at phase `theta`.
    /// The fitted model of every channel at the phase with `sin θ`, `cos θ`,
    /// written to `out` (one value per channel).
    #[inline]
    pub(crate) fn model_sc(&mut self, s1: f64, c1: f64, out: &mut [f64]) {
        Self::fill_basis_sc(&mut self.basis, self.k, s1, c1);
        for (ch, o) in out.iter_mut().enumerate() {
            let c = &self.coef[ch * self.m..(ch + 1) * self.m];
            *o = self.basis.iter().zip(c).map(|(b, c)| b * c).sum();
        }
    }

    /// `(AᵀA)⁻¹` diagonal: the variance of each coefficient per unit residual
    /// variance (after [`Self::solve`]).
    pub(crate) fn inverse_diagonal(&self, out: &mut [f64]) {
        let m = self.m;
        // diag((RᵀR)⁻¹) = row sums of squares of R⁻ᵀ's columns: solve Rᵀ z = e_i
        // column by column of R⁻¹ (upper triangular); var_i = Σ_j (R⁻¹)_{ij}².
        let mut inv = vec![0.0; m * m];
        for col in 0..m {
            // solve R x = e_col, x is column `col` of R⁻¹
            for i in (0..m).rev() {
                let mut v = if i == col { 1.0 } else { 0.0 };
                for j in i + 1..m {
                    v -= self.chol[i * m + j] * inv[j * m + col];
                }
                inv[i * m + col] = v / self.chol[i * m + i];
            }
        }
        for (i, o) in out.iter_mut().enumerate().take(m) {
            *o = (0..m).map(|j| inv[i * m + j].powi(2)).sum();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harmonics::synthesize;

    #[test]
    fn recovers_harmonics_over_a_fraction_of_periods() {
        let y = [
            Complex64::new(0.3, 0.0),
            Complex64::from_polar(1.0, 0.4),
            Complex64::from_polar(0.2, -1.1),
            Complex64::from_polar(0.05, 2.0),
        ];
        let mut lsq = HarmonicLsq::new(3, 1);
        for n in 0..157 {
            let th = 0.0731 * n as f64;
            lsq.add(th, &[synthesize(&y, th)]);
        }
        assert!(lsq.solve());
        let mut out = [Complex64::default(); 4];
        lsq.harmonics(0, &mut out);
        for (a, b) in out.iter().zip(&y) {
            assert!((a - b).norm() < 1e-12, "{a} vs {b}");
        }
        let mut d = [0.0; 7];
        lsq.inverse_diagonal(&mut d);
        // ≈ 1/n for the mean, 2/n for a cos/sin column over whole periods
        assert!((d[0] * 157.0 - 1.0).abs() < 0.1, "{}", d[0] * 157.0);
        assert!((d[1] * 157.0 / 2.0 - 1.0).abs() < 0.1);
    }

    #[test]
    fn singular_at_nyquist() {
        let mut lsq = HarmonicLsq::new(2, 1);
        for n in 0..64 {
            // θ = π n/2: harmonic 2 is at Nyquist, sin 2θ ≡ 0
            lsq.add(std::f64::consts::FRAC_PI_2 * n as f64, &[1.0]);
        }
        assert!(!lsq.solve());
    }
}
