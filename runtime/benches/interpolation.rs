//! Criterion bench: one frame of render strands (`SemiInterpolation::frame`, paper
//! section 4.1) — 100,000 render strands from 200 guides of N = 10 elements sampled at 4
//! points each (41 points per strand), roots on a scalp of radius 9 cm, clumping 0.5,
//! the tip criterion on, the head turned — on every core rayon finds, and the placement of
//! the roots (done once per run).
//! `cargo bench -p superhelix-runtime --bench interpolation`.

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{Rotation3, Vector3};
use std::hint::black_box;
use std::time::Duration;
use superhelix_runtime::bodies::shape_sphere::Sphere;
use superhelix_runtime::bodies::{Attachment, Body, Shape};
use superhelix_runtime::render::{RenderSettings, SemiInterpolation};

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
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
