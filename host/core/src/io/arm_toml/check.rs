//! The arm file's tables made into its description, every value checked
//! against its allowed range, each refusal naming the key path, the line
//! and what was expected.

use std::ops::Range;

use model::servo::{CurveFault, MAX_KNOTS, PULSE_RANGE_US};
use model::{Arm, Frame, MAX_JOINTS, PerJoint, ServoCurve};
use toml::{Spanned, Value};

use super::raw::*;
use super::{ArmDescription, LineIndex};
use crate::collision::{
    BodySet, BodySpec, CollisionSpec, Floor, FrameRef, PointSpec, ShapeSpec, SpecError, SpecPlace,
};
use crate::error::{InputError, Location, Problem};
use model::{Joint, JointKind};

/// What a point of a body may be written as, for messages.
pub(super) const POINT_FORMS: &str =
    "a frame name (base, j0 … j6, tool) or { frame = NAME, xyz = [x, y, z] } in m";

/// Checks values against their allowed ranges, reporting key path and line.
pub(super) struct Checker<'a> {
    pub(super) lines: &'a LineIndex,
}

impl Checker<'_> {
    pub(super) fn fail(&self, key: &str, span: Range<usize>, problem: Problem) -> InputError {
        InputError::new(Location::key(self.lines.span_line(span), key), problem)
    }

    pub(super) fn finite(&self, key: &str, value: &Spanned<f64>) -> Result<f64, InputError> {
        let v = *value.get_ref();
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.fail(
                key,
                value.span(),
                Problem::NotFinite {
                    found: v.to_string(),
                },
            ))
        }
    }

    pub(super) fn finite_array<const N: usize>(
        &self,
        key: &str,
        value: &Spanned<[f64; N]>,
    ) -> Result<[f64; N], InputError> {
        let v = *value.get_ref();
        match v.iter().position(|x| !x.is_finite()) {
            None => Ok(v),
            Some(i) => Err(self.fail(
                &format!("{key}[{}]", i + 1),
                value.span(),
                Problem::NotFinite {
                    found: v[i].to_string(),
                },
            )),
        }
    }

    pub(super) fn non_negative(
        &self,
        key: &str,
        value: &Spanned<f64>,
        expected: &'static str,
    ) -> Result<f64, InputError> {
        let v = self.finite(key, value)?;
        if v >= 0.0 {
            Ok(v)
        } else {
            Err(self.fail(
                key,
                value.span(),
                Problem::OutOfRange {
                    expected,
                    found: v.to_string(),
                },
            ))
        }
    }

    pub(super) fn frame(
        &self,
        key: &str,
        xyz: &Spanned<[f64; 3]>,
        rpy: &Spanned<[f64; 3]>,
    ) -> Result<Frame<f64>, InputError> {
        Ok(Frame {
            xyz: self.finite_array(&format!("{key}.xyz"), xyz)?,
            rpy: self.finite_array(&format!("{key}.rpy"), rpy)?,
        })
    }

    pub(super) fn joint(&self, key: &str, raw: &RawJoint) -> Result<Joint<f64>, InputError> {
        let k = |field: &str| format!("{key}.{field}");
        let limits = self.finite_array(&k("limits"), &raw.limits)?;
        if limits[0] >= limits[1] {
            return Err(self.fail(
                &k("limits"),
                raw.limits.span(),
                Problem::OutOfRange {
                    expected: "limits [lo, hi] in rad with lo < hi",
                    found: format!("[{}, {}]", limits[0], limits[1]),
                },
            ));
        }
        let servo = match &raw.servo {
            Some(servo) => Some(self.servo(&k("servo"), servo)?),
            None => None,
        };
        Ok(Joint {
            theta: self.finite(&k("theta"), &raw.theta)?,
            d: self.finite(&k("d"), &raw.d)?,
            a: self.finite(&k("a"), &raw.a)?,
            alpha: self.finite(&k("alpha"), &raw.alpha)?,
            // A nominal arm is DH: Hayati's twist is found by calibration.
            beta: 0.0,
            kind: raw.kind,
            compliance: self.non_negative(
                &k("compliance"),
                &raw.compliance,
                match raw.kind {
                    JointKind::Revolute => "a compliance >= 0 rad/Nm",
                    JointKind::Prismatic => "a compliance >= 0 m/N",
                },
            )?,
            limits,
            mass: self.non_negative(&k("mass"), &raw.mass, "a mass >= 0 kg")?,
            com: self.finite_array(&k("com"), &raw.com)?,
            servo,
            // Play and softening are found by calibration, not described.
            backlash: 0.0,
            softening: 0.0,
        })
    }
}

