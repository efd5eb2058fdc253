//! Speed benchmarks (criterion). Run `cargo bench --bench speed`; the figures
//! are reported in the README.
//!
//! Simulator throughput is in samples per second per core; a bare
//! second-order IIR loop measured in the same run is the practical ceiling.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use hystid::model::{Jenkins, Masing, ModalModel, Mode, NoElement};
use hystid::sim::{ModeFilter, Simulator};
use std::f64::consts::PI;
use std::hint::black_box;

const FS: f64 = 51200.0;
const N: usize = 1 << 16;

fn force(amplitude: f64) -> Vec<f64> {
    // 250 Hz: the paper-like system in its transition regime at 500 N
    (0..N)
        .map(|i| amplitude * (2.0 * PI * 250.0 * i as f64 / FS).cos())
        .collect()
}

fn simulator(c: &mut Criterion) {
    let model = ModalModel::sdof(10.0, 200.0, 1e7).unwrap();
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

    let mut lin = Simulator::new(&model, NoElement, FS).unwrap();
    g.bench_function("linear", |b| {
        b.iter(|| lin.run_displacement(black_box(&f), &mut out).unwrap())
    });
    let mut jen = Simulator::new(&model, Jenkins::new(2.4e7, 246.048).unwrap(), FS).unwrap();
    g.bench_function("jenkins", |b| {
        b.iter(|| jen.run_displacement(black_box(&f), &mut out).unwrap())
    });
    for n in [3.0, 22.55, 1000.0] {
        let mut mas = Simulator::new(&model, Masing::new(2.4e7, 246.048, n).unwrap(), FS).unwrap();
        g.bench_with_input(BenchmarkId::new("masing", n), &n, |b, _| {
            b.iter(|| mas.run_displacement(black_box(&f), &mut out).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, simulator);
criterion_main!(benches);
