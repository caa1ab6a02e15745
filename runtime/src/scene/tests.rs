use super::*;
use crate::forces::head_motion::HeadMotion;
use crate::model::material::{helix_curvature, CrossSection, HelixForm, Preset};
use nalgebra::Vector3;
use proptest::prelude::*;

const FULL: &str = r#"
[simulation]
mode = "dynamic"
dt = 0.03333333
duration = 2.0
output_fps = 30
integrator = "rk4"
kernels = "generic"
quadrature = 6

[environment]
gravity = [0.0, 0.0, -9.81]
air_drag = 5e-6

[head]
motion = { kind = "oscillate", axis = [0.0, 0.0, 2.0], angle_deg = 30.0, frequency_hz = 2.0 }

[output]
samples_per_element = 3

[[strands]]
name = "s0"
root = [0.0, 0.01, 0.0]
direction = [1.0, 0.0, 0.0]
normal = [1.0, 1.0, 0.0]
length = 0.3
elements = 10
preset = "curly"
radius = 40e-6
helix_form = "paper"
internal_friction = 2e-10
air_drag = 2e-5
[[strands.point_loads]]
s = 0.3
force = [0.0, 0.0, -1e-6]

[[strands]]
name = "s1"
length = 0.2
element_lengths = [0.05, 0.15]
preset = "wavy"
initial = "straight"
"#;

fn setup(text: &str) -> SimulationSetup {
    match parse_scene(text) {
        Ok(s) => s,
        Err(e) => panic!("scene should be valid: {e}"),
    }
}

#[test]
fn the_full_example_becomes_the_expected_setup() {
    let s = setup(FULL);
    assert_eq!(s.config.integrator, IntegratorKind::Rk4);
    assert_eq!(s.config.kernels, KernelChoice::Generic);
    assert_eq!(s.config.quadrature, QuadratureRule::Fixed(6));
    assert_eq!(s.samples_per_element, 3);
    let HeadMotion::Oscillate {
        axis,
        amplitude,
        frequency_hz,
        center,
    } = &s.head
    else {
        panic!("{:?}", s.head)
    };
    assert_eq!(
        (*axis, *frequency_hz, *center),
        (Vector3::z(), 2.0, Vector3::zeros())
    );
    assert!((amplitude - 30f64.to_radians()).abs() < 1e-15);

    let s0 = &s.strands[0].strand;
    assert_eq!(s0.name, "s0");
    assert_eq!(s0.geometry.lengths, vec![0.03; 10]);
    assert_eq!(s0.geometry.root_position, Vector3::new(0.0, 0.01, 0.0));
    let frame = s0.geometry.root_frame;
    assert_eq!(frame.column(0).into_owned(), Vector3::x());
    assert!(
        (frame.column(1) - Vector3::y()).norm() < 1e-15,
        "normal orthonormalised"
    );
    assert!((frame.column(2) - Vector3::z()).norm() < 1e-15);
    let curly = Preset::Curly.params();
    let expected = helix_curvature(curly.helix_radius, curly.helix_step, HelixForm::Paper);
    assert_eq!(&s0.natural[27..30], &expected);
    assert_eq!(s.strands[0].q0, s0.natural, "initial = natural by default");
    assert_eq!((s0.internal_friction, s0.air_drag), (2e-10, 2e-5));
    let cs = CrossSection {
        radius: 40e-6,
        ..curly.cross_section
    };
    let (got, want) = (s0.material, cs.material());
    assert_eq!(got.mass_per_length, want.mass_per_length);
    for i in 0..3 {
        // powi may round differently when constant-folded: compare to 1e-15.
        assert!((got.stiffness[i] / want.stiffness[i] - 1.0).abs() < 1e-15);
    }
    assert_eq!(s0.point_loads.len(), 1);

    let s1 = &s.strands[1];
    assert_eq!(s1.strand.geometry.lengths, vec![0.05, 0.15]);
    assert_eq!(s1.q0, vec![0.0; 6]);
    assert_eq!(
        s1.strand.air_drag, 5e-6,
        "environment air_drag overrides the preset's"
    );
    assert_eq!(
        s1.strand.geometry.root_frame.column(0).into_owned(),
        -Vector3::z()
    );
}

#[test]
fn every_integrator_is_selectable_by_its_name() {
    for kind in IntegratorKind::ALL {
        let text = format!(
            "[simulation]\nintegrator = \"{}\"\n[[strands]]\nlength = 0.25\n",
            kind.name()
        );
        assert_eq!(setup(&text).config.integrator, kind);
    }
    assert_eq!(
        setup("[simulation]\nintegrator = \"bdf2\"\n[[strands]]\nlength = 0.25\n")
            .config
            .integrator,
        IntegratorKind::Bdf2
    );
}

#[test]
fn a_minimal_scene_uses_the_documented_defaults() {
    let s = setup("[[strands]]\nlength = 0.25\n");
    assert_eq!(s.config, SimulationConfig::default());
    assert_eq!(s.head, HeadMotion::Still);
    assert_eq!(s.samples_per_element, DEFAULT_SAMPLES_PER_ELEMENT);
    let strand = &s.strands[0].strand;
    assert_eq!(strand.name, "strand0");
    assert_eq!(strand.geometry.elements(), DEFAULT_ELEMENTS);
    let smooth = Preset::Smooth.params();
    assert_eq!(
        strand.material.mass_per_length,
        smooth.cross_section.material().mass_per_length
    );
    assert_eq!(
        (strand.internal_friction, strand.air_drag),
        (smooth.internal_friction, smooth.air_drag)
    );
    assert!(strand.natural.iter().all(|&x| x == 0.0));
    assert_eq!(s.environment.gravity, Some(Vector3::new(0.0, 0.0, -9.81)));
}

