//! The pipeline manifest: every statement of one run, in order, each with its stage, the file
//! it comes from, the table (or macro) it makes, and the statement that undoes it if a later
//! one fails. This is THE runner's logic (parameters resolved and checked, `.read` expanded,
//! statements split, the results folder claimed and committed); a host only executes the rows:
//!
//! - `CALL trajdb_pipeline(...)` (the extension, any host) executes them on its own connection;
//! - `trajdb.pipeline` (Python) and `trajdb.windows` execute the rows of `trajdb_stages(...)` on
//!   the caller's connection (so that registered DataFrames and the result tables are the
//!   caller's), with no SQL parsing of their own;
//! - the DuckDB CLI `.read sql/pipeline.sql` runs the same files.
//!
//! A host's whole loop: execute each row's `sql`; after a row succeeds, remember its `undo`
//! (when not empty); when a row fails, execute the remembered undos last-first and report the
//! failure with the row's stage and file.
//!
//! Parts: [`Part::All`] is a whole run; [`Part::Site`] and [`Part::Window`] split one run of a
//! large archive into a site's calibration (once) and windows that reuse it (python/trajdb/
//! windows.py ships the [`SITE_TABLES`] between them; sql/window.sql explains why a window then
//! equals the whole run). [`Part::Day`] is an archive's day (src/archive/task.rs): a whole
//! run with its results folder on a site's calibration kept from an earlier day.

use super::{params, sql};
use std::error::Error;

/// Made once per site (calibrate.sql, align.sql, overlap.sql, and the camera views of
/// quality.sql) and shipped to every window of the site: the sampling periods and noise, the
/// derived parameters, the cameras' transforms and clock offsets, the view polygons and their
/// overlaps. Measuring any of them on one window instead would change the results.
pub const SITE_TABLES: &[&str] = &[
    "calib_camera_order", "calib_cameras", "calib_classes", "calib_pairs", "calibration", "calib_fit_window", "quality_views", "quality_start_density",
    "quality_starts", "quality_pi",
    "align_frames", "align_origin", "calib_match", "calibration_summary",
    "view_polygons", "view_overlaps", "view_merge_order", "view_overlaps_chain",
    // the camera pairs' fits (sql/warnings.sql reads their perspective terms: an archive's day
    // warns as its calibration day did)
    "align_pairs",
];

/// The stages a site computes once and a window never recomputes: a window takes their tables
/// from the site ([`SITE_TABLES`]) and skips their intermediate ones ([`site_work_tables`]); it
/// keeps only their statements that put `points` into the common frame and clock and their
/// `result_*()` macros.
pub const SITE_ONLY_STAGES: &[&str] = &["align", "overlap"];

/// The intermediate tables (and macros) of the [`SITE_ONLY_STAGES`]: everything their files'
/// contract headers list under `makes:` or `work:` that is not a [`SITE_TABLES`] entry, `points`
/// or a `result_*()` macro. Made by the site run only, never shipped, skipped by a window. Read
/// from the headers (checked against the SQL by tests/check_stage_contracts.py), so a table added
/// to a file is skipped without a second list to keep.
pub fn site_work_tables() -> Result<Vec<String>, Box<dyn Error>> {
    let mut out: Vec<String> = Vec::new();
    for p in sql::parts("sql/pipeline.sql")? {
        if !SITE_ONLY_STAGES.contains(&p.stage.as_str()) {
            continue;
        }
        for field in ["makes", "work"] {
            for name in sql::header_list(&p.file, field)? {
                if !SITE_TABLES.contains(&name.as_str()) && name != "points" && !name.starts_with("result_") && !out.contains(&name) {
                    out.push(name);
                }
            }
        }
    }
    Ok(out)
}

/// The stages a site's calibration runs (and nothing after them).
pub const CALIBRATION_STAGES: &[&str] = &["calibrate", "clean", "quality", "align", "overlap"];

/// The stages a window skips: clustering is an analysis of a whole period, not of a window
/// (run traj_cluster on the road users).
pub const WINDOW_SKIPS_STAGES: &[&str] = &["cluster"];

/// Which statements of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Part {
    /// The whole pipeline; with a results folder also the result files and report.html.
    All,
    /// A site's calibration: the load and [`CALIBRATION_STAGES`].
    Site,
    /// One window: the load, every stage statement that makes no site table, then sql/window.sql
    /// (the host creates the [`SITE_TABLES`] first and sets window_start, window_end,
    /// loaded_from and loaded_to).
    Window,
    /// One day of an archive (issue 40, src/archive/task.rs): the whole pipeline, with a
    /// results folder, on a calibration kept from an earlier day: every statement that makes no
    /// site table (the host creates the [`SITE_TABLES`] first, as for a window).
    Day,
}

impl Part {
    pub fn parse(s: &str) -> Result<Part, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "all" | "" => Ok(Part::All),
            "site" => Ok(Part::Site),
            "window" => Ok(Part::Window),
            "day" => Ok(Part::Day),
            other => Err(format!("part must be 'all', 'site', 'window' or 'day', got {other:?}")),
        }
    }
}

/// One statement of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    /// `params`, `load`, a stage name of sql/stages.sql, `warnings`, `write`, `report` or `window`.
    pub stage: String,
    /// The SQL file it comes from (`sql/stages/align.sql`; generated statements name the
    /// function that generates them).
    pub file: String,
    /// One SQL statement (no trailing `;`).
    pub sql: String,
    /// The table, view or macro it creates or changes ([`statement_target`]).
    pub makes: Option<String>,
    /// Executed (last-first) when a later statement fails, if this one succeeded.
    pub undo: Option<String>,
}

