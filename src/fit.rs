//! Fit stage: a [`Signal`] of a free oscillation → frequency, damping and their standard errors.
//!
//! In: a signal holding a free decay somewhere (rest, release, decay, maybe a catch).
//! Out: [`Oscillation`]: the free-decay segment chosen, a least-squares fit of
//!
//! ```text
//! x(t) = a + d·τ + e^{−σ τ} (b sin ω_d τ + c cos ω_d τ),   τ = t − t_s,   σ = ζ ωₙ,
//! ```
//!
//! (`d`, a linear trend for gyro bias or heading drift, is optional), the damped and natural
//! frequencies, the damping ratio, amplitude, residual RMS, and standard errors from the
//! covariance `s² (JᵀJ)⁻¹`. The Jacobian is analytic (exact): a relative finite-difference step
//! leaves the offset stuck when the signal's mean is near zero.
//!
//! The Levenberg–Marquardt (`levenberg_marquardt`) is in-house for a measured reason
//! (`benches/kernels`, `cd benches/kernels && cargo bench`): on the shared fork recording at
//! 1000 Hz (30,000 samples) from a start 2–10 % off, it takes 1.16 ms (median) against the
//! levenberg-marquardt crate's 15.0 ms (MINPACK's algorithm, the same analytic Jacobian), and the
//! two converged points differ by less than 1e-6 of a standard error in every parameter; here it
//! evaluates the model by phasor recurrence and stops when no step can gain. For the damped
//! sinusoid it never stores the Jacobian: one pass over the samples gives the cost, JᵀJ and Jᵀr
//! together (`LeastSquares::normal_equations`), a trial point is evaluated that way, and an
//! accepted step needs no second pass (three to four passes a fit on the shared signals).
//! The passes take the samples four at a time (`phasor_lanes`, `NormalSums`).
//!
//! The lab (seed §5.3.3.2) takes the FFT's peak: with 60 s at 100 Hz a bin is 0.017 Hz, 2 % at
//! 0.8 Hz. The fit reaches the Cramér–Rao bound ([`crb_omega_variance`]) instead.

use crate::signal::Signal;
use crate::spectral::{Peak, Spectrum, Window, ZoomSpectrum};
use nalgebra::{DMatrix, DVector};
use std::f64::consts::PI;

/// Errors of the fit stage.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FitError {
    #[error("only {0} samples: too short to fit an oscillation")]
    TooShort(usize),
    #[error(
        "the segment {}–{} s lies outside the recording ({:.2}–{:.2} s)",
        crate::stats::number_text(segment.0),
        crate::stats::number_text(segment.1),
        recording.0,
        recording.1
    )]
    SegmentOutside {
        segment: (f64, f64),
        recording: (f64, f64),
    },
    #[error("no oscillation found: the spectrum has no peak above the noise")]
    NoPeak,
    #[error("the fit did not converge ({0})")]
    NoConvergence(String),
    #[error("the free decay holds only {cycles:.1} cycles ({samples} samples); need at least 2")]
    SegmentTooShort { cycles: f64, samples: usize },
}

/// Whether to fit a linear trend beside the offset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Trend {
    /// Fit both and keep the trend when the Bayesian information criterion prefers it.
    #[default]
    Auto,
    On,
    Off,
}

/// Options of [`analyse`].
#[derive(Debug, Clone, Default)]
pub struct FitOptions {
    pub trend: Trend,
    /// Fit this time range (s), both ends included, instead of choosing the free decay
    /// automatically.
    pub segment_s: Option<(f64, f64)>,
    /// Ignore spectral peaks below this frequency (Hz); default: 2 bins of the record.
    pub min_freq_hz: Option<f64>,
}

/// A value with its standard error.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Estimate {
    pub value: f64,
    pub se: f64,
}

/// The least-squares fit of a damped sinusoid.
#[derive(Debug, Clone, PartialEq)]
pub struct DampedFit {
    /// Parameters `[a, b, c, σ, ω_d, d]` (`d` only with a trend), τ from `t_ref_s`.
    pub params: Vec<f64>,
    /// Their covariance.
    pub covariance: DMatrix<f64>,
    pub t_ref_s: f64,
    pub trend: bool,
    /// Residual RMS (square root of RSS / (N − p)).
    pub residual_rms: f64,
    pub samples: usize,
    pub iterations: usize,
}

const A: usize = 0;
const B: usize = 1;
const C: usize = 2;
const SIGMA: usize = 3;
const OMEGA: usize = 4;
const D: usize = 5;

impl DampedFit {
    /// The parameters' covariance with the noise taken as AR(1) ([`ar1_sandwich`]), from
    /// the data `t`, `x` the fit was made on; `None` when `JᵀJ` is singular.
    pub fn correlated_covariance(&self, t: &[f64], x: &[f64]) -> Option<DMatrix<f64>> {
        let n = t.len();
        let np = self.params.len();
        let tau: Vec<f64> = t.iter().map(|v| v - self.t_ref_s).collect();
        let mut jac = DMatrix::zeros(n, np);
        let mut r = DVector::zeros(n);
        residuals_and_jacobian(&self.params, self.trend, &tau, x, &mut jac, &mut r);
        let hinv = (jac.transpose() * &jac).cholesky()?.inverse();
        let rows = 0..n;
        Some(ar1_sandwich(&jac, &r, std::slice::from_ref(&rows), &hinv))
    }

    /// Model value at time `t` (s).
    pub fn eval(&self, t: f64) -> f64 {
        model(&self.params, self.trend, t - self.t_ref_s)
    }

    /// The fitted curve at every time of `t` (s) (`phasor_lanes`: one pass, no `exp` or
    /// `sin_cos` per sample on a uniform grid).
    pub fn eval_many(&self, t: &[f64]) -> Vec<f64> {
        let tau: Vec<f64> = t.iter().map(|v| v - self.t_ref_s).collect();
        let mut out = vec![0.0; tau.len()];
        phasor_lanes(self.params[SIGMA], self.params[OMEGA], &tau, |k, ch| {
            for (l, slot) in out[k..].iter_mut().take(LANES).enumerate() {
                *slot = model_from(&self.params, self.trend, ch.tau[l], (ch.es[l], ch.ec[l]));
            }
        });
        out
    }

    fn se(&self, i: usize) -> f64 {
        self.covariance[(i, i)].max(0.0).sqrt()
    }

    /// Standard error of `g(σ, ω)` from its gradient (delta method).
    fn se_sigma_omega(&self, dg_dsigma: f64, dg_domega: f64) -> f64 {
        let c = &self.covariance;
        let v = dg_dsigma * dg_dsigma * c[(SIGMA, SIGMA)]
            + 2.0 * dg_dsigma * dg_domega * c[(SIGMA, OMEGA)]
            + dg_domega * dg_domega * c[(OMEGA, OMEGA)];
        v.max(0.0).sqrt()
    }

    /// Damped angular frequency ω_d (rad/s).
    pub fn omega_d(&self) -> Estimate {
        Estimate {
            value: self.params[OMEGA],
            se: self.se(OMEGA),
        }
    }

    /// Decay rate σ = ζωₙ (1/s).
    pub fn sigma(&self) -> Estimate {
        Estimate {
            value: self.params[SIGMA],
            se: self.se(SIGMA),
        }
    }

    /// Damped frequency f_d = ω_d / 2π (Hz).
    pub fn freq_hz(&self) -> Estimate {
        Estimate {
            value: self.params[OMEGA] / (2.0 * PI),
            se: self.se(OMEGA) / (2.0 * PI),
        }
    }

    /// Damped period T = 2π / ω_d (s).
    pub fn period_s(&self) -> Estimate {
        let w = self.params[OMEGA];
        Estimate {
            value: 2.0 * PI / w,
            se: 2.0 * PI * self.se(OMEGA) / (w * w),
        }
    }

    /// Natural frequency fₙ = √(ω_d² + σ²) / 2π (Hz).
    pub fn natural_freq_hz(&self) -> Estimate {
        let (s, w) = (self.params[SIGMA], self.params[OMEGA]);
        let wn = s.hypot(w);
        Estimate {
            value: wn / (2.0 * PI),
            se: self.se_sigma_omega(s / wn, w / wn) / (2.0 * PI),
        }
    }

    /// Damping ratio ζ = σ / ωₙ.
    pub fn damping_ratio(&self) -> Estimate {
        let (s, w) = (self.params[SIGMA], self.params[OMEGA]);
        let wn = s.hypot(w);
        let wn3 = wn * wn * wn;
        Estimate {
            value: s / wn,
            se: self.se_sigma_omega(w * w / wn3, -s * w / wn3),
        }
    }

    /// Amplitude √(b² + c²) at the start of the segment.
    pub fn amplitude(&self) -> Estimate {
        let (b, c) = (self.params[B], self.params[C]);
        let amp = b.hypot(c);
        let cv = &self.covariance;
        let (gb, gc) = if amp > 0.0 {
            (b / amp, c / amp)
        } else {
            (0.0, 0.0)
        };
        let v = gb * gb * cv[(B, B)] + 2.0 * gb * gc * cv[(B, C)] + gc * gc * cv[(C, C)];
        Estimate {
            value: amp,
            se: v.max(0.0).sqrt(),
        }
    }

    /// Offset `a` at the start of the segment, and the trend `d` per second (0 without a trend).
    pub fn offset_and_trend(&self) -> (f64, f64) {
        (
            self.params[A],
            if self.trend { self.params[D] } else { 0.0 },
        )
    }
}

fn model(p: &[f64], trend: bool, tau: f64) -> f64 {
    let e = (-p[SIGMA] * tau).exp();
    let (s, c) = (p[OMEGA] * tau).sin_cos();
    let mut x = p[A] + e * (p[B] * s + p[C] * c);
    if trend {
        x += p[D] * tau;
    }
    x
}

/// Samples between exact evaluations in [`PhasorWalk`] and [`phasor_lanes`]: the recurrence's rounding grows by
/// about one unit in the last place per step, so its relative error stays below 1e-13.
const PHASOR_ANCHOR: usize = 256;

/// `(e^{−στ} sin ωτ, e^{−στ} cos ωτ)` at successive `τ`. Where consecutive `τ` are one step
/// apart (a uniform grid: every recording on the sensor's clock) the complex phasor
/// z = e^{(−σ+iω)τ} is advanced by one multiplication, z ← z·e^{(−σ+iω)Δ}; it is evaluated
/// directly at the first sample, after every change of step (a gap) and every
/// [`PHASOR_ANCHOR`] samples. This replaces an `exp` and a `sin_cos` per sample (most of the
/// fit's time) by four multiplications, to a relative error below 1e-13.
struct PhasorWalk {
    sigma: f64,
    omega: f64,
    step: f64,
    mul: (f64, f64),
    z: (f64, f64),
    prev: f64,
    since_anchor: usize,
}

impl PhasorWalk {
    fn new(sigma: f64, omega: f64) -> Self {
        PhasorWalk {
            sigma,
            omega,
            step: f64::NAN,
            mul: (0.0, 1.0),
            z: (0.0, 0.0),
            prev: f64::NAN,
            since_anchor: PHASOR_ANCHOR,
        }
    }

    fn exact(&self, t: f64) -> (f64, f64) {
        let e = (-self.sigma * t).exp();
        let (s, c) = (self.omega * t).sin_cos();
        (e * s, e * c)
    }

    /// The phasor at `t`, the next time after the previous call's.
    fn at(&mut self, t: f64) -> (f64, f64) {
        let d = t - self.prev;
        let same_step = (d - self.step).abs() <= 1e-9 * self.step.abs();
        if self.since_anchor >= PHASOR_ANCHOR || !same_step {
            self.z = self.exact(t);
            self.since_anchor = 0;
            if !same_step && d.is_finite() {
                self.step = d;
                self.mul = self.exact(d);
            }
        } else {
            // z·mul, with z = (im, re) stored as (e sin, e cos).
            let (z, m) = (self.z, self.mul);
            self.z = (z.0 * m.1 + z.1 * m.0, z.1 * m.1 - z.0 * m.0);
        }
        self.prev = t;
        self.since_anchor += 1;
        self.z
    }
}

