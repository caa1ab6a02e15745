//! The generated closed forms against the generic path, and freshness of the
//! checked-in files.

use superhelix_runtime::kernels::moments::ElementMoments;
use superhelix_runtime::{Matrix3, Vector3};

fn rel(a: f64, b: f64, scale: f64) -> f64 {
    (a - b).abs() / scale.max(1e-300)
}

/// Every field of a moment set, by name, flattened.
fn fields(m: &ElementMoments) -> Vec<(&'static str, Vec<f64>)> {
    let v3 = |v: &[Vector3<f64>]| v.iter().flat_map(|x| x.iter().copied()).collect::<Vec<_>>();
    let m3 = |v: &[Matrix3<f64>]| v.iter().flat_map(|x| x.iter().copied()).collect::<Vec<_>>();
    vec![
        ("first", m.first.iter().copied().collect()),
        ("second", m.second.iter().copied().collect()),
        ("dfirst", v3(&m.dfirst)),
        ("cross", v3(&m.cross)),
        ("gram", m.gram.iter().copied().collect()),
        ("rot", m.rot.iter().copied().collect()),
        ("rot_w", v3(&m.rot_w)),
        ("rot_ww", m.rot_ww.iter().copied().collect()),
        ("pdp", m3(&m.pdp)),
        ("d2first", v3(m.d2first.as_flattened())),
        ("cross2", v3(m.cross2.as_flattened())),
        ("pd2p", m3(m.pd2p.as_flattened())),
        ("dpdp", m3(m.dpdp.as_flattened())),
        ("dpd2p", m.dpd2p.as_flattened().as_flattened().to_vec()),
    ]
}

/// xorshift64, uniform in [−1, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

/// The kinds of Darboux vectors tested: (name, unit direction).
fn direction(kind: usize, rng: &mut Rng) -> Vector3<f64> {
    let v = match kind {
        // random direction
        0 => Vector3::new(rng.next(), rng.next(), rng.next()),
        // planar arc, curvature in a random direction of the cross-section
        1 => Vector3::new(0.0, rng.next(), rng.next()),
        // planar arc about one axis of the cross-section
        2 => Vector3::new(0.0, rng.next(), 0.0),
        3 => Vector3::new(0.0, 0.0, rng.next()),
        // pure twist
        _ => Vector3::new(rng.next(), 0.0, 0.0),
    };
    if v.norm() > 1e-3 {
        v.normalize()
    } else {
        Vector3::new(0.0, 0.6, 0.8)
    }
}

