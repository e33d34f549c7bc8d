//! Inline SVG for the report: a metric frame with equal scales, points, lines and polygons.

use super::html::esc;
use trajdb_algo::geometry::region::Region;
use std::fmt::Write as _;

const PALETTE: [&str; 8] = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"];

pub fn color(camera: i64) -> &'static str {
    PALETTE[camera.rem_euclid(PALETTE.len() as i64) as usize]
}


/// The width of a plot area in pixels (axes come on top).
pub const PLOT_W: f64 = 420.0;
/// Room for the y tick labels (left) and the x tick labels (below), in pixels.
pub const LEFT: f64 = 46.0;
const BOTTOM: f64 = 30.0;

/// A legend of camera colours (HTML).
pub fn legend(cameras: &[(i64, String)]) -> String {
    let items: Vec<String> = cameras
        .iter()
        .map(|(c, name)| format!("<span class=\"key\"><span class=\"sw\" style=\"background:{}\"></span>camera {}</span>", color(*c), esc(name)))
        .collect();
    format!("<p class=\"legend\">{}</p>", items.join(" "))
}

/// A tick step of 1, 2 or 5 × 10^k metres giving about 5 ticks over `span`.
fn tick_step(span: f64) -> f64 {
    let raw = (span / 5.0).max(1e-9);
    let p = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * p).find(|s| *s >= raw).unwrap_or(10.0 * p)
}

/// A tick label without float noise (0.30000000000000004 -> 0.3).
fn label(t: f64, step: f64) -> String {
    let digits = if step >= 1.0 { 0 } else { (-step.log10().floor()) as usize };
    let s = format!("{:.*}", digits, t);
    if s == "-0" { "0".into() } else { s }
}

