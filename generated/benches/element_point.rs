//! Criterion bench of one `ElementPoint` evaluation: the generated closed form
//! (`superhelix_generated::element_point_into`) against the runtime's reference
//! `ElementPoint::by_jets`, at W u = 0.1 (Taylor branch) and W u = 5 (closed branch);
//! and group `rotary_points_16`: the rotary quadrature's points at 16 (element,
//! abscissa) pairs, four abscissae of one element per call (`element_rotary_points_into`)
//! against one abscissa of each of W elements per call (`element_rotary_points_lanes`,
//! W = 4 and 8, compiled with AVX2 as a step on lanes would be).
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

/// 16 points of the rotary quadrature at W u = 0.5 and 5: four elements × four
/// abscissae, by element (four abscissae per call) and by lanes of elements.
fn rotary_points(c: &mut Criterion) {
    use superhelix_generated::element_rotary_point::element_rotary_points_lanes;
    use superhelix_generated::element_rotary_points_into;
    use superhelix_generated::kernels::element::{LaneRotaryPoints, RotaryPoints};
    use superhelix_generated::kernels::lane::Lanes;

    /// `n` calls at width W compiled with AVX2 (the bench's caller is not).
    #[target_feature(enable = "avx2")]
    fn lanes_avx2<const W: usize>(
        inputs: &[([Lanes<f64, W>; 3], Lanes<f64, W>)],
        out: &mut LaneRotaryPoints<W>,
    ) -> f64 {
        let mut sum = 0.0;
        for (d, u) in inputs {
            element_rotary_points_lanes(d, *u, out);
            sum += out.dw[2][2][2].0[0];
        }
        sum
    }

    let mut group = c.benchmark_group("rotary_points_16");
    for wu in [0.5, 5.0] {
        let elements: Vec<(Vector3<f64>, f64)> = (0..4)
            .map(|e| {
                let l = 0.04 + 0.002 * e as f64;
                let dir = Vector3::new(0.3, -0.8 + 0.1 * e as f64, 0.5).normalize();
                (dir * (wu / l), l)
            })
            .collect();
        let fractions = [0.07, 0.33, 0.67, 0.93];
        let mut by_element = RotaryPoints::default();
        group.bench_with_input(BenchmarkId::new("by_element", wu), &wu, |b, _| {
            b.iter(|| {
                let mut sum = 0.0;
                for (d, l) in &elements {
                    let u = fractions.map(|f| f * l);
                    element_rotary_points_into(black_box(d), &u, &mut by_element);
                    sum += by_element.dw[2][2][2].0[0];
                }
                black_box(sum)
            })
        });
        // the same 16 pairs, W elements per call
        let pairs: Vec<(Vector3<f64>, f64)> = fractions
            .iter()
            .flat_map(|f| elements.iter().map(move |(d, l)| (*d, f * l)))
            .collect();
        macro_rules! width {
            ($w:literal) => {{
                let inputs: Vec<([Lanes<f64, $w>; 3], Lanes<f64, $w>)> = pairs
                    .chunks($w)
                    .map(|c| {
                        (
                            [0, 1, 2].map(|i| Lanes(core::array::from_fn(|k| c[k].0[i]))),
                            Lanes(core::array::from_fn(|k| c[k].1)),
                        )
                    })
                    .collect();
                let mut out = LaneRotaryPoints::<$w>::default();
                group.bench_with_input(BenchmarkId::new(concat!("lanes_", $w), wu), &wu, |b, _| {
                    // SAFETY: run only where the CPU has AVX2
                    b.iter(|| black_box(unsafe { lanes_avx2(black_box(&inputs), &mut out) }))
                });
            }};
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            width!(4);
            width!(8);
        }
    }
    group.finish();
}

criterion_group!(benches, element_point, rotary_points);
criterion_main!(benches);
