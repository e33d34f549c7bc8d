//! The one declared table of pipeline parameters. The stage files read them with
//! `getvariable('name')`; the runner sets every one with `SET VARIABLE` before the stages
//! (the default or a `--param name=value` override, checked against the declared type), and
//! `sql/params.sql`, generated from this table, does the same for the DuckDB CLI.

use std::error::Error;
use std::fmt::Write as _;

/// The SQL type of a parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    Double,
    Integer,
    Boolean,
    Text,
}

/// One parameter: name, type, default (as SQL), stage, description.
#[derive(Clone, Copy, Debug)]
pub struct Param {
    pub name: &'static str,
    pub kind: Kind,
    pub default: &'static str,
    pub stage: &'static str,
    pub description: &'static str,
    /// The closed range a number must lie in (integers and doubles; `auto` is always allowed
    /// where the parameter is measured). Every number is finite.
    pub lo: f64,
    pub hi: f64,
    /// The values a text parameter may take (compared trimmed and case-insensitively); empty:
    /// any text. Checked with the rest, before any stage runs.
    pub choices: &'static [&'static str],
}

const fn d(name: &'static str, default: &'static str, stage: &'static str, description: &'static str) -> Param {
    Param { name, kind: Kind::Double, default, stage, description, lo: 0.0, hi: f64::INFINITY, choices: &[] }
}
const fn i(name: &'static str, default: &'static str, stage: &'static str, description: &'static str) -> Param {
    Param { name, kind: Kind::Integer, default, stage, description, lo: 0.0, hi: f64::INFINITY, choices: &[] }
}
const fn b(name: &'static str, default: &'static str, stage: &'static str, description: &'static str) -> Param {
    Param { name, kind: Kind::Boolean, default, stage, description, lo: 0.0, hi: f64::INFINITY, choices: &[] }
}
const fn s(name: &'static str, default: &'static str, stage: &'static str, description: &'static str) -> Param {
    Param { name, kind: Kind::Text, default, stage, description, lo: 0.0, hi: f64::INFINITY, choices: &[] }
}

impl Param {
    /// This parameter, its numbers restricted to `[lo, hi]`.
    const fn within(self, lo: f64, hi: f64) -> Param {
        Param { lo, hi, ..self }
    }
    /// This text parameter, restricted to `choices`.
    const fn one_of(self, choices: &'static [&'static str]) -> Param {
        Param { choices, ..self }
    }
}

