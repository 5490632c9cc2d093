//! Layouts, tactile maps and tactile images: `read_layout`, `Link`, `flatten`, `read_map`,
//! `TactileMap`, `Imager`.

use crate::arrays::{self, array, finite, finite_from, finite64, slice};
use crate::errors::{self, Kind, arg};
use crate::interrupt::Watch;
use nalgebra::{Point3, Unit, Vector3};
use numpy::{PyArrayDyn, PyArrayMethods, PyReadwriteArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use skin_core::image::ImageSize;
use skin_core::{LinkSkin, Taxel};
use skin_geom::{FlattenOptions, Grid, MeshOptions, NormKind, Normalisation, Rasterizer, TactileImager};
use std::path::PathBuf;

/// One link's skin: its name and taxels (ids, positions and outward normals in metres, in the
/// link's frame), and the triangles that join them when the file gives them.
#[pyclass(module = "skin._skin", frozen)]
#[derive(Clone)]
pub(crate) struct Link {
    pub(crate) inner: LinkSkin,
}

#[pymethods]
impl Link {
    /// A link from arrays: `ids` (N,) integers, `positions` (N, 3) metres, `normals` (N, 3)
    /// (normalised here; a zero normal is an error), `faces` (M, 3) indices into the taxels.
    #[new]
    #[pyo3(signature = (name, ids, positions, normals, faces=None))]
    fn new(
        name: String,
        ids: &Bound<'_, PyAny>,
        positions: &Bound<'_, PyAny>,
        normals: &Bound<'_, PyAny>,
        faces: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Link> {
        let id_array = array::<i64>("ids", ids, "int64", 1)?;
        let id_values = slice("ids", &id_array)?;
        let n = id_values.len();
        let xyz = |label: &str, obj: &Bound<'_, PyAny>| -> PyResult<Vec<f64>> {
            let a = array::<f64>(label, obj, "float64", 2)?;
            if a.shape() != [n, 3] {
                return Err(arg(
                    label,
                    format!(
                        "shape {}, expected ({n}, 3): one row per id",
                        crate::arrays::shape(a.shape())
                    ),
                ));
            }
            let v = slice(label, &a)?.to_vec();
            finite64(label, &v, &[n, 3])?;
            Ok(v)
        };
        let p = xyz("positions", positions)?;
        let nrm = xyz("normals", normals)?;
        let ids = arrays::taxel_ids("ids", id_values, true)?;
        let mut taxels = Vec::with_capacity(n);
        for (i, &id) in ids.iter().enumerate() {
            let normal = Vector3::new(nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]);
            let normal = Unit::try_new(normal, 1e-12)
                .ok_or_else(|| arg("normals", format!("row {i} (taxel {}) is zero", id.0)))?;
            taxels.push(Taxel {
                id,
                position: Point3::new(p[3 * i], p[3 * i + 1], p[3 * i + 2]),
                normal,
            });
        }
        if name.trim().is_empty() {
            return Err(arg("name", "empty: a link needs a name"));
        }
        if taxels.is_empty() {
            return Err(arg("ids", "no taxel: a link needs at least one"));
        }
        let mut inner = LinkSkin::new(name, taxels);
        if let Some(faces) = faces {
            let f = array::<i64>("faces", faces, "int64", 2)?;
            let m = f.shape()[0];
            if f.shape()[1] != 3 {
                return Err(arg(
                    "faces",
                    format!("shape {}, expected (M, 3)", crate::arrays::shape(f.shape())),
                ));
            }
            let v = slice("faces", &f)?;
            let mut tris = Vec::with_capacity(m);
            for (k, t) in v.chunks_exact(3).enumerate() {
                let mut tri = [0usize; 3];
                for (slot, &i) in tri.iter_mut().zip(t) {
                    *slot = usize::try_from(i).ok().filter(|&i| i < n).ok_or_else(|| {
                        arg("faces", format!("row {k}: index {i}, the link has {n} taxels"))
                    })?;
                }
                tris.push(tri);
            }
            inner.faces = Some(tris);
        }
        Ok(Link { inner })
    }

    /// The link's name.
    #[getter]
    fn name(&self) -> &str {
        &self.inner.name
    }

    /// Taxel ids, (N,) uint32.
    #[getter]
    fn ids<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<u32>>> {
        let ids = self.inner.taxels.iter().map(|t| t.id.0).collect();
        arrays::out(py, ids, &[self.inner.taxels.len()])
    }

    /// Taxel positions, (N, 3) metres in the link's frame.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        arrays::points(py, self.inner.taxels.iter().map(|t| t.position.coords.into()))
    }

    /// Outward unit normals, (N, 3).
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        arrays::points(py, self.inner.taxels.iter().map(|t| t.normal.into_inner().into()))
    }

    /// The triangles the file gives, (M, 3) indices into the taxels, or None.
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArrayDyn<i64>>>> {
        self.inner
            .faces
            .as_deref()
            .map(|f| arrays::faces(py, f))
            .transpose()
    }

    fn __len__(&self) -> usize {
        self.inner.taxels.len()
    }

    fn __repr__(&self) -> String {
        format!("Link({:?}, {} taxels)", self.inner.name, self.inner.taxels.len())
    }
}

