//! The lab's command line: `actuator compare | diagnose | discover | fit | report`: arguments,
//! progress bars and printing around the library's [`actuatord::lab`].

use std::io::IsTerminal;
use std::path::PathBuf;

use clap::{Args, Subcommand};

use crate::choice::Choice;

use actuatord::lab::command::Command;
use actuatord::lab::compare::{compare, default_mode, holdout, units, Mode};
use actuatord::lab::data::{load, Columns, Dataset};
use actuatord::lab::diagnose::{diagnose, DiagnoseOptions};
use actuatord::lab::discover::discover;
use actuatord::lab::methods::{fit_model, FitMethod, FitOptions, Status};
use actuatord::lab::model::Model;
use actuatord::lab::regimes::breakdown;
use actuatord::lab::regress::fit_spec;
use actuatord::lab::signals::{prepare, Prepared};

/// Where the data is and which columns hold what.
#[derive(Debug, Clone, Args)]
pub struct DataArgs {
    /// Data file: CSV with a header row, or an MCAP recording of the daemon. Repeat it to take
    /// several records together (e.g. one per supply pressure): each stays a stretch of its own.
    #[arg(long, required = true)]
    pub data: Vec<PathBuf>,
    /// CSV column with the time in s.
    #[arg(long, default_value = "time")]
    pub time: String,
    /// CSV column with the command.
    #[arg(long, default_value = "u")]
    pub input: String,
    /// CSV column with the measured position.
    #[arg(long, default_value = "y")]
    pub output: String,
    /// CSV column with the supply (V or Pa); default `supply` when present.
    #[arg(long)]
    pub supply: Option<String>,
    /// CSV column with the current (A); default `i` when present.
    #[arg(long)]
    pub current: Option<String>,
    /// What the command column is (default: the model's own, or its family's).
    #[arg(long, value_parser = Choice::<Command>::parser())]
    pub command: Option<Command>,
    /// Corner of the zero-phase filter for derivatives, Hz (default: a tenth of the sample rate,
    /// at most 50 Hz, or 2.5 times a resonance the position rings at above that).
    #[arg(long)]
    pub cutoff_hz: Option<f64>,
}

/// Which model.
#[derive(Debug, Clone, Args)]
pub struct ModelArgs {
    /// Model file (`config/models/*.toml`).
    #[arg(long, conflicts_with = "family")]
    pub model: Option<PathBuf>,
    /// Plant family: linear_axis, solenoid, pneumatic, motor_gear.
    #[arg(long)]
    pub family: Option<String>,
    /// Effects to add to the family, comma separated; with --model, effects of the catalogue or
    /// terms the model file declares as candidates (`[[lab.term]]`) made part of the model.
    #[arg(long, value_delimiter = ',')]
    pub with: Vec<String>,
}

