//! The discrete Fourier transform by the iterative radix-2 Cooley–Tukey algorithm, in place on
//! separate real and imaginary parts: X[k] = sum_j x[j] exp(-2 pi i j k / n) (forward), and
//! x[j] = (1/n) sum_k X[k] exp(+2 pi i j k / n) (inverse). Used by [`super::xcorr`] for the
//! cross-correlation of activity series over every lag.
//!
//! Complexity: O(n log n) time, no allocation. `n` must be a power of two (the caller pads).

/// Transforms `re` + i `im` in place (`inverse`: the inverse transform, scaled by 1/n).
/// Panics if the lengths differ or are not a power of two: a programming error, never input
/// (the callers pad to `next_power_of_two`).
pub fn fft(re: &mut [f64], im: &mut [f64], inverse: bool) {
    let n = re.len();
    assert!(n == im.len() && n.is_power_of_two(), "fft: lengths must be equal powers of two");
    if n <= 1 {
        return;
    }
    // bit-reversal permutation
    let mut j = 0usize;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            re.swap(i, j);
            im.swap(i, j);
        }
    }
    let sign = if inverse { 1.0 } else { -1.0 };
    let mut len = 2;
    while len <= n {
        let ang = sign * 2.0 * std::f64::consts::PI / len as f64;
        let half = len / 2;
        for start in (0..n).step_by(len) {
            for k in 0..half {
                // twiddle computed directly (not by repeated multiplication): no drift on long series
                let (s, c) = (ang * k as f64).sin_cos();
                let (a, b) = (start + k, start + k + half);
                let tr = re[b] * c - im[b] * s;
                let ti = re[b] * s + im[b] * c;
                re[b] = re[a] - tr;
                im[b] = im[a] - ti;
                re[a] += tr;
                im[a] += ti;
            }
        }
        len <<= 1;
    }
    if inverse {
        let f = 1.0 / n as f64;
        re.iter_mut().for_each(|x| *x *= f);
        im.iter_mut().for_each(|x| *x *= f);
    }
}

#[cfg(test)]
mod tests {
    use super::fft;

    #[test]
    fn matches_the_direct_dft_and_inverts() {
        for n in [1usize, 2, 4, 8, 64] {
            let x: Vec<f64> = (0..n).map(|j| ((j * 7 + 3) % 11) as f64 - 5.0).collect();
            let (mut re, mut im) = (x.clone(), vec![0.0; n]);
            fft(&mut re, &mut im, false);
            for k in 0..n {
                let (mut sr, mut si) = (0.0, 0.0);
                for (j, v) in x.iter().enumerate() {
                    let a = -2.0 * std::f64::consts::PI * (j * k) as f64 / n as f64;
                    sr += v * a.cos();
                    si += v * a.sin();
                }
                assert!((re[k] - sr).abs() < 1e-9 && (im[k] - si).abs() < 1e-9, "n {n} k {k}");
            }
            fft(&mut re, &mut im, true);
            for j in 0..n {
                assert!((re[j] - x[j]).abs() < 1e-9 && im[j].abs() < 1e-9);
            }
        }
    }
}
