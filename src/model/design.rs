//! Design stage: a bicycle and a target speed range → the smallest relative change of chosen
//! parameters that makes it stable over the range, or why no such change exists.
//!
//! In: a [`Benchmark`] (a rider already joined, if any), the range `[A, B]` (m/s) and the
//! [`DesignVariable`]s. Out: [`Design`], with the changed bicycle. Geometry stays a real
//! fork's: the trail follows the head angle and the fork offset,
//! `c = (r_F sin λ − d)/cos λ` (d the fork offset, perpendicular from the steer axis to the
//! front hub; Meijaard et al. 2007, Fig. 1), so changing the head angle with the fork kept
//! changes the trail, and "trail" as a variable means another fork (d) at the same head angle.
//! The front frame's mass and inertia are kept where they are.
//!
//! Stable over `[A, B]` means a weave speed at or below A and a capsize speed at or above B (or
//! none up to the search's end) with one stable range over both. The smallest change in
//! `‖x‖₂`, x the relative changes, is found by sequential linearization: at each step the
//! constraints `v_weave(x) ≤ A`, `v_capsize(x) ≥ B` are linearized with the model's own
//! derivatives ([`super::sensitivity::critical_speed_gradients`], chained through the
//! variables by jets) and the nearest point to no change that satisfies them, within
//! the bounds, is taken.

use super::sensitivity::{critical_speed_gradients, CriticalSpeeds, SensitivityError};
use super::{trail_keeping_offset, Benchmark};
use crate::jet::{Jet, Scalar};

/// What a design may change.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum DesignVariable {
    /// The steer axis tilt λ (from the vertical), the fork kept: the trail follows.
    HeadAngle,
    /// The trail at the original head angle (another fork offset).
    Trail,
    /// The wheelbase, the front frame and wheel moving forward with it.
    Wheelbase,
    /// A benchmark parameter by its index in [`Benchmark::NAMES`] (a mass, an inertia, a
    /// centre of mass coordinate, a radius).
    Parameter(usize),
}

impl DesignVariable {
    /// From its name on the command line: `head_angle`, `trail`, `wheelbase`, or a benchmark
    /// parameter's name (`mB`, `IFyy`, …; `lam`, `c`, `w` are the three above).
    pub fn parse(name: &str) -> Option<DesignVariable> {
        match name {
            "head_angle" | "lam" => Some(DesignVariable::HeadAngle),
            "trail" | "c" => Some(DesignVariable::Trail),
            "wheelbase" | "w" => Some(DesignVariable::Wheelbase),
            "g" => None,
            n => Benchmark::NAMES
                .iter()
                .position(|m| *m == n)
                .map(DesignVariable::Parameter),
        }
    }

    /// Every name of `names` ([`DesignVariable::parse`]), or the first that is not one.
    pub fn parse_list<S: AsRef<str>>(names: &[S]) -> Result<Vec<DesignVariable>, DesignError> {
        let vars = names
            .iter()
            .map(|n| {
                let n = n.as_ref().trim();
                DesignVariable::parse(n).ok_or_else(|| DesignError::UnknownVariable(n.into()))
            })
            .collect::<Result<Vec<_>, _>>()?;
        // One parameter named twice (`trail,c`: the trail is the fork's offset c) would be
        // weighed twice in the change's norm and its change printed as half.
        let given: Vec<&str> = names.iter().map(|n| n.as_ref().trim()).collect();
        for (i, v) in vars.iter().enumerate() {
            if let Some(j) = (0..i).find(|&j| parameter_of(vars[j]) == parameter_of(*v)) {
                return Err(DesignError::Repeated {
                    first: given[j].into(),
                    again: given[i].into(),
                    parameter: Benchmark::NAMES[parameter_of(*v)].into(),
                });
            }
        }
        Ok(vars)
    }

    /// Its name as the command line takes it.
    pub fn name(&self) -> String {
        match self {
            DesignVariable::HeadAngle => "head_angle".into(),
            DesignVariable::Trail => "trail".into(),
            DesignVariable::Wheelbase => "wheelbase".into(),
            DesignVariable::Parameter(k) => Benchmark::NAMES[*k].into(),
        }
    }
}

