//! Whole stages on the machine's cores (criterion, wall time):
//! `cargo bench --bench pipeline`.
//!
//! Targets (from the project's issues; the reference machine has 2 cores):
//!
//! * `testbench/run/embedded_default`: the embedded default virtual test
//!   (7 levels × 51 frequencies, Jenkins joint, 30 kHz) simulated and
//!   extracted, nothing written (`NoSink`). Part of the ≤ 3 s wall budget of
//!   `hystid simulate --out DIR` (simulate, extract, record; peak memory
//!   ≤ 500 MB, measured outside criterion: see the report).
//! * `record/mcap_write`, `record/wav_write`: one level of the default test
//!   (its four channels) written as the simulate command writes it;
//!   throughput is the file's bytes per second. MCAP ≥ 200 MB/s.
//! * `hb/frf_set_for_model/*`: the full 7-level × 51-frequency FRF set of
//!   the paper system with a Masing joint (harmonics {1, 3, 5}, 256
//!   samples per period), levels in parallel: ≤ 20 ms on 2 cores.
//! * `fit/identify/embedded_default`: the fit alone (Masing, the default
//!   options, harmonic-balance predictor) on the FRFs of the embedded
//!   default test: ≤ 5 s on 2 cores; the whole `hystid run` ≤ 10 s is
//!   timed outside criterion. The number of cost evaluations and the time
//!   per evaluation are printed once before the measurement.
//!
//! Every case runs 10 samples; the fit takes about a minute.

#[path = "common/mod.rs"]
mod common;

use common::masing_model;
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use hystid::fit::{FitOptions, HbPredictor, identify};
use hystid::hb::{HbOptions, frf_set_for_model};
use hystid::record::{Excitation, ExcitationKind, FORMAT_V1, RecordingMeta, RecordingWriter};
use hystid::testbench::{self, NoSink, TestDefinition};
use std::time::Duration;

fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(3))
        .sample_size(10)
}

fn bench_run(c: &mut Criterion) {
    if !common::wanted("testbench") {
        return;
    }
    let def = TestDefinition::embedded_default();
    let run = testbench::run(&def, &mut NoSink, &hystid::observe::Silent).unwrap();
    eprintln!(
        "testbench: {} dwells, {} frames, {} threads",
        run.dwells.len(),
        run.frames,
        rayon::current_num_threads()
    );
    let mut g = c.benchmark_group("testbench");
    g.throughput(Throughput::Elements(run.frames));
    g.bench_function("run/embedded_default", |b| {
        b.iter(|| testbench::run(&def, &mut NoSink, &hystid::observe::Silent).unwrap())
    });
    g.finish();
}

fn bench_record(c: &mut Criterion) {
    if !common::wanted("record") {
        return;
    }
    let (level, fs) = common::default_level();
    let dwells = common::dwell_signals(&level);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let write_mcap = || common::write_mcap(&path, fs, &dwells);
    write_mcap();
    let bytes = std::fs::metadata(&path).unwrap().len();
    eprintln!(
        "record: one level, {} dwells, {} frames; run.mcap {} bytes",
        dwells.len(),
        level.force.len(),
        bytes
    );
    let mut g = c.benchmark_group("record");
    g.throughput(Throughput::BytesDecimal(bytes));
    g.bench_function("mcap_write/one_level", |b| b.iter(write_mcap));
    let meta = RecordingMeta {
        format: FORMAT_V1.into(),
        sample_rate_hz: fs,
        channels: hystid::testbench::recorded_channels(hystid::harmonics::Quantity::Force),
        excitation: Excitation {
            kind: ExcitationKind::SteppedSine,
            steps: Vec::new(),
            sweep: None,
        },
        description: "bench".into(),
        metadata: Default::default(),
        extra: Default::default(),
        chosen_reference: None,
    };
    let stem = dir.path().join("recording");
    let write_wav = || {
        let mut w = RecordingWriter::create(&stem, meta.clone()).unwrap();
        w.write_frames(&[
            &level.force,
            &level.displacement,
            &level.velocity,
            &level.acceleration,
        ])
        .unwrap();
        w.finish().unwrap();
    };
    write_wav();
    let wav_bytes = std::fs::metadata(dir.path().join("recording.wav"))
        .unwrap()
        .len();
    g.throughput(Throughput::BytesDecimal(wav_bytes));
    g.bench_function("wav_write/one_level", |b| b.iter(write_wav));
    g.finish();
}

fn bench_hb(c: &mut Criterion) {
    if !common::wanted("hb") {
        return;
    }
    let def = TestDefinition::embedded_default();
    let levels = def.test.levels_n.clone();
    let freqs = def.frequencies().unwrap();
    let opts = HbOptions::default();
    let mut g = c.benchmark_group("hb");
    g.throughput(Throughput::Elements((levels.len() * freqs.len()) as u64));
    for n in [22.55, 3.0] {
        let model = masing_model(n);
        let set = frf_set_for_model(&model, &levels, &freqs, &opts).unwrap();
        let evals: u64 = set.iter().map(|s| s.evaluations).sum();
        let unconverged: usize = set
            .iter()
            .map(|s| s.points.iter().filter(|p| !p.converged).count())
            .sum();
        eprintln!("hb: masing N {n}: {evals} AFT evaluations, {unconverged} points unconverged");
        g.bench_with_input(
            BenchmarkId::new("frf_set_for_model/masing", n),
            &n,
            |b, _| b.iter(|| frf_set_for_model(&model, &levels, &freqs, &opts).unwrap()),
        );
    }
    g.finish();
}

fn bench_fit(c: &mut Criterion) {
    if !common::wanted("fit") {
        return;
    }
    let def = TestDefinition::embedded_default();
    let run = testbench::run(&def, &mut NoSink, &hystid::observe::Silent).unwrap();
    let options = FitOptions::default();
    let predictor = HbPredictor::default();
    let fit = identify(&run.frf, &options, &predictor, None).unwrap();
    eprintln!(
        "fit: {} cost evaluations, {} HB points, {:.2} s, {:.2} ms per evaluation",
        fit.effort.evaluations,
        fit.effort.hb_points,
        fit.effort.seconds,
        fit.effort.ms_per_evaluation
    );
    let mut g = c.benchmark_group("fit");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(1))
        .measurement_time(Duration::from_secs(10));
    g.bench_function("identify/embedded_default", |b| {
        b.iter(|| identify(&run.frf, &options, &predictor, None).unwrap())
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = config();
    targets = bench_run, bench_record, bench_hb, bench_fit
}
criterion_main!(benches);
