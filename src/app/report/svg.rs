//! Inline SVG for the report: a metric frame with equal scales, points, lines and polygons.

use super::html::esc;
use crate::algo::geometry::region::Region;
use std::fmt::Write as _;

const PALETTE: [&str; 8] = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"];

pub fn color(camera: i64) -> &'static str {
    PALETTE[camera.rem_euclid(PALETTE.len() as i64) as usize]
}


/// World → SVG pixel mapping with equal scales, y up.
pub struct Frame {
    x0: f64,
    y1: f64,
    k: f64,
    w: f64,
    h: f64,
}

impl Frame {
    pub fn fit(xs: impl Iterator<Item = (f64, f64)>, w: f64) -> Frame {
        let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for (x, y) in xs.filter(|(x, y)| x.is_finite() && y.is_finite()) {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        if !x0.is_finite() {
            (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
        }
        let pad = 0.03 * (x1 - x0).max(y1 - y0).max(1.0);
        let (x0, x1, y0, y1) = (x0 - pad, x1 + pad, y0 - pad, y1 + pad);
        let k = w / (x1 - x0).max(y1 - y0);
        Frame { x0, y1, k, w: (x1 - x0) * k, h: (y1 - y0) * k }
    }
    pub fn p(&self, x: f64, y: f64) -> (f64, f64) {
        ((x - self.x0) * self.k, (self.y1 - y) * self.k)
    }
    pub fn open(&self, title: &str) -> String {
        format!(
            "<figure><svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{:.0}\" height=\"{:.0}\" viewBox=\"0 0 {:.1} {:.1}\" style=\"background:#fff;border:1px solid #ccc\">",
            self.w, self.h, self.w, self.h
        ) + &format!("<title>{}</title>", esc(title))
    }
    pub fn close(&self, caption: &str) -> String {
        // a 10 m scale bar
        let (bx, by) = (8.0, self.h - 8.0);
        format!(
            "<line x1=\"{bx}\" y1=\"{by}\" x2=\"{:.1}\" y2=\"{by}\" stroke=\"#000\" stroke-width=\"2\"/><text x=\"{bx}\" y=\"{:.1}\" font-size=\"10\">10 m</text></svg><figcaption>{}</figcaption></figure>",
            bx + 10.0 * self.k,
            by - 4.0,
            esc(caption)
        )
    }
    /// Points as one path of zero-length round-capped segments.
    pub fn dots(&self, pts: &[(f64, f64)], color: &str, r: f64) -> String {
        let mut d = String::with_capacity(pts.len() * 16);
        for &(x, y) in pts {
            let (u, v) = self.p(x, y);
            let _ = write!(d, "M{u:.1} {v:.1}h0");
        }
        format!("<path d=\"{d}\" stroke=\"{color}\" stroke-width=\"{r}\" stroke-linecap=\"round\" stroke-opacity=\"0.5\" fill=\"none\"/>")
    }
    pub fn line(&self, pts: &[(f64, f64)], color: &str, width: f64, dash: bool) -> String {
        let mut d = String::new();
        for (i, &(x, y)) in pts.iter().enumerate() {
            let (u, v) = self.p(x, y);
            let _ = write!(d, "{}{u:.1} {v:.1}", if i == 0 { "M" } else { "L" });
        }
        format!(
            "<path d=\"{d}\" stroke=\"{color}\" stroke-width=\"{width}\" fill=\"none\"{}/>",
            if dash { " stroke-dasharray=\"4 3\"" } else { "" }
        )
    }
    /// A (multi)polygon given as WKT (parsed by the algo's polygon reader).
    pub fn polygon(&self, wkt_text: &str, stroke: &str, fill: &str, fill_opacity: f64) -> String {
        let mut d = String::new();
        for ring in rings(wkt_text) {
            for (i, &(x, y)) in ring.iter().enumerate() {
                let (u, v) = self.p(x, y);
                let _ = write!(d, "{}{u:.1} {v:.1}", if i == 0 { "M" } else { "L" });
            }
            d.push('Z');
        }
        format!("<path d=\"{d}\" stroke=\"{stroke}\" stroke-width=\"1.5\" fill=\"{fill}\" fill-opacity=\"{fill_opacity}\" fill-rule=\"evenodd\"/>")
    }
}

/// Every ring (exterior and holes) of a POLYGON / MULTIPOLYGON WKT; none for empty or invalid text.
pub fn rings(wkt: &str) -> Vec<Vec<(f64, f64)>> {
    let Ok(r) = Region::from_wkt(wkt) else { return Vec::new() };
    let mut out = Vec::new();
    for p in r.polygons() {
        for ring in std::iter::once(p.exterior()).chain(p.interiors()) {
            out.push(ring.coords().map(|c| (c.x, c.y)).collect());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::rings;

    #[test]
    fn rings_of_polygons_and_multipolygons() {
        assert_eq!(rings("POLYGON EMPTY").len(), 0);
        let r = rings("MULTIPOLYGON (((0 0, 1 0, 1 1, 0 0)), ((5 5, 6 5, 6 6, 5 5), (5.1 5.1, 5.2 5.1, 5.2 5.2, 5.1 5.1)))");
        assert_eq!(r.len(), 3);
        assert!(r[1].contains(&(6.0, 6.0)));
    }
}
