//! Positions typed or piped as text, one a line: `x y z` or `pose x y z` in
//! mm, separated by commas or spaces; blank lines, `#` comments and a header
//! line are skipped. What a tracker without a stream of our own gives
//! (copied from its software, or printed by a script).

use nalgebra::Vector3;

/// A tracker position, m, with the pose id the line names, if it names one.
pub type TrackerReading = (Option<u32>, Vector3<f64>);

/// One tracker line: `None` for a blank, comment or header line.
pub fn parse_tracker_line(line: &str) -> Result<Option<TrackerReading>, String> {
    let line = line.trim();
    if line.is_empty() || line.starts_with('#') || line.starts_with(|c: char| c.is_alphabetic()) {
        return Ok(None);
    }
    let fields: Vec<&str> = line
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|f| !f.is_empty())
        .collect();
    let numbers: Vec<f64> = fields
        .iter()
        .map(|f| f.parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<_>>()
        .ok_or_else(|| format!("expected three numbers `x y z` in mm, found `{line}`"))?;
    let mm = |x: f64, y: f64, z: f64| Vector3::new(x, y, z) / 1000.0;
    match numbers[..] {
        [x, y, z] => Ok(Some((None, mm(x, y, z)))),
        [p, x, y, z] if p >= 0.0 && p.fract() == 0.0 && p <= u32::MAX as f64 => {
            Ok(Some((Some(p as u32), mm(x, y, z))))
        }
        _ => Err(format!(
            "expected `x y z` or `pose x y z` (mm), found `{line}`"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tracker_lines_in_either_form() {
        let p = parse_tracker_line("212.41, -35.02, 188.77")
            .unwrap()
            .unwrap();
        assert_eq!(p.0, None);
        assert!((p.1 - Vector3::new(0.21241, -0.03502, 0.18877)).norm() < 1e-12);
        assert_eq!(parse_tracker_line("17 1 2 3").unwrap().unwrap().0, Some(17));
        assert_eq!(parse_tracker_line("# comment").unwrap(), None);
        assert_eq!(parse_tracker_line("x_mm,y_mm,z_mm").unwrap(), None);
        assert!(parse_tracker_line("1 2").unwrap_err().contains("expected"));
        assert!(parse_tracker_line("1 NaN 3").is_err());
        assert!(parse_tracker_line("1.5 1 2 3").is_err());
    }
}
