//! `sim-persistent run --resume`, as a user would: a run killed with SIGKILL mid-way and
//! resumed writes the same frames as an uninterrupted run, byte for byte; a damaged
//! checkpoint, or one of another scene, is refused with the file and the problem.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::Duration;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sim-persistent"))
}

fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("resume-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A hanging stockinette under gravity with friction, yarn self-contact and a clamp that
/// moves: every kind of state a checkpoint carries.
const SCENE: &str = r#"
dt = 1e-3
steps = STEPS
output_every = 5

[pattern]
builder = "stockinette"
width = 6
height = 4

[yarn]
preset = "sweater"

[forces]
yarn_contact = true

[[clamp]]
edge = "bind-off"
velocity = [0.0, 0.02, 0.0]

[output]
formats = ["nodes"]
"#;

fn run(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    bin()
        .arg("run")
        .arg(scene)
        .arg("--out")
        .arg(out)
        .args(["--checkpoint-frames", "3"])
        .args(extra)
        .output()
        .unwrap()
}

fn frames(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .filter(|n| n.starts_with("frame_"))
        .map(|n| (n.clone(), std::fs::read(dir.join(&n)).unwrap()))
        .collect();
    files.sort();
    files
}

#[test]
fn a_killed_run_resumes_to_the_uninterrupted_frames() {
    let dir = scratch("kill");
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, SCENE.replace("STEPS", "240")).unwrap();
    let (whole, killed) = (dir.join("whole"), dir.join("killed"));
    let out = run(&scene, &whole, &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    // Killed once it has checkpointed and written a few frames past it, then resumed.
    let mut child = bin()
        .arg("run")
        .arg(&scene)
        .arg("--out")
        .arg(&killed)
        .args(["--checkpoint-frames", "3"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let ready =
        || killed.join("checkpoint.bin").exists() && killed.join("frame_00020.nodes.obj").exists();
    while !ready() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run finished before it could be killed"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let at_kill = frames(&killed).len();
    assert!(at_kill < 49, "killed after the last frame");
    let out = run(&scene, &killed, &["--resume"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("resuming after step"), "{stderr}");
    eprintln!("killed with {at_kill} frames written; {stderr}");
    let (a, b) = (frames(&whole), frames(&killed));
    assert_eq!(a.len(), 49);
    assert_eq!(a.len(), b.len());
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{name} differs after the resume");
    }

    // A damaged checkpoint is refused, never used.
    let checkpoint = killed.join("checkpoint.bin");
    let bytes = std::fs::read(&checkpoint).unwrap();
    let refused = |b: &[u8]| {
        std::fs::write(&checkpoint, b).unwrap();
        let out = run(&scene, &killed, &["--resume"]);
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let e = refused(&bytes[..bytes.len() / 2]);
    assert!(
        e.contains("checkpoint.bin") && e.contains("truncated"),
        "{e}"
    );
    let mut flipped = bytes.clone();
    flipped[100] ^= 0x10;
    let e = refused(&flipped);
    assert!(e.contains("checksum"), "{e}");
    // A checkpoint of another scene (here: more steps) is refused.
    std::fs::write(&checkpoint, &bytes).unwrap();
    std::fs::write(&scene, SCENE.replace("STEPS", "300")).unwrap();
    let out = run(&scene, &killed, &["--resume"]);
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && e.contains("another scene"), "{e}");
    // A run with a USD cache does not resume.
    std::fs::write(
        &scene,
        SCENE
            .replace("STEPS", "240")
            .replace("[\"nodes\"]", "[\"nodes\", \"usd_cache\"]"),
    )
    .unwrap();
    let usd = dir.join("usd");
    assert!(run(&scene, &usd, &[]).status.success());
    let out = run(&scene, &usd, &["--resume"]);
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && e.contains("USD cache"), "{e}");
}

/// The library level: a simulator restored from a snapshot steps exactly as the one it was
/// taken of, once that one's caches are flushed at the snapshot.
#[test]
fn a_restored_simulator_steps_as_the_original() {
    let dir = scratch("lib");
    let path = dir.join("scene.toml");
    std::fs::write(&path, SCENE.replace("STEPS", "40")).unwrap();
    let scene = sim_persistent::scene::Scene::read(&path).unwrap();
    let mut a = scene.build().unwrap();
    for _ in 0..20 {
        a.step().unwrap();
    }
    let c = a.checkpoint(20, 5, None);
    let mut b = scene.build().unwrap();
    b.resume(&c).unwrap();
    assert_eq!(b.sim.snapshot(), a.sim.snapshot());
    for k in 21..=25 {
        a.step().unwrap();
        b.step().unwrap();
        assert_eq!(a.sim.snapshot(), b.sim.snapshot(), "step {k}");
    }
}
