"""The house rules of docs/architecture.md, checked: the packages are layers and each imports only from the
layers below it (so the library never imports the web app or the command line), the import graph has no
circle, the library's top level holds a few modules besides its packages, and the web app is packages only.
The 600-line cap on a module is a warning printed at the end of the run (tests/conftest.py), not a test."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MAX_LINES = 600

#: The layers, bottom to top: a module may import its own layer and the layers below it. A layer is one
#: package or a few top-level modules; two packages of one layer would be free to import each other, so
#: each package is a layer of its own.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("contactnet", "contactnet.frames", "contactnet.atomic", "contactnet.paths", "contactnet.strict_json",
     "contactnet.interrupt", "contactnet.plugins"),              # foundations
    ("contactnet.terrain",),
    ("contactnet.robots",),
    ("contactnet.motion",),                                      # gaits, trajectory optimizer, controller
    ("contactnet.sim",),
    ("contactnet.planning",),                                    # cost, network, planners, stand, capture
    ("contactnet.registry", "contactnet.records", "contactnet.locomotion"),  # the loop and the names
    ("contactnet.bench",),
    ("contactnet.jobs",),                                        # runner, datagen, train, experiments, paper
    ("app", "app.live"),                                         # the web tool, bottom to top
    ("app.scene",),
    ("app.recordings",),
    ("app.security",),
    ("app.viewer",),
    ("app.api",),
    ("app.bench",),
    ("contactnet.cli", "contactnet.__main__"),                   # the command line: serve starts the app
)
#: The most modules the library's top level holds beside its packages (``__init__`` and ``__main__`` aside).
MAX_TOP_LEVEL_MODULES = 10


def layer_of(module: str) -> int:
    """The index in `LAYERS` of the longest prefix naming the module's layer."""
    best, found = -1, None
    for index, names in enumerate(LAYERS):
        for name in names:
            if (module == name or module.startswith(name + ".")) and len(name) > best:
                best, found = len(name), index
    if found is None:
        raise LookupError(f"{module} is in no layer of tests/test_architecture.py: LAYERS")
    return found


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for folder in ("contactnet", "app") for p in sorted((ROOT / folder).rglob("*.py"))}


def _imports(path: Path, modules: dict[str, Path], name: str | None = None) -> set[str]:
    """Project modules a file (module ``name``) imports anywhere (module level or inside functions),
    resolved to files."""
    name_of_file = name or _module_name(path)
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            # ``from package import submodule`` imports the submodule; ``from module import name`` the module
            names = [f"{node.module}.{alias.name}" if f"{node.module}.{alias.name}" in modules else node.module
                     for alias in node.names]
        for name in names:
            while name and name not in modules:
                name = name.rpartition(".")[0]
            if name and name != name_of_file:
                found.add(name)
    return found


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(path, modules) for name, path in modules.items()}


def long_modules() -> list[str]:
    """Modules over `MAX_LINES` lines (for the warning at the end of a test run)."""
    return [f"{path.relative_to(ROOT)}: {n}" for path in _modules().values()
            if (n := len(path.read_text().splitlines())) > MAX_LINES]


def test_every_module_lies_in_a_layer():
    for module in _modules():
        layer_of(module)


def test_each_layer_imports_only_from_the_layers_below_it():
    up = [f"{module} (layer {layer_of(module)}) imports {target} (layer {layer_of(target)})"
          for module, targets in _graph().items() for target in sorted(targets)
          if layer_of(target) > layer_of(module)]
    assert not up, "\n".join(up)


def test_the_layer_check_sees_an_upward_import(tmp_path):
    """The check itself: a planning module importing the live session would be reported."""
    fake = tmp_path / "contactnet" / "planning" / "bad.py"
    fake.parent.mkdir(parents=True)
    fake.write_text("from app.live.session import LiveSession\n")
    modules = {**_modules(), "contactnet.planning.bad": fake}
    imported = _imports(fake, modules, "contactnet.planning.bad")
    assert imported == {"app.live.session"}
    assert layer_of("app.live.session") > layer_of("contactnet.planning.bad")


def test_the_top_level_shows_the_packages():
    top = sorted(p.stem for p in (ROOT / "contactnet").glob("*.py") if p.stem not in ("__init__", "__main__"))
    assert len(top) <= MAX_TOP_LEVEL_MODULES, top
    assert sorted(p.name for p in (ROOT / "app").glob("*.py")) == ["__init__.py"]
    for package in [*(ROOT / "contactnet").glob("*/__init__.py"), *(ROOT / "app").glob("*/__init__.py")]:
        face = ast.parse(package.read_text())
        assert ast.get_docstring(face), f"{package.relative_to(ROOT)}: a package says what it holds"


def _is_command_line(module: str) -> bool:
    return module == "contactnet.__main__" or module == "contactnet.cli" or module.startswith("contactnet.cli.")


def test_the_library_never_imports_the_app_or_the_command_line():
    bad = [f"{module} imports {target}" for module, targets in _graph().items()
           if module.startswith("contactnet") and not _is_command_line(module)
           for target in targets if target.startswith("app") or _is_command_line(target)]
    assert not bad, "\n".join(bad)


def test_the_app_does_not_import_the_command_line():
    bad = [module for module, targets in _graph().items() if module.startswith("app") and any(map(_is_command_line, targets))]
    assert not bad


def test_no_import_circle():
    graph = _graph()
    state: dict[str, int] = {}
    stack: list[str] = []
    circles: list[list[str]] = []

    def visit(node: str) -> None:
        state[node] = 1
        stack.append(node)
        for target in sorted(graph.get(node, ())):
            if state.get(target) == 1:
                circles.append(stack[stack.index(target):] + [target])
            elif target not in state:
                visit(target)
        stack.pop()
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node)
    assert not circles, "\n".join(" -> ".join(c) for c in circles)
