//! The moment-assembled kernel (quadrature moments) against the generic kernel at high
//! quadrature order: every term the integrators use, random configurations, a field with
//! uniform, linear and velocity parts, rotary inertia on and off.
mod common;
use common::*;
use faer::Mat;
use nalgebra::{Matrix3, Vector3};
use superhelix_runtime::kernels::kernel::{BodyField, EvalInput, StrandKernel, StrandTerms, Terms};
use superhelix_runtime::kernels::moments::kernel::{MomentKernel, QuadratureMoments};
use superhelix_runtime::{GenericKernel, QuadratureRule};

fn rel_mat(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
    let mut diff = 0.0f64;
    let mut scale = 0.0f64;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            diff = diff.max((a[(i, j)] - b[(i, j)]).abs());
            scale = scale.max(b[(i, j)].abs());
        }
    }
    diff / scale.max(1e-300)
}

fn rel_vec(a: &[f64], b: &[f64]) -> f64 {
    let diff = a
        .iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    diff / scale.max(1e-300)
}

fn random_field(rng: &mut Rng, rho_s: f64, linear: bool) -> BodyField {
    let omega = rng.unit() * 3.0;
    let alpha = rng.unit() * 20.0;
    let wx = omega.cross_matrix();
    let nu = 2e-5;
    BodyField {
        uniform: Vector3::new(0.3, -1.0, -9.81) * rho_s + rng.unit() * 1e-5,
        linear: if linear {
            -(alpha.cross_matrix() + wx * wx) * rho_s - wx * nu
        } else {
            Matrix3::zeros()
        },
        velocity: if linear {
            -wx * (2.0 * rho_s) - Matrix3::identity() * nu
        } else {
            -Matrix3::identity() * nu
        },
    }
}

/// A random strand for the kernel comparisons: N elements with the given W·l (cycled),
/// rotary inertia on or off, a root on the scalp 17 cm from the head origin (moments
/// about the origin would lose (0.17 / curl radius)² of their digits), fast q̇, a field
/// with a linear part when `linear`; and the generic kernel's quadrature order for it.
struct Case {
    g: superhelix_runtime::model::strand::StrandGeometry,
    q: Vec<f64>,
    v: Vec<f64>,
    field: BodyField,
    order: usize,
}

fn case(rng: &mut Rng, n: usize, wl: &[f64], rotary: bool, linear: bool) -> Case {
    let mut g = geometry(n, 0.12, rng);
    g.root_position = Vector3::new(0.12, -0.1, 0.06);
    if !rotary {
        g.rotary_inertia = [0.0; 3];
    }
    let q = q_with_wl(&g, wl, rng);
    let v: Vec<f64> = (0..3 * n).map(|_| rng.sym() * 30.0).collect();
    let field = random_field(rng, g.mass_per_length, linear);
    let maxwl = wl.iter().cloned().fold(0.0, f64::max);
    Case {
        g,
        q,
        v,
        field,
        order: 40 + (2.0 * maxwl) as usize,
    }
}

