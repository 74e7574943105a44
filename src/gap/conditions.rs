//! The conditions of a study: one bicycle ridden in several known set-ups (its controller off
//! and at several gains, a known mass added, …), each a campaign of its own. In: each
//! condition's name, model (the measured bicycle with that condition's known changes and its
//! controller) and which of its rides carry a speed reading. Out: for a candidate's effects,
//! the [`Layout`] of its parameters ([`super::effects::specs`] once per condition or shared) — the bicycle's effects shared by every condition, a
//! condition's own equipment ([`Effect::per_condition`]) fitted once per condition where it acts —
//! and each condition's parameter values from the fitted vector.
//!
//! A single campaign is a study of one condition: every parameter is then fitted once, as the
//! library lists them.

use super::effects::{Acts, Effect, ParamSpec};
use crate::model::{Benchmark, SteerControl};

/// One condition's model.
#[derive(Debug, Clone)]
pub struct ConditionModel {
    /// The condition's name (its manifest's stem).
    pub name: String,
    /// The measured bicycle with the condition's known changes.
    pub base: Benchmark,
    pub control: SteerControl,
    /// The bicycle's steer motor as declared ([`crate::model::control::SteerMotorSpec`]).
    pub steer_motor: Option<crate::model::control::SteerMotorSpec>,
    /// Some of its rides' speeds are a reading or another instrument's wheel sensor (what a
    /// speedometer's scale acts on).
    pub read_speeds: bool,
}

impl ConditionModel {
    /// Whether `effect` acts on this condition's rides ([`Acts`]): the actuator's gain only
    /// with a controller, the speedometer's scale only on read speeds.
    pub fn acts(&self, effect: Effect) -> bool {
        match effect.definition().acts {
            Acts::Always => true,
            Acts::WithController => !self.control.is_none(),
            Acts::OnReadSpeeds => self.read_speeds,
        }
    }
}

/// Where a condition's value of one effect parameter comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Slot {
    /// The fitted vector's element.
    Fitted(usize),
    /// A fixed value (the parameter's "no effect": an equipment effect a condition lacks).
    Fixed(f64),
}

/// The parameters of a candidate in a study: the fitted vector's elements and, per condition,
/// where each of the effects' parameters (`effects::specs` order) comes from.
#[derive(Debug, Clone)]
pub struct Layout {
    /// Each fitted element's spec …
    pub specs: Vec<ParamSpec>,
    /// … its index among the effects' parameters (`effects::specs` order) …
    pub compact: Vec<usize>,
    /// … its effect (an index into the effects) …
    pub effect: Vec<usize>,
    /// … and its condition (`None`: shared by all).
    pub condition: Vec<Option<usize>>,
    /// Per condition, per effect parameter.
    pub slots: Vec<Vec<Slot>>,
}

impl Layout {
    /// The layout of `effects` over `conditions`. With one condition every parameter is
    /// fitted once (the single campaign's layout); with more, an equipment effect's parameters
    /// are fitted once per condition it acts on ([`ConditionModel::acts`]) and fixed at "no
    /// effect" in the others, the bicycle's shared. A steer motor declared by a condition
    /// sets the ranges of its own effects ([`specs_of`]).
    pub fn new(effects: &[Effect], conditions: &[ConditionModel]) -> Layout {
        let mut layout = Layout {
            specs: Vec::new(),
            compact: Vec::new(),
            effect: Vec::new(),
            condition: Vec::new(),
            slots: vec![Vec::new(); conditions.len()],
        };
        let mut at = 0;
        for (j, &e) in effects.iter().enumerate() {
            for spec in specs_of(&[e], conditions) {
                let study = conditions.len() > 1 && e.per_condition();
                if study {
                    for (c, cond) in conditions.iter().enumerate() {
                        let slot = if cond.acts(e) {
                            layout.push(spec, at, j, Some(c))
                        } else {
                            Slot::Fixed(spec.none)
                        };
                        layout.slots[c].push(slot);
                    }
                } else {
                    let slot = layout.push(spec, at, j, None);
                    for s in layout.slots.iter_mut() {
                        s.push(slot);
                    }
                }
                at += 1;
            }
        }
        layout
    }

