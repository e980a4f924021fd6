//! URDF text → validated links and joints.
//!
//! Two passes. A strict pre-pass with `roxmltree` checks everything dynamics needs (names,
//! joint types, numbers in origins, axes and inertials) so that errors name the offending link
//! or joint, and strips everything dynamics does not need (visual and collision geometry,
//! materials, limits, `<gazebo>`, `<transmission>`, unknown tags), so sloppy geometry never makes
//! loading fail. `urdf-rs` then parses the stripped text into its typed `Robot`, and the values
//! are validated (finite, positive semidefinite inertia, triangle inequality, unit axes, one
//! root, no cycles).

use crate::ModelError;
use articula_spatial::{SpatialInertia, SpatialTransform};
use glam::{DMat3, DVec3};
use std::collections::HashMap;

/// The motion a URDF joint allows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum JointKind {
    /// Rotation about the axis, with limits in the URDF (the limits are not enforced).
    Revolute,
    /// Rotation about the axis without limits.
    Continuous,
    /// Translation along the axis.
    Prismatic,
    /// Welded: the child is merged into the parent.
    Fixed,
    /// Six degrees of freedom.
    Floating,
}

impl JointKind {
    /// Number of position coordinates.
    pub fn nq(self) -> usize {
        match self {
            JointKind::Fixed => 0,
            JointKind::Floating => 7,
            _ => 1,
        }
    }
    /// Number of velocity coordinates (degrees of freedom).
    pub fn nv(self) -> usize {
        match self {
            JointKind::Fixed => 0,
            JointKind::Floating => 6,
            _ => 1,
        }
    }
}

/// A link as read from the URDF.
#[derive(Clone, Debug)]
pub(crate) struct RawLink {
    pub name: String,
    /// Spatial inertia in the link frame.
    pub inertia: SpatialInertia,
}

/// A joint as read from the URDF.
#[derive(Clone, Debug)]
pub(crate) struct RawJoint {
    pub name: String,
    pub kind: JointKind,
    /// Joint frame → parent link frame (the joint origin as a pose).
    pub origin: SpatialTransform,
    /// Unit axis in the joint frame.
    pub axis: DVec3,
    pub parent: usize,
    pub child: usize,
}

/// A validated robot: links, joints, the root link, and warnings.
#[derive(Clone, Debug)]
pub(crate) struct RawRobot {
    pub name: String,
    pub links: Vec<RawLink>,
    pub joints: Vec<RawJoint>,
    pub root: usize,
    pub warnings: Vec<String>,
}

const KNOWN_TYPES: [&str; 7] = [
    "revolute",
    "continuous",
    "prismatic",
    "fixed",
    "floating",
    "planar",
    "spherical",
];

