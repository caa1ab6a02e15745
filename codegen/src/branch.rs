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
//!
//! # f32
//! With [`Float::F32`] the measurement is the one the f32 code needs: the sample points
//! are rounded to f32 (the inputs the code sees), and each branch is evaluated *in f32
//! arithmetic* ([`crate::graph::Evaluator::eval_f32`]) and compared with an f64
//! reference at the same inputs: the Taylor series of degree `N + 8` evaluated in f64
//! (its truncation and round-off are far below f32's). The truncation of the Taylor
//! branch is still measured in f64, as above, against the f32 targets
//! ([`SwitchOptions::for_f32`]). A candidate is taken when the larger of the two
//! branches' errors (their "agreement") is within the targets; errors are relative to
//! the largest `|reference|` of the output's group *at the same sample point* (stricter
//! than the scale over all directions: an element whose entries are all small is
//! measured at its own size).

use crate::float::Float;
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

/// [`samples`] rounded to `float` (the inputs generated code of that type sees).
pub(crate) fn samples_in(x: f64, n: usize, seed: u64, float: Float) -> Vec<([f64; 3], f64)> {
    let mut pts = samples(x, n, seed);
    for (d, l) in pts.iter_mut() {
        *d = d.map(|v| float.round(v));
        *l = float.round(*l);
    }
    pts
}

/// Values of `ids` at every sample evaluated in `float` arithmetic (f32: the bindings
/// computed as the f32 prologue does, [`HelixSymbols::bindings_f32`]).
pub(crate) fn evaluate_in(
    g: &Graph,
    h: &HelixSymbols,
    ids: &[Id],
    pts: &[([f64; 3], f64)],
    float: Float,
) -> Vec<Vec<f64>> {
    match float {
        Float::F64 => evaluate(g, h, ids, pts),
        Float::F32 => {
            let ev = g.evaluator(ids);
            pts.iter()
                .map(|(d, l)| ev.eval_f32(g, &h.bindings_f32(*d, *l, 0.0)))
                .collect()
        }
    }
}

/// Relative difference between `a` and the reference `b` of every output, the worst
/// over all samples, with the scale taken *per sample*: the largest `|b|` over the
/// outputs of the group at that sample (see the module docs, "f32"). A sample whose
/// group scale is zero counts 0 if `a` is zero there too, else infinity.
pub(crate) fn relative_per_point(a: &[Vec<f64>], b: &[Vec<f64>], groups: &[usize]) -> Vec<f64> {
    let k = b.first().map_or(0, |v| v.len());
    let ng = groups.iter().copied().max().map_or(0, |m| m + 1);
    let mut worst = vec![0.0f64; k];
    for (va, vb) in a.iter().zip(b) {
        let mut scale = vec![0.0f64; ng];
        for j in 0..k {
            scale[groups[j]] = scale[groups[j]].max(vb[j].abs());
        }
        for j in 0..k {
            let e = (va[j] - vb[j]).abs();
            let r = if e == 0.0 {
                0.0
            } else if scale[groups[j]] > 0.0 {
                e / scale[groups[j]]
            } else {
                f64::INFINITY
            };
            worst[j] = worst[j].max(r);
        }
    }
    worst
}

fn max_of(v: &[f64]) -> f64 {
    v.iter().copied().fold(0.0, f64::max)
}

