//! A further linear mode: a residual that is largely the same at every
//! level, as a linear effect's is. Inside the band it is fitted by its
//! frequency, damping ratio and modal constant; outside, by what the band
//! sees of it (a residual flexibility above, a residual mass below).

use super::{Candidate, Context};
use crate::diagnose::lines::LineContext;
use crate::diagnose::{ResidualFeatures, SelectedEffect, features, fmt_value};
use crate::error::Result;
use crate::fit::params::{BandSide, ZETA_MAX, band_side};
use crate::fit::{Estimate, FitData};
use crate::model::{ElementKind, Model};
use std::collections::BTreeMap;

/// See the module docs.
pub(crate) struct SecondMode;

impl Candidate for SecondMode {
    fn law(&self) -> Option<ElementKind> {
        None
    }

    fn size(&self) -> usize {
        3
    }

    fn score(&self, f: &ResidualFeatures) -> f64 {
        10.0 * f.level_independent_share
    }

    /// The mode the level-averaged residual shows (a grid search away from
    /// the modes already there); the best below and the best above the band
    /// (a mode out of the band shows only as a residual mass or
    /// flexibility, which a search over every frequency may pass over for a
    /// spurious mode inside it), searched on the residual as it is and with
    /// the baseline's bending projected out; and an identification afresh with one more
    /// mode (a missing mode also bends the linear estimates the baseline
    /// started from) with the user's fit options, the effects kept so far
    /// added back.
    fn starts(&self, cx: &Context<'_>) -> Result<Vec<Model>> {
        let model = cx.model();
        let d = features::common_receptance_residual(cx.data, cx.pred());
        let background = features::common_receptance_background(cx.data, cx.pred());
        let with = |mode| {
            let mut m = model.clone();
            m.linear.modes.push(mode);
            m
        };
        let kept = located_modes(model, &d, &background);
        let mut starts: Vec<Model> = kept.into_iter().map(with).collect();
        if let Some(&modes) = self.identifications(cx).first()
            && let Some(mut m) = cx.identified_with_modes(modes)
        {
            // the new modes with the user's joint refitted, and the effects
            // and hysteretic modes found so far
            m.effects.extend(model.effects.iter().cloned());
            let hysteretic = model.linear.modes.iter().filter(|m| m.is_hysteretic());
            m.linear.modes.extend(hysteretic.copied());
            starts.push(m);
        }
        Ok(starts)
    }

    /// Where the model may have gone astray: the recording identified
    /// afresh with one more mode than its own (not counting hysteretic ones).
    fn identifications(&self, cx: &Context<'_>) -> Vec<usize> {
        let linear = cx
            .model()
            .linear
            .modes
            .iter()
            .filter(|m| !m.is_hysteretic());
        if cx.astray() {
            vec![linear.count() + 1]
        } else {
            Vec::new()
        }
    }

    /// The modes the excited lines' receptance residual shows (the same
    /// searches as on the FRFs, the model's bending taken from its replayed
    /// receptance); no identification afresh (none reads a multisine).
    fn line_starts(&self, cx: &LineContext<'_>) -> Vec<Model> {
        let model = cx.model();
        let (d, background) = cx.receptance_residual();
        located_modes(model, &d, &background)
            .into_iter()
            .map(|mode| {
                let mut m = model.clone();
                m.linear.modes.push(mode);
                m
            })
            .collect()
    }

