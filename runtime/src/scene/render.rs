//! `[render]`: the render strands generated from the strands (the guides) at every frame
//! (see `crate::render` and `docs/interpolation.md`).

use super::reader::{Bound, Node, Range};
use crate::bodies::{Attachment, BodySetup};
use crate::render::settings::{MAX_RENDER_CLEARANCE, MAX_RENDER_DISTANCE, MAX_RENDER_STRANDS};
use crate::render::RenderSettings;

/// Read `[render]`; `bodies` are the scene's bodies (for `scalp_body`).
pub(super) fn read_render(mut n: Node<'_>, bodies: &[BodySetup]) -> Option<RenderSettings> {
    let d = RenderSettings::new(1);
    let distance = Range::new(Bound::Excl(0.0), Bound::Incl(MAX_RENDER_DISTANCE));
    let strands = n.required(
        "strands",
        &format!("the number of render strands, an integer in [1, {MAX_RENDER_STRANDS}]"),
        |n, k| n.count(k, 1, MAX_RENDER_STRANDS as i64, "the cap on render strands"),
    );
    let clumping = n.optional_f64(
        "clumping",
        d.clumping,
        Range::new(Bound::Incl(0.0), Bound::Incl(1.0)),
    );
    let tip_distance = if n.has("tip_distance") {
        n.f64("tip_distance", distance).map(Some)
    } else {
        Some(None)
    };
    let max_spacing = if n.has("max_spacing") {
        n.f64("max_spacing", distance).map(Some)
    } else {
        Some(None)
    };
    let clearance = if n.has("clearance") {
        n.f64(
            "clearance",
            Range::new(Bound::Incl(0.0), Bound::Incl(MAX_RENDER_CLEARANCE)),
        )
        .map(Some)
    } else {
        Some(None)
    };
    let seed = n.optional("seed", d.seed, Node::seed);
    let scalp_body = if n.has("scalp_body") {
        n.string("scalp_body").and_then(|name| {
            let names: Vec<&str> = bodies.iter().map(|b| b.name.as_str()).collect();
            match bodies.iter().position(|b| b.name == name) {
                Some(i) if bodies[i].attached == Attachment::Head => Some(Some(i)),
                Some(_) => {
                    n.error(
                        "scalp_body",
                        format!("body '{name}' is attached to the world: the scalp must be attached to the head"),
                    );
                    None
                }
                None => {
                    n.error(
                        "scalp_body",
                        format!("no body named '{name}' in [[bodies]] (bodies: {names:?})"),
                    );
                    None
                }
            }
        })
    } else {
        Some(None)
    };
    n.finish();
    Some(RenderSettings {
        strands: strands?,
        clumping: clumping?,
        tip_distance: tip_distance?,
        seed: seed?,
        max_spacing: max_spacing?,
        scalp_body: scalp_body?,
        clearance: clearance?,
    })
}
