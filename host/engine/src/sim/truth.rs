//! The truth file: what the simulator drew, so a calibration can be checked
//! against it. JSON, SI units (m, rad, kg, rad/Nm), with the 43 errors by name.

use serde::Serialize;
use serde::ser::SerializeMap;

use super::{ServoError, SimConfig, TrueArm, Webcam};
use model::{Arm, ParamId};

/// Version of the truth file's layout; bumped on any change a reader would notice.
/// 2: servo curves as knots (`angles_rad`, `pulses_us`) inside the arms.
pub const TRUTH_SCHEMA: &str = "lrmcal-sim-truth/2";

/// The truth file's content, in the order it is written.
#[derive(Serialize)]
struct TruthFile<'a> {
    schema: &'static str,
    units: &'static str,
    seed: u64,
    config: &'a SimConfig,
    /// True minus nominal, by stable parameter name, in `ParamId::of` order.
    errors: NamedErrors<'a>,
    true_arm: &'a Arm<f64>,
    nominal_arm: &'a Arm<f64>,
    servo_errors: &'a [ServoError],
    backlash_half_rad: &'a [f64],
    /// Where the webcam and its board really are, when a webcam watched.
    #[serde(skip_serializing_if = "Option::is_none")]
    webcam: Option<&'a Webcam>,
}

/// The errors as a JSON object whose keys keep the parameters' order.
struct NamedErrors<'a>(&'a TrueArm);

impl Serialize for NamedErrors<'_> {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(self.0.errors.len()))?;
        for (id, value) in self.0.named_errors() {
            map.serialize_entry(ParamId::name(id), &value)?;
        }
        map.end()
    }
}

impl TrueArm {
    /// The truth file as pretty-printed JSON (schema [`TRUTH_SCHEMA`]),
    /// with the webcam's placement when one watched the arm.
    pub fn truth_json(&self, webcam: Option<&Webcam>) -> String {
        let file = TruthFile {
            schema: TRUTH_SCHEMA,
            units: "SI: lengths m, angles rad, masses kg, compliances rad/Nm, softening 1/Nm",
            seed: self.seed,
            config: &self.config,
            errors: NamedErrors(self),
            true_arm: &self.arm,
            nominal_arm: &self.nominal,
            servo_errors: &self.servo_errors,
            backlash_half_rad: &self.backlash_half_rad,
            webcam,
        };
        // Plain numbers and strings: serialising cannot fail.
        serde_json::to_string_pretty(&file).expect("the truth file always serialises")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::test_support::bundled_arm;

    #[test]
    fn truth_names_all_43_errors_in_order_with_their_values() {
        let t = TrueArm::draw(&bundled_arm(), 11, &SimConfig::default()).unwrap();
        let json: serde_json::Value = serde_json::from_str(&t.truth_json(None)).unwrap();
        assert_eq!(json["schema"], TRUTH_SCHEMA);
        assert_eq!(json["seed"], 11);
        let errors = json["errors"].as_object().unwrap();
        assert_eq!(errors.len(), 43);
        // serde_json's default parser may miss the last bit; the writer is exact.
        let same = |a: f64, b: f64| (a - b).abs() <= 1e-15 * b.abs().max(1e-300);
        for (id, value) in t.named_errors() {
            assert!(same(errors[id.name()].as_f64().unwrap(), value), "{id}");
        }
        let k2 = json["true_arm"]["joints"][1]["compliance"]
            .as_f64()
            .unwrap();
        assert!(same(k2, t.arm.joints[1].compliance));
        assert!(
            t.truth_json(None)
                .contains(&format!("\"j5.alpha\": {:?}", t.errors[19]))
        );
        // The text lists the errors in the parameters' order, not alphabetically.
        let text = t.truth_json(None);
        assert!(text.find("\"j1.theta\"").unwrap() < text.find("\"base.x\"").unwrap());
    }
}
