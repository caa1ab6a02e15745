//! A simulation: strands, environment, head motion, integrator; an explicit `step`.
//! [`Simulation::new`] builds one [`StrandSystem`] per strand from a
//! [`SimulationSetup`]; [`Simulation::step`] advances them all over one time step.

pub mod state;
use crate::bodies::{Bodies, PlacedBodies, Placement};
use crate::config::{
    Engine, IntegratorKind, KernelChoice, Mode, SimulationConfig, SimulationSetup,
};
use crate::error::{Error, FieldError, Result};
use crate::forces::contacts::{
    ContactSummary, HairHair, PairCounts, SearchInterval, StrandContacts,
};
use crate::forces::effects::GlobalEffects;
use crate::forces::electrostatics::{Electrostatics, FieldSummary};
use crate::forces::head_motion::HeadMotion;
use crate::kernels::closed_form::moment_kernel;
use crate::kernels::generic::{GenericKernel, QuadratureRule};
use crate::kernels::kernel::{KernelFactory, StrandKernel};
use crate::kernels::step_terms::KernelPoints;
use crate::model::reconstruction::positions_at_sorted;
use crate::model::reconstruction::{pose_at, sample_centreline};
use crate::model::strand::{Strand, StrandGeometry};
use crate::output::FrameSource;
use crate::solver::embedded::{
    floating_group_for, group_for, EmbeddedContacts, EmbeddedGroup, StepRules,
};
use crate::solver::initial_state::check_initial_state;
use crate::solver::pair_coupling::{self, CoupledStrand};
use crate::solver::{
    solve_static, step, HeadInterval, StaticReport, StepContext, StepStats, StrandState,
    StrandSystem,
};
use rayon::prelude::*;
pub use state::SimulationState;
use superhelix_kernels::field_split::FieldRule;

/// One strand of a running simulation: its system (model, kernel, buffers), state and
/// counters.
struct StrandSim {
    system: StrandSystem,
    /// Point loads of the scene; the electrostatic loads follow them in the strand's list.
    scene_loads: usize,
    state: StrandState,
    stats: StepStats,
    group: String,
    /// Its sides of the coupled hair–hair pairs (buffers of the pair solve).
    sides: crate::solver::pair_coupling::StrandSides,
}

/// The strands of the embedded engine ([`Engine::Embedded`]): per strand its description
/// and where its state lives (a group of its N, a position in it).
struct EmbeddedStrands {
    strands: Vec<(Strand, String, usize, usize)>,
    /// Per strand, how many of its point loads are the scene's (the charges' follow).
    scene_loads: Vec<usize>,
    /// The groups by (N, whether their roots are free).
    groups: Vec<((usize, bool), Box<dyn EmbeddedGroup>)>,
    gravity: Option<nalgebra::Vector3<f64>>,
    head_moves: bool,
    counts: superhelix_kernels::fixed::StepCounts,
    /// What the error-controlled steps did so far, and since the last frame.
    tolerance_total: superhelix_kernels::fixed::ToleranceReport,
    tolerance_window: superhelix_kernels::fixed::ToleranceReport,
    /// Whether the hair–hair pairs are coupled (`coupling = "pair"`): solved after the
    /// groups' steps ([`pair_coupling`]).
    coupled: bool,
    /// Per strand (the scene's order), its sides of the coupled pairs.
    sides: Vec<pair_coupling::StrandSides>,
    /// The pair solve's sides left out for an indefinite compliance, and its pairs left
    /// unresolved.
    pair_counts: [usize; 2],
}

impl EmbeddedStrands {
    /// Run `pass` on every coupled strand (each group's in parallel) with its sides; the
    /// first failure (strand in the scene's order, cause).
    fn coupled_pass(
        &mut self,
        pass: &crate::solver::embedded::CoupledPass<'_>,
    ) -> Option<(usize, String)> {
        let mut first: Option<(usize, String)> = None;
        for (g, (_, group)) in self.groups.iter_mut().enumerate() {
            // the group's strands in its order
            let mut members = vec![usize::MAX; group.len()];
            for (i, s) in self.strands.iter().enumerate() {
                if s.2 == g {
                    if let Some(m) = members.get_mut(s.3) {
                        *m = i;
                    }
                }
            }
            let mut sides: Vec<pair_coupling::StrandSides> = members
                .iter()
                .map(|&i| {
                    self.sides
                        .get_mut(i)
                        .map(std::mem::take)
                        .unwrap_or_default()
                })
                .collect();
            let (failure, stats) = group.each_coupled(&mut sides, pass);
            for (&i, side) in members.iter().zip(sides) {
                if let Some(slot) = self.sides.get_mut(i) {
                    *slot = side;
                }
            }
            self.counts.contacts_predicted += stats.contacts_predicted;
            self.pair_counts[0] += stats.pairs_indefinite;
            if let Some((p, cause)) = failure {
                let i = members.get(p).copied().unwrap_or(0);
                if first.as_ref().is_none_or(|f| i < f.0) {
                    first = Some((i, cause));
                }
            }
        }
        first
    }

    /// The coupled hair–hair pairs (`pairs`: the step's pair count) of a step of `h`
    /// ending at `at_end`, every group's strands having stepped: their ends, the pairs
    /// that touch, each strand's responses, the pairs' forces, applied to every strand,
    /// then the contacts' bookkeeping of the step's end — the runtime engine's pair
    /// solve ([`Simulation::step_by`]), on the groups' strands. The first failure:
    /// (strand, cause).
    fn solve_coupled_pairs(
        &mut self,
        pairs: usize,
        at_end: &Placement,
        h: f64,
    ) -> Option<(usize, String)> {
        if let Some(f) = self.coupled_pass(&|strand, side, _| {
            pair_coupling::strand_ends(strand, at_end, side);
            Ok(())
        }) {
            return Some(f);
        }
        let chosen = pair_coupling::select(&mut self.sides, pairs);
        if let Some(f) = self.coupled_pass(&|strand, side, stats| {
            pair_coupling::strand_responses(strand, at_end, h, stats, side)
        }) {
            return Some(f);
        }
        if pair_coupling::solve(&mut self.sides, &chosen).is_none() {
            self.pair_counts[1] += self.sides.iter().map(|s| s.responses()).sum::<usize>();
        }
        self.coupled_pass(&|strand, side, stats| {
            pair_coupling::apply(strand, side, at_end, stats)?;
            strand.end_contacts(at_end, h);
            Ok(())
        })
    }
}

/// Depth of the Anderson acceleration of the charged static solve's outer iteration.
const ANDERSON_DEPTH: usize = 5;

/// Anderson acceleration (type II) of a fixed-point iteration x ↦ G(x): the next iterate
/// is the combination of the last `depth` values of G whose residuals `G(x) − x` combine
/// to the smallest norm (least squares by normal equations, regularised). Turns the
/// linear convergence of the charged statics' outer iteration (forces refreshed after
/// each solve) into a much faster one.
struct Anderson {
    depth: usize,
    last: Option<(Vec<f64>, Vec<f64>)>,
    df: std::collections::VecDeque<Vec<f64>>,
    dg: std::collections::VecDeque<Vec<f64>>,
}

impl Anderson {
    fn new(depth: usize) -> Self {
        Anderson {
            depth,
            last: None,
            df: Default::default(),
            dg: Default::default(),
        }
    }

    /// The next iterate after x with G(x) = g.
    fn next(&mut self, x: &[f64], g: &[f64]) -> Vec<f64> {
        let f: Vec<f64> = g.iter().zip(x).map(|(a, b)| a - b).collect();
        if let Some((f0, g0)) = self.last.take() {
            self.df
                .push_back(f.iter().zip(&f0).map(|(a, b)| a - b).collect());
            self.dg
                .push_back(g.iter().zip(&g0).map(|(a, b)| a - b).collect());
            if self.df.len() > self.depth {
                self.df.pop_front();
                self.dg.pop_front();
            }
        }
        self.last = Some((f.clone(), g.to_vec()));
        let m = self.df.len();
        if m == 0 {
            return g.to_vec();
        }
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let mut a = nalgebra::DMatrix::<f64>::zeros(m, m);
        let mut b = nalgebra::DVector::<f64>::zeros(m);
        for i in 0..m {
            for j in 0..m {
                a[(i, j)] = dot(&self.df[i], &self.df[j]);
            }
            b[i] = dot(&self.df[i], &f);
        }
        let trace: f64 = (0..m).map(|i| a[(i, i)]).sum();
        for i in 0..m {
            a[(i, i)] += 1e-10 * trace.max(1e-300);
        }
        let Some(gamma) = a.cholesky().map(|c| c.solve(&b)) else {
            self.df.clear();
            self.dg.clear();
            return g.to_vec();
        };
        let mut next = g.to_vec();
        for i in 0..m {
            for (v, d) in next.iter_mut().zip(&self.dg[i]) {
                *v -= gamma[i] * d;
            }
        }
        if next.iter().all(|v| v.is_finite()) {
            next
        } else {
            g.to_vec()
        }
    }
}

/// One charging step of [`Simulation::solve_charged_static`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ChargingStage {
    /// Fraction of the full charge.
    pub charge_fraction: f64,
    /// Outer iterations (force refreshes after a Newton solve of every strand).
    pub iterations: usize,
    /// Largest `‖F(q)‖∞ / scale` over the strands with the last forces.
    pub residual: f64,
    /// Whether it met the tolerance.
    pub converged: bool,
    /// The field at the end.
    pub field: FieldSummary,
}

/// How a charged static solve went.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ChargedStaticReport {
    /// Each charging step.
    pub stages: Vec<ChargingStage>,
    /// The strands' last Newton solves.
    pub strands: Vec<StaticReport>,
}

/// A running simulation. Built from a [`SimulationSetup`]; advanced by [`Simulation::step`].
pub struct Simulation {
    config: SimulationConfig,
    head: HeadMotion,
    bodies: Bodies,
    samples_per_element: usize,
    strands: Vec<StrandSim>,
    embedded: Option<EmbeddedStrands>,
    electrostatics: Option<Electrostatics>,
    hair_hair: Option<HairHair>,
    time: f64,
    steps: usize,
    /// Error-controlled steps accepted and rejected up to the last frame's report.
    reported_steps: (usize, usize),
    /// Wall time the hair–hair pairs' tracking and search took so far, s.
    hair_pair_seconds: f64,
}

/// What keeps the embedded engine from running `setup`: every setting and strand it
/// cannot step, each naming its field (empty: it can run the scene). `engine = "auto"`
/// takes the embedded engine exactly when this is empty.
fn embedded_refusals(setup: &SimulationSetup) -> Vec<FieldError> {
    let mut errors = Vec::new();
    let c = &setup.config;
    if c.integrator == IntegratorKind::Rk4 {
        errors.push(FieldError::new(
            "simulation.engine",
            "the embedded engine steps with linearly-implicit-euler, newton-implicit-euler or bdf2 (integrator = \"rk4\"); \
             use engine = \"runtime\" for rk4",
        ));
    }
    if c.mode == Mode::Static {
        errors.push(FieldError::new(
            "simulation.engine",
            "the embedded engine steps dynamic scenes (Simulation::solve_static still works on it); use engine = \"runtime\" or \"auto\" with mode = \"static\"",
        ));
    }
    if matches!(c.kernels, KernelChoice::Generic | KernelChoice::Moment) {
        errors.push(FieldError::new(
            "simulation.kernels",
            format!(
                "the embedded engine runs on generated fixed-N code; kernels = \"{}\" needs engine = \"runtime\"",
                c.kernels.name()
            ),
        ));
    }
    for (index, s) in setup.strands.iter().enumerate() {
        let n = s.strand.geometry.elements();
        if s.strand.ends.root == crate::model::ends::RootEnd::Free {
            // the chain's N (its joint counted) with the translation's terms of the
            // kernels, for the sizes with fixed-N code
            if crate::solver::embedded::floating_group_for(n).is_none() {
                errors.push(FieldError::new(
                    format!("strands[{index}].ends"),
                    format!(
                        "the embedded engine steps a free root whose chain (N = {n}, its joint counted) has fixed-N code in this build (N = {:?}; build with SUPERHELIX_N={n} to add it); use engine = \"runtime\"",
                        superhelix_generated::fixed::SIZES
                    ),
                ));
            }
        } else if !superhelix_generated::fixed::SIZES.contains(&n) {
            errors.push(FieldError::new(
                "simulation.engine",
                format!(
                    "strand '{}' (strands[{index}]) has N = {n} elements and this build has no \
                     fixed-N code for it (build with SUPERHELIX_N={n} to add it, or use engine = \"runtime\")",
                    s.strand.name
                ),
            ));
        }
    }
    errors
}

/// Bring strand `index`'s held tip onto its constraint at t = 0: q0 projected
/// ([`crate::solver::held_end::HeldTip::project`]) through the points of `kernel`, or the
/// problem that keeps it from it, named for `strands[index].ends.tip` (a taut rod held at
/// its whole length, a start the projection cannot bring to the holder). Both engines
/// start a held tip here.
fn hold_at_start(
    index: usize,
    held: &mut crate::solver::held_end::HeldTip,
    kernel: &mut dyn crate::kernels::kernel::StrandKernel,
    g: &crate::model::strand::StrandGeometry,
    root_free: bool,
    q0: &mut [f64],
) -> std::result::Result<(), FieldError> {
    let before = pose_at(g, q0, g.length());
    // a tip held at the strand's whole length from a held root: the rod is taut, its
    // held ends' constraints are dependent (the step's G A⁻¹ Gᵀ is singular) and the run
    // would stop at its first step
    let (p, _, _) = held.target(0.0);
    let span = (p - pose_at(g, q0, 0.0).position).norm();
    let length = g.length();
    if !root_free && !held.end.kind.slides() && span >= (1.0 - 1e-6) * length {
        return Err(FieldError::new(
            format!("strands[{index}].ends.tip"),
            format!(
                "the tip is held {span:.6} m from the root, the strand's whole length ({length:.6} m): a taut rod's held ends are dependent constraints and the run would stop at its first step; hold the tip closer to the root (ends.tip.position), start from a bent shape (q0 or natural curvatures), or let it slide along the strand (kind = \"sliding\")"
            ),
        ));
    }
    held.project(&mut KernelPoints(kernel), g, q0, 0.0)
        .map(|_| ())
        .map_err(|e| {
            let (p, frame, _) = held.target(0.0);
            let off = (before.position - p).norm();
            // the angle between the starting tip frame and the held one
            let turn = frame.transpose() * before.frame;
            let cos = (0.5 * (turn.trace() - 1.0)).clamp(-1.0, 1.0);
            let angle = cos.acos().to_degrees();
            let message = if held.end.kind.holds_frame() && angle > 1e-3 {
                format!(
                    "the initial shape's tip is {off:.4e} m from the held position and its frame is turned {angle:.1}° from the held frame (ends.tip.direction, ends.tip.normal), and could not be brought there ({e}): leave out direction and normal to hold the tip in the frame it starts in, or start from a shape whose tip has that frame (q0, or natural curvatures)"
                )
            } else {
                format!(
                    "the initial shape's tip is {off:.4e} m from the held position and could not be brought there ({e}); start from a shape that reaches it (q0, or natural curvatures)"
                )
            };
            FieldError::new(format!("strands[{index}].ends.tip"), message)
        })
}

