//! Stitching the tactile maps of a chain of links into one, every control cycle (thesis Ch. 6).
//!
//! Each link keeps its own fixed map (its distortion never changes with the posture); only the
//! placement of each child map relative to its parent's moves with the joint. For each joint,
//! every cycle:
//!
//! 1. the boundary taxels of both links (chosen once: those within `boundary_distance` of the
//!    other link at the reference posture, or given) are brought into the parent's frame with the
//!    current link poses and triangulated (Delaunay in a chart of the joint region fixed at set-up:
//!    plane or unrolled cylinder); the edges joining the two links and shorter than `max_edge`
//!    (3 cm) form the adjacency E (Eq. 6.1) with 3D lengths D^x (Eq. 6.2);
//! 2. the child map's roto-translation theta = (alpha, tx, ty) relative to the parent map
//!    minimises Eq. 6.6, 1/2 sum over E of (d^x - |u_A - (R(alpha) u_B + t)|)^2 (Eq. 6.3-6.5),
//!    with argmin's BFGS (backtracking Armijo line search, first step scaled by the Gauss-Newton
//!    Hessian), warm-started from the previous cycle;
//! 3. every iterate is usable, so a deadline (iterations or time) returns the best one so far
//!    with its cost and whether the solver converged.
//!
//! Joints whose maps are pre-aligned so that the joint's motion slides the child map without
//! turning it (a roll joint between two cylinders, Ch. 6.4) can be solved for the translation
//! alone ([`JointMode::TranslationOnly`]), which removes the trigonometric non-linearity.
//!
//! Inside the solver, lengths are in millimetres and the angle is scaled by the spread of the
//! child's boundary taxels (and turns about their centroid), so that all three parameters move the
//! taxels by comparable amounts: BFGS's first step from an identity inverse Hessian is then
//! sensible.

use crate::chart::{Chart, choose_chart};
use crate::tactile_map::TactileMap;
use crate::triangulate::delaunay;
use crate::{ChainError, Error, Result};
use argmin::core::{CostFunction, Executor, Gradient, State, TerminationReason, TerminationStatus};
use argmin::solver::linesearch::BacktrackingLineSearch;
use argmin::solver::linesearch::condition::ArmijoCondition;
use argmin::solver::quasinewton::BFGS;
use nalgebra::{Isometry3, Point2, Point3, Rotation2, Unit, Vector2, Vector3};
use std::time::Duration;

/// Where a map lies in the stitched plane: p' = R(angle) p + offset (metres, radians).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Rotation, radians, counter-clockwise.
    pub angle: f64,
    /// Translation, metres.
    pub offset: Vector2<f64>,
}

impl Placement {
    /// No rotation, no translation.
    pub const IDENTITY: Placement = Placement {
        angle: 0.0,
        offset: Vector2::new(0.0, 0.0),
    };

    /// The placed position of map point `p`.
    pub fn apply(&self, p: &Point2<f64>) -> Point2<f64> {
        Rotation2::new(self.angle) * p + self.offset
    }

    /// `self` after `inner`: p -> self(inner(p)).
    pub fn compose(&self, inner: &Placement) -> Placement {
        Placement {
            angle: self.angle + inner.angle,
            offset: Rotation2::new(self.angle) * inner.offset + self.offset,
        }
    }

    /// The map point placed at `q`.
    pub fn invert(&self, q: &Point2<f64>) -> Point2<f64> {
        Rotation2::new(-self.angle) * (q - self.offset)
    }
}

/// What is solved at a joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointMode {
    /// Rotation and translation of the child map (Eq. 6.6 in full).
    Full,
    /// Translation only, the rotation held at `angle` (maps pre-aligned, Ch. 6.4).
    TranslationOnly {
        /// The fixed rotation of the child map relative to its parent, radians.
        angle: f64,
    },
}

/// How much time a cycle's solve may take.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Deadline {
    /// At most this many solver iterations per joint.
    Iterations(u64),
    /// At most this long per joint (checked between iterations).
    Time(Duration),
}

/// Settings of a [`Stitcher`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StitchOptions {
    /// Cross-boundary edges longer than this (3D, metres) are dropped (default 0.03, as Ch. 6.4).
    pub max_edge: f64,
    /// Boundary taxels: those within this distance (metres) of the other link at the reference
    /// posture (default 0.03).
    pub boundary_distance: f64,
    /// The solver has converged when the norm of the gradient of Eq. 6.6 (in mm^2 per mm) is under
    /// this (default 1e-2: with tens of edges, a placement within about a micrometre of the
    /// optimum).
    pub tolerance: f64,
}

