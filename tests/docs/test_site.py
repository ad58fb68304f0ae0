"""The documentation site as a reader meets it: built by the README's command (Sphinx, warnings
as errors, the tutorials executed), then opened in headless Chromium.

Checks: the landing page, an env page with its animation and the API page render without
console errors; the site's search finds an env id; every image of those pages loads (and every
image file a page of the site names exists); screenshots of three pages are written to
``$RBENV_SITE_SHOTS`` (default ``docs/_build/screenshots``) for a person to look at.

The build needs the ``docs`` extra (Sphinx, furo, MyST-NB); the browser checks also need
Playwright's Python package (the same extra) and Debian's ``chromium``; each skips and says
which is missing.
"""

from __future__ import annotations

import functools
import http.server
import os
import re
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # builds the site and opens it in Chromium (CI runs it)

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
BUILD_COMMAND = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                 "docs"]

pytest.importorskip("sphinx", reason="sphinx is not installed (docs extra)")
pytest.importorskip("myst_nb", reason="myst-nb is not installed (docs extra)")

CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update",
                 "--disable-sync"]


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site, built as the README says (into a temporary folder)."""
    out = tmp_path_factory.mktemp("site")
    done = subprocess.run([*BUILD_COMMAND, str(out)], cwd=ROOT, capture_output=True, text=True,
                          timeout=900)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return out


@pytest.fixture(scope="module")
def server(site):
    """The built site on a loopback port (a browser's search needs http, not file://)."""
    handler = functools.partial(_QuietHandler, directory=str(site))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}"
    httpd.shutdown()
    httpd.server_close()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


@pytest.fixture(scope="module")
def browser():
    sync_api = pytest.importorskip("playwright.sync_api",
                                   reason="playwright is not installed (docs extra)")
    if CHROMIUM is None:
        pytest.skip("Debian's chromium is not installed (apt-get install chromium; .ci/run "
                    "installs it)")
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
        yield b
        b.close()


@pytest.fixture(scope="module")
def shots() -> Path:
    folder = Path(os.environ.get("RBENV_SITE_SHOTS", ROOT / "docs" / "_build" / "screenshots"))
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _open(browser, url: str):
    """A page at ``url`` with its console errors and failed requests collected."""
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    problems: list[str] = []
    page.on("console", lambda m: problems.append(f"console {m.type}: {m.text}")
            if m.type == "error" else None)
    page.on("pageerror", lambda e: problems.append(f"page error: {e}"))
    page.on("requestfailed", lambda r: problems.append(f"request failed: {r.url}"))
    page.on("response", lambda r: problems.append(f"HTTP {r.status}: {r.url}")
            if r.status >= 400 else None)
    page.goto(url, wait_until="networkidle")
    return page, problems


def _broken_images(page) -> list[str]:
    """The page's <img> elements that did not load (no natural size)."""
    return page.eval_on_selector_all(
        "img", "imgs => imgs.filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.src)")


PAGES = {"landing": "/index.html", "env": "/reference/envs/SatelliteReorient-v1.html",
         "api": "/reference/api.html"}


@pytest.mark.parametrize("name", list(PAGES))
def test_page_renders_without_errors_and_its_images_load(browser, server, shots, name):
    page, problems = _open(browser, server + PAGES[name])
    assert page.title()  # furo sets "<page> - rbenv <version>"
    assert problems == []
    images = page.eval_on_selector_all("img", "imgs => imgs.map(i => i.src)")
    assert bool(images) == (name != "api"), images  # the API page has none
    assert _broken_images(page) == []
    page.screenshot(path=str(shots / f"{name}.png"), full_page=False)
    assert (shots / f"{name}.png").stat().st_size > 10_000
    page.close()


def test_env_page_shows_its_animation_and_facts(browser, server):
    page, problems = _open(browser, server + PAGES["env"])
    gif = page.locator("img[src$='SatelliteReorient-v1.gif']")
    assert gif.count() == 1
    size = gif.evaluate("i => [i.naturalWidth, i.naturalHeight]")
    assert size == [240, 240]
    text = page.inner_text("article")
    for fact in ("Box(-1.0, 1.0, (12,), float32)", "cubesat-12u", "Version History"):
        assert fact in text
    assert problems == []
    page.close()


def test_search_finds_an_env_id(browser, server):
    page, problems = _open(browser, server + "/search.html?q=SatelliteDetumble")
    page.wait_for_selector("ul.search li", timeout=30_000)
    hits = page.eval_on_selector_all("ul.search li a", "links => links.map(a => a.href)")
    assert any("SatelliteDetumble-v1" in h for h in hits), hits
    assert problems == []
    page.close()


def test_every_image_a_page_names_exists(site):
    """Every <img src> of every built page points at a file of the site."""
    missing = []
    for html in site.rglob("*.html"):
        for src in re.findall(r'<img[^>]+src="([^"]+)"', html.read_text(errors="replace")):
            if "://" in src or src.startswith("data:"):
                continue
            if not (html.parent / src.split("#")[0].split("?")[0]).exists():
                missing.append(f"{html.relative_to(site)}: {src}")
    assert missing == []


def test_every_env_and_scene_has_a_page(site):
    import gymnasium as gym

    import rbenv

    ids = [k for k in gym.registry if k.startswith("rbenv/")]
    assert len(ids) >= 8
    for env_id in ids:
        assert (site / "reference" / "envs" / f"{env_id.split('/')[1]}.html").exists()
    for scene in rbenv.list_scenes():
        page = (site / "reference" / "scenes" / f"{scene}.html").read_text()
        assert "Sources" in page and "The file" in page