/// The moment kernel on the generated closed forms of a strand of `g` (with a free root,
/// wrapped with the translation's terms): the embedded engine's terms as a runtime
/// kernel, for what the runtime measures on a system of its own.
fn closed_form_kernel(
    g: &crate::model::strand::StrandGeometry,
) -> Box<dyn crate::kernels::kernel::StrandKernel> {
    use crate::kernels::floating::FloatingKernel;
    use crate::kernels::moments::kernel::MomentKernel;
    if g.floating {
        let chain = FloatingKernel::chain_geometry(g);
        Box::new(FloatingKernel::new(
            g.clone(),
            Box::new(MomentKernel::new(chain, superhelix_generated::ClosedForm)),
        ))
    } else {
        Box::new(MomentKernel::new(
            g.clone(),
            superhelix_generated::ClosedForm,
        ))
    }
}

/// What adds forces to a strand's generalized force F.
type AddForce<'a> = dyn FnMut(&mut [f64]) + 'a;

/// The reaction of `system`'s held tip with the strand at rest in (q, q̇) at `at`
/// ([`crate::solver::held_end::HeldTip::start_reaction`] with M and F there); a strand
/// whose M does not factor keeps its reaction. `contacts` adds the contacts' forces to F
/// when the system does not hold them (the embedded engine's).
fn start_reaction(
    system: &mut StrandSystem,
    at: &Placement,
    q: &[f64],
    v: &[f64],
    contacts: Option<&mut AddForce<'_>>,
) {
    let terms = crate::kernels::kernel::Terms {
        mass: true,
        force: true,
        ..Default::default()
    };
    let n = q.len();
    system.assemble(at, q, v, terms);
    let ws = &mut system.workspace;
    let mut force = ws.terms.force[..n].to_vec();
    if let Some(add) = contacts {
        add(&mut force);
    }
    for j in 0..n {
        for i in 0..n {
            ws.solver.matrix[(i, j)] = ws.terms.mass[(i, j)];
        }
    }
    ws.solver.rhs_mut().fill(0.0);
    if !ws.solver.solve_spd() {
        return;
    }
    if let Some(held) = system.held.as_mut() {
        let solver = &mut system.workspace.solver;
        let _ = held.start_reaction(
            &mut KernelPoints(system.kernel.as_mut()),
            &system.strand.geometry,
            &mut |x| solver.solve_factored_spd(x),
            q,
            &force,
            at.time,
        );
    }
}

/// Refuse `setup` when what it holds on the engine it gets ([`engine_for`]) is beyond
/// the machine's memory ([`crate::memory_plan::MemoryEstimate::check`]): the check
/// `run`, `validate` and [`Simulation::new`] make before they allocate.
pub fn check_memory(setup: &SimulationSetup) -> Result<()> {
    crate::memory_plan::estimate(setup, engine_for(setup).0).check()
}

/// The engine [`Simulation::new`] steps `setup` with ([`Engine::Embedded`] or
/// [`Engine::Runtime`], what `engine = "auto"` resolves to), and when `auto` takes the
/// runtime engine the first thing in the scene the embedded engine lacks.
pub fn engine_for(setup: &SimulationSetup) -> (Engine, Option<FieldError>) {
    match setup.config.engine {
        Engine::Embedded => (Engine::Embedded, None),
        Engine::Runtime => (Engine::Runtime, None),
        Engine::Auto => match embedded_refusals(setup).into_iter().next() {
            None => (Engine::Embedded, None),
            Some(reason) => (Engine::Runtime, Some(reason)),
        },
    }
}

/// The shortest interval between two searches of the hair–hair pairs under a tolerance,
/// s ([`Simulation::step_by`]).
pub const MIN_SEARCH_INTERVAL: f64 = 1e-6;

/// How far, in τ L, a charged particle may move between two updates of the Coulomb
/// forces under a tolerance ([`Simulation::step_by`]). A charge that moved δ changes the
/// forces on the others by about F δ / r, and a strand misses of that only what builds
/// up within an interval: on the two charged strands of `runtime/tests/error_control.rs`
/// an interval bounded by 0.9 τ L left the tips 0.16 to 0.34 τ off (τ = 1e-1 to 1e-3),
/// by 3 τ L 0.38 to 0.56 τ.
pub const CHARGE_MOTION: f64 = 3.0;

/// The hair–hair broad phase and pair tracking of the contacts `c` (`None`: no
/// `[contacts.hair_hair]`). Strands that overlap at the start are let apart slowly, as
/// points that start inside a body.
fn hair_hair_of(c: &crate::forces::contacts::ContactConfig) -> Option<HairHair> {
    let h = c.hair_hair.as_ref()?;
    let mut hh = HairHair::new(h.search_every)
        .with_depenetration_speed(c.depenetration_speed)
        .with_pair_cap(h.max_pairs_per_sample);
    if let Some(f) = h.friction {
        hh = hh.with_friction(f);
    }
    Some(if h.self_contact {
        hh.with_self_contact(h.self_exclusion())
    } else {
        hh
    })
}

/// The simulation of `setup` on the embedded engine, or every reason it cannot take it
/// (after `errors`, the problems already found) as [`Error::Invalid`].
fn embedded_strands(
    setup: SimulationSetup,
    bodies: Bodies,
    mut errors: Vec<FieldError>,
) -> Result<(Simulation, ())> {
    errors.extend(embedded_refusals(&setup));
    if !errors.is_empty() {
        return Err(Error::Invalid(errors));
    }
    let mut groups: Vec<((usize, bool), Box<dyn EmbeddedGroup>)> = Vec::new();
    let mut strands = Vec::with_capacity(setup.strands.len());
    let strand_count = setup.strands.len();
    let coupled = setup
        .contacts
        .as_ref()
        .and_then(|c| c.hair_hair.as_ref())
        .is_some_and(|h| h.coupling == crate::forces::contacts::Coupling::Pair);
    // the bodies the strands touch (those `[contacts] bodies` names)
    let contacts = setup.contacts.as_ref().map(|c| EmbeddedContacts {
        bodies: bodies
            .as_slice()
            .iter()
            .filter(|b| c.touches(&b.name))
            .cloned()
            .collect(),
        config: c.clone(),
    });
    for (index, s) in setup.strands.into_iter().enumerate() {
        let n = s.strand.geometry.elements();
        let free = s.strand.ends.root == crate::model::ends::RootEnd::Free;
        let g = match groups.iter().position(|(key, _)| *key == (n, free)) {
            Some(g) => g,
            None => match if free {
                floating_group_for(n)
            } else {
                group_for(n)
            } {
                Some(mut group) => {
                    group.set_rules(StepRules {
                        field_rule: match setup.config.field_stiffness {
                            crate::config::FieldStiffness::Projected => FieldRule::Projected,
                            crate::config::FieldStiffness::Explicit => FieldRule::Explicit,
                            crate::config::FieldStiffness::Split => FieldRule::Split,
                        },
                        max_split_depth: setup.config.max_split_depth,
                        energy_balance: setup.config.energy_balance,
                        bdf2: setup.config.integrator == IntegratorKind::Bdf2,
                        newton: setup.config.integrator == IntegratorKind::NewtonImplicitEuler,
                    });
                    groups.push(((n, free), group));
                    groups.len() - 1
                }
                None => {
                    errors.push(FieldError::new(
                        "simulation.engine",
                        format!("no fixed-N code for N = {n} (strands[{index}])"),
                    ));
                    continue;
                }
            },
        };
        // a held tip starts on its constraint, through the points of the same closed forms
        let mut q0 = s.q0;
        let held = match s.tip {
            Some(end) => {
                let g = &s.strand.geometry;
                let mut tip =
                    crate::solver::held_end::HeldTip::new(end, g, s.strand.solver_scale());
                let mut kernel = closed_form_kernel(g);
                let root_free = s.strand.ends.root == crate::model::ends::RootEnd::Free;
                if q0.len() == g.dofs() {
                    if let Err(e) =
                        hold_at_start(index, &mut tip, kernel.as_mut(), g, root_free, &mut q0)
                    {
                        errors.push(e);
                        continue;
                    }
                }
                Some(tip)
            }
            None => None,
        };
        let group = &mut groups[g].1;
        let position = group.len();
        if !group.push(&s.strand, &q0, contacts.as_ref(), held) {
            errors.push(FieldError::new(
                format!("strands[{index}].q0"),
                format!("must have {} values", s.strand.geometry.dofs()),
            ));
            continue;
        }
        strands.push((s.strand, s.group, g, position));
    }
    if !errors.is_empty() {
        return Err(Error::Invalid(errors));
    }
    let electrostatics = match setup.electrostatics {
        Some(config) => {
            let list: Vec<&Strand> = strands.iter().map(|s| &s.0).collect();
            match Electrostatics::new(config, &list) {
                Ok(e) => Some(e),
                Err(e) => return Err(Error::Invalid(vec![FieldError::new("electrostatics", e)])),
            }
        }
        None => None,
    };
    let head_moves = setup.head != HeadMotion::Still;
    let hair_hair = setup.contacts.as_ref().and_then(hair_hair_of);
    // contact points inside a body at the start are let out slowly; Coulomb anchors
    let head0 = setup.head.state(0.0);
    for (_, group) in groups.iter_mut() {
        group.start_contacts(0.0, &head0);
    }
    let scene_loads = strands.iter().map(|s| s.0.point_loads.len()).collect();
    Ok((
        Simulation {
            embedded: Some(EmbeddedStrands {
                strands,
                scene_loads,
                groups,
                gravity: setup.environment.gravity,
                head_moves,
                counts: Default::default(),
                tolerance_total: Default::default(),
                tolerance_window: Default::default(),
                coupled,
                // (only coupled strands have sides)
                sides: if coupled {
                    (0..strand_count)
                        .map(|_| pair_coupling::StrandSides::default())
                        .collect()
                } else {
                    Vec::new()
                },
                pair_counts: [0; 2],
            }),
            config: setup.config,
            head: setup.head,
            bodies,
            samples_per_element: setup.samples_per_element,
            strands: Vec::new(),
            electrostatics,
            hair_hair,
            time: 0.0,
            steps: 0,
            reported_steps: (0, 0),
            hair_pair_seconds: 0.0,
        },
        (),
    ))
}

/// Why a static solve refuses `[contacts.hair_hair]`.
const STATIC_HAIR_HAIR: &str = "the static solve does not take contacts between rods or a rod's parts (each strand's equilibrium is solved alone): run mode = \"dynamic\" with internal friction until the strands are at rest, or remove [contacts.hair_hair]";

/// Check the parts of a setup the scene reader may not have (for users of the API).
fn check_setup(setup: &SimulationSetup) -> Result<()> {
    let mut errors = Vec::new();
    let c = &setup.config;
    if !(c.dt.is_finite() && c.dt > 0.0) {
        errors.push(FieldError::new(
            "simulation.dt",
            format!("must be finite and > 0, got {}", c.dt),
        ));
    }
    if !(c.duration.is_finite() && c.duration >= 0.0) {
        errors.push(FieldError::new(
            "simulation.duration",
            format!("must be finite and >= 0, got {}", c.duration),
        ));
    }
    if setup.strands.is_empty() {
        errors.push(FieldError::new(
            "strands",
            "at least one strand is required",
        ));
    }
    if let Some(t) = c.tolerance {
        if !(crate::config::MIN_TOLERANCE..=crate::config::MAX_TOLERANCE).contains(&t) {
            errors.push(FieldError::new(
                "simulation.tolerance",
                format!(
                    "must be in [{:e}, {}], got {t}",
                    crate::config::MIN_TOLERANCE,
                    crate::config::MAX_TOLERANCE
                ),
            ));
        }
        let estimates = matches!(
            c.integrator,
            IntegratorKind::LinearlyImplicitEuler | IntegratorKind::Bdf2
        );
        if !estimates && c.mode == Mode::Dynamic {
            errors.push(FieldError::new(
                "simulation.tolerance",
                format!(
                    "the error-controlled step is BDF2 with its predictor's error estimate; integrator = \"{}\" cannot estimate its error (leave integrator unset or set \"bdf2\")",
                    c.integrator.name()
                ),
            ));
        }
    }
    if let Some(cc) = &setup.contacts {
        errors.extend(cc.check());
        if cc.hair_hair.is_some() && c.mode == Mode::Static {
            errors.push(FieldError::new("contacts.hair_hair", STATIC_HAIR_HAIR));
        }
        let paired = cc
            .hair_hair
            .as_ref()
            .is_some_and(|h| h.coupling == crate::forces::contacts::config::Coupling::Pair);
        if paired && c.integrator == IntegratorKind::Rk4 && c.mode == Mode::Dynamic {
            errors.push(FieldError::new(
                "contacts.hair_hair.coupling",
                "\"pair\" solves the pairs on each strand's implicit step matrix, which rk4 does not have: use an implicit integrator (linearly-implicit-euler, newton-implicit-euler, bdf2) or coupling = \"ball\"",
            ));
        }
    }
    for (i, s) in setup.strands.iter().enumerate() {
        let g = &s.strand.geometry;
        let at = |f: &str| format!("strands[{i}].{f}");
        if g.lengths.is_empty() {
            errors.push(FieldError::new(at("elements"), "must be >= 1"));
        }
        if g.lengths.iter().any(|l| !(l.is_finite() && *l > 0.0)) {
            errors.push(FieldError::new(
                at("element_lengths"),
                "every element length must be finite and > 0",
            ));
        }
        let n = g.dofs();
        if s.q0.len() != n || s.strand.natural.len() != n {
            errors.push(FieldError::new(
                at("q0"),
                format!("must have 3N = {n} values"),
            ));
        }
        if s.q0.iter().chain(&s.strand.natural).any(|x| !x.is_finite()) {
            errors.push(FieldError::new(at("q0"), "values must be finite"));
        }
        errors.extend(check_ends(setup, i));
        let m = &s.strand.material;
        if !(m.mass_per_length > 0.0 && m.stiffness.iter().all(|k| *k > 0.0 && k.is_finite())) {
            errors.push(FieldError::new(
                at("material"),
                "mass per length and stiffnesses must be finite and > 0",
            ));
        }
    }
    if errors.is_empty() {
        Ok(())
    } else {
        Err(Error::Invalid(errors))
    }
}

