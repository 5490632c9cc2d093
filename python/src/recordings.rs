//! Recordings and CAN logs as arrays: `read_recording`, `BusMap`, `read_log` (assembled frames,
//! per link, with their missing modules).

use crate::arrays::{self, array, slice};
use crate::errors::{self, Kind, arg};
use crate::geometry::Layout;
use crate::interrupt::{self, Watch};
use numpy::{PyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use skin_can::candump::CandumpReader;
use skin_can::{AssembledFrame, Assembler, BusMap as RustBusMap, LayoutFrames, Missing};
use skin_core::TaxelId;
use skin_core::format::recording::RecordingReader;
use skin_core::text::Gzip;
use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// The largest array `for_taxels` makes, bytes.
const MAX_ARRAY_BYTES: usize = 8 << 30;

/// A Cyskin recording, whole: frame numbers and times (T,), taxel ids (N,), readings (T, N).
#[pyclass(module = "skin._skin", frozen)]
pub(crate) struct Recording {
    inner: skin_core::Recording,
    path: PathBuf,
}

#[pymethods]
impl Recording {
    /// Frame times, (T,) seconds.
    #[getter]
    fn times<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let f = &self.inner.frames;
        arrays::out(py, f.iter().map(|f| f.time).collect(), &[f.len()])
    }

    /// Frame numbers, (T,).
    #[getter]
    fn frame_numbers<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<u64>>> {
        let n = &self.inner.frame_numbers;
        arrays::out(py, n.clone(), &[n.len()])
    }

    /// The columns' taxel ids, (N,) uint32.
    #[getter]
    fn ids<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<u32>>> {
        let ids = &self.inner.taxel_ids;
        arrays::out(py, ids.iter().map(|t| t.0).collect(), &[ids.len()])
    }

    /// Raw readings, (T, N) float32, one column per id.
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let n = self.inner.taxel_ids.len();
        let t = self.inner.frames.len();
        let mut v = Vec::with_capacity(t * n);
        for f in &self.inner.frames {
            v.extend_from_slice(&f.values[..n.min(f.values.len())]);
            v.resize(v.len() + n - n.min(f.values.len()), 0.0);
        }
        arrays::out(py, v, &[t, n])
    }

    /// The readings of the taxels `ids` (a map's or a link's, in its order), (T, len(ids)):
    /// readings at or below `threshold` and taxels the recording has no column for read 0, as
    /// `skin image` reads a recording onto a map.
    #[pyo3(signature = (ids, threshold = 0.0))]
    fn for_taxels<'py>(
        &self,
        py: Python<'py>,
        ids: &Bound<'py, PyAny>,
        threshold: f64,
    ) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        if !threshold.is_finite() {
            return Err(arg(
                "threshold",
                format!("{}: expected a number of counts", arrays::num(threshold)),
            ));
        }
        let a = array::<i64>("ids", ids, "int64", 1)?;
        let ids = crate::arrays::taxel_ids("ids", slice("ids", &a)?, false)?;
        let m = ids.len();
        let bytes = self.inner.frames.len().saturating_mul(m).saturating_mul(4);
        if bytes > MAX_ARRAY_BYTES {
            return Err(arg(
                "ids",
                format!(
                    "{m} ids over {} frames would take {:.1} GB",
                    self.inner.frames.len(),
                    bytes as f64 / 1e9
                ),
            ));
        }
        let columns = self.inner.columns(&ids);
        let mut out = vec![0.0f32; self.inner.frames.len() * m];
        if m > 0 {
            for (f, dst) in self.inner.frames.iter().zip(out.chunks_exact_mut(m)) {
                columns.gather(&f.values, threshold as f32, dst);
            }
        }
        arrays::out(py, out, &[self.inner.frames.len(), m])
    }

    /// The file read.
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    fn __len__(&self) -> usize {
        self.inner.frames.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "Recording({:?}, {} frames of {} taxels)",
            self.path.display().to_string(),
            self.inner.frames.len(),
            self.inner.taxel_ids.len()
        )
    }
}

