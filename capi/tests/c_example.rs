//! The C example `capi/examples/step_strand.c`, compiled with the system C compiler
//! (`$CC`, else `cc`) against the static library cargo built for this test, run, and its
//! output compared with the same strand stepped in Rust:
//!
//! - through `superhelix_kernels::fixed::step` (the checked step behind the C API by
//!   default) and `fixed::linearly_implicit` (the plain step): the same bits, under
//!   gravity and without;
//! - through the runtime's `Simulation` (the runtime's linearly implicit Euler step with
//!   its checks), hanging under gravity and in an elastic release from 1.03 × the
//!   natural curvature without gravity: within 1e-12 relative.
//!
//! The library is `libsuperhelix_capi.a` beside this test's executable (`deps/`): cargo
//! builds every crate type of the library (cdylib, staticlib, rlib) for the tests.
//! A Rust static library on Linux links with `-lpthread -ldl -lm`.

use nalgebra::{Matrix3, Vector3};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use superhelix_generated::ClosedForm;
use superhelix_kernels::fixed::{
    self, Effects, FixedParams, FixedStrand, FixedWorkspace, StepCounts, StepInput, StillHead,
};
use superhelix_kernels::head::HeadState;
use superhelix_kernels::material::{helix_curvature, section_terms};
use superhelix_kernels::pose::Pose;
use superhelix_runtime::config::{SimulationConfig, SimulationSetup, StrandSetup};
use superhelix_runtime::{
    CrossSection, Environment, HeadMotion, Simulation, Strand, StrandGeometry,
};

const N: usize = 5;
const D: usize = 15;
const E: usize = 6;
const B: usize = 7;
const DT: f64 = 1.0 / 30.0;
const STEPS: usize = 30;
const LENGTH: f64 = 0.2;
const GAMMA: f64 = 5e-11;
const NU: f64 = 5e-6;

/// The cross-section of the example: (radius, ellipticity, E, Poisson, density).
const SECTION: CrossSection = CrossSection {
    radius: 50e-6,
    ellipticity: 1.0,
    youngs_modulus: 1.5e9,
    poisson: 0.48,
    density: 1300.0,
    shear_factor: 1.0,
};

/// The compiled example (built once per test process).
fn example() -> &'static Path {
    static EXE: OnceLock<PathBuf> = OnceLock::new();
    EXE.get_or_init(|| {
        let deps = std::env::current_exe()
            .expect("test executable")
            .parent()
            .expect("deps directory")
            .to_path_buf();
        let lib = deps.join("libsuperhelix_capi.a");
        assert!(
            lib.exists(),
            "{} not found: cargo builds the static library with the tests \
             (crate-type staticlib in capi/Cargo.toml)",
            lib.display()
        );
        let capi = Path::new(env!("CARGO_MANIFEST_DIR"));
        let out_dir = deps.join("..").join("capi-example");
        std::fs::create_dir_all(&out_dir).expect("output directory");
        let exe = out_dir.join("step_strand");
        let cc = std::env::var("CC").unwrap_or_else(|_| "cc".to_string());
        let output = Command::new(&cc)
            .args([
                "-std=c99",
                "-O2",
                "-Wall",
                "-Wextra",
                "-pedantic",
                "-Werror",
                "-I",
            ])
            .arg(capi.join("include"))
            .arg(capi.join("examples").join("step_strand.c"))
            .arg(&lib)
            .args(["-lpthread", "-ldl", "-lm", "-o"])
            .arg(&exe)
            .output()
            .unwrap_or_else(|e| panic!("running the C compiler `{cc}`: {e}"));
        assert!(
            output.status.success(),
            "`{cc}` failed on step_strand.c:\n{}",
            String::from_utf8_lossy(&output.stderr)
        );
        exe
    })
}

/// What the example printed.
#[derive(Debug)]
struct Printed {
    frame: [f64; 9],
    natural: [f64; 3],
    q: [f64; D],
    points: [[f64; 3]; E],
    /// With a tolerance: steps taken, rejected, the largest estimated error / L.
    steps: Option<(usize, usize, f64)>,
}

fn run_example(args: &[&str]) -> Printed {
    let output = Command::new(example())
        .args(args)
        .output()
        .expect("run step_strand");
    let stdout = String::from_utf8(output.stdout).expect("UTF-8 output");
    assert!(
        output.status.success(),
        "step_strand {args:?} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let mut p = Printed {
        frame: [f64::NAN; 9],
        natural: [f64::NAN; 3],
        q: [f64::NAN; D],
        points: [[f64::NAN; 3]; E],
        steps: None,
    };
    for line in stdout.lines().filter(|l| !l.starts_with('#')) {
        let words: Vec<&str> = line.split_whitespace().collect();
        let i: usize = words[1].parse().expect("index");
        let x = |k: usize| -> f64 { words[k].parse().expect("number") };
        match words[0] {
            "frame" => p.frame[i] = x(2),
            "natural" => p.natural[i] = x(2),
            "q" => p.q[i] = x(2),
            "point" => p.points[i] = [x(2), x(3), x(4)],
            "steps" => p.steps.get_or_insert((0, 0, 0.0)).0 = words[2].parse().expect("count"),
            "rejected" => p.steps.get_or_insert((0, 0, 0.0)).1 = words[2].parse().expect("count"),
            "largest_error" => p.steps.get_or_insert((0, 0, 0.0)).2 = x(2),
            other => panic!("unexpected line `{other}` in:\n{stdout}"),
        }
    }
    let all = p.frame.iter().chain(&p.natural).chain(&p.q);
    assert!(
        all.chain(p.points.iter().flatten()).all(|x| x.is_finite()),
        "incomplete output:\n{stdout}"
    );
    p
}

