//! Inertia stage: pendulum-test folders → the bar's stiffness, moments of inertia and inertia
//! tensors, every one with its standard error.
//!
//! In: a test folder (its [`manifest::Manifest`] and logs). Each log goes through the
//! measurement core ([`crate::signal`], [`crate::fit`]) for its natural frequency; repeats are
//! averaged. Out: [`BarCalibration`] (eqs. 64–67), [`TorsionResult`] (eqs. 63, 69–74) or
//! [`CompoundResult`] (eqs. 76–78, 83). Standard errors come from the frequency fits, the
//! masses, distances and axis angles written in the manifest, and the calibration, propagated
//! together ([`crate::uncertainty::propagate`]).
//!
//! [`measured`] takes another lab's raw measurements (BicycleParameters' `*Measured.txt`) to
//! benchmark parameters on the same pendulum equations.

pub mod bike;
use crate::read::manifest;
pub mod measured;
pub mod text;

use crate::fit::{self, FitError, FitOptions};
use crate::read::log::ReadOptions;
use crate::signal::{self, Extract, SignalError};
use crate::uncertainty::{propagate, standard_errors, Inputs, Measured};
use manifest::{Kind, Manifest, ManifestError, Moment, Test};
use nalgebra::{DMatrix, DVector, Matrix2, SymmetricEigen};
use serde::Serialize;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// Standard gravity (m/s²), as the lab used it (eq. 92).
pub const GRAVITY_MPS2: f64 = 9.81;

/// Errors of the inertia stage.
#[derive(Debug, thiserror::Error)]
pub enum InertiaError {
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    #[error(transparent)]
    Signal(#[from] SignalError),
    #[error("{log}: {source}")]
    Fit { log: PathBuf, source: FitError },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
}

/// Why a set of orientations gives no tensor ([`TorsionResult::tensor_for`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TensorError {
    #[error("no orientation \"{0}\"")]
    NoOrientation(String),
    #[error("{0} orientation(s): the tensor needs three, or two with I_xz = −I_zz (eq. 74)")]
    TooFew(usize),
    /// The orientations' names, joined.
    #[error("the axes of orientations {0} do not determine the tensor")]
    Undetermined(String),
}

// ---------------------------------------------------------------------------------------------
// The physics, one equation each.

/// Inertia of a solid cylinder about a diameter through its centre, `m(3R² + L²)/12` (eq. 65).
pub fn rod_inertia(mass_kg: f64, diameter_m: f64, length_m: f64) -> f64 {
    let r = diameter_m / 2.0;
    mass_kg * (3.0 * r * r + length_m * length_m) / 12.0
}

/// Torsional stiffness of a round bar, `G·I_p/L` with `I_p = π d⁴/32` (eq. 64).
pub fn torsion_bar_theory_stiffness(shear_modulus_pa: f64, diameter_m: f64, length_m: f64) -> f64 {
    shear_modulus_pa * PI * diameter_m.powi(4) / 32.0 / length_m
}

/// Stiffness of a torsional pendulum from a known inertia and its natural frequency,
/// `k = 4π² f² I` (eq. 67).
pub fn torsional_pendulum_stiffness(inertia_kgm2: f64, freq_hz: f64) -> f64 {
    4.0 * PI * PI * freq_hz * freq_hz * inertia_kgm2
}

/// Inertia of a torsional pendulum about the bar's axis, `I = k / (2πf)²` (eqs. 63, 70).
pub fn torsional_pendulum_inertia(stiffness_nm_per_rad: f64, freq_hz: f64) -> f64 {
    stiffness_nm_per_rad / (2.0 * PI * freq_hz).powi(2)
}

/// Inertia of a compound pendulum about its pivot, `I' = m g L / (2πf)²` (eqs. 76–77).
pub fn compound_pendulum_inertia(
    mass_kg: f64,
    pivot_to_cg_m: f64,
    freq_hz: f64,
    gravity_mps2: f64,
) -> f64 {
    mass_kg * gravity_mps2 * pivot_to_cg_m / (2.0 * PI * freq_hz).powi(2)
}

/// Parallel axis (Steiner): the inertia about a parallel axis through the centre of gravity of
/// a mass `m` at distance `d`, `I − m d²` (eqs. 71, 72, 78).
pub fn parallel_axis_removed(inertia_kgm2: f64, mass_kg: f64, distance_m: f64) -> f64 {
    inertia_kgm2 - mass_kg * distance_m * distance_m
}

/// The row of eq. 69 for an axis `(e_x, 0, e_z)` of a body symmetric about xz:
/// `eᵀIe = e_x² I_xx + 2 e_x e_z I_xz + e_z² I_zz`.
pub fn tensor_row(axis: [f64; 3]) -> [f64; 3] {
    [
        axis[0] * axis[0],
        2.0 * axis[0] * axis[2],
        axis[2] * axis[2],
    ]
}

/// The axis turned by `delta_rad` about y (an error in the angle read off a photograph).
fn turn_axis(axis: [f64; 3], delta_rad: f64) -> [f64; 3] {
    let (s, c) = delta_rad.sin_cos();
    [
        axis[0] * c + axis[2] * s,
        axis[1],
        -axis[0] * s + axis[2] * c,
    ]
}

