//! Stitching the tactile maps of a chain of links into one (thesis Ch. 6): the [`Stitcher`] and
//! its algorithms, one a file.

mod bfgs;
mod chain;
mod cost;
mod edges;
mod joint_chart;
mod kabsch;
mod options;
mod placement;
mod raster;
mod report;
mod svg;

pub use chain::PostureChain;
pub use options::{Deadline, JointMode, StitchOptions};
pub use placement::Placement;
pub use raster::StitchedRasterizer;
pub use report::{BridgeTriangle, ChainTaxel, JointSolve, StitchReport};
pub use svg::stitched_svg;

use crate::tactile_map::TactileMap;
use crate::{ChainError, Error, Result};
use cost::centroid2;

use joint_chart::{JointChart, fixed_chart, taxel_normals};
use nalgebra::{Isometry3, Point2, Point3, Rotation2, Unit, Vector2, Vector3};

#[derive(Debug, Clone)]
struct Joint {
    /// Taxel indices of the boundary on the parent and on the child.
    parent: Vec<usize>,
    child: Vec<usize>,
    chart: JointChart,
    mode: JointMode,
    /// Last placement of the child map relative to the parent map.
    placement: Placement,
    /// Cross triangles of the last triangulation, as (link, taxel) corners.
    bridges: Vec<BridgeTriangle>,
}

/// Stitches the tactile maps of a chain of links into one, every control cycle (thesis Ch. 6).
///
/// Each link keeps its own fixed map (its distortion never changes with the posture); only the
/// placement of each child map relative to its parent's moves with the joint. For each joint,
/// every cycle:
///
/// 1. the boundary taxels of both links (chosen once: those within `boundary_distance` of the
///    other link at the reference posture, or given) are brought into the parent's frame with the
///    current link poses and triangulated (Delaunay in a chart of the joint region fixed at set-up:
///    plane or unrolled cylinder); the edges joining the two links and shorter than `max_edge`
///    (3 cm) form the adjacency E (Eq. 6.1) with 3D lengths D^x (Eq. 6.2);
/// 2. the child map's roto-translation theta = (alpha, tx, ty) relative to the parent map
///    minimises Eq. 6.6, 1/2 sum over E of (d^x - |u_A - (R(alpha) u_B + t)|)^2 (Eq. 6.3-6.5),
///    with argmin's BFGS (backtracking Armijo line search, first step scaled by the Gauss-Newton
///    Hessian), warm-started from the previous cycle;
/// 3. every iterate is usable, so a deadline (iterations or time) returns the best one so far
///    with its cost and whether the solver converged.
///
/// Joints whose maps are pre-aligned so that the joint's motion slides the child map without
/// turning it (a roll joint between two cylinders, Ch. 6.4) can be solved for the translation
/// alone ([`JointMode::TranslationOnly`]), which removes the trigonometric non-linearity.
///
/// Inside the solver, lengths are in millimetres and the angle is scaled by the spread of the
/// child's boundary taxels (and turns about their centroid), so that all three parameters move the
/// taxels by comparable amounts: BFGS's first step from an identity inverse Hessian is then
/// sensible.
#[derive(Debug, Clone)]
pub struct Stitcher {
    maps: Vec<TactileMap>,
    joints: Vec<Joint>,
    options: StitchOptions,
    // Per-cycle scratch, reused so that a cycle allocates as little as possible.
    chart_points: Vec<Point2<f64>>,
    world: Vec<Point3<f64>>,
}

fn check_pose(k: usize, pose: &Isometry3<f64>) -> Result<()> {
    let ok = pose.translation.vector.iter().all(|v| v.is_finite())
        && pose.rotation.coords.iter().all(|v| v.is_finite());
    if ok {
        Ok(())
    } else {
        Err(Error::NotFinite {
            what: format!("the pose of link {k}"),
        })
    }
}

impl Stitcher {
    /// A stitcher for the chain `maps[0] - maps[1] - ...` (each with its taxels' 3D positions in
    /// its link frame), choosing each joint's boundary taxels at the `reference` poses (one per
    /// link, link frame to world; the middle of each joint's range is a good choice). Each joint
    /// is solved once at the reference posture ([`Stitcher::reset`]) and that solution is the
    /// first warm start ([`Stitcher::set_placement`] overrides it).
    pub fn new(
        maps: Vec<TactileMap>,
        reference: &[Isometry3<f64>],
        options: StitchOptions,
    ) -> Result<Stitcher> {
        if maps.len() < 2 {
            return Err(Error::Chain(ChainError::TooFewLinks(maps.len())));
        }
        if reference.len() != maps.len() {
            return Err(Error::Length {
                what: "reference poses for the links",
                got: reference.len(),
                expected: maps.len(),
            });
        }
        let mut boundaries = Vec::new();
        for j in 0..maps.len() - 1 {
            check_pose(j, &reference[j])?;
            check_pose(j + 1, &reference[j + 1])?;
            let near = |a: usize, b: usize| -> Vec<usize> {
                let other: Vec<Point3<f64>> = maps[b].positions.iter().map(|p| reference[b] * p).collect();
                (0..maps[a].positions.len())
                    .filter(|&i| {
                        let p = reference[a] * maps[a].positions[i];
                        other.iter().any(|q| (q - p).norm() <= options.boundary_distance)
                    })
                    .collect()
            };
            boundaries.push((near(j, j + 1), near(j + 1, j)));
        }
        Self::with_boundaries(maps, boundaries, reference, options)
    }

