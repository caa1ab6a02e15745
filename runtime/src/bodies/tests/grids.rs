//! Grid bodies (`shape = "grid"`): a ball's signed distance sampled on a grid against the
//! analytic ball, the same code as the kernels' `SdfGrid`, the bounding ball, the scene's
//! fields, and broken files refused naming the field.

use super::{build_errors, build_one, temp_dir, Uniform};
use crate::bodies::shape_sphere::Sphere;
use crate::bodies::{Attachment, BodySetup, Shape, ShapeSetup};
use nalgebra::Vector3;
use std::path::{Path, PathBuf};
use superhelix_kernels::collider::{GridView, SdfGrid};

/// Write `values` (C order) as a version 1.0 float64 `.npy` array of shape `shape`, as
/// NumPy's `np.save` lays it out (the reader under test is not used to write it).
fn write_npy(path: &Path, shape: &[u64], values: &[f64]) {
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let tuple = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let mut dict = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {tuple}, }}");
    // the data starts on a multiple of 64 bytes, the header ends with a newline
    while (10 + dict.len() + 1) % 64 != 0 {
        dict.push(' ');
    }
    dict.push('\n');
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend_from_slice(&(dict.len() as u16).to_le_bytes());
    bytes.extend_from_slice(dict.as_bytes());
    for v in values {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(path, bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}

/// Write `values` (x fastest) as a float64 `.npy` array of shape `(nz, ny, nx)`.
fn write_grid(dir: &Path, name: &str, dims: [usize; 3], values: &[f64]) -> PathBuf {
    let path = dir.join(name);
    let [nx, ny, nz] = dims.map(|n| n as u64);
    write_npy(&path, &[nz, ny, nx], values);
    path
}

/// A grid body fixed in the world.
fn grid_setup(path: PathBuf, origin: Vector3<f64>, cell: f64) -> BodySetup {
    BodySetup {
        name: "grid".into(),
        attached: Attachment::World,
        shape: ShapeSetup::Grid { path, origin, cell },
    }
}

/// The exact signed distance of the ball of radius 0.1 about c = (0.01, −0.02, 0.03),
/// sampled at cell h = 0.01 over c + [−0.2, 0.2]³ and read as a grid body, against the
/// analytic sphere body at 2000 random points of c + [−0.3, 0.3]³ at least 0.05 m from
/// c (beyond the cell's reach): inside the box within the trilinear interpolation bound
/// `(h²/8) Σ|∂²f/∂x_i²| ≤ 3h² / (8ρ)` (the ball's distance has Hessian `(I − n nᵀ)/|x|`,
/// ρ the least distance from c over the cell, ≥ |x − c| − √3 h), the normal within
/// `2√3 h/ρ` (each gradient component within h max|∂²f| of the exact one, normalising
/// at most doubles it); beyond the box never below the exact distance by more than the
/// bound (the extension `f(p) + |x − p|` is an upper bound of a true distance, up to
/// f(p)'s own error). The body answers exactly what the kernels' `SdfGrid` answers on
/// the same values (the C ABI's grid collider), and its bounding ball never rules out a
/// point within reach.
#[test]
fn a_sampled_ball_agrees_with_the_analytic_ball_within_the_interpolation_bound() {
    let dir = temp_dir("grid-ball");
    let (r, h, n) = (0.1, 0.01, 41usize);
    let c = Vector3::new(0.01, -0.02, 0.03);
    let origin = c - Vector3::repeat(0.2);
    let mut values = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let x = origin + Vector3::new(i as f64, j as f64, k as f64) * h;
                values.push((x - c).norm() - r);
            }
        }
    }
    let path = write_grid(&dir, "ball.npy", [n, n, n], &values);
    let body = build_one(grid_setup(path, origin, h));
    let Shape::Grid(sdf) = &body.shape else {
        panic!("{:?}", body.shape)
    };
    assert_eq!(sdf.grid().dims(), [n, n, n]);
    let ball = Shape::Sphere(Sphere {
        center: c,
        radius: r,
    });
    let kernels = SdfGrid {
        grid: GridView::new(origin, h, [n, n, n], &values).expect("a valid grid"),
    };
    let mut rng = Uniform(0x9e37_79b9_7f4a_7c15);
    let (mut inside, mut beyond, mut worst) = (0, 0, 0.0f64);
    while inside + beyond < 2000 {
        let x = c + rng.point(0.3);
        let rho = (x - c).norm() - 3f64.sqrt() * h;
        if rho < 0.05 {
            continue;
        }
        let bound = 3.0 * h * h / (8.0 * rho) * (1.0 + 1e-9) + 1e-15;
        let got = body.shape.query(&x);
        let exact = ball.query(&x);
        assert_eq!(
            got,
            kernels.query(&(x)),
            "{x}: the grid body is the kernels' SdfGrid"
        );
        if (x - c).iter().all(|v| v.abs() <= 0.2) {
            inside += 1;
            let err = (got.distance - exact.distance).abs();
            worst = worst.max(err / bound);
            assert!(
                err <= bound,
                "{x}: {} against {}, bound {bound:e}",
                got.distance,
                exact.distance
            );
            let turn = (got.normal - exact.normal).norm();
            assert!(
                turn <= 2.0 * 3f64.sqrt() * h / rho,
                "{x}: normal {}",
                got.normal
            );
        } else {
            beyond += 1;
            assert!(
                got.distance >= exact.distance - bound,
                "{x}: {}",
                got.distance
            );
        }
        for reach in [0.0, 1e-3, 0.05] {
            if body.shape.farther_than(&x, reach) {
                assert!(got.distance > reach, "{x}: ruled out at {}", got.distance);
            }
        }
    }
    assert!(
        inside > 500 && beyond > 500,
        "{inside} inside, {beyond} beyond"
    );
    // the bound is not slack by orders of magnitude: the worst point uses a fair share
    assert!(worst > 0.05, "worst error {worst} of the bound");
}

