//! The diagnosis in words. In: a finished [`Diagnosis`]. Out: the verdict (where the gap lies,
//! whether it is significant, which candidate explains it or why none does, how far it shrinks,
//! what to ride next) and the human-readable table of `bikeproc gap`.

use super::diagnosis::Diagnosis;
use super::effects::{self, spaced, Effect};
use super::observe::{weighted_mean, RideResidual};
use super::thresholds::{EXPLAINED_HELDOUT_RMS, SIGNIFICANCE, TIE_SE};
use crate::stats;
use std::fmt::Write as _;

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
    // A condition whose shape the instrument check set aside leaves its shape out.
    let set_aside = |r: &RideResidual| {
        d.instrument
            .iter()
            .any(|c| c.misses && r.condition.as_deref().is_none_or(|n| n == c.condition))
    };
    let rms = |f: &dyn Fn(&RideResidual) -> f64| -> f64 {
        let v: Vec<f64> = res
            .iter()
            .filter(|r| !set_aside(r))
            .map(f)
            .filter(|x| x.is_finite())
            .collect();
        (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
    };
    let all = |f: &dyn Fn(&RideResidual) -> f64| -> f64 {
        let v: Vec<f64> = res.iter().map(f).filter(|x| x.is_finite()).collect();
        (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
    };
    let parts = [
        ("the damping rate σ", all(&|r| r.re_z)),
        ("the frequency ω", all(&|r| r.im_z)),
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
pub(super) fn verdict(d: &Diagnosis) -> String {
    let mut v = headline(d);
    v.push('\n');
    let part = |name: &str, unit: &str, sel: &dyn Fn(&RideResidual) -> (f64, f64, f64)| {
        // (In a study, rides with the eigenvalue alone have no shape residual.)
        let measured = || d.residuals.iter().filter(|r| sel(r).2.is_finite());
        let beyond = measured().filter(|r| sel(r).2.abs() > 2.0).count();
        let m = weighted_mean(measured().map(|r| {
            let (x, se, _) = sel(r);
            (x, se)
        }));
        let (mean, se) = (m.value, m.se);
        let dir = if mean < 0.0 { "lower" } else { "higher" };
        format!(
            "{name} {dir} than the model's by {:.3} ± {:.3} {unit} on average ({beyond} of {} rides beyond 2σ)",
            mean.abs(),
            se,
            measured().count()
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
    for check in d.instrument.iter().filter(|c| c.misses) {
        let _ = writeln!(v, "Instrument: {}.", check.words());
    }
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
        "; the campaign's test, either of the two: {}.",
        stats::p_is(d.campaign_p_value)
    );
    if !d.significant {
        if !d.detection_limits.is_empty() {
            v.push('\n');
            v.push_str(&super::significance::detection_text(&d.detection_limits));
        }
        return v;
    }
    v.push('\n');
    let Some(best) = d.ranking.first() else {
        v.push_str("Which: no candidate could be fitted.");
        return v;
    };
    let named: Vec<(Effect, effects::ParamSpec)> = best
        .param_effect
        .iter()
        .zip(&best.specs)
        .map(|(&j, spec)| (best.effects[j], *spec))
        .collect();
    let params: Vec<String> = named
        .iter()
        .zip(best.param_texts())
        .enumerate()
        .map(|(k, ((e, spec), text))| {
            let sep = if text.starts_with(['≤', '≥']) {
                " "
            } else {
                " = "
            };
            let (lo, hi) = spec.plausible;
            let at_bound = best.at_bound.get(k).copied().unwrap_or(false);
            let outside = match best.params.get(k) {
                Some(&p) if !at_bound && !super::rank::plausible(spec, p, best.params_se[k]) => {
                    format!(
                        ", {} the {} taken as plausible",
                        if p < lo { "below" } else { "above" },
                        range_text(lo, hi, spec.unit)
                    )
                }
                _ => String::new(),
            };
            format!("{} {}{sep}{text}{outside}", e.name(), spec.name)
        })
        .collect();
    let shrink = 1.0 - best.heldout_rms_after / best.heldout_rms_before;
    if !d.explained {
        let _ = write!(
            v,
            "Which: the closest candidate is {} ({}).\nHow far: with it, the rides left out lie at an RMS of {:.2} standard errors from their predictions (from {:.2}), and its fit to every ride gives χ² = {:.1} ({}).\n",
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

/// The verdict's first sentence: whether the gap is explained, and why, with the numbers of
/// the test that decides it (the campaign's test; then the best candidate's held-out RMS
/// against [`EXPLAINED_HELDOUT_RMS`] and its χ² test at the significance level).
fn headline(d: &Diagnosis) -> String {
    let test = format!(
        "the campaign's test gives {}",
        stats::p_is(d.campaign_p_value)
    );
    if !d.significant {
        return format!(
            "No significant gap: {test}, above the {} level{}.",
            SIGNIFICANCE,
            if d.parameters_could_explain {
                "; without the measured parameters' uncertainty there would be one, so the rides part from the model by no more than the inertia measurements allow"
            } else {
                ""
            }
        );
    }
    let Some(best) = d.ranking.first() else {
        return format!(
            "Not explained: a significant gap ({test}), and no candidate could be fitted."
        );
    };
    let dof = d.dof.saturating_sub(best.params.len()).max(1);
    let rms = format!(
        "the rides left out lie at an RMS of {:.2} standard errors from its predictions (from {:.2} without it; an explanation reaches {EXPLAINED_HELDOUT_RMS} or less)",
        best.heldout_rms_after, best.heldout_rms_before
    );
    let chi2 = format!(
        "its fit to every ride gives χ² = {:.1} on {dof} degrees of freedom ({})",
        best.chi2,
        stats::p_is(d.best_fit_p_value)
    );
    if d.explained {
        return format!(
            "Explained: a significant gap ({test}) that {} accounts for: {rms}, and {chi2}, which passes at the {} level.",
            best.effect,
            SIGNIFICANCE
        );
    }
    let mut fails = Vec::new();
    if best.heldout_rms_after > EXPLAINED_HELDOUT_RMS
        || best.heldout_rms_after >= best.heldout_rms_before
    {
        fails.push(format!("the held-out test ({rms})"));
    }
    if d.best_fit_p_value < SIGNIFICANCE {
        fails.push(format!(
            "the χ² test at the {} level ({chi2})",
            SIGNIFICANCE
        ));
    }
    format!(
        "Not explained: a significant gap ({test}) that no candidate of the library accounts for; the closest, {}, fails {}.",
        best.effect,
        fails.join(" and ")
    )
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
        // The rides already set the pair's predictions apart by what the test needs, and the
        // pair still ties: neither fits them better where they differ, and more of the same
        // rides are not expected to change that.
        Some(0) => format!(
            "the rides so far already set the closest pair's predictions apart by more than the test needs (a squared separation of {least:.1} of {:.0}), yet neither fits them better where they differ, so more rides like these are not expected to tell them apart",
            next.separation_needed
        ),
        Some(n) => format!(
            "about {n} rides there, alternately, are expected to tell them apart (the rides so far give the closest pair a squared separation of {least:.1} of the {:.0} the test needs)",
            next.separation_needed
        ),
        None => format!(
            "no number of rides is: the rides so far give the closest pair a squared separation of {least:.1} of the {:.0} the test needs, and more rides add almost nothing, because the candidates differ by less than the measured bicycle's own uncertainty moves its weave; measure the bicycle better",
            next.separation_needed
        ),
    };
    let mut out = format!(
        "\nNext: the rides that best tell the tied candidates apart are at {}; {how_many}.",
        rides.join(" and at ")
    );
    if let Some(c) = d.next_conditions.first() {
        let most = c.separation_se.iter().copied().fold(0.0, f64::max);
        let now = next
            .rides
            .first()
            .map_or(0.0, |r| r.separation_se.iter().copied().fold(0.0, f64::max));
        if most > now {
            let _ = write!(
                out,
                "\nBetter, change a known thing: {} ({} otherwise as it was), ridden at {:.2} m/s, sets the tied candidates' predictions of one ride up to {most:.1} of its standard errors apart (a ride as the campaign stands, up to {now:.1}).",
                c.change, c.from, c.speed_mps
            );
        } else {
            let _ = write!(
                out,
                "\nNo known change tried (the controller off or its gains halved or doubled, {} kg at either frame's centre of mass) sets them further apart than a ride as the campaign stands (the best, {}, up to {most:.1} of a ride's standard errors).",
                super::ties::KNOWN_MASS_KG,
                c.change
            );
        }
    }
    out
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
        let rides = if self.rides_failed.is_empty() {
            format!("{} rides", self.rides_used)
        } else {
            format!(
                "{} of {} rides; {} not analysed",
                self.rides_used,
                self.rides_used + self.rides_failed.len(),
                self.rides_failed.len()
            )
        };
        let _ = writeln!(
            out,
            "Where: experiment − model, in combined standard errors ({rides})"
        );
        for f in &self.rides_failed {
            let _ = writeln!(out, "  not analysed: {f}");
        }
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
        let pooled = self
            .between_kick_scatter
            .as_ref()
            .map_or(Vec::new(), |s| s.per_part.clone());
        for c in &self.conditions {
            let _ = writeln!(
                out,
                "  condition {}: {} rides, χ² {:.1} / {}{}",
                c.name,
                c.rides_used,
                c.chi2,
                c.dof,
                c.why_chi2_differs(&pooled)
                    .map_or(String::new(), |w| format!(" ({w})"))
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
        let order = if self.ranking.first().is_some_and(|r| r.in_study()) {
            "the held-out RMS normalized residual of the conditions left out"
        } else {
            "the BIC of the fit to every ride (χ² + k ln 2N) plus the prior's penalty"
        };
        let first = if self.ranking.first().is_some_and(|r| r.in_study()) {
            "the bicycle fitted inside its search's ranges first"
        } else {
            "no parameter at a search's bound first"
        };
        let _ = writeln!(
            out,
            "Which: candidates fitted on {}, {first}, then by {order};\n  pairs of effects are listed only where they beat the best single one on the rides left out,\n  and named ahead of it only where the tie test tells them apart; otherwise after it",
            decided_on(self.parts_per_ride)
        );
        let _ = writeln!(
            out,
            "  (before/after: the rides left out, predicted without and with the candidate, RMS in\n  their standard errors, about 1 where the model holds; plausible: every parameter where a\n  real bicycle's can be; prior: what the values outside their plausible ranges cost, in χ²)"
        );
        let rows: Vec<(String, String)> = self
            .ranking
            .iter()
            .map(|r| (r.effect.clone(), named_params(r)))
            .collect();
        let width = |f: &dyn Fn(&(String, String)) -> usize, least: usize| {
            rows.iter().map(f).max().unwrap_or(0).max(least)
        };
        let (we, wp) = (
            width(&|r| r.0.chars().count(), 6),
            width(&|r| r.1.chars().count(), 10),
        );
        let _ = writeln!(
            out,
            "  {:<we$}  {:<wp$} {:>8} {:>6} {:>8} {:>8} {:>9}",
            "effect", "parameters", "BIC", "prior", "before", "after", "plausible"
        );
        for (r, (effect, params)) in self.ranking.iter().zip(&rows) {
            let _ = writeln!(
                out,
                "  {effect:<we$}  {params:<wp$} {:>8.1} {:>6.1} {:>8.2} {:>8.2} {:>9}",
                r.bic,
                r.prior_penalty,
                r.heldout_rms_before,
                r.heldout_rms_after,
                if r.plausible { "yes" } else { "no" }
            );
        }
        let _ = writeln!(out, "Verdict:");
        for line in self.verdict.lines() {
            let _ = writeln!(out, "  {line}");
        }
        out
    }
}

/// A candidate's parameters in words, each named where its effect has more than one
/// (`cornering 11.8 ± 0.5 1/rad, relaxation 0.15 ± 0.03 m`), the effects' separated by `; `.
fn named_params(r: &super::rank::Ranked) -> String {
    let texts = r.param_texts();
    r.effects
        .iter()
        .enumerate()
        .map(|(j, e)| {
            let several = e.params().len() > 1;
            (0..texts.len())
                .filter(|&k| r.param_effect.get(k) == Some(&j))
                .map(|k| {
                    if several {
                        format!("{} {}", r.specs[k].name, texts[k])
                    } else {
                        texts[k].clone()
                    }
                })
                .collect::<Vec<_>>()
                .join(", ")
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// A plausible range in words: `0.3–1.5 × nominal`.
fn range_text(lo: f64, hi: f64, unit: &str) -> String {
    let num = |x: f64| {
        let t = format!("{x:.3}");
        t.trim_end_matches('0').trim_end_matches('.').to_string()
    };
    format!("{}–{}{}", num(lo), num(hi), spaced(unit))
}
