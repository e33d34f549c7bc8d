//! SQL: `trajdb_report_html(data)`, the pipeline's QA report page. `sql/report.sql` gathers the
//! data; the drawing is [`crate::app::report::render`].

use super::registry::{pd, Function, Section, Signature, Ty};
use super::vector::{Args, Out};
use crate::app::report;
use std::error::Error;

pub static FUNCTIONS: &[Function] = &[Function {
    name: "trajdb_report_html",
    description: "The pipeline's QA report (report.html: alignment, calibration, points before and after alignment, view polygons and \
                  overlaps, the thesis's count tables, sample merges, route patterns, parameters) from the data text that \
                  sql/report.sql gathers from the pipeline's tables (sections and cells separated by chr(30) / chr(31)). \
                  Run it through sql/report.sql (SET VARIABLE out_dir = 'results'; .read sql/report.sql, after sql/pipeline.sql), which also writes the file; malformed data is an error naming the section, row and cell.",
    example: "SELECT left(trajdb_report_html(array_to_string(['meta' || chr(31) || 'xi' || chr(31) || '5', 'meta' || chr(31) || 'eta' || chr(31) || '0.6', 'meta' || chr(31) || 'cluster_camera' || chr(31) || '1', 'meta' || chr(31) || 'step' || chr(31) || '1'], chr(30))), 15); -- <!DOCTYPE html>",
    maths: "crates/app/src/report/mod.rs",
    binding: file!(),
    section: Section::Pipeline,
    see_also: &["trajdb_pipeline"],
    signatures: &[Signature {
        params: &[pd("data", Ty::Varchar, "the report's data as sql/report.sql gathers it: sections and cells separated by chr(30) / chr(31)")],
        arities: &[],
        returns: Ty::Varchar,
        kernel: report_html,
    }],
    table: None,
}];

fn report_html(a: &Args<'_>, out: &mut Out<'_>) -> Result<(), Box<dyn Error>> {
    let data = a.text(0);
    let pages = a.map(|r| match data.get(r) {
        None => Ok(None),
        Some(text) => Ok(Some(report::render(&text).map_err(|e| format!("data: {e}"))?)),
    })?;
    out.text(&pages);
    Ok(())
}
