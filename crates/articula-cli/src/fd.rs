//! `articula fd`: the joint accelerations of one state, keyed by URDF joint name.

use crate::{load_state, print_out, CliError, DynamicsArgs};
use articula_dca::{forward_dynamics_slices, Method};
use articula_model::Model;
use serde::ser::{SerializeMap, Serializer};
use serde::Serialize;
use std::path::PathBuf;

/// Arguments of `articula fd`.
#[derive(clap::Args, Debug)]
pub struct FdArgs {
    #[command(flatten)]
    pub dynamics: DynamicsArgs,
    /// The state (docs/state-format.md); without it, the neutral configuration at rest.
    #[arg(long, value_name = "STATE.json")]
    pub state: Option<PathBuf>,
    /// `--method adaptive`: also solve exactly (DCA) and print `actual_error`, the acceleration
    /// metric of the difference.
    #[arg(long)]
    pub compare: bool,
}

/// What `--method adaptive` adds to the JSON.
pub struct AdaptiveOutput {
    /// URDF names of the joints whose accelerations were computed.
    pub active_joints: Vec<String>,
    /// `Σ q̈ᵀ A q̈` over the joints set to zero (the metric mass left in the queue).
    pub predicted_error: f64,
    /// The metric of the difference to exact DCA (`--compare`).
    pub actual_error: Option<f64>,
}

/// The JSON printed by `articula fd`.
#[derive(Serialize)]
pub struct FdOutput<'a> {
    /// The algorithm's name.
    pub method: &'static str,
    /// `q̈` per movable URDF joint, in model coordinate order.
    pub qdd: ByJoint<'a>,
    /// The adaptive selection (`--method adaptive`).
    #[serde(skip)]
    pub adaptive: Option<AdaptiveOutput>,
}

/// Per-joint slices of a coordinate vector, serialised as a JSON object in model order.
pub struct ByJoint<'a>(pub Vec<(&'a str, &'a [f64])>);

impl<'a> ByJoint<'a> {
    /// Splits a velocity-sized vector (`qd`, `qdd`, `tau`) by joint.
    pub fn velocities(model: &'a Model, v: &'a [f64]) -> ByJoint<'a> {
        ByJoint(
            model
                .coordinate_parts()
                .map(|p| (p.name.as_str(), &v[p.v_offset..p.v_offset + p.nv()]))
                .collect(),
        )
    }
}

impl Serialize for ByJoint<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(Some(self.0.len()))?;
        for (name, values) in &self.0 {
            map.serialize_entry(name, values)?;
        }
        map.end()
    }
}

/// Runs `articula fd` on the pool of `--threads`.
pub fn run(args: &FdArgs) -> Result<(), CliError> {
    let threads = crate::threads(args.dynamics.threads)?;
    threads.install(|| run_here(args, &threads))
}

