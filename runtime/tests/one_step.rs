//! One step, two storages: the checked step of `superhelix-kernels` on a fixed-N strand
//! (arrays of literal size, what the generated modules and the embedded engine step)
//! and on a runtime-N strand (`storage::heap`, vectors of any N) is one function. The
//! same strand steps to the same bits on both; a strand of an N without a generated
//! module steps as the runtime engine steps it; and with the moments by quadrature (the
//! generic reference kernel) instead of the closed forms the centrelines agree to far
//! below 1e-9 L over a second.

mod common;

use common::preset_strand;
use nalgebra::Vector3;
use superhelix_generated::ClosedForm;
use superhelix_kernels::fixed::{self, Effects, FixedStrand, FixedWorkspace, StepCounts};
use superhelix_kernels::pose::Pose;
use superhelix_kernels::storage::heap::{self, HeapStrand, HeapWorkspace};
use superhelix_kernels::strand_terms::{element_ends, MomentSource};
use superhelix_runtime::config::SimulationConfig;
use superhelix_runtime::kernels::moments::kernel::QuadratureMoments;
use superhelix_runtime::model::material::Preset;
use superhelix_runtime::solver::embedded::{fixed_params, heap_strand};
use superhelix_runtime::{HeadMotion, Simulation};

const N: usize = 5;
const D: usize = 15;
const E: usize = 6;
const B: usize = 7;
const DT: f64 = 1.0 / 30.0;

/// The head shaking about the vertical by ±30° at 2 Hz.
fn shaking_head() -> HeadMotion {
    HeadMotion::Oscillate {
        axis: Vector3::z(),
        amplitude: 30f64.to_radians(),
        frequency_hz: 2.0,
        center: Vector3::zeros(),
    }
}

fn gravity() -> Option<Vector3<f64>> {
    Some(Vector3::new(0.0, 0.0, -9.81))
}

/// The centreline of a strand (its element ends) from `source`.
fn centreline<S: MomentSource>(source: &S, strand: &HeapStrand) -> Vec<Vector3<f64>> {
    let mut ends = vec![Pose::default(); strand.elements() + 1];
    element_ends(source, &strand.params().shape(), &strand.q, &mut ends);
    ends.iter().map(|p| p.position).collect()
}

#[test]
fn a_strand_steps_to_the_same_bits_on_fixed_and_runtime_n_storage() {
    // a fuzzy strand released from straight on a shaking head under gravity for one
    // second: projections, split steps and energy checks happen on both
    let strand = preset_strand(Preset::Fuzzy, N, 0.25, Vector3::new(1.0, 0.0, -1.0));
    let mut fixed: FixedStrand<N, D, B> =
        FixedStrand::at_rest(fixed_params::<N, D>(&strand).expect("N elements"));
    fixed.set_state(&[0.0; D], &[0.0; D]);
    let mut heap = HeapStrand::from_params(&fixed.params.view());
    assert!(heap.set_state(&[0.0; D], &[0.0; D]));
    let head = shaking_head();
    let effects = Effects {
        gravity: gravity(),
        head_moves: true,
    };
    let mut fws = Box::new(FixedWorkspace::<N, D, E>::new());
    let mut hws = HeapWorkspace::new();
    let (mut fc, mut hc) = (StepCounts::default(), StepCounts::default());
    for k in 0..30 {
        let t = k as f64 * DT;
        let a = fixed::step(
            &ClosedForm,
            &mut fixed,
            &head,
            &effects,
            t,
            DT,
            &mut fws,
            &mut fc,
        )
        .expect("fixed-N step");
        let b = heap::step(
            &mut &ClosedForm,
            &mut heap,
            &head,
            &effects,
            t,
            DT,
            &mut hws,
            &mut hc,
            None,
        )
        .expect("runtime-N step");
        assert_eq!(a, b, "step {k}");
        assert_eq!(&fixed.q[..], &heap.q[..], "q after step {k}");
        assert_eq!(&fixed.v[..], &heap.v[..], "q̇ after step {k}");
    }
    assert_eq!(fc, hc);
    // the run exercised the checks (not a quiet strand that any two steps agree on)
    assert!(
        fc.substeps > 0 && fc.field_projected + fc.field_split > 0,
        "{fc:?}"
    );
    // the error-controlled step too
    let mut fh = fixed::StepHistory::<D>::default();
    let mut hh = heap::HeapHistory::default();
    let (mut fr, mut hr) = (
        fixed::ToleranceReport::default(),
        fixed::ToleranceReport::default(),
    );
    for k in 30..45 {
        let t = k as f64 * DT;
        fixed::step_to_tolerance(
            &ClosedForm,
            &mut fixed,
            &mut fh,
            &head,
            &effects,
            t,
            DT,
            1e-4,
            &mut fws,
            &mut fr,
        )
        .expect("fixed-N step to tolerance");
        heap::step_to_tolerance(
            &mut &ClosedForm,
            &mut heap,
            &mut hh,
            &head,
            &effects,
            t,
            DT,
            1e-4,
            &mut hws,
            &mut hr,
        )
        .expect("runtime-N step to tolerance");
        assert_eq!(&fixed.q[..], &heap.q[..], "q after step {k}");
    }
    assert_eq!(fr, hr);
    assert!(fr.steps > 15, "{fr:?}");
}

