//! A held tip as a holonomic constraint `g(q, t) = 0` on the chain's last pose
//! ([`crate::model::ends`]): its Jacobian, the multipliers of an implicit step, the
//! projection that removes the drift a linearised step leaves, and the reaction at the
//! holder.
//!
//! Rows of g, all in world (= head) coordinates:
//! - pinned: `y(L, q) − p(t)` (3 rows, metres);
//! - sliding: `b_k · (y(L, q) − p(t))` for the two unit vectors b₁, b₂ across the axis
//!   (2 rows);
//! - clamped: the three of pinned, then `φ = log(F_N(q) F*(t)ᵀ)`, the rotation vector
//!   from the held frame to the tip's (3 rows, radians);
//! - clamped-sliding: the two of sliding, then φ (5 rows).
//!
//! The position rows' Jacobian is J(L), the kernel's; the rotation rows' is the tip
//! frame's angular Jacobian: varying d_Q turns every frame after element Q by
//! `ω = l_Q F_{Q+1} J_r(l_Q d_Q) δd_Q` in the world (`F_{Q+1} = F_Q exp(l_Q [d_Q]×)`, and
//! `δ exp([φ]×) = exp([φ]×) [J_r(φ) δφ]×` with J_r the right Jacobian of SO(3)). For φ
//! away from 0 the exact Jacobian of the log is `J_l(φ)⁻¹` times it; the projection
//! converges on the residual whatever, and φ stays at round-off between steps.

use crate::bodies::motion::so3;
use crate::config::HeldEnd;
use crate::forces::head_motion::HeadState;
use crate::model::reconstruction::Pose;
use crate::model::strand::StrandGeometry;
use nalgebra::{Matrix3, Matrix6, Rotation3, UnitQuaternion, Vector3, Vector6};
pub use superhelix_kernels::fixed::REACH_MARGIN;
use superhelix_kernels::fixed::{EndHooks, HeldError};
use superhelix_kernels::storage::Square;
use superhelix_kernels::strand_terms::StrandPoints;

/// The drift a projection leaves, relative to the strand length (positions) or in
/// radians (frames).
pub const PROJECTION_TOLERANCE: f64 = 1e-13;
/// The drift past which a step fails: the constraint could not be met.
pub const DRIFT_LIMIT: f64 = 1e-9;
/// Projection iterations at most.
const PROJECTION_ITERATIONS: usize = 12;

/// The rotation vector φ of a rotation matrix (`exp([φ]×) = m`, |φ| ≤ π), through its
/// unit quaternion (Shepperd's method, robust for any angle) and `2 atan2(|v|, w)`: the
/// `acos` of the trace loses φ to round-off (a NaN when the trace exceeds 3 by an ulp)
/// near the identity, where a held frame spends its time.
fn rotation_log(m: &Matrix3<f64>) -> Vector3<f64> {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*m));
    let (mut w, mut v) = (q.w, q.imag());
    if w < 0.0 {
        w = -w;
        v = -v;
    }
    let n = v.norm();
    if n < 1e-300 {
        return 2.0 * v;
    }
    v * (2.0 * n.atan2(w) / n)
}

/// A held tip's constraint on one strand, with its buffers.
#[derive(Debug, Clone)]
pub struct HeldTip {
    /// What holds the tip, and where.
    pub end: HeldEnd,
    rows: usize,
    /// The Jacobian G, `rows` rows of n.
    g_jac: Vec<Vec<f64>>,
    /// g at the last evaluation.
    residual: Vector6<f64>,
    /// A scale S of the coordinates (1/l₀ on a pinned root's joint).
    scale: Vec<f64>,
    ends: Vec<Pose>,
    jac: Vec<Vector3<f64>>,
    w: Vec<Vec<f64>>,
    /// The reaction of the holder on the tip at the last step or static solve: force
    /// (N) then torque (N·m, clamped tips), world coordinates.
    pub reaction: Vector6<f64>,
    /// Each element's columns C_e of the tip frame's angular Jacobian (scratch of
    /// [`HeldTip::add_torque_stiffness`]).
    columns: Vec<Matrix3<f64>>,
    /// The largest drift left after a projection since the last
    /// [`HeldTip::take_drift`]: |position rows| / L and |rotation rows|.
    drift: f64,
}