/// The links of a layout file, in its order, with what reading it did (`notes`).
#[pyclass(module = "skin._skin", frozen)]
pub(crate) struct Layout {
    pub(crate) links: Vec<LinkSkin>,
    notes: Vec<String>,
    path: PathBuf,
}

#[pymethods]
impl Layout {
    /// The links, in layout order.
    #[getter]
    fn links(&self) -> Vec<Link> {
        self.links.iter().map(|l| Link { inner: l.clone() }).collect()
    }

    /// The links' names, in layout order.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.links.iter().map(|l| l.name.clone()).collect()
    }

    /// What reading the file did (a byte-order mark skipped, units converted, ...), one line each.
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    /// The file read.
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    fn __len__(&self) -> usize {
        self.links.len()
    }

    /// A link by name or by index.
    fn __getitem__(&self, key: &Bound<'_, PyAny>) -> PyResult<Link> {
        let found = if let Ok(i) = key.extract::<isize>() {
            let n = self.links.len() as isize;
            let k = if i < 0 { i + n } else { i };
            if !(0..n).contains(&k) {
                return Err(pyo3::exceptions::PyIndexError::new_err(format!(
                    "link {i}: the layout has {n}"
                )));
            }
            Some(&self.links[k as usize])
        } else {
            let name: String = key.extract()?;
            self.links.iter().find(|l| l.name == name)
        };
        found.map(|l| Link { inner: l.clone() }).ok_or_else(|| {
            pyo3::exceptions::PyKeyError::new_err(format!(
                "{key}: the layout has {}",
                self.names().join(", ")
            ))
        })
    }

    fn __repr__(&self) -> String {
        let n: usize = self.links.iter().map(|l| l.taxels.len()).sum();
        format!(
            "Layout({:?}, links {:?}, {n} taxels)",
            self.path.display().to_string(),
            self.names()
        )
    }
}

/// Reads a layout in any format `skin` reads (native JSON, Cyskin, iCub, URDF with tactile
/// sensors): every link.
#[pyfunction]
pub(crate) fn read_layout(path: PathBuf) -> PyResult<Layout> {
    let noted = skin_geom::read_layout(&path).map_err(errors::geom)?;
    Ok(Layout {
        links: noted.value,
        notes: noted.notes.iter().map(ToString::to_string).collect(),
        path,
    })
}

/// A link flattened onto the plane (thesis Ch. 3.2): each taxel's place `uv` on the map, and
/// how much the flattening distorted the skin.
#[pyclass(module = "skin._skin", frozen)]
#[derive(Clone)]
pub(crate) struct TactileMap {
    pub(crate) inner: skin_geom::TactileMap,
}

