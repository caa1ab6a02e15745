//! Hair–hair interaction between the simulated strands (paper section 4.1): "detection is
//! efficiently processed by exploiting temporal coherence, as in [Raghupathi et al.
//! 2003]: we avoid the quadratic cost of computing proximity of guide strands by keeping
//! track of pairs of closest points over time. As in [Choe et al. 2005], contacts between
//! hair volumes are handled by dissipative penalty forces."
//!
//! Each strand is a chain of contact samples ([`super::StrandContacts::samples`]). A
//! *pair* joins a sample of one strand to a sample of another where the two centrelines
//! are locally closest (with self-contact, [`HairHair::with_self_contact`], also two
//! samples of one strand far apart along it). Before every step:
//!
//! 1. the pairs of the last step are tracked: each side walks along its chain to the
//!    sample closest to the other side (a local descent, a few samples at most when the
//!    motion is coherent), and a pair whose points drifted apart beyond the search
//!    distance is dropped;
//! 2. every `search_every` steps a broad phase finds new pairs: the samples of every
//!    strand are filed on a grid, and the sample pairs of different strands within their
//!    search distance that are local minima of the distance along both chains become
//!    pairs. Each sample searches as far as the reach plus twice its own motion over the
//!    last step, or plus |g| h² (twice a free fall from rest over one step h) when that
//!    is more (between 2 and 1 + [`SEARCH_MARGIN`] reaches); a pair within the larger of its two
//!    samples' distances is found, so a few fast samples (a whipping tip) do not widen
//!    the search of all the others;
//! 3. each pair is refined to the closest points of the two polylines near its samples
//!    (segment against segment), and gives each of its two strands a
//!    [`super::PartnerPoint`]: its own arc length there, and the other side's point and
//!    velocity (from the last two positions), which the strand's step treats as a moving
//!    ball of radius reach (a penalty along the line of centres and a damping of the
//!    relative velocity, both implicit on the strand's own side).
//!    A pair of two parts of one strand (self-contact) gives that strand one partner
//!    point naming both arc lengths: both parts move in the strand's own step, and the
//!    pair is stepped implicitly on both
//!    ([`super::PartnerPoint::partner_s`]).
//!
//! With Coulomb friction between rods ([`HairHair::with_friction`]), a pair in contact
//! holds an anchor: the relative position of its two samples when it started to stick,
//! Δ* (kept in head coordinates, so that two strands carried round by the head do not
//! slip). The tangential slip of side a is `P (x_a − x_b − Δ*)`, P the projection across
//! the line of centres n, and of side b its opposite; each side's step holds its sample
//! to the other's by a tangential spring of stiffness `k_t = ratio · k` per metre (the
//! partner's sample plus or minus Δ* is the point it is pulled to), up to
//! `μ_s f_n`. After every step the anchor is updated from where the two samples went:
//! a slip beyond the static limit `μ_s f_n / k_t = μ_s δ / ratio` (δ the overlap: the
//! limit does not depend on k or on the weight) starts sliding, and a sliding anchor is
//! dragged behind to the kinetic limit `μ_k δ / ratio`; the spring then holds the kinetic
//! force `μ_k f_n` along the slip. A pair that leaves contact loses its anchor. When a
//! side walks to another sample (tracking), Δ* is carried over so that the anchor point
//! stays where it was.
//!
//! A pair found already overlapping (at the first update, or after the two strands met
//! between two searches) is allowed its overlap ([`HairHair::with_depenetration_speed`]):
//! its reach is reduced by the allowance, which shrinks at the depenetration speed, so the
//! two strands are let apart rather than kicked apart by the whole penalty at once.
//!
//! The cost per step is linear in the number of samples (the grid) plus the pairs.

use super::config::{RodFriction, DEFAULT_MAX_PAIRS_PER_SAMPLE};
use super::strand_contacts::{PartnerAnchor, PartnerPoint};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;
use std::collections::HashMap;

/// Most margin the search adds to the reach, in reaches: two strands approaching each
/// other faster than this per step may pass without meeting (the cost of a wider search
/// grows with the cube of its radius).
pub const SEARCH_MARGIN: f64 = 4.0;

/// A pair of samples of two strands, or of one strand far apart along it (self-contact):
/// (strand, sample) each, the first lower.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
pub struct Pair {
    /// (strand, sample) of the first side.
    pub a: (usize, usize),
    /// (strand, sample) of the second side.
    pub b: (usize, usize),
}

/// The friction anchor of a pair in contact (see the module page).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
struct PairAnchor {
    /// Δ*: where side a's sample is held relative to side b's, head coordinates, m.
    offset: Vector3<f64>,
    /// Whether the pair slid over the last step.
    sliding: bool,
}

/// The tracked pairs and the broad phase.
#[derive(Debug, Clone, Default)]
pub struct HairHair {
    pairs: Vec<Pair>,
    /// The friction anchors of the pairs (same order; all `None` without friction).
    anchors: Vec<Option<PairAnchor>>,
    friction: Option<RodFriction>,
    previous: Vec<Vec<Vector3<f64>>>,
    /// The broad phase's samples by cell (kept for its allocation).
    grid: Vec<Filed>,
    /// The samples' search distances (kept for its allocation).
    radii: Vec<f64>,
    steps: usize,
    search_every: usize,
    tracked_last: usize,
    found_last: usize,
    /// Overlap allowed to a pair of strands found already overlapping (strand indices,
    /// lower first), m; it shrinks at `depenetration_speed`.
    allowance: HashMap<(usize, usize), f64>,
    depenetration_speed: f64,
    /// Self-contact: the arc length within which two samples of one strand do not
    /// interact (`None`: a strand does not touch itself).
    self_exclusion: Option<f64>,
    /// The most pairs a sample keeps (its nearest; `None`: no cap).
    pair_cap: Option<usize>,
    /// What the last update left for [`HairHair::fill_partners`]: per pair its closest
    /// points (as [`closest_on_chains`] returns) and its reach less its strands'
    /// allowance; per sample its velocity; per strand its partners as (arc length, pair)
    /// in order (strand i's from `index_start[i]` to `index_start[i + 1]`); the head's
    /// orientation and the step.
    closest: Vec<(f64, f64)>,
    /// Per pair: the arc lengths of its two closest points and the arc length it stands
    /// for (the lesser of its two samples').
    along: Vec<(f64, f64, f64)>,
    allowed: Vec<f64>,
    velocity: Vec<Vec<Vector3<f64>>>,
    index: Vec<(f64, u32)>,
    index_start: Vec<usize>,
    rotation: Matrix3<f64>,
    h: f64,
    /// The intervals of the searches within a step under a tolerance.
    pub interval: SearchInterval,
}

/// The intervals between two searches of the pairs within a step under a tolerance
/// (`[simulation] tolerance`): a strand steps against its partners' points where they
/// were at the last search, so the search follows the partners' motion
/// (`Simulation::step_by`). Kept with the pairs (a checkpoint's part).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SearchInterval {
    /// The length of the last interval (the time since the last search), s (0: none).
    pub last: f64,
    /// The interval the last one was chosen from, before it was cut to end on the step,
    /// s (0: none).
    pub proposed: f64,
}

