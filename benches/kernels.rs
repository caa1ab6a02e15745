//! Criterion benches: one kernel evaluation (everything the linearly implicit step asks
//! for) and 30 steps of one strand, per N in 1, 2, 5, 10, 20, for the generic kernel and,
//! for every N that `superhelix::kernel_factory()` offers, the generated kernel (same
//! group, id `generated/N`): they are picked up automatically once they exist.
//! The stiffness projection of the step is benched on its own (`stiffness_projection`).
//! `cargo bench --bench kernels`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;
use superhelix::bench::{bench, BenchOptions};
use superhelix::runtime::config::KernelChoice;
use superhelix::runtime::kernels::kernel::{
    BodyField, EvalInput, StrandKernel, StrandTerms, Terms,
};
use superhelix::runtime::model::material::{helix_curvature, HelixForm, Preset};
use superhelix::runtime::model::strand::StrandGeometry;
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

/// The stiffness projection H ↦ H⁻ of the step at 3N = 15, 30, 60, on a matrix with
/// half its eigenvalues negative (as on the bench strand): the partial decomposition of
/// `superhelix_kernels::projection` (basis reuse off) against faer's full one.
fn stiffness_projection(c: &mut Criterion) {
    use faer::Mat;
    use superhelix_kernels::storage::heap::HeapProjection;
    let mut group = c.benchmark_group("stiffness_projection");
    for n in [15usize, 30, 60] {
        let mut state = 7u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let mut h = vec![0.0; n * n];
        for c in 0..n {
            for r in c..n {
                let x = next()
                    + if r == c {
                        c as f64 - n as f64 / 2.0
                    } else {
                        0.0
                    };
                h[c * n + r] = x;
                h[r * n + c] = x;
            }
        }
        let mut projection = HeapProjection::<f64>::new(n);
        let mut work = h.clone();
        group.bench_with_input(BenchmarkId::new("partial", n), &n, |b, _| {
            b.iter(|| {
                projection.forget_basis();
                work.copy_from_slice(&h);
                projection.negative_part(black_box(&mut work))
            })
        });
        let m = Mat::from_fn(n, n, |r, c| h[c * n + r]);
        group.bench_with_input(BenchmarkId::new("faer_full", n), &n, |b, _| {
            b.iter(|| {
                let eig = black_box(&m).self_adjoint_eigen(faer::Side::Lower);
                eig.map(|e| e.S()[0])
            })
        });
    }
    group.finish();
}

criterion_group!(benches, kernel_evaluation, full_step, stiffness_projection);
criterion_main!(benches);
