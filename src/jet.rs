//! Automatic differentiation, at the side of the pipeline: a second-order jet along one
//! direction, `x(ε) = v + d ε + dd ε²/2`. Evaluating a function of coordinates `q + ε q̇` with
//! jets gives, exactly (no finite differences), its value, its rate `d = J q̇` and its
//! convective second derivative `dd = q̇ᵀ H q̇`. The simulator takes from it the velocity and
//! the acceleration at `q̈ = 0` of any point or frame of the bicycle; the model
//! ([`crate::model::canonical_terms`]) the canonical matrices' derivatives by a parameter
//! (`d`, with `q̇` the parameter's unit vector).
//!
//! Kept for a measured reason (`benches/kernels`): on a kinematics-like function of three
//! coordinates it agrees with num-dual's `Dual2_64` to 4.4e-16 in the second derivative (exactly
//! in the value and rate) and takes 60 ns against 67 ns; num-dual 0.13 would add a dependency for
//! the same arithmetic (its later versions want nalgebra 0.35).

use std::ops::{Add, Div, Mul, Neg, Sub};

/// A scalar the kinematics can be written over: `f64`, or a [`Jet`].
pub trait Scalar:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    fn c(x: f64) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn sqrt(self) -> Self;
    fn value(self) -> f64;
}

impl Scalar for f64 {
    fn c(x: f64) -> f64 {
        x
    }
    fn sin(self) -> f64 {
        f64::sin(self)
    }
    fn cos(self) -> f64 {
        f64::cos(self)
    }
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
    fn value(self) -> f64 {
        self
    }
}

/// Value, first and second derivative along one direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jet {
    pub v: f64,
    pub d: f64,
    pub dd: f64,
}

impl Jet {
    /// The coordinate `v` moving at rate `d` (no acceleration).
    pub fn var(v: f64, d: f64) -> Jet {
        Jet { v, d, dd: 0.0 }
    }

    /// Applies `f` with `f'` and `f''` at the value (the chain rule to second order).
    fn chain(self, f: f64, f1: f64, f2: f64) -> Jet {
        Jet {
            v: f,
            d: f1 * self.d,
            dd: f1 * self.dd + f2 * self.d * self.d,
        }
    }
}

impl Add for Jet {
    type Output = Jet;
    fn add(self, o: Jet) -> Jet {
        Jet {
            v: self.v + o.v,
            d: self.d + o.d,
            dd: self.dd + o.dd,
        }
    }
}

impl Sub for Jet {
    type Output = Jet;
    fn sub(self, o: Jet) -> Jet {
        Jet {
            v: self.v - o.v,
            d: self.d - o.d,
            dd: self.dd - o.dd,
        }
    }
}

impl Mul for Jet {
    type Output = Jet;
    fn mul(self, o: Jet) -> Jet {
        Jet {
            v: self.v * o.v,
            d: self.d * o.v + self.v * o.d,
            dd: self.dd * o.v + 2.0 * self.d * o.d + self.v * o.dd,
        }
    }
}

impl Div for Jet {
    type Output = Jet;
    fn div(self, o: Jet) -> Jet {
        let inv = o.chain(1.0 / o.v, -1.0 / (o.v * o.v), 2.0 / (o.v * o.v * o.v));
        self * inv
    }
}

impl Neg for Jet {
    type Output = Jet;
    fn neg(self) -> Jet {
        Jet {
            v: -self.v,
            d: -self.d,
            dd: -self.dd,
        }
    }
}

impl Scalar for Jet {
    fn c(x: f64) -> Jet {
        Jet {
            v: x,
            d: 0.0,
            dd: 0.0,
        }
    }
    fn sin(self) -> Jet {
        let (s, c) = self.v.sin_cos();
        self.chain(s, c, -s)
    }
    fn cos(self) -> Jet {
        let (s, c) = self.v.sin_cos();
        self.chain(c, -s, -c)
    }
    fn sqrt(self) -> Jet {
        let r = self.v.sqrt();
        self.chain(r, 0.5 / r, -0.25 / (r * self.v))
    }
    fn value(self) -> f64 {
        self.v
    }
}

/// Three-vectors of any [`Scalar`] as arrays: the arithmetic of a rigid-body chain's
/// kinematics, the simulator's and the analysis' nonlinear bicycle alike.
pub mod v3 {
    use super::Scalar;

    /// A three-vector.
    pub type V3<S> = [S; 3];

    pub fn add<S: Scalar>(a: V3<S>, b: V3<S>) -> V3<S> {
        [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
    }

    pub fn sub<S: Scalar>(a: V3<S>, b: V3<S>) -> V3<S> {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }

    pub fn scale<S: Scalar>(a: V3<S>, k: S) -> V3<S> {
        [a[0] * k, a[1] * k, a[2] * k]
    }

    pub fn cross<S: Scalar>(a: V3<S>, b: V3<S>) -> V3<S> {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }

    pub fn dot<S: Scalar>(a: V3<S>, b: V3<S>) -> S {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn second_derivatives_match_closed_forms() {
        // f(t) = sin(t)·sqrt(t)/cos(t) at t = 0.7, moving at rate 1.3.
        let t = Jet::var(0.7, 1.3);
        let f = t.sin() * t.sqrt() / t.cos();
        let g = |x: f64| x.sin() * x.sqrt() / x.cos();
        let h = 1e-4;
        let d1 = (g(0.7 + h) - g(0.7 - h)) / (2.0 * h);
        let d2 = (g(0.7 + h) - 2.0 * g(0.7) + g(0.7 - h)) / (h * h);
        assert!((f.v - g(0.7)).abs() < 1e-15);
        assert!((f.d - 1.3 * d1).abs() < 1e-7);
        assert!((f.dd - 1.69 * d2).abs() < 1e-5);
    }
}
