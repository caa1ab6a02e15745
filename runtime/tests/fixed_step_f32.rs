//! The f32 fixed-N step against the f64 one (N = 5 and N = 20, the checked step
//! `fixed::step` on the generated closed forms, dt = 1/30 s): the same strand rounded to
//! f32 and stepped side by side, the centrelines compared at every step.
//!
//! Reported per case: the largest distance between the two centrelines (the N + 1
//! element ends) relative to the strand's length, the counters of the checks after the
//! fact (splits, energy rejections and limits) on both sides, and the energies the two
//! runs end with. Print them with
//!
//! `cargo test --release -p superhelix-runtime --test fixed_step_f32 -- --nocapture`

mod common;

use common::preset_strand;
use nalgebra::Vector3;
use superhelix_generated::ClosedForm;
use superhelix_kernels::energy::StateEnergy;
use superhelix_kernels::fixed::{
    self, Effects, FixedStrand, FixedWorkspace, HeadTrajectory, StepCounts, StillHead,
};
use superhelix_kernels::pose::Pose;
use superhelix_kernels::Float;
use superhelix_runtime::model::material::Preset;
use superhelix_runtime::solver::embedded::fixed_params;
use superhelix_runtime::HeadMotion;

/// Time step, seconds.
const DT: f64 = 1.0 / 30.0;

/// f32's machine epsilon, 2⁻²³ ≈ 1.19e-7.
const EPS32: f64 = f32::EPSILON as f64;

/// What a side-by-side run measured.
#[derive(Debug)]
struct Outcome {
    /// Largest |y32 − y64| over the element ends and the steps, relative to L.
    deviation: f64,
    /// Largest displacement of an element end from where it started, relative to L:
    /// f64 and f32.
    displacement: (f64, f64),
    counts64: StepCounts,
    counts32: StepCounts,
    /// The energy E = T + U + V of the last state, J: f64 and f32.
    energy: (f64, f64),
    /// The energy scale of the last state (T + U + |c0| L²), J (f64).
    scale: f64,
    /// Largest round-off of the f32 energy measurement: |E₃₂ − E₆₄| of the f32 states
    /// (E₆₄ of the state widened to f64) over the magnitudes of its parts,
    /// |T| + |U| + |V| + S, in f32 epsilons.
    energy_roundoff: f64,
}

fn ends<T: Float, const N: usize, const D: usize, const E: usize, const B: usize>(
    s: &FixedStrand<N, D, B, T>,
) -> [Vector3<f64>; E]
where
    ClosedForm: superhelix_kernels::strand_terms::MomentSource<T>,
{
    let mut ends = [Pose::<T>::default(); E];
    fixed::centreline(&ClosedForm, s, &mut ends);
    ends.map(|p| p.position.map(T::as_f64))
}

fn total<T: Float>(e: &Option<StateEnergy<T>>) -> f64 {
    e.map_or(f64::NAN, |e| e.total().as_f64())
}

