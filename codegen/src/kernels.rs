//! The lists of integrands the generated kernels use, and the files written from them
//! into `generated/src/` (see the README, "Regenerating kernels").

use crate::{
    format, generate_function, helix, CodegenError, Float, GenerateOptions, GeneratedCode, Graph,
    HelixSymbols, Id, Measure,
};

/// A generated function: its name, the file (relative to `generated/src/`) that holds
/// it, and its list of integrands.
#[derive(Clone, Copy, Debug)]
pub struct Kernel {
    /// Function name (also the module and file stem).
    pub name: &'static str,
    /// Integrand list.
    pub list: fn(&mut Graph, &HelixSymbols) -> Vec<(String, Id)>,
}

impl Kernel {
    /// File of the function, relative to `generated/src/`.
    pub fn file(&self) -> String {
        format!("{}.rs", self.name)
    }

    /// Name of the function (and module) in `float`: the f64 name, with `_f32` appended
    /// for [`Float::F32`].
    pub fn name_in(&self, float: Float) -> String {
        match float {
            Float::F64 => self.name.to_string(),
            Float::F32 => format!("{}_f32", self.name),
        }
    }

    /// File of the function in `float`, relative to `generated/src/`.
    pub fn file_in(&self, float: Float) -> String {
        format!("{}.rs", self.name_in(float))
    }
}

/// The element-moment functions, one per part with its own switch and Taylor degree:
/// the centreline moments M needs ([`helix::m_related_integrands`]), the force-only
/// centreline moments ([`helix::force_integrands`]) and the rotary-inertia basis
/// ([`rotary_integrands`], whose products of frames double the frequency).
pub const ELEMENT_KERNELS: [Kernel; 3] = [
    Kernel {
        name: "centreline_mass",
        list: helix::m_related_integrands,
    },
    Kernel {
        name: "centreline_force",
        list: helix::force_integrands,
    },
    Kernel {
        name: "rotary_basis",
        list: rotary_integrands,
    },
];

/// Options every element-moment function is generated with: branch agreement measured
/// per tensor group ([`Measure::Group`]), the error the assembly sees (a moment enters
/// only through contractions of its whole tensor, so an entry's error matters at the
/// scale of the tensor's largest entry, not at that of an entry that is small at this
/// direction or W l); a candidate grid fine enough that each part gets the switch it
/// needs.
pub fn element_options() -> GenerateOptions {
    let mut o = GenerateOptions::default();
    o.switch.measure = Measure::Group;
    o.switch.candidates = vec![
        0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5, 2.75, 3.0, 3.25, 3.5, 4.0, 4.5, 5.0,
        6.0,
    ];
    o.switch.check_samples = 256;
    o.switch.confirm_next = true;
    o.switch.low_tier = true;
    o
}

/// [`element_options`] for code of type `float`: for [`Float::F32`], the f32 targets
/// ([`crate::SwitchOptions::for_f32`]: truncation 2^-24, error of either branch in f32
/// against the f64 reference 2^-20 at the switch), measured the same way otherwise.
pub fn element_options_for(float: Float) -> GenerateOptions {
    let mut o = element_options();
    o.float = float;
    if float == Float::F32 {
        o.switch = o.switch.for_f32();
    }
    o
}

