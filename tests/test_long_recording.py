"""Long recordings (issue 17): a channel read block by block and spooled to disk gives the
numbers the in-memory channel gives, to 1e-12. Blocks are made small here (monkeypatched) so
that a record of a few hundred thousand samples crosses many block boundaries, gaps and
pieces; the speed and memory at 10^8 samples are measured by benchmarks/long_recording.py."""

import gc
import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import bayescal as bc
import bayescal.classical._allan as allan_module
import bayescal.models._whittle as whittle_module
import bayescal.recording._series as series_module
import bayescal.recording._stream as stream_module
from bayescal.inference._checks import lag_one_check
from bayescal.models._components import Components
from bayescal.models._noise_problem import noise_summaries
from bayescal.models._whittle import spectral_summary, whittle_log_likelihood
from bayescal.models.effects._parameter import Context
from bayescal.recording._levels import discrete_step
from bayescal.recording._series import SpooledSeries, SpoolWriter
from bayescal.recording._stream import stream_channel

RATE = 100.0
TOLERANCE = 1e-12


@pytest.fixture
def small_blocks(monkeypatch):
    """Blocks of 2^13 samples for reading, 2^12 terms for the Allan sums, pieces of 2^15
    samples for the periodogram."""
    monkeypatch.setattr(series_module, "BLOCK", 1 << 13)
    monkeypatch.setattr(stream_module, "BLOCK", 1 << 13)
    monkeypatch.setattr(stream_module, "_MIN_BLOCK_ROWS", 1 << 10)
    monkeypatch.setattr(allan_module, "_SPAN_BLOCK", 1 << 12)
    monkeypatch.setattr(whittle_module, "MAX_SEGMENT", 1 << 15)


def gyro(n: int, seed: int = 1) -> np.ndarray:
    model = bc.NoiseModel(rate_hz=RATE, bias=0.3, N=0.005, B=5e-4, K=5e-5)
    return np.array(model.simulate(n, seed=seed))


def spooled(values: np.ndarray) -> SpooledSeries:
    writer = SpoolWriter()
    for first in range(0, values.size, 30_000):  # appended in pieces unlike the blocks read
        writer.append(values[first : first + 30_000])
    return writer.finish()


@pytest.fixture
def gapped():
    values = gyro(200_003)
    values[5_000:5_100] = np.nan
    values[150_000:150_010] = np.nan
    return values


def close(a, b) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    both = np.isfinite(a) & np.isfinite(b)
    same_missing = np.array_equal(np.isfinite(a), np.isfinite(b))
    scale = np.maximum(np.abs(a[both]), np.abs(b[both]))
    return same_missing and bool(np.all(np.abs(a[both] - b[both]) <= TOLERANCE * scale))


@pytest.mark.parametrize(
    "deviation, options",
    [
        (bc.allan_deviation, {}),
        (bc.allan_deviation, {"overlapping": False}),
        (bc.hadamard_deviation, {}),
        (bc.hadamard_deviation, {"overlapping": False, "taus": 64}),
    ],
)
def test_allan_family_of_a_spooled_series_is_the_in_memory_one(
    small_blocks, gapped, deviation, options
):
    memory = deviation(gapped, RATE, **options)
    disk = deviation(spooled(gapped), RATE, **options)
    assert np.array_equal(memory.m, disk.m) and np.array_equal(memory.n, disk.n)
    assert np.array_equal(memory.alpha, disk.alpha)
    assert close(memory.deviation, disk.deviation)
    assert close(memory.ci_low, disk.ci_low) and close(memory.ci_high, disk.ci_high)


def test_modified_allan_of_a_spooled_series_is_refused_by_name(gapped):
    with pytest.raises(bc.InputError, match="modified Allan deviation of a spooled"):
        bc.modified_allan_deviation(spooled(gapped), RATE)


