//! # superhelix-capi
//!
//! The C ABI of the fixed-N Super-Helix strand step (`superhelix_kernels::fixed::step`
//! with the generated closed forms of `superhelix-generated`): what a game engine or a
//! C/C++ program links (static library, shared library) with the header
//! `include/superhelix.h`, generated from this crate by cbindgen.
//!
//! - A **batch** ([`ShBatch`], opaque) holds strands of one number of elements N, each
//!   made from a [`ShStrandParams`] at rest in its natural shape ([`sh_batch_new`]), the
//!   head state and gravity of the next steps ([`sh_batch_set_head`],
//!   [`sh_batch_set_gravity`]) and one workspace: [`sh_batch_step`] steps every strand
//!   with it.
//! - An engine that spreads a batch over its worker threads gives each worker a
//!   [`ShWorkspace`] ([`sh_workspace_new`]) and steps disjoint ranges of strands
//!   concurrently with [`sh_batch_step_range`].
//! - Results: [`sh_batch_centreline`] (world positions of the N + 1 element ends),
//!   [`sh_batch_state`] (q and q̇).
//! - Colliders: [`sh_batch_set_contacts`] (the contact law of a scene's `[contacts]`),
//!   [`sh_batch_set_colliders`] (shapes, grids of signed distances on the caller's
//!   memory, callbacks; each on the head, in the world or on a pose of its own,
//!   [`colliders`]), [`sh_batch_set_collider_pose`] (a moving collider's poses at the
//!   step's two ends) and [`sh_batch_contacts`] (per strand after a step: its deepest
//!   point inside a collider and its contact points touching). A batch with contacts
//!   steps each strand by the checked step with its contacts
//!   (`superhelix_kernels::fixed::step_with_contacts`), as the runtime's embedded engine
//!   steps a scene with bodies ([`contacts`]).
//!
//! Every function returns a [`ShStatus`] (`SH_STATUS_OK` = 0 on success;
//! [`sh_status_message`] names it), checks every pointer for NULL and every count, and
//! never lets a panic cross the boundary (it becomes `SH_STATUS_PANIC`). Errors with
//! details (which strand, which parameter) are kept in a [`ShError`]: an out-parameter
//! of [`sh_batch_new`] and [`sh_batch_step_range`], and the batch's last error
//! ([`sh_batch_last_error`]) for the other batch functions.
//!
//! The step is, by default, the checked fixed-N step (`superhelix_kernels::fixed::step`):
//! the runtime's linearly implicit Euler step with its checks after the fact (energy
//! balance, splitting a step that rotates an element too far), the same values as the
//! runtime's `Simulation` for a strand without point loads. [`sh_batch_set_checked`]
//! switches a batch to the plain step (`fixed::linearly_implicit`), without checks: the
//! caller then keeps the largest element rotation of a step
//! ([`ShStepReport::max_element_rotation`]) below ~0.2 by its choice of dt.
//! `docs/embedding.md` describes the conventions and the thread model.
#![warn(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]

mod batch;
pub mod colliders;
pub mod contacts;
mod contacts_api;
pub mod sizes;

pub use contacts_api::{
    sh_batch_contacts, sh_batch_set_collider_pose, sh_batch_set_colliders, sh_batch_set_contacts,
    sh_contact_params_default,
};

use batch::{BuildError, Group, Workspace};
use core::ffi::{c_char, c_int, CStr};
use core::panic::AssertUnwindSafe;
use nalgebra::{Matrix3, Vector3};
use std::panic::catch_unwind;
use superhelix_kernels::fixed::batch::{BatchOutcome, BatchSettings, BatchStrandSpec};
use superhelix_kernels::fixed::{ParamsError, StepError};
use superhelix_kernels::head::HeadState;
use superhelix_kernels::material::section_terms;

/// Status of a call: `SH_STATUS_OK` (0) on success, else why it failed.
/// [`sh_status_message`] gives each a static message.
#[repr(i32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShStatus {
    /// Success.
    Ok = 0,
    /// A required pointer argument is NULL.
    NullPointer = 1,
    /// A count is zero or too large (strands of a batch, a range of strands).
    InvalidCount = 2,
    /// No generated code for this number of elements N (see [`sh_supported_elements`]).
    UnsupportedElements = 3,
    /// The strands of one batch have different numbers of elements.
    MixedElements = 4,
    /// A strand's element lengths (or total length) are not finite, > 0 and ≤ 100 m.
    InvalidLength = 5,
    /// A strand's root position is not finite.
    InvalidRootPosition = 6,
    /// A strand's root frame is not a rotation (orthonormal columns within 1e-9, det > 0).
    InvalidRootFrame = 7,
    /// A strand's cross-section or material is out of range (radius, ellipticity,
    /// Young's modulus, Poisson ratio, density).
    InvalidCrossSection = 8,
    /// A strand's natural twist or curvature is not finite with |x| ≤ 1e6 rad/m.
    InvalidNatural = 9,
    /// A strand's internal friction is not finite and ≥ 0.
    InvalidInternalFriction = 10,
    /// A strand's air drag is not finite and ≥ 0.
    InvalidAirDrag = 11,
    /// The head state is not finite or its rotation is not a rotation.
    InvalidHead = 12,
    /// Gravity is not finite.
    InvalidGravity = 13,
    /// A strand index (or a range of strands) is outside the batch.
    IndexOutOfRange = 14,
    /// An output buffer is smaller than what the call writes.
    BufferTooSmall = 15,
    /// A workspace made for another number of elements than the batch's.
    WorkspaceMismatch = 16,
    /// The time step is not finite and > 0.
    InvalidTimeStep = 17,
    /// A strand's step matrix is singular; the strand kept its state.
    SingularMatrix = 18,
    /// A strand's step produced a value that is not finite; the strand kept its state.
    NonFinite = 19,
    /// A state given for a strand has a value that is not finite.
    InvalidState = 20,
    /// Memory for a batch could not be had.
    OutOfMemory = 21,
    /// An internal error (a panic, caught at the boundary).
    Panic = 22,
    /// The tolerance of the error-controlled step is neither 0 (fixed steps) nor within
    /// [1e-8, 0.5].
    InvalidTolerance = 23,
    /// A contact parameter is out of range, or contacts were asked with a step that does
    /// not take them (the plain step) or read without them.
    InvalidContacts = 24,
    /// A collider's description is out of range (its kind, mount, shape, grid or pose),
    /// or a pose was given to a collider not on a pose of its own.
    InvalidCollider = 25,
    /// A strand's error-controlled step could not meet its tolerance even at its shortest
    /// step (its estimate does not shrink with the step); the strand stopped there.
    ToleranceUnmet = 26,
}

/// Every status, in the order of its value (`ALL_STATUSES[s as usize] == s`).
const ALL_STATUSES: [ShStatus; 27] = [
    ShStatus::Ok,
    ShStatus::NullPointer,
    ShStatus::InvalidCount,
    ShStatus::UnsupportedElements,
    ShStatus::MixedElements,
    ShStatus::InvalidLength,
    ShStatus::InvalidRootPosition,
    ShStatus::InvalidRootFrame,
    ShStatus::InvalidCrossSection,
    ShStatus::InvalidNatural,
    ShStatus::InvalidInternalFriction,
    ShStatus::InvalidAirDrag,
    ShStatus::InvalidHead,
    ShStatus::InvalidGravity,
    ShStatus::IndexOutOfRange,
    ShStatus::BufferTooSmall,
    ShStatus::WorkspaceMismatch,
    ShStatus::InvalidTimeStep,
    ShStatus::SingularMatrix,
    ShStatus::NonFinite,
    ShStatus::InvalidState,
    ShStatus::OutOfMemory,
    ShStatus::Panic,
    ShStatus::InvalidTolerance,
    ShStatus::InvalidContacts,
    ShStatus::InvalidCollider,
    ShStatus::ToleranceUnmet,
];