impl Default for StitchOptions {
    fn default() -> Self {
        StitchOptions {
            max_edge: 0.03,
            boundary_distance: 0.03,
            tolerance: 1e-2,
        }
    }
}

/// One joint's result for a cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointSolve {
    /// The child map's placement relative to the parent map.
    pub placement: Placement,
    /// Eq. 6.6 at the returned placement, square metres.
    pub cost: f64,
    /// Eq. 6.6 at the start (the warm start), square metres.
    pub start_cost: f64,
    /// Solver iterations spent.
    pub iterations: u64,
    /// The solver met its tolerance before the deadline.
    pub converged: bool,
    /// Edges in E this cycle.
    pub edges: usize,
    /// No edge joined the links this cycle: the last placement was kept.
    pub kept_last: bool,
}

/// Per-link poses in, placements of every map out.
#[derive(Debug, Clone, PartialEq)]
pub struct StitchReport {
    /// Placement of every link's map in the stitched plane (link 0 at the identity).
    pub placements: Vec<Placement>,
    /// One entry per joint (joint j joins link j and link j + 1).
    pub joints: Vec<JointSolve>,
    /// The triangles across the joints this cycle (every edge under `max_edge`), each corner a
    /// (link, taxel index) pair: the skin between two links' maps, which a stitched image fills
    /// by interpolating across them.
    pub bridges: Vec<[(usize, usize); 3]>,
}

/// Fixed 2D chart of a joint region, in the parent link's frame.
#[derive(Debug, Clone, Copy)]
struct JointChart {
    chart: Chart,
    centre: Point3<f64>,
    e1: Vector3<f64>,
    e2: Vector3<f64>,
}

impl JointChart {
    fn project(&self, p: &Point3<f64>) -> Point2<f64> {
        match self.chart {
            Chart::Plane { .. } => {
                let d = p - self.centre;
                Point2::new(d.dot(&self.e1), d.dot(&self.e2))
            }
            Chart::Cylinder { axis, centre, radius } => {
                let axis = Vector3::from(axis);
                let d = p - Point3::from(centre);
                let along = d.dot(&axis);
                let angle = d.dot(&self.e2).atan2(d.dot(&self.e1));
                Point2::new(radius * angle, along)
            }
        }
    }
}

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
    bridges: Vec<[(usize, usize); 3]>,
}

