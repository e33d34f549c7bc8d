//! The SQL files of the pipeline (embedded at build time, see build.rs), the DuckDB CLI's
//! `.read` include, statement splitting (the only splitter: every host gets statements from
//! [`crate::plan`]), and the stage list.

use std::error::Error;

include!(concat!(env!("OUT_DIR"), "/sql_files.rs"));

/// The embedded contents of `path` (e.g. `sql/stages/align.sql`).
pub fn file(path: &str) -> Option<&'static str> {
    SQL_FILES.iter().find(|(p, _)| *p == path).map(|(_, t)| *t)
}

/// The file named by a `.read FILE` line (the DuckDB CLI's include).
pub fn read_target(line: &str) -> Option<&str> {
    line.trim().strip_prefix(".read ").map(|f| f.trim().trim_matches(|c| c == '\'' || c == '"'))
}

/// A `.read` file: from disk (path relative to the working directory, as in the DuckDB CLI),
/// or the embedded copy of a `sql/...` file when it is not on disk.
fn load(path: &str) -> Result<String, Box<dyn Error>> {
    match std::fs::read_to_string(path) {
        Ok(t) => Ok(t),
        Err(e) => file(path).map(str::to_string).ok_or_else(|| format!(".read {path}: {e}").into()),
    }
}

/// Replaces every `.read FILE` line by the file's contents (recursively), reading FILE from
/// disk (relative to the working directory, as the DuckDB CLI does) or else the embedded copy.
pub fn expand_reads(sql: &str) -> Result<String, Box<dyn Error>> {
    expand(sql, 0, &load)
}

/// The embedded file `path` with its `.read` lines replaced by the embedded files they name:
/// exactly the SQL this build was made with (the runner never reads SQL from the disk).
pub fn expand_embedded(path: &str) -> Result<String, Box<dyn Error>> {
    let text = file(path).ok_or_else(|| format!("{path} is not an embedded SQL file"))?;
    expand(text, 0, &|f: &str| file(f).map(str::to_string).ok_or_else(|| format!(".read {f}: not an embedded SQL file").into()))
}

type Loader<'a> = &'a dyn Fn(&str) -> Result<String, Box<dyn Error>>;

fn expand(sql: &str, depth: usize, load: Loader<'_>) -> Result<String, Box<dyn Error>> {
    if depth > 16 {
        return Err(".read nested more than 16 levels".into());
    }
    let mut out = String::with_capacity(sql.len());
    for line in sql.lines() {
        match read_target(line) {
            Some(f) => {
                out.push_str(&expand(&load(f)?, depth + 1, load)?);
                out.push_str("\n;\n");
            }
            None => {
                out.push_str(line);
                out.push('\n');
            }
        }
    }
    Ok(out)
}

/// One timed part of a script: the stage it belongs to, the file its text comes from, the text.
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    pub stage: String,
    pub file: String,
    pub sql: String,
}

/// `embedded` SQL cut into timed parts: each `.read sql/stages/NAME.sql` is the stage `NAME`;
/// every other statement (parameters, loading) goes into a part named `setup`. A stage file that
/// itself `.read`s files (sql/stages/align.sql reads sql/stages/align/*.sql, each with its own
/// contract header) gives one part per file it reads, all of the stage `NAME`, each naming its
/// own file. Files are the embedded copies, so the binary runs exactly the SQL it was built with.
pub fn parts(path: &str) -> Result<Vec<Part>, Box<dyn Error>> {
    let mut out: Vec<Part> = Vec::new();
    collect(path, None, &mut out, 0)?;
    Ok(out)
}

