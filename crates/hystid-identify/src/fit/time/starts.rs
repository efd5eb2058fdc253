//! Where a time-domain fit starts: starts spread about a given one, and the
//! grid of starts for a periodic excitation without a model written down.

use super::judging::MAX_JUDGED_SAMPLES;
use super::options::TimeFitOptions;
use super::problem::TimeProblem;
use super::records::TimeRecord;
use crate::error::{Error, Result};
use crate::fit::params::{ParameterSet, Transform};
use crate::harmonics::Quantity;
use crate::model::Model;
use crate::validate::quasi_static_above_hz;

/// How far [`spread_start`] moves a parameter at most: a factor of 1.5
/// either way for a parameter fitted in its logarithm or reciprocal, 15 %
/// of its value for one fitted on a linear scale.
const SPREAD_FACTOR: f64 = 1.5;
const SPREAD_LINEAR: f64 = 0.15;

/// The `k`-th further start about `theta0` (`k ≥ 1`): every parameter
/// moved by a share of its spread drawn uniformly from the `k`-th stream of
/// a seeded ChaCha8 generator (the same starts on every run and machine),
/// then held inside its bounds. A parameter fitted on a linear scale whose
/// value is 0 stays there unless 0 is a bound.
pub fn spread_start(parameters: &ParameterSet, theta0: &[f64], k: usize) -> Vec<f64> {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(SPREAD_SEED);
    rng.set_stream(k as u64);
    parameters
        .parameters
        .iter()
        .zip(theta0)
        .map(|(p, &t)| {
            let u: f64 = rng.random_range(-1.0..=1.0);
            let moved = match p.transform {
                Transform::Log => t + u * SPREAD_FACTOR.ln(),
                Transform::Reciprocal => t * SPREAD_FACTOR.powf(u),
                Transform::Scaled { .. } => t * (1.0 + SPREAD_LINEAR * u),
            };
            // inside the bounds by a hair: a start on a bound is a start
            // the optimiser's transform cannot leave
            let (lo, hi) = (p.theta(p.bounds[0]), p.theta(p.bounds[1]));
            let (lo, hi) = (lo.min(hi), lo.max(hi));
            let margin = 1e-6 * (hi - lo).abs().min(1.0);
            if (hi - lo).is_finite() && hi > lo {
                moved.clamp(lo + margin, hi - margin)
            } else {
                moved
            }
        })
        .collect()
}

/// The seed of [`spread_start`]'s generator.
const SPREAD_SEED: u64 = 0x5EED_57A2;

/// The starts' joint slips at these multiples of the displacement's RMS
/// (from slipping over most of every cycle to sticking throughout). A start
/// that sticks throughout has no gradient in the slip force and one that
/// slips throughout none in the stick stiffness, so the fit starts from the
/// best of a grid over this, [`START_STRUCTURE`], [`START_JOINT`] and
/// [`START_DAMPING`].
pub const START_SLIP_RMS: [f64; 5] = [0.1, 0.3, 1.0, 3.0, 10.0];

/// The structure's stiffness in the starts, as fractions of the linear
/// estimate's: the linear estimate is the structure and the joint together,
/// at the response's amplitude, and how much of it a slipping joint carries
/// is not known.
pub const START_STRUCTURE: [f64; 4] = [0.25, 0.5, 0.75, 1.0];

/// The joint's stick stiffness in the starts, as multiples of the linear
/// estimate's stiffness.
pub const START_JOINT: [f64; 3] = [0.25, 1.0, 4.0];

/// The structure's damping in the starts, as fractions of the linear
/// estimate's: that holds the joint's dissipation too.
pub const START_DAMPING: [f64; 3] = [0.25, 0.5, 1.0];

/// One start of the grid of [`periodic_starts`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StartShape {
    /// The joint's slip, multiples of the displacement's RMS.
    pub slip_rms: f64,
    /// The structure's stiffness, a fraction of the linear estimate's.
    pub structure: f64,
    /// The joint's stick stiffness, a multiple of the linear estimate's.
    pub joint: f64,
    /// The structure's damping, a fraction of the linear estimate's.
    pub damping: f64,
}

