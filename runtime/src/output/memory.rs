//! Frames kept in memory: a sink and a store in one, for tests and small library uses.

use super::frames::{FrameLayout, FrameSink, FrameStore, FrameView};
use super::{Frames, StrandFrames};
use crate::error::{Error, Result};

/// Every frame of a run in memory, frame-major, as the driver handed them over.
#[derive(Debug, Clone, PartialEq)]
pub struct MemoryFrames {
    layout: FrameLayout,
    /// Nominal time of each frame, s.
    pub times: Vec<f64>,
    /// Simulated time of each frame's state, s.
    pub state_times: Vec<f64>,
    /// `points[k]`: every strand's centreline of frame k, concatenated, m.
    pub points: Vec<Vec<[f64; 3]>>,
    /// `q[k]`: every strand's generalized coordinates of frame k, concatenated, rad/m.
    pub q: Vec<Vec<f64>>,
}

impl MemoryFrames {
    /// An empty store of frames of `layout`.
    pub fn new(layout: FrameLayout) -> Self {
        Self {
            layout,
            times: Vec::new(),
            state_times: Vec::new(),
            points: Vec::new(),
            q: Vec::new(),
        }
    }

    /// The frames strand-major, as [`Frames`].
    pub fn to_frames(&self) -> Frames {
        let point_offsets = self.layout.point_offsets();
        let q_offsets = self.layout.coordinate_offsets();
        let strands = self
            .layout
            .strands
            .iter()
            .enumerate()
            .map(|(i, s)| StrandFrames {
                name: s.name.clone(),
                points: self
                    .points
                    .iter()
                    .map(|p| p[point_offsets[i]..point_offsets[i + 1]].to_vec())
                    .collect(),
                q: self
                    .q
                    .iter()
                    .map(|q| q[q_offsets[i]..q_offsets[i + 1]].to_vec())
                    .collect(),
            })
            .collect();
        Frames {
            frame_times: self.times.clone(),
            state_times: self.state_times.clone(),
            strands,
        }
    }
}

impl FrameSink for MemoryFrames {
    fn write_frame(&mut self, frame: &FrameView<'_>) -> Result<()> {
        self.times.push(frame.time);
        self.state_times.push(frame.state_time);
        self.points.push(frame.points.to_vec());
        self.q.push(frame.q.to_vec());
        Ok(())
    }

    fn finish(&mut self) -> Result<()> {
        Ok(())
    }
}

impl FrameStore for MemoryFrames {
    fn layout(&self) -> &FrameLayout {
        &self.layout
    }

    fn frame_count(&self) -> usize {
        self.times.len()
    }

    fn time(&self, k: usize) -> f64 {
        self.times.get(k).copied().unwrap_or(f64::NAN)
    }

    fn state_time(&self, k: usize) -> f64 {
        self.state_times.get(k).copied().unwrap_or(f64::NAN)
    }

    fn points(&mut self, k: usize, out: &mut Vec<[f64; 3]>) -> Result<()> {
        let points = self.points.get(k).ok_or_else(|| {
            Error::invalid(
                "frame",
                format!(
                    "frame {k} does not exist: {} frames in memory",
                    self.times.len()
                ),
            )
        })?;
        out.clear();
        out.extend_from_slice(points);
        Ok(())
    }
}