#[test]
fn closed_form_moments_match_high_order_quadrature() {
    use superhelix_generated::{centreline_force, centreline_mass, rotary_basis};
    let mut rng = Rng(0x1234_5678_9abc_def0);
    let mut wls = vec![0.0, 1e-12, 1e-8, 1e-4, 1e-2, 0.5, 1.0, 5.0, 30.0, 100.0];
    // every switch: Taylor (low degree) | Taylor | closed form
    for s in [
        centreline_mass::CENTRELINE_MASS_LOW_SWITCH,
        centreline_mass::CENTRELINE_MASS_SWITCH,
        centreline_force::CENTRELINE_FORCE_LOW_SWITCH,
        centreline_force::CENTRELINE_FORCE_SWITCH,
        rotary_basis::ROTARY_BASIS_LOW_SWITCH,
        rotary_basis::ROTARY_BASIS_SWITCH,
    ] {
        // both sides of the switch, by a few ulps and by 1e-9
        wls.extend([s * (1.0 - 1e-9), s * (1.0 - 4.0 * f64::EPSILON), s]);
        wls.extend([s * (1.0 + 4.0 * f64::EPSILON), s * (1.0 + 1e-9)]);
    }
    // per kind of direction: samples per W l
    let kinds = [(0usize, 60usize), (1, 12), (2, 6), (3, 6), (4, 8)];
    let mut worst: Vec<(&str, f64, f64)> = Vec::new();
    let mut calls = 0;
    let mut out = ElementMoments::default();
    let mut per_wl: Vec<(f64, f64)> = Vec::new();
    for &wl in &wls {
        per_wl.push((wl, 0.0));
        for &(kind, n) in &kinds {
            for _ in 0..n {
                // lengths over three decades
                let l = 10f64.powf(-2.5 + 1.5 * rng.next());
                let d = direction(kind, &mut rng) * (wl / l);
                let rotary = if rng.next() < -0.8 {
                    [0.0; 3]
                } else {
                    [2.0e-9, 0.8e-9 * (1.5 + rng.next()), 1.2e-9]
                };
                superhelix_generated::element_moments_into(&d, l, &rotary, &mut out);
                let points = 64 + (2.0 * wl).ceil() as usize;
                let reference = ElementMoments::by_quadrature(&d, l, &rotary, points);
                calls += 1;
                for ((name, a), (_, b)) in fields(&out).into_iter().zip(fields(&reference)) {
                    // each field against its largest entry
                    let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                    let e = a
                        .iter()
                        .zip(&b)
                        .map(|(x, y)| {
                            if scale > 0.0 {
                                rel(*x, *y, scale)
                            } else {
                                x.abs()
                            }
                        })
                        .fold(0.0f64, f64::max);
                    let last = per_wl.len() - 1;
                    per_wl[last].1 = per_wl[last].1.max(e);
                    match worst.iter_mut().find(|w| w.0 == name) {
                        Some(w) if e > w.1 => *w = (name, e, wl),
                        Some(_) => {}
                        None => worst.push((name, e, wl)),
                    }
                    assert!(
                        e <= 1e-11,
                        "{name}: W l = {wl}, l = {l}, d = {d:?}, deviation {e:e}\n{a:?}\n{b:?}"
                    );
                }
            }
        }
    }
    println!("{calls} (d, l) samples, worst deviation per field (relative to its max-abs):");
    for (name, e, wl) in &worst {
        println!("  {name:8} {e:.2e} (at W l = {wl:e})");
    }
    println!("worst deviation over all fields per W l:");
    for (wl, e) in &per_wl {
        println!("  W l = {wl:<22e} {e:.2e}");
    }
}

/// The batched moments (one function at a time over a strand's elements, those in a
/// function's closed-form branch four at a time in SIMD lanes) are element by element's
/// bit for bit: strands of 1 to 13 elements whose W l mixes every branch of every
/// function (0, around each switch, up to 100), with and without rotary inertia; the
/// mass batch followed by the force batch gives the same bits.
#[test]
fn batched_moments_are_element_by_element_bit_for_bit() {
    let mut rng = Rng(0x51f1_5eed_2b7e_1516);
    let switches = [
        superhelix_generated::CENTRELINE_MASS_SWITCH,
        superhelix_generated::CENTRELINE_FORCE_SWITCH,
        superhelix_generated::ROTARY_BASIS_SWITCH,
    ];
    let mut lanes_used = 0;
    for case in 0..400 {
        let n = 1 + case % 13;
        let rotary = if case % 7 == 0 {
            [0.0; 3]
        } else {
            [2.0e-9, 0.8e-9, 1.2e-9]
        };
        let l: Vec<f64> = (0..n).map(|_| 0.02 + 0.03 * (rng.next() + 1.0)).collect();
        let d: Vec<Vector3<f64>> = (0..n)
            .map(|p| {
                let wl = match (case + p) % 5 {
                    0 => 0.0,
                    1 => switches[p % 3] * (1.0 + 1e-3 * rng.next()),
                    2 => 4.0 * (rng.next() + 1.0),
                    3 => 50.0 * (rng.next() + 1.0),
                    _ => 1e-3 * (rng.next() + 1.0),
                };
                direction(p % 5, &mut rng) * (wl / l[p])
            })
            .collect();
        lanes_used += d
            .iter()
            .zip(&l)
            .filter(|(d, &l)| d.norm() * l >= switches[1])
            .count();
        let mut batched = vec![ElementMoments::default(); n];
        superhelix_generated::element_moments_batch_into(&d, &l, &rotary, &mut batched);
        // M's fields by the mass batch (a step's end measure), the others by the force
        // batch (the next step's first solve): the full batch's bits
        let mut parts = vec![ElementMoments::default(); n];
        superhelix_generated::mass_moments_batch_into(&d, &l, &rotary, &mut parts);
        superhelix_generated::force_moments_batch_into(&d, &l, &rotary, &mut parts);
        for p in 0..n {
            let one = superhelix_generated::element_moments(&d[p], l[p], &rotary);
            for ((name, a), (_, b)) in fields(&batched[p]).iter().zip(fields(&one).iter()) {
                let same = a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
                assert!(same, "case {case}, element {p}, field {name}");
            }
            for ((name, a), (_, b)) in fields(&parts[p]).iter().zip(fields(&one).iter()) {
                let same = a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
                assert!(
                    same,
                    "case {case}, element {p}, field {name} by mass + force"
                );
            }
        }
    }
    // most strands have several elements in the closed-form branch of the force
    assert!(lanes_used > 500, "{lanes_used}");
}

