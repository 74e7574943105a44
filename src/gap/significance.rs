//! Whether the campaign can be concluded on, and whether its gap is significant. In: the
//! observations, and the χ² of the unextended model and of each single effect fitted. Out: the
//! reason a campaign is too thin (`insufficiency`), the targeted test (the likelihood ratio
//! of the single effect that lowers χ² most), the campaign's p-value (the smallest of its and
//! the χ² test's, calibrated on draws of the residuals with no effect present: `NullTest`)
//! and, for a quiet campaign, what it would have seen (`detection_limits`).

use super::observe::Observation;
use super::rank::Ranked;
use super::thresholds::{MIN_RIDES, MIN_SPEED_SPAN_MPS, SIGNIFICANCE};
use crate::stats;
use nalgebra::{DMatrix, DVector};

/// The targeted part of the campaign's test (see [`super::Diagnosis::targeted`]).
#[derive(Debug, Clone, serde::Serialize)]
pub struct TargetedTest {
    pub effect: String,
    /// χ² of the unextended model minus χ² with the effect fitted, over the effect's Birge
    /// factor `max(1, χ²/dof)` (a fit that leaves more scatter than the errors allow tells
    /// that much less).
    pub likelihood_ratio: f64,
    /// The effect's parameters: the likelihood ratio's degrees of freedom.
    pub dof: usize,
    /// The probability, with no effect present, that some single effect of the library
    /// lowers χ² at least this much (its own p-value at most this effect's): from
    /// [`NULL_DRAWS`] draws of the residuals, the effects' correlations included, never above
    /// the Bonferroni bound (its p-value times the number of effects tried).
    pub p_value: f64,
}

/// Draws of the residuals with no effect present that calibrate the campaign's test.
pub const NULL_DRAWS: usize = 10_000;

/// The seed of those draws: a campaign's p-value is the same on every run.
const NULL_SEED: u64 = 0x006a_705f_6e75_6c6c;

/// One single effect's part of the targeted test, linearized at "no effect": the residuals
/// whitened by the campaign's covariance (`u = M r` with `M Σ Mᵀ = I`,
/// [`super::fit::Campaign::whitening`]) move along `columns` (one per fitted parameter) as the
/// effect grows from nothing, so its fit lowers χ² by the squared length of `u`'s projection
/// on them (Gauss–Markov), and by nothing where the fit is held at "no effect" by a bound (a
/// mass cannot be negative).
struct Direction {
    /// An orthonormal basis of the whitened columns.
    basis: DMatrix<f64>,
    /// For a one-parameter effect that can only grow from "no effect": the unit direction in
    /// which the residuals move as it does.
    one_sided: Option<DVector<f64>>,
    /// The whitened derivative's squared length per parameter unit (one-parameter effects
    /// with a finite "no effect"): the fit's information at "no effect", `1/σ₀²`.
    information: Option<f64>,
    effect: super::effects::Effect,
}

impl Direction {
    /// The drop in χ² that the effect's fit would give on whitened residuals `u`.
    fn likelihood_ratio(&self, u: &DVector<f64>) -> f64 {
        match &self.one_sided {
            Some(d) => d.dot(u).max(0.0).powi(2),
            None => (self.basis.tr_mul(u)).norm_squared(),
        }
    }

    fn dof(&self) -> usize {
        self.basis.ncols()
    }
}

/// The campaign's test under the null: each single effect's direction in the whitened residuals,
/// and the sorted smallest p-values of [`NULL_DRAWS`] draws of `u ~ N(0, I)` (over the χ² test
/// and every single effect: `campaign`; over the single effects: `targeted`).
pub(super) struct NullTest {
    directions: Vec<Direction>,
    campaign: Vec<f64>,
    targeted: Vec<f64>,
}

/// P(χ²_k > x) with the closed forms of one and two degrees of freedom (the draws need
/// millions of them).
fn sf(x: f64, k: usize) -> f64 {
    match k {
        1 => statrs::function::erf::erfc((0.5 * x.max(0.0)).sqrt()),
        2 => (-0.5 * x.max(0.0)).exp(),
        _ => stats::chi2_sf(x, k),
    }
}

/// The p-value of a single effect's likelihood ratio `lr` (raw) when the campaign's χ² is
/// `chi2` on `dof`: the ratio over the Birge factor of the fit, `max(1, (χ² − lr)/(dof − k))`.
fn single_p(lr: f64, k: usize, chi2: f64, dof: usize) -> f64 {
    let birge = ((chi2 - lr) / dof.saturating_sub(k).max(1) as f64).max(1.0);
    sf(lr / birge, k)
}

