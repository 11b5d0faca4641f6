//! One data row of a CSV file, read through its header: cells by column
//! name, as numbers with their units converted, and errors naming the row's
//! line and the column.

use csv::StringRecord;

use model::{JointKind, PerJoint};

use super::header::Header;
use super::{Q_COLUMNS, Q_MM_COLUMNS};
use crate::error::{InputError, Location, Problem};

/// One data row with its line number, read through the header.
pub struct Row<'a> {
    pub(super) header: &'a Header,
    pub(super) record: &'a StringRecord,
    /// 1-based line of the row in the file.
    pub line: u64,
}

impl Row<'_> {
    /// An error about a cell of this row.
    pub fn error(&self, column: &str, problem: Problem) -> InputError {
        InputError::new(Location::column(self.line, column), problem)
    }

    /// Whether the file has this column.
    pub fn has(&self, column: &str) -> bool {
        self.header.index.contains_key(column)
    }

    /// The text of `column`, if the file has it.
    pub fn text(&self, column: &'static str) -> Option<&str> {
        self.has(column).then(|| self.cell(column))
    }

    /// The text of a column the schema ignores (a pose list reading a
    /// measurement file's `target`), if the file has it.
    pub fn ignored_text(&self, column: &str) -> Option<&str> {
        let &i = self.header.ignored.get(column)?;
        self.record.get(i)
    }

    fn cell(&self, column: &'static str) -> &str {
        // Only called for columns the header check guaranteed, and rows of header width.
        let i = self.header.index[column];
        &self.record[i]
    }

    /// A finite number from `column`; `expected` says what kind (with units) for the error.
    pub fn number(&self, column: &'static str, expected: &'static str) -> Result<f64, InputError> {
        let text = self.cell(column);
        let value: f64 = text.parse().map_err(|_| {
            self.error(
                column,
                Problem::NotANumber {
                    expected,
                    found: text.to_owned(),
                },
            )
        })?;
        if value.is_finite() {
            Ok(value)
        } else {
            Err(self.error(
                column,
                Problem::NotFinite {
                    found: text.to_owned(),
                },
            ))
        }
    }

    /// Like [`Row::number`], and also at least zero.
    pub fn non_negative(
        &self,
        column: &'static str,
        expected: &'static str,
    ) -> Result<f64, InputError> {
        let value = self.number(column, expected)?;
        if value >= 0.0 {
            Ok(value)
        } else {
            Err(self.error(
                column,
                Problem::OutOfRange {
                    expected,
                    found: value.to_string(),
                },
            ))
        }
    }

    /// The `pose` id: a non-negative integer.
    pub fn pose_id(&self) -> Result<u32, InputError> {
        let text = self.cell("pose");
        text.parse().map_err(|_| {
            self.error(
                "pose",
                Problem::NotANumber {
                    expected: "a pose id (integer from 0 to 4294967295)",
                    found: text.to_owned(),
                },
            )
        })
    }

    /// The joint columns' kinds: `qi_deg` revolute, `qi_mm` prismatic.
    pub fn joint_units(&self) -> PerJoint<JointKind> {
        self.header.units
    }

    /// The joint values of the `qi_deg` (to rad) and `qi_mm` (to m) columns.
    pub fn joint_angles_rad(&self) -> Result<PerJoint<f64>, InputError> {
        let units = self.header.units;
        let mut q = PerJoint::splat(units.len(), 0.0);
        for (i, qi) in q.iter_mut().enumerate() {
            *qi = match units[i] {
                JointKind::Revolute => self
                    .number(Q_COLUMNS[i], "a joint angle in degrees")?
                    .to_radians(),
                JointKind::Prismatic => {
                    self.number(Q_MM_COLUMNS[i], "a joint position in mm")? * 1e-3
                }
            };
        }
        Ok(q)
    }
}
