//! Comparison: several bicycles → their weave and capsize speeds side by side, each with its
//! standard error, and each one's difference from the first in combined standard errors.
//!
//! In: [`Parametrized`] bicycles (with a rider, a controller, as the command built them).
//! Out: [`Comparison`]. The bicycles' parameters are measured apart, so a difference's standard
//! error combines the two in quadrature (`√(se_a² + se_b²)`); two files made from the same
//! measurements are not independent and their difference's error is then overstated.

use super::uncertain::Parametrized;
use super::ParamError;
use crate::fit::Estimate;

/// A difference from the first bicycle: value, combined standard error and their ratio.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Difference {
    pub value: f64,
    pub se: f64,
    /// value / se (`None` when neither speed has an error).
    pub z: Option<f64>,
}

/// One bicycle's row.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Compared {
    pub bike: String,
    pub stable_ranges_mps: Vec<(f64, Option<f64>)>,
    pub weave_speed_mps: Option<Estimate>,
    pub capsize_speed_mps: Option<Estimate>,
    /// This bicycle's speed less the first's (`None` for the first, or where either has none).
    pub weave_speed_difference_mps: Option<Difference>,
    pub capsize_speed_difference_mps: Option<Difference>,
}

/// Several bicycles side by side.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Comparison {
    /// The speeds searched (m/s): 0 to this.
    pub max_speed_mps: f64,
    pub bikes: Vec<Compared>,
}

/// The characteristic speeds of every bicycle in `[0, v_max]` and their differences from the
/// first's.
pub fn compare(models: &[Parametrized], v_max: f64) -> Result<Comparison, ParamError> {
    let mut bikes: Vec<Compared> = Vec::with_capacity(models.len());
    for m in models {
        let s = m.speeds(v_max, 0.01)?;
        let est = |v: Option<f64>, se: Option<f64>| {
            v.map(|value| Estimate {
                value,
                se: se.unwrap_or(f64::NAN),
            })
        };
        bikes.push(Compared {
            bike: m.name.clone(),
            stable_ranges_mps: s.stability.stable_ranges_mps.clone(),
            weave_speed_mps: est(s.stability.weave_speed_mps, s.weave_speed_se_mps),
            capsize_speed_mps: est(s.stability.capsize_speed_mps, s.capsize_speed_se_mps),
            weave_speed_difference_mps: None,
            capsize_speed_difference_mps: None,
        });
    }
    let diff = |a: Option<Estimate>, b: Option<Estimate>| {
        let (a, b) = (a?, b?);
        let se = a.se.hypot(b.se);
        Some(Difference {
            value: a.value - b.value,
            se,
            z: (se > 0.0).then(|| (a.value - b.value) / se),
        })
    };
    if let Some(first) = bikes.first().cloned() {
        for b in bikes.iter_mut().skip(1) {
            b.weave_speed_difference_mps = diff(b.weave_speed_mps, first.weave_speed_mps);
            b.capsize_speed_difference_mps = diff(b.capsize_speed_mps, first.capsize_speed_mps);
        }
    }
    Ok(Comparison {
        max_speed_mps: v_max,
        bikes,
    })
}

impl Comparison {
    /// The table `bikeproc compare` prints.
    pub fn to_text(&self) -> String {
        use std::fmt::Write as _;
        let speed = |e: &Option<Estimate>| {
            e.map_or("—".to_string(), |e| {
                format!("{:.4} ± {:.4}", e.value, e.se)
            })
        };
        let diff = |d: &Option<Difference>| {
            d.map_or("".to_string(), |d| {
                format!(
                    "{:+.4} ± {:.4}{}",
                    d.value,
                    d.se,
                    d.z.map_or(String::new(), |z| format!(" ({z:+.1} SE)"))
                )
            })
        };
        let mut s = format!(
            "Weave and capsize speeds (m/s, searched in 0–{} m/s), each bicycle against the first \
             (differences in combined standard errors, the bicycles measured apart):\n\n",
            self.max_speed_mps
        );
        for b in &self.bikes {
            let ranges = super::ranges_text(&b.stable_ranges_mps, 3, " m/s");
            let _ = writeln!(s, "  {}", b.bike);
            let _ = writeln!(
                s,
                "    stable         {}",
                if ranges.is_empty() {
                    "nowhere in the range searched".to_string()
                } else {
                    ranges.join(", ")
                }
            );
            let _ = writeln!(
                s,
                "    weave speed    {:<20} {}",
                speed(&b.weave_speed_mps),
                diff(&b.weave_speed_difference_mps)
            );
            let _ = writeln!(
                s,
                "    capsize speed  {:<20} {}",
                speed(&b.capsize_speed_mps),
                diff(&b.capsize_speed_difference_mps)
            );
        }
        s
    }
}
