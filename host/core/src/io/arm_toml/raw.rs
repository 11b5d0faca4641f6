//! The arm file as TOML holds it: the raw tables with their spans, and
//! the way back from a description to them.

use model::servo::{MAX_KNOTS, PULSE_RANGE_US};
use model::{JointKind, ServoCurve};
use serde::{Deserialize, Serialize};
use toml::{Spanned, Value};

use super::ArmDescription;
use crate::collision::{BodySpec, CollisionSpec, Floor, PointSpec, ShapeSpec};

/// The file's layout; spans remember where each value was for error messages.
#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawArm {
    pub(super) name: String,
    pub(super) gravity: Spanned<[f64; 3]>,
    pub(super) base: RawBase,
    pub(super) tool: RawFrame,
    pub(super) payload: RawPayload,
    pub(super) joint: Spanned<Vec<RawJoint>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) plan: Option<RawPlan>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) collision: Option<RawCollision>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(super) body: Vec<Spanned<RawBody>>,
}

/// `[plan]`: the candidate grid's levels for this arm.
#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPlan {
    pub(super) levels_deg: Spanned<Vec<f64>>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawBase {
    pub(super) xyz: Spanned<[f64; 3]>,
    pub(super) rpy: Spanned<[f64; 3]>,
    pub(super) compliance: Spanned<f64>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawFrame {
    pub(super) xyz: Spanned<[f64; 3]>,
    pub(super) rpy: Spanned<[f64; 3]>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPayload {
    pub(super) com: Spanned<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) rated_kg: Option<Spanned<f64>>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawJoint {
    pub(super) name: String,
    /// `revolute` (the default) or `prismatic`.
    #[serde(rename = "type", default, skip_serializing_if = "is_revolute")]
    pub(super) kind: JointKind,
    pub(super) theta: Spanned<f64>,
    pub(super) d: Spanned<f64>,
    pub(super) a: Spanned<f64>,
    pub(super) alpha: Spanned<f64>,
    pub(super) compliance: Spanned<f64>,
    pub(super) limits: Spanned<[f64; 2]>,
    pub(super) mass: Spanned<f64>,
    pub(super) com: Spanned<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) servo: Option<Spanned<RawServo>>,
}

/// A servo curve in either form: the three points of earlier files, or the knots.
#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawServo {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) minus100: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) zero: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) plus100: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) angles_deg: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) pulses_us: Option<Vec<f64>>,
}

impl RawServo {
    /// The knots form of `curve`, with angles that read back as the very same radians.
    pub(super) fn knots(curve: &ServoCurve<f64>) -> Self {
        Self {
            minus100: None,
            zero: None,
            plus100: None,
            angles_deg: Some(curve.angles_rad().iter().map(|&a| degrees_of(a)).collect()),
            pulses_us: Some(curve.pulses_us().to_vec()),
        }
    }
}

/// The shortest decimal number of degrees that reads back as exactly `rad`
/// (`100f64.to_radians().to_degrees()` is not 100, and a written file must
/// read back as the arm it was written from).
pub(super) fn degrees_of(rad: f64) -> f64 {
    let deg = rad.to_degrees();
    (0..=15)
        .map(|places| {
            let scale = 10f64.powi(places);
            (deg * scale).round() / scale
        })
        .find(|d| d.to_radians() == rad)
        .unwrap_or(deg)
}

// The messages below spell these two out.
const _: () = assert!(MAX_KNOTS == 9 && PULSE_RANGE_US[0] == 500 && PULSE_RANGE_US[1] == 2500);

