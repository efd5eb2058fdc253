//! The candidate effects the diagnosis can add to a model, as data.
//!
//! Each candidate is one file implementing [`Candidate`]: how strongly the
//! residual's features point at it, the models it starts from (sized from
//! the residual), its parameters in a fitted model, which of them decide
//! whether the data resolve it, and the sentence that explains it. The
//! [`Effect`] names come from one registry line each below; the diagnosis
//! loop itself knows no candidate by name.

mod bilinear_stiffness;
mod bouc_wen_joint;
mod clearance;
mod cubic_stiffness;
mod hysteretic_mode;
mod iwan4_joint;
mod quadratic_damping;
mod second_mode;
mod shaker;

use super::{DiagnoseOptions, Refit, ResidualFeatures, SelectedEffect};
use crate::error::Result;
use crate::extract::NonlinearFrf;
use crate::fit::{Estimate, FitData, HbPredictor, Prediction};
use crate::model::{ElementKind, ElementSpec, Model};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// What a candidate's starts are made from: the model it is added to and
/// its prediction, the data judged, the recording's FRFs and the options.
pub struct Context<'a> {
    /// The model the effect is added to, with its prediction and `χ²`.
    pub(crate) current: &'a Refit,
    /// The data judged.
    pub(crate) data: &'a FitData,
    /// The nonlinear FRFs (for a candidate that identifies afresh).
    pub(crate) frf: &'a NonlinearFrf,
    /// The diagnosis options (the user's fit options among them).
    pub(crate) options: &'a DiagnoseOptions,
    /// The predictor.
    pub(crate) predictor: &'a HbPredictor,
    /// Identifications afresh by their number of modes, shared by the
    /// candidates of one diagnosis (see [`Context::identified_with_modes`]).
    pub(crate) identified: &'a Identified,
    /// The `χ²` the noise alone gives on `data`.
    pub(crate) expected_chi2: f64,
}

/// Identifications afresh of a diagnosis's FRFs with the user's fit options,
/// by number of modes: they depend on neither the model a candidate is added
/// to nor the round, and one takes seconds.
pub(crate) type Identified = std::sync::Mutex<BTreeMap<usize, Option<Model>>>;

/// The recording identified afresh with `modes` modes and the user's fit
/// options (`None`: it failed): only a start, polished by the refit, so no
/// bootstrap, no second optimiser, and a third of the simplex's iterations.
fn identify_afresh(
    frf: &NonlinearFrf,
    options: &DiagnoseOptions,
    predictor: &HbPredictor,
    modes: usize,
) -> Option<Model> {
    let opts = crate::fit::FitOptions {
        modes,
        band_hz: options.band_hz.or(options.fit.band_hz),
        bootstrap: 0,
        second_optimiser: false,
        max_iterations: options.fit.max_iterations.div_ceil(3),
        ..options.fit.clone()
    };
    crate::fit::identify(frf, &opts, predictor, None)
        .ok()
        .map(|f| f.model)
}

/// Makes the identifications afresh that `modes` asks for and `identified`
/// does not hold yet, side by side.
pub(crate) fn identify_beforehand(
    identified: &Identified,
    modes: &[usize],
    frf: &NonlinearFrf,
    options: &DiagnoseOptions,
    predictor: &HbPredictor,
) {
    use rayon::prelude::*;
    let mut missing: Vec<usize> = {
        let cache = identified.lock().unwrap_or_else(|e| e.into_inner());
        modes
            .iter()
            .copied()
            .filter(|m| !cache.contains_key(m))
            .collect()
    };
    missing.sort_unstable();
    missing.dedup();
    let made: Vec<(usize, Option<Model>)> = missing
        .into_par_iter()
        .map(|m| (m, identify_afresh(frf, options, predictor, m)))
        .collect();
    identified
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .extend(made);
}

