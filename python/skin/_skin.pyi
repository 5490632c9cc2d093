"""Type stubs of the native module (skin._skin). Units: metres, seconds, raw counts."""

import os
from pathlib import Path
from typing import (
    Any,
    Callable,
    ClassVar,
    Dict,
    Iterator,
    List,
    Literal,
    Mapping,
    Optional,
    Sequence,
    Tuple,
    Union,
    final,
)

import numpy as np
import numpy.typing as npt

from skin.events import EventDict, EventKind
from skin.events import GateAction as _GateAction

_Path = Union[str, "os.PathLike[str]"]
_Array = npt.ArrayLike
# (rows, cols): any sequence of two whole numbers (a tuple, a list, an array).
_Size = Union[Sequence[int], npt.NDArray[np.integer[Any]]]

# Every class is final (none can be subclassed) and those with a constructor take their arguments
# in `__new__`, as the native module defines them.

__all__ = [
    "__version__",
    "EVENT_KINDS",
    "Link",
    "Layout",
    "TactileMap",
    "Imager",
    "read_layout",
    "flatten",
    "read_map",
    "Recording",
    "BusMap",
    "CanFrame",
    "LogFrames",
    "read_recording",
    "write_recording",
    "read_log",
    "Session",
    "Event",
    "Contact",
    "_event",
    "_contact",
    "_ros_type_hash",
    "_ros_joint_state",
    "_ros_event",
    "_rmw_zenoh_entity",
    "_rmw_zenoh_attachment",
    "read_sim_config",
    "read_session_settings",
    "Calibration",
    "read_probes",
    "calibrate",
    "calibrate_force",
    "synthesize",
    "export",
    "export_bytes",
    "read_grey",
    "Dataset",
    "TaskStack",
]

__version__: str

@final
class Link:
    """One link's skin: taxel ids, positions and outward normals (metres, the link's frame)."""

    def __new__(cls, name: str, ids: _Array, positions: _Array, normals: _Array, faces: Optional[_Array] = None) -> "Link":
        """`ids` (N,) integers, `positions` (N, 3) metres, `normals` (N, 3) (normalised; a zero
        normal is an error), `faces` (M, 3) indices into the taxels."""
    @property
    def name(self) -> str: ...
    @property
    def ids(self) -> npt.NDArray[np.uint32]:
        """(N,) taxel ids."""
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """(N, 3) metres."""
    @property
    def normals(self) -> npt.NDArray[np.float64]:
        """(N, 3) unit vectors."""
    @property
    def faces(self) -> Optional[npt.NDArray[np.int64]]:
        """(M, 3) indices into the taxels, or None."""
    def __len__(self) -> int: ...

@final
class Layout:
    """The links of a layout file, in its order."""

    @property
    def links(self) -> List[Link]: ...
    @property
    def names(self) -> List[str]: ...
    @property
    def notes(self) -> List[str]:
        """What reading the file did, one line each."""
    @property
    def path(self) -> Path: ...
    def __len__(self) -> int: ...
    def __getitem__(self, key: Union[int, str], /) -> Link:
        """By name (KeyError if none) or index (IndexError)."""

def read_layout(path: _Path) -> Layout:
    """Any layout format `skin` reads: native JSON, Cyskin, iCub taxel files, URDF with tactile sensors."""

@final
class TactileMap:
    """A link flattened onto the plane (LSCM)."""

    @property
    def name(self) -> str: ...
    @property
    def ids(self) -> npt.NDArray[np.uint32]: ...
    @property
    def uv(self) -> npt.NDArray[np.float64]:
        """(N, 2) metres on the map."""
    @property
    def areas(self) -> npt.NDArray[np.float64]:
        """(N,) m², the skin area each taxel stands for (its force model's)."""
    @property
    def border_mm(self) -> npt.NDArray[np.float64]:
        """(N,) each taxel's distance from the skin's border on the map, millimetres."""
    @property
    def positions(self) -> npt.NDArray[np.float64]: ...
    @property
    def faces(self) -> npt.NDArray[np.int64]: ...
    @property
    def report(self) -> str:
        """The distortion report `skin flatten` prints."""
    @property
    def distortion(self) -> Dict[str, float]: ...
    def write(self, path: _Path, format: Literal["native", "cyskin"] = "native") -> None:
        """"native" (skin flatten's JSON) or "cyskin"; replaces only a tactile map."""
    def to_svg(self) -> str: ...
    def __len__(self) -> int: ...

