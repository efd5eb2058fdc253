//! The dwells of a long stepped-sine record found a block at a time.
//!
//! [`super::find_dwells_whole`] follows the reference's phase over the whole
//! record: its local RMS, the analytic signal of the reference divided by
//! it (an FFT of the record), the phase and envelope at every sample. That
//! is about 60 bytes a frame on top of the record: 3.4 GB of peak memory
//! for `identify` on a 30 M-frame recording whose steps are not stated
//! (what a shaker controller's export usually is). A record longer than
//! [`super::WHOLE_RECORD_FRAMES`] is instead read a stretch at a time
//! ([`find_dwells_in_blocks`]), so that memory is set by the blocks, not by
//! the record's length:
//!
//! - **The mean and the longest half period** (the local RMS's width, from
//!   the gaps between zero crossings) in two reads of the reference, the
//!   gaps counted by length (the same 90th percentile as sorting them).
//! - **The phase and envelope** per block of [`Blocks::analytic_block`]
//!   frames, each normalised by its local RMS and transformed with
//!   [`Blocks::analytic_margin`] frames on either side behind half Hann
//!   tapers, as the long sweep's phase is (`super::sweep_blocks`): the
//!   Hilbert transform is not local, and behind a smooth taper the cut's
//!   error falls as the taper's spectrum does. The phase is carried from
//!   block to block by whole turns and cut into tracking windows as it comes
//!   (`WindowTracker`, the same code as the whole record's).
//! - **The dwells** are then the whole record's algorithm on those windows,
//!   each dwell read from the source when it is examined.
//!
//! The windows can differ from the whole record's in the last digits (the
//! local RMS from sums over the block, the transform's cut), so the dwells
//! found agree with the whole record's to within a sample at their ends and
//! the frequencies to rounding (tested); records up to
//! [`super::WHOLE_RECORD_FRAMES`] are read whole.

use super::blocks::{BLOCKS, Blocks, PairSource};
use super::stepped::{DwellOptions, WindowTracker, dwells_of_windows};
use super::sweep_blocks::BlockPhase;
use crate::error::{Error, Result};
use crate::observe::{Observer, progress};
use crate::signals::{FrameSource, Step};
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// The progress task of a dwell search read a stretch at a time.
pub const FINDING: &str = "finding dwells";

/// [`super::find_dwells_whole`] of the reference (`src`'s force) read a
/// stretch at a time (see the module docs), telling `observer` how far its
/// four reads have come (`finding dwells`: the mean, the crossings, the
/// phase, the dwells examined) and stopping where it asks.
pub(super) fn find_dwells_in_blocks(
    src: &mut dyn PairSource,
    sample_rate_hz: f64,
    options: &DwellOptions,
    blocks: &Blocks,
    observer: &dyn Observer,
) -> Result<Vec<Step>> {
    super::stepped::check_rate(sample_rate_hz)?;
    let n = src.frames();
    if n < 64 {
        return Err(Error::input(
            "reference",
            format!("{n} samples: too short to find dwells"),
        ));
    }
    let total = 4 * n as u64;
    let report = |read: usize, a: usize| progress(observer, FINDING, (read * n + a) as u64, total);
    let mean = finite_mean(src, blocks.read, &report)?;
    let half_period = half_period_of_crossings(src, mean, blocks.read, &report)?;
    let half = (2 * half_period).min(n / 2).max(1);

    let mut tracker = WindowTracker::new(sample_rate_hz, options.window_periods.max(1));
    let mut block = BlockPhase::default();
    let (mut cycles, mut envelope) = (Vec::new(), Vec::new());
    let (mut cum, mut rms, mut unit) = (Vec::new(), Vec::new(), Vec::new());
    let mut a = 0;
    while a < n {
        let b = (a + blocks.analytic_block).min(n);
        let (lo, hi) = (
            a.saturating_sub(blocks.analytic_margin),
            (b + blocks.analytic_margin).min(n),
        );
        // the local RMS at lo..hi reaches `half` further either way
        let (r0, r1) = (lo.saturating_sub(half), (hi + half + 1).min(n));
        let (force, _) = src.pair(r0, r1)?;
        cum.clear();
        cum.push(0.0);
        let mut acc = 0.0;
        for &v in force {
            acc += (v - mean) * (v - mean);
            cum.push(acc);
        }
        rms.clear();
        unit.clear();
        for i in lo..hi {
            let (wl, wh) = (i.saturating_sub(half), (i + half + 1).min(n));
            let r = ((cum[wh - r0] - cum[wl - r0]).max(0.0) / (wh - wl) as f64).sqrt();
            rms.push(r);
            unit.push(if r > 0.0 {
                (force[i - r0] - mean) / r
            } else {
                0.0
            });
        }
        cycles.clear();
        envelope.clear();
        block.follow(&unit, (lo, a, b, hi), n, |f, phase, z| {
            cycles.push(phase / (2.0 * PI));
            envelope.push(z.norm() * rms[f - lo]);
        });
        tracker.push(&cycles, &envelope);
        a = b;
        report(2, a)?;
    }
    // the dwells examined, each read as it is (the last read's progress:
    // the furthest frame read)
    let mut furthest = 0;
    let found = dwells_of_windows(&tracker.windows, n, sample_rate_hz, options, &mut |r| {
        furthest = furthest.max(r.end);
        report(3, furthest)?;
        let (force, _) = src.pair(r.start, r.end)?;
        Ok(Cow::Owned(force.to_vec()))
    })?;
    report(4, 0)?;
    Ok(found)
}

