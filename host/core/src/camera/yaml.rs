//! YAML reading shared by the camera's files: text to a tag-free value, and
//! a value to a struct, each error an [`InputError`] with its line or key.
//!
//! The YAML crate is `serde_norway`, the maintained fork of the archived
//! `serde_yaml` (see the workspace's `Cargo.toml`).

use serde::de::DeserializeOwned;
use serde_norway::Value;

use crate::error::{Field, InputError, Location, Problem};

/// The YAML value of `text`, with every tag dropped.
///
/// OpenCV's FileStorage opens with `%YAML:1.0` (before OpenCV 5), a
/// directive no YAML parser accepts; it is blanked (the line stays, so
/// errors name the file's own lines). Its matrices are tagged
/// `!!opencv-matrix`; the tags carry nothing the keys do not say.
pub(crate) fn parse_value(text: &str) -> Result<Value, InputError> {
    let text = match text.strip_prefix("%YAML:") {
        Some(rest) => rest.find('\n').map_or("", |end| &rest[end..]),
        None => text,
    };
    let value: Value = serde_norway::from_str(text).map_err(|e| {
        let line = e.location().map(|l| l.line() as u64);
        InputError::new(
            Location { line, field: None },
            Problem::Syntax {
                message: e.to_string(),
            },
        )
    })?;
    Ok(untagged(value))
}

/// `value` without its tags, at every depth.
fn untagged(value: Value) -> Value {
    match value {
        Value::Tagged(tagged) => untagged(tagged.value),
        Value::Sequence(items) => Value::Sequence(items.into_iter().map(untagged).collect()),
        Value::Mapping(map) => Value::Mapping(
            map.into_iter()
                .map(|(k, v)| (untagged(k), untagged(v)))
                .collect(),
        ),
        other => other,
    }
}

/// `value` as a `T`, a missing or mistyped key named by its path.
pub(crate) fn from_value<T: DeserializeOwned>(value: Value) -> Result<T, InputError> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = crate::io::key_path(e.path());
        InputError::new(
            Location {
                line: None,
                field: (!path.is_empty()).then_some(Field::Key(path)),
            },
            Problem::Syntax {
                message: e.into_inner().to_string(),
            },
        )
    })
}

/// An [`InputError`] at `key`.
pub(crate) fn at(key: impl Into<String>, problem: Problem) -> InputError {
    InputError::new(Location::key(None, key), problem)
}

/// A number read as finite, or an error at `key`.
pub(crate) fn finite(key: &str, value: f64) -> Result<f64, InputError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(at(
            key,
            Problem::NotFinite {
                found: value.to_string(),
            },
        ))
    }
}
