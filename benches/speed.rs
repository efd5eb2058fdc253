//! Speed benchmarks (criterion). Figures go to the README and closing notes.
use criterion::{Criterion, criterion_group, criterion_main};

fn placeholder(c: &mut Criterion) {
    c.bench_function("noop", |b| b.iter(|| std::hint::black_box(1.0f64).sqrt()));
}

criterion_group!(benches, placeholder);
criterion_main!(benches);