def test_summaries_of_a_spooled_series_are_the_in_memory_ones(small_blocks, gapped):
    disk = spooled(gapped)
    memory_classical, disk_classical = (
        bc.classical_noise(gapped, RATE),
        bc.classical_noise(disk, RATE),
    )
    assert memory_classical.n_samples == disk_classical.n_samples
    for name in ("bias", "bias_ci_low", "bias_ci_high", "std", "duration_s"):
        assert close(getattr(memory_classical, name), getattr(disk_classical, name)), name
    terms = ("white", "bias_instability", "rate_random_walk")
    (memory_spectrum, memory_level), (disk_spectrum, disk_level) = (
        noise_summaries(values, RATE, terms) for values in (gapped, disk)
    )
    assert close(memory_level.block_mean, disk_level.block_mean)
    assert np.array_equal(memory_level.basis, disk_level.basis)
    for name in ("count", "node_power", "node_count", "basis", "mean_increment"):
        assert close(getattr(memory_spectrum, name), getattr(disk_spectrum, name)), name
    autocovariance = np.array([2.0, -1.0, 0.0])
    assert close(
        lag_one_check(gapped, autocovariance)["statistic"],
        lag_one_check(disk, autocovariance)["statistic"],
    )
    grid = np.round(gapped / 1e-3) * 1e-3
    assert discrete_step(spooled(grid)) == discrete_step(grid) == pytest.approx(1e-3)
    assert discrete_step(disk) == discrete_step(gapped) == 0.0


def test_equal_pieces_pool_their_bins_without_changing_the_likelihood(small_blocks):
    """A gap-free run four pieces long gives one piece's bins, and its likelihood is the sum
    of the four pieces' likelihoods taken apart."""
    values = gyro(4 * (1 << 15))
    components = Components.of(("white", "output_filter"), Context(RATE))
    pooled = spectral_summary(values, RATE, components=components)
    pieces = [
        spectral_summary(values[k << 15 : (k + 1) << 15], RATE, components=components)
        for k in range(4)
    ]
    assert pooled.n_bins == pieces[0].n_bins
    assert pooled.mean_increment.size == 4
    variances = np.asarray(components.weights({"N": 0.005, "F": 1e-8}))
    total = float(np.sum(whittle_log_likelihood(pooled, variances)))
    apart = sum(float(np.sum(whittle_log_likelihood(p, variances))) for p in pieces)
    assert total == pytest.approx(apart, rel=1e-12)


def test_a_spooled_series_is_never_read_whole_and_its_file_goes_with_it(gapped):
    disk = spooled(gapped)
    with pytest.raises(TypeError, match="read in blocks"):
        np.asarray(disk)
    assert np.array_equal(disk.read(10, 20), gapped[10:20], equal_nan=True)
    assert np.array_equal(disk.read(3, 190_000, 997), gapped[3:190_000:997], equal_nan=True)
    assert np.array_equal(disk.read(3, 190_000, 7), gapped[3:190_000:7], equal_nan=True)
    path = disk.path
    assert path.exists()
    del disk
    gc.collect()
    assert not path.exists() and not path.parent.exists()


def write_table(path, values, time=None, *, rate=RATE):
    time = np.arange(values.size) / rate if time is None else time
    if path.suffix == ".parquet":
        pq.write_table(
            pa.table({"time": time, "gyro_x[deg/s]": values, "acc_x[g]": values / 100}),
            path,
            row_group_size=5_000,
        )
    else:
        with path.open("w") as handle:
            handle.write("time,gyro_x[deg/s],acc_x[g]\n")
            np.savetxt(handle, np.column_stack([time, values, values / 100]), "%.17g", ",")


@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_a_streamed_channel_is_the_in_memory_channel(small_blocks, tmp_path, suffix):
    path = tmp_path / f"gyro{suffix}"
    values = gyro(60_001, seed=4)
    time = np.arange(values.size) / RATE
    keep = np.ones(values.size, bool)
    keep[[20_000, 20_001, 40_003]] = False  # dropped samples, one of them at a block's edge
    write_table(path, values[keep], time[keep])
    for window in ({}, {"start": 35.0, "stop": 420.0}):
        memory = bc.load_recording(path).channel("gyro_x", gaps="split", **window)
        disk = stream_channel(path, "gyro_x", gaps="split", **window)
        assert disk.rate_hz == memory.rate_hz == RATE
        assert disk.start_s == memory.start_s and disk.unit == memory.unit == "deg/s"
        assert disk.values.size == memory.values.size
        assert np.array_equal(disk.values.read(0, disk.values.size), memory.values, equal_nan=True)


def test_a_streamed_element_of_a_parquet_list_is_the_in_memory_one(small_blocks, tmp_path):
    """A column of vectors (one list of three axes a row) streams element by element."""
    path = tmp_path / "vectors.parquet"
    values = gyro(30_000, seed=5)
    axes = pa.FixedSizeListArray.from_arrays(
        np.column_stack([values, -values, 2 * values]).ravel(), 3
    )
    time = np.arange(values.size) / RATE
    pq.write_table(pa.table({"time": time, "gyro[deg/s]": axes}), path, row_group_size=5_000)
    memory = bc.load_recording(path).channel("gyro_1")
    disk = stream_channel(path, "gyro_1")
    assert disk.unit == memory.unit == "deg/s" and disk.rate_hz == memory.rate_hz == RATE
    assert np.array_equal(disk.values.read(0, disk.values.size), memory.values)
    assert np.array_equal(memory.values, -values)


