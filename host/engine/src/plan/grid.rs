//! The candidate grid: every joint at every level, `L^n` poses for an arm
//! of `n` joints, each with a stable id.

use std::fmt;
use std::str::FromStr;

use model::PerJoint;

use lrmcal_core::dataset::Pose;

/// The most poses a grid may have: 10 levels of six joints (10^6 poses) is already more than
/// pose selection can use, and more would only fill memory.
pub const MAX_GRID_POSES: usize = 1_000_000;

/// The angles every joint takes in the grid, rad, strictly increasing.
#[derive(Clone, Debug, PartialEq)]
pub struct Levels(Vec<f64>);

impl Levels {
    /// The paper's grid: -100°, 0°, +100°.
    pub fn paper() -> Self {
        Self(vec![-100f64.to_radians(), 0.0, 100f64.to_radians()])
    }

    /// `count` levels evenly spaced from -100° to +100° (`count >= 2`).
    pub fn even(count: usize) -> Result<Self, LevelsError> {
        if count < 2 {
            return Err(LevelsError::TooFewEven { count });
        }
        let step = 200.0 / (count - 1) as f64;
        Self::from_degrees((0..count).map(|i| -100.0 + step * i as f64).collect())
    }

    /// Levels given in degrees, in any order; they must be finite and distinct.
    pub fn from_degrees(mut degrees: Vec<f64>) -> Result<Self, LevelsError> {
        if let Some(&bad) = degrees.iter().find(|d| !d.is_finite()) {
            return Err(LevelsError::NotFinite {
                found: bad.to_string(),
            });
        }
        degrees.sort_by(f64::total_cmp);
        if let Some(w) = degrees.windows(2).find(|w| w[0] == w[1]) {
            return Err(LevelsError::Repeated { degrees: w[0] });
        }
        if degrees.is_empty() {
            return Err(LevelsError::Empty);
        }
        Ok(Self(degrees.into_iter().map(f64::to_radians).collect()))
    }

    /// The levels, rad, increasing.
    pub fn radians(&self) -> &[f64] {
        &self.0
    }

    /// Number of grid poses for an arm of `joints` joints, `levels^joints`,
    /// or the error when it is more than [`MAX_GRID_POSES`].
    pub fn grid_size(&self, joints: usize) -> Result<usize, LevelsError> {
        let count = self.0.len();
        count
            .checked_pow(joints as u32)
            .filter(|&n| n <= MAX_GRID_POSES)
            .ok_or(LevelsError::TooMany { count, joints })
    }

    /// Every pose of the grid of an arm of `joints` joints (none when it is
    /// too large, [`Levels::grid_size`]). The id is the pose's index with
    /// joint 1 as the most significant digit and the last joint the least:
    /// in the 3-level grid of six joints pose 0 is all joints at -100°, 364
    /// all at 0°, 728 all at +100°.
    pub fn grid(&self, joints: usize) -> impl Iterator<Item = Pose> + '_ {
        let n = self.0.len();
        (0..self.grid_size(joints).unwrap_or(0)).map(move |index| {
            let mut rest = index;
            let mut q = PerJoint::splat(joints, 0.0);
            for qi in q.iter_mut().rev() {
                *qi = self.0[rest % n];
                rest /= n;
            }
            Pose {
                id: index as u32,
                q,
            }
        })
    }
}

impl Default for Levels {
    fn default() -> Self {
        Self::paper()
    }
}

impl fmt::Display for Levels {
    /// The levels in degrees, comma-separated (the form [`Levels::from_str`] reads).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let degrees: Vec<String> = self
            .0
            .iter()
            .map(|r| format!("{}", (r.to_degrees() * 1e9).round() / 1e9))
            .collect();
        f.write_str(&degrees.join(","))
    }
}

impl FromStr for Levels {
    type Err = LevelsError;

