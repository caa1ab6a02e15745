//! The per-sample contact law (module page of [`crate::contact`]): the parameters, the
//! friction models, the Coulomb spring and the response of one sample touching a body.

use nalgebra::{Matrix3, Vector3};

type V3 = Vector3<f64>;
type M3 = Matrix3<f64>;

/// How the tangential (friction) force of a hair–body contact is modelled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Friction {
    /// Frictionless contact.
    None,
    /// The paper's tangential viscous friction (section 4.2), scaled by the normal force:
    /// `f_t = −μ(θ) f_n v_t / v_s`, Coulomb's force at the slip speed v_s.
    Viscous {
        /// μ, ≥ 0.
        coefficient: f64,
        /// v_s, m/s, > 0.
        slip_speed: f64,
    },
    /// Coulomb friction with real sticking: each contact point is held to an anchor on
    /// the body by a tangential spring while `|f_t| ≤ μ_s(θ) f_n`, and slides (its anchor
    /// dragged behind it) with `|f_t| = μ_k(θ) f_n` otherwise.
    Coulomb {
        /// μ_s, ≥ 0.
        static_coefficient: f64,
        /// μ_k, in [0, μ_s].
        kinetic_coefficient: f64,
        /// Tangential spring stiffness over the normal penalty stiffness, > 0.
        stiffness_ratio: f64,
    },
}

/// Coulomb friction between rods: coefficients and the tangential spring's stiffness
/// over the normal penalty's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RodFriction {
    /// μ_s, ≥ 0.
    pub static_coefficient: f64,
    /// μ_k, in [0, μ_s].
    pub kinetic_coefficient: f64,
    /// k_t / k, > 0.
    pub stiffness_ratio: f64,
}

/// The resolved contact parameters of one strand.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactParams {
    /// Contact radius r, m.
    pub radius: f64,
    /// Normal penalty stiffness k, N/m².
    pub stiffness: f64,
    /// Normal damping c per metre, N·s/m².
    pub damping: f64,
    /// δ_max, m.
    pub max_depth: f64,
    /// A step taking a new contact deeper than this is split, m.
    pub split_depth: f64,
    /// Speed at which a point that started inside a body is let out, m/s.
    pub depenetration_speed: f64,
    /// Friction model.
    pub friction: Friction,
    /// α.
    pub anisotropy: f64,
}

/// The tangential spring of a Coulomb contact (bodies or rods): its force and stiffness
/// matrix for the slip `slip` (in the plane of `tangent_plane`), stiffness `stiff`; while
/// sticking `−stiff · slip`; beyond the static limit `limit`, or while `sliding`, the
/// kinetic force `kinetic` along the slip, whose only stiffness is that of its turning.
pub fn coulomb_spring(
    tangent_plane: &M3,
    slip: &V3,
    stiff: f64,
    limit: f64,
    kinetic: f64,
    sliding: bool,
) -> (V3, M3) {
    let norm = slip.norm();
    if (sliding || stiff * norm > limit) && norm > 0.0 {
        let dir = slip / norm;
        (
            -kinetic * dir,
            (kinetic / norm) * (tangent_plane - dir * dir.transpose()),
        )
    } else {
        (-stiff * slip, stiff * tangent_plane)
    }
}

/// The friction between two rods at an anchored pair (Coulomb, `f`): the force on this
/// strand, its stiffness matrix and its damping matrix, for the slip `slip` of the
/// anchored point across the line of centres (`plane`), its velocity `rel` relative to
/// what it is held to, the spring's stiffness `stiff` and the normal force `normal`; the
/// anchor slid over the last step when `sliding`, and `step` is that step's length, s.
/// Sticking, the spring `−stiff · slip` (up to μ_s f_n). Sliding (over the last step, or
/// beyond the static limit now), the kinetic force μ_k f_n against the slip predicted at
/// the step's end, u = slip + h v_t: the slip now, within μ δ / ratio, is far shorter
/// than a step's motion, and its direction would lag a step behind; its turning with the
/// velocity goes in the damping, h (μ_k f_n / |u|) (P − ûûᵀ).
#[allow(clippy::too_many_arguments)]
pub fn rod_friction(
    f: &RodFriction,
    sliding: bool,
    step: f64,
    plane: &M3,
    slip: &V3,
    rel: &V3,
    stiff: f64,
    normal: f64,
) -> (V3, M3, M3) {
    let kinetic = f.kinetic_coefficient * normal;
    let limit = f.static_coefficient * normal;
    let slides = sliding || stiff * slip.norm() > limit;
    let predicted = slip + plane * rel * step;
    if slides && predicted.norm() > 0.0 {
        let (spring, kt) = coulomb_spring(plane, &predicted, stiff, 0.0, kinetic, true);
        (spring, M3::zeros(), kt * step)
    } else {
        let (spring, kt) = coulomb_spring(plane, slip, stiff, limit, kinetic, false);
        (spring, kt, M3::zeros())
    }
}

