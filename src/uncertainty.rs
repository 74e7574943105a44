//! Uncertainty propagation: a value with its standard error, and the first-order (linear)
//! propagation of an input covariance through any smooth function, `Σ_out = J Σ_in Jᵀ`
//! (GUM, JCGM 100:2008, §5), with `J` by central differences.
//!
//! Every derived figure of the inertia pipeline goes through [`propagate`], so the standard
//! errors of the masses, distances, axis angles, frequencies and the bar's stiffness all reach
//! the tensor, with their correlations.

use nalgebra::{DMatrix, DVector};

/// A value with its standard error.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Measured {
    pub value: f64,
    pub se: f64,
}

impl Measured {
    pub fn new(value: f64, se: f64) -> Measured {
        Measured { value, se }
    }

    /// Relative standard error.
    pub fn rel_se(&self) -> f64 {
        self.se / self.value.abs()
    }
}

/// Inputs for [`propagate`]: values and their covariance.
#[derive(Debug, Clone, Default)]
pub struct Inputs {
    values: Vec<f64>,
    cov: Vec<(usize, usize, f64)>,
}

impl Inputs {
    pub fn new() -> Inputs {
        Inputs::default()
    }

    /// Adds an independent input; returns its index.
    pub fn push(&mut self, m: Measured) -> usize {
        self.values.push(m.value);
        let i = self.values.len() - 1;
        self.cov.push((i, i, m.se * m.se));
        i
    }

    /// Adds correlated inputs with their covariance matrix; returns the first index.
    pub fn push_correlated(&mut self, values: &[f64], cov: &DMatrix<f64>) -> usize {
        let first = self.values.len();
        self.values.extend_from_slice(values);
        for r in 0..values.len() {
            for c in 0..values.len() {
                if cov[(r, c)] != 0.0 {
                    self.cov.push((first + r, first + c, cov[(r, c)]));
                }
            }
        }
        first
    }

    pub fn values(&self) -> &[f64] {
        &self.values
    }

    pub fn covariance(&self) -> DMatrix<f64> {
        let n = self.values.len();
        let mut m = DMatrix::zeros(n, n);
        for &(r, c, v) in &self.cov {
            m[(r, c)] += v;
        }
        m
    }
}

/// Propagates `inputs` through `f`: returns the outputs at the input values and their
/// covariance `J Σ Jᵀ`. The derivative step for input `i` is a thousandth of its standard error
/// (or 1e-7 of its value when it has none; inputs without uncertainty do not contribute).
pub fn propagate<F: Fn(&[f64]) -> Vec<f64>>(inputs: &Inputs, f: F) -> (Vec<f64>, DMatrix<f64>) {
    let cov = inputs.covariance();
    let (y0, jac) = jacobian(inputs.values(), &cov, f);
    let out_cov = &jac * cov * jac.transpose();
    (y0, out_cov)
}

/// [`propagate`] with the covariance kept as a factor: the outputs and `U` (outputs × inputs
/// with an error) with `U Uᵀ = J Σ Jᵀ`, `U = J V √D` for `Σ = V D Vᵀ` (negative rounding in D
/// taken as zero). A few dozen inputs against hundreds of outputs: what a low-rank update of an
/// inverse needs (Woodbury), where the full matrix would be factored afresh.
pub fn propagate_factor<F: Fn(&[f64]) -> Vec<f64>>(
    inputs: &Inputs,
    f: F,
) -> (Vec<f64>, DMatrix<f64>) {
    let cov = inputs.covariance();
    let (y0, jac) = jacobian(inputs.values(), &cov, f);
    (y0, factor_of(&jac, &cov))
}

