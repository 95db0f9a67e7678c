"""Open a page in headless chromium, as the tests of the HTML report and the docs site do:
the DOM after the page's scripts ran, and how many of its images the browser decoded."""

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

_CHECKER = """<script>
window.addEventListener("load", function () {
  var images = Array.from(document.images);
  var decoded = images.filter(function (img) { return img.complete && img.naturalWidth > 0; });
  var marker = document.createElement("div");
  marker.id = "bayescal-image-check";
  marker.textContent = "images " + decoded.length + "/" + images.length;
  document.body.appendChild(marker);
});
</script>"""
_CHECKED = re.compile(r'id="bayescal-image-check">images (\d+)/(\d+)<')


def chromium() -> str:
    """The browser's executable; skips where there is none, fails in CI (which installs it)."""
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail("chromium is not installed (.ci/run installs Debian's chromium)")
    pytest.skip("chromium not installed (apt-get install chromium); CI installs it")


def run_browser(binary, profile, *arguments) -> subprocess.CompletedProcess:
    """Headless chromium with ``arguments``, a fresh profile and nothing in the background."""
    command = [
        binary,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--disable-dev-shm-usage",
        f"--user-data-dir={profile}",
        *arguments,
    ]
    return subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)


def rendered(page: Path, profile: Path) -> tuple[str, int, int]:
    """The DOM of ``page`` once loaded, with the count of images decoded and of all images.

    A copy of the page with a load handler that counts the images is opened beside the page
    (so its relative links resolve as the page's own do)."""
    checked = page.with_name(f"{page.stem}.checked{page.suffix}")
    checked.write_text(page.read_text().replace("</body>", _CHECKER + "</body>"))
    try:
        result = run_browser(
            chromium(), profile, "--virtual-time-budget=10000", "--dump-dom", checked.as_uri()
        )
    finally:
        checked.unlink()
    assert result.returncode == 0, result.stderr[-2000:]
    match = _CHECKED.search(result.stdout)
    assert match, f"{page.name}: the load handler did not run: " + result.stderr[-2000:]
    return result.stdout, int(match[1]), int(match[2])


_FOLLOWER = """<script>
window.addEventListener("load", function () {
  var marker = document.createElement("div");
  marker.id = "bayescal-link-check";
  var link = document.querySelector(SELECTOR);
  if (!link) {
    marker.textContent = "link none";
    document.body.appendChild(marker);
    return;
  }
  link.click();
  setTimeout(function () {
    var target = document.querySelector(":target");
    var top = target ? Math.round(target.getBoundingClientRect().top) : -1;
    marker.textContent = ["link", location.hash, target ? target.id : "none", top,
                          window.innerHeight, Math.round(window.scrollY)].join(" ");
    document.body.appendChild(marker);
  }, 200);
});
</script>"""
_FOLLOWED = re.compile(r'id="bayescal-link-check">link (\S*) (\S*) (-?\d+) (\d+) (\d+)<')


def followed(page: Path, selector: str, profile: Path) -> dict:
    """Click the first link of ``page`` that the CSS ``selector`` finds, in the browser, and
    say where it went: the URL's fragment, the id of the element it targets (``:target``),
    that element's distance from the top of the window and the window's height, px, and how
    far the page scrolled, px."""
    import json

    checked = page.with_name(f"{page.stem}.followed{page.suffix}")
    script = _FOLLOWER.replace("SELECTOR", json.dumps(selector))
    checked.write_text(page.read_text().replace("</body>", script + "</body>"))
    try:
        result = run_browser(
            chromium(),
            profile,
            "--virtual-time-budget=10000",
            "--window-size=1280,900",
            "--dump-dom",
            checked.as_uri(),
        )
    finally:
        checked.unlink()
    assert result.returncode == 0, result.stderr[-2000:]
    none = 'id="bayescal-link-check">link none<' in result.stdout
    assert not none, f"{page.name}: no link matches {selector}"
    match = _FOLLOWED.search(result.stdout)
    assert match, f"{page.name}: the click handler did not run: " + result.stderr[-2000:]
    hash_, target, top, height, scrolled = match.groups()
    return {
        "hash": hash_,
        "target": target,
        "top": int(top),
        "height": int(height),
        "scrolled": int(scrolled),
    }
