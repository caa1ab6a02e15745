//! `superhelix coulomb`: the Coulomb potential and field of any point set, read from and
//! written to `.npy` files, by the multipole method or the direct sum of
//! `superhelix-fmm`.
//!
//! Input: `points` `[n, 3]` and `charges` `[n]`, float64 or float32, C order (positions
//! in m, charges in C). Output in `out`: `potential.npy` `[n]` (V) and `field.npy`
//! `[n, 3]` (V/m), float64, with `Φ_i = k Σ_{j≠i} q_j φ(r_ij)` and `E_i = −∇Φ(x_i)`;
//! `k = 1/(4πε₀)` unless another constant is asked for (1 gives the plain kernel
//! `1/r`).

use crate::runtime::output::atomic::write_atomically;
use crate::{Error, Result};
use std::path::{Path, PathBuf};
use std::time::Instant;
use superhelix_fmm::{direct_sum, Fmm, FmmOptions, FmmStats, Potentials, Softening};

/// Coulomb's constant `1/(4πε₀)`, N·m²/C² (CODATA 2018).
pub const COULOMB_CONSTANT: f64 = 8.987_551_792_3e9;

/// How to sum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Method {
    /// The multipole method with these options.
    Fmm(FmmOptions),
    /// Every pair, with this softening.
    Direct(Softening),
}

/// What `coulomb` did.
#[derive(Debug, Clone)]
pub struct CoulombReport {
    /// Number of charges.
    pub particles: usize,
    /// Seconds of the evaluation alone (no file input or output).
    pub seconds: f64,
    /// The tree and its passes (multipole method only).
    pub stats: Option<FmmStats>,
    /// The files written.
    pub written: Vec<PathBuf>,
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.display().to_string(),
        source,
    }
}

/// Read an `.npy` array of float64 or float32 with its shape.
pub fn read_array(path: &Path, field: &str) -> Result<(Vec<f64>, Vec<u64>)> {
    let bytes = crate::runtime::input::read_bounded(path, u64::MAX, ".npy file")
        .map_err(|e| Error::invalid(field, e))?;
    let file = npyz::NpyFile::new(&bytes[..])
        .map_err(|e| Error::invalid(field, format!("{}: not an .npy file: {e}", path.display())))?;
    let shape = file.shape().to_vec();
    if file.order() != npyz::Order::C {
        return Err(Error::invalid(
            field,
            format!("{}: must be in C order", path.display()),
        ));
    }
    let descr = file
        .dtype()
        .descr()
        .trim_matches(|c| c == '\'' || c == '"')
        .to_string();
    let data = match descr.as_str() {
        "<f8" => file.into_vec::<f64>(),
        "<f4" => file
            .into_vec::<f32>()
            .map(|v| v.into_iter().map(f64::from).collect()),
        other => {
            return Err(Error::invalid(
                field,
                format!(
                    "{}: dtype {other}: must be float64 or float32 (little-endian)",
                    path.display()
                ),
            ))
        }
    }
    .map_err(|e| Error::invalid(field, format!("{}: {e}", path.display())))?;
    Ok((data, shape))
}

/// Write a float64 `.npy` array of `shape`, whole or not at all.
pub fn write_array(path: &Path, data: &[f64], shape: &[u64]) -> Result<()> {
    let mut bytes = Vec::with_capacity(128 + 8 * data.len());
    {
        use npyz::WriterBuilder;
        let mut writer = npyz::WriteOptions::new()
            .default_dtype()
            .shape(shape)
            .writer(&mut bytes)
            .begin_nd()
            .map_err(io(path))?;
        writer.extend(data.iter().copied()).map_err(io(path))?;
        writer.finish().map_err(io(path))?;
    }
    write_atomically(path, &bytes)
}

/// The largest magnitude of an input coordinate or charge: squares and products of two
/// stay finite in float64 (1e100² = 1e200).
pub const MAX_INPUT: f64 = 1e100;

/// The command-line option of an FMM option's name.
fn flag(name: &str) -> &'static str {
    match name {
        "order" => "--order",
        "theta" => "--theta",
        "leaf_size" => "--leaf-size",
        "softening" => "--softening",
        _ => "--eps",
    }
}

