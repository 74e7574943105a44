//! Statistics shared by the stages: the χ² distribution's upper tail (the inertia tensor's fit, the
//! gap's campaign test; statrs), the Birge-scaled likelihood ratio of two nested fits, and how a
//! p-value, or any number in a message, is written.

/// The likelihood ratio χ²_smaller − χ²_larger of a model against the model with more
/// parameters (χ²_larger on `dof_larger` degrees of freedom), over the larger one's Birge ratio
/// χ²/dof where it is above 1: where even the larger model leaves more scatter than its errors
/// say, the ratio is judged in that scatter (Birge 1932). Never negative.
pub fn birge_likelihood_ratio(chi2_smaller: f64, chi2_larger: f64, dof_larger: usize) -> f64 {
    let birge = (chi2_larger / dof_larger.max(1) as f64).max(1.0);
    ((chi2_smaller - chi2_larger) / birge).max(0.0)
}

/// P(χ²_k > x): the probability that a χ² variable with `k` degrees of freedom exceeds `x`.
/// statrs' χ² distribution (its regularized upper incomplete gamma function); `NaN` for
/// `k = 0` or a `NaN` statistic.
pub fn chi2_sf(x: f64, k: usize) -> f64 {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    if x.is_nan() {
        return f64::NAN;
    }
    ChiSquared::new(k as f64).map_or(f64::NAN, |d| d.sf(x.max(0.0)))
}

/// A p-value for text: three significant digits, or "< 1e-300".
/// "p = 0.034", "p = 1.20e-05" or "p < 1e-300".
pub fn p_is(p: f64) -> String {
    let f = format_p(p);
    if f.starts_with('<') {
        format!("p {f}")
    } else {
        format!("p = {f}")
    }
}

/// A number as a person reads it: plain, or in exponent form when very large or small (a value
/// of 1e300 in a message is `1e300`, not three hundred digits).
pub fn number_text(x: f64) -> String {
    if x != 0.0 && x.is_finite() && !(1e-4..1e6).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

pub fn format_p(p: f64) -> String {
    if p < 1e-300 {
        "< 1e-300".into()
    } else if p < 1e-3 {
        format!("{p:.2e}")
    } else {
        format!("{p:.3}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed forms: k = 2 gives e^{−x/2}; k = 1 gives erfc(√(x/2)) — 3.841458820694124 is the
    /// 5 % point; k = 4 gives e^{−x/2}(1 + x/2).
    #[test]
    fn tail_matches_closed_forms() {
        for x in [0.1, 1.0, 5.0, 30.0, 200.0] {
            assert!(
                (chi2_sf(x, 2) - (-x / 2.0f64).exp()).abs()
                    < 1e-13 * (1.0 + 1e13 * (-x / 2.0f64).exp()).min(1e13)
            );
            let k4 = (-x / 2.0f64).exp() * (1.0 + x / 2.0);
            assert!(((chi2_sf(x, 4) - k4) / k4).abs() < 1e-12, "{x}");
        }
        assert!((chi2_sf(3.841458820694124, 1) - 0.05).abs() < 1e-12);
        // The median of χ²₃₂ is about 31.336 (k (1 − 2/(9k))³).
        assert!((chi2_sf(31.336, 32) - 0.5).abs() < 2e-3);
    }
}
