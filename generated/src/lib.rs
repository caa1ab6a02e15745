//! # superhelix-generated
//!
//! Closed-form Super-Helix kernels written by `superhelix-codegen` (never edited by hand;
//! regenerate with `cargo run -p superhelix-codegen --release`, and the test
//! `generated_files_are_fresh` fails with the stale file's name when they are out of date).
//!
//! Every per-element integral of the moment-based assembly
//! (`superhelix_kernels::moments::ElementMoments`) is generated in closed form, in three
//! functions with their own Taylor switch and degree (see each file's header):
//! [`centreline_mass()`] (what M needs), [`centreline_force()`] (what only the force needs)
//! and [`rotary_basis()`] (the rotary inertia); [`element_moments_into`] fills every field,
//! [`mass_moments`] only those of M. [`element_point_into`] gives an element's local
//! functions at one abscissa, [`element_rotary_point_into`] the same without the second
//! derivatives `d2p` (what the rotary-inertia quadrature reads), and
//! [`element_rotary_points_into`] that at four abscissae at once (SIMD lanes).
//! [`ClosedForm`] is all of them as a `MomentSource`: what the runtime's kernels and the
//! fixed-N step of `superhelix_kernels::fixed` (re-exported as [`kernels`]) run on.
//!
//! The crate is `#![no_std]` and allocates nothing; the `std` feature (the runtime's) takes
//! the elementary functions from std and picks AVX2 code at run time.
//!
//! In f32, for engines that compute in f32: [`centreline_mass_f32()`],
//! [`centreline_force_f32()`], [`rotary_basis_f32()`] and [`element_point_f32()`] (into a
//! flat array named by [`ELEMENT_POINT_F32_OUTPUTS`]), scalar, with switches and Taylor
//! degrees chosen for f32 (docs/kernels.md, "f32 kernels", has what f32 costs against
//! f64).
#![no_std]
#![warn(missing_docs)]

#[cfg(feature = "std")]
extern crate std;

/// The no_std core the generated code runs on (element, moments, the fixed-N step).
pub use superhelix_kernels as kernels;

/// Generated: the centreline moments of M (see the file's header for op counts).
#[rustfmt::skip]
#[allow(clippy::all, clippy::pedantic, missing_docs, unused_parens, non_snake_case)]
pub mod centreline_mass;

/// Generated: the force-only centreline moments (see the file's header for op counts).
#[rustfmt::skip]
#[allow(clippy::all, clippy::pedantic, missing_docs, unused_parens, non_snake_case)]
pub mod centreline_force;

/// Generated: the rotary-inertia basis (see the file's header for op counts).
#[rustfmt::skip]
#[allow(clippy::all, clippy::pedantic, missing_docs, unused_parens, non_snake_case)]
pub mod rotary_basis;

pub use centreline_force::{centreline_force, centreline_force_closed_x4, CENTRELINE_FORCE_SWITCH};
pub use centreline_mass::{centreline_mass, centreline_mass_closed_x4, CENTRELINE_MASS_SWITCH};
pub use rotary_basis::{rotary_basis, rotary_basis_closed_x4, ROTARY_BASIS_SWITCH};
use superhelix_kernels::lanes::F4;

/// Generated: the numbers of elements with checked-in kernels.
pub mod sizes;

include!(concat!(env!("OUT_DIR"), "/extra_sizes.rs"));

use nalgebra::{Matrix3, Vector3};
use superhelix_kernels::element::{ElementPoint, RotaryPoints};
use superhelix_kernels::moments::ElementMoments;
use superhelix_kernels::strand_terms::MomentSource;

/// The closed-form element integrals and local functions.
#[derive(Debug, Clone, Copy, Default)]
pub struct ClosedForm;

