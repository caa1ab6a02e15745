//! CPU time of one M2L at order p (minimum of several rounds).
//! `cargo run --release -p superhelix-fmm --example m2l_cost -- P`
use num_complex::Complex64 as C;
use superhelix_fmm::harmonics::tri_len;
use superhelix_fmm::operators::{m2l, Scratch};

fn cpu() -> f64 {
    let mut t = libc_time();
    t.0 += 0;
    t.0 as f64 + t.1 as f64 * 1e-9
}
fn libc_time() -> (i64, i64) {
    // CLOCK_THREAD_CPUTIME_ID through std is not available; use process time via /proc.
    let s = std::fs::read_to_string("/proc/thread-self/stat").unwrap();
    let f: Vec<&str> = s.rsplit(')').next().unwrap().split_whitespace().collect();
    let ticks: i64 = f[11].parse::<i64>().unwrap() + f[12].parse::<i64>().unwrap();
    (ticks / 100, (ticks % 100) * 10_000_000)
}

fn main() {
    let p: usize = std::env::args().nth(1).map_or(12, |v| v.parse().unwrap());
    let mut s = Scratch::new(p);
    let mp: Vec<C> = (0..tri_len(p))
        .map(|k| C::new(1.0 / (k + 1) as f64, 0.5 / (k + 2) as f64))
        .collect();
    let mut l = vec![C::new(0.0, 0.0); tri_len(p)];
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let t = cpu();
        for k in 0..200_000 {
            let d = 3.0 + (k % 7) as f64 * 0.1;
            m2l([0.0; 3], [d, 0.3 * d, -0.2 * d], &mp, &mut l, &mut s);
        }
        best = best.min((cpu() - t) / 200_000.0);
    }
    println!("p={p}: {:.3} us per M2L ({:e})", best * 1e6, l[3].re);
}