impl Context<'_> {
    /// The model the effect is added to.
    pub fn model(&self) -> &Model {
        &self.current.model
    }

    /// Its prediction.
    pub fn pred(&self) -> &Prediction {
        &self.current.pred
    }

    /// The structure's viscous damping and its stiffness with the joint's
    /// stick stiffness (a contact or clearance is visible against the
    /// total): the scales an effect's size is probed at.
    pub fn damping_and_stiffness(&self) -> (f64, f64) {
        let (_, c, k) = self.model().linear.as_mck().unwrap_or((1.0, 1.0, 1.0));
        (c, k + self.model().stick_stiffness())
    }

    /// The largest displacement and velocity amplitudes in the data.
    pub fn amplitudes(&self) -> (f64, f64) {
        super::amplitudes(self.data)
    }

    /// The model with an element of one size parameter added at starting
    /// sizes from the residual: the best of a scan around `probe` (both
    /// signs if `signed`), and the Gauss–Newton step where it differs by more
    /// than a factor 2 (the scan's best `χ²` before the refit is not always
    /// the basin of the best after it).
    pub fn sized_starts(
        &self,
        with: &dyn Fn(f64) -> ElementSpec,
        probe: f64,
        signed: bool,
    ) -> Vec<Model> {
        let Some((v, _, gn)) = super::scan_start(
            self.model(),
            self.data,
            self.pred(),
            self.predictor,
            with,
            probe,
            signed,
        ) else {
            return Vec::new();
        };
        let mut sizes = vec![v];
        sizes.extend(gn.filter(|g| g / v > 2.0 || g / v < 0.5));
        sizes
            .into_iter()
            .map(|s| self.with_element(with(s)))
            .collect()
    }

    /// True when the model the effect is added to leaves more than
    /// [`super::ASTRAY_CHI2_PER_DOF`] times the noise's `χ²`: it may have
    /// gone astray (a joint bent to stand in for what is missing), and a
    /// start afresh is worth its cost. Within it, the residual's own
    /// features locate what is missing as well as an identification afresh
    /// would, which costs seconds.
    pub fn astray(&self) -> bool {
        super::far_from_noise(self.current.chi2, self.expected_chi2)
    }

    /// The recording identified afresh with `modes` modes and the user's
    /// fit options (`None`: it failed), computed once per diagnosis.
    pub fn identified_with_modes(&self, modes: usize) -> Option<Model> {
        let cached = |i: &Identified| {
            let cache = i.lock().unwrap_or_else(|e| e.into_inner());
            cache.get(&modes).cloned()
        };
        if let Some(m) = cached(self.identified) {
            return m;
        }
        // not held while identifying: the identification runs in parallel
        // itself, and a thread waiting in it may take up another candidate
        // that asks for the same (made beforehand, see
        // [`Candidate::identifications`]; made twice here at worst, equal)
        let m = identify_afresh(self.frf, self.options, self.predictor, modes);
        let mut cache = self.identified.lock().unwrap_or_else(|e| e.into_inner());
        cache.entry(modes).or_insert(m).clone()
    }

    /// The model with `element` added as an effect.
    pub fn with_element(&self, element: ElementSpec) -> Model {
        self.model().with_effect(element)
    }
}

/// For a candidate that replaces the joint law by `law`: the current joint's
/// stick stiffness and slip force (what every law's start is read from),
/// when it has both and is not of `law` already.
pub(super) fn replaceable_joint(model: &Model, law: ElementKind) -> Option<(f64, f64)> {
    let joint = model.joint.as_ref()?;
    let d = joint.kind().description();
    if joint.kind() == law || !d.is_joint() {
        return None;
    }
    Some((
        joint.value_of(crate::model::Role::StickStiffness)?,
        joint.value_of(crate::model::Role::SlipForce)?,
    ))
}

/// The parameters a joint law of `size` free parameters adds in place of
/// `before`'s joint (at least one: a swap must earn something).
pub(super) fn replacing_parameters(size: usize, before: &Model) -> usize {
    let had = before
        .joint
        .as_ref()
        .map_or(0, |j| j.kind().description().parameters.len());
    size.saturating_sub(had).max(1)
}

/// How strongly a residual points at the joint law itself: it grows with
/// level from nothing at the lowest, where every law sticks.
pub(super) fn joint_misfit_score(f: &ResidualFeatures) -> f64 {
    2.0 * (1.0 - f.level_independent_share) + f.growth_with_level.max(0.0)
}

