//! The preview: pictures of the strands from a default camera, `preview.png` (last
//! frame), `preview_first.png` (first frame) and the animated `preview.gif`.
//!
//! A picture is one orthographic panel per view, side by side (default front and side):
//! - front: x to the right, z up, looking along +y;
//! - side: y to the right, z up, looking along −x;
//! - top: x to the right, y up, looking down (along −z).
//!
//! All panels share one scale (pixels per metre), fitted to the bounding box of every
//! frame and body, so the animation does not jump and lengths compare across panels.
//! White background, a light frame round each panel, a scale bar with its length (a
//! 1, 2 or 5 × 10ⁿ m that fits a third of a panel) under the first panel's lower left
//! corner, the nominal time at the top left; strands are anti-aliased polylines
//! (≥ 1.5 px wide) coloured by group with [`PALETTE`] (group g in order of first
//! appearance gets `PALETTE[g % 10]` in every picture and in `hair.usda`); bodies are
//! filled light grey under the strands, at the head's pose of each frame (how each shape
//! is drawn: [`super::scenery`]); render strands (`[render]`) are one-pixel lines in a
//! light shade of their dominant guide's group colour, between the bodies and the guides
//! (at most [`PREVIEW_RENDER_STRANDS`] of them: every k-th when there are more).
//!
//! The GIF has every frame, or every k-th frame to keep at most
//! [`PreviewOptions::gif_max_frames`], looped, each shown for k / output_fps s (rounded to
//! the GIF's 1/100 s). Its colours come from a fixed palette: each group colour blended
//! with white at 15 levels, and 32 greys; every pixel is mapped to the nearest entry,
//! which is exact for the background, the frame and the strands' own colours and close
//! for their anti-aliased edges.

use super::atomic::{write_atomically, AtomicFile};
use super::frames::{FrameLayout, FrameStore};
use super::render_strands::RenderFrames;
use super::scenery::{PreviewShape, Scenery};
use crate::error::{Error, Result};
use nalgebra::Vector3;
use std::collections::HashMap;
use std::path::Path;
use tiny_skia::{
    Color, FillRule, LineCap, LineJoin, Mask, Paint, PathBuilder, Pixmap, Rect, Stroke, Transform,
};

pub use super::scenery::PreviewBody;

/// Most render strands a picture draws (every k-th when there are more).
pub const PREVIEW_RENDER_STRANDS: usize = 1000;
/// Level (of 15) of the render strands' colour: their group colour blended with white at
/// 5/15, an exact entry of the GIF's palette, drawn opaque (translucent lines would make
/// every overlap a new colour for the GIF to match).
const RENDER_LEVEL: u32 = 5;
/// Width of the render strands' lines, pixels: 0 is a one-pixel anti-aliased hairline
/// (the fastest stroke).
const RENDER_WIDTH: f32 = 0.0;

/// Name of the last frame's picture.
pub const PNG_FILE: &str = "preview.png";
/// Name of the first frame's picture.
pub const FIRST_PNG_FILE: &str = "preview_first.png";
/// Name of the animation.
pub const GIF_FILE: &str = "preview.gif";

/// Group colours (sRGB), the "category10" palette of d3 and matplotlib: blue, orange,
/// green, red, purple, brown, pink, grey, olive, cyan.
pub const PALETTE: [[u8; 3]; 10] = [
    [0x1f, 0x77, 0xb4],
    [0xff, 0x7f, 0x0e],
    [0x2c, 0xa0, 0x2c],
    [0xd6, 0x27, 0x28],
    [0x94, 0x67, 0xbd],
    [0x8c, 0x56, 0x4b],
    [0xe3, 0x77, 0xc2],
    [0x7f, 0x7f, 0x7f],
    [0xbc, 0xbd, 0x22],
    [0x17, 0xbe, 0xcf],
];

/// Colour of group `g` (index in [`FrameLayout::groups`]).
pub fn group_colour(g: usize) -> [u8; 3] {
    PALETTE[g % PALETTE.len()]
}

const BODY_GREY: u8 = 0xdd;
const FRAME_GREY: u8 = 0xc8;
const INK_GREY: u8 = 0x40;

/// An orthographic view.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum View {
    /// x to the right, z up (looking along +y).
    Front,
    /// y to the right, z up (looking along −x).
    Side,
    /// x to the right, y up (looking down).
    Top,
}

impl View {
    /// The panel's label: the view's name and its axes, right then up.
    pub fn label(self) -> &'static str {
        match self {
            View::Front => "front (x-z)",
            View::Side => "side (y-z)",
            View::Top => "top (x-y)",
        }
    }

    /// The view's name: `front`, `side` or `top`.
    pub fn name(self) -> &'static str {
        match self {
            View::Front => "front",
            View::Side => "side",
            View::Top => "top",
        }
    }

    /// The view called `name`.
    pub fn from_name(name: &str) -> Option<View> {
        match name {
            "front" => Some(View::Front),
            "side" => Some(View::Side),
            "top" => Some(View::Top),
            _ => None,
        }
    }

    /// A comma list of views (`front,side`); the error names what is allowed.
    pub fn parse_list(list: &str) -> std::result::Result<Vec<View>, String> {
        let mut views = Vec::new();
        for name in list.split(',').map(str::trim) {
            let view = View::from_name(name).ok_or_else(|| {
                format!("unknown view '{name}': must be a comma list of front, side, top")
            })?;
            if views.contains(&view) {
                return Err(format!("view '{name}' is listed twice"));
            }
            views.push(view);
        }
        Ok(views)
    }

    /// World axes shown to the right and up.
    fn axes(self) -> (usize, usize) {
        match self {
            View::Front => (0, 2),
            View::Side => (1, 2),
            View::Top => (0, 1),
        }
    }
}