/// What the last update did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PairCounts {
    /// Pairs after the update.
    pub pairs: usize,
    /// Pairs carried over from the step before by tracking.
    pub tracked: usize,
    /// Pairs the broad phase added.
    pub found: usize,
}

fn dist2(p: &[Vec<Vector3<f64>>], a: (usize, usize), b: (usize, usize)) -> f64 {
    (p[a.0][a.1] - p[b.0][b.1]).norm_squared()
}

/// Walk the side `which` (0: a, 1: b) of `pair` to the sample of its chain closest to the
/// other side's point.
fn descend(
    p: &[Vec<Vector3<f64>>],
    arcs: &[&[(f64, f64)]],
    exclusion: Option<f64>,
    pair: &mut Pair,
    which: usize,
) {
    loop {
        let (own, other) = if which == 0 {
            (pair.a, pair.b)
        } else {
            (pair.b, pair.a)
        };
        let here = dist2(p, own, other);
        let len = p[own.0].len();
        let mut best = (here, own.1);
        for k in [own.1.wrapping_sub(1), own.1 + 1] {
            // a side of a pair of one strand does not walk into the exclusion
            if k < len && distinct(arcs, exclusion, (own.0, k), other) {
                let d = dist2(p, (own.0, k), other);
                if d < best.0 {
                    best = (d, k);
                }
            }
        }
        if best.1 == own.1 {
            return;
        }
        if which == 0 {
            pair.a.1 = best.1;
        } else {
            pair.b.1 = best.1;
        }
    }
}

/// What [`HairHair`] carries from one step to the next (a checkpoint's part): the pairs,
/// their anchors, the samples' last positions, the step count and the allowances.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HairHairState {
    pairs: Vec<Pair>,
    anchors: Vec<Option<PairAnchor>>,
    previous: Vec<Vec<Vector3<f64>>>,
    steps: usize,
    tracked_last: usize,
    found_last: usize,
    /// The allowances sorted by pair of strands (a map has no order to write).
    allowance: Vec<((usize, usize), f64)>,
    interval: SearchInterval,
}

impl HairHair {
    /// What the next step needs of the pairs (see [`HairHairState`]).
    pub fn state(&self) -> HairHairState {
        let mut allowance: Vec<_> = self.allowance.iter().map(|(&k, &v)| (k, v)).collect();
        allowance.sort_by_key(|&(k, _)| k);
        HairHairState {
            pairs: self.pairs.clone(),
            anchors: self.anchors.clone(),
            previous: self.previous.clone(),
            steps: self.steps,
            tracked_last: self.tracked_last,
            found_last: self.found_last,
            allowance,
            interval: self.interval,
        }
    }

    /// Continue from `state` (taken of a set of pairs of the same scene).
    pub fn restore(&mut self, state: HairHairState) {
        self.pairs = state.pairs;
        self.anchors = state.anchors;
        self.previous = state.previous;
        self.steps = state.steps;
        self.tracked_last = state.tracked_last;
        self.found_last = state.found_last;
        self.allowance = state.allowance.into_iter().collect();
        self.interval = state.interval;
    }

    /// The largest distance a sample of a pair moved since the last update (where the
    /// strand on the pair's other side saw it over the interval), over the length of that
    /// strand: `points` the samples' positions now (world, as [`Self::update`] takes
    /// them), `lengths` the strands' lengths. 0 without pairs or before a first update.
    pub fn partner_motion(&self, points: &[Vec<Vector3<f64>>], lengths: &[f64]) -> f64 {
        let moved = |(s, k): (usize, usize)| match (self.previous.get(s), points.get(s)) {
            (Some(prev), Some(now)) if prev.len() == now.len() && k < now.len() => {
                (now[k] - prev[k]).norm()
            }
            _ => 0.0,
        };
        let length = |s: usize| lengths.get(s).copied().unwrap_or(f64::INFINITY);
        self.pairs
            .iter()
            .map(|p| (moved(p.b) / length(p.a.0)).max(moved(p.a) / length(p.b.0)))
            .fold(0.0, f64::max)
    }

    /// The largest distance any sample moved since the last update, m (0 before a first
    /// update): `points` as [`Self::partner_motion`] takes them.
    pub fn fastest_motion(&self, points: &[Vec<Vector3<f64>>]) -> f64 {
        points
            .iter()
            .zip(&self.previous)
            .filter(|(now, prev)| now.len() == prev.len())
            .flat_map(|(now, prev)| now.iter().zip(prev).map(|(a, b)| (a - b).norm()))
            .fold(0.0, f64::max)
    }

    /// An empty set of pairs; the broad phase runs every `search_every` steps.
    pub fn new(search_every: usize) -> Self {
        HairHair {
            search_every: search_every.max(1),
            pair_cap: Some(DEFAULT_MAX_PAIRS_PER_SAMPLE),
            ..Default::default()
        }
    }

    /// Keep at most `cap` pairs per sample: a pair is kept while it is among the `cap`
    /// nearest pairs of either of its two samples (default
    /// [`DEFAULT_MAX_PAIRS_PER_SAMPLE`]). The pairs are then at most `cap` times the
    /// samples, whatever the density of the hair.
    pub fn with_pair_cap(mut self, cap: usize) -> Self {
        self.pair_cap = Some(cap.max(1));
        self
    }

    /// Let two strands that are found already overlapping (at the first update, or on
    /// first meeting between two searches) apart at `speed` (m/s) rather than kick them
    /// apart: their overlap when found is allowed (no force), and the allowance shrinks by
    /// `speed` per second and to their present overlap (0, the default: no allowance, any
    /// overlap is pushed out at once).
    pub fn with_depenetration_speed(mut self, speed: f64) -> Self {
        self.depenetration_speed = speed;
        self
    }

    /// Let distant parts of one strand touch (a rope piling up, a coil, a plectoneme):
    /// pairs of samples of one strand more than `exclusion` apart in arc length are
    /// found and tracked as pairs of two strands are (default: none).
    pub fn with_self_contact(mut self, exclusion: f64) -> Self {
        self.self_exclusion = Some(exclusion);
        self
    }

    /// Coulomb friction between the strands (and the parts of a strand) in contact
    /// (default: none; the penalty's damping then acts along the line of centres only).
    pub fn with_friction(mut self, friction: RodFriction) -> Self {
        self.friction = Some(friction);
        self
    }

    /// How many pairs hold a friction anchor, and how many of those slid over the last
    /// step.
    pub fn anchor_counts(&self) -> (usize, usize) {
        let held = self.anchors.iter().flatten().count();
        let sliding = self.anchors.iter().flatten().filter(|a| a.sliding).count();
        (held, sliding)
    }

    /// The current pairs.
    pub fn pairs(&self) -> &[Pair] {
        &self.pairs
    }

    /// What the last update did.
    pub fn counts(&self) -> PairCounts {
        PairCounts {
            pairs: self.pairs.len(),
            tracked: self.tracked_last,
            found: self.found_last,
        }
    }