/// Samples a [`phasor_lanes`] chunk holds.
const LANES: usize = 4;

/// One chunk of [`phasor_lanes`]: the samples' `τ`, 1 for a sample and 0 for the padding past
/// the end, and their phasors.
struct Lanes {
    tau: [f64; LANES],
    live: [f64; LANES],
    es: [f64; LANES],
    ec: [f64; LANES],
}

/// `v[k..k + LANES]`, zero past its end.
fn lanes_of(v: &[f64], k: usize) -> [f64; LANES] {
    let mut out = [0.0; LANES];
    for (o, x) in out.iter_mut().zip(&v[k.min(v.len())..]) {
        *o = *x;
    }
    out
}

/// Sums for a linear least-squares problem's normal equations over chunks of [`LANES`] rows:
/// the upper triangle of AᵀA, Aᵀy and yᵀy. Two accumulators each (a chunk's rows alternate
/// between them, and they are added at the end): the compiler packs them into one register,
/// and 28 entries of four would not stay in the registers.
struct NormalSums<const NP: usize> {
    ata: [[[f64; 2]; NP]; NP],
    aty: [[f64; 2]; NP],
    yty: [f64; 2],
}

impl<const NP: usize> NormalSums<NP> {
    fn new() -> Self {
        NormalSums {
            ata: [[[0.0; 2]; NP]; NP],
            aty: [[0.0; 2]; NP],
            yty: [0.0; 2],
        }
    }

    /// Adds the rows `a[·][l]` with right-hand sides `y[l]`, l = 0…[`LANES`].
    fn add(&mut self, a: &[[f64; LANES]; NP], y: &[f64; LANES]) {
        for half in 0..LANES / 2 {
            let lane = |v: &[f64; LANES], l: usize| v[2 * half + l];
            for i in 0..NP {
                for l in 0..2 {
                    self.aty[i][l] += lane(&a[i], l) * lane(y, l);
                }
                for j in i..NP {
                    for l in 0..2 {
                        self.ata[i][j][l] += lane(&a[i], l) * lane(&a[j], l);
                    }
                }
            }
            for l in 0..2 {
                self.yty[l] += lane(y, l) * lane(y, l);
            }
        }
    }

    /// AᵀA (symmetric, whole), Aᵀy and yᵀy.
    fn totals(&self) -> ([[f64; NP]; NP], [f64; NP], f64) {
        let sum = |v: &[f64; 2]| v[0] + v[1];
        let upper = |i: usize, j: usize| sum(&self.ata[i.min(j)][i.max(j)]);
        let ata = std::array::from_fn(|i| std::array::from_fn(|j| upper(i, j)));
        (ata, self.aty.map(|v| sum(&v)), sum(&self.yty))
    }
}

/// The damped phasors `(e^{−στ} sin ωτ, e^{−στ} cos ωτ)` of `τ`, [`LANES`] samples at a time:
/// `f(k, chunk)` for the chunk starting at sample `k` (the last one padded with zeros, its
/// `live` mask 0 past the end). On a uniform grid of step Δ (the first step) a chunk's phasors
/// are the previous sample's times the exact powers z_j = e^{(−σ+iω) jΔ}, j = 1…[`LANES`],
/// independent of one another (what [`PhasorWalk`] does one sample after another, as one long
/// chain of multiplications). A sample that is not Δ after the previous one (a gap, a
/// jittering clock) is evaluated directly, as is one every [`PHASOR_ANCHOR`] samples. Relative
/// error below 1e-13, as [`PhasorWalk`]'s.
fn phasor_lanes(sigma: f64, omega: f64, tau: &[f64], mut f: impl FnMut(usize, &Lanes)) {
    let exact = |t: f64| {
        let e = (-sigma * t).exp();
        let (s, c) = (omega * t).sin_cos();
        (e * s, e * c)
    };
    let step = if tau.len() > 1 { tau[1] - tau[0] } else { 0.0 };
    let tolerance = 1e-9 * step.abs();
    let on_step = |from: f64, to: f64| step > 0.0 && (to - from - step).abs() <= tolerance;
    // z_{j+1} = e^{(−σ+iω)(j+1)Δ} as (im, re).
    let mut pow_s = [0.0; LANES];
    let mut pow_c = [0.0; LANES];
    for j in 0..LANES {
        (pow_s[j], pow_c[j]) = exact((j + 1) as f64 * step);
    }
    // z·w with (im, re) stored as (e sin, e cos).
    let times = |z: (f64, f64), w: (f64, f64)| (z.0 * w.1 + z.1 * w.0, z.1 * w.1 - z.0 * w.0);
    // The previous sample's time and phasor, and the samples since an exact evaluation.
    let mut last: Option<(f64, (f64, f64))> = None;
    let mut since_anchor = 0;
    let mut lanes = Lanes {
        tau: [0.0; LANES],
        live: [1.0; LANES],
        es: [0.0; LANES],
        ec: [0.0; LANES],
    };
    for (chunk_index, chunk) in tau.chunks(LANES).enumerate() {
        let k = chunk_index * LANES;
        let joins = |last: Option<(f64, (f64, f64))>, t: f64, since: usize| {
            last.filter(|&(lt, _)| since < PHASOR_ANCHOR && on_step(lt, t))
        };
        let uniform = chunk.len() == LANES && chunk.windows(2).all(|w| on_step(w[0], w[1]));
        match joins(last, chunk[0], since_anchor + LANES) {
            Some((_, z)) if uniform => {
                for j in 0..LANES {
                    (lanes.es[j], lanes.ec[j]) = times(z, (pow_s[j], pow_c[j]));
                    lanes.tau[j] = chunk[j];
                }
                since_anchor += LANES;
            }
            _ => {
                for j in 0..LANES {
                    let live = j < chunk.len();
                    let t = if live { chunk[j] } else { 0.0 };
                    let z = match (live, joins(last, t, since_anchor)) {
                        (false, _) => (0.0, 0.0),
                        (true, Some((_, z))) => {
                            since_anchor += 1;
                            times(z, (pow_s[0], pow_c[0]))
                        }
                        (true, None) => {
                            since_anchor = 0;
                            exact(t)
                        }
                    };
                    if live {
                        last = Some((t, z));
                    }
                    (lanes.es[j], lanes.ec[j]) = z;
                    lanes.tau[j] = t;
                    lanes.live[j] = if live { 1.0 } else { 0.0 };
                }
            }
        }
        if uniform {
            let j = LANES - 1;
            last = Some((chunk[j], (lanes.es[j], lanes.ec[j])));
        }
        f(k, &lanes);
    }
}

/// The model at `τ` = `t` from its phasor `(e^{−στ} sin ωτ, e^{−στ} cos ωτ)`.
fn model_from(p: &[f64], trend: bool, t: f64, (es, ec): (f64, f64)) -> f64 {
    let mut m = p[A] + (p[B] * es + p[C] * ec);
    if trend {
        m += p[D] * t;
    }
    m
}

/// Residuals `model − x` and the exact Jacobian of the model, rows per sample.
fn residuals_and_jacobian(
    p: &[f64],
    trend: bool,
    tau: &[f64],
    x: &[f64],
    jac: &mut DMatrix<f64>,
    r: &mut DVector<f64>,
) {
    let mut walk = PhasorWalk::new(p[SIGMA], p[OMEGA]);
    for (i, (&t, &xi)) in tau.iter().zip(x).enumerate() {
        let (es, ec) = walk.at(t);
        let osc = p[B] * es + p[C] * ec;
        jac[(i, A)] = 1.0;
        jac[(i, B)] = es;
        jac[(i, C)] = ec;
        jac[(i, SIGMA)] = -t * osc;
        jac[(i, OMEGA)] = t * (p[B] * ec - p[C] * es);
        if trend {
            jac[(i, D)] = t;
        }
        r[i] = model_from(p, trend, t, (es, ec)) - xi;
    }
}

fn rss(p: &[f64], trend: bool, tau: &[f64], x: &[f64]) -> f64 {
    let mut walk = PhasorWalk::new(p[SIGMA], p[OMEGA]);
    tau.iter()
        .zip(x)
        .map(|(&t, &xi)| (model_from(p, trend, t, walk.at(t)) - xi).powi(2))
        .sum()
}

/// For fixed σ and ω the model is linear in `a, b, c (, d)`: solve those by least squares
/// (normal equations, the trend's column scaled to the segment's length for conditioning).
/// Returns the full parameter vector and the residual sum of squares.
fn linear_step(
    sigma: f64,
    omega: f64,
    trend: bool,
    tau: &[f64],
    x: &[f64],
) -> Option<(Vec<f64>, f64)> {
    let span = tau.last().copied().unwrap_or(1.0).max(1e-9);
    // The data less their mean (the offset column takes it back): the residual sum of squares
    // below comes from the normal equations, xᵀx − solᵀAᵀx, without a second pass over the
    // samples, and an offset large against the swing would cost it digits.
    let mean = x.iter().sum::<f64>() / x.len().max(1) as f64;
    let mut sums = NormalSums::<4>::new();
    phasor_lanes(sigma, omega, tau, |k, ch| {
        let xs = lanes_of(x, k);
        let mut rows = [[0.0; LANES]; 4];
        let mut xc = [0.0; LANES];
        for l in 0..LANES {
            rows[0][l] = ch.live[l];
            rows[1][l] = ch.es[l];
            rows[2][l] = ch.ec[l];
            rows[3][l] = if trend { ch.tau[l] / span } else { 0.0 };
            xc[l] = ch.live[l] * (xs[l] - mean);
        }
        sums.add(&rows, &xc);
    });
    let (mut upper, atx, xtx) = sums.totals();
    if !trend {
        upper[3][3] = 1.0;
    }
    let ata = nalgebra::Matrix4::from_fn(|i, j| upper[i][j]);
    let atb = nalgebra::Vector4::from(atx);
    let sol = ata.cholesky()?.solve(&atb);
    let mut p = vec![sol[0] + mean, sol[1], sol[2], sigma, omega];
    if trend {
        p.push(sol[3] / span);
    }
    let r = (xtx - sol.dot(&atb)).max(0.0);
    r.is_finite().then_some((p, r))
}

/// A nonlinear least-squares problem for [`levenberg_marquardt`]: residuals with their exact
/// Jacobian, and the cost (the residuals' sum of squares) alone for trial steps.
pub(crate) trait LeastSquares {
    /// Residuals and their Jacobian (one row per residual, one column per parameter) at `p`.
    fn residuals_and_jacobian(&self, p: &[f64], jac: &mut DMatrix<f64>, r: &mut DVector<f64>);
    /// The sum of squared residuals at `p`.
    fn cost(&self, p: &[f64]) -> f64;
    /// The bounds of parameter `i` (by default none).
    fn bounds(&self, _i: usize) -> (f64, f64) {
        (f64::NEG_INFINITY, f64::INFINITY)
    }
    /// [`LeastSquares::cost`] where it is at most `bound`; where it is above, any value above
    /// `bound` (a problem may stop summing once its partial sum is: a trial that cannot lower
    /// the cost is rejected without its whole cost). By default the whole cost.
    fn cost_within(&self, p: &[f64], bound: f64) -> f64 {
        let _ = bound;
        self.cost(p)
    }
    /// The cost at `p` with the normal equations' `JᵀJ` and `Jᵀr` written into `h` and `g`,
    /// accumulated residual by residual without storing `J`, where the problem can: then
    /// [`levenberg_marquardt`] evaluates every trial point this way, and an accepted step needs
    /// no second pass over the data. `None` (the default): the problem has only the two
    /// methods above, and a trial is judged by its cost alone.
    fn normal_equations(
        &self,
        _p: &[f64],
        _h: &mut DMatrix<f64>,
        _g: &mut DVector<f64>,
    ) -> Option<f64> {
        None
    }
    /// `JᵀJ` and `Jᵀr` at `p` for a problem without [`LeastSquares::normal_equations`] (its
    /// trials judged by their cost alone), `r` left holding the residuals: by default through
    /// the stored Jacobian (`jac`: work space); a problem whose Jacobian is mostly zeros sums
    /// its rows' nonzero products instead.
    fn accepted_normal_equations(
        &self,
        p: &[f64],
        jac: &mut DMatrix<f64>,
        r: &mut DVector<f64>,
        h: &mut DMatrix<f64>,
        g: &mut DVector<f64>,
    ) {
        self.residuals_and_jacobian(p, jac, r);
        *h = jac.tr_mul(jac);
        *g = jac.tr_mul(r);
    }
}

