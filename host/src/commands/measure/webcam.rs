//! `measure --webcam`: a V4L2 webcam read directly (Linux), through the
//! pure-Rust `linuxvideo` crate (the kernel's ioctls, no C library to
//! install). The device is opened once for the whole run and streams all
//! along, so its automatic exposure, white balance and focus settle once;
//! a grabber command that opens the device for every frame (`ffmpeg ...
//! -frames:v 1`) takes each frame before they have.
//!
//! A frame is taken fresh: the frames the driver queued while the arm was
//! moving are dropped first, and the next one is waited for (at most
//! [`FRAME_TIMEOUT_S`]). The device's own formats are asked in the order
//! of [`FORMATS`]: uncompressed grey or YUYV first (a corner's pixels as
//! the sensor gave them), else Motion-JPEG, decoded to grey.

use std::os::fd::{AsFd, OwnedFd};
use std::path::{Path, PathBuf};

use image::GrayImage;
use linuxvideo::format::{PixFormat, PixelFormat};
use linuxvideo::stream::ReadStream;
use linuxvideo::{BufType, Device};
use rustix::event::{PollFd, PollFlags, Timespec, poll};

use crate::error::Error;

/// How long a frame is waited for, s: a webcam streams 5-30 frames a
/// second, so one that gives none in this long has stopped.
const FRAME_TIMEOUT_S: i64 = 5;

/// The pixel formats read, in order of preference.
const FORMATS: [PixelFormat; 4] = [
    PixelFormat::from_fourcc(*b"GREY"),
    PixelFormat::YUYV,
    PixelFormat::MJPG,
    PixelFormat::JPEG,
];

/// A webcam streaming for the run.
pub(super) struct Webcam {
    /// The device file, for messages.
    device: PathBuf,
    /// The stream's device, opened again, waited on for a frame.
    fd: OwnedFd,
    /// The frames' layout, as the driver set it.
    layout: Layout,
    stream: ReadStream,
}

impl Webcam {
    /// Opens `device` at `width` × `height` pixels and starts its stream;
    /// refuses a device that is not a camera, offers none of [`FORMATS`],
    /// or not that size.
    pub(super) fn open(device: &Path, width: u32, height: u32) -> Result<Self, Error> {
        let fail = |reason: String| Error::Webcam {
            device: device.to_owned(),
            reason,
        };
        let opened = Device::open(device).map_err(|e| {
            fail(format!(
                "{e}: expected a V4L2 camera such as /dev/video0 (`v4l2-ctl --list-devices` \
                 lists them)"
            ))
        })?;
        let offered: Vec<PixelFormat> = opened
            .formats(BufType::VIDEO_CAPTURE)
            .map(|f| f.map(|f| f.pixel_format()))
            .collect::<Result<_, _>>()
            .map_err(|e| fail(format!("it lists no video formats ({e}): is it a camera?")))?;
        let Some(pixel_format) = FORMATS.into_iter().find(|f| offered.contains(f)) else {
            return Err(fail(format!(
                "it offers {}, none of GREY, YUYV, MJPG or JPEG",
                names(&offered)
            )));
        };
        let capture = opened
            .video_capture(PixFormat::new(width, height, pixel_format))
            .map_err(|e| {
                fail(format!(
                    "it refuses {width}x{height} px {pixel_format}: {e}"
                ))
            })?;
        let format = capture.format();
        if (format.width(), format.height()) != (width, height) {
            return Err(fail(format!(
                "asked for {width}x{height} px, it gives {}x{} px: pass --webcam-size with a \
                 size it offers (`v4l2-ctl --list-formats-ext` lists them) and the intrinsics \
                 of that size",
                format.width(),
                format.height()
            )));
        }
        let layout = Layout {
            width,
            height,
            stride: format.bytes_per_line() as usize,
            pixel_format: format.pixel_format(),
        };
        let fd = capture
            .as_fd()
            .try_clone_to_owned()
            .map_err(|e| fail(e.to_string()))?;
        let stream = capture
            .into_stream()
            .map_err(|e| fail(format!("its stream does not start: {e}")))?;
        Ok(Self {
            device: device.to_owned(),
            fd,
            layout,
            stream,
        })
    }

    /// The next frame the webcam takes, grey: the frames queued before
    /// this call are dropped.
    pub(super) fn grab(&mut self) -> Result<GrayImage, Error> {
        let fail = |reason: String| Error::Webcam {
            device: self.device.clone(),
            reason,
        };
        while !self.stream.will_block().map_err(|e| fail(e.to_string()))? {
            self.stream
                .dequeue(|_| Ok(()))
                .map_err(|e| fail(e.to_string()))?;
        }
        let mut ready = [PollFd::new(&self.fd, PollFlags::IN)];
        let timeout = Timespec {
            tv_sec: FRAME_TIMEOUT_S,
            tv_nsec: 0,
        };
        if poll(&mut ready, Some(&timeout)).map_err(|e| fail(e.to_string()))? == 0 {
            return Err(fail(format!("no frame in {FRAME_TIMEOUT_S} s")));
        }
        let layout = &self.layout;
        self.stream
            .dequeue(|frame| {
                if frame.is_error() {
                    return Err(std::io::Error::other("the driver flagged the frame as bad"));
                }
                layout.grey(&frame).map_err(std::io::Error::other)
            })
            .map_err(|e| fail(e.to_string()))
    }
}

