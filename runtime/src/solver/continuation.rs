//! One strand's static equilibria followed as a parameter changes: pseudo-arclength
//! continuation (Keller) of `F(q, a) + Gᵀμ = 0`, `g(q, a) = 0`, where F is the
//! generalized force of the static solve ([`super::statics`]: elasticity (5c)/(5d),
//! gravity, point loads) and g the held tip's constraint ([`super::held_end`]).
//!
//! The parameter a is either a scale of the strand's point loads (load control) or the
//! displacement of its holder along a direction (displacement control). Each point is
//! found by Newton on the bordered system
//!
//! ```text
//! [ K    Gᵀ  F_a ] [Δq]     [ F + Gᵀμ     ]
//! [ G    0   g_a ] [Δμ] = − [ g           ]
//! [ wt_q 0   t_a ] [Δa]     [ t·(x − x_p) ]
//! ```
//!
//! with K = ∂(F + Gᵀμ)/∂q (the holder's reaction's geometric stiffness in it) and the
//! last row the arclength hyperplane through the predictor x_p = x_k + h t_k, normal to
//! the tangent t_k. The matrix stays regular at a fold, where K is singular, so the
//! branch is followed through it and onto its unstable part instead of jumping to
//! another branch as a load-stepped static solve does.
//!
//! A fold is where the tangent's parameter component t_a changes sign; it is located on
//! the branch by regula falsi on t_a along the arclength. Each point also carries the
//! number of unstable directions of the energy on the constraint (the negative
//! eigenvalues of the bordered Hessian `[−K Gᵀ; G 0]` less the constraint count), so a
//! branch point, where that number changes without a fold, is seen too. Such a change
//! is first refined with smaller steps: at a sharp corner of an imperfect bifurcation a
//! long step can land on the neighbouring branch, whose stability differs.

use faer::{Mat, Side};
use nalgebra::{Vector3, Vector6};

use super::statics::{solve_static, StaticReport};
use super::system::StrandSystem;
use crate::bodies::Placement;
use crate::kernels::kernel::Terms;
use crate::kernels::step_terms::KernelPoints;
use superhelix_kernels::strand_terms::StrandPoints;

/// What the continuation's parameter a is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BranchParameter {
    /// a scales the strand's point loads as they are when the continuation starts
    /// (dimensionless; 1: the loads as given).
    LoadScale,
    /// a moves the held tip's holder from where it is when the continuation starts,
    /// along the unit vector `direction` (world coordinates), metres.
    Holder {
        /// Unit vector of the move.
        direction: Vector3<f64>,
    },
}

/// How far and in what steps a branch is followed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContinuationSettings {
    /// The parameter.
    pub parameter: BranchParameter,
    /// a at the first point: the static equilibrium there, from the strand's q as a
    /// guess, starts the branch.
    pub start: f64,
    /// The branch ends at the point where a reaches `stop` (it sets the direction the
    /// branch leaves `start` in).
    pub stop: f64,
    /// The first arclength step, in the scaled norm
    /// `|Δx|² = Σ_e (l_e Δq_e)² + (Δa/σ)²` (radians of bend per element, a pinned root's
    /// joint its rotation; σ = 1 for a load scale, the strand's length for a holder).
    pub step: f64,
    /// The largest step the adaptation may take (same norm).
    pub max_step: f64,
    /// Points at most (the start included).
    pub max_points: usize,
}

/// One equilibrium on the branch.
#[derive(Debug, Clone, PartialEq)]
pub struct BranchPoint {
    /// The parameter a.
    pub parameter: f64,
    /// The strand's q.
    pub q: Vec<f64>,
    /// The tip's position, world coordinates (the head at rest), m.
    pub tip: Vector3<f64>,
    /// The holder's reaction on the tip: force (N) then torque (N·m), world; zero
    /// without a held tip.
    pub reaction: Vector6<f64>,
    /// Directions in which the energy decreases on the constraint (0: stable).
    pub unstable: usize,
    /// The potential energy (elastic, gravity, point loads at this a), J.
    pub energy: f64,
}

/// A fold (limit point) of the parameter on the branch.
#[derive(Debug, Clone, PartialEq)]
pub struct Fold {
    /// It lies between points `after` and `after + 1` of the branch.
    pub after: usize,
    /// The equilibrium at the fold.
    pub point: BranchPoint,
}

