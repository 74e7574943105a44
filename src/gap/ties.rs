//! Ties, and the rides that would break them. In: the ranked candidates with their held-out
//! whitened residuals, the campaign's covariance and the measured bicycle's. Out: whether the
//! rides left out tell two candidates apart (`distinguishable`, [`heldout_contrast`]), the
//! candidates tied with the best, and the two speeds to ride next with how many rides there
//! are expected to split them ([`NextRides`]).

use super::fit::Campaign;
use super::observe::Observation;
use super::rank::{distinguishable, heldout_contrast, Ranked};
use super::thresholds::TIE_SE;
use super::{effects, linear};
use crate::model::uncertain::{Parametrized, WEAVE_PARTS};
use crate::model::Benchmark;
use nalgebra::{DMatrix, DVector};

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
pub(super) fn next_rides(
    campaign: &Campaign<'_>,
    exp_cov: &DMatrix<f64>,
    model: &Parametrized,
    ranking: &[Ranked],
    tied: &[String],
) -> NextRides {
    let (Some(best), true) = (ranking.first(), tied.len() > 1) else {
        return NextRides::default();
    };
    let rivals = rivals_of(ranking, tied, best);
    let separation_now: Vec<f64> = rivals.iter().map(|r| heldout_contrast(best, r).1).collect();
    let needed = still_needed(best, &rivals);
    let obs = campaign.obs;
    let parts = &campaign.parts;
    // A ride at speed v is expected to be measured as well as the campaign's ride nearest to
    // it: the covariance of its parts (the fit's and the speed's).
    let block =
        |m: &DMatrix<f64>, start: usize, p: usize| m.view((start, start), (p, p)).into_owned();
    let mean_slowing = obs.iter().map(|o| o.speed_correction_mps).sum::<f64>() / obs.len() as f64;
    let predict_at = |r: &Ranked, v: f64, i: usize| -> Option<Vec<f64>> {
        let c = campaign.ride_condition[i];
        let own = campaign.layout(&r.effects).condition_params(&r.params, c);
        let cond = &campaign.conditions[c];
        predict_ride(campaign, r, &own, &cond.base, cond.control, v, i)
    };
    let grid = speed_grid(obs, 0.05);
    // The model's error at every grid speed (one propagation); where it fails, the nearest
    // ride's (its block of the campaign's covariance less the fit's and the speed's).
    // (In a study the nearest ride's condition sets the controller: its block.)
    let model_at_grid = if campaign.is_study() {
        None
    } else {
        model.weave_model(&grid).ok()
    };
    // D of each rival at each grid speed.
    let d: Vec<Vec<f64>> = grid
        .iter()
        .enumerate()
        .map(|(k, &v)| {
            let zero = vec![0.0; rivals.len()];
            let Some((i, b)) =
                nearest(obs, 0..obs.len(), v).and_then(|i| Some((i, predict_at(best, v, i)?)))
            else {
                return zero;
            };
            let (start, p) = (parts.start(i), parts.of(i));
            let model_block = match &model_at_grid {
                Some(wm) => block(&wm.cov, WEAVE_PARTS * k, p),
                None => campaign.cov_block(i) - block(exp_cov, start, p),
            };
            let Some(chol) = (block(exp_cov, start, p) + model_block).cholesky() else {
                return zero;
            };
            rivals
                .iter()
                .map(|r| predict_at(r, v, i).map_or(0.0, |x| squared_separation(&chol, &b, &x)))
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

/// The candidates in the best's standing ([`Ranked::standing`]) that the rides left out cannot tell from it
/// ([`distinguishable`]); empty when only the best.
pub(super) fn tied(ranked: &[Ranked]) -> Vec<String> {
    let Some(best) = ranked.first() else {
        return Vec::new();
    };
    let t: Vec<String> = ranked
        .iter()
        .filter(|r| r.standing() == best.standing() && !r.not_needed && !distinguishable(best, r))
        .map(|r| r.effect.clone())
        .collect();
    if t.len() > 1 {
        t
    } else {
        Vec::new()
    }
}

/// In a study, the candidates tied with the first (the conditions left out cannot tell them
/// apart, [`tied`]) ordered among themselves by the BIC of their fits to every ride, ahead of
/// the rest: the held-out prediction ranks, and where it cannot tell, the χ² of every ride
/// (which carries the measured parameters' error correlated across rides, as the conditions
/// left out whitened ride by ride do not) breaks the tie. In blind studies a single whose fit
/// to every ride gave χ² 15,376 on 160 came first, tied with the withheld effect's at 185.6
/// (docs/decisions/2026-12-03-study-admission.md). A campaign's order is the BIC already.
pub(super) fn break_ties_by_bic(ranking: &mut Vec<Ranked>) {
    if !ranking.first().is_some_and(Ranked::in_study) {
        return;
    }
    let t = tied(ranking);
    if t.len() < 2 {
        return;
    }
    let (mut front, rest): (Vec<Ranked>, Vec<Ranked>) =
        ranking.drain(..).partition(|r| t.contains(&r.effect));
    front.sort_by(|a, b| {
        a.bic
            .total_cmp(&b.bic)
            .then_with(|| a.effect.cmp(&b.effect))
    });
    ranking.extend(front);
    ranking.extend(rest);
}

/// The candidates tied with `best`, itself left out, in the order of `tied`.
fn rivals_of<'r>(ranking: &'r [Ranked], tied: &[String], best: &Ranked) -> Vec<&'r Ranked> {
    tied.iter()
        .filter(|t| **t != best.effect)
        .filter_map(|t| ranking.iter().find(|r| r.effect == *t))
        .collect()
}

/// What each rival still lacks of [`UNTIE_SEPARATION`] against `best`.
fn still_needed(best: &Ranked, rivals: &[&Ranked]) -> Vec<f64> {
    rivals
        .iter()
        .map(|r| (UNTIE_SEPARATION - heldout_contrast(best, r).1).max(0.0))
        .collect()
}

/// Speeds on a grid of `step` (m/s) from 0.5 m/s below the campaign's slowest ride to 0.5 m/s
/// above its fastest (never below 0.5 m/s).
fn speed_grid(obs: &[Observation], step: f64) -> Vec<f64> {
    let (lo, hi) = obs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), o| {
            (a.min(o.speed_mps), b.max(o.speed_mps))
        });
    (0..)
        .map(|k| (lo - 0.5).max(0.5) + step * k as f64)
        .take_while(|&v| v <= hi + 0.5 + 1e-9)
        .collect()
}

