//! Fitting a Super-Helix to a curve: the twist and curvatures q (3N) of N equal helical
//! elements (paper section 3.1, eq. 3) whose closed-form centreline (section 3.2,
//! appendix A, eq. 7) passes closest to the curve's points, by Levenberg–Marquardt on
//! the sum of squared distances `Σ_i |y(s_i; q) − p_i|²`.
//!
//! **Unknowns.** Besides q, a polyline does not give the rest of what the sum needs,
//! so they are unknowns too:
//!
//! - the strand's length L: a polyline's length falls short of the curve's by about
//!   (hκ)²/24 of it for segments of length h on a curvature κ (0.6 % for a curl of radius
//!   6 mm sampled every 2.5 mm), and the strand is inextensible;
//! - the arc length s_i = σ_i L of each point but the root (σ = 0) and the tip (σ = 1),
//!   starting from the polyline's own; with them free the sum is over the distances of
//!   the points to the strand (orthogonal distance regression, as in curve fitting by
//!   foot points);
//! - the tilt of the root tangent n0 (two angles about n1 and n2): it starts along the
//!   first segment, which is off the true tangent by about half the segment's turning
//!   angle. A rotation about n0 itself changes nothing a rotation of every element's
//!   (κ1, κ2) does not: it is left out.
//!
//! **Scaling.** The centreline of a strand of length L with curvatures q is L times
//! that of a strand of unit length with curvatures c = L q (arc lengths scale with L,
//! curvatures with 1/L), so the fit works on the unit strand: y_i = R L Y(σ_i; c) in
//! the root frame, R the tilt, J = ∂Y/∂c from the kernel's `point` (`StrandKernel::point`:
//! the exact derivative of the reconstruction), ∂y/∂L = R Y, ∂y/∂σ_i = R L Y′(σ_i) (the
//! tangent). Each σ_i enters one residual only, so it is eliminated from the normal
//! equations by its Schur complement (as in bundle adjustment) and the linear system
//! stays of size 3N + 3.
//!
//! **Start.** The strand is grown from the root: for k = 1 … N the first k elements (the
//! ones after them on the same helix as the k-th, the k-th starting as the (k−1)-th) are
//! fitted to the points along them, σ and L held at the polyline's. The whole is then
//! fitted with L free, then with the σ free too.
//!
//! **Error.** The fit error of a curve is the RMS and the largest of the distances
//! `|y(s_i) − p_i|` over its points (the root's is zero by construction and not
//! counted), divided by the fitted length L.

use super::curves::Curve;
use crate::kernels::closed_form::moment_kernel;
use crate::kernels::kernel::StrandKernel;
use crate::model::reconstruction::pose_at;
use crate::model::strand::StrandGeometry;
use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Vector3};

/// Most Levenberg–Marquardt iterations of the joint fit.
pub const DEFAULT_MAX_ITERATIONS: usize = 200;
/// Most iterations of each element's fit in the sweep.
const SWEEP_ITERATIONS: usize = 60;
/// A relative fall of the cost below this is slow progress.
const SLOW: f64 = 1e-7;
/// Fewest points an element's fit in the sweep takes.
const SWEEP_POINTS: usize = 3;

/// How a curve is fitted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitSettings {
    /// N: elements of the strand, of equal length.
    pub elements: usize,
    /// Most iterations of the joint fit.
    pub max_iterations: usize,
}

impl FitSettings {
    /// N elements and the default iteration cap.
    pub fn new(elements: usize) -> Self {
        FitSettings {
            elements,
            max_iterations: DEFAULT_MAX_ITERATIONS,
        }
    }
}

/// How far a fitted strand is from its curve, relative to the strand's length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitError {
    /// Root mean square of the points' distances to the strand, divided by L.
    pub rms: f64,
    /// Largest distance of a point to the strand, divided by L.
    pub max: f64,
    /// Index of that point among the curve's distinct points (the root is 0).
    pub worst_point: usize,
}

