//! The `ends` group of `superhelix stress`: rods held otherwise than a hair (a pinned
//! or free root, a tip pinned, clamped, sliding, clamped on a slider or driven, a follower load),
//! each at N = 5 and 20 and at 30 and 100 frames per second, under gravity.
//!
//! Each case is a scene (the TOML a user would write), so what is stressed is what a
//! scene gets. Besides the checks of every case ([`super::stress`]: finite values, exact
//! inextensibility, the kinetic-energy budget), a held tip's drift from its holder must
//! stay within 10⁻⁹ L after every step, and a rod whose holders are fixed and on which no
//! load works (all but the driven holder and the follower load) must not gain energy.

use crate::runtime::parse_scene;
use crate::stress::{Case, Checks, LENGTH};

/// Frames per second of the cases (the step is one frame).
const RATES: [u32; 2] = [30, 100];
/// Elements of the cases.
const ELEMENTS: [usize; 2] = [5, 20];
/// Simulated time of a case, s.
const DURATION: f64 = 1.5;

/// The points of a circular arc from the origin to (span, 0, 0) of arc length `length`,
/// sagging below the chord (in −z): the start of the ropes.
fn sagging_arc(length: f64, span: f64) -> String {
    let x = crate::runtime::model::ends::arc_half_angle(length, span);
    let radius = 0.5 * length / x;
    let points: Vec<String> = (0..=40)
        .map(|k| {
            // angle from the start, the arc's centre above the chord's middle
            let a = -x + 2.0 * x * k as f64 / 40.0;
            let centre_z = radius * x.cos();
            format!(
                "[{}, 0.0, {}]",
                0.5 * span + radius * a.sin(),
                centre_z - radius * a.cos()
            )
        })
        .collect();
    format!("polyline = [{}]", points.join(", "))
}

/// GJ and EI of the `smooth` preset (the cases' fibre), N·m².
fn stiffnesses() -> (f64, f64) {
    parse_scene("[[strands]]\nlength = 0.25\n")
        .map(|s| {
            let k = s.strands[0].strand.material.stiffness;
            (k[0], k[1])
        })
        .unwrap_or((f64::NAN, f64::NAN))
}