    fn size_parameters(&self) -> &'static [&'static str] {
        &["residue", "flexibility"]
    }

    fn implausible(
        &self,
        name: &str,
        e: &Estimate,
        model: &Model,
        data: &FitData,
    ) -> Option<String> {
        // at the driving point every mode's modal constant has the sign of
        // the first: a "mode" of negative modal mass is a curve fit, not a
        // mode of the structure (in a transfer, modes take either sign)
        if matches!(name, "residue" | "flexibility")
            && !data.transfer
            && let Some(first) = model.linear.modes.first()
            && e.value * first.residue < 0.0
        {
            return Some(format!(
                "lowered χ² enough, but only as a mode of negative modal mass ({}), which a driving-point response cannot have",
                fmt_value(1.0 / e.value)
            ));
        }
        // a mode held at the largest damping ratio allowed is no resonance:
        // the optimiser used it as a smooth background, not as a mode
        // (inside the band; outside it, a mode is a background by nature
        // and judged by its size alone)
        if name == "damping_ratio"
            && e.value >= 0.99 * ZETA_MAX
            && model
                .linear
                .modes
                .last()
                .is_some_and(|m| band_side(m.frequency_hz, data.band_hz()).is_none())
        {
            return Some(format!(
                "lowered χ² enough, but only as a mode damped at the bound ζ = {:.2}: not a resolved mode",
                e.value
            ));
        }
        // inside the band a mode is its resonance: a damping ratio the data
        // bound only within a decade is a peak narrower than the steps
        // between the points around it (or at one point), which a curve fit
        // can place anywhere between them
        if name == "damping_ratio"
            && model
                .linear
                .modes
                .last()
                .is_some_and(|m| band_side(m.frequency_hz, data.band_hz()).is_none())
            && !(e.identifiable && crate::diagnose::resolution::within_a_decade(e.ci95))
        {
            let [lo, hi] = e.ci95;
            return Some(format!(
                "lowered χ² enough, but only as a resonance the points do not resolve: its damping ratio ζ = {} has the 95 % interval [{}, {}]",
                fmt_value(e.value),
                fmt_value(lo),
                fmt_value(hi)
            ));
        }
        None
    }

    /// The last mode without a joint of its own after the first (the
    /// candidate appends it; a hysteretic mode added later does not take
    /// its place).
    fn added_mode(&self, model: &Model) -> Option<usize> {
        let i = model
            .linear
            .modes
            .iter()
            .rposition(|m| !m.is_hysteretic())?;
        (i >= 1).then_some(i)
    }

    fn parameters(&self, model: &Model, data: &FitData) -> BTreeMap<String, f64> {
        let mut out = BTreeMap::new();
        if let Some(m) = self.added_mode(model).map(|i| &model.linear.modes[i]) {
            out.insert("frequency_hz".into(), m.frequency_hz);
            out.insert("modal_mass".into(), 1.0 / m.residue);
            // a mode above the band is seen there as a flexibility; outside
            // the band a damping ratio is no result
            match band_side(m.frequency_hz, data.band_hz()) {
                Some(BandSide::Above) => {
                    out.insert("flexibility".into(), m.static_flexibility());
                }
                Some(BandSide::Below) => {}
                None => {
                    out.insert("damping_ratio".into(), m.damping_ratio);
                }
            }
        }
        out
    }

    /// A modal mass, as the test definitions give it, rather than the
    /// fitted modal constant; a modal constant whose interval includes zero
    /// leaves the mass unbounded.
    fn reported(&self, name: &str, e: Estimate) -> (String, Estimate) {
        if name != "residue" {
            return (name.to_string(), e);
        }
        let [rlo, rhi] = e.ci95;
        let (ci95, identifiable, note) = if rlo <= 0.0 && rhi >= 0.0 {
            (
                [f64::NEG_INFINITY, f64::INFINITY],
                false,
                Some("the modal constant's 95 % interval includes zero".into()),
            )
        } else {
            let (lo, hi) = (1.0 / rhi, 1.0 / rlo);
            ([lo.min(hi), lo.max(hi)], e.identifiable, e.note.clone())
        };
        (
            "modal_mass".to_string(),
            Estimate {
                value: 1.0 / e.value,
                ci95,
                identifiable,
                note,
                ..e
            },
        )
    }

    fn remove(&self, model: &Model) -> Option<Model> {
        let mut m = model.clone();
        m.linear.modes.remove(self.added_mode(model)?);
        Some(m)
    }

    fn explain(&self, f: &ResidualFeatures, sel: &SelectedEffect) -> String {
        // a mode above the band is seen in it as a flexibility only: its
        // frequency is where the fit put it, not a result
        let resolved = |e: &Estimate| {
            let [lo, hi] = e.ci95;
            e.identifiable && lo > 0.0 && hi / lo < 1.5
        };
        let at = match (
            sel.parameters.get("flexibility"),
            sel.parameters.get("frequency_hz"),
        ) {
            (Some(x), Some(f)) if resolved(f) => format!(
                " at {:.4} Hz, above the measured band (a residual flexibility of {} m/N in it)",
                f.value,
                fmt_value(x.value)
            ),
            (Some(x), _) => format!(
                " above the measured band, seen in it as a residual flexibility of {} m/N (its frequency is not resolved by these data)",
                fmt_value(x.value)
            ),
            (None, Some(e)) => format!(" at {:.4} Hz", e.value),
            _ => String::new(),
        };
        if f.level_independent_share >= 0.5 {
            format!(
                "the residual was largely the same at every level ({:.0} % of it common to all levels), as a linear effect's is: a further mode{at}",
                100.0 * f.level_independent_share
            )
        } else {
            format!("the residual's shape over frequency matched a further linear mode{at}")
        }
    }
}

