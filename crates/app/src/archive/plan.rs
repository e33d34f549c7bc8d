//! Which site-days a round runs, each with the calibration it starts from: the archive's
//! incremental rule and its calibration chain, written once for every host.
//!
//! A partition is done when the state holds it with the same input fingerprint, build,
//! parameters and calibration in effect, and not failed (a failed one is tried once per run:
//! a task killed for memory may pass next time, a corrupt file fails again in a second). A
//! site's days are walked in date order ([`super::layout::date_order`]) with the calibration in
//! effect; a day that makes (or made last time) its site's calibration runs first and the
//! site's later days wait for the next round, when its folder is there. Cost: O(partitions).

use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};

/// One row of the archive's state (`_state/partitions.parquet`): what was processed from which
/// input, and what came of it (docs/archive.md has the column dictionary).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StateRow {
    pub site: String,
    pub date: String,
    pub status: String,
    pub inputs: Option<String>,
    pub fingerprint: Option<String>,
    pub trajdb_version: Option<String>,
    pub params: Option<String>,
    pub calibration_in: Option<String>,
    pub calibration_out: Option<String>,
    pub calibration_made: Option<bool>,
    pub changes: Option<String>,
    pub cameras: Option<i64>,
    pub points: Option<i64>,
    pub road_users: Option<i64>,
    pub matches: Option<i64>,
    pub checks: Option<String>,
    pub warnings: Option<String>,
    pub error: Option<String>,
}

/// The state's columns in order, with their SQL types (the file's schema).
pub const STATE_COLUMNS: &[(&str, &str)] = &[
    ("site", "VARCHAR"), ("date", "VARCHAR"), ("status", "VARCHAR"), ("inputs", "VARCHAR"), ("fingerprint", "VARCHAR"),
    ("trajdb_version", "VARCHAR"), ("params", "VARCHAR"), ("calibration_in", "VARCHAR"), ("calibration_out", "VARCHAR"),
    ("calibration_made", "BOOLEAN"), ("changes", "VARCHAR"), ("cameras", "BIGINT"), ("points", "BIGINT"), ("road_users", "BIGINT"),
    ("matches", "BIGINT"), ("checks", "VARCHAR"), ("warnings", "VARCHAR"), ("error", "VARCHAR"),
];

/// A partition as the plan sees it: its key and input fingerprint.
#[derive(Clone, Debug)]
pub struct Day<'a> {
    pub site: &'a str,
    pub date: &'a str,
    pub fingerprint: &'a str,
}

/// One task of a round: the index of its partition and the calibration it starts from.
#[derive(Clone, Debug, PartialEq)]
pub struct Task {
    pub index: usize,
    pub cal_id: Option<String>,
}

/// The build and parameters of this run.
pub struct Run<'a> {
    pub build: &'a str,
    pub params_json: &'a str,
}

/// One round's tasks over `days` (sorted by site, then date order). `cal_exists(site, id)`: the
/// calibration's folder is there. `attempted`: (site, date, calibration) run earlier in this run.
/// Without `wait`, every day that needs work (the progress count).
pub fn plan(
    days: &[Day<'_>], state: &HashMap<(String, String), StateRow>, run: &Run<'_>, cal_exists: &dyn Fn(&str, &str) -> bool,
    wait: bool, attempted: &HashSet<(String, String, Option<String>)>,
) -> Vec<Task> {
    let mut tasks = Vec::new();
    let mut k = 0;
    while k < days.len() {
        let site = days[k].site;
        let end = (k..days.len()).find(|&j| days[j].site != site).unwrap_or(days.len());
        let mut cal: Option<String> = None;
        for (j, d) in days.iter().enumerate().take(end).skip(k) {
            let st = state.get(&(site.to_string(), d.date.to_string()));
            let same = st.is_some_and(|st| {
                st.fingerprint.as_deref() == Some(d.fingerprint)
                    && st.trajdb_version.as_deref() == Some(run.build)
                    && st.params.as_deref() == Some(run.params_json)
                    && st.calibration_in == cal
                    && cal.as_deref().is_none_or(|c| cal_exists(site, c))
                    // a day that made a calibration is done only while its folder is there (a
                    // deleted folder is made again by its day, not waited for by the days after)
                    && (!st.calibration_made.unwrap_or(false) || st.calibration_out.as_deref().is_some_and(|c| cal_exists(site, c)))
            });
            if same {
                let st = st.expect("same");
                if st.status == "ok" || attempted.contains(&(site.to_string(), d.date.to_string(), cal.clone())) {
                    cal = st.calibration_out.clone();
                    continue;
                }
            }
            if wait && cal.as_deref().is_some_and(|c| !cal_exists(site, c)) {
                break; // a calibration this round makes: the site's later days wait for the next round
            }
            tasks.push(Task { index: j, cal_id: cal.clone() });
            let makes = cal.is_none() || st.is_some_and(|s| s.calibration_made.unwrap_or(false));
            if cal.is_none() {
                cal = Some(super::fingerprint::calibration_id(d.date, d.fingerprint, run.build, run.params_json));
            }
            if wait && makes {
                break; // it makes the site's calibration again (or may: a camera change): the later days wait for it
            }
        }
        k = end;
    }
    tasks
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(site: &str, date: &str, cin: Option<&str>, cout: &str, made: bool) -> StateRow {
        StateRow {
            site: site.into(), date: date.into(), status: "ok".into(), fingerprint: Some(format!("fp{date}")), trajdb_version: Some("b".into()),
            params: Some("{}".into()), calibration_in: cin.map(str::to_string), calibration_out: Some(cout.into()), calibration_made: Some(made),
            ..Default::default()
        }
    }

    #[test]
    fn chain() {
        let fps: Vec<String> = (1..=3).map(|d| format!("fp{d}")).collect();
        let dates = ["1", "2", "3"];
        let days: Vec<Day> = (0..3).map(|k| Day { site: "s", date: dates[k], fingerprint: &fps[k] }).collect();
        let run = Run { build: "b", params_json: "{}" };
        let none = HashSet::new();
        let mut state = HashMap::new();
        let yes = |_: &str, _: &str| true;
        // nothing done: the first day calibrates, the others wait
        assert_eq!(plan(&days, &state, &run, &yes, true, &none), vec![Task { index: 0, cal_id: None }]);
        assert_eq!(plan(&days, &state, &run, &yes, false, &none).len(), 3);
        let c1 = calibration_id_of("1", "fp1");
        state.insert(("s".into(), "1".into()), row("s", "1", None, &c1, true));
        let t = plan(&days, &state, &run, &yes, true, &none);
        assert_eq!(t, vec![Task { index: 1, cal_id: Some(c1.clone()) }, Task { index: 2, cal_id: Some(c1.clone()) }]);
        state.insert(("s".into(), "2".into()), row("s", "2", Some(&c1), &c1, false));
        state.insert(("s".into(), "3".into()), row("s", "3", Some(&c1), &c1, false));
        assert!(plan(&days, &state, &run, &yes, true, &none).is_empty());
        // the calibration folder deleted: its day makes it again
        let no = |_: &str, _: &str| false;
        assert_eq!(plan(&days, &state, &run, &no, true, &none), vec![Task { index: 0, cal_id: None }]);
        // other parameters: everything again
        let run2 = Run { build: "b", params_json: "{\"x\": \"1\"}" };
        assert_eq!(plan(&days, &state, &run2, &yes, true, &none)[0], Task { index: 0, cal_id: None });
    }

    fn calibration_id_of(date: &str, fp: &str) -> String {
        super::super::fingerprint::calibration_id(date, fp, "b", "{}")
    }
}