/// What one run is: the input (a file, glob or table name, never SQL), the results folder,
/// the part and the parameter values given (`name`, `value` as text; checked here).
#[derive(Clone, Debug)]
pub struct Request {
    pub input: String,
    pub out: Option<String>,
    pub part: Part,
    pub params: Vec<(String, String)>,
}

/// The table a statement creates or changes ([`statement_action`]'s name); `None` for anything else.
pub fn statement_target(stmt: &str) -> Option<String> {
    statement_action(stmt).map(|(_, name)| name)
}

/// The tokens of a statement, lower case, for the readers below: a name is one token, dotted
/// parts and quoted parts included (`temp.main."My T"` is `temp.main.my t`); a string literal is
/// the token `'`; any other character is a token of its own (`(`, `,`, `;`, ...). Comments (`--`
/// to the end of the line, `/* */`) are skipped. O(length).
fn tokens(stmt: &str) -> Vec<String> {
    let c: Vec<char> = stmt.chars().collect();
    let (mut out, mut k) = (Vec::new(), 0);
    let word = |ch: char| ch.is_alphanumeric() || ch == '_' || ch == '$';
    while k < c.len() {
        let ch = c[k];
        if ch.is_whitespace() {
            k += 1;
        } else if ch == '-' && c.get(k + 1) == Some(&'-') {
            while k < c.len() && c[k] != '\n' {
                k += 1;
            }
        } else if ch == '/' && c.get(k + 1) == Some(&'*') {
            k += 2;
            while k < c.len() && !(c[k] == '*' && c.get(k + 1) == Some(&'/')) {
                k += 1;
            }
            k += 2;
        } else if ch == '\'' {
            k += 1;
            while k < c.len() && !(c[k] == '\'' && c.get(k + 1) != Some(&'\'')) {
                k += if c[k] == '\'' { 2 } else { 1 };
            }
            k += 1;
            out.push("'".to_string());
        } else if ch == '"' || word(ch) {
            // a name: parts, quoted or not, joined by dots
            let mut name = String::new();
            loop {
                if c.get(k) == Some(&'"') {
                    k += 1;
                    while k < c.len() && !(c[k] == '"' && c.get(k + 1) != Some(&'"')) {
                        name.push(c[k]);
                        k += if c[k] == '"' { 2 } else { 1 };
                    }
                    k += 1;
                } else {
                    while k < c.len() && word(c[k]) {
                        name.push(c[k]);
                        k += 1;
                    }
                }
                if c.get(k) == Some(&'.') && c.get(k + 1).is_some_and(|&n| n == '"' || word(n)) {
                    name.push('.');
                    k += 1;
                } else {
                    break;
                }
            }
            out.push(name.to_lowercase());
        } else {
            out.push(ch.to_string());
            k += 1;
        }
    }
    out
}

/// The tokens of the main statement: after a leading `WITH [RECURSIVE] name [(cols)] AS [[NOT]
/// MATERIALIZED] (...), ...`, so that `WITH x AS (...) INSERT INTO t ...` reads as the INSERT.
fn main_statement(t: &[String]) -> &[String] {
    if t.first().map(String::as_str) != Some("with") {
        return t;
    }
    let mut k = 1 + usize::from(t.get(1).map(String::as_str) == Some("recursive"));
    // the token after the balanced parentheses that open at k
    let past = |mut k: usize| -> usize {
        let mut depth = 0usize;
        while k < t.len() {
            match t[k].as_str() {
                "(" => depth += 1,
                ")" => {
                    depth = depth.saturating_sub(1);
                    if depth == 0 {
                        return k + 1;
                    }
                }
                _ => {}
            }
            k += 1;
        }
        k
    };
    loop {
        k += 1; // the CTE's name
        if t.get(k).map(String::as_str) == Some("(") {
            k = past(k);
        }
        if t.get(k).map(String::as_str) == Some("as") {
            k += 1;
        }
        if t.get(k).map(String::as_str) == Some("not") {
            k += 1;
        }
        if t.get(k).map(String::as_str) == Some("materialized") {
            k += 1;
        }
        if t.get(k).map(String::as_str) == Some("(") {
            k = past(k);
        }
        if t.get(k).map(String::as_str) == Some(",") {
            k += 1;
        } else {
            return t.get(k..).unwrap_or(&[]);
        }
    }
}

/// The object a main statement creates or changes, as (action, qualified name), from its tokens.
fn action_of(w: &[String]) -> Option<(&'static str, String)> {
    let w: Vec<&str> = w.iter().map(String::as_str).collect();
    let name_at = |k: usize| -> Option<String> { w.get(k).filter(|n| !n.is_empty() && !n.starts_with(|c: char| !(c.is_alphanumeric() || c == '_' || c == '$'))).map(|n| n.to_string()) };
    match w.as_slice() {
        ["create", rest @ ..] => {
            let mut k = 1;
            if rest.first() == Some(&"or") && rest.get(1) == Some(&"replace") {
                k += 2;
            }
            if matches!(w.get(k), Some(&"temp") | Some(&"temporary")) {
                k += 1;
            }
            let kind = match w.get(k) {
                Some(&"table") => "table",
                Some(&"view") => "view",
                Some(&"macro") => "macro",
                _ => return None,
            };
            k += 1;
            if w.get(k) == Some(&"if") && w.get(k + 1) == Some(&"not") && w.get(k + 2) == Some(&"exists") {
                k += 3;
            }
            name_at(k).map(|n| (kind, n))
        }
        ["insert", "or", _, "into", ..] => name_at(4).map(|n| ("insert", n)),
        ["insert", "into", ..] => name_at(2).map(|n| ("insert", n)),
        ["delete", "from", ..] => name_at(2).map(|n| ("delete", n)),
        ["update", ..] => name_at(1).map(|n| ("update", n)),
        _ => None,
    }
}

