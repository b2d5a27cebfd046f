//! House rules of the sources that a compiler does not check.
//!
//! - **No module cycles inside a crate.** The top-level modules of a crate (a file or folder
//!   under its `src/`) form a layered graph: no module reaches back to one that reaches it
//!   through `crate::` paths. Unit-test modules (`#[cfg(test)] mod …`) may use any module.
//! - **A figure module is a figure:** every file of `bench/src/figures/` but `mod.rs` has its
//!   registry entry `pub fn spec()`; shared computations live in `bench/src/studies/`.
//! - **No lab notebook in the code's comments.** Measurements belong to the figures' manifests
//!   and notes (`reports/<figure>/NOTES.md`) and to closing notes; the code's docs say what,
//!   why, equations, units and defaults. Dates and commit hashes are the mark of a notebook
//!   entry, and they go stale the moment they are written, so no comment in a crate's `src/`
//!   may hold a date stamp (`YYYY-MM-DD`) or a commit hash (7–12 lower-case hexadecimal digits
//!   with at least one letter and one digit).

use std::path::{Path, PathBuf};

/// The workspace root (this crate is `tests/` inside it).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ is inside the workspace")
        .to_path_buf()
}

/// Every `.rs` file under `dir`, recursively.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.map(|e| e.expect("a readable directory entry")) {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The comment of a source line (the text after its first `//`), if any. String literals that
/// contain `//` are rare in these sources and would only make the check stricter.
fn comment(line: &str) -> Option<&str> {
    line.find("//").map(|i| &line[i + 2..])
}

/// The code of a source file up to its unit-test module, comments removed.
fn code_lines(text: &str) -> impl Iterator<Item = &str> {
    let lines: Vec<&str> = text.lines().collect();
    let end = (0..lines.len())
        .find(|&i| {
            lines[i].trim() == "#[cfg(test)]"
                && lines
                    .get(i + 1)
                    .is_some_and(|l| l.trim_start().starts_with("mod "))
        })
        .unwrap_or(lines.len());
    lines
        .into_iter()
        .take(end)
        .map(|l| l.find("//").map_or(l, |i| &l[..i]))
}

/// The crate's top-level modules that `code` names through `crate::` paths.
fn crate_paths(code: &str) -> Vec<String> {
    code.match_indices("crate::")
        .filter(|(i, _)| {
            *i == 0 || !code[..*i].ends_with(|c: char| c.is_ascii_alphanumeric() || c == '_')
        })
        .map(|(i, m)| {
            code[i + m.len()..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect::<String>()
        })
        .filter(|name| name.starts_with(|c: char| c.is_ascii_lowercase()))
        .collect()
}

/// The cycles of the top-level module graph of the crate whose sources are under `src`: for
/// each module on a cycle, the path back to itself.
fn module_cycles(src: &Path) -> Vec<Vec<String>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let mut edges: std::collections::BTreeMap<String, std::collections::BTreeSet<String>> =
        Default::default();
    for file in &files {
        let rel = file.strip_prefix(src).expect("under src");
        let first = rel.components().next().expect("a file name");
        let top = first
            .as_os_str()
            .to_string_lossy()
            .trim_end_matches(".rs")
            .to_string();
        if rel.components().count() == 1 && (top == "lib" || top == "main") {
            continue;
        }
        if top == "bin" {
            continue;
        }
        let text = std::fs::read_to_string(file).expect("a UTF-8 source file");
        for line in code_lines(&text) {
            for used in crate_paths(line) {
                if used != top {
                    edges.entry(top.clone()).or_default().insert(used);
                }
            }
        }
    }
    // A module is on a cycle when it reaches itself; report the path found by a search.
    let mut cycles = Vec::new();
    for start in edges.keys() {
        let mut path = vec![start.clone()];
        let mut seen = std::collections::BTreeSet::new();
        if reaches(&edges, start, start, &mut path, &mut seen) {
            cycles.push(path);
        }
    }
    cycles
}

/// Depth-first search for a path from `from` to `target`, appended to `path`.
fn reaches(
    edges: &std::collections::BTreeMap<String, std::collections::BTreeSet<String>>,
    from: &str,
    target: &str,
    path: &mut Vec<String>,
    seen: &mut std::collections::BTreeSet<String>,
) -> bool {
    for next in edges.get(from).into_iter().flatten() {
        path.push(next.clone());
        if next == target {
            return true;
        }
        if seen.insert(next.clone()) && reaches(edges, next, target, path, seen) {
            return true;
        }
        path.pop();
    }
    false
}

/// Every crate of the workspace with a `src/` folder.
fn crate_sources(root: &Path) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(root)
        .expect("the workspace root")
        .map(|m| m.expect("an entry").path().join("src"))
        .filter(|src| src.is_dir())
        .collect();
    out.sort();
    out
}

