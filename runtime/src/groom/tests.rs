//! Unit tests of the groom parts: parsers, regions, surfaces, elimination.

use super::curves_obj::parse_obj_curves;
use super::curves_usda::parse_usda_curves;
use super::poisson::{eliminate, max_radius, min_distance};
use super::region::{PlaneCut, Region};
use super::surface::Surface;
use nalgebra::{Matrix3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

#[test]
fn obj_polylines_are_read_and_joined() {
    let text = "# hair\nv 0 0 0\nv 0 0 -1\nv 0 0.5 -2 1.0\nv 1 0 0\nv 1 0 -1\n\
                l 1 2\nl 2 3\ng other\nl -2 -1\n";
    let curves = parse_obj_curves(text, "t.obj").expect("valid");
    assert_eq!(curves.len(), 2);
    assert_eq!(curves[0].points.len(), 3);
    assert_eq!(curves[0].points[2], Vector3::new(0.0, 0.5, -2.0));
    assert_eq!(
        curves[1].points,
        vec![Vector3::new(1.0, 0.0, 0.0), Vector3::new(1.0, 0.0, -1.0)]
    );
}

#[test]
fn malformed_obj_names_the_file_and_line() {
    for (text, line, what) in [
        ("v 0 0 0\nv 1 x 0\n", 2, "not a finite number"),
        ("v 0 0 0\nv 1 0 0\nl 1 3\n", 3, "out of range"),
        ("v 0 0 0\nl 1\n", 2, "at least two"),
        ("v 0 0\n", 1, "3 coordinates"),
        ("v 0 0 0\nf 1 1 1\n", 0, "no line records"),
    ] {
        let e = parse_obj_curves(text, "bad.obj").expect_err(text);
        assert!(e.contains("'bad.obj'"), "{e}");
        if line > 0 {
            assert!(e.contains(&format!("line {line}:")), "{e}");
        }
        assert!(e.contains(what), "{e}");
    }
}

#[test]
fn usda_basis_curves_default_value_or_earliest_sample() {
    let text = r#"#usda 1.0
(
    doc = """a "doc" { with [ brackets"""
    upAxis = "Z"
)
def Xform "root" (
    kind = "group"
)
{
    double3 xformOp:translate = (1, 2, 3)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def BasisCurves "a"
    {
        uniform token type = "linear"
        int[] curveVertexCounts = [2, 3]
        point3f[] points.timeSamples = {
            2: [(9, 9, 9), (9, 9, 9), (9, 9, 9), (9, 9, 9), (9, 9, 9)],
            0.5: [(0, 0, 0), (0, 0, -1), (1, 0, 0), (1, 0, -1), (1, 0, -2)],
        }
        float[] widths = [0.1] (
            interpolation = "constant"
        )
        custom dictionary d = { string s = "}" }
    }
    def BasisCurves "b"
    {
        int[] curveVertexCounts = [2]
        point3f[] points = [(0, 1, 0), (0, 1, -1e-1)]
        point3f[] points.timeSamples = { 0: [(5, 5, 5), (5, 5, 5)] }
    }
}
"#;
    let curves = parse_usda_curves(text, "t.usda").expect("valid");
    assert_eq!(curves.len(), 3);
    assert_eq!(
        curves[0].points,
        vec![Vector3::zeros(), Vector3::new(0.0, 0.0, -1.0)]
    );
    assert_eq!(curves[1].points.len(), 3);
    assert_eq!(curves[2].points[1], Vector3::new(0.0, 1.0, -0.1));
}

#[test]
fn malformed_usda_names_the_file_and_line() {
    let head = "#usda 1.0\ndef BasisCurves \"c\"\n{\n";
    for (body, line, what) in [
        ("    int[] curveVertexCounts = [3]\n    point3f[] points = [(0, 0, 0), (1, 0, 0)]\n}\n", 5, "add up to 3"),
        ("    int[] curveVertexCounts = [2]\n    point3f[] points = [(0, 0, 0), (1, x, 0)]\n}\n", 5, "not a finite number"),
        ("    int[] curveVertexCounts = [2]\n    point3f[] points = [(0, 0, 0), (1, 0, 0)]\n", 5, "not closed"),
        ("    uniform token type = \"cubic\"\n    int[] curveVertexCounts = [2]\n    point3f[] points = [(0, 0, 0), (1, 0, 0)]\n}\n", 4, "control points"),
        ("    int[] curveVertexCounts = [1]\n    point3f[] points = [(0, 0, 0)]\n}\n", 4, "at least two"),
        ("    point3f[] points = [(0, 0, 0)]\n}\n", 2, "no curveVertexCounts"),
    ] {
        let text = format!("{head}{body}");
        let e = parse_usda_curves(&text, "bad.usda").expect_err(&text);
        assert!(e.contains(&format!("'bad.usda' line {line}:")), "{e}");
        assert!(e.contains(what), "{e}");
    }
    let e = parse_usda_curves("PXR-USDC", "bin.usd").expect_err("binary");
    assert!(e.contains("line 1") && e.contains(".usda"), "{e}");
}

#[test]
fn regions_cap_and_cut() {
    let region = Region {
        center: Vector3::zeros(),
        axis: Vector3::z(),
        max_angle: 60f64.to_radians(),
        cut: Some(PlaneCut {
            point: Vector3::zeros(),
            normal: Vector3::x(),
        }),
    };
    assert!(region.contains(&Vector3::new(0.1, 0.0, 1.0)));
    assert!(
        !region.contains(&Vector3::new(-0.1, 0.0, 1.0)),
        "behind the cut"
    );
    assert!(
        !region.contains(&Vector3::new(1.0, 0.0, 0.2)),
        "outside the cap"
    );
}

#[test]
fn surfaces_are_sampled_uniformly_by_area() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let surfaces = [
        Surface::Sphere {
            center: Vector3::new(0.0, 0.0, 1.0),
            radius: 0.1,
        },
        Surface::Ellipsoid {
            center: Vector3::zeros(),
            radii: Vector3::new(0.08, 0.1, 0.12),
            rotation: Matrix3::identity(),
        },
        Surface::Capsule {
            start: Vector3::zeros(),
            end: Vector3::new(0.0, 0.0, 0.2),
            radius: 0.05,
        },
    ];
    // the ellipsoid's area against Knud Thomsen's formula (within 1.061 %), exact
    // formulas for the others
    let p = 1.6075;
    let (a, b, c): (f64, f64, f64) = (0.08, 0.1, 0.12);
    let thomsen = 4.0
        * std::f64::consts::PI
        * (((a * b).powf(p) + (a * c).powf(p) + (b * c).powf(p)) / 3.0).powf(1.0 / p);
    let ellipsoid_area = surfaces[1].area();
    assert!(
        (ellipsoid_area / thomsen - 1.0).abs() < 0.011,
        "{ellipsoid_area} {thomsen}"
    );
    for surface in &surfaces {
        // the share of points above the plane z = z0 is that of the area above it
        let n = 40_000;
        let mut above = 0;
        for _ in 0..n {
            let p = surface.sample(&mut rng);
            assert!((p.normal.norm() - 1.0).abs() < 1e-12);
            if p.position.z > surface.center().z {
                above += 1;
            }
        }
        let share = above as f64 / n as f64;
        assert!((share - 0.5).abs() < 0.01, "{surface:?}: {share}");
    }
    // ellipsoid: the share within z > 0.06 (a cap) by the exact area of that cap,
    // measured by the same area quadrature restricted to it
    let e = &surfaces[1];
    let n = 200_000;
    let cap = (0..n)
        .filter(|_| e.sample(&mut rng).position.z > 0.06)
        .count() as f64
        / n as f64;
    let exact = ellipsoid_cap_share(0.06 / 0.12, &Vector3::new(a, b, c));
    assert!(
        (cap - exact).abs() < 4.0 * (exact * (1.0 - exact) / n as f64).sqrt(),
        "{cap} {exact}"
    );
}

