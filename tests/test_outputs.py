"""All or nothing: the files of a run appear together when it succeeds, with the mode the umask
allows, and none of them — no temporary, no folder it made — when it fails, is interrupted
(Ctrl-C, exit 130) or terminated (SIGTERM, exit 143)."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from recording_files import write_csv

from bayescal._errors import InputError
from bayescal._output import Outputs, write_json

ROOT = Path(__file__).resolve().parents[1]


def test_files_appear_together_or_not_at_all(tmp_path):
    folder = tmp_path / "made"
    with Outputs() as outputs:
        outputs.folder(folder, "--out")
        write_json(folder / "a.json", {"a": 1})
        write_json(tmp_path / "b.json", {"b": 2})
        assert not (folder / "a.json").exists() and not (tmp_path / "b.json").exists()
    assert json.loads((folder / "a.json").read_text()) == {"a": 1}
    assert json.loads((tmp_path / "b.json").read_text()) == {"b": 2}

    other = tmp_path / "other"
    with pytest.raises(RuntimeError), Outputs() as outputs:
        outputs.folder(other, "--out")
        write_json(other / "c.json", {"c": 3})
        write_json(tmp_path / "b.json", {"b": "new"})
        raise RuntimeError("the analysis failed")
    assert not other.exists()
    assert json.loads((tmp_path / "b.json").read_text()) == {"b": 2}
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["a.json", "b.json", "made"]


def test_outputs_honour_the_umask(tmp_path):
    previous = os.umask(0o027)
    try:
        with Outputs():
            write_json(tmp_path / "shared.json", {})
    finally:
        os.umask(previous)
    assert (tmp_path / "shared.json").stat().st_mode & 0o777 == 0o640


def test_an_output_may_not_be_an_input_or_another_output(tmp_path):
    recording = tmp_path / "rec.csv"
    recording.write_text("time,gyro_x\n")
    outputs = Outputs([recording])
    with pytest.raises(InputError, match="is an input of this run"):
        outputs.claim(tmp_path / "." / "rec.csv", "--json")
    outputs.claim(tmp_path / "out.json", "--json")
    with pytest.raises(InputError, match="--json already writes to this file"):
        outputs.claim(tmp_path / "out.json", "--export kalibr")
    with Outputs() as staged, pytest.raises(InputError, match="two outputs of this run"):
        write_json(tmp_path / "x.json", {})
        staged.stage(tmp_path / "x.json")


def test_a_failure_late_in_a_run_leaves_nothing(run_cli, tmp_path, monkeypatch):
    """The JSON is written before the exports; an export that fails takes the JSON with it."""
    rng = np.random.default_rng(0)
    path = write_csv(
        tmp_path / "rec.csv",
        {"time": np.arange(2000) / 100, "gyro_x": 0.1 + 0.01 * rng.standard_normal(2000)},
    )

    def fail(plans, result):
        raise InputError("the export failed")

    monkeypatch.setattr("bayescal.report._export.write_exports", fail)
    out = tmp_path / "out"
    code, _, stderr = run_cli(
        "noise", path, "--channel", "gyro_x", "--classical-only", "--json", tmp_path / "n.json",
        "--out", out, "--export", "kalibr", tmp_path / "imu.yaml",
    )  # fmt: skip
    assert code == 2 and "the export failed" in stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rec.csv"]


_SAID = {signal.SIGTERM: (143, "terminated"), signal.SIGINT: (130, "interrupted")}


def _noise_run(recording, folder):
    """``bayescal noise`` with a short posterior (white noise alone), writing a JSON and an
    --out folder (the posterior's netCDF) into ``folder``, as a process of its own."""
    folder.mkdir()
    environment = {**os.environ, "PYTHONPATH": str(ROOT), "JAX_PLATFORMS": "cpu"}
    return subprocess.Popen(
        [sys.executable, "-c", "import sys; from bayescal.cli import main; sys.exit(main())",
         "noise", str(recording), "--channel", "gyro_x", "--terms", "white",
         "--json", str(folder / "n.json"), "--out", str(folder / "posterior"), "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=environment,
    )  # fmt: skip


def _files(folder):
    return sorted(str(path.relative_to(folder)) for path in folder.rglob("*"))


def test_a_signal_at_any_moment_ends_the_run_quietly(tmp_path):
    """SIGTERM and SIGINT, in turn, at eight moments spread over a whole Bayesian run (loading
    the modules, reading, JAX's compilations and optimisation, emcee, the checks, the
    writers): each run ends with one line, the shell's code (143, 130) and no file at all,
    never a traceback. A signal after the outputs are in place is too late to stop them: the
    run's files are all there and nothing is said (exit 0, or the signal's own end if it
    came during the interpreter's teardown, when Python has put back the default handler)."""
    rng = np.random.default_rng(1)
    recording = write_csv(
        tmp_path / "rec.csv",
        {"time": np.arange(2000) / 100, "gyro_x": 0.1 + 0.01 * rng.standard_normal(2000)},
    )
    for name in ("warm", "timed"):  # the first fills JAX's caches; the second times the run
        started = time.monotonic()
        process = _noise_run(recording, tmp_path / name)
        _, stderr = process.communicate(timeout=300)
        assert process.returncode == 0, stderr
    duration = time.monotonic() - started
    complete = _files(tmp_path / "timed")
    assert complete == [
        "n.json", "posterior", "posterior/noise_gyro_x.json",
        "posterior/noise_gyro_x_posterior.nc",
    ]  # fmt: skip
    stopped = 0
    for k, fraction in enumerate(np.linspace(0.05, 0.95, 8)):
        sent = (signal.SIGTERM, signal.SIGINT)[k % 2]
        folder = tmp_path / f"run{k}"
        started = time.monotonic()
        process = _noise_run(recording, folder)
        time.sleep(fraction * duration)
        if process.poll() is None:
            process.send_signal(sent)
        else:  # the machine ran faster than when timed: the moments follow it
            duration = time.monotonic() - started
        _, stderr = process.communicate(timeout=120)
        code, word = _SAID[sent]
        context = f"{sent.name} at {fraction:.2f} of {duration:.2f} s: exit {process.returncode}"
        if process.returncode == code:
            # Before the command line is parsed the run does not yet know its command's name.
            assert stderr.strip() in (
                f"bayescal noise: {word}; no output written",
                f"bayescal: {word}; no output written",
            ), context
            assert _files(folder) == [], context
            stopped += 1
        else:
            assert process.returncode in (0, -sent), f"{context}: {stderr}"
            assert stderr == "" and _files(folder) == complete, f"{context}: {stderr}"
    assert stopped >= 5, f"only {stopped} of 8 signals came while the run worked"


def test_a_signal_waits_while_the_files_move_into_place(tmp_path, monkeypatch):
    """Ctrl-C as the first of a run's files moves into place: both move, then it acts."""
    moved = []

    def replace(source, target):
        if not moved:
            signal.raise_signal(signal.SIGINT)
        moved.append(Path(target).name)
        os.rename(source, target)

    monkeypatch.setattr(os, "replace", replace)
    # Python's own SIGINT handler, whatever an earlier test in this worker left installed.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt), Outputs():
            write_json(tmp_path / "a.json", {"a": 1})
            write_json(tmp_path / "b.json", {"b": 2})
    finally:
        signal.signal(signal.SIGINT, previous)
    assert moved == ["a.json", "b.json"]
    assert sorted(path.name for path in tmp_path.iterdir()) == ["a.json", "b.json"]


def test_an_interrupted_sampler_says_nothing(capsys):
    """emcee's wrapper of the log density prints a traceback of any exception before passing
    it on; bayescal's sampler calls the log density without it: an interruption there ends
    the sampling quietly, nothing evaluated after it."""
    from bayescal.inference._mcmc import sample_ensemble

    calls = []

    def log_density(theta):
        calls.append(theta.shape[0])
        if len(calls) == 30:
            raise KeyboardInterrupt
        return -0.5 * np.sum(theta**2, axis=1)

    with pytest.raises(KeyboardInterrupt):
        sample_ensemble(log_density, np.zeros(2), np.eye(2), np.random.default_rng(0), 8, 1000)
    assert len(calls) == 30
    assert capsys.readouterr() == ("", "")


def test_a_signal_swallowed_by_the_garbage_collector_is_raised_again():
    """JAX's garbage-collector hook runs often while modules load; a signal handled inside
    it cannot raise there (Python swallows the exception): the handler raises it again
    moments later, where the run is."""
    import gc

    from bayescal.cli._main import _Signals

    fired = []

    def callback(phase, info):
        if phase == "start" and not fired:
            fired.append(phase)
            signal.raise_signal(signal.SIGINT)
            sum(range(100))  # the handler runs here, inside the callback

    signals = _Signals().install()
    gc.callbacks.append(callback)
    try:
        with pytest.raises(KeyboardInterrupt):
            gc.collect()
            deadline = time.monotonic() + 5
            while time.monotonic() < deadline:
                time.sleep(0.001)
    finally:
        gc.callbacks.remove(callback)
        signals.restore()
    assert fired and signals.received[0] == signal.SIGINT


class _RaisesWhenCollected:
    """What a signal does to a callback Python runs without letting it raise (JAX's garbage
    collector hook, a ``__del__``): the handler's exception is swallowed there."""

    def __init__(self, exception):
        self.exception = exception

    def __del__(self):
        raise self.exception


def test_a_signal_swallowed_by_a_callback_prints_no_traceback(monkeypatch):
    """The run says a swallowed signal in one line (it records it, and raises it before its
    outputs move into place); Python's "Exception ignored in ..." report of it is silenced
    while the run lasts. Before any signal the hook in place before (Python's printer;
    pytest's here) gets every other report; after one, none: they are its echoes."""
    import sys

    from bayescal.cli._main import _Signals

    reported = []
    monkeypatch.setattr(sys, "unraisablehook", lambda report: reported.append(report.exc_value))
    signals = _Signals().install()
    try:
        bug = ValueError("a real bug")
        _RaisesWhenCollected(bug)
        signals.received.append(signal.SIGINT)  # what the handler records
        _RaisesWhenCollected(KeyboardInterrupt())
        _RaisesWhenCollected(ValueError("an echo of the interruption"))
        with pytest.raises(KeyboardInterrupt):
            signals.settle()
    finally:
        signals.restore()
    assert reported == [bug]
    interrupt = KeyboardInterrupt()
    _RaisesWhenCollected(interrupt)
    assert reported == [bug, interrupt]


# --- A full disk ------------------------------------------------------------------------------

# Run inside a private mount namespace whose tmpfs FULL is full: the command line's runs (each
# its own process: a crash is its return code), then the writers with the free-space check
# switched off, so that the write itself meets the full disk. Prints what happened as JSON.
_FULL_DISK_DRIVER = """
import json, os, subprocess, sys
from pathlib import Path

full, recording = Path(sys.argv[1]), sys.argv[2]
command = [sys.executable, "-c", "import sys; from bayescal.cli import main; sys.exit(main())"]
runs = {}
for name, arguments in {
    "json": ["--classical-only", "--json", full / "n.json"],
    "out": ["--terms", "white", "--out", full / "posterior", "--quiet"],
}.items():
    done = subprocess.run(
        [*command, "noise", recording, "--channel", "gyro_x", *map(str, arguments)],
        capture_output=True, text=True, check=False,
    )
    runs[name] = [done.returncode, done.stderr]

import numpy as np
import xarray as xr
import bayescal._output as output
from bayescal._errors import InputError
from bayescal.recording._series import SpoolWriter

def spool(values):
    writer = SpoolWriter()
    try:
        writer.append(values)
    except BaseException:
        writer.abandon()  # as stream_channel does
        raise

output._check_room = lambda target, size: None
tree = xr.DataTree(xr.Dataset({"x": ("draw", np.zeros(200_000))}))
os.environ["BAYESCAL_SPOOL"] = str(full)
for name, write in {
    "netcdf": lambda: output.write_netcdf(tree, full / "x.nc"),
    "json unchecked": lambda: output.write_json(full / "x.json", {"x": list(range(10_000))}),
    "spool": lambda: spool(np.zeros(200_000)),
}.items():
    try:
        write()
        runs[name] = "written"
    except InputError as error:
        runs[name] = str(error)
runs["left"] = sorted(os.listdir(full))
print(json.dumps(runs))
"""


def test_a_full_disk_is_said_with_the_path_and_leaves_nothing(tmp_path):
    """``noise --json`` and ``noise --out`` into a full file system: exit 2 naming the file,
    no crash (HDF5's own write to a full disk ended in a segmentation fault), no file left;
    the writers without their free-space check meet the full disk and say so too. The tmpfs
    is mounted in a private mount namespace (unshare), where the machine allows one."""
    if not sys.platform.startswith("linux"):
        pytest.skip("a tmpfs in a private mount namespace needs Linux")
    probe = subprocess.run(
        ["unshare", "--user", "--map-root-user", "--mount", "true"],
        capture_output=True,
        text=True,
        check=False,
    )
    if probe.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here (unshare: {probe.stderr.strip()})")
    rng = np.random.default_rng(4)
    path = write_csv(
        tmp_path / "rec.csv",
        {"time": np.arange(2000) / 100, "gyro_x": 0.1 + 0.01 * rng.standard_normal(2000)},
    )
    full = tmp_path / "full"
    full.mkdir()
    (tmp_path / "driver.py").write_text(_FULL_DISK_DRIVER)
    script = (
        'mount -t tmpfs -o size=256k tmpfs "$1" && '
        '(dd if=/dev/zero of="$1/filler" bs=4k 2>/dev/null; true) && '
        'exec "$3" driver.py "$1" "$2"'
    )
    environment = {**os.environ, "PYTHONPATH": str(ROOT), "JAX_PLATFORMS": "cpu"}
    done = subprocess.run(
        ["unshare", "--user", "--map-root-user", "--mount", "sh", "-c", script, "sh",
         str(full), str(path), sys.executable],
        capture_output=True, text=True, cwd=tmp_path, env=environment, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    runs = json.loads(done.stdout)
    for name, target in (("json", "n.json"), ("out", "posterior/noise_gyro_x_posterior.nc")):
        code, stderr = runs[name]
        assert code == 2, stderr
        message = stderr.strip()
        assert "\n" not in message and "Traceback" not in message
        assert f"{full / target}: not written: it needs" in message, message
        assert "its file system has 0 B free; free space there or choose another path" in message
    for name, target in (("netcdf", "x.nc"), ("json unchecked", "x.json")):
        assert runs[name] == (
            f"{full / target}: not written: its file system is full; "
            "free space there or choose another path"
        )
    assert runs["spool"].startswith(f"{full}/bayescal-spool-")
    assert "not written: its file system is full; set BAYESCAL_SPOOL" in runs["spool"]
    assert runs["left"] == ["filler"]
