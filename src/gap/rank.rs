//! The candidates fitted and ranked. In: the campaign ready to fit ([`super::fit::Campaign`])
//! and the library of effects. Out: every single effect and the pairs worth trying, each with
//! its fitted parameters and standard errors, its χ², its leave-one-ride-out predictions
//! (whitened residuals and refitted parameters) and whether its values are plausible, in the
//! order the verdict names them ([`Ranked`]).

use super::effects::{self, Effect};
use super::fit::{assumed_se, fit_effects, param_se, refit_near, Campaign, ResidualCache};
use super::{linear, GapError, Observation, CLOSED_RMS, PAIR_GAIN_CHI2, PAIR_POOL, PLAUSIBLE_SE};
use nalgebra::Complex;

/// One candidate (an effect or a pair) fitted and tested out of sample.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Ranked {
    /// Its name: an effect's, or two joined by " + ".
    pub effect: String,
    pub effects: Vec<Effect>,
    pub params: Vec<f64>,
    pub params_se: Vec<f64>,
    pub units: Vec<&'static str>,
    /// Each parameter at its search bound, or within its standard error of it
    /// ([`at_bound`]): then the rides bound it on one side only, and it is shown as a bound.
    pub at_bound: Vec<bool>,
    /// χ² of the fit to every ride, its degrees of freedom and the BIC `χ² + k ln(2N)`.
    pub chi2: f64,
    pub bic: f64,
    /// RMS of the held-out rides' residuals in their own standard errors, without and with
    /// the effect (each ride predicted from a fit to the others).
    pub heldout_rms_before: f64,
    pub heldout_rms_after: f64,
    /// The same as sums of squared normalized residuals (Σz² over 2N parts).
    pub heldout_chi2_before: f64,
    pub heldout_chi2_after: f64,
    /// Each held-out ride's z² (its parts), in the campaign's order.
    #[serde(skip)]
    pub heldout_per_ride: Vec<f64>,
    /// Each held-out ride's residual whitened by its covariance (its z², summed, is
    /// `heldout_per_ride`); empty where the prediction failed.
    #[serde(skip)]
    pub heldout_whitened: Vec<Vec<f64>>,
    /// The parameters fitted without each ride, in the campaign's order.
    #[serde(skip)]
    pub heldout_params: Vec<Vec<f64>>,
    /// Every fitted value inside its plausible range, or within [`PLAUSIBLE_SE`] of its
    /// standard errors of it, and none at a bound.
    pub plausible: bool,
    /// A pair whose held-out prediction the rides left out cannot tell from the best single
    /// effect's (the tie test, [`super::ties::distinguishable`]): listed after it, never named
    /// ahead of it.
    pub not_needed: bool,
}

/// Held-out residual of each ride for a candidate, whitened ([`Campaign::ride_whitened`];
/// empty where the prediction fails), and the parameters refitted without it: the ride
/// predicted by the candidate refitted without it (from the full fit), in the ride's own
/// standard errors. (Conditioning the prediction on the other rides' residuals, through the
/// model's correlated parameter error, was tried: it lets the parameters' prior absorb the
/// effects that are a measured parameter off, and on the 130 blind campaigns of the two
/// designs it left 76 tied instead of 20.)
fn heldout(
    campaign: &Campaign<'_>,
    effects: &[Effect],
    full_fit: &[f64],
) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let n = campaign.obs.len();
    let mut per_ride = Vec::with_capacity(n);
    let mut fits = Vec::with_capacity(n);
    let cache = ResidualCache::new(campaign, effects);
    for i in 0..n {
        let params = match campaign.leave_one_out(i) {
            Some(s) => {
                let step: Vec<f64> = effects::specs(effects)
                    .iter()
                    .map(|p| 0.05 * (p.hi - p.lo))
                    .collect();
                refit_near(&s, &cache, full_fit, &step).params
            }
            None => full_fit.to_vec(),
        };
        per_ride.push(
            campaign
                .ride_whitened(effects, &params, i)
                .map_or(Vec::new(), |w| w.iter().copied().collect()),
        );
        fits.push(params);
    }
    (per_ride, fits)
}

