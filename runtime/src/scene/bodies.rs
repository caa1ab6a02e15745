//! The `[[bodies]]` tables: the head and obstacles as shapes, attached to the head, fixed
//! in the world, or on their own rigid motion (a `[bodies.motion]` table, read as the
//! head's `[head.motion]`). A mesh's or a grid's `path` is taken relative to the scene file's folder; the
//! file itself is read when the simulation is built ([`crate::bodies::Bodies::build`]).

use super::head::read_motion;
use super::reader::{Bound, Node, Range};
use crate::bodies::setup::{MAX_BODY_SIZE, MAX_MESH_SCALE};
use crate::bodies::{Attachment, BodySetup, ShapeSetup};
use nalgebra::{Matrix3, Rotation3, Vector3};
use std::collections::HashMap;
use std::path::Path;

/// Shapes as written in scenes.
const SHAPES: [&str; 7] = [
    "sphere",
    "ellipsoid",
    "capsule",
    "plane",
    "mesh",
    "cylinder",
    "grid",
];

/// Radii, half-axes and cells, m.
const SIZE: Range = Range::new(Bound::Excl(0.0), Bound::Incl(MAX_BODY_SIZE));
/// A mesh's scale.
const SCALE: Range = Range::new(Bound::Excl(0.0), Bound::Incl(MAX_MESH_SCALE));

/// The bodies of `[[bodies]]`, in order; mesh paths resolved against `scene_dir`.
/// Problems are recorded on the nodes; the result then lacks the invalid bodies.
pub(super) fn read_bodies(root: &mut Node<'_>, scene_dir: &Path) -> Vec<BodySetup> {
    let mut first_use: HashMap<String, String> = HashMap::new();
    let mut out = Vec::new();
    for (i, mut n) in root.tables("bodies").into_iter().enumerate() {
        let name = n.optional("name", format!("body{i}"), |n, k| {
            n.string(k).map(str::to_string)
        });
        let attached = attachment(&mut n);
        let what = format!("one of {}", SHAPES.join(", "));
        let kind = n.required("shape", &what, |n, k| {
            n.choice(k, &SHAPES, |s| SHAPES.iter().position(|&m| m == s))
        });
        let shape = match kind {
            Some(0) => sphere(&mut n),
            Some(1) => ellipsoid(&mut n),
            Some(2) => capsule(&mut n),
            Some(3) => plane(&mut n),
            Some(4) => mesh(&mut n, scene_dir),
            Some(5) => cylinder(&mut n),
            Some(6) => grid(&mut n, scene_dir),
            _ => None,
        };
        if let Some(name) = &name {
            if let Some(previous) = first_use.get(name) {
                n.error(
                    "name",
                    format!("duplicate body name '{name}' (already used by {previous})"),
                );
            } else {
                first_use.insert(name.clone(), n.own_path().to_string());
            }
        }
        // With an unknown shape the other fields cannot be checked: do not call them unknown.
        if kind.is_some() {
            n.finish();
        }
        if let (Some(name), Some(attached), Some(shape)) = (name, attached, shape) {
            out.push(BodySetup {
                name,
                attached,
                shape,
            });
        }
    }
    out
}

/// Names of `attached`.
const ATTACHED: [&str; 3] = ["head", "world", "motion"];

/// `attached` and, for `attached = "motion"` (the default when the body has one), the
/// `[bodies.motion]` table: the same kinds and fields as `[head.motion]`.
fn attachment(n: &mut Node<'_>) -> Option<Attachment> {
    let table = n.table("motion");
    let has_motion = n.has("motion");
    let default = if has_motion { "motion" } else { "head" };
    let name = n.optional("attached", default, |n, k| {
        n.choice(k, &ATTACHED, |s| {
            ATTACHED.iter().find(|&&a| a == s).copied()
        })
    })?;
    match (name, table) {
        ("motion", Some(table)) => read_motion(table).map(Attachment::Motion),
        // present but not a table: already reported
        ("motion", None) if has_motion => None,
        ("motion", None) => n.missing(
            "motion",
            "a [bodies.motion] table (kind = one of still, oscillate, translate-oscillate, \
             keyframes, sudden-stop, jolt, and its fields, as in [head.motion])",
        ),
        (other, _) if has_motion => {
            n.error(
                "motion",
                format!(
                    "only for a body with attached = \"motion\" (this one has attached = \"{other}\")"
                ),
            );
            None
        }
        (other, _) => Attachment::from_name(other),
    }
}

