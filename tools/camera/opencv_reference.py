"""Reference data for lrmcal-core's camera model: OpenCV's own projection.

Writes, into host/core/tests/data/camera/:
- `opencv_calibration.yaml`: intrinsics as `cv2.FileStorage(..., WRITE)` writes
  them after `calibrateCamera` (the keys of OpenCV's calibration sample);
- `opencv_projected.csv`: points in the camera frame (m) and the pixels
  `cv2.projectPoints` gives for them (identity pose), with Python's shortest
  round-trip float text, so the test reads back OpenCV's very numbers.

Regenerate (from the workspace root):
    python3 -m venv /tmp/cvenv && /tmp/cvenv/bin/pip install opencv-python-headless
    /tmp/cvenv/bin/python tools/camera/opencv_reference.py
"""

import pathlib

import cv2
import numpy as np

OUT = pathlib.Path(__file__).resolve().parents[2] / "host/core/tests/data/camera"

WIDTH, HEIGHT = 1280, 720
K = np.array([[910.5, 0.0, 642.3], [0.0, 905.25, 358.7], [0.0, 0.0, 1.0]])
# k1, k2, p1, p2, k3: a webcam's barrel distortion, tangential terms included.
DIST = np.array([[-0.12, 0.08, 0.0012, -0.0009, -0.02]])

# Points in front of the camera (x right, y down, z forward, m): the centre,
# the image's edges and corners at several depths, off-axis points where the
# distortion is strong.
POINTS = np.array(
    [
        [0.0, 0.0, 0.8],
        [0.1, 0.0, 0.8],
        [0.0, -0.1, 0.8],
        [0.25, 0.15, 0.6],
        [-0.3, 0.2, 0.9],
        [-0.4, -0.2, 1.2],
        [0.5, -0.3, 1.1],
        [0.02, 0.03, 0.3],
        [-0.05, 0.01, 2.5],
        [0.31, 0.17, 0.45],
        [-0.6, 0.35, 1.0],
        [0.123456, -0.0654321, 0.987654],
    ]
)


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    fs = cv2.FileStorage(str(OUT / "opencv_calibration.yaml"), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", WIDTH)
    fs.write("image_height", HEIGHT)
    fs.write("camera_matrix", K)
    fs.write("distortion_coefficients", DIST)
    fs.release()

    pixels, _ = cv2.projectPoints(POINTS, np.zeros(3), np.zeros(3), K, DIST)
    with open(OUT / "opencv_projected.csv", "w", encoding="utf-8") as f:
        f.write(f"# cv2.projectPoints, OpenCV {cv2.__version__}; tools/camera/opencv_reference.py\n")
        f.write("x_m,y_m,z_m,u_px,v_px\n")
        for p, uv in zip(POINTS, pixels.reshape(-1, 2)):
            f.write(",".join(repr(float(v)) for v in (*p, *uv)) + "\n")


if __name__ == "__main__":
    main()
