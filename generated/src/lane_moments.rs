//! The closed-form element moments of W elements at once, one per lane: element k of W
//! strands of one N, the moments a step that advances W strands per call starts from
//! (docs/architecture.md, "Strands in lanes", part 2).
//!
//! Each of the three generated functions ([`crate::centreline_mass()`],
//! [`crate::centreline_force()`], [`crate::rotary_basis()`]) runs its closed-form branch on
//! all W lanes at once (`*_closed_lanes`), when any lane's `W l` is at or above its switch;
//! a lane below the switch (a nearly straight element, on the Taylor branch) takes the
//! scalar function and its outputs are written into that lane. Every lane therefore holds,
//! bit for bit, what the function gives for that lane's element alone
//! (`tests/lane_moments.rs`), whatever the other lanes hold.
//!
//! The outputs stay in the generated functions' flat order, one lane value per output
//! ([`LaneMoments`]); [`LaneMoments::lane_into`] turns one lane into an
//! [`ElementMoments`], the same bits as [`crate::element_moments_into`].

use crate::{
    centreline_force, centreline_force::centreline_force_closed_lanes, centreline_mass,
    centreline_mass::centreline_mass_closed_lanes, clear_rotary, element_wl, fill_force, fill_mass,
    fill_rotary, rotary_basis, rotary_basis::rotary_basis_closed_lanes, CENTRELINE_FORCE_SWITCH,
    CENTRELINE_MASS_SWITCH, ROTARY_BASIS_SWITCH,
};
use superhelix_kernels::lane::{Lane, Lanes, Mask};
use superhelix_kernels::lanes::F4;
use superhelix_kernels::moments::ElementMoments;

/// The outputs of the three generated element functions for W elements, one per lane, in
/// each function's order ([`crate::centreline_mass::CENTRELINE_MASS_OUTPUTS`], …).
#[derive(Debug, Clone, Copy)]
pub struct LaneMoments<const W: usize> {
    /// [`crate::centreline_mass()`]'s outputs: what M needs.
    pub mass: [Lanes<f64, W>; 51],
    /// [`crate::centreline_force()`]'s outputs: what only the force needs.
    pub force: [Lanes<f64, W>; 135],
    /// [`crate::rotary_basis()`]'s outputs: the rotary inertia's basis, per unit of each
    /// entry of D.
    pub rotary: [Lanes<f64, W>; 63],
}

impl<const W: usize> Default for LaneMoments<W> {
    fn default() -> Self {
        let zero = Lanes([0.0; W]);
        LaneMoments {
            mass: [zero; 51],
            force: [zero; 135],
            rotary: [zero; 63],
        }
    }
}

/// Which of the three functions [`element_moments_lanes_into`] evaluates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LaneParts {
    /// [`crate::centreline_mass()`].
    pub mass: bool,
    /// [`crate::centreline_force()`].
    pub force: bool,
    /// [`crate::rotary_basis()`] (skip it when no lane has rotary inertia).
    pub rotary: bool,
}

impl LaneParts {
    /// All three.
    pub const ALL: LaneParts = LaneParts {
        mass: true,
        force: true,
        rotary: true,
    };
}

impl<const W: usize> LaneMoments<W> {
    /// Lane `k`'s element as an [`ElementMoments`] with rotary inertia `rotary` = diag D:
    /// bit for bit [`crate::element_moments_into`] of that element (the fields of the
    /// parts evaluated; with `rotary` all zero the rotary fields are zero, as there).
    pub fn lane_into(&self, k: usize, rotary: &[f64; 3], out: &mut ElementMoments) {
        fill_mass(&lane_of(&self.mass, k), out);
        fill_force(&lane_of(&self.force, k), out);
        if rotary.iter().all(|&x| x == 0.0) {
            clear_rotary(out);
        } else {
            fill_rotary(&lane_of(&self.rotary, k), rotary, out);
        }
    }
}

/// Lane `k` of each of `o`.
fn lane_of<const W: usize, const K: usize>(o: &[Lanes<f64, W>; K], k: usize) -> [f64; K] {
    o.map(|x| x.0[k])
}

/// The element moments of W elements, lane k for Darboux vector `(d[0], d[1], d[2])`
/// and length `l` of lane k: the parts `parts` into `out` (the others left as they
/// were). Compiled with AVX2, taken when the CPU has it; the same bits on every path.
pub fn element_moments_lanes_into<const W: usize>(
    d: &[Lanes<f64, W>; 3],
    l: Lanes<f64, W>,
    parts: LaneParts,
    out: &mut LaneMoments<W>,
) {
    #[cfg(all(target_arch = "x86_64", feature = "std"))]
    {
        // AVX2, not AVX-512: on a Xeon with AVX-512, 16 elements' moments at W l = 30 took
        // 8.9 µs at 8 lanes with AVX2 against 14.0 with AVX-512, and 4 lanes with AVX2
        // were the fastest of all (7.0 µs; docs/performance.md, "Strands in lanes")
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            unsafe { lanes_avx2(d, l, parts, out) };
            return;
        }
    }
    element_moments_lanes_into_portable(d, l, parts, out);
}

