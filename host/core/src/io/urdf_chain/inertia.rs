//! The masses each DH link carries, and their centres of mass in its frame.

use std::collections::HashMap;

use nalgebra::{Point3, Vector3};

use super::chain::{Chain, Placed, Tree};
use super::frames::Pose;
use crate::error::InputError;

/// The links that move together: their mass and centre of mass.
pub(super) struct Body {
    /// kg.
    pub mass: f64,
    /// In the body's DH frame, m; zeros without mass.
    pub com: [f64; 3],
}

/// The masses of the base and of DH links 1..=n.
pub(super) struct Masses {
    /// What is fixed to the base link up to joint 1.
    pub base: Body,
    /// DH links 1..=n.
    pub links: Vec<Body>,
    /// The moving joints off the chain, taken as rigid, in file order.
    pub frozen: Vec<String>,
}

/// Shares the links below the base link out among the base (body 0) and the
/// DH links (body i after chain joint i), each link's mass checked.
/// `frames` are DH frames 0..=n at q = 0 in the base link's frame.
pub(super) fn masses(
    tree: &Tree<'_>,
    chain: &Chain,
    placed: &Placed,
    frames: &[Pose],
) -> Result<Masses, InputError> {
    let starts: HashMap<usize, usize> = (chain.moving.iter().enumerate())
        .map(|(i, m)| (m.joint, i + 1))
        .collect();
    // Per link below the base: the body it moves with.
    let mut body_of = HashMap::new();
    // Per body: total mass and mass times centre of mass, base link's frame.
    let mut sums = vec![(0.0, Vector3::zeros()); frames.len()];
    let mut frozen = Vec::new();
    for &link in &placed.order {
        let body = match tree.parent_joint(link).filter(|_| link != chain.base) {
            None => 0,
            Some(j) => match starts.get(&j) {
                Some(&i) => i,
                None => {
                    if tree.joint(j).joint_type != urdf_rs::JointType::Fixed {
                        frozen.push(j);
                    }
                    // Placed links come after their parents.
                    body_of[&tree.ends(j).0]
                }
            },
        };
        body_of.insert(link, body);
        let inertial = &tree.link(link).inertial;
        let (mass, xyz) = (inertial.mass.value, inertial.origin.xyz.0);
        if !(mass.is_finite() && mass >= 0.0) || xyz.iter().any(|v| !v.is_finite()) {
            return Err(tree.link_error(
                link,
                format!(
                    "link `{}`: expected a finite <mass> ≥ 0 and a finite <inertial><origin xyz>, found mass {mass}, xyz `{} {} {}`",
                    tree.link(link).name,
                    xyz[0],
                    xyz[1],
                    xyz[2]
                ),
            ));
        }
        let com = placed.pose(link) * Point3::from(xyz);
        sums[body].0 += mass;
        sums[body].1 += com.coords * mass;
    }
    frozen.sort_unstable();
    let mut bodies = sums
        .iter()
        .zip(frames)
        .map(|(&(mass, moment), frame)| Body {
            mass,
            com: if mass > 0.0 {
                frame
                    .inverse_transform_point(&Point3::from(moment / mass))
                    .coords
                    .into()
            } else {
                [0.0; 3]
            },
        });
    let base = bodies.next().expect("frames hold DH frame 0");
    Ok(Masses {
        base,
        links: bodies.collect(),
        frozen: frozen
            .into_iter()
            .map(|j| tree.joint(j).name.clone())
            .collect(),
    })
}
