//! The generated closed forms against the generic path, and freshness of the
//! checked-in files.

use superhelix_runtime::moments::ElementMoments;
use superhelix_runtime::Vector3;

fn rel(a: f64, b: f64, scale: f64) -> f64 {
    (a - b).abs() / scale.max(1e-300)
}

/// Largest |x| over a moment set (the scale deviations are measured against).
fn flatten(m: &ElementMoments) -> Vec<f64> {
    let mut v: Vec<f64> = m
        .first
        .iter()
        .chain(m.second.iter())
        .chain(m.gram.iter())
        .copied()
        .collect();
    for i in 0..3 {
        v.extend(m.dfirst[i].iter());
        v.extend(m.cross[i].iter());
        v.extend(m.rot_w[i].iter());
    }
    for i in 0..3 {
        v.extend(m.pdp[i].iter());
    }
    v.extend(m.rot.iter());
    v.extend(m.rot_ww.iter());
    v
}

#[test]
fn closed_form_moments_match_high_order_quadrature() {
    let mut seed = 0x1234_5678_9abc_def0u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let rotary = [2.0e-9, 0.8e-9, 1.2e-9];
    let mut worst: f64 = 0.0;
    for &wl in &[
        0.0, 1e-12, 1e-8, 1e-4, 1e-2, 0.3, 1.0, 2.4999, 2.5, 2.5001, 10.0, 30.0, 100.0,
    ] {
        for planar in [false, true] {
            for _ in 0..20 {
                let l = 0.01 + 0.05 * (next() + 1.0);
                let mut dir = Vector3::new(next(), next(), next());
                if planar {
                    dir[0] = 0.0;
                }
                let d = if dir.norm() > 0.0 {
                    dir.normalize() * (wl / l)
                } else {
                    dir
                };
                let closed = superhelix_generated::mass_moments(&d, l, &rotary);
                let points = 60 + (2.0 * wl) as usize;
                let reference = ElementMoments::by_quadrature(&d, l, &rotary, points);
                let (a, b) = (flatten(&closed), flatten(&reference));
                // each group is compared against the largest entry of its own kind
                let scale_of = |range: std::ops::Range<usize>| {
                    b[range].iter().fold(0.0f64, |m, x| m.max(x.abs()))
                };
                let groups = [0..3, 3..12, 12..21, 21..b.len()];
                for g in groups {
                    let s = scale_of(g.clone());
                    for i in g {
                        let e = rel(a[i], b[i], s);
                        worst = worst.max(e);
                        assert!(
                            e <= 1e-11,
                            "W l = {wl}, entry {i}: {} vs {} (scale {s})",
                            a[i],
                            b[i]
                        );
                    }
                }
            }
        }
    }
    println!("worst relative deviation {worst:e}");
}

#[test]
fn generated_files_are_fresh() {
    // SUPERHELIX_UPDATE_GENERATED=1 rewrites them (same as `cargo run -p superhelix-codegen --release`).
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let update = std::env::var_os("SUPERHELIX_UPDATE_GENERATED").is_some();
    for (name, text) in superhelix_codegen::kernels::checked_in_files().expect("generation") {
        let path = dir.join(&name);
        let current = std::fs::read_to_string(&path).unwrap_or_default();
        if update {
            std::fs::write(&path, &text).expect("write");
            continue;
        }
        if current != text {
            let line = current
                .lines()
                .zip(text.lines())
                .position(|(a, b)| a != b)
                .unwrap_or(0);
            panic!(
                "{} is stale (first difference at line {}):\n  checked in: {:?}\n  generated:  {:?}\nrun `cargo run -p superhelix-codegen --release`",
                path.display(),
                line + 1,
                current.lines().nth(line).unwrap_or(""),
                text.lines().nth(line).unwrap_or("")
            );
        }
    }
}

