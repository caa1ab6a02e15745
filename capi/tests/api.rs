//! The C API called from Rust: statuses and their messages, every refusal (NULL
//! pointers, counts, sizes, parameters out of range), failures that leave the other
//! strands alone, stepping a batch in ranges from several threads, the world
//! centreline and the memory figures.

use core::ffi::CStr;
use core::ptr::{null, null_mut};
use nalgebra::{Matrix3, Rotation3, Vector3};
use superhelix_capi::*;
use superhelix_kernels::fixed::{FixedStrand, FixedWorkspace};

/// The strand of the C example (N = `n`, hanging along (0.3, 0, −1), curly).
fn params(n: usize) -> ShStrandParams {
    let n0 = Vector3::new(0.3, 0.0, -1.0).normalize();
    let x = Vector3::x();
    let n1 = (x - n0 * n0.dot(&x)).normalize();
    let frame = Matrix3::from_columns(&[n0, n1, n0.cross(&n1)]);
    let mut root_frame = [0.0; 9];
    root_frame.copy_from_slice(frame.as_slice());
    ShStrandParams {
        elements: n,
        length: 0.2,
        element_lengths: null(),
        root_position: [0.0; 3],
        root_frame,
        cross_section: ShCrossSection {
            radius: 50e-6,
            ellipticity: 1.0,
            youngs_modulus: 1.5e9,
            poisson_ratio: 0.48,
            density: 1300.0,
        },
        natural: superhelix_kernels::material::helix_curvature(6e-3, 5e-3, true),
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

fn new_batch(p: &[ShStrandParams]) -> Result<Batch, Box<ShError>> {
    let mut out = null_mut();
    let mut error = ShError::plain_for_tests();
    // SAFETY: valid slice, out and error pointers.
    let status = unsafe { sh_batch_new(p.as_ptr(), p.len(), &mut out, &mut error) };
    assert_eq!(status, error.status);
    if status == ShStatus::Ok {
        assert!(!out.is_null());
        Ok(Batch(out))
    } else {
        assert!(out.is_null());
        Err(Box::new(error))
    }
}

trait ForTests {
    fn plain_for_tests() -> Self;
}

impl ForTests for ShError {
    /// An error value to be overwritten.
    fn plain_for_tests() -> Self {
        ShError {
            status: ShStatus::Panic,
            strand: 12345,
            message: [1; SH_ERROR_MESSAGE_BYTES],
        }
    }
}

fn last_error(b: &Batch) -> ShError {
    let mut e = ShError::plain_for_tests();
    // SAFETY: live batch, valid out pointer.
    assert_eq!(unsafe { sh_batch_last_error(b.0, &mut e) }, ShStatus::Ok);
    e
}

fn state(b: &Batch, i: usize) -> (Vec<f64>, Vec<f64>) {
    let mut q = vec![0.0; 60];
    let mut v = vec![0.0; 60];
    let mut written = 0;
    // SAFETY: live batch, buffers of 60 values.
    let s = unsafe { sh_batch_state(b.0, i, q.as_mut_ptr(), v.as_mut_ptr(), 60, &mut written) };
    assert_eq!(s, ShStatus::Ok);
    q.truncate(written);
    v.truncate(written);
    (q, v)
}

fn step(b: &Batch, dt: f64) -> ShStatus {
    // SAFETY: live batch.
    unsafe { sh_batch_step(b.0, dt) }
}

fn set_gravity(b: &Batch) {
    let g = [0.0, 0.0, -9.81];
    // SAFETY: live batch, 3 values.
    assert_eq!(
        unsafe { sh_batch_set_gravity(b.0, g.as_ptr()) },
        ShStatus::Ok
    );
}

#[test]
fn every_status_has_its_value_and_a_message() {
    for code in 0..27 {
        let s = ShStatus::from_code(code).expect("a status");
        assert_eq!(s as i32, code);
        // SAFETY: sh_status_message returns a static NUL-terminated string.
        let m = unsafe { CStr::from_ptr(sh_status_message(code)) };
        assert!(!m.to_bytes().is_empty() && m.to_str().is_ok());
    }
    for code in [-1, 27, 1000, i32::MIN, i32::MAX] {
        assert!(ShStatus::from_code(code).is_none());
        // SAFETY: as above.
        let m = unsafe { CStr::from_ptr(sh_status_message(code)) };
        assert_eq!(m.to_str(), Ok("unknown status"));
    }
}

#[test]
fn supported_elements_are_the_sizes_of_the_build() {
    // the checked-in sizes, and those of SUPERHELIX_N when superhelix-generated was built
    // with it
    let build = &superhelix_generated::fixed::SIZES;
    let mut sizes = [0usize; 256];
    let mut count = 0;
    // SAFETY: 256 values of room, valid count pointer.
    let s = unsafe { sh_supported_elements(sizes.as_mut_ptr(), 256, &mut count) };
    assert_eq!(s, ShStatus::Ok);
    assert_eq!(&sizes[..count], &build[..]);
    assert!(superhelix_generated::sizes::CHECKED_IN_SIZES
        .iter()
        .all(|n| build.contains(n)));
    // SAFETY: capacity 0 with NULL, valid count pointer.
    let s = unsafe { sh_supported_elements(null_mut(), 0, &mut count) };
    assert_eq!((s, count), (ShStatus::BufferTooSmall, build.len()));
    // SAFETY: NULL count is refused before any write.
    let s = unsafe { sh_supported_elements(sizes.as_mut_ptr(), 32, null_mut()) };
    assert_eq!(s, ShStatus::NullPointer);
}

#[test]
fn memory_figures_are_the_fixed_types_sizes() {
    let (mut s, mut w) = (0, 0);
    // SAFETY: valid out pointers.
    unsafe {
        assert_eq!(sh_strand_bytes(5, &mut s), ShStatus::Ok);
        assert_eq!(sh_workspace_bytes(5, &mut w), ShStatus::Ok);
    }
    assert_eq!(s, FixedStrand::<5, 15, 7>::BYTES);
    assert_eq!(w, FixedWorkspace::<5, 15, 6>::BYTES);
    // SAFETY: valid out pointers, or NULL (refused).
    unsafe {
        assert_eq!(sh_strand_bytes(20, &mut s), ShStatus::Ok);
        assert_eq!(s, FixedStrand::<20, 60, 30>::BYTES);
        assert_eq!(sh_workspace_bytes(7, &mut w), ShStatus::UnsupportedElements);
        assert_eq!(sh_workspace_bytes(5, null_mut()), ShStatus::NullPointer);
    }
    let b = new_batch(&[params(10), params(10), params(10)]).unwrap();
    let (mut per, mut total, mut count, mut n) = (0, 0, 0, 0);
    // SAFETY: live batch, valid out pointers.
    unsafe {
        assert_eq!(sh_batch_bytes(b.0, &mut per, &mut total), ShStatus::Ok);
        assert_eq!(sh_batch_size(b.0, &mut count, &mut n), ShStatus::Ok);
    }
    assert_eq!(per, FixedStrand::<10, 30, 15>::BYTES);
    assert!(total > 3 * per + FixedWorkspace::<10, 30, 11>::BYTES);
    assert_eq!((count, n), (3, 10));
}

/// A change to a strand's parameters.
type Change = Box<dyn Fn(&mut ShStrandParams)>;

#[test]
fn batch_new_refuses_what_it_cannot_make() {
    let p = [params(5)];
    let mut out = null_mut();
    // SAFETY: NULL out pointer (refused), NULL error allowed.
    let s = unsafe { sh_batch_new(p.as_ptr(), 1, null_mut(), null_mut()) };
    assert_eq!(s, ShStatus::NullPointer);
    // SAFETY: NULL params (refused), valid out pointer.
    let s = unsafe { sh_batch_new(null(), 1, &mut out, null_mut()) };
    assert_eq!(s, ShStatus::NullPointer);
    assert!(out.is_null());

    let e = new_batch(&[]).err().unwrap();
    assert_eq!(e.status, ShStatus::InvalidCount);

    let e = new_batch(&[params(7)]).err().unwrap();
    assert_eq!((e.status, e.strand), (ShStatus::UnsupportedElements, 0));
    assert!(e.message_str().contains("N = 7"), "{e:?}");
    let e = new_batch(&[params(0)]).err().unwrap();
    assert_eq!(e.status, ShStatus::UnsupportedElements);

    let e = new_batch(&[params(5), params(5), params(6)]).err().unwrap();
    assert_eq!((e.status, e.strand), (ShStatus::MixedElements, 2));

    // each parameter out of range, on strand 1 of 2: its status, the strand and the
    // parameter's name in the message
    let lengths = [0.04, 0.04, -0.04, 0.04, 0.04];
    let natural_nan = [f64::NAN; 15];
    let cases: Vec<(ShStatus, &str, Change)> = vec![
        (
            ShStatus::InvalidLength,
            "lengths",
            Box::new(|p| p.length = 0.0),
        ),
        (
            ShStatus::InvalidLength,
            "lengths",
            Box::new(move |p| p.element_lengths = lengths.as_ptr()),
        ),
        (
            ShStatus::InvalidRootPosition,
            "root_position",
            Box::new(|p| p.root_position[1] = f64::INFINITY),
        ),
        (
            ShStatus::InvalidRootFrame,
            "root_frame",
            Box::new(|p| p.root_frame[0] *= 1.001),
        ),
        (
            ShStatus::InvalidRootFrame,
            "root_frame",
            Box::new(|p| {
                for x in &mut p.root_frame[6..] {
                    *x = -*x; // det < 0
                }
            }),
        ),
        (
            ShStatus::InvalidCrossSection,
            "cross_section.radius",
            Box::new(|p| p.cross_section.radius = 0.0),
        ),
        (
            ShStatus::InvalidCrossSection,
            "cross_section.ellipticity",
            Box::new(|p| p.cross_section.ellipticity = 0.5),
        ),
        (
            ShStatus::InvalidCrossSection,
            "cross_section.youngs_modulus",
            Box::new(|p| p.cross_section.youngs_modulus = f64::NAN),
        ),
        (
            ShStatus::InvalidCrossSection,
            "cross_section.poisson_ratio",
            Box::new(|p| p.cross_section.poisson_ratio = 0.6),
        ),
        (
            ShStatus::InvalidCrossSection,
            "cross_section.density",
            Box::new(|p| p.cross_section.density = -1.0),
        ),
        (
            ShStatus::InvalidNatural,
            "natural",
            Box::new(|p| p.natural[1] = 2e6),
        ),
        (
            ShStatus::InvalidNatural,
            "natural",
            Box::new(move |p| p.natural_per_element = natural_nan.as_ptr()),
        ),
        (
            ShStatus::InvalidInternalFriction,
            "internal_friction",
            Box::new(|p| p.internal_friction = -1e-12),
        ),
        (
            ShStatus::InvalidAirDrag,
            "air_drag",
            Box::new(|p| p.air_drag = f64::NAN),
        ),
    ];
    for (status, field, change) in &cases {
        let mut bad = params(5);
        change(&mut bad);
        let e = new_batch(&[params(5), bad]).err().unwrap();
        assert_eq!((e.status, e.strand), (*status, 1), "{field}: {e:?}");
        let m = e.message_str();
        assert!(
            m.starts_with("strand 1: ") && m.contains(field),
            "{field}: {m}"
        );
    }
}

#[test]
fn per_element_lengths_and_natural_shape_are_read() {
    let lengths = [0.03, 0.05, 0.04, 0.06, 0.02];
    let natural: Vec<f64> = (0..15).map(|i| 10.0 + i as f64).collect();
    let mut p = params(5);
    p.element_lengths = lengths.as_ptr();
    p.natural_per_element = natural.as_ptr();
    let b = new_batch(&[p]).unwrap();
    let (q, v) = state(&b, 0);
    assert_eq!(q, natural);
    assert!(v.iter().all(|&x| x == 0.0));
}

#[test]
fn head_and_gravity_are_checked_and_errors_are_kept_until_a_success() {
    let b = new_batch(&[params(5)]).unwrap();
    let mut head = ShHeadState {
        position: [0.0; 3],
        rotation: [0.0; 9],
        velocity: [0.0; 3],
        acceleration: [0.0; 3],
        angular_velocity: [0.0; 3],
        angular_acceleration: [0.0; 3],
        moves: 0,
    };
    // SAFETY: live batch; valid or NULL head pointers.
    unsafe {
        assert_eq!(sh_batch_set_head(b.0, &head), ShStatus::InvalidHead);
        let e = last_error(&b);
        assert_eq!(e.status, ShStatus::InvalidHead);
        assert!(e.message_str().contains("head.rotation"), "{e:?}");
        assert_eq!(sh_head_rest(&mut head), ShStatus::Ok);
        head.velocity[0] = f64::NAN;
        assert_eq!(sh_batch_set_head(b.0, &head), ShStatus::InvalidHead);
        assert_eq!(sh_batch_set_head(b.0, null()), ShStatus::NullPointer);
        assert_eq!(last_error(&b).status, ShStatus::NullPointer);
        assert_eq!(sh_batch_set_head(null_mut(), &head), ShStatus::NullPointer);
        let g = [0.0, f64::NAN, 0.0];
        assert_eq!(
            sh_batch_set_gravity(b.0, g.as_ptr()),
            ShStatus::InvalidGravity
        );
        assert_eq!(last_error(&b).status, ShStatus::InvalidGravity);
        assert_eq!(sh_batch_set_gravity(b.0, null()), ShStatus::Ok);
        let e = last_error(&b);
        assert_eq!(
            (e.status, e.strand, e.message_str()),
            (ShStatus::Ok, usize::MAX, "")
        );
        assert_eq!(sh_head_rest(null_mut()), ShStatus::NullPointer);
    }
}

#[test]
fn a_bad_time_step_steps_nothing() {
    let b = new_batch(&[params(5)]).unwrap();
    set_gravity(&b);
    let before = state(&b, 0);
    for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert_eq!(step(&b, dt), ShStatus::InvalidTimeStep);
        assert_eq!(state(&b, 0), before);
    }
    let mut r = junk_report();
    // SAFETY: live batch, valid report pointer.
    assert_eq!(unsafe { sh_batch_last_step(b.0, &mut r) }, ShStatus::Ok);
    assert_eq!((r.stepped, r.failed, r.first_failed), (0, 0, usize::MAX));
    assert_eq!(step(&null_batch(), 0.01), ShStatus::NullPointer);
}

/// A report to be overwritten.
fn junk_report() -> ShStepReport {
    ShStepReport {
        stepped: 99,
        failed: 99,
        first_failed: 99,
        max_element_rotation: -1.0,
        substeps: 99,
        energy_rejected: 99,
        energy_limited: 99,
        energy_unbalanced: 99,
        steps: 99,
        rejected: 99,
        largest_error: -1.0,
        smallest_step: -1.0,
        largest_step: -1.0,
    }
}

fn last_step(b: &Batch) -> ShStepReport {
    let mut r = junk_report();
    // SAFETY: live batch, valid report pointer.
    assert_eq!(unsafe { sh_batch_last_step(b.0, &mut r) }, ShStatus::Ok);
    r
}

#[test]
fn the_checked_step_splits_what_the_plain_step_takes_whole() {
    // released from straight, a curly strand's first steps rotate its elements by more
    // than 0.2 rad: the checked step splits them
    let straight = [0.0; 15];
    let checked = new_batch(&[params(5)]).unwrap();
    let plain = new_batch(&[params(5)]).unwrap();
    // SAFETY: live batches, 15 values.
    unsafe {
        assert_eq!(sh_batch_set_checked(plain.0, 0), ShStatus::Ok);
        assert_eq!(sh_batch_set_checked(null_mut(), 0), ShStatus::NullPointer);
        for b in [&checked, &plain] {
            let s = sh_batch_set_state(b.0, 0, straight.as_ptr(), null(), 15);
            assert_eq!(s, ShStatus::Ok);
        }
    }
    assert_eq!(step(&checked, 1.0 / 30.0), ShStatus::Ok);
    assert_eq!(step(&plain, 1.0 / 30.0), ShStatus::Ok);
    let (c, p) = (last_step(&checked), last_step(&plain));
    assert!(c.substeps > 0, "{c:?}");
    assert_eq!((p.substeps, p.energy_rejected, p.energy_limited), (0, 0, 0));
    assert!(p.max_element_rotation > 0.2, "{p:?}");
    assert_ne!(state(&checked, 0), state(&plain, 0));
}

/// `sh_batch_set_tolerance`: out-of-range values are refused and change nothing; a
/// tolerance gives error-controlled steps, reported, whose history `sh_batch_set_state`
/// forgets; 0 returns to fixed steps.
#[test]
fn a_tolerance_chooses_error_controlled_steps() {
    let straight = [0.0; 15];
    let b = new_batch(&[params(5)]).unwrap();
    let fresh = new_batch(&[params(5)]).unwrap();
    // SAFETY: live batches, 15 values.
    unsafe {
        for bad in [-1e-3, 1e-9, 0.6, f64::NAN, f64::INFINITY] {
            assert_eq!(sh_batch_set_tolerance(b.0, bad), ShStatus::InvalidTolerance);
            assert!(last_error(&b).message_str().contains("tolerance"));
        }
        assert_eq!(
            sh_batch_set_tolerance(null_mut(), 1e-3),
            ShStatus::NullPointer
        );
        // still fixed steps: the report has no error-controlled steps
        assert_eq!(step(&b, 1.0 / 30.0), ShStatus::Ok);
        assert_eq!(last_step(&b).steps, 0);
        for x in [&b, &fresh] {
            assert_eq!(sh_batch_set_tolerance(x.0, 1e-3), ShStatus::Ok);
            let s = sh_batch_set_state(x.0, 0, straight.as_ptr(), null(), 15);
            assert_eq!(s, ShStatus::Ok);
        }
    }
    // released from straight: many steps within the first 1/30 s, each within 1e-3
    for _ in 0..2 {
        assert_eq!(step(&b, 1.0 / 30.0), ShStatus::Ok);
        assert_eq!(step(&fresh, 1.0 / 30.0), ShStatus::Ok);
    }
    let r = last_step(&b);
    assert!(r.steps > 1, "{r:?}");
    assert!(r.largest_error > 0.0 && r.largest_error <= 1e-3, "{r:?}");
    assert!(
        r.smallest_step > 0.0 && r.smallest_step <= r.largest_step,
        "{r:?}"
    );
    assert!(r.largest_step <= 1.0 / 30.0 + 1e-15, "{r:?}");
    assert_eq!((r.substeps, r.energy_rejected), (0, 0));
    assert_eq!(state(&b, 0), state(&fresh, 0));
    // setting the state forgets the history: the same steps as a fresh start
    let (q, _) = state(&b, 0);
    // SAFETY: live batches, 15 values.
    unsafe {
        for x in [&b, &fresh] {
            assert_eq!(
                sh_batch_set_state(x.0, 0, q.as_ptr(), null(), 15),
                ShStatus::Ok
            );
        }
    }
    let restarted = new_batch(&[params(5)]).unwrap();
    // SAFETY: live batch, 15 values.
    unsafe {
        assert_eq!(sh_batch_set_tolerance(restarted.0, 1e-3), ShStatus::Ok);
        let s = sh_batch_set_state(restarted.0, 0, q.as_ptr(), null(), 15);
        assert_eq!(s, ShStatus::Ok);
    }
    assert_eq!(step(&b, 1.0 / 30.0), ShStatus::Ok);
    assert_eq!(step(&restarted, 1.0 / 30.0), ShStatus::Ok);
    assert_eq!(state(&b, 0), state(&restarted, 0));
    // 0: fixed steps again
    // SAFETY: live batch.
    assert_eq!(unsafe { sh_batch_set_tolerance(b.0, 0.0) }, ShStatus::Ok);
    assert_eq!(step(&b, 1.0 / 30.0), ShStatus::Ok);
    assert_eq!(last_step(&b).steps, 0);
}

fn null_batch() -> Batch {
    Batch(null_mut())
}

#[test]
fn a_failing_strand_keeps_its_state_and_the_others_step() {
    // with fixed steps, and with error-controlled ones (which shrink the failing step down
    // to the shortest before they give up)
    for tolerance in [0.0, 1e-3] {
        failing_strand(tolerance);
    }
}

fn failing_strand(tolerance: f64) {
    let b = new_batch(&[params(5), params(5), params(5)]).unwrap();
    let single = new_batch(&[params(5)]).unwrap();
    set_gravity(&b);
    set_gravity(&single);
    // SAFETY: live batches.
    unsafe {
        assert_eq!(sh_batch_set_tolerance(b.0, tolerance), ShStatus::Ok);
        assert_eq!(sh_batch_set_tolerance(single.0, tolerance), ShStatus::Ok);
    }
    // strand 1 gets a state whose step cannot be finite
    let wild = [1e300; 15];
    // SAFETY: live batch, 15 values.
    let s = unsafe { sh_batch_set_state(b.0, 1, wild.as_ptr(), null(), 15) };
    assert_eq!(s, ShStatus::Ok);
    let status = step(&b, 1.0 / 30.0);
    assert!(
        matches!(status, ShStatus::NonFinite | ShStatus::SingularMatrix),
        "{status:?}"
    );
    let e = last_error(&b);
    assert_eq!((e.status, e.strand), (status, 1));
    assert!(e.message_str().starts_with("strand 1: "), "{e:?}");
    let mut r = junk_report();
    // SAFETY: live batch, valid report pointer.
    assert_eq!(unsafe { sh_batch_last_step(b.0, &mut r) }, ShStatus::Ok);
    assert_eq!((r.stepped, r.failed, r.first_failed), (3, 1, 1));
    assert!(r.max_element_rotation > 0.0 && r.max_element_rotation < 0.2);
    assert_eq!(r.steps > 0, tolerance > 0.0, "{r:?}");
    // strand 1 kept its state; 0 and 2 stepped as a strand alone does
    assert_eq!(state(&b, 1), (wild.to_vec(), vec![0.0; 15]));
    assert_eq!(step(&single, 1.0 / 30.0), ShStatus::Ok);
    assert_eq!(state(&b, 0), state(&single, 0));
    assert_eq!(state(&b, 2), state(&single, 0));
    // a state that is not finite is refused
    let nan = [f64::NAN; 15];
    // SAFETY: live batch, 15 values each.
    unsafe {
        assert_eq!(
            sh_batch_set_state(b.0, 0, wild.as_ptr(), nan.as_ptr(), 15),
            ShStatus::InvalidState
        );
        assert_eq!(
            sh_batch_set_state(b.0, 0, wild.as_ptr(), null(), 14),
            ShStatus::InvalidCount
        );
        assert_eq!(
            sh_batch_set_state(b.0, 3, wild.as_ptr(), null(), 15),
            ShStatus::IndexOutOfRange
        );
        assert_eq!(
            sh_batch_set_state(b.0, 0, null(), null(), 15),
            ShStatus::NullPointer
        );
    }
}

#[test]
fn outputs_refuse_small_buffers_and_bad_indices() {
    let b = new_batch(&[params(5), params(5)]).unwrap();
    let mut buf = [0.0; 64];
    let mut written = 0;
    // SAFETY: live batch; buffers of 64 values, capacities at most that.
    unsafe {
        let s = sh_batch_state(b.0, 0, buf.as_mut_ptr(), null_mut(), 14, &mut written);
        assert_eq!((s, written), (ShStatus::BufferTooSmall, 15));
        let s = sh_batch_state(b.0, 2, buf.as_mut_ptr(), null_mut(), 64, &mut written);
        assert_eq!(s, ShStatus::IndexOutOfRange);
        let s = sh_batch_state(b.0, 0, null_mut(), null_mut(), 64, &mut written);
        assert_eq!(s, ShStatus::NullPointer);
        let s = sh_batch_centreline(b.0, 0, buf.as_mut_ptr(), 5, &mut written);
        assert_eq!((s, written), (ShStatus::BufferTooSmall, 6));
        let s = sh_batch_centreline(b.0, 1, buf.as_mut_ptr(), 6, null_mut());
        assert_eq!(s, ShStatus::Ok);
        let s = sh_batch_centreline(b.0, 2, buf.as_mut_ptr(), 6, &mut written);
        assert_eq!(s, ShStatus::IndexOutOfRange);
        let s = sh_batch_centreline(null(), 0, buf.as_mut_ptr(), 6, &mut written);
        assert_eq!(s, ShStatus::NullPointer);
        // read-only calls leave the last error alone
        assert_eq!(last_error(&b).status, ShStatus::Ok);
    }
}

fn centreline(b: &Batch, i: usize) -> Vec<[f64; 3]> {
    let mut xyz = [0.0; 63];
    let mut written = 0;
    // SAFETY: live batch, room for 21 points.
    let s = unsafe { sh_batch_centreline(b.0, i, xyz.as_mut_ptr(), 21, &mut written) };
    assert_eq!(s, ShStatus::Ok);
    xyz[..3 * written]
        .chunks(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect()
}

#[test]
fn centreline_is_in_world_coordinates_and_starts_at_the_root() {
    let mut p = params(10);
    p.root_position = [0.01, -0.02, 0.03];
    let b = new_batch(&[p]).unwrap();
    let local = centreline(&b, 0);
    assert_eq!(local.len(), 11);
    assert_eq!(local[0], p.root_position);
    // the ends of a natural helix of 0.2 m lie within its length of the root
    let tip = Vector3::from(local[10]) - Vector3::from(local[0]);
    assert!(tip.norm() > 0.0 && tip.norm() < 0.2);
    let rotation = Rotation3::new(Vector3::new(0.4, -0.2, 0.9));
    let x = Vector3::new(1.0, 2.0, -0.5);
    let mut head = ShHeadState {
        position: x.into(),
        rotation: [0.0; 9],
        velocity: [0.0; 3],
        acceleration: [0.0; 3],
        angular_velocity: [0.0; 3],
        angular_acceleration: [0.0; 3],
        moves: 0,
    };
    head.rotation.copy_from_slice(rotation.matrix().as_slice());
    // SAFETY: live batch, valid head.
    assert_eq!(unsafe { sh_batch_set_head(b.0, &head) }, ShStatus::Ok);
    for (w, y) in centreline(&b, 0).iter().zip(&local) {
        let expected = x + rotation * Vector3::from(*y);
        assert!((Vector3::from(*w) - expected).amax() <= 1e-15);
    }
}

#[test]
fn a_moving_head_drives_the_strands() {
    let b = new_batch(&[params(5)]).unwrap();
    let mut head = ShHeadState {
        position: [0.0; 3],
        rotation: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        velocity: [0.2, 0.0, 0.0],
        acceleration: [3.0, 0.0, 0.0],
        angular_velocity: [0.0, 0.0, 1.0],
        angular_acceleration: [0.0, 0.0, 5.0],
        moves: 1,
    };
    // SAFETY: live batch, valid head.
    assert_eq!(unsafe { sh_batch_set_head(b.0, &head) }, ShStatus::Ok);
    let rest = state(&b, 0).0;
    for _ in 0..5 {
        assert_eq!(step(&b, 1.0 / 120.0), ShStatus::Ok);
    }
    let moved = state(&b, 0).0;
    assert!(moved.iter().zip(&rest).any(|(a, b)| a != b));
    // the same derivatives with a still head: nothing acts (no gravity), q stays
    let still = new_batch(&[params(5)]).unwrap();
    head.moves = 0;
    // SAFETY: live batch, valid head.
    assert_eq!(unsafe { sh_batch_set_head(still.0, &head) }, ShStatus::Ok);
    assert_eq!(step(&still, 1.0 / 120.0), ShStatus::Ok);
    assert_eq!(state(&still, 0).0, rest);
}

/// A workspace owned by the test.
struct Workspace(*mut ShWorkspace);

// SAFETY: a workspace is plain memory, used by one thread at a time here.
unsafe impl Send for Workspace {}

impl Drop for Workspace {
    fn drop(&mut self) {
        // SAFETY: from sh_workspace_new, freed once here.
        unsafe { sh_workspace_free(self.0) };
    }
}

fn workspace(n: usize) -> Workspace {
    let mut w = null_mut();
    // SAFETY: valid out pointer.
    assert_eq!(unsafe { sh_workspace_new(n, &mut w) }, ShStatus::Ok);
    Workspace(w)
}

/// The batch pointer, shared by threads that step disjoint ranges.
#[derive(Clone, Copy)]
struct Shared(*const ShBatch);

// SAFETY: the threads below step disjoint ranges of the batch, each with its own
// workspace, and nothing else touches it meanwhile (sh_batch_step_range's contract).
unsafe impl Send for Shared {}

#[test]
fn ranges_stepped_from_threads_equal_the_whole_batch_step() {
    let strands: Vec<ShStrandParams> = (0..6)
        .map(|k| {
            let mut p = params(5);
            p.length = 0.1 + 0.02 * k as f64;
            p
        })
        .collect();
    let whole = new_batch(&strands).unwrap();
    let split = new_batch(&strands).unwrap();
    set_gravity(&whole);
    set_gravity(&split);
    let mut workspaces = [workspace(5), workspace(5)];
    for _ in 0..10 {
        assert_eq!(step(&whole, 1.0 / 30.0), ShStatus::Ok);
        let mut whole_report = junk_report();
        // SAFETY: live batch, valid report.
        assert_eq!(
            unsafe { sh_batch_last_step(whole.0, &mut whole_report) },
            ShStatus::Ok
        );
        let shared = Shared(split.0);
        let rotations: Vec<f64> = std::thread::scope(|scope| {
            let handles: Vec<_> = workspaces
                .iter_mut()
                .enumerate()
                .map(|(k, ws)| {
                    scope.spawn(move || {
                        let (shared, ws) = (shared, ws);
                        let mut report = junk_report();
                        // SAFETY: disjoint ranges (0..3, 3..6), one workspace each.
                        let s = unsafe {
                            sh_batch_step_range(
                                shared.0,
                                3 * k,
                                3,
                                ws.0,
                                1.0 / 30.0,
                                &mut report,
                                null_mut(),
                            )
                        };
                        assert_eq!(s, ShStatus::Ok);
                        assert_eq!((report.stepped, report.failed), (3, 0));
                        assert_eq!(report.first_failed, usize::MAX);
                        report.max_element_rotation
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("range step"))
                .collect()
        });
        // the two ranges report the whole batch's largest rotation between them (the
        // strands fall under gravity: it is not zero)
        let largest = rotations.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        assert!(whole_report.max_element_rotation > 0.0);
        assert_eq!(largest, whole_report.max_element_rotation, "{rotations:?}");
    }
    for i in 0..6 {
        assert_eq!(state(&whole, i), state(&split, i), "strand {i}");
    }
    // refusals: range, workspace of another N, NULLs
    let other = workspace(6);
    let mut e = ShError::plain_for_tests();
    // SAFETY: live batch and workspaces, valid error pointer.
    unsafe {
        let w = workspaces[0].0;
        let s = sh_batch_step_range(split.0, 4, 3, w, 0.01, null_mut(), &mut e);
        assert_eq!((s, e.status), (ShStatus::IndexOutOfRange, s));
        let s = sh_batch_step_range(split.0, usize::MAX, 2, w, 0.01, null_mut(), null_mut());
        assert_eq!(s, ShStatus::IndexOutOfRange);
        let s = sh_batch_step_range(split.0, 0, 6, other.0, 0.01, null_mut(), &mut e);
        assert_eq!(s, ShStatus::WorkspaceMismatch);
        assert!(e.message_str().contains("N = 6"), "{e:?}");
        let s = sh_batch_step_range(split.0, 0, 6, null_mut(), 0.01, null_mut(), null_mut());
        assert_eq!(s, ShStatus::NullPointer);
        let s = sh_batch_step_range(split.0, 0, 6, w, 0.0, null_mut(), null_mut());
        assert_eq!(s, ShStatus::InvalidTimeStep);
        let s = sh_batch_step_range(split.0, 2, 0, w, 0.01, null_mut(), &mut e);
        assert_eq!((s, e.status), (ShStatus::Ok, ShStatus::Ok));
        let mut w = null_mut();
        assert_eq!(sh_workspace_new(7, &mut w), ShStatus::UnsupportedElements);
        assert!(w.is_null());
        assert_eq!(sh_workspace_new(5, null_mut()), ShStatus::NullPointer);
        sh_workspace_free(null_mut());
        sh_batch_free(null_mut());
    }
}

#[test]
fn a_step_at_the_largest_size_runs_on_a_small_stack() {
    // the batch and the workspace are made here; the step itself needs little stack
    let b = new_batch(&[params(20)]).unwrap();
    set_gravity(&b);
    let ws = workspace(20);
    let shared = Shared(b.0);
    std::thread::Builder::new()
        .stack_size(128 * 1024)
        .spawn(move || {
            let (shared, ws) = (shared, ws);
            for _ in 0..3 {
                // SAFETY: the only user of the batch and of the workspace meanwhile.
                let s = unsafe {
                    sh_batch_step_range(shared.0, 0, 1, ws.0, 1.0 / 30.0, null_mut(), null_mut())
                };
                assert_eq!(s, ShStatus::Ok);
            }
        })
        .unwrap()
        .join()
        .unwrap();
}

/// The C API's moving head against the runtime: a strand on a head turning at a constant
/// 90°/s about a tilted axis through the root (the C library given the head's state at
/// the end of each step, the runtime the `sudden-stop` motion before its stop), stepped
/// 30 times at 1/120 s by each: the same coordinates to 1e-12 relative (measured
/// 5e-21: the same step).
#[test]
fn a_moving_head_steps_the_strand_as_the_runtime_does() {
    let p = params(5);
    let b = new_batch(&[p]).unwrap();
    let axis = Vector3::new(0.2, 0.3, 1.0).normalize();
    let speed = 90f64.to_radians();
    let dt = 1.0 / 120.0;
    for k in 1..=30 {
        let t = k as f64 * dt;
        let rotation = Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), speed * t);
        let mut head = ShHeadState {
            position: [0.0; 3],
            rotation: [0.0; 9],
            velocity: [0.0; 3],
            acceleration: [0.0; 3],
            angular_velocity: (axis * speed).into(),
            angular_acceleration: [0.0; 3],
            moves: 1,
        };
        head.rotation.copy_from_slice(rotation.matrix().as_slice());
        // SAFETY: live batch, valid head.
        assert_eq!(unsafe { sh_batch_set_head(b.0, &head) }, ShStatus::Ok);
        assert_eq!(step(&b, dt), ShStatus::Ok);
    }
    let c_q = state(&b, 0).0;
    // the same strand in a scene: root frame (n0 along `direction`, n1 from `normal`),
    // cross-section, exact helix, friction and drag of `params`, no gravity
    let n0 = Vector3::new(0.3, 0.0, -1.0).normalize();
    let scene = format!(
        r#"
[simulation]
dt = {dt}
duration = {duration}
engine = "runtime"
[environment]
gravity = "none"
[head]
motion = {{ kind = "sudden-stop", axis = [{}, {}, {}], angular_speed_deg = 90.0, stop_time = 100.0, stop_duration = 1.0 }}
[[strands]]
length = 0.2
elements = 5
direction = [{}, {}, {}]
normal = [1.0, 0.0, 0.0]
radius = 50e-6
ellipticity = 1.0
youngs_modulus = 1.5e9
poisson = 0.48
density = 1300.0
helix_radius = 6e-3
helix_step = 5e-3
helix_form = "exact"
internal_friction = 5e-11
air_drag = 5e-6
"#,
        axis.x,
        axis.y,
        axis.z,
        n0.x,
        n0.y,
        n0.z,
        duration = 30.0 * dt,
    );
    let setup = superhelix_runtime::parse_scene(&scene).expect("scene");
    let mut sim = superhelix_runtime::Simulation::new(setup, None).expect("simulation");
    assert_eq!(
        sim.q(0),
        &state(&new_batch(&[p]).unwrap(), 0).0[..],
        "same start"
    );
    for _ in 0..30 {
        sim.step().expect("step");
    }
    let r_q = sim.q(0);
    let scale = r_q.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let dq = r_q
        .iter()
        .zip(&c_q)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
        / scale;
    let rest = state(&new_batch(&[p]).unwrap(), 0).0;
    let moved = r_q
        .iter()
        .zip(&rest)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
        / scale;
    println!("C API against the runtime on a turning head: {dq:.2e} relative (the strand moved {moved:.2e})");
    assert!(moved > 1e-4, "the turning head moved the strand: {moved:e}");
    assert!(dq <= 1e-12, "C {c_q:?}\nruntime {r_q:?}");
}