/// Camera settings of the preview pictures.
#[derive(Debug, Clone, PartialEq)]
pub struct PreviewOptions {
    /// Picture width, pixels (all panels).
    pub width: u32,
    /// Picture height, pixels.
    pub height: u32,
    /// Panels from left to right.
    pub views: Vec<View>,
    /// Frame drawn in `preview.png` (default: the last one).
    pub frame: Option<usize>,
    /// Most frames the GIF holds (every k-th frame is taken to stay within).
    pub gif_max_frames: usize,
}

impl Default for PreviewOptions {
    /// 1200 × 600, front and side, last frame, at most 200 GIF frames.
    fn default() -> Self {
        Self {
            width: 1200,
            height: 600,
            views: vec![View::Front, View::Side],
            frame: None,
            gif_max_frames: 200,
        }
    }
}

/// Smallest and largest picture side, pixels.
pub const SIZE_RANGE: std::ops::RangeInclusive<u32> = 64..=8192;

impl PreviewOptions {
    /// Check the options; errors name the field as `<prefix>width` etc.
    pub fn check(&self, prefix: &str) -> Result<()> {
        let mut problems = Vec::new();
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if !SIZE_RANGE.contains(&v) {
                problems.push(crate::error::FieldError::new(
                    format!("{prefix}{name}"),
                    format!(
                        "{v} is out of range: must be in {}..={} pixels",
                        SIZE_RANGE.start(),
                        SIZE_RANGE.end()
                    ),
                ));
            }
        }
        if self.views.is_empty() {
            problems.push(crate::error::FieldError::new(
                format!("{prefix}views"),
                "must list at least one of front, side, top",
            ));
        } else if self.width / (self.views.len() as u32) < 32 {
            problems.push(crate::error::FieldError::new(
                format!("{prefix}width"),
                format!(
                    "{} pixels leave less than 32 per view for {} views",
                    self.width,
                    self.views.len()
                ),
            ));
        }
        if self.gif_max_frames == 0 {
            problems.push(crate::error::FieldError::new(
                format!("{prefix}gif_max_frames"),
                "must be >= 1",
            ));
        }
        if problems.is_empty() {
            Ok(())
        } else {
            Err(Error::Invalid(problems))
        }
    }
}

/// An axis-aligned bounding box, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Smallest x, y, z.
    pub lo: [f64; 3],
    /// Largest x, y, z.
    pub hi: [f64; 3],
}

impl Bounds {
    /// The empty box.
    pub fn empty() -> Self {
        Self {
            lo: [f64::INFINITY; 3],
            hi: [f64::NEG_INFINITY; 3],
        }
    }

    /// Grow to hold `p` (non-finite points are ignored).
    pub fn include(&mut self, p: [f64; 3]) {
        if p.iter().all(|v| v.is_finite()) {
            for c in 0..3 {
                self.lo[c] = self.lo[c].min(p[c]);
                self.hi[c] = self.hi[c].max(p[c]);
            }
        }
    }

    /// Whether no point was included.
    pub fn is_empty(&self) -> bool {
        self.lo[0] > self.hi[0]
    }
}

/// The box holding every point of every frame of `store` and every body of `scenery` at
/// the head's pose of every frame (half-spaces left out).
pub fn frame_bounds(store: &mut dyn FrameStore, scenery: &Scenery) -> Result<Bounds> {
    let mut bounds = Bounds::empty();
    let mut points = Vec::new();
    for k in 0..store.frame_count() {
        store.points(k, &mut points)?;
        for p in &points {
            bounds.include(*p);
        }
        let head = scenery.head_at(store.state_time(k));
        for b in &scenery.bodies {
            if let Some((lo, hi)) = b.placed(&head, store.state_time(k)).extent() {
                bounds.include(lo);
                bounds.include(hi);
            }
        }
    }
    Ok(bounds)
}

/// A frame's render strands as a picture draws them: every point (strand after strand),
/// points per strand, and the group index of each strand's colour.
pub type RenderView<'a> = (&'a [[f32; 3]], usize, &'a [u16]);

/// What a picture shows besides the guides: the bodies placed at the frame's head pose
/// and the frame's render strands.
#[derive(Debug, Clone, Default)]
pub struct FrameScene<'a> {
    /// Bodies in world coordinates.
    pub bodies: Vec<PreviewShape>,
    /// Render strands.
    pub render: Option<RenderView<'a>>,
}

/// Where each view's panel is and the common scale.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    width: u32,
    height: u32,
    views: Vec<View>,
    /// Pixels per metre.
    scale: f64,
    /// World point at each panel's centre (right, up coordinates).
    centres: Vec<(f64, f64)>,
    panel_width: f64,
}

/// Margins: above (the time), below (the scale bar), at the sides, pixels.
const TOP: f64 = 28.0;
const BOTTOM: f64 = 36.0;
const SIDE: f64 = 14.0;

