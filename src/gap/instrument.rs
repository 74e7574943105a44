//! The instrument checked before the bicycle. In: a ranked campaign ([`Campaign`],
//! [`Ranked`]) whose conditions' rides carry their mode shape γ/θ. Out: per such condition, the
//! common factor by which the measured shape misses the model's (|γ/θ| × k, arg γ/θ + φ, the
//! same for every ride) and whether it misses every candidate of the library by it
//! ([`ShapeCheck`]), and what an instrument's convention would make of it ([`Convention`]).
//!
//! A bicycle's effects move the shape by different amounts at different speeds, and the
//! candidates are fitted to it; a shape that every one of them misses by one factor is
//! recorded otherwise than the model assumes: the steer's sign reversed (φ = 180°), one angle
//! in degrees and the other in radians (k = 57.3 or 1/57.3), the steer read through a gear or
//! about another axis, a filter's lag on the roll, or an effect outside the library. None of
//! these is the bicycle the library can fit, and fitted with it a shape hundreds of standard
//! errors off steers every candidate, so [`super::diagnose_study`] diagnoses such a condition
//! on its eigenvalue alone and says why. The record: docs/decisions/2026-12-02-instrument-check.md.

use super::fit::Campaign;
use super::rank::Ranked;
use crate::fit::Estimate;
use nalgebra::{DMatrix, DVector, Matrix2, Vector2};

/// A condition's shape misses a candidate by a common factor when that factor's χ² (two
/// degrees of freedom: ln k and φ, by generalized least squares in the rides' whole
/// covariance) exceeds this; it misses the library when it misses every candidate. The
/// χ²(2) point of p = 10⁻⁶: the check is made once per condition and should never fire on a
/// shape recorded as the model assumes (docs/gap-calibration.md counts how often it did on
/// simulated campaigns with the effects the library lacks).
pub const SHAPE_MISS_CHI2: f64 = 27.63;

/// What an instrument's convention would make of a common factor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Convention {
    /// φ within its error (or 20°) of 180°: the steer (or the roll) measured with its sign
    /// reversed.
    SignReversed,
    /// k within its error (or a factor 1.25) of 180/π: the steer in degrees read as radians
    /// (or the roll in radians where the steer is in degrees).
    SteerInDegrees,
    /// k near π/180: the roll in degrees read as radians.
    RollInDegrees,
    /// In a controlled condition, the shape agrees with the bicycle's without its controller
    /// (ln k within 3 standard errors or ln 1.25 of 0, φ within 3 or 20°): the controller's
    /// model moves the shape where the bicycle's does not, or the controller was off.
    ControllerModel,
}

impl Convention {
    /// In words, for the verdict.
    pub fn words(self) -> &'static str {
        match self {
            Convention::SignReversed => {
                "the phase is off by half a turn: the steer's (or the roll's) sign reversed"
            }
            Convention::SteerInDegrees => {
                "|γ/θ| is 57.3 times the model's: the steer in degrees read as radians"
            }
            Convention::RollInDegrees => {
                "|γ/θ| is 1/57.3 of the model's: the roll in degrees read as radians"
            }
            Convention::ControllerModel => {
                "the shape is the bicycle's without its controller: the controller's model moves the shape where the bicycle's does not (or the controller was off)"
            }
        }
    }
}

/// One condition's shape against the model and the candidates.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ShapeCheck {
    /// The condition (a single campaign's model name).
    pub condition: String,
    /// Its rides with a shape.
    pub rides: usize,
    /// The candidate the figures below are against: the first whose common factor is below
    /// [`SHAPE_MISS_CHI2`] ("none": the model as it is, tried first), or where every one
    /// misses, the one missing least.
    pub against: String,
    /// ln k, the common factor of |γ/θ| (measured / predicted), and φ, the common phase
    /// (measured − predicted, rad), with their standard errors.
    pub log_ratio: Estimate,
    pub phase_rad: Estimate,
    /// The common factor's χ² on two degrees of freedom.
    pub chi2: f64,
    /// The shape misses every candidate: the condition is diagnosed on its eigenvalue alone.
    pub misses: bool,
    /// Where it misses: the common factor against the best candidate of the diagnosis on the
    /// eigenvalue alone (the candidates above were fitted to the shape too, which pulls them
    /// off the bicycle), from which the convention is named.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub against_eigenvalue_fit: Option<CommonFactor>,
    /// What a convention would make of it, when one fits.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub convention: Option<Convention>,
}

