//! A serial chain from a URDF file (urdf-rs): forward kinematics of every link, and the 6 x n
//! geometric Jacobian of any point on any link.
//!
//! The chain runs from a base link to a tip link through revolute, continuous and prismatic
//! joints (fixed joints are folded into the next transform). Joint i moves link frames after it:
//! the Jacobian of a point on link k has zero columns for the joints past k. Rows 0-2 are the
//! point's linear velocity, rows 3-5 the link's angular velocity, both in the base frame.

use nalgebra::{DMatrix, Isometry3, Point3, Translation3, Unit, UnitQuaternion, Vector3};
use std::path::Path;

/// What can go wrong building or using a chain.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KinematicsError {
    /// The URDF could not be read or parsed.
    #[error("{path}: {message}")]
    Urdf {
        /// The file (or "string").
        path: String,
        /// What urdf-rs said.
        message: String,
    },
    /// A link name is not in the chain (or the URDF).
    #[error("link \"{name}\" is not in {place} (links: {available})")]
    UnknownLink {
        /// The name asked for.
        name: String,
        /// Where it was looked for.
        place: String,
        /// The names there are.
        available: String,
    },
    /// No chain of joints leads from the base to the tip.
    #[error("no chain of joints leads from \"{base}\" to \"{tip}\"")]
    NoPath {
        /// Base link.
        base: String,
        /// Tip link.
        tip: String,
    },
    /// A joint vector of the wrong length, or not finite.
    #[error("{0}")]
    Joints(String),
}

/// The kind of motion of a joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// Rotation about the axis (revolute or continuous).
    Revolute,
    /// Translation along the axis.
    Prismatic,
}

/// One movable joint of a chain.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainJoint {
    /// Joint name.
    pub name: String,
    /// Revolute or prismatic.
    pub kind: JointKind,
    /// Parent link frame to joint frame at q = 0 (fixed joints before it folded in).
    pub origin: Isometry3<f64>,
    /// Axis in the joint frame.
    pub axis: Unit<Vector3<f64>>,
    /// Lower and upper limit (radians or metres; infinite for a continuous joint).
    pub limits: (f64, f64),
    /// The link this joint moves (its child).
    pub link: String,
}

/// A serial chain of links.
#[derive(Debug, Clone, PartialEq)]
pub struct Chain {
    base: String,
    joints: Vec<ChainJoint>,
    /// Fixed transform from the last movable joint's link to the tip link.
    tip_offset: Isometry3<f64>,
    tip: String,
    /// Links rigidly attached after each joint (by fixed joints), with their offset from that
    /// joint's link: (joint index, link name, offset).
    fixed_links: Vec<(usize, String, Isometry3<f64>)>,
}

fn pose(p: &urdf_rs::Pose) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(p.xyz[0], p.xyz[1], p.xyz[2]),
        UnitQuaternion::from_euler_angles(p.rpy[0], p.rpy[1], p.rpy[2]),
    )
}

/// A joint's numbers must be finite, its origin within `MAX_POSITION_M` (100 m) of its parent and
/// its limits ordered: the chain's poses and the collision shapes built on them stay finite.
fn check_joint(j: &urdf_rs::Joint, place: &str) -> Result<(), KinematicsError> {
    let bad = |what: String| KinematicsError::Urdf {
        path: place.into(),
        message: format!("joint \"{}\": {what}", j.name),
    };
    let limit = skin_core::format::MAX_POSITION_M;
    if !j.origin.xyz.iter().all(|v| v.is_finite() && v.abs() <= limit) {
        return Err(bad(format!(
            "origin xyz {:?} must be finite metres within {limit} m",
            &j.origin.xyz[..]
        )));
    }
    if !j
        .origin
        .rpy
        .iter()
        .chain(j.axis.xyz.iter())
        .all(|v| v.is_finite())
    {
        return Err(bad("origin rpy and axis must be finite".into()));
    }
    let movable = matches!(
        j.joint_type,
        urdf_rs::JointType::Revolute | urdf_rs::JointType::Prismatic
    );
    let (lo, hi) = (j.limit.lower, j.limit.upper);
    if movable && !(lo.is_finite() && hi.is_finite() && lo <= hi) {
        return Err(bad(format!(
            "limits lower {lo} and upper {hi} must be finite with lower <= upper"
        )));
    }
    Ok(())
}

