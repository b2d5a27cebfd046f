//! Continuation with step halving
//!
//! A nonlinear solve far from its warm start (a large load step, a long time step, a distant
//! database sample) often fails where a sequence of smaller steps succeeds. Both routines here
//! take a user closure that *attempts one step* — solves from the current state to a new
//! parameter value and commits the new state only on success, returning `Err` otherwise (the
//! state must then be unchanged) — and retry failed steps with halved lengths:
//!
//! - [`march`]: load stepping along a scalar parameter `t` from `t0` to `t1` in steps of at
//!   most `max_step`; a failed step is halved (at most `max_halvings` times in a row), and
//!   after every success the step grows back to `min(max_step, |t1 − t|)`. The last step lands
//!   exactly on `t1`. At least one step is attempted, so `t0 = t1` re-solves at `t1`.
//! - [`bisect`]: a fixed segment (for example a time step `h`, or a path from one strain to
//!   another) that is split in two halves on failure, recursively, depth first, at most
//!   `max_depth` levels deep; the halves of a split segment are both solved at the half length
//!   (no growth back). How a segment splits is the caller's `split` closure, so midpoints are
//!   computed exactly as the caller defines them (`h/2` twice, or `(a, (a+b)/2)`,
//!   `((a+b)/2, b)` of any parameter type).
//!
//! Each attempt is told its *depth* (the number of halvings behind its length) and whether it
//! is the last chance (`depth == max`), so a caller may spend a larger budget on it. A closure
//! reports a failure either as [`StepError::Halve`] (retry with a halved step) or
//! [`StepError::Abort`] (stop at once: bad input, a failure halving cannot cure).
//!
//! Both return a [`ContinuationReport`] (steps, halvings, deepest level) or a
//! [`ContinuationError`] carrying the last good parameter, the failed step and the closure's
//! error.

/// The failure of one attempted step.
#[derive(Debug)]
pub enum StepError<E> {
    /// The step failed; retry it with half the length (if halvings remain).
    Halve(E),
    /// A failure that halving cannot cure: stop at once.
    Abort(E),
}

impl<E> StepError<E> {
    /// The wrapped error.
    pub fn into_inner(self) -> E {
        match self {
            Self::Halve(e) | Self::Abort(e) => e,
        }
    }
}

/// One attempted step as seen by the closure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Attempt {
    /// Halvings behind this step's length (0: full length).
    pub depth: usize,
    /// `true` when this step cannot be halved again if it fails.
    pub last_chance: bool,
}

/// What a continuation did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ContinuationReport {
    /// Successful steps.
    pub steps: usize,
    /// Failed attempts that were retried with a halved step.
    pub halvings: usize,
    /// Deepest halving level of a successful step.
    pub max_depth: usize,
}

/// A continuation that could not be completed.
#[derive(Debug, thiserror::Error)]
#[error(
    "continuation failed at depth {depth} after {} steps and {} halvings: {source}",
    .report.steps, .report.halvings
)]
pub struct ContinuationError<P, E: std::error::Error + 'static> {
    /// The last parameter reached: for [`march`] `t` of the last committed state; for
    /// [`bisect`] the last segment solved (the failed one itself when none was).
    pub last_good: P,
    /// The step that failed: for [`march`] its target `t`, for [`bisect`] the failed segment.
    pub failed: P,
    /// Halvings behind the failed step's length.
    pub depth: usize,
    /// Whether the closure aborted ([`StepError::Abort`]) rather than running out of halvings.
    pub aborted: bool,
    /// Work done before the failure.
    pub report: ContinuationReport,
    /// The closure's error.
    #[source]
    pub source: E,
}

/// Settings of [`march`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarchSettings {
    /// Largest step `|Δt|` (units of `t`, > 0).
    pub max_step: f64,
    /// Consecutive halvings of one step before giving up.
    pub max_halvings: usize,
}

/// Bad input of [`march`] (reported before any attempt).
#[derive(Debug, thiserror::Error)]
#[error("invalid continuation input: {0}")]
pub struct InvalidContinuation(pub String);

