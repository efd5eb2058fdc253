//! `hystid identify-points` through the binary: a three-mass chain with a
//! Jenkins joint between its second and third masses, simulated in the
//! time domain by the digital-filter method, recorded at three
//! accelerometers, fitted by harmonic balance.

use crate::cli::{hystid, text};
use hystid::harmonics::Quantity;
use hystid::model::{Jenkins, Lumped};
use hystid::record::{
    Channel, Excitation, ExcitationKind, Recording, RecordingMeta, SampleFormat, Step,
    write_recording,
};
use hystid::sim::PointSimulator;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use serde_json::Value;
use std::f64::consts::PI;
use std::path::Path;

const KD: f64 = 4.0e4;
const FD: f64 = 4.0;

/// ground - m1 - m2 - m3, 1 kg and 4e4 N/m each, Rayleigh damping: modes
/// at 14.2, 39.7 and 57.4 Hz.
fn chain() -> Lumped {
    Lumped {
        points: vec!["a1".into(), "a2".into(), "a3".into()],
        masses: vec![1.0; 3],
        springs: vec![(0, None, 4.0e4), (0, Some(1), 4.0e4), (1, Some(2), 4.0e4)],
        alpha: 8.0,
        beta: 5.0e-5,
    }
}

/// A stepped sine at four levels over 10-80 Hz, driven at m1, the joint
/// between m2 and m3, each accelerometer with 1 % noise (seeded), written
/// as `chain.wav` + `chain.json`.
fn record_chain(dir: &Path) -> std::path::PathBuf {
    let fs = 2048.0;
    let (settle, dwell, lines) = ((2.0 * fs) as usize, (3.5 * fs) as usize, 32);
    let (mut force, mut steps, mut phase) = (Vec::new(), Vec::new(), 0.0_f64);
    for level in [0.5, 1.5, 3.0, 6.0] {
        for l in 0..lines {
            let f = 10.0 + 70.0 * l as f64 / (lines - 1) as f64;
            steps.push(Step {
                frequency_hz: f,
                level,
                start: force.len(),
                settle,
                length: dwell,
            });
            for _ in 0..dwell {
                force.push(level * phase.cos());
                phase = (phase + 2.0 * PI * f / fs) % (2.0 * PI);
            }
        }
    }
    let structure = chain().modes().unwrap();
    let joint = Jenkins::new(KD, FD).unwrap();
    let mut sim = PointSimulator::new(&structure, 0, (1, Some(2)), joint, fs).unwrap();
    let mut accel = sim.run(&force).unwrap().acceleration;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(71);
    for a in &mut accel {
        let rms = (a.iter().map(|v| v * v).sum::<f64>() / a.len() as f64).sqrt();
        for v in a.iter_mut() {
            let n: f64 = StandardNormal.sample(&mut rng);
            *v += 0.01 * rms * n;
        }
    }
    let channel = |name: &str, quantity: Quantity, unit: &str| Channel {
        name: name.into(),
        quantity,
        unit: unit.into(),
        scale: 1.0,
    };
    let mut channels = vec![channel("force", Quantity::Force, "N")];
    channels.extend((1..=3).map(|p| channel(&format!("a{p}"), Quantity::Acceleration, "m/s^2")));
    let excitation = Excitation {
        kind: ExcitationKind::SteppedSine,
        steps,
        sweep: None,
    };
    let mut all = vec![force];
    all.extend(accel);
    let rec = Recording {
        meta: RecordingMeta::new(fs, channels, excitation),
        channels: all,
    };
    let path = dir.join("chain.json");
    write_recording(&path, &rec, SampleFormat::Float32).unwrap();
    path
}

