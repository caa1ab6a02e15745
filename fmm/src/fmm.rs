//! The fast multipole method (paper section 2.3.1) over the adaptive octree: upward pass
//! (P2M at the leaves, M2M to the root), interactions found by a dual traversal of the
//! tree (a pair of boxes far enough apart exchanges an M2L, a pair of close leaves a
//! P2P), downward pass (L2L), evaluation (L2P and P2P at the leaves). Every pass is
//! parallel with rayon; nothing is shared between threads but read-only data.

use crate::direct::{add_interactions, self_potential, Softening, SourceSlices};
use crate::harmonics::tri_len;
use crate::operators::{l2l, l2p, m2l_batch, m2m, p2m, BatchScratch, Scratch, LANES};
use crate::tree::Octree;
use crate::FmmError;
use num_complex::Complex64 as C;
use rayon::prelude::*;
use std::time::Instant;

/// Parameters of the multipole method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FmmOptions {
    /// Order p of the expansions (terms `n ≤ p`), 1 ..= [`MAX_ORDER`].
    pub order: usize,
    /// Opening criterion: two boxes of radii `r_a`, `r_b` whose centres are `d` apart
    /// interact through their expansions when `r_a + r_b ≤ θ d`; (0, 1).
    pub theta: f64,
    /// Most particles in a leaf, ≥ 1.
    pub leaf_size: usize,
    /// The near-field regularisation ([`Softening`]); boxes closer than its radius
    /// never interact through expansions, so the far field is the plain `1/r`.
    pub softening: Softening,
}

/// Largest order accepted.
pub const MAX_ORDER: usize = 40;

/// Relative l2 error of the field (over 2000 sampled particles, against the direct sum)
/// at orders p = 1 … 20 with θ = 0.5 and leaves of 64, measured on 100,000 hair-like
/// particles (1000 curly fibres of 100 signed charges hanging from a half sphere,
/// [`crate::samples::curly_fibres`]): the table [`FmmOptions::for_accuracy`] chooses p
/// from, checked by the tests on random and hair-like sets.
pub const ERROR_BY_ORDER: [f64; 20] = [
    1.55e-2, 4.83e-3, 1.72e-3, 6.26e-4, 2.34e-4, 8.69e-5, 3.20e-5, 1.17e-5, 4.40e-6, 1.80e-6,
    7.68e-7, 3.37e-7, 1.59e-7, 7.21e-8, 3.27e-8, 1.57e-8, 7.43e-9, 3.68e-9, 1.8e-9, 8.60e-10,
];

/// The expected relative l2 error of the field at order `p` (θ = 0.5): the table up to
/// 20, then a factor 0.48 per order.
pub fn expected_error(p: usize) -> f64 {
    match p {
        0 => 1.0,
        1..=20 => ERROR_BY_ORDER[p - 1],
        _ => ERROR_BY_ORDER[19] * 0.48f64.powi(p as i32 - 20),
    }
}

impl FmmOptions {
    /// Options for a requested accuracy `eps` in (0, 1): θ = 0.5, leaves of 64, and the
    /// smallest order p whose measured relative l2 error of the field on hair-like
    /// particles ([`ERROR_BY_ORDER`]) is at most `eps / 10`, the convention of FMM3D
    /// (whose `eps = 1e-6` gives ~1e-7 there), so that equal `eps` compares equal errors.
    pub fn for_accuracy(eps: f64) -> Result<Self, FmmError> {
        if !(eps.is_finite() && eps > 0.0 && eps < 1.0) {
            return Err(FmmError::Option {
                name: "eps",
                value: eps,
                allowed: "(0, 1)",
            });
        }
        let target = eps / 10.0;
        let order = (1..=MAX_ORDER)
            .find(|&p| expected_error(p) <= target)
            .unwrap_or(MAX_ORDER);
        Ok(FmmOptions {
            order,
            theta: 0.5,
            leaf_size: 64,
            softening: Softening::NONE,
        })
    }

