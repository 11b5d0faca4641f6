//! The arm description file (`docs/FORMATS.md`, "Arm description"): TOML <-> [`model::Arm`]
//! and the planner's [`CollisionSpec`].
//!
//! Every key of the model is required; there are no defaults, because a
//! forgotten line in a calibration input should be an error, not a silent
//! zero. Two parts are optional: a joint's `servo` table (an arm our board
//! does not drive has none, see [`no_servo`]), and the collision description
//! (`[collision]`, `[[body]]`), whose defaults are the planner's. Unknown keys
//! are rejected (a misspelt key would otherwise be ignored). Numbers must be
//! finite; masses, compliances and sizes must not be negative; joint limits
//! must satisfy `lo < hi`; servo curves must be strictly monotonic with their
//! pulses in [`PULSE_RANGE_US`]. Errors name the key path (`joint[3].mass`,
//! `body[2].capsule.from`, array positions counted from 1 like the joints
//! `j1..j6`), the line, and what was expected.
//!
//! A servo curve is written as its knots, `{ angles_deg = [...], pulses_us =
//! [...] }`; the three points of earlier files, `{ minus100, zero, plus100 }`,
//! still read as the same curve, bit for bit.

use std::ops::Range;
use std::path::Path;

use model::servo::{CurveFault, MAX_KNOTS, PULSE_RANGE_US};
use model::{Arm, Frame, JOINTS, Joint, ServoCurve};
use serde::{Deserialize, Serialize};
use toml::{Spanned, Value};

use crate::collision::{
    BodySet, BodySpec, CollisionSpec, Floor, FrameRef, PointSpec, ShapeSpec, SpecError, SpecPlace,
};
use crate::error::{Error, Field, InputError, Location, Problem};
use crate::io::{atomic, read_text};

/// An arm description as read from (or written to) a TOML file.
#[derive(Clone, Debug, PartialEq)]
pub struct ArmDescription {
    /// The arm's name (`name` key).
    pub name: String,
    /// The joints' names, base to tip (`joint[i].name`).
    pub joint_names: [String; JOINTS],
    /// The arm's parameters; a joint without a `servo` table has [`no_servo`].
    pub arm: Arm<f64>,
    /// The bodies, floor and clearance the planner tests (`[collision]`, `[[body]]`).
    pub collision: CollisionSpec,
}

/// The servo curve of a joint whose arm file has no `servo` table (an arm
/// moved by its own controller, calibrated from its tracker data alone): all
/// pulses 0. The model never reads the curve; the board commands refuse it
/// (see [`joint_without_servo`]), and so would the board, since it is not
/// monotonic, which a curve from a file always is.
pub fn no_servo() -> ServoCurve<f64> {
    ServoCurve::from_three_points(0.0, 0.0, 0.0)
}

/// The first joint (1-based) of `arm` that has no servo curve ([`no_servo`]), if any.
pub fn joint_without_servo(arm: &Arm<f64>) -> Option<usize> {
    arm.joints
        .iter()
        .position(|j| j.servo == no_servo())
        .map(|i| i + 1)
}

/// Reads and checks an arm description file.
pub fn read(path: &Path) -> Result<ArmDescription, Error> {
    let text = read_text(path)?;
    parse(&text).map_err(|e| e.in_file(path))
}

/// Writes an arm description file atomically (a temporary file renamed into place).
pub fn write(path: &Path, description: &ArmDescription) -> Result<(), Error> {
    let text = to_toml(description);
    atomic::write(path, |w| w.write_all(text.as_bytes()))
}

/// Serialises an arm description as TOML in the layout `docs/FORMATS.md` describes.
pub fn to_toml(description: &ArmDescription) -> String {
    let raw = RawArm::from_description(description);
    // Serialising plain structs of numbers and strings cannot fail.
    let body = toml::to_string(&raw).expect("an arm description always serialises");
    format!("# Arm description (lrmcal docs/FORMATS.md): metres, radians, kilograms, µs.\n{body}")
}

/// Parses and checks the text of an arm description.
pub fn parse(text: &str) -> Result<ArmDescription, InputError> {
    let lines = LineIndex::new(text);
    let deserializer = toml::Deserializer::parse(text).map_err(|e| toml_error(&lines, e, None))?;
    let raw: RawArm = serde_path_to_error::deserialize(deserializer).map_err(|e| {
        let path = super::key_path(e.path());
        toml_error(&lines, e.into_inner(), Some(path))
    })?;
    raw.check(&lines)
}

