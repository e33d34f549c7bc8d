//! The lake's layout: which partitions (site, date) it holds and which files each has; the
//! order of a site's days; the names a site or a date may have (they become folder names).
//!
//! Layouts: `site=S/date=D/` (hive style), or `date=D/` of one site (named by the caller, else
//! the lake folder's name), or `date=D/` whose files have a `site` column (the host splits
//! those by its values: it needs to read the files, see [`Layout::Dates`]). Hidden and `_`
//! names are skipped. Cost: one directory walk, O(files · log files).

use super::ArchiveError;
use std::cmp::Ordering;
use std::fs;
use std::path::{Path, PathBuf};

/// One partition: a site's day and its data files (sorted).
#[derive(Clone, Debug, PartialEq)]
pub struct Partition {
    pub site: String,
    pub date: String,
    pub files: Vec<PathBuf>,
    /// Its rows are the ones whose `site` column equals `site` (the date=D/ layout with a site column).
    pub site_column: bool,
}

impl Partition {
    /// "parquet", "csv", "mixed" (refused by the task) or "none" (no data file).
    pub fn format(&self) -> &'static str {
        format_of(&self.files)
    }
}

/// What the lake's folders say (before any file is read).
#[derive(Debug)]
pub enum Layout {
    /// site=S/date=D/: the partitions.
    Sites(Vec<Partition>),
    /// date=D/ folders (site None): the host checks whether the files have a `site` column and
    /// names or splits the partitions ([`name_single_site`], [`split_by_site`]).
    Dates(Vec<Partition>),
}

const DATA: [&str; 3] = [".parquet", ".csv", ".csv.gz"];

fn hidden(name: &str) -> bool {
    name.starts_with('.') || name.starts_with('_')
}

fn key(entry: &str) -> Option<(&str, &str)> {
    let (k, v) = entry.split_once('=')?;
    (matches!(k, "site" | "date") && !v.is_empty()).then_some((k, v))
}

fn sorted_entries(dir: &Path) -> Result<Vec<(String, PathBuf, bool)>, ArchiveError> {
    let rd = fs::read_dir(dir).map_err(|e| ArchiveError(format!("trajdb archive: cannot list {}: {e}", dir.display())))?;
    let mut out = Vec::new();
    for e in rd {
        let e = e.map_err(|e| ArchiveError(format!("trajdb archive: cannot list {}: {e}", dir.display())))?;
        let Ok(name) = e.file_name().into_string() else { continue };
        if hidden(&name) {
            continue;
        }
        let p = e.path();
        out.push((name, p.clone(), p.is_dir()));
    }
    out.sort_by(|a, b| a.0.cmp(&b.0));
    Ok(out)
}

/// The data files below one partition folder (recursively; hidden and `_` names skipped), sorted
/// as a walk that visits each folder's sorted files, then its sorted sub-folders.
pub fn data_files(folder: &Path) -> Result<Vec<PathBuf>, ArchiveError> {
    let mut out = Vec::new();
    let entries = sorted_entries(folder)?;
    for (name, p, _) in entries.iter().filter(|e| !e.2) {
        // regular files only (a FIFO or a device named *.csv would block or never end)
        if DATA.iter().any(|s| name.to_ascii_lowercase().ends_with(s)) && fs::metadata(p).is_ok_and(|m| m.is_file()) {
            out.push(p.clone());
        }
    }
    for (_, p, _) in entries.iter().filter(|e| e.2) {
        out.extend(data_files(p)?);
    }
    Ok(out)
}

fn format_of(files: &[PathBuf]) -> &'static str {
    let parquet = files.iter().filter(|f| f.to_string_lossy().to_ascii_lowercase().ends_with(".parquet")).count();
    match (files.is_empty(), parquet) {
        (true, _) => "none",
        (false, p) if p == files.len() => "parquet",
        (false, 0) => "csv",
        _ => "mixed",
    }
}

