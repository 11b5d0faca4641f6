//! The CSV reading shared by measurements, pose lists and predictions.
//!
//! Accepted: a header line naming the columns in any order, `#` comment lines
//! anywhere, blank lines, spaces around cells. Columns whose name starts with
//! [`NOTE_PREFIX`] (`note_time`, `note_rms`, …) are carried along by other
//! tools and ignored here. What happens to any other column the file kind does
//! not define is the schema's [`Extra`]: measurements and predictions refuse
//! it, listing the expected columns, so that a misspelt column cannot pass
//! unnoticed; pose lists ignore it, since any file with the pose columns (a
//! measurement file, a spreadsheet of poses) is a pose list, but still refuse
//! a column that looks like a misspelt optional one (`load` for `load_kg`),
//! which would otherwise silently turn into its default.

use std::collections::HashMap;

use csv::{ReaderBuilder, StringRecord, Trim};

use model::{JointKind, PerJoint};

use crate::dataset::TargetName;
use crate::error::{InputError, Location, Problem};
use crate::io::record_line;

/// Columns starting with this are ignored by every reader.
pub const NOTE_PREFIX: &str = "note_";

/// The joint angle columns, in joint order: a file has the first `n`, one
/// per joint of its arm.
pub const Q_COLUMNS: [&str; model::MAX_JOINTS] = [
    "q1_deg", "q2_deg", "q3_deg", "q4_deg", "q5_deg", "q6_deg", "q7_deg", "q8_deg", "q9_deg",
    "q10_deg",
];

/// The joint columns of a prismatic joint, its value in mm, in joint order:
/// joint `i`'s column is `qi_deg` or `qi_mm`, as the joint turns or slides.
pub const Q_MM_COLUMNS: [&str; model::MAX_JOINTS] = [
    "q1_mm", "q2_mm", "q3_mm", "q4_mm", "q5_mm", "q6_mm", "q7_mm", "q8_mm", "q9_mm", "q10_mm",
];

/// The joint column of joint `i` (from 0) of `kind`: `q3_deg`, `q1_mm`.
pub fn q_column(i: usize, kind: JointKind) -> &'static str {
    match kind {
        JointKind::Revolute => Q_COLUMNS[i],
        JointKind::Prismatic => Q_MM_COLUMNS[i],
    }
}

/// The joint-angle columns that may be absent: all but the first (a file
/// of an arm of `n` joints has `q1_deg` to `qn_deg`).
const OPTIONAL_Q_COLUMNS: [&str; model::MAX_JOINTS - 1] = [
    "q2_deg", "q3_deg", "q4_deg", "q5_deg", "q6_deg", "q7_deg", "q8_deg", "q9_deg", "q10_deg",
];

/// The position columns.
pub const XYZ_COLUMNS: [&str; 3] = ["x_mm", "y_mm", "z_mm"];

/// The columns of one kind of file.
pub struct Schema {
    /// Every column, in the order writers write them.
    pub columns: &'static [&'static str],
    /// Those of `columns` that may be absent, besides the joint columns
    /// after the first (`OPTIONAL_Q_COLUMNS`: an arm has as many as it has joints).
    pub optional: &'static [&'static str],
    /// What to do with other columns.
    pub extra: Extra,
}

impl Schema {
    /// The columns of `columns` that may be absent: `optional` and the joint
    /// columns after the first.
    fn optional_columns(&self) -> impl Iterator<Item = &'static str> + '_ {
        let joints = OPTIONAL_Q_COLUMNS
            .iter()
            .filter(|c| self.columns.contains(c));
        self.optional.iter().chain(joints).copied()
    }
}

/// What a reader does with a column its kind of file does not define.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Extra {
    /// Refuse it, listing the expected columns.
    Refuse,
    /// Ignore it, unless it looks like an optional column misspelt or in
    /// another unit (`laod_kg`, `payload_g` for `load_kg`): that must not silently
    /// become the optional column's default.
    Ignore,
}