/// Why the branch ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BranchEnd {
    /// The parameter reached `stop`.
    Reached,
    /// `max_points` points were taken first.
    MaxPoints,
    /// The corrector failed with steps below a millionth of `step`, at this parameter
    /// (the holder beyond the rod's reach, a singular branch point).
    Stalled {
        /// The parameter of the last point.
        parameter: f64,
    },
}

/// A followed branch.
#[derive(Debug, Clone, PartialEq)]
pub struct Branch {
    /// Its points, in order along the arclength.
    pub points: Vec<BranchPoint>,
    /// Its folds, in order.
    pub folds: Vec<Fold>,
    /// The points after which the count of unstable directions changed without a fold,
    /// with steps refined to a thousandth of the first: branch points crossed (the
    /// followed branch goes on; another crosses it there).
    pub branch_points: Vec<usize>,
    /// Why it ended.
    pub end: BranchEnd,
    /// The static solve that found the first point.
    pub start: StaticReport,
}

/// Newton iterations of one correction at most.
const CORRECTOR_ITERATIONS: usize = 12;
/// Relative tolerance on the generalized force of a corrected point.
const CORRECTOR_TOLERANCE: f64 = 1e-10;
/// Constraint tolerance of a corrected point (|g|/L, radians).
const CONSTRAINT_TOLERANCE: f64 = 1e-12;
/// The step, relative to the first, down to which a change of stability without a fold
/// is refined before it is taken for a branch point.
const BRANCH_POINT_STEP: f64 = 1e-3;
/// Singular values below this fraction of the largest are a zero mode of the bordered
/// matrix (the least-norm solve leaves them out).
const SINGULAR: f64 = 1e-12;
/// Smallest cosine between consecutive tangents: a sharper turn is a step too long
/// (the corrector may have landed on another branch).
const TURN_COSINE: f64 = 0.95;

/// A point in the bordered unknowns.
#[derive(Debug, Clone)]
struct State {
    q: Vec<f64>,
    mu: Vector6<f64>,
    a: f64,
}

/// The tangent (q, μ, a), unit in the scaled norm.
#[derive(Debug, Clone)]
struct Tangent {
    q: Vec<f64>,
    mu: Vector6<f64>,
    a: f64,
}

/// The last row of the bordered system.
enum LastRow<'a> {
    /// Arclength: through the predictor, normal to the tangent.
    Arclength(&'a State, &'a Tangent, f64),
    /// a fixed at a value.
    Fixed(f64),
}

struct Tracer<'a> {
    system: &'a mut StrandSystem,
    parameter: BranchParameter,
    base_loads: Vec<crate::model::strand::PointLoad>,
    holder: Vector3<f64>,
    /// The norm's weights of q (element lengths) and σ of a.
    w: Vec<f64>,
    sigma: f64,
    n: usize,
    m: usize,
    force_scale: f64,
    /// Solver scale S (1 but on a pinned root's joint).
    scale: Vec<f64>,
    matrix: Mat<f64>,
    /// F + Gᵀμ, g, and the row's residual at the last assembly.
    residual: Vec<f64>,
    zero: Vec<f64>,
}