impl MomentSource for ClosedForm {
    fn moments(&self, d: &Vector3<f64>, l: f64, rotary: &[f64; 3], out: &mut ElementMoments) {
        crate::element_moments_into(d, l, rotary, out);
    }
    fn moments_batch(
        &self,
        d: &[Vector3<f64>],
        l: &[f64],
        rotary: &[f64; 3],
        out: &mut [ElementMoments],
    ) {
        crate::element_moments_batch_into(d, l, rotary, out);
    }
    fn mass_moments_batch(
        &self,
        d: &[Vector3<f64>],
        l: &[f64],
        rotary: &[f64; 3],
        out: &mut [ElementMoments],
    ) {
        crate::mass_moments_batch_into(d, l, rotary, out);
    }
    fn point(&self, d: &Vector3<f64>, u: f64, out: &mut ElementPoint) {
        crate::element_point_into(d, u, out);
    }
    fn rotary_point(&self, d: &Vector3<f64>, u: f64, out: &mut ElementPoint) {
        crate::element_rotary_point_into(d, u, out);
    }
    fn rotary_points(&self, d: &Vector3<f64>, u: &[f64], out: &mut RotaryPoints) {
        crate::element_rotary_points_into(d, u, out);
    }
    fn describe(&self) -> &'static str {
        "closed form"
    }
    fn is_generated(&self) -> bool {
        true
    }
}

/// Index of entry (r, c) in the packed upper triangle (00, 01, 02, 11, 12, 22).
const SYM: [[usize; 3]; 3] = [[0, 1, 2], [1, 3, 4], [2, 4, 5]];

/// Offsets in the output of [`centreline_force`] of `dpdpt_i_j_…` for i ≤ j, in the
/// packed order 00, 01, 02, 11, 12, 22 (6 entries for i = j, 9 for i < j).
const DPDPT: [usize; 6] = [72, 78, 87, 96, 102, 111];

/// `(v_1 w_2 − v_2 w_1, …)` from `n(a, b)` = ∫ v_a w_b: ∫ v × w.
fn cross_of(n: impl Fn(usize, usize) -> f64) -> Vector3<f64> {
    Vector3::new(n(1, 2) - n(2, 1), n(2, 0) - n(0, 2), n(0, 1) - n(1, 0))
}

/// The fields of M's centreline moments from the output of [`centreline_mass`].
fn fill_mass(o: &[f64; 51], m: &mut ElementMoments) {
    let sym3 = |base: usize| Matrix3::from_fn(|r, c| o[base + SYM[r][c]]);
    m.first = Vector3::new(o[0], o[1], o[2]);
    m.second = sym3(3);
    m.gram = sym3(45);
    for i in 0..3 {
        m.dfirst[i] = Vector3::new(o[9 + 3 * i], o[10 + 3 * i], o[11 + 3 * i]);
        // pdp_a_i_b = ∫ p_a (∂_i p)_b at 18 + 9a + 3i + b
        let pdp = |a: usize, b: usize| o[18 + 9 * a + 3 * i + b];
        m.cross[i] = cross_of(pdp);
        m.pdp[i] = Matrix3::from_fn(pdp);
    }
}

/// The force-only fields from the output of [`centreline_force`].
fn fill_force(o: &[f64; 135], m: &mut ElementMoments) {
    for i in 0..3 {
        for j in 0..3 {
            let pij = SYM[i][j];
            m.d2first[i][j] = Vector3::new(o[3 * pij], o[3 * pij + 1], o[3 * pij + 2]);
            // pd2p_ij_a_b = ∫ p_a (∂_ij p)_b at 18 + 9 P(i, j) + 3a + b
            let pd2p = |a: usize, b: usize| o[18 + 9 * pij + 3 * a + b];
            m.pd2p[i][j] = Matrix3::from_fn(pd2p);
            m.cross2[i][j] = cross_of(pd2p);
            // dpdpt_i_j_a_b = ∫ (∂_i p)_a (∂_j p)_b, stored for i ≤ j
            let base = DPDPT[pij];
            m.dpdp[i][j] = Matrix3::from_fn(|a, b| {
                let (a, b) = if i <= j { (a, b) } else { (b, a) };
                if i == j {
                    o[base + SYM[a][b]]
                } else {
                    o[base + 3 * a + b]
                }
            });
            // dpd2p_i_jk at 117 + 6i + P(j, k)
            for k in 0..3 {
                m.dpd2p[i][j][k] = o[117 + 6 * i + SYM[j][k]];
            }
        }
    }
}

