//! Tests of the time-domain fit.

use super::driver::LM_TOLERANCE;
use super::folded::FOLDED_ROWS;
use super::intervals::felt_covariance;
use super::judging::JUDGED_STRETCH;
use super::streamed::ModelResiduals;
use super::*;
use crate::fit::optimise::{self, FitStatus, Objective};
use crate::fit::params::{ParameterSet, Transform};
use crate::harmonics::Quantity;
use crate::model::Model;
use crate::validate::resample::MAX_FACTOR;

/// A column the replay does not feel (exactly zero) is left out of the
/// covariance, which the others then have: with it, `JᵀJ` is singular.
#[test]
fn an_unfelt_parameter_is_left_out_of_the_covariance() {
    let jac = nalgebra::DMatrix::from_row_slice(
        4,
        3,
        &[
            1.0, 0.0, 0.5, //
            0.0, 0.0, 1.0, //
            2.0, 0.0, 0.0, //
            1.0, 0.0, 1.0,
        ],
    );
    let (free, cov) = felt_covariance(&jac, &[false; 3], 2.0);
    assert_eq!(free, vec![0, 2]);
    // the two felt columns' `s² (JᵀJ)⁻¹`, by hand: JᵀJ = [[6, 1.5], [1.5, 2.25]]
    let det = 6.0 * 2.25 - 1.5 * 1.5;
    let expected = [2.0 * 2.25 / det, -2.0 * 1.5 / det, 2.0 * 6.0 / det];
    let cov = cov.expect("invertible without the unfelt column");
    for (got, want) in [cov[(0, 0)], cov[(0, 1)], cov[(1, 1)]]
        .into_iter()
        .zip(expected)
    {
        assert!((got - want).abs() < 1e-12, "{got} against {want}");
    }
    // with every column kept there is no inverse
    let all = (jac.transpose() * &jac).try_inverse();
    assert!(all.is_none());
    // a tall Jacobian with a column at its bound: the free columns'
    // `JᵀJ`, read from the whole one's, is the same bits as that of their
    // copy (each entry one column's dot product with another)
    let tall = nalgebra::DMatrix::from_fn(5_001, 4, |i, j| {
        ((i * 7 + j * 13) as f64 * 0.37).sin() * (1.0 + j as f64)
    });
    let at_bound = [false, true, false, false];
    let (free, cov) = felt_covariance(&tall, &at_bound, 1.5);
    assert_eq!(free, vec![0, 2, 3]);
    let copy = nalgebra::DMatrix::from_fn(tall.nrows(), 3, |i, k| tall[(i, free[k])]);
    let want = copy.tr_mul(&copy).try_inverse().expect("invertible") * 1.5;
    assert_eq!(cov.expect("invertible"), want);
}
use crate::signals::{Channel, Excitation, ExcitationKind, Recording, RecordingMeta, Step};
use std::f64::consts::PI;
/// The further starts are the same on every call, move a parameter
/// fitted in its logarithm by up to a factor 1.5, a reciprocal one
/// likewise and a linear one by up to 15 %, cover that range both ways
/// (the draws are uniform: over 400 starts the extremes come within 2 %
/// of it and the mean within 0.1 of the middle), and stay strictly
/// inside the bounds: a start on a bound (a damping ratio at its
/// largest) is moved off it.
#[test]
fn further_starts_are_spread_about_the_given_one_inside_the_bounds() {
    use super::super::params::{Parameter, Target};
    let p = |transform, bounds| Parameter {
        name: "p".into(),
        target: Target::Mass { mode: 0 },
        transform,
        bounds,
    };
    let set = ParameterSet {
        parameters: vec![
            p(Transform::Log, [1e-3, 1e3]),
            p(Transform::Scaled { scale: 0.1 }, [0.0, 0.9]),
            p(Transform::Reciprocal, [1.0, 1e3]),
        ],
    };
    let values = [2.0, 0.9, 10.0];
    let theta0: Vec<f64> = set
        .parameters
        .iter()
        .zip(values)
        .map(|(p, v)| p.theta(v))
        .collect();
    let mut shares: Vec<Vec<f64>> = vec![Vec::new(); 3];
    for k in 1..=400 {
        let t = spread_start(&set, &theta0, k);
        assert_eq!(t, spread_start(&set, &theta0, k));
        let v = set.values(&t);
        let ratio = v[0] / values[0];
        assert!((1.0 / 1.5..=1.5).contains(&ratio), "{ratio}");
        shares[0].push(ratio.ln() / 1.5f64.ln());
        // from its upper bound: only down, and never on it
        assert!(v[1] < 0.9 && v[1] >= 0.9 * 0.85, "{}", v[1]);
        let ratio = v[2] / values[2];
        assert!((1.0 / 1.5..=1.5).contains(&ratio), "{ratio}");
        shares[2].push(ratio.ln() / 1.5f64.ln());
    }
    assert_ne!(
        spread_start(&set, &theta0, 1),
        spread_start(&set, &theta0, 2)
    );
    for u in [&shares[0], &shares[2]] {
        let (lo, hi) = u
            .iter()
            .fold((1.0f64, -1.0f64), |(a, b), &x| (a.min(x), b.max(x)));
        let mean = u.iter().sum::<f64>() / u.len() as f64;
        assert!(
            lo < -0.98 && hi > 0.98 && mean.abs() < 0.1,
            "{lo} {hi} {mean}"
        );
    }
}

