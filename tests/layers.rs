//! The layer table of `docs/architecture.md` holds for the code: every
//! top-level module of `src/` is in it, and each imports only modules of its
//! own layer or below, with no circle between any two (test code aside).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

const TABLE: &str = "docs/architecture.md";

/// Layer of each module the table names: its numbered list, one item per
/// layer, naming modules as `name/` or `name.rs`.
fn layers(text: &str) -> BTreeMap<String, usize> {
    let mut out = BTreeMap::new();
    let mut layer = None;
    for line in text.lines() {
        let head = line
            .split_once(". ")
            .filter(|(n, _)| n.chars().all(|c| c.is_ascii_digit()) && !n.is_empty());
        match head {
            Some((n, _)) => layer = n.parse::<usize>().ok(),
            None if line.trim().is_empty() => layer = None,
            None => {}
        }
        let Some(layer) = layer else { continue };
        for (i, part) in line.split('`').enumerate() {
            let name = part.strip_suffix('/').or_else(|| part.strip_suffix(".rs"));
            if let Some(name) = name.filter(|n| i % 2 == 1 && n.chars().all(|c| c.is_ascii_lowercase() || c == '_')) {
                out.insert(name.to_string(), layer);
            }
        }
    }
    out
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("read src") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// `text` without comments and without the items under `#[cfg(test)]`.
fn code_of(text: &str) -> String {
    let lines: Vec<&str> = text.lines().map(|l| l.split("//").next().unwrap_or("")).collect();
    let mut out = String::new();
    let mut i = 0;
    while i < lines.len() {
        if lines[i].trim() == "#[cfg(test)]" {
            // Skip the item: up to its closing brace (or `;`).
            let mut depth = 0i32;
            i += 1;
            while i < lines.len() {
                depth += lines[i].matches('{').count() as i32 - lines[i].matches('}').count() as i32;
                let ended = depth <= 0 && (lines[i].contains('}') || lines[i].trim_end().ends_with(';'));
                i += 1;
                if ended {
                    break;
                }
            }
            continue;
        }
        out += lines[i];
        out.push('\n');
        i += 1;
    }
    out
}

/// The top-level modules `code` names after `crate::` (alone or in a
/// `crate::{…}` group).
fn imports(code: &str, modules: &BTreeSet<String>) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for (_, rest) in code.match_indices("crate::").map(|(i, _)| ((), &code[i + 7..])) {
        let names: Vec<&str> = match rest.strip_prefix('{') {
            Some(group) => {
                let group = &group[..group.find('}').unwrap_or(group.len())];
                group.split(',').map(str::trim).collect()
            }
            None => vec![rest],
        };
        for name in names {
            let word: String = name
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if modules.contains(&word) {
                out.insert(word);
            }
        }
    }
    out
}

/// Module → the modules it imports (test code aside).
fn graph(src: &Path, modules: &BTreeSet<String>) -> BTreeMap<String, BTreeSet<String>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for file in files {
        let rel = file.strip_prefix(src).expect("in src");
        let first = rel.components().next().expect("a path").as_os_str().to_string_lossy();
        let module = first.trim_end_matches(".rs").to_string();
        if !modules.contains(&module) {
            continue;
        }
        let code = code_of(&std::fs::read_to_string(&file).expect("read"));
        let named = imports(&code, modules);
        out.entry(module.clone())
            .or_default()
            .extend(named.into_iter().filter(|m| *m != module));
    }
    out
}

/// A circle through `from`, if there is one: the path back to it.
fn circle_through(from: &str, graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    let mut stack = vec![vec![from.to_string()]];
    let mut seen = BTreeSet::new();
    while let Some(path) = stack.pop() {
        let last = path.last().expect("non-empty");
        for next in graph.get(last).into_iter().flatten() {
            if next == from {
                let mut circle = path.clone();
                circle.push(next.clone());
                return Some(circle);
            }
            if seen.insert(next.clone()) {
                let mut longer = path.clone();
                longer.push(next.clone());
                stack.push(longer);
            }
        }
    }
    None
}

#[test]
fn modules_import_only_their_layer_and_below_with_no_circle() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let table = layers(&std::fs::read_to_string(root.join(TABLE)).expect("the layer table"));
    let src = root.join("src");
    let modules: BTreeSet<String> = std::fs::read_dir(&src)
        .expect("src")
        .map(|e| {
            e.expect("entry")
                .file_name()
                .to_string_lossy()
                .trim_end_matches(".rs")
                .to_string()
        })
        .filter(|m| m != "lib" && m != "main")
        .collect();
    let missing: Vec<&String> = modules.iter().filter(|m| !table.contains_key(*m)).collect();
    assert!(
        missing.is_empty(),
        "modules not in the layer table of {TABLE}: {missing:?}"
    );
    let stale: Vec<&String> = table.keys().filter(|m| !modules.contains(*m) && *m != "main").collect();
    assert!(stale.is_empty(), "{TABLE} names modules that do not exist: {stale:?}");
    let graph = graph(&src, &modules);
    let mut upward = Vec::new();
    for (module, named) in &graph {
        for other in named {
            if table[other] > table[module] {
                upward.push(format!(
                    "{module} (layer {}) imports {other} (layer {})",
                    table[module], table[other]
                ));
            }
        }
    }
    assert!(upward.is_empty(), "upward imports:\n{}", upward.join("\n"));
    let circles: BTreeSet<String> = modules
        .iter()
        .filter_map(|m| circle_through(m, &graph))
        .map(|c| c.join(" → "))
        .collect();
    assert!(
        circles.is_empty(),
        "import circles:\n{}",
        circles.iter().cloned().collect::<Vec<_>>().join("\n")
    );
}

#[test]
fn the_reader_sees_groups_comments_and_test_code_as_they_are() {
    let modules: BTreeSet<String> = ["a", "b", "c", "d"].iter().map(|s| s.to_string()).collect();
    let code = code_of(
        "use crate::{a::X, b};\n// crate::c in a comment\nfn f() { crate::d::g(); }\n#[cfg(test)]\nmod tests {\n    use crate::c;\n}\n",
    );
    let named: Vec<String> = imports(&code, &modules).into_iter().collect();
    assert_eq!(named, ["a", "b", "d"]);
    let table = layers("1. **Data:** `a/`, `b.rs`\n   and `c.rs`\n\nNot `d.rs`.\n2. **Top:** `d/`\n");
    assert_eq!(table.get("c"), Some(&1));
    assert_eq!(table.get("d"), Some(&2));
}