impl ShStatus {
    /// The status with this value, if any.
    pub fn from_code(code: c_int) -> Option<ShStatus> {
        usize::try_from(code)
            .ok()
            .and_then(|i| ALL_STATUSES.get(i).copied())
    }

    /// The static message of this status.
    pub fn message(self) -> &'static CStr {
        match self {
            ShStatus::Ok => c"ok",
            ShStatus::NullPointer => c"a required pointer argument is NULL",
            ShStatus::InvalidCount => c"a count is zero or too large",
            ShStatus::UnsupportedElements => {
                c"no generated code for this number of elements (see sh_supported_elements)"
            }
            ShStatus::MixedElements => {
                c"the strands of one batch must have the same number of elements"
            }
            ShStatus::InvalidLength => {
                c"element lengths (or the total length) must be finite, > 0 and <= 100 m"
            }
            ShStatus::InvalidRootPosition => c"the root position must be finite",
            ShStatus::InvalidRootFrame => {
                c"the root frame must be a rotation (orthonormal columns n0, n1, n2 within 1e-9, det > 0)"
            }
            ShStatus::InvalidCrossSection => {
                c"cross-section out of range (radius > 0, ellipticity >= 1, Young's modulus > 0, Poisson ratio in (-1, 0.5], density > 0, all finite)"
            }
            ShStatus::InvalidNatural => {
                c"natural twist and curvatures must be finite with |x| <= 1e6 rad/m"
            }
            ShStatus::InvalidInternalFriction => c"internal friction must be finite and >= 0",
            ShStatus::InvalidAirDrag => c"air drag must be finite and >= 0",
            ShStatus::InvalidHead => {
                c"the head state must be finite and its rotation a rotation (orthonormal within 1e-6, det > 0)"
            }
            ShStatus::InvalidGravity => c"gravity must be finite",
            ShStatus::IndexOutOfRange => c"strand index or range outside the batch",
            ShStatus::BufferTooSmall => c"output buffer too small",
            ShStatus::WorkspaceMismatch => {
                c"the workspace was made for another number of elements than the batch's"
            }
            ShStatus::InvalidTimeStep => c"the time step must be finite and > 0",
            ShStatus::SingularMatrix => {
                c"singular step matrix (the strand kept its state)"
            }
            ShStatus::NonFinite => {
                c"the step produced a non-finite value (the strand kept its state)"
            }
            ShStatus::InvalidState => c"a state value is not finite",
            ShStatus::OutOfMemory => c"out of memory",
            ShStatus::Panic => c"internal error (a panic was caught at the C boundary)",
            ShStatus::InvalidTolerance => {
                c"the tolerance must be 0 (fixed steps) or within [1e-8, 0.5]"
            }
            ShStatus::InvalidContacts => {
                c"contact parameter out of range, or contacts with a step that does not take them"
            }
            ShStatus::InvalidCollider => {
                c"collider description out of range (kind, mount, shape, grid or pose)"
            }
            ShStatus::ToleranceUnmet => {
                c"the error-controlled step could not meet its tolerance at its shortest step"
            }
        }
    }
}

impl From<StepError> for ShStatus {
    fn from(e: StepError) -> Self {
        match e {
            StepError::SingularMatrix => ShStatus::SingularMatrix,
            StepError::NonFinite { .. } => ShStatus::NonFinite,
            StepError::TimeStep => ShStatus::InvalidTimeStep,
            StepError::Tolerance => ShStatus::InvalidTolerance,
            // (the batch sizes its workspaces for its strands: not reached)
            StepError::Sizes => ShStatus::MixedElements,
            // (only point loads stop a step so, and the batch's strands carry none: not
            // reached; an internal error if it were)
            StepError::UnresolvedMotion { .. } => ShStatus::Panic,
            // (the batch's strands have free tips: not reached)
            StepError::Held(_) => ShStatus::Panic,
            StepError::ToleranceUnmet { .. } => ShStatus::ToleranceUnmet,
        }
    }
}

impl From<ParamsError> for ShStatus {
    fn from(e: ParamsError) -> Self {
        match e.field {
            "elements" => ShStatus::UnsupportedElements,
            "root_position" => ShStatus::InvalidRootPosition,
            "root_frame" => ShStatus::InvalidRootFrame,
            "lengths" => ShStatus::InvalidLength,
            "natural" => ShStatus::InvalidNatural,
            "internal_friction" => ShStatus::InvalidInternalFriction,
            "air_drag" => ShStatus::InvalidAirDrag,
            // mass_per_length, stiffness, rotary_inertia: terms of the cross-section
            _ => ShStatus::InvalidCrossSection,
        }
    }
}

/// Bytes of [`ShError::message`], its terminating NUL included.
pub const SH_ERROR_MESSAGE_BYTES: usize = 256;

/// The details of a failure: its status, the strand it concerns and a message.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct ShError {
    /// The status (`SH_STATUS_OK` when there was no failure).
    pub status: ShStatus,
    /// Index of the strand the failure concerns, or `SIZE_MAX` when it concerns none.
    pub strand: usize,
    /// What failed, UTF-8, NUL-terminated (e.g. `strand 2: lengths: must be finite, >
    /// 0 and ≤ 100 m`); empty on success.
    pub message: [c_char; SH_ERROR_MESSAGE_BYTES],
}

impl ShError {
    /// No failure.
    pub(crate) const NONE: ShError = ShError {
        status: ShStatus::Ok,
        strand: usize::MAX,
        message: [0; SH_ERROR_MESSAGE_BYTES],
    };

    fn new(status: ShStatus, strand: Option<usize>, message: &str) -> ShError {
        let mut e = ShError {
            status,
            strand: strand.unwrap_or(usize::MAX),
            ..ShError::NONE
        };
        // truncate at a character boundary, keeping room for the NUL
        let mut end = message.len().min(SH_ERROR_MESSAGE_BYTES - 1);
        while !message.is_char_boundary(end) {
            end -= 1;
        }
        for (m, &b) in e.message.iter_mut().zip(&message.as_bytes()[..end]) {
            *m = b as c_char;
        }
        e
    }

    /// The message as a string (up to its NUL).
    pub fn message_str(&self) -> &str {
        let bytes: &[u8] = {
            let m = &self.message;
            // SAFETY: c_char and u8 have the same size and alignment; the slice covers
            // exactly the array.
            unsafe { core::slice::from_raw_parts(m.as_ptr().cast::<u8>(), m.len()) }
        };
        let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
        core::str::from_utf8(&bytes[..end]).unwrap_or("")
    }
}

impl core::fmt::Debug for ShError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ShError")
            .field("status", &self.status)
            .field("strand", &self.strand)
            .field("message", &self.message_str())
            .finish()
    }
}

/// A failure inside the library, made into a [`ShError`] at the boundary.
#[derive(Debug)]
struct Failure {
    status: ShStatus,
    strand: Option<usize>,
    message: String,
}

impl Failure {
    fn new(status: ShStatus, strand: Option<usize>, message: &str) -> Failure {
        Failure {
            status,
            strand,
            message: message.to_string(),
        }
    }