/// Steps `s64` and its f32 copy for `steps` steps of [`DT`] with the head moving as
/// `head`, comparing their centrelines after every step.
fn side_by_side<const N: usize, const D: usize, const E: usize, const B: usize>(
    mut s64: FixedStrand<N, D, B>,
    head: &dyn HeadTrajectory,
    effects: Effects,
    steps: usize,
) -> Outcome {
    let mut s32: FixedStrand<N, D, B, f32> = s64.cast();
    let mut ws64 = Box::new(FixedWorkspace::<N, D, E>::new());
    let mut ws32 = Box::new(FixedWorkspace::<N, D, E, f32>::new());
    let (mut counts64, mut counts32) = (StepCounts::default(), StepCounts::default());
    let length = s64.params.length();
    let (start64, start32) = (ends::<_, N, D, E, B>(&s64), ends::<_, N, D, E, B>(&s32));
    let mut out = Outcome {
        deviation: 0.0,
        displacement: (0.0, 0.0),
        counts64,
        counts32,
        energy: (0.0, 0.0),
        scale: 0.0,
        energy_roundoff: 0.0,
    };
    let mut ws_wide = Box::new(FixedWorkspace::<N, D, E>::new());
    let largest = |a: &[Vector3<f64>; E], b: &[Vector3<f64>; E]| {
        a.iter()
            .zip(b)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).norm()))
            / length
    };
    for k in 0..steps {
        let t = k as f64 * DT;
        fixed::step(
            &ClosedForm,
            &mut s64,
            head,
            &effects,
            t,
            DT,
            &mut ws64,
            &mut counts64,
        )
        .unwrap_or_else(|e| panic!("f64 step {k}: {e}"));
        fixed::step(
            &ClosedForm,
            &mut s32,
            head,
            &effects,
            t,
            DT,
            &mut ws32,
            &mut counts32,
        )
        .unwrap_or_else(|e| panic!("f32 step {k}: {e}"));
        assert!(
            s32.q.iter().chain(&s32.v).all(|x| x.is_finite()),
            "f32 step {k}: non-finite state"
        );
        let (e64, e32) = (ends::<_, N, D, E, B>(&s64), ends::<_, N, D, E, B>(&s32));
        let at = head.state(t + DT);
        let narrow = fixed::energy(&ClosedForm, &s32, &effects, &at, t + DT, &mut ws32);
        let wide = fixed::energy(
            &ClosedForm,
            &s32.cast::<f64>(),
            &effects,
            &at,
            t + DT,
            &mut ws_wide,
        );
        let parts = wide.kinetic.abs() + wide.elastic.abs() + wide.potential.abs() + wide.scale;
        out.energy_roundoff = out
            .energy_roundoff
            .max((narrow.total() as f64 - wide.total()).abs() / parts / EPS32);
        out.deviation = out.deviation.max(largest(&e32, &e64));
        out.displacement.0 = out.displacement.0.max(largest(&e64, &start64));
        out.displacement.1 = out.displacement.1.max(largest(&e32, &start32));
    }
    out.counts64 = counts64;
    out.counts32 = counts32;
    out.energy = (total(&s64.last_energy), total(&s32.last_energy));
    out.scale = s64.last_energy.map_or(f64::NAN, |e| e.scale);
    out
}

fn gravity() -> Effects {
    Effects {
        gravity: Some(Vector3::new(0.0, 0.0, -9.81)),
        head_moves: false,
    }
}

/// A strand of `preset` (N elements, `length`, rooted along `direction`) in its natural
/// shape.
fn strand<const N: usize, const D: usize, const B: usize>(
    preset: Preset,
    length: f64,
    direction: Vector3<f64>,
) -> FixedStrand<N, D, B> {
    let s = preset_strand(preset, N, length, direction);
    FixedStrand::at_rest(fixed_params::<N, D>(&s).expect("a strand of N elements"))
}

/// The curly strand hanging at rest under gravity: its static equilibrium, reached in
/// f64 by 20 s of steps with ten times the air drag (the drag does not move the
/// equilibrium, only the way there).
fn hanging_at_rest<const N: usize, const D: usize, const E: usize, const B: usize>(
) -> FixedStrand<N, D, B> {
    let mut s = strand(Preset::Curly, 0.2, Vector3::new(0.3, 0.0, -1.0));
    let drag = s.params.air_drag;
    s.params.air_drag = drag * 10.0;
    let mut ws = Box::new(FixedWorkspace::<N, D, E>::new());
    let mut counts = StepCounts::default();
    for k in 0..600 {
        fixed::step(
            &ClosedForm,
            &mut s,
            &StillHead,
            &gravity(),
            k as f64 * DT,
            DT,
            &mut ws,
            &mut counts,
        )
        .expect("settling step");
    }
    s.params.air_drag = drag;
    let v = s.v;
    s.set_state(&s.q.clone(), &[0.0; D]);
    let speed = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!(speed < 1e-6, "not settled: |q̇| up to {speed:e} rad/(m·s)");
    s
}