/// Every case of the group.
pub fn end_cases() -> Vec<Case> {
    let l = LENGTH;
    let (gj, ei) = stiffnesses();
    let arc = sagging_arc(l, 0.8 * l);
    let still = Checks {
        periodic: false,
        energy_from: Some(0.0),
    };
    let worked = Checks {
        periodic: false,
        energy_from: None,
    };
    let periodic = Checks {
        periodic: true,
        energy_from: None,
    };
    // (tag, the [[strands]] fields beyond length and elements, checks)
    let kinds: Vec<(&str, String, Checks)> = vec![
        (
            "pinned-root/fall",
            "direction = [1.0, 0.0, 0.0]\n[strands.ends]\nroot = \"pinned\"\n".into(),
            still,
        ),
        (
            "pinned-root/fall/frictionless",
            "direction = [1.0, 0.0, 0.0]\ninternal_friction = 0.0\nair_drag = 0.0\n\
             [strands.ends]\nroot = \"pinned\"\n"
                .into(),
            still,
        ),
        (
            // a free rod in no gravity, released straight from its natural curvature
            // (2 rad over its length): it flails and drifts, its energy constant
            "free-root/flail",
            "direction = [1.0, 0.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\nnatural = [0.0, 8.0, 0.0]\n\
             initial = \"straight\"\ninternal_friction = 0.0\nair_drag = 0.0\n\
             [strands.ends]\nroot = \"free\"\n\
             [environment]\ngravity = \"none\"\n"
                .into(),
            still,
        ),
        (
            // a free rod at its natural shape (an arc of 2 rad) dropped onto a floor with
            // Coulomb friction, 2.3 cm below its lowest point
            "free-root/floor",
            "direction = [1.0, 0.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\nnatural = [0.0, 8.0, 0.0]\n\
             initial = \"natural\"\n[strands.ends]\nroot = \"free\"\n\
             [[bodies]]\nname = \"floor\"\nshape = \"plane\"\npoint = [0.0, 0.0, -0.2]\n\
             normal = [0.0, 0.0, 1.0]\n[contacts]\nfriction = \"coulomb\"\n"
                .into(),
            still,
        ),
        (
            "rope",
            format!("{arc}\n[strands.ends]\nroot = \"pinned\"\n[strands.ends.tip]\nkind = \"pinned\"\n"),
            still,
        ),
        (
            "rope/frictionless",
            format!(
                "{arc}\ninternal_friction = 0.0\nair_drag = 0.0\n[strands.ends]\nroot = \"pinned\"\n\
                 [strands.ends.tip]\nkind = \"pinned\"\n"
            ),
            still,
        ),
        (
            "clamped-both",
            format!("{arc}\n[strands.ends.tip]\nkind = \"clamped\"\n"),
            still,
        ),
        (
            // a column under twice Euler's clamped–pinned load, from a slight bend
            "sliding/buckle",
            format!(
                "direction = [0.0, 0.0, 1.0]\nnatural = [0.0, 0.5, 0.0]\n\
                 [[strands.point_loads]]\ns = {l}\nforce = [0.0, 0.0, {}]\n\
                 [strands.ends.tip]\nkind = \"sliding\"\n",
                -2.0 * 20.19 * ei / (l * l)
            ),
            still,
        ),
        (
            // twisted 1.5 times past Greenhill's critical twist, from a slight bend
            "clamped-sliding/twist",
            {
                let phi = 1.5 * 8.98682 * ei / gj;
                format!(
                    "direction = [1.0, 0.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\n\
                     natural = [{}, 0.2, 0.0]\ninitial = \"natural\"\n\
                     [strands.ends.tip]\nkind = \"clamped-sliding\"\n",
                    phi / l
                )
            },
            still,
        ),
        (
            // the rope's tip held by a holder moving up and down, 2 cm at 2 Hz
            "driven",
            format!(
                "{arc}\n[strands.ends]\nroot = \"pinned\"\n[strands.ends.tip]\nkind = \"pinned\"\n\
                 [strands.ends.tip.motion]\nkind = \"translate-oscillate\"\n\
                 direction = [0.0, 0.0, 1.0]\namplitude = 0.02\nfrequency_hz = 2.0\n"
            ),
            periodic,
        ),
        (
            // a terminal load across the tip (along its n2), 5 EI/L²
            "follower",
            format!(
                "direction = [1.0, 0.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\n\
                 [[strands.point_loads]]\ns = {l}\nforce = [0.0, 0.0, {}]\nfollows = true\n",
                5.0 * ei / (l * l)
            ),
            worked,
        ),
    ];
    let mut cases = Vec::new();
    for (tag, fields, checks) in &kinds {
        for n in ELEMENTS {
            for fps in RATES {
                let duration = if checks.periodic {
                    crate::stress::PERIODIC_DURATION
                } else {
                    DURATION
                };
                let text = format!(
                    "[simulation]\ndt = {}\nduration = {duration}\nengine = \"runtime\"\n\
                     [[strands]]\nname = \"rod\"\nlength = {l}\nelements = {n}\n{fields}",
                    1.0 / fps as f64
                );
                // a polyline gives the length itself
                let text = if fields.contains("polyline") {
                    text.replace(&format!("length = {l}\n"), "")
                } else {
                    text
                };
                let name = format!("ends/{tag}/N{n}/fps{fps}");
                match parse_scene(&text) {
                    Ok(setup) => cases.push(Case {
                        quick: n == 5 && fps == 30 && !tag.contains("frictionless"),
                        name,
                        group: "ends",
                        setup,
                        checks: *checks,
                    }),
                    // a scene of this file that does not parse is a defect of the file
                    Err(e) => panic!("stress case {name}: {e}"),
                }
            }
        }
    }
    cases
}

/// Whether a case holds a tip (`[strands.ends.tip]`): its step is linearly implicit
/// Euler's at fixed steps, on the runtime engine.
pub fn holds_a_tip(case: &Case) -> bool {
    case.setup.strands.iter().any(|s| s.tip.is_some())
}

/// Whether a strand of `case` has a pinned or free root (not clamped).
pub fn frees_the_root(case: &Case) -> bool {
    case.setup
        .strands
        .iter()
        .any(|s| s.strand.ends.root != crate::runtime::model::ends::RootEnd::Clamped)
}
