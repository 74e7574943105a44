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

/// The smallest size of one candidate that a campaign would have detected.
#[derive(Debug, Clone, serde::Serialize)]
pub struct DetectionLimit {
    pub effect: String,
    /// Its parameter's name and unit.
    pub param: &'static str,
    pub unit: &'static str,
    /// The deviation from "no effect" (in `unit`) that the campaign's test would have found
    /// with 80 % power at its level: values below `none − size` or above `none + size` (only
    /// above for a parameter that cannot go below "no effect", such as a mass) would have
    /// been seen.
    pub size: f64,
    /// The same in the bicycle's own unit where the parameter is a factor on a measured
    /// quantity (a trail of 0.08 m off by ± 0.14 is ± 0.011 m), with that unit.
    pub absolute: Option<(f64, &'static str)>,
    /// The parameter's value meaning "no effect".
    pub none: f64,
    pub one_sided: bool,
}

/// Power asked of a detection limit.
pub const DETECTION_POWER: f64 = 0.8;

/// Each single one-parameter candidate's detection limit on this campaign: the campaign's
/// targeted test (Bonferroni over the `tried` single effects, the p doubled with the χ² test's)
/// rejects at [`super::SIGNIFICANCE`] when the likelihood ratio of the effect's fit exceeds
/// z² with z the normal quantile at 1 − α/(4·tried); at the effect's true size δ the ratio is
/// about (δ/σ₀)² (σ₀ the standard error of its fit at "no effect", from the whitened derivative
/// of the residuals, the full covariance with the model's correlated error included), so it
/// is seen with power 1 − β when δ ≥ (z + z_β) σ₀. Linear in the effect: the size where its
/// effect on the weave stops being linear is beyond what the rides see anyway.
pub(super) fn detection_limits(
    campaign: &super::fit::Campaign<'_>,
    tried: usize,
) -> Vec<DetectionLimit> {
    use statrs::distribution::{ContinuousCDF, Normal};
    let all: Vec<usize> = (0..campaign.obs.len()).collect();
    let (Some(r0), Some(chol)) = (
        campaign.residuals(&[], &[], &all),
        campaign.cov.clone().cholesky(),
    ) else {
        return Vec::new();
    };
    let Ok(normal) = Normal::new(0.0, 1.0) else {
        return Vec::new();
    };
    let alpha = super::SIGNIFICANCE / (2.0 * tried.max(1) as f64);
    let z = normal.inverse_cdf(1.0 - alpha / 2.0) + normal.inverse_cdf(DETECTION_POWER);
    campaign
        .library()
        .into_iter()
        .filter_map(|e| {
            let [spec] = e.params()[..] else {
                return None;
            };
            let layout = campaign.layout(&[e]);
            if !spec.none.is_finite() {
                return None;
            }
            let one_sided = spec.none <= spec.lo;
            let h = 1e-3 * (spec.hi - spec.lo);
            let at = |p: f64| campaign.residuals(&[e], &layout.expand(&[p]), &all);
            let derivative = if one_sided {
                (at(spec.none + h)? - &r0) / h
            } else {
                (at(spec.none + h)? - at(spec.none - h)?) / (2.0 * h)
            };
            // The residual moves by −prediction's change; the sign does not matter here.
            let whitened = chol.l().solve_lower_triangular(&derivative)?;
            let information = whitened.norm_squared();
            if !(information.is_finite() && information > 0.0) {
                return None;
            }
            let size = z / information.sqrt();
            Some(DetectionLimit {
                effect: e.name().to_string(),
                param: spec.name,
                unit: spec.unit,
                size,
                absolute: absolute(e, &campaign.conditions[0].base, size),
                none: spec.none,
                one_sided,
            })
        })
        .collect()
}

/// A factor's deviation `size` on the measured quantity it multiplies, in that quantity's unit.
fn absolute(
    e: super::effects::Effect,
    b: &crate::model::Benchmark,
    size: f64,
) -> Option<(f64, &'static str)> {
    use super::effects::Effect as E;
    let (base, unit) = match e {
        E::Trail => (b.c, "m"),
        E::FrameIxx => (b.i_bxx, "kg·m²"),
        E::FrameIzz => (b.i_bzz, "kg·m²"),
        E::FrameIxz => (b.i_bxz, "kg·m²"),
        E::FrontIxx => (b.i_hxx, "kg·m²"),
        E::FrontIzz => (b.i_hzz, "kg·m²"),
        E::WheelSpin => (b.i_ryy + b.i_fyy, "kg·m² (both wheels)"),
        E::FrameCgHeight => (b.z_b, "m"),
        E::FrameCgX => (b.x_b, "m"),
        _ => return None,
    };
    Some((size * base.abs(), unit))
}

/// The detection limits in words: "a trail off by more than ± 0.14 × measured (± 0.011 m)".
pub fn detection_text(limits: &[DetectionLimit]) -> String {
    let parts: Vec<String> = limits
        .iter()
        .map(|l| {
            let sign = if l.one_sided { "+" } else { "±" };
            let abs = l
                .absolute
                .map_or(String::new(), |(a, u)| format!(" ({sign} {a:.3} {u})"));
            format!("{} {sign} {:.3} {}{abs}", l.effect, l.size, l.unit)
        })
        .collect();
    format!(
        "Ruled out: sizes these rides would have detected (the campaign's test at its level, {:.0} % power), each alone, from \"no effect\": {}; anything smaller could be there unseen.",
        100.0 * DETECTION_POWER,
        parts.join("; ")
    )
}