#[pymethods]
impl TactileMap {
    /// The link's name.
    #[getter]
    fn name(&self) -> &str {
        &self.inner.name
    }

    /// Taxel ids in map order, (N,) uint32.
    #[getter]
    fn ids<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<u32>>> {
        arrays::out(
            py,
            self.inner.ids.iter().map(|t| t.0).collect(),
            &[self.inner.ids.len()],
        )
    }

    /// Each taxel's place on the map, (N, 2) metres.
    #[getter]
    fn uv<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let n = self.inner.points.len();
        arrays::out(
            py,
            self.inner.points.iter().flat_map(|p| [p.x, p.y]).collect(),
            &[n, 2],
        )
    }

    /// Each taxel's distance from the skin's border on the map (the outline of its triangles
    /// and the rim of any hole), (N,) millimetres: 0 on the border, and for a taxel in no
    /// triangle.
    #[getter]
    fn border_mm<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let d = self.inner.border_distances();
        let n = d.len();
        arrays::out(py, d.into_iter().map(|m| m * 1e3).collect(), &[n])
    }

    /// The skin area each taxel stands for, (N,) m², from the map's triangles in 3D (a third of
    /// each triangle it is a corner of): what a force model turns its pressure into newtons
    /// with. 0 for a taxel in no triangle; an error for a map read without 3D positions.
    #[getter]
    fn areas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let a = skin_learn::force_calibration::link_areas(&self.inner)
            .map_err(|e| errors::raise(Kind::Geometry, &e))?;
        let n = a.len();
        arrays::out(py, a, &[n])
    }

    /// Each taxel's 3D position, (N, 3) metres (empty for a map read without them).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        arrays::points(py, self.inner.positions.iter().map(|p| p.coords.into()))
    }

    /// The map's triangles, (M, 3) indices into the taxels.
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<i64>>> {
        arrays::faces(py, &self.inner.faces)
    }

    /// The distortion report, as `skin flatten` prints it.
    #[getter]
    fn report(&self) -> String {
        self.inner.flattening().to_string()
    }

    /// The distortion figures: angles in degrees, ratios map/skin (the fields of skin-geom's
    /// `DistortionReport`, by name).
    #[getter]
    fn distortion(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let fields = serde_json::to_value(self.inner.report.distortion)
            .map_err(|e| errors::error(Kind::Other, format!("the distortion report: {e}")))?;
        crate::event::json(py, &fields)
    }

    /// Writes the map: `format` "native" (the JSON of `skin flatten`) or "cyskin". The file
    /// appears complete or not at all; an existing file is replaced only if it is a tactile map.
    #[pyo3(signature = (path, format = "native"))]
    fn write(&self, path: PathBuf, format: &str) -> PyResult<()> {
        let text = match format {
            "native" => self.inner.to_json(),
            "cyskin" => skin_core::format::cyskin::tactile_map_to_string(&self.inner.to_cyskin()),
            other => {
                return Err(arg(
                    "format",
                    format!("{other:?}: expected \"native\" or \"cyskin\""),
                ));
            }
        };
        let is_map = |p: &std::path::Path| {
            skin_geom::TactileMap::read(p).is_ok()
                || skin_core::format::read_text(p)
                    .ok()
                    .is_some_and(|t| skin_core::format::cyskin::parse_tactile_map(&t, p).is_ok())
        };
        let io = |e: skin_core::output::OutputError| errors::raise(Kind::Input, &e);
        skin_core::output::check_replaceable(&path, "a tactile map", is_map).map_err(io)?;
        skin_core::output::write_file(
            &path,
            text.as_bytes(),
            &skin_core::output::Inputs::new::<&str>([]),
        )
        .map_err(io)
    }

    /// The map as an SVG drawing.
    fn to_svg(&self) -> String {
        self.inner.to_svg()
    }

    fn __len__(&self) -> usize {
        self.inner.ids.len()
    }

    fn __repr__(&self) -> String {
        let (w, h) = self.inner.extent();
        format!(
            "TactileMap({:?}, {} taxels, {:.1} x {:.1} mm)",
            self.inner.name,
            self.inner.ids.len(),
            w * 1e3,
            h * 1e3
        )
    }
}