impl Camera {
    /// The camera showing `bounds` whole in every panel of `options`.
    pub fn fit(bounds: &Bounds, options: &PreviewOptions) -> Camera {
        let b = if bounds.is_empty() {
            Bounds {
                lo: [-0.1; 3],
                hi: [0.1; 3],
            }
        } else {
            *bounds
        };
        let n = options.views.len().max(1) as f64;
        let panel_width = options.width as f64 / n;
        let avail_w = (panel_width - 2.0 * SIDE).max(8.0);
        let avail_h = (options.height as f64 - TOP - BOTTOM).max(8.0);
        let mut scale = f64::INFINITY;
        let mut centres = Vec::new();
        for v in &options.views {
            let (r, u) = v.axes();
            // at least 1 mm across so a point or a straight line still gets a finite scale
            let er = (b.hi[r] - b.lo[r]).max(1e-3);
            let eu = (b.hi[u] - b.lo[u]).max(1e-3);
            scale = scale.min(avail_w / er).min(avail_h / eu);
            centres.push((0.5 * (b.lo[r] + b.hi[r]), 0.5 * (b.lo[u] + b.hi[u])));
        }
        Camera {
            width: options.width,
            height: options.height,
            views: options.views.clone(),
            scale: if scale.is_finite() { scale } else { 1.0 },
            centres,
            panel_width,
        }
    }

    /// Pixels per metre.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Pixel position of `p` in panel `i`.
    pub fn project(&self, i: usize, p: [f64; 3]) -> (f32, f32) {
        let (r, u) = self.views[i].axes();
        let (cr, cu) = self.centres[i];
        let x = self.panel_width * (i as f64 + 0.5) + (p[r] - cr) * self.scale;
        let y = TOP + 0.5 * (self.height as f64 - TOP - BOTTOM) - (p[u] - cu) * self.scale;
        (x as f32, y as f32)
    }
}

fn paint(rgb: [u8; 3]) -> Paint<'static> {
    let mut paint = Paint::default();
    paint.set_color_rgba8(rgb[0], rgb[1], rgb[2], 255);
    paint.anti_alias = true;
    paint
}

fn stroke(width: f32) -> Stroke {
    Stroke {
        width,
        line_cap: LineCap::Round,
        line_join: LineJoin::Round,
        ..Stroke::default()
    }
}

/// Draw frame `points` (all strands of `layout`) as `camera` sees it, with the bodies and
/// render strands of `scene` and
/// an optional `label` (digits, `.`, `=`, `-`, `(`, `)`, spaces and the letters
/// `c d e f i m n o p r s t x y z`) at the top left; each panel is labelled with its view.
pub fn render_frame(
    layout: &FrameLayout,
    points: &[[f64; 3]],
    camera: &Camera,
    scene: &FrameScene<'_>,
    label: Option<&str>,
) -> Result<Pixmap> {
    let mut pixmap = Pixmap::new(camera.width, camera.height).ok_or_else(|| {
        Error::invalid(
            "width",
            format!("cannot make a {} x {} picture", camera.width, camera.height),
        )
    })?;
    pixmap.fill(Color::WHITE);
    let groups = layout.groups();
    let offsets = layout.point_offsets();
    let fine = stroke(1.0);
    for (i, _) in camera.views.iter().enumerate() {
        // panel frame
        let x0 = camera.panel_width * i as f64 + 4.0;
        let x1 = camera.panel_width * (i + 1) as f64 - 4.0;
        let (y0, y1) = (4.0, camera.height as f64 - BOTTOM + 6.0);
        if let Some(rect) = Rect::from_ltrb(
            x0 as f32 + 0.5,
            y0 as f32 + 0.5,
            x1 as f32 - 0.5,
            y1 as f32 - 0.5,
        ) {
            let path = PathBuilder::from_rect(rect);
            pixmap.stroke_path(
                &path,
                &paint([FRAME_GREY; 3]),
                &fine,
                Transform::identity(),
                None,
            );
        }
        // the view's name and axes at the panel's top right
        let name = camera.views[i].label();
        let text_width = 6.5 * 10.0 / 6.0 * name.chars().count() as f64;
        draw_text(
            &mut pixmap,
            name,
            (x1 - 8.0 - text_width) as f32,
            10.0,
            10.0,
        );
        // bodies, clipped to the panel
        if !scene.bodies.is_empty() {
            let mask = panel_mask(camera, i, (x0, y0, x1, y1));
            for b in &scene.bodies {
                draw_body(&mut pixmap, camera, i, b, mask.as_ref());
            }
        }
        // render strands, thin and translucent, one path per group
        if let Some((render, per_strand, colours)) = scene.render {
            draw_render_strands(
                &mut pixmap,
                camera,
                i,
                render,
                per_strand,
                colours,
                groups.len(),
            );
        }
        // strands, one path per group
        for (g, group) in groups.iter().enumerate() {
            let mut pb = PathBuilder::new();
            let mut width = 1.5f64;
            for (s, strand) in layout.strands.iter().enumerate() {
                if strand.group != *group {
                    continue;
                }
                width = width.max(2.0 * strand.radius * camera.scale);
                let line = points.get(offsets[s]..offsets[s + 1]).unwrap_or(&[]);
                for (j, p) in line.iter().enumerate() {
                    let (x, y) = camera.project(i, *p);
                    if !(x.is_finite() && y.is_finite()) {
                        continue;
                    }
                    if j == 0 {
                        pb.move_to(x, y);
                    } else {
                        pb.line_to(x, y);
                    }
                }
            }
            if let Some(path) = pb.finish() {
                let w = width.min(12.0) as f32;
                pixmap.stroke_path(
                    &path,
                    &paint(group_colour(g)),
                    &stroke(w),
                    Transform::identity(),
                    None,
                );
            }
        }
    }
    draw_scale_bar(&mut pixmap, camera);
    if let Some(text) = label {
        draw_text(&mut pixmap, text, 12.0, 8.0, 12.0);
    }
    Ok(pixmap)
}

