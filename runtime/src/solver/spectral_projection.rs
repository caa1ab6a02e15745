//! A strand's kept basis of the stiffness projection: the step's negative semidefinite
//! part `H⁻ = U min(Λ, 0) Uᵀ` (`superhelix_kernels::projection`, from a partial
//! eigendecomposition that reuses the last basis while it still splits the matrix)
//! starts from it, so the runtime keeps it per strand between steps and in checkpoints,
//! and lends it to the one step.

/// The kept basis of one strand's projection, for n × n matrices.
pub struct SpectralProjection {
    n: usize,
    vectors: Vec<f64>,
    basis_k: usize,
    basis_negative: bool,
}

impl SpectralProjection {
    /// No basis yet, for n × n matrices.
    pub fn new(n: usize) -> Self {
        SpectralProjection {
            n,
            vectors: vec![0.0; n * n],
            basis_k: 0,
            basis_negative: true,
        }
    }

    /// The kept basis (a checkpoint's part): its columns in use, column-major, and whether
    /// it spans the negative eigenvalues.
    pub fn basis(&self) -> (Vec<f64>, bool) {
        (
            self.vectors[..self.basis_k * self.n].to_vec(),
            self.basis_negative,
        )
    }

    /// Keep `vectors` (whole columns of length n, at most n of them) as the basis, as
    /// [`Self::basis`] gave it; false (nothing changed) when they do not fit.
    pub fn set_basis(&mut self, vectors: &[f64], negative: bool) -> bool {
        if self.n == 0 || vectors.len() % self.n != 0 || vectors.len() > self.vectors.len() {
            return vectors.is_empty();
        }
        self.vectors[..vectors.len()].copy_from_slice(vectors);
        self.basis_k = vectors.len() / self.n;
        self.basis_negative = negative;
        true
    }

    /// The kept basis as the one step of `superhelix-kernels` keeps it: its columns (n
    /// each, n of room), how many are in use, and whether it spans the negative
    /// eigenvalues (what a strand's step lends as its `StrandView`).
    pub fn basis_parts(&mut self) -> (&mut [f64], &mut usize, &mut bool) {
        (
            &mut self.vectors,
            &mut self.basis_k,
            &mut self.basis_negative,
        )
    }
}
