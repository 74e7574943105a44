//! The campaign's observations and their residuals. In: each analysed ride (a log's dynamic
//! test or a CSV's free decay, [`crate::ride::dynamic`]). Out: one [`Observation`] per ride
//! (its weave, mode shape and speed with their standard errors), the names of the rides that
//! gave none, and the residual types the diagnosis fills in ([`RideResidual`], by speed band
//! [`BandResidual`]).

use super::linear;
use crate::ride::dynamic::{DynamicTest, SpeedSource};
use nalgebra::Complex;

/// One ride's experimental weave, as the dynamic test gave it.
#[derive(Debug, Clone)]
pub struct Observation {
    pub ride: String,
    /// The speed where the eigenvalue applies (m/s): the `Sync` speed, the noted reading plus
    /// `speed_correction_mps`, or the kinematic speed.
    pub speed_mps: f64,
    /// For a noted reading: the slowing from the release to where the eigenvalue applies
    /// (m/s, negative), measured by the ride's frame sensor
    /// ([`crate::ride::speed::slowing`]); 0 otherwise.
    pub speed_correction_mps: f64,
    pub speed_se_mps: f64,
    pub speed_source: SpeedSource,
    /// Every source of the speed the ride's log offers, compared.
    pub speed_sources: crate::ride::speed::SpeedSources,
    pub weave: Complex<f64>,
    pub re_se: f64,
    pub im_se: f64,
    /// `re_se`, `im_se` were the fit's residuals white ([`crate::ride::modal::Eigenvalue::se_if_white`]):
    /// the errors before residual correlation was allowed for, for the between-kick scatter's
    /// comparison ([`ConditionScatter::q_white`]).
    pub se_if_white: [f64; 2],
    /// The weave's mode shape |γ/θ| and arg(γ/θ) (rad), with the fit's standard errors.
    pub shape_ratio: crate::fit::Estimate,
    pub shape_phase_rad: crate::fit::Estimate,
    /// The fitted window's time (s), roll and steer (rad), for the time-series check.
    pub window: Option<[Vec<f64>; 3]>,
    /// The window's length (s) and the bicycle's forward acceleration over it (m/s²).
    pub window_s: f64,
    pub window_accel_mps2: f64,
    /// The correction taken off a coasting ride's fit for its changing speed (`[re, im]` in
    /// 1/s, `[|γ/θ|, arg]`; [`crate::ride::dynamic::DynamicTest`]), 0 otherwise.
    pub coasting_bias: [f64; 4],
    /// The size that correction's error is counted in (same layout,
    /// [`crate::ride::dynamic::CoastingCorrection::error_scale`]), 0 at constant speed: its
    /// error is mostly common to the campaign's rides.
    pub coasting_error_scale: [f64; 4],
    /// The window the ride stage replayed for `coasting_bias`, on a ride whose speed changed
    /// over it ([`super::coasting`] replays each candidate's bicycle on it).
    pub coasting: Option<crate::ride::dynamic::CoastingWindow>,
    /// The speed the lab set for the ride (a treadmill's setting given in the manifest), when
    /// there is one: a condition's rides of one set speed repeat one set-up. `None` for a
    /// coasting ride, whose noted reading is where it was released, not a set-up.
    pub set_speed_mps: Option<f64>,
    /// The motion's size over the window ([`crate::ride::dynamic::motion_size_rad2`]), 0 where
    /// the window's angles are not at hand: the linear model's eigenvalue and mode shape are
    /// the small motion's; a larger one's differ by about this times coefficients the rides
    /// share ([`super::NONLINEAR_COMMON_FACTOR`]).
    pub motion_sq_rad2: f64,
    /// The weave's steer amplitude where its eigenvalue applies (rad,
    /// [`crate::ride::modal::ModalFit::weave_steer_amplitude_rad`]): where a dry steer
    /// friction's equivalent damping is taken ([`super::effects::for_ride`]). `None` for a
    /// decay fitted without a steer angle's shape.
    pub steer_amplitude_rad: Option<f64>,
}

