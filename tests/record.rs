//! Integration tests: record (WAV + JSON recordings, MCAP run files).

use hystid::harmonics::Quantity;
use hystid::record::{
    Channel, Excitation, ExcitationKind, FORMAT_V1, FrameSource, McapRecorder, McapRunReader,
    Recording, RecordingMeta, RecordingReader, RunInfo, SampleFormat, Step, read_recording,
    read_run, write_recording,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

// ---------------------------------------------------------------- helpers

fn channel(name: &str, quantity: Quantity, scale: f64) -> Channel {
    Channel {
        name: name.into(),
        quantity,
        unit: quantity.si_unit().into(),
        scale,
    }
}

/// A 3-channel recording: a sine force, a noisy displacement, an
/// acceleration, with two dwells.
pub(crate) fn sample_recording(frames: usize, seed: u64) -> Recording {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 1.0).unwrap();
    let fs = 8192.0;
    let force: Vec<f64> = (0..frames)
        .map(|i| 150.0 * (2.0 * std::f64::consts::PI * 64.0 * i as f64 / fs).sin())
        .collect();
    let disp: Vec<f64> = (0..frames)
        .map(|i| {
            3e-5 * (2.0 * std::f64::consts::PI * 64.0 * i as f64 / fs).cos()
                + 1e-7 * noise.sample(&mut rng)
        })
        .collect();
    let acc: Vec<f64> = (0..frames).map(|_| 4.0 * noise.sample(&mut rng)).collect();
    let half = frames / 2;
    Recording {
        meta: RecordingMeta {
            format: FORMAT_V1.into(),
            sample_rate_hz: fs,
            channels: vec![
                channel("force", Quantity::Force, 1.0),
                channel("response", Quantity::Displacement, 1.0),
                channel("accel", Quantity::Acceleration, 1.0),
            ],
            excitation: Excitation {
                kind: ExcitationKind::SteppedSine,
                steps: vec![
                    Step {
                        frequency_hz: 64.0,
                        level: 150.0,
                        start: 0,
                        settle: half / 4,
                        length: half,
                    },
                    Step {
                        frequency_hz: 65.0,
                        level: 150.0,
                        start: half,
                        settle: 0,
                        length: frames - half,
                    },
                ],
                sweep: None,
            },
            description: "test recording".into(),
            metadata: serde_json::Map::from_iter([("rig".to_string(), json!("virtual"))]),
            extra: serde_json::Map::new(),
            chosen_reference: None,
        },
        channels: vec![force, disp, acc],
    }
}

/// Minimal RIFF/WAVE writer written from the format description (not
/// hound), for checking the reader against an independent reference.
pub(crate) fn wav_bytes(
    tag: u16,
    channels: u16,
    rate: u32,
    bits: u16,
    subformat: Option<[u8; 16]>,
    extra_chunk: bool,
    data: &[u8],
) -> Vec<u8> {
    let block = channels * bits / 8;
    let mut fmt = Vec::new();
    fmt.extend_from_slice(&tag.to_le_bytes());
    fmt.extend_from_slice(&channels.to_le_bytes());
    fmt.extend_from_slice(&rate.to_le_bytes());
    fmt.extend_from_slice(&(rate * block as u32).to_le_bytes());
    fmt.extend_from_slice(&block.to_le_bytes());
    fmt.extend_from_slice(&bits.to_le_bytes());
    if let Some(guid) = subformat {
        fmt.extend_from_slice(&22u16.to_le_bytes()); // cbSize
        fmt.extend_from_slice(&bits.to_le_bytes()); // valid bits
        fmt.extend_from_slice(&0u32.to_le_bytes()); // channel mask
        fmt.extend_from_slice(&guid);
    }
    let mut body = b"WAVE".to_vec();
    body.extend_from_slice(b"fmt ");
    body.extend_from_slice(&(fmt.len() as u32).to_le_bytes());
    body.extend_from_slice(&fmt);
    if extra_chunk {
        body.extend_from_slice(b"LIST");
        body.extend_from_slice(&6u32.to_le_bytes());
        body.extend_from_slice(b"INFOab");
    }
    body.extend_from_slice(b"data");
    body.extend_from_slice(&(data.len() as u32).to_le_bytes());
    body.extend_from_slice(data);
    let mut out = b"RIFF".to_vec();
    out.extend_from_slice(&(body.len() as u32).to_le_bytes());
    out.extend_from_slice(&body);
    out
}

/// KSDATAFORMAT_SUBTYPE_PCM / _IEEE_FLOAT.
pub(crate) fn guid(kind: u8) -> [u8; 16] {
    [
        kind, 0, 0, 0, 0, 0, 0x10, 0, 0x80, 0, 0, 0xaa, 0, 0x38, 0x9b, 0x71,
    ]
}

pub(crate) fn sidecar(rate: u32, channels: &[(&str, &str, &str, f64)]) -> serde_json::Value {
    json!({
        "format": "hystid.recording.v1",
        "sample_rate_hz": rate,
        "channels": channels.iter().map(|(n, q, u, s)| json!({"name": n, "quantity": q, "unit": u, "scale": s})).collect::<Vec<_>>(),
    })
}

fn put(dir: &Path, stem: &str, wav: &[u8], json: &serde_json::Value) -> PathBuf {
    std::fs::write(dir.join(format!("{stem}.wav")), wav).unwrap();
    std::fs::write(
        dir.join(format!("{stem}.json")),
        serde_json::to_string_pretty(json).unwrap(),
    )
    .unwrap();
    dir.join(stem)
}

fn error_of(r: hystid::Result<impl std::fmt::Debug>) -> String {
    r.expect_err("expected an error").to_string()
}

// ---------------------------------------------------------------- WAV + JSON

