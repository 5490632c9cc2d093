//! Finding the robot's own body in an RGB-D frame before probing it (thesis Ch. 7.2.1-7.2.2).
//!
//! 1. The kinematic chain's joints are projected into the image with the pinhole model
//!    ([`PinholeCamera::project`], Eq. 7.1), giving the arm's skeleton.
//! 2. Each link's thickness is estimated from depth: pixels along its skeleton segment are
//!    back-projected and their largest distance from the 3D link is d_max
//!    ([`link_thickness`]); in pixels, d_max k_x / z.
//! 3. A polygon contains the arm: lines parallel to each segment at +-d_max, intersected with
//!    those of the neighbouring segments, closed by perpendiculars through the first and last
//!    joints ([`containing_polygon`], Fig. 7.4).
//! 4. Inside the polygon, a pixel is body when its depth is less than that of the closest link
//!    point plus that link's d_max ([`body_mask`]).
//! 5. A target is a random body pixel away from the borders, projected onto the body with its
//!    depth, its normal the one of the depth point cloud around it ([`pick_target`],
//!    [`surface_at`]).
//!
//! Depth images are row-major, metres along the optical axis (z in the camera frame), 0 or NaN
//! where the sensor has no reading.

use nalgebra::{Isometry3, Point3, Unit, Vector2, Vector3};

/// A pinhole camera (Eq. 7.1): k_x, k_y the focal length in pixels along each axis, (u_0, v_0) the
/// principal point, and where the camera is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinholeCamera {
    /// Focal length over pixel width, pixels.
    pub kx: f64,
    /// Focal length over pixel height, pixels.
    pub ky: f64,
    /// Principal point, pixels.
    pub u0: f64,
    /// Principal point, pixels.
    pub v0: f64,
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
    /// Robot base frame to camera frame (c_T_b): a point p in the base frame is `base_to_camera * p`
    /// in the camera frame (z along the optical axis, u rightwards, v downwards).
    pub base_to_camera: Isometry3<f64>,
}

impl PinholeCamera {
    /// The pixel (u, v) of a point of the base frame (Eq. 7.1: u = u~ / w~, v = v~ / w~), or
    /// `None` behind the camera.
    pub fn project(&self, p: &Point3<f64>) -> Option<[f64; 2]> {
        let c = self.base_to_camera * p;
        (c.z > 1e-9).then(|| [self.kx * c.x / c.z + self.u0, self.ky * c.y / c.z + self.v0])
    }

    /// The point of the base frame seen at pixel (u, v) with depth z (metres along the axis).
    pub fn back_project(&self, u: f64, v: f64, z: f64) -> Point3<f64> {
        let c = Point3::new((u - self.u0) * z / self.kx, (v - self.v0) * z / self.ky, z);
        self.base_to_camera.inverse_transform_point(&c)
    }

    /// Depth (camera z) of a point of the base frame.
    pub fn depth_of(&self, p: &Point3<f64>) -> f64 {
        (self.base_to_camera * p).z
    }

    /// Camera centre in the base frame.
    pub fn centre(&self) -> Point3<f64> {
        self.base_to_camera.inverse_transform_point(&Point3::origin())
    }
}

/// The depth at integer pixel (u, v), if the sensor has one.
fn depth_at(camera: &PinholeCamera, depth: &[f32], u: i64, v: i64) -> Option<f64> {
    if u < 0 || v < 0 || u as usize >= camera.width || v as usize >= camera.height {
        return None;
    }
    let z = f64::from(*depth.get(v as usize * camera.width + u as usize)?);
    (z.is_finite() && z > 0.0).then_some(z)
}

