"""The work done for one recording of a batch, on whichever Dask worker runs it.

:func:`process_file` reads the file, runs the requested jobs and writes each output atomically
into the recording's result folder:

=============  =====================================================================
``fit``        ``fit.json``: the least-squares fit (:meth:`FitResult.to_json_dict`)
``sample``     ``posterior.nc`` (ArviZ DataTree), ``posterior.json``; the emcee
               checkpoint ``posterior.h5`` is kept, so a killed run resumes its chain
``diagnose``   ``diagnosis.json`` (a clear per-file error in a build without
               :mod:`bayes_emt.discovery`)
=============  =====================================================================

and, **last**, the completion marker ``done.json`` (also atomic). A folder is finished exactly
when its marker exists and matches the input's SHA-256 and the batch settings
(:func:`is_finished`); anything short of that is redone (the sampler resuming its checkpoint).
The marker is deleted before a folder's work starts, so a half-redone folder never looks
finished. A failure writes ``error.json`` with a one-line message and the traceback, and no
marker: a re-run tries that file again.

Only plain values cross the process boundary: the worker builds the model from its spec string
and returns a :class:`FileOutcome` of builtins.
"""

from __future__ import annotations

import json
import time
import traceback
import warnings
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from pathlib import Path

from .._atomic import atomic_write_text
from ..models.derived import derived_values
from .inputs import BatchInput, file_sha256

__all__ = ["JOBS", "MARKER", "ERROR_FILE", "BatchSettings", "FileOutcome", "process_file", "is_finished",
           "read_marker", "read_error", "DiagnoseUnavailable"]

JOBS = ("fit", "sample", "diagnose")
MARKER = "done.json"
ERROR_FILE = "error.json"


class DiagnoseUnavailable(RuntimeError):
    """The ``diagnose`` job needs :mod:`bayes_emt.discovery`, which this build does not have."""


@dataclass(frozen=True)
class BatchSettings:
    """What every recording of a batch is given (plain values: it is sent to the workers).

    Attributes
    ----------
    jobs : the jobs to run, a subset of :data:`JOBS` (``fit`` always runs: the others start from it).
    model : model spec (``UD``, ``NL+winding_capacitance``, ...).
    rings, n_turns : NL/UL ring count (None: default) and coil turns N.
    seed : sampler seed (the same for every file: each file's run is then reproducible alone).
    max_steps : sampler step budget per file.
    read_options : ``freq_unit``, ``phase_unit``, ``quantity`` for files that do not say.
    omega_min, omega_max : band kept [rad/s] (None: all).
    """

    jobs: tuple[str, ...] = ("fit",)
    model: str = "UD"
    rings: int | None = None
    n_turns: float = 480.0
    seed: int = 0
    max_steps: int = 20000
    read_options: tuple[tuple[str, str], ...] = ()
    omega_min: float | None = None
    omega_max: float | None = None

    def __post_init__(self):
        bad = [j for j in self.jobs if j not in JOBS]
        if bad or not self.jobs:
            raise ValueError(f"--jobs: unknown job {', '.join(bad) or '(none given)'}; "
                             f"choose from {', '.join(JOBS)}")
        if self.max_steps < 1:
            raise ValueError(f"--max-steps must be positive, got {self.max_steps}")
        self.build_model()  # an unknown model is a usage error now, not twenty file errors later

    def build_model(self):
        """The model named by ``model``, ``rings`` and ``n_turns``."""
        from ..models import parse_model_spec

        try:
            return parse_model_spec(self.model, rings=self.rings, n_turns=self.n_turns)
        except ValueError as exc:
            raise ValueError(f"--model {self.model}: {exc}") from None

    def identity(self) -> dict:
        """What a finished folder must have been made with to be reused (jobs compared apart)."""
        d = asdict(self)
        d.pop("jobs")
        d["read_options"] = [list(kv) for kv in self.read_options]
        return d


