//! Tables of time series (CSV): a header row of names, then rows of numbers, comma- or
//! semicolon-separated (decimal commas in the Spanish locale), streamed row by row.
//!
//! In: a file or any reader, named in messages. Out: [`Signal`] for a plain `time_s,value` file
//! ([`Signal::from_csv`]), [`CsvTable`] for a whole table, [`CsvRows`] for a long one read as it
//! streams (another instrument's ride, `crate::ride::csv`). Every number is checked finite where
//! it is read; errors name the file, the line and the column.

use crate::signal::{not_advancing, sampling_grid, Signal, SignalError, MIN_SAMPLES};
use std::path::{Path, PathBuf};

impl Signal {
    /// Reads a plain CSV `time_s,value` signal (a header row, then rows). The sampling must be
    /// uniform; the rate is taken from the median step, and a row off the grid is an error.
    pub fn from_csv(path: &Path) -> Result<Signal, SignalError> {
        let file = crate::read::kind::open_text(path).map_err(|e| SignalError::Invalid {
            path: path.to_path_buf(),
            line: e.line.unwrap_or(0) as usize,
            message: e.message,
        })?;
        Signal::from_csv_reader(file, path)
    }

    /// As [`Signal::from_csv`], from any reader; `path` names it in messages.
    pub fn from_csv_reader<R: std::io::Read>(
        reader: R,
        path: &Path,
    ) -> Result<Signal, SignalError> {
        let table = CsvTable::read(reader, path)?;
        if table.headers.len() < 2 {
            return Err(table.error(
                1,
                1,
                format!(
                    "expected the columns time_s,value, found {} column(s)",
                    table.headers.len()
                ),
            ));
        }
        let mut columns = table.columns(&[0, 1])?.into_iter();
        let (t, v) = (
            columns.next().unwrap_or_default(),
            columns.next().unwrap_or_default(),
        );
        let (dt, index) = table.sampling_grid(&t)?;
        Ok(Signal {
            name: table.headers[1].clone(),
            unit: String::new(),
            sample_rate_hz: 1.0 / dt,
            t0_s: t[0],
            index,
            values: v,
        })
    }
}

/// A CSV file of named columns, read whole: fields are parsed as numbers only in the columns
/// asked for ([`CsvTable::columns`]), so that a timestamp or a label column elsewhere is no
/// error. Every error names the file, the line and the column.
pub struct CsvTable {
    pub path: PathBuf,
    /// The header's names, trimmed.
    pub headers: Vec<String>,
    /// Each data row with its line in the file.
    rows: Vec<(u64, csv::ByteRecord)>,
}

impl CsvTable {
    /// Reads a CSV with a header row; every row must have the header's number of fields. A
    /// first row of numbers only is no header but the first sample: the columns are then named
    /// `column 1`, `column 2`, … (a file written without its header row loses no sample and
    /// gets no number for a name). [`CsvRows`] reads the same row by row.
    pub fn read<R: std::io::Read>(reader: R, path: &Path) -> Result<CsvTable, SignalError> {
        let mut rows = CsvRows::open(reader, path)?;
        let mut kept = Vec::new();
        while let Some(line) = rows.next_row()? {
            kept.push((line, rows.record().clone()));
        }
        Ok(CsvTable {
            path: path.to_path_buf(),
            headers: rows.headers,
            rows: kept,
        })
    }

    /// An error at `line`, `column` of this file.
    pub fn error(&self, line: u64, column: usize, message: String) -> SignalError {
        csv_error(&self.path, line, column, message)
    }

    /// The index of the first column named any of `names`: an exact match first (a file may
    /// have both `Time` and `time`), else one that differs in case only.
    pub fn find(&self, names: &[&str]) -> Option<usize> {
        find_column(&self.headers, names)
    }

    /// The line of each data row in the file.
    pub fn lines(&self) -> Vec<u64> {
        self.rows.iter().map(|(l, _)| *l).collect()
    }

    /// The columns `which` as finite numbers, parsed row by row (the first bad field in the
    /// file is the one named).
    pub fn columns(&self, which: &[usize]) -> Result<Vec<Vec<f64>>, SignalError> {
        let mut out = vec![Vec::with_capacity(self.rows.len()); which.len()];
        for (line, rec) in &self.rows {
            for (col_out, &k) in out.iter_mut().zip(which) {
                col_out.push(number(&self.path, &self.headers, *line, rec, k)?);
            }
        }
        Ok(out)
    }

    /// Checks that the times `t` (s, one per row) advance from row to row; the first that does
    /// not is named by its line.
    pub fn advancing(&self, t: &[f64]) -> Result<(), SignalError> {
        match not_advancing(t) {
            Some((i, message)) => Err(self.error(self.rows.get(i).map_or(0, |r| r.0), 1, message)),
            None => Ok(()),
        }
    }

