//! MJCF (MuJoCo's XML) → the links and joints the model builder composes (docs/mjcf.md).
//!
//! Every MJCF body becomes a link; a body with several joints becomes a run of massless links
//! joined by one-axis joints, which the builder composes into one multi-DOF joint (as it does
//! URDF runs through massless links). MuJoCo moves a body by each joint in turn about the
//! joint's anchor `p` (body coordinates): `X = X_parent · X_body · Π T(p) M(q − ref) T(−p)`,
//! so each part's origin carries `T(−p_prev) T(p) M(−ref)` and the body's own frame hangs off
//! the last part by a weld `T(−p_last)`.

mod geom;
mod mesh;
mod mesh_file;
pub(crate) mod spring_damper;
mod xml;

use crate::urdf::{Geometry, JointKind, RawJoint, RawLink, RawRobot};
use crate::{JointDynamics, LoadWarning, ModelError};
use articula_spatial::{SpatialInertia, SpatialTransform};
use geom::{frame, Geom, GeomMass};
use glam::{DMat3, DVec3};
use mesh::Meshes;
use std::collections::{BTreeMap, HashMap, HashSet};
use xml::{Attrs, Compiler, Defaults, Doc, El, MAIN};

/// A read MJCF model: the robot, whether its one top-level body is free (a floating base),
/// and the names of the links standing in for MJCF bodies whose frame is offset from their
/// last joint's (link name → body name).
pub(crate) struct MjcfRobot {
    pub raw: RawRobot,
    pub floating_base: bool,
    pub renames: HashMap<String, String>,
    /// The floating base's MJCF free joint (its name and dynamics).
    pub free_joint: Option<RawJoint>,
    /// Every joint's dynamics, by name.
    pub joints_dynamics: HashMap<String, JointDynamics>,
    /// Joints whose stiffness and damping come from `springdamper` (name, `[timeconst,
    /// dampratio]`), set by [`spring_damper::apply`] once the model is built.
    pub spring_dampers: Vec<(String, [f64; 2])>,
    /// MuJoCo's `qpos0` where it is not neutral (the `ref` of hinge and slide joints).
    pub qpos0: HashMap<String, f64>,
    /// `<option gravity>` (MuJoCo's default `0 0 -9.81`), zero under `<flag gravity="disable">`.
    pub gravity: DVec3,
}

pub(crate) fn read_file(path: &std::path::Path) -> Result<MjcfRobot, ModelError> {
    read(Doc::read_file(path)?)
}

pub(crate) fn read_str(text: &str) -> Result<MjcfRobot, ModelError> {
    read(Doc::read_str(text)?)
}

/// Whether text looks like MJCF (its root element is `<mujoco>`): how `Model::from_file` tells
/// MJCF from URDF.
pub fn is_mjcf(text: &str) -> bool {
    let mut rest = text.trim_start_matches('\u{feff}');
    loop {
        rest = rest.trim_start();
        if let Some(r) = rest.strip_prefix("<?") {
            rest = r.split_once("?>").map_or("", |x| x.1);
        } else if let Some(r) = rest.strip_prefix("<!--") {
            rest = r.split_once("-->").map_or("", |x| x.1);
        } else if let Some(r) = rest.strip_prefix("<!") {
            rest = r.split_once('>').map_or("", |x| x.1);
        } else {
            return rest.starts_with("<mujoco")
                && rest[7..].starts_with(|c: char| c.is_whitespace() || c == '>' || c == '/');
        }
    }
}

struct Builder<'a> {
    doc: &'a Doc,
    defaults: Defaults,
    compiler: Compiler,
    /// The `<mesh>` assets, read when a geom's inertia needs one.
    meshes: Meshes,
    links: Vec<RawLink>,
    joints: Vec<RawJoint>,
    link_names: HashSet<String>,
    joint_names: HashSet<String>,
    /// Free bodies: (body link, its free joint's index).
    free: Vec<(usize, usize)>,
    renames: HashMap<String, String>,
    /// What the dynamics does not model, by kind.
    ignored: BTreeMap<String, Vec<String>>,
    warnings: Vec<LoadWarning>,
    /// Bodies read so far.
    bodies: usize,
    spring_dampers: Vec<(String, [f64; 2])>,
    qpos0: HashMap<String, f64>,
}