/// What a held tip carries from one step to the next (a checkpoint's part): the
/// holder's reaction, the drift not yet reported and the last residual.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HeldTipState {
    reaction: Vector6<f64>,
    residual: Vector6<f64>,
    drift: f64,
}

impl HeldTip {
    /// What the next step needs (see [`HeldTipState`]).
    pub fn state(&self) -> HeldTipState {
        HeldTipState {
            reaction: self.reaction,
            residual: self.residual,
            drift: self.drift,
        }
    }

    /// Continue from `state`.
    pub fn restore(&mut self, state: HeldTipState) {
        self.reaction = state.reaction;
        self.residual = state.residual;
        self.drift = state.drift;
    }

    /// The constraint of `end` on a strand of `geometry`; `scale` as the step's
    /// ([`crate::model::strand::Strand::solver_scale`]).
    pub fn new(end: HeldEnd, geometry: &StrandGeometry, scale: Option<Vec<f64>>) -> Self {
        let n = geometry.dofs();
        let rows = end.kind.rows();
        HeldTip {
            end,
            rows,
            g_jac: vec![vec![0.0; n]; rows],
            residual: Vector6::zeros(),
            scale: scale.unwrap_or_else(|| vec![1.0; n]),
            ends: vec![Pose::default(); geometry.elements() + 1],
            jac: vec![Vector3::zeros(); n],
            w: vec![vec![0.0; n]; rows],
            reaction: Vector6::zeros(),
            columns: vec![Matrix3::zeros(); geometry.elements()],
            drift: 0.0,
        }
    }

    /// The force of the holder on the tip at the last step or static iteration, world
    /// coordinates, N.
    pub fn reaction_force(&self) -> Vector3<f64> {
        self.reaction.fixed_rows::<3>(0).into_owned()
    }

    /// Whether the holder moves (`[strands.ends.tip.motion]`).
    pub fn is_driven(&self) -> bool {
        self.end.motion != crate::forces::head_motion::HeadMotion::Still
    }

    /// The power the holder puts into the strand at time t through its reaction (of the
    /// last step): `f · v_p + τ · ω`, v_p the held point's velocity and ω the holder's
    /// angular velocity (world), W; 0 for a holder at rest.
    pub fn holder_power(&self, t: f64) -> f64 {
        if !self.is_driven() {
            return 0.0;
        }
        let m = self.end.motion.state(t);
        let velocity = m.velocity + m.rotation * m.omega.cross(&self.end.position);
        let omega = m.rotation * m.omega;
        let torque = Vector3::new(self.reaction[3], self.reaction[4], self.reaction[5]);
        self.reaction_force().dot(&velocity) + torque.dot(&omega)
    }

    /// Number of scalar constraints.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// The largest drift since the last call (see the field), reset.
    pub fn take_drift(&mut self) -> f64 {
        std::mem::take(&mut self.drift)
    }

    /// The held place at time t: the point, the frame and the axis, world coordinates.
    pub fn target(&self, t: f64) -> (Vector3<f64>, Matrix3<f64>, Vector3<f64>) {
        let m = self.end.motion.state(t);
        (
            m.position + m.rotation * self.end.position,
            m.rotation * self.end.frame,
            m.rotation * self.end.axis,
        )
    }

    /// Why the tip cannot be held at `t` when the holder is out of the rod's reach: within
    /// [`REACH_MARGIN`] of its length from the root or beyond it (from the root to the axis for a sliding
    /// holder), where the rod would be taut or torn (its constraints dependent); `None`
    /// when the holder is within reach.
    pub fn beyond_reach(&self, geometry: &StrandGeometry, q: &[f64], t: f64) -> Option<HeldError> {
        if geometry.floating {
            return None;
        }
        let root = geometry.root_pose(q).position;
        let (p, _, axis) = self.target(t);
        let d = p - root;
        let distance = if self.end.kind.slides() {
            (d - axis * axis.dot(&d)).norm()
        } else {
            d.norm()
        };
        let length = geometry.length();
        (distance >= (1.0 - REACH_MARGIN) * length).then_some(HeldError::BeyondReach {
            kind: self.end.kind.name(),
            distance,
            length,
            t,
        })
    }

