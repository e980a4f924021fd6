//! Many states of one model across cores: [`Batch`], forward dynamics and steps of a slice of
//! states (what Pinocchio's `abaInParallel` does), for users who sample (learning,
//! optimisation, Monte Carlo).

use crate::{forward_dynamics, step, Data, DynamicsError, Integrator, Method, State, Threads};
use articula_model::Model;
use thiserror::Error;

/// One [`Data`] workspace per thread of a [`Threads`], reused from call to call.
///
/// `n` states are split into [`Threads::count`] contiguous runs of `⌈n / count⌉` states, one
/// run per workspace; each state is solved exactly as [`forward_dynamics`] (or [`step`])
/// would with a workspace of its own, so the results are the same bits for any thread count
/// and equal to a serial loop's. After the first call of a given size nothing is allocated
/// but the pool's own bookkeeping.
///
/// ```
/// use articula_dca::{Batch, Method, State, Threads};
/// use articula_model::{LoadOptions, Model};
///
/// let urdf = r#"<robot name="pendulum"><link name="base"/>
///   <link name="bob"><inertial><origin xyz="0 0 -1"/><mass value="1"/>
///     <inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>
///   <joint name="swing" type="continuous"><parent link="base"/><child link="bob"/>
///     <axis xyz="0 1 0"/></joint></robot>"#;
/// let model = Model::from_urdf_str(urdf, &LoadOptions::default()).unwrap();
/// let states: Vec<State> = (0..100).map(|i| State::random(&model, i, 1.0)).collect();
/// let mut batch = Batch::new(&model, Threads::new(2).unwrap());
/// let mut qdd = vec![0.0; states.len() * model.nv];
/// batch.forward_dynamics(&model, &states, Method::Dca, &mut qdd).unwrap();
/// // m l² q̈ = −m g l sin q + τ, with the bob's own inertia I_yy = 1e-4 added.
/// let expected = (-9.81 * states[7].q[0].sin() + states[7].tau[0]) / (1.0 + 1e-4);
/// assert!((qdd[7] - expected).abs() < 1e-10);
/// ```
#[derive(Debug)]
pub struct Batch {
    threads: Threads,
    workers: Vec<Data>,
}

/// What can go wrong in a [`Batch`] call.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum BatchError {
    /// The output slice does not hold `states × nv` numbers.
    #[error("the output has length {found}, {states} states of the model need {expected}")]
    Output {
        /// The number of states.
        states: usize,
        /// `states × nv`.
        expected: usize,
        /// The length given.
        found: usize,
    },
    /// A state's dynamics failed (the lowest such index; every other state is still solved).
    #[error("state {index}: {source}")]
    State {
        /// The state's index in the slice.
        index: usize,
        /// Its error.
        #[source]
        source: DynamicsError,
    },
}

impl Batch {
    /// One default workspace ([`Data::new`]) per thread of `threads`.
    pub fn new(model: &Model, threads: Threads) -> Batch {
        Batch::with_data(&Data::new(model), threads)
    }

    /// One copy of `prototype` (its gravity and switches) per thread of `threads`.
    pub fn with_data(prototype: &Data, threads: Threads) -> Batch {
        let workers = vec![prototype.clone(); threads.count()];
        Batch { threads, workers }
    }

    /// The threads the batch runs on.
    pub fn threads(&self) -> &Threads {
        &self.threads
    }

    /// `q̈` of every state by `method`, state `i`'s in `qdd[i·nv .. (i+1)·nv]`. On error the
    /// lowest failing index is reported; every other state's `q̈` is still written.
    pub fn forward_dynamics(
        &mut self,
        model: &Model,
        states: &[State],
        method: Method,
        qdd: &mut [f64],
    ) -> Result<(), BatchError> {
        let nv = model.nv;
        if qdd.len() != states.len() * nv {
            return Err(BatchError::Output {
                states: states.len(),
                expected: states.len() * nv,
                found: qdd.len(),
            });
        }
        let solve = |data: &mut Data, first: usize, run: &[State], out: &mut [f64]| {
            let mut error = None;
            for (j, state) in run.iter().enumerate() {
                match forward_dynamics(model, data, state, method) {
                    Ok(a) => out[j * nv..(j + 1) * nv].copy_from_slice(a),
                    Err(e) => {
                        error.get_or_insert((first + j, e));
                    }
                }
            }
            error
        };
        let len = states.len().div_ceil(self.workers.len()).max(1);
        #[cfg(feature = "parallel")]
        let error = if self.threads.count() > 1 && nv > 0 {
            use rayon::prelude::*;
            let workers = &mut self.workers;
            self.threads.install(|| {
                workers
                    .par_iter_mut()
                    .zip(states.par_chunks(len))
                    .zip(qdd.par_chunks_mut(len * nv))
                    .enumerate()
                    .map(|(c, ((data, run), out))| solve(data, c * len, run, out))
                    .reduce_with(first_error)
                    .flatten()
            })
        } else {
            solve(&mut self.workers[0], 0, states, qdd)
        };
        #[cfg(not(feature = "parallel"))]
        let error = {
            let _ = len;
            solve(&mut self.workers[0], 0, states, qdd)
        };
        into_result(error)
    }

    /// One [`step`] of every state in place. On error the lowest failing index is reported;
    /// every other state is still stepped (a failing one is left as [`step`] leaves it).
    pub fn step(
        &mut self,
        model: &Model,
        states: &mut [State],
        method: Method,
        integrator: Integrator,
        dt: f64,
    ) -> Result<(), BatchError> {
        let advance = |data: &mut Data, first: usize, run: &mut [State]| {
            let mut error = None;
            for (j, state) in run.iter_mut().enumerate() {
                if let Err(e) = step(model, data, state, method, integrator, dt) {
                    error.get_or_insert((first + j, e));
                }
            }
            error
        };
        let len = states.len().div_ceil(self.workers.len()).max(1);
        #[cfg(feature = "parallel")]
        let error = if self.threads.count() > 1 {
            use rayon::prelude::*;
            let workers = &mut self.workers;
            self.threads.install(|| {
                workers
                    .par_iter_mut()
                    .zip(states.par_chunks_mut(len))
                    .enumerate()
                    .map(|(c, (data, run))| advance(data, c * len, run))
                    .reduce_with(first_error)
                    .flatten()
            })
        } else {
            advance(&mut self.workers[0], 0, states)
        };
        #[cfg(not(feature = "parallel"))]
        let error = {
            let _ = len;
            advance(&mut self.workers[0], 0, states)
        };
        into_result(error)
    }
}

type IndexedError = Option<(usize, DynamicsError)>;

/// The error of the lower index: the same whichever run finishes first.
#[cfg(feature = "parallel")]
fn first_error(a: IndexedError, b: IndexedError) -> IndexedError {
    match (a, b) {
        (Some(a), Some(b)) => Some(if a.0 <= b.0 { a } else { b }),
        (a, b) => a.or(b),
    }
}

fn into_result(error: IndexedError) -> Result<(), BatchError> {
    match error {
        None => Ok(()),
        Some((index, source)) => Err(BatchError::State { index, source }),
    }
}