/// The rotary fields for D = diag(`rotary`) from the output of [`rotary_basis`].
fn fill_rotary(o: &[f64; 63], rotary: &[f64; 3], m: &mut ElementMoments) {
    m.rot = Matrix3::zeros();
    m.rot_w = [Vector3::zeros(); 3];
    m.rot_ww = Matrix3::zeros();
    for (a, &da) in rotary.iter().enumerate() {
        // ee_a_rc at 21a + P(r, c), eew_a_j_r at 21a + 6 + 3j + r, eww_a_ij at 21a + 15 + P(i, j)
        let base = 21 * a;
        m.rot += Matrix3::from_fn(|r, c| o[base + SYM[r][c]]) * da;
        for j in 0..3 {
            let v = Vector3::new(
                o[base + 6 + 3 * j],
                o[base + 7 + 3 * j],
                o[base + 8 + 3 * j],
            );
            m.rot_w[j] += v * da;
        }
        m.rot_ww += Matrix3::from_fn(|r, c| o[base + 15 + SYM[r][c]]) * da;
    }
}

/// The rotary fields of an element without rotary inertia.
fn clear_rotary(m: &mut ElementMoments) {
    m.rot = Matrix3::zeros();
    m.rot_w = [Vector3::zeros(); 3];
    m.rot_ww = Matrix3::zeros();
}

/// The rotary part: the basis is skipped when the rotary inertia is zero.
fn rotary_into(d: &[f64; 3], l: f64, rotary: &[f64; 3], m: &mut ElementMoments) {
    if rotary.iter().all(|&x| x == 0.0) {
        clear_rotary(m);
    } else {
        let mut o = [0.0; 63];
        rotary_basis(d, l, &mut o);
        fill_rotary(&o, rotary, m);
    }
}

/// Every field of the element moments (`superhelix_kernels::moments::ElementMoments`)
/// in closed form, for Darboux vector `d`, length `l` and rotary inertia `rotary` =
/// diag D: the same integrals as `ElementMoments::by_quadrature`. Allocates nothing and
/// cannot panic.
pub fn element_moments_into(d: &Vector3<f64>, l: f64, rotary: &[f64; 3], out: &mut ElementMoments) {
    let dd = [d[0], d[1], d[2]];
    let mut om = [0.0; 51];
    centreline_mass(&dd, l, &mut om);
    fill_mass(&om, out);
    let mut of = [0.0; 135];
    centreline_force(&dd, l, &mut of);
    fill_force(&of, out);
    rotary_into(&dd, l, rotary, out);
}

/// [`element_moments_into`] for several elements (`d[p]`, `l[p]` into `out[p]`), one
/// generated function at a time over all of them (its code, ~10–35 kB of instructions on
/// one branch, fetched once per strand instead of once per element), and the elements
/// in a function's closed-form branch four at a time in SIMD lanes (`*_closed_x4`): the
/// same values, bit for bit, as element by element (`tests/generated.rs`).
pub fn element_moments_batch_into(
    d: &[Vector3<f64>],
    l: &[f64],
    rotary: &[f64; 3],
    out: &mut [ElementMoments],
) {
    moments_batch(d, l, rotary, out, true);
}

/// [`element_moments_batch_into`] for the fields of M only (the `mass_moments` fields;
/// the force-only fields are left as they were): the same bits for those fields.
pub fn mass_moments_batch_into(
    d: &[Vector3<f64>],
    l: &[f64],
    rotary: &[f64; 3],
    out: &mut [ElementMoments],
) {
    moments_batch(d, l, rotary, out, false);
}

