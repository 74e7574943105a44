//! What the gap stage gives: a campaign's (or a study's) [`Diagnosis`], each field filled by one
//! of the stage's files in the order [`super::diagnose`] runs them.

use super::observe::{BandResidual, BetweenKickScatter, RideResidual};
use super::rank::Ranked;
use super::significance::{DetectionLimit, TargetedTest};
use super::ties::{NextCondition, NextRides};

/// The diagnosis of a campaign.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Diagnosis {
    /// `false` when the campaign cannot support a conclusion (then `reason` says why and
    /// nothing is ranked).
    pub conclusive: bool,
    pub reason: Option<String>,
    pub rides_used: usize,
    /// Rides left out, with why.
    pub rides_failed: Vec<String>,
    /// In a study of several conditions: each condition (empty for a single campaign).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub conditions: Vec<ConditionSummary>,
    /// Repeated kicks of one set-up (a condition's rides at one set speed) that scatter beyond
    /// their fits' errors: the scatter between kicks, carried in every ride's covariance.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub between_kick_scatter: Option<BetweenKickScatter>,
    pub residuals: Vec<RideResidual>,
    /// The same with the best explanation in the model (fitted to every ride).
    pub residuals_after: Vec<RideResidual>,
    pub bands: Vec<BandResidual>,
    /// The campaign's χ² against the unextended model with the full covariance, its degrees of
    /// freedom and p-value; the same without the model's parameter error.
    pub chi2: f64,
    pub dof: usize,
    pub p_value: f64,
    pub chi2_without_parameter_error: f64,
    pub p_value_without_parameter_error: f64,
    /// The parts of each ride in the residuals and the fits: 4 (the eigenvalue's real and
    /// imaginary parts, the mode shape's |γ/θ| and phase) or 2 (the eigenvalue only, when
    /// the shape is left out or the model has none at some ride).
    pub parts_per_ride: usize,
    /// The targeted test: the single effect of the library that lowers the campaign's χ² the
    /// most, its likelihood ratio and p-value over all the single effects tried.
    pub targeted: Option<TargetedTest>,
    /// The campaign's test: the smallest of the χ² test's p and the single effects' (either
    /// may find the gap), calibrated on draws of the residuals with no effect present
    /// (`significance::NullTest`); significant below [`super::SIGNIFICANCE`].
    pub campaign_p_value: f64,
    /// The variance of θ and γ over the rides' windows that the eigenvalues account for (mean
    /// over rides and the two signals; modes' amplitudes, offsets and trends fitted, eigenvalues
    /// held): the model as it is, and with the best explanation refitted without each ride.
    pub heldout_vaf_before: Option<f64>,
    pub heldout_vaf_after: Option<f64>,
    /// `campaign_p_value` < [`SIGNIFICANCE`](super::SIGNIFICANCE).
    pub significant: bool,
    /// The gap is significant without the parameters' uncertainty but not with it.
    pub parameters_could_explain: bool,
    /// Best first.
    pub ranking: Vec<Ranked>,
    /// Candidates the held-out test cannot tell from the best (the best included), when more
    /// than one.
    pub tied: Vec<String>,
    /// The best candidate explains the gap: its held-out RMS normalized residual is at most
    /// [`EXPLAINED_HELDOUT_RMS`](super::EXPLAINED_HELDOUT_RMS) and smaller than without it, and its fit to every ride passes
    /// the χ² test at [`SIGNIFICANCE`](super::SIGNIFICANCE). `false` when the gap is not significant.
    pub explained: bool,
    /// The best candidate's goodness of fit: p of its χ² on 2N − k degrees of freedom.
    pub best_fit_p_value: f64,
    /// When candidates are tied: the rides to make next, where their predictions differ most.
    pub next_rides: NextRides,
    /// … and the known changes (another condition: the controller off or its gains changed, a
    /// known mass added) that would split them most, best first.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub next_conditions: Vec<NextCondition>,
    /// Each one-parameter candidate's smallest size these rides would have detected (the
    /// campaign's test, 80 % power): with no significant gap, what the quiet campaign rules out.
    pub detection_limits: Vec<DetectionLimit>,
    /// The instrument checked before the bicycle: each condition's mode shape against the
    /// model and the candidates ([`super::instrument`]). A condition whose shape misses every
    /// candidate by a common factor (`misses`) is diagnosed on its eigenvalue alone.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub instrument: Vec<super::instrument::ShapeCheck>,
    pub verdict: String,
}

impl Diagnosis {
    /// A campaign of `rides_used` rides (and `rides_failed`) before any stage has run: no
    /// conclusion, nothing ranked, every number NaN.
    pub(super) fn unconcluded(rides_used: usize, rides_failed: Vec<String>) -> Diagnosis {
        Diagnosis {
            conclusive: false,
            reason: None,
            rides_used,
            rides_failed,
            conditions: Vec::new(),
            between_kick_scatter: None,
            residuals: Vec::new(),
            residuals_after: Vec::new(),
            bands: Vec::new(),
            chi2: f64::NAN,
            dof: 2 * rides_used,
            parts_per_ride: 2,
            targeted: None,
            campaign_p_value: f64::NAN,
            p_value: f64::NAN,
            chi2_without_parameter_error: f64::NAN,
            p_value_without_parameter_error: f64::NAN,
            heldout_vaf_before: None,
            heldout_vaf_after: None,
            significant: false,
            parameters_could_explain: false,
            ranking: Vec::new(),
            tied: Vec::new(),
            explained: false,
            best_fit_p_value: f64::NAN,
            next_rides: NextRides::default(),
            next_conditions: Vec::new(),
            detection_limits: Vec::new(),
            instrument: Vec::new(),
            verdict: String::new(),
        }
    }
}

/// One condition of a study in the diagnosis.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ConditionSummary {
    pub name: String,
    /// Whether it carries a controller.
    pub controlled: bool,
    pub rides_used: usize,
    pub rides_failed: Vec<String>,
    /// Its rides' χ² against the unextended model (their block of the covariance) and its
    /// degrees of freedom.
    pub chi2: f64,
    pub dof: usize,
    /// The scatter between its own repeated kicks (per part, as
    /// [`super::observe::BetweenKickScatter::per_part`]; empty without repeats): diagnosed
    /// alone, its χ² takes this; in the study it takes the scatter pooled over every
    /// condition's repeats, so the two χ² differ where these differ
    /// ([`ConditionSummary::why_chi2_differs`]).
    pub scatter_alone: Vec<f64>,
}

impl ConditionSummary {
    /// Why this condition's χ² in a study differs from its χ² diagnosed alone, in words, when
    /// its own repeats scatter otherwise than the study's pooled ones (`pooled`): `None` when
    /// they agree to 5 %.
    pub fn why_chi2_differs(&self, pooled: &[f64]) -> Option<String> {
        let differs = self
            .scatter_alone
            .iter()
            .zip(pooled)
            .take(2)
            .any(|(a, p)| (a - p).abs() > 0.05 * p.abs().max(1e-12));
        let alone = |s: &[f64]| -> String {
            if s.len() < 2 {
                "none (no repeated kicks)".into()
            } else {
                format!("σ {:.3} 1/s, ω {:.3} rad/s", s[0], s[1])
            }
        };
        (differs || (self.scatter_alone.is_empty() && pooled.iter().any(|&p| p > 0.0))).then(|| {
            format!(
                "its χ² here takes the scatter between repeated kicks pooled over the study's \
                 conditions ({}); alone it would take its own, {}",
                alone(pooled),
                alone(&self.scatter_alone)
            )
        })
    }
}