/// The collision description's parts (`[collision]`, `[[body]]`).
impl Checker<'_> {
    pub(super) fn frame_ref(
        &self,
        key: &str,
        name: &Spanned<String>,
    ) -> Result<FrameRef, InputError> {
        name.get_ref()
            .parse()
            .map_err(|message| self.fail(key, name.span(), Problem::Invalid { message }))
    }

    /// A body's point: a frame name, or a table with `frame` and `xyz`.
    pub(super) fn point(&self, key: &str, value: &Spanned<Value>) -> Result<PointSpec, InputError> {
        let wrong = |found: &str| {
            self.fail(
                key,
                value.span(),
                Problem::Invalid {
                    message: format!("expected {POINT_FORMS}, found {found}"),
                },
            )
        };
        let named = |name: &str| {
            name.parse::<FrameRef>()
                .map_err(|message| self.fail(key, value.span(), Problem::Invalid { message }))
        };
        match value.get_ref() {
            Value::String(name) => Ok(PointSpec::origin(named(name)?)),
            Value::Table(table) => {
                if let Some(other) = table.keys().find(|k| *k != "frame" && *k != "xyz") {
                    return Err(wrong(&format!("the key `{other}`")));
                }
                let frame = match table.get("frame") {
                    Some(Value::String(name)) => named(name)?,
                    _ => return Err(wrong("a table without a `frame` name")),
                };
                let xyz = match table.get("xyz") {
                    Some(Value::Array(xyz)) if xyz.len() == 3 => {
                        let mut out = [0.0; 3];
                        for (o, v) in out.iter_mut().zip(xyz) {
                            *o = match v {
                                Value::Float(x) if x.is_finite() => *x,
                                Value::Integer(i) => *i as f64,
                                other => return Err(wrong(&format!("`xyz` holding {other}"))),
                            };
                        }
                        out
                    }
                    _ => return Err(wrong("a table without an `xyz` of three numbers")),
                };
                Ok(PointSpec { frame, xyz_m: xyz })
            }
            other => Err(wrong(&other.to_string())),
        }
    }

    pub(super) fn body(&self, key: &str, raw: &Spanned<RawBody>) -> Result<BodySpec, InputError> {
        let b = raw.get_ref();
        let k = |field: &str| format!("{key}.{field}");
        let shape = match (&b.capsule, &b.cuboid) {
            (Some(c), None) => {
                let c = c.get_ref();
                ShapeSpec::Capsule {
                    from: self.point(&k("capsule.from"), &c.from)?,
                    to: self.point(&k("capsule.to"), &c.to)?,
                    radius_m: self.non_negative(
                        &k("capsule.radius"),
                        &c.radius,
                        "a radius >= 0 m",
                    )?,
                }
            }
            (None, Some(bx)) => {
                let bx = bx.get_ref();
                ShapeSpec::Box {
                    frame: self.frame_ref(&k("box.frame"), &bx.frame)?,
                    min_m: self.finite_array(&k("box.min"), &bx.min)?,
                    max_m: self.finite_array(&k("box.max"), &bx.max)?,
                }
            }
            _ => {
                return Err(self.fail(
                    key,
                    raw.span(),
                    Problem::Invalid {
                        message: "expected exactly one of `capsule = { from, to, radius }` or `box = { frame, min, max }`".into(),
                    },
                ));
            }
        };
        Ok(BodySpec {
            name: b.name.clone(),
            shape,
            floor: b.floor,
        })
    }

    pub(super) fn floor(&self, value: &Spanned<Value>) -> Result<Floor, InputError> {
        match value.get_ref() {
            Value::Float(z) if z.is_finite() => Ok(Floor::At { z_m: *z }),
            Value::Integer(z) => Ok(Floor::At { z_m: *z as f64 }),
            Value::Boolean(false) => Ok(Floor::Off),
            other => Err(self.fail(
                "collision.floor",
                value.span(),
                Problem::Invalid {
                    message: format!(
                        "expected the floor's height in the world frame in m, or false for no floor, found {other}"
                    ),
                },
            )),
        }
    }

    pub(super) fn collision(
        &self,
        raw: Option<&RawCollision>,
        bodies: &[Spanned<RawBody>],
    ) -> Result<CollisionSpec, InputError> {
        let mut spec = CollisionSpec::default();
        if let Some(c) = raw {
            if let Some(clearance) = &c.clearance {
                spec.clearance_m = Some(self.non_negative(
                    "collision.clearance",
                    clearance,
                    "a clearance >= 0 m",
                )?);
            }
            if let Some(floor) = &c.floor {
                spec.floor = self.floor(floor)?;
            }
            if let Some(radius) = &c.radius {
                spec.skeleton_radius_m =
                    Some(self.non_negative("collision.radius", radius, "a radius >= 0 m")?);
            }
            spec.ignore = c.ignore.iter().map(|p| p.get_ref().clone()).collect();
        }
        for (i, raw) in bodies.iter().enumerate() {
            spec.bodies
                .push(self.body(&format!("body[{}]", i + 1), raw)?);
        }
        Ok(spec)
    }

    /// A [`SpecError`] of the planner at its key, on the line of the table or value it concerns.
    pub(super) fn spec_error(
        &self,
        e: SpecError,
        raw: Option<&RawCollision>,
        bodies: &[Spanned<RawBody>],
    ) -> InputError {
        let span = match e.place {
            SpecPlace::Body { index, key } => bodies.get(index).map(|b| {
                let c = b.get_ref().capsule.as_ref();
                let cuboid = b.get_ref().cuboid.as_ref();
                match key {
                    "capsule" => c.map_or(b.span(), Spanned::span),
                    "capsule.radius" => c.map_or(b.span(), |c| c.get_ref().radius.span()),
                    // A frame the arm does not have (`j7` on a six-joint arm).
                    "capsule.from" => c.map_or(b.span(), |c| c.get_ref().from.span()),
                    "capsule.to" => c.map_or(b.span(), |c| c.get_ref().to.span()),
                    "box" => cuboid.map_or(b.span(), Spanned::span),
                    "box.frame" => cuboid.map_or(b.span(), |x| x.get_ref().frame.span()),
                    _ => b.span(),
                }
            }),
            SpecPlace::Collision { key } => raw.and_then(|c| match key {
                "radius" => c.radius.as_ref().map(Spanned::span),
                "clearance" => c.clearance.as_ref().map(Spanned::span),
                _ => None,
            }),
            SpecPlace::Ignore { index } => raw.and_then(|c| c.ignore.get(index)).map(Spanned::span),
        };
        self.fail(
            &e.place.to_string(),
            span.unwrap_or(0..0),
            Problem::Invalid { message: e.message },
        )
    }
}