    fn push(
        &mut self,
        spec: ParamSpec,
        compact: usize,
        effect: usize,
        condition: Option<usize>,
    ) -> Slot {
        self.specs.push(spec);
        self.compact.push(compact);
        self.effect.push(effect);
        self.condition.push(condition);
        Slot::Fitted(self.specs.len() - 1)
    }

    /// How many elements are fitted.
    pub fn len(&self) -> usize {
        self.specs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.specs.is_empty()
    }

    /// Condition `c`'s values of the effects' parameters from the fitted vector `params`.
    pub fn condition_params(&self, params: &[f64], c: usize) -> Vec<f64> {
        self.slots[c]
            .iter()
            .map(|s| match *s {
                Slot::Fitted(k) => params.get(k).copied().unwrap_or(f64::NAN),
                Slot::Fixed(v) => v,
            })
            .collect()
    }

    /// The fitted vector with every condition's copy of a parameter at the same value:
    /// `compact` holds the effects' parameters (`effects::specs` order).
    pub fn expand(&self, compact: &[f64]) -> Vec<f64> {
        self.compact.iter().map(|&k| compact[k]).collect()
    }

    /// The fitted elements of this layout's effects from those of the same effects without
    /// the one at `missing` (`rest`, in their own layout's order, which is this one's with
    /// `missing`'s elements taken out) and `missing`'s compact parameters from `compact` (the
    /// effects' parameters in [`super::effects::specs`] order; the others' entries unread).
    /// `None` when `rest` does not have the elements the others need, exactly.
    pub fn with_effect(&self, missing: usize, rest: &[f64], compact: &[f64]) -> Option<Vec<f64>> {
        let mut rest = rest.iter();
        let out = (0..self.len())
            .map(|k| {
                if self.effect[k] == missing {
                    compact.get(self.compact[k]).copied()
                } else {
                    rest.next().copied()
                }
            })
            .collect::<Option<Vec<f64>>>()?;
        rest.next().is_none().then_some(out)
    }

    /// The bounds of the fitted elements.
    pub fn bounds(&self) -> (Vec<f64>, Vec<f64>) {
        (
            self.specs.iter().map(|p| p.lo).collect(),
            self.specs.iter().map(|p| p.hi).collect(),
        )
    }

    /// `params` with the elements of condition `c` (fitted on the others, which do not
    /// constrain them) replaced by what the others say of the same parameter, or "no effect"
    /// when no other condition has one. The prediction of a condition left out.
    ///
    /// What the others say: their copies' common value, each weighted by its inverse variance
    /// (`se`, the elements' standard errors; the maximum-likelihood common value of copies
    /// with independent errors), or their plain mean where some copy has no finite positive
    /// error or `se` is `None`: a copy its condition hardly determines would otherwise move
    /// every other condition's prediction as much as a well-measured one
    /// ([docs/decisions/ranking-rules.md](../../docs/decisions/ranking-rules.md#a-condition-left-out-its-equipment-as-the-others-copies-weigh)).
    pub fn predicting(&self, params: &[f64], c: usize, se: Option<&[f64]>) -> Vec<f64> {
        let mut out = params.to_vec();
        for k in self.own(c) {
            out[k] = self
                .mean_of_copies(params, se, self.compact[k], Some(c))
                .unwrap_or(self.specs[k].none);
        }
        out
    }

    /// The effects' parameters (`effects::specs` order) in a condition not yet ridden: a shared
    /// parameter's value, an equipment parameter at the mean of its fitted copies (the
    /// condition's own equipment as the others' is), "no effect" where no condition has one.
    pub fn new_condition(&self, params: &[f64], compact_len: usize) -> Vec<f64> {
        (0..compact_len)
            .map(|k| {
                self.mean_of_copies(params, None, k, None)
                    .unwrap_or_else(|| {
                        // No fitted copy: every condition holds it at "no effect".
                        match self.slots.first().and_then(|s| s.get(k)) {
                            Some(Slot::Fixed(v)) => *v,
                            _ => f64::NAN,
                        }
                    })
            })
            .collect()
    }