/// Every parameter of every stage, in stage order. Numbers are >= 0 unless a range says otherwise. The defaults and the measurements behind
/// them are explained at the top of each stage file.
pub const PARAMS: &[Param] = &[
    s("input_columns", "''", "load", "your column names, as 'camera=cam_id, track_id=id, t=time' (any of camera, track_id, class, t, x, y, estimated; unnamed ones keep their name; estimated may be absent)"),
    b("clean_drop_estimated_tails", "false", "clean", "drop a track whose last clean_xi points are all estimated"),
    i("clean_xi", "3", "clean", "points of the estimated tail rule").within(1.0, 1e6),
    i("clean_min_points", "auto", "clean", "a track with fewer real points than this ... (auto: 2, the least that shows motion)").within(1.0, 1e9),
    d("clean_min_duration_s", "auto", "clean", "... and spanning less than this many seconds is dropped (auto: 1.5 sampling periods)"),
    d("clean_max_speed", "70.0", "clean", "a track whose median real speed exceeds this (m/s) is implausible and dropped").within(1e-09, 1e6),
    d("quality_max_gap", "2.5", "quality", "a broken piece may resume up to this many seconds later").within(0.0, 86400.0),
    d("quality_max_dist", "2.0", "quality", "... within this many metres of where the track would be at its final velocity"),
    d("quality_max_accel", "auto", "quality", "second linking pass: a leftover start may lie max_dist + accel * gap^2 / 2 from the prediction (m/s^2; auto: the class's measured 95th percentile acceleration, see quality.sql)"),
    d("quality_inset", "1.0", "quality", "endpoints closer than this (m) to the view's edge are entries and exits"),
    i("align_min_points", "10", "align", "tracks need at least this many real points to form hypotheses").within(2.0, 1e9),
    d("align_min_overlap_s", "2.0", "align", "track pairs overlap at least this long in time (s)"),
    i("align_min_pairs", "10", "align", "a hypothesis needs at least this many time-interpolated point pairs").within(3.0, 1e9),
    d("align_min_span_m", "3.0", "align", "... and its moving points span at least this many metres"),
    i("align_max_hypotheses", "4000", "align", "at most this many track pairs per camera pair are scanned (a hash sample of a long day)").within(1.0, 1e9),
    d("align_max_clock_offset_s", "1.0", "align", "clock offsets between two cameras are searched up to this many seconds either way first; a camera pair whose winner lies at the edge, or is too weak, is searched again over 4x and 16x this range").within(0.0, 172800.0),
    d("align_bin_s", "0.05", "align", "vote bin (and scan step) of the clock offset (s)").within(1e-06, 86400.0),
    d("align_clock_step_s", "0.005", "align", "step of the joint clock offset search around the winning bin (s)").within(1e-06, 86400.0),
    d("align_max_rms_m", "auto", "align", "hypotheses fitting their own pairs within this RMS (m) vote (auto: 0.1 + 3 sigma_pair)"),
    d("align_bin_deg", "2.0", "align", "vote bin of the rotation (degrees)").within(1e-06, 180.0),
    d("align_bin_m", "1.0", "align", "vote bin of the translation (m)").within(1e-06, 10000000.0),
    d("align_agree_deg", "3.0", "align", "a hypothesis agrees with the winning bin within this rotation (degrees)").within(0.0, 180.0),
    d("align_agree_m", "2.0", "align", "... and this translation (m)"),
    i("align_min_support", "3", "align", "a camera pair needs at least this many agreeing track pairs").within(1.0, 1e9),
    d("align_trim", "0.1", "align", "share of point pairs the trimmed refit leaves out").within(0.0, 0.9),
    d("align_refine_rms_m", "auto", "align", "second pass: track pairs within this RMS (m) of the first fit are kept (auto: 0.05 + 2 sigma_pair)"),
    s("overlap_method", "'convex'", "overlap", "view polygon hull: 'convex' or 'concave'").one_of(&["convex", "concave"]),
    d("overlap_concavity", "2.0", "overlap", "concavity of the concave hull").within(1e-09, 1e6),
    d("overlap_radius_m", "2.0", "overlap", "density rule: a point counts with overlap_min_neighbours others within this radius (m)"),
    i("overlap_min_neighbours", "3", "overlap", "density rule: neighbours a point needs").within(0.0, 1e6),
    d("overlap_shrink_sigmas", "1.0", "overlap", "each view polygon is shrunk by this many times the camera's measured noise").within(0.0, 100.0),
    d("merge_epsilon", "auto", "merge", "LCSS epsilon (m) for matching and merging (auto: per camera pair, 3.03 x the measured residual sigma: 99% of true pairs)").within(1e-09, 1e6),
    d("merge_time_window", "0.25", "merge", "LCSS time window T (s)").within(0.0, 86400.0),
    i("merge_min_points", "auto", "merge", "LCSS xi: points a track needs inside the overlap (auto: 2 real samples of the slowest camera on the common clock, >= 3)").within(1.0, 1e9),
    d("merge_eta", "0.5", "merge", "eta-bar: the lowest similarity that links two tracks").within(1e-09, 1.0),
    d("merge_resample_s", "0.1", "merge", "common clock period (s); 0 keeps the raw samples").within(0.0, 3600.0),
    d("merge_resample_max_gap", "1.0", "merge", "the common clock does not bridge gaps longer than this (s)").within(0.0, 86400.0),
    i("cluster_camera", "auto", "cluster", "the camera whose tracks are clustered (auto: the camera with the most real tracks; ties: the lowest id)").within(-2147483648.0, 2147483647.0),
    s("cluster_classes", "''", "cluster", "the classes clustered, as 'car, pedestrian' ('' : every class)"),
    i("cluster_delta", "5", "cluster", "Buzan's delta: samples of time warping").within(0.0, 1e9),
    d("cluster_epsilon", "2.0", "cluster", "Buzan's epsilon (m)").within(1e-09, 1e6),
    d("cluster_rho", "0.5", "cluster", "Buzan's rho: length ratio below which tracks are not compared").within(0.0, 1.0),
    d("cluster_threshold", "0.5", "cluster", "average-linkage cut height"),
    s("cluster_method", "'auto'", "cluster", "'exact' (every pair of tracks, traj_cluster), 'prototypes' (traj_cluster_prototypes: linear in the tracks) or 'auto' (exact up to cluster_exact_max tracks of a class, prototypes above)").one_of(&["auto", "exact", "prototypes"]),
    i("cluster_exact_max", "3000", "cluster", "with cluster_method auto, the most tracks of one class clustered exactly (3,000: 4.5 M pairs, a few seconds)").within(0.0, 80000.0),
    b("cluster_translation_invariant", "false", "cluster", "use S2 (shapes anywhere) instead of S1 (routes)"),
    s("report_gates", "''", "report", "gates the report counts movements by, instead of approaches found in the data: a .csv or .parquet file, or a table or view of this connection, with approach, x1, y1, x2, y2 (metres in the results' frame: the site map's axes) or approach, wkt (LINESTRING (x1 y1, x2 y2)); '' : approaches from the data"),
    d("archive_change_z", "5.0", "archive", "an archive's daily check (trajdb archive): a camera pair whose registration on the day's matches differs from its calibration day's by more than this many standard errors (rotation, position, clock) has moved; the camera is registered again from that day (docs/archive.md)").within(1.0, 1000.0),
];

