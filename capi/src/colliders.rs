//! The colliders of a batch: their C descriptions ([`ShCollider`], [`ShPose`]), checked
//! and copied into the batch's own form ([`Colliders`]), and that form as the colliders
//! of the fixed-N step (`superhelix_kernels::fixed::StepColliders`), placed in time on a
//! worker's frames ([`StepSet`]).
//!
//! A collider answers its signed distance in its own coordinates with the kernels'
//! analytic shapes (`superhelix_kernels::collider`), a grid of signed distances on the
//! caller's memory (`SdfGrid`: trilinear inside its box, `f(p) + |x − p|` beyond it) or
//! the caller's callback; its mount says where those coordinates are: the head's frame,
//! the world, or a frame on its own motion given by its poses at the two ends of each
//! step (`PoseOverStep`: uniform motion, a constant turn; placed by the kernels'
//! `PosedColliders`).

use core::ffi::{c_int, c_void};
use nalgebra::{Matrix3, Vector3};
use superhelix_kernels::collider::{
    Capsule, Collider, Cylinder, Ellipsoid, GridView, Plane, PoseOverStep, Proximity, SdfGrid,
    Sphere,
};
pub(crate) use superhelix_kernels::fixed::Carrier;
use superhelix_kernels::fixed::PosedColliders;

type V3 = Vector3<f64>;

/// [`ShCollider::kind`]: a ball ([`ShShape::sphere`]).
pub const SH_COLLIDER_SPHERE: c_int = 0;
/// [`ShCollider::kind`]: a capsule ([`ShShape::capsule`]).
pub const SH_COLLIDER_CAPSULE: c_int = 1;
/// [`ShCollider::kind`]: an ellipsoid ([`ShShape::ellipsoid`]).
pub const SH_COLLIDER_ELLIPSOID: c_int = 2;
/// [`ShCollider::kind`]: a half-space ([`ShShape::plane`]).
pub const SH_COLLIDER_PLANE: c_int = 3;
/// [`ShCollider::kind`]: a cylinder with flat caps ([`ShShape::cylinder`]).
pub const SH_COLLIDER_CYLINDER: c_int = 4;
/// [`ShCollider::kind`]: a grid of signed distances on the caller's memory
/// ([`ShShape::grid`]).
pub const SH_COLLIDER_GRID: c_int = 5;
/// [`ShCollider::kind`]: the caller's callback ([`ShShape::callback`]).
pub const SH_COLLIDER_CALLBACK: c_int = 6;

/// [`ShCollider::mount`]: fixed in the head's frame (its coordinates are head
/// coordinates; it moves with the head).
pub const SH_MOUNT_HEAD: c_int = 0;
/// [`ShCollider::mount`]: fixed in the world (its coordinates are world coordinates).
pub const SH_MOUNT_WORLD: c_int = 1;
/// [`ShCollider::mount`]: on a pose of its own, set before each step by
/// `sh_batch_set_collider_pose` (the identity at the origin until then).
pub const SH_MOUNT_POSE: c_int = 2;

/// Most colliders of one batch.
pub const SH_MAX_COLLIDERS: usize = 4096;

/// Most nodes of one grid collider (2²⁸: 2 GB of doubles).
pub const SH_MAX_GRID_NODES: usize = 1 << 28;

/// Largest radius, half-axis or coordinate of a collider's size, m (as a scene's
/// bodies).
pub const SH_MAX_COLLIDER_SIZE: f64 = 1000.0;

/// A ball: the points within `radius` of `center`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShSphere {
    /// Centre, m (the collider's coordinates).
    pub center: [f64; 3],
    /// Radius, m, in (0, 1000].
    pub radius: f64,
}

/// A capsule: the points within `radius` of the segment from `start` to `end` (a ball
/// when they coincide).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShCapsule {
    /// One end of the axis, m.
    pub start: [f64; 3],
    /// The other end, m.
    pub end: [f64; 3],
    /// Radius, m, in (0, 1000].
    pub radius: f64,
}

/// A solid ellipsoid `|(Rᵀ(y − c))ᵢ / aᵢ|² ≤ 1`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShEllipsoid {
    /// Centre c, m.
    pub center: [f64; 3],
    /// Half-axes a, m, each in (0, 1000].
    pub radii: [f64; 3],
    /// R, column-major: the ellipsoid's axes (its columns) in the collider's coordinates;
    /// a rotation within 1e-9.
    pub rotation: [f64; 9],
}

/// The half-space behind a plane: `(y − point) · normal ≤ 0`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShPlane {
    /// A point of the plane, m.
    pub point: [f64; 3],
    /// Unit outward normal (length 1 within 1e-9).
    pub normal: [f64; 3],
}

