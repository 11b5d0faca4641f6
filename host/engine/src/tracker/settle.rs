//! From DTrack frames to one position per pose: wait until the target holds
//! still, then average a window of frames. Pure: frames in, a reading or the
//! reason there is none out; the socket lives in `listen`.
//!
//! The window holds the last `frames` frames in which the target was tracked.
//! It is accepted when no frame in it lies farther than `max_spread_m` from
//! the window's mean; otherwise the arm is still moving (or ringing after the
//! move) and the window slides on by one frame. Frames without the target
//! (out of view, quality <= 0) are skipped and counted; too many in a row
//! stop the reading with what was seen instead.

use std::collections::{BTreeSet, VecDeque};
use std::fmt;

use nalgebra::Vector3;

use super::dtrack::{Frame, Target};

/// How a reading is taken.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SettleOptions {
    /// Frames averaged into one reading.
    pub frames: usize,
    /// Largest distance of an averaged frame from the mean, m.
    pub max_spread_m: f64,
    /// Frames in a row without the target after which the reading fails.
    pub max_lost_in_row: usize,
}

impl Default for SettleOptions {
    fn default() -> Self {
        Self {
            frames: 20,
            max_spread_m: 0.5e-3,
            max_lost_in_row: 120,
        }
    }
}

/// One averaged position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading {
    /// Mean position of the window, tracker frame, m.
    pub position: Vector3<f64>,
    /// Largest distance of a window frame from the mean, m.
    pub spread_m: f64,
    /// Frames averaged.
    pub frames: usize,
    /// Frames without the target while this reading was taken.
    pub lost: usize,
    /// Frame counters of the window's first and last frame.
    pub frame_range: (u64, u64),
}

/// The mean of `points` and the largest distance of one of them from it, m
/// (`None` for no points).
pub fn mean_and_spread<'a>(
    points: impl Iterator<Item = &'a Vector3<f64>> + Clone,
) -> Option<(Vector3<f64>, f64)> {
    let (sum, n) = points
        .clone()
        .fold((Vector3::zeros(), 0usize), |(s, n), p| (s + p, n + 1));
    if n == 0 {
        return None;
    }
    let mean = sum / n as f64;
    let spread = points.map(|p| (p - mean).norm()).fold(0.0, f64::max);
    Some((mean, spread))
}

/// The last frame that arrived, for messages.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LastFrame {
    /// Its frame counter.
    pub counter: u64,
    /// Its timestamp, s, when DTrack sends one.
    pub timestamp_s: Option<f64>,
    /// How long ago it arrived, s.
    pub ago_s: f64,
}

impl fmt::Display for LastFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "last frame {}", self.counter)?;
        if let Some(ts) = self.timestamp_s {
            write!(f, " at ts {ts:.3} s")?;
        }
        write!(f, ", {:.1} s ago", self.ago_s)
    }
}

/// Why no reading came.
#[derive(Clone, Debug, PartialEq)]
pub enum StreamProblem {
    /// No DTrack frame during the whole wait.
    Silent {
        /// How long was waited, s.
        waited_s: f64,
        /// The last frame ever received, if any.
        last: Option<LastFrame>,
        /// Datagrams that were not DTrack output, and the last one's problem.
        foreign: Option<(usize, String)>,
    },
    /// Frames came before, then stopped.
    Stopped {
        /// The last frame received.
        last: LastFrame,
    },
    /// The target was missing or untracked in too many frames in a row.
    Lost {
        /// The target.
        target: Target,
        /// Frames in a row without it.
        in_row: usize,
        /// Whether it was tracked at all during this reading.
        ever_seen: bool,
        /// Ids of its kind tracked in the last frame.
        tracked: Vec<u32>,
        /// Calibrated bodies (`6dcal`), if sent.
        calibrated: Option<u32>,
        /// When no frame had the target's kind of line (`6d`, `3d`): the
        /// kinds of line the frames did carry.
        line_missing: Option<Vec<String>>,
    },
    /// Frames came with the target, but never `frames` of them within the spread.
    Unsettled {
        /// How long was waited, s.
        waited_s: f64,
        /// Frames with the target.
        frames: usize,
        /// Spread of the last full window, m, if one filled.
        last_spread_m: Option<f64>,
        /// The options in force.
        options: SettleOptions,
    },
}

