//! DTrack's ASCII measurement output (DTrack2 / DTrack3 "Technical Appendix"):
//! one UDP datagram per camera frame, one line per kind of data, in mm.
//!
//! ```text
//! fr 21753                                   frame counter, always first
//! ts 39596.024831                            timestamp, s since 00:00 UTC (optional)
//! 6dcal 2                                    number of calibrated bodies (optional)
//! 6d 1 [0 1.000][326.848 -187.216 109.503][-0.940508 ... 0.990286]
//! 3d 2 [88 1.000][-20.1 310.0 512.3][91 1.000][44.0 -8.2 1021.7]
//! ```
//!
//! A `6d` line holds the tracked standard bodies, each as `[id qu][x y z]` (older
//! versions add the Euler angles `η θ φ` to this block) followed by the rotation
//! matrix `[b0 .. b8]`; a `3d` line the single markers as `[id qu][x y z]`. A body
//! the cameras lost is left out of the line or has a quality of -1, depending on
//! the version; both read here as "not tracked". Every other line type
//! (`6di`, `6df2`, `6dmt2`, `gl`, `st`, …, and whatever a later DTrack adds) is
//! skipped, as DTrack's own SDK does.

use std::fmt;

use nalgebra::Vector3;

/// One datagram: what the cameras saw at one instant.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// DTrack's frame counter (`fr`).
    pub counter: u64,
    /// The controller's clock at the exposure, s since 00:00 UTC (`ts`), when sent.
    pub timestamp_s: Option<f64>,
    /// How many bodies are calibrated (`6dcal`), when sent.
    pub calibrated_bodies: Option<u32>,
    /// The `6d` bodies in the datagram.
    pub bodies: Vec<Tracked>,
    /// The `3d` single markers in the datagram.
    pub markers: Vec<Tracked>,
    /// The kind of every line after `fr`, as written (`ts`, `6d`, `6di`, …),
    /// read or skipped.
    pub kinds: Vec<String>,
}

/// A body or marker as the datagram gives it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tracked {
    /// DTrack's id (bodies count from 0).
    pub id: u32,
    /// DTrack's quality; zero or negative means not tracked.
    pub quality: f64,
    /// Position in the tracker's room frame, m.
    pub position: Vector3<f64>,
}

/// What to read from the stream: a 6DOF body or a single marker, by DTrack id.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// A standard body of the `6d` line.
    Body(u32),
    /// A single marker of the `3d` line.
    Marker(u32),
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Body(id) => write!(f, "body {id}"),
            Self::Marker(id) => write!(f, "marker {id}"),
        }
    }
}

impl Target {
    /// The kind of line that carries this target: `6d` for a standard body,
    /// `3d` for a single marker.
    pub fn line_kind(self) -> &'static str {
        match self {
            Self::Body(_) => "6d",
            Self::Marker(_) => "3d",
        }
    }

    /// The entries of this target's kind in `frame`.
    pub fn candidates(self, frame: &Frame) -> &[Tracked] {
        match self {
            Self::Body(_) => &frame.bodies,
            Self::Marker(_) => &frame.markers,
        }
    }

    /// The target's position in `frame`, if it is there and tracked.
    pub fn position_in(self, frame: &Frame) -> Option<Vector3<f64>> {
        let (Self::Body(id) | Self::Marker(id)) = self;
        self.candidates(frame)
            .iter()
            .find(|t| t.id == id && t.quality > 0.0)
            .map(|t| t.position)
    }
}

/// A datagram that is not DTrack ASCII output.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("line {line} (`{text}`): {problem}")]
pub struct DatagramError {
    /// 1-based line within the datagram.
    pub line: usize,
    /// The line, cut to 60 characters.
    pub text: String,
    /// What was expected.
    pub problem: String,
}

