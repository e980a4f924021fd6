//! How a pass forms `a·b + c`, and whether this CPU can run the passes compiled for AVX2 + FMA
//! (docs/design.md#dca): the arithmetic strategy that the DCA pass here, and other crates'
//! passes written over it, are compiled with.

/// Whether this CPU can run the fused (AVX2 + FMA) compilations: of the DCA pass
/// (checked once per `Data`), and of other crates' passes written over [`Arith`].
pub fn fused_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// How a pass forms `a·b + c`: rounded twice ([`Portable`]) or once ([`Fused`]). The two
/// give the same solution to rounding. A pass written over `Arith` is compiled twice: with
/// [`Portable`] for any CPU, and with [`Fused`] only inside a function compiled with
/// `#[target_feature(enable = "avx2,fma")]` into which everything using it is inlined (in
/// this crate the DCA pass's `dca_fused`), called only when [`fused_available`].
pub trait Arith {
    /// `a·b + c`.
    fn mul_add(a: f64, b: f64, c: f64) -> f64;

    /// `c − a·b`.
    #[inline(always)]
    fn neg_mul_add(a: f64, b: f64, c: f64) -> f64 {
        Self::mul_add(-a, b, c)
    }
}

/// `a·b + c` as a product and a sum (any CPU).
pub struct Portable;

impl Arith for Portable {
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a * b + c
    }
    #[inline(always)]
    fn neg_mul_add(a: f64, b: f64, c: f64) -> f64 {
        c - a * b
    }
}

/// `a·b + c` rounded once: a `vfmadd` inside a function compiled for AVX2 + FMA such as the
/// DCA pass's `dca_fused` (elsewhere `f64::mul_add` would call a slow library routine, so only
/// such functions may use this type).
#[cfg(target_arch = "x86_64")]
pub struct Fused;

#[cfg(target_arch = "x86_64")]
impl Arith for Fused {
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a.mul_add(b, c)
    }
}
