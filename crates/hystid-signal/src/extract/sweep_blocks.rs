//! Long swept-sine records reduced a block at a time.
//!
//! The swept-sine reduction ([`super::reduce_sweep`]) transforms a record
//! whole twice: the reference's analytic signal, to follow its phase, and,
//! with the sweep-distortion compensation, each harmonic's convolution with
//! the compensation's kernel. Each takes buffers of 16 bytes per frame, on
//! top of the record itself: 1.4 GB for a 10-minute sweep at 20 kHz. A
//! record longer than [`super::WHOLE_RECORD_FRAMES`] is instead reduced a block at
//! a time, and read a stretch at a time ([`PairSource`], from the
//! [`FrameSource`] [`super::reduce_sweep`] is handed), so that memory is set
//! by the blocks and the compensation's kernel, not by the record's length:
//!
//! - **Following the phase.** The analytic signal is taken per block of
//!   [`Blocks::analytic_block`] frames, each transformed with
//!   [`Blocks::analytic_margin`] frames of the record on either side,
//!   tapered by half Hann windows. The Hilbert transform is not local: a
//!   block cut square would be wrong by about `1/(2π·periods to its edge)`
//!   near the cut; behind a smooth taper the error falls as the taper's
//!   spectrum does at twice the signal's frequency (with 40 periods of
//!   margin, the fitted phase law is the whole transform's to 8e-6 rad of
//!   3e6 swept: tested). The unwrapped phase is carried
//!   from block to block by the whole turns that join them, and kept with
//!   the envelope at every `D`-th frame (`D` so that at most
//!   [`Blocks::phase_points`] are kept): the phase law is fitted to those
//!   as to a record sampled at `fs/D`, then rescaled to frames, so the
//!   active sweep's ends are known to `D` frames. The law itself needs no
//!   more: 20 000 points fix it as well as all (see `fit_sweep`).
//! - **The plain windows** are the same computation either way, reading
//!   each window's samples as it comes.
//! - **The compensation.** Each harmonic's convolution is computed by
//!   overlap-save in FFT blocks of at least [`Blocks::convolution`] and
//!   two kernel lengths, evaluated at the window centres only; the
//!   kernel's sums over the record's support (its normalisation, and the
//!   noise's propagation) are prefix sums of the kernel, compensated
//!   (Neumaier), in place of a transform of the support. It equals the
//!   whole-record convolution to rounding (2e-14: tested).
//!
//! The compensation's own memory grows with its window `σ` (its kernel is
//! `8σ·fs` frames long, and two FFT buffers of twice that are held: 64 MB
//! at σ 3 s and 20 kHz), not with the record; the automatic choice
//! ([`super::choose_compensation`]) keeps `σ` at a few of the sweep's time
//! constants.

use super::analytic::next_smooth;
use super::blocks::{BLOCKS, Blocks, PairSource, frame_reference};
use super::sweep::{
    Demodulated, Harmonics, PhaseLaw, SweepFit, SweepOptions, WindowFit, chirp_kernel, fit_phase,
    gaussian_squared, kernel, reach, store, window_centres,
};
use crate::error::{Error, Result};
use crate::signals::FrameSource;
use num_complex::Complex64;
use rustfft::FftPlanner;
use std::f64::consts::PI;

/// The sweep in channel `reference` of `source` (its active stretch and
/// fitted frequency law), without reducing a response: what a time-domain
/// fit needs to judge a swept record inside a band. A record of up to
/// [`super::WHOLE_RECORD_FRAMES`] frames is read whole
/// ([`super::find_sweep_whole`]), a longer one a block at a time as the
/// long sweep's reduction reads it (module docs), never held whole. A held
/// channel is handed over as [`crate::signals::InMemoryFrames::single`].
pub fn find_sweep(
    source: &mut impl FrameSource,
    reference: usize,
    options: &super::SweepOptions,
) -> Result<super::SweepFit> {
    let fs = source.meta().sample_rate_hz;
    find_sweep_in(
        &mut frame_reference(source, reference, &BLOCKS)?,
        fs,
        options,
        &BLOCKS,
    )
}

fn find_sweep_in(
    src: &mut dyn PairSource,
    sample_rate_hz: f64,
    options: &super::SweepOptions,
    blocks: &Blocks,
) -> Result<super::SweepFit> {
    let n = src.frames();
    if n <= blocks.whole {
        let (reference, _) = src.pair(0, n)?;
        return super::find_sweep_whole(reference, sample_rate_hz, options);
    }
    super::sweep::check_sweep_rate(sample_rate_hz)?;
    fit_sweep_in_blocks(src, sample_rate_hz, options, blocks).map(|(_, s)| s)
}

