//! Reading a calibration file: its text parsed (an older version's upgraded
//! first), then what the types alone cannot hold checked: both arms of the
//! same joints and within the physical bounds, the joints' names, each
//! parameter a known one of this arm, once, and the targets.

use std::path::Path;

use super::upgrade::upgrade;
use super::{CalibrationFile, OLDEST_SCHEMA_VERSION, SCHEMA, SCHEMA_VERSION};
use crate::error::{Error, InputError, Location, Problem};
use crate::io::{json, read_text};
use crate::param_key::ParamKey;

impl CalibrationFile {
    /// Parses and checks a calibration file's text.
    pub fn parse(text: &str) -> Result<Self, InputError> {
        let file: Self = json::parse_upgrading(
            text,
            SCHEMA,
            OLDEST_SCHEMA_VERSION..=SCHEMA_VERSION,
            upgrade,
        )?;
        // Both arms of the same joints, at least one.
        let joints = file.nominal.joints.len();
        if joints == 0 || file.arm.joints.len() != joints {
            return Err(InputError::new(
                Location::key(None, "arm.joints"),
                Problem::Invalid {
                    message: format!(
                        "expected the calibrated arm to have the nominal arm's joints (1 to {}), \
                         found {} and {joints}",
                        model::MAX_JOINTS,
                        file.arm.joints.len()
                    ),
                },
            ));
        }
        // The joints' names, when recorded: one per joint, none empty.
        let names = &file.joint_names;
        if !names.is_empty() && (names.len() != joints || names.iter().any(|n| n.trim().is_empty()))
        {
            return Err(InputError::new(
                Location::key(None, "joint_names"),
                Problem::Invalid {
                    message: format!(
                        "expected one name per joint of the arm ({joints}), none empty, found {} ({})",
                        names.len(),
                        names.join(", ")
                    ),
                },
            ));
        }
        // Both arms' rated payloads, and their compliances, softenings and
        // plays within the physical bounds worked out from the nominal arm
        // (`model::bounds`): what the fit keeps to and the board checks.
        for (which, arm) in [("nominal", &file.nominal), ("arm", &file.arm)] {
            if !(arm.rated_payload_kg.is_finite() && arm.rated_payload_kg >= 0.0) {
                return Err(InputError::new(
                    Location::key(None, format!("{which}.rated_payload_kg")),
                    Problem::OutOfRange {
                        expected: "a payload >= 0 kg",
                        found: arm.rated_payload_kg.to_string(),
                    },
                ));
            }
            crate::io::bounds::check(&file.nominal, arm, which, None, false)?;
        }
        for (i, p) in file.parameters.iter().enumerate() {
            let repeated = file.parameters[..i].iter().any(|q| q.name == p.name);
            // A further target's tool point names a target the file lists.
            let known = match p.name {
                ParamKey::TargetTool { target, .. } => usize::from(target) < file.targets.len(),
                key => key.fits(joints),
            };
            if !known || repeated {
                let n = joints;
                return Err(InputError::new(
                    Location::key(None, format!("parameters[{}].name", i + 1)),
                    Problem::Invalid {
                        message: format!(
                            "expected a parameter name of this arm of {n} joints (j1.theta … \
                             j{n}.alpha, base.x … tool.yaw, k0 … k{n}, j1.servo[1] … \
                             j{n}.servo[9], j1.backlash … j{n}.backlash, s0 … s{n}, tool[N].x … \
                             tool[N].z of a listed target), each once, found `{}`",
                            p.name
                        ),
                    },
                ));
            }
        }
        for (i, t) in file.targets.iter().enumerate() {
            let problem = if t.name.is_empty() {
                Some("a name".to_string())
            } else if file.targets[..i].iter().any(|u| u.name == t.name) {
                Some(format!("a name not used before, found `{}` again", t.name))
            } else if !t.tool_m.iter().all(|v| v.is_finite()) {
                Some("finite coordinates in m".to_string())
            } else {
                None
            };
            if let Some(message) = problem {
                return Err(InputError::new(
                    Location::key(None, format!("targets[{}]", i + 1)),
                    Problem::Invalid {
                        message: format!("expected {message}"),
                    },
                ));
            }
        }
        if let Some(first) = file.targets.first()
            && first.tool_m != file.arm.tool.xyz
        {
            return Err(InputError::new(
                Location::key(None, "targets[1].tool_m"),
                Problem::Invalid {
                    message: "the first target is the arm's tool point: expected arm.tool.xyz"
                        .into(),
                },
            ));
        }
        Ok(file)
    }