/// The rotary-inertia basis: for each column a of E(u), `ee_a_rc` = ∫ E_ra E_ca,
/// `eew_a_j_r` = ∫ E_ra (E_a·w_j), `eww_a_ij` = ∫ (E_a·w_i)(E_a·w_j), from which
/// ∫ E D Eᵀ, ∫ E D Eᵀ w_j and ∫ w_iᵀ E D Eᵀ w_j follow for any diagonal D.
pub fn rotary_integrands(g: &mut Graph, h: &HelixSymbols) -> Vec<(String, Id)> {
    let mut out = Vec::new();
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

/// Generate one element-moment function.
pub fn generate(k: &Kernel) -> Result<GeneratedCode, CodegenError> {
    generate_in(k, Float::F64)
}

/// Generate one element-moment function in `float` (named [`Kernel::name_in`], with
/// [`element_options_for`]).
pub fn generate_in(k: &Kernel, float: Float) -> Result<GeneratedCode, CodegenError> {
    let mut g = Graph::new();
    let h = HelixSymbols::new(&mut g);
    let list = (k.list)(&mut g, &h);
    generate_function(
        &mut g,
        &h,
        &k.name_in(float),
        &list,
        &element_options_for(float),
    )
}

/// Every checked-in generated file: (path relative to `generated/src/`, formatted text):
/// the f64 kernels, `sizes.rs`, the f32 versions of the element moments and of the
/// element point (`*_f32.rs`), and the per-N modules of
/// [`CHECKED_IN_SIZES`](crate::sizes::CHECKED_IN_SIZES) in f64 and f32 with their
/// declaring file in [`FIXED_DIR`], written by [`crate::Kernels`] exactly as a build
/// script gets them.
pub fn checked_in_files() -> Result<Vec<(String, String)>, CodegenError> {
    let mut files = Vec::new();
    // per-element op counts (after CSE) of the cheapest and dearest branch, for sizes.rs
    let (mut moments_min, mut moments_max) = (0, 0);
    for k in ELEMENT_KERNELS.iter() {
        let code = generate(k)?;
        let mut branches = vec![code.ops_closed.total(), code.ops_series.total()];
        if code.low.is_some() {
            branches.push(code.ops_series_low.total());
        }
        moments_min += branches.iter().copied().min().unwrap_or(0);
        moments_max += branches.iter().copied().max().unwrap_or(0);
        files.push((k.file(), format(&code.code)));
    }
    let (point, point_text) = crate::kernel_point::generate_element_point()?;
    let (a, b) = (
        point.ops_series_path().total(),
        point.ops_closed_path().total(),
    );
    files.push((
        crate::kernel_point::ELEMENT_POINT_FILE.to_string(),
        point_text,
    ));
    // the switch of element_point: both functions take the same branch at every (d, u)
    let (rotary_point, rotary_point_text) =
        crate::kernel_point::generate_element_rotary_point(Some(vec![point.switch]))?;
    let (ra, rb) = (
        rotary_point.ops_series_path().total(),
        rotary_point.ops_closed_path().total(),
    );
    files.push((
        crate::kernel_point::ELEMENT_ROTARY_POINT_FILE.to_string(),
        rotary_point_text,
    ));
    let ops = crate::sizes::ElementOps {
        moments: (moments_min, moments_max),
        point: (a.min(b), a.max(b)),
        rotary_point: (ra.min(rb), ra.max(rb)),
    };
    if ops != crate::sizes::ELEMENT_OPS {
        return Err(CodegenError::StaleElementOps(format!(
            "the element functions now cost {ops:?}; set superhelix_codegen::sizes::ELEMENT_OPS \
             (codegen/src/sizes.rs) to these values and regenerate"
        )));
    }
    files.push((
        crate::sizes::SIZES_FILE.to_string(),
        crate::sizes::sizes_file(&ops),
    ));
    // the f32 versions (scalar only): the element moments and the element point
    for k in ELEMENT_KERNELS.iter() {
        let code = generate_in(k, Float::F32)?;
        files.push((k.file_in(Float::F32), format(&code.code)));
    }
    let (_, point_f32_text) = crate::kernel_point::generate_element_point_f32()?;
    files.push((
        crate::kernel_point::ELEMENT_POINT_F32_FILE.to_string(),
        point_f32_text,
    ));
    // the per-N modules and their dispatch: the same call a build script makes
    let fixed = crate::Kernels::new()
        .elements(&crate::sizes::CHECKED_IN_SIZES)
        .float(Float::F64)
        .float(Float::F32)
        .files()
        .map_err(|e| CodegenError::Unsupported(e.to_string()))?;
    for (name, text) in fixed {
        files.push((format!("{FIXED_DIR}/{name}"), text));
    }
    Ok(files)
}

/// Folder (relative to `generated/src/`) of the checked-in per-N modules and of their
/// declaring file ([`crate::fixed_n::KERNELS_FILE`]).
pub const FIXED_DIR: &str = "fixed";
