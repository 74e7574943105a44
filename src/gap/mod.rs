//! Gap stage: where measurement and model part, which unmodelled effect causes it, and how far
//! the gap shrinks once that effect is in the model.
//!
//! In: a campaign's dynamic tests (each ride's weave eigenvalue and mode shape γ/θ with their
//! standard errors, its speed from every source its log offers, [`crate::ride::dynamic`]) and
//! the measured bicycle with its parameters' uncertainty ([`crate::model::uncertain`]). Out: a
//! [`Diagnosis`]:
//! - **where**: each ride's residual (experiment − model: σ, ω, |γ/θ|, arg γ/θ) in units of the
//!   combined standard error (the ride's fit, its speed and the shape's drift over the window,
//!   and the model's from the measured parameters, correlated across rides), the residuals by
//!   speed band, and whether the parameters' own uncertainty could explain the gap;
//! - **whether**: the campaign's test, either the χ² of every ride with that covariance or the
//!   likelihood ratio of the single effect that lowers it most (Bonferroni over the library),
//!   p doubled;
//! - **which**: every effect of [`effects`] fitted to the campaign by generalized least squares
//!   on the eigenvalues and mode shapes, ranked by leave-one-ride-out prediction (each ride
//!   predicted by the effect fitted to the others), pairs of the best effects when no single
//!   one closes the gap, effects the held-out test cannot tell apart reported as tied with the
//!   two rides to make next; an explanation only when the rides left out are predicted within
//!   [`EXPLAINED_HELDOUT_RMS`] and the fit passes the χ² test, "not explained" otherwise;
//! - **how far**: the held-out RMS normalized residual before and after, and the variance of
//!   the rides' θ and γ that the eigenvalues account for.
//!
//! Speeds the lab noted at the release come carried to the eigenvalue's time by the slowing each
//! ride's frame sensor measures, with the reading's resolution and error in their standard
//! error ([`crate::ride::speed`]). The diagnosis uses only linear extensions of the model
//! ([`linear`], [`effects`]); the simulator's nonlinear effects are separate code, and
//! `sim::campaign::blind_campaign` makes the campaigns it is checked on blind.

pub mod effects;
pub mod fit;
pub mod linear;
pub use crate::stats;

use crate::model::uncertain::{Parametrized, WEAVE_PARTS};
use crate::ride::dynamic::{DynamicTest, SpeedSource};
use effects::Effect;
use fit::{fit_effects, param_se, refit_near, Campaign, ResidualCache};
use nalgebra::{Complex, DMatrix, DVector};
use std::fmt::Write as _;

/// One ride's experimental weave, as the dynamic test gave it.
#[derive(Debug, Clone)]
pub struct Observation {
    pub ride: String,
    /// The speed where the eigenvalue applies (m/s): the `Sync` speed, the noted reading plus
    /// `speed_correction_mps`, or the kinematic speed.
    pub speed_mps: f64,
    /// For a noted reading: the slowing from the release to where the eigenvalue applies
    /// (m/s, negative), measured by the ride's frame sensor
    /// ([`crate::ride::speed::slowing`]); 0 otherwise.
    pub speed_correction_mps: f64,
    pub speed_se_mps: f64,
    pub speed_source: SpeedSource,
    /// Every source of the speed the ride's log offers, compared.
    pub speed_sources: crate::ride::speed::SpeedSources,
    pub weave: Complex<f64>,
    pub re_se: f64,
    pub im_se: f64,
    /// The weave's mode shape |γ/θ| and arg(γ/θ) (rad), with the fit's standard errors.
    pub shape_ratio: crate::fit::Estimate,
    pub shape_phase_rad: crate::fit::Estimate,
    /// The fitted window's time (s), roll and steer (rad), for the time-series check.
    pub window: Option<[Vec<f64>; 3]>,
    /// The window's length (s) and the bicycle's forward acceleration over it (m/s²).
    pub window_s: f64,
    pub window_accel_mps2: f64,
}

impl Observation {
    pub fn from_test(ride: &str, t: &DynamicTest) -> Observation {
        Observation {
            ride: ride.to_string(),
            speed_mps: t.speed.speed_mps,
            speed_correction_mps: match (t.speed.source, &t.speed.sources.noted) {
                (SpeedSource::Noted, Some(n)) => n.slowing.delta_mps,
                _ => 0.0,
            },
            speed_se_mps: t.speed.speed_se_mps,
            speed_source: t.speed.source,
            speed_sources: t.speed.sources.clone(),
            weave: Complex::new(t.fit.weave.re, t.fit.weave.im),
            re_se: t.fit.weave.re_se,
            im_se: t.fit.weave.im_se,
            shape_ratio: t.fit.shape.ratio,
            shape_phase_rad: t.fit.shape.phase_rad,
            window_s: t.fit.end_s - t.fit.start_s,
            window_accel_mps2: t.speed.sources.window_accel_mps2,
            window: {
                let rows: Vec<&[f64; 3]> = t
                    .trace
                    .iter()
                    .filter(|r| r[0] >= t.fit.start_s && r[0] <= t.fit.end_s)
                    .collect();
                (rows.len() >= 40).then(|| [0, 1, 2].map(|k| rows.iter().map(|r| r[k]).collect()))
            },
        }
    }
}

impl Observation {
    /// A CSV ride's free decay ([`crate::ride::csv`]): its eigenvalue, its mode shape when it
    /// was fitted from roll and steer (none from the roll rate alone), its speed from the
    /// wheel-speed column or the reading given; `None` without a speed.
    pub fn from_decay(ride: &str, d: &crate::ride::csv::DecaySummary) -> Option<Observation> {
        let (speed, source) = (d.speed_mps?, d.speed_source?);
        let w = &d.decay.weave;
        let none = crate::fit::Estimate {
            value: f64::NAN,
            se: f64::NAN,
        };
        let (a, b) = d.decay.window_s;
        Some(Observation {
            ride: ride.to_string(),
            speed_mps: speed.value,
            speed_correction_mps: 0.0,
            speed_se_mps: speed.se,
            speed_source: source,
            speed_sources: crate::ride::speed::SpeedSources {
                at_s: 0.5 * (a + b),
                noted: None,
                sync: None,
                kinematic: None,
                window_accel_mps2: 0.0,
                disagreements: Vec::new(),
            },
            weave: Complex::new(w.re, w.im),
            re_se: w.re_se,
            im_se: w.im_se,
            shape_ratio: d.decay.shape.map_or(none, |s| s.ratio),
            shape_phase_rad: d.decay.shape.map_or(none, |s| s.phase_rad),
            window: None,
            window_s: b - a,
            window_accel_mps2: 0.0,
        })
    }
}

