//! Uncertainty of the model's results: a bicycle whose benchmark parameters are a function of
//! measured inputs with standard errors, and the linear propagation of those errors to the
//! eigenvalues and the characteristic speeds (checked against a Monte Carlo in the tests).

use super::lab::lab_to_benchmark;
use super::params::{Benchmark, ParamError};
use super::{Canonical, Stability, SteerControl};
use crate::inertia::bike::LabBike;
use crate::signal::wrap_near;
use crate::uncertainty::{propagate, propagate_se, propagate_with_factor, Inputs, Measured};
use nalgebra::Complex;

/// Inputs → benchmark parameters.
pub type Builder = std::sync::Arc<dyn Fn(&[f64]) -> Benchmark + Send + Sync>;

/// A bicycle whose benchmark parameters are a function of measured inputs: the
/// uncertainties are propagated from those inputs (with their correlations through the
/// conversion), not from the benchmark parameters.
#[derive(Clone)]
pub struct Parametrized {
    pub name: String,
    pub inputs: Inputs,
    /// What each input is, in the order of `inputs` (for the uncertainty budget): the benchmark
    /// parameter's name, or the lab body's quantity (`frame I_xx`), or the rider's (`rider mB`).
    pub input_names: Vec<String>,
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
            input_names: Benchmark::NAMES.iter().map(|n| n.to_string()).collect(),
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
            input_names: (0..inputs.values().len())
                .map(|k| format!("input {k}"))
                .collect(),
            inputs,
            build,
            control: SteerControl::NONE,
        }
    }

    /// The lab's bicycle: inputs are its masses and inertia entries (with their standard errors).
    pub fn from_lab(name: &str, bike: &LabBike) -> Parametrized {
        let mut inputs = Inputs::new();
        let mut input_names = Vec::new();
        for (body, body_name) in [
            (&bike.rear_wheel, "rear_wheel"),
            (&bike.frame, "frame"),
            (&bike.handlebar, "handlebar"),
            (&bike.front_wheel, "front_wheel"),
        ] {
            for q in ["mass", "I_xx", "I_yy", "I_zz", "I_xz"] {
                input_names.push(format!("{body_name} {q}"));
            }
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
            input_names,
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

    /// The same bicycle with `rider` joined to its rear frame
    /// ([`Benchmark::with_body`]): the rider's seven parameters become inputs beside the
    /// bicycle's, with their standard errors, so that both propagate.
    pub fn with_rider(mut self, rider: &super::params::Rider) -> Parametrized {
        let n = self.inputs.values().len();
        for ((v, s), name) in rider
            .body
            .to_array()
            .iter()
            .zip(rider.se)
            .zip(super::params::Rider::NAMES)
        {
            self.inputs.push(Measured::new(*v, s));
            self.input_names.push(format!("rider {name}"));
        }
        let build = self.build.clone();
        self.build = std::sync::Arc::new(move |x: &[f64]| {
            let mut r = [0.0; 7];
            r.copy_from_slice(&x[n..n + 7]);
            let body = super::params::RigidBody::from_array(&r);
            build(&x[..n]).with_body(super::params::Frame::Rear, &body)
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

/// The fewest speeds a thread of [`Parametrized::bands`] takes at a time.
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
    ///
    /// The parameters reach the eigenvalues only through the canonical matrices M, C₁, K₀, K₂
    /// (Meijaard et al. 2007, eq. 1), so their covariance is propagated once, to those
    /// matrices' 16 entries; at each speed each eigenvalue's derivatives by the entries follow
    /// from first-order perturbation theory, `dλ = wᵀ dA v / (wᵀ v)` with v, w its right and
    /// left eigenvectors ([`eigenvalue_gradient`]). Where two eigenvalues nearly meet (the
    /// derivative is then no longer a good guide) the speed is propagated by finite
    /// differences through the parameters instead, as [`propagate_se`] does.
    pub fn bands(&self, speeds: &[f64]) -> Result<Bands, ParamError> {
        use rayon::prelude::*;
        let nominal = self.nominal_canonical();
        let sweep = nominal.sweep(speeds)?;
        let (_, entries_cov) = propagate(&self.inputs, |x| {
            canonical_entries(&self.canonical_at(x)).to_vec()
        });
        let entries_cov = nalgebra::SMatrix::<f64, 16, 16>::from_fn(|r, c| entries_cov[(r, c)]);
        let se: Vec<[(f64, f64); 4]> = speeds
            .par_iter()
            .zip(&sweep.eigenvalues)
            .with_min_len(BANDS_CHUNK)
            .map(|(&v, ev)| {
                perturbed_se(&nominal, v, ev, &entries_cov)
                    .unwrap_or_else(|| self.finite_difference_se(v, ev))
            })
            .collect();
        Ok(Bands { sweep, se })
    }

    /// The standard errors of the eigenvalues `ev` (named as at this speed) at speed `v`, by
    /// central differences through the parameters, each perturbed set's eigenvalues matched to
    /// `ev` ([`super::match_order`]).
    fn finite_difference_se(&self, v: f64, ev: &[Complex<f64>; 4]) -> [(f64, f64); 4] {
        let flat = propagate_se(&self.inputs, 1, 1, |x, _| {
            let perturbed = self
                .canonical_at(x)
                .eigenvalues(v)
                .unwrap_or([Complex::new(f64::NAN, 0.0); 4]);
            super::match_order(ev, &perturbed)
                .iter()
                .flat_map(|z| [z.re, z.im])
                .collect()
        });
        std::array::from_fn(|k| (flat[2 * k], flat[2 * k + 1]))
    }
}

/// The canonical matrices' entries, row by row: M, C₁, K₀, K₂.
fn canonical_entries(c: &Canonical) -> [f64; 16] {
    let mut out = [0.0; 16];
    for (m, matrix) in [c.m, c.c1, c.k0, c.k2].iter().enumerate() {
        for i in 0..2 {
            for j in 0..2 {
                out[4 * m + 2 * i + j] = matrix[(i, j)];
            }
        }
    }
    out
}

/// An eigenvalue whose standard error exceeds this fraction of its distance to the nearest
/// other is propagated by finite differences: near a meeting of two eigenvalues the first
/// derivative changes over the error itself (at 0.25 m/s the lab bicycle's near-double pair
/// −3.68 ± 0.02i has an SE of 0.30 in ω, and the two linearizations differ by 4e-5 of it).
const NEAR_MEETING_SE_FRACTION: f64 = 0.1;

/// The standard errors of each of `ev` (the eigenvalues of `model` at `v`) from the
/// covariance of the canonical entries ([`canonical_entries`]), by [`eigenvalue_gradient`];
/// `None` where a gradient fails or an eigenvalue is near another
/// ([`NEAR_MEETING_SE_FRACTION`]).
fn perturbed_se(
    model: &Canonical,
    v: f64,
    ev: &[Complex<f64>; 4],
    entries_cov: &nalgebra::SMatrix<f64, 16, 16>,
) -> Option<[(f64, f64); 4]> {
    let mut out = [(0.0, 0.0); 4];
    for (k, &lambda) in ev.iter().enumerate() {
        let g = eigenvalue_gradient(model, v, lambda)?;
        let re = nalgebra::SVector::<f64, 16>::from_fn(|i, _| g[i].re);
        let im = nalgebra::SVector::<f64, 16>::from_fn(|i, _| g[i].im);
        let se = (
            re.dot(&(entries_cov * re)).max(0.0).sqrt(),
            im.dot(&(entries_cov * im)).max(0.0).sqrt(),
        );
        let nearest = (0..4)
            .filter(|&j| j != k)
            .map(|j| (ev[j] - lambda).norm())
            .fold(f64::INFINITY, f64::min);
        if se.0.max(se.1) > NEAR_MEETING_SE_FRACTION * nearest {
            return None;
        }
        out[k] = se;
    }
    Some(out)
}

/// dλ/d(entry) of an eigenvalue λ of `model` at speed `v`, for the entries of
/// `canonical_entries`. The state matrix is `A = [[0, I], [X, Y]]` with
/// `[X Y] = −M⁻¹ ([g K₀ + v² K₂, v C₁] − e_δ kᵀ)` (k the controller's gains): a right
/// eigenvector is `(q, λ q)` and a left one `(λ p − Yᵀ p, p)`, with q and p the right and left
/// null vectors of `P(λ) = λ² I − λ Y − X`, and `wᵀ v = pᵀ (2λ I − Y) q`. With `u = M⁻ᵀ p`, first-
/// order perturbation theory gives `dλ/dM_ij = −u_i λ² q_j`, `dλ/dK₀_ij = −g u_i q_j`,
/// `dλ/dK₂_ij = −v² u_i q_j` and `dλ/dC₁_ij = −v u_i λ q_j`, each over `wᵀ v` (since
/// `∂[X Y]/∂M_ij = −M⁻¹ E_ij [X Y]` and `[X Y] (q, λq) = λ² q`). `None` when M is singular or
/// λ is (nearly) a double eigenvalue.
pub fn eigenvalue_gradient(
    model: &Canonical,
    v: f64,
    lambda: Complex<f64>,
) -> Option<[Complex<f64>; 16]> {
    use nalgebra::{Matrix2, Vector2};
    let a = model.state_matrix(v)?.map(|x| Complex::new(x, 0.0));
    let minv = model.m.try_inverse()?.map(|x| Complex::new(x, 0.0));
    let x: Matrix2<Complex<f64>> = a.fixed_view::<2, 2>(2, 0).into_owned();
    let y: Matrix2<Complex<f64>> = a.fixed_view::<2, 2>(2, 2).into_owned();
    let eye = Matrix2::<Complex<f64>>::identity();
    let p = eye * (lambda * lambda) - y * lambda - x;
    // Right null vector from P's larger row, left from its larger column.
    let q = if p.row(0).norm_squared() >= p.row(1).norm_squared() {
        Vector2::new(-p[(0, 1)], p[(0, 0)])
    } else {
        Vector2::new(-p[(1, 1)], p[(1, 0)])
    };
    let w = if p.column(0).norm_squared() >= p.column(1).norm_squared() {
        Vector2::new(-p[(1, 0)], p[(0, 0)])
    } else {
        Vector2::new(-p[(1, 1)], p[(0, 1)])
    };
    let denom = (w.transpose() * (eye * (lambda * 2.0) - y) * q)[(0, 0)];
    let scale = (q[0].norm() + q[1].norm()) * (w[0].norm() + w[1].norm());
    // A (nearly) double eigenvalue, or NaN.
    let floor = 1e-9 * scale * (1.0 + lambda.norm());
    if denom.norm().partial_cmp(&floor) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let u = minv.transpose() * w;
    let mut out = [Complex::new(0.0, 0.0); 16];
    for i in 0..2 {
        for j in 0..2 {
            let base = -u[i] * q[j] / denom;
            out[2 * i + j] = base * lambda * lambda;
            out[4 + 2 * i + j] = base * lambda * v;
            out[8 + 2 * i + j] = base * model.g;
            out[12 + 2 * i + j] = base * v * v;
        }
    }
    out.iter()
        .all(|z| z.re.is_finite() && z.im.is_finite())
        .then_some(out)
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
    /// That covariance as a factor U (parts × measured inputs with an error), `U Uᵀ = cov`
    /// ([`crate::uncertainty::propagate_factor`]).
    pub factor: nalgebra::DMatrix<f64>,
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
        let (_, cov, factor) = propagate_with_factor(&self.inputs, |x| {
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
            factor,
        })
    }
}
