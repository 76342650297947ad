"""The job-array recipes of examples/cluster as the schedulers run them: the
Slurm task script under a job array's environment, and the Kubernetes
Indexed Job's container command with its completion index, each as separate
processes at once, merged: the rows of one machine."""

from __future__ import annotations

import os
import subprocess

import yaml

from conftest import REPO
from test_ray import SWEEP, rows_without_time, sweep_folder

CLUSTER = REPO / "examples" / "cluster"


def path_with(uvpin_cli) -> dict[str, str]:
    return dict(os.environ, PATH=f"{uvpin_cli.parent}{os.pathsep}{os.environ['PATH']}")


def test_the_slurm_script_on_an_array_gives_the_rows_of_one_machine(tmp_path, uvpin_cli):
    folder = sweep_folder(tmp_path)
    subprocess.run([str(uvpin_cli), "sweep", "cli.sweep.ron", "-q"], cwd=folder, check=True, capture_output=True)
    env = path_with(uvpin_cli)
    # --array=1-5:2 (tasks 1, 3, 5): the script numbers shards by position.
    tasks = [
        subprocess.Popen(
            ["bash", str(CLUSTER / "sweep.slurm"), "ray.sweep.ron"],
            cwd=folder,
            env=dict(env, SLURM_ARRAY_TASK_ID=str(task), SLURM_ARRAY_TASK_MIN="1",
                     SLURM_ARRAY_TASK_STEP="2", SLURM_ARRAY_TASK_COUNT="3", SLURM_CPUS_PER_TASK="1"),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )
        for task in (1, 3, 5)
    ]
    for task in tasks:
        _, err = task.communicate(timeout=600)
        assert task.returncode == 0, err
    assert sorted(p.name for p in (folder / "out-ray" / "shards").iterdir()) == ["0-of-3", "1-of-3", "2-of-3"]
    merge = subprocess.run([str(uvpin_cli), "sweep", "ray.sweep.ron", "--merge"], cwd=folder,
                           capture_output=True, text=True, timeout=600)
    assert merge.returncode == 0, merge.stderr
    assert rows_without_time(folder / "out-ray" / "runs.csv") == rows_without_time(folder / "out-cli" / "runs.csv")


def test_the_kubernetes_indexed_job_gives_the_rows_of_one_machine(tmp_path, uvpin_cli):
    sweep, merge = yaml.safe_load_all((CLUSTER / "sweep-indexed-job.yaml").read_text())
    assert sweep["spec"]["completionMode"] == "Indexed"
    completions = sweep["spec"]["completions"]
    shard = sweep["spec"]["template"]["spec"]["containers"][0]["command"]
    joined = merge["spec"]["template"]["spec"]["containers"][0]["command"]
    folder = tmp_path / "data"
    folder.mkdir()
    sweep_folder(folder)
    (folder / shard[2]).write_text(SWEEP.replace("OUTPUT", "out-k8s"))
    subprocess.run([str(uvpin_cli), "sweep", "cli.sweep.ron", "-q"], cwd=folder, check=True, capture_output=True)
    # The pods: Kubernetes expands $(JOB_COMPLETION_INDEX) in the command.
    pods = [
        subprocess.Popen(
            [arg.replace("$(JOB_COMPLETION_INDEX)", str(i)) for arg in shard],
            cwd=folder, env=path_with(uvpin_cli), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        )
        for i in range(completions)
    ]
    for pod in pods:
        _, err = pod.communicate(timeout=900)
        assert pod.returncode == 0, err
    ran = subprocess.run(joined, cwd=folder, env=path_with(uvpin_cli), capture_output=True, text=True, timeout=600)
    assert ran.returncode == 0, ran.stderr
    assert "| uvpin |" in ran.stdout, "the merge prints the summary"
    assert len(list((folder / "out-k8s" / "shards").iterdir())) == completions
    assert rows_without_time(folder / "out-k8s" / "runs.csv") == rows_without_time(folder / "out-cli" / "runs.csv")