/// Runs `articula fd` on the current thread (or pool); one body's DCA split over `threads`
/// from [`articula_dca::PARALLEL_DCA_MIN_BODIES`] bodies.
fn run_here(args: &FdArgs, threads: &articula_dca::Threads) -> Result<(), CliError> {
    let (model, mut data) = args.dynamics.load()?;
    let state = load_state(args.state.as_deref(), &model)?;
    let method = args.dynamics.method;
    if args.compare && method != crate::MethodArg::Adaptive {
        return Err(CliError("--compare needs --method adaptive".to_string()));
    }
    let Some(exact) = method.exact() else {
        let mut ad = args.dynamics.adaptive(&model, 1);
        let qdd = ad
            .forward_dynamics(&model, &state.q, &state.qd, &state.tau, &state.f_ext)?
            .to_vec();
        let sel = ad.selection().clone();
        let active_joints = model
            .bodies
            .iter()
            .enumerate()
            .filter(|(i, _)| ad.is_selected(&model, *i))
            .flat_map(|(_, b)| b.joint.iter().map(|p| p.name.clone()))
            .collect();
        let actual_error = if args.compare {
            let e = forward_dynamics_slices(
                &model,
                &mut data,
                &state.q,
                &state.qd,
                &state.tau,
                &state.f_ext,
                Method::Dca,
            )?;
            let mut err = 0.0;
            for (i, b) in model.bodies.iter().enumerate() {
                let r = b.v_offset..b.v_offset + b.nv;
                let d: Vec<f64> = qdd[r.clone()]
                    .iter()
                    .zip(&e[r])
                    .map(|(x, y)| x - y)
                    .collect();
                let w = ad.weight(&model, i);
                for p in 0..b.nv {
                    for q in 0..b.nv {
                        err += d[p] * w[p * b.nv + q] * d[q];
                    }
                }
            }
            Some(err)
        } else {
            None
        };
        let out = FdOutput {
            method: method.name(),
            qdd: ByJoint::velocities(&model, &qdd),
            adaptive: Some(AdaptiveOutput {
                active_joints,
                predicted_error: sel.predicted_error,
                actual_error,
            }),
        };
        return print_out(&out.to_json()?);
    };
    let qdd = articula_dca::forward_dynamics_threads(
        &model,
        &mut data,
        &state.q,
        &state.qd,
        &state.tau,
        &state.f_ext,
        exact,
        threads,
    )?
    .to_vec();
    if data.fallback_count() > 0 {
        eprintln!(
            "warning: DCA could not certify this solve (its refinement did not converge); \
             the accelerations are ABA's (docs/algorithms.md, \"When DCA falls back to ABA\")"
        );
    }
    let out = FdOutput {
        method: exact.name(),
        qdd: ByJoint::velocities(&model, &qdd),
        adaptive: None,
    };
    print_out(&out.to_json()?)
}

impl FdOutput<'_> {
    /// Pretty JSON with each joint's vector on one line.
    pub fn to_json(&self) -> Result<String, serde_json::Error> {
        let mut s = format!(
            "{{\n  \"method\": {},\n  \"qdd\": {{",
            serde_json::to_string(self.method)?
        );
        for (i, (name, values)) in self.qdd.0.iter().enumerate() {
            s.push_str(if i == 0 { "\n    " } else { ",\n    " });
            s.push_str(&serde_json::to_string(name)?);
            s.push_str(": ");
            s.push_str(&serde_json::to_string(values)?.replace(',', ", "));
        }
        s.push_str(if self.qdd.0.is_empty() { "}" } else { "\n  }" });
        if let Some(a) = &self.adaptive {
            s.push_str(",\n  \"active_joints\": ");
            s.push_str(&serde_json::to_string(&a.active_joints)?.replace(',', ", "));
            s.push_str(",\n  \"predicted_error\": ");
            s.push_str(&serde_json::to_string(&a.predicted_error)?);
            if let Some(e) = a.actual_error {
                s.push_str(",\n  \"actual_error\": ");
                s.push_str(&serde_json::to_string(&e)?);
            }
        }
        s.push_str("\n}\n");
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_is_valid_and_in_order() {
        let v = [1.5, -0.25, 1e-300, 2.0];
        let out = FdOutput {
            method: "dca",
            qdd: ByJoint(vec![("z\"q", &v[0..1]), ("a", &v[1..4])]),
            adaptive: None,
        };
        let text = out.to_json().unwrap();
        assert_eq!(
            text,
            "{\n  \"method\": \"dca\",\n  \"qdd\": {\n    \"z\\\"q\": [1.5],\n    \"a\": [-0.25, 1e-300, 2.0]\n  }\n}\n"
        );
        let parsed: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(parsed["qdd"]["a"][1], 1e-300);
        assert_eq!(parsed, serde_json::to_value(&out).unwrap());
        let empty = FdOutput {
            method: "aba",
            qdd: ByJoint(vec![]),
            adaptive: None,
        };
        let parsed: serde_json::Value = serde_json::from_str(&empty.to_json().unwrap()).unwrap();
        assert_eq!(parsed, serde_json::json!({"method": "aba", "qdd": {}}));
    }
}
