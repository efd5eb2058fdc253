//! Reading and reducing recordings (criterion, wall time):
//! `cargo bench --bench io`.
//!
//! Targets (from the project's issues):
//!
//! * `f16/*`: import one level of the F-16 ground vibration benchmark
//!   (`F16Data_SineSw_Level1.mat`, 108 477 samples at 400 Hz, force and the
//!   second accelerometer) with `hystid::import`, then reduce the sweep with
//!   `hystid::extract::reduce_sweep`: ≤ 1 s for both. Skipped, with a
//!   message, when the data set is absent (`$HYSTID_DATASETS` or
//!   `../shared/datasets`).
//! * `stream/wav_1gb/*`: a 1 GB stepped-sine recording (two float channels
//!   at 51.2 kHz, 2442 dwells of 1 s) reduced in one streaming pass: each
//!   dwell read through `hystid::record::RecordingReader` (its settling
//!   quarter skipped by seeking) and reduced by `hystid::extract::noncoherent`
//!   (harmonics 0..=5, 4 blocks), so memory is bounded by one dwell: peak
//!   RSS ≤ 300 MB. The recording is generated once under the system
//!   temporary folder (`hystid-bench/stepped-1GB.wav` + `.json`, reused by
//!   later runs, never in the repository). Criterion times the first tenth
//!   of the file per iteration (throughput: WAV bytes per second).
//!
//! * `sweep/10min` (with `HYSTID_BENCH_RSS` only): a 10-minute swept sine at
//!   20 kHz (12 M frames, 96 MB of float WAV: a Jenkins SDOF at 80 Hz swept
//!   10 -> 200 Hz), reduced as `hystid identify` reduces it
//!   (`hystid::analysis::recording::reduce_path`, the automatic
//!   sweep-distortion compensation): read from disk a stretch at a time, peak
//!   RSS ≤ 200 MB. Generated once beside the stepped one (`swept-10min`).
//!   `HYSTID_BENCH_SWEEP_MINUTES=40` makes it 40 minutes long (48 M frames,
//!   the same 10 -> 200 Hz, so four times as many periods: more than a
//!   sweep's points allow, `hystid::extract::MAX_SWEEP_POINTS`), to show
//!   the peak does not grow with the length (`swept-40min`).
//!
//! The whole gigabyte in one pass, then the swept reduction, each timed
//! with its peak memory measured alone (the peak is reset after the file
//! exists, via `/proc/self/clear_refs`):
//!
//! ```text
//! HYSTID_BENCH_RSS=1 cargo bench --bench io
//! ```
//!
//! prints each pass's time and `VmHWM` and exits without running criterion.

#[path = "common/mod.rs"]
mod common;

use criterion::{Criterion, Throughput};
use hystid::extract::{SweepOptions, noncoherent, reduce_sweep};
use hystid::harmonics::Quantity;
use hystid::import::{ChannelSpec, ImportSpec, SampleRateSource, import};
use hystid::record::{
    Channel, Excitation, ExcitationKind, FORMAT_V1, RecordingMeta, RecordingReader,
    RecordingWriter, Step,
};
use hystid::signals::InMemoryFrames;
use std::f64::consts::PI;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn f16_spec() -> ImportSpec {
    ImportSpec::new(
        vec![
            ChannelSpec::new("Force", Quantity::Force).name("force"),
            ChannelSpec::new("Acceleration", Quantity::Acceleration)
                .row(2)
                .name("acc2"),
        ],
        SampleRateSource::Variable("Fs".into()),
    )
}

