//! A small SVG plotter: line and scatter charts and bar charts, enough for the report.

use std::fmt::Write as _;

const W: f64 = 720.0;
const H: f64 = 260.0;
const L: f64 = 70.0;
const B: f64 = 30.0;
const COLOURS: [&str; 5] = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e"];

/// One series: name, points, drawn as a line or as dots.
pub struct Series<'a> {
    pub name: &'a str,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub dots: bool,
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn range(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for x in v.filter(|x| x.is_finite()) {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo <= 0.0 {
        (lo - 0.5, hi + 0.5)
    } else {
        let pad = 0.05 * (hi - lo);
        (lo - pad, hi + pad)
    }
}

/// A chart of several series with axis labels. Series are thinned to at most 3000 points.
pub fn chart(title: &str, xlabel: &str, ylabel: &str, series: &[Series]) -> String {
    let (x0, x1) = range(series.iter().flat_map(|s| s.x.iter().copied()));
    let (y0, y1) = range(series.iter().flat_map(|s| s.y.iter().copied()));
    let px = |x: f64| L + (x - x0) / (x1 - x0) * (W - L - 10.0);
    let py = |y: f64| H - B - (y - y0) / (y1 - y0) * (H - B - 25.0);
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg xmlns='http://www.w3.org/2000/svg' width='{W}' height='{H}' font-family='sans-serif' font-size='11'>\
         <rect width='100%' height='100%' fill='white'/>\
         <text x='{L}' y='14' font-size='13'>{}</text>\
         <rect x='{L}' y='25' width='{}' height='{}' fill='none' stroke='#888'/>",
        esc(title),
        W - L - 10.0,
        H - B - 25.0
    );
    for i in 0..=4 {
        let fy = y0 + (y1 - y0) * i as f64 / 4.0;
        let fx = x0 + (x1 - x0) * i as f64 / 4.0;
        let _ = write!(
            s,
            "<text x='{}' y='{}' text-anchor='end'>{fy:.3e}</text><text x='{}' y='{}' text-anchor='middle'>{fx:.3}</text>",
            L - 4.0,
            py(fy) + 4.0,
            px(fx),
            H - B + 14.0
        );
    }
    let _ = write!(
        s,
        "<text x='{}' y='{}' text-anchor='middle'>{}</text><text x='12' y='{}' transform='rotate(-90 12 {})' text-anchor='middle'>{}</text>",
        (W + L) / 2.0,
        H - 3.0,
        esc(xlabel),
        H / 2.0,
        H / 2.0,
        esc(ylabel)
    );
    for (i, se) in series.iter().enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        let stride = (se.x.len() / 3000).max(1);
        if se.dots {
            for (x, y) in se.x.iter().zip(&se.y).step_by(stride) {
                let _ = write!(
                    s,
                    "<circle cx='{:.1}' cy='{:.1}' r='1.2' fill='{c}' fill-opacity='0.5'/>",
                    px(*x),
                    py(*y)
                );
            }
        } else {
            let _ = write!(
                s,
                "<polyline fill='none' stroke='{c}' stroke-width='1' points='"
            );
            for (x, y) in se.x.iter().zip(&se.y).step_by(stride) {
                let _ = write!(s, "{:.1},{:.1} ", px(*x), py(*y));
            }
            s.push_str("'/>");
        }
        let _ = write!(
            s,
            "<text x='{}' y='{}' fill='{c}'>{}</text>",
            W - 200.0,
            40.0 + 13.0 * i as f64,
            esc(se.name)
        );
    }
    s.push_str("</svg>");
    s
}

/// Horizontal bars: one group of values per label (one value per model).
pub fn bars(
    title: &str,
    unit: &str,
    labels: &[String],
    values: &[Vec<f64>],
    names: &[String],
) -> String {
    let rows = labels.len().max(1);
    let per = values.len().max(1);
    let row_h = 6.0 + 9.0 * per as f64;
    let h = 40.0 + row_h * rows as f64;
    let left = 260.0;
    let vmax = values
        .iter()
        .flatten()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max)
        .max(f64::MIN_POSITIVE);
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg xmlns='http://www.w3.org/2000/svg' width='{W}' height='{h}' font-family='sans-serif' font-size='11'>\
         <rect width='100%' height='100%' fill='white'/><text x='4' y='14' font-size='13'>{} ({})</text>",
        esc(title),
        esc(unit)
    );
    for (m, name) in names.iter().enumerate() {
        let _ = write!(
            s,
            "<text x='{}' y='14' fill='{}'>{}</text>",
            W - 260.0 + 130.0 * m as f64,
            COLOURS[m % COLOURS.len()],
            esc(name)
        );
    }
    for (r, label) in labels.iter().enumerate() {
        let y = 30.0 + r as f64 * row_h;
        let _ = write!(
            s,
            "<text x='{}' y='{}' text-anchor='end'>{}</text>",
            left - 4.0,
            y + row_h / 2.0 + 3.0,
            esc(label)
        );
        for (m, vals) in values.iter().enumerate() {
            let v = vals.get(r).copied().unwrap_or(0.0);
            let w = if v.is_finite() {
                v / vmax * (W - left - 80.0)
            } else {
                0.0
            };
            let _ = write!(
                s,
                "<rect x='{left}' y='{}' width='{w:.1}' height='8' fill='{}'/><text x='{}' y='{}'>{v:.2e}</text>",
                y + 3.0 + 9.0 * m as f64,
                COLOURS[m % COLOURS.len()],
                left + w + 3.0,
                y + 10.0 + 9.0 * m as f64
            );
        }
    }
    s.push_str("</svg>");
    s
}
