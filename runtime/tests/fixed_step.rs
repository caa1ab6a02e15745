//! The no_std checked fixed-N step of `superhelix-kernels` against the runtime's step of
//! the same strand (linearly implicit Euler, generated kernels, the same checks after the
//! fact): the two compute the same steps and must agree to round-off.

mod common;

use common::{preset_strand, setup};
use nalgebra::Vector3;
use superhelix_generated::ClosedForm;
use superhelix_kernels::field_split::FieldRule;
use superhelix_kernels::fixed::{self, Effects, FixedStrand, FixedWorkspace, StepCounts};
use superhelix_runtime::config::{FieldStiffness, SimulationConfig};
use superhelix_runtime::model::material::Preset;
use superhelix_runtime::model::strand::Strand;
use superhelix_runtime::solver::embedded::fixed_params;
use superhelix_runtime::{HeadMotion, Simulation};

const N: usize = 5;
const D: usize = 15;
const E: usize = 6;
const B: usize = 7;

/// The fixed-N strand of a runtime strand.
fn fixed_strand(s: &Strand) -> FixedStrand<N, D, B> {
    FixedStrand::at_rest(fixed_params::<N, D>(s).expect("a strand of N elements"))
}

/// Steps the runtime and the fixed strand (starting from the fixed strand's q) side by
/// side for `steps` steps of 1/30 s; the largest |Δq| relative to max(|q|, 1) over the
/// run, and both sides' counters.
fn compare(
    strand: Strand,
    fixed: FixedStrand<N, D, B>,
    gravity: Option<Vector3<f64>>,
    head: HeadMotion,
    steps: usize,
) -> (f64, String) {
    compare_by(
        strand,
        fixed,
        gravity,
        head,
        steps,
        FieldStiffness::default(),
    )
}

/// [`compare`] with the field stiffness taken by `rule` on both sides.
fn compare_by(
    strand: Strand,
    mut fixed: FixedStrand<N, D, B>,
    gravity: Option<Vector3<f64>>,
    head: HeadMotion,
    steps: usize,
    rule: FieldStiffness,
) -> (f64, String) {
    let dt = 1.0 / 30.0;
    let config = SimulationConfig {
        dt,
        duration: steps as f64 * dt,
        field_stiffness: rule,
        ..Default::default()
    };
    let factory = superhelix_runtime::kernels::closed_form::kernel_factory();
    let head_moves = head != HeadMotion::Still;
    let mut s = setup(vec![strand], config, gravity, head.clone());
    s.strands[0].q0 = fixed.q.to_vec();
    let mut sim = Simulation::new(s, Some(factory)).expect("valid setup");
    let mut ws = Box::new(FixedWorkspace::<N, D, E>::new());
    ws.set_field_rule(match rule {
        FieldStiffness::Split => FieldRule::Split,
        _ => FieldRule::Projected,
    });
    let effects = Effects {
        gravity,
        head_moves,
    };
    let mut counts = StepCounts::default();
    let mut worst: f64 = 0.0;
    for k in 0..steps {
        sim.step().expect("runtime step");
        let t = k as f64 * dt;
        fixed::step(
            &ClosedForm,
            &mut fixed,
            &head,
            &effects,
            t,
            dt,
            &mut ws,
            &mut counts,
        )
        .expect("fixed step");
        let q = sim.q(0);
        let scale = q.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1.0);
        for (a, b) in q.iter().zip(&fixed.q) {
            worst = worst.max((a - b).abs() / scale);
        }
    }
    (
        worst,
        format!("runtime {:?}; fixed {counts:?}", sim.stats()),
    )
}

#[test]
fn elastic_release_without_gravity_matches_the_runtime() {
    // a wavy strand released from 3 % beyond its natural curvature: elasticity, friction
    // and drag, no field stiffness to project
    let strand = preset_strand(Preset::Wavy, N, 0.25, Vector3::new(0.0, 0.0, -1.0));
    let mut fixed = fixed_strand(&strand);
    for x in fixed.q.iter_mut() {
        *x *= 1.03;
    }
    let (worst, stats) = compare(strand, fixed, None, HeadMotion::Still, 30);
    eprintln!("elastic release: {worst:.3e}; {stats}");
    assert!(worst <= 1e-12, "largest relative |Δq| {worst:.3e}; {stats}");
}