    /// g(q, t) and its Jacobian G into the buffers (read by [`Self::row`], as the
    /// continuation's bordered Newton does); returns the largest |g| relative to
    /// `length` (positions) or in radians.
    pub(crate) fn evaluate(
        &mut self,
        points: &mut dyn StrandPoints,
        geometry: &StrandGeometry,
        q: &[f64],
        t: f64,
    ) -> f64 {
        let n = q.len();
        let length = geometry.length();
        let (p, frame, axis) = self.target(t);
        let y = points.point(q, length, &mut self.jac);
        let d = y - p;
        let across = |a: &Vector3<f64>| {
            let b1 = crate::model::ends::perpendicular(a);
            (b1, a.cross(&b1))
        };
        if self.end.kind.slides() {
            let (b1, b2) = across(&axis);
            for (row, b) in [b1, b2].iter().enumerate() {
                self.residual[row] = b.dot(&d);
                for k in 0..n {
                    self.g_jac[row][k] = b.dot(&self.jac[k]);
                }
            }
        } else {
            for row in 0..3 {
                self.residual[row] = d[row];
                for k in 0..n {
                    self.g_jac[row][k] = self.jac[k][row];
                }
            }
        }
        let p = self.end.kind.position_rows();
        let mut worst = (0..p).map(|r| self.residual[r].abs()).fold(0.0, f64::max) / length;
        if self.end.kind.holds_frame() {
            points.ends(q, &mut self.ends);
            let tip = self.ends[geometry.elements()].frame;
            let phi = rotation_log(&(tip * frame.transpose()));
            for r in 0..3 {
                self.residual[p + r] = phi[r];
            }
            for (e, &l) in geometry.lengths.iter().enumerate() {
                let dq = Vector3::new(q[3 * e], q[3 * e + 1], q[3 * e + 2]);
                let cols = self.ends[e + 1].frame * so3::right_jacobian(&(dq * l)) * l;
                for i in 0..3 {
                    for r in 0..3 {
                        self.g_jac[p + r][3 * e + i] = cols[(r, i)];
                    }
                }
            }
            worst = worst.max(phi.norm());
        }
        worst
    }

    /// The generalized force `G_rotᵀ T` of a torque T (world coordinates) on the tip's
    /// frame: `l_Q J_r(l_Q d_Q)ᵀ F_{Q+1}ᵀ T` on element Q's coordinates, into `out` (the
    /// reference of [`HeldTip::add_torque_stiffness`]'s test).
    #[cfg(test)]
    fn torque_force(
        &mut self,
        points: &mut dyn StrandPoints,
        geometry: &StrandGeometry,
        q: &[f64],
        torque: &Vector3<f64>,
        out: &mut [f64],
    ) {
        points.ends(q, &mut self.ends);
        for (e, &l) in geometry.lengths.iter().enumerate() {
            let dq = Vector3::new(q[3 * e], q[3 * e + 1], q[3 * e + 2]);
            let cols = self.ends[e + 1].frame * so3::right_jacobian(&(dq * l)) * l;
            let g = cols.transpose() * torque;
            out[3 * e..3 * e + 3].copy_from_slice(g.as_slice());
        }
    }

