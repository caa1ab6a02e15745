//! Internal loads and reactions (`Simulation::internal_loads`) against beam theory and
//! rigid-body dynamics, references nobody here wrote: Euler–Bernoulli statics of a
//! cantilever and of a beam clamped at both ends, a pinned pendulum hanging still, and the
//! pin's reaction on a rigid rod swinging down from the horizontal.

use superhelix_runtime::forces::internal_loads::Momenta;
use superhelix_runtime::{parse_scene, Simulation};

/// A steel rod (L = 0.2 m, r = 1 mm, E = 200 GPa, 7800 kg/m³) of `elements` elements
/// along +x from the origin, gravity −z, no drag, with `extra` appended to its table.
fn steel_rod(elements: usize, root: &str, extra: &str, simulation: &str) -> String {
    format!(
        "[simulation]\n{simulation}\n[environment]\ngravity = [0.0, 0.0, -9.81]\n\
         [[strands]]\nname = \"rod\"\nroot = [0.0, 0.0, 0.0]\nlength = 0.2\nelements = {elements}\n\
         radius = 1e-3\nyoungs_modulus = 2e11\npoisson = 0.3\ndensity = 7800.0\n\
         direction = [1.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nnatural = [0.0, 0.0, 0.0]\n\
         initial = \"straight\"\nair_drag = 0.0\n{extra}\n[strands.ends]\nroot = \"{root}\"\n"
    )
}

const L: f64 = 0.2;

fn weight_per_length(sim: &Simulation) -> f64 {
    sim.strand(0).geometry.mass_per_length * 9.81
}

#[test]
fn a_cantilever_carries_its_weight_as_beam_theory_says() {
    // clamped at x = 0, free at x = L, under its weight w per length: the root's reaction
    // is w L up and a moment w L²/2 holding it up (about −y); inside, n(s) = −w (L − s) ẑ
    // and m(s) = w (L − s)²/2 ŷ (the outer part hangs on the inner). Each element's
    // constitutive moment EI κ is the element's mean of w (L − s)²/2, as the Galerkin
    // equations of the piecewise-constant curvature make it. The sag is 0.15 % of L, so
    // the geometry changes these by ~(sag/L)² = 2e-6.
    let text = steel_rod(
        10,
        "clamped",
        "internal_friction = 0.0",
        "mode = \"static\"",
    );
    let mut sim = Simulation::new(parse_scene(&text).expect("scene"), None).expect("simulation");
    sim.solve_static().expect("static");
    let w = weight_per_length(&sim);
    let loads = sim.internal_loads(0, &[]).expect("loads");
    assert!(!loads.inertia);
    let r = loads.root_reaction.expect("a clamped root has a reaction");
    // the weight is summed exactly by the quadrature
    assert!((r[2] - w * L).abs() < 1e-12 * w * L, "{r:?}");
    assert!(
        r[0].abs() < 1e-5 * w * L && r[1].abs() < 1e-12 * w * L,
        "{r:?}"
    );
    let m0 = w * L * L / 2.0;
    assert!((r[4] + m0).abs() < 1e-5 * m0, "{} against {}", r[4], -m0);
    assert!(r[3].abs() < 1e-12 * m0 && r[5].abs() < 1e-12 * m0, "{r:?}");
    for (k, s) in loads.arcs.iter().enumerate() {
        let (n, m) = (loads.force[k], loads.moment[k]);
        let (n_exact, m_exact) = (-w * (L - s), w * (L - s).powi(2) / 2.0);
        assert!((n[2] - n_exact).abs() < 1e-5 * w * L, "s = {s}: {n:?}");
        assert!(
            (m[1] - m_exact).abs() < 1e-5 * m0,
            "s = {s}: {} against {m_exact}",
            m[1]
        );
    }
    let ei = sim.strand(0).material.stiffness[1];
    for (e, m) in loads.element_moment.iter().enumerate() {
        let (a, b) = (loads.arcs[e], loads.arcs[e + 1]);
        let mean = w * ((L - a).powi(3) - (L - b).powi(3)) / (6.0 * (b - a));
        // bending about n1 or n2 (which one is ŷ depends on the frame's turn): its size
        let bending = m[1].hypot(m[2]);
        assert!(
            (bending - mean).abs() < 1e-5 * m0,
            "element {e}: {bending} against the mean {mean} (EI = {ei})"
        );
        assert!(m[0].abs() < 1e-12 * m0, "no twist: {m:?}");
        // the world vector is about +ŷ
        let world = loads.element_moment_world[e];
        assert!((world[1] - mean).abs() < 1e-5 * m0, "{world:?}");
    }
}

