//! Repository automation.
//!
//! ```text
//! cargo xtask reproduce-figures [--quick] [--only NAME[,NAME]] [--bless] [--shard K/N | --merge N]
//! cargo xtask validate [--quick]
//! cargo xtask list
//! ```
//!
//! Figures are written to `<workspace>/reports/`; see `bench::report`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(about = "Repository automation for the yarn-level cloth workbench")]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Run figure generators into reports/NAME/ and regenerate reports/README.md.
    ReproduceFigures {
        /// Coarse sweeps: every figure in seconds.
        #[arg(long)]
        quick: bool,
        /// Only these figures (comma-separated or repeated).
        #[arg(long, value_name = "NAME", value_delimiter = ',')]
        only: Vec<String>,
        /// Rewrite reports/reference/NAME.csv for guarded figures. Implies
        /// --quick: the reference-curve test recomputes guarded figures in
        /// quick mode, so the references must be quick-mode data.
        #[arg(long)]
        bless: bool,
        /// Run only shard K of N (0 <= K < N) of the selected figures, for a job array
        /// (`scripts/slurm/figures.sbatch`); leaves reports/README.md to `--merge N`.
        #[arg(long, value_name = "K/N", conflicts_with = "merge")]
        shard: Option<sim_periodic::shard::Shard>,
        /// Check that the N shards run with the same options finished, and regenerate
        /// reports/README.md (runs no figure).
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
        merge: Option<u64>,
    },
    /// Cross-method validation: the same yarn through every method (`cross-method`) and the
    /// closed loop (`closed-loop`), written to reports/ like any figure, with the agreement
    /// table printed.
    Validate {
        /// Small swatches and short ranges: seconds instead of minutes.
        #[arg(long)]
        quick: bool,
    },
    /// List the registered figures.
    List,
}

fn main() -> ExitCode {
    let result = match Cli::parse().command {
        Cmd::ReproduceFigures {
            quick,
            only,
            bless,
            shard,
            merge,
        } => match merge {
            Some(count) => merge_figures(quick, only, bless, count as usize),
            None => reproduce_figures(quick, only, bless, shard),
        },
        Cmd::Validate { quick } => validate(quick),
        Cmd::List => {
            list();
            Ok(ExitCode::SUCCESS)
        }
    };
    result.unwrap_or_else(|e| {
        eprintln!("error: {e:#}");
        ExitCode::from(2)
    })
}

/// The workspace root: the parent of this crate's manifest folder.
fn workspace_root() -> anyhow::Result<PathBuf> {
    let manifest_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest_dir
        .parent()
        .map(Path::to_path_buf)
        .context("xtask manifest folder has no parent")
}

/// `reproduce-figures --merge N`: the README once every shard has finished; fails when a
/// shard recorded a failed figure.
fn merge_figures(
    quick: bool,
    only: Vec<String>,
    bless: bool,
    count: usize,
) -> anyhow::Result<ExitCode> {
    let reports_dir = workspace_root()?.join("reports");
    let opts = bench::RunOptions {
        quick,
        only: (!only.is_empty()).then_some(only),
        bless,
        reports_dir: reports_dir.clone(),
        shard: None,
    };
    let records = bench::report::merge_figure_shards(&opts, count)?;
    let figures: usize = records.iter().map(|r| r.units).sum();
    let failed: Vec<&String> = records.iter().flat_map(|r| &r.failed).collect();
    println!(
        "{count} shards, {figures} figures ({} failed); wrote {}",
        failed.len(),
        reports_dir.join("README.md").display()
    );
    for f in &failed {
        eprintln!("error in {f}");
    }
    Ok(if failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

fn reproduce_figures(
    quick: bool,
    only: Vec<String>,
    bless: bool,
    shard: Option<sim_periodic::shard::Shard>,
) -> anyhow::Result<ExitCode> {
    let reports_dir = workspace_root()?.join("reports");
    if bless && !quick {
        eprintln!("note: --bless implies --quick (reference curves are quick-mode data)");
    }
    let opts = bench::RunOptions {
        quick,
        only: (!only.is_empty()).then_some(only),
        bless,
        reports_dir: reports_dir.clone(),
        shard,
    };
    let runs = bench::run_figures(&opts)?;
    if runs.is_empty() {
        println!(
            "no figures are registered yet; wrote {}",
            reports_dir.join("README.md").display()
        );
        return Ok(ExitCode::SUCCESS);
    }

    print!("{}", bench::report::summary_table(&runs));
    println!("reports: {}", reports_dir.display());
    if bless && !runs.iter().any(|r| r.blessed) {
        println!("note: --bless wrote nothing (no guarded figure among those run)");
    }
    let failed: Vec<_> = runs.iter().filter(|r| r.error.is_some()).collect();
    for run in &failed {
        if let Some(e) = &run.error {
            eprintln!("\nerror in {}: {e:#}", run.name);
        }
    }
    Ok(if failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// The figures `cargo xtask validate` runs.
const VALIDATION_FIGURES: [&str; 2] = ["cross-method", "closed-loop"];

fn validate(quick: bool) -> anyhow::Result<ExitCode> {
    let code = reproduce_figures(
        quick,
        VALIDATION_FIGURES.iter().map(|s| s.to_string()).collect(),
        false,
        None,
    )?;
    let reports = workspace_root()?.join("reports");
    for name in VALIDATION_FIGURES {
        let manifest = reports.join(name).join("manifest.json");
        let Ok(text) = std::fs::read_to_string(&manifest) else {
            continue;
        };
        let json: serde_json::Value = serde_json::from_str(&text)
            .with_context(|| format!("reading {}", manifest.display()))?;
        println!("\n{name}: agreement");
        for k in json["key_numbers"].as_array().into_iter().flatten() {
            println!(
                "  {}: {}",
                k["name"].as_str().unwrap_or(""),
                k["value"].as_str().unwrap_or("")
            );
        }
    }
    Ok(code)
}

fn list() {
    let figures = bench::all_figures();
    if figures.is_empty() {
        println!("no figures are registered yet");
    }
    let width = figures.iter().map(|f| f.name.len()).max().unwrap_or(0);
    for f in figures {
        let guarded = if f.guarded { "  [guarded]" } else { "" };
        println!("{:<width$}  {}{guarded}", f.name, f.title);
    }
}
