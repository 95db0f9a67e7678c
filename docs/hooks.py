"""MkDocs hooks.

The studies that read real recordings need ../shared/data beside the repository (read in place,
never copied). Where it is absent (a clean checkout elsewhere), those notebooks are rendered
without being executed, and each such page opens with a note that says so, so that the build
still checks every other page and every notebook that can run. Which notebooks need the data is
their own metadata (``"bayescal": {"requires": ["shared_data"]}``).

The notebooks' kernels inherit this process's environment: JAX's persistent compilation cache
is switched on there as the command line does (``~/.cache/bayescal/jax``), so that a notebook
reuses what another, or an earlier build, compiled. Its key is the compiled computation itself,
so a change of the library can never be served a stale result (unlike mkdocs-jupyter's page
cache, which mkdocs.yml leaves off).

The pages' equations (``\\( ... \\)`` and ``\\[ ... \\]``, marked by pymdownx.arithmatex) are
converted to MathML when the site is built (latex2mathml), which browsers render natively: the
site needs no script from a CDN and reads the same offline.
"""

import html
import json
import logging
import re
from pathlib import Path

from latex2mathml.converter import convert

from bayescal.cli._main import _enable_compilation_cache

REPOSITORY = Path(__file__).resolve().parents[1]
SHARED_DATA = REPOSITORY.parent / "shared" / "data"
NOTEBOOKS = REPOSITORY / "notebooks"

log = logging.getLogger("mkdocs.hooks.bayescal")
_unexecuted: set[str] = set()


def _needs_shared_data(notebook: Path) -> bool:
    metadata = json.loads(notebook.read_text(encoding="utf-8")).get("metadata", {})
    return "shared_data" in metadata.get("bayescal", {}).get("requires", [])


def on_config(config):
    _enable_compilation_cache()
    if SHARED_DATA.is_dir():
        return config
    plugin = config.plugins["mkdocs-jupyter"]
    for notebook in sorted(NOTEBOOKS.glob("*.ipynb")):
        if _needs_shared_data(notebook):
            plugin.config["execute_ignore"].append(f"notebooks/{notebook.name}")
            _unexecuted.add(notebook.name)
            log.info("%s not executed: %s is absent", notebook.name, SHARED_DATA)
    return config


_INLINE = re.compile(r'<span class="arithmatex">\\\((.+?)\\\)</span>', re.S)
_DISPLAY = re.compile(r'<div class="arithmatex">\\\[(.+?)\\\]</div>', re.S)


def _mathml(match: re.Match, display: str) -> str:
    return convert(html.unescape(match[1]).strip(), display=display)


def on_page_content(content, page, config, files):
    content = _DISPLAY.sub(lambda match: _mathml(match, "block"), content)
    content = _INLINE.sub(lambda match: _mathml(match, "inline"), content)
    if Path(page.file.src_uri).name in _unexecuted:
        note = (
            '<div class="admonition warning"><p class="admonition-title">Not executed</p>'
            "<p>This build had no <code>../shared/data</code>, which this study reads; it is "
            "shown without its outputs.</p></div>"
        )
        return note + content
    return content
