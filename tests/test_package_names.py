"""The package's structure (issue 27): public names kept when modules are split, and no
module using another's private names."""

import ast
import importlib
from pathlib import Path

import pytest

import liff

# What ``liff.colmap`` offered as one module (main at 868753f, before the split into a
# package): every name it defined. The names it imported from elsewhere (os, numpy,
# pycolmap, typing, liff.pose_graph's PairMeasurement, ...) were never its API.
COLMAP_NAMES = [
    "FeatureImage", "MAX_BASELINE_RELATIVE_SIGMA", "MetricScale", "PANORAMIC_BASELINE",
    "PairPose", "PathLike", "SfmResult", "colmap_log", "describe_sizes",
    "descriptors_to_colmap", "grey_uint8_image", "keypoints_to_colmap", "left_out_images",
    "mapper_options", "match", "match_by_pose", "matching_options", "metric_scale",
    "prepare_light_field", "reconstruct", "reconstruct_from_poses", "root_sift",
    "scale_reconstruction", "table_metrics", "write_database",
]
# ... and ``liff.hloc``'s, with the names it imported from liff.colmap.
HLOC_NAMES = [
    "Added", "DESCRIPTOR_NORM", "DIGEST_ATTR", "PAIR_DIGEST_ATTRS", "PAIR_NAME_ATTRS",
    "add_feature_files", "check_export", "check_file_kind", "check_pair_names",
    "feature_datasets", "feature_file_group", "features_digest", "features_in", "image_name",
    "match_scores", "names_to_pair", "updated", "write_features", "write_matches",
    "grey_uint8_image", "keypoints_to_colmap",
]
# What ``liff.pose`` offered as one module (main at 3cee258, before the split into a
# package): every name it defined (not those it imported: cv2, numpy, typing, ...).
POSE_NAMES = [
    "CHI2_INLIER", "GUIDED_ROUNDS", "MAX_TRANSFER_VARIANCE", "MIN_MATCHES", "NoiseModel",
    "PoseEstimationError", "RANSAC_BATCH", "RANSAC_CHANCE_FACTOR", "RANSAC_CHANCE_TRIALS",
    "RANSAC_LOCAL_POOL", "RANSAC_LOCAL_ROUNDS", "RANSAC_MAX_HYPOTHESES", "RANSAC_SIGMA",
    "RelativePose", "SIGMA_FLOOR", "check_seed", "estimate_relative_pose", "guided_matches",
    "observation_ransac", "observations", "ransac_pose", "refine_relative_pose",
    "translation_length_sigma",
]


@pytest.mark.parametrize("module, names", [("liff.colmap", COLMAP_NAMES), ("liff.hloc", HLOC_NAMES),
                                           ("liff.pose", POSE_NAMES)])
def test_public_names_are_kept(module, names):
    """Every public name of the module as it was is still importable from it."""
    imported = importlib.import_module(module)
    missing = [name for name in names if not hasattr(imported, name)]
    assert not missing, f"{module} lost {missing}"
    for name in names:  # and ``from module import name`` works as ``module.name`` does
        assert getattr(importlib.import_module(module), name) is getattr(imported, name)


def test_colmap_all_is_its_public_names():
    """``from liff.colmap import *`` gives what the module gave (its own names only)."""
    import liff.colmap

    assert sorted(liff.colmap.__all__) == sorted(COLMAP_NAMES)


def test_pose_all_is_its_public_names():
    """``from liff.pose import *`` gives what the module gave (its own names only)."""
    import liff.pose

    assert sorted(liff.pose.__all__) == sorted(POSE_NAMES)


# --- no private name across modules --------------------------------------------------
#
# The rule: a name starting with one underscore (``_check``, not ``__version__``) belongs
# to the module that defines it; no other module of python/liff imports it or reaches it
# as ``module._name`` (or ``getattr(module, "_name")``). A module that needs it gets it
# public (documented, in its owner's API) or takes it over. Private *modules*
# (``liff._core``, ``liff._detector``, ``liff.io._matv5``) are the package's own: any
# module inside the package that holds them may import them and use their public names
# (``liff.io._matv5`` from ``liff.io`` and below only), but not their underscore names.
# Tests may use the private names of the module they test.

PACKAGE_ROOT = Path(liff.__file__).resolve().parent


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE_ROOT.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_module(dotted: str) -> bool:
    """True if ``dotted`` (liff.x.y) is a module or package of python/liff."""
    if dotted == "liff":
        return True
    if not dotted.startswith("liff."):
        return False
    base = PACKAGE_ROOT.joinpath(*dotted.split(".")[1:])
    return (base.with_suffix(".py").is_file() or (base / "__init__.py").is_file()
            or any(base.parent.glob(base.name + ".*.so")) or base.with_suffix(".pyi").is_file())


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _private_module_outside_its_package(module: str, importer: str) -> bool:
    """A private module (some part of its name private) imported from outside the package
    that holds it."""
    parts = module.split(".")
    for i, part in enumerate(parts):
        if _private(part):
            holder = ".".join(parts[:i])
            return not (importer == holder or importer.startswith(holder + "."))
    return False


