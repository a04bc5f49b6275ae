//! `diffosi identify`: DiffOSI on transitions read from a CSV file, with the
//! named parameters themselves as mu (each scalar of each parameter is one
//! mu component, in the order given).

use std::path::Path;

use diffosi::derivatives::Impulses;
use diffosi::derivatives::Transition;
use diffosi::model::{Param, ParamMap, State};
use diffosi::osi::{default_scale, Adam, CmaEs, Estimate, Identifier, Lm, Problem};
use serde_json::json;

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// Bounded Levenberg-Marquardt on the exact residual Jacobian.
    Lm,
    /// The paper's first-order variant: Adam on the loss gradient.
    Adam,
    /// Derivative-free CMA-ES (seeded), a baseline.
    Cmaes,
}

/// How the transitions' engine applies its constraint impulses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ImpulsesArg {
    /// Through M + E (MuJoCo's and our Euler step).
    Model,
    /// Through M alone (DART's).
    Mass,
}

impl From<ImpulsesArg> for Impulses {
    fn from(a: ImpulsesArg) -> Impulses {
        match a {
            ImpulsesArg::Model => Impulses::Model,
            ImpulsesArg::Mass => Impulses::Mass,
        }
    }
}

/// What `identify` is asked, as parsed from the command line.
pub struct Request<'a> {
    pub model: &'a super::ModelFile,
    pub params: &'a [String],
    pub transitions: &'a Path,
    pub method: Method,
    pub lower: Option<Vec<f64>>,
    pub upper: Option<Vec<f64>>,
    pub init: Option<Vec<f64>>,
    pub scale: Option<Vec<f64>>,
    /// The margin, force scale and impulses when the constraints are unknown.
    pub unknown_constraints: Option<(f64, Option<Vec<f64>>, Impulses)>,
    pub json: bool,
}

pub fn identify(r: Request) -> Result<(), String> {
    let model = r.model.load()?;
    if r.params.is_empty() {
        return Err("--params names no parameter".into());
    }
    let mut params: Vec<Param> = vec![];
    for name in r.params {
        let p = model.param(name).map_err(|e| e.to_string())?;
        if params.contains(&p) {
            return Err(format!("parameter '{name}' is given twice"));
        }
        params.push(p);
    }
    let labels = labels(r.params, &params);
    let nmu = labels.len();
    let current: Vec<f64> = r
        .params
        .iter()
        .flat_map(|name| model.get_param(name).unwrap())
        .collect();
    let (default_lower, default_upper) = default_bounds(&params, &current);
    let lower = values("--lower", r.lower, default_lower, nmu)?;
    let upper = values("--upper", r.upper, default_upper, nmu)?;
    for i in 0..nmu {
        let (lo, hi) = (lower[i], upper[i]);
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(format!(
                "bounds of {}: lower {lo} and upper {hi} must be finite with lower < upper",
                labels[i]
            ));
        }
    }
    // The model's values, clamped into the bounds, unless given.
    let default_init = (0..nmu)
        .map(|i| current[i].clamp(lower[i], upper[i]))
        .collect();
    let init = values("--init", r.init, default_init, nmu)?;
    for i in 0..nmu {
        if !(lower[i]..=upper[i]).contains(&init[i]) {
            return Err(format!(
                "--init {} = {} lies outside its bounds [{}, {}]",
                labels[i], init[i], lower[i], upper[i]
            ));
        }
    }
    let nv = model.nv();
    let scale = match r.scale {
        Some(s) if s.len() == 1 => vec![s[0]; 2 * nv],
        s => values("--scale", s, default_scale(&model), 2 * nv)
            .map_err(|e| format!("{e} (or a single value for all)"))?,
    };
    if let Some(s) = scale.iter().find(|s| !(s.is_finite() && **s > 0.0)) {
        return Err(format!("--scale value {s} must be finite and positive"));
    }

    let window = read_transitions(r.transitions, model.nq(), nv)?;
    let map = ParamMap::identity(&model, r.params).map_err(|e| e.to_string())?;
    let mut problem =
        Problem::new(&model, map, &lower, &upper, &init, &scale).map_err(|e| e.to_string())?;
    if let Some((margin, force_scale, impulses)) = r.unknown_constraints {
        let force_scale = match force_scale {
            Some(s) if s.len() == 1 => vec![s[0]; nv],
            s => values("--force-scale", s, vec![1.0; nv], nv)
                .map_err(|e| format!("{e} (or a single value for all)"))?,
        };
        problem = problem
            .with_unknown_constraints(margin, &force_scale, impulses)
            .map_err(|e| e.to_string())?;
    }
    let estimate = match r.method {
        Method::Lm => Lm::default().identify(&mut problem, &window, &init),
        Method::Adam => Adam::default().identify(&mut problem, &window, &init),
        Method::Cmaes => CmaEs::default().identify(&mut problem, &window, &init),
    }
    .map_err(|e| e.to_string())?;
    if r.json {
        let out = to_json(&labels, r.method, window.len(), &estimate);
        println!("{}", serde_json::to_string_pretty(&out).unwrap());
    } else {
        print_text(&labels, r.method, window.len(), &estimate);
    }
    Ok(())
}

