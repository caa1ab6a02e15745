//! Static electricity: the coupling Σ J(s_i)ᵀ F_i against the gradient of the
//! electrostatic energy, the charged equilibrium, charged dynamics, and a scene without
//! charge building nothing.

use superhelix_runtime::forces::head_motion::HeadState;
use superhelix_runtime::{parse_scene, Simulation};

fn sim(text: &str) -> Simulation {
    let setup = parse_scene(text).unwrap_or_else(|e| panic!("{e}"));
    Simulation::new(setup, None).unwrap_or_else(|e| panic!("{e}"))
}

/// Two short fibres side by side, 4 mm apart, strongly charged.
const PAIR: &str = r#"
[simulation]
mode = "static"
[environment]
gravity = "none"
[electrostatics]
charge_per_length = -2e-9
particle_density = 400
method = "direct"
[[strands]]
root = [0.0, 0.0, 0.0]
direction = [0.3, 0.1, -1.0]
length = 0.05
elements = 3
preset = "wavy"
[[strands]]
root = [0.004, 0.0, 0.0]
direction = [-0.2, 0.0, -1.0]
length = 0.05
elements = 3
preset = "wavy"
"#;

/// The generalized force the particles put on a strand is −∂U/∂q of the electrostatic
/// energy U = ½ k Σ q_i Φ_i (central differences of U in each coordinate).
#[test]
fn generalized_coulomb_force_is_minus_the_energy_gradient() {
    let mut s = sim(PAIR);
    let rest = HeadState::rest();
    // The force of elasticity alone (charge 0), then with the charge.
    s.electrostatics_mut()
        .expect("charged")
        .set_charge_scale(0.0);
    s.update_electrostatics(&rest).expect("update");
    let elastic = s.static_force(0);
    s.electrostatics_mut()
        .expect("charged")
        .set_charge_scale(1.0);
    s.update_electrostatics(&rest).expect("update");
    let total = s.static_force(0);
    let coulomb: Vec<f64> = total.iter().zip(&elastic).map(|(a, b)| a - b).collect();
    let q0 = s.q(0).to_vec();
    let v0 = vec![0.0; q0.len()];
    let scale = coulomb.iter().fold(0.0, |m: f64, v| m.max(v.abs()));
    assert!(scale > 0.0);
    for j in 0..q0.len() {
        let h = 1e-5;
        let mut energy = [0.0; 2];
        for (k, sign) in [1.0, -1.0].into_iter().enumerate() {
            let mut q = q0.clone();
            q[j] += sign * h;
            s.set_state(0, &q, &v0);
            s.update_electrostatics(&rest).expect("update");
            energy[k] = s.electrostatics().expect("charged").energy();
        }
        let fd = -(energy[0] - energy[1]) / (2.0 * h);
        assert!(
            (fd - coulomb[j]).abs() <= 1e-6 * scale,
            "q[{j}]: J^T F = {:e}, -dU/dq = {fd:e}",
            coulomb[j]
        );
    }
}

/// Charged fibres hanging side by side push each other apart, and the outer iteration
/// ends below its tolerance, in one step and in logarithmic steps alike (both reach the
/// same equilibrium here: the fibres are far from any instability).
#[test]
fn charged_equilibrium_repels_and_converges() {
    let text = |charge: &str| {
        format!(
            "[simulation]\nmode = \"static\"\n{charge}\n[[strands]]\nroot = [0.0, 0.0, 0.0]\nlength = 0.2\nelements = 5\n\
             preset = \"smooth\"\n[[strands]]\nroot = [0.003, 0.0, 0.0]\nlength = 0.2\nelements = 5\npreset = \"smooth\"\n"
        )
    };
    let tips = |s: &mut Simulation| {
        let a = s.position_at(0, 0.2);
        let b = s.position_at(1, 0.2);
        (a - b).norm()
    };
    let mut plain = sim(&text(""));
    plain.solve_static().expect("static");
    let apart = tips(&mut plain);
    let mut equilibria: Vec<(f64, Vec<f64>)> = Vec::new();
    for steps in [1, 4] {
        let charged = format!("[electrostatics]\ncharge_per_length = -1e-9\ncharging_steps = {steps}\ntolerance = 1e-8");
        let mut s = sim(&text(&charged));
        let report = s.solve_charged_static().expect("charged static");
        assert_eq!(report.stages.len(), steps);
        let last = report.stages.last().expect("stage");
        assert!(last.converged && last.residual <= 1e-8, "{last:?}");
        // Without acceleration this took more than 30 outer iterations.
        assert!(last.iterations <= 12, "{last:?}");
        assert_eq!(last.charge_fraction, 1.0);
        let d = tips(&mut s);
        assert!(
            d > apart + 1e-3,
            "tips {d} m apart charged, {apart} m uncharged"
        );
        let q: Vec<f64> = (0..2).flat_map(|i| s.q(i).to_vec()).collect();
        equilibria.push((d, q));
    }
    // one step and four reach the same equilibrium: the same tips and coordinates to
    // what the tolerance 1e-8 on the force leaves (curvatures of order 1 rad/m; measured
    // 6.7e-11 m between the tips and 3.0e-9 rad/m on the coordinates)
    let ((d1, q1), (d4, q4)) = (&equilibria[0], &equilibria[1]);
    let dq = q1
        .iter()
        .zip(q4)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    println!("one step against four: tips {d1} and {d4} m apart, coordinates within {dq:.2e}");
    assert!((d1 - d4).abs() < 1e-9, "tips {d1} vs {d4}");
    assert!(dq < 1e-7, "coordinates differ by {dq}");
}

