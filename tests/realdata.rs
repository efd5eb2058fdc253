//! Integration tests: time-domain validation (`hystid::validate`), the
//! streaming stepped-sine reduction, and the real data sets end to end
//! (import -> reduction -> identification -> validation).
//!
//! Independent references: the noise actually added to a simulated
//! recording (a true model must leave exactly that as its error), a
//! simulation at ten times the rate (the upsampled validation must approach
//! it), the in-memory reduction (the streaming one must equal it), the
//! analytic FRF of an SDOF (peak refinement), and for the real data the
//! data sets' pinned figures and the linear (level-1) model the joint model
//! must beat.

use crate::common;
use hystid::extract::{
    Direction, FrfPoint, NonlinearFrf, ReduceOptions, SweepOptions, choose_compensation,
    reduce_stepped_by_dwell, reduce_stepped_report, reduce_sweep,
};
use hystid::fit::{FitOptions, FitResult, HbPredictor, LinearStart, identify};
use hystid::harmonics::{Quantity, omega};
use hystid::import::{ChannelSpec, ImportSpec, SampleRateSource, import};
use hystid::model::{ElementSpec, ModalModel, Model};
use hystid::record::{
    Channel, Excitation, ExcitationKind, FORMAT_V1, Recording, RecordingMeta, RecordingReader,
    SampleFormat, Step, read_recording, write_recording,
};
use hystid::sim::Simulator;
use hystid::validate::{
    DriveInput, Reduction, ValidateOptions, Validation, error_metrics, h1_peak, simulate_response,
    validate_recording,
};
use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::f64::consts::PI;
use std::path::Path;

/// SDOF, f_n = 20 Hz, ζ = 2 %, m = 1 kg, with a Masing joint of half the
/// stiffness (stick frequency 24.5 Hz) slipping at 20 N.
fn joint_model() -> Model {
    let m = 1.0;
    let k = m * omega(20.0).powi(2);
    let c = 2.0 * 0.02 * (k * m).sqrt();
    Model::new(
        ModalModel::sdof(m, c, k).unwrap(),
        vec![ElementSpec::Masing {
            kd: 0.5 * k,
            fd: 20.0,
            n: 3.0,
        }],
    )
    .unwrap()
}

fn channel(name: &str, q: Quantity) -> Channel {
    Channel {
        name: name.into(),
        quantity: q,
        unit: q.si_unit().into(),
        scale: 1.0,
    }
}

fn recording(
    fs: f64,
    force: Vec<f64>,
    response: Vec<f64>,
    q: Quantity,
    kind: ExcitationKind,
) -> Recording {
    Recording {
        meta: RecordingMeta {
            format: FORMAT_V1.into(),
            sample_rate_hz: fs,
            channels: vec![channel("force", Quantity::Force), channel("y", q)],
            excitation: Excitation {
                kind,
                steps: Vec::new(),
                sweep: None,
            },
            description: String::new(),
            metadata: Default::default(),
            extra: Default::default(),
            chosen_reference: None,
        },
        channels: vec![force, response],
    }
}

/// A linear sweep `f0 -> f1` over `seconds`, amplitude `a`, with a
/// half-second raised-cosine fade-in (the structure starts at rest).
fn sweep_force(fs: f64, f0: f64, f1: f64, seconds: f64, a: f64) -> Vec<f64> {
    let n = (seconds * fs) as usize;
    let rate = (f1 - f0) / seconds;
    (0..n)
        .map(|i| {
            let t = i as f64 / fs;
            let fade = if t < 0.5 {
                0.5 - 0.5 * (PI * t / 0.5).cos()
            } else {
                1.0
            };
            a * fade * (2.0 * PI * (f0 * t + 0.5 * rate * t * t)).sin()
        })
        .collect()
}

