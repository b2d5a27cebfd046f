//! The `shell-fem` binary: `curves` writes finite target curves and a manifest; `fit` rejects a
//! malformed data file with file, line and problem.

use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_shell-fem"))
}

fn scratch(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("shell-fem-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn curves_subcommand_writes_csv_json_and_manifest() {
    let dir = scratch("curves");
    let params = dir.join("p.json");
    std::fs::write(
        &params,
        r#"{"kxx":300,"kxy":60,"kyy":900,"kss":150,"kn1":40,"kn2":20}"#,
    )
    .unwrap();
    let out = dir.join("out");
    let status = bin()
        .args([
            "curves",
            "--params",
            params.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--range",
            "weft=0.5",
            "--range",
            "warp=0.3",
            "--samples",
            "6",
        ])
        .status()
        .unwrap();
    assert!(status.success());
    let csv = std::fs::read_to_string(out.join("curves.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 2 * 6);
    assert!(!csv.to_lowercase().contains("nan"));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("curves.json")).unwrap()).unwrap();
    assert_eq!(v["stretch"]["warp"].as_array().unwrap().len(), 6);
    assert!(out.join("manifest.json").exists());
}

#[test]
fn fit_reports_file_line_and_problem_for_bad_data() {
    let dir = scratch("bad");
    let data = dir.join("d.csv");
    std::fs::write(
        &data,
        "direction,s,f_s,c\nweft,0.1,1.0,0.01\nweft,0.2,abc,0.02\n",
    )
    .unwrap();
    let output = bin()
        .args([
            "fit",
            "--data",
            data.to_str().unwrap(),
            "--out",
            dir.join("o").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(!output.status.success());
    let err = String::from_utf8_lossy(&output.stderr);
    assert!(
        err.contains("d.csv:3: `f_s`: `abc` is not a finite number"),
        "{err}"
    );
}

#[test]
fn fit_rejects_malformed_bending_data_before_fitting() {
    let dir = scratch("bad-bending");
    let data = dir.join("d.csv");
    std::fs::write(
        &data,
        "direction,s,f_s,c\nweft,0.1,1.0,0.01\nweft,0.2,2.0,0.02\n",
    )
    .unwrap();
    let bending = dir.join("b.csv");
    std::fs::write(&bending, "direction,d,r\nweft,0.034,1.2\nweft,0.02,-1\n").unwrap();
    let output = bin()
        .args([
            "fit",
            "--data",
            data.to_str().unwrap(),
            "--bending",
            bending.to_str().unwrap(),
            "--out",
            dir.join("o").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(!output.status.success());
    let err = String::from_utf8_lossy(&output.stderr);
    assert!(
        err.contains("b.csv:3: ratio r must be finite and > 0, got -1"),
        "{err}"
    );
    assert!(!dir.join("o").join("params.json").exists());
}
