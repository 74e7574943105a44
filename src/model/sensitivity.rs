//! Sensitivity stage: a bicycle → how its weave and capsize speeds, and its weave eigenvalue at
//! chosen speeds, move with each benchmark parameter, and each parameter's share of their
//! variance (the uncertainty budget).
//!
//! In: a [`Parametrized`] bicycle (benchmark parameters with their covariance, from a file's
//! standard errors or propagated from a lab's measurements), without a controller.
//! Out: [`Sensitivity`]. The derivatives are the model's own, not finite differences: the
//! canonical matrices' derivatives by every parameter come from jets (automatic
//! differentiation) through Meijaard et al. 2007's (A 1)–(A 27) ([`crate::jet`]), an eigenvalue's from first-order perturbation
//! theory ([`eigenvalue_gradient`]), and a critical speed's from the implicit function theorem
//! on `Re λ(v, p) = 0`: `dv_c/dp = −(∂Re λ/∂p)/(∂Re λ/∂v)`, with `∂λ/∂v` from the same
//! gradient (λ depends on v through `v C₁` and `v² K₂`).

use super::uncertain::{eigenvalue_gradient, Parametrized};
use super::{canonical_terms, Benchmark, BenchmarkOf, Canonical, ParamError};
use crate::fit::Estimate;
use crate::jet::{Jet, Scalar};
use nalgebra::{Complex, DMatrix, DVector};

/// Errors of the sensitivity stage.
#[derive(Debug, thiserror::Error)]
pub enum SensitivityError {
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error(
        "{0}: the bicycle has a steer controller; sensitivities are of the Whipple model itself \
         (give the bicycle without --controller)"
    )]
    Controlled(String),
    #[error(
        "{name}: the eigenvalues' derivatives fail at {speed_mps} m/s (a double eigenvalue there)"
    )]
    Degenerate { name: String, speed_mps: f64 },
    #[error("{name}: no oscillatory weave at {speed_mps} m/s (below its merge speed the weave is two real roots); give speeds above it")]
    NoWeave { name: String, speed_mps: f64 },
}

/// The unit of a benchmark parameter, by its name ([`Benchmark::NAMES`]).
pub fn unit_of(name: &str) -> &'static str {
    match name {
        "lam" => "rad",
        "g" => "m/s²",
        n if n.starts_with('m') => "kg",
        n if n.starts_with('I') => "kg·m²",
        _ => "m",
    }
}

/// One benchmark parameter's effect on the characteristic speeds.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ParameterSensitivity {
    /// BicycleParameters' name (`w`, `c`, `lam`, `mB`, `IBxx`, …).
    pub name: &'static str,
    pub unit: &'static str,
    pub value: f64,
    pub se: f64,
    /// dv_weave/dp (m/s per the parameter's unit); `None` without a weave speed.
    pub d_weave_speed: Option<f64>,
    /// dv_capsize/dp (m/s per the parameter's unit); `None` without a capsize speed.
    pub d_capsize_speed: Option<f64>,
    /// (p/v) dv/dp: the relative change of the speed per relative change of the parameter;
    /// `None` where the parameter is zero.
    pub weave_elasticity: Option<f64>,
    pub capsize_elasticity: Option<f64>,
    /// The parameter's share of the speed's variance, `g_k (C g)_k / gᵀCg` (C the parameters'
    /// covariance, g the gradient): the shares add up to 1; with correlated parameters a share
    /// can be negative (a correlation that offsets).
    pub weave_variance_share: Option<f64>,
    pub capsize_variance_share: Option<f64>,
}

/// One measured input's share of the speeds' variance (the lab bicycle's masses and inertia
/// entries, a rider's parameters; for a benchmark file, its parameters again).
#[derive(Debug, Clone, serde::Serialize)]
pub struct InputShare {
    /// `frame I_xx`, `rider mB`, or a benchmark parameter's name.
    pub input: String,
    pub value: f64,
    pub se: f64,
    pub weave_variance_share: Option<f64>,
    pub capsize_variance_share: Option<f64>,
}

/// A measurement's share: the inputs one test gives (a body's inertia entries from its
/// pendulum tests, its mass from the scale), and how many repeats of that test alone would
/// halve the weave speed's standard error.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MeasurementShare {
    /// `frame inertia` (its torsion and compound-pendulum tests), `frame mass` (the scale),
    /// `rider`, or a benchmark parameter's name.
    pub measurement: String,
    pub weave_variance_share: Option<f64>,
    pub capsize_variance_share: Option<f64>,
    /// The repeats n of this measurement alone (its random error's variance over n) that
    /// bring the weave speed's variance to a quarter: `(1 − s) + s/n ≤ 1/4`, so
    /// `n = ⌈s/(s − 3/4)⌉`; `None` when its share s is 3/4 or less (no number of repeats of
    /// it alone halves the standard error).
    pub repeats_to_halve_weave_se: Option<u64>,
}

