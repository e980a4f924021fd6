//! Composite inertias of the assembly tree's nodes (docs/design.md#adaptive): every rigid
//! subassembly enters the main pass as one rigid body.

use articula_model::Model;
use glam::{DMat3, DVec3};

/// A rigid body's mass properties: mass, centre of mass and rotational inertia about it
/// (computation frame).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Rigid {
    pub m: f64,
    pub c: DVec3,
    pub ic: DMat3,
}

impl Rigid {
    /// The composite of two rigid bodies welded together (parallel-axis theorem about the
    /// common centre of mass).
    pub fn combine(&self, o: &Rigid) -> Rigid {
        let m = self.m + o.m;
        if m <= 0.0 {
            return Rigid::default();
        }
        let c = (self.c * self.m + o.c * o.m) / m;
        let shift = |r: &Rigid| {
            let d = r.c - c;
            (DMat3::from_diagonal(DVec3::splat(d.length_squared())) - outer(d, d)) * r.m
        };
        Rigid {
            m,
            c,
            ic: self.ic + o.ic + shift(self) + shift(o),
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
    /// The composite mass properties (computation frame; `comp`).
    pub rigid: Vec<Rigid>,
    /// Whether the subassembly holds the ground (a fixed base): it then never moves.
    pub grounded: Vec<bool>,
    /// Its top body (nearest the root; `usize::MAX` for a node holding the ground).
    pub top: Vec<usize>,
}

impl Composites {
    /// Sized for `model`'s assembly tree.
    pub(crate) fn new(model: &Model) -> Composites {
        let nn = model.assembly.nodes.len();
        Composites {
            rigid: vec![Rigid::default(); nn],
            grounded: vec![false; nn],
            top: vec![usize::MAX; nn],
        }
    }
}
