//! The per-N modules of the fixed-N strand, and the library API that writes them for a
//! build script.
//!
//! For each number of elements N, [`Kernels`] writes one module, `n{N}.rs`, in which every
//! size is a literal: `N`, `DOFS` = 3N, `ENDS` = N + 1, `BASIS` = ⌊3N/2⌋, the types
//! `Strand`, `Params`, `Workspace`, `Assembly` and `Ends`, and the functions `step` (the
//! checked step), `linearly_implicit` (the bare step of paper section 3.4), `evaluate`
//! and `centreline`, each calling the const-generic code of
//! `superhelix_kernels::fixed` with the generated closed forms (`ClosedForm`) as the
//! moment source. Its header gives an estimate of what one step costs at that N.
//!
//! With [`Float::F32`] ([`Kernels::float`]) it writes the same module in f32,
//! `n{N}_f32.rs`: the same names with the strand, its workspace and every operation of
//! its step in f32, on the generated f32 closed forms (`ClosedForm` as an f32 moment
//! source); it is declared as `n{N}::f32` (`n7::f32::step`, `n7::f32::Strand`, …).
//!
//! Beside the modules it writes [`KERNELS_FILE`], which declares them
//! (`pub mod n7 { include!("n7.rs"); pub mod f32 { include!("n7_f32.rs"); } }`), lists
//! them (`SIZES`) and dispatches a run-time N to the matching const parameters
//! (`visit_size`, over `superhelix_generated::SizeVisitor`). A crate that depends on `superhelix-generated`
//! (and on this crate as a build-dependency) gets them with
//!
//! ```no_run
//! // build.rs
//! use superhelix_codegen::{Float, Kernels};
//! let out = std::env::var("OUT_DIR").expect("cargo sets OUT_DIR");
//! if let Err(e) = Kernels::new().elements(&[7]).float(Float::F64).float(Float::F32).write_to(&out) {
//!     eprintln!("error: {e}");
//!     std::process::exit(1);
//! }
//! ```
//!
//! and, in its library, `include!(concat!(env!("OUT_DIR"), "/superhelix_kernels.rs"));`,
//! after which `n7::step`, `n7::Strand`, `n7::f32::step`, `n7::f32::Strand` and
//! `visit_size(7, …)` are its own. The emitted
//! code names everything by absolute paths (`::superhelix_generated::kernels::fixed::…`,
//! `::superhelix_generated::ClosedForm`), so the same text compiles inside
//! `superhelix-generated` (the checked-in sizes, `generated/src/fixed/`) and in any crate
//! that depends on it.
//!
//! Writing the modules is text formatting only (no symbolic work): the element closed
//! forms they call are the checked-in ones, and the operation counts in the headers are
//! [`ELEMENT_OPS`].

use crate::sizes::{ElementOps, ELEMENT_OPS};
use crate::Float;
use std::fmt;
use std::path::{Path, PathBuf};

/// Largest number of elements the API writes a module for (a strand of N elements
/// keeps 3N × 3N matrices of literal size in its workspace: 1.4 MB each at N = 200).
pub const MAX_ELEMENTS: usize = 200;

/// The file that declares the per-N modules and holds the dispatch.
pub const KERNELS_FILE: &str = "superhelix_kernels.rs";

/// Why [`Kernels`] wrote nothing (or not everything).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum KernelsError {
    /// A number of elements outside `1..=`[`MAX_ELEMENTS`].
    Elements(usize),
    /// A path that is not valid UTF-8 (the declaring file names the modules by path).
    Path(PathBuf),
    /// Creating the directory or writing a file failed.
    Io {
        /// The file or directory.
        path: PathBuf,
        /// What the operating system said.
        message: String,
    },
}

impl fmt::Display for KernelsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            KernelsError::Elements(n) => write!(
                f,
                "number of elements N = {n} is out of range: N must be in 1..={MAX_ELEMENTS}"
            ),
            KernelsError::Path(p) => write!(f, "{}: the path is not valid UTF-8", p.display()),
            KernelsError::Io { path, message } => write!(f, "{}: {message}", path.display()),
        }
    }
}

impl std::error::Error for KernelsError {}

