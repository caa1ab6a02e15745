//! Criterion bench: the closed-form element moments against the generic path's
//! quadrature (`ElementMoments::by_quadrature` at its adaptive order 8 + ⌈1.5 W l⌉), at
//! W l = 0.1 (Taylor branches), 3 and 30; and 16 elements' moments by the batch
//! (`element_moments_batch_into`, four lanes at a time) against W lanes at once
//! (`lane_moments::element_moments_lanes_into`, W = 4, 8, 16: element k of W strands).
//! `cargo bench -p superhelix-generated --bench element_moments`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;
use std::time::Duration;
use superhelix_runtime::kernels::moments::ElementMoments;
use superhelix_runtime::Vector3;

const WLS: [f64; 3] = [0.1, 3.0, 30.0];

fn case(wl: f64) -> (Vector3<f64>, f64, [f64; 3]) {
    let l = 0.02;
    let d = Vector3::new(0.3, -0.8, 0.5).normalize() * (wl / l);
    (d, l, [2.0e-9, 0.8e-9, 1.2e-9])
}

fn element_moments(c: &mut Criterion) {
    let mut group = c.benchmark_group("element_moments");
    group
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(40);
    for wl in WLS {
        let (d, l, rotary) = case(wl);
        let mut out = ElementMoments::default();
        group.bench_with_input(BenchmarkId::new("closed_all_fields", wl), &wl, |b, _| {
            b.iter(|| {
                superhelix_generated::element_moments_into(black_box(&d), l, &rotary, &mut out);
                black_box(out.dpd2p[0][0][0])
            })
        });
        group.bench_with_input(BenchmarkId::new("closed_mass_fields", wl), &wl, |b, _| {
            b.iter(|| {
                black_box(superhelix_generated::mass_moments(
                    black_box(&d),
                    l,
                    &rotary,
                ))
            })
        });
        let points = 8 + (1.5 * wl).ceil() as usize;
        group.bench_with_input(
            BenchmarkId::new(format!("quadrature_{points}_points"), wl),
            &wl,
            |b, _| {
                b.iter(|| {
                    black_box(ElementMoments::by_quadrature(
                        black_box(&d),
                        l,
                        &rotary,
                        points,
                    ))
                })
            },
        );
        let dd = [d[0], d[1], d[2]];
        let mut om = [0.0; 51];
        let mut of = [0.0; 135];
        let mut or = [0.0; 63];
        group.bench_with_input(BenchmarkId::new("centreline_mass", wl), &wl, |b, _| {
            b.iter(|| superhelix_generated::centreline_mass(black_box(&dd), l, &mut om))
        });
        group.bench_with_input(BenchmarkId::new("centreline_force", wl), &wl, |b, _| {
            b.iter(|| superhelix_generated::centreline_force(black_box(&dd), l, &mut of))
        });
        group.bench_with_input(BenchmarkId::new("rotary_basis", wl), &wl, |b, _| {
            b.iter(|| superhelix_generated::rotary_basis(black_box(&dd), l, &mut or))
        });
    }
    group.finish();
}

/// 16 elements in the closed-form branch (W l = 3 and 30): the batch, four lanes at a
/// time with the fields filled, against lanes of width 4, 8 and 16 (outputs left in
/// lanes, as a step in lanes reads them).
fn lanes(c: &mut Criterion) {
    use superhelix_generated::kernels::lane::Lanes;
    use superhelix_generated::lane_moments::{element_moments_lanes_into, LaneMoments, LaneParts};
    let mut group = c.benchmark_group("moments_16_elements");
    group
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(40);
    for wl in [3.0, 30.0] {
        let elements: Vec<(Vector3<f64>, f64)> = (0..16)
            .map(|k| {
                let l = 0.02 + 0.001 * k as f64;
                let dir = Vector3::new(0.3, -0.8 + 0.05 * k as f64, 0.5).normalize();
                (dir * (wl * (1.0 + 0.02 * k as f64) / l), l)
            })
            .collect();
        let rotary = [2.0e-9, 0.8e-9, 1.2e-9];
        let d: Vec<Vector3<f64>> = elements.iter().map(|e| e.0).collect();
        let l: Vec<f64> = elements.iter().map(|e| e.1).collect();
        let mut out = vec![ElementMoments::default(); 16];
        group.bench_with_input(BenchmarkId::new("batch", wl), &wl, |b, _| {
            b.iter(|| {
                superhelix_generated::element_moments_batch_into(
                    black_box(&d),
                    &l,
                    &rotary,
                    &mut out,
                );
                black_box(out[15].dpd2p[0][0][0])
            })
        });
        macro_rules! width {
            ($w:literal) => {{
                let chunks: Vec<([Lanes<f64, $w>; 3], Lanes<f64, $w>)> = elements
                    .chunks($w)
                    .map(|c| {
                        (
                            [0, 1, 2].map(|i| Lanes(core::array::from_fn(|k| c[k].0[i]))),
                            Lanes(core::array::from_fn(|k| c[k].1)),
                        )
                    })
                    .collect();
                let mut out = LaneMoments::<$w>::default();
                group.bench_with_input(BenchmarkId::new(concat!("lanes_", $w), wl), &wl, |b, _| {
                    b.iter(|| {
                        for (d, l) in &chunks {
                            element_moments_lanes_into(black_box(d), *l, LaneParts::ALL, &mut out);
                        }
                        black_box(out.force[134].0[0])
                    })
                });
            }};
        }
        width!(4);
        width!(8);
        width!(16);
    }
    group.finish();
}

criterion_group!(benches, element_moments, lanes);
criterion_main!(benches);
