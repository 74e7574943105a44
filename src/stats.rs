//! Statistics shared by the stages: the χ² distribution's upper tail (the inertia tensor's fit, the
//! gap's campaign test) and how a p-value is written.

/// ln Γ(x) for x > 0 (Lanczos, g = 7, 9 terms: relative error below 1e-14).
fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection.
        return (std::f64::consts::PI / (std::f64::consts::PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, &c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The regularized upper incomplete gamma function Q(a, x) = Γ(a, x)/Γ(a): by its series
/// below x = a + 1, by its continued fraction (modified Lentz) above.
fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let front = (-x + a * x.ln() - ln_gamma(a)).exp();
    if x < a + 1.0 {
        let (mut term, mut sum, mut n) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            n += 1.0;
            term *= x / n;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (1.0 - sum * front).max(0.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (front * h).clamp(0.0, 1.0)
    }
}

/// P(χ²_k > x): the probability that a χ² variable with `k` degrees of freedom exceeds `x`.
pub fn chi2_sf(x: f64, k: usize) -> f64 {
    if !x.is_finite() {
        return if x > 0.0 { 0.0 } else { f64::NAN };
    }
    gamma_q(0.5 * k as f64, 0.5 * x)
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
