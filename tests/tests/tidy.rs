//! House rules of the sources that a compiler does not check.
//!
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
    for member in std::fs::read_dir(&root).expect("the workspace root") {
        let src = member.expect("an entry").path().join("src");
        if src.is_dir() {
            rust_files(&src, &mut files);
        }
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