/// (scene text, field path that must be reported, fragment of its message).
const BROKEN: &[(&str, &str, &str)] = &[
    ("[simulation]\ndt = 0.0\n[[strands]]\nlength = 0.3", "simulation.dt", "must be in (0, 1], got 0"),
    ("[simulation]\ndt = 2.0\n[[strands]]\nlength = 0.3", "simulation.dt", "must be in (0, 1]"),
    ("[simulation]\ndt = nan\n[[strands]]\nlength = 0.3", "simulation.dt", "got NaN"),
    ("[simulation]\nduration = -1\n[[strands]]\nlength = 0.3", "simulation.duration", "must be >= 0"),
    ("[simulation]\nduration = inf\n[[strands]]\nlength = 0.3", "simulation.duration", "finite"),
    ("[simulation]\nduration = 1e9\ndt = 0.01\n[[strands]]\nlength = 0.3", "simulation.duration", "cap"),
    ("[simulation]\noutput_fps = 0\n[[strands]]\nlength = 0.3", "simulation.output_fps", "must be in (0, "),
    ("[simulation]\nmode = \"fast\"\n[[strands]]\nlength = 0.3", "simulation.mode", "allowed: dynamic, static"),
    ("[simulation]\nintegrator = \"euler\"\n[[strands]]\nlength = 0.3", "simulation.integrator", "newton-implicit-euler, bdf2, rk4"),
    ("[simulation]\nkernels = \"gpu\"\n[[strands]]\nlength = 0.3", "simulation.kernels", "generated"),
    ("[simulation]\nquadrature = 0\n[[strands]]\nlength = 0.3", "simulation.quadrature", ">= 1"),
    ("[simulation]\nquadrature = \"gauss\"\n[[strands]]\nlength = 0.3", "simulation.quadrature", "adaptive"),
    ("[simulation]\ndtt = 0.1\n[[strands]]\nlength = 0.3", "simulation.dtt", "unknown field"),
    ("[simulation]\nmax_split_depth = 9\n[[strands]]\nlength = 0.3", "simulation.max_split_depth", "deepest split"),
    ("[simulation]\nmax_split_depth = -1\n[[strands]]\nlength = 0.3", "simulation.max_split_depth", ">= 0"),
    ("[simulation]\nfield_stiffness = \"none\"\n[[strands]]\nlength = 0.3", "simulation.field_stiffness", "allowed: projected, split, explicit"),
    ("[simulation]\nenergy_balance = 1\n[[strands]]\nlength = 0.3", "simulation.energy_balance", "expected true or false"),
    ("[environment]\nair_drag = -1.0\n[[strands]]\nlength = 0.3", "environment.air_drag", "must be in [0, 100]"),
    ("[environment]\ngravity = \"down\"\n[[strands]]\nlength = 0.3", "environment.gravity", "none"),
    ("[environment]\ngravity = [0.0, 1.0]\n[[strands]]\nlength = 0.3", "environment.gravity", "exactly 3"),
    ("[environment]\nrelative_humidity = 120\n[[strands]]\nlength = 0.3", "environment.relative_humidity", "must be in [0, 100], got 120"),
    ("[environment]\nrelative_humidity = -0.5\n[[strands]]\nlength = 0.3", "environment.relative_humidity", "must be in [0, 100], got -0.5"),
    ("[environment]\nrelative_humidity = nan\n[[strands]]\nlength = 0.3", "environment.relative_humidity", "must be in [0, 100], got NaN"),
    ("[electrostatics]\nparticle_density = 0\n[[strands]]\nlength = 0.3", "electrostatics.particle_density", "must be in (0, 100000]"),
    ("[electrostatics]\ncharge_per_length = 1.0\n[[strands]]\nlength = 0.3", "electrostatics.charge_per_length", "must be in [-0.001, 0.001]"),
    ("[electrostatics]\ncharge_per_length = 1e-6\n[[strands]]\nlength = 0.3", "electrostatics.charge_per_length", "air's breakdown field"),
    ("[electrostatics]\n[[strands]]\nlength = 0.3\ncharge_per_length = -2e-8", "electrostatics.charge_per_length", "strand 'strand0''s own"),
    ("[electrostatics]\naccuracy = 0.5\n[[strands]]\nlength = 0.3", "electrostatics.accuracy", "must be in"),
    ("[electrostatics]\nmethod = \"tree\"\n[[strands]]\nlength = 0.3", "electrostatics.method", "auto, fmm, direct"),
    ("[electrostatics]\ncharging_steps = 0\n[[strands]]\nlength = 0.3", "electrostatics.charging_steps", ">= 1"),
    ("[electrostatics]\nsoftening = -1e-3\n[[strands]]\nlength = 0.3", "electrostatics.softening", "must be in [0, 1]"),
    ("[electrostatics]\nparticle_density = 1e5\n[[patches]]\nlength = 100\ncount = [100, 100]\nsize = [1.0, 1.0]", "electrostatics.particle_density", "cap of 50000000"),
    ("[electrostatics]\ncharges = 1\n[[strands]]\nlength = 0.3", "electrostatics.charges", "unknown field"),
    ("[[strands]]\nlength = 0.3\ncharge_per_length = -1e-11", "electrostatics", "add an [electrostatics] table"),
    ("[[tresses]]\nlength = 0.3\nsemi_axes = [0.01, 0.005]", "tresses[0].count", "required"),
    ("[[tresses]]\nlength = 0.3\ncount = 10", "tresses[0].semi_axes", "required"),
    ("[[tresses]]\nlength = 0.3\ncount = 10\nsemi_axes = [0.01]", "tresses[0].semi_axes", "exactly 2"),
    ("[[tresses]]\nlength = 0.3\ncount = 0\nsemi_axes = [0.01, 0.01]", "tresses[0].count", ">= 1"),
    ("[electrostatics]\nscalp_body = \"head\"\n[[strands]]\nlength = 0.3", "electrostatics.scalp_charge", "required with scalp_body"),
    ("[electrostatics]\nscalp_body = \"head\"\nscalp_charge = 1e-9\n[[strands]]\nlength = 0.3", "electrostatics.scalp_body", "no body named 'head'"),
    ("[[bodies]]\nname = \"b\"\nshape = \"plane\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n[[scalp_hair]]\nbody = \"b\"\ncount = 3\nlength = 0.1", "scalp_hair[0].body", "not a sphere or an ellipsoid"),
    ("[[scalp_hair]]\nbody = \"x\"\ncount = 3\nlength = 0.1", "scalp_hair[0].body", "no body named 'x'"),
    ("[[bodies]]\nname = \"h\"\nshape = \"sphere\"\nradius = 0.1\n[[scalp_hair]]\nbody = \"h\"\ncount = 3\nlength = 0.1\ndirection = [0.0, 0.0, 1.0]", "scalp_hair[0].direction", "surface normal"),
    ("[environment]\nrelative_humidity = \"wet\"\n[[strands]]\nlength = 0.3", "environment.relative_humidity", "expected a number"),
    ("[environment]\nhumidity = 50\n[[strands]]\nlength = 0.3", "environment.humidity", "unknown field"),
    ("[output]\nsamples_per_element = 0\n[[strands]]\nlength = 0.3", "output.samples_per_element", ">= 1"),
    ("[head]\nmotion = { kind = \"spin\" }\n[[strands]]\nlength = 0.3", "head.motion.kind", "oscillate"),
    ("[head]\nmotion = { kind = \"oscillate\", axis = [0.0, 0.0, 1.0], angle_deg = 30.0 }\n[[strands]]\nlength = 0.3", "head.motion.frequency_hz", "required"),
    ("[head]\nmotion = { kind = \"oscillate\", axis = [0.0, 0.0, 0.0], angle_deg = 30.0, frequency_hz = 1.0 }\n[[strands]]\nlength = 0.3", "head.motion.axis", "non-zero"),
    ("[head]\nmotion = { kind = \"keyframes\", keys = [{ t = 0.5 }, { t = 0.5 }] }\n[[strands]]\nlength = 0.3", "head.motion.keys[1].t", "strictly increasing"),
    ("[head]\nmotion = { kind = \"jolt\", direction = [1.0, 0.0, 0.0], acceleration = 5.0, start = 0.0, duration = 0.0 }\n[[strands]]\nlength = 0.3", "head.motion.duration", "must be in (0, 1000000]"),
    ("[head]\nmotion = { kind = \"still\", speed = 1.0 }\n[[strands]]\nlength = 0.3", "head.motion.speed", "unknown field"),
    ("[simulation]\ndt = 0.01", "strands", "no strands"),
    ("strands = 5", "strands", "array of tables"),
    ("[[strands]]\nlenght = 0.3", "strands[0].lenght", "unknown field (did you mean 'length'?)"),
    ("[[strands]]\nlenght = 0.3", "strands[0].length", "required"),
    ("[[strands]]\nlength = -0.3", "strands[0].length", "must be in (0, 100], got -0.3"),
    ("[[strands]]\nlength = 1e300", "strands[0].length", "must be in (0, 100], got 1e300"),
    ("[[strands]]\nlength = 0.3\nradius = 2.0", "strands[0].radius", "must be in (0, 1]"),
    ("[[strands]]\nlength = 0.3\nelements = 1\nq0 = [0.0, -2e6, 0.0]", "strands[0].q0[1]", "must be in [-1000000, 1000000]"),
    ("[[strands]]\nlength = 0.3\nelements = 1\nq0 = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]", "strands[0].q0", "the whole q of a pinned root; this strand's root is clamped: give 3N = 3"),
    ("[[strands]]\nlength = 0.3\nelements = 1\nq0 = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]\n[strands.ends]\nroot = \"pinned\"", "strands[0].q0", "the whole q of a free root; this strand's root is pinned: give 3N = 3 or its whole q, 6"),
    ("[[strands]]\nlength = 0.3\nelements = 1\nq0 = [1e20, 0.0, 0.0, 0.0, 0.0, 0.0]\n[strands.ends]\nroot = \"pinned\"", "strands[0].q0[0]", "got 1e20"),
    ("[[strands]]\nlength = 0.3\nelements = 1\nq0 = [0.0, 0.0, 0.0, 0.0, 3e6, 0.0]\n[strands.ends]\nroot = \"pinned\"", "strands[0].q0[4]", "must be in [-1000000, 1000000]"),
    ("[[patches]]\nname = \"p\"\nlength = 0.3\nelements = 1\nq0 = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]", "patches[0].q0", "must have 3N = 3 values (N = 1 elements); got 6"),
    ("[[strands]]\nlength = 0.3\nnatural = [0.0, 2e6, 0.0]", "strands[0].natural", "within [-1e6, 1e6] rad/m"),
    ("[[strands]]\nlength = 0.3\nelements = 0", "strands[0].elements", "must be an integer >= 1"),
    ("[[strands]]\nlength = 0.3\nelements = 500", "strands[0].elements", "<= 200"),
    ("[[strands]]\nlength = 0.3\nelements = 2.5", "strands[0].elements", "expected an integer"),
    ("[[strands]]\nlength = 0.3\npreset = \"frizzy\"", "strands[0].preset", "allowed: smooth, wavy, curly, fuzzy"),
    ("[[strands]]\nlength = 0.3\nradius = 0.0", "strands[0].radius", "must be in (0, 1]"),
    ("[[strands]]\nlength = 0.3\nyoungs_modulus = -1e9", "strands[0].youngs_modulus", "must be in (0, 10000000000000]"),
    ("[[strands]]\nlength = 0.3\ndensity = 0", "strands[0].density", "must be in (0, 100000]"),
    ("[[strands]]\nlength = 0.3\npoisson = 0.51", "strands[0].poisson", "must be in (-1, 0.5]"),
    ("[[strands]]\nlength = 0.3\npoisson = -1.0", "strands[0].poisson", "must be in (-1, 0.5]"),
    ("[[strands]]\nlength = 0.3\nellipticity = 0.9", "strands[0].ellipticity", ">= 1"),
    ("[[strands]]\nlength = 0.3\nhelix_radius = -0.01", "strands[0].helix_radius", ">= 0"),
    ("[[strands]]\nlength = 0.3\nhelix_step = -0.01", "strands[0].helix_step", ">= 0"),
    ("[[strands]]\nlength = 0.3\nradius = 1e-300", "strands[0].radius", "finite and > 0"),
    ("[[strands]]\nlength = 0.3\nhelix_radius = 1e-300", "strands[0].natural", "not finite"),
    ("[[strands]]\nlength = 0.3\nhelix_form = \"round\"", "strands[0].helix_form", "exact, paper"),
    ("[[strands]]\nlength = 0.3\nnatural = [1.0, 2.0, 3.0]\nhelix_radius = 0.01", "strands[0].helix_radius", "cannot be combined"),
    ("[[strands]]\nlength = 0.3\nnatural = [1.0, 2.0, 3.0]\nnatural_profile = [{ s = 0.0, value = [0.0, 0.0, 0.0] }]", "strands[0].natural_profile", "not both"),
    ("[[strands]]\nlength = 0.3\nnatural_profile = [{ s = 0.2, value = [0.0, 0.0, 0.0] }, { s = 0.1, value = [0.0, 0.0, 0.0] }]", "strands[0].natural_profile[1].s", "strictly increasing"),
    ("[[strands]]\nlength = 0.3\nnatural_profile = [{ s = 0.5, value = [0.0, 0.0, 0.0] }]", "strands[0].natural_profile[0].s", "must be in [0, 0.3]"),
    ("[[strands]]\nlength = 0.3\ncurvature_variation = 2.0", "strands[0].curvature_variation", "[0, 1]"),
    ("[[strands]]\nlength = 0.3\nseed = -1", "strands[0].seed", ">= 0"),
    ("[[strands]]\nlength = 0.3\nair_drag = -1e-5", "strands[0].air_drag", "must be in [0, 100]"),
    ("[[strands]]\nlength = 0.3\ninternal_friction = inf", "strands[0].internal_friction", "must be in [0, 100]"),
    ("[[strands]]\nlength = 0.3\ninitial = \"bent\"", "strands[0].initial", "natural, straight"),
    ("[[strands]]\nlength = 0.3\nelements = 2\nq0 = [0.0, 0.0]", "strands[0].q0", "must have 3N = 6 values"),
    ("[[strands]]\nlength = 0.3\nelements = 1\nq0 = [0.0, 0.0, 0.0]\ninitial = \"straight\"", "strands[0].q0", "not both"),
    ("[[strands]]\nlength = 0.3\ndirection = [0.0, 0.0, 0.0]", "strands[0].direction", "non-zero"),
    ("[[strands]]\nlength = 0.3\ndirection = [1.0, 0.0, 0.0]\nnormal = [-2.0, 0.0, 0.0]", "strands[0].normal", "parallel"),
    ("[[strands]]\nlength = 0.3\nelement_lengths = [0.1, 0.1]", "strands[0].element_lengths", "must sum to length = 0.3"),
    ("[[strands]]\nlength = 0.3\nelements = 2\nelement_lengths = [0.1, 0.2]", "strands[0].element_lengths", "not both"),
    ("[[strands]]\nelement_lengths = [0.1, -0.2]", "strands[0].element_lengths[1]", "must be in (0, 100]"),
    ("[[strands]]\nlength = 0.3\n[[strands.point_loads]]\ns = 0.5\nforce = [0.0, 0.0, 1.0]", "strands[0].point_loads[0].s", "must be in [0, 0.3]"),
    ("[[strands]]\nlength = 0.3\n[[strands.point_loads]]\ns = 0.1", "strands[0].point_loads[0].force", "required"),
    // a polyline: its fit stands for it or is refused; its length and loads are checked
    // against what it is, not a stand-in
    ("[[strands]]\nelements = 3\npolyline = [[0.0, 0.0, 0.0], [0.03, 0.0, -0.03], [0.0, 0.0, -0.06], [0.03, 0.0, -0.09], [0.0, 0.0, -0.12], [0.03, 0.0, -0.15], [0.0, 0.0, -0.18], [0.03, 0.0, -0.21], [0.0, 0.0, -0.24], [0.03, 0.0, -0.27], [0.0, 0.0, -0.3]]", "strands[0].polyline", "of its length from the curve at its point 9, more than 1e-2 (max_fit_error)"),
    ("[[strands]]\nelements = 4\npolyline = [[0.0, 0.0, 0.0], [0.0, 0.0, -0.1], [0.0, 0.0, -0.2], [0.001, 0.0, -0.1], [0.002, 0.0, 0.0]]", "strands[0].polyline", "zig-zags or doubles back"),
    ("[[strands]]\npolyline = [[0.0, 0.0, 0.0], [0.0, 0.0, -200.0]]", "strands[0].polyline", "more than a strand may be (100 m)"),
    ("[[strands]]\npolyline = [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]]\nnormal = [1.0, 0.0, 0.0]", "strands[0].normal", "along the polyline's first segment"),
    ("[[strands]]\npolyline = [[0.0, 0.0, 0.0], [0.0, 0.0, -2.0]]\n[[strands.point_loads]]\ns = 2.5\nforce = [0.0, 0.0, 1.0]", "strands[0].point_loads[0].s", "the length of the strand fitted to the polyline"),
    ("[[strands]]\nname = \"a\"\nlength = 0.3\n[[strands]]\nname = \"a\"\nlength = 0.3", "strands[1].name", "duplicate"),
    ("[[patches]]\nlength = 0.3\ncount = [0, 2]\nsize = [0.01, 0.01]", "patches[0].count[0]", ">= 1"),
    ("[[patches]]\nlength = 0.3\ncount = [2, 2]", "patches[0].size", "coincide"),
    ("[[patches]]\nlength = 0.3\ncount = [1000, 1000]\nsize = [0.01, 0.01]", "patches[0].count", "cap"),
    ("[[patches]]\nlength = 0.3\ncount = [2, 1]\nsize = [0.01, 0.0]\nspacing_u = [0.0, 0.01, 0.0]", "patches[0].size", "not both"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nradius = 0.1", "bodies[0].shape", "required: one of sphere, ellipsoid, capsule, plane, mesh"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"cube\"", "bodies[0].shape", "allowed: sphere, ellipsoid, capsule, plane, mesh"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"", "bodies[0].radius", "required: radius in m; must be in (0, 1000]"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.0", "bodies[0].radius", "must be in (0, 1000], got 0"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.1\ncenter = [0.0, 0.0]", "bodies[0].center", "exactly 3"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.1\nradii = [0.1, 0.1, 0.1]", "bodies[0].radii", "unknown field (did you mean 'radius'?)"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.1\nattached = \"hand\"", "bodies[0].attached", "allowed: head, world"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"ellipsoid\"\nradii = [0.1, 0.1]", "bodies[0].radii", "exactly 3"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"ellipsoid\"\nradii = [0.1, -0.1, 0.1]", "bodies[0].radii[1]", "must be in (0, 1000]"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"ellipsoid\"\nradii = [0.1, 0.1, 0.1]\nrotation_axis_angle_deg = [0.0, nan, 0.0]", "bodies[0].rotation_axis_angle_deg[1]", "finite"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"capsule\"\nstart = [0.0, 0.0, 0.0]\nradius = 0.02", "bodies[0].end", "required"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"capsule\"\nstart = [0.0, 0.0, 0.0]\nend = [0.0, 0.0, 0.1]\nradius = 2000.0", "bodies[0].radius", "must be in (0, 1000]"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"plane\"\nnormal = [0.0, 0.0, 0.0]", "bodies[0].normal", "non-zero"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"plane\"", "bodies[0].normal", "required"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"mesh\"", "bodies[0].path", "required: the OBJ file"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"mesh\"\npath = \"\"", "bodies[0].path", "must name an OBJ file"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"mesh\"\npath = \"no-such-head.obj\"", "bodies[0].path", "cannot read 'no-such-head.obj'"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"mesh\"\npath = \"head.obj\"\ncell = 0.0", "bodies[0].cell", "must be in (0, 1000]"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"mesh\"\npath = \"head.obj\"\nscale = -1.0", "bodies[0].scale", "must be in (0, 1000000]"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.1\n[[bodies]]\nshape = \"plane\"\nnormal = [0.0, 0.0, 1.0]\nname = \"body0\"", "bodies[1].name", "duplicate body name 'body0'"),
    ("bodies = 5\n[[strands]]\nlength = 0.3", "bodies", "array of tables"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.02\nattached = \"motion\"", "bodies[0].motion", "required: a [bodies.motion] table"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.02\nattached = \"world\"\nmotion = { kind = \"still\" }", "bodies[0].motion", "only for a body with attached = \"motion\" (this one has attached = \"world\")"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.02\nattached = \"head\"\n[bodies.motion]\nkind = \"still\"", "bodies[0].motion", "only for a body with attached = \"motion\""),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.02\nmotion = 3", "bodies[0].motion", "expected a table"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.02\n[bodies.motion]\nkind = \"spin\"", "bodies[0].motion.kind", "allowed: still, oscillate, translate-oscillate, keyframes, sudden-stop, jolt"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.02\n[bodies.motion]\nkind = \"keyframes\"", "bodies[0].motion.keys", "required: a list of { t, position, rotation_axis_angle_deg }"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.02\n[bodies.motion]\nkind = \"keyframes\"\nkeys = [{ t = 1.0 }, { t = 0.5 }]", "bodies[0].motion.keys[1].t", "strictly increasing, got 0.5 after 1"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.02\n[bodies.motion]\nkind = \"keyframes\"\nkeys = [{ t = 0.0, position = [0.0, 0.1] }]", "bodies[0].motion.keys[0].position", "exactly 3"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.02\n[bodies.motion]\nkind = \"keyframes\"\nkeys = [{ t = 0.0, speed = 1.0 }]", "bodies[0].motion.keys[0].speed", "unknown field"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.02\n[bodies.motion]\nkind = \"oscillate\"\naxis = [0.0, 0.0, 1.0]\nangle_deg = 30.0\nfrequency_hz = 80.0", "bodies[0].motion.frequency_hz", "must be in [0, 50], got 80"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.02\n[bodies.motion]\nkind = \"oscillate\"\naxis = [0.0, 0.0, 1.0]\nangle_deg = 200.0\nfrequency_hz = 1.0", "bodies[0].motion.angle_deg", "must be in [0, 180]"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.02\n[bodies.motion]\nkind = \"translate-oscillate\"\ndirection = [0.0, 0.0, 0.0]\namplitude = 0.1\nfrequency_hz = 1.0", "bodies[0].motion.direction", "non-zero"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nshape = \"sphere\"\nradius = 0.02\n[bodies.motion]\nkind = \"translate-oscillate\"\ndirection = [1.0, 0.0, 0.0]\namplitude = -0.1\nfrequency_hz = 1.0", "bodies[0].motion.amplitude", "must be in [0, 10000]"),
    ("[[strands]]\nlength = 0.3\n[render]\nclumping = 0.5", "render.strands", "required: the number of render strands, an integer in [1, 10000000]"),
    ("[[strands]]\nlength = 0.3\n[render]\nstrands = 0", "render.strands", "must be an integer >= 1"),
    ("[[strands]]\nlength = 0.3\n[render]\nstrands = 20000000", "render.strands", "<= 10000000"),
    ("[[strands]]\nlength = 0.3\n[render]\nstrands = 10.5", "render.strands", "expected an integer"),
    ("[[strands]]\nlength = 0.3\n[render]\nstrands = 10\nclumping = 1.5", "render.clumping", "must be in [0, 1], got 1.5"),
    ("[[strands]]\nlength = 0.3\n[render]\nstrands = 10\ntip_distance = 0.0", "render.tip_distance", "must be in (0, 100], got 0"),
    ("[[strands]]\nlength = 0.3\n[render]\nstrands = 10\nmax_spacing = -1.0", "render.max_spacing", "must be in (0, 100]"),
    ("[[strands]]\nlength = 0.3\n[render]\nstrands = 10\nseed = -3", "render.seed", ">= 0"),
    ("[[strands]]\nlength = 0.3\n[render]\nstrands = 10\nclearance = 0.5", "render.clearance", "must be in [0, 0.1], got 0.5"),
    ("[[strands]]\nlength = 0.3\n[render]\nstrands = 10\nclearance = -1e-3", "render.clearance", "must be in [0, 0.1]"),
    ("[[strands]]\nlength = 0.3\n[render]\nstrands = 10\nscalp_body = \"head\"", "render.scalp_body", "no body named 'head'"),
    ("[[strands]]\nlength = 0.3\n[[bodies]]\nname = \"floor\"\nshape = \"plane\"\nnormal = [0.0, 0.0, 1.0]\nattached = \"world\"\n[render]\nstrands = 10\nscalp_body = \"floor\"", "render.scalp_body", "attached to the world"),
    ("[[strands]]\nlength = 0.3\n[render]\nstrands = 10\nclumpiness = 0.5", "render.clumpiness", "unknown field; allowed fields here: clearance, clumping, max_spacing"),
    ("render = 5\n[[strands]]\nlength = 0.3", "render", "table"),
];