#[test]
fn a_strand_of_any_n_steps_on_runtime_n_storage_as_the_runtime_engine_steps_it() {
    // N = 7 has no generated module: the runtime-N storage steps it, with the closed forms
    // at any N, as the runtime engine (the yardstick) does
    const M: usize = 7;
    assert!(!superhelix_generated::fixed::SIZES.contains(&M));
    let strand = preset_strand(Preset::Curly, M, 0.25, Vector3::new(1.0, 0.0, -1.0));
    let mut heap = heap_strand(&strand);
    // released from straight: its first steps are split
    let straight = vec![0.0; 3 * M];
    assert!(heap.set_state(&straight, &straight));
    let head = shaking_head();
    let config = SimulationConfig {
        dt: DT,
        duration: 1.0,
        ..Default::default()
    };
    let mut s = common::setup(vec![strand], config, gravity(), head.clone());
    s.strands[0].q0 = heap.q.clone();
    let factory = superhelix_runtime::kernels::closed_form::kernel_factory();
    let mut sim = Simulation::new(s, Some(factory)).expect("valid setup");
    let effects = Effects {
        gravity: gravity(),
        head_moves: true,
    };
    let mut ws = HeapWorkspace::new();
    let mut counts = StepCounts::default();
    let mut worst: f64 = 0.0;
    for k in 0..30 {
        sim.step().expect("runtime step");
        let t = k as f64 * DT;
        heap::step(
            &mut &ClosedForm,
            &mut heap,
            &head,
            &effects,
            t,
            DT,
            &mut ws,
            &mut counts,
            None,
        )
        .expect("runtime-N step");
        let q = sim.q(0);
        let scale = q.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1.0);
        for (a, b) in q.iter().zip(&heap.q) {
            worst = worst.max((a - b).abs() / scale);
        }
    }
    eprintln!("N = 7: {worst:.3e}; {counts:?}; runtime {:?}", sim.stats());
    // the same operations in the same order as the fixed-N step, which the runtime's
    // step matches to 1e-12 (runtime/tests/fixed_step.rs)
    assert!(worst <= 1e-12, "largest relative |Δq| {worst:.3e}");
    assert!(counts.substeps > 0, "{counts:?}");
}