/// Stitches a chain of link maps; see the module documentation.
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

    /// Where the parent map, extended, would put the child's boundary taxels, and the child-map
    /// placement that best fits them (Kabsch in 2D; only the offset when the angle is fixed).
    fn extension_start(&self, j: usize, to_parent: &Isometry3<f64>, fixed: Option<f64>) -> Option<Placement> {
        let joint = &self.joints[j];
        let (pm, cm) = (&self.maps[j], &self.maps[j + 1]);
        let parent3: Vec<Point3<f64>> = joint.parent.iter().map(|&i| pm.positions[i]).collect();
        let k = 6.min(parent3.len());
        if k < 4 {
            return None;
        }
        let mut from = Vec::new();
        let mut to = Vec::new();
        for &c in &joint.child {
            let q = to_parent * cm.positions[c];
            let mut near: Vec<(f64, usize)> = parent3
                .iter()
                .enumerate()
                .map(|(i, p)| ((p - q).norm_squared(), i))
                .collect();
            near.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0));
            // Affine map [x y z 1] -> map point, least squares with a little ridge (the points are
            // nearly coplanar, so their normal direction is unconstrained).
            let centre = near[..k]
                .iter()
                .fold(Vector3::zeros(), |s, &(_, i)| s + parent3[i].coords)
                / k as f64;
            let mut ata = nalgebra::Matrix4::<f64>::zeros();
            let mut atb = nalgebra::Matrix4x2::<f64>::zeros();
            for &(_, i) in &near[..k] {
                let d = (parent3[i].coords - centre) * 1e3; // mm
                let row = nalgebra::Vector4::new(d.x, d.y, d.z, 1.0);
                let u = pm.points[joint.parent[i]].coords * 1e3;
                ata += row * row.transpose();
                atb += row * u.transpose();
            }
            for r in 0..3 {
                ata[(r, r)] += 1e-3;
            }
            let coef = ata.cholesky()?.solve(&atb);
            let d = (q.coords - centre) * 1e3;
            let u = coef.transpose() * nalgebra::Vector4::new(d.x, d.y, d.z, 1.0) * 1e-3;
            from.push(cm.points[c].coords);
            to.push(u);
        }
        let n = from.len() as f64;
        let cf = from.iter().sum::<Vector2<f64>>() / n;
        let ct = to.iter().sum::<Vector2<f64>>() / n;
        let angle = fixed.unwrap_or_else(|| {
            let (mut sxx, mut sxy) = (0.0, 0.0);
            for (f, t) in from.iter().zip(&to) {
                let (a, b) = (f - cf, t - ct);
                sxx += a.x * b.x + a.y * b.y;
                sxy += a.x * b.y - a.y * b.x;
            }
            sxy.atan2(sxx)
        });
        let placement = Placement {
            angle,
            offset: ct - Rotation2::new(angle) * cf,
        };
        (placement.angle.is_finite() && placement.offset.iter().all(|v| v.is_finite())).then_some(placement)
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

    /// Eq. 6.1-6.2 for joint `j`: edges (parent boundary index, child boundary index, 3D length)
    /// of the cross-boundary Delaunay triangulation, at most `max_edge` long.
    fn edges(&mut self, j: usize, to_parent: &Isometry3<f64>) -> Result<Vec<(usize, usize, f64)>> {
        let joint = &self.joints[j];
        let (parent_map, child_map) = (&self.maps[j], &self.maps[j + 1]);
        self.world.clear();
        self.world
            .extend(joint.parent.iter().map(|&i| parent_map.positions[i]));
        self.world
            .extend(joint.child.iter().map(|&i| to_parent * child_map.positions[i]));
        let chart = joint.chart;
        self.chart_points.clear();
        self.chart_points
            .extend(self.world.iter().map(|p| chart.project(p)));
        if let Chart::Cylinder { radius, .. } = chart.chart {
            unwrap_angles(&mut self.chart_points, radius);
        }
        let triangles = cross_delaunay(&self.chart_points)?;
        let np = joint.parent.len();
        let max_edge = self.options.max_edge;
        let corner = |v: usize| {
            if v < np {
                (j, joint.parent[v])
            } else {
                (j + 1, joint.child[v - np])
            }
        };
        let bridges: Vec<[(usize, usize); 3]> = triangles
            .iter()
            .filter(|t| {
                let mixed = t.iter().any(|&v| v < np) && t.iter().any(|&v| v >= np);
                mixed && (0..3).all(|k| (self.world[t[k]] - self.world[t[(k + 1) % 3]]).norm() <= max_edge)
            })
            .map(|t| t.map(corner))
            .collect();
        // Each cross edge, once (an inner edge belongs to two triangles).
        let mut pairs: Vec<(usize, usize)> = triangles
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .map(|(a, b)| (a.min(b), a.max(b)))
            .filter(|&(a, b)| a < np && b >= np)
            .collect();
        pairs.sort_unstable();
        pairs.dedup();
        let edges: Vec<(usize, usize, f64)> = pairs
            .into_iter()
            .map(|(a, b)| (a, b - np, (self.world[a] - self.world[b]).norm()))
            .filter(|e| e.2 <= max_edge)
            .collect();
        self.joints[j].bridges = bridges;
        Ok(edges)
    }

    fn solve_joint(
        &mut self,
        j: usize,
        to_parent: &Isometry3<f64>,
        deadline: Deadline,
    ) -> Result<JointSolve> {
        let edges = self.edges(j, to_parent)?;
        let joint = &self.joints[j];
        let last = joint.placement;
        let kept = |edges: usize, cost: f64| JointSolve {
            placement: last,
            cost,
            start_cost: cost,
            iterations: 0,
            converged: false,
            edges,
            kept_last: true,
        };
        if edges.is_empty() {
            return Ok(kept(0, f64::NAN));
        }
        let problem = Eq66::new(&self.maps[j], &self.maps[j + 1], joint, &edges);
        let start = problem.param_of(&last);
        let start_cost = problem.cost_m2(&start);
        let budget_is_zero = match deadline {
            Deadline::Iterations(n) => n == 0,
            Deadline::Time(t) => t.is_zero(),
        };
        if budget_is_zero {
            return Ok(JointSolve {
                kept_last: false,
                ..kept(edges.len(), start_cost)
            });
        }
        // Already at a minimum: nothing to do (a line search from a stationary point cannot make
        // progress and is not asked to).
        let g0 = problem.gradient_mm(&start);
        if g0.iter().map(|g| g * g).sum::<f64>().sqrt() < self.options.tolerance {
            return Ok(JointSolve {
                converged: true,
                kept_last: false,
                ..kept(edges.len(), start_cost)
            });
        }
        let inv_hessian = problem.gauss_newton_inverse(&start);
        // Backtracking (Armijo) rather than More-Thuente: it always ends, which a control loop
        // needs; the Gauss-Newton scaling makes the first trial step usually the right one.
        let condition =
            ArmijoCondition::new(1e-4).map_err(|e| Error::Solve(format!("solver set-up: {e}")))?;
        let solver = BFGS::new(BacktrackingLineSearch::new(condition))
            .with_tolerance_grad(self.options.tolerance)
            .map_err(|e| Error::Solve(format!("solver set-up: {e}")))?
            .with_tolerance_cost(0.0)
            .map_err(|e| Error::Solve(format!("solver set-up: {e}")))?;
        let (max_iters, timeout) = match deadline {
            Deadline::Iterations(n) => (n, None),
            Deadline::Time(t) => (1_000, Some(t)),
        };
        *problem.best.borrow_mut() = (problem.cost_mm2(&start), start.clone());
        let mut executor = Executor::new(problem.clone(), solver).configure(|state| {
            state
                .param(start.clone())
                .inv_hessian(inv_hessian)
                .max_iters(max_iters)
        });
        if let Some(t) = timeout {
            executor = executor.timeout(t);
        }
        let (iterations, converged) = match executor.run() {
            Ok(result) => {
                let state = result.state();
                let converged = matches!(
                    state.get_termination_status(),
                    TerminationStatus::Terminated(TerminationReason::SolverConverged)
                );
                (state.get_iter(), converged)
            }
            // A degenerate step stopped the solver: the best point it evaluated is kept, and
            // reported as not converged.
            Err(_) => (0, false),
        };
        let best = problem.best.borrow().1.clone();
        let best = if best.len() == start.len() {
            best
        } else {
            start.clone()
        };
        let cost = problem.cost_m2(&best);
        let (best, cost) = if cost <= start_cost {
            (best, cost)
        } else {
            (start, start_cost)
        };
        let placement = problem.placement_of(&best);
        self.joints[j].placement = placement;
        Ok(JointSolve {
            placement,
            cost,
            start_cost,
            iterations,
            converged,
            edges: edges.len(),
            kept_last: false,
        })
    }
}