/// The share of an ellipsoid's area with z/c > z0, by the midpoint rule in (z, φ) on the
/// sphere (area element abc |u ⊘ a| dz dφ).
fn ellipsoid_cap_share(z0: f64, radii: &Vector3<f64>) -> f64 {
    let (nz, nphi) = (2000, 400);
    let (mut all, mut cap) = (0.0, 0.0);
    for i in 0..nz {
        let z = -1.0 + (i as f64 + 0.5) * 2.0 / nz as f64;
        let r = (1.0 - z * z).sqrt();
        for j in 0..nphi {
            let phi = (j as f64 + 0.5) * 2.0 * std::f64::consts::PI / nphi as f64;
            let w = Vector3::new(r * phi.cos(), r * phi.sin(), z)
                .component_div(radii)
                .norm();
            all += w;
            if z > z0 {
                cap += w;
            }
        }
    }
    cap / all
}

#[test]
fn sample_elimination_keeps_the_count_and_spreads_the_points() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let surface = Surface::Sphere {
        center: Vector3::zeros(),
        radius: 0.1,
    };
    let count = 500;
    let points: Vec<Vector3<f64>> = (0..5 * count)
        .map(|_| surface.sample(&mut rng).position)
        .collect();
    let kept = eliminate(&points, count, surface.area());
    assert_eq!(kept.len(), count);
    let kept_points: Vec<Vector3<f64>> = kept.iter().map(|&i| points[i]).collect();
    let packing = 2.0 * max_radius(surface.area(), count);
    let spread = min_distance(&kept_points, packing) / packing;
    // as many uniform points: the smallest distance is a few percent of the packing's
    let random = min_distance(&points[..count], packing) / packing;
    assert!(spread > 0.5, "{spread}");
    assert!(random < 0.2, "{random}");
    assert_eq!(
        eliminate(&points, count, surface.area()),
        kept,
        "deterministic"
    );
}