#[test]
fn the_fixed_n_step_and_the_runtime_n_path_with_generic_kernels_agree_over_a_second() {
    // the same scene: the fixed-N step with the generated closed forms against the
    // runtime-N storage of the same step with a generic kernel (no generated code): the
    // element moments by Gauss–Legendre quadrature, and the runtime's generic kernel
    // (quadrature over the whole strand), one second on a shaking head
    use superhelix_runtime::kernels::kernel::StrandTerms;
    use superhelix_runtime::kernels::step_terms::KernelTerms;
    use superhelix_runtime::kernels::{GenericKernel, QuadratureRule};
    let strand = preset_strand(Preset::Wavy, N, 0.25, Vector3::new(1.0, 0.0, -1.0));
    let length = 0.25;
    let mut fixed: FixedStrand<N, D, B> =
        FixedStrand::at_rest(fixed_params::<N, D>(&strand).expect("N elements"));
    let (mut by_moments, mut by_kernel) = (heap_strand(&strand), heap_strand(&strand));
    let mut kernel = GenericKernel::new(strand.geometry.clone(), QuadratureRule::default());
    let (mut terms, mut flat) = (StrandTerms::new(D), Vec::new());
    let head = shaking_head();
    let effects = Effects {
        gravity: gravity(),
        head_moves: true,
    };
    let mut fws = Box::new(FixedWorkspace::<N, D, E>::new());
    let (mut mws, mut kws) = (HeapWorkspace::new(), HeapWorkspace::new());
    let mut counts = [StepCounts::default(); 3];
    let quadrature = QuadratureMoments::default();
    let (mut worst_moments, mut worst_kernel, mut travel): (f64, f64, f64) = (0.0, 0.0, 0.0);
    let start = centreline(&ClosedForm, &by_moments);
    for k in 0..30 {
        let t = k as f64 * DT;
        let [fc, mc, kc] = &mut counts;
        fixed::step(
            &ClosedForm,
            &mut fixed,
            &head,
            &effects,
            t,
            DT,
            &mut fws,
            fc,
        )
        .expect("fixed-N step");
        heap::step(
            &mut &quadrature,
            &mut by_moments,
            &head,
            &effects,
            t,
            DT,
            &mut mws,
            mc,
            None,
        )
        .expect("runtime-N step, moments by quadrature");
        let mut source = KernelTerms::new(&mut kernel, &mut terms, &mut flat);
        heap::step(
            &mut source,
            &mut by_kernel,
            &head,
            &effects,
            t,
            DT,
            &mut kws,
            kc,
            None,
        )
        .expect("runtime-N step, generic kernel");
        let mut as_heap = HeapStrand::from_params(&fixed.params.view());
        as_heap.q.copy_from_slice(&fixed.q);
        let a = centreline(&ClosedForm, &as_heap);
        let (b, c) = (
            centreline(&quadrature, &by_moments),
            centreline(&quadrature, &by_kernel),
        );
        for (((x, y), z), s) in a.iter().zip(&b).zip(&c).zip(&start) {
            worst_moments = worst_moments.max((x - y).norm() / length);
            worst_kernel = worst_kernel.max((x - z).norm() / length);
            travel = travel.max((x - s).norm() / length);
        }
    }
    eprintln!(
        "fixed-N closed forms vs runtime-N over 1 s: quadrature moments {worst_moments:.3e} L, \
         generic kernel {worst_kernel:.3e} L (the tip moved {travel:.2} L); {counts:?}"
    );
    assert!(travel > 0.05, "the strand moved {travel:.3} L");
    assert!(
        worst_moments <= 1e-9,
        "moments: {worst_moments:.3e} L apart"
    );
    assert!(
        worst_kernel <= 1e-9,
        "generic kernel: {worst_kernel:.3e} L apart"
    );
}

#[test]
fn the_generic_kernel_steps_on_the_one_step_as_the_runtime_engine_steps_it() {
    // the runtime's generic kernel (Gauss–Legendre quadrature over the strand, no moment
    // assembly) handed to the one step through `KernelTerms`, against the runtime engine
    // with kernels = "generic": the same terms, the same step rules
    use superhelix_runtime::config::KernelChoice;
    use superhelix_runtime::kernels::kernel::StrandTerms;
    use superhelix_runtime::kernels::step_terms::KernelTerms;
    use superhelix_runtime::kernels::{GenericKernel, QuadratureRule};
    const M: usize = 6;
    let strand = preset_strand(Preset::Wavy, M, 0.25, Vector3::new(1.0, 0.0, -1.0));
    let mut kernel = GenericKernel::new(strand.geometry.clone(), QuadratureRule::default());
    let mut terms = StrandTerms::new(3 * M);
    let mut flat = Vec::new();
    let mut heap = heap_strand(&strand);
    let straight = vec![0.0; 3 * M];
    assert!(heap.set_state(&straight, &straight));
    let head = shaking_head();
    let config = SimulationConfig {
        dt: DT,
        duration: 1.0,
        kernels: KernelChoice::Generic,
        ..Default::default()
    };
    let mut s = common::setup(vec![strand], config, gravity(), head.clone());
    s.strands[0].q0 = heap.q.clone();
    let mut sim = Simulation::new(s, None).expect("valid setup");
    let effects = Effects {
        gravity: gravity(),
        head_moves: true,
    };
    let mut ws = HeapWorkspace::new();
    let mut counts = StepCounts::default();
    let mut worst: f64 = 0.0;
    for k in 0..30 {
        sim.step().expect("runtime step");
        let t = k as f64 * DT;
        let mut source = KernelTerms::new(&mut kernel, &mut terms, &mut flat);
        heap::step(
            &mut source,
            &mut heap,
            &head,
            &effects,
            t,
            DT,
            &mut ws,
            &mut counts,
            None,
        )
        .expect("one step, generic kernel");
        let q = sim.q(0);
        let scale = q.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1.0);
        for (a, b) in q.iter().zip(&heap.q) {
            worst = worst.max((a - b).abs() / scale);
        }
    }
    eprintln!(
        "generic kernel: {worst:.3e}; {counts:?}; runtime {:?}",
        sim.stats()
    );
    assert!(worst <= 1e-12, "largest relative |Δq| {worst:.3e}");
    assert!(counts.substeps > 0, "{counts:?}");
}