/// Reads a URDF file (bytes are checked for being text first).
pub(crate) fn read_file(path: &std::path::Path) -> Result<RawRobot, ModelError> {
    let bytes = std::fs::read(path).map_err(|e| ModelError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    let text = std::str::from_utf8(&bytes).map_err(|e| ModelError::NotText {
        reason: "invalid UTF-8".into(),
        offset: e.valid_up_to(),
    })?;
    read_str(text)
}

/// Reads a URDF from text.
pub(crate) fn read_str(text: &str) -> Result<RawRobot, ModelError> {
    if text.trim().is_empty() {
        return Err(ModelError::Empty);
    }
    if let Some(offset) = text.bytes().position(|b| b == 0) {
        return Err(ModelError::NotText {
            reason: "NUL byte".into(),
            offset,
        });
    }
    let (stripped, warnings) = prepass(text)?;
    let robot =
        urdf_rs::read_from_string(&stripped).map_err(|e| ModelError::Urdf(e.to_string()))?;
    validate(robot, warnings)
}

fn malformed(element: &'static str, name: &str, message: impl Into<String>) -> ModelError {
    ModelError::Malformed {
        element,
        name: name.to_string(),
        message: message.into(),
    }
}

/// Strictly parses `n` whitespace-separated numbers.
fn numbers(s: &str, n: usize) -> Option<Vec<f64>> {
    let v: Vec<f64> = s
        .split_whitespace()
        .map(|t| t.parse::<f64>())
        .collect::<Result<_, _>>()
        .ok()?;
    (v.len() == n).then_some(v)
}

fn check_numbers(
    node: roxmltree::Node,
    attr: &str,
    n: usize,
    element: &'static str,
    name: &str,
    required: bool,
) -> Result<(), ModelError> {
    match node.attribute(attr) {
        Some(s) => numbers(s, n).map(|_| ()).ok_or_else(|| {
            malformed(
                element,
                name,
                format!(
                    "<{}> attribute '{attr}' must hold {n} number(s), found \"{s}\"",
                    node.tag_name().name()
                ),
            )
        }),
        None if required => Err(malformed(
            element,
            name,
            format!("<{}> lacks attribute '{attr}'", node.tag_name().name()),
        )),
        None => Ok(()),
    }
}

/// Whether urdf-rs reads `quat_xyzw` (URDF 1.1 and later; the same test as urdf-rs: a missing
/// or malformed `version` means 1.0).
fn supports_quat(robot: roxmltree::Node) -> bool {
    robot
        .attribute("version")
        .and_then(|v| {
            let (major, minor) = v.trim().split_once('.')?;
            Some((major.parse::<u32>().ok()?, minor.parse::<u32>().ok()?))
        })
        .is_some_and(|version| version >= (1, 1))
}

fn check_origin(
    node: roxmltree::Node,
    element: &'static str,
    name: &str,
    supports_quat: bool,
) -> Result<(), ModelError> {
    check_numbers(node, "xyz", 3, element, name, false)?;
    check_numbers(node, "rpy", 3, element, name, false)?;
    check_numbers(node, "quat_xyzw", 4, element, name, false)?;
    if !supports_quat {
        return Ok(());
    }
    let Some(quat) = node.attribute("quat_xyzw").and_then(|s| numbers(s, 4)) else {
        return Ok(());
    };
    // urdf-rs rejects both orientations without naming the link or joint, and silently reads
    // a zero or NaN quaternion as the identity.
    if node.attribute("rpy").is_some() {
        return Err(malformed(
            element,
            name,
            "<origin> has both 'rpy' and 'quat_xyzw'",
        ));
    }
    if quat.iter().any(|x| !x.is_finite()) {
        return Err(if element == "joint" {
            ModelError::InvalidOrigin { joint: name.into() }
        } else {
            ModelError::NonFiniteInertia { link: name.into() }
        });
    }
    if quat.iter().all(|&x| x == 0.0) {
        return Err(malformed(
            element,
            name,
            "<origin> 'quat_xyzw' is the zero quaternion",
        ));
    }
    Ok(())
}

/// Records `tag` as seen inside a link or joint, failing on a second occurrence: urdf-rs would
/// reject the duplicate without naming the link or joint.
fn once<'a>(
    seen: &mut Vec<&'a str>,
    tag: &'a str,
    element: &'static str,
    name: &str,
) -> Result<(), ModelError> {
    if seen.contains(&tag) {
        return Err(malformed(element, name, format!("duplicate <{tag}>")));
    }
    seen.push(tag);
    Ok(())
}

/// roxmltree reads a name written `:x` as `x` with an empty namespace prefix, which urdf-rs's
/// XML parser rejects without saying where: reject it here, with its position, for the elements
/// that are handed on to urdf-rs.
fn check_prefixes(doc: &roxmltree::Document, node: roxmltree::Node) -> Result<(), ModelError> {
    let text = doc.input_text();
    let range = node.range();
    let raw = &text[range.clone()];
    // The end tag, if any, must match the start tag, so `</:x>` goes with `<:x>`; check it too.
    let end_tag = (!raw.ends_with("/>"))
        .then(|| raw.rfind("</").map(|i| range.start + i + 1))
        .flatten();
    let bad = std::iter::once(range.start)
        .chain(end_tag)
        .map(|lt| lt + 1)
        .chain(node.attributes().map(|a| a.range_qname().start))
        .find(|&at| text[at..].starts_with(':'));
    match bad {
        Some(at) => {
            let pos = doc.text_pos_at(at);
            Err(ModelError::Xml {
                line: pos.row,
                column: pos.col,
                message: "name with an empty namespace prefix".into(),
            })
        }
        None => Ok(()),
    }
}

