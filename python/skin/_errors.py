"""The exceptions `skin` raises: one base, `SkinError`, and a subclass per kind of fault.

Each carries the message the `skin` command line prints for the same fault: the file, line,
field, taxel or frame at fault, and what to do.
"""


class SkinError(Exception):
    """Base of every error `skin` raises."""


class InputError(SkinError):
    """A file or stream that is not what it should be, or cannot be read or written."""


class MissingFileError(InputError, FileNotFoundError):
    """A file that is not there: an `InputError`, and a `FileNotFoundError` as Python's own
    `open` raises (``except FileNotFoundError`` catches both)."""


class ConfigError(SkinError):
    """A run configuration (``run.toml``) or a model card at fault."""


class ModelError(SkinError):
    """A model that cannot be loaded or run."""


class ArrayError(SkinError, ValueError):
    """A bad argument, named: wrong dtype, shape or length, a NaN, a read-only output."""


class UnknownNameError(SkinError, KeyError):
    """A name the layout, scene or model does not have: a link, tool, body or actuator (a
    KeyError too, as a lookup by name)."""


class NotReadyError(SkinError, RuntimeError):
    """A call made before what it needs: a bridge or kit used before it was bound to a
    compiled model (a RuntimeError too)."""


class GeometryError(SkinError):
    """A skin that cannot be flattened, imaged or stitched."""


class SessionError(SkinError):
    """The session failed on a frame."""


class ControlError(SkinError):
    """The task stack cannot be solved as given."""


class SkinWarning(UserWarning):
    """What `skin` warns of where the command line says it on its error stream: no fault, but
    worth knowing (layout taxels on no bus of the bus map, a session ended before its baseline
    was learned). Filter it with ``warnings.filterwarnings(..., category=skin.SkinWarning)``."""


__all__ = [
    "SkinError",
    "InputError",
    "MissingFileError",
    "ConfigError",
    "ModelError",
    "ArrayError",
    "UnknownNameError",
    "NotReadyError",
    "GeometryError",
    "SessionError",
    "ControlError",
    "SkinWarning",
]
