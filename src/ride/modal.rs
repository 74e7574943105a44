//! Modal fit of a ride's free motion: θ(t) and γ(t) after the kick → the weave eigenvalue
//! σ + iω (and real modes where the data support them) with standard errors, and its mode shape.
//!
//! Both signals share the modes (the linear model's solution is a sum of modes, each with one
//! eigenvalue and a fixed roll/steer ratio, seed §3 and Meijaard et al. 2007 §5):
//!
//! ```text
//! θ(t) = e^{στ + ½σ̇τ²} (a_θ cos φ + b_θ sin φ) + Σₖ c_θₖ e^{rₖ τ₀} + o_θ (+ d_θ τ)
//! γ(t) = e^{στ + ½σ̇τ²} (a_γ cos φ + b_γ sin φ) + Σₖ c_γₖ e^{rₖ τ₀} + o_γ (+ d_γ τ)
//! φ = ωτ + ½ω̇τ²,   τ = t − t_ref,   τ₀ = t − t_start
//! ```
//!
//! The coasting bicycle slows down (0.05–0.15 m/s²), so its eigenvalue drifts over the window.
//! The eigenvalue is fitted constant (σ̇ = ω̇ = 0) and applies at `t_ref`, the amplitude-weighted
//! time at which a linear drift leaves the constant fit unbiased (`eigenvalue_time`); there
//! the speed is read. What the drift leaves beyond first order is measured by fitting σ̇ and ω̇
//! too: the eigenvalue of that fit at `t_ref` less the constant fit's is a systematic error
//! ([`Drift`]), added to the standard errors in quadrature (noise-sized on a steady ride, up to
//! 0.2 /s on a ride slowing through the weave speed). Which terms the data support (0–2 real
//! modes, the trends) is chosen by the Bayesian information criterion
//! `Σ_s n ln(RSS_s/n) + k ln N` (separate noise levels for θ and γ). Each signal is
//! weighted by its residual level; standard errors come from the sandwich covariance
//! `H⁻¹ (Σ_s v_s J_sᵀ R_s J_s) H⁻¹` of residuals with AR(1) correlation per signal (their
//! noise, [`crate::fit::ar1_sandwich`]), beside the white residuals' `s² (JᵀWJ)⁻¹`,
//! and are checked by a moving-block bootstrap of the residuals (one Gauss–Newton step per
//! resample).

use crate::fit::{clamp, free_system, levenberg_marquardt, marquardt_step, Estimate, LeastSquares};
use nalgebra::{Complex, DMatrix, DVector};
use std::ops::ControlFlow;

/// The fewest samples a window may hold: below it the fit is refused ([`ModalError::TooShort`]),
/// and no reader hands it such a window.
pub const MIN_SAMPLES: usize = 40;

/// The most real modes a fit carries beside the weave.
pub const MAX_REAL_MODES: usize = 2;

/// Errors of the modal fit.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ModalError {
    #[error("the window holds {0} samples: too few to fit the modes")]
    TooShort(usize),
    #[error("no weave found: no oscillation in roll and steer after the kick fits")]
    NoWeave,
}

/// Which terms beside the weave a fit carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Structure {
    /// Real modes (capsize, castor) beside the weave: 0, 1 or 2 ([`MAX_REAL_MODES`]; a
    /// structure asked for with more is fitted with that many).
    pub real_modes: usize,
    /// The weave's eigenvalue drifts linearly in time (σ̇, ω̇): only in the drift's check.
    pub drift: bool,
    /// Linear trends beside the offsets.
    pub trend: bool,
    /// Powers of τ beyond the trend, τ² and up (0–[`MAX_CURVE_TERMS`]; only with `trend`): the
    /// slow part of the motion (a capsize mode, the sensors' drift) as a fixed basis
    /// ([`Estimator::Projected`]). Left out of the JSON when 0.
    #[serde(skip_serializing_if = "is_zero")]
    pub curve_terms: usize,
}

/// Whether `n` is 0 (a field left out of the JSON).
fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// The most powers of τ beyond the trend a structure carries ([`Structure::curve_terms`]): τ²
/// and τ³.
pub const MAX_CURVE_TERMS: usize = 2;

impl Structure {
    /// The weave with offsets and trends only.
    pub const WEAVE_AND_TRENDS: Structure = Structure {
        real_modes: 0,
        drift: false,
        trend: true,
        curve_terms: 0,
    };
    fn nonlinear(&self) -> usize {
        2 + if self.drift { 2 } else { 0 } + self.real_modes
    }
    /// The powers of τ in the slow basis beyond the offset: the trend's and the curve's.
    fn powers(&self) -> usize {
        if self.trend {
            1 + self.curve_terms.min(MAX_CURVE_TERMS)
        } else {
            0
        }
    }
    /// Linear parameters per signal.
    fn linear(&self) -> usize {
        2 + self.real_modes + 1 + self.powers()
    }
    fn params(&self) -> usize {
        self.nonlinear() + 2 * self.linear()
    }
}

/// An eigenvalue with standard errors: the noise's (from the covariance, checked by residual
/// resampling) and the drift's, combined in quadrature in `re_se`, `im_se`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Eigenvalue {
    pub re: f64,
    pub im: f64,
    /// Total standard errors: noise and drift.
    pub re_se: f64,
    pub im_se: f64,
    /// The noise's standard errors were the residuals white: from the covariance
    /// `s² (JᵀWJ)⁻¹`.
    pub re_se_noise: f64,
    pub im_se_noise: f64,
    /// How much the noise's errors grow for residuals that are not white (σ, ω): the
    /// correlated residuals' errors over `re_se_noise`, `im_se_noise` (the AR(1) sandwich of
    /// a roll-and-steer fit, √((1 + ρ)/(1 − ρ)) of a roll-rate fit). `re_se`, `im_se` hold
    /// the grown errors.
    pub noise_inflation: [f64; 2],
    /// Correlation of the real and imaginary parts' noise errors.
    pub re_im_corr: f64,
    /// The noise's standard errors from the moving-block bootstrap of the residuals.
    pub re_se_resampled: f64,
    pub im_se_resampled: f64,
    /// The drift's systematic errors: |Re|, |Im| of [`Drift::shift`] (0 when not measured).
    pub re_se_drift: f64,
    pub im_se_drift: f64,
}

impl Eigenvalue {
    /// The total standard errors `[re, im]` were the fit's residuals white: each part's
    /// noise error taken back to `re_se_noise`, `im_se_noise`, every other term (drift,
    /// and what later stages add in quadrature) kept — the errors as they were before issue 75,
    /// for the between-kick scatter's comparison.
    pub fn se_if_white(&self) -> [f64; 2] {
        let part = |total: f64, white: f64, inflation: f64| {
            (total.powi(2) - (white * inflation).powi(2) + white.powi(2))
                .max(0.0)
                .sqrt()
        };
        [
            part(self.re_se, self.re_se_noise, self.noise_inflation[0]),
            part(self.im_se, self.im_se_noise, self.noise_inflation[1]),
        ]
    }
}

/// How far the weave's eigenvalue drifted over the window: a second fit with λ(t) = λ(t_ref) +
/// λ̇ (t − t_ref), the same modes and trends.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Drift {
    /// σ̇ and ω̇ (1/s²).
    pub sigma_rate: Estimate,
    pub omega_rate: Estimate,
    /// λ(t_ref) of the drifting fit less the constant fit's λ: `[re, im]` (1/s).
    pub shift: [f64; 2],
}

/// The weave's mode shape: γ/θ as a complex ratio at the eigenvalue with ω > 0.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ModeShape {
    /// |γ|/|θ| (rad/rad).
    pub ratio: Estimate,
    /// arg(γ/θ) (rad): positive when steer leads roll.
    pub phase_rad: Estimate,
}

/// The fit of a ride's free motion.
#[derive(Debug, Clone)]
pub struct ModalFit {
    pub structure: Structure,
    /// The window fitted (s).
    pub start_s: f64,
    pub end_s: f64,
    /// Where the eigenvalue applies: the amplitude-weighted time of the window (s).
    pub t_ref_s: f64,
    pub weave: Eigenvalue,
    /// The eigenvalue's drift over the window; `None` when its fit failed.
    pub drift: Option<Drift>,
    /// The real modes' rates (1/s), slowest first.
    pub real_modes: Vec<Estimate>,
    pub shape: ModeShape,
    /// Variance accounted for, θ and γ (fraction of the window's variance, 0–1).
    pub vaf: [f64; 2],
    /// Residual RMS of θ and γ (rad).
    pub residual_rms_rad: [f64; 2],
    pub samples: usize,
    pub bic: f64,
    /// How the fit's solves ended: converged or at their iteration limit.
    pub solver: Solver,
    /// The model of the free response and its solver: a replay of the ride is fitted by it.
    pub estimator: Estimator,
    params: Vec<f64>,
}

impl ModalFit {
    /// The weave's part of θ at time `t` as a phasor: θ_weave(t) = Re(A) (rad), A turning with
    /// the fitted eigenvalue.
    pub fn weave_roll_phasor(&self, t: f64) -> Complex<f64> {
        let st = self.structure;
        let p = &self.params;
        let (e, cos, sin) = carrier(p, st, t - self.t_ref_s);
        let l = st.nonlinear();
        Complex::new(p[l], -p[l + 1]) * Complex::new(e * cos, e * sin)
    }

    /// The weave's steer amplitude (rad) where its eigenvalue applies, at the window's
    /// amplitude-weighted time: |A(t_ref)|·|γ/θ|. Where a dry friction's equivalent damping is
    /// taken (`gap::effects::for_ride`).
    pub fn weave_steer_amplitude_rad(&self) -> f64 {
        self.weave_roll_phasor(self.t_ref_s).norm() * self.shape.ratio.value
    }

    /// The real modes' part of θ and γ at time `t`, and its rates: `[θ, γ, θ̇, γ̇]` (rad, rad/s).
    pub fn real_modes_state(&self, t: f64) -> [f64; 4] {
        let st = self.structure;
        let p = &self.params;
        let mut out = [0.0; 4];
        for s in 0..2 {
            let l = st.nonlinear() + s * st.linear();
            for k in 0..st.real_modes {
                let rate = p[real_index(st, k)];
                let x = p[l + 2 + k] * (rate * (t - self.start_s)).exp();
                out[s] += x;
                out[s + 2] += rate * x;
            }
        }
        out
    }

    /// The fitted θ and γ at time `t` (s).
    pub fn eval(&self, t: f64) -> [f64; 2] {
        let st = self.structure;
        let p = &self.params;
        model_values(p, st, t - self.t_ref_s, t - self.start_s)
    }
}

/// The values of the model's two signals (θ, γ) at τ, τ₀.
fn model_values(p: &[f64], st: Structure, tau: f64, tau0: f64) -> [f64; 2] {
    let (e, cos, sin) = carrier(p, st, tau);
    let mut exps = [0.0; MAX_REAL_MODES];
    for (k, ex) in exps.iter_mut().enumerate().take(st.real_modes) {
        *ex = (p[real_index(st, k)] * tau0).exp();
    }
    combine(p, st, [e * cos, e * sin], &exps, tau)
}

/// The two signals from the nonlinear functions at one time: the weave's `E (cos φ, sin φ)`,
/// the real modes' exponentials, and τ for the trend.
#[inline(always)]
fn combine(p: &[f64], st: Structure, wave: [f64; 2], exps: &[f64], tau: f64) -> [f64; 2] {
    [
        combine_one(p, st, wave, exps, tau, 0),
        combine_one(p, st, wave, exps, tau, 1),
    ]
}