    /// A failure with the status's own message.
    fn plain(status: ShStatus) -> Failure {
        Failure::new(status, None, status.message().to_str().unwrap_or(""))
    }

    fn to_error(&self) -> ShError {
        ShError::new(self.status, self.strand, &self.message)
    }
}

/// Cross-section and material of a fibre, SI units (an elliptic section of mean radius
/// r and ellipticity e: semi-axes r√e along n1 and r/√e along n2).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShCrossSection {
    /// Mean radius r, metres (> 0).
    pub radius: f64,
    /// Ellipticity e = r_max / r_min (≥ 1).
    pub ellipticity: f64,
    /// Young's modulus E, pascals (> 0).
    pub youngs_modulus: f64,
    /// Poisson ratio, in (−1, 0.5].
    pub poisson_ratio: f64,
    /// Density ρ, kg/m³ (> 0).
    pub density: f64,
}

/// The parameters of one strand. The root position and frame are in head coordinates.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct ShStrandParams {
    /// Number of elements N (one of [`sh_supported_elements`]).
    pub elements: usize,
    /// Total length L, metres, split into N equal elements; read only when
    /// `element_lengths` is NULL.
    pub length: f64,
    /// N element lengths, metres (root first), or NULL for `length` / N each.
    pub element_lengths: *const f64,
    /// Root position r_0, head coordinates, metres.
    pub root_position: [f64; 3],
    /// Root frame F_0, head coordinates, column-major: n0 (the tangent), n1, n2; a
    /// rotation within 1e-9.
    pub root_frame: [f64; 9],
    /// Cross-section and material.
    pub cross_section: ShCrossSection,
    /// Natural (τ, κ1, κ2) of every element, rad/m (twist first); read only when
    /// `natural_per_element` is NULL.
    pub natural: [f64; 3],
    /// 3N values (τ, κ1, κ2 of each element, root first), or NULL for `natural` on
    /// every element.
    pub natural_per_element: *const f64,
    /// Internal friction γ, kg·m³/s (≥ 0).
    pub internal_friction: f64,
    /// Air drag ν, kg/(m·s) (≥ 0).
    pub air_drag: f64,
}

/// The head's state at the end of the next step(s). The head frame maps head
/// coordinates y to world coordinates X + R y.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShHeadState {
    /// X: world position of the head origin, metres.
    pub position: [f64; 3],
    /// R: head to world rotation, column-major (within 1e-6 of a rotation).
    pub rotation: [f64; 9],
    /// Ẋ, world coordinates, m/s (read only when `moves` is nonzero).
    pub velocity: [f64; 3],
    /// Ẍ, world coordinates, m/s² (read only when `moves` is nonzero).
    pub acceleration: [f64; 3],
    /// ω, head coordinates, rad/s (`Ṙ = R [ω]×`; read only when `moves` is nonzero).
    pub angular_velocity: [f64; 3],
    /// dω/dt, head coordinates, rad/s² (read only when `moves` is nonzero).
    pub angular_acceleration: [f64; 3],
    /// Nonzero: the head moves, and the fictitious forces of its motion (from the four
    /// derivatives above) act on the strands; zero: a still head.
    pub moves: c_int,
}

/// What a step of several strands found.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShStepReport {
    /// Number of strands stepped (those whose step failed included).
    pub stepped: usize,
    /// Number of strands whose step failed (each kept its state).
    pub failed: usize,
    /// Index of the first strand whose step failed, or `SIZE_MAX`.
    pub first_failed: usize,
    /// Largest rotation a step put into one element over the strands stepped, radians
    /// (`l_Q |Δd_Q|` between the start and the end of the step). The checked step splits
    /// a step whose rotation exceeds 0.2; with the plain step, keep it below ~0.2 by the
    /// choice of dt.
    pub max_element_rotation: f64,
    /// Checked step: steps split into halves (each split counts once), summed over the
    /// strands.
    pub substeps: usize,
    /// Checked step: steps split because they created energy.
    pub energy_rejected: usize,
    /// Checked step: steps whose excess energy was removed from the velocities.
    pub energy_limited: usize,
    /// Checked step: deepest substeps accepted although their energy exceeded the bound.
    pub energy_unbalanced: usize,
    /// Error-controlled step ([`sh_batch_set_tolerance`]): steps accepted, summed over the
    /// strands (0 with fixed steps).
    pub steps: usize,
    /// Error-controlled step: steps rejected (their estimated error above the tolerance)
    /// and retried shorter, summed over the strands.
    pub rejected: usize,
    /// Error-controlled step: the largest estimated local error of an accepted step,
    /// relative to its strand's length.
    pub largest_error: f64,
    /// Error-controlled step: the smallest step any strand took, s (0: none).
    pub smallest_step: f64,
    /// Error-controlled step: the largest step any strand took, s.
    pub largest_step: f64,
}

impl ShStepReport {
    /// Nothing stepped.
    pub(crate) const NONE: ShStepReport = ShStepReport {
        stepped: 0,
        failed: 0,
        first_failed: usize::MAX,
        max_element_rotation: 0.0,
        substeps: 0,
        energy_rejected: 0,
        energy_limited: 0,
        energy_unbalanced: 0,
        steps: 0,
        rejected: 0,
        largest_error: 0.0,
        smallest_step: 0.0,
        largest_step: 0.0,
    };
}

/// A batch of strands with the same number of elements, their head state and gravity,
/// and one workspace (opaque).
pub struct ShBatch {
    strands: Box<dyn Group>,
    workspace: Workspace,
    settings: BatchSettings,
    last_error: ShError,
    last_step: ShStepReport,
    /// The contact law (`None`: no contacts).
    contacts: Option<contacts::ContactSettings>,
    /// The colliders the strands touch when contacts are set.
    colliders: colliders::Colliders,
}

impl ShBatch {
    /// The colliders a step hands the strands: those of the batch when contacts are set.
    fn step_colliders(&self) -> Option<&colliders::Colliders> {
        self.contacts.is_some().then_some(&self.colliders)
    }
}

/// The scratch of one step at one number of elements, for one thread (opaque).
pub struct ShWorkspace {
    inner: Workspace,
}

/// Runs `f`, turning a panic into [`ShStatus::Panic`].
fn guard(f: impl FnOnce() -> ShStatus) -> ShStatus {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or(ShStatus::Panic)
}

/// Writes `value` to `out` when it is not NULL.
///
/// # Safety
/// `out` is NULL or valid for writing one `T`.
unsafe fn write_opt<T>(out: *mut T, value: T) {
    if !out.is_null() {
        // SAFETY: non-NULL and, by the caller, valid for writing one T.
        unsafe { out.write(value) };
    }
}

/// The static message of a status value (any `int`: an unknown value gives
/// "unknown status"). Never NULL; UTF-8 (ASCII), NUL-terminated, valid for the life of
/// the program.
#[no_mangle]
pub extern "C" fn sh_status_message(status: c_int) -> *const c_char {
    match ShStatus::from_code(status) {
        Some(s) => s.message().as_ptr(),
        None => c"unknown status".as_ptr(),
    }
}