/// A record's phase followed a block at a time (module docs): each block's
/// analytic signal behind half Hann tapers over its margins, the phase
/// unwrapped from the block's first frame and joined to the block before by
/// whole turns.
pub(super) struct BlockPhase {
    planner: FftPlanner<f64>,
    buf: Vec<Complex64>,
    /// The unwrapped phase at the first frame of the next block, as the
    /// block before it saw it (in its margin).
    carried: Option<f64>,
}

impl Default for BlockPhase {
    fn default() -> BlockPhase {
        BlockPhase {
            planner: FftPlanner::new(),
            buf: Vec::new(),
            carried: None,
        }
    }
}

impl BlockPhase {
    /// Follows block `a..b` of a record of `frames` frames, `x` holding its
    /// frames `lo..hi` (the block and its margins): `each(frame, phase, z)`
    /// for every frame of the block, `z` the analytic signal.
    pub(super) fn follow(
        &mut self,
        x: &[f64],
        (lo, a, b, hi): (usize, usize, usize, usize),
        frames: usize,
        mut each: impl FnMut(usize, f64, Complex64),
    ) {
        let n = hi - lo;
        let (rise, fall) = (a - lo, hi - b);
        let mean = x.iter().sum::<f64>() / n as f64;
        let nfft = next_smooth(n.max(2));
        let buf = &mut self.buf;
        buf.clear();
        buf.resize(nfft, Complex64::default());
        for (i, (z, &v)) in buf.iter_mut().zip(x).enumerate() {
            let w = if i < rise {
                0.5 - 0.5 * (PI * (i as f64 + 0.5) / rise as f64).cos()
            } else if i >= n - fall {
                0.5 - 0.5 * (PI * ((n - i) as f64 - 0.5) / fall as f64).cos()
            } else {
                1.0
            };
            *z = Complex64::new((v - mean) * w, 0.0);
        }
        super::analytic::to_analytic(&mut self.planner, buf);
        let inv = 1.0 / nfft as f64;
        // unwrap from frame `a`, joined to the block before by whole turns
        let first = buf[a - lo].arg();
        let mut offset = self
            .carried
            .map_or(0.0, |p| 2.0 * PI * ((p - first) / (2.0 * PI)).round());
        let mut last = first;
        let through = if b < frames { b } else { b - 1 };
        for f in a..=through {
            let z = buf[f - lo] * inv;
            let arg = z.arg();
            let step = arg - last;
            if step > PI {
                offset -= 2.0 * PI;
            } else if step < -PI {
                offset += 2.0 * PI;
            }
            last = arg;
            if f == b {
                self.carried = Some(arg + offset);
            } else {
                each(f, arg + offset, z);
            }
        }
    }
}

/// The sweep in a long record: the analytic signal a block at a time, the
/// phase law fitted to every `D`-th frame (module docs). Checks that both
/// channels are finite on the way.
pub(super) fn fit_sweep_in_blocks(
    src: &mut dyn PairSource,
    sample_rate_hz: f64,
    options: &SweepOptions,
    blocks: &Blocks,
) -> Result<(PhaseLaw, SweepFit)> {
    let frames = src.frames();
    let d = frames.div_ceil(blocks.phase_points).max(1);
    let mut phase_kept = Vec::with_capacity(frames.div_ceil(d));
    let mut amplitude = Vec::with_capacity(frames.div_ceil(d));
    let mut block = BlockPhase::default();
    let mut a = 0;
    while a < frames {
        let b = (a + blocks.analytic_block).min(frames);
        let (lo, hi) = (
            a.saturating_sub(blocks.analytic_margin),
            (b + blocks.analytic_margin).min(frames),
        );
        let (force, response) = src.pair(lo, hi)?;
        for (name, signal) in [("force", force), ("response", response)] {
            if let Some(i) = signal[a - lo..b - lo].iter().position(|v| !v.is_finite()) {
                return Err(Error::input(
                    format!("{name}[{}]", a + i),
                    format!("samples must be finite, got {}", signal[a - lo + i]),
                ));
            }
        }
        block.follow(force, (lo, a, b, hi), frames, |f, phase, z| {
            if f % d == 0 {
                phase_kept.push(phase);
                amplitude.push(z.norm());
            }
        });
        a = b;
    }
    let (law, sweep) = fit_phase(
        &super::analytic::Analytic {
            phase: phase_kept,
            amplitude,
        },
        sample_rate_hz / d as f64,
        options,
    )?;
    let df = d as f64;
    let law = match law {
        PhaseLaw::Quadratic { mid, half, p } => PhaseLaw::Quadratic {
            mid: mid * df,
            half: half * df,
            p,
        },
        PhaseLaw::Exponential { mid, c, lambda } => PhaseLaw::Exponential {
            mid: mid * df,
            c,
            lambda: lambda / df,
        },
    };
    Ok((
        law,
        SweepFit {
            start: sweep.start * d,
            end: ((sweep.end - 1) * d + 1).min(frames),
            ..sweep
        },
    ))
}