def test_each_sample_takes_its_place_on_the_grid_whatever_the_stamps(tmp_path):
    """Evenly spaced stamps (the loader's shortcut: no grid search, the mean step as the
    period), stamps with 0.1 % jitter and stamps with a dropped sample give the same grid and
    rate as the rate given outright."""
    values = gyro(20_000, seed=6)
    even = np.arange(values.size) / RATE
    jitter = even + 1e-5 * np.random.default_rng(1).standard_normal(values.size)
    given = bc.Recording("given", {"gyro_x": values}, {"gyro_x": "deg/s"}).channel(
        "gyro_x", rate_hz=RATE
    )
    for stamps in (even, jitter, 1e6 + even):
        path = tmp_path / "gyro.parquet"
        write_table(path, values, stamps)
        channel = bc.load_recording(path).channel("gyro_x")
        assert channel.rate_hz == pytest.approx(RATE, rel=1e-6)
        assert np.array_equal(channel.values, given.values)
    keep = np.ones(values.size, bool)
    keep[7_000] = False
    write_table(path, values[keep], even[keep])
    gapped = bc.load_recording(path).channel("gyro_x", gaps="split")
    assert gapped.rate_hz == RATE and np.isnan(gapped.values[7_000])
    assert np.array_equal(np.delete(gapped.values, 7_000), values[keep])


def test_a_gap_between_blocks_is_refused_by_row_as_in_memory(small_blocks, tmp_path):
    path = tmp_path / "gyro.parquet"
    values = gyro(30_000, seed=2)
    time = np.arange(values.size) / RATE
    time[8192:] += 5.0  # 5 s of nothing at the start of the second block
    write_table(path, values, time)
    with pytest.raises(bc.InputError, match=r"gap of 5\.01 s") as error:
        stream_channel(path, "gyro_x")
    assert "data row 8193" in str(error.value) and 'gaps="split"' in error.value.fix


def test_the_posterior_of_a_streamed_channel_is_the_in_memory_one(small_blocks, tmp_path):
    path = tmp_path / "gyro.parquet"
    write_table(path, gyro(1 << 16, seed=6))
    options = {"terms": ("white", "rate_random_walk"), "seed": 3}
    memory = bc.fit_noise(bc.load_recording(path).channel("gyro_x"), **options)
    disk = bc.fit_noise(stream_channel(path, "gyro_x"), **options)
    for name, summary in memory.summary.items():
        for key in ("mean", "sd", "q05", "q95", "map"):
            assert close(summary[key], disk.summary[name][key]), (name, key)
    assert memory.passed == disk.passed
    assert [c.p_value for c in memory.checks] == pytest.approx(
        [c.p_value for c in disk.checks], rel=TOLERANCE
    )


def test_noise_command_streams_and_agrees_with_reading_in_memory(small_blocks, run_cli, tmp_path):
    path = tmp_path / "gyro.csv"
    write_table(path, gyro(50_000, seed=8))
    documents = {}
    for how in ("--stream", "--no-stream"):
        output = tmp_path / f"{how}.json"
        code, _, stderr = run_cli(
            "noise", path, "--channel", "gyro_x", how, "--classical-only", "--json", output
        )
        assert code == 0, stderr
        documents[how] = json.loads(output.read_text())["classical"]
    streamed, in_memory = documents["--stream"], documents["--no-stream"]
    assert close(streamed["bias"]["value"], in_memory["bias"]["value"])
    assert close(streamed["allan"]["adev"], in_memory["allan"]["adev"])
    assert close(streamed["allan"]["ci_high"], in_memory["allan"]["ci_high"])


def test_noise_command_refuses_to_stream_what_it_cannot(run_cli, tmp_path):
    path = tmp_path / "gyro.npz"
    np.savez(path, gyro_x=gyro(5_000))
    code, _, stderr = run_cli("noise", path, "--channel", "gyro_x", "--rate", "100", "--stream")
    assert code == 2 and "--stream reads Parquet files and text tables" in stderr
    assert "Traceback" not in stderr
