//! The f32 kernels (`centreline_mass_f32`, `centreline_force_f32`, `rotary_basis_f32`,
//! `element_point_f32`) against their f64 versions: what f32 costs in accuracy, and where
//! the Taylor switch-overs moved.
//!
//! The error of an output group (the entries of one tensor, e.g. all `pd2p_…`, or one
//! field of `ElementPoint`) at one point is max |f32 − f64| over the group divided by
//! max |f64| over the group, both kernels evaluated at the same inputs: the f32 inputs,
//! widened exactly to f64 (what the f32 kernel adds to the error, not what rounding the
//! inputs to f32 does; that is reported on its own by the study).
//!
//! `f32_kernels_agree_with_f64` (default suite) holds every group within
//! [`TOLERANCE_TAYLOR`] in the Taylor branches and [`TOLERANCE_CLOSED`] in the closed
//! forms on a small grid; `f32_study` (ignored) prints the tables of `docs/kernels.md`,
//! "f32 kernels":
//!
//! `cargo test -p superhelix-generated --release --test f32 -- --ignored --nocapture`

use nalgebra::Vector3;
use superhelix_codegen::{
    generate_function, kernel_point, kernels, Float, Graph, HelixSymbols, Measure,
};
use superhelix_generated as gen;
use superhelix_generated::{
    centreline_force_f32 as force32, centreline_mass_f32 as mass32, rotary_basis_f32 as rotary32,
};

/// f32's unit round-off, 2^-24: a correctly rounded f32 operation errs by at most this,
/// relative.
const U: f64 = f32::EPSILON as f64 / 2.0;

/// What the default test allows in a Taylor branch: 64 f32 round-offs (3.8e-6) relative
/// to each group's largest entry. A Taylor branch is a polynomial in `W l` whose terms
/// grow with `W l` and alternate: its f32 error is a few round-offs for nearly straight
/// elements and grows towards the switch; the study measures at most 42 (the Taylor
/// branch of `centreline_force_f32` just below its switch, W l = 4).
const TOLERANCE_TAYLOR: f64 = 64.0 * U;

/// What the default test allows in a closed-form branch: 256 f32 round-offs (2^-16 =
/// 1.5e-5), i.e. 8 of f32's 24 bits lost. The closed forms in f32 are sums of hundreds to
/// thousands of rounded products of `sin`, `cos`, powers of `W l` and of `1/(W l)` whose
/// terms cancel in part at every `W l` (most just above the switch, and again for the
/// products of frames as `W l` grows): the study measures at most 190 round-offs
/// (`rotary_basis_f32`, group `eww`, W l = 4.9), 114 for `centreline_force_f32`, 84 for
/// `centreline_mass_f32`, 24 for `element_point_f32`.
const TOLERANCE_CLOSED: f64 = 256.0 * U;

/// The tolerance of a branch.
fn tolerance(b: Branch) -> f64 {
    match b {
        Branch::LowTaylor | Branch::Taylor => TOLERANCE_TAYLOR,
        Branch::Closed => TOLERANCE_CLOSED,
    }
}

/// Which branch of an f32 function a point falls in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Branch {
    LowTaylor,
    Taylor,
    Closed,
}

impl Branch {
    fn name(self) -> &'static str {
        match self {
            Branch::LowTaylor => "low-degree Taylor",
            Branch::Taylor => "Taylor",
            Branch::Closed => "closed form",
        }
    }
}

/// An f32 function and its f64 version.
struct Function {
    name: &'static str,
    /// The f64 outputs at (d, l), in the order of the f32 outputs.
    f64: fn(&[f64; 3], f64) -> Vec<f64>,
    f32: fn(&[f32; 3], f32) -> Vec<f32>,
    /// Output groups (name, indices): the tensors, or the fields of `ElementPoint`.
    groups: Vec<(String, Vec<usize>)>,
    /// The branch the f32 function takes at (d, l).
    branch: fn(&[f32; 3], f32) -> Branch,
}

/// `W l` as the f32 moment functions compute it.
fn wl32(d: &[f32; 3], l: f32) -> f32 {
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() * l
}

