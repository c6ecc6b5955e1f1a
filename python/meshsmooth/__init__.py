"""meshsmooth from Python: smooth a noisy triangle mesh held in numpy arrays, in this process or
through a meshsmoothd, with the same jobs, parameters and results as the `meshsmooth` CLI.

    import meshsmooth
    result = meshsmooth.smooth(vertices, faces)                  # the default job, in this process
    result = meshsmooth.smooth(vertices, faces, flow="taubin", iterations=20,
                               server="smooth.example.org:50051", tls_ca="ca.pem", token_file="token")
    result.vertices, result.attributes, result.summary

The jobs run in the C++ client library (the extension module _core): without `server` the job
runs in this process on the mesh in memory, as the CLI's local run does; with it, the mesh goes
to the service Draco-encoded, as the CLI's upload does. docs/python.md has a pipeline example.
"""

from __future__ import annotations

import dataclasses
import math
import os
from typing import Any, Callable, Dict, List, Literal, Mapping, Optional, Union

import numpy as np
import numpy.typing as npt

from . import _core
from ._open3d import smooth_open3d

__all__ = ["Error", "Progress", "Result", "Summary", "enhance", "smooth", "smooth_open3d"]

PathLike = Union[str, "os.PathLike[str]"]


class Error(Exception):
    """A job that failed, or a parameter it refused.

    `code` is the gRPC status code's name ("INVALID_ARGUMENT", "UNAVAILABLE", "CANCELLED",
    "DEADLINE_EXCEEDED", ...) and `message` its message, which names the parameter when one is
    wrong. A job run in this process fails with the codes and messages the service would send.
    """

    def __init__(self, code: str, message: str) -> None:
        super().__init__(f"{code}: {message}")
        self.code = code
        self.message = message


def _fields_of(cls: Any, d: Mapping[str, Any]) -> Any:
    """An instance of the dataclass `cls` from the dict of a protobuf message (None where absent)."""
    return cls(**{f.name: d.get(f.name) for f in dataclasses.fields(cls)})


@dataclasses.dataclass(frozen=True)
class Progress:
    """A job's progress (meshsmooth.v1.Progress): iterations done of `total`, the last
    iteration's largest and mean move (mesh units) and the share of vertices that moved, the
    seconds since smoothing started, the phase ("PROGRESS_PHASE_SMOOTHING", ...) and the flow."""

    iteration: int
    total: int
    max_displacement: float
    mean_displacement: float
    moved_share: float
    elapsed_seconds: float
    phase: str
    flow: str

    @classmethod
    def _from_dict(cls, d: Mapping[str, Any]) -> "Progress":
        return _fields_of(cls, d)


@dataclasses.dataclass(frozen=True)
class Summary:
    """A job's summary (meshsmooth.v1.Summary), as `meshsmooth smooth --json` prints it.

    `before` and `after` are the mesh's metrics (area, signed_volume, edge_length_mean, ...),
    `timings` the job's seconds by phase, `parameters` the parameters it ran with (its flow,
    iterations_requested, iterations_run, step, ..., stop_reason), `features` the ridge and
    ravine counts with ridges=True (else None); the displacements are in mesh units.
    """

    before: Dict[str, float]
    after: Dict[str, float]
    rms_displacement: float
    max_displacement: float
    flipped_normals: int
    timings: Dict[str, float]
    parameters: Dict[str, Any]
    result_bytes: int
    job_id: str
    features: Optional[Dict[str, Any]]
    warnings: List[str]
    vertices_at_bound: int

    @classmethod
    def _from_dict(cls, d: Mapping[str, Any]) -> "Summary":
        return _fields_of(cls, d)


@dataclasses.dataclass(frozen=True)
class Result:
    """A smoothed mesh: vertex i is vertex i of the input.

    `vertices` (N, 3) float64 in the input's coordinates: a vertex the job did not move is
    exactly as given; a moved one is the float32 the service computes, shifted back to the
    input's origin (survey coordinates keep their magnitude). `faces` (M, 3) int32, the input's
    but for faces naming a vertex that does not exist (left out, with a warning).
    `attributes` holds the input's per-vertex arrays as given (a flow moves positions only) but
    "normals", recomputed from the smoothed positions (0 for a vertex no face uses), and, with
    ridges=True, "ridge_labels"
    (uint8: 0 none, 1 ridge, 2 ravine). `warnings`: about the input and from the job, one
    sentence each.
    """

    vertices: npt.NDArray[np.float64]
    faces: npt.NDArray[np.int32]
    attributes: Dict[str, np.ndarray]
    summary: Summary
    warnings: List[str]