/// The judging factor: the smallest that brings the samples within the
/// bound, over all the recordings; none below 8 samples a period of the
/// model's highest frequency, nor above the resampling limit.
#[test]
fn a_fit_judges_at_the_lowest_rate_its_bound_asks_and_its_model_allows() {
    let rec = |fs: f64, n: usize| TimeRecord {
        name: "r".into(),
        reference: vec![1.0; n].into(),
        reference_quantity: Quantity::Force,
        response: vec![1.0; n].into(),
        sample_rate_hz: fs,
        quantity: Quantity::Displacement,
        window: 0..n,
        segments: vec![0..n / 2, n / 2..n],
        band_hz: None,
        periodic: false,
    };
    let two = [rec(30_000.0, 6_000_000), rec(30_000.0, 2_230_473)];
    // 8 230 473 over 2^20: 8; 30 kHz allows 12 at 293 Hz, 3 at 1 kHz
    assert_eq!(judging_factors(&two, 293.0, MAX_JUDGED_SAMPLES), vec![8, 8]);
    assert_eq!(
        judging_factors(&two, 1000.0, MAX_JUDGED_SAMPLES),
        vec![3, 3]
    );
    // within the bound, or no frequency to go by: every sample
    assert_eq!(judging_factors(&two, 293.0, 1 << 24), vec![1, 1]);
    assert_eq!(judging_factors(&two, f64::NAN, 1000), vec![1, 1]);
    // a slow recording beside a fast one keeps its own floor
    let mixed = [rec(30_000.0, 8_000_000), rec(2_000.0, 1_000_000)];
    assert_eq!(
        judging_factors(&mixed, 100.0, MAX_JUDGED_SAMPLES),
        vec![9, 2]
    );
    assert_eq!(
        judging_factors(&mixed, 1.0, 1000),
        vec![MAX_FACTOR, MAX_FACTOR]
    );
}

/// A stepped sine of `steps`, stated.
fn stepped(steps: Vec<Step>) -> Excitation {
    Excitation {
        kind: ExcitationKind::SteppedSine,
        steps,
        sweep: None,
    }
}

fn recording(fs: f64, force: Vec<f64>, excitation: Excitation) -> Recording {
    let channel = |name: &str, quantity: Quantity| Channel {
        name: name.into(),
        quantity,
        unit: quantity.si_unit().into(),
        scale: 1.0,
    };
    // any response that is not silent: the band only picks samples
    let response: Vec<f64> = force.iter().map(|f| 1e-3 * f).collect();
    Recording {
        meta: RecordingMeta {
            format: crate::record::FORMAT_V1.into(),
            sample_rate_hz: fs,
            channels: vec![
                channel("force", Quantity::Force),
                channel("x", Quantity::Displacement),
            ],
            excitation,
            description: String::new(),
            metadata: Default::default(),
            extra: Default::default(),
            chosen_reference: None,
        },
        channels: vec![force, response],
    }
}

