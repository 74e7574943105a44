//! The candidates fitted and ranked. In: the campaign ready to fit ([`super::fit::Campaign`])
//! and the library of effects. Out: every single effect and the pairs worth trying, each with
//! its fitted parameters and standard errors, its χ², its leave-one-ride-out predictions
//! (whitened residuals and refitted parameters) and whether its values are plausible, in the
//! order the verdict names them ([`Ranked`]).

use super::conditions::{Layout, Slot};
use super::effects::{self, Effect};
use super::error::GapError;
use super::fit::{
    assumed_se, fit_effects, fit_effects_from_smaller, param_se, refine, refit_near, Campaign,
    EffectFit, ResidualCache,
};
use super::linear;
use super::observe::Observation;
use super::thresholds::{
    CLOSED_RMS, PAIR_GAIN_CHI2, PAIR_POOL, PLAUSIBLE_SE, SIGNIFICANCE, TIE_CHI2, TIE_SE,
};
use nalgebra::Complex;
use std::collections::BTreeMap;

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
    /// Each parameter whose search stopped at an edge ([`pinned`]) with the χ²'s minimum more
    /// than `PINNED_SE` standard errors beyond it: the candidate's χ² is then not its own
    /// minimum. A value merely within its standard error of the edge, or at the edge where
    /// the rides barely tell (a controller's gain in a condition of three rides: 0.1 ± 0.49,
    /// its minimum 1.4 SE beyond), is a fit, shown as a bound but not held against the
    /// candidate.
    #[serde(skip)]
    pub held_back: Vec<bool>,
    /// Each parameter whose search stopped at an edge ([`pinned`]): the fit would go beyond
    /// the range searched, so its value is a bound, not an estimate. In a study a candidate
    /// with one of the bicycle's ranks below every candidate without
    /// ([`Ranked::bicycle_at_edge`], [`Ranked::standing`]).
    pub at_edge: Vec<bool>,
    /// χ² of the fit to every ride, its degrees of freedom and the BIC `χ² + k ln(2N)`.
    pub chi2: f64,
    pub bic: f64,
    /// χ² of the first fit, in the campaign's covariance at "no effect" and without coasting
    /// shifts: the targeted test's ([`super::significance`]), whose null draws are made there.
    #[serde(skip)]
    pub chi2_test: f64,
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
    /// `heldout_per_ride`; in a study whitened with its condition's other rides,
    /// [`Campaign::rides_whitened`]); empty where the prediction failed.
    #[serde(skip)]
    pub heldout_whitened: Vec<Vec<f64>>,
    /// The parameters fitted without each ride, in the campaign's order.
    #[serde(skip)]
    pub heldout_params: Vec<Vec<f64>>,
    /// Every fitted value inside its plausible range, or within [`PLAUSIBLE_SE`] of its
    /// standard errors of it, and none at a bound.
    pub plausible: bool,
    /// The plausibility prior's penalty on the fitted values, summed
    /// ([`effects::ParamSpec::prior_penalty`]: 0 inside every plausible range): in a campaign
    /// the order is by `bic + prior_penalty`, so a value outside its range pays in the
    /// evidence, visibly, instead of being set behind every plausible candidate.
    pub prior_penalty: f64,
    /// Each fitted element's spec and, in a study, its condition (`None`: shared by all).
    #[serde(skip)]
    pub specs: Vec<effects::ParamSpec>,
    #[serde(skip)]
    pub param_conditions: Vec<Option<String>>,
    /// Each fitted element's effect (an index into `effects`).
    #[serde(skip)]
    pub param_effect: Vec<usize>,
    /// In a study: each condition's values of the effects' parameters (in the order of
    /// `effects`' parameters; a shared effect repeats its value, an equipment effect a
    /// condition lacks is `null`) and their standard errors …
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub params_by_condition: BTreeMap<String, Vec<Option<f64>>>,
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub params_se_by_condition: BTreeMap<String, Vec<Option<f64>>>,
    /// … each condition predicted from the others (its own equipment at the others' mean):
    /// the RMS of its rides' residuals in their standard errors (the ranking's `before` and
    /// `after` are these, over every condition) …
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub heldout_rms_by_condition: BTreeMap<String, f64>,
    /// … and, beside it, every ride left out one at a time.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heldout_rms_rides_out: Option<f64>,
    /// A pair whose held-out prediction the rides left out cannot tell from the best single
    /// effect's (the tie test, `super::ties::distinguishable`): listed after it, never named
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
    use rayon::prelude::*;
    let n = campaign.obs.len();
    let cache = ResidualCache::new(campaign, effects);
    let step = steps(campaign, effects);
    let refit = |i: usize| {
        let params = match campaign.leave_one_out(i) {
            Some(s) => {
                let check = n < campaign.trusted_newton_rides;
                refit_near(&s, &cache, full_fit, &step, &[], check).params
            }
            None => full_fit.to_vec(),
        };
        (whitened(campaign, effects, &params, i), params)
    };
    // The first refit alone: it evaluates the steps around the full fit that every other one
    // starts from (the cache's shared part); the others in parallel, in the rides' order.
    let mut out = Vec::with_capacity(n);
    if n > 0 {
        out.push(refit(0));
    }
    out.par_extend((1..n).into_par_iter().map(refit));
    out.into_iter().unzip()
}