/// Neumaier's compensated running sum: prefix sums of many terms to
/// rounding.
#[derive(Clone, Copy, Default)]
struct Neumaier {
    sum: f64,
    carry: f64,
}

impl Neumaier {
    fn add(&mut self, v: f64) {
        let t = self.sum + v;
        self.carry += if self.sum.abs() >= v.abs() {
            (self.sum - t) + v
        } else {
            (v - t) + self.sum
        };
        self.sum = t;
    }
    fn value(&self) -> f64 {
        self.sum + self.carry
    }
}

/// Prefix sums `S[j] = Σ_{m=−r}^{j−r−1} f(|m|)` of a symmetric kernel, and
/// its sum over the record's support seen from a centre.
struct KernelSums {
    reach: usize,
    prefix: Vec<Complex64>,
}

impl KernelSums {
    fn new(reach: usize, f: &dyn Fn(f64) -> Complex64) -> KernelSums {
        let (mut re, mut im) = (Neumaier::default(), Neumaier::default());
        let mut prefix = Vec::with_capacity(2 * reach + 2);
        prefix.push(Complex64::default());
        for m in -(reach as i64)..=reach as i64 {
            let v = f(m.unsigned_abs() as f64);
            re.add(v.re);
            im.add(v.im);
            prefix.push(Complex64::new(re.value(), im.value()));
        }
        KernelSums { reach, prefix }
    }

    /// `Σ f(m)` over `|m| ≤ reach` with `0 ≤ c − m < len`.
    fn over_support(&self, c: usize, len: usize) -> Complex64 {
        let r = self.reach as i64;
        let (c, len) = (c as i64, len as i64);
        let lo = (c - len + 1).max(-r);
        let hi = c.min(r);
        self.prefix[(hi + r + 1) as usize] - self.prefix[(lo + r) as usize]
    }
}

