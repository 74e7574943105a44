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
//!   likelihood ratio of the single effect that lowers it most, the smallest p calibrated on
//!   draws of the residuals with no effect present (the effects' correlations counted);
//! - **which**: every effect of [`effects`] fitted to the campaign by generalized least squares
//!   on the eigenvalues and mode shapes, ranked by the BIC of that fit (in a study, by
//!   predicting each condition from the others), tested by leave-one-ride-out prediction (each
//!   ride predicted by the effect fitted to the others), pairs ([`PairSearch`]) when no single
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
//!
//! - **the instrument first**: each condition's mode shape against the model and the
//!   candidates; a shape that misses every one by a common factor is recorded otherwise than
//!   the model assumes (a sign, a unit, a controller's model), and the condition is
//!   diagnosed on its eigenvalue alone ([`instrument`]).
//!
//! The stages, one file each: [`observe`] (the rides as observations, their residual types),
//! [`significance`] (too thin to conclude on; the campaign's test), [`fit`] (the candidates'
//! generalized least squares), [`rank`] (fitted, held out, ordered), [`ties`] (which the rides
//! cannot tell apart, and the rides to make next), [`instrument`] (the shape's conventions
//! checked), [`verdict`] (the words); this file runs them
//! in order ([`diagnose`]).

pub mod coasting;
pub mod conditions;
pub mod diagnosis;
pub mod effects;
pub mod error;
pub mod experiment;
pub mod fit;
pub mod instrument;
pub mod linear;
pub mod observe;
pub mod rank;
pub mod significance;
pub mod speed_grid;
pub mod thresholds;
pub mod ties;
pub mod verdict;
pub use crate::stats;
pub use diagnosis::{ConditionSummary, Diagnosis};
pub use effects::param_text;
pub use error::GapError;
pub use observe::{observations, weighted_mean, BandResidual, Observation, RideResidual};
pub use rank::Ranked;
pub use rank::{heldout_contrast, ride_contrasts};
pub use significance::{DetectionLimit, TargetedTest};
pub use thresholds::*;
pub use ties::{NextRide, NextRides, UNTIE_SEPARATION};

use crate::model::uncertain::{Parametrized, WEAVE_PARTS};
use fit::Campaign;
use nalgebra::Complex;
use observe::{shape_residual, speed_bands};
use rank::{rank, ride_vaf};
use significance::{insufficiency, targeted_test};
use ties::{next_rides, tied};
use verdict::verdict;

/// Options of [`diagnose`].
#[derive(Debug, Clone)]
pub struct GapOptions {
    /// Fit and rank on the mode shape as well as the eigenvalue.
    pub shape: bool,
    /// The rides from which a ride left out is refitted by a Newton step taken unchecked
    /// ([`fit::refit_near`]; [`fit::TRUSTED_NEWTON_RIDES`] by default, `usize::MAX` to check
    /// every step).
    pub trusted_newton_rides: usize,
    /// Predict a condition with many rides from a grid of speeds where that is exact to
    /// [`speed_grid::TOLERANCE`] (true by default; false to solve every ride's eigenproblem).
    pub speed_grid: bool,
    /// Which pairs are fitted where no single effect closes the gap ([`PairSearch`]).
    pub pairs: PairSearch,
}

impl Default for GapOptions {
    fn default() -> Self {
        GapOptions {
            shape: true,
            trusted_newton_rides: fit::TRUSTED_NEWTON_RIDES,
            speed_grid: true,
            pairs: PairSearch::Standard,
        }
    }
}