impl Observation {
    pub fn from_test(ride: &str, t: &DynamicTest) -> Observation {
        Observation {
            ride: ride.to_string(),
            speed_mps: t.speed.speed_mps,
            speed_correction_mps: match (t.speed.source, &t.speed.sources.noted) {
                (SpeedSource::Noted, Some(n)) => n.slowing.delta_mps,
                _ => 0.0,
            },
            speed_se_mps: t.speed.speed_se_mps,
            speed_source: t.speed.source,
            speed_sources: t.speed.sources.clone(),
            weave: Complex::new(t.fit.weave.re, t.fit.weave.im),
            re_se: t.fit.weave.re_se,
            im_se: t.fit.weave.im_se,
            se_if_white: t.fit.weave.se_if_white(),
            shape_ratio: t.fit.shape.ratio,
            shape_phase_rad: t.fit.shape.phase_rad,
            window_s: t.fit.end_s - t.fit.start_s,
            window_accel_mps2: t.speed.sources.window_accel_mps2,
            coasting_bias: t.coasting_bias,
            coasting_error_scale: t.coasting_error_scale,
            coasting: t.coasting,
            set_speed_mps: None,
            motion_sq_rad2: crate::ride::dynamic::motion_size_rad2(
                t.trace.iter().copied(),
                t.fit.start_s,
                t.fit.end_s,
            ),
            window: {
                let rows: Vec<&[f64; 3]> = t
                    .trace
                    .iter()
                    .filter(|r| r[0] >= t.fit.start_s && r[0] <= t.fit.end_s)
                    .collect();
                (rows.len() >= 40).then(|| [0, 1, 2].map(|k| rows.iter().map(|r| r[k]).collect()))
            },
            steer_amplitude_rad: Some(t.fit.weave_steer_amplitude_rad()),
        }
    }
}

impl Observation {
    /// A CSV ride's free decay ([`crate::ride::csv`]): its eigenvalue, its mode shape when the
    /// file has roll and steer angles (and their fit agrees with the roll rate's), its speed
    /// from the wheel-speed column or the reading given; `None` without a speed.
    pub fn from_decay(ride: &str, d: &crate::ride::csv::DecaySummary) -> Option<Observation> {
        let (speed, source) = (d.speed_mps?, d.speed_source?);
        let w = &d.decay.weave;
        let none = crate::fit::Estimate {
            value: f64::NAN,
            se: f64::NAN,
        };
        let (a, b) = d.decay.window_s;
        Some(Observation {
            ride: ride.to_string(),
            speed_mps: speed.value,
            speed_correction_mps: 0.0,
            speed_se_mps: speed.se,
            speed_source: source,
            speed_sources: crate::ride::speed::SpeedSources {
                at_s: 0.5 * (a + b),
                noted: None,
                sync: None,
                kinematic: None,
                window_accel_mps2: 0.0,
                // The wheel against the speed given, beyond the disagreement's bar.
                disagreements: d
                    .given_beside
                    .filter(|b| b.z.abs() > crate::ride::speed::DISAGREEMENT_SIGMAS)
                    .map(|b| b.text())
                    .into_iter()
                    .collect(),
                given_beside_wheel: d.given_beside,
            },
            weave: Complex::new(w.re, w.im),
            re_se: w.re_se,
            im_se: w.im_se,
            se_if_white: w.se_if_white(),
            shape_ratio: d.decay.shape.map_or(none, |s| s.ratio),
            shape_phase_rad: d.decay.shape.map_or(none, |s| s.phase_rad),
            window: None,
            window_s: b - a,
            window_accel_mps2: 0.0,
            coasting_bias: [0.0; 4],
            coasting_error_scale: [0.0; 4],
            coasting: None,
            set_speed_mps: d.set_speed_mps,
            motion_sq_rad2: 0.0,
            steer_amplitude_rad: d.decay.steer_amplitude_rad,
        })
    }
}

