//! Deterministic shards of a long run, for job arrays (`sbatch --array=0-(N-1)`, see
//! `scripts/slurm/`).
//!
//! A run of `T` independent units (database lines, fits, figures) is split into `N` shards;
//! shard `K` (0-based, written `K/N`) owns the units `t` with `t mod N = K`. Round robin
//! rather than contiguous blocks, so that neighbouring units, which tend to cost alike, are
//! spread over the shards. Which shard owns what depends on `T` and `N` only, never on timing,
//! so a shard that fails or is killed reruns alone and finds the same units.
//!
//! A shard that finishes writes a *completion record* `shard-K-of-N.json` into the run's
//! folder: the fingerprint of the run's inputs and the units it finished. The merge step
//! ([`check_complete`]) refuses to run until every shard's record is there, for the same
//! inputs, and names the shards that are missing.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// Shard `index` of `count` (0-based: `0/4` … `3/4`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard, `0..count`.
    pub index: usize,
    /// Number of shards (≥ 1).
    pub count: usize,
}

impl Shard {
    /// The whole run as one shard.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Shard `index` of `count`; `None` unless `index < count`.
    pub fn new(index: usize, count: usize) -> Option<Self> {
        (index < count).then_some(Self { index, count })
    }

    /// Whether this shard owns unit `unit` (round robin).
    pub fn owns(&self, unit: usize) -> bool {
        unit % self.count == self.index
    }

    /// The shard that owns `unit` among `count` shards.
    pub fn owner(unit: usize, count: usize) -> Shard {
        Shard {
            index: unit % count,
            count,
        }
    }

    /// The file name of this shard's completion record.
    pub fn record_name(&self) -> String {
        format!("shard-{}-of-{}.json", self.index, self.count)
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// A `K/N` that is not a shard.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("shard {text:?}: expected K/N with whole numbers 0 <= K < N (e.g. 0/4 ... 3/4)")]
pub struct ShardParseError {
    /// What was given.
    pub text: String,
}

impl FromStr for Shard {
    type Err = ShardParseError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let err = || ShardParseError { text: s.into() };
        let (k, n) = s.split_once('/').ok_or_else(err)?;
        let k: usize = k.trim().parse().map_err(|_| err())?;
        let n: usize = n.trim().parse().map_err(|_| err())?;
        Shard::new(k, n).ok_or_else(err)
    }
}

/// What a finished shard writes (`shard-K-of-N.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Completion {
    /// What kind of run (`"database"`, `"campaign"`, `"figures"`).
    pub kind: String,
    /// This shard.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
    /// Fingerprint of the run's inputs (the same for every shard of one run).
    pub fingerprint: String,
    /// Units this shard owns.
    pub units: usize,
    /// Owned units that did not succeed, with the reason (merged as failed, not re-run).
    pub failed: Vec<String>,
}

/// Errors of shard bookkeeping.
#[derive(Debug, thiserror::Error)]
pub enum ShardError {
    /// Some shards have not finished.
    #[error(
        "{} of {count} shards have not finished ({} has no {}): rerun {} with --shard",
        missing.len(),
        dir.display(),
        missing.iter().map(|s| s.record_name()).collect::<Vec<_>>().join(", "),
        missing.iter().map(|s| s.to_string()).collect::<Vec<_>>().join(", ")
    )]
    Missing {
        /// The run's folder.
        dir: PathBuf,
        /// Number of shards.
        count: usize,
        /// The shards without a completion record.
        missing: Vec<Shard>,
    },
    /// A completion record is unreadable, or belongs to another run.
    #[error("{}: {problem}", path.display())]
    Record {
        /// The record.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
}

/// Writes `completion` into `dir` (atomically: a temporary file, then a rename).
pub fn write_completion(dir: &Path, completion: &Completion) -> Result<(), ShardError> {
    let shard = Shard {
        index: completion.index,
        count: completion.count,
    };
    let path = dir.join(shard.record_name());
    let problem = |e: String| ShardError::Record {
        path: path.clone(),
        problem: e,
    };
    let text = serde_json::to_string_pretty(completion).map_err(|e| problem(e.to_string()))?;
    std::fs::create_dir_all(dir)
        .and_then(|()| write_atomically(&path, (text + "\n").as_bytes()))
        .map_err(|e| problem(e.to_string()))
}