/// The parameters of a JSON object (`{"merge_eta": 0.6, "cluster_classes": "car"}`): numbers,
/// booleans and text as text, for [`resolve`] to check. Anything else is an error naming it, and
/// so is a key given twice (`{"merge_eta": 0.6, "merge_eta": 0.4}`: JSON parsers disagree on
/// which one wins, so neither is taken silently; the object is read in order, never into a map).
pub fn from_json(text: &str) -> Result<Vec<(String, String)>, Box<dyn Error>> {
    let entries = ordered_object(if text.trim().is_empty() { "{}" } else { text })
        .map_err(|e| format!("params must be a JSON object of parameter names and values, e.g. '{{\"merge_eta\": 0.6}}' ({e})"))?;
    let mut out: Vec<(String, String)> = Vec::new();
    out.try_reserve(entries.len()).map_err(|_| "params: too many entries to hold")?;
    for (k, v) in entries {
        if out.iter().any(|(seen, _)| *seen == k) {
            return Err(format!("params: parameter {k} is given twice in the JSON object; give each parameter once").into());
        }
        let text = match v {
            serde_json::Value::String(s) => s,
            serde_json::Value::Number(n) => n.to_string(),
            serde_json::Value::Bool(b) => b.to_string(),
            other => return Err(format!("parameter {k} must be a number, a boolean or text, got {other}").into()),
        };
        out.push((k, text));
    }
    Ok(out)
}

/// A JSON object's entries in the order written, repeats kept (serde_json's Map keeps the last).
fn ordered_object(text: &str) -> Result<Vec<(String, serde_json::Value)>, serde_json::Error> {
    struct Entries;
    impl<'de> serde::de::Visitor<'de> for Entries {
        type Value = Vec<(String, serde_json::Value)>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a JSON object")
        }
        fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
            let mut out = Vec::new();
            while let Some(entry) = map.next_entry::<String, serde_json::Value>()? {
                out.push(entry);
            }
            Ok(out)
        }
    }
    let mut de = serde_json::Deserializer::from_str(text);
    let entries = serde::Deserializer::deserialize_map(&mut de, Entries)?;
    de.end()?;
    Ok(entries)
}

/// The SQL type name of a parameter kind.
pub fn kind_sql(k: Kind) -> &'static str {
    match k {
        Kind::Double => "DOUBLE",
        Kind::Integer => "BIGINT",
        Kind::Boolean => "BOOLEAN",
        Kind::Text => "VARCHAR",
    }
}

/// The declared parameter called `name`.
pub fn find(name: &str) -> Option<&'static Param> {
    PARAMS.iter().find(|p| p.name == name)
}