/// The weave eigenvalue at a speed and its derivatives by every parameter.
#[derive(Debug, Clone, serde::Serialize)]
pub struct WeaveDerivatives {
    pub speed_mps: f64,
    /// The weave eigenvalue (1/s), its imaginary part positive.
    pub re: f64,
    pub im: f64,
    /// dRe λ/dp and dIm λ/dp (1/s per the parameter's unit), in the order of
    /// [`Benchmark::NAMES`] (in JSON maps from the parameter's name, in that order).
    #[serde(serialize_with = "by_benchmark_name")]
    pub d_re: Vec<f64>,
    #[serde(serialize_with = "by_benchmark_name")]
    pub d_im: Vec<f64>,
}

/// The sensitivities of a bicycle's characteristic speeds and weave.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Sensitivity {
    pub bike: String,
    /// The weave and capsize speeds (m/s) with their standard errors from the budget
    /// (`√(gᵀCg)`).
    pub weave_speed_mps: Option<Estimate>,
    pub capsize_speed_mps: Option<Estimate>,
    /// Every benchmark parameter, in the order of [`Benchmark::NAMES`] (in JSON a map from
    /// the parameter's name, in that order).
    #[serde(serialize_with = "by_name")]
    pub parameters: Vec<ParameterSensitivity>,
    /// The budget by measured input (the model's own inputs, with their correlations).
    pub inputs: Vec<InputShare>,
    /// The budget by measurement, largest weave share first.
    pub measurements: Vec<MeasurementShare>,
    pub weave_derivatives: Vec<WeaveDerivatives>,
}

/// The parameters as a JSON map from their names, in their order.
fn by_name<S: serde::Serializer>(v: &[ParameterSensitivity], s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeMap;
    let mut m = s.serialize_map(Some(v.len()))?;
    for p in v {
        m.serialize_entry(p.name, p)?;
    }
    m.end()
}

/// Values in the order of [`Benchmark::NAMES`] as a JSON map from those names.
fn by_benchmark_name<S: serde::Serializer>(v: &[f64], s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeMap;
    let mut m = s.serialize_map(Some(v.len()))?;
    for (name, x) in Benchmark::NAMES.iter().zip(v) {
        m.serialize_entry(name, x)?;
    }
    m.end()
}

/// The derivatives of the canonical entries (M, C₁, K₀, K₂ row by row, then g) by each of the
/// 26 parameters: row k holds d(entry)/dp_k, exact (jets through (A 1)–(A 27)).
pub fn canonical_derivatives(b: &Benchmark) -> [[f64; 17]; 26] {
    let values = b.to_array();
    std::array::from_fn(|k| {
        let p = BenchmarkOf::from_array(std::array::from_fn(|i| {
            if i == k {
                Jet::var(values[i], 1.0)
            } else {
                Jet::c(values[i])
            }
        }));
        let t = canonical_terms(&p);
        let mut row = [0.0; 17];
        for (m, e) in [t.m, t.c1, t.k0, t.k2].iter().enumerate() {
            for j in 0..4 {
                row[4 * m + j] = e[j].d;
            }
        }
        row[16] = t.g.d;
        row
    })
}

/// dλ/dp_k for every parameter and ∂λ/∂v, for the eigenvalue `lambda` of `model` at speed
/// `v > 0`: the chain rule through the canonical entries (`d_entries` from
/// [`canonical_derivatives`]). `None` where the gradient fails (a double eigenvalue).
fn eigenvalue_derivatives(
    model: &Canonical,
    v: f64,
    lambda: Complex<f64>,
    d_entries: &[[f64; 17]; 26],
) -> Option<([Complex<f64>; 26], Complex<f64>)> {
    let grad = eigenvalue_gradient(model, v, lambda)?;
    let entry = |m: &nalgebra::Matrix2<f64>, j: usize| m[(j / 2, j % 2)];
    // λ depends on g through g K₀: ∂λ/∂g = Σ (∂λ/∂K₀_ij) K₀_ij / g.
    let d_g: Complex<f64> = (0..4)
        .map(|j| grad[8 + j] * entry(&model.k0, j))
        .sum::<Complex<f64>>()
        / model.g;
    // And on v through v C₁ and v² K₂.
    let d_v: Complex<f64> = (0..4)
        .map(|j| grad[4 + j] * entry(&model.c1, j) + grad[12 + j] * (2.0 * entry(&model.k2, j)))
        .sum::<Complex<f64>>()
        / v;
    let d_p = std::array::from_fn(|k| {
        let row = &d_entries[k];
        (0..16).map(|e| grad[e] * row[e]).sum::<Complex<f64>>() + d_g * row[16]
    });
    Some((d_p, d_v))
}

