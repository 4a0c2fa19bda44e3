"""The façade and the command line load lazily; every public name resolves."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

from hybridlab._lazy import type_checking_imports

PACKAGES = ["hybridlab", "hybridlab.ensemble", "hybridlab.graph", "hybridlab.identify",
            "hybridlab.io", "hybridlab.model", "hybridlab.reachability", "hybridlab.simulation",
            "hybridlab.symbolic"]


@pytest.mark.parametrize("name", PACKAGES)
def test_every_public_name_resolves_to_its_origin(name: str) -> None:
    package = importlib.import_module(name)
    with open(package.__file__, encoding="utf-8") as fh:
        origins = type_checking_imports(fh.read())
    assert sorted(origins) == sorted(package.__all__)
    for exported, (module, attribute) in origins.items():
        assert getattr(package, exported) is getattr(importlib.import_module(module), attribute)
    assert set(package.__all__) <= set(dir(package))


def test_an_unknown_name_is_an_attribute_error() -> None:
    import hybridlab

    with pytest.raises(AttributeError, match="has no attribute 'simulatee'"):
        hybridlab.simulatee  # noqa: B018


def test_submodules_load_on_first_access() -> None:
    out = subprocess.run([sys.executable, "-c", "import hybridlab\n"
                          "print(hybridlab.model.loads_model is hybridlab.loads_model, "
                          "hybridlab.reachability.sets.Zonotope is hybridlab.Zonotope)"],
                         capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True", "True"]


def _modules_loaded_by(code: str) -> set[str]:
    out = subprocess.run([sys.executable, "-c", code + "\nimport sys\nprint(*sys.modules)"],
                         capture_output=True, text=True, check=True)
    return set(out.stdout.split())


@pytest.mark.parametrize("code", [
    "import hybridlab",
    "from hybridlab.cli import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass",
    "from hybridlab.cli import main\nmain(['reach', '--help'])",
])
def test_import_and_help_load_no_numerical_library(code: str) -> None:
    loaded = _modules_loaded_by(code)
    assert not loaded & {"numpy", "scipy", "sympy", "pydantic", "networkx", "numba"}


# a kernel module whose docstring edits would force a numba recompile of the kernel
_NO_EXAMPLE = {"hybridlab.simulation.compiled.signatures.watch_addresses"}


def test_every_public_name_has_a_runnable_example() -> None:
    import inspect
    import pkgutil

    import hybridlab

    missing = []
    for info in pkgutil.walk_packages(hybridlab.__path__, "hybridlab."):
        if info.name == "hybridlab.__main__":
            continue
        module = importlib.import_module(info.name)
        for name in getattr(module, "__all__", ()):
            obj = getattr(module, name)
            if getattr(obj, "__module__", None) != module.__name__ or not (
                    inspect.isclass(obj) or inspect.isfunction(obj)):
                continue  # re-exported, or a constant
            if ">>>" not in (inspect.getdoc(obj) or "") and \
                    f"{module.__name__}.{name}" not in _NO_EXAMPLE:
                missing.append(f"{module.__name__}.{name}")
    assert not missing, f"public names without an example: {', '.join(missing)}"