macro_rules! moment_function {
    ($name:literal, $f64:path, $f32:path, $k:literal, $outputs:path, $low:path, $switch:path) => {{
        fn f64_outputs(d: &[f64; 3], l: f64) -> Vec<f64> {
            let mut o = [0.0; $k];
            $f64(d, l, &mut o);
            o.to_vec()
        }
        fn f32_outputs(d: &[f32; 3], l: f32) -> Vec<f32> {
            let mut o = [0.0f32; $k];
            $f32(d, l, &mut o);
            o.to_vec()
        }
        fn branch(d: &[f32; 3], l: f32) -> Branch {
            let x = wl32(d, l);
            if x < $low {
                Branch::LowTaylor
            } else if x < $switch {
                Branch::Taylor
            } else {
                Branch::Closed
            }
        }
        let names: Vec<&str> = $outputs.to_vec();
        let ids = Measure::Group.groups(&names);
        let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
        for (j, &gid) in ids.iter().enumerate() {
            if gid == groups.len() {
                let key = names[j].split('_').next().unwrap_or(names[j]);
                groups.push((key.to_string(), Vec::new()));
            }
            groups[gid].1.push(j);
        }
        Function {
            name: $name,
            f64: f64_outputs,
            f32: f32_outputs,
            groups,
            branch,
        }
    }};
}

/// The entry of an f64 `ElementPoint` that the f32 output `name` holds.
fn point_entry(e: &superhelix_kernels::element::ElementPoint, name: &str) -> f64 {
    let (field, index) = name.split_once('_').expect("field_index");
    let i: Vec<usize> = index
        .chars()
        .filter_map(|c| c.to_digit(10).map(|v| v as usize))
        .collect();
    match field {
        "frame" => e.frame[(i[0], i[1])],
        "p" => e.p[i[0]],
        "dp" => e.dp[i[0]][i[1]],
        "d2p" => e.d2p[i[0]][i[1]][i[2]],
        "w" => e.w[i[0]][i[1]],
        "dw" => e.dw[i[0]][i[1]][i[2]],
        other => panic!("unknown field {other}"),
    }
}

fn point_function() -> Function {
    fn f64_outputs(d: &[f64; 3], u: f64) -> Vec<f64> {
        let e = gen::element_point(&Vector3::new(d[0], d[1], d[2]), u);
        gen::ELEMENT_POINT_F32_OUTPUTS
            .iter()
            .map(|n| point_entry(&e, n))
            .collect()
    }
    fn f32_outputs(d: &[f32; 3], u: f32) -> Vec<f32> {
        let mut o = [0.0f32; 63];
        gen::element_point_f32(d, u, &mut o);
        o.to_vec()
    }
    fn branch(d: &[f32; 3], u: f32) -> Branch {
        let z = u * u * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        let s = gen::ELEMENT_POINT_F32_SWITCH;
        if z < s * s {
            Branch::Taylor
        } else {
            Branch::Closed
        }
    }
    // the groups the generator measures on: the fields (w with w_0 = p, dw with dp)
    let mut g = Graph::new();
    let h = HelixSymbols::new(&mut g);
    let spec = kernel_point::element_point_spec(&mut g, &h);
    let names: Vec<&str> = spec.outputs.iter().map(|o| o.0.as_str()).collect();
    assert_eq!(names, gen::ELEMENT_POINT_F32_OUTPUTS.to_vec());
    Function {
        name: "element_point_f32",
        f64: f64_outputs,
        f32: f32_outputs,
        groups: spec.groups,
        branch,
    }
}