#[test]
fn the_cycle_finder_sees_cycles() {
    assert_eq!(
        crate_paths("use crate::a::b; x = crate::c::D; my_crate::e; crate::Type"),
        ["a", "c"]
    );
    let dir = std::env::temp_dir().join(format!("tidy-cycles-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("b")).unwrap();
    std::fs::write(dir.join("lib.rs"), "pub mod a; pub mod b; use crate::a::X;").unwrap();
    std::fs::write(
        dir.join("a.rs"),
        "use crate::b::Y; // crate::c in a comment",
    )
    .unwrap();
    std::fs::write(dir.join("b/mod.rs"), "mod c;").unwrap();
    std::fs::write(dir.join("b/c.rs"), "fn f() { crate::a::g() }").unwrap();
    std::fs::write(
        dir.join("c.rs"),
        "#[cfg(test)]\nmod tests { use crate::a; }",
    )
    .unwrap();
    let cycles = module_cycles(&dir);
    assert_eq!(cycles, [vec!["a", "b", "a"], vec!["b", "a", "b"]]);
    std::fs::write(
        dir.join("b/c.rs"),
        "#[cfg(test)]\nmod tests { use crate::a; }",
    )
    .unwrap();
    assert!(module_cycles(&dir).is_empty());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn no_module_cycles_inside_a_crate() {
    let root = root();
    let mut found = Vec::new();
    for src in crate_sources(&root) {
        for cycle in module_cycles(&src) {
            let krate = src.parent().unwrap().strip_prefix(&root).unwrap().display();
            found.push(format!("{krate}: {}", cycle.join(" → ")));
        }
    }
    assert!(found.is_empty(), "module cycles:\n{}", found.join("\n"));
}

#[test]
fn every_figure_module_has_a_spec() {
    let dir = root().join("bench/src/figures");
    let mut missing = Vec::new();
    let mut figures = 0;
    for entry in std::fs::read_dir(&dir).expect("bench/src/figures") {
        let path = entry.expect("an entry").path();
        if path.file_name().is_some_and(|n| n == "mod.rs") {
            continue;
        }
        let text = std::fs::read_to_string(&path).expect("a UTF-8 source file");
        figures += 1;
        if !text.contains("\npub fn spec() -> FigureSpec") {
            missing.push(path.display().to_string());
        }
    }
    assert!(figures > 20, "found only {figures} figure modules");
    assert!(
        missing.is_empty(),
        "figure modules without `pub fn spec() -> FigureSpec` (move shared code to \
         bench/src/studies/): {missing:?}"
    );
}

/// Whether `word` reads as a date stamp `YYYY-MM-DD` (from 2000 on) at its start.
fn is_date(word: &str) -> bool {
    let b = word.as_bytes();
    b.len() >= 10
        && b[..4].iter().all(u8::is_ascii_digit)
        && word.starts_with("20")
        && b[4] == b'-'
        && b[5..7].iter().all(u8::is_ascii_digit)
        && b[7] == b'-'
        && b[8..10].iter().all(u8::is_ascii_digit)
        && (b"01".contains(&b[5]))
}

/// Whether `token` (alphanumeric) reads as an abbreviated commit hash.
fn is_hash(token: &str) -> bool {
    (7..=12).contains(&token.len())
        && token
            .bytes()
            .all(|c| c.is_ascii_digit() || (b'a'..=b'f').contains(&c))
        && token.bytes().any(|c| c.is_ascii_digit())
        && token.bytes().any(|c| c.is_ascii_alphabetic())
}

/// The date stamps and hashes in one comment.
fn notebook_marks(text: &str) -> Vec<String> {
    let mut found = Vec::new();
    for (i, _) in text.char_indices() {
        let at_boundary = i == 0 || !text[..i].ends_with(|c: char| c.is_ascii_alphanumeric());
        if at_boundary && is_date(&text[i..]) {
            found.push(text[i..i + 10].to_string());
        }
    }
    for token in text.split(|c: char| !c.is_ascii_alphanumeric()) {
        if is_hash(token) {
            found.push(token.to_string());
        }
    }
    found
}

#[test]
fn the_checker_sees_dates_and_hashes() {
    assert_eq!(
        notebook_marks(" run 2026-11-29, at a5c8811"),
        ["2026-11-29", "a5c8811"]
    );
    assert!(notebook_marks(" 1e-6 relative, 0x1f2e3d4c, 12345678, deadbeef, cafe").is_empty());
    assert!(notebook_marks(" YYYY-MM-DD, 29 February 2000").is_empty());
}

#[test]
fn no_dates_or_commit_hashes_in_source_comments() {
    let root = root();
    let mut files = Vec::new();
    for src in crate_sources(&root) {
        rust_files(&src, &mut files);
    }
    assert!(files.len() > 100, "found only {} source files", files.len());
    let mut offences = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).expect("a UTF-8 source file");
        for (n, line) in text.lines().enumerate() {
            if let Some(c) = comment(line) {
                for mark in notebook_marks(c) {
                    let shown = file.strip_prefix(&root).unwrap_or(file).display();
                    offences.push(format!("{shown}:{}: {mark}", n + 1));
                }
            }
        }
    }
    assert!(
        offences.is_empty(),
        "dates or commit hashes in comments (move the measurement to the figure's NOTES.md or \
         manifest):\n{}",
        offences.join("\n")
    );
}
