//! The fixed-N strand of 7 elements this crate's build script generated: a hanging hair
//! strand stepped 30 times at 1/30 s under gravity, against the kernels' const-generic
//! step (bit for bit), the runtime's moment kernel (the terms at the same state) and the
//! runtime's step of the same strand. N = 7 is not a checked-in size, so there is no
//! checked-in module to compare with.

use superhelix_example_fixed_n7::{n7, visit_size, SIZES};
use superhelix_generated::kernels::body_field::BodyField;
use superhelix_generated::kernels::fixed::{
    self, Effects, FixedStrand, FixedWorkspace, StepCounts, StepInput, StillHead,
};
use superhelix_generated::kernels::head::{body_field, HeadState};
use superhelix_generated::kernels::material::section_terms;
use superhelix_generated::kernels::strand_terms::{evaluate_terms, TermMatrix, TermVectors, Terms};
use superhelix_generated::ClosedForm;
use superhelix_runtime::config::{SimulationConfig, SimulationSetup, StrandSetup};
use superhelix_runtime::kernels::moments::kernel::MomentKernel;
use superhelix_runtime::{
    CrossSection, Environment, EvalInput, HeadMotion, Matrix3, Simulation, Strand, StrandGeometry,
    StrandKernel, StrandTerms, Vector3,
};

/// Time step, seconds.
const H: f64 = 1.0 / 30.0;
/// Steps taken.
const STEPS: usize = 30;
/// Total length, metres.
const LENGTH: f64 = 0.25;
/// Internal friction γ, kg·m³/s.
const FRICTION: f64 = 5e-11;
/// Air drag ν, kg/(m·s).
const DRAG: f64 = 5e-6;
/// Natural (τ, κ1, κ2) of every element, rad/m: a loose curl.
const NATURAL: [f64; 3] = [2.0, 20.0, 5.0];
/// Root frame, columns (n0, n1, n2): the tangent n0 along −z (hanging).
const FRAME: [[f64; 3]; 3] = [[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]];
/// Hair: radius 50 µm, round, E = 1 GPa, Poisson 0.48, density 1300 kg/m³.
const HAIR: CrossSection = CrossSection {
    radius: 50e-6,
    ellipticity: 1.0,
    youngs_modulus: 1e9,
    poisson: 0.48,
    density: 1300.0,
    shear_factor: 1.0,
};

/// Reports the const parameters it is visited with.
struct SizeVisitorCheck;

impl superhelix_generated::SizeVisitor for SizeVisitorCheck {
    type Output = (usize, usize, usize, usize);
    fn visit<const N: usize, const D: usize, const E: usize, const B: usize>(self) -> Self::Output {
        (N, D, E, B)
    }
}

fn gravity() -> Vector3<f64> {
    Vector3::new(0.0, 0.0, -9.81)
}

/// The strand's parameters, from the kernels' section formulas.
fn params() -> n7::Params {
    let section = section_terms(
        HAIR.radius,
        HAIR.ellipticity,
        HAIR.youngs_modulus,
        HAIR.poisson,
        HAIR.density,
    );
    n7::Params::new(
        [0.0; 3],
        FRAME,
        [LENGTH / n7::N as f64; n7::N],
        &section,
        core::array::from_fn(|i| NATURAL[i % 3]),
        FRICTION,
        DRAG,
    )
    .expect("valid parameters")
}

/// The same strand as the runtime describes it.
fn runtime_strand() -> Strand {
    let material = HAIR.material();
    let frame = Matrix3::from_fn(|r, c| FRAME[c][r]);
    Strand {
        name: "hanging".to_string(),
        geometry: StrandGeometry::new(
            Vector3::zeros(),
            frame,
            vec![LENGTH / n7::N as f64; n7::N],
            &material,
        ),
        material,
        natural: (0..n7::N).flat_map(|_| NATURAL).collect(),
        internal_friction: FRICTION,
        air_drag: DRAG,
        point_loads: Vec::new(),
        ends: Default::default(),
    }
}

fn effects() -> Effects {
    Effects {
        gravity: Some(gravity()),
        head_moves: false,
    }
}

fn assert_finite(s: &n7::Strand, step: usize) {
    assert!(
        s.q.iter().chain(&s.v).all(|x| x.is_finite()),
        "step {step}: non-finite state {:?} {:?}",
        s.q,
        s.v
    );
}

fn bits(x: &[f64]) -> Vec<u64> {
    x.iter().map(|x| x.to_bits()).collect()
}

