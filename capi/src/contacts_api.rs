//! The C functions of a batch's contacts with colliders: the contact law
//! ([`sh_batch_set_contacts`]), the colliders ([`sh_batch_set_colliders`]), the poses of
//! those on a pose of their own ([`sh_batch_set_collider_pose`]) and what the strands
//! found ([`sh_batch_contacts`]). Each checks its arguments and turns the batch's Rust
//! form to what they say; the step itself is the batch's (`batch.rs`).

use crate::colliders::{self, Carrier, ShCollider, ShPose, SH_MAX_COLLIDERS};
use crate::contacts::{ContactSettings, ShContactParams, DEFAULT_PARAMS};
use crate::{with_batch, Failure, ShBatch, ShStatus};
use superhelix_kernels::collider::PoseOverStep;

/// Fills `*params` with the defaults of a scene's `[contacts]` table: radius 1 mm, the
/// default stiffness (0: 10⁴ ρS g₀ / r), damping ratio 0.5, viscous friction μ = 0.3 at
/// a slip speed of 0.05 m/s, anisotropy 0.3, 4 contact points per element and one at
/// the tip, predicted contacts, depths (maximum and split) of the radius, a
/// depenetration speed of 0.05 m/s.
///
/// # Safety
/// `params` is NULL or valid for writing one [`ShContactParams`].
#[no_mangle]
pub unsafe extern "C" fn sh_contact_params_default(params: *mut ShContactParams) -> ShStatus {
    if params.is_null() {
        return ShStatus::NullPointer;
    }
    // SAFETY: checked non-NULL; valid for one write (caller).
    unsafe { params.write(DEFAULT_PARAMS) };
    ShStatus::Ok
}

/// Sets the contacts of the batch's strands with its colliders
/// ([`sh_batch_set_colliders`]) for the next steps; NULL: no contacts (the state a batch
/// starts in). Every strand then keeps its contact points (`samples_per_element` per
/// element, one at the tip with `tip_sample`), per point its Coulomb anchor and its
/// allowance (a depth it started with, let out at the depenetration speed), and its own
/// clock; each workspace keeps the contacts' scratch (sized at its first step with
/// contacts, then reused: the steps allocate nothing). The contacts start afresh at each
/// strand's next step (its root zone, allowances and anchors from its state then).
///
/// With contacts a step is the checked step with them (`fixed::step_with_contacts`, as
/// the runtime's embedded engine steps a scene with bodies): the penalty, friction and
/// damping of the points within `radius` of a collider in every solve, their energy in
/// the balance, a step split when a point goes deeper than `split_depth`; with a
/// tolerance ([`crate::sh_batch_set_tolerance`]) the error-controlled step with them.
/// Contacts need the checked step: `SH_STATUS_INVALID_CONTACTS` after
/// `sh_batch_set_checked(batch, 0)`, and that call refuses while contacts are set. A value
/// out of range is `SH_STATUS_INVALID_CONTACTS` (the last error names the field and its
/// range) and changes nothing.
///
/// # Safety
/// `batch` is NULL or a live pointer from `sh_batch_new` used by no other thread during
/// the call; `params` is NULL or valid for reading one [`ShContactParams`].
#[no_mangle]
pub unsafe extern "C" fn sh_batch_set_contacts(
    batch: *mut ShBatch,
    params: *const ShContactParams,
) -> ShStatus {
    let f = |b: &mut ShBatch| {
        if params.is_null() {
            b.strands
                .set_contacts(None)
                .map_err(|_| Failure::plain(ShStatus::OutOfMemory))?;
            b.contacts = None;
            return Ok(());
        }
        // SAFETY: checked non-NULL; valid for reading one value (caller).
        let p = unsafe { params.read() };
        let settings = ContactSettings::new(&p)
            .map_err(|m| Failure::new(ShStatus::InvalidContacts, None, &m))?;
        if !b.settings.checked {
            return Err(Failure::new(
                ShStatus::InvalidContacts,
                None,
                "contacts: the plain step takes no contacts (sh_batch_set_checked(batch, 1) first)",
            ));
        }
        b.strands
            .set_contacts(Some(&settings))
            .map_err(|_| Failure::plain(ShStatus::OutOfMemory))?;
        b.contacts = Some(settings);
        Ok(())
    };
    // SAFETY: `batch` is NULL or live and used by this thread alone (caller).
    unsafe { with_batch(batch, f) }
}

