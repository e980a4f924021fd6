//! The joints' passive dynamics in adaptive stepping (docs/loading.md#armature-and-damping):
//! the time step whose implicit damping the workspace's armature holds, and the joint forces
//! `τ + passive(q, q̇)` of a step's solves.

/// What a step adds to the rigid-body dynamics: damping `b` integrated implicitly over the
/// step `h` by adding `h b` to the armature (`Adaptive::data.armature`, which holds the
/// model's armature plus `dt b`), and the passive forces `−b q̇ − k (q − q_spring)` added to
/// `τ` (articula-dca's `with_passive_forces`, MuJoCo's implicit damping).
#[derive(Clone, Debug, Default)]
pub(crate) struct PassiveForces {
    /// The `h` of the `h b` in the workspace's armature (0: the model's own armature).
    pub(crate) dt: f64,
    /// `τ + passive(q, q̇)`: every joint's for a whole-body solve, the active joints' for a
    /// hybrid step (empty until a step of a model with damping or springs).
    pub(crate) tau: Vec<f64>,
    /// `τ + passive(q, 0)` of every joint (the springs alone), while `locked_set`: the torques
    /// of the joints a re-selection locks, once locked (`q̇ = 0`), which the caches of the
    /// rigid subassemblies it builds hold (a locked joint's damping force is zero).
    pub(crate) locked: Vec<f64>,
    /// Whether `locked` holds the torques of the state of the current re-selection.
    pub(crate) locked_set: bool,
}
