//! bikeproc's in-house kernels beside the maintained crates, on the same problems: first the
//! accuracy (printed), then the speed (divan). Run: `cd benches/kernels && cargo bench`.
//!
//! - Levenberg–Marquardt (`bikeproc::fit`) against the levenberg-marquardt crate (MINPACK's
//!   algorithm) on the damped-sinusoid fit of the shared fork recording at 1000 Hz (30,000
//!   samples), both from the same start: the converged point off by a fraction of the standard
//!   errors, the iterations, the time.
//! - The bounded Nelder–Mead of the gap's candidate fits (`bikeproc::gap::fit::nelder_mead`)
//!   against argmin's `NelderMead` on Rosenbrock's function from (−1.2, 1) (minimum (1, 1)).
//! - The simulator's Dormand–Prince 5(4) (`bikeproc::sim::ode`) against ode_solvers' `Dopri5`
//!   on a damped oscillator over 10 s (closed form), both at rtol 1e-10, atol 1e-12.
//! - The simulator's second-order jets (`bikeproc::jet`) against num-dual's `Dual2_64` on
//!   a kinematics-like function of three coordinates along one direction.

use bikeproc::fit::{self, FitOptions};
use bikeproc::read::log::ReadOptions;
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{DMatrix, DVector, Dyn, Owned};
use std::path::PathBuf;
use std::sync::OnceLock;

/// The fork recording's free-decay segment, the fit bikeproc makes of it, and a start off that
/// fit by a few percent in every parameter.
struct Sinusoid {
    tau: Vec<f64>,
    x: Vec<f64>,
    t_ref: f64,
    fitted: Vec<f64>,
    se: Vec<f64>,
    start: Vec<f64>,
}

fn sinusoid() -> &'static Sinusoid {
    static S: OnceLock<Sinusoid> = OnceLock::new();
    S.get_or_init(|| {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../../shared/reference/signals/browserins_fork_compound_first1_1000hz.csv");
        let sig = bikeproc::signal::load_signal(
            &path,
            &bikeproc::signal::Extract::DominantRotation,
            None,
            &ReadOptions::default(),
        )
        .expect("the shared fork recording")
        .signal;
        let osc = fit::analyse(
            &sig,
            &FitOptions {
                trend: bikeproc::fit::Trend::Off,
                ..FitOptions::default()
            },
        )
        .expect("it fits");
        let t = sig.times_s();
        let (a, b) = osc.segment_s;
        let keep: Vec<usize> = (0..t.len()).filter(|&k| t[k] >= a && t[k] <= b).collect();
        let t_ref = t[keep[0]];
        let fitted = osc.fit.params.clone();
        let se: Vec<f64> = (0..fitted.len())
            .map(|i| osc.fit.covariance[(i, i)].sqrt())
            .collect();
        let start = fitted
            .iter()
            .zip([1.02, 0.98, 1.03, 1.10, 1.002])
            .map(|(p, f)| p * f)
            .collect();
        Sinusoid {
            tau: keep.iter().map(|&k| t[k] - t_ref).collect(),
            x: keep.iter().map(|&k| sig.values[k]).collect(),
            t_ref,
            fitted,
            se,
            start,
        }
    })
}

/// x(τ) = a + e^{−στ}(b sin ωτ + c cos ωτ) for the levenberg-marquardt crate.
struct CrateProblem<'a> {
    s: &'a Sinusoid,
    p: DVector<f64>,
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for CrateProblem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, p: &DVector<f64>) {
        self.p.copy_from(p);
    }

    fn params(&self) -> DVector<f64> {
        self.p.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        let p = &self.p;
        Some(DVector::from_iterator(
            self.s.tau.len(),
            self.s.tau.iter().zip(&self.s.x).map(|(&t, &x)| {
                let e = (-p[3] * t).exp();
                let (sn, cs) = (p[4] * t).sin_cos();
                p[0] + e * (p[1] * sn + p[2] * cs) - x
            }),
        ))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let p = &self.p;
        let n = self.s.tau.len();
        let mut j = DMatrix::zeros(n, 5);
        for (i, &t) in self.s.tau.iter().enumerate() {
            let e = (-p[3] * t).exp();
            let (sn, cs) = (p[4] * t).sin_cos();
            let osc = p[1] * sn + p[2] * cs;
            j[(i, 0)] = 1.0;
            j[(i, 1)] = e * sn;
            j[(i, 2)] = e * cs;
            j[(i, 3)] = -t * e * osc;
            j[(i, 4)] = t * e * (p[1] * cs - p[2] * sn);
        }
        Some(j)
    }
}