/// A strand fitted to a curve.
#[derive(Debug, Clone, PartialEq)]
pub struct FittedCurve {
    /// Root: the curve's first point, m.
    pub root: Vector3<f64>,
    /// Root frame (n0, n1, n2) as columns.
    pub frame: Matrix3<f64>,
    /// Fitted length L, m.
    pub length: f64,
    /// Length of the curve's polyline, m.
    pub polyline_length: f64,
    /// Element lengths (N equal ones), m.
    pub lengths: Vec<f64>,
    /// Twist and curvatures (3N), rad/m.
    pub q: Vec<f64>,
    /// The fit's error.
    pub error: FitError,
    /// Iterations of the joint fit.
    pub iterations: usize,
}

/// Largest relative difference between a fitted strand's length and the length of its
/// curve's polyline for the fit to stand for the curve. The chords of a smooth curve
/// sampled at three or more points per radian of turning fall short of its arc by under
/// 2 %; a strand much longer than its polyline runs past it (a zig-zag "fitted" by a rod
/// 4.6 times as long came within 3.4e-4 of its points), one much shorter cuts it (a
/// curve that doubles back).
pub const MAX_LENGTH_MISMATCH: f64 = 0.1;

/// Largest distance of a curve's point from its fitted strand, relative to the fitted
/// length, with which a fit is accepted when the scene sets no `max_fit_error`: 1 % (the
/// fits of `runtime/tests/groom_fit.rs` stay under 9.4e-3, the widening helix with two
/// elements; a zig-zag of 3 cm teeth on a 42 cm polyline fitted by 3 elements misses by
/// 4.2 %).
pub const DEFAULT_MAX_FIT_ERROR: f64 = 0.01;

impl FittedCurve {
    /// Why this fit does not stand for its curve, beyond `max_error` (its largest
    /// distance relative to the length) or [`MAX_LENGTH_MISMATCH`]: `None` when it does.
    pub fn refusal(&self, max_error: f64) -> Option<String> {
        let mismatch = (self.length - self.polyline_length).abs() / self.polyline_length;
        // (a NaN is refused too)
        if mismatch.is_nan() || mismatch > MAX_LENGTH_MISMATCH {
            return Some(format!(
                "the fitted strand is {:.4} m long, the curve's polyline {:.4} m ({:.0} % apart, at most {:.0} % allowed): the curve zig-zags or doubles back faster than the strand's elements can follow; smooth it or raise elements",
                self.length,
                self.polyline_length,
                100.0 * mismatch,
                100.0 * MAX_LENGTH_MISMATCH
            ));
        }
        if self.error.max.is_nan() || self.error.max > max_error {
            return Some(format!(
                "the fitted strand is {:.3e} of its length from the curve at its point {}, more than {max_error:e} (max_fit_error): raise elements, or max_fit_error if that is close enough",
                self.error.max, self.error.worst_point
            ));
        }
        None
    }
}

/// The unit strand the fit works on: N equal elements of total length 1, root at the
/// origin, root frame the identity.
struct UnitStrand {
    geometry: StrandGeometry,
    kernel: Box<dyn StrandKernel>,
    jac: Vec<Vector3<f64>>,
}

impl UnitStrand {
    fn new(elements: usize) -> Self {
        let geometry = StrandGeometry {
            root_position: Vector3::zeros(),
            root_frame: Matrix3::identity(),
            lengths: vec![1.0 / elements as f64; elements],
            mass_per_length: 1.0,
            rotary_inertia: [0.0; 3],
            floating: false,
        };
        let kernel = moment_kernel(&geometry);
        UnitStrand {
            jac: vec![Vector3::zeros(); 3 * elements],
            geometry,
            kernel,
        }
    }

    fn elements(&self) -> usize {
        self.geometry.lengths.len()
    }

    /// Y(σ; c), and ∂Y/∂c into `self.jac`.
    fn point(&mut self, c: &[f64], sigma: f64) -> Vector3<f64> {
        self.kernel.point(c, sigma, &mut self.jac, None)
    }

    /// The unit tangent Y′(σ; c).
    fn tangent(&self, c: &[f64], sigma: f64) -> Vector3<f64> {
        pose_at(&self.geometry, c, sigma)
            .frame
            .column(0)
            .into_owned()
    }
}

