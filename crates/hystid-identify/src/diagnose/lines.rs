//! The residual of a time-domain fit to multisines, line by line, traced to
//! the candidates: the lines, their classes and the residual in units of
//! the noise are the signal layer's ([`crate::extract::lines`]).
//!
//! A candidate is traced by its signature on the lines, `δ_k = (Ŷ_k^c −
//! Ŷ_k)/σ_k`, the change of the replayed lines when it is added to the
//! model, less what the model's own free parameters can make: `δ` is
//! projected off the span of their sensitivities `∂Ŷ/∂θ_j / σ` (one replay
//! each), since the candidate's refit lets them readjust (a cubic stiffness
//! is at first mostly more stiffness, which the fitted stiffness already
//! gives). The share of the residual's `χ² = Σ|r_k|²` a step along it
//! removes at best is `s_c = max(0, Re⟨r, δ⟩)² / (‖r‖² ‖δ‖²)` (as in
//! [`super::time_residual`]), and for an effect of one size parameter the
//! Gauss–Newton step `Re⟨r, δ⟩/‖δ‖²` along a probe sizes its start.

use crate::error::Result;
use crate::extract::lines::{LineClass, PeriodicSpectra};
use crate::fit::time::TimeProblem;
use crate::model::{ElementSpec, Model};
use num_complex::Complex64;

/// `δ` with its components along the orthonormal `basis` removed.
fn orthogonal(delta: &[Vec<Complex64>], basis: &[Vec<Vec<Complex64>>]) -> Vec<Vec<Complex64>> {
    let mut out = delta.to_vec();
    for q in basis {
        let (dot, _) = projection(&out, q);
        for (o, q) in out.iter_mut().zip(q) {
            for (a, b) in o.iter_mut().zip(q) {
                *a -= b * dot;
            }
        }
    }
    out
}

/// `Re⟨r, δ⟩` and `‖δ‖²` over every recording's lines.
fn projection(r: &[Vec<Complex64>], delta: &[Vec<Complex64>]) -> (f64, f64) {
    let mut dot = 0.0;
    let mut dd = 0.0;
    for (r, d) in r.iter().zip(delta) {
        for (a, b) in r.iter().zip(d) {
            dot += a.re * b.re + a.im * b.im;
            dd += b.norm_sqr();
        }
    }
    (dot, dd)
}

/// `s_c` of the module docs: the share of the residual `r`'s `χ²` a step
/// along the signature `delta` removes at best (0 where it points away).
pub fn share_explained(r: &[Vec<Complex64>], delta: &[Vec<Complex64>]) -> f64 {
    let (dot, dd) = projection(r, delta);
    let rr: f64 = r.iter().flatten().map(|v| v.norm_sqr()).sum();
    if dd <= 0.0 || rr <= 0.0 || !dot.is_finite() {
        return 0.0;
    }
    dot.max(0.0).powi(2) / (rr * dd)
}

/// What a candidate's starts on the lines are made from: the model it is
/// added to, its replayed lines and residual, and the replay of any other
/// model on the same grid.
pub struct LineContext<'a> {
    model: &'a Model,
    problem: &'a TimeProblem<'a>,
    spectra: &'a [PeriodicSpectra],
    /// The model's residual per recording, in units of the noise.
    residual: Vec<Vec<Complex64>>,
    /// An orthonormal basis of the lines' change with the model's own free
    /// parameters (see [`LineContext::new`]).
    basis: Vec<Vec<Vec<Complex64>>>,
    /// Its `χ²`.
    pub chi2: f64,
    /// The largest displacement and velocity amplitudes of the responses.
    amplitudes: (f64, f64),
    /// The responses' quantity.
    quantity: crate::harmonics::Quantity,
}

/// A multisine's peak over its RMS taken for the amplitudes a candidate is
/// probed at: a random-phase multisine's crest factor is about 3-4, and
/// the probe only needs the order of magnitude (its Gauss–Newton step
/// sizes the start).
const CREST_FACTOR: f64 = 3.0;

