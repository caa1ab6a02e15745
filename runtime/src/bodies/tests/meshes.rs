//! Mesh bodies: OBJ files written here, their sampled fields against the exact distances
//! of the solids they tessellate, and the errors of broken meshes.

use super::{build_errors, build_one, mesh_setup, temp_dir, write_obj, Uniform};
use crate::bodies::grid::Grid;
use crate::bodies::mesh_distance::MeshDistance;
use crate::bodies::triangle_mesh::ClosedMesh;
use crate::bodies::{Body, Shape};
use nalgebra::Vector3;
use std::collections::HashMap;

/// An icosphere of radius `r` about `c`: the icosahedron subdivided `levels` times, every
/// vertex on the sphere (20 · 4^levels triangles, outward).
fn icosphere(c: Vector3<f64>, r: f64, levels: usize) -> (Vec<Vector3<f64>>, Vec<[usize; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<Vector3<f64>> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vector3::new(p[0], p[1], p[2]).normalize())
    .collect();
    let mut f: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid: HashMap<(usize, usize), usize> = HashMap::new();
        let mut next = Vec::with_capacity(f.len() * 4);
        for tri in &f {
            let m: [usize; 3] = std::array::from_fn(|k| {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    v.push(((v[a] + v[b]) / 2.0).normalize());
                    v.len() - 1
                })
            });
            next.push([tri[0], m[0], m[2]]);
            next.push([tri[1], m[1], m[0]]);
            next.push([tri[2], m[2], m[1]]);
            next.push(m);
        }
        f = next;
    }
    (v.into_iter().map(|p| c + p * r).collect(), f)
}

/// The largest gap between a sphere of radius `r` and the flat triangles of a mesh whose
/// vertices lie on it: R − √(R² − ρ²) for the largest circumradius ρ. The mesh lies in
/// the shell between radii R − gap and R, so its signed distance differs from the
/// sphere's by at most the gap everywhere (a ray from the centre crosses the mesh once,
/// within the shell).
fn sagitta(vertices: &[Vector3<f64>], triangles: &[[usize; 3]], r: f64) -> f64 {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| vertices[i]);
            let (la, lb, lc) = ((b - c).norm(), (c - a).norm(), (a - b).norm());
            let area2 = (b - a).cross(&(c - a)).norm();
            let rho = la * lb * lc / (2.0 * area2);
            r - (r * r - rho * rho).sqrt()
        })
        .fold(0.0, f64::max)
}

fn grid_of(body: &Body) -> &Grid {
    match &body.shape {
        Shape::Mesh(sdf) => sdf.grid(),
        other => panic!("not a mesh: {other:?}"),
    }
}

/// Every node of `grid`.
fn nodes(grid: &Grid) -> impl Iterator<Item = [usize; 3]> {
    let [nx, ny, nz] = grid.dims();
    (0..nz).flat_map(move |k| (0..ny).flat_map(move |j| (0..nx).map(move |i| [i, j, k])))
}