/// Flattens a link as `skin flatten` does (LSCM, thesis Ch. 3.2): on the file's triangles, or
/// on a new triangulation (`triangulate`), edges longer than `max_edge` taxel pitches dropped.
#[pyfunction]
#[pyo3(signature = (link, *, triangulate = false, max_edge = 3.0))]
pub(crate) fn flatten(py: Python<'_>, link: &Link, triangulate: bool, max_edge: f64) -> PyResult<TactileMap> {
    if !(max_edge > 0.0 && max_edge <= 1e3) {
        return Err(arg(
            "max_edge",
            format!(
                "{}: expected more than 0, at most 1000, in taxel pitches (multiples of the distance between neighbouring taxels; not mm or m)",
                arrays::num(max_edge)
            ),
        ));
    }
    let options = FlattenOptions {
        mesh: MeshOptions {
            use_given_faces: !triangulate,
            max_edge_pitches: max_edge,
            ..MeshOptions::default()
        },
    };
    let inner = &link.inner;
    let map = py
        .detach(|| skin_geom::TactileMap::flatten(inner, &options))
        .map_err(|e| {
            errors::error(
                Kind::Geometry,
                format!("link \"{}\": {}", inner.name, errors::message(&e)),
            )
        })?;
    Ok(TactileMap { inner: map })
}

/// Reads a tactile map (`skin flatten`'s JSON or a Cyskin `tactile_maps` file); a layout file is
/// flattened with the default options, as the command line does: its only link, or the one
/// named `link`.
#[pyfunction]
#[pyo3(signature = (path, link = None))]
pub(crate) fn read_map(py: Python<'_>, path: PathBuf, link: Option<String>) -> PyResult<TactileMap> {
    // A layout of several links: the one asked for, flattened.
    if let Ok(layout) = skin_geom::read_layout(&path) {
        let names: Vec<&str> = layout.value.iter().map(|l| l.name.as_str()).collect();
        if layout.value.len() > 1 || link.is_some() {
            let pick = match &link {
                Some(name) => names.iter().position(|n| n == name).ok_or_else(|| {
                    arg(
                        "link",
                        format!(
                            "{}: no link {name:?} (it has {})",
                            path.display(),
                            names.join(", ")
                        ),
                    )
                })?,
                None => {
                    return Err(arg(
                        "link",
                        format!(
                            "{}: {} links ({}); choose one with link=",
                            path.display(),
                            names.len(),
                            names.join(", ")
                        ),
                    ));
                }
            };
            let one = &layout.value[pick];
            let map = py
                .detach(|| skin_geom::TactileMap::flatten(one, &FlattenOptions::default()))
                .map_err(|e| {
                    errors::error(
                        Kind::Geometry,
                        format!("{}: {}", path.display(), errors::message(&e)),
                    )
                })?;
            return Ok(TactileMap { inner: map });
        }
    }
    let noted = py
        .detach(|| skin_geom::read_map(&path, &FlattenOptions::default()))
        .map_err(errors::geom)?;
    if let Some(name) = link
        && name != noted.value.name
    {
        return Err(arg(
            "link",
            format!(
                "{}: a map of link {:?}, not {name:?}",
                path.display(),
                noted.value.name
            ),
        ));
    }
    Ok(TactileMap { inner: noted.value })
}