/// The numbers of elements N with generated code, in increasing order: writes up to
/// `capacity` of them to `out` (which may be NULL when `capacity` is 0) and their
/// total number to `*count`.
///
/// # Safety
/// `out` is valid for writing `capacity` values (or `capacity` is 0); `count` is valid
/// for writing one.
#[no_mangle]
pub unsafe extern "C" fn sh_supported_elements(
    out: *mut usize,
    capacity: usize,
    count: *mut usize,
) -> ShStatus {
    guard(|| {
        if count.is_null() || (out.is_null() && capacity > 0) {
            return ShStatus::NullPointer;
        }
        let sizes = sizes::SIZES;
        for (i, &n) in sizes.iter().take(capacity).enumerate() {
            // SAFETY: i < capacity, and `out` is valid for `capacity` values.
            unsafe { out.add(i).write(n) };
        }
        // SAFETY: checked non-NULL; valid for one write by the caller.
        unsafe { count.write(sizes.len()) };
        if capacity < sizes.len() {
            ShStatus::BufferTooSmall
        } else {
            ShStatus::Ok
        }
    })
}

/// Bytes one strand of N elements keeps (its parameters, state and kept eigenbasis).
///
/// # Safety
/// `bytes` is valid for writing one value.
#[no_mangle]
pub unsafe extern "C" fn sh_strand_bytes(elements: usize, bytes: *mut usize) -> ShStatus {
    guard(|| {
        if bytes.is_null() {
            return ShStatus::NullPointer;
        }
        match batch::bytes(elements) {
            Some((s, _)) => {
                // SAFETY: checked non-NULL; valid for one write by the caller.
                unsafe { bytes.write(s) };
                ShStatus::Ok
            }
            None => ShStatus::UnsupportedElements,
        }
    })
}

/// Bytes of one workspace for N elements (the scratch of a step: one per batch, and
/// one per thread that steps a range of a batch).
///
/// # Safety
/// `bytes` is valid for writing one value.
#[no_mangle]
pub unsafe extern "C" fn sh_workspace_bytes(elements: usize, bytes: *mut usize) -> ShStatus {
    guard(|| {
        if bytes.is_null() {
            return ShStatus::NullPointer;
        }
        match batch::bytes(elements) {
            Some((_, w)) => {
                // SAFETY: checked non-NULL; valid for one write by the caller.
                unsafe { bytes.write(w) };
                ShStatus::Ok
            }
            None => ShStatus::UnsupportedElements,
        }
    })
}

/// Largest number of strands in one batch.
pub const SH_MAX_STRANDS: usize = 1_073_741_824;

/// The cross-section's values checked, naming the first out of range.
fn check_cross_section(c: &ShCrossSection) -> Result<(), &'static str> {
    let positive = |x: f64| x.is_finite() && x > 0.0;
    if !positive(c.radius) {
        return Err("cross_section.radius: must be finite and > 0");
    }
    if !(c.ellipticity.is_finite() && c.ellipticity >= 1.0) {
        return Err("cross_section.ellipticity: must be finite and ≥ 1");
    }
    if !positive(c.youngs_modulus) {
        return Err("cross_section.youngs_modulus: must be finite and > 0");
    }
    if !(c.poisson_ratio > -1.0 && c.poisson_ratio <= 0.5) {
        return Err("cross_section.poisson_ratio: must be in (-1, 0.5]");
    }
    if !positive(c.density) {
        return Err("cross_section.density: must be finite and > 0");
    }
    Ok(())
}

/// The run-time description of strand `i`, its lengths and natural shape copied into
/// `lengths` and `natural`.
///
/// # Safety
/// `p.element_lengths` and `p.natural_per_element` are NULL or valid for reading N and
/// 3N values.
unsafe fn strand_spec<'a>(
    i: usize,
    p: &ShStrandParams,
    lengths: &'a mut Vec<f64>,
    natural: &'a mut Vec<f64>,
) -> Result<BatchStrandSpec<'a>, Failure> {
    let n = p.elements;
    if let Err(m) = check_cross_section(&p.cross_section) {
        return Err(Failure::new(
            ShStatus::InvalidCrossSection,
            Some(i),
            &format!("strand {i}: {m}"),
        ));
    }
    lengths.clear();
    if p.element_lengths.is_null() {
        lengths.resize(n, p.length / n as f64);
    } else {
        // SAFETY: non-NULL, and by the caller valid for reading N values.
        lengths.extend_from_slice(unsafe { core::slice::from_raw_parts(p.element_lengths, n) });
    }
    natural.clear();
    if p.natural_per_element.is_null() {
        for _ in 0..n {
            natural.extend_from_slice(&p.natural);
        }
    } else {
        // SAFETY: non-NULL, and by the caller valid for reading 3N values.
        natural.extend_from_slice(unsafe {
            core::slice::from_raw_parts(p.natural_per_element, 3 * n)
        });
    }
    let c = &p.cross_section;
    let f = &p.root_frame;
    Ok(BatchStrandSpec {
        root_position: p.root_position,
        root_frame: [[f[0], f[1], f[2]], [f[3], f[4], f[5]], [f[6], f[7], f[8]]],
        lengths,
        section: section_terms(
            c.radius,
            c.ellipticity,
            c.youngs_modulus,
            c.poisson_ratio,
            c.density,
        ),
        natural,
        internal_friction: p.internal_friction,
        air_drag: p.air_drag,
    })
}

/// Makes a batch of `count` strands from `params[0..count]`, each at rest in its
/// natural shape (q = q_n, q̇ = 0), with the head at rest at the origin (X = 0, R = I)
/// and no gravity until [`sh_batch_set_head`] and [`sh_batch_set_gravity`] say
/// otherwise.
///
/// All strands of a batch have the same number of elements N (an engine with several
/// N makes one batch per N): `SH_STATUS_MIXED_ELEMENTS` otherwise, and
/// `SH_STATUS_UNSUPPORTED_ELEMENTS` for an N without generated code. A parameter out of
/// range gives its status (`SH_STATUS_INVALID_LENGTH`, …); `error` (may be NULL)
/// receives the details: the strand's index and a message naming the parameter. On
/// failure `*out` is set to NULL.
///
/// # Safety
/// `params` is valid for reading `count` values, and each one's `element_lengths` and
/// `natural_per_element` are NULL or valid for reading N and 3N values; `out` is valid
/// for writing one pointer; `error` is NULL or valid for writing one [`ShError`].
#[no_mangle]
pub unsafe extern "C" fn sh_batch_new(
    params: *const ShStrandParams,
    count: usize,
    out: *mut *mut ShBatch,
    error: *mut ShError,
) -> ShStatus {
    let mut detail = ShError::NONE;
    let status = guard(|| {
        if out.is_null() {
            detail = Failure::plain(ShStatus::NullPointer).to_error();
            return ShStatus::NullPointer;
        }
        // SAFETY: checked non-NULL; valid for one write by the caller.
        unsafe { out.write(core::ptr::null_mut()) };
        // SAFETY: valid for one write by the caller (checked non-NULL inside).
        match unsafe { new_batch(params, count) } {
            Ok(b) => {
                // SAFETY: as above.
                unsafe { out.write(Box::into_raw(b)) };
                ShStatus::Ok
            }
            Err(e) => {
                detail = e.to_error();
                e.status
            }
        }
    });
    if status == ShStatus::Panic {
        detail = Failure::plain(ShStatus::Panic).to_error();
    }
    // SAFETY: NULL or valid for one write, by the caller.
    unsafe { write_opt(error, detail) };
    status
}

