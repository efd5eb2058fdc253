//! The model half of eq. (9): harmonic balance at every measured point.
//!
//! Each measured series (one level, one sweep) is solved point by point in
//! measurement order, warm-started from the previous point's solution scaled
//! to the point's measured force, so the branch followed is the one the test
//! followed. The model is driven at each point's *measured* force amplitude,
//! since `H = X/F` of a nonlinear structure depends on it. Series run in
//! parallel (rayon); the result does not depend on the thread count.

use super::problem::{FitData, FrfPredictor, Prediction};
use crate::error::Result;
use crate::harmonics::omega;
use crate::hb::{HbOptions, HbSolver, all_harmonics, odd_harmonics};
use crate::model::Model;
use num_complex::Complex64;
use rayon::prelude::*;

/// One series' prediction: each point's harmonics judged and its solved
/// state (`None` where the solve failed), and the points solved.
type SeriesPrediction = (
    Vec<Option<Vec<Complex64>>>,
    Vec<Option<Vec<Complex64>>>,
    usize,
);

/// Predicts measured FRFs by harmonic balance.
#[derive(Clone, Debug, Default)]
pub struct HbPredictor {
    /// Settings; the harmonic set is widened to cover what the data need.
    pub options: HbOptions,
}

impl HbPredictor {
    /// The harmonic-balance options used for `model` and `data`: at least
    /// `{1, 3, 5}`, every fitted odd harmonic, and the even ones and DC when
    /// the model is asymmetric; as many time samples as the laws ask for their
    /// kinks, or, when every law is smooth enough to state its own count
    /// ([`crate::model::Description::smooth_samples`]) and the predictor's
    /// count is the default, the largest they state (eq. (10) at `N <= 3.5`:
    /// 128, half the default).
    pub fn options_for(&self, model: &Model, data: &FitData) -> HbOptions {
        let top = data.harmonics.iter().copied().max().unwrap_or(1).max(5);
        // a symmetric model's even harmonics and DC are zero by symmetry: they
        // are solved for only when an element is asymmetric (the prediction
        // of a harmonic not solved for is 0)
        let even = model.is_asymmetric();
        let mut o = self.options.clone();
        let base: Vec<usize> = if even {
            all_harmonics(top)
        } else {
            odd_harmonics(top | 1)
        };
        let mut set: Vec<usize> = base
            .into_iter()
            .chain(o.harmonics.iter().copied())
            .collect();
        if !even {
            set.retain(|h| h % 2 == 1);
        }
        set.sort_unstable();
        set.dedup();
        o.harmonics = set;
        // a law with kinks says how many samples a period resolves them; a
        // model of smooth laws alone takes the fewer its laws state, unless
        // the predictor was given a count of its own
        o.samples_per_period = match model.smooth_samples_per_period() {
            Some(smooth) if o.samples_per_period == HbOptions::default().samples_per_period => {
                smooth.max(16)
            }
            _ => o.samples_per_period.max(model.samples_per_period()),
        };
        while o.samples_per_period <= 4 * o.harmonics.last().copied().unwrap_or(1) {
            o.samples_per_period *= 2;
        }
        o
    }
}

impl FrfPredictor for HbPredictor {
    fn predict_from(
        &self,
        model: &Model,
        data: &FitData,
        start: Option<&Prediction>,
    ) -> Result<Prediction> {
        self.predict(model, data, start, false)
    }

    fn predict_near(
        &self,
        model: &Model,
        data: &FitData,
        start: &Prediction,
    ) -> Result<Prediction> {
        self.predict(model, data, Some(start), true)
    }
}