/// The joints from `base` to `tip`, base first: walked from the tip up through each link's
/// parent joint. Both links must exist, and a loop in the file ends the walk as no path.
fn joint_path<'a>(
    robot: &'a urdf_rs::Robot,
    base: &str,
    tip: &str,
    place: &str,
) -> Result<Vec<&'a urdf_rs::Joint>, KinematicsError> {
    for name in [base, tip] {
        if !robot.links.iter().any(|l| l.name == name) {
            let mut names: Vec<&str> = robot.links.iter().map(|l| l.name.as_str()).collect();
            names.truncate(40);
            return Err(KinematicsError::UnknownLink {
                name: name.into(),
                place: place.into(),
                available: names.join(", "),
            });
        }
    }
    let mut path: Vec<&urdf_rs::Joint> = Vec::new();
    let mut link = tip.to_string();
    while link != base {
        let Some(j) = robot.joints.iter().find(|j| j.child.link == link) else {
            return Err(KinematicsError::NoPath {
                base: base.into(),
                tip: tip.into(),
            });
        };
        path.push(j);
        link = j.parent.link.clone();
        if path.len() > robot.joints.len() {
            return Err(KinematicsError::NoPath {
                base: base.into(),
                tip: tip.into(),
            });
        }
    }
    path.reverse();
    Ok(path)
}