/// A ride's residual against the unextended model.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RideResidual {
    pub ride: String,
    /// In a study, the ride's condition.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub condition: Option<String>,
    pub speed_mps: f64,
    /// The correction of a noted speed for the slowing before the window (m/s; 0 for `Sync`).
    pub speed_correction_mps: f64,
    pub speed_se_mps: f64,
    /// The source the speed is taken from, and every source the log offers, compared.
    pub speed_source: SpeedSource,
    pub speed_sources: crate::ride::speed::SpeedSources,
    /// Experiment − model (1/s), real and imaginary parts.
    pub re: f64,
    pub im: f64,
    /// Combined standard errors (experiment, speed and model).
    pub re_se: f64,
    pub im_se: f64,
    pub re_z: f64,
    pub im_z: f64,
    /// The mode shape: |γ/θ| and its phase (rad), experiment − model, with their combined
    /// standard errors (the fit's with its floor, the speed's, the model's from the
    /// parameters; the fit's alone when the shape is left out of the diagnosis).
    pub shape_ratio: f64,
    pub shape_ratio_se: f64,
    pub shape_ratio_z: f64,
    pub shape_phase_rad: f64,
    pub shape_phase_se_rad: f64,
    pub shape_phase_z: f64,
}

impl RideResidual {
    /// Ride `o`'s residual (`condition` its study's condition): `values` experiment − model and
    /// their combined standard errors `se`, each `[re, im, |γ/θ|, arg γ/θ]`, the z's their
    /// ratios.
    pub fn of(o: &Observation, condition: Option<String>, values: [f64; 4], se: [f64; 4]) -> Self {
        RideResidual {
            ride: o.ride.clone(),
            condition,
            speed_mps: o.speed_mps,
            speed_correction_mps: o.speed_correction_mps,
            speed_se_mps: o.speed_se_mps,
            speed_source: o.speed_source,
            speed_sources: o.speed_sources.clone(),
            re: 0.0,
            im: 0.0,
            re_se: 0.0,
            im_se: 0.0,
            re_z: 0.0,
            im_z: 0.0,
            shape_ratio: 0.0,
            shape_ratio_se: 0.0,
            shape_ratio_z: 0.0,
            shape_phase_rad: 0.0,
            shape_phase_se_rad: 0.0,
            shape_phase_z: 0.0,
        }
        .with(values, se)
    }

    /// The same ride's residual with other `values` and standard errors `se` (as in
    /// [`RideResidual::of`]): a candidate's, after the ride's before it.
    pub fn with(&self, values: [f64; 4], se: [f64; 4]) -> Self {
        let [re, im, ratio, phase] = values;
        let [re_se, im_se, ratio_se, phase_se] = se;
        RideResidual {
            re,
            im,
            re_se,
            im_se,
            re_z: re / re_se,
            im_z: im / im_se,
            shape_ratio: ratio,
            shape_ratio_se: ratio_se,
            shape_ratio_z: ratio / ratio_se,
            shape_phase_rad: phase,
            shape_phase_se_rad: phase_se,
            shape_phase_z: phase / phase_se,
            ..self.clone()
        }
    }
}

/// The residual of a ride's mode shape against `bike` at its weave: (Δ|γ/θ|, Δarg) with the
/// phase difference wrapped to ±π; NaN when the model has no shape there.
pub(super) fn shape_residual(
    bike: &linear::LinearBike,
    o: &Observation,
    speed_mps: f64,
    weave: Complex<f64>,
) -> (f64, f64) {
    match bike.mode_shape(speed_mps, weave) {
        Some(m) => (
            o.shape_ratio.value - m.norm(),
            crate::signal::wrap_pi(o.shape_phase_rad.value - m.arg()),
        ),
        None => (f64::NAN, f64::NAN),
    }
}

