//! The Coulomb force on every tracer particle, `F_i = q_i E(x_i)` with
//! `E = −∇Φ`, `Φ(x) = k Σ_j q_j φ(|x − x_j|)` (paper eqs. 1 and 6, SI), by the multipole
//! method or the direct sum of `superhelix-fmm`, with the near-field softening of
//! [`superhelix_fmm::Softening`] (each particle's charge spread over a ball of radius
//! `a`, default the particle spacing 1/ρ_P: bounded for crossing fibres, exactly
//! Coulomb beyond `a`).

use super::tracers::Tracers;
use super::ElectrostaticsConfig;
use crate::bodies::Body;
use crate::forces::contacts::SearchInterval;
use crate::forces::head_motion::HeadState;
use crate::model::strand::{PointLoad, Strand};
use nalgebra::Vector3;
use std::time::Instant;
use superhelix_fmm::{direct_sum, Fmm, FmmOptions, Potentials, Softening};

/// The field (V/m) of the charged scalp `body` (charge `charge`, C) at the world point
/// `x`, the body's frame in state `frame` (see [`Body::frame`]; `None`: fixed in the
/// world): `k Q_S / max(d, a)² n` outside (d the distance to the surface, n
/// the outward normal), `k Q_S / a² n` inside (paper eq. 8 and its fallback; see
/// [`super::ScalpCharge`]). Bounded by `k |Q_S| / a²` for `a > 0`.
pub fn scalp_field(
    body: &Body,
    frame: Option<&HeadState>,
    x: &Vector3<f64>,
    charge: f64,
    a: f64,
) -> Vector3<f64> {
    let p = body.query_in(frame, x);
    let r = if p.distance > a { p.distance } else { a };
    if r <= 0.0 {
        return Vector3::zeros();
    }
    p.normal * (COULOMB_CONSTANT * charge / (r * r))
}

/// Coulomb's constant `1/(4πε₀)`, N·m²/C² (CODATA 2018).
pub const COULOMB_CONSTANT: f64 = 8.987_551_792_3e9;

/// Below this many particles `Auto` sums directly.
pub const DIRECT_BELOW: usize = 3000;

/// How the field is summed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CoulombMethod {
    /// The direct sum below [`DIRECT_BELOW`] particles, the multipole method above.
    Auto,
    /// Always the multipole method.
    Fmm,
    /// Always the direct sum (O(n²)).
    Direct,
}

impl CoulombMethod {
    /// The scene name.
    pub fn name(self) -> &'static str {
        match self {
            CoulombMethod::Auto => "auto",
            CoulombMethod::Fmm => "fmm",
            CoulombMethod::Direct => "direct",
        }
    }

    /// From a scene name.
    pub fn from_name(name: &str) -> Option<Self> {
        [
            CoulombMethod::Auto,
            CoulombMethod::Fmm,
            CoulombMethod::Direct,
        ]
        .into_iter()
        .find(|m| m.name() == name)
    }
}

/// How often the Coulomb forces of `[electrostatics]` were recomputed over a run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CoulombUpdates {
    /// Updates (evaluations of the field at every charged particle).
    pub updates: u64,
    /// Wall-clock seconds of those evaluations, s.
    pub seconds: f64,
}

/// What one evaluation found.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FieldSummary {
    /// Particles.
    pub particles: usize,
    /// Mean of |E| = |F|/|q| over the particles, V/m (the paper's 13 kV/m measure).
    pub mean_field: f64,
    /// Largest |F| on a particle, N.
    pub max_force: f64,
    /// Seconds of the evaluation (the sum and the forces; the positions are placed
    /// before, [`Electrostatics::positions`]).
    pub seconds: f64,
    /// Whether the multipole method was used.
    pub multipole: bool,
}

/// What the electrostatics carry from one update to the next (a checkpoint's part): the
/// particles' positions, charges, potentials, fields and forces of the last update, the
/// charge scale and the last summary.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ElectrostaticsState {
    points: Vec<[f64; 3]>,
    charges: Vec<f64>,
    potential: Vec<f64>,
    field: Vec<[f64; 3]>,
    forces: Vec<Vector3<f64>>,
    scale: f64,
    last: FieldSummary,
    #[serde(default)]
    interval: SearchInterval,
    #[serde(default)]
    frame: Option<[f64; 12]>,
    #[serde(default)]
    updated_at: Option<f64>,
    #[serde(default)]
    rate: f64,
}

