//! The native module of the `skin` Python package (`skin._skin`; the package's `__init__.py`
//! re-exports it with the exceptions and the dataset loader). Each function is a thin call into
//! the crates: arguments checked and named, arrays in and out without copies where the data
//! already lies right, the GIL released for work on many frames.
//!
//! | Python | crate |
//! |---|---|
//! | `read_layout`, `Link`, `flatten`, `read_map`, `TactileMap`, `Imager` | skin-geom ([`geometry`]) |
//! | `read_recording`, `BusMap`, `read_log`, `CanFrame` | skin-core, skin-can ([`recordings`]) |
//! | `Session`, `Event`, `Contact`, `read_sim_config`, `read_session_settings`, Python models | skin-learn session ([`session`], [`models`]) |
//! | `read_probes`, `calibrate` | skin-learn calibration ([`calibration`]) |
//! | `synthesize`, `read_grey`, `Dataset` | skin-learn synth, dataset ([`synth`]) |
//! | `export`, `export_bytes` | skin-dataset ([`export`]) |
//! | `TaskStack` | skin-control ([`control`]) |
//! | `_ros_*`, `_rmw_zenoh_*` (for `skin.sim.zenoh`), `BusMap.candump` | skin-ros, skin-can ([`ros`]) |

mod arrays;
mod calibration;
mod control;
mod errors;
mod event;
mod export;
mod force;
mod geometry;
mod interrupt;
mod models;
mod recordings;
mod ros;
mod session;
mod settings;
mod synth;

use pyo3::prelude::*;

/// Rust's allocations in the module (the session, tract's tensors) are mimalloc's: glibc's
/// malloc let the Python objects a loop keeps settle in the blocks tract frees at each decision,
/// so those blocks were made anew elsewhere and memory grew with every kept event (see
/// python/Cargo.toml).
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// The module.
#[pymodule]
fn _skin(m: &Bound<'_, PyModule>) -> PyResult<()> {
    load_numpy(m.py())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<geometry::Link>()?;
    m.add_class::<geometry::Layout>()?;
    m.add_class::<geometry::TactileMap>()?;
    m.add_class::<geometry::Imager>()?;
    m.add_function(wrap_pyfunction!(geometry::read_layout, m)?)?;
    m.add_function(wrap_pyfunction!(geometry::flatten, m)?)?;
    m.add_function(wrap_pyfunction!(geometry::read_map, m)?)?;
    m.add_class::<recordings::Recording>()?;
    m.add_class::<recordings::BusMap>()?;
    m.add_class::<recordings::CanFrame>()?;
    m.add_class::<recordings::LogFrames>()?;
    m.add_function(wrap_pyfunction!(recordings::read_recording, m)?)?;
    m.add_function(wrap_pyfunction!(recordings::write_recording, m)?)?;
    m.add_function(wrap_pyfunction!(recordings::read_log, m)?)?;
    m.add_class::<session::Session>()?;
    m.add_class::<event::Event>()?;
    // The event kinds as the Rust session names them (skin.events holds its Literal to these).
    m.add(
        "EVENT_KINDS",
        pyo3::types::PyTuple::new(m.py(), skin_learn::session::Event::KINDS)?,
    )?;
    m.add_class::<event::Contact>()?;
    m.add_function(wrap_pyfunction!(event::_event, m)?)?;
    m.add_function(wrap_pyfunction!(event::_contact, m)?)?;
    m.add_function(wrap_pyfunction!(ros::_ros_type_hash, m)?)?;
    m.add_function(wrap_pyfunction!(ros::_ros_joint_state, m)?)?;
    m.add_function(wrap_pyfunction!(ros::_ros_event, m)?)?;
    m.add_function(wrap_pyfunction!(ros::_rmw_zenoh_entity, m)?)?;
    m.add_function(wrap_pyfunction!(ros::_rmw_zenoh_attachment, m)?)?;
    m.add_function(wrap_pyfunction!(settings::read_sim_config, m)?)?;
    m.add_function(wrap_pyfunction!(settings::read_session_settings, m)?)?;
    m.add_class::<calibration::Calibration>()?;
    m.add_function(wrap_pyfunction!(calibration::read_probes, m)?)?;
    m.add_function(wrap_pyfunction!(calibration::calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(force::calibrate_force, m)?)?;
    m.add_function(wrap_pyfunction!(synth::synthesize, m)?)?;
    m.add_function(wrap_pyfunction!(synth::read_grey, m)?)?;
    m.add_class::<synth::Dataset>()?;
    m.add_function(wrap_pyfunction!(export::export, m)?)?;
    m.add_function(wrap_pyfunction!(export::export_bytes, m)?)?;
    m.add_class::<control::TaskStack>()?;
    Ok(())
}

/// Loads numpy's C API and rust-numpy's borrow checking now, with the module, rather than in
/// the first call that makes or reads an array: loading them runs Python code, and a Ctrl-C
/// pending then (at the end of a long first call) made the loader panic, a `PanicException`
/// that `except Exception` does not catch. Here the only Python code runs first, in a call that
/// fails with the interrupt's own exception; what follows reads modules already imported.
fn load_numpy(py: Python<'_>) -> PyResult<()> {
    use numpy::PyArrayMethods;
    numpy::get_array_module(py)?;
    let probe = numpy::PyArray1::<u8>::zeros(py, 1, false);
    drop(probe.try_readwrite()?);
    drop(probe.try_readonly()?);
    Ok(())
}
