//! The HTML report: measurement and model over time, residual against velocity, position and
//! supply, error by regime as bars, before/after when several models are given, the residual map
//! of each model against every signal with the structure left in it, and the ladder of
//! `discover` when one was run: the error falling rung by rung, the residual before and after
//! each rung, and the structure it left unexplained.

use std::fmt::Write as _;
use std::path::Path;

use super::compare::{compare, Comparison, Mode};
use super::data::Dataset;
use super::discover::Discovery;
use super::model::Model;
use super::regimes::{breakdown, Breakdown};
use super::signals::Prepared;
use super::structure::{self, Against, MapRow};
use super::svg::{bars, chart, Series};

/// Text safe inside HTML.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Write `index.html` into `dir` for the models on the data, with the ladder of `discover` when
/// one is given; returns the file written.
pub fn write_report(
    dir: &Path,
    data: &Dataset,
    prep: &Prepared,
    models: &[Model],
    mode: Mode,
    ladder: Option<&Discovery>,
) -> anyhow::Result<std::path::PathBuf> {
    std::fs::create_dir_all(dir).map_err(|e| anyhow::anyhow!("{}: {e}", dir.display()))?;
    let mut results: Vec<(Comparison, Breakdown)> = Vec::new();
    for m in models {
        let c = compare(m, data, prep, mode, 10)?;
        let b = breakdown(&c, data, prep);
        results.push((c, b));
    }
    let names: Vec<String> = models.iter().map(|m| m.name.clone()).collect();
    let mut html = String::new();
    let _ = write!(
        html,
        "<!doctype html><html><head><meta charset='utf-8'><title>actuator lab: {}</title>\
         <style>body{{font-family:sans-serif;max-width:760px;margin:auto}}td,th{{padding:2px 8px;text-align:right}}</style></head><body>\
         <h1>Model lab report</h1><p>Data: <code>{}</code>, {} samples, period {:.4} s. Mode: <b>{}</b>.</p><table><tr><th>model</th><th>fit %</th><th>NRMSE</th><th>RMSE</th></tr>",
        esc(&data.origin),
        esc(&data.origin),
        data.len(),
        data.period_s(),
        mode
    );
    for (m, (c, _)) in models.iter().zip(&results) {
        let _ = write!(
            html,
            "<tr><td>{}</td><td>{:.1}</td><td>{:.4}</td><td>{:.3e} {}</td></tr>",
            esc(&m.name),
            c.fit,
            c.nrmse,
            c.rmse,
            c.unit
        );
    }
    html.push_str("</table>");
    for (m, (_, b)) in models.iter().zip(&results) {
        let _ = write!(html, "<p><b>{}</b>: {}</p>", esc(&m.name), esc(&b.worst));
    }
    // Over time.
    let first = &results[0].0;
    let mut series = vec![Series {
        name: "measured",
        x: first.index.iter().map(|&k| data.time[k]).collect(),
        y: first.measured.clone(),
        dots: mode == Mode::InverseDynamics,
    }];
    for (name, (c, _)) in names.iter().zip(&results) {
        series.push(Series {
            name,
            x: c.index.iter().map(|&k| data.time[k]).collect(),
            y: c.predicted.clone(),
            dots: mode == Mode::InverseDynamics,
        });
    }
    html.push_str(&chart(
        &format!("{} over time", first.quantity),
        "time (s)",
        &format!("{} ({})", first.quantity, first.unit),
        &series,
    ));
    // Residual against velocity, position, supply.
    let pos_unit = super::compare::units(&models[0]).0;
    let mut against = |label: &str, axis: &str, f: &dyn Fn(usize) -> f64| {
        let series: Vec<Series> = names
            .iter()
            .zip(&results)
            .map(|(name, (c, _))| Series {
                name,
                x: c.index.iter().map(|&k| f(k)).collect(),
                y: c.residual(),
                dots: true,
            })
            .collect();
        html.push_str(&chart(
            &format!("residual against {label}"),
            axis,
            &format!("residual ({})", first.unit),
            &series,
        ));
    };
    against("velocity", &format!("velocity ({pos_unit}/s)"), &|k| {
        prep.v[k]
    });
    against("position", &format!("position ({pos_unit})"), &|k| {
        data.output[k]
    });
    if let Some(s) = &data.supply {
        against("supply", "supply (V or Pa)", &|k| s[k]);
    }
    // Error by regime.
    let labels: Vec<String> = results[0]
        .1
        .regimes
        .iter()
        .map(|r| format!("{}: {}", r.group, r.label))
        .collect();
    let values: Vec<Vec<f64>> = results
        .iter()
        .map(|(_, b)| {
            labels
                .iter()
                .map(|l| {
                    b.regimes
                        .iter()
                        .find(|r| format!("{}: {}", r.group, r.label) == *l)
                        .map_or(0.0, |r| r.rmse)
                })
                .collect()
        })
        .collect();
    html.push_str(&bars(
        "RMSE by regime",
        &first.unit,
        &labels,
        &values,
        &names,
    ));
    html.push_str("<h2>Residual tests (95 % bounds)</h2><table><tr><th>model</th><th>test</th><th>value</th><th>bound</th><th>pass</th></tr>");
    for (name, (_, b)) in names.iter().zip(&results) {
        for t in &b.tests {
            let _ = write!(
                html,
                "<tr><td>{}</td><td>{}</td><td>{:.3}</td><td>{:.3}</td><td>{}</td></tr>",
                esc(name),
                t.name,
                t.value,
                t.bound,
                if t.pass { "yes" } else { "no" }
            );
        }
    }
    html.push_str("</table>");
    html.push_str(&map_section(models, data, prep)?);
    if let Some(found) = ladder {
        html.push_str(&ladder_section(found, data, prep)?);
    }
    html.push_str("</body></html>\n");
    let path = dir.join("index.html");
    std::fs::write(&path, html).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(path)
}