impl HbPredictor {
    /// Every series' points in order; `near`: each point takes at least one
    /// Newton step from its start.
    fn predict(
        &self,
        model: &Model,
        data: &FitData,
        start: Option<&Prediction>,
        near: bool,
    ) -> Result<Prediction> {
        model.validate()?;
        // uncoupled parts (the point structure, each hysteretic mode) are
        // balanced apart and their harmonics added; a point's state is the
        // parts' solutions end to end
        let parts = model.parts();
        let sets = parts
            .iter()
            .map(|(_, m)| m.element_set())
            .collect::<Result<Vec<_>>>()?;
        let mut opts = self.options_for(model, data);
        // a Jacobian's column is balanced with its base's samples: a count
        // that changed with the parameter (a smooth law's, see
        // `options_for`) would put the quadratures' difference in it
        if let Some(ns) = start
            .filter(|_| near)
            .map(|p| p.samples_per_period)
            .filter(|&ns| ns > 0)
        {
            opts.samples_per_period = ns;
        }
        // each series gets its own element state (the elements are Send, not Sync)
        let starts: Vec<Option<&Vec<Option<Vec<Complex64>>>>> = (0..data.series.len())
            .map(|i| {
                start
                    .and_then(|p| p.states.get(i))
                    .filter(|s| s.len() == data.series[i].points.len())
            })
            .collect();
        let jobs: Vec<_> = data
            .series
            .iter()
            .zip(starts)
            .map(|(s, st)| (s, st, sets.clone()))
            .collect();
        let series: Vec<Result<SeriesPrediction>> = jobs
            .into_par_iter()
            .map(|(s, st, mut elements)| {
                predict_series(s, st, &mut elements, &parts, &opts, near, data)
            })
            .collect();
        let mut pred = Prediction {
            samples_per_period: opts.samples_per_period,
            ..Prediction::default()
        };
        for s in series {
            let (h, states, n) = s?;
            pred.h.push(h);
            pred.states.push(states);
            pred.solves += n;
        }
        Ok(pred)
    }
}