/// Outward unit normals of a map's taxels, from its 3D triangles (counter-clockwise on the map,
/// so their 3D normals point out of the skin); a taxel in no triangle gets the mean normal.
fn taxel_normals(map: &TactileMap) -> Vec<Unit<Vector3<f64>>> {
    let mut sums = vec![Vector3::zeros(); map.positions.len()];
    for f in &map.faces {
        let [a, b, c] = f.map(|i| map.positions[i]);
        let n = (b - a).cross(&(c - a)); // area-weighted
        for &i in f {
            sums[i] += n;
        }
    }
    let mean: Vector3<f64> = sums.iter().sum();
    sums.into_iter()
        .map(|n| {
            if n.norm() > 0.0 {
                Unit::new_normalize(n)
            } else if mean.norm() > 0.0 {
                Unit::new_normalize(mean)
            } else {
                Vector3::z_axis()
            }
        })
        .collect()
}

fn fixed_chart(points: &[Point3<f64>], normals: &[Unit<Vector3<f64>>]) -> Result<JointChart> {
    let (chart, _) = choose_chart(points, normals)?;
    let (centre, _, axes) = crate::chart::principal_axes(points);
    let (e1, e2) = match chart {
        Chart::Plane { normal } => {
            let n = Vector3::from(normal);
            let e1 = (axes[2] - n * axes[2].dot(&n)).normalize();
            (e1, n.cross(&e1))
        }
        Chart::Cylinder { axis, .. } => {
            let a = Vector3::from(axis);
            let b = if a.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::y()
            };
            let e1 = (b - a * b.dot(&a)).normalize();
            (e1, a.cross(&e1))
        }
    };
    Ok(JointChart {
        chart,
        centre,
        e1,
        e2,
    })
}