impl NullTest {
    /// The directions of the campaign's single effects (`effects`, those the ranking fitted)
    /// and the draws. `None` when the covariance is singular or the unextended model fails.
    pub(super) fn new(
        campaign: &super::fit::Campaign<'_>,
        effects: &[super::effects::Effect],
    ) -> Option<NullTest> {
        let all: Vec<usize> = (0..campaign.obs.len()).collect();
        let r0 = campaign.residuals(&[], &[], &all)?;
        let whitening = campaign.whitening()?;
        let directions: Vec<Direction> = effects
            .iter()
            .filter_map(|&e| direction(campaign, &whitening, &r0, &all, e))
            .collect();
        let (campaign_p, targeted_p) = null_draws(&directions, r0.len());
        Some(NullTest {
            directions,
            campaign: campaign_p,
            targeted: targeted_p,
        })
    }

    /// The fraction of the draws (sorted) whose smallest p is at most `p`, counted as one more
    /// draw (`(k + 1)/(N + 1)`, a valid p-value).
    fn tail(sorted: &[f64], p: f64) -> f64 {
        let k = sorted.partition_point(|&x| x <= p);
        (k as f64 + 1.0) / (sorted.len() as f64 + 1.0)
    }

    /// The smallest p that the draws reach with probability `alpha`: the campaign's test
    /// rejects when its smallest p is below it.
    fn critical(&self, alpha: f64) -> f64 {
        let k = ((alpha * (self.campaign.len() as f64 + 1.0)).floor() as usize).max(1);
        self.campaign[(k - 1).min(self.campaign.len() - 1)]
    }
}

/// From this many residual parts the null draws are made in the directions' span
/// ([`null_draws_in_span`]): at 1,000 rides (4,000 parts) the whole draws took 0.8 s.
const SPAN_DRAWS_PARTS: usize = 1024;

/// The null draws' random numbers: xoshiro256**'s uniform deviates, and standard normal ones
/// from them in pairs (Box–Muller).
struct Deviates(rand_xoshiro::Xoshiro256StarStar);

impl Deviates {
    fn new(seed: u64) -> Deviates {
        Deviates(rand::SeedableRng::seed_from_u64(seed))
    }

    fn uniform(&mut self) -> f64 {
        rand::RngExt::random::<f64>(&mut self.0)
    }

    /// `v` filled with standard normal deviates, a pair at a time (the last pair's second
    /// dropped where `v`'s length is odd).
    fn fill_normal(&mut self, v: &mut DVector<f64>) {
        let n = v.len();
        for k in (0..n).step_by(2) {
            let z = self.normal_pair();
            v[k] = z[0];
            if k + 1 < n {
                v[k + 1] = z[1];
            }
        }
    }

    fn normal_pair(&mut self) -> [f64; 2] {
        let u = 1.0 - self.uniform();
        let v = self.uniform();
        let r = (-2.0 * u.ln()).sqrt();
        let a = std::f64::consts::TAU * v;
        [r * a.cos(), r * a.sin()]
    }
}

/// [`NULL_DRAWS`] draws of whitened residuals `u ~ N(0, I_n)` (no effect present): the sorted
/// smallest p-values over the χ² test (on `n` degrees of freedom) and every direction's, and over
/// the directions alone. From [`SPAN_DRAWS_PARTS`] parts, [`null_draws_in_span`].
fn null_draws(directions: &[Direction], n: usize) -> (Vec<f64>, Vec<f64>) {
    let in_span = (n >= SPAN_DRAWS_PARTS)
        .then(|| null_draws_in_span(directions, n))
        .flatten();
    in_span.unwrap_or_else(|| null_draws_whole(directions, n))
}

/// [`null_draws`] of every part.
fn null_draws_whole(directions: &[Direction], n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut u = DVector::zeros(n);
    smallest_p_draws(n, |deviates| {
        deviates.fill_normal(&mut u);
        let chi2 = u.norm_squared();
        let best = directions
            .iter()
            .map(|d| single_p(d.likelihood_ratio(&u), d.dof(), chi2, n))
            .fold(1.0, f64::min);
        (chi2, best)
    })
}

