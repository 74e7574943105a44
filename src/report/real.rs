//! `reports/real.md`: another lab's raw recordings end to end (a robotic bicycle's pendulum
//! recordings by set-up; a balance-assist bicycle's rides, uncontrolled and controlled). In: the
//! reference folder; out: the Markdown and its figures.

use super::error::{analysing, reading, ReportError, Result};
use super::markdown::{pm, verdict_list};
use super::set::Files;
use crate::fit::{self, FitOptions};
use crate::signal::Signal;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The mean of the robot bicycle's five rod periods as that lab published it, `TtP1` of its
/// `RigidMeasured.txt` (s), and its standard error (reference README).
pub const ROBOT_ROD_TTP1_S: (f64, f64) = (0.95691904392, 2.0e-6);

/// `real.md`: another lab's raw recordings. The 57 pendulum recordings of a robotic bicycle,
/// each fitted as `bikeproc period` does, grouped by set-up (repeated trials combined:
/// [`crate::uncertainty::combine_repeats`]), and the rod's mean beside the published `TtP1`.
pub(super) fn real_report(
    reference: &Path,
    root: &Path,
    progress: &mut dyn FnMut(&str),
    files: &mut Files,
) -> Result<usize> {
    let dir = reference.join("signals/robot_bicycle");
    let mut paths: Vec<PathBuf> = reading(dir.display().to_string(), std::fs::read_dir(&dir))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| crate::read::kind::recognise(p) == crate::read::kind::Kind::Table)
        .collect();
    paths.sort();
    let mut trials = Vec::new();
    let mut segments = Vec::new();
    for path in &paths {
        let stem = path
            .file_stem()
            .map_or(String::new(), |s| s.to_string_lossy().into_owned());
        progress(&format!("robot bicycle recording {stem}"));
        let sig = Signal::from_csv(path)?;
        let osc = analysing(path, fit::analyse(&sig, &FitOptions::default()))?;
        let t = osc.fit.period_s();
        trials.push((stem, crate::uncertainty::Measured::new(t.value, t.se)));
        segments.push(osc.segment_s);
    }
    let setups = fit::group_trials(&trials);
    let mut md = String::from(
        "# Another lab's raw recordings, end to end\n\n\
         ## Pendulum recordings of a robotic bicycle\n\n\
         57 raw rate-gyro recordings (500 Hz, volts on an offset) of a robotic bicycle's frame, fork and\n\
         wheels hung as torsional and compound pendulums, and of that lab's calibration rod\n\
         (`../shared/reference/signals/robot_bicycle/`, see its README). Each is fitted as `bikeproc period`\n\
         fits one: the free decay found, x(t) = a (+ d·t) + e^{−σt}(b sin ω_d t + c cos ω_d t), the damped\n\
         period T = 2π/ω_d with the fit's standard error. The trials of one set-up are combined: the\n\
         plain mean with the scatter's standard error sd/√n when the trials scatter beyond their fits'\n\
         errors (they all do, by 0.01–0.3 %: the body re-hung, another amplitude), else the weighted mean;\n\
         a trial 4 robust standard deviations and 0.5 % from the median is flagged (*) and left out.\n\n\
         | set-up | trials | mean T (s) | scatter | each trial: T (s) ± fit's SE, segment (s) |\n\
         |---|---|---|---|---|\n",
    );
    let mut k = 0;
    for s in &setups {
        let c = &s.combined;
        let each: Vec<String> = s
            .each_trial()
            .map(|(name, p, flagged)| {
                let seg = segments[k];
                k += 1;
                format!(
                    "{}{name}: {:.6} ± {:.1e}, {:.2}–{:.2}",
                    if flagged { "*" } else { "" },
                    p.value,
                    p.se,
                    seg.0,
                    seg.1
                )
            })
            .collect();
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.3} % | {} |",
            s.setup,
            s.trials.len(),
            pm(c.mean.value, c.mean.se, 6),
            100.0 * c.sd / c.plain_mean,
            each.join("; ")
        );
    }
    if let Some(rod) = setups.iter().find(|s| s.setup == "UcdrodRodTorsionalFirst") {
        let (ttp1, ttp1_se) = ROBOT_ROD_TTP1_S;
        let m = rod.combined.plain_mean;
        let rod_starts = trials
            .iter()
            .zip(&segments)
            .filter(|(t, _)| rod.trials.contains(&t.0))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (_, s)| {
                (a.min(s.0), b.max(s.0))
            });
        let per_trial_se = rod
            .periods_s
            .iter()
            .map(|p| p.se * p.se)
            .sum::<f64>()
            .sqrt()
            / rod.periods_s.len() as f64;
        let _ = write!(
            md,
            "\n**The rod.** The mean of its {} trials is {m:.8} s against that lab's `TtP1` = {ttp1:.11} ± {ttp1_se:.1e} s:\n\
             {:+.2e} relative, {:+.1} of the two means' fit errors combined ({per_trial_se:.1e} s ours). Fit\n\
             errors alone do not cover that: the two fits differ in what they fit (ours leave out the first\n\
             {:.2}–{:.2} s, where the data leave the fitted decay, and may take a linear trend). The trials\n\
             themselves scatter by {:.3} %, so the rod's period is known to ± {:.1e} s (its mean's standard\n\
             error from the scatter), {:.0} times the two labs' difference.\n",
            rod.trials.len(),
            (m - ttp1) / ttp1,
            (m - ttp1) / per_trial_se.hypot(ttp1_se),
            rod_starts.0,
            rod_starts.1,
            100.0 * rod.combined.sd / m,
            rod.combined.mean.se,
            rod.combined.mean.se / (m - ttp1).abs()
        );
    }
    uncontrolled_section(reference, progress, &mut md)?;
    controlled_section(reference, root, progress, &mut md)?;
    study_section(root, progress, &mut md, files)?;
    files.push(("real.md".into(), md.into_bytes()));
    Ok(paths.len())
}

