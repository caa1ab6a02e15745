//! The render strands of a run's frames, for `hair.usda` and the pictures: the strands
//! written are the guides, and [`RenderFrames`] generates the render strands of each frame
//! from them ([`crate::render::SemiInterpolation`]).
//!
//! Guides of different point counts (different N) are resampled to the largest count, at
//! equal fractions of their arc length in the first frame (linear along the polyline);
//! guides that have that count are taken as they are. The guides' rest shape (for the
//! root placement and the clumping profile) is the first frame, brought into head
//! coordinates with the head's pose at that frame.
//!
//! With bodies in the scene the render strands keep out of them by `[render] clearance`,
//! by default the guides' mean fibre radius (half the width the strands are drawn with).

use super::frames::FrameStore;
use super::scenery::{RenderSource, Scenery};
use crate::error::{Error, Result};
use crate::render::{KeepOut, SemiInterpolation};
use nalgebra::Vector3;

/// The render strands of the frames of a store.
#[derive(Debug, Clone)]
pub struct RenderFrames {
    interp: SemiInterpolation,
    /// Index of each guide's first point in a frame.
    offsets: Vec<usize>,
    /// Per guide and sample: the polyline segment and the fraction along it.
    samples: Vec<(u32, f64)>,
    points: usize,
    frame_points: Vec<[f64; 3]>,
    guide_points: Vec<[f64; 3]>,
    /// Group index (in [`super::frames::FrameLayout::groups`]) of each render strand's
    /// dominant guide.
    groups: Vec<u16>,
    /// Display width of every render strand, m: twice the guides' mean display radius.
    width: f64,
}

impl RenderFrames {
    /// The render strands `source` asks for, placed on the guides of frame 0 of `store`;
    /// `scenery` gives the head's pose. Only every `stride`-th render strand is built (1:
    /// all; the pictures need at most [`super::preview::PREVIEW_RENDER_STRANDS`]). An
    /// error when the store has no frame or a guide has fewer than 2 points.
    pub fn new(
        store: &mut dyn FrameStore,
        source: &RenderSource,
        scenery: &Scenery,
        stride: usize,
    ) -> Result<Self> {
        if store.frame_count() == 0 {
            return Err(Error::invalid(
                "render",
                "no frame to place the render strands on",
            ));
        }
        let layout = store.layout().clone();
        let offsets = layout.point_offsets();
        let points = layout.strands.iter().map(|s| s.points).max().unwrap_or(0);
        if let Some(s) = layout.strands.iter().find(|s| s.points < 2) {
            return Err(Error::invalid(
                "render",
                format!(
                    "strand '{}' has {} point(s): render strands need at least 2",
                    s.name, s.points
                ),
            ));
        }
        let mut frame_points = Vec::new();
        store.points(0, &mut frame_points)?;
        let mut samples = Vec::with_capacity(layout.strands.len() * points);
        for (g, s) in layout.strands.iter().enumerate() {
            let line = frame_points.get(offsets[g]..offsets[g + 1]).unwrap_or(&[]);
            samples.extend(resampling(line, s.points, points));
        }
        let guides = layout.strands.len();
        let mut guide_points = vec![[0.0; 3]; guides * points];
        resample(&frame_points, &offsets, &samples, points, &mut guide_points);
        let head = scenery.head_at(store.state_time(0));
        let to_head = head.rotation.transpose();
        let rest: Vec<Vector3<f64>> = guide_points
            .iter()
            .map(|p| to_head * (Vector3::from(*p) - head.position))
            .collect();
        let interp = SemiInterpolation::subset(
            &source.settings,
            &rest,
            points,
            source.scalp.as_ref(),
            (0..source.settings.strands).step_by(stride.max(1)),
        )?;
        let radius = layout.strands.iter().map(|s| s.radius).sum::<f64>() / guides.max(1) as f64;
        let interp = match source.bodies.is_empty() {
            true => interp,
            false => {
                let clearance = source.settings.clearance.unwrap_or(radius);
                interp.keep_out(KeepOut::new(source.bodies.clone(), clearance)?)
            }
        };
        let names = layout.groups();
        let group_of: Vec<u16> = layout
            .strands
            .iter()
            .map(|s| names.iter().position(|g| *g == s.group).unwrap_or(0) as u16)
            .collect();
        let groups = interp
            .roots()
            .roots
            .iter()
            .map(|r| group_of[r.dominant_guide()])
            .collect();
        let width = 2.0 * radius;
        Ok(Self {
            interp,
            offsets,
            samples,
            points,
            frame_points,
            guide_points,
            groups,
            width,
        })
    }

