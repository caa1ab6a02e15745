//! Criterion bench: one step of a fixed-N strand (`superhelix_kernels::fixed::step`
//! with the generated closed forms) at N = 5, hair-like (curly preset, 20 cm, hanging
//! 17° off vertical), gravity, air drag and internal friction, dt = 1/30 s, and its parts:
//! the step without its checks (`fixed::linearly_implicit`), the terms (`fixed::evaluate`)
//! and the element moments alone; and the same strand's step, step without checks and
//! element moments in f32 (`*_f32`: the f32 strand, workspace and step on the generated
//! f32 closed forms). Group `lu_15`: the step's LU of 8 matrices of 15 × 15 (N = 5),
//! one after the other (`fixed::lu_solve`) against 8 lanes at once
//! (`lane::lu::lu_solve_lanes`, W = 4 and 8).
//! `cargo bench -p superhelix-runtime --bench fixed_step`.

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::Vector3;
use std::hint::black_box;
use std::time::Duration;
use superhelix_generated::ClosedForm;
use superhelix_kernels::fixed::{
    self, Effects, FixedParams, FixedStrand, FixedWorkspace, StepCounts, StepInput, StillHead,
};
use superhelix_kernels::head::HeadState;
use superhelix_kernels::material::{helix_curvature, section_terms};
use superhelix_kernels::moments::ElementMoments;
use superhelix_kernels::strand_terms::MomentSource;

const N: usize = 5;
const D: usize = 15;
const E: usize = 6;
const B: usize = 7;

fn strand() -> FixedStrand<N, D, B> {
    let section = section_terms(50e-6, 1.1, 1.5e9, 0.48, 1300.0);
    let k = helix_curvature(0.006, 0.005, true);
    let n0 = Vector3::new(0.3, 0.0, -1.0).normalize();
    let n1 = Vector3::y();
    let n2 = n0.cross(&n1);
    let frame = [[n0.x, n0.y, n0.z], [n1.x, n1.y, n1.z], [n2.x, n2.y, n2.z]];
    let natural = core::array::from_fn(|i| k[i % 3]);
    let params =
        FixedParams::<N, D>::new([0.0; 3], frame, [0.04; N], &section, natural, 5e-11, 5e-6)
            .expect("valid parameters");
    FixedStrand::at_rest(params)
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("fixed_n5");
    group
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .sample_size(40);
    let input = StepInput {
        head: HeadState::rest(),
        gravity: Some(Vector3::new(0.0, 0.0, -9.81)),
        head_moves: false,
    };
    let mut ws = Box::new(FixedWorkspace::<N, D, E>::new());
    // a state in motion: a few steps from rest
    let effects = Effects {
        gravity: input.gravity,
        head_moves: false,
    };
    let mut counts = StepCounts::default();
    let h = 1.0 / 30.0;
    let mut s = strand();
    for k in 0..5 {
        let t = k as f64 * h;
        fixed::step(
            &ClosedForm,
            &mut s,
            &StillHead,
            &effects,
            t,
            h,
            &mut ws,
            &mut counts,
        )
        .expect("step");
    }
    let start = s.clone();
    group.bench_function("step", |b| {
        b.iter(|| {
            let mut s = start.clone();
            fixed::step(
                &ClosedForm,
                &mut s,
                &StillHead,
                &effects,
                5.0 * h,
                h,
                &mut ws,
                &mut counts,
            )
            .expect("step");
            black_box(s.q[0])
        })
    });
    group.bench_function("linearly_implicit", |b| {
        b.iter(|| {
            let mut s = start.clone();
            fixed::linearly_implicit(&ClosedForm, &mut s, &input, h, &mut ws).expect("step");
            black_box(s.q[0])
        })
    });
    group.bench_function("evaluate", |b| {
        b.iter(|| black_box(fixed::evaluate(&ClosedForm, &start, &input, &mut ws)))
    });
    let d: Vec<Vector3<f64>> = (0..N)
        .map(|p| Vector3::new(start.q[3 * p], start.q[3 * p + 1], start.q[3 * p + 2]))
        .collect();
    let mut out = [ElementMoments::default(); N];
    group.bench_function("element_moments", |b| {
        b.iter(|| {
            ClosedForm.moments_batch(
                black_box(&d),
                &[0.04; N],
                &start.params.rotary_inertia,
                &mut out,
            );
            black_box(out[0].first[0])
        })
    });
    // the same in f32: the strand rounded to f32, moved by the same five steps in f32
    let mut ws32 = Box::new(FixedWorkspace::<N, D, E, f32>::new());
    let mut s32: FixedStrand<N, D, B, f32> = strand().cast();
    for k in 0..5 {
        let t = k as f64 * h;
        fixed::step(
            &ClosedForm,
            &mut s32,
            &StillHead,
            &effects,
            t,
            h,
            &mut ws32,
            &mut counts,
        )
        .expect("step");
    }
    let start32 = s32.clone();
    group.bench_function("step_f32", |b| {
        b.iter(|| {
            let mut s = start32.clone();
            fixed::step(
                &ClosedForm,
                &mut s,
                &StillHead,
                &effects,
                5.0 * h,
                h,
                &mut ws32,
                &mut counts,
            )
            .expect("step");
            black_box(s.q[0])
        })
    });
    group.bench_function("linearly_implicit_f32", |b| {
        b.iter(|| {
            let mut s = start32.clone();
            fixed::linearly_implicit(&ClosedForm, &mut s, &input, h, &mut ws32).expect("step");
            black_box(s.q[0])
        })
    });
    let d32: Vec<Vector3<f32>> = d.iter().map(|d| d.map(|x| x as f32)).collect();
    let mut out32 = [ElementMoments::<f32>::default(); N];
    group.bench_function("element_moments_f32", |b| {
        b.iter(|| {
            ClosedForm.moments_batch(
                black_box(&d32),
                &[0.04; N],
                &start32.params.rotary_inertia,
                &mut out32,
            );
            black_box(out32[0].first[0])
        })
    });
    group.finish();
}