/// How a frame's bytes lie.
struct Layout {
    width: u32,
    height: u32,
    /// Bytes from a row to the next (0: rows follow each other).
    stride: usize,
    pixel_format: PixelFormat,
}

impl Layout {
    /// A frame's grey pixels: the luma of grey or YUYV frames as they are,
    /// a JPEG decoded.
    fn grey(&self, data: &[u8]) -> Result<GrayImage, String> {
        let (width, height, pixel_format) = (self.width, self.height, self.pixel_format);
        let step = match pixel_format {
            f if f == FORMATS[0] => 1,
            PixelFormat::YUYV => 2,
            _ => {
                let image = image::load_from_memory_with_format(data, image::ImageFormat::Jpeg)
                    .map_err(|e| format!("a {pixel_format} frame does not decode: {e}"))?;
                if (image.width(), image.height()) != (width, height) {
                    return Err(format!(
                        "a frame decodes to {}x{} px, not the {width}x{height} px of its format",
                        image.width(),
                        image.height()
                    ));
                }
                return Ok(image.into_luma8());
            }
        };
        let row = width as usize * step;
        let stride = self.stride.max(row);
        let needed = stride * (height as usize).saturating_sub(1) + row;
        if height == 0 || data.len() < needed {
            return Err(format!(
                "a {width}x{height} px {pixel_format} frame of {} bytes, {needed} expected",
                data.len()
            ));
        }
        Ok(GrayImage::from_fn(width, height, |x, y| {
            image::Luma([data[y as usize * stride + x as usize * step]])
        }))
    }
}

/// The formats' four-character codes, for a message.
fn names(formats: &[PixelFormat]) -> String {
    if formats.is_empty() {
        return "no formats".into();
    }
    formats
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout(width: u32, height: u32, stride: usize, pixel_format: PixelFormat) -> Layout {
        Layout {
            width,
            height,
            stride,
            pixel_format,
        }
    }

    /// A 6×2 scene's grey levels.
    fn scene() -> Vec<u8> {
        (0..12).map(|i| 20 * i as u8).collect()
    }

    #[test]
    fn yuyv_frames_give_their_luma_row_by_row() {
        // Rows padded to 16 bytes, as drivers align them.
        let mut data = vec![0u8; 32];
        for (i, level) in scene().into_iter().enumerate() {
            let (x, y) = (i % 6, i / 6);
            data[16 * y + 2 * x] = level;
            data[16 * y + 2 * x + 1] = 128; // chroma
        }
        let grey = layout(6, 2, 16, PixelFormat::YUYV).grey(&data).unwrap();
        assert_eq!(grey.into_raw(), scene());
    }

    #[test]
    fn grey_and_jpeg_frames_read_as_grey() {
        let read = layout(6, 2, 0, FORMATS[0]).grey(&scene()).unwrap();
        assert_eq!(read.into_raw(), scene());

        let flat = GrayImage::from_pixel(16, 8, image::Luma([90]));
        let mut jpeg = Vec::new();
        flat.write_to(
            &mut std::io::Cursor::new(&mut jpeg),
            image::ImageOutputFormat::Jpeg(95),
        )
        .unwrap();
        let read = layout(16, 8, 0, PixelFormat::MJPG).grey(&jpeg).unwrap();
        assert!(read.pixels().all(|p| p.0[0].abs_diff(90) <= 1));
    }

    #[test]
    fn a_short_or_broken_frame_is_refused() {
        let short = layout(6, 2, 0, PixelFormat::YUYV)
            .grey(&[0; 20])
            .unwrap_err();
        assert!(short.contains("20 bytes, 24 expected"), "{short}");
        let broken = layout(6, 2, 0, PixelFormat::MJPG)
            .grey(&[0xff, 0xd8, 0])
            .unwrap_err();
        assert!(broken.contains("does not decode"), "{broken}");
    }

    #[test]
    fn a_file_that_is_no_camera_is_named() {
        let Err(e) = Webcam::open(Path::new("/nonexistent/video9"), 1280, 720) else {
            panic!("opened a missing device");
        };
        assert!(e.to_string().contains("/nonexistent/video9"), "{e}");
        let Err(e) = Webcam::open(Path::new("/dev/null"), 1280, 720) else {
            panic!("opened /dev/null as a camera");
        };
        assert!(e.to_string().contains("/dev/null"), "{e}");
    }
}
