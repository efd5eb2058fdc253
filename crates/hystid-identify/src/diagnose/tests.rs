//! The diagnosis's unit tests: its account in words, the drop cascade, and
//! the best refit kept of each set of effects.

use super::conclude::explain;
use super::*;
use crate::harmonics::Quantity::Force;

/// The summary's harmonics beside H1 leave out those at the noise (no
/// "H2 100.0 % → H2 100.0 %" where there are no even harmonics), and
/// keep those the model is judged on.
#[test]
fn the_summary_leaves_out_harmonics_at_the_noise() {
    let fit = |h2: f64, h3: f64| ModelFit {
        parameters: BTreeMap::new(),
        error_relative: 0.05,
        error_relative_per_harmonic: [(1, 0.05), (2, h2), (3, h3)].into(),
        chi2: 100.0,
        chi2_per_dof: 1.2,
    };
    let features = ResidualFeatures {
        chi2_per_dof_by_harmonic: [(1, 1.2), (2, 1.0), (3, 6.0)].into(),
        chi2_per_dof_by_level: Vec::new(),
        growth_with_level: 0.0,
        level_independent_share: 0.0,
        peak_shift_hz: Vec::new(),
        peak_ratio: Vec::new(),
        peak_shift_trend: 0.0,
        peak_ratio_trend: 0.0,
    };
    let added = [SelectedEffect {
        effect: Effect::CubicStiffness,
        parameters: BTreeMap::new(),
    }];
    let s = explain(
        &fit(1.0, 0.4),
        &features,
        &[],
        &added,
        &fit(1.0, 0.1),
        true,
        Force,
    );
    assert!(!s.contains("H2"), "{s}");
    assert!(s.contains("(H3 40.0 % → H3 10.0 %)"), "{s}");
    // every harmonic beside H1 at the noise: no empty parentheses
    let quiet = ResidualFeatures {
        chi2_per_dof_by_harmonic: [(1, 1.2), (2, 1.0), (3, 1.0)].into(),
        ..features
    };
    let s = explain(
        &fit(1.0, 0.9),
        &quiet,
        &[],
        &added,
        &fit(1.0, 0.9),
        true,
        Force,
    );
    assert!(s.contains("in H1; χ²/dof"), "{s}");
}

/// The drop cascade on a toy model (its state: the effects it holds,
/// a refit without one always possible), `added` last in `chosen`.
fn cascade_of(
    chosen: &[Effect],
    unresolved: impl Fn(Effect, &Vec<Effect>) -> Option<String>,
) -> Cascade<Vec<Effect>> {
    let added = *chosen.last().expect("an addition");
    drop_cascade(
        chosen.to_vec(),
        chosen,
        added,
        unresolved,
        |gone, state, left| {
            assert!(state.contains(&gone) && !left.contains(&gone));
            Some(left.to_vec())
        },
    )
}

/// A cubic stiffness kept in round 2 loses its resolution once a second
/// mode comes in (round 3), and without it the mode loses its own: the
/// round is undone (the model of round 2, with the cubic stiffness,
/// stands) rather than the cascade ending with neither.
#[test]
fn an_addition_that_loses_its_resolution_without_what_it_displaced_is_undone() {
    use Effect::{CubicStiffness as Cubic, SecondMode as Mode, Shaker};
    let undone = cascade_of(&[Shaker, Cubic, Mode], |e, state| match e {
        Cubic if state.contains(&Mode) => Some("k3 straddles zero".into()),
        Mode if !state.contains(&Cubic) => Some("its flexibility straddles zero".into()),
        _ => None,
    });
    assert_eq!(
        undone,
        Cascade::Reverted {
            displaced: vec![Cubic],
            why: "its flexibility straddles zero".into()
        }
    );
    // the same, but the mode holds without the cubic stiffness: it
    // replaces it
    let replaced = cascade_of(&[Shaker, Cubic, Mode], |e, state| {
        (e == Cubic && state.contains(&Mode)).then(|| "k3 straddles zero".to_string())
    });
    assert_eq!(
        replaced,
        Cascade::Settled {
            state: vec![Shaker, Mode],
            chosen: vec![Shaker, Mode],
            dropped: vec![(Cubic, "k3 straddles zero".into())],
        }
    );
    // nothing unresolved: nothing dropped; a refit that fails stops the
    // cascade where it is
    let kept = cascade_of(&[Shaker, Cubic], |_, _| None);
    assert_eq!(
        kept,
        Cascade::Settled {
            state: vec![Shaker, Cubic],
            chosen: vec![Shaker, Cubic],
            dropped: vec![],
        }
    );
    let stuck = drop_cascade(
        vec![Shaker, Cubic, Mode],
        &[Shaker, Cubic, Mode],
        Mode,
        |e, _: &Vec<Effect>| (e == Cubic).then(|| "unresolved".to_string()),
        |_, _, _| None,
    );
    assert_eq!(
        stuck,
        Cascade::Settled {
            state: vec![Shaker, Cubic, Mode],
            chosen: vec![Shaker, Cubic, Mode],
            dropped: vec![],
        }
    );
}

fn refit(chi2: f64, mass: f64) -> Refit {
    Refit {
        model: Model {
            linear: crate::model::ModalModel::sdof(mass, 1.0, 1e4).unwrap(),
            joint: None,
            effects: Vec::new(),
        },
        pred: Prediction::default(),
        chi2,
    }
}

/// After a drop, the refit of a set of effects seen before in a better
/// fit gives way to it (whatever the order the effects were kept in);
/// a better one is kept, and another set is its own.
#[test]
fn a_drop_never_leaves_a_worse_fit_of_effects_seen_before() {
    let mut seen = BestBySet::default();
    let (shaker, cubic) = (Effect::Shaker, Effect::CubicStiffness);
    seen.note(&[shaker], &refit(1254.8, 1.0));
    seen.note(&[shaker, cubic], &refit(1115.9, 2.0));
    // round 3's cascade: cubic dropped, a cold refit of the shaker alone
    // settles higher than round 1's
    let r = seen.better(&[shaker], refit(3041.7, 3.0));
    assert_eq!((r.chi2, r.model.linear.modes[0].residue), (1254.8, 1.0));
    // one lower is kept, and is what the set gives from then on
    let r = seen.better(&[shaker], refit(1200.0, 4.0));
    assert_eq!(r.chi2, 1200.0);
    assert_eq!(seen.better(&[shaker], refit(1300.0, 5.0)).chi2, 1200.0);
    // the set, not the order
    assert_eq!(
        seen.better(&[cubic, shaker], refit(2000.0, 6.0)).chi2,
        1115.9
    );
    // a set not seen is the refit itself
    assert_eq!(seen.better(&[cubic], refit(5000.0, 7.0)).chi2, 5000.0);
}
