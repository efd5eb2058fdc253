//! Integer-factor resampling by a Kaiser-windowed sinc (polyphase FIR).
//!
//! The simulator needs more samples per period of the model's stiffest (stick)
//! mode than a measurement may hold (ABRAVIBE's `timefresp` likewise upsamples
//! by 5 and decimates back). Interpolating the measured force band-limits it
//! to the measurement's own band; decimating the simulated response low-passes
//! it first, so harmonics the joint makes above the measurement's Nyquist
//! frequency do not alias into the result.
//!
//! Both filters are the same windowed sinc, cut off at [`CUTOFF`] of the
//! original Nyquist frequency, [`HALF_WIDTH`] original samples on each side
//! (Kaiser β = [`KAISER_BETA`], stopband about −90 dB, transition about
//! 0.09 `fs` wide). They are symmetric, so there is no delay; samples beyond
//! the record's ends count as zero (records start and end at rest or are
//! treated as if they did).

use crate::error::{Error, Result};
use crate::signals::SamplesView;
use std::f64::consts::PI;

/// Cut-off of both filters as a fraction of the original Nyquist frequency.
pub const CUTOFF: f64 = 0.9;
/// Half-length of the filters, original samples.
pub const HALF_WIDTH: usize = 32;
/// Kaiser window parameter.
pub const KAISER_BETA: f64 = 8.6;

/// Largest resampling factor accepted (a model that needs more is far
/// stiffer than the measurement can show).
pub const MAX_FACTOR: usize = 64;

/// Modified Bessel function of the first kind, order 0 (power series; the
/// terms fall fast for the arguments of a Kaiser window, `x ≤ 10`).
fn bessel_i0(x: f64) -> f64 {
    let q = 0.25 * x * x;
    let (mut sum, mut term) = (1.0, 1.0);
    for k in 1..200 {
        term *= q / (k * k) as f64;
        sum += term;
        if term < 1e-17 * sum {
            break;
        }
    }
    sum
}

/// `sinc(u) = sin(πu)/(πu)`.
fn sinc(u: f64) -> f64 {
    if u.abs() < 1e-12 {
        1.0
    } else {
        (PI * u).sin() / (PI * u)
    }
}

/// The prototype filter at the high rate, `2·HALF_WIDTH·factor + 1` taps
/// centred on index `HALF_WIDTH·factor`, with DC gain `factor` (the
/// interpolator's; the decimator divides by `factor`).
fn prototype(factor: usize) -> Vec<f64> {
    prototype_of(factor, HALF_WIDTH)
}

/// [`prototype`] reaching `half_width` original samples on each side.
fn prototype_of(factor: usize, half_width: usize) -> Vec<f64> {
    let reach = (half_width * factor) as f64;
    let i0b = bessel_i0(KAISER_BETA);
    (0..=2 * half_width * factor)
        .map(|i| {
            let t = i as f64 - reach;
            let r = t / reach;
            let w = bessel_i0(KAISER_BETA * (1.0 - r * r).max(0.0).sqrt()) / i0b;
            CUTOFF * sinc(CUTOFF * t / factor as f64) * w
        })
        .collect()
}

pub(crate) fn check(factor: usize, x: &[f64], what: &str) -> Result<()> {
    if factor == 0 || factor > MAX_FACTOR {
        return Err(Error::input(
            "resampling factor",
            format!("must be 1..={MAX_FACTOR}, got {factor}"),
        ));
    }
    match x.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(not_finite(what, x, i)),
        None => Ok(()),
    }
}

/// The error [`check`] gives for sample `i` of `x`, which is not finite.
pub(crate) fn not_finite<'a>(what: &str, x: impl Into<SamplesView<'a>>, i: usize) -> Error {
    Error::input(
        format!("{what} sample {i}"),
        format!("must be finite, got {}", x.into().get(i)),
    )
}

/// Interpolates `x` by `factor`: `factor·x.len()` samples at `factor` times
/// the rate, `y[factor·k] ≈ x[k]`, band-limited to [`CUTOFF`] of the
/// original Nyquist frequency.
pub fn interpolate(x: &[f64], factor: usize) -> Result<Vec<f64>> {
    check(factor, x, "signal")?;
    if factor == 1 {
        return Ok(x.to_vec());
    }
    let mut y = Vec::with_capacity(x.len() * factor);
    Interpolator::new(factor).fill(x.into(), 0..x.len() * factor, &mut y);
    Ok(y)
}

/// [`interpolate`]'s filter, split into its `factor` phases: any stretch
/// of the interpolated signal made on its own, from the original samples
/// within the filter's reach, equal to the bit to the whole's (the same
/// taps summed in the same order). A replay made once need not hold its
/// drive interpolated whole (`factor` times the record in `f64`s).
#[derive(Clone, Debug)]
pub struct Interpolator {
    factor: usize,
    /// Per phase `p`: the first `j` its taps pair with (`x[q − j]`), and
    /// the taps.
    phases: Vec<(isize, Vec<f64>)>,
}