impl Tracer<'_> {
    fn set_parameter(&mut self, a: f64) {
        match self.parameter {
            BranchParameter::LoadScale => {
                for (l, b) in self
                    .system
                    .strand
                    .point_loads
                    .iter_mut()
                    .zip(&self.base_loads)
                {
                    l.force = b.force * a;
                }
            }
            BranchParameter::Holder { direction } => {
                if let Some(h) = self.system.held.as_mut() {
                    h.end.position = self.holder + direction * a;
                }
            }
        }
    }

    /// Assemble the bordered matrix and the residual at `x` (the last row as `row`
    /// says). Returns the scaled residual's largest generalized force and constraint.
    fn assemble(&mut self, x: &State, row: &LastRow) -> (f64, f64) {
        let (n, m) = (self.n, self.m);
        let at = Placement::at_rest(0.0);
        self.set_parameter(x.a);
        if let Some(h) = self.system.held.as_mut() {
            h.set_multipliers(&x.mu, 0.0);
        }
        let full = Terms {
            force: true,
            stiffness: true,
            ..Default::default()
        };
        self.system.assemble(&at, &x.q, &self.zero, full);
        let d = n + m + 1;
        self.matrix.fill(0.0);
        {
            let t = &self.system.workspace.terms;
            for j in 0..n {
                for i in 0..n {
                    self.matrix[(i, j)] = t.stiffness[(i, j)];
                }
            }
            self.residual[..n].copy_from_slice(&t.force);
        }
        // ∂F/∂a: the loads' generalized force at scale 1 (they are linear in a)
        if let BranchParameter::LoadScale = self.parameter {
            let force = self.residual[..n].to_vec();
            self.set_parameter(x.a + 1.0);
            let only = Terms {
                force: true,
                ..Default::default()
            };
            self.system.assemble(&at, &x.q, &self.zero, only);
            for i in 0..n {
                self.matrix[(i, d - 1)] = self.system.workspace.terms.force[i] - force[i];
            }
            self.set_parameter(x.a);
        }
        let mut worst_g = 0.0f64;
        if let Some(h) = self.system.held.as_mut() {
            let length = self.system.strand.geometry.length();
            h.evaluate(
                &mut KernelPoints(self.system.kernel.as_mut()),
                &self.system.strand.geometry,
                &x.q,
                0.0,
            );
            let along = match self.parameter {
                BranchParameter::Holder { direction } => h.rows_along(&direction, 0.0),
                BranchParameter::LoadScale => Vector6::zeros(),
            };
            let position_rows = h.end.kind.position_rows();
            for r in 0..m {
                let (g, row) = h.row(r);
                for j in 0..n {
                    self.matrix[(n + r, j)] = row[j];
                    self.matrix[(j, n + r)] = row[j];
                    self.residual[j] += row[j] * x.mu[r];
                }
                self.matrix[(n + r, d - 1)] = along[r];
                self.residual[n + r] = g;
                let g = if r < position_rows { g / length } else { g };
                worst_g = worst_g.max(g.abs());
            }
        }
        match row {
            LastRow::Arclength(from, t, s) => {
                let mut r = 0.0;
                for i in 0..n {
                    let w2 = self.w[i] * self.w[i];
                    self.matrix[(d - 1, i)] = w2 * t.q[i];
                    r += w2 * t.q[i] * (x.q[i] - from.q[i]);
                }
                let s2 = 1.0 / (self.sigma * self.sigma);
                self.matrix[(d - 1, d - 1)] = s2 * t.a;
                r += s2 * t.a * (x.a - from.a);
                self.residual[d - 1] = r - s;
            }
            LastRow::Fixed(a) => {
                self.matrix[(d - 1, d - 1)] = 1.0;
                self.residual[d - 1] = x.a - a;
            }
        }
        let worst_f = (0..n)
            .map(|i| (self.residual[i] * self.scale[i]).abs())
            .fold(0.0, f64::max);
        (worst_f, worst_g)
    }

    /// Solve the bordered matrix of the last assembly for `rhs` in place (`false`: not
    /// finite), in the arclength's units, `(R D A D) y = R D b` and x = D y, with
    /// D = 1/w on q (y: radians of bend per element, a pinned root's joint its
    /// rotation), σ on a, and R each row's largest entry's inverse: by the SVD, the
    /// solution of least norm in y, so that a symmetry's zero mode (a rod held at two
    /// points turning about the line through them) is left out of the step instead of
    /// making it singular.
    fn solve(&mut self, rhs: &mut [f64]) -> bool {
        let d = rhs.len();
        let unit = |i: usize| self.unit(i);
        let units: Vec<f64> = (0..d).map(unit).collect();
        let unit = |i: usize| units[i];
        for j in 0..d {
            for i in 0..d {
                self.matrix[(i, j)] *= unit(i) * unit(j);
            }
        }
        let mut b = vec![0.0; d];
        for i in 0..d {
            let row = (0..d)
                .map(|j| self.matrix[(i, j)].abs())
                .fold(0.0, f64::max);
            let r = if row > 0.0 { 1.0 / row } else { 1.0 };
            for j in 0..d {
                self.matrix[(i, j)] *= r;
            }
            b[i] = rhs[i] * unit(i) * r;
        }
        let Ok(svd) = self.matrix.svd() else {
            return false;
        };
        let (u, sv, v) = (svd.U(), svd.S().column_vector(), svd.V());
        let top = (0..d).map(|k| sv[k].abs()).fold(0.0, f64::max);
        let mut y = vec![0.0; d];
        for k in 0..d {
            if sv[k].abs() <= SINGULAR * top {
                continue;
            }
            let c = (0..d).map(|i| u[(i, k)] * b[i]).sum::<f64>() / sv[k];
            for (j, yj) in y.iter_mut().enumerate() {
                *yj += v[(j, k)] * c;
            }
        }
        for i in 0..d {
            rhs[i] = y[i] * unit(i);
        }
        rhs.iter().all(|x| x.is_finite())
    }

    /// The unit of unknown i in the scaled solve: 1/w on q, 1 on μ, σ on a.
    fn unit(&self, i: usize) -> f64 {
        if i < self.n {
            1.0 / self.w[i]
        } else if i == self.n + self.m {
            self.sigma
        } else {
            1.0
        }
    }

    /// The zero modes of the constrained stiffness `[K Gᵀ; G 0]` of the last assembly
    /// (in the scaled unknowns of [`Self::solve`], unit vectors): a symmetry of the
    /// held rod, such as a rod held at two points turning about the line through them,
    /// along which the equilibrium moves at no cost. Empty on a branch without one.
    fn zero_modes(&self) -> Vec<Vec<f64>> {
        let k = self.n + self.m;
        let mut b = Mat::<f64>::zeros(k, k);
        for j in 0..k {
            for i in 0..k {
                b[(i, j)] = self.matrix[(i, j)] * self.unit(i) * self.unit(j);
            }
        }
        for i in 0..k {
            let row = (0..k).map(|j| b[(i, j)].abs()).fold(0.0, f64::max);
            if row > 0.0 {
                for j in 0..k {
                    b[(i, j)] /= row;
                }
            }
        }
        let Ok(svd) = b.svd() else {
            return Vec::new();
        };
        let (sv, v) = (svd.S().column_vector(), svd.V());
        let top = (0..k).map(|c| sv[c].abs()).fold(0.0, f64::max);
        (0..k)
            .filter(|&c| sv[c].abs() <= SINGULAR * top)
            .map(|c| (0..k).map(|i| v[(i, c)]).collect())
            .collect()
    }

    /// Newton on the bordered system from `x` (in place). Ok(iterations) when it meets
    /// the tolerances.
    fn correct(&mut self, x: &mut State, row: &LastRow) -> Option<usize> {
        let (n, m) = (self.n, self.m);
        let d = n + m + 1;
        let mut rhs = vec![0.0; d];
        for iteration in 0..=CORRECTOR_ITERATIONS {
            let (f, g) = self.assemble(x, row);
            let row_ok = match row {
                LastRow::Arclength(..) => self.residual[d - 1].abs() <= 1e-12,
                LastRow::Fixed(_) => self.residual[d - 1] == 0.0,
            };
            if !(f.is_finite() && g.is_finite()) {
                return None;
            }
            if f <= CORRECTOR_TOLERANCE * self.force_scale && g <= CONSTRAINT_TOLERANCE && row_ok {
                return Some(iteration);
            }
            if iteration == CORRECTOR_ITERATIONS {
                return None;
            }
            for i in 0..d {
                rhs[i] = -self.residual[i];
            }
            if !self.solve(&mut rhs) {
                return None;
            }
            for i in 0..n {
                x.q[i] += rhs[i];
            }
            for r in 0..m {
                x.mu[r] += rhs[n + r];
            }
            x.a = match row {
                LastRow::Fixed(a) => *a,
                LastRow::Arclength(..) => x.a + rhs[d - 1],
            };
        }
        None
    }

    fn norm(&self, q: &[f64], a: f64) -> f64 {
        let s: f64 = q.iter().zip(&self.w).map(|(q, w)| (q * w).powi(2)).sum();
        (s + (a / self.sigma).powi(2)).sqrt()
    }

    /// The unit tangent at the corrected `x` (the last assembly's matrix there), oriented
    /// along `previous` (or toward increasing a by `sign` at the start).
    fn tangent(&mut self, x: &State, previous: Option<&Tangent>, sign: f64) -> Option<Tangent> {
        let (n, m) = (self.n, self.m);
        let d = n + m + 1;
        // the last row: the previous tangent's (its inner product with the new one = 1)
        let unit = Tangent {
            q: vec![0.0; n],
            mu: Vector6::zeros(),
            a: sign * self.sigma * self.sigma,
        };
        let previous = previous.unwrap_or(&unit);
        self.assemble(x, &LastRow::Arclength(x, previous, 0.0));
        let modes = self.zero_modes();
        let mut rhs = vec![0.0; d];
        rhs[d - 1] = 1.0;
        if !self.solve(&mut rhs) {
            return None;
        }
        // a symmetry's zero mode is no direction of the branch: the tangent is kept
        // orthogonal to it, so the arclength row never pushes the corrector along it
        if !modes.is_empty() {
            let mut y: Vec<f64> = (0..d).map(|i| rhs[i] / self.unit(i)).collect();
            for v in &modes {
                let c: f64 = v.iter().zip(&y).map(|(v, y)| v * y).sum();
                for (yi, vi) in y.iter_mut().zip(v) {
                    *yi -= c * vi;
                }
            }
            for i in 0..d {
                rhs[i] = y[i] * self.unit(i);
            }
        }
        let norm = self.norm(&rhs[..n], rhs[d - 1]);
        let mut mu = Vector6::zeros();
        for r in 0..m {
            mu[r] = rhs[n + r] / norm;
        }
        Some(Tangent {
            q: rhs[..n].iter().map(|v| v / norm).collect(),
            mu,
            a: rhs[d - 1] / norm,
        })
    }

    fn cosine(&self, a: &Tangent, b: &Tangent) -> f64 {
        let s: f64 = (0..self.n)
            .map(|i| self.w[i] * self.w[i] * a.q[i] * b.q[i])
            .sum();
        s + a.a * b.a / (self.sigma * self.sigma)
    }

    fn predict(&self, x: &State, t: &Tangent, h: f64) -> State {
        State {
            q: x.q.iter().zip(&t.q).map(|(q, d)| q + h * d).collect(),
            mu: x.mu + t.mu * h,
            a: x.a + h * t.a,
        }
    }

    /// The corrected point at arclength h from `x` along `t`, and its tangent.
    fn step(&mut self, x: &State, t: &Tangent, h: f64) -> Option<(State, Tangent, usize)> {
        let mut y = self.predict(x, t, h);
        let iterations = self.correct(&mut y, &LastRow::Arclength(x, t, h))?;
        let ty = self.tangent(&y, Some(t), 1.0)?;
        Some((y, ty, iterations))
    }

    /// The unstable directions at the corrected `x`: negative eigenvalues of the
    /// bordered Hessian `[−K Gᵀ; G 0]` (scaled, symmetrised) less the rows of G.
    fn unstable(&mut self, x: &State) -> usize {
        let (n, m) = (self.n, self.m);
        self.assemble(x, &LastRow::Fixed(x.a));
        let mut h = Mat::<f64>::zeros(n + m, n + m);
        for j in 0..n {
            for i in 0..n {
                let k = 0.5 * (self.matrix[(i, j)] + self.matrix[(j, i)]);
                h[(i, j)] = -k * self.scale[i] * self.scale[j];
            }
        }
        for r in 0..m {
            let norm = (0..n)
                .map(|j| (self.matrix[(n + r, j)] * self.scale[j]).powi(2))
                .sum::<f64>()
                .sqrt()
                .max(1e-300);
            for j in 0..n {
                let g = self.matrix[(n + r, j)] * self.scale[j] / norm;
                h[(n + r, j)] = g;
                h[(j, n + r)] = g;
            }
        }
        // the stiffness's scale: the constraint rows' 1 against it
        let big = (0..n)
            .map(|i| h[(i, i)].abs())
            .fold(0.0, f64::max)
            .max(1e-300);
        for r in 0..m {
            for j in 0..n {
                h[(n + r, j)] *= big;
                h[(j, n + r)] *= big;
            }
        }
        let Ok(values) = h.self_adjoint_eigenvalues(Side::Lower) else {
            return 0;
        };
        let top = values.iter().fold(0.0f64, |t, v| t.max(v.abs()));
        let negative = values.iter().filter(|&&v| v < -1e-9 * top).count();
        negative.saturating_sub(m)
    }

    fn point(&mut self, x: &State, unstable: usize) -> BranchPoint {
        self.set_parameter(x.a);
        let length = self.system.strand.geometry.length();
        let mut jac = vec![Vector3::zeros(); self.n];
        let tip = KernelPoints(self.system.kernel.as_mut()).point(&x.q, length, &mut jac);
        let reaction = match self.system.held.as_mut() {
            Some(h) => {
                h.set_multipliers(&x.mu, 0.0);
                h.reaction
            }
            None => Vector6::zeros(),
        };
        let energy = self.system.energy(&x.q, &self.zero);
        BranchPoint {
            parameter: x.a,
            q: x.q.clone(),
            tip,
            reaction,
            unstable,
            energy,
        }
    }

    /// The fold between `x` (tangent `t`, t_a of one sign) and the point at arclength
    /// `h` along t (t_a of the other): regula falsi (Illinois) on t_a of the point
    /// corrected at arclength s.
    fn fold(&mut self, x: &State, t: &Tangent, h: f64, t_end: f64) -> Option<State> {
        let (mut s0, mut f0) = (0.0, t.a);
        let (mut s1, mut f1) = (h, t_end);
        let mut best: Option<(State, f64)> = None;
        let mut side = 0;
        for _ in 0..60 {
            let s = (s0 * f1 - s1 * f0) / (f1 - f0);
            let (y, ty, _) = self.step(x, t, s)?;
            let f = ty.a;
            if best.as_ref().is_none_or(|(_, b)| f.abs() < b.abs()) {
                best = Some((y, f));
            }
            if f.abs() <= 1e-12 || (s1 - s0).abs() <= 1e-13 * h {
                break;
            }
            if (f > 0.0) == (f0 > 0.0) {
                (s0, f0) = (s, f);
                if side == -1 {
                    f1 *= 0.5;
                }
                side = -1;
            } else {
                (s1, f1) = (s, f);
                if side == 1 {
                    f0 *= 0.5;
                }
                side = 1;
            }
        }
        best.map(|(y, _)| y)
    }
}