/// The strict pre-pass: validates what dynamics needs and returns the text with everything
/// else cut out, plus warnings.
fn prepass(text: &str) -> Result<(String, Vec<String>), ModelError> {
    let doc = roxmltree::Document::parse(text).map_err(|e| {
        let pos = e.pos();
        ModelError::Xml {
            line: pos.row,
            column: pos.col,
            message: e.to_string(),
        }
    })?;
    let robot = doc.root_element();
    if robot.tag_name().name() != "robot" {
        return Err(ModelError::NotARobot {
            found: robot.tag_name().name().to_string(),
        });
    }
    check_prefixes(&doc, robot)?;
    let quat = supports_quat(robot);
    let mut cut: Vec<std::ops::Range<usize>> = Vec::new();
    let mut warnings = Vec::new();
    for el in robot.children().filter(|n| n.is_element()) {
        match el.tag_name().name() {
            "link" => {
                check_prefixes(&doc, el)?;
                let name = el
                    .attribute("name")
                    .ok_or_else(|| malformed("link", "", "missing 'name' attribute"))?;
                let mut seen_inertial = Vec::new();
                for c in el.children().filter(|n| n.is_element()) {
                    if c.tag_name().name() != "inertial" {
                        cut.push(c.range());
                        continue;
                    }
                    once(&mut seen_inertial, "inertial", "link", name)?;
                    check_prefixes(&doc, c)?;
                    let mut seen = Vec::new();
                    for p in c.children().filter(|n| n.is_element()) {
                        let tag = p.tag_name().name();
                        if !matches!(tag, "origin" | "mass" | "inertia") {
                            cut.push(p.range());
                            continue;
                        }
                        once(&mut seen, tag, "link", name)?;
                        check_prefixes(&doc, p)?;
                        match tag {
                            "origin" => check_origin(p, "link", name, quat)?,
                            "mass" => check_numbers(p, "value", 1, "link", name, true)?,
                            _ => {
                                for a in ["ixx", "ixy", "ixz", "iyy", "iyz", "izz"] {
                                    check_numbers(p, a, 1, "link", name, true)?;
                                }
                            }
                        }
                    }
                    if !seen.contains(&"mass") {
                        return Err(malformed("link", name, "<inertial> lacks <mass>"));
                    }
                    if !seen.contains(&"inertia") {
                        return Err(malformed("link", name, "<inertial> lacks <inertia>"));
                    }
                }
            }
            "joint" => {
                check_prefixes(&doc, el)?;
                let name = el
                    .attribute("name")
                    .ok_or_else(|| malformed("joint", "", "missing 'name' attribute"))?;
                let kind = el
                    .attribute("type")
                    .ok_or_else(|| malformed("joint", name, "missing 'type' attribute"))?;
                if !KNOWN_TYPES.contains(&kind) {
                    return Err(ModelError::UnknownJointType {
                        joint: name.into(),
                        kind: kind.into(),
                    });
                }
                let mut seen = Vec::new();
                for c in el.children().filter(|n| n.is_element()) {
                    let tag = c.tag_name().name();
                    if matches!(tag, "origin" | "axis" | "parent" | "child") {
                        once(&mut seen, tag, "joint", name)?;
                        check_prefixes(&doc, c)?;
                    }
                    match tag {
                        "origin" => check_origin(c, "joint", name, quat)?,
                        "axis" => {
                            check_numbers(c, "xyz", 3, "joint", name, true).map_err(|_| {
                                ModelError::InvalidAxis {
                                    joint: name.into(),
                                    reason: format!(
                                        "'xyz' must hold 3 numbers, found {:?}",
                                        c.attribute("xyz").unwrap_or("")
                                    ),
                                }
                            })?
                        }
                        "parent" | "child" => {
                            if c.attribute("link").is_none() {
                                return Err(malformed(
                                    "joint",
                                    name,
                                    format!("<{tag}> lacks attribute 'link'"),
                                ));
                            }
                        }
                        "mimic" => {
                            warnings.push(format!(
                                "joint '{name}' mimics '{}': loaded as an independent joint (the mimic constraint is not enforced)",
                                c.attribute("joint").unwrap_or("?")
                            ));
                            cut.push(c.range());
                        }
                        _ => cut.push(c.range()),
                    }
                }
                if !seen.contains(&"parent") {
                    return Err(malformed("joint", name, "missing <parent>"));
                }
                if !seen.contains(&"child") {
                    return Err(malformed("joint", name, "missing <child>"));
                }
            }
            _ => cut.push(el.range()),
        }
    }
    cut.sort_by_key(|r| r.start);
    let mut out = String::with_capacity(text.len());
    let mut at = 0;
    for r in cut {
        if r.start >= at {
            out.push_str(&text[at..r.start]);
            at = r.end;
        }
    }
    out.push_str(&text[at..]);
    Ok((out, warnings))
}