/// Parses one datagram.
pub fn parse(datagram: &str) -> Result<Frame, DatagramError> {
    let mut frame = Frame {
        counter: 0,
        timestamp_s: None,
        calibrated_bodies: None,
        bodies: Vec::new(),
        markers: Vec::new(),
        kinds: Vec::new(),
    };
    let mut lines = datagram
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty());
    let fail = |line: usize, text: &str, problem: String| DatagramError {
        line,
        text: text.chars().take(60).collect(),
        problem,
    };
    match lines.next() {
        Some((n, text)) => match text.split_whitespace().collect::<Vec<_>>()[..] {
            ["fr", counter] => {
                frame.counter = counter
                    .parse()
                    .map_err(|_| fail(n, text, "expected `fr <frame counter>`".into()))?;
            }
            _ => {
                return Err(fail(
                    n,
                    text,
                    "expected DTrack output, which starts with `fr <frame counter>`".into(),
                ));
            }
        },
        None => return Err(fail(1, "", "expected DTrack output, found nothing".into())),
    }
    for (n, text) in lines {
        let (kind, rest) = text.split_once(char::is_whitespace).unwrap_or((text, ""));
        frame.kinds.push(kind.to_owned());
        let result = match kind {
            "ts" => number(rest.trim(), "a timestamp in s").map(|t| frame.timestamp_s = Some(t)),
            "6dcal" => count(rest.trim()).map(|c| frame.calibrated_bodies = Some(c)),
            "6d" => entries(rest, 3, "[id qu][x y z ...][b0 .. b8]").map(|e| frame.bodies = e),
            "3d" => entries(rest, 2, "[id qu][x y z]").map(|e| frame.markers = e),
            _ => Ok(()),
        };
        result.map_err(|problem| fail(n, text, format!("`{kind}` line: {problem}")))?;
    }
    Ok(frame)
}

fn number(text: &str, what: &str) -> Result<f64, String> {
    text.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("expected {what}, found `{text}`"))
}

fn count(text: &str) -> Result<u32, String> {
    text.parse()
        .map_err(|_| format!("expected a count, found `{text}`"))
}