/// Follow the static equilibria of `system`'s strand from `q` (a guess of the first
/// point's) as the parameter of `settings` goes from `start` toward `stop`: see the
/// module's documentation. The system's point loads and holder are left as they were.
pub fn follow_branch(
    system: &mut StrandSystem,
    q: &[f64],
    settings: &ContinuationSettings,
) -> Result<Branch, String> {
    if system.contacts.is_some() {
        return Err("continuation: the strand has contacts, whose forces are not smooth".into());
    }
    if let BranchParameter::Holder { .. } = settings.parameter {
        if system.held.is_none() {
            return Err(
                "continuation: the parameter is the holder, but the tip is not held".into(),
            );
        }
    }
    let base_loads = system.strand.point_loads.clone();
    let holder = system
        .held
        .as_ref()
        .map_or(Vector3::zeros(), |h| h.end.position);
    let held_state = system.held.as_ref().map(|h| h.state());
    let explicit = std::mem::replace(&mut system.context.explicit_field_stiffness, false);
    let result = follow(system, q, settings, base_loads.clone(), holder);
    system.context.explicit_field_stiffness = explicit;
    system.strand.point_loads = base_loads;
    if let Some(h) = system.held.as_mut() {
        h.end.position = holder;
        if let Some(state) = held_state {
            h.restore(state);
        }
    }
    result
}