/// [`NULL_DRAWS`] draws of `(χ², the directions' smallest p)` from `draw` (on `n` parts): the
/// sorted smallest p-values over the χ² test and the directions, and over the directions alone.
fn smallest_p_draws(
    n: usize,
    mut draw: impl FnMut(&mut Deviates) -> (f64, f64),
) -> (Vec<f64>, Vec<f64>) {
    let mut deviates = Deviates::new(NULL_SEED);
    let (mut campaign, mut targeted) = (
        Vec::with_capacity(NULL_DRAWS),
        Vec::with_capacity(NULL_DRAWS),
    );
    for _ in 0..NULL_DRAWS {
        let (chi2, best) = draw(&mut deviates);
        targeted.push(best);
        campaign.push(best.min(stats::chi2_sf(chi2, n)));
    }
    campaign.sort_by(f64::total_cmp);
    targeted.sort_by(f64::total_cmp);
    (campaign, targeted)
}

/// [`null_draws`] in the span of the directions: with Q an orthonormal basis of every
/// direction's columns (m of them), `u = Q z + u⊥` where `z = Qᵀu ~ N(0, I_m)` and `|u⊥|² ~
/// χ²(n − m)` are independent, each likelihood ratio reads `u` through `z` alone, and `|u|² =
/// |z|² + |u⊥|²`: m normal deviates and one χ² deviate ([`chi2_deviate`]) a draw instead of n,
/// the same distribution. `None` when the directions span nothing or all of the parts.
fn null_draws_in_span(directions: &[Direction], n: usize) -> Option<(Vec<f64>, Vec<f64>)> {
    let columns: Vec<DVector<f64>> = directions
        .iter()
        .flat_map(|d| d.basis.column_iter().map(|c| c.into_owned()))
        .collect();
    if columns.is_empty() {
        return None;
    }
    let q = orthonormal(&DMatrix::from_columns(&columns))?;
    let m = q.ncols();
    if m >= n {
        return None;
    }
    // Each direction read through z: its basis's coordinates in Q, or its one-sided unit
    // direction's.
    let read: Vec<DMatrix<f64>> = directions
        .iter()
        .map(|d| match &d.one_sided {
            Some(unit) => DMatrix::from_row_slice(1, m, q.tr_mul(unit).as_slice()),
            None => d.basis.tr_mul(&q),
        })
        .collect();
    let mut z = DVector::zeros(m);
    Some(smallest_p_draws(n, |deviates| {
        deviates.fill_normal(&mut z);
        let chi2 = z.norm_squared() + chi2_deviate(n - m, deviates);
        let best = directions
            .iter()
            .zip(&read)
            .map(|(d, r)| {
                let projected = r * &z;
                let lr = match d.one_sided {
                    Some(_) => projected[0].max(0.0).powi(2),
                    None => projected.norm_squared(),
                };
                single_p(lr, d.dof(), chi2, n)
            })
            .fold(1.0, f64::min);
        (chi2, best)
    }))
}

/// A deviate of χ²(ν), ν ≥ 2: twice a Gamma(ν/2) deviate by Marsaglia and Tsang's
/// squeeze-and-reject method ("A simple method for generating gamma variables", ACM TOMS 26,
/// 2000).
fn chi2_deviate(nu: usize, deviates: &mut Deviates) -> f64 {
    let d = 0.5 * nu as f64 - 1.0 / 3.0;
    let c = 1.0 / (9.0 * d).sqrt();
    loop {
        let x = deviates.normal_pair()[0];
        let v = (1.0 + c * x).powi(3);
        if v <= 0.0 {
            continue;
        }
        let u = deviates.uniform();
        if u < 1.0 - 0.0331 * x.powi(4) || u.ln() < 0.5 * x * x + d * (1.0 - v + v.ln()) {
            return 2.0 * d * v;
        }
    }
}

