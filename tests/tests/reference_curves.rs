//! Reference-curve regression: every guarded figure in `bench::all_figures()`
//! is recomputed in quick mode and compared with `reports/reference/<name>.csv`.
//!
//! Tolerances: `rtol = 1e-6`, `atol = 1e-12` per entry
//! (`|actual - reference| <= atol + rtol * |reference|`, see
//! [`bench::Tolerance::REFERENCE`]). The figures are deterministic, so this
//! only absorbs last-bit differences in `libm` and summation order across
//! machines; any modelling change shows up as a failure.
//!
//! After an intended change: `cargo xtask reproduce-figures --bless`
//! (quick mode), review the diff of `reports/reference/`, commit.

use std::path::{Path, PathBuf};

use bench::{FigureContext, Tolerances, all_figures, compare_with_file};

fn reference_dir() -> PathBuf {
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests crate is inside the workspace");
    workspace.join("reports").join(bench::report::REFERENCE_DIR)
}

/// A fresh scratch folder for one figure's plot output.
fn scratch_dir(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("workbench-reference-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create scratch folder");
    dir
}

#[test]
fn guarded_figures_match_their_reference_curves() {
    let guarded: Vec<_> = all_figures().into_iter().filter(|f| f.guarded).collect();
    if guarded.is_empty() {
        eprintln!("no guarded figures registered yet");
    }
    let mut failures = Vec::new();
    for spec in &guarded {
        let dir = scratch_dir(spec.name);
        let ctx = FigureContext::new(spec.name, true, &dir);
        let result = (spec.run)(&ctx).and_then(|out| {
            let reference = reference_dir().join(format!("{}.csv", spec.name));
            compare_with_file(&reference, &out.data, &Tolerances::default())
        });
        let _ = std::fs::remove_dir_all(&dir);
        match result {
            Ok(()) => eprintln!("{}: matches its reference curve", spec.name),
            Err(e) => failures.push(format!("{}: {e:#}", spec.name)),
        }
    }
    assert!(
        failures.is_empty(),
        "{} guarded figure(s) differ from their reference curves \
         (if the change is intended: `cargo xtask reproduce-figures --bless`):\n\n{}",
        failures.len(),
        failures.join("\n\n")
    );
}
