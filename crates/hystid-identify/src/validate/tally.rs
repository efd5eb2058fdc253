//! The error figures of a replay tallied as it is made, a stretch at a
//! time: a validation never holds the simulated response whole (a stepped
//! test of eight million frames replayed is 66 MB a copy).
//!
//! The sum of squared errors is folded in the samples' order from the value
//! `Iterator::sum` starts from, so a tally equals [`super::error_metrics`]
//! of the whole signals to the bit. The split by frequency
//! ([`super::ErrorByFrequency`]) is Parseval's theorem on one FFT per block
//! of [`SPLIT_BLOCK`] samples: a stretch no longer than that is transformed
//! whole; a longer one in blocks of that length and what is
//! left, whose mean squares add up to the stretch's (a block's spectrum
//! resolves `fs / 2^20`, 0.03 Hz at 30 kHz; the last one's, shorter, less
//! finely, on its own share of the samples). A power of two keeps the
//! transforms fast and small, and the last block is padded with zeros to a
//! fast length: blocks of any length would take a Bluestein transform each,
//! 2.5 times the time and 190 MB on a record of 8 M samples.

use super::{BandShares, ErrorByFrequency, ErrorMetrics, error_metrics_of_sum, sum_start};
use crate::error::{Error, Result};
use crate::signals::SamplesView;
use std::ops::Range;

/// The most samples the split by frequency transforms at once (2^20, the
/// most a time fit judges: its splits are of one block).
pub const SPLIT_BLOCK: usize = 1 << 20;

/// The mean square of the error and of both responses below, inside, just
/// above and beyond a band, tallied block by block.
pub(crate) struct FrequencySplit {
    band: (f64, f64),
    sample_rate_hz: f64,
    range: Range<usize>,
    /// The measured mean over the range.
    mean: f64,
    blocks: usize,
    /// The block being filled and its last sample (exclusive).
    block: usize,
    block_end: usize,
    measured: Vec<f64>,
    simulated: Vec<f64>,
    /// `[error, measured, simulated][part]`.
    parts: [[f64; 4]; 3],
    planner: realfft::RealFftPlanner<f64>,
}

impl FrequencySplit {
    /// A split of samples `range` of `measured` (the measured mean taken
    /// over it now) about `band_hz`.
    ///
    /// Errors: an empty range or a band that is not `0 <= lo < hi`.
    pub(crate) fn new(
        measured: SamplesView,
        sample_rate_hz: f64,
        range: Range<usize>,
        band_hz: (f64, f64),
    ) -> Result<FrequencySplit> {
        let (a, b) = (range.start, range.end);
        let (lo, hi) = band_hz;
        if a >= b || !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo < hi) {
            return Err(Error::input(
                "error split by frequency",
                format!("samples {a}..{b} and band {lo}:{hi} Hz: need samples and 0 <= lo < hi"),
            ));
        }
        let len = b - a;
        let mut sum = sum_start();
        measured.for_each_stretch(a..b, |_, w| sum = w.iter().fold(sum, |acc, x| acc + x));
        let blocks = len.div_ceil(SPLIT_BLOCK);
        let mut split = FrequencySplit {
            band: band_hz,
            sample_rate_hz,
            range,
            mean: sum / len as f64,
            blocks,
            block: 0,
            block_end: a,
            measured: Vec::new(),
            simulated: Vec::new(),
            parts: [[0.0; 4]; 3],
            planner: realfft::RealFftPlanner::new(),
        };
        split.block_end = split.block_start(1);
        Ok(split)
    }

    fn block_start(&self, k: usize) -> usize {
        (self.range.start + k * SPLIT_BLOCK).min(self.range.end)
    }

    /// Takes the samples from `at` on (those outside the range are passed
    /// over); `measured` and `simulated` are as long.
    pub(crate) fn push(&mut self, at: usize, measured: &[f64], simulated: &[f64]) -> Result<()> {
        let mut i = at.max(self.range.start);
        let end = (at + measured.len()).min(self.range.end);
        while i < end {
            let take = (self.block_end.min(end)) - i;
            self.measured
                .extend_from_slice(&measured[i - at..i - at + take]);
            self.simulated
                .extend_from_slice(&simulated[i - at..i - at + take]);
            i += take;
            if i == self.block_end {
                self.close_block()?;
            }
        }
        Ok(())
    }

    fn close_block(&mut self) -> Result<()> {
        // the last block of a long stretch padded with zeros to a fast
        // length (its energy is the same: Parseval's theorem holds for the
        // padded block, on a finer grid of frequencies)
        let n = if self.blocks > 1 {
            crate::extract::next_smooth(self.measured.len())
        } else {
            self.measured.len()
        };
        let whole = self.range.len() as f64;
        let fft = self.planner.plan_fft_forward(n);
        let mut spectrum = fft.make_output_vec();
        let mut input = fft.make_input_vec();
        let (lo, hi) = self.band;
        let fs = self.sample_rate_hz;
        let mut parts = |x: &mut dyn Iterator<Item = f64>| -> Result<[f64; 4]> {
            input.fill(0.0);
            for (i, v) in input.iter_mut().zip(x) {
                *i = v;
            }
            fft.process(&mut input, &mut spectrum)
                .map_err(|e| Error::input("error split by frequency", e.to_string()))?;
            let mut out = [0.0; 4];
            for (k, z) in spectrum.iter().enumerate() {
                // each bin but the mean and (for an even length) Nyquist's
                // stands for its negative-frequency twin too
                let twice = k > 0 && 2 * k != n;
                let e = z.norm_sqr() * if twice { 2.0 } else { 1.0 };
                let f = k as f64 * fs / n as f64;
                out[if f < lo {
                    0
                } else if f <= hi {
                    1
                } else if f <= 2.0 * hi {
                    2
                } else {
                    3
                }] += e;
            }
            // this block's share of the range's mean square
            Ok(out.map(|e| e / (n as f64 * whole)))
        };
        let (m, s, mean) = (&self.measured, &self.simulated, self.mean);
        let got = [
            parts(&mut m.iter().zip(s).map(|(x, y)| y - x))?,
            parts(&mut m.iter().map(|x| x - mean))?,
            parts(&mut s.iter().map(|y| y - mean))?,
        ];
        for (sum, block) in self.parts.iter_mut().zip(got) {
            for (p, b) in sum.iter_mut().zip(block) {
                *p += b;
            }
        }
        self.measured.clear();
        self.simulated.clear();
        self.block += 1;
        self.block_end = self.block_start(self.block + 1);
        Ok(())
    }

    /// The split, every sample of the range having been pushed.
    pub(crate) fn finish(self) -> ErrorByFrequency {
        debug_assert_eq!(
            self.block, self.blocks,
            "a split was handed too few samples"
        );
        let [error, meas, sim] = self.parts;
        let rms = (meas.iter().sum::<f64>()).sqrt();
        let share = |i: usize| BandShares {
            error: error[i].sqrt() / rms,
            measured: meas[i].sqrt() / rms,
            simulated: sim[i].sqrt() / rms,
        };
        ErrorByFrequency {
            band_hz: self.band,
            below: share(0),
            inside: share(1),
            above: share(2),
            beyond: share(3),
        }
    }
}