/// A solid cylinder with flat caps: the points within `radius` of the axis from `start`
/// to `end`, between the caps through the two ends.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShCylinder {
    /// Centre of one cap, m.
    pub start: [f64; 3],
    /// Centre of the other cap, m (not `start`).
    pub end: [f64; 3],
    /// Radius, m, in (0, 1000].
    pub radius: f64,
}

/// A signed distance sampled on a regular grid (negative inside), on the caller's
/// memory: node (i, j, k) at `origin + spacing · (i, j, k)` holds
/// `values[i + dims[0] (j + dims[1] k)]` (x fastest: a C array `values[nz][ny][nx]`).
/// Inside the grid's box the distance is the trilinear interpolant of the cell's eight
/// nodes, its normal the interpolant's normalised gradient; beyond the box it is
/// `f(p) + |x − p|` with p the box's nearest point (an upper bound of a true distance).
///
/// The batch keeps the pointer, not a copy: the values must stay valid and finite while
/// the batch may step (until the colliders are set again or the batch is freed), and
/// unchanged during a step. They may be rewritten between two steps provided no node of
/// the grid's boundary gets a value below the least boundary value when the colliders
/// were set (from it the batch computes the ball beyond which the grid is not queried);
/// otherwise set the colliders again.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShGrid {
    /// dims[0] · dims[1] · dims[2] values, m, all finite.
    pub values: *const f64,
    /// Nodes along x, y, z, each ≥ 2; at most `SH_MAX_GRID_NODES` in all.
    pub dims: [usize; 3],
    /// Position of node (0, 0, 0), m (the collider's coordinates).
    pub origin: [f64; 3],
    /// Distance between neighbouring nodes along every axis, m, in (0, 1000].
    pub spacing: f64,
}

/// What a collider callback answers for a point.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShProximity {
    /// Signed distance to the surface, m (negative inside; +infinity: far away).
    pub distance: f64,
    /// Unit outward normal at the nearest surface point (the distance's gradient).
    pub normal: [f64; 3],
    /// Velocity of the surface's material point there, m/s, in the collider's
    /// coordinates and relative to them (0 for a rigid collider: its mount's motion is
    /// added by the library).
    pub velocity: [f64; 3],
}

/// A collider callback: answers for the point `point` (3 values, the collider's
/// coordinates) into `*answer`, which the library fills with `distance` = +infinity,
/// normal +z and zero velocity before the call. A distance that is not a number counts
/// as +infinity; a normal that is not finite and nonzero as +z; it is normalised. It may
/// be called from every thread that steps a range of the batch at once. NULL is no
/// function.
pub type ShColliderCallback = Option<
    unsafe extern "C" fn(user_data: *mut c_void, point: *const f64, answer: *mut ShProximity),
>;

/// The function of an [`ShColliderCallback`].
type CallbackFn =
    unsafe extern "C" fn(user_data: *mut c_void, point: *const f64, answer: *mut ShProximity);

/// A collider answered by the caller's function.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct ShCallbackCollider {
    /// The function (not NULL).
    pub query: ShColliderCallback,
    /// Handed to every call of `query` unchanged.
    pub user_data: *mut c_void,
    /// Nonzero when the surface moves within the collider's coordinates (the callback
    /// answers nonzero velocities): the work of its motion on the strands then enters
    /// their energy balance, as a collider on its own pose's. Zero: the velocities
    /// answered are not read (a rigid collider, moving with its mount only).
    pub moves: c_int,
}

/// The shape of an [`ShCollider`], read as its `kind` says.
#[repr(C)]
#[derive(Clone, Copy)]
pub union ShShape {
    /// `SH_COLLIDER_SPHERE`.
    pub sphere: ShSphere,
    /// `SH_COLLIDER_CAPSULE`.
    pub capsule: ShCapsule,
    /// `SH_COLLIDER_ELLIPSOID`.
    pub ellipsoid: ShEllipsoid,
    /// `SH_COLLIDER_PLANE`.
    pub plane: ShPlane,
    /// `SH_COLLIDER_CYLINDER`.
    pub cylinder: ShCylinder,
    /// `SH_COLLIDER_GRID`.
    pub grid: ShGrid,
    /// `SH_COLLIDER_CALLBACK`.
    pub callback: ShCallbackCollider,
}

