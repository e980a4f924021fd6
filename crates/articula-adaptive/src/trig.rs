//! `sin` and `cos` of a joint angle together, inlined into the active kinematics (a libm call
//! costs more on this hot path, with its rounding-mode guard, and makes every vector
//! register caller-saved around it).
//!
//! The FreeBSD / musl algorithm (fdlibm's): the argument reduced by `n π/2` with `n` the nearest
//! integer to `2x/π` (Cody–Waite, π/2 in three 33-bit parts, the second and third used only when
//! cancellation needs them: `__rem_pio2`'s medium case), then the polynomial kernels `__sin`,
//! `__cos` on `[−π/4, π/4]` with the reduction's tail, and the quadrant. Errors below one unit in
//! the last place (tested against the system libm over a million angles in ±10 rad: equal,
//! or one ulp apart for ~3% of them). Arguments beyond `|x| ≈ 8·10⁵` rad, infinities and NaN go to the libm.
//!
//! Plain multiplications and additions only (no fused multiply–adds), so the portable and the
//! AVX2 compilations of the kinematics give the same bits.

/// `2/π`.
const INV_PIO2: f64 = f64::from_bits(0x3fe45f30_6dc9c883); // 0.6366197723675814
/// The first 33 bits of `π/2` (`n · PIO2_1` is exact for `|n| < 2²⁰`) and `π/2 − PIO2_1`.
const PIO2_1: f64 = f64::from_bits(0x3ff921fb_54400000); // 1.5707963267341256
const PIO2_1T: f64 = f64::from_bits(0x3dd0b461_1a626331); // 6.077100506506192e-11
/// The next 33 bits and the remainder.
const PIO2_2: f64 = f64::from_bits(0x3dd0b461_1a600000); // 6.077100506303966e-11
const PIO2_2T: f64 = f64::from_bits(0x3ba3198a_2e037073); // 2.0222662487959506e-21
/// The next 33 bits and the remainder.
const PIO2_3: f64 = f64::from_bits(0x3ba3198a_2e000000); // 2.0222662487111665e-21
const PIO2_3T: f64 = f64::from_bits(0x397b839a_252049c1); // 8.4784276603689e-32
/// `1.5 · 2⁵²`: adding and subtracting it rounds `|v| < 2⁵¹` to the nearest integer (ties to
/// even), as `rint` does.
const TOINT: f64 = 6_755_399_441_055_744.0;
/// Arguments reduced here: `|x| < 2¹⁹ π/2` (`n` fits the exact products above).
const LIMIT: f64 = 823_549.6;

/// `__sin`'s coefficients (`sin x ≈ x + S1 x³ + … + S6 x¹³` on `[−π/4, π/4]`).
const S1: f64 = f64::from_bits(0xbfc55555_55555549); // -0.16666666666666632
const S2: f64 = f64::from_bits(0x3f811111_1110f8a6); // 0.00833333333332249
const S3: f64 = f64::from_bits(0xbf2a01a0_19c161d5); // -0.0001984126982985795
const S4: f64 = f64::from_bits(0x3ec71de3_57b1fe7d); // 2.7557313707070068e-06
const S5: f64 = f64::from_bits(0xbe5ae5e6_8a2b9ceb); // -2.5050760253406863e-08
const S6: f64 = f64::from_bits(0x3de5d93a_5acfd57c); // 1.58969099521155e-10
/// `__cos`'s coefficients (`cos x ≈ 1 − x²/2 + C1 x⁴ + … + C6 x¹⁴`).
const C1: f64 = f64::from_bits(0x3fa55555_5555554c); // 0.0416666666666666
const C2: f64 = f64::from_bits(0xbf56c16c_16c15177); // -0.001388888888887411
const C3: f64 = f64::from_bits(0x3efa01a0_19cb1590); // 2.480158728947673e-05
const C4: f64 = f64::from_bits(0xbe927e4f_809c52ad); // -2.7557314351390663e-07
const C5: f64 = f64::from_bits(0x3e21ee9e_bdb4b1c4); // 2.087572321298175e-09
const C6: f64 = f64::from_bits(0xbda8fae9_be8838d4); // -1.1359647557788195e-11

/// The biased binary exponent of `x`.
#[inline(always)]
fn exponent(x: f64) -> i64 {
    ((x.to_bits() >> 52) & 0x7ff) as i64
}

/// `(sin x, cos x)` (see the module doc).
#[inline(always)]
pub(crate) fn sin_cos(x: f64) -> (f64, f64) {
    if x.abs() < LIMIT {
        reduced(x)
    } else {
        // Large, infinite or NaN (which fails every comparison).
        x.sin_cos()
    }
}

