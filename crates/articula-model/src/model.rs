//! The articulated model: rigid bodies (URDF links merged across fixed joints), each moved by
//! one joint that may be composed of several single-axis URDF joints.

use crate::assembly::AssemblyTree;
use crate::body_inertia::{BodyInertia, InertiaDefect, InertiaDefectKind, Verdict};
use crate::urdf::{self, Geometry, JointKind, RawRobot};
use crate::{LoadOptions, LoadWarning, MasslessLeafPolicy, ModelError};
use articula_spatial::{SpatialInertia, SpatialMotion, SpatialTransform};
use glam::{DMat3, DVec3};
use std::path::Path;

fn is_finite(x: &SpatialTransform) -> bool {
    x.e.is_finite() && x.r.is_finite()
}

/// Name given to the 6-DOF joint of a floating base.
pub const FLOATING_BASE_JOINT: &str = "floating_base";

/// One URDF joint inside a body's (possibly composed) joint.
#[derive(Clone, Debug, PartialEq)]
pub struct JointPart {
    /// The URDF joint name (or [`FLOATING_BASE_JOINT`]).
    pub name: String,
    /// Its motion.
    pub kind: JointKind,
    /// Joint frame → preceding frame: the parent body's frame for the first part, the previous
    /// part's moving frame otherwise (the URDF joint origin, with any fixed joints folded in).
    pub origin: SpatialTransform,
    /// Unit axis in the joint frame (revolute, continuous, prismatic).
    pub axis: DVec3,
    /// Offset of this part's coordinates in the model's `q`.
    pub q_offset: usize,
    /// Offset of this part's velocity coordinates in the model's `qd`.
    pub v_offset: usize,
    /// `[lower, upper]` from the URDF's `<limit>` (revolute and prismatic joints with
    /// `lower < upper`; rad or m), enforced by the contact step (`docs/contact.md`).
    pub limits: Option<[f64; 2]>,
}

impl JointPart {
    /// Number of position coordinates (1; 4 for ball, 7 for floating).
    pub fn nq(&self) -> usize {
        self.kind.nq()
    }

    /// Number of velocity coordinates (1; 3 for ball, 6 for floating).
    pub fn nv(&self) -> usize {
        self.kind.nv()
    }

    /// `(i, ±1)` when this part is revolute (or continuous) about the coordinate axis `±e_i`
    /// of its joint frame — the usual URDF case, for which kinematics can rotate two columns
    /// instead of forming the general axis–angle rotation.
    pub fn coordinate_axis(&self) -> Option<(usize, f64)> {
        if !self.kind.is_hinge() {
            return None;
        }
        // One component ±1, the other two 0 (−0 included): straight-line tests, no search
        // (kinematics asks this of every composed-joint part at every call).
        let unit = |x: f64| x == 1.0 || x == -1.0;
        let DVec3 { x, y, z } = self.axis;
        if unit(x) && y == 0.0 && z == 0.0 {
            Some((0, x))
        } else if unit(y) && x == 0.0 && z == 0.0 {
            Some((1, y))
        } else if unit(z) && x == 0.0 && y == 0.0 {
            Some((2, z))
        } else {
            None
        }
    }

    /// The joint's own motion: the map from the moving frame (after the motion) to the joint
    /// frame, for this part's coordinates `q` (length [`JointPart::nq`]).
    ///
    /// Revolute/continuous: rotation by `q[0]` about the axis. Prismatic: translation by
    /// `q[0]` along the axis. Floating: `q = [x, y, z, qw, qx, qy, qz]`, the moving frame's
    /// position and orientation (unit quaternion) in the joint frame. Ball: `q = [qw, qx, qy,
    /// qz]`, the moving frame's orientation.
    pub fn motion_transform(&self, q: &[f64]) -> SpatialTransform {
        self.kind.motion_transform(self.axis, q)
    }

    /// Column `k` of the motion subspace in the moving frame ([`JointKind::subspace_column`]).
    /// Revolute: `[axis; 0]`; prismatic: `[0; axis]`; ball and floating: the unit vectors (their
    /// `qd` is the moving frame's angular velocity `ω`, or spatial velocity `[ω; v]`, relative
    /// to the joint frame, in moving-frame coordinates).
    pub fn subspace_column(&self, k: usize) -> SpatialMotion {
        self.kind.subspace_column(self.axis, k)
    }

