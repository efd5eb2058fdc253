//! Harmonic balance of a structure seen at several points
//! ([`crate::model::PointModes`]) with one joint between two points.
//!
//! With the force `F` at the drive point `d` and the joint's force `g` on
//! the relative motion `x_j = x_a − x_b`, each harmonic `k` obeys
//!
//! ```text
//! X_j,k = H_jd(kω) F δ_k1 − H_jj(kω) G_k
//! X_p,k = H_pd(kω) F δ_k1 − H_pj(kω) G_k
//! ```
//!
//! The first is the one-point balance `X = H (D F − G)` with the
//! receptance `H_jj` and the drive `D = H_jd/H_jj` at the fundamental
//! ([`LinearPart::drive`]), so the same solver finds the joint's motion
//! ([`JointReceptance`]); every point's motion then follows from the
//! joint's force harmonics `G_k = D F δ_k1 − X_j,k / H_jj(kω)`
//! ([`point_harmonics`]).

use super::{HbPoint, LinearPart};
use crate::error::Result;
use crate::model::{PointModes, Site};
use num_complex::Complex64;
use std::f64::consts::PI;

/// A [`PointModes`] structure as the joint between `ends` sees it, driven
/// at point `drive`.
#[derive(Clone, Copy, Debug)]
pub struct JointReceptance<'a> {
    /// The structure.
    pub structure: &'a PointModes,
    /// The drive point.
    pub drive: usize,
    /// The joint's ends (`None`: the ground).
    pub ends: (usize, Option<usize>),
}

impl JointReceptance<'_> {
    fn joint(&self) -> Site {
        Site::Across(self.ends.0, self.ends.1)
    }
}

impl LinearPart for JointReceptance<'_> {
    fn receptance(&self, omega: f64) -> Result<Complex64> {
        Ok(self
            .structure
            .receptance_between(self.joint(), self.joint(), omega))
    }

    fn drive(&self, omega: f64) -> Complex64 {
        let s = self.structure;
        s.receptance_between(self.joint(), Site::Point(self.drive), omega)
            / s.receptance_between(self.joint(), self.joint(), omega)
    }
}

/// Every point's displacement harmonics (`[point][harmonic]`, in the
/// solution's harmonic order, m) of a balance of `joint` solved at
/// `point.frequency_hz` and `point.force_amplitude`.
pub fn point_harmonics(joint: &JointReceptance<'_>, point: &HbPoint) -> Vec<Vec<Complex64>> {
    let s = joint.structure;
    let w = 2.0 * PI * point.frequency_hz;
    let f = point.force_amplitude;
    let j = joint.joint();
    let drive = Site::Point(joint.drive);
    (0..s.points.len())
        .map(|p| {
            point
                .harmonics
                .iter()
                .zip(&point.x)
                .map(|(&k, &xj)| {
                    let wk = w * k as f64;
                    let hjj = s.receptance_between(j, j, wk);
                    let forced = if k == 1 { f } else { 0.0 };
                    let g = joint.drive(wk) * forced - xj / hjj;
                    s.receptance_between(Site::Point(p), drive, wk) * forced
                        - s.receptance_between(Site::Point(p), j, wk) * g
                })
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hb::{HbOptions, HbSolver, odd_harmonics};
    use crate::model::{Jenkins, Lumped};
    use crate::sim::PointSimulator;

    /// The steady state of the two-mass chain with a Jenkins joint between
    /// its masses, driven at the first between its modes hard enough to
    /// slip: harmonic balance (odd harmonics to 15) gives each mass's
    /// fundamental receptance as the digital-filter simulation does after
    /// its transient has died away (8 s, 30 decay times of the slower
    /// mode), read over the last 36 whole periods: within 0.05 %
    /// (measured: 0.002 % and 0.008 %; the filters' `sinc²` factor is 7e-5
    /// at 18 Hz). The joint slips: the chain stuck (kd beside k2) or
    /// slipping freely (k2 alone) is more than 5 % away.
    #[test]
    fn harmonic_balance_of_a_joint_between_two_masses_is_the_simulators_steady_state() {
        let chain = crate::model::points::two_mass_chain(5.0, 2.0e-5);
        let structure = chain.modes().unwrap();
        let (kd, fd, amplitude, f) = (5.0e3, 2.0, 30.0, 18.0);
        let joint = JointReceptance {
            structure: &structure,
            drive: 0,
            ends: (0, Some(1)),
        };
        let mut solver = HbSolver::new(&HbOptions::with_harmonics(odd_harmonics(15))).unwrap();
        let mut jenkins = Jenkins::new(kd, fd).unwrap();
        let balance = solver
            .solve_point(&joint, &mut jenkins, f, amplitude, None)
            .unwrap();
        assert!(balance.converged, "{:?}", balance.failure);
        let by_hb = point_harmonics(&joint, &balance);

        let (fs, n, last) = (4000.0, 32_000, 8000);
        let force: Vec<f64> = (0..n)
            .map(|i| amplitude * (2.0 * PI * f * i as f64 / fs).cos())
            .collect();
        let mut sim = PointSimulator::new(
            &structure,
            0,
            (0, Some(1)),
            Jenkins::new(kd, fd).unwrap(),
            fs,
        )
        .unwrap();
        let run = sim.run(&force).unwrap();
        let fundamental = |x: &[f64]| -> Complex64 {
            let start = n - last;
            (start..n)
                .map(|i| x[i] * Complex64::from_polar(1.0, -2.0 * PI * f * i as f64 / fs))
                .sum::<Complex64>()
                * (2.0 / last as f64)
        };
        let reference = fundamental(&force);
        assert!((reference.norm() / amplitude - 1.0).abs() < 1e-9);
        let one = balance.harmonics.iter().position(|&k| k == 1).unwrap();
        for p in 0..2 {
            let simulated = fundamental(&run.displacement[p]) / reference;
            let balanced = by_hb[p][one] / amplitude;
            let off = (simulated - balanced).norm() / balanced.norm();
            assert!(off < 5e-4, "point {p}: {simulated} vs {balanced} ({off:e})");
        }
        // the joint's own motion, the balance's unknowns
        let simulated = fundamental(&run.joint_displacement) / reference;
        let balanced = balance.x[one] / amplitude;
        assert!((simulated - balanced).norm() < 5e-4 * balanced.norm());
        for k2 in [1.0e4 + kd, 1.0e4] {
            let linear = Lumped {
                springs: vec![(0, None, 4.0e4), (0, Some(1), k2)],
                ..chain.clone()
            };
            let h = linear.modes().unwrap().receptance(0, 0, f);
            let balanced = by_hb[0][one] / amplitude;
            assert!((h - balanced).norm() > 0.05 * balanced.norm(), "k2 {k2}");
        }
    }
}