/// A common factor of the mode shape against one prediction: ln k and φ (rad) with their
/// standard errors.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CommonFactor {
    /// The prediction's candidate ("none": the model as it is).
    pub against: String,
    pub log_ratio: Estimate,
    pub phase_rad: Estimate,
}

impl ShapeCheck {
    /// The check in words, for the verdict.
    pub fn words(&self) -> String {
        let k = self.log_ratio.value.exp();
        let k_se = k * self.log_ratio.se;
        let mut out = format!(
            "the mode shape of {} ({} rides) misses every candidate by a common factor: |γ/θ| × {k:.3} ± {k_se:.3}, arg γ/θ {:+.1} ± {:.1}° (χ² {:.1} on 2 degrees of freedom against the closest, {})",
            self.condition,
            self.rides,
            self.phase_rad.value.to_degrees(),
            self.phase_rad.se.to_degrees(),
            self.chi2,
            self.against
        );
        if let Some(f) = &self.against_eigenvalue_fit {
            let k = f.log_ratio.value.exp();
            out += &format!(
                "; against the best candidate of the eigenvalues alone, {}: |γ/θ| × {k:.3} ± {:.3}, arg γ/θ {:+.1} ± {:.1}°",
                f.against,
                k * f.log_ratio.se,
                f.phase_rad.value.to_degrees(),
                f.phase_rad.se.to_degrees()
            );
        }
        match self.convention {
            Some(c) => {
                out += "; ";
                out += c.words();
            }
            None => out += "; no convention fits it: the steer read through a gear or about another axis, a filter's lag on the roll, or an effect outside the library",
        }
        out += ". Diagnosed on the eigenvalue alone there";
        out
    }
}

/// The weighted circular mean of `(phase, weight)` pairs (rad): where phase residuals near
/// ±180° are averaged without cancelling, before they are unwrapped near it.
fn circular_mean(phases: impl Iterator<Item = (f64, f64)>) -> f64 {
    let (s, c) = phases.fold((0.0, 0.0), |(s, c), (p, w)| {
        (s + w * p.sin(), c + w * p.cos())
    });
    s.atan2(c)
}

/// The common factor by which the shapes of `rides` miss a prediction: generalized least
/// squares of y = X β, β = (ln k, φ), in `cov` (the rides' shape parts' covariance, factored).
/// For ride i with measured |γ/θ| ρᵢ and residual (Δρᵢ, Δφᵢ), y holds ρᵢ ln(ρᵢ/(ρᵢ − Δρᵢ)) (≈ Δρᵢ
/// for a small factor, so `cov` applies) with X's entry ρᵢ, and Δφᵢ, unwrapped near the
/// residuals' circular mean, with X's entry 1. `None` where a prediction has no shape.
fn common_factor(
    campaign: &Campaign<'_>,
    rides: &[usize],
    residuals: &DVector<f64>,
    cov: &nalgebra::Cholesky<f64, nalgebra::Dyn>,
    phase_var: &[f64],
) -> Option<(Vector2<f64>, Matrix2<f64>)> {
    let n = rides.len();
    let at = |i: usize| campaign.parts.start(i);
    let phases: Vec<f64> = rides.iter().map(|&i| residuals[at(i) + 3]).collect();
    if phases.iter().any(|p| !p.is_finite()) {
        return None;
    }
    let weights: Vec<f64> = phase_var
        .iter()
        .map(|v| 1.0 / v.max(f64::MIN_POSITIVE))
        .collect();
    let centre = circular_mean(phases.iter().copied().zip(weights.iter().copied()));
    let mut y = DVector::zeros(2 * n);
    let mut x = DMatrix::zeros(2 * n, 2);
    for (k, &i) in rides.iter().enumerate() {
        let o = &campaign.obs[i];
        let rho = o.shape_ratio.value;
        let predicted = rho - residuals[at(i) + 2];
        if !(predicted > 0.0 && rho > 0.0) {
            return None;
        }
        y[2 * k] = rho * (rho / predicted).ln();
        x[(2 * k, 0)] = rho;
        y[2 * k + 1] = crate::signal::wrap_near(phases[k], centre);
        x[(2 * k + 1, 1)] = 1.0;
    }
    let wx = cov.l().solve_lower_triangular(&x)?;
    let wy = cov.l().solve_lower_triangular(&y)?;
    let a = wx.tr_mul(&wx);
    let a = Matrix2::new(a[(0, 0)], a[(0, 1)], a[(1, 0)], a[(1, 1)]);
    let b = wx.tr_mul(&wy);
    let beta = a.try_inverse()? * Vector2::new(b[0], b[1]);
    beta.iter().all(|v| v.is_finite()).then_some((beta, a))
}

