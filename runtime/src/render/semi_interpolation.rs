//! The semi-interpolating scheme of the paper (section 4.1 and Figure 4): each render
//! strand is a blend of its guides, fully interpolated near the root and following its
//! dominant guide near the tip, with guides whose tips are too far apart left out.
//!
//! Guide k of a render strand with root r (head coordinates) carries the offset
//! o_k = r − root_k (head coordinates), turned with the head: at a frame where the head
//! has rotation R and guide k has centreline points `P_k[j]` (world, root first), the guide
//! proposes the point `P_k[j] + R o_k` for sample j (its own shape, moved so that its root
//! falls on the render root). The render strand's sample j is
//!
//! ```text
//! S[j] = Σ_k ω_k(j) (P_k[j] + R o_k),   ω_k(j) = (1 − c_j) w̃_k + c_j [k = d]
//! ```
//!
//! where d is the dominant guide, c_j = c(u_j) the clumping profile at the arc-length
//! fraction u_j of the dominant guide's sample j ([`super::settings::clump_profile`]), and
//! w̃ the root weights w with the tip criterion applied: w̃_k ∝ w_k φ(|tip_k − tip_d|),
//! φ = 1 up to 3/4 of `tip_distance`, 0 from `tip_distance` on, smoothstep between (so
//! that a guide leaves the blend without a jump in time), renormalised to sum 1 (the
//! dominant guide always stays). Every ω sums to 1. At the root every guide proposes r
//! itself, so `S[0] = X + R r` whatever the weights; with c ≡ 0 the strand is the classic
//! interpolation `Σ w̃_k P_k[j]` plus the turned offset of r from the weighted root; with
//! c ≡ 1 it is its dominant guide moved to r (a lock of fixed offset).
//!
//! The per-frame work allocates nothing: the guides are converted into a reused f32
//! buffer, and the render strands are written into a reused f32 buffer, in parallel over
//! chunks of strands (rayon).
//!
//! With bodies ([`SemiInterpolation::keep_out`]), [`SemiInterpolation::frame_at`] then
//! moves every render point that comes nearer a body than the clearance out of it
//! ([`super::clearance`]).

use super::clearance::{Frame, KeepOut, Row, LANES};
#[cfg(target_arch = "x86_64")]
use super::lanes::Avx;
use super::lanes::Lanes;
use super::render_roots::RenderRoots;
use super::settings::{clump_profile, smoothstep, RenderSettings};
use crate::bodies::{Body, Placement};
use crate::error::{Error, Result};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;
use wide::f32x8;

/// Render strands per parallel task.
const CHUNK: usize = 256;
/// Fraction of `tip_distance` from which a guide starts leaving a blend.
const TIP_FADE_START: f64 = 0.75;

/// A render strand's data for the per-frame blend, f32.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Blend {
    guides: [u32; 3],
    weights: [f32; 3],
    dominant: u8,
    /// o_k = r − root_k, head coordinates, m.
    offsets: [[f32; 3]; 3],
}

/// The render strands of a set of guides: roots placed once, centrelines generated per
/// frame.
#[derive(Debug, Clone, PartialEq)]
pub struct SemiInterpolation {
    roots: RenderRoots,
    blends: Vec<Blend>,
    guides: usize,
    points: usize,
    /// c(u) of each guide's samples, guide-major.
    profile: Vec<f32>,
    tip_distance: Option<f32>,
    guide_points: Vec<[f32; 3]>,
    out: Vec<[f32; 3]>,
    /// The bodies the strands keep out of (`None`: none).
    keep_out: Option<KeepOut>,
    /// Per chunk of strands, one group's rows of points and offsets (only with bodies).
    scratch: Vec<Row>,
    /// Use the portable SIMD path even on a CPU with AVX2 (to compare the two).
    portable: bool,
}

