//! A periodic multisine's lines: the measured response's mean and noise at
//! the lines of its period, and a replay's residual there.
//!
//! A periodic multisine (a period of `N` samples played `P + 1` times, the
//! first period a transient) is read where it is exact: at the lines of its
//! period. Over the `P` steady periods, the DFT of each period at line `k`
//! (`f_k = k f_s / N`) is averaged, `Ȳ_k = (1/P) Σ_p Y_k^(p)`, and the
//! periods' scatter gives the noise of that mean,
//! `σ_k² = Σ_p |Y_k^(p) − Ȳ_k|² / (P (P − 1))`, smoothed over the
//! neighbouring lines (with few periods one line's scatter is itself noisy).
//! The model's replay, driven by the same measured reference from rest, is
//! averaged over the same periods, `Ŷ_k`, so that the transient both share
//! cancels. The residual of line `k` in units of the noise is
//! `r_k = (Ȳ_k − Ŷ_k)/σ_k`, `|r_k|² ≈ 1` where only noise is left.
//!
//! The lines fall into three classes, the multisine user's reading of a
//! nonlinearity (Pintelon and Schoukens, *System Identification: A
//! Frequency Domain Approach*, 2012, ch. 4): the **excited** lines (the
//! reference's, within 20 dB of its strongest), where a wrong linear part or
//! a level-dependent stiffness or damping shows; and the lines not excited,
//! **odd** and **even** by their index `k`, where the response holds only what
//! the nonlinearity moved there (an odd law such as a joint or a cubic
//! stiffness fills odd combinations, an asymmetric one even ones). The lines
//! judged run to three times the highest excited frequency (an odd law's
//! third-order products), at most to Nyquist.
//!
//! The candidates of a diagnosis are traced on these lines in
//! `diagnose::lines`; a validation reports them ([`LineValidation`],
//! [`LineSpectrum`]).

use crate::error::{Error, Result};
use crate::signals::SamplesView;
use num_complex::Complex64;
use rustfft::FftPlanner;
use serde::Serialize;
use std::ops::Range;

/// What a line of a multisine's period holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LineClass {
    /// A line the reference excites.
    Excited,
    /// A line not excited, of odd index.
    OddNotExcited,
    /// A line not excited, of even index.
    EvenNotExcited,
}

impl LineClass {
    /// In words.
    pub fn words(self) -> &'static str {
        match self {
            LineClass::Excited => "excited",
            LineClass::OddNotExcited => "odd not excited",
            LineClass::EvenNotExcited => "even not excited",
        }
    }
}

/// The DFT of the real samples `x` (as long as `fft`).
fn spectrum(fft: &dyn rustfft::Fft<f64>, x: &[f64]) -> Vec<Complex64> {
    let mut b: Vec<Complex64> = x.iter().map(|&v| Complex64::new(v, 0.0)).collect();
    fft.process(&mut b);
    b
}

/// The lines of a period judged, from the reference's spectrum `u` over
/// the period (bins `0..⌈N/2⌉`): every bin from the first to three times
/// the highest excited one (where a cubic law puts its harmonics), each
/// with its class; `None` where no line is excited.
fn lines_of(u: &[Complex64]) -> Option<(Vec<usize>, Vec<LineClass>)> {
    let half = u.len();
    let strongest = u.get(1..)?.iter().map(|v| v.norm()).fold(0.0, f64::max);
    let excited =
        |k: usize| strongest > 0.0 && u[k].norm() >= crate::extract::EXCITED_LINE * strongest;
    let highest = (1..half).filter(|&k| excited(k)).max()?;
    let last = (3 * highest).min(half - 1);
    let bins: Vec<usize> = (1..=last).collect();
    let class = bins
        .iter()
        .map(|&k| match (excited(k), k % 2) {
            (true, _) => LineClass::Excited,
            (false, 1) => LineClass::OddNotExcited,
            _ => LineClass::EvenNotExcited,
        })
        .collect();
    Some((bins, class))
}

/// A model's error at the lines of a single period: a record with no
/// second steady period to judge the noise by (`validate --periodic`, the
/// record one period of a periodic steady state). Each line's amplitude
/// measured, simulated and of their difference, and per class of line the
/// difference relative to what was measured there: the output-error
/// spectrum a benchmark reports beside e_RMS.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LineSpectrum {
    /// Samples in the period.
    pub period_samples: usize,
    /// Lines judged (every bin up to three times the highest excited).
    pub lines: usize,
    /// The difference's RMS over the lines judged (Parseval), in the
    /// response's unit: the part of e_RMS the period's lines hold.
    pub error_rms_at_lines: f64,
    /// Per class of line.
    pub by_class: Vec<ClassError>,
    /// Each line's frequency (Hz), class and amplitudes (measured,
    /// simulated, difference; a sinusoid's amplitude, `2|X_k|/N`): the
    /// figure's.
    #[serde(skip)]
    pub per_line: Vec<(f64, LineClass, [f64; 3])>,
}

