//! Symbolic builders for one helical element (design page "Reconstruction"):
//!
//! ```text
//! E(u) = I + sin(uW)/W K + (1 − cos(uW))/W² K²
//! P(u) = u I + (1 − cos(uW))/W² K + (uW − sin(uW))/W³ K²
//! p(u) = P(u) e0,   w_i(u) = P(u) e_i
//! ```
//!
//! with `K = [d]×`, `W = |d|`. `W` is a symbol of its own, declared to depend on `d`
//! (`∂W/∂d_i = d_i/W`); the generated code computes it as `sqrt(d·d)`.

use crate::graph::{Graph, Id};

/// The symbols of one element: Darboux vector `d`, its norm `W`, the element length `l`
/// and the local abscissa `u` (the integration variable).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HelixSymbols {
    /// `d0, d1, d2` (symbols named `d0`, `d1`, `d2`).
    pub d: [Id; 3],
    /// `W = |d|` (symbol `w`).
    pub w: Id,
    /// Element length (symbol `l`).
    pub l: Id,
    /// Local abscissa (symbol `u`).
    pub u: Id,
    /// `x = W l` (symbol `x`), the variable of the integrals' results.
    pub x: Id,
    /// `d_i l` (symbols `dl0`, `dl1`, `dl2`), the variables of the integrals' results.
    pub dl: [Id; 3],
}

impl HelixSymbols {
    /// Create (or look up) the symbols and declare `∂W/∂d_i = d_i/W`.
    pub fn new(g: &mut Graph) -> HelixSymbols {
        let d = [g.symbol("d0"), g.symbol("d1"), g.symbol("d2")];
        let w = g.symbol("w");
        let l = g.symbol("l");
        let u = g.symbol("u");
        for di in d {
            let p = g.div(di, w);
            g.set_partial(w, di, p);
        }
        let x = g.symbol("x");
        let dl = [g.symbol("dl0"), g.symbol("dl1"), g.symbol("dl2")];
        HelixSymbols { d, w, l, u, x, dl }
    }

    /// Bindings for [`Graph::eval`]: `d`, `W = |d|`, `l`, `u`, `x = W l`, `dl = d l`.
    pub fn bindings(&self, d: [f64; 3], l: f64, u: f64) -> Vec<(Id, f64)> {
        let w = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        vec![
            (self.d[0], d[0]),
            (self.d[1], d[1]),
            (self.d[2], d[2]),
            (self.w, w),
            (self.l, l),
            (self.u, u),
            (self.x, w * l),
            (self.dl[0], d[0] * l),
            (self.dl[1], d[1] * l),
            (self.dl[2], d[2] * l),
        ]
    }

    /// [`HelixSymbols::bindings`] computed in `f32` arithmetic from `d`, `l`, `u` rounded
    /// to `f32`, as the prologue of generated f32 code computes them (`W = sqrt(d·d)`,
    /// `x = W l`, `dl = d l`); the values are widened to `f64` (exact).
    pub fn bindings_f32(&self, d: [f64; 3], l: f64, u: f64) -> Vec<(Id, f64)> {
        let d = d.map(|x| x as f32);
        let (l, u) = (l as f32, u as f32);
        let w = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let f = |x: f32| x as f64;
        vec![
            (self.d[0], f(d[0])),
            (self.d[1], f(d[1])),
            (self.d[2], f(d[2])),
            (self.w, f(w)),
            (self.l, f(l)),
            (self.u, f(u)),
            (self.x, f(w * l)),
            (self.dl[0], f(d[0] * l)),
            (self.dl[1], f(d[1] * l)),
            (self.dl[2], f(d[2] * l)),
        ]
    }
}

/// `d × v`.
fn cross(g: &mut Graph, d: [Id; 3], v: [Id; 3]) -> [Id; 3] {
    let c = |g: &mut Graph, a: usize, b: usize| {
        let x = g.mul2(d[a], v[b]);
        let y = g.mul2(d[b], v[a]);
        g.sub(x, y)
    };
    [c(g, 1, 2), c(g, 2, 0), c(g, 0, 1)]
}

