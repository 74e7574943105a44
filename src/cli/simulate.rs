//! `simulate`: the lab simulated from physics (pendulum tests, rides, the campaigns in `data/`,
//! blind campaigns, the failure fixtures). The only command that uses [`bikeproc::sim`].

use super::args::{RideArgs, SimCommand};
use super::io::{note, out, refuse_files_over_inputs, write_atomic};
use anyhow::{Context, Result};
use bikeproc::inertia::bike::LabBike;
use bikeproc::output::write_atomic_set;
use bikeproc::read::log::Log;
use bikeproc::sim::{self, campaign, pendulum, ride};
use std::path::{Path, PathBuf};

pub fn simulate(s: SimCommand) -> Result<()> {
    let (pendulum, c) = match s {
        SimCommand::Ride(r) => return simulate_ride(r),
        SimCommand::Rides { out } => {
            let bike = LabBike::load(&out.join("lab_bike.toml"))?;
            return write_generated(&out, &campaign::lab_rides(&bike)?);
        }
        SimCommand::Blind {
            effect,
            design,
            draws,
            seed,
            bike,
            out,
        } => {
            let withheld = campaign::Withheld::from_label(&effect)
                .ok_or_else(|| anyhow::anyhow!("unknown effect `{effect}`"))?;
            let design = campaign::BlindDesign::from_label(&design)
                .ok_or_else(|| anyhow::anyhow!("unknown design `{design}`"))?;
            let lab = LabBike::load(&bike)?;
            let draws = if draws == "broad" {
                campaign::Draws::Broad
            } else {
                campaign::Draws::Suite
            };
            let (mut files, _) = campaign::blind_campaign_plus(
                &lab,
                "bike.toml",
                withheld,
                design,
                seed,
                &[],
                draws,
            )?;
            let text = std::fs::read_to_string(&bike)
                .with_context(|| format!("reading {}", bike.display()))?;
            files.push(("bike.toml".into(), text));
            return write_generated(&out, &files);
        }
        SimCommand::BlindStudy {
            seed,
            effect_free,
            controller_speed_scale,
            actuator_lag_s,
            bike,
            out,
        } => {
            use bikeproc::sim::study::StudyMotor;
            let lab = LabBike::load(&bike)?;
            let motor = StudyMotor {
                rotor_and_gain: effect_free.then_some((0.0, 1.0)),
                speed_sensor_scale: controller_speed_scale,
                lag_s: actuator_lag_s,
            };
            let (mut files, _) =
                bikeproc::sim::study::blind_study_with(&lab, "bike.toml", seed, motor)?;
            let text = std::fs::read_to_string(&bike)
                .with_context(|| format!("reading {}", bike.display()))?;
            files.push(("bike.toml".into(), text));
            return write_generated(&out, &files);
        }
        SimCommand::GapCalibration {
            campaigns,
            controls,
            only,
            bike,
            out,
            results,
        } => {
            refuse_calibration_outputs(&out, &bike, results.as_deref())?;
            return gap_calibration(campaigns, controls, &only, &bike, &out, results.as_deref());
        }
        SimCommand::StudyCalibration {
            studies,
            near_nominal,
            controls,
            controller_speed,
            actuator_lag,
            bike,
            out,
            results,
        } => {
            refuse_calibration_outputs(&out, &bike, results.as_deref())?;
            let counts = [
                studies,
                near_nominal,
                controls,
                controller_speed,
                actuator_lag,
            ];
            return study_calibration(counts, &bike, &out, results.as_deref());
        }
        SimCommand::CheckCalibration {
            results,
            per_design,
            bike,
        } => return check_calibration(&results, per_design, &bike),
        SimCommand::RideFaults { out } => {
            let bike = LabBike::load(Path::new("data/lab_bike.toml"))?;
            return write_generated(&out, &campaign::ride_fault_fixtures(&bike)?);
        }
        SimCommand::Campaign { out } => return write_generated(&out, &campaign::lab_campaign()),
        SimCommand::Torsion(t) => (
            pendulum::Pendulum::Torsion(pendulum::Torsion {
                inertia_kgm2: t.inertia_kgm2,
                stiffness_nm_per_rad: t.stiffness_nm_per_rad,
                damping_ratio: t.damping_ratio,
                coulomb_nm: t.coulomb_nm,
                swing: t.swing_freq_hz.map(|f| pendulum::Swing {
                    freq_hz: f,
                    damping_ratio: t.swing_damping_ratio,
                    coupling: t.swing_coupling,
                    release_amplitude_deg: t.swing_amplitude_deg,
                }),
            }),
            t.common,
        ),
        SimCommand::Compound(k) => (
            pendulum::Pendulum::Compound(pendulum::Compound {
                mass_kg: k.mass_kg,
                pivot_to_cg_m: k.pivot_to_cg_m,
                inertia_about_pivot_kgm2: k.inertia_about_pivot_kgm2,
                damping_ratio: k.damping_ratio,
                coulomb_nm: k.coulomb_nm,
            }),
            k.common,
        ),
    };
    let rec = sim::simulate_single(&sim::SingleTest {
        pendulum,
        release: pendulum::Release {
            rest_s: c.rest_s,
            ramp_s: c.ramp_s,
            hold_s: c.hold_s,
            amplitude_deg: c.amplitude_deg,
            duration_s: c.duration_s,
        },
        noise_deg: c.noise_deg,
        perfect_link: c.perfect_link,
        mode: c.mode.into(),
        locale: c.locale.into(),
        precision: c.precision.into(),
        sensor_id: c.sensor_id.clone(),
        label: c.label.clone(),
        seed: c.seed,
    });
    let cal = Log::cal_path(&c.out);
    write_atomic_set(&[
        (&c.out, rec.angles_log.as_bytes()),
        (&cal, rec.cal_log.as_bytes()),
    ])?;
    out(&(serde_json::to_string_pretty(&rec.truth)? + "\n"))?;
    note!("wrote {} and {}", c.out.display(), cal.display());
    Ok(())
}

