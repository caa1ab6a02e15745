//! Print, for each list of generated integrands and each candidate switch `x*`, the
//! Taylor order needed there and the measured agreement of the branches, per output and
//! per tensor group.
//!
//! `cargo run -p superhelix-codegen --release --example switch_scan [-- LIST...]`
//! (LIST: mass, force, rotary, or LIST:GROUP for the outputs of one group, e.g.
//! force:dpd2p; all by default). `-- --f32` scans the candidates of the f32 selection
//! (the checked-in f32 options, [`kernels::element_options_for`]): at each, the Taylor
//! degree the f32 truncation target needs and the error of each branch computed in f32
//! against the f64 reference, per tensor group at each sample point.

use superhelix_codegen::{
    helix, kernels, switch_scan, Float, GenerateOptions, Graph, HelixSymbols, Measure,
};

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    // --f32: the f32 measurement (each branch in f32 against the f64 reference)
    let f32_mode = args.iter().any(|a| a == "--f32");
    args.retain(|a| a != "--f32");
    if f32_mode && !args.iter().any(|a| a == "--generate") {
        let lists = if args.is_empty() {
            vec!["mass".to_string(), "force".into(), "rotary".into()]
        } else {
            args
        };
        for name in lists {
            scan_f32(&name);
        }
        return;
    }
    // --generate: generate each list with the checked-in options and print the result
    let generate = args.iter().any(|a| a == "--generate");
    args.retain(|a| a != "--generate");
    let lists = if args.is_empty() {
        vec!["mass".to_string(), "force".into(), "rotary".into()]
    } else {
        args
    };
    for name in lists {
        if generate {
            let mut g = Graph::new();
            let h = HelixSymbols::new(&mut g);
            let (base, prefix) = name.split_once(':').unwrap_or((name.as_str(), ""));
            let list = match base {
                "mass" => helix::m_related_integrands(&mut g, &h),
                "force" => helix::force_integrands(&mut g, &h),
                "rotary" => kernels::rotary_integrands(&mut g, &h),
                other => panic!("unknown list {other}"),
            };
            let list: Vec<_> = list
                .into_iter()
                .filter(|(n, _)| prefix.is_empty() || n.split('_').next() == Some(prefix))
                .collect();
            let float = if f32_mode { Float::F32 } else { Float::F64 };
            let c = superhelix_codegen::generate_function(
                &mut g,
                &h,
                "f",
                &list,
                &kernels::element_options_for(float),
            )
            .expect("generation");
            println!(
                "{name}: {} outputs, x* {} degree {}, agreement {:.2e}\n  Taylor {}\n  closed {}",
                list.len(),
                c.switch,
                c.series_order,
                c.agreement,
                c.ops_series,
                c.ops_closed
            );
            continue;
        }
        for measure in [Measure::Output, Measure::Group] {
            let mut g = Graph::new();
            let h = HelixSymbols::new(&mut g);
            let (base, prefix) = name.split_once(':').unwrap_or((name.as_str(), ""));
            let list = match base {
                "mass" => helix::m_related_integrands(&mut g, &h),
                "force" => helix::force_integrands(&mut g, &h),
                "rotary" => kernels::rotary_integrands(&mut g, &h),
                other => panic!("unknown list {other}"),
            };
            let list: Vec<_> = list
                .into_iter()
                .filter(|(n, _)| prefix.is_empty() || n.split('_').next() == Some(prefix))
                .collect();
            let mut opts = GenerateOptions::default();
            opts.switch.measure = measure;
            opts.switch.candidates = vec![
                0.3, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5, 2.75, 3.0, 3.5, 4.0, 5.0,
            ];
            println!("{name} ({} outputs), measure {measure:?}", list.len());
            let rows = switch_scan(&mut g, &h, &list, &opts).expect("scan");
            for r in rows {
                println!(
                    "  x* = {:5.2}  order {:2}  truncation {:.1e}  agreement {:.2e}  worst {}",
                    r.x, r.order, r.truncation, r.agreement, list[r.worst].0
                );
            }
        }
    }
}

/// The f32 scan of one list (see the module docs).
fn scan_f32(name: &str) {
    let mut g = Graph::new();
    let h = HelixSymbols::new(&mut g);
    let (base, prefix) = name.split_once(':').unwrap_or((name, ""));
    let list = match base {
        "mass" => helix::m_related_integrands(&mut g, &h),
        "force" => helix::force_integrands(&mut g, &h),
        "rotary" => kernels::rotary_integrands(&mut g, &h),
        other => panic!("unknown list {other}"),
    };
    let list: Vec<_> = list
        .into_iter()
        .filter(|(n, _)| prefix.is_empty() || n.split('_').next() == Some(prefix))
        .collect();
    let opts = kernels::element_options_for(Float::F32);
    println!(
        "{name} ({} outputs), f32: truncation target {:.1e}, error target {:.1e}",
        list.len(),
        opts.switch.truncation_target,
        opts.switch.agreement_target
    );
    let rows = switch_scan(&mut g, &h, &list, &opts).expect("scan");
    let u = Float::F32.unit_roundoff();
    for r in rows {
        println!(
            "  x* = {:5.2}  order {:2}  truncation {:.1e}  f32 error (× 2^-24): Taylor {:6.1}  \
             closed {:6.1}  worst {}",
            r.x,
            r.order,
            r.truncation,
            r.series_error / u,
            r.closed_error / u,
            list[r.worst].0
        );
    }
}