    /// The mean of the fitted copies of the effects' parameter `compact` outside condition
    /// `except`, weighted by their inverse variances where `se` gives every one of them a
    /// finite positive error ([`Layout::predicting`]); `None` when there is none.
    fn mean_of_copies(
        &self,
        params: &[f64],
        se: Option<&[f64]>,
        compact: usize,
        except: Option<usize>,
    ) -> Option<f64> {
        let copies: Vec<usize> = (0..self.len())
            .filter(|&j| {
                self.compact[j] == compact && (except.is_none() || self.condition[j] != except)
            })
            .collect();
        if copies.is_empty() {
            return None;
        }
        let errors: Option<Vec<f64>> = se.and_then(|se| {
            copies
                .iter()
                .map(|&j| se.get(j).copied().filter(|s| s.is_finite() && *s > 0.0))
                .collect()
        });
        Some(match errors {
            Some(errors) => {
                super::observe::weighted_mean(copies.iter().map(|&j| params[j]).zip(errors)).value
            }
            None => copies.iter().map(|&j| params[j]).sum::<f64>() / copies.len() as f64,
        })
    }

    /// The fitted elements that condition `c`'s rides do not see (its own copies of the
    /// equipment effects), which a fit without them leaves where they are.
    pub fn own(&self, c: usize) -> Vec<usize> {
        (0..self.len())
            .filter(|&k| self.condition[k] == Some(c))
            .collect()
    }
}

/// The parameters of `effects` ([`super::effects::specs`] order) on the bicycle of
/// `conditions`: the library's, but for an effect of the steer motor itself where a condition
/// declares the motor ([`super::effects::Definition::of_declared_motor`]).
pub fn specs_of(effects: &[Effect], conditions: &[ConditionModel]) -> Vec<ParamSpec> {
    let motor = conditions.iter().find_map(|c| c.steer_motor);
    effects
        .iter()
        .flat_map(|&e| {
            let declared = e.definition().of_declared_motor.zip(motor);
            e.params().iter().map(move |&spec| match declared {
                Some((of, m)) => of(spec, &m),
                None => spec,
            })
        })
        .collect()
}