/// The modes the receptance residual `d` (frequency, residual, its standard
/// error) shows away from `model`'s: the best anywhere, below and above the
/// points' band, and on either side near and far with `background` (the
/// model's own bending) projected out; one per distinct start.
fn located_modes(
    model: &Model,
    d: &[(f64, num_complex::Complex64, f64)],
    background: &[Vec<num_complex::Complex64>],
) -> Vec<crate::model::Mode> {
    let existing: Vec<f64> = model.linear.modes.iter().map(|m| m.frequency_hz).collect();
    let mut modes = Vec::new();
    modes.extend(crate::fit::linear::locate_mode_in(d, &existing));
    let fmin = d.iter().map(|p| p.0).fold(f64::MAX, f64::min);
    let fmax = d.iter().map(|p| p.0).fold(0.0, f64::max);
    let (below, above) = ((0.05 * fmin, 0.9 * fmin), (1.1 * fmax, 20.0 * fmax));
    for (lo, hi) in [below, above] {
        modes.extend(crate::fit::linear::locate_mode_between(
            d, &existing, lo, hi,
        ));
    }
    // the same sides with the baseline's own bending projected out (see
    // `locate_mode_against`), near and far apart: the best far mode can
    // hide a near one, and a refit does not cross from one to the other
    for (lo, hi) in [
        (below.0, 0.3 * fmin),
        (0.3 * fmin, below.1),
        (above.0, 3.0 * fmax),
        (3.0 * fmax, above.1),
    ] {
        modes.extend(crate::fit::linear::locate_mode_against(
            d, background, &existing, lo, hi,
        ));
    }
    // one refit per distinct start
    let mut kept: Vec<crate::model::Mode> = Vec::new();
    for m in modes {
        if !kept.iter().any(|k| {
            (k.frequency_hz / m.frequency_hz - 1.0).abs() < 0.05
                && (k.damping_ratio / m.damping_ratio - 1.0).abs() < 0.5
        }) {
            kept.push(m);
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::{DiagnoseOptions, Refit};
    use crate::fit::{FitOptions, FrfPredictor, HbPredictor, identify};
    use crate::testbench::{self, NoSink, TestDefinition};

    /// A further mode whose modal constant has the other sign than the
    /// first's is a curve fit at a driving point, and a mode like any other
    /// in a transfer: stated (`--transfer`) or implied by a negative first
    /// modal constant.
    #[test]
    fn a_mode_of_the_other_sign_is_implausible_only_at_a_driving_point() {
        let mode = |f: f64, residue: f64| crate::model::Mode {
            frequency_hz: f,
            damping_ratio: 0.01,
            residue,
            joint: None,
        };
        let model = crate::model::Model::new(
            crate::model::ModalModel::new(vec![mode(100.0, 0.1), mode(300.0, -0.05)]).unwrap(),
            Vec::new(),
        )
        .unwrap();
        let point: FitData = serde_json::from_value(serde_json::json!({
            "response": "displacement", "harmonics": [1], "series": []
        }))
        .unwrap();
        assert!(!point.transfer);
        let e = Estimate {
            value: -0.05,
            ci95: [-0.06, -0.04],
            identifiable: true,
            note: None,
            bootstrap_ci95: None,
        };
        let why = SecondMode.implausible("residue", &e, &model, &point);
        assert!(
            why.as_deref()
                .is_some_and(|w| w.contains("negative modal mass")),
            "{why:?}"
        );
        let stated = point.clone().with_transfer(true);
        assert_eq!(SecondMode.implausible("residue", &e, &model, &stated), None);
        let implied = point.with_sign(-1.0);
        assert!(implied.transfer);
        assert_eq!(
            SecondMode.implausible("residue", &e, &model, &implied),
            None
        );
    }

    /// The further mode's parameters are those of the mode it added, the
    /// last linear one: beside a mode of the user's fit or a hysteretic
    /// mode added later, not the one the name `second_mode` labels; and
    /// removing it removes that mode.
    #[test]
    fn its_parameters_are_the_mode_it_added() {
        let mode = |f: f64, joint: bool| crate::model::Mode {
            frequency_hz: f,
            damping_ratio: 0.01,
            residue: 0.1,
            joint: joint.then_some(crate::model::ElementSpec::Jenkins { kd: 1e6, fd: 10.0 }),
        };
        let model = |modes| {
            crate::model::Model::new(crate::model::ModalModel::new(modes).unwrap(), Vec::new())
                .unwrap()
        };
        // the user's two modes, then the one added
        let two = model(vec![mode(5.0, false), mode(6.4, false), mode(1.5, false)]);
        assert_eq!(SecondMode.label("second_mode", &two), "mode_2");
        assert_eq!(
            SecondMode.own_parameter("second_mode", &two, "mode_2.residue"),
            Some("residue")
        );
        assert_eq!(
            SecondMode.own_parameter("second_mode", &two, "second_mode.residue"),
            None
        );
        // added, then a hysteretic mode
        let hyst = model(vec![mode(87.0, false), mode(95.0, true), mode(89.6, false)]);
        assert_eq!(SecondMode.label("second_mode", &hyst), "mode_2");
        assert_eq!(
            SecondMode.own_parameter("second_mode", &hyst, "mode_2.frequency_hz"),
            Some("frequency_hz")
        );
        let without = SecondMode.remove(&hyst).unwrap();
        let left: Vec<f64> = without
            .linear
            .modes
            .iter()
            .map(|m| m.frequency_hz)
            .collect();
        assert_eq!(left, [87.0, 95.0]);
        assert_eq!(
            SecondMode.parameters(&hyst, &point_data())["frequency_hz"],
            89.6
        );
        // the first mode alone is no further mode
        assert_eq!(
            SecondMode.remove(&model(vec![mode(87.0, false), mode(95.0, true)])),
            None
        );
    }

    /// A mode inside the band is resolved when its half-power bandwidth
    /// `2ζf` spans the steps between the points around it, and not when the
    /// peak falls between two points: there every point sees `R/(ωn² − ω²)`,
    /// whatever ζ (the closed form of a mode away from its peak). Points
    /// every 10 Hz, a further mode at 203.3 Hz: ζ = 0.03 (12 Hz wide) is
    /// resolved, ζ = 1e-4 (0.04 Hz) is not; judged at the true model on
    /// its own noiseless FRF with 2 % standard errors.
    #[test]
    fn a_mode_narrower_than_the_steps_around_it_is_not_resolved() {
        use crate::diagnose::resolution::{Intervals, unresolved_in};
        use crate::diagnose::{Effect, Refit};
        use crate::extract::Direction;
        use crate::fit::{MeasuredPoint, MeasuredSeries};
        let judged = |zeta: f64| {
            let mode = |f: f64, z: f64| crate::model::Mode {
                frequency_hz: f,
                damping_ratio: z,
                residue: 1.0,
                joint: None,
            };
            let modes = vec![mode(100.0, 0.02), mode(203.3, zeta)];
            let model =
                Model::new(crate::model::ModalModel::new(modes).unwrap(), Vec::new()).unwrap();
            let points = (5..=30)
                .map(|i| MeasuredPoint {
                    frequency_hz: 10.0 * i as f64,
                    force_amplitude: 1.0,
                    h: vec![num_complex::Complex64::new(0.0, 0.0)],
                    std_error: vec![0.0],
                    blocks: 16,
                })
                .collect();
            let mut data = point_data();
            data.series = vec![MeasuredSeries {
                level: 1.0,
                direction: Direction::Up,
                points,
            }];
            let predictor = HbPredictor::default();
            let pred = predictor.predict_from(&model, &data, None).unwrap();
            for (p, h) in data.series[0].points.iter_mut().zip(&pred.h[0]) {
                p.h = h.clone().unwrap();
                p.std_error = vec![0.02 * p.h[0].norm()];
            }
            let pred = predictor.predict_from(&model, &data, None).unwrap();
            let r = Refit {
                chi2: crate::fit::problem::chi_square(&data, &pred),
                model,
                pred,
            };
            let intervals = Intervals::at(&r, &data, &predictor).unwrap();
            unresolved_in(Effect::SecondMode, &r, &intervals, &data)
        };
        assert_eq!(judged(0.03), None);
        let why = judged(1e-4);
        assert!(
            why.as_deref()
                .is_some_and(|w| w.contains("resonance the points do not resolve")),
            "{why:?}"
        );
    }

    fn point_data() -> FitData {
        serde_json::from_value(serde_json::json!({
            "response": "displacement", "harmonics": [1], "series": []
        }))
        .unwrap()
    }

    /// Every start keeps the joint law the user fitted (the re-identification
    /// with one more mode once used the default options: a Masing joint).
    #[test]
    fn every_start_keeps_the_users_joint_law() {
        let text = r#"
[system]
mass = 10.0
damping = 200.0
stiffness = 1.0e7
[joint]
kind = "jenkins"
kd = 2.4e7
fd = 246.048
[[effects]]
kind = "second_mode"
frequency_hz = 420.0
damping_ratio = 0.01
modal_mass = 50.0
[test]
frequencies_hz = { start = 150.0, stop = 350.0, count = 13 }
levels_n = [50.0, 1000.0, 30000.0]
noise = 0.10
seed = 3
"#;
        let def = TestDefinition::from_toml(text, "second mode").unwrap();
        let run = testbench::run(&def, &mut NoSink, &crate::observe::Silent).unwrap();
        let predictor = HbPredictor::default();
        let fit_options = FitOptions {
            element: ElementKind::Jenkins,
            ..FitOptions::default()
        };
        let fit = identify(&run.frf, &fit_options, &predictor, None).unwrap();
        let options = DiagnoseOptions {
            fit: fit_options,
            ..DiagnoseOptions::default()
        };
        let data = FitData::from_frf(&run.frf, &[1, 2, 3], None, None)
            .unwrap()
            .with_sign(fit.response_sign);
        let pred = predictor.predict_from(&fit.model, &data, None).unwrap();
        let current = Refit {
            model: fit.model.clone(),
            chi2: crate::fit::problem::chi_square(&data, &pred),
            pred,
        };
        let cx = Context {
            current: &current,
            data: &data,
            frf: &run.frf,
            options: &options,
            predictor: &predictor,
            identified: &Default::default(),
            // taken as astray: the identification afresh is among the starts
            expected_chi2: 0.0,
        };
        let starts = SecondMode.starts(&cx).unwrap();
        // the residual's mode, and the identification afresh at least
        assert!(starts.len() >= 2, "{} starts", starts.len());
        for m in &starts {
            assert_eq!(m.linear.modes.len(), 2);
            assert_eq!(
                m.joint.as_ref().map(crate::model::ElementSpec::kind),
                Some(ElementKind::Jenkins),
                "{m:?}"
            );
        }
    }
}