/// The residual map: each model's balance residual (free parameters refitted) as its means
/// over bins of position, velocity, acceleration, command, command rate, supply and time, and
/// the structures left in it that no effect of the catalogue makes.
pub fn map_section(models: &[Model], data: &Dataset, prep: &Prepared) -> anyhow::Result<String> {
    let mut html = String::from(
        "<h2>Residual map</h2><p>The residual of the balance (free parameters refitted), its mean \
         over 16 bins of equal count of each signal; the share is the part of the residual's \
         variance the bin means hold. Structures: a sinusoid in position or time, or a drift, \
         holding at least 30 % of the variance.</p>",
    );
    let mut maps = Vec::new();
    for m in models {
        let (_, fit) = super::regress::fit_spec(&m.spec, data, prep, None)?;
        maps.push(structure::analyse(&fit.residual, &fit.index, data, prep));
    }
    let (position_unit, force_unit) = super::compare::units(&models[0]);
    html.push_str("<table><tr><th>model</th><th>structure left</th></tr>");
    for (m, map) in models.iter().zip(&maps) {
        let text = if map.structures.is_empty() {
            "none".to_string()
        } else {
            map.structures
                .iter()
                .map(|s| esc(&s.describe(position_unit, force_unit)))
                .collect::<Vec<_>>()
                .join("<br>")
        };
        let _ = write!(
            html,
            "<tr><td>{}</td><td style='text-align:left'>{text}</td></tr>",
            esc(&m.name)
        );
    }
    html.push_str("</table>");
    for against in Against::ALL {
        let rows: Vec<(&Model, &MapRow)> = models
            .iter()
            .zip(&maps)
            .filter_map(|(m, map)| {
                map.rows
                    .iter()
                    .find(|r| r.against == against)
                    .map(|r| (m, r))
            })
            .collect();
        if rows.is_empty() {
            continue;
        }
        let names: Vec<String> = rows
            .iter()
            .map(|(m, r)| format!("{} (share {:.0} %)", m.name, 100.0 * r.share))
            .collect();
        let series: Vec<Series> = rows
            .iter()
            .zip(&names)
            .map(|((_, r), name)| Series {
                name,
                x: r.centres.clone(),
                y: r.means.clone(),
                dots: false,
            })
            .collect();
        html.push_str(&chart(
            &format!("residual map: against {}", against.name().replace('_', " ")),
            against.name(),
            &format!("mean residual ({force_unit})"),
            &series,
        ));
    }
    Ok(html)
}