#[test]
fn moment_kernel_matches_the_generic_kernel_on_every_term() {
    let mut rng = Rng(0x5eed_1234);
    let wl_sets: [&[f64]; 6] = [
        &[0.0],
        &[1e-12, 1e-8],
        &[1e-4, 1e-2],
        &[1.0, 0.3, 2.0],
        &[30.0, 5.0],
        &[100.0, 0.5],
    ];
    let mut worst = [0.0f64; 7];
    let names = [
        "M",
        "force",
        "b",
        "stiffness",
        "damping",
        "dB/dqdot",
        "first moment",
    ];
    for n in [1usize, 2, 3, 5, 10] {
        for (c, wl) in wl_sets.iter().enumerate() {
            for rotary in [false, true] {
                let Case {
                    g,
                    q,
                    v,
                    field,
                    order,
                } = case(&mut rng, n, wl, rotary, c % 2 == 0);
                let mut reference = GenericKernel::new(g.clone(), QuadratureRule::Fixed(order));
                let mut ours = MomentKernel::new(g.clone(), QuadratureMoments::default());
                let input = EvalInput {
                    q: &q,
                    v: &v,
                    field,
                    terms: Terms::all(),
                };
                let mut a = StrandTerms::new(3 * n);
                let mut b = StrandTerms::new(3 * n);
                ours.evaluate(&input, &mut a);
                reference.evaluate(&input, &mut b);
                let dev = [
                    rel_mat(&a.mass, &b.mass),
                    rel_vec(&a.force, &b.force),
                    rel_vec(&a.velocity_term, &b.velocity_term),
                    rel_mat(&a.stiffness, &b.stiffness),
                    rel_mat(&a.damping, &b.damping),
                    rel_mat(&a.velocity_term_jacobian, &b.velocity_term_jacobian),
                    (a.first_moment - b.first_moment).norm() / b.first_moment.norm(),
                ];
                for (w, d) in worst.iter_mut().zip(dev) {
                    *w = w.max(d);
                }
                for (name, d) in names.iter().zip(dev) {
                    assert!(
                        d <= 1e-10,
                        "{name}: relative deviation {d:.2e} at N={n}, W·l {wl:?}, rotary {rotary}"
                    );
                }
            }
        }
    }
    for (name, w) in names.iter().zip(worst) {
        println!("moment kernel vs generic, worst relative deviation of {name}: {w:.2e}");
    }
}

#[test]
fn moment_kernel_points_match_the_generic_kernel() {
    let mut rng = Rng(0xabc);
    let mut worst = [0.0f64; 3];
    for n in [1usize, 3, 5] {
        for wl in [[0.0, 1e-9, 1e-3], [1.0, 30.0, 100.0]] {
            let g = geometry(n, 0.12, &mut rng);
            let q = q_with_wl(&g, &wl, &mut rng);
            let mut reference = GenericKernel::new(g.clone(), QuadratureRule::Adaptive);
            let mut ours = MomentKernel::new(g.clone(), QuadratureMoments::default());
            for k in 0..20 {
                let s = g.length() * k as f64 / 19.0;
                let c = rng.unit();
                let mut ja = vec![Vector3::zeros(); 3 * n];
                let mut jb = vec![Vector3::zeros(); 3 * n];
                let mut ha = Mat::zeros(3 * n, 3 * n);
                let mut hb = Mat::zeros(3 * n, 3 * n);
                let ya = ours.point(&q, s, &mut ja, Some((c, &mut ha)));
                let yb = reference.point(&q, s, &mut jb, Some((c, &mut hb)));
                let jscale = jb.iter().fold(0.0f64, |m, v| m.max(v.amax()));
                let jdiff = ja
                    .iter()
                    .zip(&jb)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).amax()));
                // positions relative to the strand's length; J and H to their largest entry
                let dev = [
                    (ya - yb).amax() / g.length(),
                    jdiff / jscale.max(1e-300),
                    rel_mat(&ha, &hb),
                ];
                for (w, d) in worst.iter_mut().zip(dev) {
                    *w = w.max(d);
                    assert!(
                        d <= 1e-12,
                        "point deviation {d:.2e} at N={n}, s={s}, W·l {wl:?}"
                    );
                }
            }
        }
    }
    println!(
        "moment kernel point vs generic: position {:.2e}, J {:.2e}, Hessian {:.2e}",
        worst[0], worst[1], worst[2]
    );
}

