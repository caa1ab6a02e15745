//! Criterion bench: one frame of render strands (`SemiInterpolation::frame`, paper
//! section 4.1) — 100,000 render strands from 200 guides of N = 10 elements sampled at 4
//! points each (41 points per strand), roots on a scalp of radius 9 cm, clumping 0.5,
//! the tip criterion on, the head turned — on every core rayon finds, and the placement of
//! the roots (done once per run). Then the same number of strands from 200 guides draped
//! over a head ellipsoid (along its meridians, then hanging) and through two shoulder
//! capsules: the blend alone, and kept out of the three bodies (`frame_at`).
//! `cargo bench -p superhelix-runtime --bench interpolation`.

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{Rotation3, Vector3};
use std::hint::black_box;
use std::time::Duration;
use superhelix_kernels::head::HeadState;
use superhelix_runtime::bodies::shape_capsule::Capsule;
use superhelix_runtime::bodies::shape_ellipsoid::Ellipsoid;
use superhelix_runtime::bodies::shape_sphere::Sphere;
use superhelix_runtime::bodies::{Attachment, Body, Placement, Shape};
use superhelix_runtime::render::{KeepOut, RenderSettings, SemiInterpolation};

const GUIDES_PER_SIDE: usize = 20;
const GUIDE_ROWS: usize = 10;
const POINTS: usize = 41;
const RENDER_STRANDS: usize = 100_000;
const SCALP: f64 = 0.09;

/// 200 guides on a cap of the scalp, 25 cm long, hanging outward and down with a wave.
fn guides() -> Vec<Vector3<f64>> {
    let mut out = Vec::with_capacity(GUIDES_PER_SIDE * GUIDE_ROWS * POINTS);
    for i in 0..GUIDE_ROWS {
        for j in 0..GUIDES_PER_SIDE {
            let theta = 0.2 + 0.12 * i as f64;
            let phi = std::f64::consts::TAU * j as f64 / GUIDES_PER_SIDE as f64;
            let n = Vector3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            let root = n * SCALP;
            for k in 0..POINTS {
                let s = k as f64 / (POINTS - 1) as f64;
                let wave = 0.01 * (12.0 * s + phi).sin();
                out.push(root + n * (0.05 * s) + Vector3::new(wave, 0.0, -0.25 * s));
            }
        }
    }
    out
}

/// Half-axes of the head ellipsoid of the draped guides, m.
const HEAD: [f64; 3] = [0.08, 0.09, 0.1];

/// 200 guides of 25 cm on the grid of `guides`, each along its meridian 1 mm above the
/// head ellipsoid [`HEAD`] down to the equator, then hanging straight down (head
/// coordinates).
fn draped_guides() -> Vec<Vector3<f64>> {
    let lift = 0.001;
    let mut out = Vec::with_capacity(GUIDES_PER_SIDE * GUIDE_ROWS * POINTS);
    for i in 0..GUIDE_ROWS {
        for j in 0..GUIDES_PER_SIDE {
            let theta0 = 0.2 + 0.12 * i as f64;
            let phi = std::f64::consts::TAU * j as f64 / GUIDES_PER_SIDE as f64;
            let at = |theta: f64| {
                Vector3::new(
                    (HEAD[0] + lift) * theta.sin() * phi.cos(),
                    (HEAD[1] + lift) * theta.sin() * phi.sin(),
                    (HEAD[2] + lift) * theta.cos(),
                )
            };
            let steps = 1000;
            let half = std::f64::consts::FRAC_PI_2;
            let mut dense: Vec<Vector3<f64>> = (0..=steps)
                .map(|k| at(theta0 + (half - theta0) * k as f64 / steps as f64))
                .collect();
            let equator = at(half);
            dense.extend(
                (1..=steps).map(|k| equator - Vector3::z() * 0.25 * k as f64 / steps as f64),
            );
            let mut s = vec![0.0];
            for w in dense.windows(2) {
                s.push(s[s.len() - 1] + (w[1] - w[0]).norm());
            }
            for k in 0..POINTS {
                let target = 0.25 * k as f64 / (POINTS - 1) as f64;
                let a = s
                    .partition_point(|&x| x <= target)
                    .clamp(1, dense.len() - 1)
                    - 1;
                let t = ((target - s[a]) / (s[a + 1] - s[a])).clamp(0.0, 1.0);
                out.push(dense[a] + t * (dense[a + 1] - dense[a]));
            }
        }
    }
    out
}