    fn check(&self) -> Result<(), FmmError> {
        if !(1..=MAX_ORDER).contains(&self.order) {
            return Err(FmmError::Option {
                name: "order",
                value: self.order as f64,
                allowed: "1 ..= 40",
            });
        }
        if !(self.theta > 0.0 && self.theta < 1.0) {
            return Err(FmmError::Option {
                name: "theta",
                value: self.theta,
                allowed: "(0, 1)",
            });
        }
        if self.leaf_size == 0 {
            return Err(FmmError::Option {
                name: "leaf_size",
                value: 0.0,
                allowed: ">= 1",
            });
        }
        let a = self.softening.radius;
        if !(a.is_finite() && a >= 0.0) {
            return Err(FmmError::Option {
                name: "softening",
                value: a,
                allowed: "finite, >= 0",
            });
        }
        Ok(())
    }
}

/// What one evaluation did and how long each part took.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FmmStats {
    /// Boxes of the tree.
    pub nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Depth of the deepest box.
    pub depth: usize,
    /// M2L translations.
    pub m2l: usize,
    /// Leaf–box pairs summed directly.
    pub p2p_pairs: usize,
    /// Particle–particle interactions summed directly.
    pub p2p_interactions: usize,
    /// Seconds: tree, upward pass, traversal, M2L, downward pass, evaluation.
    pub seconds: [f64; 6],
}

/// The potential and field of every particle, in the input order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Potentials {
    /// `Φ_i = Σ_{j≠i} q_j φ(|x_i − x_j|)` (kernel `1/r`, softened).
    pub potential: Vec<f64>,
    /// `E_i = −∇Φ(x_i)`.
    pub field: Vec<[f64; 3]>,
}

/// The multipole evaluator; keeps its tree and expansions between calls, so repeated
/// evaluations (every step of a simulation) reuse the memory.
#[derive(Debug, Clone)]
pub struct Fmm {
    options: FmmOptions,
    tree: Octree,
    multipoles: Vec<C>,
    locals: Vec<C>,
    m2l_start: Vec<u32>,
    m2l_source: Vec<u32>,
    p2p_start: Vec<u32>,
    p2p_source: Vec<u32>,
    soa: [Vec<f64>; 4],
    tree_potential: Vec<f64>,
    tree_field: Vec<[f64; 3]>,
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

impl Fmm {
    /// An evaluator with `options` (checked).
    pub fn new(options: FmmOptions) -> Result<Self, FmmError> {
        options.check()?;
        Ok(Fmm {
            options,
            tree: Octree::default(),
            multipoles: Vec::new(),
            locals: Vec::new(),
            m2l_start: Vec::new(),
            m2l_source: Vec::new(),
            p2p_start: Vec::new(),
            p2p_source: Vec::new(),
            soa: Default::default(),
            tree_potential: Vec::new(),
            tree_field: Vec::new(),
        })
    }

    /// The options.
    pub fn options(&self) -> FmmOptions {
        self.options
    }

    /// The potential and field at every point due to all other charges.
    pub fn evaluate(
        &mut self,
        points: &[[f64; 3]],
        charges: &[f64],
    ) -> Result<(Potentials, FmmStats), FmmError> {
        let mut out = Potentials::default();
        let stats = self.evaluate_into(points, charges, &mut out)?;
        Ok((out, stats))
    }

