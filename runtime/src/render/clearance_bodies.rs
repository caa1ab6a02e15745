//! The bodies of [`super::clearance`] placed at one frame, and how each pushes a render
//! point out to the clearance.
//!
//! Spheres, ellipsoids, capsules and planes are answered in closed form, in f32 (the
//! precision of the render points), by straight-line code without branches so that the
//! eight strands of a group are answered together in SIMD registers. Cylinders and meshes
//! are asked through their exact query ([`Shape::query`]), one point at a time, in f64.
//!
//! - **Ellipsoid** (and a sphere, an ellipsoid of equal half-axes), centre o, rotation R,
//!   half-axes aᵢ: with v = D⁻¹Rᵀ(x − o) (D = diag aᵢ) and ρ = |v|, the distance to the
//!   surface is at least (ρ − 1) min aᵢ outside and at most (ρ − 1) max aᵢ (both exact on
//!   a sphere). A point is within the clearance c when ρ < ρ_c = 1 + c / min aᵢ, the level
//!   that is c from the surface along the shortest axis and at least c everywhere. It is
//!   moved along the gradient of ρ at the point (the outward normal of the level surface
//!   through it) onto the level ρ_c: in the scaled coordinates the motion s·n (n the unit
//!   gradient, world) moves v along w = D⁻¹Rᵀn, and |v + s w|² = ρ_c² is a quadratic in s
//!   with one positive root, taken in the form without cancellation,
//!   s = (ρ_c² − ρ²) / (v·w + √((v·w)² + |w|²(ρ_c² − ρ²))). On a sphere this is the
//!   exact push along the normal to the clearance; on an ellipsoid the point ends between
//!   c and c · max aᵢ / min aᵢ from the surface (exactly c where the shortest axis meets
//!   it), with no iteration.
//! - **Capsule**: the closest point of the segment, then out along the line from it to
//!   the radius plus the clearance (exact).
//! - **Plane**: out along its normal to the clearance (exact).
//!
//! Every closed-form push aims a little beyond the clearance, by [`MARGIN`] of the scale of
//! the body's coordinates, so that f32 rounding never leaves a pushed point nearer than the
//! clearance.

use super::lanes::Lanes;
use crate::bodies::{Body, Shape};
use nalgebra::{Matrix3, Vector3};
use superhelix_kernels::head::HeadState;

/// How far beyond the clearance a closed-form push aims, in units of f32's epsilon times
/// the scale of the body's coordinates (the distance of its centre from the world origin
/// plus its size): about 2·10⁻⁷ m for a head of 10 cm at the origin.
pub const MARGIN: f32 = 16.0;

/// An ellipsoid (or sphere) at one frame, f32.
#[derive(Debug, Clone, Copy)]
pub(super) struct Ellipsoid<L> {
    origin: P<L>,
    /// Rows of D⁻¹Rᵀ: world offsets to scaled axes coordinates.
    to_scaled: [P<L>; 3],
    /// Rows of R: axes directions to world.
    from_axes: [P<L>; 3],
    inv_a: P<L>,
    half_a_min: L,
    /// ρ_c²: a point below it is within the clearance.
    level2: L,
    /// The square of the level a point is pushed to (ρ_c plus the margin).
    target2: L,
    /// Unit vector of the shortest axis (axes coordinates): the way out from the centre.
    shortest: P<L>,
}

/// A capsule at one frame, f32.
#[derive(Debug, Clone, Copy)]
pub(super) struct Capsule<L> {
    start: P<L>,
    axis: P<L>,
    /// 1 / |axis|² (0 for a capsule of no length: a ball).
    inv_len2: L,
    radius: L,
    /// (radius + clearance)²: a point nearer the segment is within the clearance.
    reach2: L,
    /// Distance from the segment a point is pushed to.
    target: L,
    /// A unit vector across the axis: the way out from a point on it.
    across: P<L>,
    /// The middle of the segment, and the square of the radius of a ball about it that
    /// holds every point within the clearance.
    middle: P<L>,
    ball2: L,
}

/// A plane at one frame, f32.
#[derive(Debug, Clone, Copy)]
pub(super) struct Plane<L> {
    point: P<L>,
    normal: P<L>,
    clearance: L,
    target: L,
}

