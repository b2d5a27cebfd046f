//! Reading uniaxial stretch measurements (formats in the project's format notes).
//!
//! Two schemas:
//!
//! 1. **Stitch-by-stitch CSV** (real data): optional `#` comment lines (the shared files note
//!    the specimen width at the clamp there; it is not read), a header naming at least
//!    `axial_strain`, `transverse_strain` and `stress_n_per_mm` (force per unit clamp width),
//!    optionally `video,frame,force_n` (the force is checked, not used). Several repeated
//!    loading runs (`video`) are merged: from each run only the **loading branch** is kept
//!    (rows up to the run's largest axial strain), then all points are **binned** over axial
//!    strain (equal-width bins over the range covered by every run) and averaged per bin.
//!    Stretch `s` = axial strain; compression `c = −transverse_strain`; force
//!    `f_s = stress × w̄` with `w̄` the virtual swatch width (the data's specimens are not
//!    6 cm wide, so force per unit width is what carries over).
//! 2. **Per-direction schema** (seed-002 style): header `direction,s,f_s,c` with
//!    `direction ∈ {weft, bias, warp}` (or `x`/`y`, `0`/`45`/`90`), force in N for the standard
//!    6 cm swatch.
//!
//! Every error names the file, the line and the problem.

use std::collections::BTreeMap;
use std::path::Path;
use yarn_pattern::direction::Direction;

use serde::{Deserialize, Serialize};

use crate::ShellError;
use crate::csv_io::{Record, records};

/// One measured (or binned) point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeasuredPoint {
    /// Stretch `s`.
    pub s: f64,
    /// Stretch force `f_s` (N) for the virtual swatch width.
    pub force: f64,
    /// Orthogonal compression `c`.
    pub compression: f64,
}

/// A measured force/compression–stretch curve for one direction, increasing in `s`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Measurement {
    /// Test direction.
    pub direction: Direction,
    /// Points, strictly increasing in `s`.
    pub points: Vec<MeasuredPoint>,
    /// Where the data came from.
    pub source: String,
}

impl Measurement {
    /// Largest measured stretch.
    pub fn s_max(&self) -> f64 {
        self.points.last().map_or(0.0, |p| p.s)
    }

    /// Linear interpolation of force and compression at `s` (clamped to the measured range);
    /// NaN values for an empty curve (which the readers never produce).
    pub fn interpolate(&self, s: f64) -> MeasuredPoint {
        let p = &self.points;
        if p.is_empty() {
            return MeasuredPoint {
                s,
                force: f64::NAN,
                compression: f64::NAN,
            };
        }
        if s <= p[0].s {
            return MeasuredPoint { s, ..p[0] };
        }
        for w in p.windows(2) {
            if s <= w[1].s {
                let t = (s - w[0].s) / (w[1].s - w[0].s);
                return MeasuredPoint {
                    s,
                    force: w[0].force + t * (w[1].force - w[0].force),
                    compression: w[0].compression + t * (w[1].compression - w[0].compression),
                };
            }
        }
        MeasuredPoint {
            s,
            ..*p.last().expect("non-empty")
        }
    }
}

/// Options of the stitch-by-stitch reader.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BinOptions {
    /// Number of equal-width strain bins. Default 24.
    pub bins: usize,
    /// Width of the virtual swatch the force is scaled to (m). Default 0.06.
    pub swatch_width: f64,
}

impl Default for BinOptions {
    fn default() -> Self {
        Self {
            bins: 24,
            swatch_width: 0.06,
        }
    }
}

fn data_err(file: &str, line: usize, problem: impl Into<String>) -> ShellError {
    ShellError::Data {
        file: file.into(),
        line,
        problem: problem.into(),
    }
}

fn read(path: &Path) -> Result<String, ShellError> {
    std::fs::read_to_string(path).map_err(|source| ShellError::Io {
        file: path.display().to_string(),
        source,
    })
}

/// Stitch-pattern words that may carry a direction letter glued to their end
/// (`babyredo_gartery`, `babyredo_stockxnew`): only after one of these is a trailing `x`/`y`
/// read as a direction, so that names such as `jersey` are not misread.
pub const PATTERN_WORDS: [&str; 16] = [
    "garter",
    "rib",
    "seed",
    "moss",
    "stock",
    "stockinette",
    "jersey",
    "purl",
    "interlock",
    "links",
    "pique",
    "cable",
    "lace",
    "knit",
    "weave",
    "twill",
];