    /// `N` (an integer, N levels evenly from -100° to +100°) or a
    /// comma-separated list of angles in degrees, e.g. `-100,0,100`.
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let text = text.trim();
        if !text.contains(',')
            && let Ok(count) = text.parse::<usize>()
        {
            return Self::even(count);
        }
        let degrees = text
            .split(',')
            .map(|cell| {
                let cell = cell.trim();
                cell.parse::<f64>().map_err(|_| LevelsError::NotANumber {
                    found: cell.to_owned(),
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Self::from_degrees(degrees)
    }
}

/// Why a set of grid levels is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LevelsError {
    /// An even grid needs at least its two ends.
    #[error("expected at least 2 evenly spaced levels, found {count}")]
    TooFewEven {
        /// The count given.
        count: usize,
    },
    /// No levels at all.
    #[error("expected at least one level")]
    Empty,
    /// A level is not a number.
    #[error(
        "expected a level count (e.g. `5`) or angles in degrees (e.g. `-100,0,100`), found `{found}`"
    )]
    NotANumber {
        /// The text found.
        found: String,
    },
    /// A level is NaN or infinite.
    #[error("expected finite angles in degrees, found {found}")]
    NotFinite {
        /// The value found.
        found: String,
    },
    /// The same level twice would give duplicate poses.
    #[error("level {degrees}° is given twice; expected distinct levels")]
    Repeated {
        /// The repeated level, degrees.
        degrees: f64,
    },
    /// The grid would be too large.
    #[error(
        "{count} levels make {count}^{joints} poses for an arm of {joints} joints; expected at most {MAX_GRID_POSES}"
    )]
    TooMany {
        /// The number of levels.
        count: usize,
        /// The arm's joints.
        joints: usize,
    },
}

#[cfg(test)]
mod tests {
    use super::*;
    use model::testing::TEST_ARM_JOINTS as JOINTS;

    #[test]
    fn paper_grid_has_729_poses_with_stable_ids() {
        let levels: Levels = "-100,0,100".parse().unwrap();
        assert_eq!(levels, Levels::paper());
        let poses: Vec<Pose> = levels.grid(6).collect();
        assert_eq!(poses.len(), 729);
        let h = 100f64.to_radians();
        assert_eq!(poses[0].q, [-h; JOINTS]);
        assert_eq!(poses[364].q, [0.0; JOINTS]);
        assert_eq!(poses[728].q, [h; JOINTS]);
        // Joint 6 is the fastest digit, joint 1 the slowest.
        assert_eq!(poses[1].q, [-h, -h, -h, -h, -h, 0.0]);
        assert_eq!(poses[243].q, [0.0, -h, -h, -h, -h, -h]);
        assert!(poses.iter().enumerate().all(|(i, p)| p.id == i as u32));
    }

    #[test]
    fn a_count_gives_an_even_grid() {
        let levels: Levels = "5".parse().unwrap();
        assert_eq!(levels.to_string(), "-100,-50,0,50,100");
        assert_eq!(levels.grid_size(6), Ok(15625));
        assert_eq!("2".parse::<Levels>().unwrap().to_string(), "-100,100");
        assert_eq!(
            " 0, -45 ,45".parse::<Levels>().unwrap().to_string(),
            "-45,0,45"
        );
    }

    #[test]
    fn bad_levels_say_what_was_expected() {
        let err = |s: &str| s.parse::<Levels>().unwrap_err().to_string();
        assert!(err("1").contains("at least 2"), "{}", err("1"));
        assert!(err("-100,x,100").contains("`x`"));
        assert!(err("-100,,100").contains("found ``"));
        assert!(err("0,0").contains("given twice"));
        assert!(err("nan,1").contains("finite"));
        let eleven: Levels = "11".parse().unwrap();
        let e = eleven.grid_size(6).unwrap_err().to_string();
        assert!(e.contains("11^6") && e.contains("at most"), "{e}");
        assert_eq!(eleven.grid_size(5), Ok(161_051));
        assert!(err("").contains("level count"));
    }
}
