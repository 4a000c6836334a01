"""The KiCad layer is the bottom layer: static import analysis (ast) of `pcbdata/kicad/*.py`.

Its modules may import the standard library, `pcbnew`, each other and the pure leaf modules
below; every import counts, including those inside functions. The leaves import nothing of
pcbdata but other leaves. Outside the KiCad layer nothing imports `pcbnew` or starts processes
(`subprocess`): every KiCad call (pcbnew and kicad-cli) runs in `KicadPool` workers.
"""
from __future__ import annotations

import ast
import sys
from pathlib import Path

from tests.conftest import REPO_ROOT

PACKAGE = REPO_ROOT / "pcbdata"
LEAVES = {"pcbdata.core.errors", "pcbdata.core.hashing", "pcbdata.core.textio", "pcbdata.core.tree",
          "pcbdata.core.sexpr_text", "pcbdata.core.ratsnest", "pcbdata.core.copper_geometry",
          "pcbdata.core.copper_text", "pcbdata.core.fsutil"}
THIRD_PARTY_ALLOWED = {"pcbnew"}
#: Pure numerics and geometry, no KiCad: the leaves may use them (cut-file check, Specctra
#: boundary inset, pad outlines).
LEAF_THIRD_PARTY = {"numpy", "shapely"}


def _imports(path: Path) -> list[tuple[int, str]]:
    """(line, module) of every import statement of a file, nested ones included."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"{path}:{node.lineno}: relative import"
            out.append((node.lineno, node.module or ""))
            # `from pcbdata import x` imports the module pcbdata.x when x is one
            out += [(node.lineno, f"{node.module}.{alias.name}") for alias in node.names
                    if node.module == "pcbdata"]
    return out


def _module_of(path: Path) -> str:
    parts = path.relative_to(REPO_ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _allowed(module: str, extra: set[str]) -> bool:
    top = module.split(".")[0]
    return (top == "__future__" or top in sys.stdlib_module_names or module in extra
            or module == "pcbdata.kicad" or module.startswith("pcbdata.kicad."))


#: Text work-arounds beside their one user (`specctra.py`): pure geometry, no KiCad, so they
#: may use what the leaves use.
GEOMETRY_ONLY = {"specctra_text.py", "specctra_pads.py"}


def test_the_kicad_layer_imports_nothing_above_it():
    bad = []
    for path in sorted((PACKAGE / "kicad").glob("*.py")):
        for line, module in _imports(path):
            if module == "pcbdata":
                continue  # `from pcbdata import x`: x is checked on its own
            if path.name in GEOMETRY_ONLY and module.split(".")[0] in LEAF_THIRD_PARTY:
                continue
            if not _allowed(module, LEAVES | THIRD_PARTY_ALLOWED):
                bad.append(f"{path.relative_to(REPO_ROOT)}:{line}: imports {module}")
    assert not bad, "the KiCad layer imports upward:\n" + "\n".join(bad)


def test_the_leaf_modules_import_only_the_standard_library_and_other_leaves():
    bad = []
    for module in sorted(LEAVES):
        path = REPO_ROOT / (module.replace(".", "/") + ".py")
        assert path.is_file(), module
        for line, imported in _imports(path):
            top = imported.split(".")[0]
            if not (top == "__future__" or top in sys.stdlib_module_names or imported in LEAVES
                    or top in LEAF_THIRD_PARTY):
                bad.append(f"{module}:{line}: imports {imported}")
    assert not bad, "\n".join(bad)


def test_only_the_kicad_layer_imports_pcbnew_or_starts_processes():
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if _module_of(path).startswith("pcbdata.kicad"):
            continue
        for line, module in _imports(path):
            if module.split(".")[0] in ("pcbnew", "subprocess"):
                bad.append(f"{path.relative_to(REPO_ROOT)}:{line}: imports {module}")
    assert not bad, "KiCad runs only inside KicadPool workers:\n" + "\n".join(bad)


def test_the_analysis_sees_nested_and_from_imports(tmp_path):
    sample = tmp_path / "sample.py"
    sample.write_text("import os\n\ndef f():\n    from pcbdata.build.d3 import is_kept\n"
                      "    import pcbnew\n")
    found = [module for _, module in _imports(sample)]
    assert found == ["os", "pcbdata.build.d3", "pcbnew"]
    assert not _allowed("pcbdata.build.d3", LEAVES)
