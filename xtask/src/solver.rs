//! The methods the benchmarks compare, as one small enum. A new method (the adaptive solver at
//! a budget, once `articula-adaptive` exists) is a new variant plus one arm in each `match`:
//! its label, and how its [`Runner`] computes `q̈` and takes a step.

use articula_dca::{forward_dynamics, step, Data, Integrator, Method, State};
use articula_model::Model;

/// A method of computing forward dynamics inside this process.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Solver {
    /// One of the exact solvers of `articula-dca`.
    Exact(Method),
    // Adaptive { budget: usize } — added with articula-adaptive: `label` gives
    // "adaptive b=K", `Runner::new` builds its workspace, `forward`/`step` call it.
}

impl Solver {
    /// The exact solvers, in table order.
    pub const EXACT: [Solver; 3] = [
        Solver::Exact(Method::Dca),
        Solver::Exact(Method::Aba),
        Solver::Exact(Method::Crba),
    ];

    /// The label in tables and chart legends.
    pub fn label(self) -> String {
        match self {
            Solver::Exact(m) => m.name().to_uppercase(),
        }
    }

    /// Whether the method is worth running on a model of `nv` degrees of freedom (CRBA's dense
    /// factorisation is O(n³): the benches stop it at 1000 links).
    pub fn runs_at(self, nv: usize) -> bool {
        match self {
            Solver::Exact(Method::Crba) => nv <= 1000,
            Solver::Exact(_) => true,
        }
    }
}

/// A solver with its workspace for one model.
pub struct Runner<'m> {
    model: &'m Model,
    solver: Solver,
    data: Data,
}

impl<'m> Runner<'m> {
    pub fn new(model: &'m Model, solver: Solver) -> Runner<'m> {
        Runner {
            model,
            solver,
            data: Data::new(model),
        }
    }

    /// `q̈` of `state`.
    pub fn forward(&mut self, state: &State) -> Result<&[f64], String> {
        match self.solver {
            Solver::Exact(m) => forward_dynamics(
                self.model,
                &mut self.data,
                &state.q,
                &state.qd,
                &state.tau,
                &state.f_ext,
                m,
            )
            .map_err(|e| e.to_string()),
        }
    }

    /// Advances `state` by `dt`.
    pub fn step(
        &mut self,
        state: &mut State,
        integrator: Integrator,
        dt: f64,
    ) -> Result<(), String> {
        match self.solver {
            Solver::Exact(m) => step(self.model, &mut self.data, state, m, integrator, dt)
                .map_err(|e| e.to_string()),
        }
    }
}