#[test]
fn views_of_different_sizes_are_refused_not_stepped() {
    // a workspace of another N, and a BDF2 history of another length lent with the
    // strand: both steps on views answer StepError::Sizes and leave the strand as it was
    let strand = preset_strand(Preset::Wavy, 5, 0.2, Vector3::new(1.0, 0.0, -1.0));
    let mut heap = heap_strand(&strand);
    let q0 = heap.q.clone();
    let head = shaking_head();
    let effects = Effects {
        gravity: gravity(),
        head_moves: true,
    };
    let mut ws = HeapWorkspace::new();
    let mut counts = StepCounts::default();
    let wrong_n = fixed::step_views(
        &mut &ClosedForm,
        &mut heap.view(),
        &head,
        &effects,
        0.0,
        DT,
        ws.view(6),
        &mut counts,
        None,
    );
    assert_eq!(wrong_n.err(), Some(fixed::StepError::Sizes));
    let (mut q, mut v, mut h, mut next_h) = (vec![0.0; 12], vec![0.0; 12], DT, 0.0);
    let mut view = heap.view();
    view.history = Some(fixed::HistoryView {
        q: &mut q,
        v: &mut v,
        h: &mut h,
        next_h: &mut next_h,
    });
    let wrong_history = fixed::step_views(
        &mut &ClosedForm,
        &mut view,
        &head,
        &effects,
        0.0,
        DT,
        ws.view(5),
        &mut counts,
        None,
    );
    assert_eq!(wrong_history.err(), Some(fixed::StepError::Sizes));
    assert_eq!(heap.q, q0);
    assert_eq!(counts.attempts, 0);
}

#[test]
fn a_held_tip_is_kept_by_the_checked_step_and_refused_by_bdf2_and_the_tolerance() {
    // a wavy strand clamped at its root, its tip pinned where it starts, under gravity:
    // the checked step keeps the tip on its holder (to the projection's 1e-13 L) while
    // the strand sags; BDF2 and the error-controlled step refuse the held tip and leave
    // the strand as it was
    use superhelix_kernels::fixed::{HeldError, StepError, StillHead};
    use superhelix_runtime::config::HeldEnd;
    use superhelix_runtime::model::ends::HeldKind;
    use superhelix_runtime::model::reconstruction::pose_at;
    use superhelix_runtime::solver::held_end::{HeldHook, HeldTip};
    let strand = preset_strand(Preset::Wavy, 5, 0.2, Vector3::new(1.0, 0.0, -1.0));
    let geometry = strand.geometry.clone();
    let length = geometry.length();
    let mut heap = heap_strand(&strand);
    let q0 = heap.q.clone();
    let holder = pose_at(&geometry, &q0, length).position;
    let end = HeldEnd {
        kind: HeldKind::Pinned,
        position: holder,
        frame: nalgebra::Matrix3::identity(),
        axis: Vector3::x(),
        motion: HeadMotion::Still,
    };
    let mut tip = HeldTip::new(end, &geometry, None);
    let effects = Effects {
        gravity: gravity(),
        head_moves: false,
    };
    let mut ws = HeapWorkspace::new();
    let mut counts = StepCounts::default();
    // BDF2's history lent with the held tip
    let (mut hq, mut hv, mut h, mut next_h) = (q0.clone(), vec![0.0; 15], DT, 0.0);
    let mut view = heap.view();
    let mut hook = HeldHook {
        tip: &mut tip,
        geometry: &geometry,
    };
    view.end = Some(&mut hook);
    view.history = Some(fixed::HistoryView {
        q: &mut hq,
        v: &mut hv,
        h: &mut h,
        next_h: &mut next_h,
    });
    let refused = fixed::step_views(
        &mut &ClosedForm,
        &mut view,
        &StillHead,
        &effects,
        0.0,
        DT,
        ws.view(5),
        &mut counts,
        None,
    );
    assert_eq!(refused.err(), Some(StepError::Held(HeldError::Unsupported)));
    let mut history = view.history.take().expect("history");
    let mut report = fixed::ToleranceReport::default();
    let refused = fixed::step_to_tolerance_views(
        &mut &ClosedForm,
        &mut view,
        &mut history,
        &StillHead,
        &effects,
        (0.0, DT),
        1e-3,
        ws.view(5),
        &mut report,
        None,
    );
    assert_eq!(refused.err(), Some(StepError::Held(HeldError::Unsupported)));
    assert_eq!(view.q, &q0[..]);
    // the checked step keeps it
    let mut t = 0.0;
    let mut sag: f64 = 0.0;
    for _ in 0..30 {
        fixed::step_views(
            &mut &ClosedForm,
            &mut view,
            &StillHead,
            &effects,
            t,
            DT,
            ws.view(5),
            &mut counts,
            None,
        )
        .expect("step");
        t += DT;
        let q = view.q.to_vec();
        let off = (pose_at(&geometry, &q, length).position - holder).norm() / length;
        assert!(
            off <= 1e-12,
            "the tip is {off:.3e} L off its holder at t = {t:.3}"
        );
        let middle = pose_at(&geometry, &q, 0.5 * length).position;
        let middle0 = pose_at(&geometry, &q0, 0.5 * length).position;
        sag = sag.max((middle - middle0).norm() / length);
    }
    // the holder pulls: a reaction, and the strand moved under gravity
    assert!(tip.reaction_force().norm() > 0.0);
    assert!(sag > 1e-3, "the middle moved {sag:.3e} L");
}

