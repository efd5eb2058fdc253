//! The estimation loop of the paper (Figures 2.2 and 3.3) for one element.
//!
//! 1. The underlying linear system from the largest level's FRF (the joint
//!    slips freely there) and the stick stiffness from the smallest level's;
//!    the initial `kd₀ = k_low − k` (the paper's rule).
//! 2. An initial slip force from a coarse scan of the cost over `Fd` (the
//!    paper does not say how it started; the scan makes the start robust).
//! 3. Nelder–Mead on eq. (9) in log parameters; optionally a second,
//!    derivative-based optimiser (Levenberg–Marquardt) from the same start,
//!    which must land inside the first one's confidence region.
//! 4. Confidence intervals from the Jacobian and the measured noise; a
//!    parameter at its bound is reported as not identifiable with the range
//!    the data allow (for Jenkins data `N` runs off to its bound: eq. (10)
//!    tends to the Jenkins element as `N → ∞` and the cost is flat there).

mod intervals;

pub use super::problem::Astray;
pub use intervals::{Confidence, confidence};

use intervals::{bootstrap, jenkins_limit_check};

use super::linear::{FrfSample, SdofEstimate, fit_sdof};
use super::optimise::{self, FitStatus, OptimiserRun};
use super::params::{Parameter, ParameterSet, Target, Transform};
use super::problem::{
    FitData, FitProblem, FrfPredictor, Prediction, Weighting, chi_square, relative_error, residuals,
};
use crate::error::{Error, Result};
use crate::extract::NonlinearFrf;
use crate::model::{ElementAt, ElementKind, ElementSpec, ModalModel, Mode, Model, Role};
use crate::observe::TraceEntry;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Options of an identification.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitOptions {
    /// The element fitted (`masing`: kd, Fd, N; `jenkins`: kd, Fd).
    pub element: ElementKind,
    /// Harmonics in the cost.
    pub harmonics: Vec<usize>,
    /// Residual scaling.
    pub weighting: Weighting,
    /// Which linear parameters are refined with the element's.
    pub refine_linear: LinearRefinement,
    /// Where the linear part starts from.
    pub linear_start: LinearStart,
    /// Modes of the linear part (1: the paper's SDOF); more are located in
    /// the residual of the SDOF fits of the largest and smallest levels.
    #[serde(default = "one_mode")]
    pub modes: usize,
    /// Starting guesses for modes beyond the first.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extra_modes: Vec<Mode>,
    /// Run Levenberg–Marquardt as well and compare.
    pub second_optimiser: bool,
    /// Nelder–Mead iteration cap.
    pub max_iterations: u64,
    /// Parametric bootstrap refits (0: none).
    pub bootstrap: usize,
    /// Bootstrap seed.
    pub seed: u64,
    /// Frequency band, Hz.
    pub band_hz: Option<(f64, f64)>,
    /// The response is not at the driving point: a mode's modal constant
    /// may take either sign (implied by a negative first modal constant).
    #[serde(default)]
    pub transfer: bool,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            element: ElementKind::Masing,
            harmonics: vec![1],
            weighting: Weighting::None,
            refine_linear: LinearRefinement::All,
            linear_start: LinearStart::Extremes,
            modes: 1,
            extra_modes: Vec::new(),
            second_optimiser: false,
            max_iterations: 600,
            bootstrap: 0,
            seed: 1,
            band_hz: None,
            transfer: false,
        }
    }
}

impl FitOptions {
    /// Checks the options, naming the first bad one: a joint law to fit,
    /// at least one harmonic, at least one mode, a band `0 <= lo < hi`.
    pub fn validate(&self) -> Result<()> {
        if !self.element.description().is_fitted_joint() {
            let joints: Vec<&str> = ElementKind::fitted_joints()
                .map(ElementKind::name)
                .collect();
            return Err(Error::plan(
                "element",
                format!(
                    "expected a joint law ({}), got `{}`",
                    joints.join(" or "),
                    self.element.name()
                ),
            ));
        }
        if self.harmonics.is_empty() {
            return Err(Error::plan("harmonics", "give at least one harmonic"));
        }
        if self.modes == 0 {
            return Err(Error::plan("modes", "expected at least 1, got 0"));
        }
        if let Some((lo, hi)) = self.band_hz
            && !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo < hi)
        {
            return Err(Error::plan(
                "band_hz",
                format!("need 0 <= lo < hi, got {lo}:{hi}"),
            ));
        }
        Ok(())
    }
}

fn one_mode() -> usize {
    1
}

/// Why a gauge of `law` is reported at its start.
pub fn held_gauge_note(law: &crate::model::Description) -> String {
    let gauges: Vec<&str> = law
        .parameters
        .iter()
        .filter(|p| p.role == Role::Gauge)
        .map(|p| p.name)
        .collect();
    format!(
        "held at its start ({}): the {} law depends on it only through its products with the others, which carry its scale",
        gauges.join(", "),
        law.name
    )
}