/// The compensated harmonics at each window centre of a long record
/// (module docs): the whole-record computation's sums, by overlap-save.
pub(super) fn compensated_in_blocks(
    src: &mut dyn PairSource,
    law: &PhaseLaw,
    sweep: &SweepFit,
    windows: &[WindowFit],
    sigma_samples: f64,
    k: usize,
    blocks: &Blocks,
) -> Result<Vec<Harmonics>> {
    let alpha = law.chirp_rate();
    let (start, end) = (sweep.start, sweep.end);
    let len = end - start;
    let width = k + 1;
    let r = reach(sigma_samples, sweep);
    let nfft = next_smooth(blocks.convolution.max(2 * (2 * r + 1)));
    // outputs per block: the input block holds `r` frames either side
    let step = nfft - 2 * r;
    let mut planner = FftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(nfft);
    let inv = planner.plan_fft_inverse(nfft);
    let scale = 1.0 / nfft as f64;
    let s2 = sigma_samples * sigma_samples;
    let centers: Vec<usize> = window_centres(windows, sweep).collect();
    let energy: Vec<f64> = {
        let sums = KernelSums::new(r, &|m| gaussian_squared(m, s2));
        centers
            .iter()
            .map(|&c| sums.over_support(c, len).re)
            .collect()
    };
    let mut out: Vec<Harmonics> = windows.iter().map(|_| Harmonics::new(width)).collect();
    let mut seg = vec![Complex64::default(); nfft];
    for h in 0..width {
        let hf = h as f64;
        let f = |m: f64| chirp_kernel(m, s2, hf * alpha);
        let mut ker = kernel(nfft, r, f);
        fwd.process(&mut ker);
        let norm: Vec<Complex64> = {
            let sums = KernelSums::new(r, &f);
            centers.iter().map(|&c| sums.over_support(c, len)).collect()
        };
        for ch in 0..2 {
            let demodulated = Demodulated {
                law,
                start,
                windows,
                width,
                ch,
                h,
            };
            let mut next = 0; // the next centre to compute
            while next < centers.len() {
                // outputs `o..ob` from inputs `o − r..ob + r` (within the sweep)
                let o = centers[next];
                let ob = (o + step).min(len);
                let (ia, ib) = (o.saturating_sub(r), (ob + r).min(len));
                seg.iter_mut().for_each(|v| *v = Complex64::default());
                let (force, response) = src.pair(start + ia, start + ib)?;
                let signal = if ch == 0 { force } else { response };
                let first = start as f64 + ia as f64;
                let mut j = windows.partition_point(|w| w.center <= first);
                let shift = r + ia - o; // seg index of input `ia`
                for (i, &v) in (ia..ib).zip(signal) {
                    seg[shift + i - ia] = demodulated.at(i, v, &mut j);
                }
                fwd.process(&mut seg);
                for (x, y) in seg.iter_mut().zip(&ker) {
                    *x *= y * scale;
                }
                inv.process(&mut seg);
                while next < centers.len() && centers[next] < ob {
                    let w = next;
                    let conv = seg[centers[w] - o + r];
                    store(&mut out[w], &windows[w], (ch, h), conv, norm[w], energy[w]);
                    next += 1;
                }
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::blocks::{InMemory, SMALL, frame_pair};
    use super::super::sweep::{compensated, fit_sweep, plain_windows};
    use super::super::sweep_reduce::reduce_sweep_from;
    use super::super::{choose_compensation, reduce_sweep};
    use super::*;
    use crate::extract::SweepLaw;
    use crate::model::{ModalModel, Mode, NoElement};
    use crate::record::{Channel, Excitation, ExcitationKind, Recording, RecordingMeta};
    use crate::signals::InMemoryFrames;
    use crate::sim::Simulator;

    const FS: f64 = 1000.0;

    /// A 20 Hz mode (ζ 2 %, τ 0.4 s) swept 5 -> 45 Hz at 1 kHz, in a record
    /// of 131 s with `silence` seconds before and after the sweep.
    fn record(silence: f64) -> (Vec<f64>, Vec<f64>) {
        let n = 1 << 17;
        let (t0, t1) = (silence, n as f64 / FS - silence);
        let rate = 40.0 / (t1 - t0);
        let force: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64 / FS;
                if (t0..t1).contains(&t) {
                    let s = t - t0;
                    10.0 * (2.0 * PI * (5.0 * s + 0.5 * rate * s * s)).sin()
                } else {
                    0.0
                }
            })
            .collect();
        let model = ModalModel::new(vec![Mode::from_modal_mass(20.0, 0.02, 1.0).unwrap()]).unwrap();
        let x = Simulator::new(&model, NoElement, FS)
            .unwrap()
            .run(&force, &crate::observe::Silent)
            .unwrap()
            .displacement;
        (force, x)
    }

    fn options() -> SweepOptions {
        SweepOptions {
            compensation_s: Some(1.6),
            ..SweepOptions::default()
        }
    }

    /// The phase followed a block at a time (the analytic signal in
    /// tapered blocks) against the whole record's transform: the same sweep,
    /// and the fitted phase laws apart by at most 3e-5 rad over it, which
    /// moves a window by 1e-3 of a sample at the sweep's lowest frequency.
    /// (The sweep fills the record: where it starts abruptly, the envelope's
    /// crossing of the threshold, a Hilbert transform's near a jump, can
    /// move by a frame.)
    #[test]
    fn the_phase_followed_in_blocks_is_the_whole_records() {
        let (force, x) = record(0.0);
        let (whole, s) = fit_sweep(&force, FS, &options()).unwrap();
        let mut src = InMemory {
            force: &force,
            response: &x,
        };
        let (blocks, t) = fit_sweep_in_blocks(&mut src, FS, &options(), &SMALL).unwrap();
        assert_eq!((s.law, s.start, s.end), (t.law, t.start, t.end));
        assert_eq!(s.law, SweepLaw::Linear);
        let apart = (s.start..s.end)
            .map(|n| (whole.phase(n as f64) - blocks.phase(n as f64)).abs())
            .fold(0.0, f64::max);
        let mid = (s.start + s.end) / 2;
        let centre = (whole.phase(mid as f64) - blocks.phase(mid as f64)).abs();
        eprintln!("phase laws apart by {apart:.1e} rad, {centre:.1e} at the middle");
        assert!(apart < 3e-5, "{apart}");
    }

    /// A long reference's sweep found a block at a time from scratch files
    /// (as a time fit's `--band` finds it) is the one its blocks give in
    /// memory, and the band's samples are those of the whole record's
    /// sweep to within a sample; a short one is read whole (the same bits).
    #[test]
    fn a_held_references_sweep_is_found_a_block_at_a_time() {
        let (force, x) = record(3.0);
        let spilled = {
            let mut b = crate::signals::SamplesBuilder::new(force.len(), &[]).spilling_above(1000);
            b.extend(&force).unwrap();
            b.finish().unwrap()
        };
        assert!(spilled.is_spilled() && force.len() > SMALL.whole);
        let find = |fs: f64, blocks: &Blocks| {
            let mut held = InMemoryFrames::single(spilled.view(), fs);
            find_sweep_in(
                &mut frame_reference(&mut held, 0, blocks)?,
                fs,
                &options(),
                blocks,
            )
        };
        let held = find(FS, &SMALL).unwrap();
        let mut src = InMemory {
            force: &force,
            response: &x,
        };
        let (_, blocks) = fit_sweep_in_blocks(&mut src, FS, &options(), &SMALL).unwrap();
        assert_eq!(format!("{held:?}"), format!("{blocks:?}"));
        let whole = super::super::find_sweep_whole(&force, FS, &options()).unwrap();
        for band in [(10.0, 20.0), (30.0, 44.0)] {
            let (h, w) = (held.samples_in(band), whole.samples_in(band));
            assert!(
                h.start.abs_diff(w.start) <= 1 && h.end.abs_diff(w.end) <= 1,
                "{band:?}: {h:?} against {w:?}"
            );
        }
        let short = find(FS, &BLOCKS).unwrap();
        assert_eq!(format!("{short:?}"), format!("{whole:?}"));
        let e = find(0.0, &SMALL).unwrap_err();
        assert!(e.to_string().contains("sample rate"), "{e}");
    }

    /// The compensation by overlap-save in blocks of 4 096 against the
    /// whole record's convolution, from the same plain windows: the same
    /// harmonics and variances to 1e-10 (both are the same sums, in a
    /// different order).
    #[test]
    fn the_compensation_by_overlap_save_is_the_whole_convolution() {
        let (force, x) = record(3.0);
        let (law, sweep) = fit_sweep(&force, FS, &options()).unwrap();
        let mut src = InMemory {
            force: &force,
            response: &x,
        };
        let windows = plain_windows(&mut src, &law, &sweep, &options()).unwrap();
        let sigma = 1.6 * FS;
        let k = options().max_harmonic;
        let whole = compensated(&force, &x, &law, &sweep, &windows, sigma, k);
        let blocks =
            compensated_in_blocks(&mut src, &law, &sweep, &windows, sigma, k, &SMALL).unwrap();
        let (mut value, mut variance) = (0.0f64, 0.0f64);
        for (a, b) in whole.iter().zip(&blocks) {
            for ch in 0..2 {
                let scale = a.of(ch)[1].norm();
                for (p, q) in a.of(ch).iter().zip(b.of(ch)) {
                    value = value.max((p - q).norm() / scale);
                }
                for (p, q) in a.variances(ch).iter().zip(b.variances(ch)) {
                    variance = variance.max((p / q - 1.0).abs());
                }
            }
        }
        eprintln!(
            "{} windows: harmonics {value:.1e}, variances {variance:.1e}",
            windows.len()
        );
        assert!(value < 1e-10, "{value}");
        assert!(variance < 1e-10, "{variance}");
    }

    /// With the phase kept at every 8th frame the sweep rate is the same to
    /// 1e-6, its ends move by at most 8 frames and its end
    /// frequencies by the law's change over those frames, to 1e-6 Hz.
    #[test]
    fn a_decimated_phase_gives_the_same_law() {
        let (force, x) = record(3.0);
        let blocks = Blocks {
            phase_points: 1 << 14,
            ..SMALL
        };
        let mut src = InMemory {
            force: &force,
            response: &x,
        };
        let (_, whole) = super::super::sweep::fit_phase(
            &super::super::analytic::analytic(&force),
            FS,
            &options(),
        )
        .unwrap();
        let (_, coarse) = fit_sweep_in_blocks(&mut src, FS, &options(), &blocks).unwrap();
        eprintln!("{whole:?}\n{coarse:?}");
        let rate = whole.rate_hz_per_s;
        assert!((coarse.rate_hz_per_s / rate - 1.0).abs() < 1e-6);
        assert!(whole.start.abs_diff(coarse.start) <= 8);
        assert!(whole.end.abs_diff(coarse.end) <= 8);
        let moved = |a: usize, b: usize| (b as f64 - a as f64) / FS * rate;
        let start = coarse.f_start_hz - whole.f_start_hz - moved(whole.start, coarse.start);
        let end = coarse.f_end_hz - whole.f_end_hz - moved(whole.end, coarse.end);
        eprintln!("start {start:.1e} Hz, end {end:.1e} Hz");
        assert!(start.abs() < 1e-6 && end.abs() < 1e-6);
    }

    /// Held in scratch files (as a loader holds a long recording's
    /// channels, and `validate` a long replay), the record reduces to the
    /// same bits as its values in memory, and the automatic compensation
    /// chosen from it is the same.
    #[test]
    fn channels_held_in_scratch_files_reduce_as_in_memory() {
        let (force, x) = record(3.0);
        let spilled = |v: &[f64]| {
            let mut b = crate::signals::SamplesBuilder::new(v.len(), &[]).spilling_above(5_000);
            v.chunks(7_777).for_each(|c| b.extend(c).unwrap());
            let s = b.finish().unwrap();
            assert!(s.is_spilled());
            s
        };
        let (f, y) = (spilled(&force), spilled(&x));
        let pair = |f, y| InMemoryFrames::pair(f, y, FS);
        let mut held = pair(f.view(), y.view()).unwrap();
        let mut whole = pair((&force).into(), (&x).into()).unwrap();
        assert_eq!(
            reduce_sweep(&mut held, 0, 1, &options()).unwrap(),
            reduce_sweep(&mut whole, 0, 1, &options()).unwrap()
        );
        let plain = SweepOptions {
            compensation_s: None,
            ..options()
        };
        assert_eq!(
            choose_compensation(&mut held, 0, 1, &plain).unwrap(),
            choose_compensation(&mut whole, 0, 1, &plain).unwrap()
        );
        let short = spilled(&x[..x.len() - 1]);
        let e = pair(f.view(), short.view()).err().unwrap().to_string();
        assert!(e.contains("must be sampled together"), "{e}");
    }

    /// Read from a WAV file a stretch at a time, the record reduces to the
    /// same bits as read whole into memory; a non-finite sample is named
    /// by its frame.
    #[test]
    fn a_recording_read_a_stretch_at_a_time_equals_it_in_memory() {
        let (force, x) = record(3.0);
        let channel = |name: &str, quantity: crate::harmonics::Quantity| Channel {
            name: name.into(),
            quantity,
            unit: crate::harmonics::Quantity::si_unit(quantity).into(),
            scale: 1.0,
        };
        let rec = Recording {
            meta: RecordingMeta {
                format: crate::record::FORMAT_V1.into(),
                sample_rate_hz: FS,
                channels: vec![
                    channel("force", crate::harmonics::Quantity::Force),
                    channel("x", crate::harmonics::Quantity::Displacement),
                ],
                excitation: Excitation {
                    kind: ExcitationKind::SweptSine,
                    steps: Vec::new(),
                    sweep: None,
                },
                description: String::new(),
                metadata: Default::default(),
                extra: Default::default(),
                chosen_reference: None,
            },
            channels: vec![force, x],
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sweep.json");
        crate::record::write_recording(&path, &rec, crate::record::SampleFormat::Float32).unwrap();
        let back = crate::record::read_recording(&path).unwrap();
        let mut reader = crate::record::RecordingReader::open(&path).unwrap();
        let mut pair = frame_pair(&mut reader, 0, 1, &SMALL).unwrap();
        let streamed = reduce_sweep_from(&mut pair, FS, &options(), &SMALL).unwrap();
        let in_memory = reduce_sweep_from(
            &mut InMemory {
                force: &back.channels[0],
                response: &back.channels[1],
            },
            FS,
            &options(),
            &SMALL,
        )
        .unwrap();
        assert_eq!(streamed, in_memory);
        let mut bad = back;
        bad.channels[1][70_000] = f64::NAN;
        let err = reduce_sweep_from(
            &mut InMemory {
                force: &bad.channels[0],
                response: &bad.channels[1],
            },
            FS,
            &options(),
            &SMALL,
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("response[70000]"), "{err}");
    }
}