/// Of `models`, the one that fits best as it stands (one prediction each,
/// warm-started from the current model's), with its `χ²`.
pub(super) fn best_as_it_stands(
    cx: &Context<'_>,
    models: impl Iterator<Item = Model>,
) -> Option<(f64, Model)> {
    use crate::fit::FrfPredictor;
    models
        .filter_map(|m| {
            let pred = cx
                .predictor
                .predict_from(&m, cx.data, Some(cx.pred()))
                .ok()?;
            let chi2 = crate::fit::problem::chi_square(cx.data, &pred);
            chi2.is_finite().then_some((chi2, m))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

/// Everything the diagnosis knows about one candidate effect.
pub trait Candidate: Sync {
    /// The element law it adds (`None`: it is not an element, e.g. a mode).
    fn law(&self) -> Option<ElementKind>;

    /// How many parameters it adds (the information criterion's `p`).
    fn size(&self) -> usize {
        self.law().map_or(0, |k| k.description().parameters.len())
    }

    /// Whether a diagnosis tries it unless told which candidates to try
    /// (one whose refit costs many times the others' is tried when named).
    fn by_default(&self) -> bool {
        true
    }

    /// What it adds, in a few words for the command's help, where its name
    /// does not say it all (none: the name does).
    fn help(&self) -> Option<&'static str> {
        None
    }

    /// Whether it is tried only on a model left above
    /// [`super::ASTRAY_CHI2_PER_DOF`] times the noise's `χ²` (one whose
    /// refit costs as much as the rest of a diagnosis is not spent on a
    /// residual that is nearly noise).
    fn only_far_from_noise(&self) -> bool {
        false
    }

    /// Whether it replaces the model's joint law rather than adding an
    /// effect (its parameters are then the joint's, named plainly).
    fn replaces_joint(&self) -> bool {
        false
    }

    /// Whether `model` can take it (a law the joint already follows cannot
    /// replace it).
    fn applies_to(&self, _model: &Model) -> bool {
        true
    }

    /// Why it does not apply to FRFs measured against `reference` (the
    /// shaker on a measured force), where it offers no start for that
    /// reason: the diagnosis says it is not applicable, not that it failed.
    fn not_applicable_to(&self, _reference: crate::harmonics::Quantity) -> Option<&'static str> {
        None
    }

    /// How many parameters it adds to `before` (the information
    /// criterion's `p`): its size, unless it replaces a part of `before`.
    fn added_parameters(&self, _before: &Model) -> usize {
        self.size()
    }

    /// For a candidate that adds a mode: which mode of `model` it added
    /// (`None`: it adds no mode, or `model` does not hold it). A fit names a
    /// mode by its place among the modes, so its parameters are found by
    /// this, not by the candidate's name.
    fn added_mode(&self, _model: &Model) -> Option<usize> {
        None
    }

    /// The name its parameters are reported under in `model`: its own, or
    /// the label of the mode it added (`second_mode` unless the model holds
    /// further modes of the user's or hysteretic ones).
    fn label(&self, effect: &str, model: &Model) -> String {
        self.added_mode(model)
            .map_or_else(|| effect.to_string(), |i| model.linear.label(i))
    }

    /// Its own parameter's name within a fitted parameter's `name` of
    /// `model`, if the parameter is its own (an effect's are prefixed with
    /// its [`Candidate::label`], a replacing joint's are the joint's plain
    /// names).
    fn own_parameter<'n>(&self, effect: &str, model: &Model, name: &'n str) -> Option<&'n str> {
        if self.replaces_joint() {
            let law = self.law()?.description();
            law.parameters
                .iter()
                .any(|p| p.name == name)
                .then_some(name)
        } else {
            let label = self.label(effect, model);
            name.strip_prefix(label.as_str())?.strip_prefix('.')
        }
    }

    /// How strongly the residual's features point at it (higher first).
    fn score(&self, features: &ResidualFeatures) -> f64;

    /// The models it is refitted from, each the current model with the
    /// effect added; empty when the residual offers no start.
    fn starts(&self, cx: &Context<'_>) -> Result<Vec<Model>>;

    /// The identifications afresh (by number of modes) its [`starts`] from
    /// `cx` would read: the diagnosis makes them before the candidates are
    /// refitted in parallel, with every thread, instead of one candidate
    /// making one while others wait for it.
    ///
    /// [`starts`]: Candidate::starts
    fn identifications(&self, _cx: &Context<'_>) -> Vec<usize> {
        Vec::new()
    }

    /// The models it is refitted from on a multisine's time-domain fit,
    /// each the current model with the effect added, sized on the residual
    /// per line ([`super::lines`]); empty when the lines offer no start or
    /// it is not traced there.
    fn line_starts(&self, _cx: &super::lines::LineContext<'_>) -> Vec<Model> {
        Vec::new()
    }

    /// The parameters that size it: the data must resolve one of these
    /// (an interval that excludes zero, not at a bound) for it to be kept;
    /// its shape parameters (a gap, a mode's frequency) may sit at a bound.
    fn size_parameters(&self) -> &'static [&'static str];

    /// A reason, beyond resolution, why a refit that lowered `χ²` is not
    /// this effect (a mode of negative modal mass): `name` and `estimate`
    /// are one of its parameters at the refit `model`.
    fn implausible(
        &self,
        _name: &str,
        _estimate: &Estimate,
        _model: &Model,
        _data: &FitData,
    ) -> Option<String> {
        None
    }

    /// Its parameters' values in `model` (which has it).
    fn parameters(&self, model: &Model, _data: &FitData) -> BTreeMap<String, f64> {
        let mut out = BTreeMap::new();
        for e in model.elements().filter(|e| Some(e.kind()) == self.law()) {
            for (n, v) in e.parameters() {
                out.insert(n.to_string(), v);
            }
        }
        out
    }

    /// How a parameter's estimate is reported (its name and interval as a
    /// user reads them): as fitted, unless the effect says otherwise.
    fn reported(&self, name: &str, estimate: Estimate) -> (String, Estimate) {
        (name.to_string(), estimate)
    }

    /// `model` without it (its last instance among the effects).
    fn remove(&self, model: &Model) -> Option<Model> {
        let mut m = model.clone();
        let i = m
            .effects
            .iter()
            .rposition(|e| Some(e.kind()) == self.law())?;
        m.effects.remove(i);
        Some(m)
    }

    /// Why the residual pointed at it, in a clause a sentence starts with.
    fn explain(&self, features: &ResidualFeatures, selected: &SelectedEffect) -> String;
}

