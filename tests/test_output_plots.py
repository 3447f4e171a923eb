"""Every output drawn: each output of a model in its own axes, with its unit, band and domain marks.

The figures of ``validate --plot``, ``simulate --plot`` and ``compare --plot`` on a two-output
model (the 3-D neck's tilt vector ``tilt_x``, ``tilt_y``): how many axes, and which line sits on
which axes. The figure is caught where the command saves it (``neckid.cli.explain._save_figure``).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest
from typer.testing import CliRunner

from neckid import IOData, Lags, LinearARX
from neckid.cli import app
from neckid.report.plots import plot_outputs

runner = CliRunner()
TS = 0.02


def _tilt_log(rng: np.random.Generator, n: int = 500, gain: float = 1.0) -> IOData:
    """Two coupled first-order outputs [deg] from two motor inputs [rad]; tilt_y ≠ tilt_x."""
    u = gain * np.repeat(rng.uniform(-1.0, 1.0, (n // 20, 2)), 20, axis=0)
    y = np.zeros((n, 2))
    for t in range(1, n):
        y[t, 0] = 0.9 * y[t - 1, 0] + 0.8 * u[t - 1, 0]
        y[t, 1] = 0.7 * y[t - 1, 1] - 0.5 * u[t - 1, 1] + 3.0
    return IOData(
        u,
        y + rng.normal(0.0, 0.01, y.shape),
        ts=TS,
        input_names=["motor_1", "motor_2"],
        output_names=["tilt_x", "tilt_y"],
        input_units=["rad", "rad"],
        output_units=["deg", "deg"],
    )


def _lines(ax) -> dict[str, np.ndarray]:
    return {line.get_label(): np.asarray(line.get_ydata(), dtype=float) for line in ax.lines}


@pytest.fixture
def two_outputs(rng):
    data = _tilt_log(rng)
    model = LinearARX(Lags.arx(1, 1, 1)).fit(data)
    return data, model, model.simulate(data)


def test_each_output_has_its_axes_its_unit_and_its_own_lines(two_outputs) -> None:
    data, _, result = two_outputs
    fig = plot_outputs(data, {"arx": result})
    assert len(fig.axes) == 2
    for j, ax in enumerate(fig.axes):
        lines = _lines(ax)
        np.testing.assert_array_equal(lines["measured"], data.y[:, j])
        np.testing.assert_array_equal(lines["arx"], result.y[:, j])
        assert ax.get_ylabel() == f"{data.output_names[j]} [deg]"
    # the two outputs differ: a figure that drew tilt_x twice would fail above
    assert not np.allclose(data.y[:, 0], data.y[:, 1])
    assert fig.axes[-1].get_xlabel() == "time [s]"
    plt.close(fig)


def test_bands_and_domain_marks_sit_on_their_output(two_outputs) -> None:
    data, _, result = two_outputs
    width = np.array([0.5, 4.0])  # a narrow band on tilt_x, a wide one on tilt_y
    banded = dataclasses.replace(result, lower=result.y - width, upper=result.y + width)
    outside = np.zeros(data.n_samples, dtype=bool)
    outside[100:140] = True
    fig = plot_outputs(data, {"arx": banded}, outside=outside)
    for j, ax in enumerate(fig.axes):
        (band,) = ax.collections
        vertices = np.concatenate([p.vertices for p in band.get_paths()])
        top = float(vertices[:, 1].max())
        assert top == pytest.approx(float(np.max(banded.upper[1:, j])), rel=1e-9)
        marks = [line for line in ax.lines if line.get_marker() == "|"]
        assert len(marks) == 1
        np.testing.assert_array_equal(marks[0].get_xdata(), data.time[outside])
    plt.close(fig)


def test_with_errors_each_output_is_followed_by_its_own(two_outputs) -> None:
    data, _, result = two_outputs
    fig = plot_outputs(data, {"arx": result}, residuals=True)
    assert len(fig.axes) == 4
    for j in range(2):
        (error,) = fig.axes[2 * j + 1].lines[:1]
        np.testing.assert_allclose(
            error.get_ydata(), (data.y - result.y)[result.n_initial :, j], rtol=0, atol=0
        )
        assert fig.axes[2 * j + 1].get_ylabel() == "error y − ŷ [deg]"
    plt.close(fig)


def test_plot_outputs_refuses_axes_of_another_count(two_outputs) -> None:
    data, _, result = two_outputs
    fig, ax = plt.subplots()
    with pytest.raises(ValueError, match=r"one Axes per output \(2\); got 1"):
        plot_outputs(data, {"arx": result}, [ax])
    plt.close(fig)


# ---------------------------------------------------------------------------- the commands
@pytest.fixture
def saved(monkeypatch):
    """The figures the commands save, caught before they are closed."""
    figures: list = []
    import neckid.cli.explain as explain
    import neckid.cli.models as models

    def keep(fig, path):
        figures.append(fig)
        fig.savefig(path, format="png")  # the file is still written

    monkeypatch.setattr(explain, "_save_figure", keep)
    monkeypatch.setattr(models, "_save_figure", keep)
    yield figures
    for fig in figures:
        plt.close(fig)


def _files(rng, tmp_path: Path) -> tuple[Path, Path, Path]:
    train, test = tmp_path / "train.csv", tmp_path / "test.csv"
    _tilt_log(rng).to_csv(train)
    _tilt_log(rng).to_csv(test)
    model = tmp_path / "tilt.npz"
    arguments = ["identify", str(train), "--inputs", "motor_1,motor_2"]
    arguments += ["--outputs", "tilt_x,tilt_y", "--method", "arx", "--orders", "1,1,1"]
    result = runner.invoke(app, [*arguments, "--save", str(model)])
    assert result.exit_code == 0, result.output
    return train, test, model


def _check_outputs(axes, log: Path) -> None:
    data = IOData.from_csv(log, ["motor_1", "motor_2"], ["tilt_x", "tilt_y"])
    for j, ax in enumerate(axes):
        np.testing.assert_allclose(_lines(ax)["measured"], data.y[:, j])
        assert ax.get_ylabel().startswith(data.output_names[j] + " [")


def test_validate_and_simulate_plot_every_output(rng, tmp_path, saved) -> None:
    train, test, model = _files(rng, tmp_path)
    one = runner.invoke(app, ["validate", str(model), str(test), "--plot", str(tmp_path / "a.png")])
    assert one.exit_code == 0, one.output
    (fig,) = saved
    assert len(fig.axes) == 4  # tilt_x, its errors, tilt_y, its errors
    _check_outputs(fig.axes[::2], test)
    assert "(tilt_x)" in fig.axes[0].get_title() and "(tilt_y)" in fig.axes[0].get_title()
    two = runner.invoke(
        app, ["validate", str(model), str(test), str(train), "--plot", str(tmp_path / "b.png")]
    )
    assert two.exit_code == 0, two.output
    assert len(saved[1].axes) == 4  # two logs, two outputs each
    _check_outputs(saved[1].axes[:2], test)
    _check_outputs(saved[1].axes[2:], train)
    arguments = ["simulate", str(model), str(test), "--out", str(tmp_path / "s.csv")]
    run = runner.invoke(app, [*arguments, "--plot", str(tmp_path / "s.png")])
    assert run.exit_code == 0, run.output
    assert len(saved[2].axes) == 4 and (tmp_path / "s.png").stat().st_size > 1000
    _check_outputs(saved[2].axes[::2], test)


def test_compare_plots_every_output_of_every_test_log(rng, tmp_path, saved) -> None:
    train, test, _ = _files(rng, tmp_path)
    other = tmp_path / "train2.csv"
    _tilt_log(rng).to_csv(other)
    arguments = ["compare", str(train), str(other), "--test", str(test), "--methods", "arx"]
    arguments += ["--inputs", "motor_1,motor_2", "--outputs", "tilt_x,tilt_y"]
    result = runner.invoke(app, [*arguments, "--plot", str(tmp_path / "c.png")])
    assert result.exit_code == 0, result.output
    (fig,) = saved
    assert len(fig.axes) == 2
    _check_outputs(fig.axes, test)
    assert {"measured", "arx"} <= set(_lines(fig.axes[1]))


def test_a_diverged_run_kept_is_drawn_up_to_where_it_leaves_the_plot(rng, tmp_path, saved) -> None:
    data = _tilt_log(rng)
    model = LinearARX(Lags.arx(1, 1, 1)).fit(data)
    model.coef_ = model.coef_.copy()
    model.coef_[0, 0] = 8.0  # tilt_x's own pole at 8: the free run overflows
    log = tmp_path / "run.csv"
    data.to_csv(log)
    path = model.save(tmp_path / "unstable.npz")
    arguments = ["simulate", str(path), str(log), "--out", str(tmp_path / "s.csv")]
    result = runner.invoke(app, [*arguments, "--keep-diverged", "--plot", str(tmp_path / "s.png")])
    assert result.exit_code == 3, result.output
    (fig,) = saved
    assert "diverged" in fig.axes[0].get_title()
    drawn = _lines(fig.axes[0])["Linear ARX"]
    span = np.ptp(data.y[:, 0])
    assert np.nanmax(np.abs(drawn)) <= np.max(np.abs(data.y[:, 0])) + 10 * span
    assert np.isnan(drawn[-1])  # beyond the plot: not drawn
    np.testing.assert_allclose(_lines(fig.axes[2])["measured"], data.y[:, 1])