/// The joint mode's stiffness at the smallest level.
fn stick_stiffness(linear: &LinearReport) -> f64 {
    linear
        .stick_modes
        .as_ref()
        .map_or(linear.stick.stiffness, |m| m.modes[0].modal_stiffness())
}

/// The parameters of every mode beyond the first.
fn extra_mode_parameters(model: &Model, band_hz: Option<(f64, f64)>) -> ParameterSet {
    let mut p = ParameterSet::for_linear_in(model, band_hz);
    p.parameters.retain(|q| {
        !matches!(
            q.target,
            Target::Mass { .. } | Target::Damping { .. } | Target::Stiffness { .. }
        )
    });
    p
}

/// Which linear parameters the element fit refines.
///
/// The largest level's FRF gives `m, c, k` with the joint slipping, but the
/// slipping joint still dissipates: its equivalent viscous damping adds about
/// `4 Fd/(π F₀)` of the force at resonance (3 % of `c` at the paper-like
/// 30 kN level), which biases `c` high and, through it, the slip force low.
/// Refining `c` with the element removes the bias (the paper does the same
/// for its experiment, section 4: "the damping in this model has to be
/// adjusted").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LinearRefinement {
    /// `m, c, k` fixed at the largest level's estimate.
    None,
    /// `c` refined.
    Damping,
    /// `m, c, k` refined (the default: at a lightly damped peak `|H|` moves
    /// 1 % for 0.03 % in `k/m`, more than one level's estimate of them can
    /// promise).
    #[default]
    All,
}

/// As the command line writes it: `none`, `damping` or `all`.
impl std::str::FromStr for LinearRefinement {
    type Err = Error;
    fn from_str(text: &str) -> Result<Self> {
        match text {
            "none" => Ok(LinearRefinement::None),
            "damping" => Ok(LinearRefinement::Damping),
            "all" => Ok(LinearRefinement::All),
            other => Err(Error::option(
                "refine_linear",
                format!("expected none, damping or all, got `{other}`"),
            )),
        }
    }
}

/// Where the linear part of the model starts from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LinearStart {
    /// The paper's recipe: `m, c, k` from the largest level (the joint slips
    /// freely), `k + kd` from the smallest (it sticks). For virtual tests and
    /// rigs driven hard enough to saturate the joint.
    #[default]
    Extremes,
    /// Real jointed structures, whose joints never slip fully: the mode of
    /// the smallest level (stick), with `kd` taken out of its stiffness and
    /// `k` refined with the element.
    Lowest,
}

/// As the command line writes it: `extremes` or `lowest`.
impl std::str::FromStr for LinearStart {
    type Err = Error;
    fn from_str(text: &str) -> Result<Self> {
        match text {
            "extremes" => Ok(LinearStart::Extremes),
            "lowest" => Ok(LinearStart::Lowest),
            other => Err(Error::option(
                "linear_start",
                format!("expected extremes or lowest, got `{other}`"),
            )),
        }
    }
}

/// The simplex step of a parameter when refining from a good start: about
/// the size of its uncertainty (a few per mille for the linear part, whose
/// estimate from one level is already that close; a few per cent for the
/// element).
fn refine_step(p: &super::params::Parameter) -> f64 {
    match (&p.transform, &p.target) {
        (Transform::Reciprocal, _) => 0.0125,
        (_, Target::Element { .. } | Target::TiedStickStiffness { .. }) => 0.05,
        _ => 0.0125,
    }
}

/// The initial simplex step of a parameter, in its optimiser coordinate.
fn initial_step(p: &super::params::Parameter) -> f64 {
    match (&p.transform, &p.target) {
        (Transform::Reciprocal, _) => 0.05,
        (_, Target::Element { .. } | Target::TiedStickStiffness { .. }) => 0.2,
        _ => 0.05,
    }
}

/// One estimated parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// Value.
    pub value: f64,
    /// 95 % confidence interval `[lo, hi]` (`hi` may be infinite).
    #[serde(deserialize_with = "interval_from_json")]
    pub ci95: [f64; 2],
    /// Whether the data determine it.
    pub identifiable: bool,
    /// A plain note when it is not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// Bootstrap 95 % interval, if requested.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "optional_interval_from_json"
    )]
    pub bootstrap_ci95: Option<[f64; 2]>,
}

/// An interval as JSON writes it: an unbounded end (infinite, or not
/// determined) is `null`, read back as that side's infinity.
fn interval_from_json<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<[f64; 2], D::Error> {
    let [lo, hi] = <[Option<f64>; 2]>::deserialize(d)?;
    Ok([lo.unwrap_or(f64::NEG_INFINITY), hi.unwrap_or(f64::INFINITY)])
}

