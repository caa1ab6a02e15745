//! The element's local functions at one abscissa u
//! (`superhelix_runtime::model::element::ElementPoint`), generated in closed form by
//! [`crate::point`]: the file `generated/src/element_point.rs`.
//!
//! With `K = [d]×`, `W = |d|`, the helix coefficients `A = sin(uW)/W`,
//! `B = (1 − cos uW)/W²`, `C = (uW − sin uW)/W³` (the expressions of [`crate::helix`])
//! are radial functions ([`crate::point`]): `A = u a(z)`, `B = u² b(z)`, `C = u³ c(z)`,
//! `z = (uW)²`, and
//!
//! ```text
//! E(u) = I + A K + B K²
//! P(u) = u I + B K + C K²  =  A I + B K + C d dᵀ     (K² = d dᵀ − W² I, u − W² C = A)
//! ```
//!
//! The d-derivatives of `p = P e0` and `w_i = P e_i` are taken of the first form of P:
//! they need `B`, `C` and their first two derivatives `F_{k+1} = (1/W) ∂F_k/∂W`
//! (`= 2u² ∂F_k/∂z`), and E needs `A`, `B`: seven radial functions, each with a closed
//! form and a Taylor branch from the same expression; everything else is a polynomial
//! in `d` and `u` shared by both branches. The values `p`, `w_i` are taken of the second
//! form: in `u e_i + C K² e_i` a term of size u cancels to a result of size `u/(W u)`
//! when d ⊥ e_i (the digits lost grow like `W u`), while each term of the second form
//! is at most the size of the result. (The second form's derivatives have the opposite
//! defect: along d ∥ e0, `∂²p/∂d0²` is a difference of terms `W u` times larger than
//! the field.) Symmetry: `∂²p/∂d_i∂d_j` is generated for `i ≤ j` only, and `w_0 = p`,
//! `∂w_0/∂d_j = ∂p/∂d_j` are not generated twice.

use crate::emit::{literal, literal_in};
use crate::point::{generate_point, radial_family, PointCode, PointOptions, PointSpec};
use crate::{format, CodegenError, Float, Graph, HelixSymbols, Id, VERSION};
use proc_macro2::{Ident, Span, TokenStream};
use quote::quote;

/// Name of the generated function filling an `ElementPoint` (`element_point_into`,
/// with the allocating wrapper `element_point`).
pub const ELEMENT_POINT: &str = "element_point";

/// File (relative to `generated/src/`) holding [`ELEMENT_POINT`].
pub const ELEMENT_POINT_FILE: &str = "element_point.rs";

/// Name of the generated f32 function: [`ELEMENT_POINT`]'s outputs in f32, into a flat
/// array (see [`generate_element_point_f32`]).
pub const ELEMENT_POINT_F32: &str = "element_point_f32";

/// File (relative to `generated/src/`) holding [`ELEMENT_POINT_F32`].
pub const ELEMENT_POINT_F32_FILE: &str = "element_point_f32.rs";

/// Name of the generated function filling the fields of an `ElementPoint` that the
/// rotary-inertia quadrature reads (`element_rotary_point_into`): everything but
/// `d2p`.
pub const ELEMENT_ROTARY_POINT: &str = "element_rotary_point";

/// File (relative to `generated/src/`) holding [`ELEMENT_ROTARY_POINT`].
pub const ELEMENT_ROTARY_POINT_FILE: &str = "element_rotary_point.rs";

/// `d × v`.
fn cross(g: &mut Graph, d: [Id; 3], v: [Id; 3]) -> [Id; 3] {
    let c = |g: &mut Graph, a: usize, b: usize| {
        let x = g.mul2(d[a], v[b]);
        let y = g.mul2(d[b], v[a]);
        g.sub(x, y)
    };
    [c(g, 1, 2), c(g, 2, 0), c(g, 0, 1)]
}

/// `e_i`, `d × e_i` and `d × (d × e_i) = d d_i − |d|² e_i` (polynomial in d).
fn basis_terms(g: &mut Graph, d: [Id; 3], i: usize) -> [[Id; 3]; 3] {
    let mut e = [g.zero(); 3];
    e[i] = g.one();
    let k = cross(g, d, e);
    let k2 = cross(g, d, k);
    [e, k, k2]
}

