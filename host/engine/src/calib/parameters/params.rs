//! The free parameters of a calibration: a typed key per quantity the fit may
//! correct, and [`ParamVector`], the one registry of their values.
//!
//! The model fixes the paper's 43 error parameters ([`model::ParamId`], fields
//! of the arm). A calibration may correct more than that: a tool point per
//! measured target, the base pose in the tracker's frame, servo curve knots,
//! backlash widths. [`ParamKey`] is the host's name for any of them: the
//! arm's own parameters ([`ParamKey::Arm`]), the tool points of further
//! measured targets ([`ParamKey::TargetTool`], see `calib::targets`), the
//! knots of the servo curves ([`ParamKey::ServoKnot`], see
//! `calib::servo_knots`) and the joints' backlash ([`ParamKey::Backlash`]).
//! A new kind is one variant here with its stable name, its kind and the
//! quantity it corrects in a [`Rig`]; the registry, the solver and the files
//! take it as it is.
//!
//! [`ParamVector`] keeps its keys in the order given (the solver's column
//! order), finds a key through a sorted index (never by position), knows which
//! keys are held fixed, and applies its values in one way: each is a
//! correction *added* to the quantity its key names, nothing clamped. Keeping
//! a value physical (a compliance at or above zero) is the fit's job, which
//! fixes such a parameter at its bound.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fmt;

pub use lrmcal_core::param_key::ParamKey;

use crate::calib::parameters::targets::Rig;

/// What [`ParamVector`] needs of a key: an order for its index, a stable
/// name, and the quantity it corrects in the model it applies to.
pub trait Key: Copy + Ord + fmt::Debug {
    /// What the corrections are applied to.
    type Model: Clone;
    /// The stable name written in files (`j2.theta`, `k0`, …).
    fn name(self) -> Cow<'static, str>;
    /// The current value of the quantity this key corrects.
    fn value(self, model: &Self::Model) -> f64;
    /// The quantity this key corrects.
    fn slot(self, model: &mut Self::Model) -> &mut f64;
}

impl Key for ParamKey {
    type Model = Rig;

    fn name(self) -> Cow<'static, str> {
        ParamKey::name(self)
    }

    /// The current value of the quantity in `rig`.
    fn value(self, rig: &Rig) -> f64 {
        match self {
            Self::Arm(id) => id.value(&rig.arm),
            Self::TargetTool { target, axis } => rig
                .tool_point(usize::from(target))
                .map_or(f64::NAN, |p| p[usize::from(axis)]),
            Self::ServoKnot { joint, knot } => {
                let curve = rig.arm.joints[usize::from(joint)].servo.as_ref();
                curve
                    .and_then(|curve| {
                        crate::calib::parameters::servo_knots::curve_index(curve, usize::from(knot))
                            .and_then(|i| curve.angles_rad().get(i).copied())
                    })
                    .unwrap_or(f64::NAN)
            }
            Self::Backlash { joint } => rig.arm.joints[usize::from(joint)].backlash,
            Self::Softening { spring: 0 } => rig.arm.base_softening,
            Self::Softening { spring } => rig.arm.joints[usize::from(spring) - 1].softening,
            Self::Lens { field } => rig
                .camera
                .as_ref()
                .and_then(|c| c.lens)
                .map_or(f64::NAN, |e| e[usize::from(field)]),
        }
    }

    /// The quantity in `rig` this key corrects.
    ///
    /// # Panics
    /// For a target the rig does not have (keys are made for their rig,
    /// `Rig::tool_keys`, `RigCamera::lens_keys`), or a servo knot its curve does not have (the fit
    /// puts every curve on the knots it identifies first,
    /// `calib::servo_knots::fit_start`): a bug of the caller either way.
    fn slot(self, rig: &mut Rig) -> &mut f64 {
        match self {
            Self::Arm(id) => id.value_mut(&mut rig.arm),
            Self::TargetTool { target, axis } => {
                &mut rig.tools[usize::from(target) - 1][usize::from(axis)]
            }
            Self::ServoKnot { joint, knot } => {
                let curve = rig.arm.joints[usize::from(joint)]
                    .servo
                    .as_mut()
                    .expect("a joint's knots are keys only where it has a curve");
                let i =
                    crate::calib::parameters::servo_knots::curve_index(curve, usize::from(knot))
                        .expect("the fit puts the curve on its knots' grid first");
                &mut curve.angles_rad_mut()[i]
            }
            Self::Backlash { joint } => &mut rig.arm.joints[usize::from(joint)].backlash,
            Self::Softening { spring: 0 } => &mut rig.arm.base_softening,
            Self::Softening { spring } => &mut rig.arm.joints[usize::from(spring) - 1].softening,
            Self::Lens { field } => &mut rig
                .camera
                .as_mut()
                .and_then(|c| c.lens.as_mut())
                .expect("lens keys are made for a camera refining its lens")[usize::from(field)],
        }
    }
}

