//! Plain-text and JSON exporters of the inertia stage's results.

use super::{BarCalibration, CompoundResult, TensorXz, TorsionResult};
use serde_json::{json, Value};
use std::fmt::Write as _;

fn pm(v: f64, se: f64) -> String {
    format!("{v:.4} ± {se:.4}")
}

pub fn calibration_text(c: &BarCalibration) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "torsion-bar calibration (seed §5.3.3.2)");
    let _ = writeln!(
        s,
        "  rod inertia       I = {:.5} ± {:.5} kg·m² (eq. 65, from its dimensions)",
        c.rod_inertia_kgm2, c.rod_inertia_se_kgm2
    );
    let _ = writeln!(
        s,
        "  rod frequency     f = {:.5} ± {:.5} Hz (natural, {} repeats)",
        c.freq_hz,
        c.freq_se_hz,
        c.tests.first().map_or(0, |t| t.repeats.len())
    );
    if let Some(ff) = c.fixture_freq_hz {
        let _ = writeln!(s, "  fixture           I_f = {:.2e} ± {:.1e} kg·m² (empty-fixture test at {ff:.3} Hz; correlation with k {:+.2})", c.fixture_inertia_kgm2, c.fixture_inertia_se_kgm2, c.stiffness_fixture_correlation);
    }
    let _ = writeln!(
        s,
        "  stiffness         k = {:.3} ± {:.3} N·m/rad (eq. 67)",
        c.stiffness_nm_per_rad, c.stiffness_se_nm_per_rad
    );
    if let Some(t) = c.theory_stiffness_nm_per_rad {
        let _ = writeln!(s, "  theory            G·I_p/L = {t:.2} N·m/rad (eq. 64)");
    }
    s
}

pub fn calibration_json(c: &BarCalibration) -> Value {
    serde_json::to_value(c).unwrap_or(Value::Null)
}

fn tensor_text(s: &mut String, t: &TensorXz) {
    let _ = writeln!(
        s,
        "  tensor from orientations {}{}: I_xx = {}, I_xz = {}, I_zz = {} kg·m²",
        t.orientations.join(", "),
        if t.handlebar_constraint {
            " (I_xz = −I_zz)"
        } else {
            ""
        },
        pm(t.ixx, t.ixx_se),
        pm(t.ixz, t.ixz_se),
        pm(t.izz, t.izz_se)
    );
    let _ = writeln!(
        s,
        "    principal {:.4}, {:.4} kg·m², first axis at {:.1}° from x; condition number {:.1}; {}",
        t.principal_kgm2[0],
        t.principal_kgm2[1],
        t.principal_axis_deg,
        t.condition_number,
        match t.chi2_p_value {
            Some(p) => format!(
                "χ² {:.2} on {} degree{} of freedom ({})",
                t.chi2,
                t.chi2_dof,
                if t.chi2_dof == 1 { "" } else { "s" },
                crate::stats::p_is(p)
            ),
            None => "exactly determined (no χ² test)".into(),
        }
    );
    for w in &t.warnings {
        let _ = writeln!(s, "    warning: {w}");
    }
}

pub fn torsion_text(r: &TorsionResult) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{} ({} kg), torsion tests; k = {:.3} ± {:.3} N·m/rad, fixture {:.1e} kg·m²",
        r.body,
        r.mass_kg,
        r.stiffness_nm_per_rad,
        r.stiffness_se_nm_per_rad,
        r.fixture_inertia_kgm2
    );
    let _ = writeln!(
        s,
        "  {:<6} {:>20} {:>18} {:>18} {:>18} {:>8}",
        "test", "f (Hz)", "with weights", "without weights", "about the CG", "repeats"
    );
    let _ = writeln!(
        s,
        "  {:<6} {:>20} {:>18} {:>18} {:>18} {:>8}",
        "", "", "(kg·m²)", "(kg·m²)", "(kg·m²)", "spread"
    );
    for o in &r.orientations {
        let flagged = o.repeats.iter().filter(|x| x.outlier).count();
        let _ = writeln!(
            s,
            "  {:<6} {:>20} {:>18} {:>18} {:>18} {:>7.2}%{}",
            o.name,
            format!("{:.5} ± {:.5}", o.freq_hz, o.freq_se_hz),
            pm(o.inertia_with_weights, o.inertia_with_weights_se),
            pm(o.inertia_without_weights, o.inertia_without_weights_se),
            pm(o.inertia_about_cg, o.inertia_about_cg_se),
            100.0 * o.repeat_spread,
            if flagged > 0 {
                format!("  ({flagged} repeat(s) flagged as outliers, left out)")
            } else {
                String::new()
            }
        );
    }
    tensor_text(&mut s, &r.tensor);
    s
}