/// The electrostatic state of a simulation: the particles, the evaluator and the last
/// forces.
pub struct Electrostatics {
    config: ElectrostaticsConfig,
    tracers: Tracers,
    fmm: Option<Fmm>,
    points: Vec<[f64; 3]>,
    charges: Vec<f64>,
    field: Potentials,
    forces: Vec<Vector3<f64>>,
    scale: f64,
    last: FieldSummary,
    /// Each strand's length, m (in the strands' order): what the particles' motion is
    /// measured against.
    lengths: Vec<f64>,
    /// The particles' forces before the last update (empty: none; not kept by a
    /// checkpoint: read only right after an update).
    previous_forces: Vec<Vector3<f64>>,
    /// The intervals of the updates within a step under a tolerance
    /// (`Simulation::step_by`), as the hair–hair searches take them.
    pub interval: SearchInterval,
    /// The head's frame (its position, then its rotation by columns) at the last update
    /// (`None`: none yet).
    frame: Option<[f64; 12]>,
    /// The time of the last update, s (`None`: none yet).
    updated_at: Option<f64>,
    /// How fast the particles moved between the last two updates: the largest motion
    /// of a particle relative to its strand's length, per second (0: not known).
    rate: f64,
    /// The updates since this state was made or restored (not kept by a checkpoint: a
    /// resumed run counts its own).
    updates: CoulombUpdates,
}

impl Electrostatics {
    /// Particles on `strands` as `config` asks.
    pub fn new(config: ElectrostaticsConfig, strands: &[&Strand]) -> Result<Self, String> {
        let tracers = Tracers::place(strands, config.particle_density, &config.charge_per_length);
        let n = tracers.len();
        let multipole = match config.method {
            CoulombMethod::Fmm => true,
            CoulombMethod::Direct => false,
            CoulombMethod::Auto => n >= DIRECT_BELOW,
        };
        let fmm = if multipole {
            let mut options =
                FmmOptions::for_accuracy(config.accuracy).map_err(|e| e.to_string())?;
            options.softening = Softening {
                radius: config.softening,
            };
            Some(Fmm::new(options).map_err(|e| e.to_string())?)
        } else {
            None
        };
        Ok(Electrostatics {
            config,
            tracers,
            fmm,
            points: vec![[0.0; 3]; n],
            charges: Vec::with_capacity(n),
            field: Potentials::default(),
            forces: vec![Vector3::zeros(); n],
            scale: 1.0,
            last: FieldSummary::default(),
            lengths: strands.iter().map(|s| s.geometry.length()).collect(),
            previous_forces: Vec::new(),
            interval: SearchInterval::default(),
            frame: None,
            updated_at: None,
            rate: 0.0,
            updates: CoulombUpdates::default(),
        })
    }

    /// What the steps until the next update need (see [`ElectrostaticsState`]).
    pub fn state(&self) -> ElectrostaticsState {
        ElectrostaticsState {
            points: self.points.clone(),
            charges: self.charges.clone(),
            potential: self.field.potential.clone(),
            field: self.field.field.clone(),
            forces: self.forces.clone(),
            scale: self.scale,
            last: self.last,
            interval: self.interval,
            frame: self.frame,
            updated_at: self.updated_at,
            rate: self.rate,
        }
    }

    /// Continue from `state`; an error when its particles are not these.
    pub fn restore(&mut self, state: ElectrostaticsState) -> Result<(), String> {
        if state.points.len() != self.points.len() || state.forces.len() != self.forces.len() {
            return Err(format!(
                "{} charged particles in the checkpoint, {} in the scene",
                state.points.len(),
                self.points.len()
            ));
        }
        self.points = state.points;
        self.charges = state.charges;
        self.field.potential = state.potential;
        self.field.field = state.field;
        self.forces = state.forces;
        self.scale = state.scale;
        self.last = state.last;
        self.interval = state.interval;
        self.frame = state.frame;
        self.updated_at = state.updated_at;
        self.rate = state.rate;
        self.updates = CoulombUpdates::default();
        Ok(())
    }

    /// The configuration.
    pub fn config(&self) -> &ElectrostaticsConfig {
        &self.config
    }

    /// The particles.
    pub fn tracers(&self) -> &Tracers {
        &self.tracers
    }

    /// The fraction of the full charge in effect (charging).
    pub fn charge_scale(&self) -> f64 {
        self.scale
    }

    /// Set the fraction of the full charge in effect (1 by default).
    pub fn set_charge_scale(&mut self, scale: f64) {
        self.scale = scale;
    }

    /// The last evaluation.
    pub fn last(&self) -> FieldSummary {
        self.last
    }

    /// Whether the multipole method is used.
    pub fn uses_multipole(&self) -> bool {
        self.fmm.is_some()
    }