/// Cuts the unrolled angles at the widest empty sector, so the region is in one piece.
fn unwrap_angles(coords: &mut [Point2<f64>], radius: f64) {
    if coords.is_empty() || radius <= 0.0 {
        return;
    }
    let tau = std::f64::consts::TAU;
    let mut angles: Vec<f64> = coords.iter().map(|c| c.x / radius).collect();
    angles.sort_by(f64::total_cmp);
    let mut cut = angles[0] + tau;
    let mut widest = angles[0] + tau - angles[angles.len() - 1];
    for w in angles.windows(2) {
        if w[1] - w[0] > widest {
            widest = w[1] - w[0];
            cut = w[1];
        }
    }
    for c in coords.iter_mut() {
        let mut a = c.x / radius;
        while a < cut {
            a += tau;
        }
        while a >= cut + tau {
            a -= tau;
        }
        c.x = a * radius;
    }
}

/// Delaunay triangles of the joint region: spade's bulk loading (several times faster than
/// inserting point by point, which the set-up of a map can afford but a control cycle cannot),
/// keeping the input order; points that coincide fall back to incremental insertion, which
/// merges them.
fn cross_delaunay(points: &[Point2<f64>]) -> Result<Vec<[usize; 3]>> {
    use spade::{DelaunayTriangulation, Triangulation};
    let vertices: Vec<spade::Point2<f64>> = points.iter().map(|p| spade::Point2::new(p.x, p.y)).collect();
    let tri = DelaunayTriangulation::<spade::Point2<f64>>::bulk_load_stable(vertices)
        .map_err(|e| Error::TooFewTaxels(format!("joint region cannot be triangulated: {e:?}")))?;
    if tri.num_vertices() < points.len() {
        return delaunay(points);
    }
    Ok(tri
        .inner_faces()
        .map(|f| f.vertices().map(|v| v.fix().index()))
        .collect())
}

fn centroid2(points: impl Iterator<Item = Point2<f64>>) -> Vector2<f64> {
    let (mut sum, mut n) = (Vector2::zeros(), 0usize);
    for p in points {
        sum += p.coords;
        n += 1;
    }
    sum / n.max(1) as f64
}

/// Eq. 6.6 for one joint, in solver units: millimetres, and the angle times the RMS radius of the
/// child's boundary taxels about their centroid c (the child turns about c).
#[derive(Debug, Clone)]
struct Eq66 {
    /// Per edge: parent point u_A, child point u_B minus c (both mm), and the 3D length (mm).
    edges: Vec<(Vector2<f64>, Vector2<f64>, f64)>,
    /// Child boundary centroid, mm.
    c: Vector2<f64>,
    /// Angle scale: RMS radius of the child's edge points about c, mm.
    rho: f64,
    /// `Some(angle)`: translation only, at this angle.
    fixed_angle: Option<f64>,
    /// The best point the solver has evaluated (cost in mm^2, parameters): every iterate is
    /// usable, so whatever stops the solver, this is the answer.
    /// Shared by the clone the solver runs on, so it survives a solver error.
    best: std::rc::Rc<std::cell::RefCell<(f64, Vec<f64>)>>,
}

impl Eq66 {
    fn new(parent: &TactileMap, child: &TactileMap, joint: &Joint, edges: &[(usize, usize, f64)]) -> Eq66 {
        let c = centroid2(edges.iter().map(|e| child.points[joint.child[e.1]])) * 1e3;
        let list: Vec<(Vector2<f64>, Vector2<f64>, f64)> = edges
            .iter()
            .map(|&(a, b, d)| {
                (
                    parent.points[joint.parent[a]].coords * 1e3,
                    child.points[joint.child[b]].coords * 1e3 - c,
                    d * 1e3,
                )
            })
            .collect();
        let rho = (list.iter().map(|e| e.1.norm_squared()).sum::<f64>() / list.len().max(1) as f64)
            .sqrt()
            .max(1.0);
        let fixed_angle = match joint.mode {
            JointMode::Full => None,
            JointMode::TranslationOnly { angle } => Some(angle),
        };
        Eq66 {
            edges: list,
            c,
            rho,
            fixed_angle,
            best: std::rc::Rc::new(std::cell::RefCell::new((f64::INFINITY, Vec::new()))),
        }
    }

