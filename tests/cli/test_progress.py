"""Progress a user sees on stderr without a terminal (logs, CI, job schedulers): a line
per finished input, a line every so often while one step runs long, nothing with
--quiet (docs: liff.cli.progress)."""

from __future__ import annotations

import re
import time

import numpy as np
import pytest

from liff import synthetic
from liff.cli import main, progress


@pytest.fixture
def two_inputs(tmp_path):
    paths = []
    for i in range(2):
        path = tmp_path / f"scene{i}.npy"
        np.save(path, synthetic.textured_plane((3, 3, 64, 80), 0.5 + i, seed=i))
        paths.append(str(path))
    return paths


def test_a_log_gets_a_line_per_finished_input(tmp_path, capsys, two_inputs):
    assert main(["detect", *two_inputs, "--out", str(tmp_path / "out")]) == 0
    err = capsys.readouterr().err
    assert "liff detect: 1/2 file(s) done" in err and "liff detect: 2/2 file(s) done" in err


def test_quiet_prints_no_progress_but_still_the_errors(tmp_path, capsys, two_inputs):
    missing = str(tmp_path / "missing.npy")
    assert main(["detect", *two_inputs, missing, "--out", str(tmp_path / "out"), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "file(s) done" not in err
    assert f"liff detect: {missing}" in err


def test_a_long_item_or_step_says_it_is_still_working(monkeypatch, capsys):
    monkeypatch.setattr(progress, "HEARTBEAT_SECONDS", 0.2)
    with progress.progress(desc="liff sfm: pairs matched", total=3, unit="pair") as bar:
        time.sleep(0.7)
        bar.update()
    with progress.step("liff sfm: incremental mapping"):
        time.sleep(0.7)
    err = capsys.readouterr().err
    assert "liff sfm: pairs matched: 0/3 pair(s) done" in err and "still working" in err
    assert "liff sfm: incremental mapping: still running" in err
    assert "liff sfm: incremental mapping: done in" in err


def test_units_other_than_files_print_at_most_one_line_a_while(monkeypatch, capsys):
    monkeypatch.setattr(progress, "LINE_SECONDS", 3600.0)
    for _ in progress.progress(range(100), desc="liff synth", unit="pose"):
        pass
    lines = [line for line in capsys.readouterr().err.splitlines() if "pose(s) done" in line]
    assert lines == ["liff synth: 100/100 pose(s) done, 0 s"]


def test_liff_progress_forces_the_bar(monkeypatch):
    from tqdm import tqdm

    monkeypatch.setenv("LIFF_PROGRESS", "1")
    bar = progress.progress(desc="x", total=1)
    assert isinstance(bar, tqdm) and not bar.disable
    bar.close()
    monkeypatch.delenv("LIFF_PROGRESS")
    assert isinstance(progress.progress(desc="x", total=1), progress.LineProgress)


def test_a_finished_inputs_line_names_it(tmp_path, capsys, two_inputs):
    """Break test: 'liff detect: 1/2 file(s) done, 0 s' did not say which input had
    finished (with --workers the order is not the command line's)."""
    for workers in ("1", "2"):
        assert main(["detect", *two_inputs, "--out", str(tmp_path / f"out{workers}"),
                     "--workers", workers]) == 0
        lines = [line for line in capsys.readouterr().err.splitlines() if "file(s) done" in line]
        named = [re.search(r"liff detect: (\d)/2 file\(s\) done, last (\S+), \d+ s$", line)
                 for line in lines]
        assert all(named) and [m.group(1) for m in named] == ["1", "2"]
        assert sorted(m.group(2) for m in named) == sorted(two_inputs)


def test_a_failed_input_is_counted_apart_not_done(tmp_path, capsys, two_inputs):
    """Break test 5: 'liff detect: 1/4 file(s) done, 1 s' counted a failed input done;
    the progress lines count it apart ('1 failed'); its error line names it (once)."""
    broken = tmp_path / "broken.npy"
    broken.write_bytes(b"not numpy")
    for workers in ("1", "2"):
        assert main(["detect", str(broken), *two_inputs, "--out", str(tmp_path / f"out{workers}"),
                     "--workers", workers]) == 1
        err = capsys.readouterr().err
        lines = [line for line in err.splitlines() if "file(s) done" in line]
        assert len(lines) == 3 and lines[-1].startswith("liff detect: 2/3 file(s) done, last ")
        assert lines[-1].endswith(" s") and ", 1 failed, " in lines[-1]
        failing = next(line for line in lines if ", 1 failed, " in line)
        done = int(re.match(r"liff detect: (\d)/3 file\(s\) done", failing).group(1))
        assert done == lines.index(failing)  # the failed input is not counted done
        assert err.count(str(broken)) == 1 and f"liff detect: {broken}: " in err


def test_a_batch_that_raises_leaves_no_heartbeat_behind(monkeypatch):
    """A run that ends in an error nobody catches (or Ctrl-C) closes its progress line:
    an open one kept printing "still working" from its thread for the life of the
    process (seen in a later test's output)."""
    import threading

    from liff import _processes
    from liff._progress import HEARTBEAT_THREAD

    monkeypatch.delenv("LIFF_PROGRESS", raising=False)

    def fails(x):
        raise RuntimeError(f"job {x} broke")

    def heartbeats():
        return [t for t in threading.enumerate() if t.name == HEARTBEAT_THREAD]

    before = len(heartbeats())
    with pytest.raises(RuntimeError, match="job 0 broke"):
        _processes.run_batch(fails, [(0,), (1,)], 1, "test", label=lambda job: str(job[0]))
    assert len(heartbeats()) == before
