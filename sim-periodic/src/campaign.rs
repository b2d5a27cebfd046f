//! Fit campaigns: every fit config of a list × every swarm seed, as independent tasks that a
//! job array runs in shards ([`crate::shard`]) and a merge collects into one table.
//!
//! ```toml
//! # campaign.toml (paths relative to this file)
//! out = "campaign"                          # task outputs and the merged table
//! fits = ["acrylic-garter.toml", "babyredo-rib.toml"]   # `sim-periodic fit` configs
//! seeds = [1, 2, 3, 4]                      # replaces each config's [fit] seed
//! ```
//!
//! Task `t` is fit `t / n_seeds` with seed `t mod n_seeds`; it writes what
//! `sim-periodic fit` writes (journal, `fit.json`, curves) into `out/<fit stem>/seed-<seed>/`,
//! so a killed task resumes from its journal. Restarts ([`crate::fit::SwarmSettings::restarts`])
//! stay inside a task: the best of a fit's restarts starts its local search, so they are not
//! independent units.
//!
//! The merge ([`merge`]) reads every task's `fit.json` into `out/campaign.csv`, one row per
//! task in task order with the deterministic results only (no timings), so a merged campaign
//! equals a single-process one byte for byte.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::config::ConfigError;
use solver::checksum::fnv1a;

/// A campaign file, its paths resolved against the file's folder.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Campaign {
    /// Output folder.
    pub out: PathBuf,
    /// `sim-periodic fit` configs ([`crate::config::FitConfig`]).
    pub fits: Vec<PathBuf>,
    /// Swarm seeds, each run on every fit.
    pub seeds: Vec<u64>,
}

/// One fit of a campaign with one seed.
#[derive(Clone, Debug, PartialEq)]
pub struct Task {
    /// Task number (the shard unit).
    pub number: usize,
    /// The fit config.
    pub fit: PathBuf,
    /// The fit's name (its file stem).
    pub name: String,
    /// The swarm seed.
    pub seed: u64,
    /// Its output folder, `out/<name>/seed-<seed>`.
    pub out: PathBuf,
}

/// The completion record kind of campaign shards.
pub const SHARD_KIND: &str = "campaign";

/// The merged table's file name in the campaign's `out`.
pub const TABLE_FILE: &str = "campaign.csv";

impl Campaign {
    /// Reads and checks `path` ([`Campaign::parse`]), resolves its paths against the file's
    /// folder and checks that the fit configs exist.
    pub fn read(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let mut campaign = Self::parse(&text, path)?;
        let base = path.parent().unwrap_or(Path::new("."));
        campaign.out = base.join(&campaign.out);
        for fit in &mut campaign.fits {
            *fit = base.join(&*fit);
            if !fit.is_file() {
                return Err(ConfigError::Invalid {
                    message: format!("fit config {} does not exist", fit.display()),
                    path: path.to_path_buf(),
                });
            }
        }
        Ok(campaign)
    }

    /// Parses campaign TOML `text` (`path` names it in errors): at least one fit and one
    /// seed, distinct fit names (file stems) and seeds. Paths stay as written.
    pub fn parse(text: &str, path: &Path) -> Result<Self, ConfigError> {
        let campaign: Self = crate::config::parse_toml(text, path)?;
        let bad = |message: String| ConfigError::Invalid {
            message,
            path: path.to_path_buf(),
        };
        if campaign.fits.is_empty() || campaign.seeds.is_empty() {
            return Err(bad(
                "`fits` and `seeds` must each list at least one entry".into()
            ));
        }
        let mut names: Vec<String> = Vec::new();
        for fit in &campaign.fits {
            let name = fit
                .file_stem()
                .map(|s| s.to_string_lossy().to_string())
                .filter(|s| !s.is_empty())
                .ok_or_else(|| bad(format!("fit {:?} has no file name", fit.display())))?;
            if names.contains(&name) {
                return Err(bad(format!(
                    "two fits are named {name:?}: their outputs would share out/{name}; \
                     give the configs distinct file names"
                )));
            }
            names.push(name);
        }
        for (i, s) in campaign.seeds.iter().enumerate() {
            if campaign.seeds[..i].contains(s) {
                return Err(bad(format!("seed {s} is listed twice")));
            }
        }
        Ok(campaign)
    }

    /// The tasks in task order (fit-major).
    pub fn tasks(&self) -> Vec<Task> {
        let mut tasks = Vec::with_capacity(self.fits.len() * self.seeds.len());
        for fit in &self.fits {
            let name = fit
                .file_stem()
                .map(|s| s.to_string_lossy().to_string())
                .unwrap_or_default();
            for &seed in &self.seeds {
                tasks.push(Task {
                    number: tasks.len(),
                    fit: fit.clone(),
                    name: name.clone(),
                    seed,
                    out: self.out.join(&name).join(format!("seed-{seed}")),
                });
            }
        }
        tasks
    }

    /// Fingerprint of the campaign's inputs: its seeds and every fit config's text and
    /// target curves. Shards of one campaign must agree on it.
    pub fn fingerprint(&self) -> Result<String, ConfigError> {
        let mut bytes = format!("{:?}", self.seeds).into_bytes();
        for fit in &self.fits {
            let read = |p: &Path| {
                std::fs::read(p).map_err(|source| ConfigError::Io {
                    path: p.to_path_buf(),
                    source,
                })
            };
            bytes.extend(read(fit)?);
            let config = crate::config::FitConfig::read(fit)?;
            bytes.extend(read(&config.targets)?);
        }
        Ok(format!("{:016x}", fnv1a(&bytes)))
    }
}

