//! Generating in f32 ([`Float::F32`]): the emitted function computes in f32, its
//! switch is measured in f32 against f64, and the f64 output does not change.

use superhelix_codegen::{
    format, generate_function, helix, Float, GenerateOptions, Graph, HelixSymbols, SwitchOptions,
};

/// A small list: p_1, p_1 p_2 (products of the centreline's components).
fn list(g: &mut Graph, h: &HelixSymbols) -> Vec<(String, superhelix_codegen::Id)> {
    let p = helix::position(g, h, h.u);
    let pp = g.mul2(p[1], p[2]);
    vec![("p1".to_string(), p[1]), ("p1p2".to_string(), pp)]
}

fn generate(float: Float) -> superhelix_codegen::GeneratedCode {
    let mut g = Graph::new();
    let h = HelixSymbols::new(&mut g);
    let l = list(&mut g, &h);
    let mut opts = GenerateOptions {
        float,
        ..GenerateOptions::default()
    };
    if float == Float::F32 {
        opts.switch = SwitchOptions::default().for_f32();
    }
    generate_function(&mut g, &h, "small", &l, &opts).expect("generation")
}

#[test]
fn f32_generation_writes_an_f32_function_measured_against_f64() {
    let c = generate(Float::F32);
    let file: syn::File = syn::parse_str(&c.code).expect("raw token output parses");
    let text = format(&c.code);
    syn::parse_str::<syn::File>(&text).expect("formatted output parses");
    assert!(
        text.contains("pub fn small(d: &[f32; 3], l: f32, out: &mut [f32; 2])"),
        "{text}"
    );
    assert!(text.contains("pub const SMALL_SWITCH: f32 ="));
    // one plain function: no four-lane copy, no AVX2 copy, and no f64 value (the
    // comments and docs name f64 as the reference)
    assert!(!text.contains("F4") && !text.contains("avx2"));
    assert!(!text.contains(": f64") && !text.contains("[f64"));
    let fns = file
        .items
        .iter()
        .filter(|i| matches!(i, syn::Item::Fn(_)))
        .count();
    assert_eq!(fns, 1);
    // measured in f32 against f64: errors of a few f32 round-offs, not f64's
    let u = Float::F32.unit_roundoff();
    assert!(c.series_error.is_finite() && c.closed_error.is_finite());
    assert!(
        c.agreement > 1e3 * Float::F64.unit_roundoff(),
        "{}",
        c.agreement
    );
    assert!(c.agreement <= 64.0 * u, "{}", c.agreement);
    assert!(c.truncation <= u);
    assert_eq!(c.float, Float::F32);
}

#[test]
fn f32_switch_and_degree_differ_from_f64_and_f64_is_unchanged() {
    let a = generate(Float::F64);
    let b = generate(Float::F32);
    // f64: the same text as with the options before the float option existed
    assert!(format(&a.code).contains("d: &[f64; 3], l: f64"));
    assert!(a.series_error.is_nan() && a.target_met);
    // f32 needs a lower degree: its truncation target is 2^-24, not 1e-15
    assert!(
        b.series_order < a.series_order,
        "f32 degree {} vs f64 {}",
        b.series_order,
        a.series_order
    );
}