/// Signal `s` of [`combine`] (a function rather than a closure, so that it inlines).
#[inline(always)]
fn combine_one(p: &[f64], st: Structure, wave: [f64; 2], exps: &[f64], tau: f64, s: usize) -> f64 {
    let l = st.nonlinear() + s * st.linear();
    let mut x = p[l] * wave[0] + p[l + 1] * wave[1];
    for (k, ex) in exps.iter().enumerate().take(st.real_modes) {
        x += p[l + 2 + k] * ex;
    }
    x += p[l + 2 + st.real_modes];
    if st.trend {
        x += p[l + 3 + st.real_modes] * tau;
        let mut power = tau;
        for k in 1..st.powers() {
            power *= tau;
            x += p[l + 3 + st.real_modes + k] * power;
        }
    }
    x
}

/// The nonlinear functions of time at every sample of a window, for one parameter vector:
/// what every residual and Jacobian row is built from.
struct Basis {
    /// The weave's `E (cos φ, sin φ)`: `exp((σ + iω)τ + ½(σ̇ + iω̇)τ²)`.
    wave: Vec<[f64; 2]>,
    /// The real modes' `exp(r_k τ₀)`.
    real: Vec<[f64; MAX_REAL_MODES]>,
}

/// Samples between two exact evaluations of the recurrences in [`Problem::basis`]: the
/// products' rounding grows with the run (below 1e-14 relative over 32 samples).
const BASIS_RUN: usize = 32;

/// The iterations a modal fit's Levenberg–Marquardt may take (every fit of an IMU ride's; a
/// structure's search in [`ModalOptions::search_iterations`]).
pub const SOLVE_ITERATIONS: usize = 200;

/// Samples between two checks of a trial's partial cost against the cost to beat
/// ([`Problem::rss_within`]).
const BOUND_EVERY: usize = 16;

fn real_index(st: Structure, k: usize) -> usize {
    2 + if st.drift { 2 } else { 0 } + k
}

/// The weave's envelope and carrier at τ: `(E, cos φ, sin φ)`.
fn carrier(p: &[f64], st: Structure, tau: f64) -> (f64, f64, f64) {
    let (sd, wd) = if st.drift { (p[2], p[3]) } else { (0.0, 0.0) };
    let e = (p[0] * tau + 0.5 * sd * tau * tau).exp();
    let (sin, cos) = (p[1] * tau + 0.5 * wd * tau * tau).sin_cos();
    (e, cos, sin)
}

/// The most parameters one residual depends on: the nonlinear ones (σ, ω, their drifts, the
/// real modes' rates) and its own signal's linear ones.
const MAX_ROW: usize = 2 + 2 + MAX_REAL_MODES + MAX_LINEAR;

/// The most linear parameters of one signal: the weave's two, the real modes', offset, trend
/// and the curve's powers.
const MAX_LINEAR: usize = 2 + MAX_REAL_MODES + 2 + MAX_CURVE_TERMS;

/// `$body` with `$c` bound to the structure `$st` as a constant, one copy per structure a
/// fit can have: the per-sample loops it inlines ([`Problem::each_basis`], [`combine`],
/// [`Problem::sparse_rows`]) then know their widths and branches when compiled. The same
/// operations in the same order, so the same numbers bit for bit.
macro_rules! for_structure {
    ($st:expr, |$c:ident| $body:expr) => {
        for_structure!(@arms $st, $c, $body;
            (0, false, false) (0, true, false) (1, false, false) (1, true, false)
            (2, false, false) (2, true, false) (0, false, true) (0, true, true)
            (1, false, true) (1, true, true) (2, false, true) (2, true, true))
    };
    (@arms $st:expr, $c:ident, $body:expr; $(($r:literal, $t:literal, $d:literal))*) => {
        match $st {
            $(Structure { real_modes: $r, trend: $t, drift: $d, curve_terms: 0 } => {
                let $c = Structure { real_modes: $r, trend: $t, drift: $d, curve_terms: 0 };
                $body
            })*
            other => {
                let $c = other;
                $body
            }
        }
    };
}

/// The weighted least-squares problem: rows 0..n are θ, n..2n are γ, each times its weight.
struct Problem<'a> {
    t: &'a [f64],
    x: [&'a [f64]; 2],
    weight: [f64; 2],
    t_ref: f64,
    t0: f64,
    st: Structure,
    estimator: Estimator,
}

impl Problem<'_> {
    fn n(&self) -> usize {
        self.t.len()
    }

    /// The nonlinear functions at every sample ([`Basis`]). On a uniform stretch of samples
    /// (step h) the exponentials follow recurrences, the exact ones evaluated every
    /// [`BASIS_RUN`] samples and wherever the step changes (a dropped packet):
    /// `z(τ + h) = z(τ) ρ(τ)`, `ρ(τ + h) = ρ(τ) exp(b h²)` for `z = exp(aτ + ½bτ²)` and
    /// `ρ(τ) = exp(a h + b (τ h + ½h²))` — one complex product per sample where `exp` and
    /// `sin_cos` took a third of a campaign's ride fits.
    fn basis(&self, p: &[f64]) -> Basis {
        let n = self.n();
        let mut wave = Vec::with_capacity(n);
        let mut real = Vec::with_capacity(n);
        let _ = for_structure!(self.st, |st| self.each_basis(st, p, |_, w, ex| {
            wave.push(w);
            real.push(*ex);
            ControlFlow::Continue(())
        }));
        Basis { wave, real }
    }

    /// The nonlinear functions of [`Problem::basis`], handed sample by sample to `visit`
    /// (index, the weave's `E (cos φ, sin φ)`, the real modes' exponentials) until it breaks:
    /// one pass, nothing stored, the same values. `st` is the problem's structure (as a
    /// constant from [`for_structure`]).
    #[inline(always)]
    fn each_basis(
        &self,
        st: Structure,
        p: &[f64],
        mut visit: impl FnMut(usize, [f64; 2], &[f64; MAX_REAL_MODES]) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        let n = self.n();
        let a = Complex::new(p[0], p[1]);
        let b = if st.drift {
            Complex::new(p[2], p[3])
        } else {
            Complex::new(0.0, 0.0)
        };
        let mut rates = [0.0; MAX_REAL_MODES];
        for (k, r) in rates.iter_mut().enumerate().take(st.real_modes) {
            *r = p[real_index(st, k)];
        }
        let rates = &rates[..st.real_modes];
        let (mut z, mut rho, mut q) = (Complex::new(0.0, 0.0), a, a);
        let mut ex = [0.0; MAX_REAL_MODES];
        let mut ex_step = [0.0; MAX_REAL_MODES];
        let mut step = f64::NAN;
        let mut run = 0;
        for i in 0..n {
            let tau = self.t[i] - self.t_ref;
            let tau0 = self.t[i] - self.t0;
            let h = if i > 0 {
                self.t[i] - self.t[i - 1]
            } else {
                f64::NAN
            };
            // Timestamps of one uniform grid differ by their rounding: 1e-14 s at 100 s, 2e-11
            // s at 28 h (a long recording's row numbers at 100 Hz, where a tolerance of the
            // step's alone sent every sample to the exact evaluation).
            let rounding = 8.0 * f64::EPSILON * self.t[i].abs();
            if run < BASIS_RUN && (h - step).abs() <= 1e-9 * step.abs() + rounding {
                z *= rho;
                rho *= q;
                for k in 0..st.real_modes {
                    ex[k] *= ex_step[k];
                }
                run += 1;
            } else {
                z = (a * tau + b * (0.5 * tau * tau)).exp();
                for (k, &r) in rates.iter().enumerate() {
                    ex[k] = (r * tau0).exp();
                }
                // The step to the next sample, assumed the next one's too.
                step = if i + 1 < n {
                    self.t[i + 1] - self.t[i]
                } else {
                    f64::NAN
                };
                rho = (a * step + b * (tau * step + 0.5 * step * step)).exp();
                q = (b * (step * step)).exp();
                for (k, &r) in rates.iter().enumerate() {
                    ex_step[k] = (r * step).exp();
                }
                run = 0;
            }
            visit(i, [z.re, z.im], &ex)?;
        }
        ControlFlow::Continue(())
    }

    /// How much of the fitted motion at `p` the weave carries over the window, per signal: the
    /// variance of its part against that of the whole fitted curve (`[θ, γ]`, 0–1).
    fn weave_share(&self, p: &[f64]) -> [f64; 2] {
        let st = self.st;
        let basis = self.basis(p);
        let var = |x: &[f64]| {
            let m = x.iter().sum::<f64>() / x.len().max(1) as f64;
            x.iter().map(|v| (v - m).powi(2)).sum::<f64>()
        };
        [0, 1].map(|s| {
            let l = st.nonlinear() + s * st.linear();
            let (weave, all): (Vec<f64>, Vec<f64>) = (0..self.n())
                .map(|i| {
                    let wave = basis.wave[i];
                    let v = combine_one(p, st, wave, &basis.real[i], self.t[i] - self.t_ref, s);
                    (p[l] * wave[0] + p[l + 1] * wave[1], v)
                })
                .unzip();
            var(&weave) / var(&all).max(1e-300)
        })
    }

    /// Per-signal residual sums of squares (unweighted, rad²).
    fn rss(&self, p: &[f64]) -> [f64; 2] {
        self.rss_within(p, f64::INFINITY)
    }

    /// [`Problem::rss`], its sums cut short once the weighted cost they make exceeds `bound`
    /// (checked every [`BOUND_EVERY`] samples): sums of squares only grow, so a cost found
    /// above `bound` that way is above it whole, and the whole cost where it is not.
    fn rss_within(&self, p: &[f64], bound: f64) -> [f64; 2] {
        let mut out = [0.0; 2];
        let _ = for_structure!(self.st, |st| self.each_basis(st, p, |i, wave, ex| {
            let values = combine(p, st, wave, ex, self.t[i] - self.t_ref);
            for s in 0..2 {
                out[s] += (values[s] - self.x[s][i]).powi(2);
            }
            if (i + 1) % BOUND_EVERY == 0 && self.weighted(out) > bound {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        }));
        out
    }

    /// The weighted cost of per-signal sums of squares.
    fn weighted(&self, rss: [f64; 2]) -> f64 {
        self.weight[0].powi(2) * rss[0] + self.weight[1].powi(2) * rss[1]
    }

    /// The linear parameters for fixed nonlinear ones (per signal, normal equations with
    /// columns scaled to unit norm); `None` when singular.
    fn project(&self, nonlinear: &[f64]) -> Option<Vec<f64>> {
        let st = self.st;
        let nl = st.linear();
        let mut p = nonlinear.to_vec();
        p.resize(st.params(), 0.0);
        // The columns are θ's and γ's alike.
        let basis = self.basis(&p);
        let rows: Vec<[f64; MAX_LINEAR]> =
            (0..self.n()).map(|i| self.linear_row(&basis, i)).collect();
        let mut norms = [0.0f64; MAX_LINEAR];
        for r in &rows {
            for (k, v) in r.iter().enumerate().take(nl) {
                norms[k] += v * v;
            }
        }
        let norms = norms.map(|v| v.sqrt().max(1e-300));
        // The normal matrix is θ's and γ's alike: summed once (in fixed arrays, no bounds to
        // check), factored once; each signal sums its own right-hand side.
        let mut sums = [[0.0; MAX_LINEAR]; MAX_LINEAR];
        for r in &rows {
            for i in 0..nl {
                let ri = r[i] / norms[i];
                for j in 0..nl {
                    sums[i][j] += ri * r[j] / norms[j];
                }
            }
        }
        let ata = DMatrix::<f64>::from_fn(nl, nl, |i, j| sums[i][j]);
        let ch = ata.cholesky()?;
        for s in 0..2 {
            let mut atb = DVector::<f64>::zeros(nl);
            for (r, &x) in rows.iter().zip(self.x[s]) {
                for i in 0..nl {
                    atb[i] += r[i] / norms[i] * x;
                }
            }
            let sol = ch.solve(&atb);
            let l = st.nonlinear() + s * nl;
            for i in 0..nl {
                p[l + i] = sol[i] / norms[i];
            }
        }
        p.iter().all(|v| v.is_finite()).then_some(p)
    }

    /// The columns of the linear parameters at sample `i` (the same for θ and γ); entries
    /// beyond [`Structure::linear`] are zero.
    fn linear_row(&self, basis: &Basis, i: usize) -> [f64; MAX_LINEAR] {
        let st = self.st;
        let mut row = [0.0; MAX_LINEAR];
        row[0] = basis.wave[i][0];
        row[1] = basis.wave[i][1];
        row[2..2 + st.real_modes].copy_from_slice(&basis.real[i][..st.real_modes]);
        row[2 + st.real_modes] = 1.0;
        if st.trend {
            let tau = self.t[i] - self.t_ref;
            let mut power = tau;
            row[3 + st.real_modes] = power;
            for k in 1..st.powers() {
                power *= tau;
                row[3 + st.real_modes + k] = power;
            }
        }
        row
    }

    /// Sample `i`'s two weighted residuals and their Jacobian rows, each row held sparse: its
    /// first `nonlinear()` entries are the columns `0..nonlinear()`, the next `linear()` its
    /// signal's linear columns (θ's, then γ's); every other column of the row is zero.
    /// `st` is the problem's structure (as a constant from [`for_structure`]).
    #[inline(always)]
    fn sparse_rows(
        &self,
        st: Structure,
        p: &[f64],
        basis: &Basis,
        i: usize,
    ) -> [([f64; MAX_ROW], f64); 2] {
        // Called twice rather than through `[0, 1].map` (whose machinery took a third of the
        // ride fits), and a function rather than a closure, so that it inlines.
        [
            self.sparse_row(st, p, basis, i, 0),
            self.sparse_row(st, p, basis, i, 1),
        ]
    }

    /// Signal `s`'s row of [`Problem::sparse_rows`].
    #[inline(always)]
    fn sparse_row(
        &self,
        st: Structure,
        p: &[f64],
        basis: &Basis,
        i: usize,
        s: usize,
    ) -> ([f64; MAX_ROW], f64) {
        let t = self.t[i];
        let tau = t - self.t_ref;
        let tau0 = t - self.t0;
        let [ecos, esin] = basis.wave[i];
        let exps = &basis.real[i][..st.real_modes];
        let nn = st.nonlinear();
        let w = self.weight[s];
        let mut row = [0.0; MAX_ROW];
        let l = nn + s * st.linear();
        let (a, b) = (p[l], p[l + 1]);
        let osc = a * ecos + b * esin;
        let dosc = -a * esin + b * ecos;
        row[0] = w * tau * osc;
        row[1] = w * tau * dosc;
        if st.drift {
            row[2] = w * 0.5 * tau * tau * osc;
            row[3] = w * 0.5 * tau * tau * dosc;
        }
        row[nn] = w * ecos;
        row[nn + 1] = w * esin;
        let mut m = osc;
        for (k, &ex) in exps.iter().enumerate() {
            let c = p[l + 2 + k];
            m += c * ex;
            row[real_index(st, k)] = w * c * tau0 * ex;
            row[nn + 2 + k] = w * ex;
        }
        m += p[l + 2 + st.real_modes];
        row[nn + 2 + st.real_modes] = w;
        if st.trend {
            m += p[l + 3 + st.real_modes] * tau;
            row[nn + 3 + st.real_modes] = w * tau;
            let mut power = tau;
            for k in 1..st.powers() {
                power *= tau;
                m += p[l + 3 + st.real_modes + k] * power;
                row[nn + 3 + st.real_modes + k] = w * power;
            }
        }
        (row, w * (m - self.x[s][i]))
    }

    /// The column of the full Jacobian that entry `j` of signal `s`'s sparse row stands for.
    fn column(&self, s: usize, j: usize) -> usize {
        let nn = self.st.nonlinear();
        if j < nn {
            j
        } else {
            j + s * self.st.linear()
        }
    }

    /// The nonzero entries of a sparse row: the nonlinear parameters and one signal's linear ones.
    fn row_width(&self) -> usize {
        self.st.nonlinear() + self.st.linear()
    }
}

