//! Criterion benchmarks of the multipole method and the direct sum, one thread:
//! `cargo bench -p superhelix-fmm --bench coulomb`.

use criterion::{criterion_group, criterion_main, Criterion};
use superhelix_fmm::samples::curly_fibres;
use superhelix_fmm::{direct_sum, Fmm, FmmOptions, Softening};

fn bench(c: &mut Criterion) {
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let (points, q) = curly_fibres(200, 100, 1);
    for eps in [1e-3, 1e-6] {
        let mut fmm = Fmm::new(FmmOptions::for_accuracy(eps).expect("eps")).expect("options");
        c.bench_function(&format!("fmm/20000_hair_like/eps_{eps:e}"), |b| {
            b.iter(|| one.install(|| fmm.evaluate(&points, &q).expect("evaluate")))
        });
    }
    let (p, q) = curly_fibres(50, 100, 2);
    c.bench_function("direct/5000", |b| {
        b.iter(|| one.install(|| direct_sum(&p, &q, Softening::NONE)))
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench
}
criterion_main!(benches);