/// The reference's mean, summed in the record's order, every sample
/// checked finite (pass 0 of the progress).
fn finite_mean(
    src: &mut dyn PairSource,
    read: usize,
    report: &dyn Fn(usize, usize) -> Result<()>,
) -> Result<f64> {
    let n = src.frames();
    let mut sum = -0.0;
    let mut a = 0;
    while a < n {
        let b = (a + read).min(n);
        let (force, _) = src.pair(a, b)?;
        if let Some(i) = force.iter().position(|v| !v.is_finite()) {
            return Err(Error::input(
                format!("reference[{}]", a + i),
                format!("samples must be finite, got {}", force[i]),
            ));
        }
        sum = force.iter().fold(sum, |acc, v| acc + v);
        a = b;
        report(0, a)?;
    }
    Ok(sum / n as f64)
}

/// Half the drive's period, as the gap between crossings of the `mean` that
/// 90 % of the gaps are shorter than (pass 1 of the progress); a quarter of
/// the record where there are none.
fn half_period_of_crossings(
    src: &mut dyn PairSource,
    mean: f64,
    read: usize,
    report: &dyn Fn(usize, usize) -> Result<()>,
) -> Result<usize> {
    let n = src.frames();
    // the gaps between crossings of the mean, counted by length
    let mut gaps: BTreeMap<usize, usize> = BTreeMap::new();
    let (mut count, mut last, mut below) = (0, None, None);
    let mut a = 0;
    while a < n {
        let b = (a + read).min(n);
        let (force, _) = src.pair(a, b)?;
        for (i, v) in (a..b).zip(force) {
            let now = v - mean < 0.0;
            if below.is_some_and(|was| was != now) {
                if let Some(l) = last {
                    *gaps.entry(i - l).or_insert(0) += 1;
                    count += 1;
                }
                last = Some(i);
            }
            below = Some(now);
        }
        a = b;
        report(1, a)?;
    }
    let mut rank = count * 9 / 10;
    let mut half_period = None;
    for (&gap, &k) in &gaps {
        if rank < k {
            half_period = Some(gap);
            break;
        }
        rank -= k;
    }
    Ok(half_period.unwrap_or(n / 4).max(2))
}

/// The stepped-sine dwells of channel `reference` of `source`: read whole
/// where the record is at most [`super::WHOLE_RECORD_FRAMES`] long
/// ([`super::find_dwells_whole`], the same dwells as ever), a stretch at a
/// time with the library's block sizes where it is longer (a channel held
/// in a scratch file is then never copied whole), telling `observer` how
/// far it has come ([`FINDING`]). A held channel is handed over as
/// [`crate::signals::InMemoryFrames::single`].
///
/// Errors: the channel out of range, a read that fails, and those of
/// [`super::find_dwells_whole`].
pub fn find_dwells<S: FrameSource>(
    source: &mut S,
    reference: usize,
    options: &DwellOptions,
    observer: &dyn Observer,
) -> Result<Vec<Step>> {
    let fs = source.meta().sample_rate_hz;
    let frames = source.frames();
    let mut only = super::blocks::frame_reference(source, reference, &BLOCKS)?;
    if frames <= BLOCKS.whole {
        let (force, _) = only.pair(0, frames)?;
        return super::find_dwells_whole(force, fs, options);
    }
    find_dwells_in_blocks(&mut only, fs, options, &BLOCKS, observer)
}

#[cfg(test)]
mod tests {
    use super::super::blocks::{InMemory, SMALL};
    use super::super::stepped::{normalise, track};
    use super::*;
    use crate::observe::Silent;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    const FS: f64 = 2000.0;

