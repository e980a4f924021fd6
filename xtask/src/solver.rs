//! The methods the benchmarks compare, as one small enum. A new method is a new variant plus
//! one arm in each `match`: its label, and how its [`Runner`] computes `q̈` and takes a step.
//!
//! The adaptive solver (`articula-adaptive`) runs at every budget of [`ADAPTIVE_BUDGETS`]:
//! `forward` is its one-state selection (selected joints exact, the others zero) and `step` a
//! full adaptive step re-selecting every `every` steps (1: selection and rigidification at
//! every step; `Settings::BALANCED`: the library's default period), by semi-implicit Euler
//! (`Adaptive::step`) or RK4 (`Adaptive::step_rk4`) as the caller asks.

use articula_adaptive::{Adaptive, Reselection, Settings};
use articula_dca::{forward_dynamics_slices, step, Data, Integrator, Method, State};
use articula_model::Model;

/// A method of computing forward dynamics inside this process.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Solver {
    /// One of the exact solvers of `articula-dca`.
    Exact(Method),
    /// Adaptive dynamics with at most `budget` active internal degrees of freedom.
    Adaptive {
        /// The budget.
        budget: usize,
        /// Re-selection period of `step` (`Settings::reselect_every`; `Settings::BALANCED`
        /// for the library's default).
        every: u64,
        /// Re-select through the caches (`Reselection::Caches`) instead of the default exact
        /// solve.
        caches: bool,
    },
}

/// The budgets (active joints) the benchmarks run the adaptive solver at: the seeds' table
/// rows.
pub const ADAPTIVE_BUDGETS: [usize; 7] = [1, 50, 100, 150, 200, 250, 300];

impl Solver {
    /// The adaptive solver at `budget` active joints, re-selecting at every step.
    pub fn adaptive(budget: usize) -> Option<Solver> {
        Some(Solver::Adaptive {
            budget,
            every: 1,
            caches: false,
        })
    }

    /// Every solver the benchmarks run: the exact ones, then the adaptive budgets that exist.
    pub fn all() -> Vec<Solver> {
        Solver::EXACT
            .into_iter()
            .chain(ADAPTIVE_BUDGETS.into_iter().filter_map(Solver::adaptive))
            .collect()
    }

    /// Whether any adaptive solver exists yet.
    pub fn adaptive_available() -> bool {
        ADAPTIVE_BUDGETS
            .iter()
            .any(|&b| Solver::adaptive(b).is_some())
    }

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
            Solver::Adaptive {
                budget,
                every,
                caches,
            } => {
                let route = if caches { " caches" } else { "" };
                match every {
                    1 => format!("adaptive b={budget}{route}"),
                    Settings::BALANCED => format!("adaptive b={budget} balanced{route}"),
                    _ => format!("adaptive b={budget} every {every}{route}"),
                }
            }
        }
    }

    /// Whether the method is worth running on a model of `nv` degrees of freedom (CRBA's dense
    /// factorisation is O(n³): the benches stop it at 1000 links).
    pub fn runs_at(self, nv: usize) -> bool {
        match self {
            Solver::Exact(Method::Crba) => nv <= 1000,
            Solver::Exact(_) => true,
            Solver::Adaptive { .. } => true,
        }
    }
}

/// A solver with its workspace for one model.
pub struct Runner<'m> {
    model: &'m Model,
    solver: Solver,
    data: Data,
    adaptive: Option<Adaptive>,
}

impl<'m> Runner<'m> {
    pub fn new(model: &'m Model, solver: Solver) -> Runner<'m> {
        let adaptive = match solver {
            Solver::Adaptive {
                budget,
                every,
                caches,
            } => {
                let mut ad = Adaptive::new(
                    model,
                    Settings {
                        budget: Some(budget),
                        reselect_every: every,
                        ..Settings::default()
                    },
                );
                if caches {
                    ad.set_reselection(Reselection::Caches);
                }
                Some(ad)
            }
            Solver::Exact(_) => None,
        };
        Runner {
            model,
            solver,
            data: Data::new(model),
            adaptive,
        }
    }

    /// `q̈` of `state`.
    pub fn forward(&mut self, state: &State) -> Result<&[f64], String> {
        match self.solver {
            Solver::Exact(m) => forward_dynamics_slices(
                self.model,
                &mut self.data,
                &state.q,
                &state.qd,
                &state.tau,
                &state.f_ext,
                m,
            )
            .map_err(|e| e.to_string()),
            Solver::Adaptive { .. } => self
                .adaptive
                .as_mut()
                .expect("adaptive workspace")
                .forward_dynamics(self.model, &state.q, &state.qd, &state.tau, &state.f_ext)
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
            Solver::Adaptive { .. } => {
                let ad = self.adaptive.as_mut().expect("adaptive workspace");
                match integrator {
                    Integrator::SemiImplicitEuler => ad.step(self.model, state, dt),
                    Integrator::Rk4 => ad.step_rk4(self.model, state, dt),
                }
                .map(|_| ())
                .map_err(|e| e.to_string())
            }
        }
    }

    /// The adaptive solver's `q̈` of its last step (selected joints exact, the others zero);
    /// `None` for an exact solver.
    pub fn adaptive_qdd(&self) -> Option<&[f64]> {
        self.adaptive.as_ref().map(|ad| ad.qdd())
    }
}