/// A common factor's phase names a convention within 3 of its standard errors of it, and at
/// least within this (degrees): repeated kicks scatter in phase by about 10° on real bicycles
/// (reports/real.md), and a reversed sign is 180° away.
pub const PHASE_TOLERANCE_DEG: f64 = 20.0;

/// … and its k within 3 standard errors of ln k, or at least within this factor: the steer
/// read through a gear or about another axis, or the model's |γ/θ| off by its parameters,
/// moves k by tens of percent, where degrees move it 57.3 times.
pub const RATIO_TOLERANCE: f64 = 1.25;

/// Whether a common factor is no factor: ln k and φ within [`RATIO_TOLERANCE`] and
/// [`PHASE_TOLERANCE_DEG`] (or 3 standard errors) of 0.
pub fn agrees(f: &CommonFactor) -> bool {
    f.log_ratio.value.abs() <= (3.0 * f.log_ratio.se).max(RATIO_TOLERANCE.ln())
        && f.phase_rad.value.abs() <= (3.0 * f.phase_rad.se).max(PHASE_TOLERANCE_DEG.to_radians())
}

/// Which convention a common factor looks like: its phase within 3 standard errors (at
/// least 20°) of 180°, or its ln k within 3 (at least ln 1.25) of ±ln(180/π).
pub fn convention(f: &CommonFactor) -> Option<Convention> {
    let (log_ratio, log_se) = (f.log_ratio.value, f.log_ratio.se);
    let phase_off = crate::signal::wrap_pi(f.phase_rad.value - std::f64::consts::PI).abs();
    let degrees = (180.0 / std::f64::consts::PI).ln();
    let near_log =
        |target: f64| (log_ratio - target).abs() <= (3.0 * log_se).max(RATIO_TOLERANCE.ln());
    if phase_off <= (3.0 * f.phase_rad.se).max(PHASE_TOLERANCE_DEG.to_radians()) {
        Some(Convention::SignReversed)
    } else if near_log(degrees) {
        Some(Convention::SteerInDegrees)
    } else if near_log(-degrees) {
        Some(Convention::RollInDegrees)
    } else {
        None
    }
}

