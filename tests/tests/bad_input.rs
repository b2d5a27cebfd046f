//! Bad input in every file a user hands to the workbench: empty files, NaN, infinities and
//! negative sizes give an error that names the file and, for line-based formats, the line;
//! never a panic and never a silent default.

use std::path::Path;

/// Asserts `result` is an error whose message names `file` and contains every one of
/// `expected`; returns the message.
fn refused<T: std::fmt::Debug, E: std::fmt::Display>(
    result: Result<T, E>,
    file: &str,
    expected: &[&str],
) -> String {
    let message = match result {
        Ok(v) => panic!("accepted bad input of {file}: {v:?}"),
        Err(e) => e.to_string(),
    };
    assert!(
        message.contains(file),
        "the error does not name {file}: {message}"
    );
    for e in expected {
        assert!(message.contains(e), "expected {e:?} in: {message}");
    }
    message
}

fn stockinette_pyp() -> String {
    std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/patterns/stockinette.pyp"
    ))
    .unwrap()
}

#[test]
fn pyp_tiles() {
    use yarn_pattern::pyp::parse_pyp;
    let good = stockinette_pyp();
    refused(parse_pyp("", "bad.pyp"), "bad.pyp", &[]);
    // The period and radius line (line 2), then a position (line 5).
    let line = |k: usize, to: &str| -> String {
        good.lines()
            .enumerate()
            .map(|(i, l)| {
                if i + 1 == k {
                    to.to_string()
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n")
    };
    refused(
        parse_pyp(&line(2, "0.0150513 0.00793099 -0.001 100"), "bad.pyp"),
        "bad.pyp",
        &["2"],
    );
    refused(
        parse_pyp(&line(2, "NaN 0.00793099 0.001 100"), "bad.pyp"),
        "bad.pyp",
        &["2"],
    );
    refused(
        parse_pyp(&line(5, "-0.0077 inf -0.0011948 0.158865"), "bad.pyp"),
        "bad.pyp",
        &["5"],
    );
    refused(
        parse_pyp(&line(5, "-0.0077 NaN -0.0011948 0.158865"), "bad.pyp"),
        "bad.pyp",
        &["5"],
    );
}

#[test]
fn scenes_and_charts() {
    use sim_persistent::scene::Scene;
    let path = Path::new("bad-scene.toml");
    let base = "steps = 10\n[pattern]\nbuilder = \"stockinette\"\nwidth = 4\nheight = 3\n";
    refused(Scene::parse("", path), "bad-scene.toml", &["steps"]);
    for (text, line) in [
        (format!("dt = nan\n{base}"), "1"),
        (format!("dt = inf\n{base}"), "1"),
        (format!("dt = -1e-3\n{base}"), "1"),
        (base.replace("width = 4", "width = -4"), "4"),
        (format!("{base}[yarn]\nradius = nan\n"), "7"),
        (format!("{base}[yarn]\nradius = -1e-3\n"), "7"),
        (format!("{base}[damping]\nalpha = inf\n"), "7"),
    ] {
        let e = Scene::parse(&text, path).and_then(|s| s.build().map(|_| s));
        refused(e, "bad-scene.toml", &[line]);
    }
    // A chart is text inside a scene or a file; an empty one is refused.
    assert!(sim_persistent::chart::Chart::parse("").is_err());
}

#[test]
fn sim_periodic_configs() {
    use sim_periodic::campaign::Campaign;
    use sim_periodic::config::{Config, FitConfig};
    let path = Path::new("bad-run.toml");
    refused(Config::parse("", path), "bad-run.toml", &["tile"]);
    let base = "tile = \"t.pyp\"\nout = \"o\"\n";
    for (text, key) in [
        (format!("{base}[model]\nk1 = nan\n"), "k1"),
        (format!("{base}[model]\nbending = -1e-6\n"), "bending"),
        (
            format!("{base}[model]\ncontact_stiffness = [inf, 1e6]\n"),
            "contact",
        ),
        (
            format!("{base}[database]\nsx = {{ min = 0.0, max = 1.0, n = 0 }}\n"),
            "sx",
        ),
        (format!("{base}[database]\nsa = [nan, 0.0]\n"), "sa"),
        (
            format!("{base}[solver]\ngradient_abs_tol = -1.0\n"),
            "gradient_abs_tol",
        ),
    ] {
        let checked = Config::parse(&text, path).and_then(|c| {
            c.model(1e-3, path)?;
            c.validate(path)?;
            Ok(c)
        });
        refused(checked, "bad-run.toml", &[key]);
    }
    let path = Path::new("bad-fit.toml");
    refused(FitConfig::parse("", path), "bad-fit.toml", &["targets"]);
    let base = "targets = \"c.csv\"\npattern = \"stockinette\"\nout = \"o\"\n";
    for (text, key) in [
        (format!("{base}[fit]\nparticles = 0\n"), "particles"),
        (
            format!("{base}[fit]\ncomfort_stress = nan\n"),
            "comfort_stress",
        ),
        (format!("{base}[fit]\nrestarts = 0\n"), "restarts"),
        (format!("{base}[fit]\ninertia = [nan, 0.1]\n"), "inertia"),
        (format!("{base}[model]\nk2 = inf\n"), "k2"),
    ] {
        let checked = FitConfig::parse(&text, path).and_then(|c| {
            c.model(1e-3, path)?;
            c.settings(path)?;
            Ok(c)
        });
        refused(checked, "bad-fit.toml", &[key]);
    }
    let path = Path::new("bad-campaign.toml");
    refused(Campaign::parse("", path), "bad-campaign.toml", &["out"]);
    refused(
        Campaign::parse("out = \"o\"\nfits = []\nseeds = [1]\n", path),
        "bad-campaign.toml",
        &["fits"],
    );
}

#[test]
fn measurement_and_target_csvs() {
    use shell_fem::measurements::{BinOptions, parse_direction_csv, parse_stitch_csv};
    refused(parse_direction_csv("", "bad.csv"), "bad.csv", &[]);
    let header = "direction,s,f_s,c\n";
    for (row, line) in [
        ("weft,nan,0.1,0.0", "2"),
        ("weft,0.1,inf,0.0", "2"),
        ("weft,0.1,0.2,NaN", "2"),
    ] {
        refused(
            parse_direction_csv(&format!("{header}{row}\n"), "bad.csv"),
            "bad.csv",
            &[line],
        );
    }
    let stitch = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/measurements/acrylic-yarn-garter-x.csv"
    ))
    .unwrap();
    let opts = BinOptions::default();
    let weft = yarn_pattern::direction::Direction::Weft;
    refused(
        parse_stitch_csv("", "bad-stitch.csv", weft, &opts),
        "bad-stitch.csv",
        &[],
    );
    let mut lines: Vec<String> = stitch.lines().map(str::to_string).collect();
    let k = lines.len() / 2;
    let mut fields: Vec<&str> = lines[k].split(',').collect();
    fields[3] = "nan"; // stress_n_per_mm (force_n is an optional, unread column)
    lines[k] = fields.join(",");
    let line = (k + 1).to_string();
    refused(
        parse_stitch_csv(&lines.join("\n"), "bad-stitch.csv", weft, &opts),
        "bad-stitch.csv",
        &[&line],
    );

    use shell_fem::bending_fit::parse_bending_csv;
    refused(
        parse_bending_csv("", "bad-bending.csv"),
        "bad-bending.csv",
        &[],
    );

    use sim_periodic::fit::Targets;
    let path = Path::new("bad-targets.csv");
    refused(Targets::parse("", path), "bad-targets.csv", &[]);
    let header = "kind,direction,x,c,sigma\n";
    for row in [
        "stretch,weft,nan,0,0",
        "stretch,weft,0.1,0,inf",
        "stretch,weft,0.1,-inf,1",
    ] {
        refused(
            Targets::parse(&format!("{header}stretch,weft,0,0,0\n{row}\n"), path),
            "bad-targets.csv",
            &["3"],
        );
    }
}

#[test]
fn madypg_tables_and_meshes() {
    use yarn_pattern::madypg::Database;
    let dir = Path::new("bad-db");
    let npy = {
        let header = "{'descr': '<f4', 'fortran_order': False, 'shape': (1, 4), }";
        let mut b = b"\x93NUMPY\x01\x00".to_vec();
        b.extend_from_slice(&(header.len() as u16).to_le_bytes());
        b.extend_from_slice(header.as_bytes());
        b.extend_from_slice(&[0u8; 16]);
        b
    };
    refused(Database::parse("", &npy, dir), "axes.txt", &[]);
    refused(Database::parse("0\n0\n0\n", &[], dir), "data.npy", &[]);
    for (axes, line) in [
        ("nan\n0\n0\n", "1"),
        ("0\ninf\n0\n", "2"),
        ("0\n0\n-inf\n", "3"),
    ] {
        refused(Database::parse(axes, &npy, dir), "axes.txt", &[line]);
    }
    let mut nan_data = npy.clone();
    let n = nan_data.len();
    nan_data[n - 4..].copy_from_slice(&f32::NAN.to_le_bytes());
    refused(
        Database::parse("0\n0\n0\n", &nan_data, dir),
        "data.npy",
        &[],
    );

    use yarn_output::obj_mesh::{Uv, parse_obj, parse_obj_positions};
    let path = Path::new("bad.obj");
    refused(parse_obj("", path, Uv::Ignored), "bad.obj", &[]);
    for (text, line) in [
        ("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "2"),
        ("v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n", "3"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -9\n", "4"),
    ] {
        refused(parse_obj(text, path, Uv::Ignored), "bad.obj", &[line]);
    }
    let mut out = Vec::new();
    refused(
        parse_obj_positions("v 0 0\n", path, &mut out),
        "bad.obj",
        &["1"],
    );
}
