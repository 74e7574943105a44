//! Many rides' predictions from a grid of speeds. In: the speeds at which one condition's
//! rides are predicted (their true speeds under a candidate), each ride's branch guess, and the
//! bicycle's weave (with its mode shape γ/θ) at a speed. Out: each ride's weave and shape,
//! interpolated from the grid where the interpolation's error is below [`TOLERANCE`], or a
//! mark that the ride is to be predicted on its own.
//!
//! A ride's prediction is an eigenproblem at its speed (4 × 4, or 9 × 9 with compliant tyres),
//! and a candidate's fit, its errors and its held-out refits ask for every ride's hundreds of
//! times: with 1,000 rides the diagnosis took 22.7 s solving each ride's, 16.1 s with the
//! grid (data/rides.toml's rides 62 times over, 0.02 m/s apart). The weave and its shape are
//! analytic in the speed wherever the weave is a simple eigenvalue, so a condition whose rides
//! outnumber twice the grid's points ([`STEP_MPS`] apart over their speeds) solves the
//! eigenproblem at the grid's points only and interpolates each ride by the cubic through the
//! four points around it (Lagrange). Its error at an interval's middle is 3/128 of the fourth
//! difference there (the polynomial's remainder, f⁽⁴⁾/24 · 1.5 · 0.5 · 0.5 · 1.5 h⁴); an interval
//! whose fourth differences on either side say more than [`TOLERANCE`], or whose points have
//! no weave (a branch point, a change of branch between neighbours), is left to the rides'
//! own eigenproblems. A campaign of data/rides.toml's size (16 rides over 2 m/s, against 70
//! points) never takes the grid: its numbers are the eigenproblems' own.

use nalgebra::Complex;

/// The grid's step (m/s), on multiples of which its points lie whatever the rides' speeds (so
/// that a candidate's parameters moving the speeds do not move the grid).
pub const STEP_MPS: f64 = 1.0 / 32.0;

/// The largest interpolation error accepted (1/s in the eigenvalue; in the ratio γ/θ's real
/// and imaginary parts): a thousandth of the best standard error a ride's weave has (about
/// 0.001 1/s), so that 1,000 rides' residuals, each off by it, move χ² by about 2 √1000 ·
/// 0.001 ≈ 0.06 at most where their own scatter is 1, and a fitted parameter by a thousandth
/// of its error. On the benchmark bicycle the grid's estimate is 2e-7 at 4 m/s (the weave's
/// frequency turning up), 1e-8 or less at 2–3 and 5–6 m/s.
pub const TOLERANCE: f64 = 1e-6;

/// A prediction: the weave and, where asked for, γ/θ.
pub type Prediction = (Complex<f64>, Option<Complex<f64>>);