/// Checks the shape of each condition `c` with `shaped[c]` against the model as it is, then
/// against `ranking`'s candidates in turn until one leaves no common factor beyond
/// [`SHAPE_MISS_CHI2`]; `names[c]` names it. A condition whose shape parts' covariance is not
/// positive definite, or whose predictions have no shape, is left unchecked.
pub(super) fn check_shapes(
    campaign: &Campaign<'_>,
    shaped: &[bool],
    names: &[String],
    ranking: &[Ranked],
) -> Vec<ShapeCheck> {
    let all: Vec<usize> = (0..campaign.obs.len()).collect();
    let mut residuals: Vec<(String, Option<DVector<f64>>)> =
        vec![("none".into(), campaign.residuals(&[], &[], &all))];
    let mut residuals_of = |k: usize| -> Option<(String, Option<DVector<f64>>)> {
        while residuals.len() <= k {
            let r = ranking.get(residuals.len() - 1)?;
            let at = campaign.with_coasting(&r.effects, &r.params);
            residuals.push((r.effect.clone(), at.residuals(&r.effects, &r.params, &all)));
        }
        Some(residuals[k].clone())
    };
    let mut checks = Vec::new();
    for (c, name) in names.iter().enumerate() {
        if !shaped.get(c).copied().unwrap_or(false) {
            continue;
        }
        let rides = campaign.rides_of(c);
        let idx: Vec<usize> = rides
            .iter()
            .flat_map(|&i| {
                let s = campaign.parts.start(i);
                [s + 2, s + 3]
            })
            .collect();
        let block = campaign
            .cov()
            .select_rows(idx.iter())
            .select_columns(idx.iter());
        let phase_var: Vec<f64> = (0..rides.len())
            .map(|k| block[(2 * k + 1, 2 * k + 1)])
            .collect();
        let Some(cov) = block.cholesky() else {
            continue;
        };
        let mut closest: Option<(String, Vector2<f64>, Matrix2<f64>, f64)> = None;
        let mut k = 0;
        while let Some((candidate, r)) = residuals_of(k) {
            k += 1;
            let Some((beta, a)) =
                r.and_then(|r| common_factor(campaign, &rides, &r, &cov, &phase_var))
            else {
                continue;
            };
            let chi2 = beta.dot(&(a * beta));
            if closest.as_ref().is_none_or(|c| chi2 < c.3) {
                closest = Some((candidate, beta, a, chi2));
            }
            if chi2 <= SHAPE_MISS_CHI2 {
                break;
            }
        }
        let Some((against, beta, a, chi2)) = closest else {
            continue;
        };
        let se = a
            .try_inverse()
            .map_or([f64::NAN; 2], |c| [c[(0, 0)].sqrt(), c[(1, 1)].sqrt()]);
        let misses = chi2 > SHAPE_MISS_CHI2;
        checks.push(ShapeCheck {
            condition: name.clone(),
            rides: rides.len(),
            against,
            log_ratio: Estimate {
                value: beta[0],
                se: se[0],
            },
            phase_rad: Estimate {
                value: crate::signal::wrap_pi(beta[1]),
                se: se[1],
            },
            chi2,
            misses,
            against_eigenvalue_fit: None,
            convention: None,
        });
    }
    checks
}

/// The common factor of the shapes in `residuals` (each ride's against one prediction, with
/// the fits' standard errors; in a study, those of `condition`), by weighted least squares of
/// ln(ρ/(ρ − Δρ)) and of Δφ unwrapped near their circular mean: each standard error the larger
/// of the fits' and the one the rides' own scatter about the mean gives (repeated kicks
/// scatter beyond their fits). `None` without two rides of finite shape residuals.
pub fn common_factor_of(
    residuals: &[super::observe::RideResidual],
    condition: Option<&str>,
    against: &str,
    measured_ratio: &dyn Fn(&super::observe::RideResidual) -> Option<f64>,
) -> Option<CommonFactor> {
    let rows: Vec<ShapeRow> = residuals
        .iter()
        .filter(|r| condition.is_none_or(|c| r.condition.as_deref() == Some(c)))
        .filter_map(|r| {
            ShapeRow::new(
                measured_ratio(r)?,
                r.shape_ratio,
                r.shape_ratio_se,
                r.shape_phase_rad,
                r.shape_phase_se_rad,
            )
        })
        .collect();
    factor_of_rows(&rows, against)
}

/// One ride's shape against a prediction: ln(ρ/ρ̂) and its standard error, the phase
/// difference (rad) and its.
pub struct ShapeRow(f64, f64, f64, f64);

impl ShapeRow {
    /// From the measured |γ/θ| `rho`, the residual `d_ratio` = ρ − ρ̂ with the fit's standard
    /// error, and the phase residual with its; `None` where one is not finite or positive.
    pub fn new(
        rho: f64,
        d_ratio: f64,
        ratio_se: f64,
        d_phase_rad: f64,
        phase_se_rad: f64,
    ) -> Option<ShapeRow> {
        let predicted = rho - d_ratio;
        let finite = [ratio_se, d_phase_rad, phase_se_rad]
            .iter()
            .all(|x| x.is_finite());
        (rho > 0.0 && predicted > 0.0 && finite && ratio_se > 0.0 && phase_se_rad > 0.0).then(
            || {
                ShapeRow(
                    (rho / predicted).ln(),
                    ratio_se / rho,
                    d_phase_rad,
                    phase_se_rad,
                )
            },
        )
    }
}