/// One collider: its shape (in its own coordinates) and where those coordinates are.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct ShCollider {
    /// Which member of `shape` is read: one of `SH_COLLIDER_SPHERE`, `SH_COLLIDER_CAPSULE`,
    /// `SH_COLLIDER_ELLIPSOID`, `SH_COLLIDER_PLANE`, `SH_COLLIDER_CYLINDER`,
    /// `SH_COLLIDER_GRID`, `SH_COLLIDER_CALLBACK`.
    pub kind: c_int,
    /// Where the collider's coordinates are: `SH_MOUNT_HEAD`, `SH_MOUNT_WORLD` or
    /// `SH_MOUNT_POSE`.
    pub mount: c_int,
    /// The shape.
    pub shape: ShShape,
}

/// A rigid pose: a point y of the collider's coordinates is at `position + rotation · y`
/// in the world.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShPose {
    /// Position, world coordinates, m.
    pub position: [f64; 3],
    /// Rotation, column-major (within 1e-6 of a rotation).
    pub rotation: [f64; 9],
}

/// A collider's shape, checked.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Shape {
    Sphere(Sphere),
    Capsule(Capsule),
    Ellipsoid(Ellipsoid),
    Plane(Plane),
    Cylinder(Cylinder),
    /// The grid and its bounding ball (`GridView::bounding_ball`: beyond it a point is
    /// farther from the surface than from the ball).
    Grid {
        sdf: SdfGrid<'static>,
        center: V3,
        reach: f64,
    },
    Callback {
        query: CallbackFn,
        user_data: *mut c_void,
        moves: bool,
    },
}

/// The colliders of a batch, copied from their descriptions (a grid's values and a
/// callback's user data stay the caller's).
#[derive(Debug, Default)]
pub(crate) struct Colliders {
    pub items: Vec<(Shape, Carrier)>,
}

// SAFETY: the raw pointers are the caller's grid values (read only) and callback user
// data; the C API documents that the grid stays valid and unchanged while the batch
// steps and that a callback may be called from every thread stepping the batch at once.
unsafe impl Send for Colliders {}
// SAFETY: as for Send: nothing here is written through a shared reference.
unsafe impl Sync for Colliders {}

/// Why a collider description was refused: the message names the field and its range.
pub(crate) type Refusal = String;

fn finite3(v: &[f64; 3], field: &str) -> Result<V3, Refusal> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(V3::from(*v))
    } else {
        Err(format!("{field}: every value must be finite"))
    }
}

fn size(x: f64, field: &str) -> Result<f64, Refusal> {
    if x > 0.0 && x <= SH_MAX_COLLIDER_SIZE {
        Ok(x)
    } else {
        Err(format!(
            "{field}: {x} must be in (0, {SH_MAX_COLLIDER_SIZE}] m"
        ))
    }
}

/// A rotation matrix from 9 column-major values: finite, orthonormal within `tol`,
/// det > 0.
pub(crate) fn rotation(r: &[f64; 9], tol: f64, field: &str) -> Result<Matrix3<f64>, Refusal> {
    let m = Matrix3::from_column_slice(r);
    let ok = r.iter().all(|x| x.is_finite())
        && (m.transpose() * m - Matrix3::identity()).amax() <= tol
        && m.determinant() > 0.0;
    if ok {
        Ok(m)
    } else {
        Err(format!(
            "{field}: must be a rotation (orthonormal columns within {tol:e}, det > 0)"
        ))
    }
}

/// The grid's shape, its values checked finite.
///
/// # Safety
/// `g.values` is NULL or valid for reading the grid's values for as long as the batch
/// uses them (the C API's lifetime rule).
unsafe fn grid(g: &ShGrid, at: &str) -> Result<Shape, Refusal> {
    if g.values.is_null() {
        return Err(format!("{at}.values: must not be NULL"));
    }
    if let Some(a) = g.dims.iter().position(|&n| n < 2) {
        return Err(format!(
            "{at}.dims[{a}]: {} must be at least 2 (a grid has two nodes along every axis)",
            g.dims[a]
        ));
    }
    let nodes = g.dims.iter().try_fold(1usize, |n, &d| n.checked_mul(d));
    let nodes = match nodes {
        Some(n) if n <= SH_MAX_GRID_NODES => n,
        _ => {
            return Err(format!(
                "{at}.dims: {:?} has more than SH_MAX_GRID_NODES = {SH_MAX_GRID_NODES} nodes",
                g.dims
            ))
        }
    };
    let origin = finite3(&g.origin, &format!("{at}.origin"))?;
    let spacing = size(g.spacing, &format!("{at}.spacing"))?;
    // SAFETY: non-NULL and, by the caller, valid for reading `nodes` values for the
    // batch's use of them (the C API's lifetime rule, documented on ShGrid).
    let values: &'static [f64] = unsafe { core::slice::from_raw_parts(g.values, nodes) };
    if let Some(i) = values.iter().position(|x| !x.is_finite()) {
        return Err(format!("{at}.values[{i}]: {} must be finite", values[i]));
    }
    let view = GridView::new(origin, spacing, g.dims, values)
        .ok_or_else(|| format!("{at}: not a grid of its dims and spacing"))?;
    let (center, reach) = view.bounding_ball();
    Ok(Shape::Grid {
        sdf: SdfGrid { grid: view },
        center,
        reach,
    })
}