fn report(case: &str, o: &Outcome) {
    eprintln!(
        "{case}: f32 vs f64 centreline {:.2e} L ({:.1} eps32); displacement f64 {:.2e} L, \
         f32 {:.2e} L; E f64 {:.6e} J, f32 {:.6e} J (ΔE {:.1e} of the scale {:.3e} J); \
         f32 energy round-off {:.1} eps32\n  \
         counts f64 {:?}\n  counts f32 {:?}",
        o.deviation,
        o.deviation / EPS32,
        o.displacement.0,
        o.displacement.1,
        o.energy.0,
        o.energy.1,
        (o.energy.1 - o.energy.0).abs() / o.scale,
        o.scale,
        o.energy_roundoff,
        o.counts64,
        o.counts32,
    );
}

/// The checks common to every case: the f32 centreline within `bound` f32 epsilons of
/// the strand's length of the f64 one; the checks after the fact counting as in f64
/// (the same splits within 10 % and two, the same energy rejections and limits within
/// two, no substep accepted unbalanced); the final energies within 8 epsilons of the
/// energy scale (measured: under 0.1); the round-off of the f32 energy measurement within
/// 8 epsilons of its parts (measured: up to 1.4).
fn check(case: &str, o: &Outcome, bound: f64) {
    report(case, o);
    assert!(
        o.deviation <= bound * EPS32,
        "{case}: f32 vs f64 {:e} L = {:.1} eps32 > {bound} eps32",
        o.deviation,
        o.deviation / EPS32
    );
    let (a, b) = (&o.counts64, &o.counts32);
    let near = |x: usize, y: usize, slack: usize| x.abs_diff(y) <= slack;
    assert!(
        near(a.substeps, b.substeps, a.substeps / 10 + 2)
            && near(a.energy_rejected, b.energy_rejected, 2)
            && near(a.energy_limited, b.energy_limited, 2)
            && b.energy_unbalanced == 0,
        "{case}: counts f64 {a:?}, f32 {b:?}"
    );
    let de = (o.energy.1 - o.energy.0).abs() / o.scale;
    assert!(de <= 8.0 * EPS32, "{case}: ΔE {de:e} of the scale");
    // the f32 energy balance allows 64 epsilons (energy::ROUNDOFF_F32) for this
    assert!(
        o.energy_roundoff <= 8.0,
        "{case}: f32 energy round-off {:.1} eps32",
        o.energy_roundoff
    );
}

// The bounds, in f32 epsilons (2⁻²³ ≈ 1.2e-7) of the length L. Rounding a state to f32
// moves its centreline by a few epsilons of L (each element end sums the N elements
// before it, each rounded), and a step from rest adds round-off of the same order: at
// rest the two centrelines stay within 0.3 (N = 5) and 0.9 (N = 20) epsilons of each
// other and the f32 strand moves by 0.005 and 0.7 epsilons in 1 s; the bounds are 4 and
// 2. Along a transient the round-off of the state is carried and amplified by the
// motion: a straight strand released horizontally (1 s, 198 split substeps at N = 5)
// ends 16.3 (N = 5) and 6.1 (N = 20) epsilons from the f64 strand, bound 128; on the
// shaking head (2 s) 0.7 and 3.0, bound 32; on a head that turns at 180°/s and stops
// within 0.1 s (2 s, four presets) up to 8.6, bound 64.

#[test]
fn hanging_strand_at_rest_stays_at_rest_in_f32() {
    for (n, o) in [
        (
            5,
            side_by_side::<5, 15, 6, 7>(
                hanging_at_rest::<5, 15, 6, 7>(),
                &StillHead,
                gravity(),
                30,
            ),
        ),
        (
            20,
            side_by_side::<20, 60, 21, 30>(
                hanging_at_rest::<20, 60, 21, 30>(),
                &StillHead,
                gravity(),
                30,
            ),
        ),
    ] {
        let case = format!("(a) N = {n}, hanging at rest, 1 s");
        check(&case, &o, 4.0);
        assert!(
            o.displacement.0 < 1e-12,
            "{case}: f64 moved {:e} L",
            o.displacement.0
        );
        assert!(
            o.displacement.1 <= 2.0 * EPS32,
            "{case}: f32 moved {:e} L",
            o.displacement.1
        );
    }
}

