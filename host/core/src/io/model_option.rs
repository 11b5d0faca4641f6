//! The model option by name in the files and on the command line: a
//! calibration file writes [`ModelOption::name`] and reads it back, refusing
//! an unknown name with the list of the valid ones. The option itself is
//! [`model::ModelOption`], the one the board stores.

use model::ModelOption;
use serde::{Deserialize, Deserializer, Serializer, de::Error};

/// The names every option has, for messages: `a, b, c or d`.
pub fn names() -> String {
    let names = ModelOption::EVERY.map(ModelOption::name);
    format!(
        "{} or {}",
        names[..names.len() - 1].join(", "),
        names[names.len() - 1]
    )
}

/// Writes the option's name (`#[serde(with = "crate::io::model_option")]`).
pub fn serialize<S: Serializer>(option: &ModelOption, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(option.name())
}

/// Reads an option by name.
pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<ModelOption, D::Error> {
    let name = String::deserialize(d)?;
    ModelOption::from_name(&name).ok_or_else(|| {
        D::Error::custom(format!(
            "unknown model option `{name}`: expected {}",
            names()
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq, serde::Serialize, serde::Deserialize)]
    struct Named(#[serde(with = "super")] ModelOption);

    #[test]
    fn every_option_is_written_and_read_by_its_name() {
        for o in ModelOption::EVERY {
            let json = serde_json::to_string(&Named(o)).unwrap();
            assert_eq!(json, format!("\"{}\"", o.name()));
            assert_eq!(serde_json::from_str::<Named>(&json).unwrap(), Named(o));
        }
        assert_eq!(
            names(),
            "kinematic, elastic, elasto-kinematic, elasto-kinematic-servo, paper-kinematic or paper-elasto-kinematic"
        );
    }

    #[test]
    fn an_unknown_name_is_refused_listing_the_valid_ones() {
        let e = serde_json::from_str::<Named>("\"rigid\"")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("unknown model option `rigid`: expected kinematic, elastic, elasto-kinematic, elasto-kinematic-servo, paper-kinematic or paper-elasto-kinematic"),
            "{e}"
        );
    }
}