/// PCM 24 read against a file assembled byte by byte: each value must be
/// exactly `k / 2^23 * scale`.
#[test]
fn wav_reader_decodes_hand_built_pcm24() {
    let dir = tempfile::tempdir().unwrap();
    let codes: [[i32; 2]; 6] = [
        [0, 1],
        [-1, 8_388_607],
        [-8_388_608, 123_456],
        [-654_321, 42],
        [7, -7],
        [4_000_000, -4_000_001],
    ];
    let mut data = Vec::new();
    for frame in codes {
        for k in frame {
            data.extend_from_slice(&k.to_le_bytes()[..3]);
        }
    }
    let scales = [1000.0, 1.0e-4];
    let json = sidecar(
        48000,
        &[
            ("f", "force", "N", scales[0]),
            ("x", "displacement", "m", scales[1]),
        ],
    );
    let stem = put(
        dir.path(),
        "pcm24",
        &wav_bytes(1, 2, 48000, 24, None, false, &data),
        &json,
    );
    let rec = read_recording(&stem).unwrap();
    assert_eq!(rec.frames(), codes.len());
    for (f, frame) in codes.iter().enumerate() {
        for c in 0..2 {
            let want = frame[c] as f64 / 8_388_608.0 * scales[c];
            assert_eq!(rec.channels[c][f], want, "channel {c} frame {f}");
        }
    }
}

/// WAVE_FORMAT_EXTENSIBLE headers (PCM 16 and float 32, 3 channels, an
/// unknown chunk before the data) decode to the hand-computed values.
#[test]
fn wav_reader_accepts_extensible_headers() {
    let dir = tempfile::tempdir().unwrap();
    let chans = [
        ("f", "force", "N", 2.0),
        ("v", "velocity", "m/s", 0.5),
        ("a", "acceleration", "m/s^2", -4.0),
    ];
    let codes: [i16; 6] = [i16::MIN, i16::MAX, 0, -3, 1000, -1];
    let data: Vec<u8> = codes.iter().flat_map(|k| k.to_le_bytes()).collect();
    let stem = put(
        dir.path(),
        "ext16",
        &wav_bytes(0xfffe, 3, 1000, 16, Some(guid(1)), true, &data),
        &sidecar(1000, &chans),
    );
    let rec = read_recording(&stem).unwrap();
    assert_eq!(rec.frames(), 2);
    for (i, &k) in codes.iter().enumerate() {
        assert_eq!(
            rec.channels[i % 3][i / 3],
            k as f64 / 32768.0 * chans[i % 3].3
        );
    }

    let values: [f32; 6] = [1.5, -2.25, 3.0e-7, 0.0, -1.0e6, 7.125];
    let data: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    let stem = put(
        dir.path(),
        "extf",
        &wav_bytes(0xfffe, 3, 1000, 32, Some(guid(3)), false, &data),
        &sidecar(1000, &chans),
    );
    let rec = read_recording(&stem).unwrap();
    for (i, &v) in values.iter().enumerate() {
        assert_eq!(rec.channels[i % 3][i / 3], v as f64 * chans[i % 3].3);
    }
}

/// Every format: read values are exactly the quantised ones, the PCM peak
/// sits at full scale − 1 LSB, and write → read → write is byte-identical.
#[test]
fn wav_round_trip_is_exact_and_stable() {
    let dir = tempfile::tempdir().unwrap();
    let rec = sample_recording(3001, 7);
    for (format, bits) in [
        (SampleFormat::Pcm16, 16),
        (SampleFormat::Pcm24, 24),
        (SampleFormat::Pcm32, 32),
        (SampleFormat::Float32, 32),
    ] {
        let a = dir.path().join(format!("a{bits}{format:?}"));
        write_recording(&a, &rec, format).unwrap();
        let back = read_recording(&a).unwrap();
        assert_eq!(back.meta.excitation, rec.meta.excitation);
        assert_eq!(back.meta.metadata, rec.meta.metadata);
        for c in 0..3 {
            let x = &rec.channels[c];
            let y = &back.channels[c];
            let scale = back.meta.channels[c].scale;
            if format == SampleFormat::Float32 {
                assert_eq!(scale, 1.0);
                for f in 0..x.len() {
                    assert_eq!(y[f], x[f] as f32 as f64, "{format:?} ch {c} frame {f}");
                }
                continue;
            }
            let full = 2f64.powi(bits - 1);
            let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let want_scale = peak * full / (full - 1.0);
            assert!(
                (scale - want_scale).abs() <= 1e-15 * want_scale,
                "{format:?} ch {c} scale {scale} vs {want_scale}"
            );
            let lsb = scale / full;
            let mut top = 0i64;
            for f in 0..x.len() {
                let k = (x[f] / lsb).round();
                assert_eq!(y[f], k / full * scale, "{format:?} ch {c} frame {f}");
                assert!((y[f] - x[f]).abs() <= 0.5 * lsb * (1.0 + 1e-9));
                top = top.max(k.abs() as i64);
            }
            assert_eq!(top, full as i64 - 1, "{format:?} ch {c} peak code");
        }
        let b = dir.path().join(format!("b{bits}{format:?}"));
        write_recording(&b, &back, format).unwrap();
        for ext in ["wav", "json"] {
            let fa = std::fs::read(a.with_extension(ext)).unwrap();
            let fb = std::fs::read(b.with_extension(ext)).unwrap();
            assert!(fa == fb, "{format:?} {ext} differs after a second write");
        }
    }
}

/// Float32 keeps a non-unit scale: stored value = (x / scale) as f32.
#[test]
fn wav_float_keeps_given_scale() {
    let dir = tempfile::tempdir().unwrap();
    let mut rec = sample_recording(500, 3);
    rec.meta.channels[1].scale = 1.0e-6;
    let p = dir.path().join("scaled.wav");
    write_recording(&p, &rec, SampleFormat::Float32).unwrap();
    let back = read_recording(&p).unwrap();
    assert_eq!(back.meta.channels[1].scale, 1.0e-6);
    for f in 0..500 {
        let x = rec.channels[1][f];
        assert_eq!(back.channels[1][f], (x / 1.0e-6) as f32 as f64 * 1.0e-6);
    }
}

