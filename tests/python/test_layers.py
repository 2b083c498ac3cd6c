"""The gstlandmark package in layers, read from its source (ast, nothing
imported): the library (top-level modules, synth/) imports nothing from
commands/ or devtools/; commands/ import the library and each other, not
devtools/; devtools/ may import both; commands.cli, the dispatcher, may
load any of them, and the sub-commands it names by string (``_lazy``) count
as its imports. The research tools in tools/ (not installed) may import
the package; the package never imports them. No import cycle,
function-level imports included, and no private name (``_x``) of one
module used by another. The checker is tried on planted packages so that
it can fail."""

import ast
import os

import pytest

SOURCE_ROOT = os.environ.get(
    "LANDMARK_SOURCE_ROOT",
    os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..")))
PACKAGE_DIR = os.path.join(SOURCE_ROOT, "python", "gstlandmark")
TOOLS_DIR = os.path.join(SOURCE_ROOT, "tools")
CLI = "gstlandmark.commands.cli"

# each may import leftwards
LAYERS = ("library", "commands", "devtools", "cli", "tools")


def modules(package_dir, package="gstlandmark"):
    """{module name: file path} of every .py file of the package."""
    found = {}
    for folder, dirs, files in os.walk(package_dir):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        rel = os.path.relpath(folder, package_dir)
        parts = [package] + ([] if rel == "." else rel.split(os.sep))
        for name in sorted(files):
            if not name.endswith(".py"):
                continue
            if name == "__init__.py":
                found[".".join(parts)] = os.path.join(folder, name)
            else:
                found[".".join(parts + [name[:-3]])] = os.path.join(folder,
                                                                    name)
    return found


def tool_modules(tools_dir):
    """{"tools.NAME": file path} of the scripts in tools/ (each imports
    another as ``NAME``, its folder being on sys.path when it runs)."""
    return {f"tools.{name[:-3]}": os.path.join(tools_dir, name)
            for name in sorted(os.listdir(tools_dir)) if name.endswith(".py")}


def layer(module):
    parts = module.split(".")
    if parts[0] == "tools":
        return "tools"
    if module == CLI:
        return "cli"
    return parts[1] if len(parts) > 1 and parts[1] in LAYERS[1:3] \
        else "library"


def _absolute(name, mods):
    """An absolute import's module; a tool's ``NAME`` is tools.NAME."""
    return f"tools.{name}" if f"tools.{name}" in mods else name


def _resolve(module, is_package, node):
    """The absolute module an ImportFrom names."""
    if node.level == 0:
        return node.module
    base = module.split(".")
    if not is_package:
        base = base[:-1]
    base = base[:len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imports(mods):
    """{module: {imported module of the package: [names it uses]}} and
    the private names used across modules, as (module, "target._name")."""
    graph, private = {}, []
    for mod, path in mods.items():
        with open(path, encoding="utf-8") as f:
            tree = ast.parse(f.read(), path)
        is_package = path.endswith("__init__.py")
        edges, bound = {}, {}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    name = _absolute(alias.name, mods)
                    if name in mods:
                        edges.setdefault(name, [])
                        bound[alias.asname or alias.name] = name
            elif (mod == CLI and isinstance(node, ast.Call)
                  and getattr(node.func, "id", None) == "_lazy"):
                edges.setdefault(f"gstlandmark.{node.args[0].value}", [])
            elif isinstance(node, ast.ImportFrom):
                target = _resolve(mod, is_package, node)
                if node.level == 0:
                    target = _absolute(target, mods)
                for alias in node.names:
                    sub = f"{target}.{alias.name}"
                    if sub in mods:           # a module: from . import x
                        edges.setdefault(sub, [])
                        bound[alias.asname or alias.name] = sub
                    elif target in mods:      # a name: from .x import f
                        edges.setdefault(target, []).append(alias.name)
                        if alias.name.startswith("_") and not (
                                alias.name.startswith("__")):
                            private.append((mod, f"{target}.{alias.name}"))
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute)
                    and isinstance(node.value, ast.Name)
                    and node.value.id in bound
                    and node.attr.startswith("_")
                    and not node.attr.startswith("__")):
                private.append((mod, f"{bound[node.value.id]}.{node.attr}"))
        edges.pop(mod, None)
        graph[mod] = edges
    return graph, private


def layer_breaks(graph):
    """(importer, imported) pairs that import a later layer."""
    return sorted((a, b) for a, edges in graph.items() for b in edges
                  if LAYERS.index(layer(b)) > LAYERS.index(layer(a)))


