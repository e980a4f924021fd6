//! Test support shared by the crates of the articula workspace (`publish = false`): what their
//! tests, benchmarks and `cargo xtask` have in common.
//!
//! - [`fixtures`]: the bundled models (embedded, so no test reads `models/` at run time) and
//!   procedural chains of any length.
//! - [`alloc`]: a counting global allocator for the "a step allocates nothing" tests.
//! - [`dd`] and [`reference`](mod@reference): double-double arithmetic and a high-precision articulated-body
//!   algorithm written independently of the library, the reference for accuracy tests.
//! - With the `dca` feature, [`seeds`]: the adaptive benchmarks' state with external forces.
//!
//! It depends on articula-model only (and articula-dca with `dca`), so every crate from
//! articula-dca up can dev-depend on it.
//!
//! ```
//! let model = articula_testkit::chain(1000);
//! assert_eq!((model.bodies.len(), model.nv), (1000, 1000));
//! assert_eq!(model.assembly.max_handles(), 2);
//! ```

pub mod alloc;
pub mod dd;
pub mod fixtures;
pub mod reference;
#[cfg(feature = "dca")]
pub mod seeds;

pub use alloc::{count_allocated_bytes, count_allocations, CountingAllocator};
pub use dd::{Dd, Real};
pub use fixtures::{
    branches_urdf, bundled, bundled_urdf, bundled_with, chain, chain_urdf, example_robots_dir,
    hair_urdf, point_mass_humanoid_urdf, random_tree_urdf, ratio_chain_urdf, star_urdf,
    urdfs_under, ARMATURE_MJCF, BUNDLED, SWIMMER_MJCF,
};
pub use reference::{rel_error, ReferenceModel};
