//! The step's O(N²) assembly on lanes (everything `strand_terms::evaluate_terms` does for
//! a strand in gravity and drag on a still head, the rotary inertia's quadrature included)
//! of 4 strands of N = 5, one at a time against once on `Lanes<f64, 4>` (the same code
//! over `Arith`, compiled with AVX2), on four moving helical strands.
//! `cargo bench -p superhelix-generated --bench lane_assembly`.

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{Matrix3, Vector3};
use std::hint::black_box;
use std::time::Duration;
use superhelix_generated::element_rotary_point::element_rotary_points_lanes;
use superhelix_generated::element_rotary_points_into;
use superhelix_generated::ClosedForm;
use superhelix_kernels::element::RotaryPoints;
use superhelix_kernels::lane::soa::Soa;
use superhelix_kernels::lane::Lanes;
use superhelix_kernels::material::helix_curvature;
use superhelix_kernels::moments::jacobians::VelocityRow;
use superhelix_kernels::moments::jacobians::{add_field_hessian, add_velocity_jacobian};
use superhelix_kernels::moments::rotary::{
    add_rotary_terms, rotary_element, rotary_element_lanes, rotary_points, RotaryElement,
};
use superhelix_kernels::moments::{
    assemble_inertial_and_field_force, assemble_mass_gram_and_gravity, frame_motions,
    suffix_bodies, ElementMoments, EndDerivatives, FrameMotion, SuffixBody,
};
use superhelix_kernels::strand_terms::{prepare, MomentBuffers, StrandShape};
use superhelix_kernels::Arith;
use superhelix_kernels::BodyField;
use superhelix_kernels::Pose;

const N: usize = 5;
const D: usize = 3 * N;

struct Input<T: Arith> {
    darboux: [Vector3<T>; N],
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
        rotary_inertia: ROTARY,
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
        darboux,
        ends,
        derivs,
        moments,
        motions,
        velocities,
        lengths,
    }
}

/// Outputs of the assembly.
struct Output<T: Arith> {
    motions: [FrameMotion<T>; N + 1],
    bodies: [SuffixBody<T>; N + 1],
    rows: [VelocityRow<T>; D],
    mass: [T; D * D],
    gram: [T; D * D],
    stiffness: [T; D * D],
    velocity_jacobian: [T; D * D],
    gravity: [T; D],
    inertial: [T; D],
    field_force: [T; D],
    rotary: [RotaryElement<T>; N],
    beyond: [(Matrix3<T>, Matrix3<T>); N],
}

impl<T: Arith> Output<T> {
    fn new() -> Box<Self> {
        Box::new(Output {
            motions: [FrameMotion::default(); N + 1],
            bodies: [SuffixBody::default(); N + 1],
            rows: [VelocityRow::default(); D],
            mass: [T::zero(); D * D],
            gram: [T::zero(); D * D],
            stiffness: [T::zero(); D * D],
            velocity_jacobian: [T::zero(); D * D],
            gravity: [T::zero(); D],
            inertial: [T::zero(); D],
            field_force: [T::zero(); D],
            rotary: [RotaryElement::default(); N],
            beyond: [(Matrix3::zeros(), Matrix3::zeros()); N],
        })
    }
}

/// The step's assembly of one strand (or W strands in lanes) in gravity and air drag
/// with the head still, as `strand_terms::evaluate_terms` runs it for the linearly
/// implicit step, less the rotary inertia: the frame motions, the suffix bodies, M and
/// the Gram matrix, the inertial and field forces, the field's Hessian and ∂b/∂q̇.
#[inline(always)]
fn assemble<T: Arith>(x: &Input<T>, field: &BodyField<T>, rho_s: T, o: &mut Output<T>) {
    frame_motions(&x.ends, &x.derivs, &x.velocities, &mut o.motions);
    let (ends, derivs, moments) = (&x.ends, &x.derivs, &x.moments);
    suffix_bodies(
        ends,
        &x.lengths,
        moments,
        &o.motions,
        &x.velocities,
        true,
        &mut o.bodies,
    );
    let mut first = Vector3::zeros();
    assemble_mass_gram_and_gravity(
        &o.bodies,
        rho_s,
        &x.lengths,
        ends,
        derivs,
        moments,
        &field.uniform,
        &mut o.mass,
        Some(&mut o.gram),
        &mut o.gravity,
        &mut first,
    );
    assemble_inertial_and_field_force(
        rho_s,
        &x.lengths,
        ends,
        derivs,
        moments,
        &o.motions,
        &x.velocities,
        field,
        &mut o.inertial,
        &mut o.field_force,
    );
    o.stiffness.fill(T::zero());
    let (c0, c1) = (&field.uniform, &field.linear);
    add_field_hessian(c0, c1, ends, derivs, moments, &o.bodies, &mut o.stiffness);
    o.velocity_jacobian.fill(T::zero());
    add_velocity_jacobian(
        rho_s + rho_s,
        ends,
        derivs,
        moments,
        &o.motions,
        &o.bodies,
        &x.velocities,
        &mut o.rows,
        &mut o.velocity_jacobian,
    );
}

/// The cross-sections' inertia (ρ(I1 + I2), ρI1, ρI2 of a 50 µm fibre, kg·m).
const ROTARY: [f64; 3] = [2.0e-12, 1.0e-12, 1.0e-12];