/// The unknowns of the fit.
#[derive(Debug, Clone)]
struct State {
    /// Dimensionless curvatures c = L q.
    c: Vec<f64>,
    /// Tilt of the root frame, in the initial root frame.
    rotation: Matrix3<f64>,
    /// Length L.
    length: f64,
    /// σ of the points 1..M (the last, the tip, stays 1).
    sigma: Vec<f64>,
}

/// What one Levenberg–Marquardt run moves: the first `fitted` elements (the ones after
/// them follow the last of these on the same helix) and the tilt, and the length and
/// the arc lengths of the points when asked.
#[derive(Debug, Clone, Copy)]
struct Stage {
    fitted: usize,
    length: bool,
    sigma: bool,
}

impl Stage {
    /// Number of unknowns besides the σ.
    fn unknowns(&self) -> usize {
        3 * self.fitted + 2 + usize::from(self.length)
    }
}

/// The fitting problem of one curve: the targets in the initial root frame.
struct Problem {
    unit: UnitStrand,
    targets: Vec<Vector3<f64>>,
}

/// The normal equations of one linearisation.
struct Normal {
    a: DMatrix<f64>,
    g: DVector<f64>,
    /// Per point: (index, Jᵀb, b·b, b·r) of its σ (free points only).
    sigma: Vec<(usize, DVector<f64>, f64, f64)>,
    cost: f64,
}

impl Problem {
    /// Σ |r_i|² over `points` at `state`.
    fn cost(&mut self, state: &State, points: &[usize]) -> f64 {
        points
            .iter()
            .map(|&i| {
                let y = state.rotation * self.unit.point(&state.c, state.sigma[i]) * state.length;
                (y - self.targets[i]).norm_squared()
            })
            .sum()
    }

    fn normal(&mut self, state: &State, stage: Stage, points: &[usize]) -> Normal {
        let n = self.unit.elements();
        let p = stage.unknowns();
        let mut a = DMatrix::zeros(p, p);
        let mut g = DVector::zeros(p);
        let mut sigma = Vec::new();
        let mut cost = 0.0;
        let last = self.targets.len() - 1;
        let mut rows = DMatrix::zeros(3, p);
        for &i in points {
            let unit_y = self.unit.point(&state.c, state.sigma[i]);
            let y = state.rotation * unit_y * state.length;
            let r = y - self.targets[i];
            cost += r.norm_squared();
            rows.fill(0.0);
            let scale = state.rotation * state.length;
            let mut put = |col: usize, v: Vector3<f64>| {
                for k in 0..3 {
                    rows[(k, col)] += v[k];
                }
            };
            let f = stage.fitted;
            for e in 0..n {
                for k in 0..3 {
                    put(3 * e.min(f - 1) + k, scale * self.unit.jac[3 * e + k]);
                }
            }
            let ly = unit_y * state.length;
            put(3 * f, state.rotation * Vector3::y().cross(&ly));
            put(3 * f + 1, state.rotation * Vector3::z().cross(&ly));
            if stage.length {
                put(3 * f + 2, state.rotation * unit_y);
            }
            // A += RᵀR, g += Rᵀr in place (no temporaries per point)
            a.gemm_tr(1.0, &rows, &rows, 1.0);
            g.gemv_tr(1.0, &rows, &DVector::from_column_slice(r.as_slice()), 1.0);
            if stage.sigma && i != last {
                let b = scale * self.unit.tangent(&state.c, state.sigma[i]);
                let jb = rows.tr_mul(&DVector::from_column_slice(b.as_slice()));
                sigma.push((i, jb, b.norm_squared(), b.dot(&r)));
            }
        }
        Normal { a, g, sigma, cost }
    }

    /// The state moved by the step `dx` (and `dsigma` of the free points).
    fn apply(
        &self,
        state: &State,
        stage: Stage,
        dx: &DVector<f64>,
        dsigma: &[(usize, f64)],
    ) -> State {
        let n = self.unit.elements();
        let mut next = state.clone();
        let tilt = |a: f64, b: f64| Rotation3::new(Vector3::new(0.0, a, b)).into_inner();
        let f = stage.fitted;
        for e in 0..n {
            for k in 0..3 {
                next.c[3 * e + k] = state.c[3 * e.min(f - 1) + k] + dx[3 * e.min(f - 1) + k];
            }
        }
        next.rotation = state.rotation * tilt(dx[3 * f], dx[3 * f + 1]);
        if stage.length {
            next.length += dx[3 * f + 2];
        }
        for &(i, d) in dsigma {
            next.sigma[i] = (state.sigma[i] + d).clamp(0.0, 1.0);
        }
        next
    }