/// [`interval_from_json`] of an optional interval.
fn optional_interval_from_json<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Option<[f64; 2]>, D::Error> {
    Ok(Option::<[Option<f64>; 2]>::deserialize(d)?
        .map(|[lo, hi]| [lo.unwrap_or(f64::NEG_INFINITY), hi.unwrap_or(f64::INFINITY)]))
}

/// The linear system estimates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LinearReport {
    /// kg (the fit's final value).
    pub mass: f64,
    /// N s/m.
    pub damping: f64,
    /// N/m.
    pub stiffness: f64,
    /// From the largest level.
    pub underlying: SdofEstimate,
    /// The largest level, N.
    pub underlying_level: f64,
    /// From the smallest level (stick).
    pub stick: SdofEstimate,
    /// The smallest level, N.
    pub stick_level: f64,
    /// Initial `kd = k_low − k`.
    pub kd_initial: f64,
    /// With several modes: the largest level's modes (the joint's first).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub underlying_modes: Option<ModalModel>,
    /// With several modes: the smallest level's modes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stick_modes: Option<ModalModel>,
}

/// Misfit measures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorReport {
    /// `||H_meas − H_model|| / ||H_meas||` over all points of the fundamental.
    pub relative: f64,
    /// The same per fitted harmonic.
    pub per_harmonic: BTreeMap<usize, f64>,
    /// `χ²` with the measured standard errors.
    pub chi2: f64,
    /// `χ²` per degree of freedom.
    pub chi2_per_dof: f64,
    /// Cost (eq. 9 squared, as fitted).
    pub cost: f64,
}

/// Effort spent.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EffortReport {
    /// Cost evaluations.
    pub evaluations: usize,
    /// Harmonic-balance points solved.
    pub hb_points: usize,
    /// Wall time, s.
    pub seconds: f64,
    /// Wall time per cost evaluation, ms.
    pub ms_per_evaluation: f64,
}

/// The result of [`identify`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitResult {
    /// The element kind.
    pub element: ElementKind,
    /// Element (and refined linear) parameters by name.
    pub parameters: BTreeMap<String, Estimate>,
    /// The linear system.
    pub linear: LinearReport,
    /// Misfit.
    pub error: ErrorReport,
    /// The fitted model.
    pub model: Model,
    /// The main optimiser's run.
    pub optimiser: OptimiserRun,
    /// The second optimiser's run, if any, and whether it agrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub second_optimiser: Option<(OptimiserRun, bool)>,
    /// Cost trace of the main optimiser.
    pub trace: Vec<TraceEntry>,
    /// Effort.
    pub effort: EffortReport,
    /// How the fit ended: the main optimiser's status, or
    /// [`FitStatus::ModelNotConverged`] when model points failed at the optimum.
    #[serde(default)]
    pub status: FitStatus,
    /// Notes (warnings) for the user.
    pub notes: Vec<String>,
    /// The model predicts `response_sign × H_measured` (see
    /// [`FitData::response_sign`]).
    pub response_sign: f64,
    /// The response is not at the driving point ([`FitData::transfer`]).
    #[serde(default)]
    pub transfer: bool,
    /// The parameters (of `parameters`) that ended at (within 1 % of) a bound of the fit: the
    /// optimiser's own (a slip force bounded by the levels tested, say) or
    /// the interval's. Their value is the bound's, not a measurement.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub at_bound: Vec<String>,
    /// The quantity of the reference the FRFs were measured against (a
    /// force or a voltage): `validate` refuses a recording driven by the
    /// other (absent from fit.json files written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_quantity: Option<crate::harmonics::Quantity>,
    /// The first mode's parameters that ended at a bound the smallest
    /// level's linear estimate sets (see [`super::anchor`]): a fit led
    /// astray, not a measurement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub astray: Option<Astray>,
}

/// Linear system estimates from the largest and smallest levels.
pub fn linear_from_levels(frf: &NonlinearFrf, band_hz: Option<(f64, f64)>) -> Result<LinearReport> {
    linear_from_levels_with(frf, band_hz, 1, &[])
}

