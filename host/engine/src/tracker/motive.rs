//! OptiTrack Motive's CSV export of a take (Format Version 1.2x, Motive 2 and 3).
//!
//! ```text
//! Format Version,1.23,Take Name,arm-run,...,Rotation Type,Quaternion,Length Units,Meters,Coordinate Space,Global
//!
//! ,Type,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Rigid Body,...
//! ,Name,Tool,Tool,Tool,Tool,Tool,Tool,Tool,...
//! ,ID,1,1,1,1,1,1,1,...
//! ,,Rotation,Rotation,Rotation,Rotation,Position,Position,Position,...
//! Frame,Time (Seconds),X,Y,Z,W,X,Y,Z,...
//! 0,0.000000,0.012,-0.970,0.011,0.240,0.210533,0.180119,-0.035017,...
//! ```
//!
//! The first line is the export's settings as key, value pairs; then one row
//! each names the asset type, name and id of every column, the quantity
//! (`Rotation`, `Position`, `Mean Marker Error`, `Marker Quality`) and the
//! component. Positions are in the header's `Length Units` (Motive's setting:
//! metres, centimetres or millimetres) and in Motive's frame, Y up unless the
//! export set another axis convention, which the file does not record. A frame
//! where the asset was not tracked has empty cells.

use std::collections::HashMap;
use std::fmt;

use csv::{ReaderBuilder, StringRecord};
use nalgebra::Vector3;

use lrmcal_core::error::Location;

use super::still::Sample;

/// Which asset of the take to read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Asset<'a> {
    /// A rigid body, by name: its pivot point.
    RigidBody(&'a str),
    /// A labelled marker, by name (as in the export, e.g. `Tool:Marker1`).
    Marker(&'a str),
}

impl Asset<'_> {
    fn kind(self) -> &'static str {
        match self {
            Self::RigidBody(_) => "Rigid Body",
            Self::Marker(_) => "Marker",
        }
    }

    fn name(self) -> &'static str {
        match self {
            Self::RigidBody(_) => "rigid body",
            Self::Marker(_) => "marker",
        }
    }
}

impl fmt::Display for Asset<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (Self::RigidBody(n) | Self::Marker(n)) = self;
        write!(f, "{} `{n}`", self.name())
    }
}

/// The length units Motive exports, as the header names them, in m.
pub const UNITS: [(&str, f64); 3] = [
    ("Meters", 1.0),
    ("Centimeters", 0.01),
    ("Millimeters", 0.001),
];

/// The track of one asset through a take.
#[derive(Clone, Debug, PartialEq)]
pub struct Take {
    /// The take's name, from the header.
    pub name: Option<String>,
    /// The header's `Length Units`.
    pub units: String,
    /// One sample per exported frame, positions converted to m.
    pub samples: Vec<Sample>,
}

/// A problem in a take file: where, and what was expected.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{location}{problem}")]
pub struct TakeError {
    /// Line and column.
    pub location: Location,
    /// What is wrong and what was expected.
    pub problem: String,
}

fn error(location: Location, problem: impl Into<String>) -> TakeError {
    TakeError {
        location,
        problem: problem.into(),
    }
}

fn line_of(text: &str, record: &StringRecord) -> u64 {
    lrmcal_core::io::record_line(text, record.position(), None)
}

