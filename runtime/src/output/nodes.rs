//! `frames.nodes.npy` and `frames.d1.npy` (`[output] nodes = K`): every strand sampled at
//! K evenly spaced arc lengths, with its material director d1 between them, for
//! comparisons with discrete rod codes and measurements.
//!
//! - `frames.nodes.npy`: float64, C order, shape `[frames, strands, K, 3]`: node j of
//!   strand i at arc length `s_j = j L_i / (K − 1)` from the root (j = 0 … K − 1, so the
//!   first node is the root and the last the tip), world coordinates, m.
//! - `frames.d1.npy`: float64, shape `[frames, strands, K − 1, 3]`: the director d1 (the
//!   material frame's first normal n1, the axis of the κ1 bending; section 3.1 of the
//!   Super-Helix paper) at the middle of each of the K − 1 segments between consecutive
//!   nodes, `s = (j + 1/2) L_i / (K − 1)`, world coordinates, a unit vector. With the
//!   tangent t = n0 (the segment's direction to second order) and n2 = t × n1 it gives
//!   the whole frame.
//!
//! The positions and frames are the closed-form reconstruction at those arc lengths
//! (equation 6 of the paper, [`poses_at_sorted`]) moved by the head's pose at the frame's
//! simulated time, not an interpolation of the written centreline. A pinned root's joint
//! element (10⁻¹⁰ L long) is not counted: arc length starts at its end.
//!
//! Both files grow as the run goes, as `frames.npy` does (the header is rewritten with the
//! frame count after every frame), and are written whatever the `formats`.

use super::frames::{FrameSink, FrameView};
use super::npy::GrowingNpy;
use crate::error::{Error, Result};
use crate::forces::head_motion::HeadMotion;
use crate::model::reconstruction::{poses_at_sorted, Pose};
use crate::model::strand::{Strand, StrandGeometry};
use std::path::Path;

/// Name of the nodes file.
pub const NODES_FILE: &str = "frames.nodes.npy";
/// Name of the directors file.
pub const D1_FILE: &str = "frames.d1.npy";
/// The fewest nodes per strand (the root and the tip).
pub const MIN_NODES: usize = 2;
/// The most nodes per strand.
pub const MAX_NODES: usize = 100_000;

/// What the sampler keeps of one strand.
struct Sampled {
    geometry: StrandGeometry,
    /// Arc length of the first node (the pinned root's joint length, else 0), m.
    first: f64,
    /// Length sampled, m.
    length: f64,
}

/// Samples every strand of a frame at `count` evenly spaced arc lengths and its d1
/// director between them (the arrays of [`NODES_FILE`] and [`D1_FILE`], one frame).
pub struct NodeSampler {
    strands: Vec<Sampled>,
    head: HeadMotion,
    count: usize,
    arcs: Vec<f64>,
    poses: Vec<Pose>,
}

impl NodeSampler {
    /// A sampler of `strands` (as the simulation has them, in scene order) on a head
    /// moving as `head`, `count` nodes per strand ([`MIN_NODES`] to [`MAX_NODES`]).
    pub fn new(strands: &[&Strand], head: &HeadMotion, count: usize) -> Result<Self> {
        if !(MIN_NODES..=MAX_NODES).contains(&count) {
            return Err(Error::invalid(
                "output.nodes",
                format!("{count} nodes per strand; allowed {MIN_NODES} to {MAX_NODES}"),
            ));
        }
        let strands = strands
            .iter()
            .map(|s| {
                let joint = s.ends.joint_elements();
                let first: f64 = s.geometry.lengths[..joint].iter().sum();
                Sampled {
                    geometry: s.geometry.clone(),
                    first,
                    length: s.geometry.length() - first,
                }
            })
            .collect();
        Ok(Self {
            strands,
            head: head.clone(),
            count,
            arcs: Vec::with_capacity(2 * count),
            poses: Vec::with_capacity(2 * count),
        })
    }

    /// Nodes per strand.
    pub fn count(&self) -> usize {
        self.count
    }

    /// Number of strands.
    pub fn strand_count(&self) -> usize {
        self.strands.len()
    }