/// Errors of the design stage.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    #[error("--stable {0}:{1}: a range of speeds 0 < A < B (m/s)")]
    Range(f64, f64),
    #[error("no variable to vary: give --vary with at least one of head_angle, trail, wheelbase or a benchmark parameter")]
    NoVariables,
    #[error("`{0}`: not a design variable (head_angle, trail, wheelbase, or a benchmark parameter's name other than g: w, c, lam, rR, mR, IRxx, IRyy, xB, zB, mB, IBxx, IByy, IBzz, IBxz, xH, zH, mH, IHxx, IHyy, IHzz, IHxz, rF, mF, IFxx, IFyy)")]
    UnknownVariable(String),
    #[error("--vary moves `{parameter}` twice (`{first}` and `{again}`): name each variable once")]
    Repeated {
        first: String,
        again: String,
        parameter: String,
    },
    #[error("`{0}` is zero on this bicycle: a relative change of it means nothing (vary another)")]
    ZeroParameter(String),
    #[error(transparent)]
    Model(#[from] SensitivityError),
}

/// One variable's change.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Change {
    pub variable: String,
    /// The benchmark parameter it moves most directly, as named there (`lam`, `c`, `w`, …).
    pub parameter: &'static str,
    pub from: f64,
    pub to: f64,
    /// (to − from)/from.
    pub relative: f64,
    /// At the bound of the search (±`max_change`).
    pub at_bound: bool,
}

/// The result: reached or not, the changes, the speeds and stable ranges before and after, and
/// the changed bicycle.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Design {
    pub bike: String,
    pub target_mps: (f64, f64),
    pub reached: bool,
    /// Why not, in words (`None` when reached).
    pub reason: Option<String>,
    pub changes: Vec<Change>,
    /// ‖relative changes‖₂.
    pub relative_change_norm: f64,
    pub before_stable_ranges_mps: Vec<(f64, Option<f64>)>,
    pub after_stable_ranges_mps: Vec<(f64, Option<f64>)>,
    pub before_weave_speed_mps: Option<f64>,
    pub before_capsize_speed_mps: Option<f64>,
    pub after_weave_speed_mps: Option<f64>,
    pub after_capsize_speed_mps: Option<f64>,
    #[serde(skip)]
    pub bicycle: Benchmark,
}

/// The parameters with the relative changes `x` of `vars` applied (any arithmetic, so that
/// jets give their derivatives).
fn apply<T: Scalar>(base: &[f64; 26], vars: &[DesignVariable], x: &[T]) -> [T; 26] {
    const W: usize = 0;
    const C: usize = 1;
    const LAMBDA: usize = 2;
    const X_H: usize = 15;
    const R_F: usize = 22;
    let one = T::c(1.0);
    let mut p: [T; 26] = base.map(T::c);
    let (mut lambda, mut trail_at_base) = (p[LAMBDA], p[C]);
    for (v, &xi) in vars.iter().zip(x) {
        match v {
            DesignVariable::HeadAngle => lambda = p[LAMBDA] * (one + xi),
            DesignVariable::Trail => trail_at_base = p[C] * (one + xi),
            DesignVariable::Wheelbase => {
                let w = p[W] * (one + xi);
                p[X_H] = p[X_H] + (w - p[W]);
                p[W] = w;
            }
            DesignVariable::Parameter(k) => p[*k] = p[*k] * (one + xi),
        }
    }
    // The trail at the head angle, of the fork whose trail at the original head angle that is.
    p[C] = trail_keeping_offset(p[R_F], (T::c(base[LAMBDA]), trail_at_base), lambda);
    p[LAMBDA] = lambda;
    p
}

/// The benchmark parameter a variable names.
fn parameter_of(v: DesignVariable) -> usize {
    match v {
        DesignVariable::HeadAngle => 2,
        DesignVariable::Trail => 1,
        DesignVariable::Wheelbase => 0,
        DesignVariable::Parameter(k) => k,
    }
}

/// The constraints `[v_weave − A, B − v_capsize]`, their gradients by the variables (one
/// `[d g₁, d g₂]` per variable), and the stability search at that point.
type Linearized = ([f64; 2], Vec<[f64; 2]>, super::Stability);

