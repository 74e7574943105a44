//! Blind studies checked at once (`bikeproc simulate study-calibration`): each simulated
//! ([`crate::sim::study::blind_study_with`]) into a scratch folder, diagnosed from its files as
//! `bikeproc gap DIR/study.toml` does, then each powered condition alone, and compared with its
//! sealed truth. In: the measured bicycle, seeds and kinds. Out: one [`StudyResult`] per study
//! and the tallies as Markdown (`docs/study-calibration.md`, [`study_markdown`]).

use super::{in_scratch, stage, BlindError};
use crate::gap::effects::Effect;
use crate::sim::study::{
    blind_study_with, lag_draw, near_nominal_motor, sensor_scale_draw, StudyMotor, StudyTruth,
    STUDY_GAINS,
};
use std::fmt::Write as _;

/// The first seed of the near-nominal studies of a calibration.
pub const NEAR_NOMINAL_SEEDS: u64 = 2001;

/// The first seed of the studies whose controller senses its speed off by a factor.
pub const CONTROLLER_SPEED_SEEDS: u64 = 3001;

/// The first seed of the studies whose motor's torque lags its command.
pub const ACTUATOR_LAG_SEEDS: u64 = 4001;

/// The steer motor's two effects as the diagnosis names them together.
const PAIR: &str = "actuator_gain + steer_inertia";
/// Its rotor alone.
const INERTIA: &str = "steer_inertia";

/// The kinds of study a calibration runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum StudyKind {
    /// The motor drawn away from nominal ([`crate::sim::study::blind_study`]).
    Blind,
    /// The motor's torque within 5 % of nominal ([`near_nominal_motor`]).
    NearNominal,
    /// A weightless rotor, the torque as commanded.
    EffectFree,
    /// A weightless rotor and the torque as commanded, the controller's firmware sensing its
    /// speed off by a factor ([`sensor_scale_draw`]).
    ControllerSpeed,
    /// A weightless rotor and the torque as commanded, through a first-order lag
    /// ([`lag_draw`]).
    ActuatorLag,
}

impl StudyKind {
    /// Every kind, in a calibration's order.
    pub const ALL: [StudyKind; 5] = [
        StudyKind::Blind,
        StudyKind::NearNominal,
        StudyKind::EffectFree,
        StudyKind::ControllerSpeed,
        StudyKind::ActuatorLag,
    ];

    /// Its name in a calibration's progress lines.
    pub fn label(self) -> &'static str {
        match self {
            StudyKind::Blind => "blind",
            StudyKind::NearNominal => "near-nominal",
            StudyKind::EffectFree => "effect-free",
            StudyKind::ControllerSpeed => "controller-speed",
            StudyKind::ActuatorLag => "actuator-lag",
        }
    }

    /// The one effect of the library a kind withholds alone beside an effect-free motor (its
    /// controller's speed sensor, its lag); `None` for the motor's own kinds.
    pub fn withheld(self) -> Option<Effect> {
        match self {
            StudyKind::ControllerSpeed => Some(Effect::ControllerSpeedScale),
            StudyKind::ActuatorLag => Some(Effect::ActuatorLag),
            _ => None,
        }
    }

    /// The motor of the study of `seed` of this kind.
    fn motor(self, seed: u64) -> StudyMotor {
        match self {
            StudyKind::Blind => StudyMotor::DRAWN,
            StudyKind::NearNominal => StudyMotor {
                rotor_and_gain: Some(near_nominal_motor(seed)),
                ..StudyMotor::DRAWN
            },
            StudyKind::EffectFree => StudyMotor::EFFECT_FREE,
            StudyKind::ControllerSpeed => StudyMotor {
                speed_sensor_scale: sensor_scale_draw(seed),
                ..StudyMotor::EFFECT_FREE
            },
            StudyKind::ActuatorLag => StudyMotor {
                lag_s: lag_draw(seed),
                ..StudyMotor::EFFECT_FREE
            },
        }
    }
}