/// A held-out ride's z² from its whitened residual; infinite where it could not be predicted
/// (empty).
fn whitened_chi2(w: &[f64]) -> f64 {
    if w.is_empty() {
        f64::INFINITY
    } else {
        w.iter().map(|x| x * x).sum()
    }
}

/// Pushes onto `pairs` each pair of `a` with another effect of `library`, sorted, that is in
/// neither `pairs` nor `skip`.
fn push_pairs_with(
    pairs: &mut Vec<Vec<Effect>>,
    a: Effect,
    library: &[Effect],
    skip: &[Vec<Effect>],
) {
    for &b in library.iter().filter(|&&b| b != a) {
        let mut p = vec![a, b];
        p.sort();
        if !pairs.contains(&p) && !skip.contains(&p) {
            pairs.push(p);
        }
    }
}

/// The first pair of a ranking that is needed (not listed after a smaller candidate).
fn best_pair(ranked: &[Ranked]) -> Option<&Ranked> {
    ranked
        .iter()
        .find(|r| r.effects.len() == 2 && !r.not_needed)
}

/// The initial steps of a refit: a twentieth of each element's range.
fn steps(campaign: &Campaign<'_>, effects: &[Effect]) -> Vec<f64> {
    let (lo, hi) = campaign.layout(effects).bounds();
    lo.iter().zip(&hi).map(|(l, h)| 0.05 * (h - l)).collect()
}

/// Ride `i`'s residual at `params`, whitened ([`Campaign::ride_whitened`]); empty where the
/// prediction fails.
fn whitened(campaign: &Campaign<'_>, effects: &[Effect], params: &[f64], i: usize) -> Vec<f64> {
    campaign
        .ride_whitened(effects, params, i)
        .map_or(Vec::new(), |w| w.iter().copied().collect())
}

