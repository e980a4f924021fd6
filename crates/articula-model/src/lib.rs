//! # articula-model
//!
//! URDF → articulated model → binary assembly tree.
//!
//! - Loading ([`Model::from_urdf_file`], [`Model::from_urdf_str`]) validates everything dynamics
//!   needs and fails with one typed [`ModelError`] that names the offending link or joint (every
//!   one of them, for inertias and massless joints) — never a panic. Inputs are capped
//!   ([`MAX_URDF_BYTES`], [`MAX_XML_DEPTH`] levels of nesting).
//! - Inertias are checked on the bodies after fixed-joint merging (what dynamics sees), with
//!   tolerances in each body's own scale, under an [`InertiaPolicy`] of [`LoadOptions`]:
//!   `Accept` (the default: load as written, one [`LoadWarning`] per odd body), `Strict`
//!   (refuse, every offender listed with its numbers) or `Repair` (MuJoCo-like fixes, each
//!   reported before/after). On the command line: `--inertia accept|strict|repair`.
//! - Moving joints that carry no mass (romeo's fingers) are locked by default
//!   ([`MasslessLeafPolicy`], [`Model::locked_joints`]): their `q̈` is 0, never a NaN.
//! - With the feature `urdf-rs`, `Model::from_urdf_robot` builds the same model from a robot
//!   read by the `urdf-rs` crate.
//! - See `docs/loading.md` for what is validated, the tolerances and the limits. Visual and collision geometry, materials, `<gazebo>` and `<transmission>`
//!   tags are ignored by the strict pass, so sloppy geometry never stops a load. Collision (else
//!   visual) primitives are read leniently on the side into [`Body::geometry`]; malformed ones
//!   are dropped.
//! - Links welded by `fixed` joints are merged into one [`Body`] (spatial inertias summed).
//! - Runs of moving joints joined by massless links (a 3-DOF hip made of three revolute joints)
//!   become one multi-DOF joint: a [`Body`] whose `joint` has several [`JointPart`]s.
//! - The [`AssemblyTree`] joins bodies pairwise at balanced cuts, nodes in post-order.
//!
//! ```
//! use articula_model::{LoadOptions, Model};
//! let urdf = r#"<robot name="pendulum">
//!   <link name="base"/>
//!   <link name="bob">
//!     <inertial><origin xyz="0 0 -1"/><mass value="1"/>
//!       <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
//!   </link>
//!   <joint name="swing" type="continuous">
//!     <parent link="base"/><child link="bob"/><axis xyz="0 1 0"/>
//!   </joint>
//! </robot>"#;
//! let model = Model::from_urdf_str(urdf, &LoadOptions::default()).unwrap();
//! assert_eq!(model.nv, 1);
//! assert_eq!(model.bodies[0].joint[0].name, "swing");
//! // Ground and bob, joined at "swing".
//! assert_eq!(model.assembly.nodes.len(), 3);
//! ```

mod assembly;
mod atomic_file;
pub mod body_inertia;
mod collision;
mod dynamics;
mod error;
mod joint;
mod mjcf;
pub use mjcf::is_mjcf;
mod model;
mod options;
mod urdf;
#[cfg(feature = "urdf-rs")]
mod urdf_rs_interop;
mod visual;
mod warning;

pub use assembly::{AssemblyNode, AssemblyTree, HandleLayout, NodeKind, GATHER_ABOVE};
pub use atomic_file::AtomicFile;
pub use body_inertia::{InertiaChange, InertiaDefect, InertiaDefectKind};
pub use collision::{
    inertia_box, shape_points, shape_spheres, CollisionModel, ContactSphere, Rim, RIM_POINTS,
};
pub use dynamics::{DofDynamics, JointDynamics};
pub use error::ModelError;
pub use joint::{integrate_floating, JointKind, JOINT_KINDS};
pub use model::{Body, JointPart, LinkFrame, LockedJoint, Model, FLOATING_BASE_JOINT};
pub use options::{InertiaPolicy, LoadOptions, MasslessLeafPolicy};
pub use urdf::{
    read_limited, rpy_to_matrix, Geometry, GeometryRole, Shape, MAX_INERTIA, MAX_LENGTH, MAX_MASS,
    MAX_URDF_BYTES, MAX_XML_ATTRIBUTES, MAX_XML_DEPTH,
};
#[cfg(feature = "urdf-rs")]
pub use urdf_rs;
pub use visual::{Visual, VisualShape, Visuals};
pub use warning::LoadWarning;

impl Body {
    /// The joint's name: its URDF joint name, or the names of its parts joined by `+` when
    /// it is composed of several.
    pub fn joint_name(&self) -> String {
        let names: Vec<&str> = self.joint.iter().map(|p| p.name.as_str()).collect();
        names.join("+")
    }

    /// How far a composed joint of three rotations (an Euler-angle joint, such as a hip
    /// `z + x + y`) is from gimbal lock at the coordinates `q` (the model's whole `q`):
    /// `|det[a₁ a₂ a₃]|`, the volume spanned by its three unit axes expressed in one frame.
    /// For orthogonal axes it is `|cos q₂|`, the cosine of the middle angle: 1 in the neutral
    /// pose, 0 when the first and third axes align and the three coordinates move the body
    /// about two axes only (there the joint-space inertia is singular and the coordinates'
    /// velocities grow like `1 / cos q₂` for a bounded angular velocity). `None` for any other
    /// joint or a `q` too short.
    pub fn euler_axes_volume(&self, q: &[f64]) -> Option<f64> {
        let rotational = |p: &JointPart| p.kind.is_hinge();
        if self.joint.len() != 3 || !self.joint.iter().all(rotational) {
            return None;
        }
        // Rotation part of a frame map: v ↦ E v.
        let rot = |t: &articula_spatial::SpatialTransform, v: articula_spatial::DVec3| {
            t.apply_point(v) - t.apply_point(articula_spatial::DVec3::ZERO)
        };
        let mut axes = [articula_spatial::DVec3::ZERO; 3];
        for (k, part) in self.joint.iter().enumerate() {
            // Part k's axis (the same in its joint and moving frames), carried back to the first
            // part's joint frame through the earlier parts' origins and motions.
            let mut v = part.axis;
            for j in (0..k).rev() {
                v = rot(&self.joint[j + 1].origin, v);
                let p = &self.joint[j];
                v = rot(&p.motion_transform(q.get(p.q_offset..p.q_offset + 1)?), v);
            }
            axes[k] = v;
        }
        Some(axes[0].dot(axes[1].cross(axes[2])).abs())
    }
}
