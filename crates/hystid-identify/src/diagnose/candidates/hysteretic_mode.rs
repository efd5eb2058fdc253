//! A further mode that carries a joint of its own (a hysteretic mode, see
//! [`crate::model::modal`]): a resonance the model lacks that softens and
//! gains damping with level, as a second jointed mode of a built-up
//! structure does (the F-16's 6.6 Hz mode beside its torsion, a lap-joint
//! beam's modes, each with its own share of the interface). A linear
//! further mode (`second_mode`) explains such a resonance at one level;
//! this one follows it through every level.
//!
//! Started from the further linear modes `second_mode` locates in the
//! residual: each given a Jenkins joint as stiff as the mode itself, with the
//! located frequency read as the bare mode's or as the stuck one's, and a
//! slip force on a grid over the measured force levels; the best of these as
//! it stands is each located mode's start.

use super::second_mode::SecondMode;
use super::{Candidate, Context, best_as_it_stands};
use crate::diagnose::lines::LineContext;
use crate::diagnose::{ResidualFeatures, SelectedEffect, fmt_value};
use crate::error::Result;
use crate::fit::{Estimate, FitData};
use crate::model::{ElementKind, ElementSpec, Mode, Model};
use std::collections::BTreeMap;

/// See the module docs.
pub(crate) struct HystereticMode;

/// The slip forces tried, as multiples of the smallest measured force
/// level up to this many times the largest.
const SLIP_REACH: f64 = 10.0;
const SLIP_STEPS: usize = 6;