/// Reads a Cyskin raw recording (line 1: taxel ids; then frame number, time in s, one reading
/// per id); gzip-compressed files too. The GIL is released while reading; Ctrl-C ends the read,
/// a named pipe's wait for its writer too.
#[pyfunction]
pub(crate) fn read_recording(py: Python<'_>, path: PathBuf) -> PyResult<Recording> {
    let watch = Arc::new(Watch::new());
    let read = py.detach(|| open_recording(&path, &watch)?.into_recording());
    match read {
        Ok(inner) => Ok(Recording { inner, path }),
        Err(e) => Err(watch.raised().unwrap_or_else(|| errors::core(e))),
    }
}

/// Writes a Cyskin raw recording, the form `read_recording` and `skin run --recording` read:
/// `ids` (N,) taxel ids, `times` (T,) seconds in increasing order, `values` (T, N) raw counts
/// (whole numbers are written as integers). Frames are numbered from 0. The file appears
/// complete or not at all; an existing file is replaced only if it is a recording.
#[pyfunction]
pub(crate) fn write_recording(
    path: PathBuf,
    ids: &Bound<'_, PyAny>,
    times: &Bound<'_, PyAny>,
    values: &Bound<'_, PyAny>,
) -> PyResult<()> {
    let i = array::<i64>("ids", ids, "int64", 1)?;
    let taxel_ids = arrays::taxel_ids("ids", slice("ids", &i)?, true)?;
    if taxel_ids.is_empty() {
        return Err(arg("ids", "empty: a recording needs at least one taxel"));
    }
    let t = array::<f64>("times", times, "float64", 1)?;
    let times = slice("times", &t)?;
    arrays::finite64("times", times, t.shape())?;
    if let Some(k) = times.windows(2).position(|w| w[1] <= w[0]) {
        return Err(arg(
            "times",
            format!(
                "{} at index {} after {}: times must increase",
                times[k + 1],
                k + 1,
                times[k]
            ),
        ));
    }
    let v = array::<f32>("values", values, "float32", 2)?;
    let shape = v.shape().to_vec();
    if shape != [times.len(), taxel_ids.len()] {
        return Err(arg(
            "values",
            format!(
                "shape ({}): expected ({}, {}), a row per time and a column per id",
                arrays::shape(&shape),
                times.len(),
                taxel_ids.len()
            ),
        ));
    }
    let flat = slice("values", &v)?;
    arrays::finite("values", flat, &shape)?;
    let limit = skin_core::format::recording::MAX_READING;
    if let Some(at) = flat.iter().position(|x| x.abs() > limit) {
        return Err(arg(
            "values",
            format!(
                "{} at row {}, column {}: counts are at most {limit:e}",
                flat[at],
                at / shape[1],
                at % shape[1]
            ),
        ));
    }
    let rec = skin_core::Recording {
        taxel_ids,
        frame_numbers: (0..times.len() as u64).collect(),
        frames: times
            .iter()
            .zip(flat.chunks(shape[1].max(1)))
            .map(|(&time, row)| skin_core::Frame {
                time,
                values: row.to_vec(),
            })
            .collect(),
    };
    let io = |e: skin_core::output::OutputError| errors::raise(Kind::Input, &e);
    let is_recording = |p: &Path| {
        RecordingReader::open(p)
            .and_then(|mut r| r.next_frame().map(|_| ()))
            .is_ok()
    };
    skin_core::output::check_replaceable(&path, "a recording", is_recording).map_err(io)?;
    let text = skin_core::format::recording::to_string(&rec);
    skin_core::output::write_file(
        &path,
        text.as_bytes(),
        &skin_core::output::Inputs::new::<&str>([]),
    )
    .map_err(io)
}

/// A bus map (`busmap.toml`): which module on which bus carries which taxels.
#[pyclass(module = "skin._skin", frozen)]
pub(crate) struct BusMap {
    pub(crate) inner: RustBusMap,
}

#[pymethods]
impl BusMap {
    /// Reads a bus map file.
    #[staticmethod]
    fn read(path: PathBuf) -> PyResult<BusMap> {
        Ok(BusMap {
            inner: RustBusMap::read(&path).map_err(errors::can)?,
        })
    }