/// Block-wise streaming and seeking give the same samples as a whole read.
#[test]
fn wav_streaming_reader_matches_whole_read() {
    let dir = tempfile::tempdir().unwrap();
    let rec = sample_recording(40_000, 11);
    let p = dir.path().join("stream");
    write_recording(&p, &rec, SampleFormat::Pcm24).unwrap();
    let whole = read_recording(&p).unwrap();
    let mut r = RecordingReader::open(&p.with_extension("json")).unwrap();
    assert_eq!(r.frames(), 40_000);
    let mut out = vec![Vec::new(); 3];
    let mut joined = vec![Vec::new(); 3];
    loop {
        let n = r.read_frames(7_777, &mut out).unwrap();
        if n == 0 {
            break;
        }
        for c in 0..3 {
            assert_eq!(out[c].len(), n);
            joined[c].extend_from_slice(&out[c]);
        }
    }
    assert_eq!(joined, whole.channels);
    r.seek_frame(31_234).unwrap();
    assert_eq!(r.read_frames(20_000, &mut out).unwrap(), 40_000 - 31_234);
    assert_eq!(out[2][..], whole.channels[2][31_234..]);
    r.seek_frame(10).unwrap();
    r.skip_frames(5).unwrap();
    assert_eq!(r.position(), 15);
    r.read_frames(3, &mut out).unwrap();
    assert_eq!(out[0][..], whole.channels[0][15..18]);
    assert!(r.seek_frame(40_001).is_err());
    assert!(r.read_frames(3, &mut out[..2]).is_err());
}

/// NAME.wav, NAME.json and the stem (with dots) all name the same pair;
/// unknown top-level keys survive a rewrite.
#[test]
fn wav_paths_and_unknown_keys() {
    let dir = tempfile::tempdir().unwrap();
    let mut rec = sample_recording(100, 1);
    rec.meta.extra.insert(
        "operator".into(),
        json!({"name": "A. N. Other", "shift": 2}),
    );
    let stem = dir.path().join("run.2024-05-01");
    write_recording(&stem, &rec, SampleFormat::Pcm16).unwrap();
    assert!(dir.path().join("run.2024-05-01.wav").is_file());
    assert!(dir.path().join("run.2024-05-01.json").is_file());
    let a = read_recording(&stem).unwrap();
    let b = read_recording(&dir.path().join("run.2024-05-01.wav")).unwrap();
    let c = read_recording(&dir.path().join("run.2024-05-01.json")).unwrap();
    assert_eq!(a, b);
    assert_eq!(a, c);
    assert_eq!(a.meta.extra["operator"]["shift"], json!(2));
    let other = dir.path().join("copy");
    write_recording(&other, &a, SampleFormat::Pcm16).unwrap();
    let text = std::fs::read_to_string(other.with_extension("json")).unwrap();
    assert!(text.contains("\"operator\"") && text.contains("A. N. Other"));
    // Only the two files, no temporaries left behind.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 4);
}

/// Non-finite samples are refused, naming channel and frame, and nothing is
/// written.
#[test]
fn wav_writer_rejects_non_finite() {
    let dir = tempfile::tempdir().unwrap();
    let mut rec = sample_recording(50, 2);
    rec.channels[2][17] = f64::NAN;
    let e = error_of(write_recording(
        &dir.path().join("bad"),
        &rec,
        SampleFormat::Float32,
    ));
    assert!(e.contains("accel[frame 17]"), "{e}");
    rec.channels[2][17] = 0.0;
    rec.channels[0][3] = f64::INFINITY;
    let e = error_of(write_recording(
        &dir.path().join("bad"),
        &rec,
        SampleFormat::Pcm16,
    ));
    assert!(e.contains("force[frame 3]"), "{e}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// Each sidecar rule: the error names the file and the field.
#[test]
fn wav_sidecar_errors_name_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let data: Vec<u8> = (0..8i16).flat_map(|k| (k * 100).to_le_bytes()).collect();
    let wav = wav_bytes(1, 2, 1000, 16, None, false, &data);
    let good = sidecar(
        1000,
        &[("f", "force", "N", 1.0), ("x", "displacement", "m", 1.0)],
    );
    assert!(read_recording(&put(dir.path(), "good", &wav, &good)).is_ok());
    // A UTF-8 byte-order mark (some Windows tools) is accepted.
    let text = format!("\u{feff}{}", serde_json::to_string(&good).unwrap());
    std::fs::write(dir.path().join("good.json"), text).unwrap();
    assert_eq!(
        read_recording(&dir.path().join("good")).unwrap().channels[0][3],
        600.0 / 32768.0
    );
    let step = |start: u64, settle: u64, length: u64, f: f64| json!({"kind": "stepped-sine", "steps": [{"frequency_hz": f, "level": 1.0, "start": start, "settle": settle, "length": length}]});
    type Mutation = Box<dyn Fn(&mut serde_json::Value)>;
    let cases: Vec<(&str, Mutation)> = vec![
        (
            "`format`",
            Box::new(|j| j["format"] = json!("hystid.recording.v2")),
        ),
        (
            "`sample_rate_hz`",
            Box::new(|j| j["sample_rate_hz"] = json!(1001)),
        ),
        (
            "`channels`",
            Box::new(|j| {
                j["channels"]
                    .as_array_mut()
                    .unwrap()
                    .push(json!({"name": "v", "quantity": "velocity", "unit": "m/s"}))
            }),
        ),
        (
            "`channels[1].name`",
            Box::new(|j| j["channels"][1]["name"] = json!("f")),
        ),
        (
            "`channels[0].quantity`",
            Box::new(|j| j["channels"][0]["quantity"] = json!("forse")),
        ),
        (
            "`channels[1].unit`",
            Box::new(|j| j["channels"][1]["unit"] = json!("mm")),
        ),
        (
            "`channels[0].scale`",
            Box::new(|j| j["channels"][0]["scale"] = json!(0.0)),
        ),
        (
            "`channels[0].scale`",
            Box::new(|j| j["channels"][0]["scale"] = json!("1")),
        ),
        (
            "`excitation.steps[0]`",
            Box::new(move |j| j["excitation"] = step(2, 0, 3, 10.0)),
        ),
        (
            "`excitation.steps[0].settle`",
            Box::new(move |j| j["excitation"] = step(0, 3, 2, 10.0)),
        ),
        (
            "`excitation.steps[0].frequency_hz`",
            Box::new(move |j| j["excitation"] = step(0, 0, 2, 0.0)),
        ),
        (
            "`excitation.steps[0].start`",
            Box::new(|j| {
                j["excitation"] = json!({"steps": [{"frequency_hz": 1.0, "level": 1.0, "start": -1, "length": 2}]})
            }),
        ),
        (
            "`excitation.kind`",
            Box::new(|j| j["excitation"] = json!({"kind": "chirp"})),
        ),
    ];
    for (i, (field, mutate)) in cases.iter().enumerate() {
        let mut j = good.clone();
        mutate(&mut j);
        let stem = put(dir.path(), &format!("case{i}"), &wav, &j);
        let e = error_of(read_recording(&stem));
        assert!(
            e.contains(&format!("case{i}.json")) && e.contains(field),
            "case {i}: {e}"
        );
    }
    // Malformed JSON: line and column.
    std::fs::write(
        dir.path().join("case0.json"),
        "{\n  \"format\": \"hystid.recording.v1\",\n  \"channels\": [,]\n}",
    )
    .unwrap();
    let e = error_of(read_recording(&dir.path().join("case0")));
    assert!(
        e.contains("case0.json") && e.contains("line 3 column 16"),
        "{e}"
    );
}

/// Damaged WAV files: the error names the WAV file and what was expected.
#[test]
fn wav_damaged_files_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let data: Vec<u8> = (0..64i16).flat_map(|k| (k * 100).to_le_bytes()).collect();
    let wav = wav_bytes(1, 2, 1000, 16, None, false, &data);
    let json = sidecar(
        1000,
        &[("f", "force", "N", 1.0), ("x", "displacement", "m", 1.0)],
    );
    // Header cut at several places, then data cut short.
    for (i, cut) in [0usize, 4, 11, 20, 30, 40].into_iter().enumerate() {
        let stem = put(dir.path(), &format!("cut{i}"), &wav[..cut], &json);
        let e = error_of(read_recording(&stem));
        assert!(
            e.contains(&format!("cut{i}.wav")) && e.contains("header"),
            "cut {cut}: {e}"
        );
    }
    let stem = put(dir.path(), "short", &wav[..wav.len() - 10], &json);
    let e = error_of(read_recording(&stem));
    assert!(e.contains("short.wav") && e.contains("truncated"), "{e}");
    let mut bad = wav.clone();
    bad[0..4].copy_from_slice(b"RIFX");
    let e = error_of(read_recording(&put(dir.path(), "riff", &bad, &json)));
    assert!(e.contains("riff.wav") && e.contains("RIFF"), "{e}");
    // 8-bit PCM is not one of the accepted formats.
    let wav8 = wav_bytes(1, 2, 1000, 8, None, false, &[128; 16]);
    let e = error_of(read_recording(&put(dir.path(), "pcm8", &wav8, &json)));
    assert!(e.contains("pcm8.wav") && e.contains("8-bit"), "{e}");
    // A NaN in a float file is named by channel and frame.
    let vals: [f32; 4] = [1.0, 2.0, 3.0, f32::NAN];
    let data: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
    let e = error_of(read_recording(&put(
        dir.path(),
        "nan",
        &wav_bytes(3, 2, 1000, 32, None, false, &data),
        &json,
    )));
    assert!(e.contains("nan.wav") && e.contains("x[frame 1]"), "{e}");
    // Missing sidecar.
    std::fs::remove_file(dir.path().join("nan.json")).unwrap();
    let e = error_of(read_recording(&dir.path().join("nan.wav")));
    assert!(e.contains("nan.json"), "{e}");
}