impl SemiInterpolation {
    /// The render strands of `settings` for guides whose centrelines at rest are `rest`
    /// (head coordinates, `points` samples per guide, root first, guide after guide),
    /// roots projected onto `scalp` (a body of head coordinates) when given. An error when
    /// `rest` is not a whole number of guides of at least 2 points, or is not finite.
    pub fn new(
        settings: &RenderSettings,
        rest: &[Vector3<f64>],
        points: usize,
        scalp: Option<&Body>,
    ) -> Result<Self> {
        Self::subset(settings, rest, points, scalp, 0..settings.strands)
    }

    /// [`SemiInterpolation::new`] with only the render strands of indices `indices`
    /// (each below `settings.strands`; e.g. every k-th for a picture): they are the same
    /// strands as in the whole set ([`RenderRoots::place_subset`]).
    pub fn subset(
        settings: &RenderSettings,
        rest: &[Vector3<f64>],
        points: usize,
        scalp: Option<&Body>,
        indices: impl Iterator<Item = usize>,
    ) -> Result<Self> {
        check_guides(rest, points)?;
        let (roots, directions) = guide_roots(rest, points);
        let placed = RenderRoots::place_subset(&roots, &directions, settings, scalp, indices);
        Self::with_roots(settings, rest, points, placed)
    }

    /// [`SemiInterpolation::new`] with render roots placed by the caller (e.g.
    /// [`RenderRoots::at_positions`]); `settings.strands` and the placement fields are not
    /// used. An error when a root names a guide that `rest` does not have.
    pub fn with_roots(
        settings: &RenderSettings,
        rest: &[Vector3<f64>],
        points: usize,
        placed: RenderRoots,
    ) -> Result<Self> {
        check_guides(rest, points)?;
        let guides = rest.len() / points;
        if placed
            .roots
            .iter()
            .any(|r| r.guides.iter().any(|&g| g as usize >= guides))
        {
            return Err(Error::invalid(
                "render",
                format!("a render root names a guide beyond the {guides} guides"),
            ));
        }
        let roots: Vec<Vector3<f64>> = (0..guides).map(|g| rest[g * points]).collect();
        let mut profile = Vec::with_capacity(guides * points);
        for g in 0..guides {
            let line = &rest[g * points..(g + 1) * points];
            let mut s = vec![0.0; points];
            for j in 1..points {
                s[j] = s[j - 1] + (line[j] - line[j - 1]).norm();
            }
            let length = s[points - 1];
            for &sj in &s {
                let u = if length > 0.0 { sj / length } else { 0.0 };
                profile.push(clump_profile(settings.clumping, u) as f32);
            }
        }
        let blends = placed
            .roots
            .iter()
            .map(|r| Blend {
                guides: r.guides,
                weights: r.weights.map(|w| w as f32),
                dominant: r.dominant,
                offsets: [0, 1, 2].map(|k| {
                    let o = r.position - roots[r.guides[k] as usize];
                    [o.x as f32, o.y as f32, o.z as f32]
                }),
            })
            .collect::<Vec<_>>();
        let strands = blends.len();
        Ok(Self {
            roots: placed,
            blends,
            guides,
            points,
            profile,
            tip_distance: settings.tip_distance.map(|d| d as f32),
            guide_points: vec![[0.0; 3]; guides * points],
            out: vec![[0.0; 3]; strands * points],
            keep_out: None,
            scratch: Vec::new(),
            portable: false,
        })
    }

    /// Keep the render strands of [`SemiInterpolation::frame_at`] out of `keep_out`'s
    /// bodies (none: no change to the blend).
    pub fn keep_out(mut self, keep_out: KeepOut) -> Self {
        if keep_out.bodies().is_empty() {
            self.keep_out = None;
            self.scratch = Vec::new();
        } else {
            self.scratch = vec![
                [[0.0; LANES]; 3];
                self.blends.len().div_ceil(CHUNK)
                    * KeepOut::scratch_len(self.points)
            ];
            self.keep_out = Some(keep_out);
        }
        self
    }