#[test]
fn mass_matrix_and_gravity_from_closed_form_moments_match_the_generic_kernel() {
    use superhelix_runtime::kernel::{BodyField, EvalInput, StrandKernel, StrandTerms, Terms};
    use superhelix_runtime::moments::{assemble_mass_and_gravity, end_derivatives, Body};
    use superhelix_runtime::reconstruction::{darboux, element_ends, Pose};
    use superhelix_runtime::strand::StrandGeometry;
    use superhelix_runtime::{GenericKernel, Matrix3, QuadratureRule};
    let mut worst: f64 = 0.0;
    for n in [1usize, 2, 5, 10] {
        for (case, wl) in [0.0, 1e-8, 1e-3, 0.5, 2.5, 8.0, 30.0].iter().enumerate() {
            let lengths: Vec<f64> = (0..n)
                .map(|k| 0.02 + 0.01 * ((k * 7 + case) % 5) as f64)
                .collect();
            let g = StrandGeometry {
                root_position: Vector3::new(0.01, 0.0, -0.02),
                root_frame: *nalgebra::Rotation3::new(Vector3::new(0.3, -0.2, 0.9)).matrix(),
                lengths: lengths.clone(),
                mass_per_length: 1e-5,
                rotary_inertia: [2e-9, 0.8e-9, 1.2e-9],
            };
            let q: Vec<f64> = (0..n)
                .flat_map(|k| {
                    let dir =
                        Vector3::new(0.3 + 0.1 * k as f64, -0.8, 0.5 - 0.2 * k as f64).normalize();
                    let d = dir * (wl / lengths[k]);
                    [d[0], d[1], d[2]]
                })
                .collect();
            let dofs = 3 * n;
            let c0 = Vector3::new(0.2, -0.4, -9.81) * 1e-5;
            let mut generic =
                GenericKernel::new(g.clone(), QuadratureRule::Fixed(64 + (4.0 * wl) as usize));
            let mut reference = StrandTerms::new(dofs);
            let terms = Terms {
                mass: true,
                force: true,
                ..Default::default()
            };
            let field = BodyField {
                uniform: c0,
                linear: Matrix3::zeros(),
                velocity: Matrix3::zeros(),
            };
            generic.evaluate(
                &EvalInput {
                    q: &q,
                    v: &vec![0.0; dofs],
                    field,
                    terms,
                },
                &mut reference,
            );
            let mut ends = vec![Pose::default(); n + 1];
            element_ends(&g, &q, &mut ends);
            let derivs: Vec<_> = (0..n)
                .map(|k| end_derivatives(&ends[k].frame, &darboux(&q, k), lengths[k]))
                .collect();
            let moments: Vec<_> = (0..n)
                .map(|k| {
                    superhelix_generated::mass_moments(
                        &darboux(&q, k),
                        lengths[k],
                        &g.rotary_inertia,
                    )
                })
                .collect();
            let (mut mass, mut force, mut first) =
                (vec![0.0; dofs * dofs], vec![0.0; dofs], Vector3::zeros());
            let mut bodies = vec![Body::default(); n + 1];
            assemble_mass_and_gravity(
                &mut bodies,
                1e-5,
                &lengths,
                &ends,
                &derivs,
                &moments,
                &c0,
                &mut mass,
                &mut force,
                &mut first,
            );
            let mscale = (0..dofs)
                .map(|i| reference.mass[(i, i)].abs())
                .fold(0.0, f64::max);
            for j in 0..dofs {
                for i in 0..dofs {
                    let e = rel(mass[j * dofs + i], reference.mass[(i, j)], mscale);
                    worst = worst.max(e);
                    assert!(e <= 1e-10, "N={n} W l={wl} M[{i},{j}]");
                }
            }
            let fscale = reference.force.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            for (i, (a, b)) in force.iter().zip(&reference.force).enumerate() {
                assert!(rel(*a, *b, fscale) <= 1e-10, "N={n} W l={wl} f[{i}]");
            }
        }
    }
    println!("worst relative deviation of M: {worst:e}");
}