fn functions() -> Vec<Function> {
    vec![
        moment_function!(
            "centreline_mass_f32",
            gen::centreline_mass,
            gen::centreline_mass_f32,
            51,
            mass32::CENTRELINE_MASS_F32_OUTPUTS,
            mass32::CENTRELINE_MASS_F32_LOW_SWITCH,
            mass32::CENTRELINE_MASS_F32_SWITCH
        ),
        moment_function!(
            "centreline_force_f32",
            gen::centreline_force,
            gen::centreline_force_f32,
            135,
            force32::CENTRELINE_FORCE_F32_OUTPUTS,
            force32::CENTRELINE_FORCE_F32_LOW_SWITCH,
            force32::CENTRELINE_FORCE_F32_SWITCH
        ),
        moment_function!(
            "rotary_basis_f32",
            gen::rotary_basis,
            gen::rotary_basis_f32,
            63,
            rotary32::ROTARY_BASIS_F32_OUTPUTS,
            rotary32::ROTARY_BASIS_F32_LOW_SWITCH,
            rotary32::ROTARY_BASIS_F32_SWITCH
        ),
        point_function(),
    ]
}

/// The error of every group of `a` against the reference `b` (see the module docs).
fn group_errors(a: &[f64], b: &[f64], groups: &[(String, Vec<usize>)]) -> Vec<f64> {
    groups
        .iter()
        .map(|(_, idx)| {
            let scale = idx.iter().fold(0.0f64, |m, &j| m.max(b[j].abs()));
            let err = idx.iter().fold(0.0f64, |m, &j| m.max((a[j] - b[j]).abs()));
            if err == 0.0 {
                0.0
            } else if scale > 0.0 {
                err / scale
            } else {
                f64::INFINITY
            }
        })
        .collect()
}

/// One evaluation: the f32 function's branch and, per group, its error against f64 at
/// the f32 inputs and the change of the f64 outputs from rounding the inputs to f32.
struct Sample {
    branch: Branch,
    errors: Vec<f64>,
    input_rounding: Vec<f64>,
}

/// Evaluate `f` at `d`, `l` (f64; rounded to f32 for the f32 function).
fn sample(f: &Function, d: [f64; 3], l: f64) -> Sample {
    let (d32, l32) = (d.map(|v| v as f32), l as f32);
    let (dw, lw) = (d32.map(|v| v as f64), l32 as f64);
    let reference = (f.f64)(&dw, lw);
    let single: Vec<f64> = (f.f32)(&d32, l32).iter().map(|&v| v as f64).collect();
    let exact_inputs = (f.f64)(&d, l);
    Sample {
        branch: (f.branch)(&d32, l32),
        errors: group_errors(&single, &reference, &f.groups),
        input_rounding: group_errors(&reference, &exact_inputs, &f.groups),
    }
}

/// xorshift64, uniform in [−1, 1).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// Unit directions of d: the axes (pure twist, pure curvatures), planar and diagonal
/// ones, then `random` pseudo-random ones.
fn directions(random: usize) -> Vec<[f64; 3]> {
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let t = 1.0 / 3f64.sqrt();
    let mut out = vec![
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, -1.0],
        [0.0, h, h],
        [h, -h, 0.0],
        [t, t, t],
    ];
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    while out.len() < 6 + random {
        let v = [rng.next(), rng.next(), rng.next()];
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if n > 0.1 && n <= 1.0 {
            out.push(v.map(|x| x / n));
        }
    }
    out
}

/// Every switch of the f32 and f64 functions, where the grids add points either side.
fn switches() -> Vec<f64> {
    vec![
        mass32::CENTRELINE_MASS_F32_LOW_SWITCH as f64,
        gen::CENTRELINE_MASS_F32_SWITCH as f64,
        force32::CENTRELINE_FORCE_F32_LOW_SWITCH as f64,
        gen::CENTRELINE_FORCE_F32_SWITCH as f64,
        rotary32::ROTARY_BASIS_F32_LOW_SWITCH as f64,
        gen::ROTARY_BASIS_F32_SWITCH as f64,
        gen::ELEMENT_POINT_F32_SWITCH as f64,
        gen::centreline_mass::CENTRELINE_MASS_LOW_SWITCH,
        gen::CENTRELINE_MASS_SWITCH,
        gen::centreline_force::CENTRELINE_FORCE_LOW_SWITCH,
        gen::CENTRELINE_FORCE_SWITCH,
        gen::rotary_basis::ROTARY_BASIS_LOW_SWITCH,
        gen::ROTARY_BASIS_SWITCH,
        gen::ELEMENT_POINT_SWITCH,
    ]
}