/// The candidate registry: each effect's contract name and its candidate.
/// From it comes [`Effect`]; adding an effect is its own file and one line
/// here.
macro_rules! candidates {
    ($($effect:ident($name:literal, $candidate:expr)),+ $(,)?) => {
        /// A model extension the diagnosis can add.
        #[derive(
            Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize,
        )]
        pub enum Effect {
            $(
                #[doc = concat!("`", $name, "`.")]
                #[serde(rename = $name)]
                $effect,
            )+
        }

        impl Effect {
            /// Every effect, in the registry's order (which breaks ties of
            /// the ranking).
            pub const ALL: &'static [Effect] = &[$(Effect::$effect),+];

            /// The contract name.
            pub fn name(self) -> &'static str {
                match self {
                    $(Effect::$effect => $name,)+
                }
            }

            /// What the diagnosis knows about it.
            pub fn candidate(self) -> &'static dyn Candidate {
                match self {
                    $(Effect::$effect => &$candidate,)+
                }
            }
        }
    };
}

candidates! {
    SecondMode("second_mode", second_mode::SecondMode),
    CubicStiffness("cubic_stiffness", cubic_stiffness::CubicStiffness),
    BilinearStiffness("bilinear_stiffness", bilinear_stiffness::BilinearStiffness),
    QuadraticDamping("quadratic_damping", quadratic_damping::QuadraticDamping),
    Clearance("clearance", clearance::Clearance),
    Iwan4Joint("iwan4_joint", iwan4_joint::Iwan4Joint),
    BoucWenJoint("bouc_wen_joint", bouc_wen_joint::BoucWenJoint),
    HystereticMode("hysteretic_mode", hysteretic_mode::HystereticMode),
    Shaker("shaker", shaker::Shaker),
}