/// The gravity `<option>` states (the last one read wins, as in MuJoCo), zero when a
/// `<flag gravity="disable">` switches it off.
fn gravity(doc: &Doc) -> Result<DVec3, ModelError> {
    let mut g = DVec3::new(0.0, 0.0, -9.81);
    let mut enabled = true;
    for option in doc.root.each("option") {
        if let Some([x, y, z]) = Attrs::plain(doc, option).array::<3>("gravity")? {
            g = DVec3::new(x, y, z);
        }
        for flag in option.each("flag") {
            let a = Attrs::plain(doc, flag);
            match a.get("gravity") {
                None => {}
                Some("enable") => enabled = true,
                Some("disable") => enabled = false,
                Some(x) => {
                    return Err(a.err(
                        "gravity",
                        format!("expected enable or disable, found '{x}'"),
                    ))
                }
            }
        }
    }
    Ok(if enabled { g } else { DVec3::ZERO })
}

fn read(doc: Doc) -> Result<MjcfRobot, ModelError> {
    let compiler = Compiler::read(&doc)?;
    let gravity = gravity(&doc)?;
    let mut b = Builder {
        defaults: Defaults::read(&doc)?,
        meshes: Meshes::read(&doc, &compiler)?,
        compiler,
        doc: &doc,
        links: Vec::new(),
        joints: Vec::new(),
        link_names: HashSet::new(),
        joint_names: HashSet::new(),
        free: Vec::new(),
        renames: HashMap::new(),
        ignored: BTreeMap::new(),
        warnings: Vec::new(),
        bodies: 0,
        spring_dampers: Vec::new(),
        qpos0: HashMap::new(),
    };
    let name = doc.root.attr("model").unwrap_or("mujoco").to_string();
    b.add_link("world", SpatialInertia::ZERO, Vec::new(), &doc.root)?;
    for wb in doc.root.each("worldbody") {
        b.children(wb, 0, SpatialTransform::IDENTITY, MAIN)?;
    }
    b.not_modelled();
    b.scale_total_mass()?;
    let Builder {
        mut links,
        mut joints,
        free,
        renames,
        warnings,
        spring_dampers,
        qpos0,
        ..
    } = b;
    // One free body hanging alone from the world is the floating base; the world is dropped.
    let top: Vec<usize> = joints
        .iter()
        .enumerate()
        .filter(|(_, j)| j.parent == 0)
        .map(|(i, _)| i)
        .collect();
    let floating_base = free.len() == 1 && top.len() == 1 && top[0] == free[0].1;
    let joints_dynamics = joints
        .iter()
        .filter(|j| !j.dynamics.is_zero())
        .map(|j| (j.name.clone(), j.dynamics))
        .collect();
    let mut free_joint = None;
    if floating_base {
        free_joint = Some(joints.remove(free[0].1));
        links.remove(0);
        for j in &mut joints {
            j.parent -= 1;
            j.child -= 1;
        }
    }
    let root = 0;
    Ok(MjcfRobot {
        raw: RawRobot {
            name,
            links,
            joints,
            root,
            warnings,
        },
        floating_base,
        renames,
        free_joint,
        joints_dynamics,
        spring_dampers,
        qpos0,
        gravity,
    })
}