/// Reads the track of `asset` from Motive CSV text.
pub fn parse(text: &str, asset: Asset<'_>) -> Result<Take, TakeError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    // Lines counted alike whatever the line ends.
    let text = lrmcal_core::io::lf_line_ends(text);
    let line_of = |record: &StringRecord| line_of(&text, record);
    let mut records = ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(text.as_bytes())
        .into_records();
    let mut next = || -> Result<Option<StringRecord>, TakeError> {
        records.next().transpose().map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            error(Location::line(line), e.to_string())
        })
    };

    let settings = next()?.unwrap_or_default();
    if settings.get(0) != Some("Format Version") {
        return Err(error(
            Location::line(1),
            "expected a Motive CSV export, whose first line starts with `Format Version` \
             (export with the \"Header information\" option on)",
        ));
    }
    let setting: HashMap<&str, &str> = settings
        .iter()
        .collect::<Vec<_>>()
        .chunks(2)
        .filter_map(|kv| Some((kv[0], *kv.get(1)?)))
        .collect();
    let units = *setting.get("Length Units").ok_or_else(|| {
        error(
            Location::line(1),
            "expected a `Length Units` setting in the header (Motive writes it since \
             Format Version 1.2; export again with a current Motive)",
        )
    })?;
    let expected_units = || UNITS.iter().map(|(u, _)| *u).collect::<Vec<_>>().join(", ");
    let scale = UNITS
        .iter()
        .find(|(u, _)| *u == units)
        .map(|(_, m)| *m)
        .ok_or_else(|| {
            error(
                Location::column(1, "Length Units"),
                format!("expected one of {}, found `{units}`", expected_units()),
            )
        })?;
    if let Some(space) = setting.get("Coordinate Space").filter(|s| **s != "Global") {
        return Err(error(
            Location::column(1, "Coordinate Space"),
            format!(
                "expected `Global` (positions in the capture volume's frame), found `{space}`; \
                 export with Coordinate Space set to Global"
            ),
        ));
    }

    // The description rows, up to the component row that starts with `Frame`.
    let mut rows: Vec<StringRecord> = Vec::new();
    let axes = loop {
        let Some(record) = next()? else {
            return Err(error(
                Location::line(rows.last().map_or(1, line_of)),
                "expected the column header row `Frame,Time (Seconds),X,Y,Z,...`, found the end of the file",
            ));
        };
        if record.get(0) == Some("Frame") {
            break record;
        }
        rows.push(record);
    };
    let axes_line = line_of(&axes);
    let labelled = |label: &str| rows.iter().find(|r| r.get(1) == Some(label));
    let missing = |label: &str| {
        error(
            Location::line(axes_line),
            format!("expected a `{label}` row above the column header row"),
        )
    };
    let types = labelled("Type").ok_or_else(|| missing("Type"))?;
    let names = labelled("Name").ok_or_else(|| missing("Name"))?;
    // The quantity row is the one right above the component row, unlabelled.
    let quantities = rows
        .last()
        .filter(|r| r.get(0) == Some("") && r.get(1) == Some(""))
        .ok_or_else(|| missing("Position"))?;
    if !axes.get(1).is_some_and(|t| t.starts_with("Time")) {
        return Err(error(
            Location::line(axes_line),
            format!(
                "expected `Time (Seconds)` in the second column, found `{}`",
                axes.get(1).unwrap_or("")
            ),
        ));
    }

    let (Asset::RigidBody(wanted) | Asset::Marker(wanted)) = asset;
    let column = |axis: &str| {
        (2..axes.len()).find(|&c| {
            types.get(c) == Some(asset.kind())
                && names.get(c) == Some(wanted)
                && quantities.get(c) == Some("Position")
                && axes.get(c) == Some(axis)
        })
    };
    let (Some(cx), Some(cy), Some(cz)) = (column("X"), column("Y"), column("Z")) else {
        return Err(error(
            Location::line(line_of(names)),
            format!(
                "expected a {} named `{wanted}` with Position X, Y and Z columns; the take has {}",
                asset.name(),
                inventory(types, names)
            ),
        ));
    };

    let mut samples = Vec::new();
    while let Some(record) = next()? {
        let line = line_of(&record);
        let time = record.get(1).unwrap_or("");
        let time_s = time
            .parse::<f64>()
            .ok()
            .filter(|t| t.is_finite())
            .ok_or_else(|| {
                error(
                    Location::column(line, "Time (Seconds)"),
                    format!("expected a time in s, found `{time}`"),
                )
            })?;
        if samples.last().is_some_and(|s: &Sample| s.time_s > time_s) {
            return Err(error(
                Location::column(line, "Time (Seconds)"),
                format!("expected times in increasing order, found {time_s} after a later one"),
            ));
        }
        // Motive leaves all three cells empty where the asset was not tracked.
        let cells = [cx, cy, cz].map(|c| record.get(c).unwrap_or("").trim());
        let position = if cells.iter().all(|c| c.is_empty()) {
            None
        } else {
            let mut xyz = [0.0; 3];
            for ((v, cell), axis) in xyz.iter_mut().zip(cells).zip(["X", "Y", "Z"]) {
                *v = cell
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| {
                        error(
                            Location::column(line, format!("{wanted} Position {axis}")),
                            format!(
                                "expected a position in {}, or all three cells empty, found `{cell}`",
                                units.to_lowercase()
                            ),
                        )
                    })?;
            }
            Some(Vector3::from(xyz) * scale)
        };
        samples.push(Sample { time_s, position });
    }
    if samples.is_empty() {
        return Err(error(
            Location::line(axes_line),
            "expected frames after the column header row, found none",
        ));
    }
    Ok(Take {
        name: setting.get("Take Name").map(|s| (*s).to_owned()),
        units: units.to_owned(),
        samples,
    })
}

