//! `superhelix coulomb` (.npy in and out) and the tress experiments of
//! `superhelix electrostatics`, small.

mod support;

use superhelix::electrostatics_study::{run_experiments, write_report, ExperimentOptions};
use superhelix_fmm::samples::curly_fibres;
use superhelix_fmm::{direct_sum, Softening};
use support::{scratch, stderr, superhelix};

fn write_npy_f64(path: &std::path::Path, data: &[f64], shape: &[u64]) {
    superhelix::coulomb::write_array(path, data, shape).expect("write");
}

fn write_npy_f32(path: &std::path::Path, data: &[f64], shape: &[u64]) {
    use npyz::WriterBuilder;
    let mut bytes = Vec::new();
    {
        let mut w = npyz::WriteOptions::new()
            .default_dtype()
            .shape(shape)
            .writer(&mut bytes)
            .begin_nd()
            .expect("header");
        w.extend(data.iter().map(|v| *v as f32)).expect("data");
        w.finish().expect("finish");
    }
    std::fs::write(path, bytes).expect("write");
}

/// `coulomb` reads float64 and float32 points, writes potential.npy [n] and field.npy
/// [n, 3] in volts and V/m, matching the direct sum (times 1/(4πε₀)) within the
/// requested accuracy; `--direct` matches it to round-off.
#[test]
fn coulomb_command_reads_and_writes_npy() {
    let dir = scratch("coulomb_npy");
    let (points, q) = curly_fibres(60, 100, 2);
    let q: Vec<f64> = q.iter().map(|v| v * 1e-12).collect();
    let flat: Vec<f64> = points.iter().flatten().copied().collect();
    let n = points.len() as u64;
    write_npy_f64(&dir.join("p.npy"), &flat, &[n, 3]);
    write_npy_f32(&dir.join("p32.npy"), &flat, &[n, 3]);
    write_npy_f64(&dir.join("q.npy"), &q, &[n]);
    let (phi0, e0) = direct_sum(&points, &q, Softening::NONE);
    let k = superhelix::coulomb::COULOMB_CONSTANT;
    // (field tolerance, potential tolerance): the multipole method at eps 1e-6; the
    // direct sum is this sum in another order, round-off only
    for (pts, extra, tol, ptol) in [
        ("p.npy", None, 1e-6, 1e-4),
        ("p.npy", Some("--direct"), 1e-13, 1e-12),
    ] {
        let out = dir.join(format!("out_{}", extra.unwrap_or("fmm")));
        let mut args = vec![
            "coulomb",
            "--points",
            dir.join(pts).to_str().unwrap_or_default(),
            "--charges",
            dir.join("q.npy").to_str().unwrap_or_default(),
            "--eps",
            "1e-6",
            "--out",
            out.to_str().unwrap_or_default(),
        ]
        .into_iter()
        .map(String::from)
        .collect::<Vec<_>>();
        if let Some(e) = extra {
            args.push(e.into());
        }
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        let run = superhelix(&refs);
        assert!(run.status.success(), "{}", stderr(&run));
        let (phi, shape) = superhelix::coulomb::read_array(&out.join("potential.npy"), "potential")
            .expect("potential");
        assert_eq!(shape, vec![n]);
        let (field, shape) =
            superhelix::coulomb::read_array(&out.join("field.npy"), "field").expect("field");
        assert_eq!(shape, vec![n, 3]);
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..points.len() {
            for a in 0..3 {
                num += (field[3 * i + a] - k * e0[i][a]).powi(2);
                den += (k * e0[i][a]).powi(2);
            }
            assert!(
                (phi[i] - k * phi0[i]).abs() <= ptol * (k * phi0[i]).abs().max(1e-3),
                "{extra:?}: potential {} vs {}",
                phi[i],
                k * phi0[i]
            );
        }
        assert!(
            (num / den).sqrt() <= tol,
            "{extra:?}: field error {:e}",
            (num / den).sqrt()
        );
    }
    // float32 points are read too (and rounded to f32: a looser comparison).
    let out = dir.join("out32");
    let run = superhelix(&[
        "coulomb",
        "--points",
        dir.join("p32.npy").to_str().unwrap_or_default(),
        "--charges",
        dir.join("q.npy").to_str().unwrap_or_default(),
        "--out",
        out.to_str().unwrap_or_default(),
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    // its field is that of the points as float32 rounds them, to the method's accuracy
    let rounded: Vec<[f64; 3]> = points.iter().map(|p| p.map(|c| c as f32 as f64)).collect();
    let (_, e32) = direct_sum(&rounded, &q, Softening::NONE);
    let (field, _) =
        superhelix::coulomb::read_array(&out.join("field.npy"), "field").expect("field");
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..rounded.len() {
        for a in 0..3 {
            num += (field[3 * i + a] - k * e32[i][a]).powi(2);
            den += (k * e32[i][a]).powi(2);
        }
    }
    assert!(
        (num / den).sqrt() <= 1e-6,
        "float32 points: field error {:e}",
        (num / den).sqrt()
    );
    // Wrong shapes are refused naming the option.
    let run = superhelix(&[
        "coulomb",
        "--points",
        dir.join("q.npy").to_str().unwrap_or_default(),
        "--charges",
        dir.join("q.npy").to_str().unwrap_or_default(),
        "--out",
        out.to_str().unwrap_or_default(),
    ]);
    assert!(!run.status.success());
    assert!(
        stderr(&run).contains("--points") && stderr(&run).contains("[n, 3]"),
        "{}",
        stderr(&run)
    );
}

/// Each bad input of `coulomb` is refused naming its own option, and nothing is written:
/// an FMM option out of range, a missing input file, points so far apart (finite, near
/// 1e300) that the squared distances overflow.
#[test]
fn coulomb_refuses_bad_input_naming_the_option_and_writes_nothing() {
    let dir = scratch("coulomb_refusals");
    let p = dir.join("p.npy");
    let q = dir.join("q.npy");
    write_npy_f64(&p, &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 2.0, 0.0], &[3, 3]);
    write_npy_f64(&q, &[1.0, -1.0, 0.5], &[3]);
    let run = |points: &std::path::Path, charges: &std::path::Path, extra: &[&str], out: &str| {
        let out = dir.join(out);
        let mut args = vec![
            "coulomb",
            "--points",
            points.to_str().unwrap_or_default(),
            "--charges",
            charges.to_str().unwrap_or_default(),
            "--out",
            out.to_str().unwrap_or_default(),
        ];
        args.extend_from_slice(extra);
        let r = superhelix(&args);
        (r.status.success(), stderr(&r), out.exists())
    };
    for (extra, option) in [
        (&["--order", "0"][..], "--order"),
        (&["--theta", "0"][..], "--theta"),
        (&["--leaf-size", "0"][..], "--leaf-size"),
        (&["--eps", "2"][..], "--eps"),
    ] {
        let (ok, err, written) = run(&p, &q, extra, option);
        assert!(!ok && !written, "{extra:?}: {err}");
        assert!(err.contains(&format!("{option}:")), "{extra:?}: {err}");
    }
    let missing = dir.join("absent.npy");
    let (ok, err, _) = run(&missing, &q, &[], "m1");
    assert!(
        !ok && err.contains("--points") && err.contains("absent.npy"),
        "{err}"
    );
    let (ok, err, _) = run(&p, &missing, &[], "m2");
    assert!(
        !ok && err.contains("--charges") && err.contains("absent.npy"),
        "{err}"
    );
    let far = dir.join("far.npy");
    write_npy_f64(
        &far,
        &[1e300, 0.0, 0.0, -1e300, 0.0, 0.0, 0.0, 1e300, 0.0],
        &[3, 3],
    );
    for direct in [false, true] {
        let extra: &[&str] = if direct { &["--direct"] } else { &[] };
        let (ok, err, written) = run(&far, &q, extra, "far");
        assert!(!ok && !written && err.contains("--points"), "{err}");
    }
}

/// The experiments on a small tress: RH 100 % sags more and takes more room than RH 65 %;
/// logarithmic charging converges; the report has the mean field and the pictures.
#[test]
fn tress_experiments_small() {
    let dir = scratch("tress_experiments");
    let options = ExperimentOptions {
        fibres: 24,
        elements: 5,
        element_counts: vec![3, 6],
        orders: vec![2, 4, 6],
        accuracy: 1e-6,
    };
    let e = run_experiments(&options, &dir, |_| {}).expect("experiments");
    let case = |name: &str| e.cases.iter().find(|c| c.name == name).expect("case");
    let (wet, dry) = (case("charged_rh100"), case("charged_rh65"));
    assert!(
        wet.tip_depth > 1.5 * dry.tip_depth,
        "sag {} vs {}",
        wet.tip_depth,
        dry.tip_depth
    );
    assert!(
        wet.box_volume > dry.box_volume,
        "room {} vs {}",
        wet.box_volume,
        dry.box_volume
    );
    assert!(dry.mean_field > 0.0 && case("uncharged").mean_field == 0.0);
    // the mean field the report gives, against the direct sum over every pair of the
    // same particles (the multipole method at the scene's accuracy, 1e-6)
    for c in e.cases.iter().filter(|c| c.mean_field > 0.0) {
        let direct = c
            .mean_field_direct
            .expect("a direct reference for the small tress");
        assert!(
            (c.mean_field / direct - 1.0).abs() < 1e-5,
            "{}: mean field {} V/m, direct sum {direct} V/m",
            c.name,
            c.mean_field
        );
    }
    let log = case("charged_log5");
    assert_eq!(log.iterations.len(), 5);
    assert!(log.residual <= 1e-6, "{log:?}");
    for w in e.orders.windows(2) {
        assert!(w[1].mean_direction_error < w[0].mean_direction_error);
    }
    let files = write_report(&e, &dir).expect("report");
    let report = std::fs::read_to_string(dir.join("report.md")).expect("report.md");
    // the report gives the computed mean field (kV/m, two decimals), not only the
    // paper's 13 kV/m
    assert!(report.contains("Mean field strength"));
    let shown = format!("{:.2}", dry.mean_field / 1e3);
    assert!(report.contains(&shown), "{shown} kV/m not in the report");
    assert!(files.iter().any(|f| f.ends_with("orders.svg")));
    for c in &e.cases {
        assert!(dir.join(&c.name).join("preview.png").exists(), "{}", c.name);
    }
}

/// The summary line says how often the Coulomb forces were recomputed: with fixed steps,
/// at the start and every `update_every`-th step (6 steps of 1/30 s, every second step:
/// at steps 0, 2 and 4).
#[test]
fn the_run_reports_its_coulomb_updates() {
    let dir = scratch("coulomb_updates");
    let scene = support::write(
        &dir,
        "charged.toml",
        &support::charged_tress(0.2, "update_every = 2", ""),
    );
    let out = superhelix(&[
        "run",
        &scene.to_string_lossy(),
        "--out",
        &dir.join("out").to_string_lossy(),
        "--format",
        "npy",
    ]);
    let text = support::text(&out);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains("Coulomb forces recomputed 3 times in "),
        "{text}"
    );
}
