//! The skin's control tasks (thesis Ch. 8.4): move each link so that its contact forces fall, and
//! move the end-effector towards its goal in what the contact task leaves free.
//!
//! A contact j on a link: point x_j, force f_j >= 0 (what the skin measures), stiffness K_j of the
//! contact model (Eq. 8.1: f_dot = -K n n^T x_dot), and n_j the direction along which moving the
//! contact point lowers the force: into the link, i.e. minus the skin's outward normal.
//!
//! - Contact task of a link (Eq. 8.13-8.17): S_j = [I  -[r_j x]] (r_j = x_j - x_L) maps the
//!   link's twist rho = (x_L dot, omega_L) to the contact point's velocity; the rows K_j n_j^T S_j
//!   form H, and rho = gamma H^# f makes V_dot = -f^T H rho <= 0: the squared forces fall.
//! - Activation (Ch. 8.3): a = (F_M / F_thresh)^4, saturating at 1, F_M the link's largest force.
//! - End-effector (Eq. 8.18-8.26): rho_N = gamma_N H^# f + P z, P = I - H^# H, with
//!   z = (S_h P)^# (-Gamma e - gamma_N S_h H^# f) driving the hand point x_h towards the goal
//!   (e = [x_h - x_g; orientation term]) without undoing the contact task; with no contact,
//!   rho_N = -Gamma-weighted S_h^# e.
//!
//! Pseudo-inverses here are damped (`lambda`), as the thesis requires when H is ill-conditioned.

use nalgebra::{DMatrix, DVector, Matrix3, Point3, Unit, Vector3, Vector6};

/// One contact on a link, in the base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// Where, metres.
    pub point: Point3<f64>,
    /// The skin's outward normal there.
    pub normal: Unit<Vector3<f64>>,
    /// Measured force, newtons (>= 0).
    pub force: f64,
    /// Contact stiffness K of Eq. 8.1, N/m.
    pub stiffness: f64,
}

/// Gains of the tasks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gains {
    /// gamma of Eq. 8.17 (contact tasks), m/(N s) per unit of K: rho = gamma H^# f.
    pub contact: f64,
    /// gamma_L: position error to velocity, 1/s.
    pub position: f64,
    /// gamma_A: orientation error to angular velocity, 1/s.
    pub orientation: f64,
    /// Damping of the pseudo-inverses.
    pub lambda: f64,
    /// Top speed of the hand towards the goal, m/s (the error term is scaled down beyond it;
    /// infinite for none).
    pub max_speed: f64,
}

impl Default for Gains {
    fn default() -> Self {
        Gains {
            contact: 1.0,
            position: 1.0,
            orientation: 0.5,
            lambda: 1e-3,
            max_speed: f64::INFINITY,
        }
    }
}

/// The activation of a link's contact task: (F_M / F_thresh)^4, saturating at 1; 0 for a
/// non-finite force or threshold.
pub fn activation(max_force: f64, threshold: f64) -> f64 {
    if !(max_force.is_finite() && threshold.is_finite() && threshold > 0.0) {
        return 0.0;
    }
    (max_force.max(0.0) / threshold).powi(4).min(1.0)
}

/// [I  -[r x]] (3 x 6): the velocity of a point r away from the link origin, from the link twist.
fn s_matrix(r: &Vector3<f64>) -> DMatrix<f64> {
    let mut s = DMatrix::zeros(3, 6);
    s.view_mut((0, 0), (3, 3)).copy_from(&Matrix3::identity());
    s.view_mut((0, 3), (3, 3)).copy_from(&(-r.cross_matrix()));
    s
}

/// Damped pseudo-inverse A^T (A A^T + lambda^2 I)^-1.
fn damped_pinv(a: &DMatrix<f64>, lambda: f64) -> DMatrix<f64> {
    let m = a.nrows();
    let g = a * a.transpose() + DMatrix::identity(m, m) * (lambda * lambda);
    match g.cholesky() {
        Some(ch) => ch.solve(a).transpose(),
        None => DMatrix::zeros(a.ncols(), m),
    }
}

/// H (Eq. 8.15) and f for the contacts of a link whose frame origin is `link_origin`.
fn h_and_f(link_origin: &Point3<f64>, contacts: &[Contact]) -> (DMatrix<f64>, DVector<f64>) {
    let mut h = DMatrix::zeros(contacts.len(), 6);
    let mut f = DVector::zeros(contacts.len());
    for (j, c) in contacts.iter().enumerate() {
        let n = -c.normal.into_inner();
        let row = (s_matrix(&(c.point - link_origin)).transpose() * n) * c.stiffness;
        h.row_mut(j).copy_from(&row.transpose());
        f[j] = c.force.max(0.0);
    }
    (h, f)
}

fn usable(c: &Contact) -> bool {
    c.point.coords.iter().all(|v| v.is_finite())
        && c.normal.iter().all(|v| v.is_finite())
        && c.force.is_finite()
        && c.stiffness.is_finite()
        && c.stiffness > 0.0
}

/// The contact task's reference twist of a link (Eq. 8.17): (linear; angular) velocity of the link
/// frame at `link_origin`, base frame. Contacts with non-finite values are ignored; no usable
/// contact gives zero.
pub fn contact_twist(link_origin: &Point3<f64>, contacts: &[Contact], gains: &Gains) -> Vector6<f64> {
    let usable: Vec<Contact> = contacts.iter().copied().filter(usable).collect();
    if usable.is_empty() || !link_origin.coords.iter().all(|v| v.is_finite()) {
        return Vector6::zeros();
    }
    let (h, f) = h_and_f(link_origin, &usable);
    let rho = damped_pinv(&h, gains.lambda) * f * gains.contact;
    Vector6::from_iterator(rho.iter().copied())
}