    /// The buses' interface names, in order.
    #[getter]
    fn interfaces(&self) -> Vec<String> {
        self.inner.buses.iter().map(|b| b.interface.clone()).collect()
    }

    /// The taxel ids of every slot, in bus-map order, (S,) uint32.
    #[getter]
    fn ids<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<u32>>> {
        let ids = self.inner.taxel_ids();
        arrays::out(py, ids.iter().map(|t| t.0).collect(), &[ids.len()])
    }

    /// Each module in bus-map order: (interface, address, its slots), the slots as indices into
    /// `ids` (its unused slots left out).
    #[getter]
    fn modules(&self) -> Vec<(String, u32, Vec<usize>)> {
        self.inner
            .module_slots()
            .map(|(b, m, slots)| (self.inner.buses[b].interface.clone(), m.address, slots.collect()))
            .collect()
    }

    /// One frame's traffic as candump lines (what `candump -L` writes), for a reader such as
    /// `skin run --log` on a pipe: when `sync`, every bus's sync for `cycle` at `time` (s), then
    /// the data of each module not in `missing` (interface, address), as `Session.push_bus`
    /// takes a frame. skin16 bus maps only. A skin16 cycle is complete when the next one's syncs
    /// come: a writer waiting on the reader sends those (`candump_sync`) right after.
    #[pyo3(signature = (values, time, cycle, missing = Vec::new(), sync = true))]
    fn candump(
        &self,
        values: &Bound<'_, PyAny>,
        time: f64,
        cycle: u64,
        missing: Vec<(String, u32)>,
        sync: bool,
    ) -> PyResult<String> {
        let time_us = crate::session::seconds("time", time)?;
        let (values, refs) = bus_values(&self.inner, values, &missing)?;
        let values: Vec<u16> = values.iter().map(|v| v.unwrap_or(0)).collect();
        let log = skin_can::encode::encode_frame(&self.inner, &values, cycle, time_us, &refs, sync)
            .map_err(|e| errors::error(Kind::Input, e))?;
        Ok(log.to_text())
    }

    /// Every bus's sync for `cycle` at `time` (s), as candump lines: opens that cycle and
    /// completes the one before.
    fn candump_sync(&self, time: f64, cycle: u64) -> PyResult<String> {
        let time_us = crate::session::seconds("time", time)?;
        let log = skin_can::encode::encode_syncs(&self.inner, cycle, time_us)
            .map_err(|e| errors::error(Kind::Input, e))?;
        Ok(log.to_text())
    }

    fn __repr__(&self) -> String {
        format!(
            "BusMap(interfaces {:?}, {} slots)",
            self.interfaces(),
            self.inner.taxel_ids().len()
        )
    }
}

/// A frame as the buses carry it, checked: `values` (S,) counts in bus-map slot order, rounded
/// and held within 0 and 65,535, and the modules `missing` (interface, address), whose slots are
/// not read. Returns the slots' values (None on a missing module) and the modules as the
/// assembler names them. `Session.push_bus` and `BusMap.candump` both take frames through it.
pub(crate) fn bus_values(
    busmap: &RustBusMap,
    values: &Bound<'_, PyAny>,
    missing: &[(String, u32)],
) -> PyResult<(Vec<Option<u16>>, Vec<skin_can::ModuleRef>)> {
    let values = array::<f32>("values", values, "float32", 1)?;
    let values = slice("values", &values)?;
    let slots = busmap.slot_count();
    if values.len() != slots {
        return Err(arg(
            "values",
            format!("{} values, the bus map has {slots} slots", values.len()),
        ));
    }
    let mut refs = Vec::with_capacity(missing.len());
    let mut skip = vec![false; slots];
    for (interface, address) in missing {
        let found = busmap
            .module_slots()
            .find(|(b, m, _)| busmap.buses[*b].interface == *interface && m.address == *address)
            .map(|(b, _, range)| (b, range));
        let Some((bus, range)) = found else {
            return Err(arg(
                "missing",
                format!("no module {interface}:{address} in the bus map"),
            ));
        };
        skip[range].iter_mut().for_each(|s| *s = true);
        refs.push(skin_can::ModuleRef {
            bus: u16::try_from(bus).unwrap_or(u16::MAX),
            address: *address,
        });
    }
    let mut out = Vec::with_capacity(slots);
    for (i, (&v, &skipped)) in values.iter().zip(&skip).enumerate() {
        if skipped {
            out.push(None);
        } else if v.is_finite() {
            out.push(Some(v.round().clamp(0.0, 65_535.0) as u16));
        } else {
            return Err(arg(
                "values",
                format!(
                    "slot {i} (taxel {}) is {v}: give its module in `missing` instead",
                    busmap.taxel_ids()[i].0
                ),
            ));
        }
    }
    Ok((out, refs))
}