/// What the fixed-N step asks: `Terms::symmetric_stiffness` (it keeps sym(stiffness)
/// only) leaves the antisymmetric part of C1 out, so the symmetric part of what it
/// returns is the generic kernel's symmetrised stiffness, on a head that turns and
/// accelerates (C1 with an antisymmetric part −ρS[α]× − ν[ω]×); `Terms::split_damping`
/// (C2 = −ν I − 2ρS[ω]× as −ν ∫JᵀJ plus one antisymmetric pass) gives the generic
/// kernel's damping; every other term is unchanged.
#[test]
fn a_symmetric_stiffness_request_gives_the_symmetrised_stiffness() {
    let mut rng = Rng(0x5eed_5a5a);
    for n in [1usize, 3, 5] {
        let g = geometry(n, 0.12, &mut rng);
        let q = q_with_wl(&g, &[1.0, 0.3], &mut rng);
        let v: Vec<f64> = (0..3 * n).map(|_| rng.sym() * 30.0).collect();
        let field = random_field(&mut rng, g.mass_per_length, true);
        assert_ne!(field.linear, field.linear.transpose());
        let order = 44;
        let mut reference = GenericKernel::new(g.clone(), QuadratureRule::Fixed(order));
        let mut ours = MomentKernel::new(g.clone(), QuadratureMoments::default());
        let input = |terms| EvalInput {
            q: &q,
            v: &v,
            field,
            terms,
        };
        let symmetric = Terms {
            symmetric_stiffness: true,
            split_damping: true,
            ..Terms::all()
        };
        let (mut a, mut b) = (StrandTerms::new(3 * n), StrandTerms::new(3 * n));
        ours.evaluate(&input(symmetric), &mut a);
        reference.evaluate(&input(Terms::all()), &mut b);
        let sym =
            |m: &Mat<f64>| Mat::<f64>::from_fn(3 * n, 3 * n, |i, j| 0.5 * (m[(i, j)] + m[(j, i)]));
        let d = rel_mat(&sym(&a.stiffness), &sym(&b.stiffness));
        assert!(d <= 1e-10, "N={n}: sym(stiffness) deviates {d:.2e}");
        // the antisymmetric part is not the generic kernel's (it was left out)
        let full_anti = rel_mat(&b.stiffness, &sym(&b.stiffness));
        assert!(
            full_anti > 1e-6,
            "N={n}: the test field has no antisymmetric stiffness"
        );
        assert!(rel_mat(&a.damping, &b.damping) <= 1e-10, "N={n}: damping");
        assert!(rel_vec(&a.force, &b.force) <= 1e-10, "N={n}: force");
    }
}

