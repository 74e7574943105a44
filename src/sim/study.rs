//! A blind study: the lab's bicycle carrying a geared steer motor whose reflected inertia and
//! delivered gain are withheld, ridden with the motor unpowered and powered at three controller
//! gains — four campaigns of one bicycle, as a lab splits what one campaign cannot tell.
//!
//! In: the measured bicycle, the name of its file, a seed. Out: the files (one campaign
//! manifest per condition, the logs, the study manifest `study.toml` listing them, and the
//! sealed `truth.json`) and the truth. The motor is the simulator's own ([`SteerMotor`]): its
//! rotor's inertia on the fork about the steer axis, its controller's torque in the loads.

use super::calibration::{stage, BlindError};
use super::campaign::{measured_within_errors, Files};
use super::draw::{seeded, Draw};
use super::ride::{simulate_ride, Effects, MotorController, RideSpec, SimulationError, SteerMotor};
use std::fmt::Write as _;

/// The controller's roll-rate gains of the powered conditions, G (N·m·s/rad per m/s below
/// [`CONTROL_BELOW_MPS`]): a balance-assist law, T = G (v₀ − v) φ̇ below v₀, off above it.
/// On the lab's bicycle (stable 3.1–5.4 m/s as measured) G = 1 makes it stable from 2.0 m/s,
/// G = 2 from 1.3 m/s.
pub const STUDY_GAINS: [f64; 3] = [1.0, 1.5, 2.0];

/// The speed below which the controller acts (m/s).
pub const CONTROL_BELOW_MPS: f64 = 3.5;

/// The sealed truth of a blind study.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct StudyTruth {
    /// The motor's rotor inertia reflected to the steer axis (kg·m²): 0.01–0.1. (On the lab's
    /// light bicycle, whose handlebar assembly has I_xx 0.31 kg·m², 0.23 already makes it fall
    /// within half a second of every kick unpowered and at G = 1: no ride gives a weave.)
    pub reflected_inertia_kgm2: f64,
    /// The torque the motor delivers over the commanded: 0.4–0.9 or 1.1–1.3, 39 % of the
    /// draws below the 0.67 once taken as plausible.
    pub delivered: f64,
    /// The conditions' names, uncontrolled first, and their gains G (0 unpowered).
    pub conditions: Vec<(String, f64)>,
    pub seed: u64,
}

/// The study of `seed`: 10 rides unpowered at 3.4–5.2 m/s and 10 rides per gain at
/// 2.5–3.5 m/s, where the controller acts and each gain's capsize and castor are still real
/// (below 2.5 m/s they join in a second oscillatory pair the rides' weave fits do not model);
/// the speedometer read at the release to 0.01 m/s, nothing slowing the coast, on the
/// measured bicycle off by a draw of its measurement errors.
/// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#blind_study).
pub fn blind_study(
    measured: &crate::inertia::bike::LabBike,
    bike_file: &str,
    seed: u64,
) -> Result<(Files, StudyTruth), SimulationError> {
    blind_study_with(measured, bike_file, seed, None)
}

