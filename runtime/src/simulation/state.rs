//! The state a [`Simulation`] carries from one step to the next, as a checkpoint writes
//! it: [`Simulation::state`] takes it, [`Simulation::restore`] continues from it, and the
//! steps after a restore are those the simulation would have taken, bit for bit
//! (`tests/checkpoint.rs`).
//!
//! What it holds, per strand: q and q̇, the step counters, the step buffers' history
//! (the two-step integrator's previous state, the last step's end and energy, the split
//! hint, the error-controlled step's sizes, the stiffness projection's kept basis), the
//! contacts' friction anchors and allowances, a held tip's reaction and drift; for the
//! embedded engine the same per strand in its own form and the engine's counters; the
//! electrostatics' last update (particles, forces, charge scale); the hair–hair pairs
//! with their anchors and allowances; the time and the step count. The rest of a
//! simulation is built again from the scene.

use super::Simulation;
use crate::error::{Error, Result};
use crate::forces::contacts::hair_hair::HairHairState;
use crate::forces::contacts::strand_contacts::StrandContactsState;
use crate::forces::electrostatics::force_coulomb::ElectrostaticsState;
use crate::forces::head_motion::HeadMotion;
use crate::solver::embedded::{FixedStrandState, ReportState};
use crate::solver::held_end::HeldTipState;
use crate::solver::system::WorkspaceState;
use crate::solver::{StepStats, StrandState};
use serde::{Deserialize, Serialize};
use superhelix_kernels::fixed::StepCounts;

/// Everything a [`Simulation`] needs to go on from where it is (see the module page).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimulationState {
    time: f64,
    steps: usize,
    reported_steps: (usize, usize),
    strands: Vec<StrandSimState>,
    embedded: Option<EmbeddedState>,
    electrostatics: Option<ElectrostaticsState>,
    hair_hair: Option<HairHairState>,
    /// Gravity then (world, m/s²), as the scene or [`Simulation::set_gravity`] left it.
    gravity: Option<[f64; 3]>,
    /// Each strand's own point loads then, as the scene or
    /// [`Simulation::set_point_loads`] left them.
    point_loads: Vec<Vec<SavedLoad>>,
    /// Each held tip's holder then (point, frame column-major), as the scene or
    /// [`Simulation::set_holder`] left it; `None` for a tip not held.
    holders: Vec<Option<([f64; 3], [f64; 9])>>,
    /// The head driven by [`Simulation::set_head`]: t0, then position, rotation
    /// (column-major), velocity, acceleration, ω and α at t0; `None`: the scene's
    /// motion.
    driven_head: Option<(f64, [f64; 24])>,
}

/// A point load as a state keeps it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
struct SavedLoad {
    s: f64,
    force: [f64; 3],
    follows: bool,
    torque: [f64; 3],
}

impl SimulationState {
    /// The simulated time of the state, s.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The steps taken to reach it.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// The state as a checkpoint writes it ([postcard](https://docs.rs/postcard)).
    pub fn encode(&self) -> Result<Vec<u8>> {
        postcard::to_stdvec(self)
            .map_err(|e| Error::invalid("checkpoint", format!("the state cannot be encoded: {e}")))
    }

    /// The state [`Self::encode`] wrote.
    pub fn decode(bytes: &[u8]) -> Result<Self> {
        postcard::from_bytes(bytes).map_err(|e| {
            Error::invalid(
                "--resume",
                format!("the checkpoint's simulation state does not decode: {e}"),
            )
        })
    }
}

/// One strand of the runtime engine.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct StrandSimState {
    state: StrandState,
    stats: StepStats,
    workspace: WorkspaceState,
    contacts: Option<StrandContactsState>,
    held: Option<HeldTipState>,
}

/// The embedded engine's strands, by group, and its counters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct EmbeddedState {
    groups: Vec<Vec<FixedStrandState>>,
    counts: [usize; 5],
    /// The solves by the dissipative split and by the spectral projection.
    #[serde(default)]
    field_counts: [usize; 2],
    /// The deepest substeps pulled back for the energy balance.
    #[serde(default)]
    pulled_back: usize,
    /// The solves of strands the split's rule keeps on the spectral projection.
    #[serde(default)]
    undamped: usize,
    /// The contacts that started within a step and pushed, and the deepest substeps
    /// whose rotation was limited.
    #[serde(default)]
    contact_counts: [usize; 2],
    /// The Newton iterations, and the Newton solves replaced by linearly implicit ones.
    #[serde(default)]
    newton_counts: [usize; 2],
    /// The pair solve's sides left out for an indefinite compliance, and its pairs left
    /// unresolved (`coupling = "pair"`).
    #[serde(default)]
    pair_counts: [usize; 2],
    total: ReportState,
    window: ReportState,
}