// ---------------------------------------------------------------- MCAP

pub(crate) fn run_info(fs: f64) -> RunInfo {
    RunInfo {
        tool_version: "hystid 0.1.0-test".into(),
        test_definition: "[test]\nlevels_n = [10.0, 20.0]\nseed = 42\n".into(),
        seed: 42,
        sample_rate_hz: fs,
        channels: vec![
            channel("drive", Quantity::Force, 1.0),
            channel("x", Quantity::Displacement, 1.0),
            channel("a", Quantity::Acceleration, 1.0),
        ],
        metadata: BTreeMap::from([("model".to_string(), "jenkins".to_string())]),
    }
}

/// A virtual test as plain data: per step (frequency, level, frames) and the
/// signals of the whole run.
pub(crate) struct Run {
    steps: Vec<(f64, f64, usize)>,
    force: Vec<f64>,
    disp: Vec<f64>,
    vel: Vec<f64>,
    acc: Vec<f64>,
}

pub(crate) fn virtual_run(fs: f64, steps: Vec<(f64, f64, usize)>, seed: u64) -> Run {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 0.01).unwrap();
    let (mut force, mut disp, mut vel, mut acc) = (vec![], vec![], vec![], vec![]);
    for &(f, level, n) in &steps {
        for i in 0..n {
            let th = 2.0 * std::f64::consts::PI * f * i as f64 / fs;
            force.push(level * th.sin() + noise.sample(&mut rng));
            disp.push(1e-5 * level * (th - 0.3).sin());
            vel.push(f64::NAN); // not recorded: must be ignored
            acc.push(-1e-5 * level * (2.0 * std::f64::consts::PI * f).powi(2) * (th - 0.3).sin());
        }
    }
    Run {
        steps,
        force,
        disp,
        vel,
        acc,
    }
}

/// Writes `run` the way the bench would: signals per step (split into two
/// calls), a dwell message at the end of each step, then fit iterations.
pub(crate) fn record_run(path: &Path, info: &RunInfo, run: &Run, fit_iterations: u64) {
    let mut rec = McapRecorder::create(path, info).unwrap();
    let mut start = 0usize;
    for (k, &(f, level, n)) in run.steps.iter().enumerate() {
        let split = n / 3;
        for (a, b) in [(start, start + split), (start + split, start + n)] {
            rec.write_signals(
                k as u32,
                a as u64,
                &run.force[a..b],
                &run.disp[a..b],
                &run.vel[a..b],
                &run.acc[a..b],
            )
            .unwrap();
        }
        rec.write_dwell(
            (start + n) as u64,
            &json!({"step": k, "frequency_hz": f, "level": level, "start": start, "settle": n / 4, "length": n, "h1_abs": 1e-5}),
        )
        .unwrap();
        start += n;
    }
    for i in 0..fit_iterations {
        rec.write_fit_iteration(
            i,
            &json!({"cost": 1.0 / (i + 1) as f64, "params": {"kt": 1e5}}),
        )
        .unwrap();
    }
    rec.finish().unwrap();
}

fn f32_of(x: &[f64]) -> Vec<f64> {
    x.iter().map(|&v| v as f32 as f64).collect()
}

/// Messages of a file as (topic, log time, payload), read with the mcap
/// crate's own stream reader (a second implementation of the reading).
fn messages(bytes: &[u8]) -> Vec<(String, u64, Vec<u8>)> {
    mcap::MessageStream::new_with_options(bytes, mcap::read::Options::ValidateChunkCrcs.into())
        .unwrap()
        .map(|m| {
            let m = m.unwrap();
            (m.channel.topic.clone(), m.log_time, m.data.into_owned())
        })
        .collect()
}

