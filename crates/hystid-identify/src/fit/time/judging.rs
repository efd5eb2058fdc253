//! Which samples of each recording a time-domain fit judges, and at what rate.

use super::records::TimeRecord;
use crate::error::Result;
use crate::validate::resample::{Decimator, MAX_FACTOR};
use std::ops::Range;

/// Most samples a time-domain fit judges by default, over all its
/// recordings (see [`TimeFitOptions::max_judged_samples`]).
pub const MAX_JUDGED_SAMPLES: usize = 1 << 20;

/// Fewest judged samples per period of the model's highest linearised
/// frequency that judging at a lower rate leaves (see
/// [`TimeFitOptions::max_judged_samples`]).
pub const MIN_JUDGED_PER_PERIOD: f64 = 8.0;

/// Half-width of the low-pass filter before a lower judging rate, in
/// samples of that rate (see [`crate::validate::resample::decimate_with`]):
/// what is judged lies below a quarter of its Nyquist frequency (at least
/// [`MIN_JUDGED_PER_PERIOD`] samples a period), well inside the pass band
/// of even a short filter.
pub(super) const JUDGING_HALF_WIDTH: usize = 8;

/// Each record's judging factor `k` (see
/// [`TimeFitOptions::max_judged_samples`]), for a model whose highest
/// linearised frequency is `top_hz`: the smallest that brings the judged
/// samples within `most`, but never one that leaves fewer than
/// [`MIN_JUDGED_PER_PERIOD`] judged samples a period of `top_hz`, nor more
/// than [`MAX_FACTOR`].
pub fn judging_factors(records: &[TimeRecord], top_hz: f64, most: usize) -> Vec<usize> {
    let total: usize = records
        .iter()
        .map(|r| r.segments.iter().map(|s| s.len()).sum::<usize>())
        .sum();
    let wanted = total.div_ceil(most.max(1)).max(1);
    records
        .iter()
        .map(|r| {
            let coarsest = if top_hz.is_finite() && top_hz > 0.0 {
                (r.sample_rate_hz / (MIN_JUDGED_PER_PERIOD * top_hz)).floor()
            } else {
                1.0
            };
            wanted.min(coarsest.max(1.0) as usize).min(MAX_FACTOR)
        })
        .collect()
}

/// Judged samples a judged stretch holds at most where a recording is judged
/// only in part (see [`judged_stretches`]): 256 periods of the model's
/// highest linearised frequency at the fewest judged samples a period.
pub(super) const JUDGED_STRETCH: usize = 2048;

/// Which samples of each segment (in samples of the judging rate) are
/// judged, where judging every one of them would judge more than `most`
/// over all recordings (`total`): that share of each segment, as stretches
/// of at most [`JUDGED_STRETCH`] samples, each at the end of its equal share
/// of the segment (a single stretch is a dwell's last, most settled
/// samples; several spread over it, its transient included). Every sample
/// of every segment where `total <= most`. The steady periods of a
/// periodic record (`periodic`) are alike: its share is judged as its first
/// periods whole (the last of them in part), so that its replays stop
/// there. Returns the stretches in order with the segment each lies in.
pub(super) fn judged_stretches(
    segments: &[Range<usize>],
    total: usize,
    most: usize,
    periodic: bool,
) -> Vec<(Range<usize>, usize)> {
    if total <= most {
        return segments
            .iter()
            .enumerate()
            .map(|(k, s)| (s.clone(), k))
            .collect();
    }
    // `len·most/total` in 128 bits: never more than `most` over all
    let share = |len: usize| (len as u128 * most as u128 / total as u128) as usize;
    if periodic {
        let mut left: usize = segments.iter().map(|s| share(s.len())).sum();
        let mut out = Vec::new();
        for (k, s) in segments.iter().enumerate() {
            if left == 0 {
                break;
            }
            let n = s.len().min(left);
            out.push((s.start..s.start + n, k));
            left -= n;
        }
        return out;
    }
    let mut out = Vec::new();
    for (k, s) in segments.iter().enumerate() {
        let len = s.len();
        let kept = share(len);
        let blocks = kept.div_ceil(JUDGED_STRETCH);
        for j in 0..blocks {
            let end = s.start + len * (j + 1) / blocks;
            let n = kept * (j + 1) / blocks - kept * j / blocks;
            out.push((end - n..end, k));
        }
    }
    out
}