/// [`heldout`] with whole conditions left out (a study): each condition's rides predicted by
/// the candidate fitted to the other conditions (Newton from the fit to all, then
/// Nelder–Mead: leaving a condition out moves the minimum further than leaving a ride out),
/// the condition's own equipment at what the others say of it ([`Layout::predicting`]), and
/// whitened together ([`Campaign::rides_whitened`]); `full_se`, the fit to all's errors, weigh
/// the copies the others say it with. Ride by ride, an effect that merely
/// follows the measured parameters' error (which moves every ride of a condition alike) was
/// credited once per ride: blind studies put first a single whose fit to every ride was tens
/// of χ² worse than the truth's (docs/decisions/2026-12-04-study-joint-whitening.md).
fn heldout_conditions(
    campaign: &Campaign<'_>,
    effects: &[Effect],
    full_fit: &[f64],
    full_se: &[f64],
) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    use rayon::prelude::*;
    let n = campaign.obs.len();
    let layout = campaign.layout(effects);
    let mut per_ride = vec![Vec::new(); n];
    let mut fits = vec![full_fit.to_vec(); n];
    let cache = ResidualCache::new(campaign, effects);
    let step = steps(campaign, effects);
    let refit = |c: usize| {
        let others: Vec<usize> = (0..n)
            .filter(|&i| campaign.ride_condition[i] != c)
            .collect();
        let own = layout.own(c);
        match campaign.subset(others) {
            Some(s) if !layout.is_empty() => {
                let near = refit_near(&s, &cache, full_fit, &step, &own, true);
                refine(&s, effects, &near.params, &step, &own).params
            }
            _ => full_fit.to_vec(),
        }
    };
    // The conditions' refits in parallel (each its own subset and held parameters).
    let refits: Vec<Vec<f64>> = (0..campaign.conditions.len())
        .into_par_iter()
        .map(refit)
        .collect();
    for (c, params) in refits.iter().enumerate() {
        let predicting = layout.predicting(params, c, Some(full_se));
        let rides = campaign.rides_of(c);
        for (&i, w) in rides
            .iter()
            .zip(campaign.rides_whitened(effects, &predicting, &rides))
        {
            per_ride[i] = w;
            fits[i] = predicting.clone();
        }
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
    let bike = &effects::for_ride(bike, effects, params, o, guess);
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

/// In a study, each condition's values of `values` (the fitted vector or its standard errors):
/// `null` where a condition lacks an equipment effect; empty for a single campaign.
fn by_condition(
    campaign: &Campaign<'_>,
    layout: &Layout,
    values: &[f64],
) -> BTreeMap<String, Vec<Option<f64>>> {
    if !campaign.is_study() {
        return BTreeMap::new();
    }
    campaign
        .conditions
        .iter()
        .zip(&layout.slots)
        .map(|(cond, slots)| {
            let v = slots
                .iter()
                .map(|s| match *s {
                    Slot::Fitted(k) => values.get(k).copied(),
                    Slot::Fixed(_) => None,
                })
                .collect();
            (cond.name.clone(), v)
        })
        .collect()
}

/// A fitted value `p` with standard error `se` is plausible when it lies within
/// [`PLAUSIBLE_SE`] standard errors of the parameter's plausible range (a value the fit cannot
/// tell from the range's edge is no reason to rule the effect out), but no further out than a
/// quarter of the range's width (a value the rides barely constrain is not made plausible by
/// its large error); one without a finite error only inside it.
pub(super) fn plausible(spec: &effects::ParamSpec, p: f64, se: f64) -> bool {
    let width = spec.plausible.1 - spec.plausible.0;
    let margin = if se.is_finite() {
        (PLAUSIBLE_SE * se).min(effects::PRIOR_TAIL_FRACTION * width)
    } else {
        0.0
    };
    spec.outside_plausible(p) <= margin
}

/// How close to its search's edge (a fraction of the range) a fit counts as stopped there: the
/// search clamps to the edge, and the held-out refits' differences keep 1e-3 of the range
/// clear of it.
const PINNED_FRACTION: f64 = 2e-3;

/// How far beyond its search's edge (in its standard errors) a parameter's minimum may lie
/// with the edge still within its 95 % interval.
const PINNED_SE: f64 = 2.0;

/// Whether a fitted value `p` is where its search stopped at an edge (within
/// `PINNED_FRACTION` of the range): its minimum lies there or beyond.
pub fn pinned(spec: &effects::ParamSpec, p: f64) -> bool {
    let tol = PINNED_FRACTION * (spec.hi - spec.lo);
    spec.nearest_edge(p).0 <= tol
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
    spec.nearest_edge(p).0 <= tol
}

impl Ranked {
    /// Whether the candidate was ranked in a study of several conditions.
    pub fn in_study(&self) -> bool {
        !self.heldout_rms_by_condition.is_empty()
    }

    /// Whether it ranks among the first: in a single campaign, a candidate with no parameter
    /// at its search's bound or within its standard error of it (a value the rides bound on
    /// one side only is no estimate to rank above one they bound on both; a value outside
    /// its plausible range pays the prior's penalty in the order instead,
    /// [`Ranked::prior_penalty`]); in a study, one with no parameter of the bicycle at its
    /// search's edge or within its standard error of it ([`Ranked::bicycle_at_edge`]) —
    /// there the conditions, not a prior, decide, and a best fit outside its plausible range
    /// is shown first and flagged.
    pub fn standing(&self) -> bool {
        if self.in_study() {
            !self.bicycle_at_edge()
        } else {
            !self.at_bound.contains(&true)
        }
    }

    /// Whether a parameter of the bicycle (an effect the conditions share) stopped at its
    /// search's edge ([`Ranked::at_edge`]) or lies within its standard error of it
    /// ([`Ranked::at_bound`]): shown as a bound, `≤ 0.652 × measured (at the search's edge
    /// 0.500 within its SE)`, it ranks as one. With the edge alone the balance-assist study's
    /// first was such a value (frame_cg_x, once triples beyond the best pair's were tried;
    /// front_izz ≥ 1.70 before). A condition's own equipment (its controller's
    /// delivered gain, its speedometer's scale, its clock: [`Effect::per_condition`]) is fitted
    /// from that condition's rides alone, which may barely tell it: at G = 1 a bicycle with a
    /// large rotor falls within a cycle in most rides, and a blind study's gain there came out
    /// at the edge, 0.1 ± 0.49, beside the best-predicting pair of all (`tests/study.rs`,
    /// `a_gain_its_rides_barely_tell_does_not_hide_the_motor`). It is shown as a bound; the
    /// ranking rests on the bicycle's parameters. The measurements behind it:
    /// [docs/decisions/2026-12-02-study-ranking-edges.md](../../docs/decisions/2026-12-02-study-ranking-edges.md),
    /// [docs/decisions/2026-12-03-study-triples.md](../../docs/decisions/2026-12-03-study-triples.md).
    pub fn bicycle_at_edge(&self) -> bool {
        self.param_effect
            .iter()
            .zip(self.at_edge.iter().zip(&self.at_bound))
            .any(|(&j, (&edge, &bound))| (edge || bound) && !self.effects[j].per_condition())
    }

    /// Whether a parameter's search edge holds the fit back ([`Ranked::held_back`]).
    pub fn held_back_by_an_edge(&self) -> bool {
        self.held_back.contains(&true)
    }

    /// Each parameter in words, with its unit: `0.092 ± 0.061 kg·m²`, or a bound for one at
    /// the search's edge ([`super::effects::param_text`]).
    pub fn param_texts(&self) -> Vec<String> {
        self.specs
            .iter()
            .enumerate()
            .map(|(k, spec)| {
                let (p, se) = (self.params[k], self.params_se[k]);
                let text = if self.at_bound.get(k).copied().unwrap_or(false) {
                    super::effects::bound_text(spec, p, se)
                } else {
                    super::effects::param_text(p, se, spec.unit)
                };
                match self.param_conditions.get(k) {
                    Some(Some(c)) => format!("{text} ({c})"),
                    _ => text,
                }
            })
            .collect()
    }
}

/// Fits and tests every effect, then pairs (every pair, or a screen's: [`super::PairSearch`]);
/// in the order of [`sort`].
pub(super) fn rank(
    campaign: &Campaign<'_>,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<Ranked>, GapError> {
    let n = campaign.obs.len();
    let before = if campaign.is_study() {
        (0..campaign.conditions.len())
            .flat_map(|c| campaign.rides_whitened(&[], &[], &campaign.rides_of(c)))
            .map(|w| whitened_chi2(&w))
            .sum::<f64>()
    } else {
        (0..n)
            .map(|i| campaign.ride_chi2(&[], &[], i).unwrap_or(f64::INFINITY))
            .sum::<f64>()
    };
    let parts = campaign.parts.total();
    let rms = |s: f64| (s / parts as f64).sqrt();
    let library = campaign.library();
    // The candidates set out to fit, counted as each stage (singles, pairs, their neighbours,
    // triples) sets out: the progress's total is then exact, never passed by its count, and
    // grows as a later stage turns out to be needed.
    let total = std::sync::atomic::AtomicUsize::new(0);
    let done = std::sync::atomic::AtomicUsize::new(0);
    let tick = || {
        progress(
            done.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1,
            total.load(std::sync::atomic::Ordering::SeqCst),
        )
    };
    // Every pair fitted (admitted or not), its fit to every ride: the triples' screen takes the
    // pair of the lowest χ², and where every three effects are tried each triple's first fit
    // starts from its pairs' (`fit_effects_from_smaller`), not from a grid of 7³ points: on
    // the balance-assist study 1 min 44 s against 3 min 37 s, the same first five but for one
    // triple fitted better (the record: docs/decisions/2026-12-03-study-triples.md).
    let pair_fits: std::sync::Mutex<BTreeMap<Vec<Effect>, EffectFit>> = Default::default();
    let pair_fit = |pair: &[Effect]| -> Option<Vec<f64>> {
        pair_fits.lock().ok()?.get(pair).map(|f| f.params.clone())
    };
    // A candidate is fitted to every ride, then tested out of sample; one whose BIC is not
    // below `bic_below` (a larger candidate that can never be admitted, `admit`) is not
    // tested: `None`, as the exhaustive search would leave it out, at half the cost. In a
    // study, one whose conditions left out do not beat `gain_over` (the held-out Σz² of the
    // candidate it must beat) by PAIR_GAIN_CHI2 is not admitted either, and its rides are not
    // left out one at a time (reported beside an admitted candidate, never ranked on): on the
    // balance-assist study's every triple, most of the time.
    let evaluate = |effects: &[Effect], bic_below: f64, gain_over: Option<f64>| -> Option<Ranked> {
        let effects = effects.to_vec();
        let all = campaign.subset((0..n).collect())?;
        let from_pairs = (campaign.every_triple && effects.len() == 3)
            .then(|| fit_effects_from_smaller(&all, &effects, &pair_fit))
            .flatten();
        let first = from_pairs.unwrap_or_else(|| fit_effects(&all, &effects));
        // Fitted again with the model's covariance where the first fit puts the bicycle
        // ([`Campaign::at_fit`]); its errors, χ² and held-out predictions are then those of
        // the model being fitted.
        let own = campaign.at_fit(&effects, &first.params);
        let campaign = own.as_ref().unwrap_or(campaign);
        let full = campaign.subset((0..n).collect())?;
        let f = refine(
            &full,
            &effects,
            &first.params,
            &steps(campaign, &effects),
            &[],
        );
        if effects.len() == 2 {
            if let Ok(mut fits) = pair_fits.lock() {
                fits.insert(effects.clone(), f.clone());
            }
        }
        let bic = f.chi2 + f.params.len() as f64 * (parts as f64).ln();
        if bic >= bic_below {
            tick();
            return None;
        }
        let se: Vec<f64> = param_se(&full, &effects, &f)
            .iter()
            .zip(assumed_se(campaign, &effects, &f))
            .map(|(s, a)| s.hypot(a))
            .collect();
        // In a study the conditions are left out: the ranking rests on predicting one from
        // the others; the rides left out one at a time are reported beside it.
        let (whitened, heldout_params, rides_out_rms) = if campaign.is_study() {
            let (w, p) = heldout_conditions(campaign, &effects, &f.params, &se);
            let held: f64 = w.iter().map(|w| whitened_chi2(w)).sum();
            let admissible = gain_over.is_none_or(|a| a - held > PAIR_GAIN_CHI2);
            let rides_out_rms = admissible.then(|| {
                let (rides_out, _) = heldout(campaign, &effects, &f.params);
                rms(rides_out.iter().map(|w| whitened_chi2(w)).sum())
            });
            (w, p, rides_out_rms)
        } else {
            let (rides_out, rides_out_params) = heldout(campaign, &effects, &f.params);
            (rides_out, rides_out_params, None)
        };
        let per_ride: Vec<f64> = whitened.iter().map(|w| whitened_chi2(w)).collect();
        let held: f64 = per_ride.iter().sum();
        tick();
        let name = effects
            .iter()
            .map(|e| e.name())
            .collect::<Vec<_>>()
            .join(" + ");
        let layout = campaign.layout(&effects);
        let specs = layout.specs.clone();
        let bounded: Vec<bool> = specs
            .iter()
            .zip(f.params.iter().zip(&se))
            .map(|(spec, (&p, &se))| at_bound(spec, p, se))
            .collect();
        // The slope of χ² inward from an edge, g: with χ² quadratic (curvature 2/se²) its
        // minimum lies g se/2 standard errors beyond the edge.
        let held_back: Vec<bool> = specs
            .iter()
            .enumerate()
            .map(|(k, spec)| {
                let p = f.params[k];
                if !pinned(spec, p) || !se[k].is_finite() {
                    return false;
                }
                let h = PINNED_FRACTION * (spec.hi - spec.lo);
                let inward = if spec.nearest_edge(p).1 { h } else { -h };
                let mut x = f.params.clone();
                x[k] = p + inward;
                let slope = (full.chi2(&effects, &x) - f.chi2) / h;
                0.5 * slope * se[k] > PINNED_SE
            })
            .collect();
        let at_edge: Vec<bool> = specs
            .iter()
            .zip(&f.params)
            .map(|(spec, &p)| pinned(spec, p))
            .collect();
        Some(Ranked {
            effect: name,
            held_back,
            at_edge,
            plausible: !bounded.contains(&true)
                && specs
                    .iter()
                    .zip(f.params.iter().zip(&se))
                    .all(|(spec, (&p, &se))| plausible(spec, p, se)),
            prior_penalty: specs
                .iter()
                .zip(f.params.iter().zip(&se))
                .map(|(spec, (&p, &se))| spec.prior_penalty(p, se))
                .sum(),
            at_bound: bounded,
            not_needed: false,
            units: specs.iter().map(|p| p.unit).collect(),
            param_conditions: layout
                .condition
                .iter()
                .map(|c| c.map(|c| campaign.conditions[c].name.clone()))
                .collect(),
            param_effect: layout.effect.clone(),
            params_by_condition: by_condition(campaign, &layout, &f.params),
            params_se_by_condition: by_condition(campaign, &layout, &se),
            heldout_rms_by_condition: if campaign.is_study() {
                (0..campaign.conditions.len())
                    .map(|c| {
                        let rides = campaign.rides_of(c);
                        let sum: f64 = rides.iter().map(|&i| per_ride[i]).sum();
                        let parts = campaign.parts.count(&rides).max(1) as f64;
                        (campaign.conditions[c].name.clone(), (sum / parts).sqrt())
                    })
                    .collect()
            } else {
                BTreeMap::new()
            },
            heldout_rms_rides_out: rides_out_rms,
            specs,
            effects,
            bic,
            chi2: f.chi2,
            chi2_test: first.chi2,
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
    let over = |list: &[Vec<Effect>], bic_below: f64, gain_over: Option<f64>| -> Vec<Ranked> {
        use rayon::prelude::*;
        total.fetch_add(list.len(), std::sync::atomic::Ordering::SeqCst);
        let all: Vec<Option<Ranked>> = list
            .par_iter()
            .map(|e| evaluate(e, bic_below, gain_over))
            .collect();
        all.into_iter().flatten().collect()
    };
    // Candidates of one more effect than `against`, kept when they beat it out of sample by
    // PAIR_GAIN_CHI2 and by the BIC. Parsimony: such a candidate goes ahead of `against` only
    // when the rides left out tell them apart (the tie test); otherwise it is listed after it,
    // as not needed.
    //
    // In a study a larger candidate must also lower the χ² of every ride significantly below
    // each candidate one effect smaller that it holds (of those ranked so far: every single,
    // the pairs admitted): the likelihood ratio of the two fits to every ride (each χ² in its
    // own covariance, as its BIC), over the larger one's Birge ratio where it still fails its
    // χ² test ([`crate::stats::birge_likelihood_ratio`], as the targeted test's), χ²-distributed
    // with the added parameters' degrees of freedom, Bonferroni over the library's effects
    // that could extend the smaller one (the step of a forward selection: whichever search
    // tries them, a screened one and an exhaustive one then admit by the same bar;
    // docs/decisions/2026-12-04-study-joint-whitening.md). A study tries pairs even where its
    // best single fails only the χ² test, and there an effect
    // of the bicycle beside the right one can follow the measured parameters' correlated
    // error: it bought held-out RMS (while the conditions left out were whitened ride by ride)
    // that the χ² of every ride, which carries that error, does not grant. Measured in blind
    // studies of a controller's speed sensor: docs/decisions/2026-12-03-study-admission.md;
    // kept with the conditions whitened together (docs/decisions/2026-12-04-study-joint-whitening.md).
    let significant_over = |r: &Ranked, against: &Ranked| -> bool {
        if !campaign.is_study() {
            return true;
        }
        let added = r.params.len().saturating_sub(against.params.len()).max(1);
        let dof = parts.saturating_sub(r.params.len());
        let lr = crate::stats::birge_likelihood_ratio(against.chi2, r.chi2, dof);
        let extensions = library.len().saturating_sub(against.effects.len());
        crate::stats::chi2_sf(lr, added) * extensions.max(1) as f64 <= SIGNIFICANCE
    };
    let admit = |larger: &[Vec<Effect>], against: &Ranked, ranked: &mut Vec<Ranked>| {
        for mut r in over(larger, against.bic, Some(against.heldout_chi2_after)) {
            let nested_significant = ranked
                .iter()
                .filter(|s| {
                    s.effects.len() + 1 == r.effects.len()
                        && s.effects.iter().all(|e| r.effects.contains(e))
                })
                .all(|s| significant_over(&r, s));
            if against.heldout_chi2_after - r.heldout_chi2_after > PAIR_GAIN_CHI2
                && r.bic < against.bic
                && nested_significant
            {
                r.not_needed = !distinguishable(&r, against);
                ranked.push(r);
            }
        }
        sort(ranked);
    };
    let mut ranked = over(&singles, f64::INFINITY, None);
    sort(&mut ranked);
    // The singles as the rides left out order them (a study's own order): whether one closes
    // the gap, which are paired and what a pair must beat are questions of prediction. Each
    // rule below and its measurements: docs/decisions/ranking-rules.md.
    let mut held = ranked.clone();
    sort_by(&mut held, |r| r.heldout_rms_after);
    let dof = parts.saturating_sub(1).max(1);
    let passes = |b: &Ranked| {
        b.heldout_rms_after <= CLOSED_RMS
            && (!campaign.is_study() || crate::stats::chi2_sf(b.chi2, dof) >= SIGNIFICANCE)
    };
    // A single campaign tries pairs only when no single effect passes: the rides left out
    // further than CLOSED_RMS (a failed χ² test as a second reason lost more of its blind suite
    // than it gained). Pairs of the best singles, admitted against the best single (`admit`).
    let single_passes = held.first().is_none_or(passes);
    if single_passes && !campaign.is_study() {
        return Ok(ranked);
    }
    // A study whose best single passes still tries it with each effect of the other kind (of a
    // condition's own equipment beside one of the bicycle, or the reverse): a motor's
    // delivered gain beside an effect on the bicycle is what a study is ridden to tell, and a
    // single that passes on its conditions left out can hide it. Not with another effect of
    // the same kind, which named a rotor beside an effect of the bicycle where there was none.
    if single_passes {
        if let Some(best) = held.first().map(|r| r.effects[0]) {
            let pairs: Vec<Vec<Effect>> = library
                .iter()
                .filter(|e| e.per_condition() != best.per_condition())
                .map(|&e| {
                    let mut p = vec![best, e];
                    p.sort();
                    p
                })
                .collect();
            admit(&pairs, &held[0], &mut ranked);
        }
        return Ok(ranked);
    }
    let pool: Vec<Effect> = held.iter().take(PAIR_POOL).map(|r| r.effects[0]).collect();
    // The best single with every other effect, and the next best among themselves.
    let mut pairs: Vec<Vec<Effect>> = Vec::new();
    if let Some(&first) = pool.first() {
        push_pairs_with(&mut pairs, first, &library, &[]);
    }
    // In a study, also the single that lowers the χ² of every ride most: an effect of one
    // condition's equipment that leaves a shared part along the measured parameters' errors
    // (which the χ² of every ride absorbs) can rank low out of sample, and its pair with the
    // withheld effect would never be tried.
    if campaign.is_study() {
        let by_chi2 = ranked
            .iter()
            .filter(|r| !r.held_back_by_an_edge())
            .min_by(|a, b| a.chi2.total_cmp(&b.chi2))
            .map(|r| r.effects[0]);
        if let Some(best) = by_chi2.filter(|b| Some(b) != pool.first()) {
            push_pairs_with(&mut pairs, best, &library, &[]);
        }
    }
    for a in 1..pool.len() {
        push_pairs_with(&mut pairs, pool[a], &pool[a + 1..], &[]);
    }
    if campaign.every_pair {
        for (k, &a) in library.iter().enumerate() {
            push_pairs_with(&mut pairs, a, &library[k + 1..], &[]);
        }
    }
    if let Some(b) = held.first() {
        admit(&pairs, b, &mut ranked);
        // In a study, the best pair's neighbours too: each of its effects with every other
        // effect, against the same single. A pair whose effects neither predict the conditions
        // left out best alone nor lower the χ² most alone is otherwise never fitted (blind seed
        // 48's second of every pair: docs/decisions/2026-12-04-study-joint-whitening.md).
        let best_pair = best_pair(&ranked).map(|r| r.effects.clone());
        if let (true, Some(best_pair)) = (campaign.is_study() && !campaign.every_pair, best_pair) {
            let mut near: Vec<Vec<Effect>> = Vec::new();
            for &a in &best_pair {
                push_pairs_with(&mut near, a, &library, &pairs);
            }
            admit(&near, b, &mut ranked);
        }
    }
    // In a study, when no single effect or pair passes either: three effects, under the same
    // rule against the best pair. The screen: the best pair and the next PAIR_POOL − 1 pairs
    // admitted as the conditions left out rank them (in good standing or not), and the pair
    // fitted of the lowest χ² of every ride, each with every other effect (every three with
    // `every_triple`); with fewer bases the screen missed triples whose pairs predict the
    // conditions left out poorly (docs/decisions/ranking-rules.md).
    if campaign.is_study() && ranked.first().is_some_and(|b| !passes(b)) {
        let best_pair = best_pair(&ranked).cloned();
        if let Some(pair) = best_pair {
            let triples: Vec<Vec<Effect>> = if campaign.every_triple {
                every_triple(&library)
            } else {
                // The pairs admitted that predict the conditions left out best, in good standing
                // or not, each with every other effect.
                let mut pairs: Vec<&Ranked> = ranked
                    .iter()
                    .filter(|r| r.effects.len() == 2 && !r.not_needed)
                    .collect();
                pairs.sort_by(|a, b| {
                    (a.heldout_rms_after.total_cmp(&b.heldout_rms_after))
                        .then_with(|| a.effect.cmp(&b.effect))
                });
                // And the pair fitted (admitted or not) of the lowest χ² of every ride, none of
                // its parameters where its search stopped at an edge: as with the pairs, a fit
                // whose conditions left out rank it low may hold what a third effect completes.
                let by_chi2 = pair_fits.lock().ok().and_then(|fits| {
                    fits.iter()
                        .filter(|(e, f)| {
                            !campaign
                                .layout(e)
                                .specs
                                .iter()
                                .zip(&f.params)
                                .any(|(spec, &x)| pinned(spec, x))
                        })
                        .min_by(|a, b| a.1.chi2.total_cmp(&b.1.chi2))
                        .map(|(e, _)| e.clone())
                });
                let mut bases: Vec<Vec<Effect>> = std::iter::once(&pair)
                    .chain(pairs.into_iter().take(PAIR_POOL - 1))
                    .map(|p| p.effects.clone())
                    .collect();
                bases.extend(by_chi2.filter(|b| !bases.contains(b)));
                let mut triples: Vec<Vec<Effect>> = Vec::new();
                for p in &bases {
                    for &e in library.iter().filter(|e| !p.contains(e)) {
                        let mut t = p.clone();
                        t.push(e);
                        t.sort();
                        if !triples.contains(&t) {
                            triples.push(t);
                        }
                    }
                }
                triples
            };
            admit(&triples, &pair, &mut ranked);
        }
    }
    Ok(ranked)
}

/// Every three distinct effects of `library`, each sorted, in the library's order.
fn every_triple(library: &[Effect]) -> Vec<Vec<Effect>> {
    let mut out = Vec::new();
    for (i, &a) in library.iter().enumerate() {
        for (j, &b) in library.iter().enumerate().skip(i + 1) {
            for &c in &library[j + 1..] {
                let mut t = vec![a, b, c];
                t.sort();
                out.push(t);
            }
        }
    }
    out
}

/// Candidates in good standing first ([`Ranked::standing`]), pairs not needed after the rest;
/// within each group, in a campaign by the BIC of the fit to every ride plus the plausibility
/// prior's penalty, in a study by the held-out RMS of its conditions left out ([`order_key`]).
fn sort(ranked: &mut [Ranked]) {
    sort_by(ranked, order_key);
}

/// Good standing first, pairs not needed after the rest, each group by `key`, then by name.
fn sort_by(ranked: &mut [Ranked], key: impl Fn(&Ranked) -> f64) {
    ranked.sort_by(|a, b| {
        b.standing()
            .cmp(&a.standing())
            .then(a.not_needed.cmp(&b.not_needed))
            .then_with(|| key(a).total_cmp(&key(b)))
            .then_with(|| a.effect.cmp(&b.effect))
    });
}

/// What orders candidates of one standing. In a campaign, the BIC of the fit to every ride
/// (χ² in the campaign's full covariance plus k ln 2N): the likelihood the fit maximizes, which
/// sees a pattern across rides that the rides left out one at a time miss; plus the
/// plausibility prior's penalty ([`Ranked::prior_penalty`]), so that the prior enters the
/// evidence by the amount the output shows (as −2 ln of a probability, as the BIC is). The held-out
/// prediction still decides whether a pair is needed, whether the best explains the gap and
/// which are tied with it. In a study the conditions left out carry the known change between
/// them, which a fit to every ride weighs no more than a ride: there the held-out RMS orders.
/// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#order_key).
fn order_key(r: &Ranked) -> f64 {
    if r.in_study() {
        r.heldout_rms_after
    } else {
        r.bic + r.prior_penalty
    }
}

/// Whether the rides left out tell `a` from `b`: `a` is better when S = Σᵢ (z²_b,i − z²_a,i),
/// the held-out χ² by which it beats `b`, exceeds [`TIE_CHI2`] and [`TIE_SE`] of its standard
/// deviation had the two been equally right. With the whitened residuals of ride i, r_a and
/// r_b = r_a + dᵢ (dᵢ the two predictions' difference in the ride's standard errors), each
/// term is |dᵢ|² + 2 dᵢ·r_a: its standard deviation is 2|dᵢ| when r_a is pure noise (Vuong's
/// test with the separations known), so S is judged against 2 √Σ|dᵢ|². (A paired t-test on
/// the terms, used before, could never pass with the separation in two rides of 16: its
/// statistic is then 1.46 whatever their size, so the rides recommended to break a tie could
/// not break it.)
pub(super) fn distinguishable(a: &Ranked, b: &Ranked) -> bool {
    let (s, d2) = heldout_contrast(a, b);
    s > TIE_CHI2 && s > TIE_SE * 2.0 * d2.sqrt()
}

/// (S, Σ|dᵢ|²) of the tie test between `a` and `b` (see [`super::Diagnosis::tied`]): the
/// held-out χ² by which `a` beats `b`, and the squared separation of their held-out predictions
/// in the rides' standard errors; the sums of [`ride_contrasts`]. S is infinite when one of
/// the two cannot predict a ride the other can (that ride tells them apart).
pub fn heldout_contrast(a: &Ranked, b: &Ranked) -> (f64, f64) {
    ride_contrasts(a, b)
        .iter()
        .fold((0.0, 0.0), |(s, d2), c| match c {
            Some((si, di)) => (s + si, d2 + di),
            None => (f64::INFINITY, d2),
        })
}

/// Each ride's part of [`heldout_contrast`], in the campaign's order: (z²_b − z²_a, |d|²);
/// `None` where one of the two predicts the ride and the other cannot.
pub fn ride_contrasts(a: &Ranked, b: &Ranked) -> Vec<Option<(f64, f64)>> {
    a.heldout_whitened
        .iter()
        .zip(&b.heldout_whitened)
        .map(|(ra, rb)| {
            (ra.len() == rb.len()).then(|| {
                (
                    rb.iter().map(|x| x * x).sum::<f64>() - ra.iter().map(|x| x * x).sum::<f64>(),
                    ra.iter().zip(rb).map(|(x, y)| (y - x).powi(2)).sum::<f64>(),
                )
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fit stops at its search's edge within [`PINNED_FRACTION`] of the range (the search
    /// clamps there; the held-out refits' differences keep 1e-3 of it clear): the rear frame's
    /// I_xz factor (0.25–2.2) at 0.2539 is there, at 0.26 (its SE aside) it is not.
    #[test]
    fn a_fit_at_the_search_edge_is_pinned() {
        let spec = Effect::FrameIxz.params()[0];
        assert!(pinned(&spec, 0.25));
        assert!(pinned(&spec, 0.2538));
        assert!(pinned(&spec, 2.2 - 3.9e-3));
        assert!(!pinned(&spec, 0.26));
        assert!(!pinned(&spec, 1.0));
    }

    /// A value within its standard error of the search's edge is a bound, shown as one: the
    /// rear frame's I_xz factor (search 0.25–2.2) at 0.3 ± 0.1 is "≤ 0.4"; at 0.9 ± 0.1 it is
    /// an estimate; at the upper edge without a standard error, "≥ 2.2".
    #[test]
    fn a_value_at_the_search_edge_is_a_bound() {
        let spec = Effect::FrameIxz.params()[0];
        assert!(at_bound(&spec, 0.3, 0.1));
        assert!(!at_bound(&spec, 0.9, 0.1));
        assert!(at_bound(&spec, 2.2, f64::INFINITY));
        assert!(!at_bound(&spec, 1.2, f64::INFINITY));
        let text = super::super::effects::bound_text(&spec, 0.3, 0.1);
        assert!(text.starts_with("≤ 0.400 × measured"), "{text}");
        let text = super::super::effects::bound_text(&spec, 2.2, f64::NAN);
        assert!(text.starts_with("≥ 2.200 × measured"), "{text}");
        // A value the rides barely tell is bounded by the search, not past its other edge.
        let text = super::super::effects::bound_text(&spec, 2.2, 5.0);
        assert!(text.starts_with("≥ 0.250 × measured"), "{text}");
    }

    /// The plausibility prior's penalty against its closed form: 0 inside the range; one tail
    /// scale (a quarter of the width) outside with no error, 1; with an error equal to the
    /// scale, half of it; the head angle (±0.035 rad plausible, s = 0.0175 rad) at 0.0875 rad
    /// (3 scales out), 9.
    #[test]
    fn the_prior_costs_its_closed_form() {
        let head = Effect::HeadAngle.params()[0];
        let s = 0.25 * 0.07;
        assert_eq!(head.prior_penalty(0.0349, 0.01), 0.0);
        assert_eq!(head.prior_penalty(-0.035, f64::NAN), 0.0);
        assert!((head.prior_penalty(0.035 + s, 0.0) - 1.0).abs() < 1e-12);
        assert!((head.prior_penalty(-0.035 - s, f64::INFINITY) - 1.0).abs() < 1e-12);
        assert!((head.prior_penalty(0.035 + s, s) - 0.5).abs() < 1e-12);
        assert!((head.prior_penalty(0.0875, 0.0) - 9.0).abs() < 1e-9);
        // An inertia factor (plausible 0.6–1.5, s = 0.225) at 2.0 with an error of 0.1.
        let inertia = Effect::FrameIzz.params()[0];
        let want = 0.5f64.powi(2) / (0.225f64.powi(2) + 0.01);
        assert!((inertia.prior_penalty(2.0, 0.1) - want).abs() < 1e-12);
    }
}
