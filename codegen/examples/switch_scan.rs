//! Print, for each list of generated integrands and each candidate switch `x*`, the
//! Taylor order needed there and the measured agreement of the branches, per output and
//! per tensor group.
//!
//! `cargo run -p superhelix-codegen --release --example switch_scan [-- LIST...]`
//! (LIST: mass, force, rotary, or LIST:GROUP for the outputs of one group, e.g.
//! force:dpd2p; all by default)

use superhelix_codegen::{
    helix, kernels, switch_scan, GenerateOptions, Graph, HelixSymbols, Measure,
};

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
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
            let c = superhelix_codegen::generate_function(
                &mut g,
                &h,
                "f",
                &list,
                &kernels::element_options(),
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