    /// The render strands of frame `k` of `store` (points strand after strand, world
    /// coordinates, m), with the head's pose from `scenery`, kept out of the bodies.
    pub fn frame(
        &mut self,
        store: &mut dyn FrameStore,
        k: usize,
        scenery: &Scenery,
    ) -> Result<&[[f32; 3]]> {
        store.points(k, &mut self.frame_points)?;
        if self.frame_points.len() < self.offsets.last().copied().unwrap_or(0) {
            return Err(Error::invalid(
                "render",
                format!("frame {k} has too few points"),
            ));
        }
        resample(
            &self.frame_points,
            &self.offsets,
            &self.samples,
            self.points,
            &mut self.guide_points,
        );
        let time = store.state_time(k);
        let at = crate::bodies::Placement::new(scenery.head_at(time), time);
        self.interp.frame_at(&self.guide_points, &at)
    }

    /// The points of the last frame generated (strand after strand) and the group index
    /// of each render strand.
    pub fn last_frame(&self) -> (&[[f32; 3]], &[u16]) {
        (self.interp.last_frame(), &self.groups)
    }

    /// Number of render strands.
    pub fn strand_count(&self) -> usize {
        self.interp.strand_count()
    }

    /// Points per render strand.
    pub fn points_per_strand(&self) -> usize {
        self.points
    }

    /// Group index of each render strand's dominant guide.
    pub fn groups(&self) -> &[u16] {
        &self.groups
    }

    /// Display width of the render strands, m.
    pub fn width(&self) -> f64 {
        self.width
    }
}

/// Where the `count` samples of a guide of polyline `line` (`n` points) fall: the segment
/// and the fraction along it, at equal fractions of the arc length. A guide of `count`
/// points keeps its own.
fn resampling(line: &[[f64; 3]], n: usize, count: usize) -> Vec<(u32, f64)> {
    if n == count || line.len() < 2 {
        return (0..count)
            .map(|j| {
                let i = j.min(n.saturating_sub(2));
                (i as u32, if j > i { 1.0 } else { 0.0 })
            })
            .collect();
    }
    let mut s = vec![0.0; line.len()];
    for i in 1..line.len() {
        let d: f64 = (0..3).map(|c| (line[i][c] - line[i - 1][c]).powi(2)).sum();
        s[i] = s[i - 1] + d.sqrt();
    }
    let length = s[line.len() - 1];
    (0..count)
        .map(|j| {
            let target = length * j as f64 / (count - 1) as f64;
            let i = s.partition_point(|&x| x <= target).clamp(1, line.len() - 1) - 1;
            let seg = s[i + 1] - s[i];
            let t = if seg > 0.0 {
                ((target - s[i]) / seg).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (i as u32, t)
        })
        .collect()
}

/// The guides' samples of `frame` into `out` (guide-major, `count` per guide).
fn resample(
    frame: &[[f64; 3]],
    offsets: &[usize],
    samples: &[(u32, f64)],
    count: usize,
    out: &mut [[f64; 3]],
) {
    for (g, (out, samples)) in out
        .chunks_exact_mut(count)
        .zip(samples.chunks_exact(count))
        .enumerate()
    {
        let base = offsets[g];
        for (o, &(i, t)) in out.iter_mut().zip(samples) {
            let a = frame
                .get(base + i as usize)
                .copied()
                .unwrap_or([f64::NAN; 3]);
            let b = frame.get(base + i as usize + 1).copied().unwrap_or(a);
            *o = [0, 1, 2].map(|c| a[c] + t * (b[c] - a[c]));
        }
    }
}
