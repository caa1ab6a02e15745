//! Contacts that start within a step: the samples that touch nothing at the step's start
//! but are predicted to reach a body before its end, and the one-sided penalty they add
//! to the step, resolved without a second factorisation. The prediction, its
//! complementarity problem and the end checks are
//! [`superhelix_kernels::contact::predicted`] (its module page states them), shared with
//! the fixed-N step; here are a strand's buffers for it, grown to the largest number of
//! candidates met.

use nalgebra::Vector3;
use superhelix_kernels::contact::predicted::{PredictedArrays, PredictedBuffers, PredictedScalars};

pub use superhelix_kernels::contact::candidates::Candidate;

/// The predicted contacts of one strand's step and the buffers of their complementarity
/// problem (see the module page), grown to the largest number of candidates met and
/// reused: a step allocates nothing once they have reached it.
#[derive(Default)]
pub struct PredictedContacts {
    /// What the prediction carries besides its arrays.
    pub scalars: PredictedScalars,
    /// The candidates of the coming step (the first `scalars.count`).
    pub candidates: Vec<Candidate>,
    g: Vec<f64>,
    w: Vec<f64>,
    /// The forces λ of the last solve (the first `scalars.solved`), N.
    pub lambda: Vec<f64>,
    a: Vec<f64>,
    active: Vec<bool>,
    s: Vec<f64>,
    sub: Vec<f64>,
    sub_rhs: Vec<f64>,
    index: Vec<usize>,
    lin_y: Vec<Vector3<f64>>,
    touching: Vec<bool>,
    listed: Vec<bool>,
    q_lin: Vec<f64>,
    v_free: Vec<f64>,
    shift: Vec<f64>,
    /// Samples of the strand.
    samples: usize,
}

impl PredictedContacts {
    /// Buffers for a strand of `samples` contact samples.
    pub fn new(samples: usize) -> Self {
        PredictedContacts {
            lin_y: vec![Vector3::zeros(); samples],
            touching: vec![false; samples],
            listed: vec![false; samples],
            samples,
            ..Default::default()
        }
    }

    /// Forget the last prediction: until the next, nothing is resolved.
    pub fn forget(&mut self) {
        superhelix_kernels::contact::predicted::forget(self);
    }
}

fn grow<T: Clone + Default>(v: &mut Vec<T>, n: usize) -> &mut [T] {
    if v.len() < n {
        v.resize(n, T::default());
    }
    v
}

impl PredictedBuffers for PredictedContacts {
    fn arrays(&mut self, m: usize, dofs: usize) -> PredictedArrays<'_> {
        if self.lin_y.len() < self.samples {
            self.lin_y.resize(self.samples, Vector3::zeros());
        }
        PredictedArrays {
            scalars: &mut self.scalars,
            candidates: grow_candidates(&mut self.candidates, m),
            g: grow(&mut self.g, m * dofs),
            w: grow(&mut self.w, m * dofs),
            lambda: grow(&mut self.lambda, m),
            a: grow(&mut self.a, m),
            active: grow(&mut self.active, m),
            s: grow(&mut self.s, m * m),
            sub: grow(&mut self.sub, m * m),
            sub_rhs: grow(&mut self.sub_rhs, m),
            index: grow(&mut self.index, m),
            lin_y: &mut self.lin_y,
            touching: grow(&mut self.touching, self.samples),
            listed: grow(&mut self.listed, self.samples),
            q_lin: grow(&mut self.q_lin, dofs),
            v_free: grow(&mut self.v_free, dofs),
            shift: grow(&mut self.shift, dofs),
        }
    }
}

fn grow_candidates(v: &mut Vec<Candidate>, n: usize) -> &mut [Candidate] {
    while v.len() < n {
        v.push(Candidate {
            sample: 0,
            s: 0.0,
            stiffness: 0.0,
            body: 0,
            normal: Vector3::zeros(),
            onset: 0.0,
            gap: 0.0,
            end_gap: None,
        });
    }
    v
}