impl LeastSquares for Problem<'_> {
    fn residuals_and_jacobian(&self, p: &[f64], jac: &mut DMatrix<f64>, r: &mut DVector<f64>) {
        let n = self.n();
        let width = self.row_width();
        jac.fill(0.0);
        let basis = self.basis(p);
        for i in 0..n {
            for (s, (row, res)) in self
                .sparse_rows(self.st, p, &basis, i)
                .into_iter()
                .enumerate()
            {
                for (j, &v) in row[..width].iter().enumerate() {
                    jac[(i + s * n, self.column(s, j))] = v;
                }
                r[i + s * n] = res;
            }
        }
    }

    fn cost(&self, p: &[f64]) -> f64 {
        self.weighted(self.rss(p))
    }

    /// The real modes' rates held within [`CASTOR_RATES`] by [`Estimator::Projected`]; no
    /// bounds otherwise.
    fn bounds(&self, i: usize) -> (f64, f64) {
        let st = self.st;
        let real = real_index(st, 0)..real_index(st, st.real_modes);
        match self.estimator {
            Estimator::Projected { .. } if real.contains(&i) => (CASTOR_RATES[0], CASTOR_RATES[1]),
            _ => (f64::NEG_INFINITY, f64::INFINITY),
        }
    }

    fn cost_within(&self, p: &[f64], bound: f64) -> f64 {
        self.weighted(self.rss_within(p, bound))
    }

    /// `JᵀJ` and `Jᵀr` summed over the sparse rows of [`Problem::sparse_rows`]: a row touches
    /// at most [`MAX_ROW`] of the columns, so each sample adds two small outer products (the
    /// stored Jacobian's product spent a fifth of a campaign's analysis on its zeros).
    fn accepted_normal_equations(
        &self,
        p: &[f64],
        _jac: &mut DMatrix<f64>,
        r: &mut DVector<f64>,
        h: &mut DMatrix<f64>,
        g: &mut DVector<f64>,
    ) {
        let width = self.row_width();
        // Per signal, the sums over its sparse rows; scattered into h and g at the end.
        let mut hs = [[[0.0; MAX_ROW]; MAX_ROW]; 2];
        let mut gs = [[0.0; MAX_ROW]; 2];
        let basis = self.basis(p);
        // One instance per structure, its rows' widths and branches known to the compiler.
        for_structure!(self.st, |st| self
            .accumulate(st, p, &basis, r, &mut hs, &mut gs));
        h.fill(0.0);
        g.fill(0.0);
        for (s, (hs, gs)) in hs.iter().zip(&gs).enumerate() {
            for a in 0..width {
                let ca = self.column(s, a);
                g[ca] += gs[a];
                for (b, &v) in hs[a].iter().enumerate().take(width).skip(a) {
                    let cb = self.column(s, b);
                    h[(ca, cb)] += v;
                    if ca != cb {
                        h[(cb, ca)] += v;
                    }
                }
            }
        }
    }
}

impl Problem<'_> {
    /// The sums `Σ row rowᵀ` (upper triangle) and `Σ row r` over every sample's two sparse
    /// rows (of [`Problem::row_width`]; entries beyond it are zero), the weighted residuals
    /// written to `r`. `st` is the problem's structure (as a constant from [`for_structure`]).
    #[inline(always)]
    fn accumulate(
        &self,
        st: Structure,
        p: &[f64],
        basis: &Basis,
        r: &mut DVector<f64>,
        hs: &mut [[[f64; MAX_ROW]; MAX_ROW]; 2],
        gs: &mut [[f64; MAX_ROW]; 2],
    ) {
        let n = self.n();
        let width = st.nonlinear() + st.linear();
        for i in 0..n {
            for (s, (row, res)) in self.sparse_rows(st, p, basis, i).into_iter().enumerate() {
                r[i + s * n] = res;
                for a in 0..width {
                    gs[s][a] += row[a] * res;
                    for b in a..width {
                        hs[s][a][b] += row[a] * row[b];
                    }
                }
            }
        }
    }
}

/// The white-noise level of a smooth signal sampled finely: the RMS of its second differences
/// over √6 (the motion's own second difference is (ωΔt)² of its amplitude, negligible at 100 Hz).
fn noise_level(x: &[f64]) -> f64 {
    let d: Vec<f64> = x.windows(3).map(|w| w[0] - 2.0 * w[1] + w[2]).collect();
    (d.iter().map(|v| v * v).sum::<f64>() / d.len().max(1) as f64 / 6.0).sqrt()
}

/// The dominant angular frequency (rad/s) of θ and γ together over 1–20 rad/s: the largest
/// weighted periodogram on a 0.02 rad/s grid, each signal less its least-squares parabola
/// (a slow real mode's drift would otherwise leak into the low frequencies).
fn dominant_omega(t: &[f64], x: [&[f64]; 2], weight: [f64; 2]) -> f64 {
    const STEP_RAD_PER_S: f64 = 0.02;
    let mut best = (0.0, 1.0);
    let centred: Vec<Vec<f64>> = x.iter().map(|s| less_parabola(t, s)).collect();
    // Each sample's phasor e^{iω(tᵢ − t₀)}, advanced from one ω to the next by a rotation
    // (e^{iΔω(tᵢ − t₀)}, the samples' times need not be even) and set afresh every 64 steps
    // so that rounding cannot build up: a sine and cosine per sample every 64 frequencies
    // instead of every one.
    let step: Vec<(f64, f64)> = t
        .iter()
        .map(|&ti| (STEP_RAD_PER_S * (ti - t[0])).sin_cos())
        .collect();
    let mut phasor = vec![(0.0, 1.0); t.len()];
    let mut omega = 1.0;
    let mut k = 0usize;
    while omega <= 20.0 {
        if k % 64 == 0 {
            for (p, &ti) in phasor.iter_mut().zip(t) {
                *p = (omega * (ti - t[0])).sin_cos();
            }
        }
        let (mut c, mut sn) = ([0.0; 2], [0.0; 2]);
        for (i, &(si, ci)) in phasor.iter().enumerate() {
            for s in 0..2 {
                c[s] += centred[s][i] * ci;
                sn[s] += centred[s][i] * si;
            }
        }
        for (p, &(ss, cs)) in phasor.iter_mut().zip(&step) {
            *p = (p.0 * cs + p.1 * ss, p.1 * cs - p.0 * ss);
        }
        k += 1;
        let mut power = 0.0;
        for s in 0..2 {
            power += weight[s].powi(2) * (c[s] * c[s] + sn[s] * sn[s]);
        }
        if power > best.0 {
            best = (power, omega);
        }
        omega += STEP_RAD_PER_S;
    }
    best.1
}