    /// The neutral coordinates (zero angle; identity orientation for ball and floating).
    pub fn neutral_q(&self) -> &'static [f64] {
        self.kind.neutral_q()
    }

    /// `q ← q ⊕ h·qd` on this part's coordinates in the model's whole `q` and `qd`
    /// ([`JointKind::integrate`]).
    pub fn integrate(&self, q: &mut [f64], qd: &[f64], h: f64) {
        let (qo, vo) = (self.q_offset, self.v_offset);
        self.kind
            .integrate(&mut q[qo..qo + self.nq()], &qd[vo..vo + self.nv()], h);
    }
}

/// A rigid body of the model: one massive URDF link plus the links welded to it.
#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    /// The URDF link that gives the body its frame.
    pub name: String,
    /// Parent body, `None` for the ground (the world, or the welded root of a fixed base).
    pub parent: Option<usize>,
    /// Child bodies, in index order.
    pub children: Vec<usize>,
    /// The joint from the parent to this body: one part per URDF joint, parent side first.
    /// Several parts when massless links sat between moving joints (docs/design.md#composition).
    pub joint: Vec<JointPart>,
    /// Spatial inertia in the body frame, including every link merged into it.
    pub inertia: SpatialInertia,
    /// URDF links rigidly part of this body, with the map from each link's frame to the body
    /// frame. The body's own link comes first with the identity.
    pub links: Vec<(String, SpatialTransform)>,
    /// Collision primitives of the body's links (each link's `<visual>` ones where it has no
    /// readable `<collision>`), each with the map from its frame to the body frame. Geometry of
    /// the massless links inside a composed joint is not kept.
    pub geometry: Vec<Geometry>,
    /// Massless URDF links inside the composed joint (between its parts).
    pub massless_links: Vec<String>,
    /// Offset of the joint's coordinates in `q`.
    pub q_offset: usize,
    /// Number of position coordinates of the joint.
    pub nq: usize,
    /// Offset of the joint's velocity coordinates in `qd`.
    pub v_offset: usize,
    /// Degrees of freedom of the joint (columns of its motion subspace).
    pub nv: usize,
}

/// Where a URDF link is in a [`Model`] ([`Model::find_link`]): rigidly attached to a body,
/// or to the ground (the world frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkFrame {
    /// The body the link is part of; `None` for a link welded to the world (a fixed base's
    /// root link and the links welded to it).
    pub body: Option<usize>,
    /// The map from the link's frame to the body's frame (to the world frame when `body` is
    /// `None`). The identity for the body's own link.
    pub to_body: SpatialTransform,
}

/// An articulated model: immutable description, built once from a URDF.
///
/// Bodies are stored parents before children (depth-first pre-order from the root); the
/// coordinates `q` and `qd` are the bodies' joint coordinates concatenated in that order, each
/// body's parts in order parent side first. See `docs/conventions.md`.
#[derive(Clone, Debug)]
pub struct Model {
    /// The robot name.
    pub name: String,
    /// The bodies, parents before children.
    pub bodies: Vec<Body>,
    /// URDF links welded to the world (empty with a floating base), with the map from each
    /// link's frame to the world frame.
    pub ground_links: Vec<(String, SpatialTransform)>,
    /// Mass welded to the world (the fixed base's root and its fixed children; 0 with a
    /// floating base).
    pub ground_mass: f64,
    /// Whether the root link has a floating joint.
    pub floating_base: bool,
    /// Length of `q` (the locked joints' coordinates included).
    pub nq: usize,
    /// Length of `qd` (degrees of freedom, the locked joints' included).
    pub nv: usize,
    /// The binary assembly tree.
    pub assembly: AssemblyTree,
    /// Number of links in the URDF.
    pub urdf_links: usize,
    /// Number of joints in the URDF.
    pub urdf_joints: usize,
    /// Things worth knowing that did not stop loading: mimic joints, normalised axes, odd or
    /// changed inertias, locked joints (`docs/loading.md`).
    pub warnings: Vec<LoadWarning>,
    /// Moving joints locked because they carry no mass ([`MasslessLeafPolicy::Lock`]), in URDF
    /// depth-first order. Their coordinates come after every body's in `q` and `qd`; no
    /// algorithm moves them (`q̈ = 0`).
    pub locked: Vec<LockedJoint>,
    /// Armature, damping and springs per degree of freedom (empty vectors when the model has
    /// none; `docs/loading.md#armature-and-damping`).
    pub dynamics: crate::DofDynamics,
    /// The gravity the model's file states, m/s² in world coordinates: MJCF `<option
    /// gravity>` (zero under `<flag gravity="disable">`); `(0, 0, −9.81)` for a URDF, which
    /// has none. A new `Data` starts with it (`Data::gravity`, which a program may change).
    pub gravity: DVec3,
}