/// The whitened direction of one single effect at "no effect"; `None` when its prediction
/// fails there or does not move the residuals.
fn direction(
    campaign: &super::fit::Campaign<'_>,
    whitening: &super::fit::Whitening,
    r0: &DVector<f64>,
    all: &[usize],
    e: super::effects::Effect,
) -> Option<Direction> {
    let layout = campaign.layout(&[e]);
    let specs = e.params();
    let none: Vec<f64> = specs.iter().map(|s| s.none).collect();
    let mut columns: Vec<DVector<f64>> = Vec::new();
    let mut one_sided = false;
    if none.iter().all(|v| v.is_finite()) {
        let base = layout.expand(&none);
        for (j, spec) in layout.specs.iter().enumerate() {
            let h = 1e-3 * (spec.hi - spec.lo);
            let at = |p: f64| {
                let mut params = base.clone();
                params[j] = p;
                campaign.residuals(&[e], &params, all)
            };
            let sided = spec.none <= spec.lo;
            one_sided |= sided;
            // The residual moves by −(the prediction's change): sign kept, so that a
            // one-sided effect's growth is told from its impossible shrinking.
            let derivative = if sided {
                (at(spec.none + h)? - r0) / h
            } else {
                (at(spec.none + h)? - at(spec.none - h)?) / (2.0 * h)
            };
            columns.push(derivative);
        }
    } else {
        // An effect absent at an infinite value (the tyres, rolling without slip as their
        // cornering stiffness grows without bound): its size is the inverse of that value, and
        // its direction at nothing depends on the other parameters, spanned by their bounds.
        let j = none.iter().position(|v| !v.is_finite())?;
        let small = 1e-3 / specs[j].lo.abs().max(1.0);
        let ends: &[bool] = if specs.len() > 1 {
            &[false, true]
        } else {
            &[false]
        };
        for &high in ends {
            let mut at: Vec<f64> = specs
                .iter()
                .map(|s| if high { s.hi } else { s.lo })
                .collect();
            at[j] = 1.0 / small;
            columns.push((campaign.residuals(&[e], &layout.expand(&at), all)? - r0) / small);
        }
    }
    let whitened: Vec<DVector<f64>> = columns
        .iter()
        .map(|c| whitening.whiten(c))
        .collect::<Option<_>>()?;
    let w = DMatrix::from_columns(&whitened);
    if !w.iter().all(|x| x.is_finite()) || w.norm() == 0.0 {
        return None;
    }
    let information = (w.ncols() == 1 && none[0].is_finite()).then(|| w.column(0).norm_squared());
    // The fit lowers χ² = |u + W δ|² along −W: a one-sided effect only where −wᵀu > 0.
    let one_sided = (one_sided && w.ncols() == 1).then(|| -w.column(0).normalize());
    let basis = orthonormal(&w)?;
    Some(Direction {
        basis,
        one_sided,
        information,
        effect: e,
    })
}

/// An orthonormal basis of `w`'s columns (by its thin SVD, dropping directions below 1e-9 of
/// the largest); `None` when it has none.
fn orthonormal(w: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let svd = w.clone().svd(true, false);
    let u = svd.u?;
    let largest = svd.singular_values.max();
    let keep: Vec<usize> = (0..svd.singular_values.len())
        .filter(|&i| svd.singular_values[i] > 1e-9 * largest)
        .collect();
    (!keep.is_empty()).then(|| u.select_columns(keep.iter()))
}

