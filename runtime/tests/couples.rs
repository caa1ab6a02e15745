//! Couples ([`PointLoad::torque`]) against beam theory: a cantilever under an end couple
//! bends into a circle of curvature M/EI, or twists by M/GJ, exactly (pure bending and
//! pure torsion: the internal moment is M everywhere), which the piecewise-constant
//! curvature holds exactly too; stepped with internal friction it comes to rest there.

use superhelix_runtime::{parse_scene, PointLoad, Simulation, Vector3};

const L: f64 = 0.2;
const N: usize = 10;

/// A steel rod along +x (n1 = +z, so n2 = x × z = −y), no gravity, heavy internal
/// friction, with `loads` appended (TOML) and `extra` in `[simulation]`.
fn rod(loads: &str, extra: &str) -> Simulation {
    let text = format!(
        "[simulation]\nengine = \"runtime\"\ndt = 0.002\n{extra}\n[environment]\ngravity = \"none\"\n\
         [[strands]]\nname = \"rod\"\nroot = [0.0, 0.0, 0.0]\nlength = {L}\nelements = {N}\n\
         radius = 1e-3\nyoungs_modulus = 2e11\npoisson = 0.3\ndensity = 7800.0\n\
         direction = [1.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nnatural = [0.0, 0.0, 0.0]\n\
         initial = \"straight\"\nair_drag = 0.0\ninternal_friction = 1e-3\n{loads}"
    );
    Simulation::new(parse_scene(&text).expect("scene"), None).expect("simulation")
}

#[test]
fn an_end_couple_balances_the_circle_of_curvature_m_over_ei_and_the_twist_m_over_gj() {
    let mut sim = rod("", "");
    let [gj, ei, _] = sim.strand(0).material.stiffness;
    let m = 0.05; // N·m: the circle turns by M L / EI = 0.064 rad
    for (torque, component, stiffness) in [
        (Vector3::new(0.0, -m, 0.0), 2, ei), // about n2 = −y: κ2
        (Vector3::new(0.0, 0.0, m), 1, ei),  // about n1 = +z: κ1
        (Vector3::new(m, 0.0, 0.0), 0, gj),  // about the tangent: twist
    ] {
        sim.set_point_loads(
            0,
            vec![PointLoad {
                s: L,
                force: Vector3::zeros(),
                follows: false,
                torque,
            }],
        )
        .expect("couple");
        // the exact shape: one coordinate M/stiffness in every element
        let mut q = vec![0.0; 3 * N];
        for e in 0..N {
            q[3 * e + component] = m / stiffness;
        }
        sim.set_state(0, &q, &vec![0.0; 3 * N]);
        let force = sim.static_force(0);
        let scale = m * L / N as f64;
        let worst = force.iter().fold(0.0f64, |w, f| w.max(f.abs()));
        assert!(worst < 1e-12 * scale, "{component}: {worst:e} of {scale:e}");
        // and the internal moment is the couple at every element end
        let loads = sim.internal_loads(0, &[]).expect("loads");
        for (k, moment) in loads.moment.iter().enumerate() {
            assert!(
                (moment - torque).norm() < 1e-9 * m,
                "{component}, end {k}: {moment}"
            );
        }
        let root = loads.root_reaction.expect("clamped");
        assert!((Vector3::new(root[3], root[4], root[5]) + torque).norm() < 1e-9 * m);
        // a shape off the circle is not balanced: the check can fail
        q[3 * (N / 2) + component] *= 1.01;
        sim.set_state(0, &q, &vec![0.0; 3 * N]);
        let off = sim
            .static_force(0)
            .iter()
            .fold(0.0f64, |w, f| w.max(f.abs()));
        assert!(off > 1e-3 * scale, "{component}: {off:e}");
    }
}

#[test]
fn a_cantilever_stepped_under_an_end_couple_comes_to_rest_on_its_circle() {
    // the couple given in the scene; the checked step counts its work as a power
    // (no potential in three dimensions): no step is limited by the energy balance
    let m = 0.05;
    for engine in ["runtime", "embedded"] {
        let mut sim = rod(
            &format!(
                "[[strands.point_loads]]\ns = {L}\ntorque = [0.0, {}, 0.0]\n",
                -m
            ),
            "",
        );
        if engine == "embedded" {
            let text = format!(
                "[simulation]\nengine = \"embedded\"\ndt = 0.002\n[environment]\ngravity = \"none\"\n\
                 [[strands]]\nname = \"rod\"\nroot = [0.0, 0.0, 0.0]\nlength = {L}\nelements = {N}\n\
                 radius = 1e-3\nyoungs_modulus = 2e11\npoisson = 0.3\ndensity = 7800.0\n\
                 direction = [1.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nnatural = [0.0, 0.0, 0.0]\n\
                 initial = \"straight\"\nair_drag = 0.0\ninternal_friction = 1e-3\n\
                 [[strands.point_loads]]\ns = {L}\ntorque = [0.0, {}, 0.0]\n",
                -m
            );
            sim = Simulation::new(parse_scene(&text).expect("scene"), None).expect("embedded");
        }
        let ei = sim.strand(0).material.stiffness[1];
        for _ in 0..1500 {
            sim.step().expect("step");
        }
        assert!(sim.max_speed() < 1e-7, "{engine}: {}", sim.max_speed());
        for e in 0..N {
            let k = sim.q(0)[3 * e + 2];
            assert!(
                (k * ei / m - 1.0).abs() < 1e-6,
                "{engine}, element {e}: {k} against {}",
                m / ei
            );
        }
        assert_eq!(sim.stats().energy_limited, 0, "{engine}: {:?}", sim.stats());
    }
}

#[test]
fn couples_are_refused_where_they_cannot_be_taken() {
    // the static solve minimises an energy a couple does not have
    let couple = format!("[[strands.point_loads]]\ns = {L}\ntorque = [0.0, -0.05, 0.0]\n");
    let text = |engine: &str, mode: &str| {
        format!(
            "[simulation]\nengine = \"{engine}\"\nmode = \"{mode}\"\n[environment]\ngravity = \"none\"\n\
             [[strands]]\nname = \"rod\"\nlength = {L}\nelements = {N}\nradius = 1e-3\n\
             youngs_modulus = 2e11\npoisson = 0.3\ndensity = 7800.0\n{couple}"
        )
    };
    let e = Simulation::new(
        parse_scene(&text("runtime", "static")).expect("scene"),
        None,
    )
    .err()
    .expect("static refused")
    .to_string();
    assert!(e.contains("point_loads[0].torque"), "{e}");
    let mut sim =
        Simulation::new(parse_scene(&text("auto", "dynamic")).expect("scene"), None).expect("auto");
    let e = sim.solve_static().expect_err("static solve").to_string();
    assert!(e.contains("torque"), "{e}");
}
