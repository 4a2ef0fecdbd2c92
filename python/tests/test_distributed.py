"""Bulk generation over Ray on a local 2-worker cluster: byte for byte the
dataset of the command line, resumed after losing a part, refused for a
folder of another run, with progress reported; the initial guess as a
setting of the dataset."""

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
import ray
import tandem
import tandem.distributed
from conftest import GRASP_FAMILY

# 8 samples in parts of 2: 4 Ray tasks over 2 workers.
RUN = dict(count=8, chunk_size=2, horizon=20, seed=3)


def dataset_files(folder: Path) -> dict:
    """Every file of a dataset but the wall-clock timings, by name."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


@pytest.fixture(scope="module")
def cluster():
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


@pytest.fixture(scope="module")
def cli_dataset(tmp_path_factory, tandem_cli):
    out = tmp_path_factory.mktemp("cli") / "dataset"
    args = ["--count", "8", "--chunk-size", "2", "-T", "20", "--seed", "3", "--threads", "2"]
    subprocess.run([tandem_cli, "generate", "--family", GRASP_FAMILY, "--out", out, "--quiet", *args], check=True)
    files = dataset_files(out)
    assert sorted(files) == ["_dataset.json", "_manifest.json"] + [f"part-0000{k}.parquet" for k in range(4)]
    return out


def test_ray_dataset_equals_the_command_line_byte_for_byte(cluster, cli_dataset, tmp_path):
    out = tmp_path / "ray"
    reports = []
    summary = tandem.distributed.generate(GRASP_FAMILY, out=out, progress=reports.append, **RUN)
    assert dataset_files(out) == dataset_files(cli_dataset)
    assert sorted(p.name for p in (out / "_timings").iterdir()) == [f"part-0000{k}.csv" for k in range(4)]
    manifest = summary["manifest"]
    assert manifest["samples"] == 8 and manifest["accepted"] >= 7
    run = summary["distributed"]
    assert run["parts_computed"] == 4 and run["samples_computed"] == 8
    # One report per part, counting up to the whole run.
    assert [r["parts_done"] for r in reports] == [1, 2, 3, 4]
    assert reports[-1]["samples_done"] == reports[-1]["samples_total"] == 8
    assert reports[-1]["accepted"] == manifest["accepted"]

    # A lost part (and manifest) is recomputed alone, to the same bytes.
    (out / "part-00002.parquet").unlink()
    (out / "_manifest.json").unlink()
    again = tandem.distributed.generate(GRASP_FAMILY, out=out, progress=False, **RUN)
    assert again["distributed"]["parts_computed"] == 1
    assert dataset_files(out) == dataset_files(cli_dataset)

    # A complete dataset: nothing to compute, Ray not needed.
    done = tandem.distributed.generate(GRASP_FAMILY, out=out, progress=False, **RUN)
    assert done["distributed"]["parts_computed"] == 0 and done["parts_kept"] == 4


def test_a_folder_of_another_run_is_refused_before_any_work(cluster, cli_dataset):
    before = dataset_files(cli_dataset)
    with pytest.raises(tandem.DatasetError, match="generated with seed = 3, this run asks 4"):
        tandem.distributed.generate(GRASP_FAMILY, out=cli_dataset, **dict(RUN, seed=4))
    assert dataset_files(cli_dataset) == before


def test_single_process_generate_equals_the_command_line(cli_dataset, tmp_path):
    out = tmp_path / "local"
    summary = tandem.generate(GRASP_FAMILY, out, threads=1, **RUN)
    assert summary["parts_written"] == 4 and summary["samples_run"] == 8
    assert Path(summary["manifest_path"]) == out / "_manifest.json"
    assert dataset_files(out) == dataset_files(cli_dataset)


def test_the_initial_guess_is_part_of_the_dataset(cli_dataset, tandem_cli, tmp_path):
    """``initial_guess="straight"``: the command line's ``--initial-guess
    straight`` bytes, recorded in ``_dataset.json``; a resume asking another
    guess is refused by name; an unknown guess is a ValueError."""
    local, cli = tmp_path / "local", tmp_path / "cli"
    tandem.generate(GRASP_FAMILY, local, threads=1, initial_guess="straight", **RUN)
    args = ["--count", "8", "--chunk-size", "2", "-T", "20", "--seed", "3", "--initial-guess", "straight"]
    subprocess.run([tandem_cli, "generate", "--family", GRASP_FAMILY, "--out", cli, "--quiet", *args], check=True)
    assert dataset_files(local) == dataset_files(cli)
    assert json.loads((local / "_dataset.json").read_text())["initial_guess"] == "straight"
    assert json.loads((cli_dataset / "_dataset.json").read_text())["initial_guess"] == "planned"
    with pytest.raises(tandem.DatasetError, match='initial_guess = "straight", this run asks "planned"'):
        tandem.generate(GRASP_FAMILY, local, **RUN)
    with pytest.raises(ValueError, match='initial_guess must be "planned" or "straight", got "sideways"'):
        tandem.generate(GRASP_FAMILY, tmp_path / "other", initial_guess="sideways", **RUN)
    problem = tandem.Problem.builtin("panda_grasp_box")
    solution = tandem.solve(problem, seed=1, initial_guess="straight")
    assert solution.converged, solution.report()
    # Another seed, the same motion: it depends on the task only.
    again = tandem.solve(problem, seed=2, initial_guess="straight")
    np.testing.assert_array_equal(solution.trajectory, again.trajectory)
