//! The bit image of a tag36h11 tag, taken from the AprilTag C library that
//! defines the family (`apriltag_to_image`), so a rendered board carries the
//! very codes the detector looks for.

// The bit images come from the C library through its FFI.
#![allow(unsafe_code)]

/// Cells across a tag36h11 bit image: the white border, the black border, 6 bits.
pub const CELLS: usize = 10;

/// The bit image of tag `id`, `CELLS` × `CELLS` grey levels (0 black, 255
/// white) row by row from the top of the tag seen upright; `None` for an id
/// outside the family.
pub fn tag36h11(id: u32) -> Option<Vec<u8>> {
    if id >= lrmcal_core::camera::board::TAG36H11_IDS {
        return None;
    }
    let index = std::os::raw::c_int::try_from(id).ok()?;
    // SAFETY: the family and the image are the library's, created here, read
    // while alive within the image's own width, height and stride, and each
    // destroyed once; the id is within the family (checked above).
    unsafe {
        let family = apriltag_sys::tag36h11_create();
        let image = apriltag_sys::apriltag_to_image(family, index);
        let im = &*image;
        let bits = (im.width == CELLS as i32 && im.height == CELLS as i32).then(|| {
            let stride = usize::try_from(im.stride).unwrap_or(CELLS);
            (0..CELLS * CELLS)
                .map(|k| *im.buf.add(k / CELLS * stride + k % CELLS))
                .collect()
        });
        apriltag_sys::image_u8_destroy(image);
        apriltag_sys::tag36h11_destroy(family);
        bits
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tag36h11 image: a white outer ring, a black ring inside it, and
    /// tags differ; ids past the family have none.
    #[test]
    fn tags_have_their_borders_and_differ() {
        let a = tag36h11(0).unwrap();
        let b = tag36h11(586).unwrap();
        assert_ne!(a, b);
        for bits in [&a, &b] {
            for k in 0..CELLS {
                for (r, c) in [(0, k), (CELLS - 1, k), (k, 0), (k, CELLS - 1)] {
                    assert_eq!(bits[r * CELLS + c], 255);
                }
            }
            for k in 1..CELLS - 1 {
                for (r, c) in [(1, k), (CELLS - 2, k), (k, 1), (k, CELLS - 2)] {
                    assert_eq!(bits[r * CELLS + c], 0);
                }
            }
        }
        assert_eq!(tag36h11(587), None);
    }
}
