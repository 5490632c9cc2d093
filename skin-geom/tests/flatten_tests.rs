//! LSCM flattening: analytic cases, an independent dense solve, real patches and bad meshes.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test or bench

use nalgebra::{DMatrix, DVector, Isometry3, Point2, Point3, Translation3, Unit, UnitQuaternion, Vector3};
use proptest::prelude::*;
use skin_core::{LinkSkin, Taxel, TaxelId};
use skin_geom::{DistortionReport, Error, FlattenOptions, MeshOptions, SkinMesh, TactileMap};

use shared_data::shared;
use skin_test_support::shared_data;

fn taxel(id: u32, p: Point3<f64>, n: Vector3<f64>) -> Taxel {
    Taxel {
        id: TaxelId(id),
        position: p,
        normal: Unit::new_normalize(n),
    }
}

/// Taxels on a cylinder of `radius` around the y axis, `cols` around and `rows` along, with a
/// little deterministic jitter so the triangulation is not degenerate.
fn cylinder_patch(radius: f64, angle: f64, length: f64, cols: usize, rows: usize) -> LinkSkin {
    let mut taxels = Vec::new();
    for r in 0..rows {
        for c in 0..cols {
            let jitter = ((r * 31 + c * 17) % 7) as f64 / 7.0 - 0.5;
            let phi = -angle / 2.0 + angle * (c as f64 + 0.15 * jitter) / (cols - 1) as f64;
            let y = length * (r as f64 + 0.5 * (c % 2) as f64 + 0.1 * jitter) / rows as f64;
            let n = Vector3::new(phi.sin(), 0.0, phi.cos());
            taxels.push(taxel(
                (r * cols + c) as u32,
                Point3::new(radius * n.x, y, radius * n.z),
                n,
            ));
        }
    }
    LinkSkin::new("cylinder", taxels)
}

fn flat_grid(cols: usize, rows: usize, pitch: f64) -> LinkSkin {
    let taxels = (0..rows * cols)
        .map(|i| {
            let (r, c) = (i / cols, i % cols);
            taxel(
                i as u32,
                Point3::new(
                    c as f64 * pitch + 0.3 * pitch * (r % 2) as f64,
                    r as f64 * pitch,
                    0.0,
                ),
                Vector3::z(),
            )
        })
        .collect();
    LinkSkin::new("flat", taxels)
}

/// The (x, y) of each taxel: the exact map of a patch lying in the z = 0 plane.
fn plane_xy(link: &LinkSkin) -> Vec<Point2<f64>> {
    link.taxels
        .iter()
        .map(|t| Point2::new(t.position.x, t.position.y))
        .collect()
}

fn flatten(link: &LinkSkin) -> TactileMap {
    TactileMap::flatten(link, &FlattenOptions::default()).unwrap()
}

/// Best 2D rigid motion (no reflection) from `a` onto `b` (Kabsch), and the largest residual.
fn rigid_residual(a: &[Point2<f64>], b: &[Point2<f64>]) -> f64 {
    let n = a.len() as f64;
    let ca = a.iter().map(|p| p.coords).sum::<nalgebra::Vector2<f64>>() / n;
    let cb = b.iter().map(|p| p.coords).sum::<nalgebra::Vector2<f64>>() / n;
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for (p, q) in a.iter().zip(b) {
        let (u, v) = (p.coords - ca, q.coords - cb);
        sxx += u.x * v.x + u.y * v.y;
        sxy += u.x * v.y - u.y * v.x;
    }
    let rot = nalgebra::Rotation2::new(sxy.atan2(sxx));
    a.iter()
        .zip(b)
        .map(|(p, q)| (rot * (p.coords - ca) - (q.coords - cb)).norm())
        .fold(0.0, f64::max)
}

