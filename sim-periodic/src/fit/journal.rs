//! The evaluation journal that makes a fit resumable.
//!
//! Every objective evaluation is appended to a JSON-lines file as soon as it is done, keyed by
//! the phase and the exact bits of the normalized parameter point. The optimizers are
//! deterministic (seeded swarm, COBYLA), so a rerun after a kill replays the same sequence of
//! points and takes the value of every journaled one from the file, bit for bit: it loses no
//! finished evaluation and reaches the same result as an uninterrupted run. The first line
//! holds a fingerprint of the inputs; a journal written for other inputs is refused. A last
//! line cut short by the kill is dropped. Levenberg–Marquardt evaluations (residuals and
//! Jacobians) are not journaled: a run killed during it repeats them, with the same result.

use std::collections::HashMap;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use serde::{Deserialize, Serialize};

use super::FitError;

/// One journaled evaluation.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Line {
    /// Phase (`swarm`, `local`, `final`).
    phase: String,
    /// The normalized point, as the hexadecimal bits of each `f64`.
    x: Vec<String>,
    /// The objective value's bits, or `None` when the evaluation failed.
    value: Option<String>,
    /// The objective value, for reading (the bits are authoritative).
    g: Option<f64>,
    /// Why the evaluation failed.
    error: Option<String>,
}

#[derive(Serialize, Deserialize)]
struct Header {
    fingerprint: String,
}

type Key = (String, Vec<u64>);

/// A journal: the evaluations known so far and the file they are appended to.
pub struct Journal {
    path: Option<PathBuf>,
    file: Option<Mutex<File>>,
    known: Mutex<HashMap<Key, Result<f64, String>>>,
}

impl Journal {
    /// A journal that keeps evaluations in memory only.
    pub fn in_memory() -> Self {
        Self {
            path: None,
            file: None,
            known: Mutex::new(HashMap::new()),
        }
    }

