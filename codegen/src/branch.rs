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
//! With `confirm_next`, a candidate is taken only if the next candidate passes as well
//! (a guard against directions the samples missed).
//!
//! Relative error of output j: `|a_j − b_j| / s_j`, with `s_j` the largest `|b_j|`
//! over the sampled directions at the same `x` — relative to the size of that
//! integral at that `W l`, not to a value that happens to be small for one direction
//! ([`Measure::Output`]); or, with [`Measure::Group`], `s_j` the largest such size over
//! the outputs of j's group (the entries of one tensor), which is the error an
//! assembly contracting the whole tensor sees. Samples: pseudo-random unit directions
//! of d (seeded, reproducible), `|d| = x/l`, with l alternating between 1 and 0.01.

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

/// Relative difference between `a` and the reference `b` of every output (see the
/// module docs), the worst over all samples. `groups[j]` is the group of output j: the
/// scale of an output is the largest `|b|` over the samples and over the outputs of its
/// group (one group per output: the per-output measure). An output whose scale is zero
/// has difference 0 if `a` is zero there too, else infinity.
pub(crate) fn relative_per_output(a: &[Vec<f64>], b: &[Vec<f64>], groups: &[usize]) -> Vec<f64> {
    let k = b.first().map_or(0, |v| v.len());
    let mut group_scale: std::collections::HashMap<usize, f64> = Default::default();
    for j in 0..k {
        let s = b.iter().map(|v| v[j].abs()).fold(0.0, f64::max);
        let e = group_scale.entry(groups[j]).or_insert(0.0);
        *e = e.max(s);
    }
    (0..k)
        .map(|j| {
            let scale = group_scale[&groups[j]];
            if scale == 0.0 {
                return if a.iter().any(|v| v[j] != 0.0) {
                    f64::INFINITY
                } else {
                    0.0
                };
            }
            a.iter()
                .zip(b)
                .map(|(va, vb)| (va[j] - vb[j]).abs() / scale)
                .fold(0.0, f64::max)
        })
        .collect()
}

/// The largest of [`relative_per_output`].
pub(crate) fn max_relative(a: &[Vec<f64>], b: &[Vec<f64>], groups: &[usize]) -> f64 {
    relative_per_output(a, b, groups)
        .into_iter()
        .fold(0.0, f64::max)
}

/// The chosen switch and what was measured there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwitchChoice {
    /// `x*`: the Taylor branch is used for `W l < x*`.
    pub x_star: f64,
    /// Degree in W of the Taylor branch.
    pub order: u32,
    /// Largest relative difference of the two branches at `x*` (all samples), under
    /// the measure of the options.
    pub agreement: f64,
    /// The same under the per-output measure ([`Measure::Output`]).
    pub agreement_per_output: f64,
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
    /// What "relative" is relative to.
    pub measure: Measure,
    /// Add a second, lower-degree Taylor branch below the largest candidate whose
    /// truncation target is met at half the degree of the main one (see
    /// [`LowTier`]): nearly straight elements pay for a lower degree.
    pub low_tier: bool,
    /// Take a candidate only if the next one passes too (the closed branch stays
    /// accurate just above the switch, not only at the sampled directions of `x*`).
    pub confirm_next: bool,
}

/// The scale a difference of one output is divided by (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Measure {
    /// The largest `|value|` of that output over the sampled directions.
    Output,
    /// The largest `|value|` over the sampled directions and over every output of the
    /// same group: the outputs whose names agree up to the first `_` (e.g. all
    /// `pd2p_…`, the entries of one tensor).
    Group,
}

impl Measure {
    /// Group index of every output name under this measure.
    pub fn groups(self, names: &[&str]) -> Vec<usize> {
        match self {
            Measure::Output => (0..names.len()).collect(),
            Measure::Group => {
                let mut keys: Vec<&str> = Vec::new();
                names
                    .iter()
                    .map(|n| {
                        let k = n.split('_').next().unwrap_or(n);
                        keys.iter().position(|x| *x == k).unwrap_or_else(|| {
                            keys.push(k);
                            keys.len() - 1
                        })
                    })
                    .collect()
            }
        }
    }
}

impl std::fmt::Display for Measure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Measure::Output => "per output (largest |value| of the output over directions)",
            Measure::Group => {
                "per tensor group (largest |value| over directions and the entries of the \
                 output's group: a moment enters the assembly only through contractions of \
                 its whole tensor, so that is the scale its error is seen at)"
            }
        })
    }
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
            measure: Measure::Output,
            confirm_next: false,
            low_tier: false,
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
    groups: &[usize],
    opts: &SwitchOptions,
) -> Result<SwitchChoice, crate::CodegenError> {
    let mut order = opts.min_order;
    let mut best: Option<SwitchChoice> = None;
    let mut pending: Option<SwitchChoice> = None;
    for &x in &opts.candidates {
        let pts = samples(x, opts.samples, opts.seed);
        let trunc = loop {
            let reference = series(g, order + 8)?;
            let s = series(g, order)?;
            let r = evaluate(g, h, &reference, &pts);
            let sv = evaluate(g, h, &s, &pts);
            let t = max_relative(&sv, &r, groups);
            if t <= opts.truncation_target || order + 2 > opts.max_order {
                break t;
            }
            order += 2;
        };
        if trunc > opts.truncation_target {
            break;
        }
        let passed = pending.take();
        let s = series(g, order)?;
        let sv = evaluate(g, h, &s, &pts);
        let cv = evaluate(g, h, closed, &pts);
        let agreement = max_relative(&cv, &sv, groups);
        let c = SwitchChoice {
            x_star: x,
            order,
            agreement,
            agreement_per_output: f64::NAN,
            truncation: trunc,
        };
        if best.is_none_or(|b| agreement < b.agreement) {
            best = Some(c);
        }
        if agreement <= opts.safety * opts.agreement_target {
            // confirm on more directions (another seed) before taking it
            let mut more = samples(x, opts.check_samples, opts.seed ^ 0xa5a5);
            let (cm, sm) = (evaluate(g, h, closed, &more), evaluate(g, h, &s, &more));
            let check = max_relative(&cm, &sm, groups);
            if check <= opts.agreement_target {
                // the per-output figure on both sets, for the record
                more.extend(pts);
                let own: Vec<usize> = (0..closed.len()).collect();
                let per_output = max_relative(
                    &evaluate(g, h, closed, &more),
                    &evaluate(g, h, &s, &more),
                    &own,
                );
                let c = SwitchChoice {
                    agreement: check.max(agreement),
                    agreement_per_output: per_output,
                    ..c
                };
                if !opts.confirm_next {
                    return Ok(c);
                }
                if let Some(p) = passed {
                    return Ok(p);
                }
                pending = Some(c);
            }
        }
    }
    if let Some(p) = pending {
        return Ok(p);
    }
    Err(crate::CodegenError::NoSwitch(format!(
        "no candidate x* meets agreement {:e} with truncation {:e}; best: {:?}",
        opts.agreement_target, opts.truncation_target, best
    )))
}