    /// The particles' positions (world, m, in the order of [`Self::particles`]) with
    /// `place(i, arcs, out)` writing strand i's points at the arc lengths `arcs`
    /// (increasing) into `out`: what [`Self::update`] evaluates at and
    /// [`Self::motion_since_update`] measures, without the sum over the particles.
    pub fn positions(
        &self,
        place: impl Fn(usize, &[f64], &mut Vec<Vector3<f64>>) + Sync,
    ) -> Vec<[f64; 3]> {
        use rayon::prelude::*;
        let strands = self.tracers.offsets.len() - 1;
        let tracers = &self.tracers;
        let per_strand: Vec<Vec<Vector3<f64>>> = (0..strands)
            .into_par_iter()
            .map(|i| {
                let mut out = Vec::new();
                let arcs = &tracers.s[tracers.of(i)];
                if !arcs.is_empty() {
                    place(i, arcs, &mut out);
                }
                out
            })
            .collect();
        let mut points = Vec::with_capacity(self.tracers.len());
        for v in per_strand {
            points.extend(v.into_iter().map(<[f64; 3]>::from));
        }
        points
    }

    /// The largest distance a particle at `points` ([`Self::positions`]) stands from
    /// where the last update had it, relative to its strand's length, both measured in
    /// the head's frame (`position`, `rotation` head to world, now; the last update's
    /// frame then): a head carrying the charges together changes no force between them,
    /// and the charged scalp moves with it. 0 before the first update.
    pub fn motion_since_update(
        &self,
        points: &[[f64; 3]],
        position: &Vector3<f64>,
        rotation: &nalgebra::Matrix3<f64>,
    ) -> f64 {
        if self.last.particles == 0 || points.len() != self.points.len() {
            return 0.0;
        }
        // the last update's head frame (the world's when it was given none)
        let (p, r) = match &self.frame {
            Some(f) => (
                Vector3::new(f[0], f[1], f[2]),
                nalgebra::Matrix3::from_column_slice(&f[3..]),
            ),
            None => (Vector3::zeros(), nalgebra::Matrix3::identity()),
        };
        let then = |x: &[f64; 3]| r.transpose() * (Vector3::from(*x) - p);
        let now = |x: &[f64; 3]| rotation.transpose() * (Vector3::from(*x) - position);
        let strands = self.tracers.offsets.len().saturating_sub(1);
        (0..strands)
            .map(|i| {
                let r = self.tracers.of(i);
                let length = self.lengths.get(i).copied().unwrap_or(0.0);
                if length <= 0.0 {
                    return 0.0;
                }
                points[r.clone()]
                    .iter()
                    .zip(&self.points[r])
                    .map(|(a, b)| (now(a) - then(b)).norm())
                    .fold(0.0, f64::max)
                    / length
            })
            .fold(0.0, f64::max)
    }

    /// The time of the last update, s (`None`: none yet).
    pub fn updated_at(&self) -> Option<f64> {
        self.updated_at
    }

    /// How fast the particles moved between the last two updates: the largest distance
    /// a particle moved ([`Self::motion_since_update`]) over the time between them, in
    /// strand lengths per second (0 before a second update, or when both were at the same
    /// time).
    pub fn rate(&self) -> f64 {
        self.rate
    }

    /// The updates since this state was made or restored, and their seconds.
    pub fn updates(&self) -> CoulombUpdates {
        self.updates
    }