    /// Add the geometric stiffness of the holder's torque (of the last step or static
    /// iteration) to `stiffness` (∂F/∂q): `∂(G_rotᵀ T)/∂q`, the torque held fixed in the
    /// world, symmetrised. It is what makes a clamped tip's twisting moment destabilise a
    /// straight rod (Greenhill): the elastic energy alone has no coupling of twist and
    /// bending. Nothing for a tip whose frame is free or without torque.
    ///
    /// With `C_e = F_{e+1} J_r(l_e d_e) l_e` (element e's columns of G_rot), element e's
    /// generalized torque is `Q_e = C_eᵀ T`. Varying `d_k` for k ≤ e turns `F_{e+1}` by
    /// `[C_k δd]×`, so `∂Q_e/∂d_k = C_eᵀ [T]× C_k`; for k = e, `J_r(l_e d_e)` varies too,
    /// adding `l_e (∂J_r/∂φ · l_e e_i)ᵀ F_{e+1}ᵀ T` as column i; for k > e it is zero.
    /// O(N²) 3 × 3 blocks from one chain of element frames.
    pub fn add_torque_stiffness(
        &mut self,
        points: &mut dyn StrandPoints,
        geometry: &StrandGeometry,
        q: &[f64],
        stiffness: &mut impl FnMut(usize, usize, f64),
    ) {
        let torque = Vector3::new(self.reaction[3], self.reaction[4], self.reaction[5]);
        if !self.end.kind.holds_frame() || torque == Vector3::zeros() {
            return;
        }
        points.ends(q, &mut self.ends);
        let elements = geometry.elements();
        let tx = so3::hat(&torque);
        for e in 0..elements {
            let l = geometry.lengths[e];
            let phi = Vector3::new(q[3 * e], q[3 * e + 1], q[3 * e + 2]) * l;
            self.columns[e] = self.ends[e + 1].frame * so3::right_jacobian(&phi) * l;
        }
        let columns = &self.columns;
        let mut add = |row: usize, col: usize, block: &Matrix3<f64>| {
            for a in 0..3 {
                for b in 0..3 {
                    stiffness(3 * row + a, 3 * col + b, block[(a, b)]);
                }
            }
        };
        for e in 0..elements {
            let left = columns[e].transpose() * tx;
            for k in 0..e {
                let block = left * columns[k] * 0.5;
                add(e, k, &block);
                add(k, e, &block.transpose());
            }
            let mut block = left * columns[e];
            let l = geometry.lengths[e];
            let phi = Vector3::new(q[3 * e], q[3 * e + 1], q[3 * e + 2]) * l;
            let w = self.ends[e + 1].frame.transpose() * torque;
            for i in 0..3 {
                let direction = Vector3::ith(i, l);
                let column = so3::right_jacobian_rate(&phi, &direction).transpose() * w * l;
                for a in 0..3 {
                    block[(a, i)] += column[a];
                }
            }
            add(e, e, &((block + block.transpose()) * 0.5));
        }
    }

    /// `(G W)⁻¹ x` for the rows in use, W = S² Gᵀ (or the columns in `self.w`), with the
    /// unused rows of a 6 × 6 system set to the identity.
    fn solve_rows(&self, x: &Vector6<f64>) -> Option<Vector6<f64>> {
        let mut s = Matrix6::identity();
        for a in 0..self.rows {
            for b in 0..self.rows {
                s[(a, b)] = self.g_jac[a]
                    .iter()
                    .zip(&self.w[b])
                    .map(|(g, w)| g * w)
                    .sum();
            }
        }
        let mut rhs = Vector6::zeros();
        for r in 0..self.rows {
            rhs[r] = x[r];
        }
        let out = s.lu().solve(&rhs)?;
        out.iter().all(|v| v.is_finite()).then_some(out)
    }

    /// W = S² Gᵀ: the scaled identity metric of the projections.
    fn metric_columns(&mut self) {
        for r in 0..self.rows {
            for (k, w) in self.w[r].iter_mut().enumerate() {
                *w = self.scale[k] * self.scale[k] * self.g_jac[r][k];
            }
        }
    }

    /// Project q onto g(q, t) = 0 along `S² Gᵀ` (Gauss–Newton), to
    /// [`PROJECTION_TOLERANCE`]; records the drift left. Errors when it stays above
    /// [`DRIFT_LIMIT`].
    pub fn project(
        &mut self,
        points: &mut dyn StrandPoints,
        geometry: &StrandGeometry,
        q: &mut [f64],
        t: f64,
    ) -> Result<f64, HeldError> {
        let mut worst = self.evaluate(points, geometry, q, t);
        for _ in 0..PROJECTION_ITERATIONS {
            if worst <= PROJECTION_TOLERANCE {
                break;
            }
            self.metric_columns();
            let Some(mu) = self.solve_rows(&self.residual) else {
                break;
            };
            for r in 0..self.rows {
                for (qk, w) in q.iter_mut().zip(&self.w[r]) {
                    *qk -= w * mu[r];
                }
            }
            worst = self.evaluate(points, geometry, q, t);
        }
        if worst.is_nan() || worst > DRIFT_LIMIT {
            if let Some(cause) = self.beyond_reach(geometry, q, t) {
                return Err(cause);
            }
            return Err(HeldError::NotKept {
                kind: self.end.kind.name(),
                off: worst,
            });
        }
        self.drift = self.drift.max(worst);
        Ok(worst)
    }