/// The covariance of a least-squares fit whose noise is AR(1) within each block of rows:
/// `H⁻¹ (Σ_b v_b J_bᵀ R_b J_b) H⁻¹` (`jac` the weighted Jacobian, `r` the residuals, `hinv`
/// = `(JᵀJ)⁻¹`, `blocks` the rows of each signal), `R_b[i][j] = ρ_b^|i−j|` and ρ_b, v_b from
/// the block's residuals by [`ar1_of_residuals`]. The sensors' filters and what a model leaves
/// out make neighbouring residuals alike, and n samples then hold fewer independent ones
/// (White 1980; the AR(1) case of Newey & West 1987); with ρ = 0 it is the white covariance
/// `s² H⁻¹`. Lags are counted in rows (a dropped packet shortens none). Every ride fit's
/// errors come from it (issue 75: one noise model for every instrument).
pub fn ar1_sandwich(
    jac: &DMatrix<f64>,
    r: &DVector<f64>,
    blocks: &[std::ops::Range<usize>],
    hinv: &DMatrix<f64>,
) -> DMatrix<f64> {
    let np = jac.ncols();
    let mut meat = DMatrix::zeros(np, np);
    for rows in blocks {
        let j = jac.rows(rows.start, rows.len()).into_owned();
        let rb = r.rows(rows.start, rows.len()).into_owned();
        if let Some((rho, v)) = ar1_of_residuals(&j, &rb, hinv) {
            meat += j.transpose() * ar1_times(&j, rho) * v;
        }
    }
    hinv * meat * hinv
}

/// `R J` for `R[i][j] = ρ^|i−j|`, by a forward and a backward recursion in O(n p):
/// `f_i = j_i + ρ f_{i−1}`, `b_i = j_i + ρ b_{i+1}`, `R j = f + b − j`.
pub fn ar1_times(j: &DMatrix<f64>, rho: f64) -> DMatrix<f64> {
    let (n, np) = j.shape();
    let mut y = DMatrix::zeros(n, np);
    for c in 0..np {
        let mut f = 0.0;
        for i in 0..n {
            f = j[(i, c)] + rho * f;
            y[(i, c)] = f;
        }
        let mut b = 0.0;
        for i in (0..n).rev() {
            b = j[(i, c)] + rho * b;
            y[(i, c)] += b - j[(i, c)];
        }
    }
    y
}

/// The AR(1) correlation ρ and marginal variance v of the noise under one signal's residuals
/// `r` (its Jacobian rows `j`, the fit's `hinv` = `(JᵀJ)⁻¹`), by the method of moments with
/// the fit's projection allowed for: the residuals are `M e` with `M = I − J H⁻¹ Jᵀ`, so their
/// lag-one sum and sum of squares have expectations `v tr(M A M R(ρ))` with `A` the lag-one
/// (half the off-diagonals) and the identity; ρ solves `E[lag-one sum]/E[sum of squares]` =
/// the observed ratio (bisection on [0, 0.99]; 0 when the ratio is at or below the white
/// noise's), and `v` = sum of squares / `tr(M M R(ρ))`. Why not the residuals' plain lag-one
/// autocorrelation: it reads low by what the fit absorbs, and its errors fell short of the
/// scatter ([docs/decisions/2026-12-02-ride-estimator.md](../docs/decisions/2026-12-02-ride-estimator.md#2026-12-02-fourth-session-variable-projection-on-todays-structures-and-the-errors-of-correlated-residuals)).
/// `None` for zero residuals.
pub fn ar1_of_residuals(
    j: &DMatrix<f64>,
    r: &DVector<f64>,
    hinv: &DMatrix<f64>,
) -> Option<(f64, f64)> {
    let n = j.nrows();
    let ss = r.norm_squared();
    if ss <= 0.0 || n < 3 {
        return None;
    }
    let lag: f64 = (1..n).map(|i| r[i] * r[i - 1]).sum();
    let observed = lag / ss;
    // A J for A = half the lag-one off-diagonals.
    let mut aj = DMatrix::zeros(n, j.ncols());
    for i in 0..n {
        for c in 0..j.ncols() {
            let before = if i > 0 { j[(i - 1, c)] } else { 0.0 };
            let after = if i + 1 < n { j[(i + 1, c)] } else { 0.0 };
            aj[(i, c)] = 0.5 * (before + after);
        }
    }
    // The traces below as sums of elementwise products with R J, each O(n p):
    // tr(H⁻¹ XᵀRJ) = Σ (X H⁻¹) ∘ RJ, tr(K JᵀRJ) = Σ (J K) ∘ RJ for symmetric K.
    let jh = j * hinv;
    let ajh = &aj * hinv;
    let j_k_lag = &jh * (aj.transpose() * &jh);
    let j_k_sq = &jh * (j.transpose() * &jh);
    // E[lag-one sum]/v and E[sum of squares]/v at ρ.
    let moments = |rho: f64| -> (f64, f64) {
        let rj = ar1_times(j, rho);
        let lag = (n - 1) as f64 * rho - 2.0 * ajh.dot(&rj) + j_k_lag.dot(&rj);
        let sq = n as f64 - 2.0 * jh.dot(&rj) + j_k_sq.dot(&rj);
        (lag, sq)
    };
    let ratio = |rho: f64| {
        let (lag, sq) = moments(rho);
        lag / sq
    };
    let rho = if ratio(0.0) >= observed {
        0.0
    } else if ratio(0.99) <= observed {
        0.99
    } else {
        let (mut lo, mut hi) = (0.0, 0.99);
        for _ in 0..30 {
            let mid = 0.5 * (lo + hi);
            if ratio(mid) < observed {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    };
    let sq = moments(rho).1;
    (sq > 0.0 && rho.is_finite()).then(|| (rho, ss / sq))
}

/// Where [`levenberg_marquardt`] stopped: the parameters, the cost there, the iterations used,
/// `JᵀJ` at the solution (for the covariance), and whether it converged.
pub(crate) struct Solution {
    pub params: Vec<f64>,
    pub cost: f64,
    pub iterations: usize,
    pub normal: DMatrix<f64>,
    /// The Gauss–Newton step left at the solution moves no parameter by more than
    /// [`CONVERGED_STEP_SE`] of its standard error ([`gauss_newton_step_in_se`]).
    pub converged: bool,
}

/// A fit has converged when the Gauss–Newton step still to take moves no parameter by more
/// than this fraction of its standard error: what is left is below any figure a report
/// prints and far below the 0.05 SE an iteration limit may move an answer (issue 75).
pub(crate) const CONVERGED_STEP_SE: f64 = 1e-3;

/// The largest |δᵢ| / SEᵢ of the Gauss–Newton step δ = −H⁻¹g from normal equations `h`, `g` at
/// `p` with cost `cost` over `n` residuals, SEᵢ = √(s² (H⁻¹)ᵢᵢ), s² = cost / (n − p): how far
/// the minimum of the local quadratic lies, in the parameters' own errors. The step is first
/// held to the problem's bounds ([`LeastSquares::bounds`]): a parameter at its bound with the
/// step pointing out has nowhere to go. `None` when `h` is singular.
pub(crate) fn gauss_newton_step_in_se(
    problem: &dyn LeastSquares,
    p: &[f64],
    h: &DMatrix<f64>,
    g: &DVector<f64>,
    cost: f64,
    n: usize,
) -> Option<f64> {
    let np = p.len();
    let (h, g) = free_system(problem, p, h, g);
    let ch = h.cholesky()?;
    let delta = ch.solve(&(-g));
    let mut trial: Vec<f64> = p.iter().zip(delta.iter()).map(|(a, b)| a + b).collect();
    clamp(problem, &mut trial);
    let s2 = cost / (n.saturating_sub(np)).max(1) as f64;
    let hinv = ch.inverse();
    let worst = (0..np)
        .map(|i| {
            let se = (s2 * hinv[(i, i)]).max(1e-300).sqrt();
            (trial[i] - p[i]).abs() / se
        })
        .fold(0.0, f64::max);
    worst.is_finite().then_some(worst)
}

/// `p` held within the problem's bounds ([`LeastSquares::bounds`]).
pub(crate) fn clamp(problem: &dyn LeastSquares, p: &mut [f64]) {
    for (i, v) in p.iter_mut().enumerate() {
        let (lo, hi) = problem.bounds(i);
        *v = v.clamp(lo, hi);
    }
}

/// The normal equations `h`, `g` with every parameter held at its bound taken out (its row
/// and column of `h` the identity's, its gradient 0): a parameter at a bound that the descent
/// direction −g would push beyond it stays there, and the step is the other parameters'
/// (a projected Gauss–Newton step).
pub(crate) fn free_system(
    problem: &dyn LeastSquares,
    p: &[f64],
    h: &DMatrix<f64>,
    g: &DVector<f64>,
) -> (DMatrix<f64>, DVector<f64>) {
    let (mut h, mut g) = (h.clone(), g.clone());
    for (i, &v) in p.iter().enumerate() {
        let (lo, hi) = problem.bounds(i);
        if (v <= lo && g[i] > 0.0) || (v >= hi && g[i] < 0.0) {
            h.row_mut(i).fill(0.0);
            h.column_mut(i).fill(0.0);
            h[(i, i)] = 1.0;
            g[i] = 0.0;
        }
    }
    (h, g)
}

/// The damped step `δ = −(H + λ diag(D))⁻¹ g` (Marquardt's scaling by the diagonal of `d`, each
/// entry at least 1e-300); `None` where that matrix is not positive definite (a larger λ is
/// the caller's next try).
pub(crate) fn marquardt_step(
    h: &DMatrix<f64>,
    d: &DMatrix<f64>,
    g: &DVector<f64>,
    lambda: f64,
) -> Option<DVector<f64>> {
    let mut a = h.clone();
    for k in 0..h.nrows() {
        a[(k, k)] += lambda * d[(k, k)].max(1e-300);
    }
    Some(a.cholesky()?.solve(&(-g)))
}

/// Levenberg–Marquardt on all parameters from `p0` (`n` residuals), with Marquardt's diagonal
/// scaling; each trial held to the problem's bounds ([`LeastSquares::bounds`]). Stops when the
/// Gauss–Newton step left is below `tolerance_se` of every parameter's standard error
/// ([`gauss_newton_step_in_se`]; 0 never stops there), when a step no longer lowers the cost,
/// gains less than 1e-15 of it or moves no parameter by 1e-12 of its size, or after
/// `max_iterations`. [`Solution::converged`] says whether the step left is below
/// [`CONVERGED_STEP_SE`] where it stopped.
pub(crate) fn levenberg_marquardt(
    problem: &dyn LeastSquares,
    n: usize,
    p0: Vec<f64>,
    max_iterations: usize,
    tolerance_se: f64,
) -> Solution {
    let np = p0.len();
    let mut p = p0;
    let (mut h, mut g) = (DMatrix::zeros(np, np), DVector::zeros(np));
    let (mut h_trial, mut g_trial) = (DMatrix::zeros(np, np), DVector::zeros(np));
    let first = problem.normal_equations(&p, &mut h, &mut g);
    let fused = first.is_some();
    // The stored Jacobian only for a problem without its own accumulation.
    let (rows, cols) = if fused { (0, 0) } else { (n, np) };
    let mut jac = DMatrix::zeros(rows, cols);
    let mut r = DVector::zeros(rows);
    let mut cost = match first {
        Some(cost) => cost,
        None => {
            problem.accepted_normal_equations(&p, &mut jac, &mut r, &mut h, &mut g);
            r.norm_squared()
        }
    };
    let mut lambda = 1e-3;
    let mut iterations = 0;
    for it in 0..max_iterations {
        if tolerance_se > 0.0
            && gauss_newton_step_in_se(problem, &p, &h, &g, cost, n)
                .is_some_and(|s| s < tolerance_se)
        {
            break;
        }
        iterations = it + 1;
        let mut improved = false;
        let mut small_step = false;
        // The parameters held at their bounds out of the step (none without bounds).
        let (h_free, g_free) = free_system(problem, &p, &h, &g);
        while lambda < 1e16 {
            let Some(delta) = marquardt_step(&h_free, &h_free, &g_free, lambda) else {
                lambda *= 10.0;
                continue;
            };
            // The reduction the quadratic model predicts: −(2 δᵀg + δᵀHδ).
            let predicted = -(2.0 * delta.dot(&g_free) + delta.dot(&(&h_free * &delta)));
            if predicted <= 1e-15 * cost {
                // Converged: no step can gain more than rounding (its trials were all
                // rejected, one λ after another, until λ was enormous).
                small_step = true;
                break;
            }
            let mut trial: Vec<f64> = p.iter().zip(delta.iter()).map(|(a, b)| a + b).collect();
            clamp(problem, &mut trial);
            let new_cost = if fused {
                problem
                    .normal_equations(&trial, &mut h_trial, &mut g_trial)
                    .unwrap_or(f64::NAN)
            } else {
                problem.cost_within(&trial, cost)
            };
            let rel_step = delta
                .iter()
                .zip(&p)
                .map(|(d, v)| d.abs() / (v.abs() + 1e-12))
                .fold(0.0, f64::max);
            if new_cost.is_finite() && new_cost <= cost {
                let gain = (cost - new_cost) / cost.max(1e-300);
                p = trial;
                cost = new_cost;
                lambda = (lambda / 10.0).max(1e-15);
                improved = true;
                small_step = gain < 1e-15 || rel_step < 1e-12;
                if fused {
                    std::mem::swap(&mut h, &mut h_trial);
                    std::mem::swap(&mut g, &mut g_trial);
                }
                break;
            }
            lambda *= 10.0;
        }
        // No step taken: the normal equations are still those of `p`.
        if !fused && improved {
            problem.accepted_normal_equations(&p, &mut jac, &mut r, &mut h, &mut g);
        }
        if !improved || small_step {
            break;
        }
    }
    let converged = gauss_newton_step_in_se(problem, &p, &h, &g, cost, n)
        .is_some_and(|s| s < CONVERGED_STEP_SE.max(tolerance_se));
    Solution {
        params: p,
        cost,
        iterations,
        normal: h,
        converged,
    }
}

/// The damped sinusoid of [`fit_damped_sinusoid`] as a least-squares problem.
struct Sinusoid<'a> {
    tau: &'a [f64],
    x: &'a [f64],
    trend: bool,
}

impl LeastSquares for Sinusoid<'_> {
    fn residuals_and_jacobian(&self, p: &[f64], jac: &mut DMatrix<f64>, r: &mut DVector<f64>) {
        residuals_and_jacobian(p, self.trend, self.tau, self.x, jac, r);
    }
    fn cost(&self, p: &[f64]) -> f64 {
        rss(p, self.trend, self.tau, self.x)
    }
    fn normal_equations(
        &self,
        p: &[f64],
        h: &mut DMatrix<f64>,
        g: &mut DVector<f64>,
    ) -> Option<f64> {
        Some(if self.trend {
            sinusoid_normal_equations::<6>(p, self.tau, self.x, h, g)
        } else {
            sinusoid_normal_equations::<5>(p, self.tau, self.x, h, g)
        })
    }
}

