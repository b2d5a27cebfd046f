//! The floating-point type of the per-frame pipeline: `f32` (the production path, as on the GPU)
//! or `f64` (the reference path used for exactness tests and precision studies).
//!
//! [`Real`] is num-traits' [`Float`] (arithmetic, `sqrt`, `abs`, `min`, `max`, `is_finite`,
//! `T::zero()`, `T::one()`, all forwarding to the primitive methods, so results are
//! bit-identical to plain `f32`/`f64` code) with [`AsPrimitive<f64>`] for exact widening
//! (`x.as_()`, i.e. `x as f64`). The extension adds only the two conversions `Float` lacks in
//! infallible form (its `NumCast::from` and `ToPrimitive` return `Option`): rounding an `f64`
//! to the type and truncating to an index, both Rust's `as` casts.

use std::fmt::Debug;
use std::ops::AddAssign;

pub use num_traits::{AsPrimitive, Float};

/// A scalar the deformer can run in (`f32` or `f64`): [`Float`] plus the `as` casts it lacks.
pub trait Real:
    Float + AsPrimitive<f64> + Debug + Default + Send + Sync + AddAssign + 'static
{
    /// Rounds an `f64` to this type (`x as Self`: round to nearest).
    fn from_f64(x: f64) -> Self;
    /// Truncation to an index (`self as u32`: saturating; NaN gives 0).
    fn to_index(self) -> u32;
}

macro_rules! impl_real {
    ($t:ty) => {
        impl Real for $t {
            #[inline(always)]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn to_index(self) -> u32 {
                self as u32
            }
        }
    };
}

impl_real!(f32);
impl_real!(f64);