/// Solves eq. 69 by weighted least squares for `(I_xx, I_xz, I_zz)` (exact with three axes);
/// with `handlebar_constraint`, `I_xz = −I_zz` (eq. 74) leaves two unknowns. Returns the three
/// entries, or `None` when the axes do not determine them.
pub fn solve_tensor(
    axes: &[[f64; 3]],
    moments: &[f64],
    weights: &[f64],
    handlebar_constraint: bool,
) -> Option<[f64; 3]> {
    let rows: Vec<[f64; 3]> = axes.iter().map(|a| tensor_row(*a)).collect();
    let ncol = if handlebar_constraint { 2 } else { 3 };
    let mut a = DMatrix::zeros(rows.len(), ncol);
    let mut b = DVector::zeros(rows.len());
    for (i, r) in rows.iter().enumerate() {
        let w = weights[i].sqrt();
        if handlebar_constraint {
            a[(i, 0)] = w * r[0];
            a[(i, 1)] = w * (r[2] - r[1]);
        } else {
            for c in 0..3 {
                a[(i, c)] = w * r[c];
            }
        }
        b[i] = w * moments[i];
    }
    if rows.len() < ncol {
        return None;
    }
    if !(a.iter().all(|x| x.is_finite()) && b.iter().all(|x| x.is_finite())) {
        return None;
    }
    let x = a
        .try_svd(
            true,
            true,
            f64::EPSILON,
            crate::MAX_DECOMPOSITION_ITERATIONS,
        )?
        .solve(&b, 1e-12)
        .ok()?;
    Some(if handlebar_constraint {
        [x[0], -x[1], x[1]]
    } else {
        [x[0], x[1], x[2]]
    })
}

/// Condition number of the (weighted) design matrix of eq. 69: how strongly errors in the
/// measured moments are amplified into the tensor.
pub fn design_condition(axes: &[[f64; 3]], handlebar_constraint: bool) -> f64 {
    let ncol = if handlebar_constraint { 2 } else { 3 };
    let mut a = DMatrix::zeros(axes.len(), ncol);
    for (i, ax) in axes.iter().enumerate() {
        let r = tensor_row(*ax);
        if handlebar_constraint {
            a[(i, 0)] = r[0];
            a[(i, 1)] = r[2] - r[1];
        } else {
            for c in 0..3 {
                a[(i, c)] = r[c];
            }
        }
    }
    let Some(sv) = a
        .iter()
        .all(|x| x.is_finite())
        .then(|| {
            a.try_svd(
                false,
                false,
                f64::EPSILON,
                crate::MAX_DECOMPOSITION_ITERATIONS,
            )
        })
        .flatten()
        .map(|s| s.singular_values)
    else {
        return f64::INFINITY;
    };
    let (mx, mn) = sv
        .iter()
        .fold((0.0f64, f64::INFINITY), |(a, b), &s| (a.max(s), b.min(s)));
    if mn > 0.0 {
        mx / mn
    } else {
        f64::INFINITY
    }
}

// ---------------------------------------------------------------------------------------------
// Frequencies of a test's repeats.

/// One log of a test.
#[derive(Debug, Clone, Serialize)]
pub struct Repeat {
    pub log: PathBuf,
    /// Natural frequency (Hz), corrected to small amplitude for a compound pendulum.
    pub freq_hz: f64,
    pub freq_se_hz: f64,
    pub damping_ratio: f64,
    /// Release amplitude at the segment's start (rad), when the signal is an angle.
    pub amplitude_rad: Option<f64>,
    pub segment_s: [f64; 2],
    /// Far from the other repeats: left out of the mean.
    pub outlier: bool,
}

/// A test's frequency from its repeats.
#[derive(Debug, Clone, Serialize)]
pub struct TestFrequency {
    pub name: String,
    pub freq_hz: f64,
    pub freq_se_hz: f64,
    /// Relative standard deviation of the repeats (the lab's spread).
    pub repeat_spread: f64,
    pub repeats: Vec<Repeat>,
    #[serde(skip)]
    pub first_fit: Option<(signal::Signal, fit::Oscillation)>,
}

impl TestFrequency {
    pub fn freq(&self) -> Measured {
        Measured::new(self.freq_hz, self.freq_se_hz)
    }
}

/// The amplitude correction of a pendulum's period: `T(θ₀) ≈ T₀ (1 + θ₀²/16)` to second order,
/// with θ₀² the decaying amplitude's square averaged with the weights that the frequency fit
/// gives each sample (`A(t)² (t − t̄)²`).
fn small_amplitude_factor(osc: &fit::Oscillation) -> (f64, f64) {
    let f = &osc.fit;
    let (a0, sigma) = (f.amplitude().value, f.sigma().value);
    let (t0, t1) = osc.segment_s;
    let n = 400;
    let ts: Vec<f64> = (0..n)
        .map(|i| t0 + (t1 - t0) * i as f64 / (n - 1) as f64)
        .collect();
    let a2: Vec<f64> = ts
        .iter()
        .map(|t| (a0 * (-sigma * (t - t0)).exp()).powi(2))
        .collect();
    let wsum: f64 = a2.iter().sum();
    let tbar = ts.iter().zip(&a2).map(|(t, w)| t * w).sum::<f64>() / wsum;
    let w: Vec<f64> = ts
        .iter()
        .zip(&a2)
        .map(|(t, a)| a * (t - tbar).powi(2))
        .collect();
    let theta2 = w.iter().zip(&a2).map(|(w, a)| w * a).sum::<f64>() / w.iter().sum::<f64>();
    (1.0 + theta2 / 16.0, theta2.sqrt())
}