/// The collider of `c`, checked (`at`: its name in messages, e.g. `colliders[2]`).
///
/// # Safety
/// A grid's values and a callback's user data are as the C API requires (see
/// [`ShGrid`], [`ShCallbackCollider`]).
pub(crate) unsafe fn collider(c: &ShCollider, at: &str) -> Result<(Shape, Carrier), Refusal> {
    let carrier = match c.mount {
        SH_MOUNT_HEAD => Carrier::Head,
        SH_MOUNT_WORLD => Carrier::World,
        SH_MOUNT_POSE => Carrier::Pose(PoseOverStep::still(V3::zeros(), Matrix3::identity())),
        m => {
            return Err(format!(
                "{at}.mount: {m} is not one of SH_MOUNT_HEAD (0), SH_MOUNT_WORLD (1), SH_MOUNT_POSE (2)"
            ))
        }
    };
    // SAFETY (every union read below): the members are plain numbers and pointers, any
    // bit pattern of which is a value; `kind` says which the caller wrote.
    let shape = match c.kind {
        SH_COLLIDER_SPHERE => {
            let s = unsafe { c.shape.sphere };
            Shape::Sphere(Sphere {
                center: finite3(&s.center, &format!("{at}.shape.sphere.center"))?,
                radius: size(s.radius, &format!("{at}.shape.sphere.radius"))?,
            })
        }
        SH_COLLIDER_CAPSULE => {
            let s = unsafe { c.shape.capsule };
            Shape::Capsule(Capsule {
                start: finite3(&s.start, &format!("{at}.shape.capsule.start"))?,
                end: finite3(&s.end, &format!("{at}.shape.capsule.end"))?,
                radius: size(s.radius, &format!("{at}.shape.capsule.radius"))?,
            })
        }
        SH_COLLIDER_ELLIPSOID => {
            let s = unsafe { c.shape.ellipsoid };
            let mut radii = V3::zeros();
            for (k, r) in s.radii.iter().enumerate() {
                radii[k] = size(*r, &format!("{at}.shape.ellipsoid.radii[{k}]"))?;
            }
            Shape::Ellipsoid(Ellipsoid {
                center: finite3(&s.center, &format!("{at}.shape.ellipsoid.center"))?,
                radii,
                rotation: rotation(
                    &s.rotation,
                    1e-9,
                    &format!("{at}.shape.ellipsoid.rotation"),
                )?,
            })
        }
        SH_COLLIDER_PLANE => {
            let s = unsafe { c.shape.plane };
            let normal = finite3(&s.normal, &format!("{at}.shape.plane.normal"))?;
            if (normal.norm() - 1.0).abs() >= 1e-9 {
                return Err(format!(
                    "{at}.shape.plane.normal: must be a unit vector (length 1 within 1e-9), got length {}",
                    normal.norm()
                ));
            }
            Shape::Plane(Plane {
                point: finite3(&s.point, &format!("{at}.shape.plane.point"))?,
                normal,
            })
        }
        SH_COLLIDER_CYLINDER => {
            let s = unsafe { c.shape.cylinder };
            let start = finite3(&s.start, &format!("{at}.shape.cylinder.start"))?;
            let end = finite3(&s.end, &format!("{at}.shape.cylinder.end"))?;
            if start == end {
                return Err(format!(
                    "{at}.shape.cylinder.end: must differ from start (a cylinder needs an axis)"
                ));
            }
            Shape::Cylinder(Cylinder {
                start,
                end,
                radius: size(s.radius, &format!("{at}.shape.cylinder.radius"))?,
            })
        }
        SH_COLLIDER_GRID => {
            let g = unsafe { c.shape.grid };
            // SAFETY: the grid's values are as the C API requires (caller).
            unsafe { grid(&g, &format!("{at}.shape.grid"))? }
        }
        SH_COLLIDER_CALLBACK => {
            let s = unsafe { c.shape.callback };
            let query = s
                .query
                .ok_or_else(|| format!("{at}.shape.callback.query: must not be NULL"))?;
            Shape::Callback {
                query,
                user_data: s.user_data,
                moves: s.moves != 0,
            }
        }
        k => {
            return Err(format!(
                "{at}.kind: {k} is not a collider kind (SH_COLLIDER_SPHERE (0) to SH_COLLIDER_CALLBACK (6))"
            ))
        }
    };
    Ok((shape, carrier))
}