/// The residuals of the rides in one speed band, weighted means.
#[derive(Debug, Clone, serde::Serialize)]
pub struct BandResidual {
    pub speeds_mps: [f64; 2],
    pub rides: usize,
    pub re: crate::fit::Estimate,
    pub im: crate::fit::Estimate,
}

/// `n` rides from `base`'s taken over and over: copy k of each `k · step_mps` faster and named
/// `{ride}_{k}`, its coasting window moved with it where `move_windows`. A large campaign from
/// a small one, for the diagnosis's cost and agreement at many rides (benches, tests).
pub fn copies(
    base: &[Observation],
    n: usize,
    step_mps: f64,
    move_windows: bool,
) -> Vec<Observation> {
    (0..n)
        .map(|k| {
            let copy = k / base.len();
            let mut o = base[k % base.len()].clone();
            let dv = step_mps * copy as f64;
            o.ride = format!("{}_{copy}", o.ride);
            o.speed_mps += dv;
            if let Some(w) = o.coasting.as_mut().filter(|_| move_windows) {
                w.speed_mps += dv;
            }
            o
        })
        .collect()
}

/// A campaign's analysed rides as observations, and the names and reasons of those that gave
/// none (a CSV decay without a speed, or whose fit resolves no weave).
pub fn observations(
    results: &[crate::ride::dynamic::CampaignRide],
) -> (Vec<Observation>, Vec<String>) {
    use crate::ride::dynamic::Analysed;
    let mut rides = Vec::new();
    let mut failed = Vec::new();
    for r in results {
        let name = &r.name;
        match &r.result {
            Ok(Analysed::Log(t)) => rides.push(Observation::from_test(name, t)),
            // A decay whose fit resolves no oscillation observes no weave: it never enters.
            Ok(Analysed::Csv(d)) if !d.decay.resolves_weave() => failed.push(format!(
                "{name}: no weave resolved (ω {:.3} ± {:.3} rad/s: its standard error exceeds it)",
                d.decay.weave.im, d.decay.weave.im_se
            )),
            Ok(Analysed::Csv(d)) => match Observation::from_decay(name, d) {
                Some(o) => rides.push(o),
                None => failed.push(format!("{name}: no speed")),
            },
            Err(e) => failed.push(format!("{name}: {e}")),
        }
    }
    (rides, failed)
}

/// The scatter between repeated kicks of one set-up beyond their fits' errors (a random
/// effect per kick), estimated from the repeats.
#[derive(Debug, Clone, serde::Serialize)]
pub struct BetweenKickScatter {
    /// Its standard deviation per part of a ride's residual: the eigenvalue's real and
    /// imaginary parts (1/s), and with the shape |γ/θ| and its phase (rad).
    pub per_part: Vec<f64>,
    /// The set-ups repeated (a condition's rides at one set speed, at least two) and their
    /// kicks.
    pub setups: usize,
    pub kicks: usize,
    /// Cochran's Q of the eigenvalue's parts (summed over them) against its degrees of freedom,
    /// and its p: the repeats agree within their errors when p is not small.
    pub q: f64,
    pub q_dof: usize,
    pub p_value: f64,
    /// The same Q and its degrees of freedom per condition with a repeated set-up (by the
    /// condition's index): how far each condition's repeats scatter beyond their fits'
    /// errors (Q/dof near 1 when they do not).
    pub by_condition: Vec<ConditionScatter>,
}

/// Cochran's Q of one condition's repeated kicks ([`BetweenKickScatter::by_condition`]).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ConditionScatter {
    pub condition: usize,
    pub q: f64,
    pub q_dof: usize,
    /// The same Q with the fits' errors as were their residuals white
    /// ([`Observation::se_if_white`]; NaN until [`with_white_errors`] sets it): how much of the
    /// scatter the residuals' correlation accounts for.
    pub q_white: f64,
}

