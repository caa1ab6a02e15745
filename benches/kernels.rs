//! Criterion benches: one kernel evaluation (everything the linearly implicit step asks
//! for) and 30 steps of one strand, per N in 1, 2, 5, 10, 20, for the generic kernel and,
//! for every N that `superhelix::kernel_factory()` offers, the generated kernel (same
//! group, id `generated/N`): they are picked up automatically once they exist.
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

/// The kernels benched for a geometry: the generic one (adaptive rule) and, when
/// `superhelix::kernel_factory()` offers this N, the generated one.
fn kernels(g: &StrandGeometry) -> Vec<(&'static str, Box<dyn StrandKernel>)> {
    let mut kernels: Vec<(&'static str, Box<dyn StrandKernel>)> = vec![(
        "generic",
        Box::new(GenericKernel::new(g.clone(), QuadratureRule::Adaptive)),
    )];
    if let Some(k) = superhelix::kernel_factory().and_then(|f| f.create(g)) {
        kernels.push(("generated", k));
    }
    kernels
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
        for (name, mut kernel) in kernels(&g) {
            group.bench_with_input(BenchmarkId::new(name, n), &n, |b, _| {
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
    }
    group.finish();
}

fn full_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("step_one_strand");
    group.sample_size(10);
    let generated = superhelix::kernel_factory()
        .map(|f| f.available())
        .unwrap_or_default();
    for n in NS {
        let mut choices = vec![KernelChoice::Generic];
        if generated.contains(&n) {
            choices.push(KernelChoice::Generated);
        }
        for kernels in choices {
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
    }
    group.finish();
}

criterion_group!(benches, kernel_evaluation, full_step);
criterion_main!(benches);
