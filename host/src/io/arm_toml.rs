//! The arm description file (shared/CONTRACTS.md §1): TOML <-> [`model::Arm`].
//!
//! Every key is required; there are no defaults, because a forgotten line in a
//! calibration input should be an error, not a silent zero. Unknown keys are
//! rejected (a misspelt key would otherwise be ignored). Numbers must be
//! finite; masses and compliances must not be negative; joint limits must
//! satisfy `lo < hi`; servo curves must be strictly monotonic with their
//! pulses in [`PULSE_RANGE_US`]. Errors name the key path (`joint[3].mass`,
//! array positions counted from 1 like the joints `j1..j6`), the line, and
//! what was expected.
//!
//! A servo curve is written as its knots, `{ angles_deg = [...], pulses_us =
//! [...] }`; the three points of earlier files, `{ minus100, zero, plus100 }`,
//! still read as the same curve, bit for bit.

use std::ops::Range;
use std::path::Path;

use model::servo::{CurveFault, MAX_KNOTS, PULSE_RANGE_US};
use model::{Arm, Frame, JOINTS, Joint, ServoCurve};
use serde::{Deserialize, Serialize};
use toml::Spanned;

use crate::error::{Error, Field, InputError, Location, Problem};
use crate::io::{atomic, read_text};

/// An arm description as read from (or written to) a TOML file.
#[derive(Clone, Debug, PartialEq)]
pub struct ArmDescription {
    /// The arm's name (`name` key).
    pub name: String,
    /// The joints' names, base to tip (`joint[i].name`).
    pub joint_names: [String; JOINTS],
    /// The arm's parameters.
    pub arm: Arm<f64>,
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

/// Serialises an arm description as TOML in the layout of CONTRACTS.md §1.
pub fn to_toml(description: &ArmDescription) -> String {
    let raw = RawArm::from_description(description);
    // Serialising plain structs of numbers and strings cannot fail.
    let body = toml::to_string(&raw).expect("an arm description always serialises");
    format!(
        "# Arm description (shared/CONTRACTS.md section 1): metres, radians, kilograms, µs.\n{body}"
    )
}

/// Parses and checks the text of an arm description.
pub fn parse(text: &str) -> Result<ArmDescription, InputError> {
    let lines = LineIndex::new(text);
    let deserializer = toml::Deserializer::parse(text).map_err(|e| toml_error(&lines, e, None))?;
    let raw: RawArm = serde_path_to_error::deserialize(deserializer).map_err(|e| {
        let path = render_path(e.path());
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

/// A serde path as `joint[3].servo.zero`, array positions counted from 1.
fn render_path(path: &serde_path_to_error::Path) -> String {
    use serde_path_to_error::Segment;
    let mut out = String::new();
    for segment in path.iter() {
        match segment {
            Segment::Seq { index } => out.push_str(&format!("[{}]", index + 1)),
            // `Spanned` wraps a value in a private map; its keys are not the user's.
            Segment::Map { key } if key.starts_with("$__") => {}
            Segment::Map { key } | Segment::Enum { variant: key } => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(key);
            }
            Segment::Unknown => {}
        }
    }
    out
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
    servo: Spanned<RawServo>,
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
        let servo = self.servo(&k("servo"), &raw.servo)?;
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
        })
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
            tool: c.frame("tool", &self.tool.xyz, &self.tool.rpy)?,
            payload_com: c.finite_array("payload.com", &self.payload.com)?,
            joints: joints.try_into().expect("length checked above"),
        };
        let joint_names = std::array::from_fn(|i| raw_joints[i].name.clone());
        Ok(ArmDescription {
            name: self.name,
            joint_names,
            arm,
        })
    }

    fn from_description(d: &ArmDescription) -> Self {
        // Values made in memory have no place in a file: an empty span.
        fn s<T>(v: T) -> Spanned<T> {
            Spanned::new(0..0, v)
        }
        let a = &d.arm;
        Self {
            name: d.name.clone(),
            gravity: s(a.gravity),
            base: RawBase {
                xyz: s(a.base.xyz),
                rpy: s(a.base.rpy),
                compliance: s(a.base_compliance),
            },
            tool: RawFrame {
                xyz: s(a.tool.xyz),
                rpy: s(a.tool.rpy),
            },
            payload: RawPayload {
                com: s(a.payload_com),
            },
            joint: s(a
                .joints
                .iter()
                .zip(&d.joint_names)
                .map(|(j, name)| RawJoint {
                    name: name.clone(),
                    theta: s(j.theta),
                    d: s(j.d),
                    a: s(j.a),
                    alpha: s(j.alpha),
                    compliance: s(j.compliance),
                    limits: s(j.limits),
                    mass: s(j.mass),
                    com: s(j.com),
                    servo: s(RawServo::knots(&j.servo)),
                })
                .collect()),
        }
    }
}
