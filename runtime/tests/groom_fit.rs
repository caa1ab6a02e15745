//! The Super-Helix fit of curves (`superhelix_runtime::groom::fit`): an exact
//! Super-Helix is recovered to round-off, a measured-style helix and a random smooth
//! curve within stated bounds that fall with N.

use nalgebra::{Rotation3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use superhelix_runtime::groom::{fit_curve, Curve, FitSettings};
use superhelix_runtime::model::reconstruction::sample_centreline;
use superhelix_runtime::StrandGeometry;

fn curve(points: Vec<Vector3<f64>>) -> Curve {
    Curve {
        points,
        origin: "test".into(),
    }
}

/// A strand of the model: N elements, a curly natural shape varied per element, a
/// turned root frame; its centreline sampled at `per` points per element.
fn model_curve(n: usize, per: usize, seed: u64) -> (Curve, Vec<f64>, f64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let length = 0.2;
    let frame = Rotation3::new(Vector3::new(0.3, -1.1, 0.7)).into_inner();
    let geometry = StrandGeometry {
        root_position: Vector3::new(0.01, 0.02, 0.1),
        root_frame: frame,
        lengths: vec![length / n as f64; n],
        mass_per_length: 1e-5,
        rotary_inertia: [0.0; 3],
        floating: false,
    };
    // curly: helix radius 6 mm, step 5 mm (kappa ~ 160, tau ~ 22 rad/m), +-30 %
    let mut q = Vec::new();
    for _ in 0..n {
        let f: f64 = 1.0 + 0.3 * rng.random_range(-1.0..=1.0);
        q.extend([22.0 * f, 160.0 * f, 10.0 * rng.random_range(-1.0..=1.0)]);
    }
    let mut points = Vec::new();
    sample_centreline(&geometry, &q, per, &mut points);
    (curve(points), q, length)
}

#[test]
fn an_exact_super_helix_is_recovered_to_round_off() {
    for (n, per, seed) in [(5, 6, 1), (10, 4, 2), (8, 3, 3)] {
        let (c, _q, length) = model_curve(n, per, seed);
        let fit = fit_curve(&c, &FitSettings::new(n), None).expect("fits");
        println!(
            "model's own strand, N = {n}, {per} points per element: RMS {:.2e} L, max {:.2e} L, \
             length {:.12} m (true {length}, polyline {:.6})",
            fit.error.rms, fit.error.max, fit.length, fit.polyline_length
        );
        assert!(fit.error.max <= 1e-8, "N = {n}: {:?}", fit.error);
        assert!((fit.length - length).abs() <= 1e-8 * length);
    }
}

/// x = R cos t, y = R sin t, z = c t (a helix about z), turned to hang down from the
/// root, `count` points evenly in t over `turns` turns.
fn analytic_helix(radius: impl Fn(f64) -> f64, c: f64, turns: f64, count: usize) -> Curve {
    let turn = Rotation3::new(Vector3::new(std::f64::consts::PI, 0.0, 0.0)).into_inner();
    let t_end = 2.0 * std::f64::consts::PI * turns;
    let points = (0..count)
        .map(|k| {
            let t = t_end * k as f64 / (count - 1) as f64;
            let r = radius(t / t_end);
            turn * Vector3::new(r * t.cos(), r * t.sin(), c * t)
        })
        .collect();
    curve(points)
}

#[test]
fn measured_style_helices() {
    // a circular helix (curly: R = 6 mm, step 5 mm, 5 turns, 201 points: L = 19.0 cm) is
    // in the model's shape space at every N (one element is an exact helix): it is
    // recovered to round-off even by a single element
    let c = 0.005 / (2.0 * std::f64::consts::PI);
    let helix = analytic_helix(|_| 0.006, c, 5.0, 201);
    for n in [1, 3, 8, 20] {
        let fit = fit_curve(&helix, &FitSettings::new(n), None).expect("fits");
        println!(
            "circular helix, N = {n}: RMS {:.2e} L, max {:.2e} L",
            fit.error.rms, fit.error.max
        );
        assert!(fit.error.max <= 1e-8, "N = {n}: {:?}", fit.error);
        let exact = 5.0 * (2.0 * std::f64::consts::PI * 0.006f64).hypot(0.005);
        assert!((fit.length - exact).abs() <= 1e-8 * exact);
    }
    // a curl that widens from 4 to 8 mm along the strand: its curvature varies along s,
    // which elements of constant curvature follow to second order in their length l
    // (each element's helix matches the curve's curvature at its middle; the curvature
    // is off by |κ′| l/2 at its ends, which displaces the points by O(κ′ l² L)): each
    // doubling of N should divide the error by about 4. Asserted: the error falls at
    // every doubling, and from N = 8 on stays within twice the second-order prediction
    // from N = 4, rms(N) ≤ 2 rms(4) (4/N)².
    let cone = analytic_helix(|u| 0.004 + 0.004 * u, c, 5.0, 301);
    let mut errors = Vec::new();
    for n in [2, 4, 8, 16, 32] {
        let fit = fit_curve(&cone, &FitSettings::new(n), None).expect("fits");
        println!(
            "widening helix, N = {n}: RMS {:.2e} L, max {:.2e} L",
            fit.error.rms, fit.error.max
        );
        errors.push((n, fit.error.rms, fit.error.max));
    }
    for w in errors.windows(2) {
        assert!(w[1].1 < w[0].1 && w[1].2 < w[0].2, "{errors:?}");
    }
    let rms4 = errors[1].1;
    for &(n, rms, _) in &errors[2..] {
        let bound = 2.0 * rms4 * (4.0 / n as f64).powi(2);
        assert!(rms <= bound, "N = {n}: {rms:e} > {bound:e}");
    }
}

/// A random smooth curve: a 20 cm drop plus, along each axis, five sines of 1 to 5
/// periods over the curve with random phases and amplitudes 7.5–15 mm / f² (f the
/// number of periods), 400 points. Length about 22 cm, radius of curvature down to
/// about 1 cm.
fn random_curve(seed: u64) -> Curve {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let terms: Vec<(f64, f64, f64, usize)> = (0..15)
        .map(|k| {
            let freq = 1.0 + (k / 3) as f64;
            let amp = 0.015 / (freq * freq) * rng.random_range(0.5..1.0);
            (
                amp,
                freq,
                rng.random_range(0.0..std::f64::consts::TAU),
                k % 3,
            )
        })
        .collect();
    let points = (0..400)
        .map(|k| {
            let t = k as f64 / 399.0;
            let mut p = Vector3::new(0.0, 0.0, -0.2 * t);
            for &(a, f, phase, axis) in &terms {
                p[axis] += a * ((f * std::f64::consts::TAU * t + phase).sin() - phase.sin());
            }
            p
        })
        .collect();
    curve(points)
}

#[test]
fn random_smooth_curves() {
    // bounds on the largest distance of a point to the fitted strand, relative to L,
    // for N = 10, 20, 40 (measured on seeds 0–2: at most 3.1e-3, 8.2e-4, 1.1e-4); the
    // error falls with N on every curve
    let bounds = [(10, 5e-3), (20, 1.5e-3), (40, 2.5e-4)];
    for seed in 0..3u64 {
        let c = random_curve(seed);
        let mut previous = f64::INFINITY;
        for (n, bound) in bounds {
            let fit = fit_curve(&c, &FitSettings::new(n), None).expect("fits");
            println!(
                "random curve {seed}, N = {n}: RMS {:.2e} L, max {:.2e} L, L = {:.4} m (polyline {:.4} m)",
                fit.error.rms, fit.error.max, fit.length, fit.polyline_length
            );
            assert!(
                fit.error.max <= bound,
                "seed {seed}, N = {n}: {:?}",
                fit.error
            );
            assert!(fit.error.max < previous);
            previous = fit.error.max;
            // the curve is sampled finely: its length is the polyline's to 1 %
            assert!((fit.length / fit.polyline_length - 1.0).abs() < 0.01);
        }
    }
}