/// The campaign's targeted test: among the single effects of the ranking, the one whose fit
/// gives the smallest p-value (its likelihood ratio χ²-distributed with as many degrees of
/// freedom as it has parameters when the model is right, Wilks; from its first fit, in the
/// covariance at "no effect" where the null draws are made, [`super::rank::Ranked::chi2_test`]:
/// the final fit's coasting shifts, held at the first fit, are no part of those draws, and a
/// speedometer's scale there took an effect-free campaign's p from 0.18 to 0.0055); that
/// smallest p calibrated on the null draws of [`NullTest`], so that effects that move the
/// weave alike (a trail and a front frame's inertia) count once and not as independent tries.
/// The campaign's p-value is the same for the smaller of it and the χ² test's p. Each is
/// capped by its Bonferroni bound (the draws resolve p-values down to 1/[`NULL_DRAWS`]; the
/// bound below that). From the unextended model's `chi2` on `dof` degrees of freedom with its
/// p-value `p_value`, and the `ranking`: the targeted test and the campaign's p-value.
pub(super) fn targeted_test(
    chi2: f64,
    dof: usize,
    p_value: f64,
    ranking: &[Ranked],
    null: Option<&NullTest>,
) -> (Option<TargetedTest>, f64) {
    let chi2_before = chi2;
    let singles: Vec<&Ranked> = ranking.iter().filter(|r| r.effects.len() == 1).collect();
    let tried = singles.len().max(1) as f64;
    let best = singles
        .iter()
        .map(|r| {
            let k = r.params.len();
            let lr = stats::birge_likelihood_ratio(chi2_before, r.chi2_test, dof.saturating_sub(k));
            (r.effect.clone(), lr, k, stats::chi2_sf(lr, k))
        })
        .min_by(|a, b| a.3.total_cmp(&b.3).then(b.1.total_cmp(&a.1)));
    let p_single = best.as_ref().map_or(1.0, |b| b.3);
    let bonferroni = (p_single * tried).min(1.0);
    let p_targeted = null.map_or(bonferroni, |n| {
        NullTest::tail(&n.targeted, p_single).min(bonferroni)
    });
    let targeted = best.map(|(effect, lr, k, _)| TargetedTest {
        effect,
        likelihood_ratio: lr,
        dof: k,
        p_value: p_targeted,
    });
    let smallest = p_value.min(p_single);
    let bound = (2.0 * p_value.min(bonferroni)).min(1.0);
    let campaign = null.map_or(bound, |n| NullTest::tail(&n.campaign, smallest).min(bound));
    (targeted, campaign)
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

/// Each single one-parameter candidate's detection limit on this campaign: the campaign's test
/// rejects at [`super::SIGNIFICANCE`] when its smallest p is below the null draws' critical
/// value p* ([`NullTest`]), so for one effect when the likelihood ratio of its fit exceeds z²
/// with z the normal quantile at 1 − p*/2; at the effect's true size δ the ratio is about
/// (δ/σ₀)² (σ₀ the standard error of its fit at "no effect", from the whitened derivative of
/// the residuals, the full covariance with the model's correlated error included), so it is
/// seen with power 1 − β when δ ≥ (z + z_β) σ₀. Linear in the effect: the size where its effect
/// on the weave stops being linear is beyond what the rides see anyway.
pub(super) fn detection_limits(
    campaign: &super::fit::Campaign<'_>,
    null: &NullTest,
) -> Vec<DetectionLimit> {
    use statrs::distribution::{ContinuousCDF, Normal};
    let Ok(normal) = Normal::new(0.0, 1.0) else {
        return Vec::new();
    };
    let critical = null.critical(SIGNIFICANCE);
    let z = normal.inverse_cdf(1.0 - critical / 2.0) + normal.inverse_cdf(DETECTION_POWER);
    null.directions
        .iter()
        .filter_map(|d| {
            let information = d.information.filter(|i| i.is_finite() && *i > 0.0)?;
            let [spec] = d.effect.params()[..] else {
                return None;
            };
            let size = z / information.sqrt();
            Some(DetectionLimit {
                effect: d.effect.name().to_string(),
                param: spec.name,
                unit: spec.unit,
                size,
                absolute: absolute(d.effect, &campaign.conditions[0].base, size),
                none: spec.none,
                one_sided: spec.none <= spec.lo,
            })
        })
        .collect()
}

/// A factor's deviation `size` on the measured quantity it multiplies, in that quantity's unit
/// ([`super::effects::Definition::measured`]).
fn absolute(
    e: super::effects::Effect,
    b: &crate::model::Benchmark,
    size: f64,
) -> Option<(f64, &'static str)> {
    let q = e.definition().measured?;
    Some((size * (q.of)(b).abs(), q.unit))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::effects::Effect;

    /// A direction along the unit vector `axis` of `n` dimensions.
    fn along(n: usize, axis: usize, one_sided: bool) -> Direction {
        let e = DVector::from_fn(n, |i, _| if i == axis { 1.0 } else { 0.0 });
        Direction {
            basis: DMatrix::from_columns(std::slice::from_ref(&e)),
            one_sided: one_sided.then_some(e),
            information: Some(1.0),
            effect: Effect::Trail,
        }
    }

    /// Closed forms on many residuals (n = 2000, where the Birge factor is 1 within 3 %): the
    /// smallest of m independent two-sided p-values falls below x with probability
    /// 1 − (1 − x)^m (Šidák); m copies of one direction count once; a one-sided direction's p
    /// (taken two-sided) falls below x half as often. Tolerances: three of the draws' standard
    /// errors (√(p(1 − p)/10⁴) ≤ 0.004) and 0.006 for the Birge factor.
    #[test]
    fn the_null_draws_match_closed_forms() {
        // Every part drawn, and the directions' span with a χ² for the rest.
        for n in [1000, 2000] {
            null_draws_match_closed_forms(n);
        }
    }

    fn null_draws_match_closed_forms(n: usize) {
        let independent: Vec<Direction> = (0..4).map(|a| along(n, a, false)).collect();
        let (_, targeted) = null_draws(&independent, n);
        let sidak = 1.0 - 0.95_f64.powi(4);
        let got = NullTest::tail(&targeted, 0.05);
        assert!((got - sidak).abs() < 0.018, "{got} against {sidak}");

        let copies: Vec<Direction> = (0..4).map(|_| along(n, 0, false)).collect();
        let (_, targeted) = null_draws(&copies, n);
        let got = NullTest::tail(&targeted, 0.05);
        assert!((got - 0.05).abs() < 0.013, "{got} against 0.05");

        let (_, targeted) = null_draws(&[along(n, 0, true)], n);
        let got = NullTest::tail(&targeted, 0.1);
        assert!((got - 0.05).abs() < 0.013, "{got} against 0.05");
    }

    /// χ²(ν) deviates for ν = 1,000 and 4,000: 20,000 of them have mean ν and variance 2ν
    /// within four of their standard errors (√(2ν/N) for the mean; 2ν √(2/N) for the variance,
    /// nearly normal at these ν).
    #[test]
    fn chi2_deviates_have_the_chi2_moments() {
        let mut deviates = Deviates::new(5);
        for nu in [1000usize, 4000] {
            let n = 20_000;
            let x: Vec<f64> = (0..n).map(|_| chi2_deviate(nu, &mut deviates)).collect();
            let mean = x.iter().sum::<f64>() / n as f64;
            let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
            let nu = nu as f64;
            let nf = n as f64;
            assert!(
                (mean - nu).abs() < 4.0 * (2.0 * nu / nf).sqrt(),
                "mean {mean} for {nu}"
            );
            assert!(
                (var - 2.0 * nu).abs() < 4.0 * 2.0 * nu * (2.0 / nf).sqrt(),
                "variance {var} for {nu}"
            );
        }
    }

    /// The draws in the directions' span and the draws of every part have one distribution:
    /// on 1,500 parts with three overlapping directions (a two-parameter one, a one-sided one
    /// half inside it, one beside both), the two samples' smallest p-values (campaign and
    /// targeted) lie within the two-sample Kolmogorov–Smirnov distance of 1 % (1.63 √(2/10⁴)
    /// = 0.023).
    #[test]
    fn the_draws_in_the_span_are_the_whole_draws_in_distribution() {
        let n = 1500;
        let unit = |a: usize| DVector::from_fn(n, |i, _| if i == a { 1.0 } else { 0.0 });
        let two = Direction {
            basis: DMatrix::from_columns(&[unit(0), unit(1)]),
            one_sided: None,
            information: None,
            effect: Effect::Tyres,
        };
        let half = (unit(1) + unit(2)).normalize();
        let sided = Direction {
            basis: DMatrix::from_columns(std::slice::from_ref(&half)),
            one_sided: Some(half.clone()),
            information: Some(1.0),
            effect: Effect::SteerDamping,
        };
        let directions = vec![two, sided, along(n, 7, false)];
        let (span, whole) = (
            null_draws_in_span(&directions, n).expect("three directions in 1,500 parts"),
            null_draws_whole(&directions, n),
        );
        let ks = |a: &[f64], b: &[f64]| {
            a.iter()
                .chain(b)
                .map(|&x| {
                    let fa = a.partition_point(|&v| v <= x) as f64 / a.len() as f64;
                    let fb = b.partition_point(|&v| v <= x) as f64 / b.len() as f64;
                    (fa - fb).abs()
                })
                .fold(0.0, f64::max)
        };
        let (campaign, targeted) = (ks(&span.0, &whole.0), ks(&span.1, &whole.1));
        assert!(campaign < 0.023, "campaign's smallest p: KS {campaign}");
        assert!(targeted < 0.023, "targeted p: KS {targeted}");
    }

    /// With the χ² test alone (no direction) the campaign's smallest p is the χ² test's, uniform:
    /// its critical value at 0.01 is 0.01 within the draws' error (three SE, 0.003).
    #[test]
    fn the_chi2_test_alone_is_uniform() {
        let (campaign, _) = null_draws(&[], 60);
        let test = NullTest {
            directions: Vec::new(),
            campaign,
            targeted: Vec::new(),
        };
        let critical = test.critical(0.01);
        assert!((critical - 0.01).abs() < 0.003, "{critical}");
    }
}