/// The starts of a time-domain fit of a periodic excitation without a model
/// written down: `linear` an SDOF fitted to the linear FRF at the excited
/// lines (`1/(k − mω² + jcω)`, the FRF fit's own linear estimate; `lines`
/// of `quantity` per force), and a joint of `kind` beside a structure of
/// its mass, over the grid of [`START_SLIP_RMS`] (from
/// `displacement_rms`, the displacement's RMS as the linear estimate
/// predicts it), [`START_STRUCTURE`], [`START_JOINT`] and
/// [`START_DAMPING`]. Returns the starts with their shapes, and the SDOF.
pub fn periodic_starts(
    lines: &[crate::fit::FrfSample],
    quantity: Quantity,
    kind: crate::model::ElementKind,
    displacement_rms: impl Fn(&crate::fit::SdofEstimate) -> f64,
) -> Result<(Vec<(Model, StartShape)>, crate::fit::SdofEstimate)> {
    let linear = crate::fit::fit_sdof(lines, quantity, "the excited lines")?;
    let starts = start_grid(
        kind,
        displacement_rms(&linear),
        linear.stiffness,
        |structure, damping| {
            crate::model::ModalModel::sdof(
                linear.mass,
                damping * linear.damping,
                structure * linear.stiffness,
            )
        },
    )?;
    Ok((starts, linear))
}

/// The grid of [`periodic_starts`]: a joint of `kind` whose stick stiffness
/// is [`START_JOINT`] times `stiffness` and whose slip is [`START_SLIP_RMS`]
/// times `x`, the displacement's RMS the linear estimate predicts, beside
/// `structure(stiffness share, damping share)` over [`START_STRUCTURE`] and
/// [`START_DAMPING`].
fn start_grid(
    kind: crate::model::ElementKind,
    x: f64,
    stiffness: f64,
    structure: impl Fn(f64, f64) -> Result<crate::model::ModalModel>,
) -> Result<Vec<(Model, StartShape)>> {
    if !(x.is_finite() && x > 0.0) {
        return Err(Error::input(
            "response",
            format!("the linear estimate predicts no displacement (RMS {x:e} m)"),
        ));
    }
    let mut starts = Vec::new();
    for slip_rms in START_SLIP_RMS {
        for share in START_STRUCTURE {
            for joint in START_JOINT {
                for damping in START_DAMPING {
                    let kd = joint * stiffness;
                    let spec =
                        crate::model::ElementSpec::joint(kind, kd, kd * slip_rms * x, "--element")?;
                    let model =
                        Model::with_joint(structure(share, damping)?, Some(spec), Vec::new())?;
                    let shape = StartShape {
                        slip_rms,
                        structure: share,
                        joint,
                        damping,
                    };
                    starts.push((model, shape));
                }
            }
        }
    }
    Ok(starts)
}

/// The linear estimate at a multisine's excited lines with `modes` modes:
/// the SDOF fit ([`crate::fit::fit_sdof`]) is the dominant mode, `modes − 1`
/// more are located in its residual and all are refitted together
/// ([`crate::fit::linear::locate_extra_mode`], [`crate::fit::linear::fit_modes`]), as
/// the FRF fit's linear start does for a level. The modal constants carry
/// the SDOF's sign (a transfer's are negative). Returns the modes and the
/// SDOF.
pub fn linear_modes_at_lines(
    lines: &[crate::fit::FrfSample],
    quantity: Quantity,
    modes: usize,
) -> Result<(crate::model::ModalModel, crate::fit::SdofEstimate)> {
    use crate::model::{ModalModel, Mode};
    let what = "the excited lines";
    let sdof = crate::fit::fit_sdof(lines, quantity, what)?;
    // fitted to H × sign, so that every modal constant starts positive
    let signed: Vec<crate::fit::FrfSample> = lines
        .iter()
        .map(|l| crate::fit::FrfSample {
            h: l.h * sdof.sign,
            ..*l
        })
        .collect();
    let mut m = ModalModel::new(vec![Mode::from_mck(
        sdof.mass,
        sdof.damping,
        sdof.stiffness,
    )?])?;
    for _ in 1..modes {
        let guess = crate::fit::linear::locate_extra_mode(&signed, quantity, &m)
            .ok_or_else(|| Error::input(what, "too few lines to locate another mode"))?;
        m.modes.push(guess);
        m = crate::fit::linear::fit_modes(&signed, quantity, &m, what)?.0;
    }
    for mode in &mut m.modes {
        mode.residue *= sdof.sign;
    }
    Ok((m, sdof))
}