#[test]
fn flattening_a_developable_cylinder_preserves_edge_lengths() {
    // Radius 60 mm, 150 degrees around, 200 mm long, ~8 mm pitch: a triangulated point cloud.
    let link = cylinder_patch(0.060, 150f64.to_radians(), 0.200, 20, 25);
    let map = flatten(&link);
    let d = map.report.distortion;
    assert!(matches!(
        map.report.source,
        Some(skin_geom::MeshSource::Triangulated {
            chart: skin_geom::Chart::Cylinder { .. }
        })
    ));
    assert_eq!(map.report.components, 1);
    assert_eq!(d.flipped_faces, 0);
    assert!(d.edge_ratio_p5 > 0.995 && d.edge_ratio_p95 < 1.005, "{d}");
    assert!((d.area_ratio - 1.0).abs() < 1e-9);
    // The unrolled patch is R * angle long around the arm (within the pitch lost at the border).
    let (w, h) = map.extent();
    let around = 0.060 * 150f64.to_radians();
    assert!(
        (w.max(h) - 0.200).abs() < 0.012 && (w.min(h) - around).abs() < 0.005,
        "{w} x {h}"
    );
}

#[test]
fn a_cylinder_triangulated_along_its_rulings_flattens_exactly() {
    // Quads between rulings split into two triangles: an exactly developable mesh.
    let (cols, rows, radius) = (12usize, 6usize, 0.05);
    let mut taxels = Vec::new();
    for r in 0..rows {
        for c in 0..cols {
            let phi = c as f64 * 0.15;
            let n = Vector3::new(phi.sin(), 0.0, phi.cos());
            taxels.push(taxel(
                (r * cols + c) as u32,
                Point3::new(radius * n.x, r as f64 * 0.01, radius * n.z),
                n,
            ));
        }
    }
    let mut faces = Vec::new();
    for r in 0..rows - 1 {
        for c in 0..cols - 1 {
            let i = r * cols + c;
            faces.push([i, i + 1, i + cols + 1]);
            faces.push([i, i + cols + 1, i + cols]);
        }
    }
    let mut link = LinkSkin::new("ruled", taxels);
    link.faces = Some(faces);
    let d = flatten(&link).report.distortion;
    assert!(
        d.angle_error_mean_deg < 1e-8 && (d.edge_ratio_spread() - 1.0).abs() < 1e-10,
        "{d}"
    );
    assert!(d.angle_error_bound_deg < 1e-9);
}

#[test]
fn a_flat_patch_maps_onto_itself_up_to_a_rigid_motion() {
    let link = flat_grid(9, 7, 0.008);
    let map = flatten(&link);
    let original = plane_xy(&link);
    assert!(rigid_residual(&map.points, &original) < 1e-9);
    // Seen from outside (+z), the map keeps the handedness of the patch: no mirror image.
    assert!(map.faces.iter().all(|f| {
        let p = f.map(|t| map.points[t]);
        (p[1] - p[0]).perp(&(p[2] - p[0])) > 0.0
    }));
}

#[test]
fn a_patch_seen_from_below_is_mirrored_so_it_reads_from_outside() {
    // The same patch with normals pointing down: seen from outside it is the mirror image.
    let mut link = flat_grid(9, 7, 0.008);
    for t in &mut link.taxels {
        t.normal = Unit::new_normalize(-Vector3::z());
    }
    let map = flatten(&link);
    let mirrored: Vec<Point2<f64>> = link
        .taxels
        .iter()
        .map(|t| Point2::new(t.position.x, -t.position.y))
        .collect();
    assert!(rigid_residual(&map.points, &mirrored) < 1e-9);
}