/// Measures every repeat of a test and averages them
/// ([`combine_repeats`](crate::uncertainty::combine_repeats)): repeats far from the others
/// flagged and left out, the mean's standard error the larger of the fits' own and the
/// repeats' scatter (with two repeats the scatter usually dominates).
pub fn measure_test(m: &Manifest, t: &Test, compound: bool) -> Result<TestFrequency, InertiaError> {
    let extract = t
        .channel
        .clone()
        .map_or(Extract::DominantRotation, Extract::Channel);
    let mut repeats = Vec::new();
    let mut first_fit = None;
    for log in &t.logs {
        let path = m.log_path(log);
        let sig = signal::load_signal(
            &path,
            &extract,
            t.sensor.as_deref(),
            &ReadOptions::default(),
        )?
        .signal;
        let osc =
            fit::analyse(&sig, &FitOptions::default()).map_err(|source| InertiaError::Fit {
                log: path.clone(),
                source,
            })?;
        let fnat = osc.fit.natural_freq_hz();
        let angle = sig.unit == "rad";
        let (factor, amp) = if compound && (angle || sig.unit == "rad/s") {
            let (fac, a) = small_amplitude_factor(&osc);
            // A rate signal's amplitude is ω times the angle's.
            if angle {
                (fac, Some(a))
            } else {
                let a_rad = a / (2.0 * PI * fnat.value);
                (1.0 + a_rad * a_rad / 16.0, Some(a_rad))
            }
        } else {
            (
                1.0,
                if angle {
                    Some(osc.fit.amplitude().value)
                } else {
                    None
                },
            )
        };
        repeats.push(Repeat {
            log: log.clone(),
            freq_hz: fnat.value * factor,
            freq_se_hz: fnat.se * factor,
            damping_ratio: osc.fit.damping_ratio().value,
            amplitude_rad: amp,
            segment_s: [osc.segment_s.0, osc.segment_s.1],
            outlier: false,
        });
        if first_fit.is_none() {
            first_fit = Some((sig, osc));
        }
    }
    let combined = crate::uncertainty::combine_repeats(
        &repeats
            .iter()
            .map(|r| (r.freq_hz, r.freq_se_hz))
            .collect::<Vec<_>>(),
    );
    for (r, &o) in repeats.iter_mut().zip(&combined.outlier) {
        r.outlier = o;
    }
    let (freq, se) = (combined.mean.value, combined.mean.se);
    let (plain_mean, sd) = (combined.plain_mean, combined.sd);
    Ok(TestFrequency {
        name: t.name.clone(),
        freq_hz: freq,
        freq_se_hz: se,
        repeat_spread: sd / plain_mean,
        repeats,
        first_fit,
    })
}

// ---------------------------------------------------------------------------------------------
// Bar calibration.

/// The torsion bar's calibration (seed §5.3.3.2), and the fixture's own inertia.
#[derive(Debug, Clone, Serialize)]
pub struct BarCalibration {
    pub stiffness_nm_per_rad: f64,
    pub stiffness_se_nm_per_rad: f64,
    /// The rod's natural frequency on the bar (Hz).
    pub freq_hz: f64,
    pub freq_se_hz: f64,
    pub rod_inertia_kgm2: f64,
    pub rod_inertia_se_kgm2: f64,
    /// `G·I_p/L` from the bar's dimensions (eq. 64), when the manifest gives them.
    pub theory_stiffness_nm_per_rad: Option<f64>,
    /// The Cardan joint and clamp about the bar's axis (0 without an empty-fixture test).
    pub fixture_inertia_kgm2: f64,
    pub fixture_inertia_se_kgm2: f64,
    /// Correlation of the stiffness and the fixture's inertia (they are solved together).
    pub stiffness_fixture_correlation: f64,
    pub fixture_freq_hz: Option<f64>,
    #[serde(skip)]
    pub tests: Vec<TestFrequency>,
}

/// The calibration file's name in the bar-calibration folder.
pub const CALIBRATION_FILE: &str = "calibration.toml";

impl BarCalibration {
    /// The stiffness and fixture inertia as correlated inputs for propagation.
    pub fn push_inputs(&self, inputs: &mut Inputs) -> usize {
        let (sk, sf) = (self.stiffness_se_nm_per_rad, self.fixture_inertia_se_kgm2);
        let c = self.stiffness_fixture_correlation * sk * sf;
        inputs.push_correlated(
            &[self.stiffness_nm_per_rad, self.fixture_inertia_kgm2],
            &DMatrix::from_row_slice(2, 2, &[sk * sk, c, c, sf * sf]),
        )
    }

    /// The calibration file: what `bikeproc inertia` reads.
    pub fn to_toml(&self) -> String {
        let mut s = String::from("# Torsion-bar calibration, written by `bikeproc calibrate-bar`; read by `bikeproc inertia`.\n# SI units; every value with its standard error.\nversion = 1\n");
        let mut kv = |k: &str, v: f64| s.push_str(&format!("{k} = {v:e}\n"));
        kv("stiffness_nm_per_rad", self.stiffness_nm_per_rad);
        kv("stiffness_se_nm_per_rad", self.stiffness_se_nm_per_rad);
        kv("fixture_inertia_kgm2", self.fixture_inertia_kgm2);
        kv("fixture_inertia_se_kgm2", self.fixture_inertia_se_kgm2);
        kv(
            "stiffness_fixture_correlation",
            self.stiffness_fixture_correlation,
        );
        kv("freq_hz", self.freq_hz);
        kv("freq_se_hz", self.freq_se_hz);
        kv("rod_inertia_kgm2", self.rod_inertia_kgm2);
        kv("rod_inertia_se_kgm2", self.rod_inertia_se_kgm2);
        if let Some(t) = self.theory_stiffness_nm_per_rad {
            kv("theory_stiffness_nm_per_rad", t);
        }
        s
    }
}

