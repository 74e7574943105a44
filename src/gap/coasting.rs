//! A coasting ride's bias under a candidate. In: the rides whose speed changed over their
//! window (each with the window the ride stage replayed,
//! [`crate::ride::dynamic::CoastingWindow`]), each condition's measured bicycle, and a damped
//! candidate or one that moves the rides' speeds, at its first fit. Out: per ride, what the
//! candidate adds to its prediction so that it is compared with the fit as the ride stage
//! corrected it ([`CoastingBase::shifts`]). Also in: the size of each ride's correction's
//! error as the ride stage counted it; out: what that error adds to the campaign's
//! experimental covariance (`correction_cov`).
//!
//! The ride stage corrects a coasting ride's mode shape by a replay of the measured, undamped
//! bicycle and carries the replay's eigenvalue as an error
//! ([`crate::ride::dynamic::COASTING_BIAS_ERROR_SCALE`]). A damped bicycle's bias is another,
//! and it sits in the fit's real modes, which a replay from the weave alone does not show. So
//! the replays here start where the ride's fit says the motion began
//! ([`ReplayStart::Fitted`]), and a damped candidate's prediction carries its own replay less
//! the measured bicycle's, in the eigenvalue and the mode shape. The rides and campaigns that
//! showed it: [docs/decisions/constants.md](../../docs/decisions/constants.md#gapcoasting-a-damped-candidates-replay).
//!
//! Each change also carries what the ride's acceleration does to the candidate's own mode
//! shape ([`accel_shape_shift`]), as the ride stage's correction carries the measured
//! bicycle's.
//!
//! The replay (an RK4 run and a modal fit, about a millisecond) is too slow for every step of
//! a fit: it is made where the candidate's first fit puts the bicycle
//! ([`super::fit::Campaign::at_fit`]) and held while the candidate is fitted again. The
//! targeted test and its calibration, at "no effect", do not see it. Near the weave speed a
//! replay's fit is fragile (on data/rides.toml, a ride at 3.3 m/s moved |γ/θ| by 0.24, 4.6
//! of its errors, under damping with tyres): each shift carries an error of
//! [`crate::ride::dynamic::COASTING_BIAS_SE_FRACTION`] of itself, as the ride stage's
//! correction does.
//!
//! Only candidates with damping, whose bias this is, carry a replay of their own bicycle: the
//! secants of the other effects in an earlier version were erratic near the weave speed (−3.2
//! to +4.7 1/s per unit of a speedometer's scale). A speedometer's scale or a clock alone,
//! which moves the speed a ride applies at, carries the ride stage's own correction moved to
//! that speed: the ride stage made it at the reported speed, which such a candidate says was
//! not the ride's.

use super::conditions::ConditionModel;
use super::effects::{any_change, linear_bike, true_speed, Change, Effect};
use super::linear::LinearBike;
use super::observe::Observation;
use crate::ride::dynamic::{
    accel_shape_shift, coasting_correction, replay_coasting, CoastingWindow, ReplayStart,
    COASTING_SHAPE_APPLIED,
};
use rayon::prelude::*;

/// The part of a replay's change taken into a candidate's prediction: `[re, im, |γ/θ|, arg]`
/// (the eigenvalue's whole, the shape's as the ride stage takes it).
const APPLIED: [f64; 4] = [1.0, 1.0, COASTING_SHAPE_APPLIED, COASTING_SHAPE_APPLIED];

/// What a coasting ride's window does to `bike`'s weave as the ride would report it: its
/// replay from the fit's start ([`ReplayStart::Fitted`], the part [`APPLIED`]) and the slowing
/// bicycle's own change ([`accel_shape_shift`], on the bicycle with rigid wheels: the compliant
/// tyres' model has no v̇ terms). `None` where the replay fails.
fn fitted_change(bike: &LinearBike, window: &CoastingWindow) -> Option<[f64; 4]> {
    let replay = replay_coasting(bike, window, ReplayStart::Fitted)?;
    let rigid = LinearBike {
        tyres: None,
        ..*bike
    };
    let shift = accel_shape_shift(&rigid, window).unwrap_or([0.0; 4]);
    Some(std::array::from_fn(|a| APPLIED[a] * replay[a] + shift[a]))
}

/// Each coasting ride's change on its condition's measured bicycle (`fitted_change`; `None`
/// for a ride at constant speed, or where the replay fails): the base a candidate's is
/// compared with.
#[derive(Debug, Clone, Default)]
pub struct CoastingBase {
    rides: Vec<Option<[f64; 4]>>,
}