/// One assembled frame of a CAN log: per link its readings (NaN where a module's data did not
/// arrive), and the modules missing.
#[pyclass(module = "skin._skin", frozen)]
pub(crate) struct CanFrame {
    pub(crate) frame: AssembledFrame,
    values: Vec<Vec<f32>>,
    interfaces: Vec<String>,
}

#[pymethods]
impl CanFrame {
    /// Time of the cycle's first sync, seconds on the log's clock.
    #[getter]
    fn time(&self) -> f64 {
        self.frame.time_us as f64 * 1e-6
    }

    /// The same, microseconds.
    #[getter]
    fn time_us(&self) -> u64 {
        self.frame.time_us
    }

    /// The cycle number (the sync counter, unwrapped past 255).
    #[getter]
    fn cycle(&self) -> u64 {
        self.frame.cycle
    }

    /// Readings per link (layout order): a list of (N_link,) float32 arrays, NaN for a taxel whose
    /// module's data did not arrive or that no bus carries.
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyArrayDyn<f32>>>> {
        self.values
            .iter()
            .map(|v| arrays::out(py, v.clone(), &[v.len()]))
            .collect()
    }

    /// The modules with data missing, as (bus interface, address).
    #[getter]
    fn missing(&self) -> Vec<(String, u32)> {
        self.frame
            .missing
            .iter()
            .map(|m| {
                (
                    self.interfaces
                        .get(usize::from(m.bus))
                        .cloned()
                        .unwrap_or_default(),
                    m.address,
                )
            })
            .collect()
    }

    /// Every module sent all its data.
    #[getter]
    fn complete(&self) -> bool {
        self.frame.is_complete()
    }

    fn __repr__(&self) -> String {
        format!(
            "CanFrame(cycle {}, t {:.6} s, {} modules missing)",
            self.frame.cycle,
            self.time(),
            self.frame.missing.len()
        )
    }
}

/// What a log being read holds between frames.
struct LogState {
    reader: CandumpReader,
    assembler: Assembler<Box<dyn skin_can::decode::Decoder + Send>>,
    layout: LayoutFrames,
    ready: VecDeque<AssembledFrame>,
    ended: bool,
}

/// The assembled frames of a candump log, read as they are asked for (any length of log). The
/// GIL is released while reading; Ctrl-C ends a read (a named pipe's wait for data too), and
/// the log is not read further after that: read it again.
#[pyclass(module = "skin._skin")]
pub(crate) struct LogFrames {
    state: Mutex<LogState>,
    interfaces: Vec<String>,
    /// (link, taxel index) of the layout's taxels on no bus of the map.
    uncovered: Vec<(String, usize)>,
    /// Ctrl-C during a read; the reader's place in the log is then unknown.
    watch: Arc<Watch>,
    path: PathBuf,
}

#[pymethods]
impl LogFrames {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    /// The layout's taxels that no slot of the bus map carries, as (link name, taxel index):
    /// they read NaN in every frame (the session takes them as dead). A frame is complete when
    /// every module of the bus map sent its data, whatever the layout has beyond it.
    #[getter]
    fn uncovered(&self) -> Vec<(String, usize)> {
        self.uncovered.clone()
    }