/// What one linearly implicit step of a strand of N elements costs, in floating-point
/// operations: estimates from the code's loops (see [`StepCost::for_elements`]), not
/// measurements.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepCost {
    /// N.
    pub elements: usize,
    /// N × (element moments + end point), cheapest and dearest branch of the closed
    /// forms (operation counts after CSE).
    pub closed_forms: (u64, u64),
    /// The rotary-inertia quadrature: 6 + ⌈W l⌉ rotary points per element (at least 6),
    /// with W l = 0 and W l = 4 (cheapest branch, dearest branch).
    pub rotary_points: (u64, u64),
    /// The O(N²) assembly of one evaluation of every term and of the step matrix.
    pub assembly: u64,
    /// LU factorisation with partial pivoting and the solve: 2/3 D³ + 2 D².
    pub lu: u64,
    /// The negative semidefinite part of the field stiffness when −H is definite
    /// (one Cholesky factorisation, D³/3).
    pub projection_definite: u64,
    /// One sweep of the cyclic Jacobi eigendecomposition it falls back to otherwise
    /// (D(D − 1)/2 rotations of two rows, two columns and two eigenvectors: 9 D²(D − 1)).
    pub jacobi_sweep: u64,
}

/// Flops per entry of a D × D matrix of the assembly's O(N²) loops, counted from
/// `superhelix_kernels::moments` (the cross-element loops, which dominate): M and the
/// centreline Gram matrix ~33 D² (≈ 65 per entry of the upper triangle), the field
/// stiffness ~3.5 D², the damping of an isotropic drag D² (−ν times the Gram matrix),
/// ∂b/∂q̇ ~32 D² (full matrix, ≈ 25 flops per entry upstream and 39 downstream), the
/// step matrix, its right-hand side and the symmetrised stiffness ~13 D².
const ASSEMBLY_PER_ENTRY: f64 = 33.0 + 3.5 + 1.0 + 32.0 + 13.0;

impl StepCost {
    /// The estimate for N elements from the per-element operation counts `ops`: the
    /// closed forms are exact counts of the emitted code (after CSE), the rest are
    /// counts of the loops' arithmetic, rounded: one linearly implicit step with a still
    /// head (one evaluation of M, the force, the field stiffness, the damping and ∂b/∂q̇,
    /// the projection, one LU). The checked step adds an energy measure (M reused,
    /// 2 D²) and repeats all of it for each half of a split step.
    pub fn for_elements(n: usize, ops: &ElementOps) -> StepCost {
        let n64 = n as u64;
        let d = 3 * n64;
        let df = d as f64;
        StepCost {
            elements: n,
            closed_forms: (
                n64 * (ops.moments.0 + ops.point.0),
                n64 * (ops.moments.1 + ops.point.1),
            ),
            rotary_points: (n64 * 6 * ops.rotary_point.0, n64 * 10 * ops.rotary_point.1),
            assembly: (ASSEMBLY_PER_ENTRY * df * df).round() as u64,
            lu: (2.0 / 3.0 * df * df * df + 2.0 * df * df).round() as u64,
            projection_definite: (df * df * df / 3.0).round() as u64,
            jacobi_sweep: 9 * d * d * d.saturating_sub(1),
        }
    }

    /// Total of a step with a definite −H (cheapest and dearest closed-form branch).
    pub fn total(&self) -> (u64, u64) {
        let rest = self.assembly + self.lu + self.projection_definite;
        (
            self.closed_forms.0 + self.rotary_points.0 + rest,
            self.closed_forms.1 + self.rotary_points.1 + rest,
        )
    }
}

/// The per-N modules of the fixed-N strand for a set of N, and the file that declares
/// them and dispatches to them: what `superhelix-generated` checks in for its sizes and
/// what a build script writes for others (see the module page).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Kernels {
    elements: Vec<usize>,
    floats: Vec<Float>,
}

impl Kernels {
    /// No sizes; `f64` unless [`Kernels::float`] adds a float type.
    pub fn new() -> Kernels {
        Kernels::default()
    }

    /// Add modules for these numbers of elements (repeats are written once; each must
    /// be in `1..=`[`MAX_ELEMENTS`], checked when the files are made).
    pub fn elements(mut self, sizes: &[usize]) -> Kernels {
        self.elements.extend_from_slice(sizes);
        self
    }

    /// Add a float type to write the modules in (repeats are written once): for each N,
    /// [`Float::F64`] writes `n{N}.rs` (the module `n{N}`), [`Float::F32`] writes
    /// `n{N}_f32.rs` (the module `n{N}::f32`: the strand and its step in f32). Without
    /// any, `f64` only.
    pub fn float(mut self, float: Float) -> Kernels {
        if !self.floats.contains(&float) {
            self.floats.push(float);
        }
        self
    }