/// Errors of the diagnosis itself (the model cannot be evaluated).
#[derive(Debug, thiserror::Error)]
pub enum GapError {
    #[error(transparent)]
    Model(#[from] crate::model::ParamError),
    #[error("the covariance of the residuals is not positive definite")]
    Covariance,
}

/// A ride's residual against the unextended model.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RideResidual {
    pub ride: String,
    pub speed_mps: f64,
    /// The correction of a noted speed for the slowing before the window (m/s; 0 for `Sync`).
    pub speed_correction_mps: f64,
    pub speed_se_mps: f64,
    /// The source the speed is taken from, and every source the log offers, compared.
    pub speed_source: SpeedSource,
    pub speed_sources: crate::ride::speed::SpeedSources,
    /// Experiment − model (1/s), real and imaginary parts.
    pub re: f64,
    pub im: f64,
    /// Combined standard errors (experiment, speed and model).
    pub re_se: f64,
    pub im_se: f64,
    pub re_z: f64,
    pub im_z: f64,
    /// The mode shape: |γ/θ| and its phase (rad), experiment − model, with their combined
    /// standard errors (the fit's with its floor, the speed's, the model's from the
    /// parameters; the fit's alone when the shape is left out of the diagnosis).
    pub shape_ratio: f64,
    pub shape_ratio_se: f64,
    pub shape_ratio_z: f64,
    pub shape_phase_rad: f64,
    pub shape_phase_se_rad: f64,
    pub shape_phase_z: f64,
}

/// The residual of a ride's mode shape against `bike` at its weave: (Δ|γ/θ|, Δarg) with the
/// phase difference wrapped to ±π; NaN when the model has no shape there.
fn shape_residual(
    bike: &linear::LinearBike,
    o: &Observation,
    speed_mps: f64,
    weave: Complex<f64>,
) -> (f64, f64) {
    match bike.mode_shape(speed_mps, weave) {
        Some(m) => (
            o.shape_ratio.value - m.norm(),
            crate::signal::wrap_pi(o.shape_phase_rad.value - m.arg()),
        ),
        None => (f64::NAN, f64::NAN),
    }
}

/// The residuals of the rides in one speed band, weighted means.
#[derive(Debug, Clone, serde::Serialize)]
pub struct BandResidual {
    pub speeds_mps: [f64; 2],
    pub rides: usize,
    pub re: crate::fit::Estimate,
    pub im: crate::fit::Estimate,
}

/// One candidate (an effect or a pair) fitted and tested out of sample.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Ranked {
    /// Its name: an effect's, or two joined by " + ".
    pub effect: String,
    pub effects: Vec<Effect>,
    pub params: Vec<f64>,
    pub params_se: Vec<f64>,
    pub units: Vec<&'static str>,
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
    /// standard errors of it.
    pub plausible: bool,
}

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
    /// The campaign's test: the smaller of the χ² test's p and the targeted test's, doubled
    /// (either may find the gap); significant below [`SIGNIFICANCE`].
    pub campaign_p_value: f64,
    /// The variance of θ and γ over the rides' windows that the eigenvalues account for (mean
    /// over rides and the two signals; modes' amplitudes, offsets and trends fitted, eigenvalues
    /// held): the model as it is, and with the best explanation refitted without each ride.
    pub heldout_vaf_before: Option<f64>,
    pub heldout_vaf_after: Option<f64>,
    /// `campaign_p_value` < [`SIGNIFICANCE`].
    pub significant: bool,
    /// The gap is significant without the parameters' uncertainty but not with it.
    pub parameters_could_explain: bool,
    /// Best first.
    pub ranking: Vec<Ranked>,
    /// Candidates the held-out test cannot tell from the best (the best included), when more
    /// than one.
    pub tied: Vec<String>,
    /// The best candidate explains the gap: its held-out RMS normalized residual is at most
    /// [`EXPLAINED_HELDOUT_RMS`] and smaller than without it, and its fit to every ride passes
    /// the χ² test at [`SIGNIFICANCE`]. `false` when the gap is not significant.
    pub explained: bool,
    /// The best candidate's goodness of fit: p of its χ² on 2N − k degrees of freedom.
    pub best_fit_p_value: f64,
    /// When candidates are tied: the rides to make next, where their predictions differ most.
    pub next_rides: NextRides,
    pub verdict: String,
}

/// A candidate that leaves the rides left out further than this from its prediction (RMS, in
/// their standard errors; ≈ 1 when the explanation is right) does not explain the gap.
pub const EXPLAINED_HELDOUT_RMS: f64 = 2.0;

/// How many of its standard errors a fitted value may lie outside its plausible range and
/// still count as plausible.
pub const PLAUSIBLE_SE: f64 = 1.0;

/// The significance level of the campaign's test.
pub const SIGNIFICANCE: f64 = 0.01;
/// The best candidate is told from another when the rides left out favour it by more than this
/// in Σz² …
pub const TIE_CHI2: f64 = 2.0;
/// … and by more than this many of that sum's standard deviations had the two been equally
/// right (`distinguishable`).
pub const TIE_SE: f64 = 2.0;
/// Fewer usable rides than this support no conclusion.
pub const MIN_RIDES: usize = 4;
/// Speeds spanning less than this (m/s) are "a single speed".
pub const MIN_SPEED_SPAN_MPS: f64 = 0.5;
/// Pairs tried: the best single effect with every other, and the next `PAIR_POOL − 1` best
/// among themselves.
const PAIR_POOL: usize = 4;
/// A single effect closes the gap when the rides left out are predicted within this RMS
/// normalized residual (two standard errors); pairs are tried only when none does.
pub const CLOSED_RMS: f64 = 2.0;
/// A pair must beat the best single effect's held-out Σz² by this much (the 1 % point of χ²
/// with one degree of freedom: the pair's extra parameter) and by the BIC.
pub const PAIR_GAIN_CHI2: f64 = 6.63;

