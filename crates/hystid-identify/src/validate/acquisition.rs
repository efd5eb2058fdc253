//! The response channel's acquisition: the low-pass decimation stages a
//! recorded response passed through on its way from the rate it was made
//! at to the recording's, which the model's replay is put through too.
//!
//! A data-acquisition system, or a script that synthesises a benchmark,
//! samples fast and decimates: each stage low-passes with an FIR and keeps
//! every `r`-th sample. A short FIR is not flat in its pass band. MATLAB's
//! `decimate(y, r, 'fir')` filters with `fir1(30, 1/r)` (31 taps,
//! Hamming-windowed sinc, unit gain at DC, its delay of 15 samples
//! compensated): by 20 at once from 15 kHz it takes 0.085 % off 18 Hz and
//! 0.42 % off 41 Hz, which is what the Bouc-Wen benchmark's sine-sweep test
//! set carries. A replay of the continuous model then errs by that droop at
//! the response's resonance, however accurate it is (2.6e-6 m there against
//! about 1e-7 m with the droop put through).
//!
//! The chain is linear and its stages are zero-phase, so all it does to a
//! response below the recording's Nyquist frequency is scale each
//! frequency by `A(f) = Π_s A_s(f)`, each stage's
//! `A_s(f) = Σ_k b_k cos(2π f (k − L)/R_s)` at its input rate `R_s`. The
//! replay, made at the recording's rate, is put through the zero-phase FIR
//! at that rate whose response is `A(f)` (least squares on `[0, 0.8]` of
//! the Nyquist frequency, within [`MAX_KERNEL_ERROR`]): what the chain would
//! have made of the continuous response, as far as the recording can show
//! it. Its ends are extended by odd reflection about the end samples, as
//! `decimate` extends them.
//!
//! Declared in a model file beside `response_sign`:
//!
//! ```toml
//! [acquisition]
//! decimated_by = 20        # or stages in order, e.g. [2, 2, 5]
//! taps = 31                # each stage's FIR (31: MATLAB's decimate, 'fir')
//! ```
//!
//! or for the recordings validated, whatever the model, by `hystid validate
//! --acquisition 20` (`--acquisition-taps`).

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// Taps of each stage's FIR where a declaration does not say (MATLAB's
/// `decimate(…, 'fir')`: `fir1(30, 1/r)`).
pub const DEFAULT_TAPS: usize = 31;

/// Taps each side of the equivalent zero-phase FIR at the recording's rate.
const KERNEL_HALF_WIDTH: usize = 24;

/// Most the equivalent FIR's response may depart from the chain's over the
/// band it is fitted on (a stage whose response the recording's rate cannot
/// follow is refused).
pub const MAX_KERNEL_ERROR: f64 = 1e-7;

/// Share of the recording's Nyquist frequency the equivalent FIR is fitted
/// over (a recording's content above it is its own anti-aliasing's).
const FITTED_BAND: f64 = 0.8;

/// How the response was decimated to the recording's rate (see the module
/// docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Acquisition {
    /// The stages' decimation factors, from the fastest rate down: one
    /// number, or a list.
    #[serde(with = "one_or_many")]
    pub decimated_by: Vec<usize>,
    /// Each stage's FIR length (odd).
    #[serde(default = "default_taps")]
    pub taps: usize,
}

fn default_taps() -> usize {
    DEFAULT_TAPS
}

/// `decimated_by = 20` or `decimated_by = [2, 2, 5]`.
mod one_or_many {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Form {
        One(usize),
        Many(Vec<usize>),
    }