#[test]
fn the_render_table_is_read_with_its_defaults() {
    let plain = setup("[[strands]]\nlength = 0.3");
    assert_eq!(plain.output.render, None);
    let s = setup(
        "[[strands]]\nlength = 0.3\n[[bodies]]\nname = \"head\"\nshape = \"sphere\"\nradius = 0.09\n[render]\nstrands = 1000",
    );
    assert_eq!(
        s.output.render,
        Some(crate::render::RenderSettings::new(1000))
    );
    let s = setup(
        "[[strands]]\nlength = 0.3\n[[bodies]]\nname = \"head\"\nshape = \"sphere\"\nradius = 0.09\n[render]\nstrands = 20\nclumping = 0.8\ntip_distance = 0.05\nseed = 3\nmax_spacing = 0.02\nscalp_body = \"head\"\nclearance = 0.001",
    );
    assert_eq!(
        s.output.render,
        Some(crate::render::RenderSettings {
            strands: 20,
            clumping: 0.8,
            tip_distance: Some(0.05),
            seed: 3,
            max_spacing: Some(0.02),
            scalp_body: Some(0),
            clearance: Some(0.001),
        })
    );
}

#[test]
fn every_broken_scene_reports_its_field_and_range() {
    for (text, field, fragment) in BROKEN {
        let errors = validate_scene(text);
        let hit = errors.iter().find(|e| e.field == *field);
        let Some(hit) = hit else {
            panic!("{field} not reported for\n{text}\ngot {errors:?}")
        };
        assert!(
            hit.message.contains(fragment),
            "{field}: message '{}' lacks '{fragment}'",
            hit.message
        );
    }
}