/// [`blind_study`] with the motor given, `(reflected inertia kg·m², delivered)`, instead of
/// drawn (`(0, 1)`: an effect-free study, the motor's rotor weightless and its torque as
/// commanded); the rides' draws are those of the seed either way.
pub fn blind_study_with(
    measured: &crate::inertia::bike::LabBike,
    bike_file: &str,
    seed: u64,
    motor: Option<(f64, f64)>,
) -> Result<(Files, StudyTruth), SimulationError> {
    let mut rng = seeded(31_000 + seed);
    let truth_bike = measured_within_errors(measured, &mut seeded(37_000 + seed));
    let bike = crate::model::lab::lab_to_benchmark(&truth_bike);
    let drawn = (
        rng.range(0.01, 0.1),
        delivered_away_from_nominal(rng.range(0.0, 0.7)),
    );
    let (reflected, delivered) = motor.unwrap_or(drawn);
    let mut conditions = vec![("unpowered".to_string(), 0.0)];
    conditions.extend(STUDY_GAINS.iter().map(|g| (format!("gain_{g}"), *g)));
    let mut files = Files::new();
    let mut listed = Vec::new();
    for (c, (name, gain)) in conditions.iter().enumerate() {
        let controller = (*gain > 0.0).then(|| MotorController {
            speeds_mps: vec![0.0, CONTROL_BELOW_MPS, 20.0],
            gains: vec![
                [0.0, 0.0, gain * CONTROL_BELOW_MPS, 0.0],
                [0.0; 4],
                [0.0; 4],
            ],
            delivered,
        });
        let effects = Effects {
            steer_motor: Some(SteerMotor {
                reflected_inertia_kgm2: reflected,
                controller,
            }),
            ..Effects::default()
        };
        let mut manifest = format!(
            "# A blind study's condition: {name}.\nversion = 1\nbike = \"{bike_file}\"\n\
             speedometer_resolution_mps = 0.01\nspeedometer_se_fraction = 0.0\n"
        );
        if *gain > 0.0 {
            let _ = write!(
                manifest,
                "\n[controller]\ndescription = \"roll-rate assist, G = {gain}\"\n\
                 speeds_mps = [0.0, {CONTROL_BELOW_MPS}, 20.0]\n\
                 roll_rate_nms_per_rad = [{}, 0.0, 0.0]\n",
                gain * CONTROL_BELOW_MPS
            );
        }
        for k in 0..10 {
            let speed = if *gain > 0.0 {
                2.5 + 0.11 * k as f64
            } else {
                3.4 + 0.2 * k as f64
            };
            let mut spec = RideSpec::lab(speed, effects.clone());
            // The speedometer read at the release (no reed switch: a reed switch that lost
            // pulses at 3.35 m/s gave 2.31 ± 0.38 m/s on one ride of seed 102's effect-free
            // study, which the campaign then took over the reading, χ² 6757 for 40 dof).
            spec.sync = false;
            spec.kick.peak_force_n = rng.range(12.0, 18.0);
            spec.receiver_late_bursts_per_minute = 6.0;
            let ride = simulate_ride(&bike, &spec, 1000 * seed + 100 * c as u64 + k as u64)?;
            let log = format!("{name}_ride_{:02}", k + 1);
            files.push((format!("{log}.log").into(), ride.angles_log));
            files.push((format!("{log}_cal.log").into(), ride.cal_log));
            let _ = write!(
                manifest,
                "\n[[ride]]\nlog = \"{log}.log\"\nnoted_speed_mps = {:.2}\n",
                ride.truth.noted_speed_mps
            );
        }
        files.push((format!("{name}.toml").into(), manifest));
        listed.push(format!("\"{name}.toml\""));
    }
    files.push((
        "study.toml".into(),
        format!(
            "# A blind study: a steer motor's inertia and delivered gain withheld (truth.json).\n\
             version = 1\nconditions = [{}]\n",
            listed.join(", ")
        ),
    ));
    let truth = StudyTruth {
        reflected_inertia_kgm2: reflected,
        delivered,
        conditions,
        seed,
    };
    files.push((
        "truth.json".into(),
        serde_json::to_string(&truth).unwrap_or_default(),
    ));
    files.sort_by(|a, b| a.0.cmp(&b.0));
    Ok((files, truth))
}

/// The delivered gain of a blind study from `u` in [0, 0.7): 0.4–0.9 or 1.1–1.3, uniform over
/// both. Near the nominal the gain is no effect these rides can name beside the rotor: of the
/// 6 draws of 0.4–1.3 within 0.05 of it in 50 studies, the rotor alone was named in all 6, and
/// with every pair tried the rotor with an effect of the bicycle in 2 and the pair in 1.
/// [`near_nominal_motor`] draws those for a tally of their own.
fn delivered_away_from_nominal(u: f64) -> f64 {
    if u < 0.5 {
        0.4 + u
    } else {
        1.1 + (u - 0.5)
    }
}

/// A motor whose torque is as commanded within 5 % (delivered 0.95–1.05), its rotor 0.025–0.1
/// kg·m² (seeded apart from the rides'): the rotor alone is the answer the rides can give.
pub fn near_nominal_motor(seed: u64) -> (f64, f64) {
    let mut rng = seeded(41_000 + seed);
    (rng.range(0.025, 0.1), rng.range(0.95, 1.05))
}

/// The first seed of the near-nominal studies of a calibration.
pub const NEAR_NOMINAL_SEEDS: u64 = 2001;

/// The steer motor's two effects as the diagnosis names them together.
const PAIR: &str = "actuator_gain + steer_inertia";
/// Its rotor alone.
const INERTIA: &str = "steer_inertia";

