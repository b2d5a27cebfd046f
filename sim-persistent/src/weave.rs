//! Weave patterns: which yarn lies on top at each warp × weft crossing (seed 000 §3.1, §3.2.1).
//!
//! Warp yarns run along the fabric's y axis (columns `i`), weft yarns along x (rows `j`).
//! A float is a run of crossings where the same yarn stays on top; plain weave has none,
//! twill and satin distribute floats differently and so change the fabric's mechanics.

/// A periodic weave pattern.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WeavePattern {
    /// Plain weave: the warp is on top where `i + j` is even (no floats).
    Plain,
    /// `over/under` twill: the warp is on top where `(i + j) mod (over + under) < over`,
    /// so each row shifts the pattern by one and floats form diagonal lines.
    Twill {
        /// Crossings the warp floats over the weft (≥ 1).
        over: usize,
        /// Crossings the warp passes under the weft (≥ 1).
        under: usize,
    },
    /// Satin of `harness` ≥ 5 with counter `step` (2 ≤ step ≤ harness − 2, coprime with
    /// harness): the warp is on top where `(i · step + j) mod harness == 0`, so every warp
    /// and every weft is on top exactly once per repeat and no two such crossings touch.
    Satin {
        /// Repeat size (≥ 5).
        harness: usize,
        /// Counter (move number).
        step: usize,
    },
}

impl WeavePattern {
    /// Checks the parameters; `Err` with a description if they are invalid.
    pub fn validate(&self) -> Result<(), String> {
        match *self {
            WeavePattern::Plain => Ok(()),
            WeavePattern::Twill { over, under } => {
                if over == 0 || under == 0 {
                    Err(format!("twill {over}/{under}: both counts must be ≥ 1"))
                } else {
                    Ok(())
                }
            }
            WeavePattern::Satin { harness, step } => {
                if harness < 5 || step < 2 || step + 2 > harness || gcd(harness, step) != 1 {
                    Err(format!(
                        "satin {harness}/{step}: needs harness ≥ 5, 2 ≤ step ≤ harness − 2, \
                         step coprime with harness"
                    ))
                } else {
                    Ok(())
                }
            }
        }
    }

    /// Whether the warp yarn `i` lies on top of the weft yarn `j` at their crossing.
    pub fn warp_over(&self, i: usize, j: usize) -> bool {
        match *self {
            WeavePattern::Plain => (i + j).is_multiple_of(2),
            WeavePattern::Twill { over, under } => (i + j) % (over + under) < over,
            WeavePattern::Satin { harness, step } => (i * step + j).is_multiple_of(harness),
        }
    }
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}
