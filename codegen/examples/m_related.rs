//! Generate the M-related element integrals (design page "Efficient assembly") and
//! print the statistics; with a path argument, also write the formatted code there.
//!
//! `cargo run -p superhelix-codegen --release --example m_related [-- out.rs]`

use superhelix_codegen::{format, generate_function, helix, GenerateOptions, Graph, HelixSymbols};

fn main() {
    let mut g = Graph::new();
    let h = HelixSymbols::new(&mut g);
    let list = helix::m_related_integrands(&mut g, &h);
    let t = std::time::Instant::now();
    let out = generate_function(
        &mut g,
        &h,
        "m_related_integrals",
        &list,
        &GenerateOptions::default(),
    )
    .expect("generation");
    eprintln!(
        "generated in {:.2?}; graph has {} nodes",
        t.elapsed(),
        g.len()
    );
    eprintln!(
        "switch W*l = {}, Taylor degree {}, agreement {:.2e}, truncation {:.2e}",
        out.switch, out.series_order, out.agreement, out.truncation
    );
    eprintln!("ops before CSE: {}", out.ops_before);
    eprintln!("ops after CSE:  {}", out.ops_after);
    eprintln!("  Taylor branch: {}", out.ops_series);
    eprintln!("  closed branch: {}", out.ops_closed);
    if let Some(path) = std::env::args().nth(1) {
        std::fs::write(&path, format(&out.code)).expect("write");
        eprintln!("wrote {path}");
    }
}