/// What the ends of strand `i` need of the scene: a pinned root its joint and a
/// scale-aware integrator, a held tip the linearly implicit step (or the static solve)
/// and a still head; a follower load a dynamic run.
fn check_ends(setup: &SimulationSetup, i: usize) -> Vec<FieldError> {
    use crate::model::ends::{RootEnd, ROOT_JOINT_FRACTION};
    let mut errors = Vec::new();
    let s = &setup.strands[i].strand;
    let c = &setup.config;
    let dynamic = c.mode == Mode::Dynamic;
    if s.ends.root != RootEnd::Clamped {
        let l = s.geometry.length();
        let joint = s.geometry.lengths.first().copied().unwrap_or(0.0);
        if s.geometry.lengths.len() < 2 || (joint - ROOT_JOINT_FRACTION * l).abs() > 1e-3 * joint {
            errors.push(FieldError::new(
                format!("strands[{i}].ends.root"),
                "a pinned root needs its joint element first (Strand::pin_root)",
            ));
        }
        if dynamic && c.integrator == IntegratorKind::NewtonImplicitEuler {
            errors.push(FieldError::new(
                format!("strands[{i}].ends.root"),
                format!("a {} root is stepped by linearly-implicit-euler, bdf2 or rk4; integrator = \"newton-implicit-euler\" does not take it", s.ends.root.name()),
            ));
        }
    }
    if s.ends.root == RootEnd::Free {
        let at = format!("strands[{i}].ends.root");
        if !s.geometry.floating || s.natural.len() != s.geometry.dofs() {
            errors.push(FieldError::new(
                at.clone(),
                "a free root needs its translation coordinates (Strand::free_root)",
            ));
        }
        if !dynamic {
            errors.push(FieldError::new(
                at.clone(),
                "a free rod has no static equilibrium to solve for (nothing holds it): run mode = \"dynamic\"",
            ));
        }
        if setup.strands[i].tip.is_some() {
            errors.push(FieldError::new(
                at,
                "a free root with a held tip is a rod held by its tip only: hold that end as the root instead (root = \"pinned\" or \"clamped\", the rod's nodes reversed)",
            ));
        }
    } else if s.geometry.floating {
        errors.push(FieldError::new(
            format!("strands[{i}].ends.root"),
            "translation coordinates without a free root (use Strand::free_root)",
        ));
    }
    if !dynamic {
        if let Some(j) = s.point_loads.iter().position(|l| l.follows) {
            errors.push(FieldError::new(
                format!("strands[{i}].point_loads[{j}].follows"),
                "a follower load has no potential, and the static solve minimises the energy: run mode = \"dynamic\" with internal friction until the strand is at rest",
            ));
        }
        if let Some(j) = s
            .point_loads
            .iter()
            .position(|l| l.torque != nalgebra::Vector3::zeros())
        {
            errors.push(FieldError::new(
                format!("strands[{i}].point_loads[{j}].torque"),
                "a couple has no potential in three dimensions, and the static solve minimises the energy: run mode = \"dynamic\" with internal friction until the strand is at rest",
            ));
        }
    }
    if let Some(tip) = &setup.strands[i].tip {
        let at = format!("strands[{i}].ends.tip");
        if setup.head != HeadMotion::Still {
            errors.push(FieldError::new(
                at.clone(),
                "a held tip needs a still head (move the holder with [strands.ends.tip.motion])",
            ));
        }
        if dynamic && c.integrator != IntegratorKind::LinearlyImplicitEuler {
            errors.push(FieldError::new(
                at.clone(),
                format!(
                    "a held tip is stepped by linearly-implicit-euler only (integrator = \"{}\")",
                    c.integrator.name()
                ),
            ));
        }
        if dynamic && c.tolerance.is_some() {
            errors.push(FieldError::new(
                at.clone(),
                "a held tip is stepped with fixed steps: remove [simulation] tolerance",
            ));
        }
        if dynamic {
            errors.extend(holder_resolved(&tip.motion, c.dt, &at));
        }
        let finite = tip
            .position
            .iter()
            .chain(tip.frame.iter())
            .chain(tip.axis.iter());
        if !finite.into_iter().all(|x| x.is_finite()) {
            errors.push(FieldError::new(
                at,
                "position, frame and axis must be finite",
            ));
        }
    }
    errors
}

/// Steps per period a holder's oscillation needs: the held tip is placed where the holder
/// is at each step's end, so a holder that turns back within a few steps is seen at a
/// few phases of its period only (at one step per period, always at the same place).
pub const HOLDER_STEPS_PER_PERIOD: f64 = 8.0;

/// Whether steps of `dt` resolve a holder's `motion` (`at`: its field): an oscillation of
/// frequency f needs `dt ≤ 1 / (8 f)` ([`HOLDER_STEPS_PER_PERIOD`]), keyframes a step no
/// longer than the closest two keys.
fn holder_resolved(motion: &HeadMotion, dt: f64, at: &str) -> Option<FieldError> {
    match motion {
        HeadMotion::Oscillate { frequency_hz, .. }
        | HeadMotion::TranslateOscillate { frequency_hz, .. } => {
            let needed = 1.0 / (HOLDER_STEPS_PER_PERIOD * frequency_hz);
            (dt > needed * (1.0 + 1e-9)).then(|| {
                FieldError::new(
                    format!("{at}.motion.frequency_hz"),
                    format!(
                        "a holder oscillating at {frequency_hz} Hz needs steps of at most 1/({HOLDER_STEPS_PER_PERIOD} f) = {needed:.3e} s to be followed between its turns; the scene's steps are {dt:.3e} s (set [simulation] dt to {needed:.3e} or less)"
                    ),
                )
            })
        }
        HeadMotion::Keyframes(track) => {
            let keys = track.keys();
            let (k, gap) = keys
                .windows(2)
                .enumerate()
                .map(|(k, w)| (k, w[1].t - w[0].t))
                .min_by(|a, b| a.1.total_cmp(&b.1))?;
            (dt > gap * (1.0 + 1e-9)).then(|| {
                FieldError::new(
                    format!("{at}.motion.keys[{}].t", k + 1),
                    format!(
                        "keys {k} and {} of the holder are {gap:.3e} s apart, less than the scene's steps of {dt:.3e} s: the holder would move between two steps unseen (set [simulation] dt to {gap:.3e} or less)",
                        k + 1
                    ),
                )
            })
        }
        _ => None,
    }
}

fn make_kernel(
    choice: KernelChoice,
    rule: QuadratureRule,
    geometry: &StrandGeometry,
    generated: Option<&dyn KernelFactory>,
    index: usize,
    name: &str,
) -> std::result::Result<Box<dyn StrandKernel>, FieldError> {
    if geometry.floating {
        // a free root: the chain's kernel, wrapped for the root's translation
        let chain = crate::kernels::floating::FloatingKernel::chain_geometry(geometry);
        return make_kernel(choice, rule, &chain, generated, index, name).map(|k| {
            Box::new(crate::kernels::floating::FloatingKernel::new(
                geometry.clone(),
                k,
            )) as Box<dyn StrandKernel>
        });
    }
    let n = geometry.elements();
    let from_generated = || generated.and_then(|f| f.create(geometry));
    match choice {
        KernelChoice::Generic => Ok(Box::new(GenericKernel::new(geometry.clone(), rule))),
        KernelChoice::Moment => Ok(moment_kernel(geometry)),
        // the factory's kernel (fixed-N code where the build has it, the moment path
        // otherwise), and without a factory the moment path: the closed forms are always
        // linked in, so a strand never falls back to quadrature silently
        KernelChoice::Auto => Ok(from_generated().unwrap_or_else(|| moment_kernel(geometry))),
        KernelChoice::Generated => {
            let available = generated.map(|f| f.available()).unwrap_or_default();
            available
                .contains(&n)
                .then(from_generated)
                .flatten()
                .ok_or_else(|| {
                    FieldError::new(
                        "simulation.kernels",
                        format!(
                            "strand '{name}' (strands[{index}]) has N = {n} elements and this build has no \
                             generated fixed-N code for it (it has N in {available:?}); build with \
                             SUPERHELIX_N={n} to generate it, or use kernels = \"auto\" (the moment \
                             assembly on the generated closed forms) or \"generic\""
                        ),
                    )
                })
        }
    }
}

impl Simulation {
    /// Build the simulation: one kernel per strand (generated where `generated` has one
    /// and the configuration allows it), workspaces sized once. The initial state is
    /// checked as the first step would meet it ([`crate::solver::initial_state`]): a
    /// missing generated kernel, a non-finite centreline, force or mass matrix, and under
    /// RK4 a dt beyond its stability limit are [`Error::Invalid`], every problem listed.
    /// The bodies are built here ([`Bodies::build`]: mesh files read, their fields
    /// sampled); their problems are listed with the others.
    pub fn new(setup: SimulationSetup, generated: Option<&dyn KernelFactory>) -> Result<Self> {
        check_setup(&setup)?;
        // what will not fit in the machine's memory is refused before it is allocated
        check_memory(&setup)?;
        let (bodies, mut errors) = match Bodies::build(&setup.bodies) {
            Ok(bodies) => (bodies, Vec::new()),
            Err(Error::Invalid(errors)) => (Bodies::default(), errors),
            Err(e) => return Err(e),
        };
        if engine_for(&setup).0 == Engine::Embedded {
            let (mut sim, ()) = embedded_strands(setup, bodies, errors)?;
            if sim.electrostatics.is_some() && sim.config.mode == Mode::Dynamic {
                // the Coulomb loads of t = 0
                sim.refresh_charges(0.0)?;
            }
            if sim.config.mode == Mode::Dynamic {
                sim.start_held_reactions();
            }
            return Ok(sim);
        }
        let head_moves = setup.head != HeadMotion::Still;
        let context = StepContext {
            effects: GlobalEffects {
                gravity: setup.environment.gravity,
                head_moves,
            },
            integrator: setup.config.integrator,
            max_split_depth: setup.config.max_split_depth,
            // (a static solve and RK4 take the whole stiffness whatever the setting: it
            // is about the implicit step's matrix)
            explicit_field_stiffness: setup.config.field_stiffness
                == crate::config::FieldStiffness::Explicit
                && setup.config.mode == Mode::Dynamic
                && setup.config.integrator != IntegratorKind::Rk4,
            field_split: setup.config.field_stiffness == crate::config::FieldStiffness::Split,
            energy_balance: setup.config.energy_balance,
            tolerance: setup
                .config
                .tolerance
                .filter(|_| setup.config.mode == Mode::Dynamic),
        };
        let head0 = Placement::new(setup.head.state(0.0), 0.0);
        let rk4_dt = (setup.config.integrator == IntegratorKind::Rk4
            && setup.config.mode == Mode::Dynamic)
            .then_some(setup.config.dt);
        let contact_bodies: Option<std::sync::Arc<[crate::bodies::Body]>> =
            setup.contacts.as_ref().map(|c| {
                bodies
                    .as_slice()
                    .iter()
                    .filter(|b| c.touches(&b.name))
                    .cloned()
                    .collect()
            });
        let mut strands = Vec::with_capacity(setup.strands.len());
        for (index, s) in setup.strands.into_iter().enumerate() {
            let kernel = match make_kernel(
                setup.config.kernels,
                setup.config.quadrature,
                &s.strand.geometry,
                generated,
                index,
                &s.strand.name,
            ) {
                Ok(kernel) => kernel,
                Err(e) => {
                    errors.push(e);
                    continue;
                }
            };
            let mut system = StrandSystem::new(s.strand, kernel, context);
            system.held = s.tip.map(|end| {
                let scale = system.strand.solver_scale();
                crate::solver::held_end::HeldTip::new(end, &system.strand.geometry, scale)
            });
            if let (Some(c), Some(b)) = (&setup.contacts, &contact_bodies) {
                let g = &system.strand.geometry;
                let rho_s = system.strand.material.mass_per_length;
                let free_ends = c.free_ends(
                    system.strand.ends.root == crate::model::ends::RootEnd::Free,
                    system.held.is_none(),
                );
                system.contacts = Some(
                    StrandContacts::new(
                        g,
                        b.clone(),
                        c.params(rho_s),
                        c.hair_hair.as_ref().map(|h| h.params(rho_s)),
                        c.samples_per_element,
                        free_ends,
                    )
                    .with_prediction(c.predict),
                );
            }
            let mut q0 = s.q0;
            if let Some(held) = system.held.as_mut() {
                let root_free = system.strand.ends.root == crate::model::ends::RootEnd::Free;
                if let Err(e) = hold_at_start(
                    index,
                    held,
                    system.kernel.as_mut(),
                    &system.strand.geometry,
                    root_free,
                    &mut q0,
                ) {
                    errors.push(e);
                    continue;
                }
            }
            errors.extend(check_initial_state(index, &mut system, &head0, &q0, rk4_dt));
            let n = q0.len();
            strands.push(StrandSim {
                scene_loads: system.strand.point_loads.len(),
                system,
                state: StrandState {
                    q: q0,
                    v: vec![0.0; n],
                },
                stats: StepStats::default(),
                sides: Default::default(),
                group: s.group,
            });
        }
        let electrostatics = match setup.electrostatics {
            Some(config) => {
                let list: Vec<&crate::model::strand::Strand> =
                    strands.iter().map(|s| &s.system.strand).collect();
                match Electrostatics::new(config, &list) {
                    Ok(e) => Some(e),
                    Err(e) => {
                        errors.push(FieldError::new("electrostatics", e));
                        None
                    }
                }
            }
            None => None,
        };
        if !errors.is_empty() {
            return Err(Error::Invalid(errors));
        }
        let mut sim = Simulation {
            config: setup.config,
            head: setup.head,
            bodies,
            samples_per_element: setup.samples_per_element,
            strands,
            embedded: None,
            electrostatics,
            hair_hair: setup.contacts.as_ref().and_then(hair_hair_of),
            time: 0.0,
            steps: 0,
            reported_steps: (0, 0),
            hair_pair_seconds: 0.0,
        };
        // contact points inside a body at the start are let out slowly; Coulomb anchors
        for st in &mut sim.strands {
            if let Some(c) = &mut st.system.contacts {
                c.start(&head0, &st.system.strand.geometry, &st.state.q);
            }
        }
        if sim.electrostatics.is_some() && sim.config.mode == Mode::Dynamic {
            sim.refresh_charges(0.0)?;
        }
        if sim.config.mode == Mode::Dynamic {
            // (with the Coulomb loads of t = 0)
            sim.start_held_reactions();
        }
        Ok(sim)
    }