/// The points `[n, 3]` and charges `[n]` of two `.npy` files, checked.
pub fn read_input(points: &Path, charges: &Path) -> Result<(Vec<[f64; 3]>, Vec<f64>)> {
    let (p, pshape) = read_array(points, "--points")?;
    if pshape.len() != 2 || pshape[1] != 3 {
        return Err(Error::invalid(
            "--points",
            format!("shape {pshape:?}: must be [n, 3]"),
        ));
    }
    let (q, qshape) = read_array(charges, "--charges")?;
    if qshape.len() != 1 || qshape[0] != pshape[0] {
        return Err(Error::invalid(
            "--charges",
            format!(
                "shape {qshape:?}: must be [{}], one charge per point",
                pshape[0]
            ),
        ));
    }
    let pts: Vec<[f64; 3]> = p.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    if let Some(i) = pts.iter().position(|x| !x.iter().all(|v| v.is_finite())) {
        return Err(Error::invalid("--points", format!("row {i} is not finite")));
    }
    if let Some(i) = pts
        .iter()
        .position(|x| x.iter().any(|v| v.abs() > MAX_INPUT))
    {
        return Err(Error::invalid(
            "--points",
            format!("row {i}: coordinates must be within ±{MAX_INPUT:e} (squared distances must stay finite)"),
        ));
    }
    if let Some(i) = q.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid(
            "--charges",
            format!("entry {i} is not finite"),
        ));
    }
    if let Some(i) = q.iter().position(|v| v.abs() > MAX_INPUT) {
        return Err(Error::invalid(
            "--charges",
            format!("entry {i}: charges must be within ±{MAX_INPUT:e}"),
        ));
    }
    Ok((pts, q))
}

/// The potential and field (times `constant`) of `charges` at `points`.
pub fn evaluate(
    points: &[[f64; 3]],
    charges: &[f64],
    method: Method,
    constant: f64,
) -> Result<(Potentials, CoulombReport)> {
    let start = Instant::now();
    let (mut out, stats) = match method {
        Method::Fmm(options) => {
            let mut fmm = Fmm::new(options).map_err(|e| {
                let name = match &e {
                    superhelix_fmm::FmmError::Option { name, .. } => *name,
                    _ => "eps",
                };
                Error::invalid(flag(name), e.to_string())
            })?;
            let (out, stats) = fmm
                .evaluate(points, charges)
                .map_err(|e| Error::invalid("--points", e.to_string()))?;
            (out, Some(stats))
        }
        Method::Direct(softening) => {
            let (potential, field) = direct_sum(points, charges, softening);
            (Potentials { potential, field }, None)
        }
    };
    let seconds = start.elapsed().as_secs_f64();
    if constant != 1.0 {
        out.potential.iter_mut().for_each(|v| *v *= constant);
        out.field.iter_mut().flatten().for_each(|v| *v *= constant);
    }
    // nothing non-finite is written: two coincident points, or values beyond float64
    if let Some(i) = out
        .potential
        .iter()
        .position(|v| !v.is_finite())
        .or_else(|| {
            out.field
                .iter()
                .position(|f| !f.iter().all(|v| v.is_finite()))
        })
    {
        return Err(Error::invalid(
            "--points",
            format!(
                "the potential or field at point {i} is not finite (charges and distances whose ratio overflows): nothing was written"
            ),
        ));
    }
    Ok((
        out,
        CoulombReport {
            particles: points.len(),
            seconds,
            stats,
            written: Vec::new(),
        },
    ))
}

/// Read the input files, evaluate, write `potential.npy` and `field.npy` into `out`.
pub fn coulomb_files(
    points: &Path,
    charges: &Path,
    method: Method,
    constant: f64,
    out: &Path,
) -> Result<CoulombReport> {
    let (pts, q) = read_input(points, charges)?;
    let (result, mut report) = evaluate(&pts, &q, method, constant)?;
    std::fs::create_dir_all(out).map_err(io(out))?;
    let n = pts.len() as u64;
    let potential = out.join("potential.npy");
    write_array(&potential, &result.potential, &[n])?;
    let field = out.join("field.npy");
    let flat: Vec<f64> = result.field.iter().flatten().copied().collect();
    write_array(&field, &flat, &[n, 3])?;
    report.written = vec![potential, field];
    Ok(report)
}