pub fn torsion_json(r: &TorsionResult) -> Value {
    let t = &r.tensor;
    json!({
        "body": r.body,
        "mass_kg": r.mass_kg,
        "stiffness_nm_per_rad": r.stiffness_nm_per_rad,
        "stiffness_se_nm_per_rad": r.stiffness_se_nm_per_rad,
        "fixture_inertia_kgm2": r.fixture_inertia_kgm2,
        "orientations_used": t.orientations,
        "ixx": t.ixx, "ixx_se": t.ixx_se,
        "ixz": t.ixz, "ixz_se": t.ixz_se,
        "izz": t.izz, "izz_se": t.izz_se,
        "tensor": t,
        "orientations": r.orientations,
    })
}

pub fn compound_text(r: &CompoundResult) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{} ({} kg), compound pendulum tests", r.body, r.mass_kg);
    for t in &r.tests {
        let _ = writeln!(
            s,
            "  {:<9} {:?}: f = {:.5} ± {:.5} Hz (small amplitude), L = {} m, about the pivot {} kg·m², about the CG {} kg·m²",
            t.name,
            t.moment,
            t.freq_hz,
            t.freq_se_hz,
            t.pivot_to_cg_m,
            pm(t.inertia_about_pivot, t.inertia_about_pivot_se),
            pm(t.inertia_about_cg, t.inertia_about_cg_se)
        );
    }
    s
}

pub fn compound_json(r: &CompoundResult) -> Value {
    let mut v = serde_json::to_value(r).unwrap_or(Value::Null);
    for t in &r.tests {
        let key = match t.moment {
            crate::read::manifest::Moment::Iyy => vec!["iyy"],
            crate::read::manifest::Moment::IxxIzz => vec!["ixx", "izz"],
        };
        for k in key {
            v[k] = json!(t.inertia_about_cg);
            v[format!("{k}_se")] = json!(t.inertia_about_cg_se);
        }
    }
    v
}

/// `bikeproc measured`: the parameters with their units and standard errors, then the stable
/// speed range.
pub fn measured_text(r: &super::measured::MeasuredReport) -> String {
    use super::measured::unit;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: benchmark parameters (Meijaard et al. 2007) from the raw measurements in {}",
        r.name,
        r.source.display()
    );
    for (name, m) in &r.parameters {
        let _ = writeln!(
            s,
            "  {name:<5} = {:>12.6} ± {:<10.6} {}",
            m.value,
            m.se,
            unit(name)
        );
    }
    let speed = |v: Option<f64>, se: Option<f64>| match (v, se) {
        (Some(v), Some(se)) => format!("{v:.3} ± {se:.3} m/s"),
        (Some(v), None) => format!("{v:.3} m/s (no standard error)"),
        (None, _) => format!("none up to {} m/s", r.max_speed_mps),
    };
    let ranges: Vec<String> = r
        .stable_ranges_mps
        .iter()
        .map(|(lo, hi)| match hi {
            Some(h) => format!("{lo:.3} – {h:.3} m/s"),
            None => format!("above {lo:.3} m/s (up to {} searched)", r.max_speed_mps),
        })
        .collect();
    let _ = writeln!(
        s,
        "stable (linearized Whipple model): {}",
        if ranges.is_empty() {
            format!("nowhere from 0 to {} m/s", r.max_speed_mps)
        } else {
            ranges.join(", ")
        }
    );
    if r.parameters.contains_key("mD") {
        let _ = writeln!(
            s,
            "(the flywheel D is not in the model: the Whipple bicycle has four bodies)"
        );
    }
    let _ = writeln!(
        s,
        "weave speed {}, capsize speed {} (standard errors from the measurements)",
        speed(r.weave_speed_mps, r.weave_speed_se_mps),
        speed(r.capsize_speed_mps, r.capsize_speed_se_mps)
    );
    s
}