/// The kinds of study a calibration runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum StudyKind {
    /// The motor drawn away from nominal ([`blind_study`]).
    Blind,
    /// The motor's torque within 5 % of nominal ([`near_nominal_motor`]).
    NearNominal,
    /// A weightless rotor, the torque as commanded.
    EffectFree,
}

impl StudyKind {
    /// Every kind, in a calibration's order.
    pub const ALL: [StudyKind; 3] = [
        StudyKind::Blind,
        StudyKind::NearNominal,
        StudyKind::EffectFree,
    ];

    /// Its name in a calibration's progress lines.
    pub fn label(self) -> &'static str {
        match self {
            StudyKind::Blind => "blind",
            StudyKind::NearNominal => "near-nominal",
            StudyKind::EffectFree => "effect-free",
        }
    }
}

/// What the diagnosis said of one blind study, beside its truth.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct StudyResult {
    pub seed: u64,
    pub kind: StudyKind,
    /// The steer inertia fitted alone `(value, se)`, wherever it ranks.
    pub inertia_alone: Option<(f64, f64)>,
    /// steer_inertia alone named first, or tied at the top, with a significant gap.
    pub names_inertia_alone: bool,
    /// `None` for an effect-free study.
    pub truth: Option<StudyTruth>,
    pub rides_used: usize,
    pub significant: bool,
    /// NaN (`null` in the JSON) where no candidate was fitted.
    #[serde(deserialize_with = "super::calibration::number_nan_for_null")]
    pub campaign_p_value: f64,
    pub best: String,
    pub tied: Vec<String>,
    /// The pair named first, or tied at the top, with a significant gap.
    pub named: bool,
    /// The joint diagnosis's `actuator_gain + steer_inertia` (three gains, then the inertia)
    /// with standard errors, wherever it ranks (an error NaN, `null` in the JSON, at a bound).
    #[serde(deserialize_with = "super::calibration::fit_nan_for_null")]
    pub motor_fit: Option<(Vec<f64>, Vec<f64>)>,
    /// The single-campaign diagnoses of the powered conditions: how many name the pair first
    /// (or tied at the top), and their inertia fits `(value, se)` where they do.
    pub singles_named: usize,
    pub singles_inertia: Vec<(f64, f64)>,
}

/// Simulates the study of `seed` (the motor drawn, or effect-free) into a scratch folder and
/// diagnoses it from its files as `bikeproc gap DIR/study.toml` does, then each powered
/// condition alone as `bikeproc gap DIR/gain_G.toml` does.
pub fn run_study(
    measured: &crate::inertia::bike::LabBike,
    bike_text: &str,
    seed: u64,
    kind: StudyKind,
) -> Result<StudyResult, BlindError> {
    let effect_free = kind == StudyKind::EffectFree;
    let motor = match kind {
        StudyKind::Blind => None,
        StudyKind::NearNominal => Some(near_nominal_motor(seed)),
        StudyKind::EffectFree => Some((0.0, 1.0)),
    };
    let (files, truth) = blind_study_with(measured, "bike.toml", seed, motor).map_err(stage)?;
    let name = format!("study_calibration_{seed}_{kind:?}");
    super::calibration::in_scratch(&name, &files, bike_text, &|dir| {
        let study = crate::read::study::Study::load(&dir.join("study.toml")).map_err(stage)?;
        let bike = study.bike_path().map_err(stage)?;
        let model = crate::read::bicycle::load(&bike).map_err(stage)?;
        let d = crate::gap::diagnose_manifests(&study.conditions, &model, &|_, _, _| {})
            .map_err(stage)?;
        // `effect` named: first, or tied at the top, with a significant gap.
        let names = |d: &crate::gap::Diagnosis, effect: &str| {
            d.significant
                && (d.ranking.first().is_some_and(|b| b.effect == effect)
                    || d.tied.iter().any(|t| t == effect))
        };
        let motor_fit = d
            .ranking
            .iter()
            .find(|r| r.effect == PAIR)
            .map(|r| (r.params.clone(), r.params_se.clone()));
        let (mut singles_named, mut singles_inertia) = (0, Vec::new());
        // The powered conditions one at a time, for the blind studies' comparison only.
        for (_, m) in study
            .conditions
            .iter()
            .filter(|(_, m)| kind == StudyKind::Blind && !m.control.is_none())
        {
            let one = m.model(None).map_err(stage)?;
            let s = crate::gap::diagnose_campaign(m, &one, &|_, _, _| {}).map_err(stage)?;
            if names(&s, PAIR) {
                singles_named += 1;
                if let Some(r) = s.ranking.iter().find(|r| r.effect == PAIR) {
                    singles_inertia.push((r.params[1], r.params_se[1]));
                }
            }
        }
        let inertia_alone = d
            .ranking
            .iter()
            .find(|r| r.effect == INERTIA)
            .map(|r| (r.params[0], r.params_se[0]));
        Ok(StudyResult {
            seed,
            kind,
            inertia_alone,
            names_inertia_alone: names(&d, INERTIA),
            truth: (!effect_free).then(|| truth.clone()),
            rides_used: d.rides_used,
            significant: d.significant,
            campaign_p_value: d.campaign_p_value,
            best: d
                .ranking
                .first()
                .map_or(String::new(), |r| r.effect.clone()),
            tied: d.tied.clone(),
            named: names(&d, PAIR),
            motor_fit,
            singles_named,
            singles_inertia,
        })
    })
}