    /// A stitcher with the boundary taxels given: for joint j, (taxel indices on link j, on link
    /// j + 1). `reference` poses fix each joint's chart.
    pub fn with_boundaries(
        maps: Vec<TactileMap>,
        boundaries: Vec<(Vec<usize>, Vec<usize>)>,
        reference: &[Isometry3<f64>],
        options: StitchOptions,
    ) -> Result<Stitcher> {
        if maps.len() < 2 {
            return Err(Error::Chain(ChainError::TooFewLinks(maps.len())));
        }
        for (what, got, expected) in [
            ("boundaries for the joints", boundaries.len(), maps.len() - 1),
            ("reference poses for the links", reference.len(), maps.len()),
        ] {
            if got != expected {
                return Err(Error::Length { what, got, expected });
            }
        }
        for (k, m) in maps.iter().enumerate() {
            if m.positions.len() != m.points.len() {
                return Err(Error::Chain(ChainError::NoPositions {
                    index: k,
                    name: m.name.clone(),
                }));
            }
        }
        let mut joints = Vec::new();
        for (j, (parent, child)) in boundaries.into_iter().enumerate() {
            check_pose(j, &reference[j])?;
            check_pose(j + 1, &reference[j + 1])?;
            for (list, map) in [(&parent, &maps[j]), (&child, &maps[j + 1])] {
                if list.is_empty() {
                    return Err(Error::Chain(ChainError::NoBoundary {
                        joint: j,
                        link: map.name.clone(),
                    }));
                }
                if let Some(&bad) = list.iter().find(|&&i| i >= map.points.len()) {
                    return Err(Error::Chain(ChainError::BoundaryIndex {
                        joint: j,
                        index: bad,
                        taxels: map.points.len(),
                        link: map.name.clone(),
                    }));
                }
            }
            // The joint region at the reference posture, in the parent's frame.
            let to_parent = reference[j].inverse() * reference[j + 1];
            let mut points: Vec<Point3<f64>> = parent.iter().map(|&i| maps[j].positions[i]).collect();
            points.extend(child.iter().map(|&i| to_parent * maps[j + 1].positions[i]));
            let (na, nb) = (taxel_normals(&maps[j]), taxel_normals(&maps[j + 1]));
            let mut normals: Vec<Unit<Vector3<f64>>> = parent.iter().map(|&i| na[i]).collect();
            normals.extend(child.iter().map(|&i| to_parent.rotation * nb[i]));
            let chart = fixed_chart(&points, &normals)?;
            // The placement is set by the reference solve below.
            joints.push(Joint {
                parent,
                child,
                chart,
                mode: JointMode::Full,
                placement: Placement::IDENTITY,
                bridges: Vec::new(),
            });
        }
        let mut stitcher = Stitcher {
            maps,
            joints,
            options,
            chart_points: Vec::new(),
            world: Vec::new(),
        };
        stitcher.reset(reference)?;
        Ok(stitcher)
    }

    /// Solves every joint afresh at `poses`: for a first cycle, or after the posture jumped (a warm
    /// start only helps when the posture moved little since the last cycle). The start extends
    /// the parent's map over the child's boundary taxels (a local affine fit of the parent map
    /// around each of them, from 3D to 2D) and fits the child map onto those points; Eq. 6.6 is
    /// then solved from there. Distances alone have folded local minima (the child map laid over
    /// the parent's boundary rows); this start avoids them.
    pub fn reset(&mut self, poses: &[Isometry3<f64>]) -> Result<StitchReport> {
        self.check_poses(poses)?;
        let mut joints = Vec::with_capacity(self.joints.len());
        for j in 0..self.joints.len() {
            let to_parent = poses[j].inverse() * poses[j + 1];
            let last = self.joints[j].placement;
            let fixed = match self.joints[j].mode {
                JointMode::TranslationOnly { angle } => Some(angle),
                JointMode::Full => None,
            };
            self.joints[j].placement = match self.extension_start(j, &to_parent, fixed) {
                Some(p) => p,
                None => {
                    let (ca, cb) = self.boundary_centroids(j);
                    let angle = fixed.unwrap_or(0.0);
                    Placement {
                        angle,
                        offset: ca - Rotation2::new(angle) * cb,
                    }
                }
            };
            let best = self.solve_joint(j, &to_parent, Deadline::Iterations(200))?;
            self.joints[j].placement = if best.kept_last { last } else { best.placement };
            joints.push(JointSolve {
                placement: self.joints[j].placement,
                ..best
            });
        }
        Ok(self.report(joints))
    }
    /// One finite pose per link, or an error saying what is wrong.
    fn check_poses(&self, poses: &[Isometry3<f64>]) -> Result<()> {
        if poses.len() != self.maps.len() {
            return Err(Error::Length {
                what: "poses for the chain's links",
                got: poses.len(),
                expected: self.maps.len(),
            });
        }
        for (k, p) in poses.iter().enumerate() {
            check_pose(k, p)?;
        }
        Ok(())
    }