/// [`sh_batch_new`]'s work.
///
/// # Safety
/// As [`sh_batch_new`] for `params`.
unsafe fn new_batch(params: *const ShStrandParams, count: usize) -> Result<Box<ShBatch>, Failure> {
    if params.is_null() {
        return Err(Failure::plain(ShStatus::NullPointer));
    }
    if count == 0 || count > SH_MAX_STRANDS {
        return Err(Failure::new(
            ShStatus::InvalidCount,
            None,
            &format!("count: must be in 1..={SH_MAX_STRANDS}, got {count}"),
        ));
    }
    // SAFETY: non-NULL and, by the caller, valid for reading `count` values.
    let params = unsafe { core::slice::from_raw_parts(params, count) };
    let n = params[0].elements;
    if batch::bytes(n).is_none() {
        return Err(Failure::new(
            ShStatus::UnsupportedElements,
            Some(0),
            &format!(
                "strand 0: elements: no generated code for N = {n} (sizes: {:?})",
                sizes::SIZES
            ),
        ));
    }
    if let Some(i) = params.iter().position(|p| p.elements != n) {
        return Err(Failure::new(
            ShStatus::MixedElements,
            Some(i),
            &format!(
                "strand {i}: elements: {} where strand 0 has {n} (one N per batch)",
                params[i].elements
            ),
        ));
    }
    let mut lengths = vec![Vec::new(); count];
    let mut natural = vec![Vec::new(); count];
    let mut specs = Vec::with_capacity(count);
    for ((i, p), (l, k)) in params
        .iter()
        .enumerate()
        .zip(lengths.iter_mut().zip(natural.iter_mut()))
    {
        // SAFETY: the pointers in `p` are NULL or valid for N and 3N values (caller).
        specs.push(unsafe { strand_spec(i, p, l, k) }?);
    }
    let strands = match batch::build(n, &specs) {
        Some(Ok(s)) => s,
        Some(Err(BuildError::Params(i, e))) => {
            return Err(Failure::new(e.into(), Some(i), &format!("strand {i}: {e}")))
        }
        Some(Err(BuildError::OutOfMemory)) => return Err(Failure::plain(ShStatus::OutOfMemory)),
        None => return Err(Failure::plain(ShStatus::UnsupportedElements)),
    };
    let workspace = strands.new_workspace();
    Ok(Box::new(ShBatch {
        strands,
        workspace,
        settings: BatchSettings::initial(),
        last_error: ShError::NONE,
        last_step: ShStepReport::NONE,
        contacts: None,
        colliders: colliders::Colliders::default(),
    }))
}

/// Frees a batch (NULL is allowed and does nothing).
///
/// # Safety
/// `batch` is NULL or a pointer from [`sh_batch_new`] not yet freed; it is not used
/// afterwards.
#[no_mangle]
pub unsafe extern "C" fn sh_batch_free(batch: *mut ShBatch) {
    if !batch.is_null() {
        // SAFETY: from Box::into_raw in sh_batch_new, freed once (caller).
        let b = unsafe { Box::from_raw(batch) };
        // dropping frees plain memory only; a panic cannot happen, but never unwind out
        let _ = catch_unwind(AssertUnwindSafe(move || drop(b)));
    }
}

/// Runs `f` on the batch behind `batch`, recording a failure as its last error (a
/// success clears it).
///
/// # Safety
/// `batch` is NULL or a live pointer from [`sh_batch_new`] used by no other thread
/// during the call.
unsafe fn with_batch(
    batch: *mut ShBatch,
    f: impl FnOnce(&mut ShBatch) -> Result<(), Failure>,
) -> ShStatus {
    if batch.is_null() {
        return ShStatus::NullPointer;
    }
    // SAFETY: non-NULL, live and not shared during the call (caller).
    let b = unsafe { &mut *batch };
    // (nothing allocated on the way of a success: the step's path allocates nothing)
    let mut result = None;
    let status = guard(|| {
        let r = f(b);
        let status = match &r {
            Ok(()) => ShStatus::Ok,
            Err(e) => e.status,
        };
        result = Some(r);
        status
    });
    b.last_error = match result {
        Some(Ok(())) if status == ShStatus::Ok => ShError::NONE,
        Some(Err(e)) => e.to_error(),
        _ => Failure::plain(status).to_error(),
    };
    status
}

/// Reads the batch behind `batch` (a failure is not recorded: the batch is read-only
/// here).
///
/// # Safety
/// `batch` is NULL or a live pointer from [`sh_batch_new`] that no thread modifies
/// during the call.
unsafe fn read_batch(batch: *const ShBatch, f: impl FnOnce(&ShBatch) -> ShStatus) -> ShStatus {
    if batch.is_null() {
        return ShStatus::NullPointer;
    }
    // SAFETY: non-NULL, live and not modified during the call (caller).
    let b = unsafe { &*batch };
    guard(|| f(b))
}

/// The error of the last call on `batch` that failed since the last one that succeeded
/// (status `SH_STATUS_OK` and an empty message when the last call succeeded). The
/// read-only functions (`sh_batch_centreline`, `sh_batch_state`, …) leave it as it was.
///
/// # Safety
/// `batch` is NULL or a live pointer from [`sh_batch_new`]; `error` is valid for writing
/// one [`ShError`].
#[no_mangle]
pub unsafe extern "C" fn sh_batch_last_error(
    batch: *const ShBatch,
    error: *mut ShError,
) -> ShStatus {
    if error.is_null() {
        return ShStatus::NullPointer;
    }
    let f = |b: &ShBatch| {
        // SAFETY: checked non-NULL; valid for one write (caller).
        unsafe { error.write(b.last_error) };
        ShStatus::Ok
    };
    // SAFETY: `batch` is NULL or live and not modified meanwhile (caller).
    unsafe { read_batch(batch, f) }
}

/// Number of strands and number of elements N of each.
///
/// # Safety
/// `batch` is NULL or a live pointer from [`sh_batch_new`]; `count` and `elements` are
/// NULL or valid for writing one value each.
#[no_mangle]
pub unsafe extern "C" fn sh_batch_size(
    batch: *const ShBatch,
    count: *mut usize,
    elements: *mut usize,
) -> ShStatus {
    let f = |b: &ShBatch| {
        // SAFETY: NULL or valid for one write each (caller).
        unsafe {
            write_opt(count, b.strands.len());
            write_opt(elements, b.strands.elements());
        }
        ShStatus::Ok
    };
    // SAFETY: `batch` is NULL or live and not modified meanwhile (caller).
    unsafe { read_batch(batch, f) }
}

/// Bytes the batch's strands keep: per strand ([`sh_strand_bytes`] at its N) and for
/// the batch as a whole (its strands, its workspace and its own fields).
///
/// # Safety
/// `batch` is NULL or a live pointer from [`sh_batch_new`]; `per_strand` and `total` are
/// NULL or valid for writing one value each.
#[no_mangle]
pub unsafe extern "C" fn sh_batch_bytes(
    batch: *const ShBatch,
    per_strand: *mut usize,
    total: *mut usize,
) -> ShStatus {
    let f = |b: &ShBatch| {
        let s = b.strands.strand_bytes();
        let all = s * b.strands.len()
            + b.workspace.bytes
            + b.workspace.contacts.bytes()
            + b.strands.contact_bytes()
            + b.colliders.items.capacity()
                * core::mem::size_of::<(colliders::Shape, colliders::Carrier)>()
            + core::mem::size_of::<ShBatch>();
        // SAFETY: NULL or valid for one write each (caller).
        unsafe {
            write_opt(per_strand, s);
            write_opt(total, all);
        }
        ShStatus::Ok
    };
    // SAFETY: `batch` is NULL or live and not modified meanwhile (caller).
    unsafe { read_batch(batch, f) }
}