#[test]
fn mass_moments_are_the_mass_fields_of_element_moments() {
    let rotary = [2.0e-9, 0.8e-9, 1.2e-9];
    for (d, l) in [
        (Vector3::new(0.3, -20.0, 7.0), 0.05),
        (Vector3::new(1e-9, 0.0, 2e-9), 0.1),
        (Vector3::new(40.0, 1.0, -3.0), 0.07),
    ] {
        let all = superhelix_generated::element_moments(&d, l, &rotary);
        let m = superhelix_generated::mass_moments(&d, l, &rotary);
        let expect = ElementMoments {
            first: all.first,
            second: all.second,
            dfirst: all.dfirst,
            cross: all.cross,
            gram: all.gram,
            pdp: all.pdp,
            rot: all.rot,
            rot_w: all.rot_w,
            rot_ww: all.rot_ww,
            ..Default::default()
        };
        assert_eq!(m, expect);
        // gram is the trace of dpdp
        for i in 0..3 {
            for j in 0..3 {
                let t = all.dpdp[i][j].trace();
                assert!((t - all.gram[(i, j)]).abs() <= 1e-13 * all.gram.amax());
            }
        }
    }
}

/// A strand of n elements at W·l = `wl` per element with random directions and q̇, its
/// element ends, end derivatives and frame motions: the set-up of the force tests.
struct ForceCase {
    lengths: Vec<f64>,
    g: superhelix_runtime::model::strand::StrandGeometry,
    q: Vec<f64>,
    v: Vec<f64>,
    ends: Vec<superhelix_runtime::model::reconstruction::Pose>,
    derivs: Vec<superhelix_runtime::kernels::moments::EndDerivatives>,
    motions: Vec<superhelix_runtime::kernels::moments::FrameMotion>,
}

/// The strand of the force tests: a tilted root off the origin, ρS = 1e-5 kg/m and a
/// rotary inertia large enough to show at their tolerances.
fn test_geometry(lengths: &[f64]) -> superhelix_runtime::model::strand::StrandGeometry {
    superhelix_runtime::model::strand::StrandGeometry {
        root_position: Vector3::new(0.01, 0.0, -0.02),
        root_frame: *nalgebra::Rotation3::new(Vector3::new(0.3, -0.2, 0.9)).matrix(),
        lengths: lengths.to_vec(),
        mass_per_length: 1e-5,
        rotary_inertia: [2e-9, 0.8e-9, 1.2e-9],
        floating: false,
    }
}

fn force_case(n: usize, wl: f64, rng: &mut Rng) -> ForceCase {
    use superhelix_runtime::kernels::moments::{end_derivatives, frame_motions, FrameMotion};
    use superhelix_runtime::model::reconstruction::{darboux, element_ends, Pose};
    let lengths: Vec<f64> = (0..n).map(|k| 0.02 + 0.005 * (k % 3) as f64).collect();
    let g = test_geometry(&lengths);
    let q: Vec<f64> = (0..n)
        .flat_map(|k| {
            let d = direction(k % 5, rng) * (wl / lengths[k]);
            [d[0], d[1], d[2]]
        })
        .collect();
    let v: Vec<f64> = (0..3 * n).map(|_| 30.0 * rng.next()).collect();
    let mut ends = vec![Pose::default(); n + 1];
    element_ends(&g, &q, &mut ends);
    let derivs: Vec<_> = (0..n)
        .map(|k| end_derivatives(&ends[k].frame, &darboux(&q, k), lengths[k]))
        .collect();
    let mut motions = vec![FrameMotion::default(); n + 1];
    frame_motions(&ends, &derivs, &v, &mut motions);
    ForceCase {
        lengths,
        g,
        q,
        v,
        ends,
        derivs,
        motions,
    }
}