/// The section terms as the library computes them: from values it reads at run time.
/// (With constant arguments the compiler may fold the formula's `powi` at build time
/// into a result one ulp away from the run-time one.)
fn section() -> superhelix_kernels::material::SectionTerms {
    let c = std::hint::black_box(SECTION);
    section_terms(
        c.radius,
        c.ellipticity,
        c.youngs_modulus,
        c.poisson,
        c.density,
    )
}

/// The example's strand in Rust, from the frame and natural shape it printed.
fn rust_strand(p: &Printed) -> FixedStrand<N, D, B> {
    let f = &p.frame;
    let params = FixedParams::<N, D>::new(
        [0.0; 3],
        [[f[0], f[1], f[2]], [f[3], f[4], f[5]], [f[6], f[7], f[8]]],
        [LENGTH / N as f64; N],
        &section(),
        core::array::from_fn(|i| p.natural[i % 3]),
        GAMMA,
        NU,
    )
    .expect("valid parameters");
    FixedStrand::at_rest(params)
}

/// Steps `strand` as the example does (the checked step or the plain one) and returns
/// it with its centreline (world = head coordinates: the head rests at the origin).
fn step_in_rust(
    mut strand: FixedStrand<N, D, B>,
    gravity: Option<Vector3<f64>>,
    checked: bool,
) -> (FixedStrand<N, D, B>, [Pose; E]) {
    let mut ws = Box::new(FixedWorkspace::<N, D, E>::new());
    let input = StepInput {
        head: HeadState::rest(),
        gravity,
        head_moves: false,
    };
    let effects = Effects {
        gravity,
        head_moves: false,
    };
    let mut counts = StepCounts::default();
    for k in 0..STEPS {
        let t = k as f64 * DT;
        let r = if checked {
            fixed::step(
                &ClosedForm,
                &mut strand,
                &StillHead,
                &effects,
                t,
                DT,
                &mut ws,
                &mut counts,
            )
        } else {
            fixed::linearly_implicit(&ClosedForm, &mut strand, &input, DT, &mut ws)
        };
        r.expect("fixed step");
    }
    let mut ends = [Pose::default(); E];
    fixed::centreline(&ClosedForm, &strand, &mut ends);
    (strand, ends)
}

/// Largest |a − b| relative to max(max |a|, 1).
fn relative(a: &[f64], b: &[f64]) -> f64 {
    let scale = a.iter().fold(1.0f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs() / scale))
}

fn check_against_rust(
    p: &Printed,
    strand: FixedStrand<N, D, B>,
    gravity: Option<Vector3<f64>>,
    checked: bool,
) {
    let (strand, ends) = step_in_rust(strand, gravity, checked);
    let dq = relative(&strand.q, &p.q);
    eprintln!(
        "C vs fixed::step: largest relative |Δq| {dq:.3e} ({})",
        if strand.q == p.q {
            "bit-identical"
        } else {
            "not bit-identical"
        }
    );
    assert!(dq <= 1e-12, "C q {:?}\nRust q {:?}", p.q, strand.q);
    let rust_points: Vec<f64> = ends
        .iter()
        .flat_map(|e| e.position.iter().copied())
        .collect();
    let c_points: Vec<f64> = p.points.iter().flatten().copied().collect();
    let dx = rust_points
        .iter()
        .zip(&c_points)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(dx <= 1e-12 * LENGTH, "centreline differs by {dx:.3e} m");
}

/// The example computes its frame and natural shape as documented.
fn check_inputs(p: &Printed) {
    let n0 = Vector3::new(0.3, 0.0, -1.0).normalize();
    let x = Vector3::x();
    let n1 = (x - n0 * n0.dot(&x)).normalize();
    let frame = Matrix3::from_columns(&[n0, n1, n0.cross(&n1)]);
    let df = frame
        .as_slice()
        .iter()
        .zip(&p.frame)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(df <= 1e-15, "frame differs by {df:.3e}");
    assert_eq!(p.natural, helix_curvature(6e-3, 5e-3, true));
}