def _invalid(message: str) -> Error:
    return Error("INVALID_ARGUMENT", message)


def _iterations(value: Union[int, Literal["auto"]]) -> int:
    if value == "auto":
        return 0
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise _invalid(f"iterations must be 'auto' or a whole number >= 1, got {value!r}")
    return int(value)


def _length(name: str, value: Union[None, float, str]) -> str:
    """A length as the CLI's --max-displacement and --detail take it: "" (unset), "0.02" or "0.5h"."""
    if value is None:
        return ""
    if isinstance(value, str):
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)) or not math.isfinite(value) \
            or value < 0:
        raise _invalid(f"{name} must be None, a finite number >= 0 or a string such as '0.5h', got {value!r}")
    return repr(float(value))


def _per_vertex(name: str, array: Any, count: int) -> np.ndarray:
    a = np.asarray(array)
    if a.ndim == 0 or a.shape[0] != count:
        raise _invalid(f"{name}: one value (or row) per vertex is needed, {count} of them; got shape {a.shape}")
    return a


def smooth(vertices: npt.ArrayLike, faces: npt.ArrayLike, *,
           attributes: Optional[Mapping[str, npt.ArrayLike]] = None,
           strength: Optional[npt.ArrayLike] = None,
           flow: str = "auto",
           iterations: Union[int, Literal["auto"]] = "auto",
           step: float = 0.0,
           weights: Literal["u0", "u1"] = "u0",
           mu: float = 0.0,
           pass_band: float = 0.0,
           tangential_weight: Optional[float] = None,
           epsilon: float = 0.0,
           normal_iterations: int = 0,
           vertex_iterations: int = 0,
           sigma_spatial: float = 0.0,
           sigma_range: float = 0.0,
           adaptive: Literal["none", "constant", "ring1", "ring2"] = "none",
           threshold: float = 0.0,
           recompute_every: int = 10,
           boundary: Literal["auto", "fixed", "curve"] = "auto",
           tolerance: float = 0.0,
           max_displacement: Union[None, float, str] = None,
           ridges: bool = False,
           ridge_threshold: float = 0.0,
           job_id: Optional[str] = None,
           server: Optional[str] = None,
           tls_ca: Optional[PathLike] = None,
           token_file: Optional[PathLike] = None,
           timeout: float = 3600.0,
           retries: int = 4,
           progress: Optional[Callable[[Progress], None]] = None) -> Result:
    """Smooths the triangle mesh (`vertices`, (N, 3) float64; `faces`, (M, 3) vertex indices).

    The parameters are the CLI's `meshsmooth smooth` options by the same names and meanings
    (`meshsmooth smooth --help`, README): `flow` "auto" or a flow of `meshsmooth flows`;
    `iterations` "auto" (estimate the noise and stop where the estimated error is least) or a
    count; `step` 0 = the flow's default; `weights`, `mu`, `pass_band`, `tangential_weight`
    (None = the default), `epsilon`, `normal_iterations`, `vertex_iterations`, `sigma_spatial`,
    `sigma_range`, `adaptive`, `threshold`, `recompute_every`, `boundary`, `tolerance`;
    `max_displacement` None, D (mesh units) or "Dh" (D mean edge lengths, e.g. "0.5h"); `ridges`
    and `ridge_threshold`; `job_id`.

    `attributes`: per-vertex arrays (colours, normals under "normals", anything else) that come
    back in Result.attributes. `strength`: one value in [0, 1] per vertex (0 = the vertex does not
    move, 1 = the flow as it is, between = its moves scaled), as the CLI's --weight/--region give.

    Without `server` the job runs in this process. With it, through that meshsmoothd (any gRPC
    target the CLI's --server takes), over TLS when `tls_ca` names a PEM file of CA
    certificates, with the bearer token in `token_file`; `timeout` seconds for the call, retries
    included; `retries` of a call refused with UNAVAILABLE (or RESOURCE_EXHAUSTED for the
    server's capacity) before any result came.

    `progress` is called with a Progress on the calling thread while the job runs. The GIL is
    released meanwhile; Ctrl-C (KeyboardInterrupt), or an exception from `progress`, cancels the
    job (on the server too) and is raised once it has stopped.

    Raises Error (code and message) when a parameter is wrong or the job fails.
    """
    params = dict(flow=flow, iterations=_iterations(iterations), step=step, weights=weights, mu=mu,
                  pass_band=pass_band, tangential_weight=-1.0 if tangential_weight is None else tangential_weight,
                  epsilon=epsilon, normal_iterations=normal_iterations, vertex_iterations=vertex_iterations,
                  sigma_spatial=sigma_spatial, sigma_range=sigma_range, adaptive=adaptive, threshold=threshold,
                  recompute_every=recompute_every, boundary=boundary, tolerance=tolerance,
                  max_displacement=_length("max_displacement", max_displacement), ridges=ridges,
                  ridge_threshold=ridge_threshold, job_id=job_id or "")
    return _run(vertices, faces, attributes, strength, params, server, tls_ca, token_file, timeout, retries,
                progress)


