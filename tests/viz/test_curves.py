"""Learning curves: the plotted lines are the CSV's numbers; ``dyncatch plot`` on real runs."""

import numpy as np
import pytest

from dyncatch.cli.main import main
from dyncatch.reproduce.presentation import method_labels
from dyncatch.viz.curves import plot_runs
from tests.cli.test_train_cli import TINY

CSV = """iteration,env_steps,reward_per_step,eval/success_rate
1,64,0.5,0.25
2,128,0.75,
3,192,-0.125,0.5
"""


def _run(folder, text=CSV):
    folder.mkdir(parents=True)
    (folder / "metrics.csv").write_text(text)
    return folder


def _lines(ax):
    return {line.get_label(): (line.get_xdata(), line.get_ydata()) for line in ax.get_lines()}


def test_the_plotted_lines_are_the_csv_values(tmp_path):
    a = _run(tmp_path / "a" / "run")
    b = _run(tmp_path / "b" / "run", CSV.replace("0.75", "1.5"))
    fig = plot_runs([a, b], ["reward_per_step", "eval/success_rate"])
    reward, success = fig.axes
    assert [reward.get_title(), success.get_title()] == ["reward_per_step", "eval/success_rate"]
    # Two folders named "run": their parents tell them apart.
    lines = _lines(reward)
    assert list(lines) == ["a/run", "b/run"]
    np.testing.assert_array_equal(lines["a/run"][0], [64, 128, 192])
    np.testing.assert_array_equal(lines["a/run"][1], [0.5, 0.75, -0.125])
    np.testing.assert_array_equal(lines["b/run"][1], [0.5, 1.5, -0.125])
    # The evaluation is drawn through the iterations that measured it.
    x, y = _lines(success)["a/run"]
    np.testing.assert_array_equal(x, [64, 192])
    np.testing.assert_array_equal(y, [0.25, 0.5])


def test_bad_runs_and_metrics_are_one_line_errors(tmp_path, capsys):
    run = _run(tmp_path / "run")
    empty = tmp_path / "empty"
    empty.mkdir()
    cases = [
        (["plot", str(run), "--metrics", "catches"], "no column catches"),
        (["plot", str(run), "--metrics", "catches"], "from iteration, reward_per_step, eval/succ"),
        (["plot", str(empty)], "--logger csv"),
    ]
    for argv, needle in cases:
        capsys.readouterr()
        assert main([*argv, "--out", str(tmp_path / "c.png")]) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and needle in err, (argv, err)
    assert not (tmp_path / "c.png").exists()


@pytest.mark.extended  # trains two runs; test_the_plotted_lines_are_the_csv_values covers plotting
def test_plot_two_trained_runs(tmp_path):
    runs = []
    for seed in (0, 1):
        out = tmp_path / f"seed{seed}"
        argv = ["train", "--method", "rl", "--out", str(out), "--seed", str(seed), *TINY]
        # No evaluation: one compilation, the one tests/cli/test_train_cli.py's runs share.
        assert main([*argv, "--total-steps", "128", "--eval-every", "0"]) == 0
        runs.append(out)
    png = tmp_path / "plots" / "curves.png"
    assert main(["plot", *map(str, runs), "--out", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    fig = plot_runs(runs, ["reward_per_step", "eval/success_rate"], method_labels())
    lines = _lines(fig.axes[0])
    assert list(lines) == ["seed0 (RL)", "seed1 (RL)"]
    np.testing.assert_array_equal(lines["seed0 (RL)"][0], [64, 128])
    assert not np.array_equal(lines["seed0 (RL)"][1], lines["seed1 (RL)"][1])  # two seeds
    # A run never evaluated draws an empty line, not zeros.
    assert len(_lines(fig.axes[1])["seed1 (RL)"][0]) == 0