/// The head state as nalgebra values, checked.
fn head_state(h: &ShHeadState) -> Result<(HeadState, bool), Failure> {
    let values = h
        .position
        .iter()
        .chain(&h.rotation)
        .chain(&h.velocity)
        .chain(&h.acceleration)
        .chain(&h.angular_velocity)
        .chain(&h.angular_acceleration);
    if !values.into_iter().all(|x| x.is_finite()) {
        return Err(Failure::new(
            ShStatus::InvalidHead,
            None,
            "head: every value must be finite",
        ));
    }
    let r = Matrix3::from_column_slice(&h.rotation);
    if (r.transpose() * r - Matrix3::identity()).amax() > 1e-6 || r.determinant() <= 0.0 {
        return Err(Failure::new(
            ShStatus::InvalidHead,
            None,
            "head.rotation: must be a rotation (orthonormal columns within 1e-6, det > 0)",
        ));
    }
    let v = Vector3::from;
    Ok((
        HeadState {
            position: v(h.position),
            rotation: r,
            velocity: v(h.velocity),
            acceleration: v(h.acceleration),
            omega: v(h.angular_velocity),
            alpha: v(h.angular_acceleration),
        },
        h.moves != 0,
    ))
}

/// The head at rest at the origin: X = 0, R = I, every derivative zero, `moves` = 0.
///
/// # Safety
/// `head` is valid for writing one [`ShHeadState`].
#[no_mangle]
pub unsafe extern "C" fn sh_head_rest(head: *mut ShHeadState) -> ShStatus {
    if head.is_null() {
        return ShStatus::NullPointer;
    }
    let rest = ShHeadState {
        position: [0.0; 3],
        rotation: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        velocity: [0.0; 3],
        acceleration: [0.0; 3],
        angular_velocity: [0.0; 3],
        angular_acceleration: [0.0; 3],
        moves: 0,
    };
    // SAFETY: checked non-NULL; valid for one write (caller).
    unsafe { head.write(rest) };
    ShStatus::Ok
}

/// Sets the head state the next steps end at (it stays until set again), and the
/// frame [`sh_batch_centreline`] maps to world coordinates with. With `moves` zero only
/// the position and rotation are read. The substeps of the checked step follow the
/// head's motion extrapolated back from this state over the step (constant
/// acceleration and angular acceleration).
///
/// # Safety
/// `batch` is NULL or a live pointer from [`sh_batch_new`] used by no other thread
/// during the call; `head` is NULL or valid for reading one [`ShHeadState`].
#[no_mangle]
pub unsafe extern "C" fn sh_batch_set_head(
    batch: *mut ShBatch,
    head: *const ShHeadState,
) -> ShStatus {
    let f = |b: &mut ShBatch| {
        if head.is_null() {
            return Err(Failure::plain(ShStatus::NullPointer));
        }
        // SAFETY: checked non-NULL; valid for reading one value (caller).
        let (state, moves) = head_state(&unsafe { head.read() })?;
        if moves != b.settings.input.head_moves {
            // the energies the strands kept were measured in the other field
            b.strands.forget_energy();
        }
        b.settings.input.head = state;
        b.settings.input.head_moves = moves;
        Ok(())
    };
    // SAFETY: `batch` is NULL or live and used by this thread alone (caller).
    unsafe { with_batch(batch, f) }
}

/// Sets gravity, world coordinates, m/s² (e.g. {0, 0, −9.81}), for the next steps;
/// NULL: no gravity (the state a batch starts in).
///
/// # Safety
/// `batch` is NULL or a live pointer from [`sh_batch_new`] used by no other thread
/// during the call; `gravity` is NULL or valid for reading 3 values.
#[no_mangle]
pub unsafe extern "C" fn sh_batch_set_gravity(
    batch: *mut ShBatch,
    gravity: *const f64,
) -> ShStatus {
    let f = |b: &mut ShBatch| {
        let g = if gravity.is_null() {
            None
        } else {
            // SAFETY: checked non-NULL; valid for reading 3 values (caller).
            let g = unsafe { core::slice::from_raw_parts(gravity, 3) };
            if !g.iter().all(|x| x.is_finite()) {
                return Err(Failure::plain(ShStatus::InvalidGravity));
            }
            Some(Vector3::new(g[0], g[1], g[2]))
        };
        if g != b.settings.input.gravity {
            // the strands' potential energies change with gravity
            b.strands.forget_energy();
        }
        b.settings.input.gravity = g;
        Ok(())
    };
    // SAFETY: `batch` is NULL or live and used by this thread alone (caller).
    unsafe { with_batch(batch, f) }
}

/// Chooses the step of the next [`sh_batch_step`] and [`sh_batch_step_range`] calls:
/// nonzero `checked` (the default) takes the checked step, the runtime's: each strand's
/// linearly implicit Euler step checked after the fact and split into halves when it
/// rotates an element by more than 0.2 or creates energy (a small excess of energy is
/// removed from the velocities). Zero takes the plain linearly implicit step, without
/// checks: cheaper, and the caller keeps the element rotation of a step
/// ([`ShStepReport::max_element_rotation`]) below ~0.2 by its choice of dt.
///
/// # Safety
/// `batch` is NULL or a live pointer from [`sh_batch_new`] used by no other thread
/// during the call.
#[no_mangle]
pub unsafe extern "C" fn sh_batch_set_checked(batch: *mut ShBatch, checked: c_int) -> ShStatus {
    let f = |b: &mut ShBatch| {
        if checked == 0 && b.contacts.is_some() {
            return Err(Failure::new(
                ShStatus::InvalidContacts,
                None,
                "checked: the plain step takes no contacts (sh_batch_set_contacts(batch, NULL) first)",
            ));
        }
        b.settings.checked = checked != 0;
        Ok(())
    };
    // SAFETY: `batch` is NULL or live and used by this thread alone (caller).
    unsafe { with_batch(batch, f) }
}

/// Chooses error-controlled steps for the next [`sh_batch_step`] and
/// [`sh_batch_step_range`] calls: with `tolerance` in [1e-8, 0.5] each strand takes
/// steps of its own within every `dt` so that each one's estimated local error stays
/// below `tolerance`, relative to the strand's length (variable-step BDF2 with its
/// predictor's estimate; the error norm is the largest of the centreline's distance at
/// the element ends / L and each element's l‖Δq‖ and l‖Δq̇‖h; docs/time-stepping.md).
/// The strands keep their step size and history from one call to the next; each keeps
/// 2·3N + 2 more numbers for it (allocated here, once). [`ShStepReport`] counts the
/// steps taken and rejected and gives the largest estimated error and the step sizes.
/// `tolerance` = 0 returns to fixed steps (as [`sh_batch_set_checked`] chose); anything
/// else out of range is `SH_STATUS_INVALID_TOLERANCE` and changes nothing. With contacts
/// ([`sh_batch_set_contacts`]) every solve of the error-controlled step takes them (their
/// terms and the contacts that start within a step; their energy in the balance, their
/// anchors and allowances after every accepted step); a step in which a contact acts is
/// not extrapolated.
///
/// The head given by [`sh_batch_set_head`] is its state at the end of each `dt`; the
/// strands' own steps follow the motion extrapolated back from it (its velocity,
/// acceleration, angular velocity and angular acceleration).
///
/// # Safety
/// `batch` is NULL or a live pointer from [`sh_batch_new`] used by no other thread
/// during the call.
#[no_mangle]
pub unsafe extern "C" fn sh_batch_set_tolerance(batch: *mut ShBatch, tolerance: f64) -> ShStatus {
    let f = |b: &mut ShBatch| {
        if tolerance == 0.0 {
            b.settings.tolerance = None;
            return Ok(());
        }
        let range =
            superhelix_kernels::fixed::MIN_TOLERANCE..=superhelix_kernels::fixed::MAX_TOLERANCE;
        if !range.contains(&tolerance) {
            return Err(Failure::new(
                ShStatus::InvalidTolerance,
                None,
                &format!("tolerance: {tolerance:e} is neither 0 nor within [1e-8, 0.5]"),
            ));
        }
        b.strands
            .keep_histories()
            .map_err(|_| Failure::plain(ShStatus::OutOfMemory))?;
        b.settings.tolerance = Some(tolerance);
        Ok(())
    };
    // SAFETY: `batch` is NULL or live and used by this thread alone (caller).
    unsafe { with_batch(batch, f) }
}