    /// A stepped sine of three levels 70 dB apart (0.02, 1 and 60 N) at
    /// seven frequencies 20-80 Hz, 4 000 frames a dwell, the phase
    /// continuous across switches, each later level's amplitude ramped in
    /// over a tenth of its first dwell, 1 % noise of each dwell's
    /// amplitude.
    fn reference() -> (Vec<f64>, Vec<(f64, f64)>) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let (mut x, mut dwells) = (Vec::new(), Vec::new());
        let mut phase: f64 = 0.3;
        for level in [0.02, 1.0, 60.0] {
            for (k, f) in [20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0]
                .into_iter()
                .enumerate()
            {
                dwells.push((f, level));
                for i in 0..4000 {
                    let ramp = if k == 0 && !x.is_empty() {
                        (i as f64 / 400.0).min(1.0)
                    } else {
                        1.0
                    };
                    let noise: f64 = StandardNormal.sample(&mut rng);
                    x.push(level * (ramp * phase.sin() + 0.01 * noise));
                    phase += 2.0 * PI * f / FS;
                }
            }
        }
        (x, dwells)
    }

    /// The tracker cuts the same windows, to the bit, however the phase
    /// comes: whole, or in stretches of 1 to 3 000 samples.
    #[test]
    fn the_windows_are_the_same_however_the_phase_comes() {
        let (x, _) = reference();
        let whole = track(&x, FS, 4);
        assert!(whole.len() > 500, "{}", whole.len());
        let (unit, rms) = normalise(&x);
        let a = super::super::analytic::analytic(&unit);
        let cycles: Vec<f64> = a.phase.iter().map(|p| p / (2.0 * PI)).collect();
        let envelope: Vec<f64> = a.amplitude.iter().zip(&rms).map(|(e, r)| e * r).collect();
        let mut tracker = WindowTracker::new(FS, 4);
        let mut at = 0;
        for size in [1, 2, 3, 3000, 17, 1, 999].into_iter().cycle() {
            let to = (at + size).min(x.len());
            tracker.push(&cycles[at..to], &envelope[at..to]);
            at = to;
            if at == x.len() {
                break;
            }
        }
        assert_eq!(tracker.windows, whole);
    }

    /// Read a stretch at a time, in blocks of 16 384 frames, the record's
    /// 21 dwells are found as well as read whole, and held to the same
    /// truth: each inside its true dwell, losing at most four windows at
    /// either end, its analysed part after the ramp where there is one, its
    /// frequency within 1e-5 and its level within 1e-3. (The two differ by
    /// about a period in where their windows fall: the windows are cut at
    /// whole periods from the phase at the first sample, which the Hilbert
    /// transform cannot know to better than some tens of degrees there, and
    /// the two transforms' ends differ.)
    #[test]
    fn the_dwells_found_in_blocks_are_the_whole_records() {
        let (x, truth) = reference();
        let options = DwellOptions::default();
        let whole = super::super::find_dwells_whole(&x, FS, &options).unwrap();
        let response = vec![0.0; x.len()];
        let mut src = InMemory {
            force: &x,
            response: &response,
        };
        // the search's progress: its four reads in steps to the end, never
        // back, the same dwells found whether it is watched or not
        let told = std::sync::Mutex::new(Vec::new());
        let watch = |e: crate::observe::Event<'_>| {
            if let crate::observe::Event::Progress { task, done, total } = e {
                told.lock().unwrap().push((task, done, total));
            }
        };
        let blocks = find_dwells_in_blocks(&mut src, FS, &options, &SMALL, &watch).unwrap();
        let told = told.into_inner().unwrap();
        let n = 4 * x.len() as u64;
        assert!(told.len() > 3 * x.len() / SMALL.analytic_block + blocks.len());
        assert!(told.iter().all(|&(t, _, total)| t == FINDING && total == n));
        assert!(told.windows(2).all(|w| w[0].1 <= w[1].1) && told.last().unwrap().1 == n);
        let mut src = InMemory {
            force: &x,
            response: &response,
        };
        assert!(find_dwells_in_blocks(&mut src, FS, &options, &SMALL, &Silent).unwrap() == blocks);
        // a search asked to stop stops
        struct Stop;
        impl Observer for Stop {
            fn observe(&self, _: crate::observe::Event<'_>) {}
            fn cancelled(&self) -> bool {
                true
            }
        }
        let mut src = InMemory {
            force: &x,
            response: &response,
        };
        let e = find_dwells_in_blocks(&mut src, FS, &options, &SMALL, &Stop).unwrap_err();
        assert!(matches!(e, Error::Cancelled), "{e}");
        for found in [&whole, &blocks] {
            assert_eq!(found.len(), truth.len());
            for (k, (s, &(f, level))) in found.iter().zip(&truth).enumerate() {
                let (start, end) = (4000 * k, 4000 * (k + 1));
                let window = 4.0 * FS / f;
                assert!(s.start >= start && s.start + s.length <= end, "{s:?}");
                let lost = (end - start - s.length) as f64;
                assert!(lost <= 2.0 * 4.0 * window + 2.0, "{s:?} lost {lost}");
                if k % 7 == 0 && k > 0 {
                    assert!(s.start + s.settle >= start + 400, "{s:?} in the ramp");
                }
                assert!((s.frequency_hz / f - 1.0).abs() < 1e-5, "{s:?} at {f}");
                assert!((s.level / level - 1.0).abs() < 1e-3, "{s:?} at {level}");
            }
        }
        let mut bad = x.clone();
        bad[70_001] = f64::NAN;
        let mut src = InMemory {
            force: &bad,
            response: &response,
        };
        let e = find_dwells_in_blocks(&mut src, FS, &options, &SMALL, &Silent)
            .unwrap_err()
            .to_string();
        assert!(e.contains("reference[70001]"), "{e}");
    }
}