/// `rigid bodies A, B; markers C` from the Type and Name rows.
fn inventory(types: &StringRecord, names: &StringRecord) -> String {
    let mut out: Vec<String> = Vec::new();
    for (kind, label) in [("Rigid Body", "rigid bodies"), ("Marker", "markers")] {
        let mut found: Vec<&str> = Vec::new();
        for c in 2..types.len() {
            if let (Some(k), Some(name)) = (types.get(c), names.get(c))
                && k == kind
                && !found.contains(&name)
            {
                found.push(name);
            }
        }
        if !found.is_empty() {
            out.push(format!("{label} {}", found.join(", ")));
        }
    }
    if out.is_empty() {
        "no rigid bodies or markers".into()
    } else {
        out.join("; ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "Format Version,1.23,Take Name,run 1,Take Notes,,Capture Frame Rate,100.000000,\
Export Frame Rate,100.000000,Capture Start Time,2026-03-14 10.02.11.250 AM,Total Frames in Take,3,\
Total Exported Frames,3,Rotation Type,Quaternion,Length Units,Millimeters,Coordinate Space,Global\n\n\
,Type,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Rigid Body,Marker,Marker,Marker\n\
,Name,Tool,Tool,Tool,Tool,Tool,Tool,Tool,Tool,Base:M1,Base:M1,Base:M1\n\
,ID,1,1,1,1,1,1,1,1,\"7A1\",\"7A1\",\"7A1\"\n\
,,Rotation,Rotation,Rotation,Rotation,Position,Position,Position,Mean Marker Error,Position,Position,Position\n\
Frame,Time (Seconds),X,Y,Z,W,X,Y,Z,,X,Y,Z\n";

    fn text(rows: &str) -> String {
        format!("{HEADER}{rows}")
    }

    #[test]
    fn positions_of_a_rigid_body_or_a_marker_in_metres() {
        let t = text(
            "0,0.000000,0,0,0,1,210.5,180.25,-35.0,0.0001,1,2,3\n\
             1,0.010000,,,,,,,,,4,5,6\n\
             2,0.020000,0,0,0,1,210.7,180.25,-35.0,0.0001,,,\n",
        );
        let take = parse(&t, Asset::RigidBody("Tool")).unwrap();
        assert_eq!(
            (take.name.as_deref(), take.units.as_str()),
            (Some("run 1"), "Millimeters")
        );
        let p: Vec<_> = take.samples.iter().map(|s| s.position).collect();
        assert!((p[0].unwrap() - Vector3::new(0.2105, 0.18025, -0.035)).norm() < 1e-12);
        assert_eq!(p[1], None);
        assert_eq!(take.samples[2].time_s, 0.02);
        let marker = parse(&t, Asset::Marker("Base:M1")).unwrap();
        assert!((marker.samples[1].position.unwrap().z - 0.006).abs() < 1e-12);
        assert_eq!(marker.samples[2].position, None);
    }

    #[test]
    fn bad_takes_name_the_line_and_what_was_expected() {
        let rows = "0,0.0,0,0,0,1,1,2,3,0,1,2,3\n";
        let err = |t: &str, asset| parse(t, asset).unwrap_err().to_string();

        let e = err(&text(rows), Asset::RigidBody("Probe"));
        assert!(
            e.starts_with("line 4: expected a rigid body named `Probe`"),
            "{e}"
        );
        assert!(
            e.contains("the take has rigid bodies Tool; markers Base:M1"),
            "{e}"
        );

        let e = err(
            &text(rows).replace("Length Units,Millimeters", "Length Units,Inches"),
            Asset::RigidBody("Tool"),
        );
        assert!(
            e.starts_with("line 1, column `Length Units`: expected one of Meters, Centimeters, Millimeters, found `Inches`"),
            "{e}"
        );
        let e = err(
            &text(rows).replace(",Length Units,Millimeters", ""),
            Asset::RigidBody("Tool"),
        );
        assert!(
            e.starts_with("line 1: expected a `Length Units` setting"),
            "{e}"
        );
        let e = err(
            &text(rows).replace("Global", "Local"),
            Asset::RigidBody("Tool"),
        );
        assert!(e.contains("expected `Global`"), "{e}");

        let e = err(
            &text("0,0.0,0,0,0,1,1,x,3,0,1,2,3\n"),
            Asset::RigidBody("Tool"),
        );
        assert!(
            e.starts_with("line 8, column `Tool Position Y`: expected a position in millimeters"),
            "{e}"
        );
        let e = err(
            &text("0,0.1,0,0,0,1,1,2,3\n1,0.0,0,0,0,1,1,2,3\n"),
            Asset::RigidBody("Tool"),
        );
        assert!(
            e.starts_with("line 9, column `Time (Seconds)`: expected times in increasing"),
            "{e}"
        );
        // The same lines with Windows line ends, and with a blank line
        // before the rows (the csv reader places a row after one on the
        // line above).
        let windows = text("0,0.1,0,0,0,1,1,2,3\n1,0.0,0,0,0,1,1,2,3\n").replace('\n', "\r\n");
        let e = err(&windows, Asset::RigidBody("Tool"));
        assert!(e.starts_with("line 9, column `Time (Seconds)`"), "{e}");
        let e = err(
            &text("0,0.0,0,0,0,1,1,2,3,0,1,2,3\n\n1,0.1,0,0,0,1,1,x,3,0,1,2,3\n"),
            Asset::RigidBody("Tool"),
        );
        assert!(e.starts_with("line 10, column `Tool Position Y`"), "{e}");
        let e = err(&text(""), Asset::RigidBody("Tool"));
        assert!(e.contains("found none"), "{e}");
        let e = err("Frame,Time\n0,0\n", Asset::RigidBody("Tool"));
        assert!(e.starts_with("line 1: expected a Motive CSV export"), "{e}");
    }
}
