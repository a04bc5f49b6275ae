//! `diffosi jacobian`: one step's exact Jacobians, as tables or JSON.

use diffosi::derivatives::{step_jacobians, StepJacobians, Workspace, Wrt};
use diffosi::Model;
use nalgebra::DMatrixView;
use serde_json::json;

/// The point of the step.
#[derive(clap::Args)]
pub struct State {
    /// Positions (nq values, comma separated); the reference configuration if omitted.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    q: Option<Vec<f64>>,
    /// Velocities (nv values); zero if omitted.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    v: Option<Vec<f64>>,
    /// Generalized forces (nv values); zero if omitted.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    tau: Option<Vec<f64>>,
}

pub fn jacobian(
    file: &super::ModelFile,
    state: State,
    names: &[String],
    as_json: bool,
) -> Result<(), String> {
    let model = file.load()?;
    let q = state.q.unwrap_or_else(|| model.reference_q());
    let v = state.v.unwrap_or_else(|| vec![0.0; model.nv()]);
    let tau = state.tau.unwrap_or_else(|| vec![0.0; model.nv()]);
    let params = names
        .iter()
        .map(|name| model.param(name))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let wrt = Wrt {
        state: true,
        control: true,
        params: &params,
    };
    let mut ws = Workspace::new(&model);
    let j = step_jacobians(&model, &mut ws, (&q, &v, &tau), &wrt).map_err(|e| e.to_string())?;
    if as_json {
        println!("{}", to_json(&model, names, &j));
    } else {
        print_tables(&j);
    }
    Ok(())
}

fn rows(m: DMatrixView<f64>) -> Vec<Vec<f64>> {
    m.row_iter().map(|r| r.iter().copied().collect()).collect()
}

fn to_json(model: &Model, params: &[String], j: &StepJacobians) -> serde_json::Value {
    json!({
        "model": model.name,
        "joint_names": model.joints.iter().map(|j| &j.name).collect::<Vec<_>>(),
        // the rows and columns of every block: the dofs (positions in the tangent space)
        "dof_names": model.coordinate_names().1,
        "params": params,
        "q_next": j.q_next,
        "v_next": j.v_next,
        "dq_dq": rows(j.dq_dq()),
        "dq_dv": rows(j.dq_dv()),
        "dq_dtau": rows(j.dq_dtau()),
        "dv_dq": rows(j.dv_dq()),
        "dv_dv": rows(j.dv_dv()),
        "dv_dtau": rows(j.dv_dtau()),
        "dq_dp": rows(j.dq_dp()),
        "dv_dp": rows(j.dv_dp()),
    })
}

fn print_tables(j: &StepJacobians) {
    println!("q_next = {:?}\nv_next = {:?}", j.q_next, j.v_next);
    let blocks = [
        ("dq/dq", j.dq_dq()),
        ("dq/dv", j.dq_dv()),
        ("dq/dtau", j.dq_dtau()),
        ("dv/dq", j.dv_dq()),
        ("dv/dv", j.dv_dv()),
        ("dv/dtau", j.dv_dtau()),
        ("dq/dp", j.dq_dp()),
        ("dv/dp", j.dv_dp()),
    ];
    for (name, m) in blocks.into_iter().filter(|(_, m)| m.ncols() > 0) {
        println!("{name}:");
        for row in m.row_iter() {
            // Adding 0.0 prints -0.0 as 0.
            let cells: Vec<String> = row.iter().map(|x| format!("{:>12.5e}", x + 0.0)).collect();
            println!("  {}", cells.join(" "));
        }
    }
}