/// The partitions the folders of `lake` show.
pub fn discover(lake: &Path) -> Result<Layout, ArchiveError> {
    if !lake.is_dir() {
        return Err(ArchiveError(format!(
            "trajdb archive: the input {:?} is not a folder; give the lake's root folder (site=S/date=D/ partitions)",
            lake.display().to_string()
        )));
    }
    let top = sorted_entries(lake)?;
    let sites: Vec<_> = top.iter().filter(|e| e.2 && key(&e.0).is_some_and(|(k, _)| k == "site")).collect();
    let dates: Vec<_> = top.iter().filter(|e| key(&e.0).is_some_and(|(k, _)| k == "date")).collect();
    let lk = lake.display().to_string();
    if !sites.is_empty() && !dates.is_empty() {
        return Err(ArchiveError(format!(
            "trajdb archive: {lk:?} mixes site= and date= folders at its top; give one layout (site=S/date=D/ or date=D/)"
        )));
    }
    let mut parts = Vec::new();
    if !sites.is_empty() {
        for (name, folder, _) in sites {
            let site = key(name).expect("site=").1.to_string();
            for (e, p, is_dir) in sorted_entries(folder)? {
                if let Some(("date", d)) = key(&e).filter(|_| is_dir) {
                    parts.push(Partition { site: site.clone(), date: d.to_string(), files: data_files(&p)?, site_column: false });
                }
            }
        }
        return Ok(Layout::Sites(parts));
    }
    if !dates.is_empty() {
        for (name, folder, is_dir) in dates {
            let files = if *is_dir { data_files(folder)? } else { Vec::new() };
            parts.push(Partition { site: String::new(), date: key(name).expect("date=").1.to_string(), files, site_column: false });
        }
        return Ok(Layout::Dates(parts));
    }
    Err(ArchiveError(format!(
        "trajdb archive: {lk:?} has no site=S/ or date=D/ folders; lay the lake out as site=S/date=D/*.parquet (hive style; CSV too), or date=D/ for one site"
    )))
}

/// date=D/ partitions of one site: named `site`, else the lake folder's name.
pub fn name_single_site(parts: Vec<Partition>, site: Option<&str>, lake: &Path) -> Vec<Partition> {
    let name = site.map(str::to_string).or_else(|| lake.file_name().map(|n| n.to_string_lossy().into_owned())).unwrap_or_else(|| "site".into());
    parts.into_iter().map(|p| Partition { site: name.clone(), ..p }).collect()
}

/// date=D/ partitions whose files have a site column: one partition per (date, site value)
/// (`values[k]`: the sorted site values of partition k; a partition without any is "(unknown)",
/// which the task then reports as empty).
pub fn split_by_site(parts: Vec<Partition>, values: &[Vec<String>]) -> Vec<Partition> {
    let mut out = Vec::new();
    for (p, vals) in parts.into_iter().zip(values) {
        for s in vals {
            out.push(Partition { site: s.clone(), site_column: true, ..p.clone() });
        }
        if p.files.is_empty() || vals.is_empty() {
            out.push(Partition { site: "(unknown)".into(), site_column: true, ..p });
        }
    }
    out
}

/// The partitions of site `site` only (`site` given for a lake of several sites); an error when
/// the lake has none.
pub fn only_site(parts: Vec<Partition>, site: &str) -> Result<Vec<Partition>, ArchiveError> {
    let sites: Vec<String> = {
        let mut v: Vec<String> = parts.iter().map(|p| p.site.clone()).collect();
        v.sort();
        v.dedup();
        v
    };
    let kept: Vec<Partition> = parts.into_iter().filter(|p| p.site == site).collect();
    if kept.is_empty() {
        return Err(ArchiveError(format!(
            "trajdb archive: site {site:?} is not in the lake (its sites: {}); leave site out for every site",
            sites.iter().take(10).cloned().collect::<Vec<_>>().join(", ")
        )));
    }
    Ok(kept)
}