/// A body without a closed form here (cylinder, mesh) at one frame: its exact query.
#[derive(Debug, Clone, Copy)]
pub(super) struct Queried<'a> {
    shape: &'a Shape,
    /// Its frame (`None`: fixed in the world): `x = position + rotation y`.
    frame: Option<(Matrix3<f64>, Vector3<f64>)>,
    /// A world ball around its surface.
    ball: Option<(Vector3<f64>, f64)>,
    clearance: f64,
}

/// One body at one frame.
#[derive(Debug, Clone, Copy)]
// the closed forms hold their constants in every lane, read at every point: kept inline
// (a frame places a handful of bodies once)
#[allow(clippy::large_enum_variant)]
pub(super) enum Placed<'a, L> {
    /// A sphere or an ellipsoid.
    Ellipsoid(Ellipsoid<L>),
    /// A capsule.
    Capsule(Capsule<L>),
    /// A plane.
    Plane(Plane<L>),
    /// A cylinder or a mesh.
    Queried(Queried<'a>),
}

fn f32x3(v: &Vector3<f64>) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// `v` in every lane.
fn lanes<L: Lanes>(v: &Vector3<f64>) -> P<L> {
    splat3(f32x3(v))
}

/// `v` in every lane.
fn lane<L: Lanes>(v: f64) -> L {
    L::splat(v as f32)
}

/// The rows of `m`, each in every lane.
fn rows<L: Lanes>(m: &Matrix3<f64>) -> [P<L>; 3] {
    [0, 1, 2].map(|i| lanes(&m.row(i).transpose()))
}

/// The unit vector of the smallest entry of `a`, in every lane.
fn unit_of_smallest<L: Lanes>(a: &Vector3<f64>) -> P<L> {
    let mut e = Vector3::zeros();
    e[a.imin()] = 1.0;
    lanes(&e)
}

impl<'a, L: Lanes> Placed<'a, L> {
    /// `body` in the frame `frame` (`None`: fixed in the world), kept `clearance` away.
    pub(super) fn new(body: &'a Body, frame: Option<&HeadState>, clearance: f64) -> Self {
        let to_world = |y: &Vector3<f64>| match frame {
            None => *y,
            Some(f) => f.position + f.rotation * y,
        };
        let turn = |r: &Matrix3<f64>| match frame {
            None => *r,
            Some(f) => f.rotation * r,
        };
        let margin = |centre: &Vector3<f64>, size: f64| {
            (MARGIN * f32::EPSILON) as f64 * (centre.norm() + size + clearance)
        };
        let ellipsoid = |centre: Vector3<f64>, rotation: Matrix3<f64>, a: Vector3<f64>| {
            let a_min = a.min();
            let level = 1.0 + clearance / a_min;
            let target = level + margin(&centre, a.max()) / a_min;
            let inv_a = a.map(|v| 1.0 / v);
            Placed::Ellipsoid(Ellipsoid {
                origin: lanes(&centre),
                to_scaled: rows(&(Matrix3::from_diagonal(&inv_a) * rotation.transpose())),
                from_axes: rows(&rotation),
                inv_a: lanes(&inv_a),
                half_a_min: lane(0.5 * a_min),
                level2: lane(level * level),
                target2: lane(target * target),
                shortest: unit_of_smallest(&a),
            })
        };
        match &body.shape {
            Shape::Sphere(s) => ellipsoid(
                to_world(&s.center),
                turn(&Matrix3::identity()),
                Vector3::repeat(s.radius),
            ),
            Shape::Ellipsoid(e) => ellipsoid(to_world(&e.center), turn(&e.rotation), e.radii),
            Shape::Capsule(c) => {
                let (start, end) = (to_world(&c.start), to_world(&c.end));
                let axis = end - start;
                let len2 = axis.norm_squared();
                let centre = 0.5 * (start + end);
                let reach = c.radius + clearance;
                // a unit vector across the axis (any for a capsule of no length)
                let across = [Vector3::x(), Vector3::y()]
                    .map(|e| axis.cross(&e))
                    .into_iter()
                    .max_by(|a, b| a.norm_squared().total_cmp(&b.norm_squared()))
                    .filter(|a| a.norm_squared() > 0.0)
                    .map_or_else(Vector3::x, |a| a.normalize());
                Placed::Capsule(Capsule {
                    start: lanes(&start),
                    axis: lanes(&axis),
                    inv_len2: lane(if len2 > 0.0 { 1.0 / len2 } else { 0.0 }),
                    radius: lane(c.radius),
                    reach2: lane(reach * reach),
                    target: lane(reach + margin(&centre, len2.sqrt() + c.radius)),
                    across: lanes(&across),
                    middle: lanes(&centre),
                    ball2: lane((0.5 * len2.sqrt() + reach).powi(2) * (1.0 + 1e-5)),
                })
            }
            Shape::Plane(p) => {
                let point = to_world(&p.point);
                let normal = turn(&Matrix3::identity()) * p.normal;
                Placed::Plane(Plane {
                    point: lanes(&point),
                    normal: lanes(&normal),
                    clearance: lane(clearance),
                    target: lane(clearance + margin(&point, 0.0)),
                })
            }
            shape => Placed::Queried(Queried {
                shape,
                frame: frame.map(|f| (f.rotation, f.position)),
                ball: shape.bounding_ball().map(|(c, r)| (to_world(&c), r)),
                clearance,
            }),
        }
    }