/// Dense LSCM, written independently from the per-triangle least-squares rows (Lévy 2002,
/// eq. 6): rows [Re; Im] of sum_j (w_j / sqrt(2 A)) U_j with w_j the complex edge opposite j.
fn dense_lscm(
    verts: &[Point3<f64>],
    faces: &[[usize; 3]],
    pins: [usize; 2],
    pin_uv: [Point2<f64>; 2],
) -> Vec<Point2<f64>> {
    let n = verts.len();
    let mut m = DMatrix::<f64>::zeros(2 * faces.len(), 2 * n);
    for (f, face) in faces.iter().enumerate() {
        let [p0, p1, p2] = face.map(|i| verts[i]);
        let e1 = (p1 - p0).normalize();
        let normal = (p1 - p0).cross(&(p2 - p0));
        let area = 0.5 * normal.norm();
        let e2 = normal.normalize().cross(&e1);
        let z: Vec<(f64, f64)> = [p0, p1, p2]
            .iter()
            .map(|p| ((p - p0).dot(&e1), (p - p0).dot(&e2)))
            .collect();
        let s = (2.0 * area).sqrt();
        for j in 0..3 {
            let (a, b) = (
                z[(j + 2) % 3].0 - z[(j + 1) % 3].0,
                z[(j + 2) % 3].1 - z[(j + 1) % 3].1,
            );
            let v = face[j];
            m[(2 * f, 2 * v)] += a / s;
            m[(2 * f, 2 * v + 1)] -= b / s;
            m[(2 * f + 1, 2 * v)] += b / s;
            m[(2 * f + 1, 2 * v + 1)] += a / s;
        }
    }
    let free: Vec<usize> = (0..2 * n).filter(|k| !pins.contains(&(k / 2))).collect();
    let mut rhs = DVector::<f64>::zeros(2 * faces.len());
    for (p, uv) in pins.iter().zip(pin_uv) {
        rhs -= m.column(2 * p) * uv.x + m.column(2 * p + 1) * uv.y;
    }
    let a = m.select_columns(&free);
    let x = a.clone().svd(true, true).solve(&rhs, 1e-14).unwrap();
    let mut out = vec![Point2::origin(); n];
    for (p, uv) in pins.iter().zip(pin_uv) {
        out[*p] = uv;
    }
    for (k, &col) in free.iter().enumerate() {
        if col % 2 == 0 {
            out[col / 2].x = x[k];
        } else {
            out[col / 2].y = x[k];
        }
    }
    out
}

#[test]
fn sparse_lscm_matches_a_dense_least_squares_solve() {
    // A curved, not developable patch (a piece of sphere), so the answer is not trivial.
    let mut taxels = Vec::new();
    for r in 0..6 {
        for c in 0..7 {
            let (x, y) = (c as f64 * 0.01 + 0.003 * (r % 2) as f64, r as f64 * 0.009);
            let p = Point3::new(x, y, -(x * x + y * y) * 4.0);
            let n = Vector3::new(8.0 * x, 8.0 * y, 1.0);
            taxels.push(taxel((r * 7 + c) as u32, p, n));
        }
    }
    let link = LinkSkin::new("bowl", taxels);
    let mesh = SkinMesh::build(&link, &MeshOptions::default()).unwrap();
    let verts = &mesh.mesh.vertices;
    let faces = &mesh.mesh.faces;
    let pins = [0, verts.len() - 1];
    let pin_uv = [Point2::new(0.0, 0.0), Point2::new(0.07, 0.01)];
    let lscm = skin_geom::Lscm::new(verts.len(), faces, pins).unwrap();
    let sparse = lscm.solve(verts, pin_uv).unwrap();
    let dense = dense_lscm(verts, faces, pins, pin_uv);
    let worst = sparse
        .iter()
        .zip(&dense)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(worst < 1e-10, "sparse and dense LSCM differ by {worst} m");
    let d = DistortionReport::measure(verts, &sparse, faces);
    assert!(
        d.angle_error_mean_deg > 0.01,
        "a bowl cannot flatten without distortion: {d}"
    );
    assert!(d.angle_error_mean_deg >= d.angle_error_bound_deg);
}

#[test]
fn a_flat_sole_is_a_plane_whatever_its_normals_say() {
    // A flat patch whose file gives every taxel the normal +x, along the plane (the iCub foot
    // soles' quirk): the chart comes from the points, so it is the plane, and nothing folds.
    let mut sole = flat_grid(12, 8, 0.008);
    for t in &mut sole.taxels {
        t.normal = Unit::new_normalize(Vector3::x());
    }
    let map = flatten(&sole);
    assert_eq!(
        map.report.distortion.flipped_faces, 0,
        "{}",
        map.report.distortion
    );
    assert!(
        matches!(
            map.report.source,
            Some(skin_geom::MeshSource::Triangulated {
                chart: skin_geom::Chart::Plane { .. }
            })
        ),
        "{:?}",
        map.report.source
    );
    // Which side is outside, normals along the plane cannot say: the map is the patch, or its
    // mirror image.
    let xy = plane_xy(&sole);
    let mirrored: Vec<Point2<f64>> = xy.iter().map(|p| Point2::new(-p.x, p.y)).collect();
    let residual = rigid_residual(&xy, &map.points).min(rigid_residual(&mirrored, &map.points));
    assert!(residual < 1e-9, "{residual}");
    assert_eq!(
        map.report.mesh.normals_off_plane.len(),
        96,
        "every normal was off the plane"
    );
    let report = map.flattening().to_string();
    assert!(
        report.starts_with("mesh: ")
            && report.contains("Delaunay in the best-fit plane")
            && report.contains("96 taxel normal(s) lie more than 60 deg off")
            && report.ends_with("flipped triangles  0"),
        "{report}"
    );
}