/// [`sin_cos`] for `|x| < LIMIT`.
#[inline(always)]
fn reduced(x: f64) -> (f64, f64) {
    // __rem_pio2, medium case: x = n π/2 + (y0 + y1).
    // `n` rounded in the low bits of `2x/π + 1.5·2⁵²` (whose unit is 1): its last two bits are
    // the quadrant (`2⁵¹ ≡ 0 mod 4`, negative `n` in two's complement).
    let big = x * INV_PIO2 + TOINT;
    let fnn = big - TOINT;
    let n = big.to_bits();
    let mut r = x - fnn * PIO2_1;
    let mut w = fnn * PIO2_1T;
    let mut y0 = r - w;
    let ex = exponent(x);
    if ex - exponent(y0) > 16 {
        // Cancellation: the second 33 bits of π/2 (good to 118 bits).
        let t = r;
        w = fnn * PIO2_2;
        r = t - w;
        w = fnn * PIO2_2T - ((t - r) - w);
        y0 = r - w;
        if ex - exponent(y0) > 49 {
            // And the third (151 bits).
            let t = r;
            w = fnn * PIO2_3;
            r = t - w;
            w = fnn * PIO2_3T - ((t - r) - w);
            y0 = r - w;
        }
    }
    let y1 = (r - y0) - w;
    // __sin(y0, y1, 1) and __cos(y0, y1).
    let z = y0 * y0;
    let zz = z * z;
    let rs = S2 + z * (S3 + z * S4) + z * zz * (S5 + z * S6);
    let v = z * y0;
    let s = y0 - ((z * (0.5 * y1 - v * rs) - y1) - v * S1);
    let rc = z * (C1 + z * (C2 + z * C3)) + zz * zz * (C4 + z * (C5 + z * C6));
    let hz = 0.5 * z;
    let wc = 1.0 - hz;
    let c = wc + (((1.0 - wc) - hz) + (z * rc - y0 * y1));
    // The quadrant without branches: (s, c), (c, −s), (−s, −c), (−c, s) for n mod 4 = 0…3 —
    // swapped when n is odd, sin negated when bit 1 of n is set, cos when bit 1 of n + 1 is.
    let (a, b) = if n & 1 == 0 { (s, c) } else { (c, s) };
    let sign = |bit: u64, v: f64| f64::from_bits(v.to_bits() ^ ((bit & 2) << 62));
    (sign(n, a), sign(n.wrapping_add(1), b))
}

/// [`sin_cos`] of four angles in AVX2 lanes: the same operations per lane as [`reduced`] (a
/// multiply, then an add: no fused multiply–adds), so the same bits. Lanes beyond the
/// reduction's limit, NaN, or needing the cancellation steps (an argument within ~2⁻¹⁶ of a
/// multiple of π/2 relative to its size) send the four to [`sin_cos`] one by one.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(crate) unsafe fn sin_cos4(x: &[f64; 4]) -> ([f64; 4], [f64; 4]) {
    use std::arch::x86_64::*;
    let scalar = |x: &[f64; 4]| {
        let (mut s, mut c) = ([0.0; 4], [0.0; 4]);
        for l in 0..4 {
            (s[l], c[l]) = sin_cos(x[l]);
        }
        (s, c)
    };
    let k = |v: f64| _mm256_set1_pd(v);
    let xv = _mm256_loadu_pd(x.as_ptr());
    let ax = _mm256_andnot_pd(k(-0.0), xv);
    if _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(ax, k(LIMIT))) != 0xf {
        return scalar(x);
    }
    let big = _mm256_add_pd(_mm256_mul_pd(xv, k(INV_PIO2)), k(TOINT));
    let fnn = _mm256_sub_pd(big, k(TOINT));
    let r = _mm256_sub_pd(xv, _mm256_mul_pd(fnn, k(PIO2_1)));
    let w = _mm256_mul_pd(fnn, k(PIO2_1T));
    let y0 = _mm256_sub_pd(r, w);
    let exponent = |v: __m256d| {
        _mm256_and_si256(
            _mm256_srli_epi64::<52>(_mm256_castpd_si256(v)),
            _mm256_set1_epi64x(0x7ff),
        )
    };
    let gap = _mm256_sub_epi64(exponent(xv), exponent(y0));
    let cancel = _mm256_cmpgt_epi64(gap, _mm256_set1_epi64x(16));
    if _mm256_movemask_pd(_mm256_castsi256_pd(cancel)) != 0 {
        return scalar(x);
    }
    let y1 = _mm256_sub_pd(_mm256_sub_pd(r, y0), w);
    let (add, sub, mul) = (_mm256_add_pd, _mm256_sub_pd, _mm256_mul_pd);
    let z = mul(y0, y0);
    let zz = mul(z, z);
    // rs = S2 + z (S3 + z S4) + z zz (S5 + z S6)
    let rs = add(
        add(k(S2), mul(z, add(k(S3), mul(z, k(S4))))),
        mul(mul(z, zz), add(k(S5), mul(z, k(S6)))),
    );
    let v = mul(z, y0);
    // s = y0 − ((z (½ y1 − v rs) − y1) − v S1)
    let sv = sub(
        y0,
        sub(
            sub(mul(z, sub(mul(k(0.5), y1), mul(v, rs))), y1),
            mul(v, k(S1)),
        ),
    );
    // rc = z (C1 + z (C2 + z C3)) + zz zz (C4 + z (C5 + z C6))
    let rc = add(
        mul(z, add(k(C1), mul(z, add(k(C2), mul(z, k(C3)))))),
        mul(mul(zz, zz), add(k(C4), mul(z, add(k(C5), mul(z, k(C6)))))),
    );
    let hz = mul(k(0.5), z);
    let wc = sub(k(1.0), hz);
    // c = wc + (((1 − wc) − hz) + (z rc − y0 y1))
    let cv = add(
        wc,
        add(sub(sub(k(1.0), wc), hz), sub(mul(z, rc), mul(y0, y1))),
    );
    // The quadrant: swapped where n is odd, signs from bit 1 of n and of n + 1.
    let n = _mm256_castpd_si256(big);
    let one = _mm256_set1_epi64x(1);
    let two = _mm256_set1_epi64x(2);
    let odd = _mm256_castsi256_pd(_mm256_cmpeq_epi64(_mm256_and_si256(n, one), one));
    let a = _mm256_blendv_pd(sv, cv, odd);
    let b = _mm256_blendv_pd(cv, sv, odd);
    let flip = |m: __m256i, v: __m256d| {
        let bit = _mm256_slli_epi64::<62>(_mm256_and_si256(m, two));
        _mm256_xor_pd(v, _mm256_castsi256_pd(bit))
    };
    let (mut so, mut co) = ([0.0; 4], [0.0; 4]);
    _mm256_storeu_pd(so.as_mut_ptr(), flip(n, a));
    _mm256_storeu_pd(co.as_mut_ptr(), flip(_mm256_add_epi64(n, one), b));
    (so, co)
}

