//! The lists of integrands the generated kernels use, and the files written from them
//! into `generated/src/` (see the README, "Regenerating kernels").

use crate::{
    format, generate_function, helix, CodegenError, GenerateOptions, GeneratedCode, Graph,
    HelixSymbols, Id,
};

/// Name of the generated element-moment function.
pub const ELEMENT_MOMENTS: &str = "element_moments";

/// File (relative to `generated/src/`) holding [`ELEMENT_MOMENTS`].
pub const ELEMENT_MOMENTS_FILE: &str = "element_moments.rs";

/// Integrands of the element moments of the moment-based assembly of M and the
/// first-moment Jacobian (`runtime/src/moments.rs`): the M-related list of
/// [`helix::m_related_integrands`], then for each column a of E(u) the rotary-inertia
/// basis `ee_a_rc` = ∫ E_ra E_ca, `eew_a_j_r` = ∫ E_ra (E_a·w_j), `eww_a_ij` =
/// ∫ (E_a·w_i)(E_a·w_j), from which ∫ E D Eᵀ, ∫ E D Eᵀ w_j and ∫ w_iᵀ E D Eᵀ w_j follow
/// for any diagonal D.
pub fn element_moment_integrands(g: &mut Graph, h: &HelixSymbols) -> Vec<(String, Id)> {
    let mut out = helix::m_related_integrands(g, h);
    let e = helix::frame(g, h, h.u);
    let w: [[Id; 3]; 3] = [0, 1, 2].map(|j| helix::rotation_column(g, h, h.u, j));
    for a in 0..3 {
        let col = [e[0][a], e[1][a], e[2][a]];
        for r in 0..3 {
            for c in r..3 {
                out.push((format!("ee_{a}_{r}{c}"), g.mul2(col[r], col[c])));
            }
        }
        let ew: [Id; 3] = w.map(|wj| {
            let t: Vec<Id> = (0..3).map(|m| g.mul2(col[m], wj[m])).collect();
            g.add(&t)
        });
        for (j, ewj) in ew.iter().enumerate() {
            for (r, cr) in col.iter().enumerate() {
                out.push((format!("eew_{a}_{j}_{r}"), g.mul2(*cr, *ewj)));
            }
        }
        for i in 0..3 {
            for j in i..3 {
                out.push((format!("eww_{a}_{i}{j}"), g.mul2(ew[i], ew[j])));
            }
        }
    }
    out
}

/// Generate the element-moment function.
pub fn generate_element_moments() -> Result<GeneratedCode, CodegenError> {
    let mut g = Graph::new();
    let h = HelixSymbols::new(&mut g);
    let list = element_moment_integrands(&mut g, &h);
    generate_function(
        &mut g,
        &h,
        ELEMENT_MOMENTS,
        &list,
        &GenerateOptions::default(),
    )
}

/// Every checked-in generated file: (path relative to `generated/src/`, formatted text).
pub fn checked_in_files() -> Result<Vec<(String, String)>, CodegenError> {
    let moments = generate_element_moments()?;
    Ok(vec![
        (ELEMENT_MOMENTS_FILE.to_string(), format(&moments.code)),
        (
            crate::sizes::SIZES_FILE.to_string(),
            crate::sizes::sizes_file(),
        ),
    ])
}