/// The critical eigenvalue at a characteristic speed: the weave's (the pair with Im > 0 whose
/// real part is nearest zero) or the capsize's (the real eigenvalue nearest zero).
fn critical_eigenvalue(model: &Canonical, v: f64, oscillatory: bool) -> Option<Complex<f64>> {
    let ev = model.eigenvalues(v)?;
    ev.into_iter()
        .filter(|z| {
            let real = z.im.abs() <= 1e-9 * (1.0 + z.norm());
            if oscillatory {
                z.im > 0.0 && !real
            } else {
                real
            }
        })
        .min_by(|a, b| a.re.abs().total_cmp(&b.re.abs()))
}

/// A characteristic speed (m/s), its derivatives by the parameters, its standard error and the
/// parameters' shares of its variance.
type Critical = (f64, [f64; 26], f64, Option<Vec<f64>>);

/// The derivative of a characteristic speed by every parameter: `−Re(dλ/dp)/Re(∂λ/∂v)`.
fn speed_derivatives(
    model: &Canonical,
    v: f64,
    oscillatory: bool,
    d_entries: &[[f64; 17]; 26],
) -> Option<[f64; 26]> {
    let lambda = critical_eigenvalue(model, v, oscillatory)?;
    let (d_p, d_v) = eigenvalue_derivatives(model, v, lambda, d_entries)?;
    if d_v.re == 0.0 || !d_v.re.is_finite() {
        return None;
    }
    Some(d_p.map(|d| -d.re / d_v.re))
}

/// A speed (m/s) and its derivatives by the 26 benchmark parameters.
pub type SpeedGradient = (f64, [f64; 26]);

/// The characteristic speeds with their derivatives, and the stability search they come from.
#[derive(Debug, Clone)]
pub struct CriticalSpeeds {
    pub stability: super::Stability,
    pub weave: Option<SpeedGradient>,
    pub capsize: Option<SpeedGradient>,
}

/// The weave and capsize speeds of the bicycle `b` (no controller) in `[0, v_max]` as
/// `stability` finds them, each with its derivatives by the 26 parameters; `None` for a speed
/// not in the range.
pub fn critical_speed_gradients(
    b: &Benchmark,
    v_max: f64,
) -> Result<CriticalSpeeds, SensitivityError> {
    let canonical = Canonical::from_benchmark(b);
    let stability = canonical.stability(v_max, 0.01)?;
    let d_entries = canonical_derivatives(b);
    let gradient = |v: Option<f64>, oscillatory: bool| -> Result<_, SensitivityError> {
        let Some(v) = v else { return Ok(None) };
        let d = speed_derivatives(&canonical, v, oscillatory, &d_entries).ok_or(
            SensitivityError::Degenerate {
                name: String::new(),
                speed_mps: v,
            },
        )?;
        Ok(Some((v, d)))
    };
    let weave = gradient(stability.weave_speed_mps, true)?;
    let capsize = gradient(stability.capsize_speed_mps, false)?;
    Ok(CriticalSpeeds {
        stability,
        weave,
        capsize,
    })
}

/// `√(gᵀCg)` and each parameter's share `g_k (C g)_k / gᵀCg` (`None` when the parameters carry
/// no uncertainty that reaches the speed).
fn budget(g: &[f64], cov: &DMatrix<f64>) -> (f64, Option<Vec<f64>>) {
    let gv = DVector::from_column_slice(g);
    let cg = cov * &gv;
    let var = gv.dot(&cg);
    let shares = (var > 0.0).then(|| (0..g.len()).map(|k| g[k] * cg[k] / var).collect());
    (var.max(0.0).sqrt(), shares)
}