/// A moving URDF joint that carries no mass, locked at its neutral position.
#[derive(Clone, Debug, PartialEq)]
pub struct LockedJoint {
    /// The joint, with its offsets in `q` and `qd` (after every body's coordinates).
    pub joint: JointPart,
    /// The massless links it moves (its child and the links welded to it).
    pub links: Vec<String>,
    /// The body its links are welded to (at the joint's neutral position), `None` for the
    /// ground or when it hangs from a massless link inside a composed joint (its links are
    /// then not part of any body).
    pub body: Option<usize>,
}

impl Model {
    /// Loads a URDF file.
    pub fn from_urdf_file(
        path: impl AsRef<Path>,
        options: &LoadOptions,
    ) -> Result<Model, ModelError> {
        Self::build(urdf::read_file(path.as_ref())?, options)
    }

    /// Loads a URDF from text.
    pub fn from_urdf_str(text: &str, options: &LoadOptions) -> Result<Model, ModelError> {
        Self::build(urdf::read_str(text)?, options)
    }

    /// Loads an MJCF (MuJoCo XML) file, its `<include>`s resolved against its directory
    /// (docs/mjcf.md). The file decides the base: one free body alone under the world is a
    /// floating base ([`LoadOptions::floating_base`] is not used); the other options apply
    /// as for a URDF.
    pub fn from_mjcf_file(
        path: impl AsRef<Path>,
        options: &LoadOptions,
    ) -> Result<Model, ModelError> {
        Self::from_mjcf(crate::mjcf::read_file(path.as_ref())?, options)
    }

    /// Loads an MJCF model from text (an `<include>` is then an error: it needs a directory).
    pub fn from_mjcf_str(text: &str, options: &LoadOptions) -> Result<Model, ModelError> {
        Self::from_mjcf(crate::mjcf::read_str(text)?, options)
    }