/// The experimental mode shape's standard error has at least this relative part in |γ/θ| …
pub const SHAPE_RATIO_FLOOR: f64 = 0.0;
/// … and this much in its phase (rad).
pub const SHAPE_PHASE_FLOOR_RAD: f64 = 0.0;

/// Options of [`diagnose`].
#[derive(Debug, Clone)]
pub struct GapOptions {
    /// Fit and rank on the mode shape as well as the eigenvalue.
    pub shape: bool,
}

impl Default for GapOptions {
    fn default() -> Self {
        GapOptions { shape: true }
    }
}

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

/// A ride to make next, to tell tied candidates apart.
#[derive(Debug, Clone, serde::Serialize)]
pub struct NextRide {
    /// Where the eigenvalue should apply (m/s) …
    pub speed_mps: f64,
    /// … and so the speed to release the bicycle at (m/s): the same less the campaign's mean
    /// slowing between release and window.
    pub release_speed_mps: f64,
    /// For each candidate tied with the best: how far apart their predictions of a ride there
    /// are, in the standard errors the tie test weighs it with (√(δᵀ Σ⁻¹ δ) over the parts;
    /// Σ the fit's and the speed's errors of the campaign's ride nearest that speed and the
    /// model's at that speed), in the order of `tied` without the best.
    pub separation_se: Vec<f64>,
}

/// The rides to make next and what they are expected to achieve.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct NextRides {
    /// Two speeds, best first; empty when nothing is tied.
    pub rides: Vec<NextRide>,
    /// For each candidate tied with the best, in the order of `tied` without the best: the
    /// squared separation Σ|dᵢ|² the campaign's rides already give the pair in the tie test …
    pub separation_now: Vec<f64>,
    /// … and what it takes to expect the test to pass by one of its standard deviations,
    /// [`UNTIE_SEPARATION`].
    pub separation_needed: f64,
    /// Rides at the two speeds, alternately, expected to reach it for every tied pair; `None`
    /// when rides there add (almost) nothing (then the candidates differ no more than the
    /// measured bicycle's own uncertainty lets the model move, and only a better measured
    /// bicycle can tell them apart).
    pub rides_needed: Option<usize>,
}

/// The squared separation Σ|dᵢ|² at which the tie test is expected to pass by one of its
/// standard deviations: S ≈ Σ|dᵢ|² − 2√Σ|dᵢ|² must exceed [`TIE_SE`] · 2√Σ|dᵢ|², so
/// √Σ|dᵢ|² ≥ 2·TIE_SE + 2 (36 with TIE_SE = 2).
pub const UNTIE_SEPARATION: f64 = (2.0 * TIE_SE + 2.0) * (2.0 * TIE_SE + 2.0);

/// More rides than this at the recommended speeds count as "none would do".
const MAX_RIDES_NEEDED: usize = 100;

/// The rides to make next when candidates are tied: two speeds, chosen one after the other on
/// a 0.05 m/s grid from 0.5 m/s below the campaign's slowest ride to 0.5 m/s above its
/// fastest (at least 0.3 m/s apart), each maximizing Σ over the best's tied rivals of
/// min(D, needed), D the squared separation of the two candidates' predictions of a ride
/// there (with the rides already chosen) and "needed" what the pair still lacks of
/// [`UNTIE_SEPARATION`].
///
/// D is weighed as the tie test ([`distinguishable`]) will weigh the ride once made: by its
/// own covariance, the fit's and the speed's errors of the campaign's ride nearest that speed
/// (a ride near the weave speed is measured less well than one above it) plus the model's
/// error at that speed, propagated from the measured parameters. That last part matters: the
/// candidates often differ by less than the measured bicycle's uncertainty moves its weave, and
/// weighing a ride by its fit's errors alone promised three to four times the separation the
/// recommended rides then gave. A ride at that speed is predicted from that nearest ride,
/// speed source and slowing alike.
fn next_rides(
    campaign: &Campaign<'_>,
    exp_cov: &DMatrix<f64>,
    model: &Parametrized,
    ranking: &[Ranked],
    tied: &[String],
) -> NextRides {
    let (Some(best), true) = (ranking.first(), tied.len() > 1) else {
        return NextRides::default();
    };
    let rivals: Vec<&Ranked> = tied
        .iter()
        .filter(|t| **t != best.effect)
        .filter_map(|t| ranking.iter().find(|r| r.effect == *t))
        .collect();
    let separation_now: Vec<f64> = rivals.iter().map(|r| heldout_contrast(best, r).1).collect();
    let needed: Vec<f64> = separation_now
        .iter()
        .map(|now| (UNTIE_SEPARATION - now).max(0.0))
        .collect();
    let obs = campaign.obs;
    let p = campaign.parts;
    // A ride at speed v is expected to be measured as well as the campaign's ride nearest to
    // it: the covariance of its parts (the fit's and the speed's).
    let nearest = |v: f64| -> Option<usize> {
        (0..obs.len()).min_by(|&a, &b| {
            (obs[a].speed_mps - v)
                .abs()
                .total_cmp(&(obs[b].speed_mps - v).abs())
        })
    };
    let block = |m: &DMatrix<f64>, start: usize| m.view((start, start), (p, p)).into_owned();
    let (lo, hi) = obs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), o| {
            (a.min(o.speed_mps), b.max(o.speed_mps))
        });
    let mean_slowing = obs.iter().map(|o| o.speed_correction_mps).sum::<f64>() / obs.len() as f64;
    let predict_at = |r: &Ranked, v: f64, i: usize| -> Option<Vec<f64>> {
        let o = Observation {
            speed_mps: v,
            ..obs[i].clone()
        };
        let bike = effects::linear_bike(campaign.base, &campaign.control, &r.effects, &r.params);
        let guess = linear::LinearBike::whipple(campaign.base)
            .with_control(campaign.control)
            .weave_near(v, campaign.guesses[i])?;
        let (w, shape) = effects::predict_weave(&bike, &r.effects, &r.params, &o, guess, p > 2)?;
        let mut out = vec![w.re, w.im];
        if let Some(s) = shape {
            out.extend([s.norm(), s.arg()]);
        }
        Some(out)
    };
    let grid: Vec<f64> = (0..)
        .map(|k| (lo - 0.5).max(0.5) + 0.05 * k as f64)
        .take_while(|&v| v <= hi + 0.5 + 1e-9)
        .collect();
    // The model's error at every grid speed (one propagation); where it fails, the nearest
    // ride's (its block of the campaign's covariance less the fit's and the speed's).
    let model_at_grid = model.weave_model(&grid).ok();
    // D of each rival at each grid speed.
    let d: Vec<Vec<f64>> = grid
        .iter()
        .enumerate()
        .map(|(k, &v)| {
            let zero = vec![0.0; rivals.len()];
            let Some((i, b)) = nearest(v).and_then(|i| Some((i, predict_at(best, v, i)?))) else {
                return zero;
            };
            let model_block = match &model_at_grid {
                Some(wm) => block(&wm.cov, WEAVE_PARTS * k),
                None => block(&campaign.cov, p * i) - block(exp_cov, p * i),
            };
            let Some(chol) = (block(exp_cov, p * i) + model_block).cholesky() else {
                return zero;
            };
            rivals
                .iter()
                .map(|r| {
                    predict_at(r, v, i).map_or(0.0, |x| {
                        let delta = DVector::from_iterator(
                            b.len(),
                            (0..b.len()).map(|a| {
                                let diff = b[a] - x[a];
                                if a == 3 {
                                    crate::signal::wrap_pi(diff)
                                } else {
                                    diff
                                }
                            }),
                        );
                        chol.l()
                            .solve_lower_triangular(&delta)
                            .map_or(0.0, |w| w.norm_squared())
                    })
                })
                .collect()
        })
        .collect();
    let mut so_far = vec![0.0; rivals.len()];
    let mut rides = Vec::new();
    for _ in 0..2 {
        let gain = |k: usize| -> f64 {
            so_far
                .iter()
                .zip(&d[k])
                .zip(&needed)
                .map(|((s, x), n)| (s + x).min(*n))
                .sum()
        };
        let Some(k) = (0..grid.len())
            .filter(|&k| {
                rides
                    .iter()
                    .all(|n: &NextRide| (n.speed_mps - grid[k]).abs() >= 0.3)
            })
            .max_by(|&a, &b| gain(a).total_cmp(&gain(b)).then(b.cmp(&a)))
        else {
            break;
        };
        for (s, x) in so_far.iter_mut().zip(&d[k]) {
            *s += x;
        }
        rides.push(NextRide {
            speed_mps: grid[k],
            release_speed_mps: grid[k] - mean_slowing,
            separation_se: d[k].iter().map(|x| x.sqrt()).collect(),
        });
    }
    // Rides alternately at the two speeds until every pair has what it needs.
    let rides_needed = (|| {
        let per_ride: Vec<Vec<f64>> = rides
            .iter()
            .map(|r| r.separation_se.iter().map(|x| x * x).collect())
            .collect();
        if per_ride.is_empty() {
            return None;
        }
        let mut got = vec![0.0; rivals.len()];
        for n in 0..=MAX_RIDES_NEEDED {
            if got.iter().zip(&needed).all(|(g, need)| g >= need) {
                return Some(n);
            }
            for (g, x) in got.iter_mut().zip(&per_ride[n % per_ride.len()]) {
                *g += x;
            }
        }
        None
    })();
    NextRides {
        rides,
        separation_now,
        separation_needed: UNTIE_SEPARATION,
        rides_needed,
    }
}