/// A revolute, continuous or prismatic URDF joint `j` as a chain joint at `origin` (its pose
/// after the fixed joints before it).
fn movable_joint(
    j: &urdf_rs::Joint,
    origin: Isometry3<f64>,
    place: &str,
) -> Result<ChainJoint, KinematicsError> {
    let axis = Vector3::new(j.axis.xyz[0], j.axis.xyz[1], j.axis.xyz[2]);
    // Scaled by its largest component first, so that huge axes keep a finite norm.
    let axis = Unit::try_new(axis / axis.amax().max(f64::MIN_POSITIVE), 1e-12).ok_or_else(|| {
        KinematicsError::Urdf {
            path: place.into(),
            message: format!("joint \"{}\" has a zero axis", j.name),
        }
    })?;
    let continuous = j.joint_type == urdf_rs::JointType::Continuous;
    Ok(ChainJoint {
        name: j.name.clone(),
        kind: if j.joint_type == urdf_rs::JointType::Prismatic {
            JointKind::Prismatic
        } else {
            JointKind::Revolute
        },
        origin,
        axis,
        limits: if continuous {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else {
            (j.limit.lower, j.limit.upper)
        },
        link: j.child.link.clone(),
    })
}

impl Chain {
    /// Reads the chain from `base` to `tip` in a URDF file.
    pub fn from_urdf(path: &Path, base: &str, tip: &str) -> Result<Chain, KinematicsError> {
        let robot = urdf_rs::read_file(path).map_err(|e| KinematicsError::Urdf {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Self::from_robot(&robot, base, tip, &path.display().to_string())
    }

    /// Reads the chain from URDF text.
    pub fn from_urdf_str(text: &str, base: &str, tip: &str) -> Result<Chain, KinematicsError> {
        let robot = urdf_rs::read_from_string(text).map_err(|e| KinematicsError::Urdf {
            path: "URDF text".into(),
            message: e.to_string(),
        })?;
        Self::from_robot(&robot, base, tip, "the URDF")
    }

    fn from_robot(
        robot: &urdf_rs::Robot,
        base: &str,
        tip: &str,
        place: &str,
    ) -> Result<Chain, KinematicsError> {
        let path = joint_path(robot, base, tip, place)?;
        let mut joints = Vec::new();
        let mut fixed_links = Vec::new();
        let mut pending = Isometry3::identity();
        for j in path {
            check_joint(j, place)?;
            let origin = pending * pose(&j.origin);
            match j.joint_type {
                urdf_rs::JointType::Revolute
                | urdf_rs::JointType::Continuous
                | urdf_rs::JointType::Prismatic => {
                    joints.push(movable_joint(j, origin, place)?);
                    pending = Isometry3::identity();
                }
                urdf_rs::JointType::Fixed => {
                    pending = origin;
                    if let Some(k) = joints.len().checked_sub(1) {
                        fixed_links.push((k, j.child.link.clone(), pending));
                    }
                }
                _ => {
                    return Err(KinematicsError::Urdf {
                        path: place.into(),
                        message: format!(
                            "joint \"{}\": only revolute, continuous, prismatic and fixed joints are supported",
                            j.name
                        ),
                    });
                }
            }
        }
        Ok(Chain {
            base: base.into(),
            joints,
            tip_offset: pending,
            tip: tip.into(),
            fixed_links,
        })
    }

    /// Number of movable joints.
    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    /// The movable joints, base to tip.
    pub fn joints(&self) -> &[ChainJoint] {
        &self.joints
    }

    fn check(&self, q: &[f64]) -> Result<(), KinematicsError> {
        if q.len() != self.joints.len() {
            return Err(KinematicsError::Joints(format!(
                "{} joint values for a chain of {} joints",
                q.len(),
                self.joints.len()
            )));
        }
        if let Some(i) = q.iter().position(|v| !v.is_finite()) {
            return Err(KinematicsError::Joints(format!(
                "joint {} (\"{}\") is not finite",
                i, self.joints[i].name
            )));
        }
        Ok(())
    }

    /// Pose of every movable joint's link in the base frame at `q`.
    pub fn link_poses(&self, q: &[f64]) -> Result<Vec<Isometry3<f64>>, KinematicsError> {
        self.check(q)?;
        let mut out = Vec::with_capacity(self.joints.len());
        let mut t = Isometry3::identity();
        for (j, &qi) in self.joints.iter().zip(q) {
            let motion = match j.kind {
                JointKind::Revolute => Isometry3::from_parts(
                    Translation3::identity(),
                    UnitQuaternion::from_axis_angle(&j.axis, qi),
                ),
                JointKind::Prismatic => Isometry3::from_parts(
                    Translation3::from(j.axis.into_inner() * qi),
                    UnitQuaternion::identity(),
                ),
            };
            t = t * j.origin * motion;
            out.push(t);
        }
        Ok(out)
    }

    /// Where `link` is (its index among the joints' links, and its fixed offset from that link);
    /// the base is (None, identity).
    fn locate(&self, link: &str) -> Result<(Option<usize>, Isometry3<f64>), KinematicsError> {
        if link == self.base {
            return Ok((None, Isometry3::identity()));
        }
        if let Some(k) = self.joints.iter().position(|j| j.link == link) {
            return Ok((Some(k), Isometry3::identity()));
        }
        if link == self.tip {
            return Ok((self.joints.len().checked_sub(1), self.tip_offset));
        }
        if let Some((k, _, off)) = self.fixed_links.iter().find(|(_, name, _)| name == link) {
            return Ok((Some(*k), *off));
        }
        let mut names: Vec<&str> = vec![self.base.as_str()];
        names.extend(self.joints.iter().map(|j| j.link.as_str()));
        names.push(self.tip.as_str());
        Err(KinematicsError::UnknownLink {
            name: link.into(),
            place: format!("the chain {} -> {}", self.base, self.tip),
            available: names.join(", "),
        })
    }

    /// Pose of `link` in the base frame at `q`.
    pub fn link_pose(&self, link: &str, q: &[f64]) -> Result<Isometry3<f64>, KinematicsError> {
        self.posture(q)?.link_pose(link)
    }

    /// The 6 x n geometric Jacobian of `point` (in `link`'s frame) at `q`: rows 0-2 its linear
    /// velocity, rows 3-5 the link's angular velocity, base frame; zero columns for joints that do
    /// not move the link.
    pub fn jacobian(
        &self,
        link: &str,
        point: &Point3<f64>,
        q: &[f64],
    ) -> Result<DMatrix<f64>, KinematicsError> {
        self.posture(q)?.jacobian(link, point)
    }

    /// The chain at joint values `q`, its forward kinematics computed once for any number of
    /// poses and Jacobians (a control cycle asks for several).
    pub fn posture(&self, q: &[f64]) -> Result<Posture<'_>, KinematicsError> {
        Ok(Posture {
            chain: self,
            poses: self.link_poses(q)?,
        })
    }
}

/// A [`Chain`] at given joint values: every moving link's pose, computed once.
#[derive(Debug, Clone)]
pub struct Posture<'a> {
    chain: &'a Chain,
    poses: Vec<Isometry3<f64>>,
}

impl Posture<'_> {
    /// Pose of `link` in the base frame.
    pub fn link_pose(&self, link: &str) -> Result<Isometry3<f64>, KinematicsError> {
        let (k, off) = self.chain.locate(link)?;
        Ok(k.map_or(Isometry3::identity(), |k| self.poses[k]) * off)
    }

    /// The 6 x n geometric Jacobian of `point` (in `link`'s frame), as [`Chain::jacobian`].
    pub fn jacobian(&self, link: &str, point: &Point3<f64>) -> Result<DMatrix<f64>, KinematicsError> {
        let (k, off) = self.chain.locate(link)?;
        let joints = &self.chain.joints;
        let mut jac = DMatrix::zeros(6, joints.len());
        let Some(k) = k else {
            return Ok(jac);
        };
        let p = self.poses[k] * off * point;
        for (i, (j, pose)) in joints.iter().zip(&self.poses).enumerate().take(k + 1) {
            // The joint axis in the base frame, through the joint frame's origin (the child
            // link's frame at the joint value).
            let axis = pose.rotation * j.axis.into_inner();
            let origin = pose.translation.vector;
            match j.kind {
                JointKind::Revolute => {
                    let v = axis.cross(&(p.coords - origin));
                    jac.fixed_view_mut::<3, 1>(0, i).copy_from(&v);
                    jac.fixed_view_mut::<3, 1>(3, i).copy_from(&axis);
                }
                JointKind::Prismatic => {
                    jac.fixed_view_mut::<3, 1>(0, i).copy_from(&axis);
                }
            }
        }
        Ok(jac)
    }
}
