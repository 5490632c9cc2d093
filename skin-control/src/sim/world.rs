//! The simulated world: the arm's links as skin-covered capsules, obstacles as solids, contact
//! forces from the linear spring model of Eq. 8.1 (f = K d, d how far the skin is pressed into
//! an obstacle's padding), collision queries by parry.

use super::scene::{Obstacle, Scene, SceneError, rpy, v3};
use crate::contact_tasks::{Contact, group_contacts};
use crate::controller::LinkContacts;
use crate::kinematics::{Chain, Posture};
use nalgebra::{Isometry3, Point3, Unit, Vector3};
use parry3d_f64::math::{Pose, Vector};
use parry3d_f64::query::{self, PointQuery};
use parry3d_f64::shape::{Capsule, Cuboid, Segment, Shape};

/// Distance between neighbouring taxels on the simulated skin, metres (Cyskin's pitch is
/// about 8 mm on a patch; 15 mm keeps the simulation fast and still finds every contact
/// deeper than a millimetre on the bars of the default scene).
pub const TAXEL_PITCH: f64 = 0.01;

/// Taxels closer than this (chained) are one contact, metres (1.5 taxel pitches).
pub const CONTACT_RADIUS: f64 = 1.5 * TAXEL_PITCH;

/// Smallest force a simulated taxel reports, newtons (below it the skin reads zero).
pub const SKIN_FLOOR: f64 = 0.05;

fn to_vec(v: &Vector3<f64>) -> Vector {
    Vector::new(v.x, v.y, v.z)
}

fn to_pose(iso: &Isometry3<f64>) -> Pose {
    let q = iso.rotation.quaternion();
    Pose::from_parts(
        to_vec(&iso.translation.vector),
        parry3d_f64::math::Rot3::from_xyzw(q.i, q.j, q.k, q.w),
    )
}

/// The shapes a solid can have.
#[derive(Debug, Clone)]
enum Geometry {
    Capsule(Capsule),
    Cuboid(Cuboid),
}

impl Geometry {
    fn shape(&self) -> &dyn Shape {
        match self {
            Geometry::Capsule(c) => c,
            Geometry::Cuboid(c) => c,
        }
    }
}

/// A rigid solid of the world (an obstacle, or something touching the arm), base frame.
#[derive(Debug, Clone)]
pub struct Solid {
    shape: Geometry,
    pose: Pose,
}

impl Solid {
    /// A capsule around the segment a-b.
    pub fn capsule(a: &Point3<f64>, b: &Point3<f64>, radius: f64) -> Solid {
        Solid {
            shape: Geometry::Capsule(Capsule::new(to_vec(&a.coords), to_vec(&b.coords), radius)),
            pose: Pose::IDENTITY,
        }
    }

    /// A box of half sizes `half_extents` at `pose`.
    pub fn cuboid(half_extents: &Vector3<f64>, pose: &Isometry3<f64>) -> Solid {
        Solid {
            shape: Geometry::Cuboid(Cuboid::new(to_vec(half_extents))),
            pose: to_pose(pose),
        }
    }

    /// A scene obstacle.
    pub fn from_obstacle(o: &Obstacle) -> Solid {
        match o {
            Obstacle::Capsule { a, b, radius } => {
                Solid::capsule(&Point3::from(*a), &Point3::from(*b), *radius)
            }
            Obstacle::Box {
                center,
                half_extents,
                rpy: r,
            } => Solid::cuboid(
                &v3(half_extents),
                &Isometry3::from_parts(v3(center).into(), rpy(r)),
            ),
        }
    }

    /// Signed distance from `p` to the surface (negative inside).
    pub fn signed_distance(&self, p: &Point3<f64>) -> f64 {
        match &self.shape {
            Geometry::Capsule(c) => c.distance_to_point(&self.pose, to_vec(&p.coords), false),
            Geometry::Cuboid(c) => c.distance_to_point(&self.pose, to_vec(&p.coords), false),
        }
    }

    /// True when the segment a-b touches or crosses the solid.
    pub fn crosses(&self, a: &Point3<f64>, b: &Point3<f64>) -> bool {
        let seg = Segment::new(to_vec(&a.coords), to_vec(&b.coords));
        query::intersection_test(&Pose::IDENTITY, &seg, &self.pose, self.shape.shape())
            .is_ok_and(|i| i.intersecting)
    }
}

/// One skin-covered part of the arm: a capsule fixed to a link.
#[derive(Debug, Clone)]
pub struct BodyPart {
    /// The link it moves with (and whose contact task its contacts feed).
    pub link: String,
    /// Axis end points and radius, in the link's frame.
    pub a: Point3<f64>,
    /// See `a`.
    pub b: Point3<f64>,
    /// Radius, m.
    pub radius: f64,
    shape: Capsule,
    /// Taxels: position and outward normal, link frame.
    taxels: Vec<(Point3<f64>, Unit<Vector3<f64>>)>,
}

