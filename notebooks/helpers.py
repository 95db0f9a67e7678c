"""What the study notebooks share: where the data are, and the ``bayescal`` command line run
the way a user runs it, with its JSON document handed back.

The notebooks run with ``notebooks/`` as their working directory; the real recordings live in
``../shared/data`` beside the repository and are read in place, never copied.
"""

import atexit
import json
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parent.parent
DATA = REPOSITORY.parent / "shared" / "data"


def work_folder(name: str) -> Path:
    """A fresh temporary folder for what a notebook writes (JSON, simulated recordings),
    removed when the kernel exits."""
    folder = Path(tempfile.mkdtemp(prefix=f"bayescal-{name}-"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return folder


def _shown(argument: str) -> str:
    """A path as a user would type it: the shared data relative to the repository."""
    text = str(argument)
    return text.replace(str(DATA), "../shared/data")


def bayescal(*arguments, tail: int | None = None) -> dict | None:
    """Run ``bayescal ARGUMENTS...`` with this kernel's Python (so the same installation),
    print the command and what it prints (its last ``tail`` lines only, when given), and
    return the document written to ``--json PATH`` (None without --json).

    A string is command-line text and is split as a shell would (``"--channel gyro_z
    --pad"``); a :class:`~pathlib.Path` is one argument, spaces and all. A non-zero exit
    status — bad input (2), a failed posterior health check (1), a bug (3) — raises, with
    the command's message."""
    argv = []
    for argument in arguments:
        argv += [str(argument)] if isinstance(argument, Path) else shlex.split(str(argument))
    print("$ bayescal " + " ".join(shlex.quote(_shown(argument)) for argument in argv))
    done = subprocess.run(
        [sys.executable, "-m", "bayescal._cli", *argv],
        capture_output=True,
        text=True,
        check=False,
    )
    lines = done.stdout.rstrip().splitlines()
    if tail is not None and len(lines) > tail:
        lines = ["  [...]", *lines[-tail:]]
    print("\n".join(lines))
    if done.stderr.strip():
        print(done.stderr.rstrip())
    if done.returncode != 0:
        raise RuntimeError(f"bayescal exited with status {done.returncode}: {done.stderr}")
    if "--json" in argv:
        return json.loads(Path(argv[argv.index("--json") + 1]).read_text())
    return None