/// The checked step of `n7` and `fixed::step::<ClosedForm, 7, 21, 8, 10, f64>` side by side;
/// the strand of `n7` at the end.
fn step_both() -> n7::Strand {
    let mut a = n7::Strand::at_rest(params());
    let mut b = FixedStrand::<7, 21, 10>::at_rest(params());
    let mut wa = Box::new(n7::Workspace::new());
    let mut wb = Box::new(FixedWorkspace::<7, 21, 8>::new());
    let (mut ca, mut cb) = (StepCounts::default(), StepCounts::default());
    for k in 0..STEPS {
        let t = k as f64 * H;
        let ra = n7::step(&mut a, &StillHead, &effects(), t, H, &mut wa, &mut ca);
        let rb = fixed::step::<ClosedForm, 7, 21, 8, 10, f64>(
            &ClosedForm,
            &mut b,
            &StillHead,
            &effects(),
            t,
            H,
            &mut wb,
            &mut cb,
        );
        let ra = ra.unwrap_or_else(|e| panic!("step {k}: {e}"));
        assert_eq!(Ok(ra), rb, "step {k}");
        assert_finite(&a, k);
        assert_eq!(bits(&a.q), bits(&b.q), "q after step {k}");
        assert_eq!(bits(&a.v), bits(&b.v), "q̇ after step {k}");
    }
    assert_eq!(ca, cb);
    a
}

#[test]
fn the_build_script_wrote_n7_and_its_dispatch() {
    assert_eq!(SIZES, [7]);
    assert_eq!(
        (n7::N, n7::DOFS, n7::ENDS, n7::BASIS),
        (7, 21, 8, 10),
        "every size a literal"
    );
    assert_eq!(visit_size(7, SizeVisitorCheck), Some((7, 21, 8, 10)));
    assert_eq!(visit_size(5, SizeVisitorCheck), None);
    assert_eq!(visit_size(0, SizeVisitorCheck), None);
}

#[test]
fn hanging_strand_steps_as_the_const_generic_step_bit_for_bit() {
    let s = step_both();
    // gravity pulled the curl open: the state left its natural shape
    let moved =
        s.q.iter()
            .zip(&s.params.natural)
            .fold(0.0f64, |m, (q, n)| m.max((q - n).abs()));
    assert!(moved > 1e-3, "the strand did not move ({moved:e} rad/m)");
    let mut ends = [Default::default(); n7::ENDS];
    n7::centreline(&s, &mut ends);
    let tip = ends[n7::N].position;
    assert!(
        tip.iter().all(|x| x.is_finite()) && tip.z < -0.1,
        "tip {tip:?}"
    );
}

#[test]
fn linearly_implicit_steps_as_the_const_generic_step_bit_for_bit() {
    let input = StepInput {
        head: HeadState::rest(),
        gravity: Some(gravity()),
        head_moves: false,
    };
    let mut a = n7::Strand::at_rest(params());
    let mut b = FixedStrand::<7, 21, 10>::at_rest(params());
    let mut wa = Box::new(n7::Workspace::new());
    let mut wb = Box::new(FixedWorkspace::<7, 21, 8>::new());
    for k in 0..STEPS {
        let ra = n7::linearly_implicit(&mut a, &input, H, &mut wa);
        let rb = fixed::linearly_implicit::<ClosedForm, 7, 21, 8, 10, f64>(
            &ClosedForm,
            &mut b,
            &input,
            H,
            &mut wb,
        );
        let ra = ra.unwrap_or_else(|e| panic!("step {k}: {e}"));
        assert_eq!(Ok(ra), rb, "step {k}");
        assert_finite(&a, k);
        assert_eq!(bits(&a.q), bits(&b.q), "q after step {k}");
        assert_eq!(bits(&a.v), bits(&b.v), "q̇ after step {k}");
    }
}

fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let diff = a
        .iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    diff / scale.max(1e-300)
}