/// [`linear_from_levels`] with `modes` modes per level: the SDOF estimate
/// first (the joint's mode), then modes located in its residual (or given
/// in `extra`, as starting guesses), all fitted together.
pub fn linear_from_levels_with(
    frf: &NonlinearFrf,
    band_hz: Option<(f64, f64)>,
    modes: usize,
    extra: &[Mode],
) -> Result<LinearReport> {
    let samples = |i: usize| level_samples(frf, i, band_hz);
    if frf.levels.len() < 2 {
        return Err(Error::input(
            "recording",
            format!(
                "identification needs at least two force levels (the largest gives the underlying linear system, the smallest the stick stiffness); found {}",
                frf.levels.len()
            ),
        ));
    }
    // an SDOF per level; a level whose FRF is not one damped mode (a jump, a
    // mode out of reach, a response below the recording's resolution) is
    // passed over, not fatal
    let mut order: Vec<usize> = (0..frf.levels.len()).collect();
    order.sort_by(|&a, &b| frf.levels[a].level.total_cmp(&frf.levels[b].level));
    let mut fits: Vec<(usize, SdofEstimate)> = Vec::new();
    let mut first_error = None;
    for &i in &order {
        let what = format!("level {}", frf.levels[i].level);
        match fit_sdof(&samples(i), frf.response, &what) {
            Ok(e) => fits.push((i, e)),
            Err(e) => {
                first_error.get_or_insert(e);
            }
        }
    }
    if fits.len() < 2 {
        return Err(first_error.unwrap_or_else(|| {
            Error::input(
                "recording",
                "fewer than two levels look like one damped mode: no linear estimate",
            )
        }));
    }
    // the stick stiffness from the smallest level that can be read; the
    // underlying (slipping) system from the level whose mode is softest: the
    // joint only softens with level, so any level stiffer than another
    // carries something more (a joint still partly stuck, or a hardening
    // the model lacks, which would bias the whole fit if taken as linear)
    // (the largest level unless another is softer by more than 2 %: within
    // that, levels that all slip freely differ by noise and by the friction
    // damping, which is least at the largest level)
    let (lo, stick) = fits[0];
    let largest = fits.last().cloned().expect("two fits");
    let softest = fits
        .iter()
        .skip(1)
        .min_by(|a, b| a.1.stiffness.total_cmp(&b.1.stiffness))
        .cloned()
        .expect("two fits");
    let (hi, underlying) = if softest.1.stiffness < 0.98 * largest.1.stiffness {
        softest
    } else {
        largest
    };
    let several = |s: &SdofEstimate, samples: &[FrfSample], what: &str| {
        modes_from_sdof(s, samples, frf.response, (modes, extra), what)
    };
    let underlying_modes = several(
        &underlying,
        &samples(hi),
        &format!("level {} (underlying)", frf.levels[hi].level),
    )?;
    let stick_modes = several(
        &stick,
        &samples(lo),
        &format!("level {} (stick)", frf.levels[lo].level),
    )?;
    let k_of = |m: &Option<ModalModel>, s: &SdofEstimate| {
        m.as_ref()
            .map_or(s.stiffness, |m| m.modes[0].modal_stiffness())
    };
    Ok(LinearReport {
        mass: underlying.mass,
        damping: underlying.damping,
        stiffness: underlying.stiffness,
        kd_initial: match (&underlying_modes, &stick_modes) {
            // a spring kd at the point puts the stick resonance where
            // 1 + kd Re H(ω) = 0 (for one mode, the paper's k_low − k)
            (Some(u), Some(st)) => -1.0 / u.receptance(st.modes[0].omega()).re,
            _ => k_of(&stick_modes, &stick) - k_of(&underlying_modes, &underlying),
        },
        underlying,
        underlying_level: frf.levels[hi].level,
        stick,
        stick_level: frf.levels[lo].level,
        underlying_modes,
        stick_modes,
    })
}

/// The fundamental's points of level `i` inside the band, those a fit can
/// use.
fn level_samples(frf: &NonlinearFrf, i: usize, band_hz: Option<(f64, f64)>) -> Vec<FrfSample> {
    frf.levels[i]
        .points
        .iter()
        .filter(|p| band_hz.is_none_or(|(lo, hi)| p.frequency_hz >= lo && p.frequency_hz <= hi))
        .filter(|p| super::problem::usable_point(p, &[1]))
        .map(|p| FrfSample {
            frequency_hz: p.frequency_hz,
            h: p.h[1],
            std_error: p.std_error[1],
        })
        .collect()
}

/// Several modes fitted to one level's points from its SDOF estimate `s`:
/// `modes` in all, the `extra` ones started where given, the others located
/// in the residual. None where one mode is asked for.
fn modes_from_sdof(
    s: &SdofEstimate,
    samples: &[FrfSample],
    response: crate::harmonics::Quantity,
    (modes, extra): (usize, &[Mode]),
    what: &str,
) -> Result<Option<ModalModel>> {
    if modes <= 1 && extra.is_empty() {
        return Ok(None);
    }
    let mut main = Mode::from_mck(s.mass, s.damping, s.stiffness)?;
    main.residue *= s.sign;
    let mut m = ModalModel::new(vec![main])?;
    for i in 1..modes.max(extra.len() + 1) {
        let guess = match extra.get(i - 1) {
            Some(g) => Mode {
                residue: g.residue * s.sign,
                ..*g
            },
            None => super::linear::locate_extra_mode(samples, response, &m)
                .ok_or_else(|| Error::input(what, "too few points to locate another mode"))?,
        };
        m.modes.push(guess);
        m = super::linear::fit_modes(samples, response, &m, what)?.0;
    }
    // the model is fitted to H × sign: flip every modal constant with it
    for mode in &mut m.modes {
        mode.residue *= s.sign;
    }
    Ok(Some(m))
}