/// The batch of [`element_moments_batch_into`], with the force-only fields when `force`.
fn moments_batch(
    d: &[Vector3<f64>],
    l: &[f64],
    rotary: &[f64; 3],
    out: &mut [ElementMoments],
    force: bool,
) {
    let n = d.len().min(l.len()).min(out.len());
    let dd = |p: usize| [d[p][0], d[p][1], d[p][2]];
    each_element(
        n,
        &dd,
        l,
        CENTRELINE_MASS_SWITCH,
        centreline_mass,
        centreline_mass_closed_x4,
        |p, o: &[f64; 51]| fill_mass(o, &mut out[p]),
    );
    if force {
        each_element(
            n,
            &dd,
            l,
            CENTRELINE_FORCE_SWITCH,
            centreline_force,
            centreline_force_closed_x4,
            |p, o: &[f64; 135]| fill_force(o, &mut out[p]),
        );
    }
    if rotary.iter().all(|&x| x == 0.0) {
        out[..n].iter_mut().for_each(clear_rotary);
    } else {
        each_element(
            n,
            &dd,
            l,
            ROTARY_BASIS_SWITCH,
            rotary_basis,
            rotary_basis_closed_x4,
            |p, o: &[f64; 63]| fill_rotary(o, rotary, &mut out[p]),
        );
    }
}

/// `W l` exactly as the generated functions' prologue computes it (their branch test).
fn element_wl(d: &[f64; 3], l: f64) -> f64 {
    superhelix_kernels::math::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) * l
}

/// Run one generated element function over elements `0..n` and hand each element's
/// outputs to `fill`: the elements at or above `switch` (its closed-form branch) in
/// groups of four through `x4` (a last group of two or three padded with copies of its
/// last element, whose lanes are not read), the others one by one through `one`.
fn each_element<const K: usize>(
    n: usize,
    d: &dyn Fn(usize) -> [f64; 3],
    l: &[f64],
    switch: f64,
    one: fn(&[f64; 3], f64, &mut [f64; K]),
    x4: fn(&[F4; 3], F4, &mut [F4; K]),
    mut fill: impl FnMut(usize, &[f64; K]),
) {
    let mut single = [0.0; K];
    let mut group = [0usize; 4];
    let mut used = 0;
    for p in 0..n {
        if element_wl(&d(p), l[p]) < switch {
            one(&d(p), l[p], &mut single);
            fill(p, &single);
            continue;
        }
        group[used] = p;
        used += 1;
        if used == 4 {
            closed_group(&group[..used], d, l, one, x4, &mut fill);
            used = 0;
        }
    }
    if used > 0 {
        closed_group(&group[..used], d, l, one, x4, &mut fill);
    }
}

/// The elements `group` (one to four, all in the closed-form branch) through `x4`, the
/// unused lanes repeating the last element, or a lone element through `one` (measured:
/// as fast, and it does not pay for four lanes).
fn closed_group<const K: usize>(
    group: &[usize],
    d: &dyn Fn(usize) -> [f64; 3],
    l: &[f64],
    one: fn(&[f64; 3], f64, &mut [f64; K]),
    x4: fn(&[F4; 3], F4, &mut [F4; K]),
    fill: &mut impl FnMut(usize, &[f64; K]),
) {
    let mut single = [0.0; K];
    if let [p] = group {
        one(&d(*p), l[*p], &mut single);
        fill(*p, &single);
        return;
    }
    let at = |k: usize| group[k.min(group.len() - 1)];
    let ds = [d(at(0)), d(at(1)), d(at(2)), d(at(3))];
    let lane_d = |i: usize| F4([ds[0][i], ds[1][i], ds[2][i], ds[3][i]]);
    let lane_l = F4([l[at(0)], l[at(1)], l[at(2)], l[at(3)]]);
    let mut lanes = [F4([0.0; 4]); K];
    x4(&[lane_d(0), lane_d(1), lane_d(2)], lane_l, &mut lanes);
    for (k, &p) in group.iter().enumerate() {
        for (s, x) in single.iter_mut().zip(&lanes) {
            *s = x.0[k];
        }
        fill(p, &single);
    }
}