    /// The float types to write, `f64` first: those added, or `f64` alone.
    pub fn floats(&self) -> Vec<Float> {
        [Float::F64, Float::F32]
            .into_iter()
            .filter(|f| self.floats.is_empty() && *f == Float::F64 || self.floats.contains(f))
            .collect()
    }

    /// The numbers of elements, ascending, without repeats; an error names the first
    /// one out of range.
    pub fn sizes(&self) -> Result<Vec<usize>, KernelsError> {
        if let Some(&n) = self
            .elements
            .iter()
            .find(|&&n| !(1..=MAX_ELEMENTS).contains(&n))
        {
            return Err(KernelsError::Elements(n));
        }
        let mut sizes = self.elements.clone();
        sizes.sort_unstable();
        sizes.dedup();
        Ok(sizes)
    }

    /// Every file as (name, text): for each N, ascending, `n{N}.rs` and `n{N}_f32.rs`
    /// (those of the float types asked for), then [`KERNELS_FILE`]. The texts depend
    /// only on the sizes and float types (and this crate's version).
    pub fn files(&self) -> Result<Vec<(String, String)>, KernelsError> {
        let sizes = self.sizes()?;
        let floats = self.floats();
        let mut files: Vec<(String, String)> = Vec::new();
        for &n in &sizes {
            for &float in &floats {
                files.push((
                    module_file_in(n, float),
                    module_text_in(n, &ELEMENT_OPS, float),
                ));
            }
        }
        files.push((KERNELS_FILE.to_string(), declaring_text_in(&sizes, &floats)));
        Ok(files)
    }