/// Checks every name and sorts the partitions by site, then [`date_order`].
pub fn finish(mut parts: Vec<Partition>) -> Result<Vec<Partition>, ArchiveError> {
    for p in &parts {
        check_name("site", &p.site)?;
        check_name("date", &p.date)?;
    }
    parts.sort_by(|a, b| a.site.cmp(&b.site).then_with(|| date_order(&a.date, &b.date)));
    Ok(parts)
}

/// A site or date becomes a folder name under OUT: letters, digits and `_ . : + @ -` and
/// spaces, starting with a letter or digit, at most 128 characters, never `..` (a site column's
/// value `x/../../home` would otherwise write outside the archive folder).
pub fn check_name(what: &str, value: &str) -> Result<(), ArchiveError> {
    let ok = !value.is_empty()
        && value.len() <= 128
        && value.chars().next().is_some_and(|c| c.is_ascii_alphanumeric())
        && value.chars().all(|c| c.is_ascii_alphanumeric() || "_.:+@ -".contains(c))
        && !value.contains("..");
    if ok {
        Ok(())
    } else {
        Err(ArchiveError(format!(
            "trajdb archive: the {what} {value:?} cannot name a folder (letters, digits, _ . : + @ - and spaces, starting with a letter or digit, no '..'); rename it in the lake"
        )))
    }
}

/// The calendar date a day's name starts with (2026-05-04, 2026-5-4, 20260504, 2026-05-04T06),
/// or None (a name that is no date).
pub fn calendar(date: &str) -> Option<(u32, u32, u32)> {
    let b = date.as_bytes();
    let digits = |s: &[u8]| s.iter().all(u8::is_ascii_digit);
    let num = |s: &[u8]| std::str::from_utf8(s).ok()?.parse::<u32>().ok();
    if b.len() < 4 || !digits(&b[..4]) {
        return None;
    }
    let y = num(&b[..4])?;
    let rest = &b[4..];
    let (mo, d, end) = if rest.first() == Some(&b'-') {
        // -M(M)-D(D)
        let r = &rest[1..];
        let m_len = r.iter().take_while(|c| c.is_ascii_digit()).count();
        if !(1..=2).contains(&m_len) || r.get(m_len) != Some(&b'-') {
            return None;
        }
        let r2 = &r[m_len + 1..];
        let d_len = r2.iter().take_while(|c| c.is_ascii_digit()).count();
        if !(1..=2).contains(&d_len) {
            return None;
        }
        (num(&r[..m_len])?, num(&r2[..d_len])?, 4 + 1 + m_len + 1 + d_len)
    } else {
        if rest.len() < 4 || !digits(&rest[..4]) {
            return None;
        }
        (num(&rest[..2])?, num(&rest[2..4])?, 8)
    };
    if b.get(end).is_some_and(u8::is_ascii_digit) {
        return None; // (?!\d): 2026-05-041 is no date
    }
    ((1..=12).contains(&mo) && (1..=31).contains(&d)).then_some((y, mo, d))
}

/// The order of a site's days (their calibrations are chained in it): by calendar date, so that
/// 2026-5-10 comes after 2026-5-9; names that are no date after every date, by name.
pub fn date_order(a: &str, b: &str) -> Ordering {
    match (calendar(a), calendar(b)) {
        (Some(x), Some(y)) => x.cmp(&y).then_with(|| a.cmp(b)),
        (Some(_), None) => Ordering::Less,
        (None, Some(_)) => Ordering::Greater,
        (None, None) => a.cmp(b),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_in_calendar_order() {
        let mut v = vec!["2026-5-10", "zz", "2026-5-9", "20260508", "2026-05-09T06", "2026-13-01", "2026-05-041"];
        v.sort_by(|a, b| date_order(a, b));
        assert_eq!(v, ["20260508", "2026-05-09T06", "2026-5-9", "2026-5-10", "2026-05-041", "2026-13-01", "zz"]);
    }

    #[test]
    fn names() {
        assert!(check_name("site", "mellingen 1").is_ok());
        for bad in ["", "x/../y", "..", ".a", "a/b", "a\u{0}", "é"] {
            assert!(check_name("site", bad).is_err(), "{bad:?}");
        }
    }
}
