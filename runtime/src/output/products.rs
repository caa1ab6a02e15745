//! The files written after a run from its frames: `hair.usda`, `preview.png`,
//! `preview_first.png`, `preview.gif`, `last_frame.obj`, as [`Formats`] says; the stage
//! and the pictures with the render strands and the pictures with the bodies of the
//! run's [`Scenery`].

use super::frames::FrameStore;
use super::obj::{write_obj, OBJ_FILE};
use super::plan::Formats;
use super::preview::{
    frame_bounds, write_frame_png, write_gif, Camera, PreviewOptions, FIRST_PNG_FILE, GIF_FILE,
    PNG_FILE, PREVIEW_RENDER_STRANDS,
};
use super::render_strands::RenderFrames;
use super::scenery::Scenery;
use super::usd::{write_usda, USDA_FILE};
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Write the post-run files `formats` asks for (`usda`, `png`, `gif`, `obj`; `json` and
/// `npy` are written while the run goes) into `dir` from the frames of `store`, with the
/// camera settings `view`, the bodies and head motion of `scenery` and its render strands
/// (placed once on the first frame). Returns the files written; nothing when `store` has
/// no frame. `view.frame` (default: the last frame) must be a frame of `store`.
pub fn write_products(
    store: &mut dyn FrameStore,
    formats: &Formats,
    dir: &Path,
    view: &PreviewOptions,
    scenery: &Scenery,
) -> Result<Vec<PathBuf>> {
    let count = store.frame_count();
    let mut written = Vec::new();
    if count == 0 {
        return Ok(written);
    }
    view.check("preview.")?;
    let shown = view.frame.unwrap_or(count - 1);
    if shown >= count {
        return Err(Error::invalid(
            "preview.frame",
            format!(
                "{shown} is out of range: the run wrote frames 0..={}",
                count - 1
            ),
        ));
    }
    std::fs::create_dir_all(dir).map_err(|source| Error::Io {
        path: dir.display().to_string(),
        source,
    })?;
    // the stage takes every render strand, the pictures only those they draw
    let mut render = match &scenery.render {
        Some(source) if formats.usda || formats.png || formats.gif => {
            let stride = match formats.usda {
                true => 1,
                false => source.settings.strands.div_ceil(PREVIEW_RENDER_STRANDS),
            };
            Some(RenderFrames::new(store, source, scenery, stride)?)
        }
        _ => None,
    };
    if formats.usda {
        let path = dir.join(USDA_FILE);
        write_usda(&path, store, render.as_mut().map(|r| (r, scenery)))?;
        written.push(path);
    }
    if formats.png || formats.gif {
        let bounds = frame_bounds(store, scenery)?;
        let camera = Camera::fit(&bounds, view);
        if formats.png {
            for (name, k) in [(PNG_FILE, shown), (FIRST_PNG_FILE, 0)] {
                let path = dir.join(name);
                write_frame_png(&path, store, k, &camera, scenery, render.as_mut())?;
                written.push(path);
            }
        }
        if formats.gif {
            let path = dir.join(GIF_FILE);
            write_gif(&path, store, &camera, view, scenery, render.as_mut())?;
            written.push(path);
        }
    }
    if formats.obj {
        let path = dir.join(OBJ_FILE);
        write_obj(&path, store)?;
        written.push(path);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::frames::{FrameLayout, StrandInfo};
    use crate::output::preview::{group_colour, PreviewBody};

    /// Frames held in memory.
    struct VecStore {
        layout: FrameLayout,
        frames: Vec<Vec<[f64; 3]>>,
    }

    impl FrameStore for VecStore {
        fn layout(&self) -> &FrameLayout {
            &self.layout
        }
        fn frame_count(&self) -> usize {
            self.frames.len()
        }
        fn time(&self, k: usize) -> f64 {
            k as f64 / self.layout.output_fps
        }
        fn points(&mut self, k: usize, out: &mut Vec<[f64; 3]>) -> Result<()> {
            out.clear();
            out.extend_from_slice(&self.frames[k]);
            Ok(())
        }
    }

    /// Two groups ("left": two strands, "right": one) of 5-point strands hanging from
    /// z = 0 and swinging in x over `frames` frames.
    fn store(frames: usize) -> VecStore {
        let strand = |name: &str, group: &str| StrandInfo {
            name: name.into(),
            group: group.into(),
            radius: 4e-5,
            points: 5,
            coordinates: 3,
        };
        let layout = FrameLayout {
            strands: vec![
                strand("l0", "left"),
                strand("r 0", "right"),
                strand("l1", "left"),
            ],
            output_fps: 25.0,
            planned_frames: frames,
            held_tips: Vec::new(),
        };
        let roots = [-0.1, 0.1, -0.05];
        let frames = (0..frames)
            .map(|k| {
                let swing = 0.05 * (k as f64 * 0.3).sin();
                roots
                    .iter()
                    .flat_map(|&x| {
                        (0..5).map(move |j| {
                            [
                                x + swing * j as f64 / 4.0,
                                0.01 * j as f64,
                                -0.05 * j as f64,
                            ]
                        })
                    })
                    .collect()
            })
            .collect();
        VecStore { layout, frames }
    }

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("superhelix-products-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    fn all() -> Formats {
        Formats {
            json: false,
            npy: false,
            usda: true,
            png: true,
            gif: true,
            obj: true,
        }
    }

    fn ok<T>(r: Result<T>) -> T {
        r.unwrap_or_else(|e| panic!("{e}"))
    }

    fn read(path: &Path) -> String {
        std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
    }

    #[test]
    fn every_product_is_written_and_nothing_else() {
        let dir = scratch("all");
        let mut s = store(12);
        let files = ok(write_products(
            &mut s,
            &all(),
            &dir,
            &PreviewOptions::default(),
            &Scenery::default(),
        ));
        let names: Vec<_> = files
            .iter()
            .filter_map(|f| f.file_name()?.to_str())
            .collect();
        assert_eq!(
            names,
            [
                "hair.usda",
                "preview.png",
                "preview_first.png",
                "preview.gif",
                "last_frame.obj"
            ]
        );
        let mut present: Vec<_> = std::fs::read_dir(&dir)
            .map(|d| {
                d.filter_map(|e| e.ok()?.file_name().into_string().ok())
                    .collect()
            })
            .unwrap_or_default();
        present.sort();
        // no temporary file is left
        assert_eq!(
            present,
            [
                "hair.usda",
                "last_frame.obj",
                "preview.gif",
                "preview.png",
                "preview_first.png"
            ]
        );
        let only_obj = Formats {
            usda: false,
            png: false,
            gif: false,
            ..all()
        };
        let dir2 = scratch("obj-only");
        assert_eq!(
            ok(write_products(
                &mut s,
                &only_obj,
                &dir2,
                &PreviewOptions::default(),
                &Scenery::default(),
            ))
            .len(),
            1
        );
        assert!(ok(write_products(
            &mut store(0),
            &all(),
            &scratch("none"),
            &PreviewOptions::default(),
            &Scenery::default(),
        ))
        .is_empty());
    }

    #[test]
    fn a_frame_out_of_range_is_refused() {
        let view = PreviewOptions {
            frame: Some(12),
            ..PreviewOptions::default()
        };
        let e = write_products(
            &mut store(12),
            &all(),
            &scratch("frame"),
            &view,
            &Scenery::default(),
        );
        assert!(e.is_err_and(
            |e| e.to_string().contains("preview.frame") && e.to_string().contains("0..=11")
        ));
    }

    #[test]
    fn the_obj_holds_the_last_frame_as_one_polyline_per_strand() {
        let dir = scratch("obj");
        let mut s = store(7);
        let formats = Formats {
            usda: false,
            png: false,
            gif: false,
            ..all()
        };
        ok(write_products(
            &mut s,
            &formats,
            &dir,
            &PreviewOptions::default(),
            &Scenery::default(),
        ));
        let text = read(&dir.join(OBJ_FILE));
        let objects: Vec<&str> = text.lines().filter(|l| l.starts_with("o ")).collect();
        assert_eq!(objects, ["o l0", "o r_0", "o l1"]);
        let vertices: Vec<[f64; 3]> = text
            .lines()
            .filter_map(|l| l.strip_prefix("v "))
            .map(|l| {
                let v: Vec<f64> = l.split(' ').filter_map(|x| x.parse().ok()).collect();
                [v[0], v[1], v[2]]
            })
            .collect();
        assert_eq!(vertices.len(), 15);
        for (v, p) in vertices.iter().zip(&s.frames[6]) {
            for c in 0..3 {
                // written as float32: relative error below 2^-24
                assert!(
                    (v[c] - p[c]).abs() <= 1e-7 * p[c].abs().max(1e-3),
                    "{v:?} vs {p:?}"
                );
            }
        }
        let lines: Vec<&str> = text.lines().filter(|l| l.starts_with("l ")).collect();
        assert_eq!(lines, ["l 1 2 3 4 5", "l 6 7 8 9 10", "l 11 12 13 14 15"]);
    }

    #[test]
    fn the_usda_has_one_curves_prim_per_group_with_every_frame() {
        let dir = scratch("usda");
        let mut s = store(3);
        let formats = Formats {
            png: false,
            gif: false,
            obj: false,
            ..all()
        };
        ok(write_products(
            &mut s,
            &formats,
            &dir,
            &PreviewOptions::default(),
            &Scenery::default(),
        ));
        let text = read(&dir.join(USDA_FILE));
        assert!(text.starts_with("#usda 1.0\n"));
        for needle in [
            "upAxis = \"Z\"",
            "metersPerUnit = 1",
            "timeCodesPerSecond = 25",
            "startTimeCode = 0",
            "endTimeCode = 2",
            "def BasisCurves \"left\"",
            "def BasisCurves \"right\"",
            "uniform token type = \"linear\"",
            "int[] curveVertexCounts = [5, 5]",
            "int[] curveVertexCounts = [5]",
            "interpolation = \"vertex\"",
            // 2 x radius 4e-5
            "float[] widths = [8e-5, 8e-5, 8e-5, 8e-5, 8e-5]",
        ] {
            assert!(text.contains(needle), "{needle} missing");
        }
        let [r, g, b] = group_colour(1);
        assert!(text.contains(&format!(
            "primvars:displayColor = [({}, {}, {})]",
            r as f32 / 255.0,
            g as f32 / 255.0,
            b as f32 / 255.0
        )));
        // frame 2 of group "left" = strands l0 then l1
        let left = text.split("def BasisCurves \"right\"").next().unwrap_or("");
        let line = left
            .lines()
            .find(|l| l.trim_start().starts_with("2: ["))
            .unwrap_or("");
        let first = s.frames[2][0];
        let f = |c: usize| crate::output::usd::format_f32(first[c] as f32);
        assert!(
            line.starts_with(&format!("            2: [({}, {}, {})", f(0), f(1), f(2))),
            "{line}"
        );
        assert_eq!(line.matches('(').count(), 10);
        assert!(!dir.join("hair.usda.tmp").exists());
    }

    #[test]
    fn pictures_show_each_group_in_its_colour_and_bodies_in_grey() {
        let dir = scratch("png");
        let mut s = store(4);
        let view = PreviewOptions {
            width: 400,
            height: 300,
            ..PreviewOptions::default()
        };
        let scenery = Scenery {
            bodies: vec![PreviewBody::sphere([0.0, 0.0, 0.05], 0.04)],
            ..Scenery::default()
        };
        let formats = Formats {
            usda: false,
            gif: false,
            obj: false,
            ..all()
        };
        ok(write_products(&mut s, &formats, &dir, &view, &scenery));
        let bytes = std::fs::read(dir.join(PNG_FILE)).unwrap_or_default();
        let pixmap = tiny_skia::Pixmap::decode_png(&bytes).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((pixmap.width(), pixmap.height()), (400, 300));
        let count = |rgb: [u8; 3]| {
            pixmap
                .data()
                .chunks_exact(4)
                .filter(|p| p[..3] == rgb)
                .count()
        };
        // fully covered pixels of each group's colour: a 20 cm strand at ~1000 px/m
        for g in 0..2 {
            assert!(
                count(group_colour(g)) > 40,
                "group {g}: {}",
                count(group_colour(g))
            );
        }
        assert_eq!(count(group_colour(2)), 0);
        assert!(count([0xdd; 3]) > 1000, "body");
    }

    #[test]
    fn the_gif_has_the_frames_at_the_output_rate() {
        let dir = scratch("gif");
        let mut s = store(9);
        let view = PreviewOptions {
            width: 200,
            height: 100,
            gif_max_frames: 4,
            ..PreviewOptions::default()
        };
        let formats = Formats {
            usda: false,
            png: false,
            obj: false,
            ..all()
        };
        ok(write_products(
            &mut s,
            &formats,
            &dir,
            &view,
            &Scenery::default(),
        ));
        let bytes = std::fs::read(dir.join(GIF_FILE)).unwrap_or_default();
        assert_eq!(&bytes[..6], b"GIF89a");
        assert_eq!(u16::from_le_bytes([bytes[6], bytes[7]]), 200);
        assert_eq!(u16::from_le_bytes([bytes[8], bytes[9]]), 100);
        // frames 0, 3, 6, 8: four image descriptors with a delay of 3 / 25 s = 12 cs
        let controls: Vec<u16> = bytes
            .windows(8)
            .filter(|w| w[0] == 0x21 && w[1] == 0xf9 && w[2] == 4)
            .map(|w| u16::from_le_bytes([w[4], w[5]]))
            .collect();
        assert_eq!(controls, [12, 12, 12, 12]);
    }
}

#[cfg(test)]
mod body_pictures {
    use crate::bodies::{Attachment, BodySetup, ShapeSetup};
    use crate::forces::head_motion::HeadMotion;
    use crate::output::frames::FrameLayout;
    use crate::output::preview::{render_frame, Bounds, Camera, FrameScene, PreviewOptions};
    use crate::output::scenery::{PreviewBody, Scenery};
    use nalgebra::{Matrix3, Vector3};
    use superhelix_kernels::head::HeadState;

    const WHITE: f64 = 255.0;
    const GREY: f64 = 221.0;

    fn empty() -> FrameLayout {
        FrameLayout {
            strands: Vec::new(),
            output_fps: 25.0,
            planned_frames: 1,
            held_tips: Vec::new(),
        }
    }

    fn camera() -> Camera {
        let bounds = Bounds {
            lo: [-0.2, -0.2, -0.4],
            hi: [0.2, 0.2, 0.2],
        };
        let options = PreviewOptions {
            width: 1200,
            height: 800,
            ..PreviewOptions::default()
        };
        Camera::fit(&bounds, &options)
    }

    /// Covered area (px²) and coverage-weighted centroid (px) in the front panel (the left
    /// half) of `body` drawn at head state `head` at t = 0: each pixel covers
    /// (255 − v) / (255 − 221) of itself, from its anti-aliased grey v.
    fn coverage(body: &PreviewBody, head: &HeadState) -> (f64, f64, f64) {
        coverage_at(body, head, 0.0)
    }

    /// [`coverage`] at time `t`.
    fn coverage_at(body: &PreviewBody, head: &HeadState, t: f64) -> (f64, f64, f64) {
        let scene = FrameScene {
            bodies: vec![body.placed(head, t)],
            render: None,
        };
        let pixmap =
            render_frame(&empty(), &[], &camera(), &scene, None).unwrap_or_else(|e| panic!("{e}"));
        let (w, h) = (pixmap.width() as usize, pixmap.height() as usize);
        let (mut area, mut cx, mut cy) = (0.0, 0.0, 0.0);
        for y in 40..h - 60 {
            for x in 10..w / 2 - 10 {
                let v = pixmap.data()[4 * (y * w + x)] as f64;
                let c = ((WHITE - v) / (WHITE - GREY)).clamp(0.0, 1.0);
                area += c;
                cx += c * x as f64;
                cy += c * y as f64;
            }
        }
        (area, cx / area.max(1e-300), cy / area.max(1e-300))
    }

    #[test]
    fn bodies_are_drawn_at_their_size_and_move_with_the_head() {
        let s = camera().scale();
        let ball = PreviewBody {
            attached: Attachment::Head,
            ..PreviewBody::sphere([0.0, 0.0, 0.08], 0.03)
        };
        let rest = HeadState::rest();
        let (area, x0, y0) = coverage(&ball, &rest);
        let expected = std::f64::consts::PI * (0.03 * s).powi(2);
        // anti-aliased coverage: the area to 1 %
        assert!(
            (area / expected - 1.0).abs() < 0.01,
            "{area} px² vs {expected}"
        );
        // the head 5 cm along x and turned by 90° about z: the ball, 8 cm above the
        // origin on the z axis, moves by 5 cm along x only
        let motion = HeadMotion::TranslateOscillate {
            direction: Vector3::x(),
            amplitude: 0.05,
            frequency_hz: 1.0,
        };
        let mut moved = motion.state(0.25);
        moved.rotation = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
        let (area1, x1, y1) = coverage(&ball, &moved);
        assert!((area1 - area).abs() < 0.01 * area);
        assert!(
            (x1 - x0 - 0.05 * s).abs() < 0.05,
            "{} px vs {}",
            x1 - x0,
            0.05 * s
        );
        assert!((y1 - y0).abs() < 0.05);
        // a body fixed in the world stays
        let fixed = PreviewBody::sphere([0.0, 0.0, 0.08], 0.03);
        let (_, xf, _) = coverage(&fixed, &moved);
        assert!((xf - x0).abs() < 0.05);
        // a body on its own motion is drawn where its motion is at the frame's time,
        // whatever the head does: 5 cm along x at t = 0.25 s, back at t = 0.5 s
        let own = PreviewBody {
            attached: Attachment::Motion(motion.clone()),
            ..PreviewBody::sphere([0.0, 0.0, 0.08], 0.03)
        };
        let (area2, x2, y2) = coverage_at(&own, &rest, 0.25);
        assert!((area2 - area).abs() < 0.01 * area);
        assert!((x2 - x0 - 0.05 * s).abs() < 0.05, "{} px", x2 - x0);
        assert!((y2 - y0).abs() < 0.05);
        let (_, x3, _) = coverage_at(&own, &moved, 0.5);
        assert!((x3 - x0).abs() < 0.05, "{} px", x3 - x0);

        // a capsule: a stadium of 2 r L + π r²; an ellipsoid turned in the x-z plane
        let capsule = PreviewBody::from_setup(&BodySetup {
            name: "c".into(),
            attached: Attachment::World,
            shape: ShapeSetup::Capsule {
                start: Vector3::new(-0.05, 0.0, -0.3),
                end: Vector3::new(0.05, 0.0, -0.3),
                radius: 0.02,
            },
        })
        .unwrap_or_else(|e| panic!("{e}"));
        let (area, _, _) = coverage(&capsule, &rest);
        let expected = (0.04 * 0.1 + std::f64::consts::PI * 0.0004) * s * s;
        assert!((area / expected - 1.0).abs() < 0.01, "{area} vs {expected}");
        let turn = nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), 0.7).into_inner();
        let ellipsoid = PreviewBody::from_setup(&BodySetup {
            name: "e".into(),
            attached: Attachment::Head,
            shape: ShapeSetup::Ellipsoid {
                center: Vector3::zeros(),
                radii: Vector3::new(0.06, 0.02, 0.03),
                rotation: turn,
            },
        })
        .unwrap_or_else(|e| panic!("{e}"));
        // its shadow along y is the ellipse of half-axes 6 cm and 3 cm, turned
        let (area, _, _) = coverage(&ellipsoid, &rest);
        let expected = std::f64::consts::PI * 0.06 * 0.03 * s * s;
        assert!((area / expected - 1.0).abs() < 0.01, "{area} vs {expected}");

        // a cube mesh of side 4 cm: its shadow is a 4 cm square
        let dir = std::env::temp_dir().join(format!("superhelix-mesh-{}", std::process::id()));
        let _ = std::fs::create_dir_all(&dir);
        let path = dir.join("cube.obj");
        let cube = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
                    f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
        std::fs::write(&path, cube).unwrap_or_else(|e| panic!("{e}"));
        let mesh = PreviewBody::from_setup(&BodySetup {
            name: "m".into(),
            attached: Attachment::World,
            shape: ShapeSetup::Mesh {
                path,
                cell: None,
                scale: 0.04,
                rotation: Matrix3::identity(),
                translation: Vector3::new(0.1, 0.0, 0.1),
            },
        })
        .unwrap_or_else(|e| panic!("{e}"));
        let (area, _, _) = coverage(&mesh, &rest);
        let expected = 0.04 * 0.04 * s * s;
        assert!((area / expected - 1.0).abs() < 0.02, "{area} vs {expected}");

        // a floor seen edge on fills the panel below its line; seen from above, nothing
        let floor = PreviewBody::from_setup(&BodySetup {
            name: "f".into(),
            attached: Attachment::World,
            shape: ShapeSetup::Plane {
                point: Vector3::new(0.0, 0.0, -0.35),
                normal: Vector3::z(),
            },
        })
        .unwrap_or_else(|e| panic!("{e}"));
        let (area, _, cy) = coverage(&floor, &rest);
        let (_, line) = camera().project(0, [0.0, 0.0, -0.35]);
        assert!(
            area > 100.0 && cy > line as f64,
            "{area} px² at y {cy} vs the line at {line}"
        );
        let tilted = PreviewBody::from_setup(&BodySetup {
            name: "t".into(),
            attached: Attachment::World,
            shape: ShapeSetup::Plane {
                point: Vector3::new(0.0, 0.0, -0.35),
                normal: Vector3::new(0.0, 0.6, 0.8),
            },
        })
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(coverage(&tilted, &rest).0, 0.0);
        let scenery = Scenery {
            head: motion,
            bodies: vec![ball, floor],
            render: None,
        };
        // the floor does not count in the bounds; the ball does, at every pose
        assert!(scenery.bodies[1].placed(&rest, 0.0).extent().is_none());
        let (lo, hi) = scenery.bodies[0]
            .placed(&scenery.head_at(0.25), 0.25)
            .extent()
            .unwrap_or_else(|| panic!("no extent"));
        for (got, want) in lo
            .iter()
            .chain(&hi)
            .zip([0.02, -0.03, 0.05, 0.08, 0.03, 0.11])
        {
            assert!((got - want).abs() < 1e-15, "{lo:?} {hi:?}");
        }
    }
}
