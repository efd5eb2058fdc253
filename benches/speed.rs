//! Per-core speed (criterion): `cargo bench --bench speed`.
//!
//! Every figure here is the **CPU time of the measuring thread**
//! ([`common::ThreadCpu`]), so it is what one core spends whatever else runs
//! on the machine; all work is single-threaded.
//!
//! Targets (from the project's issues):
//!
//! * `sim/*`: the digital-filter simulator on the paper system (m 10 kg,
//!   c 200 N s/m, k 1e7 N/m; Jenkins kd 2.4e7 N/m, Fd 246.048 N; Masing the
//!   same with N 3, 22.55, 1000), driven at 250 Hz, 500 N, 51.2 kHz:
//!   linear ≥ 150 M samples/s, Jenkins ≥ 50 M/s, Masing ≥ 15 M/s, each also
//!   read as a ratio to `sim/bare_iir_loop` (a bare second-order IIR loop,
//!   the practical ceiling) from the same run; Jenkins also to
//!   `sim/bare_iir_jenkins_loop` (the loop with the joint's closed-form
//!   implicit step written in, without placing transitions inside the
//!   sample), and `sim/jenkins_located` (transitions placed inside their
//!   samples, `Simulator::with_transitions_located`) to it: >= 0.6x. `sim/masing_formula` is the
//!   Masing element on the untabulated eq. (10) backbone, for comparison;
//!   `sim/model_element_set` the type the virtual test bench simulates
//!   (`ElementSet<AnyElement>` from a `Model`). `sim/bouc_wen/1`, `/2`, `/1.5`:
//!   the Bouc-Wen joint at its example shape, the exact flow (ν = 1) and
//!   the flow along the law's universal curve for a whole and a
//!   fractional exponent (target ≥ 10 M samples/s). `sim/iwan4`: Segalman's Iwan joint
//!   (χ = −0.5, β = 0.5) through the model's element set (target ≥ 15 M
//!   samples/s, as Masing).
//! * `hb/point_warm/*`: one converged, warm-started harmonic-balance point
//!   (Masing, harmonics {1, 3, 5}, 256 samples per period) ≤ 30 µs. Every
//!   point of the embedded default's 7 levels × 51 frequencies but the first
//!   of each level is solved from its neighbour's solution (as the fit's
//!   predictor does); the throughput is points per second.
//!   `hb/describing_function/*` solves the single-harmonic balance of the
//!   same points (the ratio asked for); `hb/point_warm/masing_formula` uses
//!   the untabulated backbone; `hb/point_warm/bouc_wen/1`, `/2` and `/1.5`
//!   the Bouc-Wen joint at its example shape, the exact flow and the
//!   universal curve for a whole and a fractional exponent (periods
//!   marched until its loop repeats; target ≤ 40 µs); `hb/point_warm/iwan4/0.5` the Iwan joint (target ≤ 40 µs).
//! * `hb/curve/jenkins/*` (issue 16's curve): the paper system with its
//!   Jenkins joint, harmonics 0..=7, 512 samples per period, 121 points
//!   150-350 Hz at 1 kN, each warm-started from its neighbour: `hystid`
//!   point by point (`HbSolver::solve_point`, as the fits call it),
//!   `hystid_sweep` through `HbSolver::sweep` (a tangent predictor along the
//!   branch), `naive` the textbook balance of `common/naive_hb.rs` (direct
//!   sums, the slider marched two periods, a Jacobian by differences) as the
//!   yardstick the ratio is read against. Both are checked to converge at
//!   every point and to agree on `H1` within 1e-3 before timing.
//! * `extract/*`: one coherent dwell of 4096 samples (4 blocks of 1024, 8
//!   periods each), harmonics 0..=7; the non-coherent least-squares
//!   reduction of the same samples for comparison.
//! * `record/mcap_write/one_level`: the longest level of the embedded default
//!   test (51 dwells, four channels) written to a run file as `hystid
//!   simulate` writes it (single-threaded zstd): ≥ 200 MB/s of file. The
//!   CPU time leaves out waiting for the disk (`finish` syncs the file);
//!   `cargo bench --bench pipeline -- record` has the wall time.
//! * `replay/f16_level/*` (issue 13): one whole F-16 sine-sweep level,
//!   108 477 samples at 400 Hz (a linear sweep 15 -> 2 Hz at 50 N, as the
//!   benchmark's), replayed as a time fit and `validate` replay it
//!   (`hystid::validate::simulate_response`: the band-limited drive, the
//!   acceleration) through the models the README fits to it: `masing`, the
//!   time-domain protocol's (three modes and the eq. (10) joint), and
//!   `iwan4_hysteretic_mode`, the walkthrough's (three modes, Segalman's
//!   Iwan joint at the drive point and the 6.3 Hz hysteretic mode with its
//!   Jenkins joint): ≤ 5 ms.