/// Sets the colliders the batch's strands touch (once contacts are set): `count`
/// descriptions from `colliders` (NULL when `count` is 0: none), copied. Collider `i`
/// keeps index `i` for [`sh_batch_set_collider_pose`]. A grid's values and a callback's
/// user data are not copied: they stay the caller's (see `ShGrid`, `ShCallbackCollider`).
/// A collider mounted with `SH_MOUNT_POSE` stands at the identity pose at the origin until
/// its pose is set. The strands' anchors refer to colliders by index: they let go of a
/// collider whose index is taken by another (the contacts start afresh at each strand's
/// next step).
///
/// A description out of range is `SH_STATUS_INVALID_COLLIDER` (the last error names it,
/// e.g. `colliders[2].shape.sphere.radius: -1 must be in (0, 1000] m`), more than
/// `SH_MAX_COLLIDERS` is `SH_STATUS_INVALID_COUNT`; either changes nothing.
///
/// # Safety
/// `batch` is NULL or a live pointer from `sh_batch_new` used by no other thread during
/// the call; `colliders` is valid for reading `count` values (or `count` is 0); each
/// grid's values are valid for reading its nodes for as long as the batch may step with
/// them, and each callback may be called with its user data from any thread that steps
/// the batch.
#[no_mangle]
pub unsafe extern "C" fn sh_batch_set_colliders(
    batch: *mut ShBatch,
    colliders: *const ShCollider,
    count: usize,
) -> ShStatus {
    let f = |b: &mut ShBatch| {
        if count > SH_MAX_COLLIDERS {
            return Err(Failure::new(
                ShStatus::InvalidCount,
                None,
                &format!("count: {count} must be in 0..={SH_MAX_COLLIDERS}"),
            ));
        }
        if colliders.is_null() && count > 0 {
            return Err(Failure::plain(ShStatus::NullPointer));
        }
        let given = if count == 0 {
            &[][..]
        } else {
            // SAFETY: non-NULL and valid for reading `count` values (caller).
            unsafe { core::slice::from_raw_parts(colliders, count) }
        };
        let mut items = Vec::new();
        items
            .try_reserve_exact(count)
            .map_err(|_| Failure::plain(ShStatus::OutOfMemory))?;
        for (i, c) in given.iter().enumerate() {
            // SAFETY: grids and callbacks as the caller guarantees (above).
            let item = unsafe { colliders::collider(c, &format!("colliders[{i}]")) }
                .map_err(|m| Failure::new(ShStatus::InvalidCollider, None, &m))?;
            items.push(item);
        }
        b.colliders.items = items;
        // anchors name colliders by index: start the contacts afresh
        if let Some(settings) = b.contacts {
            b.strands
                .set_contacts(Some(&settings))
                .map_err(|_| Failure::plain(ShStatus::OutOfMemory))?;
        }
        Ok(())
    };
    // SAFETY: `batch` is NULL or live and used by this thread alone (caller).
    unsafe { with_batch(batch, f) }
}