/// Calibrates the bar from the rod's tests in `dir` (eqs. 65–67). With an empty-fixture folder
/// named in the manifest, the fixture's inertia `I_f` and the stiffness are solved together:
/// the rod gives `k = 4π² f_r² (I_rod + I_f)`, the fixture with its calibration weights `W`
/// gives `I_f = k/(2πf_e)² − W`, so `k = 4π² f_r² (I_rod − W) / (1 − f_r²/f_e²)`.
pub fn calibrate_bar(dir: &Path) -> Result<BarCalibration, InertiaError> {
    let m = Manifest::load(dir)?;
    if m.kind != Kind::BarCalibration {
        return Err(InertiaError::Invalid {
            path: m.dir.join(manifest::MANIFEST),
            message: format!("kind is {:?}, expected bar_calibration", m.kind),
        });
    }
    let rod = m.rod.as_ref().ok_or_else(|| InertiaError::Invalid {
        path: m.dir.join(manifest::MANIFEST),
        message: "missing [rod]".into(),
    })?;
    let mut tests = Vec::new();
    for t in &m.tests {
        tests.push(measure_test(&m, t, false)?);
    }
    // All rod tests together: their frequencies' weighted mean.
    let rod_freq = combine(&tests);
    let mut fixture: Option<(TestFrequency, f64, f64)> = None; // test, W, W_se
    if let Some(fdir) = &m.fixture {
        let fm = Manifest::load(&m.dir.join(fdir))?;
        if fm.kind != Kind::EmptyFixture {
            return Err(InertiaError::Invalid {
                path: fm.dir.join(manifest::MANIFEST),
                message: format!("kind is {:?}, expected empty_fixture", fm.kind),
            });
        }
        let ft: Vec<TestFrequency> = fm
            .tests
            .iter()
            .map(|t| measure_test(&fm, t, false))
            .collect::<Result<_, _>>()?;
        let t0 = &fm.tests[0];
        let (wm, wr) = (
            t0.weights_kg.unwrap_or(0.0),
            t0.weights_distance_m.unwrap_or(0.0),
        );
        let wr_se = t0.weights_distance_se_m.unwrap_or(fm.distance_se_m());
        let w = wm * wr * wr;
        let w_se = ((wr * wr * fm.mass_se_kg()).powi(2) + (2.0 * wm * wr * wr_se).powi(2)).sqrt();
        let f = combine(&ft);
        fixture = Some((
            TestFrequency {
                name: "empty fixture".into(),
                freq_hz: f.value,
                freq_se_hz: f.se,
                repeat_spread: 0.0,
                repeats: ft.into_iter().flat_map(|t| t.repeats).collect(),
                first_fit: None,
            },
            w,
            w_se,
        ));
    }
    let mut inputs = Inputs::new();
    inputs.push(rod_freq);
    inputs.push(Measured::new(rod.mass_kg, rod.mass_se_kg.unwrap_or(0.02)));
    let dim_se = rod.dimension_se_m.unwrap_or(1e-4);
    inputs.push(Measured::new(rod.diameter_m, dim_se));
    inputs.push(Measured::new(rod.length_m, dim_se));
    let (fe, w) = match &fixture {
        Some((t, w, w_se)) => (t.freq(), Measured::new(*w, *w_se)),
        None => (Measured::new(f64::INFINITY, 0.0), Measured::new(0.0, 0.0)),
    };
    inputs.push(fe);
    inputs.push(w);
    let (y, cov) = propagate(&inputs, |x| {
        let i_rod = rod_inertia(x[1], x[2], x[3]);
        let ratio = if x[4].is_finite() {
            (x[0] / x[4]).powi(2)
        } else {
            0.0
        };
        let k = 4.0 * PI * PI * x[0] * x[0] * (i_rod - x[5]) / (1.0 - ratio);
        let i_fix = if x[4].is_finite() {
            torsional_pendulum_inertia(k, x[4]) - x[5]
        } else {
            0.0
        };
        vec![k, i_fix, i_rod]
    });
    let se = standard_errors(&cov);
    let corr = if se[0] > 0.0 && se[1] > 0.0 {
        cov[(0, 1)] / (se[0] * se[1])
    } else {
        0.0
    };
    Ok(BarCalibration {
        stiffness_nm_per_rad: y[0],
        stiffness_se_nm_per_rad: se[0],
        freq_hz: rod_freq.value,
        freq_se_hz: rod_freq.se,
        rod_inertia_kgm2: y[2],
        rod_inertia_se_kgm2: se[2],
        theory_stiffness_nm_per_rad: m
            .bar
            .as_ref()
            .map(|b| torsion_bar_theory_stiffness(b.shear_modulus_pa, b.diameter_m, b.length_m)),
        fixture_inertia_kgm2: y[1],
        fixture_inertia_se_kgm2: se[1],
        stiffness_fixture_correlation: corr,
        fixture_freq_hz: fixture.as_ref().map(|(t, _, _)| t.freq_hz),
        tests: tests
            .into_iter()
            .chain(fixture.map(|(t, _, _)| t))
            .collect(),
    })
}

