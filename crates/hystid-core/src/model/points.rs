//! A structure seen at several named points: its modes, each with its shape
//! at every point, so that a joint can act between two points that several
//! modes share (a bolted interface between two substructures) rather than
//! only between the drive point and the ground.
//!
//! With mass-normalised shapes `φ_r` (`Φᵀ M Φ = I`), the receptance from
//! point `q` to point `p` is
//!
//! ```text
//! H_pq(ω) = Σ_r φ_r(p) φ_r(q) / (ω_r² − ω² + 2 j ζ_r ω_r ω)
//! ```
//!
//! (Ewins, *Modal Testing*, eq. 2.62), so that a mode's modal constant at
//! the drive point, [`crate::model::Mode::residue`], is `φ_r(d)²`: a
//! [`crate::model::ModalModel`] is the one-point case. The modes come
//! either as given or from a small lumped model ([`Lumped`]) by the
//! generalised eigenproblem `K φ = ω² M φ`.

use crate::error::{Error, Result, require_non_negative, require_positive};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// One real normal mode with its mass-normalised shape at every point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShapedMode {
    /// Undamped natural frequency, Hz.
    pub frequency_hz: f64,
    /// Viscous damping ratio ζ (0 ≤ ζ < 1).
    pub damping_ratio: f64,
    /// `φ_r(p)` at each of the structure's points, in its points' order,
    /// m/√kg.
    pub shape: Vec<f64>,
}

/// Where a force acts or a motion is read: at a point, or across two
/// points (a joint's relative motion `x_a − x_b`; `None`: the ground).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Site {
    /// One point.
    Point(usize),
    /// From the second point (or the ground) to the first.
    Across(usize, Option<usize>),
}

impl ShapedMode {
    /// The shape's value at `site`: `φ(p)`, or `φ(a) − φ(b)` across a joint.
    pub fn at(&self, site: Site) -> f64 {
        match site {
            Site::Point(p) => self.shape[p],
            Site::Across(a, b) => self.shape[a] - b.map_or(0.0, |b| self.shape[b]),
        }
    }
}

/// A structure's modes seen at its named points.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointModes {
    /// The points' names (drive, sensors, joint ends).
    pub points: Vec<String>,
    /// The modes.
    pub modes: Vec<ShapedMode>,
}

impl PointModes {
    /// The index of point `name`, or an error naming the points there are.
    pub fn point(&self, name: &str) -> Result<usize> {
        self.points.iter().position(|p| p == name).ok_or_else(|| {
            Error::model(
                "points",
                format!(
                    "no point `{name}`; the points are {}",
                    self.points.join(", ")
                ),
            )
        })
    }

