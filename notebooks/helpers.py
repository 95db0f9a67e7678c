"""What the study notebooks share: where the data are, and a temporary folder for what a
notebook writes.

The notebooks run with ``notebooks/`` as their working directory; the real recordings live in
``../shared/data`` beside the repository and are read in place, never copied.
"""

import atexit
import shutil
import tempfile
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parent.parent
DATA = REPOSITORY.parent / "shared" / "data"


def work_folder(name: str) -> Path:
    """A fresh temporary folder for what a notebook writes (a calibration file, say), removed
    when the kernel exits."""
    folder = Path(tempfile.mkdtemp(prefix=f"bayescal-{name}-"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return folder