impl BodyPart {
    /// A capsule part of `link` covered with taxels [`TAXEL_PITCH`] apart.
    pub fn new(link: &str, a: Point3<f64>, b: Point3<f64>, radius: f64) -> BodyPart {
        BodyPart {
            link: link.into(),
            a,
            b,
            radius,
            shape: Capsule::new(to_vec(&a.coords), to_vec(&b.coords), radius),
            taxels: capsule_taxels(&a, &b, radius, TAXEL_PITCH),
        }
    }

    /// Number of taxels.
    pub fn taxel_count(&self) -> usize {
        self.taxels.len()
    }
}

/// Taxels covering a capsule: rings along the cylinder, latitude rings on both caps.
fn capsule_taxels(
    a: &Point3<f64>,
    b: &Point3<f64>,
    r: f64,
    pitch: f64,
) -> Vec<(Point3<f64>, Unit<Vector3<f64>>)> {
    let axis = b - a;
    let len = axis.norm();
    let u = if len > 1e-12 { axis / len } else { Vector3::z() };
    let helper = if u.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = u.cross(&helper).normalize();
    let e2 = u.cross(&e1);
    let mut out = Vec::new();
    let per_ring = |radius: f64| ((2.0 * std::f64::consts::PI * radius / pitch).ceil() as usize).max(1);
    let rings = ((len / pitch).ceil() as usize).max(1) + 1;
    let m = per_ring(r);
    for i in 0..rings {
        let t = len * i as f64 / (rings - 1) as f64;
        let stagger = if i % 2 == 1 { 0.5 } else { 0.0 };
        for k in 0..m {
            let th = 2.0 * std::f64::consts::PI * (k as f64 + stagger) / m as f64;
            let n = e1 * th.cos() + e2 * th.sin();
            out.push((a + u * t + n * r, Unit::new_unchecked(n)));
        }
    }
    // Caps: latitude phi from the equator (already covered) to the pole.
    let dphi = pitch / r;
    let levels = ((std::f64::consts::FRAC_PI_2 / dphi).floor() as usize).max(1);
    for (centre, dir) in [(b, u), (a, -u)] {
        for j in 1..=levels {
            let phi = (j as f64 * dphi).min(std::f64::consts::FRAC_PI_2);
            let ring_r = r * phi.cos();
            let count = if ring_r < 1e-9 { 1 } else { per_ring(ring_r) };
            for k in 0..count {
                let th = 2.0 * std::f64::consts::PI * k as f64 / count as f64;
                let n = (e1 * th.cos() + e2 * th.sin()) * phi.cos() + dir * phi.sin();
                out.push((centre + n * r, Unit::new_normalize(n)));
            }
        }
        // The pole, unless the last ring already is it.
        if levels as f64 * dphi < std::f64::consts::FRAC_PI_2 - 1e-9 {
            out.push((centre + dir * r, Unit::new_normalize(dir)));
        }
    }
    out
}

/// What the skin and the world report at one posture.
#[derive(Debug, Clone, Default)]
pub struct Sensing {
    /// Contacts for the controller: each link's touched taxels grouped into contacts
    /// ([`group_contacts`]), only links with a contact.
    pub contacts: Vec<LinkContacts>,
    /// What the skin reads: every taxel with a force of at least [`SKIN_FLOOR`], by link.
    pub taxels: Vec<LinkContacts>,
    /// Largest force a taxel reports, newtons.
    pub skin_max: f64,
    /// Largest contact force on any part by the spring model (K times the deepest penetration
    /// of the part into any solid), newtons: what the obstacle feels, whether or not a taxel
    /// sits exactly there.
    pub max_force: f64,
    /// Number of taxels in contact.
    pub taxels_in_contact: usize,
}

/// The arm with its skin, and the fixed obstacles.
#[derive(Debug, Clone)]
pub struct World {
    chain: Chain,
    tip: String,
    parts: Vec<BodyPart>,
    obstacles: Vec<Solid>,
    stiffness: f64,
}

/// Capsule radius per joint of the built-in arm (upper arm thicker than the wrist).
const ARM7_RADII: [f64; 7] = [0.05, 0.045, 0.045, 0.04, 0.04, 0.035, 0.03];

