//! Issue 12: the speed where the eigenvalue applies, from the ride's own log, and the
//! eigenvalue's errors on a coasting bicycle, against the simulator's truth, on rides made as a
//! lab without a reed switch makes them (noted reading at the release rounded to 0.1 m/s,
//! coasting 0.05–0.2 m/s², kick 1–1.5 s after the release, sensors a few degrees off).

use bikeproc::inertia::bike::LabBike;
use bikeproc::model::nonlinear::NonlinearBicycle;
use bikeproc::model::{lab::lab_to_benchmark, uncertain, Benchmark, Canonical};
use bikeproc::ride::amplitude::amplitude_shift;
use bikeproc::ride::dynamic::{dynamic_test, DynamicOptions, DynamicTest};
use bikeproc::ride::speed::NotedReading;
use bikeproc::sim::campaign::{coasting_ride, noted_reading, truth_bike};
use bikeproc::sim::draw::{seeded, Draw};
use bikeproc::sim::ride::{simulate_ride, Effects, RideSpec, RideTruth};
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn bikes() -> (uncertain::Parametrized, Benchmark) {
    let path = root().join("data/lab_bike.toml");
    let truth = truth_bike(&LabBike::load(&path).unwrap());
    (
        bikeproc::read::bicycle::load(&path).unwrap(),
        lab_to_benchmark(&truth),
    )
}