fn crate_lm(s: &Sinusoid) -> (DVector<f64>, usize) {
    let problem = CrateProblem {
        s,
        p: DVector::from_column_slice(&s.start),
    };
    let (done, report) = LevenbergMarquardt::new().minimize(problem);
    (done.p, report.number_of_evaluations)
}

fn bikeproc_lm(s: &Sinusoid) -> fit::DampedFit {
    fit::fit_damped_sinusoid(&s.tau, &s.x, s.t_ref, &s.start, false).expect("converges")
}

#[divan::bench(sample_count = 20)]
fn lm_bikeproc_fork_1000hz() -> fit::DampedFit {
    bikeproc_lm(divan::black_box(sinusoid()))
}

#[divan::bench(sample_count = 20)]
fn lm_crate_fork_1000hz() -> (DVector<f64>, usize) {
    crate_lm(divan::black_box(sinusoid()))
}

fn rosenbrock(x: &[f64]) -> f64 {
    (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2)
}

fn bikeproc_nm() -> (Vec<f64>, f64) {
    bikeproc::gap::fit::nelder_mead(
        &rosenbrock,
        &[-1.2, 1.0],
        &[0.1, 0.1],
        &[-2.0, -2.0],
        &[2.0, 2.0],
        2000,
    )
}

struct Rosenbrock;

impl argmin::core::CostFunction for Rosenbrock {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        Ok(rosenbrock(p))
    }
}

fn argmin_nm() -> (Vec<f64>, f64, u64) {
    use argmin::core::State as _;
    let simplex = vec![vec![-1.2, 1.0], vec![-1.1, 1.0], vec![-1.2, 1.1]];
    let solver = argmin::solver::neldermead::NelderMead::new(simplex)
        .with_sd_tolerance(1e-12)
        .expect("a tolerance");
    let res = argmin::core::Executor::new(Rosenbrock, solver)
        .configure(|s| s.max_iters(2000))
        .run()
        .expect("runs");
    let st = res.state();
    (
        st.best_param.clone().unwrap_or_default(),
        st.best_cost,
        st.get_func_counts().get("cost_count").copied().unwrap_or(0),
    )
}

#[divan::bench(sample_count = 50)]
fn nelder_mead_bikeproc_rosenbrock() -> (Vec<f64>, f64) {
    bikeproc_nm()
}

#[divan::bench(sample_count = 50)]
fn nelder_mead_argmin_rosenbrock() -> (Vec<f64>, f64, u64) {
    argmin_nm()
}

/// y'' + 2ζω y' + ω² y = 0, ω = 2π rad/s, ζ = 0.05, from y = 1, y' = 0: its state at 10 s.
const OMEGA: f64 = 2.0 * std::f64::consts::PI;
const ZETA: f64 = 0.05;

fn oscillator_exact(t: f64) -> [f64; 2] {
    let wd = OMEGA * (1.0 - ZETA * ZETA).sqrt();
    let s = ZETA * OMEGA;
    let e = (-s * t).exp();
    let (sn, cs) = (wd * t).sin_cos();
    let y = e * (cs + s / wd * sn);
    let v = e * (-(s * s + wd * wd) / wd * sn);
    [y, v]
}

fn bikeproc_ode() -> ([f64; 2], usize) {
    use bikeproc::sim::ode::{integrate, Tolerance};
    let f = |_t: f64, y: &[f64; 2]| Some([y[1], -2.0 * ZETA * OMEGA * y[1] - OMEGA * OMEGA * y[0]]);
    let mut y = [1.0, 0.0];
    let (mut h, mut fsal) = (1e-3, None);
    let steps = integrate(
        &f,
        &|_| {},
        0.0,
        10.0,
        &mut y,
        &mut h,
        &mut fsal,
        &Tolerance::default(),
    )
    .expect("integrates");
    (y, steps)
}

struct Oscillator;

impl ode_solvers::System<f64, ode_solvers::Vector2<f64>> for Oscillator {
    fn system(&self, _t: f64, y: &ode_solvers::Vector2<f64>, dy: &mut ode_solvers::Vector2<f64>) {
        dy[0] = y[1];
        dy[1] = -2.0 * ZETA * OMEGA * y[1] - OMEGA * OMEGA * y[0];
    }
}