#[test]
fn released_straight_strand_splits_its_steps_as_the_runtime_does() {
    // released from straight: the first steps rotate elements by more than 0.2 and are
    // split, as in the runtime
    let strand = preset_strand(Preset::Wavy, N, 0.25, Vector3::new(0.0, 0.0, -1.0));
    let mut fixed = fixed_strand(&strand);
    fixed.q = [0.0; D];
    let (worst, stats) = compare(strand, fixed, None, HeadMotion::Still, 30);
    eprintln!("straight release: {worst:.3e}; {stats}");
    assert!(worst <= 1e-12, "largest relative |Δq| {worst:.3e}; {stats}");
}

#[test]
fn hanging_strand_under_gravity_matches_the_runtime() {
    let strand = preset_strand(Preset::Curly, N, 0.2, Vector3::new(0.3, 0.0, -1.0));
    let fixed = fixed_strand(&strand);
    let (worst, stats) = compare(
        strand,
        fixed,
        Some(Vector3::new(0.0, 0.0, -9.81)),
        HeadMotion::Still,
        30,
    );
    eprintln!("hanging: {worst:.3e}; {stats}");
    assert!(worst <= 1e-12, "largest relative |Δq| {worst:.3e}; {stats}");
}

/// The head shaking about the vertical by ±30° at 2 Hz.
fn shaking_head() -> HeadMotion {
    HeadMotion::Oscillate {
        axis: Vector3::z(),
        amplitude: 30f64.to_radians(),
        frequency_hz: 2.0,
        center: Vector3::zeros(),
    }
}

#[test]
fn strand_on_a_shaking_head_matches_the_runtime() {
    let strand = preset_strand(Preset::Fuzzy, N, 0.25, Vector3::new(1.0, 0.0, -1.0));
    let fixed = fixed_strand(&strand);
    let head = shaking_head();
    let (worst, stats) = compare(strand, fixed, Some(Vector3::new(0.0, 0.0, -9.81)), head, 60);
    eprintln!("shaking: {worst:.3e}; {stats}");
    assert!(worst <= 1e-12, "largest relative |Δq| {worst:.3e}; {stats}");
}

#[test]
fn both_field_stiffness_rules_take_the_same_steps_on_both_engines() {
    // field_stiffness = "split" (superhelix_kernels::field_split, the default) and
    // "projected": the same rule, shared, on both sides; a hanging curly strand and a
    // fuzzy one on a shaking head, the counters showing which rule took the solves
    for rule in [FieldStiffness::Split, FieldStiffness::Projected] {
        let strand = preset_strand(Preset::Curly, N, 0.2, Vector3::new(0.3, 0.0, -1.0));
        let fixed = fixed_strand(&strand);
        let gravity = Some(Vector3::new(0.0, 0.0, -9.81));
        let (worst, stats) = compare_by(strand, fixed, gravity, HeadMotion::Still, 30, rule);
        eprintln!("hanging, {}: {worst:.3e}; {stats}", rule.name());
        assert!(worst <= 1e-12, "largest relative |Δq| {worst:.3e}; {stats}");
        let (taken, other) = match rule {
            FieldStiffness::Split => ("field_split: ", "field_projected: "),
            _ => ("field_projected: ", "field_split: "),
        };
        assert!(
            stats.contains(taken)
                && !stats.contains(&format!("{taken}0,"))
                && stats.contains(&format!("{other}0,")),
            "{stats}"
        );
        let strand = preset_strand(Preset::Fuzzy, N, 0.25, Vector3::new(1.0, 0.0, -1.0));
        let fixed = fixed_strand(&strand);
        let head = shaking_head();
        let (worst, stats) = compare_by(strand, fixed, gravity, head, 60, rule);
        eprintln!("shaking, {}: {worst:.3e}; {stats}", rule.name());
        assert!(worst <= 1e-12, "largest relative |Δq| {worst:.3e}; {stats}");
    }
}
