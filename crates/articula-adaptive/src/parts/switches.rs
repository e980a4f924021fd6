//! Which implementation of a pass a workspace runs (the results agree; tests compare them).

/// Switches between a pass and its reference or its compiled variant.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Switches {
    /// Run every call as whole-body passes (the reference for the hierarchical state).
    pub full_passes: bool,
    /// Run the reduced ABA compiled with fused multiply–adds, and the other hot passes (join,
    /// kinematics, rigid coefficients, back-substitution, cache evaluations) compiled for
    /// AVX2 + FMA with the same arithmetic as their portable versions (set where the CPU has
    /// AVX2 and FMA: `articula_spatial::numerics::fused_available`).
    pub fused: bool,
    /// Re-select through the caches (O(active region)); off: whole-body passes (reference).
    pub use_cache: bool,
    /// How a due re-selection finds the new hybrid body ([`crate::Reselection`]).
    pub reselection: crate::Reselection,
}

impl Default for Switches {
    /// The fast paths, the fused ones where the CPU has them.
    fn default() -> Switches {
        Switches {
            full_passes: false,
            fused: articula_spatial::numerics::fused_available(),
            use_cache: true,
            reselection: crate::Reselection::ExactSolve,
        }
    }
}
