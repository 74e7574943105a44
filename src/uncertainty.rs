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
    let x = inputs.values();
    let y0 = f(x);
    let cov = inputs.covariance();
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
    let out_cov = &jac * cov * jac.transpose();
    (y0, out_cov)
}

/// The standard errors on the diagonal of a covariance.
pub fn standard_errors(cov: &DMatrix<f64>) -> DVector<f64> {
    DVector::from_iterator(
        cov.nrows(),
        (0..cov.nrows()).map(|i| cov[(i, i)].max(0.0).sqrt()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

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
