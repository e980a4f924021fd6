//! The scratch of the main and metric passes: what one join or one node's metric writes and
//! reads within itself.

use articula_model::Model;
use articula_spatial::Mat6;

/// Five rows of a one-axis join's `Ỹ_h`, each padded to eight lanes (the last two zero).
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Rows5(pub [[f64; 8]; 5]);

/// Per-handle and per-node scratch, sized for the model's largest node (`nh` handles).
#[derive(Clone, Debug)]
pub(crate) struct PassScratch {
    /// The metric pass's `A_C K` (k × 6nh; `s1`).
    pub metric_ak: Vec<f64>,
    /// The metric pass's `Kᵀ A k` and `G = Ψ_X[jx,jx] N` (6 × 6nh; `s2`).
    pub metric_g: Vec<f64>,
    /// The metric pass's row of `s Ψ_X[i,jx] N` (6nh; `s3`).
    pub metric_row: Vec<f64>,
    /// A node's handle forces `F` as one array (6nh; `fx`).
    pub handle_forces: Vec<f64>,
    /// A child's handle → the joined node's handle (`usize::MAX`: the joint's own handle).
    pub handle_map: Vec<usize>,
    /// Per handle of the join being computed: the columns of `Y_h` and `U_h`.
    pub y_cols: Vec<[[f64; 6]; 6]>,
    pub u_cols: Vec<[[f64; 6]; 6]>,
    /// Per handle of the one-axis join: the five rows of `Ỹ_h`, each padded to eight (lanes
    /// 6, 7 stay zero) so that its Gram products run on whole 4-wide vectors.
    pub y_rows: Vec<Rows5>,
    /// Per handle of the one-axis join: `G_F,h`.
    pub g_force: Vec<Mat6>,
}

impl PassScratch {
    /// Sized for `model`'s largest node.
    pub(crate) fn new(model: &Model) -> PassScratch {
        let mh = model.assembly.max_handles().max(1);
        let scratch = 4 * 6 * mh * 6 * mh;
        PassScratch {
            metric_ak: vec![0.0; scratch],
            metric_g: vec![0.0; scratch],
            metric_row: vec![0.0; scratch],
            handle_forces: vec![0.0; 6 * mh],
            handle_map: vec![usize::MAX; mh],
            y_cols: vec![[[0.0; 6]; 6]; mh],
            u_cols: vec![[[0.0; 6]; 6]; mh],
            y_rows: vec![Rows5([[0.0; 8]; 5]); mh],
            g_force: vec![Mat6::ZERO; mh],
        }
    }
}