/// Reads a test direction from one name token: `x`/`course`/`weft`/`0` → weft,
/// `y`/`wale`/`warp`/`90` → warp, `bias`/`45` → bias, or a [`PATTERN_WORDS`] word followed by
/// `x`/`y`.
fn direction_token(token: &str) -> Option<Direction> {
    match token {
        "course" | "courses" => return Some(Direction::Weft),
        "wale" | "wales" => return Some(Direction::Warp),
        _ => {}
    }
    if let Some(d) = Direction::parse(token) {
        return Some(d);
    }
    let (word, letter) = token.split_at(token.len().checked_sub(1)?);
    if PATTERN_WORDS.contains(&word) {
        return Direction::parse(letter);
    }
    None
}

/// Canonical spellings of pattern words (`stock` → `stockinette`), so that the two files of
/// one fabric (`babyredo_stockxnew`, `babyredo_stockinettey`) get one fabric name.
const PATTERN_ALIASES: [(&str, &str); 2] = [("stock", "stockinette"), ("moss", "seed")];

/// Splits a measurement file name into its fabric name and test direction. The stem is split
/// at `-`, `_`, `.` and spaces; trailing version words (`new`, `old`, `v2`, digits) are
/// dropped, also when glued to the end of the last token (`garterxnew`); then the last token
/// names the direction (`direction_token`: `…-x`, `…_y`, `…-weft`, `…_course`, `…_gartery`,
/// `…_stockxnew`). The fabric name is the remaining tokens joined by `-`, pattern words in
/// their canonical spelling (`babyredo_stockxnew` → `babyredo-stockinette`, weft). `None` when
/// the last token names no direction.
pub fn split_name(path: &Path) -> Option<(String, Direction)> {
    let stem = path.file_stem()?.to_str()?.to_ascii_lowercase();
    let is_version = |t: &str| {
        matches!(t, "new" | "old" | "final" | "raw")
            || t.chars().all(|c| c.is_ascii_digit())
            || (t.len() > 1 && t.starts_with('v') && t[1..].chars().all(|c| c.is_ascii_digit()))
    };
    let mut tokens: Vec<&str> = stem
        .split(['-', '_', '.', ' '])
        .filter(|t| !t.is_empty())
        .collect();
    while tokens.len() > 1 && tokens.last().is_some_and(|t| is_version(t)) {
        tokens.pop();
    }
    let last = tokens.pop()?;
    let trimmed = ["new", "old"]
        .iter()
        .find_map(|v| last.strip_suffix(v).filter(|t| !t.is_empty()))
        .unwrap_or(last);
    let direction = direction_token(trimmed)?;
    let mut name: Vec<&str> = tokens;
    if Direction::parse(trimmed).is_none()
        && !matches!(trimmed, "course" | "courses" | "wale" | "wales")
    {
        // A pattern word with the direction letter glued on.
        name.push(&trimmed[..trimmed.len() - 1]);
    }
    let name: Vec<&str> = name
        .into_iter()
        .map(|t| {
            PATTERN_ALIASES
                .iter()
                .find(|(alias, _)| *alias == t)
                .map_or(t, |(_, canonical)| canonical)
        })
        .collect();
    Some((name.join("-"), direction))
}

/// Guesses the direction of a stitch-by-stitch file from its name: [`split_name`], or else a
/// name containing `weft`, `bias` or `warp` anywhere. `None` when nothing matches (the caller
/// asks for `DIR=path`).
pub fn direction_from_name(path: &Path) -> Option<Direction> {
    if let Some((_, d)) = split_name(path) {
        return Some(d);
    }
    let stem = path.file_stem()?.to_str()?.to_ascii_lowercase();
    Direction::ALL.into_iter().find(|d| stem.contains(d.name()))
}

/// Whether a file uses the stitch-by-stitch schema (its header names `axial_strain`) rather
/// than the per-direction one.
pub fn is_stitch_csv(path: &Path) -> Result<bool, ShellError> {
    let records = records(&read(path)?, &path.display().to_string())?;
    Ok(records.first().is_some_and(|h| {
        h.fields
            .iter()
            .any(|f| f.eq_ignore_ascii_case("axial_strain"))
    }))
}

/// Reads a stitch-by-stitch CSV file (see the module docs).
pub fn read_stitch_csv(
    path: &Path,
    direction: Direction,
    opts: &BinOptions,
) -> Result<Measurement, ShellError> {
    parse_stitch_csv(&read(path)?, &path.display().to_string(), direction, opts)
}

