//! Uniform target curves: what `shell-fem curves` writes (`curves.csv`, columns
//! `kind,direction,x,c,sigma`; `stretch` rows are `{s, c, σ_s}` with σ in N/m, `bending` rows
//! are read past, since the fit uses stretch and compression only, as the paper does, §7.3.1).

use std::collections::BTreeMap;
use std::path::Path;
use yarn_pattern::direction::Direction;

use super::FitError;

/// One target point: stretch `s`, orthogonal compression `c` and stretch stress `σ_s` (N/m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TargetPoint {
    /// Stretch.
    pub s: f64,
    /// Orthogonal compression at zero orthogonal stress.
    pub c: f64,
    /// Stretch stress (first Piola–Kirchhoff, N/m).
    pub sigma: f64,
}

/// Target curves per direction, each sorted by `s` with distinct stretches.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Targets {
    /// The curves.
    pub curves: BTreeMap<Direction, Vec<TargetPoint>>,
}

impl Targets {
    /// Reads `path` (see the module documentation).
    pub fn read(path: &Path) -> Result<Self, FitError> {
        let text = std::fs::read_to_string(path).map_err(|e| FitError::Input {
            path: path.to_path_buf(),
            line: 0,
            problem: e.to_string(),
        })?;
        Self::parse(&text, path)
    }

    /// Parses CSV text read from `path` (named in errors).
    pub fn parse(text: &str, path: &Path) -> Result<Self, FitError> {
        let bad = |line: usize, problem: String| FitError::Input {
            path: path.to_path_buf(),
            line,
            problem,
        };
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(true)
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        let header: Vec<String> = reader
            .headers()
            .map_err(|e| bad(1, e.to_string()))?
            .iter()
            .map(str::to_lowercase)
            .collect();
        if header != ["kind", "direction", "x", "c", "sigma"] {
            return Err(bad(
                1,
                format!(
                    "expected the header `kind,direction,x,c,sigma` (shell-fem curves), found \
                     `{}`",
                    header.join(",")
                ),
            ));
        }
        let mut curves: BTreeMap<Direction, Vec<TargetPoint>> = BTreeMap::new();
        for record in reader.records() {
            let record = record.map_err(|e| {
                let line = e.position().map_or(0, |p| p.line() as usize);
                bad(line, e.to_string())
            })?;
            let line = record.position().map_or(0, |p| p.line() as usize);
            match &record[0] {
                "stretch" => {}
                "bending" => continue,
                other => {
                    return Err(bad(
                        line,
                        format!("kind must be `stretch` or `bending`, found `{other}`"),
                    ));
                }
            }
            let direction = Direction::parse(&record[1]).ok_or_else(|| {
                bad(
                    line,
                    format!(
                        "direction must be weft, bias or warp, found `{}`",
                        &record[1]
                    ),
                )
            })?;
            let number = |i: usize, name: &str| -> Result<f64, FitError> {
                record[i]
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| {
                        bad(
                            line,
                            format!("{name} must be a finite number, found `{}`", &record[i]),
                        )
                    })
            };
            let point = TargetPoint {
                s: number(2, "x (the stretch s)")?,
                c: number(3, "c")?,
                sigma: number(4, "sigma")?,
            };
            if point.s <= -1.0 || point.c >= 1.0 {
                return Err(bad(
                    line,
                    format!(
                        "need s > -1 and c < 1, found s = {}, c = {}",
                        point.s, point.c
                    ),
                ));
            }
            let curve = curves.entry(direction).or_default();
            if let Some(last) = curve.last()
                && point.s <= last.s
            {
                return Err(bad(
                    line,
                    format!(
                        "{} stretches must increase, found {} after {}",
                        direction.name(),
                        point.s,
                        last.s
                    ),
                ));
            }
            curve.push(point);
        }
        if curves.is_empty() {
            return Err(bad(0, "no stretch rows".into()));
        }
        for (d, c) in &curves {
            if c.len() < 2 {
                return Err(bad(
                    0,
                    format!("the {} curve needs at least 2 points", d.name()),
                ));
            }
        }
        Ok(Self { curves })
    }

    /// The target at stretch `s` of direction `d`, linearly interpolated (clamped to the
    /// curve's ends).
    pub fn at(&self, d: Direction, s: f64) -> Option<TargetPoint> {
        interpolate(self.curves.get(&d)?, s)
    }

    /// Serializes to the CSV format [`Targets::parse`] reads (stretch rows only).
    pub fn to_csv(&self) -> String {
        let mut out = String::from("kind,direction,x,c,sigma\n");
        for (d, curve) in &self.curves {
            for p in curve {
                out.push_str(&format!(
                    "stretch,{},{},{},{}\n",
                    d.name(),
                    p.s,
                    p.c,
                    p.sigma
                ));
            }
        }
        out
    }
}

/// `curve` (increasing in `s`) linearly interpolated at `s`, held constant beyond its ends;
/// `None` for an empty curve.
pub fn interpolate(curve: &[TargetPoint], s: f64) -> Option<TargetPoint> {
    let first = *curve.first()?;
    let last = *curve.last()?;
    if s <= first.s {
        return Some(TargetPoint { s, ..first });
    }
    if s >= last.s {
        return Some(TargetPoint { s, ..last });
    }
    let k = curve.partition_point(|p| p.s <= s);
    let (a, b) = (curve[k - 1], curve[k]);
    let t = (s - a.s) / (b.s - a.s);
    Some(TargetPoint {
        s,
        c: a.c + t * (b.c - a.c),
        sigma: a.sigma + t * (b.sigma - a.sigma),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "kind,direction,x,c,sigma\n\
        stretch,weft,0,0,0\n\
        stretch,weft,0.5,0.1,10\n\
        stretch,warp,0,0,0\n\
        stretch,warp,0.2,0.05,30\n\
        bending,weft,0,,0\n";

    #[test]
    fn reads_shell_fem_curves_and_interpolates() {
        let t = Targets::parse(GOOD, Path::new("c.csv")).unwrap();
        assert_eq!(t.curves.len(), 2);
        let p = t.at(Direction::Weft, 0.25).unwrap();
        assert!((p.c - 0.05).abs() < 1e-15 && (p.sigma - 5.0).abs() < 1e-12);
        assert_eq!(t.at(Direction::Warp, 1.0).unwrap().sigma, 30.0);
        assert!(t.at(Direction::Bias, 0.1).is_none());
        let again = Targets::parse(&t.to_csv(), Path::new("again.csv")).unwrap();
        assert_eq!(again, t);
    }

    #[test]
    fn bad_rows_name_file_line_and_expectation() {
        let err = |text: &str| {
            Targets::parse(text, Path::new("t.csv"))
                .unwrap_err()
                .to_string()
        };
        let e = err("kind,direction,s,c,sigma\n");
        assert!(e.contains("t.csv") && e.contains("header"), "{e}");
        let e = err("kind,direction,x,c,sigma\nstretch,weft,0,0,0\nstretch,sideways,1,0,1\n");
        assert!(
            e.contains("line 3") && e.contains("weft, bias or warp"),
            "{e}"
        );
        let e = err("kind,direction,x,c,sigma\nstretch,weft,0,0,0\nstretch,weft,0.1,0,abc\n");
        assert!(e.contains("line 3") && e.contains("sigma"), "{e}");
        let e = err("kind,direction,x,c,sigma\nstretch,weft,0.2,0,0\nstretch,weft,0.1,0,1\n");
        assert!(e.contains("increase"), "{e}");
        let e = err("kind,direction,x,c,sigma\nstretch,weft,0.2,0,0\n");
        assert!(e.contains("at least 2"), "{e}");
    }
}