    /// Opens (or creates) the journal at `path` for inputs with `fingerprint`.
    pub fn open(path: &Path, fingerprint: &str) -> Result<Self, FitError> {
        let bad = |line: usize, problem: String| FitError::Input {
            path: path.to_path_buf(),
            line,
            problem,
        };
        let mut known = HashMap::new();
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
            Err(e) => return Err(bad(0, e.to_string())),
        };
        // Only complete lines count: a kill may have cut the last one short.
        let complete = &text[..text.rfind('\n').map_or(0, |i| i + 1)];
        let mut lines = complete.lines().enumerate();
        match lines.next() {
            None => {}
            Some((_, first)) => {
                let header: Header = serde_json::from_str(first)
                    .map_err(|e| bad(1, format!("expected the fingerprint header line: {e}")))?;
                if header.fingerprint != fingerprint {
                    return Err(bad(
                        1,
                        "the journal was written for other inputs (targets, tile, model, \
                         bounds or settings); remove it or use the original inputs"
                            .into(),
                    ));
                }
            }
        }
        for (i, text) in lines {
            let line: Line = serde_json::from_str(text)
                .map_err(|e| bad(i + 1, format!("expected a journal entry: {e}")))?;
            let x = line
                .x
                .iter()
                .map(|h| u64::from_str_radix(h, 16))
                .collect::<Result<Vec<u64>, _>>()
                .map_err(|e| bad(i + 1, format!("a coordinate is not hexadecimal bits: {e}")))?;
            let value =
                match (&line.value, &line.error) {
                    (Some(bits), _) => Ok(f64::from_bits(u64::from_str_radix(bits, 16).map_err(
                        |e| bad(i + 1, format!("the value is not hexadecimal bits: {e}")),
                    )?)),
                    (None, Some(e)) => Err(e.clone()),
                    (None, None) => {
                        return Err(bad(i + 1, "an entry needs a value or an error".into()));
                    }
                };
            known.insert((line.phase, x), value);
        }
        // Rewrite the complete part (dropping a cut line), then append.
        if complete.len() != text.len() || complete.is_empty() {
            let mut content = complete.to_string();
            if content.is_empty() {
                content = serde_json::to_string(&Header {
                    fingerprint: fingerprint.to_string(),
                })
                .expect("header serializes")
                    + "\n";
            }
            std::fs::write(path, content).map_err(|e| bad(0, e.to_string()))?;
        }
        let file = OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(|e| bad(0, e.to_string()))?;
        Ok(Self {
            path: Some(path.to_path_buf()),
            file: Some(Mutex::new(file)),
            known: Mutex::new(known),
        })
    }

    /// Number of journaled evaluations.
    pub fn len(&self) -> usize {
        self.known.lock().expect("journal lock").len()
    }

    /// Whether nothing is journaled.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The journaled result of `phase` at `x`, if any.
    pub fn get(&self, phase: &str, x: &[f64]) -> Option<Result<f64, String>> {
        let key = (phase.to_string(), x.iter().map(|v| v.to_bits()).collect());
        self.known.lock().expect("journal lock").get(&key).cloned()
    }

    /// Records the result of `phase` at `x` (appended to the file at once).
    pub fn record(
        &self,
        phase: &str,
        x: &[f64],
        result: &Result<f64, String>,
    ) -> Result<(), FitError> {
        let bits: Vec<u64> = x.iter().map(|v| v.to_bits()).collect();
        if let Some(file) = &self.file {
            let line = Line {
                phase: phase.to_string(),
                x: bits.iter().map(|b| format!("{b:016x}")).collect(),
                value: result
                    .as_ref()
                    .ok()
                    .map(|v| format!("{:016x}", v.to_bits())),
                g: result.as_ref().ok().copied().filter(|v| v.is_finite()),
                error: result.as_ref().err().cloned(),
            };
            let mut text = serde_json::to_string(&line).expect("journal line serializes");
            text.push('\n');
            let mut file = file.lock().expect("journal file lock");
            file.write_all(text.as_bytes())
                .and_then(|()| file.flush())
                .map_err(|e| FitError::Input {
                    path: self.path.clone().unwrap_or_default(),
                    line: 0,
                    problem: e.to_string(),
                })?;
        }
        self.known
            .lock()
            .expect("journal lock")
            .insert((phase.to_string(), bits), result.clone());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn journal_round_trips_bits_drops_a_cut_line_and_refuses_other_inputs() {
        let dir = std::env::temp_dir().join(format!("journal-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("journal.jsonl");
        let _ = std::fs::remove_file(&path);
        let x = [0.1, 1.0 / 3.0];
        {
            let j = Journal::open(&path, "abc").unwrap();
            j.record("swarm", &x, &Ok(std::f64::consts::PI / 7.0))
                .unwrap();
            j.record("swarm", &[0.5, 0.5], &Err("no equilibrium".into()))
                .unwrap();
        }
        // A kill mid-write leaves a cut line.
        let mut f = OpenOptions::new().append(true).open(&path).unwrap();
        f.write_all(b"{\"phase\":\"swarm\",\"x\":[\"3f").unwrap();
        drop(f);
        let j = Journal::open(&path, "abc").unwrap();
        assert_eq!(j.len(), 2);
        assert_eq!(j.get("swarm", &x), Some(Ok(std::f64::consts::PI / 7.0)));
        assert_eq!(j.get("local", &x), None);
        assert_eq!(
            j.get("swarm", &[0.5, 0.5]),
            Some(Err("no equilibrium".to_string()))
        );
        drop(j);
        let e = Journal::open(&path, "other").err().unwrap().to_string();
        assert!(
            e.contains("journal.jsonl") && e.contains("other inputs"),
            "{e}"
        );
        std::fs::write(&path, "{\"fingerprint\":\"abc\"}\nnot json\n").unwrap();
        let e = Journal::open(&path, "abc").err().unwrap().to_string();
        assert!(e.contains("line 2"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