/// `scatter`'s per-condition Q beside the same Q computed with `white_se` as the fits'
/// errors ([`ConditionScatter::q_white`]).
pub fn with_white_errors(
    scatter: &mut BetweenKickScatter,
    rides: &[Observation],
    ride_condition: &[usize],
    parts: usize,
    white_se: &dyn Fn(&Observation) -> [f64; 4],
) {
    let white = between_kick_scatter(rides, ride_condition, parts, white_se);
    for c in &mut scatter.by_condition {
        c.q_white = white
            .as_ref()
            .and_then(|w| w.by_condition.iter().find(|w| w.condition == c.condition))
            .map_or(f64::NAN, |w| w.q);
    }
}

/// The between-kick scatter of a campaign's (or study's) repeated kicks: rides of one condition
/// at one set speed (a treadmill's setting, [`Observation::set_speed_mps`]) form a set-up; per part of the residual, Cochran's
/// Q = Σ wᵢ (xᵢ − x̄_w)² over each set-up's kicks (wᵢ = 1/seᵢ², `fit_se` the fit's errors) and
/// the DerSimonian–Laird moment estimate τ² = max(0, (Q − df)/(Σw − Σw²/Σw)) pooled over the
/// set-ups (DerSimonian & Laird 1986). `None` without a repeated set-up, or when the repeats
/// agree within their errors (every τ zero).
pub fn between_kick_scatter(
    rides: &[Observation],
    ride_condition: &[usize],
    parts: usize,
    fit_se: &dyn Fn(&Observation) -> [f64; 4],
) -> Option<BetweenKickScatter> {
    let mut setups: Vec<Vec<usize>> = Vec::new();
    for i in 0..rides.len() {
        let Some(set) = rides[i].set_speed_mps else {
            continue;
        };
        let same = |j: usize| {
            ride_condition[j] == ride_condition[i]
                && rides[j].set_speed_mps.map(f64::to_bits) == Some(set.to_bits())
        };
        match setups.iter_mut().find(|s| same(s[0])) {
            Some(s) => s.push(i),
            None => setups.push(vec![i]),
        }
    }
    setups.retain(|s| s.len() > 1);
    if setups.is_empty() {
        return None;
    }
    let value = |o: &Observation, a: usize| -> f64 {
        match a {
            0 => o.weave.re,
            1 => o.weave.im,
            2 => o.shape_ratio.value,
            _ => o.shape_phase_rad.value,
        }
    };
    let (mut q_eig, mut dof) = (0.0, 0usize);
    let mut by_condition: Vec<ConditionScatter> = Vec::new();
    let per_part: Vec<f64> = (0..parts)
        .map(|a| {
            let (mut q, mut df, mut c) = (0.0, 0usize, 0.0);
            for s in &setups {
                // The kicks that measured this part (the shape needs both angles).
                let s: Vec<usize> = s
                    .iter()
                    .copied()
                    .filter(|&i| {
                        let se = fit_se(&rides[i])[a];
                        value(&rides[i], a).is_finite() && se.is_finite() && se > 0.0
                    })
                    .collect();
                if s.len() < 2 {
                    continue;
                }
                let w: Vec<f64> = s.iter().map(|&i| fit_se(&rides[i])[a].powi(-2)).collect();
                let sw: f64 = w.iter().sum();
                let mean = s
                    .iter()
                    .zip(&w)
                    .map(|(&i, wi)| wi * value(&rides[i], a))
                    .sum::<f64>()
                    / sw;
                let q_setup = s
                    .iter()
                    .zip(&w)
                    .map(|(&i, wi)| {
                        let mut dx = value(&rides[i], a) - mean;
                        if a == 3 {
                            dx = crate::signal::wrap_pi(dx);
                        }
                        wi * dx * dx
                    })
                    .sum::<f64>();
                q += q_setup;
                df += s.len() - 1;
                if a < 2 {
                    let condition = ride_condition[s[0]];
                    match by_condition.iter_mut().find(|c| c.condition == condition) {
                        Some(c) => {
                            c.q += q_setup;
                            c.q_dof += s.len() - 1;
                        }
                        None => by_condition.push(ConditionScatter {
                            condition,
                            q: q_setup,
                            q_dof: s.len() - 1,
                            q_white: f64::NAN,
                        }),
                    }
                }
                c += sw - w.iter().map(|x| x * x).sum::<f64>() / sw;
            }
            if a < 2 {
                q_eig += q;
                dof += df;
            }
            let tau2 = ((q - df as f64) / c).max(0.0);
            if tau2.is_finite() {
                tau2.sqrt()
            } else {
                0.0
            }
        })
        .collect();
    if per_part.iter().all(|&t| t == 0.0) {
        return None;
    }
    Some(BetweenKickScatter {
        setups: setups.len(),
        kicks: setups.iter().map(Vec::len).sum(),
        q: q_eig,
        q_dof: dof,
        p_value: crate::stats::chi2_sf(q_eig, dof),
        per_part,
        by_condition,
    })
}

