//! Criterion benches: one kernel evaluation (everything the linearly implicit step asks
//! for) and one full step, per N, for each kernel path available in this build.
//! `cargo bench --bench kernels`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;
use superhelix::bench::{bench, BenchOptions};
use superhelix::runtime::kernel::{BodyField, EvalInput, StrandKernel, StrandTerms, Terms};
use superhelix::runtime::material::{helix_curvature, HelixForm, Preset};
use superhelix::runtime::simulation::KernelChoice;
use superhelix::runtime::strand::StrandGeometry;
use superhelix::runtime::{GenericKernel, Matrix3, QuadratureRule, Vector3};

const NS: [usize; 5] = [1, 2, 5, 10, 20];

fn wavy(n: usize) -> (StrandGeometry, Vec<f64>) {
    let p = Preset::Wavy.params();
    let material = p.cross_section.material();
    let natural = helix_curvature(p.helix_radius, p.helix_step, HelixForm::Exact);
    let g = StrandGeometry::new(
        Vector3::zeros(),
        Matrix3::identity(),
        vec![0.2 / n as f64; n],
        &material,
    );
    (g, (0..n).flat_map(|_| natural).collect())
}

fn kernel_evaluation(c: &mut Criterion) {
    let mut group = c.benchmark_group("evaluate_all_terms");
    for n in NS {
        let (g, q) = wavy(n);
        let v: Vec<f64> = (0..3 * n).map(|i| 0.1 * i as f64).collect();
        let field = BodyField {
            uniform: Vector3::new(0.0, 0.0, -9.81e-5),
            linear: Matrix3::zeros(),
            velocity: -Matrix3::identity() * 1e-5,
        };
        let mut out = StrandTerms::new(3 * n);
        let mut kernel = GenericKernel::new(g, QuadratureRule::Adaptive);
        group.bench_with_input(BenchmarkId::new("generic", n), &n, |b, _| {
            b.iter(|| {
                kernel.evaluate(
                    &EvalInput {
                        q: black_box(&q),
                        v: &v,
                        field,
                        terms: Terms::all(),
                    },
                    &mut out,
                );
                black_box(out.force[0])
            })
        });
    }
    group.finish();
}

fn full_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("step_one_strand");
    group.sample_size(10);
    // the generated kernels join here when they exist (issue #3)
    let kernels = KernelChoice::Generic;
    for n in NS {
        let options = BenchOptions {
            elements: n,
            strands: 1,
            steps: 30,
            kernels,
            ..BenchOptions::default()
        };
        group.bench_with_input(BenchmarkId::new(kernels.name(), n), &n, |b, _| {
            b.iter(|| bench(black_box(&options)).map(|r| r.strand_steps_per_second))
        });
    }
    group.finish();
}

criterion_group!(benches, kernel_evaluation, full_step);
criterion_main!(benches);