impl World {
    /// The world of a scene: its robot (one capsule per moving link, from the link's origin to
    /// the next joint, the last one ending `radius` short of the tip so that the tip frame's
    /// origin is the hand's surface point) and its obstacles.
    pub fn from_scene(scene: &Scene) -> Result<World, SceneError> {
        let (text, name) = scene.urdf_text()?;
        let field = |field: &str, why: String| SceneError::Field {
            origin: scene.name(),
            field: field.into(),
            why,
        };
        let chain = Chain::from_urdf_str(&text, &scene.base, &scene.tip)
            .map_err(|e| field("urdf", format!("{name}: {e}")))?;
        let n = chain.dof();
        let radii = match &scene.radii {
            Some(r) if r.len() != n => {
                return Err(field(
                    "radii",
                    format!("{} radii for a chain of {n} joints", r.len()),
                ));
            }
            Some(r) => r.clone(),
            None => (0..n).map(|i| ARM7_RADII[i.min(ARM7_RADII.len() - 1)]).collect(),
        };
        let zero = vec![0.0; n];
        let poses = chain
            .link_poses(&zero)
            .map_err(|e| field("urdf", format!("{name}: {e}")))?;
        let tip_pose = chain
            .link_pose(&scene.tip, &zero)
            .map_err(|e| field("tip", e.to_string()))?;
        let mut parts = Vec::new();
        for k in 0..n {
            let link = &chain.joints()[k].link;
            if k + 1 < n {
                let end = Point3::from(chain.joints()[k + 1].origin.translation.vector);
                parts.push(BodyPart::new(link, Point3::origin(), end, radii[k]));
            } else {
                // The last link in the tip's frame, reported as the tip (the end-effector).
                let from_tip = tip_pose.inverse() * poses[k];
                let start = Point3::from(from_tip.translation.vector);
                let dir = Point3::origin() - start;
                let len = dir.norm();
                let end = if len > radii[k] {
                    Point3::origin() - dir / len * radii[k]
                } else {
                    start
                };
                parts.push(BodyPart::new(&scene.tip, start, end, radii[k]));
            }
        }
        Ok(World {
            chain,
            tip: scene.tip.clone(),
            parts,
            obstacles: scene.obstacles.iter().map(Solid::from_obstacle).collect(),
            stiffness: scene.stiffness,
        })
    }

    /// The robot's chain.
    pub fn chain(&self) -> &Chain {
        &self.chain
    }

    /// The tip link's name.
    pub fn tip(&self) -> &str {
        &self.tip
    }

    /// The arm's skin-covered parts.
    pub fn parts(&self) -> &[BodyPart] {
        &self.parts
    }

    /// The fixed obstacles.
    pub fn obstacles(&self) -> &[Solid] {
        &self.obstacles
    }

    /// Spring stiffness K, N/m.
    pub fn stiffness(&self) -> f64 {
        self.stiffness
    }

    /// The hand point (tip frame origin) at a posture.
    pub fn hand(&self, at: &Posture<'_>) -> Point3<f64> {
        at.link_pose(&self.tip)
            .map_or(Point3::origin(), |p| Point3::from(p.translation.vector))
    }

    /// True when the straight segment from `a` to `b` crosses an obstacle.
    pub fn blocked(&self, a: &Point3<f64>, b: &Point3<f64>) -> bool {
        self.obstacles.iter().any(|o| o.crosses(a, b))
    }

    /// Skin contacts and spring forces at posture `at`, against the obstacles and `extra`
    /// solids (things that touch the arm, such as a hand).
    pub fn sense(&self, at: &Posture<'_>, extra: &[Solid]) -> Sensing {
        let mut out = Sensing::default();
        for part in &self.parts {
            let Ok(pose) = at.link_pose(&part.link) else {
                continue;
            };
            let ppose = to_pose(&pose);
            let mut touching: Vec<&Solid> = Vec::new();
            for solid in self.obstacles.iter().chain(extra) {
                let c = query::contact(&ppose, &part.shape, &solid.pose, solid.shape.shape(), 0.0);
                if let Ok(Some(c)) = c
                    && c.dist < 0.0
                {
                    out.max_force = out.max_force.max(-c.dist * self.stiffness);
                    touching.push(solid);
                }
            }
            if touching.is_empty() {
                continue;
            }
            let mut contacts = Vec::new();
            for (p, n) in &part.taxels {
                let wp = pose * p;
                let depth = touching
                    .iter()
                    .map(|s| -s.signed_distance(&wp))
                    .fold(0.0, f64::max);
                let force = depth * self.stiffness;
                if force >= SKIN_FLOOR {
                    out.skin_max = out.skin_max.max(force);
                    contacts.push(Contact {
                        point: wp,
                        normal: Unit::new_unchecked(pose.rotation * n.into_inner()),
                        force,
                        stiffness: self.stiffness,
                    });
                }
            }
            if contacts.is_empty() {
                continue;
            }
            out.taxels_in_contact += contacts.len();
            let grouped = group_contacts(&contacts, CONTACT_RADIUS);
            match out.taxels.iter_mut().find(|lc| lc.link == part.link) {
                Some(lc) => lc.contacts.extend(contacts),
                None => out.taxels.push(LinkContacts {
                    link: part.link.clone(),
                    contacts,
                }),
            }
            let contacts = grouped;
            match out.contacts.iter_mut().find(|lc| lc.link == part.link) {
                Some(lc) => lc.contacts.extend(contacts),
                None => out.contacts.push(LinkContacts {
                    link: part.link.clone(),
                    contacts,
                }),
            }
        }
        out
    }
}