/// What either form of a servo curve looks like, for the error when neither is given.
pub(super) const SERVO_FORMS: &str = "either `{ angles_deg = [...], pulses_us = [...] }` (2 to 9 knots: angles in degrees, strictly increasing, and their pulses in µs) or `{ minus100, zero, plus100 }` (the pulses at -100°, 0° and +100°)";

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCollision {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) clearance: Option<Spanned<f64>>,
    /// A height in m, or `false`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) floor: Option<Spanned<Value>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) radius: Option<Spanned<f64>>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(super) ignore: Vec<Spanned<[String; 2]>>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawBody {
    pub(super) name: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) floor: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) capsule: Option<Spanned<RawCapsule>>,
    #[serde(rename = "box", skip_serializing_if = "Option::is_none")]
    pub(super) cuboid: Option<Spanned<RawBox>>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCapsule {
    /// A frame name, or `{ frame = NAME, xyz = [x, y, z] }`.
    pub(super) from: Spanned<Value>,
    pub(super) to: Spanned<Value>,
    pub(super) radius: Spanned<f64>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawBox {
    pub(super) frame: Spanned<String>,
    pub(super) min: Spanned<[f64; 3]>,
    pub(super) max: Spanned<[f64; 3]>,
}

impl RawArm {
    pub(super) fn from_description(d: &ArmDescription) -> Self {
        let a = &d.arm;
        Self {
            name: d.name.clone(),
            gravity: unspanned(a.gravity),
            base: RawBase {
                xyz: unspanned(a.base.xyz),
                rpy: unspanned(a.base.rpy),
                compliance: unspanned(a.base_compliance),
            },
            tool: RawFrame {
                xyz: unspanned(a.tool.xyz),
                rpy: unspanned(a.tool.rpy),
            },
            payload: RawPayload {
                com: unspanned(a.payload_com),
                rated_kg: (a.rated_payload_kg != 0.0).then(|| unspanned(a.rated_payload_kg)),
            },
            joint: unspanned(
                a.joints
                    .iter()
                    .zip(&d.joint_names)
                    .map(|(j, name)| RawJoint {
                        name: name.clone(),
                        kind: j.kind,
                        theta: unspanned(j.theta),
                        d: unspanned(j.d),
                        a: unspanned(j.a),
                        alpha: unspanned(j.alpha),
                        compliance: unspanned(j.compliance),
                        limits: unspanned(j.limits),
                        mass: unspanned(j.mass),
                        com: unspanned(j.com),
                        servo: j.servo.as_ref().map(|c| unspanned(RawServo::knots(c))),
                    })
                    .collect(),
            ),
            plan: d.levels_deg.as_ref().map(|levels| RawPlan {
                levels_deg: unspanned(levels.clone()),
            }),
            collision: RawCollision::from_spec(&d.collision),
            body: d
                .collision
                .bodies
                .iter()
                .map(|b| unspanned(RawBody::from_spec(b)))
                .collect(),
        }
    }
}

/// A value made in memory: it has no place in a file, an empty span.
pub(super) fn unspanned<T>(value: T) -> Spanned<T> {
    Spanned::new(0..0, value)
}

/// A point as the file writes it: a frame name for an origin, else a table.
pub(super) fn point_value(p: &PointSpec) -> Spanned<Value> {
    let name = Value::String(p.frame.to_string());
    let value = if p.xyz_m == [0.0; 3] {
        name
    } else {
        let mut table = toml::Table::new();
        table.insert("frame".into(), name);
        table.insert(
            "xyz".into(),
            Value::Array(p.xyz_m.iter().map(|&x| Value::Float(x)).collect()),
        );
        Value::Table(table)
    };
    unspanned(value)
}

impl RawCollision {
    /// `None` when every setting is the default (no `[collision]` table).
    pub(super) fn from_spec(c: &CollisionSpec) -> Option<Self> {
        let floor = match c.floor {
            f if f == Floor::default() => None,
            Floor::At { z_m } => Some(unspanned(Value::Float(z_m))),
            Floor::Off => Some(unspanned(Value::Boolean(false))),
        };
        let raw = Self {
            clearance: c.clearance_m.map(unspanned),
            floor,
            radius: c.skeleton_radius_m.map(unspanned),
            ignore: c
                .ignore
                .iter()
                .map(|p| Spanned::new(0..0, p.clone()))
                .collect(),
        };
        let empty = raw.clearance.is_none()
            && raw.floor.is_none()
            && raw.radius.is_none()
            && raw.ignore.is_empty();
        (!empty).then_some(raw)
    }
}

impl RawBody {
    pub(super) fn from_spec(b: &BodySpec) -> Self {
        let (capsule, cuboid) = match &b.shape {
            ShapeSpec::Capsule { from, to, radius_m } => (
                Some(unspanned(RawCapsule {
                    from: point_value(from),
                    to: point_value(to),
                    radius: unspanned(*radius_m),
                })),
                None,
            ),
            ShapeSpec::Box {
                frame,
                min_m,
                max_m,
            } => (
                None,
                Some(unspanned(RawBox {
                    frame: unspanned(frame.to_string()),
                    min: unspanned(*min_m),
                    max: unspanned(*max_m),
                })),
            ),
        };
        Self {
            name: b.name.clone(),
            floor: b.floor,
            capsule,
            cuboid,
        }
    }
}

/// Whether a joint is revolute, the kind the file leaves out.
fn is_revolute(kind: &JointKind) -> bool {
    *kind == JointKind::Revolute
}
