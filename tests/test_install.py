"""A package that installs: the wheel built from this checkout, installed (not editable) into a
fresh virtual environment outside the repository, answers ``bayescal noise --sensor`` and
``bc.sensor_cards()`` from its own files. The sensor cards live in the repository's ``models/``
folder and reach the wheel as the package data ``bayescal/_cards``; a plain ``pip install .``
once had none of them."""

import json
import os
import shutil
import site
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from recording_files import write_csv

import bayescal as bc

ROOT = Path(__file__).resolve().parents[1]


def _run(command, **options):
    return subprocess.run(
        [str(part) for part in command], capture_output=True, text=True, check=False, **options
    )


def test_the_wheel_installs_outside_the_repository_with_its_sensor_cards(tmp_path):
    # Without PYTHONPATH and away from the checkout: only the installed package can be found.
    environment = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    # Built from a copy: a build writes build/ and bayescal.egg-info beside its sources.
    source = tmp_path / "source"
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, source / name)
    for name in ("bayescal", "models"):
        shutil.copytree(ROOT / name, source / name, ignore=shutil.ignore_patterns("__pycache__"))
    wheels = tmp_path / "wheels"
    built = _run(
        [sys.executable, "-m", "pip", "wheel", source, "--no-deps", "-w", wheels, "-q"],
        env=environment,
    )
    output = built.stdout + built.stderr
    if built.returncode != 0 and "install build dependencies" in output:
        pytest.skip(f"the build backend (setuptools) cannot be installed here: {output[-300:]}")
    assert built.returncode == 0, output
    (wheel,) = wheels.glob("bayescal-*.whl")

    names = set(zipfile.ZipFile(wheel).namelist())
    packages = sorted(path.parent for path in (ROOT / "bayescal").rglob("__init__.py"))
    missing = [
        str(package.relative_to(ROOT))
        for package in packages
        if f"{package.relative_to(ROOT).as_posix()}/__init__.py" not in names
    ]
    assert not missing, f"packages not in the wheel (pyproject.toml lists them): {missing}"
    cards = sorted(path.name for path in (ROOT / "models").glob("*.toml"))
    assert cards and all(f"bayescal/_cards/{card}" in names for card in cards)

    # A fresh environment: the wheel alone, its dependencies seen through a .pth file from this
    # one (the editable bayescal of this one is not: a .pth line adds a folder to the path, and
    # the .pth files inside that folder, the editable install's among them, are not read).
    venv = tmp_path / "venv"
    made = _run([sys.executable, "-m", "venv", "--without-pip", venv], env=environment)
    assert made.returncode == 0, made.stderr
    python = venv / "bin" / "python"
    (target,) = venv.glob("lib/python*/site-packages")
    (target / "dependencies.pth").write_text("\n".join(site.getsitepackages()) + "\n")
    installed = _run(
        [sys.executable, "-m", "pip", "--python", python, "install", "--no-deps", "--no-index",
         "-q", wheel],
        env=environment,
    )  # fmt: skip
    assert installed.returncode == 0, installed.stdout + installed.stderr

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    probe = _run(
        [python, "-c",
         "import json, bayescal as bc; print(json.dumps({'file': bc.__file__, "
         "'cards': [card.name for card in bc.sensor_cards()], "
         "'folder': str(bc.find_card('mpu-6050').path.parent)}))"],
        cwd=elsewhere, env=environment,
    )  # fmt: skip
    assert probe.returncode == 0, probe.stderr
    found = json.loads(probe.stdout)
    assert found["file"].startswith(str(venv)), found["file"]
    assert found["folder"].startswith(str(venv)) and found["folder"].endswith("bayescal/_cards")
    assert found["cards"] == [card.name for card in bc.sensor_cards()]

    rng = np.random.default_rng(5)
    recording = write_csv(
        elsewhere / "rec.csv",
        {"time": np.arange(2000) / 100, "gyro_x": 0.1 + 0.01 * rng.standard_normal(2000)},
    )
    noise = _run(
        [venv / "bin" / "bayescal", "noise", recording, "--channel", "gyro_x", "--terms",
         "white", "--sensor", "MPU-6050", "--json", elsewhere / "noise.json", "--quiet"],
        cwd=elsewhere, env=environment,
    )  # fmt: skip
    assert noise.returncode in (0, 1), noise.stderr
    prior = json.loads((elsewhere / "noise.json").read_text())["bayesian"]["prior"]
    assert prior.startswith("sensor card MPU-6050 (")
