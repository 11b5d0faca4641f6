//! The deflected state of one pose as the derivatives see it (frames,
//! torque axes, the masses beyond each joint and their moments, the springs'
//! rates), and the small rigid motions ([`Twist`]) whose effect on the
//! torques it gives.

use model::PerFrame;
use nalgebra::{IsometryMatrix3, Vector3};

use crate::calib::Rig;

/// A small rigid motion of the part of the arm beyond `from`: a point it
/// moves goes `ω × x + v`, world frame.
#[derive(Clone, Copy, Debug)]
pub(super) struct Twist {
    /// Angular rate, rad per unit of the parameter.
    pub(super) w: Vector3<f64>,
    /// Velocity of the point at the world origin, m per unit.
    pub(super) v: Vector3<f64>,
    /// Frames `from..=n` and bodies `max(from, 1)..` move; `n + 1`
    /// ([`State::payload`]): the payload alone (a tool frame parameter).
    pub(super) from: usize,
}

impl Twist {
    /// A turn about `axis` through `point`.
    pub(super) fn about(axis: Vector3<f64>, point: &Vector3<f64>, from: usize) -> Self {
        Self {
            w: axis,
            v: point.cross(&axis),
            from,
        }
    }

    /// A slide along `direction`.
    pub(super) fn along(direction: Vector3<f64>, from: usize) -> Self {
        Self {
            w: Vector3::zeros(),
            v: direction,
            from,
        }
    }
}

/// One deflected state as the derivatives see it, world frame.
///
/// Its `n + 1` coordinates are the `n` joint angles, then the base tilt;
/// the bodies that carry weight are links `1..=n`, then the payload (`n + 1`).
pub(super) struct State {
    /// The arm's joints, n.
    pub(super) joints: usize,
    /// Frames 0 (tilted base) ..= n.
    pub(super) frames: PerFrame<IsometryMatrix3<f64>>,
    /// Gravity, m/s².
    pub(super) gravity: Vector3<f64>,
    /// Axis and origin of each state coordinate's torque: joint `i + 1`
    /// about `z(i)` through `o(i)`, then the base tilt about `y(0)` through `o(0)`.
    pub(super) axes: Vec<(Vector3<f64>, Vector3<f64>)>,
    /// `M_s`: mass of bodies `s..=n+1` (index 0 unused, n + 2 none), kg.
    pub(super) mass: Vec<f64>,
    /// `C_s`: `Σ m c` over bodies `s..=n+1`, world, kg·m.
    pub(super) moment: Vec<Vector3<f64>>,
    /// The compliances in state order (`k1..kn`, `k0`), rad/Nm.
    pub(super) compliance: Vec<f64>,
    /// The springs' softenings in state order, 1/Nm.
    pub(super) softening: Vec<f64>,
    /// The springs' rates at their torques, `k (1 + 2 s |τ|)`, rad/Nm.
    pub(super) rate: Vec<f64>,
    /// Whether each joint slides: its coordinate is a length along its axis
    /// and its generalised force the weight beyond it along the axis.
    pub(super) prismatic: Vec<bool>,
}