#[test]
fn every_real_layout_in_the_shared_data_flattens_without_a_flip() {
    let Some(root) = shared("") else {
        return;
    };
    let mut files: Vec<_> = ["cyskin", "icub"]
        .iter()
        .flat_map(|d| {
            std::fs::read_dir(root.join(d))
                .unwrap()
                .map(|e| e.unwrap().path())
        })
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            (name.ends_with(".json") && !name.contains("isomap")) || name.ends_with(".txt")
        })
        .collect();
    files.sort();
    assert!(files.len() >= 6, "{files:?}");
    for p in &files {
        let link = skin_geom::read_link(p).unwrap_or_else(|e| panic!("{e}")).value;
        let map = flatten(&link);
        let d = map.report.distortion;
        assert_eq!(d.flipped_faces, 0, "{}: {d}", p.display());
        assert_eq!(map.ids.len(), link.taxels.len());
    }
    // The recorded patch: its 8 taxels with the placeholder id stay as dead mesh vertices.
    let patch = skin_geom::read_link(&root.join("cyskin/curved_gesture_patch.json")).unwrap();
    assert_eq!(patch.value.taxels.len(), 642);
    assert_eq!(
        patch
            .value
            .taxels
            .iter()
            .filter(|t| t.id.is_placeholder())
            .count(),
        8
    );
    assert_eq!(patch.notes.len(), 1, "{:?}", patch.notes);
}

#[test]
fn the_cyskin_patch_flattens_far_better_than_its_isomap() {
    let Some(p) = shared("cyskin/ur10e_link1_patch1.json") else {
        return;
    };
    let link = skin_core::format::cyskin::read_skin(&p).unwrap().value;
    let map = flatten(&link);
    let d = map.report.distortion;
    assert_eq!(d.flipped_faces, 0, "{d}");
    assert!(d.edge_ratio_spread() <= 1.02, "{d}");
    assert!(d.angle_error_mean_deg <= 0.1, "{d}");
    assert_eq!(map.points.len(), 642);

    // The isomap shipped with the data, measured with the same report: 1.36 and 5.9 degrees.
    let Some(iso) = shared("cyskin/ur10e_link1_patch1_isomap.json") else {
        return;
    };
    let text = std::fs::read_to_string(&iso).unwrap();
    let iso = skin_core::format::cyskin::parse_tactile_map(&text, &iso).unwrap();
    assert_eq!(iso.ids, link.ids());
    let uv: Vec<Point2<f64>> = iso.points.iter().map(|p| Point2::new(p[0], p[1])).collect();
    let xyz: Vec<Point3<f64>> = link.taxels.iter().map(|t| t.position).collect();
    let di = DistortionReport::measure(&xyz, &uv, &iso.faces);
    assert!((di.edge_ratio_spread() - 1.36).abs() < 0.01, "{di}");
    assert!((di.angle_error_mean_deg - 5.9).abs() < 0.1, "{di}");
}