/// A grid whose body reaches its box's boundary (a half-space's distance, negative on
/// part of the boundary): the bounding ball grows by the deepest boundary value, so a
/// point outside the box but near the cut surface is still queried.
#[test]
fn the_bounding_ball_of_a_grid_cut_by_its_surface_keeps_the_points_near_it() {
    let dir = temp_dir("grid-cut");
    let (h, n) = (0.01, 11usize);
    let origin = Vector3::zeros();
    let mut values = Vec::new();
    for _k in 0..n {
        for _j in 0..n {
            for i in 0..n {
                // the half-space x ≤ 0.05, cut by the box's faces
                values.push(i as f64 * h - 0.05);
            }
        }
    }
    let path = write_grid(&dir, "cut.npy", [n, n, n], &values);
    let body = build_one(grid_setup(path, origin, h));
    let mut rng = Uniform(7);
    for _ in 0..2000 {
        let x = Vector3::new(0.05, 0.05, 0.05) + rng.point(0.4);
        let got = body.shape.query(&x);
        for reach in [0.0, 1e-3, 0.02] {
            if body.shape.farther_than(&x, reach) {
                assert!(got.distance > reach, "{x}: ruled out at {}", got.distance);
            }
        }
    }
}

#[test]
fn broken_grids_are_refused_naming_the_field() {
    let dir = temp_dir("grid-broken");
    let good = vec![0.0; 8];
    let mut nan = good.clone();
    nan[5] = f64::NAN;
    let flat = dir.join("flat.npy");
    write_npy(&flat, &[2, 4], &good);
    let cases = [
        (dir.join("missing.npy"), 0.01, "path", "missing.npy"),
        (flat, 0.01, "path", "3 axes"),
        (
            write_grid(&dir, "thin.npy", [8, 1, 1], &good),
            0.01,
            "path",
            "at least 2",
        ),
        (
            write_grid(&dir, "nan.npy", [2, 2, 2], &nan),
            0.01,
            "path",
            "value 5 is NaN",
        ),
        (
            write_grid(&dir, "good.npy", [2, 2, 2], &good),
            0.0,
            "cell",
            "(0, 1000]",
        ),
        (dir.join("good.npy"), f64::NAN, "cell", "(0, 1000]"),
    ];
    for (path, cell, field, fragment) in cases {
        let errors = build_errors(grid_setup(path.clone(), Vector3::zeros(), cell));
        let hit = errors
            .iter()
            .find(|e| e.field == format!("bodies[0].{field}"));
        assert!(
            hit.is_some_and(|e| e.message.contains(fragment)),
            "{}: expected bodies[0].{field} with '{fragment}', got {errors:?}",
            path.display()
        );
    }
    let errors = build_errors(grid_setup(
        dir.join("good.npy"),
        Vector3::new(0.0, f64::INFINITY, 0.0),
        0.01,
    ));
    assert!(
        errors.iter().any(|e| e.field == "bodies[0].origin"),
        "{errors:?}"
    );
}