    /// Whether the body is asked again right after it pushed a point out: only a mesh or
    /// a grid, whose distance is interpolated (its push may leave the point still within).
    pub(super) fn asked_again(&self) -> bool {
        matches!(self, Placed::Queried(q) if matches!(q.shape, Shape::Mesh(_) | Shape::Grid(_)))
    }

    /// The body's answer about the eight world points `x` (one per lane) where `asked`:
    /// `None` when none of them is within the clearance, else a signed measure of each
    /// one's depth (m; +∞ where the point is not within the clearance or not asked;
    /// compared between bodies to push out of the deepest first) and the points pushed
    /// out to the clearance (meaningless where the measure is +∞). No branches for the
    /// closed forms but the one that ends early.
    #[inline(always)]
    pub(super) fn push(&self, x: P<L>, asked: L) -> Option<(L, P<L>)> {
        match self {
            Placed::Ellipsoid(e) => e.push(x, asked),
            Placed::Capsule(c) => c.push(x, asked),
            Placed::Plane(p) => p.push(x, asked),
            Placed::Queried(q) => {
                let lanes = asked.bitmask();
                let xs = [x[0].to_array(), x[1].to_array(), x[2].to_array()];
                let (mut depth, mut out) = ([f32::INFINITY; 8], xs);
                for l in (0..8).filter(|&l| lanes >> l & 1 == 1) {
                    let (d, p) = q.push([xs[0][l], xs[1][l], xs[2][l]]);
                    depth[l] = d;
                    for c in 0..3 {
                        out[c][l] = p[c];
                    }
                }
                Some((
                    L::from_array(depth),
                    [
                        L::from_array(out[0]),
                        L::from_array(out[1]),
                        L::from_array(out[2]),
                    ],
                ))
            }
        }
    }
}

/// Eight points, one per lane, by coordinate.
pub(super) type P<L> = [L; 3];