/// The cost, `JᵀJ` and `Jᵀr` of the damped sinusoid (`NP` = 5 parameters, or 6 with the trend)
/// in one pass over the samples ([`phasor_lanes`], [`NormalSums`]), the Jacobian's rows those
/// of [`residuals_and_jacobian`], never stored.
fn sinusoid_normal_equations<const NP: usize>(
    p: &[f64],
    tau: &[f64],
    x: &[f64],
    h: &mut DMatrix<f64>,
    g: &mut DVector<f64>,
) -> f64 {
    let trend = NP > D;
    let mut sums = NormalSums::<NP>::new();
    let (b, c) = (p[B], p[C]);
    phasor_lanes(p[SIGMA], p[OMEGA], tau, |k, ch| {
        let xs = lanes_of(x, k);
        let mut rows = [[0.0; LANES]; NP];
        let mut r = [0.0; LANES];
        for l in 0..LANES {
            let (t, es, ec) = (ch.tau[l], ch.es[l], ch.ec[l]);
            let osc = b * es + c * ec;
            rows[A][l] = ch.live[l];
            rows[B][l] = es;
            rows[C][l] = ec;
            rows[SIGMA][l] = -t * osc;
            rows[OMEGA][l] = t * (b * ec - c * es);
            if trend {
                rows[NP - 1][l] = t;
            }
            // Zero on the padding (its row is zero there too).
            r[l] = ch.live[l] * (model_from(p, trend, t, (es, ec)) - xs[l]);
        }
        sums.add(&rows, &r);
    });
    let (hs, gs, cost) = sums.totals();
    *h = DMatrix::from_fn(NP, NP, |i, j| hs[i][j]);
    *g = DVector::from_column_slice(&gs);
    cost
}

/// Levenberg–Marquardt (`levenberg_marquardt`) on all parameters from `p0`.
///
/// `tau` is time from the segment start; the result's covariance is `s² (JᵀJ)⁻¹` with
/// `s² = RSS / (N − p)`.
pub fn fit_damped_sinusoid(
    tau: &[f64],
    x: &[f64],
    t_ref_s: f64,
    p0: &[f64],
    trend: bool,
) -> Result<DampedFit, FitError> {
    let np = if trend { 6 } else { 5 };
    let n = tau.len();
    if n <= np + 2 {
        return Err(FitError::TooShort(n));
    }
    let problem = Sinusoid { tau, x, trend };
    let Solution {
        params: mut p,
        cost,
        iterations,
        normal: mut h,
        ..
    } = levenberg_marquardt(&problem, n, p0[..np].to_vec(), 500, 0.0);
    if p[OMEGA] < 0.0 {
        // ω → −ω with b → −b is the same curve.
        p[OMEGA] = -p[OMEGA];
        p[B] = -p[B];
        let mut g = DVector::zeros(np);
        problem.normal_equations(&p, &mut h, &mut g);
    }
    let dof = (n - np) as f64;
    let s2 = cost / dof;
    let hinv = h
        .clone()
        .cholesky()
        .map(|c| c.inverse())
        .or_else(|| h.pseudo_inverse(1e-14).ok())
        .ok_or_else(|| FitError::NoConvergence("singular normal matrix".into()))?;
    if !p.iter().all(|v| v.is_finite()) || !s2.is_finite() {
        return Err(FitError::NoConvergence("non-finite parameters".into()));
    }
    Ok(DampedFit {
        params: p,
        covariance: hinv * s2,
        t_ref_s,
        trend,
        residual_rms: s2.sqrt(),
        samples: n,
        iterations,
    })
}

/// Samples the σ search of [`initial_guess`] looks at, at most: a start needs no more.
const GUESS_SAMPLES: usize = 512;

/// Starting values for σ and ω: ω from the spectral peak, σ by a search over a logarithmic
/// grid of damping ratios, each solved for the linear parameters (variable projection). On a
/// long record the search looks at every m-th sample (at most [`GUESS_SAMPLES`], at least 16 a
/// period): the start moves a little, the least-squares optimum it leads to does not.
fn initial_guess(tau: &[f64], x: &[f64], omega0: f64, trend: bool) -> Option<Vec<f64>> {
    let n = tau.len();
    let step_s = if n > 1 {
        (tau[n - 1] - tau[0]) / (n - 1) as f64
    } else {
        1.0
    };
    let per_period = (2.0 * PI / omega0 / step_s / 16.0).floor().max(1.0) as usize;
    let stride = n.div_ceil(GUESS_SAMPLES).clamp(1, per_period);
    let (tau_s, x_s): (Vec<f64>, Vec<f64>) = tau
        .iter()
        .zip(x)
        .step_by(stride)
        .map(|(&t, &v)| (t, v))
        .unzip();
    let mut best: Option<(f64, f64)> = None;
    for k in 0..20 {
        let zeta = 1e-4 * 10f64.powf(k as f64 * 3.5 / 19.0); // 1e-4 … 0.3
        let sigma = zeta * omega0;
        if let Some((_, r)) = linear_step(sigma, omega0, trend, &tau_s, &x_s) {
            if best.is_none_or(|(_, br)| r < br) {
                best = Some((sigma, r));
            }
        }
    }
    // The linear parameters of the best σ from every sample.
    best.and_then(|(sigma, _)| linear_step(sigma, omega0, trend, tau, x).map(|(p, _)| p))
}

/// Fits `t, x` (times in s) with τ measured from `t[0]`, starting from `omega0` (rad/s) and a
/// search over σ.
pub fn fit_from_frequency(
    t: &[f64],
    x: &[f64],
    omega0: f64,
    trend: bool,
) -> Result<DampedFit, FitError> {
    let t_ref = *t.first().ok_or(FitError::TooShort(0))?;
    let tau: Vec<f64> = t.iter().map(|v| v - t_ref).collect();
    let p0 = initial_guess(&tau, x, omega0, trend)
        .ok_or_else(|| FitError::NoConvergence("no starting point".into()))?;
    fit_damped_sinusoid(&tau, x, t_ref, &p0, trend)
}

/// Fits `t, x` starting from a previous fit's σ and ω (the linear parameters solved afresh).
fn fit_from_guess(
    t: &[f64],
    x: &[f64],
    sigma0: f64,
    omega0: f64,
    trend: bool,
) -> Result<DampedFit, FitError> {
    let t_ref = *t.first().ok_or(FitError::TooShort(0))?;
    let tau: Vec<f64> = t.iter().map(|v| v - t_ref).collect();
    let (p0, _) = linear_step(sigma0, omega0, trend, &tau, x)
        .ok_or_else(|| FitError::NoConvergence("no starting point".into()))?;
    fit_damped_sinusoid(&tau, x, t_ref, &p0, trend)
}

