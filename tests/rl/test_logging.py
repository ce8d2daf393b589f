"""Training loggers: the registry, offline W&B with the run's config, and name checks."""

import csv
import json
import time
from pathlib import Path

import pytest

from dyncatch.rl.logging import LOGGERS, MetricLog, validate_loggers

HEADER = {"method": "sp_rl", "behavior": "reactive", "seed": 3, "ppo": {"num_envs": 8}}


def wandb_records(run_dir: Path) -> list:
    """The protobuf records of an offline W&B run (``run-*.wandb``: a ``:W&B`` header, then
    LevelDB-log chunks of 7-byte headers: crc32 (4), length (2, little-endian), type (1);
    blocks of 32 KiB, a block's tail shorter than a header is padding)."""
    from wandb.proto.wandb_internal_pb2 import Record

    (path,) = run_dir.glob("run-*.wandb")
    data, block = path.read_bytes(), 32768
    assert data[:4] == b":W&B"
    pos, chunks, records = 7, b"", []
    while pos + 7 <= len(data):
        if block - pos % block < 7:
            pos += block - pos % block
            continue
        length, kind = int.from_bytes(data[pos + 4 : pos + 6], "little"), data[pos + 6]
        chunks += data[pos + 7 : pos + 7 + length]
        pos += 7 + length
        if kind in (1, 4):  # a full record, or the last chunk of one
            records.append(Record.FromString(chunks))
            chunks = b""
    return records


def finished_records(run_dir: Path, timeout_s: float = 20.0) -> list:
    """The records once the run's ``exit`` record is on disk (W&B's service process writes
    the file after ``finish`` returns)."""
    deadline = time.monotonic() + timeout_s
    while True:
        records = wandb_records(run_dir)
        if any(r.WhichOneof("record_type") == "exit" for r in records):
            return records
        assert time.monotonic() < deadline, f"{run_dir}: no exit record after {timeout_s} s"
        time.sleep(0.1)


def wandb_config(run_dir: Path) -> dict:
    """``wandb.config`` as recorded, without W&B's own ``_wandb`` entry."""
    (run,) = [r.run for r in finished_records(run_dir) if r.WhichOneof("record_type") == "run"]
    config = {item.key: json.loads(item.value_json) for item in run.config.update}
    return {k: v for k, v in config.items() if k != "_wandb"}


def wandb_history(run_dir: Path) -> list[dict]:
    records = finished_records(run_dir)
    rows = [r.history for r in records if r.WhichOneof("record_type") == "history"]
    return [
        {i.key or "/".join(i.nested_key): json.loads(i.value_json) for i in h.item} for h in rows
    ]


def test_wandb_runs_offline_with_the_run_config(tmp_path, monkeypatch):
    monkeypatch.delenv("WANDB_MODE", raising=False)
    log = MetricLog(tmp_path, 0, ("csv", "wandb"), HEADER)
    log.write(1, 64, {"reward_per_step": 0.25, "eval/success_rate": ""})
    log.write(2, 128, {"reward_per_step": 0.5, "eval/success_rate": 0.75})
    log.close()
    (run_dir,) = (tmp_path / "wandb").glob("offline-run-*")
    assert wandb_config(run_dir) == HEADER
    history = [
        {k: v for k, v in row.items() if not k.startswith("_") or k == "_step"}
        for row in wandb_history(run_dir)
    ]
    assert history == [
        {"_step": 64, "iteration": 1, "reward_per_step": 0.25},
        {"_step": 128, "iteration": 2, "reward_per_step": 0.5, "eval/success_rate": 0.75},
    ]
    # The other chosen logger writes as before; an unchosen one writes nothing.
    with (tmp_path / "metrics.csv").open() as f:
        assert [r["reward_per_step"] for r in csv.DictReader(f)] == ["0.25", "0.5"]
    assert not (tmp_path / "tb").exists()


def test_a_configured_wandb_mode_is_respected(tmp_path, monkeypatch):
    monkeypatch.setenv("WANDB_MODE", "disabled")
    log = MetricLog(tmp_path, 0, ("wandb",), HEADER)
    log.write(1, 64, {"reward_per_step": 0.25})
    log.close()
    assert not list(tmp_path.glob("wandb/offline-run-*"))


def test_logger_names_are_checked_with_the_choices():
    assert validate_loggers(["tensorboard", "csv"]) == ("tensorboard", "csv")
    for bad in (["mlflow"], [], ["csv", "csv"]):
        with pytest.raises(ValueError, match="--logger") as err:
            validate_loggers(bad)
        assert all(name in str(err.value) for name in LOGGERS)


def test_csv_resume_drops_rows_past_the_checkpoint_and_keeps_the_clock(tmp_path):
    log = MetricLog(tmp_path, 0, ("csv",))
    for it in (1, 2, 3):
        log.write(it, 64 * it, {"time_s": 10.0 * it})
    log.close()
    log = MetricLog(tmp_path, 2, ("csv", "tensorboard"))
    assert log.last("time_s") == 20.0
    log.close()
    with (tmp_path / "metrics.csv").open() as f:
        assert [int(r["iteration"]) for r in csv.DictReader(f)] == [1, 2]
    assert MetricLog(tmp_path / "x", 0, ("tensorboard",)).last("time_s", -1.0) == -1.0


def test_a_resume_without_csv_cuts_an_earlier_metrics_csv_to_the_checkpoint(tmp_path):
    from dyncatch.rl.logging import MetricLog

    log = MetricLog(tmp_path, 0, ("csv",))
    for it in (1, 2, 3):
        log.write(it, 64 * it, {"loss": 0.5})
    log.close()
    MetricLog(tmp_path, 2, ("tensorboard",)).close()
    rows = (tmp_path / "metrics.csv").read_text().splitlines()
    assert [r.split(",")[0] for r in rows[1:]] == ["1", "2"]