impl Interpolator {
    /// The filter of [`interpolate`] by `factor` (at least 2).
    pub fn new(factor: usize) -> Interpolator {
        let h = prototype(factor);
        let centre = HALF_WIDTH * factor;
        // polyphase: output m = q·factor + p sums x[k]·h(m − k·factor);
        // taps of phase p: h[centre + p + j·factor] pairs with x[q − j]
        let phases = (0..factor)
            .map(|p| {
                let lo = -((centre + p) as isize / factor as isize);
                let hi = ((h.len() - 1 - centre - p) / factor) as isize;
                let taps = (lo..=hi)
                    .map(|j| h[(centre as isize + p as isize + j * factor as isize) as usize])
                    .collect();
                (lo, taps)
            })
            .collect();
        Interpolator { factor, phases }
    }

    /// Appends samples `fine` of `x` interpolated to `out` (samples beyond
    /// the record's ends count as zero).
    pub fn fill(&self, x: SamplesView, fine: std::ops::Range<usize>, out: &mut Vec<f64>) {
        if fine.is_empty() {
            return;
        }
        let (f, n) = (self.factor, x.len());
        // the original samples within reach of the stretch
        let reach = self.phases.iter().map(|(_, t)| t.len()).max().unwrap_or(0);
        let first = (fine.start / f).saturating_sub(reach);
        let last = ((fine.end - 1) / f + reach + 1).min(n);
        let xs = x.range(first..last.max(first));
        out.extend(fine.map(|m| {
            let (q, p) = (m / f, m % f);
            let (lo, taps) = &self.phases[p];
            let mut acc = 0.0;
            for (t, &c) in taps.iter().enumerate() {
                let k = q as isize - (lo + t as isize);
                if k >= 0 && (k as usize) < n {
                    acc += c * xs[k as usize - first];
                }
            }
            acc
        }));
    }
}

/// Low-passes `y` (sampled at `factor` times the target rate) to
/// [`CUTOFF`] of the target Nyquist frequency and keeps every `factor`-th
/// sample, starting with the first: `ceil(y.len()/factor)` samples.
pub fn decimate(y: &[f64], factor: usize) -> Result<Vec<f64>> {
    decimate_with(y, factor, HALF_WIDTH)
}

/// [`decimate`] with a filter reaching `half_width` samples of the target
/// rate on each side ([`HALF_WIDTH`] for [`decimate`]): a shorter one costs
/// less and has a wider transition band, enough where what matters lies
/// well below the target Nyquist frequency (a time fit's judging, see
/// `fit::time::MAX_JUDGED_SAMPLES`).
pub fn decimate_with<'a>(
    y: impl Into<SamplesView<'a>>,
    factor: usize,
    half_width: usize,
) -> Result<Vec<f64>> {
    let y = match y.into() {
        SamplesView::Exact(y) => y,
        // converted and pushed a stretch at a time (no copy of the whole)
        held => {
            check(factor, &[], "signal")?;
            let mut d = Decimator::new(factor, half_width, held.len())?;
            let mut out = Vec::with_capacity(d.outputs());
            let mut bad = None;
            held.for_each_stretch(0..held.len(), |at, x| {
                if bad.is_none() {
                    bad = x.iter().position(|v| !v.is_finite()).map(|i| at + i);
                }
                d.push(x, &mut out);
            });
            return match bad {
                Some(i) => Err(not_finite("signal", held, i)),
                None => Ok(out),
            };
        }
    };
    check(factor, y, "signal")?;
    if factor == 1 {
        return Ok(y.to_vec());
    }
    let mut d = Decimator::new(factor, half_width, y.len())?;
    let mut out = Vec::with_capacity(d.outputs());
    // the samples where they are, not pushed (a copy)
    d.emit(y, 0, &mut out);
    Ok(out)
}

/// [`decimate_with`] a stretch at a time: the samples of a signal whose
/// length is known in advance are pushed as they come (a replay is made a
/// stretch at a time) and each output is made as soon as the filter's reach
/// has arrived, every one equal to the bit to [`decimate_with`]'s (the same
/// taps summed in the same order). Holds the filter's reach, not the
/// signal.
#[derive(Clone, Debug)]
pub struct Decimator {
    g: Vec<f64>,
    factor: usize,
    centre: usize,
    /// Samples of the whole signal.
    total: usize,
    /// Samples from `held_from` on, pushed and still in some output's reach.
    held: Vec<f64>,
    held_from: usize,
    /// The next output's index.
    next: usize,
}

impl Decimator {
    /// A decimator by `factor` (1 passes the samples on) with a filter
    /// reaching `half_width` output samples on each side, for a signal of
    /// `total` samples.
    pub fn new(factor: usize, half_width: usize, total: usize) -> Result<Decimator> {
        check(factor, &[], "signal")?;
        let g = if factor == 1 {
            Vec::new()
        } else {
            prototype_of(factor, half_width)
                .into_iter()
                .map(|v| v / factor as f64)
                .collect()
        };
        Ok(Decimator {
            g,
            factor,
            centre: half_width * factor,
            total,
            held: Vec::new(),
            held_from: 0,
            next: 0,
        })
    }