/// Errors of the merge.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    /// A task's result is missing or unreadable.
    #[error("{}: {problem}", path.display())]
    Result {
        /// The task's `fit.json`.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// The table could not be written.
    #[error("{}: {source}", path.display())]
    Write {
        /// The table.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
}

/// One merged row: a task and its `fit.json` (or why it failed).
#[derive(Clone, Debug)]
pub struct Row {
    /// The task.
    pub task: Task,
    /// Its `fit.json`, `None` for a task its shard recorded as failed.
    pub result: Option<serde_json::Value>,
}

/// Reads every task's result (`failed` lists the task numbers whose shard recorded them as
/// failed) and writes `out/campaign.csv`: fit, seed, status, objective g, comfort-range error,
/// power and compression errors, evaluations, failed evaluations, then the fitted parameters
/// as `name=value` pairs separated by `;`. Returns the rows.
pub fn merge(campaign: &Campaign, failed: &[usize]) -> Result<Vec<Row>, MergeError> {
    let mut rows = Vec::new();
    let mut csv = String::from(
        "fit,seed,status,objective,comfort_error,power_error,compression_error,\
         swarm_evaluations,local_evaluations,failed_evaluations,parameters\n",
    );
    for task in campaign.tasks() {
        let path = task.out.join("fit.json");
        if failed.contains(&task.number) {
            let _ = writeln!(csv, "{},{},failed,,,,,,,,", task.name, task.seed);
            rows.push(Row { task, result: None });
            continue;
        }
        let bad = |problem: String| MergeError::Result {
            path: path.clone(),
            problem,
        };
        let text = std::fs::read_to_string(&path).map_err(|e| {
            bad(format!(
                "task {} ({} seed {}) has no result: {e}",
                task.number, task.name, task.seed
            ))
        })?;
        let json: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| bad(format!("not a fit result: {e}")))?;
        // A number, or empty where the fit has none (`null`: e.g. no comfort-range samples).
        let number = |key: &str| -> Result<String, MergeError> {
            match &json[key] {
                serde_json::Value::Null if json.get(key).is_some() => Ok(String::new()),
                v => v
                    .as_f64()
                    .map(|v| format!("{v:e}"))
                    .ok_or_else(|| bad(format!("has no number {key:?}"))),
            }
        };
        let count = |a: &str, b: Option<&str>| {
            let v = b.map_or(&json[a], |b| &json[a][b]);
            v.as_u64().map_or(String::new(), |n| n.to_string())
        };
        let parameters: Vec<String> = json["parameters"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|p| {
                format!(
                    "{}={:e}",
                    p["name"].as_str().unwrap_or("?"),
                    p["value"].as_f64().unwrap_or(f64::NAN)
                )
            })
            .collect();
        let _ = writeln!(
            csv,
            "{},{},ok,{},{},{},{},{},{},{},{}",
            task.name,
            task.seed,
            number("objective")?,
            number("comfort_error")?,
            number("power_error")?,
            number("compression_error")?,
            count("evaluations", Some("swarm")),
            count("evaluations", Some("local")),
            count("failed_evaluations", None),
            parameters.join(";")
        );
        rows.push(Row {
            task,
            result: Some(json),
        });
    }
    let table = campaign.out.join(TABLE_FILE);
    std::fs::create_dir_all(&campaign.out)
        .and_then(|()| std::fs::write(&table, csv))
        .map_err(|source| MergeError::Write {
            path: table.clone(),
            source,
        })?;
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn campaigns_are_checked_and_enumerate_fit_major() {
        let dir = std::env::temp_dir().join(format!("campaign-read-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("b")).unwrap();
        std::fs::write(dir.join("a.toml"), "").unwrap();
        std::fs::write(dir.join("b").join("c.toml"), "").unwrap();
        let write = |text: &str| {
            let p = dir.join("campaign.toml");
            std::fs::write(&p, text).unwrap();
            Campaign::read(&p)
        };
        let c =
            write("out = \"o\"\nfits = [\"a.toml\", \"b/c.toml\"]\nseeds = [3, 1, 2]\n").unwrap();
        let tasks = c.tasks();
        assert_eq!(tasks.len(), 6);
        assert_eq!((tasks[4].name.as_str(), tasks[4].seed), ("c", 1));
        assert_eq!(tasks[4].out, dir.join("o").join("c").join("seed-1"));
        let e = write("out = \"o\"\nfits = [\"a.toml\"]\nseeds = []\n").unwrap_err();
        assert!(e.to_string().contains("at least one"), "{e}");
        let e = write("out = \"o\"\nfits = [\"a.toml\", \"a.toml\"]\nseeds = [1]\n").unwrap_err();
        assert!(e.to_string().contains("two fits are named \"a\""), "{e}");
        let e = write("out = \"o\"\nfits = [\"x.toml\"]\nseeds = [1]\n").unwrap_err();
        assert!(e.to_string().contains("x.toml does not exist"), "{e}");
        let e = write("out = \"o\"\nfits = [\"a.toml\"]\nseeds = [1, 1]\n").unwrap_err();
        assert!(e.to_string().contains("seed 1 is listed twice"), "{e}");
        let e = write("out = \"o\"\nfits = [\"a.toml\"]\nseed = [1]\n").unwrap_err();
        assert!(e.to_string().contains("campaign.toml:3:"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
