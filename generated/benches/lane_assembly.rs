//! The O(N²) assembly of the step on lanes: the suffix bodies and M, the Gram matrix and
//! the gravity force (`moments::suffix_bodies`, `moments::assemble_mass_gram_and_gravity`)
//! of 4 strands of N = 5, one at a time against once on `Lanes<f64, 4>` (the same code
//! over `Arith`, compiled with AVX2), on four moving helical strands.
//! `cargo bench -p superhelix-generated --bench lane_assembly`.

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{Matrix3, Vector3};
use std::hint::black_box;
use std::time::Duration;
use superhelix_generated::ClosedForm;
use superhelix_kernels::lane::soa::Soa;
use superhelix_kernels::lane::Lanes;
use superhelix_kernels::material::helix_curvature;
use superhelix_kernels::moments::jacobians::VelocityRow;
use superhelix_kernels::moments::rotary::RotaryElement;
use superhelix_kernels::moments::{
    assemble_mass_gram_and_gravity, frame_motions, suffix_bodies, ElementMoments, EndDerivatives,
    FrameMotion, SuffixBody,
};
use superhelix_kernels::strand_terms::{prepare, MomentBuffers, StrandShape};
use superhelix_kernels::Arith;
use superhelix_kernels::Pose;

const N: usize = 5;
const D: usize = 3 * N;

struct Input<T: Arith> {
    ends: [Pose<T>; N + 1],
    derivs: [EndDerivatives<T>; N],
    moments: [ElementMoments<T>; N],
    motions: [FrameMotion<T>; N + 1],
    velocities: [T; D],
    lengths: [T; N],
}

/// Strand `k` of four: N = 5 elements of 4 cm, helical (radius 6 mm, step 5 mm, scaled
/// by k), leaning off the vertical, moving (q̇ of a few rad/(m s)); its element ends, end
/// derivatives and moments from the generated closed forms, its frame motions at q̇.
fn strand_input(k: usize) -> Input<f64> {
    let kappa = helix_curvature(0.006 * (1.0 + 0.3 * k as f64), 0.005, true);
    let q: [f64; D] = core::array::from_fn(|i| kappa[i % 3] * (1.0 + 0.05 * (i / 3) as f64));
    let velocities = core::array::from_fn(|i| (i as f64 * 0.7 + k as f64).sin() * 3.0);
    let lengths = [0.04; N];
    let n0 = Vector3::new(0.3, 0.1 * k as f64, -1.0).normalize();
    let n1 = Vector3::y().cross(&n0).normalize();
    let shape = StrandShape {
        root_position: Vector3::new(0.0, 0.01 * k as f64, 0.1),
        root_frame: Matrix3::from_columns(&[n0, n1, n0.cross(&n1)]),
        lengths: &lengths,
        mass_per_length: 2.4e-5,
        rotary_inertia: [1e-12, 5e-13, 5e-13],
    };
    let mut ends = [Pose::default(); N + 1];
    let mut darboux = [Vector3::zeros(); N];
    let mut derivs = [EndDerivatives::default(); N];
    let mut moments = [ElementMoments::default(); N];
    let mut motions = [FrameMotion::default(); N + 1];
    let mut bodies = [SuffixBody::default(); N + 1];
    let mut rotary = [RotaryElement::default(); N];
    let mut beyond = [(Matrix3::zeros(), Matrix3::zeros()); N];
    let mut velocity_rows = [VelocityRow::default(); D];
    let (mut mass, mut gram, mut matrix) = ([0.0; D * D], [0.0; D * D], [0.0; D * D]);
    let (mut vector, mut prepared, mut mass_prepared) = ([0.0; D], [f64::NAN; D], [f64::NAN; D]);
    let mut mass_valid = false;
    let mut buffers = MomentBuffers {
        ends: &mut ends,
        darboux: &mut darboux,
        end_derivs: &mut derivs,
        moments: &mut moments,
        motions: &mut motions,
        bodies: &mut bodies,
        rotary: &mut rotary,
        beyond: &mut beyond,
        velocity_rows: &mut velocity_rows,
        mass: &mut mass,
        gram: &mut gram,
        mass_valid: &mut mass_valid,
        matrix: &mut matrix,
        vector: &mut vector,
        prepared: &mut prepared,
        mass_prepared: &mut mass_prepared,
    };
    prepare(&ClosedForm, &shape, &mut buffers, &q);
    frame_motions(&ends, &derivs, &velocities, &mut motions);
    Input {
        ends,
        derivs,
        moments,
        motions,
        velocities,
        lengths,
    }
}