    /// Loads a URDF or an MJCF file, by its content (an MJCF's root element is `<mujoco>`).
    pub fn from_file(path: impl AsRef<Path>, options: &LoadOptions) -> Result<Model, ModelError> {
        let path = path.as_ref();
        let head = urdf::read_limited(path, 1 << 16).or_else(|e| {
            if e.kind() == std::io::ErrorKind::FileTooLarge {
                // Long files: their first 64 KiB.
                use std::io::Read;
                let mut b = Vec::new();
                std::fs::File::open(path)
                    .and_then(|f| f.take(1 << 16).read_to_end(&mut b))
                    .map(|_| b)
            } else {
                Err(e)
            }
        });
        let head = head.map_err(|e| ModelError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        if crate::mjcf::is_mjcf(&String::from_utf8_lossy(&head)) {
            Self::from_mjcf_file(path, options)
        } else {
            Self::from_urdf_file(path, options)
        }
    }

    fn from_mjcf(
        robot: crate::mjcf::MjcfRobot,
        options: &LoadOptions,
    ) -> Result<Model, ModelError> {
        let options = options.with_floating_base(robot.floating_base);
        let free = robot.free_joint.clone();
        let mut model = Self::build(robot.raw, &options)?;
        model.gravity = robot.gravity;
        for b in &mut model.bodies {
            if let Some(name) = robot.renames.get(&b.name) {
                b.name = name.clone();
            }
        }
        if let (Some(free), true) = (free, model.floating_base) {
            model.bodies[0].joint[0].name = free.name.clone();
            let mut per_joint = model.dynamics_by_joint(&robot.joints_dynamics);
            if !free.dynamics.is_zero() {
                per_joint.push((0, 6, free.dynamics));
            }
            model.dynamics = crate::DofDynamics::from_joints(model.nv, &per_joint);
        }
        crate::mjcf::spring_damper::apply(&mut model, &robot.spring_dampers, &robot.qpos0)?;
        Ok(model)
    }

    /// Each moving part's `(v_offset, nv, dynamics)` for the joints named in `dynamics`.
    fn dynamics_by_joint(
        &self,
        dynamics: &std::collections::HashMap<String, crate::JointDynamics>,
    ) -> Vec<(usize, usize, crate::JointDynamics)> {
        self.coordinate_parts()
            .filter_map(|p| Some((p.v_offset, p.nv(), *dynamics.get(p.name.as_str())?)))
            .collect()
    }

    /// Builds a model from a robot already read by the `urdf-rs` crate (feature `urdf-rs`),
    /// with the same validation and policies as [`Model::from_urdf_str`]. `urdf-rs` has already
    /// converted URDF 1.1 quaternions to roll, pitch, yaw.
    #[cfg(feature = "urdf-rs")]
    pub fn from_urdf_robot(
        robot: &urdf_rs::Robot,
        options: &LoadOptions,
    ) -> Result<Model, ModelError> {
        Self::build(
            urdf::validate(crate::urdf_rs_interop::robot_data(robot)?)?,
            options,
        )
    }

    /// The URDF names of the locked joints ([`Model::locked`]).
    pub fn locked_joints(&self) -> Vec<&str> {
        self.locked.iter().map(|l| l.joint.name.as_str()).collect()
    }

    /// Every movable joint's coordinates in order: the bodies' parts ([`Model::joint_parts`])
    /// then the locked joints. What a state (`q`, `qd`, `τ`) is made of.
    pub fn coordinate_parts(&self) -> impl Iterator<Item = &JointPart> {
        self.joint_parts()
            .map(|(_, p)| p)
            .chain(self.locked.iter().map(|l| &l.joint))
    }

    /// Total mass of the moving bodies (kg). The welded root of a fixed base is not counted.
    pub fn moving_mass(&self) -> f64 {
        self.bodies.iter().map(|b| b.inertia.mass).sum()
    }

    /// Every movable URDF joint (plus [`FLOATING_BASE_JOINT`]) in coordinate order, with the
    /// body it moves and its part index.
    pub fn joint_parts(&self) -> impl Iterator<Item = (usize, &JointPart)> {
        self.bodies
            .iter()
            .enumerate()
            .flat_map(|(i, b)| b.joint.iter().map(move |p| (i, p)))
    }

    /// Finds a movable joint by its URDF name.
    pub fn find_joint(&self, name: &str) -> Option<(usize, &JointPart)> {
        self.joint_parts().find(|(_, p)| p.name == name)
    }

    /// Finds a URDF link by name: the body it belongs to (or the ground) and the map from the
    /// link's frame to that body's frame. Links welded to a body by fixed joints are found on
    /// that body (`Body::links`); with a fixed base, the root link and the links welded to it
    /// are on the ground (`Model::ground_links`, whose frame is the world). The massless links
    /// folded into a composed joint (`Body::massless_links`) have no frame of their own here and
    /// are not found.
    pub fn find_link(&self, name: &str) -> Option<LinkFrame> {
        let on = |links: &[(String, SpatialTransform)]| {
            links.iter().find(|(n, _)| n == name).map(|(_, x)| *x)
        };
        if let Some(to_body) = on(&self.ground_links) {
            return Some(LinkFrame {
                body: None,
                to_body,
            });
        }
        self.bodies.iter().enumerate().find_map(|(i, b)| {
            on(&b.links).map(|to_body| LinkFrame {
                body: Some(i),
                to_body,
            })
        })
    }

    /// The neutral configuration (all angles zero, identity orientations).
    pub fn neutral_q(&self) -> Vec<f64> {
        let mut q = Vec::with_capacity(self.nq);
        for p in self.coordinate_parts() {
            q.extend_from_slice(p.neutral_q());
        }
        q
    }

    /// The rest configuration: [`Model::neutral_q`] with every limited coordinate whose
    /// limits exclude its neutral value moved to the nearer bound (go1's knees, whose range
    /// `[−2.82, −0.89]` rad excludes the straight leg). A state that honours the joint limits
    /// from its start; the pose a scene's characters start in and their pose springs hold.
    pub fn rest_q(&self) -> Vec<f64> {
        let mut q = self.neutral_q();
        for p in self.coordinate_parts() {
            if let Some([lo, hi]) = p.limits {
                let x = &mut q[p.q_offset];
                *x = x.clamp(lo, hi);
            }
        }
        q
    }

    fn build(raw: RawRobot, options: &LoadOptions) -> Result<Model, ModelError> {
        let bounds = options.bounds()?;
        // 1. Fixed joints weld links into owners.
        let mut welded = Welded::new(&raw)?;
        // 2. The inertia of every body dynamics sees, checked and, by the policy, kept,
        //    changed or refused.
        let warnings = judge_inertias(&raw, options, bounds, &mut welded)?;
        // 3. Bodies, depth first from the root.
        let mut model = Model {
            name: raw.name.clone(),
            bodies: Vec::new(),
            ground_links: Vec::new(),
            ground_mass: 0.0,
            floating_base: options.floating_base,
            nq: 0,
            nv: 0,
            assembly: AssemblyTree::default(),
            urdf_links: raw.links.len(),
            urdf_joints: raw.joints.len(),
            warnings,
            locked: Vec::new(),
            dynamics: crate::DofDynamics::default(),
            gravity: DVec3::new(0.0, 0.0, -9.81),
        };
        add_bodies(&raw, options, &mut welded, &mut model)?;
        // 4. Locked coordinates, limits, joint dynamics, the assembly tree.
        finish_joints(&raw, &mut model);
        Ok(model)
    }
}

/// Stage 1 of [`Model::build`]: the URDF's links welded by fixed joints into owners (the
/// nearest link up the tree reached by a moving joint, or the root), with what each owner
/// carries.
struct Welded {
    /// The joints leaving each link (indices into the URDF's joints).
    children_joints: Vec<Vec<usize>>,
    /// Each link's owner.
    owner: Vec<usize>,
    /// The map from each link's frame to its owner's frame.
    to_owner: Vec<SpatialTransform>,
    /// The links breadth first from the root.
    order: Vec<usize>,
    /// Each owner's inertia, its welded links' summed in its frame.
    merged: Vec<SpatialInertia>,
    /// Each owner's links with their frames in the owner's.
    members: Vec<Vec<(String, SpatialTransform)>>,
    /// Each owner's collision geometry in its frame.
    geometry: Vec<Vec<Geometry>>,
    /// Moving joints leaving each owner, with origins re-expressed in the owner's frame.
    moving_out: Vec<Vec<(usize, SpatialTransform)>>,
    /// Whether each owner carries no mass (before stage 2 may repair it).
    massless: Vec<bool>,
    /// Whether anything in the subtree of each link (through any joint) has mass.
    massive_below: Vec<bool>,
}

impl Welded {
    fn new(raw: &RawRobot) -> Result<Welded, ModelError> {
        let n = raw.links.len();
        let mut children_joints: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (j, joint) in raw.joints.iter().enumerate() {
            children_joints[joint.parent].push(j);
        }
        let mut owner = vec![usize::MAX; n];
        let mut to_owner = vec![SpatialTransform::IDENTITY; n];
        let mut order = vec![raw.root];
        owner[raw.root] = raw.root;
        let mut at = 0;
        while at < order.len() {
            let l = order[at];
            at += 1;
            for &j in &children_joints[l] {
                let joint = &raw.joints[j];
                let c = joint.child;
                if joint.kind == JointKind::Fixed {
                    owner[c] = owner[l];
                    to_owner[c] = to_owner[l] * joint.origin;
                    // Finite origins can add up to infinity along a run of fixed joints.
                    if !is_finite(&to_owner[c]) {
                        return Err(ModelError::InvalidOrigin {
                            joint: joint.name.clone(),
                        });
                    }
                } else {
                    owner[c] = c;
                }
                order.push(c);
            }
        }
        let mut welded = Welded {
            children_joints,
            owner,
            to_owner,
            order,
            merged: vec![SpatialInertia::ZERO; n],
            members: vec![Vec::new(); n],
            geometry: vec![Vec::new(); n],
            moving_out: vec![Vec::new(); n],
            massless: Vec::new(),
            massive_below: vec![false; n],
        };
        welded.gather(raw)?;
        Ok(welded)
    }