fn simulate_ride(r: RideArgs) -> Result<()> {
    let truth = r.truth.clone().unwrap_or_else(|| {
        let stem = r
            .out
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        r.out.with_file_name("truth").join(format!("{stem}.json"))
    });
    let cal = Log::cal_path(&r.out);
    let effects_file = Path::new(&r.effects);
    refuse_files_over_inputs(
        &[&r.out, &cal, &truth],
        &[&r.bike],
        (!matches!(r.effects.as_str(), "none" | "realistic")).then_some(effects_file),
    )?;
    let bike = bikeproc::read::bicycle::load(&r.bike)?.nominal();
    let effects = match r.effects.as_str() {
        "none" => ride::Effects::default(),
        "realistic" => ride::Effects::realistic(),
        file => {
            let text =
                std::fs::read_to_string(file).with_context(|| format!("reading effects {file}"))?;
            toml::from_str(&text).map_err(|e| anyhow::anyhow!("{file}: {}", e.message()))?
        }
    };
    let mut spec = ride::RideSpec::lab(r.speed, effects);
    spec.sync = r.sync;
    spec.mode = r.mode.into();
    spec.locale = r.locale.into();
    let ride = ride::simulate_ride(&bike, &spec, r.seed)?;
    let truth_json = serde_json::to_string(&ride.truth)?;
    write_atomic_set(&[
        (&r.out, ride.angles_log.as_bytes()),
        (&cal, ride.cal_log.as_bytes()),
        (&truth, truth_json.as_bytes()),
    ])?;
    let t = &ride.truth;
    note!(
        "wrote {} (release {:.2} s, kick {:.2} s, catch {:.2} s; speedometer {:.2} m/s) and the truth {}",
        r.out.display(),
        t.release_s,
        t.kick_s,
        t.catch_s,
        t.noted_speed_mps,
        truth.display()
    );
    Ok(())
}

/// Writes generated files under `out` and says how many.
fn write_generated(out: &Path, files: &campaign::Files) -> Result<()> {
    campaign::write_files(out, files)
        .with_context(|| format!("writing under {}", out.display()))?;
    note!("wrote {} files under {}", files.len(), out.display());
    Ok(())
}