#[test]
fn terms_match_the_runtime_moment_kernel() {
    let s = step_both();
    let field: BodyField = body_field(
        Some(gravity()),
        false,
        &HeadState::rest(),
        s.params.mass_per_length,
        DRAG,
    );
    // the terms on n7's buffers of literal size
    let mut assembly = Box::new(n7::Assembly::new());
    let (mut force, mut b) = ([0.0; n7::DOFS], [0.0; n7::DOFS]);
    let mut first = Vector3::zeros();
    let mut mass = vec![0.0; n7::DOFS * n7::DOFS];
    let mut vectors = TermVectors {
        force: &mut force,
        velocity_term: &mut b,
        first_moment: &mut first,
    };
    evaluate_terms(
        &ClosedForm,
        &s.params.shape(),
        &mut assembly.buffers(),
        &s.q,
        &s.v,
        &field,
        Terms::all(),
        &mut vectors,
        &mut |which, m| {
            if which == TermMatrix::Mass {
                mass.copy_from_slice(m);
            }
        },
    );
    // the runtime's moment kernel (Vec buffers) at the same q, q̇
    let geometry = runtime_strand().geometry;
    let mut kernel = MomentKernel::new(geometry, ClosedForm);
    let mut out = StrandTerms::new(n7::DOFS);
    kernel.evaluate(
        &EvalInput {
            q: &s.q,
            v: &s.v,
            field,
            terms: Terms::all(),
        },
        &mut out,
    );
    let runtime_mass: Vec<f64> = (0..n7::DOFS)
        .flat_map(|c| (0..n7::DOFS).map(move |r| (r, c)))
        .map(|(r, c)| out.mass[(r, c)])
        .collect();
    let dm = rel_diff(&mass, &runtime_mass);
    let df = rel_diff(&force, &out.force);
    eprintln!("n7 vs MomentKernel<ClosedForm>: M {dm:.2e}, force {df:.2e}");
    assert!(dm <= 1e-12, "M differs by {dm:e}");
    assert!(df <= 1e-12, "force differs by {df:e}");
}

/// The runtime's step of the same strand (the runtime engine, linearly implicit Euler,
/// the same checks after the fact and the same projection of the field stiffness).
#[test]
fn steps_match_the_runtime_step_of_the_same_strand() {
    let strand = runtime_strand();
    let setup = SimulationSetup {
        electrostatics: None,
        contacts: None,
        config: SimulationConfig {
            dt: H,
            duration: STEPS as f64 * H,
            ..SimulationConfig::default()
        },
        environment: Environment {
            gravity: Some(gravity()),
        },
        head: HeadMotion::Still,
        strands: vec![StrandSetup {
            charge_per_length: None,
            tip: None,
            q0: strand.natural.clone(),
            group: strand.name.clone(),
            strand,
        }],
        bodies: Vec::new(),
        samples_per_element: 2,
        output: Default::default(),
    };
    let factory = superhelix_runtime::kernels::closed_form::kernel_factory();
    let mut sim = Simulation::new(setup, Some(factory)).expect("valid setup");
    // N = 7 has generated fixed-N code in superhelix-generated only when it was built
    // with SUPERHELIX_N=7; otherwise `auto` runs the moment path (never quadrature)
    let expected = if superhelix_generated::fixed::SIZES.contains(&7) {
        "generated fixed-N (N = 7)"
    } else {
        "moment assembly (closed form), N = 7"
    };
    assert_eq!(sim.kernel_description(0), expected);
    let mut s = n7::Strand::at_rest(params());
    let mut ws = Box::new(n7::Workspace::new());
    let mut counts = StepCounts::default();
    let mut worst = 0.0f64;
    for k in 0..STEPS {
        sim.step().expect("runtime step");
        n7::step(
            &mut s,
            &StillHead,
            &effects(),
            k as f64 * H,
            H,
            &mut ws,
            &mut counts,
        )
        .unwrap_or_else(|e| panic!("step {k}: {e}"));
        let (q, v) = (sim.q(0), sim.v(0));
        let scale = q.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1.0);
        let dq = q
            .iter()
            .zip(&s.q)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs() / scale));
        worst = worst.max(dq).max(rel_diff(&s.v, v));
    }
    eprintln!("n7::step vs the runtime's step: largest relative |Δq|, |Δq̇| {worst:.2e}");
    assert!(worst <= 1e-12, "largest relative |Δq|, |Δq̇| {worst:.3e}");
}