/// One label per mu component: the name, with an index for vector parameters.
fn labels(names: &[String], params: &[Param]) -> Vec<String> {
    let mut out = vec![];
    for (name, p) in names.iter().zip(params) {
        if p.size() == 1 {
            out.push(name.clone());
        } else {
            out.extend((0..p.size()).map(|i| format!("{name}[{i}]")));
        }
    }
    out
}

/// Default bounds around the model's values x (documented in `--help`):
/// masses and inertia diagonals [x/10, 10x]; COM coordinates x -+ 1 m;
/// inertia products x -+ the largest diagonal moment; damping, stiffness and
/// armature [0, max(10x, 1)].
fn default_bounds(params: &[Param], current: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (mut lower, mut upper) = (vec![], vec![]);
    let mut k = 0;
    for p in params {
        let x = &current[k..k + p.size()];
        for (i, &xi) in x.iter().enumerate() {
            let (lo, hi) = match p {
                Param::Mass(_) => (xi / 10.0, xi * 10.0),
                Param::Inertia(_) if i < 3 => (xi / 10.0, xi * 10.0),
                Param::Inertia(_) => {
                    let d = x[..3].iter().fold(0.0f64, |m, v| m.max(v.abs()));
                    (xi - d, xi + d)
                }
                Param::Com(_) => (xi - 1.0, xi + 1.0),
                _ => (0.0, (10.0 * xi).max(1.0)),
            };
            lower.push(lo);
            upper.push(hi);
        }
        k += p.size();
    }
    (lower, upper)
}

fn values(
    what: &str,
    given: Option<Vec<f64>>,
    default: Vec<f64>,
    n: usize,
) -> Result<Vec<f64>, String> {
    match given {
        None => Ok(default),
        Some(v) if v.len() != n => Err(format!("{what} takes {n} values, got {}", v.len())),
        Some(v) => {
            if let Some(x) = v.iter().find(|x| x.is_nan()) {
                return Err(format!("{what} value {x} is not a number"));
            }
            Ok(v)
        }
    }
}

/// The transition blocks in a row's order, with their column prefix in a
/// named header (as `diffosi simulate` writes it).
const BLOCKS: [(&str, &str); 5] = [
    ("q", "q_"),
    ("v", "v_"),
    ("tau", "tau_"),
    ("q_next", "q_next_"),
    ("v_next", "v_next_"),
];