    /// Levenberg–Marquardt over `points` from `state`; the number of iterations taken.
    fn solve(
        &mut self,
        state: &mut State,
        stage: Stage,
        points: &[usize],
        max_iterations: usize,
    ) -> usize {
        let mut lambda = 1e-3;
        let mut iterations = 0;
        let mut slow = 0;
        while iterations < max_iterations {
            iterations += 1;
            let normal = self.normal(state, stage, points);
            if normal.cost == 0.0 {
                break;
            }
            let mut accepted = None;
            while lambda <= 1e12 {
                if let Some((dx, dsigma)) = damped_step(&normal, lambda) {
                    let trial = self.apply(state, stage, &dx, &dsigma);
                    let cost = self.cost(&trial, points);
                    if trial.length > 0.0 && cost.is_finite() && cost < normal.cost {
                        accepted = Some((trial, cost));
                        lambda = (lambda / 3.0).max(1e-12);
                        break;
                    }
                }
                lambda *= 4.0;
            }
            let Some((trial, cost)) = accepted else { break };
            *state = trial;
            // converged when the cost falls by less than 10⁻⁷ of itself three times in
            // a row (a residual at round-off ends it earlier: no step lowers it)
            if normal.cost - cost <= SLOW * normal.cost {
                slow += 1;
                if slow == 3 {
                    break;
                }
            } else {
                slow = 0;
            }
        }
        iterations
    }
}

/// The damped step: `(A + λ D) dx = −g` with the σ eliminated, D the diagonal of A
/// (plus 10⁻⁹ of its largest entry, so that directions the points do not see are held).
type Step = (DVector<f64>, Vec<(usize, f64)>);

fn damped_step(normal: &Normal, lambda: f64) -> Option<Step> {
    let p = normal.g.len();
    let floor = 1e-9
        * (0..p)
            .map(|k| normal.a[(k, k)])
            .fold(0.0, f64::max)
            .max(1e-300);
    let mut s = normal.a.clone();
    for k in 0..p {
        s[(k, k)] += lambda * (normal.a[(k, k)] + floor);
    }
    let mut rhs = -normal.g.clone();
    let mut pivots = Vec::with_capacity(normal.sigma.len());
    for (_, jb, bb, br) in &normal.sigma {
        let d = bb * (1.0 + lambda) + floor;
        // s −= jb jbᵀ / d, rhs += jb br / d, in place
        s.ger(-1.0 / d, jb, jb, 1.0);
        rhs.axpy(*br / d, jb, 1.0);
        pivots.push(d);
    }
    let dx = s.cholesky()?.solve(&rhs);
    if !dx.iter().all(|x| x.is_finite()) {
        return None;
    }
    let dsigma = normal
        .sigma
        .iter()
        .zip(&pivots)
        .map(|((i, jb, _, br), d)| (*i, -(br + jb.dot(&dx)) / d))
        .collect();
    Some((dx, dsigma))
}

/// The discrete shape of a polyline at an interior vertex: the curvature of the circle
/// through it and its neighbours, the Frenet normal and binormal, the torsion (the mean
/// of the turning rates of the binormal along the two segments), in the coordinates of
/// the points.
#[derive(Debug, Clone, Copy)]
struct VertexShape {
    sigma: f64,
    curvature: f64,
    normal: Vector3<f64>,
    binormal: Vector3<f64>,
    torsion: f64,
}