@dataclass(frozen=True)
class FileOutcome:
    """What became of one recording.

    Attributes
    ----------
    name : result folder name; ``file`` the input path.
    status : ``"done"``, ``"error"`` or ``"skipped"`` (finished by an earlier run).
    error : one-line message when ``status == "error"``.
    summary : headline numbers (see :func:`_summary`), each key carrying its unit.
    warnings : messages of warnings raised while processing (untrustworthy parts say so here).
    seconds : wall time on the worker [s].
    """

    name: str
    file: str
    status: str
    error: str = ""
    summary: dict = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    seconds: float = 0.0


def _read_json(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def read_marker(folder: Path) -> dict | None:
    """The completion marker of a result folder, or None."""
    return _read_json(Path(folder) / MARKER)


def read_error(folder: Path) -> dict | None:
    """The error record of a result folder, or None."""
    return _read_json(Path(folder) / ERROR_FILE)


def is_finished(inp: BatchInput, folder: Path, settings: BatchSettings) -> bool:
    """True when ``folder`` holds a completed run of ``settings``' jobs on these exact input bytes."""
    marker = read_marker(folder)
    if not marker:
        return False
    try:
        return (marker.get("sha256") == file_sha256(inp.path)
                and set(settings.jobs) <= set(marker.get("jobs", ()))
                and marker.get("settings") == settings.identity())
    except OSError:
        return False


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    msg = text[0] if text else ""
    return msg if isinstance(exc, (ValueError, FileNotFoundError, DiagnoseUnavailable)) and msg \
        else f"{type(exc).__name__}: {msg}" if msg else type(exc).__name__


def _unlink(path: Path) -> None:
    try:
        path.unlink()
    except FileNotFoundError:
        pass


def _summary(meas, fit, post=None) -> dict:
    p = fit.parameters
    out = {"points": int(meas.n_points), "f_min_hz": float(meas.f_hz[0]), "f_max_hz": float(meas.f_hz[-1]),
           "rms_rel_residual": float(fit.rms_rel_residual), "chi2": float(fit.chi2),
           "fit_success": bool(fit.success)}
    for name, key in (("zeta", "zeta"), ("omega0", "omega0_rad_s"), ("phi", "phi_N_per_A_sqrtkg"),
                      ("R0", "R0_ohm")):
        if name in p:
            out[key] = float(p[name])
    if "omega0" in p:
        out["f0_hz"] = derived_values(fit.model, fit.theta)["fs"]
    out.update(_ts_summary(fit, post))
    if post is not None:
        rows = post.summary_rows()
        out.update({"converged": bool(post.converged), "steps": int(post.n_steps),
                    "ess_min": float(min(r["ess"] for r in rows)),
                    "sample_seconds": float(post.wall_time)})
    return out


#: the T/S set in the summary: (name, summary key with its unit)
TS_KEYS = (("fs", "fs_hz"), ("Re", "Re_ohm"), ("Qms", "Qms"), ("Qes", "Qes"), ("Qts", "Qts"))


def _ts_summary(fit, post=None) -> dict:
    """The free-air T/S set (fs [Hz], Re [Ω], Qms, Qes, Qts) as ``fit``, ``sample`` and ``ts``
    print it: the posterior's medians and 90 % intervals when there is a posterior
    (:func:`~bayes_emt.thiele_small.from_posterior`), else the fit's Gaussian approximation
    (:func:`~bayes_emt.thiele_small.from_fit`). Flat keys for the table, ``ts`` with the intervals
    and units for the JSON, ``ts_from`` naming the source."""
    from ..thiele_small import from_fit, from_posterior

    try:
        ts = from_posterior(post) if post is not None else from_fit(fit)
    except (ValueError, KeyError, IndexError) as exc:  # a model without a mechanical resonance
        return {"ts_from": f"none ({exc})"}
    out = {"ts_from": "posterior" if post is not None else
           "fit" if ts.inputs.get("uncertainty") == "laplace" else "fit (no covariance)", "ts": {}}
    for name, key in TS_KEYS:
        p = ts.parameters.get(name)
        if p is not None:
            out[key] = float(p["value"])
            out["ts"][name] = {"value": float(p["value"]), "ci90": p["ci90"], "unit": p["unit"]}
    return out


def _diagnose(meas, model, folder: Path, settings) -> dict:
    try:
        from .. import discovery  # noqa: F401  (absent from builds without it)
        from ..discovery import diagnose
    except ImportError:
        raise DiagnoseUnavailable("diagnose is not available in this build (bayes_emt.discovery "
                                  "is not installed); run with --jobs fit,sample") from None
    from ..io.paramfile import write_json

    rec = diagnose(meas, model, seed=settings.seed).to_json_dict()
    write_json(folder / "diagnosis.json", rec)
    return rec


def _sample(meas, model, fit, folder: Path, settings: BatchSettings):
    from ..inference.sampling import sample_posterior
    from ..io.paramfile import write_json

    ckpt = folder / "posterior.h5"
    common = {"fit": fit, "seed": settings.seed, "max_steps": settings.max_steps, "checkpoint": ckpt,
              "progress": False}
    post = None
    if ckpt.exists():
        try:
            post = sample_posterior(meas, model, resume=True, **common)
        except (ValueError, OSError, KeyError):
            # a checkpoint cut before its header, or of other settings: our own file, start afresh
            post = None
    if post is None:
        post = sample_posterior(meas, model, overwrite=True, **common)
    post.save(folder / "posterior.nc")
    write_json(folder / "posterior.json", post.to_json_dict())
    return post


def process_file(inp: BatchInput, folder: str | Path, settings: BatchSettings) -> FileOutcome:
    """Run ``settings.jobs`` on one recording, outputs in ``folder`` (module docstring).

    Never raises for a problem with the recording: it comes back as ``status="error"`` with a
    one-line message (and ``error.json`` in the folder). Runs on a Dask worker: arguments and
    result are plain picklable values.
    """
    from ..estimation.fitting import fit_admittance
    from ..io import read_measurement
    from ..io.paramfile import write_json
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    _unlink(folder / MARKER)
    _unlink(folder / ERROR_FILE)
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            sha = file_sha256(inp.path)
            meas = read_measurement(inp.path, **dict(settings.read_options)).select(settings.omega_min,
                                                                                  settings.omega_max)
            model = settings.build_model()
            fit = fit_admittance(meas, model)
            write_json(folder / "fit.json", fit.to_json_dict())
            post = _sample(meas, model, fit, folder, settings) if "sample" in settings.jobs else None
            if "diagnose" in settings.jobs:
                _diagnose(meas, model, folder, settings)
            summary = _summary(meas, fit, post)
        except Exception as exc:  # noqa: BLE001 (one file's failure must not stop the batch)
            msg = _one_line(exc)
            notes = tuple(dict.fromkeys(str(w.message) for w in caught))
            atomic_write_text(folder / ERROR_FILE, json.dumps(
                {"file": str(inp.path), "error": msg, "type": type(exc).__name__, "warnings": list(notes),
                 "traceback": traceback.format_exc()}, indent=2))
            return FileOutcome(inp.name, str(inp.path), "error", error=msg, warnings=notes,
                               seconds=time.perf_counter() - t0)
    notes = tuple(dict.fromkeys(str(w.message) for w in caught))
    seconds = time.perf_counter() - t0
    marker = {"file": str(inp.path), "sha256": sha, "jobs": list(settings.jobs),
              "settings": settings.identity(),
              "finished_utc": datetime.now(UTC).isoformat(timespec="seconds"),
              "seconds": seconds, "summary": summary, "warnings": list(notes)}
    atomic_write_text(folder / MARKER, json.dumps(marker, indent=2))  # last: the folder is now finished
    return FileOutcome(inp.name, str(inp.path), "done", summary=summary, warnings=notes, seconds=seconds)