    /// The multipliers of a linearly implicit step whose unconstrained velocities
    /// `v` (`A v = r`) were just solved with the factors of A in `solve`: replaces `v`
    /// by `v − A⁻¹Gᵀλ` with `G v = −g(q, t + h)/h`, so that the linearised tip lands on
    /// the holder at the step's end, and records the reaction `−λ/h`.
    pub fn constrain_velocities(
        &mut self,
        points: &mut dyn StrandPoints,
        geometry: &StrandGeometry,
        solve: &mut impl FnMut(&mut [f64]) -> bool,
        q: &[f64],
        v: &mut [f64],
        t_end: f64,
        h: f64,
    ) -> Result<(), HeldError> {
        self.prepare_change(points, geometry, solve, q, t_end)
            .ok_or(HeldError::SingularStep)?;
        let mut x = Vector6::zeros();
        for r in 0..self.rows {
            let gv: f64 = self.g_jac[r].iter().zip(v.iter()).map(|(g, v)| g * v).sum();
            x[r] = gv + self.residual[r] / h;
        }
        let lambda = self.solve_rows(&x).ok_or_else(|| {
            self.beyond_reach(geometry, q, t_end)
                .unwrap_or(HeldError::Dependent)
        })?;
        for r in 0..self.rows {
            for (vk, w) in v.iter_mut().zip(&self.w[r]) {
                *vk -= w * lambda[r];
            }
        }
        self.record_reaction(&(-lambda / h), t_end);
        Ok(())
    }

    /// The reaction at the start of a dynamic run, the strand at rest: the multipliers μ
    /// that keep the tip's acceleration on the holder, `M a = F + Gᵀμ`, `G a = 0`, i.e.
    /// `μ = −(G M⁻¹ Gᵀ)⁻¹ G M⁻¹ F` (a driven holder's own acceleration at t left out).
    /// `solve` solves with M (its factors), `force` is F at (q, 0).
    pub fn start_reaction(
        &mut self,
        points: &mut dyn StrandPoints,
        geometry: &StrandGeometry,
        solve: &mut impl FnMut(&mut [f64]) -> bool,
        q: &[f64],
        force: &[f64],
        t: f64,
    ) -> Result<(), String> {
        self.prepare_change(points, geometry, solve, q, t)
            .ok_or("held tip: singular mass matrix")?;
        let mut accel = force.to_vec();
        if !solve(&mut accel) {
            return Err("held tip: singular mass matrix".into());
        }
        let mut x = Vector6::zeros();
        for r in 0..self.rows {
            x[r] = -self.g_jac[r]
                .iter()
                .zip(&accel)
                .map(|(g, a)| g * a)
                .sum::<f64>();
        }
        let mu = self
            .solve_rows(&x)
            .ok_or("held tip: the constraints are dependent (singular G M⁻¹ Gᵀ)")?;
        self.record_reaction(&mu, t);
        Ok(())
    }

    /// The rows at (q, t), and the columns `w_r = A⁻¹ g_r` with the factors in `solve`
    /// (`None`: not finite): what [`Self::constrain_velocities`] and
    /// [`Self::start_reaction`] start from, and what [`Self::constrain_change`] needs for a
    /// change of velocity after the step's solve (the pair solve of two strands,
    /// [`super::pair_coupling`]).
    pub(crate) fn prepare_change(
        &mut self,
        points: &mut dyn StrandPoints,
        geometry: &StrandGeometry,
        solve: &mut impl FnMut(&mut [f64]) -> bool,
        q: &[f64],
        t: f64,
    ) -> Option<()> {
        self.evaluate(points, geometry, q, t);
        for r in 0..self.rows {
            self.w[r].copy_from_slice(&self.g_jac[r]);
            if !solve(&mut self.w[r]) {
                return None;
            }
        }
        Some(())
    }