fn vec3(v: &urdf_rs::Vec3) -> DVec3 {
    DVec3::new(v[0], v[1], v[2])
}

/// URDF `rpy` (fixed-axis roll about x, then pitch about y, then yaw about z) as a rotation
/// matrix `Rz(y) Ry(p) Rx(r)`.
pub fn rpy_to_matrix(rpy: DVec3) -> DMat3 {
    DMat3::from_rotation_z(rpy.z) * DMat3::from_rotation_y(rpy.y) * DMat3::from_rotation_x(rpy.x)
}

fn pose(p: &urdf_rs::Pose) -> Option<SpatialTransform> {
    let (xyz, rpy) = (vec3(&p.xyz), vec3(&p.rpy));
    (xyz.is_finite() && rpy.is_finite())
        .then(|| SpatialTransform::from_pose(rpy_to_matrix(rpy), xyz))
}

/// Positive semidefinite test of a symmetric 3×3 matrix through all principal minors, with a
/// tolerance relative to its scale.
fn is_psd3(m: DMat3, scale: f64) -> bool {
    let tol = 1e-9 * scale;
    let a = |i: usize, j: usize| m.col(j)[i];
    let d = [a(0, 0), a(1, 1), a(2, 2)];
    if d.iter().any(|&x| x < -tol) {
        return false;
    }
    for (i, j) in [(0, 1), (0, 2), (1, 2)] {
        if a(i, i) * a(j, j) - a(i, j) * a(i, j) < -tol * tol {
            return false;
        }
    }
    m.determinant() >= -tol * tol * tol
}