/// Which pairs (and, in a study, triples) of effects a campaign or study fits where no single
/// effect (pair) closes the gap. Every way admits a candidate under the same rule (it beats the
/// best single's (pair's) held-out Σz² by [`thresholds::PAIR_GAIN_CHI2`] and its BIC); they
/// differ in which are fitted at all. The records: docs/decisions/2026-12-02-pair-search.md,
/// docs/decisions/2026-12-03-study-triples.md.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PairSearch {
    /// Every pair in a single campaign, the screen in a study: the screen missed the
    /// exhaustive search's first pair in 2 of the 4 blind campaigns that tried pairs, and
    /// matches its first five on the real balance-assist study and the 100 blind motor and
    /// effect-free studies of the calibration's seeds, where fitting every pair takes twice the
    /// time (`tests/pair_search.rs`). In a study where
    /// no pair passes, three effects: the best pair, the next three pairs admitted (held out)
    /// and the pair fitted of the lowest χ² of every ride, each with every other effect.
    #[default]
    Standard,
    /// The screen everywhere: the best single (held out) with every other effect, the next
    /// [`PAIR_POOL`]` − 1` among themselves and, in a study, the single of the lowest χ² with
    /// every other, then each effect of the best pair with every other: 20–70 pairs.
    Screen,
    /// Every pair of the library everywhere (23 effects with a controller: 253 pairs; 19
    /// without: 171); three effects as [`PairSearch::Standard`] tries them.
    Every,
    /// Every pair, and in a study where no pair passes every three effects of the library
    /// (1,771 with a controller): 40 s where the standard search takes 5 s on the balance-assist
    /// study, whose first five the screen returns (docs/decisions/2026-12-04-study-joint-whitening.md).
    EveryTriple,
}

impl PairSearch {
    /// Whether every pair is fitted, in a study (`is_study`) or a single campaign.
    pub fn every_pair(self, is_study: bool) -> bool {
        match self {
            PairSearch::Standard => !is_study,
            PairSearch::Screen => false,
            PairSearch::Every | PairSearch::EveryTriple => true,
        }
    }
}

