//! Uncertainty of the model's results: a bicycle whose benchmark parameters are a function of
//! measured inputs with standard errors, and the linear propagation of those errors to the
//! eigenvalues and the characteristic speeds (checked against a Monte Carlo in the tests).

use super::lab::lab_to_benchmark;
use super::params::{Benchmark, ParamError};
use super::{Canonical, Stability, SteerControl};
use crate::inertia::bike::LabBike;
use crate::signal::wrap_near;
use crate::uncertainty::{propagate, propagate_se, Inputs, Measured};
use nalgebra::Complex;
use std::path::Path;

/// Inputs → benchmark parameters.
pub type Builder = std::sync::Arc<dyn Fn(&[f64]) -> Benchmark + Send + Sync>;

/// A bicycle whose benchmark parameters are a function of measured inputs: the
/// uncertainties are propagated from those inputs (with their correlations through the
/// conversion), not from the benchmark parameters.
#[derive(Clone)]
pub struct Parametrized {
    pub name: String,
    pub inputs: Inputs,
    build: Builder,
    /// A known steer controller closing the loop ([`SteerControl::NONE`]: none); it has no
    /// uncertainty of its own here.
    pub control: SteerControl,
}

impl Parametrized {
    /// A benchmark parameter set whose inputs are its own 26 parameters.
    pub fn from_benchmark(name: &str, b: &Benchmark) -> Parametrized {
        let mut inputs = Inputs::new();
        for (v, s) in b.to_array().iter().zip(b.se) {
            inputs.push(Measured::new(*v, s));
        }
        Parametrized {
            name: name.into(),
            inputs,
            build: std::sync::Arc::new(|x: &[f64]| {
                let mut a = [0.0; 26];
                a.copy_from_slice(&x[..26]);
                Benchmark::from_array(&a)
            }),
            control: SteerControl::NONE,
        }
    }

    /// A bicycle whose benchmark parameters `build` computes from `inputs` (measurements with
    /// their covariance).
    pub fn from_inputs(name: &str, inputs: Inputs, build: Builder) -> Parametrized {
        Parametrized {
            name: name.into(),
            inputs,
            build,
            control: SteerControl::NONE,
        }
    }

    /// The lab's bicycle: inputs are its masses and inertia entries (with their standard errors).
    pub fn from_lab(name: &str, bike: &LabBike) -> Parametrized {
        let mut inputs = Inputs::new();
        for body in [
            &bike.rear_wheel,
            &bike.frame,
            &bike.handlebar,
            &bike.front_wheel,
        ] {
            inputs.push(Measured::new(body.mass_kg, body.mass_se_kg));
            inputs.push(Measured::new(body.ixx_kgm2, body.ixx_se_kgm2));
            inputs.push(Measured::new(body.iyy_kgm2, body.iyy_se_kgm2));
            inputs.push(Measured::new(body.izz_kgm2, body.izz_se_kgm2));
            inputs.push(Measured::new(body.ixz_kgm2, body.ixz_se_kgm2));
        }
        let bike = bike.clone();
        Parametrized {
            name: name.into(),
            inputs,
            build: std::sync::Arc::new(move |x: &[f64]| {
                let mut b = bike.clone();
                for (k, body) in [
                    &mut b.rear_wheel,
                    &mut b.frame,
                    &mut b.handlebar,
                    &mut b.front_wheel,
                ]
                .into_iter()
                .enumerate()
                {
                    let v = &x[5 * k..5 * k + 5];
                    body.mass_kg = v[0];
                    body.ixx_kgm2 = v[1];
                    body.iyy_kgm2 = v[2];
                    body.izz_kgm2 = v[3];
                    body.ixz_kgm2 = v[4];
                }
                lab_to_benchmark(&b)
            }),
            control: SteerControl::NONE,
        }
    }

    /// The same bicycle with known point masses added (a condition's known change):
    /// [`Benchmark::with_point_mass`] after the inputs make the parameters, so that their
    /// uncertainty propagates through the changed bicycle.
    pub fn with_masses(mut self, masses: &[super::params::PointMass]) -> Parametrized {
        if masses.is_empty() {
            return self;
        }
        let build = self.build.clone();
        let masses = masses.to_vec();
        self.build = std::sync::Arc::new(move |x: &[f64]| {
            masses.iter().fold(build(x), |b, m| b.with_point_mass(m))
        });
        self
    }

    /// The same bicycle with `control` closing the loop.
    pub fn with_control(mut self, control: SteerControl) -> Parametrized {
        self.control = control;
        self
    }

    /// The canonical matrices at given input values, with the controller.
    pub fn canonical_at(&self, x: &[f64]) -> Canonical {
        Canonical::from_benchmark(&self.benchmark_at(x)).with_control(self.control)
    }