/// The constraints at `x`: `[v_weave − A, B − v_capsize]` (≤ 0 when met) and their gradients
/// by x; the stability found. A capsize speed beyond the search counts as met (at the
/// search's end); no weave speed at all as unmet by the search's end.
fn constraints(
    base: &[f64; 26],
    vars: &[DesignVariable],
    x: &[f64],
    (a, b): (f64, f64),
    v_max: f64,
) -> Result<Linearized, SensitivityError> {
    let bike = Benchmark::from_array(&apply(base, vars, x));
    let CriticalSpeeds {
        stability,
        weave,
        capsize,
    } = critical_speed_gradients(&bike, v_max)?;
    // dp/dx_j by jets.
    let dp: Vec<[f64; 26]> = (0..vars.len())
        .map(|j| {
            let xd: Vec<Jet> = x
                .iter()
                .enumerate()
                .map(|(i, &v)| if i == j { Jet::var(v, 1.0) } else { Jet::c(v) })
                .collect();
            apply(base, vars, &xd).map(|d| d.d)
        })
        .collect();
    let chain = |g: &[f64; 26]| -> Vec<f64> {
        dp.iter()
            .map(|d| d.iter().zip(g).map(|(a, b)| a * b).sum())
            .collect()
    };
    let (gw, vw) = match &weave {
        Some((v, g)) => (chain(g), *v - a),
        None => (vec![0.0; vars.len()], v_max - a),
    };
    let (gc, vc) = match &capsize {
        Some((v, g)) => (chain(g).iter().map(|d| -d).collect(), b - *v),
        None => (vec![0.0; vars.len()], b - v_max),
    };
    let grads = (0..vars.len()).map(|j| [gw[j], gc[j]]).collect();
    Ok(([vw, vc], grads, stability))
}

/// The point nearest the origin with `g_i + G_i·(y − x) ≤ −margin` for the constraints, every
/// |y_j| ≤ `bound`: the active sets of at most two constraints enumerated, variables at a
/// bound fixed there one at a time. `None` when no point satisfies them.
fn nearest_feasible(
    x: &[f64],
    g: [f64; 2],
    grads: &[[f64; 2]],
    bound: f64,
    margin: f64,
) -> Option<Vec<f64>> {
    let n = x.len();
    // Constraint i in y: a_i · y ≤ b_i.
    let a: Vec<Vec<f64>> = (0..2)
        .map(|i| grads.iter().map(|r| r[i]).collect())
        .collect();
    let b: Vec<f64> = (0..2)
        .map(|i| -margin - g[i] + a[i].iter().zip(x).map(|(p, q)| p * q).sum::<f64>())
        .collect();
    let mut fixed: Vec<Option<f64>> = vec![None; n];
    for _ in 0..=n {
        let free: Vec<usize> = (0..n).filter(|&j| fixed[j].is_none()).collect();
        // With the fixed variables moved to the right-hand side.
        let bb: Vec<f64> = (0..2)
            .map(|i| {
                b[i] - (0..n)
                    .filter_map(|j| fixed[j].map(|f| a[i][j] * f))
                    .sum::<f64>()
            })
            .collect();
        let af: Vec<Vec<f64>> = (0..2)
            .map(|i| free.iter().map(|&j| a[i][j]).collect())
            .collect();
        let dot = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(p, q)| p * q).sum::<f64>();
        let feasible = |y: &[f64]| (0..2).all(|i| dot(&af[i], y) <= bb[i] + 1e-12);
        let mut best: Option<Vec<f64>> = None;
        let mut consider = |y: Vec<f64>| {
            if y.iter().all(|v| v.is_finite())
                && feasible(&y)
                && best.as_ref().is_none_or(|b| dot(&y, &y) < dot(b, b))
            {
                best = Some(y);
            }
        };
        consider(vec![0.0; free.len()]);
        for i in 0..2 {
            let nn = dot(&af[i], &af[i]);
            if nn > 0.0 {
                consider(af[i].iter().map(|v| v * bb[i] / nn).collect());
            }
        }
        // Both active: y = A^T (A A^T)^{-1} b.
        let (g11, g12, g22) = (
            dot(&af[0], &af[0]),
            dot(&af[0], &af[1]),
            dot(&af[1], &af[1]),
        );
        let det = g11 * g22 - g12 * g12;
        if det.abs() > 1e-14 * (g11 * g22).max(1e-300) {
            let l0 = (g22 * bb[0] - g12 * bb[1]) / det;
            let l1 = (g11 * bb[1] - g12 * bb[0]) / det;
            consider(
                (0..free.len())
                    .map(|k| l0 * af[0][k] + l1 * af[1][k])
                    .collect(),
            );
        }
        let y = best?;
        // The free variable furthest beyond its bound is fixed there; again.
        let worst = y
            .iter()
            .enumerate()
            .filter(|(_, v)| v.abs() > bound)
            .max_by(|p, q| p.1.abs().total_cmp(&q.1.abs()));
        match worst {
            None => {
                let mut out = vec![0.0; n];
                for (k, &j) in free.iter().enumerate() {
                    out[j] = y[k];
                }
                for j in 0..n {
                    if let Some(f) = fixed[j] {
                        out[j] = f;
                    }
                }
                return Some(out);
            }
            Some((k, v)) => fixed[free[k]] = Some(bound * v.signum()),
        }
    }
    None
}