/// The sensitivities of `model` (no controller): characteristic speeds searched in `[0, v_max]`
/// as `stability` finds them, the weave's derivatives at `speeds` (each > 0).
pub fn sensitivity(
    model: &Parametrized,
    speeds: &[f64],
    v_max: f64,
) -> Result<Sensitivity, SensitivityError> {
    if !model.control.is_none() {
        return Err(SensitivityError::Controlled(model.name.clone()));
    }
    let canonical = model.nominal_canonical();
    let input_cov = model.inputs.covariance();
    let (values, jac) = crate::uncertainty::jacobian(model.inputs.values(), &input_cov, |x| {
        model.benchmark_at(x).to_array().to_vec()
    });
    let cov = &jac * &input_cov * jac.transpose();
    let mut nominal = [0.0; 26];
    nominal.copy_from_slice(&values);
    let bench = Benchmark::from_array(&nominal);
    let d_entries = canonical_derivatives(&bench);
    let degenerate = |v: f64| SensitivityError::Degenerate {
        name: model.name.clone(),
        speed_mps: v,
    };
    let named = |e: SensitivityError| match e {
        SensitivityError::Degenerate { speed_mps, .. } => degenerate(speed_mps),
        e => e,
    };
    let CriticalSpeeds { weave, capsize, .. } =
        critical_speed_gradients(&bench, v_max).map_err(named)?;
    let with_budget = |c: Option<SpeedGradient>| {
        c.map(|(v, d)| {
            let (se, shares) = budget(&d, &cov);
            (v, d, se, shares)
        })
    };
    let (weave, capsize) = (with_budget(weave), with_budget(capsize));
    let elasticity = |d: f64, p: f64, v: f64| (p != 0.0).then(|| d * p / v);
    let parameters = (0..26)
        .map(|k| {
            let value = nominal[k];
            let of = |c: &Option<Critical>| {
                c.as_ref().map(|(v, d, _, shares)| {
                    (
                        d[k],
                        elasticity(d[k], value, *v),
                        shares.as_ref().map(|s| s[k]),
                    )
                })
            };
            let (w, c) = (of(&weave), of(&capsize));
            ParameterSensitivity {
                name: Benchmark::NAMES[k],
                unit: unit_of(Benchmark::NAMES[k]),
                value,
                se: cov[(k, k)].max(0.0).sqrt(),
                d_weave_speed: w.map(|w| w.0),
                d_capsize_speed: c.map(|c| c.0),
                weave_elasticity: w.and_then(|w| w.1),
                capsize_elasticity: c.and_then(|c| c.1),
                weave_variance_share: w.and_then(|w| w.2),
                capsize_variance_share: c.and_then(|c| c.2),
            }
        })
        .collect();
    let weave_derivatives = speeds
        .iter()
        .map(|&v| {
            let lambda = critical_eigenvalue(&canonical, v, true)
                .filter(|_| v > 0.0)
                .ok_or_else(|| SensitivityError::NoWeave {
                    name: model.name.clone(),
                    speed_mps: v,
                })?;
            let (d_p, _) = eigenvalue_derivatives(&canonical, v, lambda, &d_entries)
                .ok_or_else(|| degenerate(v))?;
            Ok(WeaveDerivatives {
                speed_mps: v,
                re: lambda.re,
                im: lambda.im,
                d_re: d_p.iter().map(|z| z.re).collect(),
                d_im: d_p.iter().map(|z| z.im).collect(),
            })
        })
        .collect::<Result<Vec<_>, SensitivityError>>()?;
    // By input: g_in = Jᵀ g, shares g_in,j (Σ g_in)_j / g_inᵀ Σ g_in (the same variance).
    let input_shares = |c: &Option<Critical>| -> Option<Vec<f64>> {
        let (_, d, _, _) = c.as_ref()?;
        let g_in = jac.transpose() * DVector::from_column_slice(d);
        budget(g_in.as_slice(), &input_cov).1
    };
    let (weave_in, capsize_in) = (input_shares(&weave), input_shares(&capsize));
    let inputs: Vec<InputShare> = model
        .input_names
        .iter()
        .enumerate()
        .map(|(j, name)| InputShare {
            input: name.clone(),
            value: model.inputs.values()[j],
            se: input_cov[(j, j)].max(0.0).sqrt(),
            weave_variance_share: weave_in.as_ref().map(|s| s[j]),
            capsize_variance_share: capsize_in.as_ref().map(|s| s[j]),
        })
        .collect();
    let measurements = measurement_shares(&inputs);
    let speed = |c: &Option<Critical>| {
        c.as_ref()
            .map(|(v, _, se, _)| Estimate { value: *v, se: *se })
    };
    Ok(Sensitivity {
        bike: model.name.clone(),
        weave_speed_mps: speed(&weave),
        capsize_speed_mps: speed(&capsize),
        parameters,
        inputs,
        measurements,
        weave_derivatives,
    })
}