    /// Update the pairs for the sample positions `points` (world, per strand per sample;
    /// `arcs` their arc lengths and weights) with interaction distance `reach`, and give
    /// each strand its partner points for the coming step of `h` seconds (the velocities
    /// from the positions of the last update, `since` seconds ago; zero at the first).
    /// `fall` is how far a point starting at rest may move in the coming step (|g| h²:
    /// twice the free fall), the least margin of the search. `rotation` is the
    /// head's orientation (friction anchors are kept in head coordinates).
    pub fn update(
        &mut self,
        points: &[Vec<Vector3<f64>>],
        arcs: &[&[(f64, f64)]],
        reach: f64,
        (h, since): (f64, f64),
        fall: f64,
        rotation: &Matrix3<f64>,
    ) {
        // the search reaches as far as the two samples of a pair moved over the last
        // step, twice the larger (a pair must exist before the two points meet: the step
        // that brings them together is split by the strand's contact check until it
        // resolves the approach)
        let motion: Vec<Vec<f64>> = points
            .par_iter()
            .enumerate()
            .map(|(i, chain)| match self.previous.get(i) {
                Some(prev) if prev.len() == chain.len() => chain
                    .iter()
                    .zip(prev)
                    .map(|(x, y)| (x - y).norm())
                    .collect(),
                _ => vec![0.0; chain.len()],
            })
            .collect();
        let margin = |m: f64| (2.0 * m).max(fall).clamp(reach, SEARCH_MARGIN * reach);
        let radius: Vec<Vec<f64>> = motion
            .iter()
            .map(|chain| chain.iter().map(|&m| reach + margin(m)).collect())
            .collect();
        let search2 = |a: (usize, usize), b: (usize, usize)| {
            let r = radius[a.0][a.1].max(radius[b.0][b.1]);
            r * r
        };
        // 1. track (a pair's anchor goes with it: Δ* is carried to the samples it walks to)
        let rt = rotation.transpose();
        let mut anchors = std::mem::take(&mut self.anchors);
        anchors.resize(self.pairs.len(), None);
        // each pair is then keyed by the samples nearest its closest points (a contact
        // is keyed by the samples nearest its two closest points: two sample pairs that
        // are both local minima of the samples' distance around one crossing (the
        // diagonal neighbours (i, j) and (i + 1, j + 1) of two rods crossing at an
        // angle) refine to the same closest points and are one contact, not two (as two
        // they pressed twice, and as one of them came and went with the motion the
        // crossing's force jumped: two ropes crossing at rest were kept swinging))
        let exclusion = self.self_exclusion;
        let carried: Vec<(Keyed, bool)> = self
            .pairs
            .par_iter()
            .zip(&anchors)
            .filter(|(p, _)| {
                p.a.0 < points.len()
                    && p.b.0 < points.len()
                    && p.a.1 < points[p.a.0].len()
                    && p.b.1 < points[p.b.0].len()
            })
            .filter_map(|(p, anchor)| {
                let start = *p;
                let mut p = *p;
                for _ in 0..4 {
                    let before = p;
                    descend(points, arcs, exclusion, &mut p, 0);
                    descend(points, arcs, exclusion, &mut p, 1);
                    if p == before {
                        break;
                    }
                }
                // a pair whose points drifted apart beyond the search is dropped, and a
                // pair of one strand whose sides slid together within the exclusion is
                // no contact
                if dist2(points, p.a, p.b) >= search2(p.a, p.b)
                    || !distinct(arcs, exclusion, p.a, p.b)
                {
                    return None;
                }
                let anchor = anchor.map(|mut a| {
                    if p != start {
                        let moved = (points[p.a.0][p.a.1] - points[start.a.0][start.a.1])
                            - (points[p.b.0][p.b.1] - points[start.b.0][start.b.1]);
                        a.offset += rt * moved;
                    }
                    a
                });
                let keyed = to_closest(p, anchor, false, points, arcs, exclusion, &rt);
                let moved = keyed.pair != start;
                Some((keyed, moved))
            })
            .collect();
        // two pairs tracked to the same samples are one: the one that holds an anchor is
        // kept (the anchored first), so that a contact sliding across the samples keeps
        // its friction
        let mut keyed = in_order(carried, |k| (k.pair, k.anchor.is_none()));
        keyed.dedup_by_key(|k| k.pair);
        self.tracked_last = keyed.len();
        // the pairs of strands already in contact: a pair the search finds between them
        // again is no new meeting and takes no allowance
        // (their strands kept as they are; sorted only when a fresh pair overlaps)
        let mut known: Vec<(usize, usize)> = if self.depenetration_speed > 0.0 {
            keyed.iter().map(|k| (k.pair.a.0, k.pair.b.0)).collect()
        } else {
            Vec::new()
        };
        let mut known_sorted = false;
        // 2. broad phase
        let mut found = 0;
        if self.steps % self.search_every == 0 {
            // the grid's cells as large as the search of nine samples in ten (at least the
            // smallest search): the others look further, over more cells
            let mut radii = std::mem::take(&mut self.radii);
            radii.clear();
            radii.extend(radius.iter().flatten().copied());
            let cell = if radii.is_empty() {
                reach + margin(0.0)
            } else {
                let n = (radii.len() - 1) * 9 / 10;
                let (_, q, _) = radii.select_nth_unstable_by(n, |a, b| a.total_cmp(b));
                q.max(reach + margin(0.0))
            };
            self.radii = radii;
            let new_pairs = broad_phase(
                points,
                arcs,
                exclusion,
                &radius,
                cell,
                self.pair_cap.unwrap_or(usize::MAX),
                &mut self.grid,
            );
            // the pairs not tracked already, keyed as the tracked ones are and in order
            let tracked = &keyed;
            let mut fresh: Vec<Keyed> = new_pairs
                .into_par_iter()
                .filter(|p| tracked.binary_search_by(|k| k.pair.cmp(p)).is_err())
                .map(|p| to_closest(p, None, true, points, arcs, exclusion, &rt))
                .collect();
            found = fresh.len();
            fresh.sort_unstable_by_key(|k| k.pair);
            fresh.dedup_by_key(|k| k.pair);
            // both lists are sorted: merged (a pair keyed as a tracked one is that one)
            if !fresh.is_empty() {
                let mut merged = Vec::with_capacity(keyed.len() + fresh.len());
                let mut fresh = fresh.into_iter().peekable();
                for k in keyed {
                    while let Some(f) = fresh.next_if(|f| f.pair <= k.pair) {
                        if f.pair != k.pair {
                            merged.push(f);
                        }
                    }
                    merged.push(k);
                }
                merged.extend(fresh);
                keyed = merged;
            }
        }
        // the cap: the pairs tracked to new samples and those found may crowd a sample
        if let Some(cap) = self.pair_cap {
            keyed = keep_nearest(keyed, |k| k.pair, points, cap);
        }
        self.found_last = found;
        self.steps += 1;
        // 3. partners
        let mut tracked = Vec::with_capacity(keyed.len());
        let mut anchors = Vec::with_capacity(keyed.len());
        let mut closest = std::mem::take(&mut self.closest);
        closest.clear();
        let mut fresh_pair = Vec::with_capacity(keyed.len());
        for k in keyed {
            tracked.push(k.pair);
            anchors.push(k.anchor);
            closest.push(k.closest);
            fresh_pair.push(k.fresh);
        }
        // the allowances: a pair that is found already overlapping (at the first update,
        // or after the two strands met between two searches) is allowed its overlap, so
        // that it is let apart at the depenetration speed rather than pushed apart by its
        // whole penalty at once; an allowance shrinks by that speed and to the pair's
        // present overlap
        if self.depenetration_speed > 0.0 {
            let mut overlap: HashMap<(usize, usize), f64> = HashMap::new();
            let mut fresh: HashMap<(usize, usize), f64> = HashMap::new();
            for (index, (p, &(ta, tb))) in tracked.iter().zip(&closest).enumerate() {
                let depth = reach - (point_at(points, p.a, ta) - point_at(points, p.b, tb)).norm();
                if depth <= 0.0 {
                    continue;
                }
                let key = (p.a.0, p.b.0);
                let o = overlap.entry(key).or_insert(0.0);
                *o = o.max(depth);
                if fresh_pair[index] && {
                    if !known_sorted {
                        known.sort_unstable();
                        known.dedup();
                        known_sorted = true;
                    }
                    known.binary_search(&key).is_err()
                } {
                    let f = fresh.entry(key).or_insert(0.0);
                    *f = f.max(depth);
                }
            }
            let shrink = self.depenetration_speed * h;
            self.allowance.retain(|k, a| {
                *a = a.min(overlap.get(k).copied().unwrap_or(0.0)) - shrink;
                *a > 0.0
            });
            for (k, f) in fresh {
                let a = self.allowance.entry(k).or_insert(0.0);
                *a = a.max(f);
            }
        }
        drop(fresh_pair);
        // the reach of each pair: its strands' reach less their allowance (most steps
        // there is none)
        let allowance = &self.allowance;
        let mut allowed = std::mem::take(&mut self.allowed);
        allowed.clear();
        allowed.extend(tracked.iter().map(|p| {
            if allowance.is_empty() {
                reach
            } else {
                reach - allowance.get(&(p.a.0, p.b.0)).copied().unwrap_or(0.0)
            }
        }));
        // the friction anchors, from where the samples went over the last step
        let friction = self.friction;
        anchors
            .par_iter_mut()
            .zip(&tracked)
            .zip(&closest)
            .zip(&allowed)
            .for_each(|(((anchor, p), &(ta, tb)), &reach)| {
                let Some(f) = friction else {
                    *anchor = None;
                    return;
                };
                let line = point_at(points, p.a, ta) - point_at(points, p.b, tb);
                let d = line.norm();
                if d >= reach || d == 0.0 {
                    *anchor = None;
                    return;
                }
                let overlap = reach - d;
                let delta = rt * (points[p.a.0][p.a.1] - points[p.b.0][p.b.1]);
                let n = rt * line / d;
                *anchor = Some(match *anchor {
                    None => PairAnchor {
                        offset: delta,
                        sliding: false,
                    },
                    Some(a) => {
                        let gap = delta - a.offset;
                        let slip = gap - n * n.dot(&gap);
                        let norm = slip.norm();
                        let keep = f.kinetic_coefficient * overlap / f.stiffness_ratio;
                        let limit = f.static_coefficient * overlap / f.stiffness_ratio;
                        let slides = if a.sliding { norm > keep } else { norm > limit };
                        if slides && norm > 0.0 {
                            PairAnchor {
                                offset: a.offset + slip * (1.0 - keep / norm),
                                sliding: true,
                            }
                        } else {
                            PairAnchor {
                                offset: a.offset,
                                sliding: false,
                            }
                        }
                    }
                });
            });
        // the velocities of the samples, from their positions of the last update
        let previous = &self.previous;
        let mut velocity = std::mem::take(&mut self.velocity);
        velocity.resize(points.len(), Vec::new());
        velocity.par_iter_mut().enumerate().for_each(|(s, v)| {
            v.clear();
            match previous.get(s) {
                Some(prev) if since > 0.0 && prev.len() == points[s].len() => {
                    v.extend(points[s].iter().zip(prev).map(|(x, x0)| (x - x0) / since))
                }
                _ => v.resize(points[s].len(), Vector3::zeros()),
            }
        });
        self.velocity = velocity;
        // each strand's partners in the order of their arc lengths along it (a pair of
        // two parts of one strand acts on it through its first side; ties in the order
        // of the pairs): (arc length, pair), strand by strand
        let arc_at = |(s, k): (usize, usize), t: f64| {
            let j = if t < 0.0 { k.wrapping_sub(1) } else { k + 1 };
            let arc = arcs[s][k].0;
            let arc2 = arcs[s].get(j).map_or(arc, |a| a.0);
            arc + (arc2 - arc) * t.abs()
        };
        let mut start = std::mem::take(&mut self.index_start);
        start.clear();
        start.resize(points.len() + 1, 0);
        for p in &tracked {
            start[p.a.0 + 1] += 1;
            if p.a.0 != p.b.0 {
                start[p.b.0 + 1] += 1;
            }
        }
        for i in 0..points.len() {
            start[i + 1] += start[i];
        }
        let mut along = std::mem::take(&mut self.along);
        along.clear();
        along.extend(tracked.iter().zip(&closest).map(|(p, &(ta, tb))| {
            let weight = arcs[p.a.0][p.a.1].1.min(arcs[p.b.0][p.b.1].1);
            (arc_at(p.a, ta), arc_at(p.b, tb), weight)
        }));
        let mut index = std::mem::take(&mut self.index);
        index.clear();
        index.resize(start[points.len()], (0.0, 0));
        let mut cursor: Vec<usize> = start[..points.len()].to_vec();
        for (i, (p, &(sa, sb, _))) in tracked.iter().zip(&along).enumerate() {
            index[cursor[p.a.0]] = (sa, i as u32);
            cursor[p.a.0] += 1;
            if p.a.0 != p.b.0 {
                index[cursor[p.b.0]] = (sb, i as u32);
                cursor[p.b.0] += 1;
            }
        }
        drop(cursor);
        {
            let mut lists: Vec<&mut [(f64, u32)]> = Vec::with_capacity(points.len());
            let mut rest = &mut index[..];
            for w in start.windows(2) {
                let (list, tail) = rest.split_at_mut(w[1] - w[0]);
                lists.push(list);
                rest = tail;
            }
            lists.par_iter_mut().for_each(|list| {
                if !list.windows(2).all(|w| w[0].0.total_cmp(&w[1].0).is_le()) {
                    list.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
                }
            });
        }
        self.index = index;
        self.index_start = start;
        self.along = along;
        self.closest = closest;
        self.allowed = allowed;
        self.rotation = *rotation;
        self.h = h;
        self.pairs = tracked;
        self.anchors = anchors;
        self.previous.resize(points.len(), Vec::new());
        for (prev, now) in self.previous.iter_mut().zip(points) {
            prev.clear();
            prev.extend_from_slice(now);
        }
    }

