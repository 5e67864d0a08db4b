"""mfcontrol sweep: files, resume after a kill, --keep, Dask."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

import mfcontrol
from mfcontrol.experiments.cases import resolve_case

GRID = ["--grid", "controller.alpha=logspace(-1,1,4)", "--grid", "plant.dR=0,2.5,5"]
FAST = ["--set", "sim.t_end=0.002"]


def messages(stderr: str) -> list[str]:
    """stderr's lines without the progress line (redrawn with carriage returns)."""
    return [line for line in stderr.replace("\r", "\n").splitlines()
            if line.strip() and not line.startswith("[sweep]")]


def sweep(*args, check=True):
    proc = subprocess.run([sys.executable, "-m", "mfcontrol.cli", "sweep", *args],
                          capture_output=True, text=True)
    if check:
        assert proc.returncode == 0, proc.stderr
    return proc


def test_results_have_one_row_per_member(tmp_path):
    sweep("voltage-stable-standard", *GRID, *FAST, "--out", str(tmp_path / "s"))
    d = pd.read_parquet(tmp_path / "s" / "results.parquet")
    assert len(d) == 12 and d["member"].tolist() == list(range(12))
    assert {"controller.alpha", "plant.dR", "iae", "settled", "t_diverge"} <= set(d.columns)
    np.testing.assert_array_equal(d["plant.dR"][:3], [0.0, 2.5, 5.0])  # last key fastest
    meta = json.loads((tmp_path / "s" / "sweep.json").read_text())
    assert meta["n_members"] == 12 and meta["case"] == "voltage-stable-standard"


def test_killed_sweep_resumes_and_equals_an_uninterrupted_one(tmp_path):
    out = tmp_path / "killed"
    args = [sys.executable, "-m", "mfcontrol.cli", "sweep", "voltage-stable-standard",
            "--grid", "controller.alpha=logspace(-1,1,10)", "--grid", "plant.dR=0,5",
            "--set", "sim.t_end=0.004", "--chunk", "2", "--out", str(out)]
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and not list((out / "chunks").glob("chunk-*.parquet")):
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    finished = sorted((out / "chunks").glob("chunk-*.parquet"))
    assert 1 <= len(finished)
    if proc.returncode == 130:  # interrupted before the end: it says so, keeps its chunks
        assert "resume" in err and not (out / "results.parquet").exists()
    stamps = {p.name: p.stat().st_mtime_ns for p in finished}
    rerun = subprocess.run(args, capture_output=True, text=True)
    assert rerun.returncode == 0, rerun.stderr
    for p in finished:  # finished chunks were skipped, not redone
        assert p.stat().st_mtime_ns == stamps[p.name]
    fresh = tmp_path / "fresh"
    subprocess.run(args[:-1] + [str(fresh)], check=True, capture_output=True)
    pd.testing.assert_frame_equal(pd.read_parquet(out / "results.parquet"),
                                  pd.read_parquet(fresh / "results.parquet"))


def test_a_different_sweep_into_the_same_folder_is_refused(tmp_path):
    sweep("voltage-stable-standard", *GRID, *FAST, "--out", str(tmp_path / "s"))
    proc = sweep("voltage-stable-standard", "--grid", "plant.dR=1,2", *FAST, "--out",
                 str(tmp_path / "s"), check=False)
    assert proc.returncode == 2 and "different sweep" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_fast_sweep_is_close_to_the_exact_one_and_is_not_mixed_with_it(tmp_path):
    sweep("voltage-stable-standard", *GRID, *FAST, "--out", str(tmp_path / "exact"))
    sweep("voltage-stable-standard", *GRID, *FAST, "--fast", "--out", str(tmp_path / "fast"))
    exact = pd.read_parquet(tmp_path / "exact" / "results.parquet")
    fast = pd.read_parquet(tmp_path / "fast" / "results.parquet")
    assert json.loads((tmp_path / "fast" / "sweep.json").read_text())["arithmetic"] == "fast"
    np.testing.assert_allclose(fast["iae"], exact["iae"], rtol=1e-12)
    assert fast["settled"].tolist() == exact["settled"].tolist()
    # resuming a folder with the other arithmetic would mix two kinds of results
    proc = sweep("voltage-stable-standard", *GRID, *FAST, "--out", str(tmp_path / "exact"),
                 "--fast", check=False)
    assert proc.returncode == 2 and "different sweep" in proc.stderr