    /// Every held tip's reaction with the strands at rest in their current state (what
    /// frame 0 of a dynamic run reports; [`Simulation::new`] calls it, call it again after
    /// [`Simulation::set_state`]): [`crate::solver::held_end::HeldTip::start_reaction`]
    /// with M and F at the current time. A strand whose M does not factor keeps its
    /// reaction.
    pub fn start_held_reactions(&mut self) {
        let at = Placement::new(self.head.state(self.time), self.time);
        if self.embedded.is_some() {
            // each held strand measured on a system of its own (the same closed forms),
            // its tip lent to it and taken back
            for i in 0..self.strand_count() {
                let Some(e) = &self.embedded else { return };
                let (_, _, g, p) = e.strands[i];
                let Some(tip) = e.groups[g].1.held(p).cloned() else {
                    continue;
                };
                let mut system = self.measuring_system(i);
                system.held = Some(tip);
                let (q, v) = (self.q(i).to_vec(), self.v(i).to_vec());
                let Some(e) = &mut self.embedded else { return };
                let group = &mut e.groups[g].1;
                // the contacts' forces at rest, as the runtime engine's assembly adds them
                let mut points = closed_form_kernel(&system.strand.geometry);
                let mut contacts = |force: &mut [f64]| {
                    group.add_contact_force(
                        p,
                        at.time,
                        &at.head,
                        &mut KernelPoints(points.as_mut()),
                        force,
                    )
                };
                start_reaction(&mut system, &at, &q, &v, Some(&mut contacts));
                if let (Some(tip), Some(slot)) = (system.held, group.held_mut(p)) {
                    *slot = tip;
                }
            }
            return;
        }
        for s in self.strands.iter_mut().filter(|s| s.system.held.is_some()) {
            start_reaction(&mut s.system, &at, &s.state.q, &s.state.v, None);
        }
    }

    /// The reaction of the holder on strand `i`'s held tip at the last step or static
    /// solve: force (N) then torque (N·m, clamped tips), world coordinates; `None` for a
    /// free tip.
    pub fn held_reaction(&self, i: usize) -> Option<nalgebra::Vector6<f64>> {
        if let Some(e) = &self.embedded {
            let (_, _, g, p) = e.strands.get(i)?;
            return e.groups[*g].1.held(*p).map(|h| h.reaction);
        }
        let s = self.strands.get(i)?;
        s.system.held.as_ref().map(|h| h.reaction)
    }

    /// The largest drift of strand `i`'s held tip from its holder since the last call
    /// (position off relative to the strand's length, frame off in radians), reset;
    /// `None` for a free tip.
    pub fn take_held_drift(&mut self, i: usize) -> Option<f64> {
        if let Some(e) = &mut self.embedded {
            let (_, _, g, p) = e.strands.get(i)?;
            let (g, p) = (*g, *p);
            return e.groups[g].1.held_mut(p).map(|h| h.take_drift());
        }
        let s = self.strands.get_mut(i)?;
        s.system.held.as_mut().map(|h| h.take_drift())
    }

    /// The electrostatic state, when the scene has `[electrostatics]`.
    pub fn electrostatics(&self) -> Option<&Electrostatics> {
        self.electrostatics.as_ref()
    }

    /// Mutable access to the electrostatic state (e.g. to set the charge scale).
    pub fn electrostatics_mut(&mut self) -> Option<&mut Electrostatics> {
        self.electrostatics.as_mut()
    }

    /// Recompute the Coulomb forces at the current state with the head at `head`, and
    /// make them the strands' electrostatic point loads (after the scene's own).
    pub fn update_electrostatics(
        &mut self,
        head: &crate::forces::head_motion::HeadState,
    ) -> std::result::Result<FieldSummary, String> {
        let points = self.charge_positions(head);
        self.update_electrostatics_with(head, self.time, points)
    }

    /// The charged particles' positions (world, m) with the head at `head`
    /// ([`Electrostatics::positions`]; empty without `[electrostatics]`).
    fn charge_positions(&self, head: &crate::forces::head_motion::HeadState) -> Vec<[f64; 3]> {
        let Some(e) = &self.electrostatics else {
            return Vec::new();
        };
        let strands: Vec<(&StrandGeometry, &[f64])> = match &self.embedded {
            Some(em) => em
                .strands
                .iter()
                .map(|(strand, _, g, p)| (&strand.geometry, em.groups[*g].1.q(*p)))
                .collect(),
            None => self
                .strands
                .iter()
                .map(|s| (&s.system.strand.geometry, &s.state.q[..]))
                .collect(),
        };
        e.positions(|i, arcs, out| {
            let (geometry, q) = strands[i];
            positions_at_sorted(geometry, q, arcs.iter().copied(), out);
            for y in out.iter_mut() {
                *y = head.position + head.rotation * *y;
            }
        })
    }

    /// [`Self::update_electrostatics`] at time `time` (the charged scalp's placement)
    /// with the particles at `points`
    /// ([`Self::charge_positions`] at `head`).
    fn update_electrostatics_with(
        &mut self,
        head: &crate::forces::head_motion::HeadState,
        time: f64,
        points: Vec<[f64; 3]>,
    ) -> std::result::Result<FieldSummary, String> {
        let Some(e) = &mut self.electrostatics else {
            return Ok(FieldSummary::default());
        };
        let scalp = e
            .config()
            .scalp
            .as_ref()
            .and_then(|sc| self.bodies.as_slice().iter().find(|b| b.name == sc.body))
            .map(|b| (b, b.frame(&Placement::new(*head, time))));
        let summary = e.update(points, time, (&head.position, &head.rotation), scalp)?;
        // the last steps' energies as the new forces count them (the balance's ceiling with
        // them): the change of the loads is not work the strands did
        if let Some(e) = &self.electrostatics {
            let changes: Vec<f64> = (0..self.strand_count())
                .map(|i| e.load_change(i, &head.position))
                .collect();
            if let Some(em) = &mut self.embedded {
                for (i, (_, _, g, p)) in em.strands.iter().enumerate() {
                    em.groups[*g].1.shift_load_energy(*p, changes[i]);
                }
            }
            for (sim, &change) in self.strands.iter_mut().zip(&changes) {
                sim.system.workspace.shift_load_energy(change);
            }
        }
        self.apply_charge_loads();
        Ok(summary)
    }

    /// [`Self::update_electrostatics`] with the head at time `t`, a failure as the run's
    /// error at `t`.
    fn refresh_charges(&mut self, t: f64) -> Result<()> {
        let head = self.head.state(t);
        let points = self.charge_positions(&head);
        self.refresh_charges_with(&head, t, points)
    }

    /// [`Self::refresh_charges`] with the particles at `points` ([`Self::charge_positions`]
    /// at `head`, the head at time `t`).
    fn refresh_charges_with(
        &mut self,
        head: &crate::forces::head_motion::HeadState,
        t: f64,
        points: Vec<[f64; 3]>,
    ) -> Result<()> {
        self.update_electrostatics_with(head, t, points)
            .map(|_| ())
            .map_err(|cause| Error::Diverged {
                strand: "(electrostatics)".into(),
                index: 0,
                time: t,
                cause,
            })
    }

    /// Make the Coulomb forces of the last electrostatic update each strand's point loads
    /// after the scene's own, on either engine.
    pub(crate) fn apply_charge_loads(&mut self) {
        let Some(e) = &self.electrostatics else {
            return;
        };
        if let Some(em) = &mut self.embedded {
            for (i, (strand, _, g, p)) in em.strands.iter_mut().enumerate() {
                let loads = &mut strand.point_loads;
                loads.truncate(em.scene_loads[i]);
                loads.extend(e.loads(i));
                em.groups[*g].1.set_loads(*p, loads);
            }
        }
        for (i, sim) in self.strands.iter_mut().enumerate() {
            let loads = &mut sim.system.strand.point_loads;
            loads.truncate(sim.scene_loads);
            loads.extend(e.loads(i));
        }
    }

    /// Advance every strand by one time step `dt` (in parallel over strands). On failure
    /// the error names the strand, the time and the cause, and the state is left at the
    /// last good step for the other strands.
    pub fn step(&mut self) -> Result<()> {
        self.step_by(self.config.dt)
    }

    /// Advance every strand by a step of `h` seconds (> 0, finite) instead of `dt`: what
    /// `[output] times` uses to end a step on a frame's time. The integrators take variable
    /// steps (BDF2 restarts from a linearly implicit Euler step after a step ratio above
    /// [`superhelix_kernels::fixed::BDF2_MAX_RATIO`]); errors as [`Self::step`]. The
    /// hair–hair pairs are searched at the step's start, and under a tolerance again
    /// within it as the strands move (`Self::advance_in_intervals`).
    pub fn step_by(&mut self, h: f64) -> Result<()> {
        if !(h.is_finite() && h > 0.0) {
            return Err(Error::invalid(
                "h",
                format!("a step of {h} s: the step must be a positive, finite time"),
            ));
        }
        let t = self.time;
        // under a tolerance the pairs and the charges follow the strands within the step
        let intervals = self.hair_hair.is_some() || self.electrostatics.is_some();
        // the Coulomb forces, every update_every steps, as point loads (either engine)
        if let Some(e) = &self.electrostatics {
            let every = e.config().update_every.max(1);
            if self.steps % every == 0 && self.steps > 0 && self.config.tolerance.is_none() {
                self.refresh_charges(t)?;
            }
        }
        match (self.config.tolerance, intervals) {
            (Some(tolerance), true) => self.advance_in_intervals(t, h, tolerance)?,
            _ => {
                let points = self.hair_hair.is_some().then(|| self.hair_points(t));
                self.advance(t, h, h, points)?;
            }
        }
        self.time = t + h;
        self.steps += 1;
        Ok(())
    }

    /// A step from `t` to `t + h` under `tolerance` with hair–hair contacts or
    /// `[electrostatics]`: in intervals, each strand taking its own error-controlled
    /// steps within each. A strand steps against its partners' points as they were at
    /// the last search and the charges' forces as they were at the last update, and a
    /// pair exists only once the search found it. So the intervals follow the motion, as
    /// the error-controlled step's steps do: the next is the last scaled so that over it
    ///
    /// - a paired sample moves at most 0.9 τ of the length of the strand on the pair's
    ///   other side ([`HairHair::partner_motion`]: what that strand's step missed of it),
    /// - no sample moves more than half the contacts' reach (two samples closing in
    ///   on each other were within the search's margin, at least the reach, at its start),
    ///
    /// at the rates of the last interval, between 0.2 and 2 times it, none shorter than
    /// [`MIN_SEARCH_INTERVAL`]; the last ends on `t + h` (a remainder shorter than two
    /// intervals is taken in two equal ones). The pairs are searched at every interval's
    /// start.
    ///
    /// The Coulomb forces keep their own schedule (`update_every` is for fixed steps): at
    /// an interval's start the particles are placed (cheap beside the sum over them) and
    /// the forces recomputed only when, at the rate the particles moved since the last
    /// update, some particle would stand more than 0.9 [`CHARGE_MOTION`] τ of its strand's
    /// length from where that update had it before the interval ends
    /// ([`Electrostatics::motion_since_update`], in the head's frame). After an update the
    /// interval is also bounded so that it would not (at the rate between the last two
    /// updates); without hair–hair contacts that bound alone sets the intervals.
    fn advance_in_intervals(&mut self, t: f64, h: f64, tolerance: f64) -> Result<()> {
        const SAFETY: f64 = 0.9;
        const SHRINK: f64 = 0.2;
        const GROW: f64 = 2.0;
        let end = t + h;
        let mut now = t;
        let lengths = self.strand_lengths();
        let reach = self.hair_reach();
        // the motion of the charges (in CHARGE_MOTION τ L) an update allows
        let allowed = SAFETY * tolerance;
        while end - now > 1e-12 * end.abs().max(1.0) {
            let start = std::time::Instant::now();
            let mut motion: f64 = 0.0;
            let mut fastest = 0.0;
            let mut points = None;
            let mut interval = None;
            if self.hair_hair.is_some() {
                let at = self.hair_points(now);
                if let Some(hh) = &self.hair_hair {
                    motion = hh.partner_motion(&at, &lengths);
                    fastest = hh.fastest_motion(&at);
                    interval = Some(hh.interval);
                }
                points = Some(at);
            }
            self.hair_pair_seconds += start.elapsed().as_secs_f64();
            if let (None, Some(e)) = (interval, &self.electrostatics) {
                interval = Some(e.interval);
            }
            let Some(SearchInterval { last, proposed }) = interval else {
                break;
            };
            let mut next = if last > 0.0 {
                // the motion over the last interval at the rate it had, within the growth
                // of the interval it was chosen as (a last interval cut to end on a step
                // moved less for being shorter)
                let reference = last.max(proposed);
                let mut wanted = f64::INFINITY;
                if motion > 0.0 {
                    wanted = SAFETY * tolerance * last / motion;
                }
                if fastest > 0.0 {
                    // no sample moves more than half the reach: two that close in on
                    // each other within an interval were within the search's margin
                    // (at least the reach) at its start, and are paired
                    wanted = wanted.min(0.5 * reach * last / fastest);
                }
                wanted.clamp(SHRINK * last, GROW * reference)
            } else {
                h
            };
            // the Coulomb forces: recomputed when the charges would move too far before
            // the interval ends
            if self.electrostatics.is_some() {
                let head = self.head.state(now);
                let at = self.charge_positions(&head);
                let (due, rate) = match &self.electrostatics {
                    Some(e) => {
                        let moved = e.motion_since_update(&at, &head.position, &head.rotation)
                            / CHARGE_MOTION;
                        let rate = match e.updated_at() {
                            Some(then) if now > then => moved / (now - then),
                            _ => e.rate() / CHARGE_MOTION,
                        };
                        (
                            e.updated_at().is_none() || moved + rate * next > allowed,
                            rate,
                        )
                    }
                    None => (false, 0.0),
                };
                if due {
                    self.refresh_charges_with(&head, now, at)?;
                    // the next update as far off as the rate between the last two allows
                    let rate = self
                        .electrostatics
                        .as_ref()
                        .map_or(rate, |e| e.rate() / CHARGE_MOTION);
                    if rate > 0.0 && last > 0.0 {
                        next = next.min((allowed / rate).max(SHRINK * last));
                    }
                }
            }
            let next = next.max(MIN_SEARCH_INTERVAL);
            let (step, landing) = superhelix_kernels::fixed::step_within(next, end - now);
            let since = if last > 0.0 { last } else { step };
            let interval = SearchInterval {
                last: step,
                proposed: next,
            };
            if let Some(hh) = &mut self.hair_hair {
                hh.interval = interval;
            }
            if let Some(e) = &mut self.electrostatics {
                e.interval = interval;
            }
            self.advance(now, step, since, points)?;
            now = if landing { end } else { now + step };
        }
        Ok(())
    }

