//! What a partition's result depends on, as names: the input files (names, sizes, times and a
//! content fingerprint), the build and the parameters; and the name of the calibration a day
//! makes from them. The strings are the ones the archive's state holds, so an archive made by
//! one host (the SQL call, Python, Spark) is read as done by another.
//!
//! Cost: [`inputs`] is one `stat` per file; [`content`] reads every byte once (BLAKE2b), and
//! is called only when `inputs` differ from the state's (a no-op run reads no data).

use blake2::digest::{Update, VariableOutput};
use blake2::Blake2bVar;
use std::fs::File;
use std::io::Read;
use std::path::Path;

fn blake2b_hex(size: usize, feed: impl FnOnce(&mut Blake2bVar) -> std::io::Result<()>) -> std::io::Result<String> {
    let mut h = Blake2bVar::new(size).expect("a BLAKE2b size of 1..=64 bytes");
    feed(&mut h)?;
    let mut out = vec![0u8; size];
    h.finalize_variable(&mut out).expect("the size given");
    Ok(out.iter().map(|b| format!("{b:02x}")).collect())
}

/// A JSON string as Python's `json.dumps` writes it (`ensure_ascii`): the state's `inputs`
/// must read the same whichever host wrote it.
pub fn json_string(s: &str) -> String {
    let mut o = String::with_capacity(s.len() + 2);
    o.push('"');
    for c in s.chars() {
        match c {
            '"' => o.push_str("\\\""),
            '\\' => o.push_str("\\\\"),
            '\n' => o.push_str("\\n"),
            '\r' => o.push_str("\\r"),
            '\t' => o.push_str("\\t"),
            '\u{8}' => o.push_str("\\b"),
            '\u{c}' => o.push_str("\\f"),
            c if (c as u32) < 0x20 || (c as u32) > 0x7e => {
                let mut buf = [0u16; 2];
                for u in c.encode_utf16(&mut buf) {
                    o.push_str(&format!("\\u{u:04x}"));
                }
            }
            c => o.push(c),
        }
    }
    o.push('"');
    o
}

/// The partition's inputs: `[[path relative to the lake, size, mtime in ns], ...]` as JSON.
pub fn inputs(files: &[std::path::PathBuf], lake: &Path) -> std::io::Result<String> {
    let mut rows = Vec::with_capacity(files.len());
    for f in files {
        let m = std::fs::metadata(f)?;
        let ns = {
            use std::os::unix::fs::MetadataExt;
            m.mtime() as i128 * 1_000_000_000 + m.mtime_nsec() as i128
        };
        let rel = f.strip_prefix(lake).unwrap_or(f);
        rows.push(format!("[{}, {}, {}]", json_string(&rel.to_string_lossy()), m.len(), ns));
    }
    Ok(format!("[{}]", rows.join(", ")))
}

/// The content fingerprint of a partition's files: BLAKE2b-128 over each file's name, a 0 byte,
/// its bytes and a 1 byte, in order; for a partition cut from files by their site column, `-`
/// and 8 hex digits of SHA-1 of the site (the same files hold other sites' days).
pub fn content(files: &[std::path::PathBuf], site_column: Option<&str>) -> std::io::Result<String> {
    let mut hex = blake2b_hex(16, |h| {
        let mut buf = vec![0u8; 1 << 22];
        for f in files {
            h.update(f.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default().as_bytes());
            h.update(b"\0");
            let mut fh = File::open(f)?;
            loop {
                let n = fh.read(&mut buf)?;
                if n == 0 {
                    break;
                }
                h.update(&buf[..n]);
            }
            h.update(b"\x01");
        }
        Ok(())
    })?;
    if let Some(site) = site_column {
        use sha1::Digest;
        let d = sha1::Sha1::digest(site.as_bytes());
        hex.push('-');
        hex.extend(d.iter().take(4).map(|b| format!("{b:02x}")));
    }
    Ok(hex)
}

/// The build a result depends on: the version and 12 hex digits of BLAKE2b over the
/// extension file's bytes (a rebuilt extension may compute other numbers under one version).
pub fn build(version: &str, extension: &Path) -> std::io::Result<String> {
    let hex = blake2b_hex(6, |h| {
        let mut f = File::open(extension)?;
        let mut buf = vec![0u8; 1 << 20];
        loop {
            let n = f.read(&mut buf)?;
            if n == 0 {
                return Ok(());
            }
            h.update(&buf[..n]);
        }
    })?;
    Ok(format!("{version}+{hex}"))
}

/// The parameters as the state holds them: `{"name": "value", ...}` sorted by name, every value
/// as text (Python's `json.dumps(..., sort_keys=True)`).
pub fn params_json(params: &[(String, String)]) -> String {
    let mut v: Vec<&(String, String)> = params.iter().collect();
    v.sort_by(|a, b| a.0.cmp(&b.0));
    v.dedup_by(|a, b| a.0 == b.0);
    format!("{{{}}}", v.iter().map(|(k, x)| format!("{}: {}", json_string(k), json_string(x))).collect::<Vec<_>>().join(", "))
}

/// The name of the calibration a day makes: its date, 12 hex digits of its input's fingerprint,
/// and 8 of BLAKE2b over the build and parameters that made it (made under other parameters, it
/// is another calibration, never reused).
pub fn calibration_id(date: &str, fingerprint: &str, build: &str, params_json: &str) -> String {
    let made_by = blake2b_hex(4, |h| {
        h.update(build.as_bytes());
        h.update(b"\n");
        h.update(params_json.as_bytes());
        Ok(())
    })
    .expect("no I/O");
    let fp: String = fingerprint.chars().take(12).collect();
    format!("{date}-{fp}-{made_by}")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values computed with Python 3's hashlib (the archive's first host), pinned.
    #[test]
    fn same_names_as_python() {
        // hashlib.blake2b(b"0.1.0+abc\n{}", digest_size=4).hexdigest()
        assert_eq!(calibration_id("2026-05-04", "0123456789abcdef", "0.1.0+abc", "{}"), "2026-05-04-0123456789ab-".to_string() + &blake2b_hex(4, |h| {
            h.update(b"0.1.0+abc\n{}");
            Ok(())
        }).unwrap());
        assert_eq!(blake2b_hex(4, |h| { h.update(b"0.1.0+abc\n{}"); Ok(()) }).unwrap(), PY_B2B4);
        assert_eq!(json_string("a\"é\u{1F600}\n"), r#""a\"\u00e9\ud83d\ude00\n""#);
        assert_eq!(params_json(&[("b".into(), "1".into()), ("a".into(), "x".into())]), r#"{"a": "x", "b": "1"}"#);
    }
    const PY_B2B4: &str = "4776a345";

    #[test]
    fn content_as_python() {
        // h = hashlib.blake2b(digest_size=16); h.update(b"x.parquet\0"); h.update(b"hello"); h.update(b"\1")
        let dir = std::env::temp_dir().join(format!("trajdb-fp-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("x.parquet");
        std::fs::write(&f, b"hello").unwrap();
        assert_eq!(content(&[f.clone()], None).unwrap(), "80cbe3bfefd4158c888ccae8ccc603bb");
        // hashlib.sha1(b"site-a").hexdigest()[:8]
        assert_eq!(content(&[f], Some("site-a")).unwrap(), "80cbe3bfefd4158c888ccae8ccc603bb-274fceac");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