/// [`periodic_starts`] for a structure of several modes
/// ([`linear_modes_at_lines`]): the grid's shares of stiffness and damping
/// are the dominant mode's (the one the joint softens: the SDOF fit's), the
/// joint's stick stiffness a multiple of that mode's modal stiffness, and
/// its slip force from `displacement_rms` of the modes' receptance. The
/// other modes are kept as estimated. Returns the starts with their shapes,
/// and the modes.
pub fn periodic_starts_modal(
    lines: &[crate::fit::FrfSample],
    quantity: Quantity,
    kind: crate::model::ElementKind,
    modes: usize,
    displacement_rms: impl Fn(&crate::model::ModalModel) -> f64,
) -> Result<(Vec<(Model, StartShape)>, crate::model::ModalModel)> {
    let (linear, _) = linear_modes_at_lines(lines, quantity, modes)?;
    // the dominant mode: the SDOF fit's, refitted among the others
    let main = &linear.modes[0];
    let (sign, mass, damping, stiffness) = (
        main.residue.signum(),
        main.modal_mass().abs(),
        main.modal_damping().abs(),
        main.modal_stiffness().abs(),
    );
    let starts = start_grid(
        kind,
        displacement_rms(&linear),
        stiffness,
        |structure, share| {
            let mut dominant =
                crate::model::Mode::from_mck(mass, share * damping, structure * stiffness)?;
            dominant.residue *= sign;
            let mut m = linear.clone();
            m.modes[0] = dominant;
            Ok(m)
        },
    )?;
    Ok((starts, linear))
}

/// Most samples [`closest_start`] judges each start on (an eighth of
/// [`MAX_JUDGED_SAMPLES`]): a grid of 180 starts replayed over a long
/// multisine's million judged samples takes minutes, and the starts differ
/// by far more than a part of the record can hide.
pub const START_JUDGED_SAMPLES: usize = MAX_JUDGED_SAMPLES / 8;

/// The index of the start whose replay is closest to `records` (the fit's
/// own misfit over what it judges, [`TimeProblem::judged_misfit`]: each
/// segment's squared relative e_RMS, summed; judged on at most
/// [`START_JUDGED_SAMPLES`]), replayed on the coarsest grid
/// that replays the start of the highest frequency as the options' rate
/// does ([`TimeProblem::fix_replay_grid`]); a start the simulator rejects
/// is passed over, ties go to the first. `None` when the simulator rejects
/// every one.
pub fn closest_start(
    starts: &[Model],
    records: &[TimeRecord],
    options: &TimeFitOptions,
) -> Result<Option<(usize, f64)>> {
    use rayon::prelude::*;
    let Some(first) = starts.first() else {
        return Ok(None);
    };
    // one problem: the drives are prepared (resampled) once for every start;
    // a long record's starts told apart on a part of what the fit judges
    let options = TimeFitOptions {
        max_judged_samples: options.max_judged_samples.min(START_JUDGED_SAMPLES),
        ..options.clone()
    };
    let mut problem = TimeProblem::new(
        first.clone(),
        ParameterSet::default(),
        records,
        1.0,
        options,
        None,
    )?;
    // replayed on the grid the start with the highest frequency needs (see
    // `fix_replay_grid`), not at the sure rate: a grid of starts replayed
    // at 12 times a long multisine's rate takes minutes
    let slowest = records
        .iter()
        .map(|r| r.sample_rate_hz)
        .fold(f64::INFINITY, f64::min);
    let top = |m: &Model| m.highest_replayed_frequency_hz(quasi_static_above_hz(slowest));
    let stiffest = starts
        .iter()
        .max_by(|a, b| top(a).total_cmp(&top(b)))
        .expect("one start at least");
    problem.fix_replay_grid(stiffest, "stiffest start");
    let misfits = starts
        .par_iter()
        .map(|m| match problem.judged_misfit(m) {
            Ok(misfit) => Ok(Some(misfit)),
            Err(Error::InvalidModel { .. } | Error::NotConverged { .. }) => Ok(None),
            Err(e) => Err(e),
        })
        .collect::<Result<Vec<Option<f64>>>>()?;
    Ok(misfits
        .into_iter()
        .enumerate()
        .filter_map(|(i, m)| m.filter(|v| v.is_finite()).map(|v| (i, v)))
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0))))
}