/// The last part of a dotted name (`temp.main.points` is `points`).
fn bare(name: &str) -> String {
    name.rsplit('.').next().unwrap_or(name).to_string()
}

/// What a statement does to which table, view or macro: `CREATE [OR REPLACE] [TEMP|TEMPORARY]
/// TABLE|VIEW|MACRO [IF NOT EXISTS] name` gives ("table" | "view" | "macro", name), `INSERT [OR
/// REPLACE|IGNORE] INTO name` ("insert", name), `DELETE FROM name` ("delete", name), `UPDATE
/// name` ("update", name), also after a `WITH` clause; names in lower case, without their schema
/// (`temp.main."Points"` is `points`); `None` for anything else. Comments are skipped. The one
/// reading of a statement's target: the runner's undo and the stage contract check
/// (tests/check_stage_contracts.py, through `trajdb_statement`) both use it.
pub fn statement_action(stmt: &str) -> Option<(&'static str, String)> {
    action_of(main_statement(&tokens(stmt))).map(|(a, n)| (a, bare(&n)))
}

/// The short name a statement gives one of trajdb's macros (sql/analysis.sql: `CREATE OR REPLACE
/// TEMP MACRO routes(...) AS TABLE FROM trajdb_routes(...)` names `trajdb_routes` `routes`), or
/// `None`. A host leaves such a statement out when the name is already the user's (a table, view,
/// macro or function of theirs: python/trajdb's execute_steps), so that a run never redefines a
/// user's name; `trajdb_<name>` is always there. `trajdb_stages` and `trajdb_script` give it per
/// row (column `short_name`).
pub fn short_name(stmt: &str) -> Option<String> {
    let ("macro", name) = statement_action(stmt)? else { return None };
    if name.starts_with("trajdb_") {
        return None;
    }
    let code: String = stmt.lines().filter(|l| !l.trim_start().starts_with("--")).collect::<Vec<_>>().join("\n").to_ascii_lowercase();
    let words: Vec<&str> = code.split_whitespace().collect();
    let target = format!("trajdb_{name}");
    // the body: the words after the first `as` that follows the parameter list's `)`
    let close = words.iter().position(|w| w.contains(')'))?;
    let at = close + words[close..].iter().position(|w| *w == "as")? + 1;
    let body = match words.get(at..)? {
        ["table", "from", rest @ ..] => rest,
        rest => rest,
    };
    let call = body.first()?;
    let calls = call.strip_prefix(target.as_str()).is_some_and(|r| r.starts_with('('))
        || (*call == target && body.get(1).is_some_and(|w| w.starts_with('(')));
    calls.then_some(name)
}

/// Why `stmt` could change something outside the session (the caller's database file, an
/// attached database, a setting), or `None` when it only touches the session: every object a
/// manifest creates is TEMP (TEMP objects live in the connection's own in-memory catalog: never
/// stored in a database file, allowed on a read-only one, gone when the connection closes), it
/// changes (INSERT / UPDATE / DELETE / DROP) only objects it created TEMP earlier (`made`) or
/// names `temp.` explicitly, and it runs no statement that writes a catalog or a setting (ATTACH,
/// ALTER, COMMENT, CHECKPOINT, SET other than SET VARIABLE, ...). Statements that only read, or
/// write files (COPY ... TO: the results folder's rules, outdir.rs), pass.
pub fn leaves_the_session(stmt: &str, made: &[String]) -> Option<String> {
    let all = tokens(stmt);
    let w = main_statement(&all);
    let at = |k: usize| w.get(k).map(String::as_str).unwrap_or("");
    // an unqualified name the run made TEMP (a qualified one must say temp.: main.points is the user's)
    let temp_made = |name: &str| !name.contains('.') && made.iter().any(|m| m == name);
    match at(0) {
        "create" => {
            let k = if at(1) == "or" && at(2) == "replace" { 3 } else { 1 };
            (!matches!(at(k), "temp" | "temporary")).then(|| "it creates an object that is not TEMP".to_string())
        }
        "insert" | "delete" | "update" => {
            // the full name as written: temp.… is the session's own
            let raw = action_of(w).map(|(_, n)| n).unwrap_or_default();
            (!raw.starts_with("temp.") && !temp_made(&raw)).then(|| "it changes a table the run did not create TEMP".to_string())
        }
        "drop" => {
            let k = if at(2) == "if" && at(3) == "exists" { 4 } else { 2 };
            (!at(k).starts_with("temp.")).then(|| "it drops an object not named temp.…".to_string())
        }
        "set" => (at(1) != "variable").then(|| "it changes a setting (only SET VARIABLE is the session's own)".to_string()),
        // COPY (query) TO file only: COPY table FROM file would fill a table
        "copy" => (at(1) != "(").then(|| "only COPY (query) TO is part of a run".to_string()),
        "select" | "from" | "values" | "" => None,
        // a WITH clause before anything else (a CTE list that never ends): not read, so refused
        "with" => Some("a WITH clause whose statement cannot be read".to_string()),
        other => Some(format!("{other} statements are not part of a run")),
    }
}