/// A class of line's share of a [`LineSpectrum`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClassError {
    /// The class.
    pub class: LineClass,
    /// Lines of it judged.
    pub lines: usize,
    /// `√(Σ|Y − Ŷ|² / Σ|Y|²)` over its lines (measured `Y`, simulated
    /// `Ŷ`); infinite where nothing was measured there.
    pub relative: f64,
    /// Its share of the difference's power at the lines judged.
    pub share: f64,
}

/// The [`LineSpectrum`] of `simulated` against `measured` over one period
/// driven by `reference` (the same length, at `sample_rate_hz`); `None`
/// where the reference excites no line or the period is shorter than 8
/// samples.
pub fn line_spectrum(
    reference: &[f64],
    measured: &[f64],
    simulated: &[f64],
    sample_rate_hz: f64,
) -> Option<LineSpectrum> {
    let n = reference.len();
    if n < 8 || measured.len() != n || simulated.len() != n {
        return None;
    }
    let fft = FftPlanner::<f64>::new().plan_fft_forward(n);
    let half = |x: &[f64]| {
        let mut b = spectrum(&*fft, x);
        b.truncate(n.div_ceil(2));
        b
    };
    let (u, y, m) = (half(reference), half(measured), half(simulated));
    let (bins, class) = lines_of(&u)?;
    let amplitude = |v: Complex64| 2.0 * v.norm() / n as f64;
    let per_line: Vec<(f64, LineClass, [f64; 3])> = bins
        .iter()
        .zip(&class)
        .map(|(&k, &c)| {
            let f = k as f64 * sample_rate_hz / n as f64;
            (
                f,
                c,
                [amplitude(y[k]), amplitude(m[k]), amplitude(y[k] - m[k])],
            )
        })
        .collect();
    let power: f64 = per_line.iter().map(|l| l.2[2] * l.2[2]).sum();
    let by_class = [
        LineClass::Excited,
        LineClass::OddNotExcited,
        LineClass::EvenNotExcited,
    ]
    .into_iter()
    .filter_map(|c| {
        let of: Vec<&[f64; 3]> = per_line.iter().filter(|l| l.1 == c).map(|l| &l.2).collect();
        let error: f64 = of.iter().map(|a| a[2] * a[2]).sum();
        let measured: f64 = of.iter().map(|a| a[0] * a[0]).sum();
        (!of.is_empty()).then(|| ClassError {
            class: c,
            lines: of.len(),
            relative: if measured > 0.0 {
                (error / measured).sqrt()
            } else {
                f64::INFINITY
            },
            share: if power > 0.0 { error / power } else { 0.0 },
        })
    })
    .collect();
    Some(LineSpectrum {
        period_samples: n,
        lines: bins.len(),
        // a sinusoid of amplitude A has RMS A/√2
        error_rms_at_lines: (power / 2.0).sqrt(),
        by_class,
        per_line,
    })
}

/// Neighbouring lines on either side over which a line's noise is averaged.
const NOISE_NEIGHBOURS: usize = 8;

/// One recording's steady periods at the lines of its period: the measured
/// response's mean and its noise (see the module docs).
#[derive(Clone, Debug)]
pub struct PeriodicSpectra {
    /// The recording.
    pub name: String,
    /// What its reference is (a force, or a shaker's voltage).
    pub reference_quantity: crate::harmonics::Quantity,
    /// Samples per second.
    pub sample_rate_hz: f64,
    /// Samples per period.
    pub period: usize,
    /// The steady periods, as samples of the record.
    periods: Vec<Range<usize>>,
    /// The lines judged (DFT bins).
    pub bins: Vec<usize>,
    /// Each line's class.
    pub class: Vec<LineClass>,
    /// The reference's mean spectrum at the lines.
    pub reference: Vec<Complex64>,
    /// The measured response's mean spectrum at the lines.
    pub measured: Vec<Complex64>,
    /// The noise (standard error) of `measured` at each line.
    pub sigma: Vec<f64>,
}