/// Fits `options.element` to measured nonlinear FRFs.
///
/// The first mode's `m, c, k` are held to what the smallest level's linear
/// estimate allows (see [`super::anchor`]). A fit from the paper's start
/// (the largest level's mode) that ends at one of those bounds has been led
/// astray by what the largest level holds (a jump, a strong effect the model
/// lacks): it is restarted from the smallest level's mode, the better of the
/// two kept, and the notes say so.
pub fn identify(
    frf: &NonlinearFrf,
    options: &FitOptions,
    predictor: &dyn FrfPredictor,
    observer: Option<&dyn crate::observe::Observer>,
) -> Result<FitResult> {
    options.validate()?;
    let first = identify_from(frf, options, predictor, observer)?;
    let Some(astray) = first.astray.clone() else {
        return Ok(first);
    };
    if options.linear_start != LinearStart::Extremes {
        return Ok(with_astray_note(first, &astray, None));
    }
    let again = FitOptions {
        linear_start: LinearStart::Lowest,
        ..options.clone()
    };
    let second = match identify_from(frf, &again, predictor, observer) {
        Ok(f) => f,
        Err(_) => return Ok(with_astray_note(first, &astray, None)),
    };
    let restart = Some(second.error.cost < first.error.cost);
    Ok(if second.error.cost < first.error.cost {
        with_astray_note(second, &astray, restart)
    } else {
        with_astray_note(first, &astray, restart)
    })
}

/// `fit` with a note on the first fit's parameters at an anchored bound
/// (`astray`), and on the restart from the smallest level's mode: `Some(true)`
/// when it was kept.
fn with_astray_note(mut fit: FitResult, astray: &Astray, restart: Option<bool>) -> FitResult {
    let first = format!(
        "the first fit (from the largest level's mode) went astray: {}",
        astray.describe()
    );
    let note = match (restart, &fit.astray) {
        (None, _) => format!("{first}; not trusted"),
        (Some(true), None) => {
            format!("{first}; restarted from the smallest level's mode, which is kept")
        }
        (Some(true), Some(a)) => format!(
            "{first}; restarted from the smallest level's mode, which is kept, though it went astray too ({}): not trusted",
            a.describe()
        ),
        (Some(false), _) => format!(
            "{first}; restarted from the smallest level's mode, which ended worse: the first fit is kept, not trusted"
        ),
    };
    fit.notes.push(note);
    fit
}