/// The head ellipsoid [`HEAD`] (on the head) and two shoulder capsules (in the world),
/// whose round ends come within 4 mm of the hanging guides.
fn head_and_shoulders() -> Vec<Body> {
    let shoulder = |name: &str, side: f64| Body {
        name: name.into(),
        attached: Attachment::World,
        shape: Shape::Capsule(Capsule {
            start: Vector3::new(0.0, side * 0.14, -0.17),
            end: Vector3::new(0.0, side * 0.25, -0.19),
            radius: 0.045,
        }),
    };
    vec![
        Body {
            name: "head".into(),
            attached: Attachment::Head,
            shape: Shape::Ellipsoid(Ellipsoid {
                center: Vector3::zeros(),
                radii: Vector3::from(HEAD),
                rotation: nalgebra::Matrix3::identity(),
            }),
        },
        shoulder("left", 1.0),
        shoulder("right", -1.0),
    ]
}

fn bench(c: &mut Criterion) {
    let rest = guides();
    let settings = RenderSettings {
        clumping: 0.5,
        tip_distance: Some(0.05),
        seed: 1,
        ..RenderSettings::new(RENDER_STRANDS)
    };
    let scalp = Body {
        name: "scalp".into(),
        attached: Attachment::Head,
        shape: Shape::Sphere(Sphere {
            center: Vector3::zeros(),
            radius: SCALP,
        }),
    };
    let rotation = Rotation3::from_axis_angle(&Vector3::z_axis(), 0.3).into_inner();
    let world: Vec<[f64; 3]> = rest
        .iter()
        .map(|p| {
            let q = rotation * p;
            [q.x, q.y, q.z]
        })
        .collect();
    let mut group = c.benchmark_group("interpolation");
    group
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5))
        .sample_size(30);
    let mut interp =
        SemiInterpolation::new(&settings, &rest, POINTS, Some(&scalp)).expect("render strands");
    group.bench_function("frame_100k_from_200_guides", |b| {
        b.iter(|| {
            let out = interp.frame(black_box(&world), &rotation).expect("frame");
            black_box(out[out.len() - 1][2])
        })
    });
    group.sample_size(10);
    group.bench_function("place_100k_roots", |b| {
        b.iter(|| {
            black_box(
                SemiInterpolation::new(&settings, &rest, POINTS, Some(&scalp))
                    .expect("render strands")
                    .strand_count(),
            )
        })
    });
    // draped over a head and shoulders: the blend alone, then kept out of the bodies
    let rest = draped_guides();
    let bodies = head_and_shoulders();
    let head = HeadState {
        rotation,
        ..HeadState::rest()
    };
    let world: Vec<[f64; 3]> = rest
        .iter()
        .map(|p| {
            let q = head.to_world(p);
            [q.x, q.y, q.z]
        })
        .collect();
    let mut plain =
        SemiInterpolation::new(&settings, &rest, POINTS, Some(&bodies[0])).expect("render strands");
    let mut kept = plain
        .clone()
        .keep_out(KeepOut::new(bodies.clone(), 5e-5).expect("clearance"));
    let blended = plain.frame(&world, &rotation).expect("frame").to_vec();
    let moved = kept
        .frame_at(&world, &Placement::new(head, 0.0))
        .expect("frame");
    let changed = moved.iter().zip(&blended).filter(|(a, b)| a != b).count();
    let deepest: Vec<String> = bodies
        .iter()
        .map(|b| {
            let d = blended
                .iter()
                .map(|p| {
                    b.distance(
                        &Placement::new(head, 0.0),
                        &Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64),
                    )
                })
                .fold(f64::INFINITY, f64::min);
            format!("{} {:.2} mm", b.name, d * 1e3)
        })
        .collect();
    println!(
        "draped: {changed} of {} render points moved out of the bodies (nearest blended point: {})",
        blended.len(),
        deepest.join(", ")
    );
    group.sample_size(30);
    group.bench_function("frame_100k_draped", |b| {
        b.iter(|| {
            let out = plain.frame(black_box(&world), &rotation).expect("frame");
            black_box(out[out.len() - 1][2])
        })
    });
    group.bench_function("frame_100k_draped_kept_out_of_head_and_shoulders", |b| {
        b.iter(|| {
            let out = kept
                .frame_at(black_box(&world), &Placement::new(head, 0.0))
                .expect("frame");
            black_box(out[out.len() - 1][2])
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