    /// The canonical matrices at the nominal inputs, with the controller.
    pub fn nominal_canonical(&self) -> Canonical {
        self.canonical_at(self.inputs.values())
    }

    /// The benchmark parameters at given input values.
    pub fn benchmark_at(&self, x: &[f64]) -> Benchmark {
        (self.build)(x)
    }

    /// The nominal benchmark parameters, with standard errors propagated from the inputs.
    pub fn nominal(&self) -> Benchmark {
        let (y, cov) = crate::uncertainty::propagate(&self.inputs, |x| {
            self.benchmark_at(x).to_array().to_vec()
        });
        let mut a = [0.0; 26];
        a.copy_from_slice(&y);
        let mut b = Benchmark::from_array(&a);
        for k in 0..26 {
            b.se[k] = cov[(k, k)].max(0.0).sqrt();
        }
        b
    }
}

/// The characteristic speeds with their standard errors.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SpeedsWithSe {
    pub stability: Stability,
    pub weave_speed_se_mps: Option<f64>,
    pub capsize_speed_se_mps: Option<f64>,
}

/// Eigenvalues against speed with standard errors of their real and imaginary parts.
#[derive(Debug, Clone)]
pub struct Bands {
    pub sweep: super::Sweep,
    /// Per speed and branch: (se of the real part, se of the imaginary part).
    pub se: Vec<[(f64, f64); 4]>,
}

/// Speeds per chunk of [`Parametrized::bands`]' propagation.
const BANDS_CHUNK: usize = 512;

/// The speed where `max_real` changes sign within ±0.02 m/s of `v0` (the perturbations of the
/// propagation move it by far less), or `NaN`.
fn crossing_near(c: &Canonical, v0: f64) -> f64 {
    let (a, b) = ((v0 - 0.02).max(0.0), v0 + 0.02);
    let (fa, fb) = (c.max_real(a), c.max_real(b));
    if !(fa.is_finite() && fb.is_finite()) || (fa < 0.0) == (fb < 0.0) {
        return f64::NAN;
    }
    super::illinois(a, b, |v| c.max_real(v))
}

impl Parametrized {
    /// Stability in `[0, v_max]` and the standard errors of the weave and capsize speeds.
    pub fn speeds(&self, v_max: f64, step: f64) -> Result<SpeedsWithSe, ParamError> {
        let nominal = self.nominal_canonical();
        let stability = nominal.stability(v_max, step)?;
        let se_of = |v0: Option<f64>| -> Option<f64> {
            let v0 = v0?;
            let (_, cov) = propagate(&self.inputs, |x| {
                vec![crossing_near(&self.canonical_at(x), v0)]
            });
            let var = cov[(0, 0)];
            var.is_finite().then(|| var.max(0.0).sqrt())
        };
        Ok(SpeedsWithSe {
            weave_speed_se_mps: se_of(stability.weave_speed_mps),
            capsize_speed_se_mps: se_of(stability.capsize_speed_mps),
            stability,
        })
    }

    /// Named eigenvalues at `speeds` with the standard errors of their parts.
    pub fn bands(&self, speeds: &[f64]) -> Result<Bands, ParamError> {
        let nominal = self.nominal_canonical();
        let sweep = nominal.sweep(speeds)?;
        // Each speed's eigenvalues and their standard errors, BANDS_CHUNK speeds at a time:
        // memory in proportion to the speeds (the covariance across speeds is not kept).
        let flat = propagate_se(&self.inputs, speeds.len(), BANDS_CHUNK, |x, range| {
            let c = self.canonical_at(x);
            let mut out = Vec::with_capacity(8 * range.len());
            for i in range {
                let ev = c
                    .eigenvalues(speeds[i])
                    .unwrap_or([Complex::new(f64::NAN, 0.0); 4]);
                for z in super::match_order(&sweep.eigenvalues[i], &ev) {
                    out.push(z.re);
                    out.push(z.im);
                }
            }
            out
        });
        let se = flat
            .chunks_exact(8)
            .map(|s| [(s[0], s[1]), (s[2], s[3]), (s[4], s[5]), (s[6], s[7])])
            .collect();
        Ok(Bands { sweep, se })
    }
}

/// The model's weave at a set of speeds: its eigenvalue and mode shape, and their covariance
/// from the measured parameters.
#[derive(Debug, Clone)]
pub struct WeaveModel {
    /// The weave eigenvalue at each speed.
    pub weaves: Vec<Complex<f64>>,
    /// Its mode shape γ/θ (steer over roll, complex); `NaN` where the model gives none.
    pub shapes: Vec<Complex<f64>>,
    /// Covariance of `[re₀, im₀, |γ/θ|₀, arg₀, re₁, …]` (arg in rad), propagated from the
    /// parameters: correlated across speeds, since one parameter set makes every speed's weave.
    pub cov: nalgebra::DMatrix<f64>,
}

