//! What loading noticed without refusing: [`LoadWarning`].

use crate::body_inertia::{InertiaChange, InertiaDefect};
use std::fmt;

/// Something worth knowing about a model that loaded: read as written but odd, changed by the
/// loader, or not modelled. Printed one a line (`Display`).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum LoadWarning {
    /// A `<mimic>` joint, loaded as an independent joint.
    Mimic {
        /// The mimicking joint.
        joint: String,
        /// The joint it mimics.
        leader: String,
    },
    /// A joint axis that was not of unit length.
    AxisNormalised {
        /// The joint.
        joint: String,
        /// The length read.
        length: f64,
    },
    /// A body whose inertia no rigid body has, loaded as written
    /// ([`crate::InertiaPolicy::Accept`]): the conditions it breaks.
    OddInertia(Vec<InertiaDefect>),
    /// A body whose inertia the loader changed: a point or rod mass given the smallest
    /// invertible inertia under [`crate::InertiaPolicy::Accept`], or any defect under
    /// [`crate::InertiaPolicy::Repair`].
    InertiaChanged(InertiaChange),
    /// A moving joint carrying no mass, locked ([`crate::MasslessLeafPolicy::Lock`]).
    LockedJoint {
        /// The joint.
        joint: String,
        /// The massless links it moves.
        links: Vec<String>,
    },
    /// Something the file describes that articula's dynamics does not model (MJCF tendons,
    /// equality constraints, actuators, sensors, sites; joint friction), listed by name.
    NotModelled {
        /// What it is (`MJCF <tendon>`).
        what: String,
        /// The elements' names.
        items: Vec<String>,
    },
}

impl LoadWarning {
    /// Adds `item` to the [`LoadWarning::NotModelled`] of `what` in `warnings` (one warning
    /// per kind of thing, listing every element), or starts it.
    pub(crate) fn not_modelled(warnings: &mut Vec<LoadWarning>, what: &str, item: &str) {
        for w in warnings.iter_mut() {
            if let LoadWarning::NotModelled {
                what: w_what,
                items,
            } = w
            {
                if w_what == what {
                    items.push(item.to_string());
                    return;
                }
            }
        }
        warnings.push(LoadWarning::NotModelled {
            what: what.to_string(),
            items: vec![item.to_string()],
        });
    }
}

impl fmt::Display for LoadWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LoadWarning::Mimic { joint, leader } => write!(
                f,
                "joint '{joint}' mimics '{leader}': loaded as an independent joint (the mimic constraint is not enforced)"
            ),
            LoadWarning::AxisNormalised { joint, length } => {
                write!(f, "joint '{joint}': axis of length {length} normalised")
            }
            LoadWarning::OddInertia(defects) => {
                let parts: Vec<String> = defects.iter().map(|d| d.to_string()).collect();
                write!(f, "{}; loaded as written", parts.join("; "))
            }
            LoadWarning::InertiaChanged(change) => write!(f, "{change}"),
            LoadWarning::LockedJoint { joint, links } => write!(
                f,
                "joint '{joint}' moves only massless links ({}): locked, its q̈ is 0",
                links.join(", ")
            ),
            LoadWarning::NotModelled { what, items } => write!(
                f,
                "{what} not modelled, ignored ({}): {}",
                items.len(),
                items.join(", ")
            ),
        }
    }
}