/// Refuses a manifest with a statement that [`leaves_the_session`]: the guarantee that a run
/// stores nothing in, and replaces nothing of, the caller's database holds by this check of
/// every statement, whatever a SQL file says (a test runs it on every part and script).
/// `host_made`: tables the host creates TEMP before the rows run (a window's site tables).
pub fn check_session_only(steps: &[Step], host_made: &[&str]) -> Result<(), Box<dyn Error>> {
    let mut made: Vec<String> = host_made.iter().map(|s| s.to_string()).collect();
    for s in steps {
        if let Some(why) = leaves_the_session(&s.sql, &made) {
            let line = s.sql.lines().find(|l| !l.trim_start().starts_with("--")).unwrap_or("").trim();
            return Err(format!(
                "trajdb: a statement of {} (stage {}) could write to your database: {why} ({line}); a run keeps everything in TEMP",
                s.file, s.stage
            )
            .into());
        }
        if let (Some(name), true) = (&s.makes, is_temp_create(&s.sql)) {
            made.push(name.clone());
        }
    }
    Ok(())
}

fn push_script(out: &mut Vec<Step>, stage: &str, file: &str, text: &str) {
    for s in sql::split_statements(text) {
        let stmt = s.trim().to_string();
        out.push(Step { stage: stage.to_string(), file: file.to_string(), makes: statement_target(&stmt), sql: stmt, undo: None });
    }
}

/// Every statement of `req`, in order. Parameter names and values are checked here (an
/// unknown name or a bad value is an error naming it), before anything runs.
pub fn plan(req: &Request) -> Result<Vec<Step>, Box<dyn Error>> {
    // a NUL byte would cut a path short in the C calls below SQL: never a silent truncation
    let texts = [("input", Some(&req.input)), ("out_dir", req.out.as_ref())];
    for (what, v) in texts.into_iter().filter_map(|(w, v)| v.map(|v| (w.to_string(), v.clone()))).chain(req.params.iter().map(|(k, v)| (k.clone(), v.clone()))) {
        if v.contains('\0') {
            return Err(format!("{what} contains a NUL byte ({v:?}); remove it").into());
        }
    }
    let values = params::resolve(&req.params)?;
    if req.out.is_some() && !matches!(req.part, Part::All | Part::Day) {
        return Err("out_dir is only for parts 'all' and 'day' (a site or a window returns tables, not files)".into());
    }
    let mut steps = Vec::new();
    // 1. every parameter: the given values, every other one back to its default
    push_script(&mut steps, "params", "trajdb_params_sql", &params::set_sql(&values));
    steps.push(Step {
        stage: "params".into(),
        file: "trajdb_stages".into(),
        sql: format!("SET VARIABLE pipeline_input = {}", sql::sql_string(&req.input)),
        makes: None,
        undo: None,
    });
    // text camera ids are numbered by the load (sql/pipeline.sql); an archive's site and days
    // (src/archive/task.rs) keep the numbers of the site's first calibration, given by the
    // host in load_camera_numbers (camera text -> number), so that a day without one camera
    // numbers the others as its site did. A whole run starts from none.
    steps.push(Step {
        stage: "params".into(),
        file: "trajdb_stages".into(),
        sql: if req.part == Part::All {
            "SET VARIABLE load_camera_numbers = MAP {}::MAP(VARCHAR, INTEGER)".into()
        } else {
            "SET VARIABLE load_camera_numbers = coalesce(getvariable('load_camera_numbers'), MAP {}::MAP(VARCHAR, INTEGER))".into()
        },
        makes: None,
        undo: None,
    });
    // an archive's day may carry a note of its host for the day's warnings and report (a camera
    // change found and registered again: src/archive/task.rs); every other run has none
    steps.push(Step {
        stage: "params".into(),
        file: "trajdb_stages".into(),
        sql: if req.part == Part::Day {
            "SET VARIABLE archive_day_note = getvariable('archive_day_note')::VARCHAR".into()
        } else {
            "SET VARIABLE archive_day_note = NULL::VARCHAR".into()
        },
        makes: None,
        undo: None,
    });
    // 2. the results folder is claimed before any work: refused here when it holds the user's
    //    own files, is the input's folder, '' or '/' (crates/app/src/outdir.rs); undone (the
    //    staging folder removed, the earlier results left as they were) when a later step fails
    if let Some(out) = &req.out {
        let o = sql::sql_string(out);
        // the caller's views, so that a view input is followed to the files it reads (out must
        // not contain them; crates/app/src/outdir.rs)
        steps.push(Step {
            stage: "params".into(),
            file: "trajdb_stages".into(),
            sql: "SET VARIABLE trajdb_input_views = (SELECT coalesce(to_json(list({'database': database_name, 'schema': schema_name, \
                  'name': view_name, 'sql': sql}))::VARCHAR, '[]') FROM duckdb_views() WHERE NOT internal)"
                .into(),
            makes: None,
            undo: None,
        });
        steps.push(Step {
            stage: "params".into(),
            file: "trajdb_results_begin".into(),
            sql: format!(
                "SET VARIABLE out_dir = (SELECT staging FROM trajdb_results_begin({o}, {}, views := getvariable('trajdb_input_views')))",
                sql::sql_string(&req.input)
            ),
            makes: None,
            undo: Some(format!("FROM trajdb_results_end({o}, false)")),
        });
        // the folder as the caller named it (out_dir is the staging folder while the run writes):
        // analysis.sql in the results reads merged.parquet from there (sql/export.sql)
        steps.push(Step { stage: "params".into(), file: "trajdb_stages".into(), sql: format!("SET VARIABLE trajdb_results_dir = {o}"), makes: None, undo: None });
        steps.push(clock_step("start", "params"));
        // the report's gates, read and checked before any stage: a bad file fails in seconds
        steps.extend(gates_steps(&values));
        push_script(&mut steps, "params", "sql/report_gates.sql", &sql::expand_embedded("sql/report_gates.sql")?);
    }
    // 3. the load and the stages (sql/pipeline.sql: params.sql keeps the values set above)
    let work = site_work_tables()?;
    let skip: Vec<&str> = SITE_TABLES.iter().copied().chain(work.iter().map(String::as_str)).collect();
    let mut timed = String::new();
    for sql::Part { stage: name, file, sql: text } in sql::parts("sql/pipeline.sql")? {
        let stage = if name == "setup" { "load".to_string() } else { name };
        let file = if stage == "load" { "sql/pipeline.sql".to_string() } else { file };
        match req.part {
            Part::Site if stage != "load" && !CALIBRATION_STAGES.contains(&stage.as_str()) => continue,
            Part::Window if WINDOW_SKIPS_STAGES.contains(&stage.as_str()) => continue,
            _ => {}
        }
        // one clock step per stage (a stage of several files is timed as one)
        if req.out.is_some() && stage != "load" && stage != timed {
            steps.push(clock_step(&stage, &file));
        }
        timed.clone_from(&stage);
        let mut part = Vec::new();
        push_script(&mut part, &stage, &file, &text);
        if matches!(req.part, Part::Window | Part::Day) && stage != "load" {
            part.retain(|s| !s.makes.as_deref().is_some_and(|m| skip.contains(&m)));
        }
        steps.extend(part);
    }
    match req.part {
        Part::All | Part::Day => {
            push_script(&mut steps, "warnings", "sql/warnings.sql", &sql::expand_embedded("sql/warnings.sql")?);
            // the analyst's questions as macros over `merged` (movements, speeds, conflicts,
            // routes: docs/analysis.md), defined in the session that ran the pipeline
            push_script(&mut steps, "analysis", "sql/analysis.sql", &sql::expand_embedded("sql/analysis.sql")?);
        }
        Part::Window => push_script(&mut steps, "window", "sql/window.sql", &sql::expand_embedded("sql/window.sql")?),
        Part::Site => {}
    }
    // 4. the result files into the staging folder, report.html, then the commit: the files
    //    replace the earlier results only when all are written
    if let Some(out) = &req.out {
        steps.push(clock_step("write", "sql/export.sql"));
        push_script(&mut steps, "write", "sql/export.sql", &sql::expand_embedded("sql/export.sql")?);
        steps.push(clock_step("report", "sql/report.sql"));
        steps.push(Step {
            stage: "report".into(),
            file: "sql/report.sql".into(),
            // the stage times of this run, from the clock rows above: report.html's stage table
            // (none in an archive's day: its report is then the same bytes on every run of the
            // same input, and the times are in the archive's _state/runs.csv)
            sql: if req.part == Part::Day {
                "CREATE OR REPLACE TEMP TABLE pipeline_timings (stage VARCHAR, seconds DOUBLE)".into()
            } else {
                "CREATE OR REPLACE TEMP TABLE pipeline_timings AS \
                  SELECT stage, epoch(lead(began) OVER (ORDER BY k) - began) AS seconds FROM pipeline_clock QUALIFY seconds IS NOT NULL ORDER BY k"
                    .into()
            },
            makes: Some("pipeline_timings".into()),
            undo: None,
        });
        push_script(&mut steps, "report", "sql/report.sql", &sql::expand_embedded("sql/report.sql")?);
        steps.push(Step {
            stage: "commit".into(),
            file: "trajdb_results_end".into(),
            sql: format!("FROM trajdb_results_end({}, true)", sql::sql_string(out)),
            makes: None,
            undo: None,
        });
    }
    let host_made: &[&str] = if matches!(req.part, Part::Window | Part::Day) { SITE_TABLES } else { &[] };
    check_session_only(&steps, host_made)?;
    Ok(steps)
}

