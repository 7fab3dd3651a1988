"""Issue 29, deliverable 4: the README's command-line examples run, on small inputs, and
do what they say.

Every line that starts with ``liff`` in the README's ```bash blocks runs, in the order
written, in one folder, through ``liff.cli.main`` (what the ``liff`` command runs), with
only these changes: ``liff synth`` gets small sizes where the line gives none (the
scenes are the same); ``--camera`` and ``--focus-distance`` are the ``poses.truth.json``
of that smaller ``liff synth poses`` (the README's numbers are checked separately
against the default one's); ``--scheduler``'s address is an in-process Dask cluster's.
The inputs the README assumes the user has (a folder of Lytro ESLF images, a 12-bit
MATLAB light field, two light fields ``a.npz`` / ``b.npz``, a list of inputs) are made
small beforehand. Each command must exit 0 and make what it promises (files, printed
counts, a metric pose near the truth); a README line that no check knows fails here,
so a new example is run too.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import time
from typing import Callable, Dict, List, Tuple

import cv2
import numpy as np

import liff
from liff.cli import build_parser, main

README = os.path.join(os.path.dirname(__file__), "..", "..", "README.md")

#: options a small ``liff synth`` adds where the README's line gives none
SMALL_SYNTH = {"disks": {"--views": "5", "--size": ("64", "64")},
               "layers": {"--views": "5", "--size": ("64", "64")},
               "poses": {"--views": "3", "--size": ("120", "160"), "--poses": "4"}}
#: seconds the whole README may take here (a 2-core machine shared with other jobs)
TIME_LIMIT = 60


def readme_commands() -> List[Tuple[List[str], str]]:
    """(argv, comment) of each ``liff`` line of the README's bash blocks, in order."""
    with open(README, encoding="utf-8") as f:
        blocks = re.findall(r"^```bash\n(.*?)^```", f.read(), re.M | re.S)
    commands = []
    for line in "\n".join(blocks).splitlines():
        if line.startswith("liff "):
            code, _, comment = line.partition("#")
            commands.append((code.split(), comment.strip()))
    return commands


def option(argv: List[str], flag: str, count: int = 1):
    """The value(s) after ``flag`` in argv, or None."""
    if flag not in argv:
        return None
    i = argv.index(flag)
    return argv[i + 1] if count == 1 else argv[i + 1:i + 1 + count]


def small(argv: List[str], scheduler: Callable[[], str]) -> List[str]:
    """The README's argv as run here (see the module's docstring)."""
    argv = list(argv)
    if argv[1] == "synth":
        for flag, value in SMALL_SYNTH[argv[2]].items():
            if flag not in argv:
                argv += [flag, *((value,) if isinstance(value, str) else value)]
    if "--camera" in argv:
        with open("poses.truth.json", encoding="utf-8") as f:
            truth = json.load(f)
        k = truth["intrinsics"]
        i = argv.index("--camera")
        argv[i + 1:i + 5] = [repr(v) for v in (k["focal"], truth["baseline"], k["cx"], k["cy"])]
        argv[argv.index("--focus-distance") + 1] = repr(truth["focus_depth"])
    if "--scheduler" in argv:
        argv[argv.index("--scheduler") + 1] = scheduler()
    return argv