def flatten(link: Link, *, triangulate: bool = False, max_edge: float = 3.0) -> TactileMap:
    """LSCM, as `skin flatten`; a new triangulation (`triangulate`) drops edges longer than
    `max_edge` taxel pitches (multiples of the distance between neighbouring taxels, not mm or m)."""
def read_map(path: _Path, link: Optional[str] = None) -> TactileMap:
    """A map file, or a layout's link flattened (`link` names it when the layout has several)."""

@final
class Imager:
    """Tactile images of one map (thesis eq. 3.1), built once; one thread at a time."""

    def __new__(
        cls,
        map: TactileMap,
        *,
        step_mm: Optional[float] = None,  # 1.0
        grid: Optional[_Size] = None,
        norm: Literal["contact_max", "full_scale"] = "contact_max",
        full_scale: Optional[float] = None,
        threshold: float = 0.0,
        morph: bool = False,
        size: Optional[_Size] = None,
    ) -> "Imager":
        """step_mm (1 mm by default) or grid=(rows, cols); full_scale only with norm="full_scale"."""
    @property
    def size(self) -> Tuple[int, int]: ...
    @property
    def taxels(self) -> int: ...
    def image(self, frame: _Array) -> npt.NDArray[np.uint8]:
        """(N,) readings in map order -> (rows, cols)."""
    def images(self, frames: _Array, out: Optional[npt.NDArray[np.uint8]] = None) -> npt.NDArray[np.uint8]:
        """(T, N) -> (T, rows, cols); every frame checked first, then imaged a copied block at a
        time with the GIL released. Ctrl-C raises KeyboardInterrupt within a frame (`out` then
        holds the frames done so far)."""
    def pressure_image(self, frame: _Array) -> npt.NDArray[np.float32]: ...

@final
class Recording:
    @property
    def times(self) -> npt.NDArray[np.float64]: ...
    @property
    def frame_numbers(self) -> npt.NDArray[np.uint64]: ...
    @property
    def ids(self) -> npt.NDArray[np.uint32]: ...
    @property
    def values(self) -> npt.NDArray[np.float32]:
        """(T, N) raw readings."""
    @property
    def path(self) -> Path: ...
    def for_taxels(self, ids: _Array, threshold: float = 0.0) -> npt.NDArray[np.float32]: ...
    def __len__(self) -> int: ...

def write_recording(path: _Path, ids: _Array, times: _Array, values: _Array) -> None:
    """Writes a raw recording (ids (N,), times (T,) s increasing, values (T, N) counts), whole or not at all."""

def read_recording(path: _Path) -> Recording:
    """The GIL is released while reading; Ctrl-C ends it (a named pipe's wait for a writer too)."""

@final
class BusMap:
    @staticmethod
    def read(path: _Path) -> "BusMap": ...
    @property
    def interfaces(self) -> List[str]: ...
    @property
    def ids(self) -> npt.NDArray[np.uint32]: ...
    @property
    def modules(self) -> List[Tuple[str, int, List[int]]]:
        """(interface, address, its slots as indices into `ids`), in bus-map order."""
    def candump(
        self,
        values: _Array,
        time: float,
        cycle: int,
        missing: Sequence[Tuple[str, int]] = ...,  # none missing
        sync: bool = True,
    ) -> str:
        """One frame's traffic as candump lines (skin16): the cycle's syncs when `sync`, then the
        data of each module not in `missing`; `values` (S,) counts in slot order, `time` in s."""
    def candump_sync(self, time: float, cycle: int) -> str:
        """Every bus's sync for `cycle` at `time` (s): completes the cycle before."""

@final
class CanFrame:
    @property
    def time(self) -> float: ...
    @property
    def time_us(self) -> int: ...
    @property
    def cycle(self) -> int: ...
    @property
    def values(self) -> List[npt.NDArray[np.float32]]:
        """Per link, NaN where a module's data did not arrive."""
    @property
    def missing(self) -> List[Tuple[str, int]]: ...
    @property
    def complete(self) -> bool: ...

@final
class LogFrames(Iterator[CanFrame]):
    """Frames read as asked for, the GIL released; after Ctrl-C ended a read, the next raises
    InputError (read the log again)."""

    @property
    def uncovered(self) -> List[Tuple[str, int]]:
        """(link, taxel index) of the layout's taxels on no bus: NaN in every frame."""
    def __iter__(self) -> "LogFrames": ...
    def __next__(self) -> CanFrame: ...