/// Fits a damped sinusoid x(t) = a + e^{−στ}(b sin ωτ + c cos ωτ) to a short record (down to
/// half a cycle, where no spectrum resolves the frequency): the start is the best of a grid
/// over σ from −2 to 6 /s (0.25 /s steps) and ω in `omega_range`, each point with its linear
/// parameters solved: ω in steps of 0.25 rad/s first, then in steps of 0.05 rad/s within 0.25
/// of the [`SHORT_DECAY_REFINED`] best of those (a record of at most 10 s has minima at least
/// 0.6 rad/s wide); then Levenberg–Marquardt from it ([`fit_damped_sinusoid`]). For a
/// roll-rate record after a kick: the weave's σ and ω (the eigenvalue −σ ± iω) with the fit's
/// standard errors; no trend (half a cycle cannot tell one from the swing).
pub fn fit_short_decay(
    t: &[f64],
    x: &[f64],
    omega_range: (f64, f64),
) -> Result<DampedFit, FitError> {
    if t.len() < 16 || x.len() != t.len() {
        return Err(FitError::TooShort(t.len()));
    }
    let t_ref = t[0];
    let tau: Vec<f64> = t.iter().map(|v| v - t_ref).collect();
    // The grid's envelopes e^{−στ} once for every σ, its carriers once per ω: a real
    // instrument's jittering clock leaves no uniform step for the phasor recurrence, and
    // `exp` and `sin_cos` per sample per grid point took most of a CSV ride's analysis.
    let sigmas: Vec<f64> = (0..=32).map(|k| -2.0 + 0.25 * k as f64).collect();
    let envelopes: Vec<Vec<f64>> = sigmas
        .iter()
        .map(|s| tau.iter().map(|t| (-s * t).exp()).collect())
        .collect();
    let sum_sq: f64 = x.iter().map(|v| v * v).sum();
    let mut carrier = vec![(0.0, 0.0); tau.len()];
    // The best (parameters, residual sum of squares) over every σ at one ω.
    let mut best_at = |omega: f64| -> Option<([f64; 5], f64)> {
        for (slot, t) in carrier.iter_mut().zip(&tau) {
            *slot = (omega * t).sin_cos();
        }
        sigmas
            .iter()
            .zip(&envelopes)
            .filter_map(|(&sigma, env)| linear_step_on(sigma, omega, env, &carrier, x, sum_sq))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    };
    let grid = |lo: f64, hi: f64, step: f64| {
        let n = ((hi - lo) / step + 1e-9).floor() as usize;
        (0..=n).map(move |k| lo + step * k as f64)
    };
    let (coarse, fine) = (0.25, 0.05);
    let mut coarse_best: Vec<(f64, f64)> = grid(omega_range.0, omega_range.1, coarse)
        .filter_map(|omega| best_at(omega).map(|(_, r)| (omega, r)))
        .collect();
    coarse_best.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut best: Option<([f64; 5], f64)> = None;
    for &(centre, _) in coarse_best.iter().take(SHORT_DECAY_REFINED) {
        let lo = (centre - coarse).max(omega_range.0);
        let hi = (centre + coarse).min(omega_range.1);
        for omega in grid(lo, hi, fine) {
            if let Some((p, r)) = best_at(omega) {
                if best.as_ref().is_none_or(|b| r < b.1) {
                    best = Some((p, r));
                }
            }
        }
    }
    let (p0, _) = best.ok_or_else(|| FitError::NoConvergence("no starting point".into()))?;
    fit_damped_sinusoid(&tau, x, t_ref, &p0, false)
}

/// The coarse grid's best frequencies that [`fit_short_decay`] refines.
pub const SHORT_DECAY_REFINED: usize = 3;

/// [`linear_step`] without a trend from a record's envelope `e^{−στ}` and carrier
/// `(sin ωτ, cos ωτ)` at every sample; the residual sum of squares from the normal equations
/// (Σx² − pᵀAᵀx, `sum_sq` = Σx²). The sums of the row (1, e sin, e cos) times itself and
/// times x, each product once (the upper triangle, mirrored), in the samples' order.
fn linear_step_on(
    sigma: f64,
    omega: f64,
    envelope: &[f64],
    carrier: &[(f64, f64)],
    x: &[f64],
    sum_sq: f64,
) -> Option<([f64; 5], f64)> {
    let [mut a00, mut a01, mut a02, mut a11, mut a12, mut a22] = [0.0; 6];
    let [mut b0, mut b1, mut b2] = [0.0; 3];
    for ((&e, &(s, c)), &xi) in envelope.iter().zip(carrier).zip(x) {
        let (es, ec) = (e * s, e * c);
        a00 += 1.0;
        a01 += es;
        a02 += ec;
        a11 += es * es;
        a12 += es * ec;
        a22 += ec * ec;
        b0 += xi;
        b1 += es * xi;
        b2 += ec * xi;
    }
    let ata = nalgebra::Matrix3::new(a00, a01, a02, a01, a11, a12, a02, a12, a22);
    let atb = nalgebra::Vector3::new(b0, b1, b2);
    let sol = ata.cholesky()?.solve(&atb);
    let r = sum_sq - sol.dot(&atb);
    r.is_finite()
        .then_some(([sol[0], sol[1], sol[2], sigma, omega], r))
}

/// Everything measured about one free oscillation.
#[derive(Debug, Clone)]
pub struct Oscillation {
    pub fit: DampedFit,
    /// The free-decay segment fitted, seconds `[start, end]`.
    pub segment_s: (f64, f64),
    /// The spectral peak the fit started from (rectangular window over the stretch of motion).
    pub main_peak: Peak,
    /// Peaks of the fit residual's spectrum that stand out of its noise: other modes (the
    /// Cardan joint's swing), strongest first.
    pub secondary_peaks: Vec<Peak>,
    /// Bayesian information criterion of the chosen model (lower is better).
    pub bic: f64,
}

fn bic(fit: &DampedFit) -> f64 {
    let n = fit.samples as f64;
    let p = fit.params.len() as f64;
    let rss = fit.residual_rms.powi(2) * (n - p);
    n * (rss / n).ln() + p * n.ln()
}

/// Centered moving mean over `w` samples (shorter at the ends), in O(n).
fn moving_mean(x: &[f64], w: usize) -> Vec<f64> {
    let n = x.len();
    let mut prefix = vec![0.0; n + 1];
    for i in 0..n {
        prefix[i + 1] = prefix[i] + x[i];
    }
    let h = w / 2;
    (0..n)
        .map(|i| {
            let lo = i.saturating_sub(h);
            let hi = (i + w - h).min(n);
            (prefix[hi] - prefix[lo]) / (hi - lo) as f64
        })
        .collect()
}

/// The variance of the noise on `x`, from its second differences: for white noise of variance
/// s² a second difference has variance 6 s² and median absolute value 0.6745·√6·s; a swing
/// well below the sampling rate adds little to them (a 5 Hz swing at 100 Hz, 9 % of its
/// amplitude), and the median ignores the release's jolt.
fn noise_variance(x: &[f64]) -> f64 {
    if x.len() < 3 {
        return 0.0;
    }
    let d2: Vec<f64> = x
        .windows(3)
        .map(|w| (w[0] - 2.0 * w[1] + w[2]).abs())
        .collect();
    (crate::signal::median(&d2) / 0.6745).powi(2) / 6.0
}

/// Where the motion is: from the window of largest variance (0.5 s windows) until the variance
/// sinks to the quiet level (4× the smallest window's, and a tenth of the largest, but at least
/// twice the noise's, [`noise_variance`]) for 2 s. Returns sample indices `[begin, end]`.
/// The largest variance is often the window that straddles the release (the held angle, then
/// the first swing), so `begin` is the end of that window: surely inside the free decay.
fn motion_stretch(x: &[f64], rate_hz: f64) -> (usize, usize) {
    let n = x.len();
    let w = ((0.5 * rate_hz).round() as usize).clamp(5, n.max(5));
    let m = moving_mean(x, w);
    let sq: Vec<f64> = x.iter().map(|v| v * v).collect();
    let m2 = moving_mean(&sq, w);
    let var: Vec<f64> = m2
        .iter()
        .zip(&m)
        .map(|(a, b)| (a - b * b).max(0.0))
        .collect();
    let imax = (0..n)
        .max_by(|&a, &b| var[a].total_cmp(&var[b]))
        .unwrap_or(0);
    let quiet = var
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
        .max(var[imax] * 1e-12);
    // Quiet for 2 s on end: near a crest of a slow swing a 0.5 s window is briefly quiet too.
    let sustain = (2.0 * rate_hz).round() as usize;
    let mut run = 0;
    let mut end = n - 1;
    // Quiet is also well below the motion (a tenth of the largest variance): a lightly damped
    // swing recorded without a rest after it (normal in a real lab) has no quiet windows, and
    // its smallest (at the record's end, where the windows are short) made the swing itself
    // "quiet", leaving too short a stretch to find its frequency in ("no peak above the
    // noise" on clean 12-cycle swings).
    // And quiet is never below twice the noise: at a low signal-to-noise ratio (a rate gyro's
    // 1 rad/s of noise under a 5 rad/s swing, 12 dB) a tenth of the largest variance is under
    // the noise's own, no window is quiet and the stretch ran to the record's end, 40 s of
    // noise burying a 3 s decay's peak.
    let quiet_below = (4.0 * quiet)
        .min(0.1 * var[imax])
        .max(2.0 * noise_variance(x));
    for (i, &v) in var.iter().enumerate().skip(imax) {
        run = if v < quiet_below { run + 1 } else { 0 };
        if run >= sustain {
            end = (i + 1 - run + w / 2).min(n - 1);
            break;
        }
    }
    ((imax + w / 2).min(end.saturating_sub(16)), end)
}

/// `bikeproc period FILE`: the free oscillation of one recording (a log pair or a `time_s,value`
/// CSV), its summary with the receiver's off-time rows, and the reader's warnings.
pub fn measure_file(
    file: &std::path::Path,
    extract: &crate::signal::Extract,
    sensor: Option<&str>,
    options: &FitOptions,
) -> Result<(OscillationSummary, Vec<String>), MeasureError> {
    let loaded = crate::signal::load_signal(
        file,
        extract,
        sensor,
        &crate::read::log::ReadOptions::default(),
    )?;
    let sig = &loaded.signal;
    let osc = analyse(sig, options).map_err(|error| MeasureError::Fit {
        path: file.to_path_buf(),
        error,
    })?;
    let mut summary = osc.summary(sig);
    summary.receiver_time_off_rows = loaded.time_off_rows;
    Ok((summary, loaded.warnings))
}