    /// The sampling grid of the times `t` (s, one per row): [`sampling_grid`], its errors at
    /// their row's line.
    pub fn sampling_grid(&self, t: &[f64]) -> Result<(f64, Vec<u64>), SignalError> {
        let lines = self.lines();
        if t.len() < MIN_SAMPLES {
            return Err(SignalError::Invalid {
                path: self.path.clone(),
                line: lines.last().copied().unwrap_or(1) as usize,
                message: format!("only {} samples: too few for a signal", t.len()),
            });
        }
        self.advancing(t)?;
        sampling_grid(t).map_err(|(i, message)| self.error(lines[i], 1, message))
    }
}

/// An error at `line`, `column` of the CSV file `path`.
fn csv_error(path: &Path, line: u64, column: usize, message: String) -> SignalError {
    SignalError::Csv {
        path: path.to_path_buf(),
        line,
        column,
        message,
    }
}

/// Field `k` of `rec` (at `line` of `path`), its blanks trimmed, as a finite number; the error
/// names the line and the field's column in characters.
fn number(
    path: &Path,
    headers: &[String],
    line: u64,
    rec: &csv::ByteRecord,
    k: usize,
) -> Result<f64, SignalError> {
    let field = rec.get(k).unwrap_or(b"").trim_ascii();
    crate::read::log::plain_decimal(field)
        .or_else(|| std::str::from_utf8(field).ok()?.parse::<f64>().ok())
        .filter(|x| x.is_finite())
        .ok_or_else(|| SignalError::Csv {
            path: path.to_path_buf(),
            line,
            column: field_column(rec, k),
            message: format!(
                "`{}` in column {}: expected a finite number",
                String::from_utf8_lossy(field),
                headers.get(k).map_or("?", String::as_str)
            ),
        })
}

/// The column (in characters, from 1) where field `k` of `rec` begins, past its leading
/// blanks: the fields before it and their separators.
fn field_column(rec: &csv::ByteRecord, k: usize) -> usize {
    let chars = |f: &[u8]| String::from_utf8_lossy(f).chars().count();
    let field = rec.get(k).unwrap_or(b"");
    1 + (0..k)
        .map(|j| rec.get(j).map_or(0, chars) + 1)
        .sum::<usize>()
        + (field.len() - field.trim_ascii_start().len())
}

/// The csv reader of [`CsvRows`]: every record a row (the header is read as one), rows of any
/// length (counted against the header's by [`CsvRows::next_row`]).
fn rows_reader<R: std::io::Read>(reader: R) -> csv::Reader<R> {
    csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(reader)
}

/// A CSV of named columns read row by row, one record held at a time (a recording of millions
/// of rows in bounded memory); the same rules and errors as [`CsvTable::read`].
pub struct CsvRows<R: std::io::Read> {
    reader: csv::Reader<R>,
    pub path: PathBuf,
    /// The header's names, trimmed (`column 1`, … when the file has none).
    pub headers: Vec<String>,
    /// The first row, when it was a sample and not a header, until it is read.
    first: Option<csv::ByteRecord>,
    record: csv::ByteRecord,
}

impl<R: std::io::Read> CsvRows<R> {
    /// Reads the header row (or takes a first row of numbers only as the first sample).
    pub fn open(reader: R, path: &Path) -> Result<CsvRows<R>, SignalError> {
        let mut reader = rows_reader(reader);
        let err =
            |line: u64, column: usize, message: String| csv_error(path, line, column, message);
        // The header as text (its names trimmed); the rows as bytes, each field trimmed and
        // read as text only where a number is asked of it.
        let mut first = csv::StringRecord::new();
        reader
            .read_record(&mut first)
            .map_err(|e| err(1, 1, e.to_string()))?;
        first.trim();
        if first.len() == 1 && first.get(0).is_some_and(|f| f.contains(';')) {
            return Err(err(
                1,
                1,
                "fields separated by ';' (a spreadsheet's export for decimal commas?): bikeproc \
                 reads comma-separated values with a point as the decimal mark"
                    .into(),
            ));
        }
        if first.len() == 1 && first.get(0).is_some_and(|f| f.contains('\t')) {
            return Err(err(
                1,
                1,
                "fields separated by tabs: bikeproc reads comma-separated values (`tr '\\t' \
                 ,` converts a tab-separated file)"
                    .into(),
            ));
        }
        let numbers_only = !first.is_empty()
            && first
                .iter()
                .all(|f| f.parse::<f64>().is_ok_and(|x| x.is_finite()));
        let (headers, first) = if numbers_only {
            (
                (1..=first.len()).map(|k| format!("column {k}")).collect(),
                Some(first.into_byte_record()),
            )
        } else {
            (first.iter().map(str::to_string).collect::<Vec<_>>(), None)
        };
        for (j, h) in headers.iter().enumerate() {
            if let Some(i) = headers[..j].iter().position(|g| g == h && !h.is_empty()) {
                return Err(err(
                    1,
                    j + 1,
                    format!(
                        "column `{h}` twice (columns {} and {}): which one is meant is not known",
                        i + 1,
                        j + 1
                    ),
                ));
            }
        }
        Ok(CsvRows {
            reader,
            path: path.to_path_buf(),
            headers,
            first,
            record: csv::ByteRecord::new(),
        })
    }