#[inline(always)]
fn dot<L: Lanes>(a: P<L>, b: P<L>) -> L {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
fn splat3<L: Lanes>(v: [f32; 3]) -> P<L> {
    [L::splat(v[0]), L::splat(v[1]), L::splat(v[2])]
}

#[inline(always)]
fn times<L: Lanes>(m: &[P<L>; 3], v: P<L>) -> P<L> {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

/// `a` where `mask`, `b` elsewhere.
#[inline(always)]
fn select3<L: Lanes>(mask: L, a: P<L>, b: P<L>) -> P<L> {
    [
        mask.select(a[0], b[0]),
        mask.select(a[1], b[1]),
        mask.select(a[2], b[2]),
    ]
}

#[inline(always)]
fn sub<L: Lanes>(a: P<L>, b: P<L>) -> P<L> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline(always)]
fn along<L: Lanes>(x: P<L>, s: L, n: P<L>) -> P<L> {
    [x[0] + s * n[0], x[1] + s * n[1], x[2] + s * n[2]]
}

/// The depth where `within`, +∞ elsewhere.
#[inline(always)]
fn depth_within<L: Lanes>(within: L, depth: L) -> L {
    within.select(depth, L::splat(f32::INFINITY))
}

impl<L: Lanes> Ellipsoid<L> {
    /// [`Placed::push`] for an ellipsoid.
    #[inline(always)]
    fn push(&self, x: P<L>, asked: L) -> Option<(L, P<L>)> {
        let v = times(&self.to_scaled, sub(x, self.origin));
        let rho2 = dot(v, v);
        let within = asked & rho2.lt(self.level2);
        if within.none() {
            return None;
        }
        let inv_a = self.inv_a;
        // the gradient of ρ in the axes, ∝ g = D⁻¹v (not normalised: the step s along it
        // comes out in its units); from the centre, the shortest axis
        let g = [v[0] * inv_a[0], v[1] * inv_a[1], v[2] * inv_a[2]];
        let centre = dot(g, g).le(L::splat(f32::MIN_POSITIVE));
        let n = select3(centre, self.shortest, g);
        // the motion of v for a unit step along n
        let w = [n[0] * inv_a[0], n[1] * inv_a[1], n[2] * inv_a[2]];
        let (vw, ww) = (dot(v, w), dot(w, w));
        let rise = self.target2 - rho2;
        let s = rise / (vw + (vw * vw + ww * rise).sqrt());
        let out = times(&self.from_axes, n);
        // a depth measure without a root: (ρ² − 1) min aᵢ / 2 ≈ (ρ − 1) min aᵢ
        let depth = (rho2 - L::splat(1.0)) * self.half_a_min;
        Some((depth_within(within, depth), along(x, s, out)))
    }
}

impl<L: Lanes> Capsule<L> {
    /// [`Placed::push`] for a capsule: first the ball about it.
    #[inline(always)]
    fn push(&self, x: P<L>, asked: L) -> Option<(L, P<L>)> {
        let m = sub(x, self.middle);
        if (asked & dot(m, m).lt(self.ball2)).none() {
            return None;
        }
        let axis = self.axis;
        let d = sub(x, self.start);
        let t = (dot(d, axis) * self.inv_len2)
            .max(L::splat(0.0))
            .min(L::splat(1.0));
        let e = [d[0] - t * axis[0], d[1] - t * axis[1], d[2] - t * axis[2]];
        let e2 = dot(e, e);
        let len = e2.sqrt();
        // out along e by (target − |e|) / |e| of it; from the axis, across it
        let on_axis = e2.le(L::splat(f32::MIN_POSITIVE));
        let n = select3(on_axis, self.across, e);
        let s = on_axis.select(self.target, (self.target - len) / len);
        let within = asked & e2.lt(self.reach2);
        let depth = len - self.radius;
        Some((depth_within(within, depth), along(x, s, n)))
    }
}

impl<L: Lanes> Plane<L> {
    /// [`Placed::push`] for a plane.
    #[inline(always)]
    fn push(&self, x: P<L>, asked: L) -> Option<(L, P<L>)> {
        let normal = self.normal;
        let distance = dot(sub(x, self.point), normal);
        let within = asked & distance.lt(self.clearance);
        if within.none() {
            return None;
        }
        Some((
            depth_within(within, distance),
            along(x, self.target - distance, normal),
        ))
    }
}

impl Queried<'_> {
    /// [`Placed::push`] for one point: its depth (+∞ when not within) and the point pushed
    /// out.
    fn push(&self, x: [f32; 3]) -> (f32, [f32; 3]) {
        let c = self.clearance;
        let p = Vector3::new(x[0] as f64, x[1] as f64, x[2] as f64);
        if let Some((centre, r)) = self.ball {
            // NaN: not near
            let near = (p - centre).norm_squared() <= (r + c) * (r + c);
            if !near {
                return (f32::INFINITY, x);
            }
        }
        let (q, normal) = match &self.frame {
            None => {
                let q = self.shape.query(&p);
                (q, q.normal)
            }
            Some((rotation, position)) => {
                let q = self.shape.query(&(rotation.transpose() * (p - position)));
                (q, rotation * q.normal)
            }
        };
        let push = c - q.distance;
        if q.distance < c && push.is_finite() && normal.iter().all(|v| v.is_finite()) {
            (q.distance as f32, f32x3(&(p + push * normal)))
        } else {
            (f32::INFINITY, x)
        }
    }
}