    /// A velocity change `u = A⁻¹ Q` (of a generalized impulse Q) made to keep the
    /// linearised tip on its holder: `u − A⁻¹Gᵀλ` with `G (u − A⁻¹Gᵀλ) = 0`. Returns λ,
    /// the holder's impulse against Q (see [`Self::add_impulse`]); `None` when the rows
    /// are dependent. Needs [`Self::prepare_change`].
    pub(crate) fn constrain_change(&self, u: &mut [f64]) -> Option<Vector6<f64>> {
        let mut x = Vector6::zeros();
        for r in 0..self.rows {
            x[r] = self.g_jac[r].iter().zip(u.iter()).map(|(g, v)| g * v).sum();
        }
        let lambda = self.solve_rows(&x)?;
        for r in 0..self.rows {
            for (uk, w) in u.iter_mut().zip(&self.w[r]) {
                *uk -= w * lambda[r];
            }
        }
        Some(lambda)
    }

    /// Add the holder's impulse `λ` (of [`Self::constrain_change`]) over a step of `h`
    /// to the reaction recorded at `t`.
    pub(crate) fn add_impulse(&mut self, lambda: &Vector6<f64>, h: f64, t: f64) {
        let r = self.reaction_of(&(-lambda / h), t);
        self.reaction += r;
    }

    /// The reaction from multipliers μ of the rows (generalized force Gᵀμ on the strand).
    fn record_reaction(&mut self, mu: &Vector6<f64>, t: f64) {
        self.reaction = self.reaction_of(mu, t);
    }

    /// The reaction (force, torque; world) of the multipliers μ at `t`.
    fn reaction_of(&self, mu: &Vector6<f64>, t: f64) -> Vector6<f64> {
        let mut r = Vector6::zeros();
        let kind = self.end.kind;
        if kind.slides() {
            let (_, _, axis) = self.target(t);
            let b1 = crate::model::ends::perpendicular(&axis);
            let f = b1 * mu[0] + axis.cross(&b1) * mu[1];
            r.fixed_rows_mut::<3>(0).copy_from(&f);
        } else {
            r.fixed_rows_mut::<3>(0).copy_from(&mu.fixed_rows::<3>(0));
        }
        if kind.holds_frame() {
            let p = kind.position_rows();
            for k in 0..3 {
                r[3 + k] = mu[p + k];
            }
        }
        r
    }

    /// For the static solve at (q, t): the multipliers μ that best balance the
    /// generalized force `force` (least squares in the scaled metric,
    /// `min |S (F + Gᵀμ)|`), the balanced force `F + Gᵀμ` written over `force`, and the
    /// reaction recorded. Returns the largest |g|.
    pub fn balance_static(
        &mut self,
        points: &mut dyn StrandPoints,
        geometry: &StrandGeometry,
        q: &[f64],
        force: &mut [f64],
        t: f64,
    ) -> Option<f64> {
        let worst = self.evaluate(points, geometry, q, t);
        self.metric_columns();
        let mut x = Vector6::zeros();
        for r in 0..self.rows {
            x[r] = -self.w[r]
                .iter()
                .zip(force.iter())
                .map(|(w, f)| w * f)
                .sum::<f64>();
        }
        let mu = self.solve_rows(&x)?;
        for r in 0..self.rows {
            for (f, g) in force.iter_mut().zip(&self.g_jac[r]) {
                *f += g * mu[r];
            }
        }
        self.record_reaction(&mu, t);
        Some(worst)
    }

    /// Row r of g and of G of the last evaluation.
    pub(crate) fn row(&self, r: usize) -> (f64, &[f64]) {
        (self.residual[r], &self.g_jac[r])
    }

    /// Record the reaction of multipliers μ of the rows at `t` (its generalized force on
    /// the strand is Gᵀμ): what the next assembly's geometric stiffness takes.
    pub(crate) fn set_multipliers(&mut self, mu: &Vector6<f64>, t: f64) {
        self.record_reaction(mu, t);
    }