/// How a record is judged: at its own rate, or low-passed and kept at every
/// `factor`-th sample; every sample of its segments at that rate, or
/// stretches of them (see [`judged_stretches`]).
pub(super) struct Judging {
    pub(super) factor: usize,
    /// The measured response at each judged sample, in order (`None`: every
    /// sample of the segments at the record's own rate, read from it).
    pub(super) measured: Option<Vec<f64>>,
    /// The judged stretches in samples of the judging rate, in order, each
    /// with the segment it lies in.
    pub(super) stretches: Vec<(Range<usize>, usize)>,
    /// `RMS_s · √N_s` of each segment over its judged samples: the
    /// residual's divisor.
    pub(super) scale: Vec<f64>,
}

impl Judging {
    /// `r`'s segments in samples of `1/factor` of its rate.
    pub(super) fn segments_at(r: &TimeRecord, factor: usize) -> Vec<Range<usize>> {
        // sample q of the judging rate is sample q·factor of the record's
        let outputs = r.response.len().div_ceil(factor);
        r.segments
            .iter()
            .map(|s| s.start.div_ceil(factor)..s.end.div_ceil(factor).min(outputs))
            .collect()
    }

    /// `r` judged at `1/factor` of its rate at `stretches` (`scale`: its
    /// segments' divisors at its own rate, every sample judged).
    pub(super) fn of(
        r: &TimeRecord,
        scale: &[f64],
        factor: usize,
        stretches: Vec<(Range<usize>, usize)>,
    ) -> Result<Judging> {
        let every = stretches.len() == r.segments.len()
            && stretches.iter().zip(&r.segments).all(|((a, _), b)| a == b);
        if factor <= 1 && every {
            return Ok(Judging {
                factor: 1,
                measured: None,
                stretches,
                scale: scale.to_vec(),
            });
        }
        // the response at the judging rate, made a stretch at a time and
        // kept where judged (the same bits as `decimate_with` whole)
        let mut decimator = Decimator::new(factor, JUDGING_HALF_WIDTH, r.response.len())?;
        let judged: usize = stretches.iter().map(|(s, _)| s.len()).sum();
        let mut measured = Vec::with_capacity(judged);
        let mut made = Vec::new();
        let (mut q, mut k) = (0, 0);
        let mut bad = None;
        r.response.for_each_stretch(0..r.response.len(), |at, x| {
            if bad.is_none() {
                bad = x.iter().position(|v| !v.is_finite()).map(|i| at + i);
            }
            made.clear();
            decimator.push(x, &mut made);
            for &v in &made {
                while k < stretches.len() && stretches[k].0.end <= q {
                    k += 1;
                }
                if k < stretches.len() && stretches[k].0.start <= q {
                    measured.push(v);
                }
                q += 1;
            }
        });
        if let Some(i) = bad {
            return Err(crate::validate::resample::not_finite(
                "signal",
                r.response.view(),
                i,
            ));
        }
        let mut sums = vec![0.0; r.segments.len()];
        let mut at = 0;
        for (s, k) in &stretches {
            let w = &measured[at..at + s.len()];
            sums[*k] = w.iter().fold(sums[*k], |acc, v| acc + v * v);
            at += s.len();
        }
        Ok(Judging {
            factor,
            measured: Some(measured),
            stretches,
            scale: sums.into_iter().map(f64::sqrt).collect(),
        })
    }

    /// Samples judged.
    pub(super) fn judged(&self) -> usize {
        self.stretches.iter().map(|(s, _)| s.len()).sum()
    }

    /// The measured response at each judged sample, in order, read from
    /// `r` where not held.
    pub(super) fn for_each_measured(&self, r: &TimeRecord, mut f: impl FnMut(usize, f64)) {
        match &self.measured {
            Some(m) => {
                let mut at = 0;
                for (s, k) in &self.stretches {
                    for &v in &m[at..at + s.len()] {
                        f(*k, v);
                    }
                    at += s.len();
                }
            }
            None => {
                for (s, k) in &self.stretches {
                    r.response.for_each_stretch(s.clone(), |_, w| {
                        for &v in w {
                            f(*k, v);
                        }
                    });
                }
            }
        }
    }
}