    /// Strand `strand`'s partner points for the coming step, from the pairs of the last
    /// [`Self::update`] at `points` (the same positions, `arcs` the same arc lengths):
    /// written into `out` (cleared first; its memory kept), in the order of their arc
    /// lengths along the strand. Each pair gives each of its strands a
    /// [`PartnerPoint`]: its own arc length at the pair's closest point, and the other
    /// side's point and velocity there (linear between samples); a pair of two parts of
    /// one strand gives it one, through its first side.
    pub fn fill_partners(
        &self,
        strand: usize,
        points: &[Vec<Vector3<f64>>],
        out: &mut Vec<PartnerPoint>,
    ) {
        out.clear();
        let (Some(&lo), Some(&hi)) = (
            self.index_start.get(strand),
            self.index_start.get(strand + 1),
        ) else {
            return;
        };
        out.reserve(hi - lo);
        for &(_, index) in &self.index[lo..hi] {
            let index = index as usize;
            out.push(self.partner_point(index, self.pairs[index].a.0 == strand, points));
        }
    }

    /// The partner point pair `index` gives the strand of its side a (`on_a`) or b.
    fn partner_point(
        &self,
        index: usize,
        on_a: bool,
        points: &[Vec<Vector3<f64>>],
    ) -> PartnerPoint {
        let p = self.pairs[index];
        let (ta, tb) = self.closest[index];
        let reach = self.allowed[index];
        let anchor = self.anchors[index];
        let (rotation, h) = (&self.rotation, self.h);
        let velocity = |s: usize, k: usize| self.velocity[s][k];
        let (sa, sb, weight) = self.along[index];
        let at = |side: (usize, usize), t: f64| {
            // the point at parameter t ∈ [−1, 1] around sample side.1: its position and
            // velocity (linear between samples)
            let (s, k) = side;
            let j = if t < 0.0 { k.wrapping_sub(1) } else { k + 1 };
            let f = t.abs();
            let x = points[s][k]
                + (points[s].get(j).copied().unwrap_or(points[s][k]) - points[s][k]) * f;
            let v0 = velocity(s, k);
            let v = if j < points[s].len() {
                v0 + (velocity(s, j) - v0) * f
            } else {
                v0
            };
            (x, v)
        };
        let (xa, va) = at(p.a, ta);
        let (xb, vb) = at(p.b, tb);
        let normal = (xa - xb).try_normalize(0.0).unwrap_or_else(Vector3::zeros);
        // each side's sample is pulled to the other's, offset by ±Δ*
        let own_pair = p.a.0 == p.b.0;
        let held = |own: (usize, usize), other: (usize, usize), sign: f64| {
            anchor.map(|a| PartnerAnchor {
                sample: own.1,
                point: points[other.0][other.1] + rotation * a.offset * sign,
                velocity: velocity(other.0, other.1),
                sliding: a.sliding,
                partner_sample: own_pair.then_some(other.1),
                offset: a.offset * sign,
                step: h,
            })
        };
        if on_a {
            PartnerPoint {
                s: sa,
                weight,
                point: xb,
                velocity: vb,
                reach,
                anchor: held(p.a, p.b, 1.0),
                partner_s: own_pair.then_some(sb),
                pair: index,
                normal,
            }
        } else {
            PartnerPoint {
                s: sb,
                weight,
                point: xa,
                velocity: va,
                reach,
                anchor: held(p.b, p.a, -1.0),
                partner_s: own_pair.then_some(sa),
                pair: index,
                normal: -normal,
            }
        }
    }
}