/// A pose, checked.
pub(crate) fn pose(p: &ShPose, field: &str) -> Result<(V3, Matrix3<f64>), Refusal> {
    let position = finite3(&p.position, &format!("{field}.position"))?;
    let r = rotation(&p.rotation, 1e-6, &format!("{field}.rotation"))?;
    Ok((position, r))
}

impl Collider for Shape {
    fn proximity(&self, y: &V3) -> Proximity {
        self.answer(y).0
    }
    fn farther_than(&self, y: &V3, r: f64) -> bool {
        Shape::farther_than(self, y, r)
    }
    fn surface_velocity(&self, y: &V3) -> V3 {
        self.answer(y).1
    }
    fn surface_moves(&self) -> bool {
        matches!(self, Shape::Callback { moves: true, .. })
    }
}

impl Shape {
    /// Signed distance, outward normal and closest point of `y` (the collider's
    /// coordinates), and the surface's own velocity there (callbacks only).
    fn answer(&self, y: &V3) -> (Proximity, V3) {
        let p = match self {
            Shape::Sphere(s) => s.proximity(y),
            Shape::Capsule(s) => s.proximity(y),
            Shape::Ellipsoid(s) => s.proximity(y),
            Shape::Plane(s) => s.proximity(y),
            Shape::Cylinder(s) => s.proximity(y),
            Shape::Grid { sdf, .. } => sdf.proximity(y),
            Shape::Callback {
                query, user_data, ..
            } => return call(*query, *user_data, y),
        };
        (p, V3::zeros())
    }

    /// Whether `y` is certainly farther than `r` outside (a bounding ball, as the
    /// runtime's bodies test it; the ellipsoid's own test).
    fn farther_than(&self, y: &V3, r: f64) -> bool {
        let ball = |c: V3, radius: f64| (y - c).norm_squared() > (radius + r) * (radius + r);
        match self {
            Shape::Sphere(s) => ball(s.center, s.radius),
            Shape::Capsule(c) => ball(
                0.5 * (c.start + c.end),
                0.5 * (c.end - c.start).norm() + c.radius,
            ),
            Shape::Cylinder(c) => ball(
                0.5 * (c.start + c.end),
                (0.25 * (c.end - c.start).norm_squared() + c.radius * c.radius).sqrt(),
            ),
            Shape::Ellipsoid(e) => e.farther_than(y, r),
            Shape::Grid { center, reach, .. } => ball(*center, *reach),
            Shape::Plane(_) | Shape::Callback { .. } => false,
        }
    }
}

/// The callback's answer at `y`, made safe: a distance that is not a number is
/// +infinity, a normal that is not finite and nonzero is +z, the normal normalised, a
/// velocity that is not finite zero.
fn call(query: CallbackFn, user_data: *mut c_void, y: &V3) -> (Proximity, V3) {
    let mut answer = ShProximity {
        distance: f64::INFINITY,
        normal: [0.0, 0.0, 1.0],
        velocity: [0.0; 3],
    };
    let point = [y.x, y.y, y.z];
    // SAFETY: the callback is the caller's, called as the C API documents: a point of 3
    // values and an answer to fill, both valid for the call.
    unsafe { query(user_data, point.as_ptr(), &mut answer) };
    let distance = if answer.distance.is_nan() {
        f64::INFINITY
    } else {
        answer.distance
    };
    let n = V3::from(answer.normal);
    let norm = n.norm();
    let normal = if norm.is_finite() && norm > 0.0 {
        n / norm
    } else {
        V3::z()
    };
    let v = V3::from(answer.velocity);
    let velocity = if v.iter().all(|x| x.is_finite()) {
        v
    } else {
        V3::zeros()
    };
    let closest = if distance.is_finite() {
        y - normal * distance
    } else {
        *y
    };
    (
        Proximity {
            distance,
            normal,
            closest,
        },
        velocity,
    )
}

/// The colliders of a batch placed in time for one strand's step
/// (`superhelix_kernels::fixed::PosedColliders`: those on a pose of their own at the pose
/// of the time asked, over the step, in a worker's frames).
pub(crate) type StepSet<'a> = PosedColliders<'a, Shape>;
