//! A coasting ride's bias under each candidate. In: the rides whose speed changed over their
//! window (each with the window the ride stage replayed, [`crate::ride::dynamic::CoastingWindow`],
//! and the correction it took off), each condition's measured bicycle. Out: per ride, what a
//! candidate at its parameters adds to the prediction so that it is compared with the fit as
//! the ride stage corrected it ([`CoastingResponse::shift`]).
//!
//! The ride stage takes off a part of the bias that the measured bicycle's replay gives (half
//! of the eigenvalue's, [`crate::ride::dynamic::COASTING_BIAS_APPLIED`]; the whole mode
//! shape's, [`crate::ride::dynamic::COASTING_SHAPE_APPLIED`]). On 200 coasting rides of a
//! knife-edge bicycle that leaves σ and ω unbiased (mean normalized errors +0.03 and +0.05
//! against the true bicycle's linear weave). But the bias depends on the bicycle: with steer
//! damping of 0.3 and 0.6 N·m·s/rad the same correction left σ at −0.36 and −0.71 (the
//! damped bicycle's bias is another), and on 50 noted campaigns steer damping came out at a
//! median 1.37 of its standard errors high. Here a candidate with damping has the change of
//! its bias added to its prediction, taken at the ride stage's fractions: with its own
//! bicycle's replay the same rides' σ lay at −0.26 and −0.39. The replay (an RK4 run and a
//! modal fit, milliseconds) is too slow for every step of every fit, so the change is linear
//! in the damping, a secant from none to [`DAMPING_SECANT_NMS_PER_RAD`], made once per ride.
//!
//! Only the damping, whose bias has the other sign: the secants of the other effects
//! (inertias, masses, trail, the speedometer) were erratic on rides near the weave speed, where
//! the replay's fit changes its structure (−3.2 to +4.7 1/s per unit of a speedometer's
//! scale), and with them (and the whole bias put back) 14 of 100 effect-free noted campaigns
//! came out significant at 1 %, 2 without. With the damping's alone, 3 of the same 100 (the
//! third a campaign whose bicycle's measurement errors moved every ride's σ and ω alike,
//! taken up by 0.058 N·m·s/rad; p 0.05 before).

use super::conditions::ConditionModel;
use super::effects::{linear_bike, Effect};
use super::Observation;
use crate::ride::dynamic::{replay_coasting, COASTING_BIAS_APPLIED, COASTING_SHAPE_APPLIED};
use rayon::prelude::*;

/// The damping at the secant's far point (N·m·s/rad): half the plausible range's edge.
pub const DAMPING_SECANT_NMS_PER_RAD: f64 = 0.5;

/// The fractions of the replayed bias the ride stage takes off: `[re, im, |γ/θ|, arg γ/θ]`.
const APPLIED: [f64; 4] = [
    COASTING_BIAS_APPLIED,
    COASTING_BIAS_APPLIED,
    COASTING_SHAPE_APPLIED,
    COASTING_SHAPE_APPLIED,
];

/// One coasting ride's correction's change per N·m·s/rad of steer damping, at the ride
/// stage's fractions.
#[derive(Debug, Clone)]
struct RideResponse {
    per_damping: [f64; 4],
}

/// Every ride's response (`None` for a ride at constant speed, or where the replay fails).
#[derive(Debug, Clone, Default)]
pub struct CoastingResponse {
    rides: Vec<Option<RideResponse>>,
}

impl CoastingResponse {
    /// The responses of `obs` (each ride in condition `ride_condition[i]` of `conditions`):
    /// two replays per coasting ride, in parallel.
    pub fn new(
        obs: &[Observation],
        conditions: &[ConditionModel],
        ride_condition: &[usize],
    ) -> CoastingResponse {
        let rides = obs
            .par_iter()
            .enumerate()
            .map(|(i, o)| {
                let window = o.coasting?;
                let c = &conditions[ride_condition[i]];
                let replay = |effects: &[Effect], params: &[f64]| {
                    replay_coasting(&linear_bike(&c.base, &c.control, effects, params), &window)
                };
                let none = replay(&[], &[])?;
                let damped = replay(&[Effect::SteerDamping], &[DAMPING_SECANT_NMS_PER_RAD])?;
                Some(RideResponse {
                    per_damping: std::array::from_fn(|a| {
                        APPLIED[a] * (damped[a] - none[a]) / DAMPING_SECANT_NMS_PER_RAD
                    }),
                })
            })
            .collect();
        CoastingResponse { rides }
    }

    fn ride(&self, i: usize) -> Option<&RideResponse> {
        self.rides.get(i).and_then(|r| r.as_ref())
    }

    /// What `effects` at `params` (the condition's own values, in the effects' order) add to
    /// ride `i`'s prediction: `[re, im]` (1/s), `[|γ/θ|, arg γ/θ]`; zeros on a ride at
    /// constant speed.
    pub fn shift(&self, i: usize, effects: &[Effect], params: &[f64]) -> [f64; 4] {
        let Some(r) = self.ride(i) else {
            return [0.0; 4];
        };
        let mut out = [0.0; 4];
        let mut at = 0;
        for &e in effects {
            if e == Effect::SteerDamping {
                if let Some(&c) = params.get(at) {
                    for (o, s) in out.iter_mut().zip(&r.per_damping) {
                        *o += s * c;
                    }
                }
            }
            at += e.params().len();
        }
        out
    }
}