/// Whether samples `a` and `b` may form a pair: of two strands, or of one strand more than
/// `exclusion` apart in arc length (`arcs`: per strand, per sample, its arc length first).
fn distinct(
    arcs: &[&[(f64, f64)]],
    exclusion: Option<f64>,
    a: (usize, usize),
    b: (usize, usize),
) -> bool {
    if a.0 != b.0 {
        return true;
    }
    let arc = |(s, k): (usize, usize)| arcs.get(s).and_then(|c| c.get(k)).map(|x| x.0);
    match (exclusion, arc(a), arc(b)) {
        (Some(e), Some(x), Some(y)) => (x - y).abs() > e,
        _ => false,
    }
}

/// How many pairs the first update of a [`HairHair`] with pair cap `cap` (and
/// self-contact `self_exclusion`) finds at `points` (world, per strand per sample; `arcs`
/// their arc lengths and weights) with reach `reach` and a free fall `fall` over the first
/// step: the broad phase of [`HairHair::update`] with no motion yet, capped. The memory
/// estimate counts the pairs of a scene's start with it.
pub fn pairs_at_start(
    points: &[Vec<Vector3<f64>>],
    arcs: &[&[(f64, f64)]],
    self_exclusion: Option<f64>,
    reach: f64,
    fall: f64,
    cap: usize,
) -> usize {
    let search = reach + fall.clamp(reach, SEARCH_MARGIN * reach);
    let radius: Vec<Vec<f64>> = points.iter().map(|c| vec![search; c.len()]).collect();
    let mut found = broad_phase(
        points,
        arcs,
        self_exclusion,
        &radius,
        search,
        cap,
        &mut Vec::new(),
    );
    found.sort_unstable();
    keep_nearest(found, |p| *p, points, cap).len()
}

/// The items (each standing for its `pair`; sorted) whose pairs are among the `cap`
/// nearest of either of their two samples (distance between the samples at `points`;
/// ties by order), in the same order.
fn keep_nearest<T>(
    items: Vec<T>,
    pair: impl Fn(&T) -> Pair,
    points: &[Vec<Vector3<f64>>],
    cap: usize,
) -> Vec<T> {
    if items.len() <= cap {
        return items;
    }
    // most steps no sample holds more than `cap` pairs: counted without sorting
    let mut offsets = Vec::with_capacity(points.len());
    let mut total = 0;
    for chain in points {
        offsets.push(total);
        total += chain.len();
    }
    let mut held = vec![0usize; total];
    for p in items.iter().map(&pair) {
        held[offsets[p.a.0] + p.a.1] += 1;
        held[offsets[p.b.0] + p.b.1] += 1;
    }
    if held.iter().all(|&n| n <= cap) {
        return items;
    }
    // a sample that holds at most `cap` pairs keeps them all; the others rank theirs:
    // every pair under each of its samples that holds more, nearest first
    let over = |(s, k): (usize, usize)| held[offsets[s] + k] > cap;
    let mut ends: Vec<((usize, usize), f64, usize)> = items
        .iter()
        .map(&pair)
        .enumerate()
        .filter(|(_, p)| over(p.a) || over(p.b))
        .flat_map(|(i, p)| {
            let d = dist2(points, p.a, p.b);
            [(p.a, d, i), (p.b, d, i)]
        })
        .filter(|e| over(e.0))
        .collect();
    ends.par_sort_unstable_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)).then(x.2.cmp(&y.2)));
    let mut keep: Vec<bool> = items
        .iter()
        .map(&pair)
        .map(|p| !over(p.a) || !over(p.b))
        .collect();
    let mut rank = 0;
    for j in 0..ends.len() {
        rank = if j > 0 && ends[j].0 == ends[j - 1].0 {
            rank + 1
        } else {
            0
        };
        if rank < cap {
            keep[ends[j].2] = true;
        }
    }
    if keep.iter().all(|&k| k) {
        return items;
    }
    items
        .into_iter()
        .zip(keep)
        .filter_map(|(x, k)| k.then_some(x))
        .collect()
}

/// A sample filed on the broad phase's grid: its cell, strand and sample, position and
/// search distance (copied, so that comparing a cell's samples reads one array).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Filed {
    cell: u64,
    strand: u32,
    sample: u32,
    x: [f64; 3],
    /// Arc length along its strand, m.
    arc: f64,
    radius: f64,
    /// The previous and the next sample of the chain (infinite where there is none).
    around: [[f64; 3]; 2],
    /// Their arc lengths.
    around_arc: [f64; 2],
}