impl Effect {
    /// Parses a contract name.
    pub fn from_name(name: &str) -> Option<Effect> {
        Effect::ALL.iter().copied().find(|e| e.name() == name)
    }

    /// How many parameters it adds.
    pub fn size(self) -> usize {
        self.candidate().size()
    }

    /// The candidates as `--candidates`' help lists them, from the
    /// registry: each name, with what it adds where the name does not say
    /// it, and which are left out of the default set.
    pub fn help_list() -> String {
        let named: Vec<String> = Effect::ALL
            .iter()
            .map(|e| match e.candidate().help() {
                Some(h) => format!("{} ({h})", e.name()),
                None => e.name().to_string(),
            })
            .collect();
        let (last, rest) = named.split_last().expect("a registered candidate");
        let only_named: Vec<&str> = Effect::ALL
            .iter()
            .filter(|e| !e.by_default())
            .map(|e| e.name())
            .collect();
        let example = only_named.first().copied().unwrap_or("shaker");
        format!(
            "Candidate effects (default: all but {}): {} and {last}; `all` for every one, \
             `default` for the default set (e.g. `default,{example}`)",
            only_named.join(", "),
            rest.join(", "),
        )
    }

    /// The candidates a diagnosis tries unless told which: every one but
    /// those tried only when named (`bouc_wen_joint`).
    pub fn defaults() -> Vec<Effect> {
        Effect::ALL
            .iter()
            .copied()
            .filter(|e| e.candidate().by_default())
            .collect()
    }

    /// Whether a diagnosis tries it unless told which candidates to try.
    pub fn by_default(self) -> bool {
        self.candidate().by_default()
    }