/// [`McapRunReader`] on `path` serves every window of `rec` (the run read
/// whole) as it is: across block and step boundaries, behind its scan (which
/// restarts), and cut at the end; its description is the recording's.
fn assert_reader_matches(path: &Path, rec: &Recording) {
    let mut reader = McapRunReader::open(path).unwrap();
    assert_eq!(reader.meta(), &rec.meta);
    let n = rec.frames();
    assert_eq!(reader.frames(), n);
    let mut out = vec![Vec::new(); rec.channels.len()];
    // forward with gaps, a window inside the last one, one behind it, and
    // one running past the end
    let windows = [
        (0, 10),
        (4090, 20),
        (5000, 4097),
        (5001, 3),
        (n / 2, 1),
        (100, 8192),
        (n.saturating_sub(7), 50),
        (n, 5),
    ];
    for (start, count) in windows.into_iter().filter(|w| w.0 <= n) {
        let got = reader.read_at(start, count, &mut out).unwrap();
        let end = (start + count).min(n);
        assert_eq!(got, end - start, "window {start}+{count}");
        for (c, o) in out.iter().enumerate() {
            assert_eq!(
                o[..],
                rec.channels[c][start..end],
                "channel {c}, {start}+{count}"
            );
        }
    }
    let e = error_of(reader.read_at(n + 1, 1, &mut out));
    assert!(e.contains("beyond the recording"), "{e}");
}

#[test]
fn mcap_run_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let fs = 5000.0;
    let info = run_info(fs);
    let run = virtual_run(
        fs,
        vec![(40.0, 10.0, 5000), (41.0, 20.0, 9001), (42.5, 20.0, 4100)],
        5,
    );
    let path = dir.path().join("run.mcap");
    record_run(&path, &info, &run, 7);
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "temporary left behind"
    );

    let got = read_run(&path).unwrap();
    assert!(!got.truncated);
    assert_eq!(got.info, info);
    // Expected counts, computed from the call pattern: blocks of <= 4096 per
    // write_signals call; a preview every ceil(5000/1000) = 5th frame.
    let mut blocks = 0;
    for &(_, _, n) in &run.steps {
        blocks += (n / 3).div_ceil(4096) + (n - n / 3).div_ceil(4096);
    }
    let total: usize = run.steps.iter().map(|s| s.2).sum();
    let previews = (0..total).filter(|f| f % 5 == 0).count();
    let counts: BTreeMap<String, u64> = [
        ("/hystid/dwell", 3),
        ("/hystid/fit", 7),
        ("/hystid/preview", previews as u64),
        ("/hystid/signals", blocks as u64),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect();
    assert_eq!(got.message_counts, counts);
    assert_eq!(got.signals.len(), 3);
    let mut start = 0;
    for (k, s) in got.signals.iter().enumerate() {
        let n = run.steps[k].2;
        assert_eq!(
            (s.step, s.first_frame, s.frames()),
            (k as u32, start as u64, n)
        );
        assert_eq!(s.force, f32_of(&run.force[start..start + n]));
        assert_eq!(s.displacement, f32_of(&run.disp[start..start + n]));
        assert_eq!(s.acceleration, f32_of(&run.acc[start..start + n]));
        assert!(s.velocity.is_empty());
        start += n;
    }
    assert_eq!(got.dwells[1]["length"], json!(9001));
    assert_eq!(
        got.fit_iterations[6],
        json!({"cost": 1.0 / 7.0, "iteration": 6, "params": {"kt": 1e5}})
    );

    // Log times: integer ns from frame indices, in order across topics.
    let bytes = std::fs::read(&path).unwrap();
    let msgs = messages(&bytes);
    assert!(
        msgs.windows(2).all(|w| w[0].1 <= w[1].1),
        "messages out of log-time order"
    );
    for (topic, t, data) in &msgs {
        match topic.as_str() {
            "/hystid/signals" => {
                let first_frame = u64::from_le_bytes(data[12..20].try_into().unwrap());
                assert_eq!(*t, first_frame * 200_000, "1e9/5000 = 200000 ns per frame");
            }
            "/hystid/preview" => {
                assert_eq!(t % 1_000_000, 0, "previews every 5 frames = 1 ms");
                let v: serde_json::Value = serde_json::from_slice(data).unwrap();
                let f = (t / 200_000) as usize;
                assert_eq!(
                    v,
                    json!({"force": run.force[f], "displacement": run.disp[f], "acceleration": run.acc[f]})
                );
            }
            "/hystid/dwell" => {
                let v: serde_json::Value = serde_json::from_slice(data).unwrap();
                let end = v["start"].as_u64().unwrap() + v["length"].as_u64().unwrap();
                assert_eq!(*t, end * 200_000);
            }
            _ => assert_eq!(*t, total as u64 * 200_000),
        }
    }
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    assert_eq!(
        summary.stats.unwrap().message_count,
        counts.values().sum::<u64>()
    );

    // As a recording: force + the recorded responses, steps from the dwells.
    let rec = got.to_recording().unwrap();
    assert_eq!(rec.frames(), total);
    assert_eq!(
        rec.meta
            .channels
            .iter()
            .map(|c| c.name.as_str())
            .collect::<Vec<_>>(),
        ["drive", "x", "a"]
    );
    assert_eq!(rec.channels[0], f32_of(&run.force));
    assert_eq!(rec.channels[2], f32_of(&run.acc));
    assert_eq!(
        rec.meta.excitation.steps[2],
        Step {
            frequency_hz: 42.5,
            level: 20.0,
            start: 14001,
            settle: 1025,
            length: 4100
        }
    );
    assert_eq!(rec.meta.metadata["seed"], json!(42));
    assert_reader_matches(&path, &rec);
    // reduced one dwell at a time from the file: the FRFs of the whole read
    let options = hystid::analysis::ReductionOptions::default();
    let streamed = hystid::analysis::reduce_path(
        &path,
        hystid::analysis::ChannelChoice::response(Some("x")),
        &options,
        &hystid::observe::Silent,
    )
    .unwrap();
    let loaded = hystid::analysis::load_recording(
        &path,
        hystid::analysis::ChannelChoice::response(Some("x")),
    )
    .unwrap();
    let whole = hystid::analysis::reduce(&loaded, &options, &hystid::observe::Silent).unwrap();
    assert!(streamed.streamed && !whole.streamed);
    assert_eq!(streamed.frf.levels.len(), 2);
    assert_eq!(streamed.frf, whole.frf);
    // a reference that is all zero is refused, naming the file and channel,
    // streamed or whole
    let mut flat = virtual_run(fs, vec![(40.0, 10.0, 5000)], 5);
    flat.force.iter_mut().for_each(|f| *f = 0.0);
    let flat_path = dir.path().join("flat.mcap");
    record_run(&flat_path, &info, &flat, 0);
    for e in [
        error_of(
            hystid::analysis::reduce_path(
                &flat_path,
                hystid::analysis::ChannelChoice::response(Some("x")),
                &options,
                &hystid::observe::Silent,
            )
            .map(|_| ()),
        ),
        error_of(
            hystid::analysis::load_recording(
                &flat_path,
                hystid::analysis::ChannelChoice::response(Some("x")),
            )
            .map(|_| ()),
        ),
    ] {
        assert!(
            e.contains("flat.mcap") && e.contains("drive") && e.contains("flat (all zero)"),
            "{e}"
        );
    }
    let wav = dir.path().join("from_run");
    write_recording(&wav, &rec, SampleFormat::Float32).unwrap();
    assert_eq!(read_recording(&wav).unwrap(), rec);
}