fn center(n: &mut Node<'_>, key: &'static str) -> Option<Vector3<f64>> {
    n.optional(key, Vector3::zeros(), Node::position)
}

fn radius(n: &mut Node<'_>) -> Option<f64> {
    n.required_f64("radius", "radius in m", SIZE)
}

/// `rotation_axis_angle_deg`: a rotation vector (axis times angle in degrees).
fn rotation(n: &mut Node<'_>) -> Option<Matrix3<f64>> {
    let v = n.optional("rotation_axis_angle_deg", Vector3::zeros(), Node::vec3)?;
    Some(Rotation3::new(v * 1f64.to_radians()).into_inner())
}

fn sphere(n: &mut Node<'_>) -> Option<ShapeSetup> {
    let center = center(n, "center");
    let radius = radius(n);
    Some(ShapeSetup::Sphere {
        center: center?,
        radius: radius?,
    })
}

fn ellipsoid(n: &mut Node<'_>) -> Option<ShapeSetup> {
    let center = center(n, "center");
    let what = format!("[a, b, c], half-axes in m, each {SIZE}");
    let radii = n.required("radii", &what, |n, k| n.fixed_list(k, 3, SIZE));
    let rotation = rotation(n);
    let radii = radii?;
    Some(ShapeSetup::Ellipsoid {
        center: center?,
        radii: Vector3::new(radii[0], radii[1], radii[2]),
        rotation: rotation?,
    })
}

fn capsule(n: &mut Node<'_>) -> Option<ShapeSetup> {
    let start = n.required(
        "start",
        "[x, y, z] in m, one end of the axis",
        Node::position,
    );
    let end = n.required(
        "end",
        "[x, y, z] in m, the other end of the axis",
        Node::position,
    );
    let radius = radius(n);
    Some(ShapeSetup::Capsule {
        start: start?,
        end: end?,
        radius: radius?,
    })
}

fn cylinder(n: &mut Node<'_>) -> Option<ShapeSetup> {
    let start = n.required(
        "start",
        "[x, y, z] in m, the centre of one cap",
        Node::position,
    );
    let end = n.required(
        "end",
        "[x, y, z] in m, the centre of the other cap",
        Node::position,
    );
    let radius = radius(n);
    Some(ShapeSetup::Cylinder {
        start: start?,
        end: end?,
        radius: radius?,
    })
}

fn plane(n: &mut Node<'_>) -> Option<ShapeSetup> {
    let point = center(n, "point");
    let normal = n.required("normal", "a non-zero 3-vector (outward)", Node::unit);
    Some(ShapeSetup::Plane {
        point: point?,
        normal: normal?,
    })
}

fn mesh(n: &mut Node<'_>, scene_dir: &Path) -> Option<ShapeSetup> {
    let path = n.required(
        "path",
        "the OBJ file, relative to the scene file",
        |n, k| {
            let path = n.string(k)?;
            if path.is_empty() {
                n.error(k, "must name an OBJ file");
                return None;
            }
            Some(scene_dir.join(path))
        },
    );
    let cell = if n.has("cell") {
        n.f64("cell", SIZE).map(Some)
    } else {
        Some(None)
    };
    let scale = n.optional_f64("scale", 1.0, SCALE);
    let rotation = rotation(n);
    let translation = center(n, "translation");
    Some(ShapeSetup::Mesh {
        path: path?,
        cell: cell?,
        scale: scale?,
        rotation: rotation?,
        translation: translation?,
    })
}

fn grid(n: &mut Node<'_>, scene_dir: &Path) -> Option<ShapeSetup> {
    let path = n.required(
        "path",
        "the .npy file of signed distances (float64, shape (nz, ny, nx)), relative to the scene file",
        |n, k| {
            let path = n.string(k)?;
            if path.is_empty() {
                n.error(k, "must name a .npy file");
                return None;
            }
            Some(scene_dir.join(path))
        },
    );
    let origin = n.required(
        "origin",
        "[x, y, z] in m, the position of node (0, 0, 0)",
        Node::position,
    );
    let cell = n.required_f64("cell", "the distance between neighbouring nodes in m", SIZE);
    Some(ShapeSetup::Grid {
        path: path?,
        origin: origin?,
        cell: cell?,
    })
}