/// The measurement an input comes from: a lab body's inertia entries from its pendulum tests
/// (`frame inertia`), its mass from the scale (`frame mass`), a rider's parameters together
/// (`rider`); a benchmark parameter is its own.
fn measurement_of(input: &str) -> String {
    match input.split_once(' ') {
        Some(("rider", _)) => "rider".into(),
        Some((body, "mass")) => format!("{body} mass"),
        Some((body, _)) => format!("{body} inertia"),
        None => input.into(),
    }
}

/// The inputs' shares summed by measurement, largest weave share first (ties by name), with
/// the repeats that would halve the weave speed's standard error.
fn measurement_shares(inputs: &[InputShare]) -> Vec<MeasurementShare> {
    let mut out: Vec<MeasurementShare> = Vec::new();
    for i in inputs {
        let m = measurement_of(&i.input);
        let add = |a: Option<f64>, b: Option<f64>| Some(a? + b?);
        match out.iter_mut().find(|o| o.measurement == m) {
            Some(o) => {
                o.weave_variance_share = add(o.weave_variance_share, i.weave_variance_share);
                o.capsize_variance_share = add(o.capsize_variance_share, i.capsize_variance_share);
            }
            None => out.push(MeasurementShare {
                measurement: m,
                weave_variance_share: i.weave_variance_share,
                capsize_variance_share: i.capsize_variance_share,
                repeats_to_halve_weave_se: None,
            }),
        }
    }
    for o in &mut out {
        o.repeats_to_halve_weave_se = o
            .weave_variance_share
            .filter(|&s| s > 0.75)
            .map(|s| (s / (s - 0.75)).ceil() as u64);
    }
    out.sort_by(|a, b| {
        let s = |m: &MeasurementShare| m.weave_variance_share.unwrap_or(0.0);
        s(b).total_cmp(&s(a))
            .then(a.measurement.cmp(&b.measurement))
    });
    out
}