/// A decay's roll-and-steer fit shown beside its eigenvalue ("—" without one), "(disagrees)"
/// where the two differ beyond two combined standard errors.
fn beside_text(d: &crate::ride::csv::CsvDecay) -> String {
    d.roll_and_steer_weave.map_or("—".to_string(), |r| {
        format!(
            "{}, {}{}",
            pm(-r.re, r.re_se, 3),
            pm(r.im, r.im_se, 3),
            if d.fits_disagree() {
                " (disagrees)"
            } else {
                ""
            }
        )
    })
}

/// The free decays the other lab marked in its uncontrolled balance-assist recording (its README).
pub const UNCONTROLLED_DECAYS_S: [(f64, f64); 3] =
    [(141.28, 142.71), (148.53, 149.94), (153.98, 155.50)];

/// `real.md`'s section on the uncontrolled balance-assist recording: each marked free decay
/// fitted from the CSV (the roll rate, and roll and steer beside it), the speed from the rear
/// wheel, the Whipple model of `Balanceassistv1` beside it.
pub(super) fn uncontrolled_section(
    reference: &Path,
    progress: &mut dyn FnMut(&str),
    md: &mut String,
) -> Result<()> {
    use crate::ride::csv::{fit_decay, read_csv_ride, Columns};
    let path = reference.join("rides/balanceassist_uncontrolled_18kmh.csv");
    let bike_path = reference.join("bicycleparameters/Balanceassistv1Benchmark.txt");
    progress("the balance-assist bicycle's uncontrolled ride");
    let ride = read_csv_ride(&path, &Columns::default(), None)?;
    let model = crate::read::bicycle::load(&bike_path)?;
    md.push_str(
        "\n## A real riderless bicycle, uncontrolled\n\n\
         Another lab's balance-assist bicycle on a treadmill at 18 km/h with its steer motor's assistance\n\
         off, kicked sideways (`../shared/reference/rides/balanceassist_uncontrolled_18kmh.csv`, 100 Hz:\n\
         its IMU's fused roll, the steer-angle sensor in 0.1–0.5° steps on an offset, the rear wheel's\n\
         speed). Each free decay that lab marked is fitted as `bikeproc dynamic FILE.csv --window A:B`\n\
         fits it: the eigenvalue from the gyro's roll rate (one damped sinusoid on an offset), and\n\
         beside it from roll and steer together (the weave with the real modes and offsets and trends\n\
         the information criterion keeps), whose mode shape is kept where the two eigenvalues agree\n\
         (the fused roll angle carries its filter's dynamics: on simulated recordings the roll rate's\n\
         fit is the calibrated one); the speed is the rear wheel's over the window. Beside it, the\n\
         linear Whipple model of that bicycle (`Balanceassistv1Benchmark.txt`, its parameters'\n\
         uncertainty propagated, and the speed's).\n\n\
         | window (s) | speed (m/s) | weave σ (1/s) | weave ω (rad/s) | roll and steer: σ, ω | \\|γ/θ\\| | arg γ/θ (°) | model σ | model ω | model \\|γ/θ\\|, arg (°) | z σ | z ω |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut zs = Vec::new();
    for &(a, b) in &UNCONTROLLED_DECAYS_S {
        let d = fit_decay(
            &ride,
            Some((a, b)),
            &crate::ride::modal::ModalOptions::default(),
        )?;
        let Some(v) = d.wheel_speed_mps else {
            return Err(ReportError::Data(format!(
                "{}: no wheel-speed column",
                path.display()
            )));
        };
        let e = &d.weave;
        let m = crate::ride::model_weave::model_weave_at(&path, &model, v.value, v.se, e)?;
        let (ratio, phase) = d.shape.map_or(("—".to_string(), "—".to_string()), |s| {
            (
                pm(s.ratio.value, s.ratio.se, 3),
                pm(
                    s.phase_rad.value.to_degrees(),
                    s.phase_rad.se.to_degrees(),
                    1,
                ),
            )
        });
        let _ =
            writeln!(
            md,
            "| {a:.2}–{b:.2} | {} | {} | {} | {} | {ratio} | {phase} | {} | {} | {:.3}, {:.1} | {:+.1} | {:+.1} |",
            pm(v.value, v.se, 3),
            pm(-e.re, e.re_se, 3),
            pm(e.im, e.im_se, 3),
            beside_text(&d),
            pm(-m.re, m.re_se, 3),
            pm(m.im, m.im_se, 3),
            m.shape_ratio,
            m.shape_phase_rad.to_degrees(),
            -m.re_z,
            m.im_z
        );
        zs.push((m.re_z, m.im_z));
    }
    let worst =
        |f: &dyn Fn(&(f64, f64)) -> f64| zs.iter().map(f).fold(0.0f64, |a, b| a.max(b.abs()));
    let _ = write!(
        md,
        "\nσ is the decay rate (−Re λ); z is experiment − model in combined standard errors. Against\n\
         the model the weave's frequency is lower in every decay, by up to {:.1} combined standard\n\
         errors, its decay rate higher by up to {:.1}, and the steer lags the roll by less, with a\n\
         smaller |γ/θ|. **What one speed can tell:** that the model and this bicycle part at 5 m/s,\n\
         and by how much, in the eigenvalue and the mode shape. It cannot tell why: the unpowered\n\
         steer motor's inertia and friction, the treadmill's belt, the tyres, or a parameter measured\n\
         off all move the weave at one speed, and with one speed's σ, ω, |γ/θ| and phase any of them\n\
         can be fitted to the same four numbers; telling them apart takes how the gap changes with\n\
         speed, which no single speed shows.\n",
        worst(&|z| z.1),
        worst(&|z| z.0),
    );
    progress("the uncontrolled ride's kicks");
    let kicks = crate::ride::csv::ride_decays(
        &ride,
        None,
        None,
        Some(&model),
        &crate::ride::modal::ModalOptions::default(),
    )?;
    let _ = write!(
        md,
        "\n**Every kick, found.** `bikeproc dynamic FILE.csv` without a window finds {} kicks in the\n\
         recording (roll-rate peaks over {} times the background's median |roll rate|, read from the\n\
         lower quartile while the wheel turns, and over {} times the largest swing of the second\n\
         before the kick's motion began) and fits each; kicks while the treadmill starts or stops\n\
         are listed, not fitted. Each decay starts where the push is over: at the push's own peak\n\
         when its swing rose in under {} of its fall (an impulse), else at the swing back (a hand\n\
         pushing through its swing). It ends where the free motion ends: a swing that grows (a new\n\
         push; a weave growing at a steady rate goes on), one that lasts over {} times the one\n\
         before (the swinging stops: held, leaning on the harness, drifting), one within the\n\
         background sway, the next kick, or {} s. That lab marked 141.28–142.71, 148.53–149.94\n\
         and 153.98–155.50 s by hand.\n\n\
         | kick (s) | window (s) | starts, ends | speed (m/s) | weave σ (1/s) | weave ω (rad/s) | roll and steer: σ, ω | VAF | z σ | z ω |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
        kicks.len(),
        crate::ride::kicks::KICK_OVER_BACKGROUND,
        crate::ride::kicks::KICK_OVER_SWING,
        crate::ride::kicks::FORCED_RISE_QUARTERS,
        crate::ride::kicks::STALL_RATIO,
        crate::ride::kicks::DECAY_MAX_S
    );
    for k in &kicks {
        let (a, b) = k.kick.window_s;
        match (&k.decay, &k.not_fitted) {
            (Some(d), _) => {
                let e = &d.decay.weave;
                let v = d.speed_mps.map_or(String::new(), |v| pm(v.value, v.se, 3));
                let z = d.model.as_ref().map_or(" | ".to_string(), |m| {
                    format!("{:+.1} | {:+.1}", -m.re_z, m.im_z)
                });
                let _ = writeln!(
                    md,
                    "| {:.2} | {a:.2}–{b:.2} | {} | {v} | {} | {} | {} | {} | {z} |",
                    k.kick.at_s,
                    why_window(&k.kick),
                    pm(-e.re, e.re_se, 3),
                    pm(e.im, e.im_se, 3),
                    beside_text(&d.decay),
                    d.decay.vaf_text()
                );
            }
            (None, why) => {
                let why = why.as_deref().unwrap_or("");
                let why = why.rsplit(".csv: ").next().unwrap_or(why);
                let _ = writeln!(
                    md,
                    "| {:.2} | {a:.2}–{b:.2} | {} | not fitted: {why} | | | | | | |",
                    k.kick.at_s,
                    why_window(&k.kick)
                );
            }
        }
    }
    let unresolved: Vec<String> = kicks
        .iter()
        .filter_map(|k| {
            let resolved = k.decay.as_ref()?.decay.resolves_weave();
            (!resolved).then(|| format!("{:.2} s", k.kick.at_s))
        })
        .collect();
    if !unresolved.is_empty() {
        let _ = write!(
            md,
            "\nThe kick{} at {} resolve{} no weave: ω's standard error is larger than ω. The roll\n\
             does not decay from the kick but wanders (rates of 0.1–0.3 rad/s for a second, then\n\
             little; perhaps a hand steadying the bicycle); the fit says so rather than inventing an\n\
             eigenvalue. The lab marked only the three from 141 s on.\n",
            if unresolved.len() == 1 { "" } else { "s" },
            unresolved.join(" and "),
            if unresolved.len() == 1 { "s" } else { "" },
        );
    }
    Ok(())
}

/// `real.md`'s section on the controlled balance-assist rides: every post-kick segment's weave
/// eigenvalue from its roll rate, by gain and treadmill speed, beside the Whipple model with the
/// lab's controller in the loop and without it, and what `bikeproc gap` says per gain.
pub(super) fn controlled_section(
    reference: &Path,
    root: &Path,
    progress: &mut dyn FnMut(&str),
    md: &mut String,
) -> Result<()> {
    use crate::gap::{diagnose, observations, GapOptions};
    use crate::read::rides::RideManifest;
    use crate::ride::dynamic::{run_campaign, Analysed};
    let whipple = crate::read::bicycle::load(
        &reference.join("bicycleparameters/Balanceassistv1Benchmark.txt"),
    )?;
    md.push_str(
        "\n## A real riderless bicycle, controlled\n\n\
         The same bicycle with its steer motor's assistance on: that lab's controller, a steer torque\n\
         from the roll rate with gain G·(4.7 − v) below 4.7 m/s and from the roll angle with gain\n\
         0.7·(v − 4.7) above (in the benchmark's signs, steering into the fall; that lab writes the same\n\
         law as T = −k·x), 63 post-kick segments of 0.5–2.6 s with the roll rate only (`gyro_x`). One\n\
         campaign per gain, `fixtures/real/balanceassist_gain{6,8,10}.toml`, with the controller in its\n\
         `[controller]` table: `bikeproc dynamic` fits each segment (one damped sinusoid on an offset,\n\
         the eigenvalue −σ ± iω, no mode shape without the steer; its errors grown for the residuals'\n\
         correlation), the speed is the treadmill's setting (1 % of it as its error), and the model is\n\
         the Whipple model of `Balanceassistv1` with the controller closing the loop.\n",
    );
    let mut verdicts = String::new();
    let mut bests: Vec<(u32, crate::gap::Ranked)> = Vec::new();
    // The widest range of ω among the kicks of one set-up (gain and speed).
    let mut widest = 0.0f64;
    for g in [6, 8, 10] {
        let path = root.join(format!("fixtures/real/balanceassist_gain{g}.toml"));
        progress(&format!("controlled campaign, gain {g}"));
        let manifest = RideManifest::load(&path)?;
        let model = manifest.model(None)?;
        let results = run_campaign(&manifest, &model, &Default::default(), &|_, _| {});
        let _ = write!(
            md,
            "\n### Gain {g}\n\n\
             | segment | speed (m/s) | fitted weave (1/s) | model, controlled | z σ | z ω | Whipple, uncontrolled |\n\
             |---|---|---|---|---|---|---|\n"
        );
        for r in &results {
            let Ok(Analysed::Csv(d)) = &r.result else {
                let why = r
                    .result
                    .as_ref()
                    .err()
                    .map_or(String::new(), |e| e.to_string());
                let _ = writeln!(md, "| {} | | not fitted: {why} | | | | |", r.name);
                continue;
            };
            let w = &d.decay.weave;
            let v = d.speed_mps.map_or(f64::NAN, |v| v.value);
            for other in &results {
                if let Ok(Analysed::Csv(o)) = &other.result {
                    if o.speed_mps.map(|s| s.value) == Some(v) {
                        widest = widest.max((o.decay.weave.im - w.im).abs());
                    }
                }
            }
            let free = whipple.bands(&[v])?.sweep.eigenvalues[0][0];
            let free = if free.im > 0.0 {
                format!("{:.2} ± {:.2}i", free.re, free.im)
            } else {
                "no weave".into()
            };
            let (model_cell, zs) = match &d.model {
                Some(m) => (
                    format!("({}) ± ({})i", pm(m.re, m.re_se, 2), pm(m.im, m.im_se, 2)),
                    format!("{:+.1} | {:+.1}", m.re_z, m.im_z),
                ),
                None => ("no weave".into(), " | ".into()),
            };
            let _ = writeln!(
                md,
                "| {} | {v:.2} | ({}) ± ({})i | {model_cell} | {zs} | {free} |",
                r.name,
                pm(w.re, w.re_se, 2),
                pm(w.im, w.im_se, 2)
            );
        }
        let (rides, failed) = observations(&results);
        let d = diagnose(&rides, &failed, &model, &GapOptions::default(), &|_, _| {})?;
        let _ = write!(verdicts, "\n**Gain {g}.** ");
        let mean = |sel: &dyn Fn(&crate::gap::RideResidual) -> (f64, f64)| {
            crate::gap::weighted_mean(d.residuals.iter().map(sel))
        };
        let (dre, dim) = (mean(&|r| (r.re, r.re_se)), mean(&|r| (r.im, r.im_se)));
        let _ = write!(
            verdicts,
            "Experiment − controlled model: ω {}, σ {} (weighted means, 1/s); χ² {:.0} for {} degrees\n\
             of freedom. ",
            pm(dim.value, dim.se, 2),
            pm(-dre.value, dre.se, 2),
            d.chi2,
            d.dof
        );
        if let Some(best) = d.ranking.first() {
            bests.push((g, best.clone()));
        }
        match d.ranking.first() {
            Some(best) => {
                let params: Vec<String> = best.param_texts();
                let _ = write!(
                    verdicts,
                    "Best candidate: {} ({}), the segments left out predicted at an RMS of {:.2}\n\
                     standard errors (from {:.2}); {}.\n",
                    best.effect,
                    params.join(", "),
                    best.heldout_rms_after,
                    best.heldout_rms_before,
                    if d.explained {
                        "it explains the gap".to_string()
                    } else if best.heldout_rms_after > crate::gap::EXPLAINED_HELDOUT_RMS {
                        format!(
                            "**not explained**: no candidate brings the held-out residuals within \
                             {} of their standard errors",
                            crate::gap::EXPLAINED_HELDOUT_RMS
                        )
                    } else {
                        format!(
                            "**not explained**: the held-out residuals come within {} of their \
                             standard errors, but its fit to every segment fails its χ² test (p {})",
                            crate::gap::EXPLAINED_HELDOUT_RMS,
                            crate::gap::stats::format_p(d.best_fit_p_value)
                        )
                    }
                );
            }
            None => {
                let _ = writeln!(verdicts, "{}", verdict_list(&d.verdict));
            }
        }
    }
    // An effect in every gain's best candidate, and its values across the gains.
    let mut shared = String::new();
    if let (Some((_, first)), 3) = (bests.first(), bests.len()) {
        for (k, e) in first.effects.iter().enumerate() {
            let values: Option<Vec<String>> = bests
                .iter()
                .map(|(g, b)| {
                    let at = b.effects.iter().position(|x| x == e)?;
                    let offset: usize = b.effects[..at].iter().map(|x| x.params().len()).sum();
                    Some(format!(
                        "{} at gain {g}",
                        crate::gap::param_text(b.params[offset], b.params_se[offset], "")
                    ))
                })
                .collect();
            if let Some(values) = values {
                let _ = write!(
                    shared,
                    "\n{} ({}) is in every gain's best candidate: {} ({}).\n",
                    e.name(),
                    e.describe(),
                    values.join(", "),
                    first.units.get(k).copied().unwrap_or("")
                );
            }
        }
    }
    let _ = write!(
        md,
        "\n### What `bikeproc gap` says\n\n\
         `bikeproc gap fixtures/real/balanceassist_gainG.toml` on each campaign (the eigenvalue of each\n\
         segment; the library with the steer motor's two effects, its torque off by a factor and inertia\n\
         added about the steer axis):\n{verdicts}{shared}\n\
         The kicks of one set-up scatter beyond their fits' errors (ω by up to {widest:.2} rad/s between two\n\
         kicks of one gain and speed), which no model of one weave per speed can follow: a fit's χ² then fails whatever the effect, and bikeproc does not call the gap\n\
         explained unless the held-out segments are predicted within their errors.\n"
    );
    Ok(())
}

/// `real.md`'s joint diagnosis of the balance-assist bicycle's four conditions
/// (`fixtures/real/balanceassist_study.toml`): what is shared, what differs per condition, each
/// condition predicted from the others.
fn study_section(
    root: &Path,
    progress: &mut dyn FnMut(&str),
    md: &mut String,
    files: &mut Files,
) -> Result<()> {
    use crate::read::study::Study;
    let path = root.join("fixtures/real/balanceassist_study.toml");
    progress("the balance-assist study: four conditions together");
    let study = Study::load(&path)?;
    let model = crate::read::bicycle::load(&study.bike_path()?)?;
    let conditions = crate::gap::study_conditions(&study.conditions, &model, &|_, _, _| {});
    let d = crate::gap::diagnose_study(
        &conditions,
        &model,
        &crate::gap::GapOptions::default(),
        &|_, _| {},
    )?;
    let _ = write!(
        md,
        "\n### The four conditions together\n\n\
         `bikeproc gap fixtures/real/balanceassist_study.toml` diagnoses the uncontrolled decays (the\n\
         three windows that lab marked, `fixtures/real/balanceassist_uncontrolled.toml`) and the three\n\
         gains as one bicycle: its effects shared by every condition, the motor's delivered gain fitted\n\
         per controller, the speedometer's scale and the clock per condition; the ranking rests on each\n\
         condition predicted from the others (its own equipment at the others' mean). The controlled\n\
         segments enter by their eigenvalue (the roll rate alone), the uncontrolled decays by their\n\
         eigenvalue (the roll rate) and mode shape (roll and steer), in one likelihood. Repeated kicks of one set-up\n\
         enter with the scatter between them estimated from the repeats{}. Cochran's Q of the\n\
         repeats is shown twice: with each fit's errors as were its residuals white (before issue\n\
         75), and with the errors of residuals correlated from sample to sample (an AR(1) noise\n\
         estimated from the residuals, allowing for what the fit took out, which every fit now\n\
         carries: `fit::ar1_sandwich`); what stays\n\
         above 1 is the bicycle's own scatter from kick to kick. A condition's χ² here takes the\n\
         scatter pooled over the four conditions; diagnosed alone it takes its own repeats' (the\n\
         last column), so the two χ² differ.\n\n\
         | condition | controller | rides | χ² against the model (dof) | repeated kicks' Q/dof of σ and ω, white residuals | the same, correlated residuals | its own scatter between kicks, σ (1/s), ω (rad/s) |\n|---|---|---|---|---|---|---|\n",
        d.between_kick_scatter.as_ref().map_or(String::new(), |s| format!(
            " ({} set-ups, {} kicks: σ {:.3} 1/s, ω {:.3} rad/s between kicks; Cochran's Q {:.0} for {} dof)",
            s.setups,
            s.kicks,
            s.per_part[0],
            s.per_part.get(1).copied().unwrap_or(f64::NAN),
            s.q,
            s.q_dof
        ))
    );
    for (i, c) in d.conditions.iter().enumerate() {
        // How far this condition's repeats scatter beyond their fits' errors (1 when not).
        let repeats = d
            .between_kick_scatter
            .as_ref()
            .and_then(|s| s.by_condition.iter().find(|r| r.condition == i))
            .map_or("— | —".to_string(), |r| {
                format!(
                    "{:.1} ({:.0} on {}) | {:.1} ({:.0} on {})",
                    r.q_white / r.q_dof as f64,
                    r.q_white,
                    r.q_dof,
                    r.q / r.q_dof as f64,
                    r.q,
                    r.q_dof
                )
            });
        let own = match &c.scatter_alone[..] {
            [s, w, ..] => format!("{s:.3}, {w:.3}"),
            _ => "—".to_string(),
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.0} ({}) | {} | {own} |",
            c.name,
            if c.controlled { "on" } else { "off" },
            c.rides_used,
            c.chi2,
            c.dof,
            repeats
        );
    }
    // The instrument checked before the bicycle: each condition with a mode shape.
    for check in &d.instrument {
        let k = check.log_ratio.value.exp();
        let _ = write!(
            md,
            "\n**The instrument first.** The mode shape of {} ({} decays) against the model and the \
             candidates in turn: {}; against {}, |γ/θ| × {k:.2} ± {:.2} and arg γ/θ {:+.1} ± {:.1}° in \
             common (χ² {:.1} on 2 degrees of freedom; the shape is set aside as the instrument's \
             only where every candidate leaves over {}).\n",
            check.condition,
            check.rides,
            if check.misses {
                "it misses every one, and the condition is diagnosed on its eigenvalue alone"
            } else {
                "a candidate of the library accounts for it, so the shape stays in the diagnosis"
            },
            if check.against == "none" {
                "the model as it is".to_string()
            } else {
                check.against.clone()
            },
            k * check.log_ratio.se,
            check.phase_rad.value.to_degrees(),
            check.phase_rad.se.to_degrees(),
            check.chi2,
            crate::gap::instrument::SHAPE_MISS_CHI2
        );
    }
    let _ = write!(
        md,
        "\nThe first five of the {} candidates ranked (every single effect, pairs of the best, three \
         effects where no pair passes): a candidate with a parameter of the bicycle where its \
         search stopped at an edge, or within its standard error of one, is a bound, not a fit, \
         and ranks below every fit inside its ranges (a condition's own equipment there is shown \
         as a bound and keeps its place).\n\n\
         | candidate | parameters | fit or bound | each condition predicted from the others (RMS) | all | rides left out one at a time |\n|---|---|---|---|---|---|\n",
        d.ranking.len()
    );
    for r in d.ranking.iter().take(5) {
        let named = |flags: &[bool]| -> String {
            let mut names: Vec<&str> = r
                .param_effect
                .iter()
                .zip(flags)
                .filter(|(_, &e)| e)
                .map(|(&j, _)| r.effects[j].name())
                .collect();
            names.dedup();
            names.join(", ")
        };
        let (edges, near) = (named(&r.at_edge), named(&r.at_bound));
        let fit = match (edges.is_empty(), near.is_empty()) {
            (false, _) => format!("bound: {edges} at the search's edge"),
            (true, false) if r.bicycle_at_edge() => {
                format!("bound: {near} within its SE of an edge")
            }
            (true, false) => format!("fit inside its ranges ({near} within its SE of an edge)"),
            (true, true) => "fit inside its ranges".to_string(),
        };
        let by: Vec<String> = r
            .heldout_rms_by_condition
            .iter()
            .map(|(c, v)| format!("{c} {v:.2}"))
            .collect();
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {:.2} | {} |",
            r.effect,
            r.param_texts().join("; "),
            fit,
            by.join(", "),
            r.heldout_rms_after,
            r.heldout_rms_rides_out
                .map_or(String::new(), |v| format!("{v:.2}"))
        );
    }
    let _ = write!(md, "\n{}\n", verdict_list(&d.verdict));
    #[cfg(not(feature = "plot"))]
    let _ = files;
    #[cfg(feature = "plot")]
    if let Some(svg) = study_figure(&conditions, &d)? {
        files.push(("real/balanceassist_study.svg".into(), svg.into_bytes()));
        let _ = write!(
            md,
            "\n![each condition's weave against speed, measured and the model before and after \
             the first candidate](real/balanceassist_study.svg)\n"
        );
    }
    Ok(())
}