/// The assembly of one strand's (or W strands') input into `mass`, `gram` and `force`.
#[inline(always)]
fn assemble<T: Arith>(
    x: &Input<T>,
    c0: &Vector3<T>,
    rho_s: T,
    bodies: &mut [SuffixBody<T>; N + 1],
    mass: &mut [T; D * D],
    gram: &mut [T; D * D],
    force: &mut [T; D],
) -> Vector3<T> {
    suffix_bodies(
        &x.ends,
        &x.lengths,
        &x.moments,
        &x.motions,
        &x.velocities,
        true,
        bodies,
    );
    let mut first = Vector3::zeros();
    assemble_mass_gram_and_gravity(
        bodies,
        rho_s,
        &x.lengths,
        &x.ends,
        &x.derivs,
        &x.moments,
        c0,
        mass,
        Some(gram),
        force,
        &mut first,
    );
    first
}

fn load(inputs: &[Input<f64>; 4]) -> Input<Lanes<f64, 4>> {
    let r = inputs.each_ref();
    Input {
        ends: Soa::load(r.map(|x| &x.ends)),
        derivs: Soa::load(r.map(|x| &x.derivs)),
        moments: Soa::load(r.map(|x| &x.moments)),
        motions: Soa::load(r.map(|x| &x.motions)),
        velocities: Soa::load(r.map(|x| &x.velocities)),
        lengths: Soa::load(r.map(|x| &x.lengths)),
    }
}

#[target_feature(enable = "avx2")]
fn assemble_lanes_avx2(
    x: &Input<Lanes<f64, 4>>,
    bodies: &mut [SuffixBody<Lanes<f64, 4>>; N + 1],
    mass: &mut [Lanes<f64, 4>; D * D],
    gram: &mut [Lanes<f64, 4>; D * D],
    force: &mut [Lanes<f64, 4>; D],
) -> Vector3<Lanes<f64, 4>> {
    let c0 = Vector3::new(0.0, 0.0, -9.81).map(Lanes::from);
    assemble(x, &c0, Lanes::from(1e-5), bodies, mass, gram, force)
}

#[target_feature(enable = "avx2")]
fn assemble_scalar_avx2(
    x: &Input<f64>,
    bodies: &mut [SuffixBody<f64>; N + 1],
    mass: &mut [f64; D * D],
    gram: &mut [f64; D * D],
    force: &mut [f64; D],
) -> Vector3<f64> {
    let c0 = Vector3::new(0.0, 0.0, -9.81);
    assemble(x, &c0, 1e-5, bodies, mass, gram, force)
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("assembly_5");
    group
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(40);
    let inputs: [Input<f64>; 4] = core::array::from_fn(|k| strand_input(k));
    let lanes = load(&inputs);
    let c0 = Vector3::new(0.0, 0.0, -9.81);
    // the lanes give each strand's bits
    let mut lb = [SuffixBody::default(); N + 1];
    let (mut lm, mut lg, mut lf) = (
        [Lanes::from(0.0); D * D],
        [Lanes::from(0.0); D * D],
        [Lanes::from(0.0); D],
    );
    // SAFETY: checked for AVX2 by the caller of the benchmark (this machine has it)
    let lfirst = unsafe { assemble_lanes_avx2(&lanes, &mut lb, &mut lm, &mut lg, &mut lf) };
    for (k, x) in inputs.iter().enumerate() {
        let mut b = [SuffixBody::default(); N + 1];
        let (mut m, mut g, mut f) = ([0.0; D * D], [0.0; D * D], [0.0; D]);
        let first = assemble(x, &c0, 1e-5, &mut b, &mut m, &mut g, &mut f);
        for i in 0..D * D {
            assert_eq!(m[i].to_bits(), lm[i].0[k].to_bits());
            assert_eq!(g[i].to_bits(), lg[i].0[k].to_bits());
        }
        for i in 0..D {
            assert_eq!(f[i].to_bits(), lf[i].0[k].to_bits());
        }
        assert_eq!(first, lfirst.map(|x| x.0[k]));
    }
    group.bench_function("scalar_x4", |b| {
        let mut bodies = [SuffixBody::default(); N + 1];
        let (mut m, mut g, mut f) = ([0.0; D * D], [0.0; D * D], [0.0; D]);
        b.iter(|| {
            let mut sum = 0.0;
            for x in &inputs {
                // SAFETY: as above
                let first = unsafe { assemble_scalar_avx2(x, &mut bodies, &mut m, &mut g, &mut f) };
                sum += first[0] + m[7] + g[9] + f[3];
            }
            black_box(sum)
        })
    });
    group.bench_function("lanes_4", |b| {
        let mut bodies = [SuffixBody::default(); N + 1];
        b.iter(|| {
            // SAFETY: as above
            let first =
                unsafe { assemble_lanes_avx2(&lanes, &mut bodies, &mut lm, &mut lg, &mut lf) };
            black_box(first[0].0[0] + lm[7].0[1] + lg[9].0[2] + lf[3].0[3])
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
