//! The acceleration metric's coefficients and weights (docs/design.md#adaptive): per node
//! `A(C) = Fᵀ Ψ F + Fᵀ p + η`, a quadratic function of its handle forces, so the selection
//! knows a subassembly's metric before computing its joints.

use articula_model::Model;

/// `Ψ`, `p`, `η` of every node (written bottom-up by the metric pass) and the per-joint
/// weights `A_i`, `V_i` of the acceleration and velocity metrics.
#[derive(Clone, Debug)]
pub(crate) struct MetricCoefficients {
    /// `Ψ` (6nh × 6nh, row-major) of every node, at [`MetricCoefficients::quad_at`].
    pub quad: Vec<f64>,
    /// Per node: where its `Ψ` starts in [`MetricCoefficients::quad`].
    pub quad_at: Vec<usize>,
    /// `p` (6nh) of every node, at `6 hoff`.
    pub linear: Vec<f64>,
    /// `η`, per node.
    pub constant: Vec<f64>,
    /// Per body joint: the acceleration metric's weight `A_i` (k × k, row-major, at
    /// [`MetricCoefficients::weight_at`]; identity by default).
    pub accel_weights: Vec<f64>,
    /// Per body joint: the velocity metric's weight `V_i` (like `A_i`).
    pub velocity_weights: Vec<f64>,
    /// Per body: where its joint's weights start.
    pub weight_at: Vec<usize>,
}

impl MetricCoefficients {
    /// Sized for `model`, the weights the identity.
    pub(crate) fn new(model: &Model) -> MetricCoefficients {
        let tree = &model.assembly;
        let mut quad_at = Vec::with_capacity(tree.nodes.len());
        let mut at = 0;
        for node in &tree.nodes {
            quad_at.push(at);
            at += 36 * node.handles.len() * node.handles.len();
        }
        let mut weight_at = Vec::with_capacity(model.bodies.len());
        let mut wo = 0;
        for body in &model.bodies {
            weight_at.push(wo);
            wo += body.nv * body.nv;
        }
        let mut accel_weights = vec![0.0; wo];
        for (i, body) in model.bodies.iter().enumerate() {
            for p in 0..body.nv {
                accel_weights[weight_at[i] + p * body.nv + p] = 1.0;
            }
        }
        let handles = tree.handle_layout().handles;
        MetricCoefficients {
            quad: vec![0.0; at],
            quad_at,
            linear: vec![0.0; 6 * handles],
            constant: vec![0.0; tree.nodes.len()],
            velocity_weights: accel_weights.clone(),
            accel_weights,
            weight_at,
        }
    }
}

impl MetricCoefficients {
    /// `A_i` of body `body`'s joint (k × k, row-major).
    pub(crate) fn accel_weight(&self, model: &Model, body: usize) -> &[f64] {
        let (wo, k) = (self.weight_at[body], model.bodies[body].nv);
        &self.accel_weights[wo..wo + k * k]
    }

    /// `A_i = scale · 1` for body `body`'s joint; whether it changed.
    pub(crate) fn set_accel_weight(&mut self, model: &Model, body: usize, scale: f64) -> bool {
        let (wo, k) = (self.weight_at[body], model.bodies[body].nv);
        let w = &mut self.accel_weights[wo..wo + k * k];
        let same = (0..k).all(|i| (0..k).all(|j| w[i * k + j] == if i == j { scale } else { 0.0 }));
        if !same {
            scaled_identity(w, k, scale);
        }
        !same
    }

    /// `V_i = scale · 1` for body `body`'s joint.
    pub(crate) fn set_velocity_weight(&mut self, model: &Model, body: usize, scale: f64) {
        let (wo, k) = (self.weight_at[body], model.bodies[body].nv);
        scaled_identity(&mut self.velocity_weights[wo..wo + k * k], k, scale);
    }
}

/// `w = scale · 1` (k × k, row-major).
fn scaled_identity(w: &mut [f64], k: usize, scale: f64) {
    for p in 0..k {
        for q in 0..k {
            w[p * k + q] = if p == q { scale } else { 0.0 };
        }
    }
}