/// The low-degree Taylor branch below the main one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LowTier {
    /// Switch: the low-degree branch is used for `W l < x`.
    pub x: f64,
    /// Its degree in W.
    pub order: u32,
    /// Estimated truncation error at `x` (relative, under the measure of the options).
    pub truncation: f64,
    /// Largest difference to the main Taylor branch at `x`, over the selection and
    /// the check samples (relative, under the measure of the options).
    pub agreement: f64,
}

/// The low-degree tier below the main switch `main`: the largest candidate `x < x*`
/// whose truncation target is met at an even degree ≤ half the main degree, that
/// degree, and its measured agreement with the main Taylor branch there (which differs
/// only by truncation). `None` if no candidate qualifies.
pub(crate) fn choose_low(
    g: &mut Graph,
    h: &HelixSymbols,
    series: &mut SeriesBuilder<'_>,
    groups: &[usize],
    opts: &SwitchOptions,
    main: &SwitchChoice,
) -> Result<Option<LowTier>, crate::CodegenError> {
    let limit = (main.order / 2) & !1;
    let mut order = opts.min_order;
    let mut best = None;
    for &x in opts.candidates.iter().filter(|&&x| x < main.x_star) {
        let pts = samples(x, opts.samples, opts.seed);
        let trunc = loop {
            let reference = series(g, order + 8)?;
            let s = series(g, order)?;
            let r = evaluate(g, h, &reference, &pts);
            let sv = evaluate(g, h, &s, &pts);
            let t = max_relative(&sv, &r, groups);
            if t <= opts.truncation_target || order + 2 > limit {
                break t;
            }
            order += 2;
        };
        if trunc > opts.truncation_target {
            break;
        }
        let mut all = pts;
        all.extend(samples(x, opts.check_samples, opts.seed ^ 0xa5a5));
        let low = series(g, order)?;
        let high = series(g, main.order)?;
        let agreement = max_relative(
            &evaluate(g, h, &low, &all),
            &evaluate(g, h, &high, &all),
            groups,
        );
        if agreement <= opts.agreement_target {
            best = Some(LowTier {
                x,
                order,
                truncation: trunc,
                agreement,
            });
        }
    }
    Ok(best)
}

/// One candidate of [`crate::switch_scan`]: what the switch selection measures there.
#[derive(Clone, Debug, PartialEq)]
pub struct ScanRow {
    /// Candidate `x*`.
    pub x: f64,
    /// Smallest even Taylor order meeting the truncation target at `x` (or the largest
    /// tried).
    pub order: u32,
    /// Truncation estimate at that order.
    pub truncation: f64,
    /// Agreement of the branches at `x` over both sample sets, under the measure of the
    /// options.
    pub agreement: f64,
    /// Index of the output with the worst agreement.
    pub worst: usize,
}

/// Measure every candidate (no early exit), for diagnostics.
pub(crate) fn scan(
    g: &mut Graph,
    h: &HelixSymbols,
    closed: &[Id],
    series: &mut SeriesBuilder<'_>,
    groups: &[usize],
    opts: &SwitchOptions,
) -> Result<Vec<ScanRow>, crate::CodegenError> {
    let mut order = opts.min_order;
    let mut rows = Vec::new();
    for &x in &opts.candidates {
        let pts = samples(x, opts.samples, opts.seed);
        let trunc = loop {
            let reference = series(g, order + 8)?;
            let s = series(g, order)?;
            let r = evaluate(g, h, &reference, &pts);
            let sv = evaluate(g, h, &s, &pts);
            let t = max_relative(&sv, &r, groups);
            if t <= opts.truncation_target || order + 2 > opts.max_order {
                break t;
            }
            order += 2;
        };
        let s = series(g, order)?;
        let mut all = pts;
        all.extend(samples(x, opts.check_samples, opts.seed ^ 0xa5a5));
        let sv = evaluate(g, h, &s, &all);
        let cv = evaluate(g, h, closed, &all);
        let per = relative_per_output(&cv, &sv, groups);
        let worst = (0..per.len())
            .max_by(|&a, &b| per[a].total_cmp(&per[b]))
            .unwrap_or(0);
        rows.push(ScanRow {
            x,
            order,
            truncation: trunc,
            agreement: per.get(worst).copied().unwrap_or(0.0),
            worst,
        });
    }
    Ok(rows)
}