impl Builder<'_> {
    fn add_link(
        &mut self,
        name: &str,
        inertia: SpatialInertia,
        geometry: Vec<Geometry>,
        el: &El,
    ) -> Result<usize, ModelError> {
        if !self.link_names.insert(name.to_string()) {
            return Err(self
                .doc
                .err(el, Some("name"), format!("repeated body name '{name}'")));
        }
        self.links.push(RawLink {
            name: name.to_string(),
            inertia,
            geometry,
        });
        Ok(self.links.len() - 1)
    }

    fn add_joint(&mut self, el: &El, joint: RawJoint) -> Result<usize, ModelError> {
        if !self.joint_names.insert(joint.name.clone()) {
            return Err(self.doc.err(
                el,
                Some("name"),
                format!("repeated joint name '{}'", joint.name),
            ));
        }
        self.joints.push(joint);
        Ok(self.joints.len() - 1)
    }

    fn ignore(&mut self, what: &str, el: &El) {
        ignore(&mut self.ignored, what, el);
    }

    /// The bodies, frames and ignored elements inside `el` (a body, a frame or the world).
    fn children(
        &mut self,
        el: &El,
        link: usize,
        frame_to_link: SpatialTransform,
        childclass: &str,
    ) -> Result<(), ModelError> {
        for c in &el.children {
            match c.tag.as_str() {
                "body" => self.body(c, link, frame_to_link, childclass)?,
                "frame" => {
                    let a = Attrs::plain(self.doc, c);
                    let x = frame_to_link * frame(&a, &self.compiler)?;
                    let class = c.attr("childclass").unwrap_or(childclass);
                    self.children(c, link, x, class)?;
                }
                "site" => self.ignore("MJCF <site>", c),
                "joint" | "freejoint" | "inertial" if link == 0 => {
                    return Err(self.doc.err(
                        c,
                        None,
                        "the world body cannot have joints or an inertial",
                    ));
                }
                "joint" | "freejoint" | "inertial" | "geom" | "camera" | "light" => {}
                "composite" | "flexcomp" | "replicate" | "attach" | "skin" => {
                    return Err(self.doc.err(
                        c,
                        None,
                        format!("<{}> (a MuJoCo model macro) is not read: compile the model with MuJoCo and save it", c.tag),
                    ))
                }
                _ => {}
            }
        }
        Ok(())
    }

    fn body(
        &mut self,
        el: &El,
        parent: usize,
        frame_to_parent: SpatialTransform,
        childclass: &str,
    ) -> Result<(), ModelError> {
        let doc = self.doc;
        let a = Attrs::plain(doc, el);
        let class = el.attr("childclass").unwrap_or(childclass);
        let x_body = frame_to_parent * frame(&a, &self.compiler)?;
        // MuJoCo's body id (document order, the world 0) names an unnamed body.
        self.bodies += 1;
        let name = match el.attr("name") {
            Some(n) => n.to_string(),
            None => format!("body{}", self.bodies),
        };
        if a.number("gravcomp", 0.0)? != 0.0 {
            self.ignore("MJCF body gravity compensation (gravcomp)", el);
        }
        let (inertia, geometry) = self.body_inertia(el, class)?;
        let joint_els: Vec<&El> = el
            .children
            .iter()
            .filter(|c| c.tag == "joint" || c.tag == "freejoint")
            .collect();
        let body_link = if joint_els.is_empty() {
            let l = self.add_link(&name, inertia, geometry, el)?;
            self.add_joint(
                el,
                RawJoint {
                    name: format!("{name}#weld"),
                    kind: JointKind::Fixed,
                    origin: x_body,
                    axis: DVec3::Z,
                    limits: None,
                    parent,
                    child: l,
                    dynamics: JointDynamics::default(),
                },
            )?;
            l
        } else {
            self.jointed_body(
                el,
                &name,
                &joint_els,
                parent,
                x_body,
                class,
                (inertia, geometry),
            )?
        };
        self.children(el, body_link, SpatialTransform::IDENTITY, class)
    }

    /// A body moved by its joints: the run of parts from the parent, and the body's own link
    /// (returned).
    #[allow(clippy::too_many_arguments)]
    fn jointed_body(
        &mut self,
        el: &El,
        name: &str,
        joint_els: &[&El],
        parent: usize,
        x_body: SpatialTransform,
        class: &str,
        (inertia, geometry): (SpatialInertia, Vec<Geometry>),
    ) -> Result<usize, ModelError> {
        let doc = self.doc;
        let mut prev = parent;
        // Map from the current joint-chain frame to `prev`'s frame, before the next anchor.
        let mut pending = x_body;
        let n = joint_els.len();
        for (k, &j) in joint_els.iter().enumerate() {
            let jn = self.joint(j, name, k, class, parent)?;
            if jn.joint.kind == JointKind::Floating {
                if n > 1 {
                    return Err(doc.err(j, None, "a free joint must be its body's only joint"));
                }
                let l = self.add_link(name, inertia, geometry, el)?;
                let ji = self.add_joint(
                    j,
                    RawJoint {
                        origin: SpatialTransform::IDENTITY,
                        parent,
                        child: l,
                        ..jn.joint
                    },
                )?;
                self.free.push((l, ji));
                return Ok(l);
            }
            let last = k + 1 == n;
            let child = if last && jn.anchor == DVec3::ZERO {
                self.add_link(name, inertia, geometry.clone(), el)?
            } else {
                let link = format!("{name}@{}", jn.joint.name);
                let l = self.add_link(&link, SpatialInertia::ZERO, Vec::new(), el)?;
                if last {
                    self.renames.insert(link, name.to_string());
                }
                l
            };
            let origin =
                pending * SpatialTransform::from_pose(DMat3::IDENTITY, jn.anchor) * jn.zero;
            self.add_joint(
                j,
                RawJoint {
                    origin,
                    parent: prev,
                    child,
                    ..jn.joint
                },
            )?;
            prev = child;
            pending = SpatialTransform::from_pose(DMat3::IDENTITY, -jn.anchor);
        }
        if self.links[prev].name == name {
            return Ok(prev);
        }
        // The body's frame hangs off the last joint's frame at −anchor.
        let l = self.add_link(name, inertia, geometry, el)?;
        self.add_joint(
            el,
            RawJoint {
                name: format!("{name}#frame"),
                kind: JointKind::Fixed,
                origin: pending,
                axis: DVec3::Z,
                limits: None,
                parent: prev,
                child: l,
                dynamics: JointDynamics::default(),
            },
        )?;
        Ok(l)
    }

    /// The body's inertia (its `<inertial>`, or its geoms' by the compiler's
    /// `inertiafromgeom`) and contact geometry.
    fn body_inertia(
        &mut self,
        el: &El,
        class: &str,
    ) -> Result<(SpatialInertia, Vec<Geometry>), ModelError> {
        let doc = self.doc;
        let inertials: Vec<&El> = el.each("inertial").collect();
        if inertials.len() > 1 {
            return Err(doc.err(inertials[1], None, "a body has at most one <inertial>"));
        }
        let from_geoms = match self.compiler.inertia_from_geom {
            Some(x) => x,
            None => inertials.is_empty(),
        };
        let mut inertia = SpatialInertia::ZERO;
        let mut parts = Vec::new();
        let mut meshes = false;
        let mut geometry = Vec::new();
        for g in el.each("geom") {
            let a = Attrs::new(doc, &self.defaults, g, class)?;
            let geom = Geom::read(&a, &self.compiler)?;
            let [lo, hi] = self.compiler.inertia_groups;
            if from_geoms && (lo..=hi).contains(&geom.group) {
                let mesh = match &geom.mesh {
                    Some(m) => Some(self.meshes.inertia(doc, &self.defaults, m, &a)?),
                    None => None,
                };
                meshes |= mesh.is_some();
                let part = geom.mass_properties(&a, mesh.as_ref())?;
                inertia += part.spatial();
                parts.push(part);
            }
            geometry.extend(geom.geometry());
        }
        // Bodies with meshes take MuJoCo's route through principal axes, which drops a
        // residual that shows on tiny inertias; others keep the exact sum (the same to
        // rounding at ordinary sizes, and unchanged from before meshes were read).
        if meshes {
            inertia = GeomMass::principal_sum(&parts);
        }
        if !from_geoms {
            if let Some(i) = inertials.first() {
                inertia = self.inertial(i)?;
            }
        }
        Ok((inertia, geometry))
    }

    fn inertial(&self, el: &El) -> Result<SpatialInertia, ModelError> {
        let a = Attrs::plain(self.doc, el);
        let Some([mass]) = a.array::<1>("mass")? else {
            return Err(a.err("mass", "an <inertial> needs a mass"));
        };
        if mass < 0.0 {
            return Err(a.err("mass", format!("negative mass {mass}")));
        }
        let Some(pos) = a.array::<3>("pos")? else {
            return Err(a.err("pos", "an <inertial> needs a pos"));
        };
        let rot = DMat3::from_quat(geom::orientation(&a, &self.compiler)?);
        let ic = match (a.array::<3>("diaginertia")?, a.array::<6>("fullinertia")?) {
            (Some(d), None) => rot * DMat3::from_diagonal(DVec3::from_array(d)) * rot.transpose(),
            (None, Some([xx, yy, zz, xy, xz, yz])) => {
                let m = DMat3::from_cols(
                    DVec3::new(xx, xy, xz),
                    DVec3::new(xy, yy, yz),
                    DVec3::new(xz, yz, zz),
                );
                rot * m * rot.transpose()
            }
            (Some(_), Some(_)) => {
                return Err(a.err("fullinertia", "give diaginertia or fullinertia, not both"))
            }
            (None, None) => {
                return Err(a.err(
                    "diaginertia",
                    "an <inertial> needs diaginertia or fullinertia",
                ))
            }
        };
        let inertia = SpatialInertia::new(mass, DVec3::from_array(pos), ic);
        if !inertia.is_finite() {
            return Err(a.err("mass", "the inertia overflows"));
        }
        Ok(inertia)
    }

    /// One `<joint>` or `<freejoint>` of body `body` (its `k`-th).
    fn joint(
        &mut self,
        el: &El,
        body: &str,
        k: usize,
        class: &str,
        parent: usize,
    ) -> Result<ReadJoint, ModelError> {
        let doc = self.doc;
        let a = Attrs::new(doc, &self.defaults, el, class)?;
        let name = el
            .attr("name")
            .map_or_else(|| format!("{body}:joint{k}"), str::to_string);
        let kind = if el.tag == "freejoint" {
            "free"
        } else {
            a.get("type").unwrap_or("hinge")
        };
        let dynamics = JointDynamics {
            armature: a.number("armature", 0.0)?,
            damping: a.number("damping", 0.0)?,
            stiffness: a.number("stiffness", 0.0)?,
            spring_ref: 0.0,
        };
        for (v, attr) in [
            (dynamics.armature, "armature"),
            (dynamics.damping, "damping"),
            (dynamics.stiffness, "stiffness"),
        ] {
            if v < 0.0 {
                return Err(a.err(attr, format!("negative {attr} {v}")));
            }
        }
        if a.number("frictionloss", 0.0)? != 0.0 {
            ignore(&mut self.ignored, "MJCF joint friction (frictionloss)", el);
        }
        let spring_damper =
            match a.array::<2>("springdamper")? {
                Some([0.0, 0.0]) | None => None,
                Some([tc, dr]) if tc > 0.0 && dr > 0.0 => Some([tc, dr]),
                Some(_) => return Err(a.err(
                    "springdamper",
                    "when given, springdamper's time constant and damping ratio must be positive",
                )),
            };
        if let Some(sd) = spring_damper {
            if matches!(kind, "hinge" | "slide") {
                self.spring_dampers.push((name.clone(), sd));
            } else {
                ignore(
                    &mut self.ignored,
                    "MJCF springdamper of a ball or free joint",
                    el,
                );
            }
        }
        let joint = |kind, axis, limits, dynamics| RawJoint {
            name: name.clone(),
            kind,
            origin: SpatialTransform::IDENTITY,
            axis,
            limits,
            parent: 0,
            child: 0,
            dynamics,
        };
        match kind {
            "free" => {
                if parent != 0 {
                    return Err(doc.err(
                        el,
                        None,
                        "a free joint can only move a child of the world body",
                    ));
                }
                if dynamics.stiffness != 0.0 {
                    return Err(a.err("stiffness", "a free joint's spring is not modelled"));
                }
                Ok(ReadJoint {
                    joint: joint(JointKind::Floating, DVec3::Z, None, dynamics),
                    anchor: DVec3::ZERO,
                    zero: SpatialTransform::IDENTITY,
                })
            }
            "hinge" | "slide" => {
                let hinge = kind == "hinge";
                let reference = a.number("ref", 0.0)?;
                if reference != 0.0 {
                    let r = if hinge {
                        self.compiler.angle(reference)
                    } else {
                        reference
                    };
                    self.qpos0.insert(name.clone(), r);
                }
                self.scalar_joint(&a, hinge, dynamics, joint)
            }
            "ball" => {
                if dynamics.stiffness != 0.0 {
                    return Err(a.err("stiffness", "a ball joint's spring is not modelled"));
                }
                let range = a.array::<2>("range")?;
                let limited = match a.flag("limited", None)? {
                    Some(x) => x,
                    None => self.compiler.autolimits && range.is_some(),
                };
                if limited && range.is_some_and(|[_, hi]| hi > 0.0) {
                    ignore(&mut self.ignored, "MJCF ball joint cone limit (range)", el);
                }
                // The ball turns about its anchor; qpos = [qw, qx, qy, qz], qvel the angular
                // velocity in the body frame, as in MuJoCo.
                Ok(ReadJoint {
                    joint: joint(JointKind::Ball, DVec3::Z, None, dynamics),
                    anchor: DVec3::from_array(a.array::<3>("pos")?.unwrap_or([0.0; 3])),
                    zero: SpatialTransform::IDENTITY,
                })
            }
            other => Err(a.err("type", format!("unknown joint type '{other}'"))),
        }
    }

    fn scalar_joint(
        &self,
        a: &Attrs,
        hinge: bool,
        mut dynamics: JointDynamics,
        joint: impl Fn(JointKind, DVec3, Option<[f64; 2]>, JointDynamics) -> RawJoint,
    ) -> Result<ReadJoint, ModelError> {
        let c = &self.compiler;
        let angle = |x: f64| if hinge { c.angle(x) } else { x };
        let axis = DVec3::from_array(a.array::<3>("axis")?.unwrap_or([0.0, 0.0, 1.0]));
        if axis.length() < 1e-9 {
            return Err(a.err("axis", "zero axis"));
        }
        let axis = axis.normalize();
        let anchor = DVec3::from_array(a.array::<3>("pos")?.unwrap_or([0.0; 3]));
        let range = a.array::<2>("range")?;
        let limited = match a.flag("limited", None)? {
            Some(x) => x,
            None if c.autolimits => range.is_some(),
            None => {
                return Err(a.err(
                    "limited",
                    "with autolimits=\"false\" a joint with a range must say limited=\"true\" or \"false\"",
                ))
            }
        };
        let limits = match (limited, range) {
            (true, Some([lo, hi])) if lo < hi => Some([angle(lo), angle(hi)]),
            (true, _) => return Err(a.err("range", "a limited joint needs a range lower < upper")),
            (false, _) => None,
        };
        let reference = angle(a.number("ref", 0.0)?);
        dynamics.spring_ref = angle(a.number("springref", 0.0)?);
        // q = qpos: the joint frame carries M(−ref), so M(qpos − ref) = M(−ref) M(qpos).
        let (kind, zero) = if hinge {
            let kind = if limits.is_some() {
                JointKind::Revolute
            } else {
                JointKind::Continuous
            };
            let r = DMat3::from_axis_angle(axis, -reference);
            (kind, SpatialTransform::from_pose(r, DVec3::ZERO))
        } else {
            let t = SpatialTransform::from_pose(DMat3::IDENTITY, -reference * axis);
            (JointKind::Prismatic, t)
        };
        Ok(ReadJoint {
            joint: joint(kind, axis, limits, dynamics),
            anchor,
            zero,
        })
    }

    /// One warning per kind of element the dynamics does not model.
    fn not_modelled(&mut self) {
        let doc = self.doc;
        for (section, what) in [
            ("tendon", "MJCF <tendon>"),
            ("equality", "MJCF <equality> constraint"),
            ("actuator", "MJCF <actuator>"),
            ("sensor", "MJCF <sensor>"),
        ] {
            for s in doc.root.each(section) {
                for el in &s.children {
                    self.ignore(what, el);
                }
            }
        }
        for (what, items) in std::mem::take(&mut self.ignored) {
            self.warnings.push(LoadWarning::NotModelled { what, items });
        }
    }

    /// `settotalmass`: every body's mass and inertia scaled so that they add up to it.
    fn scale_total_mass(&mut self) -> Result<(), ModelError> {
        let Some(total) = self.compiler.total_mass else {
            return Ok(());
        };
        let sum: f64 = self.links.iter().map(|l| l.inertia.mass).sum();
        if sum <= 0.0 {
            return Err(self.doc.err(
                &self.doc.root,
                Some("settotalmass"),
                "the model has no mass to scale",
            ));
        }
        let s = total / sum;
        for l in &mut self.links {
            l.inertia = SpatialInertia {
                mass: l.inertia.mass * s,
                h: l.inertia.h * s,
                ibar: l.inertia.ibar * s,
            };
        }
        Ok(())
    }
}

/// Records an element the dynamics does not model, by its name (else its line).
fn ignore(ignored: &mut BTreeMap<String, Vec<String>>, what: &str, el: &El) {
    let name = el
        .attr("name")
        .map_or_else(|| format!("line {}", el.line), str::to_string);
    ignored.entry(what.to_string()).or_default().push(name);
}

/// A joint as read: its raw joint (origin, parent and child still to set), its anchor in the
/// body frame and the rotation or translation by `−ref`.
struct ReadJoint {
    joint: RawJoint,
    anchor: DVec3,
    zero: SpatialTransform,
}