impl CoastingBase {
    /// The replays of `obs` (ride `i` in condition `ride_condition[i]` of `conditions`), in
    /// parallel.
    pub fn new(
        obs: &[Observation],
        conditions: &[ConditionModel],
        ride_condition: &[usize],
    ) -> CoastingBase {
        let rides = obs
            .par_iter()
            .enumerate()
            .map(|(i, o)| {
                let c = &conditions[ride_condition[i]];
                fitted_change(&linear_bike(&c.base, &c.control, &[], &[]), &o.coasting?)
            })
            .collect();
        CoastingBase { rides }
    }

    /// Whether a candidate of `effects` has its coasting change in its prediction: damping
    /// (its own bias), and the effects that move the speed a ride applies at (where the ride
    /// stage made its correction).
    pub fn applies_to(effects: &[Effect]) -> bool {
        Self::damped(effects) || Self::moves_speed(effects)
    }

    /// Whether `effects` is a speedometer's scale or a clock alone: the candidates whose
    /// replays are taken at the speed they say the rides had. A pair keeps the ride stage's
    /// correction at the reported speed: every replay costs about a millisecond per ride and
    /// candidate, and with the pairs too `bikeproc gap data/rides.toml` took 0.79 s against
    /// 0.70 (divan `gap_campaign_16_rides`, its bar 0.74 s).
    fn moves_speed(effects: &[Effect]) -> bool {
        matches!(effects, [e] if matches!(e.change(), Change::Speedometer | Change::Clock))
    }

    /// Whether `effects` damp the steer: the candidates that carry their own replay.
    fn damped(effects: &[Effect]) -> bool {
        any_change(effects, |c| matches!(c, Change::SteerDamping))
    }

    /// What `effects` at `params` add to each ride's prediction (`params_of(c)`, condition
    /// `c`'s own values in the effects' order): `[re, im]` (1/s), `[|γ/θ|, arg γ/θ]`; zeros on
    /// a ride at constant speed, where a replay fails, and for a candidate of neither kind.
    ///
    /// - Damping: the candidate's own replay less the measured bicycle's, both from the fit's
    ///   start.
    /// - A speedometer's scale or a clock moves the speed a ride applies at ([`true_speed`]):
    ///   the ride stage took its correction off at the reported speed, so the prediction carries
    ///   that correction's change (the ride stage's own replay, [`ReplayStart::Weave`]) to the
    ///   candidate's speed; without it a scale fitted low by about its own error.
    ///
    /// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#coastingbaseshifts).
    pub fn shifts(
        &self,
        obs: &[Observation],
        conditions: &[ConditionModel],
        ride_condition: &[usize],
        effects: &[Effect],
        params_of: &(dyn Fn(usize) -> Vec<f64> + Sync),
    ) -> Vec<[f64; 4]> {
        if !Self::applies_to(effects) || self.rides.iter().all(Option::is_none) {
            return vec![[0.0; 4]; obs.len()];
        }
        let damped = Self::damped(effects);
        let moves_speed = Self::moves_speed(effects);
        obs.par_iter()
            .enumerate()
            .map(|(i, o)| {
                let (Some(base), Some(window)) = (self.rides.get(i).copied().flatten(), o.coasting)
                else {
                    return [0.0; 4];
                };
                let c = ride_condition[i];
                let cond = &conditions[c];
                let params = params_of(c);
                let mut d = [0.0; 4];
                if damped {
                    let own = linear_bike(&cond.base, &cond.control, effects, &params);
                    if let Some(own) = fitted_change(&own, &window) {
                        d = std::array::from_fn(|a| own[a] - base[a]);
                    }
                }
                // What the ride stage took off (`coasting_bias`: its replay at the reported
                // speed, on the model the gap stage's replays use, bit for bit), against what
                // it would have taken off at the speed the candidate says the ride had.
                let v = true_speed(effects, &params, o);
                let reported = o.speed_mps;
                if moves_speed && v.is_finite() && (v - reported).abs() > 1e-9 * reported {
                    let measured = linear_bike(&cond.base, &cond.control, &[], &[]);
                    let at_speed = CoastingWindow {
                        speed_mps: v,
                        ..window
                    };
                    if let Some(there) = coasting_correction(&measured, &at_speed) {
                        let took = there.taken_off.iter().zip(&o.coasting_bias);
                        for (d, (there, here)) in d.iter_mut().zip(took) {
                            *d += there - here;
                        }
                    }
                }
                d.map(|x| if x.is_finite() { x } else { 0.0 })
            })
            .collect()
    }
}

