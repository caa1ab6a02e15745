//! Choosing the switch `x*` on `x = W l` between the Taylor branch (below) and the
//! closed form (above), and the Taylor order, by measurement.
//!
//! For candidates `x*` in increasing order: the order N (even, from `min_order` up) is
//! the smallest whose truncation error at `x*` — measured as the difference to the
//! order `N + 8` series — is within `truncation_target`; then both branches are
//! evaluated at `x*` and the candidate is taken if they agree within
//! `safety · agreement_target`. Since the truncation error grows with x, it is largest
//! at `x*` over the Taylor range; since the closed form's cancellation shrinks with
//! x, its error is largest at `x*` over its range.
//!
//! Relative error of output j: `|a_j − b_j| / s_j`, with `s_j` the largest `|b_j|`
//! over the sampled directions at the same `x` — relative to the size of that
//! integral at that `W l`, not to a value that happens to be small for one direction.
//! Samples: pseudo-random unit directions of d (seeded, reproducible), `|d| = x/l`,
//! with l alternating between 1 and 0.01.

use crate::graph::{Graph, Id};
use crate::helix::HelixSymbols;

/// Deterministic pseudo-random numbers (splitmix64).
pub(crate) struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [−1, 1).
    pub fn symmetric(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
    /// A unit vector, uniform on the sphere.
    pub fn direction(&mut self) -> [f64; 3] {
        loop {
            let v = [self.symmetric(), self.symmetric(), self.symmetric()];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if n > 0.1 && n <= 1.0 {
                return [v[0] / n, v[1] / n, v[2] / n];
            }
        }
    }
}

/// Sample points `(d, l)` with `|d| l = x`.
pub(crate) fn samples(x: f64, n: usize, seed: u64) -> Vec<([f64; 3], f64)> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|i| {
            let l = if i % 2 == 0 { 1.0 } else { 0.01 };
            let e = rng.direction();
            ([e[0] * x / l, e[1] * x / l, e[2] * x / l], l)
        })
        .collect()
}

/// Values of `ids` at every sample: `out[sample][output]`.
pub(crate) fn evaluate(
    g: &Graph,
    h: &HelixSymbols,
    ids: &[Id],
    pts: &[([f64; 3], f64)],
) -> Vec<Vec<f64>> {
    let ev = g.evaluator(ids);
    pts.iter()
        .map(|(d, l)| ev.eval(g, &h.bindings(*d, *l, 0.0)))
        .collect()
}

/// Largest relative difference between `a` and the reference `b` (see the module
/// docs), over all samples and outputs.
pub(crate) fn max_relative(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    let k = b.first().map_or(0, |v| v.len());
    let mut worst = 0.0f64;
    for j in 0..k {
        let scale = b.iter().map(|v| v[j].abs()).fold(0.0, f64::max);
        if scale == 0.0 {
            let any = a.iter().any(|v| v[j] != 0.0);
            if any {
                return f64::INFINITY;
            }
            continue;
        }
        for (va, vb) in a.iter().zip(b) {
            worst = worst.max((va[j] - vb[j]).abs() / scale);
        }
    }
    worst
}

/// The chosen switch and what was measured there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwitchChoice {
    /// `x*`: the Taylor branch is used for `W l < x*`.
    pub x_star: f64,
    /// Degree in W of the Taylor branch.
    pub order: u32,
    /// Largest relative difference of the two branches at `x*` (all samples).
    pub agreement: f64,
    /// Estimated largest relative truncation error of the Taylor branch at `x*`.
    pub truncation: f64,
}

/// Targets and search ranges of the switch selection.
#[derive(Clone, Debug, PartialEq)]
pub struct SwitchOptions {
    /// Required agreement of the branches at `x*` (relative).
    pub agreement_target: f64,
    /// Required truncation error of the Taylor branch below `x*` (relative).
    pub truncation_target: f64,
    /// A candidate is taken if its measured agreement is within `safety` times the
    /// target (margin for directions not sampled).
    pub safety: f64,
    /// Candidates for `x*`, tried in increasing order.
    pub candidates: Vec<f64>,
    /// Number of sampled directions during the selection.
    pub samples: usize,
    /// Number of directions (another seed) that confirm a candidate; the reported
    /// agreement is the worst over both sets.
    pub check_samples: usize,
    /// Smallest and largest Taylor order tried.
    pub min_order: u32,
    /// See `min_order`.
    pub max_order: u32,
    /// Seed of the sampled directions.
    pub seed: u64,
}

impl Default for SwitchOptions {
    fn default() -> SwitchOptions {
        SwitchOptions {
            agreement_target: 1e-14,
            truncation_target: 1e-15,
            safety: 0.5,
            candidates: vec![
                0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0,
                5.0, 6.0,
            ],
            samples: 8,
            check_samples: 64,
            min_order: 2,
            max_order: 64,
            seed: 0x5eed_cafe,
        }
    }
}

/// Builds the Taylor branch of every output at a given order.
pub(crate) type SeriesBuilder<'a> =
    dyn FnMut(&mut Graph, u32) -> Result<Vec<Id>, crate::CodegenError> + 'a;

/// Pick `x*` and the Taylor order (see the module docs). `series(g, order)` builds the
/// Taylor branch of every output at a given order; `closed` are the closed forms.
pub(crate) fn choose(
    g: &mut Graph,
    h: &HelixSymbols,
    closed: &[Id],
    series: &mut SeriesBuilder<'_>,
    opts: &SwitchOptions,
) -> Result<SwitchChoice, crate::CodegenError> {
    let mut order = opts.min_order;
    let mut best: Option<SwitchChoice> = None;
    for &x in &opts.candidates {
        let pts = samples(x, opts.samples, opts.seed);
        let trunc = loop {
            let reference = series(g, order + 8)?;
            let s = series(g, order)?;
            let r = evaluate(g, h, &reference, &pts);
            let sv = evaluate(g, h, &s, &pts);
            let t = max_relative(&sv, &r);
            if t <= opts.truncation_target || order + 2 > opts.max_order {
                break t;
            }
            order += 2;
        };
        if trunc > opts.truncation_target {
            break;
        }
        let s = series(g, order)?;
        let sv = evaluate(g, h, &s, &pts);
        let cv = evaluate(g, h, closed, &pts);
        let agreement = max_relative(&cv, &sv);
        let c = SwitchChoice {
            x_star: x,
            order,
            agreement,
            truncation: trunc,
        };
        if best.is_none_or(|b| agreement < b.agreement) {
            best = Some(c);
        }
        if agreement <= opts.safety * opts.agreement_target {
            // confirm on more directions (another seed) before taking it
            let more = samples(x, opts.check_samples, opts.seed ^ 0xa5a5);
            let check = max_relative(&evaluate(g, h, closed, &more), &evaluate(g, h, &s, &more));
            if check <= opts.agreement_target {
                return Ok(SwitchChoice {
                    agreement: check.max(agreement),
                    ..c
                });
            }
        }
    }
    Err(crate::CodegenError::NoSwitch(format!(
        "no candidate x* meets agreement {:e} with truncation {:e}; best: {:?}",
        opts.agreement_target, opts.truncation_target, best
    )))
}
