//! Criterion bench of one `ElementPoint` evaluation: the generated closed form
//! (`superhelix_generated::element_point_into`) against the runtime's reference
//! `ElementPoint::by_jets`, at W u = 0.1 (Taylor branch) and W u = 5 (closed branch).
//! `cargo bench -p superhelix-generated --bench element_point`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;
use superhelix_generated::element_point_into;
use superhelix_runtime::model::element::ElementPoint;
use superhelix_runtime::Vector3;

fn element_point(c: &mut Criterion) {
    let mut group = c.benchmark_group("element_point");
    let u = 0.02;
    let dir = Vector3::new(0.3, -0.8, 0.5).normalize();
    for wu in [0.1, 5.0] {
        let d = dir * (wu / u);
        let mut out = ElementPoint::default();
        group.bench_with_input(BenchmarkId::new("generated", wu), &wu, |b, _| {
            b.iter(|| {
                element_point_into(black_box(&d), black_box(u), &mut out);
                black_box(&out);
            })
        });
        group.bench_with_input(BenchmarkId::new("by_jets", wu), &wu, |b, _| {
            b.iter(|| black_box(ElementPoint::by_jets(black_box(&d), black_box(u))))
        });
    }
    group.finish();
}

criterion_group!(benches, element_point);
criterion_main!(benches);
