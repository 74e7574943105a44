//! `reports/bicycleparameters.md`: real bicycles from their raw measurements (BicycleParameters'
//! `*Measured.txt`) against that lab's published parameters, with their stable speeds.

use super::error::{reading, Result};
use super::markdown::half_unit_of_last_digit;
use super::set::Files;
use std::fmt::Write as _;
use std::path::Path;

/// `reports/bicycleparameters.md`: every `*Measured.txt` of the reference folder converted
/// ([`crate::inertia::measured`]), compared with the `*Benchmark.txt` beside it, and its stable
/// speeds with standard errors from the measurements. Returns the number of bicycles converted.
pub(super) fn bicycleparameters_report(
    reference: &Path,
    progress: &mut dyn FnMut(&str),
    files: &mut Files,
) -> Result<usize> {
    use crate::inertia::measured::MeasuredBicycle;
    progress("bicycleparameters: real bicycles from their raw measurements");
    let dir = reference.join("bicycleparameters");
    let mut names: Vec<String> = reading(
        format!("reading {}", dir.display()),
        std::fs::read_dir(&dir),
    )?
    .filter_map(|e| {
        let name = e.ok()?.file_name().into_string().ok()?;
        Some(name.strip_suffix("Measured.txt")?.to_string())
    })
    .collect();
    names.sort();
    let mut md = String::from(
        "# Real bicycles from their raw measurements\n\n\
         BicycleParameters' `*Measured.txt` files (another lab's masses, distances, pendulum angles and\n\
         periods of real bicycles, `../shared/reference/bicycleparameters/`) converted by `bikeproc measured`\n\
         with that lab's method (rod calibration, torsional and compound pendulums, centres of mass from\n\
         the hanging lines, geometry from the measured distances) on bikeproc's own pendulum equations,\n\
         standard errors propagated to first order with the correlations. The differences are from the\n\
         `*Benchmark.txt` that lab published beside the file: the largest relative difference of a\n\
         parameter and of a standard error; \"to its digits\" when every published number is matched to\n\
         1e-6 relative (its standard error to 2 %) or, where the file is rounded, to half a unit of its\n\
         last digit. The stable range, weave and capsize speeds are the linearized Whipple model's (0–10\n\
         m/s), their standard errors propagated from the measurements through the parameters'\n\
         covariance.\n\n\
         | bicycle | published set | largest difference of a parameter | of a standard error | to its digits | stable range (m/s) | weave speed (m/s) | capsize speed (m/s) |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    let mut converted = 0;
    let mut refused = String::new();
    for name in &names {
        let path = dir.join(format!("{name}Measured.txt"));
        let bike = match MeasuredBicycle::load(&path) {
            Ok(b) => b,
            Err(e) => {
                let message = e.to_string();
                let message = message
                    .strip_prefix(&format!("{}: ", path.display()))
                    .unwrap_or(&message);
                let _ = writeln!(refused, "- {name}: refused, {message}.");
                continue;
            }
        };
        converted += 1;
        let r = bike.report(10.0, 0.01)?;
        let published_path = dir.join(format!("{name}Benchmark.txt"));
        let comparison = match std::fs::read_to_string(&published_path) {
            Ok(text) => {
                let mut worst = (0.0f64, String::from("–"));
                let mut worst_se = (0.0f64, String::from("–"));
                let mut all_within = true;
                for line in text.lines() {
                    let Some((k, rest)) = line.split_once('=') else {
                        continue;
                    };
                    let k = k.trim();
                    let (v_text, s_text) = rest.split_once("+/-").unwrap_or((rest, "0"));
                    let (Ok(v), Ok(se)) =
                        (v_text.trim().parse::<f64>(), s_text.trim().parse::<f64>())
                    else {
                        continue;
                    };
                    let Some(m) = bike.parameters.get(k) else {
                        all_within = false;
                        continue;
                    };
                    let rel = (m.value - v).abs() / v.abs().max(f64::MIN_POSITIVE);
                    let rel_se = if se > 0.0 {
                        (m.se - se).abs() / se
                    } else {
                        0.0
                    };
                    if rel > worst.0 {
                        worst = (rel, k.to_string());
                    }
                    if rel_se > worst_se.0 {
                        worst_se = (rel_se, k.to_string());
                    }
                    let tol = (1e-6 * v.abs()).max(half_unit_of_last_digit(v_text) * (1.0 + 1e-9));
                    let tol_se = (0.02 * se).max(half_unit_of_last_digit(s_text) * (1.0 + 1e-9));
                    all_within &= (m.value - v).abs() <= tol && (m.se - se).abs() <= tol_se;
                }
                format!(
                    "{name}Benchmark.txt | {:.1e} ({}) | {:.1e} ({}) | {}",
                    worst.0,
                    worst.1,
                    worst_se.0,
                    worst_se.1,
                    if all_within { "yes" } else { "**no**" }
                )
            }
            Err(_) => "none published | | | ".to_string(),
        };
        let speed = |v: Option<f64>, se: Option<f64>| match (v, se) {
            (Some(v), Some(se)) => format!("{v:.3} ± {se:.3}"),
            (Some(v), None) => format!("{v:.3}"),
            (None, _) => "–".into(),
        };
        let ranges = crate::model::ranges_text(&r.stable_ranges_mps, 3, "");
        let _ = writeln!(
            md,
            "| {name}{} | {comparison} | {} | {} | {} |",
            if bike.parameters.contains_key("mD") {
                " (flywheel not in the model)"
            } else {
                ""
            },
            if ranges.is_empty() {
                "none".to_string()
            } else {
                ranges.join(", ")
            },
            speed(r.weave_speed_mps, r.weave_speed_se_mps),
            speed(r.capsize_speed_mps, r.capsize_speed_se_mps),
        );
    }
    if !refused.is_empty() {
        md.push('\n');
        md.push_str(&refused);
    }
    md.push_str(
        "\nOne convention is that lab's and is kept so that the standard errors agree: with the table-top\n\
         geometry (`h1`…`h5`, `d1`…`d4`, `d`), the steer axis tilt λ is a quantity of its own whose standard\n\
         error is that of its starting guess atan(c/(a + b)), not the root's. Balanceassistv1's published\n\
         set is rounded to three or four digits.\n",
    );
    files.push(("bicycleparameters.md".into(), md.into_bytes()));
    Ok(converted)
}