    /// Sums each owner's inertia, links and geometry; lists the moving joints leaving it;
    /// marks the massless owners and the subtrees with mass.
    fn gather(&mut self, raw: &RawRobot) -> Result<(), ModelError> {
        let (owner, to_owner) = (&self.owner, &self.to_owner);
        for &l in &self.order {
            let o = owner[l];
            self.geometry[o].extend(raw.links[l].geometry.iter().map(|g| Geometry {
                origin: to_owner[l] * g.origin,
                ..*g
            }));
            self.merged[o] += to_owner[l].apply_inertia(&raw.links[l].inertia);
            if !self.merged[o].is_finite() {
                return Err(ModelError::NonFiniteInertia {
                    link: raw.links[l].name.clone(),
                });
            }
            self.members[o].push((raw.links[l].name.clone(), to_owner[l]));
        }
        for &l in &self.order {
            for &j in &self.children_joints[l] {
                let joint = &raw.joints[j];
                if joint.kind != JointKind::Fixed {
                    let origin = to_owner[l] * joint.origin;
                    if !is_finite(&origin) {
                        return Err(ModelError::InvalidOrigin {
                            joint: joint.name.clone(),
                        });
                    }
                    self.moving_out[owner[l]].push((j, origin));
                }
            }
        }
        self.massless = self
            .merged
            .iter()
            .map(|m| m.mass == 0.0 && m.ibar == DMat3::ZERO)
            .collect();
        for &l in self.order.iter().rev() {
            let mut below = raw.links[l].inertia != SpatialInertia::ZERO;
            for &j in &self.children_joints[l] {
                below |= self.massive_below[raw.joints[j].child];
            }
            self.massive_below[l] |= below;
        }
        Ok(())
    }
}

/// Stage 2 of [`Model::build`]: the inertia of every body dynamics sees (the owners with
/// mass, the ground excepted), checked and, by the policy, kept, changed or refused — all of
/// them before failing. Returns the load's warnings.
fn judge_inertias(
    raw: &RawRobot,
    options: &LoadOptions,
    bounds: (f64, f64),
    welded: &mut Welded,
) -> Result<Vec<LoadWarning>, ModelError> {
    let is_ground = |l: usize| l == raw.root && !options.floating_base;
    let Welded {
        owner,
        order,
        merged,
        members,
        massless,
        ..
    } = welded;
    let max_mass = order
        .iter()
        .filter(|&&l| owner[l] == l)
        .map(|&l| merged[l].mass)
        .fold(0.0, f64::max);
    let mut refused: Vec<InertiaDefect> = Vec::new();
    let mut warnings = raw.warnings.clone();
    for &l in order.iter() {
        if owner[l] != l || is_ground(l) || massless[l] {
            continue;
        }
        let com = merged[l].com();
        let size = members[l]
            .iter()
            .map(|(_, x)| (x.to_pose().1 - com).length())
            .fold(com.length(), f64::max);
        let body = BodyInertia {
            name: &raw.links[l].name,
            links: members[l].iter().map(|m| m.0.clone()).collect(),
            inertia: merged[l],
            size,
        };
        match body.judge(options.inertia, max_mass, bounds) {
            Verdict::Fine => {}
            Verdict::Odd(defects) => warnings.push(LoadWarning::OddInertia(defects)),
            Verdict::Changed(inertia, change) => {
                merged[l] = inertia;
                warnings.push(LoadWarning::InertiaChanged(change));
            }
            Verdict::Refused(defects) => refused.extend(defects),
        }
        // A point mass may pass (see `body_inertia::SINGULAR`), an overflowed one not.
        let (moments, _) = crate::body_inertia::principal_moments(merged[l].inertia_about_com());
        if refused.last().is_none_or(|d| d.body != raw.links[l].name)
            && !(merged[l].is_finite()
                && merged[l].mass > 0.0
                && moments.iter().all(|x| x.is_finite()))
        {
            refused.push(InertiaDefect {
                body: raw.links[l].name.clone(),
                links: members[l].iter().map(|m| m.0.clone()).collect(),
                mass: merged[l].mass,
                moments,
                kind: InertiaDefectKind::Singular,
                by: moments[0],
                tolerance: 0.0,
            });
        }
    }
    if !refused.is_empty() {
        return Err(ModelError::Inertia {
            policy: options.inertia,
            defects: refused,
        });
    }
    Ok(warnings)
}

/// A joint part at its URDF origin, offsets and limits not yet set.
fn part(name: &str, kind: JointKind, origin: SpatialTransform, axis: DVec3) -> JointPart {
    JointPart {
        name: name.to_string(),
        kind,
        origin,
        axis,
        q_offset: 0,
        v_offset: 0,
        limits: None,
    }
}

/// Locks the massless subtree moved by `first` (which moves `link`), its links welded at the
/// neutral position to `weld`: `Some((body or None for the ground, the map from the joint
/// frame to that frame))`, or `None` to weld them nowhere.
fn lock(
    model: &mut Model,
    raw: &RawRobot,
    children_joints: &[Vec<usize>],
    first: JointPart,
    link: usize,
    weld: Option<(Option<usize>, SpatialTransform)>,
) {
    let mut pending = vec![(first, link, weld.map(|(_, x)| x))];
    while let Some((joint, link, frame)) = pending.pop() {
        let mut links = Vec::new();
        let mut walk = vec![(link, frame)];
        let mut moving = Vec::new();
        while let Some((l, x)) = walk.pop() {
            links.push(raw.links[l].name.clone());
            if let (Some((target, _)), Some(x)) = (weld, x) {
                let list = match target {
                    Some(b) => &mut model.bodies[b].links,
                    None => &mut model.ground_links,
                };
                list.push((raw.links[l].name.clone(), x));
                let geometry = raw.links[l].geometry.iter().map(|g| Geometry {
                    origin: x * g.origin,
                    ..*g
                });
                if let Some(b) = target {
                    model.bodies[b].geometry.extend(geometry);
                }
            }
            for &j in children_joints[l].iter().rev() {
                let jt = &raw.joints[j];
                let xc = x.map(|x| x * jt.origin);
                if jt.kind == JointKind::Fixed {
                    walk.push((jt.child, xc));
                } else {
                    moving.push((part(&jt.name, jt.kind, jt.origin, jt.axis), jt.child, xc));
                }
            }
        }
        model.warnings.push(LoadWarning::LockedJoint {
            joint: joint.name.clone(),
            links: links.clone(),
        });
        model.locked.push(LockedJoint {
            joint,
            links,
            body: weld.and_then(|(b, _)| b),
        });
        pending.extend(moving.into_iter().rev());
    }
}

/// Stage 3 of [`Model::build`]: bodies, depth first from the root; runs through massless
/// links become one joint; joints carrying no mass at all are locked.
fn add_bodies(
    raw: &RawRobot,
    options: &LoadOptions,
    welded: &mut Welded,
    model: &mut Model,
) -> Result<(), ModelError> {
    let mut massless_leaves: Vec<(String, String)> = Vec::new();
    // A pending moving joint: (parent body, first part, link it moves).
    let mut stack: Vec<(Option<usize>, JointPart, usize)> = Vec::new();
    // Any joint may be locked but a floating base (a robot without mass).
    let lockable = |parent: Option<usize>| {
        options.massless_leaf == MasslessLeafPolicy::Lock
            && !(parent.is_none() && options.floating_base)
    };
    if options.floating_base {
        let name = if raw.joints.iter().any(|j| j.name == FLOATING_BASE_JOINT) {
            format!("{FLOATING_BASE_JOINT}#")
        } else {
            FLOATING_BASE_JOINT.to_string()
        };
        let base = part(
            &name,
            JointKind::Floating,
            SpatialTransform::IDENTITY,
            DVec3::ZERO,
        );
        stack.push((None, base, raw.root));
    } else {
        model.ground_links = welded.members[raw.root].clone();
        model.ground_mass = welded.merged[raw.root].mass;
        push_moving_out(&mut stack, raw, welded, raw.root, None);
    }
    while let Some((parent, first, link)) = stack.pop() {
        if !welded.massive_below[link] {
            if lockable(parent) {
                let origin = first.origin;
                let weld = Some((parent, origin));
                lock(model, raw, &welded.children_joints, first, link, weld);
            } else {
                massless_leaves.push((raw.links[link].name.clone(), first.name));
            }
            continue;
        }
        let (parts, link, massless_links) = through_massless(
            raw,
            options,
            welded,
            model,
            first,
            link,
            &mut massless_leaves,
        )?;
        let index = model.bodies.len();
        let (mut nq, mut nv) = (0, 0);
        let mut parts = parts;
        for p in &mut parts {
            p.q_offset = model.nq + nq;
            p.v_offset = model.nv + nv;
            nq += p.nq();
            nv += p.nv();
        }
        model.bodies.push(Body {
            name: raw.links[link].name.clone(),
            parent,
            children: Vec::new(),
            joint: parts,
            inertia: welded.merged[link],
            links: welded.members[link].clone(),
            geometry: std::mem::take(&mut welded.geometry[link]),
            massless_links,
            q_offset: model.nq,
            nq,
            v_offset: model.nv,
            nv,
        });
        model.nq += nq;
        model.nv += nv;
        if let Some(p) = parent {
            model.bodies[p].children.push(index);
        }
        push_moving_out(&mut stack, raw, welded, link, Some(index));
    }
    if !massless_leaves.is_empty() {
        return Err(ModelError::SingularMassless {
            leaves: massless_leaves,
        });
    }
    Ok(())
}

/// Pushes the moving joints leaving owner `link` (children of body `parent`) onto `stack`,
/// the first joint on top.
fn push_moving_out(
    stack: &mut Vec<(Option<usize>, JointPart, usize)>,
    raw: &RawRobot,
    welded: &Welded,
    link: usize,
    parent: Option<usize>,
) {
    for &(j, origin) in welded.moving_out[link].iter().rev() {
        let joint = &raw.joints[j];
        stack.push((
            parent,
            part(&joint.name, joint.kind, origin, joint.axis),
            joint.child,
        ));
    }
}

/// Follows the run of massless owners from `link` (moved by `first`) to the owner with mass
/// that ends it: the run's joint parts, that owner, and the massless links passed. Massless
/// side branches are locked or listed in `massless_leaves`; a branch with mass on two sides
/// is refused.
fn through_massless(
    raw: &RawRobot,
    options: &LoadOptions,
    welded: &Welded,
    model: &mut Model,
    first: JointPart,
    mut link: usize,
    massless_leaves: &mut Vec<(String, String)>,
) -> Result<(Vec<JointPart>, usize, Vec<String>), ModelError> {
    let mut parts = vec![first];
    let mut massless_links = Vec::new();
    while welded.massless[link] {
        // Something beyond has mass: through one moving joint, or several (a branch).
        let (out, empty): (Vec<_>, Vec<_>) = welded.moving_out[link]
            .iter()
            .partition(|&&(j, _)| welded.massive_below[raw.joints[j].child]);
        for &(j, origin) in &empty {
            let joint = &raw.joints[j];
            let p = part(&joint.name, joint.kind, origin, joint.axis);
            if options.massless_leaf == MasslessLeafPolicy::Lock {
                lock(model, raw, &welded.children_joints, p, joint.child, None);
            } else {
                massless_leaves.push((raw.links[joint.child].name.clone(), p.name));
            }
        }
        if out.len() != 1 {
            return Err(ModelError::MasslessBranch {
                link: raw.links[link].name.clone(),
                joints: out
                    .iter()
                    .map(|&(j, _)| raw.joints[j].name.clone())
                    .collect(),
            });
        }
        let (j, origin) = out[0];
        let joint = &raw.joints[j];
        massless_links.extend(welded.members[link].iter().map(|m| m.0.clone()));
        parts.push(part(&joint.name, joint.kind, origin, joint.axis));
        link = joint.child;
    }
    Ok((parts, link, massless_links))
}

/// Stage 4 of [`Model::build`]: the locked joints' coordinates after every body's, URDF
/// joint limits, armature, damping and springs (by joint name), the assembly tree.
fn finish_joints(raw: &RawRobot, model: &mut Model) {
    for l in &mut model.locked {
        l.joint.q_offset = model.nq;
        l.joint.v_offset = model.nv;
        model.nq += l.joint.nq();
        model.nv += l.joint.nv();
    }
    // Joint names are unique.
    let limits: std::collections::HashMap<&str, [f64; 2]> = raw
        .joints
        .iter()
        .filter_map(|j| Some((j.name.as_str(), j.limits?)))
        .collect();
    let parts = model.bodies.iter_mut().flat_map(|b| b.joint.iter_mut());
    for p in parts.chain(model.locked.iter_mut().map(|l| &mut l.joint)) {
        p.limits = limits.get(p.name.as_str()).copied();
    }
    let dynamics = raw
        .joints
        .iter()
        .filter(|j| !j.dynamics.is_zero())
        .map(|j| (j.name.clone(), j.dynamics))
        .collect();
    let per_joint = model.dynamics_by_joint(&dynamics);
    model.dynamics = crate::DofDynamics::from_joints(model.nv, &per_joint);
    model.assembly = AssemblyTree::build(model);
}

#[cfg(test)]
mod tests {
    use super::{JointKind, JointPart};
    use articula_spatial::SpatialTransform;
    use glam::DVec3;