def make_user_inputs() -> None:
    """What the README's examples take as the user's own: ``lytro/`` (Lytro ESLF images,
    lenslets of 13 pixels, of which --keep-views 11 keeps 11), ``todo.txt`` (inputs for a
    cluster), ``IMG_0001__Decoded.mat`` (the Light Field Toolbox's LF(t, s, v, u, c),
    12-bit RGB + weight in uint16) and ``a.npz`` / ``b.npz`` (two poses of one scene)."""
    import scipy.io

    for i in range(2):
        assert main(["synth", "disks", "--out", f"lytro/IMG_000{i}.eslf.png", "--format", "eslf",
                     "--views", "13", "--size", "48", "48", "--seed", str(i), "--noise", "1e-4"]) == 0
    with open("todo.txt", "w", encoding="utf-8") as f:
        f.write("# light fields for the cluster\nlytro/IMG_0000.eslf.png\nlytro/IMG_0001.eslf.png\n")
    shape = (5, 5, 64, 64)
    lf = liff.synthetic.render_disks(liff.synthetic.paper_disks(n=10, shape=shape, seed=2), shape)
    rgbw = np.concatenate([np.repeat(lf[..., None], 3, -1), np.ones(shape + (1,))], -1)
    scipy.io.savemat("IMG_0001__Decoded.mat", {"LF": np.round(rgbw * 4095).astype(np.uint16)})
    assert main(["synth", "poses", "--out", "pair", "--views", "3", "--size", "120", "160",
                 "--poses", "2", "--seed", "3"]) == 0
    shutil.copy("pair/pose00.npz", "a.npz")
    shutil.copy("pair/pose01.npz", "b.npz")


def feature_count(path: str) -> int:
    from liff.feature_file import load_features

    return len(load_features(path).keypoints)


def is_picture(path: str) -> bool:
    image = cv2.imread(path)
    return image is not None and image.size > 0


def true_baseline(a: str, b: str) -> float:
    """|t| between two poses of ``liff synth poses`` (poses.truth.json), metres."""
    with open("poses.truth.json", encoding="utf-8") as f:
        poses = {p["name"]: p for p in json.load(f)["poses"]}
    (R1, t1), (R2, t2) = ((np.array(poses[n]["rotation"]), np.array(poses[n]["translation"]))
                          for n in (a, b))
    R = R2 @ R1.T
    return float(np.linalg.norm(t2 - R @ t1))


def check(argv: List[str], out: str, err: str) -> None:
    """What each README line promises, beyond exit status 0."""
    command = argv[1]
    if command == "--version":
        assert out.startswith(f"liff {liff.__version__} (core on OpenCV ")
    elif command == "synth":
        path = option(argv, "--out")
        assert os.path.exists(path)
        if argv[2] == "poses":
            count = int(option(argv, "--poses"))
            assert sorted(os.listdir(path)) == [f"pose{i:02d}.npz" for i in range(count)]
            assert os.path.exists(path + ".truth.json")
    elif command == "detect":
        out_path = option(argv, "--out")
        inputs = [a for a in argv[2:] if not a.startswith("-")][:1] if "--from-list" not in argv else []
        if out_path is None:  # one input: <name>.npz here
            out_path = os.path.splitext(os.path.basename(inputs[0]))[0] + ".npz"
        if os.path.isdir(out_path):  # several inputs: one file each, and the run's manifest
            done = re.findall(r"^(\S+): (\d+) features -> (\S+?)[;,]", out, re.M)
            assert done and all(int(n) > 0 and feature_count(o) == int(n) for _, n, o in done)
            assert any(n.startswith("manifest-") for n in os.listdir(out_path))
        else:
            assert feature_count(out_path) > 10, out_path
        if "--plot" in argv:
            assert is_picture(option(argv, "--plot"))
        if "--hloc" in argv:
            import h5py

            with h5py.File(option(argv, "--hloc"), "r") as f:
                names = sorted(f)
            assert names and f"hloc: {len(names)} light field(s)" in out
            if "--hloc-images" in argv:
                assert sorted(os.listdir(option(argv, "--hloc-images"))) == names
    elif command == "match":
        inliers = int(re.search(r"inliers \(homography, 3 px\): (\d+)", out).group(1))
        if argv[2:4] == ["a.npz", "b.npz"]:  # two near poses of one scene (make_user_inputs)
            assert inliers >= 15 and "warning" not in err
        if "--plot" in argv:
            assert is_picture(option(argv, "--plot"))
        if "--hloc" in argv:
            assert re.search(r"hloc: \d+ matches of", out) and os.path.exists(option(argv, "--hloc"))
    elif command == "pose":
        t = float(re.search(r"\|t\| = ([0-9.]+) m", out).group(1))
        names = [os.path.basename(p)[:-4] for p in argv[2:4]]
        assert abs(t / true_baseline(*names) - 1) < 0.05  # metric: scale from the slopes
    elif command == "colmap":
        assert os.path.getsize(option(argv, "--database")) > 0
        assert len(os.listdir(option(argv, "--image-dir"))) == len(os.listdir(argv[2]))
    elif command == "sfm":
        assert re.search(r"registered images\s+100%", out)
        if "--camera" in argv:  # a model in metres, checked by the slopes and baselines
            factors = re.findall(r"x (\d+\.\d+)", out)
            assert "in metres" in out and factors and all(abs(float(f) - 1) < 0.01 for f in factors)
    elif command == "demo":
        assert is_picture(os.path.join(option(argv, "--out"), "features.png"))
    else:
        raise AssertionError(f"no check for the README's `{' '.join(argv)}`; add one here")


