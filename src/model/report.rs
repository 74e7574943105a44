//! Exporters of the model's results: plain text and JSON for `bikeproc stability`.

use super::uncertain::{Bands, SpeedsWithSe};
use serde::Serialize;
use std::fmt::Write as _;

/// One speed's eigenvalues, named.
#[derive(Debug, Clone, Serialize)]
pub struct EigenRow {
    pub speed_mps: f64,
    pub weave: Part,
    pub capsize: Part,
    pub castor: Part,
    /// The weave's mode shape: |δ/φ| and the phase of steer ahead of roll (deg); absent where
    /// the weave is not oscillatory.
    pub weave_steer_over_roll: Option<f64>,
    pub weave_steer_phase_deg: Option<f64>,
}

/// A complex eigenvalue with the standard errors of its parts (1/s).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Part {
    pub re: f64,
    pub im: f64,
    pub re_se: f64,
    pub im_se: f64,
}

/// What `bikeproc stability` prints.
#[derive(Debug, Clone, Serialize)]
pub struct StabilityReport {
    pub bike: String,
    pub weave_speed_mps: Option<f64>,
    pub weave_speed_se_mps: Option<f64>,
    pub capsize_speed_mps: Option<f64>,
    pub capsize_speed_se_mps: Option<f64>,
    pub weave_merge_speed_mps: Option<f64>,
    /// `[[lo, hi], …]`, `hi` null when stable up to the end of the speeds searched.
    pub stable_ranges_mps: Vec<(f64, Option<f64>)>,
    pub eigenvalues: Vec<EigenRow>,
}

/// What a speed grid START:END:STEP must be for [`StabilityReport::over`].
pub const SPEED_GRID_RULE: &str =
    "expected START:END:STEP with 0 ≤ START < END and 0 < STEP (at most a million speeds)";

/// Whether `(start, end, step)` is a speed grid [`StabilityReport::over`] takes
/// ([`SPEED_GRID_RULE`]).
pub fn valid_speed_grid((start, end, step): (f64, f64, f64)) -> bool {
    start >= 0.0 && end > start && step > 0.0 && (end - start) / step <= 1e6
}

impl StabilityReport {
    /// `bikeproc stability --speeds LO:HI:STEP`: the eigenvalues with their standard errors at
    /// LO, LO + STEP, … HI, and the weave and capsize speeds and stable ranges searched to HI
    /// at steps of STEP (at most 0.01 m/s).
    pub fn over(
        p: &super::uncertain::Parametrized,
        (lo, hi, step): (f64, f64, f64),
    ) -> Result<StabilityReport, super::ParamError> {
        let speeds: Vec<f64> = (0..=((hi - lo) / step).round() as usize)
            .map(|i| lo + i as f64 * step)
            .collect();
        let s = p.speeds(hi, step.min(0.01))?;
        let bands = p.bands(&speeds)?;
        Ok(StabilityReport::new(
            &p.name,
            &s,
            &bands,
            &p.nominal_canonical(),
        ))
    }

    pub fn new(
        name: &str,
        s: &SpeedsWithSe,
        b: &Bands,
        model: &super::Canonical,
    ) -> StabilityReport {
        let part = |i: usize, k: usize| {
            let z = b.sweep.eigenvalues[i][k];
            Part {
                re: z.re,
                im: z.im,
                re_se: b.se[i][k].0,
                im_se: b.se[i][k].1,
            }
        };
        StabilityReport {
            bike: name.into(),
            weave_speed_mps: s.stability.weave_speed_mps,
            weave_speed_se_mps: s.weave_speed_se_mps,
            capsize_speed_mps: s.stability.capsize_speed_mps,
            capsize_speed_se_mps: s.capsize_speed_se_mps,
            weave_merge_speed_mps: s.stability.weave_merge_speed_mps,
            stable_ranges_mps: s.stability.stable_ranges_mps.clone(),
            eigenvalues: (0..b.sweep.speeds_mps.len())
                .map(|i| {
                    let (v, w) = (b.sweep.speeds_mps[i], b.sweep.eigenvalues[i][0]);
                    let shape = (w.im.abs() > 1e-9)
                        .then(|| model.mode_shape(v, w))
                        .flatten()
                        .filter(|m| m[0].norm() > 0.0);
                    let ratio = shape.map(|m| m[1] / m[0]);
                    EigenRow {
                        speed_mps: v,
                        weave: part(i, 0),
                        capsize: part(i, 2),
                        castor: part(i, 3),
                        weave_steer_over_roll: ratio.map(|r| r.norm()),
                        weave_steer_phase_deg: ratio.map(|r| r.arg().to_degrees()),
                    }
                })
                .collect(),
        }
    }

    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let sp = |v: Option<f64>, se: Option<f64>| match v {
            Some(v) => match se {
                Some(se) => format!("{v:.4} ± {se:.4} m/s"),
                None => format!("{v:.4} m/s (standard error unavailable)"),
            },
            None => "none in the range".into(),
        };
        let _ = writeln!(
            s,
            "{}: linearized Whipple model (Meijaard et al. 2007)",
            self.bike
        );
        let ranges = super::ranges_text(&self.stable_ranges_mps, 4, " m/s");
        let _ = writeln!(
            s,
            "  stable         {}",
            if ranges.is_empty() {
                "at no speed in the range".to_string()
            } else {
                ranges.join(", ")
            }
        );
        let _ = writeln!(
            s,
            "  weave speed    {}",
            sp(self.weave_speed_mps, self.weave_speed_se_mps)
        );
        let _ = writeln!(
            s,
            "  capsize speed  {}",
            sp(self.capsize_speed_mps, self.capsize_speed_se_mps)
        );
        if let Some(m) = self.weave_merge_speed_mps {
            let _ = writeln!(
                s,
                "  weave appears  {m:.4} m/s (its real pair merges into a complex pair)"
            );
        }
        let _ = writeln!(
            s,
            "\n  {:>8}  {:>26}  {:>12}  {:>12}",
            "v (m/s)", "weave (1/s)", "capsize", "castor"
        );
        let every = (self.eigenvalues.len() / 20).max(1);
        for r in self.eigenvalues.iter().step_by(every) {
            let _ = writeln!(
                s,
                "  {:>8.3}  {:>12.5} {:>+12.5}i  {:>12.5}{}  {:>12.5}{}",
                r.speed_mps,
                r.weave.re,
                r.weave.im,
                r.capsize.re,
                if r.capsize.im.abs() > 1e-9 {
                    format!(" {:+.3}i", r.capsize.im)
                } else {
                    String::new()
                },
                r.castor.re,
                if r.castor.im.abs() > 1e-9 {
                    format!(" {:+.3}i", r.castor.im)
                } else {
                    String::new()
                },
            );
        }
        s
    }
}