/// The lab's commands.
#[derive(Debug, Clone, Subcommand)]
pub enum LabCommand {
    /// Compare a model with measurements: fit %, NRMSE, RMSE, error by regime, residual tests.
    Compare {
        #[command(flatten)]
        data: DataArgs,
        #[command(flatten)]
        model: ModelArgs,
        /// Prediction mode (default: inverse_dynamics; free_run for motor_gear).
        #[arg(long, value_parser = Choice::<Mode>::parser())]
        mode: Option<Mode>,
        /// Horizon of k_step in samples.
        #[arg(long, default_value_t = 10)]
        k: usize,
        /// Hold out this fraction of the samples (the last ones, e.g. 0.3): refit the free
        /// parameters on the rest and report fit and NRMSE on both parts.
        #[arg(long, value_name = "FRACTION")]
        holdout: Option<f64>,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Name the effect most likely missing from a model, with evidence.
    Diagnose {
        #[command(flatten)]
        data: DataArgs,
        #[command(flatten)]
        model: ModelArgs,
        /// Smallest relative NRMSE drop that counts, in and out of sample.
        #[arg(long, default_value_t = 0.05)]
        min_improvement: f64,
        /// Print the JSON contract.
        #[arg(long)]
        json: bool,
    },
    /// Diagnose, add the effect named, refit, repeat until nothing is significant; print the
    /// ladder and write the final model.
    Discover {
        #[command(flatten)]
        data: DataArgs,
        #[command(flatten)]
        model: ModelArgs,
        /// Smallest relative NRMSE drop that counts, in and out of sample.
        #[arg(long, default_value_t = 0.05)]
        min_improvement: f64,
        /// Where to write the final model.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Fit the free parameters and write the updated model file.
    Fit {
        #[command(flatten)]
        data: DataArgs,
        #[command(flatten)]
        model: ModelArgs,
        /// Where to write the fitted model.
        #[arg(long)]
        out: PathBuf,
        /// Identification method: least_squares (inverse dynamics, one batch), recursive (the
        /// same regression sample by sample, with forgetting: shows drift), output_error
        /// (Levenberg-Marquardt on the predicted position, from the least-squares estimate).
        #[arg(long, value_parser = Choice::<FitMethod>::parser(), default_value = "least_squares")]
        method: FitMethod,
        /// Forgetting factor of --method recursive, in (0, 1]; memory about 1/(1-λ) samples.
        #[arg(long, default_value_t = 1.0)]
        forgetting: f64,
        /// Criterion of --method output_error: k_step (works in closed loop) or free_run.
        #[arg(long, value_parser = Choice::<Mode>::parser(), default_value = "k_step")]
        mode: Mode,
        /// Horizon of the k_step criterion, samples.
        #[arg(long, default_value_t = 10)]
        k: usize,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Write an HTML report with plots for one or more models (before/after).
    Report {
        #[command(flatten)]
        data: DataArgs,
        /// Model files; give several to compare before and after.
        #[arg(long, required_unless_present = "family")]
        model: Vec<PathBuf>,
        /// Plant family of a first model (before), with the effects of --with, refitted.
        #[arg(long)]
        family: Option<String>,
        /// Effects of the --family model, comma separated.
        #[arg(long, value_delimiter = ',', requires = "family")]
        with: Vec<String>,
        /// Prediction mode.
        #[arg(long, value_parser = Choice::<Mode>::parser(), default_value = "inverse_dynamics")]
        mode: Mode,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Run `discover` from the first model (the --family one, or the first --model) and
        /// draw its ladder: the error rung by rung, the residual before and after each rung.
        #[arg(long)]
        discover: bool,
        /// Smallest relative NRMSE drop that counts for --discover, in and out of sample.
        #[arg(long, default_value_t = 0.05, requires = "discover")]
        min_improvement: f64,
    },
}

/// Read the data, make every model read its command column as `--command` says, and prepare
/// the signals.
fn load_data(a: &DataArgs, models: &mut [&mut Model]) -> anyhow::Result<(Dataset, Prepared)> {
    let cols = Columns {
        time: a.time.clone(),
        input: a.input.clone(),
        output: a.output.clone(),
        supply: Some(a.supply.clone().unwrap_or_else(|| "supply".into())),
        current: Some(a.current.clone().unwrap_or_else(|| "i".into())),
    };
    let mut data = Dataset::concat(
        a.data
            .iter()
            .map(|p| load(p, &cols))
            .collect::<Result<Vec<_>, _>>()?,
    )?;
    if let Some(c) = a.command {
        for m in models.iter_mut() {
            c.apply(&mut m.spec, &mut data)
                .map_err(|e| anyhow::anyhow!("{}: {e}", m.name))?;
        }
    }
    if let Some(fc) = a.cutoff_hz {
        if !(fc > 0.0 && fc.is_finite()) {
            anyhow::bail!("--cutoff-hz must be > 0, got {fc}");
        }
    }
    let prep = prepare(&data, a.cutoff_hz);
    Ok((data, prep))
}

/// Each record of `a` alone, prepared on its own and its command read as `model` reads it; none
/// for a single record.
fn load_records(a: &DataArgs, model: &ModelArgs) -> anyhow::Result<Vec<(Dataset, Prepared)>> {
    if a.data.len() < 2 {
        return Ok(Vec::new());
    }
    a.data
        .iter()
        .map(|p| {
            let single = DataArgs {
                data: vec![p.clone()],
                ..a.clone()
            };
            load_data(&single, &mut [&mut load_model(model)?])
        })
        .collect()
}

/// The records' own verdicts beside the joint answer, as text.
fn print_story(story: &actuatord::lab::story::Story) {
    println!(
        "
each record alone:"
    );
    for r in &story.records {
        match &r.refused {
            Some(why) => println!("  {:<28} not diagnosed: {why}", r.origin),
            None => println!(
                "  {:<28} verdict {:<20} significant: {}",
                r.origin,
                if r.undecided.is_empty() {
                    r.verdict.clone()
                } else {
                    format!("undecided ({})", r.undecided.join(", "))
                },
                if r.significant.is_empty() {
                    "none".to_string()
                } else {
                    r.significant.join(", ")
                }
            ),
        }
    }
    println!(
        "holds in every record: {}",
        if story.every.is_empty() {
            "none".to_string()
        } else {
            story.every.join(", ")
        }
    );
    for h in &story.some {
        println!("holds in some: {} ({})", h.effect, h.records.join(", "));
    }
}

fn load_model(a: &ModelArgs) -> anyhow::Result<Model> {
    match (&a.model, &a.family) {
        (Some(p), _) => {
            let mut m = Model::load(p)?;
            for name in a.with.iter().map(|w| w.trim()).filter(|w| !w.is_empty()) {
                actuatord::lab::diagnose::Addition::named(&m.spec, name)
                    .and_then(|add| add.add_to(&mut m.spec))
                    .map_err(|e| anyhow::anyhow!("{}: --with {name}: {e}", p.display()))?;
            }
            Ok(m)
        }
        (None, Some(f)) => Model::from_names(f, &a.with),
        (None, None) => anyhow::bail!("give a model: --model FILE or --family F [--with a,b]"),
    }
}

/// A progress bar on a terminal, made when the first report tells the total (nothing when
/// stderr is not a terminal). Shared by reference with the worker threads that report.
#[derive(Default)]
struct Progress(std::sync::Mutex<Option<indicatif::ProgressBar>>);

impl Progress {
    fn report(&self, done: usize, total: usize, message: &str) {
        let Ok(mut bar) = self.0.lock() else { return };
        if bar.is_none() && std::io::stderr().is_terminal() {
            let pb = indicatif::ProgressBar::new(total as u64);
            if let Ok(style) = indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} {msg}")
            {
                pb.set_style(style);
            }
            *bar = Some(pb);
        }
        if let Some(p) = bar.as_ref() {
            p.set_position(done as u64);
            p.set_message(message.to_string());
        }
    }

    fn finish(&self) {
        if let Ok(bar) = self.0.lock() {
            if let Some(p) = bar.as_ref() {
                p.finish_and_clear();
            }
        }
    }
}

/// Run a lab command and print its result.
pub fn run(cmd: LabCommand) -> anyhow::Result<()> {
    match cmd {
        LabCommand::Compare {
            data,
            model,
            mode,
            k,
            holdout: fraction,
            json,
        } => {
            let mut m = load_model(&model)?;
            let (d, prep) = load_data(&data, &mut [&mut m])?;
            let mode = mode.unwrap_or_else(|| default_mode(&m));
            let c = compare(&m, &d, &prep, mode, k)?;
            let b = breakdown(&c, &d, &prep);
            let held = fraction
                .map(|f| holdout(&m, &d, &prep, mode, k, f))
                .transpose()?;
            let drive = actuatord::lab::drive::identify(&m.spec, &d, &prep)?;
            if json {
                let out = serde_json::json!({
                    "mode": c.mode.name(), "quantity": c.quantity, "unit": c.unit,
                    "fit": c.fit, "nrmse": c.nrmse, "rmse": c.rmse, "samples": c.index.len(),
                    "data_samples": d.len(),
                    "note": c.note, "regimes": b.regimes, "tests": b.tests, "worst": b.worst,
                    "holdout": held,
                    "drive": drive.iter().map(|c| serde_json::json!({
                        "name": c.name, "declared": c.declared, "is_declared": c.is_declared,
                        "value": c.value, "low": c.low, "high": c.high,
                        "contradicted": c.contradicted(), "message": c.sentence()})).collect::<Vec<_>>(),
                });
                println!("{}", serde_json::to_string_pretty(&out)?);
                return Ok(());
            }
            println!("model {} on {} ({} samples)", m.name, d.origin, d.len());
            println!(
                "mode {}: {} fit {:.1} %, NRMSE {:.4}, RMSE {:.3e} {}  ({})",
                c.mode, c.quantity, c.fit, c.nrmse, c.rmse, c.unit, c.note
            );
            println!("\nerror by regime:");
            println!(
                "  {:<10} {:<42} {:>8} {:>11} {:>11} {:>6}",
                "group", "regime", "samples", "RMSE", "mean", "share"
            );
            for r in &b.regimes {
                println!(
                    "  {:<10} {:<42} {:>8} {:>11.3e} {:>+11.3e} {:>5.1}%",
                    r.group,
                    r.label,
                    r.samples,
                    r.rmse,
                    r.mean,
                    100.0 * r.share
                );
            }
            println!("\nresidual tests (95 % bounds):");
            for t in &b.tests {
                println!(
                    "  {:<32} {:>8.3} (bound {:.3}, lag {:>3})  {}",
                    t.name,
                    t.value,
                    t.bound,
                    t.lag,
                    if t.pass { "pass" } else { "FAIL" }
                );
            }
            println!("\n{}", b.worst);
            if !drive.is_empty() {
                println!("\ndrive constants from the data (95 % intervals):");
                for c in &drive {
                    println!(
                        "  {}{}",
                        c.sentence(),
                        if c.contradicted() {
                            "  <- the data contradict the declared value"
                        } else {
                            ""
                        }
                    );
                }
            }
            if let Some(h) = held {
                println!(
                    "\nheld-out validation (last {:.0} %, from t = {:.3} s; {}):",
                    100.0 * h.fraction,
                    h.split_time_s,
                    h.note
                );
                for (part, s) in [("training", h.training), ("held out", h.held_out)] {
                    println!(
                        "  {part:<9} {:>8} samples  fit {:>6.1} %  NRMSE {:.4}  RMSE {:.3e} {}",
                        s.samples, s.fit, s.nrmse, s.rmse, c.unit
                    );
                }
            }
            Ok(())
        }
        LabCommand::Diagnose {
            data,
            model,
            min_improvement,
            json,
        } => {
            let mut m = load_model(&model)?;
            let (d, prep) = load_data(&data, &mut [&mut m])?;
            let opts = DiagnoseOptions {
                min_improvement,
                ..DiagnoseOptions::default()
            };
            let bar = Progress::default();
            let dg = diagnose(&m, &d, &prep, &opts, &|done, total, name| {
                bar.report(done, total, name)
            })?;
            bar.finish();
            let records = load_records(&data, &model)?;
            let story = (!records.is_empty()).then(|| {
                actuatord::lab::story::per_record(
                    &m,
                    &records,
                    &opts,
                    &actuatord::lab::story::joint_effects(&dg),
                )
            });
            if json {
                let mut j = dg.to_json();
                if let Some(story) = &story {
                    j["per_record"] = story.to_json();
                }
                println!("{}", serde_json::to_string_pretty(&j)?);
                return Ok(());
            }
            println!(
                "model {} on {}: mode {}, NRMSE {:.4} (free parameters refitted), {} moving samples (N_eff {:.0})\n\
                 NRMSE here weighs the samples at rest as much as the moving ones (`compare` and `fit` give motion alone)",
                m.name, d.origin, dg.mode, dg.nrmse_base, dg.samples, dg.effective_samples
            );
            if let Some(why) = &dg.base_refused {
                println!(
                    "the model as given does not stand on this record: {why}; its candidates \
                     are judged against it, and `fit` would not write it (declare what the record \
                     cannot determine in [lab] fixed)"
                );
            }
            println!(
                "\n  {:<20} {:>8} {:>8} {:>9} {:>9} {:>10} {:>10}  evidence",
                "effect", "NRMSE", "drop", "held-out", "predicted", "ΔBIC", "p"
            );
            for c in &dg.candidates {
                println!(
                    "{} {:<20} {:>8.4} {:>7.1}% {:>8.1}% {:>9} {:>10.1} {:>10.2e}  {}",
                    if c.significant { "*" } else { " " },
                    c.effect,
                    c.nrmse,
                    100.0 * c.improvement,
                    100.0 * c.holdout_improvement,
                    c.prediction_improvement
                        .map_or_else(|| "-".to_string(), |p| format!("{:.1}%", 100.0 * p)),
                    c.delta_bic,
                    c.p_value,
                    c.evidence
                );
            }
            println!(
                "  (held-out: the drop on the last {:.0} % of the record; predicted: how much the \
                 error of the {}-step prediction of the motion there falls)",
                100.0 * opts.holdout,
                actuatord::lab::predict::HORIZON
            );
            if !dg.not_assessed.is_empty() {
                println!(
                    "\nnot assessed from this data: {}",
                    dg.not_assessed.join(", ")
                );
            }
            let (position_unit, force_unit) = units(&m);
            let structures = &dg.residual_map.structures;
            if !structures.is_empty() {
                let whose = match &dg.verdict {
                    Some(v) => format!("the model with {v}"),
                    None => "the model as it is".to_string(),
                };
                println!(
                    "\nstructure left in the residual of {whose} (RMS {:.3e} {force_unit}):",
                    dg.residual_map.rms
                );
                for s in structures {
                    println!("  {}", s.describe(position_unit, force_unit));
                }
            }
            match (&dg.verdict, structures.first()) {
                (Some(v), None) => println!("\nverdict: {v} is most likely missing (add it: --with {v}, then `actuator fit`)"),
                (Some(v), Some(s)) => println!(
                    "\nverdict: {v} is most likely missing (add it: --with {v}, then `actuator fit`); \
                     beside it the error holds structure no candidate explains ({}): {}",
                    s.describe(position_unit, force_unit),
                    s.hint()
                ),
                (None, Some(s)) if dg.unexplained => {
                    let best = dg.candidates.first().filter(|c| c.significant).map_or_else(
                        String::new,
                        |c| format!(" The best candidate, {}, cuts the error by {:.0} % but leaves this structure.", c.effect, 100.0 * c.improvement),
                    );
                    println!(
                        "\nverdict: unexplained — none of the catalogue. The error lives here: {}; {}{best}",
                        s.describe(position_unit, force_unit),
                        s.hint()
                    )
                }
                (None, _) if !dg.undecided.is_empty() => {
                    let z = dg
                        .rivals
                        .iter()
                        .map(|r| match r.z {
                            Some(z) => format!("{} z = {z:+.2}", r.effect),
                            None => format!("{} z not computable (identical fits)", r.effect),
                        })
                        .collect::<Vec<_>>()
                        .join(", ");
                    println!(
                        "\nverdict: undecided between {} — each explains the error significantly, and this record \
                         cannot tell them apart (Vuong's test of {} against the others: {z}; |z| < {} is no decision).\n\
                         {}.",
                        dg.undecided.join(", "),
                        dg.undecided[0],
                        actuatord::lab::undecided::DECIDING_Z,
                        dg.separating_record.as_deref().unwrap_or_default()
                    )
                }
                _ => match dg.candidates.iter().find(|c| dg.unconfirmed.contains(&c.effect)) {
                    Some(c) => println!(
                        "\nverdict: none confirmed — {} cuts the error by {:.0} % on the whole record (ΔBIC {:.1}) but \
                         {}: the record suggests it without confirming it{}",
                        c.effect,
                        100.0 * c.improvement,
                        c.delta_bic,
                        match c.prediction_improvement {
                            Some(p) if c.holdout_improvement > 0.0 => format!(
                                "its prediction of the held-out motion errs {:.0} % more than the model's without it",
                                -100.0 * p
                            ),
                            _ => format!("{:+.0} % on its held-out part", 100.0 * c.holdout_improvement),
                        },
                        if dg.unconfirmed.len() > 1 {
                            format!(" (so do {})", dg.unconfirmed[1..].join(", "))
                        } else {
                            String::new()
                        }
                    ),
                    None => println!("\nverdict: none — no candidate improves the fit significantly and the residual holds no structure"),
                },
            }
            if let Some(story) = &story {
                println!("\nThe verdict above is the records' taken together.");
                print_story(story);
            }
            Ok(())
        }
        LabCommand::Discover {
            data,
            model,
            min_improvement,
            out,
            json,
        } => {
            let mut m = load_model(&model)?;
            let (d, prep) = load_data(&data, &mut [&mut m])?;
            let opts = DiagnoseOptions {
                min_improvement,
                ..DiagnoseOptions::default()
            };
            let found = discover(&m, &d, &prep, &opts, &|step, effect| {
                if !json {
                    eprintln!("step {step}: adding {effect}, refitting");
                }
            })?;
            // A final model with a parameter held where the record asks it to pass a bound is
            // the model failing there: the ladder is shown, the model is not written.
            let unwritten = match (&out, &found.held_at_bound) {
                (Some(path), Some(why)) => Some(format!(
                    "{}: the final model's fit on {}: {why}; {} not written",
                    m.name,
                    d.origin,
                    path.display()
                )),
                _ => None,
            };
            let out = out.filter(|_| unwritten.is_none());
            if let Some(path) = &out {
                let text = format!(
                    "# Found by `actuator discover` on {} from {} (diagnosis NRMSE {:.4} -> {:.4}{})\n{}",
                    d.origin,
                    m.name,
                    found.nrmse_base,
                    found.nrmse_final,
                    found
                        .steps
                        .iter()
                        .map(|s| format!(", +{}", s.effect))
                        .collect::<String>(),
                    found.model.to_toml()
                );
                std::fs::write(path, text)
                    .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            }
            // Each record alone, diagnosed from the model as given, beside the joint ladder.
            let records = load_records(&data, &model)?;
            let story = (!records.is_empty()).then(|| {
                let ladder: Vec<String> = found.steps.iter().map(|s| s.effect.clone()).collect();
                actuatord::lab::story::per_record(&m, &records, &opts, &ladder)
            });
            if json {
                let mut j = found.to_json();
                j["out"] = serde_json::json!(out.as_ref().map(|p| p.display().to_string()));
                if let Some(story) = &story {
                    j["per_record"] = story.to_json();
                }
                println!("{}", serde_json::to_string_pretty(&j)?);
                return unwritten.map_or(Ok(()), |why| Err(anyhow::anyhow!(why)));
            }
            println!(
                "model {} on {}: NRMSE {:.4} (free parameters refitted; the diagnosis criterion, rest and motion)",
                m.name, d.origin, found.nrmse_base
            );
            println!(
                "\n  {:<4} {:<20} {:>8} {:>8} {:>9} {:>7} {:>10}  evidence",
                "step", "effect added", "before", "after", "held-out", "skill", "ΔBIC"
            );
            for (i, s) in found.steps.iter().enumerate() {
                println!(
                    "  {:<4} {:<20} {:>8.4} {:>8.4} {:>8.1}% {:>7} {:>10.1}  {}",
                    i + 1,
                    s.effect,
                    s.nrmse_before,
                    s.nrmse,
                    100.0 * s.holdout_improvement,
                    s.prediction
                        .map_or_else(|| "-".to_string(), |p| format!("{:.2}", p.skill)),
                    s.delta_bic,
                    s.evidence
                );
            }
            println!(
                "  (skill: the rung's model, fitted on the first {:.0} % of the record, predicting \
                 the rest {} samples ahead; 1 exact, 0 no better than coasting)",
                100.0 * (1.0 - opts.holdout),
                actuatord::lab::predict::HORIZON
            );
            if let Some((effect, why)) = &found.refused {
                println!("\n{effect} was named next, but its fit is refused: {why}");
            }
            let (position_unit, force_unit) = units(&m);
            if let Some(s) = found.unexplained.first() {
                println!("\nunexplained: the error left is not of the catalogue; it lives here:");
                for s in &found.unexplained {
                    println!("  {}", s.describe(position_unit, force_unit));
                }
                println!("  {}", s.hint());
            }
            let with: Vec<&str> = found.model.effects().iter().map(|e| e.name()).collect();
            println!(
                "\n{}; final model with {}: NRMSE {:.4}",
                found.stopped_because(),
                if with.is_empty() {
                    "no effects".to_string()
                } else {
                    with.join(",")
                },
                found.nrmse_final
            );
            match &found.prediction {
                Some(p) if p.predicts() => println!("  {}", p.describe(position_unit)),
                Some(p) => println!(
                    "  {}: it does not predict its held-out motion better than coasting",
                    p.describe(position_unit)
                ),
                None => println!("  no prediction of the held-out motion (no positive inertia, or no motion there)"),
            }
            if let Some(story) = &story {
                println!(
                    "\nThe ladder above is the records' taken together; each record alone, from {}:",
                    m.name
                );
                print_story(story);
            }
            if let Some(path) = &out {
                println!("wrote {}", path.display());
            }
            unwritten.map_or(Ok(()), |why| Err(anyhow::anyhow!(why)))
        }
        LabCommand::Fit {
            data,
            model,
            out,
            method,
            forgetting,
            mode,
            k,
            json,
        } => {
            let mut m = load_model(&model)?;
            let (d, prep) = load_data(&data, &mut [&mut m])?;
            let opts = FitOptions {
                method,
                forgetting,
                mode,
                k,
            };
            let bar = Progress::default();
            let f = fit_model(&m, &d, &prep, &opts, &|done, total| {
                bar.report(done, total, method.name())
            })?;
            bar.finish();
            let (crit_mode, crit_before, crit_after) = f.criterion;
            // A collapsed fit, or a parameter held at its bound where the record asks for more,
            // is the model failing there and a failure to report: nothing is written.
            let balance_fit = actuatord::lab::regress::balance(&f.spec, &d, &prep)
                .map(|b| b.evaluate())
                .ok();
            let refused = actuatord::lab::collapse::refused(
                &m.spec,
                &f.spec,
                crit_after,
                None,
                balance_fit.as_ref(),
                &d,
                &prep,
            )?
            .or_else(|| actuatord::lab::methods::held_at_bound(&f.parameters));
            if let Some(why) = refused {
                anyhow::bail!(
                    "{}: {} on {}: {why}; {} not written",
                    m.name,
                    method.name(),
                    d.origin,
                    out.display()
                );
            }
            let fitted = Model {
                name: out
                    .file_stem()
                    .and_then(|s| s.to_str())
                    .unwrap_or("fitted")
                    .to_string(),
                spec: f.spec.clone(),
            };
            // The inverse-dynamics figure is what `compare` reports; named once.
            let also = if crit_mode == Mode::InverseDynamics {
                String::new()
            } else {
                format!(
                    "; inverse_dynamics NRMSE {:.4} -> {:.4}",
                    f.inverse_dynamics.0, f.inverse_dynamics.1
                )
            };
            let mut text = format!(
                "# Fitted by `actuator fit --method {}` on {} ({} NRMSE {:.4} -> {:.4}{also})\n",
                method.name(),
                d.origin,
                crit_mode.name(),
                crit_before,
                crit_after,
            );
            // What a written model must do: predict motion it was not fitted on.
            let position_unit = units(&m).0;
            let prediction = actuatord::lab::predict::validate(
                &f.spec,
                &d,
                &prep,
                DiagnoseOptions::default().holdout,
                actuatord::lab::predict::HORIZON,
            );
            match &prediction {
                Ok(p) => text.push_str(&format!("# {}\n", p.describe(position_unit))),
                Err(e) => text.push_str(&format!("# no held-out prediction: {e}\n")),
            }
            for p in &f.parameters {
                if let Some((lo, hi)) = p.interval {
                    text.push_str(&format!(
                        "# {} = {:.6e}, 95 % interval [{lo:.6e}, {hi:.6e}]\n",
                        p.name, p.value
                    ));
                }
            }
            text.push_str(&fitted.to_toml());
            std::fs::write(&out, text).map_err(|e| anyhow::anyhow!("{}: {e}", out.display()))?;
            if json {
                let outj = serde_json::json!({
                    "method": method.name(), "mode": crit_mode.name(),
                    "nrmse_before": crit_before, "nrmse": crit_after,
                    "inverse_dynamics": {"nrmse_before": f.inverse_dynamics.0, "nrmse": f.inverse_dynamics.1},
                    "parameters": f.parameters.iter().map(|p| serde_json::json!({
                        "name": p.name, "value": p.value, "status": p.status,
                        "low": p.interval.map(|i| i.0), "high": p.interval.map(|i| i.1),
                        "asked": p.asked.map(|(v, (lo, hi))| serde_json::json!({"value": v, "low": lo, "high": hi}))})).collect::<Vec<_>>(),
                    "track": f.track,
                    "prediction": prediction.as_ref().ok(),
                    "note": f.note, "out": out.display().to_string()});
                println!("{}", serde_json::to_string_pretty(&outj)?);
                return Ok(());
            }
            println!(
                "model {} on {}: method {}, {} NRMSE {:.4} as given -> {:.4} fitted",
                m.name,
                d.origin,
                method.name(),
                crit_mode.name(),
                crit_before,
                crit_after
            );
            if crit_mode != Mode::InverseDynamics || method != FitMethod::LeastSquares {
                println!(
                    "  (inverse_dynamics NRMSE, the figure of `compare`: {:.4} -> {:.4})",
                    f.inverse_dynamics.0, f.inverse_dynamics.1
                );
            } else {
                println!("  (drive force, moving samples: the figure of `compare`)");
            }
            println!("  {}", f.note);
            match &prediction {
                Ok(p) if p.predicts() => println!("  {}", p.describe(position_unit)),
                Ok(p) => println!(
                    "  {}: it does not predict its held-out motion better than coasting (an \
                     effect missing? `actuator diagnose` names it)",
                    p.describe(position_unit)
                ),
                Err(e) => println!("  no held-out prediction: {e}"),
            }
            for p in &f.parameters {
                let (name, v) = (&p.name, p.value);
                match (p.status, p.interval) {
                    (Status::Estimated, Some((lo, hi))) => {
                        println!("  {name:<40} {v:>13.6e}  95 % [{lo:.4e}, {hi:.4e}]")
                    }
                    (Status::Estimated, None) => println!("  {name:<40} {v:>13.6e}"),
                    (Status::AtBound, _) => println!("  {name:<40} {v:>13.6e}  (at its bound)"),
                    (Status::Kept, _) if p.asked.is_some() => {
                        let (a, (lo, hi)) = p.asked.unwrap_or_default();
                        println!(
                            "  {name:<40} {v:>13.6e}  (held at its bound: the record asks for {a:.3e}, 95 % [{lo:.3e}, {hi:.3e}] with the others held, and the other terms make up for it)"
                        )
                    }
                    (Status::Kept, _) => println!(
                        "  {name:<40} {v:>13.6e}  (kept: not separable from the other terms on these data)"
                    ),
                    (Status::Fixed, _) => println!("  {name:<40} {v:>13.6e}  (fixed)"),
                    (Status::Grid, _) => println!("  {name:<40} {v:>13.6e}  (grid search)"),
                }
            }
            if let Some(t) = &f.track {
                println!(
                    "\n  recursive estimate over the record (forgetting {}):",
                    t.forgetting
                );
                print!("  {:<40}", "t (s)");
                for (time, _) in &t.points {
                    print!(" {time:>12.3}");
                }
                println!();
                for (j, name) in t.names.iter().enumerate() {
                    print!("  {name:<40}");
                    for (_, values) in &t.points {
                        print!(" {:>12.4e}", values[j]);
                    }
                    println!();
                }
                if let Some(c) = &t.change {
                    println!(
                        "  halves of the record fitted apart: {} {:.4e} -> {:.4e} (z = {:.1}){}",
                        c.name,
                        c.first,
                        c.second,
                        c.z,
                        if c.z > 3.0 {
                            ": the plant changed during the record, or the model lacks an effect"
                        } else {
                            ": no parameter changed beyond chance"
                        }
                    );
                }
            }
            println!("wrote {}", out.display());
            Ok(())
        }
        LabCommand::Report {
            data,
            model,
            family,
            with,
            mode,
            out,
            discover: ladder,
            min_improvement,
        } => {
            // A model named by family and effects has default values nobody chose: it enters
            // the report refitted, as `diagnose` judges it.
            let mut first = family.map(|f| Model::from_names(&f, &with)).transpose()?;
            let mut files = model
                .iter()
                .map(|p| Model::load(p))
                .collect::<anyhow::Result<Vec<_>>>()?;
            let (d, prep) = load_data(
                &data,
                &mut first.iter_mut().chain(files.iter_mut()).collect::<Vec<_>>(),
            )?;
            let first = first
                .map(|m| -> anyhow::Result<Model> {
                    let (spec, _) = fit_spec(&m.spec, &d, &prep, None)?;
                    Ok(Model {
                        name: format!("{} (refitted)", m.name),
                        spec,
                    })
                })
                .transpose()?;
            let models: Vec<Model> = first.into_iter().chain(files).collect();
            let found = if ladder {
                let opts = DiagnoseOptions {
                    min_improvement,
                    ..DiagnoseOptions::default()
                };
                Some(discover(&models[0], &d, &prep, &opts, &|step, effect| {
                    eprintln!("step {step}: adding {effect}, refitting")
                })?)
            } else {
                None
            };
            let path = actuatord::lab::report::write_report(
                &out,
                &d,
                &prep,
                &models,
                mode,
                found.as_ref(),
            )?;
            println!("wrote {}", path.display());
            Ok(())
        }
    }
}
