//! The analytic signal (FFT Hilbert transform): instantaneous phase and
//! amplitude of a reference channel, for dwell finding and sweep tracking.

use num_complex::Complex64;
use rustfft::FftPlanner;
use std::f64::consts::PI;

/// The smallest `2^a 3^b 5^c ≥ n` (fast FFT lengths; crates.md, realfft
/// pitfall 4).
pub fn next_smooth(n: usize) -> usize {
    let mut best = n.next_power_of_two();
    let mut p5 = 1usize;
    while p5 < best {
        let mut p35 = p5;
        while p35 < best {
            let mut v = p35;
            while v < n {
                v *= 2;
            }
            best = best.min(v);
            p35 *= 3;
        }
        p5 *= 5;
    }
    best
}

/// Unwrapped instantaneous phase (rad) and amplitude of a real signal, from
/// the analytic signal `x + j·H[x]` (mean removed, reflected at the ends,
/// zero-padded to a fast length). Near the record's ends and near abrupt
/// changes the Hilbert transform is not local: callers ignore a few periods
/// there.
pub(crate) struct Analytic {
    /// Unwrapped phase, rad.
    pub phase: Vec<f64>,
    /// Envelope `|x + jH[x]|`.
    pub amplitude: Vec<f64>,
}

pub(crate) fn analytic(signal: &[f64]) -> Analytic {
    let n = signal.len();
    // Zero padding: the record's ends act as jumps, whose Hilbert error
    // decays as about 1/(2π·periods from the end) of the amplitude (phase in
    // rad alike). Reflections do not help a sinusoid (an even reflection is
    // a phase jump, a point reflection adds an offset unless the end is at a
    // zero crossing), so the consumers leave the ends out instead.
    let nfft = next_smooth(n.max(2));
    let mean = signal.iter().sum::<f64>() / n.max(1) as f64;
    let mut buf = vec![Complex64::default(); nfft];
    for (b, &v) in buf.iter_mut().zip(signal) {
        *b = Complex64::new(v - mean, 0.0);
    }
    let mut planner = FftPlanner::<f64>::new();
    to_analytic(&mut planner, &mut buf);
    let inv = 1.0 / nfft as f64;
    let mut phase = Vec::with_capacity(n);
    let mut amplitude = Vec::with_capacity(n);
    let mut last = 0.0;
    let mut offset = 0.0;
    for (i, z) in buf[..n].iter().enumerate() {
        let z = z * inv;
        let a = z.arg();
        if i > 0 {
            let d = a - last;
            if d > PI {
                offset -= 2.0 * PI;
            } else if d < -PI {
                offset += 2.0 * PI;
            }
        }
        last = a;
        phase.push(a + offset);
        amplitude.push(z.norm());
    }
    Analytic { phase, amplitude }
}

/// `buf` (a real signal, zero-padded) into `nfft` times its analytic
/// signal: DC and Nyquist kept, the positive frequencies doubled, the
/// negative dropped.
pub(crate) fn to_analytic(planner: &mut FftPlanner<f64>, buf: &mut [Complex64]) {
    let nfft = buf.len();
    planner.plan_fft_forward(nfft).process(buf);
    let half = nfft / 2;
    for (k, v) in buf.iter_mut().enumerate() {
        if k == 0 || (nfft.is_multiple_of(2) && k == half) {
            continue;
        } else if k < nfft.div_ceil(2) {
            *v *= 2.0;
        } else {
            *v = Complex64::default();
        }
    }
    planner.plan_fft_inverse(nfft).process(buf);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smooth_lengths() {
        assert_eq!(next_smooth(1000), 1000);
        assert_eq!(next_smooth(1001), 1024);
        assert_eq!(next_smooth(108_477), 109_350);
        assert_eq!(next_smooth(7), 8);
    }

    #[test]
    fn phase_of_a_sine_away_from_the_ends() {
        let fs = 1000.0;
        let f = 13.7; // 68.5 periods: not periodic in the record
        let n = 5000;
        let x: Vec<f64> = (0..n)
            .map(|n| 2.0 * (2.0 * PI * f * n as f64 / fs).sin())
            .collect();
        let mean = x.iter().sum::<f64>() / n as f64;
        let a = analytic(&x);
        // the sample mean is removed, so the envelope ripples by ±|mean|
        for p in [20.0, 30.0] {
            let edge = (p * fs / f) as usize;
            let (mut worst_rate, mut worst_amp) = (0.0f64, 0.0f64);
            let span = (4.0 * fs / f) as usize; // 4 periods, as find_dwells uses
            for i in edge..n - edge {
                if i + span < n - edge {
                    let rate = (a.phase[i + span] - a.phase[i]) / span as f64;
                    worst_rate = worst_rate.max((rate / (2.0 * PI * f / fs) - 1.0).abs());
                }
                worst_amp = worst_amp.max((a.amplitude[i] - 2.0).abs() - mean.abs());
            }
            // end error ≈ A/(2π p) decaying from each end
            let bound = 2.0 / (2.0 * PI * p);
            assert!(worst_amp < bound, "{p} periods in: {worst_amp} > {bound}");
            assert!(worst_rate < 0.05 * bound, "{p} periods in: {worst_rate}");
        }
    }
}