/// Why [`measure_file`] found no period: the file, or the fit (named with the file).
#[derive(Debug, thiserror::Error)]
pub enum MeasureError {
    #[error(transparent)]
    Read(#[from] crate::signal::SignalError),
    /// The fit's error, said once with its file (not also as a cause: `{e:#}` printed it
    /// twice).
    #[error("{}: {error}", path.display())]
    Fit {
        path: std::path::PathBuf,
        error: FitError,
    },
}

/// Measures the free oscillation in `signal`: where it is, its frequency, the free-decay
/// segment, the fit, other modes.
///
/// 1. The stretch of motion (`motion_stretch`) and its rectangular-window spectrum give the
///    starting frequency; a σ search and Levenberg–Marquardt give a first fit.
/// 2. The segment: extended backwards until the data leave the fitted decay (the release:
///    before it the body was held), with a guard of half a window for the release transient;
///    ended where the fitted envelope has sunk to a tenth of the noise (the tail lost in noise:
///    the samples after it hold < 2 % of the frequency information even at 10 dB) or where the
///    residual's RMS over a period jumps above 3× the noise (a catch or a knock), or at the
///    record's end. Refitted until the segment stands still.
/// 3. With or without a linear trend, by the Bayesian information criterion ([`Trend::Auto`]).
pub fn analyse(signal: &Signal, options: &FitOptions) -> Result<Oscillation, FitError> {
    let n = signal.len();
    if n < 16 {
        return Err(FitError::TooShort(n));
    }
    let t = signal.times_s();
    let x = &signal.values;
    let trend_for_search = options.trend != Trend::Off;
    let (mut i0, mut i1) = match options.segment_s {
        Some((a, b)) => {
            // Both ends included: a sample's time is t0 + i/rate, rounded, and 30000 × 0.001
            // gives 30.000000000000004, which `t ≤ 30` dropped. A millionth of a sample covers it.
            let slack = 1e-6 / signal.sample_rate_hz;
            let i0 = t.iter().position(|&v| v >= a - slack).unwrap_or(n);
            let i1 = t.iter().rposition(|&v| v <= b + slack).unwrap_or(0);
            if i1 <= i0 + 8 {
                let span = (t.first().copied(), t.last().copied());
                return Err(match span {
                    (Some(first), Some(last)) if b < first || a > last => {
                        FitError::SegmentOutside {
                            segment: (a, b),
                            recording: (first, last),
                        }
                    }
                    _ => FitError::TooShort(i1.saturating_sub(i0)),
                });
            }
            (i0, i1)
        }
        None => motion_stretch(x, signal.sample_rate_hz),
    };
    if i1 < i0 + 16 {
        return Err(FitError::TooShort(i1 + 1 - i0));
    }
    let stretch = signal.part(i0, i1, x[i0..=i1].to_vec());
    let stretch_spectrum = ZoomSpectrum::of(&stretch, Window::Rectangular);
    let min_f = options
        .min_freq_hz
        .unwrap_or(2.0 * stretch_spectrum.resolution_hz);
    let main_peak = stretch_spectrum.main_peak(min_f).ok_or(FitError::NoPeak)?;
    let omega0 = 2.0 * PI * main_peak.freq_hz;

    let mut fit = fit_from_frequency(&t[i0..=i1], &x[i0..=i1], omega0, trend_for_search)?;
    // Refit samples i0..=i1 from a previous fit's σ and ω.
    let refit = |prev: &DampedFit, i0: usize, i1: usize| {
        fit_from_guess(
            &t[i0..=i1],
            &x[i0..=i1],
            prev.sigma().value,
            prev.omega_d().value,
            trend_for_search,
        )
    };
    if options.segment_s.is_none() {
        // After the first fit on the stretch of motion, the decay runs to the record's end
        // (refitted unless the stretch already did).
        if i1 != n - 1 {
            i1 = n - 1;
            fit = refit(&fit, i0, i1)?;
        }
        for _ in 0..6 {
            let (start, end) = refine_segment(&fit, &t, x, i0, signal.sample_rate_hz);
            if start == i0 && end == i1 {
                break;
            }
            i0 = start;
            i1 = end.max(i0 + 16).min(n - 1);
            fit = refit(&fit, i0, i1)?;
        }
    }
    // Final model: trend or not.
    let (seg_t, seg_x) = (&t[i0..=i1], &x[i0..=i1]);
    let (sg, w) = (fit.sigma().value, fit.omega_d().value);
    fit = match options.trend {
        Trend::On => fit,
        Trend::Off => fit_from_guess(seg_t, seg_x, sg, w, false)?,
        Trend::Auto => {
            let without = fit_from_guess(seg_t, seg_x, sg, w, false)?;
            if bic(&without) <= bic(&fit) {
                without
            } else {
                fit
            }
        }
    };
    let cycles = (seg_t[seg_t.len() - 1] - seg_t[0]) * fit.freq_hz().value;
    if cycles < 2.0 {
        return Err(FitError::SegmentTooShort {
            cycles,
            samples: seg_t.len(),
        });
    }
    let segment = signal.part(i0, i1, seg_x.to_vec());
    let residual = signal.part(
        i0,
        i1,
        fit.eval_many(seg_t)
            .iter()
            .zip(seg_x)
            .map(|(m, xi)| xi - m)
            .collect(),
    );
    // Rectangular windows: a second mode decays early in the segment, where Hann's taper would
    // hide it; the residual has no step at its start.
    let secondary_peaks = secondary_peaks(
        &ZoomSpectrum::of(&segment, Window::Rectangular),
        &ZoomSpectrum::of(&residual, Window::Rectangular),
        main_peak.freq_hz,
    );
    Ok(Oscillation {
        bic: bic(&fit),
        fit,
        segment_s: (t[i0], t[i1]),
        main_peak,
        secondary_peaks,
    })
}

/// One step of the segment choice of [`analyse`]: the start walked back to the release, the end
/// where the decay is lost in noise or disturbed.
fn refine_segment(
    fit: &DampedFit,
    t: &[f64],
    x: &[f64],
    i0: usize,
    rate_hz: f64,
) -> (usize, usize) {
    let n = t.len();
    let s = fit.residual_rms;
    let period_samples = ((rate_hz * 2.0 * PI / fit.omega_d().value).round() as usize).clamp(3, n);
    let squares: Vec<f64> = fit
        .eval_many(t)
        .iter()
        .zip(x)
        .map(|(m, xk)| (m - xk).powi(2))
        .collect();
    let sq = |k: usize| squares[k];
    let window_rms =
        |lo: usize, hi: usize| ((lo..hi).map(sq).sum::<f64>() / (hi - lo).max(1) as f64).sqrt();
    let w = (period_samples / 8).max(8);
    let (amp, sigma) = (fit.amplitude().value, fit.sigma().value);
    let envelope = |k: usize| amp * (-sigma * (t[k] - fit.t_ref_s)).exp();
    let mut start = i0;
    // Forward: a segment that begins in the hold before the release misfits there by a good
    // fraction of the swing's amplitude.
    let limit = (i0 + 4 * period_samples).min(n.saturating_sub(w + 1));
    while start < limit {
        let r = window_rms(start, start + w);
        if r <= 2.0 * s || r <= 0.3 * envelope(start) {
            break;
        }
        start += w / 2;
    }
    if start == i0 {
        // Backward: extend while a window fits as well as the decay's first period does
        // (within 2×; that period's residual includes any model mismatch at full amplitude,
        // so a slightly imperfect model does not stop the walk, the release does).
        let reference = s.max(window_rms(i0, (i0 + period_samples).min(n)));
        let mut left_decay = false;
        while start > 0 {
            let lo = start.saturating_sub(w);
            if window_rms(lo, start) > 2.0 * reference {
                left_decay = true;
                break;
            }
            start = lo;
        }
        if left_decay && start < i0 {
            // The release lies in the window before `start`: skip its transient, w/2 more.
            start += w / 2;
        }
    }
    // End: lost in noise, or a catch.
    let mut end = n - 1;
    if sigma > 0.0 && amp > 0.0 && s > 0.0 {
        let t_lost = fit.t_ref_s + (amp / (0.1 * s)).ln().max(0.0) / sigma;
        if let Some(k) = t.iter().position(|&v| v > t_lost) {
            end = end.min(k);
        }
    }
    let wr = period_samples.max(10);
    let mut k = start;
    while k + wr <= end {
        // A catch or a knock is gross: 3× the noise and a good part of the swing left.
        let r = window_rms(k, k + wr);
        if r > 3.0 * s && r > 0.3 * envelope(k) {
            end = k + wr / 2;
            break;
        }
        k += wr / 2;
    }
    (start, end)
}

/// Peaks of the residual's spectrum that stand 5× above its median floor and reach 2 % of the
/// signal's main peak (−34 dB), away from the main frequency and each other.
fn secondary_peaks(
    signal_spectrum: &ZoomSpectrum,
    residual_spectrum: &ZoomSpectrum,
    main_hz: f64,
) -> Vec<Peak> {
    let top = signal_spectrum.main_peak(0.0).map_or(0.0, |p| p.magnitude);
    // Apart from the main frequency and from each other by 2 bins and 5 %: a decaying mode's
    // peak ripples under a rectangular window.
    let apart = |a: f64, b: f64| {
        (a - b).abs() > (2.0 * residual_spectrum.resolution_hz).max(0.05 * a.max(b))
    };
    let mut out: Vec<Peak> = Vec::new();
    for p in residual_spectrum.peaks(2.0 * residual_spectrum.resolution_hz, 0.0, 0.02 * top, 12) {
        if apart(p.freq_hz, main_hz) && out.iter().all(|q| apart(p.freq_hz, q.freq_hz)) {
            out.push(p);
        }
    }
    out.truncate(5);
    out
}

/// What `bikeproc period` reports: the fit's results with their standard errors (SI units;
/// the signal's own unit for amplitude and residual).
#[derive(Debug, Clone, serde::Serialize)]
pub struct OscillationSummary {
    pub signal: String,
    pub unit: String,
    pub period_s: f64,
    pub period_se_s: f64,
    pub freq_hz: f64,
    pub freq_se_hz: f64,
    pub natural_freq_hz: f64,
    pub natural_freq_se_hz: f64,
    pub damping_ratio: f64,
    pub damping_ratio_se: f64,
    pub amplitude: f64,
    pub amplitude_se: f64,
    pub residual_rms: f64,
    /// The free-decay segment fitted, `[start, end]` in seconds.
    pub segment_s: [f64; 2],
    pub samples: usize,
    /// Whether a linear trend was fitted.
    pub trend: bool,
    /// The FFT's interpolated main peak (the lab's method, made sub-bin), Hz.
    pub fft_peak_hz: f64,
    /// The lab's FFT bin for this record (1 / its duration), Hz.
    pub fft_bin_hz: f64,
    /// Other significant spectral peaks, strongest first, Hz.
    pub secondary_peaks_hz: Vec<f64>,
    /// Rows of the log whose receiver time was more than half a sample off the counter's
    /// (placed by the counter); 0 for a CSV.
    pub receiver_time_off_rows: usize,
}

impl Oscillation {
    /// The Hann-windowed spectrum of the fitted segment of `signal` (the signal the fit was
    /// made on), for a figure: the fit itself does not need it.
    pub fn spectrum(&self, signal: &Signal) -> Spectrum {
        let (a, b) = self.segment_s;
        let keep: Vec<usize> = signal
            .times_s()
            .iter()
            .enumerate()
            .filter(|(_, &t)| t >= a && t <= b)
            .map(|(k, _)| k)
            .collect();
        let segment = Signal {
            index: keep.iter().map(|&k| signal.index[k]).collect(),
            values: keep.iter().map(|&k| signal.values[k]).collect(),
            ..signal.clone()
        };
        Spectrum::of(&segment, Window::Hann)
    }