/// Tactile images of one map, built once (thesis Ch. 3.3, eq. 3.1): pressure interpolated on a
/// grid laid on the map, grey = floor(255 K / K_bar), then optionally eroded and dilated and
/// resized. One imager serves one thread at a time; two threads each use their own.
#[pyclass(module = "skin._skin", frozen)]
pub(crate) struct Imager {
    state: std::sync::Mutex<ImagerState>,
    size: ImageSize,
    grid: (usize, usize),
    taxels: usize,
}

/// What an imager works in.
struct ImagerState {
    inner: TactileImager,
    threshold: f32,
    /// The frame after the threshold, in map order.
    pressures: Vec<f32>,
}

#[pymethods]
impl Imager {
    /// `step_mm`: pixel side on the map (or `grid=(rows, cols)`: exactly that many pixels);
    /// `norm`: "contact_max" (white = the frame's largest pressure) or "full_scale" (white =
    /// `full_scale` counts); `threshold`: readings at or below it are no pressure; `morph`: erosion
    /// (disk r=2) then dilation (r=4); `size=(rows, cols)`: resize (68 x 100 for HandsNet).
    #[new]
    #[pyo3(signature = (map, *, step_mm = None, grid = None, norm = "contact_max", full_scale = None, threshold = 0.0, morph = false, size = None))]
    #[allow(clippy::too_many_arguments)] // keyword arguments, as `skin image` has options
    fn new(
        map: &TactileMap,
        step_mm: Option<f64>,
        grid: Option<&Bound<'_, PyAny>>,
        norm: &str,
        full_scale: Option<f64>,
        threshold: f64,
        morph: bool,
        size: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Imager> {
        let grid = match (grid, step_mm) {
            (Some(_), Some(_)) => return Err(arg("grid", "give grid or step_mm, not both")),
            (Some(g), None) => {
                let (rows, cols) = arrays::pair("grid", g)?;
                image_size("grid", rows, cols)?;
                Grid::Size { rows, cols }
            }
            (None, step) => {
                let step = step.unwrap_or(1.0);
                if !(0.01..=1000.0).contains(&step) {
                    return Err(arg(
                        "step_mm",
                        format!("{}: expected 0.01 to 1000 mm", arrays::num(step)),
                    ));
                }
                Grid::StepMm(step)
            }
        };
        let kind = norm.parse::<NormKind>();
        if full_scale.is_some() && kind != Ok(NormKind::FullScale) {
            return Err(arg(
                "full_scale",
                "only with norm=\"full_scale\" (contact_max scales each frame by its own maximum)",
            ));
        }
        let norm = match (kind.map_err(|e| arg("norm", e))?, full_scale) {
            (NormKind::FullScale, Some(k)) if k > 0.0 && k <= f64::from(f32::MAX) => {
                Normalisation::FullScale(k as f32)
            }
            (NormKind::FullScale, Some(k)) => {
                return Err(arg(
                    "full_scale",
                    format!(
                        "{}: expected a positive number of counts, at most {:e}",
                        arrays::num(k),
                        f32::MAX
                    ),
                ));
            }
            (NormKind::FullScale, None) => {
                return Err(arg("full_scale", "norm=\"full_scale\" needs full_scale (counts)"));
            }
            (NormKind::ContactMax, _) => Normalisation::ContactMax,
        };
        if !threshold.is_finite() {
            return Err(arg(
                "threshold",
                format!("{}: expected a number of counts", arrays::num(threshold)),
            ));
        }
        let size = size
            .map(|s| arrays::pair("size", s).and_then(|(r, c)| image_size("size", r, c)))
            .transpose()?;
        let raster = Rasterizer::new(&map.inner, grid).map_err(errors::geom)?;
        let grid = (raster.rows(), raster.cols());
        let inner = TactileImager::new(raster, norm, morph, size).map_err(errors::geom)?;
        Ok(Imager {
            size: inner.output_size(),
            grid,
            taxels: map.inner.ids.len(),
            state: std::sync::Mutex::new(ImagerState {
                pressures: vec![0.0; map.inner.ids.len()],
                inner,
                threshold: threshold as f32,
            }),
        })
    }

    /// The images' (rows, cols).
    #[getter]
    fn size(&self) -> (usize, usize) {
        (self.size.rows, self.size.cols)
    }

    /// Taxels a frame has (the map's, in its order).
    #[getter]
    fn taxels(&self) -> usize {
        self.taxels
    }

    /// One frame (N,) -> its image (rows, cols) uint8.
    fn image<'py>(&self, py: Python<'py>, frame: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArrayDyn<u8>>> {
        let a = array::<f32>("frame", frame, "float32", 1)?;
        let values = self.check_frames("frame", &a)?;
        let mut out = vec![0u8; self.size.pixels()];
        self.lock()?.run(values, &mut out, None)?;
        arrays::out(py, out, &[self.size.rows, self.size.cols])
    }

    /// Frames (T, N) -> images (T, rows, cols) uint8, into `out` if given (a writable, C-ordered
    /// uint8 array of that shape). Every frame is checked before any is imaged. The GIL is
    /// released while imaging, a block of frames at a time, each block copied first: a thread
    /// that writes `frames` meanwhile tears no image and cannot slip a NaN past the check.
    /// Ctrl-C stops it within a frame and raises `KeyboardInterrupt` (`out`, if given, then holds
    /// the images of the frames done so far, the rest as they were).
    #[pyo3(signature = (frames, out = None))]
    fn images<'py>(
        &self,
        py: Python<'py>,
        frames: &Bound<'py, PyAny>,
        out: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let a = array::<f32>("frames", frames, "float32", 2)?;
        let t = a.shape()[0];
        let values = self.check_frames("frames", &a)?;
        let size = self.size;
        let shape = [t, size.rows, size.cols];
        let mut state = self.lock()?;
        let state = &mut *state;
        match out {
            Some(target) => {
                let mut w = writable(target, &shape)?;
                let dst = w.as_slice_mut().map_err(|_| arg("out", "not C-contiguous"))?;
                state.run_blocks(py, values, a.shape(), dst)?;
                drop(w);
                Ok(target.clone())
            }
            None => {
                // numpy's allocator, not Rust's: numpy asks the kernel for huge pages on large
                // arrays, and a batch's first write to fresh memory costs a fault per page.
                let target = py
                    .import("numpy")?
                    .call_method1("zeros", (shape.to_vec(), "uint8"))?
                    .cast_into::<PyArrayDyn<u8>>()?;
                let mut w = target.try_readwrite().map_err(|_| arg("out", "in use"))?;
                let dst = w.as_slice_mut().map_err(|_| arg("out", "not C-contiguous"))?;
                state.run_blocks(py, values, a.shape(), dst)?;
                drop(w);
                Ok(target.into_any())
            }
        }
    }

