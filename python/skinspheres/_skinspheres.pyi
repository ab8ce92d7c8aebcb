"""Types of the native module (python/src/module.cc); skinspheres re-exports every public name."""

import os
from typing import Any, NamedTuple, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str

# Structured dtypes. kind: TOUCHING / PENETRATING (part pairs), INTERSECTING / WITHIN_MARGIN
# (triangle pairs). Part indices are into part_names; triangle indices are the source file's.
SPHERE_PAIR_DTYPE: np.dtype  # sphere_i, sphere_j (u4, sphere_i < sphere_j), depth (f4), part_i, part_j (u2)
PART_CONTACT_DTYPE: np.dtype  # part_a, part_b (u2), kind (u4), depth, min_distance (f4), normal, center ((3,) f4),
#                               triangle_pairs, intersecting, sphere_pairs, first_triangle_pair (u4)
TRIANGLE_CONTACT_DTYPE: np.dtype  # part_contact, triangle_a, triangle_b, kind (u4), distance (f4),
#                                   point, on_a, on_b ((3,) f4)
FRAME_SPHERE_PAIR_DTYPE: np.dtype  # frame (u4), then SPHERE_PAIR_DTYPE's fields
FRAME_PART_CONTACT_DTYPE: np.dtype  # frame (u4), then PART_CONTACT_DTYPE's fields
FRAME_TRIANGLE_CONTACT_DTYPE: np.dtype  # frame (u4), then TRIANGLE_CONTACT_DTYPE's fields
TOUCHING: int
PENETRATING: int
INTERSECTING: int
WITHIN_MARGIN: int
DEFAULT_TOUCH_TOLERANCE: float

FloatArray = npt.NDArray[Union[np.float32, np.float64]]
# Paths: str, UTF-8 bytes or os.PathLike (ValueError for a NUL byte or bytes that are not UTF-8).
Path = Union[str, bytes, os.PathLike]

class Error(Exception):
    """A failed call: str(e) is the one-line message, e.code its kind ("file not found", ...)."""

    code: str

class FileNotFound(Error, FileNotFoundError): ...
class FileUnreadable(Error, OSError): ...
class FormatRejected(Error, ValueError): ...
class InvalidData(Error, ValueError): ...
class VersionMismatch(Error, ValueError): ...
class MismatchedAsset(Error, ValueError): ...
class InvalidArgument(Error, ValueError): ...
class NotFound(Error, LookupError): ...
class CheckFailed(Error, RuntimeError): ...

class Contacts(NamedTuple):
    parts: np.ndarray  # PART_CONTACT_DTYPE, sorted by (part_a, part_b)
    triangles: np.ndarray  # TRIANGLE_CONTACT_DTYPE, grouped by part pair (part_contact)

class SphereSet:
    """A fitted sphere set (rest pose). Arrays are copies the caller owns."""

    def __len__(self) -> int: ...
    def save(self, path: Path, *, fast_only: bool = False) -> None:
        """.json (JSON) or .ssb (binary); fast_only (.ssb only) leaves out the mesh."""
    @property
    def centers(self) -> npt.NDArray[np.float32]: ...  # (S, 3)
    @property
    def radii(self) -> npt.NDArray[np.float32]: ...  # (S,)
    @property
    def radii_fast(self) -> npt.NDArray[np.float32]: ...  # (S,) the fast refit's radii at rest
    @property
    def sphere_part(self) -> npt.NDArray[np.uint16]: ...  # (S,) index into part_names
    @property
    def sphere_joint(self) -> npt.NDArray[np.uint16]: ...  # (S,) dominant joint, index into joint_names
    def sphere_joints(self, sphere: int) -> tuple[npt.NDArray[np.uint16], npt.NDArray[np.float32]]:
        """The joints that move the sphere, and their weights (summing to 1)."""
    @property
    def part_names(self) -> list[str]: ...
    @property
    def joint_names(self) -> list[str]: ...
    @property
    def joint_parents(self) -> npt.NDArray[np.int32]: ...  # -1 for roots
    @property
    def joint_rest_world(self) -> npt.NDArray[np.float32]: ...  # (J, 4, 4)
    @property
    def contact_rules(self) -> str:
        """Which triangle pairs are contacts ("triangles"; "sphere_pairs" for a set written before them).

        On triangles, two triangles that intersect (or come within the margin) are a contact unless
        they share a vertex (by rest position), their joints (each triangle's joint: the one its three
        vertices weigh most in sum) are at most contact_hops bones apart in the skin's joint tree, or
        they intersect or lie closer than rest_gap (model units) in the rest pose; a triangle with no
        area in the frame is never one. The same pairs whatever the fit. On sphere pairs (older files), the pairs excluded_pairs names are never
        tested (overlapping at rest among them): what such a set reports depends on its fit.
        runtime/narrow_phase/contact_rules.h states the rules for C++; skinspheres.h for C."""
    @property
    def contact_hops(self) -> int: ...  # rule 2: 0, 1 (default) or 2 bones; 0 with rules on sphere pairs
    @property
    def rest_gap(self) -> float: ...  # rule 3, model units (fit's rest_gap times the rest height); 0 on sphere pairs
    @property
    def excluded_pairs(self) -> npt.NDArray[np.uint32]: ...  # (E, 2): sphere pairs never reported (rule 2 whole)
    @property
    def excluded_reasons(self) -> list[str]: ...  # "same_joint", "adjacent_joints" ("bind_overlap": older sets)
    @property
    def vertex_count(self) -> int: ...
    @property
    def triangle_count(self) -> int: ...
    @property
    def triangles(self) -> npt.NDArray[np.uint32]: ...  # (T, 3) vertex indices (empty without mesh)
    @property
    def mesh(self) -> dict[str, np.ndarray]:
        """The skinned mesh the set carries: positions_bind (V, 3), bind_joints (B,), inverse_binds
        (B, 4, 4), influence_offsets (V + 1,), influence_binds, influence_weights (CSR)."""
    @property
    def has_mesh(self) -> bool: ...
    @property
    def fast_only(self) -> bool: ...
    @property
    def source_file(self) -> str: ...
    @property
    def loaded_from(self) -> str: ...
    @property
    def fit_report(self) -> dict[str, Any]: ...  # fit(): seconds, body_height, standoff_before/after, split_rounds, ...