impl State {
    pub(super) fn new(
        chain: &model::Chain<f64>,
        rig: &Rig,
        frames: PerFrame<IsometryMatrix3<f64>>,
        load: f64,
    ) -> Self {
        let n = frames.len() - 1;
        let payload = n + 1;
        let mut mass = vec![0.0; n + 3];
        let mut moment = vec![Vector3::zeros(); n + 3];
        let last = &frames[n];
        mass[payload] = load;
        moment[payload] = (last.rotation * chain.payload_com + last.translation.vector) * load;
        for j in (1..=n).rev() {
            let link = &chain.links[j - 1];
            let f = &frames[j];
            mass[j] = mass[j + 1] + link.mass;
            moment[j] =
                moment[j + 1] + f.rotation * link.mass_com + f.translation.vector * link.mass;
        }
        let axes = (0..=n)
            .map(|e| {
                let (frame, column) = if e < n { (e, 2) } else { (0, 1) };
                let f = &frames[frame];
                (
                    f.rotation.matrix().column(column).into_owned(),
                    f.translation.vector,
                )
            })
            .collect();
        // A spring's value in state order: the joints' (`of`), then the base's.
        let springs = |of: fn(&model::kinematics::Link<f64>) -> f64, base: f64| -> Vec<f64> {
            chain.links.iter().map(of).chain([base]).collect()
        };
        let compliance = springs(|l| l.compliance, chain.base_compliance);
        let softening = springs(|l| l.softening, chain.base_softening);
        let mut state = Self {
            prismatic: chain.links.iter().map(|l| l.prismatic).collect(),
            joints: n,
            frames,
            gravity: rig.placed_arm().gravity_vector(),
            axes,
            mass,
            moment,
            compliance,
            softening,
            rate: Vec::new(),
        };
        let tau = state.torques();
        state.rate = (0..=n)
            .map(|e| state.compliance[e] * (1.0 + 2.0 * state.softening[e] * tau[e].abs()))
            .collect();
        state
    }

    /// The index of the payload among the bodies, n + 1.
    pub(super) fn payload(&self) -> usize {
        self.joints + 1
    }

    /// The bodies whose weight loads state coordinate `e`'s torque, from
    /// the first, and the frame its axis is fixed in.
    pub(super) fn reach(&self, e: usize) -> (usize, usize) {
        if e < self.joints { (e + 1, e) } else { (1, 0) }
    }

    /// Whether state coordinate `e` is a prismatic joint's.
    pub(super) fn slides(&self, e: usize) -> bool {
        e < self.joints && self.prismatic[e]
    }

    /// The gravity torques in state order, Nm (a prismatic joint's force, N).
    pub(super) fn torques(&self) -> Vec<f64> {
        (0..=self.joints)
            .map(|e| {
                let (first, _) = self.reach(e);
                let (axis, origin) = &self.axes[e];
                if self.slides(e) {
                    return axis.dot(&self.gravity) * self.mass[first];
                }
                let r = self.moment[first] - origin * self.mass[first];
                axis.dot(&r.cross(&self.gravity))
            })
            .collect()
    }

    /// How the torques change under `t` (module docs). A prismatic joint's
    /// force changes only when its axis turns: the weight beyond it moves
    /// rigidly and keeps its size.
    pub(super) fn torque_slopes(&self, t: &Twist) -> Vec<f64> {
        let turned_gravity = t.w.cross(&self.gravity);
        (0..=self.joints)
            .map(|e| {
                let (first, axis_frame) = self.reach(e);
                let (axis, origin) = &self.axes[e];
                if self.slides(e) {
                    return if t.from <= axis_frame {
                        -axis.dot(&turned_gravity) * self.mass[first]
                    } else {
                        0.0
                    };
                }
                if t.from <= axis_frame {
                    let r = self.moment[first] - origin * self.mass[first];
                    -axis.dot(&r.cross(&turned_gravity))
                } else {
                    let from = t.from.max(first);
                    let moved = t.w.cross(&self.moment[from]) + t.v * self.mass[from];
                    axis.dot(&moved.cross(&self.gravity))
                }
            })
            .collect()
    }

    /// Whether nothing yields: the deflection does not respond to anything.
    pub(super) fn rigid(&self) -> bool {
        self.compliance.iter().all(|k| *k == 0.0)
    }

    /// The motion of the state coordinate `e`: joint `e + 1` turns about
    /// its axis, the base tilts about `y(0)`.
    pub(super) fn state_twist(&self, e: usize) -> Twist {
        let (axis, origin) = &self.axes[e];
        if self.slides(e) {
            return Twist::along(*axis, e + 1);
        }
        Twist::about(*axis, origin, if e < self.joints { e + 1 } else { 0 })
    }
}
