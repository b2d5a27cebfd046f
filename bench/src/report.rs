//! The figure runner: runs the selected figures, writes their data and
//! manifests under `reports/`, blesses reference curves and regenerates
//! `reports/README.md`.
//!
//! Layout (with `reports_dir = <workspace>/reports`):
//!
//! ```text
//! reports/README.md                 index of all registered figures (generated)
//! reports/<name>/<name>.png|.svg    the plot (drawn by the figure itself)
//! reports/<name>/<name>.csv         the plotted data
//! reports/<name>/manifest.json      config, key numbers, git revision, timing
//! reports/reference/<name>.csv      guarded reference curve (quick mode, --bless)
//! ```

use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{Context, bail};
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use serde::{Deserialize, Serialize};

use sim_periodic::shard::{Completion, Shard, check_complete, write_completion};

use crate::figure::{FigureContext, FigureOutput, FigureSpec, all_figures};

/// Name of the folder (inside the reports folder) holding reference curves.
pub const REFERENCE_DIR: &str = "reference";

/// What [`run_figures`] should do.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Quick mode: coarse sweeps, seconds per figure.
    pub quick: bool,
    /// Run only these figures (by name); `None` runs all.
    pub only: Option<Vec<String>>,
    /// Write `reports/reference/<name>.csv` for guarded figures.
    /// Implies `quick`, because the reference-curve test recomputes the
    /// guarded figures in quick mode.
    pub bless: bool,
    /// The `reports/` folder.
    pub reports_dir: PathBuf,
    /// Run only this shard of the selected figures, for a job array
    /// (`sim_periodic::shard`: the `t`-th selected figure belongs to shard `t mod N`). A
    /// shard does not rewrite `reports/README.md`; it writes its completion record into
    /// [`SHARDS_DIR`], and [`merge_figure_shards`] writes the README once all are there.
    pub shard: Option<Shard>,
}

/// Where figure shards leave their completion records (`reports/.shards/`, not committed).
pub const SHARDS_DIR: &str = ".shards";

/// The completion record kind of figure shards.
const SHARD_KIND: &str = "figures";

/// What the shards of one figure run must agree on: the mode and the selection.
fn shard_fingerprint(opts: &RunOptions) -> String {
    format!(
        "quick={} bless={} only={:?}",
        opts.quick || opts.bless,
        opts.bless,
        opts.only
    )
}

/// The merge of `count` figure shards run with the options `opts` (without its `shard`):
/// checks that every shard finished with these options, then regenerates
/// `reports/README.md` from the figures' manifests. Returns the shards' records (their
/// `failed` lists the figures that failed, with the error).
pub fn merge_figure_shards(opts: &RunOptions, count: usize) -> anyhow::Result<Vec<Completion>> {
    merge_specs(&all_figures(), opts, count)
}

/// [`merge_figure_shards`] over an explicit list of figures.
pub(crate) fn merge_specs(
    specs: &[FigureSpec],
    opts: &RunOptions,
    count: usize,
) -> anyhow::Result<Vec<Completion>> {
    validate_specs(specs)?;
    select(specs, opts.only.as_deref())?;
    let records = check_complete(
        &opts.reports_dir.join(SHARDS_DIR),
        SHARD_KIND,
        count,
        &shard_fingerprint(opts),
    )?;
    write_readme(specs, &opts.reports_dir)?;
    Ok(records)
}

/// The result of running one figure.
#[derive(Debug)]
pub struct FigureRun {
    /// Figure name.
    pub name: &'static str,
    /// Whether it ran in quick mode.
    pub quick: bool,
    /// Wall time of the figure function (not counting file writes).
    pub wall_time: Duration,
    /// Key numbers returned by the figure (empty on failure).
    pub summary: Vec<(String, String)>,
    /// Whether its reference curve was (re)written.
    pub blessed: bool,
    /// Why it failed, if it did.
    pub error: Option<anyhow::Error>,
}

/// Contents of `reports/<name>/manifest.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Figure name.
    pub figure: String,
    /// Figure title.
    pub title: String,
    /// Whether the run was in quick mode.
    pub quick: bool,
    /// Whether the figure is guarded by a reference curve.
    pub guarded: bool,
    /// `git rev-parse HEAD`, or `"unknown"`.
    pub git_revision: String,
    /// Version of the `bench` crate.
    pub crate_version: String,
    /// The Cargo profile the figures were built with: `"release"` (what `cargo xtask` builds)
    /// or `"dev"` (tests); timings are only comparable within one profile. Manifests written
    /// before this field existed were all built in the dev profile.
    #[serde(default = "dev_profile")]
    pub build_profile: String,
    /// UTC time the run finished, RFC 3339.
    pub timestamp: String,
    /// Wall time of the figure function in seconds.
    pub wall_time_s: f64,
    /// Key numbers, in the figure's order.
    pub key_numbers: Vec<KeyNumber>,
    /// The figure's configuration.
    pub config: serde_json::Value,
}