def read_log(path: _Path, busmap: BusMap, layout: Layout) -> LogFrames:
    """A named pipe's wait for its writer (a thread of this process too) releases the GIL and ends on Ctrl-C."""

# Every event kind as the Rust session names it, in declaration order (`skin.events.EVENT_KINDS`
# is held to it).
EVENT_KINDS: Tuple[str, ...]

@final
class Event:
    """A session event: `kind` and the fields events.jsonl documents, as attributes (their types
    per kind: `skin.events`). Pickles."""

    @property
    def kind(self) -> EventKind: ...
    @property
    def image(self) -> Optional[npt.NDArray[np.uint8]]: ...
    # The fields as attributes (`event.time`, `event.touch`): the native class looks them up
    # after its own attributes, in `__getattribute__`; AttributeError for a field it lacks.
    def __getattribute__(self, name: str, /) -> Any: ...
    def __getitem__(self, name: str, /) -> Any:
        """A field by name: `event["class"]` (a Python keyword as an attribute); KeyError if none."""
    def to_dict(self) -> EventDict:
        """The line events.jsonl holds: a dict typed by its `"event"` (`skin.events.EventDict`)."""
    def __eq__(self, other: object, /) -> bool: ...
    __hash__: ClassVar[None]  # type: ignore[assignment]  # compared by value: unhashable

def _event(kind: str, fields: str, image: Optional[npt.NDArray[np.uint8]]) -> Event:
    """An unpickled Event."""

@final
class Contact:
    """One contact of the last frame on a link; a value (compared, pickled by its fields)."""

    @property
    def taxels(self) -> List[int]:
        """Indices into the link's taxels (layout order), ascending: not ids (`taxel_ids`)."""
    @property
    def taxel_ids(self) -> List[int]:
        """The same taxels' ids, in the order of `taxels`."""
    @property
    def centroid(self) -> Tuple[float, float, float]:
        """Pressure-weighted, metres in the link's frame."""
    @property
    def normal(self) -> Optional[Tuple[float, float, float]]:
        """Pressure-weighted outward unit normal, or None (the session's contacts on tactile maps)."""
    @property
    def mean_pressure(self) -> float:
        """Counts above the baseline."""
    @property
    def peak_pressure(self) -> float:
        """Counts above the baseline."""
    @property
    def force_n(self) -> Optional[float]:
        """Newtons; None on a link without a force calibration (never a guess)."""
    def __eq__(self, other: object, /) -> bool: ...
    __hash__: ClassVar[None]  # type: ignore[assignment]  # compared by value: unhashable

def _ros_type_hash(type_name: str) -> str: ...
def _ros_joint_state(
    time: float,
    names: List[str],
    positions: List[float],
    velocities: List[float] = ...,
    frame_id: str = "",
) -> bytes: ...
def _ros_event(cdr: bytes) -> Event: ...
def _rmw_zenoh_entity(
    domain: int, zid: str, namespace: str, node: str, id: int, kind: str, topic: str, type_name: str, qos: str
) -> Tuple[str, str, str, bytes]:
    """(data key expression, the node's liveliness token, the entity's, its 16-byte GID)."""
def _rmw_zenoh_attachment(seq: int, gid: bytes) -> bytes: ...
def _contact(
    taxels: Sequence[int],
    taxel_ids: Sequence[int],
    centroid: Tuple[float, float, float],
    normal: Optional[Tuple[float, float, float]],
    mean_pressure: float,
    peak_pressure: float,
    force_n: Optional[float] = None,
) -> Contact:
    """An unpickled Contact."""

# image (rows, cols) uint8 -> class probabilities (0 to 1), or part labels (rows, cols) 0..6.
_Model = Callable[[npt.NDArray[np.uint8]], Any]