/// `(s0 I + s1 K + s2 K²) e_i` with `K = [d]×`.
fn apply_k2(g: &mut Graph, d: [Id; 3], s: [Id; 3], i: usize) -> [Id; 3] {
    let [e, k, k2] = basis_terms(g, d, i);
    [0, 1, 2].map(|m| {
        let t = [g.mul2(s[0], e[m]), g.mul2(s[1], k[m]), g.mul2(s[2], k2[m])];
        g.add(&t)
    })
}

/// `(s0 I + s1 K + s2 d dᵀ) e_i`.
fn apply_ddt(g: &mut Graph, d: [Id; 3], s: [Id; 3], i: usize) -> [Id; 3] {
    let [e, k, _] = basis_terms(g, d, i);
    [0, 1, 2].map(|m| {
        let t = [
            g.mul2(s[0], e[m]),
            g.mul2(s[1], k[m]),
            g.mul(&[s[2], d[m], d[i]]),
        ];
        g.add(&t)
    })
}

/// The radial functions and outputs of `ElementPoint` (see the module docs). Output
/// names: `frame_rc`, `p_m`, `dp_i_m`, `d2p_ij_m` (i ≤ j), `w_i_m` and `dw_i_j_m` (i ≥ 1),
/// m the component; groups `frame`, `p`, `dp`, `d2p`, `w`, `dw` as the struct's fields
/// (all 27 entries of d2p, w and dw including `w_0 = p`, `dw_0 = dp`).
pub fn element_point_spec(g: &mut Graph, h: &HelixSymbols) -> PointSpec {
    point_spec(g, h, true)
}

/// [`element_point_spec`] without `d2p`: the outputs the rotary-inertia quadrature
/// reads (frame, p, dp, w, dw). Without the second d-derivatives, `b` and `c` need one
/// derivative each instead of two (five radial functions instead of seven).
pub fn element_rotary_point_spec(g: &mut Graph, h: &HelixSymbols) -> PointSpec {
    point_spec(g, h, false)
}

/// The spec of [`element_point_spec`], with `d2p` (and the radial derivatives it needs)
/// only when `with_d2p`.
fn point_spec(g: &mut Graph, h: &HelixSymbols, with_d2p: bool) -> PointSpec {
    let wu = g.mul2(h.w, h.u);
    let (s, c) = (g.sin(wu), g.cos(wu));
    let one = g.one();
    let iw = [1, 2, 3].map(|k| g.pow(h.w, -k));
    let a = g.mul2(s, iw[0]);
    let omc = g.sub(one, c);
    let b = g.mul2(omc, iw[1]);
    let xms = g.sub(wu, s);
    let cc = g.mul2(xms, iw[2]);
    // dw needs F_1 of b and c, d2p F_2
    let levels = if with_d2p { 3 } else { 2 };
    let ra = radial_family(g, h, "a", a, 1);
    let rb = radial_family(g, h, "b", b, levels);
    let rc = radial_family(g, h, "c", cc, levels);
    let [sa, sb, sc] = [ra[0].symbol, rb[0].symbol, rc[0].symbol];

    let d = h.d;
    let frame: Vec<[Id; 3]> = (0..3)
        .map(|col| apply_k2(g, d, [one, sa, sb], col))
        .collect();
    // values in the d dᵀ form, derivatives of the K² form (see the module docs)
    let w: Vec<[Id; 3]> = (0..3).map(|i| apply_ddt(g, d, [sa, sb, sc], i)).collect();
    let w_k2: Vec<[Id; 3]> = (0..3).map(|i| apply_k2(g, d, [h.u, sb, sc], i)).collect();
    let dw: Vec<Vec<[Id; 3]>> = (0..3)
        .map(|i| (0..3).map(|j| w_k2[i].map(|e| g.diff(e, d[j]))).collect())
        .collect();

    let mut outputs: Vec<(String, Id)> = Vec::new();
    let mut push = |name: String, id: Id| {
        outputs.push((name, id));
        outputs.len() - 1
    };
    let frame_idx: Vec<usize> = (0..9)
        .map(|k| push(format!("frame_{}{}", k / 3, k % 3), frame[k % 3][k / 3]))
        .collect();
    let p_idx: Vec<usize> = (0..3).map(|m| push(format!("p_{m}"), w[0][m])).collect();
    let dp_idx: Vec<usize> = (0..9)
        .map(|k| push(format!("dp_{}_{}", k / 3, k % 3), dw[0][k / 3][k % 3]))
        .collect();
    let mut d2p_at = [[[0usize; 3]; 3]; 3];
    let d2p_rows = if with_d2p { 3 } else { 0 };
    for i in 0..d2p_rows {
        for j in i..3 {
            for m in 0..3 {
                let e = g.diff(dw[0][i][m], d[j]);
                let k = push(format!("d2p_{i}{j}_{m}"), e);
                d2p_at[i][j][m] = k;
                d2p_at[j][i][m] = k;
            }
        }
    }
    let mut w_idx = p_idx.clone();
    let mut dw_idx = dp_idx.clone();
    for i in 1..3 {
        for m in 0..3 {
            w_idx.push(push(format!("w_{i}_{m}"), w[i][m]));
        }
    }
    for i in 1..3 {
        for j in 0..3 {
            for m in 0..3 {
                dw_idx.push(push(format!("dw_{i}_{j}_{m}"), dw[i][j][m]));
            }
        }
    }
    let mut radial = ra;
    radial.extend(rb);
    radial.extend(rc);
    let mut groups = vec![
        ("frame".into(), frame_idx),
        ("p".into(), p_idx),
        ("dp".into(), dp_idx),
    ];
    if with_d2p {
        let d2p_idx: Vec<usize> = d2p_at.iter().flatten().flatten().copied().collect();
        groups.push(("d2p".into(), d2p_idx));
    }
    groups.push(("w".into(), w_idx));
    groups.push(("dw".into(), dw_idx));
    PointSpec {
        radial,
        outputs,
        groups,
    }
}