/// A study's figure: each condition's measured weave (σ = −Re λ and ω against speed, bars ±2
/// of each fit's standard errors, so that the scatter between kicks shows beyond them) in its
/// colour, with the model at each ride's speed before (thin) and with the first candidate at
/// its fit to every ride (thick): the model's values are the measured ones less the study's
/// residuals. `None` for a study without a ranking or whose residuals do not match its rides.
#[cfg(feature = "plot")]
fn study_figure(
    conditions: &[crate::gap::StudyCondition],
    d: &crate::gap::Diagnosis,
) -> Result<Option<String>> {
    use crate::plot::{error_bars, Chart, Mark, Series};
    use plotters::style::RGBColor;
    let rides: Vec<(usize, &crate::gap::Observation)> = conditions
        .iter()
        .enumerate()
        .flat_map(|(c, cond)| cond.rides.iter().map(move |o| (c, o)))
        .collect();
    let (Some(best), true, true) = (
        d.ranking.first(),
        d.residuals.len() == rides.len(),
        d.residuals_after.len() == rides.len(),
    ) else {
        return Ok(None);
    };
    const COLORS: [RGBColor; 6] = [
        RGBColor(0, 0, 0),
        RGBColor(0, 114, 178),
        RGBColor(213, 94, 0),
        RGBColor(0, 158, 115),
        RGBColor(204, 121, 167),
        RGBColor(230, 159, 0),
    ];
    // Per panel: the measured value and its fit's error, and the residual's part.
    type Measured = fn(&crate::gap::Observation) -> (f64, f64);
    type Residual = fn(&crate::gap::RideResidual) -> f64;
    let parts: [(&str, Measured, Residual); 2] = [
        ("σ (1/s)", |o| (-o.weave.re, o.re_se), |r| -r.re),
        ("ω (rad/s)", |o| (o.weave.im, o.im_se), |r| r.im),
    ];
    let panels: Vec<(String, Vec<Series>)> = parts
        .iter()
        .map(|(label, value, residual)| {
            let mut series = Vec::new();
            for (c, cond) in conditions.iter().enumerate() {
                let color = COLORS[c % COLORS.len()];
                let mine: Vec<usize> = (0..rides.len()).filter(|&i| rides[i].0 == c).collect();
                let measured: Vec<(f64, f64, f64, f64)> = mine
                    .iter()
                    .map(|&i| {
                        let (v, se) = value(rides[i].1);
                        (rides[i].1.speed_mps, v, 0.0, se)
                    })
                    .collect();
                series.extend(error_bars(&measured, color, &cond.name));
                let model = |residuals: &[crate::gap::RideResidual]| -> Vec<(f64, f64)> {
                    let mut points: Vec<(f64, f64)> = mine
                        .iter()
                        .map(|&i| {
                            let o = rides[i].1;
                            (o.speed_mps, value(o).0 - residual(&residuals[i]))
                        })
                        .collect();
                    points.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
                    points
                };
                let first = c == 0;
                series.push(Series {
                    name: if first {
                        "the model as measured (thin)".into()
                    } else {
                        String::new()
                    },
                    points: model(&d.residuals),
                    color,
                    mark: Mark::Thin,
                });
                series.push(Series {
                    name: if first {
                        format!("with {} (thick)", best.effect)
                    } else {
                        String::new()
                    },
                    points: model(&d.residuals_after),
                    color,
                    mark: Mark::Line,
                });
            }
            (label.to_string(), series)
        })
        .collect();
    let title = "the weave by condition: measured (bars ±2 fit SE), the model before and after";
    // Both axes from the values, not the bars: a kick at a low speed whose weave is barely
    // resolved has bars many times the rest's, clipped at the frame.
    let range = |v: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
        let pad = 0.08 * (hi - lo).max(1e-3);
        (lo - pad, hi + pad)
    };
    let x_range = range(&mut rides.iter().map(|(_, o)| o.speed_mps));
    let charts: Vec<(u32, Chart<'_>)> = panels
        .iter()
        .enumerate()
        .map(|(k, (label, series))| {
            let values = series
                .iter()
                .filter(|s| !matches!(s.mark, Mark::Bar))
                .flat_map(|s| s.points.iter().map(|p| p.1));
            (
                if k == 0 { 300 } else { 260 },
                Chart {
                    title: if k == 0 { title } else { "" },
                    x_label: "speed (m/s)",
                    y_label: label,
                    series,
                    x_range: Some(x_range),
                    y_range: Some(range(&mut values.into_iter())),
                    ..Chart::default()
                },
            )
        })
        .collect();
    Ok(Some(crate::plot::stacked_svg(&charts)?))
}

/// A found window's start and end in two words each.
fn why_window(k: &crate::ride::kicks::Kick) -> String {
    format!("{}; {}", k.starts.short(), k.ends.short())
}