/// Weighted mean residuals in 1 m/s bands.
pub(super) fn speed_bands(res: &[RideResidual]) -> Vec<BandResidual> {
    let mut bands: Vec<BandResidual> = Vec::new();
    let mut keys: Vec<i64> = res.iter().map(|r| r.speed_mps.floor() as i64).collect();
    keys.sort_unstable();
    keys.dedup();
    for k in keys {
        let inside: Vec<&RideResidual> = res
            .iter()
            .filter(|r| r.speed_mps.floor() as i64 == k)
            .collect();
        bands.push(BandResidual {
            speeds_mps: [k as f64, k as f64 + 1.0],
            rides: inside.len(),
            re: weighted_mean(inside.iter().map(|r| (r.re, r.re_se))),
            im: weighted_mean(inside.iter().map(|r| (r.im, r.im_se))),
        });
    }
    bands
}

/// The inverse-variance weighted mean of `(value, se)` pairs, with its standard error.
pub fn weighted_mean(xs: impl Iterator<Item = (f64, f64)>) -> crate::fit::Estimate {
    let (mut sw, mut swx) = (0.0, 0.0);
    for (x, se) in xs {
        let w = 1.0 / (se * se);
        sw += w;
        swx += w * x;
    }
    crate::fit::Estimate {
        value: swx / sw,
        se: 1.0 / sw.sqrt(),
    }
}

/// Where each ride's parts lie in the residual vector: 2 (the eigenvalue's real and imaginary
/// parts) or 4 (and the mode shape's |γ/θ| and phase) per ride, in the rides' order. Rides fitted
/// from the roll rate alone give the eigenvalue only; rides with both angles give the shape too:
/// both enter one likelihood.
#[derive(Debug, Clone)]
pub struct Parts {
    per_ride: Vec<usize>,
    start: Vec<usize>,
    total: usize,
}

impl Parts {
    /// The parts of rides with `per_ride` parts each (2 or 4).
    pub fn new(per_ride: Vec<usize>) -> Parts {
        let mut start = Vec::with_capacity(per_ride.len());
        let mut total = 0;
        for &p in &per_ride {
            start.push(total);
            total += p;
        }
        Parts {
            per_ride,
            start,
            total,
        }
    }

    /// Ride `i`'s number of parts …
    pub fn of(&self, i: usize) -> usize {
        self.per_ride[i]
    }

    /// … and where they start.
    pub fn start(&self, i: usize) -> usize {
        self.start[i]
    }

    /// Every ride's parts.
    pub fn total(&self) -> usize {
        self.total
    }

    /// The parts of `rides`.
    pub fn count(&self, rides: &[usize]) -> usize {
        rides.iter().map(|&i| self.per_ride[i]).sum()
    }

    /// The most parts of any ride (4 when some ride gives its mode shape).
    pub fn most(&self) -> usize {
        self.per_ride.iter().copied().max().unwrap_or(2)
    }
}