    /// [`Fmm::evaluate`] into `out` (resized), reusing its memory.
    pub fn evaluate_into(
        &mut self,
        points: &[[f64; 3]],
        charges: &[f64],
        out: &mut Potentials,
    ) -> Result<FmmStats, FmmError> {
        crate::check_input(points, charges)?;
        let n = points.len();
        let p = self.options.order;
        let nc = tri_len(p);
        let mut stats = FmmStats::default();
        let mut clock = Instant::now();
        let mut lap = |k: usize, stats: &mut FmmStats| {
            stats.seconds[k] = clock.elapsed().as_secs_f64();
            clock = Instant::now();
        };

        self.tree.build(points, self.options.leaf_size);
        let tree = &self.tree;
        let nodes = &tree.nodes;
        stats.nodes = nodes.len();
        stats.leaves = tree.leaves.len();
        stats.depth = tree.levels.len().saturating_sub(1);
        for (k, v) in self.soa.iter_mut().enumerate() {
            v.clear();
            if k < 3 {
                v.extend(tree.points.iter().map(|x| x[k]));
            } else {
                v.extend(tree.order.iter().map(|&i| charges[i as usize]));
            }
        }
        let [sx, sy, sz, sq] = &self.soa;
        lap(0, &mut stats);

        // Upward pass.
        self.multipoles.clear();
        self.multipoles.resize(nodes.len() * nc, C::new(0.0, 0.0));
        let pts = &tree.points;
        self.multipoles
            .par_chunks_mut(nc)
            .zip(nodes.par_iter())
            .filter(|(_, node)| node.is_leaf())
            .for_each_init(
                || Scratch::new(p),
                |s, (m, node)| p2m(node.centre, &pts[node.range()], &sq[node.range()], m, s),
            );
        for level in tree.levels.iter().rev() {
            let (upper, lower) = self.multipoles.split_at_mut(level.end * nc);
            let below = level.end;
            upper[level.start * nc..]
                .par_chunks_mut(nc)
                .zip(nodes[level.clone()].par_iter())
                .filter(|(_, node)| !node.is_leaf())
                .for_each_init(
                    || Scratch::new(p),
                    |s, (m, node)| {
                        for c in node.child_range() {
                            let child = &lower[(c - below) * nc..(c - below + 1) * nc];
                            m2m(nodes[c].centre, node.centre, child, m, s);
                        }
                    },
                );
        }
        lap(1, &mut stats);

        // Interactions.
        let (m2l_pairs, p2p_pairs) = self.traverse();
        stats.m2l = m2l_pairs.len();
        stats.p2p_pairs = p2p_pairs.len();
        stats.p2p_interactions = p2p_pairs
            .iter()
            .map(|&(a, b)| nodes[a as usize].len() * nodes[b as usize].len())
            .sum();
        csr(
            &m2l_pairs,
            nodes.len(),
            &mut self.m2l_start,
            &mut self.m2l_source,
        );
        csr(
            &p2p_pairs,
            nodes.len(),
            &mut self.p2p_start,
            &mut self.p2p_source,
        );
        lap(2, &mut stats);

        // M2L, four sources at a time.
        self.locals.clear();
        self.locals.resize(nodes.len() * nc, C::new(0.0, 0.0));
        let (m2l_start, m2l_source, multipoles) =
            (&self.m2l_start, &self.m2l_source, &self.multipoles);
        self.locals
            .par_chunks_mut(nc)
            .enumerate()
            .with_min_len(4)
            .for_each_init(
                || BatchScratch::new(p),
                |s, (i, l)| {
                    let list = &m2l_source[m2l_start[i] as usize..m2l_start[i + 1] as usize];
                    for chunk in list.chunks(LANES) {
                        let mut batch: [([f64; 3], &[C]); LANES] = [([0.0; 3], &[]); LANES];
                        for (slot, &b) in batch.iter_mut().zip(chunk) {
                            let b = b as usize;
                            *slot = (nodes[b].centre, &multipoles[b * nc..(b + 1) * nc]);
                        }
                        m2l_batch(&batch[..chunk.len()], nodes[i].centre, l, s);
                    }
                },
            );
        lap(3, &mut stats);

        // Downward pass.
        for level in tree.levels.iter().skip(1) {
            let (upper, current) = self.locals.split_at_mut(level.start * nc);
            current[..level.len() * nc]
                .par_chunks_mut(nc)
                .zip(nodes[level.clone()].par_iter())
                .for_each_init(
                    || Scratch::new(p),
                    |s, (l, node)| {
                        let parent = node.parent as usize;
                        l2l(
                            nodes[parent].centre,
                            node.centre,
                            &upper[parent * nc..(parent + 1) * nc],
                            l,
                            s,
                        );
                    },
                );
        }
        lap(4, &mut stats);

        // Evaluation at the leaves: L2P and P2P.
        self.tree_potential.clear();
        self.tree_potential.resize(n, 0.0);
        self.tree_field.clear();
        self.tree_field.resize(n, [0.0; 3]);
        let mut leaves: Vec<u32> = tree.leaves.clone();
        leaves.sort_unstable_by_key(|&i| nodes[i as usize].start);
        let mut work = Vec::with_capacity(leaves.len());
        let (mut phi_rest, mut field_rest) =
            (&mut self.tree_potential[..], &mut self.tree_field[..]);
        for &leaf in &leaves {
            let len = nodes[leaf as usize].len();
            let (a, b) = std::mem::take(&mut phi_rest).split_at_mut(len);
            let (c, d) = std::mem::take(&mut field_rest).split_at_mut(len);
            work.push((leaf as usize, a, c));
            phi_rest = b;
            field_rest = d;
        }
        let (locals, p2p_start, p2p_source) = (&self.locals, &self.p2p_start, &self.p2p_source);
        let softening = self.options.softening;
        work.into_par_iter().for_each_init(
            || Scratch::new(p),
            |s, (leaf, phi, field)| {
                let node = &nodes[leaf];
                let targets = &pts[node.range()];
                let l = &locals[leaf * nc..(leaf + 1) * nc];
                for (k, x) in targets.iter().enumerate() {
                    let (v, g) = l2p(node.centre, l, *x, s);
                    phi[k] += v;
                    field[k] = [field[k][0] - g[0], field[k][1] - g[1], field[k][2] - g[2]];
                }
                for &b in &p2p_source[p2p_start[leaf] as usize..p2p_start[leaf + 1] as usize] {
                    let r = nodes[b as usize].range();
                    let src = SourceSlices {
                        x: &sx[r.clone()],
                        y: &sy[r.clone()],
                        z: &sz[r.clone()],
                        q: &sq[r],
                    };
                    add_interactions(targets, &src, softening, phi, field);
                }
                for (k, ph) in phi.iter_mut().enumerate() {
                    *ph -= self_potential(sq[node.start as usize + k], softening);
                }
            },
        );
        out.potential.clear();
        out.potential.resize(n, 0.0);
        out.field.clear();
        out.field.resize(n, [0.0; 3]);
        for (k, &i) in tree.order.iter().enumerate() {
            out.potential[i as usize] = self.tree_potential[k];
            out.field[i as usize] = self.tree_field[k];
        }
        lap(5, &mut stats);
        Ok(stats)
    }