fn bench_f16(c: &mut Criterion) {
    let Some(dir) = common::dataset("f16_gvt_benchmark") else {
        return;
    };
    let path = dir.join("BenchmarkData/F16Data_SineSw_Level1.mat");
    if !path.is_file() {
        eprintln!("SKIPPED: {} not found", path.display());
        return;
    }
    let spec = f16_spec();
    let opts = SweepOptions::default();
    let imported = import(&path, &spec).unwrap();
    let rec = &imported.recording;
    let fs = rec.meta.sample_rate_hz;
    let r = reduce_sweep(&mut InMemoryFrames::new(rec, "f16"), 0, 1, &opts).unwrap();
    eprintln!(
        "f16: {} frames at {fs} Hz, {} FRF points",
        rec.frames(),
        r.level.points.len()
    );
    let mut g = c.benchmark_group("f16");
    g.throughput(Throughput::Elements(rec.frames() as u64));
    g.bench_function("import/level1", |b| {
        b.iter(|| import(black_box(&path), &spec).unwrap())
    });
    g.bench_function("reduce_sweep/level1", |b| {
        b.iter(|| reduce_sweep(&mut InMemoryFrames::new(rec, "f16"), 0, 1, &opts).unwrap())
    });
    g.bench_function("import_and_reduce/level1", |b| {
        b.iter(|| {
            let imp = import(black_box(&path), &spec).unwrap();
            reduce_sweep(&mut InMemoryFrames::new(&imp.recording, "f16"), 0, 1, &opts).unwrap()
        })
    });
    g.finish();
}

const STREAM_FS: f64 = 51200.0;
const DWELL: usize = 51200;
const DWELLS: usize = 2442;
const HARMONICS: usize = 5;
const BLOCKS: usize = 4;

/// The generated recording's stem, created if absent.
fn stream_recording() -> PathBuf {
    let dir = std::env::temp_dir().join("hystid-bench");
    let stem = dir.join("stepped-1GB");
    let wav = stem.with_extension("wav");
    let expected = 44 + (DWELL * DWELLS * 2 * 4) as u64;
    let ok = std::fs::metadata(&wav).is_ok_and(|m| m.len() >= expected)
        && stem.with_extension("json").is_file();
    if !ok {
        std::fs::create_dir_all(&dir).unwrap();
        let t = Instant::now();
        generate(&stem);
        eprintln!(
            "stream: generated {} ({} bytes) in {:.1} s",
            wav.display(),
            std::fs::metadata(&wav).unwrap().len(),
            t.elapsed().as_secs_f64()
        );
    }
    stem
}

