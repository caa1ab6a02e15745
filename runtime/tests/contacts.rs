//! Contacts against references nobody here wrote: a cantilever propped by a cylinder
//! (beam theory), the dynamic rest state against the static solve, static friction on a
//! slope below and above the friction angle, and two strands that must not pass through
//! each other.

use superhelix_runtime::{parse_scene, Simulation};

fn sim(text: &str) -> Simulation {
    let setup = parse_scene(text).unwrap_or_else(|e| panic!("{e}"));
    Simulation::new(setup, None).unwrap_or_else(|e| panic!("{e}"))
}

const L: f64 = 0.03;
const CONTACT_RADIUS: f64 = 1e-4;
const CYLINDER_RADIUS: f64 = 0.01;

/// A straight, round 3 cm strand of `elements` elements clamped horizontally at the
/// origin, its tip resting on a horizontal cylinder (a long capsule along y) whose top is
/// under the tip; 640 contact samples in all.
fn propped(mode: &str, elements: usize) -> String {
    let samples = 640 / elements;
    format!(
        r#"
[simulation]
mode = "{mode}"
dt = 0.005
duration = 3.0
[[bodies]]
name = "cylinder"
shape = "capsule"
attached = "world"
start = [{L}, -1.0, {z}]
end = [{L}, 1.0, {z}]
radius = {CYLINDER_RADIUS}
[contacts]
radius = {CONTACT_RADIUS}
stiffness = 1e6
friction = "none"
samples_per_element = {samples}
[[strands]]
root = [0.0, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
length = {L}
elements = {elements}
radius = 5e-5
ellipticity = 1.0
youngs_modulus = 3.9e9
natural = [0.0, 0.0, 0.0]
initial = "straight"
internal_friction = 5e-10
air_drag = 5e-4
"#,
        z = -CYLINDER_RADIUS - CONTACT_RADIUS
    )
}

/// Propped cantilever under its own weight w (fixed at x = 0, simply supported at x = L):
/// deflection `w x² (3L² − 5Lx + 2x²) / (48 EI)` and prop reaction `3wL/8`.
fn propped_deflection(w: f64, ei: f64, x: f64) -> f64 {
    w * x * x * (3.0 * L * L - 5.0 * L * x + 2.0 * x * x) / (48.0 * ei)
}

#[test]
fn a_cantilever_propped_by_a_cylinder_matches_beam_theory() {
    let mut s = sim(&propped("static", 40));
    s.solve_static().expect("static solve");
    let m = &s.strand(0).material;
    let (ei, w) = (m.stiffness[1], m.mass_per_length * 9.81);
    let reaction = s.contact_summary(0).expect("contacts").normal_force;
    let expected = 3.0 * w * L / 8.0;
    // the reaction of a prop at the tip; the contact sits within one sample spacing
    // (47 µm, 0.16 % of L) of the tip, which moves the reaction by about as much
    // (measured 1.2e-3)
    let rel = (reaction - expected).abs() / expected;
    assert!(
        rel < 5e-3,
        "reaction {reaction:.4e} N vs 3wL/8 = {expected:.4e} N ({rel:.2e})"
    );
    // the deflection where it is largest (x = 0.5785 L) and at a quarter and three
    // quarters; beam theory is linear: the strand deflects by ~1e-3 L here, its
    // nonlinear terms are O(1e-6) relative. What remains is the model's: elements of
    // constant curvature under a load that varies along them (2.4 % at N = 10, falling
    // as 1/N², 0.15 % at N = 40) and the prop's offset above (measured 3.6e-3 at most)
    let vmax = propped_deflection(w, ei, 0.5785 * L);
    for x in [0.25 * L, 0.5785 * L, 0.75 * L] {
        let z = s.position_at(0, x).z;
        let v = propped_deflection(w, ei, x);
        let err = (-z - v).abs() / vmax;
        assert!(
            err < 1e-2,
            "x = {x}: deflection {:.4e} m vs {v:.4e} m ({err:.2e} of the largest)",
            -z
        );
    }
    // the tip rests on the cylinder at the contact radius, sunk by the penalty's depth
    let tip = s.position_at(0, L);
    assert!(tip.z.abs() < 0.01 * vmax, "tip at z = {:.3e} m", tip.z);
}

/// Run the propped strand dynamically for 3 s (the scene's `[simulation]` plus `extra`)
/// and check its rest state against the static solution: within 1 % of the largest
/// deflection, at rest; returns the simulation.
fn settles_on_the_static_solution(extra: &str) -> Simulation {
    let mut statics = sim(&propped("static", 10));
    statics.solve_static().expect("static solve");
    let mut dynamics =
        sim(&propped("dynamic", 10).replace("dt = 0.005\n", &format!("dt = 0.005\n{extra}")));
    let mut deepest: f64 = 0.0;
    for _ in 0..600 {
        dynamics.step().expect("step");
        deepest = deepest.max(dynamics.max_penetration().unwrap_or(0.0));
    }
    // the strand rests on the cylinder: its centreline never went 1 mm inside
    assert!(deepest < 1e-3, "{deepest:.3e} m inside the cylinder");
    let vmax = 3e-5; // the largest deflection is ~1e-3 L
    let mut worst: f64 = 0.0;
    for k in 0..=30 {
        let x = L * k as f64 / 30.0;
        let d = (statics.position_at(0, x) - dynamics.position_at(0, x)).norm();
        worst = worst.max(d);
    }
    assert!(
        worst < 0.01 * vmax,
        "dynamic rest state {worst:.3e} m from the static solution"
    );
    assert!(
        dynamics.max_speed() < 1e-4,
        "still moving: {}",
        dynamics.max_speed()
    );
    dynamics
}

#[test]
fn the_dynamic_rest_state_on_the_cylinder_is_the_static_solution() {
    settles_on_the_static_solution("");
}

/// The error-controlled step (`[simulation] tolerance`) comes to the same rest on the
/// cylinder, its steps chosen by the tolerance.
#[test]
fn with_a_tolerance_the_rest_state_on_the_cylinder_is_the_static_solution() {
    let s = settles_on_the_static_solution("tolerance = 1e-4\n");
    let control = s.error_control().expect("a tolerance");
    assert!(control.steps >= 600 && control.largest_error <= 1e-4);
}

/// A straight 10 cm strand lying across a plane tilted by `slope_deg` about x (downhill
/// is +y), clamped at its root; Coulomb friction μ_s = μ_k = `mu`.
fn slope(slope_deg: f64, mu: f64, friction: &str) -> String {
    let b = slope_deg.to_radians();
    let (sn, cs) = (b.sin(), b.cos());
    let r = 1e-3;
    // the centreline starts just inside the contact radius, so that it touches at t = 0
    let h = r * (1.0 - 1e-3);
    format!(
        r#"
[simulation]
dt = 0.0333333333333333
duration = 1.0
[[bodies]]
name = "slope"
shape = "plane"
attached = "world"
point = [0.0, 0.0, 0.0]
normal = [0.0, {sn}, {cs}]
[contacts]
radius = {r}
friction = "{friction}"
friction_coefficient = {mu}
anisotropy = 0.0
[[strands]]
root = [0.0, {y}, {z}]
direction = [1.0, 0.0, 0.0]
normal = [0.0, {cs}, {ms}]
length = 0.1
elements = 5
preset = "smooth"
ellipticity = 1.0
natural = [0.0, 0.0, 0.0]
initial = "straight"
"#,
        y = h * sn,
        z = h * cs,
        ms = -sn
    )
}

/// Displacement of the tip downhill (along the plane, perpendicular to the strand) after
/// one second.
fn tip_slide(slope_deg: f64, mu: f64, friction: &str) -> f64 {
    let mut s = sim(&slope(slope_deg, mu, friction));
    let b = slope_deg.to_radians();
    let downhill = nalgebra::Vector3::new(0.0, b.cos(), -b.sin());
    let start = s.position_at(0, 0.1);
    for _ in 0..30 {
        s.step().expect("step");
    }
    (s.position_at(0, 0.1) - start).dot(&downhill)
}

#[test]
fn static_friction_holds_below_the_friction_angle_and_slides_above() {
    let mu: f64 = 0.4;
    let angle = mu.atan().to_degrees(); // 21.8°
    eprintln!(
        "frictionless {:e} viscous {:e}",
        tip_slide(0.8 * angle, mu, "none"),
        tip_slide(0.8 * angle, mu, "viscous")
    );
    let below = tip_slide(0.8 * angle, mu, "coulomb");
    let above = tip_slide(1.25 * angle, mu, "coulomb");
    let frictionless = tip_slide(0.8 * angle, mu, "none");
    // held: the tangential springs stretch by about the weight over their stiffness,
    // r / 1e4 = 0.1 µm; allow 10 µm
    assert!(
        below.abs() < 1e-5,
        "below the friction angle the tip slid {below:.3e} m"
    );
    // above: the strand slides and bends in the plane until its elasticity holds it
    assert!(
        above > 1e-3,
        "above the friction angle the tip slid only {above:.3e} m"
    );
    // and without friction it slides at the lower slope too
    assert!(
        frictionless > 1e-3,
        "frictionless tip slid only {frictionless:.3e} m"
    );
    eprintln!("slide after 1 s: below {below:.3e} m, above {above:.3e} m, frictionless {frictionless:.3e} m");
}

/// A stiff strand along +x and a soft one along +y crossing 5 mm above it, both clamped
/// horizontally; the soft one falls onto the stiff one.
fn crossing(hair_hair: bool) -> String {
    let table = if hair_hair {
        "[contacts]\nfriction = \"none\"\n[contacts.hair_hair]\nradius = 1e-3\n"
    } else {
        ""
    };
    format!(
        r#"
[simulation]
dt = 0.0333333333333333
duration = 1.0
{table}
[[strands]]
name = "stiff"
root = [-0.05, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
length = 0.1
elements = 5
radius = 4e-4
natural = [0.0, 0.0, 0.0]
initial = "straight"
[[strands]]
name = "soft"
root = [0.0, -0.05, 0.005]
direction = [0.0, 1.0, 0.0]
normal = [1.0, 0.0, 0.0]
length = 0.1
elements = 5
preset = "smooth"
natural = [0.0, 0.0, 0.0]
initial = "straight"
"#
    )
}

/// Height of the soft strand above the stiff one where they cross (the soft strand's
/// point at y ≈ 0 and the stiff one's at x ≈ 0), after each step.
fn crossing_gaps(hair_hair: bool) -> Vec<f64> {
    let mut s = sim(&crossing(hair_hair));
    (0..30)
        .map(|_| {
            s.step().expect("step");
            s.position_at(1, 0.05).z - s.position_at(0, 0.05).z
        })
        .collect()
}

#[test]
fn two_strands_pushed_together_do_not_pass_through_each_other() {
    let with = crossing_gaps(true);
    let without = crossing_gaps(false);
    // without hair–hair interaction the soft strand falls through the stiff one
    assert!(
        without.last().copied().unwrap_or(0.0) < -0.005,
        "control: the soft strand should fall through, gaps {without:?}"
    );
    // with it, it rests on top: the gap stays near the interaction distance 2 mm, never
    // below a quarter of it
    let least = with.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(
        least > 0.5e-3,
        "the strands came within {least:.3e} m: {with:?}"
    );
    eprintln!(
        "least gap {least:.3e} m, final {:.3e} m; control final {:.3e} m",
        with[29], without[29]
    );
}

/// A 10 cm strand hanging from the origin under gravity and a capsule along y (radius
/// 1 cm, axis at z = −5 cm) keyframed from x = −4 cm to x = +12 cm over 1 s (peak speed
/// 0.24 m/s): it sweeps through where the strand hangs. `with_contacts`: the strand
/// touches it (8 contact samples per element: the last 0.8 mm of the tip, beyond the last
/// sample, is not held out; with the default 4 it went 1.2 mm in); without, the capsule
/// passes through the strand (the control).
fn sweep(with_contacts: bool) -> String {
    let contacts = if with_contacts {
        "[contacts]\nradius = 1e-4\nfriction = \"none\"\nsamples_per_element = 8\n"
    } else {
        ""
    };
    format!(
        r#"
[simulation]
dt = 0.0166666666666667
duration = 2.0
[[bodies]]
name = "sweeper"
shape = "capsule"
start = [0.0, -0.05, -0.05]
end = [0.0, 0.05, -0.05]
radius = 0.01
[bodies.motion]
kind = "keyframes"
keys = [{{ t = 0.0, position = [-0.04, 0.0, 0.0] }}, {{ t = 1.0, position = [0.12, 0.0, 0.0] }}]
{contacts}
[[strands]]
root = [0.0, 0.0, 0.0]
direction = [0.0, 0.0, -1.0]
normal = [1.0, 0.0, 0.0]
length = 0.1
elements = 8
preset = "smooth"
natural = [0.0, 0.0, 0.0]
initial = "straight"
"#
    )
}

/// Over the sweep, at every step: the deepest centreline point (sampled 8 per element)
/// inside the capsule, m (≤ 0: outside), and the largest displacement of a centreline
/// point from where it started, m.
fn sweep_extremes(with_contacts: bool) -> (f64, f64) {
    let mut s = sim(&sweep(with_contacts));
    let start = s.centreline_world(0, 8);
    let (mut deepest, mut moved) = (f64::NEG_INFINITY, 0.0_f64);
    for _ in 0..120 {
        s.step().unwrap_or_else(|e| panic!("{e}"));
        let points = s.centreline_world(0, 8);
        let bodies = s.bodies();
        for (p, p0) in points.iter().zip(&start) {
            let x = nalgebra::Vector3::from(*p);
            deepest = deepest.max(-bodies.query(0, &x).distance);
            moved = moved.max((x - nalgebra::Vector3::from(*p0)).norm());
        }
    }
    (deepest, moved)
}

/// A keyframed capsule sweeps through a hanging strand: the strand is pushed aside and no
/// centreline point is ever more than the stress cases' 1 mm inside it (the contact
/// radius is 0.1 mm); without contacts the strand stays where it hangs and the capsule
/// passes right through it (its axis crosses the strand: a point up to 1 cm deep).
#[test]
fn a_keyframed_body_sweeping_through_a_strand_pushes_it_aside() {
    let (control_depth, control_moved) = sweep_extremes(false);
    let (depth, moved) = sweep_extremes(true);
    eprintln!(
        "control: deepest {control_depth:.3e} m, moved {control_moved:.3e} m; \
         contacts: deepest {depth:.3e} m, moved {moved:.3e} m"
    );
    // the control: the strand hangs still (a straight strand under gravity: only the
    // sag of the first steps), and the capsule's axis passes through it
    assert!(control_moved < 1e-3, "control moved {control_moved:.3e} m");
    // (sampled once a step: the capsule moves up to 4 mm a step)
    assert!(control_depth > 0.005, "control depth {control_depth:.3e} m");
    // with contacts: pushed well aside, never more than 1 mm inside
    assert!(moved > 0.02, "the strand moved only {moved:.3e} m");
    assert!(depth < 1e-3, "a centreline point went {depth:.3e} m inside");
}

/// A straight, round 5 cm strand (N = 10) clamped horizontally along x and lying on a
/// horizontal plane (gravity presses it on), the plane set moving along +y by a smooth
/// jolt of 0.2 s and then sliding at the constant `speed` m/s (`speed` = 0: fixed),
/// friction `friction` with coefficient μ = 0.3 (viscous: slip speed 1 cm/s).
fn conveyor(speed: f64, friction: &str) -> String {
    let r = 1e-3;
    let h = r * (1.0 - 1e-3);
    format!(
        r#"
[simulation]
dt = 0.005
duration = 3.0
[[bodies]]
name = "belt"
shape = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[bodies.motion]
kind = "jolt"
direction = [0.0, 1.0, 0.0]
acceleration = {a}
start = 0.0
duration = 0.2
[contacts]
radius = {r}
friction = "{friction}"
friction_coefficient = 0.3
anisotropy = 0.0
slip_speed = 0.01
[[strands]]
root = [0.0, 0.0, {h}]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
length = 0.05
elements = 10
radius = 5e-5
ellipticity = 1.0
youngs_modulus = 3.9e9
density = 1300.0
natural = [0.0, 0.0, 0.0]
initial = "straight"
internal_friction = 5e-10
air_drag = 5e-4
"#,
        a = 2.0 * speed / 0.2,
    )
}

/// The tip's displacement along y after 3 s on the conveyor.
fn conveyor_tip(speed: f64, friction: &str) -> f64 {
    let mut s = sim(&conveyor(speed, friction));
    let start = s.position_at(0, 0.05);
    for _ in 0..600 {
        s.step().unwrap_or_else(|e| panic!("{e}"));
    }
    let tip = s.position_at(0, 0.05) - start;
    assert!(tip.z.abs() < 1e-3, "the tip left the belt: {tip:?}");
    tip.y
}

/// Friction acts on the velocity relative to the body: a strand clamped over a belt that
/// slides under it at a constant 1 cm/s is dragged along until its elasticity holds the
/// sliding friction, a uniform load w = μ ρS g across it (Coulomb: μ_k |f_n| with |f_n|
/// the weight; viscous: μ |f_n| |v_rel| / v_s with |v_rel| = v_s). A cantilever under w
/// bends its tip by w L⁴ / (8 EI) (here 1.2 mm, 2.5 % of L: linear theory). On a belt at
/// rest the tip stays put (it would bend the same way if friction acted on the strand's
/// own velocity in the world: it does not move).
#[test]
fn a_strand_on_a_sliding_body_is_dragged_by_friction_on_the_relative_velocity() {
    let (r, e, rho, l, mu, g) = (5e-5_f64, 3.9e9, 1300.0, 0.05_f64, 0.3, 9.81);
    let pi = std::f64::consts::PI;
    let w = mu * rho * pi * r * r * g;
    let ei = e * pi * r.powi(4) / 4.0;
    // N = 10 elements of constant curvature, each the mean of the exact w (L − s)²/(2EI)
    // over the element, bend the tip 0.335 % less than the continuum (the quadrature of
    // ∫ κ (L − s) ds by element means); what remains (the clamp carrying the first
    // contact samples' weight, the penalty's depth of r / 10⁴, the geometric
    // nonlinearity (δ/L)² ≈ 6e-4) is well under the 0.5 % allowed
    let expected = w * l.powi(4) / (8.0 * ei) * (1.0 - 0.00335);
    let still = conveyor_tip(0.0, "coulomb");
    let coulomb = conveyor_tip(0.01, "coulomb");
    let viscous = conveyor_tip(0.01, "viscous");
    eprintln!(
        "tip along y: expected {expected:.4e} m, coulomb {coulomb:.4e} m ({:+.2} %), \
         viscous {viscous:.4e} m ({:+.2} %), belt at rest {still:.3e} m",
        100.0 * (coulomb / expected - 1.0),
        100.0 * (viscous / expected - 1.0)
    );
    assert!(still.abs() < 1e-3 * expected, "belt at rest: {still:.3e} m");
    for (name, got) in [("coulomb", coulomb), ("viscous", viscous)] {
        assert!(
            (got / expected - 1.0).abs() < 0.005,
            "{name}: tip {got:.4e} m, expected {expected:.4e} m"
        );
    }
}

/// The stiff and the soft strand of [`crossing`] without gravity, the soft one starting
/// 0.5 mm above the stiff one: 1.5 mm inside the 2 mm interaction distance, with a stiff
/// hair–hair penalty (500 N/m², a hundred times the default for these strands, where an
/// overlap is a kick). `depenetration_speed` (m/s) is the scene's.
fn overlapping(depenetration_speed: f64) -> String {
    crossing(true)
        .replace(
            "[contacts]\n",
            &format!(
                "[environment]\ngravity = [0.0, 0.0, 0.0]\n[contacts]\ndepenetration_speed = {depenetration_speed}\n"
            ),
        )
        .replace("root = [0.0, -0.05, 0.005]", "root = [0.0, -0.05, 0.0005]")
        .replace("radius = 1e-3\n", "radius = 1e-3\nstiffness = 500.0\n")
}

/// The largest speed of the soft strand's crossing point over 15 steps (0.5 s), and the
/// final gap between the two strands there.
fn let_apart(depenetration_speed: f64) -> (f64, f64) {
    let mut s = sim(&overlapping(depenetration_speed));
    let h = 1.0 / 30.0;
    let mut fastest: f64 = 0.0;
    let mut before = s.position_at(1, 0.05);
    for _ in 0..15 {
        s.step().expect("step");
        let now = s.position_at(1, 0.05);
        fastest = fastest.max((now - before).norm() / h);
        before = now;
    }
    (fastest, s.position_at(1, 0.05).z - s.position_at(0, 0.05).z)
}

#[test]
fn strands_that_start_overlapping_are_let_apart_without_a_kick() {
    // a depenetration speed of 1 cm/s: the overlap is allowed at the start and the
    // allowance shrinks at that speed, so the strands part at about that speed over
    // some 0.15 s
    let (fastest, gap) = let_apart(0.01);
    // the control: an allowance gone within the first step: the whole penalty pushes the
    // strands apart at once
    let (kicked, _) = let_apart(100.0);
    eprintln!(
        "let apart: fastest {fastest:.3e} m/s, final gap {gap:.3e} m; kicked: {kicked:.3e} m/s"
    );
    assert!(
        fastest <= 0.02,
        "the soft strand moved at {fastest:.3e} m/s (twice the depenetration speed is 0.02)"
    );
    assert!(
        gap >= 1.8e-3,
        "the strands are still {gap:.3e} m apart after 0.5 s (interaction distance 2 mm)"
    );
    assert!(
        kicked > 2.0 * fastest,
        "control: without the allowance the kick ({kicked:.3e} m/s) should be far faster"
    );
}

/// The work the energy balance counts for the hair–hair damping is the power of the force
/// the step applies: with partner points moving at v_p, `drag_power` must equal
/// q̇ · (F(v_p) − F(0)), the generalized force's change when the partners stop (at q̇ = 0
/// both forces hold the penalty and the damping's part c_h w v_p alone).
#[test]
fn the_balance_counts_the_power_of_the_partners_damping() {
    use nalgebra::Vector3;
    use std::sync::Arc;
    use superhelix_kernels::head::HeadState;
    use superhelix_runtime::bodies::{Body, Placement};
    use superhelix_runtime::forces::contacts::{
        ContactConfig, HairHairConfig, PartnerPoint, StrandContacts,
    };
    use superhelix_runtime::kernels::closed_form::ClosedForm;
    use superhelix_runtime::kernels::kernel::{StrandTerms, Terms};
    use superhelix_runtime::kernels::moments::kernel::MomentKernel;

    let n = 4;
    let (material, geom) = small_strand(n);
    let q: Vec<f64> = (0..3 * n).map(|i| 3.0 * ((i as f64) * 0.9).sin()).collect();
    let v: Vec<f64> = (0..3 * n).map(|i| 2.0 * ((i as f64) * 1.3).cos()).collect();
    let mut kernel = MomentKernel::new(geom.clone(), ClosedForm);
    let config = ContactConfig {
        radius: 1e-3,
        // the partners as balls: the terms of a strand's own step
        hair_hair: Some(HairHairConfig {
            coupling: superhelix_runtime::forces::contacts::Coupling::Ball,
            ..HairHairConfig::default()
        }),
        ..ContactConfig::default()
    };
    let rho_s = material.mass_per_length;
    let hair = config.hair_hair.as_ref().expect("set").params(rho_s);
    let mut contacts = StrandContacts::new(
        &geom,
        Arc::<[Body]>::from(Vec::new()),
        config.params(rho_s),
        Some(hair),
        4,
        [false, true],
    );
    // partner points 0.3 reach off the strand at three arc lengths, moving
    let at = Placement::new(HeadState::rest(), 0.0);
    let mut jac = vec![Vector3::zeros(); 3 * n];
    let partners = |moving: bool, kernel: &mut MomentKernel<ClosedForm>| -> Vec<PartnerPoint> {
        let velocity = |k: usize| {
            if moving {
                Vector3::new(0.4, -0.2 * k as f64, 0.3)
            } else {
                Vector3::zeros()
            }
        };
        three_partners(kernel, &q, 2.0 * hair.radius, velocity)
    };
    let zero = vec![0.0; 3 * n];
    let mut force =
        |moving: bool, contacts: &mut StrandContacts, kernel: &mut MomentKernel<ClosedForm>| {
            contacts.set_partners(partners(moving, kernel));
            let mut out = StrandTerms::new(3 * n);
            let terms = Terms {
                force: true,
                ..Default::default()
            };
            contacts.add_to_terms(
                &at, kernel, &geom, &q, &zero, terms, true, &mut jac, &mut out,
            );
            assert_eq!(
                contacts.summary().hair_contacts,
                3,
                "every partner within reach"
            );
            out.force.clone()
        };
    let still = force(false, &mut contacts, &mut kernel);
    let moving = force(true, &mut contacts, &mut kernel);
    let expected: f64 = (0..3 * n).map(|i| v[i] * (moving[i] - still[i])).sum();
    let mut jac = vec![Vector3::zeros(); 3 * n];
    let power = contacts.drag_power(&at, &mut kernel, &geom, &q, &v, &mut jac);
    assert!(
        expected.abs() > 1e-9,
        "the partners' damping does work: {expected:e}"
    );
    assert!(
        (power - expected).abs() <= 1e-12 * expected.abs(),
        "counted {power:e} W, the force's power is {expected:e} W"
    );
}

/// A straight 3 cm strand along x whose centreline passes 0.5 mm deep through a small
/// sphere (radius 2 mm, centred under x = 15.25 mm) between two contact samples (at 7.5
/// and 22.5 mm): the run's deepest point comes from a dense sweep of the centreline,
/// not from the samples. The depth along the line is `R − √((x − x_c)² + (R − δ)²)`; the
/// sweep's points are every 0.5 mm, the nearest 0.25 mm from the deepest, where the depth
/// is 0.4793 mm (second order in the spacing); the samples see nothing.
#[test]
fn the_deepest_point_is_found_between_contact_samples() {
    let (sphere, depth, x_c): (f64, f64, f64) = (2e-3, 5e-4, 15.25e-3);
    let text = format!(
        r#"
[simulation]
dt = 0.001
duration = 0.001
[environment]
gravity = [0.0, 0.0, 0.0]
[[bodies]]
name = "bead"
shape = "sphere"
attached = "world"
center = [{x_c}, 0.0, {z}]
radius = {sphere}
[contacts]
radius = 1e-4
samples_per_element = 2
[[strands]]
root = [0.0, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
length = 0.03
elements = 1
natural = [0.0, 0.0, 0.0]
initial = "straight"
"#,
        z = -(sphere - depth)
    );
    let mut s = sim(&text);
    // one step: the contact samples are evaluated (no force acts: the strand stays)
    s.step().expect("step");
    assert_eq!(
        s.contact_summary(0).map(|c| c.body_contacts),
        Some(0),
        "the samples are away from the bead"
    );
    let deepest = s.max_penetration().expect("contacts");
    let nearest = sphere - (0.25e-3f64.powi(2) + (sphere - depth).powi(2)).sqrt();
    assert!(
        (deepest - nearest).abs() < 1e-9 && deepest < depth,
        "deepest {deepest:.6e} m, expected {nearest:.6e} m"
    );
}

/// The contact forces a step applies are minus the gradient of the contact energy the
/// balance counts: the body's normal penalty and its sticking Coulomb springs (on a plane:
/// a constant normal), the hair–hair penalty of partner points of other strands, and a
/// pair of two parts of the strand itself (self-contact, stepped on both parts). Central
/// differences of `energy` along three directions against `Fᵀ d`.
#[test]
fn contact_forces_are_minus_the_gradient_of_the_contact_energy() {
    use nalgebra::Vector3;
    use std::sync::Arc;
    use superhelix_kernels::head::HeadState;
    use superhelix_runtime::bodies::shape_plane::Plane;
    use superhelix_runtime::bodies::{Attachment, Body, Placement, Shape};
    use superhelix_runtime::forces::contacts::{
        ContactConfig, Friction, HairHairConfig, PartnerPoint, StrandContacts,
    };
    use superhelix_runtime::kernels::closed_form::ClosedForm;
    use superhelix_runtime::kernels::kernel::{StrandKernel, StrandTerms, Terms};
    use superhelix_runtime::kernels::moments::kernel::MomentKernel;

    let n = 4;
    let (material, geom) = small_strand(n);
    let q: Vec<f64> = (0..3 * n).map(|i| 8.0 * ((i as f64) * 0.9).sin()).collect();
    let mut kernel = MomentKernel::new(geom.clone(), ClosedForm);
    let mut jac = vec![Vector3::zeros(); 3 * n];
    // a plane under the lowest contact sample, 0.4 mm into the contact radius of 1 mm
    let probe = |contacts: &mut StrandContacts| {
        contacts.sample_poses(&geom, &q);
        contacts
            .sample_positions()
            .map(|y| y.z)
            .fold(f64::INFINITY, f64::min)
    };
    let config = ContactConfig {
        radius: 1e-3,
        stiffness: Some(1e3),
        friction: Friction::Coulomb {
            static_coefficient: 10.0,
            kinetic_coefficient: 10.0,
            stiffness_ratio: 1.0,
        },
        // the partners as balls: the terms of a strand's own step
        hair_hair: Some(HairHairConfig {
            coupling: superhelix_runtime::forces::contacts::Coupling::Ball,
            ..HairHairConfig::default()
        }),
        ..ContactConfig::default()
    };
    let rho_s = material.mass_per_length;
    let hair = config.hair_hair.as_ref().expect("set").params(rho_s);
    let make = |bodies: Vec<Body>| {
        StrandContacts::new(
            &geom,
            Arc::<[Body]>::from(bodies),
            config.params(rho_s),
            Some(hair),
            8,
            [false, true],
        )
    };
    let lowest = probe(&mut make(Vec::new()));
    let plane = Body {
        name: "floor".into(),
        attached: Attachment::Head,
        shape: Shape::Plane(Plane {
            point: Vector3::new(0.0, 0.0, lowest + 6e-4),
            normal: Vector3::z(),
        }),
    };
    let at = Placement::new(HeadState::rest(), 0.0);
    // Coulomb anchors set where the samples were at a nearby state: the springs are
    // stretched (and stick: μ = 10) at q
    let q_anchor: Vec<f64> = q
        .iter()
        .enumerate()
        .map(|(i, x)| x + 2e-3 * ((i as f64) * 2.1).cos())
        .collect();
    // partner points: three of other strands 0.3 reach off the strand, and one pair of
    // two parts of the strand itself, 0.8 of its reach apart
    let reach = 2.0 * hair.radius;
    let mut partners = three_partners(&mut kernel, &q, reach, |_| Vector3::zeros());
    let (s_a, s_b) = (0.03, 0.075);
    let gap =
        (kernel.point(&q, s_a, &mut jac, None) - kernel.point(&q, s_b, &mut jac, None)).norm();
    partners.push(PartnerPoint {
        s: s_a,
        weight: 0.01,
        point: Vector3::zeros(),
        velocity: Vector3::zeros(),
        reach: gap / 0.8,
        anchor: None,
        partner_s: Some(s_b),
        pair: 0,
        normal: Vector3::zeros(),
    });
    let self_pair = partners.pop().expect("the self pair");
    // each kind alone, so that none hides behind another
    // (name, bodies, partners, (least body contacts, hair contacts))
    type Case = (&'static str, Vec<Body>, Vec<PartnerPoint>, (usize, usize));
    let cases: [Case; 3] = [
        ("plane", vec![plane], Vec::new(), (2, 0)),
        ("other strands", Vec::new(), partners, (0, 3)),
        ("self-contact", Vec::new(), vec![self_pair], (0, 1)),
    ];
    let zero = vec![0.0; 3 * n];
    for (name, bodies, partners, (least_bodies, hairs)) in cases {
        let mut contacts = make(bodies);
        contacts.start(&at, &geom, &q_anchor);
        contacts.set_partners(partners);
        let mut out = StrandTerms::new(3 * n);
        let terms = Terms {
            force: true,
            ..Default::default()
        };
        contacts.add_to_terms(
            &at,
            &mut kernel,
            &geom,
            &q,
            &zero,
            terms,
            false,
            &mut jac,
            &mut out,
        );
        let summary = contacts.summary();
        assert!(summary.body_contacts >= least_bodies, "{name}: {summary:?}");
        assert_eq!(summary.hair_contacts, hairs, "{name}: {summary:?}");
        let force = out.force.clone();
        // central differences: truncation ~eps² (1e-8 relative here), round-off ~1e-16 E /
        // eps; measured within 1e-8 of Fᵀd in every case
        let eps = 1e-4;
        for k in 0..3 {
            let d: Vec<f64> = (0..3 * n)
                .map(|i| ((i * 7 + k * 3) as f64 * 0.77).sin())
                .collect();
            let at_q = |t: f64| -> Vec<f64> { q.iter().zip(&d).map(|(x, y)| x + t * y).collect() };
            let e = |contacts: &mut StrandContacts, t: f64| contacts.energy(&at, &geom, &at_q(t)).0;
            let slope = (e(&mut contacts, eps) - e(&mut contacts, -eps)) / (2.0 * eps);
            let work: f64 = force.iter().zip(&d).map(|(f, x)| f * x).sum();
            let relative = (work + slope).abs() / work.abs();
            println!(
                "{name}, direction {k}: −dE/dt {:.10e}, Fᵀd {work:.10e}, {relative:.1e} apart",
                -slope
            );
            assert!(work.abs() > 1e-12, "{name}: the contacts do work along d");
            // (the truncation's 1e-8 scale, with a margin of 3: a force off the gradient
            // by more than a few parts in 1e8 fails)
            assert!(
                relative <= 3e-8,
                "{name}, direction {k}: Fᵀd {work:e} against −dE {:e}",
                -slope
            );
        }
    }
}

/// The strand of the contact-force tests: `n` elements of 2.5 cm along x from the origin,
/// a light hair-like material.
fn small_strand(
    n: usize,
) -> (
    superhelix_runtime::model::material::Material,
    superhelix_runtime::model::strand::StrandGeometry,
) {
    use nalgebra::{Matrix3, Vector3};
    let material = superhelix_runtime::model::material::Material {
        mass_per_length: 1e-5,
        stiffness: [1e-9, 1.3e-9, 1.3e-9],
        rotary_inertia: [1e-15, 5e-16, 5e-16],
    };
    let geom = superhelix_runtime::model::strand::StrandGeometry::new(
        Vector3::zeros(),
        Matrix3::identity(),
        vec![0.025; n],
        &material,
    );
    (material, geom)
}

/// Three partner points of other strands 0.3 `reach` off the strand at q (at arc lengths
/// 2, 5 and 9 cm, in three directions), the k-th moving at `velocity(k)`.
fn three_partners(
    kernel: &mut dyn superhelix_runtime::kernels::kernel::StrandKernel,
    q: &[f64],
    reach: f64,
    velocity: impl Fn(usize) -> nalgebra::Vector3<f64>,
) -> Vec<superhelix_runtime::forces::contacts::PartnerPoint> {
    use nalgebra::Vector3;
    let mut jac = vec![Vector3::zeros(); q.len()];
    [0.02, 0.05, 0.09]
        .iter()
        .enumerate()
        .map(|(k, &s)| {
            let y = kernel.point(q, s, &mut jac, None);
            let off = Vector3::new(0.3, -0.5 + 0.2 * k as f64, 0.8).normalize();
            superhelix_runtime::forces::contacts::PartnerPoint {
                s,
                weight: 0.01,
                point: y + off * (0.3 * reach),
                velocity: velocity(k),
                reach,
                anchor: None,
                partner_s: None,
                pair: k,
                normal: -off,
            }
        })
        .collect()
}