/// The unit vector `e_i` as constants.
fn basis(g: &mut Graph, i: usize) -> [Id; 3] {
    let mut e = [g.zero(); 3];
    e[i] = g.one();
    e
}

/// `(sin(uW)/W, (1 − cos(uW))/W², (uW − sin(uW))/W³)` at abscissa `u`.
fn coefficients(g: &mut Graph, h: &HelixSymbols, u: Id) -> [Id; 3] {
    let x = g.mul2(u, h.w);
    let s = g.sin(x);
    let c = g.cos(x);
    let one = g.one();
    let iw = g.pow(h.w, -1);
    let iw2 = g.pow(h.w, -2);
    let iw3 = g.pow(h.w, -3);
    let a = g.mul2(s, iw);
    let omc = g.sub(one, c);
    let b = g.mul2(omc, iw2);
    let xms = g.sub(x, s);
    let cc = g.mul2(xms, iw3);
    [a, b, cc]
}

/// `P(u) v` for a vector `v` of expressions.
fn p_times(g: &mut Graph, h: &HelixSymbols, u: Id, v: [Id; 3]) -> [Id; 3] {
    let [_, b, c] = coefficients(g, h, u);
    let dxv = cross(g, h.d, v);
    let ddxv = cross(g, h.d, dxv);
    let mut out = [g.zero(); 3];
    for m in 0..3 {
        let t0 = g.mul2(u, v[m]);
        let t1 = g.mul2(b, dxv[m]);
        // K² v = d × (d × v), polynomial in d (no W² that would need W² = d·d)
        let t2 = g.mul2(c, ddxv[m]);
        out[m] = g.add(&[t0, t1, t2]);
    }
    out
}

/// `p(u) = P(u) e0`, the position at abscissa `u` in the element's start frame.
pub fn position(g: &mut Graph, h: &HelixSymbols, u: Id) -> [Id; 3] {
    rotation_column(g, h, u, 0)
}

/// `w_i(u) = P(u) e_i`, the angular derivative `∂E/∂d_i E^T = [w_i]×`.
pub fn rotation_column(g: &mut Graph, h: &HelixSymbols, u: Id, i: usize) -> [Id; 3] {
    let e = basis(g, i);
    p_times(g, h, u, e)
}

/// The frame rotation `E(u)` (row-major: `frame(..)[r][c]` is entry (r, c)).
pub fn frame(g: &mut Graph, h: &HelixSymbols, u: Id) -> [[Id; 3]; 3] {
    let [a, b, _] = coefficients(g, h, u);
    let mut out = [[g.zero(); 3]; 3];
    for c in 0..3 {
        let e = basis(g, c);
        let k = cross(g, h.d, e);
        let k2 = cross(g, h.d, k);
        for r in 0..3 {
            let t1 = g.mul2(a, k[r]);
            let t2 = g.mul2(b, k2[r]);
            out[r][c] = g.add(&[e[r], t1, t2]);
        }
    }
    out
}

/// The "M-related" integrands of the design page ("Efficient assembly"), named:
/// `p_a` (∫p), `ppt_ab` (∫p pᵀ, a ≤ b), `dp_i_a` (∫∂p/∂d_i), `pdp_a_i_b`
/// (∫p_a ∂p_b/∂d_i) and `dpdp_ij` (∫∂p/∂d_i · ∂p/∂d_j, i ≤ j): 51 integrands in u.
pub fn m_related_integrands(g: &mut Graph, h: &HelixSymbols) -> Vec<(String, Id)> {
    let p = position(g, h, h.u);
    let dp: Vec<[Id; 3]> = (0..3)
        .map(|i| [0, 1, 2].map(|a| g.diff(p[a], h.d[i])))
        .collect();
    let mut out = Vec::new();
    for a in 0..3 {
        out.push((format!("p_{a}"), p[a]));
    }
    for a in 0..3 {
        for b in a..3 {
            out.push((format!("ppt_{a}{b}"), g.mul2(p[a], p[b])));
        }
    }
    for i in 0..3 {
        for a in 0..3 {
            out.push((format!("dp_{i}_{a}"), dp[i][a]));
        }
    }
    for a in 0..3 {
        for i in 0..3 {
            for b in 0..3 {
                out.push((format!("pdp_{a}_{i}_{b}"), g.mul2(p[a], dp[i][b])));
            }
        }
    }
    for i in 0..3 {
        for j in i..3 {
            let t: Vec<Id> = (0..3).map(|a| g.mul2(dp[i][a], dp[j][a])).collect();
            out.push((format!("dpdp_{i}{j}"), g.add(&t)));
        }
    }
    out
}