/// The LU of 8 step matrices of N = 5 (diagonally weighted, as M/h² + K makes them),
/// one at a time against in lanes.
fn lu(c: &mut Criterion) {
    use superhelix_kernels::lane::lu::lu_solve_lanes;
    use superhelix_kernels::lane::Lanes;
    use superhelix_kernels::storage::Square;
    let mut group = c.benchmark_group("lu_15");
    group
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(40);
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    };
    let mats: Vec<[[f64; D]; D]> = (0..8)
        .map(|_| {
            let mut m: [[f64; D]; D] = core::array::from_fn(|_| core::array::from_fn(|_| next()));
            for (i, col) in m.iter_mut().enumerate() {
                col[i] += 4.0;
            }
            m
        })
        .collect();
    let rhs: Vec<[f64; D]> = (0..8).map(|_| core::array::from_fn(|_| next())).collect();
    group.bench_function("scalar_x8", |b| {
        b.iter(|| {
            let mut sum = 0.0;
            for (m, r) in mats.iter().zip(&rhs) {
                let (mut a, mut x, mut piv) = (*m, *r, [0usize; D]);
                fixed::lu_solve(&mut Square::of_array(&mut a), &mut x, &mut piv);
                sum += x[0];
            }
            black_box(sum)
        })
    });
    macro_rules! width {
        ($w:literal) => {{
            let lanes: Vec<([[Lanes<f64, $w>; D]; D], [Lanes<f64, $w>; D])> = mats
                .chunks($w)
                .zip(rhs.chunks($w))
                .map(|(m, r)| {
                    (
                        core::array::from_fn(|c| {
                            core::array::from_fn(|row| {
                                Lanes(core::array::from_fn(|k| m[k][c][row]))
                            })
                        }),
                        core::array::from_fn(|row| Lanes(core::array::from_fn(|k| r[k][row]))),
                    )
                })
                .collect();
            group.bench_function(concat!("lanes_", $w), |b| {
                b.iter(|| {
                    let mut sum = 0.0;
                    for (m, r) in &lanes {
                        let (mut a, mut x, mut piv) = (*m, *r, [[0u8; $w]; D]);
                        lu_solve_lanes(&mut a, &mut x, &mut piv);
                        sum += x[0].0[0];
                    }
                    black_box(sum)
                })
            });
        }};
    }
    width!(4);
    width!(8);
    group.finish();
}

criterion_group!(benches, bench, lu);
criterion_main!(benches);