    /// The reach of the hair–hair contacts (twice the largest hair volume radius), m.
    fn hair_reach(&self) -> f64 {
        match &self.embedded {
            Some(e) => e
                .groups
                .iter()
                .filter_map(|(_, g)| g.hair_reach())
                .fold(0.0, f64::max),
            None => self
                .strands
                .iter()
                .filter_map(|s| {
                    s.system
                        .contacts
                        .as_ref()?
                        .hair_params()
                        .map(|p| 2.0 * p.radius)
                })
                .fold(0.0, f64::max),
        }
    }

    /// The length of every strand, in the scene's order, m.
    fn strand_lengths(&self) -> Vec<f64> {
        match &self.embedded {
            Some(e) => e.strands.iter().map(|s| s.0.geometry.length()).collect(),
            None => self
                .strands
                .iter()
                .map(|s| s.system.strand.geometry.length())
                .collect(),
        }
    }

    /// One step of every strand from `t` to `t + h`, the hair–hair pairs searched first at
    /// `points` (the samples' positions at `t`, [`Self::hair_points`]), the last search
    /// `since` seconds earlier.
    fn advance(
        &mut self,
        t: f64,
        h: f64,
        since: f64,
        points: Option<Vec<Vec<nalgebra::Vector3<f64>>>>,
    ) -> Result<()> {
        if let Some(points) = points {
            // the pairs at the step's start, for either engine's strands
            let start = std::time::Instant::now();
            if self.embedded.is_some() {
                self.update_embedded_hair_pairs(t, (h, since), points);
            } else {
                self.update_hair_pairs(t, (h, since), points);
            }
            self.hair_pair_seconds += start.elapsed().as_secs_f64();
        }
        if let Some(e) = &mut self.embedded {
            let effects = superhelix_kernels::fixed::Effects {
                gravity: e.gravity,
                head_moves: e.head_moves,
            };
            let tolerance = self.config.tolerance;
            for (g, (_, group)) in e.groups.iter_mut().enumerate() {
                let mut report = Default::default();
                let failure = group.step(
                    &self.head,
                    &effects,
                    t,
                    h,
                    tolerance,
                    &mut e.counts,
                    &mut report,
                );
                e.tolerance_total.add(&report);
                e.tolerance_window.add(&report);
                if let Some((position, cause)) = failure {
                    let index = e
                        .strands
                        .iter()
                        .position(|s| s.2 == g && s.3 == position)
                        .unwrap_or(0);
                    return Err(Error::Diverged {
                        strand: e.strands[index].0.name.clone(),
                        index,
                        time: t + h,
                        cause,
                    });
                }
            }
            if e.coupled {
                let pairs = self.hair_hair.as_ref().map_or(0, |hh| hh.pairs().len());
                let at_end = Placement::new(self.head.state(t + h), t + h);
                if let Some((index, cause)) = e.solve_coupled_pairs(pairs, &at_end, h) {
                    return Err(Error::Diverged {
                        strand: e.strands[index].0.name.clone(),
                        index,
                        time: t + h,
                        cause,
                    });
                }
            }
            return Ok(());
        }
        let interval = HeadInterval::new(&self.head, t, h);
        // the coupled hair–hair pairs are solved after every strand's step, before the
        // contacts' bookkeeping of the step's end
        let coupled = self.hair_hair.is_some()
            && self.strands.iter().any(|s| {
                s.system
                    .contacts
                    .as_ref()
                    .and_then(|c| c.hair_params())
                    .is_some_and(|p| p.coupled)
            });
        let at_end = interval.at_end();
        let mut failure = self
            .strands
            .par_iter_mut()
            .enumerate()
            .map(|(i, s)| {
                let outcome = step(&mut s.system, &interval, &mut s.state, &mut s.stats);
                if coupled && outcome.is_ok() {
                    let mut strand = pair_coupling::RuntimeStrand {
                        system: &mut s.system,
                        state: &mut s.state,
                    };
                    pair_coupling::strand_ends(&mut strand, &at_end, &mut s.sides);
                }
                // (the one step does the contacts' bookkeeping of its end itself)
                if !coupled && outcome.is_ok() && !crate::solver::one_step::covers(&s.system) {
                    if let Some(c) = &mut s.system.contacts {
                        c.after_step(&at_end, &s.system.strand.geometry, &s.state.q, h);
                    }
                }
                outcome.err().map(|cause| (i, cause))
            })
            .flatten()
            .min_by_key(|(i, _)| *i);
        if coupled && failure.is_none() {
            failure = self.solve_coupled_pairs(&at_end, h);
        }
        if let Some((index, cause)) = failure {
            return Err(Error::Diverged {
                strand: self.strands[index].system.strand.name.clone(),
                index,
                time: t + h,
                cause,
            });
        }
        Ok(())
    }

    /// The coupled hair–hair pairs of a step of `h` whose strands have all stepped
    /// (`crate::solver::pair_coupling`): their ends, the pairs that touch, each strand's
    /// responses, the pairs' forces, applied to every strand; then the contacts'
    /// bookkeeping of the step's end (`at_end`). The first failure: (strand, cause).
    fn solve_coupled_pairs(&mut self, at_end: &Placement, h: f64) -> Option<(usize, String)> {
        let pairs = self.hair_hair.as_ref().map_or(0, |hh| hh.pairs().len());
        let mut sides: Vec<pair_coupling::StrandSides> = self
            .strands
            .iter_mut()
            .map(|s| std::mem::take(&mut s.sides))
            .collect();
        let chosen = pair_coupling::select(&mut sides, pairs);
        let failure = self
            .strands
            .par_iter_mut()
            .zip(sides.par_iter_mut())
            .enumerate()
            .map(|(i, (s, sides))| {
                let mut strand = pair_coupling::RuntimeStrand {
                    system: &mut s.system,
                    state: &mut s.state,
                };
                pair_coupling::strand_responses(&mut strand, at_end, h, &mut s.stats, sides)
                    .err()
                    .map(|cause| (i, cause))
            })
            .flatten()
            .min_by_key(|(i, _)| *i);
        if failure.is_some() {
            return failure;
        }
        if pair_coupling::solve(&mut sides, &chosen).is_none() {
            for (s, sides) in self.strands.iter_mut().zip(&sides) {
                s.stats.pairs_unresolved += sides.responses();
            }
        }
        self.strands
            .par_iter_mut()
            .zip(sides)
            .enumerate()
            .map(|(i, (s, sides))| {
                let mut strand = pair_coupling::RuntimeStrand {
                    system: &mut s.system,
                    state: &mut s.state,
                };
                let outcome = pair_coupling::apply(&mut strand, &sides, at_end, &mut s.stats);
                if outcome.is_ok() {
                    strand.end_contacts(at_end, h);
                }
                s.sides = sides;
                outcome.err().map(|cause| (i, cause))
            })
            .flatten()
            .min_by_key(|(i, _)| *i)
    }

    /// Every strand's contact samples at the state of time `t` (the head there), world
    /// coordinates, in the scene's order: what the hair–hair search pairs.
    fn hair_points(&mut self, t: f64) -> Vec<Vec<nalgebra::Vector3<f64>>> {
        let head = self.head.state(t);
        if let Some(e) = &mut self.embedded {
            let mut by_group: Vec<Vec<Vec<nalgebra::Vector3<f64>>>> = e
                .groups
                .iter()
                .map(|(_, g)| g.sample_positions(&head))
                .collect();
            return e
                .strands
                .iter()
                .map(|s| std::mem::take(&mut by_group[s.2][s.3]))
                .collect();
        }
        self.strands
            .par_iter_mut()
            .map(|s| match &mut s.system.contacts {
                Some(c) => {
                    c.sample_poses(&s.system.strand.geometry, &s.state.q);
                    c.sample_positions()
                        .map(|y| head.position + head.rotation * y)
                        .collect()
                }
                None => Vec::new(),
            })
            .collect()
    }

    /// Track and search the hair–hair pairs at the state of time `t` (head there) and give
    /// each strand its partner points for the step of length `h`.
    fn update_hair_pairs(
        &mut self,
        t: f64,
        (h, since): (f64, f64),
        points: Vec<Vec<nalgebra::Vector3<f64>>>,
    ) {
        let head = self.head.state(t);
        let reach = self.hair_reach();
        let Some(hh) = &mut self.hair_hair else {
            return;
        };
        let fall = self
            .strands
            .first()
            .and_then(|s| s.system.context.effects.gravity)
            .map_or(0.0, |g| g.norm() * h * h);
        let arcs: Vec<&[(f64, f64)]> = self
            .strands
            .iter()
            .map(|s| s.system.contacts.as_ref().map_or(&[][..], |c| c.samples()))
            .collect();
        hh.update(&points, &arcs, reach, (h, since), fall, &head.rotation);
        drop(arcs);
        // (each strand's list written in parallel, in arc-length order)
        let hh = &*hh;
        self.strands.par_iter_mut().enumerate().for_each(|(i, s)| {
            if let Some(c) = &mut s.system.contacts {
                hh.fill_partners(i, &points, c.partners_mut());
            }
        });
    }

    /// [`Self::update_hair_pairs`] on the embedded engine: the samples of every strand
    /// at the state of time `t` (the groups' order put back into the scene's), the pairs
    /// tracked and searched, each strand handed its partner points.
    fn update_embedded_hair_pairs(
        &mut self,
        t: f64,
        (h, since): (f64, f64),
        points: Vec<Vec<nalgebra::Vector3<f64>>>,
    ) {
        let reach = self.hair_reach();
        let (Some(e), Some(hh)) = (&mut self.embedded, &mut self.hair_hair) else {
            return;
        };
        let head = self.head.state(t);
        let fall = e.gravity.map_or(0.0, |g| g.norm() * h * h);
        let arcs: Vec<&[(f64, f64)]> = e
            .strands
            .iter()
            .map(|s| e.groups[s.2].1.samples(s.3))
            .collect();
        hh.update(&points, &arcs, reach, (h, since), fall, &head.rotation);
        drop(arcs);
        // each group's strands' lists written in parallel, in arc-length order (a
        // group's strand p is the scene's strand scene[g][p])
        let mut scene: Vec<Vec<usize>> = e.groups.iter().map(|(_, g)| vec![0; g.len()]).collect();
        for (i, s) in e.strands.iter().enumerate() {
            scene[s.2][s.3] = i;
        }
        let hh = &*hh;
        for ((_, group), scene) in e.groups.iter_mut().zip(&scene) {
            group.fill_partners(&|p, out| hh.fill_partners(scene[p], &points, out));
        }
    }

    /// How many hair–hair pairs hold a friction anchor, and how many of those slid over
    /// the last step (`None`: no hair–hair interaction).
    pub fn rod_friction_anchors(&self) -> Option<(usize, usize)> {
        self.hair_hair.as_ref().map(|h| h.anchor_counts())
    }

    /// What the contacts of strand `i` found at its last evaluation (`None`: the scene has
    /// no `[contacts]`).
    pub fn contact_summary(&self, i: usize) -> Option<ContactSummary> {
        if let Some(e) = &self.embedded {
            let (_, _, g, p) = e.strands.get(i)?;
            let (s, hair) = e.groups[*g].1.contact_summary(*p)?;
            return Some(ContactSummary {
                body_contacts: s.contacts,
                hair_contacts: hair,
                max_penetration: s.max_penetration,
                normal_force: s.normal_force,
            });
        }
        self.strands
            .get(i)?
            .system
            .contacts
            .as_ref()
            .map(|c| c.summary())
    }

    /// The deepest point of any strand's centreline inside a body at the current state,
    /// m (0: none; `None`: no `[contacts]`), with the head and the bodies at the current
    /// time, on a dense sweep of each centreline
    /// ([`StrandContacts::deepest_inside`](crate::forces::contacts::StrandContacts::deepest_inside)).
    pub fn max_penetration(&mut self) -> Option<f64> {
        if let Some(e) = &mut self.embedded {
            let (t, head) = (self.time, self.head.state(self.time));
            return e
                .groups
                .iter_mut()
                .filter_map(|(_, g)| g.deepest_inside(t, &head))
                .reduce(f64::max);
        }
        let head = Placement::new(self.head.state(self.time), self.time);
        // (the strands in parallel)
        self.strands
            .par_iter_mut()
            .filter_map(|s| {
                let c = s.system.contacts.as_mut()?;
                Some(c.deepest_inside(&head, &s.system.strand.geometry, &s.state.q))
            })
            .reduce_with(f64::max)
    }

    /// What the error-controlled step did so far (`None`: the scene has no tolerance).
    pub fn error_control(&self) -> Option<crate::output::ErrorControlSummary> {
        let tolerance = self.config.tolerance?;
        let per_strand = self.strand_steps()?;
        let (largest_error, smallest) = per_strand.iter().enumerate().fold(
            (0.0f64, None::<(usize, f64)>),
            |(e, small), (i, s)| {
                let small = match small {
                    Some((_, h)) if s.smallest_step <= 0.0 || h <= s.smallest_step => small,
                    _ if s.smallest_step > 0.0 => Some((i, s.smallest_step)),
                    _ => small,
                };
                (e.max(s.largest_error), small)
            },
        );
        let stats = self.stats();
        Some(crate::output::ErrorControlSummary {
            tolerance,
            largest_error,
            smallest_step: smallest.map_or(0.0, |(_, h)| h),
            smallest_step_strand: smallest.map(|(i, _)| i),
            steps: stats.error_steps,
            rejected: stats.error_rejected,
            rejected_deep: stats.error_rejected_deep,
        })
    }

    /// What the error-controlled step did so far, per strand in scene order (`None`: the
    /// scene has no tolerance).
    pub fn strand_steps(&self) -> Option<Vec<crate::output::StrandSteps>> {
        self.config.tolerance?;
        let steps = match &self.embedded {
            Some(e) => e
                .strands
                .iter()
                .map(|(_, _, g, position)| {
                    let r = e.groups[*g].1.strand_report(*position);
                    r.map_or_else(Default::default, |r| crate::output::StrandSteps {
                        steps: r.steps,
                        rejected: r.rejected,
                        largest_error: r.largest_error,
                        smallest_step: r.smallest_step,
                        largest_step: r.largest_step,
                    })
                })
                .collect(),
            None => self
                .strands
                .iter()
                .map(|s| {
                    let ec = s.system.workspace.error_control();
                    crate::output::StrandSteps {
                        steps: s.stats.error_steps,
                        rejected: s.stats.error_rejected,
                        largest_error: ec.largest_error,
                        smallest_step: ec.smallest_h,
                        largest_step: ec.largest_h,
                    }
                })
                .collect(),
        };
        Some(steps)
    }