fn counts_of(c: &StepCounts) -> [usize; 5] {
    [
        c.substeps,
        c.attempts,
        c.energy_rejected,
        c.energy_limited,
        c.energy_unbalanced,
    ]
}

fn counts_from(c: [usize; 5]) -> StepCounts {
    StepCounts {
        substeps: c[0],
        attempts: c[1],
        energy_rejected: c[2],
        energy_limited: c[3],
        energy_unbalanced: c[4],
        ..StepCounts::default()
    }
}

/// A checkpoint that does not fit the simulation built from the scene.
fn mismatch(what: impl std::fmt::Display) -> Error {
    Error::invalid(
        "checkpoint",
        format!("the checkpoint does not fit the scene: {what}"),
    )
}

impl Simulation {
    /// Everything the simulation needs to go on from where it is (see the module page).
    pub fn state(&self) -> SimulationState {
        SimulationState {
            time: self.time,
            steps: self.steps,
            reported_steps: self.reported_steps,
            strands: self
                .strands
                .iter()
                .map(|s| StrandSimState {
                    state: s.state.clone(),
                    stats: s.stats,
                    workspace: s.system.workspace.state(),
                    contacts: s.system.contacts.as_ref().map(|c| c.state()),
                    held: s.system.held.as_ref().map(|h| h.state()),
                })
                .collect(),
            embedded: self.embedded.as_ref().map(|e| EmbeddedState {
                groups: e.groups.iter().map(|(_, g)| g.state()).collect(),
                counts: counts_of(&e.counts),
                field_counts: [e.counts.field_split, e.counts.field_projected],
                pulled_back: e.counts.energy_pulled_back,
                undamped: e.counts.field_undamped,
                contact_counts: [e.counts.contacts_predicted, e.counts.rotation_limited],
                newton_counts: [e.counts.newton_iterations, e.counts.newton_unconverged],
                pair_counts: e.pair_counts,
                total: ReportState::of(&e.tolerance_total),
                window: ReportState::of(&e.tolerance_window),
            }),
            electrostatics: self.electrostatics.as_ref().map(|e| e.state()),
            hair_hair: self.hair_hair.as_ref().map(|h| h.state()),
            gravity: self.gravity().map(|g| [g[0], g[1], g[2]]),
            point_loads: (0..self.strand_count())
                .map(|i| {
                    self.point_loads(i)
                        .iter()
                        .map(|l| SavedLoad {
                            s: l.s,
                            force: [l.force[0], l.force[1], l.force[2]],
                            follows: l.follows,
                            torque: [l.torque[0], l.torque[1], l.torque[2]],
                        })
                        .collect()
                })
                .collect(),
            holders: (0..self.strand_count())
                .map(|i| {
                    self.holder(i).map(|(p, f)| {
                        let mut frame = [0.0; 9];
                        frame.copy_from_slice(f.as_slice());
                        ([p[0], p[1], p[2]], frame)
                    })
                })
                .collect(),
            driven_head: match &self.head {
                HeadMotion::Driven { t0, state } => {
                    let mut words = [0.0; 24];
                    words[..3].copy_from_slice(state.position.as_slice());
                    words[3..12].copy_from_slice(state.rotation.as_slice());
                    for (k, v) in [state.velocity, state.acceleration, state.omega, state.alpha]
                        .iter()
                        .enumerate()
                    {
                        words[12 + 3 * k..15 + 3 * k].copy_from_slice(v.as_slice());
                    }
                    Some((*t0, words))
                }
                _ => None,
            },
        }
    }