/// The errors of the Taylor branch `s` and of the closed form `closed`, evaluated in
/// f32 at `pts`, against the f64 values `reference` there ([`relative_per_point`] per
/// output under `groups`).
fn f32_errors(
    g: &Graph,
    h: &HelixSymbols,
    closed: &[Id],
    s: &[Id],
    reference: &[Vec<f64>],
    pts: &[([f64; 3], f64)],
    groups: &[usize],
) -> (Vec<f64>, Vec<f64>) {
    let sv = evaluate_in(g, h, s, pts, Float::F32);
    let cv = evaluate_in(g, h, closed, pts, Float::F32);
    (
        relative_per_point(&sv, reference, groups),
        relative_per_point(&cv, reference, groups),
    )
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
    /// With [`Float::F32`]: the largest error of the Taylor branch in f32 at `x*`
    /// against the f64 reference, over both sample sets (per point and group, see the
    /// module docs); NaN for f64.
    pub series_error: f64,
    /// The same for the closed form in f32.
    pub closed_error: f64,
    /// Whether the agreement target was met (always, for f64: without, there is no
    /// switch); with [`Float::F32`], `false` means that no candidate met it and the
    /// switch is the one of smallest error (`pick_f32`).
    pub target_met: bool,
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

impl SwitchOptions {
    /// These options with the targets of f32 code ([`Float::F32`]): a truncation
    /// target of one f32 unit round-off (`2^-24`, the Taylor branch as exact as one f32
    /// operation) and an agreement target of 16 round-offs (`2^-20`, about what the
    /// f64 targets are in f64 round-offs: 1e-15 ≈ 9 and 1e-14 ≈ 90 units of `2^-53`,
    /// both scaled to f32's), which the error of either f32 branch against the f64
    /// reference must meet at the switch.
    pub fn for_f32(mut self) -> SwitchOptions {
        let u = Float::F32.unit_roundoff();
        self.truncation_target = u;
        self.agreement_target = 16.0 * u;
        self
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
    float: Float,
) -> Result<SwitchChoice, crate::CodegenError> {
    if float == Float::F32 {
        return choose_f32(g, h, closed, series, groups, opts);
    }
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
            series_error: f64::NAN,
            closed_error: f64::NAN,
            target_met: true,
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

/// The smallest even order from `*order` up whose truncation at `pts` (against the
/// series of order + 8, in f64) is within the target, or the largest tried; with its
/// truncation.
#[allow(clippy::too_many_arguments)]
fn order_for(
    g: &mut Graph,
    h: &HelixSymbols,
    series: &mut SeriesBuilder<'_>,
    groups: &[usize],
    pts: &[([f64; 3], f64)],
    order: &mut u32,
    limit: u32,
    target: f64,
) -> Result<f64, crate::CodegenError> {
    loop {
        let reference = series(g, *order + 8)?;
        let s = series(g, *order)?;
        let r = evaluate(g, h, &reference, pts);
        let sv = evaluate(g, h, &s, pts);
        let t = max_relative(&sv, &r, groups);
        if t <= target || *order + 2 > limit {
            return Ok(t);
        }
        *order += 2;
    }
}

/// What the f32 selection measured at one candidate switch: the errors of the two
/// branches computed in f32 against the f64 reference, on the selection samples and
/// on all samples (selection and check sets).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct F32Candidate {
    /// The candidate `x*`.
    pub x: f64,
    /// Error of the Taylor branch on the selection samples.
    pub series_sel: f64,
    /// Error of the closed form on the selection samples.
    pub closed_sel: f64,
    /// Error of the Taylor branch on all samples.
    pub series_all: f64,
    /// Error of the closed form on all samples.
    pub closed_all: f64,
}

/// The f32 selection rule over the measured candidates (in increasing order): the
/// error of candidate i is the larger error of its Taylor branch at `x_i` and of the
/// closed form at `x_i` and (with `confirm_next`) at `x_{i+1}` — what the function errs
/// by just below and just above the switch. The first candidate whose error is within
/// `safety · target` on the selection samples and within `target` on all samples is
/// taken, as for f64; when none is (the f32 closed forms do not reach a few f32
/// round-offs anywhere on the candidate range), the one with the smallest error on all
/// samples, where the two branches' error curves cross. Returns the index, its error
/// on all samples, and whether the target was met. `None` without candidates.
pub(crate) fn pick_f32(
    c: &[F32Candidate],
    target: f64,
    safety: f64,
    confirm_next: bool,
) -> Option<(usize, f64, bool)> {
    // (Taylor, closed) on the selection samples or on all
    let at = |k: usize, sel: bool| {
        if sel {
            (c[k].series_sel, c[k].closed_sel)
        } else {
            (c[k].series_all, c[k].closed_all)
        }
    };
    let err = |i: usize, sel: bool| {
        let (s, cl) = at(i, sel);
        let next = if confirm_next && i + 1 < c.len() {
            at(i + 1, sel).1
        } else {
            0.0
        };
        s.max(cl).max(next)
    };
    // with confirm_next, the last candidate has no next to confirm it
    let usable = if confirm_next && c.len() > 1 {
        c.len() - 1
    } else {
        c.len()
    };
    if let Some(i) =
        (0..usable).find(|&i| err(i, true) <= safety * target && err(i, false) <= target)
    {
        return Some((i, err(i, false), true));
    }
    (0..usable)
        .min_by(|&a, &b| err(a, false).total_cmp(&err(b, false)))
        .map(|i| (i, err(i, false), false))
}

/// [`choose`] for [`Float::F32`] (see the module docs, "f32" and [`pick_f32`]): every
/// candidate measured (up to the first whose truncation target no order up to
/// `max_order` meets), the Taylor order from the truncation target as for f64, each
/// branch in f32 against the f64 reference (the Taylor series of degree `order + 8` in
/// f64).
fn choose_f32(
    g: &mut Graph,
    h: &HelixSymbols,
    closed: &[Id],
    series: &mut SeriesBuilder<'_>,
    groups: &[usize],
    opts: &SwitchOptions,
) -> Result<SwitchChoice, crate::CodegenError> {
    let float = Float::F32;
    let mut order = opts.min_order;
    let mut measured: Vec<(F32Candidate, u32, f64)> = Vec::new();
    for &x in &opts.candidates {
        let pts = samples_in(x, opts.samples, opts.seed, float);
        let trunc = order_for(
            g,
            h,
            series,
            groups,
            &pts,
            &mut order,
            opts.max_order,
            opts.truncation_target,
        )?;
        if trunc > opts.truncation_target {
            break;
        }
        let mut all = pts.clone();
        all.extend(samples_in(x, opts.check_samples, opts.seed ^ 0xa5a5, float));
        let s = series(g, order)?;
        let reference = series(g, order + 8)?;
        let rv = evaluate(g, h, &reference, &all);
        let (es, ec) = f32_errors(g, h, closed, &s, &rv, &all, groups);
        let n = pts.len();
        let (ss, cs) = f32_errors(g, h, closed, &s, &rv[..n], &pts, groups);
        measured.push((
            F32Candidate {
                x,
                series_sel: max_of(&ss),
                closed_sel: max_of(&cs),
                series_all: max_of(&es),
                closed_all: max_of(&ec),
            },
            order,
            trunc,
        ));
    }
    let cands: Vec<F32Candidate> = measured.iter().map(|m| m.0).collect();
    let Some((i, agreement, target_met)) = pick_f32(
        &cands,
        opts.agreement_target,
        opts.safety,
        opts.confirm_next,
    ) else {
        return Err(crate::CodegenError::NoSwitch(format!(
            "no candidate x* meets the (f32) truncation target {:e}",
            opts.truncation_target
        )));
    };
    let (c, order, truncation) = measured[i];
    // the per-output figure, for the record
    let mut all = samples_in(c.x, opts.samples, opts.seed, float);
    all.extend(samples_in(
        c.x,
        opts.check_samples,
        opts.seed ^ 0xa5a5,
        float,
    ));
    let s = series(g, order)?;
    let reference = series(g, order + 8)?;
    let rv = evaluate(g, h, &reference, &all);
    let own: Vec<usize> = (0..closed.len()).collect();
    let (ps, pc) = f32_errors(g, h, closed, &s, &rv, &all, &own);
    Ok(SwitchChoice {
        x_star: c.x,
        order,
        agreement,
        agreement_per_output: max_of(&ps).max(max_of(&pc)),
        truncation,
        series_error: c.series_all,
        closed_error: c.closed_all,
        target_met,
    })
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
///
/// With [`Float::F32`] the agreement is the error of the low branch evaluated in f32
/// against the f64 reference (the series of the main degree + 8 in f64), at sample
/// points rounded to f32.
pub(crate) fn choose_low(
    g: &mut Graph,
    h: &HelixSymbols,
    series: &mut SeriesBuilder<'_>,
    groups: &[usize],
    opts: &SwitchOptions,
    main: &SwitchChoice,
    float: Float,
) -> Result<Option<LowTier>, crate::CodegenError> {
    let limit = (main.order / 2) & !1;
    let mut order = opts.min_order;
    let mut best = None;
    for &x in opts.candidates.iter().filter(|&&x| x < main.x_star) {
        if float == Float::F32 {
            let mut pts = samples_in(x, opts.samples, opts.seed, float);
            let trunc = order_for(
                g,
                h,
                series,
                groups,
                &pts,
                &mut order,
                limit,
                opts.truncation_target,
            )?;
            if trunc > opts.truncation_target {
                break;
            }
            pts.extend(samples_in(x, opts.check_samples, opts.seed ^ 0xa5a5, float));
            let low = series(g, order)?;
            let reference = series(g, main.order + 8)?;
            let rv = evaluate(g, h, &reference, &pts);
            let lv = evaluate_in(g, h, &low, &pts, float);
            let agreement = max_of(&relative_per_point(&lv, &rv, groups));
            if agreement <= opts.agreement_target {
                best = Some(LowTier {
                    x,
                    order,
                    truncation: trunc,
                    agreement,
                });
            }
            continue;
        }
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
    /// With [`Float::F32`]: the error of the Taylor branch in f32 against the f64
    /// reference over both sample sets (the agreement is the larger of this and
    /// `closed_error`); NaN for f64.
    pub series_error: f64,
    /// The same for the closed form in f32.
    pub closed_error: f64,
}

/// Measure every candidate (no early exit), for diagnostics.
pub(crate) fn scan(
    g: &mut Graph,
    h: &HelixSymbols,
    closed: &[Id],
    series: &mut SeriesBuilder<'_>,
    groups: &[usize],
    opts: &SwitchOptions,
    float: Float,
) -> Result<Vec<ScanRow>, crate::CodegenError> {
    let mut order = opts.min_order;
    let mut rows = Vec::new();
    for &x in &opts.candidates {
        if float == Float::F32 {
            let mut pts = samples_in(x, opts.samples, opts.seed, float);
            let trunc = order_for(
                g,
                h,
                series,
                groups,
                &pts,
                &mut order,
                opts.max_order,
                opts.truncation_target,
            )?;
            pts.extend(samples_in(x, opts.check_samples, opts.seed ^ 0xa5a5, float));
            let s = series(g, order)?;
            let reference = series(g, order + 8)?;
            let rv = evaluate(g, h, &reference, &pts);
            let (es, ec) = f32_errors(g, h, closed, &s, &rv, &pts, groups);
            let per: Vec<f64> = es.iter().zip(&ec).map(|(a, b)| a.max(*b)).collect();
            let worst = (0..per.len())
                .max_by(|&a, &b| per[a].total_cmp(&per[b]))
                .unwrap_or(0);
            rows.push(ScanRow {
                x,
                order,
                truncation: trunc,
                agreement: per.get(worst).copied().unwrap_or(0.0),
                worst,
                series_error: max_of(&es),
                closed_error: max_of(&ec),
            });
            continue;
        }
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
            series_error: f64::NAN,
            closed_error: f64::NAN,
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cand(x: f64, s: f64, c: f64) -> F32Candidate {
        F32Candidate {
            x,
            series_sel: s,
            closed_sel: c,
            series_all: s,
            closed_all: c,
        }
    }

    #[test]
    fn f32_pick_takes_the_first_candidate_within_the_target_else_the_smallest_error() {
        // the closed form's error falls, the Taylor branch's rises
        let c = [
            cand(1.0, 1.0, 50.0),
            cand(2.0, 2.0, 9.0),
            cand(3.0, 4.0, 3.0),
            cand(4.0, 8.0, 2.0),
            cand(5.0, 30.0, 1.0),
        ];
        // within 10 (5 on the selection samples): 3.0 (its next closed, 2.0, passes too)
        assert_eq!(pick_f32(&c, 10.0, 0.5, true), Some((2, 4.0, true)));
        // without confirm_next the same here; 2.0 fails the safety margin (9 > 5)
        assert_eq!(pick_f32(&c, 10.0, 0.5, false), Some((2, 4.0, true)));
        // with confirm_next, the next closed form counts: 2.0's error is max(2, 9, 3)
        assert_eq!(pick_f32(&c, 20.0, 0.5, true), Some((1, 9.0, true)));
        // nowhere within 1: the smallest error, max(Taylor, closed, next closed)
        assert_eq!(pick_f32(&c, 1.0, 0.5, true), Some((2, 4.0, false)));
        assert_eq!(pick_f32(&[], 1.0, 0.5, true), None);
        // one candidate: no next to confirm it, taken on its own
        assert_eq!(pick_f32(&c[..1], 1.0, 0.5, true), Some((0, 50.0, false)));
    }

    #[test]
    fn per_point_scale_is_the_group_at_that_point() {
        // two samples, two outputs in one group; the second sample is 1000 times smaller
        let b = vec![vec![1.0, 0.5], vec![1e-3, 5e-4]];
        let a = vec![vec![1.0, 0.5], vec![1e-3, 5e-4 + 1e-6]];
        let per_point = relative_per_point(&a, &b, &[0, 0]);
        assert!((per_point[1] - 1e-3).abs() < 1e-12, "{per_point:?}");
        // the f64 measure divides by the largest over the samples
        let over_samples = relative_per_output(&a, &b, &[0, 0]);
        assert!((over_samples[1] - 1e-6).abs() < 1e-15, "{over_samples:?}");
    }
}
