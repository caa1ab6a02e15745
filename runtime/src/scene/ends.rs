//! `[strands.ends]`: how a strand's root and tip are held (`root = "clamped" | "pinned" |
//! "free"`,
//! a `[strands.ends.tip]` table for a held tip), see [`crate::model::ends`].

use super::head::read_motion;
use super::reader::{Bound, Node, Range};
use crate::config::{HeldEnd, StrandSetup};
use crate::forces::head_motion::HeadMotion;
use crate::model::ends::{HeldKind, RootEnd};
use crate::model::reconstruction::pose_at;
use nalgebra::{Matrix3, Vector3};

const ROOTS: [&str; 3] = ["clamped", "pinned", "free"];
const TIPS: [&str; 5] = ["free", "pinned", "clamped", "sliding", "clamped-sliding"];

/// What a `[strands.ends]` table asks for, before the strand exists.
#[derive(Debug, Clone)]
pub(super) struct EndsSpec {
    root: RootEnd,
    tip: Option<TipSpec>,
}

#[derive(Debug, Clone)]
struct TipSpec {
    kind: HeldKind,
    position: Option<Vector3<f64>>,
    direction: Option<Vector3<f64>>,
    normal: Option<Vector3<f64>>,
    axis: Option<Vector3<f64>>,
    motion: HeadMotion,
}

/// Read `[strands.ends]` (absent: the hair's ends). `None` when invalid (reported).
pub(super) fn read_ends(n: &mut Node<'_>) -> Option<EndsSpec> {
    let Some(mut e) = n.table("ends") else {
        return (!n.has("ends")).then_some(EndsSpec {
            root: RootEnd::Clamped,
            tip: None,
        });
    };
    let root = e.optional("root", 0, |e, k| {
        e.choice(k, &ROOTS, |name| ROOTS.iter().position(|&r| r == name))
    });
    let tip = match e.table("tip") {
        Some(t) => read_tip(t).map(Some),
        None if e.has("tip") => None,
        None => Some(None),
    };
    e.finish();
    Some(EndsSpec {
        root: [RootEnd::Clamped, RootEnd::Pinned, RootEnd::Free][root?],
        tip: tip?.flatten(),
    })
}

fn read_tip(mut t: Node<'_>) -> Option<Option<TipSpec>> {
    let what = format!("one of {}", TIPS.join(", "));
    let kind = t.required("kind", &what, |t, k| {
        t.choice(k, &TIPS, |name| TIPS.iter().position(|&r| r == name))
    });
    let kind = match kind? {
        0 => {
            t.finish();
            return Some(None);
        }
        1 => HeldKind::Pinned,
        2 => HeldKind::Clamped,
        3 => HeldKind::Sliding,
        _ => HeldKind::ClampedSliding,
    };
    let optional_vec = |t: &mut Node<'_>, key: &'static str, unit: bool| {
        if !t.has(key) {
            return Some(None);
        }
        let v = if unit { t.unit(key) } else { t.vec3(key) };
        v.map(Some)
    };
    let position = optional_vec(&mut t, "position", false);
    let (direction, normal) = if kind.holds_frame() {
        (
            optional_vec(&mut t, "direction", true),
            optional_vec(&mut t, "normal", true),
        )
    } else {
        (Some(None), Some(None))
    };
    let axis = if kind.slides() {
        optional_vec(&mut t, "axis", true)
    } else {
        Some(None)
    };
    let motion = match t.table("motion") {
        Some(m) => read_motion(m),
        None if t.has("motion") => None,
        None => Some(HeadMotion::Still),
    };
    t.finish();
    Some(Some(TipSpec {
        kind,
        position: position?,
        direction: direction?,
        normal: normal?,
        axis: axis?,
        motion: motion?,
    }))
}

/// Largest rotation of a pinned or free root's frame from its starting orientation in a
/// given `q0`, rad (the joint's coordinates times its length): many turns, far beyond a
/// rod's.
const MAX_ROOT_ROTATION: f64 = 1e3;