    /// Write [`Kernels::files`] into `dir` (created if missing). A file whose content is
    /// already the same is left untouched (its modification time too, so that cargo
    /// does not rebuild what includes it). Returns the paths of the files.
    pub fn write_to(&self, dir: impl AsRef<Path>) -> Result<Vec<PathBuf>, KernelsError> {
        let dir = dir.as_ref();
        if dir.to_str().is_none() {
            return Err(KernelsError::Path(dir.to_path_buf()));
        }
        let files = self.files()?;
        let io = |path: &Path, e: std::io::Error| KernelsError::Io {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
        let mut written = Vec::with_capacity(files.len());
        for (name, text) in files {
            let path = dir.join(name);
            let same = std::fs::read(&path).is_ok_and(|old| old == text.as_bytes());
            if !same {
                std::fs::write(&path, text).map_err(|e| io(&path, e))?;
            }
            written.push(path);
        }
        Ok(written)
    }
}

/// The file of the module for N elements.
pub fn module_file(n: usize) -> String {
    module_file_in(n, Float::F64)
}

/// The file of the module for N elements in `float`: `n{N}.rs` (f64), `n{N}_f32.rs`.
pub fn module_file_in(n: usize, float: Float) -> String {
    match float {
        Float::F64 => format!("n{n}.rs"),
        Float::F32 => format!("n{n}_f32.rs"),
    }
}

/// The kept eigenbasis's columns for N elements: ⌊3N/2⌋.
fn basis(n: usize) -> usize {
    3 * n / 2
}

/// Comma-separated list.
fn list(sizes: &[usize]) -> String {
    sizes
        .iter()
        .map(|n| n.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// "1 element", "5 elements".
fn elements_phrase(n: usize) -> String {
    if n == 1 {
        "1 element".to_string()
    } else {
        format!("{n} elements")
    }
}

/// Path of the kernels' fixed-N module in emitted code.
const FIXED: &str = "::superhelix_generated::kernels::fixed";

/// A call `{FIXED}::{function}(&ClosedForm, args…)` as rustfmt lays it out in a function
/// body (one argument per line).
fn call(function: &str, args: &[&str]) -> String {
    let mut s = format!("    {FIXED}::{function}(\n        &::superhelix_generated::ClosedForm,\n");
    for a in args {
        s.push_str(&format!("        {a},\n"));
    }
    s.push_str("    )\n");
    s
}

/// The return type of the steps, laid out as rustfmt does.
fn step_result() -> String {
    format!("Result<\n    {FIXED}::StepReport,\n    {FIXED}::StepError,\n>")
}

/// The text of `n{N}.rs`: items only (no inner attributes or inner doc comments), so
/// that it can be `include!`d into a module; laid out as rustfmt would.
pub fn module_text(n: usize, ops: &ElementOps) -> String {
    module_text_in(n, ops, Float::F64)
}

/// The text of the module for N elements in `float` ([`module_text`] for f64; for f32
/// the same items on the f32 strand, workspace and step).
pub fn module_text_in(n: usize, ops: &ElementOps, float: Float) -> String {
    let (d, e, b) = (3 * n, n + 1, basis(n));
    let c = StepCost::for_elements(n, ops);
    let (t0, t1) = c.total();
    let elements = elements_phrase(n);
    let (first, type_arg, ends_type, in_float) = match float {
        Float::F64 => (
            format!(
                "// The fixed-N strand of N = {n} ({elements}, {d} coordinates, {e} element ends,\n\
                 // a kept eigenbasis of {b} column{b_plural}), stepped by superhelix-kernels' const-generic\n\
                 // step with the generated closed forms (ClosedForm) as its moment source.\n",
                b_plural = if b == 1 { "" } else { "s" },
            ),
            String::new(),
            String::new(),
            String::new(),
        ),
        Float::F32 => (
            format!(
                "// The fixed-N strand of N = {n} in f32 ({elements}, {d} coordinates, {e} element\n\
                 // ends, a kept eigenbasis of {b} column{b_plural}): superhelix-kernels' const-generic\n\
                 // step in f32 (the strand, its workspace and every operation of the step), with\n\
                 // the generated f32 closed forms (ClosedForm as an f32 moment source). Times, the\n\
                 // head's motion and gravity are f64, rounded to f32 where the step uses them.\n\
                 // The operation counts below are those of the f64 module (the f32 closed forms\n\
                 // have their own Taylor degrees: see the headers of generated/src/*_f32.rs).\n",
                b_plural = if b == 1 { "" } else { "s" },
            ),
            ", f32".to_string(),
            "<f32>".to_string(),
            " in f32".to_string(),
        ),
    };
    let header = format!(
        "// @generated by superhelix-codegen {version}\n\
         {first}\
         // Cost of one linearly implicit step, floating-point operations (ESTIMATES: the\n\
         // closed forms are exact counts of the emitted code after CSE, the rest counted\n\
         // from the loops; still head, one evaluation of every term, one projection, one LU):\n\
         //   element closed forms, N x (moments + end point):    {cf0} .. {cf1}\n\
         //   rotary-inertia points, N x (6 .. 10) points:         {rp0} .. {rp1}\n\
         //   O(N^2) assembly, ~{per:.1} D^2 (M and Gram ~33, field stiffness ~3.5,\n\
         //     damping 1, db/dqdot ~32, step matrix ~13 per entry):  ~{asm}\n\
         //   O(D^3) LU with partial pivoting, 2/3 D^3 + 2 D^2:     ~{lu}\n\
         //   projection of the field stiffness: Cholesky D^3/3 ~{chol} when -H is\n\
         //     definite, else the kept eigenbasis's check or a partial\n\
         //     eigendecomposition (Householder tridiagonalisation 4/3 D^3 ~{tri} and\n\
         //     the smaller side's eigenvectors); cyclic Jacobi ~{jac} per sweep only\n\
         //     when that fails its checks\n\
         //   total (Cholesky case): ~{t0} .. ~{t1}\n\
         // The checked step (`step`) adds an energy measurement per (sub)step (M at the\n\
         // new state: the moments of M and its O(N^2) assembly), and its splits.\n",
        version = crate::VERSION,
        cf0 = c.closed_forms.0,
        cf1 = c.closed_forms.1,
        rp0 = c.rotary_points.0,
        rp1 = c.rotary_points.1,
        per = ASSEMBLY_PER_ENTRY,
        asm = c.assembly,
        lu = c.lu,
        chol = c.projection_definite,
        jac = c.jacobi_sweep,
        tri = 4 * d * d * d / 3,
    );
    let items = format!(
        "\n\
         /// Number of elements N.\n\
         pub const N: usize = {n};\n\
         /// Generalized coordinates, D = 3N (twist and two curvatures per element).\n\
         pub const DOFS: usize = {d};\n\
         /// Element ends, N + 1 (the root first).\n\
         pub const ENDS: usize = {e};\n\
         /// Columns of the kept eigenbasis of the projection, B = ⌊D/2⌋.\n\
         pub const BASIS: usize = {b};\n\
         \n\
         /// What a strand of {elements} keeps between steps (parameters, q, q̇, the kept\n\
         /// eigenbasis){in_float}: `FixedStrand<{n}, {d}, {b}{type_arg}>`.\n\
         pub type Strand = {FIXED}::FixedStrand<{n}, {d}, {b}{type_arg}>;\n\
         /// The parameters of a strand of {elements}{in_float}, checked by `Params::new`.\n\
         pub type Params = {FIXED}::FixedParams<{n}, {d}{type_arg}>;\n\
         /// The scratch of one step{in_float}, one per worker: `FixedWorkspace<{n}, {d}, {e}{type_arg}>`.\n\
         pub type Workspace = {FIXED}::FixedWorkspace<{n}, {d}, {e}{type_arg}>;\n\
         /// The moment assembly's buffers at N = {n}{in_float}.\n\
         pub type Assembly = {FIXED}::Assembly<{n}, {d}, {e}{type_arg}>;\n\
         /// The poses at the {e} element ends, root first, in head coordinates{in_float}.\n\
         pub type Ends = [::superhelix_generated::kernels::pose::Pose{ends_type}; {e}];\n\
         /// What a strand keeps for the error-controlled step besides its state (the BDF2\n\
         /// history and the next step size){in_float}: `StepHistory<{d}{type_arg}>`.\n\
         pub type History = {FIXED}::StepHistory<{d}{type_arg}>;\n\
         \n\
         /// Advance `strand` from time `t` by `h` seconds with the head moving as `head`:\n\
         /// the linearly implicit Euler step (paper section 3.4) checked after the fact and\n\
         /// split when it is not acceptable (energy balance, element rotation), as\n\
         /// `superhelix_kernels::fixed::step`. Allocates nothing; on failure the strand keeps\n\
         /// the state of its last accepted substep.\n\
         pub fn step(\n    \
             strand: &mut Strand,\n    \
             head: &dyn {FIXED}::HeadTrajectory,\n    \
             effects: &{FIXED}::Effects,\n    \
             t: f64,\n    \
             h: f64,\n    \
             ws: &mut Workspace,\n    \
             counts: &mut {FIXED}::StepCounts,\n\
         ) -> {result} {{\n\
         {step}\
         }}\n\
         \n\
         /// Advance `strand` from time `t` to `t + h` in steps of its own that keep each\n\
         /// one's estimated local error below `tolerance` (relative to the strand's length;\n\
         /// variable-step BDF2 with the checked step's energy balance), adding what it did to\n\
         /// `report`, as `superhelix_kernels::fixed::step_to_tolerance`. Allocates nothing;\n\
         /// on failure the strand keeps the state of its last accepted step.\n\
         #[allow(clippy::too_many_arguments)]\n\
         pub fn step_to_tolerance(\n    \
             strand: &mut Strand,\n    \
             history: &mut History,\n    \
             head: &dyn {FIXED}::HeadTrajectory,\n    \
             effects: &{FIXED}::Effects,\n    \
             t: f64,\n    \
             h: f64,\n    \
             tolerance: f64,\n    \
             ws: &mut Workspace,\n    \
             report: &mut {FIXED}::ToleranceReport,\n\
         ) -> {result} {{\n\
         {step_to_tolerance}\
         }}\n\
         \n\
         /// One linearly implicit Euler step of `h` seconds (paper section 3.4) with the head\n\
         /// in `input.head` at its end, without the checks of [`step`]\n\
         /// (`superhelix_kernels::fixed::linearly_implicit`). On failure the strand keeps its\n\
         /// state.\n\
         pub fn linearly_implicit(\n    \
             strand: &mut Strand,\n    \
             input: &{FIXED}::StepInput,\n    \
             h: f64,\n    \
             ws: &mut Workspace,\n\
         ) -> {result} {{\n\
         {linearly_implicit}\
         }}\n\
         \n\
         /// The terms of the equation of motion (paper eq. 4–6) at the strand's state into\n\
         /// `ws` (`superhelix_kernels::fixed::evaluate`); whether the stiffness holds field\n\
         /// terms.\n\
         pub fn evaluate(\n    \
             strand: &Strand,\n    \
             input: &{FIXED}::StepInput,\n    \
             ws: &mut Workspace,\n\
         ) -> bool {{\n\
         {evaluate}\
         }}\n\
         \n\
         /// The centreline: the poses at the {e} element ends, root first, in head\n\
         /// coordinates (metres).\n\
         pub fn centreline(strand: &Strand, ends: &mut Ends) {{\n\
         {centreline}\
         }}\n",
        result = step_result(),
        step = call(
            "step",
            &["strand", "head", "effects", "t", "h", "ws", "counts"]
        ),
        step_to_tolerance = call(
            "step_to_tolerance",
            &["strand", "history", "head", "effects", "t", "h", "tolerance", "ws", "report"]
        ),
        linearly_implicit = call("linearly_implicit", &["strand", "input", "h", "ws"]),
        evaluate = call("evaluate", &["strand", "input", "ws"]),
        centreline = call("centreline", &["strand", "ends"]),
    );
    header + &items
}

/// `list` as comment lines of at most ~90 characters after `prefix`.
fn wrapped_list(prefix: &str, sizes: &[usize], suffix: &str) -> String {
    let mut out = String::new();
    let mut line = format!("// {prefix}");
    let words: Vec<String> = sizes
        .iter()
        .enumerate()
        .map(|(i, n)| {
            if i + 1 < sizes.len() {
                format!("{n},")
            } else {
                format!("{n}{suffix}")
            }
        })
        .collect();
    for w in words {
        if line.len() + 1 + w.len() > 90 {
            out.push_str(line.trim_end());
            out.push('\n');
            line = "//".to_string();
        }
        line.push(' ');
        line.push_str(&w);
    }
    if sizes.is_empty() {
        line.push_str(&format!(" (none){suffix}"));
    }
    out.push_str(&line);
    out.push('\n');
    out
}

/// The text of [`KERNELS_FILE`] for `sizes` (ascending, in range).
pub fn declaring_text(sizes: &[usize]) -> String {
    declaring_text_in(sizes, &[Float::F64])
}

/// The text of [`KERNELS_FILE`] for `sizes` (ascending, in range) in the float types
/// `floats` (each module `n{N}` holds the f64 items of `n{N}.rs` and the module
/// `n{N}::f32` of `n{N}_f32.rs`, as asked).
pub fn declaring_text_in(sizes: &[usize], floats: &[Float]) -> String {
    let f64_items = floats.contains(&Float::F64);
    let f32_items = floats.contains(&Float::F32);
    let mut s = format!(
        "// @generated by superhelix-codegen {version}\n\
         {list_lines}\
         // (each in {files} beside this file), and the dispatch of a run-time N to them.\n",
        version = crate::VERSION,
        files = match (f64_items, f32_items) {
            (true, true) => "n<N>.rs and n<N>_f32.rs",
            (false, true) => "n<N>_f32.rs",
            _ => "n<N>.rs",
        },
        list_lines = wrapped_list("The fixed-N strand modules for N =", sizes, ""),
    );
    for &n in sizes {
        let mut body = String::new();
        if f64_items {
            body.push_str(&format!("    include!(\"n{n}.rs\");\n"));
        }
        if f32_items {
            if f64_items {
                body.push('\n');
            }
            body.push_str(&format!(
                "    /// The same strand in f32: the strand, its workspace and every operation of\n    \
                 /// its step in f32, on the generated f32 closed forms (see `n{n}_f32.rs`).\n    \
                 pub mod f32 {{\n        \
                     include!(\"n{n}_f32.rs\");\n    \
                 }}\n"
            ));
        }
        s.push_str(&format!(
            "\n/// The fixed-N strand of {elements} ({d} coordinates), stepped with the\n\
             /// generated closed forms (see the file's header for what a step costs).\n\
             pub mod n{n} {{\n\
             {body}\
             }}\n",
            elements = elements_phrase(n),
            d = 3 * n,
        ));
    }
    s.push_str(&format!(
        "\n/// The numbers of elements with a module here, ascending.\n\
         pub const SIZES: [usize; {count}] = [{list}];\n\
         \n\
         /// Calls `visitor.visit::<N, 3N, N + 1, ⌊3N/2⌋>()` for `n` = N when there is a module\n\
         /// for it here ([`SIZES`]); `None` for any other `n`.\n\
         pub fn visit_size<V: ::superhelix_generated::SizeVisitor>(\n    \
             n: usize,\n    \
             visitor: V,\n\
         ) -> Option<V::Output> {{\n",
        count = sizes.len(),
        list = list(sizes),
    ));
    push_size_match(&mut s, sizes, |n| (3 * n, n + 1, basis(n)));
    s.push_str(
        "\n/// Calls `visitor.visit::<N, 3N + 3, N + 2, ⌊(3N + 3)/2⌋>()` for `n` = N when there is\n\
         /// a module for it here ([`SIZES`]): the sizes of a free root's strand, its chain of\n\
         /// N elements and the root's translation after the chain's 3N coordinates (the step's\n\
         /// end poses sized for the coordinates' N + 1); `None` for any other `n`.\n\
         pub fn visit_free_root_size<V: ::superhelix_generated::SizeVisitor>(\n    \
             n: usize,\n    \
             visitor: V,\n\
         ) -> Option<V::Output> {\n",
    );
    push_size_match(&mut s, sizes, |n| (3 * n + 3, n + 2, (3 * n + 3) / 2));
    s
}

/// The body of a size dispatch for `sizes`: `visitor.visit::<N, D, E, B>()` for each N,
/// with (D, E, B) = `dims(N)`, `None` for any other n.
fn push_size_match(s: &mut String, sizes: &[usize], dims: impl Fn(usize) -> (usize, usize, usize)) {
    if sizes.is_empty() {
        s.push_str("    let _ = (n, visitor);\n    None\n}\n");
        return;
    }
    s.push_str("    match n {\n");
    for &n in sizes {
        let (d, e, b) = dims(n);
        s.push_str(&format!(
            "        {n} => Some(visitor.visit::<{n}, {d}, {e}, {b}>()),\n"
        ));
    }
    s.push_str("        _ => None,\n    }\n}\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_are_checked_sorted_and_deduplicated() {
        let k = Kernels::new().elements(&[9, 7]).elements(&[7]);
        assert_eq!(k.sizes(), Ok(vec![7, 9]));
        let e = Kernels::new().elements(&[7, 0]).files().unwrap_err();
        assert_eq!(e, KernelsError::Elements(0));
        assert!(e.to_string().contains("1..=200"), "{e}");
        let e = Kernels::new().elements(&[201]).sizes().unwrap_err();
        assert_eq!(e, KernelsError::Elements(201));
        let k = Kernels::new().elements(&[7]);
        assert_eq!(k.floats(), [Float::F64]);
        assert_eq!(k.clone().float(Float::F32).floats(), [Float::F32]);
        let both = k.float(Float::F32).float(Float::F64).float(Float::F32);
        assert_eq!(both.floats(), [Float::F64, Float::F32]);
    }

    #[test]
    fn every_size_is_a_literal() {
        let files = Kernels::new().elements(&[5]).files().expect("files");
        let names: Vec<&str> = files.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["n5.rs", KERNELS_FILE]);
        let m = &files[0].1;
        assert!(m.starts_with("// @generated by superhelix-codegen"));
        for item in [
            "pub const N: usize = 5;",
            "pub const DOFS: usize = 15;",
            "pub const ENDS: usize = 6;",
            "pub const BASIS: usize = 7;",
            "FixedStrand<5, 15, 7>",
            "FixedWorkspace<5, 15, 6>",
            "Assembly<5, 15, 6>",
            "[::superhelix_generated::kernels::pose::Pose; 6]",
        ] {
            assert!(m.contains(item), "{item} missing from\n{m}");
        }
        assert!(
            !m.contains("#!") && !m.contains("//!"),
            "no inner attributes"
        );
        let decl = &files[1].1;
        assert!(decl.contains("pub mod n5 {\n    include!(\"n5.rs\");\n}"));
        assert!(decl.contains("5 => Some(visitor.visit::<5, 15, 6, 7>()),"));
        assert!(decl.contains("pub const SIZES: [usize; 1] = [5];"));
    }

    #[test]
    fn no_sizes_give_an_empty_dispatch() {
        let files = Kernels::new().files().expect("files");
        assert_eq!(files.len(), 1);
        assert!(files[0].1.contains("pub const SIZES: [usize; 0] = [];"));
        assert!(files[0].1.contains("let _ = (n, visitor);"));
    }

    #[test]
    fn cost_grows_as_expected() {
        let a = StepCost::for_elements(5, &ELEMENT_OPS);
        let b = StepCost::for_elements(10, &ELEMENT_OPS);
        assert_eq!(b.closed_forms.0, 2 * a.closed_forms.0);
        assert!(b.assembly >= 4 * a.assembly - 4);
        assert!(b.lu > 7 * a.lu);
        assert!(a.total().0 < a.total().1);
    }
}