#[path = "common/mod.rs"]
mod common;
#[path = "common/naive_hb.rs"]
mod naive_hb;

use common::{C, FD, K, KD, M, ThreadCpu, bouc_wen_model, iwan4_model, masing_model, sdof};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use hystid::extract::{HarmonicAnalyser, noncoherent};
use hystid::hb::{HbOptions, HbSolver, describing};
use hystid::model::{
    AnyElement, BoucWen, ElementSet, Jenkins, Masing, Mode, Model, NoElement, PowerBackbone,
};
use hystid::sim::{ModeFilter, Simulator};
use hystid::testbench::TestDefinition;
use num_complex::Complex64;
use std::f64::consts::PI;
use std::hint::black_box;
use std::time::Duration;

const FS: f64 = 51200.0;
const N: usize = 1 << 16;

fn config() -> Criterion<ThreadCpu> {
    Criterion::default()
        .with_measurement(ThreadCpu)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(20)
}

fn force(amplitude: f64) -> Vec<f64> {
    // 250 Hz: the paper system in its transition regime at 500 N
    (0..N)
        .map(|i| amplitude * (2.0 * PI * 250.0 * i as f64 / FS).cos())
        .collect()
}

fn simulator(c: &mut Criterion<ThreadCpu>) {
    let model = sdof();
    let f = force(500.0);
    let mut out = vec![0.0; N];
    let mut g = c.benchmark_group("sim");
    g.throughput(Throughput::Elements(N as u64));

    let sec = ModeFilter::new(&Mode::from_mck(10.0, 200.0, 1e7).unwrap(), 1.0 / FS).displacement;
    g.bench_function("bare_iir_loop", |b| {
        b.iter(|| {
            let (mut y1, mut y2, mut u1, mut u2) = (0.0, 0.0, 0.0, 0.0);
            for (u, y) in black_box(&f).iter().zip(out.iter_mut()) {
                let v =
                    sec.b[0] * u + sec.b[1] * u1 + sec.b[2] * u2 - sec.a[0] * y1 - sec.a[1] * y2;
                (y2, y1, u2, u1) = (y1, v, u1, *u);
                *y = v;
            }
        })
    });

    // the same section with the Jenkins joint's closed-form implicit step
    // written in (stick, else slip; the slider at the sampled extremum): the
    // practical ceiling of `sim/jenkins`, which also places each slip
    // transition inside its sample (issue 16: >= 0.6x this loop)
    g.bench_function("bare_iir_jenkins_loop", |b| {
        b.iter(|| {
            let (mut y1, mut y2, mut u1, mut u2, mut slider) = (0.0, 0.0, 0.0, 0.0, 0.0);
            let gain = 1.0 / (1.0 + sec.b[0] * KD);
            for (f, y) in black_box(&f).iter().zip(out.iter_mut()) {
                let pred = sec.b[1] * u1 + sec.b[2] * u2 - sec.a[0] * y1 - sec.a[1] * y2;
                let x = (pred + sec.b[0] * (f + KD * slider)) * gain;
                let stick = KD * (x - slider);
                let u = if stick.abs() <= FD {
                    f - stick
                } else {
                    let s = stick.signum();
                    let x = pred + sec.b[0] * (f - s * FD);
                    slider = x - s * FD / KD;
                    f - s * FD
                };
                let x = pred + sec.b[0] * u;
                (y2, y1, u2, u1) = (y1, x, u1, u);
                *y = x;
            }
        })
    });

    let mut lin = Simulator::new(&model, NoElement, FS).unwrap();
    g.bench_function("linear", |b| {
        b.iter(|| lin.run_displacement(black_box(&f), &mut out).unwrap())
    });
    let mut jen = Simulator::new(&model, Jenkins::new(KD, FD).unwrap(), FS).unwrap();
    g.bench_function("jenkins", |b| {
        b.iter(|| jen.run_displacement(black_box(&f), &mut out).unwrap())
    });
    let mut located = Simulator::new(&model, Jenkins::new(KD, FD).unwrap(), FS)
        .unwrap()
        .with_transitions_located();
    g.bench_function("jenkins_located", |b| {
        b.iter(|| located.run_displacement(black_box(&f), &mut out).unwrap())
    });
    for n in [3.0, 22.55, 1000.0] {
        let mut mas = Simulator::new(&model, Masing::new(KD, FD, n).unwrap(), FS).unwrap();
        g.bench_with_input(BenchmarkId::new("masing", n), &n, |b, _| {
            b.iter(|| mas.run_displacement(black_box(&f), &mut out).unwrap())
        });
    }
    let formula = Masing::with_backbone(PowerBackbone::new(KD, FD, 22.55).unwrap());
    let mut mas = Simulator::new(&model, formula, FS).unwrap();
    g.bench_function("masing_formula/22.55", |b| {
        b.iter(|| mas.run_displacement(black_box(&f), &mut out).unwrap())
    });
    // Bouc-Wen at its example shape (softening to 240 N, near the paper's
    // slip force): the exact flow (ν = 1) and the general flow's short
    // steps and sub-steps (ν = 2: |z|^(ν−1) by multiplication; ν = 1.5: a
    // power per flow)
    for (nu, beta) in [
        (1.0, 1e5),
        (2.0, 2.4e7 / 240.0 / 240.0),
        (1.5, 2.4e7 / 240f64.powf(1.5)),
    ] {
        let bw = BoucWen::new(2.4e7, beta, 0.5, 0.5, nu).unwrap();
        let mut sim = Simulator::new(&model, bw, FS).unwrap();
        g.bench_with_input(BenchmarkId::new("bouc_wen", nu), &nu, |b, _| {
            b.iter(|| sim.run_displacement(black_box(&f), &mut out).unwrap())
        });
    }
    // Segalman's Iwan joint (the Masing element on its exact backbone)
    let iwan: ElementSet<AnyElement> = iwan4_model().element_set().unwrap();
    let mut sim = Simulator::new(&model, iwan, FS).unwrap();
    g.bench_function("iwan4", |b| {
        b.iter(|| sim.run_displacement(black_box(&f), &mut out).unwrap())
    });
    let set: ElementSet<AnyElement> = masing_model(22.55).element_set().unwrap();
    let mut any = Simulator::new(&model, set, FS).unwrap();
    g.bench_function("model_element_set/masing/22.55", |b| {
        b.iter(|| any.run_displacement(black_box(&f), &mut out).unwrap())
    });
    g.finish();
}