impl PeriodicSpectra {
    /// The spectra of two channels (reference and response) held however
    /// they are, judged
    /// over `periods` (at least two, of equal length, in order): each
    /// period's spectrum is made and added in turn, never all held (the
    /// response read twice: its mean, then its scatter about it), so a
    /// recording of any length costs a period's samples.
    pub fn of_channels(
        name: &str,
        (reference_quantity, sample_rate_hz): (crate::harmonics::Quantity, f64),
        (reference, response): (SamplesView, SamplesView),
        periods: Vec<Range<usize>>,
    ) -> Result<PeriodicSpectra> {
        let at = |f: &str| format!("{name}: {f}");
        let period = periods.first().map_or(0, |s| s.len());
        if periods.len() < 2 || period < 8 || periods.iter().any(|s| s.len() != period) {
            return Err(Error::input(
                at("periods"),
                format!(
                    "the residual per line needs at least two steady periods of equal length; \
                     the record is judged over {} stretch(es)",
                    periods.len()
                ),
            ));
        }
        let fft = FftPlanner::<f64>::new().plan_fft_forward(period);
        // every period's spectrum at `bins`, handed in turn to `each`
        let spectra = |x: SamplesView, bins: &[usize], each: &mut dyn FnMut(usize, Complex64)| {
            for p in &periods {
                let b = spectrum(&*fft, &x.range(p.clone()));
                for (i, &k) in bins.iter().enumerate() {
                    each(i, b[k]);
                }
            }
        };
        let n = periods.len() as f64;
        let half = period.div_ceil(2);
        let mut u = vec![Complex64::new(0.0, 0.0); half];
        let all: Vec<usize> = (0..half).collect();
        spectra(reference, &all, &mut |k, v| u[k] += v);
        u.iter_mut().for_each(|v| *v /= n);
        let (bins, class) = lines_of(&u)
            .ok_or_else(|| Error::input(at("reference"), "no line of its period is excited"))?;
        let mut measured = vec![Complex64::new(0.0, 0.0); bins.len()];
        spectra(response, &bins, &mut |i, v| measured[i] += v);
        measured.iter_mut().for_each(|v| *v /= n);
        let mut scatter = vec![0.0; bins.len()];
        spectra(response, &bins, &mut |i, v| {
            scatter[i] += (v - measured[i]).norm_sqr()
        });
        scatter.iter_mut().for_each(|v| *v /= n * (n - 1.0));
        // smoothed over the neighbours; held above the rounding of the
        // largest line, so that a noise-free record still scales
        let floor = (1e-12 * measured.iter().map(|v| v.norm()).fold(0.0, f64::max)).powi(2);
        let sigma = (0..bins.len())
            .map(|i| {
                let lo = i.saturating_sub(NOISE_NEIGHBOURS);
                let hi = (i + NOISE_NEIGHBOURS + 1).min(bins.len());
                let v = scatter[lo..hi].iter().sum::<f64>() / (hi - lo) as f64;
                v.max(floor).max(f64::MIN_POSITIVE).sqrt()
            })
            .collect();
        Ok(PeriodicSpectra {
            name: name.to_string(),
            reference_quantity,
            sample_rate_hz,
            period,
            reference: bins.iter().map(|&k| u[k]).collect(),
            periods,
            bins,
            class,
            measured,
            sigma,
        })
    }

    /// The frequency of line `i`, Hz.
    pub fn frequency_hz(&self, i: usize) -> f64 {
        self.bins[i] as f64 * self.sample_rate_hz / self.period as f64
    }

    /// A replay's mean spectrum at the lines made as the replay comes, a
    /// stretch at a time ([`ReplayedLines`]).
    pub fn replayed_lines(&self) -> ReplayedLines<'_> {
        ReplayedLines {
            spectra: self,
            fft: FftPlanner::<f64>::new().plan_fft_forward(self.period),
            next: 0,
            held: Vec::with_capacity(self.period),
            sum: vec![Complex64::new(0.0, 0.0); self.bins.len()],
        }
    }

    /// A replay's mean spectrum over the same periods at the same lines
    /// ([`ReplayedLines`] handed the whole replay). Panics where the replay
    /// ends before the last period.
    pub fn replayed(&self, replay: &[f64]) -> Vec<Complex64> {
        let mut lines = self.replayed_lines();
        lines.push(0, replay);
        lines
            .finish()
            .expect("a replay as long as the record it was made for")
    }

    /// The residual in units of the noise, `(Ȳ − Ŷ)/σ`, of a replay's lines.
    pub fn residual(&self, replayed: &[Complex64]) -> Vec<Complex64> {
        self.measured
            .iter()
            .zip(replayed)
            .zip(&self.sigma)
            .map(|((m, r), s)| (m - r) / s)
            .collect()
    }

    /// The RMS of the measured displacement over a period, from the lines
    /// (Parseval; the response converted from its quantity at each line).
    pub fn displacement_rms(&self, quantity: crate::harmonics::Quantity) -> f64 {
        let sum: f64 = (0..self.bins.len())
            .map(|i| {
                let w = crate::harmonics::omega(self.frequency_hz(i));
                (self.measured[i] / quantity.from_displacement(w)).norm_sqr()
            })
            .sum();
        (2.0 * sum).sqrt() / self.period as f64
    }
}