/// The energy of a rod friction spring (see [`rod_friction`]): `|f_t|² / (2 k_t)` of the
/// force it holds at `slip`, and that force.
pub fn rod_spring_energy(
    f: &RodFriction,
    sliding: bool,
    plane: &M3,
    slip: &V3,
    stiff: f64,
    normal: f64,
) -> (f64, V3) {
    let (spring, _) = coulomb_spring(
        plane,
        slip,
        stiff,
        f.static_coefficient * normal,
        f.kinetic_coefficient * normal,
        sliding,
    );
    (0.5 * spring.norm_squared() / stiff, spring)
}

/// What one sample touching a body contributes, head coordinates: its forces and the
/// 3 × 3 matrices the step projects with the sample's Jacobian.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleLaw {
    /// The normal penalty `k w min(δ, δ_max) n`.
    pub normal: V3,
    /// The Coulomb spring (zero without an anchor or without Coulomb friction).
    pub spring: V3,
    /// The stiffness of the normal penalty: k w below δ_max, else 0.
    pub normal_stiffness: f64,
    /// The spring's stiffness matrix (`k_t w P` while it sticks, its turning while it
    /// slides).
    pub spring_stiffness: M3,
    /// The whole force: elastic, normal damping and viscous friction.
    pub force: V3,
    /// The damping matrix (`−c w n nᵀ`, and `−c_t P` with viscous friction).
    pub damping: M3,
}

impl SampleLaw {
    /// The elastic force, normal penalty and spring.
    pub fn elastic(&self) -> V3 {
        self.normal + self.spring
    }

    /// The stiffness matrix of the elastic force, `−k w n nᵀ − K_t` (`n` the normal).
    pub fn stiffness(&self, n: &V3) -> M3 {
        -self.normal_stiffness * n * n.transpose() - self.spring_stiffness
    }
}

/// The elastic part of a body contact's response: the normal penalty, the Coulomb spring
/// and their stiffnesses (see [`SampleLaw`]), for a sample of weight `w` at effective
/// depth `depth` (> 0: touching) under the outward normal `n`, the strand's unit tangent
/// `t` there, at `y` (head coordinates), held to `anchor` (head coordinates, and whether
/// it slid over the last step) under Coulomb friction.
#[allow(clippy::too_many_arguments)]
pub fn body_elastic(
    p: &ContactParams,
    w: f64,
    depth: f64,
    n: &V3,
    t: &V3,
    y: &V3,
    anchor: Option<(V3, bool)>,
) -> (V3, V3, f64, M3) {
    let normal = p.stiffness * w * depth.clamp(0.0, p.max_depth) * n;
    let kn = if depth < p.max_depth {
        p.stiffness * w
    } else {
        0.0
    };
    let (mut spring, mut kt) = (V3::zeros(), M3::zeros());
    if let Friction::Coulomb {
        static_coefficient,
        kinetic_coefficient,
        stiffness_ratio,
    } = p.friction
    {
        if let Some((a, sliding)) = anchor {
            let tangent_plane = M3::identity() - n * n.transpose();
            let slip = tangent_plane * (y - a);
            let stiff = stiffness_ratio * p.stiffness * w;
            let norm = slip.norm();
            let cos = if norm > 0.0 { t.dot(&slip) / norm } else { 0.0 };
            let scale = 1.0 + p.anisotropy * cos;
            let limit = static_coefficient * scale * normal.norm();
            let kinetic = kinetic_coefficient * scale * normal.norm();
            (spring, kt) = coulomb_spring(&tangent_plane, &slip, stiff, limit, kinetic, sliding);
        }
    }
    (normal, spring, kn, kt)
}

