//! Placing an arm file's body on the arm: its shape anchored on the DH
//! frames it names, checked, and the links it moves with.

use nalgebra::{IsometryMatrix3, Point3, Translation3, Vector3};

use super::body::{Anchor, Body, Shape};
use super::skeleton::Skeleton;
use super::spec::{BodySpec, FrameRef, PointSpec, ShapeSpec, SpecError, SpecPlace};

/// `value` if it is a finite number >= 0.
pub(super) fn non_negative(value: f64, place: SpecPlace) -> Result<f64, SpecError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(SpecError::new(
            place,
            format!("expected a finite size >= 0 m, found {value}"),
        ))
    }
}

/// A spec point as an anchor on a DH frame (tool points move into frame 6).
fn anchor_of(point: &PointSpec, tool: &IsometryMatrix3<f64>, joints: usize) -> Anchor {
    let p = Point3::from(point.xyz_m);
    match point.frame {
        FrameRef::Dh(frame) => Anchor {
            frame,
            offset_m: p.coords,
        },
        FrameRef::Tool => Anchor {
            frame: joints,
            offset_m: (tool * p).coords,
        },
    }
}

/// Places body `index` of the spec on the arm.
pub(super) fn place(
    index: usize,
    spec: &BodySpec,
    tool: &IsometryMatrix3<f64>,
    skeleton: &Skeleton,
) -> Result<Body, SpecError> {
    let at = |key| SpecPlace::Body { index, key };
    let joints = skeleton.joints;
    let frames = match spec.shape {
        ShapeSpec::Capsule { from, to, .. } => {
            [(from.frame, "capsule.from"), (to.frame, "capsule.to")]
        }
        ShapeSpec::Box { frame, .. } => [(frame, "box.frame"), (frame, "box.frame")],
    };
    if let Some((frame, key)) = frames.iter().find(|(f, _)| f.dh_index(joints) > joints) {
        return Err(SpecError::new(
            at(key),
            format!("expected a frame of the arm (base, j0 … j{joints} or tool), found `{frame}`"),
        ));
    }
    let (shape, ends, links) = match spec.shape {
        ShapeSpec::Capsule { from, to, radius_m } => {
            non_negative(radius_m, at("capsule.radius"))?;
            let [from_links, to_links] = [from.links(joints), to.links(joints)];
            let links = [
                from_links[0].max(to_links[0]),
                from_links[1].min(to_links[1]),
            ];
            if links[0] > links[1] {
                return Err(SpecError::new(
                    at("capsule"),
                    format!(
                        "a body must move with one link, but `from` ({}) moves with {} and `to` ({}) with {}; \
                         split it into one body per link",
                        from.frame,
                        link_names(from_links),
                        to.frame,
                        link_names(to_links)
                    ),
                ));
            }
            let shape = Shape::Capsule {
                from: anchor_of(&from, tool, joints),
                to: anchor_of(&to, tool, joints),
                radius_m,
            };
            (shape, [from.frame, to.frame], links)
        }
        ShapeSpec::Box {
            frame,
            min_m,
            max_m,
        } => {
            let finite = min_m.iter().chain(&max_m).all(|x| x.is_finite());
            if let Some(axis) = (0..3).find(|&k| !finite || min_m[k] > max_m[k]) {
                return Err(SpecError::new(
                    at("box"),
                    format!(
                        "expected `min` <= `max` on every axis, found {} > {} on {}",
                        min_m[axis],
                        max_m[axis],
                        ["x", "y", "z"][axis]
                    ),
                ));
            }
            let centre = (Vector3::from(min_m) + Vector3::from(max_m)) / 2.0;
            let in_frame =
                IsometryMatrix3::from_parts(Translation3::from(centre), Default::default());
            let (dh, placement) = match frame {
                FrameRef::Dh(i) => (i, in_frame),
                FrameRef::Tool => (joints, tool * in_frame),
            };
            let shape = Shape::Box {
                frame: dh,
                placement,
                half_extents_m: (Vector3::from(max_m) - Vector3::from(min_m)) / 2.0,
            };
            (shape, [frame, frame], [dh, dh])
        }
    };
    let arcs = ends.map(|f| skeleton.arc_of(f));
    Ok(Body {
        name: spec.name.clone(),
        shapes: vec![shape],
        links,
        span_m: [arcs[0].min(arcs[1]), arcs[0].max(arcs[1])],
        floor: spec.floor.unwrap_or(links[0] >= 2),
    })
}

/// `link 2` or `links 2 and 3`.
fn link_names([lo, hi]: [usize; 2]) -> String {
    if lo == hi {
        format!("link {lo}")
    } else {
        format!("links {lo} and {hi}")
    }
}