#[test]
fn the_step_matrix_factored_after_a_step_is_the_linearly_implicit_steps() {
    // what the pair solve of `coupling = "pair"` takes after a BDF2 or Newton step: the
    // linearly implicit step's matrix at the strand's state, factored
    // (`fixed::factor_step_views`), the very factors a linearly implicit step from that
    // state solves on
    const M: usize = 7;
    let strand = preset_strand(Preset::Wavy, M, 0.25, Vector3::new(1.0, 0.0, -1.0));
    let mut heap = heap_strand(&strand);
    let head = shaking_head();
    let effects = Effects {
        gravity: gravity(),
        head_moves: true,
    };
    let mut ws = HeapWorkspace::new();
    let mut counts = StepCounts::default();
    for k in 0..5 {
        heap::step(
            &mut &ClosedForm,
            &mut heap,
            &head,
            &effects,
            k as f64 * DT,
            DT,
            &mut ws,
            &mut counts,
            None,
        )
        .expect("step");
    }
    let t_end = 6.0 * DT;
    let input = fixed::StepInput {
        head: fixed::HeadTrajectory::state(&head, t_end),
        gravity: effects.gravity,
        head_moves: true,
    };
    let (q, v) = (heap.q.clone(), heap.v.clone());
    let mut factored = HeapWorkspace::new();
    assert!(fixed::factor_step_views(
        &mut &ClosedForm,
        &mut heap.view(),
        &input,
        (DT, t_end),
        factored.view(M),
        None,
    ));
    assert_eq!((&heap.q, &heap.v), (&q, &v), "the state is not changed");
    let (piece, lu, pivots) = factored.last_factors().expect("factors kept");
    assert_eq!(piece, DT);
    let mut stepped = HeapWorkspace::new();
    heap::linearly_implicit(&mut &ClosedForm, &mut heap, &input, DT, &mut stepped)
        .expect("linearly implicit step");
    let (piece2, lu2, pivots2) = stepped.last_factors().expect("factors kept");
    assert_eq!(piece2, DT);
    assert_eq!(pivots, pivots2);
    // to round-off: the step's projection starts from the basis the factoring left
    // (measured 4.6e-16 of the largest factor)
    let scale = lu.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let worst = lu
        .iter()
        .zip(lu2)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    eprintln!("factors {:.3e} apart of {scale:.3e}", worst);
    assert!(worst <= 1e-12 * scale, "{worst:e} of {scale:e}");
    // and they are a step's: the state moved
    assert!(heap.q.iter().zip(&q).any(|(a, b)| a != b));
}