    /// Checks every mode: a frequency above zero, a damping ratio in
    /// [0, 1), a finite shape value at each point.
    pub fn validate(&self) -> Result<()> {
        if self.points.is_empty() || self.modes.is_empty() {
            return Err(Error::model(
                "points",
                "needs one point and one mode at least",
            ));
        }
        for (r, m) in self.modes.iter().enumerate() {
            let field = |f: &str| format!("modes[{r}].{f}");
            require_positive(&field("frequency_hz"), m.frequency_hz)?;
            if !(m.damping_ratio >= 0.0 && m.damping_ratio < 1.0) {
                return Err(Error::model(
                    field("damping_ratio"),
                    format!("must lie in [0, 1), got {}", m.damping_ratio),
                ));
            }
            if m.shape.len() != self.points.len() || m.shape.iter().any(|v| !v.is_finite()) {
                return Err(Error::model(
                    field("shape"),
                    format!(
                        "needs one finite value per point ({}), got {:?}",
                        self.points.len(),
                        m.shape
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The receptance `H_pq` at `frequency_hz` (m/N).
    pub fn receptance(&self, p: usize, q: usize, frequency_hz: f64) -> Complex64 {
        self.receptance_between(Site::Point(p), Site::Point(q), 2.0 * PI * frequency_hz)
    }

    /// The receptance from a force at `from` to the motion at `to`, at
    /// angular frequency `omega` (rad/s): `Σ_r φ_r(to) φ_r(from) / D_r(ω)`.
    pub fn receptance_between(&self, to: Site, from: Site, omega: f64) -> Complex64 {
        self.modes
            .iter()
            .map(|m| {
                let wr = 2.0 * PI * m.frequency_hz;
                m.at(to) * m.at(from)
                    / Complex64::new(wr * wr - omega * omega, 2.0 * m.damping_ratio * wr * omega)
            })
            .sum()
    }
}

/// A small lumped model: masses at named points, springs between two points
/// or a point and the ground, and proportional damping `C = α M + β K`
/// (Rayleigh), which keeps the modes real.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Lumped {
    /// The points' names.
    pub points: Vec<String>,
    /// Each point's mass, kg.
    pub masses: Vec<f64>,
    /// Springs: the two points' indices (`None`: the ground) and the
    /// stiffness, N/m.
    pub springs: Vec<(usize, Option<usize>, f64)>,
    /// Rayleigh damping's mass factor α, 1/s.
    pub alpha: f64,
    /// Rayleigh damping's stiffness factor β, s.
    pub beta: f64,
}

impl Lumped {
    /// The stiffness matrix.
    pub fn stiffness(&self) -> nalgebra::DMatrix<f64> {
        let n = self.points.len();
        let mut k = nalgebra::DMatrix::zeros(n, n);
        for &(a, b, s) in &self.springs {
            k[(a, a)] += s;
            if let Some(b) = b {
                k[(b, b)] += s;
                k[(a, b)] -= s;
                k[(b, a)] -= s;
            }
        }
        k
    }

    /// The modes, lowest first: `K φ = ω² M φ` solved as the symmetric
    /// problem `M^{-1/2} K M^{-1/2} ψ = ω² ψ`, `φ = M^{-1/2} ψ`, each shape
    /// signed so that its largest value is positive; `ζ_r = α/(2ω_r) +
    /// β ω_r/2`.
    pub fn modes(&self) -> Result<PointModes> {
        let n = self.points.len();
        if self.masses.len() != n {
            return Err(Error::model("masses", "needs one mass per point"));
        }
        for (i, &m) in self.masses.iter().enumerate() {
            require_positive(&format!("masses[{i}]"), m)?;
        }
        for (i, &(a, b, s)) in self.springs.iter().enumerate() {
            if a >= n || b.is_some_and(|b| b >= n || b == a) {
                return Err(Error::model(
                    format!("springs[{i}]"),
                    "must join two distinct points, or a point and the ground",
                ));
            }
            require_positive(&format!("springs[{i}]"), s)?;
        }
        require_non_negative("alpha", self.alpha)?;
        require_non_negative("beta", self.beta)?;
        let scale: Vec<f64> = self.masses.iter().map(|m| 1.0 / m.sqrt()).collect();
        let k = self.stiffness();
        let a = nalgebra::DMatrix::from_fn(n, n, |i, j| scale[i] * k[(i, j)] * scale[j]);
        let eigen = nalgebra::SymmetricEigen::new(a);
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&i, &j| eigen.eigenvalues[i].total_cmp(&eigen.eigenvalues[j]));
        let top = eigen.eigenvalues.iter().cloned().fold(0.0, f64::max);
        let mut modes = Vec::with_capacity(n);
        for r in order {
            let w2 = eigen.eigenvalues[r];
            // a free structure's rigid-body eigenvalue is zero to rounding
            if w2.is_nan() || w2 <= 1e-9 * top {
                return Err(Error::model(
                    "springs",
                    "the structure has a rigid-body mode: hold it to the ground",
                ));
            }
            let wr = w2.sqrt();
            let mut shape: Vec<f64> = (0..n)
                .map(|i| scale[i] * eigen.eigenvectors[(i, r)])
                .collect();
            let largest = shape
                .iter()
                .cloned()
                .fold(0.0, |m: f64, v| if v.abs() > m.abs() { v } else { m });
            if largest < 0.0 {
                shape.iter_mut().for_each(|v| *v = -*v);
            }
            modes.push(ShapedMode {
                frequency_hz: wr / (2.0 * PI),
                damping_ratio: self.alpha / (2.0 * wr) + self.beta * wr / 2.0,
                shape,
            });
        }
        let modes = PointModes {
            points: self.points.clone(),
            modes,
        };
        modes.validate()?;
        Ok(modes)
    }
}

/// The tests' chain: ground - 4e4 N/m - 2 kg ("drive") - 1e4 N/m - 1 kg
/// ("tip"), with Rayleigh damping `alpha`, `beta` (modes at 13.5 and
/// 26.5 Hz).
#[cfg(test)]
pub(crate) fn two_mass_chain(alpha: f64, beta: f64) -> Lumped {
    Lumped {
        points: vec!["drive".into(), "tip".into()],
        masses: vec![2.0, 1.0],
        springs: vec![(0, None, 4.0e4), (0, Some(1), 1.0e4)],
        alpha,
        beta,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chain() -> Lumped {
        two_mass_chain(0.0, 0.0)
    }

    /// The two-mass chain's frequencies are the closed-form roots of
    /// `det(K − ω² M) = 0`, and its receptance from the modes is the
    /// inverse of the dynamic stiffness `K − ω² M` to rounding.
    #[test]
    fn a_two_mass_chain_has_its_closed_form_modes_and_receptance() {
        let c = chain();
        let modes = c.modes().unwrap();
        // (k1 + k2 − 2ω²)(k2 − ω²) − k2² = 0: 2λ² − (k1 + 3 k2) λ + k1 k2 = 0
        let (k1, k2): (f64, f64) = (4.0e4, 1.0e4);
        let disc = ((k1 + 3.0 * k2).powi(2) - 8.0 * k1 * k2).sqrt();
        let roots = [(k1 + 3.0 * k2 - disc) / 4.0, (k1 + 3.0 * k2 + disc) / 4.0];
        for (m, l) in modes.modes.iter().zip(roots) {
            let w = 2.0 * PI * m.frequency_hz;
            assert!((w * w / l - 1.0).abs() < 1e-12, "{} vs {l}", w * w);
        }
        let w = 2.0 * PI * 10.0;
        let k = c.stiffness();
        let d = nalgebra::Matrix2::new(
            k[(0, 0)] - 2.0 * w * w,
            k[(0, 1)],
            k[(1, 0)],
            k[(1, 1)] - w * w,
        );
        let h = d.try_inverse().unwrap();
        for (p, q) in [(0, 0), (0, 1), (1, 1)] {
            let modal = modes.receptance(p, q, 10.0);
            assert!((modal.re / h[(p, q)] - 1.0).abs() < 1e-10, "{p}{q}");
            assert!(modal.im.abs() < 1e-15);
        }
    }

    #[test]
    fn a_chain_free_of_the_ground_is_refused() {
        let mut c = chain();
        c.springs.remove(0);
        let e = c.modes().unwrap_err().to_string();
        assert!(e.contains("rigid-body"), "{e}");
    }
}