/// The error of a range's outcome.
fn step_error(outcome: &BatchOutcome) -> Option<Failure> {
    let (i, e) = outcome.first?;
    let more = match outcome.failed {
        1 => String::new(),
        f => format!(" ({} more strands failed)", f - 1),
    };
    Some(Failure::new(
        e.into(),
        Some(i),
        &format!("strand {i}: {e}; it kept its state{more}"),
    ))
}

fn check_dt(dt: f64) -> Result<(), Failure> {
    if dt.is_finite() && dt > 0.0 {
        Ok(())
    } else {
        Err(Failure::plain(ShStatus::InvalidTimeStep))
    }
}

/// Steps every strand of the batch by `dt` seconds with the batch's workspace, to the
/// head state and gravity last set: the checked step (split into substeps where needed)
/// or the plain one, as [`sh_batch_set_checked`] chose.
///
/// Every strand is stepped; one whose step fails keeps the state it had. The status is
/// that of the first failure (`SH_STATUS_SINGULAR_MATRIX`, `SH_STATUS_NON_FINITE`),
/// [`sh_batch_last_error`] names its strand, and [`sh_batch_last_step`] counts the
/// failures and gives the largest element rotation of the step. A `dt` that is not
/// finite and > 0 steps nothing.
///
/// # Safety
/// `batch` is NULL or a live pointer from [`sh_batch_new`] used by no other thread
/// during the call.
#[no_mangle]
pub unsafe extern "C" fn sh_batch_step(batch: *mut ShBatch, dt: f64) -> ShStatus {
    let f = |b: &mut ShBatch| {
        b.last_step = ShStepReport::NONE;
        check_dt(dt)?;
        let n = b.strands.len();
        // SAFETY: `b` is borrowed exclusively, so nothing else uses its strands.
        let colliders = b.contacts.is_some().then_some(&b.colliders);
        let outcome = unsafe {
            b.strands
                .step_range(0, n, &b.settings, dt, &mut b.workspace, colliders)
                .ok_or_else(|| Failure::plain(ShStatus::WorkspaceMismatch))?
        };
        b.last_step = step_report(n, &outcome);
        match step_error(&outcome) {
            Some(e) => Err(e),
            None => Ok(()),
        }
    };
    // SAFETY: `batch` is NULL or live and used by this thread alone (caller).
    unsafe { with_batch(batch, f) }
}

fn step_report(stepped: usize, o: &BatchOutcome) -> ShStepReport {
    ShStepReport {
        stepped,
        failed: o.failed,
        first_failed: o.first.map_or(usize::MAX, |(i, _)| i),
        max_element_rotation: o.max_element_rotation,
        substeps: o.counts.substeps,
        energy_rejected: o.counts.energy_rejected,
        energy_limited: o.counts.energy_limited + o.tolerance.energy_limited,
        energy_unbalanced: o.counts.energy_unbalanced,
        steps: o.tolerance.steps,
        rejected: o.tolerance.rejected,
        largest_error: o.tolerance.largest_error,
        smallest_step: o.tolerance.smallest_step,
        largest_step: o.tolerance.largest_step,
    }
}

/// The report of the last [`sh_batch_step`] (all zero, `first_failed` = `SIZE_MAX`,
/// before the first).
///
/// # Safety
/// `batch` is NULL or a live pointer from [`sh_batch_new`]; `report` is valid for
/// writing one [`ShStepReport`].
#[no_mangle]
pub unsafe extern "C" fn sh_batch_last_step(
    batch: *const ShBatch,
    report: *mut ShStepReport,
) -> ShStatus {
    if report.is_null() {
        return ShStatus::NullPointer;
    }
    let f = |b: &ShBatch| {
        // SAFETY: checked non-NULL; valid for one write (caller).
        unsafe { report.write(b.last_step) };
        ShStatus::Ok
    };
    // SAFETY: `batch` is NULL or live and not modified meanwhile (caller).
    unsafe { read_batch(batch, f) }
}

/// Makes a workspace for strands of `elements` elements: the scratch of one step, for
/// one thread (see [`sh_batch_step_range`]). `*out` is NULL on failure.
///
/// # Safety
/// `out` is valid for writing one pointer.
#[no_mangle]
pub unsafe extern "C" fn sh_workspace_new(elements: usize, out: *mut *mut ShWorkspace) -> ShStatus {
    if out.is_null() {
        return ShStatus::NullPointer;
    }
    // SAFETY: checked non-NULL; valid for one write (caller).
    unsafe { out.write(core::ptr::null_mut()) };
    guard(|| match batch::new_workspace(elements) {
        Some(inner) => {
            // SAFETY: as above.
            unsafe { out.write(Box::into_raw(Box::new(ShWorkspace { inner }))) };
            ShStatus::Ok
        }
        None => ShStatus::UnsupportedElements,
    })
}

/// Frees a workspace (NULL is allowed and does nothing).
///
/// # Safety
/// `workspace` is NULL or a pointer from [`sh_workspace_new`] not yet freed; it is not
/// used afterwards.
#[no_mangle]
pub unsafe extern "C" fn sh_workspace_free(workspace: *mut ShWorkspace) {
    if !workspace.is_null() {
        // SAFETY: from Box::into_raw in sh_workspace_new, freed once (caller).
        let w = unsafe { Box::from_raw(workspace) };
        let _ = catch_unwind(AssertUnwindSafe(move || drop(w)));
    }
}