/// The converged solutions of the embedded default's grid, by sweeping.
fn converged_grid(
    model: &Model,
    opts: &HbOptions,
) -> (Vec<f64>, Vec<f64>, Vec<Vec<Vec<Complex64>>>) {
    let def = TestDefinition::embedded_default();
    let levels = def.test.levels_n.clone();
    let freqs = def.frequencies().unwrap();
    let sweeps = hystid::hb::frf_set_for_model(model, &levels, &freqs, opts).unwrap();
    let x = sweeps
        .iter()
        .map(|s| s.points.iter().map(|p| p.x.clone()).collect())
        .collect();
    let bad: usize = sweeps
        .iter()
        .map(|s| s.points.iter().filter(|p| !p.converged).count())
        .sum();
    assert_eq!(bad, 0, "every point of the grid converges");
    (levels, freqs, x)
}

fn harmonic_balance(c: &mut Criterion<ThreadCpu>) {
    let opts = HbOptions::default();
    assert_eq!(opts.harmonics, vec![1, 3, 5]);
    assert_eq!(opts.samples_per_period, 256);
    let mut g = c.benchmark_group("hb");
    for (name, n, formula) in [
        ("masing", 22.55, false),
        ("masing", 3.0, false),
        ("masing_formula", 22.55, true),
        ("bouc_wen", 1.0, false),
        ("bouc_wen", 2.0, false),
        ("bouc_wen", 1.5, false),
        ("iwan4", 0.5, false),
    ] {
        let model = match name {
            "bouc_wen" => bouc_wen_model(n),
            "iwan4" => iwan4_model(),
            _ => masing_model(n),
        };
        let (levels, freqs, x) = converged_grid(&model, &opts);
        let points = levels.len() * (freqs.len() - 1);
        g.throughput(Throughput::Elements(points as u64));
        let mut elements: ElementSet<AnyElement> = if formula {
            ElementSet::new(vec![AnyElement::Masing(Masing::with_backbone(
                PowerBackbone::new(KD, FD, n).unwrap(),
            ))])
        } else {
            model.element_set().unwrap()
        };
        // every point of the grid but each level's first, from its
        // neighbour's solution; how many did not converge
        let walk = |solver: &mut HbSolver, elements: &mut ElementSet<AnyElement>| {
            let mut unconverged = 0;
            for (l, &level) in levels.iter().enumerate() {
                for i in 1..freqs.len() {
                    let p = solver
                        .solve_point(&model.linear, elements, freqs[i], level, Some(&x[l][i - 1]))
                        .unwrap();
                    unconverged += !p.converged as usize;
                }
            }
            unconverged
        };
        // the work per point, free of the machine's load: AFT evaluations
        let mut solver = HbSolver::new(&opts).unwrap();
        walk(&mut solver, &mut elements);
        eprintln!(
            "hb/point_warm/{name}/{n}: {:.2} AFT evaluations per point",
            solver.evaluations() as f64 / points as f64
        );
        let mut solver = HbSolver::new(&opts).unwrap();
        let mut unconverged = 0;
        g.bench_function(BenchmarkId::new(format!("point_warm/{name}"), n), |b| {
            b.iter(|| unconverged += walk(&mut solver, &mut elements))
        });
        assert_eq!(unconverged, 0, "warm-started points converge");
        if formula {
            continue;
        }
        let mut elements = model.element_set().unwrap();
        let ns = opts.samples_per_period;
        g.bench_function(
            BenchmarkId::new(format!("describing_function/{name}"), n),
            |b| {
                b.iter(|| {
                    let mut roots = 0;
                    for &level in &levels {
                        for &f in &freqs[1..] {
                            let w = 2.0 * PI * f;
                            let h1 = model.linear.receptance(w);
                            roots += describing::solve(h1, level, |a| {
                                describing::of_elements(&mut elements, a, w, ns)
                            })
                            .len();
                        }
                    }
                    roots
                })
            },
        );
    }
    g.finish();
}

