//! What makes a reported parameter less than a plain result: at a bound of
//! its fit, outside its physical domain, not identifiable, or not resolved
//! by the data. One test for every report (`run`, `diagnose`, `identify`),
//! so the same estimate carries the same flags wherever it is shown.

use crate::fit::Estimate;
pub use crate::model::units::{
    describe, force_drive, law_parameter_unit, parameter_unit, unit_suffix,
};
use crate::model::{Domain, Model};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Why a reported parameter is not a plain result.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Flag {
    /// At (within 1 % of) a bound of its fit: the data pushed it there, and
    /// its value is the bound's, not a measurement.
    AtBound,
    /// Outside what the quantity can physically be (a negative mass,
    /// stiffness or modal mass at a driving point, a negative slip force).
    NonPhysical,
    /// The data do not determine it: an interval without an end, or the
    /// fit said so.
    NotIdentifiable,
    /// Its 95 % interval includes zero or spans more than a factor of 10.
    Unresolved,
}

impl Flag {
    /// The flag in words.
    pub fn words(self) -> &'static str {
        match self {
            Flag::AtBound => "at a bound of its fit",
            Flag::NonPhysical => "non-physical",
            Flag::NotIdentifiable => "not identifiable",
            Flag::Unresolved => "not resolved (its interval includes zero or spans a factor > 10)",
        }
    }
}

/// The flags of estimate `e` of `name`, `at_bound` of its fit, whose law
/// says it lies in `domain`; `transfer`: the response is not at the
/// driving point (a mode may have a negative modal constant there).
pub fn flags_of(
    name: &str,
    e: &Estimate,
    at_bound: bool,
    domain: Option<Domain>,
    transfer: bool,
) -> Vec<Flag> {
    let v = e.value;
    let mut flags = Vec::new();
    if at_bound {
        flags.push(Flag::AtBound);
    }
    let leaf = name.rsplit('.').next().unwrap_or(name);
    let modal_constant = matches!(leaf, "modal_mass" | "residue" | "flexibility");
    // a driving point's modes have positive modal masses (a run's response
    // is the drive's); a transfer's take either sign
    let outside = !(transfer && modal_constant)
        && match domain {
            Some(Domain::Positive) => v.is_nan() || v <= 0.0,
            Some(Domain::NonNegative) => v.is_nan() || v < 0.0,
            Some(Domain::Range { min, max }) => !(v > min && v < max),
            Some(Domain::Signed) | None => false,
        };
    let negative_mode = !transfer && modal_constant && v < 0.0;
    if outside || negative_mode {
        flags.push(Flag::NonPhysical);
    }
    let [lo, hi] = e.ci95;
    if !determined(e) {
        flags.push(Flag::NotIdentifiable);
    } else if (lo <= 0.0 && hi >= 0.0)
        || (lo > 0.0 && hi / lo > 10.0)
        || (hi < 0.0 && lo / hi > 10.0)
    {
        flags.push(Flag::Unresolved);
    }
    flags
}

/// Whether the data determine `e`: its fit said so and its 95 % interval
/// has two finite ends. The one test behind both an estimate's
/// `identifiable` in a report and its `not_identifiable` flag.
pub fn determined(e: &Estimate) -> bool {
    let [lo, hi] = e.ci95;
    e.identifiable && lo.is_finite() && hi.is_finite()
}

/// The flagged ones of `estimates` of `model`'s parameters with their
/// flags, `at_bound` naming those that ended at a bound of their fit (as
/// [`crate::fit::FitResult::at_bound`] does); a parameter without a flag is
/// left out. `transfer` as [`flags_of`] takes it. Each estimate's
/// `identifiable` is set to [`determined`], so that a report says the same
/// in it and in its flags.
pub fn flag_estimates(
    estimates: &mut BTreeMap<String, Estimate>,
    model: &Model,
    at_bound: &[String],
    transfer: bool,
) -> BTreeMap<String, Vec<Flag>> {
    for e in estimates.values_mut() {
        e.identifiable = determined(e);
    }
    estimates
        .iter()
        .filter_map(|(name, e)| {
            let domain = describe(name, model).1;
            let flags = flags_of(name, e, at_bound.contains(name), domain, transfer);
            (!flags.is_empty()).then(|| (name.clone(), flags))
        })
        .collect()
}