    /// Candidates by name, `all` for every one and `default` for
    /// [`Effect::defaults`]; the error's message (field `candidates`) names
    /// the unknown one and the names known.
    pub fn parse_list(names: &[String]) -> Result<Vec<Effect>> {
        let mut out: Vec<Effect> = Vec::new();
        for name in names {
            let add: Vec<Effect> = match name.as_str() {
                "all" => Effect::ALL.to_vec(),
                "default" => Effect::defaults(),
                n => vec![Effect::from_name(n).ok_or_else(|| {
                    let known: Vec<&str> = Effect::ALL.iter().map(|e| e.name()).collect();
                    crate::error::Error::plan(
                        "candidates",
                        format!(
                            "unknown effect `{n}` (known: {}; or all, default)",
                            known.join(", ")
                        ),
                    )
                })?],
            };
            for e in add {
                if !out.contains(&e) {
                    out.push(e);
                }
            }
        }
        if out.is_empty() {
            return Err(crate::error::Error::plan(
                "candidates",
                "give at least one effect",
            ));
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    /// The help lists every registered candidate once, in the registry's
    /// order, and names those left out of the default set as such.
    #[test]
    fn the_help_lists_the_registry() {
        let help = Effect::help_list();
        let mut from = 0;
        for e in Effect::ALL {
            let at = help[from..]
                .find(&format!(" {}", e.name()))
                .unwrap_or_else(|| panic!("{} not listed after byte {from}: {help}", e.name()));
            from += at + 1;
        }
        assert!(
            help.starts_with("Candidate effects (default: all but bouc_wen_joint): second_mode, ")
        );
        assert!(help.contains("iwan4_joint (an Iwan joint in place of the fitted joint law)"));
        assert!(help.ends_with("(e.g. `default,bouc_wen_joint`)"));
    }

    /// A correlation with level near zero is said to show no trend: the
    /// cubic stiffness's and quadratic damping's explanations claim a peak
    /// that moved, or fell short, only where `|r|` is at least 0.5.
    #[test]
    fn explanations_claim_no_trend_from_a_weak_correlation() {
        let features = |shift: f64, ratio: f64| ResidualFeatures {
            chi2_per_dof_by_harmonic: Default::default(),
            chi2_per_dof_by_level: Vec::new(),
            growth_with_level: 0.3,
            level_independent_share: 0.0,
            peak_shift_hz: Vec::new(),
            peak_ratio: Vec::new(),
            peak_shift_trend: shift,
            peak_ratio_trend: ratio,
        };
        let why = |effect: Effect, f: &ResidualFeatures| {
            let sel = SelectedEffect {
                effect,
                parameters: Default::default(),
            };
            effect.candidate().explain(f, &sel)
        };
        let weak = features(-0.04, -0.04);
        let cubic = why(Effect::CubicStiffness, &weak);
        assert!(
            cubic.contains("no clear shift") && !cubic.contains("downward"),
            "{cubic}"
        );
        let damping = why(Effect::QuadraticDamping, &weak);
        assert!(
            damping.contains("no clear shortfall") && !damping.contains("fell short"),
            "{damping}"
        );
        let strong = features(-0.9, -0.9);
        assert!(why(Effect::CubicStiffness, &strong).contains("moved downward"));
        assert!(why(Effect::QuadraticDamping, &strong).contains("fell short"));
    }

    /// `all` is every candidate, `default` every one but those tried when
    /// named, names repeat once, and an unknown one is named in the error.
    #[test]
    fn candidate_lists_parse() {
        assert_eq!(Effect::parse_list(&names(&["all"])).unwrap(), Effect::ALL);
        let defaults = Effect::parse_list(&names(&["default"])).unwrap();
        assert_eq!(defaults.len(), Effect::ALL.len() - 1);
        assert!(!defaults.contains(&Effect::BoucWenJoint));
        // tried by default, where the model leaves more than twice the noise
        assert!(defaults.contains(&Effect::HystereticMode));
        assert!(Effect::HystereticMode.candidate().only_far_from_noise());
        assert_eq!(
            Effect::parse_list(&names(&["bouc_wen_joint", "default", "clearance"])).unwrap(),
            [&[Effect::BoucWenJoint][..], &Effect::defaults()].concat()
        );
        let e = Effect::parse_list(&names(&["clearance", "friction"]))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("`friction`") && e.contains("bouc_wen_joint"),
            "{e}"
        );
        assert!(Effect::parse_list(&[]).is_err());
    }

    /// A candidate that adds a mode is judged by that mode's modal constant
    /// wherever the mode lies: in the band (fitted by its residue), below
    /// or above it (by its flexibility). A name the size check does not
    /// know lets an unresolved mode through (a hysteretic mode above the
    /// F-16's band was kept with its flexibility's interval across zero).
    #[test]
    fn an_added_modes_constant_is_a_size_parameter_on_every_side_of_the_band() {
        use crate::model::{ModalModel, Mode};
        let band = Some((90.0, 110.0));
        let mut checked = 0;
        for &effect in Effect::ALL {
            let candidate = effect.candidate();
            for frequency_hz in [50.0, 100.0, 200.0] {
                let mut added = Mode {
                    frequency_hz,
                    damping_ratio: 0.01,
                    residue: 0.5,
                    joint: None,
                };
                if effect == Effect::HystereticMode {
                    added.joint = Some(ElementSpec::Jenkins { kd: 1e6, fd: 10.0 });
                }
                let first = Mode {
                    frequency_hz: 100.0,
                    damping_ratio: 0.01,
                    residue: 1.0,
                    joint: None,
                };
                let model =
                    Model::new(ModalModel::new(vec![first, added]).unwrap(), Vec::new()).unwrap();
                if candidate.added_mode(&model) != Some(1) {
                    continue;
                }
                let params = crate::diagnose::model_parameters(&model, band);
                let constant = params
                    .parameters
                    .iter()
                    .filter_map(|p| candidate.own_parameter(effect.name(), &model, &p.name))
                    .find(|n| *n == "residue" || *n == "flexibility");
                let Some(constant) = constant else {
                    panic!(
                        "{}: no modal constant among its parameters at {frequency_hz} Hz",
                        effect.name()
                    );
                };
                assert!(
                    candidate.size_parameters().contains(&constant),
                    "{} at {frequency_hz} Hz: {constant} is not judged",
                    effect.name()
                );
                checked += 1;
            }
        }
        // a linear and a hysteretic mode, each on three sides of the band
        assert_eq!(checked, 6);
    }
}
