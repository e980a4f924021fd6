//! How a pass forms `a·b + c`, whether this CPU can run the passes compiled for AVX2 + FMA,
//! and `fma_dispatch!`, which compiles a pass both ways and picks one
//! at run time (docs/design.md#numerics).

/// Whether this CPU can run the AVX2 + FMA compilations of `fma_dispatch!`
/// (detected once by the standard library, then cached).
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
/// give the same solution to rounding. A pass written over `Arith` is compiled twice by
/// `fma_dispatch!`: with [`Portable`] for any CPU, and inside a
/// function compiled with `#[target_feature(enable = "avx2,fma")]`, into which everything
/// using it is inlined, with the strategy the dispatch names (usually [`Fused`]).
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

/// `a·b + c` rounded once: a `vfmadd` inside a function compiled for AVX2 + FMA (the
/// AVX2 + FMA compilation of `fma_dispatch!`); elsewhere
/// `f64::mul_add` would call a slow library routine, so only such functions may use this type.
#[cfg(target_arch = "x86_64")]
pub struct Fused;

#[cfg(target_arch = "x86_64")]
impl Arith for Fused {
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a.mul_add(b, c)
    }
}

/// A function compiled twice, for any CPU and for AVX2 + FMA, and a dispatcher that runs the
/// second when a flag says so (the workspace's one way to do it; docs/design.md#numerics).
///
/// ```text
/// fma_dispatch! {
///     /// Documentation of the dispatcher.
///     pub(crate) fn name<const K: usize>(arg: Type, …) -> Ret;
///     avx2_fma: FLAG, STRATEGY;
///     |A| BODY
/// }
/// ```
///
/// expands to `fn name(arg: Type, …) -> Ret` which evaluates `BODY` with the type `A` =
/// [`Portable`], unless on x86-64 `FLAG` is true: then it calls a private inner function
/// compiled with `#[target_feature(enable = "avx2,fma")]` that evaluates `BODY` with `A` =
/// `STRATEGY` ([`Fused`]: fused multiply–adds; [`Portable`]: the same bits, with wider
/// vectors and three-operand instructions). `BODY` should call an `#[inline(always)]`
/// function generic over [`Arith`] so that all of it is compiled with those features. `FLAG`
/// must be true only where [`fused_available`] is (callers cache that answer in their
/// workspace, and set the flag false to run the portable compilation anywhere). Const generic
/// parameters (`<const K: usize, …>`) are passed on to the inner function.
#[macro_export]
macro_rules! fma_dispatch {
    (
        $(#[$meta:meta])*
        $vis:vis fn $name:ident $(<$(const $k:ident : $kt:ty),+ $(,)?>)?
            ($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)?;
        avx2_fma: $flag:expr, $strategy:ident;
        |$a:ident| $body:expr
    ) => {
        $(#[$meta])*
        #[allow(clippy::too_many_arguments)]
        $vis fn $name $(<$(const $k: $kt),+>)? ($($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2,fma")]
                #[allow(clippy::too_many_arguments)]
                fn avx2_fma $(<$(const $k: $kt),+>)? ($($arg: $ty),*) $(-> $ret)? {
                    #[allow(unused)]
                    type $a = $crate::numerics::$strategy;
                    $body
                }
                if $flag {
                    // SAFETY: the flag is true only where the CPU has AVX2 and FMA
                    // (`fused_available`), the features this function is compiled for.
                    return unsafe { avx2_fma $(::<$($k),+>)? ($($arg),*) };
                }
            }
            #[allow(unused)]
            type $a = $crate::numerics::Portable;
            $body
        }
    };
}