/// The VAF of ride `o`'s window by `bike`'s weave and slowest two real modes at the ride's
/// true speed under `effects` (mean of θ and γ).
pub(super) fn ride_vaf(
    bike: &linear::LinearBike,
    effects: &[Effect],
    params: &[f64],
    o: &Observation,
    guess: Complex<f64>,
) -> Option<f64> {
    let [t, roll, steer] = o.window.as_ref()?;
    let v = effects::true_speed(effects, params, o);
    let clock = effects::clock(effects, params);
    let weave = bike.weave_near(v, guess)? / clock;
    let mut reals: Vec<f64> = bike
        .eigenvalues(v)?
        .into_iter()
        // Real modes slower than castor's tail; a neutral one (the heading, with tyres) is the
        // offset already.
        .filter(|z| z.im.abs() < 1e-6 && z.re > -25.0 && z.re.abs() > 1e-3)
        .map(|z| z.re / clock)
        .collect();
    reals.sort_by(|a, b| b.total_cmp(a));
    reals.truncate(2);
    let vaf = crate::ride::modal::vaf_with_modes(t, roll, steer, weave, &reals)?;
    Some(0.5 * (vaf[0] + vaf[1]))
}

/// A fitted value `p` with standard error `se` is plausible when it lies within
/// [`PLAUSIBLE_SE`] standard errors of the parameter's plausible range (a value the fit cannot
/// tell from the range's edge is no reason to rule the effect out), but no further out than a
/// quarter of the range's width (a value the rides barely constrain is not made plausible by
/// its large error); one without a finite error only inside it.
fn plausible(spec: &effects::ParamSpec, p: f64, se: f64) -> bool {
    let width = spec.plausible.1 - spec.plausible.0;
    let margin = if se.is_finite() {
        (PLAUSIBLE_SE * se).min(0.25 * width)
    } else {
        0.0
    };
    p + margin >= spec.plausible.0 && p - margin <= spec.plausible.1
}

/// Whether a fitted value `p` (standard error `se`) sits at its search's bound: within its
/// standard error of it, or within a thousandth of the range where it has none. The rides then
/// tell one side of the value only (and the curvature at the edge is no standard error).
pub fn at_bound(spec: &effects::ParamSpec, p: f64, se: f64) -> bool {
    let tol = if se.is_finite() {
        se.max(1e-6 * (spec.hi - spec.lo))
    } else {
        1e-3 * (spec.hi - spec.lo)
    };
    p - spec.lo <= tol || spec.hi - p <= tol
}

impl Ranked {
    /// Each parameter in words, with its unit: `0.092 ± 0.061 kg·m²`, or a bound for one at
    /// the search's edge ([`super::verdict::param_text`]).
    pub fn param_texts(&self) -> Vec<String> {
        effects::specs(&self.effects)
            .iter()
            .enumerate()
            .map(|(k, spec)| {
                let (p, se) = (self.params[k], self.params_se[k]);
                if self.at_bound.get(k).copied().unwrap_or(false) {
                    super::verdict::bound_text(spec, p, se)
                } else {
                    super::verdict::param_text(p, se, spec.unit)
                }
            })
            .collect()
    }
}