/// `wl` values, with every switch × (1 ± 1e-6) added.
fn with_switches(mut wl: Vec<f64>) -> Vec<f64> {
    for s in switches() {
        wl.push(s * (1.0 - 1e-6));
        wl.push(s * (1.0 + 1e-6));
    }
    wl.sort_by(f64::total_cmp);
    wl.dedup();
    wl
}

/// The worst error of one function in one branch.
struct BranchWorst {
    branch: Branch,
    points: usize,
    error: f64,
    /// Where: W l, l, group index.
    at: (f64, f64, usize),
    /// Smallest and largest W l sampled in the branch.
    range: (f64, f64),
}

/// The worst of one function over a set of points: overall, per branch, per group, per
/// band of W l, and of the input rounding.
#[derive(Default)]
struct Worst {
    /// (error, W l, l, group index)
    overall: (f64, f64, f64, usize),
    branch: Vec<BranchWorst>,
    group: Vec<f64>,
    band: Vec<f64>,
    input_rounding: f64,
    points: usize,
}

/// Bands of W l for the study's table (lower bounds).
const BANDS: [f64; 6] = [0.0, 0.1, 1.0, 2.0, 3.0, 4.0];

fn measure(f: &Function, wl: &[f64], lengths: &[f64], dirs: &[[f64; 3]]) -> Worst {
    let mut w = Worst {
        group: vec![0.0; f.groups.len()],
        band: vec![0.0; BANDS.len()],
        ..Worst::default()
    };
    for &x in wl {
        for &l in lengths {
            for e in dirs {
                let d = e.map(|c| c * x / l);
                let s = sample(f, d, l);
                w.points += 1;
                let (gi, err) = s
                    .errors
                    .iter()
                    .copied()
                    .enumerate()
                    .fold((0, 0.0f64), |a, (i, v)| if v > a.1 { (i, v) } else { a });
                if err > w.overall.0 || w.points == 1 {
                    w.overall = (err, x, l, gi);
                }
                for (k, v) in s.errors.iter().enumerate() {
                    w.group[k] = w.group[k].max(*v);
                }
                let band = BANDS.iter().rposition(|&b| x >= b).unwrap_or(0);
                w.band[band] = w.band[band].max(err);
                w.input_rounding = s
                    .input_rounding
                    .iter()
                    .fold(w.input_rounding, |m, v| m.max(*v));
                match w.branch.iter_mut().find(|b| b.branch == s.branch) {
                    Some(b) => {
                        b.points += 1;
                        if err > b.error {
                            (b.error, b.at) = (err, (x, l, gi));
                        }
                        b.range = (b.range.0.min(x), b.range.1.max(x));
                    }
                    None => w.branch.push(BranchWorst {
                        branch: s.branch,
                        points: 1,
                        error: err,
                        at: (x, l, gi),
                        range: (x, x),
                    }),
                }
            }
        }
    }
    w.branch.sort_by_key(|b| b.branch);
    w
}

/// The small grid of the default test: W l over the hair range (1e-4 to 6), either side
/// of every switch, three lengths (1 mm, 1 cm, 10 cm), 16 directions.
#[test]
fn f32_kernels_agree_with_f64() {
    let mut wl = vec![1e-4, 1e-3, 1e-2, 0.1];
    wl.extend((1..=12).map(|k| 0.5 * k as f64));
    let wl = with_switches(wl);
    let dirs = directions(10);
    for f in functions() {
        let w = measure(&f, &wl, &[1e-3, 1e-2, 0.1], &dirs);
        assert_eq!(
            w.branch.len(),
            if f.name == "element_point_f32" { 2 } else { 3 },
            "{}: every branch sampled",
            f.name
        );
        for b in &w.branch {
            let (branch, err, (x, l, gi)) = (b.branch, b.error, b.at);
            println!(
                "{} ({}): worst {:.2e} = {:.1} × 2^-24 ({}, W l = {x}, l = {l})",
                f.name,
                branch.name(),
                err,
                err / U,
                f.groups[gi].0
            );
            assert!(
                err <= tolerance(branch),
                "{} ({}): group {} errs by {err:.3e} = {:.1} × 2^-24 > {:.0} × 2^-24 at W l = {x}, \
                 l = {l}",
                f.name,
                branch.name(),
                f.groups[gi].0,
                err / U,
                tolerance(branch) / U
            );
        }
    }
}

