//! What the clustering examples share: `n` and the methods from the command line, and n random
//! 2-D points (a fixed xorshift seed, so every run and example times the same input).

pub fn setup() -> (usize, Vec<String>, Vec<(f64, f64)>) {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(5000);
    let mut methods: Vec<String> = args.collect();
    if methods.is_empty() {
        methods = ["single", "complete", "average", "weighted", "ward"].map(String::from).to_vec();
    }
    let mut s = 5u64;
    let mut rnd = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 * 1000.0
    };
    let pts: Vec<(f64, f64)> = (0..n).map(|_| (rnd(), rnd())).collect();
    (n, methods, pts)
}

/// The Euclidean distance of points `i` and `j`.
pub fn dist(pts: &[(f64, f64)], i: usize, j: usize) -> f64 {
    ((pts[i].0 - pts[j].0).powi(2) + (pts[i].1 - pts[j].1).powi(2)).sqrt()
}

/// Repetitions per timing: `REPS` in the environment, default 3.
pub fn reps() -> usize {
    std::env::var("REPS").ok().and_then(|s| s.parse().ok()).unwrap_or(3)
}