/// A study's truth of the effect its kind withholds alone ([`StudyKind::withheld`]): the
/// sensor's scale, the lag (s); NaN for other kinds.
fn withheld_truth(r: &StudyResult) -> f64 {
    match (r.kind, &r.truth) {
        (StudyKind::ControllerSpeed, Some(t)) => t.speed_sensor_scale,
        (StudyKind::ActuatorLag, Some(t)) => t.actuator_lag_s,
        _ => f64::NAN,
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
    #[serde(deserialize_with = "crate::blind::number_nan_for_null")]
    pub campaign_p_value: f64,
    pub best: String,
    pub tied: Vec<String>,
    /// The pair named first, or tied at the top, with a significant gap.
    pub named: bool,
    /// The joint diagnosis's `actuator_gain + steer_inertia` (three gains, then the inertia)
    /// with standard errors, wherever it ranks (an error NaN, `null` in the JSON, at a bound).
    #[serde(deserialize_with = "crate::blind::fit_nan_for_null")]
    pub motor_fit: Option<(Vec<f64>, Vec<f64>)>,
    /// The single-campaign diagnoses of the powered conditions: how many name the pair first
    /// (or tied at the top), and their inertia fits `(value, se)` where they do.
    pub singles_named: usize,
    pub singles_inertia: Vec<(f64, f64)>,
    /// The conditions whose mode shape the instrument check set aside
    /// ([`crate::gap::instrument`]), in the joint diagnosis or alone: every simulated study
    /// records its shape as the model assumes, so each is a false alarm or a shape no
    /// candidate follows.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shapes_set_aside: Vec<String>,
    /// The effect its kind withholds alone ([`StudyKind::withheld`]) named first, or tied at
    /// the top, with a significant gap.
    #[serde(
        default,
        alias = "names_controller_speed",
        skip_serializing_if = "std::ops::Not::not"
    )]
    pub names_withheld: bool,
    /// That effect's fit alone `(value, se)` wherever it ranks (studies of such kinds only).
    #[serde(
        default,
        alias = "controller_speed_fit",
        skip_serializing_if = "Option::is_none"
    )]
    pub withheld_fit: Option<(f64, f64)>,
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
    let (files, truth) =
        blind_study_with(measured, "bike.toml", seed, kind.motor(seed)).map_err(stage)?;
    let name = format!("study_calibration_{seed}_{kind:?}");
    in_scratch(&name, &files, bike_text, &|dir| {
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
        let set_aside = |d: &crate::gap::Diagnosis| {
            d.instrument
                .iter()
                .filter(|c| c.misses)
                .map(|c| c.condition.clone())
                .collect::<Vec<_>>()
        };
        let mut shapes_set_aside = set_aside(&d);
        // The powered conditions one at a time, for the blind studies' comparison only.
        for (_, m) in study
            .conditions
            .iter()
            .filter(|(_, m)| kind == StudyKind::Blind && !m.control.is_none())
        {
            let one = m.model(None).map_err(stage)?;
            let s = crate::gap::diagnose_campaign(m, &one, &|_, _, _| {}).map_err(stage)?;
            shapes_set_aside.extend(set_aside(&s).into_iter().map(|c| format!("{c} alone")));
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
            shapes_set_aside,
            names_withheld: kind.withheld().is_some_and(|e| names(&d, e.name())),
            withheld_fit: kind.withheld().and_then(|e| {
                d.ranking
                    .iter()
                    .find(|r| r.effect == e.name())
                    .map(|r| (r.params[0], r.params_se[0]))
            }),
        })
    })
}

/// A study of a kind that withholds one effect alone ([`StudyKind::withheld`]: a controller's
/// speed sensor, an actuator's lag) named it at the right size: first (or tied at the top)
/// with a significant gap, its fit within 30 % of the truth's deviation from "no effect" (the
/// gap calibration's "right").
pub fn withheld_right(r: &StudyResult) -> bool {
    r.names_withheld && withheld_size_right(r)
}

/// A study of a kind that withholds one effect alone put it in its first candidate, alone or
/// beside another effect, with a significant gap, its fit alone at the right size.
pub fn withheld_in_first(r: &StudyResult) -> bool {
    let Some(e) = r.kind.withheld() else {
        return false;
    };
    r.significant && r.best.split(" + ").any(|b| b == e.name()) && withheld_size_right(r)
}

/// The withheld effect fitted alone within 30 % of the truth's deviation from "no effect"
/// ([`crate::blind::campaigns::size_right`]).
fn withheld_size_right(r: &StudyResult) -> bool {
    let (Some(e), Some((k, _))) = (r.kind.withheld(), r.withheld_fit) else {
        return false;
    };
    crate::blind::campaigns::size_right(e, &[k], &[withheld_truth(r)])
}

/// `a` of `b` with its percentage, `–` of none.
fn pct(a: usize, b: usize) -> String {
    if b == 0 {
        "–".to_string()
    } else {
        format!("{a}/{b} ({:.1} %)", 100.0 * a as f64 / b as f64)
    }
}

/// What a study named first, for a table of those it missed.
fn named_instead(r: &StudyResult) -> &str {
    if r.best.is_empty() {
        "no conclusion"
    } else {
        &r.best
    }
}

/// The joint diagnosis's motor fit against the study's truth, `(fit − truth)/SE` of each gain
/// and then of the inertia; `None` for a study without a truth or a motor fit.
fn motor_z(r: &StudyResult) -> Option<Vec<f64>> {
    let (Some(t), Some((p, se))) = (&r.truth, &r.motor_fit) else {
        return None;
    };
    let n = p.len();
    (n >= 2).then(|| {
        (0..n)
            .map(|k| {
                let truth = if k + 1 == n {
                    t.reflected_inertia_kgm2
                } else {
                    t.delivered
                };
                (p[k] - truth) / se[k]
            })
            .collect()
    })
}