/// Simulates a ride, writes its log pair to a scratch folder and runs the dynamic test with
/// the reading `noted` makes of the speedometer's (none: `None`).
fn analyse(
    bike: &Benchmark,
    model: &uncertain::Parametrized,
    spec: &RideSpec,
    noted: impl FnOnce(f64) -> Option<f64>,
    seed: u64,
) -> (Result<DynamicTest, String>, RideTruth) {
    let ride = simulate_ride(bike, spec, seed).unwrap();
    let noted = noted(ride.truth.noted_speed_mps);
    let dir = std::env::temp_dir().join(format!("bikeproc_speed_{}_{seed}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("r.log"), &ride.angles_log).unwrap();
    std::fs::write(dir.join("r_cal.log"), &ride.cal_log).unwrap();
    let options = DynamicOptions {
        noted: noted.map(NotedReading::lab),
        ..DynamicOptions::default()
    };
    let r = dynamic_test(&dir.join("r.log"), model, &options).map_err(|e| e.to_string());
    std::fs::remove_dir_all(&dir).ok();
    (r, ride.truth)
}

fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    (
        m,
        (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt(),
    )
}

fn parallel<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    use rayon::prelude::*;
    (0..n).into_par_iter().map(&f).collect()
}

/// Normalized errors of one coasting ride: speed (noted carried), kinematic speed, σ, ω.
#[derive(Debug, Clone, Copy)]
struct Z {
    speed: f64,
    kinematic: f64,
    kinematic_rel: f64,
    re: f64,
    im: f64,
    /// σ and ω against the Whipple model of the true bicycle at the true speed (what the gap
    /// stage predicts; the simulator's own linearization carries the resistances too).
    re_whipple: f64,
    im_whipple: f64,
    /// The same with the error the gap stage gives the ride in a campaign: its own and the
    /// coasting correction's common part ([`campaign_se`]).
    re_campaign: f64,
    im_campaign: f64,
    /// |γ/θ| and arg γ/θ against the same model's mode shape.
    ratio_whipple: f64,
    phase_whipple: f64,
}

/// A coasting ride's standard error in part `part` (0 σ, 1 ω) as the gap stage counts it in a
/// campaign (`gap::coasting::correction_cov`'s diagonal): the ride's own `se_ride`, whose
/// share `COASTING_RIDE_SE_FRACTION` of the correction's error scale `scale` is replaced by
/// the common part and the ride's own part beside it.
fn campaign_se(se_ride: f64, scale: f64, part: usize) -> f64 {
    use bikeproc::ride::dynamic::{
        COASTING_BIAS_COMMON_FRACTION as C, COASTING_BIAS_OWN_FRACTION as O,
        COASTING_RIDE_SE_FRACTION as H,
    };
    (se_ride.powi(2) + (C * C + O * O - H[part] * H[part]) * scale * scale).sqrt()
}

fn coasting_rides(
    n: usize,
    first_seed: u64,
    effects: Effects,
    released_mps: (f64, f64),
) -> (Vec<Z>, Vec<String>) {
    let (model, bike) = bikes();
    let out = parallel(n, |i| {
        let seed = first_seed + i as u64;
        let mut rng = seeded(seed);
        let v = rng.range(released_mps.0, released_mps.1);
        let spec = coasting_ride(&mut rng, v, effects.clone());
        let (r, t) = analyse(
            &bike,
            &model,
            &spec,
            |s| Some(noted_reading(&mut rng, s)),
            seed,
        );
        let r = r.map_err(|e| format!("{v:.2}: {e}"))?;
        let at = r.fit.t_ref_s;
        let v_true = t.speed_at(at).ok_or("no truth speed")?;
        let w = t.weave_at(v_true).ok_or("no truth weave")?;
        let (whipple, whipple_shape) = bikeproc::gap::linear::LinearBike::whipple(&bike)
            .weave_and_shape(v_true, w, true)
            .and_then(|(w, s)| Some((w, s?)))
            .unwrap_or((
                nalgebra::Complex::new(f64::NAN, f64::NAN),
                nalgebra::Complex::new(f64::NAN, f64::NAN),
            ));
        let f = &r.fit.weave;
        let k = r.speed.sources.kinematic;
        if std::env::var("BIKEPROC_DEBUG").is_ok() {
            let f = &r.fit;
            println!(
                "v {v_true:.2} a {:.3} win {:.2}-{:.2} tref {:.2} re {:.3}±{:.3} (truth {:.3}, coasting scale {:.3}, drift {:.3}) im {:.3}±{:.3} (truth {:.3}, coasting scale {:.3}) real {:?}",
                r.speed.sources.window_accel_mps2, f.start_s - r.kick_s, f.end_s - r.kick_s, f.t_ref_s - r.kick_s,
                f.weave.re, f.weave.re_se, w.re, r.coasting_error_scale[0], f.weave.re_se_drift,
                f.weave.im, f.weave.im_se, w.im, r.coasting_error_scale[1],
                f.real_modes.iter().map(|m| m.value).collect::<Vec<_>>()
            );
        }
        Ok::<Z, String>(Z {
            speed: (r.speed.speed_mps - v_true) / r.speed.speed_se_mps,
            kinematic: k.map_or(f64::NAN, |k| (k.speed_mps - v_true) / k.se_mps),
            kinematic_rel: k.map_or(f64::NAN, |k| k.speed_mps / v_true - 1.0),
            re: (f.re - w.re) / f.re_se,
            im: (f.im - w.im) / f.im_se,
            re_whipple: (f.re - whipple.re) / f.re_se,
            im_whipple: (f.im - whipple.im) / f.im_se,
            re_campaign: (f.re - whipple.re) / campaign_se(f.re_se, r.coasting_error_scale[0], 0),
            im_campaign: (f.im - whipple.im) / campaign_se(f.im_se, r.coasting_error_scale[1], 1),
            ratio_whipple: (r.fit.shape.ratio.value - whipple_shape.norm()) / r.fit.shape.ratio.se,
            phase_whipple: (r.fit.shape.phase_rad.value - whipple_shape.arg())
                / r.fit.shape.phase_rad.se,
        })
    });
    let mut ok = Vec::new();
    let mut failed = Vec::new();
    for r in out {
        match r {
            Ok(z) => ok.push(z),
            Err(e) => failed.push(e),
        }
    }
    (ok, failed)
}

/// One of the normalized errors of every ride, where it is finite.
fn column(z: &[Z], f: fn(&Z) -> f64) -> Vec<f64> {
    z.iter().map(f).filter(|x| x.is_finite()).collect()
}

/// Prints the normalized errors' means and standard deviations and asserts the bars:
/// speed |mean| < 0.2 and sd in 0.8–1.25; σ and ω sd in 0.8–1.25; at most 2 rides failed; the
/// kinematic speed's |mean| under 1 and sd under 1.25 (its SE holds the tyres' slip).
fn assert_calibrated(z: &[Z], failed: &[String]) {
    println!("failed: {failed:?}");
    let col = |f: fn(&Z) -> f64| column(z, f);
    let (ms, ss) = mean_sd(&col(|z| z.speed));
    let (mk, sk) = mean_sd(&col(|z| z.kinematic));
    let (mkr, skr) = mean_sd(&col(|z| z.kinematic_rel));
    let (mr, sr) = mean_sd(&col(|z| z.re));
    let (mi, si) = mean_sd(&col(|z| z.im));
    println!(
        "speed z: mean {ms:.3} sd {ss:.3}; kinematic z: mean {mk:.3} sd {sk:.3} (relative {mkr:.4} ± {skr:.4}); σ z: mean {mr:.3} sd {sr:.3}; ω z: mean {mi:.3} sd {si:.3} ({} rides)",
        z.len()
    );
    assert!(failed.len() <= 2, "{} rides failed", failed.len());
    assert!(
        ms.abs() < 0.2 && (0.8..=1.25).contains(&ss),
        "speed: mean {ms}, sd {ss}"
    );
    assert!(mk.abs() < 1.0 && sk < 1.25, "kinematic: mean {mk}, sd {sk}");
    assert!((0.8..=1.25).contains(&sr), "σ: sd {sr}");
    assert!((0.8..=1.25).contains(&si), "ω: sd {si}");
}

/// Over 100 coasting rides without `Sync` (no effect beyond the resistances, the speedometer
/// true): the speed where the eigenvalue applies, the noted reading carried by the measured
/// slowing, has normalized errors with a standard deviation in 0.8–1.25 and a mean under 0.2;
/// the weave's real and imaginary parts too (standard deviation 0.8–1.25).
///
/// Against what: the simulator's own linearization carries the coast's resistances (drag and
/// rolling resistance lower the weave by 0.006–0.017 1/s in σ and 0.011–0.021 rad/s in ω at
/// 3.9–5 m/s on two of these rides), the Whipple model that the gap stage predicts with does
/// not. The ride stage takes none of the replayed coasting bias off the eigenvalue and carries
/// a quarter of it as an error (`ride::dynamic::COASTING_BIAS_ERROR_SCALE`): the bias is the
/// opposite way with tyres and damping (the next test), which a real bicycle has. These
/// knife-edge wheels are the far end: σ and ω +0.28 and +0.43 of their errors above the
/// Whipple model (means over these 100 rides; +0.29 and +0.44 with the error the gap stage
/// gives a ride in a campaign, whose coasting part is small at these speeds). The mean must
/// stay within ±0.6 of the errors: a bias shared by a 16-ride campaign adds about 16 × 0.6² ≈
/// 6 to its χ² on 50–60 degrees of freedom, about half of χ²'s own spread (√(2·55) ≈ 10.5).
/// The mode shape against the same model's: |γ/θ| −0.16 and arg γ/θ −0.23 of their errors
/// with the slowing bicycle's own shape change taken off (`ride::dynamic::accel_shape_shift`),
/// −0.31 and −0.28 without it: |γ/θ| within ±0.25 (which that shift decides), arg within ±0.3.
#[test]
fn speed_and_eigenvalue_errors_hold_on_coasting_rides() {
    let (z, failed) = coasting_rides(100, 40_000, Effects::default(), (3.7, 6.3));
    assert_calibrated(&z, &failed);
    let (re, _) = mean_sd(&column(&z, |z| z.re_whipple));
    let (im, _) = mean_sd(&column(&z, |z| z.im_whipple));
    let (re_c, _) = mean_sd(&column(&z, |z| z.re_campaign));
    let (im_c, _) = mean_sd(&column(&z, |z| z.im_campaign));
    let (ratio, _) = mean_sd(&column(&z, |z| z.ratio_whipple));
    let (phase, _) = mean_sd(&column(&z, |z| z.phase_whipple));
    println!(
        "against the Whipple model: σ z mean {re:.3}, ω z mean {im:.3} (in a campaign {re_c:.3}, \
         {im_c:.3}), |γ/θ| {ratio:.3}, arg {phase:.3}"
    );
    assert!(re_c.abs() < 0.6 && im_c.abs() < 0.6, "σ {re_c}, ω {im_c}");
    assert!(
        ratio.abs() < 0.25 && phase.abs() < 0.3,
        "|γ/θ| {ratio}, arg {phase}"
    );
}

/// The same with the realistic effects (steer damping, compliant tyres, the sensors' masses;
/// the speedometer true): tyres slip, so the kinematic speed is only a check, but the noted
/// reading carried and the eigenvalue's errors hold. The coasting correction's other end, the
/// one a real bicycle is at: σ's and ω's mean normalized errors against the simulator's own
/// linearization +0.21 and −0.07, within ±0.35 (each end of a quarter taken off lay about 0.24
/// of the errors from the middle; a mean of 100 normalized errors has a standard error of 0.1).
#[test]
fn speed_and_eigenvalue_errors_hold_with_tyres_and_damping() {
    let effects = Effects {
        speedometer_scale: 1.0,
        ..Effects::realistic()
    };
    let (z, failed) = coasting_rides(100, 50_000, effects, (3.7, 6.3));
    assert_calibrated(&z, &failed);
    let (re, _) = mean_sd(&column(&z, |z| z.re));
    let (im, _) = mean_sd(&column(&z, |z| z.im));
    assert!(re.abs() < 0.35 && im.abs() < 0.35, "σ {re}, ω {im}");
}

/// Prints how many rides were fitted and refused and the σ and ω normalized errors' means
/// and standard deviations; returns the largest |z| of either part.
fn summarize(z: &[Z], failed: &[String]) -> f64 {
    let worst = z
        .iter()
        .map(|z| z.re.abs().max(z.im.abs()))
        .fold(0.0, f64::max);
    let (mr, sr) = mean_sd(&z.iter().map(|z| z.re).collect::<Vec<_>>());
    let (mi, si) = mean_sd(&z.iter().map(|z| z.im).collect::<Vec<_>>());
    println!(
        "{} rides fitted, {} refused; largest |z| {worst:.2}; σ z {mr:.2} ± {sr:.2}, ω z {mi:.2} ± {si:.2}",
        z.len(),
        failed.len()
    );
    worst
}

/// Below the weave speed (released at 3.0–3.5 m/s, the weave growing or near neutral): a ride
/// either is refused, its reason named, or gives an eigenvalue within 3.5 of its standard
/// errors of the truth at its stated speed. Measured: 27 of 30 fitted (4 when the window
/// waited 0.8 s after the kick and stopped at 0.1 rad of roll), σ z −0.64 ± 0.62, ω z
/// 0.46 ± 0.44, largest |z| 2.46 (with the roll alone as the motion's size, 2.5 /s per rad²:
/// −0.64 ± 0.46, 0.40 ± 0.33, 1.77); without the motion's size in the errors the largest was
/// 3.1.
#[test]
fn growing_weaves_are_fitted_in_the_linear_range_or_refused() {
    let (z, failed) = coasting_rides(30, 60_000, Effects::default(), (3.0, 3.5));
    println!("failed: {failed:?}");
    for f in &failed {
        assert!(f.contains("too short") || f.contains("no weave"), "{f}");
    }
    let worst = summarize(&z, &failed);
    assert!(!z.is_empty() && worst < 3.5, "largest |z| {worst}");
}

/// Issue 12, item 4: rides released at 2.8–6.3 m/s (the weave speed of the lab's bicycle is
/// 3.1 m/s, so about a fifth of them below it once the bicycle has slowed to the kick) lose at
/// most 15 % to refusals, with the realistic effects and without; the fitted ones' eigenvalue
/// errors stay within 4 standard errors.
#[test]
fn a_campaign_from_2_8_to_6_3_m_per_s_loses_at_most_15_percent() {
    for (effects, first_seed) in [
        (Effects::default(), 70_000),
        (
            Effects {
                speedometer_scale: 1.0,
                ..Effects::realistic()
            },
            71_000,
        ),
    ] {
        let (z, failed) = coasting_rides(40, first_seed, effects, (2.8, 6.3));
        println!("failed: {failed:?}");
        let worst = summarize(&z, &failed);
        assert!(failed.len() <= 6, "{} of 40 refused", failed.len());
        assert!(worst < 4.0, "largest |z| {worst}");
    }
}

/// The reed switch's speed over many rides at one speed, as a lab rides them: the wheel's
/// magnet stands anywhere at the start, so each ride's pulses fall on other samples and their
/// quantization errors are independent draws. Over 40 rides released at 5.05 m/s (the `Sync`
/// design's sixth ride) the `Sync` speed's normalized error against the simulator's truth at
/// the eigenvalue's time has a mean within ±0.35 (about twice its standard error over 40
/// draws) and a spread of 0.4–1.4. Measured: mean +0.08, spread 0.58 (the standard error's
/// floor of one sample's quantization is conservative at this speed; over 119 rides at
/// 3.8–6.55 m/s the spread was 1.09). With the magnet at the switch at every start the 40
/// rides' pulses fell on nearly the same samples: mean +0.21, spread 0.29, and the test fails.
#[test]
fn sync_speeds_at_one_speed_are_independent_draws() {
    let (model, bike) = bikes();
    let z: Vec<f64> = parallel(40, |i| {
        let seed = 80_000 + i as u64;
        let mut spec = RideSpec::lab(5.05, Effects::default());
        spec.sync = true;
        let (r, t) = analyse(&bike, &model, &spec, |_| None, seed);
        let r = r.ok()?;
        let s = r.speed.sources.sync?;
        let v_true = t.speed_at(r.fit.t_ref_s)?;
        Some((s.speed_mps - v_true) / s.se_mps)
    })
    .into_iter()
    .flatten()
    .collect();
    let (m, sd) = mean_sd(&z);
    println!(
        "{} rides with a Sync speed: z mean {m:.3} sd {sd:.3}",
        z.len()
    );
    assert!(z.len() >= 35, "{} of 40 rides gave a Sync speed", z.len());
    assert!(
        m.abs() < 0.35 && (0.4..=1.4).contains(&sd),
        "mean {m}, sd {sd}"
    );
}

/// Normalized errors of one ride with a steer motor: speed (noted reading to 0.01 m/s,
/// carried), σ, ω, |γ/θ| and arg γ/θ against the linear model of the true bicycle with the
/// motor's inertia and delivered gain at the true speed.
struct MotorZ {
    speed: f64,
    parts: [f64; 4],
    /// The same with the share of the motion's size common to the rides beside each part's
    /// error (`gap::NONLINEAR_COMMON_FACTOR` times the ride's own).
    with_common: [f64; 4],
}

/// `n` rides of the true bicycle carrying a steer motor (reflected inertia `rotor` kg·m²,
/// delivering 0.8 of the torque its roll-rate law T = G (3.5 − v) φ̇ commands, `gain` = G; 0:
/// unpowered), released at `v0`–`v0 + 0.01 n` m/s, no `Sync`, kicked at 12–17.5 N.
fn motor_rides(gain: f64, v0: f64, rotor: f64, n: u64) -> Vec<MotorZ> {
    use bikeproc::gap::effects::{linear_bike, predict_weave, Effect};
    use bikeproc::model::control::{ControllerSpec, SteerControl};
    use bikeproc::sim::ride::{MotorController, SteerMotor};
    const DELIVERED: f64 = 0.8;
    let (model, bike) = bikes();
    let path = root().join("data/lab_bike.toml");
    let law = ControllerSpec {
        description: String::new(),
        speeds_mps: vec![0.0, 3.5, 20.0],
        roll_nm_per_rad: None,
        steer_nm_per_rad: None,
        roll_rate_nms_per_rad: Some(vec![gain * 3.5, 0.0, 0.0]),
        steer_rate_nms_per_rad: None,
    };
    let control = SteerControl::from_spec(&law, &path).unwrap();
    let effects = [Effect::ActuatorGain, Effect::SteerInertia];
    let truth = linear_bike(&bike, &control, &effects, &[DELIVERED, rotor]);
    let out = parallel(n as usize, |i| {
        let i = i as u64;
        let controller = (gain > 0.0).then(|| MotorController {
            speeds_mps: law.speeds_mps.clone(),
            gains: vec![[0.0, 0.0, gain * 3.5, 0.0], [0.0; 4], [0.0; 4]],
            delivered: DELIVERED,
            speed_sensor_scale: 1.0,
            lag_s: 0.0,
        });
        let motor = Effects {
            steer_motor: Some(SteerMotor {
                reflected_inertia_kgm2: rotor,
                controller,
            }),
            ..Effects::default()
        };
        let mut spec = RideSpec::lab(v0 + 0.01 * i as f64, motor);
        spec.sync = false;
        spec.kick.peak_force_n = 12.0 + 0.5 * i as f64;
        let (r, t) = analyse(
            &bike,
            &model,
            &spec,
            |s| Some((s * 100.0).round() / 100.0),
            70_000 + i,
        );
        let r = r.ok()?;
        let v = t.speed_at(r.fit.t_ref_s)?;
        let f = &r.fit;
        let mut o = bikeproc::gap::observe::Observation::from_test("ride", &r);
        o.speed_mps = v;
        let guess = nalgebra::Complex::new(f.weave.re, f.weave.im);
        let (w, shape) = predict_weave(&truth, &effects, &[DELIVERED, rotor], &o, guess, true)?;
        let shape = shape?;
        let delta = [
            f.weave.re - w.re,
            f.weave.im - w.im,
            f.shape.ratio.value - shape.norm(),
            f.shape.phase_rad.value - shape.arg(),
        ];
        let se = [
            f.weave.re_se,
            f.weave.im_se,
            f.shape.ratio.se,
            f.shape.phase_rad.se,
        ];
        let common = bikeproc::ride::dynamic::nonlinear_se(o.motion_sq_rad2, f.shape.ratio.value)
            .map(|x| bikeproc::gap::NONLINEAR_COMMON_FACTOR * x);
        Some(MotorZ {
            speed: (r.speed.speed_mps - v) / r.speed.speed_se_mps,
            parts: std::array::from_fn(|k| delta[k] / se[k]),
            with_common: std::array::from_fn(|k| delta[k] / se[k].hypot(common[k])),
        })
    });
    out.into_iter().flatten().collect()
}

/// The speed of rides with a steer motor's rotor on the fork, whose weave puts 0.3–0.4 rad
/// into the steer: the frame sensor's lever arm is found from its lateral and vertical
/// accelerations (`ride::speed`), not from the forward one, where it cannot be told from the
/// speed the weave gives back to the forward motion. With the arm from the forward
/// acceleration, the normalized speed errors' means were −1.00 (unpowered, 4.0 m/s) and −2.10
/// (G = 1.5, 3.0 m/s) over these 24 rides each; now −0.03 and −0.55, and −0.26 and −0.33
/// without the rotor (as before).
#[test]
fn a_steer_motors_rides_keep_their_speed() {
    for (gain, v0) in [(0.0, 4.0), (1.5, 3.0)] {
        let z = motor_rides(gain, v0, 0.05, 24);
        let (m, s) = mean_sd(&z.iter().map(|z| z.speed).collect::<Vec<_>>());
        println!(
            "G {gain}, {v0} m/s: {} rides, speed z {m:.2} ± {s:.2}",
            z.len()
        );
        assert!(z.len() >= 22, "{} rides of 24", z.len());
        assert!(
            m.abs() < 0.8 && s < 1.5,
            "G {gain}: speed z {m:.2} ± {s:.2}"
        );
    }
}

/// The motion's size in a ride's errors (`ride::dynamic::NONLINEAR_SE_PER_RAD2`): rides with
/// a steer motor (0.05 kg·m², delivered 0.8) under the roll-rate law at G = 1 and 2, released
/// at 3.0–3.3 m/s and kicked at 12–17.5 N, steer up to 0.15–0.32 rad in the window. Before the
/// mode shape's errors held it, |γ/θ| lay a mean +3 to +10 of its errors above the linear
/// model at the true speed and arg −2.6 to −4.7 (10 rides each). The ride's own errors hold
/// the motion's scatter from ride to ride (|γ/θ| now +2.3 at G = 1), the gap stage adds the
/// part the rides share (`gap::NONLINEAR_COMMON_FACTOR`), of which a condition's rides are one
/// draw: with it, each part's mean must stay within 2 (that draw within two of its standard
/// deviations; measured 0.2–1.3).
#[test]
fn a_large_motions_mode_shape_carries_its_size_in_its_errors() {
    for (gain, v0) in [(1.0, 3.0), (2.0, 3.0), (2.0, 3.3)] {
        let z = motor_rides(gain, v0, 0.05, 10);
        assert!(z.len() >= 9, "{} rides of 10", z.len());
        let mean = |f: fn(&MotorZ) -> [f64; 4]| -> Vec<f64> {
            (0..4)
                .map(|k| mean_sd(&z.iter().map(|z| f(z)[k]).collect::<Vec<_>>()).0)
                .collect()
        };
        let (own, with_common) = (mean(|z| z.parts), mean(|z| z.with_common));
        println!(
            "G {gain}, {v0} m/s: σ, ω, |γ/θ|, arg z means {own:.2?}, with the common part {with_common:.2?}"
        );
        for (k, m) in with_common.iter().enumerate() {
            assert!(m.abs() < 2.0, "G {gain}, {v0} m/s: part {k} mean z {m:.2}");
        }
    }
}

/// The speed a reed switch or a speedometer reads of a window: a line through the truth's
/// rolling speed over `[from_s, to_s]` (whose swing at twice the weave's frequency it
/// averages), at `at_s`.
fn window_speed(t: &RideTruth, from_s: f64, to_s: f64, at_s: f64) -> f64 {
    let (a, b) = (
        (from_s * t.rate_hz).round() as usize,
        (to_s * t.rate_hz).round() as usize,
    );
    let pts: Vec<(f64, f64)> = (a..b.min(t.speed_mps.len()))
        .map(|i| (i as f64 / t.rate_hz, t.speed_mps[i]))
        .collect();
    let n = pts.len() as f64;
    let (tm, vm) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let slope = pts.iter().map(|p| (p.0 - tm) * (p.1 - vm)).sum::<f64>()
        / pts.iter().map(|p| (p.0 - tm).powi(2)).sum::<f64>();
    vm + slope * (at_s - tm)
}

/// Issue 29: a hard kick's weave is the small motion's once replayed on the measured
/// bicycle's nonlinear equations (`ride::amplitude`, a diagnostic the ride stage does not
/// apply). Ten knife-edge rides at 4 m/s kicked at 30 N (twice the lab's push; 0.09 rad of
/// lean) of the lab's true bicycle: their fitted ω lay a mean +0.0275 ± 0.0009 1/s above the
/// simulator's own linearization at the window's speed; less the replay's shift, +0.0030 ±
/// 0.0009 (the measured bicycle's nonlinearity is not quite the true one's). At least four
/// fifths of the shift must go.
#[test]
fn a_hard_kicks_weave_is_the_small_motions_once_replayed() {
    let (model, bike) = bikes();
    let nominal = model.nominal();
    let (replayed, linear) = (
        NonlinearBicycle::new(&nominal),
        Canonical::from_benchmark(&nominal),
    );
    let rides = parallel(10, |i| {
        let spec = kicked_with_sync(4.0, 30.0);
        let (r, t) = analyse(&bike, &model, &spec, |_| None, 500 + i as u64);
        let r = r.unwrap();
        let v = window_speed(&t, r.fit.start_s, r.fit.end_s, r.fit.t_ref_s);
        let truth = t.weave_at(v).unwrap();
        let shift = amplitude_shift(&replayed, &linear, &r.fit, r.speed.speed_mps).unwrap();
        (r.fit.weave.im - truth.im, shift[1])
    });
    let raw: Vec<f64> = rides.iter().map(|r| r.0).collect();
    let corrected: Vec<f64> = rides.iter().map(|r| r.0 - r.1).collect();
    let (m, sd) = mean_sd(&corrected);
    let (m_raw, sd_raw) = mean_sd(&raw);
    let (sem, sem_raw) = (sd / 10f64.sqrt(), sd_raw / 10f64.sqrt());
    println!(
        "ω less the truth: {m_raw:+.4} ± {sem_raw:.4} 1/s as fitted, {m:+.4} ± {sem:.4} less the replay's shift"
    );
    assert!(
        m_raw > 5.0 * sem_raw,
        "the hard kick's shift is there: {m_raw:+.4} ± {sem_raw:.4}"
    );
    assert!(m.abs() < 0.2 * m_raw, "corrected: {m:+.4} ± {sem:.4} 1/s");
}

/// The speed carried from the release by the frame sensor's forward acceleration holds no
/// gravity from the rear frame's pitch (`ride::speed::remove_pitch_gravity`: the frame pitches
/// as it leans and steers, and its forward axis picks up g times that pitch). 72 knife-edge
/// rides at 3.8 and 5 m/s kicked at the lab's 15 N (no resistances: the truth's speed changes
/// only as the weave gives its energy back): the integrated slowing less the truth's change
/// between the same instants came out a mean 0.0030 ± 0.0011 m/s low with the pitch's gravity
/// left in, 0.0013 ± 0.0011 without it. The bar: a
/// mean error under a fifth of the slowing's own mean standard error (0.013 m/s), where a
/// bias moves the coverage of ±1 SE by under 1 %.
#[test]
fn the_carried_speed_holds_no_gravity_from_the_frames_pitch() {
    let (model, _) = bikes();
    let measured = model.nominal();
    let mut err = Vec::new();
    let mut se = Vec::new();
    for v0 in [3.8, 5.0] {
        let rides = parallel(36, |i| {
            let spec = RideSpec::lab(v0, Effects::default());
            let (r, t) = analyse(&measured, &model, &spec, Some, 5000 + i as u64);
            let r = r.unwrap();
            let s = r.speed.sources.noted.unwrap().slowing;
            let truth = t.speed_at(s.to_s).unwrap() - t.speed_at(s.from_s).unwrap();
            (s.delta_mps - truth, s.se_mps)
        });
        err.extend(rides.iter().map(|r| r.0));
        se.extend(rides.iter().map(|r| r.1));
    }
    let (m, sd) = mean_sd(&err);
    let sem = sd / (err.len() as f64).sqrt();
    let se_mean = se.iter().sum::<f64>() / se.len() as f64;
    println!("carried speed less the truth's: {m:+.4} ± {sem:.4} m/s; its SE {se_mean:.4} m/s");
    assert!(m.abs() < 0.2 * se_mean, "{m:+.4} ± {sem:.4} m/s");
}

/// A knife-edge ride of the lab's bicycle at `speed_mps` with a reed switch, kicked at
/// `force_n`.
fn kicked_with_sync(speed_mps: f64, force_n: f64) -> RideSpec {
    let mut spec = RideSpec::lab(speed_mps, Effects::default());
    spec.sync = true;
    spec.kick.peak_force_n = force_n;
    spec
}

/// Issue 29: a faint weave's window runs on into the quiet (`ride::dynamic::fit_window`). A
/// kick of half the lab's (7.5 N) at 6 m/s leaves the weave under the gyros' noise 1.5 s
/// later, where the catch is found; the window from 0.8 s after the kick was then too short
/// and the ride went to the early window, in the castor's tail, with σ a mean 0.80 of its
/// standard error low over these 40 rides (8 of 40 refused at 6.5 m/s). Now the window runs
/// on past a catch the weave had sunk into the noise before: σ's mean normalized error +0.25
/// (a calibrated fit's mean over 40 rides has a spread of 0.16; the bar is 2.5 of it).
#[test]
fn a_faint_weaves_window_runs_on_into_the_quiet() {
    let (model, bike) = bikes();
    let rides = parallel(40, |i| {
        let spec = kicked_with_sync(6.0, 7.5);
        let (r, t) = analyse(&bike, &model, &spec, Some, 9000 + i as u64);
        let r = r.ok()?;
        let v = window_speed(&t, r.fit.start_s, r.fit.end_s, r.fit.t_ref_s);
        let truth = t.weave_at(v)?;
        let early = r.fit.start_s - r.kick_s < 0.5;
        Some(((r.fit.weave.re - truth.re) / r.fit.weave.re_se, early))
    });
    let done: Vec<(f64, bool)> = rides.into_iter().flatten().collect();
    let z: Vec<f64> = done.iter().map(|r| r.0).collect();
    let early = done.iter().filter(|r| r.1).count();
    let (m, sd) = mean_sd(&z);
    println!(
        "{} of 40 rides, {early} early windows; σ's normalized error {m:+.2} (sd {sd:.2})",
        z.len()
    );
    assert_eq!(z.len(), 40, "every ride analysed");
    assert_eq!(early, 0, "no window in the castor's tail");
    assert!(m.abs() < 0.4, "σ's mean normalized error {m:+.2}");
}

/// The other side of `a_faint_weaves_window_runs_on_into_the_quiet`: a weave stopped by a hand
/// while still seen is not run on past the catch into the held bicycle's samples. 30 rides at
/// 5.5 m/s kicked at 15 N and caught 1.6 s after the kick: every one takes the window before
/// the catch (the early one); judged by a fit that ran on, the weave looked dead at the catch
/// and that fit's σ came out 1.30 of its (1.8 1/s) error low on average; now −0.59 of 0.03.
#[test]
fn a_weave_a_hand_stops_is_not_run_on() {
    let (model, bike) = bikes();
    let rides = parallel(30, |i| {
        let mut spec = kicked_with_sync(5.5, 15.0);
        spec.coast_s = spec.kick.after_release_s + 1.6;
        let (r, _) = analyse(&bike, &model, &spec, Some, 9500 + i as u64);
        r.ok().map(|r| r.fit.end_s <= r.kick_s + 1.6)
    });
    let done: Vec<bool> = rides.into_iter().flatten().collect();
    println!("{} of 30 analysed", done.len());
    assert!(done.len() >= 27, "{} of 30 analysed", done.len());
    assert!(
        done.iter().all(|&before| before),
        "a window ran past the catch"
    );
}