/// A straight curly strand released horizontally under gravity, 1 s.
fn released<const N: usize, const D: usize, const E: usize, const B: usize>() -> Outcome {
    let mut s = strand::<N, D, B>(Preset::Curly, 0.2, Vector3::new(1.0, 0.0, 0.0));
    s.q = [0.0; D];
    side_by_side::<N, D, E, B>(s, &StillHead, gravity(), 30)
}

#[test]
fn straight_strand_released_horizontally_in_f32() {
    for (n, o) in [
        (5, released::<5, 15, 6, 7>()),
        (20, released::<20, 60, 21, 30>()),
    ] {
        let case = format!("(b) N = {n}, straight curly strand released horizontally, 1 s");
        check(&case, &o, 128.0);
        assert!(o.displacement.1 > 0.5, "{case}: the strand did not fall");
    }
}

/// A curly strand on a head shaking at 2 Hz by ±30° about the vertical, 2 s.
fn shaking<const N: usize, const D: usize, const E: usize, const B: usize>() -> Outcome {
    let s = strand::<N, D, B>(Preset::Curly, 0.25, Vector3::new(1.0, 0.0, -1.0));
    let head = HeadMotion::Oscillate {
        axis: Vector3::z(),
        amplitude: 30f64.to_radians(),
        frequency_hz: 2.0,
        center: Vector3::zeros(),
    };
    let effects = Effects {
        head_moves: true,
        ..gravity()
    };
    side_by_side::<N, D, E, B>(s, &head, effects, 60)
}

#[test]
fn strand_on_a_shaking_head_in_f32() {
    for (n, o) in [
        (5, shaking::<5, 15, 6, 7>()),
        (20, shaking::<20, 60, 21, 30>()),
    ] {
        let case = format!("(c) N = {n}, curly strand on a head shaking at 2 Hz by ±30°, 2 s");
        check(&case, &o, 32.0);
        assert!(o.displacement.1 > 1e-2, "{case}: the strand did not move");
    }
}

/// A strand on a head turning at 180°/s about the vertical that stops within 0.1 s at
/// t = 0.5 s (the scene `sudden-stop`), 2 s.
fn sudden_stop<const N: usize, const D: usize, const E: usize, const B: usize>(
    preset: Preset,
    length: f64,
) -> Outcome {
    let s = strand::<N, D, B>(preset, length, Vector3::new(1.0, 0.0, -1.0));
    let head = HeadMotion::SuddenStop {
        axis: Vector3::z(),
        angular_speed: 180f64.to_radians(),
        stop_time: 0.5,
        stop_duration: 0.1,
        center: Vector3::zeros(),
    };
    let effects = Effects {
        head_moves: true,
        ..gravity()
    };
    side_by_side::<N, D, E, B>(s, &head, effects, 60)
}

#[test]
fn strands_on_a_head_that_stops_suddenly_in_f32() {
    for p in [Preset::Smooth, Preset::Wavy, Preset::Curly, Preset::Fuzzy] {
        for (n, o) in [
            (5, sudden_stop::<5, 15, 6, 7>(p, 0.3)),
            (20, sudden_stop::<20, 60, 21, 30>(p, 0.3)),
        ] {
            let case = format!("(d) N = {n}, {p:?} strand on a head stopping suddenly, 2 s");
            check(&case, &o, 64.0);
        }
    }
}

/// What a strand and a workspace take in f32 against f64 (docs/embedding.md, "Memory"):
/// about half (the time of the energy a strand keeps stays f64, pivot indices `usize`).
#[test]
fn f32_strand_and_workspace_take_about_half_the_memory() {
    fn sizes<const N: usize, const D: usize, const E: usize, const B: usize>() -> [usize; 4] {
        [
            FixedStrand::<N, D, B>::BYTES,
            FixedStrand::<N, D, B, f32>::BYTES,
            FixedWorkspace::<N, D, E>::BYTES,
            FixedWorkspace::<N, D, E, f32>::BYTES,
        ]
    }
    for (n, [s64, s32, w64, w32]) in [
        (5, sizes::<5, 15, 6, 7>()),
        (10, sizes::<10, 30, 11, 15>()),
        (20, sizes::<20, 60, 21, 30>()),
    ] {
        eprintln!("N = {n}: strand {s64} B (f64), {s32} B (f32); workspace {w64} B, {w32} B");
        // half, but for the f64 time of the kept energy and the pivots' indices
        assert!(100 * s32 <= 52 * s64 && 100 * w32 <= 52 * w64, "N = {n}");
    }
}