/// The study named the motor's pair with every value (each gain, the inertia) within 2 of its
/// standard errors of the truth: the study calibration's headline (issue 75's bar: 45 of 50).
pub fn named_within_2se(r: &StudyResult) -> bool {
    r.named && motor_z(r).is_some_and(|z| z.iter().all(|z| z.abs() <= 2.0))
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
        let Some(z) = motor_z(r) else { continue };
        named_within_2 += usize::from(named_within_2se(r));
        let n = z.len();
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
                named_instead(r)
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
    for kind in [StudyKind::ControllerSpeed, StudyKind::ActuatorLag] {
        let withheld = of(kind);
        if !withheld.is_empty() {
            withheld_section(&mut md, kind, &withheld);
        }
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
    let set_aside: Vec<String> = results
        .iter()
        .flat_map(|r| {
            r.shapes_set_aside
                .iter()
                .map(move |c| format!("seed {} ({}): {c}", r.seed, r.kind.label()))
        })
        .collect();
    let _ = write!(
        md,
        "\n## The instrument checked first\n\nEvery simulated study records its mode shape as the model assumes, so the instrument check (`gap::instrument`: a condition's shape that misses every candidate by a common factor, χ² over {} on 2 degrees of freedom, is set aside and the condition diagnosed on its eigenvalue) should never fire, in the joint diagnosis or in a condition alone. It fired {} times in {} studies{}.\n",
        crate::gap::instrument::SHAPE_MISS_CHI2,
        set_aside.len(),
        results.len(),
        if set_aside.is_empty() {
            String::new()
        } else {
            format!(": {}", set_aside.join("; "))
        }
    );
    if !failures.is_empty() {
        let _ = write!(md, "\n## Studies that could not be run\n\n");
        for f in failures {
            let _ = writeln!(md, "- {f}");
        }
    }
    md
}

/// The studies of a kind that withholds one effect alone as Markdown: how often it is named,
/// at the right size, its errors' coverage, and the studies where it is not right.
fn withheld_section(md: &mut String, kind: StudyKind, studies: &[&StudyResult]) {
    let Some(effect) = kind.withheld() else {
        return;
    };
    let mut z: Vec<f64> = studies
        .iter()
        .filter_map(|r| {
            let (k, se) = r.withheld_fit?;
            Some((k - withheld_truth(r)) / se).filter(|z| z.is_finite())
        })
        .collect();
    z.sort_by(f64::total_cmp);
    let within = |k: f64| z.iter().filter(|x| x.abs() <= k).count();
    let named = studies.iter().filter(|r| r.names_withheld).count();
    let right = studies.iter().filter(|r| withheld_right(r)).count();
    let in_first = studies.iter().filter(|r| withheld_in_first(r)).count();
    let none = effect.params()[0].none;
    let (title, seeds, what) = match kind {
        StudyKind::ActuatorLag => (
            "The actuator's lag",
            ACTUATOR_LAG_SEEDS,
            "the motor's torque following its command through a first-order lag of \
             0.01–0.08 s (`sim::study::lag_draw`)",
        ),
        _ => (
            "The speed the controller senses",
            CONTROLLER_SPEED_SEEDS,
            "the controller's firmware sensing 0.85–0.97 or 1.03–1.15 times the rear \
             wheel's speed (`sim::study::sensor_scale_draw`)",
        ),
    };
    let _ = write!(
        md,
        "\n## {title}\n\n{} studies (seeds {seeds} on) with a weightless rotor and the torque \
         as commanded, {what}: significant in {}; `{}` named (first or tied) in {}, at the \
         right size (within 30 % of the truth's deviation from {none}) in {}; in the first \
         candidate, alone or beside an effect of the bicycle, at the right size in {}. Its fit \
         alone, wherever it ranks: the truth within 1 SE in {}, within 2 SE in {} (median z \
         {:+.2}).\n",
        studies.len(),
        pct(
            studies.iter().filter(|r| r.significant).count(),
            studies.len()
        ),
        effect.name(),
        pct(named, studies.len()),
        pct(right, studies.len()),
        pct(in_first, studies.len()),
        pct(within(1.0), z.len()),
        pct(within(2.0), z.len()),
        z.get(z.len() / 2).copied().unwrap_or(f64::NAN),
    );
    let missed: Vec<&&StudyResult> = studies.iter().filter(|r| !withheld_right(r)).collect();
    if !missed.is_empty() {
        md.push_str(
            "\nNot right:\n\n| seed | truth | fitted | rides used | p | named instead |\n\
             |---|---|---|---|---|---|\n",
        );
        for r in missed {
            let fitted = r
                .withheld_fit
                .map_or("—".to_string(), |(k, se)| format!("{k:.3} ± {se:.3}"));
            let _ = writeln!(
                md,
                "| {} | {:.3} | {fitted} | {} | {:.1e} | {} |",
                r.seed,
                withheld_truth(r),
                r.rides_used,
                r.campaign_p_value,
                named_instead(r)
            );
        }
    }
}
