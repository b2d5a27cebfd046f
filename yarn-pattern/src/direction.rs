//! The three in-plane test directions of a fabric: weft (0°), bias (45°) and warp (90°), as
//! used by the stretch tests of seed 002 §4.3 and the periodic target curves of §6.

/// Fabric test direction. With the `serde` feature it (de)serializes as `Weft`/`Bias`/`Warp`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Direction {
    /// 0°: along material x.
    Weft,
    /// 45°.
    Bias,
    /// 90°: along material y.
    Warp,
}

impl Direction {
    /// All three directions, in the usual order.
    pub const ALL: [Direction; 3] = [Direction::Weft, Direction::Bias, Direction::Warp];

    /// Angle of the pull direction from material x (rad).
    pub fn angle(self) -> f64 {
        match self {
            Direction::Weft => 0.0,
            Direction::Bias => std::f64::consts::FRAC_PI_4,
            Direction::Warp => std::f64::consts::FRAC_PI_2,
        }
    }

    /// Lower-case name (`weft`, `bias`, `warp`).
    pub fn name(self) -> &'static str {
        match self {
            Direction::Weft => "weft",
            Direction::Bias => "bias",
            Direction::Warp => "warp",
        }
    }

    /// Parses `weft`/`x`/`0`, `bias`/`45`, `warp`/`y`/`90` (case-insensitive, trimmed).
    pub fn parse(s: &str) -> Option<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "weft" | "x" | "0" => Some(Direction::Weft),
            "bias" | "45" => Some(Direction::Bias),
            "warp" | "y" | "90" => Some(Direction::Warp),
            _ => None,
        }
    }
}

impl std::fmt::Display for Direction {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_back_and_angles_increase() {
        for d in Direction::ALL {
            assert_eq!(
                Direction::parse(&format!(" {} ", d.name().to_uppercase())),
                Some(d)
            );
            assert_eq!(d.to_string(), d.name());
        }
        assert_eq!(Direction::parse("y"), Some(Direction::Warp));
        assert_eq!(Direction::parse("45"), Some(Direction::Bias));
        assert_eq!(Direction::parse("diagonal"), None);
        assert!(
            Direction::ALL
                .windows(2)
                .all(|w| w[0].angle() < w[1].angle())
        );
    }
}