fn ident(s: &str) -> Ident {
    Ident::new(s, Span::call_site())
}

/// `Vector3::new(<prefix>0, <prefix>1, <prefix>2)`.
fn vec3(prefix: &str) -> TokenStream {
    let [a, b, c] = [0, 1, 2].map(|m| ident(&format!("{prefix}{m}")));
    quote!(Vector3::new(#a, #b, #c))
}

/// The fields of `ElementPoint` as expressions of the output identifiers of
/// [`point_spec`]: frame, p, dp, d2p, w, dw (d2p only meaningful with d2p outputs).
struct Fields {
    frame: Vec<Ident>,
    p: TokenStream,
    dp: Vec<TokenStream>,
    d2p: Vec<TokenStream>,
    w: Vec<TokenStream>,
    dw: Vec<TokenStream>,
}

fn fields() -> Fields {
    let frame: Vec<Ident> = (0..9)
        .map(|k| ident(&format!("frame_{}{}", k / 3, k % 3)))
        .collect();
    let p = vec3("p_");
    let dp: Vec<TokenStream> = (0..3).map(|i| vec3(&format!("dp_{i}_"))).collect();
    let d2p: Vec<TokenStream> = (0..3)
        .map(|i| {
            let row: Vec<TokenStream> = (0..3)
                .map(|j| vec3(&format!("d2p_{}{}_", i.min(j), i.max(j))))
                .collect();
            quote!([#(#row),*])
        })
        .collect();
    let w: Vec<TokenStream> = std::iter::once(p.clone())
        .chain((1..3).map(|i| vec3(&format!("w_{i}_"))))
        .collect();
    let dw: Vec<TokenStream> = std::iter::once(quote!([#(#dp),*]))
        .chain((1..3).map(|i| {
            let row: Vec<TokenStream> = (0..3).map(|j| vec3(&format!("dw_{i}_{j}_"))).collect();
            quote!([#(#row),*])
        }))
        .collect();
    Fields {
        frame,
        p,
        dp,
        d2p,
        w,
        dw,
    }
}

/// `name: degree` of every radial function.
fn orders(code: &PointCode) -> Vec<String> {
    code.radial_names
        .iter()
        .zip(&code.series_orders)
        .map(|(n, o)| format!("{n}: {o}"))
        .collect()
}

/// The file header: `what` (the function's line, after the version line), `radial`
/// (what the radial functions are), `groups` (the fields the agreement is measured on),
/// then the switch, agreement and op counts of `code`.
fn header(what: &str, radial: &str, groups: &str, code: &PointCode) -> String {
    let n = code.radial_names.len();
    format!(
        "// @generated by superhelix-codegen {VERSION}\n\
         // {what}\n\
         // {n} radial functions of z = (W u)^2 ({radial}), Taylor degrees in W u: {}\n\
         // switch W*u = {} (Taylor below); branch agreement {:.2e}, truncation {:.2e}: largest \
         |closed - Taylor| (resp. |Taylor - Taylor of degree + 8|) at the switch over {} sample \
         points, relative to the largest |entry| of the same field ({groups}) \
         at the same point\n\
         // ops before CSE (as trees, radial functions inlined): Taylor path {}; closed path {}\n\
         // ops after CSE (as emitted): Taylor path {}; closed path {}\n\
         //   prologue: {}\n\
         //   Taylor radial functions: {}\n\
         //   closed radial functions: {}\n\
         //   shared polynomial part: {}\n",
        orders(code).join(", "),
        code.switch,
        code.agreement,
        code.truncation,
        code.agreement_samples,
        code.ops_before_series,
        code.ops_before_closed,
        code.ops_series_path(),
        code.ops_closed_path(),
        code.ops_prologue,
        code.ops_series,
        code.ops_closed,
        code.ops_shared,
    )
}

/// The items of a generated point file: the imports, the switch constant `switch` and
/// `fn_name(d, u, out)`, which binds d's components, evaluates `body` and writes the
/// outputs with `fill`.
fn point_function(
    switch: &Ident,
    fn_name: &Ident,
    doc_switch: &str,
    doc: &str,
    xs: &TokenStream,
    body: &TokenStream,
    fill: TokenStream,
) -> TokenStream {
    let function = crate::emit::multiversioned(
        fn_name,
        doc,
        quote!(d: &Vector3<f64>, u: f64, out: &mut ElementPoint),
        quote!(d, u, out),
        quote! {
            let d0 = d.x;
            let d1 = d.y;
            let d2 = d.z;
            #body
            #fill
        },
    );
    quote! {
        use nalgebra::{Matrix3, Vector3};
        use superhelix_kernels::element::ElementPoint;
        #[allow(unused_imports)]
        use superhelix_kernels::math::Elementary as _;

        #[doc = #doc_switch]
        pub const #switch: f64 = #xs;

        #function
    }
}

/// Generate `ElementPoint` in closed form: the measured code and the formatted file.
pub fn generate_element_point() -> Result<(PointCode, String), CodegenError> {
    let mut g = Graph::new();
    let h = HelixSymbols::new(&mut g);
    let spec = element_point_spec(&mut g, &h);
    let switch = ident("ELEMENT_POINT_SWITCH");
    let code = generate_point(&mut g, &h, &spec, &switch, &PointOptions::default())?;
    let Fields {
        frame,
        p,
        dp,
        d2p,
        w,
        dw,
    } = fields();

    let xs = literal(code.switch);
    let body = &code.body;
    let doc_switch =
        " Switch on `W u` of [`element_point_into`]: the Taylor branch is used below it."
            .to_string();
    let doc = format!(
        " The element's local functions at abscissa `u` for Darboux vector `d` (see \
         `ElementPoint`), in closed form: E(u), p(u), ∂p/∂d_i, ∂²p/∂d_i∂d_j, w_i(u) = P(u) e_i, \
         ∂w_i/∂d_j.\n\n The radial functions of `z = (W u)²` are taken from their Taylor \
         series for `W u < {}` (degrees in `W u`: {}), from their closed forms above; the \
         polynomial part in `d` and `u` is common to both. The branches agree to {:.1e} at \
         the switch, relative to the largest entry of each field. Allocation-free and \
         panic-free.",
        code.switch,
        orders(&code).join(", "),
        code.agreement
    );
    let fill = quote! {
        *out = ElementPoint {
            frame: Matrix3::new(#(#frame),*),
            p: #p,
            dp: [#(#dp),*],
            d2p: [#(#d2p),*],
            w: [#(#w),*],
            dw: [#(#dw),*],
        };
    };
    let function = point_function(
        &switch,
        &ident("element_point_into"),
        &doc_switch,
        &doc,
        &xs,
        body,
        fill,
    );
    let tokens = quote! {
        #function

        /// [`element_point_into`] into a new value.
        pub fn element_point(d: &Vector3<f64>, u: f64) -> ElementPoint {
            let mut out = ElementPoint::default();
            element_point_into(d, u, &mut out);
            out
        }
    };
    let header = header(
        &format!(
            "{ELEMENT_POINT}: ElementPoint at one abscissa u, 63 distinct outputs (frame 9, p 3, \
             dp 9, d2p 18 of 27 by symmetry, w 6 and dw 18 besides w_0 = p, dw_0 = dp)"
        ),
        "a0 = u a(z); b, c = u^2 b(z), u^3 c(z) and two derivatives each",
        "frame, p, dp, d2p, w, dw",
        &code,
    );
    let text = format(&format!("{header}{tokens}\n"));
    Ok((code, text))
}

/// The options of [`generate_element_point_f32`]: [`PointOptions::default`] for f32
/// ([`PointOptions::for_f32`]).
pub fn element_point_f32_options() -> PointOptions {
    PointOptions::default().for_f32()
}

/// The spec and the measured code of [`ELEMENT_POINT_F32`] in `g` (what
/// [`generate_element_point_f32`] writes; its radial functions' branches are
/// `code.series` and `code.closed`, functions of `u` and the symbols `wu` = W u and
/// `zu` = (W u)², and its outputs `spec.outputs`, functions of `d`, `u` and the radial
/// symbols).
pub fn element_point_f32_code(
    g: &mut Graph,
    h: &HelixSymbols,
) -> Result<(PointSpec, PointCode), CodegenError> {
    let spec = element_point_spec(g, h);
    let switch = ident("ELEMENT_POINT_F32_SWITCH");
    let code = generate_point(g, h, &spec, &switch, &element_point_f32_options())?;
    Ok((spec, code))
}

/// Generate [`ELEMENT_POINT_F32`] in closed form: the outputs of [`element_point_spec`]
/// in f32, `element_point_f32(d: &[f32; 3], u: f32, out: &mut [f32; 63])` with the
/// names in `ELEMENT_POINT_F32_OUTPUTS` (`frame_rc` = E(u)_rc, `p_m`, `dp_i_m` =
/// (∂p/∂d_i)_m, `d2p_ij_m` for i ≤ j, `w_i_m` and `dw_i_j_m` for i = 1, 2; `w_0 = p`,
/// `dw_0_j = dp_j`), the switch and Taylor degrees chosen for f32
/// ([`element_point_f32_options`]). Scalar, one plain function (no AVX2 copy). Returns
/// the measured code and the formatted file.
pub fn generate_element_point_f32() -> Result<(PointCode, String), CodegenError> {
    let mut g = Graph::new();
    let h = HelixSymbols::new(&mut g);
    let (spec, code) = element_point_f32_code(&mut g, &h)?;
    let switch = ident("ELEMENT_POINT_F32_SWITCH");
    let opts = element_point_f32_options();
    let xs = literal_in(code.switch, Float::F32);
    let body = &code.body;
    let names: Vec<&str> = spec.outputs.iter().map(|o| o.0.as_str()).collect();
    let outputs: Vec<Ident> = names.iter().map(|n| ident(n)).collect();
    let slots: Vec<proc_macro2::Literal> = (0..names.len())
        .map(proc_macro2::Literal::usize_unsuffixed)
        .collect();
    let k = proc_macro2::Literal::usize_unsuffixed(names.len());
    let selection = if code.target_met {
        format!(
            "the first candidate where the outputs through either branch (through the closed \
             one also at the next candidate) are within {:.1e} of the f64 values",
            opts.agreement_target
        )
    } else {
        format!(
            "no candidate has the outputs through both branches within {:.1e} of the f64 values: \
             the candidate of smallest error ({:.1e}, through the closed branch also at the next \
             candidate)",
            opts.agreement_target, code.agreement
        )
    };
    let doc = format!(
        " The element's local functions at abscissa `u` for Darboux vector `d`, in f32: the \
         fields of `ElementPoint` (E(u), p(u), ∂p/∂d_i, ∂²p/∂d_i∂d_j, w_i(u) = P(u) e_i, \
         ∂w_i/∂d_j) as `out[k]` named `ELEMENT_POINT_F32_OUTPUTS[k]`: `frame_rc` = E_rc, `p_m`, \
         `dp_i_m` = (∂p/∂d_i)_m, `d2p_ij_m` for i ≤ j (symmetric), `w_i_m` and `dw_i_j_m` for \
         i = 1, 2 (`w_0 = p`, `∂w_0/∂d_j = ∂p/∂d_j`).\n\n The radial functions of `z = (W u)²` \
         are taken from their Taylor series for `W u < {}` (degrees in `W u`: {}), from their \
         closed forms above. The switch is {selection}. At the switch, computed in f32, the \
         outputs through the Taylor branch err by {:.1e} and through the closed one by {:.1e} \
         against the f64 values, relative to the largest entry of each field at the same point. \
         Allocation-free and panic-free.",
        code.switch,
        orders(&code).join(", "),
        code.series_error,
        code.closed_error
    );
    let doc_switch =
        " Switch on `W u` of [`element_point_f32`]: the Taylor branch is used below it.";
    let doc_outputs = " Names of the outputs of [`element_point_f32`], in order.";
    let attrs = crate::emit::generated_attrs();
    let tokens = quote! {
        #[allow(unused_imports)]
        use superhelix_kernels::math::Elementary as _;

        #[doc = #doc_outputs]
        pub const ELEMENT_POINT_F32_OUTPUTS: [&str; #k] = [#(#names),*];

        #[doc = #doc_switch]
        pub const #switch: f32 = #xs;

        #[doc = #doc]
        #attrs
        pub fn element_point_f32(d: &[f32; 3], u: f32, out: &mut [f32; #k]) {
            let d0 = d[0];
            let d1 = d[1];
            let d2 = d[2];
            #body
            #(out[#slots] = #outputs;)*
        }
    };
    let n = code.radial_names.len();
    let header = format!(
        "// @generated by superhelix-codegen {VERSION}\n\
         // {ELEMENT_POINT_F32}: ElementPoint at one abscissa u in f32, 63 distinct outputs (frame 9, \
         p 3, dp 9, d2p 18 of 27 by symmetry, w 6 and dw 18 besides w_0 = p, dw_0 = dp) into a flat \
         array\n\
         // {n} radial functions of z = (W u)^2 (a0 = u a(z); b, c = u^2 b(z), u^3 c(z) and two \
         derivatives each), Taylor degrees in W u: {}\n\
         // switch W*u = {} (Taylor below): {selection}\n\
         // error in f32 against f64 at the switch: Taylor branch {:.2e}, closed branch {:.2e}; \
         truncation {:.2e}: largest |f32 - f64| over {} sample points (inputs rounded to f32), \
         relative to the largest |f64 entry| of the same field (frame, p, dp, d2p, w, dw) at the \
         same point\n\
         // ops after CSE (as emitted): Taylor path {}; closed path {}\n",
        orders(&code).join(", "),
        code.switch,
        code.series_error,
        code.closed_error,
        code.truncation,
        code.agreement_samples,
        code.ops_series_path(),
        code.ops_closed_path(),
    );
    let text = format(&format!("{header}{tokens}\n"));
    Ok((code, text))
}

/// Generate the rotary point (`element_rotary_point_into`: `ElementPoint` without
/// `d2p`, see [`element_rotary_point_spec`]) in closed form: the measured code and the
/// formatted file. Its switch is searched among `switch_candidates` (in increasing
/// order; [`PointOptions::default`]'s when `None`).
pub fn generate_element_rotary_point(
    switch_candidates: Option<Vec<f64>>,
) -> Result<(PointCode, String), CodegenError> {
    let mut g = Graph::new();
    let h = HelixSymbols::new(&mut g);
    let spec = element_rotary_point_spec(&mut g, &h);
    let switch = ident("ELEMENT_ROTARY_POINT_SWITCH");
    let mut opts = PointOptions::default();
    if let Some(c) = switch_candidates {
        opts.candidates = c;
    }
    let code = generate_point(&mut g, &h, &spec, &switch, &opts)?;
    let Fields {
        frame,
        p,
        dp,
        w,
        dw,
        ..
    } = fields();

    let xs = literal(code.switch);
    let body = &code.body;
    let doc_switch =
        " Switch on `W u` of [`element_rotary_point_into`]: the Taylor branch is used below it."
            .to_string();
    let doc = format!(
        " The fields of `ElementPoint` that the rotary-inertia quadrature reads, at abscissa \
         `u` for Darboux vector `d`, in closed form: E(u), p(u), ∂p/∂d_i, w_i(u) = P(u) e_i, \
         ∂w_i/∂d_j, the same functions as `element_point_into` without the second \
         derivatives. `out.d2p` is not written: it keeps whatever it held (do not read it \
         after this call).\n\n The radial functions of `z = (W u)²` are taken from their \
         Taylor series for `W u < {}` (degrees in `W u`: {}), from their closed forms above; \
         the polynomial part in `d` and `u` is common to both. The branches agree to {:.1e} \
         at the switch, relative to the largest entry of each field. Allocation-free and \
         panic-free.",
        code.switch,
        orders(&code).join(", "),
        code.agreement
    );
    let fill = quote! {
        out.frame = Matrix3::new(#(#frame),*);
        out.p = #p;
        out.dp = [#(#dp),*];
        out.w = [#(#w),*];
        out.dw = [#(#dw),*];
    };
    let one_point = point_function(
        &switch,
        &ident("element_rotary_point_into"),
        &doc_switch,
        &doc,
        &xs,
        body,
        fill,
    );
    let lanes = rotary_points_function(&code);
    let tokens = quote! {
        #one_point

        #lanes
    };
    let header = header(
        &format!(
            "{ELEMENT_ROTARY_POINT}: ElementPoint without d2p (what the rotary quadrature reads) \
             at one abscissa u, and at up to four at once on F4 lanes (element_rotary_points_into), \
             45 distinct outputs (frame 9, p 3, dp 9, w 6 and dw 18 besides w_0 = p, dw_0 = dp)"
        ),
        "a0 = u a(z); b, c = u^2 b(z), u^3 c(z) and one derivative each",
        "frame, p, dp, w, dw",
        &code,
    );
    let text = format(&format!("{header}{tokens}\n"));
    Ok((code, text))
}

/// `element_rotary_points_into(d, u, out)`: [`generate_element_rotary_point`]'s
/// function at up to four abscissae `u[k]` of one element, into lane k of a
/// `RotaryPoints`. Each lane's radial functions are taken one lane at a time (the switch
/// is per abscissa, and the closed branch calls `sin_cos`), with the one-point
/// function's statements; the polynomial part then runs once on four lanes (`F4`, with
/// `d` as plain `f64`; u enters it only through the radial functions, so it is not
/// bound as lanes: a part that read it would not compile), its statements unchanged:
/// with `F4`'s operations acting lane by lane on the same operands in the same order,
/// lane k is the one-point function at `u[k]` bit for bit.
fn rotary_points_function(code: &PointCode) -> TokenStream {
    let radial: Vec<Ident> = code.radial_names.iter().map(|n| ident(n)).collect();
    let lit = proc_macro2::Literal::usize_unsuffixed;
    let slots: Vec<proc_macro2::Literal> = (0..radial.len()).map(lit).collect();
    let nr = lit(radial.len());
    let (radial_body, shared_body) = (&code.radial_body, &code.shared_body);
    let mut stores: Vec<TokenStream> = Vec::new();
    // the same stores for W lanes (`element_rotary_points_lanes`)
    let mut lane_stores: Vec<TokenStream> = Vec::new();
    for c in 0..3 {
        for r in 0..3 {
            let v = ident(&format!("frame_{r}{c}"));
            let (c, r) = (lit(c), lit(r));
            stores.push(quote!(out.frame[#c][#r] = F4::from(#v);));
            lane_stores.push(quote!(out.frame[#c][#r] = Lanes::<f64, W>::from(#v);));
        }
    }
    // w_0 = p and ∂w_0/∂d_j = ∂p/∂d_j are generated once, under p's names
    for i in 0..3 {
        for m in 0..3 {
            let v = if i == 0 {
                ident(&format!("p_{m}"))
            } else {
                ident(&format!("w_{i}_{m}"))
            };
            let (i, m) = (lit(i), lit(m));
            stores.push(quote!(out.w[#i][#m] = F4::from(#v);));
            lane_stores.push(quote!(out.w[#i][#m] = Lanes::<f64, W>::from(#v);));
        }
    }
    for i in 0..3 {
        for j in 0..3 {
            for m in 0..3 {
                let v = if i == 0 {
                    ident(&format!("dp_{j}_{m}"))
                } else {
                    ident(&format!("dw_{i}_{j}_{m}"))
                };
                let (i, j, m) = (lit(i), lit(j), lit(m));
                stores.push(quote!(out.dw[#i][#j][#m] = F4::from(#v);));
                lane_stores.push(quote!(out.dw[#i][#j][#m] = Lanes::<f64, W>::from(#v);));
            }
        }
    }
    let doc = " [`element_rotary_point_into`] at up to four abscissae `u[k]` of one element \
               (any beyond the fourth are ignored), into lane k of `out`: the same bits, lane by \
               lane, as the one-point function. Each lane's radial functions are taken on their \
               own (the switch is per abscissa); the polynomial part runs once on four lanes. The \
               lanes beyond `u.len()` hold finite values of no meaning. Allocation-free and \
               panic-free.";
    let function = crate::emit::multiversioned(
        &ident("element_rotary_points_into"),
        doc,
        quote!(d: &Vector3<f64>, u: &[f64], out: &mut RotaryPoints),
        quote!(d, u, out),
        quote! {
            let d0 = d.x;
            let d1 = d.y;
            let d2 = d.z;
            let mut lanes = [[0.0f64; 4]; #nr];
            for (k, &u) in u.iter().take(4).enumerate() {
                #radial_body
                #(lanes[#slots][k] = #radial;)*
            }
            #(let #radial = F4(lanes[#slots]);)*
            #shared_body
            #(#stores)*
        },
    );
    // the same at one abscissa of each of W elements (element k of W strands): each
    // lane's radial functions on their own, the polynomial part once on the W lanes with
    // d as lanes too
    let doc_lanes =
        " [`element_rotary_point_into`] of W elements at once, lane k at Darboux vector \
                     `(d[0], d[1], d[2])` and abscissa `u` of lane k (element k of W strands), \
                     into lane k of `out`: the same bits, lane by lane, as the one-point \
                     function. Each lane's radial functions are taken on their own (the switch \
                     is per lane); the polynomial part runs once on the W lanes. Inlined into \
                     its caller, which chooses the vector width by compiling it inside a \
                     `#[target_feature]` function. Allocation-free and panic-free.";
    let attrs = crate::emit::generated_attrs();
    quote! {
        use superhelix_kernels::element::{LaneRotaryPoints, RotaryPoints};
        use superhelix_kernels::lane::Lanes;
        use superhelix_kernels::lanes::F4;

        #function

        #[doc = #doc_lanes]
        #attrs
        #[inline(always)]
        pub fn element_rotary_points_lanes<const W: usize>(
            d: &[Lanes<f64, W>; 3],
            u: Lanes<f64, W>,
            out: &mut LaneRotaryPoints<W>,
        ) {
            let mut lanes = [[0.0f64; W]; #nr];
            for k in 0..W {
                let d0 = d[0].0[k];
                let d1 = d[1].0[k];
                let d2 = d[2].0[k];
                let u = u.0[k];
                #radial_body
                #(lanes[#slots][k] = #radial;)*
            }
            let d0 = d[0];
            let d1 = d[1];
            let d2 = d[2];
            #(let #radial = Lanes(lanes[#slots]);)*
            #shared_body
            #(#lane_stores)*
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::helix;

    /// The shared part with the radial symbols bound to their closed forms equals the
    /// d-derivatives of the engine's own helix builders ([`helix::position`],
    /// [`helix::rotation_column`], [`helix::frame`]) differentiated directly.
    #[test]
    fn shared_part_matches_direct_differentiation_of_the_helix() {
        let mut g = Graph::new();
        let h = HelixSymbols::new(&mut g);
        let spec = element_point_spec(&mut g, &h);
        let e = helix::frame(&mut g, &h, h.u);
        let w: Vec<[Id; 3]> = (0..3)
            .map(|i| helix::rotation_column(&mut g, &h, h.u, i))
            .collect();
        let mut direct: Vec<(String, Id)> = Vec::new();
        for r in 0..3 {
            for c in 0..3 {
                direct.push((format!("frame_{r}{c}"), e[r][c]));
            }
        }
        for i in 0..3 {
            for m in 0..3 {
                direct.push((format!("w_{i}_{m}"), w[i][m]));
                for j in 0..3 {
                    let dw = g.diff(w[i][m], h.d[j]);
                    direct.push((format!("dw_{i}_{j}_{m}"), dw));
                    if i == 0 {
                        for k in j..3 {
                            let d2 = g.diff(dw, h.d[k]);
                            direct.push((format!("d2p_{j}{k}_{m}"), d2));
                        }
                    }
                }
            }
        }
        for (d, u) in [
            ([3.0, -7.0, 11.0], 0.2),
            ([0.4, 0.1, -0.2], 1.3),
            ([0.0, 2.0, 0.0], 0.5),
        ] {
            let mut b = h.bindings(d, 0.0, u);
            let rv: Vec<f64> = spec.radial.iter().map(|r| g.eval(r.expr, &b)).collect();
            b.extend(spec.radial.iter().map(|r| r.symbol).zip(rv));
            for (name, id) in &spec.outputs {
                // p = w_0, dp = dw_0
                let key = if let Some(rest) = name.strip_prefix("dp_") {
                    format!("dw_0_{rest}")
                } else if let Some(rest) = name.strip_prefix("p_") {
                    format!("w_0_{rest}")
                } else {
                    name.clone()
                };
                let (_, reference) = direct
                    .iter()
                    .find(|(n, _)| *n == key)
                    .unwrap_or_else(|| panic!("no direct output {key}"));
                let (a, r) = (g.eval(*id, &b), g.eval(*reference, &b));
                assert!(
                    (a - r).abs() <= 1e-12 * r.abs().max(1.0),
                    "{name}: {a} vs {r}"
                );
            }
        }
    }
}