    /// Recompute the forces with the particles at `points` ([`Self::positions`]) at time
    /// `time` with the head's frame at (`position`, `rotation`, head to world).
    ///
    /// `scalp`: the charged body ([`super::ScalpCharge`]) and the state of its frame
    /// ([`Body::frame`]).
    pub fn update(
        &mut self,
        points: Vec<[f64; 3]>,
        time: f64,
        (position, rotation): (&Vector3<f64>, &nalgebra::Matrix3<f64>),
        scalp: Option<(&Body, Option<HeadState>)>,
    ) -> Result<FieldSummary, String> {
        let start = Instant::now();
        if points.len() != self.tracers.len() {
            return Err(format!(
                "{} positions for {} charged particles",
                points.len(),
                self.tracers.len()
            ));
        }
        if let Some(before) = self.updated_at {
            if time > before {
                self.rate = self.motion_since_update(&points, position, rotation) / (time - before);
            }
        }
        self.points = points;
        let mut f = [0.0; 12];
        f[..3].copy_from_slice(position.as_slice());
        f[3..].copy_from_slice(rotation.as_slice());
        self.frame = Some(f);
        self.updated_at = Some(time);
        self.charges.clear();
        self.charges
            .extend(self.tracers.charge.iter().map(|q| q * self.scale));
        let softening = Softening {
            radius: self.config.softening,
        };
        match &mut self.fmm {
            Some(fmm) => {
                fmm.evaluate_into(&self.points, &self.charges, &mut self.field)
                    .map_err(|e| e.to_string())?;
            }
            None => {
                let (potential, field) = direct_sum(&self.points, &self.charges, softening);
                self.field = Potentials { potential, field };
            }
        }
        if let (Some((body, frame)), Some(sc)) = (scalp, &self.config.scalp) {
            use rayon::prelude::*;
            let (a, qs) = (self.config.softening, sc.charge * self.scale);
            self.field
                .field
                .par_iter_mut()
                .zip(&self.points)
                .for_each(|(e, x)| {
                    let add = scalp_field(body, frame.as_ref(), &Vector3::from(*x), qs, a)
                        / COULOMB_CONSTANT;
                    for k in 0..3 {
                        e[k] += add[k];
                    }
                });
        }
        self.previous_forces.clear();
        if self.last.particles > 0 {
            self.previous_forces.extend_from_slice(&self.forces);
        }
        let mut sum = 0.0;
        let mut max_force: f64 = 0.0;
        for ((f, e), q) in self
            .forces
            .iter_mut()
            .zip(&self.field.field)
            .zip(&self.charges)
        {
            let e = Vector3::from(*e) * COULOMB_CONSTANT;
            *f = e * *q;
            sum += e.norm();
            max_force = max_force.max(f.norm());
        }
        if let Some(i) = self
            .forces
            .iter()
            .position(|f| !(f.x.is_finite() && f.y.is_finite() && f.z.is_finite()))
        {
            return Err(format!("the Coulomb force on particle {i} is not finite"));
        }
        let n = self.forces.len();
        self.last = FieldSummary {
            particles: n,
            mean_field: if n > 0 { sum / n as f64 } else { 0.0 },
            max_force,
            seconds: start.elapsed().as_secs_f64(),
            multipole: self.fmm.is_some(),
        };
        self.updates.updates += 1;
        self.updates.seconds += self.last.seconds;
        Ok(self.last)
    }

    /// The particles' forces on strand `i` as point loads (world coordinates).
    pub fn loads(&self, i: usize) -> impl Iterator<Item = PointLoad> + '_ {
        let r = self.tracers.of(i);
        self.tracers.s[r.clone()]
            .iter()
            .zip(&self.forces[r])
            .map(|(&s, &force)| PointLoad {
                s,
                force,
                follows: false,
                torque: nalgebra::Vector3::zeros(),
            })
    }

    /// The electrostatic energy of the particles at the last update,
    /// `U = ½ k Σ_i q_i Φ_i` (J): its gradient with respect to a particle's position is
    /// minus the force on it, so `−∂U/∂q` of a strand is its generalized Coulomb force.
    pub fn energy(&self) -> f64 {
        0.5 * COULOMB_CONSTANT
            * self
                .charges
                .iter()
                .zip(&self.field.potential)
                .map(|(q, p)| q * p)
                .sum::<f64>()
    }

    /// The charges of every particle from the last update, C (in the order of
    /// [`Self::particles`]).
    pub fn charges(&self) -> &[f64] {
        &self.charges
    }

    /// The mean |E| over the particles of the last update by the direct sum over every
    /// pair (with the same softening), V/m: a reference for [`FieldSummary::mean_field`]
    /// of the multipole method. `None` with a charged scalp (its field is not summed).
    pub fn direct_mean_field(&self) -> Option<f64> {
        if self.config.scalp.is_some() || self.points.is_empty() {
            return None;
        }
        let softening = Softening {
            radius: self.config.softening,
        };
        let (_, field) = direct_sum(&self.points, &self.charges, softening);
        let sum: f64 = field
            .iter()
            .map(|e| (Vector3::from(*e) * COULOMB_CONSTANT).norm())
            .sum();
        Some(sum / field.len() as f64)
    }

    /// Σ (f − f₋) · (x − p) over strand `i`'s particles: how much the last update changed
    /// Σ f_l · y_l of the strand's charge loads at the state it was made in (f₋ the
    /// forces before it, x the particles' positions, p the head's position; 0 at the
    /// first update). The energy the strand's last step ended with, measured under the
    /// old forces, has its potential V = … − Σ f_l · y_l lower by this under the new ones.
    pub fn load_change(&self, i: usize, head_position: &Vector3<f64>) -> f64 {
        if self.previous_forces.len() != self.forces.len() {
            return 0.0;
        }
        let r = self.tracers.of(i);
        self.forces[r.clone()]
            .iter()
            .zip(&self.previous_forces[r.clone()])
            .zip(&self.points[r])
            .map(|((f, g), x)| (f - g).dot(&(Vector3::from(*x) - head_position)))
            .sum()
    }

    /// Positions (world, m) and forces (N) of every particle from the last update.
    pub fn particles(&self) -> (&[[f64; 3]], &[Vector3<f64>]) {
        (&self.points, &self.forces)
    }
}
