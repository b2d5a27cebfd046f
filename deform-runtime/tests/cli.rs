//! The `deform-runtime run` binary on a two-frame OBJ sequence: outputs, manifest, errors.

mod common;

use std::fmt::Write as _;
use std::process::Command;

use common::*;
use deform_runtime::synthetic;

fn write_obj(
    path: &std::path::Path,
    mesh: &deform_runtime::obj::ObjMesh,
    positions: &[[f64; 3]],
    uvs: bool,
) {
    let mut s = String::new();
    for p in positions {
        writeln!(s, "v {} {} {}", p[0], p[1], p[2]).unwrap();
    }
    if uvs {
        for t in &mesh.uvs {
            writeln!(s, "vt {} {}", t[0], t[1]).unwrap();
        }
    }
    for (tp, tu) in mesh.tri_positions.iter().zip(&mesh.tri_uvs) {
        if uvs {
            writeln!(
                s,
                "f {}/{} {}/{} {}/{}",
                tp[0] + 1,
                tu[0] + 1,
                tp[1] + 1,
                tu[1] + 1,
                tp[2] + 1,
                tu[2] + 1
            )
            .unwrap();
        } else {
            writeln!(s, "f {} {} {}", tp[0] + 1, tp[1] + 1, tp[2] + 1).unwrap();
        }
    }
    std::fs::write(path, s).unwrap();
}

#[test]
fn run_writes_frames_and_manifest_and_reports_bad_meshes() {
    let tile = stockinette();
    let dir = std::env::temp_dir().join(format!("deform-runtime-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("anim")).unwrap();
    database(&tile).write(dir.join("db")).unwrap();
    let mesh = grid(&tile, 2.0, 3.0, 3);
    let rest = synthetic::map_uvs(&mesh, |uv| [uv[0], uv[1], 0.0]);
    let moved = synthetic::map_uvs(&mesh, synthetic::strain_map([0.2, 0.1, 0.0]));
    write_obj(&dir.join("anim/cloth_2.obj"), &mesh, &moved, true);
    write_obj(&dir.join("anim/cloth_10.obj"), &mesh, &moved, true);
    write_obj(&dir.join("anim/cloth_1.obj"), &mesh, &rest, true);
    let pattern = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/patterns/stockinette.pyp"
    );
    let out = dir.join("out");
    let status = Command::new(env!("CARGO_BIN_EXE_deform-runtime"))
        .args([
            "run",
            "--pattern",
            pattern,
            "--backend",
            "cpu",
            "--format",
            "obj",
            "--format",
            "bcc",
            "--format",
            "usd-cache",
            "--fps",
            "30",
            "--png",
            "--png-size",
            "160x120",
            "--png-view",
            "0.2,0.4,-1",
        ])
        .arg("--database")
        .arg(dir.join("db"))
        .arg("--mesh")
        .arg(dir.join("anim/cloth_*.obj"))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    for k in 1..=3 {
        assert!(out.join(format!("yarns_{k:06}.obj")).is_file());
        assert!(out.join(format!("yarns_{k:06}.bcc")).is_file());
    }
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    let frames = manifest["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 3);
    // Numeric order: cloth_1, cloth_2, cloth_10; the third frame repeats the second (static).
    assert!(
        frames[0]["input"]
            .as_str()
            .unwrap()
            .ends_with("cloth_1.obj")
    );
    assert!(
        frames[2]["input"]
            .as_str()
            .unwrap()
            .ends_with("cloth_10.obj")
    );
    assert_eq!(
        frames[2]["stats"]["static_frame"],
        serde_json::Value::Bool(true)
    );
    assert!(manifest["embedding"]["vertices"].as_u64().unwrap() > 100);
    // --format usd-cache: one USD cache of the three frames, which Pixar's USD loads.
    let cache = out.join("yarns.usda");
    assert_eq!(manifest["usd_cache"].as_str(), cache.to_str());
    let text = std::fs::read_to_string(&cache).unwrap();
    assert!(text.contains("timeCodesPerSecond = 30") && text.contains("endTimeCode = 2"));
    match yarn_output::usda::check_with_usd_if_available(&cache, 3, 0).unwrap() {
        Some(report) => assert_eq!(report.lines().count(), 3, "{report}"),
        None => eprintln!(
            "skipping the USD check of {}: no pxr module",
            cache.display()
        ),
    }
    // --png: one rendered PNG per frame, 160 × 120, with every yarn edge drawn.
    for (k, frame) in frames.iter().enumerate() {
        let png = std::fs::read(out.join(format!("frame_{:04}.png", k + 1))).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(&png[12..16], b"IHDR");
        assert_eq!(u32::from_be_bytes(png[16..20].try_into().unwrap()), 160);
        assert_eq!(u32::from_be_bytes(png[20..24].try_into().unwrap()), 120);
        assert!(frame["render"]["segments"].as_u64().unwrap() > 100);
        assert_eq!(frame["render"]["skipped_vertices"].as_u64(), Some(0));
    }
    assert_eq!(manifest["render"]["width"].as_u64(), Some(160));

    // A degenerate PNG camera is rejected before any frame is written.
    let status = Command::new(env!("CARGO_BIN_EXE_deform-runtime"))
        .args(["run", "--pattern", pattern, "--backend", "cpu", "--png"])
        .args(["--png-view", "0,1,0", "--png-up", "0,2,0"])
        .arg("--database")
        .arg(dir.join("db"))
        .arg("--mesh")
        .arg(dir.join("anim/cloth_*.obj"))
        .arg("--out")
        .arg(dir.join("out3"))
        .output()
        .unwrap();
    assert!(!status.status.success());
    let stderr = String::from_utf8_lossy(&status.stderr);
    assert!(
        stderr.contains("PNG options") && stderr.contains("camera"),
        "{stderr}"
    );
    assert!(!dir.join("out3").exists());

    // A mesh without UVs fails with the file and line.
    write_obj(&dir.join("nouv.obj"), &mesh, &rest, false);
    let status = Command::new(env!("CARGO_BIN_EXE_deform-runtime"))
        .args(["run", "--pattern", pattern, "--backend", "cpu"])
        .arg("--database")
        .arg(dir.join("db"))
        .arg("--mesh")
        .arg(dir.join("nouv.obj"))
        .arg("--out")
        .arg(dir.join("out2"))
        .output()
        .unwrap();
    assert!(!status.status.success());
    let stderr = String::from_utf8_lossy(&status.stderr);
    let first_face = rest.len() + 1;
    assert!(
        stderr.contains(&format!("nouv.obj:{first_face}:")),
        "{stderr}"
    );
    assert!(stderr.contains("texture coordinate"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}
