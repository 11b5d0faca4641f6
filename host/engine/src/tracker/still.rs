//! Still periods of a recorded take: where the arm held a pose.
//!
//! A window of `min_duration_s` starting at a frame is still when no tracked
//! frame in it lies farther than `max_spread_m` from the window's mean and the
//! target is tracked in at least half of its frames. Overlapping still windows
//! join into one still period; its position is the mean of all tracked frames
//! in it. A move between poses breaks the chain, since every window that
//! reaches into the move spreads beyond the threshold. A take may skip time
//! (frames the software dropped, a take stopped and resumed): a window is a
//! hold only when its frames span `min_duration_s` (to within a frame and a
//! half), so the frame before a skip is not a hold of its own.

use nalgebra::Vector3;

use super::settle::mean_and_spread;

/// One frame of a take.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Time since the take started, s.
    pub time_s: f64,
    /// The target's position, m; `None` where it was not tracked.
    pub position: Option<Vector3<f64>>,
}

/// How still periods are found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StillOptions {
    /// Shortest hold that counts, s.
    pub min_duration_s: f64,
    /// Largest distance of a frame from the window's mean, m.
    pub max_spread_m: f64,
}

/// A stretch of the take where the target held still.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StillPeriod {
    /// Time of its first frame, s.
    pub start_s: f64,
    /// Time of its last frame, s.
    pub end_s: f64,
    /// Mean position of its tracked frames, m.
    pub position: Vector3<f64>,
    /// Tracked frames averaged.
    pub frames: usize,
    /// Frames without the target.
    pub lost: usize,
    /// Largest distance of a tracked frame from the mean over the whole period, m.
    pub spread_m: f64,
}

/// The still periods of `samples` (in time order), in order.
pub fn still_periods(samples: &[Sample], options: StillOptions) -> Vec<StillPeriod> {
    // Half-open index ranges of the still windows' union, merged as they come.
    let mut spans: Vec<(usize, usize)> = Vec::new();
    let frame_s = median_interval_s(samples);
    let mut end = 0;
    for start in 0..samples.len() {
        let until = samples[start].time_s + options.min_duration_s;
        end = end.max(start + 1);
        while end < samples.len() && samples[end].time_s <= until {
            end += 1;
        }
        // A window cut short by the end of the take is not a hold of its own,
        // but it carries on a hold that reaches the end.
        let cut_short = end == samples.len() && samples[end - 1].time_s < until - 1e-9;
        if cut_short && spans.last().is_none_or(|last| start >= last.1) {
            break;
        }
        let window = &samples[start..end];
        let span_s = window[window.len() - 1].time_s - window[0].time_s;
        if !cut_short && span_s < options.min_duration_s - 1.5 * frame_s {
            continue;
        }
        let tracked = window.iter().filter_map(|s| s.position.as_ref());
        if 2 * tracked.clone().count() < window.len() {
            continue;
        }
        let still =
            mean_and_spread(tracked).is_some_and(|(_, spread)| spread <= options.max_spread_m);
        if !still {
            continue;
        }
        match spans.last_mut() {
            Some(last) if start < last.1 => last.1 = last.1.max(end),
            _ => spans.push((start, end)),
        }
    }
    spans
        .into_iter()
        .filter_map(|(a, b)| {
            let period = &samples[a..b];
            let tracked = period.iter().filter_map(|s| s.position.as_ref());
            let frames = tracked.clone().count();
            let (position, spread_m) = mean_and_spread(tracked)?;
            Some(StillPeriod {
                start_s: period[0].time_s,
                end_s: period[period.len() - 1].time_s,
                position,
                frames,
                lost: period.len() - frames,
                spread_m,
            })
        })
        .collect()
}

/// The median time between consecutive frames, s (0 for fewer than two).
fn median_interval_s(samples: &[Sample]) -> f64 {
    let mut steps: Vec<f64> = samples
        .windows(2)
        .map(|w| w[1].time_s - w[0].time_s)
        .collect();
    if steps.is_empty() {
        return 0.0;
    }
    steps.sort_by(f64::total_cmp);
    steps[steps.len() / 2]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 100 Hz: hold at x = 0 for 2 s, move 50 mm in 1 s, hold 2 s, with a
    /// 0.3 s dropout in the second hold.
    fn take() -> Vec<Sample> {
        (0..500)
            .map(|i| {
                let t = i as f64 / 100.0;
                let x = match t {
                    t if t < 2.0 => 0.0,
                    t if t < 3.0 => 50.0 * (t - 2.0),
                    _ => 50.0,
                };
                let lost = (3.8..4.1).contains(&t);
                Sample {
                    time_s: t,
                    position: (!lost).then(|| Vector3::new(x, 10.0, 20.0) / 1000.0),
                }
            })
            .collect()
    }

    #[test]
    fn two_holds_give_two_periods_through_a_dropout() {
        let options = StillOptions {
            min_duration_s: 1.0,
            max_spread_m: 0.5e-3,
        };
        let periods = still_periods(&take(), options);
        assert_eq!(periods.len(), 2, "{periods:?}");
        let (a, b) = (periods[0], periods[1]);
        assert_eq!(a.start_s, 0.0);
        // Until 0.5 mm (10 ms of the move at 50 mm/s) past the hold.
        assert!((a.end_s - 2.0).abs() < 0.02, "{a:?}");
        assert!((a.position - Vector3::new(0.0, 0.01, 0.02)).norm() < 1e-5);
        assert!(
            b.start_s > 2.98 && b.start_s < 3.0 && b.end_s == 4.99,
            "{b:?}"
        );
        assert_eq!(b.lost, 30);
        assert!((b.position.x - 0.05).abs() < 1e-5 && b.spread_m < 0.5e-3);
    }

    #[test]
    fn holds_shorter_than_the_minimum_are_not_periods() {
        let options = StillOptions {
            min_duration_s: 2.5,
            max_spread_m: 0.5e-3,
        };
        assert!(still_periods(&take(), options).is_empty());
        // Nothing tracked: nothing still.
        let lost: Vec<Sample> = take()
            .into_iter()
            .map(|s| Sample {
                position: None,
                ..s
            })
            .collect();
        assert!(
            still_periods(
                &lost,
                StillOptions {
                    min_duration_s: 0.5,
                    ..options
                }
            )
            .is_empty()
        );
    }

    #[test]
    fn a_skip_in_time_is_not_a_hold_and_a_hold_across_one_stays_one() {
        let options = StillOptions {
            min_duration_s: 1.0,
            max_spread_m: 0.5e-3,
        };
        // The first hold's last 0.5 s are not in the take, and the take
        // resumes 3 s later during the move.
        let skipped: Vec<Sample> = take()
            .into_iter()
            .filter(|s| !(1.5..2.5).contains(&s.time_s))
            .collect();
        let periods = still_periods(&skipped, options);
        assert_eq!(periods.len(), 2, "{periods:?}");
        assert!(periods.iter().all(|p| p.frames > 50), "{periods:?}");
        // A frame alone before a skip of several seconds, then a hold.
        let mut lone = vec![Sample {
            time_s: 0.0,
            position: Some(Vector3::new(0.3, 0.0, 0.0)),
        }];
        lone.extend(take().into_iter().map(|s| Sample {
            time_s: s.time_s + 10.0,
            ..s
        }));
        let periods = still_periods(&lone, options);
        assert_eq!(periods.len(), 2, "{periods:?}");
        assert!(periods[0].start_s >= 10.0, "{periods:?}");
    }
}