/// A mask of panel `i`'s frame (`None` when it cannot be made).
fn panel_mask(camera: &Camera, _i: usize, (x0, y0, x1, y1): (f64, f64, f64, f64)) -> Option<Mask> {
    let mut mask = Mask::new(camera.width, camera.height)?;
    let rect = Rect::from_ltrb(x0 as f32, y0 as f32, x1 as f32, y1 as f32)?;
    mask.fill_path(
        &PathBuilder::from_rect(rect),
        FillRule::Winding,
        false,
        Transform::identity(),
    );
    Some(mask)
}

/// Points on each end circle of a cylinder whose shadows' hull is drawn (the polygon
/// falls short of the circle by r (1 − cos(π/64)), 0.12 % of the radius).
const CIRCLE_POINTS: usize = 64;

/// The convex hull of `points` (screen coordinates), counter-clockwise, by Andrew's
/// monotone chain (de Berg et al., *Computational Geometry*, 1.1); `points` is sorted in
/// place. Fewer than three distinct points are returned as they are.
fn convex_hull(points: &mut [(f32, f32)]) -> Vec<(f32, f32)> {
    points.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    if points.len() < 3 {
        return points.to_vec();
    }
    let cross = |o: (f32, f32), a: (f32, f32), b: (f32, f32)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    // the lower chain left to right, then the upper one right to left; the last point of
    // each starts the other
    let mut hull: Vec<(f32, f32)> = Vec::with_capacity(points.len() + 1);
    let chain = |hull: &mut Vec<(f32, f32)>, ordered: &mut dyn Iterator<Item = &(f32, f32)>| {
        let floor = hull.len();
        for &p in ordered {
            while hull.len() >= floor + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    };
    chain(&mut hull, &mut points.iter());
    chain(&mut hull, &mut points.iter().rev());
    hull
}

/// Fill body `shape` (world coordinates) in panel `i` in light grey.
fn draw_body(
    pixmap: &mut Pixmap,
    camera: &Camera,
    i: usize,
    shape: &PreviewShape,
    mask: Option<&Mask>,
) {
    let (r, u) = camera.views[i].axes();
    let grey = paint([BODY_GREY; 3]);
    let s = camera.scale;
    let project = |p: &Vector3<f64>| camera.project(i, [p.x, p.y, p.z]);
    match shape {
        PreviewShape::Ellipsoid {
            centre,
            axes,
            radii,
        } => {
            // the shadow of the ellipsoid is the ellipse of the 2 x 2 block (r, u) of
            // M = Q diag(radii²) Qᵀ; its Cholesky factor maps the unit disc onto it
            let m = |a: usize, b: usize| {
                (0..3)
                    .map(|k| axes[(a, k)] * axes[(b, k)] * radii[k] * radii[k])
                    .sum::<f64>()
            };
            let (a, b, d) = (m(r, r), m(r, u), m(u, u));
            if a.is_nan() || a <= 0.0 {
                return;
            }
            let l00 = a.sqrt();
            let l10 = b / l00;
            let l11 = (d - l10 * l10).max(0.0).sqrt();
            let (cx, cy) = project(centre);
            // screen y points down
            let t = Transform::from_row(
                (s * l00) as f32,
                (-s * l10) as f32,
                0.0,
                (-s * l11) as f32,
                cx,
                cy,
            );
            if let Some(path) =
                Rect::from_ltrb(-1.0, -1.0, 1.0, 1.0).and_then(PathBuilder::from_oval)
            {
                pixmap.fill_path(&path, &grey, FillRule::Winding, t, mask);
            }
        }
        PreviewShape::Capsule { start, end, radius } => {
            let ((x0, y0), (x1, y1)) = (project(start), project(end));
            let mut pb = PathBuilder::new();
            pb.move_to(x0, y0);
            // a zero-length line still gets its round caps
            pb.line_to(x1 + 1e-3, y1);
            if let Some(path) = pb.finish() {
                let width = (2.0 * radius * s) as f32;
                pixmap.stroke_path(&path, &grey, &stroke(width), Transform::identity(), mask);
            }
        }
        PreviewShape::Cylinder { start, end, radius } => {
            // the shadow of a cylinder is the convex hull of its two end circles' shadows
            let axis = (end - start).try_normalize(0.0).unwrap_or_else(Vector3::z);
            let across = if axis.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::y()
            };
            let e1 = axis.cross(&across).normalize();
            let e2 = axis.cross(&e1);
            let mut points: Vec<(f32, f32)> = (0..CIRCLE_POINTS)
                .flat_map(|k| {
                    let phi = std::f64::consts::TAU * k as f64 / CIRCLE_POINTS as f64;
                    let rim = *radius * (phi.cos() * e1 + phi.sin() * e2);
                    [project(&(start + rim)), project(&(end + rim))]
                })
                .collect();
            let hull = convex_hull(&mut points);
            let mut pb = PathBuilder::new();
            if let Some((first, rest)) = hull.split_first() {
                pb.move_to(first.0, first.1);
                for p in rest {
                    pb.line_to(p.0, p.1);
                }
                pb.close();
            }
            if let Some(path) = pb.finish() {
                pixmap.fill_path(&path, &grey, FillRule::Winding, Transform::identity(), mask);
            }
        }
        PreviewShape::HalfSpace { point, normal } => {
            let view = 3 - r - u;
            let (nr, nu) = (normal[r], normal[u]);
            let across = (nr * nr + nu * nu).sqrt();
            if normal[view].abs() > 1e-6 || across == 0.0 {
                return;
            }
            // the region behind the plane's line, far beyond the panel
            let far = 10.0 * (camera.width.max(camera.height) as f64) / s;
            let (nr, nu) = (nr / across, nu / across);
            let (tr, tu) = (-nu, nr);
            let at = |a: f64, b: f64| {
                let mut p = [point.x, point.y, point.z];
                p[r] += a * tr - b * nr;
                p[u] += a * tu - b * nu;
                camera.project(i, p)
            };
            let mut pb = PathBuilder::new();
            let corners = [at(-far, 0.0), at(far, 0.0), at(far, far), at(-far, far)];
            pb.move_to(corners[0].0, corners[0].1);
            for c in &corners[1..] {
                pb.line_to(c.0, c.1);
            }
            pb.close();
            if let Some(path) = pb.finish() {
                pixmap.fill_path(&path, &grey, FillRule::Winding, Transform::identity(), mask);
            }
        }
        PreviewShape::Mesh {
            vertices,
            triangles,
        } => {
            // every projected triangle turned the same way: the winding rule fills their
            // union, the mesh's shadow
            let projected: Vec<(f32, f32)> = vertices.iter().map(project).collect();
            let mut pb = PathBuilder::new();
            for t in triangles.iter() {
                let (Some(&a), Some(&b), Some(&c)) = (
                    projected.get(t[0]),
                    projected.get(t[1]),
                    projected.get(t[2]),
                ) else {
                    continue;
                };
                let cross = (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
                let (b, c) = if cross < 0.0 { (c, b) } else { (b, c) };
                pb.move_to(a.0, a.1);
                pb.line_to(b.0, b.1);
                pb.line_to(c.0, c.1);
                pb.close();
            }
            if let Some(path) = pb.finish() {
                pixmap.fill_path(&path, &grey, FillRule::Winding, Transform::identity(), mask);
            }
        }
    }
}

/// Draw the render strands `points` (`per_strand` points each) in panel `i`: at most
/// [`PREVIEW_RENDER_STRANDS`], thin, translucent, in their groups' colours.
fn draw_render_strands(
    pixmap: &mut Pixmap,
    camera: &Camera,
    i: usize,
    points: &[[f32; 3]],
    per_strand: usize,
    colours: &[u16],
    groups: usize,
) {
    if per_strand == 0 {
        return;
    }
    let count = points.len() / per_strand;
    let step = count.div_ceil(PREVIEW_RENDER_STRANDS).max(1);
    for g in 0..groups.max(1) {
        let mut pb = PathBuilder::new();
        for s in (0..count).step_by(step) {
            if colours.get(s).copied().unwrap_or(0) as usize != g {
                continue;
            }
            for (j, p) in points[s * per_strand..(s + 1) * per_strand]
                .iter()
                .enumerate()
            {
                let (x, y) = camera.project(i, p.map(f64::from));
                if !(x.is_finite() && y.is_finite()) {
                    continue;
                }
                if j == 0 {
                    pb.move_to(x, y);
                } else {
                    pb.line_to(x, y);
                }
            }
        }
        if let Some(path) = pb.finish() {
            let light =
                group_colour(g).map(|v| (255 - ((255 - v as u32) * RENDER_LEVEL + 7) / 15) as u8);
            pixmap.stroke_path(
                &path,
                &paint(light),
                &stroke(RENDER_WIDTH),
                Transform::identity(),
                None,
            );
        }
    }
}

/// The longest 1, 2 or 5 × 10ⁿ m not longer than `max` m, and its label.
pub fn scale_bar_length(max: f64) -> (f64, String) {
    let mut best = (1e-6, "0.001 mm".to_string());
    for n in -6..=4 {
        for m in [1.0, 2.0, 5.0] {
            let len = m * 10f64.powi(n);
            if len <= max {
                best = (len, scale_label(len));
            }
        }
    }
    best
}

fn scale_label(len: f64) -> String {
    let (value, unit) = if len >= 1.0 {
        (len, "m")
    } else if len >= 0.01 {
        (len * 100.0, "cm")
    } else {
        (len * 1000.0, "mm")
    };
    // shortest decimal of a 1/2/5 x 10^n value
    let text = format!("{:.3}", value);
    let text = text.trim_end_matches('0').trim_end_matches('.');
    format!("{text} {unit}")
}

fn draw_scale_bar(pixmap: &mut Pixmap, camera: &Camera) {
    let max = camera.panel_width / 3.0 / camera.scale;
    let (len, label) = scale_bar_length(max);
    let px = (len * camera.scale) as f32;
    let x0 = 16.0f32;
    let y = camera.height as f32 - 14.0;
    let mut pb = PathBuilder::new();
    pb.move_to(x0, y - 4.0);
    pb.line_to(x0, y);
    pb.line_to(x0 + px, y);
    pb.line_to(x0 + px, y - 4.0);
    if let Some(path) = pb.finish() {
        pixmap.stroke_path(
            &path,
            &paint([INK_GREY; 3]),
            &stroke(1.5),
            Transform::identity(),
            None,
        );
    }
    draw_text(pixmap, &label, x0 + px + 8.0, y - 10.0, 10.0);
}

/// Strokes of a glyph on a 4 × 6 grid (y down; lower case on rows 2..6).
fn glyph(c: char) -> &'static [&'static [(f32, f32)]] {
    match c {
        '0' => &[
            &[(0., 0.), (4., 0.), (4., 6.), (0., 6.), (0., 0.)],
            &[(4., 0.), (0., 6.)],
        ],
        '1' => &[&[(1., 1.), (2., 0.), (2., 6.)], &[(1., 6.), (3., 6.)]],
        '2' => &[&[(0., 0.), (4., 0.), (4., 3.), (0., 3.), (0., 6.), (4., 6.)]],
        '3' => &[
            &[(0., 0.), (4., 0.), (4., 6.), (0., 6.)],
            &[(1., 3.), (4., 3.)],
        ],
        '4' => &[&[(0., 0.), (0., 3.), (4., 3.)], &[(4., 0.), (4., 6.)]],
        '5' => &[&[(4., 0.), (0., 0.), (0., 3.), (4., 3.), (4., 6.), (0., 6.)]],
        '6' => &[&[(4., 0.), (0., 0.), (0., 6.), (4., 6.), (4., 3.), (0., 3.)]],
        '7' => &[&[(0., 0.), (4., 0.), (1.5, 6.)]],
        '8' => &[
            &[(0., 0.), (4., 0.), (4., 6.), (0., 6.), (0., 0.)],
            &[(0., 3.), (4., 3.)],
        ],
        '9' => &[&[(4., 3.), (0., 3.), (0., 0.), (4., 0.), (4., 6.), (0., 6.)]],
        '.' => &[&[(1.5, 5.5), (2., 6.)]],
        '=' => &[&[(0., 2.5), (4., 2.5)], &[(0., 4.5), (4., 4.5)]],
        '-' => &[&[(0., 3.5), (4., 3.5)]],
        'c' => &[&[(4., 2.), (0., 2.), (0., 6.), (4., 6.)]],
        'm' => &[
            &[(0., 6.), (0., 2.), (4., 2.), (4., 6.)],
            &[(2., 2.), (2., 6.)],
        ],
        's' => &[&[(4., 2.), (0., 2.), (0., 4.), (4., 4.), (4., 6.), (0., 6.)]],
        't' => &[&[(1.5, 0.), (1.5, 6.), (4., 6.)], &[(0., 2.), (3.5, 2.)]],
        'd' => &[&[(4., 0.), (4., 6.), (0., 6.), (0., 2.), (4., 2.)]],
        'e' => &[&[(0., 4.), (4., 4.), (4., 2.), (0., 2.), (0., 6.), (4., 6.)]],
        'f' => &[
            &[(4., 0.), (2., 0.), (1., 1.), (1., 6.)],
            &[(0., 2.5), (3., 2.5)],
        ],
        'i' => &[&[(2., 2.), (2., 6.)], &[(2., 0.), (2., 0.7)]],
        'n' => &[
            &[(0., 6.), (0., 2.)],
            &[(0., 3.), (1., 2.), (4., 2.), (4., 6.)],
        ],
        'o' => &[&[(0., 2.), (4., 2.), (4., 6.), (0., 6.), (0., 2.)]],
        'p' => &[&[(0., 8.), (0., 2.), (4., 2.), (4., 5.), (0., 5.)]],
        'r' => &[&[(0., 6.), (0., 2.)], &[(0., 3.), (1., 2.), (4., 2.)]],
        'x' => &[&[(0., 2.), (4., 6.)], &[(4., 2.), (0., 6.)]],
        'y' => &[&[(0., 2.), (2., 5.)], &[(4., 2.), (1., 8.)]],
        'z' => &[&[(0., 2.), (4., 2.), (0., 6.), (4., 6.)]],
        '(' => &[&[(3., 0.), (1.5, 2.), (1.5, 5.), (3., 7.)]],
        ')' => &[&[(1., 0.), (2.5, 2.), (2.5, 5.), (1., 7.)]],
        _ => &[],
    }
}