/// The point within `±bound` that minimizes the squared shortfall `Σ max(0, g_i + G_i·(y −
/// x))²` of the linearized constraints (projected gradient descent, step 1/L with L twice
/// the squared Frobenius norm of G, which bounds the gradient's Lipschitz constant).
fn least_shortfall(x: &[f64], g: [f64; 2], grads: &[[f64; 2]], bound: f64) -> Vec<f64> {
    let n = x.len();
    let lipschitz = 2.0 * grads.iter().map(|r| r[0] * r[0] + r[1] * r[1]).sum::<f64>();
    if lipschitz <= 0.0 {
        return x.to_vec();
    }
    let mut y = x.to_vec();
    for _ in 0..5000 {
        let r: Vec<f64> = (0..2)
            .map(|i| {
                let v = g[i] + (0..n).map(|j| grads[j][i] * (y[j] - x[j])).sum::<f64>();
                v.max(0.0)
            })
            .collect();
        for j in 0..n {
            let grad = 2.0 * (r[0] * grads[j][0] + r[1] * grads[j][1]);
            y[j] = (y[j] - grad / lipschitz).clamp(-bound, bound);
        }
    }
    y
}

/// The squared shortfall of the constraints' values `g` (m²/s²): how far the weave speed lies
/// above the target's start and the capsize speed below its end; zero when both are met.
fn shortfall(g: [f64; 2]) -> f64 {
    g.iter().map(|v| v.max(0.0).powi(2)).sum()
}

/// Whether one stable range covers `[a, b]`.
fn covers(ranges: &[(f64, Option<f64>)], (a, b): (f64, f64)) -> bool {
    ranges
        .iter()
        .any(|&(lo, hi)| lo <= a + 1e-9 && hi.is_none_or(|h| h >= b - 1e-9))
}