class Asset:
    """A sphere set ready for the runtime; immutable; shared by its instances (any thread)."""

    def __init__(self, sphere_set: SphereSet, *, margin: float = 0.0, touch_tolerance: float = ...) -> None:
        """margin: also report triangle pairs nearer than this (set units). touch_tolerance: part pairs
        intersecting deeper than this share of the rest height penetrate, the others touch."""
    def instance(self, joint_names: Optional[Sequence[str]] = None) -> Instance: ...
    def check(self, joint_names: Sequence[str], vertex_count: int) -> None:
        """Raises MismatchedAsset unless the set was fitted on this character."""
    def fix_pose(
        self, locals: npt.ArrayLike, *, max_depth: float = 0.0
    ) -> tuple[npt.NDArray[np.float32], dict[str, Any]]:
        """The pose corrected so that no part pair penetrates deeper than max_depth (the set's
        units; 0: the touch tolerance), turning as few joints as little as it can. locals: (J, 10)
        per joint of the set, translation xyz, rotation quaternion xyzw, scale xyz. Returns the fixed
        pose (rotations changed) and {"holds", "steps", "deepest_before", "deepest_after"}. Creates
        a fixer per call (milliseconds); the C and C++ APIs keep one."""
    @property
    def sphere_set(self) -> SphereSet: ...
    @property
    def part_names(self) -> list[str]: ...
    @property
    def joint_names(self) -> list[str]: ...
    @property
    def joints_read(self) -> npt.NDArray[np.bool_]: ...  # per set joint: read every frame
    @property
    def sphere_count(self) -> int: ...
    @property
    def vertex_count(self) -> int: ...
    @property
    def has_contacts(self) -> bool: ...  # holds its mesh: contacts() works
    @property
    def margin(self) -> float: ...
    @property
    def touch_tolerance(self) -> float: ...  # set units

class Instance:
    """One character's per-frame state. One thread at a time (a second raises ValueError)."""

    def __init__(self, asset: Asset, joint_names: Optional[Sequence[str]] = None) -> None: ...
    def update_fast(self, world: FloatArray) -> None:
        """world: (J, 4, 4), J >= joint_count, in joint_names' order; world[j] @ [x, y, z, 1]."""
    def update_exact(self, positions: FloatArray, world: Optional[FloatArray] = None) -> None:
        """positions: (V, 3) skinned vertices, V >= the set's vertex_count; world as update_fast, or None."""
    def sphere_pairs(self) -> np.ndarray:
        """The overlapping sphere pairs (SPHERE_PAIR_DTYPE), sorted by (sphere_i, sphere_j)."""
    def contacts(self, positions: Optional[FloatArray] = None) -> Contacts:
        """The triangles that touch, behind the sphere pairs. positions: the skinned vertices the
        spheres came from (exact mode), or None: the instance skins what it tests."""
    @property
    def spheres(self) -> npt.NDArray[np.float32]: ...  # (S, 4): x, y, z, radius
    @property
    def asset(self) -> Asset: ...
    @property
    def joint_count(self) -> int: ...
    @property
    def extra_joints(self) -> list[str]: ...  # the engine's joints the set does not list
    @property
    def unmapped_joints(self) -> list[str]: ...  # the set's joints the engine's list lacks (never read)

def fit(
    path: Optional[Path] = None,
    *,
    parts: str = "",
    rays: int = 80,
    per_level: int = 2,
    method: str = "m1a",
    overlap: float = 0.3,
    step: float = 0.02,
    hops: int = 1,
    refine: int = 2,
    tighten: bool = True,
    split_gain: float = 0.9,
    split_rounds: int = 8,
    target_standoff: float = 0.0125,
    max_spheres: int = 200,
    rest_gap: float = 0.01,  # rule 3 (contact_rules): a share of the rest height, at most 0.05
    piece_edge: float = 0.0,
    group_blends: bool = True,
) -> SphereSet:
    """Fits a character file (glTF, GLB, FBX, ...; None: the built-in character), as `skinspheres fit`."""