/// A linear sweep 2 -> 20 Hz over 100 s at 200 Hz: the band 5-10 Hz is
/// reached at t = 50/3 s and left at 400/9 s, by the closed form
/// `f(t) = 2 + 0.18 t`, so the window is samples 3333..8889 (within the
/// phase fit's rounding, a sample).
#[test]
fn a_swept_record_is_judged_where_the_sweep_is_in_the_band() {
    let fs = 200.0;
    let force: Vec<f64> = (0..20_000)
        .map(|i| {
            let t = i as f64 / fs;
            (2.0 * PI * (2.0 * t + 0.09 * t * t)).sin()
        })
        .collect();
    let kind = |kind| Excitation {
        kind,
        ..Excitation::default()
    };
    let rec = recording(fs, force, kind(ExcitationKind::SweptSine));
    let r = TimeRecord::from_recording("sweep", &rec, 1, None, Some((5.0, 10.0))).unwrap();
    let want = (50.0 / 3.0 * fs, 400.0 / 9.0 * fs);
    assert!(
        (r.window.start as f64 - want.0).abs() <= 2.0
            && (r.window.end as f64 - want.1).abs() <= 2.0,
        "{:?} against {want:?}",
        r.window
    );
    assert_eq!(r.segments, vec![r.window.clone()]);
    let all = TimeRecord::from_recording("sweep", &rec, 1, None, None).unwrap();
    assert_eq!(all.window, 0..20_000);
    let e = TimeRecord::from_recording("sweep", &rec, 1, None, Some((30.0, 40.0)))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("sweep: band") && e.contains("never inside"),
        "{e}"
    );
}

/// Three stated dwells at 4, 6 and 8 Hz: the band 5-7 Hz keeps the
/// middle one's segment only; a band holding none is an error.
#[test]
fn a_stepped_record_is_judged_on_its_dwells_in_the_band() {
    let fs = 200.0;
    let steps: Vec<Step> = [4.0, 6.0, 8.0]
        .iter()
        .enumerate()
        .map(|(k, &f)| Step {
            frequency_hz: f,
            level: 1.0,
            start: 1000 * k,
            settle: 0,
            length: 1000,
        })
        .collect();
    let force: Vec<f64> = (0..3000)
        .map(|i| (2.0 * PI * steps[i / 1000].frequency_hz * i as f64 / fs).sin())
        .collect();
    let rec = recording(fs, force, stepped(steps));
    let r = TimeRecord::from_recording("dwells", &rec, 1, None, Some((5.0, 7.0))).unwrap();
    assert_eq!(r.segments, vec![1000..2000]);
    let all = TimeRecord::from_recording("dwells", &rec, 1, None, None).unwrap();
    assert_eq!(all.segments.len(), 3);
    let e = TimeRecord::from_recording("dwells", &rec, 1, None, Some((9.0, 10.0)))
        .unwrap_err()
        .to_string();
    assert!(e.contains("no dwell"), "{e}");
}

/// `model`'s displacement driven by `force` sampled at `fs` (20 samples
/// a period of its highest frequency, noise-free).
fn displacement_of(model: &Model, force: &[f64], fs: f64) -> Vec<f64> {
    crate::validate::simulate_response(model, force, fs, Quantity::Displacement, 1.0, 20.0)
        .unwrap()
        .values
}

/// An SDOF at 60 Hz (1 kg, 2 % damping) with a Jenkins joint of slip
/// force 40 N and stick stiffness `kd` times the linear one, driven in
/// three stated dwells (52 Hz at 20 N, 60 and 71 Hz at 60 N; 12 000
/// samples each at 4 kHz after 500 of silence): the recording of the
/// joint at `kd` 1.2, noise-free; the model as a function of `kd`.
fn jenkins_dwells() -> (Recording, impl Fn(f64) -> Model, Model) {
    use crate::model::{ElementSpec, ModalModel};
    let fs = 4000.0;
    let w = 2.0 * PI * 60.0;
    let model = move |kd: f64| {
        Model::new(
            ModalModel::sdof(1.0, 2.0 * 0.02 * w, w * w).unwrap(),
            vec![ElementSpec::Jenkins {
                kd: kd * w * w,
                fd: 40.0,
            }],
        )
        .unwrap()
    };
    let mut force = Vec::new();
    let mut steps = Vec::new();
    for (f, level) in [(52.0, 20.0), (60.0, 60.0), (71.0, 60.0)] {
        force.extend(std::iter::repeat_n(0.0, 500));
        steps.push(Step {
            frequency_hz: f,
            level,
            start: force.len(),
            settle: 4000,
            length: 12_000,
        });
        force.extend((0..12_000).map(|i| level * (2.0 * PI * f * i as f64 / fs).sin()));
    }
    let truth = model(1.2);
    let measured = displacement_of(&truth, &force, fs);
    let mut rec = recording(fs, force, stepped(steps));
    rec.channels[1] = measured;
    (rec, model, truth)
}