/// The effects of the library that a study of `conditions` can fit: the steer motor's only
/// where a condition carries a controller (its rotor's inertia also where a condition declares
/// the motor: powered or not, it turns with the steer), an equipment effect only where it
/// acts on some condition.
pub fn library(conditions: &[ConditionModel]) -> Vec<Effect> {
    let controlled = conditions.iter().any(|c| !c.control.is_none());
    let motor = conditions.iter().any(|c| c.steer_motor.is_some());
    Effect::library(controlled, motor)
        .into_iter()
        .filter(|&e| {
            conditions.len() < 2 || !e.per_condition() || conditions.iter().any(|c| c.acts(e))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn condition(name: &str, controlled: bool, read: bool) -> ConditionModel {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/reference/bicycleparameters/BenchmarkBenchmark.txt");
        let control = if controlled {
            let spec = crate::model::control::ControllerSpec {
                description: String::new(),
                speeds_mps: vec![0.0],
                roll_nm_per_rad: None,
                steer_nm_per_rad: None,
                roll_rate_nms_per_rad: Some(vec![10.0]),
                steer_rate_nms_per_rad: None,
            };
            SteerControl::from_spec(&spec, &path).unwrap()
        } else {
            SteerControl::NONE
        };
        ConditionModel {
            name: name.into(),
            base: Benchmark::load(&path).unwrap(),
            control,
            steer_motor: None,
            read_speeds: read,
        }
    }

    /// A condition left out takes its equipment's parameter from the others' copies weighted
    /// by their inverse variances: copies 0.5 ± 0.1 and 0.9 ± 0.3 say
    /// (0.5/0.01 + 0.9/0.09) / (1/0.01 + 1/0.09) = 0.54; without errors, their mean 0.7.
    #[test]
    fn a_condition_left_out_takes_the_others_copies_by_their_errors() {
        let conds = [
            condition("u", false, true),
            condition("g1", true, true),
            condition("g2", true, true),
            condition("g3", true, true),
        ];
        let l = Layout::new(&[Effect::ActuatorGain], &conds);
        assert_eq!(l.condition, vec![Some(1), Some(2), Some(3)]);
        let p = [0.5, 0.9, 0.8];
        let weighted = l.predicting(&p, 3, Some(&[0.1, 0.3, 0.2]));
        assert!(
            (weighted[2] - 60.0 / (100.0 + 1.0 / 0.09)).abs() < 1e-12,
            "{weighted:?}"
        );
        assert_eq!(&weighted[..2], &p[..2]);
        assert!((l.predicting(&p, 3, None)[2] - 0.7).abs() < 1e-12);
        // A copy without a finite error: the plain mean.
        let unweighted = l.predicting(&p, 3, Some(&[0.1, f64::NAN, 0.2]));
        assert!((unweighted[2] - 0.7).abs() < 1e-12);
    }

    /// Uncontrolled, then two gains: the actuator's gain is fitted twice (once per controller)
    /// and fixed at 1 without one; the trail once for all; predicting the second gain from the
    /// others takes the first gain's value.
    #[test]
    fn equipment_per_condition_bicycle_shared() {
        let conds = [
            condition("u", false, true),
            condition("g6", true, true),
            condition("g8", true, true),
        ];
        let l = Layout::new(&[Effect::Trail, Effect::ActuatorGain], &conds);
        assert_eq!(l.len(), 3);
        assert_eq!(l.condition, vec![None, Some(1), Some(2)]);
        let p = [1.1, 0.6, 0.8];
        assert_eq!(l.condition_params(&p, 0), vec![1.1, 1.0]);
        assert_eq!(l.condition_params(&p, 1), vec![1.1, 0.6]);
        assert_eq!(l.condition_params(&p, 2), vec![1.1, 0.8]);
        assert_eq!(l.predicting(&p, 2, None), vec![1.1, 0.6, 0.6]);
        assert_eq!(l.predicting(&p, 0, None), p.to_vec());
        assert_eq!(l.expand(&[1.2, 0.7]), vec![1.2, 0.7, 0.7]);
        // A pair's fit with the third effect inserted: the trail and the damper kept in order,
        // the actuator's gain at its compact value in each controlled condition.
        let t = Layout::new(
            &[Effect::SteerDamping, Effect::Trail, Effect::ActuatorGain],
            &conds,
        );
        assert_eq!(
            t.with_effect(2, &[0.3, 1.1], &[0.0, 0.0, 0.7]),
            Some(vec![0.3, 1.1, 0.7, 0.7])
        );
        assert_eq!(
            t.with_effect(0, &[1.1, 0.6, 0.8], &[0.4, 0.0, 0.0]),
            Some(vec![0.4, 1.1, 0.6, 0.8])
        );
        assert_eq!(t.with_effect(2, &[0.3], &[0.0, 0.0, 0.7]), None);
        assert_eq!(t.with_effect(2, &[0.3, 1.1, 0.9], &[0.0, 0.0, 0.7]), None);
        assert_eq!(l.own(1), vec![1]);
        // One condition: the library's parameters, once each.
        let one = Layout::new(&[Effect::Trail, Effect::ActuatorGain], &conds[1..2]);
        assert_eq!(one.len(), 2);
        assert_eq!(one.condition, vec![None, None]);
        // No read speed anywhere: no speedometer in a study.
        let unread = [condition("a", false, false), condition("b", true, false)];
        assert!(!library(&unread).contains(&Effect::SpeedScale));
        assert!(library(&unread).contains(&Effect::ActuatorGain));
    }
}