fn collect(path: &str, stage: Option<&str>, out: &mut Vec<Part>, depth: usize) -> Result<(), Box<dyn Error>> {
    if depth > 16 {
        return Err(".read nested more than 16 levels".into());
    }
    let text = file(path).ok_or_else(|| format!("{path} is not an embedded SQL file"))?;
    for line in text.lines() {
        match (read_target(line), stage) {
            // a stage file: its own part (or, when it reads files, theirs)
            (Some(f), None) if f.starts_with("sql/stages/") => {
                let name = f.trim_start_matches("sql/stages/").trim_end_matches(".sql").to_string();
                collect(f, Some(&name), out, depth + 1)?;
            }
            (Some(f), Some(s)) => collect(f, Some(s), out, depth + 1)?,
            (Some(f), None) => collect(f, None, out, depth + 1)?,
            (None, st) => {
                let (st, file) = match st {
                    Some(s) => (s.to_string(), path.to_string()),
                    None => ("setup".to_string(), String::new()),
                };
                if out.last().is_none_or(|p| p.stage != st || p.file != file) {
                    out.push(Part { stage: st, file, sql: String::new() });
                }
                let last = out.last_mut().expect("pushed");
                last.sql.push_str(line);
                last.sql.push('\n');
            }
        }
    }
    Ok(())
}

/// The stage names of `sql/stages.sql`, in order.
pub fn stages() -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for p in parts("sql/stages.sql").expect("sql/stages.sql") {
        if p.stage != "setup" && out.last() != Some(&p.stage) {
            out.push(p.stage);
        }
    }
    out
}

/// A SQL string literal (single quotes doubled).
pub fn sql_string(s: &str) -> String {
    format!("'{}'", s.replace('\'', "''"))
}

/// Splits a script into statements at `;`, ignoring semicolons inside quotes and comments.
pub fn split_statements(sql: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut chars = sql.chars().peekable();
    let mut has_code = false;
    while let Some(c) = chars.next() {
        match c {
            '\'' | '"' => {
                cur.push(c);
                has_code = true;
                while let Some(d) = chars.next() {
                    cur.push(d);
                    if d == c {
                        if chars.peek() == Some(&c) {
                            cur.push(chars.next().unwrap());
                        } else {
                            break;
                        }
                    }
                }
            }
            '-' if chars.peek() == Some(&'-') => {
                for d in chars.by_ref() {
                    if d == '\n' {
                        cur.push('\n');
                        break;
                    }
                }
            }
            '/' if chars.peek() == Some(&'*') => {
                chars.next();
                let mut prev = ' ';
                for d in chars.by_ref() {
                    if prev == '*' && d == '/' {
                        break;
                    }
                    prev = d;
                }
                cur.push(' ');
            }
            ';' => {
                if has_code {
                    out.push(std::mem::take(&mut cur));
                }
                cur.clear();
                has_code = false;
            }
            _ => {
                if !c.is_whitespace() {
                    has_code = true;
                }
                cur.push(c);
            }
        }
    }
    if has_code {
        out.push(cur);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_outside_quotes_and_comments() {
        let s = split_statements("SELECT 'a;b'; -- c;d\nSELECT \"x;\" /* ; */ ;  ;");
        assert_eq!(s.len(), 2);
        assert!(s[0].contains("'a;b'"));
        assert!(s[1].contains("\"x;\""));
    }

    #[test]
    fn one_stage_list_for_every_runner() {
        assert_eq!(stages(), ["calibrate", "clean", "quality", "align", "overlap", "merge", "fuse", "cluster"]);
        let p = parts("sql/pipeline.sql").unwrap();
        let mut names: Vec<&str> = p.iter().map(|x| x.stage.as_str()).collect();
        names.dedup();
        assert_eq!(names, ["setup", "calibrate", "clean", "quality", "align", "overlap", "merge", "fuse", "cluster"]);
        assert!(p[0].sql.contains("coalesce(getvariable('merge_eta')") && p[0].sql.contains("pipeline_input"));
        // every part of a stage names the file its text comes from
        for x in p.iter().filter(|x| x.stage != "setup") {
            assert!(file(&x.file).is_some() && x.file.starts_with(&format!("sql/stages/{}", x.stage)), "{x:?}");
        }
        for x in p.iter().filter(|x| x.stage != "setup") {
            let (s, text) = (&x.file, &x.sql);
            // a stage may set a check variable (`SET VARIABLE x_check = (... error() ...)`: prints
            // nothing in the DuckDB CLI), never a parameter
            for l in text.lines().filter(|l| l.trim_start().to_ascii_uppercase().starts_with("SET VARIABLE")) {
                let name = l.split_whitespace().nth(2).unwrap_or("");
                assert!(crate::params::find(name).is_none() && name.ends_with("_check"), "{s}: parameters belong to sql/params.sql: {l}");
            }
        }
    }
}