#[test]
fn a_tessellated_sphere_matches_the_analytic_sphere_within_the_derived_tolerance() {
    let (c, r) = (Vector3::new(0.01, -0.02, 0.015), 0.1);
    let (vertices, triangles) = icosphere(c, r, 4); // 5120 triangles
    let gap = sagitta(&vertices, &triangles, r);
    assert!(gap < 2e-4, "{gap}");
    let dir = temp_dir("sphere");
    let path = write_obj(&dir, "sphere.obj", &vertices, &triangles);
    let h = 0.008;
    let body = build_one(mesh_setup(path, Some(h)));
    let grid = grid_of(&body);
    assert_eq!(grid.cell(), h);
    let sphere = |x: &Vector3<f64>| (x - c).norm() - r;
    // nodes: the exact mesh distance, within the tessellation gap of the sphere's
    let mut inside = 0;
    for n in nodes(grid) {
        let x = grid.node_position(n);
        let d = grid.node(n);
        assert!(
            (d - sphere(&x)).abs() <= gap + 1e-12,
            "node {x}: {d} vs {}",
            sphere(&x)
        );
        if sphere(&x) < -gap {
            assert!(d < 0.0);
            inside += 1;
        }
    }
    assert!(inside > 1000, "{inside} nodes inside");
    // between nodes: the interpolant of (mesh − sphere), within the gap, plus the
    // trilinear error of the sphere's distance, (h²/8) Σᵢ max|∂ᵢ²d| ≤ 3h²/(8 r_min) with
    // r_min ≥ |x − c| − √3 h the nearest a cell corner comes to the centre
    let mut u = Uniform(21);
    let (lo, hi) = (grid.origin(), grid.corner());
    let mut checked = 0;
    while checked < 4000 {
        let x = lo + Vector3::from_fn(|a, _| u.next() * (hi[a] - lo[a]));
        let rc = (x - c).norm();
        let r_min = rc - 3f64.sqrt() * h;
        if r_min < 0.3 * r {
            continue;
        }
        checked += 1;
        let tol = gap + 3.0 * h * h / (8.0 * r_min) + 1e-12;
        let p = body.query(&Default::default(), &x);
        assert!(
            (p.distance - sphere(&x)).abs() <= tol,
            "{x}: {} vs {}",
            p.distance,
            sphere(&x)
        );
        if sphere(&x) < -tol {
            assert!(p.distance < 0.0, "inside points are negative");
        }
        // the normal points away from the centre, to within the interpolation's slope error
        assert!(
            p.normal.dot(&(x - c).normalize()) > 0.9,
            "{x}: {}",
            p.normal
        );
    }
    // beyond the grid: the extension is the boundary value plus the distance to the box,
    // an upper bound of the distance to the sphere (1-Lipschitz), and points outward
    for _ in 0..200 {
        let x = c + u.point(1.0) + Vector3::new(0.6, 0.0, 0.0);
        let p = body.query(&Default::default(), &x);
        let box_point = x.sup(&lo).inf(&hi);
        let at_box = body.query(&Default::default(), &box_point).distance;
        assert!((p.distance - (at_box + (x - box_point).norm())).abs() < 1e-12);
        let tol = gap + 3.0 * h * h / (8.0 * ((box_point - c).norm() - 3f64.sqrt() * h));
        assert!(p.distance >= sphere(&x) - tol, "an upper bound");
        assert!(p.normal.dot(&(x - c)) > 0.0);
    }
    let _ = std::fs::remove_dir_all(dir);
}

/// A cube of half-side `a` about `c`, each face split into n × n squares of two triangles,
/// the vertices shared (a closed manifold mesh with flat edges inside the faces).
fn cube(c: Vector3<f64>, a: f64, n: usize) -> (Vec<Vector3<f64>>, Vec<[usize; 3]>) {
    let mut index: HashMap<[i64; 3], usize> = HashMap::new();
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    let mut vertex = |p: [i64; 3]| {
        *index.entry(p).or_insert_with(|| {
            vertices.push(
                c + Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64) * (a * 2.0 / n as f64)
                    - Vector3::repeat(a),
            );
            vertices.len() - 1
        })
    };
    let n = n as i64;
    for axis in 0..3 {
        for side in [0, n] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for i in 0..n {
                for j in 0..n {
                    let corner = |di: i64, dj: i64| {
                        let mut p = [0i64; 3];
                        p[axis] = side;
                        p[u] = i + di;
                        p[v] = j + dj;
                        p
                    };
                    let q =
                        [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)].map(&mut vertex);
                    // u × v = axis: counter-clockwise from outside on the far side
                    if side == n {
                        triangles.push([q[0], q[1], q[2]]);
                        triangles.push([q[0], q[2], q[3]]);
                    } else {
                        triangles.push([q[0], q[2], q[1]]);
                        triangles.push([q[0], q[3], q[2]]);
                    }
                }
            }
        }
    }
    (vertices, triangles)
}

/// The exact signed distance of the box of half-side `a` about `c`.
fn box_distance(x: &Vector3<f64>, c: &Vector3<f64>, a: f64) -> f64 {
    let q = (x - c).abs() - Vector3::repeat(a);
    q.sup(&Vector3::zeros()).norm() + q.max().min(0.0)
}