/// [`element_moments_lanes_into`] compiled for the baseline target only (what it runs on
/// a CPU without AVX2); for the test that every path gives the same bits.
#[doc(hidden)]
#[inline(never)]
pub fn element_moments_lanes_into_portable<const W: usize>(
    d: &[Lanes<f64, W>; 3],
    l: Lanes<f64, W>,
    parts: LaneParts,
    out: &mut LaneMoments<W>,
) {
    lanes_body(d, l, parts, out, true);
}

#[cfg(all(target_arch = "x86_64", feature = "std"))]
#[target_feature(enable = "avx2")]
fn lanes_avx2<const W: usize>(
    d: &[Lanes<f64, W>; 3],
    l: Lanes<f64, W>,
    parts: LaneParts,
    out: &mut LaneMoments<W>,
) {
    lanes_body(d, l, parts, out, false);
}

/// The closed-form branch of one generated function on all W lanes: at four lanes the
/// `*_closed_x4` batch this crate compiles once (its portable build where `portable`;
/// the same generated text at W = 4, so the same bits), at any other width the
/// `*_closed_lanes` text inlined here. (Four lanes through the `x4` batches keep a crate
/// that calls this at four lanes from compiling the closed forms again: each width
/// compiled is two more copies of ~50 kB of straight-line code.)
macro_rules! closed {
    ($w:ident, $d:expr, $l:expr, $out:expr, $portable:expr, $x4:path, $x4_portable:path, $lanes:path, $k:literal) => {
        if const { $w == 4 } {
            let d4 = [0, 1, 2].map(|i| F4(core::array::from_fn(|k| $d[i].0[k])));
            let l4 = F4(core::array::from_fn(|k| $l.0[k]));
            let mut o4 = [F4::default(); $k];
            if $portable {
                $x4_portable(&d4, l4, &mut o4);
            } else {
                $x4(&d4, l4, &mut o4);
            }
            for (o, x) in $out.iter_mut().zip(&o4) {
                o.0 = core::array::from_fn(|k| x.0[k]);
            }
        } else {
            $lanes($d, $l, $out);
        }
    };
}

#[inline(always)]
fn lanes_body<const W: usize>(
    d: &[Lanes<f64, W>; 3],
    l: Lanes<f64, W>,
    parts: LaneParts,
    out: &mut LaneMoments<W>,
    portable: bool,
) {
    let element = |k: usize| [d[0].0[k], d[1].0[k], d[2].0[k]];
    // W l exactly as the functions' prologue computes it (their branch test)
    let wl = Lanes::<f64, W>::from_fn(|k| element_wl(&element(k), l.0[k]));
    if parts.mass {
        let taylor = wl.lt(Lanes::splat(CENTRELINE_MASS_SWITCH));
        if !taylor.all() {
            closed!(
                W,
                d,
                l,
                &mut out.mass,
                portable,
                crate::centreline_mass::centreline_mass_closed_x4,
                crate::centreline_mass::centreline_mass_closed_x4_portable,
                centreline_mass_closed_lanes,
                51
            );
        }
        each_taylor_lane(taylor, &element, l, centreline_mass, &mut out.mass);
    }
    if parts.force {
        let taylor = wl.lt(Lanes::splat(CENTRELINE_FORCE_SWITCH));
        if !taylor.all() {
            closed!(
                W,
                d,
                l,
                &mut out.force,
                portable,
                crate::centreline_force::centreline_force_closed_x4,
                crate::centreline_force::centreline_force_closed_x4_portable,
                centreline_force_closed_lanes,
                135
            );
        }
        each_taylor_lane(taylor, &element, l, centreline_force, &mut out.force);
    }
    if parts.rotary {
        let taylor = wl.lt(Lanes::splat(ROTARY_BASIS_SWITCH));
        if !taylor.all() {
            closed!(
                W,
                d,
                l,
                &mut out.rotary,
                portable,
                crate::rotary_basis::rotary_basis_closed_x4,
                crate::rotary_basis::rotary_basis_closed_x4_portable,
                rotary_basis_closed_lanes,
                63
            );
        }
        each_taylor_lane(taylor, &element, l, rotary_basis, &mut out.rotary);
    }
}

/// The lanes of `taylor` through the scalar function `one`, written into their lanes.
#[inline(always)]
fn each_taylor_lane<const W: usize, const K: usize>(
    taylor: Mask<W>,
    element: &impl Fn(usize) -> [f64; 3],
    l: Lanes<f64, W>,
    one: fn(&[f64; 3], f64, &mut [f64; K]),
    out: &mut [Lanes<f64, W>; K],
) {
    if !taylor.any() {
        return;
    }
    let mut single = [0.0; K];
    for k in (0..W).filter(|&k| taylor.0[k]) {
        one(&element(k), l.0[k], &mut single);
        for (o, &x) in out.iter_mut().zip(&single) {
            o.0[k] = x;
        }
    }
}
