"""One very long log read in pieces (threads or Dask workers) equals the one-pass read."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest

import accelcore
from accelcore._accelcore import RunData, merge_runs, plan_split, read_run, read_run_range
from accelcore.apps.bulk import read_run_split


@pytest.fixture(scope="module")
def long_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 20 Hz log with a gap, NaN cells and an extra column (about 60k rows)."""
    rng = np.random.default_rng(5)
    n = 60_000
    time_s = np.arange(n) / 20.0
    time_s[n // 2 :] += 7.3  # a gap: later blocks stay on the grid
    temp = -2.0 + 67.0 * np.arange(n) / n + rng.normal(0, 0.02, n)
    xyz = 1.5 + rng.normal(0, 1e-3, (n, 3))
    supply = 3.0 + rng.normal(0, 1e-4, n)
    lines = ["time_s,temp_c,x,y,z,supply_v"]
    for i in range(n):
        y = "nan" if i % 997 == 3 else f"{xyz[i, 1]:.6f}"
        lines.append(
            f"{time_s[i]:.2f},{temp[i]:.3f},{xyz[i, 0]:.6f},{y},{xyz[i, 2]:.6f},{supply[i]:.5f}"
        )
    path = tmp_path_factory.mktemp("long") / "run.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def assert_same_run(a: RunData, b: RunData) -> None:
    np.testing.assert_array_equal(a.blocks.block_index, b.blocks.block_index)
    np.testing.assert_array_equal(a.blocks.count, b.blocks.count)
    # A block cut by a piece boundary is the count-weighted mean of two partial means:
    # the same sum in another association order, so equal to a few ulps of the values.
    for name in ("time_s", "temperature_c", "channels"):
        np.testing.assert_allclose(
            getattr(a.blocks, name), getattr(b.blocks, name), rtol=1e-14, atol=0, err_msg=name
        )
    for name in (
        "n_rows",
        "n_skipped_nonfinite",
        "n_gaps",
        "first_time_s",
        "last_time_s",
        "max_interval_s",
        "channel_names",
    ):
        assert getattr(a, name) == getattr(b, name), name
    np.testing.assert_array_equal(a.channel_min, b.channel_min)
    np.testing.assert_array_equal(a.n_at_max, b.n_at_max)


@pytest.mark.parametrize("pieces", [1, 2, 5, 13])
@pytest.mark.parametrize("min_count", [1, 8])
def test_split_with_threads_equals_one_pass(long_log: Path, pieces: int, min_count: int) -> None:
    whole = read_run(str(long_log), min_count=min_count)
    split = read_run_split(long_log, pieces=pieces, min_count=min_count)
    assert_same_run(split, whole)
    assert split.n_skipped_nonfinite == 61 and split.n_gaps == 1


def test_run_data_pickles(long_log: Path) -> None:
    ranges, t0 = plan_split(str(long_log), 3)
    assert t0 == 0.0
    piece = read_run_range(str(long_log), *ranges[1], t0_s=t0)
    again = pickle.loads(pickle.dumps(piece))
    assert_same_run(again, piece)
    np.testing.assert_array_equal(again.n_at_min, piece.n_at_min)
    parts = [read_run_range(str(long_log), a, b, t0_s=t0) for a, b in ranges]
    assert_same_run(merge_runs(parts), read_run(str(long_log)))


def test_pieces_out_of_order_are_refused(long_log: Path) -> None:
    ranges, t0 = plan_split(str(long_log), 3)
    assert t0 is not None
    parts = [read_run_range(str(long_log), a, b, t0_s=t0) for a, b in ranges]
    with pytest.raises(accelcore.IncompatibleError, match="file order"):
        merge_runs(parts[::-1])


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
@pytest.mark.filterwarnings("ignore::ResourceWarning")
@pytest.mark.filterwarnings("ignore::UserWarning")
def test_split_on_a_dask_cluster_equals_one_pass(long_log: Path) -> None:
    distributed = pytest.importorskip("distributed", reason="dask[distributed] not installed")
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        split = read_run_split(long_log, client=client, pieces=4)
    assert_same_run(split, read_run(str(long_log)))