@final
class Session:
    """The per-frame pipeline of a skin: frames in, events out. Not picklable (TypeError): pickle
    its events. Building one whose bus map leaves layout taxels on no bus warns (SkinWarning)."""

    @staticmethod
    def from_config(
        path: _Path,
        *,
        classifier: Optional[_Model] = None,
        segmenter: Optional[_Model] = None,
        classes: Optional[Sequence[str]] = None,
        hand: Optional[str] = None,
    ) -> "Session": ...
    @staticmethod
    def from_layout(
        layout: Layout,
        *,
        busmap: Optional[BusMap] = None,
        classifier: Optional[_Model] = None,
        segmenter: Optional[_Model] = None,
        classes: Optional[Sequence[str]] = None,
        hand: Optional[str] = None,
        image_size: Optional[_Size] = None,  # (68, 100)
        baseline_frames: Optional[int] = None,  # 20
        polarity: Optional[Literal["rising", "falling"]] = None,  # "rising"
        threshold: Optional[float] = None,  # 5.0 counts
        min_taxels: Optional[int] = None,  # 2
        decide_frames: Optional[int] = None,  # 3
        release_frames: Optional[int] = None,  # 2
        gate: Optional[Dict[str, _GateAction]] = None,  # {class name: action}; None: no gate
    ) -> "Session": ...
    def push(self, readings: Union[Sequence[_Array], Mapping[str, _Array], _Array], time: float) -> List[Event]:
        """One frame; times in seconds, in order."""
    def push_can(self, frame: CanFrame) -> List[Event]: ...
    def push_bus(
        self,
        values: _Array,
        time: float,
        missing: Sequence[Tuple[str, int]] = ...,  # none missing
    ) -> List[Event]:
        """(S,) counts in bus-map slot order, and the modules lost (interface, address): a CAN frame."""
    def finish(self) -> List[Event]:
        """Releases open touches; the session then takes no more frames. Before the baseline
        was learned: no events, and a SkinWarning."""
    def run_log(self, path: _Path) -> List[Event]:
        """A whole log, on a new session (which it ends); the GIL is released, and Ctrl-C raises
        KeyboardInterrupt within a frame, the events dropped."""
    def run_recording(self, path: _Path) -> List[Event]:
        """As run_log, for a Cyskin recording."""
    def tare(self, *, force: bool = False) -> str:
        """Learns the baseline again over the next baseline frames (they read no pressure).
        Raises SessionError while a touch is on the skin unless force (touches released first),
        and even forced while the gate stops the arm for a touch or the baseline is learned."""
    def joint_states(self, time: float, names: List[str], positions: List[float]) -> None:
        """The robot's joint angles at `time` (s, the frames' clock), by name; needs [stitch] urdf.
        Frames then take the posture of their time; touches get `centroid_base`."""
    def describe(self) -> Dict[str, Any]:
        """The skin as skin_msgs/TactileLayout describes it: simulated, source,
        touch_threshold_counts, and per link name, ids, positions, normals (m), areas (m²),
        modules, units ("counts" or "N"), calibration_id, dead."""
    def contacts(self, link: Union[int, str]) -> List[Contact]: ...
    def wrench(
        self, link: Union[int, str]
    ) -> Optional[Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], Optional[npt.NDArray[np.float64]]]]:
        """Force (N) and torque (N m, about the link's origin) of the last frame's contacts, in
        the link's frame, and their centre of pressure (m; None without contact); None on a link
        without a force calibration."""
    @property
    def links(self) -> List[str]: ...
    @property
    def taxels(self) -> List[int]: ...
    @property
    def classes(self) -> List[str]: ...
    @property
    def gate(self) -> Optional[_GateAction]:
        """What the gate says now, or None without a gate."""
    @property
    def settings(self) -> Optional[Dict[str, Any]]:
        """What it runs with, as run.toml's sections and keys: image_size, baseline, touch, gate."""
    @property
    def stats(self) -> Dict[str, int]: ...
    @property
    def uncovered(self) -> List[Tuple[str, int]]:
        """(link, taxel id) of the layout's taxels on no bus of the bus map: dead."""

@final
class Calibration:
    @property
    def ids(self) -> npt.NDArray[np.uint32]: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """(N, 3) metres, NaN rows where not fitted."""
    @property
    def normals(self) -> npt.NDArray[np.float64]: ...
    @property
    def centre_sd_mm(self) -> npt.NDArray[np.float64]: ...
    @property
    def samples(self) -> npt.NDArray[np.uint64]: ...
    @property
    def fitted(self) -> npt.NDArray[np.bool_]: ...
    @property
    def status(self) -> List[str]: ...
    def to_tsv(self) -> str: ...
    def __len__(self) -> int: ...

def read_sim_config(path: Optional[_Path] = None, overrides: Optional[Dict[str, Any]] = None) -> Dict[str, Any]:
    """A run configuration's `[sim]` table (all defaults without a file), `overrides` on top, checked."""

def read_session_settings(path: Optional[_Path] = None) -> Dict[str, Any]:
    """A run configuration's session settings (image_size, baseline, touch, gate), checked, the
    defaults filled in (all of them without a file): what a session built from it runs with."""