fn dist2_of(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

impl Filed {
    /// Whether the two samples are a local minimum of their distance along both chains
    /// (no neighbour of either sample along its chain is closer to the other sample), their
    /// squared distance being `d`. For two samples of one strand, a neighbour within the
    /// self-contact `exclusion` of the other sample does not count: the two legs of a
    /// hairpin are paired where they come within reach, not only at its bend.
    fn local_minimum(&self, other: &Filed, d: f64, exclusion: Option<f64>) -> bool {
        let counts = |arc: f64, of: &Filed, to: &Filed| {
            of.strand != to.strand || exclusion.is_none_or(|e| (arc - to.arc).abs() > e)
        };
        (0..2).all(|i| {
            !counts(self.around_arc[i], self, other) || dist2_of(&self.around[i], &other.x) >= d
        }) && (0..2).all(|i| {
            !counts(other.around_arc[i], other, self) || dist2_of(&other.around[i], &self.x) >= d
        })
    }
}

/// The sample pairs (a, b) of different strands (or of one strand more than
/// `self_exclusion` apart in arc length, when given) closer than the larger of their two
/// search distances (`radius`, per strand per sample) that are local minima of their
/// distance along both chains ([`Filed::local_minimum`]; each once, in no order). Every
/// sample is filed under its cell of a grid of cells of size `cell` (in `cells`, sorted
/// by cell), the cells in parallel. Each pair is taken once: when neither of its samples
/// searches beyond a cell, by the sample in the earlier cell (or the earlier sample of
/// one cell), which looks at its own cell and the 13 of the 26 around it that come after
/// it; else by the one that searches the farther, which looks at every cell within its
/// search distance (so a few fast samples, a whipping tip, do not widen the search of
/// all the others). Each sample keeps the `cap` nearest of the pairs
/// it took (by distance, then by pair): at most `cap` pairs a sample, and every pair
/// among the `cap` nearest of both its samples.
fn broad_phase(
    points: &[Vec<Vector3<f64>>],
    arcs: &[&[(f64, f64)]],
    self_exclusion: Option<f64>,
    radius: &[Vec<f64>],
    cell: f64,
    cap: usize,
    cells: &mut Vec<Filed>,
) -> Vec<Pair> {
    // cell coordinates offset into 21 bits each (± 10⁶ cells: ± 8 km at an 8 mm cell);
    // a point outside that range is not filed
    const BIAS: i64 = 1 << 20;
    const SPAN: i64 = 64;
    // one cell along each axis
    const ONE: u64 = (1 << 42) + (1 << 21) + 1;
    let coord = |x: f64| -> Option<u64> {
        let c = (x / cell).floor();
        (c.is_finite() && c.abs() < (BIAS - SPAN) as f64).then(|| (c as i64 + BIAS) as u64)
    };
    let key = |x: &Vector3<f64>| -> Option<u64> {
        Some((coord(x.x)? << 42) | (coord(x.y)? << 21) | coord(x.z)?)
    };
    cells.clear();
    for (i, chain) in points.iter().enumerate() {
        let arc = |k: usize| arcs.get(i).and_then(|c| c.get(k)).map_or(0.0, |a| a.0);
        for (k, x) in chain.iter().enumerate() {
            if let Some(c) = key(x) {
                let at = |j: Option<usize>| {
                    j.and_then(|j| chain.get(j))
                        .map_or([f64::INFINITY; 3], |y| [y.x, y.y, y.z])
                };
                cells.push(Filed {
                    cell: c,
                    strand: i as u32,
                    sample: k as u32,
                    x: [x.x, x.y, x.z],
                    arc: arc(k),
                    radius: radius[i][k],
                    around: [at(k.checked_sub(1)), at(Some(k + 1))],
                    around_arc: [
                        k.checked_sub(1).map_or(f64::INFINITY, arc),
                        if k + 1 < chain.len() {
                            arc(k + 1)
                        } else {
                            f64::INFINITY
                        },
                    ],
                });
            }
        }
    }
    cells.par_sort_unstable_by_key(|f| (f.cell, f.strand, f.sample));
    let cells = &cells[..];
    // the start of each cell's run
    let starts: Vec<usize> = (0..cells.len())
        .filter(|&i| i == 0 || cells[i].cell != cells[i - 1].cell)
        .collect();
    // the cells' keys in order, apart from the samples (a small array to search)
    let keys: Vec<u64> = starts.iter().map(|&i| cells[i].cell).collect();
    let run = |c: u64| -> &[Filed] {
        match keys.binary_search(&c) {
            Ok(n) => &cells[starts[n]..starts.get(n + 1).copied().unwrap_or(cells.len())],
            Err(_) => &[],
        }
    };
    let pairs: Vec<Pair> = starts
        .par_iter()
        .enumerate()
        .flat_map_iter(|(n, &lo)| {
            let hi = starts.get(n + 1).copied().unwrap_or(cells.len());
            let own = &cells[lo..hi];
            let c = own[0].cell;
            // every pair is taken once, by one rule: a pair whose larger search distance
            // is at most a cell, from the cell earlier in the order of the keys (within
            // one cell, from its earlier sample); any other from the side of the larger
            // search distance, which looks as far as it (at a tie, the earlier sample's)
            let earlier =
                |f: &Filed, g: &Filed| (f.cell, f.strand, f.sample) < (g.cell, g.strand, g.sample);
            // what the cell's samples take: (sample within the cell, squared distance,
            // pair)
            let mut taken: Vec<(u32, f64, Pair)> = Vec::new();
            let mut consider = |ia: usize, fa: &Filed, fb: &Filed| {
                if fa.strand == fb.strand
                    && self_exclusion.is_none_or(|e| (fa.arc - fb.arc).abs() <= e)
                {
                    return;
                }
                let r = fa.radius.max(fb.radius);
                let d = dist2_of(&fa.x, &fb.x);
                // only the local minima of the distance along both chains
                if d >= r * r || !fa.local_minimum(fb, d, self_exclusion) {
                    return;
                }
                let a = (fa.strand as usize, fa.sample as usize);
                let b = (fb.strand as usize, fb.sample as usize);
                let (a, b) = if a < b { (a, b) } else { (b, a) };
                taken.push((ia as u32, d, Pair { a, b }));
            };
            // the samples that search within a cell take their pairs with the others that
            // do in this cell and the cells after it (the cells before it take theirs with
            // this one)
            let slow = |f: &Filed| f.radius <= cell;
            if own.iter().any(slow) {
                for dx in 0..=2u64 {
                    for dy in 0..=2u64 {
                        for dz in 0..=2u64 {
                            let other = (c + (dx << 42) + (dy << 21) + dz).wrapping_sub(ONE);
                            if other < c {
                                continue;
                            }
                            let others = run(other);
                            for (ia, fa) in own.iter().enumerate().filter(|(_, f)| slow(f)) {
                                // within the cell, from its earlier sample
                                let from = if other == c { ia + 1 } else { 0 };
                                for fb in others.get(from..).unwrap_or(&[]) {
                                    if slow(fb) {
                                        consider(ia, fa, fb);
                                    }
                                }
                            }
                        }
                    }
                }
            }
            // a sample that searches further takes its pairs with every sample that
            // searches less far (or as far, and comes after it), over the cells within its
            // search distance
            for (ia, fa) in own.iter().enumerate().filter(|(_, f)| !slow(f)) {
                let span = ((fa.radius / cell).ceil() as i64).clamp(1, SPAN - 1) as u64;
                let corner = (span << 42) + (span << 21) + span;
                for dx in 0..=2 * span {
                    for dy in 0..=2 * span {
                        for dz in 0..=2 * span {
                            let other = (c + (dx << 42) + (dy << 21) + dz).wrapping_sub(corner);
                            for fb in run(other) {
                                if fa.radius > fb.radius
                                    || (fa.radius == fb.radius && earlier(fa, fb))
                                {
                                    consider(ia, fa, fb);
                                }
                            }
                        }
                    }
                }
            }
            // each sample keeps the `cap` nearest of the pairs it took (a pair among the
            // `cap` nearest of both its samples is among them; `keep_nearest` caps each
            // sample's pairs again after the merge with the tracked ones)
            // (ranked only when a sample took more than `cap`)
            let over = taken.len() > cap && {
                let mut count = vec![0usize; own.len()];
                taken.iter().any(|x| {
                    count[x.0 as usize] += 1;
                    count[x.0 as usize] > cap
                })
            };
            if over {
                taken.sort_unstable_by(|x, y| {
                    x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)).then(x.2.cmp(&y.2))
                });
                let mut rank = 0;
                let mut last = u32::MAX;
                taken.retain(|x| {
                    rank = if x.0 == last { rank + 1 } else { 0 };
                    last = x.0;
                    rank < cap
                });
            }
            taken.into_iter().map(|x| x.2)
        })
        .collect();
    pairs
}