/// The runtime's `Simulation` on the example's strand from q0 for the example's steps.
fn runtime_q(
    p: &Printed,
    natural: &[f64; D],
    q0: &[f64; D],
    gravity: Option<Vector3<f64>>,
    tolerance: Option<f64>,
) -> Vec<f64> {
    let material = SECTION.material();
    let runtime_strand = Strand {
        name: "example".into(),
        geometry: StrandGeometry::new(
            Vector3::zeros(),
            Matrix3::from_column_slice(&p.frame),
            vec![LENGTH / N as f64; N],
            &material,
        ),
        material,
        natural: natural.to_vec(),
        internal_friction: GAMMA,
        air_drag: NU,
        point_loads: Vec::new(),
        ends: Default::default(),
    };
    let setup = SimulationSetup {
        electrostatics: None,
        contacts: None,
        config: SimulationConfig {
            dt: DT,
            duration: STEPS as f64 * DT,
            tolerance,
            engine: superhelix_runtime::config::Engine::Runtime,
            ..Default::default()
        },
        environment: Environment { gravity },
        head: HeadMotion::Still,
        strands: vec![StrandSetup {
            charge_per_length: None,
            tip: None,
            strand: runtime_strand,
            q0: q0.to_vec(),
            group: "example".into(),
        }],
        bodies: Vec::new(),
        samples_per_element: 4,
        output: Default::default(),
    };
    let factory = superhelix_runtime::kernels::closed_form::kernel_factory();
    let mut sim = Simulation::new(setup, Some(factory)).expect("valid setup");
    assert!(sim.uses_generated_kernel(0));
    for _ in 0..STEPS {
        sim.step().expect("runtime step");
    }
    eprintln!("runtime: {:?}", sim.stats());
    sim.q(0).to_vec()
}

const GRAVITY: Vector3<f64> = Vector3::new(0.0, 0.0, -9.81);

#[test]
fn c_example_under_gravity_matches_the_fixed_step_and_the_runtime() {
    let p = run_example(&[]);
    check_inputs(&p);
    let strand = rust_strand(&p);
    check_against_rust(&p, strand.clone(), Some(GRAVITY), true);
    // the strand hangs: its tip is below its root
    assert!(p.points[E - 1][2] < 0.0);
    let q = runtime_q(&p, &strand.params.natural, &strand.q, Some(GRAVITY), None);
    let dq = relative(&q, &p.q);
    eprintln!("C vs Simulation under gravity: largest relative |Δq| {dq:.3e}");
    assert!(dq <= 1e-12, "C q {:?}\nruntime q {q:?}", p.q);
}

#[test]
fn c_example_release_matches_the_fixed_step_and_the_runtime() {
    let p = run_example(&["release"]);
    check_inputs(&p);
    let mut strand = rust_strand(&p);
    let q0: [f64; D] = core::array::from_fn(|i| strand.q[i] * 1.03);
    strand.set_state(&q0, &[0.0; D]);
    check_against_rust(&p, strand.clone(), None, true);
    let q = runtime_q(&p, &strand.params.natural, &q0, None, None);
    let dq = relative(&q, &p.q);
    eprintln!("C vs Simulation: largest relative |Δq| {dq:.3e}");
    assert!(dq <= 1e-12, "C q {:?}\nruntime q {q:?}", p.q);
}

#[test]
fn c_example_with_the_plain_step_matches_the_linearly_implicit_step() {
    for args in [&["unchecked"][..], &["unchecked", "release"][..]] {
        let p = run_example(args);
        check_inputs(&p);
        let mut strand = rust_strand(&p);
        let gravity = if args.contains(&"release") {
            let q0: [f64; D] = core::array::from_fn(|i| strand.q[i] * 1.03);
            strand.set_state(&q0, &[0.0; D]);
            None
        } else {
            Some(GRAVITY)
        };
        check_against_rust(&p, strand, gravity, false);
    }
}

/// `sh_batch_set_tolerance`: the C strand takes the runtime engine's error-controlled
/// steps (measured: q equal to round-off, 5e-16 relative), more of them than the 30 fixed
/// steps, each within the tolerance.
#[test]
fn c_example_with_a_tolerance_matches_the_runtimes_error_controlled_step() {
    for (args, tolerance) in [
        (&["tolerance", "1e-3"][..], 1e-3),
        (&["release", "tolerance", "1e-5"][..], 1e-5),
    ] {
        let p = run_example(args);
        check_inputs(&p);
        let mut strand = rust_strand(&p);
        let gravity = if args.contains(&"release") {
            let q0: [f64; D] = core::array::from_fn(|i| strand.q[i] * 1.03);
            strand.set_state(&q0, &[0.0; D]);
            None
        } else {
            Some(GRAVITY)
        };
        let q = runtime_q(
            &p,
            &strand.params.natural,
            &strand.q,
            gravity,
            Some(tolerance),
        );
        let dq = relative(&q, &p.q);
        let (steps, rejected, largest) = p.steps.expect("the example reports its steps");
        eprintln!(
            "{args:?}: C vs Simulation: largest relative |Δq| {dq:.3e}; {steps} steps, {rejected} rejected, largest error {largest:.2e}"
        );
        assert!(dq <= 1e-12, "C q {:?}\nruntime q {q:?}", p.q);
        assert!(steps > STEPS, "{steps} steps");
        assert!(
            largest > 0.0 && largest <= tolerance,
            "largest error {largest:e}"
        );
    }
}