/// A polyline's `normal` along z (the default direction of other strands, which a
/// polyline has not) and a load beyond 1 m on a 2 m polyline: accepted, as the
/// polyline's own frame and length allow.
#[test]
fn a_polyline_takes_a_normal_across_it_and_loads_along_its_length() {
    let s = setup(
        "[[strands]]\npolyline = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]\nnormal = [0.0, 0.0, 1.0]\n[[strands.point_loads]]\ns = 1.5\nforce = [0.0, 0.0, 1.0]",
    );
    let strand = &s.strands[0].strand;
    let n1 = strand.geometry.root_frame.column(1);
    assert!((n1 - Vector3::z()).norm() < 1e-12, "{n1}");
    assert!((strand.geometry.length() - 2.0).abs() < 1e-9);
    assert_eq!(strand.point_loads[0].s, 1.5);
}

#[test]
fn all_problems_are_reported_at_once() {
    let text = "[simulation]\ndt = -1\nduration = -2\n[[strands]]\nlength = -0.3\nelements = 0\npreset = \"x\"\nfoo = 1\n";
    let fields: Vec<String> = validate_scene(text).into_iter().map(|e| e.field).collect();
    for f in [
        "simulation.dt",
        "simulation.duration",
        "strands[0].length",
        "strands[0].elements",
        "strands[0].preset",
        "strands[0].foo",
    ] {
        assert!(fields.iter().any(|g| g == f), "{f} missing from {fields:?}");
    }
    match parse_scene(text) {
        Err(Error::Invalid(errors)) => assert_eq!(errors.len(), fields.len()),
        other => panic!("expected Invalid, got {other:?}"),
    }
}

