//! The AprilTag detector on rendered boards whose corners are known: every
//! tag found with its id, each corner within half a pixel in the board's
//! order and OpenCV's pixel convention, whichever way the board is turned.

#[path = "common/tags.rs"]
mod tags;

use lrmcal_engine::camera::detect::{Grey, TagDetector};
use tags::{HEIGHT, View, WIDTH, board, render};

/// Detects the board in the image `view` renders; returns each corner's
/// error (detected less true), px.
fn corner_errors(view: View) -> Vec<[f64; 2]> {
    let board = board();
    let image = render(&board, view);
    let mut detector = TagDetector::new().unwrap();
    let grey = Grey {
        width: WIDTH,
        height: HEIGHT,
        pixels: &image.pixels,
    };
    let found = detector.detect(grey, &board).unwrap();
    assert_eq!(found.foreign, 0, "{view:?}");
    let ids: Vec<u32> = found.tags.iter().map(|t| t.id).collect();
    let expected: Vec<u32> = image.truth.iter().map(|(id, _)| *id).collect();
    assert_eq!(ids, expected, "{view:?}");
    let mut errors = Vec::new();
    for (tag, (_, truth)) in found.tags.iter().zip(&image.truth) {
        for (k, (c, t)) in tag.corners_px.iter().zip(truth).enumerate() {
            let e = (c[0] - t[0]).hypot(c[1] - t[1]);
            assert!(
                e < 0.5,
                "{view:?}: tag {} corner {k} at {c:?}, truth {t:?}",
                tag.id
            );
            errors.push([c[0] - t[0], c[1] - t[1]]);
        }
    }
    errors
}

#[test]
fn corners_are_found_in_order_within_half_a_pixel_whichever_way_the_board_turns() {
    let mut all = Vec::new();
    for (roll_deg, tilt_deg) in [(0.0, 0.0), (90.0, 0.0), (180.0, 0.0), (20.0, 40.0)] {
        let view = View {
            roll_deg,
            tilt_deg,
            distance_m: 0.8,
        };
        let signed = corner_errors(view);
        let n = signed.len() as f64;
        let mean = [0, 1].map(|axis| signed.iter().map(|e| e[axis]).sum::<f64>() / n);
        // The bias left depends on where the edges fall within their pixels
        // (the same for every tag of an upright board); seen tilted, the
        // edges fall everywhere and the mean tells the half-pixel convention.
        if tilt_deg != 0.0 {
            assert!(mean[0].abs() < 0.05 && mean[1].abs() < 0.05, "{mean:?}");
        }
        let mut errors: Vec<f64> = signed.iter().map(|[du, dv]| du.hypot(*dv)).collect();
        errors.sort_by(f64::total_cmp);
        eprintln!(
            "roll {roll_deg} deg, tilt {tilt_deg} deg: median {:.3} px, max {:.3} px, \
             mean ({:.3}, {:.3}) px",
            errors[errors.len() / 2],
            errors[errors.len() - 1],
            mean[0],
            mean[1]
        );
        all.extend(errors);
    }
    all.sort_by(f64::total_cmp);
    eprintln!(
        "all views: median {:.3} px, max {:.3} px over {} corners",
        all[all.len() / 2],
        all[all.len() - 1],
        all.len()
    );
}

#[test]
fn tags_off_the_board_are_counted_not_returned() {
    let image = render(
        &board(),
        View {
            roll_deg: 0.0,
            tilt_deg: 0.0,
            distance_m: 0.8,
        },
    );
    // Ids 7 and 8 of the six rendered (5 to 10).
    let mut smaller = board();
    smaller.rows = 1;
    smaller.cols = 2;
    smaller.first_id = 7;
    let found = TagDetector::new()
        .unwrap()
        .detect(
            Grey {
                width: WIDTH,
                height: HEIGHT,
                pixels: &image.pixels,
            },
            &smaller,
        )
        .unwrap();
    let ids: Vec<u32> = found.tags.iter().map(|t| t.id).collect();
    assert_eq!((ids, found.foreign), (vec![7, 8], 4));
}