impl<'a> LineContext<'a> {
    /// The context of `model` (replayed by `problem`, whose records are those
    /// of `spectra`, in order).
    pub fn new(
        model: &'a Model,
        problem: &'a TimeProblem<'a>,
        spectra: &'a [PeriodicSpectra],
        quantity: crate::harmonics::Quantity,
    ) -> Result<LineContext<'a>> {
        let lines = replay_lines(problem, spectra, model)?;
        let residual: Vec<Vec<Complex64>> = spectra
            .iter()
            .zip(&lines)
            .map(|(s, l)| s.residual(l))
            .collect();
        let chi2 = residual.iter().flatten().map(|v| v.norm_sqr()).sum();
        // the velocity's amplitude at the response's centroid frequency
        let (mut a, mut v) = (0.0f64, 0.0f64);
        for s in spectra {
            let x = CREST_FACTOR * s.displacement_rms(quantity);
            let (num, den) = (0..s.bins.len())
                .filter(|&i| s.class[i] == LineClass::Excited)
                .fold((0.0, 0.0), |(n, d), i| {
                    let m = (s.measured[i] / quantity.from_displacement(1.0)).norm();
                    (n + m * s.frequency_hz(i), d + m)
                });
            let w = crate::harmonics::omega(if den > 0.0 { num / den } else { 1.0 });
            a = a.max(x);
            v = v.max(x * w);
        }
        // the lines' change with each of the model's own free parameters
        // (a step of 1e-4 in its transformed coordinate), orthonormalised:
        // a candidate is traced by what it adds beyond them, as its refit
        // lets them readjust (a cubic stiffness is mostly more stiffness
        // at the excited lines, which the fitted stiffness already gives)
        let mut basis: Vec<Vec<Vec<Complex64>>> = Vec::new();
        let params = problem.parameters();
        if let Ok(theta) = params.theta_of(model) {
            let scale = residual.iter().flatten().map(|v| v.norm_sqr()).sum::<f64>();
            for j in 0..theta.len() {
                let mut t = theta.clone();
                t[j] += 1e-4;
                let Ok((m, _)) = params.model_at(model, &t) else {
                    continue;
                };
                let Ok(l) = replay_lines(problem, spectra, &m) else {
                    continue;
                };
                let column: Vec<Vec<Complex64>> = spectra
                    .iter()
                    .zip(&l)
                    .zip(&lines)
                    .map(|((s, a), b)| {
                        a.iter()
                            .zip(b)
                            .zip(&s.sigma)
                            .map(|((a, b), s)| (a - b) / s)
                            .collect()
                    })
                    .collect();
                let q = orthogonal(&column, &basis);
                let (_, qq) = projection(&q, &q);
                // a direction the lines do not feel, or one the others span
                if !(qq.is_finite() && qq > 1e-20 * scale.max(f64::MIN_POSITIVE)) {
                    continue;
                }
                let norm = qq.sqrt();
                basis.push(
                    q.into_iter()
                        .map(|v| v.into_iter().map(|x| x / norm).collect())
                        .collect(),
                );
            }
        }
        Ok(LineContext {
            model,
            problem,
            spectra,
            basis,
            residual,
            chi2,
            amplitudes: (a.max(f64::MIN_POSITIVE), v.max(f64::MIN_POSITIVE)),
            quantity,
        })
    }

    /// The model the effect is added to.
    pub fn model(&self) -> &Model {
        self.model
    }

    /// Each recording's reference peak (its RMS over a period, from the
    /// lines, times the multisine's crest factor).
    pub fn reference_peaks(&self) -> Vec<f64> {
        self.spectra
            .iter()
            .map(|s| {
                let sum: f64 = s.reference.iter().map(|u| u.norm_sqr()).sum();
                CREST_FACTOR * (2.0 * sum).sqrt() / s.period as f64
            })
            .collect()
    }

    /// What the recordings' reference is (the first's: a fit's are alike).
    pub fn reference_quantity(&self) -> crate::harmonics::Quantity {
        self.spectra
            .first()
            .map_or(crate::harmonics::Quantity::Force, |s| s.reference_quantity)
    }

    /// The model's residual per recording, in units of the noise.
    pub fn residual(&self) -> &[Vec<Complex64>] {
        &self.residual
    }

    /// The structure's viscous damping and its stiffness with the joint's
    /// stick stiffness (as the FRF diagnosis's context gives them).
    pub fn damping_and_stiffness(&self) -> (f64, f64) {
        let (_, c, k) = self.model.linear.as_mck().unwrap_or((1.0, 1.0, 1.0));
        (c, k + self.model.stick_stiffness())
    }

    /// The largest displacement and velocity amplitudes (a crest factor of
    /// 3 over the RMS the lines give).
    pub fn amplitudes(&self) -> (f64, f64) {
        self.amplitudes
    }

    /// The model with `element` added as an effect.
    pub fn with_element(&self, element: ElementSpec) -> Model {
        self.model.with_effect(element)
    }

    /// `model`'s signature: its replayed lines less the context model's, in
    /// units of the noise, without what the context model's own free
    /// parameters can give (the part a refit would absorb; `None`: the
    /// simulator rejects it).
    pub fn signature(&self, model: &Model) -> Option<Vec<Vec<Complex64>>> {
        let lines = replay_lines(self.problem, self.spectra, model).ok()?;
        let sig: Vec<Vec<Complex64>> = self
            .spectra
            .iter()
            .zip(&lines)
            .zip(&self.residual)
            .map(|((s, l), r)| {
                // (Ŷ_c − Ŷ)/σ = r − r_c
                r.iter().zip(s.residual(l)).map(|(r, rc)| r - rc).collect()
            })
            .collect();
        sig.iter()
            .flatten()
            .all(|v| v.re.is_finite() && v.im.is_finite())
            .then(|| orthogonal(&sig, &self.basis))
    }

    /// The residual at the excited lines as a displacement receptance
    /// (frequency, `(Ȳ − Ŷ)/U` in displacement per force, its standard
    /// error), every recording's lines in order of frequency, with the
    /// model's bending there: its receptance's sensitivities to a
    /// single mode's stiffness, mass and damping (`−H²`, `ω²H²`, `−iωH²`,
    /// `H = Ŷ/U`), as the FRF diagnosis's
    /// [`super::features::common_receptance_background`] gives them.
    #[allow(clippy::type_complexity)]
    pub fn receptance_residual(&self) -> (Vec<(f64, Complex64, f64)>, Vec<Vec<Complex64>>) {
        let mut points: Vec<(f64, Complex64, f64, Complex64)> = Vec::new();
        for (s, r) in self.spectra.iter().zip(&self.residual) {
            for (i, r) in r.iter().enumerate() {
                let u = s.reference[i];
                if s.class[i] != LineClass::Excited || u.norm() == 0.0 {
                    continue;
                }
                let f = s.frequency_hz(i);
                let conv = self.quantity.from_displacement(crate::harmonics::omega(f)) * u;
                let diff = r * s.sigma[i];
                let replayed = s.measured[i] - diff;
                points.push((f, diff / conv, s.sigma[i] / conv.norm(), replayed / conv));
            }
        }
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        let background = (0..3)
            .map(|j| {
                points
                    .iter()
                    .map(|&(f, _, _, h)| {
                        let w = crate::harmonics::omega(f);
                        let h2 = h * h;
                        [-h2, w * w * h2, -Complex64::i() * w * h2][j]
                    })
                    .collect()
            })
            .collect();
        (
            points.into_iter().map(|(f, d, e, _)| (f, d, e)).collect(),
            background,
        )
    }

    /// `χ²` of `model` on the lines (`None`: the simulator rejects it).
    pub fn chi2_of(&self, model: &Model) -> Option<f64> {
        let lines = replay_lines(self.problem, self.spectra, model).ok()?;
        let chi2: f64 = self
            .spectra
            .iter()
            .zip(&lines)
            .map(|(s, l)| s.residual(l).iter().map(|v| v.norm_sqr()).sum::<f64>())
            .sum();
        chi2.is_finite().then_some(chi2)
    }

    /// The model with an element of one size parameter added at the size
    /// the Gauss–Newton step along a probe at `probe` gives (`signed`: of
    /// either sign; else none where the step is negative, the residual
    /// asking for less than nothing). Empty where the probe is rejected.
    pub fn sized_starts(
        &self,
        with: &dyn Fn(f64) -> ElementSpec,
        probe: f64,
        signed: bool,
    ) -> Vec<Model> {
        let Some(delta) = self.signature(&self.with_element(with(probe))) else {
            return Vec::new();
        };
        let (dot, dd) = projection(&self.residual, &delta);
        if dd <= 0.0 || !dot.is_finite() || (!signed && dot <= 0.0) {
            return Vec::new();
        }
        let size = probe * dot / dd;
        let m = self.with_element(with(size));
        if m.validate().is_err() {
            return Vec::new();
        }
        vec![m]
    }

    /// Of `models`, the one with the lowest `χ²` on the lines, with it.
    pub fn best_as_it_stands(&self, models: impl Iterator<Item = Model>) -> Option<(f64, Model)> {
        models
            .filter_map(|m| Some((self.chi2_of(&m)?, m)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }
}

/// `model`'s replayed lines on every recording of `problem` (those of
/// `spectra`, in order), each replay's periods taken as it is made (a
/// period held at a time, never the replay: the same lines to the bit as
/// the whole replay's, see [`crate::extract::lines::ReplayedLines`]).
pub fn replay_lines(
    problem: &TimeProblem<'_>,
    spectra: &[PeriodicSpectra],
    model: &Model,
) -> Result<Vec<Vec<Complex64>>> {
    spectra
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let mut lines = s.replayed_lines();
            let mut replay = problem.replay_of(model, i)?;
            let mut at = 0;
            while let Some(stretch) = replay.next_stretch(&crate::observe::Silent)? {
                lines.push(at, stretch);
                at += stretch.len();
            }
            lines.finish()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extract::lines::{line_residual, line_spectrum};
    use crate::fit::TimeRecord;
    use crate::harmonics::Quantity;

    /// A record of `periods` periods of a three-line multisine through a
    /// linear filter `y = 2u` plus an odd distortion at line 9 (`u` excites
    /// 3, 4 and 5 of 64) and a small deterministic "noise".
    fn record(periods: usize) -> TimeRecord {
        let n = 64;
        let u: Vec<f64> = (0..n * periods)
            .map(|i| {
                let t = (i % n) as f64 / n as f64 * std::f64::consts::TAU;
                (3.0 * t).cos() + (4.0 * t + 1.0).cos() + (5.0 * t + 2.0).cos()
            })
            .collect();
        let y: Vec<f64> = u
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let t = (i % n) as f64 / n as f64 * std::f64::consts::TAU;
                // noise that differs per period, of RMS ~1e-3
                let e = 1e-3 * ((i as f64 * 12.9898).sin() * 43758.5453).fract();
                2.0 * v + 0.1 * (9.0 * t).cos() + e
            })
            .collect();
        TimeRecord {
            name: "r".into(),
            reference: u.into(),
            reference_quantity: Quantity::Force,
            response: y.into(),
            sample_rate_hz: 64.0,
            quantity: Quantity::Displacement,
            window: n..n * periods,
            segments: (1..periods).map(|p| p * n..(p + 1) * n).collect(),
            band_hz: None,
            periodic: true,
        }
    }

    #[test]
    fn the_lines_are_classed_and_the_distortion_is_where_it_was_put() {
        let r = record(5);
        let s = r.periodic_spectra().unwrap();
        // judged to three times the highest excited line, 15
        assert_eq!(s.bins, (1..=15).collect::<Vec<_>>());
        let class = |k: usize| s.class[k - 1];
        assert_eq!(class(3), LineClass::Excited);
        assert_eq!(class(5), LineClass::Excited);
        assert_eq!(class(9), LineClass::OddNotExcited);
        assert_eq!(class(10), LineClass::EvenNotExcited);
        // the mean spectrum: 2 U at the excited lines, N/2 · 0.1 at line 9
        for k in [3, 4, 5] {
            let i = k - 1;
            assert!((s.measured[i] - 2.0 * s.reference[i]).norm() < 1e-2 * s.measured[i].norm());
        }
        assert!(
            (s.measured[8].norm() - 3.2).abs() < 0.01,
            "{}",
            s.measured[8]
        );
        // a replay of the linear part alone leaves the distortion at line
        // 9, odd and not excited, far above the noise
        let replay: Vec<f64> = r.reference.values().iter().map(|v| 2.0 * v).collect();
        let res = s.residual(&s.replayed(&replay));
        let f = line_residual(std::slice::from_ref(&s), std::slice::from_ref(&res));
        assert_eq!(f.strongest[0].class, LineClass::OddNotExcited);
        assert!((f.strongest[0].frequency_hz - 9.0).abs() < 1e-12);
        let odd = f
            .by_class
            .iter()
            .find(|c| c.class == LineClass::OddNotExcited)
            .unwrap();
        assert!(odd.share > 0.99, "{odd:?}");
        // a signature along the distortion explains all of it; one at an
        // excited line none of it
        let mut along = vec![Complex64::new(0.0, 0.0); res.len()];
        along[8] = res[8] * 0.5;
        assert!(
            (share_explained(std::slice::from_ref(&res), std::slice::from_ref(&along)) - 1.0).abs()
                < 0.01
        );
        let mut across = vec![Complex64::new(0.0, 0.0); res.len()];
        across[3] = Complex64::new(1.0, 0.0);
        assert!(share_explained(std::slice::from_ref(&res), &[across]) < 1e-3);
    }

    /// The lines of a replay handed whole are the mean of each period's DFT
    /// written out; handed a stretch at a time (stretches of 1 to 150
    /// samples, across the periods' edges) they are the same to the bit,
    /// and so are the measured spectra of channels held
    /// in scratch files; a replay that ends inside a period is refused.
    #[test]
    fn a_replay_handed_in_stretches_has_the_whole_replays_lines() {
        let r = record(7);
        let s = r.periodic_spectra().unwrap();
        let replay: Vec<f64> = r
            .response
            .values()
            .iter()
            .enumerate()
            .map(|(i, v)| 0.9 * v + 1e-3 * (i as f64 * 0.37).sin())
            .collect();
        let whole = s.replayed(&replay);
        // against the mean over the periods of each line's DFT sum written
        // out (no FFT)
        let n = s.period as f64;
        for (i, &k) in s.bins.iter().enumerate() {
            // the spectra's periods are the record's segments
            let mean = r
                .segments
                .iter()
                .map(|p| {
                    p.clone()
                        .map(|t| {
                            let phase = -std::f64::consts::TAU * (k * (t - p.start)) as f64 / n;
                            replay[t] * Complex64::from_polar(1.0, phase)
                        })
                        .sum::<Complex64>()
                })
                .sum::<Complex64>()
                / r.segments.len() as f64;
            assert!(
                (whole[i] - mean).norm() < 1e-12 * (1.0 + mean.norm()),
                "line {k}"
            );
        }
        for step in [1, 7, 64, 150] {
            let mut lines = s.replayed_lines();
            let mut at = 0;
            for (k, chunk) in replay.chunks(step).enumerate() {
                // stretches of uneven length
                let n = chunk.len().min(1 + k % step);
                lines.push(at, &chunk[..n]);
                lines.push(at + n, &chunk[n..]);
                at += chunk.len();
            }
            assert!(lines.finish().unwrap() == whole, "stretches of {step}");
        }
        let mut short = s.replayed_lines();
        short.push(0, &replay[..replay.len() - 1]);
        let e = short.finish().unwrap_err().to_string();
        assert!(
            e.contains("r: replay") && e.contains("period 6 of 6"),
            "{e}"
        );
        let spill = |x: &[f64]| {
            let mut b = crate::signals::SamplesBuilder::new(x.len(), &[]).spilling_above(100);
            b.extend(x).unwrap();
            b.finish().unwrap()
        };
        let (u, y) = (spill(&r.reference.values()), spill(&r.response.values()));
        assert!(u.is_spilled() && y.is_spilled());
        let held = PeriodicSpectra::of_channels(
            "r",
            (r.reference_quantity, r.sample_rate_hz),
            (u.view(), y.view()),
            r.segments.clone(),
        )
        .unwrap();
        assert!(
            held.measured == s.measured && held.sigma == s.sigma && held.reference == s.reference
        );
    }

    /// One period's lines against the closed form: the record's period of
    /// three excited lines (3, 4, 5 of 64) through `y = 2u` with a
    /// distortion of amplitude 0.1 at line 9, replayed by `2u` alone. The
    /// excited lines are met (relative difference 0), the distortion is the
    /// whole difference (amplitude 0.1 at 9 Hz, its class's relative
    /// difference 1, all the power), and its RMS `0.1/√2` is the error's.
    #[test]
    fn one_periods_lines_hold_the_distortion_the_model_lacks() {
        let r = record(2);
        let u = r.reference.values();
        let n = 64;
        let period: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64 / n as f64 * std::f64::consts::TAU;
                2.0 * u[i] + 0.1 * (9.0 * t).cos()
            })
            .collect();
        let replay: Vec<f64> = u[..n].iter().map(|v| 2.0 * v).collect();
        let l = line_spectrum(&u[..n], &period, &replay, 64.0).unwrap();
        assert_eq!((l.period_samples, l.lines), (64, 15));
        let class = |c: LineClass| l.by_class.iter().find(|e| e.class == c).unwrap().clone();
        assert!(class(LineClass::Excited).relative < 1e-14);
        let odd = class(LineClass::OddNotExcited);
        assert!((odd.relative - 1.0).abs() < 1e-12 && (odd.share - 1.0).abs() < 1e-12);
        let nine = l.per_line[8];
        assert_eq!((nine.0, nine.1), (9.0, LineClass::OddNotExcited));
        assert!((nine.2[0] - 0.1).abs() < 1e-12 && nine.2[1] < 1e-14);
        assert!((nine.2[2] - 0.1).abs() < 1e-12);
        assert!((l.error_rms_at_lines - 0.1 / 2f64.sqrt()).abs() < 1e-12);
        // the excited lines' amplitudes: 2 of the reference's unit lines
        assert!((l.per_line[2].2[0] - 2.0).abs() < 1e-12);
        // nothing excited, nothing to judge
        assert!(line_spectrum(&[0.0; 64], &period, &replay, 64.0).is_none());
        assert!(line_spectrum(&u[..n], &period[..10], &replay, 64.0).is_none());
    }

    #[test]
    fn one_steady_period_is_refused_by_name() {
        let e = record(2).periodic_spectra().unwrap_err().to_string();
        assert!(
            e.contains("r: periods") && e.contains("at least two"),
            "{e}"
        );
    }
}
