//! Integration tests: record (WAV + JSON recordings, MCAP run files).

use hystid::harmonics::Quantity;
use hystid::record::{
    Channel, Excitation, ExcitationKind, FORMAT_V1, McapRecorder, Recording, RecordingMeta,
    RecordingReader, RunInfo, SampleFormat, Step, read_recording, read_run, write_recording,
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
fn sample_recording(frames: usize, seed: u64) -> Recording {
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
        },
        channels: vec![force, disp, acc],
    }
}

/// Minimal RIFF/WAVE writer written from the format description (not
/// hound), for checking the reader against an independent reference.
fn wav_bytes(
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
fn guid(kind: u8) -> [u8; 16] {
    [
        kind, 0, 0, 0, 0, 0, 0x10, 0, 0x80, 0, 0, 0xaa, 0, 0x38, 0x9b, 0x71,
    ]
}

fn sidecar(rate: u32, channels: &[(&str, &str, &str, f64)]) -> serde_json::Value {
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
    let step = |start: u64, settle: u64, length: u64, f: f64| json!({"kind": "stepped-sine", "steps": [{"frequency_hz": f, "level": 1.0, "start": start, "settle": settle, "length": length}]});
    let cases: Vec<(&str, Box<dyn Fn(&mut serde_json::Value)>)> = vec![
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