/// Parses stitch-by-stitch CSV text; `file` names the source in errors.
pub fn parse_stitch_csv(
    text: &str,
    file: &str,
    direction: Direction,
    opts: &BinOptions,
) -> Result<Measurement, ShellError> {
    if opts.bins < 2 || opts.swatch_width.is_nan() || opts.swatch_width <= 0.0 {
        return Err(ShellError::InvalidInput(
            "need ≥ 2 bins and a positive swatch width".into(),
        ));
    }
    let records = records(text, file)?;
    let Some((head, rows)) = records.split_first() else {
        return Err(data_err(file, 0, "no header line"));
    };
    let cols: Vec<String> = head.fields.iter().map(|f| f.to_ascii_lowercase()).collect();
    let find = |name: &str| cols.iter().position(|c| c == name);
    let need = |name: &str| {
        find(name).ok_or_else(|| {
            data_err(
                file,
                head.line,
                format!("header lacks column `{name}` (found {cols:?})"),
            )
        })
    };
    let (i_ax, i_tr, i_st) = (
        need("axial_strain")?,
        need("transverse_strain")?,
        need("stress_n_per_mm")?,
    );
    let i_run = find("video");
    // The clamp force is checked (a finite number) but not used: the stress column carries
    // the force per unit width, which is what carries over to the virtual swatch.
    let i_force = find("force_n");
    // Runs in order of first appearance: name → (axial, transverse, stress).
    let mut runs: Vec<(String, Vec<[f64; 3]>)> = Vec::new();
    for Record { line, fields } in rows {
        if fields.len() != cols.len() {
            return Err(data_err(
                file,
                *line,
                format!("expected {} fields, found {}", cols.len(), fields.len()),
            ));
        }
        let num = |i: usize| -> Result<f64, ShellError> {
            let v: f64 = fields[i].parse().map_err(|_| {
                data_err(
                    file,
                    *line,
                    format!("column `{}`: `{}` is not a number", cols[i], fields[i]),
                )
            })?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(data_err(
                    file,
                    *line,
                    format!("column `{}` is not finite", cols[i]),
                ))
            }
        };
        let row = [num(i_ax)?, num(i_tr)?, num(i_st)?];
        if let Some(i) = i_force {
            num(i)?;
        }
        let run = i_run.map_or("", |i| fields[i].as_str()).to_owned();
        match runs.iter_mut().find(|(r, _)| *r == run) {
            Some((_, rows)) => rows.push(row),
            None => runs.push((run, vec![row])),
        }
    }
    if runs.is_empty() {
        return Err(data_err(file, 0, "no data rows"));
    }
    // Loading branch of each run: rows up to its largest axial strain.
    let mut merged = Vec::new();
    let mut common_max = f64::INFINITY;
    for (name, rows) in &runs {
        let (imax, smax) = rows
            .iter()
            .enumerate()
            .fold((0, f64::NEG_INFINITY), |m, (i, r)| {
                if r[0] > m.1 { (i, r[0]) } else { m }
            });
        if smax.is_nan() || smax <= 0.0 {
            return Err(data_err(
                file,
                0,
                format!("run `{name}` never stretches (max axial strain {smax})"),
            ));
        }
        common_max = common_max.min(smax);
        merged.extend_from_slice(&rows[..=imax]);
    }
    let n = opts.bins;
    let width = common_max / n as f64;
    let mut acc = vec![[0.0f64; 4]; n];
    for r in &merged {
        if r[0] < 0.0 || r[0] > common_max {
            continue;
        }
        let b = ((r[0] / width) as usize).min(n - 1);
        acc[b][0] += r[0];
        acc[b][1] += -r[1];
        acc[b][2] += r[2];
        acc[b][3] += 1.0;
    }
    let force_scale = 1e3 * opts.swatch_width; // N/mm → N over the swatch width
    let points: Vec<MeasuredPoint> = acc
        .iter()
        .filter(|a| a[3] > 0.0)
        .map(|a| MeasuredPoint {
            s: a[0] / a[3],
            compression: a[1] / a[3],
            force: a[2] / a[3] * force_scale,
        })
        .collect();
    if points.len() < 2 {
        return Err(data_err(file, 0, "fewer than two non-empty strain bins"));
    }
    Ok(Measurement {
        direction,
        points,
        source: file.into(),
    })
}

