//! Where the camera stands, for ROS: a static transform from a parent frame
//! (the arm's base link) to the camera's optical frame, as `tf2_ros`'s
//! `static_transform_publisher` takes it on its command line and in a ROS 2
//! launch file. Translation in metres, rotation as a unit quaternion
//! (x y z w), the child frame's axes in the parent's: OpenCV's optical
//! frame (x right, y down, z forward), what ROS calls `*_optical_frame`.

use nalgebra::{IsometryMatrix3, UnitQuaternion};

/// The camera's optical frame in a parent frame.
#[derive(Clone, Debug, PartialEq)]
pub struct StaticTransform {
    /// The parent frame's name (`base_link`).
    pub parent: String,
    /// The child frame's name (`camera_optical_frame`).
    pub child: String,
    /// The child frame in the parent's.
    pub child_in_parent: IsometryMatrix3<f64>,
}

impl StaticTransform {
    /// `static_transform_publisher`'s arguments (ROS 2, named form).
    pub fn arguments(&self) -> String {
        let t = self.child_in_parent.translation.vector;
        let q = UnitQuaternion::from_rotation_matrix(&self.child_in_parent.rotation);
        format!(
            "--x {:.6} --y {:.6} --z {:.6} --qx {:.8} --qy {:.8} --qz {:.8} --qw {:.8} \
             --frame-id {} --child-frame-id {}",
            t.x, t.y, t.z, q.i, q.j, q.k, q.w, self.parent, self.child
        )
    }

    /// The command that publishes it.
    pub fn command(&self) -> String {
        format!(
            "ros2 run tf2_ros static_transform_publisher {}",
            self.arguments()
        )
    }

    /// A ROS 2 XML launch file publishing it (`ros2 launch FILE`).
    pub fn launch_xml(&self) -> String {
        format!(
            "<launch>\n  <!-- Written by lrmcal identify: the camera's optical frame in {}. -->\n  \
             <node pkg=\"tf2_ros\" exec=\"static_transform_publisher\" name=\"lrmcal_camera_tf\" \
             args=\"{}\"/>\n</launch>\n",
            self.parent,
            self.arguments()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Translation3, Vector3};

    /// The arguments read back (as `static_transform_publisher` reads them)
    /// give the transform, to the printed digits.
    #[test]
    fn the_arguments_read_back_to_the_transform() {
        let tf = StaticTransform {
            parent: "base_link".into(),
            child: "camera_optical_frame".into(),
            child_in_parent: IsometryMatrix3::from_parts(
                Translation3::new(0.61, -0.052, 0.33),
                Rotation3::from_euler_angles(-1.9, 0.12, 1.4),
            ),
        };
        let args = tf.arguments();
        let words: Vec<&str> = args.split_whitespace().collect();
        let value = |flag: &str| -> f64 {
            let at = words.iter().position(|w| *w == flag).unwrap();
            words[at + 1].parse().unwrap()
        };
        let t = Vector3::new(value("--x"), value("--y"), value("--z"));
        assert!((t - tf.child_in_parent.translation.vector).norm() < 1e-6);
        let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            value("--qw"),
            value("--qx"),
            value("--qy"),
            value("--qz"),
        ));
        let r = UnitQuaternion::from_rotation_matrix(&tf.child_in_parent.rotation);
        assert!(q.angle_to(&r) < 1e-7);
        assert!(args.ends_with("--frame-id base_link --child-frame-id camera_optical_frame"));
        let launch = tf.launch_xml();
        assert!(launch.contains(&format!("args=\"{args}\"")), "{launch}");
    }
}
