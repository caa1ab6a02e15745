//! The translation operators of the fast multipole method on the scaled solid harmonics
//! of [`crate::harmonics`]: P2M, M2M, M2L, L2L, L2P (and M2P, for checks).
//!
//! A multipole expansion about `c` stands for `Φ(x) = Σ M_n^m I_n^m(x − c)` outside a
//! sphere around `c` holding the charges (the paper's eqs. 3–4); a local expansion about
//! `c` stands for `Φ(c + y) = Σ L_n^m conj(R_n^m(y))` inside a sphere free of charges.
//! Both are kept for `0 ≤ m ≤ n ≤ p` (triangular arrays, [`tri_len`]`(p)` long): the
//! potential is real, so `X_n^{−m} = (−1)^m conj(X_n^m)`.
//!
//! ```text
//! P2M  M_n^m  = Σ_i q_i conj(R_n^m(x_i − c))
//! M2M  M'_n^m = Σ_{k ≤ n} Σ_l conj(R_k^l(d)) M_{n−k}^{m−l},           d = c − c'
//! M2L  L_n^m  = (−1)^n Σ_{j ≤ p−n} Σ_k M_j^k I_{j+n}^{k+m}(D),         D = c_L − c_M
//! L2L  L'_j^i = Σ_{k ≤ p−j} Σ_l L_{j+k}^{i+l} conj(R_k^l(d)),         d = c' − c
//! L2P  Φ(c + y) = Σ L_n^m conj(R_n^m(y)),  ∇Φ from ∂R_n^m (harmonics.rs)
//! ```
//!
//! Each follows from the addition theorems of [`crate::harmonics`]; `tests` check each
//! against a direct sum.

use crate::fmm::MAX_ORDER;
use crate::harmonics::{irregular, regular, signed, tri, tri_len};
use num_complex::Complex64 as C;

/// Per-thread scratch of the operators for order `p`.
pub struct Scratch {
    p: usize,
    /// Regular harmonics up to degree p (triangular).
    r: Vec<C>,
    /// Irregular harmonics up to degree p (triangular).
    i: Vec<C>,
    /// M2L's buffers ([`m2l`] is a batch of one).
    batch: BatchScratch,
}

impl Scratch {
    /// Scratch for expansions of order `p`.
    pub fn new(p: usize) -> Self {
        Scratch {
            p,
            r: vec![C::new(0.0, 0.0); tri_len(p)],
            i: vec![C::new(0.0, 0.0); tri_len(p)],
            batch: BatchScratch::new(p),
        }
    }

    /// The order these buffers serve.
    pub fn order(&self) -> usize {
        self.p
    }
}

fn sign(n: usize) -> f64 {
    if n % 2 == 0 {
        1.0
    } else {
        -1.0
    }
}

/// P2M: add the expansion about `c` of the charges `q` at `x` to `m`.
pub fn p2m(c: [f64; 3], x: &[[f64; 3]], q: &[f64], m: &mut [C], s: &mut Scratch) {
    let p = s.p;
    for (xi, &qi) in x.iter().zip(q) {
        regular([xi[0] - c[0], xi[1] - c[1], xi[2] - c[2]], p, &mut s.r);
        for (mm, r) in m.iter_mut().zip(&s.r) {
            *mm += r.conj() * qi;
        }
    }
}

/// M2M: add the expansion `child` about `c_child`, moved to `c_parent`, to `parent`.
pub fn m2m(c_child: [f64; 3], c_parent: [f64; 3], child: &[C], parent: &mut [C], s: &mut Scratch) {
    let p = s.p;
    let d = [
        c_child[0] - c_parent[0],
        c_child[1] - c_parent[1],
        c_child[2] - c_parent[2],
    ];
    regular(d, p, &mut s.r);
    for n in 0..=p {
        for m in 0..=n {
            let mut acc = C::new(0.0, 0.0);
            for k in 0..=n {
                let lo = (m as isize - (n - k) as isize).max(-(k as isize));
                let hi = (m as isize + (n - k) as isize).min(k as isize);
                for l in lo..=hi {
                    acc += signed(&s.r, k, l).conj() * signed(child, n - k, m as isize - l);
                }
            }
            parent[tri(n, m)] += acc;
        }
    }
}