    /// The same strands computed on the portable SIMD path even on a CPU with AVX2.
    #[cfg(test)]
    pub(super) fn portable(mut self) -> Self {
        self.portable = true;
        self
    }

    /// The bodies the render strands keep out of, if any.
    pub fn bodies(&self) -> Option<&KeepOut> {
        self.keep_out.as_ref()
    }

    /// Number of render strands.
    pub fn strand_count(&self) -> usize {
        self.blends.len()
    }

    /// Points per render strand (= per guide).
    pub fn points_per_strand(&self) -> usize {
        self.points
    }

    /// Number of guides.
    pub fn guide_count(&self) -> usize {
        self.guides
    }

    /// The render roots and the sites they were drawn from.
    pub fn roots(&self) -> &RenderRoots {
        &self.roots
    }

    /// The render strands of one frame, blended only (not kept out of the bodies):
    /// `guides` are the guides' centrelines in world coordinates (the layout of `new`),
    /// `rotation` the head's rotation R (head to world). Returns every render strand's
    /// points, strand after strand, world coordinates, m; allocates nothing. An error when
    /// `guides` has the wrong length.
    pub fn frame(&mut self, guides: &[[f64; 3]], rotation: &Matrix3<f64>) -> Result<&[[f32; 3]]> {
        self.generate(guides, rotation, None)
    }

    /// [`SemiInterpolation::frame`] with the head in state `at.head`, then kept out of the
    /// bodies of [`SemiInterpolation::keep_out`] placed at `at` (bodies on the head at its
    /// state, bodies on their own motion at their pose of `at.time`). Without bodies the
    /// points are those of `frame(guides, &at.head.rotation)`, bit for bit.
    pub fn frame_at(&mut self, guides: &[[f64; 3]], at: &Placement) -> Result<&[[f32; 3]]> {
        self.generate(guides, &at.head.rotation, Some(at))
    }

    /// The blend, and the bodies when `head` is given and there are some.
    fn generate(
        &mut self,
        guides: &[[f64; 3]],
        rotation: &Matrix3<f64>,
        head: Option<&Placement>,
    ) -> Result<&[[f32; 3]]> {
        if guides.len() != self.guides * self.points {
            return Err(Error::invalid(
                "render",
                format!(
                    "expected {} guide points ({} guides of {}), got {}",
                    self.guides * self.points,
                    self.guides,
                    self.points,
                    guides.len()
                ),
            ));
        }
        for (b, p) in self.guide_points.iter_mut().zip(guides) {
            *b = p.map(|v| v as f32);
        }
        let m = self.points;
        let inputs = Inputs {
            guide_points: &self.guide_points,
            profile: &self.profile,
            m,
            r: rotation.map(|v| v as f32),
            tip: self.tip_distance,
        };
        let blends = &self.blends;
        #[cfg_attr(not(target_arch = "x86_64"), allow(unused_variables))]
        let avx2 = !self.portable && has_avx2();
        let strands = self
            .out
            .par_chunks_mut(CHUNK * m)
            .zip(blends.par_chunks(CHUNK));
        match (head, &self.keep_out) {
            (Some(head), Some(keep)) => {
                let scratch = self.scratch.par_chunks_mut(KeepOut::scratch_len(m));
                #[cfg(target_arch = "x86_64")]
                if avx2 {
                    let placed = keep.at::<Avx>(head);
                    strands.zip(scratch).for_each(|((out, blends), scratch)| {
                        // SAFETY: the CPU has AVX2 (`has_avx2`)
                        unsafe { blend_kept_avx2(&inputs, out, blends, &placed, scratch) }
                    });
                    return Ok(&self.out);
                }
                let placed = keep.at::<f32x8>(head);
                strands.zip(scratch).for_each(|((out, blends), scratch)| {
                    inputs.blend_kept(out, blends, &placed, scratch)
                });
            }
            _ => {
                #[cfg(target_arch = "x86_64")]
                if avx2 {
                    strands.for_each(|(out, blends)| {
                        // SAFETY: the CPU has AVX2 (`has_avx2`)
                        unsafe { blend_avx2(&inputs, out, blends) }
                    });
                    return Ok(&self.out);
                }
                strands.for_each(|(out, blends)| inputs.blend(out, blends));
            }
        }
        Ok(&self.out)
    }