    /// ∂g/∂a of the holder moved by a along the unit vector `direction` (world): the
    /// position rows' −direction, across the axis for a sliding holder; 0 for the
    /// rotation rows.
    pub(crate) fn rows_along(&self, direction: &Vector3<f64>, t: f64) -> Vector6<f64> {
        let mut out = Vector6::zeros();
        if self.end.kind.slides() {
            let (_, _, axis) = self.target(t);
            let b1 = crate::model::ends::perpendicular(&axis);
            out[0] = -b1.dot(direction);
            out[1] = -axis.cross(&b1).dot(direction);
        } else {
            for r in 0..3 {
                out[r] = -direction[r];
            }
        }
        out
    }

    /// ρ for [`HeldTip::augment`] of the order of the stiffness `k` over the largest
    /// diagonal of GᵀG (G of the last evaluation).
    pub fn augmentation_scale(&self, k: f64) -> f64 {
        let n = self.scale.len();
        let largest = (0..n)
            .map(|i| {
                (0..self.rows)
                    .map(|r| self.g_jac[r][i].powi(2))
                    .sum::<f64>()
            })
            .fold(0.0f64, f64::max);
        if largest > 0.0 {
            k / largest
        } else {
            0.0
        }
    }

    /// `H += ρ GᵀG` and `F −= ρ Gᵀg` (the augmented Lagrangian's Newton system; G and g
    /// of the last evaluation).
    pub fn augment(&self, h: &mut faer::Mat<f64>, rhs: &mut [f64], rho: f64) {
        let n = self.scale.len();
        for r in 0..self.rows {
            let g = &self.g_jac[r];
            for j in 0..n {
                let gj = rho * g[j];
                if gj == 0.0 {
                    continue;
                }
                for i in 0..n {
                    h[(i, j)] += g[i] * gj;
                }
                rhs[j] -= gj * self.residual[r];
            }
        }
    }

    /// The Newton direction of the static solve under the constraint: given `hinv_f`
    /// = H⁻¹F and a solver of H (its factors), `Δ = H⁻¹F − H⁻¹Gᵀμ` with
    /// `G Δ = −g`, written over `hinv_f`. Uses g and G of the last
    /// [`HeldTip::balance_static`].
    pub fn static_direction(
        &mut self,
        solve: &mut impl FnMut(&mut [f64]) -> bool,
        hinv_f: &mut [f64],
    ) -> Result<(), String> {
        for r in 0..self.rows {
            self.w[r].copy_from_slice(&self.g_jac[r]);
            if !solve(&mut self.w[r]) {
                return Err("static solve: singular Hessian with the held tip".into());
            }
        }
        let mut x = Vector6::zeros();
        for r in 0..self.rows {
            let gd: f64 = self.g_jac[r]
                .iter()
                .zip(hinv_f.iter())
                .map(|(g, d)| g * d)
                .sum();
            x[r] = gd + self.residual[r];
        }
        let mu = self
            .solve_rows(&x)
            .ok_or("static solve: the held tip's constraints are dependent")?;
        for r in 0..self.rows {
            for (d, w) in hinv_f.iter_mut().zip(&self.w[r]) {
                *d -= w * mu[r];
            }
        }
        Ok(())
    }
}

/// A held tip as the one step's hook ([`EndHooks`]): the tip and the geometry of its
/// strand (the root its reach is measured from).
#[derive(Debug)]
pub struct HeldHook<'a> {
    /// The tip's constraint.
    pub tip: &'a mut HeldTip,
    /// Its strand's geometry.
    pub geometry: &'a StrandGeometry,
}

