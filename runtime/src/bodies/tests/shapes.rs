//! The analytic shapes against their closed forms and brute-force searches.

use super::Uniform;
use crate::bodies::shape_capsule::Capsule;
use crate::bodies::shape_ellipsoid::Ellipsoid;
use crate::bodies::shape_plane::Plane;
use crate::bodies::shape_sphere::Sphere;
use crate::bodies::Proximity;
use nalgebra::{Matrix3, Rotation3, Vector3};

/// The answer is consistent: unit normal, `closest = x − d n`.
fn assert_consistent(x: &Vector3<f64>, p: &Proximity, tol: f64) {
    assert!((p.normal.norm() - 1.0).abs() < 1e-12, "{p:?}");
    let back = x - p.normal * p.distance;
    assert!((back - p.closest).norm() < tol, "x {x}: {p:?}");
}

#[test]
fn a_sphere_is_exact() {
    let s = Sphere {
        center: Vector3::new(0.01, -0.02, 0.03),
        radius: 0.09,
    };
    let mut u = Uniform(7);
    for _ in 0..500 {
        let x = s.center + u.point(0.3);
        let p = s.query(&x);
        let r = (x - s.center).norm();
        assert_eq!(p.distance, r - s.radius);
        assert!((p.normal - (x - s.center) / r).norm() < 1e-15);
        assert!(((p.closest - s.center).norm() - s.radius).abs() < 1e-15);
        assert_consistent(&x, &p, 1e-15);
    }
    let centre = s.query(&s.center);
    assert_eq!(centre.distance, -s.radius);
    assert_eq!(centre.normal, Vector3::z());
}

#[test]
fn a_plane_is_exact() {
    let normal = Vector3::new(1.0, -2.0, 2.0) / 3.0;
    let plane = Plane {
        point: Vector3::new(0.0, 0.0, -0.5),
        normal,
    };
    let mut u = Uniform(11);
    for _ in 0..500 {
        let x = u.point(2.0);
        let p = plane.query(&x);
        assert_eq!(p.distance, (x - plane.point).dot(&normal));
        assert_eq!(p.normal, normal);
        assert!((p.closest - plane.point).dot(&normal).abs() < 1e-15);
        assert_consistent(&x, &p, 1e-15);
    }
    assert!(plane.query(&Vector3::new(0.0, 0.0, -1.0)).distance < 0.0);
}

/// min over t in [0, 1] of |x − (a + t (b − a))|, by dense sampling and golden-section
/// refinement of the bracket around the best sample (the distance is convex in t).
fn brute_segment_distance(x: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let f = |t: f64| (x - (a + (b - a) * t)).norm();
    let n = 10_000;
    let best = (0..=n)
        .min_by(|&i, &j| f(i as f64 / n as f64).total_cmp(&f(j as f64 / n as f64)))
        .unwrap_or(0);
    let (mut lo, mut hi) = (
        (best as f64 - 1.0).max(0.0) / n as f64,
        (best as f64 + 1.0).min(n as f64) / n as f64,
    );
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..200 {
        let (m1, m2) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if f(m1) < f(m2) {
            hi = m2;
        } else {
            lo = m1;
        }
    }
    f(0.5 * (lo + hi)).min(f(0.0)).min(f(1.0))
}

#[test]
fn a_capsule_matches_the_brute_force_closest_point_of_its_axis() {
    let c = Capsule {
        start: Vector3::new(-0.05, 0.02, 0.0),
        end: Vector3::new(0.07, -0.01, 0.04),
        radius: 0.03,
    };
    let mut u = Uniform(3);
    let mut points: Vec<Vector3<f64>> = (0..300).map(|_| u.point(0.15)).collect();
    // on the axis, at the ends, beyond them, inside near the axis
    points.extend([
        c.start,
        c.end,
        (c.start + c.end) / 2.0,
        c.end + (c.end - c.start),
        c.start + Vector3::new(0.0, 0.0, 1e-9),
    ]);
    for x in points {
        let p = c.query(&x);
        let want = brute_segment_distance(&x, &c.start, &c.end) - c.radius;
        assert!(
            (p.distance - want).abs() < 1e-12,
            "{:?}: {} vs {want}",
            x.as_slice(),
            p.distance
        );
        let axis = c.axis_point(&p.closest);
        assert!(
            ((p.closest - axis).norm() - c.radius).abs() < 1e-12,
            "on the surface: {:?} {p:?} {:?}",
            x.as_slice(),
            axis.as_slice()
        );
        assert_consistent(&x, &p, 1e-12);
    }
    // on the axis the normal is perpendicular to it
    let mid = c.query(&((c.start + c.end) / 2.0));
    assert!(mid.normal.dot(&(c.end - c.start)).abs() < 1e-12);
    assert_eq!(mid.distance, -c.radius);
    // both ends at one point: a ball
    let ball = Capsule { end: c.start, ..c };
    let x = Vector3::new(0.1, 0.2, -0.1);
    assert!((ball.query(&x).distance - ((x - c.start).norm() - c.radius)).abs() < 1e-15);
}

/// The surface point of an axis-aligned ellipsoid with half-axes `a` at angles (θ, φ).
fn on_ellipsoid(a: &Vector3<f64>, theta: f64, phi: f64) -> Vector3<f64> {
    Vector3::new(
        a.x * theta.sin() * phi.cos(),
        a.y * theta.sin() * phi.sin(),
        a.z * theta.cos(),
    )
}