def _run(vertices: npt.ArrayLike, faces: npt.ArrayLike, attributes: Optional[Mapping[str, npt.ArrayLike]],
         strength: Optional[npt.ArrayLike], params: Dict[str, Any], server: Optional[str],
         tls_ca: Optional[PathLike], token_file: Optional[PathLike], timeout: float, retries: int,
         progress: Optional[Callable[[Progress], None]]) -> Result:
    """One job (smooth() or enhance()) in this process or through `server`."""
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    n = v.shape[0] if v.ndim == 2 else -1
    given = {name: _per_vertex(f"attributes[{name!r}]", a, n) for name, a in (attributes or {}).items()}
    connection = dict(server=server or "", tls_ca=os.fspath(tls_ca) if tls_ca else "",
                      token_file=os.fspath(token_file) if token_file else "", timeout=timeout, retries=retries)
    on_progress = None if progress is None else (lambda p: progress(Progress._from_dict(p)))
    try:
        raw = _core.smooth(v, f, params, connection, strength, given.get("normals"), on_progress)
    except _core.StatusError as e:
        raise Error(*e.args) from None
    out = {name: np.array(a, copy=True) for name, a in given.items() if name != "normals"}
    for name in ("normals", "ridge_labels"):
        if name in raw:
            out[name] = raw[name]
    return Result(vertices=raw["vertices"], faces=raw["faces"], attributes=out,
                  summary=Summary._from_dict(raw["summary"]), warnings=list(raw["warnings"]))


def enhance(vertices: npt.ArrayLike, faces: npt.ArrayLike, *,
            attributes: Optional[Mapping[str, npt.ArrayLike]] = None,
            strength: Optional[npt.ArrayLike] = None,
            gain: float = 2.0,
            detail: Union[None, float, str] = None,
            smooth_first: bool = False,
            method: Literal["poisson", "inverted-flow"] = "poisson",
            ridges: bool = False,
            ridge_threshold: float = 0.0,
            job_id: Optional[str] = None,
            server: Optional[str] = None,
            tls_ca: Optional[PathLike] = None,
            token_file: Optional[PathLike] = None,
            timeout: float = 3600.0,
            retries: int = 4,
            progress: Optional[Callable[[Progress], None]] = None) -> Result:
    """Enhances the mesh's detail, the inverse of smoothing, as `meshsmooth enhance` does (a job
    with JobSpec.enhance): waves along the surface shorter than `detail` grow by `gain` (in
    (1, 100]), longer ones stay (screened-Poisson sharpening, stable for any gain); boundary
    vertices stay, a closed mesh keeps its volume; `method` "inverted-flow" runs the paper's
    inverted umbrella flow with eq. (14)'s bound instead (`meshsmooth enhance --help`). `detail` None (8 mean edge lengths), D (mesh
    units) or "Dh" (D mean edge lengths, e.g. "8h"). A noisy input (one the default job would
    smooth) raises Error FAILED_PRECONDITION naming its noise, unless `smooth_first`: then the
    default job smooths it first. `attributes`, `strength` (0 = the vertex does not move), the
    connection and `progress` as for smooth(); Result.summary.parameters["enhance"] says what ran.
    """
    return _run(vertices, faces, attributes, strength,
                dict(flow="", enhance=True, gain=gain, detail=_length("detail", detail),
                     smooth_first=smooth_first, method=method, ridges=ridges, ridge_threshold=ridge_threshold,
                     job_id=job_id or ""),
                server, tls_ca, token_file, timeout, retries, progress)
