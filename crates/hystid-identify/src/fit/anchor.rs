//! The first mode's mass, damping and stiffness held to what the most
//! linear level allows.
//!
//! The smallest level's FRF is the structure's most nearly linear one: its
//! SDOF estimate (`m, c, k` of the stuck joint) is the anchor. A fit may
//! move the mass a decade either way, the stiffness two decades down (the
//! joint takes its share of the stuck stiffness) and one up, the damping
//! up to two decades above and down to nothing (a joint can carry all of
//! a jointed structure's dissipation, as on the F-16); never to a mass of
//! 1e-13 kg, which a fit on a recording with a strong effect its model
//! lacks would otherwise reach. A fit that ends at
//! one of these bounds has gone astray: see [`LinearAnchor::astray`].

use super::linear::SdofEstimate;
use super::params::{ParameterSet, Target};
use crate::harmonics::Quantity;
use crate::model::Model;
use serde::{Deserialize, Serialize};

/// Decades a parameter may move below and above its anchor.
const MASS_DECADES: (f64, f64) = (1.0, 1.0);
const STIFFNESS_DECADES: (f64, f64) = (2.0, 1.0);
// unbounded below: 10^-∞ = 0
const DAMPING_DECADES: (f64, f64) = (f64::INFINITY, 2.0);

/// The smallest level's linear estimate of the first mode.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LinearAnchor {
    /// kg (V s²/m on a voltage reference).
    pub mass: f64,
    /// N s/m (V s/m).
    pub damping: f64,
    /// N/m (V/m).
    pub stiffness: f64,
    /// The smallest level's linear fit's RMS relative residual.
    #[serde(default)]
    pub residual: f64,
    /// What the FRFs are referred to: the estimate's units follow it.
    #[serde(default = "force")]
    pub reference: Quantity,
}

fn force() -> Quantity {
    Quantity::Force
}

impl LinearAnchor {
    /// The anchor of an SDOF estimate of FRFs referred to `reference`;
    /// none where it is not a physical mode (a value that is not finite and
    /// positive).
    pub fn of(e: &SdofEstimate, reference: Quantity) -> Option<LinearAnchor> {
        let ok = |v: f64| v.is_finite() && v > 0.0;
        (ok(e.mass) && ok(e.damping) && ok(e.stiffness)).then_some(LinearAnchor {
            mass: e.mass,
            damping: e.damping,
            stiffness: e.stiffness,
            residual: e.relative_rms_residual,
            reference,
        })
    }

    /// The range a target may take, if the anchor bounds it.
    pub fn range(&self, target: &Target) -> Option<[f64; 2]> {
        let (value, (below, above)) = match target {
            Target::Mass { mode: 0 } => (self.mass, MASS_DECADES),
            Target::Stiffness { mode: 0 } => (self.stiffness, STIFFNESS_DECADES),
            Target::Damping { mode: 0 } => (self.damping, DAMPING_DECADES),
            _ => return None,
        };
        Some([value * 10f64.powf(-below), value * 10f64.powf(above)])
    }

    /// `set` with the first mode's `m, c, k` bounded by the anchor, each
    /// range widened to hold its value in `start` (a start outside would be
    /// clamped: a fit starts where its caller put it).
    pub fn bound(&self, mut set: ParameterSet, start: &Model) -> ParameterSet {
        for p in &mut set.parameters {
            let Some([lo, hi]) = self.range(&p.target) else {
                continue;
            };
            let at_start = p.read(start).map(f64::abs).unwrap_or(f64::NAN);
            let (lo, hi) = if at_start.is_finite() && at_start > 0.0 {
                (lo.min(at_start), hi.max(at_start))
            } else {
                (lo, hi)
            };
            p.bounds = [p.bounds[0].max(lo), p.bounds[1].min(hi)];
        }
        set
    }

    /// The names of `set`'s anchored parameters whose `values` sit at the
    /// ends of the anchor's range (within 1 %) or beyond them.
    pub fn astray(&self, set: &ParameterSet, values: &[f64]) -> Vec<String> {
        set.parameters
            .iter()
            .zip(values)
            .filter_map(|(p, &v)| {
                let [lo, hi] = self.range(&p.target)?;
                let v = v.abs();
                let inside = v > lo * 1.01 && v < hi * 0.99;
                (!inside).then(|| p.name.clone())
            })
            .collect()
    }

    /// [`LinearAnchor::astray`] of a model's first mode.
    pub fn astray_in(&self, model: &Model) -> Vec<String> {
        let set = ParameterSet::for_sdof(0);
        let values: Vec<f64> = set
            .parameters
            .iter()
            .map(|p| p.read(model).unwrap_or(f64::NAN))
            .collect();
        self.astray(&set, &values)
    }

    /// One line naming the anchor, for reports.
    pub fn describe(&self) -> String {
        let unit = |name| crate::model::units::law_parameter_unit(None, name, self.reference);
        format!(
            "the smallest level's linear estimate: m = {:.4e} {}, c = {:.4e} {}, k = {:.4e} {}",
            self.mass,
            unit("mass"),
            self.damping,
            unit("damping"),
            self.stiffness,
            unit("stiffness")
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ModalModel;

    fn anchor() -> LinearAnchor {
        LinearAnchor {
            mass: 4.0,
            damping: 20.0,
            stiffness: 1e7,
            residual: 0.01,
            reference: Quantity::Force,
        }
    }

    #[test]
    fn the_first_modes_mass_is_held_within_a_decade_of_the_anchor() {
        let start =
            Model::with_joint(ModalModel::sdof(4.0, 20.0, 1e7).unwrap(), None, Vec::new()).unwrap();
        let set = anchor().bound(ParameterSet::for_sdof(0), &start);
        let bounds: Vec<[f64; 2]> = set.parameters.iter().map(|p| p.bounds).collect();
        // for_sdof: mass, damping, stiffness
        assert_eq!(bounds[0], [0.4, 40.0]);
        assert_eq!(bounds[1], [1e-30, 2000.0]);
        assert_eq!(bounds[2], [1e5, 1e8]);
        // clamped there, whatever the optimiser asks for
        let theta = [(1.3e-13f64).ln(), 20f64.ln(), 1e7f64.ln()];
        assert_eq!(set.values(&theta)[0], 0.4);
        assert_eq!(anchor().astray(&set, &set.values(&theta)), ["mass"]);
        assert!(anchor().astray(&set, &[4.2, 25.0, 9e6]).is_empty());
    }

    #[test]
    fn a_start_outside_the_anchors_range_widens_it_to_the_start() {
        let start = Model::with_joint(
            ModalModel::sdof(100.0, 20.0, 1e7).unwrap(),
            None,
            Vec::new(),
        )
        .unwrap();
        let set = anchor().bound(ParameterSet::for_sdof(0), &start);
        assert_eq!(set.parameters[0].bounds, [0.4, 100.0]);
    }

    #[test]
    fn a_model_beyond_the_range_is_astray() {
        let far = ModalModel::sdof(1e-3, 1.0, 1e7).unwrap();
        let far = Model::with_joint(far, None, Vec::new()).unwrap();
        assert_eq!(anchor().astray_in(&far), ["mass"]);
        let near = ModalModel::sdof(1.0, 20.0, 1e7).unwrap();
        let near = Model::with_joint(near, None, Vec::new()).unwrap();
        assert!(anchor().astray_in(&near).is_empty());
    }
}