/// The report's gates (parameter `report_gates`, issue 39): the rows as given, into the temp
/// table `report_gates_in` that sql/report.sql reads; empty when the parameter is '' (approaches
/// from the data). A name ending in .csv or .parquet is a file (read_csv / read_parquet), any
/// other a table or view (query_table); the value is read from its variable, never spliced
/// into the SQL.
fn gates_steps(values: &[(&'static params::Param, String)]) -> Vec<Step> {
    let given = values.iter().find(|(p, _)| p.name == "report_gates").map(|(_, v)| v.trim_matches('\'').trim().to_ascii_lowercase()).unwrap_or_default();
    let step = |sql: &str| Step { stage: "params".into(), file: "report_gates".into(), makes: statement_target(sql), sql: sql.to_string(), undo: None };
    if given.is_empty() {
        return vec![step("CREATE OR REPLACE TEMP TABLE report_gates_in AS SELECT NULL::VARCHAR AS approach, NULL::DOUBLE AS x1, NULL::DOUBLE AS y1, NULL::DOUBLE AS x2, NULL::DOUBLE AS y2 WHERE false")];
    }
    let read = if given.ends_with(".csv") || given.ends_with(".csv.gz") { Some("read_csv") } else if given.ends_with(".parquet") { Some("read_parquet") } else { None };
    match read {
        Some(f) => vec![
            step(
                "SET VARIABLE report_gates_checked = (SELECT CASE WHEN count(*) = 0 THEN error('report_gates: no file ' || getvariable('report_gates') \
                 || ' (a gates file: .csv or .parquet with approach, x1, y1, x2, y2 or approach, wkt)') ELSE true END FROM glob(getvariable('report_gates')))",
            ),
            step(&format!("CREATE OR REPLACE TEMP TABLE report_gates_in AS FROM {f}(getvariable('report_gates'))")),
        ],
        None => vec![
            step(
                "SET VARIABLE report_gates_checked = (SELECT CASE WHEN count(*) = 0 THEN error('report_gates: no table or view named ' \
                 || getvariable('report_gates') || ' in this connection; give a .csv or .parquet file (the name must end so), or the name of a table \
                 or view with approach, x1, y1, x2, y2 or approach, wkt') ELSE true END \
                 FROM (SELECT table_name AS n, schema_name AS s FROM duckdb_tables() UNION ALL SELECT view_name, schema_name FROM duckdb_views()) \
                 WHERE lower(n) = lower(getvariable('report_gates')) OR lower(s || '.' || n) = lower(getvariable('report_gates')))",
            ),
            step("CREATE OR REPLACE TEMP TABLE report_gates_in AS FROM query_table(getvariable('report_gates'))"),
        ],
    }
}

/// A row of the run's clock (`pipeline_clock`: when each stage began), from which the report's
/// stage times are computed in SQL, so that every host gets them without timing anything.
/// `now()` is the start of the statement's transaction: each statement of a run is its own.
fn clock_step(stage: &str, file: &str) -> Step {
    let sql = if stage == "start" {
        "CREATE OR REPLACE TEMP TABLE pipeline_clock AS SELECT 0 AS k, 'load' AS stage, now() AS began".to_string()
    } else {
        format!("INSERT INTO pipeline_clock SELECT max(k) + 1, {}, now() FROM pipeline_clock", sql::sql_string(stage))
    };
    let stage = if stage == "start" { "params" } else { stage };
    Step { stage: stage.to_string(), file: file.to_string(), makes: statement_target(&sql), sql, undo: None }
}

/// Every name an embedded SQL file creates TEMP (the tables a file run alone may change).
fn temp_tables_of_trajdb() -> Result<Vec<String>, Box<dyn Error>> {
    let mut names = Vec::new();
    for (path, _) in sql::SQL_FILES {
        let mut steps = Vec::new();
        push_script(&mut steps, "script", path, &sql::expand_embedded(path)?);
        for s in steps {
            if let (Some(name), true) = (s.makes, is_temp_create(&s.sql)) {
                names.push(name);
            }
        }
    }
    Ok(names)
}

fn is_temp_create(stmt: &str) -> bool {
    let code: String = stmt.lines().filter(|l| !l.trim_start().starts_with("--")).collect::<Vec<_>>().join("\n");
    let w: Vec<String> = code.split_whitespace().take(4).map(|w| w.to_ascii_lowercase()).collect();
    w.first().is_some_and(|f| f == "create") && w.iter().any(|x| x == "temp" || x == "temporary")
}

/// The statements of one embedded SQL file (`sql/score.sql`, `sql/report.sql`, ...), its
/// `.read` lines expanded: what `.read FILE` runs in the DuckDB CLI.
pub fn script(path: &str) -> Result<Vec<Step>, Box<dyn Error>> {
    let text = sql::expand_embedded(path)?;
    let mut steps = Vec::new();
    push_script(&mut steps, "script", path, &text);
    // one file of a run (a stage alone, as tests/test_stages_python.py runs them) changes the TEMP
    // tables of the files before it: the tables trajdb's SQL creates TEMP
    check_session_only(&steps, &temp_tables_of_trajdb()?.iter().map(String::as_str).collect::<Vec<_>>())?;
    Ok(steps)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_window_recomputes_nothing_of_the_site_only_stages() {
        let work = site_work_tables().unwrap();
        // the alignment's and the overlap's intermediates, from their headers
        for name in ["align_vote", "align_hyp", "align_drift_obs", "align_register", "align_transform", "view_points"] {
            assert!(work.iter().any(|w| w == name), "{name} not in {work:?}");
        }
        assert!(!work.iter().any(|w| w == "points" || w.starts_with("result_") || SITE_TABLES.contains(&w.as_str())), "{work:?}");
        // a window keeps of those stages only the frame and clock of points and the result macros
        for s in plan(&req(Part::Window, None)).unwrap() {
            if SITE_ONLY_STAGES.contains(&s.stage.as_str()) {
                let m = s.makes.as_deref().unwrap_or("");
                assert!(m.is_empty() || m == "points" || m.starts_with("result_"), "a window runs {m}: {}", s.sql);
            }
        }
    }

    #[test]
    fn short_names_are_read_from_the_statement() {
        assert_eq!(short_name("CREATE OR REPLACE TEMP MACRO routes(p := NULL) AS TABLE FROM trajdb_routes(p)").as_deref(), Some("routes"));
        assert_eq!(short_name("-- a comment\nCREATE OR REPLACE TEMP MACRO Speed(a) AS\n  trajdb_speed (a)").as_deref(), Some("speed"));
        // not a short name: trajdb's own name, another body, another statement
        assert_eq!(short_name("CREATE OR REPLACE TEMP MACRO trajdb_routes() AS TABLE FROM merged"), None);
        assert_eq!(short_name("CREATE OR REPLACE TEMP MACRO routes() AS TABLE FROM trajdb_routes_all()"), None);
        assert_eq!(short_name("CREATE OR REPLACE TEMP MACRO routes() AS TABLE FROM merged"), None);
        assert_eq!(short_name("CREATE TEMP TABLE routes AS FROM trajdb_routes()"), None);
        // every short name of sql/analysis.sql, one per trajdb_ macro it names
        let file = crate::sql::expand_embedded("sql/analysis.sql").unwrap();
        let names: Vec<String> = crate::sql::split_statements(&file).iter().filter_map(|st| short_name(st)).collect();
        assert!(names.len() >= 10 && names.contains(&"routes".to_string()), "{names:?}");
        for n in &names {
            assert!(file.contains(&format!("MACRO trajdb_{n}(")), "{n}");
        }
    }

    fn req(part: Part, out: Option<&str>) -> Request {
        Request { input: "points.parquet".into(), out: out.map(str::to_string), part, params: vec![] }
    }

    #[test]
    fn targets_of_statements() {
        assert_eq!(statement_target("-- c\nCREATE OR REPLACE TEMP TABLE align_scan AS SELECT 1").as_deref(), Some("align_scan"));
        assert_eq!(statement_target("CREATE OR REPLACE TEMP MACRO align_sample(a, b) AS a").as_deref(), Some("align_sample"));
        assert_eq!(statement_target("CREATE TEMP TABLE IF NOT EXISTS pipeline_timings (a INT)").as_deref(), Some("pipeline_timings"));
        assert_eq!(statement_target("insert into Points SELECT 1").as_deref(), Some("points"));
        assert_eq!(statement_target("DELETE FROM calib_pairs WHERE x").as_deref(), Some("calib_pairs"));
        assert_eq!(statement_target("UPDATE align_frames SET a = 1").as_deref(), Some("align_frames"));
        assert_eq!(statement_target("SELECT 1"), None);
        assert_eq!(statement_target("SET VARIABLE x = 1"), None);
        assert_eq!(statement_action("CREATE OR REPLACE TEMP MACRO m(x) AS x"), Some(("macro", "m".to_string())));
        assert_eq!(statement_action("-- c\nUPDATE Points SET t = 1"), Some(("update", "points".to_string())));
        assert_eq!(statement_action("CREATE INDEX i ON t (a)"), None);
        // quoted and qualified names, block comments, a WITH clause, INSERT OR REPLACE
        assert_eq!(statement_action("CREATE TEMP TABLE temp.main.\"My T\" AS SELECT 1"), Some(("table", "my t".to_string())));
        assert_eq!(statement_action("/* x */ INSERT INTO main.points SELECT 1"), Some(("insert", "points".to_string())));
        assert_eq!(statement_action("WITH a AS (SELECT '(' AS p), b(x) AS (SELECT 1) INSERT INTO t SELECT 1"), Some(("insert", "t".to_string())));
        assert_eq!(statement_action("INSERT OR REPLACE INTO t VALUES (1)"), Some(("insert", "t".to_string())));
        assert_eq!(statement_action("WITH a AS (SELECT 1) SELECT * FROM a"), None);
        assert_eq!(statement_action("CREATE TEMP TABLE \"a\"\"b\" AS SELECT 1"), Some(("table", "a\"b".to_string())));
    }

    #[test]
    fn a_whole_run_claims_first_and_commits_last() {
        let steps = plan(&req(Part::All, Some("results"))).unwrap();
        let begin = steps.iter().position(|s| s.file == "trajdb_results_begin").unwrap();
        let first_load = steps.iter().position(|s| s.stage == "load").unwrap();
        assert!(begin < first_load, "the folder is claimed before any work");
        assert!(steps[begin].undo.as_deref().unwrap().contains("trajdb_results_end('results', false)"));
        assert_eq!(steps.last().unwrap().sql, "FROM trajdb_results_end('results', true)");
        let stages: Vec<&str> = steps.iter().map(|s| s.stage.as_str()).collect();
        for s in sql::stages() {
            assert!(stages.contains(&s.as_str()), "{s} missing");
        }
        assert!(steps.iter().all(|s| !s.sql.trim().is_empty() && !s.sql.trim_end().ends_with(';')));
    }

    #[test]
    fn input_and_folder_are_quoted_never_spliced() {
        let mut r = req(Part::All, Some("a'); DROP TABLE x; --"));
        r.input = "p'); COPY x TO '/etc/passwd".into();
        let steps = plan(&r).unwrap();
        let set = steps.iter().find(|s| s.sql.starts_with("SET VARIABLE pipeline_input")).unwrap();
        assert_eq!(set.sql, "SET VARIABLE pipeline_input = 'p''); COPY x TO ''/etc/passwd'");
        assert!(steps.iter().any(|s| s.sql.contains("trajdb_results_begin('a''); DROP TABLE x; --', ")));
    }

    #[test]
    fn nul_bytes_are_refused() {
        let mut r = req(Part::All, Some("res\0x"));
        assert!(plan(&r).unwrap_err().to_string().contains("out_dir contains a NUL byte"));
        r.out = None;
        r.input = "p\0.parquet".into();
        assert!(plan(&r).unwrap_err().to_string().contains("input contains a NUL byte"));
    }

    #[test]
    fn parameters_are_checked_before_anything_runs() {
        let mut r = req(Part::All, None);
        r.params = vec![("merge_etaa".into(), "0.6".into())];
        assert!(plan(&r).unwrap_err().to_string().contains("merge_etaa"));
        r.params = vec![("merge_eta".into(), "lots".into())];
        assert!(plan(&r).is_err());
        r.params = vec![("merge_eta".into(), "0.6".into())];
        assert!(plan(&r).unwrap().iter().any(|s| s.sql.contains("merge_eta = 0.6")));
    }

    #[test]
    fn every_run_and_script_stays_in_the_session() {
        // plan() and script() refuse a manifest that would write to the caller's database; these
        // are every manifest this build can produce
        for part in [Part::All, Part::Site, Part::Window] {
            let out = if part == Part::All { Some("results") } else { None };
            plan(&req(part, out)).unwrap();
        }
        plan(&req(Part::All, None)).unwrap();
        for (path, _) in sql::SQL_FILES {
            if let Err(e) = script(path) {
                assert!(!e.to_string().contains("could write to your database"), "{path}: {e}");
            }
        }
        let made = vec!["points".to_string()];
        for bad in [
            "CREATE OR REPLACE MACRO routes() AS TABLE SELECT 1",
            "CREATE VIEW analysis_no_gates AS SELECT 1",
            "CREATE TABLE IF NOT EXISTS x (a INT)",
            "-- c\nCREATE OR REPLACE TABLE merged AS SELECT 1",
            "INSERT INTO user_table SELECT 1",
            "UPDATE user_table SET a = 1",
            "DELETE FROM main.points",
            "DROP TABLE IF EXISTS routes",
            "ATTACH 'x.db'",
            "ALTER TABLE points ADD COLUMN z INT",
            "COMMENT ON MACRO routes IS 'x'",
            "CHECKPOINT",
            "SET search_path = 'x'",
            "CREATE SCHEMA s",
            "COPY points FROM 'x.csv'",
            "COPY user_table TO 'x.csv'",
            "CALL pragma_version()",
            // what the word reader missed: a WITH before the DML, quotes, qualified names, comments
            "WITH x AS (SELECT 1 AS a) INSERT INTO user_table SELECT a FROM x",
            "WITH RECURSIVE x(a) AS (SELECT 1), y AS MATERIALIZED (SELECT 2) DELETE FROM main.points",
            "INSERT INTO main.points SELECT 1",
            "INSERT OR REPLACE INTO user_table SELECT 1",
            "/* a comment */ CREATE MACRO m() AS 1",
            "CREATE /* TEMP */ TABLE t AS SELECT 1",
            "UPDATE \"User Table\" SET a = 1",
        ] {
            assert!(leaves_the_session(bad, &made).is_some(), "{bad}");
        }
        for good in [
            "CREATE OR REPLACE TEMP MACRO routes() AS TABLE SELECT 1",
            "create temporary table x as select 1",
            "CREATE TEMP TABLE IF NOT EXISTS pipeline_warnings (k INT)",
            "INSERT INTO points SELECT 1",
            "DELETE FROM points WHERE true",
            "UPDATE points SET a = 1",
            "DROP TABLE IF EXISTS temp.main.align_keys",
            "SET VARIABLE x = 1",
            "SELECT 1",
            "FROM trajdb_results_end('r', true)",
            "COPY (SELECT 1) TO 'x.csv'",
            "COPY\n(FROM result_transforms() ORDER BY cam_from) TO 'x' (HEADER)",
            "WITH x AS (SELECT 1) SELECT * FROM x",
            "WITH x AS (SELECT ')' AS p) INSERT INTO points SELECT 1 FROM x",
            "INSERT INTO temp.main.\"Points\" SELECT 1",
            "/* c */ -- c\nCREATE TEMP TABLE x AS SELECT 1",
        ] {
            assert_eq!(leaves_the_session(good, &made), None, "{good}");
        }
        let steps = vec![Step { stage: "s".into(), file: "f.sql".into(), sql: "CREATE MACRO m() AS 1".into(), makes: Some("m".into()), undo: None }];
        let e = check_session_only(&steps, &[]).unwrap_err().to_string();
        assert!(e.contains("f.sql") && e.contains("not TEMP"), "{e}");
    }

    #[test]
    fn a_window_skips_site_tables_and_clustering() {
        let work = site_work_tables().unwrap();
        let work: Vec<&str> = work.iter().map(String::as_str).collect();
        let site = plan(&req(Part::Site, None)).unwrap();
        let window = plan(&req(Part::Window, None)).unwrap();
        assert!(site.iter().any(|s| s.makes.as_deref() == Some("align_frames")));
        assert!(!site.iter().any(|s| s.stage == "merge" || s.stage == "cluster"));
        assert!(!window.iter().any(|s| s.makes.as_deref().is_some_and(|m| SITE_TABLES.contains(&m) || work.contains(&m))));
        assert!(!window.iter().any(|s| s.stage == "cluster"));
        assert!(window.iter().any(|s| s.stage == "merge") && window.iter().any(|s| s.stage == "window"));
        assert!(plan(&Request { out: Some("r".into()), ..req(Part::Site, None) }).is_err());
        // an archive's day: the whole run with its results folder, on the site's tables
        let day = plan(&req(Part::Day, Some("r"))).unwrap();
        assert!(!day.iter().any(|s| s.makes.as_deref().is_some_and(|m| SITE_TABLES.contains(&m) || work.contains(&m))));
        assert!(day.iter().any(|s| s.stage == "report") && day.iter().any(|s| s.stage == "commit") && !day.iter().any(|s| s.stage == "window"));
        // every site table and work table is made by a statement of the site run: a renamed
        // table would otherwise be recomputed per window without notice
        let made: Vec<&str> = site.iter().filter_map(|s| s.makes.as_deref()).collect();
        for t in SITE_TABLES.iter().chain(&work) {
            assert!(made.contains(t), "{t} is named a site table but no site statement makes it");
        }
    }
}