/// Draw `text` with its top left corner at (`x`, `y`), `height` pixels tall.
fn draw_text(pixmap: &mut Pixmap, text: &str, x: f32, y: f32, height: f32) {
    let unit = height / 6.0;
    let mut pb = PathBuilder::new();
    for (n, c) in text.chars().enumerate() {
        let left = x + n as f32 * 6.5 * unit;
        for line in glyph(c) {
            for (j, &(gx, gy)) in line.iter().enumerate() {
                let (px, py) = (left + gx * unit, y + gy * unit);
                if j == 0 {
                    pb.move_to(px, py);
                } else {
                    pb.line_to(px, py);
                }
            }
        }
    }
    if let Some(path) = pb.finish() {
        pixmap.stroke_path(
            &path,
            &paint([INK_GREY; 3]),
            &stroke(1.3),
            Transform::identity(),
            None,
        );
    }
}

/// The time label of a picture: `t = 1.23 s`.
pub fn time_label(t: f64) -> String {
    format!("t = {t:.2} s")
}

/// Write `pixmap` as a PNG file at `path` (through a temporary file).
pub fn write_png(path: &Path, pixmap: &Pixmap) -> Result<()> {
    let bytes = pixmap.encode_png().map_err(|e| Error::Io {
        path: path.display().to_string(),
        source: std::io::Error::other(e.to_string()),
    })?;
    write_atomically(path, &bytes)
}