    /// Continue from `state`, taken of a simulation of the same scene: the steps that
    /// follow are those that simulation would have taken. An error (naming what does not
    /// fit) leaves this simulation unusable for a continued run; build it again.
    pub fn restore(&mut self, state: SimulationState) -> Result<()> {
        if state.strands.len() != self.strands.len() {
            return Err(mismatch(format!(
                "{} strands on the runtime engine in the checkpoint, {} in the scene",
                state.strands.len(),
                self.strands.len()
            )));
        }
        for (i, (s, saved)) in self.strands.iter_mut().zip(state.strands).enumerate() {
            let name = &s.system.strand.name;
            if saved.state.q.len() != s.state.q.len() || saved.state.v.len() != s.state.v.len() {
                return Err(mismatch(format!(
                    "strand {i} ({name}) has {} coordinates in the checkpoint, {} in the scene",
                    saved.state.q.len(),
                    s.state.q.len()
                )));
            }
            s.state = saved.state;
            s.stats = saved.stats;
            s.system
                .workspace
                .restore(saved.workspace)
                .map_err(|e| mismatch(format!("strand {i} ({name}): {e}")))?;
            match (&mut s.system.contacts, saved.contacts) {
                (Some(c), Some(saved)) => c
                    .restore(saved)
                    .map_err(|e| mismatch(format!("strand {i} ({name}): {e}")))?,
                (None, None) => {}
                _ => return Err(mismatch("contacts in one and not in the other")),
            }
            match (&mut s.system.held, saved.held) {
                (Some(h), Some(saved)) => h.restore(saved),
                (None, None) => {}
                _ => {
                    return Err(mismatch(format!(
                        "strand {i} ({name}) has a held tip in one and not in the other"
                    )))
                }
            }
        }
        match (&mut self.embedded, state.embedded) {
            (Some(e), Some(saved)) => {
                if saved.groups.len() != e.groups.len() {
                    return Err(mismatch("the embedded engine's groups differ"));
                }
                for ((_, group), states) in e.groups.iter_mut().zip(saved.groups) {
                    group.restore(states).map_err(mismatch)?;
                }
                e.counts = counts_from(saved.counts);
                [e.counts.field_split, e.counts.field_projected] = saved.field_counts;
                e.counts.energy_pulled_back = saved.pulled_back;
                e.counts.field_undamped = saved.undamped;
                [e.counts.contacts_predicted, e.counts.rotation_limited] = saved.contact_counts;
                [e.counts.newton_iterations, e.counts.newton_unconverged] = saved.newton_counts;
                e.pair_counts = saved.pair_counts;
                e.tolerance_total = saved.total.report();
                e.tolerance_window = saved.window.report();
            }
            (None, None) => {}
            _ => return Err(mismatch("the engine differs (embedded or runtime)")),
        }
        match (&mut self.electrostatics, state.electrostatics) {
            (Some(e), Some(saved)) => e.restore(saved).map_err(mismatch)?,
            (None, None) => {}
            _ => return Err(mismatch("electrostatics in one and not in the other")),
        }
        if state.point_loads.len() != self.strand_count() {
            return Err(mismatch(format!(
                "{} strands' point loads in the checkpoint, {} strands in the scene",
                state.point_loads.len(),
                self.strand_count()
            )));
        }
        self.put_gravity(state.gravity.map(nalgebra::Vector3::from));
        if let Some((t0, w)) = state.driven_head {
            let v = |k: usize| nalgebra::Vector3::new(w[k], w[k + 1], w[k + 2]);
            self.put_driven_head(
                t0,
                crate::HeadState {
                    position: v(0),
                    rotation: nalgebra::Matrix3::from_column_slice(&w[3..12]),
                    velocity: v(12),
                    acceleration: v(15),
                    omega: v(18),
                    alpha: v(21),
                },
            );
        }
        if state.holders.len() != self.strand_count() {
            return Err(mismatch("the held tips differ"));
        }
        for (i, saved) in state.holders.iter().enumerate() {
            if let Some((p, f)) = saved {
                self.put_holder(i, (*p).into(), nalgebra::Matrix3::from_column_slice(f))
                    .map_err(|()| {
                        mismatch(format!(
                            "strand {i} has a held tip in one and not in the other"
                        ))
                    })?;
            }
        }
        for (i, loads) in state.point_loads.iter().enumerate() {
            let loads: Vec<_> = loads
                .iter()
                .map(|l| crate::model::strand::PointLoad {
                    s: l.s,
                    force: l.force.into(),
                    follows: l.follows,
                    torque: l.torque.into(),
                })
                .collect();
            self.put_own_loads(i, &loads);
        }
        // the Coulomb loads of the last update, after each strand's own
        self.apply_charge_loads();
        match (&mut self.hair_hair, state.hair_hair) {
            (Some(h), Some(saved)) => h.restore(saved),
            (None, None) => {}
            _ => return Err(mismatch("hair–hair contacts in one and not in the other")),
        }
        self.time = state.time;
        self.steps = state.steps;
        self.reported_steps = state.reported_steps;
        Ok(())
    }
}