/// M2L: add the local expansion about `c_local` of the multipole expansion `mp` about
/// `c_multipole` to `local`. The spheres around the two centres must not overlap.
///
/// Written as, for each `(n, j, k)`, an update of every `m` at once
/// (`L_n^{0..n} += M_j^k I_{j+n}^{k+0..k+n}`, real and imaginary parts in separate rows)
/// so that the compiler vectorises it.
pub fn m2l(c_multipole: [f64; 3], c_local: [f64; 3], mp: &[C], local: &mut [C], s: &mut Scratch) {
    m2l_batch(&[(c_multipole, mp)], c_local, local, &mut s.batch)
}

/// M2L of up to four multipole expansions into one local expansion at once: the same
/// sums as [`m2l`], with the four sources in the four lanes of every operation (one
/// AVX2 register of f64), so that the vector units do four translations for the price
/// of one. Lanes beyond `sources.len()` are idle.
pub fn m2l_batch(
    sources: &[([f64; 3], &[C])],
    c_local: [f64; 3],
    local: &mut [C],
    s: &mut BatchScratch,
) {
    debug_assert!(sources.len() <= LANES);
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the processor has AVX2 and FMA (checked just above).
            unsafe { m2l_batch_avx2(sources, c_local, local, s) };
            return;
        }
    }
    m2l_batch_generic(sources, c_local, local, s)
}

/// Lanes of [`m2l_batch`].
pub const LANES: usize = 4;

/// Scratch of [`m2l_batch`]: the four sources' harmonics and expansions, lane-interleaved.
pub struct BatchScratch {
    p: usize,
    one: Vec<C>,
    ire: Vec<[f64; LANES]>,
    iim: Vec<[f64; LANES]>,
    mre: Vec<[f64; LANES]>,
    mim: Vec<[f64; LANES]>,
}