fn list(ids: &[u32]) -> String {
    if ids.is_empty() {
        "none".into()
    } else {
        ids.iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl fmt::Display for StreamProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Silent {
                waited_s,
                last,
                foreign,
            } => {
                write!(f, "no DTrack frame for {waited_s:.1} s (")?;
                match last {
                    Some(last) => write!(f, "{last}")?,
                    None => write!(f, "none since listening began")?,
                }
                write!(f, ")")?;
                if let Some((n, problem)) = foreign {
                    write!(
                        f,
                        "; {n} datagrams that are not DTrack ASCII output arrived, the last: {problem}"
                    )?;
                }
                write!(
                    f,
                    ": is DTrack running, and its UDP output sent to this machine and port?"
                )
            }
            Self::Stopped { last } => write!(
                f,
                "the stream stopped: no frame for {:.1} s ({last}): did DTrack stop measuring, or the network drop?",
                last.ago_s
            ),
            Self::Lost {
                target,
                in_row,
                line_missing: Some(kinds),
                ..
            } => {
                let wanted = target.line_kind();
                let carried = if kinds.is_empty() {
                    "nothing but the frame counter".to_owned()
                } else {
                    kinds
                        .iter()
                        .map(|k| format!("`{k}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                };
                let output = match target {
                    Target::Body(_) => "standard bodies (`6d`)",
                    Target::Marker(_) => "single markers (`3d`)",
                };
                write!(
                    f,
                    "{target}: no `{wanted}` line arrived in {in_row} frames (they carry {carried}): \
                     switch on DTrack's output of {output} for this UDP channel"
                )
            }
            Self::Lost {
                target,
                in_row,
                ever_seen,
                tracked,
                calibrated,
                line_missing: None,
            } => {
                let what = match target {
                    Target::Body(_) => "bodies",
                    Target::Marker(_) => "markers",
                };
                if *ever_seen {
                    write!(f, "{target} lost for {in_row} frames in a row")?;
                } else {
                    write!(f, "{target} not tracked in any of {in_row} frames")?;
                }
                write!(f, " ({what} tracked in the last frame: {}", list(tracked))?;
                if let (Target::Body(_), Some(n)) = (target, calibrated) {
                    write!(
                        f,
                        "; {n} bodies calibrated, ids 0 to {}",
                        n.saturating_sub(1)
                    )?;
                }
                write!(f, "): ")?;
                match target {
                    Target::Body(_) => write!(
                        f,
                        "is the body in view of the cameras, and is --body its id in DTrack's output (counting from 0)?"
                    ),
                    Target::Marker(_) => write!(
                        f,
                        "is the marker in view, and is `3d` output on? DTrack may give a marker a new id after losing it; a 6DOF body (--body) keeps its id"
                    ),
                }
            }
            Self::Unsettled {
                waited_s,
                frames,
                last_spread_m,
                options,
            } => {
                write!(
                    f,
                    "not {} frames within {:.3} mm in {waited_s:.1} s ({frames} frames with the target",
                    options.frames,
                    options.max_spread_m * 1e3
                )?;
                if let Some(s) = last_spread_m {
                    write!(f, ", the last window spread {:.3} mm", s * 1e3)?;
                }
                write!(
                    f,
                    "): is the arm still moving or shaking? Raise --max-spread-mm or --tracker-timeout-s, or lower --frames"
                )
            }
        }
    }
}

/// A stream this long without a frame has stopped, rather than being slow: DTrack
/// sends at the camera rate (tens to hundreds of frames per second).
pub const STOPPED_AFTER_S: f64 = 1.0;

/// Collects frames into one reading.
#[derive(Clone, Debug)]
pub struct Settler {
    target: Target,
    options: SettleOptions,
    window: VecDeque<(u64, Vector3<f64>)>,
    frames: usize,
    seen: usize,
    lost: usize,
    lost_in_row: usize,
    last_spread_m: Option<f64>,
    tracked: BTreeSet<u32>,
    calibrated: Option<u32>,
    /// Whether any frame had the target's kind of line.
    line_seen: bool,
    /// The kinds of line the frames carried.
    kinds: BTreeSet<String>,
}

impl Settler {
    /// A settler for `target`; `options.frames` is at least 1.
    pub fn new(target: Target, options: SettleOptions) -> Self {
        Self {
            target,
            options: SettleOptions {
                frames: options.frames.max(1),
                ..options
            },
            window: VecDeque::new(),
            frames: 0,
            seen: 0,
            lost: 0,
            lost_in_row: 0,
            last_spread_m: None,
            tracked: BTreeSet::new(),
            calibrated: None,
            line_seen: false,
            kinds: BTreeSet::new(),
        }
    }

    /// Takes one frame: `Ok(Some)` once a still window is complete, `Err` when
    /// the target has been lost for too long.
    pub fn push(&mut self, frame: &Frame) -> Result<Option<Reading>, StreamProblem> {
        self.frames += 1;
        self.tracked = self
            .target
            .candidates(frame)
            .iter()
            .filter(|t| t.quality > 0.0)
            .map(|t| t.id)
            .collect();
        self.calibrated = frame.calibrated_bodies.or(self.calibrated);
        let wanted = self.target.line_kind();
        self.line_seen |= frame.kinds.iter().any(|k| k == wanted);
        self.kinds.extend(frame.kinds.iter().cloned());
        let Some(position) = self.target.position_in(frame) else {
            self.lost += 1;
            self.lost_in_row += 1;
            if self.lost_in_row > self.options.max_lost_in_row {
                return Err(self.lost_problem());
            }
            return Ok(None);
        };
        self.seen += 1;
        self.lost_in_row = 0;
        self.window.push_back((frame.counter, position));
        if self.window.len() > self.options.frames {
            self.window.pop_front();
        }
        if self.window.len() < self.options.frames {
            return Ok(None);
        }
        let (mean, spread) = mean_and_spread(self.window.iter().map(|(_, p)| p))
            .expect("the window is full, so not empty");
        self.last_spread_m = Some(spread);
        if spread > self.options.max_spread_m {
            return Ok(None);
        }
        Ok(Some(Reading {
            position: mean,
            spread_m: spread,
            frames: self.window.len(),
            lost: self.lost,
            frame_range: (self.window[0].0, frame.counter),
        }))
    }

    fn lost_problem(&self) -> StreamProblem {
        StreamProblem::Lost {
            target: self.target,
            in_row: self.lost_in_row,
            ever_seen: self.seen > 0,
            tracked: self.tracked.iter().copied().collect(),
            calibrated: self.calibrated,
            line_missing: (!self.line_seen).then(|| self.kinds.iter().cloned().collect()),
        }
    }

    /// Why there is no reading after waiting `waited_s`: `last` is the last
    /// frame ever received, `foreign` the datagrams that were not DTrack output.
    pub fn give_up(
        &self,
        waited_s: f64,
        last: Option<LastFrame>,
        foreign: Option<(usize, String)>,
    ) -> StreamProblem {
        match last {
            Some(last) if last.ago_s >= STOPPED_AFTER_S => StreamProblem::Stopped { last },
            _ if self.frames == 0 => StreamProblem::Silent {
                waited_s,
                last,
                foreign,
            },
            _ if self.seen == 0 || self.lost_in_row >= self.options.frames => self.lost_problem(),
            _ => StreamProblem::Unsettled {
                waited_s,
                frames: self.seen,
                last_spread_m: self.last_spread_m,
                options: self.options,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracker::dtrack::Tracked;

    fn frame(counter: u64, body: Option<(f64, [f64; 3])>) -> Frame {
        Frame {
            counter,
            timestamp_s: Some(counter as f64 / 60.0),
            calibrated_bodies: Some(2),
            bodies: body
                .map(|(quality, mm)| Tracked {
                    id: 1,
                    quality,
                    position: Vector3::from(mm) / 1000.0,
                })
                .into_iter()
                .collect(),
            markers: vec![],
            kinds: ["ts", "6dcal", "6d"].map(String::from).to_vec(),
        }
    }

    fn options(frames: usize) -> SettleOptions {
        SettleOptions {
            frames,
            max_spread_m: 0.5e-3,
            max_lost_in_row: 5,
        }
    }

    #[test]
    fn a_still_target_is_averaged_over_the_window() {
        let mut s = Settler::new(Target::Body(1), options(4));
        let xs = [100.0, 100.2, 99.8, 100.0];
        for (i, x) in xs.iter().enumerate().take(3) {
            assert_eq!(
                s.push(&frame(i as u64, Some((1.0, [*x, 0.0, 0.0])))),
                Ok(None)
            );
        }
        let r = s
            .push(&frame(3, Some((1.0, [xs[3], 0.0, 0.0]))))
            .unwrap()
            .unwrap();
        assert!((r.position - Vector3::new(0.1, 0.0, 0.0)).norm() < 1e-12);
        assert!((r.spread_m - 0.2e-3).abs() < 1e-12);
        assert_eq!((r.frames, r.lost, r.frame_range), (4, 0, (0, 3)));
    }

    #[test]
    fn a_moving_target_slides_the_window_until_it_holds_still() {
        let mut s = Settler::new(Target::Body(1), options(4));
        // Arriving at 2 mm per frame, then holding at 120 mm.
        let path = [
            110.0, 112.0, 114.0, 116.0, 118.0, 120.0, 120.0, 120.1, 119.9,
        ];
        let mut reading = None;
        for (i, x) in path.iter().enumerate() {
            if let Some(r) = s
                .push(&frame(i as u64, Some((1.0, [*x, 5.0, 5.0]))))
                .unwrap()
            {
                reading = Some((i, r));
                break;
            }
        }
        let (i, r) = reading.expect("a reading once the target holds");
        // The first window of four within 0.5 mm: frames 5..=8.
        assert_eq!((i, r.frame_range), (8, (5, 8)));
        assert!((r.position.x - 0.120).abs() < 1e-9);
    }

    #[test]
    fn lost_frames_are_skipped_and_counted() {
        let mut s = Settler::new(Target::Body(1), options(3));
        assert_eq!(s.push(&frame(0, Some((1.0, [1.0, 2.0, 3.0])))), Ok(None));
        assert_eq!(s.push(&frame(1, None)), Ok(None));
        // Quality -1: calibrated but not tracked.
        assert_eq!(s.push(&frame(2, Some((-1.0, [0.0; 3])))), Ok(None));
        assert_eq!(s.push(&frame(3, Some((1.0, [1.0, 2.0, 3.0])))), Ok(None));
        let r = s
            .push(&frame(4, Some((1.0, [1.0, 2.0, 3.0]))))
            .unwrap()
            .unwrap();
        assert_eq!((r.frames, r.lost, r.frame_range), (3, 2, (0, 4)));
    }

    #[test]
    fn too_many_lost_in_a_row_says_what_was_seen() {
        let mut s = Settler::new(Target::Body(3), options(3));
        let mut result = Ok(None);
        for i in 0..7 {
            result = s.push(&frame(i, Some((1.0, [0.0; 3]))));
            if result.is_err() {
                break;
            }
        }
        let problem = result.unwrap_err();
        let text = problem.to_string();
        assert!(
            matches!(
                problem,
                StreamProblem::Lost {
                    in_row: 6,
                    ever_seen: false,
                    ..
                }
            ),
            "{problem:?}"
        );
        assert!(
            text.contains("body 3 not tracked in any of 6 frames"),
            "{text}"
        );
        assert!(
            text.contains("bodies tracked in the last frame: 1"),
            "{text}"
        );
        assert!(text.contains("2 bodies calibrated, ids 0 to 1"), "{text}");
    }

    #[test]
    fn giving_up_names_silence_a_stopped_stream_or_motion() {
        let last = |ago_s| {
            Some(LastFrame {
                counter: 1234,
                timestamp_s: Some(39596.02),
                ago_s,
            })
        };
        let s = Settler::new(Target::Body(1), options(3));
        let text = s.give_up(5.0, None, None).to_string();
        assert!(
            text.contains("no DTrack frame for 5.0 s (none since listening began)"),
            "{text}"
        );
        let text = s
            .give_up(0.5, last(0.5), Some((3, "line 1 (`hello`): ...".into())))
            .to_string();
        assert!(
            text.contains(
                "no DTrack frame for 0.5 s (last frame 1234 at ts 39596.020 s, 0.5 s ago)"
            ),
            "{text}"
        );
        assert!(text.contains("3 datagrams that are not DTrack"), "{text}");
        // Frames came before this reading, none since: the stream stopped.
        let text = s.give_up(5.0, last(12.5), None).to_string();
        assert!(
            text.starts_with("the stream stopped: no frame for 12.5 s (last frame 1234"),
            "{text}"
        );

        let mut s = Settler::new(Target::Body(1), options(3));
        for i in 0..6 {
            // Swinging by 2 mm every frame: never still.
            let x = if i % 2 == 0 { 0.0 } else { 2.0 };
            assert_eq!(s.push(&frame(i, Some((1.0, [x, 0.0, 0.0])))), Ok(None));
        }
        let problem = s.give_up(5.0, last(0.01), None);
        let text = problem.to_string();
        assert!(
            text.starts_with("not 3 frames within 0.500 mm in 5.0 s (6 frames"),
            "{text}"
        );
        assert!(text.contains("the last window spread"), "{text}");
        assert!(matches!(
            s.give_up(5.0, last(3.0), None),
            StreamProblem::Stopped { .. }
        ));
    }

    #[test]
    fn a_stream_without_the_targets_line_says_so_not_that_the_body_is_out_of_view() {
        let mut settler = Settler::new(Target::Body(0), SettleOptions::default());
        let only_6di = |counter| Frame {
            counter,
            timestamp_s: None,
            calibrated_bodies: Some(1),
            bodies: vec![],
            markers: vec![],
            kinds: ["6dcal", "6di"].map(String::from).to_vec(),
        };
        let problem = (0..1000)
            .find_map(|c| settler.push(&only_6di(c)).err())
            .expect("the body is given up on");
        let text = problem.to_string();
        assert!(
            text.contains("no `6d` line arrived") && text.contains("`6dcal`, `6di`"),
            "{text}"
        );
        assert!(!text.contains("in view"), "{text}");
        // One frame with a `6d` line (the body not in it): out of view again.
        let mut settler = Settler::new(Target::Body(0), SettleOptions::default());
        let text = (0..1000)
            .find_map(|c| settler.push(&frame(c, None)).err())
            .expect("the body is given up on")
            .to_string();
        assert!(text.contains("in view"), "{text}");
    }
}
