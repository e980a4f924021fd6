//! `articula info`: what a URDF becomes.

use crate::CliError;
use articula_model::{LoadOptions, Model};
use serde::Serialize;
use std::fmt::Write;
use std::path::Path;

/// The JSON printed by `articula info --json`.
#[derive(Serialize)]
pub struct Info {
    /// Robot name.
    pub name: String,
    /// Links in the URDF.
    pub urdf_links: usize,
    /// Joints in the URDF (all types).
    pub urdf_joints: usize,
    /// Rigid bodies after merging fixed joints and composing massless links (moving bodies).
    pub bodies: usize,
    /// Movable URDF joints (plus the floating base joint when asked for).
    pub movable_joints: usize,
    /// Degrees of freedom (length of `qd`).
    pub dof: usize,
    /// Length of `q` (differs from `dof` with a floating base: position + quaternion).
    pub nq: usize,
    /// Whether the root link floats.
    pub floating_base: bool,
    /// Total mass of all URDF links (kg).
    pub total_mass: f64,
    /// Mass of the moving bodies (kg): `total_mass` less what is welded to the world.
    pub moving_mass: f64,
    /// Joints composed from several URDF joints through massless links.
    pub composed_joints: Vec<Composed>,
    /// Bodies that absorbed other links through fixed joints.
    pub merged_bodies: Vec<Merged>,
    /// Links welded to the world.
    pub ground_links: Vec<String>,
    /// The assembly tree.
    pub assembly: Assembly,
    /// Load warnings: odd or changed inertias, locked joints, mimic joints, normalised axes.
    pub warnings: Vec<String>,
    /// Joints locked because they move no mass (q̈ = 0), with their massless links.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub locked_joints: Vec<Locked>,
}

/// A locked joint.
#[derive(Serialize)]
pub struct Locked {
    /// The URDF joint.
    pub joint: String,
    /// The massless links it moves.
    pub links: Vec<String>,
}

/// A composed joint.
#[derive(Serialize)]
pub struct Composed {
    /// The body it moves.
    pub body: String,
    /// Its URDF joints, parent side first.
    pub joints: Vec<String>,
    /// The massless links between them.
    pub massless_links: Vec<String>,
    /// Degrees of freedom.
    pub dof: usize,
}

/// A body made of several URDF links.
#[derive(Serialize)]
pub struct Merged {
    /// The body.
    pub body: String,
    /// All its URDF links, its own first.
    pub links: Vec<String>,
}

/// Assembly-tree figures.
#[derive(Serialize)]
pub struct Assembly {
    /// Number of nodes.
    pub nodes: usize,
    /// Height of the tree (root at depth 0).
    pub depth: usize,
    /// Largest handle count of any node.
    pub max_handles: usize,
}

impl Info {
    /// Gathers the figures of a loaded model.
    pub fn of(model: &Model) -> Info {
        Info {
            name: model.name.clone(),
            urdf_links: model.urdf_links,
            urdf_joints: model.urdf_joints,
            bodies: model.bodies.len(),
            movable_joints: model.coordinate_parts().count(),
            dof: model.nv,
            nq: model.nq,
            floating_base: model.floating_base,
            total_mass: round(model.moving_mass() + model.ground_mass),
            moving_mass: round(model.moving_mass()),
            composed_joints: model
                .bodies
                .iter()
                .filter(|b| b.joint.len() > 1)
                .map(|b| Composed {
                    body: b.name.clone(),
                    joints: b.joint.iter().map(|p| p.name.clone()).collect(),
                    massless_links: b.massless_links.clone(),
                    dof: b.nv,
                })
                .collect(),
            merged_bodies: model
                .bodies
                .iter()
                .filter(|b| b.links.len() > 1)
                .map(|b| Merged {
                    body: b.name.clone(),
                    links: b.links.iter().map(|l| l.0.clone()).collect(),
                })
                .collect(),
            ground_links: model.ground_links.iter().map(|l| l.0.clone()).collect(),
            assembly: Assembly {
                nodes: model.assembly.nodes.len(),
                depth: model.assembly.depth(),
                max_handles: model.assembly.max_handles(),
            },
            warnings: model.warnings.iter().map(|w| w.to_string()).collect(),
            locked_joints: model
                .locked
                .iter()
                .map(|l| Locked {
                    joint: l.joint.name.clone(),
                    links: l.links.clone(),
                })
                .collect(),
        }
    }
}

/// Rounds to 9 significant decimals so that sums print stably.
fn round(x: f64) -> f64 {
    (x * 1e9).round() / 1e9
}

/// "MJCF" or "URDF": the format `Model::from_file` read `path` as (its first 64 KiB decide).
fn file_format(path: &Path) -> &'static str {
    use std::io::Read;
    let mut head = Vec::new();
    let read = std::fs::File::open(path).and_then(|f| f.take(1 << 16).read_to_end(&mut head));
    match read {
        Ok(_) if articula_model::is_mjcf(&String::from_utf8_lossy(&head)) => "MJCF",
        _ => "URDF",
    }
}

/// Runs `articula info`.
pub fn run(path: &Path, options: &LoadOptions, json: bool, tree: bool) -> Result<(), CliError> {
    let model = Model::from_file(path, options)?;
    let info = Info::of(&model);
    let format = file_format(path);
    if json {
        return crate::print_out(&format!("{}\n", serde_json::to_string_pretty(&info)?));
    }
    let mut out = String::new();
    for w in &info.warnings {
        eprintln!("warning: {w}");
    }
    writeln!(out, "robot        {}", info.name)?;
    writeln!(
        out,
        "{format:<12} {} links, {} joints",
        info.urdf_links, info.urdf_joints
    )?;
    writeln!(
        out,
        "bodies       {} moving (after merging fixed joints){}",
        info.bodies,
        if info.floating_base {
            ", floating base"
        } else {
            ", fixed base"
        }
    )?;
    writeln!(
        out,
        "joints       {} movable, {} DOF (nq = {})",
        info.movable_joints, info.dof, info.nq
    )?;
    writeln!(
        out,
        "mass         {:.3} kg total, {:.3} kg moving",
        info.total_mass, info.moving_mass
    )?;
    writeln!(
        out,
        "assembly     {} nodes, depth {}, at most {} handles per node",
        info.assembly.nodes, info.assembly.depth, info.assembly.max_handles
    )?;
    writeln!(
        out,
        "collision    {}",
        articula_model::CollisionModel::new(&model).summary()
    )?;
    let limited = model
        .joint_parts()
        .filter(|(_, p)| p.limits.is_some())
        .count();
    writeln!(out, "limits       {limited} joints with {format} limits")?;
    if !info.composed_joints.is_empty() {
        writeln!(out, "composed joints (through massless links):")?;
        for c in &info.composed_joints {
            writeln!(
                out,
                "  {:<14} {} DOF = {}  (massless: {})",
                c.body,
                c.dof,
                c.joints.join(" + "),
                c.massless_links.join(", ")
            )?;
        }
    }
    if !info.locked_joints.is_empty() {
        writeln!(out, "locked joints (moving no mass, q̈ = 0):")?;
        for l in &info.locked_joints {
            writeln!(out, "  {:<14} {}", l.joint, l.links.join(", "))?;
        }
    }
    if !info.merged_bodies.is_empty() {
        writeln!(out, "merged by fixed joints:")?;
        for m in &info.merged_bodies {
            writeln!(out, "  {:<14} {}", m.body, m.links.join(", "))?;
        }
    }
    if tree {
        writeln!(out, "assembly tree:")?;
        write!(out, "{}", model.assembly.outline(&model))?;
    }
    crate::print_out(&out)
}