#[test]
fn full_generalized_force_from_closed_form_moments_matches_quadrature_moments() {
    use superhelix_runtime::kernels::kernel::BodyField;
    use superhelix_runtime::kernels::moments::assemble_force;
    use superhelix_runtime::model::reconstruction::darboux;
    let mut worst: f64 = 0.0;
    let mut rng = Rng(0x5151_7e57_0000_0001);
    for n in [1usize, 3, 8] {
        for &wl in &[0.0, 1e-6, 0.3, 2.0, 3.4, 3.6, 9.0, 40.0] {
            let ForceCase {
                lengths,
                g,
                q,
                v,
                ends,
                derivs,
                motions,
            } = force_case(n, wl, &mut rng);
            let field = BodyField {
                uniform: Vector3::new(0.2, -0.4, -9.81) * 1e-5,
                linear: Matrix3::from_fn(|r, c| 1e-4 * (r as f64 - 0.5 * c as f64)),
                velocity: -Matrix3::identity() * 1e-5,
            };
            let force_of = |moments: &[ElementMoments]| {
                let mut f = vec![0.0; 3 * n];
                assemble_force(
                    1e-5, &lengths, &ends, &derivs, moments, &motions, &v, &field, &mut f,
                );
                f
            };
            let closed: Vec<_> = (0..n)
                .map(|k| {
                    superhelix_generated::element_moments(
                        &darboux(&q, k),
                        lengths[k],
                        &g.rotary_inertia,
                    )
                })
                .collect();
            let quad: Vec<_> = (0..n)
                .map(|k| {
                    ElementMoments::by_quadrature(
                        &darboux(&q, k),
                        lengths[k],
                        &g.rotary_inertia,
                        64 + (2.0 * wl) as usize,
                    )
                })
                .collect();
            let (a, b) = (force_of(&closed), force_of(&quad));
            let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            for (i, (x, y)) in a.iter().zip(&b).enumerate() {
                let e = rel(*x, *y, scale);
                worst = worst.max(e);
                assert!(e <= 1e-11, "N={n} W l={wl} f[{i}]: {x:e} vs {y:e}");
            }
        }
    }
    println!("worst relative deviation of the generalized force: {worst:e}");
}

/// The force assembly the step calls against the plain `assemble_force`: the inertial
/// and field parts in one pass give the bits of two calls (ρS without the field, the
/// field without ρS).
#[test]
fn the_split_force_assembly_matches_assemble_force() {
    use superhelix_runtime::kernels::kernel::BodyField;
    use superhelix_runtime::kernels::moments::{assemble_force, assemble_inertial_and_field_force};
    use superhelix_runtime::model::reconstruction::darboux;
    let mut rng = Rng(0x5151_7e57_0000_0002);
    for n in [1usize, 3, 8] {
        for &wl in &[0.0, 0.3, 3.6, 40.0] {
            let ForceCase {
                lengths,
                g,
                q,
                v,
                ends,
                derivs,
                motions,
            } = force_case(n, wl, &mut rng);
            let c1 = Matrix3::from_fn(|r, c| 1e-4 * (r as f64 - 0.5 * c as f64));
            let field = BodyField {
                uniform: Vector3::new(0.2, -0.4, -9.81) * 1e-5,
                linear: c1,
                velocity: -Matrix3::identity() * 1e-5,
            };
            let moments: Vec<_> = (0..n)
                .map(|k| {
                    superhelix_generated::element_moments(
                        &darboux(&q, k),
                        lengths[k],
                        &g.rotary_inertia,
                    )
                })
                .collect();
            let plain = |rho_s: f64, field: &BodyField| {
                let mut f = vec![0.0; 3 * n];
                assemble_force(
                    rho_s, &lengths, &ends, &derivs, &moments, &motions, &v, field, &mut f,
                );
                f
            };
            let (mut inertial, mut field_force) = (vec![0.0; 3 * n], vec![0.0; 3 * n]);
            assemble_inertial_and_field_force(
                1e-5,
                &lengths,
                &ends,
                &derivs,
                &moments,
                &motions,
                &v,
                &field,
                &mut inertial,
                &mut field_force,
            );
            assert_eq!(inertial, plain(1e-5, &BodyField::zero()), "N={n} W l={wl}");
            assert_eq!(field_force, plain(0.0, &field), "N={n} W l={wl}");
        }
    }
}