    /// One frame (N,) -> its pressure image K (grid rows, grid cols) float32, counts: before
    /// quantisation, morphology and resizing.
    fn pressure_image<'py>(
        &self,
        py: Python<'py>,
        frame: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let a = array::<f32>("frame", frame, "float32", 1)?;
        let values = self.check_frames("frame", &a)?;
        let mut scratch = vec![0u8; self.size.pixels()];
        let mut state = self.lock()?;
        state.run(values, &mut scratch, None)?;
        arrays::out(
            py,
            state.inner.pressure_image().to_vec(),
            &[self.grid.0, self.grid.1],
        )
    }

    fn __repr__(&self) -> String {
        format!(
            "Imager({} taxels -> {} x {} px)",
            self.taxels, self.size.rows, self.size.cols
        )
    }
}

impl Imager {
    /// The imager's state, unless another thread is imaging with it.
    fn lock(&self) -> PyResult<std::sync::MutexGuard<'_, ImagerState>> {
        errors::claim(&self.state, Kind::Other, "the imager")
    }

    /// The values of a batch of frames of this imager's taxels, finite.
    fn check_frames<'a>(&self, name: &str, a: &'a numpy::PyReadonlyArrayDyn<'_, f32>) -> PyResult<&'a [f32]> {
        let n = self.taxels;
        let last = *a.shape().last().unwrap_or(&0);
        if last != n {
            return Err(arg(
                name,
                format!(
                    "shape {}: {last} readings a frame, the map has {n} taxels",
                    crate::arrays::shape(a.shape())
                ),
            ));
        }
        let values = slice(name, a)?;
        finite(name, values, a.shape())?;
        Ok(values)
    }
}

