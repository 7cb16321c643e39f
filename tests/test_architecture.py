"""The layout contract, read from the source itself (no imports of the code under test):

- the planner's layers import only downwards, a method never imports another method, and nothing in the
  planner, the operators or the panels forms an import cycle, counting imports inside functions;
- the planner never uses Blender, and nobody drives a private scipy module;
- no Blender-layer function is longer than 120 lines;
- the README stays short, and user-facing text names methods by what they do, not by internal ids.
"""
import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CORE = "flank_addon"
# bottom to top; a module may import its own layer and those below
LAYERS = ("progress", "collector", "geometry", "tooling", "io", "simulation", "methods", "exports", "machining",
          "posts", "report", "cli")
INTERNAL_IDS = re.compile(r"(?<![A-Za-z0-9_])s00[0-4](?![A-Za-z0-9_])|\b[Ii]ssue \d+")
BLENDER_MODULES = {"bpy", "mathutils", "bmesh", "blf", "gpu", "imbuf", "bl_operators", "bl_ui", "bpy_extras"}


def _modules(*tops):
    """dotted module name -> path, for the packages ``tops`` (relative to the repo root)."""
    out = {}
    for top in tops:
        for path in sorted((ROOT / top).rglob("*.py")):
            rel = path.relative_to(ROOT).with_suffix("")
            parts = list(rel.parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = path
    return out


def _is_package(name, mods):
    return (ROOT / Path(*name.split(".")) / "__init__.py").is_file()


def _imports(name, path, mods):
    """Project modules imported anywhere in ``path`` (module level or inside functions)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = name if _is_package(name, mods) else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name in mods:
                    found.add(a.name)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)] if node.level > 1 else base
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            for a in node.names:
                sub = f"{target}.{a.name}"
                if sub in mods:
                    found.add(sub)
                elif target in mods:
                    found.add(target)
    found.discard(name)
    return found


def _graph(*tops):
    mods = _modules(*tops)
    return {m: _imports(m, p, mods) for m, p in mods.items()}, mods


def _cycles(graph):
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def _layer(mod):
    parts = mod.split(".")
    if len(parts) == 1:
        return None                       # flank_addon/__init__: documentation only
    key = parts[1]
    if key == "__main__":
        return len(LAYERS)
    return LAYERS.index(key)


def test_no_import_cycles_in_the_planner_or_the_blender_layer():
    graph, _ = _graph(CORE, "operators", "panels")
    assert _cycles(graph) == []


def test_the_planner_imports_only_downwards():
    graph, _ = _graph(CORE)
    # the reader sees lazy and relative imports: a few edges every layout has
    assert "flank_addon.simulation.verify" in graph["flank_addon.methods.single_flank.planner"]
    assert "flank_addon.geometry.screw" in graph["flank_addon.simulation.sweep"]
    assert sum(map(len, graph.values())) > 80
    bad = []
    for mod, deps in graph.items():
        lm = _layer(mod)
        for d in deps:
            ld = _layer(d)
            if lm is not None and ld is not None and ld > lm:
                bad.append(f"{mod} -> {d}")
    assert bad == []


def test_a_method_never_imports_another_method():
    graph, _ = _graph(CORE)
    bad = []
    for mod, deps in graph.items():
        p = mod.split(".")
        if len(p) > 2 and p[1] == "methods":
            for d in deps:
                q = d.split(".")
                if len(q) > 2 and q[1] == "methods" and q[2] != p[2]:
                    bad.append(f"{mod} -> {d}")
    assert bad == []


def test_every_method_has_a_subpackage_of_its_own():
    names = sorted(p.name for p in (ROOT / CORE / "methods").iterdir() if (p / "__init__.py").is_file())
    assert names == ["double_flank", "formed_cutter", "freeform_g1", "paraboloid_groove", "single_flank"]


def test_the_planner_never_uses_blender():
    used = []
    for path in sorted((ROOT / CORE).rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        if "bpy" in text:
            used.append(f"{path.relative_to(ROOT)}: mentions bpy")
        for node in ast.walk(ast.parse(text)):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level:
                names = [node.module or ""]
            used += [f"{path.relative_to(ROOT)}: imports {n}" for n in names
                     if n.split(".")[0] in BLENDER_MODULES]
    assert used == []


def test_no_private_scipy_module_anywhere():
    private = []
    for top in (CORE, "operators", "panels", "tools", "bench", "tests"):
        for path in sorted((ROOT / top).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                names = []
                if isinstance(node, ast.Import):
                    names = [a.name for a in node.names]
                elif isinstance(node, ast.ImportFrom) and not node.level:
                    names = [node.module or ""] + [f"{node.module}.{a.name}" for a in node.names]
                for n in names:
                    parts = n.split(".")
                    if parts[0] == "scipy" and any(p.startswith("_") for p in parts[1:]):
                        private.append(f"{path.relative_to(ROOT)}: {n}")
    assert private == []


def _long_functions(paths, limit):
    out = []
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > limit:
                    out.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({n} lines)")
    return out


def test_no_blender_layer_function_is_longer_than_120_lines():
    paths = sorted((ROOT / "operators").rglob("*.py")) + sorted((ROOT / "panels").rglob("*.py")) + [
        ROOT / "__init__.py"]
    assert _long_functions(paths, 120) == []


def test_readme_is_short_and_user_text_has_no_internal_ids():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(readme.splitlines()) <= 250
    hits = []
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if INTERNAL_IDS.search(line):
                hits.append(f"{path.relative_to(ROOT)}:{k}: {line.strip()[:80]}")
    for top in ("operators", "panels"):
        for path in sorted((ROOT / top).rglob("*.py")):
            for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                if INTERNAL_IDS.search(line):
                    hits.append(f"{path.relative_to(ROOT)}:{k}: {line.strip()[:80]}")
    assert hits == []


def test_cli_help_names_methods_not_internal_ids(capsys):
    from flank_addon.cli import main

    assert main(["--help"]) == 0
    top = capsys.readouterr().out
    commands = re.search(r"{([a-z,-]+)}", top).group(1).split(",")
    texts = [top]
    for cmd in commands:
        assert main([cmd, "--help"]) == 0
        texts.append(capsys.readouterr().out)
    assert len(texts) >= 12
    joined = " ".join("\n".join(texts).split())
    assert not INTERNAL_IDS.search(joined), INTERNAL_IDS.search(joined)
    for name in ("single-flank conical", "double-flank custom tool", "formed disc cutter", "paraboloid groove",
                 "free-form G1"):
        assert name in joined, name


@pytest.mark.parametrize("argv, option, value", [
    (["plan", "single-flank", "--mesh", "m.stl", "--flank-point", "-10,2,3", "--out", "p.json"],
     "flank_point", (-10.0, 2.0, 3.0)),
    (["plan", "freeform", "--mesh", "m.stl", "--direction", "-0.3,0,1", "--point", "-1e-3,-2,3.5",
      "--out", "p.json"], "direction", (-0.3, 0.0, 1.0)),
    (["plan", "double-flank", "--builtin", "nilson-male", "--valley-point", "-1.5,-2,-3", "--out", "p.json"],
     "valley_point", (-1.5, -2.0, -3.0)),
    (["export", "p.json", "--cl", "x.apt", "--z-range", "-5,5"], "z_range", (-5.0, 5.0)),
])
def test_negative_numbers_in_comma_lists_need_no_equals_sign(argv, option, value):
    from flank_addon.cli import attach_negative_lists, build_parser

    assert getattr(build_parser().parse_args(attach_negative_lists(argv)), option) == value


def test_a_bad_comma_list_is_refused_by_name(capsys):
    from flank_addon.cli import main

    assert main(["plan", "freeform", "--mesh", "m.stl", "--direction", "-0.3,0", "--out", "p.json"]) == 2
    assert "--direction: '-0.3,0' must be three finite numbers X,Y,Z" in capsys.readouterr().err