#[test]
fn syntax_errors_give_line_and_column() {
    match parse_scene("[simulation]\ndt = 0.1\nduration = = 2\n") {
        Err(Error::Parse(msg)) => assert!(msg.starts_with("line 3, column "), "{msg}"),
        other => panic!("expected Parse, got {other:?}"),
    }
    let errors = validate_scene("[[strands]\n");
    assert_eq!(errors.len(), 1);
    assert_eq!(errors[0].field, "<toml>");
}

#[test]
fn patches_make_named_grids_with_reproducible_variation() {
    let text = r#"
[[patches]]
name = "p"
center = [0.0, 0.0, 0.1]
direction = [0.0, 0.0, -1.0]
normal = [1.0, 0.0, 0.0]
count = [3, 2]
size = [0.02, 0.01]
length = 0.2
elements = 4
preset = "curly"
curvature_variation = 0.2
seed = 7
"#;
    let s = setup(text);
    let names: Vec<&str> = s.strands.iter().map(|x| x.strand.name.as_str()).collect();
    assert_eq!(
        names,
        ["p_0_0", "p_0_1", "p_1_0", "p_1_1", "p_2_0", "p_2_1"]
    );
    let root = |k: usize| s.strands[k].strand.geometry.root_position;
    assert!(
        (root(0) - Vector3::new(-0.01, 0.005, 0.1)).norm() < 1e-15,
        "{}",
        root(0)
    );
    assert!(
        (root(5) - Vector3::new(0.01, -0.005, 0.1)).norm() < 1e-15,
        "{}",
        root(5)
    );
    let base = helix_curvature(0.006, 0.005, HelixForm::Exact);
    for x in &s.strands {
        for (q, chunk) in x.strand.natural.chunks(3).enumerate() {
            let factor = chunk[1] / base[1];
            assert!((0.8..=1.2).contains(&factor), "factor {factor}");
            assert!(
                (chunk[0] / base[0] - factor).abs() < 1e-12,
                "element {q} scaled as a whole"
            );
        }
    }
    assert_ne!(s.strands[0].strand.natural, s.strands[1].strand.natural);
    assert_eq!(setup(text), s, "same seed, same scene");
}

