//! The Slurm workflow of `scripts/slurm/` on a real cluster: a 4-task job array for a small
//! database and for a small fit campaign, each with its dependent merge, equal byte for byte
//! to the single-process run; a shard cancelled mid-way makes the merge name it, and rerun
//! alone it completes the same merge.
//!
//! Needs a Slurm cluster that answers `sinfo` (CI starts a one-node one with
//! `scripts/slurm/local-cluster up`); without one the test says so and passes, unless
//! `WORKBENCH_REQUIRE_SLURM` is set, as in CI, where it fails.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

mod common;
use common::{write_sharding_campaign, write_sharding_database};

const BIN: &str = env!("CARGO_BIN_EXE_sim-periodic");

fn scripts() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/slurm")
}

/// Whether a Slurm cluster answers; panics when one is required and none does.
fn slurm_available() -> bool {
    let up = Command::new("sinfo")
        .args(["-h", "-o", "%t"])
        .output()
        .is_ok_and(|o| o.status.success() && !o.stdout.is_empty());
    if !up {
        assert!(
            std::env::var_os("WORKBENCH_REQUIRE_SLURM").is_none(),
            "WORKBENCH_REQUIRE_SLURM is set but no Slurm cluster answers `sinfo` \
             (scripts/slurm/local-cluster up starts a local one)"
        );
        eprintln!("no Slurm cluster answers `sinfo`: the Slurm workflow was NOT tested");
    }
    up
}

fn ok(out: Output) -> String {
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).to_string()
}

/// `sbatch --parsable ARGS` in `dir`: the job id.
fn sbatch(dir: &Path, args: &[&str]) -> String {
    let out = ok(Command::new("sbatch")
        .current_dir(dir)
        .arg("--parsable")
        .args(args)
        .output()
        .unwrap());
    out.trim().split(';').next().unwrap().to_string()
}

/// `scripts/slurm/submit N COMMAND...` in `dir`: the array and merge job ids.
fn submit(dir: &Path, n: usize, command: &[&str]) -> (String, String) {
    let out = ok(Command::new(scripts().join("submit"))
        .current_dir(dir)
        .arg(n.to_string())
        .args(command)
        .output()
        .unwrap());
    let ids: Vec<&str> = out.lines().last().unwrap().split_whitespace().collect();
    (ids[0].to_string(), ids[1].to_string())
}

/// Waits until none of `jobs` (ids, array tasks included) is queued or running.
fn wait(jobs: &[&str]) {
    let start = Instant::now();
    loop {
        let out = Command::new("squeue")
            .args(["-h", "-o", "%i", "-j", &jobs.join(",")])
            .output()
            .unwrap();
        if String::from_utf8_lossy(&out.stdout).trim().is_empty() {
            return;
        }
        assert!(
            start.elapsed() < Duration::from_secs(240),
            "Slurm jobs {jobs:?} still queued after 240 s"
        );
        std::thread::sleep(Duration::from_millis(500));
    }
}

/// The output file of merge job `id` in `dir`.
fn merge_log(dir: &Path, id: &str) -> String {
    std::fs::read_to_string(dir.join(format!("slurm-workbench-merge-{id}.out"))).unwrap()
}

fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("slurm-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn job_arrays_merge_to_the_single_process_results() {
    if !slurm_available() {
        return;
    }

    // A database: 4 shards and their merge.
    let dir = scratch("database");
    write_sharding_database(&dir);
    ok(Command::new(BIN)
        .current_dir(&dir)
        .args(["database", "single.toml"])
        .output()
        .unwrap());
    let (array, merge) = submit(&dir, 4, &[BIN, "database", "sharded.toml"]);
    wait(&[&array, &merge]);
    let log = merge_log(&dir, &merge);
    assert!(log.contains("75 samples (75 resumed)"), "{log}");
    for file in ["database/axes.txt", "database/data.npy", "pattern.pyp"] {
        let a = std::fs::read(dir.join("single").join(file)).unwrap();
        let b = std::fs::read(dir.join("sharded").join(file)).unwrap();
        assert!(
            a == b,
            "{file}: the merged database differs from the single run"
        );
    }
    for k in 0..4 {
        assert!(
            dir.join(format!("sharded/checkpoint/shard-{k}-of-4.json"))
                .is_file()
        );
    }

    // A fit campaign, 2 fits × 2 seeds: shard 3 is cancelled, the merge names it; rerun alone,
    // the merge completes with the single-process table.
    let dir = scratch("campaign");
    write_sharding_campaign(&dir);
    ok(Command::new(BIN)
        .current_dir(&dir)
        .args(["campaign", "single.toml"])
        .output()
        .unwrap());
    let command = [BIN, "campaign", "sharded.toml"];
    let (array, merge) = submit(&dir, 4, &command);
    ok(Command::new("scancel")
        .arg(format!("{array}_3"))
        .output()
        .unwrap());
    wait(&[&array, &merge]);
    let log = merge_log(&dir, &merge);
    assert!(
        log.contains("1 of 4 shards have not finished") && log.contains("shard-3-of-4.json"),
        "{log}"
    );
    let shard = scripts().join("shard.sbatch");
    let merge_script = scripts().join("merge.sbatch");
    let mut args = vec!["--array=3", shard.to_str().unwrap(), "4"];
    args.extend(command);
    let rerun = sbatch(&dir, &args);
    let dependency = format!("--dependency=afterok:{rerun}");
    let mut args = vec![dependency.as_str(), merge_script.to_str().unwrap(), "4"];
    args.extend(command);
    let merge = sbatch(&dir, &args);
    wait(&[&rerun, &merge]);
    let log = merge_log(&dir, &merge);
    assert!(log.contains("4 tasks (0 failed)"), "{log}");
    let table = |name: &str| std::fs::read(dir.join(name).join("campaign.csv")).unwrap();
    assert!(
        table("single") == table("sharded"),
        "the merged campaign table differs from the single run"
    );
}
