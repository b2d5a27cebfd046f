//! CSV through the `csv` crate: located records for the readers, one writer for the tables.
//!
//! Reading skips blank lines and lines starting with `#`, trims fields, and keeps each
//! record's 1-based line number so that every reader can name the file and line of a bad
//! entry. Field counts are checked by the readers (each knows its schema), not here.

use crate::ShellError;

/// One CSV record and the line it starts on.
#[derive(Clone, Debug)]
pub struct Record {
    /// 1-based line number in the source.
    pub line: usize,
    /// Trimmed fields.
    pub fields: Vec<String>,
}

/// Parses CSV `text`; `file` names the source in errors.
pub fn records(text: &str, file: &str) -> Result<Vec<Record>, ShellError> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    // A record's position is where the reader started looking for it, before any comment or
    // blank lines it skipped (and its own line count skips those); find the record's line
    // from the byte offset instead, counting newlines incrementally (offsets only grow).
    let mut counted = (0usize, 1usize); // (byte offset, line number there)
    let mut line_at = |p: Option<&csv::Position>| {
        let Some(p) = p else { return 0 };
        let start = (p.byte() as usize).clamp(counted.0, text.len());
        counted.1 += text.as_bytes()[counted.0..start]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        counted.0 = start;
        let mut line = counted.1;
        for l in text[start..].lines() {
            let l = l.trim();
            if !l.is_empty() && !l.starts_with('#') {
                break;
            }
            line += 1;
        }
        line
    };
    let mut out = Vec::new();
    for r in reader.records() {
        let r = r.map_err(|e| ShellError::Data {
            file: file.into(),
            line: line_at(e.position()),
            problem: format!("not valid CSV: {e}"),
        })?;
        let line = line_at(r.position());
        let fields: Vec<String> = r.iter().map(str::to_owned).collect();
        if fields.iter().all(String::is_empty) {
            continue;
        }
        out.push(Record { line, fields });
    }
    Ok(out)
}

/// Builds a CSV table in memory: a header, then rows of the same length.
pub struct CsvTable {
    writer: csv::Writer<Vec<u8>>,
    columns: usize,
}

impl CsvTable {
    /// A table with the given column names.
    pub fn new(header: &[&str]) -> Self {
        let mut writer = csv::WriterBuilder::new()
            .terminator(csv::Terminator::Any(b'\n'))
            .from_writer(Vec::new());
        writer
            .write_record(header)
            .expect("writing to memory cannot fail");
        Self {
            writer,
            columns: header.len(),
        }
    }

    /// Appends a row; numbers are written with `Display` (shortest round-trip form).
    ///
    /// # Panics
    /// If the row length differs from the header's (a programming error).
    pub fn row<I, T>(&mut self, fields: I)
    where
        I: IntoIterator<Item = T>,
        T: ToString,
    {
        let fields: Vec<String> = fields.into_iter().map(|f| f.to_string()).collect();
        assert_eq!(fields.len(), self.columns, "CSV row {fields:?}");
        self.writer
            .write_record(&fields)
            .expect("writing to memory cannot fail");
    }

    /// The CSV text.
    pub fn finish(self) -> String {
        let bytes = self
            .writer
            .into_inner()
            .unwrap_or_else(|_| unreachable!("flushing to memory cannot fail"));
        String::from_utf8(bytes).expect("CSV of UTF-8 fields is UTF-8")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_keep_line_numbers_and_skip_comments_and_blanks() {
        let r = records("# c\na, b\n\n# x\n1,2,3\n", "f.csv").unwrap();
        assert_eq!(r.len(), 2);
        assert_eq!(
            (r[0].line, r[0].fields.clone()),
            (2, vec!["a".into(), "b".into()])
        );
        assert_eq!((r[1].line, r[1].fields.len()), (5, 3));
    }

    #[test]
    fn table_round_trips_through_records() {
        let mut t = CsvTable::new(&["name", "x"]);
        t.row(["a,b".to_string(), 0.1.to_string()]);
        t.row(["c".to_string(), String::new()]);
        let text = t.finish();
        let r = records(&text, "t").unwrap();
        assert_eq!(r[1].fields, ["a,b", "0.1"]);
        assert_eq!(r[2].fields, ["c", ""]);
    }
}
