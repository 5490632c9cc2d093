//! # skin-geom: tactile maps and tactile images
//!
//! Turns the taxels of a curved robot link into a flat **tactile map**, and pressure frames into
//! **tactile images** (thesis Ch. 3):
//!
//! ```text
//! LinkSkin --SkinMesh::build--> mesh S* --TactileMap::flatten (LSCM)--> map M*
//!          --Rasterizer::new (once)--> per frame: pressures -> image K (f32) -> grey -> morphology -> resize
//! ```
//!
//! - [`SkinMesh`]: triangles over the taxels, given or triangulated in a [`Chart`].
//! - [`TactileMap`]: one 2D point per taxel from least-squares conformal maps ([`Lscm`]), with a
//!   [`DistortionReport`]. Example: `examples/examples/flatten_link.rs`.
//! - [`Rasterizer`]: the grid on the map, with per-pixel taxel triples and
//!   barycentric weights precomputed; renders a frame with no allocation. [`TactileImager`] adds
//!   grey conversion (eq. 3.1), erosion / dilation and resizing for classifiers. Example:
//!   `examples/examples/tactile_images.rs`.
//! - [`Stitcher`] (Ch. 6): the maps of a chain of links placed every control cycle so
//!   that the skin across each joint keeps its 3D lengths (Eq. 6.6, argmin's BFGS, anytime), and
//!   [`StitchedRasterizer`]: one tactile image over all of them. Example:
//!   `examples/examples/stitch_links.rs`. [`ChainContacts`]: contacts over the stitched chain,
//!   so a touch across a joint is one contact. [`PostureChain`]: all of these at the postures of
//!   a poses file, each solved once, and stitched again without the [`DeadTaxels`] an input lacks.
//! - [`read_layout`], [`read_link`], [`read_map`]: any layout file a user has (project JSON,
//!   Cyskin, iCub, OBJ / glTF mesh) or a map, with [`Note`](skin_core::format::Note)s saying
//!   what was done to read a real file.
//! - [`MapCache`]: maps flattened once and kept in a folder, keyed by the layout file's content.
//! - [`BlindSpots`], [`Decimation`] (Ch. 5): blind spots and removed taxels, deterministic per
//!   seed, for robustness studies.
//!
//! The fixture forearm's tactile map (715 taxels, 1,328 triangles), as `skin flatten --svg`
//! draws it:
//!
#![doc = concat!("<div style=\"max-width: 640px\">", include_str!("../../docs/forearm_map.svg"), "</div>")]
//!
//! ```
//! use skin_core::{LinkSkin, Taxel, TaxelId};
//! use skin_geom::{FlattenOptions, Grid, Rasterizer, TactileMap};
//! use nalgebra::{Point3, Unit, Vector3};
//!
//! // A 10 x 10 grid of taxels, 8 mm apart, on a flat patch.
//! let taxels = (0..100u32)
//!     .map(|i| Taxel {
//!         id: TaxelId(i),
//!         position: Point3::new((i % 10) as f64 * 0.008, (i / 10) as f64 * 0.008, 0.0),
//!         normal: Unit::new_normalize(Vector3::z()),
//!     })
//!     .collect();
//! let map = TactileMap::flatten(&LinkSkin::new("patch", taxels), &FlattenOptions::default())?;
//! assert_eq!(map.report.distortion.flipped_faces, 0);
//!
//! let mut raster = Rasterizer::new(&map, Grid::StepMm(1.0))?;
//! let mut image = vec![0.0f32; raster.len()];
//! raster.render(&vec![100.0; 100], &mut image)?; // constant pressure...
//! assert!(image.iter().all(|&k| k == 0.0 || (k - 100.0).abs() < 1e-3)); // ...constant image
//! # Ok::<(), skin_geom::Error>(())
//! ```

mod border;
mod chain_contacts;
mod chart;
mod dead_taxels;
mod distortion;
mod error;
mod faults;
mod flatten;
mod imager;
mod layout_file;
mod map_cache;
mod map_file;
mod map_flatten;
mod map_svg;
mod mesh;
mod mesh_file;
mod morphology;
mod png;
mod raster;
mod resize;
mod stitch;
mod tactile_map;
mod triangulate;

pub use chain_contacts::{ChainContacts, ChainIndex};
pub use chart::Chart;
pub use dead_taxels::DeadTaxels;
pub use distortion::DistortionReport;
pub use error::{ChainError, Error, Result};
pub use faults::{BlindSpots, Decimation, masked_ground_truth};
pub use flatten::Lscm;
pub use imager::TactileImager;
pub use layout_file::{read_layout, read_link, read_map};
pub use map_cache::MapCache;
pub use map_file::MAP_FORMAT;
pub use mesh::{MeshOptions, MeshReport, MeshSource, SkinMesh, TriMesh, WELD_DISTANCE};
pub use mesh_file::{MAX_MESH_BYTES, MeshFileLink, load_mesh_file};
pub use morphology::{dilate_disk, erode_disk};
pub use png::{encode_png, write_png};
pub use raster::{BackProjection, Grid, NormKind, Normalisation, Rasterizer, UnknownNorm, to_grey};
pub use resize::Resizer;
pub use stitch::{
    BridgeTriangle, ChainTaxel, Deadline, JointMode, JointSolve, Placement, PostureChain, StitchOptions,
    StitchReport, StitchedRasterizer, Stitcher, stitched_svg,
};
pub use tactile_map::{FlattenOptions, FlattenReport, Flattening, TactileMap};
