//! Forward-mode automatic differentiation for the model's own derivatives.
//!
//! In: the benchmark parameters as [`Dual`] numbers, one of them carrying a unit derivative.
//! Out: the canonical matrices and their exact derivatives by that parameter (the same
//! arithmetic as [`super::Canonical::from_benchmark`], carried through the chain rule), which
//! [`super::sensitivity`] combines with the eigenvalues' first-order perturbation theory.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// The arithmetic the canonical matrices need: `f64` for the model, [`Dual`] for its
/// derivatives.
pub trait Real:
    Copy
    + From<f64>
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// The value (without its derivative).
    fn value(self) -> f64;
    fn sin_cos(self) -> (Self, Self);
    /// `self²`.
    fn squared(self) -> Self;
}

impl Real for f64 {
    fn value(self) -> f64 {
        self
    }
    fn sin_cos(self) -> (f64, f64) {
        f64::sin_cos(self)
    }
    fn squared(self) -> f64 {
        self.powi(2)
    }
}

/// A number `re + eps·ε` with `ε² = 0`: `eps` is the derivative of `re` along one direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dual {
    pub re: f64,
    pub eps: f64,
}

impl Dual {
    /// A constant (zero derivative).
    pub fn constant(re: f64) -> Dual {
        Dual { re, eps: 0.0 }
    }
    /// The variable differentiated by (unit derivative).
    pub fn variable(re: f64) -> Dual {
        Dual { re, eps: 1.0 }
    }
}

impl From<f64> for Dual {
    fn from(re: f64) -> Dual {
        Dual::constant(re)
    }
}

impl Add for Dual {
    type Output = Dual;
    fn add(self, o: Dual) -> Dual {
        Dual {
            re: self.re + o.re,
            eps: self.eps + o.eps,
        }
    }
}

impl Sub for Dual {
    type Output = Dual;
    fn sub(self, o: Dual) -> Dual {
        Dual {
            re: self.re - o.re,
            eps: self.eps - o.eps,
        }
    }
}

impl Mul for Dual {
    type Output = Dual;
    fn mul(self, o: Dual) -> Dual {
        Dual {
            re: self.re * o.re,
            eps: self.eps * o.re + self.re * o.eps,
        }
    }
}

impl Div for Dual {
    type Output = Dual;
    fn div(self, o: Dual) -> Dual {
        Dual {
            re: self.re / o.re,
            eps: (self.eps * o.re - self.re * o.eps) / (o.re * o.re),
        }
    }
}

impl Neg for Dual {
    type Output = Dual;
    fn neg(self) -> Dual {
        Dual {
            re: -self.re,
            eps: -self.eps,
        }
    }
}

impl Real for Dual {
    fn value(self) -> f64 {
        self.re
    }
    fn sin_cos(self) -> (Dual, Dual) {
        let (s, c) = self.re.sin_cos();
        (
            Dual {
                re: s,
                eps: c * self.eps,
            },
            Dual {
                re: c,
                eps: -s * self.eps,
            },
        )
    }
    fn squared(self) -> Dual {
        self * self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against closed-form derivatives: d/dx of x²/(1 + x) sin x and of cos(3x) at x = 0.7.
    #[test]
    fn duals_carry_the_chain_rule() {
        let x = Dual::variable(0.7);
        let f = x.squared() / (Dual::from(1.0) + x) * x.sin_cos().0;
        let (xv, s, c) = (0.7f64, 0.7f64.sin(), 0.7f64.cos());
        let expected =
            (2.0 * xv / (1.0 + xv) - xv * xv / (1.0 + xv).powi(2)) * s + xv * xv / (1.0 + xv) * c;
        assert!((f.eps - expected).abs() < 1e-15, "{} vs {expected}", f.eps);
        let g = (Dual::from(3.0) * x).sin_cos().1;
        assert!((g.eps + 3.0 * (2.1f64).sin()).abs() < 1e-15);
        assert_eq!((-x - x).eps, -2.0);
    }
}