/// The [`VertexShape`] of every interior vertex of `points` (σ: of points 1.., as in
/// [`State`]); vertices where the polyline does not turn are left out.
fn vertex_shapes(points: &[Vector3<f64>], sigma: &[f64]) -> Vec<VertexShape> {
    let mut out: Vec<(usize, VertexShape)> = Vec::new();
    for i in 1..points.len().saturating_sub(1) {
        let (a, b) = (points[i] - points[i - 1], points[i + 1] - points[i]);
        let cross = a.cross(&b);
        let denominator = a.norm() * b.norm() * (a + b).norm();
        if cross.norm() <= 1e-12 * denominator.cbrt().powi(2) || denominator == 0.0 {
            continue;
        }
        let binormal = cross.normalize();
        let tangent = (a.normalize() + b.normalize()).normalize();
        out.push((
            i,
            VertexShape {
                sigma: sigma[i - 1],
                curvature: 2.0 * cross.norm() / denominator,
                normal: binormal.cross(&tangent),
                binormal,
                torsion: 0.0,
            },
        ));
    }
    // torsion of the segment between two turning vertices next to each other
    let mut rates = vec![(0.0, 0usize); out.len()];
    for k in 1..out.len() {
        let ((i, a), (j, b)) = (out[k - 1], out[k]);
        if j != i + 1 {
            continue;
        }
        let segment = points[j] - points[i];
        let angle = a
            .binormal
            .cross(&b.binormal)
            .dot(&segment.normalize())
            .atan2(a.binormal.dot(&b.binormal));
        let rate = angle / segment.norm();
        for idx in [k - 1, k] {
            rates[idx].0 += rate;
            rates[idx].1 += 1;
        }
    }
    out.into_iter()
        .zip(rates)
        .map(|((_, mut v), (sum, count))| {
            if count > 0 {
                v.torsion = sum / count as f64;
            }
            v
        })
        .collect()
}

/// The dimensionless Darboux vector c = L (τ, κ sin θ, κ cos θ) of `element` from the
/// polyline's curvature κ (mean over the element's vertices) and torsion τ (weighted by
/// κ²), θ the angle of the strand's current n1 at the element's start from the Frenet
/// normal there (the Frenet frame turns with (τ, 0, κ), the material frame is it turned
/// by θ about the tangent). `None` where the element has no turning vertex.
fn element_estimate(
    unit: &UnitStrand,
    state: &State,
    shapes: &[VertexShape],
    element: usize,
    elements: usize,
) -> Option<[f64; 3]> {
    let (a, b) = (
        element as f64 / elements as f64,
        (element + 1) as f64 / elements as f64,
    );
    let inside: Vec<&VertexShape> = shapes
        .iter()
        .filter(|v| v.sigma >= a && v.sigma <= b)
        .collect();
    if inside.is_empty() {
        return None;
    }
    let curvature = inside.iter().map(|v| v.curvature).sum::<f64>() / inside.len() as f64;
    let weight: f64 = inside.iter().map(|v| v.curvature.powi(2)).sum();
    let torsion = inside
        .iter()
        .map(|v| v.curvature.powi(2) * v.torsion)
        .sum::<f64>()
        / weight;
    let first = inside
        .iter()
        .min_by(|x, y| (x.sigma - a).abs().total_cmp(&(y.sigma - a).abs()))?;
    let n1 = state.rotation * pose_at(&unit.geometry, &state.c, a).frame.column(1);
    let theta = n1.dot(&first.binormal).atan2(n1.dot(&first.normal));
    let d = [torsion, curvature * theta.sin(), curvature * theta.cos()];
    let c = d.map(|x| x * state.length);
    c.iter().all(|x| x.is_finite()).then_some(c)
}

/// A unit vector perpendicular to the unit vector `v`, from `hint` when it is not
/// parallel to `v`, else from the world axis least aligned with `v`.
fn perpendicular(v: &Vector3<f64>, hint: Option<&Vector3<f64>>) -> Vector3<f64> {
    if let Some(h) = hint {
        let u = h - v * v.dot(h);
        if u.norm() > 1e-6 * h.norm() {
            return u.normalize();
        }
    }
    let e = Vector3::ith(v.iamin(), 1.0);
    (e - v * v.dot(&e)).normalize()
}