#[test]
fn patch_spacing_vectors_place_the_roots() {
    let text =
        "[[patches]]\ncount = [2, 1]\nspacing_u = [0.0, 0.02, 0.0]\nlength = 0.1\nelements = 2\n";
    let s = setup(text);
    assert_eq!(
        s.strands[0].strand.geometry.root_position,
        Vector3::new(0.0, -0.01, 0.0)
    );
    assert_eq!(
        s.strands[1].strand.geometry.root_position,
        Vector3::new(0.0, 0.01, 0.0)
    );
}

#[test]
fn natural_profile_takes_exact_element_means() {
    // tau = 0, kappa1 rises linearly from 0 at s = 0.1 to 10 at s = 0.3, constant outside.
    let text = r#"
[[strands]]
length = 0.4
elements = 4
natural_profile = [{ s = 0.1, value = [0.0, 0.0, 1.0] }, { s = 0.3, value = [0.0, 10.0, 1.0] }]
"#;
    let s = setup(text);
    let k1: Vec<f64> = s.strands[0]
        .strand
        .natural
        .chunks(3)
        .map(|d| d[1])
        .collect();
    let expected = [0.0, 2.5, 7.5, 10.0];
    for (got, want) in k1.iter().zip(expected) {
        assert!((got - want).abs() < 1e-12, "{k1:?}");
    }
    assert!(s.strands[0].strand.natural.chunks(3).all(|d| d[2] == 1.0));
    // An element straddling a knot: mean over [0.05, 0.15] of max(0, 50 (s - 0.1)).
    let text = text.replace("elements = 4", "element_lengths = [0.05, 0.1, 0.25]");
    let s = setup(&text);
    assert!((s.strands[0].strand.natural[4] - 0.625).abs() < 1e-12);
}

#[test]
fn q0_natural_and_keyframes_and_gravity_none() {
    let text = r#"
[environment]
gravity = "none"
[head]
motion = { kind = "keyframes", keys = [{ t = 0.0 }, { t = 1.0, position = [0.0, 0.0, 0.1], rotation_axis_angle_deg = [0.0, 0.0, 90.0] }] }
[[strands]]
length = 0.3
elements = 1
q0 = [1.0, 2.0, 3.0]
"#;
    let s = setup(text);
    assert_eq!(s.environment.gravity, None);
    assert_eq!(s.strands[0].q0, vec![1.0, 2.0, 3.0]);
    let end = s.head.state(2.0);
    assert!((end.rotation * Vector3::x() - Vector3::y()).norm() < 1e-12);
}

#[test]
fn deep_nesting_and_odd_input_do_not_panic() {
    let deep = format!("x = {}{}", "[".repeat(100_000), "]".repeat(100_000));
    assert!(parse_scene(&deep).is_err());
    for text in [
        "",
        "\u{0}",
        "[[strands]]\nlength = 1e308\nelements = 200",
        "a.b.c.d = 1",
        "[[strands]]\nroot = [1e308, -1e308, 1e308]\nlength = 0.1",
    ] {
        let _ = parse_scene(text);
    }
}

/// Valid lines to splice into random scenes.
const LINES: &[&str] = &[
    "[simulation]", "dt = 0.01", "duration = 0.5", "output_fps = 30", "mode = \"static\"", "quadrature = 3",
    "[environment]", "gravity = [0.0, 0.0, -9.81]", "air_drag = 1e-5", "[head]",
    "motion = { kind = \"oscillate\", axis = [0.0, 0.0, 1.0], angle_deg = 30.0, frequency_hz = 2.0 }",
    "motion = { kind = \"keyframes\", keys = [{ t = 0.0 }, { t = 1.0 }] }",
    "[[strands]]", "length = 0.3", "elements = 3", "element_lengths = [0.1, 0.2]", "preset = \"fuzzy\"",
    "natural_profile = [{ s = 0.0, value = [1.0, 2.0, 3.0] }]", "q0 = [0.0, 0.0, 0.0]", "direction = [0.0, 0.0, 0.0]",
    "normal = [1.0, 0.0, 0.0]", "curvature_variation = 0.5", "[[strands.point_loads]]", "s = 0.1", "force = [0.0, 0.0, 1.0]",
    "[[patches]]", "count = [2, 3]", "size = [0.01, 0.02]", "spacing_u = [0.0, 0.0, 0.0]", "length = -1", "elements = 0",
    "[[bodies]]", "shape = \"sphere\"", "shape = \"mesh\"", "radius = 0.1", "radii = [0.1, 0.2, 0.3]", "path = \"head.obj\"",
    "attached = \"world\"", "normal = [0.0, 0.0, 1.0]", "cell = -1",
];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn random_text_never_panics(text in "\\PC{0,200}") {
        let _ = parse_scene(&text);
    }

    #[test]
    fn spliced_scenes_never_panic(picks in proptest::collection::vec(0..LINES.len(), 0..25)) {
        let text: Vec<&str> = picks.iter().map(|&i| LINES[i]).collect();
        let _ = parse_scene(&text.join("\n"));
    }

    #[test]
    fn mutated_full_scene_never_panics(pos in 0..FULL.len(), cut in 0..20usize, insert in "[\\[\\]=\"{},.0-9a-z \\n-]{0,8}") {
        let mut text = FULL.as_bytes().to_vec();
        let end = (pos + cut).min(text.len());
        text.splice(pos..end, insert.bytes());
        let _ = parse_scene(&String::from_utf8_lossy(&text));
    }
}

#[test]
fn strands_get_their_group_and_output_reads_formats_and_max_bytes() {
    let s = setup(
        "[output]\nformats = [\"npy\", \"preview\"]\nmax_bytes = 5e9\n\
         [[strands]]\nname = \"a\"\nlength = 0.1\ngroup = \"fringe\"\n\
         [[strands]]\nname = \"b\"\nlength = 0.1\n\
         [[patches]]\nname = \"crown\"\ncount = [1, 2]\nsize = [0.0, 0.01]\nlength = 0.1\n",
    );
    let groups: Vec<&str> = s.strands.iter().map(|s| s.group.as_str()).collect();
    assert_eq!(groups, vec!["fringe", "b", "crown", "crown"]);
    let formats = s.output.formats.map(|f| f.names());
    assert_eq!(formats, Some(vec!["npy", "png", "gif"]));
    assert_eq!(s.output.max_bytes, Some(5_000_000_000));
    assert_eq!(
        setup("[[strands]]\nlength = 0.1\n").output,
        OutputSettings::default()
    );
    let broken = [
        (
            "[output]\nformats = [\"json\", \"vtk\"]\n",
            "output.formats[1]",
            "json, npy, usda, png, gif, obj, preview",
        ),
        (
            "[output]\nformats = [\"json\", 3]\n",
            "output.formats[1]",
            "expected a format name",
        ),
        (
            "[output]\nformats = \"json\"\n",
            "output.formats",
            "expected a list",
        ),
        ("[output]\nformats = []\n", "output.formats", "at least one"),
        ("[output]\nmax_bytes = 0\n", "output.max_bytes", "(0, "),
        (
            "[[strands]]\ngroup = \"\"\n",
            "strands[1].group",
            "non-empty",
        ),
        ("[[strands]]\ngroup = 1\n", "strands[1].group", "a string"),
    ];
    for (extra, field, message) in broken {
        let text = format!("[[strands]]\nlength = 0.1\n{extra}");
        let text = text.replace("[[strands]]\ngroup", "[[strands]]\nlength = 0.1\ngroup");
        let errors = validate_scene(&text);
        assert!(
            errors
                .iter()
                .any(|e| e.field == field && e.message.contains(message)),
            "{field} / {message}: {errors:?}"
        );
    }
}

