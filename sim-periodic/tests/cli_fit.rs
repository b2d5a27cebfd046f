//! `sim-periodic fit`: a run killed mid-swarm resumes from its journal and ends with the same
//! result as an uninterrupted run; bad configs are refused with the file and the problem.

use std::process::{Command, Stdio};
use std::time::Duration;

mod common;
use common::known_weft_targets;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sim-periodic"))
}

fn scratch(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("sim-periodic-fit-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const CONFIG: &str = r#"
targets = "curves.csv"
pattern = "stockinette"
out = "OUT"

[parameters]
k1 = "paper"
bending = "paper"

[fit]
particles = 6
swarm_iterations = 3
swarm_samples = 3
local_samples = 3
local_evaluations = 8
compression_nodes = 2
"#;

fn journal_entries(path: &std::path::Path) -> usize {
    std::fs::read_to_string(path)
        .map(|t| t.lines().count().saturating_sub(1))
        .unwrap_or(0)
}

#[test]
fn a_fit_killed_mid_swarm_resumes_to_the_uninterrupted_result() {
    let dir = scratch("resume");
    std::fs::write(dir.join("curves.csv"), known_weft_targets().to_csv()).unwrap();
    for name in ["a", "b"] {
        std::fs::write(
            dir.join(format!("{name}.toml")),
            CONFIG.replace("OUT", &format!("out-{name}")),
        )
        .unwrap();
    }

    // Uninterrupted.
    let uninterrupted = bin().arg("fit").arg(dir.join("a.toml")).output().unwrap();
    assert!(uninterrupted.status.success());
    let swarm_total = 6 * (3 + 1);

    // Killed once a few swarm evaluations are journaled, then rerun.
    let journal = dir.join("out-b").join("journal.jsonl");
    let mut child = bin()
        .arg("fit")
        .arg(dir.join("b.toml"))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    while journal_entries(&journal) < 3 {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the fit finished before it could be killed"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let at_kill = journal_entries(&journal);
    eprintln!("killed with {at_kill} of {swarm_total} swarm evaluations journaled");
    assert!(at_kill < swarm_total, "killed after the swarm");
    let output = bin().arg("fit").arg(dir.join("b.toml")).output().unwrap();
    assert!(output.status.success());
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains(&format!("{at_kill} from the journal")),
        "{stdout}"
    );

    let read = |name: &str| -> serde_json::Value {
        serde_json::from_str(
            &std::fs::read_to_string(dir.join(format!("out-{name}")).join("fit.json")).unwrap(),
        )
        .unwrap()
    };
    let (a, b) = (read("a"), read("b"));
    for key in ["parameters", "objective", "comfort_error", "swarm_best"] {
        assert_eq!(a[key], b[key], "{key} differs after the resume");
    }
    // The comfort-range samples: those of the written curve with s > 0 in the comfort range,
    // and a warning where fewer than two.
    let curves = std::fs::read_to_string(dir.join("out-a").join("fitted-curves.csv")).unwrap();
    let counted = curves
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|f| f[0] == "weft" && f[1].parse::<f64>().unwrap() > 0.0 && f[6] == "true")
        .count();
    assert_eq!(
        a["comfort_samples"]["weft"], counted,
        "{}",
        a["comfort_samples"]
    );
    eprintln!("{counted} weft comfort-range samples");
    let stderr = String::from_utf8_lossy(&uninterrupted.stderr);
    assert_eq!(
        stderr.contains("warning: the weft comfort range"),
        counted < 2,
        "{counted} comfort-range samples: {stderr}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_fit_configs_are_refused_with_file_and_problem() {
    let dir = scratch("bad");
    std::fs::write(
        dir.join("curves.csv"),
        "kind,direction,x,c,sigma\nstretch,weft,0,0,0\nstretch,weft,0.2,0.05,40\n",
    )
    .unwrap();
    let run = |config: &str| {
        std::fs::write(dir.join("c.toml"), config).unwrap();
        let out = bin().arg("fit").arg(dir.join("c.toml")).output().unwrap();
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let e = run(
        "targets = \"curves.csv\"\nout = \"o\"\npattern = \"stockinette\"\n[fit]\nparticle = 3\n",
    );
    assert!(e.contains("c.toml:5:") && e.contains("particle"), "{e}");
    let e = run("targets = \"curves.csv\"\nout = \"o\"\npattern = \"chainmail\"\n");
    assert!(e.contains("chainmail") && e.contains("stockinette"), "{e}");
    let e = run("targets = \"curves.csv\"\nout = \"o\"\n");
    assert!(e.contains("exactly one of `tile`"), "{e}");
    let e = run(
        "targets = \"curves.csv\"\nout = \"o\"\npattern = \"garter\"\n[parameters]\nstiffness = \"paper\"\n",
    );
    assert!(
        e.contains("stiffness") && e.contains("contact_stiffness"),
        "{e}"
    );
    let e = run("targets = \"missing.csv\"\nout = \"o\"\npattern = \"garter\"\n");
    assert!(e.contains("missing.csv"), "{e}");
    let e = run("targets = \"curves.csv\"\nout = \"o\"\npattern = \"garter\"\nresolution = 5\n");
    assert!(
        e.contains("c.toml") && e.contains("garter") && e.contains("at least 8"),
        "{e}"
    );
    let e = run("targets = \"curves.csv\"\nout = \"o\"\ntile = \"t.pyp\"\nresolution = 16\n");
    assert!(e.contains("c.toml") && e.contains("`resolution`"), "{e}");
    let e = run(
        "targets = \"curves.csv\"\nout = \"o\"\npattern = \"garter\"\n[fit]\nsample_layout = \"dense\"\n",
    );
    assert!(
        e.contains("c.toml") && e.contains("\"dense\"") && e.contains("comfort-half"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
