//! The frame interface shared by every output: the layout of a run's frames, one frame
//! as the driver hands it to the sinks, the sink and store traits.

use crate::error::Result;

/// What the output knows of one strand, fixed for the whole run.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StrandInfo {
    /// Strand name (unique in the scene).
    pub name: String,
    /// Group the strand belongs to: the patch name for strands of a `[[patches]]` entry,
    /// the `group` field (default: the strand's own name) for a `[[strands]]` entry.
    /// One USD prim and one preview colour per group.
    pub group: String,
    /// Fibre radius for display (m): the cross-section's mean semi-axis (a + b)/2.
    pub radius: f64,
    /// Number of centreline points written per frame: 1 + samples_per_element · N.
    pub points: usize,
    /// Number of generalized coordinates, 3N.
    pub coordinates: usize,
}

/// The layout every frame of a run shares.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameLayout {
    /// Strands in scene order.
    pub strands: Vec<StrandInfo>,
    /// Frames per second of the output (nominal frame k is at k / output_fps).
    pub output_fps: f64,
    /// Frames the run plans to write (the written count can be smaller when it stops early).
    pub planned_frames: usize,
    /// The strands whose tip is held (`[strands.ends.tip]`), by index in scene order: the
    /// rows of every frame's held-end report (absent when empty).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub held_tips: Vec<usize>,
}

impl FrameLayout {
    /// Total centreline points of one frame (all strands).
    pub fn total_points(&self) -> usize {
        self.strands.iter().map(|s| s.points).sum()
    }

    /// Total generalized coordinates of one frame (all strands).
    pub fn total_coordinates(&self) -> usize {
        self.strands.iter().map(|s| s.coordinates).sum()
    }

    /// Index of each strand's first point in a frame's point list (len = strands + 1).
    pub fn point_offsets(&self) -> Vec<usize> {
        prefix_sums(self.strands.iter().map(|s| s.points))
    }

    /// Index of each strand's first coordinate in a frame's q list (len = strands + 1).
    pub fn coordinate_offsets(&self) -> Vec<usize> {
        prefix_sums(self.strands.iter().map(|s| s.coordinates))
    }

    /// Groups in order of first appearance.
    pub fn groups(&self) -> Vec<&str> {
        let mut groups: Vec<&str> = Vec::new();
        for s in &self.strands {
            if !groups.contains(&s.group.as_str()) {
                groups.push(&s.group);
            }
        }
        groups
    }
}

fn prefix_sums(counts: impl Iterator<Item = usize>) -> Vec<usize> {
    let mut offsets = vec![0];
    let mut total = 0;
    for c in counts {
        total += c;
        offsets.push(total);
    }
    offsets
}

/// One frame as the driver hands it to every sink.
#[derive(Debug, Clone, Copy)]
pub struct FrameView<'a> {
    /// Frame index k (0-based, consecutive).
    pub index: usize,
    /// Nominal time k / output_fps, s.
    pub time: f64,
    /// Simulated time of the state written, s.
    pub state_time: f64,
    /// Every strand's centreline, concatenated in strand order, world coordinates, m.
    pub points: &'a [[f64; 3]],
    /// Every strand's generalized coordinates, concatenated in strand order, rad/m.
    pub q: &'a [f64],
    /// What the error-controlled step did since the previous frame (`None`: fixed steps).
    pub steps: Option<super::FrameSteps>,
    /// Every held tip's drift and reaction, one per strand of
    /// [`FrameLayout::held_tips`] (empty: no held tips).
    pub held: &'a [super::HeldEndFrame],
}

/// A file format written while the run goes: every frame is written (and readable) as
/// soon as it is computed.
pub trait FrameSink {
    /// Write one frame.
    fn write_frame(&mut self, frame: &FrameView<'_>) -> Result<()>;
    /// Make every frame written durable (synced to disk) and say where the files end, as
    /// a checkpoint records it (the sink's `resume` constructor takes it back); by default
    /// nothing to record (a sink that keeps nothing across a resume).
    fn mark(&mut self) -> Result<Vec<u64>> {
        Ok(Vec::new())
    }
    /// Close the file so that every frame written is readable (also called when the run
    /// stops early).
    fn finish(&mut self) -> Result<()>;
}

/// Read access to frames written by a run (frames.json, frames.npy, or in memory).
pub trait FrameStore {
    /// The layout.
    fn layout(&self) -> &FrameLayout;
    /// Frames available.
    fn frame_count(&self) -> usize;
    /// Nominal time of frame k, s.
    fn time(&self, k: usize) -> f64;
    /// Simulated time of the state written as frame k, s (what the head's pose at that
    /// frame is computed for); by default the nominal time.
    fn state_time(&self, k: usize) -> f64 {
        self.time(k)
    }
    /// All points of frame k (total_points of them), m.
    fn points(&mut self, k: usize, out: &mut Vec<[f64; 3]>) -> Result<()>;
}