def test_fast_sweep_keeps_fast_single_run_trajectories(tmp_path):
    sweep("voltage-stable-standard", "--grid", "controller.kp=1.5,2", *FAST, "--keep", "1",
          "--fast", "--out", str(tmp_path / "k"))
    traj = pd.read_csv(tmp_path / "k" / "trajectories" / "member-0.csv")
    cfg = resolve_case("voltage-stable-standard", {"sim.t_end": 0.002, "controller.kp": 1.5})[1]
    np.testing.assert_array_equal(traj["y"].to_numpy(),
                                  mfcontrol.simulate(cfg, fast=True).signals["y"])


def test_fast_sweep_of_a_toolkit_case_runs_in_the_general_engine(tmp_path):
    # every loop is compiled now: --fast works on the positional laws and other plants
    sweep("first-order-ip-algebraic", "--grid", "controller.kp=2,5", "--fast",
          "--set", "sim.t_end=1.0", "--out", str(tmp_path / "s"))
    df = pd.read_parquet(tmp_path / "s" / "results.parquet")
    _, cfg = resolve_case("first-order-ip-algebraic", {"sim.t_end": 1.0,
                                                       "controller.kp": 5.0})
    exact = mfcontrol.simulate(cfg).metrics["iae"]
    assert df["iae"].iloc[1] == pytest.approx(exact, rel=1e-10)


def test_keep_writes_single_run_trajectories(tmp_path):
    sweep("voltage-stable-variational", "--grid", "controller.Gamma=1e-8,1e-6,1e-4", *FAST,
          "--keep", "2", "--out", str(tmp_path / "k"))
    files = sorted((tmp_path / "k" / "trajectories").glob("member-*.csv"))
    assert [f.name for f in files] == ["member-0.csv", "member-2.csv"]
    traj = pd.read_csv(files[1])
    single = mfcontrol.run_case("voltage-stable-variational",
                                {"sim.t_end": 0.002, "controller.Gamma": 1e-4})
    np.testing.assert_array_equal(traj["u_raw"].to_numpy(), single.signals["u_raw"])
    d = pd.read_parquet(tmp_path / "k" / "results.parquet")
    assert d["iae"][2] == single.metrics["iae"]


@pytest.mark.parametrize("bad,needle", [(["--grid=plant.Q=1,2"], "plant.Q"),
                                        (["--grid=plant.R=linspace(1,2)"], "plant.R"),
                                        (["--grid=plant.R=1,2", "--keep=-1"], "--keep"),
                                        ([], "--grid")])
def test_bad_sweep_input_is_one_line_exit_2(tmp_path, bad, needle):
    proc = sweep("voltage-stable-standard", *bad, *FAST, "--out", str(tmp_path / "b"),
                 check=False)
    assert proc.returncode == 2 and needle in proc.stderr and "Traceback" not in proc.stderr
    assert len(messages(proc.stderr)) == 1


def test_dask_local_cluster_gives_identical_results(tmp_path):
    pytest.importorskip("dask.distributed")
    sweep("voltage-stable-standard", *GRID, *FAST, "--chunk", "4", "--out",
          str(tmp_path / "local"))
    env_args = [*GRID, *FAST, "--chunk", "4", "--dask", "local:2", "--out",
                str(tmp_path / "dask")]
    proc = subprocess.run([sys.executable, "-m", "mfcontrol.cli", "sweep",
                           "voltage-stable-standard", *env_args], capture_output=True,
                          text=True, env={**os.environ, "NUMBA_NUM_THREADS": "1"})
    assert proc.returncode == 0, proc.stderr
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "local" / "results.parquet"),
                                  pd.read_parquet(tmp_path / "dask" / "results.parquet"))


# --- issue 14: one owner per folder, metadata written whole, paths and --dask refused ------

def test_a_second_sweep_into_a_folder_in_use_is_refused_and_the_first_finishes(tmp_path):
    from filelock import FileLock

    out = tmp_path / "s"
    out.mkdir()
    # another process holds the folder (here this one: an OS lock is per open file)
    with FileLock(out / ".lock"):
        proc = sweep("voltage-stable-standard", *GRID, *FAST, "--out", str(out), check=False)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert "is being written by another running sweep" in proc.stderr
    assert not (out / "sweep.json").exists()  # nothing written
    sweep("voltage-stable-standard", *GRID, *FAST, "--out", str(out))  # the lock is free again
    assert len(pd.read_parquet(out / "results.parquet")) == 12