/// A replay's mean spectrum at the lines of [`PeriodicSpectra`], made from
/// the replay handed a stretch at a time, in order: a period is held until
/// it is complete, then its spectrum is added ([`PeriodicSpectra::replayed`]
/// of the whole replay, to the bit, holding a period's samples).
pub struct ReplayedLines<'a> {
    spectra: &'a PeriodicSpectra,
    fft: std::sync::Arc<dyn rustfft::Fft<f64>>,
    /// The period being filled.
    next: usize,
    /// Its samples so far.
    held: Vec<f64>,
    sum: Vec<Complex64>,
}

impl ReplayedLines<'_> {
    /// The replay's samples `at..at + replay.len()`, following those
    /// pushed before.
    pub fn push(&mut self, at: usize, replay: &[f64]) {
        let end = at + replay.len();
        let periods = &self.spectra.periods;
        while let Some(p) = periods.get(self.next) {
            // the sample the period needs next; a stretch handed twice or
            // one skipped cannot fill it
            let want = p.start + self.held.len();
            if want >= end || want < at {
                break;
            }
            let stop = p.end.min(end);
            self.held.extend_from_slice(&replay[want - at..stop - at]);
            if self.held.len() < p.len() {
                break;
            }
            let b = spectrum(&*self.fft, &self.held);
            for (s, &k) in self.sum.iter_mut().zip(&self.spectra.bins) {
                *s += b[k];
            }
            self.held.clear();
            self.next += 1;
        }
    }

    /// The mean spectrum; an error where the replay ended before the last
    /// period.
    pub fn finish(self) -> Result<Vec<Complex64>> {
        let periods = &self.spectra.periods;
        if self.next < periods.len() {
            return Err(Error::input(
                format!("{}: replay", self.spectra.name),
                format!(
                    "ends inside period {} of {} (samples {:?})",
                    self.next + 1,
                    periods.len(),
                    periods[self.next]
                ),
            ));
        }
        let n = periods.len() as f64;
        Ok(self.sum.into_iter().map(|v| v / n).collect())
    }
}

/// `χ²` of a class of lines, and its share of the whole.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClassResidual {
    /// The class.
    pub class: LineClass,
    /// Lines of it judged.
    pub lines: usize,
    /// `χ²` per line (about 1 where only noise is left).
    pub chi2_per_line: f64,
    /// Its share of the residual's `χ²`.
    pub share: f64,
}

/// `χ²` per line over a band of the excited range.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BandResidual {
    /// From, Hz.
    pub from_hz: f64,
    /// To, Hz.
    pub to_hz: f64,
    /// Lines in it (all classes).
    pub lines: usize,
    /// `χ²` per line.
    pub chi2_per_line: f64,
}

/// One of the lines the residual is largest at.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StrongLine {
    /// The recording.
    pub recording: String,
    /// Its frequency, Hz.
    pub frequency_hz: f64,
    /// Its class.
    pub class: LineClass,
    /// `|r_k|`: the residual in units of the noise.
    pub in_noise: f64,
}

/// A model's residual per line over every recording, in features.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LineResidual {
    /// Lines judged over every recording.
    pub lines: usize,
    /// `χ²` per line over all (about 1 where only noise is left).
    pub chi2_per_line: f64,
    /// By class of line.
    pub by_class: Vec<ClassResidual>,
    /// By recording: its name and `χ²` per line.
    pub by_recording: Vec<(String, f64)>,
    /// By band, the judged range cut into [`BANDS`] of equal width.
    pub by_band: Vec<BandResidual>,
    /// The lines it is largest at, the largest first (at most
    /// [`STRONGEST`]).
    pub strongest: Vec<StrongLine>,
}

