//! What the scene's `[render]` table asks for (plain data): how many render strands, how
//! clumpy, the tip-distance criterion, the seed of the root placement and the scalp.

/// Most render strands of a scene.
pub const MAX_RENDER_STRANDS: usize = 10_000_000;
/// Largest `tip_distance` and `max_spacing`, m.
pub const MAX_RENDER_DISTANCE: f64 = 100.0;
/// Default `clumping`: interpolated on the first third of the length, clumped on the
/// last third (Fig. 4b of the paper).
pub const DEFAULT_CLUMPING: f64 = 0.5;
/// Fraction of the length over which a render strand goes from interpolated to clumped.
pub const CLUMP_TRANSITION: f64 = 0.25;
/// Disc radius of a guide alone (no neighbour within `max_spacing`, no spacing known), m.
pub const DEFAULT_LOCK_RADIUS: f64 = 0.0025;
/// `max_spacing` defaults to this many times the median spacing of the guide roots (the
/// distance from each root to its nearest other root).
pub const DEFAULT_SPACING_FACTOR: f64 = 3.0;
/// Largest `clearance`, m.
pub const MAX_RENDER_CLEARANCE: f64 = 0.1;

/// The render strands of a scene (`[render]`), see `docs/interpolation.md`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    /// Number of render strands R, in [1, [`MAX_RENDER_STRANDS`]].
    pub strands: usize,
    /// κ in [0, 1]: 0 interpolates every render strand from root to tip (smooth hair,
    /// Fig. 4a), 1 makes each follow its dominant guide from the root (disjoint locks,
    /// Fig. 4c); in between the strands are interpolated near the root and clumped near
    /// the tips (Fig. 4b), clumps starting nearer the root as κ grows.
    pub clumping: f64,
    /// Guides whose tips are farther than this (m) from the tip of a render strand's
    /// dominant guide drop out of its blend (Fig. 4d); `None`: no criterion.
    pub tip_distance: Option<f64>,
    /// Seed of the root placement (ChaCha8).
    pub seed: u64,
    /// Longest edge between two guide roots the placement interpolates across, m;
    /// `None`: [`DEFAULT_SPACING_FACTOR`] times the median root spacing.
    pub max_spacing: Option<f64>,
    /// Index (in `[[bodies]]`) of the body the render roots are projected onto; it is
    /// attached to the head. `None`: no projection.
    pub scalp_body: Option<usize>,
    /// Distance (m) the render strands keep from the scene's bodies: every render point
    /// (but the root) closer than this to a body is moved out along the body's normal
    /// ([`super::clearance`]); `None`: the strands' mean fibre radius.
    pub clearance: Option<f64>,
}

impl RenderSettings {
    /// `strands` render strands with the defaults: κ = [`DEFAULT_CLUMPING`], no tip
    /// criterion, seed 0, the default spacing, no scalp, the default clearance.
    pub fn new(strands: usize) -> Self {
        Self {
            strands,
            clumping: DEFAULT_CLUMPING,
            tip_distance: None,
            seed: 0,
            max_spacing: None,
            scalp_body: None,
            clearance: None,
        }
    }

    /// The clumping profile c(u) in [0, 1] at the arc-length fraction u ∈ [0, 1] from the
    /// root: 0 where the render strand is interpolated, 1 where it follows its dominant
    /// guide. With κ = `clumping` and h = [`CLUMP_TRANSITION`], c is 0 up to
    /// u = 1 − κ(1 + h), 1 from u = (1 + h)(1 − κ), and the smoothstep between.
    pub fn profile(&self, u: f64) -> f64 {
        clump_profile(self.clumping, u)
    }
}

/// [`RenderSettings::profile`] for κ = `clumping`.
pub fn clump_profile(clumping: f64, u: f64) -> f64 {
    let h = CLUMP_TRANSITION;
    let start = 1.0 - clumping * (1.0 + h);
    smoothstep((u - start) / h)
}

/// 3x² − 2x³ on x clamped to [0, 1].
pub fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}