def test_two_different_sweeps_started_together_never_mix(tmp_path):
    out = tmp_path / "s"
    cmds = [[sys.executable, "-m", "mfcontrol.cli", "sweep", "voltage-stable-standard",
             "--grid", grid, *FAST, "--out", str(out)]
            for grid in ("plant.dR=0,1,2,3,4,5,6,7", "controller.alpha=5,10,15,20,25,30")]
    procs = [subprocess.Popen(c, stderr=subprocess.PIPE, text=True) for c in cmds]
    codes = [p.wait() for p in procs]
    errs = [p.stderr.read() for p in procs]
    assert sorted(codes) in ([0, 2], [0, 0]), errs  # [0, 0]: one ended before the other began
    if sorted(codes) == [0, 2]:
        assert any("another running sweep" in e or "different sweep" in e for e in errs)
    grid = json.loads((out / "sweep.json").read_text())["grid"]
    results = pd.read_parquet(out / "results.parquet")
    (key, values), = grid.items()
    other = {"plant.dR", "controller.alpha"} - {key}
    assert key in results.columns and not other & set(results.columns)
    assert len(results) == len(values) and sorted(results[key]) == sorted(values)
    assert not list(out.glob("*.tmp")) and not list(out.glob(".*.tmp"))


def test_a_torn_sweep_json_is_one_line(tmp_path):
    out = tmp_path / "s"
    out.mkdir()
    (out / "sweep.json").write_text('{"case": "voltage-st')
    proc = sweep("voltage-stable-standard", *GRID, *FAST, "--out", str(out), check=False)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "sweep.json that is not a sweep's" in proc.stderr


@pytest.mark.parametrize("address,needle", [
    ("local:0", "N workers, 1 to 1024"), ("local:-1", "N workers, 1 to 1024"),
    ("local:x", "N workers"), ("garbage", "a scheduler address"),
    ("tcp://127.0.0.1:9", "no Dask scheduler answered there")])
def test_bad_dask_addresses_are_one_line_and_write_nothing(tmp_path, address, needle):
    pytest.importorskip("dask.distributed")
    out = tmp_path / "d"
    proc = sweep("voltage-stable-standard", *GRID, *FAST, "--dask", address, "--out",
                 str(out), check=False)
    assert proc.returncode == 2 and needle in proc.stderr and "Traceback" not in proc.stderr
    assert len(messages(proc.stderr)) == 1
    assert not (out / "results.parquet").exists()


def test_out_under_a_file_is_one_line(tmp_path):
    (tmp_path / "file").write_text("x")
    proc = sweep("voltage-stable-standard", *GRID, *FAST, "--out",
                 str(tmp_path / "file" / "s"), check=False)
    assert proc.returncode == 2 and "cannot be created" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_ctrl_c_under_dask_is_one_line(tmp_path):
    """A terminal's Ctrl-C reaches the whole process group: the local cluster's worker
    processes printed KeyboardInterrupt tracebacks (issue 14 item 9)."""
    pytest.importorskip("dask.distributed")
    out = tmp_path / "s"
    args = [sys.executable, "-m", "mfcontrol.cli", "sweep", "voltage-stable-standard",
            "--grid", "controller.alpha=logspace(-1,1,2000)", "--set", "sim.t_end=0.004",
            "--chunk", "2", "--dask", "local:1", "--out", str(out)]
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    deadline = time.time() + 180
    while time.time() < deadline and not (out / "chunks" / "chunk-000002.parquet").exists():
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)  # as a terminal does
    _, err = proc.communicate(timeout=120)
    lines = messages(err)
    assert proc.returncode == 130 and "Traceback" not in err, err[-2000:]
    assert len(lines) == 1 and "resume" in lines[0]


def test_local_dask_workers_log_only_critical_errors():
    """The Ctrl-C test above failed in CI once: a worker's heartbeat met the closing
    scheduler and its process logged a CommClosedError traceback, which LocalCluster's
    silence_logs does not reach (it sets the parent's handlers and the nanny's logger)."""
    pytest.importorskip("dask.distributed")
    import logging

    from mfcontrol.experiments.sweeps import _connect

    client, cluster = _connect("local:1")
    try:
        levels = client.run(lambda: logging.getLogger("distributed.worker").getEffectiveLevel())
    finally:
        client.close()
        cluster.close()
    assert list(levels.values()) == [logging.CRITICAL]