/// The scene of frame `k` of `store`: the bodies of `scenery` at the frame's head pose
/// and, with `render`, the frame's render strands.
pub fn frame_scene<'a>(
    store: &mut dyn FrameStore,
    k: usize,
    scenery: &Scenery,
    render: Option<&'a mut RenderFrames>,
) -> Result<FrameScene<'a>> {
    let head = scenery.head_at(store.state_time(k));
    let t = store.state_time(k);
    let bodies = scenery.bodies.iter().map(|b| b.placed(&head, t)).collect();
    let render = match render {
        None => None,
        Some(r) => {
            let per_strand = r.points_per_strand();
            r.frame(store, k, scenery)?;
            let r: &'a RenderFrames = r;
            let (points, groups) = r.last_frame();
            Some((points, per_strand, groups))
        }
    };
    Ok(FrameScene { bodies, render })
}

/// Render frame `k` of `store` and write it as the PNG `path`, with the bodies of
/// `scenery` and the render strands of `render`.
pub fn write_frame_png(
    path: &Path,
    store: &mut dyn FrameStore,
    k: usize,
    camera: &Camera,
    scenery: &Scenery,
    render: Option<&mut RenderFrames>,
) -> Result<()> {
    let mut points = Vec::new();
    store.points(k, &mut points)?;
    let label = time_label(store.time(k));
    let scene = frame_scene(store, k, scenery, render)?;
    let pixmap = render_frame(store.layout(), &points, camera, &scene, Some(&label))?;
    write_png(path, &pixmap)
}