/// The profile this crate was built with, as far as the compiler tells: `"dev"` with debug
/// assertions, otherwise `"release"`.
pub fn build_profile() -> &'static str {
    if cfg!(debug_assertions) {
        "dev"
    } else {
        "release"
    }
}

fn dev_profile() -> String {
    "dev".to_string()
}

/// One named key number of a manifest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KeyNumber {
    /// What the number is, e.g. `"error at 64 segments"`.
    pub name: String,
    /// The value with its unit, e.g. `"0.31 %"`.
    pub value: String,
}

/// Runs the registered figures selected by `opts` (see [`RunOptions`]) and
/// regenerates `reports/README.md`.
///
/// A figure that fails does not stop the others: its error is in the
/// returned [`FigureRun`]. Returns `Err` only for bad options (e.g. unknown
/// names in `only`) or when the README cannot be written.
pub fn run_figures(opts: &RunOptions) -> anyhow::Result<Vec<FigureRun>> {
    run_specs(&all_figures(), opts)
}

/// [`run_figures`] over an explicit list of figures (the README indexes all of them).
pub(crate) fn run_specs(specs: &[FigureSpec], opts: &RunOptions) -> anyhow::Result<Vec<FigureRun>> {
    validate_specs(specs)?;
    let mut selected = select(specs, opts.only.as_deref())?;
    if let Some(shard) = opts.shard {
        selected = selected
            .into_iter()
            .enumerate()
            .filter(|(t, _)| shard.owns(*t))
            .map(|(_, s)| s)
            .collect();
    }
    let quick = opts.quick || opts.bless;
    fs::create_dir_all(&opts.reports_dir)
        .with_context(|| format!("creating {}", opts.reports_dir.display()))?;
    let git_revision = git_revision(&opts.reports_dir);

    // MultiProgress draws to stderr and hides itself when stderr is not a terminal.
    let multi = MultiProgress::new();
    let overall = multi.add(ProgressBar::new(selected.len() as u64));
    overall.set_style(
        ProgressStyle::with_template("figures [{bar:30}] {pos}/{len} {msg} ({elapsed})")
            .expect("valid template")
            .progress_chars("=> "),
    );

    // Shared by the figures of this run (e.g. databases several figures use).
    let cache = std::sync::Arc::new(crate::figure::FigureCache::default());
    let mut runs = Vec::new();
    for spec in selected {
        overall.set_message(spec.name);
        let run = run_one(spec, quick, opts, &git_revision, &multi, &cache);
        let line = match &run.error {
            None => format!(
                "done   {} ({:.1} s)",
                spec.name,
                run.wall_time.as_secs_f64()
            ),
            Some(e) => format!("FAILED {}: {e:#}", spec.name),
        };
        // A no-op when progress is hidden; the caller prints its own summary.
        let _ = multi.println(line);
        overall.inc(1);
        runs.push(run);
    }
    overall.finish_and_clear();

    match opts.shard {
        None => write_readme(specs, &opts.reports_dir)?,
        Some(shard) => write_completion(
            &opts.reports_dir.join(SHARDS_DIR),
            &Completion {
                kind: SHARD_KIND.into(),
                index: shard.index,
                count: shard.count,
                fingerprint: shard_fingerprint(opts),
                units: runs.len(),
                failed: runs
                    .iter()
                    .filter_map(|r| Some(format!("{}: {:#}", r.name, r.error.as_ref()?)))
                    .collect(),
            },
        )?,
    }
    Ok(runs)
}

/// Figure names must be unique kebab-case and must not clash with the reference folder.
fn validate_specs(specs: &[FigureSpec]) -> anyhow::Result<()> {
    for (i, spec) in specs.iter().enumerate() {
        let kebab = !spec.name.is_empty()
            && !spec.name.starts_with('-')
            && !spec.name.ends_with('-')
            && spec
                .name
                .chars()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-');
        if !kebab || spec.name == REFERENCE_DIR {
            bail!(
                "figure name {:?} must be kebab-case and not {REFERENCE_DIR:?}",
                spec.name
            );
        }
        if specs[..i].iter().any(|s| s.name == spec.name) {
            bail!("figure {:?} is registered twice", spec.name);
        }
    }
    Ok(())
}