def private_name_uses(path: Path):
    """(line, what) for each use in the file of another module's private name."""
    here = _module_name(path)
    is_package = path.name == "__init__.py"
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    modules = {}  # local name -> the liff module it is bound to
    found = []

    def absolute(node: ast.ImportFrom) -> str:
        if not node.level:
            return node.module or ""
        base = here.split(".") if is_package else here.split(".")[:-1]
        base = base[:len(base) - (node.level - 1)]
        return ".".join(base + ([node.module] if node.module else []))

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name == "liff" or alias.name.startswith("liff."):
                    if _private_module_outside_its_package(alias.name, here):
                        found.append((node.lineno, f"import {alias.name}"))
                    if alias.asname:
                        modules[alias.asname] = alias.name
                    else:
                        modules[alias.name.split(".")[0]] = alias.name.split(".")[0]
        elif isinstance(node, ast.ImportFrom):
            source = absolute(node)
            if not (source == "liff" or source.startswith("liff.")):
                continue
            if _private_module_outside_its_package(source, here):
                found.append((node.lineno, f"from {source} import ..."))
            for alias in node.names:
                target = f"{source}.{alias.name}"
                if _is_module(target):
                    if _private_module_outside_its_package(target, here):
                        found.append((node.lineno, f"from {source} import {alias.name}"))
                    modules[alias.asname or alias.name] = target
                elif _private(alias.name) and source != here:
                    found.append((node.lineno, f"from {source} import {alias.name}"))

    def resolve(node):
        """The liff module an expression names (a bound name, then .submodule ...), or None."""
        if isinstance(node, ast.Name):
            return modules.get(node.id)
        if isinstance(node, ast.Attribute):
            owner = resolve(node.value)
            if owner is not None and _is_module(f"{owner}.{node.attr}"):
                return f"{owner}.{node.attr}"
        return None

    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _private(node.attr):
            owner = resolve(node.value)
            if owner is not None and owner != here and not _is_module(f"{owner}.{node.attr}"):
                found.append((node.lineno, f"{owner}.{node.attr}"))
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
              and node.func.id in ("getattr", "setattr", "hasattr") and len(node.args) >= 2
              and isinstance(node.args[1], ast.Constant) and isinstance(node.args[1].value, str)
              and _private(node.args[1].value)):
            owner = resolve(node.args[0])
            if owner is not None and owner != here:
                found.append((node.lineno, f"{node.func.id}({owner}, {node.args[1].value!r})"))
    return found


def test_no_private_name_is_used_across_modules():
    """No module of python/liff uses another module's underscore name (the rule above)."""
    uses = [f"{path.relative_to(PACKAGE_ROOT.parent)}:{line}: {what}"
            for path in sorted(PACKAGE_ROOT.rglob("*.py"))
            for line, what in private_name_uses(path)]
    assert not uses, "private names used across modules:\n" + "\n".join(uses)


def test_the_private_name_check_sees_each_kind_of_use(tmp_path, monkeypatch):
    """The check above finds what it is for, and leaves private modules' public names."""
    package = tmp_path / "liff"
    (package / "sub").mkdir(parents=True)
    for name in ("__init__.py", "a.py", "_b.py", "sub/__init__.py", "sub/_c.py"):
        (package / name).write_text("")
    (package / "user.py").write_text(
        "import liff.a\nimport liff.a as aa\nfrom . import a, _b\nfrom .a import _x, y\n"
        "from ._b import z, _w\nfrom .sub import _c\nfrom .sub._c import q\n"
        "a._p\naa._q\nliff.a._r\n_b.ok\ngetattr(a, '_s')\na.__doc__\n")
    (package / "sub" / "inner.py").write_text("from . import _c\nfrom ._c import ok\n_c._t\n")
    monkeypatch.setitem(globals(), "PACKAGE_ROOT", package)
    assert [what for _, what in private_name_uses(package / "user.py")] == [
        "from liff.a import _x", "from liff._b import _w", "from liff.sub import _c",
        "from liff.sub._c import ...", "liff.a._p", "liff.a._q", "liff.a._r", "getattr(liff.a, '_s')"]
    assert [what for _, what in private_name_uses(package / "sub" / "inner.py")] == ["liff.sub._c._t"]
