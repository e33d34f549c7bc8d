//! The report's data text, as `sql/report.sql` builds it: rows separated by `\x1e`, cells by
//! `\x1f`, the first cell of a row its section, NULL as `\x15`. Numbers are DuckDB's VARCHAR
//! casts (shortest round-trip form), so parsing them back is exact.

use std::collections::HashMap;
use std::fmt;

/// A malformed data text: which section, row and cell, and what was expected.
#[derive(Debug, Clone, PartialEq)]
pub struct DataError(pub String);

impl fmt::Display for DataError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for DataError {}

pub type R<T> = Result<T, DataError>;

/// The rows of every section, in their order.
pub struct Data {
    sections: HashMap<String, Vec<Row>>,
}

/// One row of a section; cells are 0-based after the section name.
pub struct Row {
    section: String,
    index: usize,
    cells: Vec<Option<String>>,
}

impl Data {
    pub fn parse(text: &str) -> Data {
        let mut sections: HashMap<String, Vec<Row>> = HashMap::new();
        for line in text.split('\x1e').filter(|l| !l.is_empty()) {
            let mut cells = line.split('\x1f');
            let section = cells.next().unwrap_or_default().to_string();
            let cells: Vec<Option<String>> = cells.map(|c| if c == "\x15" { None } else { Some(c.to_string()) }).collect();
            let rows = sections.entry(section.clone()).or_default();
            let index = rows.len();
            rows.push(Row { section, index, cells });
        }
        Data { sections }
    }

    /// The rows of `section` (none when it is absent).
    pub fn rows(&self, section: &str) -> &[Row] {
        self.sections.get(section).map_or(&[], Vec::as_slice)
    }

    /// The value of a `meta` row (`[key, value]`).
    pub fn meta(&self, key: &str) -> Option<&str> {
        self.rows("meta").iter().find(|r| r.cells.first().and_then(|c| c.as_deref()) == Some(key)).and_then(|r| r.cells.get(1)?.as_deref())
    }
}

impl Row {
    fn err(&self, k: usize, what: &str) -> DataError {
        let got = match self.cells.get(k) {
            None => "no such cell".to_string(),
            Some(None) => "NULL".to_string(),
            Some(Some(v)) => format!("'{}'", v.chars().take(40).collect::<String>()),
        };
        DataError(format!("section '{}' row {} cell {}: {what}, got {got}", self.section, self.index + 1, k + 1))
    }

    /// Cell `k` as text; NULL is an error.
    pub fn s(&self, k: usize) -> R<String> {
        self.opt_s(k)?.ok_or_else(|| self.err(k, "expected text"))
    }

    /// Cell `k` as text or NULL.
    pub fn opt_s(&self, k: usize) -> R<Option<String>> {
        self.cells.get(k).cloned().ok_or_else(|| self.err(k, "missing cell"))
    }

    pub fn i(&self, k: usize) -> R<i64> {
        self.s(k)?.parse().map_err(|_| self.err(k, "expected an integer"))
    }

    pub fn f(&self, k: usize) -> R<f64> {
        self.opt_f(k)?.ok_or_else(|| self.err(k, "expected a number"))
    }

    pub fn opt_f(&self, k: usize) -> R<Option<f64>> {
        match self.opt_s(k)? {
            None => Ok(None),
            Some(v) => v.parse().map(Some).map_err(|_| self.err(k, "expected a number")),
        }
    }

    /// Cell `k` as `x y,x y,...` points (`report_xy` in sql/report.sql).
    pub fn xy(&self, k: usize) -> R<Vec<(f64, f64)>> {
        let text = self.s(k)?;
        text.split(',')
            .filter(|p| !p.is_empty())
            .map(|p| {
                let mut it = p.split(' ').map(str::parse::<f64>);
                match (it.next(), it.next()) {
                    (Some(Ok(x)), Some(Ok(y))) => Ok((x, y)),
                    _ => Err(self.err(k, "expected 'x y' points")),
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_sections_nulls_and_points() {
        let d = Data::parse("meta\x1finput\x1fa.parquet\x1etransform\x1f1\x1f\x15\x1fnan\x1eroute\x1fcar\x1f1 2,3.5 -4e+20");
        assert_eq!(d.meta("input"), Some("a.parquet"));
        let t = &d.rows("transform")[0];
        assert_eq!(t.i(0).unwrap(), 1);
        assert_eq!(t.opt_f(1).unwrap(), None);
        assert!(t.f(2).unwrap().is_nan());
        assert!(t.f(1).unwrap_err().0.contains("section 'transform' row 1 cell 2"));
        assert_eq!(d.rows("route")[0].xy(1).unwrap(), vec![(1.0, 2.0), (3.5, -4e20)]);
        assert!(d.rows("absent").is_empty());
        assert!(t.s(9).is_err());
    }
}
