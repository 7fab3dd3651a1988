"""Issue 14: batches on Dask (liff.batch, liff detect --scheduler) that survive faults,
with inputs from folders, globs and lists, a manifest per run, and each task held to
its worker's threads and memory."""

from __future__ import annotations

import csv
import os
import signal
import socket
import subprocess
import sys
import time

import numpy as np
import pytest

import liff
from liff import batch
from liff.cli import main
from liff.feature_file import load_features

distributed = pytest.importorskip("distributed", reason="pip install 'liff[dask]'")
dask = pytest.importorskip("dask")


def write_light_fields(folder, count, shape=(3, 3, 64, 64), prefix="lf"):
    """``count`` different small light fields (layers scenes of different seeds), .npy."""
    os.makedirs(folder, exist_ok=True)
    paths = []
    for i in range(count):
        lf = liff.synthetic.textured_layers(shape, seed=i, noise_variance=0).light_field
        paths.append(os.path.join(folder, f"{prefix}{i:02d}.npy"))
        np.save(paths[-1], lf)
    return paths


def read_manifest(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def cluster():
    """An in-process LocalCluster of two one-thread workers."""
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=":0") as local, distributed.Client(local) as client:
        yield client


def test_local_cluster_batch_equals_the_api_and_reports_failures(cluster, tmp_path):
    paths = write_light_fields(tmp_path / "in", 3)
    damaged = tmp_path / "in" / "damaged.npy"
    damaged.write_bytes(b"\x93NUMPY not really")
    outcomes = batch.detect([str(tmp_path / "in")], str(tmp_path / "out"), client=cluster,
                            manifest=str(tmp_path / "m.csv"), contrastThreshold=0.02)
    assert [o.status for o in outcomes] == ["failed", "done", "done", "done"]  # sorted names
    assert "damaged.npy" in outcomes[0].error
    for path, outcome in zip(paths, outcomes[1:]):
        features = load_features(outcome.output)
        expected = liff.LiFF.create(contrastThreshold=0.02).detect(np.load(path))
        assert len(features.keypoints) == outcome.features == len(expected)
        assert outcome.worker.startswith(("tcp://", "inproc://"))
    rows = read_manifest(tmp_path / "m.csv")
    assert list(rows[0]) == ["input", "output", "status", "features", "first_slope",
                             "last_slope", "searched", "built", "slopes_from", "seconds",
                             "cpu_seconds", "error", "worker", "notes", "format", "reader_options"]
    assert [r["format"] for r in rows] == ["npy"] * 4 and rows[1]["reader_options"] == ""
    assert [r["status"] for r in rows] == ["failed", "done", "done", "done"]
    assert rows[1]["slopes_from"] == "automatic" and float(rows[1]["seconds"]) > 0
    assert float(rows[1]["first_slope"]) <= float(rows[1]["last_slope"])
    assert int(rows[1]["built"]) >= int(rows[1]["searched"]) >= 1
    # A re-run does only what is missing.
    os.remove(outcomes[2].output)
    again = batch.detect([str(tmp_path / "in")], str(tmp_path / "out"), client=cluster,
                         contrastThreshold=0.02)
    assert sorted(o.status for o in again) == ["done", "failed", "kept", "kept"]
    assert next(o for o in again if o.status == "done").output == outcomes[2].output


def _profiler_running(worker) -> str:
    callbacks = worker.periodic_callbacks
    return "".join("1" if key in callbacks and callbacks[key].is_running() else "0"
                   for key in ("profile", "profile-cycle"))