/// The rotary inertia's part of the step: each element's integrals by quadrature at its
/// own point count and their b and ∂b/∂q̇, one strand.
#[inline(always)]
fn rotary_scalar(x: &Input<f64>, o: &mut Output<f64>) {
    for p in 0..N {
        let d = x.darboux[p];
        o.rotary[p] = rotary_element(
            &|u: &[f64], out: &mut RotaryPoints| element_rotary_points_into(&d, u, out),
            x.lengths[p],
            &ROTARY,
            &x.moments[p],
            &x.ends[p],
            &o.motions[p],
            &x.velocities[3 * p..3 * p + 3],
            rotary_points(d.norm() * x.lengths[p]),
            true,
        );
    }
    rotary_terms(x, o);
}

/// The rotary elements' part of b and ∂b/∂q̇, one strand or W in lanes.
#[inline(always)]
fn rotary_terms<T: Arith>(x: &Input<T>, o: &mut Output<T>) {
    let jacobian = Some(&mut o.velocity_jacobian[..]);
    let b = Some(&mut o.inertial[..]);
    let (rotary, motions) = (&o.rotary, &o.motions);
    add_rotary_terms(
        &x.derivs,
        rotary,
        motions,
        &x.velocities,
        b,
        jacobian,
        &mut o.beyond,
    );
}

/// [`rotary_scalar`] for 4 strands in lanes.
#[inline(always)]
fn rotary_lanes(x: &Input<L4>, o: &mut Output<L4>) {
    let rotary = ROTARY.map(L4::from);
    for p in 0..N {
        let d = x.darboux[p].data.0[0];
        let l = x.lengths[p];
        let points = core::array::from_fn(|k| {
            let dk = Vector3::new(d[0].0[k], d[1].0[k], d[2].0[k]);
            rotary_points(dk.norm() * l.0[k])
        });
        o.rotary[p] = rotary_element_lanes(
            &mut |u, out| element_rotary_points_lanes(&d, u, out),
            l,
            &rotary,
            &x.moments[p],
            &x.ends[p],
            &o.motions[p],
            &x.velocities[3 * p..3 * p + 3],
            points,
            true,
        );
    }
    rotary_terms(x, o);
}

type L4 = Lanes<f64, 4>;

/// The field of gravity and an isotropic air drag (ν = 5e-6 N s/m²).
fn field() -> BodyField<f64> {
    BodyField {
        uniform: Vector3::new(0.0, 0.0, -9.81 * RHO_S),
        linear: Matrix3::zeros(),
        velocity: Matrix3::identity() * -5e-6,
    }
}

const RHO_S: f64 = 2.4e-5;

fn load(inputs: &[Input<f64>; 4]) -> Input<Lanes<f64, 4>> {
    let r = inputs.each_ref();
    Input {
        darboux: Soa::load(r.map(|x| &x.darboux)),
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
    field: &BodyField<Lanes<f64, 4>>,
    o: &mut Output<Lanes<f64, 4>>,
) {
    assemble(x, field, Lanes::from(RHO_S), o);
    rotary_lanes(x, o);
}

#[target_feature(enable = "avx2")]
fn assemble_scalar_avx2(x: &Input<f64>, field: &BodyField<f64>, o: &mut Output<f64>) {
    assemble(x, field, RHO_S, o);
    rotary_scalar(x, o);
}

fn bench(c: &mut Criterion) {
    assert!(
        std::arch::is_x86_feature_detected!("avx2"),
        "the benchmark runs AVX2 code"
    );
    let mut group = c.benchmark_group("assembly_5");
    group
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(40);
    let inputs: [Input<f64>; 4] = core::array::from_fn(strand_input);
    let lanes = load(&inputs);
    let field = field();
    let field_lanes: BodyField<Lanes<f64, 4>> = Soa::load([&field; 4]);
    // the lanes give each strand's bits (the equality test is kernels' moments::tests)
    let mut lo = Output::new();
    // SAFETY: the CPU has AVX2 (asserted above)
    unsafe { assemble_lanes_avx2(&lanes, &field_lanes, &mut lo) };
    for (k, x) in inputs.iter().enumerate() {
        let mut o = Output::new();
        // SAFETY: as above
        unsafe { assemble_scalar_avx2(x, &field, &mut o) };
        for (a, b) in o.velocity_jacobian.iter().zip(&lo.velocity_jacobian) {
            assert_eq!(a.to_bits(), b.0[k].to_bits());
        }
        for (a, b) in o.inertial.iter().zip(&lo.inertial) {
            assert_eq!(a.to_bits(), b.0[k].to_bits());
        }
    }
    group.bench_function("scalar_x4", |b| {
        let mut o = Output::new();
        b.iter(|| {
            let mut sum = 0.0;
            for x in &inputs {
                // SAFETY: as above
                unsafe { assemble_scalar_avx2(x, &field, &mut o) };
                sum += o.mass[7] + o.velocity_jacobian[9] + o.inertial[3];
            }
            black_box(sum)
        })
    });
    group.bench_function("lanes_4", |b| {
        b.iter(|| {
            // SAFETY: as above
            unsafe { assemble_lanes_avx2(&lanes, &field_lanes, &mut lo) };
            black_box(lo.mass[7].0[0] + lo.velocity_jacobian[9].0[1] + lo.inertial[3].0[3])
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