    /// The dual traversal: (target, source) pairs for M2L and, for target leaves, P2P.
    fn traverse(&self) -> (Pairs, Pairs) {
        let nodes = &self.tree.nodes;
        let mut m2l_pairs = Vec::new();
        let mut p2p_pairs = Vec::new();
        if nodes.is_empty() || nodes[0].is_empty() {
            return (m2l_pairs, p2p_pairs);
        }
        let theta = self.options.theta;
        let soft = self.options.softening.radius;
        let p = self.options.order;
        // A leaf pair this small is cheaper summed directly than translated.
        let direct_cutoff = (p + 1) * (p + 1) * tri_len(p) / 8;
        let mut stack = vec![(0u32, 0u32)];
        while let Some((a, b)) = stack.pop() {
            let (na, nb) = (&nodes[a as usize], &nodes[b as usize]);
            let d = distance(na.centre, nb.centre);
            let gap = d - na.radius - nb.radius;
            let separated = a != b && na.radius + nb.radius <= theta * d && gap > soft;
            if separated {
                if na.is_leaf() && nb.is_leaf() && na.len() * nb.len() <= direct_cutoff {
                    p2p_pairs.push((a, b));
                } else {
                    m2l_pairs.push((a, b));
                }
            } else if na.is_leaf() && nb.is_leaf() {
                p2p_pairs.push((a, b));
            } else if nb.is_leaf() || (!na.is_leaf() && na.radius >= nb.radius) {
                for c in na.child_range() {
                    stack.push((c as u32, b));
                }
            } else {
                for c in nb.child_range() {
                    stack.push((a, c as u32));
                }
            }
        }
        (m2l_pairs, p2p_pairs)
    }
}

/// (target, source) box pairs.
type Pairs = Vec<(u32, u32)>;

/// Pairs (target, source) into compressed rows by target.
fn csr(pairs: &[(u32, u32)], rows: usize, start: &mut Vec<u32>, source: &mut Vec<u32>) {
    start.clear();
    start.resize(rows + 1, 0);
    for &(a, _) in pairs {
        start[a as usize + 1] += 1;
    }
    for i in 0..rows {
        start[i + 1] += start[i];
    }
    let mut fill: Vec<u32> = start[..rows].to_vec();
    source.clear();
    source.resize(pairs.len(), 0);
    for &(a, b) in pairs {
        source[fill[a as usize] as usize] = b;
        fill[a as usize] += 1;
    }
}