/// Runs the dynamic test of every ride of `manifest` (in parallel) and diagnoses the
/// campaign against `model`; `progress(stage, done, total)` with stage "rides" then
/// "candidates".
pub fn diagnose_campaign(
    manifest: &crate::read::rides::RideManifest,
    model: &Parametrized,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<Diagnosis, GapError> {
    diagnose_campaign_with(manifest, model, &GapOptions::default(), progress)
}

/// [`diagnose_campaign`] with `options`.
pub fn diagnose_campaign_with(
    manifest: &crate::read::rides::RideManifest,
    model: &Parametrized,
    options: &GapOptions,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<Diagnosis, GapError> {
    let results = crate::ride::dynamic::run_campaign(
        manifest,
        model,
        &crate::ride::modal::ModalOptions::default(),
        &|done, total| progress("rides", done, total),
    );
    let (rides, failed) = observations(&results);
    let one = [StudyCondition {
        steer_motor: manifest.steer_motor,
        ..StudyCondition::of_model(model, rides, failed)
    }];
    diagnose_study(&one, model, options, &|done, total| {
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

/// Diagnoses a campaign: `rides` are the rides that gave an eigenvalue, `failed` the names and
/// reasons of those that did not. `progress(done, total)` after each candidate.
pub fn diagnose(
    rides: &[Observation],
    failed: &[String],
    model: &Parametrized,
    options: &GapOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Diagnosis, GapError> {
    let one = [StudyCondition::of_model(
        model,
        rides.to_vec(),
        failed.to_vec(),
    )];
    diagnose_study(&one, model, options, progress)
}

/// One condition of a study as it enters the diagnosis: its name, its controller, the rides
/// that gave an eigenvalue and the names and reasons of those that did not.
#[derive(Debug, Clone)]
pub struct StudyCondition {
    pub name: String,
    pub control: crate::model::SteerControl,
    /// Known masses added to the bicycle in this condition (its manifest's `[[known_mass]]`).
    pub masses: Vec<crate::model::params::PointMass>,
    pub rides: Vec<Observation>,
    pub failed: Vec<String>,
    /// The bicycle's steer motor as its manifest declares it (`[steer_motor]`): the range of
    /// the inertia it adds about the steer axis follows from it ([`conditions::Layout::new`]).
    pub steer_motor: Option<crate::model::control::SteerMotorSpec>,
}

impl StudyCondition {
    /// A single campaign's one condition: named after `model`, with its controller, no known
    /// mass and no motor declared.
    pub fn of_model(model: &Parametrized, rides: Vec<Observation>, failed: Vec<String>) -> Self {
        StudyCondition {
            name: model.name.clone(),
            control: model.control,
            masses: Vec::new(),
            rides,
            failed,
            steer_motor: None,
        }
    }
}

/// Runs the dynamic test of every ride of each manifest (a condition each, named by its
/// manifest's stem, with its controller) and diagnoses them together against `model` (the
/// bicycle they share); `progress(stage, done, total)` as [`diagnose_campaign`].
pub fn diagnose_manifests(
    manifests: &[(String, crate::read::rides::RideManifest)],
    model: &Parametrized,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<Diagnosis, GapError> {
    diagnose_manifests_with(manifests, model, &GapOptions::default(), progress)
}

/// [`diagnose_manifests`] with `options`.
pub fn diagnose_manifests_with(
    manifests: &[(String, crate::read::rides::RideManifest)],
    model: &Parametrized,
    options: &GapOptions,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<Diagnosis, GapError> {
    let conditions = study_conditions(manifests, model, progress);
    diagnose_study(&conditions, model, options, &|done, total| {
        progress("candidates", done, total)
    })
}

/// The conditions of a study as they enter the diagnosis: each manifest's rides run through
/// their dynamic tests (in parallel) on `model` with the condition's known masses and
/// controller, named by the manifest's stem; `progress("rides of NAME", done, total)`.
pub fn study_conditions(
    manifests: &[(String, crate::read::rides::RideManifest)],
    model: &Parametrized,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Vec<StudyCondition> {
    manifests
        .iter()
        .map(|(name, manifest)| {
            let controlled = model
                .clone()
                .with_masses(&manifest.known_masses)
                .with_control(manifest.control);
            let results = crate::ride::dynamic::run_campaign(
                manifest,
                &controlled,
                &crate::ride::modal::ModalOptions::default(),
                &|done, total| progress(&format!("rides of {name}"), done, total),
            );
            let (rides, failed) = observations(&results);
            StudyCondition {
                name: name.clone(),
                control: manifest.control,
                masses: manifest.known_masses.clone(),
                rides,
                failed,
                steer_motor: manifest.steer_motor,
            }
        })
        .collect()
}

/// Diagnoses the conditions of a study together (one condition: a single campaign, as
/// [`diagnose`]): the bicycle's effects shared, each condition's own equipment fitted per
/// condition ([`conditions`]), and with two or more conditions each predicted from the others.
/// The instrument is checked first ([`instrument`]): a condition whose mode shape misses
/// every candidate by a common factor is diagnosed again on its eigenvalue alone, and the
/// diagnosis says why ([`Diagnosis::instrument`]).
///
/// A condition none of whose rides gave an eigenvalue is left out while two or more others
/// have rides: it tells nothing of the bicycle, and its own equipment (a controller's
/// delivered gain) would enter every candidate as a parameter no ride constrains, counted in
/// the BIC and printed with a value and no error (blind study 7, its G = 1 rides all falling
/// within a cycle). It stays listed among the conditions with its failures, and the verdict
/// says so.
pub fn diagnose_study(
    study: &[StudyCondition],
    model: &Parametrized,
    options: &GapOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Diagnosis, GapError> {
    let with_rides = study.iter().filter(|c| !c.rides.is_empty()).count();
    if with_rides == study.len() || with_rides < 2 {
        return diagnose_conditions(study, model, options, progress);
    }
    let kept: Vec<StudyCondition> = study
        .iter()
        .filter(|c| !c.rides.is_empty())
        .cloned()
        .collect();
    let mut d = diagnose_conditions(&kept, model, options, progress)?;
    let mut left_out = Vec::new();
    for (at, c) in study.iter().enumerate().filter(|(_, c)| c.rides.is_empty()) {
        d.conditions.insert(
            at.min(d.conditions.len()),
            ConditionSummary {
                name: c.name.clone(),
                controlled: !c.control.is_none(),
                rides_used: 0,
                rides_failed: c.failed.clone(),
                chi2: 0.0,
                dof: 0,
                scatter_alone: Vec::new(),
            },
        );
        left_out.push(format!(
            "{} ({} rides, none usable)",
            c.name,
            c.failed.len()
        ));
    }
    d.rides_failed = pooled(study).2;
    d.verdict.push_str(&format!(
        "\nLeft out: condition{} {}: without an eigenvalue it tells nothing of the bicycle, \
         and its own equipment is not fitted.",
        if left_out.len() > 1 { "s" } else { "" },
        left_out.join(", ")
    ));
    Ok(d)
}

/// [`diagnose_study`] on conditions that each have rides (or all of them, as given).
fn diagnose_conditions(
    study: &[StudyCondition],
    model: &Parametrized,
    options: &GapOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Diagnosis, GapError> {
    let mut shape_off = vec![false; study.len()];
    let mut missed: Vec<instrument::ShapeCheck> = Vec::new();
    loop {
        match diagnose_pass(study, model, options, &shape_off, progress)? {
            Pass::Diagnosed(mut d, checks) => {
                // Each shape set aside, against the best candidate of the eigenvalues alone.
                let (after, best) = match d.ranking.first() {
                    Some(b) if !d.residuals_after.is_empty() => {
                        (&d.residuals_after, b.effect.as_str())
                    }
                    _ => (&d.residuals, "none"),
                };
                for check in &mut missed {
                    let c = study.iter().position(|c| c.name == check.condition);
                    let ratio = |r: &RideResidual| {
                        let cond = c.map(|c| &study[c])?;
                        let o = cond.rides.iter().find(|o| o.ride == r.ride)?;
                        Some(o.shape_ratio.value)
                    };
                    let condition = (study.len() > 1).then_some(check.condition.as_str());
                    check.against_eigenvalue_fit =
                        instrument::common_factor_of(after, condition, best, &ratio);
                    check.convention = check
                        .against_eigenvalue_fit
                        .as_ref()
                        .and_then(instrument::convention);
                    if let (None, Some(c)) = (check.convention, c) {
                        if without_controller(&study[c], model)
                            .is_some_and(|f| instrument::agrees(&f))
                        {
                            check.convention = Some(instrument::Convention::ControllerModel);
                        }
                    }
                }
                missed.extend(checks);
                let order = |name: &str| study.iter().position(|c| c.name == name);
                missed.sort_by_key(|c| order(&c.condition));
                d.instrument = missed;
                // (A campaign too thin to conclude on keeps its pass's "No conclusion".)
                if d.conclusive {
                    d.verdict = verdict(&d);
                }
                return Ok(*d);
            }
            Pass::ShapeMisses(checks) => {
                for check in checks.into_iter().filter(|c| c.misses) {
                    if let Some(c) = study.iter().position(|c| c.name == check.condition) {
                        shape_off[c] = true;
                    }
                    missed.push(check);
                }
            }
        }
    }
}

/// A study's rides pooled in the order of its conditions, each ride's condition, and the rides
/// that failed (in a study named with their condition).
fn pooled(study: &[StudyCondition]) -> (Vec<Observation>, Vec<usize>, Vec<String>) {
    let is_study = study.len() > 1;
    let rides: Vec<Observation> = study.iter().flat_map(|c| c.rides.clone()).collect();
    let ride_condition: Vec<usize> = study
        .iter()
        .enumerate()
        .flat_map(|(c, cond)| std::iter::repeat_n(c, cond.rides.len()))
        .collect();
    let failed: Vec<String> = study
        .iter()
        .flat_map(|c| {
            c.failed.iter().map(move |f| {
                if is_study {
                    format!("{}: {f}", c.name)
                } else {
                    f.clone()
                }
            })
        })
        .collect();
    (rides, ride_condition, failed)
}

/// Each condition's model as the candidates extend it: the measured bicycle with its known
/// masses at their values (the nominal's errors kept), its controller, and whether its rides'
/// speeds were read (a speedometer's scale can apply).
fn condition_models(
    study: &[StudyCondition],
    per_condition: &[(Parametrized, Vec<f64>)],
    model: &Parametrized,
) -> Vec<conditions::ConditionModel> {
    let base = model.nominal();
    study
        .iter()
        .zip(per_condition)
        .map(|(c, (m, _))| conditions::ConditionModel {
            name: c.name.clone(),
            base: crate::model::Benchmark {
                se: base.se,
                ..m.benchmark_at(m.inputs.values())
            },
            control: c.control,
            steer_motor: c.steer_motor,
            read_speeds: c.rides.iter().any(|o| {
                matches!(
                    o.speed_source,
                    crate::ride::dynamic::SpeedSource::Noted
                        | crate::ride::dynamic::SpeedSource::WheelSpeed
                        | crate::ride::dynamic::SpeedSource::Set
                )
            }),
        })
        .collect()
}

/// Each condition of a study on its own: its rides, its χ² against the unextended model (its
/// block of the campaign's covariance) and the scatter between its own repeated kicks.
fn condition_summaries(study: &[StudyCondition], campaign: &Campaign<'_>) -> Vec<ConditionSummary> {
    let (rides, parts) = (campaign.obs, &campaign.parts);
    study
        .iter()
        .enumerate()
        .map(|(c, cond)| {
            let own = campaign.rides_of(c);
            ConditionSummary {
                name: cond.name.clone(),
                controlled: !cond.control.is_none(),
                rides_used: cond.rides.len(),
                rides_failed: cond.failed.clone(),
                chi2: campaign
                    .subset(own.clone())
                    .map_or(f64::NAN, |s| s.chi2(&[], &[])),
                dof: parts.count(&own),
                scatter_alone: {
                    let own_rides: Vec<Observation> =
                        own.iter().map(|&i| rides[i].clone()).collect();
                    observe::between_kick_scatter(
                        &own_rides,
                        &vec![0; own_rides.len()],
                        parts.most(),
                        &experiment::fit_se,
                    )
                    .map_or(Vec::new(), |s| s.per_part)
                },
            }
        })
        .collect()
}

/// Each ride's residual against the unextended model (`r0`, in the order of the campaign's
/// parts) with its combined standard errors; a ride whose shape the diagnosis leaves out gets
/// its shape's residual against `unextended` with the fit's own errors.
fn residuals_before(
    campaign: &Campaign<'_>,
    r0: &nalgebra::DVector<f64>,
    unextended: &[linear::LinearBike],
    study: &[StudyCondition],
) -> Vec<RideResidual> {
    let (rides, parts, ride_condition) = (campaign.obs, &campaign.parts, &campaign.ride_condition);
    let is_study = study.len() > 1;
    rides
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let at = parts.start(i);
            let se = |a: usize| campaign.cov()[(at + a, at + a)].sqrt();
            let (re_se, im_se) = (se(0), se(1));
            let (ratio_se, phase_se) = if parts.of(i) > 2 {
                (se(2), se(3))
            } else {
                (o.shape_ratio.se, o.shape_phase_rad.se)
            };
            let model_weave = Complex::new(o.weave.re - r0[at], o.weave.im - r0[at + 1]);
            let (dr, dp) = if parts.of(i) > 2 {
                (r0[at + 2], r0[at + 3])
            } else {
                shape_residual(&unextended[ride_condition[i]], o, o.speed_mps, model_weave)
            };
            RideResidual::of(
                o,
                is_study.then(|| study[ride_condition[i]].name.clone()),
                [r0[at], r0[at + 1], dr, dp],
                [re_se, im_se, ratio_se, phase_se],
            )
        })
        .collect()
}

/// What the best candidate makes of the campaign: its goodness of fit, whether it explains the
/// gap, the variance of θ and γ the eigenvalues account for before and with it (each ride from
/// the fit without it), and each ride's residual with it.
fn with_best(d: &mut Diagnosis, campaign: &Campaign<'_>, unextended: &[linear::LinearBike]) {
    let Some(best) = d.ranking.first() else {
        return;
    };
    let (rides, parts, ride_condition) = (campaign.obs, &campaign.parts, &campaign.ride_condition);
    let guesses = &campaign.guesses;
    let all: Vec<usize> = (0..rides.len()).collect();
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
            .map(|(i, o)| ride_vaf(&unextended[ride_condition[i]], &[], &[], o, guesses[i]))
            .collect(),
    );
    let layout = campaign.layout(&best.effects);
    d.heldout_vaf_after = mean(
        rides
            .iter()
            .enumerate()
            .map(|(i, o)| {
                let params = best.heldout_params.get(i)?;
                let (bike, own) = campaign.bike(&best.effects, &layout, params, ride_condition[i]);
                ride_vaf(&bike, &best.effects, &own, o, guesses[i])
            })
            .collect(),
    );
    let at_best = campaign.with_coasting(&best.effects, &best.params);
    let shift_error = at_best.coasting_error();
    if let Some(r) = at_best.residuals(&best.effects, &best.params, &all) {
        d.residuals_after = d
            .residuals
            .iter()
            .enumerate()
            .map(|(i, before)| {
                let o = &rides[i];
                let at = parts.start(i);
                let (bike, own) =
                    campaign.bike(&best.effects, &layout, &best.params, ride_condition[i]);
                let clock = effects::clock(&best.effects, &own);
                let weave = Complex::new(o.weave.re - r[at], o.weave.im - r[at + 1]);
                let v = effects::true_speed(&best.effects, &own, o);
                let (dr, dp) = if parts.of(i) > 2 {
                    (r[at + 2], r[at + 3])
                } else {
                    let bike = effects::for_ride(&bike, &best.effects, &own, o, guesses[i]);
                    shape_residual(&bike, o, v, weave * clock)
                };
                // A candidate's coasting shift carries its own error (on the parts the
                // ride has: a ride without its shape has no shift there).
                let se = |a: usize, own: f64| match &shift_error {
                    Some(e) if a < parts.of(i) => own.hypot(e[at + a]),
                    _ => own,
                };
                let (re_se, im_se) = (se(0, before.re_se), se(1, before.im_se));
                let ratio_se = se(2, before.shape_ratio_se);
                let phase_se = se(3, before.shape_phase_se_rad);
                before.with(
                    [r[at], r[at + 1], dr, dp],
                    [re_se, im_se, ratio_se, phase_se],
                )
            })
            .collect();
    }
}

/// A controlled condition's measured shapes against the bicycle's without its controller
/// (the measured one, with the condition's known masses), at each ride's speed and nearest
/// weave; `None` for an uncontrolled condition or without two rides to compare.
fn without_controller(
    condition: &StudyCondition,
    model: &Parametrized,
) -> Option<instrument::CommonFactor> {
    if condition.control.is_none() {
        return None;
    }
    let m = model.clone().with_masses(&condition.masses);
    let bike = linear::LinearBike::whipple(&m.benchmark_at(m.inputs.values()));
    let rows: Vec<instrument::ShapeRow> = condition
        .rides
        .iter()
        .filter_map(|o| {
            let (_, shape) = bike.weave_and_shape(o.speed_mps, o.weave, true)?;
            let s = shape?;
            instrument::ShapeRow::new(
                o.shape_ratio.value,
                o.shape_ratio.value - s.norm(),
                o.shape_ratio.se,
                crate::signal::wrap_pi(o.shape_phase_rad.value - s.arg()),
                o.shape_phase_rad.se,
            )
        })
        .collect();
    instrument::factor_of_rows(&rows, "the bicycle without its controller")
}

/// One pass of [`diagnose_study`]: the diagnosis with the shape of the conditions `shape_off`
/// left out, and its shape checks; or, as soon as the ranking shows a condition's shape
/// missing every candidate, those checks alone (the pass to make again without it).
enum Pass {
    Diagnosed(Box<Diagnosis>, Vec<instrument::ShapeCheck>),
    ShapeMisses(Vec<instrument::ShapeCheck>),
}

fn diagnose_pass(
    study: &[StudyCondition],
    model: &Parametrized,
    options: &GapOptions,
    shape_off: &[bool],
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Pass, GapError> {
    let is_study = study.len() > 1;
    let (rides, ride_condition, failed) = pooled(study);
    let rides = &rides[..];
    let failed = &failed[..];
    let n = rides.len();
    let mut d = Diagnosis::unconcluded(n, failed.to_vec());
    if let Some(reason) = insufficiency(rides, failed) {
        d.verdict = format!("No conclusion: {reason}.");
        d.reason = Some(reason);
        return Ok(Pass::Diagnosed(Box::new(d), Vec::new()));
    }
    // The model at the rides' speeds under each condition's controller, its covariance (one
    // parameter set for every condition), and the speeds' contribution.
    let per_condition: Vec<(Parametrized, Vec<f64>)> = study
        .iter()
        .map(|c| {
            (
                model.clone().with_masses(&c.masses).with_control(c.control),
                c.rides.iter().map(|o| o.speed_mps).collect(),
            )
        })
        .collect();
    let wm = model.weave_model_conditions(&per_condition)?;
    // The mode shape enters for a condition whose every ride measured it (both angles) where
    // the model has one; a condition of roll-rate segments gives the eigenvalue alone.
    let shape_usable = |i: usize| {
        let o = &rides[i];
        wm.shapes[i].is_finite()
            && [o.shape_ratio, o.shape_phase_rad]
                .iter()
                .all(|e| e.value.is_finite() && e.se.is_finite() && e.se > 0.0)
    };
    let condition_shapes: Vec<bool> = (0..study.len())
        .map(|c| {
            options.shape
                && !shape_off[c]
                && (0..n).filter(|&i| ride_condition[i] == c).all(shape_usable)
        })
        .collect();
    let parts = observe::Parts::new(
        (0..n)
            .map(|i| {
                if condition_shapes[ride_condition[i]] {
                    4
                } else {
                    2
                }
            })
            .collect(),
    );
    let guesses = wm.weaves.clone();
    let model_idx: Vec<usize> = (0..n)
        .flat_map(|i| (0..parts.of(i)).map(move |a| WEAVE_PARTS * i + a))
        .collect();
    let model_cov = wm
        .cov
        .select_rows(model_idx.iter())
        .select_columns(model_idx.iter());
    let condition_models = condition_models(study, &per_condition, model);
    let unextended: Vec<linear::LinearBike> = condition_models
        .iter()
        .map(|c| linear::LinearBike::whipple(&c.base).with_control(c.control))
        .collect();
    // Repeated kicks of one set-up that scatter beyond their fits' errors: the scatter between
    // kicks, a random effect of every kick.
    d.between_kick_scatter =
        observe::between_kick_scatter(rides, &ride_condition, parts.most(), &experiment::fit_se);
    if let Some(s) = d.between_kick_scatter.as_mut() {
        let white_se = |o: &Observation| {
            let [_, _, ratio, phase] = experiment::fit_se(o);
            [o.se_if_white[0], o.se_if_white[1], ratio, phase]
        };
        observe::with_white_errors(s, rides, &ride_condition, parts.most(), &white_se);
    }
    let scatter = d
        .between_kick_scatter
        .as_ref()
        .map_or(vec![0.0; parts.most()], |s| s.per_part.clone());
    let (exp_cov, exp_common) = experiment::covariance(
        rides,
        &ride_condition,
        &parts,
        &unextended,
        &guesses,
        &wm.shapes,
        &scatter,
    );
    // The coasting rides' replays on the measured bicycle, for the candidates' shifts.
    let coasting = coasting::CoastingBase::new(rides, &condition_models, &ride_condition);
    let all: Vec<usize> = (0..n).collect();
    let condition_inputs: Vec<Parametrized> =
        per_condition.iter().map(|(m, _)| m.clone()).collect();
    let campaign = Campaign {
        obs: rides,
        conditions: &condition_models,
        ride_condition: ride_condition.clone(),
        guesses: guesses.clone(),
        parts: parts.clone(),
        cov: std::sync::OnceLock::from(&exp_cov + &model_cov),
        factor: std::sync::OnceLock::new(),
        inverse: std::sync::OnceLock::new(),
        model_factor: wm.factor.select_rows(model_idx.iter()),
        exp_common: &exp_common,
        assumed: effects::Assumed::NOMINAL,
        exp_cov: &exp_cov,
        models: &condition_inputs,
        coasting: &coasting,
        coasting_shift: None,
        trusted_newton_rides: options.trusted_newton_rides,
        speed_grid: options.speed_grid,
        every_pair: options.pairs.every_pair(is_study),
        every_triple: options.pairs == PairSearch::EveryTriple,
    };
    d.parts_per_ride = parts.most();
    d.dof = parts.total();
    let full = campaign.subset(all.clone()).ok_or(GapError::Covariance)?;
    let r0 = campaign
        .residuals(&[], &[], &all)
        .ok_or(GapError::Covariance)?;
    d.chi2 = full.chi2(&[], &[]);
    d.p_value = stats::chi2_sf(d.chi2, d.dof);
    d.chi2_without_parameter_error = campaign
        .experiment_whitening()
        .and_then(|w| w.whiten(&r0))
        .map_or(f64::NAN, |w| w.norm_squared());
    d.p_value_without_parameter_error = stats::chi2_sf(d.chi2_without_parameter_error, d.dof);
    if is_study {
        d.conditions = condition_summaries(study, &campaign);
    }
    d.residuals = residuals_before(&campaign, &r0, &unextended, study);
    d.bands = speed_bands(&d.residuals);
    d.conclusive = true;
    d.ranking = rank(&campaign, progress)?;
    let names: Vec<String> = study.iter().map(|c| c.name.clone()).collect();
    let checks = instrument::check_shapes(&campaign, &condition_shapes, &names, &d.ranking);
    if checks.iter().any(|c| c.misses) {
        return Ok(Pass::ShapeMisses(checks));
    }
    let mut singles: Vec<effects::Effect> = d
        .ranking
        .iter()
        .filter_map(|r| match r.effects[..] {
            [e] => Some(e),
            _ => None,
        })
        .collect();
    singles.sort();
    let null = significance::NullTest::new(&campaign, &singles);
    (d.targeted, d.campaign_p_value) =
        targeted_test(d.chi2, d.dof, d.p_value, &d.ranking, null.as_ref());
    d.significant = d.campaign_p_value < SIGNIFICANCE;
    d.parameters_could_explain = !d.significant && d.p_value_without_parameter_error < SIGNIFICANCE;
    if let Some(null) = &null {
        d.detection_limits = significance::detection_limits(&campaign, null);
    }
    if d.significant {
        ties::break_ties_by_bic(&mut d.ranking);
        d.tied = tied(&d.ranking);
        d.next_rides = next_rides(&campaign, &exp_cov, model, &d.ranking, &d.tied);
        d.next_conditions = ties::next_conditions(&campaign, &d.ranking, &d.tied);
    }
    with_best(&mut d, &campaign, &unextended);
    Ok(Pass::Diagnosed(Box::new(d), checks))
}