#[test]
fn the_icub_forearm_flattens_without_flips_and_its_duplicates_are_reported() {
    let Some(p) = shared("icub/left_forearm_V2.txt") else {
        return;
    };
    let read = skin_core::format::icub::read(&p, skin_core::format::icub::Duplicates::Merge).unwrap();
    assert!(!read.duplicates.is_empty());
    let map = flatten(&read.skin);
    let d = map.report.distortion;
    assert_eq!(d.flipped_faces, 0, "{d}");
    // The positions are rounded to 0.1 mm and the cover is not developable: the angle defects of
    // the mesh bound what any flattening can reach, and LSCM stays within ~3x of that bound.
    assert!(d.angle_error_bound_deg > 0.1, "{d}");
    assert!(d.angle_error_mean_deg < 3.0 * d.angle_error_bound_deg, "{d}");
    assert!(map.points.iter().all(|p| p.x.is_finite() && p.y.is_finite()));
}

#[test]
fn a_zero_area_triangle_is_dropped_not_turned_into_nan() {
    let mut link = flat_grid(4, 4, 0.01);
    // Three collinear taxels (0, 1, 2 on the first row) given as a triangle.
    link.faces = Some(vec![[0, 1, 5], [0, 5, 4], [1, 2, 6], [1, 6, 5], [0, 1, 2]]);
    let map = flatten(&link);
    assert_eq!(map.report.mesh.degenerate_faces, 1);
    assert_eq!(map.faces.len(), 4);
    assert!(map.points.iter().all(|p| p.x.is_finite() && p.y.is_finite()));
}

#[test]
fn taxels_at_one_position_share_a_map_point() {
    let mut link = flat_grid(5, 5, 0.01);
    let dup = Taxel {
        id: TaxelId(999),
        ..link.taxels[12].clone()
    };
    link.taxels.push(dup);
    let map = flatten(&link);
    assert_eq!(map.report.mesh.welded, vec![vec![TaxelId(12), TaxelId(999)]]);
    assert_eq!(map.points[12], map.points[25]);
    assert!(map.points.iter().all(|p| p.x.is_finite()));
}

#[test]
fn a_second_piece_is_flattened_beside_the_first_not_collapsed() {
    let a = flat_grid(6, 6, 0.01);
    let mut taxels = a.taxels.clone();
    // A second patch far away, tilted.
    for (k, t) in a.taxels.iter().enumerate() {
        let p = t.position;
        taxels.push(taxel(
            100 + k as u32,
            Point3::new(0.5 + p.x, p.y, 0.3 + 0.5 * p.x),
            Vector3::new(-0.5, 0.0, 1.0),
        ));
    }
    let mut faces = Vec::new();
    for base in [0usize, 36] {
        for r in 0..5 {
            for c in 0..5 {
                let i = base + r * 6 + c;
                faces.push([i, i + 1, i + 7]);
                faces.push([i, i + 7, i + 6]);
            }
        }
    }
    let mut link = LinkSkin::new("two", taxels);
    link.faces = Some(faces);
    let map = flatten(&link);
    assert_eq!(map.report.components, 2);
    let d = map.report.distortion;
    assert!((d.area_ratio - 1.0).abs() < 1e-9 && d.flipped_faces == 0, "{d}");
    // Both pieces keep their size: the second is 0.05 x ~0.056 m, and they do not overlap.
    let second: Vec<&Point2<f64>> = map.points[36..].iter().collect();
    let first_max_u = map.points[..36].iter().map(|p| p.x).fold(f64::MIN, f64::max);
    let second_min_u = second.iter().map(|p| p.x).fold(f64::MAX, f64::min);
    assert!(
        second_min_u > first_max_u
            || map.points[..36].iter().map(|p| p.x).fold(f64::MAX, f64::min)
                > second.iter().map(|p| p.x).fold(f64::MIN, f64::max)
    );
    assert!(d.edge_ratio_spread() < 1.0 + 1e-9, "{d}");
}

#[test]
fn a_taxel_in_no_triangle_gets_an_extrapolated_point_and_is_reported() {
    let mut link = flat_grid(4, 4, 0.01);
    link.faces = Some(vec![
        [0, 1, 5],
        [0, 5, 4],
        [1, 2, 6],
        [1, 6, 5],
        [4, 5, 9],
        [4, 9, 8],
    ]);
    let map = flatten(&link);
    let isolated: Vec<u32> = map.report.mesh.isolated.iter().map(|t| t.0).collect();
    assert_eq!(isolated, vec![3, 7, 10, 11, 12, 13, 14, 15]);
    // The flat patch's affine map extends exactly: every point sits where the plane puts it.
    let original = plane_xy(&link);
    assert!(rigid_residual(&map.points, &original) < 1e-9);
}