/// [`propagate`] and [`propagate_factor`] from one Jacobian: the outputs, their covariance
/// `J Σ Jᵀ` and its factor `U`.
pub fn propagate_with_factor<F: Fn(&[f64]) -> Vec<f64>>(
    inputs: &Inputs,
    f: F,
) -> (Vec<f64>, DMatrix<f64>, DMatrix<f64>) {
    let cov = inputs.covariance();
    let (y0, jac) = jacobian(inputs.values(), &cov, f);
    let out_cov = &jac * &cov * jac.transpose();
    let factor = factor_of(&jac, &cov);
    (y0, out_cov, factor)
}

/// `U = J V √D` for the inputs' covariance `Σ = V D Vᵀ` over the inputs with an error.
fn factor_of(jac: &DMatrix<f64>, cov: &DMatrix<f64>) -> DMatrix<f64> {
    let with_error: Vec<usize> = (0..cov.nrows()).filter(|&i| cov[(i, i)] > 0.0).collect();
    if with_error.is_empty() {
        // Inputs without errors (a bicycle file with none): the outputs carry none of theirs.
        return DMatrix::zeros(jac.nrows(), 0);
    }
    let sub = cov
        .select_rows(with_error.iter())
        .select_columns(with_error.iter());
    let eig = sub.symmetric_eigen();
    let root =
        eig.eigenvectors * DMatrix::from_diagonal(&eig.eigenvalues.map(|d| d.max(0.0).sqrt()));
    jac.select_columns(with_error.iter()) * root
}

/// The outputs of `f` at `x` and their Jacobian by central differences, the step for input `i`
/// a thousandth of its standard error in `cov` (columns of inputs without one left zero).
pub(crate) fn jacobian<F: Fn(&[f64]) -> Vec<f64>>(
    x: &[f64],
    cov: &DMatrix<f64>,
    f: F,
) -> (Vec<f64>, DMatrix<f64>) {
    let y0 = f(x);
    let (n, m) = (x.len(), y0.len());
    let mut jac = DMatrix::zeros(m, n);
    let mut xp = x.to_vec();
    for i in 0..n {
        let sd = cov[(i, i)].max(0.0).sqrt();
        if sd == 0.0 {
            continue;
        }
        let h = 1e-3 * sd;
        xp[i] = x[i] + h;
        let yp = f(&xp);
        xp[i] = x[i] - h;
        let ym = f(&xp);
        xp[i] = x[i];
        for k in 0..m {
            jac[(k, i)] = (yp[k] - ym[k]) / (2.0 * h);
        }
    }
    (y0, jac)
}

/// The standard errors of many outputs, `√diag(J Σ Jᵀ)` of [`propagate`] with the same
/// derivative steps, in memory proportional to the outputs rather than to their square:
/// `f(x, items)` gives the outputs of the items in `items` (an item's outputs may depend on the
/// inputs, not on the other items), taken `chunk` items at a time on rayon's threads.
/// The result holds each item's outputs in order, as `f` lists them.
///
/// # Panics
/// If `chunk` is zero.
pub fn propagate_se<F>(inputs: &Inputs, items: usize, chunk: usize, f: F) -> Vec<f64>
where
    F: Fn(&[f64], std::ops::Range<usize>) -> Vec<f64> + Sync,
{
    assert!(chunk > 0, "propagate_se: a chunk holds at least one item");
    let cov = inputs.covariance();
    let x = inputs.values();
    let chunks = items.div_ceil(chunk);
    let per_chunk = |c: usize| -> Vec<f64> {
        let range = c * chunk..((c + 1) * chunk).min(items);
        let (_, jac) = jacobian(x, &cov, |x| f(x, range.clone()));
        let js = &jac * &cov;
        (0..jac.nrows())
            .map(|k| js.row(k).dot(&jac.row(k)).max(0.0).sqrt())
            .collect()
    };
    use rayon::prelude::*;
    let per: Vec<Vec<f64>> = (0..chunks).into_par_iter().map(per_chunk).collect();
    per.concat()
}