/// A `toml` or serde error turned into an [`InputError`] with line and key path.
fn toml_error(lines: &LineIndex, error: toml::de::Error, path: Option<String>) -> InputError {
    let line = error.span().map(|s| lines.line_of(s.start));
    let location = Location {
        line,
        field: path.filter(|p| !p.is_empty()).map(Field::Key),
    };
    InputError::new(
        location,
        Problem::Syntax {
            message: error.message().trim().to_owned(),
        },
    )
}

/// Byte offset -> 1-based line number.
struct LineIndex {
    starts: Vec<usize>,
}

impl LineIndex {
    fn new(text: &str) -> Self {
        let starts = std::iter::once(0)
            .chain(text.match_indices('\n').map(|(i, _)| i + 1))
            .collect();
        Self { starts }
    }

    fn line_of(&self, offset: usize) -> u64 {
        let line = self.starts.partition_point(|&start| start <= offset);
        line as u64
    }

    fn span_line(&self, span: Range<usize>) -> Option<u64> {
        // Values made in memory (for writing) carry an empty span at 0.
        (!span.is_empty()).then(|| self.line_of(span.start))
    }
}

/// The file's layout; spans remember where each value was for error messages.
#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawArm {
    name: String,
    gravity: Spanned<[f64; 3]>,
    base: RawBase,
    tool: RawFrame,
    payload: RawPayload,
    joint: Spanned<Vec<RawJoint>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    collision: Option<RawCollision>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    body: Vec<Spanned<RawBody>>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawBase {
    xyz: Spanned<[f64; 3]>,
    rpy: Spanned<[f64; 3]>,
    compliance: Spanned<f64>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawFrame {
    xyz: Spanned<[f64; 3]>,
    rpy: Spanned<[f64; 3]>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawPayload {
    com: Spanned<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rated_kg: Option<Spanned<f64>>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawJoint {
    name: String,
    theta: Spanned<f64>,
    d: Spanned<f64>,
    a: Spanned<f64>,
    alpha: Spanned<f64>,
    compliance: Spanned<f64>,
    limits: Spanned<[f64; 2]>,
    mass: Spanned<f64>,
    com: Spanned<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    servo: Option<Spanned<RawServo>>,
}

/// A servo curve in either form: the three points of earlier files, or the knots.
#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawServo {
    #[serde(skip_serializing_if = "Option::is_none")]
    minus100: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    zero: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    plus100: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    angles_deg: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pulses_us: Option<Vec<f64>>,
}

impl RawServo {
    /// The knots form of `curve`, with angles that read back as the very same radians.
    fn knots(curve: &ServoCurve<f64>) -> Self {
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
fn degrees_of(rad: f64) -> f64 {
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
const SERVO_FORMS: &str = "either `{ angles_deg = [...], pulses_us = [...] }` (2 to 9 knots: angles in degrees, strictly increasing, and their pulses in µs) or `{ minus100, zero, plus100 }` (the pulses at -100°, 0° and +100°)";

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawCollision {
    #[serde(skip_serializing_if = "Option::is_none")]
    clearance: Option<Spanned<f64>>,
    /// A height in m, or `false`.
    #[serde(skip_serializing_if = "Option::is_none")]
    floor: Option<Spanned<Value>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    radius: Option<Spanned<f64>>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    ignore: Vec<Spanned<[String; 2]>>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawBody {
    name: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    floor: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    capsule: Option<Spanned<RawCapsule>>,
    #[serde(rename = "box", skip_serializing_if = "Option::is_none")]
    cuboid: Option<Spanned<RawBox>>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawCapsule {
    /// A frame name, or `{ frame = NAME, xyz = [x, y, z] }`.
    from: Spanned<Value>,
    to: Spanned<Value>,
    radius: Spanned<f64>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawBox {
    frame: Spanned<String>,
    min: Spanned<[f64; 3]>,
    max: Spanned<[f64; 3]>,
}

/// What a point of a body may be written as, for messages.
const POINT_FORMS: &str =
    "a frame name (base, j0 … j6, tool) or { frame = NAME, xyz = [x, y, z] } in m";

/// Checks values against their allowed ranges, reporting key path and line.
struct Checker<'a> {
    lines: &'a LineIndex,
}

impl Checker<'_> {
    fn fail(&self, key: &str, span: Range<usize>, problem: Problem) -> InputError {
        InputError::new(Location::key(self.lines.span_line(span), key), problem)
    }

    fn finite(&self, key: &str, value: &Spanned<f64>) -> Result<f64, InputError> {
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

    fn finite_array<const N: usize>(
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

    fn non_negative(
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

    fn frame(
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

    fn joint(&self, key: &str, raw: &RawJoint) -> Result<Joint<f64>, InputError> {
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
            Some(servo) => self.servo(&k("servo"), servo)?,
            None => no_servo(),
        };
        Ok(Joint {
            theta: self.finite(&k("theta"), &raw.theta)?,
            d: self.finite(&k("d"), &raw.d)?,
            a: self.finite(&k("a"), &raw.a)?,
            alpha: self.finite(&k("alpha"), &raw.alpha)?,
            compliance: self.non_negative(
                &k("compliance"),
                &raw.compliance,
                "a compliance >= 0 rad/Nm",
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
    fn frame_ref(&self, key: &str, name: &Spanned<String>) -> Result<FrameRef, InputError> {
        name.get_ref()
            .parse()
            .map_err(|message| self.fail(key, name.span(), Problem::Invalid { message }))
    }

    /// A body's point: a frame name, or a table with `frame` and `xyz`.
    fn point(&self, key: &str, value: &Spanned<Value>) -> Result<PointSpec, InputError> {
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

    fn body(&self, key: &str, raw: &Spanned<RawBody>) -> Result<BodySpec, InputError> {
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

    fn floor(&self, value: &Spanned<Value>) -> Result<Floor, InputError> {
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

    fn collision(
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
    fn spec_error(
        &self,
        e: SpecError,
        raw: Option<&RawCollision>,
        bodies: &[Spanned<RawBody>],
    ) -> InputError {
        let span = match e.place {
            SpecPlace::Body { index, key } => bodies.get(index).map(|b| {
                let c = b.get_ref().capsule.as_ref();
                match key {
                    "capsule" => c.map_or(b.span(), Spanned::span),
                    "capsule.radius" => c.map_or(b.span(), |c| c.get_ref().radius.span()),
                    "box" => b.get_ref().cuboid.as_ref().map_or(b.span(), Spanned::span),
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
    fn servo(&self, key: &str, raw: &Spanned<RawServo>) -> Result<ServoCurve<f64>, InputError> {
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
    fn three_points(
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

    /// The knots form: as many pulses as angles, 2 to 9 of them, and a curve
    /// that maps angle to pulse one-to-one.
    fn knots(
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

impl RawArm {
    fn check(self, lines: &LineIndex) -> Result<ArmDescription, InputError> {
        let c = Checker { lines };
        let raw_joints = self.joint.get_ref();
        if raw_joints.len() != JOINTS {
            return Err(c.fail(
                "joint",
                self.joint.span(),
                Problem::JointCount {
                    found: raw_joints.len(),
                },
            ));
        }
        let mut joints = Vec::with_capacity(JOINTS);
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
            joints: joints.try_into().expect("length checked above"),
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
        let joint_names = std::array::from_fn(|i| raw_joints[i].name.clone());
        let collision = c.collision(self.collision.as_ref(), &self.body)?;
        // Names, links and pairs are only known on the arm: place the bodies once to check them.
        BodySet::for_arm(&arm, &collision)
            .map_err(|e| c.spec_error(e, self.collision.as_ref(), &self.body))?;
        Ok(ArmDescription {
            name: self.name,
            joint_names,
            arm,
            collision,
        })
    }

    fn from_description(d: &ArmDescription) -> Self {
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
                        theta: unspanned(j.theta),
                        d: unspanned(j.d),
                        a: unspanned(j.a),
                        alpha: unspanned(j.alpha),
                        compliance: unspanned(j.compliance),
                        limits: unspanned(j.limits),
                        mass: unspanned(j.mass),
                        com: unspanned(j.com),
                        servo: (j.servo != no_servo())
                            .then(|| unspanned(RawServo::knots(&j.servo))),
                    })
                    .collect(),
            ),
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
fn unspanned<T>(value: T) -> Spanned<T> {
    Spanned::new(0..0, value)
}

/// A point as the file writes it: a frame name for an origin, else a table.
fn point_value(p: &PointSpec) -> Spanned<Value> {
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
    fn from_spec(c: &CollisionSpec) -> Option<Self> {
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
    fn from_spec(b: &BodySpec) -> Self {
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