/// One series' points in measurement order (see [`HbPredictor::predict`]):
/// each from the same point of a nearby model's prediction `st` when given,
/// else continued from the previous point, scaled to the point's force.
fn predict_series(
    s: &crate::fit::problem::MeasuredSeries,
    st: Option<&Vec<Option<Vec<Complex64>>>>,
    elements: &mut [crate::model::ElementSet<crate::model::AnyElement>],
    parts: &[(f64, Model)],
    opts: &HbOptions,
    near: bool,
    data: &FitData,
) -> Result<SeriesPrediction> {
    let nh = opts.harmonics.len();
    let mut solvers = parts
        .iter()
        .map(|_| {
            let mut solver = HbSolver::new(opts)?;
            solver.step_at_least_once(near);
            Ok(solver)
        })
        .collect::<Result<Vec<_>>>()?;
    let mut previous: Option<(Vec<Complex64>, f64)> = None;
    let mut out = Vec::with_capacity(s.points.len());
    let mut states = Vec::with_capacity(s.points.len());
    for p in &s.points {
        // from the same point of a nearby model (the best so far), else
        // continued from the previous point
        let warm = st
            .and_then(|st| st[states.len()].clone())
            .filter(|g| g.len() == nh * parts.len());
        let guess: Option<Vec<Complex64>> = warm.or_else(|| {
            previous
                .as_ref()
                .map(|(x, f)| x.iter().map(|z| z * (p.force_amplitude / f)).collect())
        });
        let w = omega(p.frequency_hz);
        let mut state = Vec::with_capacity(nh * parts.len());
        let mut h = Vec::new();
        let mut converged = true;
        for (j, ((sign, part), (solver, e))) in parts
            .iter()
            .zip(solvers.iter_mut().zip(elements.iter_mut()))
            .enumerate()
        {
            let pt = solver.solve_point(
                &part.linear,
                e,
                p.frequency_hz,
                p.force_amplitude,
                guess.as_deref().map(|g| &g[j * nh..(j + 1) * nh]),
            )?;
            if !pt.converged {
                converged = false;
                break;
            }
            let part_h = data.harmonics.iter().map(|&k| {
                *sign
                    * pt.frf(k).unwrap_or_default()
                    * data.response.from_displacement(k as f64 * w)
            });
            if j == 0 {
                h = part_h.collect();
            } else {
                h.iter_mut().zip(part_h).for_each(|(a, b)| *a += b);
            }
            state.extend_from_slice(&pt.x);
        }
        if converged {
            previous = Some((state.clone(), p.force_amplitude));
            states.push(Some(state));
            out.push(Some(h));
        } else {
            previous = None;
            states.push(None);
            out.push(None);
        }
    }
    Ok((out, states, s.points.len()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extract::Direction;
    use crate::fit::problem::{MeasuredPoint, MeasuredSeries};
    use crate::harmonics::Quantity;
    use crate::model::{ElementSpec, ModalModel};

    /// One point of the paper's SDOF at 250 Hz and 300 N, where its joint
    /// slips (only the harmonics matter to the options).
    fn data() -> FitData {
        FitData {
            response: Quantity::Displacement,
            harmonics: vec![1, 3],
            series: vec![MeasuredSeries {
                level: 300.0,
                direction: Direction::Up,
                points: vec![MeasuredPoint {
                    frequency_hz: 250.0,
                    force_amplitude: 300.0,
                    h: vec![Complex64::new(1e-7, 0.0); 2],
                    std_error: vec![1e-9; 2],
                    blocks: 0,
                }],
            }],
            response_sign: 1.0,
            transfer: false,
            unusable_points: 0,
            subharmonic_points: Vec::new(),
            anchor: None,
        }
    }

    fn paper_with(laws: Vec<ElementSpec>) -> Model {
        Model::new(ModalModel::sdof(10.0, 200.0, 1e7).unwrap(), laws).unwrap()
    }

    fn masing(n: f64) -> ElementSpec {
        ElementSpec::Masing {
            kd: 2.4e7,
            fd: 246.048,
            n,
        }
    }

    /// A model whose every law states a count (`Description::smooth_samples`)
    /// is balanced with the largest they state; one law that states none
    /// keeps the default, a law with kinks its own, and a count the
    /// predictor was given stands.
    #[test]
    fn a_model_of_smooth_laws_is_balanced_with_the_fewer_samples_they_state() {
        let p = HbPredictor::default();
        let ns = |laws| p.options_for(&paper_with(laws), &data()).samples_per_period;
        assert_eq!(ns(vec![masing(2.0)]), 128);
        assert_eq!(ns(vec![masing(3.5)]), 128);
        assert_eq!(
            ns(vec![masing(2.0), ElementSpec::CubicStiffness { k3: 1e12 }]),
            128
        );
        assert_eq!(ns(vec![masing(4.0)]), 256);
        assert_eq!(
            ns(vec![masing(2.0), ElementSpec::QuadraticDamping { c2: 1.0 }]),
            256
        );
        assert_eq!(
            ns(vec![ElementSpec::Jenkins {
                kd: 2.4e7,
                fd: 246.048
            }]),
            512
        );
        let own = HbPredictor {
            options: HbOptions {
                samples_per_period: 1024,
                ..HbOptions::default()
            },
        };
        let model = paper_with(vec![masing(2.0)]);
        assert_eq!(own.options_for(&model, &data()).samples_per_period, 1024);
    }

    /// A Jacobian's column (`predict_near`) is balanced with its base's
    /// samples even where its own parameters would state another count:
    /// the base at N = 4 (256), the column at N = 3.5 (128 of its own).
    #[test]
    fn a_jacobian_column_keeps_its_bases_samples() {
        let p = HbPredictor::default();
        let base = p
            .predict_from(&paper_with(vec![masing(4.0)]), &data(), None)
            .unwrap();
        assert_eq!(base.samples_per_period, 256);
        let column = paper_with(vec![masing(3.5)]);
        let near = p.predict_near(&column, &data(), &base).unwrap();
        assert_eq!(near.samples_per_period, 256);
        let own = p.predict_from(&column, &data(), Some(&base)).unwrap();
        assert_eq!(own.samples_per_period, 128);
        // the two quadratures differ, by far less than the point's response
        let (a, b) = (
            near.h[0][0].as_ref().unwrap()[0],
            own.h[0][0].as_ref().unwrap()[0],
        );
        assert!(a != b && (a - b).norm() < 1e-4 * a.norm(), "{a} vs {b}");
    }
}
