//! The experiment's covariance of a campaign's residuals. In: the rides' observations (their
//! fits' errors, speeds, windows, coasting corrections, motion sizes), each ride's condition and
//! residual parts, the unextended model per condition, the scatter between repeated kicks. Out:
//! the covariance of experiment − model from the experiment's side (the model's parameter
//! error is added by the caller) and its common columns W (the rest is block-diagonal over
//! the rides): a ride's fit error and the scatter between kicks, its speed's error through
//! the model's slope, the shape's drift over the window, the coasting corrections' shared
//! error and the motion size's shared part.

use super::coasting;
use super::linear::LinearBike;
use super::observe::{Observation, Parts};
use super::thresholds::{NONLINEAR_COMMON_FACTOR, SHAPE_PHASE_FLOOR_RAD, SHAPE_RATIO_FLOOR};
use nalgebra::{Complex, DMatrix, DVector};

/// A ride's fit errors `[re, im, |γ/θ|, arg]`, the shape's with its floors.
pub fn fit_se(o: &Observation) -> [f64; 4] {
    [
        o.re_se,
        o.im_se,
        o.shape_ratio
            .se
            .hypot(SHAPE_RATIO_FLOOR * o.shape_ratio.value),
        o.shape_phase_rad.se.hypot(SHAPE_PHASE_FLOOR_RAD),
    ]
}

/// The experiment's covariance and its common columns W (W Wᵀ is part of it), in the order
/// of `parts`: `rides` with their conditions `ride_condition`, `unextended[c]` condition c's
/// model, `guesses` and `model_shapes` each ride's model weave and shape, `scatter` the
/// scatter between kicks per part.
pub fn covariance(
    rides: &[Observation],
    ride_condition: &[usize],
    parts: &Parts,
    unextended: &[LinearBike],
    guesses: &[Complex<f64>],
    model_shapes: &[Complex<f64>],
    scatter: &[f64],
) -> (DMatrix<f64>, DMatrix<f64>) {
    let total = parts.total();
    let mut exp_cov = DMatrix::zeros(total, total);
    for (i, o) in rides.iter().enumerate() {
        let standard_errors = fit_se(o);
        let (start, p) = (parts.start(i), parts.of(i));
        for a in 0..p {
            exp_cov[(start + a, start + a)] = standard_errors[a].powi(2) + scatter[a].powi(2);
        }
        // The model's weave and shape per m/s of speed at the ride's.
        let h = 1e-4;
        let unextended = &unextended[ride_condition[i]];
        let at = |v: f64| -> Option<[f64; 4]> {
            let (w, s) = unextended.weave_and_shape(v, guesses[i], true)?;
            let s = s?;
            Some([
                w.re,
                w.im,
                s.norm(),
                crate::signal::wrap_near(s.arg(), model_shapes[i].arg()),
            ])
        };
        let per_mps: [f64; 4] = match (at(o.speed_mps + h), at(o.speed_mps - h)) {
            (Some(a), Some(b)) => std::array::from_fn(|k| (a[k] - b[k]) / (2.0 * h)),
            _ => [0.0; 4],
        };
        // The shape drifts as the bicycle slows over the window (the fit holds it constant):
        // the model's change over half the window's slowing (as the eigenvalue's drift when its
        // own fit fails). Near the weave speed the shape changes fast with speed: without this,
        // rides there made effect-free campaigns "significant". Before a coasting ride's shape
        // was corrected for the slowing (`ride::dynamic::COASTING_SHAPE_APPLIED`) it took the
        // whole window's change to keep 200 effect-free noted campaigns' χ² from rejecting;
        // with the correction that made the χ² test conservative (a third of them in its last
        // p bin, none below 0.05 of the targeted test's), and half the window gives it back its
        // uniform histogram (0.5 % below 0.01, docs/gap-calibration.md).
        let window_change_mps = 0.5 * o.window_accel_mps2.abs() * o.window_s.max(0.0);
        for a in 2..p {
            exp_cov[(start + a, start + a)] += (per_mps[a] * window_change_mps).powi(2);
        }
        if o.speed_se_mps > 0.0 {
            let g = per_mps.map(|d| d * o.speed_se_mps);
            for a in 0..p {
                for b in 0..p {
                    exp_cov[(start + a, start + b)] += g[a] * g[b];
                }
            }
        }
    }
    let corrections: Vec<[f64; 4]> = rides.iter().map(|o| o.coasting_error_scale).collect();
    exp_cov += coasting::correction_cov(&corrections, parts);
    // The motion's size: each ride's fit differs from the small motion's by κ times its
    // size, κ one per condition and part.
    let n_conditions = ride_condition.iter().copied().max().map_or(1, |m| m + 1);
    let nonlinear: Vec<DVector<f64>> = (0..n_conditions)
        .flat_map(|c| (0..4).map(move |a| (c, a)))
        .map(|(c, a)| {
            let mut w = DVector::zeros(total);
            for (i, o) in rides.iter().enumerate() {
                if parts.of(i) > a && ride_condition[i] == c {
                    let se =
                        crate::ride::dynamic::nonlinear_se(o.motion_sq_rad2, o.shape_ratio.value);
                    w[parts.start(i) + a] = NONLINEAR_COMMON_FACTOR * se[a];
                }
            }
            w
        })
        .collect();
    for w in &nonlinear {
        exp_cov += w * w.transpose();
    }
    // Those common parts, W Wᵀ (the rest of exp_cov is block-diagonal over the rides).
    let exp_common = {
        let mut w = DMatrix::zeros(total, 1 + nonlinear.len());
        w.set_column(0, &coasting::correction_common(&corrections, parts));
        for (k, n) in nonlinear.iter().enumerate() {
            w.set_column(k + 1, n);
        }
        w
    };
    (exp_cov, exp_common)
}
