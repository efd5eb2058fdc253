//! Error figures of a simulated response against the measured one, and the
//! peak of an FRF.

use crate::error::{Error, Result};
use crate::extract::FrfPoint;
use crate::signals::SamplesView;
use serde::{Deserialize, Serialize};
/// Error figures over a stretch of samples.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorMetrics {
    /// Start of the stretch, s from the first sample.
    pub start_s: f64,
    /// End of the stretch (exclusive), s.
    pub end_s: f64,
    /// Samples compared.
    pub samples: usize,
    /// `√(mean((y_sim − y_meas)²))`, response unit.
    pub e_rms: f64,
    /// RMS of the measured response over the stretch (about its mean).
    pub measured_rms: f64,
    /// `e_rms / measured_rms`.
    pub relative: f64,
    /// The error and both responses split below, inside, just above and
    /// far above the band (`--band`): where in frequency the residual lies.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub by_frequency: Option<ErrorByFrequency>,
}

/// A stretch's error, measured and simulated responses split by frequency
/// about a band `[lo, hi]`: below it, inside it, just above it (`(hi,
/// 2 hi]`: the skirts of the band's modes and the second harmonic) and
/// beyond (the higher harmonics), each as a share of the measured
/// response's RMS over the stretch (about its mean; the parts' squares add
/// up to the square of the whole, by Parseval's theorem). The residual of a
/// model whose modes lie in the band shows here what it cannot make: the
/// higher harmonics that modes far above the band amplify, say, or a drift
/// below it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorByFrequency {
    /// The band, Hz.
    pub band_hz: (f64, f64),
    /// Below the band (with the mean).
    pub below: BandShares,
    /// Inside the band (its edges included).
    pub inside: BandShares,
    /// Above the band, up to twice its top.
    pub above: BandShares,
    /// Above twice the band's top.
    pub beyond: BandShares,
}

/// The RMS of the error and of both responses in one part of the spectrum,
/// as shares of the measured response's RMS over the stretch.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BandShares {
    /// Of `y_sim − y_meas`.
    pub error: f64,
    /// Of the measured response (about its mean).
    pub measured: f64,
    /// Of the simulated response (about the measured mean).
    pub simulated: f64,
}

/// The error figures of `simulated` against `measured` over samples
/// `range` (clipped to the shorter signal).
pub fn error_metrics(
    measured: &[f64],
    simulated: &[f64],
    sample_rate_hz: f64,
    range: std::ops::Range<usize>,
) -> Result<ErrorMetrics> {
    let n = measured.len().min(simulated.len());
    let (a, b) = error_window(range, n)?;
    let e2 = measured[a..b]
        .iter()
        .zip(&simulated[a..b])
        .map(|(x, y)| (y - x).powi(2))
        .sum::<f64>();
    Ok(error_metrics_of_sum(measured, e2, sample_rate_hz, a..b))
}

/// `range` clipped to the `n` samples compared; an error where nothing of
/// them is left.
pub(crate) fn error_window(range: std::ops::Range<usize>, n: usize) -> Result<(usize, usize)> {
    let (a, b) = (range.start.min(n), range.end.min(n));
    if a >= b {
        return Err(Error::input(
            "error window",
            format!(
                "samples {}..{} hold nothing of the {n} compared",
                range.start, range.end
            ),
        ));
    }
    Ok((a, b))
}

/// The value `Iterator::sum` starts an `f64` sum from: a sum folded in
/// order from it, a stretch at a time, is the same to the bit as the whole
/// summed at once.
pub(crate) fn sum_start() -> f64 {
    std::iter::empty::<f64>().sum::<f64>()
}

/// [`error_metrics`] over `a..b` (clipped by [`error_window`]) given the
/// sum of the squared errors there, `Σ (y_sim − y_meas)²` in the samples'
/// order (a replay handed on a stretch at a time sums it as it comes).
pub(crate) fn error_metrics_of_sum<'a>(
    measured: impl Into<SamplesView<'a>>,
    squared_errors: f64,
    sample_rate_hz: f64,
    std::ops::Range { start: a, end: b }: std::ops::Range<usize>,
) -> ErrorMetrics {
    let m = measured.into();
    let len = (b - a) as f64;
    let e2 = squared_errors / len;
    // folded in order a stretch at a time: the same bits as summing the
    // window at once
    let mut sum = sum_start();
    m.for_each_stretch(a..b, |_, w| sum = w.iter().fold(sum, |acc, x| acc + x));
    let mean = sum / len;
    let mut squares = sum_start();
    m.for_each_stretch(a..b, |_, w| {
        squares = w.iter().fold(squares, |acc, x| acc + (x - mean).powi(2))
    });
    let v = squares / len;
    let (e_rms, measured_rms) = (e2.sqrt(), v.sqrt());
    ErrorMetrics {
        start_s: a as f64 / sample_rate_hz,
        end_s: b as f64 / sample_rate_hz,
        samples: b - a,
        e_rms,
        measured_rms,
        relative: if measured_rms > 0.0 {
            e_rms / measured_rms
        } else {
            f64::INFINITY
        },
        by_frequency: None,
    }
}

/// The largest `|H1|` of a series, refined by a parabola through it and its
/// neighbours.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Peak {
    /// Frequency, Hz.
    pub frequency_hz: f64,
    /// `|H1|`, response unit per reference unit.
    pub magnitude: f64,
}

/// The `|H1|` peak of `points` (within `band_hz`), `None` when there are no
/// points. A peak with a neighbour on each side is refined by the parabola
/// through the three (magnitude against frequency).
pub fn h1_peak(points: &[FrfPoint], band_hz: Option<(f64, f64)>) -> Option<Peak> {
    let mut pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| in_band(p.frequency_hz, band_hz))
        .filter_map(|p| Some((p.frequency_hz, p.h.get(1)?.norm())))
        .filter(|(f, a)| f.is_finite() && a.is_finite())
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (i, &(f, a)) = pts
        .iter()
        .enumerate()
        .max_by(|x, y| x.1.1.total_cmp(&y.1.1))?;
    if i == 0 || i + 1 == pts.len() {
        return Some(Peak {
            frequency_hz: f,
            magnitude: a,
        });
    }
    let ((x0, y0), (x1, y1), (x2, y2)) = (pts[i - 1], pts[i], pts[i + 1]);
    // y = y1 + b (x − x1) + c (x − x1)², through the three points
    let (d0, d2) = (x0 - x1, x2 - x1);
    let (s0, s2) = ((y0 - y1) / d0, (y2 - y1) / d2);
    let c = (s2 - s0) / (d2 - d0);
    let b = s0 - c * d0;
    if c.is_nan() || c >= 0.0 {
        return Some(Peak {
            frequency_hz: f,
            magnitude: a,
        });
    }
    let dx = (-b / (2.0 * c)).clamp(d0, d2);
    Some(Peak {
        frequency_hz: x1 + dx,
        magnitude: y1 + b * dx + c * dx * dx,
    })
}

pub(super) fn in_band(f: f64, band_hz: Option<(f64, f64)>) -> bool {
    band_hz.is_none_or(|(lo, hi)| f >= lo && f <= hi)
}
