//! Static branches followed by pseudo-arclength continuation
//! (`Simulation::follow_branch`) against the elastica, a reference nobody here wrote: a
//! cantilever column pushed slightly off its axis has a complementary branch (bent
//! against the push's lateral part) whose load has a minimum, a fold, given by
//! Frisch-Fay's first integral in elliptic integrals.

use superhelix_runtime::solver::continuation::{BranchParameter, ContinuationSettings};
use superhelix_runtime::{parse_scene, Simulation};

const L: f64 = 0.2;
const N: usize = 20;
const PSI: f64 = 0.05;

/// ∫₀^φ (1 − k² sin² t)^(−1/2) dt by composite Simpson (smooth for k < 1).
fn elliptic_f(phi: f64, k: f64) -> f64 {
    let m = 4000;
    let h = phi / m as f64;
    let f = |t: f64| 1.0 / (1.0 - (k * t.sin()).powi(2)).sqrt();
    let mut s = f(0.0) + f(phi);
    for i in 1..m {
        s += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

/// The load P/EI·L² on the complementary branch at the tip angle α from the force's
/// line: u(0) = −ψ, u(L) = α, EI u'' = −P sin u, so
/// √(P/EI) L = K(k) + F(asin(sin(ψ/2)/k), k) with k = sin(α/2).
fn complementary(alpha: f64) -> f64 {
    let k = (alpha / 2.0).sin();
    let root = ((PSI / 2.0).sin() / k).asin();
    (elliptic_f(std::f64::consts::FRAC_PI_2, k) + elliptic_f(root, k)).powi(2)
}

fn column(engine: &str) -> (Simulation, f64) {
    let ei = 2e11 * std::f64::consts::PI * 1e-12 / 4.0;
    let p_cr = std::f64::consts::PI.powi(2) * ei / (4.0 * L * L);
    let (fx, fz) = (-p_cr * PSI.cos(), -p_cr * PSI.sin());
    let text = format!(
        "[simulation]\nengine = \"{engine}\"\n[environment]\ngravity = \"none\"\n\
         [[strands]]\nname = \"column\"\nroot = [0.0, 0.0, 0.0]\nlength = {L}\nelements = {N}\n\
         radius = 1e-3\nyoungs_modulus = 2e11\npoisson = 0.3\ndensity = 7800.0\n\
         direction = [1.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nnatural = [0.0, 0.0, 0.0]\n\
         initial = \"straight\"\nair_drag = 0.0\ninternal_friction = 0.0\n\
         [[strands.point_loads]]\ns = {L}\nforce = [{fx}, 0.0, {fz}]\n"
    );
    let sim = Simulation::new(parse_scene(&text).expect("scene"), None).expect("simulation");
    (sim, ei)
}

#[test]
fn an_off_axis_column_is_followed_through_the_fold_of_its_complementary_branch() {
    for engine in ["runtime", "embedded"] {
        let (mut sim, _) = column(engine);
        // bent up by 2 rad against the push's downward part: the complementary branch
        let mut q = vec![0.0; 3 * N];
        for e in 0..N {
            q[3 * e + 2] = 2.0 / L;
        }
        sim.set_state(0, &q, &vec![0.0; 3 * N]);
        let settings = ContinuationSettings {
            parameter: BranchParameter::LoadScale,
            start: 2.0,
            stop: 0.5,
            step: 0.02,
            max_step: 0.2,
            max_points: 80,
        };
        let branch = sim.follow_branch(0, &settings).expect("branch");
        assert_eq!(branch.folds.len(), 1, "{engine}: {:?}", branch.folds);
        // the elastica's fold: the least load over α (golden section)
        let (mut a, mut b) = (PSI * 1.0001, 3.0);
        let g = (5f64.sqrt() - 1.0) / 2.0;
        while b - a > 1e-9 {
            let (c, d) = (b - g * (b - a), a + g * (b - a));
            if complementary(c) < complementary(d) {
                b = d;
            } else {
                a = c;
            }
        }
        // in units of P_cr = π²EI/(4L²)
        let p_fold = complementary(0.5 * (a + b)) * 4.0 / std::f64::consts::PI.powi(2);
        let fold = &branch.folds[0];
        // the piecewise-constant curvature's error in a buckling load is ~1/N² (0.03 %
        // for Euler's load at N = 40): 3e-3 at N = 20 is its scale
        let error = fold.point.parameter / p_fold - 1.0;
        assert!(
            error.abs() < 3e-3,
            "{engine}: fold at {} against {p_fold}",
            fold.point.parameter
        );
        // falling before the fold, rising after
        let k = fold.after;
        for (j, w) in branch.points.windows(2).enumerate() {
            let rising = w[1].parameter > w[0].parameter;
            assert_eq!(rising, j > k, "{engine}: point {j}");
        }
        // in 3D the planar complementary branch has one unstable direction out of its
        // plane (bent against the push, the rod can swing round the push's line toward
        // the principal branch); the fold adds one in the plane
        for (j, p) in branch.points.iter().enumerate() {
            let expected = if j <= k { 1 } else { 2 };
            assert_eq!(p.unstable, expected, "{engine}: point {j}");
        }
        // every point on the elastica's branch at its tip angle
        for p in branch.points.iter().step_by(3) {
            sim.set_state(0, &p.q, &vec![0.0; 3 * N]);
            let t = sim.poses_world(0, &[L])[0].frame.column(0).into_owned();
            let alpha = t[2].atan2(t[0]) - PSI;
            if alpha < 1.05 * PSI {
                break;
            }
            let exact = complementary(alpha) * 4.0 / std::f64::consts::PI.powi(2);
            assert!(
                (p.parameter / exact - 1.0).abs() < 3e-3,
                "{engine}: at α = {alpha}: {} against {exact}",
                p.parameter
            );
        }
        // the loads are as the scene gave them
        assert!(sim.point_loads(0)[0].force[0] < 0.0);
    }
}

#[test]
fn a_branch_is_refused_for_settings_out_of_range() {
    let (sim, _) = column("runtime");
    let base = ContinuationSettings {
        parameter: BranchParameter::LoadScale,
        start: 1.0,
        stop: 2.0,
        step: 0.02,
        max_step: 0.2,
        max_points: 10,
    };
    let cases = [
        (ContinuationSettings { stop: 1.0, ..base }, "stop"),
        (ContinuationSettings { step: 0.0, ..base }, "step"),
        (
            ContinuationSettings {
                max_step: 0.01,
                ..base
            },
            "max_step",
        ),
        (
            ContinuationSettings {
                max_points: 1,
                ..base
            },
            "max_points",
        ),
        (
            ContinuationSettings {
                start: f64::NAN,
                ..base
            },
            "start",
        ),
        (
            ContinuationSettings {
                parameter: BranchParameter::Holder {
                    direction: nalgebra::Vector3::x(),
                },
                ..base
            },
            "parameter",
        ),
    ];
    for (settings, field) in cases {
        let e = sim
            .follow_branch(0, &settings)
            .expect_err(field)
            .to_string();
        assert!(e.contains(field), "{field}: {e}");
    }
}

#[test]
fn the_principal_branch_of_the_off_axis_column_is_stable_and_the_elasticas() {
    // from nearly straight at half Euler's load to three times it, bending with the
    // push's lateral part: u(0) = −ψ, u(L) = −α, √(P/EI) L = K(k) − F(asin(sin(ψ/2)/k), k)
    let (mut sim, _) = column("runtime");
    let settings = ContinuationSettings {
        parameter: BranchParameter::LoadScale,
        start: 0.5,
        stop: 3.0,
        step: 0.02,
        max_step: 0.2,
        max_points: 200,
    };
    let branch = sim.follow_branch(0, &settings).expect("branch");
    assert!(branch.folds.is_empty());
    assert_eq!(
        branch.end,
        superhelix_runtime::solver::continuation::BranchEnd::Reached
    );
    assert_eq!(branch.points.last().map(|p| p.parameter), Some(3.0));
    for p in &branch.points {
        assert_eq!(p.unstable, 0, "at {}", p.parameter);
        sim.set_state(0, &p.q, &vec![0.0; 3 * N]);
        let t = sim.poses_world(0, &[L])[0].frame.column(0).into_owned();
        let alpha = -(t[2].atan2(t[0]) - PSI);
        let k = (alpha / 2.0).sin();
        let root = ((PSI / 2.0).sin() / k).asin();
        let exact = (elliptic_f(std::f64::consts::FRAC_PI_2, k) - elliptic_f(root, k)).powi(2)
            * 4.0
            / std::f64::consts::PI.powi(2);
        assert!(
            (p.parameter / exact - 1.0).abs() < 3e-3,
            "at α = {alpha}: {} against {exact}",
            p.parameter
        );
    }
}

/// ∫₀^{π/2} (1 − k² sin² t)^(1/2) dt by composite Simpson.
fn elliptic_e(k: f64) -> f64 {
    let m = 4000;
    let phi = std::f64::consts::FRAC_PI_2;
    let h = phi / m as f64;
    let f = |t: f64| (1.0 - (k * t.sin()).powi(2)).sqrt();
    let mut s = f(0.0) + f(phi);
    for i in 1..m {
        s += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

#[test]
fn a_pinned_column_shortened_by_its_holder_follows_the_elastica() {
    // pinned at both ends, the holder moved toward the root: at the end shortening
    // D/L = 2 (1 − E(k)/K(k)) the holder pushes with P/P_cr = (2K(k)/π)², P_cr = π²EI/L²
    // (the pinned elastica). It starts 1 % in, bowed as a circular arc; a rod held at two
    // points can turn about the line through them at no cost, a zero mode the branch
    // is kept orthogonal to.
    let n = 40;
    let curvature = (24.0f64 * 0.01).sqrt() / L;
    let q0: Vec<String> = (0..n).map(|_| format!("0.0, 0.0, {curvature}")).collect();
    let text = format!(
        "[simulation]\n[environment]\ngravity = \"none\"\n\
         [[strands]]\nname = \"column\"\nroot = [0.0, 0.0, 0.0]\nlength = {L}\nelements = {n}\n\
         radius = 1e-3\nyoungs_modulus = 2e11\npoisson = 0.3\ndensity = 7800.0\n\
         direction = [1.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nnatural = [0.0, 0.0, 0.0]\n\
         q0 = [{}]\nair_drag = 0.0\ninternal_friction = 0.0\n[strands.ends]\nroot = \"pinned\"\n\
         [strands.ends.tip]\nkind = \"pinned\"\nposition = [{}, 0.0, 0.0]\n",
        q0.join(", "),
        0.99 * L
    );
    let sim = Simulation::new(parse_scene(&text).expect("scene"), None).expect("simulation");
    let settings = ContinuationSettings {
        parameter: BranchParameter::Holder {
            direction: nalgebra::Vector3::new(-1.0, 0.0, 0.0),
        },
        start: 0.0,
        stop: 0.5 * L,
        step: 0.02,
        max_step: 0.2,
        max_points: 200,
    };
    let branch = sim.follow_branch(0, &settings).expect("branch");
    assert_eq!(
        branch.end,
        superhelix_runtime::solver::continuation::BranchEnd::Reached
    );
    assert!(branch.folds.is_empty() && branch.branch_points.is_empty());
    let ei = 2e11 * std::f64::consts::PI * 1e-12 / 4.0;
    let p_cr = std::f64::consts::PI.powi(2) * ei / (L * L);
    for p in &branch.points {
        assert_eq!(p.unstable, 0, "at {}", p.parameter);
        let shortening = (0.01 * L + p.parameter) / L;
        let (mut lo, mut hi) = (0.0, 0.99);
        for _ in 0..50 {
            let k = 0.5 * (lo + hi);
            let d = 2.0 * (1.0 - elliptic_e(k) / elliptic_f(std::f64::consts::FRAC_PI_2, k));
            if d < shortening {
                lo = k;
            } else {
                hi = k;
            }
        }
        let k = 0.5 * (lo + hi);
        let exact =
            (2.0 * elliptic_f(std::f64::consts::FRAC_PI_2, k) / std::f64::consts::PI).powi(2);
        // the holder pushes the tip toward the root
        let force = -p.reaction[0] / p_cr;
        // the discretisation's ~1/N² (6e-4 at N = 40)
        assert!(
            (force / exact - 1.0).abs() < 2e-3,
            "D/L = {shortening}: {force} against {exact}"
        );
    }
}
