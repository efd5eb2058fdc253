//! Period-doubled dwells in a recording hystid did not make: development
//! case broad-101 (a Masing joint beside a bilinear stiffness with
//! `kb/k = 0.72`), whose largest two levels settle into a response that
//! repeats every second drive period near 1.6 kHz.
//!
//! The reference is the reference simulator's clean response, split by a
//! shift of one drive period: `s(t) = (y(t) − y(t+T))/2` holds every line
//! at an odd multiple of `f/2` and nothing else, `p(t) = (y(t) + y(t+T))/2`
//! the drive's harmonics. No least squares, no blocks: what the reduction
//! measures at `f/2` must be that.

use super::kit::corpus::{draw_broad, generate};
use super::kit::recording::write_recording;
use hystid::extract::{ReduceOptions, SUBHARMONIC_RATIO, reduce_stepped_report};
use hystid::observe::Silent;
use std::f64::consts::TAU;
use std::path::PathBuf;

/// `y` at the (fractional) sample `t`, linearly interpolated.
fn at(y: &[f64], t: f64) -> f64 {
    let i = t.floor() as usize;
    let w = t - i as f64;
    y[i] * (1.0 - w) + y[i + 1] * w
}

/// The ratio of the period-2 part's lines to the drive's fundamental over
/// the `periods` whole periods of `y` at `f` from sample 0.
fn shifted_ratio(y: &[f64], fs: f64, f: f64, periods: usize) -> f64 {
    let period = fs / f;
    let n = (periods as f64 * period).floor() as usize;
    let (mut s2, mut p1) = (0.0, num_complex::Complex64::default());
    for k in 0..n {
        let (a, b) = (y[k], at(y, k as f64 + period));
        s2 += ((a - b) / 2.0).powi(2);
        let w = TAU * f * k as f64 / fs;
        p1 += num_complex::Complex64::new(w.cos(), -w.sin()) * ((a + b) / 2.0);
    }
    // RMS of the lines over the fundamental's amplitude: √2·rms(s) / |P1|
    (2.0 * s2 / n as f64).sqrt() / (2.0 * p1.norm() / n as f64)
}

#[test]
fn period_doubled_dwells_are_measured_as_the_time_shift_gives_them() {
    let case = draw_broad(101);
    let rec = generate(&case);
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("broad-subharmonic");
    let _ = std::fs::remove_dir_all(&dir);
    let js = write_recording(&dir, &case, &rec).unwrap();
    let recording = hystid::record::read_recording(&js).unwrap();
    let reduced = reduce_stepped_report(&recording, 1, &ReduceOptions::default(), &Silent).unwrap();
    let frf = &reduced.frf;
    let fs = rec.sample_rate as f64;
    // the dwells as found, in time order, are the ones simulated
    assert_eq!(reduced.dwells.len(), rec.steps.len());
    let (mut flagged, mut checked) = (0, 0);
    for (&(f, level, start, settle, len), found) in rec.steps.iter().zip(&reduced.dwells) {
        let point = &frf.levels[found.level].points[found.point];
        assert!(
            (point.frequency_hz - f).abs() <= 1e-4 * f,
            "{f} Hz: {point:?}"
        );
        // the analysed part, one period short of its end for the shift
        let y = &rec.clean_response[start + settle..start + len];
        let periods = ((len - settle) as f64 * f / fs).floor() as usize - 1;
        let reference = shifted_ratio(y, fs, f, periods);
        match point.subharmonic {
            Some(s) => {
                flagged += 1;
                assert_eq!(s.order, 2, "{f} Hz at {level}: {s:?}");
                assert!(
                    (s.ratio - reference).abs() <= 0.03 * reference,
                    "{f} Hz at {level}: {} measured, {reference} by the shift",
                    s.ratio
                );
            }
            // clear of the threshold: the noise (0.5 % of the RMS here)
            // does not decide these dwells
            None => assert!(
                reference < 0.5 * SUBHARMONIC_RATIO,
                "{f} Hz at {level}: {reference} by the shift, not found"
            ),
        }
        checked += 1;
    }
    assert_eq!(checked, 98);
    assert_eq!(flagged, 6, "the top two levels at 1564, 1618 and 1643 Hz");
    let data = hystid::fit::FitData::from_frf(frf, &[1, 2, 3], None, None).unwrap();
    assert_eq!(data.subharmonic_points.len(), 6);
    let described = hystid::fit::SubharmonicPoint::describe(&data.subharmonic_points).unwrap();
    assert!(
        described.starts_with("6 dwell(s) between 1564"),
        "{described}"
    );
}