/// The GIF's fixed palette: white, each [`PALETTE`] colour blended with white at 15
/// levels, and 32 greys from black to white (at most 256 entries).
pub fn gif_palette() -> Vec<[u8; 3]> {
    let mut palette = vec![[255, 255, 255]];
    for c in PALETTE {
        for level in 1..=15u32 {
            palette.push(c.map(|v| (255 - ((255 - v as u32) * level + 7) / 15) as u8));
        }
    }
    for g in 0..32u32 {
        let v = (g * 255 / 31) as u8;
        if !palette.contains(&[v, v, v]) {
            palette.push([v, v, v]);
        }
    }
    palette
}

/// Maps opaque pixels to the nearest palette entry, remembering colours seen.
struct Quantizer {
    palette: Vec<[u8; 3]>,
    seen: HashMap<[u8; 3], u8>,
}

impl Quantizer {
    fn new(palette: Vec<[u8; 3]>) -> Self {
        Self {
            palette,
            seen: HashMap::new(),
        }
    }

    fn index(&mut self, rgb: [u8; 3]) -> u8 {
        if let Some(&i) = self.seen.get(&rgb) {
            return i;
        }
        let mut best = (u32::MAX, 0usize);
        for (i, p) in self.palette.iter().enumerate() {
            let d: u32 = (0..3)
                .map(|c| (p[c] as i32 - rgb[c] as i32).pow(2) as u32)
                .sum();
            if d < best.0 {
                best = (d, i);
            }
        }
        // the palette has at most 256 entries
        let i = best.1 as u8;
        self.seen.insert(rgb, i);
        i
    }

    /// Palette indices of an opaque RGBA picture.
    fn indices(&mut self, rgba: &[u8]) -> Vec<u8> {
        rgba.chunks_exact(4)
            .map(|p| self.index([p[0], p[1], p[2]]))
            .collect()
    }
}

/// Frames the GIF shows: every `step`-th frame, `step` the smallest keeping at most
/// `max_frames`; the last frame is always included.
pub fn gif_frames(count: usize, max_frames: usize) -> Vec<usize> {
    if count == 0 {
        return Vec::new();
    }
    let step = count.div_ceil(max_frames.max(1)).max(1);
    let mut frames: Vec<usize> = (0..count).step_by(step).collect();
    if frames.last() != Some(&(count - 1)) {
        if frames.len() >= max_frames.max(1) {
            frames.pop();
        }
        frames.push(count - 1);
    }
    frames
}