    /// What the error-controlled step did since the last call (or the start), all strands
    /// (`None`: the scene has no tolerance).
    pub fn frame_steps(&mut self) -> Option<crate::output::FrameSteps> {
        self.config.tolerance?;
        if let Some(e) = &mut self.embedded {
            let r = std::mem::take(&mut e.tolerance_window);
            return Some(crate::output::FrameSteps {
                largest_error: r.largest_error,
                steps: r.steps,
                rejected: r.rejected,
                smallest_step: r.smallest_step,
                largest_step: r.largest_step,
            });
        }
        let window = self
            .strands
            .iter_mut()
            .map(|s| s.system.workspace.error_control_mut().take_window())
            .fold(Default::default(), |a: crate::solver::StepWindow, b| {
                a.merge(&b)
            });
        let stats = self.stats();
        let (steps, rejected) = self.reported_steps;
        self.reported_steps = (stats.error_steps, stats.error_rejected);
        Some(crate::output::FrameSteps {
            largest_error: window.largest_error,
            steps: stats.error_steps - steps,
            rejected: stats.error_rejected - rejected,
            smallest_step: window.smallest_h,
            largest_step: window.largest_h,
        })
    }

    /// The contact potential of strand `i` at its current state, the head and the bodies
    /// at the current time, J (0 without `[contacts]`).
    pub fn contact_potential(&mut self, i: usize) -> f64 {
        let head = Placement::new(self.head.state(self.time), self.time);
        let Some(s) = self.strands.get_mut(i) else {
            return 0.0;
        };
        match &mut s.system.contacts {
            Some(c) => c.energy(&head, &s.system.strand.geometry, &s.state.q).0,
            None => 0.0,
        }
    }

    /// The hair–hair pairs of the last step (`None`: no hair–hair interaction).
    pub fn hair_pairs(&self) -> Option<PairCounts> {
        self.hair_hair.as_ref().map(|h| h.counts())
    }

    /// The wall time the hair–hair pairs' tracking and search (the broad phase, before
    /// each step) took over the steps so far, s (`None`: no hair–hair interaction).
    pub fn hair_pair_seconds(&self) -> Option<f64> {
        self.hair_hair.as_ref().map(|_| self.hair_pair_seconds)
    }

    /// Solve every strand's static equilibrium in place (gravity and point loads, head at
    /// rest); with `[electrostatics]`, the charged equilibrium of
    /// [`Simulation::solve_charged_static`].
    pub fn solve_static(&mut self) -> Result<Vec<StaticReport>> {
        if self.hair_hair.is_some() {
            return Err(Error::invalid("contacts.hair_hair", STATIC_HAIR_HAIR));
        }
        self.check_potential_loads()?;
        if self.electrostatics.is_some() {
            return self.solve_charged_static().map(|r| r.strands);
        }
        self.solve_static_strands()
    }

    /// The generalized force F(q) at zero velocity of strand `i`, head at rest: elasticity,
    /// gravity and its point loads (the scene's and the electrostatic ones).
    pub fn static_force(&mut self, i: usize) -> Vec<f64> {
        let rest = Placement::at_rest(0.0);
        let terms = crate::kernels::kernel::Terms {
            force: true,
            ..Default::default()
        };
        if self.embedded.is_some() {
            let mut system = self.measuring_system(i);
            let q = self.q(i).to_vec();
            let zero = vec![0.0; q.len()];
            system.assemble(&rest, &q, &zero, terms);
            return system.workspace.terms.force.clone();
        }
        let s = &mut self.strands[i];
        let zero = vec![0.0; s.state.q.len()];
        s.system.assemble(&rest, &s.state.q, &zero, terms);
        s.system.workspace.terms.force.clone()
    }

    /// The largest generalized force `‖F(q)‖∞` of each strand at rest (elasticity, gravity
    /// and the current point loads), head at rest.
    fn static_forces(&mut self) -> Vec<f64> {
        if self.embedded.is_some() {
            return (0..self.strand_count())
                .map(|i| {
                    self.static_force(i)
                        .iter()
                        .fold(0.0, |m: f64, f| m.max(f.abs()))
                })
                .collect();
        }
        let rest = Placement::at_rest(0.0);
        let terms = crate::kernels::kernel::Terms {
            force: true,
            ..Default::default()
        };
        self.strands
            .par_iter_mut()
            .map(|s| {
                let zero = vec![0.0; s.state.q.len()];
                s.system.assemble(&rest, &s.state.q, &zero, terms);
                s.system
                    .workspace
                    .terms
                    .force
                    .iter()
                    .fold(0.0, |m: f64, f| m.max(f.abs()))
            })
            .collect()
    }

    /// The charged static equilibrium (paper section 4): Newton on every strand with the
    /// exact elastic and gravity stiffness and the Coulomb forces held as dead loads, the
    /// forces refreshed in an outer iteration. The charge is brought up in
    /// `charging_steps` steps (1: at once; n: the fraction `ln(1 + k)/ln(1 + n)` at step
    /// k). The outer iteration is accelerated (Anderson, depth 5, on the strands'
    /// coordinates). Each step's outer iteration ends when every strand's `‖F(q)‖∞` with forces
    /// refreshed at its configuration is at most `tolerance` times its force scale (the
    /// largest of gravity's, elasticity's and the Coulomb generalized force at the start).
    pub fn solve_charged_static(&mut self) -> Result<ChargedStaticReport> {
        let Some(e) = &self.electrostatics else {
            return Err(Error::invalid(
                "electrostatics",
                "the scene has no [electrostatics]",
            ));
        };
        let c = e.config().clone();
        let rest = Placement::at_rest(0.0);
        let fail = |cause: String, time: f64| Error::Diverged {
            strand: "(electrostatics)".into(),
            index: 0,
            time,
            cause,
        };
        let mut report = ChargedStaticReport::default();
        let mut scale: Option<Vec<f64>> = None;
        let steps = c.charging_steps.max(1);
        for k in 1..=steps {
            let fraction = if steps == 1 {
                1.0
            } else {
                (1.0 + k as f64).ln() / (1.0 + steps as f64).ln()
            };
            if let Some(e) = &mut self.electrostatics {
                e.set_charge_scale(fraction);
            }
            let mut stage = ChargingStage {
                charge_fraction: fraction,
                ..Default::default()
            };
            let mut anderson = Anderson::new(ANDERSON_DEPTH);
            for iteration in 0..=c.max_iterations {
                stage.field = self
                    .update_electrostatics(&rest.head)
                    .map_err(|e| fail(e, self.time))?;
                let forces = self.static_forces();
                let scale =
                    scale.get_or_insert_with(|| forces.iter().map(|f| f.max(1e-300)).collect());
                stage.residual = forces
                    .iter()
                    .zip(scale.iter())
                    .map(|(f, s)| f / s)
                    .fold(0.0, f64::max);
                stage.iterations = iteration;
                if iteration > 0 && stage.residual <= c.tolerance {
                    stage.converged = true;
                    break;
                }
                if iteration == c.max_iterations {
                    break;
                }
                let x = self.all_q();
                // a strand whose static solve fails under the charge: name what to change
                report.strands = self.solve_static_strands().map_err(|e| match e {
                    Error::Diverged {
                        strand,
                        index,
                        time,
                        cause,
                    } => Error::Diverged {
                        strand,
                        index,
                        time,
                        cause: format!(
                            "{cause}, at {:.0} % of the charge: the Coulomb forces of electrostatics.charge_per_length ({:e} C/m on it) overcome the strand's stiffness; lower the charge, raise charging_steps, or run mode = \"dynamic\"",
                            100.0 * fraction,
                            c.charge_per_length.get(index).copied().unwrap_or(0.0)
                        ),
                    },
                    other => other,
                })?;
                let g = self.all_q();
                let next = anderson.next(&x, &g);
                let mut at = 0;
                for i in 0..self.strand_count() {
                    let n = self.q(i).len();
                    let q = &next[at..at + n];
                    match &mut self.embedded {
                        Some(_) => {
                            let v = self.v(i).to_vec();
                            self.set_state(i, q, &v);
                        }
                        None => self.strands[i].state.q.copy_from_slice(q),
                    }
                    at += n;
                }
            }
            report.stages.push(stage);
        }
        Ok(report)
    }

    /// Every strand's q, one after the other.
    fn all_q(&self) -> Vec<f64> {
        (0..self.strand_count())
            .flat_map(|i| self.q(i).iter().copied())
            .collect()
    }

    /// Every strand's equilibrium with its current loads.
    fn solve_static_strands(&mut self) -> Result<Vec<StaticReport>> {
        if self.embedded.is_some() {
            return self.solve_static_embedded();
        }
        let reports: Vec<std::result::Result<StaticReport, (usize, String)>> = self
            .strands
            .par_iter_mut()
            .enumerate()
            .map(|(i, s)| {
                s.system.workspace.forget_history();
                let r = solve_static(&mut s.system, &mut s.state.q);
                let finite = s.state.q.iter().all(|x| x.is_finite());
                match r {
                    Ok(rep) if finite => Ok(rep),
                    Ok(_) => Err((i, "static solve produced non-finite q".to_string())),
                    Err(e) => Err((i, e)),
                }
            })
            .collect();
        reports
            .into_iter()
            .map(|r| {
                r.map_err(|(index, cause)| Error::Diverged {
                    strand: self.strands[index].system.strand.name.clone(),
                    index,
                    time: self.time,
                    cause,
                })
            })
            .collect()
    }

    /// [`Self::solve_static_strands`] for the embedded engine: each strand's equilibrium
    /// by the runtime's static solve on a system built for it alone (the moment kernel on
    /// the same closed forms), q set to it as the runtime engine sets it. Nothing is kept.
    fn solve_static_embedded(&mut self) -> Result<Vec<StaticReport>> {
        let mut reports = Vec::with_capacity(self.strand_count());
        for i in 0..self.strand_count() {
            let mut system = self.measuring_system(i);
            // the held tip as the group holds it (its holder where it is now)
            let (group, place) = self
                .embedded
                .as_ref()
                .map_or((0, 0), |e| (e.strands[i].2, e.strands[i].3));
            system.held = self
                .embedded
                .as_ref()
                .and_then(|e| e.groups[group].1.held(place).cloned());
            let mut q = self.q(i).to_vec();
            let r = solve_static(&mut system, &mut q);
            let outcome = match r {
                Ok(rep) if q.iter().all(|x| x.is_finite()) => Ok(rep),
                Ok(_) => Err("static solve produced non-finite q".to_string()),
                Err(e) => Err(e),
            };
            match outcome {
                Ok(rep) => {
                    let v = self.v(i).to_vec();
                    self.set_state(i, &q, &v);
                    // the holder's reaction at the equilibrium
                    if let (Some(solved), Some(e)) = (system.held.take(), &mut self.embedded) {
                        if let Some(tip) = e.groups[group].1.held_mut(place) {
                            *tip = solved;
                        }
                    }
                    reports.push(rep);
                }
                Err(cause) => {
                    return Err(Error::Diverged {
                        strand: self.strand(i).name.clone(),
                        index: i,
                        time: self.time,
                        cause,
                    })
                }
            }
        }
        Ok(reports)
    }

