"""The documentation site (issue 19), built as CI builds it: ``mkdocs build --strict`` from this
checkout (a broken link or cross-reference, a docstring griffe cannot parse, or a study notebook
cell that raises fails the build; the notebooks are executed by the build, in a kernel of this
environment), then the built pages opened in headless chromium: the API page documents every
public name, and each study page shows its figures."""

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import nbformat
import pytest
from browser import rendered

import bayescal

REPOSITORY = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((REPOSITORY / "notebooks").glob("*.ipynb"))
BUILD_TIMEOUT_S = 1800
FIGURE = re.compile(r'<img[^>]*src="data:image/(?:png|svg\+xml)')


def _needs_shared_data(path: Path) -> bool:
    metadata = nbformat.read(path, as_version=4).metadata
    return "shared_data" in metadata.get("bayescal", {}).get("requires", [])


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site, built once for this module's tests (the notebooks' execution is most of it)."""
    folder = tmp_path_factory.mktemp("docs")
    scratch = folder / "tmp"
    scratch.mkdir()
    environment = {
        **os.environ,
        "BAYESCAL_DOCS_EXECUTE": "true",
        "NO_MKDOCS_2_WARNING": "1",
        # What the notebooks write to temporary folders lands in this test's folder.
        "TMPDIR": str(scratch),
    }
    started = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(folder / "site")],
        cwd=REPOSITORY,
        env=environment,
        capture_output=True,
        text=True,
        timeout=BUILD_TIMEOUT_S,
        check=False,
    )
    assert result.returncode == 0, (result.stdout + result.stderr)[-6000:]
    print(f"mkdocs build --strict (notebooks executed): {time.perf_counter() - started:.0f} s")
    return folder / "site"


def test_api_page_documents_every_public_name(site, tmp_path):
    dom, _, _ = rendered(site / "api" / "index.html", tmp_path / "profile")
    undocumented = [
        name
        for name, module in bayescal._EXPORTS.items()
        if f'id="bayescal.{module}.{name}"' not in dom
    ]
    assert not undocumented, f"no entry on the API page for {undocumented}"
    # The numpydoc sections are rendered as sections, not as raw text.
    for heading in ("Parameters:", "Returns:", "Raises:", "Examples:"):
        assert heading in dom, heading
    assert "----------" not in dom
    # In this test, not one of its own: each xdist worker that runs a test of this module
    # builds the site (minutes).
    _check_documented_defaults(site)


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda path: path.name)
def test_study_page_shows_its_figures(site, path, request, tmp_path):
    if _needs_shared_data(path):
        # Without ../shared/data the build renders this study unexecuted (docs/hooks.py).
        request.getfixturevalue("shared_data")
    page = site / "studies" / path.stem / "index.html"
    dom, decoded, total = rendered(page, tmp_path / "profile")
    figures = len(FIGURE.findall(page.read_text()))
    assert figures > 0, f"{path.name}: the executed study has no figure"
    assert decoded == total and total >= figures, f"{decoded} of {total} images decoded"
    assert "Not executed" not in dom
    assert 'class="jp-OutputArea' in dom or 'class="output_area' in dom


_HEADING = re.compile(r'<h\d id="(bayescal\.[\w.]+)" class="doc doc-heading"')
_ROW = re.compile(
    r'<tr class="doc-section-item">\s*<td>\s*<code>([^<]+)</code>\s*</td>.*?</td>\s*<td>.*?'
    r"</td>\s*<td>\s*(.*?)\s*</td>\s*</tr>",
    re.S,
)


def _documented_object(path: str):
    """(module, object) of a dotted path on the API page (a module, then attributes)."""
    import importlib

    parts = path.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            module = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        found = module
        for part in parts[cut:]:
            found = getattr(found, part)
        return module, found
    raise LookupError(path)


def _check_documented_defaults(site):
    """The Default column of every Parameters table on the API page, evaluated where the object
    lives, equals the default of its signature ("required" where there is none): the page
    reads them from the signatures (docs/griffe_extensions.py, SignatureDefaults), so a
    docstring cannot make them stale (a fit_fleet page once showed gaps=None, its default
    "error", and 31 other rows documented in pairs wrongly)."""
    import html
    import inspect

    page = (site / "api" / "index.html").read_text()
    headings = [(match.start(), match.group(1)) for match in _HEADING.finditer(page)]
    wrong, checked = [], 0
    for index, (start, path) in enumerate(headings):
        end = headings[index + 1][0] if index + 1 < len(headings) else len(page)
        section = page[start:end]
        at = section.find("Parameters:")
        if at < 0:
            continue
        table = section[at : section.find("</table>", at)]
        module, documented = _documented_object(path)
        target = documented.__init__ if inspect.isclass(documented) else documented
        try:
            parameters = inspect.signature(target).parameters
        except (TypeError, ValueError):
            continue
        for names, cell in _ROW.findall(table):
            shown = html.unescape(re.sub(r"<[^>]+>", "", cell)).strip()
            for name in (n.strip() for n in names.split(",")):
                if name.startswith("*") or name not in parameters:
                    continue
                checked += 1
                default = parameters[name].default
                if default is inspect.Parameter.empty:
                    if shown != "required":
                        wrong.append(f"{path}({name}): page {shown!r}, required")
                elif shown == "required" or eval(shown, vars(module)) != default:
                    wrong.append(f"{path}({name}): page {shown!r}, signature {default!r}")
    assert checked > 200, checked
    assert not wrong, wrong