    /// The points of the last frame generated by [`SemiInterpolation::frame`] (zeros
    /// before the first).
    pub fn last_frame(&self) -> &[[f32; 3]] {
        &self.out
    }

    /// The weights w̃ of render strand `i`'s guides at a frame whose guide centrelines
    /// are `guides` (world, the layout of `new`): the root weights with the tip criterion
    /// applied, summing to 1, and the guides they belong to; `None` for a strand or a
    /// guide layout that does not exist.
    pub fn effective_weights(&self, i: usize, guides: &[[f64; 3]]) -> Option<([u32; 3], [f64; 3])> {
        let b = self.blends.get(i)?;
        let m = self.points;
        if guides.len() != self.guides * m {
            return None;
        }
        let tip = |g: u32| {
            let p = guides[(g as usize + 1) * m - 1];
            [p[0] as f32, p[1] as f32, p[2] as f32]
        };
        let tips = b.guides.map(tip);
        let w = tip_weights(b, &tips, self.tip_distance);
        Some((b.guides, w.map(f64::from)))
    }
}

/// What every chunk of render strands reads at one frame.
struct Inputs<'x> {
    guide_points: &'x [[f32; 3]],
    profile: &'x [f32],
    m: usize,
    r: Matrix3<f32>,
    tip: Option<f32>,
}

impl Inputs<'_> {
    /// Blend the strands `blends` into `out`.
    #[inline(always)]
    fn blend(&self, out: &mut [[f32; 3]], blends: &[Blend]) {
        for (line, blend) in out.chunks_exact_mut(self.m).zip(blends) {
            blend_strand(
                line,
                blend,
                self.guide_points,
                self.profile,
                self.m,
                &self.r,
                self.tip,
            );
        }
    }

    /// Blend the strands `blends` into `out`, eight at a time, each eight then kept out of
    /// the bodies `placed`.
    #[inline(always)]
    fn blend_kept<L: Lanes>(
        &self,
        out: &mut [[f32; 3]],
        blends: &[Blend],
        placed: &Frame<L>,
        scratch: &mut [Row],
    ) {
        for (lines, blends) in out.chunks_mut(LANES * self.m).zip(blends.chunks(LANES)) {
            self.blend(lines, blends);
            placed.apply(lines, blends.len(), self.m, scratch);
        }
    }
}

/// Set (to anything) in the environment, the render strands take the portable path even
/// on a CPU with AVX2 (to measure it; the results are the same bits).
pub const PORTABLE_SIMD_VARIABLE: &str = "SUPERHELIX_PORTABLE_SIMD";

/// Whether the CPU has AVX2 and [`PORTABLE_SIMD_VARIABLE`] is not set (the render strands
/// then use the AVX2 copies below); asked once.
pub(crate) fn has_avx2() -> bool {
    static AVX2: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *AVX2.get_or_init(|| {
        #[cfg(target_arch = "x86_64")]
        let avx2 = std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let avx2 = false;
        avx2 && std::env::var_os(PORTABLE_SIMD_VARIABLE).is_none()
    })
}

/// [`Inputs::blend`] compiled with AVX2: the same operations, eight lanes to a register.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn blend_avx2(inputs: &Inputs, out: &mut [[f32; 3]], blends: &[Blend]) {
    inputs.blend(out, blends)
}

/// [`Inputs::blend_kept`] compiled with AVX2, on [`Avx`] lanes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn blend_kept_avx2(
    inputs: &Inputs,
    out: &mut [[f32; 3]],
    blends: &[Blend],
    placed: &Frame<Avx>,
    scratch: &mut [Row],
) {
    inputs.blend_kept(out, blends, placed, scratch)
}

