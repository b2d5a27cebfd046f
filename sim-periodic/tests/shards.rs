//! Sharded runs (`--shard K/N`, `--merge N`) of `sim-periodic database` and `campaign`, as a
//! job array runs them: the merge equals a single-process run byte for byte, also after a
//! shard is killed mid-way (SIGKILL) and rerun; a merge with a shard missing names it.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::Duration;

use sim_periodic::database::{DatabaseSettings, generate, generate_shard, merge_shards};
use sim_periodic::periodic::YarnModel;
use sim_periodic::shard::Shard;

mod common;
use common::{small_fit_config, stockinette, write_sharding_campaign, write_sharding_database};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sim-periodic"))
}

fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("shards-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `sim-periodic <command> <config> <args>`.
fn sim(command: &str, config: &Path, args: &[&str]) -> Output {
    bin().arg(command).arg(config).args(args).output().unwrap()
}

/// The stderr of a run that must fail.
fn refused(out: Output) -> String {
    assert!(!out.status.success());
    String::from_utf8_lossy(&out.stderr).to_string()
}

fn ok(out: Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    String::from_utf8_lossy(&out.stdout).to_string()
}

fn count_files(dir: &Path, suffix: &str) -> usize {
    std::fs::read_dir(dir)
        .map(|d| {
            d.flatten()
                .filter(|e| e.file_name().to_string_lossy().ends_with(suffix))
                .count()
        })
        .unwrap_or(0)
}

/// Starts `args`, waits until `ready()` holds, then SIGKILLs it; asserts it was killed before
/// it finished.
fn kill_when(mut args: Command, ready: impl Fn() -> bool) {
    let mut child = args
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    while !ready() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run finished before it could be killed"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
}

/// The shards walk only the branches of the continuation tree that lead to their own lines,
/// and the merge equals the single run, also with samples no continuation reaches (a Newton
/// budget of 12 iterations without halving leaves four far samples unsolved; they are marked
/// by their shards and filled from their parents by the merge, as in the single run).
#[test]
fn merged_shards_equal_the_single_run_with_failed_samples() {
    let tile = stockinette();
    let model = YarnModel::default_for_radius(tile.radius);
    let axes = [
        vec![-0.1, 0.0, 0.1, 0.2],
        vec![-0.1, 0.0, 0.1],
        vec![-0.05, 0.0, 0.1],
    ];
    for (name, settings) in [
        ("plain", DatabaseSettings::default()),
        ("failing", {
            let mut s = DatabaseSettings {
                max_bisections: 0,
                fill_unsolved: true,
                ..DatabaseSettings::default()
            };
            s.equilibrium.newton.max_iterations = 12;
            s
        }),
    ] {
        let single = generate(&tile, &model, axes.clone(), &settings, None, &|_| {}).unwrap();
        let unsolved = single.samples.iter().filter(|s| !s.solved).count();
        eprintln!("{name}: {unsolved} of 36 samples unsolved in the single run");
        let dir = scratch(&format!("lib-{name}"));
        let mut failed = 0;
        for k in 0..3 {
            let shard = Shard::new(k, 3).unwrap();
            let report =
                generate_shard(&tile, &model, axes.clone(), &settings, &dir, shard, &|_| {})
                    .unwrap();
            // The 12 (sx, sy) lines are dealt round robin: 4 per shard, 3 samples each.
            assert_eq!(report.completion.units, 4);
            assert_eq!(report.samples.len(), 12);
            failed += report.completion.failed.len();
            if k == 1 {
                let e = merge_shards(&tile, &model, axes.clone(), &settings, &dir, 3, &|_| {})
                    .unwrap_err();
                assert!(e.to_string().contains("shard-2-of-3.json"), "{e}");
            }
        }
        let merged =
            merge_shards(&tile, &model, axes.clone(), &settings, &dir, 3, &|_| {}).unwrap();
        assert_eq!(merged.database, single.database, "{name}");
        let flags = |g: &sim_periodic::database::Generated| -> Vec<bool> {
            g.samples.iter().map(|s| s.solved).collect()
        };
        assert_eq!(flags(&merged), flags(&single), "{name}");
        eprintln!("{name}: {failed} samples failed their lines in the shards");
        if name == "failing" {
            assert!(unsolved > 0 && failed >= unsolved, "{failed} {unsolved}");
        } else {
            assert_eq!(failed, 0);
        }
        // A merge for a different number of shards names every missing record.
        let e = merge_shards(&tile, &model, axes.clone(), &settings, &dir, 2, &|_| {}).unwrap_err();
        assert!(
            e.to_string()
                .contains("shard-0-of-2.json, shard-1-of-2.json"),
            "{e}"
        );
    }
}

#[test]
fn a_database_shard_killed_mid_way_reruns_to_the_single_run_bytes() {
    let dir = scratch("database");
    write_sharding_database(&dir);
    ok(bin()
        .arg("database")
        .arg(dir.join("single.toml"))
        .output()
        .unwrap());

    // The plain (unsharded) run killed mid-way and rerun gives the same bytes too.
    let single = std::fs::read_to_string(dir.join("single.toml")).unwrap();
    let killed = dir.join("killed.toml");
    std::fs::write(&killed, single.replace("\"single\"", "\"killed\"")).unwrap();
    let killed_checkpoint = dir.join("killed").join("checkpoint");
    let mut run = bin();
    run.arg("database").arg(&killed);
    kill_when(run, || count_files(&killed_checkpoint, ".bin") >= 10);
    let out = ok(sim("database", &killed, &[]));
    assert!(!out.contains("(0 resumed)"), "{out}");
    for file in ["database/axes.txt", "database/data.npy"] {
        let a = std::fs::read(dir.join("single").join(file)).unwrap();
        let b = std::fs::read(dir.join("killed").join(file)).unwrap();
        assert!(a == b, "{file} differs after the kill and rerun");
    }

    let sharded = dir.join("sharded.toml");
    let checkpoint = dir.join("sharded").join("checkpoint");
    // Shard 1 of 3 is killed once it has checkpointed a few samples, then rerun.
    let mut shard = bin();
    shard.arg("database").arg(&sharded).args(["--shard", "1/3"]);
    kill_when(shard, || count_files(&checkpoint, ".bin") >= 4);
    let at_kill = count_files(&checkpoint, ".bin");
    assert!(!checkpoint.join("shard-1-of-3.json").exists());
    let stderr = refused(sim("database", &sharded, &["--merge", "3"]));
    assert!(
        stderr.contains("3 of 3 shards have not finished"),
        "{stderr}"
    );
    for k in [0, 2, 1] {
        let out = ok(sim("database", &sharded, &["--shard", &format!("{k}/3")]));
        assert!(
            out.contains(&format!("shard {k}/3: 5 sa lines, 25 samples")),
            "{out}"
        );
        if k == 1 {
            eprintln!("killed with {at_kill} samples checkpointed; rerun: {out}");
            assert!(!out.contains("(0 resumed"), "the rerun resumed: {out}");
        }
    }
    let out = ok(sim("database", &sharded, &["--merge", "3"]));
    assert!(out.contains("75 samples (75 resumed)"), "{out}");
    for file in ["database/axes.txt", "database/data.npy", "pattern.pyp"] {
        let a = std::fs::read(dir.join("single").join(file)).unwrap();
        let b = std::fs::read(dir.join("sharded").join(file)).unwrap();
        assert!(
            a == b,
            "{file} differs between the single and the merged run"
        );
    }
    // Bad shard options are refused before any work.
    for (args, expected) in [
        (vec!["--shard", "3/3"], "expected K/N"),
        (vec!["--merge", "0"], "--merge"),
        (
            vec!["--shard", "0/2", "--merge", "2"],
            "cannot be used with",
        ),
    ] {
        let out = bin()
            .arg("database")
            .arg(&sharded)
            .args(&args)
            .output()
            .unwrap();
        assert!(!out.status.success());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
    }
}

#[test]
fn a_campaign_in_shards_merges_to_the_single_run_table() {
    let dir = scratch("campaign");
    write_sharding_campaign(&dir);
    let out = ok(bin()
        .arg("campaign")
        .arg(dir.join("single.toml"))
        .output()
        .unwrap());
    assert!(out.contains("4 tasks (0 failed)"), "{out}");
    assert!(
        out.contains("garter") && out.contains("over 2 seeds"),
        "{out}"
    );

    let sharded = dir.join("sharded.toml");
    // Shard 0 of 3 (tasks 0 and 3) is killed in its first fit, then rerun.
    let journal = dir.join("sharded/stockinette/seed-1/journal.jsonl");
    let mut shard = bin();
    shard.arg("campaign").arg(&sharded).args(["--shard", "0/3"]);
    kill_when(shard, || {
        std::fs::read_to_string(&journal).is_ok_and(|t| t.lines().count() > 2)
    });
    for k in [1, 2, 0] {
        let out = ok(sim("campaign", &sharded, &["--shard", &format!("{k}/3")]));
        let tasks = if k == 0 { 2 } else { 1 };
        assert!(
            out.contains(&format!("shard {k}/3: {tasks} tasks (0 failed)")),
            "{out}"
        );
    }
    let out = ok(sim("campaign", &sharded, &["--merge", "3"]));
    assert!(out.contains("4 tasks (0 failed)"), "{out}");
    let table = |name: &str| std::fs::read_to_string(dir.join(name).join("campaign.csv")).unwrap();
    assert_eq!(table("single"), table("sharded"));
    assert_eq!(table("single").lines().count(), 5);
    eprintln!("{}", table("single"));

    // Changed inputs invalidate the shards' records.
    std::fs::write(
        dir.join("garter.toml"),
        small_fit_config("garter") + "seed = 7\n",
    )
    .unwrap();
    let stderr = refused(sim("campaign", &sharded, &["--merge", "3"]));
    assert!(stderr.contains("other inputs"), "{stderr}");
}