#[cfg(test)]
mod tests {
    use super::sin_cos;

    /// Distance in units in the last place (same sign assumed for non-zero values).
    fn ulps(a: f64, b: f64) -> u64 {
        if a == b {
            return 0;
        }
        let key = |x: f64| {
            let i = x.to_bits() as i64;
            if i < 0 {
                i64::MIN - i
            } else {
                i
            }
        };
        key(a).abs_diff(key(b))
    }

    fn check(x: f64) {
        let (s, c) = sin_cos(x);
        let (s0, c0) = x.sin_cos();
        assert!(
            ulps(s, s0) <= 1 && ulps(c, c0) <= 1,
            "x = {x:e}: ({s:e}, {c:e}) against libm ({s0:e}, {c0:e})"
        );
    }

    /// Within one ulp of the system libm (itself correctly rounded in all but rare cases):
    /// a million pseudo-random angles in ±10 rad, wider ranges up to the reduction's limit,
    /// every quadrant boundary `k π/2` (the cancellation paths) and its neighbours, tiny and
    /// subnormal arguments, signed zeros; beyond the limit, infinities and NaN as the libm.
    #[test]
    fn within_one_ulp_of_libm() {
        let mut s: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..1_000_000 {
            check(20.0 * next() - 10.0);
        }
        for scale in [1e-3, 1.0, 1e2, 1e4, 8e5] {
            for _ in 0..20_000 {
                check(scale * (2.0 * next() - 1.0));
            }
        }
        for k in -2000i32..=2000 {
            let x = f64::from(k) * std::f64::consts::FRAC_PI_2;
            let mut y = x;
            for _ in 0..4 {
                check(y);
                check(-y);
                y = y.next_up();
            }
            let mut y = x;
            for _ in 0..4 {
                y = y.next_down();
                check(y);
            }
        }
        for x in [
            0.0,
            1e-300,
            f64::MIN_POSITIVE,
            5e-324,
            1e-8,
            0.785,
            std::f64::consts::FRAC_PI_4,
            std::f64::consts::FRAC_PI_4.next_up(),
            std::f64::consts::FRAC_PI_4.next_down(),
            823_549.0,
            823_550.0,
            1e6,
            1e300,
            f64::MAX,
        ] {
            check(x);
            check(-x);
        }
        assert_eq!(sin_cos(0.0).0.to_bits(), 0.0f64.to_bits());
        assert_eq!(sin_cos(-0.0).0.to_bits(), (-0.0f64).to_bits());
        assert_eq!(sin_cos(-0.0).1, 1.0);
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // Four at a time: the same bits as one at a time, including groups with a lane
            // that takes the scalar path (beyond the limit, NaN, near a multiple of π/2).
            let mut xs: Vec<f64> = (0..40_000).map(|_| 20.0 * next() - 10.0).collect();
            xs.extend([
                std::f64::consts::FRAC_PI_2,
                1.0,
                -0.0,
                0.0,
                1e6,
                f64::NAN,
                2.0,
                3.0,
            ]);
            for g in xs.chunks_exact(4) {
                let g: &[f64; 4] = g.try_into().unwrap();
                // SAFETY: AVX2 detected above.
                let (s4, c4) = unsafe { super::sin_cos4(g) };
                for l in 0..4 {
                    let (s, c) = sin_cos(g[l]);
                    assert_eq!(s4[l].to_bits(), s.to_bits(), "sin {:e}", g[l]);
                    assert_eq!(c4[l].to_bits(), c.to_bits(), "cos {:e}", g[l]);
                }
            }
        }
        for x in [f64::INFINITY, f64::NEG_INFINITY, f64::NAN] {
            let (s, c) = sin_cos(x);
            assert!(s.is_nan() && c.is_nan());
        }
    }
}