fn follow(
    system: &mut StrandSystem,
    q: &[f64],
    settings: &ContinuationSettings,
    base_loads: Vec<crate::model::strand::PointLoad>,
    holder: Vector3<f64>,
) -> Result<Branch, String> {
    let n = q.len();
    let m = system.held.as_ref().map_or(0, |h| h.rows());
    let length = system.strand.geometry.length();
    let scale: Vec<f64> = match system.workspace.solver.scale() {
        Some(s) => s.to_vec(),
        None => vec![1.0; n],
    };
    // the norm's weights: each chain coordinate times its element's length (radians of
    // bend; a pinned root's joint: the root frame's rotation), a free root's
    // translation over L
    let chain = system.strand.geometry.chain_dofs();
    let lengths = &system.strand.geometry.lengths;
    let w: Vec<f64> = (0..n)
        .map(|i| {
            if i < chain {
                lengths[i / 3]
            } else {
                1.0 / length
            }
        })
        .collect();
    let sigma = match settings.parameter {
        BranchParameter::LoadScale => 1.0,
        BranchParameter::Holder { .. } => length,
    };
    let mut tracer = Tracer {
        w,
        scale,
        system,
        parameter: settings.parameter,
        base_loads,
        holder,
        sigma,
        n,
        m,
        force_scale: 0.0,
        matrix: Mat::zeros(n + m + 1, n + m + 1),
        residual: vec![0.0; n + m + 1],
        zero: vec![0.0; n],
    };
    // the first point: the static solve at `start`, then the multipliers by the
    // bordered Newton at that a
    tracer.set_parameter(settings.start);
    let mut q0 = q.to_vec();
    tracer.system.workspace.forget_history();
    let report = solve_static(tracer.system, &mut q0)?;
    if !report.converged {
        return Err(format!(
            "continuation: the static solve at the start did not converge (residual {:e} of {:e})",
            report.residual, report.force_scale
        ));
    }
    let mut x = State {
        q: q0,
        mu: Vector6::zeros(),
        a: settings.start,
    };
    // the force scale: the static solve's, and the loads' at the largest |a|
    tracer.force_scale = report.force_scale;
    tracer.assemble(&x, &LastRow::Fixed(x.a));
    let d = n + m + 1;
    let reach = settings.start.abs().max(settings.stop.abs()).max(1.0);
    let loads = (0..n)
        .map(|i| (tracer.matrix[(i, d - 1)] * tracer.scale[i]).abs())
        .fold(0.0, f64::max);
    tracer.force_scale = tracer.force_scale.max(loads * reach).max(1e-300);
    tracer
        .correct(&mut x, &LastRow::Fixed(settings.start))
        .ok_or("continuation: the start's equilibrium was lost by the bordered Newton")?;
    let sign = if settings.stop >= settings.start {
        1.0
    } else {
        -1.0
    };
    let mut t = tracer
        .tangent(&x, None, sign)
        .ok_or("continuation: singular system at the start (a branch point)")?;
    let mut ux = tracer.unstable(&x);
    let mut points = vec![tracer.point(&x, ux)];
    let mut folds = Vec::new();
    let mut branch_points = Vec::new();
    let mut h = settings.step;
    let smallest = settings.step * 1e-6;
    let end = loop {
        if points.len() >= settings.max_points {
            break BranchEnd::MaxPoints;
        }
        let Some((y, ty, iterations)) = tracer.step(&x, &t, h) else {
            h *= 0.5;
            if h < smallest {
                break BranchEnd::Stalled { parameter: x.a };
            }
            continue;
        };
        if tracer.cosine(&t, &ty) < TURN_COSINE {
            h *= 0.5;
            if h < smallest {
                break BranchEnd::Stalled { parameter: x.a };
            }
            continue;
        }
        // the stability changed without a fold: a branch point crossed, or a corner of
        // the branch cut (the corrector landing on a neighbouring branch); smaller
        // steps resolve a corner, and what still changes is a branch point
        let uy = tracer.unstable(&y);
        let fold = t.a * ty.a < 0.0;
        if uy != ux && !fold {
            if h > settings.step * BRANCH_POINT_STEP {
                h *= 0.5;
                continue;
            }
            branch_points.push(points.len() - 1);
        }
        if fold {
            if let Some(f) = tracer.fold(&x, &t, h, ty.a) {
                let u = tracer.unstable(&f);
                folds.push(Fold {
                    after: points.len() - 1,
                    point: tracer.point(&f, u),
                });
            }
        }
        // past stop: the point at stop itself ends the branch
        if (y.a - settings.stop) * (x.a - settings.stop) <= 0.0 && y.a != x.a {
            let c = (settings.stop - x.a) / (y.a - x.a);
            let mut z = State {
                q: x.q.iter().zip(&y.q).map(|(a, b)| a + c * (b - a)).collect(),
                mu: x.mu + (y.mu - x.mu) * c,
                a: settings.stop,
            };
            if tracer
                .correct(&mut z, &LastRow::Fixed(settings.stop))
                .is_some()
            {
                let uz = tracer.unstable(&z);
                points.push(tracer.point(&z, uz));
                break BranchEnd::Reached;
            }
        }
        points.push(tracer.point(&y, uy));
        (x, t, ux) = (y, ty, uy);
        if iterations <= 3 {
            h = (h * 1.5).min(settings.max_step);
        }
    };
    Ok(Branch {
        points,
        folds,
        branch_points,
        end,
        start: report,
    })
}
