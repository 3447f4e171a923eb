"""`import neckid` and the CLI's --version/--help load none of the heavy libraries; the lazy API is complete."""

from __future__ import annotations

import importlib
import json
import subprocess
import sys

import pytest

import neckid

# Libraries that `import neckid` must not load: it used to load sklearn, numba, pandas, scipy and
# joblib through its eager re-exports (about 1.5 s); matplotlib and control are kept out too.
# NumPy is allowed: it is cheap next to these and may be needed by any module.
HEAVY = ("sklearn", "numba", "matplotlib", "pandas", "scipy", "control", "joblib")


def loaded_after(code: str) -> set[str]:
    """Top-level packages in ``sys.modules`` after running ``code`` in a fresh interpreter."""
    report = "import json, sys; print(json.dumps(sorted({m.split('.')[0] for m in sys.modules})))"
    completed = subprocess.run(
        [sys.executable, "-c", f"{code}\n{report}"], check=True, capture_output=True, text=True
    )
    return set(json.loads(completed.stdout.splitlines()[-1]))


def test_import_neckid_loads_no_heavy_library() -> None:
    loaded = loaded_after("import neckid")
    assert "neckid" in loaded
    assert loaded.isdisjoint(HEAVY), sorted(loaded & set(HEAVY))


@pytest.mark.parametrize("option", ["--version", "--help"])
def test_cli_version_and_help_load_no_heavy_library(option: str) -> None:
    code = (
        "import sys\n"
        "from neckid.cli import app\n"
        f"sys.argv = ['neckid', {option!r}]\n"
        "try:\n"
        "    app()\n"
        "except SystemExit as exit:\n"
        "    assert exit.code == 0, exit.code\n"
    )
    loaded = loaded_after(code)
    assert loaded.isdisjoint(HEAVY), sorted(loaded & set(HEAVY))


def test_submodules_load_on_first_use() -> None:
    code = (
        "import sys, neckid\n"
        "assert 'neckid.plant' not in sys.modules\n"
        "assert neckid.plant.SoftNeck.__module__ == 'neckid.plant.soft_neck'\n"
        "assert 'neckid.plant' in sys.modules\n"
    )
    assert "numba" in loaded_after(code)


@pytest.mark.parametrize("name", neckid.__all__)
def test_every_public_name_resolves(name: str) -> None:
    namespace: dict[str, object] = {}
    exec(f"from neckid import {name}", namespace)
    assert namespace[name] is getattr(neckid, name)
    assert name in dir(neckid)


@pytest.mark.parametrize(("name", "module"), sorted(neckid._NAME_TO_MODULE.items()))
def test_public_names_are_the_objects_of_their_modules(name: str, module: str) -> None:
    assert getattr(neckid, name) is getattr(importlib.import_module(module), name)


def test_submodules_are_the_modules() -> None:
    for name in sorted(neckid._SUBMODULES):
        assert getattr(neckid, name) is importlib.import_module(f"neckid.{name}")


def test_lazy_names_are_exactly_the_public_api() -> None:
    lazy = set(neckid._NAME_TO_MODULE) | neckid._SUBMODULES | {"__version__"}
    assert lazy == set(neckid.__all__)
    assert len(neckid.__all__) == len(set(neckid.__all__))


def test_unknown_name_raises_attribute_error() -> None:
    with pytest.raises(AttributeError, match=r"^module 'neckid' has no attribute 'NoSuchModel'$"):
        _ = neckid.NoSuchModel
    assert not hasattr(neckid, "select_lag")
    with pytest.raises(ImportError, match="cannot import name 'NoSuchModel' from 'neckid'"):
        exec("from neckid import NoSuchModel", {})


def test_model_classes_come_from_the_method_registry() -> None:
    from neckid.models.io import ModelFile
    from neckid.registry import methods, model_classes

    classes = model_classes()
    assert set(classes) == {m.estimator_class().__name__ for m in methods().values()}
    for name, module in classes.items():
        cls = getattr(importlib.import_module(module), name)
        assert cls.__name__ == name
        assert issubclass(cls, ModelFile)


def test_load_model_in_a_fresh_interpreter(tmp_path) -> None:
    # `import neckid` registers no model class any more: load_model must import the right module.
    import numpy as np

    data = neckid.IOData(np.sin(np.arange(80.0)), np.cos(np.arange(80.0)), ts=1.0)
    lags = neckid.Lags.arx(1, 1, 1)
    paths = [
        neckid.LinearARX(lags).fit(data).save(tmp_path / "arx"),
        neckid.SetMembership(lags, progress=False).fit(data).save(tmp_path / "sm"),
    ]
    code = (
        "import sys; from neckid import load_model; "
        "print(','.join(type(load_model(p)).__name__ for p in sys.argv[1:]))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, *map(str, paths)], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "LinearARX,SetMembership"