/// Weighted mean of several tests' frequencies (each already a mean of repeats).
fn combine(tests: &[TestFrequency]) -> Measured {
    if tests.len() == 1 {
        return tests[0].freq();
    }
    let w: f64 = tests.iter().map(|t| 1.0 / t.freq_se_hz.powi(2)).sum();
    let mean = tests
        .iter()
        .map(|t| t.freq_hz / t.freq_se_hz.powi(2))
        .sum::<f64>()
        / w;
    Measured::new(mean, (1.0 / w).sqrt())
}

// ---------------------------------------------------------------------------------------------
// Torsion tests of a body.

/// One orientation of a torsion test (Tables 1–2, 4–5).
#[derive(Debug, Clone, Serialize)]
pub struct Orientation {
    pub name: String,
    pub axis: [f64; 3],
    pub freq_hz: f64,
    pub freq_se_hz: f64,
    /// About the bar's axis, with the added weights (eq. 70), the fixture's inertia removed.
    pub inertia_with_weights: f64,
    pub inertia_with_weights_se: f64,
    /// Without the weights (eq. 71).
    pub inertia_without_weights: f64,
    pub inertia_without_weights_se: f64,
    /// About the parallel axis through the body's centre of gravity (eq. 72).
    pub inertia_about_cg: f64,
    pub inertia_about_cg_se: f64,
    pub repeat_spread: f64,
    pub repeats: Vec<Repeat>,
}

/// A body's inertia tensor in its xz plane of symmetry (eq. 68), from a set of orientations.
#[derive(Debug, Clone, Serialize)]
pub struct TensorXz {
    pub orientations: Vec<String>,
    /// Whether `I_xz = −I_zz` (eq. 74) was imposed (two orientations).
    pub handlebar_constraint: bool,
    pub ixx: f64,
    pub ixx_se: f64,
    pub ixz: f64,
    pub ixz_se: f64,
    pub izz: f64,
    pub izz_se: f64,
    /// Covariance of (I_xx, I_xz, I_zz).
    pub covariance: [[f64; 3]; 3],
    pub condition_number: f64,
    /// Principal moments in the xz plane (kg·m²) and the angle of the first axis from x (deg).
    pub principal_kgm2: [f64; 2],
    pub principal_axis_deg: f64,
    /// χ² of the orientations' moments about the fitted tensor (0 when exactly determined).
    pub chi2: f64,
    /// Its degrees of freedom: the orientations less the tensor's unknowns (3, or 2 with
    /// `I_xz = −I_zz`).
    pub chi2_dof: usize,
    /// The probability of a χ² at least this large were the moments' errors all there is
    /// (`None` without degrees of freedom).
    pub chi2_p_value: Option<f64>,
    pub warnings: Vec<String>,
}

/// Everything `bikeproc inertia` finds in a torsion folder.
#[derive(Debug, Clone, Serialize)]
pub struct TorsionResult {
    pub body: String,
    pub mass_kg: f64,
    pub stiffness_nm_per_rad: f64,
    pub stiffness_se_nm_per_rad: f64,
    pub fixture_inertia_kgm2: f64,
    pub orientations: Vec<Orientation>,
    /// The tensor from the orientations asked for (all by default).
    pub tensor: TensorXz,
    #[serde(skip)]
    pub frequencies: Vec<TestFrequency>,
    #[serde(skip)]
    pub manifest: Manifest,
    #[serde(skip)]
    pub calibration: BarCalibration,
}

const INPUTS_PER_ORIENTATION: usize = 5;

/// The inputs of a torsion folder: `[k, I_fix, m]` then per orientation
/// `[f, m_weights, r_weights, r_cg, δφ]`.
fn torsion_inputs(m: &Manifest, cal: &BarCalibration, freqs: &[TestFrequency]) -> Inputs {
    let mut inputs = Inputs::new();
    cal.push_inputs(&mut inputs);
    inputs.push(Measured::new(m.mass_kg.unwrap_or(0.0), m.mass_se_kg()));
    for (t, f) in m.tests.iter().zip(freqs) {
        inputs.push(f.freq());
        let wm = t.weights_kg.unwrap_or(0.0);
        inputs.push(Measured::new(
            wm,
            if wm > 0.0 { m.mass_se_kg() } else { 0.0 },
        ));
        inputs.push(Measured::new(
            t.weights_distance_m.unwrap_or(0.0),
            if wm > 0.0 {
                t.weights_distance_se_m.unwrap_or(m.distance_se_m())
            } else {
                0.0
            },
        ));
        inputs.push(Measured::new(
            t.cg_distance_m.unwrap_or(0.0),
            m.distance_se_m(),
        ));
        inputs.push(Measured::new(0.0, m.axis_angle_se_rad()));
    }
    inputs
}

/// `[I₁, I₂, I_cg]` of orientation `i` from the input vector (eqs. 70–72).
fn orientation_moments(x: &[f64], i: usize) -> [f64; 3] {
    let b = 3 + INPUTS_PER_ORIENTATION * i;
    let i1 = torsional_pendulum_inertia(x[0], x[b]) - x[1];
    let i2 = parallel_axis_removed(i1, x[b + 1], x[b + 2]);
    let icg = parallel_axis_removed(i2, x[2], x[b + 3]);
    [i1, i2, icg]
}

/// What `bikeproc inertia FOLDER` measured: a torsion folder's tensor or a compound folder's
/// moments, by the folder's manifest.
#[derive(Debug, Clone)]
pub enum FolderResult {
    Torsion(Box<TorsionResult>),
    Compound(CompoundResult),
}