fn less_parabola(t: &[f64], x: &[f64]) -> Vec<f64> {
    let t0 = t[0];
    let span = (t[t.len() - 1] - t0).max(1e-9);
    let mut ata = nalgebra::Matrix3::<f64>::zeros();
    let mut atb = nalgebra::Vector3::<f64>::zeros();
    for (&ti, &xi) in t.iter().zip(x) {
        let u = (ti - t0) / span;
        let row = nalgebra::Vector3::new(1.0, u, u * u);
        ata += row * row.transpose();
        atb += row * xi;
    }
    let c = ata
        .cholesky()
        .map_or(nalgebra::Vector3::zeros(), |ch| ch.solve(&atb));
    t.iter()
        .zip(x)
        .map(|(&ti, &xi)| {
            let u = (ti - t0) / span;
            xi - c[0] - c[1] * u - c[2] * u * u
        })
        .collect()
}

/// Options of [`fit_modes`].
#[derive(Debug, Clone, Copy)]
pub struct ModalOptions {
    /// Bootstrap resamples for the check of the standard errors.
    pub resamples: usize,
    /// Seed of the resampling.
    pub seed: u64,
    /// Fit this structure only instead of choosing one by the information criterion, and skip
    /// the drift's check: to repeat on a model's curve exactly the fit a ride got.
    pub only: Option<Structure>,
    /// Where to start instead of the searches (the periodogram's frequency and a grid of σ
    /// and of the real rates): for a replay of a model, whose eigenvalues are known.
    pub start: Option<Start>,
    /// The information criterion chooses among structures with at least this many real modes
    /// (a window that starts in the castor's tail carries it, whether or not the noise lets
    /// the criterion see it).
    pub min_real_modes: usize,
    /// The iterations each structure's fit may take while the information criterion chooses
    /// among them ([`SOLVE_ITERATIONS`] by default; the chosen one is fitted again with that
    /// many).
    pub search_iterations: usize,
    /// The model of the free response and how it is solved.
    pub estimator: Estimator,
}

/// The model of a kicked bicycle's free response a fit uses beside the weave, and its solver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum Estimator {
    /// Up to [`MAX_REAL_MODES`] free real modes and optional trends, each structure solved by
    /// Levenberg–Marquardt on every parameter to at most its iteration budget, the structure
    /// chosen by the information criterion. Many solves end at the budget along a real mode's
    /// valley, which then acts as a regulariser (issue 75): every report and calibration of
    /// today is made with it.
    #[default]
    Capped,
    /// The stated model of issue 75: θ and γ share the weave; the castor, the one fast real
    /// mode a kick leaves, enters with its rate held within [`CASTOR_RATES`] (or not at all);
    /// the slow part of the motion (a capsize mode of |rate| ≲ 1/s over a window of a few
    /// seconds, the sensors' offsets and drift) is a fixed polynomial basis to τ^(1 +
    /// `curve_terms`). With a single bounded real mode the least-squares problem has no valley:
    /// variable projection (the amplitudes solved exactly at every step, Golub and Pereyra
    /// 1973; Newton's step on the reduced cost, `solve_projected`) converges, and every solve
    /// is run to its convergence test (the step left below `fit::CONVERGED_STEP_SE` of each
    /// error). Which of castor or none, and how many curve terms, the information criterion
    /// chooses among the structures whose weave carries the motion ([`MIN_WEAVE_SHARE`]).
    /// `iterations` bounds every solve ([`PROJECTED_ITERATIONS`] by default): a guard for a
    /// pathological window, not a regulariser. Not yet the ride stage's: the measurements are
    /// in
    /// [docs/decisions/2026-12-02-ride-estimator.md](../../docs/decisions/2026-12-02-ride-estimator.md).
    Projected {
        curve_terms: usize,
        iterations: usize,
    },
}

/// The least share of the fitted motion the weave must carry in θ or in γ (the variance of
/// its part over that of the whole fitted curve) for a structure of [`Estimator::Projected`]
/// to be a candidate. Over a window of about half a weave cycle (a slow ride whose roll leaves
/// the linear range soon after the kick) the polynomial and the castor can take the motion and
/// leave a fast, faint oscillation as the "weave": of the 299 fits of tests/speed.rs's
/// simulated rides, the six below a tenth (0.03–9 % of the motion) read ω at 1.3–3 times the
/// truth, one of them 4.4 of its errors off, the others within errors of 0.5–5 rad/s; the rest
/// carried 20 % or more. The measurements:
/// [docs/decisions/2026-12-02-ride-estimator.md](../../docs/decisions/2026-12-02-ride-estimator.md#2026-12-04-ninth-session-the-stated-model-on-main-beside-todays).
pub const MIN_WEAVE_SHARE: f64 = 0.1;

/// Whether the structure fitted at `p` is a weave fit: always for [`Estimator::Capped`] (its
/// calibration is made without the test); for [`Estimator::Projected`] the weave carries at
/// least [`MIN_WEAVE_SHARE`] of the fitted motion in θ or in γ.
fn identifiable(problem: &Problem<'_>, p: &[f64]) -> bool {
    match problem.estimator {
        Estimator::Capped => true,
        Estimator::Projected { .. } => {
            let share = problem.weave_share(p);
            share[0].max(share[1]) >= MIN_WEAVE_SHARE
        }
    }
}

impl Estimator {
    /// [`Estimator::Projected`] with τ² and τ³ allowed and its default iteration bound.
    pub const PROJECTED: Estimator = Estimator::Projected {
        curve_terms: MAX_CURVE_TERMS,
        iterations: PROJECTED_ITERATIONS,
    };
}

/// The castor's rate (1/s) as [`Estimator::Projected`] holds it: slower than 1/s it is a slow
/// mode the polynomial carries, and faster than 60/s it is gone within the first samples of a
/// 100 Hz window.
pub const CASTOR_RATES: [f64; 2] = [-60.0, -1.0];

/// The iterations a solve of [`Estimator::Projected`] may take by default: a bound for a
/// pathological window, not a regulariser (on data/ and the real decays of
/// `../shared/reference` its solves converged within 15 iterations:
/// docs/decisions/2026-12-02-ride-estimator.md).
pub const PROJECTED_ITERATIONS: usize = 400;

/// A fit's starting point ([`ModalOptions::start`]): the weave's `[σ, ω]` and the real modes'
/// rates (1/s; those beyond the structure's count unused).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Start {
    pub weave: [f64; 2],
    pub real_rates: [f64; MAX_REAL_MODES],
}

/// A replay fitted as the ride was (by `estimator`): the structure `st` only, from `start`,
/// without resampling; where the replayed motion makes that fit fail (a model's weave alone
/// excites no real mode), the same without real modes. `None` when both fail.
pub fn refit_as(
    t_s: &[f64],
    roll_rad: &[f64],
    steer_rad: &[f64],
    st: Structure,
    start: Option<Start>,
    estimator: Estimator,
) -> Option<ModalFit> {
    let fit = |structure: Structure| {
        let options = ModalOptions {
            resamples: 0,
            seed: 1,
            only: Some(structure),
            start,
            min_real_modes: 0,
            search_iterations: SOLVE_ITERATIONS,
            estimator,
        };
        fit_modes(t_s, roll_rad, steer_rad, &options).ok()
    };
    fit(st).or_else(|| {
        fit(Structure {
            real_modes: 0,
            ..st
        })
    })
}

impl Default for ModalOptions {
    fn default() -> Self {
        ModalOptions {
            resamples: 400,
            seed: 1,
            only: None,
            start: None,
            min_real_modes: 0,
            search_iterations: SOLVE_ITERATIONS,
            estimator: Estimator::Capped,
        }
    }
}

/// One structure fitted: parameters, weighted cost, per-signal RSS, BIC.
struct Candidate {
    st: Structure,
    params: Vec<f64>,
    rss: [f64; 2],
    bic: f64,
}

fn bic(rss: [f64; 2], n: usize, k: usize) -> f64 {
    let nf = n as f64;
    nf * (rss[0] / nf).ln() + nf * (rss[1] / nf).ln() + k as f64 * (2.0 * nf).ln()
}