/// The force-only centreline integrands (design page "Generalized force"), named:
/// `d2p_ij_a` (∫ ∂²p_a/∂d_i∂d_j, i ≤ j), `pd2p_ij_a_b` (∫ p_a ∂²p_b/∂d_i∂d_j, i ≤ j),
/// `dpdpt_i_j_a_b` (∫ ∂p_a/∂d_i ∂p_b/∂d_j; i < j, or i = j with a ≤ b: the rest is the
/// transpose) and `dpd2p_i_jk` (∫ ∂p/∂d_i · ∂²p/∂d_j∂d_k, j ≤ k): 135 integrands in u.
pub fn force_integrands(g: &mut Graph, h: &HelixSymbols) -> Vec<(String, Id)> {
    let p = position(g, h, h.u);
    let dp: Vec<[Id; 3]> = (0..3)
        .map(|i| [0, 1, 2].map(|a| g.diff(p[a], h.d[i])))
        .collect();
    let mut d2p = [[[g.zero(); 3]; 3]; 3];
    for i in 0..3 {
        for j in i..3 {
            for a in 0..3 {
                d2p[i][j][a] = g.diff(dp[i][a], h.d[j]);
                d2p[j][i][a] = d2p[i][j][a];
            }
        }
    }
    let mut out = Vec::new();
    for i in 0..3 {
        for j in i..3 {
            for a in 0..3 {
                out.push((format!("d2p_{i}{j}_{a}"), d2p[i][j][a]));
            }
        }
    }
    for i in 0..3 {
        for j in i..3 {
            for a in 0..3 {
                for b in 0..3 {
                    out.push((format!("pd2p_{i}{j}_{a}_{b}"), g.mul2(p[a], d2p[i][j][b])));
                }
            }
        }
    }
    for i in 0..3 {
        for j in i..3 {
            for a in 0..3 {
                for b in 0..3 {
                    if i == j && b < a {
                        continue;
                    }
                    out.push((format!("dpdpt_{i}_{j}_{a}_{b}"), g.mul2(dp[i][a], dp[j][b])));
                }
            }
        }
    }
    for i in 0..3 {
        for j in 0..3 {
            for k in j..3 {
                let t: Vec<Id> = (0..3).map(|a| g.mul2(dp[i][a], d2p[j][k][a])).collect();
                out.push((format!("dpd2p_{i}_{j}{k}"), g.add(&t)));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_a_rotation_and_position_is_its_integral() {
        let mut g = Graph::new();
        let h = HelixSymbols::new(&mut g);
        let e = frame(&mut g, &h, h.u);
        let p = position(&mut g, &h, h.u);
        let d = [2.0, -5.0, 3.5];
        let u = 0.3;
        let ev = |g: &Graph, x: Id, u: f64| g.eval(x, &h.bindings(d, 0.0, u));
        for r in 0..3 {
            for c in 0..3 {
                let dot: f64 = (0..3)
                    .map(|k| ev(&g, e[k][r], u) * ev(&g, e[k][c], u))
                    .sum();
                assert!((dot - if r == c { 1.0 } else { 0.0 }).abs() < 1e-14);
            }
            // p' = E e0 by a 4th-order difference
            let s = 1e-3;
            let f = |k: f64| ev(&g, p[r], u + k * s);
            let dp = (-f(2.0) + 8.0 * f(1.0) - 8.0 * f(-1.0) + f(-2.0)) / (12.0 * s);
            assert!((dp - ev(&g, e[r][0], u)).abs() < 1e-10);
        }
    }
}