/// Sets the poses of collider `index` (mounted with `SH_MOUNT_POSE`) at the start and the
/// end of the next step (world coordinates; `end` NULL: the same as `start`, a collider
/// at rest). Over the step the collider moves uniformly from one to the other and turns
/// at a constant rate about one axis, the shorter way (`collider::PoseOverStep`), and its
/// velocity enters the contacts' damping and friction. The poses stay until set again:
/// set them before every step of a moving collider (the end of one step is the start of
/// the next). After the step, [`sh_batch_contacts`] measures the strands against the end
/// pose.
///
/// `SH_STATUS_INDEX_OUT_OF_RANGE` for an index beyond the colliders,
/// `SH_STATUS_INVALID_COLLIDER` for a collider not on a pose of its own or a pose that is
/// not finite or not a rotation (within 1e-6); either changes nothing.
///
/// # Safety
/// `batch` is NULL or a live pointer from `sh_batch_new` used by no other thread during
/// the call; `start` is NULL or valid for reading one [`ShPose`], `end` likewise.
#[no_mangle]
pub unsafe extern "C" fn sh_batch_set_collider_pose(
    batch: *mut ShBatch,
    index: usize,
    start: *const ShPose,
    end: *const ShPose,
) -> ShStatus {
    let f = |b: &mut ShBatch| {
        if start.is_null() {
            return Err(Failure::plain(ShStatus::NullPointer));
        }
        let count = b.colliders.items.len();
        let Some(item) = b.colliders.items.get_mut(index) else {
            return Err(Failure::new(
                ShStatus::IndexOutOfRange,
                None,
                &format!("index: {index} must be below the batch's {count} colliders"),
            ));
        };
        if !matches!(item.1, Carrier::Pose(_)) {
            return Err(Failure::new(
                ShStatus::InvalidCollider,
                None,
                &format!("colliders[{index}].mount: not SH_MOUNT_POSE, so it takes no pose"),
            ));
        }
        // SAFETY: checked non-NULL; valid for reading one value (caller).
        let (p0, r0) = colliders::pose(unsafe { &start.read() }, "start")?;
        let (p1, r1) = if end.is_null() {
            (p0, r0)
        } else {
            // SAFETY: non-NULL; valid for reading one value (caller).
            colliders::pose(unsafe { &end.read() }, "end")?
        };
        item.1 = Carrier::Pose(PoseOverStep {
            start_position: p0,
            start_rotation: r0,
            end_position: p1,
            end_rotation: r1,
        });
        Ok(())
    };
    // SAFETY: `batch` is NULL or live and used by this thread alone (caller).
    unsafe { with_batch(batch, f) }
}

impl From<colliders::Refusal> for Failure {
    fn from(message: colliders::Refusal) -> Self {
        Failure::new(ShStatus::InvalidCollider, None, &message)
    }
}

/// What strands `first .. first + count` found at the end of their last step (with
/// contacts set): into `deepest[k]` (may be NULL) the deepest point of strand
/// `first + k`'s centreline inside a collider, m (0: none inside), from a dense sweep
/// along the centreline (a point every 0.5 mm of arc length, the root zone not counted
/// against the collider its strand grows from), and into `touching[k]` (may be NULL) the
/// number of its contact points touching a collider (within the contact radius, beyond
/// their allowance) at the last evaluation of its contact terms. The colliders are taken
/// where the step ended (a collider on a pose of its own at its end pose), the head as
/// last set.
///
/// The sweep queries the colliders (grids, callbacks) on the batch's own workspace, so
/// the call takes the batch mutably; it is not timed in the step.
/// `SH_STATUS_INVALID_CONTACTS` without contacts, `SH_STATUS_INDEX_OUT_OF_RANGE` for a
/// range outside the batch.
///
/// # Safety
/// `batch` is NULL or a live pointer from `sh_batch_new` used by no other thread during
/// the call; `deepest` and `touching` are NULL or valid for writing `count` values each.
#[no_mangle]
pub unsafe extern "C" fn sh_batch_contacts(
    batch: *mut ShBatch,
    first: usize,
    count: usize,
    deepest: *mut f64,
    touching: *mut usize,
) -> ShStatus {
    let f = |b: &mut ShBatch| {
        if !b.strands.has_contacts() {
            return Err(Failure::new(
                ShStatus::InvalidContacts,
                None,
                "contacts: none set (sh_batch_set_contacts)",
            ));
        }
        let len = b.strands.len();
        if first.checked_add(count).is_none_or(|end| end > len) {
            return Err(Failure::new(
                ShStatus::IndexOutOfRange,
                None,
                &format!("range {first} + {count}: outside the batch's {len} strands"),
            ));
        }
        let head = b.settings.input.head;
        for k in 0..count {
            let report =
                b.strands
                    .contact_report(first + k, &b.colliders, &head, &mut b.workspace.contacts);
            let Some((depth, touches)) = report else {
                return Err(Failure::plain(ShStatus::InvalidContacts));
            };
            // SAFETY: each is NULL or valid for writing `count` values (caller); k < count.
            unsafe {
                if !deepest.is_null() {
                    deepest.add(k).write(depth);
                }
                if !touching.is_null() {
                    touching.add(k).write(touches);
                }
            }
        }
        Ok(())
    };
    // SAFETY: `batch` is NULL or live and used by this thread alone (caller).
    unsafe { with_batch(batch, f) }
}
