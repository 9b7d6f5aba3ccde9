"""The docs site (mkdocs.yml, docs/) covers the public API and every page, without building it.

``make docs`` builds the site strictly (a broken link or a failing API reference stops it);
these checks need no mkdocs: every name in ``gearbench.__all__`` has a docstring and an entry
(``::: dotted.path``) on an API reference page that resolves to that very object, every page
under docs/ and every generated page is in mkdocs.yml's nav (and every nav entry exists), the
generated effect pages render, and the README stays a few screens whose links resolve.
"""
from __future__ import annotations

import importlib
import re
import sys

import pytest
import yaml

import gearbench
from conftest import REPO

DOCS = REPO / "docs"
API = DOCS / "api"
DIRECTIVE = re.compile(r"^::: *([\w.]+)\s*$", re.M)

sys.path.insert(0, str(REPO / "tools"))
import docs_pages  # noqa: E402  (tools/docs_pages.py: the pages mkdocs-gen-files writes)


def resolve(path: str):
    """The object a ``::: path`` directive names: the longest importable module prefix, then
    attributes."""
    parts = path.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for name in parts[i:]:
            obj = getattr(obj, name)
        return obj
    raise ImportError(path)


def directives() -> list[tuple[str, str, list[str] | None]]:
    """Every ``:::`` directive of the API pages: (page, path, its ``members:`` list or None)."""
    out = []
    for page in sorted(API.glob("*.md")):
        text = page.read_text(encoding="utf-8")
        for m in DIRECTIVE.finditer(text):
            block = text[m.end():].split(":::", 1)[0]
            members = re.search(r"^\s+members:\n((?:\s+- \w+\n)+)", block, re.M)
            names = re.findall(r"- (\w+)", members.group(1)) if members else None
            out.append((page.name, m.group(1), names))
    return out


def documented_objects() -> list[object]:
    """The objects the API pages document: each directive's object, and a module directive's
    members (its listed ``members:``, else every public name defined in that module)."""
    objs = []
    for _page, path, members in directives():
        obj = resolve(path)
        objs.append(obj)
        if isinstance(obj, type(sys)):
            names = members if members is not None else [
                n for n, v in vars(obj).items() if not n.startswith("_")
                and getattr(v, "__module__", None) == obj.__name__]
            objs += [getattr(obj, n) for n in names]
    return objs


def nav_paths(node) -> list[str]:
    if isinstance(node, str):
        return [node]
    if isinstance(node, list):
        return [p for item in node for p in nav_paths(item)]
    if isinstance(node, dict):
        return [p for v in node.values() for p in nav_paths(v)]
    return []


NAV = nav_paths(yaml.safe_load((REPO / "mkdocs.yml").read_text(encoding="utf-8"))["nav"])
GENERATED = docs_pages.effect_pages()


@pytest.mark.parametrize("name", gearbench.__all__)
def test_every_public_name_has_a_docstring(name):
    obj = getattr(gearbench, name)
    doc = (obj.__doc__ or "").strip()
    assert doc, f"gearbench.{name} has no docstring"


def test_every_directive_resolves():
    found = directives()
    assert len(found) >= len(gearbench.__all__) - 5
    for page, path, _members in found:
        try:
            resolve(path)
        except (ImportError, AttributeError) as exc:
            pytest.fail(f"docs/api/{page}: ::: {path} does not resolve: {exc}")


@pytest.mark.parametrize("name", gearbench.__all__)
def test_every_public_name_is_in_the_api_reference(name):
    obj = getattr(gearbench, name)
    assert any(o is obj for o in documented_objects()), (
        f"gearbench.{name} is on no API reference page: add "
        f"'::: {obj.__module__}.{obj.__qualname__}' to one of docs/api/*.md")


def test_the_errors_and_the_effect_interface_are_documented():
    from gearbench import errors
    from gearbench.plant.effects import base
    objs = documented_objects()
    public_errors = [v for n, v in vars(errors).items() if isinstance(v, type) and issubclass(v, BaseException)
                     and v.__module__ == errors.__name__ and not n.startswith("_")]
    assert public_errors
    for obj in [*public_errors, base.Effect, base.Param, base.register]:
        assert any(o is obj for o in objs), f"{obj.__qualname__} is on no API reference page"


def test_every_page_is_in_the_nav_and_every_nav_entry_exists():
    pages = {p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md")} | set(GENERATED)
    missing = sorted(pages - set(NAV))
    assert not missing, f"pages missing from mkdocs.yml's nav: {missing}"
    dangling = sorted(set(NAV) - pages)
    assert not dangling, f"nav entries with no page: {dangling}"


def test_each_registered_effect_has_a_generated_page():
    from gearbench.plant.effects import names
    for name in names():
        page = GENERATED[f"effects/{name}.md"]
        for heading in ("## Equation and units", "## Parameters", "## Signature", "## What it is confused with"):
            assert heading in page, f"effects/{name}.md lacks {heading!r}"
        assert f"effects/{name}.md" in NAV


def test_the_figures_the_pages_copy_exist():
    for rel in docs_pages.FIGURES:
        assert (REPO / rel).is_file(), f"{rel} (tools/docs_pages.py FIGURES) is not in the repository"


def test_the_readme_is_a_few_screens_and_its_links_resolve():
    text = (REPO / "README.md").read_text(encoding="utf-8")
    n = len(text.splitlines())
    assert 100 <= n <= 250, f"README.md has {n} lines"
    assert "make test" in text and "## Citation" in text
    for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
        if "://" in target:
            continue
        assert (REPO / target).exists(), f"README.md links to {target}, which does not exist"