/// Closest points of the two segments `p0 + t (p1 − p0)` and `q0 + u (q1 − q0)`,
/// t, u ∈ [0, 1]: (t, u, squared distance).
fn segment_closest(
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    q0: &Vector3<f64>,
    q1: &Vector3<f64>,
) -> (f64, f64, f64) {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let (a, e, f) = (d1.dot(&d1), d2.dot(&d2), d2.dot(&r));
    let (mut t, mut u);
    if a <= f64::EPSILON && e <= f64::EPSILON {
        (t, u) = (0.0, 0.0);
    } else if a <= f64::EPSILON {
        t = 0.0;
        u = (f / e).clamp(0.0, 1.0);
    } else {
        let c = d1.dot(&r);
        if e <= f64::EPSILON {
            u = 0.0;
            t = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            t = if denom > 0.0 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            u = (b * t + f) / e;
            if u < 0.0 {
                u = 0.0;
                t = (-c / a).clamp(0.0, 1.0);
            } else if u > 1.0 {
                u = 1.0;
                t = ((b - c) / a).clamp(0.0, 1.0);
            }
        }
    }
    let d = (p0 + d1 * t) - (q0 + d2 * u);
    (t, u, d.norm_squared())
}

/// A pair with its friction anchor, its closest points (as [`closest_on_chains`] returns)
/// and whether this update's search found it.
struct Keyed {
    pair: Pair,
    anchor: Option<PairAnchor>,
    closest: (f64, f64),
    fresh: bool,
}

/// Pair `p` (with its anchor, and whether this update's search found it) keyed by the
/// samples nearest its closest points: the closest points of the two chains around its
/// samples ([`closest_on_chains`]), and when a side's point lies more than half-way to
/// a neighbouring sample, the pair moved to that sample (unless that makes two parts of
/// one strand within the exclusion), its closest points found again there and its
/// anchor carried along as the tracking carries it.
fn to_closest(
    p: Pair,
    anchor: Option<PairAnchor>,
    fresh: bool,
    points: &[Vec<Vector3<f64>>],
    arcs: &[&[(f64, f64)]],
    exclusion: Option<f64>,
    rt: &Matrix3<f64>,
) -> Keyed {
    let closest = closest_on_chains(points, p.a, p.b);
    let nearest = |(s, k): (usize, usize), t: f64| {
        if t > 0.5 && k + 1 < points[s].len() {
            (s, k + 1)
        } else if t < -0.5 && k > 0 {
            (s, k - 1)
        } else {
            (s, k)
        }
    };
    let q = Pair {
        a: nearest(p.a, closest.0),
        b: nearest(p.b, closest.1),
    };
    if q == p || !distinct(arcs, exclusion, q.a, q.b) {
        return Keyed {
            pair: p,
            anchor,
            closest,
            fresh,
        };
    }
    let anchor = anchor.map(|mut a| {
        let shift = (points[q.a.0][q.a.1] - points[p.a.0][p.a.1])
            - (points[q.b.0][q.b.1] - points[p.b.0][p.b.1]);
        a.offset += rt * shift;
        a
    });
    Keyed {
        pair: q,
        anchor,
        closest: closest_on_chains(points, q.a, q.b),
        fresh,
    }
}

/// `items` in the order of `key` (at equal keys, in their order), given that those not
/// marked as moved are in that order already (as when a sorted list's items move, a
/// few of them out of their places): the moved ones sorted and merged in, at equal keys
/// after the others (when the others are not in order after all, all are sorted).
fn in_order<T: Send, K: Ord>(items: Vec<(T, bool)>, key: impl Fn(&T) -> K) -> Vec<T> {
    let moves = items.iter().filter(|x| x.1).count();

    if moves == 0 {
        return items.into_iter().map(|x| x.0).collect();
    }
    let mut kept = Vec::with_capacity(items.len() - moves);
    let mut moved = Vec::with_capacity(moves);
    for (item, m) in items {
        if m {
            moved.push(item);
        } else {
            kept.push(item);
        }
    }
    moved.sort_by_key(&key);
    if !kept.windows(2).all(|w| key(&w[0]) <= key(&w[1])) {
        kept.append(&mut moved);
        kept.sort_by_key(&key);
        return kept;
    }
    let mut out = Vec::with_capacity(kept.len() + moved.len());
    let mut moved = moved.into_iter().peekable();
    for item in kept {
        while let Some(m) = moved.next_if(|m| key(m) < key(&item)) {
            out.push(m);
        }
        out.push(item);
    }
    out.extend(moved);
    out
}

/// The closest points of the two chains around samples `a` and `b`, among the segments
/// to each side's neighbours: parameters in [−1, 1] (−1: the previous sample, 1: the
/// next, 0: the sample itself).
fn closest_on_chains(p: &[Vec<Vector3<f64>>], a: (usize, usize), b: (usize, usize)) -> (f64, f64) {
    let sides = |(s, k): (usize, usize)| {
        let chain = &p[s];
        let mut out = [None, None];
        if k > 0 {
            out[0] = Some((k - 1, -1.0));
        }
        if k + 1 < chain.len() {
            out[1] = Some((k + 1, 1.0));
        }
        out
    };
    let mut best = (0.0, 0.0, (p[a.0][a.1] - p[b.0][b.1]).norm_squared());
    for (ja, sa) in sides(a).into_iter().flatten() {
        for (jb, sb) in sides(b).into_iter().flatten() {
            let (t, u, d) = segment_closest(&p[a.0][a.1], &p[a.0][ja], &p[b.0][b.1], &p[b.0][jb]);
            if d < best.2 {
                best = (sa * t, sb * u, d);
            }
        }
    }
    (best.0, best.1)
}

