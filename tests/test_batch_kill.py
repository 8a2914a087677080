"""Issue 15 acceptance 3: ``bayes-emt batch`` on 20 recordings (2 broken) is killed halfway with
SIGKILL (the whole process group: the command, its scheduler and its two worker processes), then
re-run with the same command: the re-run does only the unfinished files, the finished ones are
untouched, and the end state is 18 results and 2 clear errors."""

import os
import signal
import subprocess
import sys
import time

import pytest
from test_batch import make_recordings


def _markers(out):
    return {p.parent.name: p.read_bytes() for p in out.glob("*/done.json")}


def _command(data, out):
    return [sys.executable, "-m", "bayes_emt.cli", "batch", str(data), "--model", "I", "--jobs", "fit,sample",
            "--max-steps", "100", "--workers", "2", "--out", str(out), "--verbose"]


@pytest.mark.skipif(not hasattr(os, "killpg"), reason="needs POSIX process groups")
def test_killed_halfway_the_rerun_finishes_only_the_remaining_files(tmp_path):
    data = make_recordings(tmp_path / "data", 18)
    out = tmp_path / "out"
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MPLBACKEND": "Agg"}
    proc = subprocess.Popen(_command(data, out), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            env=env, start_new_session=True)
    deadline = time.monotonic() + 300
    try:
        while len(_markers(out)) < 4:
            assert proc.poll() is None, "the batch ended before it could be killed halfway"
            assert time.monotonic() < deadline, "no progress within 300 s"
            time.sleep(0.05)
        os.killpg(proc.pid, signal.SIGKILL)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=60)
    time.sleep(1.0)  # let anything the kill left behind settle before taking the snapshot
    before = _markers(out)
    assert 4 <= len(before) < 18, f"{len(before)} finished at the kill: not halfway"

    run = subprocess.run(_command(data, out), capture_output=True, text=True, env=env, timeout=600)
    assert run.returncode == 1, run.stderr[-2000:]  # 1: some recordings failed (the two broken ones)
    assert (f"20 recordings: 18 done ({len(before)} finished earlier, skipped), 2 failed, 0 not finished"
            in run.stdout), run.stdout
    # the re-run reported exactly the unfinished good files as done, and the broken ones as errors
    redone = {line.split(": done")[0] for line in run.stdout.splitlines() if ": done" in line}
    expected = {str(data / f"rec{i:02d}.zma") for i in range(18)} - {str(data / f"{n}.zma") for n in before}
    assert redone == expected
    assert run.stderr.count("bayes-emt: error:") == 2
    assert "broken_empty.zma: empty file" in run.stderr
    after = _markers(out)
    assert len(after) == 18
    for name, blob in before.items():
        assert after[name] == blob, f"{name} was redone although it had finished"
    for name in after:
        assert (out / name / "posterior.nc").exists()
