//! CSV rows read as their lines arrive (a controller's stream, a pipe),
//! with the rules of the whole-file reader, and why such a read can fail.

use csv::{ReaderBuilder, StringRecord, Trim};

use super::Schema;
use super::header::{Header, check_header};
use super::row::Row;
use crate::error::{InputError, Location, Problem};

/// The rows of CSV arriving line by line (a controller's stream on standard
/// input, a pipe), each handed over as soon as its line is complete rather
/// than once the input ends, with the rules of
/// [`for_each_row`](super::for_each_row): header in any order, comments,
/// blank lines, CRLF or lone CR line ends, leading byte order marks. A
/// record is one line (no line breaks inside quotes).
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

/// The cells of one CSV line (trimmed, as
/// [`for_each_row`](super::for_each_row) reads them).
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