/// The point at parameter t ∈ [−1, 1] around sample `side` of its chain (linear between
/// samples; as [`closest_on_chains`] returns).
fn point_at(p: &[Vec<Vector3<f64>>], (s, k): (usize, usize), t: f64) -> Vector3<f64> {
    let j = if t < 0.0 { k.wrapping_sub(1) } else { k + 1 };
    match p[s].get(j) {
        Some(x) => p[s][k] + (x - p[s][k]) * t.abs(),
        None => p[s][k],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether no neighbour of sample `a` along its chain is closer to sample `b` than `a`
    /// is, nor any neighbour of `b` closer to `a`.
    fn local_minimum(
        p: &[Vec<Vector3<f64>>],
        arcs: &[&[(f64, f64)]],
        exclusion: Option<f64>,
        a: (usize, usize),
        b: (usize, usize),
    ) -> bool {
        let d = dist2(p, a, b);
        let closer = |own: (usize, usize), other: (usize, usize)| {
            [own.1.wrapping_sub(1), own.1 + 1].into_iter().any(|k| {
                k < p[own.0].len()
                    && distinct(arcs, exclusion, (own.0, k), other)
                    && dist2(p, (own.0, k), other) < d
            })
        };
        !closer(a, b) && !closer(b, a)
    }

    /// The grid's pairs are those of comparing every two samples of different strands
    /// (with the same descent and per-pair distance), on random chains on both sides of
    /// the origin (cells of negative coordinates, neighbours across zero); with
    /// self-contact, also those of one strand farther apart along it than the exclusion
    /// (a tight coil among the chains has some).
    #[test]
    fn the_broad_phase_finds_what_comparing_every_two_samples_finds() {
        for exclusion in [None, Some(0.01)] {
            broad_phase_against_every_pair(exclusion);
        }
    }

    fn broad_phase_against_every_pair(exclusion: Option<f64>) {
        let mut seed = 12345u64;
        let mut rand = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut points: Vec<Vec<Vector3<f64>>> = (0..40)
            .map(|_| {
                let mut x = Vector3::new(rand() - 0.5, rand() - 0.5, rand() - 0.5) * 0.06;
                let d = Vector3::new(rand() - 0.5, rand() - 0.5, rand() - 0.5).normalize();
                (0..25)
                    .map(|_| {
                        x += (d + Vector3::new(rand() - 0.5, rand() - 0.5, rand() - 0.5)) * 0.003;
                        x
                    })
                    .collect()
            })
            .collect();
        // a coil of radius 3 mm and pitch 2 mm, 6 samples a turn
        points.push(
            (0..25)
                .map(|k| {
                    let a = k as f64 * std::f64::consts::PI / 3.0;
                    Vector3::new(
                        0.003 * a.cos(),
                        0.003 * a.sin(),
                        0.002 * a / std::f64::consts::TAU,
                    )
                })
                .collect(),
        );
        // arc lengths: the chains' samples about 3.5 mm apart, the coil's 3.1 mm
        let arcs: Vec<Vec<(f64, f64)>> = points
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let step = if i == 40 { 0.0031 } else { 0.0035 };
                (0..c.len()).map(|k| (step * k as f64, step)).collect()
            })
            .collect();
        let arcs: Vec<&[(f64, f64)]> = arcs.iter().map(|a| &a[..]).collect();
        // search distances between 4 and 8 mm, and 24 mm for one sample in 40 (a
        // whipping tip, searched beyond the 27 nearest cells)
        let cell = 0.004;
        let radius: Vec<Vec<f64>> = points
            .iter()
            .map(|c| {
                c.iter()
                    .map(|_| {
                        let u = rand();
                        if u < 0.025 {
                            6.0 * cell
                        } else {
                            cell * (1.0 + u)
                        }
                    })
                    .collect()
            })
            .collect();
        let search2 = |a: (usize, usize), b: (usize, usize)| {
            let r = radius[a.0][a.1].max(radius[b.0][b.1]);
            r * r
        };
        let mut cells = Vec::new();
        let mut found = broad_phase(
            &points,
            &arcs,
            exclusion,
            &radius,
            cell,
            usize::MAX,
            &mut cells,
        );
        // (each pair once: a repeat would stay after sorting)
        found.sort_unstable();
        let mut all = Vec::new();
        for i in 0..points.len() {
            for j in i..points.len() {
                for k in 0..points[i].len() {
                    for l in 0..points[j].len() {
                        let p = Pair {
                            a: (i, k),
                            b: (j, l),
                        };
                        if (i == j && k >= l) || !distinct(&arcs, exclusion, p.a, p.b) {
                            continue;
                        }
                        if dist2(&points, p.a, p.b) < search2(p.a, p.b)
                            && local_minimum(&points, &arcs, exclusion, p.a, p.b)
                        {
                            all.push(p);
                        }
                    }
                }
            }
        }
        let own = all.iter().filter(|p| p.a.0 == p.b.0).count();
        assert_eq!(own > 0, exclusion.is_some(), "{own} pairs of one strand");
        all.sort_unstable();
        all.dedup();
        assert!(all.len() > 50, "{} pairs: too few to test", all.len());
        assert_eq!(found, all);
        // capped: a subset, at most `cap` per sample, holding every pair that is among
        // the `cap` nearest of both its samples (each sample ranks what it sees, at least
        // the pairs within its own search distance, so a pair nearest for both is seen
        // and kept by one of them)
        let samples: usize = points.iter().map(|c| c.len()).sum();
        let by_sample = |x: (usize, usize)| {
            let mut own: Vec<(f64, Pair)> = all
                .iter()
                .filter(|p| p.a == x || p.b == x)
                .map(|p| (dist2(&points, p.a, p.b), *p))
                .collect();
            own.sort_by(|u, v| u.0.total_cmp(&v.0).then(u.1.cmp(&v.1)));
            own.into_iter().map(|u| u.1).collect::<Vec<_>>()
        };
        for cap in [1, 2, 4] {
            let mut capped = broad_phase(&points, &arcs, exclusion, &radius, cell, cap, &mut cells);
            capped.sort_unstable();
            assert!(capped.iter().all(|p| all.binary_search(p).is_ok()));
            assert!(capped.len() <= cap * samples);
            let must: Vec<Pair> = all
                .iter()
                .filter(|p| by_sample(p.a)[..].iter().take(cap).any(|q| q == *p))
                .filter(|p| by_sample(p.b)[..].iter().take(cap).any(|q| q == *p))
                .copied()
                .collect();
            assert!(!must.is_empty() && capped.len() < all.len(), "cap {cap}");
            for p in &must {
                assert!(capped.binary_search(p).is_ok(), "cap {cap}: {p:?} dropped");
            }
            // and the cap after tracking keeps what the search kept
            let kept = keep_nearest(capped.clone(), |p| *p, &points, cap);
            for p in &must {
                assert!(kept.binary_search(p).is_ok(), "cap {cap}: {p:?} not kept");
            }
        }
    }
}