/// Two charged 20 cm strands run dynamically by the error-controlled step (`[simulation]
/// tolerance`, the Coulomb forces refreshed every 1/30 s and held within it) come to
/// rest on the charged static equilibrium of `solve_charged_static`.
#[test]
fn with_a_tolerance_charged_strands_settle_on_the_charged_equilibrium() {
    let text = |mode: &str| {
        format!(
            "[simulation]\nmode = \"{mode}\"\ndt = 0.03333333333333333\nduration = 12.0\ntolerance = 1e-3\n\
             [electrostatics]\ncharge_per_length = -1e-9\ntolerance = 1e-8\n\
             [[strands]]\nroot = [0.0, 0.0, 0.0]\nlength = 0.2\nelements = 5\npreset = \"smooth\"\nair_drag = 0.003\n\
             [[strands]]\nroot = [0.003, 0.0, 0.0]\nlength = 0.2\nelements = 5\npreset = \"smooth\"\nair_drag = 0.003\n"
        )
    };
    let tips = |s: &mut Simulation| (s.position_at(0, 0.2), s.position_at(1, 0.2));
    let mut statics = sim(&text("static").replace("tolerance = 1e-3\n", ""));
    let report = statics.solve_charged_static().expect("charged static");
    assert!(report.stages.last().is_some_and(|s| s.converged));
    let (a, b) = tips(&mut statics);
    let mut dynamics = sim(&text("dynamic"));
    for _ in 0..360 {
        dynamics.step().expect("step");
    }
    let (c, d) = tips(&mut dynamics);
    // the charge moves each tip by several millimetres; at rest the two runs agree to a
    // small fraction of that
    let moved = (a - b).norm() - 0.003;
    assert!(
        moved > 1e-3,
        "the charge moved the tips apart by {moved:.3e} m only"
    );
    let off = (a - c).norm().max((b - d).norm());
    assert!(
        off < 0.01 * moved,
        "tips {off:.3e} m from the charged equilibrium ({moved:.3e} m apart)"
    );
    assert!(dynamics
        .error_control()
        .is_some_and(|e| e.largest_error <= 1e-3));
}

/// A scene without [electrostatics] builds no particles and adds no loads; with it, the
/// strands carry one load per particle after their own.
#[test]
fn a_scene_without_charge_builds_nothing() {
    let base = "[[strands]]\nlength = 0.1\nelements = 2\n[[strands.point_loads]]\ns = 0.05\nforce = [0.0, 0.0, 1e-6]\n";
    let s = sim(base);
    assert!(s.electrostatics().is_none());
    assert_eq!(s.strand(0).point_loads.len(), 1);
    let s = sim(&format!("[electrostatics]\nparticle_density = 100\n{base}"));
    let e = s.electrostatics().expect("charged");
    assert_eq!(e.tracers().len(), 10);
    assert_eq!(s.strand(0).point_loads.len(), 11);
    assert_eq!(s.strand(0).point_loads[0].force.z, 1e-6);
}

/// Charged fibres in a dynamic run move apart over time (forces refreshed every step),
/// and nothing becomes non-finite.
#[test]
fn charged_dynamics_moves_fibres_apart() {
    let text = |charge: &str| {
        format!(
            "[simulation]\ndt = 0.01\nduration = 0.3\n[environment]\ngravity = \"none\"\n{charge}\n\
             [[strands]]\nroot = [0.0, 0.0, 0.0]\nlength = 0.1\nelements = 4\ninitial = \"straight\"\n\
             [[strands]]\nroot = [0.002, 0.0, 0.0]\nlength = 0.1\nelements = 4\ninitial = \"straight\"\n"
        )
    };
    let mut distances = Vec::new();
    for charge in [
        "",
        "[electrostatics]\ncharge_per_length = -1e-9\nmethod = \"fmm\"\naccuracy = 1e-8",
    ] {
        let mut s = sim(&text(charge));
        for _ in 0..30 {
            s.step().expect("step");
        }
        distances.push((s.position_at(0, 0.1) - s.position_at(1, 0.1)).norm());
    }
    assert!(
        (distances[0] - 0.002).abs() < 1e-9,
        "uncharged straight fibres stay put: {}",
        distances[0]
    );
    assert!(
        distances[1] > 0.004,
        "charged tips only {} m apart",
        distances[1]
    );
}