impl EndsSpec {
    /// A `q0` longer than the strand's 3N is the whole q of a run (a pinned root's joint
    /// first, a free root's translation last): true when it fits this root and every value
    /// is in range (each problem reported on `n`), or when `q0` has 3N values.
    fn whole_q_fits(&self, n: &Node<'_>, setup: &StrandSetup) -> bool {
        let chain = setup.strand.geometry.dofs();
        let given = setup.q0.len();
        if given == chain {
            return true;
        }
        let (expected, root) = match self.root {
            RootEnd::Clamped => (chain, "clamped"),
            RootEnd::Pinned => (chain + 3, "pinned"),
            RootEnd::Free => (chain + 6, "free"),
        };
        if given != expected {
            n.error(
                "q0",
                format!(
                    "has {given} values, the whole q of a {} root; this strand's root is {root}: give 3N = {chain}{}",
                    if given == chain + 3 { "pinned" } else { "free" },
                    if expected > chain {
                        format!(" or its whole q, {expected}")
                    } else {
                        String::new()
                    }
                ),
            );
            return false;
        }
        let joint = crate::model::ends::ROOT_JOINT_FRACTION * setup.strand.geometry.length();
        let rotation = Range::new(
            Bound::Incl(-MAX_ROOT_ROTATION / joint),
            Bound::Incl(MAX_ROOT_ROTATION / joint),
        );
        let ok = setup.q0.iter().enumerate().all(|(i, &x)| {
            let range = if i < 3 {
                rotation
            } else if i < 3 + chain {
                super::strands::CURVATURE_RANGE
            } else {
                Range::POSITION
            };
            n.check(&format!("q0[{i}]"), x, range).is_some()
        });
        if !ok {
            n.error(
                "q0",
                format!(
                    "the whole q of a {root} root: its first three values are the root joint's (rad/m: the root frame's rotation over the joint's length l₀ = 10⁻¹⁰ L, at most {MAX_ROOT_ROTATION} rad){}",
                    if self.root == RootEnd::Free {
                        ", its last three the root's translation (m)"
                    } else {
                        ""
                    }
                ),
            );
        }
        ok
    }

    /// Apply to a strand just built: pin its root (inserting the joint), hold its tip
    /// (defaults from the tip's pose at q0, in the holder's frame at t = 0). Errors
    /// are reported on `n`.
    pub(super) fn apply(&self, n: &Node<'_>, setup: &mut StrandSetup) {
        if !self.whole_q_fits(n, setup) {
            return;
        }
        match self.root {
            RootEnd::Clamped => {}
            RootEnd::Pinned => setup.strand.pin_root(&mut setup.q0),
            RootEnd::Free => setup.strand.free_root(&mut setup.q0),
        }
        let Some(tip) = &self.tip else { return };
        let g = &setup.strand.geometry;
        let pose = pose_at(g, &setup.q0, g.length());
        let m0 = tip.motion.state(0.0);
        let to_holder = m0.rotation.transpose();
        let position = tip
            .position
            .unwrap_or_else(|| to_holder * (pose.position - m0.position));
        let frame = match tip.direction {
            Some(n0) => {
                let raw = tip
                    .normal
                    .unwrap_or_else(|| crate::model::ends::perpendicular(&n0));
                let n1 = raw - n0 * n0.dot(&raw);
                if n1.norm() < 1e-6 {
                    n.error("ends.tip.normal", "must not be parallel to direction");
                    return;
                }
                let n1 = n1.normalize();
                Matrix3::from_columns(&[n0, n1, n0.cross(&n1)])
            }
            None => to_holder * pose.frame,
        };
        let axis = tip
            .axis
            .unwrap_or_else(|| to_holder * pose.frame.column(0).into_owned());
        setup.tip = Some(HeldEnd {
            kind: tip.kind,
            position,
            frame,
            axis,
            motion: tip.motion.clone(),
        });
    }
}
