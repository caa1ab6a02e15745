//! The three kernel paths on the same strands: the generated fixed-N kernel
//! (`FixedKernel`, for the N with a per-N module), the moment path
//! (`MomentKernel<ClosedForm>`, any N) and the generic kernel (`GenericKernel`,
//! Gauss–Legendre quadrature) give the same terms; and which path `kernels = "auto"` and
//! `"generated"` choose for an N with and without generated fixed-N code.

mod common;
use common::*;
use faer::Mat;
use nalgebra::{Matrix3, Vector3};
use superhelix_runtime::config::{Engine, KernelChoice, SimulationConfig};
use superhelix_runtime::kernels::closed_form::{kernel_factory, sizes, ClosedForm};
use superhelix_runtime::kernels::kernel::{BodyField, EvalInput, StrandKernel, StrandTerms, Terms};
use superhelix_runtime::kernels::moments::kernel::MomentKernel;
use superhelix_runtime::model::material::{helix_curvature, HelixForm, Preset};
use superhelix_runtime::model::reconstruction::Pose;
use superhelix_runtime::model::strand::StrandGeometry;
use superhelix_runtime::{GenericKernel, HeadMotion, QuadratureRule, Simulation};

fn rel_mat(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
    let (mut diff, mut scale) = (0.0f64, 0.0f64);
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

fn same_bits(a: &Mat<f64>, b: &Mat<f64>) -> bool {
    (0..a.ncols()).all(|j| (0..a.nrows()).all(|i| a[(i, j)].to_bits() == b[(i, j)].to_bits()))
}

/// Gravity, the fictitious forces of a rotating head, and drag.
fn field(rng: &mut Rng, rho_s: f64) -> BodyField {
    let omega = rng.unit() * 3.0;
    let alpha = rng.unit() * 20.0;
    let wx = omega.cross_matrix();
    let nu = 5e-6;
    BodyField {
        uniform: Vector3::new(0.3, -1.0, -9.81) * rho_s,
        linear: -(alpha.cross_matrix() + wx * wx) * rho_s - wx * nu,
        velocity: -wx * (2.0 * rho_s) - Matrix3::identity() * nu,
    }
}

/// A strand of `n` elements, 20 cm, root on the scalp, rotary inertia of the preset's
/// hair, at its preset's natural curvature perturbed by up to 20 %, moving.
fn strand(preset: Preset, n: usize, rng: &mut Rng) -> (StrandGeometry, Vec<f64>, Vec<f64>) {
    let p = preset.params();
    let material = p.cross_section.material();
    let geometry = StrandGeometry::new(
        Vector3::new(0.08, -0.05, 0.06),
        rotation(Vector3::new(0.4, -1.9, 0.3)),
        vec![0.2 / n as f64; n],
        &material,
    );
    let natural = helix_curvature(p.helix_radius, p.helix_step, HelixForm::Exact);
    let q = (0..n)
        .flat_map(|_| natural)
        .map(|x| x * (1.0 + 0.2 * rng.sym()) + rng.sym())
        .collect();
    let v = (0..3 * n).map(|_| rng.sym() * 20.0).collect();
    (geometry, q, v)
}

#[test]
fn fixed_moment_and_generic_paths_agree_on_every_term() {
    let mut rng = Rng(0x0f1e_d00d);
    let names = ["M", "force", "stiffness", "damping", "dB/dqdot"];
    let mut worst = [0.0f64; 5];
    for n in [1usize, 5, 20] {
        assert!(sizes().contains(&n), "N = {n} is checked in");
        for preset in [Preset::Curly, Preset::Fuzzy] {
            for _ in 0..2 {
                let (g, q, v) = strand(preset, n, &mut rng);
                let input = EvalInput {
                    q: &q,
                    v: &v,
                    field: field(&mut rng, g.mass_per_length),
                    terms: Terms::all(),
                };
                let mut fixed = kernel_factory().create(&g).expect("a kernel for every N");
                assert_eq!(fixed.description(), format!("generated fixed-N (N = {n})"));
                let mut moment = MomentKernel::new(g.clone(), ClosedForm);
                let wl = q
                    .chunks(3)
                    .map(|d| Vector3::new(d[0], d[1], d[2]).norm() * g.lengths[0])
                    .fold(0.0, f64::max);
                let order = 40 + (2.0 * wl) as usize;
                let mut generic = GenericKernel::new(g.clone(), QuadratureRule::Fixed(order));
                let mut a = StrandTerms::new(3 * n);
                let mut b = StrandTerms::new(3 * n);
                let mut c = StrandTerms::new(3 * n);
                fixed.evaluate(&input, &mut a);
                moment.evaluate(&input, &mut b);
                generic.evaluate(&input, &mut c);
                // fixed-N and moment path: the same assembly on the same closed forms
                assert!(same_bits(&a.mass, &b.mass) && a.force == b.force);
                assert!(same_bits(&a.stiffness, &b.stiffness));
                assert!(same_bits(&a.damping, &b.damping));
                assert!(same_bits(
                    &a.velocity_term_jacobian,
                    &b.velocity_term_jacobian
                ));
                for (x, y, path) in [(&a, &c, "fixed-N"), (&b, &c, "moment")] {
                    let dev = [
                        rel_mat(&x.mass, &y.mass),
                        rel_vec(&x.force, &y.force),
                        rel_mat(&x.stiffness, &y.stiffness),
                        rel_mat(&x.damping, &y.damping),
                        rel_mat(&x.velocity_term_jacobian, &y.velocity_term_jacobian),
                    ];
                    for ((w, d), name) in worst.iter_mut().zip(dev).zip(names) {
                        *w = w.max(d);
                        assert!(
                            d <= 1e-10,
                            "{path} vs generic, {name}: {d:.2e} at N = {n}, {}",
                            preset.name()
                        );
                    }
                }
            }
        }
    }
    for (name, w) in names.iter().zip(worst) {
        println!(
            "fixed-N and moment paths vs generic, worst relative deviation of {name}: {w:.2e}"
        );
    }
}

#[test]
fn fixed_and_moment_paths_give_the_same_points_and_ends() {
    let mut rng = Rng(0x5107);
    for n in [1usize, 5, 20] {
        let (g, q, _) = strand(Preset::Curly, n, &mut rng);
        let mut fixed = kernel_factory().create(&g).expect("kernel");
        let mut moment = MomentKernel::new(g.clone(), ClosedForm);
        let (mut ea, mut eb) = (vec![Pose::default(); n + 1], vec![Pose::default(); n + 1]);
        fixed.element_ends(&q, &mut ea);
        moment.element_ends(&q, &mut eb);
        assert_eq!(ea, eb);
        for k in 0..7 {
            let s = g.length() * k as f64 / 6.0;
            let c = rng.unit();
            let (mut ja, mut jb) = (vec![Vector3::zeros(); 3 * n], vec![Vector3::zeros(); 3 * n]);
            let (mut ha, mut hb) = (Mat::zeros(3 * n, 3 * n), Mat::zeros(3 * n, 3 * n));
            let ya = fixed.point(&q, s, &mut ja, Some((c, &mut ha)));
            let yb = moment.point(&q, s, &mut jb, Some((c, &mut hb)));
            assert_eq!((ya, &ja), (yb, &jb), "N = {n}, s = {s}");
            assert!(same_bits(&ha, &hb), "N = {n}, s = {s}");
        }
    }
}

#[test]
fn points_asked_in_any_order_and_at_changing_q_are_those_of_a_fresh_chain() {
    // both kernels keep the chain of element ends between points at the same q; a kernel
    // made for each point chains from the root
    let mut rng = Rng(0xc4a1);
    let n = 5;
    let (g, q, _) = strand(Preset::Wavy, n, &mut rng);
    let other: Vec<f64> = q.iter().map(|x| x * 0.7 + 1.0).collect();
    let mut fixed = kernel_factory().create(&g).expect("kernel");
    let mut moment = MomentKernel::new(g.clone(), ClosedForm);
    let l = g.length();
    let asks = [
        (&q, 0.1),
        (&q, 0.5),
        (&q, 0.95),
        (&q, 0.3),
        (&other, 0.3),
        (&other, 0.9),
        (&q, 0.9),
        (&q, 0.0),
        (&q, 1.0),
        (&other, 0.6),
    ];
    for (at, f) in asks {
        let mut fresh = MomentKernel::new(g.clone(), ClosedForm);
        let mut jacs = [(); 3].map(|_| vec![Vector3::zeros(); 3 * n]);
        let [ja, jb, jc] = &mut jacs;
        let ya = fixed.point(at, f * l, ja, None);
        let yb = moment.point(at, f * l, jb, None);
        let yc = fresh.point(at, f * l, jc, None);
        assert_eq!((ya, &ja), (yc, &jc), "fixed-N, s = {f} L");
        assert_eq!((yb, &jb), (yc, &jc), "moment, s = {f} L");
    }
}

#[test]
fn a_point_at_another_q_does_not_spoil_the_next_evaluation() {
    // point() rebuilds element ends at its q; the next evaluation at the earlier q must
    // not reuse them
    let mut rng = Rng(0xfeed);
    let (g, q, v) = strand(Preset::Fuzzy, 5, &mut rng);
    let other: Vec<f64> = q.iter().map(|x| x * 0.5).collect();
    let input = EvalInput {
        q: &q,
        v: &v,
        field: field(&mut rng, g.mass_per_length),
        terms: Terms::all(),
    };
    let mut kernels: [Box<dyn StrandKernel>; 2] = [
        kernel_factory().create(&g).expect("kernel"),
        Box::new(MomentKernel::new(g.clone(), ClosedForm)),
    ];
    for k in kernels.iter_mut() {
        let mut before = StrandTerms::new(15);
        let mut after = StrandTerms::new(15);
        k.evaluate(&input, &mut before);
        let mut jac = vec![Vector3::zeros(); 15];
        k.point(&other, 0.15, &mut jac, None);
        k.evaluate(&input, &mut after);
        assert!(same_bits(&before.mass, &after.mass), "{}", k.description());
        assert_eq!(before.force, after.force, "{}", k.description());
    }
}

/// A simulation of one hanging strand of `n` elements with `kernels`, on the runtime
/// engine (the kernels it chooses are what these tests check).
fn simulation(
    n: usize,
    kernels: KernelChoice,
    with_factory: bool,
) -> superhelix_runtime::Result<Simulation> {
    let s = preset_strand(Preset::Wavy, n, 0.25, Vector3::new(0.0, 0.0, -1.0));
    let config = SimulationConfig {
        kernels,
        engine: Engine::Runtime,
        ..SimulationConfig::default()
    };
    let setup = setup(
        vec![s],
        config,
        Some(Vector3::new(0.0, 0.0, -9.81)),
        HeadMotion::Still,
    );
    Simulation::new(setup, with_factory.then(kernel_factory))
}

#[test]
fn auto_uses_the_fixed_n_code_where_it_exists_and_the_moment_path_elsewhere() {
    let sim = simulation(5, KernelChoice::Auto, true).expect("setup");
    assert_eq!(sim.kernel_description(0), "generated fixed-N (N = 5)");
    assert!(
        !sizes().contains(&40),
        "N = 40 has no fixed-N code in this test's build"
    );
    for with_factory in [true, false] {
        let sim = simulation(40, KernelChoice::Auto, with_factory).expect("setup");
        assert_eq!(
            sim.kernel_description(0),
            "moment assembly (closed form), N = 40"
        );
        assert!(sim.uses_generated_kernel(0));
    }
    let sim = simulation(40, KernelChoice::Generic, true).expect("setup");
    assert!(sim.kernel_description(0).starts_with("generic"));
}

#[test]
fn generated_is_refused_for_an_n_without_fixed_n_code() {
    let err = match simulation(40, KernelChoice::Generated, true) {
        Ok(_) => panic!("N = 40 has no fixed-N code and must be refused"),
        Err(e) => e.to_string(),
    };
    for part in ["simulation.kernels", "N = 40", "SUPERHELIX_N=40"] {
        assert!(err.contains(part), "{part} missing from: {err}");
    }
    let sim = simulation(20, KernelChoice::Generated, true).expect("N = 20 is checked in");
    assert_eq!(sim.kernel_description(0), "generated fixed-N (N = 20)");
}

/// `Terms::field_force` (what the energy balance's power of a rotating head reads) is the
/// full force with b added back, ∫ Jᵀ F ds, on every path: the moment assembly skips b
/// and the rotary quadrature for it, so the two must agree to round-off of the force's
/// size. Fails if the skipped terms leak into it (b alone is ~1e-2 of the force here).
#[test]
fn the_field_force_alone_is_the_force_plus_b_on_every_path() {
    let mut rng = Rng(0x5eed_f0f0);
    for n in [1usize, 5, 20] {
        for preset in [Preset::Curly, Preset::Fuzzy] {
            let (g, q, v) = strand(preset, n, &mut rng);
            let field = field(&mut rng, g.mass_per_length);
            let full = |terms| EvalInput {
                q: &q,
                v: &v,
                field,
                terms,
            };
            let mut kernels: [Box<dyn StrandKernel>; 3] = [
                kernel_factory().create(&g).expect("a kernel for every N"),
                Box::new(MomentKernel::new(g.clone(), ClosedForm)),
                Box::new(GenericKernel::new(g.clone(), QuadratureRule::Fixed(40))),
            ];
            for k in kernels.iter_mut() {
                let mut a = StrandTerms::new(3 * n);
                let mut b = StrandTerms::new(3 * n);
                // the field's force first, on a fresh kernel: nothing of the full
                // evaluation (frame motions, moments) is left over to lean on
                k.evaluate(
                    &full(Terms {
                        field_force: true,
                        ..Default::default()
                    }),
                    &mut b,
                );
                k.evaluate(
                    &full(Terms {
                        force: true,
                        ..Default::default()
                    }),
                    &mut a,
                );
                let whole: Vec<f64> = a
                    .force
                    .iter()
                    .zip(&a.velocity_term)
                    .map(|(f, x)| f + x)
                    .collect();
                let scale = whole.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                let b_size = a.velocity_term.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                assert!(
                    b_size > 1e-6 * scale,
                    "b must be present to test its absence"
                );
                let dev = whole
                    .iter()
                    .zip(&b.force)
                    .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
                    / scale;
                assert!(
                    dev <= 1e-12,
                    "{}: field force vs force + b {dev:.2e} at N = {n}",
                    k.description()
                );
                assert!((a.first_moment - b.first_moment).norm() <= 1e-14 * a.first_moment.norm());
            }
        }
    }
}