/// The specs named in `only` (in registry order), or all of them.
fn select<'a>(
    specs: &'a [FigureSpec],
    only: Option<&[String]>,
) -> anyhow::Result<Vec<&'a FigureSpec>> {
    let Some(only) = only.filter(|o| !o.is_empty()) else {
        return Ok(specs.iter().collect());
    };
    let unknown: Vec<&str> = only
        .iter()
        .map(|n| n.as_str())
        .filter(|n| !specs.iter().any(|s| s.name == *n))
        .collect();
    if !unknown.is_empty() {
        let valid: Vec<&str> = specs.iter().map(|s| s.name).collect();
        let valid = if valid.is_empty() {
            "none (no figures are registered yet)".to_string()
        } else {
            valid.join(", ")
        };
        bail!(
            "unknown figure name(s): {}; valid names: {valid}",
            unknown.join(", ")
        );
    }
    Ok(specs
        .iter()
        .filter(|s| only.iter().any(|n| n == s.name))
        .collect())
}

/// A figure's hand-written notes in its report folder (`reports/<figure>/NOTES.md`): the
/// measured history of its settings, with the runs, dates and revisions they come from, which
/// do not belong in the code's documentation. Kept when the figure is regenerated.
pub const NOTES_FILE: &str = "NOTES.md";

fn run_one(
    spec: &FigureSpec,
    quick: bool,
    opts: &RunOptions,
    git_revision: &str,
    multi: &MultiProgress,
    cache: &std::sync::Arc<crate::figure::FigureCache>,
) -> FigureRun {
    let mut run = FigureRun {
        name: spec.name,
        quick,
        wall_time: Duration::ZERO,
        summary: Vec::new(),
        blessed: false,
        error: None,
    };
    let out_dir = opts.reports_dir.join(spec.name);
    let result = (|| -> anyhow::Result<()> {
        // The folder is generated output: start from scratch so nothing stale survives,
        // except the figure's hand-written notes (NOTES_FILE), which are kept.
        let notes_path = out_dir.join(NOTES_FILE);
        let notes = fs::read(&notes_path).ok();
        if out_dir.exists() {
            fs::remove_dir_all(&out_dir)
                .with_context(|| format!("removing old {}", out_dir.display()))?;
        }
        fs::create_dir_all(&out_dir).with_context(|| format!("creating {}", out_dir.display()))?;
        if let Some(notes) = notes {
            fs::write(&notes_path, notes)
                .with_context(|| format!("restoring {}", notes_path.display()))?;
        }

        let ctx = FigureContext::with_progress(
            spec.name,
            quick,
            out_dir.clone(),
            multi.clone(),
            cache.clone(),
        );
        let start = Instant::now();
        let output = (spec.run)(&ctx);
        run.wall_time = start.elapsed();
        ctx.clear_progress();
        let output: FigureOutput = output?;

        let png = out_dir.join(format!("{}.png", spec.name));
        if !png.exists() {
            bail!(
                "the figure did not draw {} (use plot::LineChart::save(&ctx.out_dir, ctx.name))",
                png.display()
            );
        }
        output
            .data
            .write_csv(&out_dir.join(format!("{}.csv", spec.name)))?;
        let manifest = Manifest {
            figure: spec.name.to_string(),
            title: spec.title.to_string(),
            quick,
            guarded: spec.guarded,
            git_revision: git_revision.to_string(),
            crate_version: env!("CARGO_PKG_VERSION").to_string(),
            build_profile: build_profile().to_string(),
            timestamp: utc_timestamp(SystemTime::now()),
            wall_time_s: (run.wall_time.as_secs_f64() * 1e3).round() / 1e3,
            key_numbers: output
                .summary
                .iter()
                .map(|(name, value)| KeyNumber {
                    name: name.clone(),
                    value: value.clone(),
                })
                .collect(),
            config: output.config.clone(),
        };
        let manifest_path = out_dir.join("manifest.json");
        fs::write(
            &manifest_path,
            serde_json::to_string_pretty(&manifest)? + "\n",
        )
        .with_context(|| format!("writing {}", manifest_path.display()))?;

        if opts.bless && spec.guarded {
            let dir = opts.reports_dir.join(REFERENCE_DIR);
            fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
            output
                .data
                .write_csv(&dir.join(format!("{}.csv", spec.name)))?;
            run.blessed = true;
        }
        run.summary = output.summary;
        Ok(())
    })();
    run.error = result.err();
    run
}

