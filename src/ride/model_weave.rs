//! The model beside a measured weave: of the model's oscillatory modes at a ride's speed (the
//! weave, and on a controlled bicycle at low speed the capsize–castor pair), the one nearest
//! the measured eigenvalue in the combined standard errors, with its own errors and mode shape.
//!
//! In: the parametrized model, the ride's speed with its error, the measured eigenvalue. Out:
//! [`ModelWeave`]. Shared by every instrument's ride (an IMU log's [`super::dynamic`], a CSV's
//! [`super::csv`]) and the reports.

use super::modal::Eigenvalue;
use super::read::RideError;
use crate::model::uncertain::Parametrized;
use nalgebra::Complex;
use std::path::Path;

/// The model's weave at the ride's speed, and how far the experiment is from it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ModelWeave {
    pub re: f64,
    pub im: f64,
    /// Standard errors from the measured parameters' uncertainty and the speed's.
    pub re_se: f64,
    pub im_se: f64,
    /// (experiment − model) / combined standard error, real and imaginary parts.
    pub re_z: f64,
    pub im_z: f64,
    /// The model's mode shape: |γ/θ| and arg(γ/θ) (rad).
    pub shape_ratio: f64,
    pub shape_phase_rad: f64,
    /// Which of the model's oscillatory modes this is: `weave`, or `capsize_castor` where the
    /// capsize and castor roots have met in a second oscillatory pair (a controlled bicycle at
    /// low speed) and the measurement lies nearer that one.
    pub mode: ModelMode,
    /// Another oscillatory mode of the model at that speed as near the measurement, in the
    /// combined errors (within [`COMPARABLE_MODE_CHI2`]), `[re, im]` (1/s); `None` when one
    /// mode is clearly the nearer.
    pub comparable: Option<[f64; 2]>,
}

/// The model's oscillatory mode a measured one is set beside.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelMode {
    Weave,
    CapsizeCastor,
}

/// Two of the model's oscillatory modes are equally near a measured eigenvalue when their
/// squared distances in the combined errors (2 degrees of freedom) differ by less than this:
/// a likelihood ratio of e², the 2-SE rule of thumb in one dimension.
pub const COMPARABLE_MODE_CHI2: f64 = 4.0;

impl ModelMode {
    /// Its name in the text reports.
    pub fn label(self) -> &'static str {
        match self {
            ModelMode::Weave => "weave",
            ModelMode::CapsizeCastor => "capsize–castor pair",
        }
    }
}

impl ModelWeave {
    /// A line saying that another oscillatory mode of the model is as near, when one is.
    pub fn comparable_text(&self) -> Option<String> {
        self.comparable.map(|[re, im]| {
            format!(
                "(the model's other oscillatory mode, {re:.3} {im:+.3}i 1/s, is about as near: \
                 which the kick excited cannot be told from the eigenvalue alone)"
            )
        })
    }
}

