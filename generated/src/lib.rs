//! # superhelix-generated
//!
//! Closed-form Super-Helix kernels written by `superhelix-codegen` (never edited by hand;
//! regenerate with `cargo run -p superhelix-codegen --release`, and the test
//! `generated_files_are_fresh` fails with the stale file's name when they are out of date).
//!
//! Status (issue #3, in progress): the per-element closed-form integrals of the
//! moment-based assembly of M and the first-moment Jacobian are generated
//! ([`element_moments`]) and feed `superhelix_runtime::moments`; the fixed-N kernels
//! implementing `StrandKernel` are not written yet, so [`kernel_factory`] offers none.
#![warn(missing_docs)]

/// Generated: closed-form element integrals (see the file's header for op counts).
#[rustfmt::skip]
#[allow(clippy::all, clippy::pedantic, missing_docs, unused_parens, non_snake_case)]
pub mod element_moments;

pub mod factory;
mod interim;
/// Generated: the numbers of elements with checked-in kernels.
pub mod sizes;

pub use factory::{ClosedForm, GeneratedFactory, GeneratedKernel};
pub use interim::{element_moments_into, element_point_into};
use superhelix_runtime::moments::ElementMoments;
use superhelix_runtime::{KernelFactory, Matrix3, Vector3};

/// Index of entry (r, c) in the packed upper triangle (00, 01, 02, 11, 12, 22).
const SYM: [[usize; 3]; 3] = [[0, 1, 2], [1, 3, 4], [2, 4, 5]];

/// The element moments that M and the first-moment Jacobian need
/// (`superhelix_runtime::moments::assemble_mass_and_gravity`), in closed form, for Darboux
/// vector `d`, length `l` and rotary inertia `rotary` = diag D. The force-only fields
/// (`d2first`, `cross2`, `dpdp`, `dpd2p`) are left at zero: their closed forms are not
/// generated yet, so `assemble_force` must not be fed from here.
pub fn mass_moments(d: &Vector3<f64>, l: f64, rotary: &[f64; 3]) -> ElementMoments {
    let mut o = [0.0; 114];
    element_moments::element_moments(&[d[0], d[1], d[2]], l, &mut o);
    let sym3 = |base: usize| Matrix3::from_fn(|r, c| o[base + SYM[r][c]]);
    let mut m = ElementMoments {
        first: Vector3::new(o[0], o[1], o[2]),
        second: sym3(3),
        gram: sym3(45),
        ..Default::default()
    };
    for i in 0..3 {
        m.dfirst[i] = Vector3::new(o[9 + 3 * i], o[10 + 3 * i], o[11 + 3 * i]);
        // ∫ p × ∂_i p from pdp_a_i_b = ∫ p_a (∂_i p)_b at 18 + 9a + 3i + b
        let pdp = |a: usize, b: usize| o[18 + 9 * a + 3 * i + b];
        m.cross[i] = Vector3::new(
            pdp(1, 2) - pdp(2, 1),
            pdp(2, 0) - pdp(0, 2),
            pdp(0, 1) - pdp(1, 0),
        );
        m.pdp[i] = Matrix3::from_fn(pdp);
    }
    for (a, &da) in rotary.iter().enumerate() {
        let base = 51 + 21 * a;
        m.rot += sym3(base) * da;
        for j in 0..3 {
            let v = Vector3::new(
                o[base + 6 + 3 * j],
                o[base + 7 + 3 * j],
                o[base + 8 + 3 * j],
            );
            m.rot_w[j] += v * da;
        }
        m.rot_ww += sym3(base + 15) * da;
    }
    m
}

/// The generated kernels of this build (see [`factory::sizes`]).
pub fn kernel_factory() -> Option<&'static dyn KernelFactory> {
    static FACTORY: GeneratedFactory = GeneratedFactory;
    Some(&FACTORY)
}