#[test]
fn poisson_accepts_the_whole_isotropic_range_and_gives_g_of_e_over_three_at_one_half() {
    // (−1, 0.5]: 0.5 (incompressible) and −0.99 are valid; G = E / (2 (1 + ν)).
    for nu in [0.5, -0.99, 0.0] {
        let s = setup(&format!(
            "[[strands]]\nlength = 0.3\nellipticity = 1.0\nyoungs_modulus = 1.2e9\nradius = 5e-5\npoisson = {nu}"
        ));
        let m = s.strands[0].strand.material;
        // circle: GJ = G · 2I and EI = E · I, so GJ / EI = 2G / E = 1 / (1 + ν)
        let ratio = m.stiffness[0] / m.stiffness[1];
        assert!((ratio - 1.0 / (1.0 + nu)).abs() < 1e-14, "nu {nu}: {ratio}");
    }
    let s = setup("[[strands]]\nlength = 0.3\nellipticity = 1.0\npoisson = 0.5");
    let m = s.strands[0].strand.material;
    // at ν = 0.5: G = E/3, GJ = (E/3) · 2I = (2/3) EI
    assert!((m.stiffness[0] / m.stiffness[1] - 2.0 / 3.0).abs() < 1e-14);
}

/// One strand of each preset and a patch of two, with `environment` in `[environment]`
/// and `strand_fields` in every strand and the patch.
fn humid_scene(environment: &str, strand_fields: &str) -> SimulationSetup {
    let mut text = format!("[environment]\n{environment}\n");
    for preset in Preset::ALL {
        text += &format!(
            "[[strands]]\nname = \"{}\"\npreset = \"{}\"\nlength = 0.2\nelements = 3\n{strand_fields}\n",
            preset.name(),
            preset.name()
        );
    }
    text += &format!("[[patches]]\npreset = \"curly\"\ncount = [2, 1]\nsize = [0.01, 0.0]\nlength = 0.2\nelements = 3\n{strand_fields}\n");
    setup(&text)
}

fn rel(a: f64, b: f64) -> f64 {
    (a / b - 1.0).abs()
}

#[test]
fn without_humidity_or_at_65_percent_every_strand_keeps_its_values_bit_for_bit() {
    let plain = humid_scene("", "");
    assert_eq!(humid_scene("relative_humidity = 65", ""), plain);
    assert_eq!(humid_scene("relative_humidity = 65.0", ""), plain);
    for (s, preset) in plain.strands.iter().zip(Preset::ALL) {
        // powi may round differently when constant-folded: compare to 1e-15
        let (got, want) = (s.strand.material, preset.params().cross_section.material());
        assert_eq!(got.mass_per_length, want.mass_per_length);
        for i in 0..3 {
            assert!(rel(got.stiffness[i], want.stiffness[i]) <= 1e-15);
            assert!(rel(got.rotary_inertia[i], want.rotary_inertia[i]) <= 1e-15);
        }
    }
    assert_ne!(humid_scene("relative_humidity = 64.9", ""), plain);
}

#[test]
fn preset_values_follow_the_isotherms() {
    use crate::model::humidity::HumidityScaling;
    let plain = humid_scene("", "");
    for rh in [0.0, 30.0, 82.5, 100.0] {
        let humid = humid_scene(&format!("relative_humidity = {rh}"), "");
        let f = HumidityScaling::at(rh).unwrap();
        let r4 = f.radius.powi(4);
        for (a, b) in plain.strands.iter().zip(&humid.strands) {
            let name = &b.strand.name;
            let (a, b) = (a.strand.material, b.strand.material);
            assert!(rel(b.mass_per_length, a.mass_per_length * f.mass_per_length) < 1e-14);
            assert!(rel(b.stiffness[0], a.stiffness[0] * f.torsion_modulus * r4) < 1e-14);
            for i in [1, 2] {
                assert!(
                    rel(b.stiffness[i], a.stiffness[i] * f.youngs_modulus * r4) < 1e-14,
                    "{name} at {rh} %"
                );
            }
            // the rotary inertia ρI follows density · r⁴ = mass factor · r²
            let m = f.mass_per_length * f.radius * f.radius;
            assert!(rel(b.rotary_inertia[1], a.rotary_inertia[1] * m) < 1e-14);
        }
        let geometry = &humid.strands[0].strand.geometry;
        assert_eq!(
            geometry.mass_per_length,
            humid.strands[0].strand.material.mass_per_length
        );
    }
}

#[test]
fn a_strands_own_material_values_are_not_changed_by_the_humidity() {
    use crate::model::humidity::HumidityScaling;
    let own = "radius = 4e-5\nyoungs_modulus = 3e9\ndensity = 1250\npoisson = 0.3";
    let plain = humid_scene("", own);
    for rh in [0.0, 65.0, 100.0] {
        let humid = humid_scene(&format!("relative_humidity = {rh}"), own);
        for (a, b) in plain.strands.iter().zip(&humid.strands) {
            assert_eq!(a.strand.material, b.strand.material, "at {rh} %");
        }
    }

    // one field at a time: that field stays, the others follow the humidity
    let f = HumidityScaling::at(100.0).unwrap();
    let smooth_strand = |fields: &str| {
        let setup = humid_scene("relative_humidity = 100", fields);
        let plain = humid_scene("", fields);
        (
            setup.strands[0].strand.material,
            plain.strands[0].strand.material,
        )
    };
    let r2 = f.radius * f.radius;
    // youngs_modulus: E as given; G keeps the preset's G/E, which follows g/e
    let (m, m0) = smooth_strand("youngs_modulus = 3e9");
    assert!(rel(m.stiffness[1], m0.stiffness[1] * r2 * r2) < 1e-14);
    assert!(rel(m.stiffness[0], m0.stiffness[0] * r2 * r2 * f.shear()) < 1e-14);
    assert!(rel(m.mass_per_length, m0.mass_per_length * f.mass_per_length) < 1e-14);
    // radius: no swelling; the humid density gives the mass per length
    let (m, m0) = smooth_strand("radius = 4e-5");
    assert!(rel(m.stiffness[1], m0.stiffness[1] * f.youngs_modulus) < 1e-14);
    assert!(rel(m.stiffness[0], m0.stiffness[0] * f.torsion_modulus) < 1e-14);
    assert!(rel(m.mass_per_length, m0.mass_per_length * f.density()) < 1e-14);
    // density: the area swells, the density stays
    let (m, m0) = smooth_strand("density = 1250");
    assert!(rel(m.mass_per_length, m0.mass_per_length * r2) < 1e-14);
    assert!(rel(m.stiffness[1], m0.stiffness[1] * f.youngs_modulus * r2 * r2) < 1e-14);
    // poisson: G = E / (2(1 + ν)) with the humid E (a circle: GJ / EI = 1 / (1 + ν))
    let (m, m0) = smooth_strand("poisson = 0.3");
    assert!(rel(m.stiffness[0] / m.stiffness[1], 1.0 / 1.3) < 1e-14);
    assert!(rel(m.stiffness[1], m0.stiffness[1] * f.youngs_modulus * r2 * r2) < 1e-14);
}

