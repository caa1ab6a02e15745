//! `[contacts]` and `[contacts.hair_hair]`: hair–body contacts and hair–hair interaction
//! (see `forces::contacts`).

use super::reader::{kind, Bound, Node, Range};
use crate::bodies::BodySetup;
use crate::forces::contacts::{ContactConfig, Coupling, Friction, HairHairConfig, RodFriction};
use toml::Value;

/// Read `[contacts]`, checking body names against `bodies`.
pub(super) fn read_contacts(mut n: Node<'_>, bodies: &[BodySetup]) -> Option<ContactConfig> {
    let d = ContactConfig::default();
    let names: Vec<&str> = bodies.iter().map(|b| b.name.as_str()).collect();
    let body_list = match n.raw("bodies") {
        None => Some(None),
        Some(Value::Array(items)) => {
            let mut list = Vec::new();
            let mut ok = true;
            for (i, item) in items.iter().enumerate() {
                match item.as_str() {
                    Some(name) if names.contains(&name) => list.push(name.to_string()),
                    Some(name) => {
                        n.error(
                            "bodies",
                            format!("[{i}] = '{name}': no body of that name in [[bodies]] (bodies: {names:?})"),
                        );
                        ok = false;
                    }
                    None => {
                        n.error(
                            "bodies",
                            format!("[{i}]: expected a body name, got {}", kind(item)),
                        );
                        ok = false;
                    }
                }
            }
            ok.then_some(Some(list))
        }
        Some(v) => {
            n.error(
                "bodies",
                format!("expected a list of body names, got {}", kind(v)),
            );
            None
        }
    };
    if bodies.is_empty() && !n.has("hair_hair") {
        n.error(
            "bodies",
            "the scene has no [[bodies]] and no [contacts.hair_hair]: nothing to touch",
        );
    }
    let radius = n.optional_f64(
        "radius",
        d.radius,
        Range::new(Bound::Excl(0.0), Bound::Incl(0.1)),
    );
    let stiffness = if n.has("stiffness") {
        n.f64("stiffness", Range::new(Bound::Excl(0.0), Bound::Incl(1e9)))
            .map(Some)
    } else {
        Some(None)
    };
    let damping_ratio = n.optional_f64(
        "damping_ratio",
        d.damping_ratio,
        Range::new(Bound::Incl(0.0), Bound::Incl(10.0)),
    );
    let max_depth = if n.has("max_depth") {
        n.f64("max_depth", Range::new(Bound::Excl(0.0), Bound::Incl(1.0)))
            .map(Some)
    } else {
        Some(None)
    };
    let split_depth = if n.has("split_depth") {
        n.f64(
            "split_depth",
            Range::new(Bound::Excl(0.0), Bound::Incl(1.0)),
        )
        .map(Some)
    } else {
        Some(None)
    };
    let depenetration_speed = n.optional_f64(
        "depenetration_speed",
        d.depenetration_speed,
        Range::new(Bound::Excl(0.0), Bound::Incl(100.0)),
    );
    let anisotropy = n.optional_f64(
        "anisotropy",
        d.anisotropy,
        Range::new(Bound::Incl(0.0), Bound::Incl(0.99)),
    );
    let samples = n.optional("samples_per_element", d.samples_per_element, |n, k| {
        n.count(k, 1, 64, "the cap on contact samples per element")
    });
    let end_samples = if n.has("end_samples") {
        super::reader::boolean(&mut n, "end_samples", true).map(Some)
    } else {
        Some(d.end_samples)
    };
    let predict = super::reader::boolean(&mut n, "predict", d.predict);
    let models = ["none", "viscous", "coulomb"];
    let model = n.optional("friction", "viscous", |n, k| {
        n.choice(k, &models, |s| models.iter().copied().find(|m| *m == s))
    });
    let mu = n.optional_f64(
        "friction_coefficient",
        0.3,
        Range::new(Bound::Incl(0.0), Bound::Incl(10.0)),
    );
    let kinetic = if n.has("kinetic_friction_coefficient") {
        n.f64(
            "kinetic_friction_coefficient",
            Range::new(Bound::Incl(0.0), Bound::Incl(10.0)),
        )
        .map(Some)
    } else {
        Some(None)
    };
    let slip_speed = n.optional_f64(
        "slip_speed",
        0.05,
        Range::new(Bound::Excl(0.0), Bound::Incl(100.0)),
    );
    let ratio = n.optional_f64(
        "tangential_stiffness_ratio",
        1.0,
        Range::new(Bound::Excl(0.0), Bound::Incl(100.0)),
    );
    let hair_hair = match n.table("hair_hair") {
        None => Some(None),
        Some(mut h) => {
            let hd = HairHairConfig::default();
            let radius = h.optional_f64(
                "radius",
                hd.radius,
                Range::new(Bound::Excl(0.0), Bound::Incl(0.1)),
            );
            let stiffness = if h.has("stiffness") {
                h.f64("stiffness", Range::new(Bound::Excl(0.0), Bound::Incl(1e9)))
                    .map(Some)
            } else {
                Some(None)
            };
            let damping_ratio = h.optional_f64(
                "damping_ratio",
                hd.damping_ratio,
                Range::new(Bound::Incl(0.0), Bound::Incl(10.0)),
            );
            let every = h.optional("search_every", hd.search_every, |n, k| {
                n.count(k, 1, 1000, "the cap on steps between searches")
            });
            let max_pairs = h.optional("max_pairs_per_sample", hd.max_pairs_per_sample, |n, k| {
                n.count(k, 1, 64, "the cap on the pairs a contact sample keeps")
            });
            let self_contact = super::reader::boolean(&mut h, "self_contact", false);
            let couplings = ["pair", "ball"];
            let coupling = h.optional("coupling", "ball", |n, k| {
                n.choice(k, &couplings, |s| {
                    couplings.iter().copied().find(|m| *m == s)
                })
            });
            let split_depth = if h.has("split_depth") {
                h.f64(
                    "split_depth",
                    Range::new(Bound::Excl(0.0), Bound::Incl(1.0)),
                )
                .map(Some)
            } else {
                Some(None)
            };
            let self_exclusion = if h.has("self_exclusion") {
                h.f64(
                    "self_exclusion",
                    Range::new(Bound::Excl(0.0), Bound::Incl(10.0)),
                )
                .map(Some)
            } else {
                Some(None)
            };
            let hh_models = ["none", "coulomb"];
            let hh_model = h.optional("friction", "none", |n, k| {
                n.choice(k, &hh_models, |s| {
                    hh_models.iter().copied().find(|m| *m == s)
                })
            });
            let hh_mu = h.optional_f64(
                "friction_coefficient",
                0.3,
                Range::new(Bound::Incl(0.0), Bound::Incl(10.0)),
            );
            let hh_kinetic = if h.has("kinetic_friction_coefficient") {
                h.f64(
                    "kinetic_friction_coefficient",
                    Range::new(Bound::Incl(0.0), Bound::Incl(10.0)),
                )
                .map(Some)
            } else {
                Some(None)
            };
            let hh_ratio = h.optional_f64(
                "tangential_stiffness_ratio",
                1.0,
                Range::new(Bound::Excl(0.0), Bound::Incl(100.0)),
            );
            let hh_friction = match (hh_model, hh_mu, hh_kinetic, hh_ratio) {
                (Some("coulomb"), Some(mu), Some(kinetic), Some(ratio)) => {
                    let kinetic = kinetic.unwrap_or(mu);
                    if kinetic > mu {
                        h.error(
                            "kinetic_friction_coefficient",
                            format!("{kinetic}: must be in [0, friction_coefficient = {mu}]"),
                        );
                        None
                    } else {
                        Some(Some(RodFriction {
                            static_coefficient: mu,
                            kinetic_coefficient: kinetic,
                            stiffness_ratio: ratio,
                        }))
                    }
                }
                (Some(_), Some(_), Some(_), Some(_)) => Some(None),
                _ => None,
            };
            h.finish();
            match (
                radius,
                stiffness,
                damping_ratio,
                every,
                self_contact,
                self_exclusion,
                split_depth,
                hh_friction,
                max_pairs,
                coupling,
            ) {
                (
                    Some(radius),
                    Some(stiffness),
                    Some(damping_ratio),
                    Some(search_every),
                    Some(self_contact),
                    Some(self_exclusion),
                    Some(split_depth),
                    Some(friction),
                    Some(max_pairs_per_sample),
                    Some(coupling),
                ) => Some(Some(HairHairConfig {
                    radius,
                    stiffness,
                    damping_ratio,
                    search_every,
                    self_contact,
                    self_exclusion,
                    split_depth,
                    friction,
                    max_pairs_per_sample,
                    coupling: if coupling == "ball" {
                        Coupling::Ball
                    } else {
                        Coupling::Pair
                    },
                })),
                _ => None,
            }
        }
    };
    let (mu, kinetic) = (mu?, kinetic?);
    let friction = match model? {
        "none" => Friction::None,
        "coulomb" => {
            let kinetic = kinetic.unwrap_or(mu);
            if kinetic > mu {
                n.error(
                    "kinetic_friction_coefficient",
                    format!("{kinetic}: must be in [0, friction_coefficient = {mu}]"),
                );
                return None;
            }
            Friction::Coulomb {
                static_coefficient: mu,
                kinetic_coefficient: kinetic,
                stiffness_ratio: ratio?,
            }
        }
        _ => Friction::Viscous {
            coefficient: mu,
            slip_speed: slip_speed?,
        },
    };
    n.finish();
    Some(ContactConfig {
        bodies: body_list?,
        radius: radius?,
        stiffness: stiffness?,
        damping_ratio: damping_ratio?,
        max_depth: max_depth?,
        depenetration_speed: depenetration_speed?,
        friction,
        anisotropy: anisotropy?,
        samples_per_element: samples?,
        end_samples: end_samples?,
        split_depth: split_depth?,
        hair_hair: hair_hair?,
        predict: predict?,
    })
}