impl Param {
    /// `value` as an SQL literal of this parameter's type, or an error naming the parameter.
    pub fn literal(&self, value: &str) -> Result<String, Box<dyn Error>> {
        let v = value.trim();
        // `auto`: measured from the data by sql/stages/calibrate.sql (the variable stays NULL and
        // the stages read calibrated('name')); only numeric parameters can be measured.
        if v.eq_ignore_ascii_case("auto") && matches!(self.kind, Kind::Double | Kind::Integer) {
            return Ok(match self.kind {
                Kind::Double => "NULL::DOUBLE".into(),
                _ => "NULL::BIGINT".into(),
            });
        }
        let bad = |what: &str| -> Box<dyn Error> { format!("pipeline: parameter {} must be {what}, got {value:?}", self.name).into() };
        Ok(match self.kind {
            Kind::Double => {
                let x: f64 = v.parse().map_err(|_| bad("a number or auto"))?;
                if !x.is_finite() {
                    return Err(bad("a finite number"));
                }
                self.in_range(x, value)?;
                format!("{x:?}::DOUBLE")
            }
            Kind::Integer => {
                let n = v.parse::<i64>().map_err(|_| bad("an integer or auto"))?;
                self.in_range(n as f64, value)?;
                format!("{n}::BIGINT")
            }
            Kind::Boolean => match v.to_ascii_lowercase().as_str() {
                "true" => "true".into(),
                "false" => "false".into(),
                _ => return Err(bad("true or false")),
            },
            Kind::Text => {
                let inner = v.strip_prefix('\'').and_then(|x| x.strip_suffix('\'')).unwrap_or(v);
                if !self.choices.is_empty() && !self.choices.iter().any(|c| c.eq_ignore_ascii_case(inner.trim())) {
                    let list: Vec<String> = self.choices.iter().map(|c| format!("'{c}'")).collect();
                    return Err(bad(&format!("one of {}", list.join(", "))));
                }
                format!("'{}'", inner.replace('\'', "''"))
            }
        })
    }
}

impl Param {
    fn in_range(&self, x: f64, value: &str) -> Result<(), Box<dyn Error>> {
        if x < self.lo || x > self.hi {
            let r = |v: f64| if v.is_infinite() { "inf".to_string() } else { format!("{v}") };
            return Err(format!(
                "pipeline: parameter {} must be in [{}, {}], got {value:?} (see `trajdb params`: {})",
                self.name,
                r(self.lo),
                r(self.hi),
                self.description
            )
            .into());
        }
        Ok(())
    }
}

/// The value of every parameter (default or override), as SQL literals in table order.
/// Unknown names are an error that lists the known ones.
pub fn resolve(overrides: &[(String, String)]) -> Result<Vec<(&'static Param, String)>, Box<dyn Error>> {
    for (name, _) in overrides {
        if find(name).is_none() {
            let known: Vec<&str> = PARAMS.iter().map(|p| p.name).collect();
            return Err(format!("pipeline: unknown parameter {name:?}; known: {}", known.join(", ")).into());
        }
    }
    PARAMS
        .iter()
        .map(|p| {
            let v = overrides.iter().rev().find(|(n, _)| n == p.name).map(|(_, v)| v.as_str()).unwrap_or(p.default);
            Ok((p, p.literal(v)?))
        })
        .collect()
}

