//! The C API's contacts with colliders called from Rust: every refusal (NULL pointers,
//! values out of range, bad grids, indices) with its status and a message naming the
//! field; a callback answering a ball steps the strands as the analytic ball does; a
//! callback's surface velocity drags the strands lying on it; ranges stepped from two
//! threads equal the whole batch's step; a state set from outside restarts the
//! contacts; and the step allocates nothing once each workspace has its scratch.

use core::ffi::c_void;
use core::ptr::{null, null_mut};
use nalgebra::Vector3;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use superhelix_capi::colliders::*;
use superhelix_capi::contacts::*;
use superhelix_capi::*;
use superhelix_kernels::collider::Sphere;

/// Counts the allocations of each thread (for the step that must allocate nothing).
struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

// SAFETY: forwards to the system allocator; the count is a plain thread-local cell.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));

        // SAFETY: as the caller of alloc guarantees.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as the caller of dealloc guarantees.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, size: usize) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        // SAFETY: as the caller of realloc guarantees.
        unsafe { System.realloc(ptr, layout, size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

const N: usize = 5;

/// A straight strand of N = 5, 20 cm, rooted at `root` and leaving along +x.
fn params(root: [f64; 3]) -> ShStrandParams {
    ShStrandParams {
        elements: N,
        length: 0.2,
        element_lengths: null(),
        root_position: root,
        root_frame: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0],
        cross_section: ShCrossSection {
            radius: 50e-6,
            ellipticity: 1.0,
            youngs_modulus: 1.5e9,
            poisson_ratio: 0.48,
            density: 1300.0,
        },
        natural: [0.0; 3],
        natural_per_element: null(),
        internal_friction: 5e-11,
        air_drag: 5e-6,
    }
}

/// A batch owned by the test (freed on drop).
struct Batch(*mut ShBatch);

impl Drop for Batch {
    fn drop(&mut self) {
        // SAFETY: from sh_batch_new, freed once here.
        unsafe { sh_batch_free(self.0) };
    }
}

/// `count` strands 2 mm above the top of a ball of radius 5 cm at the origin, leaving
/// along +x, under gravity, with the default contacts.
fn batch(count: usize) -> Batch {
    let p: Vec<ShStrandParams> = (0..count)
        .map(|k| params([-0.03, -0.02 + 0.01 * k as f64, 0.052]))
        .collect();
    let mut out = null_mut();
    // SAFETY: valid slice and out pointer.
    let s = unsafe { sh_batch_new(p.as_ptr(), p.len(), &mut out, null_mut()) };
    assert_eq!(s, ShStatus::Ok);
    let b = Batch(out);
    let g = [0.0, 0.0, -9.81];
    // SAFETY: live batch, 3 values.
    assert_eq!(
        unsafe { sh_batch_set_gravity(b.0, g.as_ptr()) },
        ShStatus::Ok
    );
    let mut c = DEFAULT;
    // SAFETY: valid out pointer.
    assert_eq!(unsafe { sh_contact_params_default(&mut c) }, ShStatus::Ok);
    // SAFETY: live batch, valid params.
    assert_eq!(unsafe { sh_batch_set_contacts(b.0, &c) }, ShStatus::Ok);
    b
}

const DEFAULT: ShContactParams = ShContactParams {
    radius: f64::NAN,
    stiffness: f64::NAN,
    damping_ratio: f64::NAN,
    friction: -1,
    friction_coefficient: f64::NAN,
    kinetic_friction_coefficient: f64::NAN,
    slip_speed: f64::NAN,
    tangential_stiffness_ratio: f64::NAN,
    anisotropy: f64::NAN,
    samples_per_element: 0,
    tip_sample: 0,
    predict: 0,
    max_depth: f64::NAN,
    split_depth: f64::NAN,
    depenetration_speed: f64::NAN,
};

fn defaults() -> ShContactParams {
    let mut c = DEFAULT;
    // SAFETY: valid out pointer.
    unsafe { sh_contact_params_default(&mut c) };
    c
}

fn message(b: &Batch) -> String {
    let mut e = ShError {
        status: ShStatus::Panic,
        strand: 0,
        message: [1; SH_ERROR_MESSAGE_BYTES],
    };
    // SAFETY: live batch, valid out pointer.
    assert_eq!(unsafe { sh_batch_last_error(b.0, &mut e) }, ShStatus::Ok);
    e.message_str().to_string()
}

fn sphere(radius: f64, mount: i32) -> ShCollider {
    ShCollider {
        kind: SH_COLLIDER_SPHERE,
        mount,
        shape: ShShape {
            sphere: ShSphere {
                center: [0.0; 3],
                radius,
            },
        },
    }
}

fn set(b: &Batch, colliders: &[ShCollider]) -> ShStatus {
    // SAFETY: live batch, a valid slice (grids and callbacks below are valid).
    unsafe { sh_batch_set_colliders(b.0, colliders.as_ptr(), colliders.len()) }
}

fn step(b: &Batch) -> ShStatus {
    // SAFETY: live batch.
    unsafe { sh_batch_step(b.0, 1.0 / 60.0) }
}

fn centreline(b: &Batch, i: usize) -> Vec<f64> {
    let mut xyz = vec![0.0; 3 * (N + 1)];
    // SAFETY: live batch, room for N + 1 points.
    let s = unsafe { sh_batch_centreline(b.0, i, xyz.as_mut_ptr(), N + 1, null_mut()) };
    assert_eq!(s, ShStatus::Ok);
    xyz
}

#[test]
fn contact_parameters_out_of_range_are_refused_naming_the_field() {
    let b = batch(1);
    // SAFETY: NULL batch / NULL params are allowed arguments.
    assert_eq!(
        unsafe { sh_batch_set_contacts(null_mut(), &defaults()) },
        ShStatus::NullPointer
    );
    // SAFETY: NULL is refused.
    assert_eq!(
        unsafe { sh_contact_params_default(null_mut()) },
        ShStatus::NullPointer
    );
    type Edit = fn(&mut ShContactParams);
    let cases: [(Edit, &str); 11] = [
        (
            |c| c.radius = f64::NAN,
            "contacts.radius: NaN must be in (0, 0.1] m",
        ),
        (|c| c.radius = -1e-3, "contacts.radius: -0.001"),
        (|c| c.stiffness = -5.0, "contacts.stiffness"),
        (|c| c.damping_ratio = 11.0, "contacts.damping_ratio"),
        (|c| c.friction = 7, "contacts.friction: 7 is not one of"),
        (|c| c.slip_speed = 0.0, "contacts.slip_speed"),
        (
            |c| {
                c.friction = SH_FRICTION_COULOMB;
                c.kinetic_friction_coefficient = 0.5;
            },
            "contacts.kinetic_friction_coefficient: 0.5 must be in [0, friction_coefficient]",
        ),
        (|c| c.anisotropy = 1.0, "contacts.anisotropy"),
        (
            |c| c.samples_per_element = 0,
            "contacts.samples_per_element: 0 must be in 1..=64",
        ),
        (|c| c.split_depth = f64::INFINITY, "contacts.split_depth"),
        (
            |c| c.depenetration_speed = 0.0,
            "contacts.depenetration_speed",
        ),
    ];
    for (edit, fragment) in cases {
        let mut c = defaults();
        edit(&mut c);
        // SAFETY: live batch, valid params.
        let s = unsafe { sh_batch_set_contacts(b.0, &c) };
        assert_eq!(s, ShStatus::InvalidContacts, "{fragment}");
        let m = message(&b);
        assert!(m.contains(fragment), "{m:?} lacks {fragment:?}");
    }
    // contacts need the checked step (or the error-controlled one), both ways round
    // SAFETY: live batch.
    unsafe {
        assert_eq!(sh_batch_set_checked(b.0, 0), ShStatus::InvalidContacts);
        assert!(message(&b).contains("checked"));
        assert_eq!(sh_batch_set_tolerance(b.0, 1e-3), ShStatus::Ok);
        assert_eq!(sh_batch_set_contacts(b.0, null()), ShStatus::Ok);
        assert_eq!(sh_batch_set_contacts(b.0, &defaults()), ShStatus::Ok);
        assert_eq!(sh_batch_set_contacts(b.0, null()), ShStatus::Ok);
        assert_eq!(sh_batch_set_tolerance(b.0, 0.0), ShStatus::Ok);
        assert_eq!(sh_batch_set_checked(b.0, 0), ShStatus::Ok);
        assert_eq!(
            sh_batch_set_contacts(b.0, &defaults()),
            ShStatus::InvalidContacts
        );
        assert!(message(&b).contains("plain step"));
    }
}

#[test]
fn collider_descriptions_out_of_range_are_refused_naming_the_field() {
    let b = batch(1);
    let grid_values = [1.0, f64::NAN, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
    let grid = |values: *const f64, dims: [usize; 3], spacing: f64| ShCollider {
        kind: SH_COLLIDER_GRID,
        mount: SH_MOUNT_WORLD,
        shape: ShShape {
            grid: ShGrid {
                values,
                dims,
                origin: [0.0; 3],
                spacing,
            },
        },
    };
    let ones = [1.0; 8];
    let plane = ShCollider {
        kind: SH_COLLIDER_PLANE,
        mount: SH_MOUNT_WORLD,
        shape: ShShape {
            plane: ShPlane {
                point: [0.0; 3],
                normal: [0.0, 0.0, 2.0],
            },
        },
    };
    let cylinder = ShCollider {
        kind: SH_COLLIDER_CYLINDER,
        mount: SH_MOUNT_HEAD,
        shape: ShShape {
            cylinder: ShCylinder {
                start: [0.0; 3],
                end: [0.0; 3],
                radius: 0.1,
            },
        },
    };
    let ellipsoid = ShCollider {
        kind: SH_COLLIDER_ELLIPSOID,
        mount: SH_MOUNT_HEAD,
        shape: ShShape {
            ellipsoid: ShEllipsoid {
                center: [0.0; 3],
                radii: [0.1, 0.1, 0.1],
                rotation: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0],
            },
        },
    };
    let callback = ShCollider {
        kind: SH_COLLIDER_CALLBACK,
        mount: SH_MOUNT_HEAD,
        shape: ShShape {
            callback: ShCallbackCollider {
                query: None,
                user_data: null_mut(),
                moves: 0,
            },
        },
    };
    let mut unknown = sphere(0.1, SH_MOUNT_HEAD);
    unknown.kind = 99;
    let cases: Vec<(ShCollider, ShStatus, &str)> = vec![
        (
            sphere(-1.0, SH_MOUNT_HEAD),
            ShStatus::InvalidCollider,
            "colliders[1].shape.sphere.radius: -1 must be in (0, 1000] m",
        ),
        (
            sphere(f64::NAN, SH_MOUNT_HEAD),
            ShStatus::InvalidCollider,
            "colliders[1].shape.sphere.radius: NaN",
        ),
        (
            sphere(0.1, 7),
            ShStatus::InvalidCollider,
            "colliders[1].mount: 7 is not one of",
        ),
        (
            unknown,
            ShStatus::InvalidCollider,
            "colliders[1].kind: 99 is not a collider kind",
        ),
        (
            grid(null(), [2, 2, 2], 0.01),
            ShStatus::InvalidCollider,
            "colliders[1].shape.grid.values: must not be NULL",
        ),
        (
            grid(ones.as_ptr(), [2, 1, 4], 0.01),
            ShStatus::InvalidCollider,
            "colliders[1].shape.grid.dims[1]: 1 must be at least 2",
        ),
        (
            grid(ones.as_ptr(), [0, 2, 2], 0.01),
            ShStatus::InvalidCollider,
            "dims[0]: 0 must be at least 2",
        ),
        (
            grid(ones.as_ptr(), [usize::MAX, 2, 2], 0.01),
            ShStatus::InvalidCollider,
            "shape.grid.dims: [18446744073709551615, 2, 2] has more than SH_MAX_GRID_NODES",
        ),
        (
            grid(ones.as_ptr(), [2, 2, 2], 0.0),
            ShStatus::InvalidCollider,
            "shape.grid.spacing: 0 must be in (0, 1000] m",
        ),
        (
            grid(grid_values.as_ptr(), [2, 2, 2], 0.01),
            ShStatus::InvalidCollider,
            "colliders[1].shape.grid.values[1]: NaN must be finite",
        ),
        (
            plane,
            ShStatus::InvalidCollider,
            "colliders[1].shape.plane.normal: must be a unit vector",
        ),
        (
            cylinder,
            ShStatus::InvalidCollider,
            "colliders[1].shape.cylinder.end: must differ from start",
        ),
        (
            ellipsoid,
            ShStatus::InvalidCollider,
            "colliders[1].shape.ellipsoid.rotation: must be a rotation",
        ),
        (
            callback,
            ShStatus::InvalidCollider,
            "colliders[1].shape.callback.query: must not be NULL",
        ),
    ];
    assert_eq!(set(&b, &[sphere(0.05, SH_MOUNT_HEAD)]), ShStatus::Ok);
    for (bad, status, fragment) in cases {
        assert_eq!(
            set(&b, &[sphere(0.05, SH_MOUNT_HEAD), bad]),
            status,
            "{fragment}"
        );
        let m = message(&b);
        assert!(m.contains(fragment), "{m:?} lacks {fragment:?}");
    }
    // SAFETY: NULL with a count, a count beyond the cap, a NULL batch.
    unsafe {
        assert_eq!(
            sh_batch_set_colliders(b.0, null(), 2),
            ShStatus::NullPointer
        );
        assert_eq!(
            sh_batch_set_colliders(b.0, null(), SH_MAX_COLLIDERS + 1),
            ShStatus::InvalidCount
        );
        assert_eq!(
            sh_batch_set_colliders(null_mut(), null(), 0),
            ShStatus::NullPointer
        );
        assert_eq!(sh_batch_set_colliders(b.0, null(), 0), ShStatus::Ok);
    }
}

#[test]
fn poses_and_readings_refuse_bad_indices_and_values() {
    let b = batch(2);
    assert_eq!(
        set(
            &b,
            &[sphere(0.05, SH_MOUNT_HEAD), sphere(0.01, SH_MOUNT_POSE)]
        ),
        ShStatus::Ok
    );
    let good = ShPose {
        position: [0.0, 0.0, -1.0],
        rotation: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
    };
    let mut nan = good;
    nan.position[1] = f64::NAN;
    let mut skew = good;
    skew.rotation[1] = 0.1;
    // SAFETY: live batch, valid or NULL poses.
    unsafe {
        assert_eq!(
            sh_batch_set_collider_pose(b.0, 1, &good, null()),
            ShStatus::Ok
        );
        assert_eq!(
            sh_batch_set_collider_pose(b.0, 2, &good, &good),
            ShStatus::IndexOutOfRange
        );
        assert!(message(&b).contains("index: 2 must be below the batch's 2 colliders"));
        assert_eq!(
            sh_batch_set_collider_pose(b.0, 0, &good, &good),
            ShStatus::InvalidCollider
        );
        assert!(message(&b).contains("colliders[0].mount: not SH_MOUNT_POSE"));
        assert_eq!(
            sh_batch_set_collider_pose(b.0, 1, &nan, &good),
            ShStatus::InvalidCollider
        );
        assert!(message(&b).contains("start.position: every value must be finite"));
        assert_eq!(
            sh_batch_set_collider_pose(b.0, 1, &good, &skew),
            ShStatus::InvalidCollider
        );
        assert!(message(&b).contains("end.rotation: must be a rotation"));
        assert_eq!(
            sh_batch_set_collider_pose(b.0, 1, null(), &good),
            ShStatus::NullPointer
        );
        let mut deepest = [f64::NAN; 2];
        let mut touching = [usize::MAX; 2];
        let (d, t) = (deepest.as_mut_ptr(), touching.as_mut_ptr());
        assert_eq!(
            sh_batch_contacts(b.0, 1, 2, d, t),
            ShStatus::IndexOutOfRange
        );
        assert_eq!(
            sh_batch_contacts(null_mut(), 0, 2, d, t),
            ShStatus::NullPointer
        );
        assert_eq!(sh_batch_contacts(b.0, 0, 2, d, null_mut()), ShStatus::Ok);
        assert_eq!(sh_batch_contacts(b.0, 0, 2, d, t), ShStatus::Ok);
        assert_eq!(deepest, [0.0, 0.0]);
        assert_eq!(touching, [0, 0]);
        assert_eq!(sh_batch_set_contacts(b.0, null()), ShStatus::Ok);
        assert_eq!(
            sh_batch_contacts(b.0, 0, 2, d, t),
            ShStatus::InvalidContacts
        );
        assert!(message(&b).contains("none set"));
    }
}

/// The ball of radius 5 cm at the origin, answered by a callback.
unsafe extern "C" fn ball(user: *mut c_void, point: *const f64, answer: *mut ShProximity) {
    // SAFETY: the library hands 3 values and an answer; `user` is the radius.
    unsafe {
        let radius = *(user as *const f64);
        let y = Vector3::new(*point, *point.add(1), *point.add(2));
        let p = Sphere {
            center: Vector3::zeros(),
            radius,
        }
        .query(&y);
        (*answer).distance = p.distance;
        (*answer).normal = [p.normal.x, p.normal.y, p.normal.z];
    }
}

/// Strands dropped across a ball: the ball as a callback steps them as the analytic
/// ball does, to 1e-10 of the length (the library normalises a callback's normal again:
/// an ulp apart, grown through the contacts' onsets to 2.2e-13 m, 1.1e-12 L, measured);
/// they end on the ball, not through it.
#[test]
fn a_callback_ball_steps_the_strands_as_the_analytic_ball() {
    let mut radius = 0.05f64;
    let analytic = batch(3);
    let called = batch(3);
    assert_eq!(
        set(&analytic, &[sphere(radius, SH_MOUNT_HEAD)]),
        ShStatus::Ok
    );
    let cb = ShCollider {
        kind: SH_COLLIDER_CALLBACK,
        mount: SH_MOUNT_HEAD,
        shape: ShShape {
            callback: ShCallbackCollider {
                query: Some(ball),
                user_data: (&mut radius as *mut f64).cast(),
                moves: 0,
            },
        },
    };
    assert_eq!(set(&called, &[cb]), ShStatus::Ok);
    for _ in 0..30 {
        assert_eq!(step(&analytic), ShStatus::Ok);
        assert_eq!(step(&called), ShStatus::Ok);
    }
    for i in 0..3 {
        let (a, c) = (centreline(&analytic, i), centreline(&called, i));
        let d = a
            .iter()
            .zip(&c)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(d <= 1e-10 * 0.2, "strand {i}: {d:e} m apart");
    }
    let mut deepest = [f64::NAN; 3];
    // SAFETY: live batch, room for 3 values.
    let s = unsafe { sh_batch_contacts(called.0, 0, 3, deepest.as_mut_ptr(), null_mut()) };
    assert_eq!(s, ShStatus::Ok);
    assert!(
        deepest.iter().all(|&d| (0.0..=5e-4).contains(&d)),
        "{deepest:?}"
    );
    // the strands lie on the ball: the first element's end (x ≈ 0.01 m) on its top,
    // within two contact radii of its surface (a strand that fell through ends 5 cm away)
    for i in 0..3 {
        let y = &centreline(&called, i)[3..6];
        let gap = (y[0] * y[0] + y[1] * y[1] + y[2] * y[2]).sqrt() - radius;
        assert!(
            (-5e-4..=2e-3).contains(&gap),
            "strand {i}: {gap} m from the ball"
        );
    }
}

/// A floor at z = 0 under the strands' whole length, answered by a callback whose
/// surface moves along +y at 0.2 m/s (a conveyor belt): with friction the strands lying
/// on it are carried along +y; the same floor at rest leaves them where they fell (a
/// test that would pass without the surface velocity fails).
#[test]
fn a_callback_surface_velocity_drags_the_strands_lying_on_it() {
    unsafe extern "C" fn belt(user: *mut c_void, point: *const f64, answer: *mut ShProximity) {
        // SAFETY: the library hands 3 values and an answer; `user` is the belt's speed.
        unsafe {
            (*answer).distance = *point.add(2);
            (*answer).normal = [0.0, 0.0, 1.0];
            (*answer).velocity = [0.0, *(user as *const f64), 0.0];
        }
    }
    let run = |mut speed: f64| {
        let b = batch(1);
        let floor = ShCollider {
            kind: SH_COLLIDER_CALLBACK,
            mount: SH_MOUNT_WORLD,
            shape: ShShape {
                callback: ShCallbackCollider {
                    query: Some(belt),
                    user_data: (&mut speed as *mut f64).cast(),
                    moves: 1,
                },
            },
        };
        assert_eq!(set(&b, &[floor]), ShStatus::Ok);
        for _ in 0..30 {
            assert_eq!(step(&b), ShStatus::Ok);
        }
        centreline(&b, 0)[3 * N + 1]
    };
    let (still, carried) = (run(0.0), run(0.2));
    assert!(
        carried - still > 0.01,
        "tip at y = {carried} m on the belt, {still} m at rest"
    );
}

fn workspace() -> *mut ShWorkspace {
    let mut w = null_mut();
    // SAFETY: valid out pointer.
    assert_eq!(unsafe { sh_workspace_new(N, &mut w) }, ShStatus::Ok);
    w
}

/// The batch pointer, shared by threads that step disjoint ranges.
#[derive(Clone, Copy)]
struct Shared(*const ShBatch);
// SAFETY: the threads step disjoint ranges, each with its own workspace, nothing else
// meanwhile (sh_batch_step_range's contract).
unsafe impl Send for Shared {}

/// Two threads stepping halves of a batch with contacts, each on its workspace, give the
/// bits of the whole batch's step; after the first step (each workspace's scratch
/// sized) neither a range's step nor the batch's allocates.
#[test]
fn ranges_with_contacts_from_threads_equal_the_batch_step_and_allocate_nothing() {
    let whole = batch(4);
    let split = batch(4);
    for b in [&whole, &split] {
        assert_eq!(
            set(
                b,
                &[sphere(0.05, SH_MOUNT_HEAD), sphere(0.02, SH_MOUNT_POSE)]
            ),
            ShStatus::Ok
        );
    }
    let workspaces = [workspace(), workspace()].map(|w| w as usize);
    for k in 0..24 {
        // a small ball sweeping under the strands, on its own pose
        let at = |k: usize| ShPose {
            position: [-0.08 + 0.005 * k as f64, 0.0, 0.07],
            rotation: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        };
        for b in [&whole, &split] {
            // SAFETY: live batch, valid poses.
            let s = unsafe { sh_batch_set_collider_pose(b.0, 1, &at(k), &at(k + 1)) };
            assert_eq!(s, ShStatus::Ok);
        }
        let before = ALLOCATIONS.with(Cell::get);
        assert_eq!(step(&whole), ShStatus::Ok);
        let during = ALLOCATIONS.with(Cell::get) - before;
        if k > 0 {
            assert_eq!(during, 0, "step {k} allocated");
        }
        let shared = Shared(split.0);
        std::thread::scope(|scope| {
            for (t, &w) in workspaces.iter().enumerate() {
                scope.spawn(move || {
                    let shared = shared;
                    let before = ALLOCATIONS.with(Cell::get);
                    // SAFETY: disjoint ranges, one workspace per thread.
                    let s = unsafe {
                        sh_batch_step_range(
                            shared.0,
                            2 * t,
                            2,
                            w as *mut ShWorkspace,
                            1.0 / 60.0,
                            null_mut(),
                            null_mut(),
                        )
                    };
                    assert_eq!(s, ShStatus::Ok);
                    let during = ALLOCATIONS.with(Cell::get) - before;
                    assert!(
                        k == 0 || during == 0,
                        "range {t}, step {k}: {during} allocations"
                    );
                });
            }
        });
    }
    for i in 0..4 {
        assert_eq!(centreline(&whole, i), centreline(&split, i), "strand {i}");
    }
    for w in workspaces {
        // SAFETY: from sh_workspace_new, freed once.
        unsafe { sh_workspace_free(w as *mut ShWorkspace) };
    }
}

/// A state set from outside restarts the strand's contacts: a strand set back to its
/// start after falling onto the ball then steps as a new batch's strand (its anchors,
/// allowances and root zone made afresh), to round-off: its clock goes on (20/60 s
/// ahead), so its steps' lengths `(t + h) − t` differ from h by an ulp of t (measured:
/// 1.3e-11 m after 20 steps, with the contacts' onsets in between).
#[test]
fn a_state_set_from_outside_restarts_the_contacts() {
    let b = batch(1);
    let fresh = batch(1);
    let mut c = defaults();
    c.friction = SH_FRICTION_COULOMB;
    for x in [&b, &fresh] {
        // SAFETY: live batch, valid params.
        assert_eq!(unsafe { sh_batch_set_contacts(x.0, &c) }, ShStatus::Ok);
        assert_eq!(set(x, &[sphere(0.05, SH_MOUNT_HEAD)]), ShStatus::Ok);
    }
    let mut q0 = [0.0; 3 * N];
    // SAFETY: live batch, room for 3N values.
    unsafe {
        sh_batch_state(b.0, 0, q0.as_mut_ptr(), null_mut(), 3 * N, null_mut());
    }
    for _ in 0..20 {
        assert_eq!(step(&b), ShStatus::Ok);
    }
    // SAFETY: live batch, 3N values; q̇ = 0.
    assert_eq!(
        unsafe { sh_batch_set_state(b.0, 0, q0.as_ptr(), null(), 3 * N) },
        ShStatus::Ok
    );
    for _ in 0..20 {
        assert_eq!(step(&b), ShStatus::Ok);
        assert_eq!(step(&fresh), ShStatus::Ok);
    }
    let (a, f) = (centreline(&b, 0), centreline(&fresh, 0));
    let d = a
        .iter()
        .zip(&f)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(d <= 1e-9 * 0.2, "{d:e} m apart");
}