/// The smallest relative change of `vars` (each within ±`max_change`) that makes `bike` stable
/// over `[a, b]` m/s (the characteristic speeds searched to `v_max`, at least 1.5 b).
pub fn design(
    name: &str,
    bike: &Benchmark,
    vars: &[DesignVariable],
    (a, b): (f64, f64),
    max_change: f64,
) -> Result<Design, DesignError> {
    if !(a > 0.0 && b > a && b.is_finite()) {
        return Err(DesignError::Range(a, b));
    }
    if vars.is_empty() {
        return Err(DesignError::NoVariables);
    }
    let base = bike.to_array();
    for v in vars {
        let k = parameter_of(*v);
        if base[k] == 0.0 {
            return Err(DesignError::ZeroParameter(v.name()));
        }
    }
    let v_max = (1.5 * b).max(10.0);
    let mut x = vec![0.0; vars.len()];
    let (mut g, mut grads, before) = constraints(&base, vars, &x, (a, b), v_max)?;
    let mut after = before.clone();
    let mut reason = None;
    let mut unreachable_at_first_order = false;
    // A margin of 1e-6 m/s inside the target, so that the design's own search confirms it.
    let margin = 1e-6;
    for _ in 0..60 {
        // Where no change meets both to first order, the closest: the least squared shortfall.
        let y = match nearest_feasible(&x, g, &grads, max_change, margin) {
            Some(y) => y,
            None => {
                unreachable_at_first_order = true;
                least_shortfall(&x, g, &grads, max_change)
            }
        };
        // Step toward it, halved until the model's search still finds the speeds and, while
        // the target is missed, until the model's own shortfall shrinks: a step the
        // linearization promised but the model does not keep is not taken (it used to leave
        // the unchanged bicycle as the "closest design" when a smaller shortfall was in reach).
        let now = shortfall(g);
        let mut step = 1.0;
        let mut moved = None;
        let mut searched = false;
        while step > 1e-3 {
            let trial: Vec<f64> = x.iter().zip(&y).map(|(p, q)| p + step * (q - p)).collect();
            if let Ok(next) = constraints(&base, vars, &trial, (a, b), v_max) {
                searched = true;
                if now == 0.0 || shortfall(next.0) < now {
                    moved = Some((trial, next));
                    break;
                }
            }
            step *= 0.5;
        }
        let Some((trial, (g2, grads2, stab2))) = moved else {
            if !searched {
                reason = Some("the model's search failed near the changes asked for".into());
            }
            // Otherwise no step shrinks the shortfall: this is the closest design.
            break;
        };
        let delta = trial
            .iter()
            .zip(&x)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
        (x, g, grads, after) = (trial, g2, grads2, stab2);
        if delta < 1e-10 {
            break;
        }
    }
    let reached = covers(&after.stable_ranges_mps, (a, b));
    if !reached && reason.is_none() {
        let closest = super::ranges_text(&after.stable_ranges_mps, 3, " m/s");
        reason = Some(format!(
            "not reachable by {} within ±{:.0} %{}: the closest design (the least squared \
             shortfall of the weave speed below {a} m/s and the capsize speed above {b} m/s) is \
             stable {}",
            vars.iter().map(|v| v.name()).collect::<Vec<_>>().join(", "),
            100.0 * max_change,
            if unreachable_at_first_order {
                " (no change of them moves the weave speed down and the capsize speed up \
                 enough together)"
            } else {
                ""
            },
            if closest.is_empty() {
                "nowhere".to_string()
            } else {
                closest.join(", ")
            }
        ));
    }
    let p = apply(&base, vars, &x);
    let mut bicycle = Benchmark::from_array(&p);
    bicycle.se = bike.se;
    // A change the model takes but no bicycle has (an inertia no body has, a wheelbase gone) is
    // no design.
    let (reached, reason) = match bicycle.validate(std::path::Path::new(name)) {
        Ok(()) => (reached, reason),
        Err(e) => (
            false,
            Some(format!(
                "the changes asked for make no physical bicycle: {e}"
            )),
        ),
    };
    let changes = vars
        .iter()
        .zip(&x)
        .map(|(v, &xi)| {
            let k = parameter_of(*v);
            Change {
                variable: v.name(),
                parameter: Benchmark::NAMES[k],
                from: base[k],
                to: p[k],
                relative: xi,
                at_bound: xi.abs() >= max_change * (1.0 - 1e-9),
            }
        })
        .collect();
    Ok(Design {
        bike: name.into(),
        target_mps: (a, b),
        reached,
        reason: if reached { None } else { reason },
        changes,
        relative_change_norm: x.iter().map(|v| v * v).sum::<f64>().sqrt(),
        before_weave_speed_mps: before.weave_speed_mps,
        before_capsize_speed_mps: before.capsize_speed_mps,
        after_weave_speed_mps: after.weave_speed_mps,
        after_capsize_speed_mps: after.capsize_speed_mps,
        before_stable_ranges_mps: before.stable_ranges_mps,
        after_stable_ranges_mps: after.stable_ranges_mps,
        bicycle,
    })
}

impl Design {
    /// The text `bikeproc design` prints.
    pub fn to_text(&self) -> String {
        use std::fmt::Write as _;
        let ranges = |r: &[(f64, Option<f64>)]| {
            let t = super::ranges_text(r, 3, " m/s");
            if t.is_empty() {
                "nowhere".to_string()
            } else {
                t.join(", ")
            }
        };
        let speed = |v: Option<f64>| v.map_or("none".to_string(), |v| format!("{v:.4} m/s"));
        let (a, b) = self.target_mps;
        let mut s = format!("{}: stable over {a}–{b} m/s?\n", self.bike);
        match &self.reason {
            None => {
                let _ = writeln!(
                    s,
                    "  reached, with a relative change of {:.2} % (‖x‖₂):",
                    100.0 * self.relative_change_norm
                );
            }
            Some(r) => {
                let _ = writeln!(s, "  {r}.");
            }
        }
        let _ = writeln!(
            s,
            "    (each variable's own relative change; the trail's is the fork's, at the original \
             head angle)"
        );
        for c in &self.changes {
            let _ = writeln!(
                s,
                "    {:<11} ({:<4}) {:.6} → {:.6}  ({:+.2} %{})",
                c.variable,
                c.parameter,
                c.from,
                c.to,
                100.0 * c.relative,
                if c.at_bound { ", at the bound" } else { "" }
            );
        }
        let _ = writeln!(
            s,
            "  before: stable {}; weave speed {}, capsize speed {}",
            ranges(&self.before_stable_ranges_mps),
            speed(self.before_weave_speed_mps),
            speed(self.before_capsize_speed_mps)
        );
        let _ = writeln!(
            s,
            "  after:  stable {}; weave speed {}, capsize speed {}",
            ranges(&self.after_stable_ranges_mps),
            speed(self.after_weave_speed_mps),
            speed(self.after_capsize_speed_mps)
        );
        s
    }
}