#[test]
fn a_cube_mesh_gives_the_exact_box_distance_at_every_node_and_where_it_is_linear() {
    let (c, a) = (Vector3::new(0.003, -0.001, 0.002), 0.05);
    let (vertices, triangles) = cube(c, a, 3);
    // a mesh turned inward is turned outward
    let inward: Vec<[usize; 3]> = triangles.iter().map(|t| [t[0], t[2], t[1]]).collect();
    let dir = temp_dir("cube");
    for (name, tris) in [("cube.obj", &triangles), ("inward.obj", &inward)] {
        let path = write_obj(&dir, name, &vertices, tris);
        let h = 0.0071;
        let body = build_one(mesh_setup(path, Some(h)));
        let grid = grid_of(&body);
        // every node, inside and out, near edges, corners and the medial planes: the
        // pseudonormals sign it right, the closest points make it exact
        for n in nodes(grid) {
            let x = grid.node_position(n);
            let want = box_distance(&x, &c, a);
            assert!(
                (grid.node(n) - want).abs() < 1e-12,
                "{name} node {x}: {} vs {want}",
                grid.node(n)
            );
        }
        let mut u = Uniform(99);
        for _ in 0..3000 {
            let x = c + u.point(0.09);
            let want = box_distance(&x, &c, a);
            let got = body.query(&Default::default(), &x).distance;
            // any point: a convex combination of corner values of a 1-Lipschitz field
            assert!(
                (got - want).abs() <= 3f64.sqrt() * h,
                "{x}: {got} vs {want}"
            );
            // where the box distance is linear over the whole cell (one face's slab, or
            // the distance to one face inside), trilinear interpolation is exact
            let corners: Vec<Vector3<f64>> = cell_corners(grid, &x);
            let region = |p: &Vector3<f64>| {
                let q = (p - c).abs() - Vector3::repeat(a);
                let outside: Vec<usize> = (0..3).filter(|&i| q[i] > 0.0).collect();
                match outside.len() {
                    0 => Some((q.imax(), (p - c)[q.imax()] > 0.0, false)),
                    1 => Some((outside[0], (p - c)[outside[0]] > 0.0, true)),
                    _ => None,
                }
            };
            let first = region(&corners[0]);
            if first.is_some() && corners.iter().chain([&x]).all(|p| region(p) == first) {
                assert!(
                    (got - want).abs() < 1e-12,
                    "linear cell at {x}: {got} vs {want}"
                );
            }
            if want < -1e-3 {
                assert!(got < 0.0);
            }
        }
    }
    let _ = std::fs::remove_dir_all(dir);
}

/// The eight nodes of the cell that holds `x` (inside the grid).
fn cell_corners(grid: &Grid, x: &Vector3<f64>) -> Vec<Vector3<f64>> {
    let u = (x - grid.origin()) / grid.cell();
    let base: [usize; 3] = std::array::from_fn(|a| (u[a].floor() as usize).min(grid.dims()[a] - 2));
    (0..8)
        .map(|m| {
            grid.node_position([
                base[0] + (m & 1),
                base[1] + ((m >> 1) & 1),
                base[2] + ((m >> 2) & 1),
            ])
        })
        .collect()
}

#[test]
fn the_gradient_of_the_grid_field_is_its_derivative_inside_and_beyond_the_grid() {
    let (vertices, triangles) = icosphere(Vector3::zeros(), 0.1, 2);
    let mesh = match ClosedMesh::new(&vertices, &triangles) {
        Ok(m) => m,
        Err(e) => panic!("{e}"),
    };
    let sdf = match crate::bodies::mesh_sdf::MeshSdf::build(mesh, Some(0.01)) {
        Ok(s) => s,
        Err(e) => panic!("{e:?}"),
    };
    let grid = sdf.grid();
    let h = grid.cell();
    let mut u = Uniform(4);
    let mut tested = 0;
    while tested < 1000 {
        let x = u.point(0.25);
        // central differences within one cell: the interpolant is linear along each axis
        // there, so they are exact up to rounding; stay clear of cell faces
        let cell_u = (x - grid.origin()) / h;
        let inside_grid = x == x.sup(&grid.origin()).inf(&grid.corner());
        let clear = (0..3).all(|a| {
            let f = cell_u[a] - cell_u[a].floor();
            (0.01..0.99).contains(&f)
        });
        if inside_grid && !clear {
            continue;
        }
        tested += 1;
        let (_, gradient) = grid.sample(&x);
        let step = 1e-6 * h;
        let fd = Vector3::from_fn(|a, _| {
            let e = Vector3::ith(a, step);
            (grid.sample(&(x + e)).0 - grid.sample(&(x - e)).0) / (2.0 * step)
        });
        assert!((gradient - fd).norm() < 1e-6, "{x}: {gradient} vs {fd}");
    }
}