impl EndHooks<f64> for HeldHook<'_> {
    fn tip_force(&self, head: &HeadState) -> Vector3<f64> {
        head.rotation.transpose() * self.tip.reaction_force()
    }

    fn add_stiffness(
        &mut self,
        points: &mut dyn StrandPoints,
        q: &[f64],
        stiffness: &mut Square<'_, f64>,
    ) -> bool {
        // a clamped tip's torque, through the turning of the tip's frame (the head is
        // still under a held tip: head and world coordinates agree)
        let tip = &mut *self.tip;
        if !(tip.end.kind.holds_frame() && tip.reaction.fixed_rows::<3>(3).norm() > 0.0) {
            return false;
        }
        tip.add_torque_stiffness(points, self.geometry, q, &mut |i, j, x| {
            stiffness[j][i] += x
        });
        true
    }

    fn constrain(
        &mut self,
        points: &mut dyn StrandPoints,
        solve: &mut dyn FnMut(&mut [f64]) -> bool,
        q: &[f64],
        v: &mut [f64],
        t_end: f64,
        h: f64,
    ) -> Result<(), HeldError> {
        self.tip
            .constrain_velocities(points, self.geometry, &mut |x| solve(x), q, v, t_end, h)
    }

    fn project(
        &mut self,
        points: &mut dyn StrandPoints,
        q: &mut [f64],
        t: f64,
    ) -> Result<(), HeldError> {
        self.tip.project(points, self.geometry, q, t).map(|_| ())
    }

    fn beyond_reach(&self, q: &[f64], t: f64) -> Option<HeldError> {
        self.tip.beyond_reach(self.geometry, q, t)
    }

    fn power(&self, t: f64) -> f64 {
        self.tip.holder_power(t)
    }

    fn driven(&self) -> bool {
        self.tip.is_driven()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::forces::head_motion::HeadMotion;
    use crate::model::ends::HeldKind;

    #[test]
    fn the_torque_stiffness_is_the_derivative_of_the_generalized_torque() {
        // a twisted, bent strand of 6 elements (a pinned root's sliver of a joint first)
        // under a torque: the analytic blocks against central differences of G_rotᵀ T,
        // symmetrised
        let mut lengths = vec![1e-12];
        lengths.extend([0.02; 6]);
        let geometry = StrandGeometry {
            root_position: Vector3::zeros(),
            root_frame: Matrix3::identity(),
            lengths,
            mass_per_length: 1e-5,
            rotary_inertia: [0.0; 3],
            floating: false,
        };
        let n = geometry.dofs();
        let q: Vec<f64> = (0..n)
            .map(|i| {
                if i < 3 {
                    3e10 * (i as f64 - 1.0)
                } else {
                    20.0 * ((i as f64) * 1.7).sin()
                }
            })
            .collect();
        let mut kernel = crate::kernels::closed_form::moment_kernel(&geometry);
        let end = HeldEnd {
            kind: HeldKind::Clamped,
            position: Vector3::zeros(),
            frame: Matrix3::identity(),
            axis: Vector3::x(),
            motion: HeadMotion::Still,
        };
        let mut tip = HeldTip::new(end, &geometry, None);
        tip.reaction = Vector6::new(0.0, 0.0, 0.0, 2e-6, -1e-6, 3e-6);
        let torque = Vector3::new(2e-6, -1e-6, 3e-6);
        let mut analytic = faer::Mat::<f64>::zeros(n, n);
        let mut points = crate::kernels::step_terms::KernelPoints(kernel.as_mut());
        tip.add_torque_stiffness(&mut points, &geometry, &q, &mut |i, j, x| {
            analytic[(i, j)] += x
        });
        // central differences, a rotation of 1e-6 rad per element
        let mut x = q.clone();
        let (mut plus, mut minus) = (vec![0.0; n], vec![0.0; n]);
        let mut worst: f64 = 0.0;
        let mut largest: f64 = 0.0;
        let mut fd = vec![vec![0.0; n]; n];
        for j in 0..n {
            let h = 1e-6 / geometry.lengths[j / 3];
            x[j] = q[j] + h;
            tip.torque_force(&mut points, &geometry, &x, &torque, &mut plus);
            x[j] = q[j] - h;
            tip.torque_force(&mut points, &geometry, &x, &torque, &mut minus);
            x[j] = q[j];
            for i in 0..n {
                fd[i][j] = (plus[i] - minus[i]) / (2.0 * h);
            }
        }
        for i in 0..n {
            for j in 0..n {
                // compare in the solver's units (a joint coordinate is θ / l₀)
                let scale = geometry.lengths[i / 3] * geometry.lengths[j / 3];
                let reference = 0.5 * (fd[i][j] + fd[j][i]) * scale;
                largest = largest.max(reference.abs());
                worst = worst.max((analytic[(i, j)] * scale - reference).abs());
            }
        }
        assert!(largest > 0.0);
        assert!(worst < 1e-6 * largest, "{worst:e} of {largest:e}");
    }
}