impl BatchScratch {
    /// Scratch for order `p`.
    pub fn new(p: usize) -> Self {
        let size = (p + 1) * (2 * p + 1);
        BatchScratch {
            p,
            one: vec![C::new(0.0, 0.0); tri_len(p)],
            ire: vec![[0.0; LANES]; size],
            iim: vec![[0.0; LANES]; size],
            mre: vec![[0.0; LANES]; size],
            mim: vec![[0.0; LANES]; size],
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn m2l_batch_avx2(
    sources: &[([f64; 3], &[C])],
    c_local: [f64; 3],
    local: &mut [C],
    s: &mut BatchScratch,
) {
    m2l_batch_generic(sources, c_local, local, s)
}

#[inline(always)]
fn m2l_batch_generic(
    sources: &[([f64; 3], &[C])],
    c_local: [f64; 3],
    local: &mut [C],
    s: &mut BatchScratch,
) {
    let p = s.p;
    let w = 2 * p + 1;
    for lane in 0..LANES {
        let Some(&(c, mp)) = sources.get(lane) else {
            for n in 0..=p {
                for at in n * w + p - n..=n * w + p + n {
                    s.mre[at][lane] = 0.0;
                    s.mim[at][lane] = 0.0;
                    s.ire[at][lane] = 0.0;
                    s.iim[at][lane] = 0.0;
                }
            }
            continue;
        };
        irregular(
            [c_local[0] - c[0], c_local[1] - c[1], c_local[2] - c[2]],
            p,
            &mut s.one,
        );
        for n in 0..=p {
            for m in -(n as isize)..=(n as isize) {
                let at = n * w + (m + p as isize) as usize;
                let v = signed(&s.one, n, m);
                s.ire[at][lane] = v.re;
                s.iim[at][lane] = v.im;
                let v = signed(mp, n, m);
                s.mre[at][lane] = v.re;
                s.mim[at][lane] = v.im;
            }
        }
    }
    let (ire, iim, mre, mim) = (&s.ire, &s.iim, &s.mre, &s.mim);
    let mut acc_re = [[0.0; LANES]; MAX_ORDER + 1];
    let mut acc_im = [[0.0; LANES]; MAX_ORDER + 1];
    for n in 0..=p {
        let (are, aim) = (&mut acc_re[..=n], &mut acc_im[..=n]);
        for v in are.iter_mut().chain(aim.iter_mut()) {
            *v = [0.0; LANES];
        }
        for j in 0..=(p - n) {
            let row = (j + n) * w + p - j;
            let mrow = j * w + p - j;
            for k in 0..=2 * j {
                let (ar, ai) = (mre[mrow + k], mim[mrow + k]);
                let start = row + k;
                let (br, bi) = (&ire[start..start + n + 1], &iim[start..start + n + 1]);
                for (((x, y), b), c) in are.iter_mut().zip(aim.iter_mut()).zip(br).zip(bi) {
                    for l in 0..LANES {
                        x[l] += ar[l] * b[l] - ai[l] * c[l];
                        y[l] += ar[l] * c[l] + ai[l] * b[l];
                    }
                }
            }
        }
        let sg = sign(n);
        for m in 0..=n {
            let re: f64 = are[m].iter().sum();
            let im: f64 = aim[m].iter().sum();
            local[tri(n, m)] += C::new(re * sg, im * sg);
        }
    }
}

/// L2L: add the local expansion `parent` about `c_parent`, moved to `c_child`, to `child`.
pub fn l2l(c_parent: [f64; 3], c_child: [f64; 3], parent: &[C], child: &mut [C], s: &mut Scratch) {
    let p = s.p;
    let d = [
        c_child[0] - c_parent[0],
        c_child[1] - c_parent[1],
        c_child[2] - c_parent[2],
    ];
    regular(d, p, &mut s.r);
    for j in 0..=p {
        for i in 0..=j {
            let mut acc = C::new(0.0, 0.0);
            for k in 0..=(p - j) {
                let lo = (-(k as isize)).max(-((j + k) as isize) - i as isize);
                let hi = (k as isize).min((j + k) as isize - i as isize);
                for l in lo..=hi {
                    acc += signed(parent, j + k, i as isize + l) * signed(&s.r, k, l).conj();
                }
            }
            child[tri(j, i)] += acc;
        }
    }
}

/// L2P: the potential and its gradient at `x` of the local expansion `local` about `c`.
pub fn l2p(c: [f64; 3], local: &[C], x: [f64; 3], s: &mut Scratch) -> (f64, [f64; 3]) {
    let p = s.p;
    regular([x[0] - c[0], x[1] - c[1], x[2] - c[2]], p, &mut s.r);
    let r = &s.r;
    // Φ = Σ_n [L_n^0 conj R_n^0 + 2 Re Σ_{m>0} L_n^m conj R_n^m].
    let mut phi = 0.0;
    for n in 0..=p {
        phi += (local[tri(n, 0)] * r[tri(n, 0)].conj()).re;
        for m in 1..=n {
            phi += 2.0 * (local[tri(n, m)] * r[tri(n, m)].conj()).re;
        }
    }
    // ∂_z Φ = Σ L_n^m conj R_{n−1}^m;
    // ∂_x Φ = ½ Σ L_n^m conj(R_{n−1}^{m+1} − R_{n−1}^{m−1});
    // ∂_y Φ = (i/2) Σ L_n^m conj(R_{n−1}^{m+1} + R_{n−1}^{m−1}); sums over every m.
    let mut g = [0.0; 3];
    let zero = C::new(0.0, 0.0);
    for n in 1..=p {
        let k = (n - 1) as isize;
        let rr = |m: isize| {
            if m.abs() <= k {
                signed(r, n - 1, m).conj()
            } else {
                zero
            }
        };
        for m in -(n as isize)..=(n as isize) {
            let l = signed(local, n, m);
            let up = rr(m + 1);
            let down = rr(m - 1);
            g[2] += (l * rr(m)).re;
            g[0] += 0.5 * (l * (up - down)).re;
            g[1] += (l * C::new(0.0, 0.5) * (up + down)).re;
        }
    }
    (phi, g)
}

/// M2P: the potential at `x` of the multipole expansion `mp` about `c` (for checks).
pub fn m2p(c: [f64; 3], mp: &[C], x: [f64; 3], s: &mut Scratch) -> f64 {
    let p = s.p;
    irregular([x[0] - c[0], x[1] - c[1], x[2] - c[2]], p, &mut s.i);
    let mut phi = 0.0;
    for n in 0..=p {
        phi += (mp[tri(n, 0)] * s.i[tri(n, 0)]).re;
        for m in 1..=n {
            phi += 2.0 * (mp[tri(n, m)] * s.i[tri(n, m)]).re;
        }
    }
    phi
}