/// A problem of the joint's parameters from `start`, judging at most
/// `most` samples.
fn judged_within<'a>(start: &Model, records: &'a [TimeRecord], most: usize) -> TimeProblem<'a> {
    let options = TimeFitOptions {
        max_judged_samples: most,
        ..TimeFitOptions::default()
    };
    let parameters = time_parameters(start, false, None);
    TimeProblem::new(start.clone(), parameters, records, 1.0, options, None).unwrap()
}

/// The joint fitted from `start` judging at most `most` samples, its
/// stick stiffness checked against `truth`'s to `tolerance`.
fn fits_kd_within(
    start: &Model,
    records: &[TimeRecord],
    most: usize,
    truth: &Model,
    tolerance: f64,
) -> TimeFitResult {
    let options = TimeFitOptions {
        max_judged_samples: most,
        refine_linear: false,
        ..TimeFitOptions::default()
    };
    let parameters = time_parameters(start, false, None);
    let fit = identify_time(start, parameters, 1.0, records, &options, None).unwrap();
    let kd = |m: &Model| match m.elements().next() {
        Some(&crate::model::ElementSpec::Jenkins { kd, .. }) => kd,
        _ => unreachable!(),
    };
    let error = kd(&fit.model) / kd(truth) - 1.0;
    assert!(error.abs() < tolerance, "kd {error:e} off");
    fit
}

/// Where the floor of [`MIN_JUDGED_PER_PERIOD`] samples a period keeps
/// more samples than the bound, each dwell is judged on its share, in
/// stretches: the judged samples stay within the bound, every stretch
/// inside its dwell (a dwell of one stretch judged on its last
/// samples), each residual the one judging every sample at that rate
/// gives there but for the divisor (its dwell's RMS over what is
/// judged), and the fit still finds the joint (noise-free: to 1e-6).
#[test]
fn a_recording_the_floor_keeps_above_the_bound_is_judged_in_stretches_of_each_dwell() {
    let (rec, model, truth) = jenkins_dwells();
    let records = [TimeRecord::from_recording("dwells", &rec, 1, None, None).unwrap()];
    let start = model(1.0);
    let problem = |most: usize| judged_within(&start, &records, most);
    // 37 500 samples; the stick mode at 60·√2.2 = 89 Hz allows at most
    // 4000/(8·89) = 5.6: one in 5, 7 500 judged, more than 3 000
    let (part, whole) = (problem(3_000), problem(7_500));
    assert_eq!(part.judging_factors(), [5]);
    assert_eq!(whole.judging_factors(), [5]);
    assert!(part.judged_in_part() && !whole.judged_in_part());
    let judged = part.judged_samples()[0];
    assert!((2_997..=3_000).contains(&judged), "{judged}");
    let (jp, jw) = (&part.judging[0], &whole.judging[0]);
    let mut last_end = 0;
    for (s, k) in &jp.stretches {
        let segment = &jw.stretches[*k].0;
        assert!(s.start >= segment.start && s.end <= segment.end && s.start >= last_end);
        assert!(s.len() <= JUDGED_STRETCH);
        last_end = s.end;
    }
    // 2 500 a dwell at 1/5 of 12 500: a share of 1 000, one stretch
    for (k, segment) in jw.stretches.iter().enumerate() {
        let mine: Vec<_> = jp.stretches.iter().filter(|(_, j)| *j == k).collect();
        assert_eq!(mine.len(), 1);
        assert_eq!(mine[0].0.end, segment.0.end);
    }
    let theta = part.parameters().theta_of(&start).unwrap();
    let (rp, rw) = (
        part.residuals(&theta).unwrap(),
        whole.residuals(&theta).unwrap(),
    );
    let mut p = 0;
    for (s, k) in &jp.stretches {
        for q in s.clone() {
            let at_whole = q - jw.stretches[*k].0.start
                + jw.stretches[..*k]
                    .iter()
                    .map(|(s, _)| s.len())
                    .sum::<usize>();
            let (a, b) = (rp[p] * jp.scale[*k], rw[at_whole] * jw.scale[*k]);
            assert!(
                (a - b).abs() <= 1e-12 * b.abs().max(1e-9),
                "{q}: {a} against {b}"
            );
            p += 1;
        }
    }
    assert_eq!(p, judged);
    let fit = fits_kd_within(&start, &records, 3_000, &truth, 1e-6);
    assert_eq!(fit.samples, judged);
    assert!(
        fit.notes
            .iter()
            .any(|n| n.contains("in stretches of at most"))
    );
}