impl Checker<'_> {
    /// A joint's servo curve in either form, checked: finite, angles strictly
    /// increasing, pulses within [`PULSE_RANGE_US`] and strictly monotonic.
    pub(super) fn servo(
        &self,
        key: &str,
        raw: &Spanned<RawServo>,
    ) -> Result<ServoCurve<f64>, InputError> {
        let s = raw.get_ref();
        let fail = |key: &str, problem| self.fail(key, raw.span(), problem);
        let curve = match ([s.minus100, s.zero, s.plus100], &s.angles_deg, &s.pulses_us) {
            ([Some(m), Some(z), Some(p)], None, None) => self.three_points(key, raw, [m, z, p])?,
            ([None, None, None], Some(angles), Some(pulses)) => {
                self.knots(key, raw, angles, pulses)?
            }
            _ => {
                let given = [
                    ("minus100", s.minus100.is_some()),
                    ("zero", s.zero.is_some()),
                    ("plus100", s.plus100.is_some()),
                    ("angles_deg", s.angles_deg.is_some()),
                    ("pulses_us", s.pulses_us.is_some()),
                ];
                let given: Vec<&str> = given.iter().filter(|g| g.1).map(|g| g.0).collect();
                return Err(fail(
                    key,
                    Problem::OutOfRange {
                        expected: SERVO_FORMS,
                        found: format!("the keys {{ {} }}", given.join(", ")),
                    },
                ));
            }
        };
        let [lo, hi] = PULSE_RANGE_US.map(f64::from);
        if let Some(k) = curve
            .pulses_us()
            .iter()
            .position(|p| !(lo..=hi).contains(p))
        {
            let key = match s.pulses_us {
                Some(_) => format!("{key}.pulses_us[{}]", k + 1),
                None => key.to_owned(),
            };
            return Err(fail(
                &key,
                Problem::OutOfRange {
                    expected: "servo pulses within 500..=2500 µs, what a hobby servo accepts and the board sends",
                    found: format!("{} µs", curve.pulses_us()[k]),
                },
            ));
        }
        Ok(curve)
    }

    /// The three points of earlier files, checked as they always were.
    pub(super) fn three_points(
        &self,
        key: &str,
        raw: &Spanned<RawServo>,
        pulses: [f64; 3],
    ) -> Result<ServoCurve<f64>, InputError> {
        if let Some(bad) = pulses.iter().find(|p| !p.is_finite()) {
            return Err(self.fail(
                key,
                raw.span(),
                Problem::NotFinite {
                    found: bad.to_string(),
                },
            ));
        }
        let [m, z, p] = pulses;
        let curve = ServoCurve::from_three_points(m, z, p);
        if !curve.is_monotonic() {
            return Err(self.fail(key, raw.span(), Problem::OutOfRange {
                expected: "a monotonic servo curve, pulses (µs) strictly increasing or strictly decreasing from minus100 through zero to plus100",
                found: format!("{m} / {z} / {p}"),
            }));
        }
        Ok(curve)
    }

    /// `[plan] levels_deg`: at least one level, each finite, strictly
    /// increasing (a level given twice would repeat grid poses).
    pub(super) fn levels(&self, raw: &Spanned<Vec<f64>>) -> Result<Vec<f64>, InputError> {
        let key = "plan.levels_deg";
        let levels = raw.get_ref();
        if levels.is_empty() {
            return Err(self.fail(
                key,
                raw.span(),
                Problem::OutOfRange {
                    expected: "at least one grid level, degrees",
                    found: "[]".into(),
                },
            ));
        }
        if let Some(i) = levels.iter().position(|x| !x.is_finite()) {
            return Err(self.fail(
                &format!("{key}[{}]", i + 1),
                raw.span(),
                Problem::NotFinite {
                    found: levels[i].to_string(),
                },
            ));
        }
        if let Some(i) = levels.windows(2).position(|w| w[1] <= w[0]) {
            return Err(self.fail(
                &format!("{key}[{}]", i + 2),
                raw.span(),
                Problem::OutOfRange {
                    expected: "grid levels (°) strictly increasing, each above the one before",
                    found: format!("{} after {}", levels[i + 1], levels[i]),
                },
            ));
        }
        Ok(levels.clone())
    }

    /// The knots form: as many pulses as angles, 2 to 9 of them, and a curve
    /// that maps angle to pulse one-to-one.
    pub(super) fn knots(
        &self,
        key: &str,
        raw: &Spanned<RawServo>,
        angles_deg: &[f64],
        pulses_us: &[f64],
    ) -> Result<ServoCurve<f64>, InputError> {
        let fail = |field: String, expected, found| {
            self.fail(&field, raw.span(), Problem::OutOfRange { expected, found })
        };
        if !(2..=MAX_KNOTS).contains(&angles_deg.len()) {
            return Err(fail(
                format!("{key}.angles_deg"),
                "2 to 9 knots",
                format!("{} angles", angles_deg.len()),
            ));
        }
        if pulses_us.len() != angles_deg.len() {
            return Err(fail(
                format!("{key}.pulses_us"),
                "one pulse (µs) per angle of angles_deg",
                format!("{} pulses for {} angles", pulses_us.len(), angles_deg.len()),
            ));
        }
        let angles: Vec<f64> = angles_deg.iter().map(|a| a.to_radians()).collect();
        let curve = ServoCurve::new(&angles, pulses_us)
            .map_err(|e| fail(format!("{key}.angles_deg"), "2 to 9 knots", e.to_string()))?;
        match curve.check() {
            Ok(()) => Ok(curve),
            Err(CurveFault::NotFinite { knot }) => {
                let (field, value) = if angles_deg[knot].is_finite() {
                    ("pulses_us", pulses_us[knot])
                } else {
                    ("angles_deg", angles_deg[knot])
                };
                Err(self.fail(
                    &format!("{key}.{field}[{}]", knot + 1),
                    raw.span(),
                    Problem::NotFinite {
                        found: value.to_string(),
                    },
                ))
            }
            Err(CurveFault::TooFewKnots) => Err(fail(
                format!("{key}.angles_deg"),
                "2 to 9 knots",
                angles_deg.len().to_string(),
            )),
            Err(CurveFault::AnglesNotIncreasing { knot }) => Err(fail(
                format!("{key}.angles_deg[{}]", knot + 1),
                "knot angles (°) strictly increasing, each above the one before",
                format!("{} after {}", angles_deg[knot], angles_deg[knot - 1]),
            )),
            Err(CurveFault::PulsesNotMonotonic { knot }) => Err(fail(
                format!("{key}.pulses_us[{}]", knot + 1),
                "a monotonic servo curve, pulses (µs) strictly increasing or strictly decreasing with the angle",
                format!(
                    "{} then {} where the curve {} from {} to {}",
                    pulses_us[knot - 1],
                    pulses_us[knot],
                    if pulses_us[1] > pulses_us[0] {
                        "rises"
                    } else {
                        "falls"
                    },
                    pulses_us[0],
                    pulses_us[1]
                ),
            )),
        }
    }
}

