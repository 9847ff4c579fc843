"""The type stubs describe the compiled core as it is, and ship with the package."""

import ast
import pathlib

import crandall
from crandall import _core

PKG = pathlib.Path(crandall.__file__).parent


def stub_tree():
    return ast.parse((PKG / "_core.pyi").read_text())


def test_stub_and_marker_are_installed():
    assert (PKG / "py.typed").exists()
    assert (PKG / "_core.pyi").exists()


def test_stub_names_match_the_module():
    tree = stub_tree()
    declared = set()
    members = {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            declared.add(node.name)
        elif isinstance(node, ast.AnnAssign):
            declared.add(node.target.id)
        if isinstance(node, ast.ClassDef):
            members[node.name] = {n.name if isinstance(n, ast.FunctionDef) else n.target.id
                                  for n in node.body
                                  if isinstance(n, (ast.FunctionDef, ast.AnnAssign))}
    public = {n for n in dir(_core) if not n.startswith("_")}
    assert declared == public
    for cls, names in members.items():
        actual = {n for n in dir(getattr(_core, cls)) if not n.startswith("_")}
        assert {n for n in names if not n.startswith("_")} == actual, cls
