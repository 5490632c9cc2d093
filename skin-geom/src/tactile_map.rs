//! The tactile map M* = ({m_1..m_N}, F): one 2D point per taxel (thesis Ch. 3.2, Fig. 3.2a).
//! Made by flattening a link ([`crate::map_flatten`]), read and written as a file
//! ([`crate::map_file`]), drawn as SVG ([`crate::map_svg`]).

use crate::distortion::DistortionReport;
use crate::mesh::{MeshOptions, MeshReport, MeshSource};
use nalgebra::{Point2, Point3};
use skin_core::TaxelId;
use skin_core::format::cyskin::CyskinTactileMap;

/// Options for [`TactileMap::flatten`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FlattenOptions {
    /// How the mesh over the taxels is built.
    pub mesh: MeshOptions,
}

/// What flattening did besides the map itself.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct FlattenReport {
    /// Where the triangles came from (given, or triangulated in which chart). `None` for a map
    /// read from a file that does not say.
    pub source: Option<MeshSource>,
    /// Repairs made while building the mesh.
    pub mesh: MeshReport,
    /// Number of edge-connected pieces, each flattened on its own and laid side by side.
    pub components: usize,
    /// Triangles dropped because they touched another piece at a single vertex only.
    pub pinch_faces: usize,
    /// Distortion of the map.
    pub distortion: DistortionReport,
}

/// A flattened link: a 2D point per taxel (metres) and triangles over the taxels.
///
/// The map is as seen from outside the skin (triangles counter-clockwise), its area equals the 3D
/// area of the mesh, it is rotated so that its longest extent runs along u, and its bounding box
/// starts at (0, 0).
#[derive(Debug, Clone, PartialEq)]
pub struct TactileMap {
    /// Name of the link.
    pub name: String,
    /// Taxel ids in layout order.
    pub ids: Vec<TaxelId>,
    /// 3D position of each taxel, metres (empty when the map was read without them).
    pub positions: Vec<Point3<f64>>,
    /// 2D position of each taxel on the map, metres.
    pub points: Vec<Point2<f64>>,
    /// Triangles as taxel indices, counter-clockwise on the map.
    pub faces: Vec<[usize; 3]>,
    /// How the map was made and how much it distorts.
    pub report: FlattenReport,
    /// Taxels whose readings count as zero (blind spots, thesis Ch. 5.2): they stay in the
    /// triangulation, and tactile images ignore what they report. Layout indices, increasing.
    pub zeroed: Vec<usize>,
}

impl TactileMap {
    /// Width and height of the map's bounding box, metres.
    pub fn extent(&self) -> (f64, f64) {
        let (lo, hi) = self.bounds();
        (hi.x - lo.x, hi.y - lo.y)
    }

    /// Lower and upper corners of the bounding box of the points that are in a triangle.
    pub fn bounds(&self) -> (Point2<f64>, Point2<f64>) {
        let mut lo = Point2::new(f64::INFINITY, f64::INFINITY);
        let mut hi = Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY);
        for f in &self.faces {
            for &t in f {
                let p = self.points[t];
                lo = lo.inf(&p);
                hi = hi.sup(&p);
            }
        }
        (lo, hi)
    }

    /// The map in Cyskin's `tactile_maps` form.
    pub fn to_cyskin(&self) -> CyskinTactileMap {
        CyskinTactileMap {
            name: self.name.clone(),
            kind: "lscm".into(),
            ids: self.ids.clone(),
            points: self.points.iter().map(|p| [p.x, p.y]).collect(),
            faces: self.faces.clone(),
        }
    }
}

impl TactileMap {
    /// The report of the flattening that made this map: mesh, repairs, pieces, size and
    /// distortion, a line each (`Display`; what `skin flatten` prints).
    pub fn flattening(&self) -> Flattening<'_> {
        Flattening { map: self }
    }
}

/// What flattening made of a link, as `skin flatten` prints it ([`TactileMap::flattening`]).
#[derive(Debug, Clone, Copy)]
pub struct Flattening<'a> {
    map: &'a TactileMap,
}

impl std::fmt::Display for Flattening<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let map = self.map;
        let r = &map.report;
        let (w, h) = map.extent();
        match r.source {
            Some(MeshSource::Triangulated { chart }) => writeln!(
                f,
                "mesh: {} triangles, Delaunay in the {chart}; {} triangles bridging holes or the outer concavity removed",
                map.faces.len(),
                r.mesh.bridging_faces
            )?,
            _ => writeln!(f, "mesh: {} triangles as given", map.faces.len())?,
        }
        if !r.mesh.welded.is_empty() {
            writeln!(
                f,
                "taxels at the same position (sharing one map point): {}",
                r.mesh
                    .welded
                    .iter()
                    .map(|g| format!("{:?}", g.iter().map(|t| t.0).collect::<Vec<_>>()))
                    .collect::<Vec<_>>()
                    .join(" ")
            )?;
        }
        if r.mesh.degenerate_faces + r.mesh.duplicate_faces + r.pinch_faces > 0 {
            writeln!(
                f,
                "dropped triangles: {} of zero area, {} repeated, {} pinched to another piece at one vertex",
                r.mesh.degenerate_faces, r.mesh.duplicate_faces, r.pinch_faces
            )?;
        }
        if !r.mesh.normals_off_plane.is_empty() {
            writeln!(
                f,
                "{} taxel normal(s) lie more than 60 deg off the flat skin's plane: the mesh takes the plane's normal there",
                r.mesh.normals_off_plane.len()
            )?;
        }
        if !r.mesh.isolated.is_empty() {
            writeln!(
                f,
                "taxels in no triangle (map point extrapolated from the nearest triangle): {:?}",
                r.mesh.isolated.iter().map(|t| t.0).collect::<Vec<_>>()
            )?;
        }
        if r.components > 1 {
            writeln!(
                f,
                "{} separate pieces, flattened one by one and laid side by side",
                r.components
            )?;
        }
        writeln!(
            f,
            "map: {:.1} x {:.1} mm (LSCM, area-preserving scale)",
            w * 1e3,
            h * 1e3
        )?;
        write!(f, "{}", r.distortion)
    }
}
