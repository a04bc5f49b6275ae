//! `diffosi simulate`: a rollout written as CSV, one transition per row, in
//! the layout `diffosi identify` reads.
//!
//! Columns: `t` (s, the row's start), `q_<joint>`, `v_<joint>` (the state at
//! t), `tau_<dof>` (the generalized force of the step from t), `q_next_<joint>`,
//! `v_next_<joint>` (the state after that step), then for a model with
//! contact pairs one `fn_<geom a>_<geom b>` per pair (force sensing): the
//! normal force (N) on a along the contact normal at the row's state, summed
//! over the pair's contact points (a box's corners, a capsule's two ends),
//! which is the force the row's step applies under its tau. 0 out of reach;
//! b is the plane, or the geom first in MuJoCo's shape order (see
//! `diffosi::dynamics::contact` and `diffosi::dynamics::collision` for the
//! conventions).

use std::io::Write;

use diffosi::compile::{collision_pairs, contact_pairs};
use diffosi::model::{ContactModel, Inputs, State};
use diffosi::Model;
use indicatif::{ProgressBar, ProgressStyle};

pub fn simulate(
    file: &super::ModelFile,
    steps: usize,
    torques: Option<&std::path::Path>,
    q0: Option<Vec<f64>>,
    v0: Option<Vec<f64>>,
    output: &std::path::Path,
) -> Result<(), String> {
    let model = file.load()?;
    let q0 = q0.unwrap_or_else(|| model.reference_q());
    let v0 = v0.unwrap_or_else(|| vec![0.0; model.nv()]);
    // Checked before the output file is created, so a bad flag leaves no CSV behind.
    for (flag, x, n) in [("--q0: q", &q0, model.nq()), ("--v0: v", &v0, model.nv())] {
        if x.len() != n {
            return Err(format!("{flag} has length {}, expected {n}", x.len()));
        }
    }
    let taus = match torques {
        Some(file) => read_torques(file, model.nv(), steps)?,
        None => vec![vec![0.0; model.nv()]; steps],
    };
    let bar = ProgressBar::new(steps as u64).with_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} steps {elapsed}<{eta}")
            .expect("valid template"),
    );
    let mut data = model.data();
    let mut x = State::new(q0, v0);
    let file = std::fs::File::create(output)
        .map_err(|e| format!("cannot write {}: {e}", output.display()))?;
    let mut out = std::io::BufWriter::new(file);
    let io = |e: std::io::Error| format!("cannot write {}: {e}", output.display());
    let (q_names, v_names) = model.coordinate_names();
    let pairs = sensed_pairs(&model);
    let geom = |g: usize| model.geoms[g].name.as_str();
    let named = |prefix: &str, names: &[String]| -> Vec<String> {
        names.iter().map(|n| format!("{prefix}_{n}")).collect()
    };
    let header: Vec<String> = [
        vec!["t".to_string()],
        named("q", &q_names),
        named("v", &v_names),
        named("tau", &v_names),
        named("q_next", &q_names),
        named("v_next", &v_names),
        pairs
            .iter()
            .map(|&[a, b]| format!("fn_{}_{}", geom(a), geom(b)))
            .collect(),
    ]
    .concat();
    writeln!(out, "{}", header.join(",")).map_err(io)?;
    let started = std::time::Instant::now();
    for (t, tau) in taus.iter().enumerate() {
        let sensed = normal_forces(&model, &mut data, &pairs, (&x.q, &x.v, tau))
            .map_err(|e| format!("contacts at step {t}: {e}"))?;
        let next = model
            .step(&mut data, &x, &Inputs::tau(tau))
            .map_err(|e| format!("step {t}: {e}"))?;
        let time = t as f64 * model.opt.timestep;
        let row: Vec<String> = std::iter::once(time)
            .chain(
                [&x.q, &x.v, tau, &next.q, &next.v]
                    .into_iter()
                    .flatten()
                    .copied(),
            )
            .chain(sensed)
            .map(|x| format!("{x:?}"))
            .collect();
        writeln!(out, "{}", row.join(",")).map_err(io)?;
        x = next;
        bar.inc(1);
    }
    out.flush().map_err(io)?;
    bar.finish_and_clear();
    eprintln!(
        "simulated {steps} steps of {} (nq {}) in {:.3} s; wrote {}",
        model.name,
        model.nq(),
        started.elapsed().as_secs_f64(),
        output.display()
    );
    Ok(())
}

/// The geom pairs that may touch, as [geom 2, geom 1] of their contacts
/// (the geom the normal force pushes first; the smooth model's [a, b]).
fn sensed_pairs(model: &Model) -> Vec<[usize; 2]> {
    match model.opt.contact_model {
        ContactModel::Smooth => contact_pairs(model),
        ContactModel::Constraint => collision_pairs(model, &|_, _, x| x)
            .into_iter()
            .map(|([g1, g2], ..)| [g2, g1])
            .collect(),
    }
}

/// The normal force of each pair's contact at (q, v) under tau, in the
/// order of `pairs`.
fn normal_forces(
    model: &Model,
    data: &mut diffosi::dynamics::Data<f64>,
    pairs: &[[usize; 2]],
    (q, v, tau): (&[f64], &[f64], &[f64]),
) -> Result<Vec<f64>, diffosi::dynamics::StepError> {
    let mut out = vec![0.0; pairs.len()];
    if pairs.is_empty() {
        return Ok(out);
    }
    for c in model.contacts(data, &State::new(q.to_vec(), v.to_vec()), &Inputs::tau(tau))? {
        let [g1, g2] = c.geoms;
        if let Some(k) = pairs.iter().position(|&p| p == [g2, g1]) {
            out[k] += c.normal_force;
        }
    }
    Ok(out)
}

/// Reads `steps` rows of `nv` numbers; a first row that is not numeric is a header.
fn read_torques(path: &std::path::Path, nv: usize, steps: usize) -> Result<Vec<Vec<f64>>, String> {
    let shown = path.display();
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read {shown}: {e}"))?;
    let mut rows = vec![];
    for (i, line) in text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
    {
        let parsed: Result<Vec<f64>, _> =
            line.split(',').map(|x| x.trim().parse::<f64>()).collect();
        match parsed {
            Ok(row) if row.len() == nv => {
                if let Some(bad) = row.iter().position(|x| !x.is_finite()) {
                    return Err(format!(
                        "{shown}:{}: value {} is not finite",
                        i + 1,
                        bad + 1
                    ));
                }
                rows.push(row)
            }
            Ok(row) => {
                return Err(format!(
                    "{shown}:{}: {} values, expected nv = {nv}",
                    i + 1,
                    row.len()
                ))
            }
            Err(_) if i == 0 && rows.is_empty() => continue, // header
            Err(e) => return Err(format!("{shown}:{}: {e}", i + 1)),
        }
    }
    if rows.len() < steps {
        return Err(format!(
            "{shown} has {} rows of torques, --steps asks for {steps}",
            rows.len()
        ));
    }
    rows.truncate(steps);
    Ok(rows)
}
