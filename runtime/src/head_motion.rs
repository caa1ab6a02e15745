//! Rigid motion of the head (of every root): placeholder, see issue notes.
use nalgebra::{Matrix3, Vector3};

/// Placeholder.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum HeadMotion {
    /// The head does not move.
    #[default]
    Still,
}

/// Placeholder.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeadState {
    /// X
    pub position: Vector3<f64>,
    /// R
    pub rotation: Matrix3<f64>,
}