impl Sensitivity {
    /// The parameters that matter for a speed, in words: those whose |elasticity| is at least
    /// a tenth of the largest, at most four, largest first; and the largest shares of its
    /// variance (5 % or more, at most four).
    fn in_words(
        &self,
        what: &str,
        elasticity: fn(&ParameterSensitivity) -> Option<f64>,
        share: fn(&ParameterSensitivity) -> Option<f64>,
    ) -> String {
        let mut by_elasticity: Vec<(&str, f64)> = self
            .parameters
            .iter()
            .filter_map(|p| Some((p.name, elasticity(p)?)))
            .collect();
        by_elasticity.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()).then(a.0.cmp(b.0)));
        let top = by_elasticity.first().map_or(0.0, |t| t.1.abs());
        let named: Vec<String> = by_elasticity
            .iter()
            .take(4)
            .filter(|(_, e)| e.abs() >= 0.1 * top && top > 0.0)
            .map(|(n, e)| format!("{n} ({e:+.2})"))
            .collect();
        let mut text = format!(
            "The {what} moves most with {} (elasticity: the relative change per relative change).",
            named.join(", ")
        );
        let mut shares: Vec<(&str, f64)> = self
            .parameters
            .iter()
            .filter_map(|p| Some((p.name, share(p)?)))
            .collect();
        shares.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(b.0)));
        let big: Vec<String> = shares
            .iter()
            .take(4)
            .filter(|(_, s)| *s >= 0.05)
            .map(|(n, s)| format!("{n} {:.0} %", 100.0 * s))
            .collect();
        if !big.is_empty() {
            text.push_str(&format!(
                " Its uncertainty comes most from {}.",
                big.join(", ")
            ));
        }
        text
    }

    /// The text `bikeproc sensitivity` prints: the speeds, the parameters that matter in words,
    /// and every parameter ranked by the weave speed's elasticity.
    pub fn to_text(&self) -> String {
        use std::fmt::Write as _;
        let mut s = format!("{}\n", self.bike);
        let speed = |e: &Option<Estimate>| {
            e.map_or("none in the range searched".to_string(), |e| {
                format!("{:.4} ± {:.4} m/s", e.value, e.se)
            })
        };
        let _ = writeln!(s, "  weave speed    {}", speed(&self.weave_speed_mps));
        let _ = writeln!(s, "  capsize speed  {}", speed(&self.capsize_speed_mps));
        if self.weave_speed_mps.is_some() {
            let _ = writeln!(
                s,
                "  {}",
                self.in_words(
                    "weave speed",
                    |p| p.weave_elasticity,
                    |p| p.weave_variance_share
                )
            );
        }
        if self.capsize_speed_mps.is_some() {
            let _ = writeln!(
                s,
                "  {}",
                self.in_words(
                    "capsize speed",
                    |p| p.capsize_elasticity,
                    |p| p.capsize_variance_share
                )
            );
        }
        let _ = writeln!(
            s,
            "\n  {:<6} {:>24} {:>6}  {:>13} {:>10} {:>7}  {:>13} {:>10} {:>7}",
            "param",
            "value ± se",
            "unit",
            "dv_weave/dp",
            "elasticity",
            "share",
            "dv_capsize/dp",
            "elasticity",
            "share"
        );
        let mut order: Vec<&ParameterSensitivity> = self.parameters.iter().collect();
        order.sort_by(|a, b| {
            let e = |p: &ParameterSensitivity| p.weave_elasticity.unwrap_or(0.0).abs();
            e(b).total_cmp(&e(a)).then(a.name.cmp(b.name))
        });
        // A value that rounds to zero is printed as +0 (not −0).
        let num = |x: Option<f64>, width: usize, decimals: usize| {
            x.map_or(format!("{:>width$}", "—"), |x| {
                let x = if x.abs() < 0.5 * 10f64.powi(-(decimals as i32)) {
                    0.0
                } else {
                    x
                };
                format!("{x:>+width$.decimals$}")
            })
        };
        // A share that rounds to zero is printed as 0.0 (not −0.0).
        let pct = |x: Option<f64>| {
            x.map_or(format!("{:>7}", "—"), |x| {
                format!("{:>6.1}%", if x.abs() < 5e-4 { 0.0 } else { 100.0 * x })
            })
        };
        for p in order {
            let _ = writeln!(
                s,
                "  {:<6} {:>24} {:>6}  {} {} {}  {} {} {}",
                p.name,
                format!("{:.6} ± {:.6}", p.value, p.se),
                p.unit,
                num(p.d_weave_speed, 13, 5),
                num(p.weave_elasticity, 10, 4),
                pct(p.weave_variance_share),
                num(p.d_capsize_speed, 13, 5),
                num(p.capsize_elasticity, 10, 4),
                pct(p.capsize_variance_share),
            );
        }
        if self
            .measurements
            .iter()
            .any(|m| m.measurement.contains(' '))
        {
            let _ = writeln!(
                s,
                "\n  The budget by measurement (shares of each speed's variance):"
            );
            for m in &self.measurements {
                let pct = |x: Option<f64>| {
                    x.map_or("—".to_string(), |x| {
                        format!("{:.1} %", if x.abs() < 5e-4 { 0.0 } else { 100.0 * x })
                    })
                };
                let _ = writeln!(
                    s,
                    "    {:<22} weave {:>7}, capsize {:>7}{}",
                    m.measurement,
                    pct(m.weave_variance_share),
                    pct(m.capsize_variance_share),
                    m.repeats_to_halve_weave_se.map_or(String::new(), |n| format!(
                        "; repeated {n} times (alone) it would halve the weave speed's standard error"
                    ))
                );
            }
            if self
                .measurements
                .iter()
                .all(|m| m.repeats_to_halve_weave_se.is_none())
            {
                let _ = writeln!(
                    s,
                    "    No measurement holds more than 3/4 of the weave speed's variance: repeating \
                     one alone cannot halve its standard error."
                );
            }
        }
        for w in &self.weave_derivatives {
            let _ = writeln!(
                s,
                "\n  weave at {:.2} m/s: {:.4} {:+.4}i 1/s; its largest derivatives (1/s per unit):",
                w.speed_mps, w.re, w.im
            );
            let mut k: Vec<usize> = (0..w.d_re.len()).collect();
            let size = |i: usize| {
                let v = self.parameters[i].value.abs().max(1e-12);
                w.d_re[i].hypot(w.d_im[i]) * v
            };
            k.sort_by(|&a, &b| size(b).total_cmp(&size(a)).then(a.cmp(&b)));
            for &i in k.iter().take(5) {
                let _ = writeln!(
                    s,
                    "    {:<6} dRe/dp {:+.5}, dIm/dp {:+.5}",
                    self.parameters[i].name, w.d_re[i], w.d_im[i]
                );
            }
        }
        s
    }
}