/// The parts [`Parametrized::weave_model`] gives per speed.
pub const WEAVE_PARTS: usize = 4;

impl Parametrized {
    /// The weave eigenvalue and its mode shape γ/θ at each of `speeds` (any order), with the
    /// covariance of their parts propagated from the parameters. The phase of each perturbed
    /// shape is taken within ±π of the nominal one.
    pub fn weave_model(&self, speeds: &[f64]) -> Result<WeaveModel, ParamError> {
        self.weave_model_conditions(&[(self.clone(), speeds.to_vec())])
    }

    /// [`Parametrized::weave_model`] of the same bicycle in several conditions (a study's),
    /// each a model made from this one's inputs (`with_control`, `with_masses`) at its own
    /// speeds, in that order: one propagation through this bicycle's inputs, so that the
    /// covariance holds the correlation across conditions that one parameter set makes.
    pub fn weave_model_conditions(
        &self,
        conditions: &[(Parametrized, Vec<f64>)],
    ) -> Result<WeaveModel, ParamError> {
        let at = |x: &[f64], condition: &Parametrized| condition.canonical_at(x);
        let nominal_x = self.inputs.values();
        let sweeps = conditions
            .iter()
            .map(|(condition, speeds)| at(nominal_x, condition).sweep(speeds))
            .collect::<Result<Vec<_>, _>>()?;
        let shape_of = |c: &Canonical, v: f64, w: Complex<f64>| -> Complex<f64> {
            c.mode_shape(v, w)
                .map(|x| x[1] / x[0])
                .filter(|z| z.is_finite())
                .unwrap_or(Complex::new(f64::NAN, f64::NAN))
        };
        let mut weaves = Vec::new();
        let mut shapes = Vec::new();
        for ((condition, speeds), sweep) in conditions.iter().zip(&sweeps) {
            let nominal = at(nominal_x, condition);
            for (&v, e) in speeds.iter().zip(&sweep.eigenvalues) {
                weaves.push(e[0]);
                shapes.push(shape_of(&nominal, v, e[0]));
            }
        }
        let (_, cov) = propagate(&self.inputs, |x| {
            let mut out = Vec::with_capacity(WEAVE_PARTS * weaves.len());
            let mut k = 0;
            for ((condition, speeds), sweep) in conditions.iter().zip(&sweeps) {
                let c = at(x, condition);
                for (i, &v) in speeds.iter().enumerate() {
                    let ev = c.eigenvalues(v).unwrap_or([Complex::new(f64::NAN, 0.0); 4]);
                    let w = super::match_order(&sweep.eigenvalues[i], &ev)[0];
                    let s = shape_of(&c, v, w);
                    out.extend([w.re, w.im, s.norm(), wrap_near(s.arg(), shapes[k].arg())]);
                    k += 1;
                }
            }
            out
        });
        Ok(WeaveModel {
            weaves,
            shapes,
            cov,
        })
    }
}

/// Loads any bicycle file as a parametrized model: a lab bicycle (TOML with `[geometry]`)
/// keeps its measured inputs; BicycleParameters' raw measurements (`*Measured.txt`) become
/// their benchmark parameters with standard errors (what `bikeproc measured --out` writes);
/// other files are their own benchmark parameters.
pub fn load(path: &Path) -> Result<Parametrized, ParamError> {
    if path
        .file_name()
        .is_some_and(|n| n.to_string_lossy().ends_with("Measured.txt"))
    {
        let bike = crate::inertia::measured::MeasuredBicycle::load(path)
            .map_err(|e| ParamError::Measured(e.to_string()))?;
        return Ok(Parametrized::from_benchmark(&bike.name, &bike.benchmark()));
    }
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let text = std::fs::read_to_string(path).map_err(|e| ParamError::Invalid {
        path: path.to_path_buf(),
        message: format!("cannot read: {e}"),
    })?;
    if path.extension().is_some_and(|e| e == "toml")
        && text.lines().any(|l| l.trim() == "[geometry]")
    {
        let bike = LabBike::load(path).map_err(|e| ParamError::Invalid {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        let p = Parametrized::from_lab(&name, &bike);
        p.benchmark_at(p.inputs.values()).validate(path)?;
        return Ok(p);
    }
    Ok(Parametrized::from_benchmark(&name, &Benchmark::load(path)?))
}