def test_the_readme_commands_run_and_do_what_they_say(tmp_path, monkeypatch, capsys):
    import distributed  # a test dependency, as pycolmap and scipy
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "1")
    start = time.perf_counter()
    make_user_inputs()
    capsys.readouterr()
    clusters: Dict[str, object] = {}

    def scheduler() -> str:
        local = distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                         dashboard_address=":0")
        clusters["local"] = local
        return local.scheduler_address

    commands = readme_commands()
    assert len(commands) >= 15
    try:
        for readme_argv, comment in commands:
            argv = small(readme_argv, scheduler)
            try:
                status = main(argv[1:])
            except SystemExit as exit_:  # --version
                status = exit_.code
            out, err = capsys.readouterr()
            assert status == 0, f"`{' '.join(readme_argv)}` exited {status}: {err[-1500:]}"
            try:
                check(argv, out, err)
            except AssertionError as error:
                raise AssertionError(f"`{' '.join(argv)}`: {error}\n{out[-1500:]}") from None
    finally:
        for local in clusters.values():
            local.close()
    assert time.perf_counter() - start < TIME_LIMIT


def test_the_readme_camera_is_that_of_liff_synth_poses():
    """The camera the README's pose and sfm lines give is what ``liff synth poses`` (its
    defaults) writes to poses.truth.json (computed here without rendering the scene)."""
    from liff import captures
    from liff.cli.synth import shape_of

    cameras = {tuple(option(argv, "--camera", 4) + [option(argv, "--focus-distance")])
               for argv, _ in readme_commands() if "--camera" in argv}
    assert len(cameras) == 1
    focal, baseline, cx, cy, focus = (float(v) for v in cameras.pop())
    _, _, V, U = shape_of(build_parser().parse_args(["synth", "poses", "--out", "poses"]))
    truth = captures.make_capture(views=(1, 1), size=(V, U), patches=(),
                                  poses=captures.arc_poses(1))
    k = truth.intrinsics
    assert (focal, cx, cy) == (k.focal, k.cx, k.cy)
    assert round(truth.baseline, 4) == baseline and round(truth.focus_depth, 2) == focus


def test_the_folders_the_readme_commands_write_in_the_clone_are_ignored_by_git():
    """Break test 5: `bash .ci/setup.sh demo` writes liff-demo/ (the README's `liff demo
    --out liff-demo`) in the clone, which .gitignore did not list, so `git status` showed
    it as new files."""
    root = os.path.join(os.path.dirname(README), "")
    with open(os.path.join(root, ".gitignore"), encoding="utf-8") as f:
        ignored = {line.strip() for line in f if line.strip() and not line.startswith("#")}
    with open(README, encoding="utf-8") as f:
        demo_outs = set(re.findall(r"liff demo --out (\S+?)[`\s]", f.read()))
    assert demo_outs and all(f"{out.rstrip('/')}/" in ignored for out in demo_outs), demo_outs
