//! # articula
//!
//! Forward dynamics of articulated bodies — robots, characters, ropes, plants — in one crate:
//! URDF loading, Featherstone's divide-and-conquer algorithm (DCA) with ABA and CRBA as
//! references, adaptive dynamics (Redon–Galoppo–Lin: simulate only the joints that matter
//! under a budget, with the error reported) and view-dependent scenes of many bodies under one
//! joint budget.
//!
//! The layers, each a module re-exporting one crate (each depends only on those above it):
//!
//! | module | crate | what |
//! | --- | --- | --- |
//! | [`spatial`] | `articula-spatial` | 6D spatial algebra (motion, force, inertia, Plücker transforms) on glam `f64` types |
//! | [`model`] | `articula-model` | URDF → validated articulated [`Model`](model::Model) → binary assembly tree |
//! | [`dca`] | `articula-dca` | exact forward dynamics ([`Method`](dca::Method) DCA, ABA, CRBA), [`State`](dca::State), [`Data`](dca::Data) workspace, integrators |
//! | [`adaptive`] | `articula-adaptive` | adaptive dynamics: [`Adaptive`](adaptive::Adaptive) workspace, budget / tolerance [`Settings`](adaptive::Settings) |
//! | [`view`] | `articula-view` | camera, visibility weights, scenes ([`SceneBuilder`](view::SceneBuilder), [`SceneSim`](view::SceneSim)), PNG frames |
//!
//! [`glam`] is re-exported too: positions, rotations and velocities are its `f64` types
//! (`DVec3`, `DMat3`, `DQuat`). `use articula::prelude::*;` brings the names a program needs.
//!
//! ```
//! use articula::prelude::*;
//!
//! // A pendulum: a 1 kg bob 1 m below a hinge about y.
//! let urdf = r#"<robot name="pendulum"><link name="base"/>
//!   <link name="bob"><inertial><origin xyz="0 0 -1"/><mass value="1"/>
//!     <inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>
//!   <joint name="swing" type="continuous"><parent link="base"/><child link="bob"/>
//!     <axis xyz="0 1 0"/></joint></robot>"#;
//! let model = Model::from_urdf_str(urdf, &LoadOptions::default())?;
//! let mut data = Data::new(&model);
//! let mut state = State::neutral(&model);
//! state.q[0] = 0.5;
//!
//! // Exact forward dynamics: m l² q̈ = −m g l sin q (plus the bob's own inertia).
//! let qdd = forward_dynamics(&model, &mut data, &state, Method::Dca)?;
//! let expected = -9.81 * 0.5f64.sin() / (1.0 + 1e-4);
//! assert!((qdd[0] - expected).abs() < 1e-10);
//!
//! // One millisecond of motion with RK4, then the bob's world position (glam types) from the
//! // kinematics of the new state.
//! step(&model, &mut data, &mut state, Method::Dca, Integrator::Rk4, 1e-3)?;
//! let exact = forward_dynamics(&model, &mut data, &state, Method::Dca)?[0];
//! let (rotation, origin): (DMat3, DVec3) = data.body_pose(0);
//! let bob = rotation * DVec3::new(0.0, 0.0, -1.0) + origin;
//! let q = state.q[0];
//! assert!((bob - DVec3::new(-q.sin(), 0.0, -q.cos())).length() < 1e-12);
//!
//! // Adaptive dynamics with no joint to spare: the pendulum stays rigid, and the predicted
//! // error is what the skipped joint would have contributed, q̈² with unit weights.
//! let mut adaptive = Adaptive::new(&model, Settings { budget: Some(0), ..Settings::default() });
//! adaptive.forward_dynamics(&model, &state.q, &state.qd, &state.tau, &state.f_ext)?;
//! let predicted = adaptive.selection().predicted_error;
//! assert!((predicted - exact * exact).abs() < 1e-9 * exact * exact);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Features (all on by default): `serde` (scene files as JSON, serde for the scene specs, the
//! joint kinds and glam's types), `render` (PNG frames of scenes, through tiny-skia) and `gltf`
//! (animated glTF export with the models' meshes, `articula::gltf`; docs/gltf.md).
//! Examples: `cargo run --release --example rope` (a 1,000-link rope under adaptive dynamics),
//! `cargo run --release --example drop` (the humanoid dropped onto a floor by the simulation
//! driver, with its energy guard) and `cargo run --release --example crowd` (a crowd built in
//! code, frames written to a folder).

pub use articula_adaptive as adaptive;
pub use articula_dca as dca;
#[cfg(feature = "gltf")]
pub use articula_gltf as gltf;
pub use articula_model as model;
pub use articula_spatial as spatial;
pub use articula_view as view;
pub use glam;

pub mod prelude {
    //! The names a program needs: `use articula::prelude::*;`.
    //!
    //! Models ([`Model`], [`LoadOptions`]), exact dynamics ([`forward_dynamics`], [`step`],
    //! [`Data`], [`State`], [`Method`], [`Integrator`]), the quantities around it
    //! ([`inverse_dynamics`], [`mass_matrix`], [`bias_forces`], [`forward_kinematics`] for
    //! poses, Jacobians in a [`ReferenceFrame`], centre of mass, energies and momentum as
    //! [`Data`] methods), adaptive dynamics ([`Adaptive`], [`Settings`]; its stepping call,
    //! `articula::adaptive::step`, takes `articula_dca::step`'s arguments less the method),
    //! ground contact ([`Ground`], [`ContactSettings`], [`ContactData`], [`step_with_contact`]),
    //! the simulation driver ([`Simulation`] with its [`SimulationOptions`], [`GroundOptions`],
    //! [`Recorder`]s such as [`CsvRecorder`], and the [`StopReason`] of a run),
    //! scenes ([`SceneBuilder`] and its specs, files through [`SceneOptions`], [`SceneSim`]),
    //! the spatial types, glam's `DVec3`, `DMat3`, `DQuat`, and every layer's error type.

    pub use crate::adaptive::simulation::{
        CsvRecorder, Dynamics, GimbalWarning, GroundOptions, Recorder, RunControl, Simulation,
        SimulationError, SimulationOptions, Stop, StopReason,
    };
    pub use crate::adaptive::{Adaptive, AdaptiveError, Selection, Settings, StepReport};
    pub use crate::dca::{
        bias_forces, forward_dynamics, forward_kinematics, inverse_dynamics, mass_matrix, step,
        step_with_contact, ContactData, ContactError, ContactSettings, Data, DynamicsError, Ground,
        Integrator, Method, ReferenceFrame, State,
    };
    pub use crate::model::{JointKind, LoadOptions, Model, ModelError};
    pub use crate::spatial::{SpatialForce, SpatialInertia, SpatialMotion, SpatialTransform};
    pub use crate::view::{
        BodySpec, Camera, CameraSpec, CrowdSpec, KeySpec, LoadedScene, PushSpec, SceneBuilder,
        SceneOptions, SceneSim, SceneStep, ViewError,
    };
    pub use glam::{DMat3, DQuat, DVec3};
}
