//! What the JSON files `lrmcal` writes have in common: pretty text, a schema
//! name and version that a reader checks before anything else, errors that
//! name the line and the key (`arm.joints[3].compliance`, array positions
//! counted from 1 as everywhere in messages).
//!
//! A JSON format is a module of [`crate::io`] with plain serde structs, its
//! `SCHEMA` and `SCHEMA_VERSION`, and `parse`/`read` built on [`parse`]; the
//! engine converts its results into those structs (see `lrmcal_engine::calib::results::export`).

use std::ops::RangeInclusive;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Deserializer, Serialize};

use crate::error::{InputError, Location, Problem};

/// Pretty JSON text of `value`.
pub fn to_pretty(value: &impl Serialize) -> String {
    // The formats are plain structs of numbers, strings and vectors (no maps
    // with non-string keys), which always serialise.
    serde_json::to_string_pretty(value).expect("a file format always serialises")
}

/// Reads a number that serde_json wrote as `null` because it was NaN or
/// infinite back as NaN (`#[serde(deserialize_with = "…")]`): a report's
/// figure that could not be worked out reads back as not a number.
pub fn nan_if_null<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// [`nan_if_null`] for each number of a list.
pub fn nan_if_null_each<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
    let values = Vec::<Option<f64>>::deserialize(d)?;
    Ok(values.into_iter().map(|v| v.unwrap_or(f64::NAN)).collect())
}

/// Parses the text of a JSON file of kind `schema`, version `version`.
///
/// The `schema` and `schema_version` keys are checked first, so a file of
/// another kind or version is named as such rather than by its first
/// unexpected field.
pub fn parse<T: DeserializeOwned>(
    text: &str,
    schema: &'static str,
    version: u32,
) -> Result<T, InputError> {
    parse_upgrading(text, schema, version..=version, |_, _| Ok(()))
}

/// [`parse`] for a format that still reads its older versions: a file of a
/// version in `versions` below the newest is handed to `upgrade` (with its
/// version) as a JSON value, rewritten into the newest layout, then read.
/// Errors in an upgraded file name the key but no line.
pub fn parse_upgrading<T: DeserializeOwned>(
    text: &str,
    schema: &'static str,
    versions: RangeInclusive<u32>,
    upgrade: impl FnOnce(u32, &mut serde_json::Value) -> Result<(), InputError>,
) -> Result<T, InputError> {
    let mut value: serde_json::Value =
        serde_json::from_str(text).map_err(|e| json_error(&e, None))?;
    let found = value.get("schema");
    if found.and_then(|s| s.as_str()) != Some(schema) {
        return Err(InputError::new(
            Location::key(None, "schema"),
            Problem::WrongSchema {
                expected: schema,
                found: shown(found),
            },
        ));
    }
    let found = value.get("schema_version");
    let version = found
        .and_then(|v| v.as_u64())
        .and_then(|v| u32::try_from(v).ok())
        .filter(|v| versions.contains(v));
    let Some(version) = version else {
        return Err(InputError::new(
            Location::key(None, "schema_version"),
            Problem::WrongVersion {
                oldest: *versions.start(),
                newest: *versions.end(),
                found: shown(found),
            },
        ));
    };
    if version == *versions.end() {
        // From the text again, not the value: serde_json's errors then carry lines.
        let mut deserializer = serde_json::Deserializer::from_str(text);
        return serde_path_to_error::deserialize(&mut deserializer).map_err(|e| {
            let key = super::key_path(e.path());
            json_error(e.inner(), Some(key))
        });
    }
    upgrade(version, &mut value)?;
    value["schema_version"] = (*versions.end()).into();
    serde_path_to_error::deserialize(value).map_err(|e| {
        let key = super::key_path(e.path());
        // A value carries no lines: an error about the whole document (a
        // missing top-level key) is placed on its last line, where a read of
        // the text places it.
        let whole_document = key.is_empty();
        let mut error = json_error(e.inner(), Some(key));
        if whole_document {
            error.location.line = Some(text.lines().count().max(1) as u64);
        }
        error
    })
}

/// A key's value as found, for an error message.
fn shown(value: Option<&serde_json::Value>) -> String {
    value.map_or_else(|| "no such key".to_owned(), ToString::to_string)
}

/// A serde_json error with its line and, when known, the key it is about.
fn json_error(error: &serde_json::Error, key: Option<String>) -> InputError {
    let full = error.to_string();
    // serde_json appends the position to its message; the line goes into the location.
    let message = full
        .strip_suffix(&format!(
            " at line {} column {}",
            error.line(),
            error.column()
        ))
        .unwrap_or(&full);
    let message = if error.is_syntax() || error.is_eof() {
        format!("not JSON: {message}")
    } else {
        message.to_owned()
    };
    InputError::new(
        Location {
            line: (error.line() > 0).then_some(error.line() as u64),
            field: key.filter(|k| !k.is_empty()).map(crate::error::Field::Key),
        },
        Problem::Syntax { message },
    )
}