/// What the coasting corrections' error (`corrections`, each ride's `[re, im, |γ/θ|, arg]`
/// error scale, [`crate::ride::dynamic::CoastingCorrection::error_scale`]) adds to the
/// campaign's experimental covariance beyond the ride's own standard errors, which hold
/// [`COASTING_RIDE_SE_FRACTION`] of it (replaced here): that error is mostly one
/// for the whole campaign (the tyres and damping the rides share set it), so each ride's is
/// made common, [`COASTING_BIAS_COMMON_FRACTION`] of its correction, and a part
/// [`COASTING_BIAS_OWN_FRACTION`] is kept as the ride's own (erratic near the weave speed).
/// Without the common part, 14 coasting rides of an effect-free campaign gave σ and ω a
/// shared residual of +0.3 and +0.5 of their standard errors, which the effects' fits took up.
///
/// [`COASTING_RIDE_SE_FRACTION`]: crate::ride::dynamic::COASTING_RIDE_SE_FRACTION
/// [`COASTING_BIAS_COMMON_FRACTION`]: crate::ride::dynamic::COASTING_BIAS_COMMON_FRACTION
/// [`COASTING_BIAS_OWN_FRACTION`]: crate::ride::dynamic::COASTING_BIAS_OWN_FRACTION
pub(super) fn correction_cov(
    corrections: &[[f64; 4]],
    parts: &super::observe::Parts,
) -> nalgebra::DMatrix<f64> {
    use crate::ride::dynamic::{
        COASTING_BIAS_OWN_FRACTION as OWN, COASTING_RIDE_SE_FRACTION as HELD,
    };
    let common = correction_common(corrections, parts);
    let mut cov = &common * common.transpose();
    for (i, bi) in corrections.iter().enumerate() {
        for (a, b) in bi.iter().enumerate().take(parts.of(i)) {
            cov[(parts.start(i) + a, parts.start(i) + a)] += (OWN * OWN - HELD[a].powi(2)) * b * b;
        }
    }
    cov
}

/// The common part of [`correction_cov`] as one column, `C b` over every ride's parts
/// (`C` = [`COASTING_BIAS_COMMON_FRACTION`]): the covariance holds its outer product, and the
/// low-rank inverse of the campaign's takes it as one of its common directions.
///
/// [`COASTING_BIAS_COMMON_FRACTION`]: crate::ride::dynamic::COASTING_BIAS_COMMON_FRACTION
pub(super) fn correction_common(
    corrections: &[[f64; 4]],
    parts: &super::observe::Parts,
) -> nalgebra::DVector<f64> {
    use crate::ride::dynamic::COASTING_BIAS_COMMON_FRACTION as COMMON;
    let mut w = nalgebra::DVector::zeros(parts.total());
    for (i, bi) in corrections.iter().enumerate() {
        for (a, b) in bi.iter().enumerate().take(parts.of(i)) {
            w[parts.start(i) + a] = COMMON * b;
        }
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::observe::Parts;

    /// Two coasting rides (one with the mode shape, one without) and one at constant speed:
    /// the common part couples every pair of parts by 0.7² bᵢ bⱼ, and each part's own variance
    /// gains (0.7² + 0.3² − h²) b², the fraction h its standard error already holds replaced
    /// (1 in the eigenvalue, 0.5 in the shape).
    #[test]
    fn a_coasting_correction_is_mostly_common_and_partly_its_rides_own() {
        let parts = Parts::new(vec![4, 2, 4]);
        let b = [[0.02, -0.05, 0.01, 0.03], [0.04, 0.01, 9.0, 9.0], [0.0; 4]];
        let cov = correction_cov(&b, &parts);
        assert_eq!(cov.shape(), (10, 10));
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-15;
        // Ride 0's σ with ride 1's ω, and ride 0's phase with its own |γ/θ|.
        assert!(close(cov[(0, 5)], 0.49 * 0.02 * 0.01));
        assert!(close(cov[(3, 2)], 0.49 * 0.03 * 0.01));
        // Diagonals: (0.49 + 0.09 − 1) b² in the eigenvalue, (0.49 + 0.09 − 0.25) b² in the
        // shape.
        assert!(close(cov[(1, 1)], -0.42 * 0.05 * 0.05));
        assert!(close(cov[(4, 4)], -0.42 * 0.04 * 0.04));
        assert!(close(cov[(2, 2)], 0.33 * 0.01 * 0.01));
        assert!(close(cov[(3, 3)], 0.33 * 0.03 * 0.03));
        // The ride at constant speed is untouched; ride 1's missing shape parts unused.
        assert!((6..10).all(|k| (0..10).all(|l| cov[(k, l)] == 0.0 && cov[(l, k)] == 0.0)));
        assert!((&cov - cov.transpose()).amax() <= 1e-18);
    }
}