    /// (angle, s) from solver parameters: the child point u goes to R(angle)(u - c) + c + s.
    fn split(&self, p: &[f64]) -> (f64, Vector2<f64>) {
        match self.fixed_angle {
            Some(a) => (a, Vector2::new(p[0], p[1])),
            None => (p[0] / self.rho, Vector2::new(p[1], p[2])),
        }
    }

    fn param_of(&self, placement: &Placement) -> Vec<f64> {
        // offset (mm) = c + s - R c  =>  s = offset - c + R c
        let angle = self.fixed_angle.unwrap_or(placement.angle);
        let s = placement.offset * 1e3 - self.c + Rotation2::new(angle) * self.c;
        match self.fixed_angle {
            Some(_) => vec![s.x, s.y],
            None => vec![angle * self.rho, s.x, s.y],
        }
    }

    fn placement_of(&self, p: &[f64]) -> Placement {
        let (angle, s) = self.split(p);
        Placement {
            angle,
            offset: (self.c + s - Rotation2::new(angle) * self.c) * 1e-3,
        }
    }

    fn cost_mm2(&self, p: &[f64]) -> f64 {
        let (angle, s) = self.split(p);
        let r = Rotation2::new(angle);
        0.5 * self
            .edges
            .iter()
            .map(|(ua, ub, dx)| {
                let du = (ua - (r * ub + self.c + s)).norm();
                (dx - du).powi(2)
            })
            .sum::<f64>()
    }

    /// The inverse of the Gauss-Newton Hessian sum J^T J at `p` (J: derivatives of the 2D edge
    /// lengths), lightly damped: BFGS's first step is then a Gauss-Newton step, which is what lets
    /// a warm start converge in a few iterations.
    fn gauss_newton_inverse(&self, p: &[f64]) -> Vec<Vec<f64>> {
        let (angle, s) = self.split(p);
        let r = Rotation2::new(angle);
        let (sin, cos) = angle.sin_cos();
        let n = p.len();
        let mut h = nalgebra::DMatrix::<f64>::zeros(n, n);
        for (ua, ub, _) in &self.edges {
            let v = ua - (r * ub + self.c + s);
            let du = v.norm().max(1e-12);
            let dir = v / du;
            let dr = Vector2::new(-sin * ub.x - cos * ub.y, cos * ub.x - sin * ub.y);
            // d|v|/dp for p = (angle * rho, sx, sy) or (sx, sy).
            let j: Vec<f64> = match self.fixed_angle {
                Some(_) => vec![-dir.x, -dir.y],
                None => vec![-dir.dot(&dr) / self.rho, -dir.x, -dir.y],
            };
            for a in 0..n {
                for b in 0..n {
                    h[(a, b)] += j[a] * j[b];
                }
            }
        }
        let damping = 1e-3 * (h.trace() / n as f64).max(1e-9);
        for a in 0..n {
            h[(a, a)] += damping;
        }
        let inv = h
            .try_inverse()
            .unwrap_or_else(|| nalgebra::DMatrix::identity(n, n) / (self.edges.len().max(1) as f64));
        (0..n).map(|a| (0..n).map(|b| inv[(a, b)]).collect()).collect()
    }

    fn cost_m2(&self, p: &[f64]) -> f64 {
        self.cost_mm2(p) * 1e-6
    }

    fn gradient_mm(&self, p: &[f64]) -> Vec<f64> {
        let (angle, s) = self.split(p);
        let r = Rotation2::new(angle);
        let (sin, cos) = angle.sin_cos();
        let (mut ga, mut gs) = (0.0, Vector2::zeros());
        for (ua, ub, dx) in &self.edges {
            let v = ua - (r * ub + self.c + s);
            let du = v.norm().max(1e-12);
            // d/dp of 1/2 (dx - |v|)^2 = -(dx - |v|) * (v / |v|) . dv/dp, with dv/ds = -I and
            // dv/dangle = -R'(angle) ub.
            let k = -(dx - du) / du;
            gs += -v * k;
            let dr = Vector2::new(-sin * ub.x - cos * ub.y, cos * ub.x - sin * ub.y);
            ga += -k * v.dot(&dr);
        }
        match self.fixed_angle {
            Some(_) => vec![gs.x, gs.y],
            None => vec![ga / self.rho, gs.x, gs.y],
        }
    }
}