/// `SET VARIABLE` statements for resolved values (sql/params.sql then records them in the
/// `pipeline_params` table that the report shows).
pub fn set_sql(values: &[(&'static Param, String)]) -> String {
    let mut sql = String::new();
    for (p, v) in values {
        let _ = writeln!(sql, "SET VARIABLE {} = {v};", p.name);
    }
    sql
}

/// The text of `sql/params.sql`: every default, kept when the variable is already set.
pub fn params_sql() -> String {
    let mut s = String::from(
        "-- trajdb pipeline parameters: GENERATED from crates/app/src/params.rs by `trajdb params --sql > sql/params.sql`.\n\
         -- Each keeps a value you SET VARIABLE before `.read sql/params.sql`; otherwise it takes the default.\n",
    );
    let mut stage = "";
    for p in PARAMS {
        if p.stage != stage {
            let _ = writeln!(s, "\n-- {}", p.stage);
            stage = p.stage;
        }
        let _ = writeln!(s, "SET VARIABLE {0} = coalesce(getvariable('{0}'), {1}); -- {2}", p.name, p.literal(p.default).expect("valid default"), p.description);
    }
    // the values this run uses (the report's parameter table); NULL is 'auto'
    s.push_str("\n-- the values in use, one row per parameter (report.html shows them)\nCREATE OR REPLACE TEMP TABLE pipeline_params AS SELECT * FROM (VALUES\n");
    let rows: Vec<String> = PARAMS
        .iter()
        .map(|p| format!("    ('{0}', coalesce(getvariable('{0}')::VARCHAR, 'auto'), '{1}', '{2}')", p.name, p.stage, p.description.replace('\'', "''")))
        .collect();
    s.push_str(&rows.join(",\n"));
    s.push_str("\n) t(name, value, stage, description);\n");
    s
}

/// The parameters as `trajdb params` prints them (`trajdb_reference('params')`): name, type,
/// default (`auto`: measured), the closed range of a number, stage and description, the first
/// five columns padded to their widest value and two spaces apart.
pub fn table() -> String {
    // 0.5, 86400, inf; a small bound as 1e-9 (not 0.000000001)
    let bound = |v: f64| match v {
        v if v.is_infinite() => (if v > 0.0 { "inf" } else { "-inf" }).to_string(),
        v if v != 0.0 && v.abs() < 1e-4 => format!("{v:e}"),
        v => format!("{v}"),
    };
    let mut rows: Vec<[String; 6]> = vec![["name", "type", "default", "range", "stage", "description"].map(String::from)];
    for p in PARAMS {
        let range = match p.kind {
            Kind::Double | Kind::Integer => format!("[{}, {}]", bound(p.lo), bound(p.hi)),
            Kind::Boolean | Kind::Text => String::new(),
        };
        let default = p.default.trim_matches('\'').to_string();
        rows.push([p.name.to_string(), kind_sql(p.kind).to_string(), default, range, p.stage.to_string(), p.description.to_string()]);
    }
    let mut width = [0usize; 5];
    for r in &rows {
        for (w, c) in width.iter_mut().zip(r.iter()) {
            *w = (*w).max(c.chars().count());
        }
    }
    let mut s = String::new();
    for r in &rows {
        for (w, c) in width.iter().zip(r.iter()) {
            let _ = write!(s, "{c:<w$}  ");
        }
        let _ = writeln!(s, "{}", r[5]);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_checked_against_their_type() {
        let p = find("merge_eta").unwrap();
        assert_eq!(p.literal("0.4").unwrap(), "0.4::DOUBLE");
        assert!(p.literal("abc").unwrap_err().to_string().contains("merge_eta must be a number or auto, got \"abc\""));
        assert_eq!(p.literal("AUTO").unwrap(), "NULL::DOUBLE");
        assert!(find("overlap_method").unwrap().literal("auto").unwrap_err().to_string().contains("must be one of 'convex', 'concave'"));
        assert_eq!(find("cluster_method").unwrap().literal(" Exact ").unwrap(), "'Exact'");
        assert!(find("cluster_method").unwrap().literal("fast").unwrap_err().to_string().contains("cluster_method must be one of 'auto', 'exact', 'prototypes'"));
        assert!(p.literal("NaN").is_err());
        assert_eq!(find("clean_xi").unwrap().literal("4").unwrap(), "4::BIGINT");
        assert!(find("clean_xi").unwrap().literal("4.5").is_err());
        assert_eq!(find("cluster_translation_invariant").unwrap().literal("TRUE").unwrap(), "true");
        assert_eq!(find("overlap_method").unwrap().literal("concave").unwrap(), "'concave'");
        assert_eq!(find("input_columns").unwrap().literal("'x''; DROP'").unwrap(), "'x''''; DROP'");
    }

    #[test]
    fn resolve_applies_overrides_and_rejects_unknown_names() {
        let v = resolve(&[("merge_eta".into(), "0.4".into())]).unwrap();
        assert_eq!(v.len(), PARAMS.len());
        assert!(v.iter().any(|(p, v)| p.name == "merge_eta" && v == "0.4::DOUBLE"));
        let e = resolve(&[("nope".into(), "1".into())]).unwrap_err().to_string();
        assert!(e.starts_with("pipeline: unknown parameter \"nope\"; known: input_columns, clean_drop_estimated_tails"), "{e}");
        for p in PARAMS {
            p.literal(p.default).unwrap();
        }
    }

    #[test]
    fn json_params_keep_their_order_and_refuse_a_repeated_key() {
        let v = from_json(r#"{"merge_eta": 0.6, "cluster_classes": "car", "clean_drop_estimated_tails": true}"#).unwrap();
        assert_eq!(
            v,
            vec![("merge_eta".into(), "0.6".into()), ("cluster_classes".into(), "car".into()), ("clean_drop_estimated_tails".into(), "true".into())]
        );
        assert!(from_json("").unwrap().is_empty() && from_json(" {} ").unwrap().is_empty());
        let e = from_json(r#"{"merge_eta": 0.6, "merge_resample_s": 0.2, "merge_eta": 0.4}"#).unwrap_err().to_string();
        assert!(e.contains("parameter merge_eta is given twice"), "{e}");
        // the same value twice is still two keys: refused, not guessed
        assert!(from_json(r#"{"merge_eta": 0.6, "merge_eta": 0.6}"#).is_err());
        for bad in ["[1]", "{\"merge_eta\": 0.6} x", "{\"merge_eta\": [1]}", "\"x\""] {
            assert!(from_json(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn numbers_outside_their_range_are_refused() {
        let eta = find("merge_eta").unwrap();
        for bad in ["2", "0", "-0.1", "nan", "inf"] {
            assert!(eta.literal(bad).is_err(), "{bad}");
        }
        let e = eta.literal("2").unwrap_err().to_string();
        assert!(e.contains("merge_eta must be in [0.000000001, 1], got \"2\""), "{e}");
        assert!(find("clean_xi").unwrap().literal("-3").is_err());
        assert!(find("align_max_clock_offset_s").unwrap().literal("3600").is_ok());
        for p in PARAMS {
            assert!(p.lo <= p.hi && !p.lo.is_nan(), "{}", p.name);
        }
    }

    #[test]
    fn the_table_has_a_row_per_parameter_and_aligned_columns() {
        let t = table();
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(lines.len(), PARAMS.len() + 1);
        assert!(lines[0].starts_with("name ") && lines[0].ends_with("  description"), "{}", lines[0]);
        let col = lines[0].find("type").unwrap();
        for (l, p) in lines[1..].iter().zip(PARAMS) {
            assert!(l.starts_with(p.name) && l[col..].starts_with(kind_sql(p.kind)), "{l}");
            assert!(l.ends_with(p.description), "{l}");
        }
        let eta = lines.iter().find(|l| l.starts_with("merge_eta ")).unwrap();
        assert!(eta.contains("[1e-9, 1]"), "{eta}");
    }

    #[test]
    fn sql_params_file_is_generated_from_the_table() {
        let file = include_str!("../../../sql/params.sql");
        assert_eq!(file, params_sql(), "sql/params.sql is stale: run `trajdb params --sql > sql/params.sql`");
    }

    #[test]
    fn every_parameter_is_read_by_its_stage_file() {
        for p in PARAMS {
            // read by its stage, directly or as calibrated('name') (an `auto` parameter: then
            // sql/stages/calibrate.sql reads it to decide between the given and measured value)
            // the load step (stage "load") is in sql/pipeline.sql
            let file = match p.stage {
                "load" => "sql/pipeline.sql".to_string(),
                "report" => "sql/report.sql".to_string(),
                "archive" => "sql/archive_check.sql".to_string(),
                stage => format!("sql/stages/{stage}.sql"),
            };
            // (a stage of several files, align: every file it reads)
            let sql = crate::sql::expand_embedded(&file).unwrap();
            let calib = crate::sql::file("sql/stages/calibrate.sql").unwrap();
            let get = format!("getvariable('{}')", p.name);
            assert!(
                sql.contains(&get) || sql.contains(&format!("calibrated('{}')", p.name)) || calib.contains(&get),
                "{} is never read in its stage",
                p.name
            );
        }
    }
}
