//! `reports/dynamic.md`: every ride's weave eigenvalue beside the model's (seed §5.4, §8). In:
//! the campaign's analysed rides ([`super::RideCampaign`]); out: the Markdown, the continuation
//! diagram with the rides and each ride's θ and γ with the fit.

use super::error::Result;
use super::markdown::pm;
use super::set::{Files, RideCampaign};
use std::fmt::Write as _;

/// `reports/dynamic.md`: every ride of `data/rides.toml` fitted, its weave eigenvalue beside the
/// model's (seed §5.4, §8), on the continuation diagram, and each ride's θ and γ with the fit.
// Without `plot`, the figures' progress message and model are not used.
#[cfg_attr(not(feature = "plot"), allow(unused_variables))]
pub(super) fn dynamic_report(
    campaign: &RideCampaign,
    progress: &mut dyn FnMut(&str),
    files: &mut Files,
) -> Result<()> {
    use crate::ride::dynamic::SpeedSource;
    let RideCampaign {
        manifest,
        model,
        results,
    } = campaign;
    let mut md = format!(
        "# Dynamic tests: the rides' weave eigenvalues against the model (seed §5.4, §8)\n\n\
         `bikeproc dynamic data/rides.toml` on the campaign in `data/` ({} rides), against the model of the\n\
         measured bicycle (`{}`). Per ride: θ (frame roll) and γ (steer) from the two sensors, the window from\n\
         0.8 s after the kick to the catch (or 0.2 rad of roll, or 2.5 s, or two weave cycles), θ and γ fitted\n\
         jointly with the weave σ ± iω, 0–2 real modes, offsets and trends (chosen by BIC). The eigenvalue\n\
         applies at the window's amplitude-weighted time, where the speed is read (`Sync` column when the log\n\
         has one; otherwise the lab's noted speedometer reading at release, with its 0.1 m/s step and 1 % error,\n\
         carried to that time by the slowing the frame sensor's forward acceleration measures; the speed from the\n\
         rolling kinematics is the check). Its standard error joins the noise's (the fit's covariance, checked by\n\
         a block bootstrap), the drift's (the coasting bicycle slows down: the difference a fitted linear drift of\n\
         the eigenvalue makes) and the coasting correction's (the mode shape changing with the speed). The model's error comes from the measured\n\
         parameters' uncertainties and the speed's; z = (experiment − model) / combined standard error.\n\n\
         | ride | speed (m/s) | from | σ (1/s) | ω (rad/s) | of which drift (σ, ω) | model σ | model ω | z σ | z ω | \\|γ/θ\\| ride / model | VAF θ, γ |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n",
        manifest.rides.len(),
        manifest.bike.display()
    );
    let mut points_re = Vec::new();
    let mut points_im = Vec::new();
    let mut failures = String::new();
    let (mut n_ok, mut agree) = (0usize, 0usize);
    for r in results {
        let name = &r.name;
        let t = match (&r.result, r.test()) {
            (_, Some(t)) => t,
            (Err(e), _) => {
                let _ = writeln!(failures, "- {name}: {e}");
                continue;
            }
            (Ok(_), None) => continue,
        };
        n_ok += 1;
        let (w, m, sp) = (&t.fit.weave, &t.model, &t.speed);
        if m.re_z.abs() < 2.0 && m.im_z.abs() < 2.0 {
            agree += 1;
        }
        let from = match sp.source {
            SpeedSource::Sync => "Sync",
            SpeedSource::Noted => "noted",
            SpeedSource::Kinematic => "kinematic",
            SpeedSource::WheelSpeed => "wheel speed",
            SpeedSource::Set => "set",
        };
        let _ = writeln!(
            md,
            "| {name} | {} | {from} | {} | {} | {:.3}, {:.3} | {} | {} | {:+.1} | {:+.1} | {:.2} / {:.2} | {:.3}, {:.3} |",
            if sp.speed_se_mps > 0.0 { pm(sp.speed_mps, sp.speed_se_mps, 3) } else { format!("{:.3}", sp.speed_mps) },
            pm(w.re, w.re_se, 3),
            pm(w.im, w.im_se, 3),
            w.re_se_drift,
            w.im_se_drift,
            pm(m.re, m.re_se, 3),
            pm(m.im, m.im_se, 3),
            m.re_z,
            m.im_z,
            t.fit.shape.ratio.value,
            m.shape_ratio,
            t.fit.vaf[0],
            t.fit.vaf[1],
        );
        points_re.push((sp.speed_mps, w.re, sp.speed_se_mps, w.re_se));
        points_im.push((sp.speed_mps, w.im, sp.speed_se_mps, w.im_se));
    }
    let _ = write!(
        md,
        "\n{agree} of {n_ok} fitted rides agree with the model within 2 combined standard errors in both parts.\n"
    );
    if failures.is_empty() {
        md.push_str("Every ride gave an eigenvalue.\n");
    } else {
        let _ = write!(md, "\nRides without an eigenvalue:\n\n{failures}");
    }
    #[cfg(feature = "plot")]
    {
        use crate::plot::{continuation_svg, error_bars, ride_svg, Continuation};
        use plotters::style::RGBColor;
        progress("dynamic: plots");
        let speeds: Vec<f64> = (0..=250).map(|i| 2.0 + i as f64 * 0.02).collect();
        let bands = model.bands(&speeds)?;
        let stable = model.speeds(10.0, 0.01)?.stability.stable_ranges_mps;
        let conts = [Continuation {
            name: "model",
            bands: &bands,
            stable: &stable,
            color: RGBColor(30, 80, 200),
            color_real: RGBColor(200, 40, 40),
        }];
        let black = RGBColor(0, 0, 0);
        let mut extra = error_bars(&points_re, black, "rides: σ (±2 se)");
        extra.extend(error_bars(
            &points_im,
            RGBColor(20, 140, 60),
            "rides: ω (±2 se)",
        ));
        files.push((
            "dynamic/continuation.svg".into(),
            continuation_svg(
                "the lab's bicycle as measured: model and rides",
                &conts,
                (-4.0, 14.0),
                &extra,
            )?
            .into_bytes(),
        ));
        md.push_str(
            "\n## On the continuation diagram\n\nThe model's weave (real part solid, imaginary dashed, ±2 standard errors thin, stable range shaded)\n\
             with each ride's σ (black) and ω (green) at its speed, bars at ±2 standard errors.\n\n\
             ![continuation](dynamic/continuation.svg)\n\n## Each ride\n\n\
             θ and γ (mrad) as measured (dots) and the fitted modes over the window (lines, window shaded; the kick and, where it falls in the plot, the catch marked).\n\n",
        );
        for r in results {
            let Some(t) = r.test() else { continue };
            let name = &r.name;
            let f = &t.fit;
            let steps = ((f.end_s - f.start_s) * 100.0).round() as usize;
            let fitted: Vec<[f64; 3]> = (0..=steps)
                .map(|k| {
                    let time = f.start_s + (f.end_s - f.start_s) * k as f64 / steps.max(1) as f64;
                    let [roll, steer] = f.eval(time);
                    [time, roll, steer]
                })
                .collect();
            let title = format!(
                "{name}: weave {:.3} ± {:.3} {:+.3} ± {:.3} i 1/s at {:.2} ± {:.2} m/s",
                f.weave.re,
                f.weave.re_se,
                f.weave.im,
                f.weave.im_se,
                t.speed.speed_mps,
                t.speed.speed_se_mps
            );
            let file = format!("dynamic/{name}.svg");
            files.push((
                file.clone().into(),
                ride_svg(
                    &title,
                    &t.trace,
                    &fitted,
                    (f.start_s, f.end_s),
                    &[(t.kick_s, "kick"), (t.catch_s, "catch")],
                )?
                .into_bytes(),
            ));
            let _ = writeln!(md, "- [{name}]({file})");
        }
    }
    files.push(("dynamic.md".into(), md.into_bytes()));
    Ok(())
}