/// Why a parameter vector cannot be built or changed as asked.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ParamError {
    /// A key given twice.
    #[error("parameter `{0}` appears twice")]
    Duplicate(String),
    /// A key the vector does not hold.
    #[error("parameter `{0}` is not one of the parameters being fitted")]
    Absent(String),
}

/// One parameter of a [`ParamVector`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Param<K> {
    /// Which quantity.
    pub key: K,
    /// The correction added to its nominal value, SI units.
    pub error: f64,
    /// Whether the fit holds it where it is.
    pub fixed: bool,
}

/// The registry of free parameters: ordered keys, their corrections, and
/// which are fixed. See the module docs.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamVector<K: Key = ParamKey> {
    params: Vec<Param<K>>,
    index: BTreeMap<K, usize>,
}

impl<K: Key> ParamVector<K> {
    /// `keys` in this order, every correction zero and free.
    pub fn new(keys: impl IntoIterator<Item = K>) -> Result<Self, ParamError> {
        let mut v = Self {
            params: Vec::new(),
            index: BTreeMap::new(),
        };
        for key in keys {
            v.push(key, 0.0)?;
        }
        Ok(v)
    }

    fn push(&mut self, key: K, error: f64) -> Result<(), ParamError> {
        if self.index.insert(key, self.params.len()).is_some() {
            return Err(ParamError::Duplicate(key.name().into_owned()));
        }
        self.params.push(Param {
            key,
            error,
            fixed: false,
        });
        Ok(())
    }

    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.params.len()
    }

    /// Whether there is no parameter.
    pub fn is_empty(&self) -> bool {
        self.params.is_empty()
    }

    /// Every parameter in order.
    pub fn iter(&self) -> impl Iterator<Item = Param<K>> + '_ {
        self.params.iter().copied()
    }

    /// The parameter `key`, if the vector holds it.
    pub fn get(&self, key: K) -> Option<Param<K>> {
        self.index.get(&key).map(|&i| self.params[i])
    }

    fn entry(&mut self, key: K) -> Result<&mut Param<K>, ParamError> {
        match self.index.get(&key) {
            Some(&i) => Ok(&mut self.params[i]),
            None => Err(ParamError::Absent(key.name().into_owned())),
        }
    }

    /// Sets the correction of `key`.
    pub fn set(&mut self, key: K, error: f64) -> Result<(), ParamError> {
        self.entry(key)?.error = error;
        Ok(())
    }

    /// Holds `key` at the correction `error`.
    pub fn fix(&mut self, key: K, error: f64) -> Result<(), ParamError> {
        let p = self.entry(key)?;
        p.error = error;
        p.fixed = true;
        Ok(())
    }

    /// Lets the fit move `key` again, from where it is.
    pub fn release(&mut self, key: K) -> Result<(), ParamError> {
        self.entry(key)?.fixed = false;
        Ok(())
    }

    /// The free keys, in order: the solver's columns.
    pub fn free(&self) -> impl Iterator<Item = K> + '_ {
        self.params.iter().filter(|p| !p.fixed).map(|p| p.key)
    }

    /// The fixed keys, in order.
    pub fn fixed(&self) -> impl Iterator<Item = K> + '_ {
        self.params.iter().filter(|p| p.fixed).map(|p| p.key)
    }

    /// The free corrections, in [`ParamVector::free`] order.
    pub fn free_errors(&self) -> Vec<f64> {
        self.params
            .iter()
            .filter(|p| !p.fixed)
            .map(|p| p.error)
            .collect()
    }

    /// Sets the free corrections from `values`, in [`ParamVector::free`] order.
    pub fn set_free(&mut self, values: &[f64]) {
        debug_assert_eq!(values.len(), self.free().count());
        for (p, v) in self.params.iter_mut().filter(|p| !p.fixed).zip(values) {
            p.error = *v;
        }
    }

    /// `model` with every correction added to the quantity its key names.
    pub fn apply(&self, model: &K::Model) -> K::Model {
        let mut out = model.clone();
        for p in &self.params {
            *p.key.slot(&mut out) += p.error;
        }
        out
    }

    /// [`ParamVector::apply`] with the free corrections taken from `free`
    /// (in [`ParamVector::free`] order) instead: the model at a solver's trial point.
    pub fn apply_with_free(&self, model: &K::Model, free: &[f64]) -> K::Model {
        debug_assert_eq!(free.len(), self.free().count());
        let mut out = model.clone();
        let mut trial = free.iter();
        for p in &self.params {
            let error = if p.fixed {
                p.error
            } else {
                trial.next().copied().unwrap_or(p.error)
            };
            *p.key.slot(&mut out) += error;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::testing::{key, rigid_nominal};
    use model::bounds::{Bounds, Quantity};
    use model::params::ParamKind;
    use model::testing::TEST_ARM_JOINTS as JOINTS;
    use model::{Arm, ParamId};

    #[test]
    fn keys_carry_the_model_names_and_kinds() {
        for id in ParamId::all(6) {
            let k = ParamKey::from(id);
            assert_eq!(ParamKey::from_name(&k.name()), Some(k));
            assert_eq!(k.kind(), id.kind());
            assert_eq!(k.quantity().is_some(), !id.is_geometric());
        }
        assert_eq!(ParamKey::from_name("j11.d"), None);
        assert!(!ParamKey::from_name("j7.d").unwrap().fits(6));
        let knot = ParamKey::ServoKnot { joint: 2, knot: 4 };
        assert_eq!(knot.name(), "j3.servo[5]");
        assert_eq!(ParamKey::from_name("j3.servo[5]"), Some(knot));
        assert_eq!(knot.kind(), ParamKind::Angle);
        let bounds = Bounds::of(&rigid_nominal());
        assert_eq!(knot.fit_range(&bounds), (None, None));
        let play = ParamKey::Backlash { joint: 5 };
        let (lo, hi) = play.fit_range(&bounds);
        assert_eq!(lo, Some(0.0));
        // The widest play the fit may reach survives the board's f32 check.
        let widest = f64::from(hi.unwrap() as f32);
        assert!(
            widest <= model::bounds::MAX_BACKLASH_RAD
                && widest > 0.99 * model::bounds::MAX_BACKLASH_RAD
        );
        assert_eq!(
            ParamKey::from_name("k0").unwrap().quantity(),
            Some(Quantity::Compliance { spring: 0 })
        );
        assert_eq!(
            ParamKey::from_name("k4").unwrap().quantity(),
            Some(Quantity::Compliance { spring: 4 })
        );
        // A knot counts on the finest grid: on a 9-knot curve it is the
        // curve's own, on a 5-knot one every second of them.
        let mut rig = Rig::from(rigid_nominal());
        let nine: Vec<f64> = (0..9).map(|k| (k as f64 - 4.0) * 0.25).collect();
        rig.arm.joints[2].servo = rig.arm.joints[2].servo.map(|c| c.resampled(&nine).unwrap());
        assert_eq!(knot.value(&rig), 0.0);
        *knot.slot(&mut rig) += 0.01;
        assert_eq!(rig.arm.joints[2].servo.unwrap().angles_rad()[4], 0.01);
        rig.arm.joints[2].servo = rig.arm.joints[2]
            .servo
            .map(|c| c.resampled(&[-1.0, -0.5, 0.0, 0.5, 1.0]).unwrap());
        let last = ParamKey::ServoKnot { joint: 2, knot: 8 };
        assert_eq!(last.value(&rig), 1.0);
        *last.slot(&mut rig) += 0.01;
        assert_eq!(rig.arm.joints[2].servo.unwrap().angles_rad()[4], 1.01);
        assert!(
            ParamKey::ServoKnot { joint: 2, knot: 3 }
                .value(&rig)
                .is_nan()
        );
        let play = ParamKey::Backlash { joint: 5 };
        assert_eq!(play.name(), "j6.backlash");
        assert_eq!(ParamKey::from_name("j6.backlash"), Some(play));
        assert_eq!(play.kind(), ParamKind::Angle);
        *play.slot(&mut rig) += 0.004;
        assert_eq!(play.value(&rig), 0.004);
        assert_eq!(key("k0").to_string(), "k0");
    }

    /// Lookups are by key: a subset in any order finds exactly its own keys,
    /// and a key it does not hold is refused, not read from another slot.
    #[test]
    fn lookup_is_exact_and_apply_adds_without_clamping() {
        let mut v = ParamVector::new([key("k3"), key("j2.a"), key("tool.z")]).unwrap();
        v.set(key("j2.a"), 0.002).unwrap();
        v.fix(key("k3"), -0.5).unwrap();
        assert_eq!(v.get(key("j2.a")).map(|p| p.error), Some(0.002));
        assert_eq!(v.get(key("j1.theta")), None);
        assert_eq!(
            v.set(key("j1.theta"), 1.0),
            Err(ParamError::Absent("j1.theta".into()))
        );
        assert_eq!(v.free().collect::<Vec<_>>(), [key("j2.a"), key("tool.z")]);
        assert_eq!(v.fixed().collect::<Vec<_>>(), [key("k3")]);

        let rig = Rig::from(rigid_nominal());
        let nominal = rig.arm;
        let arm = v.apply(&rig).arm;
        assert_eq!(arm.joints[1].a, nominal.joints[1].a + 0.002);
        // One meaning: a correction is added as it is, even to an unphysical value.
        assert_eq!(arm.joints[2].compliance, nominal.joints[2].compliance - 0.5);
        assert_eq!(arm.joints[0], nominal.joints[0]);
        let trial = v.apply_with_free(&rig, &[0.001, 0.003]).arm;
        assert_eq!(trial.joints[1].a, nominal.joints[1].a + 0.001);
        assert_eq!(trial.tool.xyz[2], nominal.tool.xyz[2] + 0.003);
        assert_eq!(trial.joints[2].compliance, arm.joints[2].compliance);
        v.set_free(&[0.001, 0.003]);
        assert_eq!(v.apply(&rig).arm, trial);
        v.release(key("k3")).unwrap();
        assert_eq!(v.free_errors(), [-0.5, 0.001, 0.003]);
    }

    #[test]
    fn a_key_given_twice_is_refused_by_name() {
        assert_eq!(
            ParamVector::new([key("k1"), key("base.x"), key("k1")]),
            Err(ParamError::Duplicate("k1".into()))
        );
    }

    /// A model with more to correct than the arm: the arm and a backlash width
    /// per joint, as a coming calibration will have.
    #[derive(Clone, Debug, PartialEq)]
    struct BacklashRig {
        arm: Arm<f64>,
        backlash_rad: [f64; JOINTS],
    }

    #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
    enum RigKey {
        Arm(ParamId),
        Backlash(usize),
    }

    impl Key for RigKey {
        type Model = BacklashRig;
        fn name(self) -> Cow<'static, str> {
            match self {
                Self::Arm(id) => Cow::Borrowed(id.name()),
                Self::Backlash(j) => Cow::Owned(format!("j{}.backlash", j + 1)),
            }
        }
        fn value(self, rig: &BacklashRig) -> f64 {
            match self {
                Self::Arm(id) => id.value(&rig.arm),
                Self::Backlash(j) => rig.backlash_rad[j],
            }
        }
        fn slot(self, rig: &mut BacklashRig) -> &mut f64 {
            match self {
                Self::Arm(id) => id.value_mut(&mut rig.arm),
                Self::Backlash(j) => &mut rig.backlash_rad[j],
            }
        }
    }

    /// The registry is not tied to the model's 43 parameters: it holds, looks
    /// up, applies, exports and imports the 43 plus six more.
    #[test]
    fn the_registry_holds_parameters_beyond_the_43() {
        let keys = ParamId::all(6)
            .map(RigKey::Arm)
            .chain((0..JOINTS).map(RigKey::Backlash));
        let mut v = ParamVector::new(keys).unwrap();
        assert_eq!(v.len(), model::param_count(6) + 6);
        v.set(RigKey::Backlash(2), 0.01).unwrap();
        v.set(RigKey::Arm(ParamId::from_name("k3").unwrap()), 0.05)
            .unwrap();
        let nominal = BacklashRig {
            arm: rigid_nominal(),
            backlash_rad: [0.002; JOINTS],
        };
        let rig = v.apply(&nominal);
        assert_eq!(rig.backlash_rad[2], 0.012);
        assert_eq!(rig.backlash_rad[3], 0.002);
        assert_eq!(rig.arm.joints[2].compliance, 0.05);
        assert_eq!(
            v.get(RigKey::Backlash(2)).map(|p| p.key.name()),
            Some("j3.backlash".into())
        );
    }
}
