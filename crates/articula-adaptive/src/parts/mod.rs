//! The named parts of an `Adaptive` workspace, one module each: what each
//! holds, which equation of docs/design.md#adaptive it stores, how it is sized for a model.
//! The passes that read and write them are `impl Adaptive` blocks in the crate's other modules;
//! a part never names the workspace, so the parts sit below every pass (no module cycle).

pub(crate) mod caches;
pub(crate) mod coefficients;
pub(crate) mod composites;
pub(crate) mod forces;
pub(crate) mod fresh;
pub(crate) mod hierarchy;
pub(crate) mod hybrid_body;
pub(crate) mod impulse;
pub(crate) mod join_maps;
pub(crate) mod metric_coefficients;
pub(crate) mod pass_scratch;
pub(crate) mod passive;
pub(crate) mod rk_buffers;
pub(crate) mod selection_queue;
pub(crate) mod subtrees;
pub(crate) mod switches;
