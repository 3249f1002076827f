//! The layering declared in `src/lib.rs` is true: every `crate::` path in a module's files names
//! only modules listed above it. Prints the import graph; a failure names the file, the line and
//! the import that breaks the order.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The declared layers, lowest first, read from the module documentation of `src/lib.rs`:
/// one item per line, ``//! - [`name`], [`other`]: ...``.
fn declared_layers(lib: &str) -> Vec<Vec<String>> {
    let mut layers = Vec::new();
    for line in lib.lines() {
        let Some(item) = line.strip_prefix("//! - ") else {
            continue;
        };
        let head = item.split(':').next().unwrap_or("");
        let names: Vec<String> = head
            .split(',')
            .filter_map(|n| {
                n.trim()
                    .strip_prefix("[`")
                    .and_then(|n| n.strip_suffix("`]"))
                    .map(str::to_string)
            })
            .collect();
        if !names.is_empty() {
            layers.push(names);
        }
    }
    layers
}

/// The top-level modules `src/lib.rs` declares.
fn declared_modules(lib: &str) -> BTreeSet<String> {
    lib.lines()
        .filter_map(|l| l.trim().strip_prefix("pub mod "))
        .map(|l| l.trim_end_matches(';').to_string())
        .collect()
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|x| x == "rs") {
            out.push(path);
        }
    }
}

/// The top-level modules a line of code names through `crate::`: `crate::a::...` and each item of
/// `crate::{a, b::c}`. Comments are not code: a doc link may point anywhere.
fn named_modules(line: &str) -> Vec<String> {
    let code = match line.find("//") {
        Some(i) => &line[..i],
        None => line,
    };
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        let before = rest[..i].chars().next_back();
        rest = &rest[i + "crate::".len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue; // `actuatord_crate::` or the like, not this crate
        }
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for item in group[..end].split(',') {
                let name: String = item
                    .trim()
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if !name.is_empty() {
                    out.push(name);
                }
            }
        } else {
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() {
                out.push(name);
            }
        }
    }
    out
}

#[test]
fn every_import_follows_the_declared_layers() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = root.join("src");
    let lib = std::fs::read_to_string(src.join("lib.rs")).expect("src/lib.rs");
    let layers = declared_layers(&lib);
    let modules = declared_modules(&lib);

    // The list names each module exactly once, and every module is in it.
    let mut rank = BTreeMap::new();
    for (i, layer) in layers.iter().enumerate() {
        for name in layer {
            assert!(
                rank.insert(name.clone(), i).is_none(),
                "src/lib.rs lists `{name}` twice in its layers"
            );
        }
    }
    let listed: BTreeSet<String> = rank.keys().cloned().collect();
    assert_eq!(
        listed, modules,
        "src/lib.rs: the layer list and the `pub mod` lines must name the same modules"
    );

    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut graph: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    let mut broken = Vec::new();
    for file in &files {
        let rel = file.strip_prefix(&src).expect("under src");
        let first = rel
            .components()
            .next()
            .and_then(|c| c.as_os_str().to_str())
            .expect("a path")
            .trim_end_matches(".rs")
            .to_string();
        // The binaries sit on top of everything; lib.rs only declares.
        if first == "bin" || first == "lib" {
            continue;
        }
        let own = *rank
            .get(&first)
            .unwrap_or_else(|| panic!("{}: module `{first}` is not in src/lib.rs", rel.display()));
        let text = std::fs::read_to_string(file).expect("readable source");
        for (n, line) in text.lines().enumerate() {
            for used in named_modules(line) {
                if used == first {
                    continue;
                }
                let Some(&theirs) = rank.get(&used) else {
                    continue; // a macro or item at the crate root, not a module
                };
                *graph
                    .entry(first.clone())
                    .or_default()
                    .entry(used.clone())
                    .or_default() += 1;
                if theirs >= own {
                    broken.push(format!(
                        "src/{}:{}: `{first}` imports `{used}`, which is not listed above it: {}",
                        rel.display(),
                        n + 1,
                        line.trim()
                    ));
                }
            }
        }
    }

    println!("import graph (module -> modules it uses, with the number of paths), lowest first:");
    for layer in &layers {
        for name in layer {
            let uses = graph.get(name).map_or_else(String::new, |u| {
                let mut u: Vec<_> = u.iter().collect();
                u.sort_by_key(|(m, _)| rank[*m]);
                u.iter()
                    .map(|(m, c)| format!("{m} ({c})"))
                    .collect::<Vec<_>>()
                    .join(", ")
            });
            println!("  {name:<10} -> {uses}");
        }
    }
    assert!(
        broken.is_empty(),
        "{} import(s) break the layering of src/lib.rs:\n{}",
        broken.len(),
        broken.join("\n")
    );
}

#[test]
fn the_reader_sees_grouped_imports_and_ignores_comments() {
    assert_eq!(
        named_modules("use crate::{bus::Frame, canopen};"),
        ["bus", "canopen"]
    );
    assert_eq!(
        named_modules("    let c = crate::recording::read_cycles(p); // crate::daemon"),
        ["recording"]
    );
    assert!(named_modules("//! see [`crate::bench::fault_table`]").is_empty());
    assert!(named_modules("use actuatord_crate::x;").is_empty());
}