/// Reads `reports/<name>/manifest.json`, if present and valid.
pub fn read_manifest(reports_dir: &Path, name: &str) -> Option<Manifest> {
    let text = fs::read_to_string(reports_dir.join(name).join("manifest.json")).ok()?;
    serde_json::from_str(&text).ok()
}

/// Rewrites `reports/README.md`: how to regenerate, and one line per
/// registered figure with the key numbers of its latest manifest.
fn write_readme(specs: &[FigureSpec], reports_dir: &Path) -> anyhow::Result<()> {
    let mut md = String::from(
        "# Figures\n\
         \n\
         <!-- Generated by `cargo xtask reproduce-figures`; do not edit by hand. -->\n\
         \n\
         Regenerate every figure with `cargo xtask reproduce-figures` (add `--quick` for a fast, \
         coarse pass, `--only NAME[,NAME]` for a subset, `cargo xtask list` to see the names). \
         Each figure lives in `reports/<name>/`: the plot as `<name>.png` and `<name>.svg`, the \
         plotted data as `<name>.csv`, and `manifest.json` with its configuration, key numbers, \
         git revision and run time.\n\
         \n\
         Guarded figures have a reference curve in `reports/reference/<name>.csv`; \
         `cargo test -p workbench-tests --test reference_curves` recomputes them in quick mode and \
         compares. After an intended change, rewrite the references with \
         `cargo xtask reproduce-figures --bless` (which always runs in quick mode) and commit them.\n\
         \n\
         ## Index\n\
         \n",
    );
    if specs.is_empty() {
        md.push_str("_No figures are registered yet._\n");
    }
    for spec in specs {
        let latest = match read_manifest(reports_dir, spec.name) {
            None => "not generated yet".to_string(),
            Some(m) => {
                let numbers: Vec<String> = m
                    .key_numbers
                    .iter()
                    .map(|k| format!("{} = {}", k.name, k.value))
                    .collect();
                let mode = if m.quick { "quick run" } else { "full run" };
                let rev: String = m.git_revision.chars().take(10).collect();
                let numbers = if numbers.is_empty() {
                    "no key numbers".to_string()
                } else {
                    numbers.join("; ")
                };
                format!(
                    "{numbers} ({mode}, {} build, rev {rev}, {})",
                    m.build_profile, m.timestamp
                )
            }
        };
        writeln!(
            md,
            "- **[{name}]({name}/{name}.png)** — {title}. Shows: {shows}. Paper: {paper}. \
             Key numbers: {latest}. Guarded: {guarded}.",
            name = spec.name,
            title = spec.title.trim_end_matches('.'),
            shows = spec.shows.trim_end_matches('.'),
            paper = spec.paper.trim_end_matches('.'),
            guarded = if spec.guarded { "yes" } else { "no" },
        )?;
    }
    let path = reports_dir.join("README.md");
    fs::write(&path, md).with_context(|| format!("writing {}", path.display()))
}