/// Marches `t` from `t0` to `t1` (module documentation). `attempt(t, t_next, info)` solves
/// from the committed state at `t` to `t_next` and commits on `Ok`.
///
/// The step is `clamp(t1 − t, −max_step, max_step)`, halved (`× 0.5`) on each failure; the
/// target is `t1` itself when the step equals the remaining distance, `t + step` otherwise.
pub fn march<E: std::error::Error + 'static>(
    t0: f64,
    t1: f64,
    settings: &MarchSettings,
    mut attempt: impl FnMut(f64, f64, Attempt) -> Result<(), StepError<E>>,
) -> Result<ContinuationReport, MarchError<E>> {
    if !(t0.is_finite() && t1.is_finite()) {
        return Err(MarchError::Invalid(InvalidContinuation(format!(
            "parameter range [{t0}, {t1}] must be finite"
        ))));
    }
    if !(settings.max_step.is_finite() && settings.max_step > 0.0) {
        return Err(MarchError::Invalid(InvalidContinuation(format!(
            "max_step must be finite and > 0, got {}",
            settings.max_step
        ))));
    }
    let mut report = ContinuationReport::default();
    let mut t = t0;
    let mut first = true;
    loop {
        let remaining = t1 - t;
        if remaining == 0.0 && !first {
            return Ok(report);
        }
        first = false;
        let mut step = remaining.clamp(-settings.max_step, settings.max_step);
        let mut depth = 0;
        loop {
            // The last step lands exactly on `t1` (no rounding drift along the path).
            let target = if step == remaining { t1 } else { t + step };
            let info = Attempt {
                depth,
                last_chance: depth >= settings.max_halvings,
            };
            match attempt(t, target, info) {
                Ok(()) => {
                    report.steps += 1;
                    report.max_depth = report.max_depth.max(depth);
                    t = target;
                    break;
                }
                Err(StepError::Halve(_)) if depth < settings.max_halvings => {
                    report.halvings += 1;
                    depth += 1;
                    step *= 0.5;
                }
                Err(e) => {
                    let aborted = matches!(e, StepError::Abort(_));
                    return Err(MarchError::Failed(ContinuationError {
                        last_good: t,
                        failed: target,
                        depth,
                        aborted,
                        report,
                        source: e.into_inner(),
                    }));
                }
            }
        }
    }
}

/// Errors of [`march`].
#[derive(Debug, thiserror::Error)]
pub enum MarchError<E: std::error::Error + 'static> {
    /// Bad parameter range or settings.
    #[error(transparent)]
    Invalid(InvalidContinuation),
    /// A step failed after all halvings (or aborted).
    #[error(transparent)]
    Failed(ContinuationError<f64, E>),
}