/// `flags` as the terminal shows them after a parameter's line: `  FLAG:
/// at a bound of its fit; non-physical` (empty without flags).
pub fn flag_words(flags: &[Flag]) -> String {
    if flags.is_empty() {
        return String::new();
    }
    let words: Vec<&str> = flags.iter().map(|f| f.words()).collect();
    format!("  FLAG: {}", words.join("; "))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::ParameterSet;

    fn estimate(value: f64, ci95: [f64; 2]) -> Estimate {
        Estimate {
            value,
            ci95,
            identifiable: true,
            note: None,
            bootstrap_ci95: None,
        }
    }

    fn at_bound(v: f64, bounds: [f64; 2]) -> bool {
        ParameterSet {
            parameters: vec![crate::fit::Parameter {
                name: "p".into(),
                target: crate::fit::Target::Mass { mode: 0 },
                transform: crate::fit::Transform::Log,
                bounds,
            }],
        }
        .at_bounds(&[v])[0]
    }

    /// With a voltage drive every parameter's unit is stated in volts where
    /// it was in newtons: no unit of any element law or of the linear part
    /// keeps an N; with a force drive they are left as they are.
    #[test]
    fn units_follow_the_drive() {
        use crate::harmonics::Quantity::{Force, Voltage};
        use crate::model::units::in_drive_units;
        let mut units: Vec<&'static str> = crate::model::ElementKind::ALL
            .iter()
            .flat_map(|k| k.description().parameters.iter().map(|p| p.unit))
            .collect();
        let model = Model::new(
            crate::model::ModalModel::sdof(1.0, 1.0, 1.0).unwrap(),
            vec![],
        )
        .unwrap();
        for name in [
            "mass",
            "damping",
            "stiffness",
            "mode_2.residue",
            "second_mode.flexibility",
        ] {
            units.push(describe(name, &model).0);
        }
        for u in units {
            assert_eq!(in_drive_units(u, Force), u);
            let v = in_drive_units(u, Voltage);
            assert!(
                !v.split(|c: char| !c.is_alphanumeric()).any(|t| t == "N"),
                "{u} -> {v}"
            );
        }
        assert_eq!(in_drive_units("kg", Voltage), "V s²/m");
        assert_eq!(in_drive_units("N/m³", Voltage), "V/m³");
    }

    /// The complaints' cases: a damping ratio at its 1e-5 bound, a negative
    /// modal mass, an interval through zero, an unbounded one.
    #[test]
    fn parameters_at_a_bound_non_physical_or_unresolved_are_flagged() {
        let e = estimate(1e-5, [1e-5, 2e-5]);
        assert_eq!(
            flags_of(
                "second_mode.damping_ratio",
                &e,
                at_bound(1e-5, [1e-5, 0.9]),
                Some(Domain::Range { min: 0.0, max: 1.0 }),
                false
            ),
            vec![Flag::AtBound]
        );
        let e = estimate(-1.39e5, [-2e5, -1e5]);
        assert_eq!(
            flags_of(
                "second_mode.modal_mass",
                &e,
                false,
                Some(Domain::Positive),
                false
            ),
            vec![Flag::NonPhysical]
        );
        // in a transfer, a mode may have a negative modal constant
        assert_eq!(
            flags_of(
                "second_mode.modal_mass",
                &e,
                false,
                Some(Domain::Positive),
                true
            ),
            vec![]
        );
        let e = estimate(0.2, [-0.1, 0.5]);
        assert_eq!(
            flags_of(
                "quadratic_damping.c2",
                &e,
                at_bound(0.2, [0.0, 1e30]),
                Some(Domain::NonNegative),
                false
            ),
            vec![Flag::Unresolved]
        );
        let mut e = estimate(999.9997, [108.8, f64::INFINITY]);
        e.identifiable = false;
        assert_eq!(
            flags_of(
                "n",
                &e,
                at_bound(999.9997, [1.0, 1000.0]),
                Some(Domain::Positive),
                false
            ),
            vec![Flag::AtBound, Flag::NotIdentifiable]
        );
        let e = estimate(2.4e7, [2.39e7, 2.41e7]);
        assert!(
            flags_of(
                "kd",
                &e,
                at_bound(2.4e7, [1.0, 1e30]),
                Some(Domain::Positive),
                false
            )
            .is_empty()
        );
    }
}