/// A periodic record judged in part is judged on its first steady
/// periods whole (the periods are alike), not on a share of each: the
/// judged samples within the bound, the stretches the first periods
/// (the last in part), each residual the one judging every steady
/// sample gives there but for the divisor, and the fit still finds the
/// joint (noise-free: to 1e-6). Its replays stop at the last judged
/// sample, which leaves the residuals as they were.
#[test]
fn a_periodic_record_judged_in_part_is_judged_on_its_first_periods() {
    let (_, model, truth) = jenkins_dwells();
    let fs = 4000.0;
    // lines 40-80 Hz every 4 Hz (period 2 000 samples), Schroeder
    // phases, 8 periods: the joint slips on the peaks
    let (period, periods) = (2000, 8);
    let lines: Vec<usize> = (20..=40).step_by(2).collect();
    let force: Vec<f64> = (0..period * periods)
        .map(|i| {
            lines
                .iter()
                .enumerate()
                .map(|(j, &l)| {
                    let phase = -PI * (j * (j + 1)) as f64 / lines.len() as f64;
                    let t = (i % period) as f64 / period as f64;
                    10.0 * (2.0 * PI * l as f64 * t + phase).cos()
                })
                .sum()
        })
        .collect();
    let measured = displacement_of(&truth, &force, fs);
    let rec = recording(fs, force.clone(), Excitation::default());
    let record = TimeRecord::steady_periods(
        "multisine",
        &rec.meta,
        1,
        (force.into(), measured.into()),
        period,
    )
    .unwrap()
    .unwrap();
    assert!(record.periodic && record.segments.len() == periods - 1);
    let records = [record];
    let start = model(1.0);
    let problem = |most: usize| judged_within(&start, &records, most);
    // judged at one in 5 (the stick mode at 89 Hz): 400 a period, 2 800
    // in all; a bound of 1 000 gives each period a share of 142: two
    // periods whole and 194 samples of the third
    let (part, whole) = (problem(1_000), problem(2_800));
    assert_eq!(part.judging_factors(), [5]);
    assert!(part.judged_in_part() && !whole.judged_in_part());
    let (jp, jw) = (&part.judging[0], &whole.judging[0]);
    let first = |k: usize, n: usize| {
        let s = &jw.stretches[k].0;
        (s.start..s.start + n, k)
    };
    assert_eq!(jp.stretches, [first(0, 400), first(1, 400), first(2, 194)]);
    assert_eq!(part.judged_samples(), [994]);
    let theta = part.parameters().theta_of(&start).unwrap();
    let (rp, rw) = (
        part.residuals(&theta).unwrap(),
        whole.residuals(&theta).unwrap(),
    );
    // every sample judged: the misfit a start is chosen by is the sum
    // of the segments' relative errors squared
    let every = problem(14_000);
    assert_eq!(every.judging_factors(), [1]);
    let by_segment: f64 = every.errors(&start).unwrap()[0].segment_relative.powi(2);
    let judged = every.judged_misfit(&start).unwrap();
    assert!(
        (judged - by_segment).abs() < 1e-12 * by_segment,
        "{judged} {by_segment}"
    );
    // the judged samples', then the bounds' penalty row
    assert_eq!(rp.len(), 994 + 1);
    for (p, a) in rp[..994].iter().enumerate() {
        let k = p / 400;
        let (a, b) = (a * jp.scale[k], rw[p] * jw.scale[k]);
        assert!(
            (a - b).abs() <= 1e-12 * b.abs().max(1e-9),
            "{p}: {a} against {b}"
        );
    }
    let fit = fits_kd_within(&start, &records, 1_000, &truth, 1e-6);
    // the fit judges at the rate its own start model allows: within the bound
    assert!((990..=1_000).contains(&fit.samples), "{}", fit.samples);
    assert!(fit.notes.iter().any(|n| n.contains("first steady periods")));
}