impl FolderResult {
    /// The JSON of `bikeproc inertia --json`.
    pub fn json(&self) -> serde_json::Value {
        match self {
            FolderResult::Torsion(r) => text::torsion_json(r),
            FolderResult::Compound(r) => text::compound_json(r),
        }
    }

    /// The text of `bikeproc inertia`.
    pub fn text(&self) -> String {
        match self {
            FolderResult::Torsion(r) => text::torsion_text(r),
            FolderResult::Compound(r) => text::compound_text(r),
        }
    }

    /// The tensor's warnings (a torsion folder's; none for a compound one).
    pub fn warnings(&self) -> &[String] {
        match self {
            FolderResult::Torsion(r) => &r.tensor.warnings,
            FolderResult::Compound(_) => &[],
        }
    }
}

/// Measures the folder `dir` as its manifest says: a torsion folder ([`torsion`], with the
/// orientations `use_orientations`, all when empty) or a compound one ([`compound`]); a
/// bar-calibration or empty-fixture folder is an error pointing to `calibrate-bar`.
pub fn analyse_folder(
    dir: &Path,
    use_orientations: &[String],
) -> Result<FolderResult, InertiaError> {
    match manifest::Manifest::load(dir)?.kind {
        manifest::Kind::Torsion => Ok(FolderResult::Torsion(Box::new(torsion(
            dir,
            use_orientations,
        )?))),
        manifest::Kind::Compound => Ok(FolderResult::Compound(compound(dir)?)),
        manifest::Kind::BarCalibration | manifest::Kind::EmptyFixture => {
            Err(InertiaError::Invalid {
                path: dir.join(manifest::MANIFEST),
                message: "a bar-calibration or empty-fixture folder: use `bikeproc calibrate-bar`"
                    .into(),
            })
        }
    }
}

/// Processes a torsion folder: every orientation's moments, and the tensor from the
/// orientations named in `use_orientations` (all when empty).
pub fn torsion(dir: &Path, use_orientations: &[String]) -> Result<TorsionResult, InertiaError> {
    let m = Manifest::load(dir)?;
    let mpath = m.dir.join(manifest::MANIFEST);
    if m.kind != Kind::Torsion {
        return Err(InertiaError::Invalid {
            path: mpath,
            message: format!("kind is {:?}, expected torsion", m.kind),
        });
    }
    let cal_path = m.dir.join(
        m.calibration
            .as_deref()
            .unwrap_or(Path::new(CALIBRATION_FILE)),
    );
    let cal = BarCalibration::load(&cal_path)?;
    let freqs: Vec<TestFrequency> = m
        .tests
        .iter()
        .map(|t| measure_test(&m, t, false))
        .collect::<Result<_, _>>()?;
    torsion_from_frequencies(m, cal, freqs, use_orientations)
}