/// Reads a per-direction `direction,s,f_s,c` file; directions absent from the file are
/// simply absent from the result.
pub fn read_direction_csv(path: &Path) -> Result<Vec<Measurement>, ShellError> {
    parse_direction_csv(&read(path)?, &path.display().to_string())
}

/// Parses per-direction CSV text; `file` names the source in errors.
pub fn parse_direction_csv(text: &str, file: &str) -> Result<Vec<Measurement>, ShellError> {
    let records = records(text, file)?;
    let Some((head, rows)) = records.split_first() else {
        return Err(data_err(file, 0, "no header line"));
    };
    let lower: Vec<String> = head.fields.iter().map(|x| x.to_ascii_lowercase()).collect();
    if lower != ["direction", "s", "f_s", "c"] {
        return Err(data_err(
            file,
            head.line,
            format!(
                "expected header `direction,s,f_s,c`, found `{}`",
                head.fields.join(",")
            ),
        ));
    }
    let mut by_dir: BTreeMap<Direction, Vec<(usize, MeasuredPoint)>> = BTreeMap::new();
    for Record { line, fields: f } in rows {
        let line_no = *line;
        if f.len() != 4 {
            return Err(data_err(
                file,
                line_no,
                format!("expected 4 fields, found {}", f.len()),
            ));
        }
        let dir = Direction::parse(&f[0]).ok_or_else(|| {
            data_err(
                file,
                line_no,
                format!("unknown direction `{}` (weft, bias, warp)", f[0]),
            )
        })?;
        let mut v = [0.0; 3];
        for (j, name) in ["s", "f_s", "c"].iter().enumerate() {
            v[j] = f[j + 1]
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    data_err(
                        file,
                        line_no,
                        format!("`{name}`: `{}` is not a finite number", f[j + 1]),
                    )
                })?;
        }
        by_dir.entry(dir).or_default().push((
            line_no,
            MeasuredPoint {
                s: v[0],
                force: v[1],
                compression: v[2],
            },
        ));
    }
    let mut out = Vec::new();
    for (direction, pts) in by_dir {
        for w in pts.windows(2) {
            if w[1].1.s <= w[0].1.s {
                return Err(data_err(
                    file,
                    w[1].0,
                    format!(
                        "{} stretch must increase: {} after {}",
                        direction.name(),
                        w[1].1.s,
                        w[0].1.s
                    ),
                ));
            }
        }
        if pts.len() < 2 {
            return Err(data_err(
                file,
                pts[0].0,
                format!("{} has a single point", direction.name()),
            ));
        }
        out.push(Measurement {
            direction,
            points: pts.into_iter().map(|(_, p)| p).collect(),
            source: file.into(),
        });
    }
    if out.is_empty() {
        return Err(data_err(file, 0, "no data rows"));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    const STITCH: &str = "# test; width at clamp 50 mm\n\
        video,frame,force_n,stress_n_per_mm,axial_strain,transverse_strain\n\
        a,1,0,0.0,0.0,0.0\n\
        a,2,1,0.01,0.1,-0.02\n\
        a,3,2,0.02,0.2,-0.04\n\
        a,4,1,0.005,0.1,-0.03\n\
        b,1,0,0.0,0.0,0.0\n\
        b,2,1,0.012,0.1,-0.02\n\
        b,3,2,0.022,0.2,-0.04\n";

    #[test]
    fn stitch_csv_keeps_loading_branch_and_bins() {
        let m = parse_stitch_csv(
            STITCH,
            "t.csv",
            Direction::Weft,
            &BinOptions {
                bins: 2,
                swatch_width: 0.06,
            },
        )
        .unwrap();
        // Bin 0: strains 0, 0 (and 0.1? no: 0.1 = width → bin 1). The unloading row a,4 is gone.
        assert_eq!(m.points.len(), 2);
        let last = m.points[1];
        assert!((last.s - 0.15).abs() < 1e-12, "{last:?}");
        // Stresses 0.01, 0.02, 0.012, 0.022 → mean 0.016 N/mm × 60 mm.
        assert!((last.force - 0.016 * 60.0).abs() < 1e-12);
        assert!((last.compression - 0.03).abs() < 1e-12);
    }

    #[test]
    fn errors_name_file_line_and_problem() {
        let bad = STITCH.replace("b,2,1,0.012", "b,2,1,oops");
        let e =
            parse_stitch_csv(&bad, "bad.csv", Direction::Weft, &BinOptions::default()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "bad.csv:8: column `stress_n_per_mm`: `oops` is not a number"
        );
        let nan_force = STITCH.replace("b,2,1,0.012", "b,2,NaN,0.012");
        let e = parse_stitch_csv(&nan_force, "f.csv", Direction::Weft, &BinOptions::default())
            .unwrap_err();
        assert_eq!(e.to_string(), "f.csv:8: column `force_n` is not finite");
        let short = STITCH.replace("b,3,2,0.022,0.2,-0.04", "b,3,2,0.022");
        let e =
            parse_stitch_csv(&short, "s.csv", Direction::Weft, &BinOptions::default()).unwrap_err();
        assert!(
            e.to_string().starts_with("s.csv:9: expected 6 fields"),
            "{e}"
        );
        let e = parse_stitch_csv(
            "x,y\n1,2\n",
            "h.csv",
            Direction::Weft,
            &BinOptions::default(),
        )
        .unwrap_err();
        assert!(
            e.to_string()
                .starts_with("h.csv:1: header lacks column `axial_strain`"),
            "{e}"
        );
    }

    #[test]
    fn directions_are_read_from_every_naming_convention() {
        let cases = [
            ("acrylic-yarn-garter-x.csv", Some(Direction::Weft)),
            ("acrylic-yarn-rib-y.csv", Some(Direction::Warp)),
            ("acrylic-yarn-rib-x-new.csv", Some(Direction::Weft)),
            ("babyredo_garterxnew.csv", Some(Direction::Weft)),
            ("babyredo_gartery.csv", Some(Direction::Warp)),
            ("babyredo_stockxnew.csv", Some(Direction::Weft)),
            ("babyredo_stockinettey.csv", Some(Direction::Warp)),
            ("babyredo_ribx.csv", Some(Direction::Weft)),
            ("babyredo_seedy.csv", Some(Direction::Warp)),
            ("cotton_moss_course_v2.csv", Some(Direction::Weft)),
            ("Cotton-Jersey-Wale.csv", Some(Direction::Warp)),
            ("wool-bias.csv", Some(Direction::Bias)),
            ("twill_warp_run3.csv", Some(Direction::Warp)),
            // A word that merely ends in `y` is not a direction.
            ("babyredo_jersey.csv", None),
            ("babyredo_sample.csv", None),
            ("new.csv", None),
        ];
        for (name, want) in cases {
            assert_eq!(direction_from_name(Path::new(name)), want, "{name}");
        }
    }

    #[test]
    fn both_files_of_a_fabric_get_one_name() {
        let name = |f: &str| split_name(Path::new(f)).map(|(n, _)| n);
        assert_eq!(
            name("babyredo_stockxnew.csv"),
            name("babyredo_stockinettey.csv")
        );
        assert_eq!(
            name("babyredo_stockxnew.csv").unwrap(),
            "babyredo-stockinette"
        );
        assert_eq!(
            name("acrylic-yarn-rib-x-new.csv"),
            name("acrylic-yarn-rib-y.csv")
        );
        assert_eq!(name("acrylic-yarn-rib-y.csv").unwrap(), "acrylic-yarn-rib");
        assert_eq!(
            name("babyredo_garterxnew.csv"),
            name("babyredo_gartery.csv")
        );
        assert_eq!(name("cotton_moss_course_v2.csv").unwrap(), "cotton-seed");
    }

    #[test]
    fn direction_csv_accepts_missing_directions_and_rejects_bad_rows() {
        let ok = "direction,s,f_s,c\nweft,0.1,1,0.01\nweft,0.2,2.5,0.03\nwarp,0.1,3,0.02\nwarp,0.2,7,0.05\n";
        let m = parse_direction_csv(ok, "d.csv").unwrap();
        assert_eq!(m.len(), 2);
        assert_eq!(m[0].direction, Direction::Weft);
        assert_eq!(m[1].direction, Direction::Warp);
        let e = parse_direction_csv(&ok.replace("warp,0.2", "diagonal,0.2"), "d.csv").unwrap_err();
        assert_eq!(
            e.to_string(),
            "d.csv:5: unknown direction `diagonal` (weft, bias, warp)"
        );
        let e = parse_direction_csv(&ok.replace("weft,0.2", "weft,0.05"), "d.csv").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("d.csv:3: weft stretch must increase"),
            "{e}"
        );
        let e = parse_direction_csv(&ok.replace("3,0.02", "NaN,0.02"), "d.csv").unwrap_err();
        assert!(e.to_string().starts_with("d.csv:4: `f_s`"), "{e}");
    }
}