/// A Jacobian folded into the R factor of `[r₀ J]` as its rows are made
/// (a stretch of every column's replay at a time) is the whole one's:
/// `RᵀR = [r₀ J]ᵀ[r₀ J]` to rounding, `R₀₀ = ‖r₀‖`; a model's residuals
/// handed out in stretches of any length are the residual vector's to
/// the bit, and a record taken as rejected gives what the residual
/// vector gives a model the simulator rejects; Levenberg–Marquardt on
/// the folded Jacobian reaches the optimum it reaches on the whole one.
#[test]
fn a_jacobian_folded_as_it_is_made_is_the_whole_ones() {
    let (rec, model, truth) = jenkins_dwells();
    let records = [TimeRecord::from_recording("dwells", &rec, 1, None, None).unwrap()];
    let start = model(1.0);
    let make = |held: usize| {
        let options = TimeFitOptions {
            max_judged_samples: 20_000,
            ..TimeFitOptions::default()
        };
        let parameters = time_parameters(&start, true, None);
        let mut p = TimeProblem::new(start.clone(), parameters, &records, 1.0, options, None)
            .unwrap()
            .with_jacobian_held_up_to(held);
        p.choose_replay_rates();
        p
    };
    let (whole, folded) = (make(usize::MAX), make(0));
    assert!(!whole.folds_jacobian() && folded.folds_jacobian());
    let theta: Vec<f64> = whole
        .parameters()
        .theta_of(&start)
        .unwrap()
        .iter()
        .map(|t| t + 0.01)
        .collect();
    let n = theta.len();
    let r0 = whole.residuals(&theta).unwrap();
    let m = r0.len() - 1;
    assert!(
        m > 3 * FOLDED_ROWS,
        "{m} judged: the fold is to take several stretches"
    );
    eprintln!("{m} judged samples, {n} parameters");
    let j = whole.jacobian_with_penalty_row(&theta, &r0, 1e-6).unwrap();
    let rf = folded.jacobian_r_factor(&theta, &r0, 1e-6).unwrap();
    assert_eq!(rf.shape(), (n + 1, n + 1));
    let a = nalgebra::DMatrix::from_fn(
        m + 1,
        n + 1,
        |i, k| if k == 0 { r0[i] } else { j[(i, k - 1)] },
    );
    let (g, h) = (a.tr_mul(&a), rf.tr_mul(&rf));
    let largest = g.amax();
    let worst = (&g - &h).amax();
    assert!(
        worst < 1e-12 * largest,
        "RᵀR off by {worst:e} of {largest:e}"
    );
    let norm = r0.iter().map(|v| v * v).sum::<f64>().sqrt();
    assert!((rf[(0, 0)] - norm).abs() < 1e-12 * norm);
    assert!((0..=n).all(|i| (0..i).all(|k| rf[(i, k)] == 0.0)));
    // stretches of any length: the residual vector's bits
    let (probe, _) = whole.model_at(&theta).unwrap();
    for chunk in [1, 777, 5_000] {
        let mut stream = ModelResiduals::new(&whole, probe.clone(), vec![false]);
        let mut got = Vec::new();
        let mut buffer = vec![0.0; chunk];
        loop {
            let k = stream.fill(&mut buffer).ok().expect("made");
            got.extend_from_slice(&buffer[..k]);
            if k < chunk {
                break;
            }
        }
        assert_eq!(got.len(), m);
        assert!(
            got.iter().zip(&r0).all(|(a, b)| a.to_bits() == b.to_bits()),
            "{chunk}"
        );
    }
    // a record taken as rejected: worse than predicting nothing
    let mut rejected = ModelResiduals::new(&whole, probe, vec![true]);
    let mut got = vec![0.0; m];
    assert_eq!(rejected.fill(&mut got).ok(), Some(m));
    let mut want = Vec::new();
    whole.judging[0].for_each_measured(&records[0], |k, v| {
        want.push(-2.0 * v / whole.judging[0].scale[k]);
    });
    assert_eq!(got, want);
    // Levenberg–Marquardt on either: the same optimum, the truth's
    let kd = |p: &TimeProblem, t: &[f64]| match p.model_at(t).unwrap().0.elements().next() {
        Some(&crate::model::ElementSpec::Jenkins { kd, .. }) => kd,
        _ => unreachable!(),
    };
    let truth_kd = match truth.elements().next() {
        Some(&crate::model::ElementSpec::Jenkins { kd, .. }) => kd,
        _ => unreachable!(),
    };
    let fits: Vec<f64> = [&whole, &folded]
        .iter()
        .map(|p| {
            let run = optimise::levenberg_marquardt_to(*p, &theta, 40, LM_TOLERANCE).unwrap();
            kd(p, &run.theta)
        })
        .collect();
    eprintln!(
        "kd: whole {:e}, folded {:e}, truth {truth_kd:e}",
        fits[0], fits[1]
    );
    assert!((fits[1] / fits[0] - 1.0).abs() < 1e-7, "{fits:?}");
    assert!(
        (fits[1] / truth_kd - 1.0).abs() < 1e-6,
        "{fits:?} against {truth_kd}"
    );
}