def test_kept_members_too_long_to_record_stop_the_sweep_before_it_runs(tmp_path, capsys):
    """Found in review: --keep recorded its members after the whole sweep had run, so a
    horizon too long to record was refused only then."""
    from mfcontrol.cli import main

    out = tmp_path / "s"
    rc = main(["sweep", "voltage-stable-standard", "--grid", "plant.dR=0,5", "--set",
               "sim.t_end=100", "--keep", "1", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and "sim.t_end = 100.0" in messages(err)[0] and len(messages(err)) == 1
    assert not list(out.glob("chunks/*.parquet"))


def test_the_api_sweep_checks_its_kept_members_and_its_size_first():
    plant = mfcontrol.FirstOrder(a=-1.0, b=1.0)
    ctrl = mfcontrol.IP(alpha=1.0, kp=2.0, sample_time=1e-3)
    with pytest.raises(mfcontrol.ConfigError, match=r"^t_end = 50000.0: 50,000,000 samples"):
        mfcontrol.sweep(plant, ctrl, 1.0, grid={"controller.kp": [1.0, 2.0]}, t_end=5e4,
                        keep=1)
    big = np.linspace(1.0, 2.0, 4000)
    with pytest.raises(mfcontrol.ConfigError, match=r"16,000,000 members: at most"):
        mfcontrol.sweep(plant, ctrl, 1.0, grid={"controller.kp": big, "plant.a": -big},
                        t_end=1.0)


def _damaged_copy(src, dst):
    """dst: a copy of the finished sweep folder src without its results."""
    import shutil

    shutil.copytree(src, dst)
    (dst / "results.parquet").unlink()
    return dst / "chunks"


def test_a_damaged_sweep_folder_is_recomputed_where_damaged_and_never_mixed(tmp_path):
    import pyarrow.parquet as pq

    args = ["voltage-stable-standard", *GRID, *FAST, "--chunk", "2"]
    sweep(*args, "--out", str(tmp_path / "whole"))
    whole = pd.read_parquet(tmp_path / "whole" / "results.parquet")
    # another sweep of the same shape (the same grid, another horizon): its chunk 4 fits
    sweep("voltage-stable-standard", *GRID, "--set", "sim.t_end=0.003", "--chunk", "2",
          "--out", str(tmp_path / "other"))
    chunks = _damaged_copy(tmp_path / "whole", tmp_path / "d")
    name = "chunk-{:06d}.parquet".format
    data = (chunks / name(0)).read_bytes()
    (chunks / name(0)).write_bytes(data[: len(data) // 2])  # cut short (a full disk)
    (chunks / name(1)).write_bytes(b"")  # empty
    (chunks / name(2)).write_bytes(b"PAR1 not a parquet file at all")  # garbage
    table = pq.read_table(chunks / name(3))  # this sweep's mark, one row too few
    pq.write_table(table.slice(0, 1), chunks / name(3))
    (chunks / name(4)).write_bytes((tmp_path / "other" / "chunks" / name(4)).read_bytes())
    (chunks / ".chunk-000005.parquet.4242.tmp").write_bytes(b"left by kill -9")
    (tmp_path / "d" / ".sweep.json.4242.tmp").write_text("{")
    proc = sweep(*args, "--out", str(tmp_path / "d"))
    said = "\n".join(messages(proc.stderr))
    for i, why in [(0, "is unreadable"), (1, "is unreadable"), (2, "is unreadable"),
                   (3, "holds 1 row, not members 6 to 7"), (4, "is not this sweep's")]:
        assert f"{name(i)} {why}" in said, said
    assert name(5) not in said  # intact: skipped
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "d" / "results.parquet"), whole)
    assert not list((tmp_path / "d").rglob("*.tmp"))


def test_a_folder_where_a_chunk_belongs_is_one_line(tmp_path):
    args = ["voltage-stable-standard", *GRID, *FAST, "--chunk", "2"]
    sweep(*args, "--out", str(tmp_path / "whole"))
    chunks = _damaged_copy(tmp_path / "whole", tmp_path / "d")
    (chunks / "chunk-000001.parquet").unlink()
    (chunks / "chunk-000001.parquet").mkdir()
    proc = sweep(*args, "--out", str(tmp_path / "d"), check=False)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert len(messages(proc.stderr)) == 1
    assert "chunk-000001.parquet): remove it to resume" in proc.stderr


def test_a_deeply_nested_sweep_json_is_one_line(tmp_path):
    out = tmp_path / "s"
    out.mkdir()
    (out / "sweep.json").write_text("[" * 100_000 + "]" * 100_000)
    proc = sweep("voltage-stable-standard", *GRID, *FAST, "--out", str(out), check=False)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "sweep.json that is not a sweep's" in proc.stderr