fn crate_ode() -> ([f64; 2], u32) {
    let mut stepper = ode_solvers::Dopri5::new(
        Oscillator,
        0.0,
        10.0,
        // Dense output every 0.5 s (with the whole span as its interval, ode_solvers 0.6.2
        // returned 6.4e5 at the end: an interpolation outside the last step).
        0.5,
        ode_solvers::Vector2::new(1.0, 0.0),
        1e-10,
        1e-12,
    );
    let stats = stepper.integrate().expect("integrates");
    let y = stepper.y_out().last().copied().unwrap_or_default();
    ([y[0], y[1]], stats.accepted_steps)
}

#[divan::bench(sample_count = 50)]
fn dopri5_bikeproc_oscillator_10_s() -> ([f64; 2], usize) {
    bikeproc_ode()
}

#[divan::bench(sample_count = 50)]
fn dopri5_ode_solvers_oscillator_10_s() -> ([f64; 2], u32) {
    crate_ode()
}

/// f(a, b, c) = sin a cos b √(1 + c²) + cos(a + b) / (2 + sin c), over bikeproc's jets.
fn kinematics_jet(q: [f64; 3], qd: [f64; 3]) -> bikeproc::jet::Jet {
    use bikeproc::jet::{Jet, Scalar};
    let [a, b, c] = [0, 1, 2].map(|i| Jet::var(q[i], qd[i]));
    let one = Jet::c(1.0);
    a.sin() * b.cos() * (one + c * c).sqrt() + (a + b).cos() / (Jet::c(2.0) + c.sin())
}

/// The same f over num-dual's second-order duals.
fn kinematics_dual(q: [f64; 3], qd: [f64; 3]) -> num_dual::Dual2_64 {
    use num_dual::{Dual2_64, DualNum};
    let [a, b, c] = [0, 1, 2].map(|i| Dual2_64::new(q[i], qd[i], 0.0));
    let one = Dual2_64::from(1.0);
    a.sin() * b.cos() * (one + c * c).sqrt() + (a + b).cos() / (Dual2_64::from(2.0) + c.sin())
}

const Q: [f64; 3] = [0.3, -0.7, 1.1];
const QD: [f64; 3] = [1.5, 0.4, -2.0];

#[divan::bench(sample_count = 200)]
fn jet_bikeproc_kinematics() -> bikeproc::jet::Jet {
    kinematics_jet(divan::black_box(Q), divan::black_box(QD))
}

#[divan::bench(sample_count = 200)]
fn jet_num_dual_kinematics() -> num_dual::Dual2_64 {
    kinematics_dual(divan::black_box(Q), divan::black_box(QD))
}

fn main() {
    let s = sinusoid();
    let ours = bikeproc_lm(s);
    let (theirs, evals) = crate_lm(s);
    println!(
        "LM, fork 1000 Hz ({} samples), from a start 2–10 % off:",
        s.tau.len()
    );
    for (i, name) in ["a", "b", "c", "sigma", "omega"].iter().enumerate() {
        println!(
            "  {name:>5}: bikeproc {:.12e}, crate {:.12e}, difference {:.2e} standard errors (analyse: {:.12e})",
            ours.params[i],
            theirs[i],
            (ours.params[i] - theirs[i]) / s.se[i],
            s.fitted[i]
        );
    }
    println!(
        "  bikeproc {} iterations; crate {} residual evaluations",
        ours.iterations, evals
    );
    let (x, f) = bikeproc_nm();
    let (xa, fa, na) = argmin_nm();
    println!(
        "Nelder–Mead, Rosenbrock from (-1.2, 1): bikeproc ({:.3e}, {:.3e}) f {:.2e}; argmin ({:.3e}, {:.3e}) f {:.2e} in {} evaluations",
        x[0], x[1], f, xa[0], xa[1], fa, na
    );
    let exact = oscillator_exact(10.0);
    let (yb, nb) = bikeproc_ode();
    let (yc, nc) = crate_ode();
    println!(
        "Dormand–Prince 5(4), damped oscillator to 10 s: bikeproc error ({:.1e}, {:.1e}) in {nb} steps; ode_solvers ({:.1e}, {:.1e}) in {nc} steps",
        yb[0] - exact[0],
        yb[1] - exact[1],
        yc[0] - exact[0],
        yc[1] - exact[1]
    );
    let (j, d) = (kinematics_jet(Q, QD), kinematics_dual(Q, QD));
    println!(
        "Second-order jets: value {:.3e}, rate {:.3e}, second derivative {:.3e} apart (num-dual: {:.15e}, {:.15e}, {:.15e})",
        j.v - d.re,
        j.d - d.v1,
        j.dd - d.v2,
        d.re,
        d.v1,
        d.v2
    );
    divan::main();
}