/// The dissipative part of a body contact's response added to `force` (the elastic
/// force on entry): the normal damping and, with viscous friction, the friction scaled by
/// the normal force's magnitude `normal_force`, for a sample of weight `w` under the
/// normal `n` with tangent `t`, moving at `velocity` relative to the body. Returns the
/// force and the damping matrix.
pub fn body_damping(
    p: &ContactParams,
    w: f64,
    n: &V3,
    t: &V3,
    normal_force: f64,
    velocity: &V3,
    mut force: V3,
) -> (V3, M3) {
    let mut damping = M3::zeros();
    let cn = p.damping * w;
    force -= cn * n.dot(velocity) * n;
    damping -= cn * n * n.transpose();
    if let Friction::Viscous {
        coefficient,
        slip_speed,
    } = p.friction
    {
        let plane = M3::identity() - n * n.transpose();
        let slide = plane * velocity;
        let norm = slide.norm();
        let cos = if norm > 0.0 {
            t.dot(&slide) / norm
        } else {
            0.0
        };
        let ct = coefficient * (1.0 + p.anisotropy * cos) * normal_force / slip_speed;
        force -= ct * slide;
        damping -= ct * plane;
    }
    (force, damping)
}

/// The response of one sample of weight `w` at effective depth `depth` (> 0: touching)
/// under the outward normal `n`, the strand's unit tangent `t` there, at `y` (head
/// coordinates), with the anchor `anchor` it is held to (head coordinates, and whether it
/// slid over the last step) under Coulomb friction, its velocity `velocity` relative to
/// the body: the module page's law ([`body_elastic`], then [`body_damping`]).
#[allow(clippy::too_many_arguments)]
pub fn body_sample(
    p: &ContactParams,
    w: f64,
    depth: f64,
    n: &V3,
    t: &V3,
    y: &V3,
    anchor: Option<(V3, bool)>,
    velocity: &V3,
) -> SampleLaw {
    let (normal, spring, kn, kt) = body_elastic(p, w, depth, n, t, y, anchor);
    let (force, damping) = body_damping(p, w, n, t, normal.norm(), velocity, normal + spring);
    SampleLaw {
        normal,
        spring,
        normal_stiffness: kn,
        spring_stiffness: kt,
        force,
        damping,
    }
}

/// The energy a body contact stores, as its two parts: the penalty's `∫ f_n dδ` (k w δ²/2
/// up to δ_max, linear beyond, where the force no longer grows) and the Coulomb spring's
/// `|f_t|² / (2 k_t)` of the spring force `spring` (0 without Coulomb friction), for a
/// sample of weight `w` at effective depth `depth`.
pub fn body_potential(p: &ContactParams, w: f64, depth: f64, spring: &V3) -> (f64, f64) {
    let kw = p.stiffness * w;
    let penalty = if depth <= p.max_depth {
        0.5 * kw * depth * depth
    } else {
        kw * p.max_depth * (depth - 0.5 * p.max_depth)
    };
    let held = match p.friction {
        Friction::Coulomb {
            stiffness_ratio, ..
        } => 0.5 * spring.norm_squared() / (stiffness_ratio * kw),
        _ => 0.0,
    };
    (penalty, held)
}

