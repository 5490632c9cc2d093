//! Rust errors as the package's Python exceptions: `skin.SkinError` and one subclass per kind of
//! fault (defined in `skin/_errors.py`, so that `ArrayError` is a `ValueError` too). The message
//! is the one the command line prints: the error and its causes, joined by ": ".

use pyo3::prelude::*;
use std::fmt::Display;

/// Which exception a fault raises.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    /// A file or stream that is not what it should be (or cannot be read or written).
    Input,
    /// A file that is not there: an `InputError` and a `FileNotFoundError` alike (chosen by
    /// [`raise`] from the error's causes, whatever kind its caller named).
    Missing,
    /// A run configuration (`run.toml`) at fault.
    Config,
    /// A model that cannot load or run.
    Model,
    /// An argument: wrong dtype, shape, length, a NaN, a read-only output.
    Array,
    /// A skin that cannot be flattened, imaged or stitched.
    Geometry,
    /// The session, on a frame.
    Session,
    /// The task stack.
    Control,
    /// Anything else (an object in use by another thread).
    Other,
}

// The package's exception classes (skin/_errors.py), each looked up once and kept, as PyO3's
// `import_exception!` does for a class defined in Python.
pyo3::import_exception!(skin._errors, SkinError);
pyo3::import_exception!(skin._errors, InputError);
pyo3::import_exception!(skin._errors, MissingFileError);
pyo3::import_exception!(skin._errors, ConfigError);
pyo3::import_exception!(skin._errors, ModelError);
pyo3::import_exception!(skin._errors, ArrayError);
pyo3::import_exception!(skin._errors, GeometryError);
pyo3::import_exception!(skin._errors, SessionError);
pyo3::import_exception!(skin._errors, ControlError);
pyo3::import_exception!(skin._errors, SkinWarning);

/// The exception of `kind` with `message`.
pub(crate) fn error(kind: Kind, message: impl Display) -> PyErr {
    let message = message.to_string();
    match kind {
        Kind::Input => InputError::new_err(message),
        Kind::Missing => MissingFileError::new_err(message),
        Kind::Config => ConfigError::new_err(message),
        Kind::Model => ModelError::new_err(message),
        Kind::Array => ArrayError::new_err(message),
        Kind::Geometry => GeometryError::new_err(message),
        Kind::Session => SessionError::new_err(message),
        Kind::Control => ControlError::new_err(message),
        Kind::Other => SkinError::new_err(message),
    }
}

/// Warns with `message` as a `skin.SkinWarning` (`warnings.warn`), where the command line says
/// it on its error stream: what the user should know that is no fault.
pub(crate) fn warn(py: Python<'_>, message: &str) -> PyResult<()> {
    let category = py.get_type::<SkinWarning>();
    let text = std::ffi::CString::new(message.replace('\0', " "))?;
    PyErr::warn(py, &category, &text, 1)
}

/// The state behind `lock`, unless another thread (or a callable the object is running) holds
/// it: waiting would hold the GIL that thread needs, so `what` is named as in use instead.
pub(crate) fn claim<'a, T>(
    lock: &'a std::sync::Mutex<T>,
    kind: Kind,
    what: &str,
) -> PyResult<std::sync::MutexGuard<'a, T>> {
    match lock.try_lock() {
        Ok(g) => Ok(g),
        Err(std::sync::TryLockError::Poisoned(p)) => Ok(p.into_inner()),
        Err(std::sync::TryLockError::WouldBlock) => Err(error(kind, format!("{what} is in use {IN_USE}"))),
    }
}

/// Why an object is in use, and what to do.
const IN_USE: &str = "(by another thread, or by a callable it is running): give each thread its own";

/// A bad argument, named.
pub(crate) fn arg(name: &str, message: impl Display) -> PyErr {
    error(Kind::Array, format!("{name}: {message}"))
}

/// An error and its causes, as the command line prints them; a cause whose text its parent
/// already shows is not repeated.
pub(crate) fn message(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        let more = s.to_string();
        if !text.contains(&more) {
            text.push_str(": ");
            text.push_str(&more);
        }
        source = s.source();
    }
    text
}

/// `e` as the exception of `kind`; a file that is not there (an `io::Error` of kind `NotFound`
/// among its causes) as `MissingFileError`, so that `except FileNotFoundError` catches it as it
/// would Python's own `open`.
pub(crate) fn raise(kind: Kind, e: &(dyn std::error::Error + 'static)) -> PyErr {
    let kind = if not_found(e) { Kind::Missing } else { kind };
    error(kind, message(e))
}

/// Whether `e` or one of its causes is an `io::Error` saying a file is not there.
fn not_found(e: &(dyn std::error::Error + 'static)) -> bool {
    let mut at = Some(e);
    while let Some(e) = at {
        if e.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::NotFound)
        {
            return true;
        }
        at = e.source();
    }
    false
}

/// A reading fault of skin-core (files, formats).
pub(crate) fn core(e: skin_core::Error) -> PyErr {
    raise(Kind::Input, &e)
}

/// A fault of skin-geom.
pub(crate) fn geom(e: skin_geom::Error) -> PyErr {
    raise(geom_kind(&e), &e)
}

/// A fault of skin-can (bus maps, logs).
pub(crate) fn can(e: skin_can::Error) -> PyErr {
    raise(Kind::Input, &e)
}

/// A run configuration's fault: reading its file is an input fault, a model one a model fault.
pub(crate) fn config(e: skin_learn::session::ConfigError) -> PyErr {
    raise(config_kind(&e), &e)
}

fn config_kind(e: &skin_learn::session::ConfigError) -> Kind {
    use skin_learn::session::ConfigError as C;
    match e {
        C::Model(_) => Kind::Model,
        C::Read(_) => Kind::Input,
        _ => Kind::Config,
    }
}

/// Which exception a fault of skin-geom raises: reading a file is an input fault, a length or
/// a number an argument's, the rest geometry.
fn geom_kind(e: &skin_geom::Error) -> Kind {
    match e {
        skin_geom::Error::Core(_) | skin_geom::Error::Layout { .. } | skin_geom::Error::MeshFile { .. } => {
            Kind::Input
        }
        skin_geom::Error::Length { .. }
        | skin_geom::Error::NotFinite { .. }
        | skin_geom::Error::Parameter { .. } => Kind::Array,
        _ => Kind::Geometry,
    }
}

/// A session's fault, by what it is about.
pub(crate) fn session(e: skin_learn::session::SessionError) -> PyErr {
    use skin_learn::session::SessionError as E;
    let kind = match &e {
        E::Config(c) => config_kind(c),
        E::Input(_) | E::Core(_) | E::Can(_) => Kind::Input,
        E::Model(_)
        | E::Touch(skin_learn::touch::TouchError::Model(_) | skin_learn::touch::TouchError::Decide { .. }) => {
            Kind::Model
        }
        E::Geom(g) => geom_kind(g),
        // Names a caller gave its classifier's scores: an argument's fault, named as it.
        E::Frame { .. } | E::Names { .. } => Kind::Array,
        _ => Kind::Session,
    };
    raise(kind, &e)
}