#[test]
fn the_exact_mesh_distance_signs_points_inside_negative() {
    let (vertices, triangles) = cube(Vector3::zeros(), 0.05, 2);
    let distance = match ClosedMesh::new(&vertices, &triangles) {
        Ok(m) => MeshDistance::new(m),
        Err(e) => panic!("{e}"),
    };
    let mut u = Uniform(8);
    for _ in 0..2000 {
        let x = u.point(0.12);
        let want = box_distance(&x, &Vector3::zeros(), 0.05);
        let got = distance.at(&x);
        assert!(
            (got.distance - want).abs() < 1e-14,
            "{x}: {} vs {want}",
            got.distance
        );
        assert!(((x - got.closest).norm() - want.abs()).abs() < 1e-14);
    }
}

#[test]
fn broken_meshes_and_grids_are_refused_naming_the_field() {
    let dir = temp_dir("broken");
    let (vertices, triangles) = cube(Vector3::zeros(), 0.05, 1);
    let mut flipped = triangles.clone();
    flipped[0] = [flipped[0][0], flipped[0][2], flipped[0][1]];
    // two tetrahedra sharing one edge: that edge has four triangles
    let tetra_pair_vertices: Vec<Vector3<f64>> = [
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.5],
        [0.0, 1.0, 0.5],
        [-1.0, 0.0, 0.5],
        [0.0, -1.0, 0.5],
    ]
    .iter()
    .map(|p| Vector3::new(p[0], p[1], p[2]))
    .collect();
    let tetra =
        |a: usize, b: usize, c: usize, d: usize| [[a, c, b], [a, b, d], [a, d, c], [b, c, d]];
    let mut tetra_pair: Vec<[usize; 3]> = tetra(0, 1, 2, 3).to_vec();
    tetra_pair.extend(tetra(0, 1, 4, 5));
    let empty = dir.join("empty.obj");
    let _ = std::fs::write(&empty, "# nothing\nv 0 0 0\nv 1 0 0\n");
    let not_obj = dir.join("garbage.obj");
    let _ = std::fs::write(&not_obj, "f 1 2 3\n");
    let cases = [
        (dir.join("missing.obj"), "path", "cannot read"),
        (empty, "path", "no triangles"),
        (not_obj, "path", "not a readable OBJ"),
        (
            write_obj(&dir, "open.obj", &vertices, &triangles[..11]),
            "path",
            "the mesh is open",
        ),
        (
            write_obj(&dir, "flipped.obj", &vertices, &flipped),
            "path",
            "not consistently oriented",
        ),
        (
            write_obj(&dir, "fins.obj", &tetra_pair_vertices, &tetra_pair),
            "path",
            "not manifold",
        ),
    ];
    for (path, field, fragment) in cases {
        let errors = build_errors(mesh_setup(path.clone(), None));
        let hit = errors
            .iter()
            .find(|e| e.field == format!("bodies[0].{field}"));
        assert!(
            hit.is_some_and(|e| e.message.contains(fragment)),
            "{}: expected '{fragment}' on bodies[0].{field}, got {errors:?}",
            path.display()
        );
    }
    // a grid over the cap: the error names the cell and the smallest cell allowed
    let path = write_obj(&dir, "cube.obj", &vertices, &triangles);
    let errors = build_errors(mesh_setup(path.clone(), Some(1e-4)));
    assert_eq!(errors[0].field, "bodies[0].cell");
    assert!(
        errors[0].message.contains("use cell >="),
        "{}",
        errors[0].message
    );
    let _ = std::fs::remove_dir_all(dir);
}
