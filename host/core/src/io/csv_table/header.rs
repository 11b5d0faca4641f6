//! The header of a CSV file: which column sits where, checked against the
//! kind of file's [`Schema`] (unknown, duplicate, missing and misspelt
//! columns, the joints' units) once, so that each row is read by name.

use std::collections::HashMap;

use csv::StringRecord;

use model::{JointKind, PerJoint};

use super::{Extra, NOTE_PREFIX, Q_COLUMNS, Q_MM_COLUMNS, Schema, q_column};
use crate::error::{InputError, Location, Problem};

/// A parsed header: column name -> position.
pub(super) struct Header {
    pub(super) index: HashMap<&'static str, usize>,
    /// The columns the schema ignores ([`Extra::Ignore`]), by name.
    pub(super) ignored: HashMap<String, usize>,
    width: usize,
    /// Each joint column's kind, `qi_deg` (revolute) or `qi_mm` (prismatic):
    /// as many as the arm has joints.
    pub(super) units: PerJoint<JointKind>,
}

impl Header {
    /// Refuses a record (on `line`) whose field count is not the header's.
    pub(super) fn check_width(&self, record: &StringRecord, line: u64) -> Result<(), InputError> {
        if record.len() == self.width {
            return Ok(());
        }
        Err(InputError::new(
            Location::line(line),
            Problem::FieldCount {
                expected: self.width,
                found: record.len(),
            },
        ))
    }
}

pub(super) fn check_header(
    record: &StringRecord,
    line: u64,
    schema: &Schema,
) -> Result<Header, InputError> {
    let at = |column: &str| Location::column(line, column);
    let mut index = HashMap::new();
    let mut ignored = HashMap::new();
    let joint_columns = schema.columns.contains(&Q_COLUMNS[0]);
    for (i, name) in record.iter().enumerate() {
        if name.starts_with(NOTE_PREFIX) {
            continue;
        }
        let slide = Q_MM_COLUMNS
            .iter()
            .find(|&&c| c == name)
            .filter(|_| joint_columns);
        let Some(&known) = schema.columns.iter().chain(slide).find(|&&c| c == name) else {
            match schema.extra {
                Extra::Refuse => {
                    return Err(InputError::new(
                        at(name),
                        Problem::UnknownColumn {
                            column: name.to_owned(),
                            expected: schema.expected(),
                        },
                    ));
                }
                Extra::Ignore => {
                    if let Some(optional) = misspelt_optional(name, schema) {
                        return Err(InputError::new(
                            at(name),
                            Problem::Invalid {
                                message: format!(
                                    "looks like a misspelt `{optional}`; name it `{optional}`, or \
                                     `{NOTE_PREFIX}{name}` if it is something else"
                                ),
                            },
                        ));
                    }
                    ignored.entry(name.to_owned()).or_insert(i);
                    continue;
                }
            }
        };
        if index.insert(known, i).is_some() {
            return Err(InputError::new(
                at(name),
                Problem::DuplicateColumn {
                    column: name.to_owned(),
                },
            ));
        }
    }
    // A prismatic joint's `qi_mm` stands for its `qi_deg`.
    let has = |c: &&str| {
        index.contains_key(*c)
            || Q_COLUMNS
                .iter()
                .position(|q| q == c)
                .is_some_and(|i| index.contains_key(Q_MM_COLUMNS[i]))
    };
    if let Some(&missing) = schema
        .columns
        .iter()
        .find(|c| !has(c) && !schema.optional_columns().any(|o| o == **c))
    {
        return Err(InputError::new(
            at(missing),
            Problem::MissingColumn {
                column: missing,
                expected: schema.expected(),
            },
        ));
    }
    // The joints: q1 to qn, each in degrees or mm, none missing in between.
    let unit = |i: usize| match (
        index.contains_key(Q_COLUMNS[i]),
        index.contains_key(Q_MM_COLUMNS[i]),
    ) {
        (true, true) => Some(Err(Q_MM_COLUMNS[i])),
        (true, false) => Some(Ok(JointKind::Revolute)),
        (false, true) => Some(Ok(JointKind::Prismatic)),
        (false, false) => None,
    };
    let joints = (0..model::MAX_JOINTS)
        .take_while(|&i| unit(i).is_some())
        .count();
    let mut units = PerJoint::splat(joints, JointKind::Revolute);
    for (i, kind) in units.iter_mut().enumerate() {
        match unit(i) {
            Some(Ok(k)) => *kind = k,
            _ => {
                return Err(InputError::new(
                    at(Q_MM_COLUMNS[i]),
                    Problem::Invalid {
                        message: format!(
                            "is given with `{}`: a joint's column is in degrees (revolute) or in \
                             mm (prismatic), not both",
                            Q_COLUMNS[i]
                        ),
                    },
                ));
            }
        }
    }
    if joint_columns && let Some(after) = (joints..model::MAX_JOINTS).find(|&i| unit(i).is_some()) {
        return Err(InputError::new(
            at(Q_COLUMNS[joints]),
            Problem::Invalid {
                message: format!(
                    "missing from the header while `{}` is there: the joints are q1 to qn, \
                     one column per joint of the arm (`_deg`, or `_mm` for a prismatic joint)",
                    q_column(after, unit(after).and_then(Result::ok).unwrap_or_default())
                ),
            },
        ));
    }
    Ok(Header {
        index,
        ignored,
        width: record.len(),
        units,
    })
}

/// The optional column `name` most likely stands for, if any: one within
/// two typing slips of it (`laod_kg`, `load_kgs`), or whose name up to its
/// unit appears in it (`payload_g` for `load_kg`), in any case.
fn misspelt_optional(name: &str, schema: &Schema) -> Option<&'static str> {
    let name = name.to_lowercase();
    schema.optional_columns().find(|optional| {
        let stem = optional.split('_').next().unwrap_or(optional);
        name.contains(stem) || strsim::damerau_levenshtein(&name, optional) <= 2
    })
}