/// The end-effector's reference twist (Eq. 8.18-8.26): lower its contact forces, and in the
/// remaining freedom move the hand point `hand` towards `goal` and turn the tool axis `tool_axis`
/// towards the goal direction. All in the base frame; `link_origin` is the end-effector frame's
/// origin.
pub fn reach_twist(
    link_origin: &Point3<f64>,
    hand: &Point3<f64>,
    tool_axis: &Unit<Vector3<f64>>,
    goal: &Point3<f64>,
    contacts: &[Contact],
    gains: &Gains,
) -> Vector6<f64> {
    let finite = [link_origin, hand, goal]
        .iter()
        .all(|p| p.coords.iter().all(|v| v.is_finite()))
        && tool_axis.iter().all(|v| v.is_finite());
    if !finite {
        return Vector6::zeros();
    }
    // e (Eq. 8.23): position error and the rotation that turns the tool axis towards the goal.
    let to_goal = goal - hand;
    let mut e = DVector::zeros(6);
    e.rows_mut(0, 3).copy_from(&(-to_goal));
    if to_goal.norm() > 1e-9 {
        let dir = to_goal.normalize();
        let axis = tool_axis.cross(&dir);
        let theta = tool_axis.dot(&dir).clamp(-1.0, 1.0).acos();
        if axis.norm() > 1e-12 {
            // Turning about w x e by theta aligns w with e: the "error" is its opposite.
            e.rows_mut(3, 3).copy_from(&(-axis.normalize() * theta));
        }
    }
    let gamma = DVector::from_vec(vec![
        gains.position,
        gains.position,
        gains.position,
        gains.orientation,
        gains.orientation,
        gains.orientation,
    ]);
    let mut ge = e.component_mul(&gamma);
    let speed = ge.rows(0, 3).norm();
    if speed > gains.max_speed {
        ge *= gains.max_speed / speed;
    }
    // S_h (Eq. 8.24), 6 x 6.
    let mut s_h = DMatrix::identity(6, 6);
    s_h.view_mut((0, 3), (3, 3))
        .copy_from(&(-(hand - link_origin).cross_matrix()));
    let usable: Vec<Contact> = contacts.iter().copied().filter(usable).collect();
    let rho = if usable.is_empty() {
        // Eq. 8.22: rho_N = -S_h^# Gamma e.
        -damped_pinv(&s_h, gains.lambda) * ge
    } else {
        let (h, f) = h_and_f(link_origin, &usable);
        let h_pinv = damped_pinv(&h, gains.lambda);
        let contact = &h_pinv * f * gains.contact;
        let p = DMatrix::identity(6, 6) - &h_pinv * &h;
        // Eq. 8.25: z = (S_h P)^# (-Gamma e - gamma_N S_h H^# f).
        let sp = &s_h * &p;
        let z = damped_pinv(&sp, gains.lambda) * (-ge - &s_h * &contact);
        contact + p * z
    };
    if rho.iter().all(|v| v.is_finite()) {
        Vector6::from_iterator(rho.iter().copied())
    } else {
        Vector6::zeros()
    }
}

/// Groups taxel readings into contacts (Ch. 8.3, 9.2): taxels closer than `radius` (chained)
/// form one contact, at the force-weighted centroid of its taxels, with their force-weighted
/// mean normal, the largest force among them and their mean stiffness. A patch of taxels pressed
/// against one bar is one contact with one normal, as the thesis models it; kept as separate
/// rows, the spread of the taxels' normals across a curved link would forbid sliding along the
/// bar too. Taxels with non-finite values or no force are left out.
pub fn group_contacts(taxels: &[Contact], radius: f64) -> Vec<Contact> {
    let live: Vec<&Contact> = taxels.iter().filter(|c| usable(c) && c.force > 0.0).collect();
    let n = live.len();
    // Union-find over the taxels within `radius` of each other.
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for i in 0..n {
        for j in i + 1..n {
            if (live[i].point - live[j].point).norm() <= radius {
                let (a, b) = (root(&mut parent, i), root(&mut parent, j));
                if a != b {
                    parent[b] = a;
                }
            }
        }
    }
    let mut groups: Vec<(usize, Vec<usize>)> = Vec::new();
    for i in 0..n {
        let r = root(&mut parent, i);
        match groups.iter_mut().find(|(g, _)| *g == r) {
            Some((_, members)) => members.push(i),
            None => groups.push((r, vec![i])),
        }
    }
    groups
        .into_iter()
        .filter_map(|(_, members)| {
            let total: f64 = members.iter().map(|&i| live[i].force).sum();
            let mut point = Vector3::zeros();
            let mut normal = Vector3::zeros();
            let mut stiffness = 0.0;
            let mut force: f64 = 0.0;
            for &i in &members {
                let w = live[i].force / total;
                point += live[i].point.coords * w;
                normal += live[i].normal.into_inner() * w;
                stiffness += live[i].stiffness / members.len() as f64;
                force = force.max(live[i].force);
            }
            Some(Contact {
                point: Point3::from(point),
                normal: Unit::try_new(normal, 1e-9)?,
                force,
                stiffness,
            })
        })
        .collect()
}