/// The f32 strand of `n7::f32` (the same parameters rounded to f32) and
/// `fixed::step::<ClosedForm, 7, 21, 8, 10, f32>` side by side, bit for bit, and against
/// the f64 strand of `n7`: no NaN, the same checks after the fact (splits, energy
/// rejections and limits), the centrelines within 5e-4 of the length. This strand,
/// released from its natural shape, has steps whose velocities the energy balance
/// scales down (by λ from the step's excess energy); the f32 excess carries the f32
/// round-off allowance (64 ε of the energy's parts, ~1.5e-5 of the energy scale), so the
/// two trajectories part there: 2.7e-6 L after the first limited step (step 5), which
/// the whip of the release transient (steps 6–14, up to 16 substeps per step) amplifies
/// to 2.1e-4 L (1775 f32 epsilons) before the strand settles; the bound leaves 2.4× of
/// that. Before that first limited step the two differ by round-off only (1.6 f32
/// epsilons over steps 1–5), held to 16 ε.
#[test]
fn f32_strand_steps_as_the_const_generic_f32_step_and_near_the_f64_one() {
    let p64 = params();
    let p32 = n7::f32::Params::new(
        [0.0; 3],
        FRAME,
        [LENGTH / n7::N as f64; n7::N],
        &section_terms(
            HAIR.radius,
            HAIR.ellipticity,
            HAIR.youngs_modulus,
            HAIR.poisson,
            HAIR.density,
        ),
        core::array::from_fn(|i| NATURAL[i % 3]),
        FRICTION,
        DRAG,
    )
    .expect("valid parameters");
    assert_eq!(p32, p64.cast::<f32>(), "Params::new in f32 rounds once");
    let mut a = n7::f32::Strand::at_rest(p32);
    let mut b = FixedStrand::<7, 21, 10, f32>::at_rest(p32);
    let mut c = n7::Strand::at_rest(p64);
    let mut wa = Box::new(n7::f32::Workspace::new());
    let mut wb = Box::new(FixedWorkspace::<7, 21, 8, f32>::new());
    let mut wc = Box::new(n7::Workspace::new());
    let (mut ca, mut cb, mut cc) = (
        StepCounts::default(),
        StepCounts::default(),
        StepCounts::default(),
    );
    let mut worst = 0.0f64;
    let (mut worst_plain, mut plain_steps) = (0.0f64, 0);
    for k in 0..STEPS {
        let t = k as f64 * H;
        let ra = n7::f32::step(&mut a, &StillHead, &effects(), t, H, &mut wa, &mut ca);
        let rb = fixed::step::<ClosedForm, 7, 21, 8, 10, f32>(
            &ClosedForm,
            &mut b,
            &StillHead,
            &effects(),
            t,
            H,
            &mut wb,
            &mut cb,
        );
        n7::step(&mut c, &StillHead, &effects(), t, H, &mut wc, &mut cc)
            .unwrap_or_else(|e| panic!("f64 step {k}: {e}"));
        let ra = ra.unwrap_or_else(|e| panic!("f32 step {k}: {e}"));
        assert_eq!(Ok(ra), rb, "step {k}");
        assert!(
            a.q.iter().chain(&a.v).all(|x| x.is_finite()),
            "step {k}: non-finite f32 state"
        );
        let bits32 = |x: &[f32]| x.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits32(&a.q), bits32(&b.q), "q after step {k}");
        assert_eq!(bits32(&a.v), bits32(&b.v), "q̇ after step {k}");
        let mut e32 = [Default::default(); n7::ENDS];
        let mut e64 = [Default::default(); n7::ENDS];
        n7::f32::centreline(&a, &mut e32);
        n7::centreline(&c, &mut e64);
        for (x, y) in e32.iter().zip(&e64) {
            let x: superhelix_generated::kernels::pose::Pose<f32> = *x;
            worst = worst.max((x.position.map(f64::from) - y.position).norm() / LENGTH);
        }
        // until the energy balance first scales a step down, the two differ by round-off
        if ca.energy_limited == 0 && cc.energy_limited == 0 {
            worst_plain = worst;
            plain_steps = k + 1;
        }
    }
    assert_eq!(ca, cb);
    assert_eq!(ca, cc, "the f32 and f64 steps split alike");
    let eps = f32::EPSILON as f64;
    eprintln!(
        "n7::f32 vs n7: largest centreline distance {worst:.2e} L = {:.1} f32 epsilons; over the {plain_steps} steps before the first energy-limited one {:.1} epsilons",
        worst / eps,
        worst_plain / eps
    );
    // before the energy balance parts them, round-off: measured 1.6 ε over the first 5
    // steps; bound 16 ε
    assert!(
        plain_steps >= 3,
        "{plain_steps} steps before the first limit"
    );
    assert!(
        worst_plain <= 16.0 * eps,
        "{worst_plain:e} L before any limit"
    );
    assert!(worst <= 5e-4, "{worst:e} L");
}
