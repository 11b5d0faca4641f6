//! The DTrack listener against a fake DTrack sender on loopback: a stream
//! shaped like a real one (arm moving, ringing, then holding with 0.05 mm
//! jitter; dropped frames; the body briefly lost; line types we skip), one
//! that stops, one without the body, no stream at all, and frames queued
//! during a move that must not count.

use std::net::{SocketAddr, UdpSocket};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use lrmcal_engine::tracker::listen::Listener;
use lrmcal_engine::tracker::{SettleOptions, StreamProblem, Target, TrackerError};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Where the arm holds, mm.
const HOLD_MM: [f64; 3] = [412.25, -130.5, 287.75];
/// Frame interval of the fake stream (DTrack runs at 60 to 300 Hz).
const FRAME: Duration = Duration::from_millis(4);

/// The body's position at frame `i`, mm: 40 frames moving in at 1 mm per
/// frame, then a ring of 2 mm decaying with a time constant of 8 frames, then
/// still; jitter on top.
fn scripted_mm(i: u64, rng: &mut ChaCha8Rng) -> Vector3<f64> {
    let hold = Vector3::from(HOLD_MM);
    let jitter = Normal::new(0.0, 0.05).unwrap();
    let noise = Vector3::from_fn(|_, _| jitter.sample(rng));
    let offset = if i < 40 {
        Vector3::new(40.0 - i as f64, 0.0, 0.0)
    } else {
        let t = (i - 40) as f64;
        Vector3::new(0.0, 0.0, 2.0 * (-t / 8.0).exp() * (t * 0.9).cos())
    };
    hold + offset + noise
}

/// One datagram as DTrack2 sends it: body 1 tracked (or with quality -1),
/// body 0 elsewhere, a hybrid-body and a status line we skip.
fn datagram(i: u64, body: Option<Vector3<f64>>) -> String {
    let rot = "[1.000000 0.000000 0.000000 0.000000 1.000000 0.000000 0.000000 0.000000 1.000000]";
    let body1 = match body {
        Some(p) => format!("[1 1.000][{:.3} {:.3} {:.3}]{rot}", p.x, p.y, p.z),
        None => format!("[1 -1.000][0.000 0.000 0.000]{rot}"),
    };
    format!(
        "fr {}\r\nts {:.6}\r\n6dcal 2\r\n6d 2 [0 1.000][-50.000 20.000 900.000]{rot}{body1}\r\n\
         6di 0\r\nst 1 [0 3][6 2 0]\r\n",
        1000 + i,
        43_200.0 + i as f64 * FRAME.as_secs_f64()
    )
}

/// A fake DTrack sending the scripted stream to `to`, `frames` frames (or
/// until stopped): every 13th datagram is lost on the way and frames 66..76
/// have the body lost, as when an arm link crosses a camera's view.
struct Sender {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Sender {
    fn start(to: SocketAddr, frames: u64) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let stopped = stop.clone();
        let thread = std::thread::spawn(move || {
            let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
            let mut rng = ChaCha8Rng::seed_from_u64(7);
            // Start once the reader listens, so that it sees the whole script.
            std::thread::sleep(Duration::from_millis(100));
            for i in 0..frames {
                if stopped.load(Ordering::Relaxed) {
                    break;
                }
                let position = scripted_mm(i, &mut rng);
                let body = (!(66..76).contains(&i)).then_some(position);
                if i % 13 != 12 {
                    let _ = socket.send_to(datagram(i, body).as_bytes(), to);
                }
                std::thread::sleep(FRAME);
            }
        });
        Self {
            stop,
            thread: Some(thread),
        }
    }
}