/// The tallies of blind and effect-free studies as Markdown (`docs/study-calibration.md`).
pub fn study_markdown(results: &[StudyResult], failures: &[String], command: &str) -> String {
    let mut md = String::from("# The joint diagnosis of a study, calibrated on blind studies\n\n");
    let _ = write!(
        md,
        "Made by `{command}` (every study seeded: the file is byte-identical when regenerated). \
         Each study is `bikeproc simulate blind-study`: the lab's bicycle (off from its measured \
         values by a draw of their errors) with a geared steer motor whose reflected inertia \
         (0.01–0.1 kg·m²) and delivered gain (0.4–0.9 or 1.1–1.3, 39 % below the 0.67 once \
         taken as plausible) are withheld, ridden unpowered (10 rides, 3.4–5.2 m/s) and \
         powered at the gains G = {:?} (10 rides each, 2.5–3.5 m/s); near-nominal studies have \
         the rotor with the torque within 5 % of the commanded (the rotor alone is then the \
         answer); effect-free studies have a weightless rotor and the torque as commanded. \
         Each is diagnosed from its files as `bikeproc gap \
         DIR/study.toml` does, then each powered condition alone.\n\n",
        STUDY_GAINS
    );
    let of =
        |k: StudyKind| -> Vec<&StudyResult> { results.iter().filter(|r| r.kind == k).collect() };
    let (blind, near, controls) = (
        of(StudyKind::Blind),
        of(StudyKind::NearNominal),
        of(StudyKind::EffectFree),
    );
    let pct = |a: usize, b: usize| {
        if b == 0 {
            "–".to_string()
        } else {
            format!("{a}/{b} ({:.1} %)", 100.0 * a as f64 / b as f64)
        }
    };
    let named = blind.iter().filter(|r| r.named).count();
    let first = blind
        .iter()
        .filter(|r| r.significant && r.best == PAIR)
        .count();
    // Coverage of each fitted value: (z values of the inertia, z values of the gains).
    let (mut z_j, mut z_a) = (Vec::new(), Vec::new());
    // The studies that name the pair with every value within 2 SE of its truth.
    let mut named_within_2 = 0;
    for r in &blind {
        let (Some(t), Some((p, se))) = (&r.truth, &r.motor_fit) else {
            continue;
        };
        let n = p.len();
        if n < 2 {
            continue;
        }
        let z: Vec<f64> = (0..n)
            .map(|k| {
                let truth = if k + 1 == n {
                    t.reflected_inertia_kgm2
                } else {
                    t.delivered
                };
                (p[k] - truth) / se[k]
            })
            .collect();
        if r.named && z.iter().all(|z| z.abs() <= 2.0) {
            named_within_2 += 1;
        }
        z_j.push(z[n - 1]);
        z_a.extend_from_slice(&z[..n - 1]);
    }
    let within = |z: &[f64], k: f64| z.iter().filter(|x| x.abs() <= k).count();
    let median = |z: &[f64]| {
        let mut v: Vec<f64> = z.iter().copied().filter(|x| x.is_finite()).collect();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    let singles: usize = blind.iter().map(|r| r.singles_named).sum();
    let z_single: Vec<f64> = blind
        .iter()
        .filter_map(|r| Some((r.truth.as_ref()?.reflected_inertia_kgm2, &r.singles_inertia)))
        .flat_map(|(t, fits)| fits.iter().map(move |(j, se)| (j - t) / se))
        .collect();
    let _ = write!(
        md,
        "## The steer motor named, and its values\n\n\
         | studies | significant | the pair first | named (first or tied) | named, every value within 2 SE | inertia within 1 SE | within 2 SE | median z | gains within 1 SE | within 2 SE | median z |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n\
         | {} | {} | {} | {} | {} | {} | {} | {:+.2} | {} | {} | {:+.2} |\n\n\
         The same rides one powered condition at a time (`bikeproc gap DIR/gain_G.toml`): the \
         pair named in {} of the single campaigns; where named, their inertia within 1 SE of \
         its truth in {}, within 2 SE in {} (median z {:+.2}).\n",
        blind.len(),
        pct(blind.iter().filter(|r| r.significant).count(), blind.len()),
        pct(first, blind.len()),
        pct(named, blind.len()),
        pct(named_within_2, blind.len()),
        pct(within(&z_j, 1.0), z_j.len()),
        pct(within(&z_j, 2.0), z_j.len()),
        median(&z_j),
        pct(within(&z_a, 1.0), z_a.len()),
        pct(within(&z_a, 2.0), z_a.len()),
        median(&z_a),
        pct(singles, 3 * blind.len()),
        pct(within(&z_single, 1.0), z_single.len()),
        pct(within(&z_single, 2.0), z_single.len()),
        median(&z_single),
    );
    let missed: Vec<&&StudyResult> = blind.iter().filter(|r| !r.named).collect();
    if !missed.is_empty() {
        md.push_str(
            "\nNot named:\n\n| seed | rotor kg·m² | delivered | rides used | p | named instead |\n\
             |---|---|---|---|---|---|\n",
        );
        for r in missed {
            let Some(t) = &r.truth else { continue };
            let _ = writeln!(
                md,
                "| {} | {:.3} | {:.2} | {} | {:.1e} | {} |",
                r.seed,
                t.reflected_inertia_kgm2,
                t.delivered,
                r.rides_used,
                r.campaign_p_value,
                if r.best.is_empty() {
                    "no conclusion"
                } else {
                    &r.best
                }
            );
        }
    }
    if !near.is_empty() {
        let alone = near.iter().filter(|r| r.names_inertia_alone).count();
        let z: Vec<f64> = near
            .iter()
            .filter(|r| r.names_inertia_alone)
            .filter_map(|r| {
                let (j, se) = r.inertia_alone?;
                Some((j - r.truth.as_ref()?.reflected_inertia_kgm2) / se)
            })
            .collect();
        let pair = near.iter().filter(|r| r.named).count();
        let other = near
            .iter()
            .filter(|r| r.significant && !r.named && !r.names_inertia_alone)
            .count();
        let _ = write!(
            md,
            "\n## Near-nominal studies\n\n{} studies with the rotor (0.025–0.1 kg·m²) and the \
             torque within 5 % of the commanded (seeds {} on): the rotor named alone in {}, \
             its inertia within 1 SE of the truth in {}, within 2 SE in {} (median z {:+.2}); \
             the motor's pair named in {}; another explanation in {}.\n",
            near.len(),
            NEAR_NOMINAL_SEEDS,
            pct(alone, near.len()),
            pct(within(&z, 1.0), z.len()),
            pct(within(&z, 2.0), z.len()),
            median(&z),
            pct(pair, near.len()),
            pct(other, near.len()),
        );
    }
    let below = |x: f64| controls.iter().filter(|r| r.campaign_p_value < x).count();
    let _ = write!(
        md,
        "\n## Effect-free studies\n\n{} studies: significant (p < 0.01) in {}; p below 0.05 in {}.\n\n\
         | p | 0–0.1 | 0.1–0.2 | 0.2–0.3 | 0.3–0.4 | 0.4–0.5 | 0.5–0.6 | 0.6–0.7 | 0.7–0.8 | 0.8–0.9 | 0.9–1 |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n| studies |",
        controls.len(),
        pct(below(0.01), controls.len()),
        pct(below(0.05), controls.len()),
    );
    for b in 0..10 {
        let (lo, hi) = (b as f64 / 10.0, (b + 1) as f64 / 10.0);
        let n = controls
            .iter()
            .filter(|r| r.campaign_p_value >= lo && (r.campaign_p_value < hi || b == 9))
            .count();
        let _ = write!(md, " {n} |");
    }
    md.push('\n');
    if !failures.is_empty() {
        let _ = write!(md, "\n## Studies that could not be run\n\n");
        for f in failures {
            let _ = writeln!(md, "- {f}");
        }
    }
    md
}
