//! The report's charts as SVG text, drawn with `plotters`: line and scatter charts, and bars.
//! Text stays `<text>` in the SVG, laid out by the browser.

use plotters::prelude::*;
use plotters::style::RGBColor;

const W: u32 = 760;
const H: u32 = 280;
const COLOURS: [RGBColor; 5] = [
    RGBColor(0x1f, 0x77, 0xb4),
    RGBColor(0xd6, 0x27, 0x28),
    RGBColor(0x2c, 0xa0, 0x2c),
    RGBColor(0x94, 0x67, 0xbd),
    RGBColor(0xff, 0x7f, 0x0e),
];
/// More points than this are thinned: a browser draws a few thousand dots per chart briskly.
const MAX_POINTS: usize = 3000;

/// One series: name, points, drawn as a line or as dots.
pub struct Series<'a> {
    pub name: &'a str,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub dots: bool,
}

fn colour(i: usize) -> RGBColor {
    COLOURS[i % COLOURS.len()]
}

/// The span of the finite values, padded by 5 %; a unit span around a single value.
fn range(v: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = v
        .filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        });
    if !lo.is_finite() {
        return 0.0..1.0;
    }
    if hi - lo <= 0.0 {
        return lo - 0.5..hi + 0.5;
    }
    let pad = 0.05 * (hi - lo);
    lo - pad..hi + pad
}

/// Tick labels for an axis over `r`, all in one format: decimals with as many places as a
/// tenth of the span needs where the values are between 0.01 and 10⁴, scientific otherwise.
fn ticker(r: &std::ops::Range<f64>) -> impl Fn(&f64) -> String {
    let m = r.start.abs().max(r.end.abs());
    let span = (r.end - r.start).abs().max(f64::MIN_POSITIVE);
    let places = (-(span / 10.0).log10()).ceil().clamp(0.0, 6.0) as usize;
    let plain = (1e-2..1e4).contains(&m);
    move |v: &f64| {
        // Below a millionth of the span a tick is zero with rounding noise (-2.8e-17).
        if v.abs() < 1e-6 * span {
            "0".into()
        } else if plain {
            format!("{v:.places$}")
        } else {
            format!("{v:.1e}")
        }
    }
}

/// A drawing error as text (the SVG backend writes into a string and fails only on bugs).
fn failed(e: impl std::fmt::Display) -> String {
    format!("<p>chart not drawn: {e}</p>")
}

/// A chart of several series with axis labels, a legend, and the points of each series thinned
/// to at most [`MAX_POINTS`].
pub fn chart(title: &str, xlabel: &str, ylabel: &str, series: &[Series]) -> String {
    let mut svg = String::new();
    let drawn = (|| -> Result<(), Box<dyn std::error::Error>> {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        root.fill(&WHITE)?;
        let xr = range(series.iter().flat_map(|s| s.x.iter().copied()));
        let yr = range(series.iter().flat_map(|s| s.y.iter().copied()));
        let (xt, yt) = (ticker(&xr), ticker(&yr));
        let mut c = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 15))
            .margin(8)
            .x_label_area_size(34)
            .y_label_area_size(64)
            .build_cartesian_2d(xr, yr)?;
        c.configure_mesh()
            .x_desc(xlabel)
            .y_desc(ylabel)
            .x_label_formatter(&xt)
            .y_label_formatter(&yt)
            .label_style(("sans-serif", 12))
            .axis_desc_style(("sans-serif", 12))
            .light_line_style(WHITE)
            .bold_line_style(BLACK.mix(0.08))
            .draw()?;
        for (i, s) in series.iter().enumerate() {
            let col = colour(i);
            let stride = (s.x.len() / MAX_POINTS).max(1);
            let points =
                s.x.iter()
                    .zip(&s.y)
                    .step_by(stride)
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .map(|(&x, &y)| (x, y));
            if s.dots {
                c.draw_series(points.map(|p| Circle::new(p, 1, col.mix(0.5).filled())))?
                    .label(s.name)
                    .legend(move |(x, y)| Circle::new((x + 8, y), 3, col.filled()));
            } else {
                c.draw_series(LineSeries::new(points, col))?
                    .label(s.name)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], col));
            }
        }
        c.configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.3))
            .draw()?;
        root.present()?;
        Ok(())
    })();
    match drawn {
        Ok(()) => svg,
        Err(e) => failed(e),
    }
}