/// Fits and tests every effect, then pairs of the best ones; sorted by held-out RMS.
pub(super) fn rank(
    campaign: &Campaign<'_>,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<Ranked>, GapError> {
    let n = campaign.obs.len();
    let before = (0..n)
        .map(|i| campaign.ride_chi2(&[], &[], i).unwrap_or(f64::INFINITY))
        .sum::<f64>();
    let parts = n * campaign.parts;
    let rms = |s: f64| (s / parts as f64).sqrt();
    let library = Effect::library(!campaign.control.is_none());
    let total = 2 * library.len() - 1 + (PAIR_POOL - 1) * (PAIR_POOL - 2) / 2;
    let done = std::sync::atomic::AtomicUsize::new(0);
    let evaluate = |effects: &[Effect]| -> Option<Ranked> {
        let effects = effects.to_vec();
        let full = campaign.subset((0..n).collect())?;
        let f = fit_effects(&full, &effects);
        let se: Vec<f64> = param_se(&full, &effects, &f)
            .iter()
            .zip(assumed_se(campaign, &effects, &f))
            .map(|(s, a)| s.hypot(a))
            .collect();
        let (whitened, heldout_params) = heldout(campaign, &effects, &f.params);
        let per_ride: Vec<f64> = whitened
            .iter()
            .map(|w| {
                if w.is_empty() {
                    f64::INFINITY
                } else {
                    w.iter().map(|x| x * x).sum()
                }
            })
            .collect();
        let held: f64 = per_ride.iter().sum();
        progress(
            done.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1,
            total,
        );
        let name = effects
            .iter()
            .map(|e| e.name())
            .collect::<Vec<_>>()
            .join(" + ");
        let specs = effects::specs(&effects);
        let bounded: Vec<bool> = specs
            .iter()
            .zip(f.params.iter().zip(&se))
            .map(|(spec, (&p, &se))| at_bound(spec, p, se))
            .collect();
        Some(Ranked {
            effect: name,
            plausible: !bounded.contains(&true)
                && specs
                    .iter()
                    .zip(f.params.iter().zip(&se))
                    .all(|(spec, (&p, &se))| plausible(spec, p, se)),
            at_bound: bounded,
            not_needed: false,
            units: effects::specs(&effects).iter().map(|p| p.unit).collect(),
            effects,
            bic: f.chi2 + f.params.len() as f64 * (parts as f64).ln(),
            chi2: f.chi2,
            params: f.params,
            params_se: se,
            heldout_rms_before: rms(before),
            heldout_rms_after: rms(held),
            heldout_chi2_before: before,
            heldout_chi2_after: held,
            heldout_per_ride: per_ride,
            heldout_whitened: whitened,
            heldout_params,
        })
    };
    let singles: Vec<Vec<Effect>> = library.iter().map(|&e| vec![e]).collect();
    let over = |list: &[Vec<Effect>]| -> Vec<Ranked> {
        use rayon::prelude::*;
        let all: Vec<Option<Ranked>> = list.par_iter().map(|e| evaluate(e)).collect();
        all.into_iter().flatten().collect()
    };
    let mut ranked = over(&singles);
    sort(&mut ranked);
    if ranked
        .first()
        .is_none_or(|b| b.heldout_rms_after <= CLOSED_RMS)
    {
        return Ok(ranked);
    }
    // No single effect closes the gap: pairs of the best singles, kept when they beat every
    // single out of sample by PAIR_GAIN_CHI2 and by the BIC.
    let pool: Vec<Effect> = ranked
        .iter()
        .take(PAIR_POOL)
        .map(|r| r.effects[0])
        .collect();
    // The best single with every other effect, and the next best among themselves.
    let mut pairs: Vec<Vec<Effect>> = Vec::new();
    let mut add = |a: Effect, b: Effect| {
        let mut p = vec![a, b];
        p.sort();
        if a != b && !pairs.contains(&p) {
            pairs.push(p);
        }
    };
    if let Some(&first) = pool.first() {
        for &e in &library {
            add(first, e);
        }
    }
    for a in 1..pool.len() {
        for b in a + 1..pool.len() {
            add(pool[a], pool[b]);
        }
    }
    let best_single = ranked.first().cloned();
    for mut r in over(&pairs) {
        if let Some(b) = &best_single {
            if b.heldout_chi2_after - r.heldout_chi2_after > PAIR_GAIN_CHI2 && r.bic < b.bic {
                // Parsimony: a pair goes ahead of the best single only when the rides left
                // out tell it from the single (the tie test); otherwise it is listed after it,
                // as not needed.
                r.not_needed = !super::ties::distinguishable(&r, b);
                ranked.push(r);
            }
        }
    }
    sort(&mut ranked);
    Ok(ranked)
}

/// Plausible candidates first (a value no real bicycle or lab would have explains nothing,
/// however well it fits), pairs not needed after the rest, each group by held-out RMS.
fn sort(ranked: &mut [Ranked]) {
    ranked.sort_by(|a, b| {
        b.plausible
            .cmp(&a.plausible)
            .then(a.not_needed.cmp(&b.not_needed))
            .then_with(|| a.heldout_rms_after.total_cmp(&b.heldout_rms_after))
            .then_with(|| a.effect.cmp(&b.effect))
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A value within its standard error of the search's edge is a bound, shown as one: the
    /// rear frame's I_xz factor (search 0.4–1.8) at 0.45 ± 0.1 is "≤ 0.55"; at 0.9 ± 0.1 it is
    /// an estimate; at the upper edge without a standard error, "≥ 1.8".
    #[test]
    fn a_value_at_the_search_edge_is_a_bound() {
        let spec = Effect::FrameIxz.params()[0];
        assert!(at_bound(&spec, 0.45, 0.1));
        assert!(!at_bound(&spec, 0.9, 0.1));
        assert!(at_bound(&spec, 1.8, f64::INFINITY));
        assert!(!at_bound(&spec, 1.2, f64::INFINITY));
        let text = super::super::verdict::bound_text(&spec, 0.45, 0.1);
        assert!(text.starts_with("≤ 0.550 × measured"), "{text}");
        let text = super::super::verdict::bound_text(&spec, 1.8, f64::NAN);
        assert!(text.starts_with("≥ 1.800 × measured"), "{text}");
    }
}