/// The error figures over one range of samples, tallied as the simulated
/// response comes.
pub(crate) struct RangeTally {
    range: Range<usize>,
    squared_errors: f64,
    split: Option<FrequencySplit>,
}

impl RangeTally {
    /// A tally over `range` (clipped to the `n` samples compared; see
    /// [`super::error_window`]) of `measured`, split by frequency about
    /// `band_hz` where given and the measured response is not flat there.
    pub(crate) fn new(
        measured: SamplesView,
        n: usize,
        sample_rate_hz: f64,
        range: Range<usize>,
        band_hz: Option<(f64, f64)>,
    ) -> Result<RangeTally> {
        let (a, b) = super::error_window(range, n)?;
        let split = match band_hz {
            Some(band) => Some(FrequencySplit::new(measured, sample_rate_hz, a..b, band)?),
            None => None,
        };
        Ok(RangeTally {
            range: a..b,
            squared_errors: sum_start(),
            split,
        })
    }

    /// The range tallied.
    pub(crate) fn range(&self) -> Range<usize> {
        self.range.clone()
    }

    /// Takes the samples from `at` on.
    pub(crate) fn push(&mut self, at: usize, measured: &[f64], simulated: &[f64]) -> Result<()> {
        let i = at.max(self.range.start);
        let end = (at + measured.len()).min(self.range.end);
        if i < end {
            let (m, s) = (&measured[i - at..end - at], &simulated[i - at..end - at]);
            self.squared_errors = m
                .iter()
                .zip(s)
                .fold(self.squared_errors, |acc, (x, y)| acc + (y - x).powi(2));
        }
        if let Some(split) = &mut self.split {
            split.push(at, measured, simulated)?;
        }
        Ok(())
    }

    /// The figures, every sample of the range having been pushed.
    pub(crate) fn finish(self, measured: SamplesView, sample_rate_hz: f64) -> ErrorMetrics {
        let mut e = error_metrics_of_sum(measured, self.squared_errors, sample_rate_hz, self.range);
        // a flat measured response has no shares to split
        e.by_frequency = self
            .split
            .filter(|_| e.measured_rms > 0.0)
            .map(FrequencySplit::finish);
        e
    }
}