impl Schema {
    /// The columns for messages, the joint angles as one run `q1_deg..qn_deg`.
    fn expected(&self) -> String {
        let mut names: Vec<&str> = Vec::new();
        for c in self.columns {
            if Q_COLUMNS[1..].contains(c) {
                continue;
            }
            names.push(if *c == Q_COLUMNS[0] {
                "q1_deg..qn_deg (one per joint)"
            } else {
                c
            });
        }
        names.join(",")
    }
}

/// A parsed header: column name -> position.
struct Header {
    index: HashMap<&'static str, usize>,
    /// The columns the schema ignores ([`Extra::Ignore`]), by name.
    ignored: HashMap<String, usize>,
    width: usize,
    /// Each joint column's kind, `qi_deg` (revolute) or `qi_mm` (prismatic):
    /// as many as the arm has joints.
    units: PerJoint<JointKind>,
}

impl Header {
    /// Refuses a record (on `line`) whose field count is not the header's.
    fn check_width(&self, record: &StringRecord, line: u64) -> Result<(), InputError> {
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

/// One data row with its line number, read through the header.
pub struct Row<'a> {
    header: &'a Header,
    record: &'a StringRecord,
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

/// Calls `each` for every data row of `text`, after checking the header against
/// `schema`. Returns the number of rows; a file without rows is an error.
pub fn for_each_row(
    text: &str,
    schema: &Schema,
    mut each: impl FnMut(&Row<'_>) -> Result<(), InputError>,
) -> Result<usize, InputError> {
    // Every leading byte order mark: a file saved by tools that each add one.
    let mut text = crate::io::lf_line_ends(text.trim_start_matches('\u{feff}'));
    // The `csv` crate reads a last `#` line without a line end as a record,
    // not a comment.
    if !text.is_empty() && !text.ends_with('\n') {
        text.to_mut().push('\n');
    }
    let mut reader = ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(Trim::All)
        // Field counts are checked here, to name the line and both counts.
        .flexible(true)
        .from_reader(text.as_bytes());
    let header_record = reader.headers().map_err(csv_error)?.clone();
    let header_line = record_line(&text, header_record.position(), Some(b'#')).max(1);
    let header = check_header(&header_record, header_line, schema)?;
    let mut record = StringRecord::new();
    let mut rows = 0;
    while reader.read_record(&mut record).map_err(csv_error)? {
        let line = record_line(&text, record.position(), Some(b'#'));
        header.check_width(&record, line)?;
        each(&Row {
            header: &header,
            record: &record,
            line,
        })?;
        rows += 1;
    }
    if rows == 0 {
        return Err(InputError::new(
            Location::line(header_line),
            Problem::NoRows,
        ));
    }
    Ok(rows)
}

/// The rows of CSV arriving line by line (a controller's stream on standard
/// input, a pipe), each handed over as soon as its line is complete rather
/// than once the input ends, with the rules of [`for_each_row`]: header in
/// any order, comments, blank lines, CRLF or lone CR line ends, leading
/// byte order marks. A record is one line (no line breaks inside quotes).
pub struct LineRows<R> {
    reader: R,
    schema: &'static Schema,
    header: Option<(Header, u64)>,
    /// Lines read so far (the last line's number).
    line: u64,
    rows: usize,
    /// Logical lines of the last chunk read, not yet handed over (a lone CR
    /// ends a line inside a chunk), with their numbers.
    pending: std::collections::VecDeque<(u64, String)>,
}

impl<R: std::io::BufRead> LineRows<R> {
    /// Rows of `reader` for a file of kind `schema`.
    pub fn new(reader: R, schema: &'static Schema) -> Self {
        Self {
            reader,
            schema,
            header: None,
            line: 0,
            rows: 0,
            pending: Default::default(),
        }
    }

    /// Calls `each` with the next data row, blocking until its line has
    /// arrived; `Ok(None)` when the input ends (an error if it had no rows).
    pub fn next_row<T>(
        &mut self,
        each: impl FnOnce(&Row<'_>) -> Result<T, InputError>,
    ) -> Result<Option<T>, ReadError> {
        loop {
            let Some((line, text)) = self.next_line()? else {
                return match &self.header {
                    None => Err(check_header(&StringRecord::new(), 1, self.schema)
                        .err()
                        .unwrap_or_else(|| InputError::new(Location::line(1), Problem::NoRows))
                        .into()),
                    Some((_, header_line)) if self.rows == 0 => {
                        Err(InputError::new(Location::line(*header_line), Problem::NoRows).into())
                    }
                    Some(_) => Ok(None),
                };
            };
            // As the `csv` crate skips them: empty lines and those starting
            // with `#` (a line of spaces is a record of one empty cell).
            if text.is_empty() || text.starts_with('#') {
                continue;
            }
            let record = one_record(&text, line)?;
            let Some((header, _)) = &self.header else {
                self.header = Some((check_header(&record, line, self.schema)?, line));
                continue;
            };
            header.check_width(&record, line)?;
            let value = each(&Row {
                header,
                record: &record,
                line,
            })?;
            self.rows += 1;
            return Ok(Some(value));
        }
    }

    /// The next logical line and its number, without its line end.
    fn next_line(&mut self) -> Result<Option<(u64, String)>, ReadError> {
        if let Some(next) = self.pending.pop_front() {
            return Ok(Some(next));
        }
        let mut bytes = Vec::new();
        if self
            .reader
            .read_until(b'\n', &mut bytes)
            .map_err(ReadError::Read)?
            == 0
        {
            return Ok(None);
        }
        while self.line == 0 && bytes.starts_with(BOM) {
            bytes.drain(..BOM.len());
        }
        if bytes.last() == Some(&b'\n') {
            bytes.pop();
            if bytes.last() == Some(&b'\r') {
                bytes.pop();
            }
        }
        let text = String::from_utf8(bytes).map_err(|e| {
            let at = e.utf8_error().valid_up_to();
            let before = &e.as_bytes()[..at];
            // A lone CR before the bad byte ended lines of its own.
            let crs = before.iter().filter(|&&b| b == b'\r').count() as u64;
            let line_start = before
                .iter()
                .rposition(|&b| b == b'\r')
                .map_or(0, |i| i + 1);
            InputError::new(
                Location::line(self.line + 1 + crs),
                Problem::NotUtf8 {
                    byte: e.as_bytes()[at],
                    column: at - line_start + 1,
                },
            )
        })?;
        for piece in text.split('\r') {
            self.line += 1;
            self.pending.push_back((self.line, piece.to_owned()));
        }
        Ok(self.pending.pop_front())
    }
}

/// The UTF-8 byte order mark.
const BOM: &[u8] = "\u{feff}".as_bytes();

/// The cells of one CSV line (trimmed, as [`for_each_row`] reads them).
///
/// A quoted cell left open at the line's end is refused: a whole file's
/// reader would carry it on over the next lines, a stream cannot wait for
/// them.
fn one_record(text: &str, line: u64) -> Result<StringRecord, InputError> {
    let syntax =
        |message: String| InputError::new(Location::line(line), Problem::Syntax { message });
    // Ended by a line break and a character trimming keeps, which only an
    // open quote takes into a cell (`text` holds no line break).
    let ended = format!("{text}\n\u{1}");
    let mut reader = ReaderBuilder::new()
        .has_headers(false)
        .trim(Trim::All)
        .flexible(true)
        .from_reader(ended.as_bytes());
    let mut record = StringRecord::new();
    reader
        .read_record(&mut record)
        .map_err(|e| syntax(e.to_string()))?;
    if record.iter().any(|cell| cell.contains('\n')) {
        return Err(syntax(
            "a quoted cell is not closed on its line (each record is one line)".into(),
        ));
    }
    // The `csv` crate drops a byte order mark at the start of what it reads,
    // here every line; in a whole file only the first line's goes.
    if text.starts_with('\u{feff}') {
        let mut kept = StringRecord::new();
        for (i, cell) in record.iter().enumerate() {
            match i {
                0 => kept.push_field(&format!("\u{feff}{cell}")),
                _ => kept.push_field(cell),
            }
        }
        return Ok(kept);
    }
    Ok(record)
}

/// Why [`LineRows`] gave no row.
#[derive(Debug)]
pub enum ReadError {
    /// The input could not be read.
    Read(std::io::Error),
    /// A line is not what the kind of file holds.
    Input(InputError),
}

impl From<InputError> for ReadError {
    fn from(e: InputError) -> Self {
        Self::Input(e)
    }
}

fn check_header(record: &StringRecord, line: u64, schema: &Schema) -> Result<Header, InputError> {
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

fn csv_error(error: csv::Error) -> InputError {
    let line = error.position().map(|p| p.line());
    InputError::new(
        Location { line, field: None },
        Problem::Syntax {
            message: error.to_string(),
        },
    )
}

/// Tracks pose ids across rows: each (pose, load, target) once, and one configuration per id.
#[derive(Default)]
pub struct PoseBook {
    seen_load: HashMap<(u32, Option<u64>, Option<TargetName>), u64>,
    seen_q: HashMap<u32, (PerJoint<f64>, u64)>,
}

impl PoseBook {
    /// Records a row (`load_kg` None: the file has no loads) measuring
    /// `target`; errors if its (pose, load, target) was seen, or its pose id
    /// had other angles.
    pub fn record(
        &mut self,
        row: &Row<'_>,
        pose: u32,
        q: &PerJoint<f64>,
        load_kg: Option<f64>,
        target: Option<TargetName>,
    ) -> Result<(), InputError> {
        let key = (pose, load_kg.map(f64::to_bits), target);
        if let Some(&first_line) = self.seen_load.get(&key) {
            let problem = match load_kg {
                Some(load_kg) => Problem::DuplicatePose {
                    pose,
                    load_kg,
                    first_line,
                },
                None => Problem::DuplicatePoseId { pose, first_line },
            };
            return Err(row.error("pose", problem));
        }
        self.seen_load.insert(key, row.line);
        match self.seen_q.get(&pose) {
            // Angles parsed from the same text are bit-identical; a tolerance
            // only forgives a tool that rounds differently between rows.
            Some((q0, first_line)) if q0.iter().zip(q).any(|(a, b)| (a - b).abs() > 1e-9) => {
                Err(row.error(
                    "pose",
                    Problem::InconsistentPose {
                        pose,
                        first_line: *first_line,
                    },
                ))
            }
            Some(_) => Ok(()),
            None => {
                self.seen_q.insert(pose, (*q, row.line));
                Ok(())
            }
        }
    }
}

/// A number with at most `decimals` decimals, trailing zeros dropped, never `-0`.
///
/// Files are read by people and spreadsheets: `540` beats `539.9999999999999`,
/// and 1e-6 mm or 1e-9 deg is far below anything a tracker or servo resolves.
pub fn format_fixed(value: f64, decimals: usize) -> String {
    let text = format!("{value:.decimals$}");
    let text = if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.')
    } else {
        &text
    };
    if text == "-0" {
        "0".to_owned()
    } else {
        text.to_owned()
    }
}

/// Millimetres as written to files (1 nm resolution).
pub fn format_mm(value_m: f64) -> String {
    format_fixed(value_m * 1000.0, 6)
}

/// Degrees as written to files (1e-9 deg resolution).
pub fn format_deg(value_rad: f64) -> String {
    format_fixed(value_rad.to_degrees(), 9)
}

/// A joint value for its column: a revolute joint's in degrees
/// ([`format_deg`]), a prismatic one's in mm to the nanometre.
pub fn format_joint(kind: JointKind, value: f64) -> String {
    match kind {
        JointKind::Revolute => format_deg(value),
        JointKind::Prismatic => format_fixed(value * 1e3, 6),
    }
}