    /// Outputs of the whole signal: `ceil(total/factor)`.
    pub fn outputs(&self) -> usize {
        self.total.div_ceil(self.factor)
    }

    /// Pushes the next samples (at most up to the signal's length) and
    /// appends every output whose reach they complete.
    pub fn push(&mut self, x: &[f64], out: &mut Vec<f64>) {
        if self.factor == 1 {
            out.extend_from_slice(x);
            self.next += x.len();
            return;
        }
        self.held.extend_from_slice(x);
        let held = std::mem::take(&mut self.held);
        self.emit(&held, self.held_from, out);
        self.held = held;
        // what no later output reaches
        let keep_from = (self.next * self.factor).saturating_sub(self.centre);
        if keep_from > self.held_from {
            let drop = (keep_from - self.held_from).min(self.held.len());
            self.held.drain(..drop);
            self.held_from += drop;
        }
    }

    /// Appends every output not yet made whose reach `x` (the signal's
    /// samples from `from` on) holds.
    fn emit(&mut self, x: &[f64], from: usize, out: &mut Vec<f64>) {
        let received = from + x.len();
        let (factor, centre, n) = (self.factor, self.centre, self.total);
        while self.next < self.outputs() {
            let m0 = self.next * factor;
            let hi = (m0 + centre).min(n - 1);
            if hi >= received {
                break;
            }
            let acc = if m0 >= centre && m0 + centre < n {
                // inside: every tap, summed in the same order as below
                let a = m0 - centre - from;
                x[a..a + self.g.len()]
                    .iter()
                    .zip(&self.g)
                    .fold(0.0, |acc, (v, c)| acc + c * v)
            } else {
                let lo = m0.saturating_sub(centre);
                let mut acc = 0.0;
                for m in lo..=hi {
                    acc += self.g[m + centre - m0] * x[m - from];
                }
                acc
            };
            out.push(acc);
            self.next += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bessel_matches_tabulated_values() {
        // Abramowitz & Stegun table 9.8: I0(1) = 1.266065878, I0(5) = 27.23987182
        assert!((bessel_i0(1.0) - 1.266_065_878).abs() < 1e-9);
        assert!((bessel_i0(5.0) - 27.239_871_82).abs() < 1e-7);
    }

    #[test]
    fn interpolation_passes_the_samples_and_the_sine_between_them() {
        let fs = 100.0;
        let f = 13.0;
        let x: Vec<f64> = (0..600)
            .map(|i| (2.0 * PI * f * i as f64 / fs + 0.3).sin())
            .collect();
        for factor in [2, 3, 5] {
            let y = interpolate(&x, factor).unwrap();
            assert_eq!(y.len(), x.len() * factor);
            // away from the ends (the filter's reach), the band-limited sine
            let worst = (100 * factor..500 * factor)
                .map(|m| {
                    let t = m as f64 / (fs * factor as f64);
                    (y[m] - (2.0 * PI * f * t + 0.3).sin()).abs()
                })
                .fold(0.0, f64::max);
            assert!(worst < 2e-4, "factor {factor}: {worst}");
        }
    }

    #[test]
    fn decimation_keeps_the_band_and_rejects_what_would_alias() {
        let (fs, factor) = (100.0, 4);
        let hi = fs * factor as f64;
        // 10 Hz stays; 90 Hz would alias to 10 Hz at 100 Hz: must vanish
        let y: Vec<f64> = (0..4000)
            .map(|i| {
                let t = i as f64 / hi;
                (2.0 * PI * 10.0 * t).cos() + (2.0 * PI * 90.0 * t).cos()
            })
            .collect();
        let z = decimate(&y, factor).unwrap();
        assert_eq!(z.len(), 1000);
        let worst = (100..900)
            .map(|q| (z[q] - (2.0 * PI * 10.0 * q as f64 / fs).cos()).abs())
            .fold(0.0, f64::max);
        assert!(worst < 2e-4, "{worst}");
        assert!(decimate(&[1.0, f64::NAN], 2).is_err());
        // a stretch at a time, in stretches of any length: the same samples
        // to the bit
        for half_width in [8, HALF_WIDTH] {
            let whole = decimate_with(&y, factor, half_width).unwrap();
            for stretch in [1, 7, 64, 1000, 5000] {
                let mut d = Decimator::new(factor, half_width, y.len()).unwrap();
                let mut parts = Vec::new();
                for c in y.chunks(stretch) {
                    d.push(c, &mut parts);
                }
                assert_eq!(parts, whole, "stretch {stretch}, half width {half_width}");
            }
        }
        assert!(interpolate(&[1.0], 0).is_err());
    }
}