    /// `coordinate_axis` against its definition: `Some((i, s))` exactly when the part is
    /// revolute or continuous and its axis equals `s · e_i` (s = ±1), over every combination of
    /// components from a set with ±1, ±0, non-unit values and NaN.
    #[test]
    fn coordinate_axis_is_a_signed_unit_axis() {
        let vals = [1.0, -1.0, 0.0, -0.0, 0.5, 1.0 + f64::EPSILON, f64::NAN];
        let mut found = 0;
        for kind in [
            JointKind::Revolute,
            JointKind::Continuous,
            JointKind::Prismatic,
        ] {
            for &x in &vals {
                for &y in &vals {
                    for &z in &vals {
                        let part = JointPart {
                            name: "j".into(),
                            kind,
                            origin: SpatialTransform::IDENTITY,
                            axis: DVec3::new(x, y, z),
                            q_offset: 0,
                            v_offset: 0,
                            limits: None,
                        };
                        let rotates = matches!(kind, JointKind::Revolute | JointKind::Continuous);
                        let expected =
                            (0..3).flat_map(|i| [(i, 1.0), (i, -1.0)]).find(|&(i, s)| {
                                let mut e = DVec3::ZERO;
                                e[i] = s;
                                rotates && part.axis == e
                            });
                        assert_eq!(part.coordinate_axis(), expected, "{kind:?} {:?}", part.axis);
                        found += expected.is_some() as usize;
                    }
                }
            }
        }
        // ±e_i with either zero sign in the other two components: 6 axes × 4, for two kinds.
        assert_eq!(found, 2 * 6 * 4);
    }
}