/// World → SVG pixel mapping with equal scales, y up, and axes in metres.
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
    /// The world box the frame shows: (x0, x1, y0, y1).
    pub fn bounds(&self) -> (f64, f64, f64, f64) {
        (self.x0, self.x0 + self.w / self.k, self.y1 - self.h / self.k, self.y1)
    }
    /// SVG pixel of world point (x, y).
    pub fn p(&self, x: f64, y: f64) -> (f64, f64) {
        (LEFT + (x - self.x0) * self.k, (self.y1 - y) * self.k)
    }
    /// The axes: ticks and labels in metres along the bottom and the left, and a frame.
    fn axes(&self) -> String {
        let mut a = String::new();
        let (x1, y0) = (self.x0 + self.w / self.k, self.y1 - self.h / self.k);
        let step = tick_step((x1 - self.x0).max(self.y1 - y0));
        let _ = write!(a, "<rect x=\"{LEFT}\" y=\"0\" width=\"{:.1}\" height=\"{:.1}\" fill=\"none\" stroke=\"#999\"/>", self.w, self.h);
        let mut t = (self.x0 / step).ceil() * step;
        while t <= x1 {
            let (u, _) = self.p(t, 0.0);
            let _ = write!(
                a,
                "<line x1=\"{u:.1}\" y1=\"{:.1}\" x2=\"{u:.1}\" y2=\"{:.1}\" stroke=\"#999\"/><text x=\"{u:.1}\" y=\"{:.1}\" font-size=\"10\" text-anchor=\"middle\">{}</text>",
                self.h,
                self.h + 4.0,
                self.h + 14.0,
                label(t, step)
            );
            t += step;
        }
        let mut t = (y0 / step).ceil() * step;
        while t <= self.y1 {
            let (_, v) = self.p(0.0, t);
            let _ = write!(
                a,
                "<line x1=\"{:.1}\" y1=\"{v:.1}\" x2=\"{LEFT}\" y2=\"{v:.1}\" stroke=\"#999\"/><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"10\" text-anchor=\"end\">{}</text>",
                LEFT - 4.0,
                LEFT - 6.0,
                v + 3.5,
                label(t, step)
            );
            t += step;
        }
        let _ = write!(
            a,
            "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"10\" text-anchor=\"middle\">x (m)</text><text x=\"10\" y=\"{:.1}\" font-size=\"10\" transform=\"rotate(-90 10 {:.1})\" text-anchor=\"middle\">y (m)</text>",
            LEFT + self.w / 2.0,
            self.h + BOTTOM - 4.0,
            self.h / 2.0,
            self.h / 2.0
        );
        a
    }
    pub fn open(&self, title: &str) -> String {
        let (w, h) = (LEFT + self.w + 4.0, self.h + BOTTOM);
        format!(
            "<figure style=\"max-width:{w:.0}px\"><svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w:.0}\" height=\"{h:.0}\" viewBox=\"0 0 {w:.1} {h:.1}\" style=\"background:#fff\">"
        ) + &format!("<title>{}</title>", esc(title))
            + &self.axes()
    }
    pub fn close(&self, caption: &str) -> String {
        format!("</svg><figcaption>{}</figcaption></figure>", esc(caption))
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
    /// A text label at world point (x, y), `anchor` start / middle / end, with a white halo so
    /// that it reads over the paths.
    pub fn text(&self, x: f64, y: f64, s: &str, anchor: &str, size: f64) -> String {
        let (u, v) = self.p(x, y);
        format!(
            "<text x=\"{u:.1}\" y=\"{v:.1}\" font-size=\"{size}\" text-anchor=\"{anchor}\" dominant-baseline=\"middle\" \
             paint-order=\"stroke\" stroke=\"#fff\" stroke-width=\"3\" fill=\"#222\">{}</text>",
            esc(s)
        )
    }
    /// A filled circle of `r` pixels at world point (x, y).
    pub fn circle(&self, x: f64, y: f64, r: f64, fill: &str, title: &str) -> String {
        let (u, v) = self.p(x, y);
        format!(
            "<circle cx=\"{u:.1}\" cy=\"{v:.1}\" r=\"{r:.1}\" fill=\"{fill}\" fill-opacity=\"0.75\" stroke=\"#222\" stroke-width=\"0.5\"><title>{}</title></circle>",
            esc(title)
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

/// A bar chart (its own SVG, no world frame): one bar per label, `values` with their colours,
/// the y axis from 0 with about 4 ticks, labels under every `label_every`-th bar. For the
/// report's counts per 15 minutes and its PET / TTC distributions.
pub fn bars(title: &str, labels: &[String], values: &[f64], colors: &[&str], y_label: &str, label_every: usize) -> String {
    let n = values.len().max(1);
    let bw = (560.0 / n as f64).clamp(3.0, 40.0);
    // room on the right for the last label
    let (ph, w) = (160.0, LEFT + bw * n as f64 + 48.0);
    let top = values.iter().copied().fold(0.0, f64::max).max(1.0);
    let step = tick_step(top);
    let k = ph / ((top / step).ceil() * step);
    let mut s = format!(
        "<figure style=\"max-width:{w:.0}px\"><svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w:.0}\" height=\"{:.0}\" viewBox=\"0 0 {w:.1} {:.1}\" style=\"background:#fff\"><title>{}</title>",
        ph + 46.0,
        ph + 46.0,
        esc(title)
    );
    let mut t = 0.0;
    while t * k <= ph + 0.5 {
        let v = 6.0 + ph - t * k;
        let _ = write!(
            s,
            "<line x1=\"{LEFT}\" y1=\"{v:.1}\" x2=\"{:.1}\" y2=\"{v:.1}\" stroke=\"#ddd\"/><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"10\" text-anchor=\"end\">{}</text>",
            w - 4.0,
            LEFT - 4.0,
            v + 3.5,
            label(t, step)
        );
        t += step;
    }
    for (i, v) in values.iter().enumerate() {
        let x = LEFT + i as f64 * bw;
        let hgt = v.max(0.0) * k;
        let _ = write!(
            s,
            "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{hgt:.1}\" fill=\"{}\"><title>{}: {}</title></rect>",
            x + 0.5,
            6.0 + ph - hgt,
            (bw - 1.0).max(1.0),
            colors.get(i).copied().unwrap_or("#1f77b4"),
            esc(labels.get(i).map_or("", String::as_str)),
            v
        );
        if label_every > 0 && i % label_every == 0 {
            let _ = write!(
                s,
                "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"10\" text-anchor=\"start\">{}</text>",
                x + 0.5,
                ph + 20.0,
                esc(labels.get(i).map_or("", String::as_str))
            );
        }
    }
    let _ = write!(
        s,
        "<text x=\"10\" y=\"{:.1}\" font-size=\"10\" transform=\"rotate(-90 10 {:.1})\" text-anchor=\"middle\">{}</text></svg><figcaption>{}</figcaption></figure>",
        6.0 + ph / 2.0,
        6.0 + ph / 2.0,
        esc(y_label),
        esc(title)
    );
    s
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
    use super::{rings, tick_step};

    #[test]
    fn ticks_are_1_2_5_steps() {
        assert_eq!(tick_step(100.0), 20.0);
        assert_eq!(tick_step(40.0), 10.0);
        assert_eq!(tick_step(7.0), 2.0);
    }

    #[test]
    fn rings_of_polygons_and_multipolygons() {
        assert_eq!(rings("POLYGON EMPTY").len(), 0);
        let r = rings("MULTIPOLYGON (((0 0, 1 0, 1 1, 0 0)), ((5 5, 6 5, 6 6, 5 5), (5.5 5.2, 5.8 5.2, 5.8 5.5, 5.5 5.2)))");
        assert_eq!(r.len(), 3);
        assert!(r[1].contains(&(6.0, 6.0)));
    }
}