/// The frames `Imager.images` copies at a time, bytes: a copy that costs little next to imaging
/// them, and memory that does not grow with the batch.
const BLOCK_BYTES: usize = 1 << 20;

impl ImagerState {
    /// Images `values` (frames of `shape`, checked) into `out` a block of frames at a time: each
    /// block copied and checked again with the GIL held (Python threads may write the caller's
    /// array while the GIL is released), then imaged with it released, watching for Ctrl-C.
    fn run_blocks(
        &mut self,
        py: Python<'_>,
        values: &[f32],
        shape: &[usize],
        out: &mut [u8],
    ) -> PyResult<()> {
        let n = self.pressures.len();
        let px = self.inner.output_size().pixels();
        if n == 0 || px == 0 {
            return Ok(());
        }
        let frames = (BLOCK_BYTES / (n * 4)).max(1);
        let mut block = Vec::with_capacity(frames * n);
        let watch = Watch::new();
        for (k, (given, dst)) in values
            .chunks(frames * n)
            .zip(out.chunks_mut(frames * px))
            .enumerate()
        {
            block.clear();
            block.extend_from_slice(given);
            finite_from("frames", &block, shape, k * frames * n)?;
            let done = py.detach(|| self.run(&block, dst, Some(&watch)));
            if let Some(e) = watch.raised() {
                return Err(e);
            }
            done?;
        }
        Ok(())
    }

    /// Images each frame of `values` into its slot of `out`, until `watch` (if any) says stop.
    fn run(&mut self, values: &[f32], out: &mut [u8], watch: Option<&Watch>) -> PyResult<()> {
        let n = self.pressures.len();
        let px = self.inner.output_size().pixels();
        if n == 0 {
            return Ok(());
        }
        for (frame, dst) in values.chunks_exact(n).zip(out.chunks_exact_mut(px)) {
            if watch.is_some_and(Watch::stop) {
                return Ok(());
            }
            for (p, &v) in self.pressures.iter_mut().zip(frame) {
                *p = if v > self.threshold { v } else { 0.0 };
            }
            self.inner
                .process_into(&self.pressures, dst)
                .map_err(errors::geom)?;
        }
        Ok(())
    }
}

/// A checked image size (each side 1 to 4096).
fn image_size(name: &str, rows: usize, cols: usize) -> PyResult<ImageSize> {
    ImageSize::new(rows, cols).map_err(|e| arg(name, e))
}

/// `obj` as a writable uint8 array of exactly `shape`.
fn writable<'py>(obj: &Bound<'py, PyAny>, shape: &[usize]) -> PyResult<PyReadwriteArrayDyn<'py, u8>> {
    let a = obj
        .cast::<PyArrayDyn<u8>>()
        .map_err(|_| arg("out", "expected a numpy array of dtype uint8"))?;
    if a.shape() != shape {
        return Err(arg(
            "out",
            format!(
                "shape {}, expected {}",
                crate::arrays::shape(a.shape()),
                crate::arrays::shape(shape)
            ),
        ));
    }
    if !a.is_c_contiguous() {
        return Err(arg("out", "not C-contiguous"));
    }
    a.try_readwrite()
        .map_err(|_| arg("out", "read-only (or in use elsewhere)"))
}