def cycles(graph):
    """The import cycles, each as the list of its modules (Tarjan's
    strongly connected components larger than one module)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


@pytest.fixture(scope="module")
def package():
    mods = {**modules(PACKAGE_DIR), **tool_modules(TOOLS_DIR)}
    graph, private = imports(mods)
    return mods, graph, private


def test_the_layers_are_there(package):
    mods, _, _ = package
    for name in ("gstlandmark.pipeline", "gstlandmark.landmarkmap",
                 "gstlandmark.commands.cli", "gstlandmark.commands.runner",
                 "gstlandmark.devtools.bench", "gstlandmark.devtools.soak"):
        assert name in mods
    assert "gstlandmark.scenes" not in mods
    assert {layer(m) for m in mods} == set(LAYERS)
    # the research tools are not in the installed package
    for name in ("sigmastudy", "odometrydraws", "mapreuse"):
        assert f"tools.{name}" in mods
        assert f"gstlandmark.devtools.{name}" not in mods


def test_the_dispatcher_loads_its_sub_commands(package):
    _, graph, _ = package
    assert "gstlandmark.devtools.bench" in graph[CLI]
    assert "gstlandmark.commands.console" in graph[CLI] or any(
        m.startswith("gstlandmark.commands.") for m in graph[CLI])


def test_no_import_cycle(package):
    _, graph, _ = package
    assert cycles(graph) == []


def test_no_layer_imports_a_later_one(package):
    _, graph, _ = package
    assert layer_breaks(graph) == []


def test_no_private_name_across_modules(package):
    _, _, private = package
    assert private == []


def test_commands_are_registered_by_module_name(package):
    """cli lists its sub-commands by name (no import): each must be a
    module of commands/ or devtools/."""
    mods, _, _ = package
    with open(mods["gstlandmark.commands.cli"], encoding="utf-8") as f:
        tree = ast.parse(f.read())
    named = [node.args[0].value for node in ast.walk(tree)
             if isinstance(node, ast.Call)
             and getattr(node.func, "id", None) == "_lazy"]
    assert len(named) >= 10
    for name in named:
        assert f"gstlandmark.{name}" in mods, name
        assert layer(f"gstlandmark.{name}") in LAYERS[1:], name


def _plant(root, files):
    for rel, text in files.items():
        path = root / "gstlandmark" / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return modules(str(root / "gstlandmark"))


def test_the_checker_finds_a_planted_cycle_and_layer_break(tmp_path):
    mods = _plant(tmp_path, {
        "__init__.py": "",
        "meta.py": "from .commands.runner import run\n",      # library up
        "commands/__init__.py": "",
        "commands/runner.py": "def f():\n    from . import common\n",
        "commands/common.py": "from .runner import _quiet\n",  # cycle
        "devtools/__init__.py": "",
        "devtools/bench.py": "from ..commands import common\n"
                             "import gstlandmark.meta as m\nm._x\n",
    })
    graph, private = imports(mods)
    assert cycles(graph) == [["gstlandmark.commands.common",
                              "gstlandmark.commands.runner"]]
    assert layer_breaks(graph) == [("gstlandmark.meta",
                                    "gstlandmark.commands.runner")]
    assert sorted(private) == [
        ("gstlandmark.commands.common",
         "gstlandmark.commands.runner._quiet"),
        ("gstlandmark.devtools.bench", "gstlandmark.meta._x")]


def test_the_checker_sees_the_dispatchers_names_and_the_tools(tmp_path):
    """A sub-command named by string is an import of the dispatcher (a
    tool importing the dispatcher is a cycle); a tool's bare import of
    another tool resolves to it; the package importing a tool breaks."""
    mods = _plant(tmp_path, {
        "__init__.py": "",
        "meta.py": "import study\n",
        "commands/__init__.py": "",
        "commands/cli.py": "_lazy('devtools.bench', 'add')\n",
        "devtools/__init__.py": "",
        "devtools/bench.py": "from ..commands.cli import main\n",
    })
    tools = tmp_path / "tools"
    tools.mkdir()
    (tools / "study.py").write_text("from helper import _f\n"
                                    "from gstlandmark import meta\n")
    (tools / "helper.py").write_text("")
    mods.update(tool_modules(str(tools)))
    graph, private = imports(mods)
    assert graph[CLI] == {"gstlandmark.devtools.bench": []}
    assert sorted(cycles(graph)) == [
        sorted([CLI, "gstlandmark.devtools.bench"]),
        ["gstlandmark.meta", "tools.study"]]
    assert layer_breaks(graph) == [
        ("gstlandmark.devtools.bench", CLI),
        ("gstlandmark.meta", "tools.study")]
    assert private == [("tools.study", "tools.helper._f")]


def test_the_checker_passes_a_clean_planted_package(tmp_path):
    mods = _plant(tmp_path, {
        "__init__.py": "",
        "meta.py": "import json\n",
        "commands/__init__.py": "",
        "commands/run.py": "from .. import meta\n",
        "devtools/__init__.py": "",
        "devtools/soak.py": "from ..commands import run\n"
                            "from .. import meta\n",
    })
    graph, private = imports(mods)
    assert cycles(graph) == [] and layer_breaks(graph) == []
    assert private == []
    assert graph["gstlandmark.devtools.soak"] == {
        "gstlandmark.commands.run": [], "gstlandmark.meta": []}
