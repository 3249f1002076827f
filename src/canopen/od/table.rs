//! The dictionary as a Markdown table, for the README and the issue notes.

use super::{ObjectDictionary, Value};
use std::fmt::Write;

/// One row per entry: address, object and entry name, type, unit, access, bounds, default and
/// description. Subindex 0 of arrays and records is left out where it only counts the entries;
/// a writable one (1003h's, which a write of 0 clears) has a row.
pub fn markdown_table(od: &ObjectDictionary) -> String {
    let mut out = String::from(
        "| index:sub | object | entry | type | unit | access | min | max | default | description |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    for object in od.objects() {
        for e in od.object_entries(object) {
            if e.id.sub == 0 && object.kind != super::ObjectKind::Var && !e.access.writable() {
                continue;
            }
            let bound = |v: Option<Value>| v.map_or(String::new(), |v| v.to_string());
            // Rows are plain text; a '|' in a description would break the table.
            let _ = writeln!(
                out,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                e.id,
                object.name,
                e.name,
                e.data_type,
                e.unit,
                e.access.name(),
                bound(e.min),
                bound(e.max),
                cell(&e.default.to_string()),
                cell(e.description),
            );
        }
    }
    out
}

fn cell(text: &str) -> String {
    text.replace('|', "\\|")
}