impl CostFunction for Eq66 {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> std::result::Result<f64, argmin::core::Error> {
        let c = self.cost_mm2(p);
        // A non-finite point (a degenerate BFGS update) stops the solver instead of sending its
        // line search after a NaN for ever; the best point so far is kept.
        if !c.is_finite() || p.iter().any(|v| !v.is_finite()) {
            return Err(argmin::core::Error::msg("non-finite cost"));
        }
        let mut best = self.best.borrow_mut();
        if c < best.0 {
            best.0 = c;
            best.1.clear();
            best.1.extend_from_slice(p);
        }
        Ok(c)
    }
}

impl Gradient for Eq66 {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, p: &Vec<f64>) -> std::result::Result<Vec<f64>, argmin::core::Error> {
        let g = self.gradient_mm(p);
        if g.iter().any(|v| !v.is_finite()) {
            return Err(argmin::core::Error::msg("non-finite gradient"));
        }
        Ok(g)
    }
}

/// An SVG drawing of `maps` placed by `placements` (one colour per link, millimetres): what
/// `skin stitch --svg` writes per posture.
pub fn stitched_svg(maps: &[TactileMap], placements: &[Placement]) -> String {
    use std::fmt::Write as _;
    let colours = [
        "#3182bd", "#e6550d", "#31a354", "#756bb1", "#636363", "#d6616b", "#8c6d31",
    ];
    let placed: Vec<Vec<nalgebra::Point2<f64>>> = maps
        .iter()
        .zip(placements)
        .map(|(m, p)| m.points.iter().map(|q| p.apply(q) * 1e3).collect())
        .collect();
    let (mut lo, mut hi) = (
        nalgebra::Point2::new(f64::INFINITY, f64::INFINITY),
        nalgebra::Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY),
    );
    for p in placed.iter().flatten() {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let m = 5.0;
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"{:.1} {:.1} {:.1} {:.1}\" width=\"{:.0}mm\" height=\"{:.0}mm\">\n",
        lo.x - m,
        lo.y - m,
        hi.x - lo.x + 2.0 * m,
        hi.y - lo.y + 2.0 * m,
        hi.x - lo.x + 2.0 * m,
        hi.y - lo.y + 2.0 * m
    );
    for (k, (map, pts)) in maps.iter().zip(&placed).enumerate() {
        let colour = colours[k % colours.len()];
        let _ = writeln!(
            s,
            "<g fill=\"{colour}\" fill-opacity=\"0.25\" stroke=\"{colour}\" stroke-width=\"0.2\"><title>{}</title>",
            map.name
        );
        for f in &map.faces {
            let [a, b, c] = f.map(|i| pts[i]);
            let _ = writeln!(
                s,
                "<polygon points=\"{:.2},{:.2} {:.2},{:.2} {:.2},{:.2}\"/>",
                a.x, a.y, b.x, b.y, c.x, c.y
            );
        }
        s.push_str("</g>\n");
    }
    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

    use super::*;

    #[test]
    fn the_gradient_matches_finite_differences() {
        let problem = Eq66 {
            edges: vec![
                (Vector2::new(10.0, 3.0), Vector2::new(-4.0, 2.0), 12.0),
                (Vector2::new(-5.0, 8.0), Vector2::new(6.0, -1.0), 9.0),
                (Vector2::new(2.0, -7.0), Vector2::new(1.0, 5.0), 15.0),
            ],
            c: Vector2::new(30.0, -20.0),
            rho: 4.0,
            fixed_angle: None,
            best: Default::default(),
        };
        let p = vec![0.3, 1.5, -2.0];
        let g = problem.gradient_mm(&p);
        for i in 0..3 {
            let (mut up, mut down) = (p.clone(), p.clone());
            up[i] += 1e-6;
            down[i] -= 1e-6;
            let fd = (problem.cost_mm2(&up) - problem.cost_mm2(&down)) / 2e-6;
            assert!((fd - g[i]).abs() < 1e-5, "{i}: {fd} vs {}", g[i]);
        }
    }

    #[test]
    fn placements_compose_and_invert() {
        let a = Placement {
            angle: 0.4,
            offset: Vector2::new(0.1, -0.2),
        };
        let b = Placement {
            angle: -1.1,
            offset: Vector2::new(0.03, 0.05),
        };
        let p = Point2::new(0.2, 0.7);
        assert!((a.compose(&b).apply(&p) - a.apply(&b.apply(&p))).norm() < 1e-12);
        assert!((a.invert(&a.apply(&p)) - p).norm() < 1e-12);
    }
}