    /// Rows of a table whose header was read elsewhere: `reader` starts at a row's start (a
    /// part of a file read beside the part before it, its lines numbered from 1).
    pub fn headless(reader: R, path: &Path, headers: Vec<String>) -> CsvRows<R> {
        CsvRows {
            reader: rows_reader(reader),
            path: path.to_path_buf(),
            headers,
            first: None,
            record: csv::ByteRecord::new(),
        }
    }

    /// The input read from.
    pub fn get_ref(&self) -> &R {
        self.reader.get_ref()
    }

    /// Where the next row starts (at the end: the end of the input).
    pub fn position(&self) -> &csv::Position {
        self.reader.position()
    }

    /// Reads the next row into [`CsvRows::record`] and gives its line; `None` at the end.
    pub fn next_row(&mut self) -> Result<Option<u64>, SignalError> {
        let err = |line: u64, message: String| csv_error(&self.path, line, 1, message);
        if let Some(first) = self.first.take() {
            self.record = first;
        } else {
            match self.reader.read_byte_record(&mut self.record) {
                Ok(true) => {}
                Ok(false) => return Ok(None),
                Err(e) => {
                    let line = e.position().map_or(0, |p| p.line());
                    return Err(err(line, e.to_string()));
                }
            }
        }
        let line = self.record.position().map_or(0, |p| p.line());
        // Text throughout, as the header is; checked on the row's bytes at once (a fifth of the
        // reading went to checking and trimming field by field).
        if let Err(e) = std::str::from_utf8(self.record.as_slice()) {
            let field = (0..self.record.len())
                .find(|&k| {
                    self.record
                        .range(k)
                        .is_some_and(|r| r.end > e.valid_up_to())
                })
                .unwrap_or(0);
            return Err(csv_error(
                &self.path,
                line,
                field_column(&self.record, field),
                format!("bytes that are not UTF-8 text in field {}", field + 1),
            ));
        }
        if self.record.len() != self.headers.len() {
            let hint = if self.record.len() > self.headers.len() {
                " (decimal commas? bikeproc reads a point as the decimal mark and a comma \
                 between fields)"
            } else {
                ""
            };
            return Err(err(
                line,
                format!(
                    "{} fields, expected {}{hint}",
                    self.record.len(),
                    self.headers.len()
                ),
            ));
        }
        Ok(Some(line))
    }

    /// An error at `line`, `column` of this file.
    pub fn error(&self, line: u64, column: usize, message: String) -> SignalError {
        csv_error(&self.path, line, column, message)
    }

    /// The row last read.
    pub fn record(&self) -> &csv::ByteRecord {
        &self.record
    }

    /// Field `k` of the row last read (at `line`) as a finite number.
    pub fn number(&self, line: u64, k: usize) -> Result<f64, SignalError> {
        number(&self.path, &self.headers, line, &self.record, k)
    }

    /// The index of the first column named any of `names` ([`CsvTable::find`]'s rule).
    pub fn find(&self, names: &[&str]) -> Option<usize> {
        find_column(&self.headers, names)
    }
}

impl<R: std::io::Read + std::io::Seek> CsvRows<R> {
    /// Reads on from `position`, the start of a row as [`csv::ByteRecord::position`] gave it
    /// on an earlier read of the same file (its lines numbered on from there).
    pub fn seek(&mut self, position: csv::Position) -> Result<(), SignalError> {
        self.first = None;
        let line = position.line();
        self.reader
            .seek(position)
            .map_err(|e| csv_error(&self.path, line, 1, format!("cannot read on here: {e}")))
    }
}

/// The index of the first of `headers` named any of `names`: an exact match first (a file may
/// have both `Time` and `time`), else one that differs in case only.
fn find_column(headers: &[String], names: &[&str]) -> Option<usize> {
    names
        .iter()
        .find_map(|n| headers.iter().position(|h| h == n))
        .or_else(|| {
            names
                .iter()
                .find_map(|n| headers.iter().position(|h| h.eq_ignore_ascii_case(n)))
        })
}