def load(path: Path) -> SphereSet:
    """Reads a sphere set, .ssb or .json (told apart by content)."""

def clip_names(path: Path) -> list[str]:
    """The clips a file holds (a character or an animation-only file), in its order."""

def play(
    character: Optional[Path] = None,
    clip_file: Optional[Path] = None,
    *,
    clip: Union[int, str] = 0,
    fps: float = 30.0,
    mode: str = "exact",
    frames: int = 0,  # 0: the whole clip; at most 1,000,000
    spheres: Optional[Path] = None,
    margin: float = 0.0,
    touch_tolerance: float = ...,
    joint_map: str = "",
    source_rest: str = "",
    retarget: str = "auto",
) -> dict[str, Any]:
    """Every frame of one clip, as `skinspheres play` (fitting on the fly unless spheres= names a
    set). clip_file: an animation file retargeted onto the character (clip then counts its clips).
    Returns clip, frames, times, clip_times, sphere_pairs (FRAME_SPHERE_PAIR_DTYPE), part_contacts
    (FRAME_PART_CONTACT_DTYPE; first_triangle_pair indexes triangle_contacts), triangle_contacts
    (FRAME_TRIANGLE_CONTACT_DTYPE; part_contact indexes part_contacts), part_names, body_height,
    touch_tolerance (set units), notes (what the retarget did)."""

def retarget(
    character: Path,
    clip_files: Sequence[Path],
    output: Path,
    *,
    clip: str = "all",
    fps: float = 30.0,
    joint_map: str = "",
    source_rest: str = "",
    retarget: str = "auto",
    rest_directions: str = "keep",
) -> dict[str, Any]:
    """`skinspheres retarget`: writes `output` (.glb), the character with the clips of clip_files
    retargeted onto it, one LINEAR key per frame at fps for every joint. Returns {"output", "clips"
    (names), "durations" (seconds, float32 array), "frames" (keys per joint, summed), "joints",
    "notes" (what retargeting did, as the tool prints it)}. Raises as the tool refuses (exit 2)."""

def fix(
    character: Path,
    output: Path,
    clip_files: Sequence[Path] = ...,
    *,
    clip: str = "all",
    max_depth: float = ...,
    allow: Sequence[str] = ...,
    spheres: Optional[Path] = None,
    fps: float = 30.0,
    ease: float = 0.2,
    max_rotation: float = 60.0,
    max_jerk_ratio: float = 1.5,
    jobs: int = 0,
    joint_map: str = "",
    source_rest: str = "",
    retarget: str = "auto",
) -> dict[str, Any]:
    """`skinspheres fix`: the clips changed as little as possible so that no part pair penetrates
    deeper than max_depth (a share of the body height), the clips that hold written to `output`
    (.glb). Returns the report its --report writes (format "skinspheres.fix"), plus exit_code (0
    every clip holds, 1 some clip could not be fixed and was not written). Raises as the tool
    refuses (exit 2)."""

def colliders(
    character: Path,
    clip_files: Sequence[Path] = ...,
    *,
    budget: int = 32,
    shapes: str = "auto",
    format: str = "json",
    output: Optional[Path] = None,
    report: Optional[Path] = None,
    clip: str = "all",
    fps: float = 30.0,
    tolerance: float = 0.01,
    fit_poses: int = 64,
    compare: bool = False,
    joint_map: str = "",
    source_rest: str = "",
    retarget: str = "auto",
) -> dict[str, Any]:
    """`skinspheres colliders`: at most `budget` spheres and capsules on joints covering the body
    over the clips' poses. Returns the report its --report writes (format "skinspheres.colliders"),
    exit_code, and the shapes as arrays: "joint" (N,) uint32, "head" and "tail" (N, 3) float32 in
    each joint's rigid frame (its world rotation and translation, model units), "head_radius" and
    "tail_radius" (N,), "part", "joint_names", "joint_rest_world" (J, 4, 4). With `output`, also
    written in `format` (vrm1, vrm0, godot, unity, usd, json). Raises as the tool refuses (exit 2)."""

def check(
    character: Path,
    clip_files: Sequence[Path] = ...,
    *,
    clip: str = "all",
    max_depth: float = 0.01,
    touch_tolerance: float = ...,
    spheres: Optional[Path] = None,
    fps: float = 30.0,
    mode: str = "exact",
    jobs: int = 0,
    joint_map: str = "",
    source_rest: str = "",
    retarget: str = "auto",
    compare_source: bool = False,
) -> dict[str, Any]:
    """`skinspheres check`: the report its --report writes (format "skinspheres.check"), plus
    exit_code (0 clean, 1 some clip deeper than max_depth, 2 some file could not be read)."""