#[test]
fn a_free_rod_steps_on_the_kernels_free_root_terms_as_the_runtime_engine_steps_it() {
    // a wavy strand with a free root, bent and swung sideways under gravity on a shaking
    // head: its translation's terms from the kernels' `Floating` over the closed forms
    // on the runtime-N storage (a workspace of N + 1 elements for its 3N + 3
    // coordinates, the chain's moments on the first N), against the runtime engine (the
    // same `Floating` over the runtime's moment kernel)
    use superhelix_kernels::floating::{Floating, FloatingScratch};
    use superhelix_kernels::storage::ParamsView;
    let text = r#"
[simulation]
dt = 0.03333333333333333
duration = 1.0
engine = "runtime"

[environment]
gravity = [0.0, 0.0, -9.81]

[head]
motion = { kind = "oscillate", axis = [0.0, 0.0, 1.0], angle_deg = 30.0, frequency_hz = 2.0 }

[[strands]]
name = "wavy"
root = [0.0, 0.09, 0.0]
direction = [0.0, 1.0, -1.0]
length = 0.25
elements = 8
preset = "wavy"

[strands.ends]
root = "free"
"#;
    let setup = superhelix_runtime::parse_scene(text).expect("valid scene");
    let factory = superhelix_runtime::kernels::closed_form::kernel_factory();
    let mut sim = Simulation::new(setup, Some(factory)).expect("valid scene");
    let strand = sim.strand(0).clone();
    let g = &strand.geometry;
    // (a free root's joint is an element of the chain, as a pinned root's: 8 + 1)
    let chain = 3 * g.lengths.len();
    assert_eq!(sim.q(0).len(), chain + 3);
    let (stiffness, friction) = (strand.stiffness_diagonal(), strand.friction_diagonal());
    let scale = strand.solver_scale().unwrap_or_default();
    let mut heap = HeapStrand::from_params(&ParamsView {
        root_position: g.root_position,
        root_frame: g.root_frame,
        lengths: &g.lengths,
        natural: &strand.natural,
        stiffness: &stiffness,
        friction: &friction,
        mass_per_length: g.mass_per_length,
        air_drag: strand.air_drag,
        rotary_inertia: g.rotary_inertia,
        loads: &[],
        scale: &[],
    });
    // a start with the translation moving: the rod thrown sideways
    let mut v0 = vec![0.0; chain + 3];
    v0[chain + 1] = 0.4;
    assert!(heap.set_state(sim.q(0), &v0));
    let q0 = sim.q(0).to_vec();
    sim.set_state(0, &q0, &v0);
    let mut scratch = vec![0.0; FloatingScratch::<f64>::len(chain)];
    let mut source = Floating {
        chain: &ClosedForm,
        scratch: FloatingScratch::on(&mut scratch, chain).expect("sized"),
    };
    let head = shaking_head();
    let effects = Effects {
        gravity: gravity(),
        head_moves: true,
    };
    let mut ws = HeapWorkspace::new();
    let mut counts = StepCounts::default();
    let mut worst: f64 = 0.0;
    for k in 0..30 {
        sim.step().expect("runtime step");
        // (the joint's coordinates scaled as the runtime engine scales them)
        let elements = heap.work_elements();
        let mut view = heap.view();
        view.params.scale = &scale;
        fixed::step_views(
            &mut source,
            &mut view,
            &head,
            &effects,
            k as f64 * DT,
            DT,
            ws.view(elements),
            &mut counts,
            None,
        )
        .expect("runtime-N step");
        // (the joint's θ/l₀, 3e3 times the others, left out of the scale: its θ is
        // compared as the curvatures are)
        let q = sim.q(0);
        let scale = q[3..].iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1.0);
        for (i, (a, b)) in q.iter().zip(&heap.q).enumerate() {
            let l = if i < 3 {
                g.lengths[0] / g.length()
            } else {
                1.0
            };
            worst = worst.max((a - b).abs() * l / scale);
        }
    }
    let moved = (heap.q[chain..].iter().zip(&q0[chain..]))
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt();
    eprintln!(
        "free root on the kernels' terms: {worst:.3e}; moved {moved:.3e} m; {counts:?}; runtime {:?}",
        sim.stats()
    );
    assert!(moved > 0.05, "the rod's root moved {moved} m");
    assert!(worst <= 1e-12, "largest relative |Δq| {worst:.3e}");
    assert_eq!(counts.substeps, sim.stats().substeps);
}