/// Distance from `p` to the segment [a, b].
fn segment_distance(p: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>) -> (f64, f64) {
    let ab = b - a;
    let t = if ab.norm_squared() > 0.0 {
        ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    ((p - (a + ab * t)).norm(), t)
}

/// A link's thickness seen from the camera (Fig. 7.3): the largest distance between the 3D link
/// segment [a, b] and the back-projected pixels of its image segment that lie within `reach`
/// metres of it (farther ones are background). Returns (d_max in metres, its size in pixels at the
/// link's mean depth), or `None` if no pixel along the segment has depth.
pub fn link_thickness(
    camera: &PinholeCamera,
    depth: &[f32],
    a: &Point3<f64>,
    b: &Point3<f64>,
    reach: f64,
) -> Option<(f64, f64)> {
    let (pa, pb) = (camera.project(a)?, camera.project(b)?);
    let steps = ((pb[0] - pa[0]).hypot(pb[1] - pa[1]).ceil() as usize).max(1);
    let mut d_max: Option<f64> = None;
    for k in 0..=steps {
        let t = k as f64 / steps as f64;
        let (u, v) = (pa[0] + t * (pb[0] - pa[0]), pa[1] + t * (pb[1] - pa[1]));
        let Some(z) = depth_at(camera, depth, u.round() as i64, v.round() as i64) else {
            continue;
        };
        let (d, _) = segment_distance(&camera.back_project(u, v, z), a, b);
        if d <= reach {
            d_max = Some(d_max.map_or(d, |m| m.max(d)));
        }
    }
    let d_max = d_max?;
    let z = 0.5 * (camera.depth_of(a) + camera.depth_of(b));
    Some((d_max, d_max * camera.kx / z))
}

/// The polygon containing the arm (Fig. 7.4) around the image skeleton `joints` (pixels, at least
/// two) with one half-width per segment (pixels): lines parallel to every segment on both sides,
/// joined where they meet the neighbouring segment's, closed by perpendiculars through the first
/// and last joint. Vertices in order around the polygon.
pub fn containing_polygon(joints: &[[f64; 2]], half_widths: &[f64]) -> Vec<[f64; 2]> {
    let segments: Vec<(Vector2<f64>, Vector2<f64>, f64)> = joints
        .windows(2)
        .zip(half_widths)
        .filter_map(|(w, &d)| {
            let (a, b) = (Vector2::from(w[0]), Vector2::from(w[1]));
            let e = b - a;
            (e.norm() > 1e-9).then(|| (a, e.normalize(), d))
        })
        .collect();
    if segments.is_empty() {
        return Vec::new();
    }
    let last = joints.len() - 1;
    let side = |s: f64| -> Vec<[f64; 2]> {
        let mut pts = Vec::new();
        let (a0, e0, d0) = segments[0];
        let n = |e: Vector2<f64>| Vector2::new(-e.y, e.x) * s;
        pts.push(a0 + n(e0) * d0);
        for w in segments.windows(2) {
            let ((_, e1, d1), (a2, e2, d2)) = (w[0], w[1]);
            // Where line 1 (through a2 + n1 d1, along e1) meets line 2 (a2 + n2 d2, along e2).
            let p1 = a2 + n(e1) * d1;
            let p2 = a2 + n(e2) * d2;
            let cross = e1.x * e2.y - e1.y * e2.x;
            if cross.abs() < 1e-9 {
                pts.push(p2);
            } else {
                let t = ((p2 - p1).x * e2.y - (p2 - p1).y * e2.x) / cross;
                pts.push(p1 + e1 * t);
            }
        }
        let (_, e_last, d_last) = segments[segments.len() - 1];
        pts.push(Vector2::from(joints[last]) + n(e_last) * d_last);
        pts.into_iter().map(|p| [p.x, p.y]).collect()
    };
    let mut polygon = side(1.0);
    polygon.extend(side(-1.0).into_iter().rev());
    polygon
}

/// Point-in-polygon by the even-odd rule.
pub fn inside(polygon: &[[f64; 2]], p: [f64; 2]) -> bool {
    let mut hit = false;
    let n = polygon.len();
    for i in 0..n {
        let (a, b) = (polygon[i], polygon[(i + n - 1) % n]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            if p[0] < x {
                hit = !hit;
            }
        }
    }
    hit
}

/// The body mask (row-major, `true` = robot): pixels inside `polygon` whose depth is less than the
/// depth of the closest point of the closest link plus that link's d_max. `links` are the 3D link
/// segments with their d_max (metres), in the base frame.
pub fn body_mask(
    camera: &PinholeCamera,
    depth: &[f32],
    polygon: &[[f64; 2]],
    links: &[(Point3<f64>, Point3<f64>, f64)],
) -> Vec<bool> {
    let projected: Vec<Option<([f64; 2], [f64; 2])>> = links
        .iter()
        .map(|(a, b, _)| Some((camera.project(a)?, camera.project(b)?)))
        .collect();
    let mut mask = vec![false; camera.width * camera.height];
    for v in 0..camera.height {
        for u in 0..camera.width {
            let p = [u as f64, v as f64];
            if !inside(polygon, p) {
                continue;
            }
            let Some(z) = depth_at(camera, depth, u as i64, v as i64) else {
                continue;
            };
            // The closest link in the image, and the depth of its point nearest the pixel.
            let mut best: Option<(f64, f64)> = None; // (image distance, allowed depth)
            for ((a, b, d_max), seg) in links.iter().zip(&projected) {
                let Some((pa, pb)) = seg else { continue };
                let (pa, pb) = (Vector2::from(*pa), Vector2::from(*pb));
                let e = pb - pa;
                let t = if e.norm_squared() > 0.0 {
                    ((Vector2::from(p) - pa).dot(&e) / e.norm_squared()).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let dist = (Vector2::from(p) - (pa + e * t)).norm();
                let link_z = camera.depth_of(&(a + (b - a) * t));
                if best.is_none_or(|(d, _)| dist < d) {
                    best = Some((dist, link_z + d_max));
                }
            }
            if best.is_some_and(|(_, limit)| z < limit) {
                mask[v * camera.width + u] = true;
            }
        }
    }
    mask
}

/// The 3D point at pixel (u, v) and the surface normal there, from the depth point cloud within
/// `radius` pixels (plane fit of the back-projected neighbours, turned towards the camera).
/// `None` without depth at the pixel, with fewer than 6 neighbours, or when they span no plane.
pub fn surface_at(
    camera: &PinholeCamera,
    depth: &[f32],
    u: usize,
    v: usize,
    radius: usize,
) -> Option<(Point3<f64>, Unit<Vector3<f64>>)> {
    let z = depth_at(camera, depth, u as i64, v as i64)?;
    let target = camera.back_project(u as f64, v as f64, z);
    let r = radius as i64;
    let mut points = Vec::new();
    for dv in -r..=r {
        for du in -r..=r {
            if du * du + dv * dv > r * r {
                continue;
            }
            let (pu, pv) = (u as i64 + du, v as i64 + dv);
            if let Some(z) = depth_at(camera, depth, pu, pv) {
                points.push(camera.back_project(pu as f64, pv as f64, z));
            }
        }
    }
    if points.len() < 6 {
        return None;
    }
    // The same plane fit as a taxel's contacts get (a degenerate neighbourhood gives no normal).
    let (_, [_, _, mut n], _) = super::taxel_pose::plane(&points).ok()?;
    if n.dot(&(camera.centre() - target)) < 0.0 {
        n = -n;
    }
    Some((target, Unit::new_normalize(n)))
}

/// A probe target on the segmented body (Ch. 7.2.2): a random body pixel whose whole
/// neighbourhood of `radius` pixels is body too (borders give no stable contact), that
/// `reachable` accepts, with its 3D point and outward normal ([`surface_at`]). Deterministic for a
/// given `seed`; `None` after `tries` draws without one.
pub fn pick_target(
    camera: &PinholeCamera,
    depth: &[f32],
    mask: &[bool],
    radius: usize,
    seed: u64,
    tries: usize,
    reachable: impl Fn(&Point3<f64>) -> bool,
) -> Option<(Point3<f64>, Unit<Vector3<f64>>)> {
    use rand::{Rng, SeedableRng};
    let body: Vec<usize> = (0..mask.len()).filter(|&k| mask[k]).collect();
    if body.is_empty() || mask.len() != camera.width * camera.height {
        return None;
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let r = radius as i64;
    for _ in 0..tries {
        let k = body[rng.random_range(0..body.len())];
        let (u, v) = ((k % camera.width) as i64, (k / camera.width) as i64);
        let interior = (-r..=r).all(|dv| {
            (-r..=r).all(|du| {
                let (pu, pv) = (u + du, v + dv);
                pu >= 0
                    && pv >= 0
                    && (pu as usize) < camera.width
                    && (pv as usize) < camera.height
                    && mask[pv as usize * camera.width + pu as usize]
            })
        });
        if !interior {
            continue;
        }
        if let Some((p, n)) = surface_at(camera, depth, u as usize, v as usize, radius)
            && reachable(&p)
        {
            return Some((p, n));
        }
    }
    None
}