#[test]
fn generated_files_are_fresh() {
    // SUPERHELIX_UPDATE_GENERATED=1 rewrites them (same as `cargo run -p superhelix-codegen --release`).
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let update = std::env::var_os("SUPERHELIX_UPDATE_GENERATED").is_some();
    for (name, text) in superhelix_codegen::kernels::checked_in_files().expect("generation") {
        let path = dir.join(&name);
        let current = std::fs::read_to_string(&path).unwrap_or_default();
        if update {
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent).expect("create the folder");
            }
            std::fs::write(&path, &text).expect("write");
            continue;
        }
        if let Some(diff) = first_difference(&current, &text) {
            let show =
                |line: Option<&str>| line.map_or("(end of file)".to_string(), |l| format!("{l:?}"));
            panic!(
                "{} is stale (first difference at line {}; checked in {} lines, generated {} lines):\n  checked in: {}\n  generated:  {}\nrun `cargo run -p superhelix-codegen --release`",
                path.display(),
                diff.line,
                diff.lines.0,
                diff.lines.1,
                show(diff.a),
                show(diff.b)
            );
        }
    }
}

/// Where two texts first differ, line by line.
#[derive(Debug, PartialEq)]
struct FirstDifference<'a> {
    /// 1-based number of the first line that differs (the line after the common prefix).
    line: usize,
    /// That line in the first and the second text, with its terminator; `None` past the end.
    a: Option<&'a str>,
    b: Option<&'a str>,
    /// Number of lines of the first and the second text.
    lines: (usize, usize),
}

/// The first line at which `a` and `b` differ, or `None` when they are equal. Lines keep
/// their terminators, so when one text is the other with lines added at the end (or only
/// the final newline differs), the difference is at the line after the common prefix.
fn first_difference<'a>(a: &'a str, b: &'a str) -> Option<FirstDifference<'a>> {
    let la: Vec<&str> = a.split_inclusive('\n').collect();
    let lb: Vec<&str> = b.split_inclusive('\n').collect();
    let i = (0..la.len().max(lb.len())).find(|&i| la.get(i) != lb.get(i))?;
    Some(FirstDifference {
        line: i + 1,
        a: la.get(i).copied(),
        b: lb.get(i).copied(),
        lines: (la.len(), lb.len()),
    })
}

#[test]
fn first_difference_is_the_line_after_the_common_prefix() {
    // identical texts
    assert_eq!(first_difference("", ""), None);
    assert_eq!(first_difference("a\nb\nc\n", "a\nb\nc\n"), None);
    // a difference in the middle
    assert_eq!(
        first_difference("a\nb\nc\n", "a\nB\nc\n"),
        Some(FirstDifference {
            line: 2,
            a: Some("b\n"),
            b: Some("B\n"),
            lines: (3, 3)
        })
    );
    // one text a prefix of the other, either way round
    assert_eq!(
        first_difference("a\nb\n", "a\nb\nc\nd\n"),
        Some(FirstDifference {
            line: 3,
            a: None,
            b: Some("c\n"),
            lines: (2, 4)
        })
    );
    assert_eq!(
        first_difference("a\nb\nc\n", "a\n"),
        Some(FirstDifference {
            line: 2,
            a: Some("b\n"),
            b: None,
            lines: (3, 1)
        })
    );
    // a missing (checked-in file absent: read as "") or partial text
    assert_eq!(
        first_difference("", "a\n"),
        Some(FirstDifference {
            line: 1,
            a: None,
            b: Some("a\n"),
            lines: (0, 1)
        })
    );
    // only the final newline differs
    assert_eq!(
        first_difference("a\nb", "a\nb\n"),
        Some(FirstDifference {
            line: 2,
            a: Some("b"),
            b: Some("b\n"),
            lines: (2, 2)
        })
    );
}