/// [`element_moments_into`] into a new value.
pub fn element_moments(d: &Vector3<f64>, l: f64, rotary: &[f64; 3]) -> ElementMoments {
    let mut m = ElementMoments::default();
    element_moments_into(d, l, rotary, &mut m);
    m
}

/// The element moments that M and the first-moment Jacobian need
/// (`superhelix_kernels::moments::assemble_mass_and_gravity`), in closed form: `first`,
/// `second`, `dfirst`, `cross`, `gram`, `pdp` and the rotary fields, without the cost of
/// the force-only ones (`d2first`, `cross2`, `pd2p`, `dpdp`, `dpd2p`), which are left at
/// zero: `assemble_force` needs [`element_moments`].
pub fn mass_moments(d: &Vector3<f64>, l: f64, rotary: &[f64; 3]) -> ElementMoments {
    let dd = [d[0], d[1], d[2]];
    let mut m = ElementMoments::default();
    let mut om = [0.0; 51];
    centreline_mass(&dd, l, &mut om);
    fill_mass(&om, &mut m);
    rotary_into(&dd, l, rotary, &mut m);
    m
}

/// Generated: the element's local functions at one abscissa, `ElementPoint` in closed
/// form (see the file's header for the switch, agreement and op counts).
#[rustfmt::skip]
#[allow(clippy::all, clippy::pedantic, missing_docs, unused_parens, non_snake_case)]
pub mod element_point;
pub use element_point::{element_point, element_point_into, ELEMENT_POINT_SWITCH};

/// Generated: the fields of `ElementPoint` the rotary-inertia quadrature reads (all but
/// `d2p`) at one abscissa (see the file's header for the switch, agreement and op
/// counts).
#[rustfmt::skip]
#[allow(clippy::all, clippy::pedantic, missing_docs, unused_parens, non_snake_case)]
pub mod element_rotary_point;
pub use element_rotary_point::{
    element_rotary_point_into, element_rotary_points_into, ELEMENT_ROTARY_POINT_SWITCH,
};

/// Generated: the centreline moments of M in f32 (see the file's header for the switch,
/// the f32 errors and op counts).
#[rustfmt::skip]
#[allow(clippy::all, clippy::pedantic, missing_docs, unused_parens, non_snake_case)]
pub mod centreline_mass_f32;

/// Generated: the force-only centreline moments in f32 (see the file's header).
#[rustfmt::skip]
#[allow(clippy::all, clippy::pedantic, missing_docs, unused_parens, non_snake_case)]
pub mod centreline_force_f32;

/// Generated: the rotary-inertia basis in f32 (see the file's header).
#[rustfmt::skip]
#[allow(clippy::all, clippy::pedantic, missing_docs, unused_parens, non_snake_case)]
pub mod rotary_basis_f32;

/// Generated: the element's local functions at one abscissa in f32, into a flat array
/// (see the file's header).
#[rustfmt::skip]
#[allow(clippy::all, clippy::pedantic, missing_docs, unused_parens, non_snake_case)]
pub mod element_point_f32;

pub use centreline_force_f32::{centreline_force_f32, CENTRELINE_FORCE_F32_SWITCH};
pub use centreline_mass_f32::{centreline_mass_f32, CENTRELINE_MASS_F32_SWITCH};
pub use element_point_f32::{
    element_point_f32, ELEMENT_POINT_F32_OUTPUTS, ELEMENT_POINT_F32_SWITCH,
};
pub use rotary_basis_f32::{rotary_basis_f32, ROTARY_BASIS_F32_SWITCH};