/// Horizontal bars: one row per label, one bar per model (`values[model][row]`).
pub fn bars(
    title: &str,
    unit: &str,
    labels: &[String],
    values: &[Vec<f64>],
    names: &[String],
) -> String {
    let rows = labels.len().max(1);
    let models = values.len().max(1);
    let height = (70 + rows * (6 + 9 * models)) as u32;
    let vmax = values
        .iter()
        .flatten()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max)
        .max(f64::MIN_POSITIVE);
    let mut svg = String::new();
    let drawn = (|| -> Result<(), Box<dyn std::error::Error>> {
        let root = SVGBackend::with_string(&mut svg, (W, height)).into_drawing_area();
        root.fill(&WHITE)?;
        // One unit per row on the y axis, row 0 at the top; each model's bar a slice of it.
        let mut c = ChartBuilder::on(&root)
            .caption(format!("{title} ({unit})"), ("sans-serif", 15))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(250)
            .build_cartesian_2d(0.0..vmax * 1.05, rows as f64..0.0)?;
        c.configure_mesh()
            .disable_y_mesh()
            .y_labels(rows * 2 + 1)
            .y_label_formatter(&|y| {
                let r = y.floor();
                if (y - r - 0.5).abs() < 1e-6 {
                    labels.get(r as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .x_label_formatter(&ticker(&(0.0..vmax * 1.05)))
            .label_style(("sans-serif", 12))
            .axis_desc_style(("sans-serif", 12))
            .light_line_style(WHITE)
            .bold_line_style(BLACK.mix(0.08))
            .draw()?;
        let slice = 0.8 / models as f64;
        for (m, vals) in values.iter().enumerate() {
            let col = colour(m);
            c.draw_series(vals.iter().enumerate().map(|(r, &v)| {
                let top = r as f64 + 0.1 + slice * m as f64;
                let v = if v.is_finite() { v } else { 0.0 };
                Rectangle::new([(0.0, top), (v, top + slice * 0.9)], col.filled())
            }))?;
        }
        root.present()?;
        Ok(())
    })();
    if let Err(e) = drawn {
        return failed(e);
    }
    // The legend above the chart: inside, it would cover the longest bars.
    let mut legend = String::from("<p>");
    for (m, name) in names.iter().enumerate() {
        let RGBColor(r, g, b) = colour(m);
        legend.push_str(&format!(
            "<span style='color:#{r:02x}{g:02x}{b:02x}'>&#9632;</span> {} &nbsp; ",
            name.replace('&', "&amp;").replace('<', "&lt;")
        ));
    }
    legend.push_str("</p>");
    legend + &svg
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chart_has_its_title_labels_legend_and_points() {
        let svg = chart(
            "drive force over time",
            "time (s)",
            "drive force (N)",
            &[
                Series {
                    name: "measured",
                    x: vec![0.0, 1.0, 2.0],
                    y: vec![0.0, 1.0, 4.0],
                    dots: false,
                },
                Series {
                    name: "model",
                    x: vec![0.0, 1.0, 2.0],
                    y: vec![0.1, 0.9, 4.2],
                    dots: true,
                },
            ],
        );
        assert!(svg.starts_with("<svg"), "{svg}");
        for text in ["drive force over time", "time (s)", "measured", "model"] {
            assert!(svg.contains(text), "{text} in the chart");
        }
        assert!(svg.matches("<circle").count() >= 3, "the model's dots");
        assert!(svg.contains("<polyline"), "the measurement's line");
    }

    #[test]
    fn bars_label_every_row_and_draw_one_bar_per_model_and_row() {
        let labels = vec![
            "direction: moving positive".to_string(),
            "speed: slow".into(),
        ];
        let svg = bars(
            "RMSE by regime",
            "N",
            &labels,
            &[vec![1.0, 2.0], vec![0.5, 0.25]],
            &["rough".into(), "fitted".into()],
        );
        for text in [
            "RMSE by regime (N)",
            "moving positive",
            "speed: slow",
            "fitted",
        ] {
            assert!(svg.contains(text), "{text} in the bars");
        }
        // Two models by two rows and the background.
        assert_eq!(svg.matches("<rect").count(), 4 + 1, "{svg}");
    }

    #[test]
    fn ticks_share_one_format_per_axis() {
        let position = ticker(&(0.0..0.021));
        assert_eq!(position(&0.004), "0.004");
        assert_eq!(position(&0.01), "0.010");
        assert_eq!(position(&-2.8e-17), "0");
        let force = ticker(&(-5.0..40.0));
        assert_eq!(force(&35.0), "35");
        let small = ticker(&(0.0..2e-5));
        assert_eq!(small(&1.5e-5), "1.5e-5");
    }
}