/// 2442 dwells of 1 s cycling through 51 frequencies (100–350 Hz) and 7
/// levels: force `F cos`, displacement an SDOF-like response with a third
/// and fifth harmonic and a little noise.
fn generate(stem: &Path) {
    let freqs: Vec<f64> = (0..51).map(|i| 100.0 + 5.0 * i as f64).collect();
    let levels = [5.0, 50.0, 200.0, 500.0, 1000.0, 3000.0, 30000.0];
    let channel = |name: &str, q: Quantity| Channel {
        name: name.into(),
        quantity: q,
        unit: q.si_unit().into(),
        scale: 1.0,
    };
    let steps: Vec<Step> = (0..DWELLS)
        .map(|d| Step {
            frequency_hz: freqs[d % freqs.len()],
            level: levels[(d / freqs.len()) % levels.len()],
            start: d * DWELL,
            settle: DWELL / 4,
            length: DWELL,
        })
        .collect();
    let meta = RecordingMeta {
        format: FORMAT_V1.into(),
        sample_rate_hz: STREAM_FS,
        channels: vec![
            channel("force", Quantity::Force),
            channel("displacement", Quantity::Displacement),
        ],
        excitation: Excitation {
            kind: ExcitationKind::SteppedSine,
            steps: steps.clone(),
            sweep: None,
        },
        description: "hystid bench: generated 1 GB stepped sine".into(),
        metadata: Default::default(),
        extra: Default::default(),
        chosen_reference: None,
    };
    let mut w = RecordingWriter::create(stem, meta).unwrap();
    let mut force = vec![0f32; DWELL];
    let mut x = vec![0f32; DWELL];
    let mut noise = 0x2545_f491_4f6c_dd1du64;
    for s in &steps {
        let w0 = 2.0 * PI * s.frequency_hz / STREAM_FS;
        // receptance of the paper system (10 kg, 200 N s/m, 1e7 N/m)
        let om = 2.0 * PI * s.frequency_hz;
        let re = 1e7 - 10.0 * om * om;
        let im = 200.0 * om;
        let mag = s.level / (re * re + im * im).sqrt();
        let phase = -im.atan2(re);
        for i in 0..DWELL {
            let t = w0 * (s.start + i) as f64;
            noise ^= noise << 13;
            noise ^= noise >> 7;
            noise ^= noise << 17;
            let n = (noise >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            force[i] = (s.level * t.cos()) as f32;
            x[i] = (mag
                * ((t + phase).cos() + 0.03 * (3.0 * t).sin() + 0.01 * (5.0 * t).cos() + 0.02 * n))
                as f32;
        }
        w.write_frames(&[&force, &x]).unwrap();
    }
    w.finish().unwrap();
}

/// One pass over the first `dwells` dwells: each read (after its settling
/// part) and reduced. Returns a checksum of the fundamentals and the frames
/// reduced.
fn stream_pass(stem: &Path, dwells: usize) -> (f64, usize) {
    let mut reader = RecordingReader::open(stem).unwrap();
    let mut steps = reader.meta().excitation.steps.clone();
    steps.truncate(dwells);
    let fs = reader.meta().sample_rate_hz;
    let mut buf = vec![Vec::new(), Vec::new()];
    let (mut sum, mut frames) = (0.0, 0);
    for s in &steps {
        reader.seek_frame(s.start + s.settle).unwrap();
        let n = reader.read_frames(s.length - s.settle, &mut buf).unwrap();
        let d = noncoherent(&buf[0], &buf[1], fs, s.frequency_hz, HARMONICS, BLOCKS).unwrap();
        sum += d.h[1].norm();
        frames += n;
    }
    (sum, frames)
}

fn bench_stream(c: &mut Criterion) {
    let stem = stream_recording();
    // a tenth of the file per iteration keeps the bench short; the whole
    // gigabyte is timed once, with its peak memory, by HYSTID_BENCH_RSS=1
    let dwells = DWELLS / 10;
    let bytes = (dwells * DWELL * 2 * 4) as u64;
    let mut g = c.benchmark_group("stream");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(1))
        .measurement_time(Duration::from_secs(10))
        .throughput(Throughput::BytesDecimal(bytes));
    g.bench_function("wav_1gb/first_tenth/noncoherent_per_dwell", |b| {
        b.iter(|| stream_pass(&stem, dwells))
    });
    g.finish();
}

/// `HYSTID_BENCH_RSS=1`: the streaming pass alone, with its peak memory.
fn rss_mode() {
    let stem = stream_recording();
    // reset the peak (Linux: "5" clears VmHWM) so that generating the file
    // or loading the program does not count
    let reset = std::fs::write("/proc/self/clear_refs", "5").is_ok();
    let before = common::peak_rss_bytes();
    let t = Instant::now();
    let (sum, frames) = stream_pass(&stem, DWELLS);
    let took = t.elapsed().as_secs_f64();
    let bytes = std::fs::metadata(stem.with_extension("wav")).unwrap().len();
    println!(
        "stream: {frames} frames reduced ({bytes} bytes of WAV) in {took:.2} s ({:.0} MB/s); \
         checksum {sum:.6e}",
        bytes as f64 / took / 1e6
    );
    match common::peak_rss_bytes() {
        Some(p) => println!(
            "stream: peak RSS {:.1} MB (VmHWM{}; {:.1} MB when the pass started)",
            p as f64 / 1e6,
            if reset {
                ", reset before the pass"
            } else {
                ", could not be reset: includes setup"
            },
            before.unwrap_or(0) as f64 / 1e6
        ),
        None => println!("stream: peak RSS unavailable (no /proc/self/status)"),
    }
}

