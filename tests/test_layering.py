"""Data flows one way, and the sanity layer builds on rules: rules/ never imports it, not even inside a function."""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1]  # discern/
RULES = PACKAGE / "rules"


def imported_modules(source: str, package: str) -> list[tuple[int, str]]:
    """Every module an import statement at any depth names (and, for `from M import N`, M.N), made absolute."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found.extend((node.lineno, alias.name) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            parts = package.split(".")
            base = ".".join(parts[:len(parts) - node.level + 1] if node.level else [])
            module = ".".join(p for p in (base, node.module or "") if p)
            found.append((node.lineno, module))
            found.extend((node.lineno, f"{module}.{alias.name}") for alias in node.names)
    return found


def test_no_module_under_rules_imports_the_sanity_layer():
    files = sorted(RULES.rglob("*.py"))
    assert len(files) > 10
    offending = [f"{path.relative_to(PACKAGE)}:{line}: {module}" for path in files
                 for line, module in imported_modules(path.read_text(encoding="utf-8"),
                                                      ".".join(("discern",) + path.relative_to(PACKAGE).parent.parts))
                 if module == "discern.sanity" or module.startswith("discern.sanity.")]
    assert offending == []


def test_the_import_check_sees_the_sanity_layer_however_it_is_imported():
    sources = ["def f():\n    from discern.sanity import default_providers\n", "from ..sanity.window import X\n",
               "from .. import sanity\n", "import discern.sanity.window\n", "from discern import sanity\n"]
    for source in sources:
        assert any(m.startswith("discern.sanity") for _, m in imported_modules(source, "discern.rules")), source
    assert not any(m.startswith("discern.sanity") for _, m in imported_modules("from .facts import Params\n",
                                                                                 "discern.rules"))