/// The campaign's targeted test: among the single effects of the ranking, the one whose fit
/// lowers the campaign's χ² the most; its likelihood ratio is χ²-distributed with as many
/// degrees of freedom as it has parameters when the model is right (Wilks), and the p-value is
/// multiplied by the number of effects tried. Sets `targeted` and `campaign_p_value`.
fn targeted_test(d: &mut Diagnosis) {
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

/// Runs the dynamic test of every ride of `manifest` (in parallel) and diagnoses the
/// campaign against `model`; `progress(stage, done, total)` with stage "rides" then
/// "candidates".
pub fn diagnose_campaign(
    manifest: &crate::ride::dynamic::RideManifest,
    model: &Parametrized,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<Diagnosis, GapError> {
    let results = crate::ride::dynamic::run_campaign(
        manifest,
        model,
        &crate::ride::modal::ModalOptions::default(),
        &|done, total| progress("rides", done, total),
    );
    diagnose_analysed(&results, model, &|done, total| {
        progress("candidates", done, total)
    })
}

/// Diagnoses a campaign whose rides have been analysed ([`crate::ride::dynamic::run_campaign`])
/// against `model`, with the default options; `progress(done, total)` after each candidate.
pub fn diagnose_analysed(
    results: &[crate::ride::dynamic::CampaignRide],
    model: &Parametrized,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Diagnosis, GapError> {
    let (rides, failed) = observations(results);
    diagnose(&rides, &failed, model, &GapOptions::default(), progress)
}

/// A campaign's analysed rides as observations, and the names and reasons of those that gave
/// none.
pub fn observations(
    results: &[crate::ride::dynamic::CampaignRide],
) -> (Vec<Observation>, Vec<String>) {
    use crate::ride::dynamic::Analysed;
    let mut rides = Vec::new();
    let mut failed = Vec::new();
    for r in results {
        let name = &r.name;
        match &r.result {
            Ok(Analysed::Log(t)) => rides.push(Observation::from_test(name, t)),
            Ok(Analysed::Csv(d)) => match Observation::from_decay(name, d) {
                Some(o) => rides.push(o),
                None => failed.push(format!("{name}: no speed")),
            },
            Err(e) => failed.push(format!("{name}: {e}")),
        }
    }
    (rides, failed)
}

/// Diagnoses a campaign: `rides` are the rides that gave an eigenvalue, `failed` the names and
/// reasons of those that did not. `progress(done, total)` after each candidate.
pub fn diagnose(
    rides: &[Observation],
    failed: &[String],
    model: &Parametrized,
    options: &GapOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Diagnosis, GapError> {
    let n = rides.len();
    let mut d = Diagnosis {
        conclusive: false,
        reason: None,
        rides_used: n,
        rides_failed: failed.to_vec(),
        residuals: Vec::new(),
        residuals_after: Vec::new(),
        bands: Vec::new(),
        chi2: f64::NAN,
        dof: 2 * n,
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
        verdict: String::new(),
    };
    if let Some(reason) = insufficiency(rides, failed) {
        d.verdict = format!("No conclusion: {reason}.");
        d.reason = Some(reason);
        return Ok(d);
    }
    // The model at the rides' speeds, its covariance, and the speeds' contribution.
    let speeds: Vec<f64> = rides.iter().map(|o| o.speed_mps).collect();
    let wm = model.weave_model(&speeds)?;
    let shapes_usable = wm.shapes.iter().all(|s| s.is_finite())
        && rides.iter().all(|o| {
            [o.shape_ratio, o.shape_phase_rad]
                .iter()
                .all(|e| e.value.is_finite() && e.se.is_finite() && e.se > 0.0)
        });
    let parts = if options.shape && shapes_usable { 4 } else { 2 };
    let guesses = wm.weaves.clone();
    let model_idx: Vec<usize> = (0..n)
        .flat_map(|i| (0..parts).map(move |a| WEAVE_PARTS * i + a))
        .collect();
    let model_cov = wm
        .cov
        .select_rows(model_idx.iter())
        .select_columns(model_idx.iter());
    let base = model.nominal();
    let unextended = linear::LinearBike::whipple(&base).with_control(model.control);
    let mut exp_cov = DMatrix::zeros(parts * n, parts * n);
    for (i, o) in rides.iter().enumerate() {
        let standard_errors = [
            o.re_se,
            o.im_se,
            o.shape_ratio
                .se
                .hypot(SHAPE_RATIO_FLOOR * o.shape_ratio.value),
            o.shape_phase_rad.se.hypot(SHAPE_PHASE_FLOOR_RAD),
        ];
        for a in 0..parts {
            exp_cov[(parts * i + a, parts * i + a)] = standard_errors[a].powi(2);
        }
        // The model's weave and shape per m/s of speed at the ride's.
        let h = 1e-4;
        let at = |v: f64| -> Option<[f64; 4]> {
            let w = unextended.weave_near(v, guesses[i])?;
            let s = unextended.mode_shape(v, w)?;
            Some([
                w.re,
                w.im,
                s.norm(),
                crate::signal::wrap_near(s.arg(), wm.shapes[i].arg()),
            ])
        };
        let per_mps: [f64; 4] = match (at(o.speed_mps + h), at(o.speed_mps - h)) {
            (Some(a), Some(b)) => std::array::from_fn(|k| (a[k] - b[k]) / (2.0 * h)),
            _ => [0.0; 4],
        };
        // The shape drifts as the bicycle slows over the window (the fit holds it constant):
        // up to the change over half the window, as the eigenvalue's drift when its own fit
        // fails. Near the weave speed the shape changes fast with speed: without this, rides
        // there made effect-free campaigns "significant".
        let half_change_mps = o.window_accel_mps2.abs() * 0.5 * o.window_s.max(0.0);
        for a in 2..parts {
            exp_cov[(parts * i + a, parts * i + a)] += (per_mps[a] * half_change_mps).powi(2);
        }
        if o.speed_se_mps > 0.0 {
            let g = per_mps.map(|d| d * o.speed_se_mps);
            for a in 0..parts {
                for b in 0..parts {
                    exp_cov[(parts * i + a, parts * i + b)] += g[a] * g[b];
                }
            }
        }
    }
    let all: Vec<usize> = (0..n).collect();
    let campaign = Campaign {
        obs: rides,
        base: &base,
        control: model.control,
        guesses: guesses.clone(),
        parts,
        cov: &exp_cov + &model_cov,
        inverse: std::sync::OnceLock::new(),
    };
    d.parts_per_ride = parts;
    d.dof = parts * n;
    let full = campaign.subset(all.clone()).ok_or(GapError::Covariance)?;
    let r0 = campaign
        .residuals(&[], &[], &all)
        .ok_or(GapError::Covariance)?;
    d.chi2 = full.chi2(&[], &[]);
    d.p_value = stats::chi2_sf(d.chi2, d.dof);
    d.chi2_without_parameter_error = exp_cov
        .clone()
        .cholesky()
        .and_then(|c| c.l().solve_lower_triangular(&r0))
        .map_or(f64::NAN, |w| w.norm_squared());
    d.p_value_without_parameter_error = stats::chi2_sf(d.chi2_without_parameter_error, d.dof);
    d.residuals = rides
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let se = |a: usize| campaign.cov[(parts * i + a, parts * i + a)].sqrt();
            let (re_se, im_se) = (se(0), se(1));
            let (ratio_se, phase_se) = if parts > 2 {
                (se(2), se(3))
            } else {
                (o.shape_ratio.se, o.shape_phase_rad.se)
            };
            let model_weave =
                Complex::new(o.weave.re - r0[parts * i], o.weave.im - r0[parts * i + 1]);
            let (dr, dp) = shape_residual(&unextended, o, o.speed_mps, model_weave);
            RideResidual {
                ride: o.ride.clone(),
                speed_mps: o.speed_mps,
                speed_correction_mps: o.speed_correction_mps,
                speed_se_mps: o.speed_se_mps,
                speed_source: o.speed_source,
                speed_sources: o.speed_sources.clone(),
                re: r0[parts * i],
                im: r0[parts * i + 1],
                re_se,
                im_se,
                re_z: r0[parts * i] / re_se,
                im_z: r0[parts * i + 1] / im_se,
                shape_ratio: dr,
                shape_ratio_se: ratio_se,
                shape_ratio_z: dr / ratio_se,
                shape_phase_rad: dp,
                shape_phase_se_rad: phase_se,
                shape_phase_z: dp / phase_se,
            }
        })
        .collect();
    d.bands = speed_bands(&d.residuals);
    d.conclusive = true;
    d.ranking = rank(&campaign, progress)?;
    targeted_test(&mut d);
    d.significant = d.campaign_p_value < SIGNIFICANCE;
    d.parameters_could_explain = !d.significant && d.p_value_without_parameter_error < SIGNIFICANCE;
    if d.significant {
        d.tied = tied(&d.ranking);
        d.next_rides = next_rides(&campaign, &exp_cov, model, &d.ranking, &d.tied);
    }
    if let Some(best) = d.ranking.first() {
        let k = best.params.len();
        d.best_fit_p_value = stats::chi2_sf(best.chi2, d.dof.saturating_sub(k).max(1));
        d.explained = d.significant
            && best.heldout_rms_after <= EXPLAINED_HELDOUT_RMS
            && best.heldout_rms_after < best.heldout_rms_before
            && d.best_fit_p_value >= SIGNIFICANCE;
        let mean = |v: Vec<Option<f64>>| -> Option<f64> {
            let v: Option<Vec<f64>> = v.into_iter().collect();
            v.filter(|v| !v.is_empty())
                .map(|v| v.iter().sum::<f64>() / v.len() as f64)
        };
        d.heldout_vaf_before = mean(
            rides
                .iter()
                .enumerate()
                .map(|(i, o)| ride_vaf(&unextended, &[], &[], o, guesses[i]))
                .collect(),
        );
        d.heldout_vaf_after = mean(
            rides
                .iter()
                .enumerate()
                .map(|(i, o)| {
                    let params = best.heldout_params.get(i)?;
                    let bike = effects::linear_bike(&base, &model.control, &best.effects, params);
                    ride_vaf(&bike, &best.effects, params, o, guesses[i])
                })
                .collect(),
        );
        if let Some(r) = campaign.residuals(&best.effects, &best.params, &all) {
            let bike = effects::linear_bike(&base, &model.control, &best.effects, &best.params);
            let clock = effects::clock(&best.effects, &best.params);
            d.residuals_after = d
                .residuals
                .iter()
                .enumerate()
                .map(|(i, before)| {
                    let o = &rides[i];
                    let weave =
                        Complex::new(o.weave.re - r[parts * i], o.weave.im - r[parts * i + 1]);
                    let v = effects::true_speed(&best.effects, &best.params, o);
                    let (dr, dp) = shape_residual(&bike, o, v, weave * clock);
                    RideResidual {
                        re: r[parts * i],
                        im: r[parts * i + 1],
                        re_z: r[parts * i] / before.re_se,
                        im_z: r[parts * i + 1] / before.im_se,
                        shape_ratio: dr,
                        shape_ratio_z: dr / before.shape_ratio_se,
                        shape_phase_rad: dp,
                        shape_phase_z: dp / before.shape_phase_se_rad,
                        ..before.clone()
                    }
                })
                .collect();
        }
    }
    d.verdict = verdict(&d);
    Ok(d)
}

/// Why a campaign cannot support a conclusion, if it cannot.
fn insufficiency(rides: &[Observation], failed: &[String]) -> Option<String> {
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

/// Weighted mean residuals in 1 m/s bands.
fn speed_bands(res: &[RideResidual]) -> Vec<BandResidual> {
    let mut bands: Vec<BandResidual> = Vec::new();
    let mut keys: Vec<i64> = res.iter().map(|r| r.speed_mps.floor() as i64).collect();
    keys.sort_unstable();
    keys.dedup();
    for k in keys {
        let inside: Vec<&RideResidual> = res
            .iter()
            .filter(|r| r.speed_mps.floor() as i64 == k)
            .collect();
        bands.push(BandResidual {
            speeds_mps: [k as f64, k as f64 + 1.0],
            rides: inside.len(),
            re: weighted_mean(inside.iter().map(|r| (r.re, r.re_se))),
            im: weighted_mean(inside.iter().map(|r| (r.im, r.im_se))),
        });
    }
    bands
}

/// The inverse-variance weighted mean of `(value, se)` pairs, with its standard error.
pub fn weighted_mean(xs: impl Iterator<Item = (f64, f64)>) -> crate::fit::Estimate {
    let (mut sw, mut swx) = (0.0, 0.0);
    for (x, se) in xs {
        let w = 1.0 / (se * se);
        sw += w;
        swx += w * x;
    }
    crate::fit::Estimate {
        value: swx / sw,
        se: 1.0 / sw.sqrt(),
    }
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
fn ride_vaf(
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

/// Fits and tests every effect, then pairs of the best ones; sorted by held-out RMS.
fn rank(
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
        let se = param_se(&full, &effects, &f);
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
        Some(Ranked {
            effect: name,
            plausible: effects::specs(&effects)
                .iter()
                .zip(f.params.iter().zip(&se))
                .all(|(spec, (&p, &se))| plausible(spec, p, se)),
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
    for r in over(&pairs) {
        if let Some(b) = &best_single {
            if b.heldout_chi2_after - r.heldout_chi2_after > PAIR_GAIN_CHI2 && r.bic < b.bic {
                ranked.push(r);
            }
        }
    }
    sort(&mut ranked);
    Ok(ranked)
}

/// Plausible candidates first (a value no real bicycle or lab would have explains nothing,
/// however well it fits), each group by held-out RMS.
fn sort(ranked: &mut [Ranked]) {
    ranked.sort_by(|a, b| {
        b.plausible
            .cmp(&a.plausible)
            .then_with(|| a.heldout_rms_after.total_cmp(&b.heldout_rms_after))
            .then_with(|| a.effect.cmp(&b.effect))
    });
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
fn distinguishable(a: &Ranked, b: &Ranked) -> bool {
    let (s, d2) = heldout_contrast(a, b);
    s > TIE_CHI2 && s > TIE_SE * 2.0 * d2.sqrt()
}

/// (S, Σ|dᵢ|²) of the tie test between `a` and `b` (see [`Diagnosis::tied`]): the held-out χ²
/// by which `a` beats `b`, and the squared separation of their held-out predictions in the
/// rides' standard errors; the sums of [`ride_contrasts`]. S is infinite when one of the two
/// cannot predict a ride the other can (that ride tells them apart).
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

/// The candidates as plausible as the best that the rides left out cannot tell from it
/// ([`distinguishable`]); empty when only the best.
fn tied(ranked: &[Ranked]) -> Vec<String> {
    let Some(best) = ranked.first() else {
        return Vec::new();
    };
    let t: Vec<String> = ranked
        .iter()
        .filter(|r| r.plausible == best.plausible && !distinguishable(best, r))
        .map(|r| r.effect.clone())
        .collect();
    if t.len() > 1 {
        t
    } else {
        Vec::new()
    }
}

/// What each ride's residual is made of.
fn decided_on(parts: usize) -> &'static str {
    if parts > 2 {
        "the weave's eigenvalue and mode shape"
    } else {
        "the weave's eigenvalue"
    }
}

/// Where the residual the closest candidate leaves lies: the RMS normalized residual of σ, ω
/// and the mode shape's |γ/θ| and phase (the largest named), and the ride furthest from it.
fn where_left(d: &Diagnosis) -> String {
    let res = if d.residuals_after.is_empty() {
        &d.residuals
    } else {
        &d.residuals_after
    };
    let rms = |f: &dyn Fn(&RideResidual) -> f64| -> f64 {
        let v: Vec<f64> = res.iter().map(f).filter(|x| x.is_finite()).collect();
        (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
    };
    let parts = [
        ("the damping rate σ", rms(&|r| r.re_z)),
        ("the frequency ω", rms(&|r| r.im_z)),
        ("the mode shape's |γ/θ|", rms(&|r| r.shape_ratio_z)),
        ("the mode shape's phase", rms(&|r| r.shape_phase_z)),
    ];
    let (worst_part, worst_rms) = parts
        .iter()
        .copied()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or(("", f64::NAN));
    let worst_ride = res
        .iter()
        .max_by(|a, b| (a.re_z.hypot(a.im_z)).total_cmp(&b.re_z.hypot(b.im_z)));
    let mut out = format!(
        "Left: what is left lies most in {worst_part} (RMS {worst_rms:.1} standard errors; σ {:.1}, ω {:.1}, |γ/θ| {:.1}, phase {:.1})",
        parts[0].1, parts[1].1, parts[2].1, parts[3].1
    );
    if let Some(r) = worst_ride {
        let _ = write!(
            out,
            "; the ride furthest from it is {} at {:.2} m/s ({:+.1}, {:+.1} standard errors in σ, ω)",
            r.ride, r.speed_mps, r.re_z, r.im_z
        );
    }
    out.push('.');
    out
}

/// The diagnosis in words.
fn verdict(d: &Diagnosis) -> String {
    let mut v = String::new();
    let part = |name: &str, unit: &str, sel: &dyn Fn(&RideResidual) -> (f64, f64, f64)| {
        let beyond = d.residuals.iter().filter(|r| sel(r).2.abs() > 2.0).count();
        let m = weighted_mean(d.residuals.iter().map(|r| {
            let (x, se, _) = sel(r);
            (x, se)
        }));
        let (mean, se) = (m.value, m.se);
        let dir = if mean < 0.0 { "lower" } else { "higher" };
        format!(
            "{name} {dir} than the model's by {:.3} ± {:.3} {unit} on average ({beyond} of {} rides beyond 2σ)",
            mean.abs(),
            se,
            d.residuals.len()
        )
    };
    let shape = if d.residuals.iter().any(|r| r.shape_ratio_z.is_finite()) {
        part("mode shape |γ/θ|", "rad/rad", &|r| {
            (r.shape_ratio, r.shape_ratio_se, r.shape_ratio_z)
        })
    } else {
        "mode shape not measured (the rides give the eigenvalue alone)".to_string()
    };
    let _ = writeln!(
        v,
        "Where: {}; {}; {}.",
        part("weave frequency", "rad/s", &|r| (r.im, r.im_se, r.im_z)),
        part("weave damping rate (σ)", "1/s", &|r| (
            r.re, r.re_se, r.re_z
        )),
        shape
    );
    let _ = write!(
        v,
        "Test: campaign χ² = {:.1} for {} degrees of freedom ({}; {} of each ride, the measured parameters' uncertainty included)",
        d.chi2,
        d.dof,
        stats::p_is(d.p_value),
        decided_on(d.parts_per_ride)
    );
    if let Some(t) = &d.targeted {
        let _ = write!(
            v,
            "; the single effect that lowers it most, {}, by a likelihood ratio of {:.1} on {} degree{} of freedom ({} for the best of the effects tried)",
            t.effect,
            t.likelihood_ratio,
            t.dof,
            if t.dof == 1 { "" } else { "s" },
            stats::p_is(t.p_value)
        );
    }
    let _ = write!(
        v,
        "; the campaign's test, either of the two: {}: ",
        stats::p_is(d.campaign_p_value)
    );
    if !d.significant {
        v.push_str(if d.parameters_could_explain {
            "no significant gap; without the parameters' uncertainty there would be one, so it is within what the inertia measurements allow."
        } else {
            "no significant gap."
        });
        return v;
    }
    v.push_str(
        "a significant gap, which the measured parameters' own uncertainty cannot explain.\n",
    );
    let Some(best) = d.ranking.first() else {
        v.push_str("Which: no candidate could be fitted.");
        return v;
    };
    let named: Vec<(Effect, effects::ParamSpec)> = best
        .effects
        .iter()
        .flat_map(|&e| e.params().into_iter().map(move |p| (e, p)))
        .collect();
    let params: Vec<String> = named
        .iter()
        .zip(best.params.iter().zip(&best.params_se))
        .map(|((e, spec), (p, se))| {
            format!(
                "{} {} = {}",
                e.name(),
                spec.name,
                param_text(*p, *se, spec.unit)
            )
        })
        .collect();
    let shrink = 1.0 - best.heldout_rms_after / best.heldout_rms_before;
    if !d.explained {
        let _ = write!(
            v,
            "Which: no candidate of the library explains it; the closest is {} ({}).\nHow far: it leaves the rides left out at an RMS of {:.2} standard errors (from {:.2}; an explanation brings it to about 1, at most {EXPLAINED_HELDOUT_RMS}), and its fit to every ride gives χ² = {:.1} ({}).\n",
            best.effect,
            params.join(", "),
            best.heldout_rms_after,
            best.heldout_rms_before,
            best.chi2,
            stats::p_is(d.best_fit_p_value)
        );
        v.push_str(&where_left(d));
        v.push_str(&next_rides_text(d));
        return v;
    }
    if d.tied.len() > 1 {
        let _ = write!(
            v,
            "Which: the rides left out cannot tell apart {} (none is worse than the best by {TIE_SE} standard deviations of the held-out χ² difference its predictions' separation allows); the best of them is ",
            d.tied.join(", ")
        );
    } else {
        v.push_str("Which: the best explanation is ");
    }
    let _ = write!(
        v,
        "{} ({}), {}.\nHow far: held-out RMS normalized residual {:.2} → {:.2} standard errors ({:.0} % smaller).",
        best.effect,
        params.join(", "),
        if best.plausible {
            "a physically plausible value"
        } else {
            "a value outside the plausible range"
        },
        best.heldout_rms_before,
        best.heldout_rms_after,
        100.0 * shrink
    );
    if let (Some(a), Some(b)) = (d.heldout_vaf_before, d.heldout_vaf_after) {
        let _ = write!(
            v,
            " In the time series, the eigenvalues account for {:.1} % of θ's and γ's variance before and {:.1} % after.",
            100.0 * a,
            100.0 * b
        );
    }
    v.push_str(&next_rides_text(d));
    v
}

/// The next rides in words (empty when none are recommended).
fn next_rides_text(d: &Diagnosis) -> String {
    let next = &d.next_rides;
    if next.rides.is_empty() {
        return String::new();
    }
    let rides: Vec<String> = next
        .rides
        .iter()
        .map(|n| {
            let most = n.separation_se.iter().copied().fold(0.0, f64::max);
            format!(
                "{:.2} m/s where the eigenvalue applies (release at about {:.1} m/s; a ride there sets the tied candidates' predictions up to {most:.1} of its standard errors apart)",
                n.speed_mps, n.release_speed_mps
            )
        })
        .collect();
    let least = next
        .separation_now
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    let how_many = match next.rides_needed {
        Some(n) => format!(
            "about {n} rides there, alternately, are expected to tell them apart (the rides so far give the closest pair a squared separation of {least:.1} of the {:.0} the test needs)",
            next.separation_needed
        ),
        None => format!(
            "no number of rides is: the rides so far give the closest pair a squared separation of {least:.1} of the {:.0} the test needs, and more rides add almost nothing, because the candidates differ by less than the measured bicycle's own uncertainty moves its weave; measure the bicycle better",
            next.separation_needed
        ),
    };
    format!(
        "\nNext: the rides that best tell the tied candidates apart are at {}; {how_many}.",
        rides.join(" and at ")
    )
}

impl Diagnosis {
    /// The human-readable form.
    pub fn to_text(&self) -> String {
        let mut out = String::new();
        if !self.conclusive {
            let _ = writeln!(out, "{}", self.verdict);
            for f in &self.rides_failed {
                let _ = writeln!(out, "  not analysed: {f}");
            }
            return out;
        }
        let _ = writeln!(
            out,
            "Where: experiment − model, in combined standard errors ({} rides)",
            self.rides_used
        );
        let _ = writeln!(
            out,
            "  {:<10} {:>9} {:>18} {:>6} {:>18} {:>6} {:>18} {:>6} {:>16} {:>6}",
            "ride",
            "speed m/s",
            "Δσ 1/s",
            "z",
            "Δω rad/s",
            "z",
            "Δ|γ/θ| rad/rad",
            "z",
            "Δarg(γ/θ) °",
            "z"
        );
        for r in &self.residuals {
            let shape = if r.shape_ratio.is_finite() {
                format!(
                    "{:>+8.3} ± {:<7.3} {:>+6.1} {:>+6.1} ± {:<5.1} {:>+6.1}",
                    r.shape_ratio,
                    r.shape_ratio_se,
                    r.shape_ratio_z,
                    r.shape_phase_rad.to_degrees(),
                    r.shape_phase_se_rad.to_degrees(),
                    r.shape_phase_z
                )
            } else {
                "      not measured".to_string()
            };
            let _ = writeln!(
                out,
                "  {:<10} {:>9.3} {:>8.3} ± {:<7.3} {:>+6.1} {:>8.3} ± {:<7.3} {:>+6.1} {shape}",
                r.ride, r.speed_mps, r.re, r.re_se, r.re_z, r.im, r.im_se, r.im_z,
            );
        }
        for b in &self.bands {
            let _ = writeln!(
                out,
                "  band {:.0}–{:.0} m/s ({} rides): Δσ {:.3} ± {:.3}, Δω {:.3} ± {:.3}",
                b.speeds_mps[0], b.speeds_mps[1], b.rides, b.re.value, b.re.se, b.im.value, b.im.se
            );
        }
        let _ = writeln!(
            out,
            "  χ² {:.1} / {} (p {}); without the parameters' uncertainty {:.1} (p {})",
            self.chi2,
            self.dof,
            stats::format_p(self.p_value),
            self.chi2_without_parameter_error,
            stats::format_p(self.p_value_without_parameter_error)
        );
        if let Some(t) = &self.targeted {
            let _ = writeln!(
                out,
                "  targeted: {} lowers χ² by {:.1} on {} dof (p {} over the single effects tried); the campaign's test p {}",
                t.effect,
                t.likelihood_ratio,
                t.dof,
                stats::format_p(t.p_value),
                stats::format_p(self.campaign_p_value)
            );
        }
        let _ = writeln!(
            out,
            "Which: candidates fitted on {} by held-out RMS normalized residual (in standard errors;\n  pairs of effects are listed only where they beat the best single one on the rides left out)",
            decided_on(self.parts_per_ride)
        );
        let _ = writeln!(
            out,
            "  {:<28} {:>30} {:>8} {:>8} {:>9}",
            "effect", "parameters", "before", "after", "plausible"
        );
        for r in &self.ranking {
            let params: Vec<String> = r
                .params
                .iter()
                .zip(&r.params_se)
                .zip(&r.units)
                .map(|((p, se), u)| param_text(*p, *se, u))
                .collect();
            let _ = writeln!(
                out,
                "  {:<28} {:>30} {:>8.2} {:>8.2} {:>9}",
                r.effect,
                params.join(", "),
                r.heldout_rms_before,
                r.heldout_rms_after,
                if r.plausible { "yes" } else { "no" }
            );
        }
        for f in &self.rides_failed {
            let _ = writeln!(out, "  not analysed: {f}");
        }
        let _ = writeln!(out, "Verdict:");
        for line in self.verdict.lines() {
            let _ = writeln!(out, "  {line}");
        }
        out
    }
}

/// A fitted parameter with its standard error and unit, `0.092 ± 0.061 kg·m²`; one the fit left
/// at the edge of its search range (or could not identify) has no standard error, and says so.
pub fn param_text(value: f64, se: f64, unit: &str) -> String {
    let unit = if unit.is_empty() {
        String::new()
    } else {
        format!(" {unit}")
    };
    if se.is_finite() {
        format!("{value:.3} ± {se:.3}{unit}")
    } else {
        format!("{value:.3}{unit} (no standard error: at a bound or not identified)")
    }
}