/// The model's oscillatory mode at `v` ± `v_se` (m/s) beside the experimental eigenvalue
/// `exp`: of the model's eigenvalues with a positive imaginary part there (the weave, and on a
/// controlled bicycle at low speed the pair the capsize and castor roots form), the one nearest
/// the measurement in the combined standard errors (the model's from the measured parameters
/// and the speed's through dλ/dv, the experiment's). Its standard errors, the differences in
/// them, its mode shape, and any other oscillatory mode as near ([`COMPARABLE_MODE_CHI2`]).
/// `path` names the ride when the model has no oscillatory mode there.
///
/// Below about 2.5 m/s a controlled bicycle has two oscillatory pairs; the one named "weave"
/// by continuity from high speed is not always the one a kick excites (the balance-assist
/// bicycle at 1.5 m/s: the slow pair −1.33 + 2.31i beside a measured −3.44 + 5.45i).
pub fn model_weave_at(
    path: &Path,
    model: &Parametrized,
    v: f64,
    v_se: f64,
    exp: &Eigenvalue,
) -> Result<ModelWeave, RideError> {
    let no_weave = || RideError::Ride {
        path: path.to_path_buf(),
        message: format!("the model has no weave (oscillatory mode) at {v:.3} m/s to compare with"),
    };
    let h = 0.01;
    let bands = model.bands(&[v - h, v, v + h]).map_err(|_| no_weave())?;
    let at = |k: usize, j: usize| bands.sweep.eigenvalues[k][j];
    // Each oscillatory mode: its eigenvalue, standard errors, and squared distance from the
    // measurement in the combined errors.
    let candidates: Vec<(usize, Complex<f64>, f64, f64, f64)> = (0..4)
        .filter(|&j| at(1, j).im > 0.0 && at(1, j).re.is_finite())
        .map(|j| {
            let lambda = at(1, j);
            let dv = (at(2, j) - at(0, j)) / (2.0 * h);
            let (pre, pim) = bands.se[1][j];
            let re_se = (pre.powi(2) + (dv.re * v_se).powi(2)).sqrt();
            let im_se = (pim.powi(2) + (dv.im * v_se).powi(2)).sqrt();
            let d2 = (exp.re - lambda.re).powi(2) / (exp.re_se.powi(2) + re_se.powi(2))
                + (exp.im - lambda.im).powi(2) / (exp.im_se.powi(2) + im_se.powi(2));
            (
                j,
                lambda,
                re_se,
                im_se,
                if d2.is_nan() { f64::INFINITY } else { d2 },
            )
        })
        .collect();
    let &(j, lambda, re_se, im_se, d2) = candidates
        .iter()
        .min_by(|a, b| a.4.total_cmp(&b.4))
        .ok_or_else(no_weave)?;
    let comparable = candidates
        .iter()
        .filter(|c| c.0 != j && c.4 - d2 < COMPARABLE_MODE_CHI2)
        .min_by(|a, b| a.4.total_cmp(&b.4))
        .map(|c| [c.1.re, c.1.im]);
    let shape = model
        .nominal_canonical()
        .mode_shape(v, lambda)
        .map(|x| x[1] / x[0])
        .unwrap_or(Complex::new(f64::NAN, f64::NAN));
    Ok(ModelWeave {
        re: lambda.re,
        im: lambda.im,
        re_se,
        im_se,
        re_z: (exp.re - lambda.re) / (exp.re_se.powi(2) + re_se.powi(2)).sqrt(),
        im_z: (exp.im - lambda.im) / (exp.im_se.powi(2) + im_se.powi(2)).sqrt(),
        shape_ratio: shape.norm(),
        shape_phase_rad: shape.arg(),
        // One oscillatory pair: named as the bands name it (the complex pair beside two real
        // roots is the weave); two: the weave's branch followed down from high speed.
        mode: match (candidates.len(), bands.sweep.modes[j]) {
            (1, crate::model::Mode::Weave | crate::model::Mode::WeaveConjugate) => ModelMode::Weave,
            (1, _) => ModelMode::CapsizeCastor,
            _ if is_weave_branch(model, v, lambda) => ModelMode::Weave,
            _ => ModelMode::CapsizeCastor,
        },
        comparable,
    })
}

/// Whether `lambda`, an oscillatory eigenvalue of the model at `v`, lies on the weave's branch:
/// named at high speed (10 m/s, or above `v`) and followed down to `v` by continuity in steps
/// of 0.02 m/s, as `bikeproc stability` names it. Named at `v` alone, two oscillatory pairs
/// would be told apart by their real parts, which put the balance-assist bicycle's slow
/// capsize–castor pair in the weave's place at 0.8 m/s.
fn is_weave_branch(model: &Parametrized, v: f64, lambda: Complex<f64>) -> bool {
    let top = v.max(10.0);
    let steps = ((top - v) / 0.02).ceil().max(1.0) as usize;
    let speeds: Vec<f64> = (0..=steps)
        .map(|k| v + (top - v) * k as f64 / steps as f64)
        .collect();
    match model.nominal_canonical().sweep(&speeds) {
        Ok(sweep) => {
            let w = sweep.eigenvalues[0][0];
            (w - lambda).norm() <= 1e-9 * (1.0 + lambda.norm())
        }
        Err(_) => true,
    }
}