/// The entries of a `6d` or `3d` line: a count, then `blocks` bracketed blocks each.
fn entries(rest: &str, blocks: usize, shape: &str) -> Result<Vec<Tracked>, String> {
    let (head, mut tail) = match rest.split_once('[') {
        Some((head, body)) => (head, Some(body)),
        None => (rest, None),
    };
    let n = count(head.trim())? as usize;
    let mut groups = Vec::new();
    // `tail` starts just after a `[`; the block ends at `]`, and the next one
    // must follow after nothing but spaces.
    while let Some(t) = tail {
        let (inside, after) = t
            .split_once(']')
            .ok_or_else(|| "a block `[` is not closed by `]`".to_owned())?;
        groups.push(inside);
        let after = after.trim_start();
        tail = match after {
            "" => None,
            _ => Some(
                after
                    .strip_prefix('[')
                    .ok_or_else(|| format!("expected `[` after a block, found `{after}`"))?,
            ),
        };
    }
    if groups.len() != n * blocks {
        return Err(format!(
            "expected {n} entries of {blocks} blocks `{shape}`, found {} blocks",
            groups.len()
        ));
    }
    groups
        .chunks(blocks)
        .map(|entry| {
            let head: Vec<&str> = entry[0].split_whitespace().collect();
            let position: Vec<&str> = entry[1].split_whitespace().collect();
            let [id, quality] = head[..] else {
                return Err(format!("expected `[id qu]`, found `[{}]`", entry[0]));
            };
            if position.len() < 3 {
                return Err(format!(
                    "expected `[x y z ...]` in mm, found `[{}]`",
                    entry[1]
                ));
            }
            let mm = |i: usize| number(position[i], "a position in mm");
            Ok(Tracked {
                id: id
                    .parse()
                    .map_err(|_| format!("expected an id (integer >= 0), found `{id}`"))?,
                quality: number(quality, "a quality")?,
                position: Vector3::new(mm(0)?, mm(1)?, mm(2)?) / 1000.0,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A DTrack2 datagram as sent (CR LF line ends), with line types we skip.
    const DATAGRAM: &str = "fr 21753\r\nts 39596.024831\r\n6dcal 3\r\n\
        6d 2 [0 1.000][326.848 -187.216 109.503][-0.940508 -0.339238 -0.019025 0.333599 \
        -0.932599 0.137735 -0.064467 0.123194 0.990286][2 0.873][10.0 20.5 -30.25]\
        [1 0 0 0 1 0 0 0 1]\r\n\
        6df2 1 1 [0 1.000 8 2][261.1 116.5 41.0][1 0 0 0 1 0 0 0 1][0 0.00 0.00]\r\n\
        3d 2 [88 1.000][-20.1 310.0 512.3][91 1.000][44.0 -8.2 1021.7]\r\n\
        st 3 [0 3][4 2 1]\r\n";

    #[test]
    fn a_full_datagram_reads_bodies_markers_and_skips_the_rest() {
        let f = parse(DATAGRAM).unwrap();
        assert_eq!(f.counter, 21753);
        assert_eq!(f.timestamp_s, Some(39596.024831));
        assert_eq!(f.calibrated_bodies, Some(3));
        assert_eq!(f.bodies.len(), 2);
        assert_eq!((f.bodies[1].id, f.bodies[1].quality), (2, 0.873));
        let p = Target::Body(0).position_in(&f).unwrap();
        assert!((p - Vector3::new(0.326848, -0.187216, 0.109503)).norm() < 1e-12);
        let m = Target::Marker(91).position_in(&f).unwrap();
        assert!((m - Vector3::new(0.044, -0.0082, 1.0217)).norm() < 1e-12);
        assert_eq!(Target::Body(1).position_in(&f), None);
        assert_eq!(Target::Marker(0).position_in(&f), None);
    }

    #[test]
    fn the_older_6d_block_with_euler_angles_and_untracked_bodies() {
        let f = parse(
            "fr 7\n6d 2 [0 1.000][326.848 -187.216 109.503 -160.4704 -3.6963 -7.0913]\
             [-0.940508 -0.339238 -0.019025 0.333599 -0.932599 0.137735 -0.064467 0.123194 \
             0.990286][1 -1.000][0 0 0][0 0 0 0 0 0 0 0 0]\n",
        )
        .unwrap();
        assert!((Target::Body(0).position_in(&f).unwrap().x - 0.326848).abs() < 1e-12);
        // Quality -1: the body is calibrated but the cameras lost it.
        assert_eq!(Target::Body(1).position_in(&f), None);
        // Every line's kind is kept, the skipped ones' too.
        let kinds = parse("fr 3\n6dcal 1\n6di 1 [0 1 0][1 2 3][1 0 0 0 1 0 0 0 1]\n")
            .unwrap()
            .kinds;
        assert_eq!(kinds, ["6dcal", "6di"]);
        // `6d 0` (nothing tracked) is a valid line.
        assert!(parse("fr 8\n6d 0\n3d 0\n").unwrap().bodies.is_empty());
    }

    #[test]
    fn malformed_lines_say_which_and_what_was_expected() {
        let err = parse("hello\n").unwrap_err();
        assert_eq!(err.line, 1);
        assert!(err.problem.contains("starts with `fr"), "{err}");
        let err = parse("fr 1\n6d 2 [0 1.0][1 2 3][1 0 0 0 1 0 0 0 1]\n").unwrap_err();
        assert_eq!(err.line, 2);
        assert!(
            err.to_string().contains("expected 2 entries of 3 blocks"),
            "{err}"
        );
        let err = parse("fr 1\n3d 1 [4 1.0][1 2 x]\n").unwrap_err();
        assert!(
            err.to_string()
                .contains("expected a position in mm, found `x`"),
            "{err}"
        );
        assert!(parse("fr 1\n3d 1 [4 1.0][1 2 3\n").is_err());
        assert!(parse("fr 1\nts NaN\n").is_err());
        assert!(parse("").is_err());
    }
}