/// Steps strands `first .. first + count` of the batch by `dt` seconds with
/// `workspace`, as [`sh_batch_step`] steps them all: the way to spread one batch over
/// several threads.
///
/// Calls on the same batch may run concurrently from several threads when their ranges
/// do not overlap and each has its own workspace (made for the batch's N), and when no
/// other function is called on the batch meanwhile (set the head and gravity before,
/// read the results after). This call neither reads nor sets the batch's last error or
/// last step report: `report` (may be NULL) receives this range's, and `error` (may be
/// NULL) the details of its first failure.
///
/// # Safety
/// `batch` is NULL or a live pointer from [`sh_batch_new`], under the concurrency rule
/// above; `workspace` is NULL or a live pointer from [`sh_workspace_new`] used by no
/// other thread during the call; `report` and `error` are NULL or valid for writing one
/// value each.
#[no_mangle]
pub unsafe extern "C" fn sh_batch_step_range(
    batch: *const ShBatch,
    first: usize,
    count: usize,
    workspace: *mut ShWorkspace,
    dt: f64,
    report: *mut ShStepReport,
    error: *mut ShError,
) -> ShStatus {
    let mut detail = ShError::NONE;
    let mut step = ShStepReport::NONE;
    let status = guard(|| {
        let result = (|| {
            if batch.is_null() || workspace.is_null() {
                return Err(Failure::plain(ShStatus::NullPointer));
            }
            // SAFETY: live; only read here (the strands of the range are reached
            // through their cells), concurrently with other shared uses (caller).
            let b = unsafe { &*batch };
            // SAFETY: live and used by this thread alone during the call (caller).
            let ws = unsafe { &mut (*workspace).inner };
            let len = b.strands.len();
            if first.checked_add(count).is_none_or(|end| end > len) {
                return Err(Failure::new(
                    ShStatus::IndexOutOfRange,
                    None,
                    &format!("range {first} + {count}: outside the batch's {len} strands"),
                ));
            }
            if ws.elements != b.strands.elements() {
                return Err(Failure::new(
                    ShStatus::WorkspaceMismatch,
                    None,
                    &format!(
                        "workspace: made for N = {}, the batch has N = {}",
                        ws.elements,
                        b.strands.elements()
                    ),
                ));
            }
            check_dt(dt)?;
            // SAFETY: the caller steps disjoint ranges concurrently and nothing else, so
            // no other reference to these strands is in use.
            let outcome = unsafe {
                b.strands
                    .step_range(first, count, &b.settings, dt, ws, b.step_colliders())
                    .ok_or_else(|| Failure::plain(ShStatus::WorkspaceMismatch))?
            };
            step = step_report(count, &outcome);
            match step_error(&outcome) {
                Some(e) => Err(e),
                None => Ok(()),
            }
        })();
        match result {
            Ok(()) => ShStatus::Ok,
            Err(e) => {
                detail = e.to_error();
                e.status
            }
        }
    });
    if status == ShStatus::Panic {
        detail = Failure::plain(ShStatus::Panic).to_error();
    }
    // SAFETY: NULL or valid for one write each (caller).
    unsafe {
        write_opt(report, step);
        write_opt(error, detail);
    }
    status
}

/// The centreline of strand `strand`: the N + 1 element ends, root first, in world
/// coordinates (X + R y with the head state last set), as x, y, z triples into `xyz`.
/// `capacity_points` is the room in `xyz` in points (3 doubles each); `written` (may be
/// NULL) receives N + 1, also when the room is too small (`SH_STATUS_BUFFER_TOO_SMALL`,
/// nothing written).
///
/// # Safety
/// `batch` is NULL or a live pointer from [`sh_batch_new`] that no thread modifies
/// during the call; `xyz` is valid for writing `3 × capacity_points` values; `written`
/// is NULL or valid for writing one value.
#[no_mangle]
pub unsafe extern "C" fn sh_batch_centreline(
    batch: *const ShBatch,
    strand: usize,
    xyz: *mut f64,
    capacity_points: usize,
    written: *mut usize,
) -> ShStatus {
    let f = |b: &ShBatch| {
        if xyz.is_null() {
            return ShStatus::NullPointer;
        }
        if strand >= b.strands.len() {
            return ShStatus::IndexOutOfRange;
        }
        let points = b.strands.elements() + 1;
        // SAFETY: NULL or valid for one write (caller).
        unsafe { write_opt(written, points) };
        if capacity_points < points {
            return ShStatus::BufferTooSmall;
        }
        // SAFETY: non-NULL and valid for 3 × capacity_points ≥ 3 × points values.
        let out = unsafe { core::slice::from_raw_parts_mut(xyz, 3 * points) };
        b.strands.centreline(strand, &b.settings.input.head, out);
        ShStatus::Ok
    };
    // SAFETY: `batch` is NULL or live and not modified meanwhile (caller).
    unsafe { read_batch(batch, f) }
}

/// The state of strand `strand`: q (3N values: τ, κ1, κ2 per element, root first,
/// rad/m) into `q`, and q̇ (rad/(m·s)) into `qdot` unless it is NULL. `capacity` is the
/// room in each array in values; `written` (may be NULL) receives 3N, also when the
/// room is too small (`SH_STATUS_BUFFER_TOO_SMALL`, nothing written).
///
/// # Safety
/// `batch` is NULL or a live pointer from [`sh_batch_new`] that no thread modifies
/// during the call; `q` (and `qdot` unless NULL) are valid for writing `capacity`
/// values; `written` is NULL or valid for writing one value.
#[no_mangle]
pub unsafe extern "C" fn sh_batch_state(
    batch: *const ShBatch,
    strand: usize,
    q: *mut f64,
    qdot: *mut f64,
    capacity: usize,
    written: *mut usize,
) -> ShStatus {
    let f = |b: &ShBatch| {
        if q.is_null() {
            return ShStatus::NullPointer;
        }
        if strand >= b.strands.len() {
            return ShStatus::IndexOutOfRange;
        }
        let d = 3 * b.strands.elements();
        // SAFETY: NULL or valid for one write (caller).
        unsafe { write_opt(written, d) };
        if capacity < d {
            return ShStatus::BufferTooSmall;
        }
        // SAFETY: non-NULL and valid for capacity ≥ d values (caller).
        let q = unsafe { core::slice::from_raw_parts_mut(q, d) };
        let v = if qdot.is_null() {
            None
        } else {
            // SAFETY: non-NULL and valid for capacity ≥ d values (caller).
            Some(unsafe { core::slice::from_raw_parts_mut(qdot, d) })
        };
        b.strands.state(strand, q, v);
        ShStatus::Ok
    };
    // SAFETY: `batch` is NULL or live and not modified meanwhile (caller).
    unsafe { read_batch(batch, f) }
}

/// Sets the state of strand `strand`: q from `q` (3N values) and q̇ from `qdot` (3N
/// values, or NULL for q̇ = 0); `count` must be 3N. The strand forgets the eigenbasis it
/// kept, as after [`sh_batch_new`].
///
/// # Safety
/// `batch` is NULL or a live pointer from [`sh_batch_new`] used by no other thread
/// during the call; `q` (and `qdot` unless NULL) are valid for reading `count` values.
#[no_mangle]
pub unsafe extern "C" fn sh_batch_set_state(
    batch: *mut ShBatch,
    strand: usize,
    q: *const f64,
    qdot: *const f64,
    count: usize,
) -> ShStatus {
    let f = |b: &mut ShBatch| {
        if q.is_null() {
            return Err(Failure::plain(ShStatus::NullPointer));
        }
        if strand >= b.strands.len() {
            return Err(Failure::new(
                ShStatus::IndexOutOfRange,
                Some(strand),
                &format!("strand {strand}: the batch has {}", b.strands.len()),
            ));
        }
        let d = 3 * b.strands.elements();
        if count != d {
            return Err(Failure::new(
                ShStatus::InvalidCount,
                Some(strand),
                &format!("count: must be 3N = {d}, got {count}"),
            ));
        }
        // SAFETY: non-NULL and valid for reading count = d values (caller).
        let q = unsafe { core::slice::from_raw_parts(q, d) };
        let v = if qdot.is_null() {
            None
        } else {
            // SAFETY: non-NULL and valid for reading count = d values (caller).
            Some(unsafe { core::slice::from_raw_parts(qdot, d) })
        };
        let finite = q.iter().chain(v.unwrap_or(&[])).all(|x| x.is_finite());
        if !finite {
            return Err(Failure::new(
                ShStatus::InvalidState,
                Some(strand),
                &format!("strand {strand}: q and q̇ must be finite"),
            ));
        }
        b.strands.set_state(strand, q, v);
        Ok(())
    };
    // SAFETY: `batch` is NULL or live and used by this thread alone (caller).
    unsafe { with_batch(batch, f) }
}