    fn __next__(&self, py: Python<'_>) -> PyResult<Option<CanFrame>> {
        if self.watch.tripped() {
            return Err(errors::error(
                Kind::Input,
                format!(
                    "{}: its reading was interrupted (Ctrl-C) part-way through a frame: read the log again",
                    self.path.display()
                ),
            ));
        }
        let next = py.detach(|| {
            let mut state = self
                .state
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            state.next()
        });
        match next {
            Ok(next) => Ok(next.map(|(frame, values)| CanFrame {
                frame,
                values,
                interfaces: self.interfaces.clone(),
            })),
            Err(e) => Err(self.watch.raised().unwrap_or_else(|| errors::can(e))),
        }
    }
}

/// An assembled frame and its readings per link.
type Placed = (AssembledFrame, Vec<Vec<f32>>);

impl LogState {
    /// The next assembled frame, reading the log as far as it takes; None at its end.
    fn next(&mut self) -> Result<Option<Placed>, skin_can::Error> {
        while self.ready.is_empty() && !self.ended {
            let ready = &mut self.ready;
            match self.reader.next_frame()? {
                Some(frame) => {
                    // Interfaces join the assembler as the log names them (as `skin run`).
                    let named = self.reader.interfaces();
                    for name in &named[self.assembler.interfaces()..] {
                        self.assembler.add_interface(name);
                    }
                    self.assembler.push(&frame, &mut |a| ready.push_back(a.clone()));
                }
                None => {
                    self.ended = true;
                    self.assembler.finish(&mut |a| ready.push_back(a.clone()));
                }
            }
        }
        let Some(frame) = self.ready.pop_front() else {
            return Ok(None);
        };
        let mut values = self.layout.buffers();
        for v in &mut values {
            v.fill(f32::NAN);
        }
        self.layout.place(&frame, &mut values)?;
        Ok(Some((frame, values)))
    }
}

/// Reads a candump log (`candump -l` or `-L`; gzip too) through `busmap` onto the links of
/// `layout`: an iterator of `CanFrame`s, one per sync cycle. The GIL is released while the file
/// is opened (a named pipe waits for its writer, which may be a thread of this process) and
/// read; Ctrl-C ends either wait.
#[pyfunction]
pub(crate) fn read_log(
    py: Python<'_>,
    path: PathBuf,
    busmap: &BusMap,
    layout: &Layout,
) -> PyResult<LogFrames> {
    let watch = Arc::new(Watch::new());
    let reader = py
        .detach(|| open_log(&path, &watch))
        .map_err(|e| watch.raised().unwrap_or_else(|| errors::can(e)))?;
    let ids: Vec<Vec<TaxelId>> = layout.links.iter().map(skin_core::LinkSkin::ids).collect();
    let layout_frames = LayoutFrames::new(&busmap.inner, &ids, Missing::NotANumber).map_err(errors::can)?;
    let uncovered = layout_frames
        .uncovered()
        .iter()
        .map(|&(l, i)| (layout.links[l].name.clone(), i))
        .collect();
    Ok(LogFrames {
        state: Mutex::new(LogState {
            reader,
            assembler: Assembler::for_map(&busmap.inner, &[], skin_can::DEFAULT_WINDOW_US),
            layout: layout_frames,
            ready: VecDeque::new(),
            ended: false,
        }),
        interfaces: busmap.inner.buses.iter().map(|b| b.interface.clone()).collect(),
        uncovered,
        watch,
        path,
    })
}

/// A candump log opened for reading with its reads watched ([`interrupt::open`]).
pub(crate) fn open_log(path: &Path, watch: &Arc<Watch>) -> Result<CandumpReader, skin_can::Error> {
    let input = interrupt::open(path, Gzip::Read, watch)?;
    Ok(CandumpReader::new(input, path))
}

/// A recording opened for reading frame by frame with its reads watched ([`interrupt::open`]).
pub(crate) fn open_recording(path: &Path, watch: &Arc<Watch>) -> skin_core::Result<RecordingReader> {
    RecordingReader::new(interrupt::open(path, Gzip::Read, watch)?, path)
}