/// A plain-text table of the runs: figure, status, time, key numbers.
pub fn summary_table(runs: &[FigureRun]) -> String {
    let rows: Vec<[String; 4]> = runs
        .iter()
        .map(|r| {
            let status = match (&r.error, r.blessed) {
                (Some(_), _) => "FAILED",
                (None, true) => "ok, blessed",
                (None, false) => "ok",
            };
            let numbers: Vec<String> = r
                .summary
                .iter()
                .map(|(k, v)| format!("{k} = {v}"))
                .collect();
            [
                r.name.to_string(),
                status.to_string(),
                format!("{:.1} s", r.wall_time.as_secs_f64()),
                numbers.join("; "),
            ]
        })
        .collect();
    let header = ["figure", "status", "time", "key numbers"].map(String::from);
    let mut widths = header.each_ref().map(|h| h.len());
    for row in &rows {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let mut out = String::new();
    for row in std::iter::once(&header).chain(&rows) {
        let line = format!(
            "{:<w0$}  {:<w1$}  {:>w2$}  {}",
            row[0],
            row[1],
            row[2],
            row[3],
            w0 = widths[0],
            w1 = widths[1],
            w2 = widths[2]
        );
        out.push_str(line.trim_end());
        out.push('\n');
    }
    out
}

/// `git rev-parse HEAD` run in `dir`, or `"unknown"`.
fn git_revision(dir: &Path) -> String {
    Command::new("git")
        .args(["rev-parse", "HEAD"])
        .current_dir(dir)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".to_string())
}

/// RFC 3339 UTC timestamp, `YYYY-MM-DDThh:mm:ssZ`.
fn utc_timestamp(t: SystemTime) -> String {
    let secs = t.duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1_460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::{LineChart, Series};
    use crate::reference::{Tolerances, compare_with_file};
    use yarn_output::table::Table;

    /// A synthetic figure: y = x² sampled, with a dashed reference line.
    fn squares(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
        let n = if ctx.quick { 5 } else { 20 };
        let progress = ctx.progress(n as u64, "sampling");
        let mut data = Table::new(&["x", "y"]);
        for i in 0..n {
            let x = 1.0 + i as f64;
            data.push_row([x, x * x]);
            progress.inc(1);
        }
        let pts = data.rows.iter().map(|r| (r[0], r[1]));
        LineChart::new("Squares")
            .x_label("x")
            .y_label("y = x²")
            .series(Series::line_markers("x²", pts))
            .hline("ten", 10.0)
            .save(&ctx.out_dir, ctx.name)?;
        Ok(FigureOutput {
            summary: vec![("largest y".into(), format!("{}", (n * n) as f64))],
            config: serde_json::json!({ "samples": n }),
            data,
        })
    }

    fn no_plot(_ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
        Ok(FigureOutput::default())
    }

    fn spec(
        name: &'static str,
        run: fn(&FigureContext) -> anyhow::Result<FigureOutput>,
    ) -> FigureSpec {
        FigureSpec {
            name,
            title: "Squares",
            shows: "y = x² sampled at integers",
            paper: "exact by construction",
            guarded: true,
            run,
        }
    }

    fn temp_reports(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("bench-report-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        dir
    }

    #[test]
    fn end_to_end_with_synthetic_figure() {
        let reports_dir = temp_reports("e2e");
        let specs = [spec("test-squares", squares), spec("test-unrun", squares)];
        let opts = RunOptions {
            quick: false,
            only: Some(vec!["test-squares".into()]),
            bless: true,
            reports_dir: reports_dir.clone(),
            shard: None,
        };
        let runs = run_specs(&specs, &opts).unwrap();
        assert_eq!(runs.len(), 1);
        assert!(runs[0].error.is_none(), "{:?}", runs[0].error);
        assert!(
            runs[0].blessed && runs[0].quick,
            "--bless implies quick mode"
        );

        // A rerun replaces the generated files but keeps the figure's notes.
        let dir = reports_dir.join("test-squares");
        fs::write(dir.join(NOTES_FILE), "# notes\n").unwrap();
        fs::write(dir.join("stale.txt"), "old").unwrap();
        run_specs(&specs, &opts).unwrap();
        assert_eq!(
            fs::read_to_string(dir.join(NOTES_FILE)).unwrap(),
            "# notes\n"
        );
        assert!(!dir.join("stale.txt").exists());

        for file in [
            "test-squares.png",
            "test-squares.svg",
            "test-squares.csv",
            "manifest.json",
        ] {
            assert!(dir.join(file).is_file(), "missing {file}");
        }
        let manifest = read_manifest(&reports_dir, "test-squares").expect("manifest");
        assert!(manifest.quick);
        assert_eq!(manifest.key_numbers[0].value, "25");
        assert_eq!(manifest.config["samples"], 5);
        assert!(!manifest.git_revision.is_empty());

        let csv = Table::read_csv(&dir.join("test-squares.csv")).unwrap();
        assert_eq!(csv.column("y"), Some(vec![1.0, 4.0, 9.0, 16.0, 25.0]));
        let reference = reports_dir.join(REFERENCE_DIR).join("test-squares.csv");
        compare_with_file(&reference, &csv, &Tolerances::default()).unwrap();

        let readme = fs::read_to_string(reports_dir.join("README.md")).unwrap();
        assert!(
            readme.contains("[test-squares](test-squares/test-squares.png)"),
            "{readme}"
        );
        assert!(readme.contains("largest y = 25 (quick run"), "{readme}");
        assert!(
            readme.contains("**[test-unrun](test-unrun/test-unrun.png)**"),
            "{readme}"
        );
        assert!(readme.contains("not generated yet"), "{readme}");
        assert!(
            readme.contains("cargo xtask reproduce-figures --bless"),
            "{readme}"
        );

        fs::remove_dir_all(&reports_dir).unwrap();
    }

    #[test]
    fn figure_shards_split_the_selection_and_merge_into_the_readme() {
        let reports_dir = temp_reports("shards");
        let specs = [
            spec("test-a", squares),
            spec("test-b", squares),
            spec("test-c", squares),
        ];
        let opts = |shard| RunOptions {
            quick: true,
            reports_dir: reports_dir.clone(),
            shard,
            ..RunOptions::default()
        };
        let first = run_specs(&specs, &opts(Some(Shard::new(0, 2).unwrap()))).unwrap();
        let names: Vec<&str> = first.iter().map(|r| r.name).collect();
        assert_eq!(names, ["test-a", "test-c"]);
        assert!(
            !reports_dir.join("README.md").exists(),
            "a shard leaves the README"
        );
        let e = merge_specs(&specs, &opts(None), 2).unwrap_err().to_string();
        assert!(e.contains("shard-1-of-2.json"), "{e}");
        // Shards of another mode do not merge with these.
        let full = RunOptions {
            quick: false,
            ..opts(None)
        };
        let second = run_specs(&specs, &opts(Some(Shard::new(1, 2).unwrap()))).unwrap();
        assert_eq!(second.len(), 1);
        let e = merge_specs(&specs, &full, 2).unwrap_err().to_string();
        assert!(e.contains("other inputs"), "{e}");
        let records = merge_specs(&specs, &opts(None), 2).unwrap();
        assert_eq!(records.iter().map(|r| r.units).sum::<usize>(), 3);
        let readme = fs::read_to_string(reports_dir.join("README.md")).unwrap();
        assert!(
            ["test-a", "test-b", "test-c"]
                .iter()
                .all(|n| readme.contains(&format!("[{n}]({n}/{n}.png)")))
                && !readme.contains("not generated yet"),
            "{readme}"
        );
        fs::remove_dir_all(&reports_dir).unwrap();
    }

    #[test]
    fn unknown_names_list_valid_ones() {
        let reports_dir = temp_reports("unknown");
        let specs = [spec("test-squares", squares)];
        let opts = RunOptions {
            only: Some(vec!["nope".into()]),
            reports_dir: reports_dir.clone(),
            ..RunOptions::default()
        };
        let msg = run_specs(&specs, &opts).unwrap_err().to_string();
        assert!(
            msg.contains("nope") && msg.contains("valid names: test-squares"),
            "{msg}"
        );
        assert!(!reports_dir.exists(), "nothing written on bad options");
    }

    #[test]
    fn figure_without_plot_fails_but_others_run() {
        let reports_dir = temp_reports("noplot");
        let specs = [spec("test-no-plot", no_plot), spec("test-squares", squares)];
        let opts = RunOptions {
            quick: true,
            reports_dir: reports_dir.clone(),
            ..RunOptions::default()
        };
        let runs = run_specs(&specs, &opts).unwrap();
        let err = runs[0]
            .error
            .as_ref()
            .expect("no plot is an error")
            .to_string();
        assert!(err.contains("test-no-plot.png"), "{err}");
        assert!(runs[1].error.is_none());
        assert!(!runs[1].blessed);
        assert!(
            !reports_dir.join(REFERENCE_DIR).exists(),
            "no bless without --bless"
        );
        let table = summary_table(&runs);
        assert!(
            table.contains("FAILED") && table.contains("largest y = 25"),
            "{table}"
        );
        fs::remove_dir_all(&reports_dir).unwrap();
    }

    #[test]
    fn bad_spec_names_are_rejected() {
        let opts = RunOptions::default();
        assert!(run_specs(&[spec("Bad_Name", squares)], &opts).is_err());
        assert!(run_specs(&[spec("reference", squares)], &opts).is_err());
        assert!(run_specs(&[spec("a", squares), spec("a", squares)], &opts).is_err());
    }

    #[test]
    fn registry_is_valid() {
        validate_specs(&all_figures()).unwrap();
    }

    #[test]
    fn timestamps_are_rfc3339() {
        let t = UNIX_EPOCH + Duration::from_secs(951_782_400 + 3_723); // 29 February 2000, 01:02:03
        assert_eq!(utc_timestamp(t), "2000-02-29T01:02:03Z");
        assert_eq!(utc_timestamp(UNIX_EPOCH), "1970-01-01T00:00:00Z");
    }
}