    /// Centroids of joint `j`'s boundary taxels on the parent map and on the child map.
    fn boundary_centroids(&self, j: usize) -> (Vector2<f64>, Vector2<f64>) {
        let joint = &self.joints[j];
        (
            centroid2(joint.parent.iter().map(|&i| self.maps[j].points[i])),
            centroid2(joint.child.iter().map(|&i| self.maps[j + 1].points[i])),
        )
    }

    /// The link maps.
    pub fn maps(&self) -> &[TactileMap] {
        &self.maps
    }

    /// Boundary taxels of joint `j`: (on link j, on link j + 1).
    pub fn boundary(&self, j: usize) -> Option<(&[usize], &[usize])> {
        self.joints
            .get(j)
            .map(|b| (b.parent.as_slice(), b.child.as_slice()))
    }

    /// How well placements keep the skin's lengths across joint `j`: the worst relative
    /// difference between a cross-boundary pair's 3D distance at `poses` and its distance on the
    /// placed maps, over pairs closer than `max_edge` (metres) in 3D, and how many pairs that is.
    /// (0, 0) for a joint with no boundary.
    pub fn edge_fidelity(
        &self,
        j: usize,
        poses: &[Isometry3<f64>],
        placements: &[Placement],
        max_edge: f64,
    ) -> (f64, usize) {
        let (Some((a, b)), Some(pose), Some(child_pose), Some(pa), Some(pb)) = (
            self.boundary(j),
            poses.get(j),
            poses.get(j + 1),
            placements.get(j),
            placements.get(j + 1),
        ) else {
            return (0.0, 0);
        };
        let (ma, mb) = (&self.maps[j], &self.maps[j + 1]);
        let mut worst: f64 = 0.0;
        let mut n = 0;
        for &i in a {
            for &k in b {
                let d3 = (pose * ma.positions[i] - child_pose * mb.positions[k]).norm();
                if d3 > max_edge || d3 == 0.0 {
                    continue;
                }
                let d2 = (pa.apply(&ma.points[i]) - pb.apply(&mb.points[k])).norm();
                worst = worst.max((d2 - d3).abs() / d3);
                n += 1;
            }
        }
        (worst, n)
    }

    /// Solves joint `j` in `mode` from now on.
    pub fn set_mode(&mut self, j: usize, mode: JointMode) {
        if let Some(joint) = self.joints.get_mut(j) {
            joint.mode = mode;
            if let JointMode::TranslationOnly { angle } = mode {
                joint.placement.angle = angle;
            }
        }
    }

    /// The warm start of joint `j` (the child map relative to the parent map).
    pub fn set_placement(&mut self, j: usize, placement: Placement) {
        if let Some(joint) = self.joints.get_mut(j) {
            joint.placement = placement;
        }
    }

    /// One cycle: the current pose of every link (link frame to world), and how long each joint's
    /// solve may take. A zero deadline solves nothing: every joint keeps its last placement
    /// (reported as not converged, zero iterations).
    pub fn update(&mut self, poses: &[Isometry3<f64>], deadline: Deadline) -> Result<StitchReport> {
        self.check_poses(poses)?;
        let mut joints = Vec::with_capacity(self.joints.len());
        for j in 0..self.joints.len() {
            let to_parent = poses[j].inverse() * poses[j + 1];
            joints.push(self.solve_joint(j, &to_parent, deadline)?);
        }
        Ok(self.report(joints))
    }

    fn report(&self, joints: Vec<JointSolve>) -> StitchReport {
        let mut placements = vec![Placement::IDENTITY];
        for (j, s) in joints.iter().enumerate() {
            placements.push(placements[j].compose(&s.placement));
        }
        let bridges = self
            .joints
            .iter()
            .flat_map(|j| j.bridges.iter().copied())
            .collect();
        StitchReport {
            placements,
            joints,
            bridges,
        }
    }
}
