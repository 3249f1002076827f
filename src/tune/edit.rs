//! Writing values into an axis of a configuration file, keeping its comments, and the list of
//! what changed and where it came from.

use toml_edit::{DocumentMut, Item, Table, Value};

/// One changed value.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Change {
    /// Key, e.g. `axis.controller.q_per_m`.
    pub key: String,
    pub before: String,
    pub after: String,
    /// Where the new value comes from.
    pub origin: String,
}

/// A value left as it was, and why.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Kept {
    pub key: String,
    pub reason: String,
}

/// The report's list of what changed (with where it came from) and what was kept (and why).
pub fn write_changes(
    f: &mut std::fmt::Formatter<'_>,
    changes: &[Change],
    kept: &[Kept],
) -> std::fmt::Result {
    writeln!(f, "changed:")?;
    for c in changes {
        writeln!(
            f,
            "  {:<50} {} -> {}\n  {:<50}   from {}",
            c.key, c.before, c.after, "", c.origin
        )?;
    }
    writeln!(f, "kept:")?;
    for k in kept {
        writeln!(f, "  {:<50} {}", k.key, k.reason)?;
    }
    Ok(())
}

/// The configuration being tuned: one axis' table of the document.
pub struct Editor {
    pub doc: DocumentMut,
    axis: usize,
    pub changes: Vec<Change>,
    pub kept: Vec<Kept>,
}

/// A number rounded to `digits` significant digits (the file stays readable).
pub fn round_sig(x: f64, digits: usize) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    format!("{x:.*e}", digits.saturating_sub(1))
        .parse()
        .unwrap_or(x)
}

fn render(item: Option<&Item>) -> String {
    item.and_then(|i| i.as_value())
        .map(|v| v.to_string().trim().to_string())
        .unwrap_or_else(|| "absent".to_string())
}

impl Editor {
    pub fn new(doc: DocumentMut, axis: usize) -> Self {
        Editor {
            doc,
            axis,
            changes: Vec::new(),
            kept: Vec::new(),
        }
    }

    fn axis_table(&mut self) -> Option<&mut Table> {
        self.doc
            .get_mut("axis")?
            .as_array_of_tables_mut()?
            .get_mut(self.axis)
    }

    /// True when the axis has section `section`.
    pub fn has_section(&mut self, section: &str) -> bool {
        self.axis_table()
            .is_some_and(|t| t.get(section).is_some_and(|s| s.is_table_like()))
    }

    /// The current value of `section.key` of the axis.
    pub fn get(&mut self, section: &str, key: &str) -> Option<Value> {
        let t = self.axis_table()?;
        t.get(section)?.get(key)?.as_value().cloned()
    }

    /// Set `section.key` of the axis (the section is created if absent), noting the origin.
    pub fn set(&mut self, section: &str, key: &str, value: Value, origin: impl Into<String>) {
        let Some(t) = self.axis_table() else { return };
        if t.get(section).is_none() {
            let mut s = Table::new();
            s.set_implicit(false);
            // Written beside the controller's table: at the file's end it would belong to the
            // last `[[axis]]`, whichever this one is.
            s.set_position(
                t.get(crate::param_key!(
                    crate::daemon::config::AxisConfig,
                    controller
                ))
                .and_then(|c| c.as_table())
                .and_then(|c| c.position()),
            );
            t.insert(section, Item::Table(s));
        }
        let Some(s) = t.get_mut(section).and_then(|s| s.as_table_like_mut()) else {
            return;
        };
        let before = render(s.get(key));
        let mut value = value;
        value.decor_mut().clear();
        let after = value.to_string().trim().to_string();
        // A value the model confirms stays as written, comment and all.
        if after == before {
            self.kept.push(Kept {
                key: format!("axis.{section}.{key}"),
                reason: format!("the same as from {}", origin.into()),
            });
            return;
        }
        value.decor_mut().set_suffix("  # tuned");
        s.insert(key, Item::Value(value));
        self.changes.push(Change {
            key: format!("axis.{section}.{key}"),
            before,
            after,
            origin: origin.into(),
        });
    }

    pub fn set_f64(&mut self, section: &str, key: &str, v: f64, origin: impl Into<String>) {
        self.set(section, key, Value::from(round_sig(v, 6)), origin);
    }

    pub fn set_list(
        &mut self,
        section: &str,
        key: &str,
        v: &[f64],
        digits: usize,
        origin: impl Into<String>,
    ) {
        let array: toml_edit::Array = v.iter().map(|x| round_sig(*x, digits)).collect();
        self.set(section, key, Value::Array(array), origin);
    }

    pub fn keep(&mut self, key: impl Into<String>, reason: impl Into<String>) {
        self.kept.push(Kept {
            key: key.into(),
            reason: reason.into(),
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_new_section_goes_to_its_own_axis_of_several() {
        let text = "[[axis]]\nname = \"a\"\n[axis.controller]\nq_per_m = [1.0]\n\
                    [[axis.setpoints]]\nat_s = 1.0\n\
                    [[axis]]\nname = \"b\"\n[axis.controller]\nq_per_m = [2.0]\n";
        let doc: DocumentMut = text.parse().expect("TOML");
        let mut ed = Editor::new(doc, 0);
        ed.set_f64("friction_compensation", "alpha", 0.8, "test");
        let back: toml::Table = ed.doc.to_string().parse().expect("TOML");
        let axes = back["axis"].as_array().expect("axes");
        assert_eq!(
            axes[0]["friction_compensation"]["alpha"].as_float(),
            Some(0.8)
        );
        assert!(axes[1].get("friction_compensation").is_none());
        assert_eq!(axes[0]["setpoints"].as_array().map(|s| s.len()), Some(1));
        assert_eq!(ed.changes.len(), 1);
        assert_eq!(ed.changes[0].before, "absent");
    }
}