/// The torsion computation once the frequencies are measured (used by the campaign tests too).
pub fn torsion_from_frequencies(
    m: Manifest,
    cal: BarCalibration,
    freqs: Vec<TestFrequency>,
    use_orientations: &[String],
) -> Result<TorsionResult, InertiaError> {
    let mpath = m.dir.join(manifest::MANIFEST);
    let inputs = torsion_inputs(&m, &cal, &freqs);
    let n = m.tests.len();
    let (y, cov) = propagate(&inputs, |x| {
        (0..n).flat_map(|i| orientation_moments(x, i)).collect()
    });
    let se = standard_errors(&cov);
    let orientations: Vec<Orientation> = m
        .tests
        .iter()
        .zip(&freqs)
        .enumerate()
        .map(|(i, (t, f))| Orientation {
            name: t.name.clone(),
            axis: t.axis.unwrap_or([0.0; 3]),
            freq_hz: f.freq_hz,
            freq_se_hz: f.freq_se_hz,
            inertia_with_weights: y[3 * i],
            inertia_with_weights_se: se[3 * i],
            inertia_without_weights: y[3 * i + 1],
            inertia_without_weights_se: se[3 * i + 1],
            inertia_about_cg: y[3 * i + 2],
            inertia_about_cg_se: se[3 * i + 2],
            repeat_spread: f.repeat_spread,
            repeats: f.repeats.clone(),
        })
        .collect();
    let chosen: Vec<usize> = if use_orientations.is_empty() {
        (0..n).collect()
    } else {
        use_orientations
            .iter()
            .map(|name| {
                m.tests
                    .iter()
                    .position(|t| &t.name == name)
                    .ok_or_else(|| InertiaError::Invalid {
                        path: mpath.clone(),
                        message: format!(
                            "no orientation \"{name}\" (the manifest has {})",
                            m.tests
                                .iter()
                                .map(|t| format!("\"{}\"", t.name))
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    })
            })
            .collect::<Result<_, _>>()?
    };
    let tensor =
        tensor_from(&inputs, &orientations, &chosen).map_err(|e| InertiaError::Invalid {
            path: mpath.clone(),
            message: e.to_string(),
        })?;
    Ok(TorsionResult {
        body: m.body.clone().unwrap_or_default(),
        mass_kg: m.mass_kg.unwrap_or(0.0),
        stiffness_nm_per_rad: cal.stiffness_nm_per_rad,
        stiffness_se_nm_per_rad: cal.stiffness_se_nm_per_rad,
        fixture_inertia_kgm2: cal.fixture_inertia_kgm2,
        orientations,
        tensor,
        frequencies: freqs,
        manifest: m,
        calibration: cal,
    })
}

impl TorsionResult {
    /// The tensor from another set of orientations (the report shows (1,2,4), (1,3,4), all).
    pub fn tensor_for(&self, names: &[&str]) -> Result<TensorXz, TensorError> {
        let inputs = torsion_inputs(&self.manifest, &self.calibration, &self.frequencies);
        let chosen: Vec<usize> = names
            .iter()
            .map(|n| {
                self.orientations
                    .iter()
                    .position(|o| o.name == *n)
                    .ok_or_else(|| TensorError::NoOrientation(n.to_string()))
            })
            .collect::<Result<_, _>>()?;
        tensor_from(&inputs, &self.orientations, &chosen)
    }
}

fn tensor_from(
    inputs: &Inputs,
    orientations: &[Orientation],
    chosen: &[usize],
) -> Result<TensorXz, TensorError> {
    let constraint = chosen.len() == 2;
    if chosen.len() < 2 {
        return Err(TensorError::TooFew(chosen.len()));
    }
    let weights: Vec<f64> = chosen
        .iter()
        .map(|&i| 1.0 / orientations[i].inertia_about_cg_se.max(1e-12).powi(2))
        .collect();
    let axes: Vec<[f64; 3]> = chosen.iter().map(|&i| orientations[i].axis).collect();
    let solve = |x: &[f64]| -> Vec<f64> {
        let ax: Vec<[f64; 3]> = chosen
            .iter()
            .map(|&i| turn_axis(orientations[i].axis, x[3 + INPUTS_PER_ORIENTATION * i + 4]))
            .collect();
        let mo: Vec<f64> = chosen
            .iter()
            .map(|&i| orientation_moments(x, i)[2])
            .collect();
        solve_tensor(&ax, &mo, &weights, constraint).map_or(vec![f64::NAN; 3], |t| t.to_vec())
    };
    let (t, cov) = propagate(inputs, solve);
    if t.iter().any(|v| !v.is_finite()) {
        return Err(TensorError::Undetermined(
            chosen
                .iter()
                .map(|&i| orientations[i].name.clone())
                .collect::<Vec<_>>()
                .join(", "),
        ));
    }
    let se = standard_errors(&cov);
    let cond = design_condition(&axes, constraint);
    let chi2: f64 = chosen
        .iter()
        .zip(&weights)
        .map(|(&i, w)| {
            let r = tensor_row(orientations[i].axis);
            let pred = r[0] * t[0] + r[1] * t[1] + r[2] * t[2];
            w * (pred - orientations[i].inertia_about_cg).powi(2)
        })
        .sum();
    let dof = chosen.len().saturating_sub(if constraint { 2 } else { 3 });
    let eig = SymmetricEigen::new(Matrix2::new(t[0], t[1], t[1], t[2]));
    let k = eig.eigenvalues.imax();
    let v = eig.eigenvectors.column(k);
    let mut warnings = Vec::new();
    let names = chosen
        .iter()
        .map(|&i| orientations[i].name.clone())
        .collect::<Vec<_>>();
    if cond > 30.0 {
        warnings.push(format!("orientations {} are poorly spread: condition number {cond:.0} (errors in their moments are amplified up to that much)", names.join(", ")));
    }
    let (p_big, p_small) = (eig.eigenvalues[k], eig.eigenvalues[1 - k]);
    if p_small <= 0.0 {
        let worst = chosen
            .iter()
            .max_by(|&&a, &&b| {
                orientations[a]
                    .inertia_about_cg_se
                    .total_cmp(&orientations[b].inertia_about_cg_se)
            })
            .map(|&i| orientations[i].name.clone())
            .unwrap_or_default();
        warnings.push(format!(
            "not physically valid: the tensor is not positive definite (principal moments {p_big:.4}, {p_small:.4} kg·m²); the moments of orientations {} disagree with their axes — check orientation \"{worst}\" (largest uncertainty) and the axes' angles",
            names.join(", ")
        ));
    }
    if constraint {
        warnings.push(
            "two orientations: I_xz = −I_zz imposed (eq. 74), as the lab did for the handlebar"
                .into(),
        );
    }
    let c = |r: usize, s: usize| cov[(r, s)];
    Ok(TensorXz {
        orientations: names,
        handlebar_constraint: constraint,
        ixx: t[0],
        ixx_se: se[0],
        ixz: t[1],
        ixz_se: se[1],
        izz: t[2],
        izz_se: se[2],
        covariance: [
            [c(0, 0), c(0, 1), c(0, 2)],
            [c(1, 0), c(1, 1), c(1, 2)],
            [c(2, 0), c(2, 1), c(2, 2)],
        ],
        condition_number: cond,
        principal_kgm2: [p_big, p_small],
        principal_axis_deg: v[1].atan2(v[0]).to_degrees(),
        chi2,
        chi2_dof: dof,
        chi2_p_value: (dof > 0).then(|| crate::stats::chi2_sf(chi2, dof)),
        warnings,
    })
}

// ---------------------------------------------------------------------------------------------
// Compound pendulum tests.

/// One compound-pendulum test (eqs. 79–91).
#[derive(Debug, Clone, Serialize)]
pub struct CompoundTest {
    pub name: String,
    pub moment: Moment,
    pub pivot_to_cg_m: f64,
    /// Natural frequency corrected to small amplitude (Hz).
    pub freq_hz: f64,
    pub freq_se_hz: f64,
    /// About the pivot (eq. 77).
    pub inertia_about_pivot: f64,
    pub inertia_about_pivot_se: f64,
    /// About the parallel axis through the centre of gravity (eq. 78).
    pub inertia_about_cg: f64,
    pub inertia_about_cg_se: f64,
    pub repeat_spread: f64,
    pub repeats: Vec<Repeat>,
}

/// Everything `bikeproc inertia` finds in a compound-pendulum folder.
#[derive(Debug, Clone, Serialize)]
pub struct CompoundResult {
    pub body: String,
    pub mass_kg: f64,
    pub mass_se_kg: f64,
    pub tests: Vec<CompoundTest>,
    #[serde(skip)]
    pub frequencies: Vec<TestFrequency>,
}

/// Processes a compound-pendulum folder.
pub fn compound(dir: &Path) -> Result<CompoundResult, InertiaError> {
    let m = Manifest::load(dir)?;
    if m.kind != Kind::Compound {
        return Err(InertiaError::Invalid {
            path: m.dir.join(manifest::MANIFEST),
            message: format!("kind is {:?}, expected compound", m.kind),
        });
    }
    let freqs: Vec<TestFrequency> = m
        .tests
        .iter()
        .map(|t| measure_test(&m, t, true))
        .collect::<Result<_, _>>()?;
    let mut inputs = Inputs::new();
    inputs.push(Measured::new(m.mass_kg.unwrap_or(0.0), m.mass_se_kg()));
    for (t, f) in m.tests.iter().zip(&freqs) {
        inputs.push(f.freq());
        inputs.push(Measured::new(
            t.pivot_to_cg_m.unwrap_or(0.0),
            m.distance_se_m(),
        ));
    }
    let n = m.tests.len();
    let (y, cov) = propagate(&inputs, |x| {
        (0..n)
            .flat_map(|i| {
                let (f, l) = (x[1 + 2 * i], x[2 + 2 * i]);
                let ip = compound_pendulum_inertia(x[0], l, f, GRAVITY_MPS2);
                [ip, parallel_axis_removed(ip, x[0], l)]
            })
            .collect()
    });
    let se = standard_errors(&cov);
    let tests = m
        .tests
        .iter()
        .zip(&freqs)
        .enumerate()
        .map(|(i, (t, f))| CompoundTest {
            name: t.name.clone(),
            moment: t.moment.unwrap_or(Moment::Iyy),
            pivot_to_cg_m: t.pivot_to_cg_m.unwrap_or(0.0),
            freq_hz: f.freq_hz,
            freq_se_hz: f.freq_se_hz,
            inertia_about_pivot: y[2 * i],
            inertia_about_pivot_se: se[2 * i],
            inertia_about_cg: y[2 * i + 1],
            inertia_about_cg_se: se[2 * i + 1],
            repeat_spread: f.repeat_spread,
            repeats: f.repeats.clone(),
        })
        .collect();
    Ok(CompoundResult {
        body: m.body.clone().unwrap_or_default(),
        mass_kg: m.mass_kg.unwrap_or(0.0),
        mass_se_kg: m.mass_se_kg(),
        tests,
        frequencies: freqs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_seeds_equations_reproduce_its_numbers() {
        // Eq. 65 prints 1.8906 kg·m², but its own formula and numbers give 1.89030 (the seed's
        // arithmetic is 0.016 % high); eq. 64: 35.52 N·m/rad; eq. 67: 34.33 (34.325 from 1.89030).
        let i_rod = rod_inertia(22.31, 59.95e-3, 1.007);
        assert!((i_rod - 1.890297).abs() < 1e-6, "{i_rod}");
        assert!((i_rod / 1.8906 - 1.0).abs() < 2e-4);
        assert!((torsion_bar_theory_stiffness(72e9, 0.010, 1.99) - 35.52).abs() < 5e-3);
        assert!((torsional_pendulum_stiffness(i_rod, 0.6782) / 34.33 - 1.0).abs() < 3e-4);
        // Eq. 79–80: frame I'_y = 1.6298, I_y = 0.8796.
        let ip = compound_pendulum_inertia(5.48, 0.37, 0.556, 9.81);
        assert!(
            (ip - 1.6298).abs() < 5e-5
                && (parallel_axis_removed(ip, 5.48, 0.37) - 0.8796).abs() < 5e-5
        );
    }

    #[test]
    fn tensor_solve_is_exact_for_three_axes_and_matches_the_issue() {
        // Table 2's moments about the CG with eq. 73's axes: the exact solve of (1,2,4).
        let axes = [
            [0.7964, 0.0, -0.6048],
            [-0.4097, 0.0, 0.9122],
            [0.9097, 0.0, 0.4153],
        ];
        let t = solve_tensor(&axes, &[0.6964, 0.8957, 0.3403], &[1.0; 3], false).unwrap();
        for (got, want) in t.iter().zip([0.3688, -0.1512, 0.8662]) {
            assert!((got - want).abs() < 5e-4, "{got} vs {want}");
        }
    }

    #[test]
    fn handlebar_constraint_reproduces_table_6() {
        let axes = [[-0.0106, 0.0, 0.9999], [-0.9993, 0.0, 0.0376]];
        let t = solve_tensor(&axes, &[0.0394, 0.3081], &[1.0; 2], true).unwrap();
        for (got, want) in t.iter().zip([0.3056, -0.0385, 0.0385]) {
            assert!((got - want).abs() < 5e-4, "{got} vs {want}");
        }
    }
}