/// Reads one transition per row: q (nq), v (nv), tau (nv), q_next (nq),
/// v_next (nv), comma separated. A first non-blank row that is not numeric is
/// a header; blank lines are skipped. A header whose names carry the prefixes
/// `q_`, `v_`, `tau_`, `q_next_`, `v_next_` (simulate's CSV) selects those
/// columns, each block in the header's order, and other columns (`t`,
/// `fn_...`) are ignored.
pub fn read_transitions(path: &Path, nq: usize, nv: usize) -> Result<Vec<Transition>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let sizes = [nq, nv, nv, nq, nv];
    let width: usize = sizes.iter().sum();
    let layout = || format!("q: {nq}, v: {nv}, tau: {nv}, q_next: {nq}, v_next: {nv}");
    // The columns read, in transition order, with their labels; and the
    // number of cells a row must have.
    let mut columns: Vec<(usize, String)> = BLOCKS
        .iter()
        .zip(sizes)
        .flat_map(|((what, _), n)| (0..n).map(move |i| format!("{what}[{i}]")))
        .enumerate()
        .collect();
    let mut cells_per_row = width;
    let mut rows = vec![];
    let mut seen_data = false;
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        let at = format!("{} line {line_no}", path.display());
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let parsed: Vec<Result<f64, _>> = cells.iter().map(|c| c.parse::<f64>()).collect();
        if !seen_data && parsed.iter().all(|p| p.is_err()) {
            seen_data = true;
            if let Some(named) = named_columns(&cells, sizes).map_err(|e| format!("{at}: {e}"))? {
                (columns, cells_per_row) = (named, cells.len());
            }
            continue; // header
        }
        seen_data = true;
        if cells.len() != cells_per_row {
            return Err(if cells_per_row == width {
                format!(
                    "{at}: expected {width} values ({}), got {}",
                    layout(),
                    cells.len()
                )
            } else {
                format!(
                    "{at}: expected {cells_per_row} values (as the header), got {}",
                    cells.len()
                )
            });
        }
        let mut row = Vec::with_capacity(width);
        for (c, label) in &columns {
            let (cell, value) = (cells[*c], &parsed[*c]);
            let value = *value.as_ref().map_err(|_| {
                format!("{at}, column {} ({label}): '{cell}' is not a number", c + 1)
            })?;
            if !value.is_finite() {
                return Err(format!(
                    "{at}, column {} ({label}): value {value} is not finite",
                    c + 1
                ));
            }
            row.push(value);
        }
        let mut rest = row.as_slice();
        let mut take = |n: usize| {
            let (head, tail) = rest.split_at(n);
            rest = tail;
            head.to_vec()
        };
        rows.push(Transition {
            start: State::new(take(nq), take(nv)),
            tau: take(nv),
            next: State::new(take(nq), take(nv)),
        });
    }
    if rows.is_empty() {
        return Err(format!("{} holds no transitions", path.display()));
    }
    Ok(rows)
}

/// The columns of a named header in transition order (see
/// [`read_transitions`]), or None when no name carries a block's prefix.
/// Each block must have its size.
fn named_columns(
    header: &[&str],
    sizes: [usize; 5],
) -> Result<Option<Vec<(usize, String)>>, String> {
    // The longest matching prefix wins: q_next_x is q_next, not q.
    let block = |name: &str| {
        BLOCKS
            .iter()
            .enumerate()
            .filter(|(_, (_, prefix))| name.starts_with(prefix))
            .max_by_key(|(_, (_, prefix))| prefix.len())
            .map(|(k, _)| k)
    };
    if header.iter().all(|name| block(name).is_none()) {
        return Ok(None);
    }
    let mut columns = vec![];
    for (k, ((what, prefix), n)) in BLOCKS.iter().zip(sizes).enumerate() {
        let found: Vec<(usize, String)> = header
            .iter()
            .enumerate()
            .filter(|(_, name)| block(name) == Some(k))
            .map(|(c, name)| (c, name.to_string()))
            .collect();
        if found.len() != n {
            return Err(format!(
                "the header names {} {what} columns ({prefix}...), expected {n}",
                found.len()
            ));
        }
        columns.extend(found);
    }
    Ok(Some(columns))
}

fn method_name(m: Method) -> &'static str {
    match m {
        Method::Lm => "lm",
        Method::Adam => "adam",
        Method::Cmaes => "cmaes",
    }
}

/// The estimate as Python's `DiffOsi.identify` returns it (`params`: mu
/// flattened, `std`, `loss`, `iterations`, `evaluations`, `flags`: the names
/// of the flags set), plus what the command line adds: `names` (one label
/// per mu component), `method` and `transitions`.
fn to_json(
    labels: &[String],
    method: Method,
    transitions: usize,
    e: &Estimate,
) -> serde_json::Value {
    json!({
        "params": e.mu,
        "std": e.std,
        "loss": e.loss,
        "iterations": e.iterations,
        "evaluations": e.evaluations,
        "flags": e.flags.names(),
        "names": labels,
        "method": method_name(method),
        "transitions": transitions,
    })
}

fn print_text(labels: &[String], method: Method, transitions: usize, e: &Estimate) {
    println!(
        "{} on {transitions} transitions",
        method_name(method).to_uppercase()
    );
    let width = labels.iter().map(|l| l.len()).max().unwrap_or(0);
    for (i, label) in labels.iter().enumerate() {
        println!("{label:<width$} = {:.12} ± {:.3e}", e.mu[i], e.std[i]);
    }
    println!("loss {:.6e}", e.loss);
    println!("iterations {}, evaluations {}", e.iterations, e.evaluations);
    let flags = e.flags.names();
    println!(
        "flags: {}",
        if flags.is_empty() {
            "none".to_string()
        } else {
            flags.join(", ")
        }
    );
}
