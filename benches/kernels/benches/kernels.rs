//! bikeproc's in-house kernels beside the maintained crates, on the same problems: first the
//! accuracy (printed), then the speed (divan). Run: `cd benches/kernels && cargo bench`.
//!
//! - Levenberg–Marquardt (`bikeproc::fit`) against the levenberg-marquardt crate (MINPACK's
//!   algorithm) on the damped-sinusoid fit of the shared fork recording at 1000 Hz (30,000
//!   samples), both from the same start: the converged point off by a fraction of the standard
//!   errors, the iterations, the time.
//! - The bounded Nelder–Mead of the gap's candidate fits (`bikeproc::gap::fit::nelder_mead`)
//!   against argmin's `NelderMead` on Rosenbrock's function from (−1.2, 1) (minimum (1, 1)).

use bikeproc::fit::{self, FitOptions};
use bikeproc::log::ReadOptions;
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
    divan::main();
}