/// Fits θ and γ (rad) sampled at `t_s` (s, ascending: the free motion's window) jointly.
pub fn fit_modes(
    t_s: &[f64],
    roll_rad: &[f64],
    steer_rad: &[f64],
    options: &ModalOptions,
) -> Result<ModalFit, ModalError> {
    let n = t_s.len();
    if n < MIN_SAMPLES || roll_rad.len() != n || steer_rad.len() != n {
        return Err(ModalError::TooShort(n));
    }
    let x = [roll_rad, steer_rad];
    let noise = [noise_level(roll_rad), noise_level(steer_rad)];
    let weight = noise.map(|s| 1.0 / s.max(1e-9));
    let t0 = t_s[0];
    let mut problem = Problem {
        t: t_s,
        x,
        weight,
        t_ref: t0,
        t0,
        estimator: options.estimator,
        st: Structure::WEAVE_AND_TRENDS,
    };
    let mut solver = Solver::default();
    // Starting point: ω from the periodogram, σ by a search (variable projection); or the
    // eigenvalue given.
    let (sigma, omega) = match options.start {
        Some(Start {
            weave: [sigma, omega],
            ..
        }) => (sigma, omega),
        None => {
            let omega0 = dominant_omega(t_s, x, weight);
            let base = (0..=50)
                .map(|k| -4.0 + 0.12 * k as f64)
                .filter_map(|sigma| {
                    let p = problem.project(&[sigma, omega0])?;
                    Some((problem.cost(&p), p))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .ok_or(ModalError::NoWeave)?
                .1;
            let base = solve(&problem, base, &mut solver).ok_or(ModalError::NoWeave)?;
            if plausible(&base) {
                (base[0], base[1])
            } else {
                (0.0, omega0)
            }
        }
    };
    // Every structure, each from the base eigenvalue and the best starting real rates.
    let mut best: Option<Candidate> = None;
    let structures: Vec<Structure> = match options.only {
        Some(st) => vec![Structure {
            drift: false,
            real_modes: st.real_modes.min(MAX_REAL_MODES),
            ..st
        }],
        None => match options.estimator {
            // One bounded real mode or none; the slow motion in the polynomial.
            Estimator::Projected { curve_terms, .. } => (options.min_real_modes.min(1)..=1)
                .flat_map(|real_modes| {
                    (0..=curve_terms.min(MAX_CURVE_TERMS)).map(move |curve_terms| Structure {
                        real_modes,
                        curve_terms,
                        ..Structure::WEAVE_AND_TRENDS
                    })
                })
                .collect(),
            Estimator::Capped => (options.min_real_modes.min(MAX_REAL_MODES)..=MAX_REAL_MODES)
                .flat_map(|real_modes| {
                    [false, true].map(|trend| Structure {
                        real_modes,
                        drift: false,
                        trend,
                        curve_terms: 0,
                    })
                })
                .collect(),
        },
    };
    for st in structures {
        problem.st = st;
        let rates = options.start.map(|s| s.real_rates);
        let Some(c) = fit_structure(
            &problem,
            sigma,
            omega,
            rates,
            options.search_iterations,
            &mut solver,
        ) else {
            continue;
        };
        if !identifiable(&problem, &c.params) {
            continue;
        }
        if best.as_ref().is_none_or(|b| c.bic < b.bic) {
            best = Some(c);
        }
    }
    let best = best.ok_or(ModalError::NoWeave)?;
    problem.st = best.st;
    // Re-weight by the residual levels; then τ is measured from where the eigenvalue applies
    // (the curve, σ and ω do not depend on t_ref; the amplitudes are solved afresh).
    problem.weight = best.rss.map(|r| 1.0 / (r / n as f64).sqrt().max(1e-12));
    let params = solve(&problem, best.params, &mut solver).ok_or(ModalError::NoWeave)?;
    problem.t_ref = eigenvalue_time(&problem, &params).ok_or(ModalError::NoWeave)?;
    let params = problem
        .project(&params[..problem.st.nonlinear()])
        .ok_or(ModalError::NoWeave)?;
    let drift = if options.only.is_none() {
        fit_drift(&problem, &params, &mut solver)
    } else {
        None
    };
    finish(&problem, params, drift, solver, options)
}

/// How the solves of a modal fit ended ([`ModalFit::solver`]): the structures' searches, the
/// chosen one's final fit and the eigenvalue drift's check.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct Solver {
    /// Iterations of the longest solve.
    pub iterations: usize,
    /// Every solve stopped with the Gauss–Newton step left below
    /// a thousandth of the errors (`fit::CONVERGED_STEP_SE`; not at its iteration limit).
    pub converged: bool,
    /// Solves counted (0: none yet).
    pub solves: usize,
    /// Of those, the ones that did not converge.
    pub unconverged: usize,
}

impl Solver {
    fn record(&mut self, iterations: usize, converged: bool) {
        self.iterations = self.iterations.max(iterations);
        self.solves += 1;
        self.unconverged += usize::from(!converged);
        self.converged = self.unconverged == 0;
    }
}

/// The drift's check: the constant fit's structure with σ̇ and ω̇ added, from the constant fit
/// with no drift, τ from the same `t_ref`. `None` when that fit fails or lands elsewhere (ω
/// implausible).
fn fit_drift(constant: &Problem<'_>, params: &[f64], solver: &mut Solver) -> Option<Drift> {
    let problem = Problem {
        st: Structure {
            drift: true,
            ..constant.st
        },
        ..*constant
    };
    let mut p0 = params[..2].to_vec();
    p0.extend([0.0, 0.0]);
    p0.extend(&params[2..]);
    let p = solve(&problem, p0, solver)?;
    if !plausible(&p) {
        return None;
    }
    let cov = covariance(&problem, &p)?.cov;
    let est = |i: usize| Estimate {
        value: p[i],
        se: cov[(i, i)].max(0.0).sqrt(),
    };
    Some(Drift {
        sigma_rate: est(2),
        omega_rate: est(3),
        shift: [p[0] - params[0], p[1] - params[1]],
    })
}

/// The variance accounted for in θ and γ (fractions, 0–1) by modes whose eigenvalues are
/// given — the weave `weave` (im > 0) and up to two real modes `real_rates` (1/s) — with their
/// amplitudes, offsets and trends fitted by linear least squares: how much of a ride a model's
/// eigenvalues explain. `None` with fewer than 40 samples or singular normal equations.
pub fn vaf_with_modes(
    t_s: &[f64],
    roll_rad: &[f64],
    steer_rad: &[f64],
    weave: Complex<f64>,
    real_rates: &[f64],
) -> Option<[f64; 2]> {
    let n = t_s.len();
    if n < MIN_SAMPLES
        || roll_rad.len() != n
        || steer_rad.len() != n
        || real_rates.len() > MAX_REAL_MODES
    {
        return None;
    }
    let problem = Problem {
        t: t_s,
        x: [roll_rad, steer_rad],
        weight: [1.0, 1.0],
        t_ref: t_s[0],
        t0: t_s[0],
        estimator: Estimator::Capped,
        st: Structure {
            real_modes: real_rates.len(),
            drift: false,
            trend: true,
            curve_terms: 0,
        },
    };
    let mut nonlinear = vec![weave.re, weave.im.abs()];
    nonlinear.extend_from_slice(real_rates);
    let p = problem.project(&nonlinear)?;
    let rss = problem.rss(&p);
    let vaf = [0, 1].map(|s| {
        let x = problem.x[s];
        let m = x.iter().sum::<f64>() / n as f64;
        let var: f64 = x.iter().map(|v| (v - m).powi(2)).sum();
        1.0 - rss[s] / var.max(1e-300)
    });
    Some(vaf)
}

/// A structure fitted from the base eigenvalue: the real modes start from the best of a grid
/// of rates (by the projected cost), then Levenberg–Marquardt on everything. `None` when it
/// fails or lands somewhere unphysical (real rates beyond ±60 /s, two equal real modes).
fn fit_structure(
    problem: &Problem<'_>,
    sigma: f64,
    omega: f64,
    rates: Option<[f64; MAX_REAL_MODES]>,
    iterations: usize,
    solver: &mut Solver,
) -> Option<Candidate> {
    const RATES: [f64; 5] = [-0.3, -1.0, -3.0, -8.0, -20.0];
    let st = problem.st;
    let head: Vec<f64> = if st.drift {
        vec![sigma, omega, 0.0, 0.0]
    } else {
        vec![sigma, omega]
    };
    let held = |r: f64| {
        let (lo, hi) = problem.bounds(real_index(st, 0));
        r.clamp(lo, hi)
    };
    let starts: Vec<Vec<f64>> = match (st.real_modes, rates) {
        (k, Some(r)) => vec![r[..k.min(MAX_REAL_MODES)].to_vec()],
        (0, None) => vec![vec![]],
        (1, None) => RATES.iter().map(|&r| vec![held(r)]).collect(),
        (_, None) => RATES
            .iter()
            .enumerate()
            .flat_map(|(i, &a)| RATES[i + 1..].iter().map(move |&b| vec![a, b]))
            .collect(),
    };
    let p0 = starts
        .iter()
        .filter_map(|rates| {
            let mut nl = head.clone();
            nl.extend(rates);
            let p = problem.project(&nl)?;
            Some((problem.cost(&p), p))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))?
        .1;
    let mut p = solve_within(problem, p0, iterations, solver)?;
    if !plausible(&p) {
        return None;
    }
    let rates: Vec<f64> = (0..st.real_modes).map(|k| p[real_index(st, k)]).collect();
    if rates.iter().any(|r| !(-60.0..=5.0).contains(r))
        || (rates.len() == 2 && (rates[0] - rates[1]).abs() < 0.05 * rates[0].abs().max(0.1))
    {
        return None;
    }
    // Slowest real mode first.
    if rates.len() == 2 && rates[1] > rates[0] {
        let (i, j) = (real_index(st, 0), real_index(st, 1));
        p.swap(i, j);
        for s in 0..2 {
            let l = st.nonlinear() + s * st.linear();
            p.swap(l + 2, l + 3);
        }
    }
    let rss = problem.rss(&p);
    Some(Candidate {
        st,
        bic: bic(rss, problem.n(), st.params()),
        params: p,
        rss,
    })
}

/// Levenberg–Marquardt from `p0`, the parameters with ω made positive; `None` when it ends
/// non-finite. At most [`SOLVE_ITERATIONS`]: many fits end there unconverged, along the valley a
/// real mode's rate and amplitude make ([`ModalFit::solver`] says which), and the structures and
/// the coasting corrections are calibrated with the cap as it is (issue 75 replaces it). What was
/// measured: [docs/decisions/2026-12-02-ride-estimator.md](../../docs/decisions/2026-12-02-ride-estimator.md#the-iteration-cap-as-it-was-measured-before).
fn solve(problem: &Problem<'_>, p0: Vec<f64>, solver: &mut Solver) -> Option<Vec<f64>> {
    solve_within(problem, p0, SOLVE_ITERATIONS, solver)
}

/// [`solve`] in at most `iterations`, how it ended added to `solver`.
fn solve_within(
    problem: &Problem<'_>,
    p0: Vec<f64>,
    iterations: usize,
    solver: &mut Solver,
) -> Option<Vec<f64>> {
    let (mut p, cost) = match problem.estimator {
        Estimator::Capped => {
            let sol = levenberg_marquardt(problem, 2 * problem.n(), p0, iterations, 0.0);
            solver.record(sol.iterations, sol.converged);
            (sol.params, sol.cost)
        }
        Estimator::Projected { iterations, .. } => {
            let sol = solve_projected(problem, &p0, iterations)?;
            // A search that lands on no oscillation (ω → 0, where the weave's columns become
            // the offset's and the trend's and the cost has no minimum to converge to) is
            // discarded by its caller and is no solve of the fit (ω's sign is no matter).
            let omega = sol.params[1].abs();
            if plausible(&[sol.params[0], omega]) {
                solver.record(sol.iterations, sol.converged);
            }
            (sol.params, sol.cost)
        }
    };
    if p[1] < 0.0 {
        // ω → −ω (and ω̇, b) is the same curve.
        let st = problem.st;
        p[1] = -p[1];
        if st.drift {
            p[3] = -p[3];
        }
        for s in 0..2 {
            let l = st.nonlinear() + s * st.linear();
            p[l + 1] = -p[l + 1];
        }
    }
    (p.iter().all(|v| v.is_finite()) && cost.is_finite()).then_some(p)
}

/// The gain below which a cost of a few thousand squares is rounding (their sum's relative
/// rounding is about n ε): where no step lowers the cost and the step left promises no more,
/// [`solve_projected`] is at its minimum.
const ROUNDING_GAIN: f64 = 1e-11;

/// A step below this fraction of a parameter's size (of 1e-3 for one near 0) is rounding:
/// [`solve_projected`] has converged there whatever its errors say.
const ROUNDING_STEP: f64 = 1e-10;

/// Where [`solve_projected`] stopped: the parameters (the amplitudes solved for the
/// nonlinear ones), the weighted cost, the iterations and whether the convergence test held.
struct Projected {
    params: Vec<f64>,
    cost: f64,
    iterations: usize,
    converged: bool,
}

/// Variable projection from `p0`'s nonlinear parameters (σ, ω, the drift's, the real modes'
/// rates; Golub and Pereyra 1973): the amplitudes, offsets and trends are solved exactly for
/// every trial ([`Problem::project`]), so the cost is a function of the nonlinear parameters
/// alone. Its gradient is the full problem's, reduced to the nonlinear block by the Schur
/// complement of the normal equations ([`reduced_system`]; at projected amplitudes their own
/// gradient is zero), and so is the Gauss–Newton matrix `S` (Kaufman's). The step is Newton's
/// on that gradient, its Hessian by forward differences of it (a few nonlinear parameters:
/// one projection and accumulation each), damped by Levenberg–Marquardt on `S`'s diagonal and
/// held to the problem's bounds (a rate at its bound whose step points out stays there);
/// Gauss–Newton's `S` where that Hessian is not positive definite. Gauss–Newton alone crawled
/// for hundreds of iterations along a weakly determined castor rate, where its quadratic
/// model is poor. Converged when the step left moves no nonlinear parameter by more than
/// `fit::CONVERGED_STEP_SE` of its error `√(s² S⁻¹ᵢᵢ)`, or by [`ROUNDING_STEP`] of its size;
/// where no step lowers the cost, converged if the step left promises no gain beyond the
/// cost's rounding. `None` where the amplitudes cannot be solved at `p0`.
fn solve_projected(problem: &Problem<'_>, p0: &[f64], max_iterations: usize) -> Option<Projected> {
    use crate::fit::CONVERGED_STEP_SE;
    let k = problem.st.nonlinear();
    let np = problem.st.params();
    let rows = 2 * problem.n();
    let mut alpha: Vec<f64> = p0[..k].to_vec();
    clamp(problem, &mut alpha);
    let mut p = problem.project(&alpha)?;
    let mut cost = problem.cost(&p);
    let s2 = |cost: f64| cost / rows.saturating_sub(np).max(1) as f64;
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let mut converged = false;
    for it in 0..=max_iterations {
        let (sys, raw_grad) = reduced_system(problem, &p, k)?;
        // The parameters held at their bounds out of the step (`fit::free_system`).
        let (sys, grad) = free_system(problem, &alpha, &sys, &raw_grad);
        let Some(gn) = sys.clone().cholesky() else {
            break;
        };
        let inv = gn.inverse();
        let se: Vec<f64> = (0..k)
            .map(|i| (s2(cost) * inv[(i, i)]).max(1e-300).sqrt())
            .collect();
        let hessian = newton_hessian(problem, &alpha, &raw_grad, &se)
            .map(|h| free_system(problem, &alpha, &h, &raw_grad).0)
            .unwrap_or_else(|| sys.clone());
        // The step left (Newton's, or Gauss–Newton's where the Hessian is not positive
        // definite), in the nonlinear parameters' own errors.
        let step = hessian.clone().cholesky().unwrap_or(gn).solve(&(-&grad));
        let worst = (0..k)
            .map(|i| {
                let (lo, hi) = problem.bounds(i);
                ((alpha[i] + step[i]).clamp(lo, hi) - alpha[i]).abs() / se[i]
            })
            .fold(0.0, f64::max);
        // Or the step left is rounding of the parameters themselves (a curve fitted exactly,
        // whose errors are rounding too).
        let relative = (0..k)
            .map(|i| step[i].abs() / alpha[i].abs().max(1e-3))
            .fold(0.0, f64::max);
        if worst < CONVERGED_STEP_SE || relative < ROUNDING_STEP {
            converged = true;
            break;
        }
        if it == max_iterations {
            break;
        }
        iterations = it + 1;
        let mut improved = false;
        while lambda < 1e16 {
            let Some(delta) = marquardt_step(&hessian, &sys, &grad, lambda) else {
                lambda *= 10.0;
                continue;
            };
            let mut trial: Vec<f64> = alpha.iter().zip(delta.iter()).map(|(a, d)| a + d).collect();
            clamp(problem, &mut trial);
            let trial_p = problem.project(&trial);
            let trial_cost = trial_p
                .as_ref()
                .map_or(f64::NAN, |q| problem.cost_within(q, cost));
            if trial_cost.is_finite() && trial_cost < cost {
                alpha = trial;
                p = trial_p?;
                cost = trial_cost;
                lambda = (lambda / 10.0).max(1e-12);
                improved = true;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            // No step lowers the cost: a minimum to rounding where the undamped step's
            // predicted gain is within the cost's rounding (on a curve fitted exactly, whose
            // errors are themselves rounding, the test above cannot hold).
            converged = grad.dot(&(-&step)) <= ROUNDING_GAIN * cost;
            break;
        }
    }
    Some(Projected {
        params: p,
        cost,
        iterations,
        converged,
    })
}

/// The Hessian of half the projected cost at `alpha` (whose reduced gradient is `grad`), by
/// forward differences of the reduced gradient, each step a ten-thousandth of the
/// parameter's error `se` (backward where a bound is in the way); symmetrized. `None` where a
/// projection fails.
fn newton_hessian(
    problem: &Problem<'_>,
    alpha: &[f64],
    grad: &DVector<f64>,
    se: &[f64],
) -> Option<DMatrix<f64>> {
    let k = alpha.len();
    let mut hess = DMatrix::zeros(k, k);
    for j in 0..k {
        let (lo, hi) = problem.bounds(j);
        let mut h = 1e-4 * se[j];
        if alpha[j] + h > hi {
            h = -h;
        }
        if alpha[j] + h < lo {
            return None;
        }
        let mut moved = alpha.to_vec();
        moved[j] += h;
        let p = problem.project(&moved)?;
        let (_, g) = reduced_system(problem, &p, k)?;
        for i in 0..k {
            hess[(i, j)] = (g[i] - grad[i]) / h;
        }
    }
    let sym = (&hess + hess.transpose()) * 0.5;
    sym.iter().all(|v| v.is_finite()).then_some(sym)
}

/// The projected problem at `p` (amplitudes solved for its first `k`, nonlinear, parameters):
/// the Gauss–Newton matrix and the gradient of half the cost in the nonlinear parameters,
/// `S = H_nn − H_nl H_ll⁻¹ H_ln` and `g_n − H_nl H_ll⁻¹ g_l` from the full normal equations.
/// `None` when the linear block is singular.
fn reduced_system(
    problem: &Problem<'_>,
    p: &[f64],
    k: usize,
) -> Option<(DMatrix<f64>, DVector<f64>)> {
    let np = p.len();
    let (mut h, mut g) = (DMatrix::zeros(np, np), DVector::zeros(np));
    let mut unused_jac = DMatrix::zeros(0, 0);
    let mut r = DVector::zeros(2 * problem.n());
    problem.accepted_normal_equations(p, &mut unused_jac, &mut r, &mut h, &mut g);
    let m = np - k;
    let h_nn = h.view((0, 0), (k, k));
    let h_nl = h.view((0, k), (k, m));
    let h_ll = h.view((k, k), (m, m)).clone_owned();
    let x = h_ll.cholesky()?.solve(&h_nl.transpose());
    let sys = h_nn - h_nl * &x;
    let grad = g.rows(0, k) - x.transpose() * g.rows(k, m);
    Some((sys, grad))
}

/// An oscillation that is one: 0.5 ≤ ω ≤ 40 rad/s, |σ| ≤ ω (less than critically damped-ish).
fn plausible(p: &[f64]) -> bool {
    (0.5..=40.0).contains(&p[1]) && p[0].abs() <= p[1]
}

/// The time (s) at which the constant fit's eigenvalue is the drifting eigenvalue's.
///
/// If the eigenvalue drifts linearly, λ(t) = λ(t_r) + λ̇ (t − t_r), the data differ from the
/// constant model at first order by λ̇ times the columns ½τ² ∂x/∂λ (the real part's column for
/// σ̇, the imaginary part's for ω̇). Least squares passes that on as δσ = c_σσ σ̇ + c_σω ω̇ and
/// δω = c_ωσ σ̇ + c_ωω ω̇, c the regression of those columns on the fit's Jacobian; so the fitted
/// σ is σ(t_r + c_σσ) and ω is ω(t_r + c_ωω), up to the cross terms (an "imaginary" time, which
/// vanishes over many cycles; what it leaves is what [`Drift`] measures). Returned: t_r plus the
/// mean of c_σσ and c_ωω, the same whatever `t_r` the Jacobian is taken at. The weights are the
/// weave's squared amplitude times the fit's leverage τ²: for an envelope decaying from the
/// window's start, about twice the plain amplitude-weighted mean time (which read the speed
/// 0.4–0.5 s too early, the frequency 3–6 standard errors low, on simulated coasting rides).
/// `None` when singular.
fn eigenvalue_time(problem: &Problem<'_>, p: &[f64]) -> Option<f64> {
    let n = problem.n();
    let mut jac = DMatrix::zeros(2 * n, problem.st.params());
    let mut r = DVector::zeros(2 * n);
    problem.residuals_and_jacobian(p, &mut jac, &mut r);
    // Columns 0 and 1 are τ ∂x/∂σ and τ ∂x/∂ω (weighted): the drift's columns are ½τ² times.
    let mut drift = DMatrix::zeros(2 * n, 2);
    for (i, &t) in problem.t.iter().enumerate() {
        let tau = t - problem.t_ref;
        for row in [i, i + n] {
            for q in 0..2 {
                drift[(row, q)] = 0.5 * tau * jac[(row, q)];
            }
        }
    }
    let c = (jac.transpose() * &jac)
        .cholesky()?
        .solve(&(jac.transpose() * drift));
    let t = problem.t_ref + 0.5 * (c[(0, 0)] + c[(1, 1)]);
    t.is_finite().then_some(t)
}

/// The fit's Jacobian, residuals and covariances at `p`.
struct Covariance {
    jac: DMatrix<f64>,
    r: DVector<f64>,
    /// (JᵀJ)⁻¹ of the weighted Jacobian.
    hinv: DMatrix<f64>,
    /// The parameters' covariance under AR(1) residuals per signal
    /// ([`crate::fit::ar1_sandwich`]): `H⁻¹ (Σ_s v_s J_sᵀ R_s J_s) H⁻¹`.
    cov: DMatrix<f64>,
    /// s² (JᵀJ)⁻¹, s² the weighted residuals' variance: the covariance were they white.
    cov_white: DMatrix<f64>,
}

/// `None` when JᵀJ is singular.
fn covariance(problem: &Problem<'_>, p: &[f64]) -> Option<Covariance> {
    let n = problem.n();
    let np = problem.st.params();
    let mut jac = DMatrix::zeros(2 * n, np);
    let mut r = DVector::zeros(2 * n);
    problem.residuals_and_jacobian(p, &mut jac, &mut r);
    let s2 = r.norm_squared() / (2 * n - np) as f64;
    let hinv = (jac.transpose() * &jac).cholesky()?.inverse();
    let cov_white = &hinv * s2;
    let cov = crate::fit::ar1_sandwich(&jac, &r, &[0..n, n..2 * n], &hinv);
    Some(Covariance {
        jac,
        r,
        hinv,
        cov,
        cov_white,
    })
}

/// Covariance, resampling check, mode shape and fit quality of the final parameters.
fn finish(
    problem: &Problem<'_>,
    params: Vec<f64>,
    drift: Option<Drift>,
    solver: Solver,
    options: &ModalOptions,
) -> Result<ModalFit, ModalError> {
    let st = problem.st;
    let n = problem.n();
    let np = st.params();
    let Covariance {
        jac,
        r,
        hinv,
        cov,
        cov_white,
    } = covariance(problem, &params).ok_or(ModalError::NoWeave)?;
    let se = |i: usize| cov[(i, i)].max(0.0).sqrt();
    let se_white = |i: usize| cov_white[(i, i)].max(0.0).sqrt();
    let resampled = block_bootstrap(&jac, &r, &hinv, n, params[1], problem, options);
    let [re_drift, im_drift] = drift.map_or([0.0; 2], |d| d.shift.map(f64::abs));
    let weave = Eigenvalue {
        re: params[0],
        im: params[1],
        re_se: se(0).hypot(re_drift),
        im_se: se(1).hypot(im_drift),
        re_se_noise: se_white(0),
        im_se_noise: se_white(1),
        noise_inflation: [
            se(0) / se_white(0).max(1e-300),
            se(1) / se_white(1).max(1e-300),
        ],
        re_im_corr: cov[(0, 1)] / (se(0) * se(1)).max(1e-300),
        re_se_resampled: resampled[0],
        im_se_resampled: resampled[1],
        re_se_drift: re_drift,
        im_se_drift: im_drift,
    };
    let real_modes = (0..st.real_modes)
        .map(|k| Estimate {
            value: params[real_index(st, k)],
            se: se(real_index(st, k)),
        })
        .collect();
    let shape = mode_shape(&params, &cov, st);
    let rss = problem.rss(&params);
    let vaf = [0, 1].map(|s| {
        let x = problem.x[s];
        let m = x.iter().sum::<f64>() / n as f64;
        let var: f64 = x.iter().map(|v| (v - m).powi(2)).sum();
        1.0 - rss[s] / var.max(1e-300)
    });
    Ok(ModalFit {
        structure: st,
        start_s: problem.t0,
        end_s: problem.t[n - 1],
        t_ref_s: problem.t_ref,
        weave,
        drift,
        real_modes,
        shape,
        vaf,
        residual_rms_rad: rss.map(|r| (r / n as f64).sqrt()),
        samples: n,
        bic: bic(rss, n, np),
        solver,
        estimator: problem.estimator,
        params,
    })
}

/// γ/θ of the weave: A_s = a_s − i b_s (so that the signal is Re(A_s e^{λτ})), the ratio
/// A_γ/A_θ, its modulus and argument with delta-method standard errors.
fn mode_shape(p: &[f64], cov: &DMatrix<f64>, st: Structure) -> ModeShape {
    let lt = st.nonlinear();
    let lg = lt + st.linear();
    let idx = [lt, lt + 1, lg, lg + 1];
    let ratio = |v: [f64; 4]| Complex::new(v[2], -v[3]) / Complex::new(v[0], -v[1]);
    let v0 = idx.map(|i| p[i]);
    let z0 = ratio(v0);
    let grad = |f: &dyn Fn(Complex<f64>) -> f64| -> [f64; 4] {
        std::array::from_fn(|k| {
            let h = 1e-7 * v0[k].abs().max(1e-6);
            let (mut a, mut b) = (v0, v0);
            a[k] += h;
            b[k] -= h;
            (f(ratio(a)) - f(ratio(b))) / (2.0 * h)
        })
    };
    let var = |g: [f64; 4]| -> f64 {
        let mut v = 0.0;
        for i in 0..4 {
            for j in 0..4 {
                v += g[i] * g[j] * cov[(idx[i], idx[j])];
            }
        }
        v.max(0.0)
    };
    let arg0 = z0.arg();
    let modulus = |z: Complex<f64>| z.norm();
    let arg = |z: Complex<f64>| (z / Complex::from_polar(1.0, arg0)).arg();
    ModeShape {
        ratio: Estimate {
            value: z0.norm(),
            se: var(grad(&modulus)).sqrt(),
        },
        phase_rad: Estimate {
            value: arg0,
            se: var(grad(&arg)).sqrt(),
        },
    }
}

/// Standard errors of σ and ω from a moving-block bootstrap of the weighted residuals (blocks
/// of one weave period, per signal), each resample's parameters one Gauss–Newton step from the
/// fit: δp = (JᵀJ)⁻¹ Jᵀ r*.
fn block_bootstrap(
    jac: &DMatrix<f64>,
    r: &DVector<f64>,
    hinv: &DMatrix<f64>,
    n: usize,
    omega: f64,
    problem: &Problem<'_>,
    options: &ModalOptions,
) -> [f64; 2] {
    if options.resamples < 2 {
        return [f64::NAN; 2];
    }
    let dt = (problem.t[n - 1] - problem.t[0]) / (n - 1).max(1) as f64;
    let block = ((2.0 * std::f64::consts::PI / omega.max(0.1) / dt).round() as usize).clamp(1, n);
    // Rows 0 and 1 of (JᵀJ)⁻¹Jᵀ: the gain of σ and ω on each residual.
    let gain = hinv.rows(0, 2) * jac.transpose();
    // xoshiro256** from the seed (rand_xoshiro), rand's uniform f64.
    let mut rng =
        <rand_xoshiro::Xoshiro256StarStar as rand::SeedableRng>::seed_from_u64(options.seed);
    let (mut sum, mut sum2) = ([0.0f64; 2], [0.0f64; 2]);
    let mut star = vec![0.0; 2 * n];
    for _ in 0..options.resamples {
        for s in 0..2 {
            let mut k = 0;
            while k < n {
                let u: f64 = rand::RngExt::random(&mut rng);
                let start = (u * (n - block + 1) as f64) as usize;
                for j in 0..block.min(n - k) {
                    star[s * n + k + j] = r[s * n + start + j];
                }
                k += block;
            }
        }
        for q in 0..2 {
            let d: f64 = (0..2 * n).map(|i| gain[(q, i)] * star[i]).sum();
            sum[q] += d;
            sum2[q] += d * d;
        }
    }
    let b = options.resamples as f64;
    [0, 1].map(|q| {
        ((sum2[q] - sum[q] * sum[q] / b) / (b - 1.0))
            .max(0.0)
            .sqrt()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// θ and γ of a weave whose eigenvalue drifts linearly from `lambda0` at t = 0 by
    /// `rate` per second (phase and envelope integrated exactly), γ/θ = 1.4 e^{−0.5i}, plus a
    /// capsize-like real mode and seeded white noise of `noise_rad`.
    fn drifting_weave(
        lambda0: Complex<f64>,
        rate: Complex<f64>,
        noise_rad: f64,
        seed: u64,
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        use crate::sim::draw::Draw;
        let mut rng = crate::sim::draw::seeded(seed);
        let mut noise = || noise_rad * rng.normal();
        let shape = Complex::from_polar(1.4, -0.5);
        let t: Vec<f64> = (0..250).map(|k| k as f64 * 0.01).collect();
        let mut roll = Vec::new();
        let mut steer = Vec::new();
        for &ti in &t {
            let z = (lambda0 * ti + 0.5 * rate * ti * ti).exp() * Complex::new(0.04, 0.01);
            let real = 0.01 * (-0.4 * ti).exp();
            roll.push(z.re + real + noise());
            steer.push((shape * z).re - 0.5 * real + noise());
        }
        (t, roll, steer)
    }

    /// Options fitting the weave with offsets (and trends) only, without resampling.
    fn weave_only(trend: bool) -> ModalOptions {
        ModalOptions {
            resamples: 0,
            only: Some(Structure {
                real_modes: 0,
                drift: false,
                trend,
                curve_terms: 0,
            }),
            ..ModalOptions::default()
        }
    }

    /// A weave (σ −0.7, ω 5.3 1/s, γ/θ = 1.4 e^{−0.5i}), a castor mode (−9 1/s) and a cubic
    /// slow part in each signal, with seeded white noise of `noise_rad`: the stated model of
    /// [`Estimator::Projected`] exactly, at 100 Hz over 3 s.
    fn weave_castor_cubic(noise_rad: f64, seed: u64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        use crate::sim::draw::Draw;
        let mut rng = crate::sim::draw::seeded(seed);
        let mut noise = || noise_rad * rng.normal();
        let lambda = Complex::new(-0.7, 5.3);
        let shape = Complex::from_polar(1.4, -0.5);
        let t: Vec<f64> = (0..300).map(|k| 1.0 + k as f64 * 0.01).collect();
        let (mut roll, mut steer) = (Vec::new(), Vec::new());
        for &ti in &t {
            let tau = ti - 1.0;
            let z = (lambda * tau).exp() * Complex::new(0.05, -0.02);
            let castor = (-9.0 * tau).exp();
            let slow = 0.002 + 0.003 * tau - 0.002 * tau * tau + 0.0004 * tau.powi(3);
            roll.push(z.re + 0.004 * castor + slow + noise());
            steer.push((shape * z).re - 0.03 * castor - 0.5 * slow + noise());
        }
        (t, roll, steer)
    }

    /// Asserts that `fit`'s weave lies within three of its errors of `σ + iω`.
    fn assert_weave_within_3_se(fit: &ModalFit, sigma: f64, omega: f64) {
        let w = &fit.weave;
        assert!((w.re - sigma).abs() < 3.0 * w.re_se, "{w:?}");
        assert!((w.im - omega).abs() < 3.0 * w.im_se, "{w:?}");
    }

    /// The projected estimator with τ² and τ³ beside the trend, without resampling.
    fn projected(iterations: usize) -> ModalOptions {
        ModalOptions {
            resamples: 0,
            estimator: Estimator::Projected {
                curve_terms: MAX_CURVE_TERMS,
                iterations,
            },
            ..ModalOptions::default()
        }
    }

    /// On its own model without noise the projected fit finds the weave and the castor to
    /// rounding (1e-8 of their values: the curve's exactness, nothing else), chooses the
    /// structure with the castor, and converges.
    #[test]
    fn the_projected_fit_recovers_its_own_model_exactly() {
        let (t, roll, steer) = weave_castor_cubic(0.0, 1);
        let fit = fit_modes(&t, &roll, &steer, &projected(PROJECTED_ITERATIONS)).expect("a weave");
        assert_eq!(fit.structure.real_modes, 1);
        assert_eq!(fit.structure.curve_terms, 2);
        assert!((fit.weave.re + 0.7).abs() < 1e-8, "{:?}", fit.weave);
        assert!((fit.weave.im - 5.3).abs() < 1e-8, "{:?}", fit.weave);
        assert!(
            (fit.real_modes[0].value + 9.0).abs() < 1e-7,
            "{:?}",
            fit.real_modes
        );
        assert!(
            (fit.shape.ratio.value - 1.4).abs() < 1e-8,
            "{:?}",
            fit.shape
        );
        assert!(
            (fit.shape.phase_rad.value + 0.5).abs() < 1e-8,
            "{:?}",
            fit.shape
        );
        assert!(fit.solver.converged, "{:?}", fit.solver);
    }

    /// With noise (1 mrad, seeded) every solve converges, the truth lies within three of the
    /// errors, and doubling the iteration limit changes nothing: no solve came near it.
    #[test]
    fn the_projected_fit_converges_and_ignores_its_limit() {
        for seed in 1..=5 {
            let (t, roll, steer) = weave_castor_cubic(0.001, seed);
            let fit =
                fit_modes(&t, &roll, &steer, &projected(PROJECTED_ITERATIONS)).expect("a weave");
            assert!(
                fit.solver.converged && fit.solver.solves >= 3,
                "{:?}",
                fit.solver
            );
            assert!(
                fit.solver.iterations < PROJECTED_ITERATIONS / 4,
                "{:?}",
                fit.solver
            );
            assert_weave_within_3_se(&fit, -0.7, 5.3);
            let doubled = fit_modes(&t, &roll, &steer, &projected(2 * PROJECTED_ITERATIONS))
                .expect("a weave");
            let parts = |f: &ModalFit| {
                let (w, s) = (f.weave, f.shape);
                [
                    w.re,
                    w.im,
                    w.re_se,
                    w.im_se,
                    s.ratio.value,
                    s.phase_rad.value,
                ]
            };
            assert_eq!(parts(&doubled), parts(&fit));
        }
    }

    /// The solver's record tells how the fit ended: a weave with offsets and trends only (no
    /// real mode, whose rate and amplitude make a valley) converges in a few iterations, at the
    /// truth within its errors; the same fit from a start far off, allowed one iteration for
    /// its structure, says it did not.
    #[test]
    fn a_fits_solver_record_says_whether_it_converged() {
        let (t, roll, steer) =
            drifting_weave(Complex::new(-0.9, 5.1), Complex::new(0.0, 0.0), 0.002, 11);
        let options = weave_only(true);
        let fit = fit_modes(&t, &roll, &steer, &options).expect("a weave");
        assert!(fit.solver.converged, "{:?}", fit.solver);
        assert!(fit.solver.iterations < 50, "{:?}", fit.solver);
        assert_weave_within_3_se(&fit, -0.9, 5.1);
        // From a start far from the truth (no search), one iteration cannot get there.
        let cut = ModalOptions {
            search_iterations: 1,
            start: Some(Start {
                weave: [-0.3, 4.6],
                real_rates: [0.0; MAX_REAL_MODES],
            }),
            ..options
        };
        let fit = fit_modes(&t, &roll, &steer, &cut).expect("a weave");
        assert!(
            !fit.solver.converged && fit.solver.unconverged >= 1,
            "{:?}",
            fit.solver
        );
    }

    /// On a weave in AR(1) noise (ρ = 0.8, the residuals of a filtered sensor), the sandwich's
    /// errors are the scatter of σ and ω over 300 seeded windows (ratio within 0.9–1.12: the
    /// scatter's own relative error over 300 draws is 4 %), and the white residuals' errors
    /// are about √((1 − ρ)/(1 + ρ)) = 0.33 of it (below 0.6).
    #[test]
    fn correlated_residuals_errors_are_their_scatter() {
        use crate::sim::draw::Draw;
        let options = weave_only(false);
        let (mut est, mut se, mut white) = (Vec::new(), Vec::new(), Vec::new());
        for seed in 0..300 {
            let mut rng = crate::sim::draw::seeded(100 + seed);
            let t: Vec<f64> = (0..250).map(|k| k as f64 * 0.01).collect();
            let shape = Complex::from_polar(1.4, -0.5);
            let (mut e, mut f) = (0.0, 0.0);
            let (mut roll, mut steer) = (Vec::new(), Vec::new());
            for &ti in &t {
                let z = (Complex::new(-0.9, 5.1) * ti).exp() * Complex::new(0.04, 0.01);
                e = 0.8 * e + 0.002 * rng.normal();
                f = 0.8 * f + 0.002 * rng.normal();
                roll.push(z.re + e);
                steer.push((shape * z).re + f);
            }
            let fit = fit_modes(&t, &roll, &steer, &options).expect("a weave");
            let w = fit.weave;
            est.push([w.re, w.im]);
            se.push([
                w.re_se_noise * w.noise_inflation[0],
                w.im_se_noise * w.noise_inflation[1],
            ]);
            white.push([w.re_se_noise, w.im_se_noise]);
        }
        let k = est.len() as f64;
        for a in 0..2 {
            let mean = est.iter().map(|e| e[a]).sum::<f64>() / k;
            let sd = (est.iter().map(|e| (e[a] - mean).powi(2)).sum::<f64>() / (k - 1.0)).sqrt();
            let rms = |v: &[[f64; 2]]| (v.iter().map(|x| x[a] * x[a]).sum::<f64>() / k).sqrt();
            let (sandwich, white) = (rms(&se) / sd, rms(&white) / sd);
            assert!(
                (0.9..=1.12).contains(&sandwich),
                "part {a}: sandwich/scatter {sandwich}"
            );
            assert!(white < 0.6, "part {a}: white/scatter {white}");
        }
    }

    /// The recurrences of [`Problem::basis`] against `exp` and `sin_cos` at every sample, on a
    /// 100 Hz window of 600 samples with dropped packets (single and in bursts), a drifting
    /// eigenvalue and two real modes: equal to 1e-13 of the largest value.
    #[test]
    fn the_basis_recurrences_are_the_direct_evaluation() {
        let t: Vec<f64> = (0..700)
            .filter(|k| k % 37 != 5 && !(300..306).contains(k))
            .map(|k| 12.0 + k as f64 * 0.01)
            .collect();
        let zeros = vec![0.0; t.len()];
        let st = Structure {
            real_modes: 2,
            drift: true,
            trend: true,
            curve_terms: 0,
        };
        let problem = Problem {
            t: &t,
            x: [&zeros, &zeros],
            weight: [1.0, 1.0],
            t_ref: 14.3,
            t0: 12.0,
            st,
            estimator: Estimator::Capped,
        };
        let mut p = vec![0.0; st.params()];
        p[..6].copy_from_slice(&[-0.8, 5.3, 0.21, -0.33, -0.4, -6.5]);
        let basis = problem.basis(&p);
        let (mut worst, mut largest) = (0.0f64, 0.0f64);
        for (i, &ti) in t.iter().enumerate() {
            let (e, cos, sin) = carrier(&p, st, ti - problem.t_ref);
            let direct = [
                e * cos,
                e * sin,
                (p[4] * (ti - problem.t0)).exp(),
                (p[5] * (ti - problem.t0)).exp(),
            ];
            let recurred = [
                basis.wave[i][0],
                basis.wave[i][1],
                basis.real[i][0],
                basis.real[i][1],
            ];
            for (d, r) in direct.iter().zip(recurred) {
                worst = worst.max((d - r).abs());
                largest = largest.max(d.abs());
            }
        }
        assert!(worst <= 1e-13 * largest, "{worst:e} of {largest:e}");
    }

    /// A trial's cost cut short ([`Problem::rss_within`]) judges it as its whole cost does:
    /// on a noisy drifting weave, 200 parameter vectors around the truth (σ, ω and the real
    /// rate moved by up to ±20 %, the amplitudes by up to ±50 %) against bounds from a tenth to
    /// ten times each one's whole cost, `cost_within(p, b) ≤ b` exactly when `cost(p) ≤ b`, and
    /// where it is, the two are the same number (bit for bit); some were cut short.
    #[test]
    fn a_cost_cut_short_judges_a_trial_as_the_whole_cost() {
        let (t, roll, steer) =
            drifting_weave(Complex::new(-0.9, 5.1), Complex::new(0.0, 0.0), 0.002, 7);
        let st = Structure {
            real_modes: 1,
            drift: false,
            trend: true,
            curve_terms: 0,
        };
        let problem = Problem {
            t: &t,
            x: [&roll, &steer],
            weight: [500.0, 300.0],
            t_ref: 0.0,
            t0: 0.0,
            st,
            estimator: Estimator::Capped,
        };
        let truth = problem
            .project(&[-0.9, 5.1, -0.4])
            .expect("the linear parameters at the truth");
        use crate::sim::draw::Draw;
        let mut rng = crate::sim::draw::seeded(3);
        let mut cut = 0;
        for k in 0..200 {
            let p: Vec<f64> = truth
                .iter()
                .enumerate()
                .map(|(i, &v)| {
                    let spread = if i < st.nonlinear() { 0.2 } else { 0.5 };
                    v * (1.0 + spread * (2.0 * rng.range(0.0, 1.0) - 1.0))
                })
                .collect();
            let whole = problem.cost(&p);
            let bound = whole * 10f64.powf(2.0 * (k as f64 / 199.0) - 1.0);
            let within = problem.cost_within(&p, bound);
            assert_eq!(within <= bound, whole <= bound, "trial {k}");
            if within <= bound {
                assert_eq!(within.to_bits(), whole.to_bits(), "trial {k}");
            }
            cut += usize::from(within < whole);
        }
        assert!(cut > 20, "{cut} cut short");
    }

    /// Without noise or drift the fit returns the eigenvalue and the mode shape exactly.
    #[test]
    fn exact_data_give_the_eigenvalue_and_shape() {
        let lambda = Complex::new(-0.9, 7.3);
        let (t, roll, steer) = drifting_weave(lambda, Complex::new(0.0, 0.0), 0.0, 1);
        let f = fit_modes(&t, &roll, &steer, &ModalOptions::default()).unwrap();
        assert!((f.weave.re - lambda.re).abs() < 1e-6, "{:?}", f.weave);
        assert!((f.weave.im - lambda.im).abs() < 1e-6, "{:?}", f.weave);
        assert!((f.shape.ratio.value - 1.4).abs() < 1e-5);
        assert!((f.shape.phase_rad.value + 0.5).abs() < 1e-5);
    }

    /// A drifting eigenvalue (σ̇ = 0.06, ω̇ = −0.3 /s², as a bicycle slowing by 0.13 m/s² at
    /// 5 m/s): the constant fit is the eigenvalue at `t_ref` to 2 % of the drift over the
    /// window, and what remains is what the drift's check measures (its fit, exact here, gives
    /// the eigenvalue at `t_ref` and the rates). At the plain amplitude-weighted mean time
    /// (Σ t E² / Σ E²) the frequency would be off by 0.1 s of drift or more.
    #[test]
    fn a_drifting_eigenvalue_applies_at_t_ref() {
        let (l0, rate) = (Complex::new(-1.2, 8.5), Complex::new(0.06, -0.3));
        let (t, roll, steer) = drifting_weave(l0, rate, 0.0, 1);
        let f = fit_modes(&t, &roll, &steer, &ModalOptions::default()).unwrap();
        let at = l0 + rate * f.t_ref_s;
        let span = rate.norm() * 2.5;
        let d = f.drift.unwrap();
        let err = [f.weave.re - at.re, f.weave.im - at.im];
        for k in 0..2 {
            assert!(err[k].abs() < 0.02 * span, "{:?} vs {at}", f.weave);
            assert!((err[k] + d.shift[k]).abs() < 1e-4, "{err:?} {d:?}");
        }
        let plain = {
            let (mut num, mut den) = (0.0, 0.0);
            for &ti in &t {
                let e2 = (2.0 * (l0.re * ti + 0.5 * rate.re * ti * ti)).exp();
                num += ti * e2;
                den += e2;
            }
            num / den
        };
        assert!(
            (f.weave.im - (l0.im + rate.im * plain)).abs() > 0.1 * rate.im.abs(),
            "t_ref {} plain {plain}",
            f.t_ref_s
        );
        assert!((d.sigma_rate.value - rate.re).abs() < 0.01, "{d:?}");
        assert!((d.omega_rate.value - rate.im).abs() < 0.01, "{d:?}");
    }

    /// With noise, the standard errors describe the scatter: 200 seeded fits of the same weave,
    /// the normalized errors' standard deviation within 0.8–1.25 (its own sampling error is
    /// ±0.05).
    #[test]
    fn standard_errors_describe_the_scatter() {
        let lambda = Complex::new(-1.0, 8.0);
        let options = ModalOptions {
            resamples: 0,
            ..ModalOptions::default()
        };
        let z: Vec<[f64; 2]> = (0..200)
            .map(|seed| {
                let (t, roll, steer) = drifting_weave(lambda, Complex::new(0.0, 0.0), 1e-3, seed);
                let f = fit_modes(&t, &roll, &steer, &options).unwrap();
                [
                    (f.weave.re - lambda.re) / f.weave.re_se,
                    (f.weave.im - lambda.im) / f.weave.im_se,
                ]
            })
            .collect();
        for k in 0..2 {
            let x: Vec<f64> = z.iter().map(|z| z[k]).collect();
            let m = x.iter().sum::<f64>() / x.len() as f64;
            let sd = (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (x.len() - 1) as f64).sqrt();
            assert!((0.8..=1.25).contains(&sd), "part {k}: sd {sd}, mean {m}");
            assert!(m.abs() < 0.25, "part {k}: mean {m}");
        }
    }
}