impl Drop for Sender {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn listener() -> Listener {
    Listener::bind("127.0.0.1:0".parse().unwrap()).unwrap()
}

const OPTIONS: SettleOptions = SettleOptions {
    frames: 20,
    max_spread_m: 0.25e-3,
    max_lost_in_row: 30,
};

#[test]
fn a_realistic_stream_gives_the_held_position_after_the_ringing() {
    let mut l = listener();
    let _sender = Sender::start(l.local_addr(), 2000);
    let r = l
        .read(Target::Body(1), OPTIONS, Duration::from_secs(5))
        .unwrap();
    let error_mm = (r.position * 1000.0 - Vector3::from(HOLD_MM)).norm();
    // 20 frames of 0.05 mm jitter: the mean is off by ~0.02 mm, and the ring
    // has decayed below the spread before the window is accepted.
    assert!(error_mm < 0.08, "{error_mm} mm off, {r:?}");
    assert!(r.spread_m <= 0.25e-3);
    assert_eq!(r.frames, 20);
    // Not while moving or ringing: 2 mm e^(-t/8) is still 0.57 mm at frame 50.
    assert!(r.frame_range.0 >= 1000 + 50, "{r:?}");
    // The brief loss (frames 66..76) is skipped and counted; the window
    // spans it.
    assert!(r.lost >= 10 && r.frame_range.0 < 1066, "{r:?}");
}

#[test]
fn a_stream_that_stops_is_reported_with_the_last_frame() {
    let mut l = listener();
    // 50 frames: the arm is still moving when the stream stops.
    let sender = Sender::start(l.local_addr(), 50);
    let err = l
        .read(Target::Body(1), OPTIONS, Duration::from_millis(1500))
        .unwrap_err();
    drop(sender);
    let text = err.to_string();
    assert!(
        matches!(
            &err,
            TrackerError::Stream {
                problem: StreamProblem::Stopped { .. },
                ..
            }
        ),
        "{err:?}"
    );
    assert!(
        text.starts_with(&format!(
            "read body 1 from the DTrack stream on {}: the stream stopped: no frame for",
            l.local_addr()
        )),
        "{text}"
    );
    assert!(text.contains("last frame 1049 at ts"), "{text}");
}

#[test]
fn a_body_never_seen_names_the_bodies_that_are() {
    let mut l = listener();
    let _sender = Sender::start(l.local_addr(), 2000);
    let err = l
        .read(Target::Body(5), OPTIONS, Duration::from_secs(5))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("body 5 not tracked in any of 31 frames"),
        "{err}"
    );
    assert!(
        err.contains("bodies tracked in the last frame: 0, 1"),
        "{err}"
    );
    assert!(err.contains("2 bodies calibrated, ids 0 to 1"), "{err}");
}

#[test]
fn silence_and_foreign_datagrams_are_told_apart() {
    let mut l = listener();
    let err = l
        .read(Target::Body(1), OPTIONS, Duration::from_millis(300))
        .unwrap_err();
    let text = err.to_string();
    assert_eq!(host::Error::from(err).exit_code(), 6);
    assert!(
        text.contains("no DTrack frame for 0.3 s (none since listening began)"),
        "{text}"
    );
    assert!(text.contains("sent to this machine and port?"), "{text}");

    let other = UdpSocket::bind("127.0.0.1:0").unwrap();
    other
        .send_to(b"$GPGGA,123519,4807.038,N", l.local_addr())
        .unwrap();
    std::thread::sleep(Duration::from_millis(50));
    // Queued before the reading began: dropped with the rest, but counted.
    let text = l
        .read(Target::Body(1), OPTIONS, Duration::from_millis(300))
        .unwrap_err()
        .to_string();
    assert!(
        text.contains("1 datagrams that are not DTrack ASCII output"),
        "{text}"
    );
    assert!(text.contains("starts with `fr"), "{text}");
}

#[test]
fn frames_queued_during_the_move_do_not_count() {
    let mut l = listener();
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    // While nobody reads, the socket collects frames of the arm elsewhere.
    let away = Some(Vector3::new(0.0, 0.0, 100.0));
    for i in 0..50 {
        socket
            .send_to(datagram(i, away).as_bytes(), l.local_addr())
            .unwrap();
    }
    std::thread::sleep(Duration::from_millis(50));
    let to = l.local_addr();
    let sender = std::thread::spawn(move || {
        for i in 50..200 {
            let at = Some(Vector3::from(HOLD_MM));
            let _ = socket.send_to(datagram(i, at).as_bytes(), to);
            std::thread::sleep(FRAME);
        }
    });
    let r = l
        .read(Target::Body(1), OPTIONS, Duration::from_secs(5))
        .unwrap();
    sender.join().unwrap();
    assert!(
        (r.position * 1000.0 - Vector3::from(HOLD_MM)).norm() < 1e-9,
        "{r:?}"
    );
    assert!(r.frame_range.0 >= 1050, "{r:?}");
}