/// Solves `segment` with recursive halving (module documentation): `attempt(segment, info)`
/// solves it from the committed state and commits on `Ok`; on [`StepError::Halve`] with
/// `info.depth < max_depth`, `split(segment)` gives the two halves, attempted in order at
/// depth `info.depth + 1`.
pub fn bisect<S: Clone, E: std::error::Error + 'static>(
    segment: S,
    max_depth: usize,
    split: impl Fn(&S) -> (S, S),
    mut attempt: impl FnMut(&S, Attempt) -> Result<(), StepError<E>>,
) -> Result<ContinuationReport, ContinuationError<S, E>> {
    let mut report = ContinuationReport::default();
    // Depth-first: a stack of pending segments, the next one on top.
    let mut pending = vec![(segment, 0usize)];
    let mut last_good: Option<S> = None;
    while let Some((seg, depth)) = pending.pop() {
        let info = Attempt {
            depth,
            last_chance: depth >= max_depth,
        };
        match attempt(&seg, info) {
            Ok(()) => {
                report.steps += 1;
                report.max_depth = report.max_depth.max(depth);
                last_good = Some(seg);
            }
            Err(StepError::Halve(_)) if depth < max_depth => {
                report.halvings += 1;
                let (first, second) = split(&seg);
                pending.push((second, depth + 1));
                pending.push((first, depth + 1));
            }
            Err(e) => {
                let aborted = matches!(e, StepError::Abort(_));
                return Err(ContinuationError {
                    last_good: last_good.unwrap_or_else(|| seg.clone()),
                    failed: seg,
                    depth,
                    aborted,
                    report,
                    source: e.into_inner(),
                });
            }
        }
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error, PartialEq)]
    #[error("step too long: {0}")]
    struct TooLong(f64);

    /// A "solver" that only converges for steps of at most `limit`.
    fn limited(limit: f64) -> impl FnMut(f64, f64, Attempt) -> Result<(), StepError<TooLong>> {
        move |t, next, _| {
            if (next - t).abs() <= limit {
                Ok(())
            } else {
                Err(StepError::Halve(TooLong(next - t)))
            }
        }
    }

    #[test]
    fn march_without_failures_takes_max_steps_and_lands_exactly() {
        let mut visited = vec![];
        let settings = MarchSettings {
            max_step: 0.3,
            max_halvings: 3,
        };
        let report = march(0.0, 1.0, &settings, |_, next, _| {
            visited.push(next);
            Ok::<(), StepError<TooLong>>(())
        })
        .unwrap();
        assert_eq!(report.steps, 4);
        assert_eq!(report.halvings, 0);
        assert_eq!(*visited.last().unwrap(), 1.0);
        assert!((visited[0] - 0.3).abs() < 1e-15);
    }

    #[test]
    fn march_halves_failed_steps_and_grows_back() {
        let mut attempts = vec![];
        let mut solver = limited(0.26);
        let settings = MarchSettings {
            max_step: 1.0,
            max_halvings: 4,
        };
        let report = march(0.0, 1.0, &settings, |t, next, info| {
            attempts.push((next - t, info.depth));
            solver(t, next, info)
        })
        .unwrap();
        // 1 → 0.5 → 0.25 succeeds; then remaining 0.75 → 0.375 → 0.1875 (grows back each time).
        assert_eq!(attempts[..4], [(1.0, 0), (0.5, 1), (0.25, 2), (0.75, 0)]);
        assert!(report.halvings >= 2 && report.max_depth == 2, "{report:?}");
    }

    #[test]
    fn march_reports_the_last_good_parameter_when_halvings_run_out() {
        let settings = MarchSettings {
            max_step: 0.5,
            max_halvings: 2,
        };
        let err = match march(0.0, 1.0, &settings, limited(0.1)) {
            Err(MarchError::Failed(e)) => e,
            other => panic!("{other:?}"),
        };
        assert_eq!(err.last_good, 0.0);
        assert_eq!(err.failed, 0.125);
        assert_eq!(err.depth, 2);
        assert!(!err.aborted);
        assert_eq!(err.report.halvings, 2);
        assert!(matches!(
            march(
                0.0,
                1.0,
                &MarchSettings {
                    max_step: 0.0,
                    max_halvings: 1
                },
                limited(1.0)
            ),
            Err(MarchError::Invalid(_))
        ));
    }

    #[test]
    fn march_attempts_once_at_zero_distance_and_goes_backwards() {
        let mut calls = vec![];
        let settings = MarchSettings {
            max_step: 0.5,
            max_halvings: 0,
        };
        march(0.2, 0.2, &settings, |t, next, _| {
            calls.push((t, next));
            Ok::<(), StepError<TooLong>>(())
        })
        .unwrap();
        assert_eq!(calls, [(0.2, 0.2)]);
        let report = march(1.0, 0.0, &settings, limited(0.5)).unwrap();
        assert_eq!(report.steps, 2);
    }

    #[test]
    fn bisect_splits_recursively_and_keeps_half_lengths() {
        let mut lengths = vec![];
        let report = bisect(
            (0.0f64, 1.0f64),
            4,
            |&(a, b)| ((a, 0.5 * (a + b)), (0.5 * (a + b), b)),
            |&(a, b), _| {
                lengths.push(b - a);
                if b - a <= 0.25 {
                    Ok(())
                } else {
                    Err(StepError::Halve(TooLong(b - a)))
                }
            },
        )
        .unwrap();
        assert_eq!(report.steps, 4);
        assert_eq!(report.halvings, 3);
        assert_eq!(report.max_depth, 2);
        assert_eq!(lengths, [1.0, 0.5, 0.25, 0.25, 0.5, 0.25, 0.25]);
    }

    #[test]
    fn bisect_fails_with_depth_and_last_good_segment() {
        let mut commits = vec![];
        let err = bisect(
            1.0f64,
            2,
            |&h| (0.5 * h, 0.5 * h),
            |&h, info| {
                if h <= 0.1 || (info.depth == 2 && !commits.is_empty()) {
                    return Err(StepError::Halve(TooLong(h)));
                }
                if h <= 0.25 {
                    commits.push(h);
                    Ok(())
                } else {
                    Err(StepError::Halve(TooLong(h)))
                }
            },
        )
        .unwrap_err();
        assert_eq!(err.depth, 2);
        assert_eq!(err.last_good, 0.25);
        assert_eq!(err.report.steps, 1);
        assert_eq!(err.source, TooLong(0.25));
    }

    #[test]
    fn aborts_are_not_retried() {
        let mut calls = 0;
        let err = bisect(
            1.0f64,
            5,
            |&h| (0.5 * h, 0.5 * h),
            |&h, _| {
                calls += 1;
                Err(StepError::Abort(TooLong(h)))
            },
        )
        .unwrap_err();
        assert!(err.aborted);
        assert_eq!((calls, err.depth, err.report.halvings), (1, 0, 0));
    }
}