    /// Reads and checks a calibration file.
    pub fn read(path: &Path) -> Result<Self, Error> {
        Self::parse(&read_text(path)?).map_err(|e| e.in_file(path))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::calibration_file::test_support::sample_file;
    use model::ModelOption;

    /// Every option reads by its name: ours, `elasto-kinematic-servo`, the
    /// default of every lrmcal that wrote calibration files, too.
    #[test]
    fn every_option_reads_by_its_name() {
        let json = sample_file().to_json();
        for o in ModelOption::ALL {
            let text = json.replacen(
                "\"option\": \"elastic\"",
                &format!("\"option\": \"{}\"", o.name()),
                1,
            );
            assert_eq!(CalibrationFile::parse(&text).unwrap().option, o);
        }
    }

    /// Each refusal names the key (and the line, where the JSON text has one).
    #[test]
    fn rejects_other_schemas_versions_and_bad_values() {
        let json = sample_file().to_json();
        let refused = |text: &str| CalibrationFile::parse(text).unwrap_err().to_string();
        let e = refused("{\"a\": 1}");
        assert!(e.contains("key `schema`") && e.contains(SCHEMA), "{e}");
        let e = refused(&json.replace(
            &format!("\"schema_version\": {SCHEMA_VERSION}"),
            "\"schema_version\": 9",
        ));
        assert!(e.contains("key `schema_version`") && e.contains('9'), "{e}");
        let e = refused(&json.replacen("\"k2\"", "\"k9\"", 1));
        assert!(
            e.contains("key `parameters[1].name`") && e.contains("k9"),
            "{e}"
        );
        let e = refused(&json.replacen("\"compliance\": 0.1", "\"compliance\": -0.1", 1));
        assert!(e.contains("key `arm.joints[2].compliance`"), "{e}");
        // The first arm written is the nominal, its joints after its base.
        let e = refused(&json.replacen("\"softening\": 0.0", "\"softening\": -0.5", 1));
        assert!(
            e.contains("key `nominal.joints[1].softening`") && e.contains("-0.5"),
            "{e}"
        );
        let e = refused(&json.replacen("\"base_softening\": 0.0", "\"base_softening\": -2.0", 2));
        assert!(e.contains("key `nominal.base_softening`"), "{e}");
        // A negative rated payload, in either arm, as the board refuses it.
        let mut negative = sample_file();
        negative.arm.rated_payload_kg = -0.1;
        let e = refused(&negative.to_json());
        assert!(
            e.contains("key `arm.rated_payload_kg`") && e.contains("-0.1"),
            "{e}"
        );
        let e = refused(&json.replacen("\"elastic\"", "\"rigid\"", 1));
        assert!(
            e.contains("key `option`")
                && e.contains("rigid")
                && e.contains("line 4")
                && e.contains("elasto-kinematic-servo, paper-kinematic or paper-elasto-kinematic"),
            "{e}"
        );
        let e = refused(&json.replacen("\"mean_m\"", "\"mean_mm\"", 1));
        assert!(e.contains("key `fit_residual.mean_mm`"), "{e}");
        let e = refused(&json[..json.len() / 2]);
        assert!(e.contains("not JSON"), "{e}");
        // JSON has no NaN or infinity; a number too large for f64 is refused.
        let e = refused(&json.replacen("0.1", "1e999", 1));
        assert!(e.contains("not JSON") && e.contains("number"), "{e}");
    }

    /// A file knows the arm it was made for: its name and its joints' names
    /// read back as written, and a list of names that is not one per joint is
    /// refused naming the key; files without them read as before.
    #[test]
    fn the_arms_name_and_joint_names_round_trip_and_are_checked() {
        let names: Vec<String> = (1..=6).map(|i| format!("j{i}_servo")).collect();
        let named = sample_file().for_arm("my arm", &names);
        let json = named.to_json();
        let back = CalibrationFile::parse(&json).unwrap();
        assert_eq!(back, named);
        assert_eq!(back.joint_names_or_numbered(), names);
        assert_eq!(back.arm_name.as_deref(), Some("my arm"));
        let unnamed = sample_file();
        assert!(!unnamed.to_json().contains("joint_names"));
        assert_eq!(unnamed.joint_names_or_numbered()[5], "joint_6");
        let five = sample_file().for_arm("my arm", &names[..5]);
        let e = CalibrationFile::parse(&five.to_json())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("key `joint_names`") && e.contains("one name per joint of the arm (6)"),
            "{e}"
        );
    }
}
