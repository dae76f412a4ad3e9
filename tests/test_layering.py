"""Data flows one way: the sanity layer builds on rules, so rules/ never imports it, and the installed package
never imports tests/, which is not installed; not even inside a function."""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1]  # discern/
RULES = PACKAGE / "rules"
INSTALLED = ("adapters", "monitor", "rules", "sanity", "scenarios")  # pyproject's package-dir


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


def imports_of(files: list[Path], package: str) -> list[str]:
    """Where any of `files` imports `package` or a module of it, as "path:line: module"."""
    return [f"{path.relative_to(PACKAGE)}:{line}: {module}" for path in files
            for line, module in imported_modules(path.read_text(encoding="utf-8"),
                                                 ".".join(("discern",) + path.relative_to(PACKAGE).parent.parts))
            if module == package or module.startswith(package + ".")]


def test_no_module_under_rules_imports_the_sanity_layer():
    files = sorted(RULES.rglob("*.py"))
    assert len(files) > 10
    assert imports_of(files, "discern.sanity") == []


def test_the_import_check_sees_the_sanity_layer_however_it_is_imported():
    sources = ["def f():\n    from discern.sanity import default_providers\n", "from ..sanity.window import X\n",
               "from .. import sanity\n", "import discern.sanity.window\n", "from discern import sanity\n"]
    for source in sources:
        assert any(m.startswith("discern.sanity") for _, m in imported_modules(source, "discern.rules")), source
    assert not any(m.startswith("discern.sanity") for _, m in imported_modules("from .facts import Params\n",
                                                                                 "discern.rules"))


def test_no_module_of_the_installed_package_imports_the_tests():
    """The scene builder and the worked examples are test data in tests/, which pip does not install."""
    files = sorted(path for folder in INSTALLED for path in (PACKAGE / folder).rglob("*.py"))
    assert len(files) > 50
    assert imports_of(files, "tests") == []


def test_the_import_check_sees_the_tests_however_they_are_imported():
    sources = ["def f():\n    from tests.scenes import scene\n", "import tests.worked_examples\n",
               "from tests import scenes\n"]
    for source in sources:
        modules = [m for _, m in imported_modules(source, "discern.sanity")]
        assert any(m == "tests" or m.startswith("tests.") for m in modules), source
