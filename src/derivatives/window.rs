//! The identification loss over a window of transitions (the paper's eq. 1-3):
//! L(mu) = sum_t ||(g_mu(x_t, tau_t) - x_{t+1}) / scale||^2, with g_mu our step
//! under the parameters mu maps to; its stacked residuals, their Jacobian
//! (for Gauss-Newton) and the gradient.

use nalgebra::{DMatrix, DVector};

use super::step::{step_jacobians, Workspace, Wrt};
use crate::dynamics::StepError;
use crate::model::{Model, ParamError, ParamMap};

/// One observed transition (q, v) --tau--> (q_next, v_next).
#[derive(Clone, Debug, PartialEq)]
pub struct Transition {
    pub q: Vec<f64>,
    pub v: Vec<f64>,
    pub tau: Vec<f64>,
    pub q_next: Vec<f64>,
    pub v_next: Vec<f64>,
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WindowError {
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error("transition {t}: {source}")]
    Step { t: usize, source: StepError },
    #[error("transition {t}: {what} has length {got}, expected {expected}")]
    Length {
        t: usize,
        what: &'static str,
        got: usize,
        expected: usize,
    },
    #[error("transition {t}: {what} is not finite")]
    NotFinite { t: usize, what: &'static str },
    #[error("scale must hold 2 nv = {expected} positive values")]
    Scale { expected: usize },
}

/// Residuals r (2 nv per transition: q then v, divided by `scale`), their
/// Jacobian dr/dmu, the loss sum r^2 and its gradient 2 J^T r.
#[derive(Clone, Debug, PartialEq)]
pub struct WindowFit {
    pub residuals: DVector<f64>,
    pub jacobian: DMatrix<f64>,
    pub loss: f64,
    pub gradient: DVector<f64>,
}

/// Evaluates the window loss at mu. `model` is set to the parameters of mu.
pub fn window_residuals(
    model: &mut Model,
    ws: &mut Workspace,
    map: &ParamMap,
    mu: &[f64],
    window: &[Transition],
    scale: &[f64],
) -> Result<WindowFit, WindowError> {
    let n = model.nv();
    if scale.len() != 2 * n || scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(WindowError::Scale { expected: 2 * n });
    }
    map.apply(model, mu)?;
    let params = map.params();
    let wrt = Wrt {
        params: &params,
        ..Wrt::default()
    };
    let dp_dmu = map.jacobian();
    let mut residuals = DVector::zeros(2 * n * window.len());
    let mut jacobian = DMatrix::zeros(2 * n * window.len(), map.nmu);
    for (t, tr) in window.iter().enumerate() {
        check_transition(t, tr, n)?;
        let j = step_jacobians(model, ws, (&tr.q, &tr.v, &tr.tau), &wrt)
            .map_err(|source| WindowError::Step { t, source })?;
        let rows = 2 * n * t;
        let predicted = j.q_next.iter().chain(&j.v_next);
        let observed = tr.q_next.iter().chain(&tr.v_next);
        for (i, (p, o)) in predicted.zip(observed).enumerate() {
            residuals[rows + i] = (p - o) / scale[i];
        }
        let mut block = jacobian.rows_mut(rows, 2 * n);
        block.rows_mut(0, n).copy_from(&(&j.dq_dp * &dp_dmu));
        block.rows_mut(n, n).copy_from(&(&j.dv_dp * &dp_dmu));
        for (i, s) in scale.iter().enumerate() {
            block.row_mut(i).unscale_mut(*s);
        }
    }
    let gradient = jacobian.tr_mul(&residuals) * 2.0;
    Ok(WindowFit {
        loss: residuals.norm_squared(),
        residuals,
        jacobian,
        gradient,
    })
}

fn check_transition(t: usize, tr: &Transition, n: usize) -> Result<(), WindowError> {
    let fields = [
        ("q", &tr.q),
        ("v", &tr.v),
        ("tau", &tr.tau),
        ("q_next", &tr.q_next),
        ("v_next", &tr.v_next),
    ];
    for (what, x) in fields {
        if x.len() != n {
            return Err(WindowError::Length {
                t,
                what,
                got: x.len(),
                expected: n,
            });
        }
        if x.iter().any(|xi| !xi.is_finite()) {
            return Err(WindowError::NotFinite { t, what });
        }
    }
    Ok(())
}