/// Each of the rides at `speeds_mps` (their branches' `guesses`), predicted from the grid:
/// `Some` where interpolated, `None` where the ride is to be predicted on its own. `at(v,
/// guess)` is the weave and (with `shape`) γ/θ at speed v on the branch nearest `guess`.
/// `None` as a whole when the grid would cost more than the rides (fewer than twice its
/// points) or a speed is not finite.
pub fn interpolate(
    speeds_mps: &[f64],
    guesses: &[Complex<f64>],
    shape: bool,
    at: &dyn Fn(f64, Complex<f64>) -> Option<Prediction>,
) -> Option<Vec<Option<Prediction>>> {
    if speeds_mps.iter().any(|v| !v.is_finite()) || speeds_mps.len() != guesses.len() {
        return None;
    }
    let (lo, hi) = speeds_mps
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    // Two points beyond the rides on either side: the cubic takes one, the second fourth
    // difference one more.
    let first = (lo / STEP_MPS).floor() - 2.0;
    let last = (hi / STEP_MPS).floor() + 3.0;
    let points = last - first + 1.0;
    if !(points.is_finite() && 2.0 * points <= speeds_mps.len() as f64) {
        return None;
    }
    let first = first as i64;
    // Each point's guess: the nearest ride's.
    let mut order: Vec<usize> = (0..speeds_mps.len()).collect();
    order.sort_by(|&a, &b| speeds_mps[a].total_cmp(&speeds_mps[b]));
    let nearest_guess = |v: f64| {
        let k = order.partition_point(|&i| speeds_mps[i] < v);
        let below = k.checked_sub(1).map(|k| order[k]);
        let above = order.get(k).copied();
        let i = match (below, above) {
            (Some(b), Some(a)) if v - speeds_mps[b] <= speeds_mps[a] - v => b,
            (_, Some(a)) => a,
            (Some(b), None) => b,
            (None, None) => unreachable!("the rides are not empty: 2 × points ≤ their number"),
        };
        guesses[i]
    };
    let values: Vec<Option<[f64; 4]>> = (0..points as i64)
        .map(|k| {
            let v = (first + k) as f64 * STEP_MPS;
            if v <= 0.0 {
                return None;
            }
            let (w, s) = at(v, nearest_guess(v))?;
            let s = match (shape, s) {
                (true, Some(s)) => s,
                (true, None) => return None,
                (false, _) => Complex::new(0.0, 0.0),
            };
            Some([w.re, w.im, s.re, s.im])
        })
        .collect();
    // Each interval checked once: from its left point k, whether the two fourth differences
    // about it (points k − 2 … k + 3) put the cubic's error within the tolerance.
    let fourth = |k: usize, c: usize| -> Option<f64> {
        let f = |j: usize| values[j].map(|x| x[c]);
        Some(f(k)? - 4.0 * f(k + 1)? + 6.0 * f(k + 2)? - 4.0 * f(k + 3)? + f(k + 4)?)
    };
    let interval_ok: Vec<bool> = (0..values.len())
        .map(|k| {
            let error = (k >= 2 && k + 3 < values.len())
                .then(|| {
                    (0..4)
                        .map(|c| Some(fourth(k - 2, c)?.abs().max(fourth(k - 1, c)?.abs())))
                        .try_fold(0.0, |m: f64, e| Some(m.max(e?)))
                })
                .flatten();
            // Not finite (a point's value), or too large.
            error.is_some_and(|e| e * 3.0 / 128.0 <= TOLERANCE)
        })
        .collect();
    Some(
        speeds_mps
            .iter()
            .map(|&v| {
                let x = v / STEP_MPS;
                let j = x.floor();
                let t = x - j;
                let left = (j as i64 - first) as usize;
                if !interval_ok[left] {
                    return None;
                }
                let weights = [
                    -t * (t - 1.0) * (t - 2.0) / 6.0,
                    (t + 1.0) * (t - 1.0) * (t - 2.0) / 2.0,
                    -(t + 1.0) * t * (t - 2.0) / 2.0,
                    (t + 1.0) * t * (t - 1.0) / 6.0,
                ];
                let value = |c: usize| -> f64 {
                    (0..4)
                        .map(|k| weights[k] * values[left - 1 + k].map_or(f64::NAN, |x| x[c]))
                        .sum()
                };
                let w = Complex::new(value(0), value(1));
                let s = shape.then(|| Complex::new(value(2), value(3)));
                Some((w, s))
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::linear::LinearBike;
    use crate::model::Benchmark;

    /// Meijaard et al.'s benchmark bicycle's weave and γ/θ at 600 seeded speeds over 3–6 m/s,
    /// interpolated from the grid, against each speed's own eigenproblem: within the tolerance
    /// (the remainder's bound holds where the fourth differences are smooth), every ride
    /// interpolated.
    #[test]
    fn interpolated_weaves_are_the_eigenproblems_own() {
        let bike = LinearBike::whipple(&Benchmark::meijaard_2007());
        let at = |v: f64, guess: Complex<f64>| bike.weave_and_shape(v, guess, true);
        let mut rng = <rand_xoshiro::Xoshiro256StarStar as rand::SeedableRng>::seed_from_u64(3);
        let speeds: Vec<f64> = (0..600)
            .map(|_| 3.0 + 3.0 * rand::RngExt::random::<f64>(&mut rng))
            .collect();
        let guesses: Vec<Complex<f64>> = speeds
            .iter()
            .map(|&v| bike.weave_near(v, Complex::new(-1.0, 5.0)).unwrap())
            .collect();
        let grid = interpolate(&speeds, &guesses, true, &at).expect("600 rides over 3 m/s");
        for ((&v, g), p) in speeds.iter().zip(&guesses).zip(&grid) {
            let (w, s) = p.expect("smooth: every ride interpolated");
            let (w0, s0) = at(v, *g).unwrap();
            assert!((w - w0).norm() <= TOLERANCE, "v {v}: {w} against {w0}");
            assert!((s.unwrap() - s0.unwrap()).norm() <= TOLERANCE, "v {v}");
        }
    }

    /// Too few rides for the grid's points, or a speed that is not finite: no grid.
    #[test]
    fn a_grid_is_taken_only_where_it_costs_less() {
        let bike = LinearBike::whipple(&Benchmark::meijaard_2007());
        let at = |v: f64, guess: Complex<f64>| bike.weave_and_shape(v, guess, false);
        let g = Complex::new(-1.0, 5.0);
        // 3–5 m/s: 70 points, so 139 rides are too few and 140 enough.
        let spread = |n: usize| -> Vec<f64> {
            (0..n)
                .map(|k| 3.0 + 2.0 * k as f64 / (n - 1) as f64)
                .collect()
        };
        assert!(interpolate(&spread(139), &vec![g; 139], false, &at).is_none());
        assert!(interpolate(&spread(140), &vec![g; 140], false, &at).is_some());
        let mut bad = spread(140);
        bad[7] = f64::NAN;
        assert!(interpolate(&bad, &vec![g; 140], false, &at).is_none());
    }

    /// Rides down to the weave's branch point, where it turns into two real modes (about
    /// 0.68 m/s on the benchmark bicycle): the intervals near it are left to the rides' own
    /// eigenproblems, the rest interpolated within the tolerance.
    #[test]
    fn near_a_branch_point_the_rides_are_solved_on_their_own() {
        let bike = LinearBike::whipple(&Benchmark::meijaard_2007());
        let at = |v: f64, guess: Complex<f64>| bike.weave_and_shape(v, guess, false);
        let speeds: Vec<f64> = (0..400).map(|k| 0.7 + 0.005 * k as f64).collect();
        let guesses: Vec<Complex<f64>> = speeds.iter().map(|_| Complex::new(0.0, 1.0)).collect();
        let grid = interpolate(&speeds, &guesses, false, &at).expect("400 rides over 2 m/s");
        let own = grid.iter().take(10).filter(|p| p.is_none()).count();
        assert!(
            own >= 1,
            "the slowest rides interpolated across the branch point"
        );
        for ((&v, g), p) in speeds.iter().zip(&guesses).zip(&grid) {
            if let Some((w, _)) = p {
                let (w0, _) = at(v, *g).unwrap();
                assert!((w - w0).norm() <= TOLERANCE, "v {v}: {w} against {w0}");
            }
        }
        assert!(grid.iter().filter(|p| p.is_some()).count() >= 300);
    }
}
