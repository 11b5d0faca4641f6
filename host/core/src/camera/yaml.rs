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
    // The parser names the line after the last one for an error at the end
    // of a file that does not end with a line break: the last line it is.
    let last_line = 1 + text
        .char_indices()
        .filter(|&(i, c)| c == '\n' || (c == '\r' && !text[i + 1..].starts_with('\n')))
        .count() as u64;
    let value: Value = serde_norway::from_str(text).map_err(|e| {
        // Without a place (more than one document), the parser read the
        // file to its end before it refused it.
        let line = Some(
            e.location()
                .map_or(last_line, |l| (l.line() as u64).min(last_line)),
        );
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
        let message = e.into_inner().to_string();
        // A key missing at the top has no path: the key is the place. A
        // document that is no mapping at all is wrong from its first line.
        let key = match path.is_empty() {
            true => message
                .strip_prefix("missing field `")
                .and_then(|rest| rest.split('`').next())
                .map(str::to_owned),
            false => Some(path),
        };
        InputError::new(
            Location {
                line: key.is_none().then_some(1),
                field: key.map(Field::Key),
            },
            Problem::Syntax { message },
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A file of one required key, `width`.
    #[derive(Debug, serde::Deserialize)]
    struct Camera {
        #[serde(rename = "width")]
        _width: u32,
    }

    /// The place of `text`'s refusal: its line and key.
    fn place(text: &str) -> (Option<u64>, Option<String>) {
        let e = parse_value(text)
            .and_then(from_value::<Camera>)
            .unwrap_err();
        let key = e.location.field.map(|f| match f {
            Field::Key(k) => k,
            other => panic!("{other:?}"),
        });
        (e.location.line, key)
    }

    #[test]
    fn every_refusal_names_a_line_of_the_file_or_a_key() {
        // The end of a file without a final line break is its last line.
        assert_eq!(place("["), (Some(1), None));
        assert_eq!(place("width: 1\nheight: ["), (Some(2), None));
        // A key missing at the top: the key.
        assert_eq!(place(""), (None, Some("width".into())));
        assert_eq!(place("height: 2\n"), (None, Some("width".into())));
        // Two documents: the file read to its end.
        assert_eq!(place("width: 1\n---\nwidth: 2\n"), (Some(4), None));
        // No mapping at all: from its first line.
        assert_eq!(place("- 1\n- 2\n"), (Some(1), None));
    }
}