/// [`identify`] from `options.linear_start`, once.
fn identify_from(
    frf: &NonlinearFrf,
    options: &FitOptions,
    predictor: &dyn FrfPredictor,
    observer: Option<&dyn crate::observe::Observer>,
) -> Result<FitResult> {
    let t0 = std::time::Instant::now();
    let mut linear =
        linear_from_levels_with(frf, options.band_hz, options.modes, &options.extra_modes)?;
    let mut notes = Vec::new();
    // the lowest level is the most linear: its modal constant's sign decides
    let sign = linear.stick.sign;
    if linear.underlying.sign != sign {
        notes.push("the largest and smallest levels disagree on the sign of the modal constant; using the smallest's".into());
    }
    if sign < 0.0 {
        notes.push("the response moves against the drive below resonance (a transfer FRF with a negative modal constant): the model is fitted to −H".into());
    }
    let data = FitData::from_frf(frf, &options.harmonics, options.band_hz, None)?
        .with_sign(sign)
        .with_transfer(options.transfer)
        .with_anchor(super::anchor::LinearAnchor::of(
            &linear.stick,
            frf.reference,
        ));
    if let Some(s) = super::problem::SubharmonicPoint::describe(&data.subharmonic_points) {
        notes.push(s);
    }
    if data.unusable_points > 0 {
        notes.push(format!(
            "{} measured point(s) left out: a zero fundamental or a zero standard error (a response below the recording's resolution)",
            data.unusable_points
        ));
    }
    let (sdof, kd0) = match options.linear_start {
        LinearStart::Extremes => {
            let kd0 = if linear.kd_initial > 0.0 {
                linear.kd_initial
            } else {
                notes.push(format!(
                    "the smallest level is not stiffer than the largest (k_low − k = {:.4e}, N/m on a force reference, V/m on a voltage one): no stick stiffness visible; starting from kd = k",
                    linear.kd_initial
                ));
                linear.stiffness
            };
            let lin = match &linear.underlying_modes {
                Some(m) => m.clone(),
                None => ModalModel::sdof(linear.mass, linear.damping, linear.stiffness)?,
            };
            (lin, kd0)
        }
        LinearStart::Lowest => {
            // the joint never slips fully: start from the smallest level's
            // mode (stick) and take kd out of its stiffness, guessing twice
            // the softening the largest level shows
            let st = &linear.stick;
            let k_low = stick_stiffness(&linear);
            let softening = k_low - linear.underlying.stiffness;
            let kd0 = (2.0 * softening).clamp(0.02 * k_low, 0.9 * k_low);
            linear.kd_initial = kd0;
            let mut lin = match &linear.stick_modes {
                Some(m) => m.clone(),
                None => ModalModel::sdof(st.mass, st.damping, st.stiffness)?,
            };
            let mut as_model = Model {
                linear: lin.clone(),
                joint: None,
                effects: Vec::new(),
            };
            Parameter {
                name: String::new(),
                target: Target::Stiffness { mode: 0 },
                transform: Transform::Log,
                bounds: [0.0, f64::INFINITY],
            }
            .write(&mut as_model, k_low - kd0)?;
            lin = as_model.linear;
            (lin, kd0)
        }
    };
    let element = ElementSpec::joint(options.element, kd0, 1.0, "element")?;
    // the joint's stick stiffness and slip force, by what they are to the
    // law (every joint has both: see `Description::is_joint`)
    let law = options.element.description();
    let role_name = |role: Role| law.index_of(role).map(|i| law.parameters[i].name);
    let (kd_name, fd_name) = (
        role_name(Role::StickStiffness).unwrap_or_default(),
        role_name(Role::SlipForce).unwrap_or_default(),
    );
    let base = Model::with_joint(sdof, Some(element), Vec::new())?;
    let mut element_params =
        ParameterSet::for_element(&base, ElementAt::Joint, "").without_gauges(&base);
    // bounded by the data: a slip force far below the smallest level (always
    // slipping) or far above the largest (never slipping) is not identified
    // by the test, and neither is a stick stiffness decades away from the
    // structure's; the bounds keep an optimiser from running away there
    {
        let (lmin, lmax) = data.series.iter().fold((f64::MAX, 0.0f64), |(a, b), s| {
            (a.min(s.level), b.max(s.level))
        });
        let k_ref = kd0.abs().max(f64::MIN_POSITIVE);
        for p in &mut element_params.parameters {
            if p.name == fd_name && lmax > 0.0 {
                p.bounds = [1e-3 * lmin, 1e3 * lmax];
            } else if p.name == kd_name {
                p.bounds = [1e-4 * k_ref, 1e4 * k_ref];
            }
        }
    }
    let mut params = element_params.clone();
    match (options.linear_start, options.refine_linear) {
        (LinearStart::Extremes, LinearRefinement::None) => {}
        (LinearStart::Extremes, LinearRefinement::Damping) => {
            params.extend(ParameterSet::for_sdof_damping(0));
            params.extend(extra_mode_parameters(&base, data.band_hz()));
        }
        (_, LinearRefinement::All) => {
            params.extend(ParameterSet::for_linear_in(&base, data.band_hz()))
        }
        (LinearStart::Lowest, _) => {
            // k and kd are both unknown here: k is always refined
            let mut kc = ParameterSet::for_linear_in(&base, data.band_hz());
            kc.parameters
                .retain(|p| !matches!(p.target, Target::Mass { .. }));
            params.extend(kc);
        }
    }
    let params = data.anchored(params, &base);
    if options.linear_start == LinearStart::Lowest {
        // stage 1 keeps k + kd at the smallest level's stiffness
        let total = stick_stiffness(&linear);
        for p in &mut element_params.parameters {
            if matches!(&p.target, Target::Element { name, .. } if name == kd_name) {
                p.target = Target::TiedStickStiffness { mode: 0, total };
                p.bounds = [1e-6 * total, 0.99 * total];
            }
        }
    }
    // stage 1: the element, on the linear system as estimated, with its
    // damping free: the largest level's damping carries the slipping joint's
    // equivalent damping, which the element parameters would otherwise bend
    // themselves to absorb
    let mut stage1_params = element_params.clone();
    if options.linear_start == LinearStart::Extremes
        && options.refine_linear != LinearRefinement::None
    {
        stage1_params.extend(ParameterSet::for_sdof_damping(0));
    }
    let stage1_params = data.anchored(stage1_params, &base);
    let mut stage1 = FitProblem::new(
        base.clone(),
        stage1_params.clone(),
        &data,
        predictor,
        options.weighting,
        observer,
    );
    // a coarse scan of joint starts: the slip force from well below the
    // smallest level to the largest; from the smallest level's mode also
    // the split of its stiffness between structure and joint (a few
    // multiples of the softening the largest level shows). Each start is
    // the law's own `ElementSpec::joint`, so a law that holds a gauge
    // (Bouc-Wen's β) starts it where the scanned slip force puts it.
    let (lmin, lmax) = data.series.iter().fold((f64::MAX, 0.0f64), |(a, b), s| {
        (a.min(s.level), b.max(s.level))
    });
    let kd_candidates: Vec<f64> = match options.linear_start {
        LinearStart::Extremes => [0.7, 1.0, 1.4].iter().map(|f| f * kd0).collect(),
        LinearStart::Lowest => {
            let total = stick_stiffness(&linear);
            let softening = (total - linear.underlying.stiffness).max(0.01 * total);
            [1.0, 1.4, 2.0, 3.0, 5.0]
                .iter()
                .map(|f| (f * softening).min(0.9 * total))
                .collect()
        }
    };
    let mut best: (f64, Option<Model>) = (f64::INFINITY, None);
    let scan = 16;
    for &kd in &kd_candidates {
        for i in 0..=scan {
            let fd = (0.05 * lmin) * ((lmax / (0.05 * lmin)).powf(i as f64 / scan as f64));
            let mut candidate = base.clone();
            candidate.joint = Some(ElementSpec::joint(options.element, kd, fd, "element")?);
            stage1.base = candidate.clone();
            let c = stage1.cost(&stage1_params.theta_of(&candidate)?)?;
            if c < best.0 {
                best = (c, Some(candidate));
            }
        }
    }
    let base = best.1.unwrap_or(base);
    stage1.base = base.clone();
    let theta = stage1_params.theta_of(&base)?;
    let start = theta.clone();
    let steps1: Vec<f64> = stage1_params.parameters.iter().map(initial_step).collect();
    let r1 = optimise::nelder_mead(&stage1, &theta, &steps1, options.max_iterations, 1e-5)?;
    // stage 2: every free parameter from stage 1's optimum, a small simplex
    // (also restarts a simplex that may have collapsed early)
    let (base2, _) = stage1_params.model_at(&base, &r1.theta)?;
    let problem = FitProblem::new(
        base2.clone(),
        params.clone(),
        &data,
        predictor,
        options.weighting,
        observer,
    )
    .numbered_after(stage1.evaluations());
    let theta2 = params.theta_of(&base2)?;
    let steps2: Vec<f64> = params.parameters.iter().map(refine_step).collect();
    // the simplex's cost spread below 1e-6 of the cost is ~1e-3 χ² units
    let mut run = optimise::nelder_mead(&problem, &theta2, &steps2, options.max_iterations, 1e-6)?;
    // stage 3: a derivative-based polish from the simplex's optimum (a
    // simplex crawls along the correlated valley of m, k and kd); kept only
    // if it lowers the cost
    if let Ok(polish) = optimise::levenberg_marquardt(&problem, &run.theta, 8)
        && polish.cost < run.cost
    {
        run.theta = polish.theta;
        run.cost = polish.cost;
        run.termination = format!(
            "{}; polished by Levenberg–Marquardt ({})",
            run.termination, polish.termination
        );
    }
    run.iterations += r1.iterations;
    run.evaluations = stage1.evaluations() + problem.evaluations();
    let mut trace = stage1.trace();
    trace.extend(problem.trace());
    let (model, pred, _) = problem.evaluate(&run.theta)?;
    // intervals with every linear parameter free as well: m, c and k are
    // estimated from the same data, so the element's intervals must carry
    // their uncertainty even when the optimiser held them fixed
    let mut u_params =
        ParameterSet::for_element(&model, ElementAt::Joint, "").without_gauges(&model);
    u_params.extend(ParameterSet::for_linear_in(&model, data.band_hz()));
    let u_problem = FitProblem::new(
        model.clone(),
        u_params.clone(),
        &data,
        predictor,
        options.weighting,
        None,
    );
    let u_theta = u_params.theta_of(&model)?;
    let uncertainty = confidence(&u_problem, &u_theta, &pred)?;
    let mut parameters = BTreeMap::new();
    for (j, p) in u_params.parameters.iter().enumerate() {
        parameters.insert(p.name.clone(), uncertainty.estimates[j].clone());
    }
    // a gauge is reported where it was held, saying so
    if let Some(joint) = &model.joint {
        for ((name, value), info) in joint.parameters().into_iter().zip(law.parameters) {
            if info.role == Role::Gauge {
                parameters.insert(
                    name.to_string(),
                    Estimate {
                        value,
                        ci95: [value, value],
                        identifiable: false,
                        note: Some(held_gauge_note(law)),
                        bootstrap_ci95: None,
                    },
                );
            }
        }
    }
    // the optimiser's bounds are the data's (the slip force within the
    // levels' range), the interval's are the law's: either one reached
    // makes the value a bound's
    let mut at_bound: Vec<String> = Vec::new();
    for (set, theta) in [(&params, &run.theta), (&u_params, &u_theta)] {
        for (p, hit) in set.parameters.iter().zip(set.at_bounds(&set.values(theta))) {
            if hit && parameters.contains_key(&p.name) && !at_bound.contains(&p.name) {
                at_bound.push(p.name.clone());
            }
        }
    }
    at_bound.sort();
    // a shape parameter fitted by its reciprocal (the Masing curvature) may
    // sit in its law's limit (a Jenkins element), which its interval cannot say
    let shape = u_params
        .parameters
        .iter()
        .find(|p| matches!(p.transform, Transform::Reciprocal))
        .map(|p| p.name.clone());
    if let Some(e) = shape.and_then(|n| parameters.get_mut(&n))
        && e.identifiable
    {
        jenkins_limit_check(&problem, &run.theta, &pred, uncertainty.reduced_chi2, e)?;
    }
    let mut second = None;
    if options.second_optimiser {
        let lm_problem = FitProblem::new(
            base.clone(),
            params.clone(),
            &data,
            predictor,
            options.weighting,
            None,
        );
        // from stage 1's start (the slip-force scan), every parameter free
        let (start_model, _) = stage1_params.model_at(&base, &start)?;
        let lm_start = params.theta_of(&start_model)?;
        let lm = optimise::levenberg_marquardt(&lm_problem, &lm_start, 60)?;
        let values = params.values(&lm.theta);
        let agrees = params.parameters.iter().zip(&values).all(|(p, v)| {
            let e = &parameters[&p.name];
            !e.identifiable || (*v >= e.ci95[0] && *v <= e.ci95[1])
        });
        if !agrees {
            notes.push(
                "Levenberg–Marquardt ended outside Nelder–Mead's 95 % confidence region".into(),
            );
        }
        second = Some((lm, agrees));
    }
    if options.bootstrap > 0 {
        bootstrap(&problem, &run.theta, &pred, options, &mut parameters)?;
    }
    let error = error_report(&data, &pred, run.cost, params.len());
    let astray = data.astray(&model, &pred);
    if pred.failures() > 0 {
        notes.push(format!(
            "{} model points did not converge at the optimum",
            pred.failures()
        ));
    }
    let (m, c, k) =
        model
            .linear
            .as_mck()
            .unwrap_or((linear.mass, linear.damping, linear.stiffness));
    let status = if pred.failures() > 0 {
        FitStatus::ModelNotConverged
    } else {
        run.status
    };
    let seconds = t0.elapsed().as_secs_f64();
    let evaluations = stage1.evaluations() + problem.evaluations();
    Ok(FitResult {
        status,
        element: options.element,
        parameters,
        linear: LinearReport {
            mass: m,
            damping: c,
            stiffness: k,
            ..linear
        },
        error,
        model,
        optimiser: run,
        second_optimiser: second,
        trace,
        response_sign: sign,
        transfer: data.transfer,
        effort: EffortReport {
            evaluations,
            hb_points: stage1.solves() + problem.solves(),
            seconds,
            ms_per_evaluation: 1e3 * seconds / evaluations.max(1) as f64,
        },
        notes,
        at_bound,
        astray,
        reference_quantity: Some(frf.reference),
    })
}