/// The ladder of `discover`: its table, the NRMSE of each rung as bars, and per rung the residual
/// of the balance (inverse dynamics, the model fitted) before and after the effect was added.
pub fn ladder_section(
    found: &Discovery,
    data: &Dataset,
    prep: &Prepared,
) -> anyhow::Result<String> {
    let mut html = String::new();
    let _ = write!(
        html,
        "<h2>Discover: the ladder</h2><p>From <b>{}</b>, the effect each diagnosis named added and \
         the model refitted, until no candidate is significant (or none of the catalogue explains the \
         error, or the record cannot decide between candidates). NRMSE of the diagnosis (free \
         parameters refitted, rest and motion).</p><table><tr><th>step</th><th>effect added</th>\
         <th>NRMSE before</th><th>after</th><th>held-out drop</th><th>ΔBIC</th><th>evidence</th></tr>",
        esc(&found.start.name)
    );
    for (i, s) in found.steps.iter().enumerate() {
        let _ = write!(
            html,
            "<tr><td>{}</td><td>{}</td><td>{:.4}</td><td>{:.4}</td><td>{:.1} %</td><td>{:.1}</td>\
             <td style='text-align:left'>{}</td></tr>",
            i + 1,
            esc(&s.effect),
            s.nrmse_before,
            s.nrmse,
            100.0 * s.holdout_improvement,
            s.delta_bic,
            esc(&s.evidence)
        );
    }
    html.push_str("</table>");
    let with: Vec<&str> = found.model.effects().iter().map(|e| e.name()).collect();
    let _ = write!(
        html,
        "<p>{}; final model with {}: NRMSE {:.4}.</p>",
        esc(&found.stopped_because()),
        if with.is_empty() {
            "no effects".to_string()
        } else {
            esc(&with.join(", "))
        },
        found.nrmse_final
    );
    let (position_unit, force_unit) = super::compare::units(&found.start);
    for s in &found.unexplained {
        let _ = write!(
            html,
            "<p><b>Unexplained</b>: {}; {}</p>",
            esc(&s.describe(position_unit, force_unit)),
            esc(s.hint())
        );
    }
    let mut labels = vec!["as given (refitted)".to_string()];
    let mut values = vec![found.nrmse_base];
    for s in &found.steps {
        labels.push(format!("+{}", s.effect));
        values.push(s.nrmse);
    }
    html.push_str(&bars(
        "NRMSE step by step",
        "dimensionless",
        &labels,
        &[values],
        &["NRMSE (diagnosis)".to_string()],
    ));
    let mut before = &found.start;
    for (i, s) in found.steps.iter().enumerate() {
        let a = compare(before, data, prep, Mode::InverseDynamics, 10)?;
        let b = compare(&s.model, data, prep, Mode::InverseDynamics, 10)?;
        let names = [
            format!("before (NRMSE {:.4})", a.nrmse),
            format!("after +{} (NRMSE {:.4})", s.effect, b.nrmse),
        ];
        let series: Vec<Series> = [(&names[0], &a), (&names[1], &b)]
            .into_iter()
            .map(|(name, c)| Series {
                name,
                x: c.index.iter().map(|&k| data.time[k]).collect(),
                y: c.residual(),
                dots: true,
            })
            .collect();
        html.push_str(&chart(
            &format!("step {}: +{}, residual before and after", i + 1, s.effect),
            "time (s)",
            &format!("residual of the {} ({})", a.quantity, a.unit),
            &series,
        ));
        before = &s.model;
    }
    Ok(html)
}