#[test]
fn tresses_spread_roots_over_their_ellipse_and_electrostatics_takes_each_strands_charge() {
    let s = setup(
        "[electrostatics]\ncharge_per_length = -2e-11\n[[tresses]]\nname = \"t\"\ncount = 200\nsemi_axes = [0.02, 0.01]\n\
         center = [0.0, 0.0, 0.1]\ndirection = [0.0, 0.0, -1.0]\nnormal = [1.0, 0.0, 0.0]\nlength = 0.3\n\
         [[strands]]\nname = \"own\"\nlength = 0.1\ncharge_per_length = 5e-12",
    );
    assert_eq!(s.strands.len(), 201);
    let tress: Vec<_> = s.strands.iter().filter(|t| t.group == "t").collect();
    assert_eq!(tress.len(), 200);
    let (mut sx, mut sy) = (0.0f64, 0.0f64);
    for t in &tress {
        let r = t.strand.geometry.root_position;
        assert!((r.z - 0.1).abs() < 1e-15);
        let e = (r.x / 0.02).powi(2) + (r.y / 0.01).powi(2);
        assert!(e <= 1.0, "root outside the ellipse: {r:?}");
        sx += r.x;
        sy += r.y;
    }
    // Uniform over the ellipse: centred, and a quarter of the roots within half the radius.
    assert!((sx / 200.0).abs() < 1e-3 && (sy / 200.0).abs() < 1e-3);
    let inner = tress.iter().filter(|t| {
        let r = t.strand.geometry.root_position;
        (r.x / 0.02).powi(2) + (r.y / 0.01).powi(2) <= 0.25
    });
    assert_eq!(inner.count(), 50);
    let e = s.electrostatics.expect("electrostatics");
    assert_eq!(e.charge_per_length.len(), 201);
    assert_eq!(e.charge_per_length[0], 5e-12, "[[strands]] come first");
    assert!(e.charge_per_length[1..].iter().all(|l| *l == -2e-11));
    assert_eq!(e.softening, 1.0 / 330.0);
}

/// A `[bodies.motion]` table makes the body move on its own (attached = "motion" by
/// default then), read as `[head.motion]` is.
#[test]
fn a_body_with_a_motion_table_moves_on_its_own() {
    use crate::bodies::Attachment;
    use crate::forces::head_motion::HeadMotion;
    let s = setup(
        r#"
[[strands]]
length = 0.1
[[bodies]]
name = "comb"
shape = "capsule"
start = [0.0, -0.05, 0.0]
end = [0.0, 0.05, 0.0]
radius = 0.005
[bodies.motion]
kind = "keyframes"
keys = [{ t = 0.0, position = [-0.05, 0.0, -0.05] }, { t = 1.0, position = [0.05, 0.0, -0.05], rotation_axis_angle_deg = [0.0, 0.0, 90.0] }]
[[bodies]]
name = "paddle"
shape = "sphere"
radius = 0.01
attached = "motion"
motion = { kind = "translate-oscillate", direction = [0.0, 2.0, 0.0], amplitude = 0.01, frequency_hz = 2.0 }
"#,
    );
    let Attachment::Motion(HeadMotion::Keyframes(track)) = &s.bodies[0].attached else {
        panic!("{:?}", s.bodies[0].attached)
    };
    assert_eq!(track.keys().len(), 2);
    assert_eq!(track.keys()[1].position, Vector3::new(0.05, 0.0, -0.05));
    assert!((track.keys()[1].rotation.z - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    assert_eq!(
        s.bodies[1].attached,
        Attachment::Motion(HeadMotion::TranslateOscillate {
            direction: Vector3::y(),
            amplitude: 0.01,
            frequency_hz: 2.0
        })
    );
    assert_eq!(s.bodies[1].attached.name(), "motion");
}

#[test]
fn bodies_become_their_setups_and_a_scene_without_them_has_none() {
    use crate::bodies::{Attachment, ShapeSetup};
    use nalgebra::Rotation3;
    assert!(setup("[[strands]]\nlength = 0.1\n").bodies.is_empty());
    let s = parse_scene_at(
        r#"
[[strands]]
length = 0.1
[[bodies]]
name = "head"
shape = "ellipsoid"
center = [0.0, 0.0, 0.08]
radii = [0.08, 0.1, 0.12]
rotation_axis_angle_deg = [0.0, 0.0, 90.0]
[[bodies]]
shape = "sphere"
radius = 0.05
attached = "world"
[[bodies]]
shape = "capsule"
start = [0.0, 0.0, 0.0]
end = [0.0, 0.0, -0.1]
radius = 0.04
[[bodies]]
shape = "plane"
point = [0.0, 0.0, -1.0]
normal = [0.0, 0.0, 2.0]
attached = "world"
[[bodies]]
shape = "mesh"
path = "meshes/head.obj"
cell = 0.004
scale = 0.01
translation = [0.0, 0.0, 0.1]
"#,
        std::path::Path::new("/scenes"),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = s.bodies.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(names, ["head", "body1", "body2", "body3", "body4"]);
    let attached: Vec<Attachment> = s.bodies.iter().map(|b| b.attached.clone()).collect();
    use Attachment::{Head, World};
    assert_eq!(attached, [Head, World, Head, World, Head]);
    let ShapeSetup::Ellipsoid {
        radii, rotation, ..
    } = &s.bodies[0].shape
    else {
        panic!("{:?}", s.bodies[0].shape)
    };
    assert_eq!(*radii, Vector3::new(0.08, 0.1, 0.12));
    assert!((rotation * Vector3::x() - Vector3::y()).norm() < 1e-15);
    assert_eq!(
        s.bodies[3].shape,
        ShapeSetup::Plane {
            point: Vector3::new(0.0, 0.0, -1.0),
            normal: Vector3::z()
        }
    );
    assert_eq!(
        s.bodies[4].shape,
        ShapeSetup::Mesh {
            path: "/scenes/meshes/head.obj".into(),
            cell: Some(0.004),
            scale: 0.01,
            rotation: Rotation3::identity().into_inner(),
            translation: Vector3::new(0.0, 0.0, 0.1),
        }
    );
}

/// `shape = "grid"` reads its path (against the scene's folder), origin and cell, and
/// names a missing field.
#[test]
fn a_scene_grid_body_reads_its_fields() {
    let s = parse_scene_at(
        "[[strands]]\nlength = 0.1\n[[bodies]]\nshape = \"grid\"\npath = \"sdf/head.npy\"\n\
         origin = [-0.1, -0.1, 0.0]\ncell = 0.005\nattached = \"world\"\n",
        std::path::Path::new("/scenes"),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        s.bodies[0].shape,
        crate::bodies::ShapeSetup::Grid {
            path: "/scenes/sdf/head.npy".into(),
            origin: Vector3::new(-0.1, -0.1, 0.0),
            cell: 0.005,
        }
    );
    let e = parse_scene_at(
        "[[strands]]\nlength = 0.1\n[[bodies]]\nshape = \"grid\"\npath = \"a.npy\"\ncell = 0.005\n",
        std::path::Path::new("/scenes"),
    )
    .expect_err("no origin");
    assert!(e.to_string().contains("bodies[0].origin"), "{e}");
}