/// [`common_factor_of`] from its rows.
pub fn factor_of_rows(rows: &[ShapeRow], against: &str) -> Option<CommonFactor> {
    if rows.len() < 2 {
        return None;
    }
    let centre = circular_mean(rows.iter().map(|r| (r.2, r.3.powi(-2))));
    let mean = |xs: &[(f64, f64)]| -> Estimate {
        let sw: f64 = xs.iter().map(|(_, se)| se.powi(-2)).sum();
        let m = xs.iter().map(|(x, se)| x * se.powi(-2)).sum::<f64>() / sw;
        let spread =
            xs.iter().map(|(x, se)| ((x - m) / se).powi(2)).sum::<f64>() / (xs.len() - 1) as f64;
        Estimate {
            value: m,
            se: (spread.max(1.0) / sw).sqrt(),
        }
    };
    let logs: Vec<(f64, f64)> = rows.iter().map(|r| (r.0, r.1)).collect();
    let phases: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| (crate::signal::wrap_near(r.2, centre), r.3))
        .collect();
    let phase = mean(&phases);
    Some(CommonFactor {
        against: against.to_string(),
        log_ratio: mean(&logs),
        phase_rad: Estimate {
            value: crate::signal::wrap_pi(phase.value),
            se: phase.se,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn factor(k: f64, phase_deg: f64, se: f64) -> CommonFactor {
        CommonFactor {
            against: "none".into(),
            log_ratio: Estimate { value: k.ln(), se },
            phase_rad: Estimate {
                value: phase_deg.to_radians(),
                se,
            },
        }
    }

    #[test]
    fn a_convention_is_named_by_its_factor() {
        let deg = 180.0 / std::f64::consts::PI;
        assert_eq!(
            convention(&factor(1.1, -172.0, 0.01)),
            Some(Convention::SignReversed)
        );
        assert_eq!(
            convention(&factor(deg * 1.1, 5.0, 0.01)),
            Some(Convention::SteerInDegrees)
        );
        assert_eq!(
            convention(&factor(1.0 / deg, 0.0, 0.01)),
            Some(Convention::RollInDegrees)
        );
        // 150° off is no sign reversal at a 1° error, but is at a 15° one (3 SE = 45°).
        assert_eq!(convention(&factor(1.0, 150.0, 1f64.to_radians())), None);
        assert_eq!(
            convention(&factor(1.0, 150.0, 15f64.to_radians())),
            Some(Convention::SignReversed)
        );
        assert_eq!(convention(&factor(1.4, 30.0, 0.01)), None);
        assert!(agrees(&factor(1.2, -15.0, 0.01)));
        assert!(!agrees(&factor(1.3, 0.0, 0.01)));
        assert!(!agrees(&factor(1.0, 25.0, 0.01)));
    }

    /// The rows' weighted mean: equal errors and no scatter beyond them give the plain mean
    /// with the formal error σ/√n; rows scattered beyond their errors widen it by the
    /// scatter (the sample standard deviation over √n).
    #[test]
    fn the_common_factor_is_the_rows_weighted_mean() {
        let rows = |ks: &[f64], phases_deg: &[f64], se: f64| -> Vec<ShapeRow> {
            ks.iter()
                .zip(phases_deg)
                .map(|(k, p)| {
                    // ρ = 2 measured, the prediction 2/k.
                    ShapeRow::new(2.0, 2.0 - 2.0 / k, 2.0 * se, p.to_radians(), se).unwrap()
                })
                .collect()
        };
        let f = factor_of_rows(
            &rows(&[1.5, 1.5, 1.5, 1.5], &[179.0, -179.0, 179.0, -179.0], 0.1),
            "x",
        )
        .unwrap();
        assert!((f.log_ratio.value - 1.5f64.ln()).abs() < 1e-12);
        assert!((f.log_ratio.se - 0.1 / 2.0).abs() < 1e-12);
        // Across ±180° the phases average to 180°, not to 0.
        assert!((f.phase_rad.value.abs() - std::f64::consts::PI).abs() < 1e-9);
        let ks = [1.0f64, 2.0, 3.0];
        let f = factor_of_rows(&rows(&ks, &[0.0, 0.0, 0.0], 1e-3), "x").unwrap();
        let logs: Vec<f64> = ks.iter().map(|k| k.ln()).collect();
        let mean = logs.iter().sum::<f64>() / 3.0;
        let sd = (logs.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / 2.0).sqrt();
        assert!((f.log_ratio.value - mean).abs() < 1e-12);
        assert!((f.log_ratio.se - sd / 3f64.sqrt()).abs() < 1e-12);
    }
}