fn simulate(model: &Model, force: &[f64], fs: f64) -> hystid::sim::Response {
    let mut sim = Simulator::new(&model.linear, model.element_set().unwrap(), fs).unwrap();
    sim.run(force, &hystid::observe::Silent).unwrap()
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

/// The true model driven by the recorded force reproduces the noise-free
/// response sample for sample (same simulator, same rate), so its e_RMS is
/// exactly the RMS of the noise the test added; a model whose slip force is
/// 50 % off, and the linear model without the joint, are far worse. The
/// sweep window for the band 15-30 Hz follows from the law f = 10 + 0.5 t.
#[test]
fn validation_of_the_true_model_leaves_the_noise() {
    let fs = 1000.0;
    let model = joint_model();
    let force = sweep_force(fs, 10.0, 35.0, 50.0, 10.0);
    let clean = simulate(&model, &force, fs).acceleration;
    let sigma = 0.01 * rms(&clean);
    let normal = Normal::new(0.0, sigma).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let noise: Vec<f64> = (0..clean.len()).map(|_| normal.sample(&mut rng)).collect();
    let measured: Vec<f64> = clean.iter().zip(&noise).map(|(a, b)| a + b).collect();
    let rec = recording(
        fs,
        force,
        measured,
        Quantity::Acceleration,
        ExcitationKind::SweptSine,
    );
    let opts = ValidateOptions {
        band_hz: Some((15.0, 30.0)),
        reduction: Some(Reduction::Swept(SweepOptions {
            max_harmonic: 3,
            ..SweepOptions::default()
        })),
        // the recording's own simulator ran at its rate: straight lines
        // between the force's samples are what drove it
        input: DriveInput::Ramp,
        ..ValidateOptions::default()
    };
    let v = validate_recording(&model, 1.0, &rec, 1, &opts, &hystid::observe::Silent).unwrap();
    let ramp = ValidateOptions {
        input: DriveInput::Ramp,
        ..ValidateOptions::default()
    };
    let want = rms(&noise);
    eprintln!(
        "true model: e_RMS {:.6e} vs noise RMS {want:.6e}; upsampling {}",
        v.whole.e_rms, v.upsampling
    );
    assert_eq!(v.upsampling, 1);
    assert!((v.whole.e_rms / want - 1.0).abs() < 1e-9);
    let w = v.window.expect("band window");
    eprintln!(
        "  window {:.3}-{:.3} s, e_RMS {:.4e}",
        w.start_s, w.end_s, w.e_rms
    );
    assert!((w.start_s - 10.0).abs() < 0.05 && (w.end_s - 40.0).abs() < 0.05);
    let c = v.frf.as_ref().unwrap();
    let l = &c.levels[0];
    let (pm, ps) = (l.measured_peak.unwrap(), l.simulated_peak.unwrap());
    eprintln!(
        "  H1 error {:.2e} over {} points; peaks {:.4} / {:.4} Hz",
        l.relative_h1_error, l.points, pm.frequency_hz, ps.frequency_hz
    );
    // white noise of 1 % of the RMS, averaged over 4-period windows of
    // 170-400 samples, leaves under 0.5 % in H1 around the peak; it moves
    // the peak of the flat-topped (slipping) resonance by hundredths of a Hz
    assert!(l.relative_h1_error < 5e-3);
    assert!((pm.frequency_hz - ps.frequency_hz).abs() < 0.05);
    // a wrong slip force, and no joint at all
    let mut wrong = model.clone();
    wrong.joint = Some(ElementSpec::Masing {
        kd: 0.5 * model.linear.modes[0].modal_stiffness(),
        fd: 30.0,
        n: 3.0,
    });
    let vw = validate_recording(&wrong, 1.0, &rec, 1, &ramp, &hystid::observe::Silent).unwrap();
    let linear = Model::new(model.linear.clone(), Vec::new()).unwrap();
    let vl = validate_recording(&linear, 1.0, &rec, 1, &ramp, &hystid::observe::Silent).unwrap();
    eprintln!(
        "  slip force 30 N instead of 20 N: e_RMS {:.4e}; no joint: {:.4e}",
        vw.whole.e_rms, vl.whole.e_rms
    );
    assert!(vw.whole.e_rms > 3.0 * want);
    assert!(vl.whole.e_rms > vw.whole.e_rms);
    // the sign: a response recorded against the drive
    let flipped: Vec<f64> = rec.channels[1].iter().map(|v| -v).collect();
    let rec2 = recording(
        fs,
        rec.channels[0].clone(),
        flipped,
        Quantity::Acceleration,
        ExcitationKind::SweptSine,
    );
    let v2 = validate_recording(&model, -1.0, &rec2, 1, &ramp, &hystid::observe::Silent).unwrap();
    assert!((v2.whole.e_rms / want - 1.0).abs() < 1e-9);
}

/// A recording at 250 Hz holds only 10.2 samples per period of the joint
/// model's 24.5 Hz stick mode. The reference is the same structure
/// simulated at 2500 Hz and sampled every 10th sample. The validation
/// upsamples (x2 at the default 20 samples per period, x10 at 100) and
/// must come closer to the reference the more it upsamples; at x10 it
/// simulates at the reference's own rate, so what remains is the
/// interpolation of the force and the decimation filter (under 0.1 % of
/// the response RMS). Without upsampling (10 samples per period) the error
/// is about 5 %: the reason for the default of 20 (about 1 %).
#[test]
fn validation_upsamples_a_coarse_recording() {
    let (fs, factor) = (250.0, 10);
    let model = joint_model();
    let fine_force = sweep_force(fs * factor as f64, 10.0, 30.0, 40.0, 10.0);
    let fine = simulate(&model, &fine_force, fs * factor as f64).displacement;
    let force: Vec<f64> = fine_force.iter().step_by(factor).copied().collect();
    let x: Vec<f64> = fine.iter().step_by(factor).copied().collect();
    let rec = recording(
        fs,
        force,
        x,
        Quantity::Displacement,
        ExcitationKind::SweptSine,
    );
    let mut errors = Vec::new();
    for spp in [2.0, 20.0, 100.0] {
        let v = validate_recording(
            &model,
            1.0,
            &rec,
            1,
            &ValidateOptions {
                min_samples_per_period: spp,
                ..ValidateOptions::default()
            },
            &hystid::observe::Silent,
        )
        .unwrap();
        eprintln!(
            "at least {spp} samples per period: x{} upsampling, e_RMS {:.3e} ({:.3} % of the RMS)",
            v.upsampling,
            v.whole.e_rms,
            100.0 * v.whole.relative
        );
        errors.push((v.upsampling, v.whole.relative));
    }
    assert_eq!(
        errors.iter().map(|e| e.0).collect::<Vec<_>>(),
        vec![1, 2, 10]
    );
    assert!(errors[2].1 < errors[1].1 && errors[1].1 < errors[0].1);
    assert!(errors[2].1 < 1e-3, "{:?}", errors[2]);
}

/// A model whose further mode lies far above what the recording shows (a
/// broad background a time fit drove to 8 kHz beside a 90 Hz mode, at 1024
/// samples per second) is replayed, not refused, and not upsampled for it:
/// the mode, above twice the rate, is taken quasi-static, and the steady
/// response to a 90 Hz sine is the closed-form receptance's, the
/// background's flexibility included.
#[test]
fn a_mode_far_above_the_recording_is_replayed_by_its_flexibility() {
    let model = Model::new(
        ModalModel::new(vec![
            hystid::model::Mode::from_modal_mass(90.0, 0.01, 1.0).unwrap(),
            hystid::model::Mode::from_modal_mass(8000.0, 0.9, 1e-4).unwrap(),
        ])
        .unwrap(),
        Vec::new(),
    )
    .unwrap();
    let (fs, f, n) = (1024.0, 92.0, 8192);
    let force: Vec<f64> = (0..n)
        .map(|i| (2.0 * PI * f * i as f64 / fs).sin())
        .collect();
    assert_eq!(
        hystid::validate::upsampling_factor(&model, fs, 20.0).unwrap(),
        2,
        "the 90 Hz mode's rate (resolving the 8 kHz mode would ask for 157 times)"
    );
    let x = simulate_response(&model, &force, fs, Quantity::Displacement, 1.0, 20.0)
        .unwrap()
        .values;
    // the amplitude over the last second, long after the 90 Hz mode's
    // transient (time constant 0.18 s) has died
    let tail = &x[n - 1024..];
    let amplitude = (2.0 * tail.iter().map(|v| v * v).sum::<f64>() / tail.len() as f64).sqrt();
    let h = model.linear.receptance(omega(f)).norm();
    let background = model.linear.modes[1].residue / omega(8000.0).powi(2);
    eprintln!(
        "amplitude {amplitude:.6e}, |H| {h:.6e} (the background's static flexibility {:.2} % of it)",
        100.0 * background / h
    );
    assert!(
        background / h > 0.03,
        "the background must matter to the check"
    );
    // the band-limited replay of a sine 22 samples per period: 1.07e-3
    // measured, the quasi-static flexibility taking the drive's
    // pre-emphasis (θ²/12 = 0.66 % here), which only the resolved modes'
    // sinc² loss asks for, on its 6.6 % share (resolved at 64 times the
    // rate: 2e-5)
    assert!(
        (amplitude / h - 1.0).abs() < 1.5e-3,
        "{amplitude} against {h}"
    );
}

/// The simulation refuses what it cannot do, naming the problem.
#[test]
fn validation_errors_are_clear() {
    let model = joint_model();
    let force = vec![0.0; 100];
    let e = simulate_response(&model, &force, 1000.0, Quantity::Force, 1.0, 20.0)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a motion"), "{e}");
    let e = simulate_response(&model, &force, 1000.0, Quantity::Displacement, 0.5, 20.0)
        .unwrap_err()
        .to_string();
    assert!(e.contains("response_sign"), "{e}");
    // 24.5 Hz at 2 Hz sampling would need x245
    let e = simulate_response(&model, &force, 2.0, Quantity::Displacement, 1.0, 20.0)
        .unwrap_err()
        .to_string();
    assert!(e.contains("far stiffer"), "{e}");
    let mut bad = force.clone();
    bad[17] = f64::NAN;
    let e = simulate_response(&model, &bad, 1000.0, Quantity::Displacement, 1.0, 20.0)
        .unwrap_err()
        .to_string();
    assert!(e.contains("sample 17"), "{e}");
    let rec = recording(
        1000.0,
        force.clone(),
        force.clone(),
        Quantity::Displacement,
        ExcitationKind::Unknown,
    );
    let e = validate_recording(
        &model,
        1.0,
        &rec,
        1,
        &ValidateOptions {
            window_s: Some((5.0, 6.0)),
            ..ValidateOptions::default()
        },
        &hystid::observe::Silent,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("hold nothing"), "{e}");
    assert!(error_metrics(&[1.0], &[1.0], 1.0, 0..0).is_err());
}

/// The peak of an SDOF's |H| sampled every 0.25 Hz: the parabola through
/// the largest sample and its neighbours lands closer to the analytic peak
/// `f_n √(1 − 2ζ²)` than the largest sample; a sampled parabola is exact.
#[test]
fn peak_refinement_beats_the_grid() {
    let sdof = ModalModel::sdof(1.0, 2.0 * 0.05 * omega(20.0), omega(20.0).powi(2)).unwrap();
    let points: Vec<FrfPoint> = (0..40)
        .map(|i| {
            let f = 15.1 + 0.25 * i as f64;
            FrfPoint {
                frequency_hz: f,
                force_amplitude: 1.0,
                h: vec![Complex64::default(), sdof.receptance(omega(f))],
                std_error: vec![0.0; 2],
                force_distortion: Vec::new(),
                blocks: 1,
                settle_periods: 0,
                settled: true,
                subharmonic: None,
            }
        })
        .collect();
    let exact = 20.0 * (1.0 - 2.0 * 0.05f64.powi(2)).sqrt();
    let p = h1_peak(&points, None).unwrap();
    let grid = points
        .iter()
        .max_by(|a, b| a.h[1].norm().total_cmp(&b.h[1].norm()))
        .unwrap()
        .frequency_hz;
    eprintln!(
        "peak: analytic {exact:.5} Hz, grid {grid:.3} Hz, refined {:.5} Hz",
        p.frequency_hz
    );
    assert!((p.frequency_hz - exact).abs() < 0.3 * (grid - exact).abs());
    // a band that cuts the peak away leaves its edge
    let edge = h1_peak(&points, Some((15.0, 18.0))).unwrap();
    assert!(edge.frequency_hz <= 18.0);
    let parabola: Vec<FrfPoint> = [1.5, 1.8, 2.4]
        .iter()
        .map(|&f| FrfPoint {
            h: vec![
                Complex64::default(),
                Complex64::new(5.0 - (f - 1.9) * (f - 1.9), 0.0),
            ],
            frequency_hz: f,
            ..points[0].clone()
        })
        .collect();
    let q = h1_peak(&parabola, None).unwrap();
    assert!((q.frequency_hz - 1.9).abs() < 1e-12 && (q.magnitude - 5.0).abs() < 1e-12);
}

/// Stepped-sine dwells of the joint model: 2 levels x 4 frequencies,
/// each dwell 3 s settling + 2 s measured.
fn stepped(fs: f64) -> Recording {
    let model = joint_model();
    let mut sim = Simulator::new(&model.linear, model.element_set().unwrap(), fs).unwrap();
    let (mut force, mut x) = (Vec::new(), Vec::new());
    let mut steps = Vec::new();
    let mut phase = 0.0;
    for level in [5.0, 15.0] {
        for f in [17.0, 19.0, 21.0, 23.0] {
            let start = force.len();
            let (settle, length) = ((3.0 * fs) as usize, (5.0 * fs) as usize);
            for _ in 0..length {
                let v: f64 = level * f64::sin(phase);
                phase += 2.0 * PI * f / fs;
                force.push(v);
                x.push(sim.step(v).unwrap().displacement);
            }
            steps.push(Step {
                frequency_hz: f,
                level,
                start,
                settle,
                length,
            });
        }
    }
    let mut rec = recording(
        fs,
        force,
        x,
        Quantity::Displacement,
        ExcitationKind::SteppedSine,
    );
    rec.meta.excitation.steps = steps;
    rec
}

/// The streaming reduction (one dwell read at a time from the WAV file)
/// gives exactly the FRFs and dwell reports of the in-memory reduction of
/// the same file; without stated steps too (the dwells of a record this
/// short found in its reference read whole, then reduced one at a time as
/// found ones are).
#[test]
fn streaming_stepped_reduction_equals_the_in_memory_one() {
    let open = |p: &std::path::Path| RecordingReader::open(p).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("stepped");
    write_recording(&path, &stepped(1000.0), SampleFormat::Float32).unwrap();
    let opts = ReduceOptions::default();
    let t = std::time::Instant::now();
    let streamed =
        reduce_stepped_by_dwell(&mut open(&path), 1, &opts, &hystid::observe::Silent).unwrap();
    let ts = t.elapsed();
    let whole = read_recording(&path).unwrap();
    let t = std::time::Instant::now();
    let memory = reduce_stepped_report(&whole, 1, &opts, &hystid::observe::Silent).unwrap();
    eprintln!(
        "streamed {ts:?}, in memory {:?}; {} levels",
        t.elapsed(),
        memory.frf.levels.len()
    );
    assert_eq!(streamed.frf, memory.frf);
    assert_eq!(streamed.dwells, memory.dwells);
    assert_eq!(memory.frf.levels.len(), 2);
    // without steps
    let mut bare = whole.clone();
    bare.meta.excitation.steps.clear();
    let p2 = dir.path().join("bare");
    write_recording(&p2, &bare, SampleFormat::Float32).unwrap();
    let streamed =
        reduce_stepped_by_dwell(&mut open(&p2), 1, &opts, &hystid::observe::Silent).unwrap();
    let memory = reduce_stepped_report(
        &read_recording(&p2).unwrap(),
        1,
        &opts,
        &hystid::observe::Silent,
    )
    .unwrap();
    assert!(streamed.dwells_found && memory.dwells_found);
    assert_eq!(memory.dwells.len(), 8);
    assert_eq!(streamed.dwells, memory.dwells);
    assert_eq!(streamed.frf, memory.frf);
    let e = reduce_stepped_by_dwell(&mut open(&path), 5, &opts, &hystid::observe::Silent)
        .unwrap_err()
        .to_string();
    assert!(e.contains("response channel 5"), "{e}");
}

/// A stepped-sine recording without stated steps, validated with its true
/// model: the simulated response is reduced on exactly the dwells found in
/// the measured one, so with no noise the H1 error is at rounding level.
#[test]
fn stepped_validation_uses_the_measured_dwells() {
    let mut rec = stepped(1000.0);
    rec.meta.excitation.steps.clear();
    let v = validate_recording(
        &joint_model(),
        1.0,
        &rec,
        1,
        &ValidateOptions {
            reduction: Some(Reduction::Stepped(ReduceOptions::default())),
            input: DriveInput::Ramp,
            ..ValidateOptions::default()
        },
        &hystid::observe::Silent,
    )
    .unwrap();
    let c = v.frf.unwrap();
    assert_eq!(c.levels.len(), 2);
    for l in &c.levels {
        eprintln!(
            "level {:.3}: H1 error {:.2e}, {} points",
            l.level, l.relative_h1_error, l.points
        );
        assert_eq!(l.points, 4);
        assert!(l.relative_h1_error < 1e-9);
    }
    // the same simulator on the same force: identical samples
    assert_eq!(v.whole.e_rms, 0.0);
}

// ---------------------------------------------------------------- real data

/// A swept recording's FRF set: the reduction with the automatic
/// compensation, as `hystid identify` does it.
fn reduce_swept(rec: &Recording, opts: &SweepOptions) -> (NonlinearFrf, f64) {
    let r = rec.reference_channel().unwrap();
    let sigma = choose_compensation(
        &mut common::pair(&rec.channels[r], &rec.channels[1], rec.meta.sample_rate_hz),
        0,
        1,
        opts,
    )
    .unwrap();
    let red = reduce_sweep(
        &mut common::pair(&rec.channels[r], &rec.channels[1], rec.meta.sample_rate_hz),
        0,
        1,
        &SweepOptions {
            compensation_s: Some(sigma),
            ..opts.clone()
        },
    )
    .unwrap();
    (
        red.into_frf(rec.meta.channels[1].quantity, rec.meta.channels[r].quantity),
        sigma,
    )
}

fn levels_of(sets: &[NonlinearFrf]) -> NonlinearFrf {
    let mut out = sets[0].clone();
    out.levels = sets.iter().flat_map(|f| f.levels.clone()).collect();
    out
}

fn import_swept(path: &Path, spec: ImportSpec) -> Recording {
    let mut spec = spec;
    spec.excitation = Some(Excitation {
        kind: ExcitationKind::SweptSine,
        ..Default::default()
    });
    let imported = import(path, &spec).unwrap();
    assert!(!imported.quality.has_errors(), "{}", imported.quality);
    imported.recording
}

/// The model of a fit without its element: the smallest level's SDOF.
fn linear_model(fit: &FitResult) -> Model {
    let s = &fit.linear.stick;
    Model::new(
        ModalModel::sdof(s.mass, s.damping, s.stiffness).unwrap(),
        Vec::new(),
    )
    .unwrap()
}

fn swept_validation(
    model: &Model,
    sign: f64,
    rec: &Recording,
    opts: &SweepOptions,
    band: (f64, f64),
) -> Validation {
    let r = rec.reference_channel().unwrap();
    let sigma = choose_compensation(
        &mut common::pair(&rec.channels[r], &rec.channels[1], rec.meta.sample_rate_hz),
        0,
        1,
        opts,
    )
    .unwrap();
    validate_recording(
        model,
        sign,
        rec,
        1,
        &ValidateOptions {
            band_hz: Some(band),
            reduction: Some(Reduction::Swept(SweepOptions {
                compensation_s: Some(sigma),
                ..opts.clone()
            })),
            ..ValidateOptions::default()
        },
        &hystid::observe::Silent,
    )
    .unwrap()
}

/// The F-16 GVT benchmark (Noël & Schoukens 2017): fit a single-mode model
/// plus Masing joint to the torsion mode of levels 1, 3, 5, 7 (acceleration
/// 2 per force, linear start from level 1), validate by simulation on the
/// unseen levels 2, 4, 6.
///
/// Checks: the level-1 torsion mode at 7.3 ± 0.05 Hz (README: 7.323 Hz),
/// both from the reduced FRF's peak and from the fitted level-1 SDOF; on
/// each validation level the |H1| peak of the simulated response within
/// 0.05 Hz of the measured one (both reduced the same way); e_RMS of the
/// fitted model below that of the linear level-1 model, over the whole
/// record and over the torsion window (sweep between 6.4 and 8.3 Hz).
#[test]
fn f16_fit_on_odd_levels_validates_on_even_ones() {
    let Some(dir) = common::dataset("f16_gvt_benchmark") else {
        return;
    };
    let t0 = std::time::Instant::now();
    let spec = ImportSpec::new(
        vec![
            ChannelSpec::new("Force", Quantity::Force).name("force"),
            ChannelSpec::new("Acceleration", Quantity::Acceleration)
                .row(2)
                .name("acc2"),
        ],
        SampleRateSource::Variable("Fs".into()),
    );
    let file = |l: &str| dir.join(format!("BenchmarkData/F16Data_SineSw_Level{l}.mat"));
    let sweep = SweepOptions {
        max_harmonic: 3,
        hop_periods: 4.0,
        ..SweepOptions::default()
    };
    let mut sets = Vec::new();
    for l in ["1", "3", "5", "7"] {
        let rec = import_swept(&file(l), spec.clone());
        let (frf, sigma) = reduce_swept(&rec, &sweep);
        eprintln!(
            "F-16 level {l}: {:.2} N, compensation {sigma:.2} s",
            frf.levels[0].level
        );
        sets.push(frf);
    }
    let frf = levels_of(&sets);
    let peak1 = h1_peak(&frf.levels[0].points, Some((6.4, 8.3))).unwrap();
    let t_reduce = t0.elapsed();
    let options = FitOptions {
        linear_start: LinearStart::Lowest,
        band_hz: Some((6.9, 7.6)),
        ..FitOptions::default()
    };
    let fit = identify(&frf, &options, &HbPredictor::default(), None).unwrap();
    let f1 = fit.linear.stick.natural_frequency_hz();
    eprintln!(
        "F-16: level-1 peak {:.4} Hz, level-1 SDOF {f1:.4} Hz (zeta {:.3} %); fit relative error {:.4}, {} evaluations, {:.1} s; {:?}",
        peak1.frequency_hz,
        100.0 * fit.linear.stick.damping_ratio(),
        fit.error.relative,
        fit.effort.evaluations,
        fit.effort.seconds,
        fit.model
    );
    assert!((peak1.frequency_hz - 7.3).abs() <= 0.05);
    assert!((f1 - 7.3).abs() <= 0.05);
    let linear = linear_model(&fit);
    let mut table = Vec::new();
    for l in ["2_Validation", "4_Validation", "6_Validation"] {
        let rec = import_swept(&file(l), spec.clone());
        let band = (6.4, 8.3);
        let v = swept_validation(&fit.model, fit.response_sign, &rec, &sweep, band);
        let vl = swept_validation(&linear, fit.linear.stick.sign, &rec, &sweep, band);
        let c = &v.frf.as_ref().unwrap().levels[0];
        let (pm, ps) = (c.measured_peak.unwrap(), c.simulated_peak.unwrap());
        let (w, wl) = (v.window.unwrap(), vl.window.unwrap());
        eprintln!(
            "F-16 level {l} ({:.2} N): peak measured {:.4} Hz, simulated {:.4} Hz (linear model {:.4} Hz); \
             e_RMS whole {:.4e} ({:.1} % of the RMS; linear {:.4e}) m/s², torsion window {:.1}-{:.1} s {:.4e} (linear {:.4e}); \
             H1 error {:.1} % (linear {:.1} %)",
            c.level,
            pm.frequency_hz,
            ps.frequency_hz,
            vl.frf.as_ref().unwrap().levels[0]
                .simulated_peak
                .unwrap()
                .frequency_hz,
            v.whole.e_rms,
            100.0 * v.whole.relative,
            vl.whole.e_rms,
            w.start_s,
            w.end_s,
            w.e_rms,
            wl.e_rms,
            100.0 * c.relative_h1_error,
            100.0 * vl.frf.as_ref().unwrap().levels[0].relative_h1_error
        );
        assert!(
            (ps.frequency_hz - pm.frequency_hz).abs() <= 0.05,
            "level {l}"
        );
        assert!(v.whole.e_rms < vl.whole.e_rms, "level {l}");
        assert!(w.e_rms < wl.e_rms, "level {l}");
        table.push((
            l,
            [
                ("level (N)", c.level),
                ("measured peak (Hz)", pm.frequency_hz),
                ("simulated peak (Hz)", ps.frequency_hz),
                ("e_RMS of the fitted model", v.whole.e_rms),
                ("its share of the RMS (%)", 100.0 * v.whole.relative),
                ("e_RMS of the linear model", vl.whole.e_rms),
            ],
        ));
    }
    // the validation pages' validation table, as printed (after every row is printed)
    for (l, figures) in table {
        let row = common::pinned_figures(&format!("| {} (", &l[..1])).expect("pinned figures");
        assert_eq!(row.len(), figures.len(), "pinned F-16 row {l}: {row:?}");
        for ((what, value), shown) in figures.into_iter().zip(row) {
            common::assert_pinned_figure(&format!("F-16 level {l}: {what}"), value, shown);
        }
    }
    eprintln!("F-16: reductions {t_reduce:?}, all {:?}", t0.elapsed());
}

/// The UNESP bolted beam's 70-110 Hz chirps (voltage drive, laser velocity,
/// mode 2 near 91-96 Hz): fit a single mode plus Masing joint per volt on
/// 0.05, 0.15 and 0.25 V, validate on 0.10, 0.20 and 0.30 V. The data set's
/// own FRF peaks (Test.Lab's H1 at 0.0625 Hz resolution, in its
/// `summary_chirp_frf_peaks.csv`) must be matched by the reduced FRFs
/// within 0.5 Hz (the sweep distortion at 5 Hz/s moves a chirp's peak), and
/// the joint model's e_RMS must beat the linear (0.05 V) model's on every
/// validation level. The validation pages' table of the chirps is pinned.
#[test]
fn unesp_chirps_fit_and_validate() {
    let Some(dir) = common::dataset("bolted_beam_unesp_bert") else {
        return;
    };
    let t0 = std::time::Instant::now();
    let spec = ImportSpec::new(
        vec![
            ChannelSpec::new("shaker_amp_V", Quantity::Voltage).name("drive"),
            ChannelSpec::new("laser_velocity_m_per_s", Quantity::Velocity).name("laser"),
        ],
        SampleRateSource::Comment,
    );
    let file = |l: &str| dir.join(format!("csv/chirp_70to110Hz_{l}V_time.csv"));
    // the data set's peaks of mode 2 (sweep range 2), by level
    let summary = std::fs::read_to_string(dir.join("csv/summary_chirp_frf_peaks.csv"))
        .expect("summary_chirp_frf_peaks.csv");
    let test_lab = |l: &str| -> f64 {
        let volts: f64 = l.replace('p', ".").parse().unwrap();
        summary
            .lines()
            .filter(|r| !r.starts_with('#'))
            .filter_map(|r| {
                let c: Vec<f64> = r.split(',').filter_map(|v| v.parse().ok()).collect();
                (c.len() == 4 && c[0] == 2.0 && (c[1] - volts).abs() < 1e-9).then(|| c[2])
            })
            .next()
            .unwrap_or_else(|| panic!("no Test.Lab peak for {l} V"))
    };
    let pinned_row = |l: &str, role: &str| {
        let volts = l.replace('p', ".");
        common::pinned_figures(&format!("| {volts} V | {role} |"))
            .unwrap_or_else(|| panic!("pinned UNESP row {volts} V"))
    };
    let sweep = SweepOptions {
        max_harmonic: 3,
        hop_periods: 8.0,
        ..SweepOptions::default()
    };
    let mut sets = Vec::new();
    let mut table = Vec::new();
    for l in ["0p05", "0p15", "0p25"] {
        let rec = import_swept(&file(l), spec.clone());
        let (frf, sigma) = reduce_swept(&rec, &sweep);
        let p = h1_peak(&frf.levels[0].points, Some((85.0, 102.0))).unwrap();
        let reference = test_lab(l);
        eprintln!(
            "UNESP chirp {l}: {:.4} V, compensation {sigma:.3} s, peak {:.3} Hz (Test.Lab {reference} Hz), |H1| {:.3}",
            frf.levels[0].level, p.frequency_hz, p.magnitude
        );
        assert!((p.frequency_hz - reference).abs() < 0.5, "{l}");
        table.push((
            l,
            "fit",
            vec![("peak", p.frequency_hz), ("Test.Lab peak", reference)],
        ));
        sets.push(frf);
    }
    let frf = levels_of(&sets);
    let options = FitOptions {
        linear_start: LinearStart::Lowest,
        band_hz: Some((88.0, 100.0)),
        ..FitOptions::default()
    };
    let fit = identify(&frf, &options, &HbPredictor::default(), None).unwrap();
    eprintln!(
        "UNESP fit: relative error {:.4}, sign {}, {} evaluations in {:.1} s; {:?}",
        fit.error.relative,
        fit.response_sign,
        fit.effort.evaluations,
        fit.effort.seconds,
        fit.model
    );
    let linear = linear_model(&fit);
    for l in ["0p10", "0p20", "0p30"] {
        let rec = import_swept(&file(l), spec.clone());
        let v = swept_validation(&fit.model, fit.response_sign, &rec, &sweep, (88.0, 100.0));
        let vl = swept_validation(&linear, fit.linear.stick.sign, &rec, &sweep, (88.0, 100.0));
        let c = &v.frf.as_ref().unwrap().levels[0];
        let (pm, ps) = (c.measured_peak.unwrap(), c.simulated_peak.unwrap());
        let reference = test_lab(l);
        eprintln!(
            "UNESP chirp {l}: x{} upsampled; e_RMS {:.4e} m/s ({:.1} %), linear {:.4e} ({:.1} %); peak measured {:.3} Hz (Test.Lab {reference} Hz), simulated {:.3} Hz",
            v.upsampling,
            v.whole.e_rms,
            100.0 * v.whole.relative,
            vl.whole.e_rms,
            100.0 * vl.whole.relative,
            pm.frequency_hz,
            ps.frequency_hz
        );
        assert!(v.whole.e_rms < vl.whole.e_rms, "{l}");
        assert!((pm.frequency_hz - reference).abs() < 0.5, "{l}");
        table.push((
            l,
            "validation",
            vec![
                ("peak", pm.frequency_hz),
                ("Test.Lab peak", reference),
                ("simulated peak", ps.frequency_hz),
                (
                    "e_RMS of the fitted model (% of the RMS)",
                    100.0 * v.whole.relative,
                ),
                (
                    "e_RMS of the linear model (% of the RMS)",
                    100.0 * vl.whole.relative,
                ),
            ],
        ));
    }
    eprintln!("UNESP: {:?}", t0.elapsed());
    // the validation pages' table of the chirps, as printed (after every row is printed)
    let shown = common::pinned_figures("The fit's relative FRF error on the fitted chirps is")
        .expect("pinned figures");
    common::assert_pinned_figure("UNESP fit error (%)", 100.0 * fit.error.relative, shown[0]);
    for (l, role, figures) in table {
        let row = pinned_row(l, role);
        assert_eq!(row.len(), figures.len(), "pinned UNESP row {l}: {row:?}");
        for ((what, value), shown) in figures.into_iter().zip(row) {
            common::assert_pinned_figure(&format!("UNESP {l} V: {what}"), value, shown);
        }
    }
}

/// The Bouc-Wen benchmark's sine-sweep test set (40 N, 18-52 Hz,
/// displacement). Its estimation data are multisines, which a sine-based
/// identification cannot use, so the fit takes the 34-48 Hz part of the
/// test sweep's own reduced FRF: one level, given twice (the fit needs a
/// smallest and a largest level; with one, the element is fitted to the
/// amplitude variation along the FRF, the model driven at each point's
/// measured force), and the model is validated on the whole sweep. hystid's
/// elements soften on loading and unloading alike, while this Bouc-Wen
/// (γ + δ < 0) stiffens, so the e_RMS is far above the true model's floor of
/// about 1e-6 m (data set README); it must still capture the resonance:
/// below a third of the response RMS.
#[test]
fn boucwen_sweep_validation() {
    let Some(dir) = common::dataset("boucwen_benchmark") else {
        return;
    };
    let t0 = std::time::Instant::now();
    let spec = ImportSpec::new(
        vec![
            ChannelSpec::new("uval_sinesweep", Quantity::Force).name("force"),
            ChannelSpec::new("yval_sinesweep", Quantity::Displacement).name("y"),
        ],
        SampleRateSource::Value(750.0),
    );
    let rec = import_swept(&dir.join("bouc-wen.mat"), spec);
    let sweep = SweepOptions {
        max_harmonic: 3,
        hop_periods: 32.0,
        ..SweepOptions::default()
    };
    let (frf, sigma) = reduce_swept(&rec, &sweep);
    let level = frf.levels[0].clone();
    let twice = NonlinearFrf {
        levels: vec![level.clone(), level],
        ..frf
    };
    assert_eq!(twice.levels[0].direction, Direction::Up);
    let options = FitOptions {
        band_hz: Some((34.0, 48.0)),
        ..FitOptions::default()
    };
    let fit = identify(&twice, &options, &HbPredictor::default(), None).unwrap();
    let band = (34.0, 48.0);
    let v = swept_validation(&fit.model, fit.response_sign, &rec, &sweep, band);
    let vl = swept_validation(&linear_model(&fit), 1.0, &rec, &sweep, band);
    eprintln!(
        "Bouc-Wen sweep: compensation {sigma:.3} s; fitted {:?}; e_RMS {:.4e} m ({:.1} % of {:.4e} m; {:.0}x the 1e-6 m floor), \
         linear {:.4e} m; H1 error {:.1} %; {:?}",
        fit.model,
        v.whole.e_rms,
        100.0 * v.whole.relative,
        v.whole.measured_rms,
        v.whole.e_rms / 1e-6,
        vl.whole.e_rms,
        100.0 * v.frf.as_ref().unwrap().levels[0].relative_h1_error,
        t0.elapsed()
    );
    let shown =
        common::pinned_figures("Masing joint on the Bouc-Wen sweep:").expect("pinned figures");
    for ((what, value), shown) in [
        ("e_RMS", v.whole.e_rms),
        ("its share of the RMS (%)", 100.0 * v.whole.relative),
        (
            "H1 error (%)",
            100.0 * v.frf.as_ref().unwrap().levels[0].relative_h1_error,
        ),
        ("the linear model's e_RMS", vl.whole.e_rms),
    ]
    .into_iter()
    .zip(shown)
    {
        common::assert_pinned_figure(&format!("Bouc-Wen sweep, Masing: {what}"), value, shown);
    }
    assert!(v.whole.e_rms > 1e-6);
    assert!(v.whole.relative < 1.0 / 3.0);
}

/// The Bouc-Wen benchmark's published model (Noël & Schoukens 2016) as a
/// structure with the `bouc_wen` joint.
fn published_bouc_wen() -> Model {
    hystid::testbench::model_from_toml(
        "[system]\nmass = 2.0\ndamping = 10.0\nstiffness = 5.0e4\n\
         [joint]\nkind = \"bouc_wen\"\nalpha = 5.0e4\nbeta = 1.0e3\ngamma = 0.8\ndelta = -1.1\nnu = 1.0\n",
        "bouc-wen.toml",
    )
    .unwrap()
}

/// The RMS of `a − b` from sample `from` on.
fn rms_from(a: &[f64], b: &[f64], from: usize) -> f64 {
    (a[from..]
        .iter()
        .zip(&b[from..])
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        / (a.len() - from) as f64)
        .sqrt()
}

/// The Bouc-Wen benchmark's channels `u`, `y` at 750 Hz.
fn boucwen_channels(u: &str, y: &str) -> ImportSpec {
    ImportSpec::new(
        vec![
            ChannelSpec::new(u, Quantity::Force).name("force"),
            ChannelSpec::new(y, Quantity::Displacement).name("y"),
        ],
        SampleRateSource::Value(750.0),
    )
}

/// The benchmark's test sets: the sine sweep, and the multisine's
/// steady-state period played twice (with its length).
fn boucwen_test_sets(dir: &Path) -> (Recording, Recording, usize) {
    let mat = dir.join("bouc-wen.mat");
    let sweep = import_swept(&mat, boucwen_channels("uval_sinesweep", "yval_sinesweep"));
    let mut multisine = import(&mat, &boucwen_channels("uval_multisine", "yval_multisine"))
        .unwrap()
        .recording;
    let period = multisine.channels[0].len();
    for c in &mut multisine.channels {
        let once = c.clone();
        c.extend_from_slice(&once);
    }
    (sweep, multisine, period)
}

/// The Bouc-Wen benchmark's continuous equations, `m y'' + c y' + k y + z =
/// u`, `z' = α y' − β (γ |y'| z + δ y' |z|)` (ν = 1), by classical RK4 at
/// `sub` steps per sample, the force between samples by Catmull-Rom cubic
/// interpolation, from rest: a slow reference that shares nothing with the
/// digital-filter simulator.
fn boucwen_rk4(u: &[f64], fs: f64, sub: usize) -> Vec<f64> {
    boucwen_rk4_fine(u, fs, sub)
        .into_iter()
        .step_by(sub)
        .collect()
}

/// [`boucwen_rk4`]'s displacement at every one of its steps (`sub` a
/// sample).
fn boucwen_rk4_fine(u: &[f64], fs: f64, sub: usize) -> Vec<f64> {
    let (m, c, k, alpha, beta, gamma, delta) = (2.0, 10.0, 5e4, 5e4, 1e3, 0.8, -1.1);
    let at = |i: isize| u[i.clamp(0, u.len() as isize - 1) as usize];
    let force = |t: f64| {
        let i = t.floor() as isize;
        let s = t - i as f64;
        let (p0, p1, p2, p3) = (at(i - 1), at(i), at(i + 1), at(i + 2));
        p1 + 0.5
            * s
            * (p2 - p0
                + s * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + s * (3.0 * (p1 - p2) + p3 - p0)))
    };
    let deriv = |x: [f64; 3], uu: f64| {
        let [y, v, z] = x;
        [
            v,
            (uu - c * v - k * y - z) / m,
            alpha * v - beta * (gamma * v.abs() * z + delta * v * z.abs()),
        ]
    };
    let h = 1.0 / (fs * sub as f64);
    let add =
        |x: [f64; 3], d: [f64; 3], s: f64| [x[0] + s * d[0], x[1] + s * d[1], x[2] + s * d[2]];
    let mut x = [0.0; 3];
    let mut out = Vec::with_capacity(u.len() * sub);
    for n in 0..u.len() {
        for j in 0..sub {
            out.push(x[0]);
            let t = n as f64 + j as f64 / sub as f64;
            let dt = 1.0 / sub as f64;
            let k1 = deriv(x, force(t));
            let k2 = deriv(add(x, k1, 0.5 * h), force(t + 0.5 * dt));
            let k3 = deriv(add(x, k2, 0.5 * h), force(t + 0.5 * dt));
            let k4 = deriv(add(x, k3, h), force(t + dt));
            for i in 0..3 {
                x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
    }
    out
}

/// The benchmark's published model (Noël & Schoukens 2016), written down as
/// a structure with the `bouc_wen` joint and driven by the benchmark's
/// test-set forces, reaches the floor of the data themselves. The multisine
/// test set is one period of a periodic steady state: played twice, the
/// second period compared (the benchmark's protocol). The floor is the RK4
/// reference's distance from the data: on the sine sweep 2.5e-6 m (the data
/// and an accurate simulation of the published model part near the
/// resonance; the data set's pinned compared only the first 40 s), on the
/// multisine 5.8e-7 m. Measured: e_RMS 2.57e-6 m on the sweep (hystid
/// 1.2e-7 m from the reference), 4.1e-7 m on the multisine.
#[test]
fn boucwen_published_model_reaches_the_floor() {
    let Some(dir) = common::dataset("boucwen_benchmark") else {
        return;
    };
    let t0 = std::time::Instant::now();
    let model = published_bouc_wen();
    let (sweep, multisine, period) = boucwen_test_sets(&dir);
    let second = (period as f64 / 750.0, 2.0 * period as f64 / 750.0);
    for (name, rec, window, from) in [
        ("sine sweep", &sweep, None, 0),
        ("multisine", &multisine, Some(second), period),
    ] {
        let v = validate_recording(
            &model,
            1.0,
            rec,
            1,
            &ValidateOptions {
                min_samples_per_period: 400.0,
                window_s: window,
                ..ValidateOptions::default()
            },
            &hystid::observe::Silent,
        )
        .unwrap();
        let e = v.window.as_ref().unwrap_or(&v.whole);
        let reference = boucwen_rk4(&rec.channels[0], 750.0, 40);
        let data_vs_reference = rms_from(&rec.channels[1], &reference, from);
        let hystid_vs_reference = rms_from(&v.simulated, &reference, from);
        eprintln!(
            "Bouc-Wen {name} (x{} upsampled): e_RMS {:.3e} m ({:.3} % of {:.3e} m); RK4 reference vs data {:.3e} m, vs hystid {:.3e} m",
            v.upsampling,
            e.e_rms,
            100.0 * e.relative,
            e.measured_rms,
            data_vs_reference,
            hystid_vs_reference
        );
        let row = common::pinned_figures(match name {
            "sine sweep" => "| sine sweep (204 s, 40 N) |",
            _ => "| multisine (the steady-state period, played twice, the second compared) |",
        })
        .expect("pinned figures");
        for ((what, value), shown) in [
            ("hystid's e_RMS", e.e_rms),
            ("its share of the RMS (%)", 100.0 * e.relative),
            ("the RK4 reference vs the data", data_vs_reference),
            ("hystid vs the reference", hystid_vs_reference),
        ]
        .into_iter()
        .zip(row)
        {
            common::assert_pinned_figure(&format!("Bouc-Wen {name}: {what}"), value, shown);
        }
        // within 10 % of the floor the data leave to an accurate simulation
        assert!(
            e.e_rms <= 1.1 * data_vs_reference.max(1e-6),
            "{name}: e_RMS {:e} m",
            e.e_rms
        );
        // where the reference's input interpolation is accurate (the sweep,
        // at 14-42 samples per period; the multisine's lines reach fs/5,
        // where the reference's cubic and hystid's pre-emphasis part by
        // about 6e-7 m), hystid is closer to the reference than to the data
        if window.is_none() {
            assert!(
                hystid_vs_reference <= 0.2 * data_vs_reference,
                "{name}: {hystid_vs_reference:e} m from the reference"
            );
        }
    }
    eprintln!("{:?}", t0.elapsed());
}

/// The benchmark's sine-sweep test set was decimated from its integration
/// rate (15 kHz) by MATLAB's `decimate(y, 20, 'fir')`, whose 31-tap FIR
/// takes 0.42 % off the response at its 41 Hz resonance; its multisine test
/// set by three such stages (2, 2, 5), flatter. A reference that shares
/// nothing with hystid (the RK4 of [`boucwen_rk4`] at the integration rate,
/// put through that FIR at 15 kHz, delay compensated, its ends reflected as
/// `decimate` reflects them, then every 20th sample) is the sweep test set
/// within 2e-7 m, where the same RK4 without the FIR is 2.5e-6 m off. The
/// published model validated with the chain declared (`[acquisition]
/// decimated_by = 20`, resp. `[2, 2, 5]`) is within the physics issue's
/// 2e-6 m on both test sets, and as close to the data as that reference.
#[test]
fn boucwen_published_model_through_the_test_sets_acquisition_is_within_2e_6() {
    use hystid::validate::acquisition::{Acquisition, lowpass};
    let Some(dir) = common::dataset("boucwen_benchmark") else {
        return;
    };
    let model = published_bouc_wen();
    let (sweep, multisine, period) = boucwen_test_sets(&dir);
    // the reference: RK4 at 15 kHz through `decimate(y, 20, 'fir')`
    let fine = boucwen_rk4_fine(&sweep.channels[0], 750.0, 20);
    let b = lowpass(31, 1.0 / 20.0);
    let n = fine.len() as isize;
    let ext = |i: isize| {
        if i < 0 {
            2.0 * fine[0] - fine[(-i) as usize]
        } else if i >= n {
            2.0 * fine[(n - 1) as usize] - fine[(2 * (n - 1) - i) as usize]
        } else {
            fine[i as usize]
        }
    };
    let decimated: Vec<f64> = (0..sweep.channels[1].len() as isize)
        .map(|k| (0..31).map(|j| b[j] * ext(20 * k + j as isize - 15)).sum())
        .collect();
    let plain: Vec<f64> = fine.iter().step_by(20).copied().collect();
    let (reference, unfiltered) = (
        rms_from(&decimated, &sweep.channels[1], 0),
        rms_from(&plain, &sweep.channels[1], 0),
    );
    eprintln!(
        "RK4 at 15 kHz vs the sweep test set: {unfiltered:.3e} m as integrated, {reference:.3e} m through the test set's decimation"
    );
    assert!(
        unfiltered > 2e-6 && reference < 2e-7,
        "{unfiltered:e} {reference:e}"
    );
    let second = (period as f64 / 750.0, 2.0 * period as f64 / 750.0);
    let mut figures = Vec::new();
    for (name, rec, window, chain) in [
        ("sine sweep", &sweep, None, vec![20]),
        ("multisine", &multisine, Some(second), vec![2, 2, 5]),
    ] {
        let v = validate_recording(
            &model,
            1.0,
            rec,
            1,
            &ValidateOptions {
                min_samples_per_period: 400.0,
                window_s: window,
                acquisition: Some(Acquisition {
                    decimated_by: chain,
                    taps: 31,
                }),
                ..ValidateOptions::default()
            },
            &hystid::observe::Silent,
        )
        .unwrap();
        let e = v.window.as_ref().unwrap_or(&v.whole);
        eprintln!(
            "Bouc-Wen {name} through its acquisition: e_RMS {:.3e} m ({:.3} %)",
            e.e_rms,
            100.0 * e.relative
        );
        assert!(e.e_rms <= 2e-6, "{name}: {:e}", e.e_rms);
        if window.is_none() {
            // twenty times closer than any simulation without the chain, and
            // as close to the reference through it as hystid is to the
            // reference without it (its own discretisation, 1.2e-7 m)
            let from_reference = rms_from(&v.simulated, &decimated, 0);
            eprintln!("  hystid vs the reference through the decimation: {from_reference:.3e} m");
            assert!(e.e_rms <= 0.05 * unfiltered, "{name}: {:e}", e.e_rms);
            assert!(from_reference < 1.5e-7, "{name}: {from_reference:e}");
        }
        figures.push((name, e.e_rms, 100.0 * e.relative));
    }
    let shown = common::pinned_figures("The published model through the test sets' acquisition:")
        .expect("pinned figures");
    let all: Vec<(&str, f64)> = [
        ("RK4 at 15 kHz as integrated", unfiltered),
        ("through the decimation", reference),
    ]
    .into_iter()
    .chain(figures.iter().map(|&(name, e, _)| (name, e)))
    .chain(figures.iter().map(|&(name, _, percent)| (name, percent)))
    .collect();
    assert_eq!(shown.len(), all.len(), "{shown:?}");
    for ((what, value), shown) in all.into_iter().zip(shown) {
        common::assert_pinned_figure(what, value, shown);
    }
}

/// `periodic`: one period of a steady state, against the closed form. A
/// linear SDOF (20 Hz, 2 %) driven by 25 whole cycles of a 25 Hz sine in a
/// 1 s record: the periodic validation compares the settled response with
/// the analytic steady state `|H| sin(ωt + φ)` and leaves only the
/// simulator's discretisation; from rest, the transient (decaying at
/// ζω = 2.5/s, as slow as the record) stays in the error.
#[test]
fn periodic_validation_is_the_steady_state() {
    let (m, f0, zeta) = (1.0, 20.0, 0.02);
    let k = m * omega(f0).powi(2);
    let c = 2.0 * zeta * (k * m).sqrt();
    let model = Model::new(ModalModel::sdof(m, c, k).unwrap(), Vec::new()).unwrap();
    let (fs, f) = (1000.0, 25.0);
    let w = omega(f);
    let h = 1.0 / Complex64::new(k - m * w * w, c * w);
    let t = |i: usize| i as f64 / fs;
    let force: Vec<f64> = (0..1000).map(|i| (w * t(i)).sin()).collect();
    let steady: Vec<f64> = (0..1000)
        .map(|i| h.norm() * (w * t(i) + h.arg()).sin())
        .collect();
    let rec = recording(
        fs,
        force,
        steady,
        Quantity::Displacement,
        ExcitationKind::Unknown,
    );
    let relative = |periodic: bool| {
        validate_recording(
            &model,
            1.0,
            &rec,
            1,
            &ValidateOptions {
                periodic,
                ..ValidateOptions::default()
            },
            &hystid::observe::Silent,
        )
        .unwrap()
        .whole
        .relative
    };
    let (settled, from_rest) = (relative(true), relative(false));
    eprintln!("periodic {settled:.3e}, from rest {from_rest:.3e}");
    // the discretisation at 40 samples a period (6.5e-6 measured)
    assert!(settled < 5e-5, "periodic: {settled}");
    assert!(from_rest > 20.0 * settled, "from rest: {from_rest}");
}