/// The joint declared across a2-a3 comes back within 1 % in `kd` and `fd`
/// (the fit is harmonic balance, the recording a time-domain simulation
/// with 1 % noise), and every sensor's FRF error at every level is below
/// 1 % (the noise, averaged over each dwell, and the two methods' difference); `points.json`, `points.md` and a figure per sensor are written.
#[test]
fn identify_points_finds_a_joint_between_two_sensors() {
    let dir = tempfile::tempdir().unwrap();
    let rec = record_chain(dir.path());
    let out = dir.path().join("out");
    let o = hystid(&[
        "identify-points",
        rec.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--responses",
        "a1,a2,a3",
        "--joint",
        "a2:a3",
        "--law",
        "jenkins",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("points.json")).unwrap()).unwrap();
    let value = |name: &str| {
        report["joint"]["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p[0] == name)
            .unwrap()[1]
            .as_f64()
            .unwrap()
    };
    let (kd, fd) = (value("kd"), value("fd"));
    eprintln!("{}\nkd {kd:.5e}, fd {fd:.5e}", text(&o));
    assert!((kd / KD - 1.0).abs() < 0.01, "kd {kd}");
    assert!((fd / FD - 1.0).abs() < 0.01, "fd {fd}");
    let errors = report["errors"].as_array().unwrap();
    assert_eq!(errors.len(), 12);
    for e in errors {
        assert!(e["frf_error_percent"].as_f64().unwrap() < 1.0, "{e}");
    }
    for f in [
        "points.md",
        "points_a1.png",
        "points_a2.png",
        "points_a3.png",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
}

/// A joint naming a channel that is not a response is refused before any
/// work, naming the flag, with exit code 2 and no output folder.
#[test]
fn identify_points_refuses_a_joint_at_an_unknown_sensor() {
    let dir = tempfile::tempdir().unwrap();
    let rec = record_chain(dir.path());
    let out = dir.path().join("out");
    let o = hystid(&[
        "identify-points",
        rec.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--responses",
        "a1,a2,a3",
        "--joint",
        "a2:a4",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let said = text(&o);
    assert!(said.contains("--joint") && said.contains("`a4`"), "{said}");
    assert!(!out.exists());
}

/// The library's reduction at every sensor is each channel's own reduction
/// (the one `identify` makes), cut to the band: the same lines at every
/// sensor, none outside the band, and no sweep reading for a stepped sine.
#[test]
fn reduce_at_sensors_is_each_channels_reduction_cut_to_the_band() {
    use hystid::analysis::points::{PointsRequest, reduce_at_sensors};
    use hystid::analysis::recording::{ChannelChoice, ReductionOptions, reduce_path};
    let dir = tempfile::tempdir().unwrap();
    let rec = record_chain(dir.path());
    let request = PointsRequest {
        responses: ["a1", "a2", "a3"].map(String::from).to_vec(),
        drive: "a1".into(),
        joint: "a2:a3".into(),
        law: "jenkins".into(),
        band_hz: Some("20:60".into()),
        modes: 3,
        ..PointsRequest::default()
    };
    let (frfs, sweep) = reduce_at_sensors(&rec, &request).unwrap();
    assert!(sweep.is_none());
    assert_eq!(frfs.len(), 3);
    for (frf, name) in frfs.iter().zip(["a1", "a2", "a3"]) {
        let own = reduce_path(
            &rec,
            ChannelChoice::response(Some(name)),
            &ReductionOptions::default(),
            &hystid::observe::Silent,
        )
        .unwrap()
        .frf;
        assert_eq!(frf.levels.len(), 4, "{name}");
        for (cut, whole) in frf.levels.iter().zip(&own.levels) {
            let inside: Vec<_> = whole
                .points
                .iter()
                .filter(|p| (20.0..=60.0).contains(&p.frequency_hz))
                .collect();
            // 32 lines over 10-80 Hz, 2.26 Hz apart: 18 inside 20-60 Hz
            assert_eq!(cut.points.len(), 18, "{name}");
            assert_eq!(cut.points.iter().collect::<Vec<_>>(), inside, "{name}");
        }
    }
}