/// Same inputs give the same bytes; a sample rate that does not divide 1e9
/// (or is not even whole) still gives log times within 1 ns of the exact
/// `frame * 1e9 / fs`.
#[test]
fn mcap_is_reproducible_and_clock_exact() {
    let dir = tempfile::tempdir().unwrap();
    for (fs, num, den) in [
        (51200.0, 1_000_000_000u128, 51200u128),
        (7897.6, 10_000_000_000, 78976),
    ] {
        let info = run_info(fs);
        let run = virtual_run(fs, vec![(100.0, 5.0, 30_000), (101.0, 5.0, 20_000)], 9);
        let a = dir.path().join("a.mcap");
        let b = dir.path().join("b.mcap");
        record_run(&a, &info, &run, 3);
        record_run(&b, &info, &run, 3);
        let bytes = std::fs::read(&a).unwrap();
        assert!(
            bytes == std::fs::read(&b).unwrap(),
            "fs {fs}: not byte-identical"
        );
        for (topic, t, data) in messages(&bytes) {
            if topic == "/hystid/signals" {
                let frame = u64::from_le_bytes(data[12..20].try_into().unwrap()) as u128;
                let exact = frame * num / den; // floor of the exact time
                assert!(
                    (t as i128 - exact as i128).abs() <= 1,
                    "fs {fs} frame {frame}: {t} vs {exact}"
                );
            }
        }
        let got = read_run(&a).unwrap();
        assert_eq!(got.info.sample_rate_hz, fs);
    }
}

/// A file cut anywhere yields a prefix of what was written: whole chunks
/// only, every CRC checked, `truncated` set.
#[test]
fn mcap_truncated_file_recovers_a_prefix() {
    let dir = tempfile::tempdir().unwrap();
    let fs = 50_000.0;
    let info = run_info(fs);
    // Schemas and channels, then about 2.4 chunks of 4 MiB.
    let run = virtual_run(
        fs,
        vec![
            (100.0, 5.0, 260_000),
            (110.0, 5.0, 260_000),
            (120.0, 5.0, 260_000),
        ],
        3,
    );
    let path = dir.path().join("full.mcap");
    record_run(&path, &info, &run, 2);
    let bytes = std::fs::read(&path).unwrap();
    let full = read_run(&path).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    assert!(
        summary.chunk_indexes.len() >= 4,
        "{} chunks",
        summary.chunk_indexes.len()
    );
    let chunk_ends: Vec<u64> = summary
        .chunk_indexes
        .iter()
        .map(|c| c.chunk_start_offset + c.chunk_length)
        .collect();

    let mut previous = 0;
    let cuts = [
        chunk_ends[1] as usize,
        chunk_ends[1] as usize + 1,
        bytes.len() * 2 / 5,
        chunk_ends[2] as usize - 3,
        bytes.len() * 4 / 5,
        bytes.len() - 30,
        bytes.len() - 1,
    ];
    for cut in cuts {
        let p = dir.path().join("cut.mcap");
        std::fs::write(&p, &bytes[..cut]).unwrap();
        let got = read_run(&p).unwrap();
        assert!(got.truncated, "cut {cut}");
        assert_eq!(got.info, info);
        // Recovered samples are the first ones written, in order.
        let force: Vec<f64> = got
            .signals
            .iter()
            .flat_map(|s| s.force.iter().copied())
            .collect();
        assert_eq!(
            force[..],
            f32_of(&run.force[..force.len()])[..],
            "cut {cut}"
        );
        assert_eq!(got.dwells[..], full.dwells[..got.dwells.len()]);
        // Whole chunks only: the frames recovered are exactly those of the
        // complete chunks before the cut, each a whole number of blocks.
        let complete = chunk_ends.iter().filter(|&&e| e as usize <= cut).count();
        let expect_blocks: u64 = if complete == chunk_ends.len() {
            full.message_counts["/hystid/signals"]
        } else {
            let upto = chunk_ends[complete - 1] as usize;
            std::fs::write(&p, &bytes[..upto]).unwrap();
            read_run(&p)
                .unwrap()
                .message_counts
                .get("/hystid/signals")
                .copied()
                .unwrap_or(0)
        };
        assert_eq!(
            got.message_counts
                .get("/hystid/signals")
                .copied()
                .unwrap_or(0),
            expect_blocks,
            "cut {cut}"
        );
        // read frame by frame: the same frames, or the same error
        match got.to_recording() {
            Ok(rec) => assert_reader_matches(&p, &rec),
            Err(e) => {
                let r = error_of(McapRunReader::open(&p));
                assert!(r.contains(&e.to_string()), "cut {cut}: {r} against {e}");
            }
        }
        assert!(
            force.len() >= previous,
            "cut {cut}: fewer frames than a shorter cut"
        );
        previous = force.len();
    }
    // Cut in the summary: every message is there.
    assert_eq!(previous, run.force.len());
    // Cut before the run record: a clear error.
    let p = dir.path().join("stub.mcap");
    std::fs::write(&p, &bytes[..60]).unwrap();
    let e = error_of(read_run(&p));
    assert!(
        e.contains("stub.mcap") && e.contains("`metadata record run`: missing"),
        "{e}"
    );
    std::fs::write(&p, &bytes[..40]).unwrap();
    let e = error_of(read_run(&p));
    assert!(e.contains("stub.mcap") && e.contains("header"), "{e}");
}

