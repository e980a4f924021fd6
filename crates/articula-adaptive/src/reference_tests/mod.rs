//! Tests that compare a fast path with the reference path it replaces, both selected by
//! switches only tests can turn (`#[cfg(test)]` methods of [`crate::Adaptive`]): cached
//! re-selection against whole-body re-selection, forced-path maps against recomputed paths,
//! the hierarchical state against whole-body passes, the fused (AVX2 + FMA) compilation
//! against the portable one, and workspaces stepped through one shared scratch against each
//! stepped alone.

mod cache;
mod fused;
mod passes;
mod scratch;
