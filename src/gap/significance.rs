//! Whether the campaign can be concluded on, and whether its gap is significant. In: the
//! observations, and the χ² of the unextended model and of each single effect fitted. Out: the
//! reason a campaign is too thin ([`insufficiency`]), the targeted test (the likelihood ratio
//! of the single effect that lowers χ² most, Bonferroni over the library) and the campaign's
//! p-value.

use super::{stats, Diagnosis, Observation, Ranked, MIN_RIDES, MIN_SPEED_SPAN_MPS};

/// The targeted part of the campaign's test (see [`Diagnosis::targeted`]).
#[derive(Debug, Clone, serde::Serialize)]
pub struct TargetedTest {
    pub effect: String,
    /// χ² of the unextended model minus χ² with the effect fitted, over the effect's Birge
    /// factor `max(1, χ²/dof)` (a fit that leaves more scatter than the errors allow tells
    /// that much less).
    pub likelihood_ratio: f64,
    /// The effect's parameters: the likelihood ratio's degrees of freedom.
    pub dof: usize,
    /// Its p-value under χ²(dof), times the number of single effects tried (Bonferroni).
    pub p_value: f64,
}

/// The campaign's targeted test: among the single effects of the ranking, the one whose fit
/// lowers the campaign's χ² the most; its likelihood ratio is χ²-distributed with as many
/// degrees of freedom as it has parameters when the model is right (Wilks), and the p-value is
/// multiplied by the number of effects tried. Sets `targeted` and `campaign_p_value`.
pub(super) fn targeted_test(d: &mut Diagnosis) {
    let chi2_before = d.chi2;
    let singles: Vec<&Ranked> = d.ranking.iter().filter(|r| r.effects.len() == 1).collect();
    let tried = singles.len().max(1) as f64;
    d.targeted = singles
        .iter()
        .map(|r| {
            let k = r.params.len();
            let birge = (r.chi2 / d.dof.saturating_sub(k).max(1) as f64).max(1.0);
            let lr = ((chi2_before - r.chi2) / birge).max(0.0);
            TargetedTest {
                effect: r.effect.clone(),
                likelihood_ratio: lr,
                dof: k,
                p_value: (stats::chi2_sf(lr, k) * tried).min(1.0),
            }
        })
        .min_by(|a, b| {
            a.p_value
                .total_cmp(&b.p_value)
                .then(b.likelihood_ratio.total_cmp(&a.likelihood_ratio))
        });
    let p_targeted = d.targeted.as_ref().map_or(1.0, |t| t.p_value);
    d.campaign_p_value = (2.0 * d.p_value.min(p_targeted)).min(1.0);
}

/// Why a campaign cannot support a conclusion, if it cannot.
pub(super) fn insufficiency(rides: &[Observation], failed: &[String]) -> Option<String> {
    if rides.len() < MIN_RIDES {
        return Some(format!(
            "{} usable ride{} ({} failed); at least {MIN_RIDES} are needed to fit an effect and test it on rides left out",
            rides.len(),
            if rides.len() == 1 { "" } else { "s" },
            failed.len()
        ));
    }
    let (lo, hi) = rides
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), o| {
            (a.min(o.speed_mps), b.max(o.speed_mps))
        });
    if hi - lo < MIN_SPEED_SPAN_MPS {
        return Some(format!(
            "the rides span {lo:.2}–{hi:.2} m/s, a single speed: effects that shift the eigenvalue along the speed axis cannot be told from those that shift it across (at least {MIN_SPEED_SPAN_MPS} m/s of spread is needed)"
        ));
    }
    if failed.len() > rides.len() {
        return Some(format!(
            "{} of {} rides failed: the {} that remain may be the ones the model happens to fit",
            failed.len(),
            failed.len() + rides.len(),
            rides.len()
        ));
    }
    None
}