/// The energy measurement's O(N) kinetic energy, first moment and power of a linear field
/// (`strand_terms::evaluate_energy`, closed-form moments of M) against the generic
/// kernel at high quadrature order: ½ q̇ᵀ M q̇ from its M, ∫ρS y from its first moment,
/// and q̇ · ∫ Jᵀ C1 y ds as the change of its force when C1 is switched on (b cancels).
/// Random configurations, W·l from 0 to 100, rotary inertia on and off, fast q̇.
#[test]
fn the_energy_measurement_matches_the_generic_kernel() {
    use superhelix_generated::ClosedForm;
    use superhelix_kernels::moments::jacobians::VelocityRow;
    use superhelix_kernels::moments::rotary::RotaryElement;
    use superhelix_kernels::moments::EndDerivatives;
    use superhelix_kernels::moments::{ElementMoments, FrameMotion, SuffixBody};
    use superhelix_kernels::pose::Pose;
    use superhelix_kernels::strand_terms::{evaluate_energy, MomentBuffers, StrandShape};
    let mut rng = Rng(0x5eed_e4e7);
    let mut worst = [0.0f64; 3];
    for n in [1usize, 2, 5, 10] {
        for wl in [
            &[0.0][..],
            &[1e-8, 1e-3],
            &[0.3, 2.0],
            &[30.0, 5.0],
            &[100.0, 0.5],
        ] {
            for rotary in [false, true] {
                let Case {
                    g,
                    q,
                    v,
                    field,
                    order,
                } = case(&mut rng, n, wl, rotary, true);
                let mut reference = GenericKernel::new(g.clone(), QuadratureRule::Fixed(order));
                let with = |field: BodyField, terms: Terms| EvalInput {
                    q: &q,
                    v: &v,
                    field,
                    terms,
                };
                let mut r = StrandTerms::new(3 * n);
                reference.evaluate(
                    &with(
                        field,
                        Terms {
                            mass: true,
                            force: true,
                            ..Terms::default()
                        },
                    ),
                    &mut r,
                );
                let mut r0 = StrandTerms::new(3 * n);
                let no_linear = BodyField {
                    linear: Matrix3::zeros(),
                    ..field
                };
                reference.evaluate(
                    &with(
                        no_linear,
                        Terms {
                            force: true,
                            ..Terms::default()
                        },
                    ),
                    &mut r0,
                );
                let mut kinetic = 0.0;
                let mut power = 0.0;
                for j in 0..3 * n {
                    for i in 0..3 * n {
                        kinetic += 0.5 * v[i] * r.mass[(i, j)] * v[j];
                    }
                    power += v[j] * (r.force[j] - r0.force[j]);
                }
                let (mut ends, mut motions, mut bodies) = (
                    vec![Pose::default(); n + 1],
                    vec![FrameMotion::default(); n + 1],
                    vec![SuffixBody::default(); n + 1],
                );
                let (mut darboux, mut derivs, mut moments, mut rot, mut beyond) = (
                    vec![Vector3::zeros(); n],
                    vec![EndDerivatives::default(); n],
                    vec![ElementMoments::default(); n],
                    vec![RotaryElement::default(); n],
                    vec![(Matrix3::zeros(), Matrix3::zeros()); n],
                );
                let mut rows = vec![VelocityRow::default(); 3 * n];
                let (mut mass, mut gram, mut matrix) = (
                    vec![0.0; 9 * n * n],
                    vec![0.0; 9 * n * n],
                    vec![0.0; 9 * n * n],
                );
                let (mut vector, mut prepared, mut valid) =
                    (vec![0.0; 3 * n], vec![f64::NAN; 3 * n], false);
                let mut mass_prepared = vec![f64::NAN; 3 * n];
                let mut buffers = MomentBuffers {
                    ends: &mut ends,
                    darboux: &mut darboux,
                    end_derivs: &mut derivs,
                    moments: &mut moments,
                    motions: &mut motions,
                    bodies: &mut bodies,
                    rotary: &mut rot,
                    beyond: &mut beyond,
                    velocity_rows: &mut rows,
                    mass: &mut mass,
                    gram: &mut gram,
                    mass_valid: &mut valid,
                    matrix: &mut matrix,
                    vector: &mut vector,
                    prepared: &mut prepared,
                    mass_prepared: &mut mass_prepared,
                };
                let shape = StrandShape {
                    root_position: g.root_position,
                    root_frame: g.root_frame,
                    lengths: &g.lengths,
                    mass_per_length: g.mass_per_length,
                    rotary_inertia: g.rotary_inertia,
                };
                let mut energy = |linear: Option<&Matrix3<f64>>, prepare_terms: bool| {
                    evaluate_energy(
                        &ClosedForm,
                        &shape,
                        &mut buffers,
                        &q,
                        &v,
                        linear,
                        prepare_terms,
                    )
                };
                let e = energy(Some(&field.linear), false);
                // the power's scale: |q̇| |∫ Jᵀ C1 y| (its terms cancel)
                let force_scale = (0..3 * n)
                    .map(|j| (r.force[j] - r0.force[j]).powi(2))
                    .sum::<f64>()
                    .sqrt()
                    * v.iter().map(|x| x * x).sum::<f64>().sqrt();
                let dev = [
                    (e.kinetic - kinetic).abs() / kinetic,
                    (e.first_moment - r.first_moment).norm() / r.first_moment.norm(),
                    (e.power - power).abs() / force_scale,
                ];
                for (w, d) in worst.iter_mut().zip(dev) {
                    *w = w.max(d);
                }
                for (name, d) in ["kinetic energy", "first moment", "power"].iter().zip(dev) {
                    assert!(
                        d <= 1e-10,
                        "{name}: relative deviation {d:.2e} at N={n}, W·l {wl:?}, rotary {rotary}"
                    );
                }
                // prepared for the terms (every moment): the same bits
                assert_eq!(energy(Some(&field.linear), true), e);
                let without = energy(None, false);
                assert_eq!(without.power, 0.0);
                assert_eq!(without.kinetic, e.kinetic);
            }
        }
    }
    println!("energy measurement vs generic kernel, worst relative deviation (kinetic, first moment, power): {:.2e} {:.2e} {:.2e}", worst[0], worst[1], worst[2]);
}
