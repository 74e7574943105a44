//! Exporters of the model's results: plain text and JSON for `bikeproc stability`.

use super::uncertain::{Bands, SpeedsWithSe};
use serde::Serialize;
use std::fmt::Write as _;

/// One speed's eigenvalues, named, and all four.
#[derive(Debug, Clone, Serialize)]
pub struct EigenRow {
    pub speed_mps: f64,
    /// The weave: the eigenvalue with ω > 0 where the weave oscillates; below the speed where
    /// its two real roots merge ([`StabilityReport::weave_merge_speed_mps`]), the larger of them.
    pub weave: Part,
    /// The weave's other eigenvalue: its conjugate where it oscillates, the other real root
    /// below the merge speed.
    pub weave_second: Part,
    /// The capsize mode's eigenvalue (real; where capsize and castor form a complex pair at
    /// low speed, one of that pair, and `castor` the other).
    pub capsize: Part,
    pub castor: Part,
    /// Every eigenvalue of the model at this speed (four), by decreasing real part, then
    /// decreasing imaginary part: the named ones above, in another order.
    pub all: Vec<Eigenvalue>,
    /// The weave's mode shape: |δ/φ| and the phase of steer ahead of roll (deg); absent where
    /// the weave is not oscillatory.
    pub weave_steer_over_roll: Option<f64>,
    pub weave_steer_phase_deg: Option<f64>,
}

/// An eigenvalue (1/s).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Eigenvalue {
    pub re: f64,
    pub im: f64,
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
    /// The characteristic speeds were searched from 0 to this speed (m/s, the grid's END): a
    /// weave or capsize speed beyond it is not seen, and an open range may end beyond it.
    pub searched_to_mps: f64,
    pub eigenvalues: Vec<EigenRow>,
}

/// What a speed grid START:END:STEP must be for [`StabilityReport::over`].
pub const SPEED_GRID_RULE: &str = "expected START:END:STEP in m/s, finite, with 0 ≤ START < END ≤ \
     100 and 0 < STEP (at most a million speeds)";

/// The highest speed a grid may reach (m/s): beyond any bicycle's, and the characteristic
/// speeds' search (every 0.01 m/s up to END) stays within 10,000 eigenproblems.
pub const MAX_GRID_SPEED_MPS: f64 = 100.0;

/// Whether `(start, end, step)` is a speed grid [`StabilityReport::over`] takes
/// ([`SPEED_GRID_RULE`]).
pub fn valid_speed_grid((start, end, step): (f64, f64, f64)) -> bool {
    [start, end, step].iter().all(|x| x.is_finite())
        && start >= 0.0
        && end > start
        && end <= MAX_GRID_SPEED_MPS
        && step > 0.0
        && (end - start) / step <= 1e6
}

/// The speeds of a grid START:END:STEP: START, START + STEP, … up to END, never beyond it (a
/// step that does not divide the range stops short; `0:10:20` is the one speed 0, not 0 and
/// 20).
pub fn speed_grid((lo, hi, step): (f64, f64, f64)) -> Vec<f64> {
    let n = ((hi - lo) / step + 1e-9).floor() as usize;
    (0..=n).map(|i| lo + i as f64 * step).collect()
}

impl StabilityReport {
    /// `bikeproc stability --speeds LO:HI:STEP`: the eigenvalues with their standard errors at
    /// LO, LO + STEP, … HI, and the weave and capsize speeds and stable ranges searched to HI
    /// at steps of 0.01 m/s and refined by root finding (to 1e-13 m/s: a finer search finds
    /// the same speeds, in ten times the time for each tenth of the step).
    pub fn over(
        p: &super::uncertain::Parametrized,
        (lo, hi, step): (f64, f64, f64),
    ) -> Result<StabilityReport, super::ParamError> {
        let speeds = speed_grid((lo, hi, step));
        let s = p.speeds(hi, 0.01)?;
        let bands = p.bands(&speeds)?;
        Ok(StabilityReport::new(
            &p.name,
            &s,
            &bands,
            &p.nominal_canonical(),
            hi,
        ))
    }

    /// The report of the speeds `s` (searched from 0 to `searched_to_mps`) and the bands `b`.
    pub fn new(
        name: &str,
        s: &SpeedsWithSe,
        b: &Bands,
        model: &super::Canonical,
        searched_to_mps: f64,
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
            searched_to_mps,
            eigenvalues: (0..b.sweep.speeds_mps.len())
                .map(|i| {
                    let (v, w) = (b.sweep.speeds_mps[i], b.sweep.eigenvalues[i][0]);
                    let shape = (w.im.abs() > 1e-9)
                        .then(|| model.mode_shape(v, w))
                        .flatten()
                        .filter(|m| m[0].norm() > 0.0);
                    let ratio = shape.map(|m| m[1] / m[0]);
                    let mut all: Vec<Eigenvalue> = b.sweep.eigenvalues[i]
                        .iter()
                        .map(|z| Eigenvalue { re: z.re, im: z.im })
                        .collect();
                    all.sort_by(|a, b| b.re.total_cmp(&a.re).then(b.im.total_cmp(&a.im)));
                    EigenRow {
                        speed_mps: v,
                        weave: part(i, 0),
                        weave_second: part(i, 1),
                        capsize: part(i, 2),
                        castor: part(i, 3),
                        all,
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
            None => format!(
                "none up to {} m/s (the end of the search)",
                crate::stats::number_text(self.searched_to_mps)
            ),
        };
        let _ = writeln!(
            s,
            "{}: linearized Whipple model (Meijaard et al. 2007)",
            self.bike
        );
        let mut ranges = super::ranges_text(&self.stable_ranges_mps, 4, " m/s");
        if let (Some(last), Some((lo, None))) = (ranges.last_mut(), self.stable_ranges_mps.last()) {
            *last = format!(
                "{lo:.4} m/s to at least {} m/s (the end of the search)",
                crate::stats::number_text(self.searched_to_mps)
            );
        }
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
            "\n  {:>8}  {:>26}  {:>26}",
            "v (m/s)", "weave (1/s)", "capsize, castor (1/s)"
        );
        let every = (self.eigenvalues.len() / 20).max(1);
        for r in self.eigenvalues.iter().step_by(every) {
            let _ = writeln!(
                s,
                "  {:>8.3}  {:>26}  {:>26}",
                r.speed_mps,
                pair_text(&r.weave, &r.weave_second),
                pair_text(&r.capsize, &r.castor),
            );
        }
        let _ = writeln!(
            s,
            "\n  A pair is two real roots (a, b) or one complex pair (a ± bi): below the weave's \
             merge speed its two real roots; at low speed capsize and castor may join in a pair."
        );
        s
    }
}

/// Two eigenvalues as text: `re ± im i` when they are a complex pair, `a, b` when real.
fn pair_text(a: &Part, b: &Part) -> String {
    if a.im.abs() > 1e-9 {
        format!("{:.5} ± {:.5}i", a.re, a.im.abs())
    } else {
        format!("{:.5}, {:.5}", a.re.max(b.re), a.re.min(b.re))
    }
}