fn validate(robot: urdf_rs::Robot, warnings: Vec<String>) -> Result<RawRobot, ModelError> {
    let mut warnings = warnings;
    if robot.links.is_empty() {
        return Err(ModelError::NoLinks);
    }
    let mut link_index = HashMap::new();
    let mut links = Vec::with_capacity(robot.links.len());
    for l in &robot.links {
        if link_index.insert(l.name.clone(), links.len()).is_some() {
            return Err(ModelError::DuplicateLink {
                link: l.name.clone(),
            });
        }
        let m = l.inertial.mass.value;
        if !m.is_finite() || m < 0.0 {
            return Err(ModelError::InvalidMass {
                link: l.name.clone(),
                mass: m,
            });
        }
        let i = &l.inertial.inertia;
        let ic = DMat3::from_cols(
            DVec3::new(i.ixx, i.ixy, i.ixz),
            DVec3::new(i.ixy, i.iyy, i.iyz),
            DVec3::new(i.ixz, i.iyz, i.izz),
        );
        let origin = pose(&l.inertial.origin);
        let (Some(origin), true) = (origin, ic.is_finite()) else {
            return Err(ModelError::NonFiniteInertia {
                link: l.name.clone(),
            });
        };
        let scale =
            i.ixx.abs() + i.iyy.abs() + i.izz.abs() + i.ixy.abs() + i.ixz.abs() + i.iyz.abs();
        if !is_psd3(ic, scale) {
            return Err(ModelError::InertiaNotPositive {
                link: l.name.clone(),
            });
        }
        // Triangle inequality λi ≤ λj + λk  ⇔  tr(I)/2 · 1 − I ⪰ 0 (the second moment of mass).
        let second_moment = DMat3::from_diagonal(DVec3::splat(0.5 * (i.ixx + i.iyy + i.izz))) - ic;
        if !is_psd3(second_moment, scale) {
            return Err(ModelError::TriangleInequality {
                link: l.name.clone(),
            });
        }
        // The inertial frame (origin, rpy) in link coordinates: com = xyz, I_com rotated.
        let (rot, com) = origin.to_pose();
        let inertia = SpatialInertia::new(m, com, rot * ic * rot.transpose());
        // Finite inputs can still overflow (a huge mass far from the link origin).
        if !inertia.is_finite() {
            return Err(ModelError::NonFiniteInertia {
                link: l.name.clone(),
            });
        }
        links.push(RawLink {
            name: l.name.clone(),
            inertia,
        });
    }

    let mut joint_names = HashMap::new();
    let mut joints = Vec::with_capacity(robot.joints.len());
    let mut parent_joint: Vec<Option<usize>> = vec![None; links.len()];
    for j in &robot.joints {
        if joint_names.insert(j.name.clone(), joints.len()).is_some() {
            return Err(ModelError::DuplicateJoint {
                joint: j.name.clone(),
            });
        }
        let find = |role: &'static str, link: &str| {
            link_index
                .get(link)
                .copied()
                .ok_or_else(|| ModelError::MissingLink {
                    joint: j.name.clone(),
                    role,
                    link: link.to_string(),
                })
        };
        let parent = find("parent", &j.parent.link)?;
        let child = find("child", &j.child.link)?;
        let kind = match j.joint_type {
            urdf_rs::JointType::Revolute => JointKind::Revolute,
            urdf_rs::JointType::Continuous => JointKind::Continuous,
            urdf_rs::JointType::Prismatic => JointKind::Prismatic,
            urdf_rs::JointType::Fixed => JointKind::Fixed,
            urdf_rs::JointType::Floating => JointKind::Floating,
            urdf_rs::JointType::Planar => {
                return Err(ModelError::UnsupportedJointType {
                    joint: j.name.clone(),
                    kind: "planar".into(),
                })
            }
            urdf_rs::JointType::Spherical => {
                return Err(ModelError::UnsupportedJointType {
                    joint: j.name.clone(),
                    kind: "spherical".into(),
                })
            }
        };
        let origin = pose(&j.origin).ok_or_else(|| ModelError::InvalidOrigin {
            joint: j.name.clone(),
        })?;
        let mut axis = vec3(&j.axis.xyz);
        if matches!(
            kind,
            JointKind::Revolute | JointKind::Continuous | JointKind::Prismatic
        ) {
            if !axis.is_finite() {
                return Err(ModelError::InvalidAxis {
                    joint: j.name.clone(),
                    reason: "non-finite component".into(),
                });
            }
            // Scaled first, so huge components do not overflow the length to infinity (and
            // the axis to zero).
            let max = axis.abs().max_element();
            let len = if max > 0.0 {
                max * (axis / max).length()
            } else {
                0.0
            };
            if len < 1e-9 {
                return Err(ModelError::InvalidAxis {
                    joint: j.name.clone(),
                    reason: "zero length".into(),
                });
            }
            if (len - 1.0).abs() > 1e-6 {
                warnings.push(format!(
                    "joint '{}': axis of length {len} normalised",
                    j.name
                ));
            }
            axis = (axis / max).normalize();
        }
        if let Some(first) = parent_joint[child] {
            let first: &RawJoint = &joints[first];
            return Err(ModelError::MultipleParents {
                link: links[child].name.clone(),
                joints: vec![first.name.clone(), j.name.clone()],
            });
        }
        parent_joint[child] = Some(joints.len());
        joints.push(RawJoint {
            name: j.name.clone(),
            kind,
            origin,
            axis,
            parent,
            child,
        });
    }

    let roots: Vec<usize> = (0..links.len())
        .filter(|&l| parent_joint[l].is_none())
        .collect();
    if roots.len() > 1 {
        return Err(ModelError::MultipleRoots {
            roots: roots.iter().map(|&l| links[l].name.clone()).collect(),
        });
    }
    let Some(&root) = roots.first() else {
        return Err(ModelError::Cycle {
            link: links[0].name.clone(),
        });
    };
    // Every link must be reachable from the root; the unreachable ones sit on a cycle.
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); links.len()];
    for j in &joints {
        children[j.parent].push(j.child);
    }
    let mut seen = vec![false; links.len()];
    let mut stack = vec![root];
    while let Some(l) = stack.pop() {
        seen[l] = true;
        stack.extend(children[l].iter().copied().filter(|&c| !seen[c]));
    }
    if let Some(l) = seen.iter().position(|s| !s) {
        return Err(ModelError::Cycle {
            link: links[l].name.clone(),
        });
    }
    Ok(RawRobot {
        name: robot.name,
        links,
        joints,
        root,
        warnings,
    })
}
