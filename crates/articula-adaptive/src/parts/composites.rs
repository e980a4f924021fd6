//! Composite inertias of the assembly tree's nodes (docs/design.md#adaptive): every rigid
//! subassembly enters the main pass as one rigid body.

use articula_model::Model;
use glam::{DMat3, DVec3};

/// A rigid body's mass properties: mass, centre of mass and rotational inertia about it
/// (computation frame).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Rigid {
    /// The mass.
    pub mass: f64,
    /// The centre of mass.
    pub com: DVec3,
    /// The rotational inertia about the centre of mass.
    pub inertia: DMat3,
}

impl Rigid {
    /// The composite of two rigid bodies welded together (parallel-axis theorem about the
    /// common centre of mass).
    pub fn combine(&self, o: &Rigid) -> Rigid {
        let m = self.mass + o.mass;
        if m <= 0.0 {
            return Rigid::default();
        }
        let c = (self.com * self.mass + o.com * o.mass) / m;
        let shift = |r: &Rigid| {
            let d = r.com - c;
            (DMat3::from_diagonal(DVec3::splat(d.length_squared())) - outer(d, d)) * r.mass
        };
        Rigid {
            mass: m,
            com: c,
            inertia: self.inertia + o.inertia + shift(self) + shift(o),
        }
    }
}

fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// Per assembly-tree node, its subassembly welded rigid (written bottom-up by
/// `Adaptive::composites` at each whole-body load).
#[derive(Clone, Debug)]
pub(crate) struct Composites {
    /// The composite mass properties (computation frame).
    pub rigid: Vec<Rigid>,
    /// Whether the subassembly holds the ground (a fixed base): it then never moves.
    pub grounded: Vec<bool>,
    /// Its top body (nearest the root; `usize::MAX` for a node holding the ground).
    pub top_body: Vec<usize>,
}

impl Composites {
    /// Sized for `model`'s assembly tree.
    pub(crate) fn new(model: &Model) -> Composites {
        let nn = model.assembly.nodes.len();
        Composites {
            rigid: vec![Rigid::default(); nn],
            grounded: vec![false; nn],
            top_body: vec![usize::MAX; nn],
        }
    }
}