/// The error-controlled step in f32 (`fixed::step_to_tolerance`): the straight curly
/// strand released horizontally, 1 s at τ = 1e-3, against the same in f64. Both choose
/// their own steps; f32's round-off (~1e-7) is far below τ, so they take the same steps
/// and stay within τ/10 of each other (measured: 9.6e-6 L apart at most, the same 1176
/// steps and 13 rejections). A tolerance under f32's floor
/// (`min_tolerance::<f32>()`, 1000 ε) is refused, in f64 it is taken.
#[test]
fn error_controlled_step_in_f32() {
    use fixed::{StepHistory, ToleranceReport};
    const N: usize = 5;
    const D: usize = 15;
    const E: usize = 6;
    const B: usize = 7;
    let tolerance = 1e-3;
    let mut s64 = strand::<N, D, B>(Preset::Curly, 0.2, Vector3::new(1.0, 0.0, 0.0));
    s64.q = [0.0; D];
    let mut s32: FixedStrand<N, D, B, f32> = s64.cast();
    let (mut h64, mut h32) = (
        StepHistory::<D>::default(),
        StepHistory::<D, f32>::default(),
    );
    let (mut r64, mut r32) = (ToleranceReport::default(), ToleranceReport::default());
    let mut ws64 = Box::new(FixedWorkspace::<N, D, E>::new());
    let mut ws32 = Box::new(FixedWorkspace::<N, D, E, f32>::new());
    let effects = gravity();
    let length = s64.params.length();
    let mut deviation = 0.0f64;
    for k in 0..30 {
        let t = k as f64 * DT;
        fixed::step_to_tolerance(
            &ClosedForm,
            &mut s64,
            &mut h64,
            &StillHead,
            &effects,
            t,
            DT,
            tolerance,
            &mut ws64,
            &mut r64,
        )
        .expect("f64 step");
        fixed::step_to_tolerance(
            &ClosedForm,
            &mut s32,
            &mut h32,
            &StillHead,
            &effects,
            t,
            DT,
            tolerance,
            &mut ws32,
            &mut r32,
        )
        .expect("f32 step");
        let (a, b) = (ends::<f64, N, D, E, B>(&s64), ends::<f32, N, D, E, B>(&s32));
        for (x, y) in a.iter().zip(&b) {
            deviation = deviation.max((x - y).norm() / length);
        }
    }
    eprintln!(
        "f32 at τ = 1e-3: {deviation:.2e} L from f64; steps {} (f64 {}), rejected {} ({}), largest error {:.2e} ({:.2e})",
        r32.steps, r64.steps, r32.rejected, r64.rejected, r32.largest_error, r64.largest_error
    );
    assert!(deviation <= 0.1 * tolerance, "{deviation:e} L apart");
    assert!(r32.largest_error <= tolerance && r64.largest_error <= tolerance);
    assert!(
        r32.steps > 30 && r32.steps < 2 * r64.steps,
        "{r32:?} {r64:?}"
    );
    // the floor
    let floor = fixed::min_tolerance::<f32>();
    assert!((floor / (1e3 * EPS32) - 1.0).abs() < 1e-12);
    let below = fixed::step_to_tolerance(
        &ClosedForm,
        &mut s32,
        &mut h32,
        &StillHead,
        &effects,
        1.0,
        DT,
        1e-5,
        &mut ws32,
        &mut r32,
    );
    assert_eq!(below.err(), Some(fixed::StepError::Tolerance));
    fixed::step_to_tolerance(
        &ClosedForm,
        &mut s64,
        &mut h64,
        &StillHead,
        &effects,
        1.0,
        DT,
        1e-5,
        &mut ws64,
        &mut r64,
    )
    .expect("f64 takes 1e-5");
}