/// The distance of `y` to the surface of the axis-aligned, centred ellipsoid `a`: the
/// best of a dense sampling in (θ, φ), refined by a pattern search from the best samples
/// until the step falls below 1e-13 rad.
fn brute_ellipsoid_distance(a: &Vector3<f64>, y: &Vector3<f64>) -> f64 {
    let f = |t: f64, p: f64| (y - on_ellipsoid(a, t, p)).norm();
    let (nt, np) = (120usize, 240usize);
    let (dt, dp) = (
        std::f64::consts::PI / nt as f64,
        2.0 * std::f64::consts::PI / np as f64,
    );
    let mut samples: Vec<(f64, f64, f64)> = Vec::with_capacity((nt + 1) * np);
    for i in 0..=nt {
        for j in 0..np {
            let (t, p) = (i as f64 * dt, j as f64 * dp);
            samples.push((f(t, p), t, p));
        }
    }
    samples.select_nth_unstable_by(6, |x, y| x.0.total_cmp(&y.0));
    let mut best = f64::INFINITY;
    for &(mut value, mut t, mut p) in samples.iter().take(6) {
        let mut step = dt;
        let mut moves = 0;
        while step > 1e-13 {
            let mut moved = false;
            for (st, sp) in [
                (1.0, 0.0),
                (-1.0, 0.0),
                (0.0, 1.0),
                (0.0, -1.0),
                (1.0, 1.0),
                (-1.0, -1.0),
                (1.0, -1.0),
                (-1.0, 1.0),
            ] {
                let (t2, p2) = (t + st * step, p + sp * step);
                let v = f(t2, p2);
                // better by more than rounding, so the search cannot wander
                if v < value * (1.0 - 1e-14) {
                    (value, t, p, moved) = (v, t2, p2, true);
                }
            }
            moves += 1;
            // at most 64 moves per step length: near a pole of the parametrisation the
            // search could crawl along φ, where the distance hardly changes
            if !moved || moves == 64 {
                step *= 0.5;
                moves = 0;
            }
        }
        best = best.min(value);
    }
    best
}

#[test]
fn an_ellipsoid_matches_a_refined_dense_search_inside_outside_on_axes_and_at_the_centre() {
    let rotation = Rotation3::new(Vector3::new(0.3, -0.5, 0.8)).into_inner();
    let center = Vector3::new(0.02, -0.01, 0.05);
    let cases: [(Vector3<f64>, Matrix3<f64>); 4] = [
        (Vector3::new(0.09, 0.07, 0.11), rotation),
        (Vector3::new(0.1, 0.1, 0.06), Matrix3::identity()), // oblate: two equal axes
        (Vector3::new(0.05, 0.12, 0.05), rotation),          // prolate
        (Vector3::new(0.08, 0.08, 0.08), Matrix3::identity()), // a ball
    ];
    let mut u = Uniform(5);
    for (radii, rotation) in cases {
        let e = Ellipsoid {
            center,
            radii,
            rotation,
        };
        let a = radii;
        let mut local: Vec<Vector3<f64>> = (0..40).map(|_| u.point(0.2)).collect();
        local.extend((0..20).map(|_| u.point(0.05))); // mostly inside
        for axis in 0..3 {
            for s in [0.0, 1e-12, 1e-7, 0.3, 0.9, 0.999_999, 1.0, 1.3, 3.0] {
                let mut y = Vector3::zeros();
                y[axis] = s * a[axis];
                local.push(y);
                local.push(-y);
                // slightly off the axis
                let mut off = y;
                off[(axis + 1) % 3] = 1e-9;
                local.push(off);
            }
            // in the plane of the other two axes, inside
            let mut y = Vector3::new(0.2, 0.3, 0.1).component_mul(&a);
            y[axis] = 0.0;
            local.push(y);
        }
        local.push(Vector3::zeros());
        for y in local {
            let x = center + rotation * y;
            let p = e.query(&x);
            let want = brute_ellipsoid_distance(&a, &y);
            let inside = (0..3).map(|i| (y[i] / a[i]).powi(2)).sum::<f64>() < 1.0;
            let on_surface = p.distance.abs() < 1e-15;
            assert!(
                on_surface || (p.distance < 0.0) == inside,
                "sign at {:?} for {:?}: {p:?}",
                y.as_slice(),
                a.as_slice()
            );
            assert!(
                (p.distance.abs() - want).abs() < 1e-9,
                "{a} at local {y}: {} vs brute force {want}",
                p.distance.abs()
            );
            // the closest point is on the surface, along the normal from x
            let c = rotation.transpose() * (p.closest - center);
            let level: f64 = (0..3).map(|i| (c[i] / a[i]).powi(2)).sum();
            assert!(
                (level - 1.0).abs() < 1e-12,
                "closest point off the surface: {level} at {:?} for {:?}: {p:?}",
                y.as_slice(),
                a.as_slice()
            );
            assert_consistent(&x, &p, 1e-12);
            let surface_normal = rotation * c.component_div(&a.component_mul(&a)).normalize();
            assert!((p.normal - surface_normal).norm() < 1e-12);
        }
    }
}

#[test]
fn the_centre_of_an_ellipsoid_is_nearest_the_ends_of_its_shortest_axis() {
    let e = Ellipsoid {
        center: Vector3::zeros(),
        radii: Vector3::new(0.3, 0.1, 0.2),
        rotation: Matrix3::identity(),
    };
    let p = e.query(&Vector3::zeros());
    assert_eq!(p.distance, -0.1);
    assert!((p.closest.y.abs() - 0.1).abs() < 1e-15 && p.closest.x == 0.0 && p.closest.z == 0.0);
}