    /// Append the frame's nodes (strands × count × 3, world coordinates, m) to `nodes`
    /// and its directors (strands × (count − 1) × 3) to `d1`.
    pub fn sample(
        &mut self,
        frame: &FrameView<'_>,
        nodes: &mut Vec<f64>,
        d1: &mut Vec<f64>,
    ) -> Result<()> {
        let head = self.head.state(frame.state_time);
        let spans = (self.count - 1) as f64;
        let mut at = 0;
        for s in &self.strands {
            let dofs = s.geometry.dofs();
            let Some(q) = frame.q.get(at..at + dofs) else {
                return Err(Error::invalid(
                    "frame.q",
                    format!(
                        "frame {} has {} coordinates, fewer than its strands",
                        frame.index,
                        frame.q.len()
                    ),
                ));
            };
            at += dofs;
            // nodes and midpoints interleaved: one pass along the strand
            self.arcs.clear();
            for j in 0..2 * self.count - 1 {
                self.arcs
                    .push(s.first + s.length * (0.5 * j as f64 / spans).min(1.0));
            }
            poses_at_sorted(&s.geometry, q, self.arcs.iter().copied(), &mut self.poses);
            for (j, pose) in self.poses.iter().enumerate() {
                if j % 2 == 0 {
                    nodes.extend((head.position + head.rotation * pose.position).iter());
                } else {
                    d1.extend((head.rotation * pose.frame.column(1)).iter());
                }
            }
        }
        Ok(())
    }
}

/// Writes [`NODES_FILE`] and [`D1_FILE`] as the run goes.
pub struct NodesSink {
    sampler: NodeSampler,
    nodes: GrowingNpy,
    d1: GrowingNpy,
    node_values: Vec<f64>,
    d1_values: Vec<f64>,
    row: Vec<u8>,
}

impl NodesSink {
    /// Create both files in `dir` (which must exist) with zero frames, for `strands` (as
    /// the simulation has them, in scene order) on a head moving as `head`, `count` nodes
    /// per strand ([`MIN_NODES`] to [`MAX_NODES`]).
    pub fn create(
        dir: &Path,
        strands: &[&Strand],
        head: &HeadMotion,
        count: usize,
    ) -> Result<Self> {
        Self::open(dir, strands, head, count, None)
    }
}

impl NodesSink {
    /// Go on writing both files in `dir` after a checkpoint (arguments as
    /// [`Self::create`]): each is cut back to the rows `mark` gives.
    pub fn resume(
        dir: &Path,
        strands: &[&Strand],
        head: &HeadMotion,
        count: usize,
        mark: &[u64],
    ) -> Result<Self> {
        let &[rows] = mark else {
            return Err(super::json::resume_error(
                &dir.join(NODES_FILE),
                "the checkpoint does not say where it ended",
            ));
        };
        Self::open(dir, strands, head, count, Some(rows))
    }
}

impl NodesSink {
    /// Both files, created (`rows` `None`) or cut back to `rows` rows.
    fn open(
        dir: &Path,
        strands: &[&Strand],
        head: &HeadMotion,
        count: usize,
        rows: Option<u64>,
    ) -> Result<Self> {
        let sampler = NodeSampler::new(strands, head, count)?;
        let n = sampler.strand_count() as u64;
        let k = count as u64;
        let file =
            |name: &str, tail: Vec<u64>| GrowingNpy::open(dir.join(name), "<f8", 8, tail, rows);
        Ok(Self {
            nodes: file(NODES_FILE, vec![n, k, 3])?,
            d1: file(D1_FILE, vec![n, k - 1, 3])?,
            sampler,
            node_values: Vec::new(),
            d1_values: Vec::new(),
            row: Vec::new(),
        })
    }
}

impl FrameSink for NodesSink {
    fn mark(&mut self) -> Result<Vec<u64>> {
        self.d1.sync()?;
        self.nodes.sync()?;
        Ok(vec![self.nodes.rows()])
    }

    fn write_frame(&mut self, frame: &FrameView<'_>) -> Result<()> {
        self.node_values.clear();
        self.d1_values.clear();
        self.sampler
            .sample(frame, &mut self.node_values, &mut self.d1_values)?;
        self.row.clear();
        self.row
            .extend(self.d1_values.iter().flat_map(|x| x.to_le_bytes()));
        self.d1.append(&self.row)?;
        self.row.clear();
        self.row
            .extend(self.node_values.iter().flat_map(|x| x.to_le_bytes()));
        self.nodes.append(&self.row)
    }

    fn finish(&mut self) -> Result<()> {
        self.d1.finish()?;
        self.nodes.finish()
    }
}