/// The measure of the default test is not blind: an f32 result off by more than the
/// tolerance in one entry (here, 1.5 × the closed-form tolerance of its group's scale)
/// is reported above the tolerance.
#[test]
fn group_error_sees_one_wrong_entry() {
    for f in functions() {
        let (d, l) = ([30.0f32, -170.0, 220.0], 0.01f32);
        let branch = (f.branch)(&d, l);
        let reference = (f.f64)(&d.map(|v| v as f64), l as f64);
        let single: Vec<f64> = (f.f32)(&d, l).iter().map(|&v| v as f64).collect();
        let before = group_errors(&single, &reference, &f.groups);
        assert!(before.iter().all(|&e| e <= tolerance(branch)), "{}", f.name);
        for (k, (name, idx)) in f.groups.iter().enumerate() {
            let scale = idx.iter().fold(0.0f64, |m, &j| m.max(reference[j].abs()));
            let mut bad = single.clone();
            bad[idx[idx.len() / 2]] += 1.5 * TOLERANCE_CLOSED * scale;
            let after = group_errors(&bad, &reference, &f.groups);
            assert!(
                after[k] > TOLERANCE_CLOSED,
                "{} {name}: {:e}",
                f.name,
                after[k]
            );
        }
    }
}

/// The study of `docs/kernels.md`, "f32 kernels": prints the switches and degrees the
/// f64 and f32 selections chose (generating both), then the errors of the f32 functions
/// on a grid of hair-like elements: W l from 1e-4 to 6 (log-spaced to 0.1, then every
/// 0.05, and either side of every switch), lengths 1 mm to 10 cm, 24 directions.
#[test]
#[ignore = "the f32 study: prints the tables of docs/kernels.md (release build)"]
fn f32_study() {
    println!("| function | f64: switch (Taylor degree) | f64: low-degree branch | f32: switch (Taylor degree) | f32: low-degree branch | f32 switch chosen as |");
    println!("|---|---|---|---|---|---|");
    for k in kernels::ELEMENT_KERNELS.iter() {
        let a = kernels::generate_in(k, Float::F64).expect("f64 generation");
        let b = kernels::generate_in(k, Float::F32).expect("f32 generation");
        let low = |c: &superhelix_codegen::GeneratedCode| {
            c.low.map_or("none".to_string(), |t| {
                format!("W l < {} ({})", t.x, t.order)
            })
        };
        println!(
            "| {} | {} ({}) | {} | {} ({}) | {} | {} |",
            b.name,
            a.switch,
            a.series_order,
            low(&a),
            b.switch,
            b.series_order,
            low(&b),
            if b.target_met {
                "first within 16 × 2^-24".to_string()
            } else {
                format!(
                    "smallest error ({:.1} × 2^-24; none within 16 × 2^-24)",
                    b.agreement / U
                )
            }
        );
    }
    let (p64, _) = kernel_point::generate_element_point().expect("f64 point");
    let (p32, _) = kernel_point::generate_element_point_f32().expect("f32 point");
    let degrees = |c: &superhelix_codegen::point::PointCode| {
        c.series_orders
            .iter()
            .map(|o| o.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    println!(
        "| element_point_f32 | {} ({}) | none | {} ({}) | none | {} |",
        p64.switch,
        degrees(&p64),
        p32.switch,
        degrees(&p32),
        if p32.target_met {
            "first within 16 × 2^-24".to_string()
        } else {
            format!(
                "smallest error ({:.1} × 2^-24; none within 16 × 2^-24)",
                p32.agreement / U
            )
        }
    );
    println!(
        "\nAt the f32 switch, as the selection measured it (its samples, each branch in f32 \
         against f64):"
    );
    for k in kernels::ELEMENT_KERNELS.iter() {
        let b = kernels::generate_in(k, Float::F32).expect("f32 generation");
        println!(
            "  {}: Taylor branch {:.1} × 2^-24, closed form {:.1} × 2^-24",
            b.name,
            b.series_error / U,
            b.closed_error / U
        );
    }
    println!(
        "  element_point_f32: Taylor branch {:.1} × 2^-24, closed form {:.1} × 2^-24",
        p32.series_error / U,
        p32.closed_error / U
    );

    let mut wl: Vec<f64> = Vec::new();
    for e in -4..=-2 {
        for m in [1.0, 2.0, 5.0] {
            wl.push(m * 10f64.powi(e));
        }
    }
    wl.extend((2..=120).map(|k| 0.05 * k as f64));
    let wl = with_switches(wl);
    let lengths = [1e-3, 2e-3, 5e-3, 1e-2, 2e-2, 5e-2, 0.1];
    let dirs = directions(18);
    println!(
        "\nGrid: {} values of W l in [{}, {}], lengths {:?} m, {} directions; errors in units of \
         2^-24 = {:.3e}, per tensor group (per field for element_point_f32).\n",
        wl.len(),
        wl[0],
        wl[wl.len() - 1],
        lengths,
        dirs.len(),
        U
    );
    let all: Vec<(Function, Worst)> = functions()
        .into_iter()
        .map(|f| {
            let w = measure(&f, &wl, &lengths, &dirs);
            (f, w)
        })
        .collect();
    println!("| function | branch | W l | points | worst error | group | at W l, l |");
    println!("|---|---|---|---|---|---|---|");
    for (f, w) in &all {
        for b in &w.branch {
            println!(
                "| {} | {} | {:.3}–{:.3} | {} | {:.1} × 2^-24 ({:.1e}) | {} | {:.4}, {} m |",
                f.name,
                b.branch.name(),
                b.range.0,
                b.range.1,
                b.points,
                b.error / U,
                b.error,
                f.groups[b.at.2].0,
                b.at.0,
                b.at.1
            );
        }
    }
    println!("\nWorst error by band of W l (units of 2^-24):\n");
    let head: Vec<String> = BANDS
        .iter()
        .enumerate()
        .map(|(i, b)| match BANDS.get(i + 1) {
            Some(n) => format!("[{b}, {n})"),
            None => format!("[{b}, 6]"),
        })
        .collect();
    println!("| function | {} |", head.join(" | "));
    println!("|---|{}", "---|".repeat(BANDS.len()));
    for (f, w) in &all {
        let cells: Vec<String> = w.band.iter().map(|e| format!("{:.1}", e / U)).collect();
        println!("| {} | {} |", f.name, cells.join(" | "));
    }
    println!("\nWorst error per group (units of 2^-24):\n");
    for (f, w) in &all {
        let cells: Vec<String> = f
            .groups
            .iter()
            .zip(&w.group)
            .map(|((n, _), e)| format!("{n} {:.1}", e / U))
            .collect();
        println!("- {}: {}", f.name, cells.join(", "));
    }
    println!(
        "\nRounding the inputs (d, l) to f32, the f64 outputs move by at most (units of 2^-24):"
    );
    for (f, w) in &all {
        println!(
            "- {}: {:.1} ({} points)",
            f.name,
            w.input_rounding / U,
            w.points
        );
    }
    let worst = all.iter().map(|(_, w)| w.overall.0).fold(0.0f64, f64::max);
    println!(
        "\nworst over all: {:.1} × 2^-24 = {:.2e} (the default test allows {:.0} × 2^-24 in \
         the Taylor branches, {:.0} × 2^-24 in the closed forms)",
        worst / U,
        worst,
        TOLERANCE_TAYLOR / U,
        TOLERANCE_CLOSED / U
    );
}

/// `a` (an f32 value widened) is the f32 value `c`: the same bits, but for the sign of a
/// zero (the evaluator sums from +0).
fn same(a: f64, c: f32) -> bool {
    a.is_finite() && a == f64::from(c)
}

/// The f32 selection measures the code as written: the generator's f32 evaluation of
/// each branch's graph (`Evaluator::eval_f32`, what `superhelix_codegen::branch` and
/// `point` measure the candidates with) gives the generated f32 functions' results bit
/// for bit, in every branch.
#[test]
fn f32_evaluation_is_the_emitted_code() {
    let dirs = directions(4);
    let lengths = [1e-3, 0.03];
    let wl = with_switches(vec![1e-3, 0.3, 0.9, 1.7, 2.6, 3.3, 4.4, 5.9]);
    let functions = functions();
    for k in kernels::ELEMENT_KERNELS.iter() {
        let mut g = Graph::new();
        let h = HelixSymbols::new(&mut g);
        let list = (k.list)(&mut g, &h);
        let name = k.name_in(Float::F32);
        let code = generate_function(
            &mut g,
            &h,
            &name,
            &list,
            &kernels::element_options_for(Float::F32),
        )
        .expect("generation");
        let f = functions.iter().find(|f| f.name == name).expect("listed");
        let evs = [
            g.evaluator(&code.low_series),
            g.evaluator(&code.series),
            g.evaluator(&code.closed),
        ];
        let mut seen = [0; 3];
        for &x in &wl {
            for &l in &lengths {
                for e in &dirs {
                    let (d, l) = (e.map(|c| (c * x / l) as f32), l as f32);
                    let b = (f.branch)(&d, l) as usize;
                    seen[b] += 1;
                    let bindings = h.bindings_f32(d.map(f64::from), f64::from(l), 0.0);
                    let emulated = evs[b].eval_f32(&g, &bindings);
                    let emitted = (f.f32)(&d, l);
                    for (j, (a, c)) in emulated.iter().zip(&emitted).enumerate() {
                        assert!(
                            same(*a, *c),
                            "{name} {}: {a:e} vs {c:e} at d = {d:?}, l = {l}",
                            code.outputs[j]
                        );
                    }
                }
            }
        }
        assert!(seen.iter().all(|&n| n > 0), "{name}: {seen:?}");
    }
    // the element point: the radial functions' branch, then the polynomial part
    let mut g = Graph::new();
    let h = HelixSymbols::new(&mut g);
    let (spec, code) = kernel_point::element_point_f32_code(&mut g, &h).expect("generation");
    let (wu, zu) = (g.symbol("wu"), g.symbol("zu"));
    let radial = [g.evaluator(&code.series), g.evaluator(&code.closed)];
    let outputs: Vec<superhelix_codegen::Id> = spec.outputs.iter().map(|o| o.1).collect();
    let out_ev = g.evaluator(&outputs);
    let s = gen::ELEMENT_POINT_F32_SWITCH;
    let mut seen = [0; 2];
    for &x in &wl {
        for &u in &lengths {
            for e in &dirs {
                let (d, u) = (e.map(|c| (c * x / u) as f32), u as f32);
                let z = u * u * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                let b = usize::from(z >= s * s);
                seen[b] += 1;
                let r = radial[b].eval_f32(
                    &g,
                    &[
                        (h.u, f64::from(u)),
                        (wu, f64::from(z.sqrt())),
                        (zu, f64::from(z)),
                    ],
                );
                let mut bindings: Vec<(superhelix_codegen::Id, f64)> = vec![
                    (h.d[0], f64::from(d[0])),
                    (h.d[1], f64::from(d[1])),
                    (h.d[2], f64::from(d[2])),
                    (h.u, f64::from(u)),
                ];
                bindings.extend(spec.radial.iter().map(|r| r.symbol).zip(r));
                let emulated = out_ev.eval_f32(&g, &bindings);
                let mut emitted = [0.0f32; 63];
                gen::element_point_f32(&d, u, &mut emitted);
                for (j, (a, c)) in emulated.iter().zip(&emitted).enumerate() {
                    assert!(
                        same(*a, *c),
                        "element_point_f32 {}: {a:e} vs {c:e} at d = {d:?}, u = {u}",
                        spec.outputs[j].0
                    );
                }
            }
        }
    }
    assert!(seen.iter().all(|&n| n > 0), "element_point_f32: {seen:?}");
}