/// Issue 16's curve: the paper system with its Jenkins joint, harmonics
/// 0..=7, 512 samples per period, 121 points from 150 to 350 Hz at 1 kN,
/// each point warm-started from its neighbour's solution (a sweep), the
/// first from none; solved by hystid and by the naive harmonic balance of
/// `common/naive_hb.rs`. Both must converge at every point and agree on
/// `H1`.
fn hb_curve(c: &mut Criterion<ThreadCpu>) {
    const POINTS: usize = 121;
    const LEVEL: f64 = 1000.0;
    let freqs: Vec<f64> = (0..POINTS)
        .map(|i| 150.0 + 200.0 * i as f64 / (POINTS - 1) as f64)
        .collect();
    let opts = HbOptions {
        harmonics: (0..=7).collect(),
        samples_per_period: 512,
        ..HbOptions::default()
    };
    let model = Model::new(
        sdof(),
        vec![hystid::model::ElementSpec::Jenkins { kd: KD, fd: FD }],
    )
    .unwrap();
    let mut elements = model.element_set().unwrap();
    let mut solver = HbSolver::new(&opts).unwrap();
    let mut hystid_sweep = |solver: &mut HbSolver| -> Vec<Complex64> {
        let mut last: Option<Vec<Complex64>> = None;
        let mut h1 = Vec::with_capacity(POINTS);
        for &f in &freqs {
            let p = solver
                .solve_point(&model.linear, &mut elements, f, LEVEL, last.as_deref())
                .unwrap();
            assert!(p.converged, "hystid at {f} Hz: {:?}", p.failure);
            h1.push(p.h[1]);
            last = Some(p.x);
        }
        h1
    };
    let mut naive = naive_hb::NaiveHb::new(M, C, K, KD, FD, 7, 512);
    let naive_sweep = |naive: &mut naive_hb::NaiveHb| -> Vec<Complex64> {
        let mut x = vec![0.0; naive.unknowns()];
        let mut h1 = Vec::with_capacity(POINTS);
        for (i, &f) in freqs.iter().enumerate() {
            if i == 0 {
                // the linear response with the joint stuck
                let w = 2.0 * PI * f;
                let z = LEVEL / Complex64::new(K + KD - M * w * w, C * w);
                x[1] = z.re;
                x[2] = z.im;
            }
            let it = naive.solve(f, LEVEL, &mut x, opts.tolerance);
            assert!(it.is_some(), "naive at {f} Hz did not converge");
            h1.push(naive_hb::NaiveHb::harmonic(&x, 1) / LEVEL);
        }
        h1
    };
    let (a, b) = (hystid_sweep(&mut solver), naive_sweep(&mut naive));
    let worst = a
        .iter()
        .zip(&b)
        .map(|(a, b)| (a - b).norm() / a.norm())
        .fold(0.0, f64::max);
    println!(
        "hb/curve: hystid and the naive balance agree on H1 within {worst:.1e}; hystid: {:.1} \
         AFT evaluations per point",
        solver.evaluations() as f64 / POINTS as f64
    );
    assert!(worst < 1e-3, "H1 differs by {worst:.1e}");
    // the ratios from interleaved runs (each the least CPU time of 15), so
    // that a load that changes between criterion's groups does not enter
    let mut elements_sweep = model.element_set().unwrap();
    let (mut point, mut swept, mut plain) = (u64::MAX, u64::MAX, u64::MAX);
    for _ in 0..15 {
        let t = common::thread_cpu_ns();
        black_box(hystid_sweep(&mut solver));
        point = point.min(common::thread_cpu_ns() - t);
        let t = common::thread_cpu_ns();
        black_box(
            solver
                .sweep(&model.linear, &mut elements_sweep, &freqs, LEVEL)
                .unwrap(),
        );
        swept = swept.min(common::thread_cpu_ns() - t);
        let t = common::thread_cpu_ns();
        black_box(naive_sweep(&mut naive));
        plain = plain.min(common::thread_cpu_ns() - t);
    }
    let per_point = |ns: u64| ns as f64 / 1e3 / POINTS as f64;
    println!(
        "hb/curve: interleaved (least of 15, CPU time): point by point {:.1} us, the sweep {:.1} \
         us, the naive balance {:.1} us per point: {:.1}x / {:.1}x the naive",
        per_point(point),
        per_point(swept),
        per_point(plain),
        plain as f64 / point as f64,
        plain as f64 / swept as f64
    );
    let mut g = c.benchmark_group("hb");
    g.throughput(Throughput::Elements(POINTS as u64));
    g.bench_function("curve/jenkins/hystid", |b| {
        b.iter(|| black_box(hystid_sweep(&mut solver)))
    });
    // the same curve through the solver's sweep (a tangent predictor
    // along the branch, folds watched)
    let mut elements = model.element_set().unwrap();
    let swept = solver
        .sweep(&model.linear, &mut elements, &freqs, LEVEL)
        .unwrap();
    assert!(swept.points.iter().all(|p| p.converged));
    println!(
        "hb/curve: the sweep takes {:.1} AFT evaluations per point",
        swept.evaluations as f64 / POINTS as f64
    );
    g.bench_function("curve/jenkins/hystid_sweep", |b| {
        b.iter(|| {
            black_box(
                solver
                    .sweep(&model.linear, &mut elements, &freqs, LEVEL)
                    .unwrap(),
            )
        })
    });
    g.bench_function("curve/jenkins/naive", |b| {
        b.iter(|| black_box(naive_sweep(&mut naive)))
    });
    g.finish();
}