/// The swept recording's stem (10 minutes, or `HYSTID_BENCH_SWEEP_MINUTES`),
/// generated if absent.
fn swept_recording() -> PathBuf {
    let minutes: u32 = std::env::var("HYSTID_BENCH_SWEEP_MINUTES")
        .ok()
        .and_then(|m| m.parse().ok())
        .unwrap_or(10);
    let seconds = 60.0 * minutes as f64;
    let dir = std::env::temp_dir().join("hystid-bench");
    let stem = dir.join(format!("swept-{minutes}min"));
    let fs = 20_000.0;
    let n = (seconds * fs) as usize;
    let expected = 44 + (n * 2 * 4) as u64;
    let ok = std::fs::metadata(stem.with_extension("wav")).is_ok_and(|m| m.len() >= expected)
        && stem.with_extension("json").is_file();
    if ok {
        return stem;
    }
    std::fs::create_dir_all(&dir).unwrap();
    let t = Instant::now();
    let rate = 190.0 / seconds;
    let force: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 / fs;
            100.0 * (2.0 * PI * (10.0 * t + 0.5 * rate * t * t)).sin()
        })
        .collect();
    let model = hystid::model::ModalModel::new(vec![
        hystid::model::Mode::from_mck(1.0, 10.0, 2.526_618e5).unwrap(),
    ])
    .unwrap();
    let joint = hystid::model::Jenkins::new(1e5, 20.0).unwrap();
    let v = hystid::sim::Simulator::new(&model, joint, fs)
        .unwrap()
        .run(&force, &hystid::observe::Silent)
        .unwrap()
        .velocity;
    let channel = |name: &str, q: Quantity| Channel {
        name: name.into(),
        quantity: q,
        unit: q.si_unit().into(),
        scale: 1.0,
    };
    let meta = RecordingMeta {
        format: FORMAT_V1.into(),
        sample_rate_hz: fs,
        channels: vec![
            channel("force", Quantity::Force),
            channel("velocity", Quantity::Velocity),
        ],
        excitation: Excitation {
            kind: ExcitationKind::SweptSine,
            steps: Vec::new(),
            sweep: None,
        },
        description: format!("hystid bench: generated {minutes}-minute swept sine"),
        metadata: Default::default(),
        extra: Default::default(),
        chosen_reference: None,
    };
    let mut w = RecordingWriter::create(&stem, meta).unwrap();
    let (f32s, v32s): (Vec<f32>, Vec<f32>) = force
        .iter()
        .zip(&v)
        .map(|(&f, &v)| (f as f32, v as f32))
        .unzip();
    w.write_frames(&[&f32s, &v32s]).unwrap();
    w.finish().unwrap();
    eprintln!(
        "sweep: generated {} in {:.1} s",
        stem.with_extension("wav").display(),
        t.elapsed().as_secs_f64()
    );
    stem
}

/// `HYSTID_BENCH_RSS=1`: the swept recording reduced from disk, with its
/// peak memory.
fn sweep_rss_mode() {
    use hystid::analysis::recording::{ChannelChoice, ReductionOptions, reduce_path};
    let stem = swept_recording();
    let reset = std::fs::write("/proc/self/clear_refs", "5").is_ok();
    let t = Instant::now();
    let r = reduce_path(
        &stem.with_extension("json"),
        ChannelChoice::default(),
        &ReductionOptions::default(),
        &hystid::observe::Silent,
    )
    .unwrap();
    let took = t.elapsed().as_secs_f64();
    let reading = r.sweep.unwrap();
    let (sweep, sigma) = (reading.sweep, reading.compensation_s);
    println!(
        "sweep: {} frames reduced to {} points (hop {:.3} periods) in {took:.2} s ({}; sweep \
         {:.3} -> {:.3} Hz, compensation {:.2} s)",
        sweep.end - sweep.start,
        r.frf.levels[0].points.len(),
        reading.hop_periods,
        if r.streamed {
            "read a stretch at a time"
        } else {
            "read whole"
        },
        sweep.f_start_hz,
        sweep.f_end_hz,
        sigma.unwrap_or(0.0)
    );
    match common::peak_rss_bytes() {
        Some(p) => println!(
            "sweep: peak RSS {:.1} MB (VmHWM{})",
            p as f64 / 1e6,
            if reset {
                ", reset before the reduction"
            } else {
                ", could not be reset: includes setup"
            }
        ),
        None => println!("sweep: peak RSS unavailable (no /proc/self/status)"),
    }
}

fn main() {
    if std::env::var_os("HYSTID_BENCH_RSS").is_some() {
        rss_mode();
        sweep_rss_mode();
        return;
    }
    let mut c = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .sample_size(10)
        .configure_from_args();
    bench_f16(&mut c);
    bench_stream(&mut c);
    c.final_summary();
}