def read_probes(path: _Path) -> Dict[str, npt.NDArray[Any]]: ...
def calibrate(
    centroids: _Array,
    ids: _Array,
    responses: _Array,
    *,
    min_responses: Optional[int] = None,  # 8
    epsilon: float = 1e-6,
    max_iterations: Optional[int] = None,  # 200
    max_extrapolation_mm: float = 8.0,
    max_open_angle_deg: float = 170.0,
    outward: Optional[_Array] = None,  # a direction (x, y, z): any sequence or array of 3
) -> Calibration: ...
def calibrate_force(
    config: _Path,
    load: _Path,
    *,
    log: Optional[_Path] = None,
    recording: Optional[_Path] = None,
    link: Optional[str] = None,
    full_scale: Optional[float] = None,
    gain_sd: Optional[float] = None,  # 0.2
    min_frames: Optional[int] = None,  # 3
    output: Optional[_Path] = None,
) -> Dict[str, Any]:
    """A link's force model fitted from presses with a known load (`skin calibrate-force`): its
    calibration entry (name, curve, ids, gains, fit); written to `output` when given."""

def synthesize(
    map: TactileMap,
    count: int,
    *,
    seed: Optional[int] = None,  # 1
    subjects: Optional[int] = None,  # one per 40 samples
    size: Optional[_Size] = None,  # (68, 100)
    hand_fraction: float = 0.5,
    mask_labels: Literal["pressing", "as-imaged"] = "pressing",
    remove_up_to: Optional[float] = None,  # 0.01 to 0.95: Test B's removal, up to this fraction
    thinned_share: Optional[float] = None,  # 0.5; only with remove_up_to
    blind_spots: Optional[int] = None,  # 1 to 64: Test A's blind spots, up to this many
    blind_radius_mm: Optional[float] = None,  # 40.0; only with blind_spots
    blind_share: Optional[float] = None,  # 0.3; only with blind_spots
    small_objects: float = 0.0,  # share of non-hand samples that are small rigid prints (knob, rod)
    part: Optional[Tuple[int, int]] = None,  # (start, stop): only samples start..stop-1 of the count
) -> Dict[str, Any]:
    """In parallel, the GIL released; Ctrl-C raises KeyboardInterrupt within a sample."""
def export(
    inputs: Sequence[_Path],
    config: _Path,
    out: _Path,
    *,
    task: Optional[str] = None,  # "skin session"
    robot_type: Optional[str] = None,
    fps: Optional[int] = None,  # measured from the first input's stamps
    append: bool = False,
) -> Dict[str, Any]:
    """Logs or recordings as a LeRobot v3 dataset, an episode each, as `skin export` writes it."""
def export_bytes(
    name: _Path,
    data: bytes,
    config: _Path,
    out: _Path,
    *,
    task: Optional[str] = None,  # "skin session"
    robot_type: Optional[str] = None,
    fps: Optional[int] = None,
) -> Dict[str, Any]:
    """One log or recording held in memory as a new dataset of one episode; the GIL released."""
def read_grey(path: _Path) -> npt.NDArray[np.uint8]: ...

@final
class Dataset:
    """A dataset folder (labels.csv, images/, masks/) as `skin eval` reads it; what SynthDataset
    stands on. File names that leave the folder (absolute, .., links out) are refused."""

    def __new__(cls, root: _Path) -> "Dataset":
        """Reads `root/labels.csv`."""
    @property
    def entries(self) -> List[Tuple[str, bool, str, int, bool, bool]]:
        """(file, hand, kind, subject, partial, fingertips) per sample, in row order."""
    def image(self, i: int) -> npt.NDArray[np.uint8]: ...
    def mask(self, i: int) -> npt.NDArray[np.uint8]: ...
    def __len__(self) -> int: ...

@final
class TaskStack:
    """Joint velocities from a stack of tasks, highest priority first. `regularisation`:
    "activation_aware" (`lam`, `threshold`, `eta`), "damped" (`lam`) or "exact" (singular values
    under `tolerance` dropped; not for control)."""

    def __new__(
        cls,
        joints: int,
        *,
        regularisation: Literal["activation_aware", "damped", "exact"] = "activation_aware",
        lam: float = 0.05,
        threshold: float = 0.01,
        eta: float = 1.0,
        tolerance: float = 1e-9,
    ) -> "TaskStack": ...
    def solve(self, tasks: Sequence[Tuple[_Array, _Array, float]]) -> npt.NDArray[np.float64]: ...