fn extraction(c: &mut Criterion<ThreadCpu>) {
    // 30 kHz (the default test's rate), 8 periods in 1024 samples
    let fs = 30000.0;
    let (block, q, blocks, k) = (1024, 8, 4, 7);
    let f0 = q as f64 * fs / block as f64;
    let n = block * blocks;
    let force: Vec<f64> = (0..n)
        .map(|i| 500.0 * (2.0 * PI * f0 * i as f64 / fs).cos())
        .collect();
    let response: Vec<f64> = (0..n)
        .map(|i| {
            let t = 2.0 * PI * f0 * i as f64 / fs;
            1e-5 * (t - 0.3).cos() + 2e-7 * (3.0 * t).sin() + 1e-8 * ((i * 7919) % 101) as f64
        })
        .collect();
    let mut g = c.benchmark_group("extract");
    g.throughput(Throughput::Elements(n as u64));
    let mut analyser = HarmonicAnalyser::new();
    g.bench_function("coherent_dwell/4096", |b| {
        b.iter(|| {
            analyser
                .coherent(black_box(&force), black_box(&response), block, q, k)
                .unwrap()
        })
    });
    g.bench_function("noncoherent_dwell/4096", |b| {
        b.iter(|| noncoherent(black_box(&force), black_box(&response), fs, f0, k, blocks).unwrap())
    });
    g.finish();
}