    pub fn summary(&self, signal: &Signal) -> OscillationSummary {
        let f = &self.fit;
        let (p, fr, fnat, z, a) = (
            f.period_s(),
            f.freq_hz(),
            f.natural_freq_hz(),
            f.damping_ratio(),
            f.amplitude(),
        );
        OscillationSummary {
            signal: signal.name.clone(),
            unit: signal.unit.clone(),
            period_s: p.value,
            period_se_s: p.se,
            freq_hz: fr.value,
            freq_se_hz: fr.se,
            natural_freq_hz: fnat.value,
            natural_freq_se_hz: fnat.se,
            damping_ratio: z.value,
            damping_ratio_se: z.se,
            amplitude: a.value,
            amplitude_se: a.se,
            residual_rms: f.residual_rms,
            segment_s: [self.segment_s.0, self.segment_s.1],
            samples: f.samples,
            trend: f.trend,
            fft_peak_hz: self.main_peak.freq_hz,
            fft_bin_hz: 1.0 / signal.duration_s().max(f64::MIN_POSITIVE),
            secondary_peaks_hz: self.secondary_peaks.iter().map(|p| p.freq_hz).collect(),
            receiver_time_off_rows: 0,
        }
    }
}

/// `value ± se` with at least `decimals` decimals, and more where the standard error needs
/// them to show two significant digits (ζ = 0.005800 ± 0.0000021, not 0.00580 ± 0.00000).
fn with_se(value: f64, se: f64, decimals: usize) -> String {
    let needed = if se.is_finite() && se > 0.0 {
        (1.0 - se.log10().floor()).max(0.0) as usize
    } else {
        0
    };
    let d = decimals.max(needed.min(12));
    format!("{value:.d$} ± {se:.d$}")
}

impl OscillationSummary {
    /// The plain-text form printed by `bikeproc period`.
    pub fn to_text(&self, source: &std::path::Path) -> String {
        let unit = if self.unit.is_empty() {
            String::new()
        } else {
            format!(" {}", self.unit)
        };
        let peaks = if self.secondary_peaks_hz.is_empty() {
            "none".to_string()
        } else {
            self.secondary_peaks_hz
                .iter()
                .map(|f| format!("{f:.4} Hz"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        format!(
            "{}: {}\n\
             free decay       {:.2} – {:.2} s ({} samples{})\n\
             damped period    T  = {} s\n\
             damped freq      f_d = {} Hz\n\
             natural freq     f_n = {} Hz\n\
             damping ratio    ζ  = {}\n\
             amplitude        {:.5} ± {:.5}{unit} at the segment's start\n\
             residual RMS     {:.3e}{unit}\n\
             FFT peak         {:.5} Hz (bin {:.5} Hz)\n\
             secondary peaks  {peaks}\n\
             errors           this recording's noise alone; repeats of a set-up scatter more \
             (`bikeproc inertia` takes their spread)\n",
            source.display(),
            self.signal,
            self.segment_s[0],
            self.segment_s[1],
            self.samples,
            if self.trend {
                ", linear trend fitted"
            } else {
                ""
            },
            with_se(self.period_s, self.period_se_s, 6),
            with_se(self.freq_hz, self.freq_se_hz, 6),
            with_se(self.natural_freq_hz, self.natural_freq_se_hz, 6),
            with_se(self.damping_ratio, self.damping_ratio_se, 5),
            self.amplitude,
            self.amplitude_se,
            self.residual_rms,
            self.fft_peak_hz,
            self.fft_bin_hz,
        )
    }
}

/// Cramér–Rao bound on the variance of ω̂ (rad²/s²) for `x_n = A e^{−σnT} cos(ωnT + φ) + w_n`,
/// `n = 0 … N−1`, white noise of variance `s²`:
///
/// ```text
/// var(ω̂) ≥ (2 s² / A²) · S₀ / (S₀ S₂ − S₁²) / T²,    S_k = Σₙ nᵏ e^{−2σnT}.
/// ```
///
/// Derivation. The Fisher information is `F = (1/s²) Σₙ ∇xₙ ∇xₙᵀ` over the unknowns. With
/// `E = e^{−σnT}` and `θₙ = ωnT + φ`: ∂x/∂φ = −A E sin θₙ, ∂x/∂ω = −A nT E sin θₙ,
/// ∂x/∂A = E cos θₙ, ∂x/∂σ = −A nT E cos θₙ, and an offset or trend have ∂x = 1, nT. Over many
/// cycles sin² and cos² average to ½ and sin·cos, sin·1 and sin·n to 0, so (φ, ω) decouple from
/// (A, σ, offset, trend) and
///
/// ```text
/// F_φφ = A² S₀ / 2s²,   F_φω = A² T S₁ / 2s²,   F_ωω = A² T² S₂ / 2s².
/// ```
///
/// Inverting the 2×2 block, `[F⁻¹]_ωω = F_φφ / (F_φφ F_ωω − F_φω²)`, which is the formula. The bound
/// is therefore the same whether σ, A, an offset or a trend are known or fitted. Without
/// damping `S_k` are power sums and it reduces to Kay's `24 s² / (A² N (N² − 1) T²)`.
/// The averaging is asymptotic: against the exact Fisher matrix it is within 1 % for ζ ≤ 0.01
/// and ~4 % at ζ = 0.05, where the information lies in the first few cycles.
/// The test `crb_matches_exact_fisher_matrix` checks it against the exact Fisher matrix.
pub fn crb_omega_variance(amplitude: f64, sigma: f64, dt_s: f64, n: usize, noise_var: f64) -> f64 {
    let (mut s0, mut s1, mut s2) = (0.0, 0.0, 0.0);
    for k in 0..n {
        let kf = k as f64;
        let w = (-2.0 * sigma * kf * dt_s).exp();
        s0 += w;
        s1 += kf * w;
        s2 += kf * kf * w;
    }
    2.0 * noise_var / (amplitude * amplitude) * s0 / (s0 * s2 - s1 * s1) / (dt_s * dt_s)
}

/// The periods of repeated trials of one set-up, combined.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SetupPeriods {
    /// The set-up: the trials' common name (`RobotForkTorsionalFirst` for
    /// `RobotForkTorsionalFirst1` … `3`).
    pub setup: String,
    pub trials: Vec<String>,
    /// Each trial's damped period (s) with its fit's standard error.
    pub periods_s: Vec<crate::uncertainty::Measured>,
    /// Their mean (s), its standard error including the scatter between trials, the flagged
    /// trials ([`combine_repeats`](crate::uncertainty::combine_repeats)).
    pub combined: crate::uncertainty::Repeats,
}

impl SetupPeriods {
    /// Each trial: its name less the set-up's (the trial number), its period, whether it was
    /// flagged and left out.
    pub fn each_trial(&self) -> impl Iterator<Item = (&str, crate::uncertainty::Measured, bool)> {
        self.trials
            .iter()
            .zip(&self.periods_s)
            .zip(&self.combined.outlier)
            .map(|((name, p), &flagged)| {
                (
                    name.strip_prefix(self.setup.as_str()).unwrap_or(name),
                    *p,
                    flagged,
                )
            })
    }
}

/// The periods of a batch of recordings (`bikeproc period FOLDER`), grouped by set-up, and the
/// recordings that gave none with the reason. Its JSON is the command's `--json`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct PeriodBatch {
    pub setups: Vec<SetupPeriods>,
    /// `file: reason` of each recording that gave no period.
    pub failed: Vec<String>,
}

impl PeriodBatch {
    /// Groups named trials ([`group_trials`]) beside the failures.
    pub fn new(trials: &[(String, crate::uncertainty::Measured)], failed: Vec<String>) -> Self {
        PeriodBatch {
            setups: group_trials(trials),
            failed,
        }
    }