/// `simulate gap-calibration`: the blind campaigns run one after the other (each uses both
/// cores), a line on standard error per campaign.
/// A calibration's outputs checked against its inputs: its Markdown and, unless the Markdown
/// alone is made again from `results`, its JSON beside it.
fn refuse_calibration_outputs(out: &Path, bike: &Path, results: Option<&Path>) -> Result<()> {
    let json = out.with_extension("json");
    let outputs: &[&Path] = if results.is_some() {
        &[out]
    } else {
        &[out, &json]
    };
    refuse_files_over_inputs(outputs, &[bike], results)
}

/// `simulate study-calibration`: blind and effect-free studies, diagnosed and tallied.
/// `counts`: blind, near-nominal, effect-free, controller-speed and actuator-lag studies.
/// With `rendered_from`, the Markdown alone from that JSON of a run's results.
fn study_calibration(
    counts: [u64; 5],
    bike: &Path,
    out: &Path,
    rendered_from: Option<&Path>,
) -> Result<()> {
    use bikeproc::blind::studies::{
        run_study, study_markdown, StudyKind, ACTUATOR_LAG_SEEDS, CONTROLLER_SPEED_SEEDS,
    };
    let [studies, near_nominal, controls, controller_speed, actuator_lag] = counts;
    let command = format!(
        "bikeproc simulate study-calibration --studies {studies} --near-nominal {near_nominal} \
         --controls {controls} --controller-speed {controller_speed} --actuator-lag \
         {actuator_lag} --out {}",
        out.display()
    );
    if let Some(json) = rendered_from {
        let text =
            std::fs::read_to_string(json).with_context(|| format!("reading {}", json.display()))?;
        let results: Vec<bikeproc::blind::studies::StudyResult> = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a study calibration's results", json.display()))?;
        write_atomic(out, study_markdown(&results, &[], &command).as_bytes())?;
        note!("wrote {} from {}", out.display(), json.display());
        return Ok(());
    }
    let lab = LabBike::load(bike)?;
    let text =
        std::fs::read_to_string(bike).with_context(|| format!("reading {}", bike.display()))?;
    let n0 = bikeproc::blind::studies::NEAR_NOMINAL_SEEDS;
    let cases: Vec<(u64, StudyKind)> = (1..=studies)
        .map(|s| (s, StudyKind::Blind))
        .chain((n0..n0 + near_nominal).map(|s| (s, StudyKind::NearNominal)))
        .chain((1001..1001 + controls).map(|s| (s, StudyKind::EffectFree)))
        .chain(
            (CONTROLLER_SPEED_SEEDS..CONTROLLER_SPEED_SEEDS + controller_speed)
                .map(|s| (s, StudyKind::ControllerSpeed)),
        )
        .chain(
            (ACTUATOR_LAG_SEEDS..ACTUATOR_LAG_SEEDS + actuator_lag)
                .map(|s| (s, StudyKind::ActuatorLag)),
        )
        .collect();
    let (mut results, mut failures) = (Vec::new(), Vec::new());
    for (k, &(seed, kind)) in cases.iter().enumerate() {
        match run_study(&lab, &text, seed, kind) {
            Ok(r) => {
                let pair = match r.motor_fit.as_ref().map(|f| f.0.as_slice()) {
                    Some([gains @ .., inertia]) => format!(
                        "the pair's gains {} × nominal, inertia {inertia:.4} kg·m²",
                        gains
                            .iter()
                            .map(|g| format!("{g:.3}"))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                    _ => "no fit of the pair".to_string(),
                };
                let pair = match (kind.withheld(), r.withheld_fit) {
                    (Some(e), Some((k, se))) => format!("{pair}; {} {k:.3} ± {se:.3}", e.name()),
                    _ => pair,
                };
                note!(
                    "[{}/{}] {} seed {seed}: p {:.2e}, best {}; {pair}",
                    k + 1,
                    cases.len(),
                    kind.label(),
                    r.campaign_p_value,
                    r.best,
                );
                results.push(r);
            }
            Err(e) => failures.push(format!("seed {seed} ({}): {e}", kind.label())),
        }
    }
    write_atomic(
        out,
        study_markdown(&results, &failures, &command).as_bytes(),
    )?;
    let json = serde_json::to_string_pretty(&results)?;
    write_atomic(&out.with_extension("json"), json.as_bytes())?;
    note!("wrote {} and its .json", out.display());
    Ok(())
}

/// `simulate check-calibration`: each file's Markdown rendered again from its results, and a
/// few of its cases replayed against their record; a line per case, exit 1 on a difference.
fn check_calibration(files: &[PathBuf], per_design: usize, bike: &Path) -> Result<()> {
    use bikeproc::blind::replay;
    let lab = LabBike::load(bike)?;
    let bike_text =
        std::fs::read_to_string(bike).with_context(|| format!("reading {}", bike.display()))?;
    let mut differ = Vec::new();
    for json in files {
        let text =
            std::fs::read_to_string(json).with_context(|| format!("reading {}", json.display()))?;
        // A file that is not a calibration's results is the input's fault (exit 2).
        let records =
            replay::parse_records(json, &text).map_err(|e| super::Refused(e.to_string()))?;
        let md_path = json.with_extension("md");
        let md = std::fs::read_to_string(&md_path)
            .with_context(|| format!("reading {}", md_path.display()))?;
        let checked = replay::check(&records, &md, per_design, &lab, &bike_text, &|case| {
            note!("{}: replaying {case}", json.display())
        })
        .with_context(|| format!("{}", json.display()))?;
        if checked.renders_the_same {
            note!(
                "{}: rendered again from {}: the same",
                md_path.display(),
                json.display()
            );
        } else {
            differ.push(format!(
                "{} is not what {} renders to",
                md_path.display(),
                json.display()
            ));
        }
        for r in checked.replayed {
            match r.difference {
                None => note!("{}: {}: the same", json.display(), r.case),
                Some(d) => differ.push(format!("{}: {}: {d}", json.display(), r.case)),
            }
        }
    }
    if !differ.is_empty() {
        anyhow::bail!(
            "the calibration files no longer hold for this code (make them again by the \
             command each names):\n  {}",
            differ.join("\n  ")
        );
    }
    Ok(())
}

fn gap_calibration(
    campaigns: u64,
    controls: u64,
    only: &[String],
    bike: &Path,
    out: &Path,
    rendered_from: Option<&Path>,
) -> Result<()> {
    use bikeproc::blind::campaigns as calibration;
    use campaign::Withheld;
    let mut command =
        format!("bikeproc simulate gap-calibration --campaigns {campaigns} --controls {controls}");
    if !only.is_empty() {
        command += &format!(" --only {}", only.join(","));
    }
    command += &format!(" --out {}", out.display());
    if let Some(json) = rendered_from {
        let text =
            std::fs::read_to_string(json).with_context(|| format!("reading {}", json.display()))?;
        let results: Vec<calibration::CaseResult> = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a calibration's results", json.display()))?;
        let md = calibration::markdown(&results, &[], &command);
        write_atomic(out, md.as_bytes())?;
        note!("wrote {} from {}", out.display(), json.display());
        return Ok(());
    }
    for o in only {
        if Withheld::from_label(o).is_none() {
            anyhow::bail!("--only: unknown effect `{o}`");
        }
    }
    let lab = LabBike::load(bike)?;
    let text =
        std::fs::read_to_string(bike).with_context(|| format!("reading {}", bike.display()))?;
    let cases: Vec<calibration::Case> = calibration::cases(campaigns, controls)
        .into_iter()
        .filter(|c| only.is_empty() || only.iter().any(|o| o == c.withheld.label()))
        .collect();
    let (mut results, mut failures) = (Vec::new(), Vec::new());
    for (k, case) in cases.iter().enumerate() {
        match calibration::run_case(&lab, &text, *case) {
            Ok(r) => {
                note!(
                    "[{}/{}] {} {} seed {}: p {:.2e}, best {}, named {}, right {}",
                    k + 1,
                    cases.len(),
                    r.effect,
                    r.design.label(),
                    r.seed,
                    r.campaign_p_value,
                    r.best,
                    r.named,
                    r.right
                );
                results.push(r);
            }
            Err(e) => failures.push(format!(
                "{} {} seed {}: {e}",
                case.withheld.label(),
                case.design.label(),
                case.seed
            )),
        }
    }
    let md = calibration::markdown(&results, &failures, &command);
    write_atomic(out, md.as_bytes())?;
    let json = serde_json::to_string_pretty(&results)?;
    write_atomic(&out.with_extension("json"), json.as_bytes())?;
    note!("wrote {} and its .json", out.display());
    Ok(())
}