/// A damaged chunk (its stored CRC, or its data) is an error naming the file.
#[test]
fn mcap_corrupted_chunk_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let fs = 20_000.0;
    let info = run_info(fs);
    let run = virtual_run(fs, vec![(100.0, 5.0, 60_000)], 4);
    let path = dir.path().join("good.mcap");
    record_run(&path, &info, &run, 0);
    let bytes = std::fs::read(&path).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    let chunk = summary.chunk_indexes.last().unwrap();
    // Chunk record: opcode (1), length (8), start and end time (16),
    // uncompressed size (8), then the uncompressed CRC.
    let mut bad = bytes.clone();
    bad[chunk.chunk_start_offset as usize + 33] ^= 0x40;
    let p = dir.path().join("badcrc.mcap");
    std::fs::write(&p, &bad).unwrap();
    let e = error_of(read_run(&p));
    assert!(e.contains("badcrc.mcap") && e.contains("CRC"), "{e}");

    let mut bad = bytes.clone();
    bad[(chunk.chunk_start_offset + chunk.chunk_length / 2) as usize] ^= 0x01;
    let p = dir.path().join("baddata.mcap");
    std::fs::write(&p, &bad).unwrap();
    let e = error_of(read_run(&p));
    assert!(e.contains("baddata.mcap"), "{e}");
}

#[test]
fn mcap_recorder_rejects_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.mcap");
    let mut info = run_info(1000.0);
    // beside a voltage a force is a gauge's; a second voltage is refused
    info.channels.push(channel("v", Quantity::Voltage, 1.0));
    assert!(McapRecorder::create(&path, &info).is_ok());
    info.channels.push(channel("v2", Quantity::Voltage, 1.0));
    assert!(error_of(McapRecorder::create(&path, &info)).contains("channels[4]"));
    info.channels.truncate(3);
    info.channels.truncate(1);
    info.channels.push(channel("x2", Quantity::Force, 1.0));
    assert!(error_of(McapRecorder::create(&path, &info)).contains("second force"));
    info = run_info(1000.0);
    info.metadata.insert("seed".into(), "1".into());
    assert!(error_of(McapRecorder::create(&path, &info)).contains("`seed`"));

    let info = run_info(1000.0);
    let mut rec = McapRecorder::create(&path, &info).unwrap();
    let ok = vec![0.5; 100];
    let mut bad = ok.clone();
    bad[42] = f64::NAN;
    let e = error_of(rec.write_signals(0, 1000, &ok, &ok, &[], &bad));
    assert!(e.contains("a[frame 1042]"), "{e}");
    let e = error_of(rec.write_signals(0, 1000, &ok, &ok[..99], &[], &ok));
    assert!(e.contains("`x`"), "{e}");
    rec.write_signals(0, 1000, &ok, &ok, &[], &ok).unwrap();
    assert!(error_of(rec.write_signals(0, 1050, &ok, &ok, &[], &ok)).contains("overlap"));
    assert!(error_of(rec.write_dwell(900, &json!({"frequency_hz": 1.0}))).contains("time order"));
    assert!(error_of(rec.write_dwell(1100, &json!([1, 2]))).contains("JSON object"));
    // Dropped without finish: nothing is left.
    drop(rec);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// The official Python reader (mcap 1.6.0 + mcap-ros2-support 0.6.0) opens