    /// The scene's bodies placed at the current time (the head in its state then):
    /// signed distances, normals and closest points of world points. Empty when the scene
    /// has no bodies.
    pub fn bodies(&self) -> PlacedBodies<'_> {
        self.bodies.at(self.head.state(self.time), self.time)
    }

    /// Simulated time, seconds.
    pub fn time(&self) -> f64 {
        self.time
    }
    /// Steps taken.
    pub fn steps(&self) -> usize {
        self.steps
    }
    /// The run settings.
    pub fn config(&self) -> &SimulationConfig {
        &self.config
    }
    /// Centreline points per element in outputs.
    pub fn samples_per_element(&self) -> usize {
        self.samples_per_element
    }
    /// Number of strands.
    pub fn strand_count(&self) -> usize {
        match &self.embedded {
            Some(e) => e.strands.len(),
            None => self.strands.len(),
        }
    }
    /// Strand i.
    pub fn strand(&self, i: usize) -> &Strand {
        match &self.embedded {
            Some(e) => &e.strands[i].0,
            None => &self.strands[i].system.strand,
        }
    }
    /// Generalized coordinates of strand i.
    pub fn q(&self, i: usize) -> &[f64] {
        match &self.embedded {
            Some(e) => {
                let (_, _, g, p) = &e.strands[i];
                e.groups[*g].1.q(*p)
            }
            None => &self.strands[i].state.q,
        }
    }
    /// Generalized velocities of strand i.
    pub fn v(&self, i: usize) -> &[f64] {
        match &self.embedded {
            Some(e) => {
                let (_, _, g, p) = &e.strands[i];
                e.groups[*g].1.v(*p)
            }
            None => &self.strands[i].state.v,
        }
    }
    /// Gravity now (world coordinates, m/s²; `None`: none).
    pub fn gravity(&self) -> Option<nalgebra::Vector3<f64>> {
        match &self.embedded {
            Some(e) => e.gravity,
            None => self
                .strands
                .first()
                .and_then(|s| s.system.context.effects.gravity),
        }
    }

    /// Change gravity from now on (world coordinates, m/s²; `None`: none) for every
    /// strand, in the steps and the static solves alike: a load a study ramps or turns
    /// between two steps. The potential changes at once, which is no work the strands did:
    /// each strand's energy balance and step history start afresh from its state.
    pub fn set_gravity(&mut self, gravity: Option<nalgebra::Vector3<f64>>) {
        self.put_gravity(gravity);
        if let Some(e) = &mut self.embedded {
            for k in 0..e.strands.len() {
                let (_, _, g, p) = e.strands[k];
                let group = &mut e.groups[g].1;
                let (q, v) = (group.q(p).to_vec(), group.v(p).to_vec());
                // (the group forgets the strand's energy and history with it)
                group.set_state(p, &q, &v);
            }
            return;
        }
        for s in &mut self.strands {
            s.system.workspace.forget_history();
            s.system.workspace.forget_energy();
        }
    }

    /// Drive the head from the caller from now on: `state` is its pose and rates at
    /// time `at` (`None`: now), and the head moves on from it with constant acceleration
    /// and angular acceleration ([`HeadMotion::Driven`]) until the next call, in place of
    /// the scene's `[head] motion`. A head pose given between steps, as an engine gives
    /// its character's: the strands' coordinates are the head's, so a pose that jumps
    /// carries them with it; the velocities, accelerations, ω and α (head coordinates,
    /// as [`HeadState`](crate::HeadState)) make the fictitious forces of the steps. The
    /// rotation must be orthonormal and right-handed to 1e-9, the position within ±10⁴
    /// m, the rates finite. Each strand's energy balance starts afresh (the head did
    /// work on it); the integrators' histories are kept.
    pub fn set_head(&mut self, state: crate::HeadState, at: Option<f64>) -> Result<()> {
        let r = state.rotation;
        let off = (r.transpose() * r - nalgebra::Matrix3::identity())
            .abs()
            .max();
        if !(off <= 1e-9 && (r.determinant() - 1.0).abs() <= 1e-9) {
            return Err(Error::invalid(
                "rotation",
                "must be a rotation: orthonormal columns, determinant 1 (to 1e-9)",
            ));
        }
        if !state
            .position
            .iter()
            .all(|x| x.is_finite() && x.abs() <= 1e4)
        {
            return Err(Error::invalid(
                "position",
                "each coordinate must be finite, within ±1e4 m",
            ));
        }
        for (name, v) in [
            ("velocity", state.velocity),
            ("acceleration", state.acceleration),
            ("omega", state.omega),
            ("alpha", state.alpha),
        ] {
            if !v.iter().all(|x| x.is_finite() && x.abs() <= 1e6) {
                return Err(Error::invalid(
                    name,
                    "each component must be finite, within ±1e6 (SI units)",
                ));
            }
        }
        let t0 = at.unwrap_or(self.time);
        if !(t0.is_finite() && (t0 - self.time).abs() <= 1e6) {
            return Err(Error::invalid(
                "time",
                format!("{t0}: must be finite, within 1e6 s of now ({})", self.time),
            ));
        }
        if (0..self.strand_count()).any(|i| self.holder(i).is_some()) {
            return Err(Error::invalid(
                "head",
                "a held tip needs a still head: the scene's held tips keep the head where it is",
            ));
        }
        self.put_driven_head(t0, state);
        if let Some(e) = &mut self.embedded {
            for k in 0..e.strands.len() {
                let (_, _, g, p) = e.strands[k];
                e.groups[g].1.forget_energy(p);
            }
        }
        for s in &mut self.strands {
            s.system.workspace.forget_energy();
        }
        Ok(())
    }

    /// The head's state now: the scene's motion, or the caller's
    /// ([`Simulation::set_head`]).
    pub fn head_state(&self) -> crate::HeadState {
        self.head.state(self.time)
    }

    /// The head driven from `state` at `t0` ([`HeadMotion::Driven`]), its fictitious
    /// forces built from now on; nothing else changed (a restored state).
    pub(crate) fn put_driven_head(&mut self, t0: f64, state: crate::HeadState) {
        self.head = HeadMotion::Driven {
            t0,
            state: Box::new(state),
        };
        if let Some(e) = &mut self.embedded {
            e.head_moves = true;
        }
        for s in &mut self.strands {
            s.system.context.effects.head_moves = true;
        }
    }

    /// Gravity from now on, on either engine, the strands' histories left as they are
    /// (a restored state, or [`Self::set_gravity`] before it forgets them).
    pub(crate) fn put_gravity(&mut self, gravity: Option<nalgebra::Vector3<f64>>) {
        if let Some(e) = &mut self.embedded {
            e.gravity = gravity;
        }
        for s in &mut self.strands {
            s.system.context.effects.gravity = gravity;
        }
    }

    /// `Err` naming the first load without a potential (a follower load, a couple): the
    /// static solves minimise the energy.
    fn check_potential_loads(&self) -> Result<()> {
        for i in 0..self.strand_count() {
            for (k, l) in self.point_loads(i).iter().enumerate() {
                let field = if l.follows {
                    "follows"
                } else if l.torque != nalgebra::Vector3::zeros() {
                    "torque"
                } else {
                    continue;
                };
                return Err(Error::invalid(
                    format!("strands[{i}].point_loads[{k}].{field}"),
                    "a follower load or a couple has no potential, and a static solve minimises the energy: step with internal friction until the strand is at rest",
                ));
            }
        }
        Ok(())
    }

    /// `Ok` when strand `i` exists, else an error naming the strand count.
    fn check_strand(&self, i: usize) -> Result<()> {
        let count = self.strand_count();
        if i < count {
            Ok(())
        } else {
            Err(Error::invalid(
                "strand",
                format!("{i}: the simulation has {count} strand(s)"),
            ))
        }
    }

    /// Put strand i's holder at (position, frame) as a restored state had it, nothing
    /// else changed (`Err`: the tip is not held).
    pub(crate) fn put_holder(
        &mut self,
        i: usize,
        position: nalgebra::Vector3<f64>,
        frame: nalgebra::Matrix3<f64>,
    ) -> std::result::Result<(), ()> {
        let tip = match &mut self.embedded {
            Some(e) => {
                let (_, _, g, p) = e.strands[i];
                e.groups[g].1.held_mut(p)
            }
            None => self.strands[i].system.held.as_mut(),
        };
        let tip = tip.ok_or(())?;
        tip.end.position = position;
        tip.end.frame = frame;
        Ok(())
    }

    /// Make `loads` strand i's own point loads (before the Coulomb forces, which the next
    /// [`Self::apply_charge_loads`] puts back after them), on either engine.
    pub(crate) fn put_own_loads(&mut self, i: usize, loads: &[crate::model::strand::PointLoad]) {
        if let Some(e) = &mut self.embedded {
            let (strand, _, g, p) = &mut e.strands[i];
            strand
                .point_loads
                .splice(..e.scene_loads[i], loads.iter().copied());
            e.scene_loads[i] = loads.len();
            e.groups[*g].1.set_loads(*p, &strand.point_loads);
            return;
        }
        let s = &mut self.strands[i];
        s.system
            .strand
            .point_loads
            .splice(..s.scene_loads, loads.iter().copied());
        s.scene_loads = loads.len();
    }

    /// Strand i's own point loads (the scene's, or what [`Simulation::set_point_loads`]
    /// set last; the Coulomb forces of electrostatics, kept after them, not included).
    pub fn point_loads(&self, i: usize) -> &[crate::model::strand::PointLoad] {
        match &self.embedded {
            Some(e) => &e.strands[i].0.point_loads[..e.scene_loads[i]],
            None => {
                let s = &self.strands[i];
                &s.system.strand.point_loads[..s.scene_loads]
            }
        }
    }

    /// Replace strand i's own point loads from now on (the steps and static solves take
    /// them; the Coulomb forces stay): a load ramped, moved or computed by a caller
    /// between two steps. Each load's s must be in [0, L] and its force finite, at most
    /// [`crate::model::strand::MAX_POINT_LOAD`] N; the embedded engine takes no follower load.
    /// The change is no work the strand did: its last energy is shifted by the loads'
    /// potential at its state (as for electrostatics' updates), and the two-step
    /// integrator keeps its history, so a load set before every step is stepped exactly
    /// as the same load given in the scene.
    pub fn set_point_loads(
        &mut self,
        i: usize,
        loads: Vec<crate::model::strand::PointLoad>,
    ) -> Result<()> {
        self.check_strand(i)?;
        let length = self.strand(i).geometry.length();
        let max = crate::model::strand::MAX_POINT_LOAD;
        let mut loads = loads;
        for (k, load) in loads.iter_mut().enumerate() {
            // (the elements' lengths sum to L within rounding: a load at L is at the tip)
            if load.s > length && load.s <= length * (1.0 + 1e-12) {
                load.s = length;
            }
            if !(load.s.is_finite() && (0.0..=length).contains(&load.s)) {
                return Err(Error::invalid(
                    format!("point_loads[{k}].s"),
                    format!(
                        "{}: must be in [0, {length}] m, the strand's length",
                        load.s
                    ),
                ));
            }
            if !(load.force.iter().all(|f| f.is_finite()) && load.force.norm() <= max) {
                return Err(Error::invalid(
                    format!("point_loads[{k}].force"),
                    format!(
                        "[{}, {}, {}]: must be finite with a magnitude <= {max:e} N",
                        load.force[0], load.force[1], load.force[2]
                    ),
                ));
            }
            if !(load.torque.iter().all(|t| t.is_finite()) && load.torque.norm() <= max) {
                return Err(Error::invalid(
                    format!("point_loads[{k}].torque"),
                    format!(
                        "[{}, {}, {}]: must be finite with a magnitude <= {max:e} N·m",
                        load.torque[0], load.torque[1], load.torque[2]
                    ),
                ));
            }
            if load.follows && self.embedded.is_some() {
                return Err(Error::invalid(
                    format!("point_loads[{k}].follows"),
                    "the embedded engine takes no follower load: build the simulation with engine = \"runtime\"",
                ));
            }
        }
        // Σ f · (x − X) of the dead loads at the state, world: the change of the loads'
        // potential −Σ f · y the strand's last energy is shifted by
        let head = self.head.state(self.time);
        let geometry = self.strand(i).geometry.clone();
        let q = self.q(i).to_vec();
        let dead_sum = |loads: &[crate::model::strand::PointLoad]| -> f64 {
            loads
                .iter()
                .filter(|l| !l.follows)
                .map(|l| {
                    let y = pose_at(&geometry, &q, l.s).position;
                    l.force.dot(&(head.rotation * y))
                })
                .sum()
        };
        let change = dead_sum(&loads) - dead_sum(self.point_loads(i));
        self.put_own_loads(i, &loads);
        if let Some(e) = &mut self.embedded {
            let (_, _, g, p) = e.strands[i];
            e.groups[g].1.shift_load_energy(p, change);
        } else {
            self.strands[i].system.workspace.shift_load_energy(change);
        }
        Ok(())
    }

    /// Where strand i's held tip is held, in its holder's motion frame (the world for a
    /// still holder): the point and the frame (columns n0, n1, n2); `None` without a
    /// held tip.
    pub fn holder(&self, i: usize) -> Option<(nalgebra::Vector3<f64>, nalgebra::Matrix3<f64>)> {
        let tip = match &self.embedded {
            Some(e) => {
                let (_, _, g, p) = &e.strands[i];
                e.groups[*g].1.held(*p)?
            }
            None => self.strands[i].system.held.as_ref()?,
        };
        Some((tip.end.position, tip.end.frame))
    }

    /// Hold strand i's tip at `position` (and, for a clamped tip, in `frame`: columns
    /// n0, n1, n2, orthonormal and right-handed to 1e-9) from now on, in its holder's
    /// motion frame: a holder moved between steps or between static solves (the
    /// parameter of a displacement-controlled study). Refused, leaving the holder where
    /// it was, without a held tip, for a position beyond ±10⁴ m or out of the rod's
    /// reach, or a frame that is not a rotation. The holder's move is work the strand did
    /// not do: its energy balance starts afresh (the embedded engine also restarts its
    /// two-step history).
    pub fn set_holder(
        &mut self,
        i: usize,
        position: nalgebra::Vector3<f64>,
        frame: Option<nalgebra::Matrix3<f64>>,
    ) -> Result<()> {
        self.check_strand(i)?;
        if !position.iter().all(|x| x.is_finite() && x.abs() <= 1e4) {
            return Err(Error::invalid(
                "position",
                format!(
                    "[{}, {}, {}]: each coordinate must be finite, within ±1e4 m",
                    position[0], position[1], position[2]
                ),
            ));
        }
        if let Some(f) = &frame {
            let off = (f.transpose() * f - nalgebra::Matrix3::identity())
                .abs()
                .max();
            if !(off <= 1e-9 && (f.determinant() - 1.0).abs() <= 1e-9) {
                return Err(Error::invalid(
                    "frame",
                    "must be a rotation: orthonormal columns n0, n1, n2 with n2 = n0 × n1 (to 1e-9)",
                ));
            }
        }
        let (t, q) = (self.time, self.q(i).to_vec());
        let geometry = self.strand(i).geometry.clone();
        let (group, tip) = match &mut self.embedded {
            Some(e) => {
                let (_, _, g, p) = e.strands[i];
                (Some((g, p)), e.groups[g].1.held_mut(p))
            }
            None => (None, self.strands[i].system.held.as_mut()),
        };
        let Some(tip) = tip else {
            return Err(Error::invalid(
                "strand",
                format!("{i}: its tip is not held ([strands.ends.tip])"),
            ));
        };
        let before = (tip.end.position, tip.end.frame);
        tip.end.position = position;
        if let Some(f) = frame {
            tip.end.frame = f;
        }
        if let Some(why) = tip.beyond_reach(&geometry, &q, t) {
            (tip.end.position, tip.end.frame) = before;
            return Err(Error::invalid("position", why.to_string()));
        }
        match group {
            Some((g, p)) => {
                if let Some(e) = &mut self.embedded {
                    let v = e.groups[g].1.v(p).to_vec();
                    e.groups[g].1.set_state(p, &q, &v);
                }
            }
            None => self.strands[i].system.workspace.forget_energy(),
        }
        Ok(())
    }

    /// Set the state of strand i (lengths must be 3N).
    pub fn set_state(&mut self, i: usize, q: &[f64], v: &[f64]) {
        if let Some(e) = &mut self.embedded {
            let (_, _, g, p) = e.strands[i];
            e.groups[g].1.set_state(p, q, v);
            return;
        }
        let s = &mut self.strands[i];
        s.state.q.copy_from_slice(q);
        s.state.v.copy_from_slice(v);
        s.system.workspace.forget_history();
    }
    /// Description of strand i's kernel.
    pub fn kernel_description(&self, i: usize) -> String {
        match &self.embedded {
            Some(e) => format!(
                "embedded fixed-N step (N = {})",
                e.strands[i].0.geometry.elements()
            ),
            None => self.strands[i].system.kernel.description(),
        }
    }
    /// The engine stepping the strands: [`Engine::Embedded`] or [`Engine::Runtime`]
    /// (what `engine = "auto"` chose).
    pub fn engine(&self) -> Engine {
        if self.embedded.is_some() {
            Engine::Embedded
        } else {
            Engine::Runtime
        }
    }
    /// Whether strand i runs on a generated kernel.
    pub fn uses_generated_kernel(&self, i: usize) -> bool {
        match &self.embedded {
            Some(_) => true,
            None => self.strands[i].system.kernel.is_generated(),
        }
    }
    /// Solver counters summed over strands.
    pub fn stats(&self) -> StepStats {
        let mut total = StepStats::default();
        if let Some(e) = &self.embedded {
            total.substeps = e.counts.substeps;
            total.attempts = e.counts.attempts;
            total.energy_rejected = e.counts.energy_rejected;
            total.energy_limited = e.counts.energy_limited;
            total.energy_unbalanced = e.counts.energy_unbalanced;
            total.energy_pulled_back = e.counts.energy_pulled_back;
            total.field_split = e.counts.field_split;
            total.field_projected = e.counts.field_projected;
            total.field_undamped = e.counts.field_undamped;
            total.contacts_predicted = e.counts.contacts_predicted;
            total.rotation_limited = e.counts.rotation_limited;
            total.newton_iterations = e.counts.newton_iterations;
            total.newton_unconverged = e.counts.newton_unconverged;
            [total.pairs_indefinite, total.pairs_unresolved] = e.pair_counts;
            let r = &e.tolerance_total;
            total.attempts += r.solves;
            total.energy_limited += r.energy_limited;
            total.error_steps = r.steps;
            total.error_rejected = r.rejected;
            total.error_rejected_deep = r.rejected_deep;
        }
        for s in &self.strands {
            total.add(&s.stats);
        }
        total
    }
    /// Largest |q̇| entry over all strands, rad/(m·s).
    pub fn max_speed(&self) -> f64 {
        (0..self.strand_count())
            .flat_map(|i| self.v(i).iter())
            .fold(0.0, |m, v| m.max(v.abs()))
    }
    /// Total energy T + U + V_gravity + V_loads of strand i (meaningful with a still head).
    pub fn energy(&mut self, i: usize) -> f64 {
        if self.embedded.is_some() {
            let (q, v) = (self.q(i).to_vec(), self.v(i).to_vec());
            return self.measuring_system(i).energy(&q, &v);
        }
        let s = &mut self.strands[i];
        s.system.energy(&s.state.q, &s.state.v)
    }
    /// Kinetic energy ½ q̇ᵀ M q̇ of strand i relative to the head, joules.
    pub fn kinetic_energy(&mut self, i: usize) -> f64 {
        if self.embedded.is_some() {
            let (q, v) = (self.q(i).to_vec(), self.v(i).to_vec());
            return self.measuring_system(i).kinetic_energy(&q, &v);
        }
        let s = &mut self.strands[i];
        s.system.kinetic_energy(&s.state.q, &s.state.v)
    }
    /// Centreline of strand i in world coordinates: the root, then `per_element` points
    /// per element.
    pub fn centreline_world(&mut self, i: usize, per_element: usize) -> Vec<[f64; 3]> {
        let head = self.head.state(self.time);
        let mut points = Vec::new();
        sample_centreline(
            &self.strand(i).geometry,
            self.q(i),
            per_element,
            &mut points,
        );
        points
            .iter()
            .map(|y| {
                let x = head.position + head.rotation * y;
                [x[0], x[1], x[2]]
            })
            .collect()
    }
    /// Position of strand i at arc length s, head coordinates.
    pub fn position_at(&self, i: usize, s: f64) -> nalgebra::Vector3<f64> {
        pose_at(&self.strand(i).geometry, self.q(i), s).position
    }

    /// The arc lengths of [`Simulation::centreline_world`]'s points of strand i: the
    /// root, then `per_element` equally spaced in each element (a pinned or free root's
    /// joint included, as there).
    pub fn centreline_arcs(&self, i: usize, per_element: usize) -> Vec<f64> {
        let per = per_element.max(1);
        let mut arcs = vec![0.0];
        let mut start = 0.0;
        for &l in &self.strand(i).geometry.lengths {
            arcs.extend((1..=per).map(|j| start + l * j as f64 / per as f64));
            start += l;
        }
        arcs
    }

    /// The material frames of strand i at the arc lengths `arcs` (increasing), world
    /// coordinates: position and the directors n0 (the tangent), n1, n2 as columns.
    pub fn poses_world(&self, i: usize, arcs: &[f64]) -> Vec<crate::model::reconstruction::Pose> {
        let head = self.head.state(self.time);
        crate::model::kinematics::world_poses(&self.strand(i).geometry, self.q(i), &head, arcs)
    }

    /// The world velocity of strand i's centreline at the arc lengths `arcs`
    /// (increasing), the head's motion included, m/s ([`crate::model::kinematics`]).
    pub fn velocities_world(&self, i: usize, arcs: &[f64]) -> Vec<nalgebra::Vector3<f64>> {
        use crate::model::kinematics::{relative_velocities, world_velocities};
        let head = self.head.state(self.time);
        let geom = &self.strand(i).geometry;
        let mut positions = Vec::with_capacity(arcs.len());
        crate::model::reconstruction::positions_at_sorted(
            geom,
            self.q(i),
            arcs.iter().copied(),
            &mut positions,
        );
        let relative = relative_velocities(geom, self.q(i), self.v(i), arcs);
        world_velocities(&head, &positions, &relative)
    }

    /// Gravity and the head's motion as strand i's steps see them.
    fn effects(&self, i: usize) -> GlobalEffects {
        match &self.embedded {
            Some(e) => GlobalEffects {
                gravity: e.gravity,
                head_moves: e.head_moves,
            },
            None => self.strands[i].system.context.effects,
        }
    }

    /// The momenta of the parts of strand i beyond its element ends at the present state
    /// ([`crate::forces::internal_loads::momenta`]): what a caller keeps after a step for
    /// the inertia of a later [`Simulation::internal_loads`].
    pub fn momenta(&self, i: usize) -> crate::forces::internal_loads::Momenta {
        crate::forces::internal_loads::momenta(self.strand(i), self.q(i), self.v(i), self.time)
    }

    /// Keep every strand's [`Simulation::momenta`] now in `kept` (one list per strand,
    /// the last two): call it before a step whose end [`Simulation::internal_loads`]
    /// will read.
    pub fn keep_momenta(&self, kept: &mut Vec<Vec<crate::forces::internal_loads::Momenta>>) {
        for i in 0..self.strand_count() {
            crate::forces::internal_loads::keep(kept, i, self.momenta(i));
        }
    }

    /// The internal force and moment of strand i at its element ends, each element's
    /// constitutive moment and the reactions of its holders, at the present state
    /// ([`crate::forces::internal_loads`]). `earlier` holds up to two of its earlier
    /// [`Simulation::momenta`], oldest first, for the inertia (none: counted as zero,
    /// exact in a static equilibrium). Refused for a scene with contacts or
    /// electrostatics, whose forces the balance cannot place along the strand.
    pub fn internal_loads(
        &self,
        i: usize,
        earlier: &[crate::forces::internal_loads::Momenta],
    ) -> Result<crate::forces::internal_loads::InternalLoads> {
        if self.contact_summary(i).is_some() {
            return Err(Error::invalid(
                "contacts",
                "internal loads are not computed with [contacts]: the balance would leave \
                 out the contact forces, which are not kept per point of the strand",
            ));
        }
        if self.electrostatics.is_some() {
            return Err(Error::invalid(
                "electrostatics",
                "internal loads are not computed with [electrostatics]: the balance would \
                 leave out the Coulomb forces, which are not kept per point of the strand",
            ));
        }
        let head = self.head.state(self.time);
        let tip_reaction = self.held_reaction(i);
        let state = crate::forces::internal_loads::LoadState {
            strand: self.strand(i),
            q: self.q(i),
            v: self.v(i),
            head: &head,
            effects: self.effects(i),
            tip_reaction,
        };
        Ok(crate::forces::internal_loads::internal_loads(
            &state, self.time, earlier,
        ))
    }

    /// Follow strand i's static equilibria as a load scale or its holder's position
    /// changes, through folds ([`crate::solver::continuation`]): the first point is the
    /// static equilibrium at `settings.start` from the strand's present q as a guess.
    /// The head is at rest and the strand's loads, holder and state are left as they
    /// were (a point of the branch is taken with [`Simulation::set_state`]). Refused with
    /// `[contacts]` or `[electrostatics]`, for a holder parameter on a tip not held, and
    /// for settings out of range (each named).
    pub fn follow_branch(
        &self,
        i: usize,
        settings: &crate::solver::continuation::ContinuationSettings,
    ) -> Result<crate::solver::continuation::Branch> {
        use crate::solver::continuation::BranchParameter;
        self.check_strand(i)?;
        self.check_potential_loads()?;
        if self.contact_summary(i).is_some() || self.hair_hair.is_some() {
            return Err(Error::invalid(
                "contacts",
                "a branch is not followed with [contacts]: their forces are not smooth in q",
            ));
        }
        if self.electrostatics.is_some() {
            return Err(Error::invalid(
                "electrostatics",
                "a branch is not followed with [electrostatics]: the Coulomb forces are not \
                 part of the static residual's derivative",
            ));
        }
        for (name, value) in [("start", settings.start), ("stop", settings.stop)] {
            if !(value.is_finite() && value.abs() <= 1e6) {
                return Err(Error::invalid(
                    name,
                    format!("{value}: must be finite, within ±1e6"),
                ));
            }
        }
        if settings.start == settings.stop {
            return Err(Error::invalid("stop", "must differ from start"));
        }
        if !(settings.step.is_finite() && settings.step > 0.0 && settings.step <= 10.0) {
            return Err(Error::invalid(
                "step",
                format!("{}: must be in (0, 10]", settings.step),
            ));
        }
        if !(settings.max_step.is_finite() && settings.max_step >= settings.step) {
            return Err(Error::invalid(
                "max_step",
                format!(
                    "{}: must be at least step ({})",
                    settings.max_step, settings.step
                ),
            ));
        }
        if !(2..=100_000).contains(&settings.max_points) {
            return Err(Error::invalid(
                "max_points",
                format!("{}: must be in [2, 100000]", settings.max_points),
            ));
        }
        let mut system = self.measuring_system(i);
        system.context.effects = self.effects(i);
        system.held = match &self.embedded {
            Some(e) => {
                let (_, _, g, p) = e.strands[i];
                e.groups[g].1.held(p).cloned()
            }
            None => self.strands[i].system.held.clone(),
        };
        if let BranchParameter::Holder { direction } = settings.parameter {
            if system.held.is_none() {
                return Err(Error::invalid(
                    "parameter",
                    format!("holder: strand {i}'s tip is not held ([strands.ends.tip])"),
                ));
            }
            if (direction.norm() - 1.0).abs().is_nan() || (direction.norm() - 1.0).abs() > 1e-9 {
                return Err(Error::invalid(
                    "direction",
                    "must be a unit vector (to 1e-9)",
                ));
            }
        }
        let q = self.q(i).to_vec();
        crate::solver::continuation::follow_branch(&mut system, &q, settings).map_err(|cause| {
            Error::Diverged {
                strand: self.strand(i).name.clone(),
                index: i,
                time: self.time,
                cause,
            }
        })
    }

    /// A runtime system of strand i of the embedded engine, for measurements (energy).
    fn measuring_system(&self, i: usize) -> StrandSystem {
        let strand = self.strand(i).clone();
        let kernel = closed_form_kernel(&strand.geometry);
        let (gravity, head_moves) = self
            .embedded
            .as_ref()
            .map_or((None, false), |e| (e.gravity, e.head_moves));
        StrandSystem::new(
            strand,
            kernel,
            StepContext {
                effects: GlobalEffects {
                    gravity,
                    head_moves,
                },
                integrator: IntegratorKind::LinearlyImplicitEuler,
                max_split_depth: superhelix_kernels::energy::MAX_SUBSTEP_DEPTH,
                explicit_field_stiffness: false,
                field_split: false,
                energy_balance: true,
                tolerance: None,
            },
        )
    }
}

