"""Layer 8, the command line: argument parsing and exit codes over the library, nothing else.
Each command is a module with ``add_parser`` (the arguments; no heavy import, so that
``bayescal --help`` answers at once) and ``run`` (which calls the library and renders its
result).

Exit codes (../shared/DESIGN.md): 0 success, 1 an analysis ran but a health check failed,
2 bad input or usage, 3 an internal error (a bug: please report it; set BAYESCAL_DEBUG=1 to
see the traceback).
"""

from ._main import main as main