/// Where a touching sample is held after an accepted step (Coulomb friction; `None`
/// under another friction model): at its anchor `previous` (head coordinates, and whether
/// it slid over the step before) while the spring's stretch stays within the static limit
/// (the kinetic one once it slides), else dragged behind the sample so that the spring
/// holds the kinetic force; a new contact is held where it is. For a sample of weight
/// `w` at effective depth `depth` (> 0) under the normal `n`, tangent `t`, at `y`.
#[allow(clippy::too_many_arguments)]
pub fn anchor_after_step(
    p: &ContactParams,
    w: f64,
    depth: f64,
    n: &V3,
    t: &V3,
    y: &V3,
    previous: Option<(V3, bool)>,
) -> Option<(V3, bool)> {
    let Friction::Coulomb {
        static_coefficient,
        kinetic_coefficient,
        stiffness_ratio,
    } = p.friction
    else {
        return None;
    };
    let fn_ = p.stiffness * w * depth.min(p.max_depth);
    let stiff = stiffness_ratio * p.stiffness * w;
    Some(match previous {
        Some((a, was_sliding)) => {
            let slip = (y - a) - n * n.dot(&(y - a));
            let norm = slip.norm();
            let cos = if norm > 0.0 { t.dot(&slip) / norm } else { 0.0 };
            let scale = 1.0 + p.anisotropy * cos;
            // the stretch the kinetic force holds, and the static limit's
            let keep = kinetic_coefficient * scale * fn_ / stiff;
            let limit = static_coefficient * scale * fn_ / stiff;
            let slides = if was_sliding {
                norm > keep
            } else {
                norm > limit
            };
            if slides && norm > 0.0 {
                // slide: the anchor is dragged behind, the spring holds the kinetic force
                (y - slip * (keep / norm), true)
            } else {
                (a, false)
            }
        }
        None => (*y, false),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(friction: Friction) -> ContactParams {
        ContactParams {
            radius: 1e-3,
            stiffness: 40.0,
            damping: 0.02,
            max_depth: 1e-3,
            split_depth: 1e-3,
            depenetration_speed: 0.1,
            friction,
            anisotropy: 0.0,
        }
    }

    /// Central difference of `f` at `x` along each axis: columns ∂f/∂x_j.
    fn jacobian(f: impl Fn(&V3) -> V3, x: &V3, h: f64) -> M3 {
        M3::from_columns(&[0, 1, 2].map(|j| {
            let e = V3::ith(j, h);
            (f(&(x + e)) - f(&(x - e))) / (2.0 * h)
        }))
    }

    /// Against a plane (distance `n·y − c`, so depth `r − n·y + c`), the stiffness the
    /// law reports is the derivative of its elastic force with respect to the sample's
    /// position (central differences, 1e-9 m), for the penalty alone, a sticking Coulomb
    /// spring and a sliding one (along the tangent plane: the kinetic force's change with
    /// the depth is left out, as is, without anisotropy here, the turning of μ(θ)); its damping matrix is the derivative of the force with respect to the
    /// sample's velocity, normal damping and viscous friction alike.
    #[test]
    fn stiffness_and_damping_are_the_derivatives_of_the_force() {
        let n = V3::new(0.2, -0.3, 0.9).normalize();
        let t = V3::new(1.0, 0.4, 0.0).normalize();
        let c = 0.01;
        // 0.4 mm from the plane (0.6 mm deep in the 1 mm contact radius), off its origin
        let offset = V3::new(0.003, -0.002, 0.0);
        let y0 = offset - n * n.dot(&offset) + n * (c + 0.4e-3);
        let anchor = y0 + V3::new(1e-5, 2e-5, -1e-5);
        let coulomb = |static_coefficient| Friction::Coulomb {
            static_coefficient,
            kinetic_coefficient: 0.5 * static_coefficient,
            stiffness_ratio: 0.5,
        };
        // the sliding spring's force is the kinetic μ_k |f_n|, which changes with the
        // depth: the law keeps only the turning of the slip's direction, the derivative
        // along the tangent plane
        let all = M3::identity();
        let plane = M3::identity() - n * n.transpose();
        let cases = [
            ("penalty", params(Friction::None), None, all),
            (
                "sticking",
                params(coulomb(10.0)),
                Some((anchor, false)),
                all,
            ),
            (
                "sliding",
                params(coulomb(0.05)),
                Some((anchor, true)),
                plane,
            ),
        ];
        for (name, p, held, along) in cases {
            let w = 2e-3;
            let depth = |y: &V3| p.radius - (n.dot(y) - c);
            let elastic = |y: &V3| {
                let (normal, spring, _, _) = body_elastic(&p, w, depth(y), &n, &t, y, held);
                normal + spring
            };
            let law = body_sample(&p, w, depth(&y0), &n, &t, &y0, held, &V3::zeros());
            assert!(law.normal.norm() > 0.0, "{name}: touching");
            let numeric = jacobian(elastic, &y0, 1e-9) * along;
            let reported = law.stiffness(&n) * along;
            let scale = reported.norm();
            assert!(
                (numeric - reported).norm() <= 1e-6 * scale,
                "{name}: {numeric} against {reported}"
            );
        }
        for (name, friction) in [
            ("normal damping", Friction::None),
            (
                "viscous",
                Friction::Viscous {
                    coefficient: 0.3,
                    slip_speed: 0.01,
                },
            ),
        ] {
            let p = params(friction);
            let (w, depth) = (2e-3, 0.5e-3);
            let force = |v: &V3| body_sample(&p, w, depth, &n, &t, &y0, None, v).force;
            let v0 = V3::new(0.02, -0.01, 0.03);
            let numeric = jacobian(force, &v0, 1e-7);
            let reported = body_sample(&p, w, depth, &n, &t, &y0, None, &v0).damping;
            assert!(
                (numeric - reported).norm() <= 1e-7 * reported.norm(),
                "{name}: {numeric} against {reported}"
            );
        }
    }

    /// The penalty stops growing at δ_max (no stiffness beyond it); a Coulomb spring
    /// beyond its static limit holds exactly the kinetic force; without contact anchors,
    /// Coulomb friction adds nothing.
    #[test]
    fn the_penalty_saturates_and_the_spring_holds_the_kinetic_force_when_it_slides() {
        let n = V3::z();
        let t = V3::x();
        let coulomb = Friction::Coulomb {
            static_coefficient: 0.4,
            kinetic_coefficient: 0.3,
            stiffness_ratio: 1.0,
        };
        let p = params(coulomb);
        let w = 1e-3;
        let deep = body_sample(&p, w, 5e-3, &n, &t, &V3::zeros(), None, &V3::zeros());
        assert_eq!(deep.normal, n * (p.stiffness * w * p.max_depth));
        assert_eq!(deep.normal_stiffness, 0.0);
        assert_eq!(deep.spring, V3::zeros());
        let y = V3::new(0.01, 0.0, 0.0);
        let law = body_sample(
            &p,
            w,
            0.5e-3,
            &n,
            &t,
            &y,
            Some((V3::zeros(), false)),
            &V3::zeros(),
        );
        let fn_ = law.normal.norm();
        assert!((law.spring.norm() - 0.3 * fn_).abs() <= 1e-15 * fn_);
        assert!(law.spring.dot(&y) < 0.0, "against the slip");
    }

    /// The penalty's energy is the integral of its force: its derivative in the depth
    /// (central differences) is |f_n| below and beyond δ_max; the spring's energy is
    /// |f_t|²/(2 k_t).
    #[test]
    fn the_stored_energy_is_the_integral_of_the_force() {
        let p = params(Friction::Coulomb {
            static_coefficient: 0.4,
            kinetic_coefficient: 0.3,
            stiffness_ratio: 0.5,
        });
        let (n, t, w) = (V3::z(), V3::x(), 2e-3);
        for depth in [0.3e-3, 0.9e-3, 1.7e-3] {
            let h = 1e-9;
            let energy = |d: f64| body_potential(&p, w, d, &V3::zeros()).0;
            let rate = (energy(depth + h) - energy(depth - h)) / (2.0 * h);
            let force = body_sample(&p, w, depth, &n, &t, &V3::zeros(), None, &V3::zeros());
            assert!((rate - force.normal.norm()).abs() <= 1e-6 * force.normal.norm());
        }
        let spring = V3::new(3e-6, -1e-6, 0.0);
        let kt = 0.5 * p.stiffness * w;
        let held = body_potential(&p, w, 0.5e-3, &spring).1;
        assert!((held - spring.norm_squared() / (2.0 * kt)).abs() <= 1e-15 * held);
        assert_eq!(
            body_potential(&params(Friction::None), w, 0.5e-3, &spring).1,
            0.0
        );
    }

    /// A new contact is held where it is; an anchor within the static limit stays; one
    /// beyond it is dragged behind the sample until the spring holds exactly the kinetic
    /// force μ_k f_n (and is then sliding); without Coulomb friction there is no anchor.
    #[test]
    fn anchors_stay_within_the_static_limit_and_are_dragged_beyond_it() {
        let coulomb = Friction::Coulomb {
            static_coefficient: 0.4,
            kinetic_coefficient: 0.3,
            stiffness_ratio: 0.5,
        };
        let p = params(coulomb);
        let (n, t, w, depth) = (V3::z(), V3::x(), 2e-3, 0.5e-3);
        let y = V3::new(0.01, 0.02, -0.0005);
        assert_eq!(
            anchor_after_step(&p, w, depth, &n, &t, &y, None),
            Some((y, false))
        );
        assert_eq!(
            anchor_after_step(&params(Friction::None), w, depth, &n, &t, &y, None),
            None
        );
        let (fn_, kt) = (p.stiffness * w * depth, 0.5 * p.stiffness * w);
        let static_stretch = 0.4 * fn_ / kt;
        // within the limit (and off the plane by a normal offset, which does not count)
        let near = y - V3::new(0.5 * static_stretch, 0.0, 1e-4);
        assert_eq!(
            anchor_after_step(&p, w, depth, &n, &t, &y, Some((near, false))),
            Some((near, false))
        );
        let far = y - V3::new(0.0, 2.0 * static_stretch, 0.0);
        let (a, sliding) =
            anchor_after_step(&p, w, depth, &n, &t, &y, Some((far, false))).expect("Coulomb");
        assert!(sliding);
        let stretch = (y - a) - n * n.dot(&(y - a));
        assert!((kt * stretch.norm() - 0.3 * fn_).abs() <= 1e-12 * fn_);
        assert!(stretch.normalize().dot(&(y - far).normalize()) > 1.0 - 1e-12);
    }
}