#[test]
fn mass_matrix_and_gravity_from_closed_form_moments_match_the_generic_kernel() {
    use superhelix_runtime::kernels::kernel::{
        BodyField, EvalInput, StrandKernel, StrandTerms, Terms,
    };
    use superhelix_runtime::kernels::moments::{
        assemble_mass_and_gravity, bodies_at_rest, end_derivatives,
    };
    use superhelix_runtime::model::reconstruction::{darboux, element_ends, Pose};
    use superhelix_runtime::{GenericKernel, QuadratureRule};
    let mut worst: f64 = 0.0;
    for n in [1usize, 2, 5, 10] {
        for (case, wl) in [0.0, 1e-8, 1e-3, 0.5, 2.5, 8.0, 30.0].iter().enumerate() {
            let lengths: Vec<f64> = (0..n)
                .map(|k| 0.02 + 0.01 * ((k * 7 + case) % 5) as f64)
                .collect();
            let g = test_geometry(&lengths);
            let q: Vec<f64> = (0..n)
                .flat_map(|k| {
                    let dir =
                        Vector3::new(0.3 + 0.1 * k as f64, -0.8, 0.5 - 0.2 * k as f64).normalize();
                    let d = dir * (wl / lengths[k]);
                    [d[0], d[1], d[2]]
                })
                .collect();
            let dofs = 3 * n;
            let c0 = Vector3::new(0.2, -0.4, -9.81) * 1e-5;
            let mut generic =
                GenericKernel::new(g.clone(), QuadratureRule::Fixed(64 + (4.0 * wl) as usize));
            let mut reference = StrandTerms::new(dofs);
            let terms = Terms {
                mass: true,
                force: true,
                ..Default::default()
            };
            let field = BodyField {
                uniform: c0,
                linear: Matrix3::zeros(),
                velocity: Matrix3::zeros(),
            };
            generic.evaluate(
                &EvalInput {
                    q: &q,
                    v: &vec![0.0; dofs],
                    field,
                    terms,
                },
                &mut reference,
            );
            let mut ends = vec![Pose::default(); n + 1];
            element_ends(&g, &q, &mut ends);
            let derivs: Vec<_> = (0..n)
                .map(|k| end_derivatives(&ends[k].frame, &darboux(&q, k), lengths[k]))
                .collect();
            let moments: Vec<_> = (0..n)
                .map(|k| {
                    superhelix_generated::mass_moments(
                        &darboux(&q, k),
                        lengths[k],
                        &g.rotary_inertia,
                    )
                })
                .collect();
            let (mut mass, mut force, mut first) =
                (vec![0.0; dofs * dofs], vec![0.0; dofs], Vector3::zeros());
            let bodies = bodies_at_rest(&ends, &lengths, &moments);
            assemble_mass_and_gravity(
                &bodies, 1e-5, &lengths, &ends, &derivs, &moments, &c0, &mut mass, &mut force,
                &mut first,
            );
            let mscale = (0..dofs)
                .map(|i| reference.mass[(i, i)].abs())
                .fold(0.0, f64::max);
            for j in 0..dofs {
                for i in 0..dofs {
                    let e = rel(mass[j * dofs + i], reference.mass[(i, j)], mscale);
                    worst = worst.max(e);
                    assert!(e <= 1e-10, "N={n} W l={wl} M[{i},{j}]");
                }
            }
            let fscale = reference.force.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            for (i, (a, b)) in force.iter().zip(&reference.force).enumerate() {
                assert!(rel(*a, *b, fscale) <= 1e-10, "N={n} W l={wl} f[{i}]");
            }
        }
    }
    println!("worst relative deviation of M: {worst:e}");
}