/// A record whose channels are held in scratch files (as a loader holds
/// a long recording's) is judged as the one held in memory, to the bit:
/// its residuals, its replays, its errors split by frequency and the
/// replay grid chosen for it, at the recording's rate and judged at
/// every sample, and upsampled (the drive interpolated a stretch at a
/// time rather than made whole) and judged at a lower rate.
#[test]
fn a_record_held_in_scratch_files_is_judged_as_the_one_held_in_memory() {
    use crate::signals::SamplesBuilder;
    let (rec, model, truth) = jenkins_dwells();
    let held = |spill: bool| {
        let samples = |x: &[f64]| {
            let b = SamplesBuilder::new(x.len(), &[]);
            let mut b = if spill { b.spilling_above(5_000) } else { b };
            x.chunks(4_321).for_each(|c| b.extend(c).unwrap());
            b.finish().unwrap()
        };
        let channels = (samples(&rec.channels[0]), samples(&rec.channels[1]));
        assert_eq!(channels.0.is_spilled(), spill);
        TimeRecord::from_channels("dwells", &rec.meta, 1, channels, None, Some((55.0, 75.0)))
            .unwrap()
    };
    let (in_memory, spilled) = ([held(false)], [held(true)]);
    let start = model(1.0);
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for options in [
        TimeFitOptions::default(),
        TimeFitOptions {
            min_samples_per_period: 300.0,
            max_judged_samples: 10_000,
            ..TimeFitOptions::default()
        },
    ] {
        let problem = |records| {
            let mut p = TimeProblem::new(
                start.clone(),
                time_parameters(&start, true, None),
                records,
                1.0,
                options.clone(),
                None,
            )
            .unwrap();
            p.choose_replay_rates();
            p
        };
        let (a, b) = (problem(&in_memory), problem(&spilled));
        // both paths taken: upsampled 7 times and judged at a third
        let upsampled = options.max_judged_samples < MAX_JUDGED_SAMPLES;
        let factors = if upsampled { (7, 3) } else { (1, 1) };
        assert_eq!(a.replay_factors(), [Some(factors.0)]);
        assert_eq!(a.judging_factors(), [factors.1]);
        assert_eq!(a.replay_factors(), b.replay_factors());
        assert_eq!(a.judging_factors(), b.judging_factors());
        let theta: Vec<f64> = a
            .parameters()
            .theta_of(&start)
            .unwrap()
            .iter()
            .map(|t| t + 0.01)
            .collect();
        assert_eq!(
            bits(&a.residuals(&theta).unwrap()),
            bits(&b.residuals(&theta).unwrap())
        );
        let truth_replays = a.replays_of(&truth).unwrap();
        assert_eq!(truth_replays, b.replays_of(&truth).unwrap());
        let errors = a.errors_by_frequency(&start).unwrap();
        assert!(errors[0].window.by_frequency.is_some());
        assert_eq!(errors, b.errors_by_frequency(&start).unwrap());
    }
}