    pub fn serialize<S: Serializer>(v: &[usize], s: S) -> Result<S::Ok, S::Error> {
        match v {
            [one] => one.serialize(s),
            many => many.serialize(s),
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<usize>, D::Error> {
        Ok(match Form::deserialize(d)? {
            Form::One(r) => vec![r],
            Form::Many(v) => v,
        })
    }
}

impl Acquisition {
    /// Checks the declaration: at least one stage, each factor at least 2,
    /// the taps odd and at least 3.
    pub fn check(&self) -> Result<()> {
        if self.decimated_by.is_empty() || self.decimated_by.iter().any(|&r| r < 2) {
            return Err(Error::model(
                "acquisition.decimated_by",
                format!(
                    "expected one decimation factor of at least 2, or a list of them, got {:?}",
                    self.decimated_by
                ),
            ));
        }
        if self.taps < 3 || self.taps.is_multiple_of(2) {
            return Err(Error::model(
                "acquisition.taps",
                format!(
                    "expected an odd number of taps, at least 3, got {}",
                    self.taps
                ),
            ));
        }
        Ok(())
    }

    /// The chain's gain at `f_over_fs`, a frequency as a fraction of the
    /// recording's sample rate.
    pub fn gain(&self, f_over_fs: f64) -> f64 {
        // each stage's input rate, in recording rates
        let mut rate: f64 = self.decimated_by.iter().map(|&r| r as f64).product();
        let mut gain = 1.0;
        for &r in &self.decimated_by {
            let b = lowpass(self.taps, 1.0 / r as f64);
            let centre = (self.taps / 2) as f64;
            let w = 2.0 * std::f64::consts::PI * f_over_fs / rate;
            gain *= b
                .iter()
                .enumerate()
                .map(|(k, bk)| bk * (w * (k as f64 - centre)).cos())
                .sum::<f64>();
            rate /= r as f64;
        }
        gain
    }

    /// The zero-phase FIR at the recording's rate whose response is the
    /// chain's (see the module docs): `g₀, g₁, …, g_M` of `Σ g_|m| x[n+m]`.
    ///
    /// Errors: a chain whose response that FIR cannot follow within
    /// [`MAX_KERNEL_ERROR`].
    pub fn kernel(&self) -> Result<Vec<f64>> {
        self.check()?;
        let m = KERNEL_HALF_WIDTH;
        let points = 16 * (m + 1);
        let grid: Vec<f64> = (0..points)
            .map(|i| FITTED_BAND * 0.5 * i as f64 / (points - 1) as f64)
            .collect();
        let basis = |f: f64, j: usize| {
            if j == 0 {
                1.0
            } else {
                2.0 * (2.0 * std::f64::consts::PI * f * j as f64).cos()
            }
        };
        let a = nalgebra::DMatrix::from_fn(points, m + 1, |i, j| basis(grid[i], j));
        let target = nalgebra::DVector::from_iterator(points, grid.iter().map(|&f| self.gain(f)));
        let g = a
            .clone()
            .svd(true, true)
            .solve(&target, 1e-14)
            .map_err(|e| Error::model("acquisition", e.to_string()))?;
        let worst = (&a * &g - &target).amax();
        if worst > MAX_KERNEL_ERROR {
            return Err(Error::model(
                "acquisition",
                format!(
                    "its response cannot be followed at the recording's rate \
                     (within {worst:.1e} where {MAX_KERNEL_ERROR:.0e} is asked)"
                ),
            ));
        }
        Ok(g.iter().copied().collect())
    }
}

/// The Hamming-windowed sinc low-pass of `taps` taps cutting at `cutoff` of
/// the Nyquist frequency, scaled to unit gain at DC (MATLAB's `fir1`,
/// scipy's `firwin`).
pub fn lowpass(taps: usize, cutoff: f64) -> Vec<f64> {
    let centre = (taps / 2) as f64;
    // made for the first half and mirrored: exactly symmetric
    let mut b: Vec<f64> = (0..taps)
        .map(|k| k.min(taps - 1 - k))
        .map(|k| {
            let t = k as f64 - centre;
            let sinc = if t == 0.0 {
                cutoff
            } else {
                (std::f64::consts::PI * cutoff * t).sin() / (std::f64::consts::PI * t)
            };
            let hamming =
                0.54 - 0.46 * (2.0 * std::f64::consts::PI * k as f64 / (taps - 1) as f64).cos();
            sinc * hamming
        })
        .collect();
    let dc: f64 = b.iter().sum();
    b.iter_mut().for_each(|v| *v /= dc);
    b
}

/// The equivalent FIR applied to a response handed in stretches (see
/// [`Acquisition::kernel`]): each output made once the input `M` samples
/// after it has come, the record's two ends extended by odd reflection
/// about its end samples. A record no longer than the filter's reach
/// passes as it is.
pub struct AcquisitionFilter {
    g: Vec<f64>,
    /// The record's length.
    total: usize,
    /// Its first `M + 1` samples (the start's reflection).
    head: Vec<f64>,
    /// Inputs from `held_from` on, still in some output's reach.
    held: Vec<f64>,
    held_from: usize,
    /// Inputs received, outputs made.
    received: usize,
    made: usize,
}

impl AcquisitionFilter {
    /// The chain's filter for a response of `total` samples.
    pub fn new(acquisition: &Acquisition, total: usize) -> Result<AcquisitionFilter> {
        Ok(AcquisitionFilter {
            g: acquisition.kernel()?,
            total,
            head: Vec::new(),
            held: Vec::new(),
            held_from: 0,
            received: 0,
            made: 0,
        })
    }

    /// Input `i` of the record (`0 <= i < total`), held or at its head.
    fn x(&self, i: usize) -> f64 {
        if i < self.held_from {
            self.head[i]
        } else {
            self.held[i - self.held_from]
        }
    }

    /// The input at `i`, the record's ends reflected.
    fn at(&self, i: isize) -> f64 {
        let last = self.total as isize - 1;
        if i < 0 {
            2.0 * self.x(0) - self.x((-i) as usize)
        } else if i > last {
            2.0 * self.x(last as usize) - self.x((2 * last - i) as usize)
        } else {
            self.x(i as usize)
        }
    }

    /// Pushes the next inputs and appends every output they complete (all
    /// that are left once the last input has come).
    pub fn push(&mut self, x: &[f64], out: &mut Vec<f64>) {
        let m = self.g.len() - 1;
        if self.head.len() <= m {
            let more = (m + 1 - self.head.len()).min(x.len());
            self.head.extend_from_slice(&x[..more]);
        }
        self.held.extend_from_slice(x);
        self.received += x.len();
        if self.total <= 2 * m {
            // too short to filter: passed on as it comes
            out.extend_from_slice(x);
            self.made = self.received;
            self.held.clear();
            self.held_from = self.received;
            return;
        }
        let ready = if self.received >= self.total {
            self.total
        } else {
            self.received.saturating_sub(m)
        };
        while self.made < ready {
            let n = self.made as isize;
            let y = (1..=m).fold(self.g[0] * self.at(n), |acc, j| {
                acc + self.g[j] * (self.at(n - j as isize) + self.at(n + j as isize))
            });
            out.push(y);
            self.made += 1;
        }
        // what no later output reaches
        let keep_from = self.made.saturating_sub(m);
        if keep_from > self.held_from {
            let drop = (keep_from - self.held_from).min(self.held.len());
            self.held.drain(..drop);
            self.held_from += drop;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`lowpass`]`(31, 0.05)` is scipy's `firwin(31, 0.05)` (the taps
    /// scipy 1.x printed, an implementation of its own of MATLAB's
    /// `fir1(30, 1/20)`, to rounding); the chain's gain is the FIR's
    /// zero-phase response, stages multiplied at their own rates; the
    /// equivalent FIR at the recording's rate follows it within
    /// [`MAX_KERNEL_ERROR`] over the band it is fitted on.
    #[test]
    fn the_chains_gain_is_its_firs_and_the_kernel_follows_it() {
        let b = lowpass(31, 0.05);
        assert!((b.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        assert!((0..31).all(|k| b[k] == b[30 - k]));
        for (k, scipy) in [
            (0, 0.0017070784931335254),
            (7, 0.0264714571744417),
            (15, 0.07110328041787525),
        ] {
            assert!(
                (b[k] - scipy).abs() < 1e-16,
                "tap {k}: {} against {scipy}",
                b[k]
            );
        }
        assert!((lowpass(31, 0.2)[3] - 0.004227316085446902).abs() < 1e-16);
        let one = Acquisition {
            decimated_by: vec![20],
            taps: 31,
        };
        // the benchmark's sweep: 0.085 % off 18 Hz, 0.42 % off 41 Hz at 750 Hz
        let loss = |f: f64| 1.0 - one.gain(f / 750.0);
        assert!((loss(18.0) - 8.17e-4).abs() < 1e-6, "{}", loss(18.0));
        assert!((loss(41.0) - 4.232e-3).abs() < 1e-6, "{}", loss(41.0));
        // the direct sum at the fast rate
        let direct = |f: f64| {
            b.iter()
                .enumerate()
                .map(|(k, v)| {
                    v * (2.0 * std::f64::consts::PI * f / 15000.0 * (k as f64 - 15.0)).cos()
                })
                .sum::<f64>()
        };
        assert!((one.gain(41.0 / 750.0) - direct(41.0)).abs() < 1e-15);
        // three stages: each stage's response at its own input rate
        let staged = Acquisition {
            decimated_by: vec![2, 2, 5],
            taps: 31,
        };
        let stage = |r: usize, rate: f64, f: f64| {
            let b = lowpass(31, 1.0 / r as f64);
            b.iter()
                .enumerate()
                .map(|(k, v)| v * (2.0 * std::f64::consts::PI * f / rate * (k as f64 - 15.0)).cos())
                .sum::<f64>()
        };
        let f = 41.0;
        let want = stage(2, 15000.0, f) * stage(2, 7500.0, f) * stage(5, 3750.0, f);
        assert!((staged.gain(f / 750.0) - want).abs() < 1e-15);
        for a in [&one, &staged] {
            let g = a.kernel().unwrap();
            let response = |f: f64| {
                g[0] + 2.0
                    * (1..g.len())
                        .map(|j| g[j] * (2.0 * std::f64::consts::PI * f * j as f64).cos())
                        .sum::<f64>()
            };
            let worst = (0..=1000)
                .map(|i| 0.4 * i as f64 / 1000.0)
                .map(|f| (response(f) - a.gain(f)).abs())
                .fold(0.0, f64::max);
            assert!(worst < MAX_KERNEL_ERROR, "{:?}: {worst:e}", a.decimated_by);
        }
        // a factor of 1, no stage, an even number of taps
        for (decimated_by, taps) in [(vec![1], 31), (vec![], 31), (vec![4], 30)] {
            let chain = Acquisition { decimated_by, taps };
            assert!(chain.check().is_err(), "{chain:?}");
        }
    }

    /// The filter handed a response in stretches of any length is the
    /// equivalent FIR applied to the whole record with its ends reflected
    /// (written out here by index), to the bit; a record within the reach
    /// passes as it is.
    #[test]
    fn a_response_filtered_in_stretches_is_filtered_whole() {
        let a = Acquisition {
            decimated_by: vec![20],
            taps: 31,
        };
        let g = a.kernel().unwrap();
        let m = g.len() - 1;
        let x: Vec<f64> = (0..3_001)
            .map(|i| (i as f64 * 0.037).sin() + 0.3 * (i as f64 * 0.41).cos())
            .collect();
        let n = x.len() as isize;
        let ext = |i: isize| {
            if i < 0 {
                2.0 * x[0] - x[(-i) as usize]
            } else if i >= n {
                2.0 * x[(n - 1) as usize] - x[(2 * (n - 1) - i) as usize]
            } else {
                x[i as usize]
            }
        };
        let whole: Vec<f64> = (0..n)
            .map(|i| {
                (1..=m).fold(g[0] * ext(i), |acc, j| {
                    acc + g[j] * (ext(i - j as isize) + ext(i + j as isize))
                })
            })
            .collect();
        for chunk in [1, 5, 49, 1_000, 3_001] {
            let mut f = AcquisitionFilter::new(&a, x.len()).unwrap();
            let mut out = Vec::new();
            for c in x.chunks(chunk) {
                f.push(c, &mut out);
            }
            assert_eq!(out.len(), x.len(), "{chunk}");
            assert!(
                out.iter()
                    .zip(&whole)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "{chunk}"
            );
            assert!(
                f.held.len() <= 2 * m + chunk + 1,
                "{chunk}: {} held",
                f.held.len()
            );
        }
        let short = [1.0, 2.0, 3.0];
        let mut f = AcquisitionFilter::new(&a, 3).unwrap();
        let mut out = Vec::new();
        f.push(&short, &mut out);
        assert_eq!(out, short);
    }
}