/// The description the tables hold, every value checked.
impl RawArm {
    pub(super) fn check(self, lines: &LineIndex) -> Result<ArmDescription, InputError> {
        let c = Checker { lines };
        let raw_joints = self.joint.get_ref();
        if !(1..=MAX_JOINTS).contains(&raw_joints.len()) {
            return Err(c.fail(
                "joint",
                self.joint.span(),
                Problem::JointCount {
                    found: raw_joints.len(),
                },
            ));
        }
        let mut joints = Vec::with_capacity(raw_joints.len());
        for (i, raw) in raw_joints.iter().enumerate() {
            joints.push(c.joint(&format!("joint[{}]", i + 1), raw)?);
        }
        let arm = Arm {
            gravity: c.finite_array("gravity", &self.gravity)?,
            base: c.frame("base", &self.base.xyz, &self.base.rpy)?,
            base_compliance: c.non_negative(
                "base.compliance",
                &self.base.compliance,
                "a compliance >= 0 rad/Nm",
            )?,
            base_softening: 0.0,
            tool: c.frame("tool", &self.tool.xyz, &self.tool.rpy)?,
            payload_com: c.finite_array("payload.com", &self.payload.com)?,
            rated_payload_kg: match &self.payload.rated_kg {
                Some(kg) => c.non_negative("payload.rated_kg", kg, "a payload >= 0 kg")?,
                None => 0.0,
            },
            joints: PerJoint::from_slice(&joints).expect("length checked above"),
        };
        // The nominal compliances within the physical bounds (`model::bounds`).
        let bounds = model::bounds::Bounds::of(&arm);
        if let Err(v) = bounds.check(&arm) {
            let key = crate::io::bounds::key("", v.quantity, true);
            let span = match v.quantity {
                model::bounds::Quantity::Compliance { spring: 0 } => self.base.compliance.span(),
                model::bounds::Quantity::Compliance { spring } => {
                    raw_joints[usize::from(spring) - 1].compliance.span()
                }
                _ => self.joint.span(),
            };
            return Err(c.fail(
                &key,
                span,
                crate::io::bounds::problem(&v, &bounds, arm.rated_payload_kg),
            ));
        }
        let joint_names = raw_joints.iter().map(|r| r.name.clone()).collect();
        let collision = c.collision(self.collision.as_ref(), &self.body)?;
        // Names, links and pairs are only known on the arm: place the bodies once to check them.
        BodySet::for_arm(&arm, &collision)
            .map_err(|e| c.spec_error(e, self.collision.as_ref(), &self.body))?;
        let levels_deg = match &self.plan {
            Some(plan) => Some(c.levels(&plan.levels_deg)?),
            None => None,
        };
        Ok(ArmDescription {
            name: self.name,
            joint_names,
            arm,
            collision,
            levels_deg,
        })
    }
}