/// Bands the residual is split into.
pub const BANDS: usize = 8;

/// Strongest lines reported.
pub const STRONGEST: usize = 6;

/// The features of the residuals `r` (one per recording, as
/// [`PeriodicSpectra::residual`] gives them).
pub fn line_residual(spectra: &[PeriodicSpectra], r: &[Vec<Complex64>]) -> LineResidual {
    let total: f64 = r.iter().flatten().map(|v| v.norm_sqr()).sum();
    let lines: usize = r.iter().map(|v| v.len()).sum();
    let by_class = [
        LineClass::Excited,
        LineClass::OddNotExcited,
        LineClass::EvenNotExcited,
    ]
    .into_iter()
    .filter_map(|class| {
        let (n, sum) = spectra
            .iter()
            .zip(r)
            .flat_map(|(s, r)| s.class.iter().zip(r))
            .filter(|(c, _)| **c == class)
            .fold((0usize, 0.0), |(n, sum), (_, v)| {
                (n + 1, sum + v.norm_sqr())
            });
        (n > 0).then(|| ClassResidual {
            class,
            lines: n,
            chi2_per_line: sum / n as f64,
            share: sum / total.max(f64::MIN_POSITIVE),
        })
    })
    .collect();
    let by_recording = spectra
        .iter()
        .zip(r)
        .map(|(s, r)| {
            let sum: f64 = r.iter().map(|v| v.norm_sqr()).sum();
            (s.name.clone(), sum / r.len().max(1) as f64)
        })
        .collect();
    let top = spectra
        .iter()
        .map(|s| s.frequency_hz(s.bins.len() - 1))
        .fold(0.0, f64::max);
    let by_band = (0..BANDS)
        .filter_map(|b| {
            let (from, to) = (
                top * b as f64 / BANDS as f64,
                top * (b + 1) as f64 / BANDS as f64,
            );
            let (n, sum) = spectra
                .iter()
                .zip(r)
                .flat_map(|(s, r)| (0..r.len()).map(move |i| (s.frequency_hz(i), r[i])))
                .filter(|(f, _)| *f > from && *f <= to)
                .fold((0usize, 0.0), |(n, sum), (_, v)| {
                    (n + 1, sum + v.norm_sqr())
                });
            (n > 0).then(|| BandResidual {
                from_hz: from,
                to_hz: to,
                lines: n,
                chi2_per_line: sum / n as f64,
            })
        })
        .collect();
    let mut all: Vec<StrongLine> = spectra
        .iter()
        .zip(r)
        .flat_map(|(s, r)| {
            (0..r.len()).map(move |i| StrongLine {
                recording: s.name.clone(),
                frequency_hz: s.frequency_hz(i),
                class: s.class[i],
                in_noise: r[i].norm(),
            })
        })
        .collect();
    all.sort_by(|a, b| {
        b.in_noise
            .total_cmp(&a.in_noise)
            .then(a.frequency_hz.total_cmp(&b.frequency_hz))
    });
    all.truncate(STRONGEST);
    LineResidual {
        lines,
        chi2_per_line: total / lines.max(1) as f64,
        by_class,
        by_recording,
        by_band,
        strongest: all,
    }
}

/// A model's response replayed on a held-out multisine, judged at the
/// lines of its period against the noise the periods' scatter measures
/// (`validate`'s figure for a multisine: about 1 per line where the model
/// leaves only noise).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LineValidation {
    /// Steady periods judged (the first, a transient, left out).
    pub steady_periods: usize,
    /// Samples per period.
    pub period_samples: usize,
    /// The residual's features.
    #[serde(flatten)]
    pub residual: LineResidual,
    /// Each line's frequency (Hz), `|r_k|` and class (the figure's).
    #[serde(skip)]
    pub per_line: Vec<(f64, f64, LineClass)>,
}

/// A replay's lines `replayed` (its mean spectrum at the lines of
/// `spectra`) judged against the measured ones.
pub fn validate_lines(spectra: &PeriodicSpectra, replayed: &[Complex64]) -> LineValidation {
    let r = spectra.residual(replayed);
    let per_line = r
        .iter()
        .enumerate()
        .map(|(i, v)| (spectra.frequency_hz(i), v.norm(), spectra.class[i]))
        .collect();
    LineValidation {
        steady_periods: spectra.periods.len(),
        period_samples: spectra.period,
        residual: line_residual(std::slice::from_ref(spectra), &[r]),
        per_line,
    }
}