/// The standard errors on the diagonal of a covariance.
pub fn standard_errors(cov: &DMatrix<f64>) -> DVector<f64> {
    DVector::from_iterator(
        cov.nrows(),
        (0..cov.nrows()).map(|i| cov[(i, i)].max(0.0).sqrt()),
    )
}

/// Repeated trials of one set-up, combined ([`combine_repeats`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Repeats {
    /// The estimate and its standard error: the larger of the fits' own (the weighted mean's)
    /// and the trials' scatter (the plain mean's, sd/√n), each with its own mean.
    pub mean: Measured,
    /// The plain mean and standard deviation of the trials kept (sd 0 with one).
    pub plain_mean: f64,
    pub sd: f64,
    /// Per trial, in the order given: far from the others, so left out of the mean.
    pub outlier: Vec<bool>,
    /// The scatter dominates: the trials differ by more than their fits' errors allow (for a
    /// physical reason, e.g. the body re-clamped between trials), and the mean is the plain one.
    pub scatter_dominates: bool,
}

/// Combines repeated measurements `(value, se)` of one quantity.
///
/// - With three or more, a trial further than 4 robust standard deviations (1.4826 × the median
///   absolute deviation, at least its own standard error) *and* 0.5 % from the median is flagged
///   and left out: a knock or a mislabelled file, not the ordinary scatter.
/// - The estimate is the larger-error one of two: the mean weighted by the fits' errors with its
///   internal error (1/√Σwᵢ), or the plain mean with the external error sd/√n. Repeats of a
///   pendulum scatter by 0.1–0.3 % for physical reasons while one fit's error is 10⁻⁵ relative:
///   the scatter is then the truth about the quantity (a random-effects view with the
///   between-trial variance dominating), and a weighted mean would follow one trial.
///
/// # Panics
/// When `values` is empty.
pub fn combine_repeats(values: &[(f64, f64)]) -> Repeats {
    assert!(!values.is_empty(), "combine_repeats of no values");
    let mut outlier = vec![false; values.len()];
    if values.len() >= 3 {
        let median = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let med = median(values.iter().map(|v| v.0).collect());
        let robust_sd = 1.4826 * median(values.iter().map(|v| (v.0 - med).abs()).collect());
        for (flag, &(x, se)) in outlier.iter_mut().zip(values) {
            let d = (x - med).abs();
            *flag = d > 4.0 * robust_sd.max(se) && d > 0.005 * med.abs();
        }
    }
    let kept: Vec<(f64, f64)> = values
        .iter()
        .zip(&outlier)
        .filter(|(_, o)| !**o)
        .map(|(v, _)| *v)
        .collect();
    let n = kept.len() as f64;
    let var = |se: f64| se.max(1e-12).powi(2);
    let wsum: f64 = kept.iter().map(|v| 1.0 / var(v.1)).sum();
    let weighted = kept.iter().map(|v| v.0 / var(v.1)).sum::<f64>() / wsum;
    let internal = (1.0 / wsum).sqrt();
    let plain = kept.iter().map(|v| v.0).sum::<f64>() / n;
    let sd = if kept.len() > 1 {
        (kept.iter().map(|v| (v.0 - plain).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        0.0
    };
    let external = sd / n.sqrt();
    let scatter_dominates = external > internal;
    Repeats {
        mean: if scatter_dominates {
            Measured::new(plain, external)
        } else {
            Measured::new(weighted, internal)
        },
        plain_mean: plain,
        sd,
        outlier,
        scatter_dominates,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The factor's U Uᵀ is [`propagate`]'s J Σ Jᵀ: two correlated inputs, one independent,
    /// one exact (no error, no column), through five nonlinear outputs.
    #[test]
    fn a_propagated_factor_squares_to_the_propagated_covariance() {
        let mut inputs = Inputs::new();
        let pair = DMatrix::from_row_slice(2, 2, &[0.04, 0.018, 0.018, 0.09]);
        inputs.push_correlated(&[1.2, -0.7], &pair);
        inputs.push(Measured::new(3.0, 0.5));
        inputs.push(Measured::new(0.4, 0.0));
        let f = |x: &[f64]| -> Vec<f64> {
            vec![
                x[0] * x[1],
                x[0].sin() + x[2],
                x[1].powi(2) * x[3],
                (x[2] - x[0]).exp(),
                x[3] + x[1],
            ]
        };
        let (y0, cov) = propagate(&inputs, f);
        let (y1, u) = propagate_factor(&inputs, f);
        assert_eq!(y0, y1);
        assert_eq!((u.nrows(), u.ncols()), (5, 3));
        let err = (&u * u.transpose() - &cov).amax();
        assert!(err < 1e-12 * cov.amax(), "{err}");
    }

    /// Scatter far above the fits' errors: the plain mean with sd/√n.
    #[test]
    fn repeats_scattering_beyond_their_errors_take_the_scatter() {
        let v = [(0.99, 1e-5), (1.00, 1e-5), (1.01, 1e-5)];
        let r = combine_repeats(&v);
        assert!(r.scatter_dominates);
        assert!((r.mean.value - 1.0).abs() < 1e-15);
        // sd of {−0.01, 0, 0.01} is 0.01; its mean's is 0.01/√3.
        assert!((r.sd - 0.01).abs() < 1e-12);
        assert!((r.mean.se - 0.01 / 3f64.sqrt()).abs() < 1e-12);
        assert_eq!(r.outlier, vec![false; 3]);
    }

    /// Agreeing repeats: the weighted mean Σ(x/σ²)/Σ(1/σ²) with 1/√Σ(1/σ²).
    #[test]
    fn agreeing_repeats_take_the_weighted_mean() {
        let v = [(1.0, 0.1), (1.001, 0.2)];
        let r = combine_repeats(&v);
        assert!(!r.scatter_dominates);
        let (w1, w2) = (100.0, 25.0);
        assert!((r.mean.value - (1.0 * w1 + 1.001 * w2) / (w1 + w2)).abs() < 1e-15);
        assert!((r.mean.se - (1.0 / (w1 + w2)).sqrt()).abs() < 1e-15);
    }

    /// One trial 2 % off among five within 0.05 %: flagged and left out.
    #[test]
    fn a_trial_far_from_the_others_is_flagged() {
        let v = [
            (1.0, 1e-5),
            (1.0005, 1e-5),
            (0.9995, 1e-5),
            (1.02, 1e-5),
            (1.0002, 1e-5),
        ];
        let r = combine_repeats(&v);
        assert_eq!(r.outlier, vec![false, false, false, true, false]);
        assert!((r.plain_mean - (1.0 + 1.0005 + 0.9995 + 1.0002) / 4.0).abs() < 1e-15);
    }

    #[test]
    fn product_matches_the_closed_form() {
        // y = a·b: var(y) = b² var(a) + a² var(b) for independent inputs.
        let mut inp = Inputs::new();
        inp.push(Measured::new(3.0, 0.1));
        inp.push(Measured::new(5.0, 0.2));
        let (y, cov) = propagate(&inp, |x| vec![x[0] * x[1]]);
        assert_eq!(y[0], 15.0);
        let want = 25.0 * 0.01 + 9.0 * 0.04;
        assert!((cov[(0, 0)] - want).abs() < 1e-9 * want);
    }

    #[test]
    fn correlated_inputs_cancel_in_a_difference() {
        // y = a − b with corr(a, b) = 1 and equal variances: var(y) = 0.
        let mut inp = Inputs::new();
        let c = DMatrix::from_row_slice(2, 2, &[0.04, 0.04, 0.04, 0.04]);
        inp.push_correlated(&[1.0, 2.0], &c);
        let (_, cov) = propagate(&inp, |x| vec![x[0] - x[1]]);
        assert!(cov[(0, 0)].abs() < 1e-15);
    }
}