#[test]
fn too_few_or_collinear_taxels_are_errors() {
    let two = LinkSkin::new("two", flat_grid(2, 1, 0.01).taxels);
    assert!(matches!(
        TactileMap::flatten(&two, &FlattenOptions::default()),
        Err(Error::TooFewTaxels(_))
    ));
    let line = LinkSkin::new("line", flat_grid(8, 1, 0.01).taxels);
    let e = TactileMap::flatten(&line, &FlattenOptions::default()).unwrap_err();
    assert!(e.to_string().contains("line"), "{e}");
    let mut same = flat_grid(3, 1, 0.01);
    for t in &mut same.taxels {
        t.position = Point3::origin();
    }
    assert!(matches!(
        TactileMap::flatten(&same, &FlattenOptions::default()),
        Err(Error::TooFewTaxels(_))
    ));
}

#[test]
fn an_edge_with_three_triangles_is_an_error_naming_its_taxels() {
    let mut link = flat_grid(3, 3, 0.01);
    link.taxels[8].position.z = 0.01;
    link.faces = Some(vec![[0, 1, 3], [1, 0, 4], [0, 1, 8]]);
    let e = TactileMap::flatten(&link, &FlattenOptions::default()).unwrap_err();
    assert!(matches!(e, Error::NonManifoldEdge { count: 3, .. }), "{e}");
    assert!(e.to_string().contains("taxels 0 and 1"), "{e}");
}

#[test]
fn a_closed_surface_cannot_be_flattened_in_one_piece() {
    let pts = [
        [0.0, 0.0, 0.0],
        [0.01, 0.0, 0.0],
        [0.0, 0.01, 0.0],
        [0.0, 0.0, 0.01],
    ];
    let taxels = pts
        .iter()
        .enumerate()
        .map(|(i, p)| taxel(i as u32, Point3::from(*p), Vector3::new(1.0, 1.0, 1.0)))
        .collect();
    let mut link = LinkSkin::new("tetra", taxels);
    link.faces = Some(vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]);
    let e = TactileMap::flatten(&link, &FlattenOptions::default()).unwrap_err();
    assert!(matches!(e, Error::NotFlattenable(_)), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn the_map_is_invariant_under_a_rigid_motion_of_the_skin(
        axis in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
        angle in -3.1f64..3.1,
        shift in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
    ) {
        let link = cylinder_patch(0.07, 1.5, 0.12, 10, 12);
        let axis = Unit::try_new(Vector3::new(axis.0, axis.1, axis.2), 1e-3).unwrap_or(Vector3::x_axis());
        let motion = Isometry3::from_parts(Translation3::new(shift.0, shift.1, shift.2), UnitQuaternion::from_axis_angle(&axis, angle));
        let mut moved = link.clone();
        for t in &mut moved.taxels {
            t.position = motion * t.position;
            t.normal = Unit::new_normalize(motion * t.normal.into_inner());
        }
        let a = flatten(&link);
        let b = flatten(&moved);
        prop_assert_eq!(&a.faces.len(), &b.faces.len());
        prop_assert!(rigid_residual(&a.points, &b.points) < 1e-9);
    }

    #[test]
    fn flattening_never_panics_on_arbitrary_clouds(
        pts in proptest::collection::vec((-0.1f64..0.1, -0.1f64..0.1, -0.01f64..0.01, -1.0f64..1.0), 0..40),
    ) {
        let taxels: Vec<Taxel> = pts
            .iter()
            .enumerate()
            .map(|(i, &(x, y, z, tilt))| taxel(i as u32, Point3::new(x, y, z), Vector3::new(tilt, 0.0, 1.0)))
            .collect();
        if let Ok(map) = TactileMap::flatten(&LinkSkin::new("cloud", taxels), &FlattenOptions::default()) {
            prop_assert!(map.points.iter().all(|p| p.x.is_finite() && p.y.is_finite()));
            prop_assert_eq!(map.report.distortion.flipped_faces, 0);
        }
    }
}