fn recording(c: &mut Criterion<ThreadCpu>) {
    if !common::wanted("record") {
        return;
    }
    let (level, fs) = common::default_level();
    let dwells = common::dwell_signals(&level);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    common::write_mcap(&path, fs, &dwells);
    let bytes = std::fs::metadata(&path).unwrap().len();
    let mut g = c.benchmark_group("record");
    g.sample_size(10)
        .throughput(Throughput::BytesDecimal(bytes));
    g.bench_function("mcap_write/one_level", |b| {
        b.iter(|| common::write_mcap(&path, fs, &dwells))
    });
    g.finish();
}

/// One F-16 sweep level replayed through the models fitted to it (see
/// the module docs).
fn replay(c: &mut Criterion<ThreadCpu>) {
    let model = |name: &str, text: &str| {
        hystid::testbench::StructureDefinition::from_toml(text, name)
            .and_then(|d| d.model())
            .expect(name)
    };
    // as fitted, to five figures
    let masing = model(
        "the protocol's model",
        r#"
[[modes]]
frequency_hz = 6.4812
damping_ratio = 0.0022805
residue = 0.0025028
[[modes]]
frequency_hz = 4.6438
damping_ratio = 0.012022
residue = 0.0021905
[[modes]]
frequency_hz = 8.9067
damping_ratio = 0.010193
residue = 0.00056116
[joint]
kind = "masing"
kd = 1.5325e5
fd = 324.14
n = 1.9273
"#,
    );
    let walkthrough = model(
        "the walkthrough's model",
        r#"
[[modes]]
frequency_hz = 6.7583
damping_ratio = 0.0016973
residue = 0.0028575
[[modes]]
frequency_hz = 4.8713
damping_ratio = 0.010484
residue = 0.0015967
[[modes]]
frequency_hz = 8.9397
damping_ratio = 0.010440
residue = 0.00081310
[[modes]]
frequency_hz = 6.2838
damping_ratio = 0.0068945
residue = 0.00062761
joint = { kind = "jenkins", kd = 2.9954e5, fd = 49.094 }
[joint]
kind = "iwan4"
fs = 113.34
kt = 1.0995e5
chi = -0.0100001
beta = 1.0879
"#,
    );
    let fs = 400.0;
    let n = 108_477;
    let duration = n as f64 / fs;
    let rate = -13.0 / duration;
    let force: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 / fs;
            50.0 * (2.0 * PI * (15.0 * t + 0.5 * rate * t * t)).sin()
        })
        .collect();
    let replayed = |m: &Model, f: &[f64]| {
        hystid::validate::simulate_response(
            m,
            f,
            fs,
            hystid::harmonics::Quantity::Acceleration,
            1.0,
            40.0,
        )
        .unwrap()
    };
    let mut g = c.benchmark_group("replay");
    g.throughput(Throughput::Elements(n as u64));
    for (name, m) in [("masing", &masing), ("iwan4_hysteretic_mode", &walkthrough)] {
        // no upsampling at this rate: the replay is the level's own samples
        assert_eq!(replayed(m, &force).values.len(), n);
        g.bench_function(format!("f16_level/{name}"), |b| {
            b.iter(|| replayed(m, black_box(&force)))
        });
        // the simulator alone on the same samples (no drive made
        // band-limited, no stretches)
        let mut sim = Simulator::new(&m.linear, m.element_set().unwrap(), fs).unwrap();
        let mut out = vec![0.0; n];
        g.bench_function(format!("f16_level_simulator/{name}"), |b| {
            b.iter(|| {
                sim.reset();
                sim.run_output(
                    black_box(&force),
                    hystid::sim::Output::Acceleration,
                    &mut out,
                    &hystid::observe::Silent,
                )
                .unwrap()
            })
        });
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = config();
    targets = simulator, harmonic_balance, hb_curve, extraction, recording, replay
}
criterion_main!(benches);