/// Writes `bytes` to `path` through a temporary file of this process and a rename, so that a
/// reader (another shard, a resumed run) sees the whole file or none of it, and shards
/// writing the same file at once do not mix their bytes.
pub(crate) fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(format!(".{}.tmp", std::process::id()));
    let tmp = PathBuf::from(tmp);
    std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path))
}

/// Reads the completion records of all `count` shards of a `kind` run in `dir`, in shard
/// order, and checks that each is for `fingerprint`; names the shards that are missing.
pub fn check_complete(
    dir: &Path,
    kind: &str,
    count: usize,
    fingerprint: &str,
) -> Result<Vec<Completion>, ShardError> {
    let mut records = Vec::with_capacity(count);
    let mut missing = Vec::new();
    for index in 0..count {
        let shard = Shard { index, count };
        let path = dir.join(shard.record_name());
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                missing.push(shard);
                continue;
            }
            Err(e) => {
                return Err(ShardError::Record {
                    path,
                    problem: e.to_string(),
                });
            }
        };
        let bad = |problem: String| ShardError::Record {
            path: path.clone(),
            problem,
        };
        let record: Completion =
            serde_json::from_str(&text).map_err(|e| bad(format!("not a shard record: {e}")))?;
        if record.kind != kind || record.index != index || record.count != count {
            return Err(bad(format!(
                "is the record of {} shard {}/{}, expected {kind} shard {shard}",
                record.kind, record.index, record.count
            )));
        }
        if record.fingerprint != fingerprint {
            return Err(bad(
                "was written for other inputs (a different config, tile, model or grid); \
                 rerun that shard with these inputs"
                    .into(),
            ));
        }
        records.push(record);
    }
    if !missing.is_empty() {
        return Err(ShardError::Missing {
            dir: dir.to_path_buf(),
            count,
            missing,
        });
    }
    Ok(records)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse_and_own_every_unit_once() {
        assert_eq!("2/4".parse::<Shard>().unwrap(), Shard::new(2, 4).unwrap());
        for bad in ["4/4", "1", "-1/4", "a/b", "0/0", "1/2/3"] {
            let e = bad.parse::<Shard>().unwrap_err();
            assert!(e.to_string().contains(bad), "{e}");
        }
        for count in 1..6 {
            for unit in 0..40 {
                let owners: Vec<usize> = (0..count)
                    .filter(|&k| Shard::new(k, count).unwrap().owns(unit))
                    .collect();
                assert_eq!(owners, vec![Shard::owner(unit, count).index]);
            }
        }
    }

    #[test]
    fn completion_is_checked_for_every_shard_and_the_inputs() {
        let dir = std::env::temp_dir().join(format!("shard-check-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let record = |index| Completion {
            kind: "database".into(),
            index,
            count: 3,
            fingerprint: "abc".into(),
            units: 2,
            failed: vec![],
        };
        write_completion(&dir, &record(0)).unwrap();
        write_completion(&dir, &record(2)).unwrap();
        let e = check_complete(&dir, "database", 3, "abc").unwrap_err();
        assert!(
            matches!(&e, ShardError::Missing { missing, .. } if missing == &[Shard::new(1, 3).unwrap()])
        );
        assert!(e.to_string().contains("shard-1-of-3.json"), "{e}");
        write_completion(&dir, &record(1)).unwrap();
        assert_eq!(check_complete(&dir, "database", 3, "abc").unwrap().len(), 3);
        let e = check_complete(&dir, "database", 3, "xyz").unwrap_err();
        assert!(e.to_string().contains("other inputs"), "{e}");
        std::fs::write(dir.join("shard-1-of-3.json"), "{ truncated").unwrap();
        let e = check_complete(&dir, "database", 3, "abc").unwrap_err();
        assert!(
            e.to_string().contains("shard-1-of-3.json")
                && e.to_string().contains("not a shard record"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