impl Candidate for HystereticMode {
    fn help(&self) -> Option<&'static str> {
        Some(
            "a further mode with a joint of its own; tried where the model leaves more than twice the noise, its refit costing as much as the rest of a diagnosis",
        )
    }

    fn law(&self) -> Option<ElementKind> {
        None
    }

    /// The mode's frequency, damping ratio and modal constant, and its
    /// joint's stick stiffness and slip force.
    fn size(&self) -> usize {
        5
    }

    /// Its refit (a mode and a joint, a harmonic-balance solve per part and
    /// point) costs about as much as the rest of a diagnosis: tried where
    /// the model leaves more than twice the noise.
    fn only_far_from_noise(&self) -> bool {
        true
    }

    fn score(&self, f: &ResidualFeatures) -> f64 {
        // a resonance of its own (as a further mode's) that changes with
        // level (as a joint's)
        5.0 * f.level_independent_share.max(0.2) + f.growth_with_level.max(0.0)
    }

    fn starts(&self, cx: &Context<'_>) -> Result<Vec<Model>> {
        let levels = cx
            .data
            .series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.force_amplitude));
        let Some(slips) = slips(levels) else {
            return Ok(Vec::new());
        };
        let n = cx.model().linear.modes.len();
        let mut starts = Vec::new();
        for located in SecondMode.starts(cx)? {
            if let Some((_, m)) = jointed(&located, n, &slips)
                .and_then(|shapes| best_as_it_stands(cx, shapes.into_iter()))
            {
                starts.push(m);
            }
        }
        Ok(starts)
    }

    /// The second mode's (its starts are made from that candidate's).
    fn identifications(&self, cx: &Context<'_>) -> Vec<usize> {
        SecondMode.identifications(cx)
    }

    /// The same, on a multisine's lines: the modes the second mode finds
    /// there, the slips spread over the recordings' force peaks.
    fn line_starts(&self, cx: &LineContext<'_>) -> Vec<Model> {
        let Some(slips) = slips(cx.reference_peaks().into_iter()) else {
            return Vec::new();
        };
        let n = cx.model().linear.modes.len();
        SecondMode
            .line_starts(cx)
            .iter()
            .filter_map(|located| {
                let shapes = jointed(located, n, &slips)?;
                cx.best_as_it_stands(shapes.into_iter()).map(|(_, m)| m)
            })
            .collect()
    }

    /// Its modal constant (a mode above the band is fitted by its
    /// flexibility) and its joint's slip force.
    fn size_parameters(&self) -> &'static [&'static str] {
        &["residue", "flexibility", "joint.fd"]
    }

    fn implausible(
        &self,
        name: &str,
        e: &Estimate,
        model: &Model,
        data: &FitData,
    ) -> Option<String> {
        SecondMode.implausible(name, e, model, data)
    }

    fn parameters(&self, model: &Model, _data: &FitData) -> BTreeMap<String, f64> {
        let mut out = BTreeMap::new();
        if let Some(m) = self.added_mode(model).map(|i| &model.linear.modes[i]) {
            out.insert("frequency_hz".into(), m.frequency_hz);
            out.insert("damping_ratio".into(), m.damping_ratio);
            out.insert("modal_mass".into(), 1.0 / m.residue);
            for (n, v) in m.joint.iter().flat_map(ElementSpec::parameters) {
                out.insert(format!("joint.{n}"), v);
            }
        }
        out
    }

    fn reported(&self, name: &str, e: Estimate) -> (String, Estimate) {
        SecondMode.reported(name, e)
    }

    /// The last hysteretic mode (the candidate appends it).
    fn added_mode(&self, model: &Model) -> Option<usize> {
        model.linear.modes.iter().rposition(|m| m.is_hysteretic())
    }

    fn remove(&self, model: &Model) -> Option<Model> {
        let i = self.added_mode(model)?;
        let mut m = model.clone();
        m.linear.modes.remove(i);
        (!m.linear.modes.is_empty()).then_some(m)
    }

    fn explain(&self, f: &ResidualFeatures, sel: &SelectedEffect) -> String {
        let get = |n: &str| sel.parameters.get(n).map(|e| e.value);
        let at = match (get("frequency_hz"), get("joint.kd"), get("joint.fd")) {
            (Some(fr), Some(kd), Some(fd)) => {
                let stuck = get("modal_mass")
                    .map(|m| {
                        let k = m.abs() * (2.0 * std::f64::consts::PI * fr).powi(2);
                        fr * ((k + kd) / k).sqrt()
                    })
                    .unwrap_or(f64::NAN);
                format!(
                    ": a mode of its own joint, {fr:.4} Hz slipping and {stuck:.4} Hz stuck, slip force {} (in the drive's unit)",
                    fmt_value(fd)
                )
            }
            _ => String::new(),
        };
        format!(
            "the residual showed a resonance the model lacks that changed with level ({:.0} % of it level-dependent, slope {:.2}){at}",
            100.0 * (1.0 - f.level_independent_share),
            f.growth_with_level
        )
    }
}
/// Slip forces from the lowest force level to [`SLIP_REACH`] times the
/// highest, [`SLIP_STEPS`] of them evenly in the logarithm (`None` without
/// a positive level).
fn slips(levels: impl Iterator<Item = f64>) -> Option<Vec<f64>> {
    let (lo, hi) = levels
        .filter(|f| f.is_finite() && *f > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), f| {
            (lo.min(f), hi.max(f))
        });
    if !(lo.is_finite() && hi > 0.0) {
        return None;
    }
    let top = SLIP_REACH * hi;
    Some(
        (0..SLIP_STEPS)
            .map(|i| lo * (top / lo).powf(i as f64 / (SLIP_STEPS - 1) as f64))
            .collect(),
    )
}

/// The further mode `located` added (its mode `n`, the last) given a
/// Jenkins joint as stiff as its bare mode, at its frequency or `1/√2` of
/// it (the located mode may be the stuck one) and each slip force of
/// `slips` (`None`: `located` did not add one mode).
fn jointed(located: &Model, n: usize, slips: &[f64]) -> Option<Vec<Model>> {
    let mode = *located
        .linear
        .modes
        .get(n)
        .filter(|_| located.linear.modes.len() == n + 1)?;
    Some(
        [1.0, std::f64::consts::FRAC_1_SQRT_2]
            .into_iter()
            .flat_map(|bare| slips.iter().map(move |&fd| (bare, fd)))
            .map(|(bare, fd)| {
                let mut m = located.clone();
                let mut hm = Mode {
                    frequency_hz: mode.frequency_hz * bare,
                    ..mode
                };
                // a joint as stiff as the bare mode: stuck, the mode rings
                // √2 above its bare frequency
                let kd = hm.modal_stiffness().abs();
                hm.joint = Some(ElementSpec::Jenkins { kd, fd });
                m.linear.modes[n] = hm;
                m
            })
            .collect(),
    )
}
