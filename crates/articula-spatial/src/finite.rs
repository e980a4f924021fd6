//! The finiteness check of the solvers' inputs and outputs.

/// Whether every entry of `xs` is finite, without an early exit so that it vectorises: `x·0`
/// is ±0 for a finite `x` and NaN for an infinite or NaN one, summed in four lanes (a sum of
/// zeros is zero; one NaN makes it NaN). The input checks of articula-dca's solvers and of
/// articula-adaptive's steps use it.
#[inline]
pub fn all_finite(xs: &[f64]) -> bool {
    let mut acc = [0.0f64; 4];
    let mut chunks = xs.chunks_exact(4);
    for c in &mut chunks {
        for k in 0..4 {
            acc[k] += c[k] * 0.0;
        }
    }
    for &x in chunks.remainder() {
        acc[0] += x * 0.0;
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) == 0.0
}

#[cfg(test)]
mod tests {
    /// `all_finite` against `is_finite` entry by entry: every length up to 13 (the four-lane
    /// chunks and every remainder), with one NaN, +∞ or −∞ at each position, and all finite
    /// (signed zeros, subnormals, the largest finite values included).
    #[test]
    fn all_finite_matches_is_finite() {
        let finite = [
            0.0,
            -0.0,
            1.5,
            -2.25e300,
            f64::MAX,
            f64::MIN,
            5e-324,
            -1e-310,
        ];
        for len in 0..=13 {
            let base: Vec<f64> = (0..len).map(|i| finite[i % finite.len()]).collect();
            assert!(super::all_finite(&base), "len {len}");
            for pos in 0..len {
                for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                    let mut xs = base.clone();
                    xs[pos] = bad;
                    let expected = xs.iter().all(|x| x.is_finite());
                    assert!(!expected);
                    assert_eq!(
                        super::all_finite(&xs),
                        expected,
                        "len {len} pos {pos} {bad}"
                    );
                }
            }
        }
    }
}