/// The guides must be a whole number of polylines of `points` ≥ 2 finite points.
fn check_guides(rest: &[Vector3<f64>], points: usize) -> Result<()> {
    if points < 2 || rest.len() % points != 0 {
        return Err(Error::invalid(
            "render",
            format!(
                "the guides must have the same number of points, at least 2: got {} points for {points} per guide",
                rest.len()
            ),
        ));
    }
    if rest.iter().any(|p| !p.iter().all(|v| v.is_finite())) {
        return Err(Error::invalid("render", "a guide point is not finite"));
    }
    Ok(())
}

/// The roots of guide polylines `rest` of `points` points each and their root tangents
/// (the direction of the first segment; +z when it has no length).
pub fn guide_roots(rest: &[Vector3<f64>], points: usize) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
    let guides = rest.len().checked_div(points).unwrap_or(0);
    let roots = (0..guides).map(|g| rest[g * points]).collect();
    let directions = (0..guides)
        .map(|g| {
            let next = rest
                .get(g * points + 1)
                .copied()
                .unwrap_or(rest[g * points]);
            (next - rest[g * points])
                .try_normalize(1e-300)
                .unwrap_or_else(Vector3::z)
        })
        .collect();
    (roots, directions)
}

/// w̃: the weights of `b` with the tip criterion on tips `tips`, summing to 1.
fn tip_weights(b: &Blend, tips: &[[f32; 3]; 3], tip_distance: Option<f32>) -> [f32; 3] {
    let Some(limit) = tip_distance else {
        return b.weights;
    };
    let d = tips[b.dominant as usize];
    let mut w = [0.0f32; 3];
    let mut sum = 0.0;
    for k in 0..3 {
        let t = tips[k];
        let dist = ((t[0] - d[0]).powi(2) + (t[1] - d[1]).powi(2) + (t[2] - d[2]).powi(2)).sqrt();
        let fade = (limit - dist) / ((1.0 - TIP_FADE_START as f32) * limit);
        w[k] = b.weights[k] * smoothstep(fade as f64) as f32;
        sum += w[k];
    }
    if sum > 0.0 {
        w.map(|x| x / sum)
    } else {
        let mut only = [0.0; 3];
        only[b.dominant as usize] = 1.0;
        only
    }
}

/// One render strand's points into `line`.
#[inline(always)]
fn blend_strand(
    line: &mut [[f32; 3]],
    b: &Blend,
    guides: &[[f32; 3]],
    profile: &[f32],
    m: usize,
    r: &Matrix3<f32>,
    tip_distance: Option<f32>,
) {
    let g = b.guides.map(|g| g as usize * m);
    let tips = g.map(|s| guides[s + m - 1]);
    let w = tip_weights(b, &tips, tip_distance);
    let d = b.dominant as usize;
    // turned offsets: A = Σ w̃_k R o_k (interpolated part), B = R o_d (clumped part)
    let turn = |o: [f32; 3]| r * Vector3::new(o[0], o[1], o[2]);
    let mut a = Vector3::zeros();
    for k in 0..3 {
        a += turn(b.offsets[k]) * w[k];
    }
    let bd = turn(b.offsets[d]);
    let c = &profile[g[d]..g[d] + m];
    let (p0, p1, p2, pd) = (
        &guides[g[0]..g[0] + m],
        &guides[g[1]..g[1] + m],
        &guides[g[2]..g[2] + m],
        &guides[g[d]..g[d] + m],
    );
    let samples = c.iter().zip(p0).zip(p1).zip(p2).zip(pd);
    for (out, ((((&cj, q0), q1), q2), qd)) in line.iter_mut().zip(samples) {
        for x in 0..3 {
            let interpolated = w[0] * q0[x] + w[1] * q1[x] + w[2] * q2[x] + a[x];
            let clumped = qd[x] + bd[x];
            out[x] = interpolated + cj * (clumped - interpolated);
        }
    }
}
