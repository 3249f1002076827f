//! One story per machine: with several records of one actuator, each record diagnosed alone
//! beside the joint diagnosis, and which effects hold in every record, which only in some.
//!
//! The joint diagnosis is the answer (it sees every regime the records hold together). The
//! records' own verdicts say whether it is one machine's story or a mixture: an effect that
//! is significant in every record alone is the machine's; one that holds in some records only
//! belongs to what those records excite (a supply level, a speed, a direction), or to chance.

use serde::Serialize;

use super::data::Dataset;
use super::diagnose::{diagnose, DiagnoseOptions, Diagnosis};
use super::model::Model;
use super::signals::Prepared;

/// One record diagnosed alone.
#[derive(Debug, Clone, Serialize)]
pub struct RecordVerdict {
    /// The record (its file).
    pub origin: String,
    /// Its verdict: an effect, `undecided`, `unexplained` or `none` ([`Diagnosis::verdict_name`]).
    pub verdict: String,
    /// The undecided set, when the verdict is `undecided`.
    pub undecided: Vec<String>,
    /// Candidates significant on this record alone.
    pub significant: Vec<String>,
    /// Why this record could not be diagnosed alone (too little motion, a balance with
    /// nothing to explain), when it could not.
    pub refused: Option<String>,
}

/// How far one effect holds across the records.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Holding {
    pub effect: String,
    /// The records (by origin) on which it is significant alone.
    pub records: Vec<String>,
}

/// The records' verdicts beside the joint one.
#[derive(Debug, Clone, Serialize)]
pub struct Story {
    pub records: Vec<RecordVerdict>,
    /// Effects significant in every record that could be diagnosed.
    pub every: Vec<String>,
    /// Effects significant in some of them but not all, with the records.
    pub some: Vec<Holding>,
}

/// Diagnose `model` on each record alone; `leading` (the joint verdict and its undecided set,
/// or the effects of the joint ladder) come first among the effects followed across the
/// records.
pub fn per_record(
    model: &Model,
    records: &[(Dataset, Prepared)],
    opts: &DiagnoseOptions,
    leading: &[String],
) -> Story {
    let verdicts: Vec<RecordVerdict> = records
        .iter()
        .map(
            |(data, d)| match diagnose(model, data, d, opts, &|_, _, _| {}) {
                Ok(dg) => RecordVerdict {
                    origin: data.origin.clone(),
                    verdict: dg.verdict_name().to_string(),
                    undecided: dg.undecided.clone(),
                    significant: dg
                        .candidates
                        .iter()
                        .filter(|c| c.significant)
                        .map(|c| c.effect.clone())
                        .collect(),
                    refused: None,
                },
                Err(e) => RecordVerdict {
                    origin: data.origin.clone(),
                    verdict: "refused".into(),
                    undecided: Vec::new(),
                    significant: Vec::new(),
                    refused: Some(e.to_string()),
                },
            },
        )
        .collect();
    summarise(verdicts, leading)
}

/// The effects of the joint answer: its verdict and its undecided set.
pub fn joint_effects(joint: &Diagnosis) -> Vec<String> {
    joint
        .verdict
        .iter()
        .chain(&joint.undecided)
        .cloned()
        .collect()
}

/// The effects that hold in every diagnosed record and in some: those significant anywhere,
/// `leading` first, then in the order the records list them.
fn summarise(records: Vec<RecordVerdict>, leading: &[String]) -> Story {
    let diagnosed: Vec<&RecordVerdict> = records.iter().filter(|r| r.refused.is_none()).collect();
    let mut effects: Vec<String> = leading.to_vec();
    for r in &diagnosed {
        for e in &r.significant {
            if !effects.contains(e) {
                effects.push(e.clone());
            }
        }
    }
    let mut every = Vec::new();
    let mut some = Vec::new();
    for e in effects {
        let holding: Vec<String> = diagnosed
            .iter()
            .filter(|r| r.significant.contains(&e))
            .map(|r| r.origin.clone())
            .collect();
        if holding.is_empty() {
            continue;
        }
        if holding.len() == diagnosed.len() {
            every.push(e);
        } else {
            some.push(Holding {
                effect: e,
                records: holding,
            });
        }
    }
    Story {
        records,
        every,
        some,
    }
}

impl Story {
    /// The JSON beside the joint diagnosis' (`"records"`, `"every"`, `"some"`).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "records": self.records,
            "every": self.every,
            "some": self.some,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(origin: &str, significant: &[&str]) -> RecordVerdict {
        RecordVerdict {
            origin: origin.into(),
            verdict: significant.first().map_or("none", |s| s).into(),
            undecided: Vec::new(),
            significant: significant.iter().map(|s| s.to_string()).collect(),
            refused: None,
        }
    }

    #[test]
    fn every_and_some_are_counted_over_the_diagnosed_records() {
        let mut refused = record("c.csv", &[]);
        refused.refused = Some("only 12 moving samples".into());
        let story = summarise(
            vec![
                record("a.csv", &["coulomb", "deadzone"]),
                record("b.csv", &["deadzone", "spring"]),
                refused,
            ],
            &["deadzone".to_string()],
        );
        assert_eq!(story.every, vec!["deadzone"]);
        assert_eq!(
            story.some,
            vec![
                Holding {
                    effect: "coulomb".into(),
                    records: vec!["a.csv".into()]
                },
                Holding {
                    effect: "spring".into(),
                    records: vec!["b.csv".into()]
                },
            ]
        );
        // The refused record is listed with its reason, and counts for neither: deadzone
        // holds in every record that could be diagnosed.
        assert_eq!(story.records.len(), 3);
        assert!(story.records[2].refused.is_some());
    }

    #[test]
    fn the_joint_verdict_comes_first_and_an_effect_no_record_holds_is_left_out() {
        let story = summarise(
            vec![
                record("a.csv", &["spring", "payload"]),
                record("b.csv", &["payload", "spring"]),
            ],
            &["payload".to_string()],
        );
        assert_eq!(story.every, vec!["payload", "spring"]);
        let story = summarise(vec![record("a.csv", &["spring"])], &["offset".to_string()]);
        assert_eq!(story.every, vec!["spring"]);
        assert!(story.some.is_empty());
    }
}