@pytest.mark.parametrize("worker_profiler", [False, True])
def test_the_workers_profiler_is_paused_for_a_run_and_restarted_after(cluster, tmp_path,
                                                                     monkeypatch, worker_profiler):
    def states():
        return set(cluster.run(lambda dask_worker: _profiler_running(dask_worker)).values())

    assert states() == {"11"}  # Dask's default: sampling, and filing the samples
    seen = []

    def spy(*task):  # what a task's worker runs meanwhile (the workers are in this process)
        seen.append(_profiler_running(distributed.get_worker()))
        return liff.cli.detect.Detected(0, (0.0, 0.0))

    monkeypatch.setattr(liff.cli.detect, "detect_one", spy)
    paths = write_light_fields(tmp_path, 2)
    tasks = [batch.Task(p, p + ".npz", None, {}, False, {}) for p in paths]
    outcomes = batch.run(tasks, cluster, worker_profiler=worker_profiler)
    assert [o.status for o in outcomes] == ["done", "done"]
    assert set(seen) == ({"11"} if worker_profiler else {"00"})
    assert states() == {"11"}  # as the workers had it


def test_a_terminated_run_restores_the_workers_profiler(tmp_path):
    """SIGTERM (kill, timeout, a batch system's cancel) ends `liff detect --scheduler` as
    Ctrl-C does: exit status 143, and the workers' profiler, paused for the run, runs
    again."""
    write_light_fields(tmp_path / "in", 16, (7, 7, 160, 200))
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  protocol="tcp://", dashboard_address=":0") as local, \
            distributed.Client(local) as client:
        def states():
            return set(client.run(lambda dask_worker: _profiler_running(dask_worker)).values())

        run = subprocess.Popen([sys.executable, "-m", "liff", "detect", str(tmp_path / "in"),
                                "--out", str(tmp_path / "out"), "--scheduler",
                                local.scheduler_address],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.time() + 60
        while states() != {"00"} and time.time() < deadline and run.poll() is None:
            time.sleep(0.05)
        assert states() == {"00"}, "the run did not pause the profiler"
        run.send_signal(signal.SIGTERM)
        _, err = run.communicate(timeout=60)
        assert run.returncode == 128 + signal.SIGTERM and "liff detect: terminated" in err
        assert "Traceback" not in err
        assert states() == {"11"}


def test_sigterm_ends_a_local_pool_run_now_not_after_its_queue(tmp_path):
    """SIGTERM to `liff detect --workers 2`: the queued light fields are cancelled and
    the workers ended, instead of the pool finishing the whole batch first."""
    write_light_fields(tmp_path / "in", 12, (9, 9, 256, 320))
    out = tmp_path / "out"
    run = subprocess.Popen([sys.executable, "-m", "liff", "detect", str(tmp_path / "in"),
                            "--out", str(out), "--workers", "2"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and run.poll() is None and not (
            out.exists() and any(n.endswith(".npz") for n in os.listdir(out))):
        time.sleep(0.05)
    run.send_signal(signal.SIGTERM)
    _, err = run.communicate(timeout=60)
    assert run.returncode == 128 + signal.SIGTERM and "liff detect: terminated" in err
    assert sum(n.endswith(".npz") for n in os.listdir(out)) < 12  # not the whole queue
    import psutil  # (with distributed)

    time.sleep(0.5)
    assert not any(p.name() == "python" and str(tmp_path) in " ".join(p.cmdline())
                   for p in psutil.Process().children(recursive=True))


def test_a_task_takes_its_workers_threads_and_memory(tmp_path, monkeypatch):
    """A worker's thread count becomes LiFF's; its memory limit bounds each task, so a
    light field too large for the worker fails with MemoryError instead of killing it."""
    small = write_light_fields(tmp_path, 1, (3, 3, 32, 32), "small")
    large = write_light_fields(tmp_path, 1, (3, 3, 512, 512), "large")  # needs about 150 MB
    held = liff.cli.common.held_bytes()  # as the task counts it: kept working memory is reused
    limit = int((held + 90 * 2**20) / batch.MEMORY_SHARE)  # about 90 MB for each task
    threads, budget = liff.getNumThreads(), liff._budget.memory_budget_bytes
    # The worker shares this test process, already near the limit: Dask must not pause it.
    no_pausing = {f"distributed.worker.memory.{k}": False for k in ("target", "spill", "pause",
                                                                     "terminate")}
    try:
        with dask.config.set(no_pausing), \
                distributed.LocalCluster(n_workers=1, threads_per_worker=3, processes=False,
                                         memory_limit=limit, dashboard_address=":0") as local, \
                distributed.Client(local) as client:
            outcomes = batch.detect(small + large, str(tmp_path / "out"), client=client)
            seen = []

            def spy(*task):  # what a task sees (the worker is in this process)
                before = liff.cli.common.make_detector({}).getMemoryLimitMB()
                light_field = np.ones((3, 3, 512, 512, 3), np.float32)  # 28 MiB read
                after = liff.cli.common.make_detector({}).getMemoryLimitMB()
                seen.append((liff.getNumThreads(), before, after, light_field.size))
                return liff.cli.detect.Detected(0, (0.0, 0.0))

            monkeypatch.setattr(liff.cli.detect, "detect_one", spy)
            client.submit(batch.run_task, batch.Task(*small * 2, None, {}, False, {}),
                          pure=False).result()
            threads_seen, before, after, _ = seen[0]
            assert threads_seen == 3 and 1 <= before <= 90  # threads; MB left of the limit
            assert before - after >= 20  # the input read counts against the task's memory
    finally:
        assert (liff.getNumThreads(), liff._budget.memory_budget_bytes) == (threads, budget)
    assert [o.status for o in outcomes] == ["done", "failed"]
    assert outcomes[1].error.startswith("MemoryError") and "MB" in outcomes[1].error


def test_a_copy_detection_needs_is_made_before_the_memory_limit(tmp_path, monkeypatch):
    """A Fortran-order .npy (np.save of a transposed array) is copied to C order before
    the detector is made, so the copy counts in what the process holds (a 141 MB one
    had a 500 MB Dask worker killed); the features are those of the C-order array."""
    from liff._detector import as_read_in_place

    lf = liff.synthetic.textured_layers((3, 3, 64, 80), seed=3).light_field
    np.save(tmp_path / "c.npy", lf)
    np.save(tmp_path / "f.npy", np.asfortranarray(lf))
    arrays = []
    make = liff.cli.common.make_detector

    def spy(parameters):  # the light field as it is when the limit is set
        arrays.append(sys._getframe(1).f_locals["light_field"])
        return make(parameters)

    monkeypatch.setattr(liff.cli.common, "make_detector", spy)
    for name in ("c", "f"):
        liff.cli.detect.detect_one(str(tmp_path / f"{name}.npy"), str(tmp_path / f"{name}.npz"),
                                   None, {}, False, {})
    assert all(a.flags.c_contiguous for a in arrays)
    assert np.array_equal(load_features(tmp_path / "c.npz").descriptors,
                          load_features(tmp_path / "f.npz").descriptors)
    assert as_read_in_place(lf) is lf
    swapped = lf.astype(lf.dtype.newbyteorder(">"))
    native = as_read_in_place(swapped)
    assert native.dtype.isnative and native.flags.c_contiguous and np.array_equal(native, lf)


def test_inputs_from_folders_globs_and_a_list(tmp_path, capsys):
    paths = write_light_fields(tmp_path / "in", 4)
    listing = tmp_path / "list.txt"
    listing.write_text(f"# two of them\n{paths[2]}\n\n{paths[3]}\n")
    out = tmp_path / "out"
    assert main(["detect", str(tmp_path / "in" / "lf0[01].npy"), "--from-list", str(listing),
                 "--out", str(out)]) == 0
    assert sorted(os.listdir(out))[:4] == ["lf00.npz", "lf01.npz", "lf02.npz", "lf03.npz"]
    manifest = capsys.readouterr().out.split("manifest: ")[1].strip()
    assert [r["input"] for r in read_manifest(manifest)] == paths
    assert main(["detect", str(tmp_path / "in"), "--out", str(out)]) == 0  # a folder: all kept
    assert "skipped 4 input(s)" in capsys.readouterr().out
    assert main(["detect", str(tmp_path / "nothing*.npy"), "--out", str(out)]) == 1
    assert "no file matches the pattern" in capsys.readouterr().err


def test_a_folder_input_finds_light_fields_in_its_sub_folders(tmp_path):
    """A dataset folder of scene folders of .npy files: each file is a light field, a
    sub-folder of views is one, an empty folder or a link back up adds nothing."""
    from liff.cli.common import expand_inputs

    top = write_light_fields(tmp_path / "data", 1, prefix="top")
    nested = write_light_fields(tmp_path / "data" / "scene_a", 2, prefix="a")
    deeper = write_light_fields(tmp_path / "data" / "scene_b" / "day1", 1, prefix="b")
    views = tmp_path / "data" / "scene_c"
    liff.io.write_views(views, np.zeros((2, 2, 16, 16), np.uint8))
    (tmp_path / "data" / "empty").mkdir()
    os.symlink(tmp_path / "data", tmp_path / "data" / "scene_b" / "up")
    found = expand_inputs([str(tmp_path / "data")], {})
    assert found == nested + deeper + [str(views)] + top


def test_a_recursive_glob_does_not_follow_links_back_up(tmp_path):
    """glob's ** follows links to folders: two links back up made it run for ever."""
    from liff.cli.common import expand_inputs

    paths = write_light_fields(tmp_path / "data" / "scene", 1)
    for name in ("up1", "up2"):
        os.symlink(tmp_path / "data", tmp_path / "data" / "scene" / name)
    (tmp_path / "data" / ".hidden").mkdir()
    write_light_fields(tmp_path / "data" / ".hidden", 1)
    assert expand_inputs([str(tmp_path / "data" / "**" / "*.npy")], {}) == paths


def test_an_unreadable_sub_folder_is_skipped_with_a_warning(tmp_path, monkeypatch):
    """(lost+found at the top of a data disk.) Simulated: the tests may run as root."""
    from liff._warnings import LiffWarning
    from liff.cli import common

    paths = write_light_fields(tmp_path / "data" / "a", 1)
    locked = tmp_path / "data" / "locked"
    locked.mkdir()
    scandir = os.scandir

    def refusing(path="."):
        if os.fspath(path) == str(locked):
            raise PermissionError(13, "Permission denied", str(path))
        return scandir(path)

    monkeypatch.setattr(common.os, "scandir", refusing)
    with pytest.warns(LiffWarning, match="locked: cannot list the folder.*skipped"):
        assert common.expand_inputs([str(tmp_path / "data")], {}) == paths
    assert common.glob_paths(str(tmp_path / "data" / "a**" / "*.npy")) == paths  # (** in a name: *)


def test_batch_detect_takes_one_path_and_refuses_bad_arguments_up_front(tmp_path):
    paths = write_light_fields(tmp_path / "in", 2)
    outcomes = batch.detect(str(tmp_path / "in"), str(tmp_path / "out"))  # a str: one path
    assert [o.status for o in outcomes] == ["done", "done"] and len(paths) == 2
    for kwargs, message in (({"workers": 0}, "workers"), ({"firstSlope": 1.0, "lastSlope": -1.0},
                                                         "firstSlope")):
        with pytest.raises(ValueError, match=f"{message}.*expected"):
            batch.detect(paths, str(tmp_path / "other"), **kwargs)
    assert not (tmp_path / "other").exists()


def test_an_unreachable_scheduler_is_a_clear_error_within_seconds(tmp_path, capsys):
    paths = write_light_fields(tmp_path / "in", 2)
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    start = time.perf_counter()
    assert main(["detect", *paths, "--out", str(tmp_path / "out"),
                 "--scheduler", f"tcp://127.0.0.1:{port}"]) == 1
    assert time.perf_counter() - start < batch.CONNECT_TIMEOUT + 5
    err = capsys.readouterr().err
    assert f"cannot reach a Dask scheduler at tcp://127.0.0.1:{port}" in err and "Traceback" not in err
    assert not any(n.endswith(".npz") for n in os.listdir(tmp_path / "out")) if (tmp_path / "out").exists() else True


@pytest.mark.parametrize("server", ["silent", "http"])
def test_a_server_that_is_not_a_dask_scheduler_is_a_clear_error_within_seconds(tmp_path, server):
    """A port that accepts TCP but never speaks Dask (a dashboard, a stuck service), or
    answers HTTP 400: refused within the timeout, not a hang or an exabyte allocation."""
    import threading

    paths = write_light_fields(tmp_path / "in", 1)
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen()
    accepted = []

    def serve():
        while True:
            try:
                connection, _ = listener.accept()
            except OSError:  # closed: the test is over
                return
            accepted.append(connection)
            if server == "http":
                connection.recv(100)
                connection.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")

    threading.Thread(target=serve, daemon=True).start()
    address = f"tcp://127.0.0.1:{listener.getsockname()[1]}"
    start = time.perf_counter()
    try:  # (in a process of its own, so that a hang fails the test instead of holding it)
        run = subprocess.run([sys.executable, "-m", "liff", "detect", *paths, "--out",
                              str(tmp_path / "out"), "--scheduler", address],
                             capture_output=True, text=True, timeout=batch.CONNECT_TIMEOUT + 60)
    finally:
        listener.close()
        for connection in accepted:
            connection.close()
    assert run.returncode == 1
    assert time.perf_counter() - start < batch.CONNECT_TIMEOUT + 20  # (with Python's start)
    assert address in run.stderr and "Dask scheduler" in run.stderr
    assert "Traceback" not in run.stderr
    assert accepted  # it was reached: the error is about what answered


def test_a_scheduler_without_workers_says_so_and_waits_for_them(tmp_path):
    paths = write_light_fields(tmp_path / "in", 2)
    notices = []
    with distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=":0") as local, \
            distributed.Client(local) as client:
        def notice(text):  # a worker joins once told
            notices.append(text)
            local.scale(1)

        tasks = [batch.Task(p, str(tmp_path / f"{i}.npz"), None, {}, False, {})
                 for i, p in enumerate(paths)]
        outcomes = batch.run(tasks, client, notice=notice)
    assert len(notices) == 1 and "no Dask worker has joined" in notices[0]
    assert "dask worker" in notices[0]
    assert [o.status for o in outcomes] == ["done", "done"]


@pytest.mark.parametrize("address", ["foo", "tcp://", "http://127.0.0.1:8787",
                                     "tcp://127.0.0.1:8786/extra"])
def test_what_is_not_a_scheduler_address_is_refused_at_once(address):
    start = time.perf_counter()
    with pytest.raises(ValueError, match="is not an address of a Dask scheduler.*expected"):
        batch.connect(address)
    assert time.perf_counter() - start < 5


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _dask(*args):
    """Dask's own command (`dask scheduler`, `dask worker`), from this environment."""
    command = os.path.join(os.path.dirname(sys.executable), "dask")
    return subprocess.Popen([command, *args], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def test_a_worker_killed_mid_run_loses_nothing(tmp_path):
    """`dask scheduler` and two `dask worker` processes on 127.0.0.1; one worker is
    killed (SIGKILL) once outputs start to appear: its tasks (and the results it held)
    run on the other, every output is complete and the run exits 0."""
    paths = write_light_fields(tmp_path / "in", 16, (5, 5, 128, 160))
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    scheduler = _dask("scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard")
    workers = [_dask("worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                     "--host", "127.0.0.1") for _ in range(2)]
    try:
        with distributed.Client(address, timeout=30) as client:
            client.wait_for_workers(2, timeout=60)
        out = tmp_path / "out"
        run = subprocess.Popen([sys.executable, "-m", "liff", "detect", str(tmp_path / "in"),
                                "--out", str(out), "--scheduler", address,
                                "--manifest", str(tmp_path / "m.csv")],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.time() + 120
        while time.time() < deadline and not (out.exists() and any(n.endswith(".npz") for n in os.listdir(out))):
            time.sleep(0.05)
        workers[0].send_signal(signal.SIGKILL)
        at_kill = sum(n.endswith(".npz") for n in os.listdir(out))
        stdout, stderr = run.communicate(timeout=300)
        assert run.returncode == 0, stderr
        rows = read_manifest(tmp_path / "m.csv")
        assert len(rows) == 16 and {r["status"] for r in rows} == {"done"}, rows
        assert 1 <= at_kill < 16, at_kill  # killed mid-run
        for path in paths:
            features = load_features(out / (os.path.basename(path)[:-4] + ".npz"))
            assert len(features.keypoints) > 0
        # What the killed worker was writing stays under a hidden temporary name, if at all.
        assert all(n.startswith(".lf") and ".partial." in n for n in os.listdir(out) if n.startswith("."))
    finally:
        for process in workers + [scheduler]:
            process.kill()
            process.wait()


# --- manifests that never collide and survive an interrupted run (issue 32) ----------------

def test_two_batches_started_in_the_same_second_get_manifests_of_their_own(tmp_path):
    """Both had written manifest-YYYYmmdd-HHMMSS.csv, one over the other."""
    now = time.time()
    names = [batch.new_manifest_name(str(tmp_path / "out"), now) for _ in range(3)]
    stamp = time.strftime("manifest-%Y%m%d-%H%M%S", time.gmtime(now))
    assert [os.path.basename(n) for n in names] == [f"{stamp}.csv", f"{stamp}-2.csv",
                                                    f"{stamp}-3.csv"]
    assert all(os.path.isfile(n) for n in names)  # each taken as soon as it is named


def test_a_batch_writes_its_own_manifest_beside_one_of_the_same_second(tmp_path, capsys,
                                                                      monkeypatch):
    paths = write_light_fields(tmp_path / "in", 2)
    out = tmp_path / "out"
    now = time.time()
    taken = batch.new_manifest_name(str(out), now)  # another batch's, in the same second
    real = batch.new_manifest_name
    monkeypatch.setattr(batch, "new_manifest_name", lambda folder: real(folder, now))
    assert main(["detect", *paths, "--out", str(out)]) == 0
    manifest = capsys.readouterr().out.split("manifest: ")[1].strip()
    assert manifest == taken.replace(".csv", "-2.csv")
    assert [r["input"] for r in read_manifest(manifest)] == paths
    assert os.path.getsize(taken) == 0  # the other batch's, untouched


@pytest.mark.parametrize("stop", ["Ctrl-C", "SIGKILL"])
def test_a_run_stopped_early_leaves_a_manifest_of_what_it_finished(tmp_path, monkeypatch, stop):
    """SIGINT, SIGKILL or a full disk had left no manifest at all. Ctrl-C: the manifest
    is written on the way out; SIGKILL: what is on disk when the third task starts is
    what a kill then would leave (written as the run goes, each write atomic)."""
    paths = write_light_fields(tmp_path / "in", 4)
    manifest = tmp_path / "m.csv"
    monkeypatch.setattr(batch, "MANIFEST_SECONDS", 0.0)
    seen_on_disk = []
    real = batch.run_task

    def task(task):
        if task.source == paths[2]:
            seen_on_disk.append(read_manifest(manifest))
            if stop == "Ctrl-C":
                raise KeyboardInterrupt
        return real(task)

    monkeypatch.setattr(batch, "run_task", task)
    code = main(["detect", *paths, "--out", str(tmp_path / "out"), "--manifest", str(manifest)])
    rows = read_manifest(manifest)
    finished = [{"input": r["input"], "status": r["status"]} for r in seen_on_disk[0]]
    assert finished == [{"input": p, "status": "done"} for p in paths[:2]]
    if stop == "Ctrl-C":
        assert code == 130 and [r["input"] for r in rows] == paths[:2]
    else:
        assert code == 0 and [r["input"] for r in rows] == paths
    assert not [n for n in os.listdir(tmp_path) if ".partial" in n]
