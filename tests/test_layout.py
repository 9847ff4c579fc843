"""The package's layout: no import cycles, no crandall import hidden inside a function, no
C++ function longer than a screen."""

import ast
import pathlib
import re

import pytest

PACKAGE = pathlib.Path(__file__).resolve().parents[1] / "python" / "crandall"
# Modules another part of the project owns and still imports lazily.
ALLOWED_LAZY = {"analytic.physical"}


def _module_name(path: pathlib.Path) -> str:
    rel = path.relative_to(PACKAGE).with_suffix("")
    parts = [p for p in rel.parts if p != "__init__"]
    return ".".join(parts)


def _is_module(name: str) -> bool:
    base = PACKAGE.joinpath(*name.split(".")) if name else PACKAGE
    return base.with_suffix(".py").exists() or base.with_suffix(".pyi").exists() or base.is_dir()


def _imports(path: pathlib.Path, node) -> set:
    """The crandall modules an import statement names (relative to the package)."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    if isinstance(node, ast.ImportFrom):
        if node.level == 0:
            if not (node.module or "").startswith("crandall"):
                return out
            base = node.module[len("crandall"):].lstrip(".")
        else:
            base = package
            for _ in range(node.level - 1):
                base = base.rpartition(".")[0]
            if node.module:
                base = f"{base}.{node.module}" if base else node.module
        for alias in node.names:
            sub = f"{base}.{alias.name}" if base else alias.name
            out.add(sub if _is_module(sub) else base)
    else:
        for alias in node.names:
            if alias.name.startswith("crandall"):
                out.add(alias.name[len("crandall"):].lstrip("."))
    return out


def _graph():
    graph, lazy = {}, []
    for path in PACKAGE.rglob("*.py"):
        tree = ast.parse(path.read_text())
        name = _module_name(path)
        deps = set()
        for node in tree.body:
            for n in ast.walk(node) if isinstance(node, (ast.If, ast.Try)) else [node]:
                if isinstance(n, (ast.Import, ast.ImportFrom)):
                    deps |= _imports(path, n)
        graph[name] = deps - {name}
        for f in ast.walk(tree):
            if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef)):
                for n in ast.walk(f):
                    if isinstance(n, (ast.Import, ast.ImportFrom)) and _imports(path, n):
                        lazy.append((name, f.name))
    return graph, lazy


def test_no_import_cycles():
    graph, _ = _graph()
    # A package imports its modules and they import siblings: only module-to-module edges
    # that do not go through a package's own __init__ can close a cycle.
    packages = {"", "analytic"}
    edges = {m: {d for d in deps if d in graph and d not in packages}
             for m, deps in graph.items() if m not in packages}
    state = {}

    def visit(m, stack):
        state[m] = "open"
        for d in edges.get(m, ()):
            assert state.get(d) != "open", f"import cycle: {' -> '.join(stack + [d])}"
            if d not in state:
                visit(d, stack + [d])
        state[m] = "done"

    for m in edges:
        if m not in state:
            visit(m, [m])


def test_no_crandall_import_inside_a_function():
    _, lazy = _graph()
    assert [x for x in lazy if x[0] not in ALLOWED_LAZY] == []


def test_no_module_is_longer_than_700_lines():
    # Each module is one concern that reads in one sitting (docs/architecture.md): results,
    # adaptive, tail, cli, plots, fragility and records were split into packages and scene's
    # checks moved to scene_checks so that none grows past 700 lines again.
    for path in PACKAGE.rglob("*.py"):
        lines = len(path.read_text().splitlines())
        assert lines <= 700, (str(path.relative_to(PACKAGE)), lines)


def test_presentation_never_calls_the_core():
    graph, _ = _graph()
    presentation = [m for m in graph if m.split(".")[0] in ("plots", "cli", "paper", "__main__")]
    assert {"plots", "plots.figures", "cli", "cli.commands", "paper"} <= set(presentation)
    for m in presentation:
        assert "_core" not in graph[m], m


def _reach(graph, module):
    seen, todo = set(), [module]
    while todo:
        for d in graph.get(todo.pop(), ()):
            if d not in seen:
                seen.add(d)
                todo.append(d)
    return seen


def test_results_do_not_run_engines():
    # A result holds data: its bias is asked of the engine layer through a hook
    # (results.set_bias_estimator, installed by crandall.bias), never imported.
    graph, _ = _graph()
    engines = {"engine", "simulate", "adaptive", "bias", "checkpoint"}
    for m in ("results", "_dataset", "io", "distributions", "model", "streams"):
        # a package's modules (adaptive.engine) count as the package
        hits = sorted(d for d in _reach(graph, m) if d.split(".")[0] in engines)
        assert not hits, (m, hits)


def test_the_check_resolves_the_imports_it_must_see():
    # So that the tests above can fail: relative, absolute and compiled-module imports.
    src = PACKAGE / "paper.py"
    for text, want in (("from . import io", {"io"}), ("from .io import load", {"io"}),
                       ("import crandall.io", {"io"}), ("from . import _core", {"_core"}),
                       ("from .analytic import laws", {"analytic.laws"}),
                       ("import numpy", set())):
        assert _imports(src, ast.parse(text).body[0]) == want, text


def test_import_crandall_leaves_the_heavy_parts_for_later():
    # scipy (through the analytic layer) is imported when a scene first needs it, not by
    # `import crandall` (bins.analytic is a lazy stand-in, crandall._lazy).
    import subprocess
    import sys
    code = ("import sys, crandall; heavy = [m for m in ('scipy', 'crandall.analytic', "
            "'matplotlib', 'xarray', 'pandas', 'distributed') if m in sys.modules]; "
            "print(','.join(heavy))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert done.stdout.strip() == "", done.stdout


def test_the_lazy_subpackages_are_reachable_after_a_plain_import():
    # The README writes crandall.envelopes.amin_ang(...) and messages crandall.analytic.physical
    # after a plain `import crandall`: both are attributes of the package, imported (with
    # scipy) when first read, not before.
    import subprocess
    import sys
    code = ("import sys, crandall; before = 'scipy' in sys.modules or 'crandall.envelopes' in "
            "sys.modules; env = crandall.envelopes.amin_ang(0.6, t1=2.0, t2=8.0, c=0.4); "
            "import crandall.envelopes as e; from crandall import analytic; "
            "print(before, env.pieces, crandall.envelopes is e, "
            "analytic is sys.modules['crandall.analytic'], callable(analytic.physical))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.stdout.split() == ["False", "32", "True", "True", "True"], done.stderr
    code = "import crandall; crandall.nonesuch"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert "AttributeError: module 'crandall' has no attribute 'nonesuch'" in done.stderr


def test_type_checkers_see_the_lazy_subpackages_and_no_catch_all(tmp_path):
    # The lazy attributes are a module __getattr__ at run time only: a type checker that saw
    # it would accept any crandall.<misspelt name> as Any.
    pytest.importorskip("mypy")
    import os
    import subprocess
    import sys
    path = tmp_path / "uses.py"
    path.write_text("import crandall\nenv = crandall.envelopes.amin_ang(0.6, t1=2.0, t2=8.0, "
                    "c=0.4)\nreveal_type(env)\ncrandall.simulat\n")
    env = dict(os.environ, MYPYPATH=str(PACKAGE.parent))
    done = subprocess.run([sys.executable, "-m", "mypy", "--follow-imports=silent",
                           "--ignore-missing-imports", "--cache-dir", str(tmp_path / "cache"),
                           str(path)], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert 'Revealed type is "crandall.envelopes.Envelope"' in done.stdout, done.stdout
    assert 'Module has no attribute "simulat"' in done.stdout, done.stdout


CPP = PACKAGE.parents[1] / "cpp"
# The longest a C++ function may be, from the line of its opening brace to the line of its
# closing one (docs/architecture.md, "The path loop as small parts").
MAX_FUNCTION_LINES = 120
# Functions still longer, each with the reason; an entry that is gone or has come under the
# limit fails the test, so the list can only shrink.
LONG_FUNCTIONS: set = set()


def _code_only(text: str) -> str:
    """The text with comments, string and character literals blanked (newlines kept)."""
    out, i, n = [], 0, len(text)
    while i < n:
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.index("*/", i) + 2
            out.append("\n" * text.count("\n", i, j))
            i = j
        elif text.startswith('R"(', i):
            j = text.index(')"', i) + 2
            out.append("\n" * text.count("\n", i, j))
            i = j
        elif text[i] in "\"'":
            quote, j = text[i], i + 1
            while j < n and text[j] != quote:
                j += 2 if text[j] == "\\" else 1
            out.append(quote * 2)
            i = j + 1
        else:
            out.append(text[i])
            i += 1
    return "".join(out)


_CONTROL = re.compile(r"\b(if|for|while|switch|catch)\s*$")
_TRAILER = re.compile(r"(\s*(const|noexcept|override|final|mutable|->\s*[\w:<>,\s*&]+"
                      r"|\[\[[^\]]*\]\]))+$")


def _function_name(code: str, open_brace: int):
    """The name of the function whose body opens at `open_brace`, or None for any other brace
    (a class, a namespace, an initialiser, a loop's or a branch's block, a lambda's)."""
    head = _TRAILER.sub("", code[:open_brace].rstrip())
    if not head.endswith(")"):
        return None
    depth, i = 0, len(head) - 1
    while i >= 0:  # back to the parenthesis that opens the parameter list
        depth += {")": 1, "(": -1}.get(head[i], 0)
        if depth == 0:
            break
        i -= 1
    before = head[:i].rstrip()
    if _CONTROL.search(before) or before.endswith("]") or not before:
        return None  # a control statement, a lambda
    name = re.search(r"([~\w:]+)\s*$", before)
    return name.group(1).split("::")[-1] if name else None


def function_lengths(text: str):
    """(name, first line, lines) of every function body not inside another one."""
    code, stack, out = _code_only(text), [], []
    for m in re.finditer(r"[{}]", code):
        if m.group() == "{":
            stack.append((m.start(), _function_name(code, m.start())))
            continue
        if not stack:
            continue
        start, name = stack.pop()
        if name is not None and not any(n is not None for _, n in stack):
            first = code.count("\n", 0, start) + 1
            out.append((name, first, code.count("\n", 0, m.start()) + 2 - first))
    return out


def test_the_function_scan_measures_what_it_should():
    # So that the test below can fail: a function's lines, its name, braces in strings,
    # comments and lambdas, and control blocks that are not functions.
    text = ('namespace a {\nstruct S {\n  int f() const {\n    return 1;\n  }\n};\n'
            'void g(int x) {\n  // }\n  const char* s = "}{";\n  auto l = [](int y) {\n'
            '    return y;\n  };\n  if (x) {\n    x = 2;\n  }\n}\n}  // namespace a\n')
    assert function_lengths(text) == [("f", 3, 3), ("g", 7, 10)]


def test_no_cpp_function_is_longer_than_120_lines():
    long = {}
    for path in sorted(CPP.rglob("*")):
        if path.suffix not in (".cpp", ".hpp", ".inc"):
            continue
        rel = str(path.relative_to(CPP))
        for name, first, lines in function_lengths(path.read_text()):
            if lines > MAX_FUNCTION_LINES:
                long[(rel, name)] = (first, lines)
    assert set(long) - LONG_FUNCTIONS == set(), long
    assert LONG_FUNCTIONS - set(long) == set(), "no longer long: remove from LONG_FUNCTIONS"


# long double is x87's 80-bit format on x86-64, IEEE quad on aarch64 and double elsewhere: a
# result computed in it has other bits on another machine. The core's own code (cpp/src,
# cpp/include) uses none; the C++ tests may, for references.
_LONG_DOUBLE = re.compile(r"\blong\s+double\b"
                          r"|(?<![\w.])(\d+\.\d*|\.\d+|\d+(?=[eE]))([eE][+-]?\d+)?[lL]\b")


def long_double_lines(text: str):
    """The lines whose code (comments and strings left out) names long double or has a long
    double literal."""
    code = _code_only(text)
    return sorted({code.count("\n", 0, m.start()) + 1 for m in _LONG_DOUBLE.finditer(code)})


def test_the_long_double_scan_finds_what_it_should():
    # So that the test below can fail: the type, its literals, and not a comment, a string,
    # a long integer or a name.
    text = ('// long double in a comment\nlong  double x = 1;\nconst char* s = "long double";\n'
            'auto y = 0.5L;\nlong n = 1L;\nauto z = 1e-21L + .5l;\nint long_doubles = 2;\n'
            'double w = 1.0;\n')
    assert long_double_lines(text) == [2, 4, 6]


def test_the_core_uses_no_long_double():
    found = {}
    for top in ("src", "include"):
        for path in sorted((CPP / top).rglob("*")):
            if path.suffix in (".cpp", ".hpp", ".inc", ".h"):
                lines = long_double_lines(path.read_text())
                if lines:
                    found[str(path.relative_to(CPP))] = lines
    assert found == {}, found