const HEAD: &str =
    "[[bodies]]\nname = \"head\"\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 0.1\n";

/// Scalp hair is rooted on the body's surface, leaves along the normal, within its cap.
#[test]
fn scalp_hair_grows_from_the_surface_along_the_normal() {
    let s = sim(&format!(
        "{HEAD}[[scalp_hair]]\nbody = \"head\"\ncount = 50\nmax_angle_deg = 60\nlength = 0.05\nelements = 2\n"
    ));
    assert_eq!(s.strand_count(), 50);
    for i in 0..50 {
        let g = &s.strand(i).geometry;
        let r = g.root_position;
        assert!((r.norm() - 0.1).abs() < 1e-12, "root {r:?} off the sphere");
        let n0 = g.root_frame.column(0).into_owned();
        assert!(
            (n0 - r / 0.1).norm() < 1e-12,
            "direction {n0:?} not the normal"
        );
        assert!(
            r.z / 0.1 >= 60f64.to_radians().cos() - 1e-12,
            "root {r:?} outside the cap"
        );
    }
}

/// The charged scalp's field (eq. 8) is k Q/d² along the normal outside, bounded by
/// k Q/a² at and inside the surface; charged fibres on a charged scalp stand off the head.
#[test]
fn charged_scalp_repels_and_stays_bounded() {
    use superhelix_runtime::forces::electrostatics::{scalp_field, COULOMB_CONSTANT};
    let s = sim(&format!(
        "{HEAD}[[strands]]\nroot = [0.0, 0.0, 0.1]\nlength = 0.05\n"
    ));
    let body = &s.bodies().bodies()[0];
    let head = HeadState::rest();
    let (q, a) = (1e-9, 0.003);
    let out = scalp_field(
        body,
        Some(&head),
        &nalgebra::Vector3::new(0.0, 0.0, 0.12),
        q,
        a,
    );
    assert!((out.z - COULOMB_CONSTANT * q / 0.02f64.powi(2)).abs() < 1e-9 * out.z && out.x == 0.0);
    let max = COULOMB_CONSTANT * q / (a * a);
    for x in [
        [0.0, 0.0, 0.1005],
        [0.0, 0.05, 0.05],
        [0.0, 0.0, 0.0],
        [0.01, 0.0, 0.0],
    ] {
        let f = scalp_field(body, Some(&head), &nalgebra::Vector3::from(x), q, a);
        assert!(
            f.norm() <= max * (1.0 + 1e-12) && f.norm().is_finite(),
            "{x:?}: {f:?}"
        );
    }
    let inside = scalp_field(
        body,
        Some(&head),
        &nalgebra::Vector3::new(0.0, 0.05, 0.0),
        q,
        a,
    );
    assert!(inside.y > 0.0, "inside: pushed outward, got {inside:?}");
    let tips = |charge: &str| {
        let mut s = sim(&format!(
            "[simulation]\nmode = \"static\"\n{charge}\n{HEAD}[[scalp_hair]]\nbody = \"head\"\ncount = 12\n\
             max_angle_deg = 80\nlength = 0.1\nelements = 4\npreset = \"smooth\"\n"
        ));
        s.solve_static().expect("static");
        (0..12).map(|i| s.position_at(i, 0.1).norm()).sum::<f64>() / 12.0
    };
    let plain = tips("");
    let charged = tips(
        "[electrostatics]\ncharge_per_length = -1e-9\nscalp_body = \"head\"\nscalp_charge = -1e-8",
    );
    assert!(
        charged > plain + 1e-3,
        "tips {charged} m from the centre charged, {plain} m uncharged"
    );
}

/// A tress of 30 fibres (radius 50 µm) at the largest charge `validate` allows (just
/// under air's breakdown at their surface, 2π r ε₀ E_b = 8.3e-9 C/m) has a charged static
/// equilibrium: what `validate` accepts, `run` solves.
#[test]
fn the_largest_allowed_charge_has_a_static_equilibrium() {
    let text = "[simulation]\nmode = \"static\"\n[electrostatics]\ncharge_per_length = 8.3e-9\nmax_iterations = 200\n\
                [[tresses]]\nname = \"t\"\ncount = 30\nsemi_axes = [0.005, 0.003]\nlength = 0.2\nelements = 5\n";
    let mut s = sim(text);
    let report = s.solve_charged_static().expect("charged static");
    let last = report.stages.last().expect("stage");
    assert!(last.converged, "{last:?}");
    // just beyond, refused before any solve
    let over = text.replace("8.3e-9", "8.4e-9");
    let errors = superhelix_runtime::validate_scene(&over);
    assert!(
        errors
            .iter()
            .any(|e| e.field == "electrostatics.charge_per_length"
                && e.message.contains("breakdown")),
        "{errors:?}"
    );
}