/// Among `rides`, the one whose speed is nearest `v`.
fn nearest(obs: &[Observation], rides: impl Iterator<Item = usize>, v: f64) -> Option<usize> {
    rides.min_by(|&a, &b| {
        (obs[a].speed_mps - v)
            .abs()
            .total_cmp(&(obs[b].speed_mps - v).abs())
    })
}

/// Candidate `r`'s prediction of a ride like the campaign's ride `i` (its speed source,
/// slowing and parts) made at speed `v` on the bicycle `base` with `control`, its effects'
/// parameters `own` (`effects::specs` order): `[re, im(, |γ/θ|, arg)]`.
fn predict_ride(
    campaign: &Campaign<'_>,
    r: &Ranked,
    own: &[f64],
    base: &Benchmark,
    control: crate::model::SteerControl,
    v: f64,
    i: usize,
) -> Option<Vec<f64>> {
    let bike = effects::linear_bike(base, &control, &r.effects, own);
    let o = Observation {
        speed_mps: v,
        ..campaign.obs[i].clone()
    };
    let guess = linear::LinearBike::whipple(base)
        .with_control(control)
        .weave_near(v, campaign.guesses[i])?;
    let shape = campaign.parts.of(i) > 2;
    let (w, s) = effects::predict_weave(&bike, &r.effects, own, &o, guess, shape)?;
    let mut out = vec![w.re, w.im];
    if let Some(s) = s {
        out.extend([s.norm(), s.arg()]);
    }
    Some(out)
}

/// (a − b)ᵀ Σ⁻¹ (a − b) of two predictions of one ride's parts, the phase's difference wrapped
/// to ±π, Σ = L Lᵀ given by `chol`.
fn squared_separation(chol: &nalgebra::Cholesky<f64, nalgebra::Dyn>, a: &[f64], b: &[f64]) -> f64 {
    let delta = DVector::from_iterator(
        a.len(),
        a.iter().zip(b).enumerate().map(|(k, (x, y))| {
            if k == 3 {
                crate::signal::wrap_pi(x - y)
            } else {
                x - y
            }
        }),
    );
    chol.l()
        .solve_lower_triangular(&delta)
        .map_or(0.0, |w| w.norm_squared())
}

/// A known change a lab can make to tell the tied candidates apart: another condition.
#[derive(Debug, Clone, serde::Serialize)]
pub struct NextCondition {
    /// The change, in words ("the controller off", "the controller's gains × 2", "2 kg at the
    /// front frame's centre of mass").
    pub change: String,
    /// The condition it changes (its instruments and set-up kept), and the speed to ride it at
    /// (where the eigenvalue applies, m/s).
    pub from: String,
    pub speed_mps: f64,
    /// For each candidate tied with the best, in the order of `tied` without the best: how far
    /// apart their predictions of one ride there are, in the standard errors the tie test will
    /// weigh it with (those of the condition's ride nearest that speed, fit, speed and model).
    pub separation_se: Vec<f64>,
}