#[test]
fn a_beam_clamped_at_both_ends_hangs_half_its_weight_on_each() {
    // clamped at both ends (fixed–fixed beam): each end carries w L/2 and a moment
    // w L²/12; the moment inside is w (L² − 6 L s + 6 s²)/12 about ŷ (hogging at the
    // ends as at a cantilever's root, sagging at mid-span), zero at s = L/2 ± L/√12.
    // The tip's clamp slides along the rod (an inextensible rod clamped at both ends
    // at its whole length is over-constrained), which changes none of this to first
    // order in the sag
    let tip = "[strands.ends.tip]\nkind = \"clamped-sliding\"\naxis = [1.0, 0.0, 0.0]\n";
    let text = steel_rod(
        20,
        "clamped",
        "internal_friction = 0.0",
        "mode = \"static\"",
    ) + tip;
    let mut sim = Simulation::new(parse_scene(&text).expect("scene"), None).expect("simulation");
    sim.solve_static().expect("static");
    let w = weight_per_length(&sim);
    let loads = sim.internal_loads(0, &[]).expect("loads");
    let (root, tip) = (
        loads.root_reaction.expect("root"),
        loads.tip_reaction.expect("held tip"),
    );
    let m_end = w * L * L / 12.0;
    for (name, r, sign) in [("root", root, -1.0), ("tip", tip, 1.0)] {
        // (measured: 4e-16 and 2.4e-9)
        assert!((r[2] - w * L / 2.0).abs() < 1e-12 * w * L, "{name}: {r:?}");
        assert!(
            (r[4] - sign * m_end).abs() < 1e-7 * m_end,
            "{name}: {} against {}",
            r[4],
            sign * m_end
        );
    }
    for (k, s) in loads.arcs.iter().enumerate() {
        let exact = w * (L * L - 6.0 * L * s + 6.0 * s * s) / 12.0;
        assert!(
            (loads.moment[k][1] - exact).abs() < 1e-7 * m_end,
            "s = {s}: {} against {exact}",
            loads.moment[k][1]
        );
    }
}

#[test]
fn a_pinned_rod_hanging_still_has_no_moment_at_its_pin() {
    let text = steel_rod(10, "pinned", "internal_friction = 0.0", "mode = \"static\"").replace(
        "direction = [1.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]",
        "direction = [0.0, 0.0, -1.0]\nnormal = [1.0, 0.0, 0.0]",
    );
    let mut sim = Simulation::new(parse_scene(&text).expect("scene"), None).expect("simulation");
    sim.solve_static().expect("static");
    let w = weight_per_length(&sim);
    let loads = sim.internal_loads(0, &[]).expect("loads");
    let r = loads.root_reaction.expect("a pinned root has a reaction");
    assert!((r[2] - w * L).abs() < 1e-12 * w * L, "{r:?}");
    let moment = (r[3].powi(2) + r[4].powi(2) + r[5].powi(2)).sqrt();
    assert!(moment < 1e-9 * w * L * L, "{r:?}");
    // the tension inside: w (L − s) along the strand, up
    for (k, s) in loads.arcs.iter().enumerate() {
        assert!((loads.force[k][2] + w * (L - s)).abs() < 1e-12 * w * L);
    }
}

#[test]
fn the_pin_of_a_rod_swinging_down_carries_what_rigid_body_dynamics_says() {
    // a steel rod pinned at one end, released from the horizontal: a rigid rod of mass m
    // at angle θ below the horizontal turns with ω² = 3 g sin θ / L (less what the
    // integrator takes) and α = 3 g cos θ / (2 L), and the pin holds its centre of mass on
    // the circle: R = m a_cm − m g with a_cm = ω² L/2 towards the pin plus α L/2 along the
    // motion (at release R = m g / 4). Internal friction damps the rod's own bending
    // (the joint has none), so the rod swings as a rigid body; ω is measured from the
    // tip's speed, θ from its position, so the test holds the inertia the momenta give.
    let text = steel_rod(
        10,
        "pinned",
        "internal_friction = 2e-3",
        "dt = 2e-4\nduration = 1.0\nintegrator = \"bdf2\"\nengine = \"runtime\"",
    );
    let mut sim = Simulation::new(parse_scene(&text).expect("scene"), None).expect("simulation");
    let m = sim.strand(0).geometry.mass_per_length * L;
    let g = 9.81;
    let mut earlier: Vec<Momenta> = Vec::new();
    let mut checked = 0;
    let mut largest: f64 = 0.0;
    let mut passed_vertical = false;
    while sim.time() < 0.3 {
        earlier.push(sim.momenta(0));
        if earlier.len() > 2 {
            earlier.remove(0);
        }
        sim.step().expect("step");
        let steps = sim.steps();
        if steps % 100 != 0 || steps < 200 {
            continue;
        }
        let loads = sim.internal_loads(0, &earlier).expect("loads");
        assert!(loads.inertia);
        let tip = loads.positions[loads.positions.len() - 1];
        let root = loads.positions[0];
        let u = (tip - root) / (tip - root).norm();
        // below the horizontal, 0 to π
        let theta = (-u[2]).atan2(u[0]);
        let arcs = [L];
        let speed = sim.velocities_world(0, &arcs)[0].norm();
        let omega = speed / L;
        let alpha = 3.0 * g * theta.cos() / (2.0 * L);
        // along the motion, du/dθ
        let along = nalgebra::Vector3::new(u[2], 0.0, -u[0]);
        let a_cm = -u * (omega * omega * L / 2.0) + along * (alpha * L / 2.0);
        let expected = a_cm * m - nalgebra::Vector3::new(0.0, 0.0, -g) * m;
        let r = loads.root_reaction.expect("pinned");
        let got = nalgebra::Vector3::new(r[0], r[1], r[2]);
        let error = (got - expected).norm() / (m * g);
        largest = largest.max(error);
        assert!(
            error < 5e-4,
            "t = {:.4} s, θ = {theta:.4}: pin force {got:?} against {expected:?} ({error:.2e} m g)",
            sim.time()
        );
        checked += 1;
        passed_vertical |= theta > 0.6 * std::f64::consts::PI;
    }
    assert!(checked >= 10, "{checked}");
    assert!(passed_vertical, "the rod swings past the vertical");
    eprintln!("largest error of the pin force: {largest:.2e} m g over {checked} checks");
}
