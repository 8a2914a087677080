"""Fault injection (issue 24): special files, full disks, two writers, signals, corrupted files.

Every case asserts one line on stderr (no traceback), the documented exit code, and that nothing
was lost: inputs unchanged, earlier outputs intact, a checkpoint resumable to the very chain of an
uninterrupted run. The processes are real (``python -m bayes_emt.cli``) where the fault is one
of processes (signals, concurrency, a crash inside HDF5).

A full disk is a 2 MiB tmpfs when this runs as root and ``mount`` works; otherwise a patched
writer raising ENOSPC (the tests say which they used by their skip/parametrisation).
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import random
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from bayes_emt._atomic import atomic_write_text
from bayes_emt.cli import main
from bayes_emt.errors import CheckpointError, DataFormatError, PriorConflictWarning
from bayes_emt.inference.checkpoint import CheckpointLock, checkpoint_steps
from bayes_emt.io import read_measurement
from bayes_emt.io.datasets import paper_bench_path

ROOT = Path(__file__).resolve().parent.parent
ROUND3 = Path(__file__).parent / "malformed" / "round3"
DATA = paper_bench_path()
# model I on the bundled data: about 1 s per 600 steps; at 600 steps it stops unconverged (exit 1)
SAMPLE = ["sample", str(DATA), "--model", "I", "--max-steps", "600", "--seed", "3", "--quiet"]


def _env():
    return {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONWARNINGS": "ignore"}


def _cli(args, cwd, **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "bayes_emt.cli", *args], cwd=cwd, env=_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _one_line(err: str) -> str:
    assert "Traceback" not in err and "emcee: Exception" not in err, err
    lines = [ln for ln in err.strip().splitlines() if ln.startswith("bayes-emt:")]
    assert len(lines) == 1, err
    return lines[0]


def _chain(path: Path) -> np.ndarray:
    with h5py.File(path, "r", locking=False) as f:
        return f["mcmc/chain"][...]


# ---- special files ---------------------------------------------------------------------------------
def test_fifo_is_refused_at_once(tmp_path, capsys):
    fifo = tmp_path / "sweep.zma"
    os.mkfifo(fifo)
    t0 = time.perf_counter()
    with pytest.raises(DataFormatError, match=r"sweep.zma: is a FIFO \(named pipe\), not a measurement file"):
        read_measurement(fifo)
    assert main(["info", str(fifo)]) == 2
    assert time.perf_counter() - t0 < 5  # never waits for a writer
    assert "is a FIFO" in _one_line(capsys.readouterr().err)


@pytest.mark.skipif(not Path("/dev/null").exists(), reason="no /dev/null")
def test_device_and_folder_are_refused(tmp_path):
    with pytest.raises(DataFormatError, match="/dev/null: is a character device"):
        read_measurement("/dev/null")
    with pytest.raises(DataFormatError, match="is a folder"):
        read_measurement(tmp_path)


# ---- the round-3 corpus: name -> (error fragment, or None for a file that reads, with its notice) ----
ROUND3_CORPUS = {
    "huge_frequency.zma": "huge_frequency.zma:4: frequency 1e+300 Hz is beyond any transducer's band",
    "tiny_magnitude.zma": "tiny_magnitude.zma:1: |Z| = 1e-320 ohm is outside 1e-09..1e+12 ohm",
    "huge_magnitude.zma": "huge_magnitude.zma:1: |Z| = 5e+15 ohm is outside 1e-09..1e+12 ohm",
    "spl_rew.txt": "a sound-pressure (SPL) frequency response, not an impedance",
    "spl_export.frd": "spl_export.frd: a .frd file: a sound-pressure (SPL) frequency response",
    "spl_header.csv": "spl_header.csv:1: header 'Frequency (Hz),SPL (dB),Phase (deg)': a sound-pressure",
}
ROUND3_READS = {  # name -> (points, notice fragment)
    "descending_sweep.zma": (8, "descending_sweep.zma:3: frequencies are not in increasing order; "
                                "sorted them"),
    "shuffled_rows.csv": (5, "shuffled_rows.csv:4: frequencies are not in increasing order; sorted them"),
    "duplicate_identical.zma": (4, "duplicate_identical.zma:3: repeats line 2 exactly (frequency 20); "
                                   "read once"),
}


def test_round3_corpus_is_complete():
    assert {p.name for p in ROUND3.iterdir()} == set(ROUND3_CORPUS) | set(ROUND3_READS)


@pytest.mark.parametrize("name", sorted(ROUND3_CORPUS))
def test_round3_file_gives_its_specific_message(name, capsys):
    with np.errstate(all="raise"), pytest.raises(DataFormatError) as exc:
        read_measurement(ROUND3 / name)
    msg = str(exc.value)
    assert ROUND3_CORPUS[name] in msg and "\n" not in msg and msg.startswith(str(ROUND3 / name))
    assert main(["info", str(ROUND3 / name)]) == 2
    cap = capsys.readouterr()
    assert ROUND3_CORPUS[name] in _one_line(cap.err)
    assert "overflow" not in cap.err and "RuntimeWarning" not in cap.err


@pytest.mark.parametrize("name", sorted(ROUND3_READS))
def test_round3_file_reads_sorted_with_a_notice(name):
    n, notice = ROUND3_READS[name]
    with pytest.warns(UserWarning, match="sorted them|read once"):
        m = read_measurement(ROUND3 / name)
    assert m.n_points == n and np.all(np.diff(m.omega) > 0)
    assert any(notice in x for x in m.meta["notices"])


def test_descending_sweep_equals_the_ascending_one(tmp_path):
    rows = [(f, 6 + f / 1e4, 10 - f / 1e3) for f in (20.0, 50.5, 100.25, 1000.0, 20000.0)]
    up, down = tmp_path / "up.zma", tmp_path / "down.zma"
    up.write_text("".join(f"{f} {m} {p}\n" for f, m, p in rows))
    down.write_text("".join(f"{f} {m} {p}\n" for f, m, p in reversed(rows)))
    a = read_measurement(up)
    with pytest.warns(UserWarning, match="sorted them"):
        b = read_measurement(down)
    np.testing.assert_array_equal(a.omega, b.omega)
    np.testing.assert_array_equal(a.Y, b.Y)


def test_duplicate_frequency_with_different_values_names_both_lines(tmp_path):
    p = tmp_path / "d.zma"
    p.write_text("10 5 3\n20 5 3\n40 5 2\n20 5.5 3\n")
    with pytest.raises(DataFormatError, match=r"d.zma:4: duplicate frequency 20 \(also on line 2\) with "
                                              "different values"):
        read_measurement(p)


# ---- atomic writes ---------------------------------------------------------------------------------
def test_atomic_write_enospc_names_the_target_and_keeps_the_old_file(tmp_path, monkeypatch):
    target = tmp_path / "out.json"
    target.write_text("previous")

    def full(self, *a, **k):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Path, "write_text", full)
    with pytest.raises(OSError) as exc:
        atomic_write_text(target, "new")
    monkeypatch.undo()
    msg = str(exc.value)
    assert msg.startswith(f"{target}: cannot write: No space left on device")
    assert exc.value.errno == errno.ENOSPC
    assert "(the previous out.json is unchanged)" in msg and ".out.json." not in msg
    assert target.read_text() == "previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.json"]  # the temporary is gone


def test_atomic_write_permission_error_names_the_target_not_the_temporary(tmp_path, monkeypatch):
    target = tmp_path / "run.nc"

    def denied(*a, dir=None, prefix="", suffix="", **k):
        raise PermissionError(errno.EACCES, "Permission denied", os.path.join(dir, f"{prefix}abc{suffix}"))

    monkeypatch.setattr(tempfile, "mkstemp", denied)
    with pytest.raises(PermissionError) as exc:
        atomic_write_text(target, "x")
    assert str(exc.value) == f"{target}: cannot write: Permission denied"


def test_fit_json_on_a_full_disk_names_the_file(tmp_path, monkeypatch, capsys):
    out = tmp_path / "fit.json"
    out.write_text("{}")
    real = os.replace

    def full(src, dst):
        if str(dst) == str(out):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(src, dst)

    monkeypatch.setattr(os, "replace", full)
    assert main(["fit", str(DATA), "--model", "I", "--quiet", "--json", str(out)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert f"{out}: cannot write: No space left on device" in line
    assert out.read_text() == "{}" and sorted(p.name for p in tmp_path.iterdir()) == ["fit.json"]


# ---- full disk under a real checkpoint -------------------------------------------------------------
@pytest.fixture
def small_disk(tmp_path):
    """A 2 MiB tmpfs (root and mount needed; else skipped: the patched-writer tests above cover it)."""
    mnt = tmp_path / "disk"
    mnt.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(mnt)], capture_output=True)
    if r.returncode != 0:
        pytest.skip(f"mount not allowed here: {r.stderr.decode().strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


@pytest.mark.parametrize("reserve", ["checked", "fallocate only"])
def test_checkpoint_on_a_full_disk_one_line_no_segfault(small_disk, tmp_path, reserve):
    """The checkpoint fills the tmpfs. 'fallocate only' disables the free-space estimate, so the
    posix_fallocate reservation is what stops HDF5 from writing into a full disk (h5py segfaulted
    there, exit -11)."""
    (small_disk / "filler").write_bytes(b"\0" * 1_400_000)
    earlier = small_disk / "earlier.json"
    earlier.write_text('{"kept": true}')
    ckpt = small_disk / "run.h5"
    script = ("import sys, shutil\n"
              "from bayes_emt.inference import checkpoint as ck\n"
              + ("ck.shutil = type('S', (), {'disk_usage': staticmethod(lambda p: type('U', (), "
                 "{'free': 10**12})())})\n" if reserve == "fallocate only" else "")
              + "from bayes_emt.cli import main\nsys.exit(main(sys.argv[1:]))\n")
    r = subprocess.run([sys.executable, "-c", script, *SAMPLE, "--out", str(tmp_path / "run.nc"),
                        "--checkpoint", str(ckpt), "--max-steps", "3000"], env=_env(), capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 2, (r.returncode, r.stderr[-2000:])
    line = _one_line(r.stderr)
    assert f"{ckpt}: no space left on the device" in line
    assert earlier.read_text() == '{"kept": true}'
    assert not (tmp_path / "run.nc").exists()
    left = sorted(p.name for p in small_disk.iterdir())
    assert left in (["earlier.json", "filler"], ["earlier.json", "filler", "run.h5"])
    if "run.h5" in left:  # blocks stored before the disk filled stay readable
        assert checkpoint_steps(ckpt) > 0


def test_sample_out_on_a_full_disk_names_it_and_keeps_the_previous(small_disk, tmp_path):
    """netCDF says only "NetCDF: HDF error" when the disk fills: the message names the output and
    says the disk is full; the previous output and the checkpoint (elsewhere) are intact."""
    (small_disk / "filler").write_bytes(b"\0" * 1_900_000)
    out = small_disk / "out.nc"
    out.write_text("previous")
    args = [*SAMPLE, "--max-steps", "300", "--out", str(out), "--checkpoint", str(tmp_path / "run.h5")]
    r = subprocess.run([sys.executable, "-m", "bayes_emt.cli", *args], env=_env(), capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 2, r.stderr[-3000:]
    line = _one_line(r.stderr)
    assert line.startswith(f"bayes-emt: error: {out}: cannot write: No space left on device")
    assert "(the previous out.nc is unchanged)" in line
    assert out.read_text() == "previous"
    assert sorted(p.name for p in small_disk.iterdir()) == ["filler", "out.nc"]
    assert checkpoint_steps(tmp_path / "run.h5") == 300


def test_library_write_error_on_a_full_disk_is_named(tmp_path, monkeypatch):
    import shutil
    from collections import namedtuple

    target = tmp_path / "post.nc"

    def netcdf_fails(self, *a, **k):
        raise RuntimeError("NetCDF: HDF error")

    monkeypatch.setattr(Path, "write_text", netcdf_fails)
    monkeypatch.setattr(shutil, "disk_usage", lambda p: namedtuple("U", "total used free")(1, 1, 1000))
    with pytest.raises(OSError) as exc:
        atomic_write_text(target, "x")
    assert exc.value.errno == errno.ENOSPC
    assert str(exc.value) == (f"{target}: cannot write: No space left on device (0.00 MB free; "
                              "NetCDF: HDF error)")


# ---- corrupted and truncated checkpoints -----------------------------------------------------------
@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("ref")
    p = _cli([*SAMPLE, "--out", "ref.nc"], cwd=d)
    out, err = p.communicate(timeout=300)
    assert p.returncode == 1, err  # 600 steps: stops unconverged, checkpoint complete
    return d


@pytest.mark.parametrize("damage", ["corrupted", "truncated"])
def test_damaged_checkpoint_resume_one_line_naming_it(finished_run, tmp_path, damage, capsys):
    ckpt = tmp_path / "run.h5"
    raw = bytearray((finished_run / "ref.h5").read_bytes())
    if damage == "corrupted":
        rng = random.Random(5)
        for i in rng.sample(range(len(raw) // 4, len(raw)), 2000):
            raw[i] ^= 0xFF
    else:
        raw = raw[: len(raw) // 2]
    ckpt.write_bytes(bytes(raw))
    before = _sha(ckpt)
    r = subprocess.run([sys.executable, "-m", "bayes_emt.cli", *SAMPLE, "--out", str(tmp_path / "run.nc"),
                        "--checkpoint", str(ckpt), "--resume"], env=_env(), capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 2, r.stderr[-2000:]
    line = _one_line(r.stderr)
    assert str(ckpt) in line and ("corrupted" in line or "truncated" in line), line
    assert _sha(ckpt) == before  # not made worse


def test_garbage_checkpoint_without_resume_is_refused(tmp_path, capsys):
    ckpt = tmp_path / "run.h5"
    ckpt.write_bytes(b"not an HDF5 file at all" * 100)
    assert main([*SAMPLE, "--out", str(tmp_path / "run.nc"), "--checkpoint", str(ckpt)]) == 2
    assert f"{ckpt}: a checkpoint exists" in _one_line(capsys.readouterr().err)
    assert ckpt.read_bytes().startswith(b"not an HDF5")


# ---- two writers -----------------------------------------------------------------------------------
def test_lock_refuses_a_second_holder_and_is_removed(tmp_path):
    ckpt = tmp_path / "run.h5"
    with CheckpointLock(ckpt) as lock:
        assert lock.lock_path.exists()
        with pytest.raises(CheckpointError, match=rf"{ckpt}: checkpoint in use by another run \(process "
                                                  rf"{os.getpid()}\)") as exc:
            CheckpointLock(ckpt).acquire()
        assert exc.value.errno == errno.EBUSY and "Errno" not in str(exc.value)
    assert not lock.lock_path.exists()
    CheckpointLock(ckpt).acquire().release()  # free again


def _two_runs(d: Path) -> None:
    a = _cli([*SAMPLE, "--out", "run.nc"], cwd=d)
    b = _cli([*SAMPLE, "--out", "run.nc"], cwd=d)
    (_, ea), (_, eb) = a.communicate(timeout=300), b.communicate(timeout=300)
    codes = sorted([a.returncode, b.returncode])
    assert codes == [1, 2], (codes, ea, eb)  # one ran (600 steps, unconverged: 1), one refused (2)
    refused = ea if a.returncode == 2 else eb
    line = _one_line(refused)
    assert "run.h5: checkpoint in use by another run" in line or "run.h5: a checkpoint exists" in line, line
    ran = ea if a.returncode == 1 else eb
    assert "Traceback" not in ran
    assert checkpoint_steps(d / "run.h5") == 600 and not (d / ".run.h5.lock").exists()


def test_two_concurrent_samples_one_is_refused(tmp_path):
    _two_runs(tmp_path)


@pytest.mark.slow
def test_two_concurrent_samples_20_of_20(tmp_path):
    for i in range(20):
        d = tmp_path / str(i)
        d.mkdir()
        _two_runs(d)


# ---- signals ---------------------------------------------------------------------------------------
def _interrupt_and_resume(d: Path, reference: np.ndarray, sig: int, delay: float) -> None:
    p = _cli([*SAMPLE, "--out", "run.nc"], cwd=d)
    t0 = time.perf_counter()
    while checkpoint_steps(d / "run.h5") in (None, 0) and p.poll() is None and time.perf_counter() - t0 < 120:
        time.sleep(0.02)
    time.sleep(delay)
    p.send_signal(sig)
    out, err = p.communicate(timeout=300)
    assert "emcee: Exception" not in out
    if p.returncode == 1:  # finished before the signal: nothing to check but the result
        np.testing.assert_array_equal(_chain(d / "run.h5"), reference)
        return
    assert p.returncode == 128 + sig, (p.returncode, err)
    line = _one_line(err)
    steps = checkpoint_steps(d / "run.h5")
    assert line == (f"bayes-emt: interrupted; checkpoint run.h5 is intact ({steps} steps stored), continue "
                    "with --resume"), line
    r = subprocess.run([sys.executable, "-m", "bayes_emt.cli", *SAMPLE, "--out", "run.nc", "--resume"], cwd=d,
                       env=_env(), capture_output=True, text=True, timeout=300)
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr
    np.testing.assert_array_equal(_chain(d / "run.h5"), reference)  # nothing lost, nothing different


def test_sigint_and_sigterm_then_resume_give_the_same_chain(finished_run, tmp_path):
    reference = _chain(finished_run / "ref.h5")
    for sig in (signal.SIGINT, signal.SIGTERM):
        d = tmp_path / sig.name
        d.mkdir()
        _interrupt_and_resume(d, reference, sig, 0.05)


@pytest.mark.slow
def test_signals_at_random_points_then_resume(finished_run, tmp_path):
    reference = _chain(finished_run / "ref.h5")
    rng = random.Random(24)
    for i in range(10):
        d = tmp_path / str(i)
        d.mkdir()
        _interrupt_and_resume(d, reference, rng.choice([signal.SIGINT, signal.SIGTERM]), rng.uniform(0, 0.6))


def test_signal_before_sampling_one_line(tmp_path):
    """A signal during the fit (before any step): one line, exit 130, no checkpoint left behind."""
    before = _sha(DATA)
    p = _cli(["sample", str(DATA), "--model", "NL", "--rings", "5", "--quiet", "--out", "run.nc"],
             cwd=tmp_path)
    time.sleep(3.0)
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=300)
    assert p.returncode == 130, err
    assert _one_line(err).startswith("bayes-emt: interrupted")
    assert not (tmp_path / "run.h5").exists() or checkpoint_steps(tmp_path / "run.h5") > 0
    assert _sha(DATA) == before


# ---- a prior far from the data ----------------------------------------------------------------------
def test_prior_far_from_the_data_is_named(tmp_path, capsys):
    pri = tmp_path / "far.toml"
    pri.write_text('[R0]\ndist = "lognormal"\nmedian = 5.0\nsigma_log = 0.02\n')
    # white noise: the figures below are that posterior's (the message is the same with the default)
    rc = main(["sample", str(DATA), "--model", "I", "--priors", str(pri), "--max-steps", "300", "--quiet",
               "--out", str(tmp_path / "r.nc"), "--json", str(tmp_path / "r.json"), "--noise", "white"])
    assert rc == 1  # 300 steps: not converged; the message leads with the cause
    cap = capsys.readouterr()
    named = (r"the posterior lies in the far tail of the prior of R0 \(posterior median 2.6\d ohm, "
             r"3\d.\d prior standard deviations below the prior's centre 5 ohm\)")
    assert re.search("NOT CONVERGED: " + named, cap.out), cap.out
    assert re.search("bayes-emt: warning: .*" + named, cap.err) and "Traceback" not in cap.err
    warns = json.loads((tmp_path / "r.json").read_text())["warnings"]
    coded = [w for w in warns if w["code"] == "prior_conflict"]
    assert len(coded) == 1 and coded[0]["parameters"] == ["R0"] and re.search(named, coded[0]["message"])


def test_prior_conflict_library_warning():
    from bayes_emt.inference.sampling import prior_conflicts
    from bayes_emt.params import ParamSet, ParamSpec
    from bayes_emt.params.priors import LogNormal, Uniform

    ps = ParamSet([ParamSpec("R0", "ohm", "R0", LogNormal(5.0, 0.02)),
                   ParamSpec("x", "1", "x", Uniform(0.0, 1.0))])
    draws = np.column_stack([np.full(100, 2.65), np.linspace(0.2, 0.8, 100)])
    (c,) = prior_conflicts(ps, draws)
    assert c["name"] == "R0" and "31.7 prior standard deviations below" in c["how"]
    draws[:, 1] = 0.9999  # piled against the upper bound
    assert [c["name"] for c in prior_conflicts(ps, draws)] == ["R0", "x"]
    draws[:, 0] = 5.2  # 1.96 SD: an ordinary value
    assert [c["name"] for c in prior_conflicts(ps, draws)] == ["x"]
    assert PriorConflictWarning.__mro__[1] is UserWarning