/// The mass a lab adds as a known change (kg): a bag of sand, a dumbbell plate.
pub const KNOWN_MASS_KG: f64 = 2.0;

/// The known changes that would split the tied candidates most, best first (at most three,
/// each at its best speed): from each condition, its controller off (or another condition's
/// controller on), its gains halved or doubled, and [`KNOWN_MASS_KG`] at either frame's centre
/// of mass; each scored as [`next_rides`] scores a speed, by Σ over the tied rivals of
/// min(D, what the pair still lacks), D the squared separation of the two candidates'
/// predictions of a ride made so (the candidates' equipment in a new condition as in the
/// others, [`super::conditions::Layout::new_condition`]), weighed by the errors of the
/// condition's ride nearest that speed.
pub(super) fn next_conditions(
    campaign: &Campaign<'_>,
    ranking: &[Ranked],
    tied: &[String],
) -> Vec<NextCondition> {
    use crate::model::params::{Frame, PointMass};
    let (Some(best), true) = (ranking.first(), tied.len() > 1) else {
        return Vec::new();
    };
    let rivals = rivals_of(ranking, tied, best);
    let needed = still_needed(best, &rivals);
    let obs = campaign.obs;
    // The changes: (words, from condition, its model changed).
    let mut changes: Vec<(String, usize, Benchmark, crate::model::SteerControl)> = Vec::new();
    for (c, cond) in campaign.conditions.iter().enumerate() {
        let (base, control) = (cond.base, cond.control);
        if control.is_none() {
            for other in campaign.conditions.iter().filter(|o| !o.control.is_none()) {
                changes.push((
                    format!("{}'s controller on", other.name),
                    c,
                    base,
                    other.control,
                ));
            }
        } else {
            changes.push((
                "the controller off".into(),
                c,
                base,
                crate::model::SteerControl::NONE,
            ));
            for k in [0.5, 2.0] {
                let mut scaled = control;
                scaled.actuator_gain *= k;
                changes.push((format!("the controller's gains × {k}"), c, base, scaled));
            }
        }
        for (frame, words, x, z) in [
            (Frame::Rear, "rear", base.x_b, base.z_b),
            (Frame::Front, "front", base.x_h, base.z_h),
        ] {
            let mass = PointMass {
                frame,
                mass_kg: KNOWN_MASS_KG,
                x_m: x,
                z_m: z,
            };
            changes.push((
                format!("{KNOWN_MASS_KG} kg at the {words} frame's centre of mass"),
                c,
                base.with_point_mass(&mass),
                control,
            ));
        }
    }
    let grid = speed_grid(obs, 0.1);
    let predict = |r: &Ranked, base: &Benchmark, control, v: f64, i: usize| {
        let layout = campaign.layout(&r.effects);
        let own = layout.new_condition(&r.params, effects::specs(&r.effects).len());
        predict_ride(campaign, r, &own, base, control, v, i)
    };
    let mut scored: Vec<(f64, NextCondition)> = changes
        .iter()
        .filter_map(|(words, c, base, control)| {
            let own: Vec<usize> = campaign.rides_of(*c);
            grid.iter()
                .filter_map(|&v| {
                    let i = nearest(obs, own.iter().copied(), v)?;
                    let b = predict(best, base, *control, v, i)?;
                    let block = campaign.cov_block(i);
                    let chol = block.cholesky()?;
                    let d: Vec<f64> = rivals
                        .iter()
                        .map(|r| {
                            predict(r, base, *control, v, i)
                                .map_or(0.0, |x| squared_separation(&chol, &b, &x))
                        })
                        .collect();
                    let score: f64 = d.iter().zip(&needed).map(|(x, n)| x.min(*n)).sum();
                    Some((
                        score,
                        NextCondition {
                            change: words.clone(),
                            from: campaign.conditions[*c].name.clone(),
                            speed_mps: v,
                            separation_se: d.iter().map(|x| x.sqrt()).collect(),
                        },
                    ))
                })
                .max_by(|a, b| a.0.total_cmp(&b.0))
        })
        .collect();
    scored.sort_by(|a, b| b.0.total_cmp(&a.0));
    scored.into_iter().take(3).map(|(_, n)| n).collect()
}