/// Misfit measures of a prediction.
pub fn error_report(
    data: &FitData,
    pred: &Prediction,
    cost: f64,
    parameters: usize,
) -> ErrorReport {
    let chi2 = chi_square(data, pred);
    let dof = (2 * data.observations()).saturating_sub(parameters).max(1) as f64;
    ErrorReport {
        relative: relative_error(data, pred, 1).unwrap_or(f64::NAN),
        per_harmonic: data
            .harmonics
            .iter()
            .filter_map(|&h| Some((h, relative_error(data, pred, h)?)))
            .collect(),
        chi2,
        chi2_per_dof: chi2 / dof,
        cost,
    }
}

/// Unused-import guard for residuals (kept public for diagnosis).
pub fn stacked_residuals(data: &FitData, pred: &Prediction, weighting: Weighting) -> Vec<f64> {
    residuals(data, pred, weighting)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Options a fit cannot use are errors that name them.
    #[test]
    fn fit_options_are_checked() {
        assert!(FitOptions::default().validate().is_ok());
        let bad = |o: FitOptions| o.validate().unwrap_err().to_string();
        let e = bad(FitOptions {
            element: ElementKind::CubicStiffness,
            ..FitOptions::default()
        });
        assert!(
            e.contains("`element`: expected a joint law") && e.contains("cubic_stiffness"),
            "{e}"
        );
        assert!(
            bad(FitOptions {
                harmonics: Vec::new(),
                ..FitOptions::default()
            })
            .contains("`harmonics`")
        );
        assert!(
            bad(FitOptions {
                modes: 0,
                ..FitOptions::default()
            })
            .contains("`modes`")
        );
        assert!(
            bad(FitOptions {
                band_hz: Some((300.0, 100.0)),
                ..FitOptions::default()
            })
            .contains("`band_hz`")
        );
    }
}
