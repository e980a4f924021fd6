//! # articula-adaptive
//!
//! Adaptive forward dynamics of articulated bodies (Redon et al. 2005; docs/design.md#adaptive) on
//! top of [`articula_dca`]: simulate only the joints that matter and say how wrong that is.
//!
//! - **Hybrid body**: the active joints form a subtree of the assembly tree that contains the
//!   root; every other subassembly is rigid (its joints are locked) and enters the main pass as
//!   one rigid body (composite inertia).
//! - **Acceleration metric** `A(C) = Σ q̈ᵢᵀ Aᵢ q̈ᵢ` (weights [`Adaptive::set_weight`], identity by
//!   default) is a quadratic function of C's handle forces, so a top-down max-priority queue
//!   chooses the joints to simulate before computing the others ([`Settings::budget`],
//!   [`Settings::tolerance`]). The metric mass left in the queue is the error of the selection
//!   against exact DCA ([`Selection::predicted_error`]).
//! - **Rigidification**: joints leaving the hybrid body are locked by internal impulses that
//!   keep the body's spatial momentum and never add kinetic energy; the hybrid body is
//!   re-selected every [`Settings::reselect_every`] steps.
//! - **Adaptive updates**: between re-selections a step touches the active region and its
//!   rigid frontier only (hierarchical state); a re-selection reads every rigid subassembly's
//!   articulated coefficients from caches kept in its own frame, with the velocity-dependent
//!   terms as tensors in its rigid velocity, so it too costs O(active region)
//!   (`docs/adaptive.md`).
//! - **Armature, damping and springs** as in the exact methods: armature in the active
//!   joints' inertia and the locking impulses' momenta, the passive forces in the steps with
//!   damping implicit over the step (`docs/adaptive.md#armature-and-damping`).
//! - **Many bodies of one model**: a [`Scratch`] holds the buffers a call writes and reads
//!   only within itself; [`Adaptive::step_with`] and its siblings share it between all the
//!   workspaces of that model (the same results to the bit, one cache-resident copy).
//!
//! ```
//! use articula_adaptive::{Adaptive, Settings};
//! use articula_dca::{forward_dynamics_slices, Data, Method, State};
//! use articula_model::{LoadOptions, Model};
//!
//! // A 30-link planar chain of 1 m, 1 kg rods.
//! let mut urdf = String::from(r#"<robot name="chain"><link name="l0"/>"#);
//! for i in 1..=30 {
//!     urdf += &format!(r#"<link name="l{i}"><inertial><origin xyz="0 0 -0.5"/><mass value="1"/>
//!         <inertia ixx="0.08" iyy="0.08" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
//!         <joint name="j{i}" type="continuous"><parent link="l{}"/><child link="l{i}"/>
//!         <origin xyz="0 0 {}"/><axis xyz="0 1 0"/></joint>"#, i - 1, if i == 1 { 0 } else { -1 });
//! }
//! let model = Model::from_urdf_str(&(urdf + "</robot>"), &LoadOptions::default()).unwrap();
//! let state = State::random(&model, 7, 1.0);
//! // Exact DCA for reference.
//! let mut data = Data::new(&model);
//! let exact = forward_dynamics_slices(&model, &mut data, &state.q, &state.qd, &state.tau, &state.f_ext, Method::Dca)
//!     .unwrap().to_vec();
//! // Ten joints, chosen by the acceleration metric.
//! let mut adaptive = Adaptive::new(&model, Settings { budget: Some(10), ..Settings::default() });
//! let qdd = adaptive.forward_dynamics(&model, &state.q, &state.qd, &state.tau, &state.f_ext).unwrap().to_vec();
//! let sel = adaptive.selection().clone();
//! assert_eq!(sel.active_dofs, 10);
//! // The predicted error is the metric of the difference to exact DCA.
//! let actual: f64 = qdd.iter().zip(&exact).map(|(a, e)| (a - e) * (a - e)).sum();
//! assert!((sel.predicted_error - actual).abs() <= 1e-8 * sel.total_metric);
//! ```

// Index loops over joint columns and handles mirror the equations (S columns p, q; handles h, k).
#![allow(clippy::needless_range_loop)]

mod adaptive;
mod cache;
mod contact;
mod dense;
mod error;
mod hierarchy;
mod hybrid;
mod metric;
mod parts;
mod passive;
mod report;
mod rigidify;
mod rk4;
mod scratch;
mod settings;
pub mod simulation;
mod trig;
mod update;

#[cfg(test)]
mod reference_tests;

pub use adaptive::Adaptive;
/// The thread count of [`Adaptive::set_threads`] (articula-dca's).
pub use articula_dca::Threads;
pub use contact::{HybridContact, HybridScratch};
pub use error::AdaptiveError;
pub use parts::selection_queue::{selection_order, Selection};
pub use parts::subtrees::PARALLEL_HYBRID_MIN_JOINTS;
pub use report::StepReport;
pub use scratch::Scratch;
pub use settings::{Reselection, Settings};

pub use adaptive::step;
pub(crate) use adaptive::{finite, integrate_part, non_finite};