/// Fit a strand of `settings.elements` equal elements to `curve` (module doc). `normal`
/// sets the root's n1 (projected across the root tangent); without it n1 is the world
/// axis least aligned with the tangent, projected. The error says why a curve cannot be
/// fitted (fewer than two distinct points, a point that is not finite).
pub fn fit_curve(
    curve: &Curve,
    settings: &FitSettings,
    normal: Option<&Vector3<f64>>,
) -> Result<FittedCurve, String> {
    if let Some(k) = curve
        .points
        .iter()
        .position(|p| !p.iter().all(|x| x.is_finite()))
    {
        return Err(format!("point {k} is not finite"));
    }
    let points = curve.distinct_points();
    if points.len() < 2 {
        return Err("a curve needs at least two distinct points".into());
    }
    let elements = settings.elements.max(1);
    let root = points[0];
    let n0 = (points[1] - root).normalize();
    let n1 = perpendicular(&n0, normal);
    let frame0 = Matrix3::from_columns(&[n0, n1, n0.cross(&n1)]);
    let polyline_length: f64 = points.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
    // targets: points 1..M in the initial root frame
    let targets: Vec<Vector3<f64>> = points[1..]
        .iter()
        .map(|p| frame0.transpose() * (p - root))
        .collect();
    let mut run = 0.0;
    let sigma: Vec<f64> = points
        .windows(2)
        .map(|w| {
            run += (w[1] - w[0]).norm();
            run / polyline_length
        })
        .collect();
    let m = targets.len();
    let mut state = State {
        c: vec![0.0; 3 * elements],
        rotation: Matrix3::identity(),
        length: polyline_length,
        sigma,
    };
    if let Some(last) = state.sigma.last_mut() {
        *last = 1.0;
    }
    let mut problem = Problem {
        unit: UnitStrand::new(elements),
        targets,
    };
    // the start: the strand grown element by element from the root, each prefix
    // fitted to the points along it (at least three)
    let local: Vec<Vector3<f64>> = std::iter::once(Vector3::zeros())
        .chain(problem.targets.iter().copied())
        .collect();
    let shapes = vertex_shapes(&local, &state.sigma);
    for fitted in 1..=elements {
        let element = fitted - 1;
        let end = fitted as f64 / elements as f64;
        let last = state
            .sigma
            .partition_point(|&s| s <= end + 1e-12)
            .max(SWEEP_POINTS)
            .min(m);
        let chosen: Vec<usize> = (0..last).collect();
        // the new element: as the one before it, or the polyline's own curvature and
        // torsion there, whichever starts closer
        if let Some(d) = element_estimate(&problem.unit, &state, &shapes, element, elements) {
            let copied = problem.cost(&state, &chosen);
            let mut trial = state.clone();
            for e in element..elements {
                trial.c[3 * e..3 * e + 3].copy_from_slice(&d);
            }
            if problem.cost(&trial, &chosen) < copied {
                state = trial;
            }
        }
        let stage = Stage {
            fitted,
            length: false,
            sigma: false,
        };
        problem.solve(&mut state, stage, &chosen, SWEEP_ITERATIONS);
    }
    let all: Vec<usize> = (0..m).collect();
    let mut stage = Stage {
        fitted: elements,
        length: true,
        sigma: false,
    };
    let mut iterations = problem.solve(&mut state, stage, &all, settings.max_iterations);
    stage.sigma = true;
    iterations += problem.solve(&mut state, stage, &all, settings.max_iterations);
    // the error: distances at the fitted arc lengths
    let mut sum = 0.0;
    let mut max = 0.0;
    let mut worst_point = 0;
    for i in 0..m {
        let y = state.rotation * problem.unit.point(&state.c, state.sigma[i]) * state.length;
        let d = (y - problem.targets[i]).norm();
        sum += d * d;
        if d > max {
            max = d;
            worst_point = i + 1;
        }
    }
    let length = state.length;
    let q: Vec<f64> = state.c.iter().map(|c| c / length).collect();
    let error = FitError {
        rms: (sum / m as f64).sqrt() / length,
        max: max / length,
        worst_point,
    };
    let finite = length.is_finite() && length > 0.0 && q.iter().all(|x| x.is_finite());
    if !finite || !error.rms.is_finite() {
        return Err("the fit did not converge to a finite strand".into());
    }
    Ok(FittedCurve {
        root,
        frame: frame0 * state.rotation,
        length,
        polyline_length,
        lengths: vec![length / elements as f64; elements],
        q,
        error,
        iterations,
    })
}
