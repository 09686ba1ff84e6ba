"""The documentation site: ``mkdocs build --strict`` succeeds (warnings are errors, the
quickstart notebook executes), every internal link and anchor of the built site resolves, the
API reference has ``run_scenario``, and the pages render in headless Chromium with a clean
console.

The site is built once into a temporary directory, or taken from ``RTSIM_SITE_DIR`` when
``.ci/run`` has built it already. The docs tooling comes with the ``test`` extra; a missing
install is a failure that says how to fix it, not a skip.
"""

from __future__ import annotations

import functools
import http.server
import os
import re
import subprocess
import sys
import threading
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest
from chromium_cdp import find_chromium, load_page

ROOT = Path(__file__).resolve().parents[2]
#: Pages opened in the browser: the home page, a getting-started page, a model page, the API
#: reference and the executed notebook.
BROWSE = [
    "",
    "getting-started/",
    "model/adjustment/",
    "api/",
    "api/coupling/",
    "tutorials/quickstart/",
]


def _mkdocs() -> list[str]:
    try:
        import mkdocs  # noqa: F401
        import mkdocstrings  # noqa: F401
    except ImportError:
        pytest.fail('the docs tooling is missing: pip install -e ".[test]" (it includes docs)')
    return [sys.executable, "-m", "mkdocs"]


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    given = os.environ.get("RTSIM_SITE_DIR")
    if given:
        path = Path(given)
        assert (path / "index.html").is_file(), f"RTSIM_SITE_DIR={given} holds no built site"
        return path
    out = tmp_path_factory.mktemp("site")
    proc = subprocess.run(
        [*_mkdocs(), "build", "--strict", "--site-dir", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "MPLBACKEND": "Agg", "NO_MKDOCS_2_WARNING": "1"},
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return out


class _Links(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.links: list[str] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        for key, value in attrs:
            if value is None:
                continue
            if key in ("id", "name"):
                self.ids.add(value)
            elif key in ("href", "src") and tag in ("a", "img", "link", "script", "source"):
                self.links.append(value)


@functools.cache
def _parse(path: Path) -> _Links:
    p = _Links()
    p.feed(path.read_text(encoding="utf-8", errors="replace"))
    return p


def _target(site: Path, page: Path, link: str) -> tuple[Path, str] | None:
    parts = urlsplit(link)
    if parts.scheme or parts.netloc or link.startswith(("mailto:", "data:", "javascript:")):
        return None
    path = unquote(parts.path)
    base = page.parent
    target = (
        page if not path else (site / path.lstrip("/") if path.startswith("/") else base / path)
    )
    target = target.resolve()
    if target.is_dir() or path.endswith("/"):
        target = target / "index.html"
    return target, unquote(parts.fragment)


@pytest.mark.slow
def test_site_builds_strict_and_every_internal_link_resolves(site: Path) -> None:
    pages = sorted(site.rglob("*.html"))
    assert len(pages) > 30
    broken = []
    for page in pages:
        for link in _parse(page).links:
            hit = _target(site, page, link)
            if hit is None:
                continue
            target, fragment = hit
            if site.resolve() not in target.parents and target != site.resolve():
                broken.append(f"{page.relative_to(site)}: {link} (outside the site)")
            elif not target.is_file():
                broken.append(f"{page.relative_to(site)}: {link}")
            elif fragment and target.suffix == ".html" and fragment not in _parse(target).ids:
                broken.append(f"{page.relative_to(site)}: {link} (no anchor)")
    assert not broken, "\n".join(broken[:20])


def _url(md: Path) -> str:
    """The directory URL of a docs page (``a/b.md`` -> ``a/b/``, ``a/index.md`` -> ``a/``)."""
    rel = md.with_suffix("")
    return (
        rel.parent.as_posix() + "/" if rel.name == "index" else rel.as_posix() + "/"
    ).removeprefix("./")


def test_every_docs_page_is_in_the_site_and_its_navigation(site: Path) -> None:
    docs = ROOT / "docs"
    home = _parse(site / "index.html").links
    for md in sorted(docs.rglob("*.md")) + sorted(docs.rglob("*.ipynb")):
        url = _url(md.relative_to(docs))
        assert (site / url / "index.html").is_file(), f"docs/{md.relative_to(docs)}: no page"
        if url:
            assert url in home or f"./{url}" in home, f"docs/{md.relative_to(docs)}: not in nav"


def test_api_reference_documents_run_scenario(site: Path) -> None:
    html = (site / "api" / "coupling" / "index.html").read_text(encoding="utf-8")
    assert 'id="rtsim.coupling.run_scenario"' in html
    assert "duration_s" in html  # its signature and parameters are rendered
    top = (site / "api" / "index.html").read_text(encoding="utf-8")
    for name in ("run_scenario", "load_scenario", "simulate", "analyze"):
        assert re.search(rf'id="rtsim\.[a-z_.]+\.{name}"', top), name


def test_the_notebook_is_executed_in_the_build(site: Path) -> None:
    html = (site / "tutorials" / "quickstart" / "index.html").read_text(encoding="utf-8")
    assert "ScenarioResult" in html  # an output, not just the source
    assert html.count("data:image/png;base64,") >= 2  # its two figures


@pytest.fixture(scope="module")
def served(site: Path):
    handler = functools.partial(_QuietHandler, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args: object) -> None:
        pass


@pytest.mark.slow
def test_pages_render_in_chromium_with_a_clean_console(served: str) -> None:
    exe = find_chromium()
    if exe is None:
        if os.environ.get("RTSIM_REQUIRE_BROWSER") == "1":
            pytest.fail("RTSIM_REQUIRE_BROWSER=1 but no chromium found (apt-get install chromium)")
        pytest.skip("no chromium installed (set RTSIM_REQUIRE_BROWSER=1 to require it)")
    for url in BROWSE:
        page = load_page(served + url, exe)
        assert page.title.endswith("rtsim"), (url, page.title)
        assert page.console_errors == [], (url, page.console_errors)
        broken = [i["alt"] for i in page.images if not (i["complete"] and i["width"] > 0)]
        assert not broken, (url, broken)


def test_docs_tooling_is_declared() -> None:
    import tomllib

    meta = tomllib.loads((ROOT / "pyproject.toml").read_text("utf-8"))["project"]
    extras = meta["optional-dependencies"]
    names = {re.split(r"[<>=\[ ]", r, maxsplit=1)[0] for r in extras["docs"]}
    assert {"mkdocs", "mkdocs-material", "mkdocstrings", "mkdocs-jupyter"} <= names
    assert any(r.startswith("rtsim[docs]") for r in extras["test"])


#: A Sphinx role as it shows on a page when nothing renders it (``:class:`X``` → ":class:X").
SPHINX_ROLE = re.compile(r"(?<![\w:]):(?:py:)?(?:class|func|meth|data|mod|attr|exc|obj):(?=[`\w~])")


def test_no_page_shows_a_sphinx_role(site: Path) -> None:
    """The docstrings' cross-references are links or code on every page (issue 34: the API
    pages showed ``:class:``, ``:func:``, ``:meth:`` literally; tools/sphinx_roles.py)."""
    import html as html_lib

    shown = []
    for page in sorted(site.rglob("*.html")):
        text = html_lib.unescape(re.sub(r"<[^>]+>", "", page.read_text(encoding="utf-8")))
        for m in SPHINX_ROLE.finditer(text):
            shown.append(
                f"{page.relative_to(site)}: ...{text[max(0, m.start() - 40) : m.end() + 30]}"
            )
    assert not shown, shown[:5]
    api = (site / "api" / "index.html").read_text(encoding="utf-8")
    assert 'href="config/#rtsim.config.scenario.Scenario"' in api  # a role became a link
    assert "run_sweep" in api and "point_seed" in api  # the curated page's entry points