impl FrameSource for Simulation {
    fn time(&self) -> f64 {
        self.time
    }
    fn state(&self) -> Option<Result<Vec<u8>>> {
        Some(Simulation::state(self).encode())
    }
    fn restore(&mut self, state: &[u8]) -> Result<()> {
        Simulation::restore(self, SimulationState::decode(state)?)
    }
    fn strand_steps(&self) -> Option<Vec<crate::output::StrandSteps>> {
        Simulation::strand_steps(self)
    }
    fn strand_count(&self) -> usize {
        Simulation::strand_count(self)
    }
    fn strand_name(&self, i: usize) -> &str {
        &self.strand(i).name
    }
    fn strand_group(&self, i: usize) -> &str {
        match &self.embedded {
            Some(e) => &e.strands[i].1,
            None => &self.strands[i].group,
        }
    }
    fn strand_radius(&self, i: usize) -> f64 {
        crate::output::driver::display_radius(&self.strand(i).material)
    }
    fn strand_elements(&self, i: usize) -> usize {
        self.strand(i).geometry.elements()
    }
    fn q(&self, i: usize) -> &[f64] {
        Simulation::q(self, i)
    }
    fn v(&self, i: usize) -> &[f64] {
        Simulation::v(self, i)
    }
    fn centreline_world(&mut self, i: usize, samples_per_element: usize) -> Vec<[f64; 3]> {
        Simulation::centreline_world(self, i, samples_per_element)
    }
    fn step(&mut self) -> Result<()> {
        Simulation::step(self)
    }
    fn step_by(&mut self, h: f64) -> Result<()> {
        Simulation::step_by(self, h)
    }
    fn deepest_inside(&mut self) -> Option<f64> {
        self.max_penetration()
    }
    fn error_control(&self) -> Option<crate::output::ErrorControlSummary> {
        Simulation::error_control(self)
    }
    fn coulomb_updates(&self) -> Option<crate::output::CoulombUpdates> {
        self.electrostatics.as_ref().map(|e| e.updates())
    }
    fn frame_steps(&mut self) -> Option<crate::output::FrameSteps> {
        Simulation::frame_steps(self)
    }
    fn speed(&self, i: usize) -> f64 {
        // a pinned root's joint coordinates d₀ = θ / l₀: their rate counts as θ̇ = l₀ ḋ₀
        let strand = self.strand(i);
        let joint = 3 * strand.ends.joint_elements();
        self.v(i)
            .iter()
            .enumerate()
            .map(|(k, x)| {
                let x = if k < joint {
                    x * strand.geometry.lengths[k / 3]
                } else {
                    *x
                };
                x * x
            })
            .sum::<f64>()
            .sqrt()
    }
    fn has_held_tip(&self, i: usize) -> bool {
        self.held_reaction(i).is_some()
    }
    fn held_ends(&mut self, out: &mut Vec<crate::output::HeldEndFrame>) {
        out.clear();
        for i in 0..self.strand_count() {
            let reaction = self.held_reaction(i);
            if let (Some(drift), Some(r)) = (self.take_held_drift(i), reaction) {
                out.push(crate::output::HeldEndFrame {
                    strand: i,
                    drift,
                    reaction: [r[0], r[1], r[2], r[3], r[4], r[5]],
                });
            }
        }
    }

    fn solve_static(&mut self) -> Result<()> {
        Simulation::solve_static(self).map(|_| ())
    }
}