    /// The set-ups as a table: mean damped period with its standard error, where that error
    /// comes from, the scatter, and each trial (flagged ones starred).
    pub fn to_text(&self) -> String {
        use std::fmt::Write as _;
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{:<28} {:>22} {:>24} {:>9}  trials (damped period T, s; * flagged, left out)",
            "set-up", "mean T (s)", "", "scatter"
        );
        for s in &self.setups {
            let c = &s.combined;
            let trials: Vec<String> = s
                .each_trial()
                .map(|(name, p, flagged)| {
                    format!(
                        "{}{name} {:.6} ± {:.6}",
                        if flagged { "*" } else { "" },
                        p.value,
                        p.se
                    )
                })
                .collect();
            let _ = writeln!(
                out,
                "{:<28} {:>11.6} ± {:<8.6} {:>24} {:>8.3}%  {}",
                s.setup,
                c.mean.value,
                c.mean.se,
                if c.scatter_dominates {
                    "(SE from the scatter)"
                } else {
                    "(SE from the fits)"
                },
                100.0 * c.sd / c.plain_mean,
                trials.join(", ")
            );
        }
        out
    }
}

/// A trial's set-up: its name less a trailing trial number (and a `_` or `-` before it), or
/// less a trial letter after the set-up's number (`frame_torsion_1a`, `…_1b`: set-up
/// `frame_torsion_1`).
pub fn setup_name(trial: &str) -> &str {
    let b = trial.as_bytes();
    if b.len() >= 2 && b[b.len() - 1].is_ascii_lowercase() && b[b.len() - 2].is_ascii_digit() {
        return &trial[..trial.len() - 1];
    }
    trial
        .trim_end_matches(|c: char| c.is_ascii_digit())
        .trim_end_matches(['_', '-'])
}

/// Groups `(trial name, period)` by set-up ([`setup_name`]), set-ups in the order of their
/// first trial, and combines each.
pub fn group_trials(trials: &[(String, crate::uncertainty::Measured)]) -> Vec<SetupPeriods> {
    let mut setups: Vec<(String, Vec<usize>)> = Vec::new();
    for (i, (name, _)) in trials.iter().enumerate() {
        let s = setup_name(name);
        match setups.iter_mut().find(|(n, _)| n == s) {
            Some((_, members)) => members.push(i),
            None => setups.push((s.to_string(), vec![i])),
        }
    }
    setups
        .into_iter()
        .map(|(setup, members)| {
            let periods_s: Vec<_> = members.iter().map(|&i| trials[i].1).collect();
            SetupPeriods {
                setup,
                trials: members.iter().map(|&i| trials[i].0.clone()).collect(),
                combined: crate::uncertainty::combine_repeats(
                    &periods_s
                        .iter()
                        .map(|m| (m.value, m.se))
                        .collect::<Vec<_>>(),
                ),
                periods_s,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`ar1_times`]'s two recursions against the direct sum `Σ_j ρ^|i−j| J_j`, on a seeded
    /// Jacobian of 150 rows and 4 columns, ρ = 0.7: equal to 1e-12 of the largest entry.
    #[test]
    fn the_ar1_recursions_are_the_direct_sum() {
        use crate::sim::draw::Draw;
        let mut rng = crate::sim::draw::seeded(5);
        let (n, np, rho) = (150, 4, 0.7f64);
        let j = DMatrix::from_fn(n, np, |_, _| rng.normal());
        let direct = DMatrix::from_fn(n, np, |i, c| {
            (0..n)
                .map(|k| rho.powi((i as i32 - k as i32).abs()) * j[(k, c)])
                .sum::<f64>()
        });
        let fast = ar1_times(&j, rho);
        assert!((fast - &direct).amax() < 1e-12 * direct.amax(), "{direct}");
    }

    /// The AR(1) noise under a fit's residuals: on 400 seeded series of 300 samples of ρ = 0.6
    /// noise less their least-squares fit of an offset and a 5 rad/s sinusoid, the moments'
    /// ρ averages 0.6 within 0.01 (its scatter over 400 series is 0.05/√400 ≈ 0.0025), where
    /// the plain lag-one autocorrelation of the residuals reads low.
    #[test]
    fn the_residuals_ar1_allows_for_the_fit() {
        use crate::sim::draw::Draw;
        let mut rng = crate::sim::draw::seeded(9);
        let n = 300;
        let j = DMatrix::from_fn(n, 3, |i, c| {
            let t = i as f64 * 0.01;
            [1.0, (5.0 * t).cos(), (5.0 * t).sin()][c]
        });
        let hinv = (j.transpose() * &j).try_inverse().expect("regular");
        let (mut moments, mut plain) = (0.0, 0.0);
        for _ in 0..400 {
            let mut e = DVector::zeros(n);
            let mut x = rng.normal() / (1.0f64 - 0.36).sqrt();
            for i in 0..n {
                x = 0.6 * x + rng.normal();
                e[i] = x;
            }
            let r = &e - &j * (&hinv * (j.transpose() * &e));
            moments += ar1_of_residuals(&j, &r, &hinv).expect("noise").0 / 400.0;
            let lag: f64 = (1..n).map(|i| r[i] * r[i - 1]).sum();
            plain += lag / r.norm_squared() / 400.0;
        }
        assert!(
            (moments - 0.6).abs() < 0.01,
            "moments {moments}, plain {plain}"
        );
        assert!(plain < moments, "moments {moments}, plain {plain}");
    }

    /// `y = c e^{r t}`, r bounded: the least-squares problem of the tests below.
    struct Decay {
        t: Vec<f64>,
        y: Vec<f64>,
        rate_bounds: (f64, f64),
    }

    impl LeastSquares for Decay {
        fn residuals_and_jacobian(&self, p: &[f64], jac: &mut DMatrix<f64>, r: &mut DVector<f64>) {
            for (i, (&t, &y)) in self.t.iter().zip(&self.y).enumerate() {
                let e = (p[1] * t).exp();
                r[i] = p[0] * e - y;
                jac[(i, 0)] = e;
                jac[(i, 1)] = p[0] * t * e;
            }
        }
        fn cost(&self, p: &[f64]) -> f64 {
            let t = self.t.iter().zip(&self.y);
            t.map(|(&t, &y)| (p[0] * (p[1] * t).exp() - y).powi(2))
                .sum()
        }
        fn bounds(&self, i: usize) -> (f64, f64) {
            if i == 1 {
                self.rate_bounds
            } else {
                (f64::NEG_INFINITY, f64::INFINITY)
            }
        }
    }

    /// 2e^{−5t} sampled at 100 Hz for 1 s with a deterministic ±1e-3 ripple.
    fn decay(rate_bounds: (f64, f64)) -> Decay {
        let t: Vec<f64> = (0..100).map(|k| k as f64 * 0.01).collect();
        let y = t
            .iter()
            .enumerate()
            .map(|(k, &t)| 2.0 * (-5.0 * t).exp() + 1e-3 * (k as f64 * 2.7).sin())
            .collect();
        Decay { t, y, rate_bounds }
    }

    /// A fit that converges says so, within a few iterations, at the truth within its noise;
    /// the same fit cut to one iteration says it has not.
    #[test]
    fn a_converged_fit_says_so_and_a_cut_one_does_not() {
        let d = decay((f64::NEG_INFINITY, f64::INFINITY));
        let sol = levenberg_marquardt(&d, 100, vec![1.0, -2.0], 200, 1e-6);
        assert!(sol.converged && sol.iterations < 30, "{}", sol.iterations);
        assert!((sol.params[1] + 5.0).abs() < 1e-2, "{:?}", sol.params);
        let cut = levenberg_marquardt(&d, 100, vec![1.0, -2.0], 1, 0.0);
        assert!(!cut.converged);
    }

    /// A rate bounded away from the truth ends at its bound, converged (the step left is the
    /// other parameter's, zero there), with the amplitude the closed-form least squares at
    /// that rate gives: c = Σ y e^{rt} / Σ e^{2rt}.
    #[test]
    fn a_parameter_held_at_its_bound_converges_there() {
        let d = decay((-3.0, 0.0));
        let sol = levenberg_marquardt(&d, 100, vec![1.0, -1.0], 200, 1e-6);
        assert_eq!(sol.params[1], -3.0);
        let num: f64 =
            d.t.iter()
                .zip(&d.y)
                .map(|(&t, &y)| y * (-3.0 * t).exp())
                .sum();
        let den: f64 = d.t.iter().map(|&t| (-6.0 * t).exp()).sum();
        assert!(
            (sol.params[0] - num / den).abs() < 1e-9 * (num / den),
            "{:?}",
            sol.params
        );
        assert!(sol.converged && sol.iterations < 30, "{}", sol.iterations);
    }

    #[test]
    fn a_value_shows_its_standard_error_to_two_digits() {
        assert_eq!(with_se(0.0058048, 4.4e-6, 5), "0.0058048 ± 0.0000044");
        assert_eq!(with_se(1.25, 0.01, 2), "1.250 ± 0.010");
        assert_eq!(with_se(1.25, 0.2, 6), "1.250000 ± 0.200000");
        assert_eq!(with_se(1.25, f64::NAN, 3), "1.250 ± NaN");
    }

    #[test]
    fn trials_group_by_their_set_up() {
        assert_eq!(
            setup_name("RobotForkTorsionalFirst12"),
            "RobotForkTorsionalFirst"
        );
        assert_eq!(setup_name("rod_3"), "rod");
        assert_eq!(setup_name("frame-x-2"), "frame-x");
        assert_eq!(setup_name("fork"), "fork");
        assert_eq!(setup_name("frame_torsion_1a"), "frame_torsion_1");
        assert_eq!(setup_name("wheel_100hz"), "wheel_100hz");
        let m = |v| crate::uncertainty::Measured::new(v, 1e-6);
        let g = group_trials(&[
            ("b1".into(), m(1.0)),
            ("a1".into(), m(2.0)),
            ("b2".into(), m(1.1)),
        ]);
        assert_eq!(g.len(), 2);
        assert_eq!((g[0].setup.as_str(), g[0].trials.len()), ("b", 2));
        assert_eq!((g[1].setup.as_str(), g[1].trials.len()), ("a", 1));
    }

    /// The exact Fisher matrix of (A, φ, ω, σ, offset), inverted numerically.
    fn exact_crb(
        amplitude: f64,
        sigma: f64,
        omega: f64,
        phi: f64,
        dt: f64,
        n: usize,
        s2: f64,
    ) -> f64 {
        let mut f = DMatrix::<f64>::zeros(5, 5);
        for k in 0..n {
            let t = k as f64 * dt;
            let e = (-sigma * t).exp();
            let th = omega * t + phi;
            let g = [
                e * th.cos(),
                -amplitude * e * th.sin(),
                -amplitude * t * e * th.sin(),
                -amplitude * t * e * th.cos(),
                1.0,
            ];
            for i in 0..5 {
                for j in 0..5 {
                    f[(i, j)] += g[i] * g[j] / s2;
                }
            }
        }
        f.try_inverse().unwrap()[(2, 2)]
    }

    #[test]
    fn crb_matches_exact_fisher_matrix() {
        // The averaging of sin² to ½ is exact only over many cycles: the error grows with the
        // damping (the information sits in the first 1/(2πζ) cycles), 4 % at ζ = 0.05.
        for &(f_hz, zeta, secs, tol) in &[
            (0.8, 0.01, 60.0, 0.01),
            (4.0, 0.05, 30.0, 0.05),
            (0.5, 0.002, 120.0, 0.01),
            (2.0, 0.0, 30.0, 0.001),
        ] {
            let w = 2.0 * PI * f_hz;
            let sigma = zeta * w;
            let n = (secs * 100.0) as usize;
            let approx = crb_omega_variance(0.1, sigma, 0.01, n, 1e-6);
            let exact = exact_crb(0.1, sigma, w, 0.7, 0.01, n, 1e-6);
            assert!(
                (approx / exact - 1.0).abs() < tol,
                "f={f_hz} ζ={zeta}: {approx} vs {exact}"
            );
        }
    }

    /// `--segment A:B` takes both end samples: at 100 Hz sample 1,070 is at 1070 × 0.01 =
    /// 10.700000000000001 s, beyond B = 10.7 by rounding, and `t ≤ B` dropped it.
    #[test]
    fn a_segment_includes_both_ends() {
        let rate = 100.0;
        let sig = Signal {
            name: "x".into(),
            unit: "rad".into(),
            sample_rate_hz: rate,
            t0_s: 0.0,
            index: (0..=3_000).collect(),
            values: (0..=3_000)
                .map(|i| {
                    let t = i as f64 / rate;
                    (-0.05 * t).exp() * (4.0 * t).cos()
                })
                .collect(),
        };
        assert!(
            sig.times_s()[1_070] > 10.7,
            "the rounding this test is about"
        );
        for (a, b, samples) in [(0.0, 10.7, 1_071), (2.0, 10.7, 871), (0.35, 30.0, 2_966)] {
            let osc = analyse(
                &sig,
                &FitOptions {
                    trend: Trend::Off,
                    segment_s: Some((a, b)),
                    min_freq_hz: None,
                },
            )
            .expect("fits");
            assert_eq!(osc.fit.samples, samples, "{a}:{b}");
        }
    }

    #[test]
    fn crb_reduces_to_kay_without_damping() {
        let (n, dt, s2, a) = (3000usize, 0.01, 1e-4, 0.5);
        let nf = n as f64;
        let kay = 24.0 * s2 / (a * a * nf * (nf * nf - 1.0) * dt * dt);
        let got = crb_omega_variance(a, 0.0, dt, n, s2);
        assert!((got / kay - 1.0).abs() < 1e-9, "{got} vs {kay}");
    }

    #[test]
    fn exact_fit_recovers_parameters_with_zero_mean() {
        // A signal whose mean is near zero: the offset must still move (the peer tool's failure).
        let t: Vec<f64> = (0..3000).map(|i| i as f64 * 0.01).collect();
        let truth = [0.0123, 0.2, -0.3, 0.05, 5.1];
        let x: Vec<f64> = t.iter().map(|&v| model(&truth, false, v)).collect();
        let fit = fit_from_frequency(&t, &x, 5.0, false).unwrap();
        for (got, want) in fit.params.iter().zip(truth) {
            assert!((got - want).abs() < 1e-9, "{got} vs {want}");
        }
    }

    /// A uniform 100 Hz grid with dropped samples (gaps of 1–3 steps), a chunk of jittered
    /// times, and a seeded noisy damped swing with a drift on it.
    fn gappy_record() -> (Vec<f64>, Vec<f64>) {
        let mut uniform = crate::testing::lcg_uniform(99);
        let mut tau = Vec::new();
        let mut i = 0u32;
        while tau.len() < 2003 {
            i += if uniform() < 0.01 {
                2 + (uniform() * 2.0) as u32
            } else {
                1
            };
            let jitter = if (700..720).contains(&tau.len()) {
                1e-4 * uniform()
            } else {
                0.0
            };
            tau.push(f64::from(i) * 0.01 + jitter);
        }
        let truth = [0.01, 0.2, -0.3, 0.05, 5.1, 0.002];
        let x = tau
            .iter()
            .map(|&t| model(&truth, true, t) + 0.01 * (uniform() - 0.5))
            .collect();
        (tau, x)
    }

    #[test]
    fn phasor_lanes_match_exact_evaluation() {
        let (tau, _) = gappy_record();
        let (sigma, omega) = (0.05, 5.1);
        let mut worst: f64 = 0.0;
        let mut seen = 0;
        phasor_lanes(sigma, omega, &tau, |k, ch| {
            for l in 0..LANES {
                if k + l < tau.len() {
                    let t = tau[k + l];
                    assert_eq!(ch.tau[l], t);
                    assert_eq!(ch.live[l], 1.0);
                    let e = (-sigma * t).exp();
                    let (s, c) = (omega * t).sin_cos();
                    worst = worst.max((ch.es[l] - e * s).abs().max((ch.ec[l] - e * c).abs()) / e);
                    seen += 1;
                } else {
                    assert_eq!((ch.live[l], ch.es[l], ch.ec[l]), (0.0, 0.0, 0.0));
                }
            }
        });
        assert_eq!(seen, tau.len());
        assert!(worst < 1e-13, "{worst:e}");
    }

    #[test]
    fn fused_normal_equations_match_the_stored_jacobian() {
        // JᵀJ, Jᵀr and the cost accumulated in lanes against the Jacobian stored row by row
        // (PhasorWalk) and multiplied out by nalgebra.
        let (tau, x) = gappy_record();
        for trend in [false, true] {
            let np = if trend { 6 } else { 5 };
            let p = [0.012, 0.19, -0.31, 0.049, 5.102, 0.0021];
            let p = &p[..np];
            let problem = Sinusoid {
                tau: &tau,
                x: &x,
                trend,
            };
            let mut jac = DMatrix::zeros(tau.len(), np);
            let mut r = DVector::zeros(tau.len());
            problem.residuals_and_jacobian(p, &mut jac, &mut r);
            let (h_ref, g_ref) = (jac.tr_mul(&jac), jac.tr_mul(&r));
            let (mut h, mut g) = (DMatrix::zeros(np, np), DVector::zeros(np));
            let cost = problem.normal_equations(p, &mut h, &mut g).unwrap();
            assert!((cost / r.norm_squared() - 1.0).abs() < 1e-12);
            assert!((cost / problem.cost(p) - 1.0).abs() < 1e-12);
            assert!(
                (&h - &h_ref).norm() < 1e-12 * h_ref.norm(),
                "{h} vs {h_ref}"
            );
            assert!(
                (&g - &g_ref).norm() < 1e-11 * g_ref.norm(),
                "{g} vs {g_ref}"
            );
        }
    }

    #[test]
    fn the_fit_on_a_gappy_record_recovers_its_decay() {
        // The same optimum through the fused normal equations; the truth within 5 SE.
        let (tau, x) = gappy_record();
        let fit = fit_from_frequency(&tau, &x, 5.0, true).unwrap();
        let sigma = fit.sigma();
        let omega = fit.omega_d();
        assert!((sigma.value - 0.05).abs() < 5.0 * sigma.se, "{sigma:?}");
        assert!((omega.value - 5.1).abs() < 5.0 * omega.se, "{omega:?}");
    }
}