/// the file with CRC validation, counts the messages and decodes the first
/// CDR block to the numbers written.
#[test]
fn mcap_python_interop() {
    let ok = std::process::Command::new("python3")
        .args(["-c", "import mcap.reader, mcap_ros2.decoder"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        eprintln!("SKIPPED: python mcap reader not installed");
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set: the Python mcap reader must be installed"
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let fs = 10_000.0;
    let info = run_info(fs);
    let run = virtual_run(fs, vec![(80.0, 3.0, 9000), (90.0, 6.0, 7000)], 21);
    let path = dir.path().join("interop.mcap");
    record_run(&path, &info, &run, 4);
    let got = read_run(&path).unwrap();
    let n = 3000; // the first call of the first step writes 9000/3 frames: one block
    let expect = json!({
        "counts": got.message_counts,
        "first_block": {
            "step": 0, "first_frame": 0, "t0": 0.0, "fs": fs,
            "force": f32_of(&run.force[..n]),
            "displacement": f32_of(&run.disp[..n]),
            "velocity": [],
            "acceleration": f32_of(&run.acc[..n]),
        },
        "metadata": {"run": {
            "format": "hystid.run.v1", "tool_version": info.tool_version, "seed": "42",
            "sample_rate_hz": "10000", "model": "jenkins",
            "channels": "[{\"name\":\"drive\",\"quantity\":\"force\",\"unit\":\"N\"},{\"name\":\"x\",\"quantity\":\"displacement\",\"unit\":\"m\"},{\"name\":\"a\",\"quantity\":\"acceleration\",\"unit\":\"m/s^2\"}]",
        }},
        "attachment": info.test_definition,
    });
    let expect_path = dir.path().join("expect.json");
    std::fs::write(&expect_path, serde_json::to_string(&expect).unwrap()).unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/interop/check_mcap.py");
    let out = std::process::Command::new("python3")
        .arg(&script)
        .arg(&path)
        .arg(&expect_path)
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "check_mcap.py failed:\n{text}");
    assert!(text.contains("OK"), "{text}");

    // The checker must fail on a wrong expectation (so a pass means something).
    let mut wrong = expect.clone();
    wrong["first_block"]["force"][17] = json!(run.force[17] + 1e-3);
    std::fs::write(&expect_path, serde_json::to_string(&wrong).unwrap()).unwrap();
    let out = std::process::Command::new("python3")
        .arg(&script)
        .arg(&path)
        .arg(&expect_path)
        .output()
        .unwrap();
    assert!(
        !out.status.success(),
        "check_mcap.py accepted a wrong sample"
    );
}

#[test]
fn streaming_writer_equals_the_whole_write_and_leaves_nothing_when_dropped() {
    let dir = tempfile::tempdir().unwrap();
    let rec = sample_recording(10_000, 7);
    let f32s: Vec<Vec<f32>> = rec
        .channels
        .iter()
        .map(|c| c.iter().map(|&v| v as f32).collect())
        .collect();
    let mut meta = rec.meta.clone();
    for c in &mut meta.channels {
        c.scale = 1.0;
    }
    let mut w =
        hystid::record::RecordingWriter::create(&dir.path().join("s"), meta.clone()).unwrap();
    for chunk in [0..1234usize, 1234..1234, 1234..9000, 9000..10_000] {
        let slices: Vec<&[f32]> = f32s.iter().map(|c| &c[chunk.clone()]).collect();
        w.write_frames(&slices).unwrap();
    }
    assert_eq!(w.frames(), 10_000);
    w.finish().unwrap();
    let back = read_recording(&dir.path().join("s.wav")).unwrap();
    for (a, b) in back.channels.iter().zip(&f32s) {
        assert!(a.iter().zip(b).all(|(x, y)| *x == *y as f64));
    }
    // dropped unfinished: no file, no temporary
    let mut w = hystid::record::RecordingWriter::create(&dir.path().join("t"), meta).unwrap();
    let slices: Vec<&[f32]> = f32s.iter().map(|c| &c[..10]).collect();
    w.write_frames(&slices).unwrap();
    drop(w);
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert!(names.iter().all(|n| n.starts_with("s.")), "{names:?}");
}

/// `load_reference_and_response` keeps, to the bit, what
/// `load_recording(..).with_only_reference_and_response()` keeps while
/// reading the others a stretch at a time and dropping them: on a run
/// file, on a three-channel WAV recording (the default response and a
/// chosen one) and on a two-channel one (kept whole), each longer than a
/// stretch read.
#[test]
fn only_the_reference_and_response_are_loaded_as_load_recording_keeps_them() {
    use hystid::analysis::{ChannelChoice, load_recording, load_reference_and_response};
    let dir = tempfile::tempdir().unwrap();
    let same = |path: &Path, choice: ChannelChoice| {
        let whole = load_recording(path, choice)
            .unwrap()
            .with_only_reference_and_response();
        let kept = load_reference_and_response(path, choice).unwrap();
        assert_eq!(kept.recording, whole.recording, "{}", path.display());
        assert_eq!(
            (kept.response, kept.truncated, kept.truth.is_some()),
            (whole.response, whole.truncated, whole.truth.is_some())
        );
        kept
    };
    let fs = 5000.0;
    let run = virtual_run(fs, vec![(40.0, 10.0, 40_000), (41.0, 20.0, 30_001)], 5);
    let mcap = dir.path().join("run.mcap");
    record_run(&mcap, &run_info(fs), &run, 1);
    let kept = same(&mcap, ChannelChoice::default());
    assert_eq!(kept.recording.channels.len(), 2);
    assert_eq!(kept.recording.frames(), 70_001);

    let rec = sample_recording(70_001, 3);
    let wav = dir.path().join("three.wav");
    write_recording(&wav, &rec, SampleFormat::Float32).unwrap();
    let kept = same(&wav, ChannelChoice::default());
    assert_eq!(kept.recording.meta.channels[1].name, "response");
    let kept = same(&wav, ChannelChoice::response(Some("accel")));
    assert_eq!(kept.recording.meta.channels[1].name, "accel");
    assert!(kept.recording.channels[1] == read_recording(&wav).unwrap().channels[2]);

    let mut two = rec.clone();
    two.channels.truncate(2);
    two.meta.channels.truncate(2);
    let wav = dir.path().join("two.wav");
    write_recording(&wav, &two, SampleFormat::Pcm24).unwrap();
    let kept = same(&wav, ChannelChoice::default());
    assert_eq!(kept.recording.channels.len(), 2);
}

/// A time record (what `identify` / `diagnose --domain time` replay) holds
/// its reference and response as the file stored them: four bytes a sample
/// for a run file and for float32, 16- and 24-bit WAV files, every sample
/// read back the same `f64` to the bit as `load_recording` gives it, and
/// the same record when the file is read straight into that precision
/// (`load_time_record`); a 32-bit integer file's samples are no `f32`s and
/// are held as they are.
#[test]
fn a_time_record_holds_its_channels_as_the_file_stored_them() {
    use hystid::analysis::{
        ChannelChoice, load_recording, load_reference_and_response, load_time_record,
    };
    use hystid::fit::TimeRecord;
    let dir = tempfile::tempdir().unwrap();
    let check = |path: &Path, bytes_per_sample: usize| {
        let whole = load_recording(path, ChannelChoice::default()).unwrap();
        let reference = whole.recording.reference_channel().unwrap();
        let kept = load_reference_and_response(path, ChannelChoice::default()).unwrap();
        let name = path.display().to_string();
        let r = TimeRecord::from_owned_recording(&name, kept.recording, kept.response, None, None)
            .unwrap();
        // read straight into that precision, never held as f64s: the same
        let read = load_time_record(path, ChannelChoice::default(), None, None).unwrap();
        assert!(read == r, "{name}");
        for (held, channel) in [(&r.reference, reference), (&r.response, whole.response)] {
            let values = &whole.recording.channels[channel];
            assert_eq!(held.bytes(), bytes_per_sample * values.len(), "{name}");
            assert!(
                (0..values.len()).all(|i| held.get(i).to_bits() == values[i].to_bits()),
                "{name}"
            );
        }
    };
    let fs = 5000.0;
    let run = virtual_run(fs, vec![(40.0, 10.0, 40_000), (41.0, 20.0, 30_001)], 5);
    let mcap = dir.path().join("run.mcap");
    record_run(&mcap, &run_info(fs), &run, 1);
    check(&mcap, 4);
    let rec = sample_recording(20_000, 3);
    for (format, bytes) in [
        (SampleFormat::Float32, 4),
        (SampleFormat::Pcm16, 4),
        (SampleFormat::Pcm24, 4),
        (SampleFormat::Pcm32, 8),
    ] {
        let wav = dir.path().join(format!("{format:?}.wav"));
        write_recording(&wav, &rec, format).unwrap();
        check(&wav, bytes);
    }
}