/// Three recordings of an SDOF at 60 Hz with a Jenkins joint (as
/// [`jenkins_dwells`]), each two dwells (56 and 64 Hz) at its own level
/// (15, 40, 80 N), with 1 % of seeded Gaussian noise, fitted with a
/// Jenkins joint (`kd` and `fd` free, from 10 % off), then each
/// refitted alone. Made by one joint, alone and together leave the same
/// residual, the noise (1.00x at the median, each within 0.2 % of the
/// 1 %); made by a joint whose stick stiffness was another in each run
/// (1.05, 1.2, 1.4 times the structure's), each level alone is matched
/// to the noise but all three at once only to 5-10 % (9.7x at the
/// median): the note says which.
#[test]
fn recordings_fitted_alone_tell_a_wrong_dependence_on_level() {
    use crate::model::{ElementSpec, ModalModel};
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let fs = 4000.0;
    let w = 2.0 * PI * 60.0;
    let model = |joint: ElementSpec| {
        Model::new(
            ModalModel::sdof(1.0, 2.0 * 0.02 * w, w * w).unwrap(),
            vec![joint],
        )
        .unwrap()
    };
    let jenkins = |kd: f64, fd: f64| ElementSpec::Jenkins { kd: kd * w * w, fd };
    let records = |truth: &dyn Fn(usize) -> Model| -> Vec<TimeRecord> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
        let normal = Normal::new(0.0, 1.0).unwrap();
        [15.0, 40.0, 80.0]
            .iter()
            .enumerate()
            .map(|(k, &level)| {
                let mut force = Vec::new();
                let mut steps = Vec::new();
                for f in [56.0, 64.0] {
                    force.extend(std::iter::repeat_n(0.0, 500));
                    steps.push(Step {
                        frequency_hz: f,
                        level,
                        start: force.len(),
                        settle: 2000,
                        length: 6000,
                    });
                    force.extend((0..6000).map(|i| level * (2.0 * PI * f * i as f64 / fs).sin()));
                }
                let mut x = displacement_of(&truth(k), &force, fs);
                let rms = (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
                x.iter_mut()
                    .for_each(|v| *v += 0.01 * rms * normal.sample(&mut rng));
                let mut rec = recording(fs, force, stepped(steps));
                rec.channels[1] = x;
                TimeRecord::from_recording(&format!("{level} N"), &rec, 1, None, None).unwrap()
            })
            .collect()
    };
    let options = TimeFitOptions {
        refine_linear: false,
        each_alone: true,
        ..TimeFitOptions::default()
    };
    let start = model(jenkins(1.1, 40.0));
    let median = |fit: &TimeFitResult| {
        let mut c: Vec<f64> = fit.each_alone.iter().map(|a| a.closer().unwrap()).collect();
        c.sort_by(f64::total_cmp);
        c[1]
    };
    let mut closer = Vec::new();
    // the same joint at every level, then one whose slip force was
    // another in each run (30, 40, 55 N)
    let same = |_: usize| model(jenkins(1.2, 40.0));
    let changed = |k: usize| model(jenkins([1.05, 1.2, 1.4][k], 40.0));
    let truths: [&dyn Fn(usize) -> Model; 2] = [&same, &changed];
    for truth in truths {
        let recs = records(truth);
        let parameters = time_parameters(&start, false, None);
        let fit = identify_time(&start, parameters, 1.0, &recs, &options, None).unwrap();
        assert_eq!(fit.each_alone.len(), 3);
        for (a, after) in fit.each_alone.iter().zip(&fit.after) {
            assert_eq!(a.recording, after.recording);
            assert_eq!(a.together, after.window.relative);
            assert!(
                a.failed.is_none() && a.status == FitStatus::Converged,
                "{a:?}"
            );
            // an alone fit starts from the joint optimum: no worse but
            // for the optimiser's tolerance (it minimises the dwells'
            // relative errors, this is the window's)
            assert!(a.alone.unwrap() <= a.together * (1.0 + 1e-4), "{a:?}");
        }
        let note = fit.notes.last().unwrap();
        assert!(note.starts_with("refitted alone"), "{note}");
        eprintln!("{note}");
        closer.push((median(&fit), note.clone(), fit));
    }
    let (consistent, note, fit) = &closer[0];
    // the noise floor, alone or together: 1 % of the RMS
    assert!((consistent - 1.0).abs() < 0.02, "{consistent}: {note}");
    assert!(
        fit.each_alone
            .iter()
            .all(|a| (a.together - 0.01).abs() < 0.002)
    );
    assert!(note.contains("shared by every recording"), "{note}");
    let (inconsistent, note, _) = &closer[1];
    assert!(*inconsistent > 2.0 * CLOSER_ALONE, "{inconsistent}: {note}");
    assert!(note.contains("changes from one to the next"), "{note}");
    eprintln!("closer alone: {consistent:.3}x / {inconsistent:.3}x");
    // one refit or none that ended says nothing
    assert_eq!(level_consistency(&fit.each_alone[..1]), None);
}