/// Write the animation of `store` as the GIF `path` (see the module doc), with the bodies
/// of `scenery` and the render strands of `render`.
pub fn write_gif(
    path: &Path,
    store: &mut dyn FrameStore,
    camera: &Camera,
    options: &PreviewOptions,
    scenery: &Scenery,
    mut render: Option<&mut RenderFrames>,
) -> Result<()> {
    let count = store.frame_count();
    let frames = gif_frames(count, options.gif_max_frames);
    let step = if frames.len() > 1 {
        frames[1] - frames[0]
    } else {
        1
    };
    let fps = store.layout().output_fps;
    let delay = ((100.0 * step as f64 / fps).round() as u16).max(2);
    let palette = gif_palette();
    let flat: Vec<u8> = palette.iter().flatten().copied().collect();
    let (file, writer) = AtomicFile::create(path)?;
    let gif_error = |e: gif::EncodingError| file.error(std::io::Error::other(e.to_string()));
    let (w, h) = (camera.width as u16, camera.height as u16);
    let mut encoder = gif::Encoder::new(writer, w, h, &flat).map_err(gif_error)?;
    encoder
        .set_repeat(gif::Repeat::Infinite)
        .map_err(gif_error)?;
    let mut quantizer = Quantizer::new(palette);
    let mut points = Vec::new();
    for &k in &frames {
        store.points(k, &mut points)?;
        let label = time_label(store.time(k));
        let scene = frame_scene(store, k, scenery, render.as_deref_mut())?;
        let pixmap = render_frame(store.layout(), &points, camera, &scene, Some(&label))?;
        let frame = gif::Frame {
            width: w,
            height: h,
            delay,
            buffer: std::borrow::Cow::Owned(quantizer.indices(pixmap.data())),
            ..gif::Frame::default()
        };
        encoder.write_frame(&frame).map_err(gif_error)?;
    }
    let out = encoder.into_inner().map_err(|e| file.error(e))?;
    file.commit(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cylinder is drawn flat at its ends (not as the capsule about its axis): in the
    /// front view of one along z (10 cm across, 20 cm long), a point 2 cm beyond an end
    /// on the axis (inside the capsule) stays white, a point just inside an end's corner
    /// is grey; its extent is the cylinder's own box.
    #[test]
    fn a_cylinder_is_drawn_with_flat_ends() {
        let shape = PreviewShape::Cylinder {
            start: Vector3::new(0.0, 0.0, -0.1),
            end: Vector3::new(0.0, 0.0, 0.1),
            radius: 0.05,
        };
        let (lo, hi) = shape.extent().expect("finite");
        assert_eq!((lo, hi), ([-0.05, -0.05, -0.1], [0.05, 0.05, 0.1]));
        let mut bounds = Bounds::empty();
        bounds.include([-0.1, -0.1, -0.15]);
        bounds.include([0.1, 0.1, 0.15]);
        let camera = Camera::fit(&bounds, &PreviewOptions::default());
        let mut pixmap = Pixmap::new(camera.width, camera.height).expect("pixmap");
        pixmap.fill(Color::WHITE);
        draw_body(&mut pixmap, &camera, 0, &shape, None);
        let red = |p: [f64; 3]| {
            let (x, y) = camera.project(0, p);
            pixmap
                .pixel(x.round() as u32, y.round() as u32)
                .expect("inside")
                .red()
        };
        assert_eq!(red([0.0, 0.0, 0.12]), 255, "beyond the end");
        assert_eq!(red([0.0, 0.0, -0.12]), 255, "beyond the other end");
        assert_eq!(red([0.047, 0.0, 0.097]), BODY_GREY, "the corner");
        assert_eq!(red([-0.047, 0.0, -0.097]), BODY_GREY, "the other corner");
        assert_eq!(red([0.055, 0.0, 0.0]), 255, "beside it");
    }

    #[test]
    fn views_parse_and_name_what_is_allowed() {
        assert_eq!(
            View::parse_list("front,side,top"),
            Ok(vec![View::Front, View::Side, View::Top])
        );
        assert_eq!(View::parse_list(" top "), Ok(vec![View::Top]));
        assert!(View::parse_list("front,back")
            .is_err_and(|e| e.contains("'back'") && e.contains("front, side, top")));
        assert!(View::parse_list("side,side").is_err());
    }

    #[test]
    fn options_out_of_range_name_their_field() {
        let mut o = PreviewOptions {
            width: 10,
            ..PreviewOptions::default()
        };
        assert!(o
            .check("--")
            .is_err_and(|e| e.to_string().contains("--width")));
        o.width = 1200;
        assert!(o.check("--").is_ok());
        o.views.clear();
        assert!(o
            .check("output.")
            .is_err_and(|e| e.to_string().contains("output.views")));
    }

    #[test]
    fn the_scale_bar_is_the_longest_round_length_that_fits() {
        assert_eq!(scale_bar_length(0.13), (0.1, "10 cm".to_string()));
        assert_eq!(scale_bar_length(0.049).1, "2 cm");
        assert_eq!(scale_bar_length(0.0051).1, "5 mm");
        assert_eq!(scale_bar_length(3.0).1, "2 m");
    }

    #[test]
    fn gif_frames_keep_the_limit_and_the_last_frame() {
        assert_eq!(gif_frames(5, 200), vec![0, 1, 2, 3, 4]);
        assert_eq!(gif_frames(0, 200), Vec::<usize>::new());
        let f = gif_frames(1001, 200);
        assert!(f.len() <= 200, "{}", f.len());
        assert_eq!(f.last(), Some(&1000));
        assert_eq!(f[1] - f[0], 6);
    }

    #[test]
    fn the_gif_palette_holds_the_drawing_colours_exactly() {
        let p = gif_palette();
        assert!(p.len() <= 256, "{}", p.len());
        for c in PALETTE
            .iter()
            .chain(&[[255; 3], [BODY_GREY; 3], [FRAME_GREY; 3], [INK_GREY; 3]])
        {
            let mut q = Quantizer::new(p.clone());
            let i = q.index(*c) as usize;
            let d: i32 = (0..3)
                .map(|k| (p[i][k] as i32 - c[k] as i32).abs())
                .max()
                .unwrap_or(0);
            // greys are 255/31 apart: the nearest is within 4 levels; group colours exact
            assert!(
                d <= if PALETTE.contains(c) || *c == [255; 3] {
                    0
                } else {
                    4
                },
                "{c:?} -> {:?}",
                p[i]
            );
        }
    }
}
